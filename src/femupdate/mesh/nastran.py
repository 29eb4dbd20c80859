"""Nastran bulk data read by femupdate itself: GRID, CQUAD4, CTRIA3, CHEXA (8 nodes), CTETRA (4
and 10 nodes), PSHELL, PSOLID, MAT1, SPC1 (one set), CORD2R/C/S (GRID positions), and (in
:mod:`.nastran_cards`) CBAR/CBEAM with PBAR/PBEAM, CELAS1/CELAS2 with PELAS, CONM2 and RBE2, in
small-field, large-field and free-field format, with continuations and INCLUDE.  Each property id becomes an element set named by the id (``"1"``).
Executive and case control before ``BEGIN BULK`` are skipped; ``PARAM``, ``EIGRL`` and ``EIGR``
are skipped and listed; any other card is refused, named with its line."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from .._errors import InputError
from . import nastran_cards as nc
from .core import DIRS, Block, Material, Mesh, Section, int_id

_SKIPPED = {"PARAM", "EIGRL", "EIGR"}
_FRAMES = ("CBAR", "CBEAM")
_READ = ("GRID, CQUAD4, CTRIA3, CHEXA, CTETRA, CBAR, CBEAM, CELAS1, CELAS2, CONM2, RBE2, PSHELL, PSOLID, PBAR, PBEAM, "
         "PELAS, MAT1, SPC1, CORD2R/C/S")
_ELEMENTS = {"CQUAD4": ("mitc4", (4,)), "CTRIA3": ("mitc3", (3,)), "CHEXA": ("hex8", (8,)), "CTETRA": (None, (4, 10))}
_REAL = re.compile(r"^([+-]?(?:\d+\.?\d*|\.\d+))([+-]\d+)$")  # Nastran's 1.-3 for 1.e-3


def real(text: str, what: str) -> float:
    """A Nastran real field (``1.5e3``, ``1.5+3``, ``1.5D3``), refused naming the field."""
    try:
        return float(text)  # the common case, first
    except ValueError:
        pass
    s = text.strip().upper().replace("D", "E")
    try:
        return float(s)
    except ValueError:
        m = _REAL.match(s)
        if m:
            return float(f"{m.group(1)}e{m.group(2)}")
    raise InputError(f"{what}: {text.strip()!r} is not a number")


def _fields(line: str) -> tuple[str, list[str], bool]:
    """(first field, data fields, large-field) of one physical line."""
    if "," in line:
        parts = [p.strip() for p in line.split(",")]
        large = parts[0].endswith("*") or parts[0].startswith("*")
        per = 4 if large else 8
        data = parts[1:]
        if len(data) == per + 1 and data[-1][:1] in ("+", "*", ""):
            data = data[:-1]  # the continuation field
        return parts[0], data, large
    head = line[:8].strip()
    large = head.endswith("*") or head.startswith("*")  # a large-field card or its continuation
    width = 16 if large else 8
    body = line[8:72]
    return head, [body[i:i + width].strip() for i in range(0, 64, width)], large


def _lines(path: Path, seen: set):
    """(file, line number, text) of a deck and its INCLUDE files, comments removed."""
    if path.resolve() in seen:
        raise InputError(f"{path}: INCLUDE of itself")
    seen = seen | {path.resolve()}
    try:
        text = path.read_text(encoding="utf-8", errors="strict")
    except FileNotFoundError:
        raise InputError(f"{path}: no such file") from None
    except UnicodeDecodeError:
        raise InputError(f"{path}: not a text bulk-data file") from None
    for no, raw in enumerate(text.splitlines(), start=1):
        line = (raw.split("$", 1)[0] if "$" in raw else raw).rstrip()
        if "\t" in line:
            line = line.expandtabs(8)
        if not line.strip():
            continue
        if line[:1] in "Ii" and line.upper().startswith("INCLUDE"):
            name = line[7:].strip().strip("'\"")
            yield from _lines(path.parent / name, seen)
            continue
        yield path, no, line


def cards(path) -> list[tuple[str, list[str], str]]:
    """The bulk-data cards of a deck: (name, fields after the name, 'file:line') in order."""
    path = Path(path)
    lines = list(_lines(path, set()))
    begin = next((i for i, (_, _, l) in enumerate(lines) if l.strip().upper().startswith("BEGIN BULK")), None)
    if begin is not None:
        lines = lines[begin + 1:]
    out: list[tuple[str, list[str], str]] = []
    width = 8
    last, fname = None, ""
    for f, no, line in lines:
        if line[:1] in "Ee " and line.strip().upper().startswith("ENDDATA"):
            break
        head, data, large = _fields(line)
        if head[:1] in ("+", "*") or (head == "" and out):
            if not out:
                raise InputError(f"{f}:{no}: a continuation line before any card")
            prev = out[-1][1]
            prev.extend([""] * (-len(prev) % width))  # a short free-field line: its blank fields
            prev.extend(data)
            width = 4 if large else 8
            continue
        width = 4 if large else 8
        if f is not last:
            last, fname = f, f.name
        out.append((head.rstrip("*").upper(), data, f"{fname}:{no}"))
    for _, data, _ in out:
        while data and data[-1] == "":
            data.pop()
    return out


def _field(data, i, default=""):
    return data[i] if i < len(data) and data[i] != "" else default


def read_nastran(path) -> Mesh:
    """The mesh, properties and materials of a Nastran bulk-data deck (:mod:`femupdate.mesh.nastran`)."""
    path = Path(path)
    nodes: list[int] = []
    coords: list[list[float]] = []
    elems: dict[tuple, tuple[list, list, list, str]] = {}
    mesh = Mesh(str(path), np.empty(0, np.int64), np.empty((0, 3)))
    unknown: list[str] = []
    cps: list[tuple[int, str]] = []
    cords: dict[int, tuple] = {}
    frames: dict[str, dict] = {}
    pelas: dict[int, float] = {}
    coupled = False
    for name, d, at in cards(path):
        if _quick(name, d, nodes, coords, cps, elems):
            continue
        where = f"{path}: {name} at {at}"
        if name == "GRID":
            gid = int_id(_field(d, 0), where)
            if _field(d, 5, "0") != "0":
                raise InputError(f"{where}: GRID {gid} has displacement coordinate system CD = {d[5]}; femupdate's dofs "
                                 "are in basic axes (CD blank or 0; CP, the position's system, may be a CORD2R/C/S)")
            cps.append((int_id(_field(d, 1, "0"), where), where))
            if _field(d, 6):
                raise InputError(f"{where}: GRID {gid} has permanent constraints PS = {d[6]}, which are not read: "
                                 "remove them and give supports in the model file's [[mesh.support]]")
            nodes.append(gid)
            coords.append([real(_field(d, k, "0"), where) for k in (2, 3, 4)])
        elif name in _ELEMENTS:
            _element(name, d, where, elems)
        elif name in ("CORD2R", "CORD2C", "CORD2S"):
            cid = int_id(_field(d, 0), where)
            if cid in cords:
                raise InputError(f"{where}: coordinate system {cid} defined twice")
            cords[cid] = (name[-1], int_id(_field(d, 1, "0"), where), [real(_field(d, k, "0"), where) for k in range(2, 11)], where)
        elif name == "PSHELL":
            _pshell(d, where, mesh)
        elif name == "PSOLID":
            pid, mid = int_id(_field(d, 0), where), int_id(_field(d, 1), where)
            mesh.sections.append(Section(str(pid), str(mid), None, where))
        elif name == "MAT1":
            _mat1(d, where, mesh)
        elif name == "SPC1":
            _spc1(d, where, mesh)
        elif name in _FRAMES:
            nc.frame_card(name, d, where, frames)
        elif name == "PBAR":
            nc.pbar(d, where, mesh)
        elif name == "PBEAM":
            nc.pbeam(d, where, mesh)
        elif name in ("CELAS1", "CELAS2"):
            nc.celas(name, d, where, mesh, pelas)
        elif name == "PELAS":
            nc.pelas_card(d, where, mesh, pelas)
        elif name == "CONM2":
            nc.conm2(d, where, mesh, cords)
        elif name == "RBE2":
            nc.rbe2(d, where, mesh)
        elif name in _SKIPPED:
            if name == "PARAM" and _field(d, 0).upper() == "COUPMASS":
                coupled = real(_field(d, 1, "-1"), where) > 0
            mesh.ignored.append(f"{name} ({at})")
        else:
            unknown.append(f"{name} ({at})")
    if unknown:
        more = f" and {len(unknown) - 10} more" if len(unknown) > 10 else ""
        raise InputError(f"{path}: card(s) femupdate does not read: {', '.join(unknown[:10])}{more} (it reads {_READ}; "
                         "PARAM, EIGRL and EIGR are skipped)")
    if not nodes:
        raise InputError(f"{path}: no GRID cards")
    mesh.node_ids, mesh.xyz = np.array(nodes, np.int64), np.array(coords, dtype=float)
    for k, (cp, where) in enumerate(cps):
        if cp != 0:
            mesh.xyz[k] = to_basic(cp, mesh.xyz[k], cords, where)
    _frames_and_masses(mesh, frames, pelas)
    if frames and not coupled:
        mesh.ignored.append("Nastran's default lumped mass of CBAR/CBEAM (no PARAM COUPMASS > 0): femupdate gives "
                            "them their coupled (consistent) mass, as COUPMASS 1 does")
    for (type_, card), (ids, pids, conn, _) in elems.items():
        ids_a, pids_a = np.array(ids, np.int64), np.array(pids, np.int64)
        mesh.blocks.append(Block(type_, ids_a, np.array(conn, np.int64), card))
        for p in np.unique(pids_a):
            prev = mesh.elsets.get(str(p), np.empty(0, np.int64))
            mesh.elsets[str(p)] = np.concatenate([prev, ids_a[pids_a == p]])
    return mesh.check()


def _quick(name: str, d: list, nodes: list, coords: list, cps: list, elems: dict) -> bool:
    """Read a plain GRID (no CP, CD or PS; plain numbers) or an 8-node CHEXA with its property id
    the quick way; False for any other card or form (the full reading then names any problem)."""
    if name == "GRID" and 3 <= len(d) <= 5 and d[1] in ("", "0"):
        try:
            xyz = [float(d[k]) if k < len(d) and d[k] else 0.0 for k in (2, 3, 4)]
            nodes.append(int(d[0]))
        except ValueError:
            return False
        coords.append(xyz)
        cps.append((0, ""))
        return True
    if name == "CHEXA" and len(d) == 10 and d[1]:
        try:
            row = [int(x) for x in d]
        except ValueError:
            return False
        ids, pids, conn, _ = elems.setdefault(("hex8", "CHEXA"), ([], [], [], "CHEXA"))
        ids.append(row[0])
        pids.append(row[1])
        conn.append(row[2:])
        return True
    return False


def _frames_and_masses(mesh: Mesh, frames: dict, pelas: dict) -> None:
    """CBAR/CBEAM blocks (orientations from G0 resolved), CELAS1 stiffness, CONM2 absolute offsets."""
    row = {int(n): k for k, n in enumerate(mesh.node_ids)}

    def xyz_of(n):
        return mesh.xyz[row[int(n)]]

    for name, f in frames.items():
        ids, pids = np.array(f["ids"], np.int64), np.array(f["pids"], np.int64)
        offsets = np.array(f["offsets"])
        mesh.blocks.append(Block("frame3d", ids, np.array(f["conn"], np.int64), name,
                                 orientation=nc.frame_orientations(f, xyz_of),
                                 offsets=offsets if np.any(offsets != 0) else None))
        for p in np.unique(pids):
            prev = mesh.elsets.get(str(p), np.empty(0, np.int64))
            mesh.elsets[str(p)] = np.concatenate([prev, ids[pids == p]])
    nc.resolve_springs(mesh, pelas)
    for m in mesh.masses:
        if m.pop("absolute"):
            if int(m["node"]) not in row:
                raise InputError(f"{m['where']}: grid {m['node']} is not defined")
            m["offset"] = m["offset"] - xyz_of(m["node"])


def to_basic(cid: int, x, cords: dict, where: str, seen: tuple = ()) -> np.ndarray:
    """A point given in coordinate system ``cid`` (CORD2R: x, y, z; CORD2C: r, theta deg, z; CORD2S: r,
    theta deg, phi deg) in basic coordinates; its defining points A, B, C may be in another system (RID)."""
    if cid not in cords:
        raise InputError(f"{where}: coordinate system {cid} is not defined (femupdate reads CORD2R, CORD2C, CORD2S)")
    if cid in seen:
        raise InputError(f"{where}: coordinate systems {' -> '.join(map(str, seen + (cid,)))} refer to each other")
    kind, rid, abc, at = cords[cid]
    a, b, c = (np.array(abc[i:i + 3]) for i in (0, 3, 6))
    if rid != 0:
        a, b, c = (to_basic(rid, p, cords, at, seen + (cid,)) for p in (a, b, c))
    ez = b - a
    ex = (c - a) - ((c - a) @ ez) / (ez @ ez) * ez if ez @ ez > 0 else ez
    if not (np.linalg.norm(ez) > 0 and np.linalg.norm(ex) > 1e-12 * np.linalg.norm(c - a)):
        raise InputError(f"{at}: coordinate system {cid}: points A, B, C do not define axes (B = A, or C on the z axis)")
    ez, ex = ez / np.linalg.norm(ez), ex / np.linalg.norm(ex)
    ey = np.cross(ez, ex)
    x = np.asarray(x, dtype=float)
    if kind == "C":
        t = np.radians(x[1])
        x = np.array([x[0] * np.cos(t), x[0] * np.sin(t), x[2]])
    elif kind == "S":
        t, f = np.radians(x[1]), np.radians(x[2])
        x = x[0] * np.array([np.sin(t) * np.cos(f), np.sin(t) * np.sin(f), np.cos(t)])
    return a + x[0] * ex + x[1] * ey + x[2] * ez


def _element(name, d, where, elems) -> None:
    type_, counts = _ELEMENTS[name]
    eid = int_id(_field(d, 0), where)
    where = f"{where} (element {eid})"
    pid = int_id(_field(d, 1, str(eid)), where)
    limit = {"CQUAD4": 4, "CTRIA3": 3, "CHEXA": 20, "CTETRA": 10}[name]
    g = [x for x in d[2:2 + limit]]
    while g and g[-1] == "":
        g.pop()
    if "" in g or len(g) not in counts:
        shown = " ".join(x or "(blank)" for x in g)
        raise InputError(f"{where}: {name} with {len(g)} grid fields ({shown}); femupdate reads {name} with "
                         f"{' or '.join(map(str, counts))} nodes")
    if name in ("CQUAD4", "CTRIA3"):
        rest = d[2 + limit:]
        offset, thick = (rest[1:2], rest[4:]) if name == "CQUAD4" else (rest[1:2], rest[5:])
        if any(x not in ("", "0", "0.", "0.0") for x in offset) or any(x != "" for x in thick):
            raise InputError(f"{where}: offsets (ZOFFS) and corner thicknesses (T1..) are not supported; the "
                             "thickness comes from PSHELL")
    if type_ is None:
        type_ = "tet4" if len(g) == 4 else "tet10"
    key = (type_, name)
    ids, pids, conn, _ = elems.setdefault(key, ([], [], [], name))
    ids.append(eid)
    pids.append(pid)
    try:
        conn.append([int(x) for x in g])  # the common case, first
    except ValueError:
        conn.append([int_id(x, where) for x in g])


def _spc1(d, where, mesh) -> None:
    """SPC1 SID C G1 G2 ... (or G1 THRU G2): fixed dofs; one SID only (the case control is not read)."""
    sid, comp = _field(d, 0), _field(d, 1)
    if not comp or any(c not in DIRS for c in comp) or len(set(comp)) != len(comp):
        raise InputError(f"{where}: SPC1 component {comp or 'blank'!r} must be digits 1 to 6")
    grids = [g for g in d[2:] if g != ""]
    if len(grids) == 3 and grids[1].upper() == "THRU":
        a, b = int_id(grids[0], where), int_id(grids[2], where)
        nodes = list(range(a, b + 1))
    else:
        nodes = [int_id(g, where) for g in grids]
    sids = {s_["sid"] for s_ in mesh.supports}
    if sids and sid not in sids:
        raise InputError(f"{where}: SPC1 sets {', '.join(sorted(sids))} and {sid}; femupdate does not read the case "
                         "control that selects one: keep one set")
    mesh.supports.append({"nodes": nodes, "set": None, "dofs": [DIRS[c] for c in comp], "where": where, "sid": sid})


def _pshell(d, where, mesh) -> None:
    pid = int_id(_field(d, 0), where)
    where = f"{where} (PSHELL {pid})"
    mid1, mid2, mid3 = _field(d, 1), _field(d, 3), _field(d, 5)
    t = real(_field(d, 2), where) if _field(d, 2) else None
    if not mid1 or mid2 != mid1 or mid3 not in ("", mid1):
        raise InputError(f"{where}: MID1 = {mid1 or 'blank'}, MID2 = {mid2 or 'blank'}, MID3 = {mid3 or 'blank'}; "
                         "femupdate reads homogeneous shells: MID2 = MID1 and MID3 blank or = MID1")
    for k, what, ok in ((4, "12I/T**3", 1.0), (6, "TS/T", 5 / 6), (7, "NSM", 0.0)):
        if _field(d, k) and abs(real(d[k], where) - ok) > 1e-4 * max(ok, 1):
            raise InputError(f"{where}: {what} = {d[k]} is not supported (femupdate's shells have 12I/T**3 = 1, "
                             "TS/T = 5/6 and no non-structural mass)")
    if t is None:
        raise InputError(f"{where}: no thickness T")
    mesh.sections.append(Section(str(pid), str(int_id(mid1, where)), t, where))


def _mat1(d, where, mesh) -> None:
    mid = int_id(_field(d, 0), where)
    where = f"{where} (MAT1 {mid})"
    E, G, nu, rho = (real(_field(d, k), where) if _field(d, k) else None for k in (1, 2, 3, 4))
    if E is None and G is not None and nu is not None:
        E = 2 * G * (1 + nu)
    if nu is None and E is not None and G is not None:
        nu = E / (2 * G) - 1
    if E is None or nu is None:
        raise InputError(f"{where}: needs two of E, G and NU")
    if G is not None and abs(G - E / (2 * (1 + nu))) > 1e-4 * abs(G):
        raise InputError(f"{where}: G = {G:g} differs from E/(2(1+NU)) = {E / (2 * (1 + nu)):g}; femupdate's "
                         "materials are isotropic")
    if _field(d, 7) and real(d[7], where) != 0:
        mesh.ignored.append(f"structural damping GE of MAT1 {mid} ({where.split(' at ')[-1]})")
    mesh.materials[str(mid)] = Material(str(mid), E, nu, rho)


__all__ = ["read_nastran", "cards", "real"]
