"""Abaqus keyword decks (``.inp``) read by femupdate itself: ``*NODE``, ``*ELEMENT`` (S4, S4R ->
mitc4; S3, S3R -> mitc3; C3D8, C3D8I -> hex8; C3D4 -> tet4; C3D10 -> tet10), ``*ELSET``,
``*NSET`` (with GENERATE), ``*MATERIAL`` with ``*ELASTIC`` and ``*DENSITY``, ``*SHELL SECTION``,
``*SOLID SECTION``, ``*BOUNDARY`` in the model data (fixed dofs), ``*KINEMATIC COUPLING`` and ``*MPC``
BEAM/TIE (exact constraints, :mod:`.abaqus_links`); ``*PART``s instanced once each
in an ``*ASSEMBLY`` (a translated ``*INSTANCE``) are flattened.  ``*HEADING`` and ``*PREPRINT`` are skipped; the history data from ``*STEP``
to ``*END STEP`` is skipped and listed; any other keyword (``*PART``, ``*BOUNDARY``, ...) is
refused, named with its line."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .._errors import InputError
from . import abaqus_links
from .core import DIRS, Block, Material, Mesh, Section, int_id

ELEMENT_TYPES = {"S4": "mitc4", "S4R": "mitc4", "S3": "mitc3", "S3R": "mitc3", "C3D8": "hex8", "C3D8I": "hex8",
                 "C3D4": "tet4", "C3D10": "tet10"}
_COUNT = {"mitc4": 4, "mitc3": 3, "hex8": 8, "tet4": 4, "tet10": 10}
_SKIP = {"HEADING", "PREPRINT"}


def _keywords(path: Path):
    """(keyword, options, data lines [(line no, fields)], line no) of a deck."""
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise InputError(f"{path}: no such file") from None
    except UnicodeDecodeError:
        raise InputError(f"{path}: not a text Abaqus input file") from None
    out: list = []
    pending: list[str] = []
    for no, raw in enumerate(text.splitlines(), start=1):
        line = raw.strip()
        if not line or line.startswith("**"):
            continue
        if line.startswith("*"):
            if pending and out:  # a data line that ended in a comma before this keyword (set lists may)
                out[-1][2].append((no - 1, pending))
            parts = [p.strip() for p in line[1:].split(",")]
            opts = {}
            for p in parts[1:]:
                if p:
                    k, _, v = p.partition("=")
                    opts[" ".join(k.upper().split())] = v.strip()
            out.append((" ".join(parts[0].upper().split()), opts, [], no))
            pending = []
            continue
        if not out:
            raise InputError(f"{path}: line {no}: data before the first keyword")
        fields = pending + [f.strip() for f in line.split(",")]
        if line.endswith(","):  # a data line continued on the next
            pending = fields[:-1]
            continue
        pending = []
        out[-1][2].append((no, fields))
    if pending and out:
        out[-1][2].append((no, pending))
    return out


def read_abaqus(path) -> Mesh:
    """The mesh, sets, materials and sections of an Abaqus input file (:mod:`femupdate.mesh.abaqus`)."""
    path = Path(path)
    mesh = Mesh(str(path), np.empty(0, np.int64), np.empty((0, 3)))
    nodes: list[int] = []
    coords: list[list[float]] = []
    elems: dict = {}
    names: dict[str, str] = {}  # case-folded set name -> as first written
    unknown: list[str] = []
    material = None
    in_step = None
    parts: dict = {"instances": [], "part_nodes": {}, "open": None}
    links: list = []
    for kw, opts, data, no in _keywords(path):
        where = f"{path}: *{kw} at line {no}"
        if in_step is not None:
            if kw == "END STEP":
                mesh.ignored.append(f"*STEP ... *END STEP (lines {in_step}-{no})")
                in_step = None
            continue
        if kw == "STEP":
            in_step = no
        elif kw in _PARTS:
            _part(kw, opts, data, where, parts, len(nodes))
        elif kw == "NODE":
            if "SYSTEM" in opts:
                raise InputError(f"{where}: SYSTEM = {opts['SYSTEM']} is not supported (rectangular coordinates only)")
            ids = []
            for ln, f in data:
                w = f"{path}: line {ln}"
                if len(f) < 3 or len(f) > 4:
                    raise InputError(f"{w}: a *NODE line is 'id, x, y[, z]', got {', '.join(f)}")
                ids.append(int_id(f[0], w))
                nodes.append(ids[-1])
                coords.append([_num(v, w) for v in f[1:]] + [0.0] * (4 - len(f)))
            if "NSET" in opts:
                _add_set(mesh.nsets, names, opts["NSET"], ids)
        elif kw == "ELEMENT":
            _element(path, opts, data, where, elems, mesh, names)
        elif kw in ("ELSET", "NSET"):
            sets = mesh.elsets if kw == "ELSET" else mesh.nsets
            name = opts.get(kw)
            if not name:
                raise InputError(f"{where}: needs {kw}=name")
            _add_set(sets, names, name, _set_members(path, data, opts, sets, kw))
        elif kw == "MATERIAL":
            material = Material(opts.get("NAME", ""))
            if not material.name:
                raise InputError(f"{where}: needs NAME=")
            mesh.materials[material.name.upper()] = material
        elif kw in ("ELASTIC", "DENSITY"):
            if material is None:
                raise InputError(f"{where}: outside a *MATERIAL")
            if kw == "ELASTIC" and opts.get("TYPE", "ISOTROPIC").upper() != "ISOTROPIC":
                raise InputError(f"{where}: TYPE={opts['TYPE']}: only isotropic elasticity is read")
            if len(data) != 1:
                raise InputError(f"{where}: one data line expected (temperature-dependent data is not read)")
            f = [_num(v, f"{path}: line {data[0][0]}") for v in data[0][1] if v != ""]
            if kw == "ELASTIC":
                material.E, material.nu = f[0], f[1]
            else:
                material.rho = f[0]
        elif kw in ("SHELL SECTION", "SOLID SECTION"):
            if "ELSET" not in opts or "MATERIAL" not in opts:
                raise InputError(f"{where}: needs ELSET= and MATERIAL=")
            t = None
            if kw == "SHELL SECTION":
                if not data or not data[0][1][0]:
                    raise InputError(f"{where}: the thickness line is missing")
                t = _num(data[0][1][0], f"{path}: line {data[0][0]}")
            mesh.sections.append(Section(opts["ELSET"], opts["MATERIAL"].upper(), t, where))
        elif kw == "BOUNDARY":
            _boundary(path, opts, data, where, mesh)
        elif kw == "KINEMATIC COUPLING":
            abaqus_links.kinematic_coupling(path, opts, data, where, links)
        elif kw == "MPC":
            abaqus_links.mpc(path, opts, data, where, links)
        elif kw in _SKIP:
            continue
        else:
            unknown.append(f"*{kw} (line {no})")
    if unknown:
        more = f" and {len(unknown) - 10} more" if len(unknown) > 10 else ""
        raise InputError(f"{path}: keyword(s) femupdate does not read: {', '.join(unknown[:10])}{more}")
    if not nodes:
        raise InputError(f"{path}: no *NODE data")
    mesh.node_ids, mesh.xyz = np.array(nodes, np.int64), np.array(coords, dtype=float)
    for name, shift in parts["instances"]:  # one instance of each part: its nodes moved by its translation
        if name.casefold() not in parts["part_nodes"] and np.any(shift != 0):
            raise InputError(f"{path}: the instance of part {name!r} is translated, but no *PART {name} ... *END PART "
                             "defines its nodes")
        lo, hi = parts["part_nodes"].get(name.casefold(), (0, 0))
        mesh.xyz[lo:hi] += shift
    for (type_, src), (ids, conn) in elems.items():
        mesh.blocks.append(Block(type_, np.array(ids, np.int64), np.array(conn, np.int64), src))
    abaqus_links.resolve(mesh, links)
    return mesh.check()


_PARTS = {"PART", "END PART", "ASSEMBLY", "END ASSEMBLY", "INSTANCE", "END INSTANCE"}


def _part(kw, opts, data, where, parts, n_nodes) -> None:
    """``*PART`` ... ``*END PART`` and their ``*INSTANCE`` in an ``*ASSEMBLY``, flattened: each part
    instanced once, moved by a translation (a rotation is refused); ids as the part writes them."""
    if kw == "PART":
        parts["open"] = (opts.get("NAME", ""), n_nodes)
    elif kw == "END PART" and parts["open"] is not None:
        name, lo = parts["open"]
        parts["part_nodes"][name.casefold()] = (lo, n_nodes)
        parts["open"] = None
    elif kw == "INSTANCE":
        part = opts.get("PART", "")
        if any(p.casefold() == part.casefold() for p, _ in parts["instances"]):
            raise InputError(f"{where}: part {part!r} instanced twice; femupdate flattens one instance of each part "
                             "(two would repeat its node and element ids)")
        if len(data) > 1:
            raise InputError(f"{where}: instance {opts.get('NAME', '')!r} is rotated; femupdate flattens translated "
                             "instances only")
        shift = np.zeros(3)
        if data:
            f = [v for v in data[0][1] if v != ""]
            shift[:len(f)] = [_num(v, f"{where.rsplit(' at ', 1)[0]} at line {data[0][0]}") for v in f[:3]]
        parts["instances"].append((part, shift))


_NAMED = {"ENCASTRE": "123456", "PINNED": "123"}


def _boundary(path, opts, data, where, mesh) -> None:
    """``*BOUNDARY`` in the model data: ``node or set, first dof[, last dof[, 0]]``, ENCASTRE, PINNED."""
    if opts:
        raise InputError(f"{where}: options {', '.join(opts)} are not read (fixed dofs only)")
    for ln, f in data:
        w = f"{path}: line {ln}"
        f = [v for v in f if v != ""]
        if len(f) < 2 or len(f) > 4 or (len(f) == 4 and _num(f[3], w) != 0):
            raise InputError(f"{w}: *BOUNDARY reads 'node or set, first dof[, last dof]' (zero), ENCASTRE or PINNED; "
                             f"got {', '.join(f)}")
        named = _NAMED.get(f[1].upper())
        if named is None:
            a = int_id(f[1], w)
            b = int_id(f[2], w) if len(f) > 2 else a
            if not 1 <= a <= b <= 6:
                raise InputError(f"{w}: dofs {a} to {b}: Abaqus dofs are 1 to 6")
            named = "".join(str(k) for k in range(a, b + 1))
        target = f[0]
        nodes = [int(target)] if target.lstrip("-").isdigit() else None
        mesh.supports.append({"nodes": nodes, "set": target if nodes is None else None,
                              "dofs": [DIRS[c] for c in named], "where": w})


def _num(text: str, where: str) -> float:
    try:
        return float(text.replace("d", "e").replace("D", "E"))
    except ValueError:
        raise InputError(f"{where}: {text!r} is not a number") from None


def _add_set(sets: dict, names: dict, name: str, ids) -> None:
    key = names.setdefault(name.casefold(), name)
    prev = sets.get(key, np.empty(0, np.int64))
    sets[key] = np.concatenate([prev, np.asarray(ids, np.int64)])


def _set_members(path, data, opts, sets, kw) -> list[int]:
    ids: list[int] = []
    generate = any(k == "GENERATE" for k in opts)
    for ln, f in data:
        w = f"{path}: line {ln}"
        f = [v for v in f if v != ""]
        if generate:
            a, b, *s = (int_id(v, w) for v in f)
            ids.extend(range(a, b + 1, s[0] if s else 1))
            continue
        for v in f:
            if v.lstrip("-").isdigit():
                ids.append(int(v))
            else:
                hit = [k for k in sets if k.casefold() == v.casefold()]
                if not hit:
                    raise InputError(f"{w}: *{kw} names {v!r}, which is neither an id nor a set defined before")
                ids.extend(sets[hit[0]].tolist())
    return ids


def _element(path, opts, data, where, elems, mesh, names) -> None:
    src = opts.get("TYPE", "")
    type_ = ELEMENT_TYPES.get(src.upper())
    if type_ is None:
        raise InputError(f"{where}: element type {src or '(none)'!r} is not supported (femupdate reads "
                         f"{', '.join(ELEMENT_TYPES)})")
    n = _COUNT[type_]
    ids, conn = elems.setdefault((type_, src), ([], []))
    mine = []
    for ln, f in data:
        w = f"{path}: line {ln}"
        f = [v for v in f if v != ""]
        if len(f) != n + 1:
            raise InputError(f"{w}: a {src} element lists {n} nodes, got {len(f) - 1} ({', '.join(f)})")
        mine.append(int_id(f[0], w))
        conn.append([int_id(v, w) for v in f[1:]])
    ids.extend(mine)
    if "ELSET" in opts:
        _add_set(mesh.elsets, names, opts["ELSET"], mine)


__all__ = ["read_abaqus", "ELEMENT_TYPES"]
