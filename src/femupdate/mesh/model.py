"""A :class:`~femupdate.structure.Structure` from a mesh: the model file's ``[mesh]`` table
(docs/file-formats.md) or :meth:`Structure.from_mesh`.

Property sets are the deck's sections (Abaqus ``*SHELL SECTION``/``*SOLID SECTION`` by element
set, Nastran ``PSHELL``/``PSOLID`` by property id) and the sets the table names; a set's table
overrides the deck key by key (``E = "E_skin"`` makes the modulus of that set a parameter).
Every element of the mesh's structural dimension belongs to exactly one property set.  Beam
sets (Nastran PBAR/PBEAM) become frame3d groups; a deck's springs, point masses and exact
constraints (``Mesh.springs``, ``masses``, ``links``) are added as they are; what the deck holds
that is not modelled (``Mesh.ignored``) is logged as a warning.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np

import logging

from .._errors import InputError
from ..dofs import dof
from ..structure.groups import NODE_DIRS, SHELLS
from . import read_mesh
from .core import Mesh
from .units import check_value, system_of

log = logging.getLogger(__name__)
SET_KEYS = {"E", "nu", "rho", "t", "mass", "drill", "G", "A", "Iy", "Iz", "J"}
TABLE_KEYS = {"file", "format", "sets", "support", "units", "check_units"}
_DIRECTIONS = ("x", "y", "z", "rx", "ry", "rz")


def _deck_sets(mesh: Mesh, system: str | None) -> dict[str, dict]:
    """Properties of each sectioned element set of a deck: E, nu, rho from its material, t; E and rho
    checked against the declared unit ``system`` (None: not checked)."""
    out: dict[str, dict] = {}
    for sec in mesh.sections:
        try:
            name, _ = mesh.set_of(sec.elset, "element")
        except InputError as exc:
            raise InputError(f"{sec.where}: {exc}") from None
        mat = mesh.materials.get(sec.material) or mesh.materials.get(sec.material.upper())
        if mat is None:
            raise InputError(f"{sec.where}: material {sec.material!r} is not defined in {mesh.source}")
        if name in out:
            raise InputError(f"{sec.where}: element set {name!r} has a second section")
        props = {k: v for k, v in (("E", mat.E), ("nu", mat.nu), ("rho", mat.rho), ("t", sec.thickness)) if v is not None}
        props.update(sec.beam or {})
        if system is not None:
            for k in ("E", "rho"):
                check_value(k, props.get(k), system, f"{sec.where}: material {sec.material!r}")
        out[name] = props
    return out


def _property_sets(mesh: Mesh, sets: Mapping, where: str, system: str | None) -> dict[str, dict]:
    if not isinstance(sets, Mapping):
        raise InputError(f"{where}: sets must be a table of tables ([mesh.sets.NAME])")
    props = _deck_sets(mesh, system)
    for name, spec in sets.items():
        w = f"{where}: [mesh.sets.{name}]"
        if not isinstance(spec, Mapping):
            raise InputError(f"{w} must be a table (E, nu, rho, t, mass, drill)")
        unknown = sorted(set(spec) - SET_KEYS)
        if unknown:
            raise InputError(f"{w}: unknown key(s) {', '.join(unknown)} (allowed: {', '.join(sorted(SET_KEYS))})")
        for k, v in spec.items():
            ok = isinstance(v, str) if k == "mass" else (
                not isinstance(v, bool) and isinstance(v, (int, float) if k in ("nu", "drill") else (int, float, str)))
            kind = {"mass": "\"consistent\" or \"lumped\"", "nu": "a number", "drill": "a number"}.get(
                k, "a number or a parameter name")
            if not ok:
                raise InputError(f"{w}: {k} must be {kind}, got {v!r}")
            if system is not None:
                check_value(k, v, system, w)
        try:
            written, _ = mesh.set_of(str(name), "element")
        except InputError as exc:
            raise InputError(f"{w}: {exc}") from None
        props.setdefault(written, {}).update(spec)
    if not props:
        raise InputError(f"{where}: {mesh.source} has no sections and the table names no sets: give each element set "
                         "its material in [mesh.sets.NAME] (E, nu, rho; t for shells)")
    return props


def _assign(mesh: Mesh, props: dict[str, dict], where: str):
    """Per block, the property set index of each element; refused when an element has none or two."""
    names = list(props)
    owner = {}
    for b in mesh.blocks:
        owner[id(b)] = np.full(len(b.ids), -1, np.int64)
    pos = {int(e): (bk, r) for bk, b in enumerate(mesh.blocks) for r, e in enumerate(b.ids)}
    for k, name in enumerate(names):
        ids = mesh.elsets[name]
        if len(ids) == 0:
            raise InputError(f"{where}: element set {name!r} of {mesh.source} has no elements")
        for e in ids:
            hit = pos.get(int(e))
            if hit is None:
                raise InputError(f"{where}: element set {name!r} names element {int(e)}, which {mesh.source} does not "
                                 "define as a shell or solid element")
            arr = owner[id(mesh.blocks[hit[0]])]
            if arr[hit[1]] >= 0 and arr[hit[1]] != k:
                raise InputError(f"{where}: element {int(e)} is in sets {names[arr[hit[1]]]!r} and {name!r}, both with "
                                 "properties; give it one")
            arr[hit[1]] = k
    for b in mesh.blocks:
        miss = np.flatnonzero(owner[id(b)] < 0)
        if miss.size:
            raise InputError(f"{where}: {miss.size} element(s) of {mesh.source} belong to no set with a material and "
                             f"section, the first element {int(b.ids[miss[0]])} ({b.source_type}); sets with "
                             f"properties: {', '.join(names)}")
    return names, owner


def add_mesh(s, mesh: Mesh, sets: Mapping | None = None, support: Sequence | None = None, where: str = "mesh",
             units: str | None = None, check_units: bool = True) -> None:
    """Add a mesh's nodes, elements (by property set) and supports to the structure ``s``, in the
    declared consistent unit system ``units`` (:mod:`femupdate.mesh.units`): moduli and densities that
    contradict it are refused unless ``check_units`` is false.  Undeclared (None): SI unit names, and
    nothing checked (a deck in another consistent system, inch-lbf-s, is taken as it is)."""
    system = None if units is None else system_of(units, where)
    if not isinstance(check_units, bool):
        raise InputError(f"{where}: check_units must be true or false, got {check_units!r}")
    s.units = system or "m-kg-s"
    check = system is not None and check_units
    props = _property_sets(mesh, sets or {}, where, system if check else None)
    if check:  # parameters standing for E, G or rho: checked when the structure is built
        s.unit_checks = [(v, k, f"{where}: set {n!r}") for n, p in props.items() for k, v in p.items()
                         if k in ("E", "G", "rho") and isinstance(v, str)]
    names, owner = _assign(mesh, props, where)
    s.add_nodes(mesh.node_ids.tolist(), mesh.xyz)
    for k, name in enumerate(names):
        p = dict(props[name])
        kw = {"mass": p.pop("mass", "consistent")}
        for b in mesh.blocks:
            rows = np.flatnonzero(owner[id(b)] == k)
            if rows.size == 0:
                continue
            w = f"{where}: set {name!r}"
            need = ("E", "nu", "rho", "t") if b.type in SHELLS else ("E", "rho", "A", "Iy", "Iz", "J") if b.type == "frame3d" \
                else ("E", "nu", "rho")
            missing = [x for x in need if x not in p]
            if missing:
                raise InputError(f"{w}: its {b.source_type} elements need {', '.join(missing)} (from the file's "
                                 f"section and material, or [mesh.sets.{name}])")
            if b.type == "frame3d":
                _frame(s, b, rows, p, w, kw)
            elif b.type in SHELLS:
                s.shell(b.conn[rows], E=p["E"], nu=p["nu"], t=p["t"], rho=p["rho"], drill=p.get("drill", 0.1),
                        where=w, **kw)
            else:
                s.solid(b.conn[rows], E=p["E"], nu=p["nu"], rho=p["rho"], where=w, **kw)
            s.groups[-1].where = [f"{mesh.source}: element {int(e)} ({b.source_type}, set {name!r})" for e in b.ids[rows]]
    _extras(s, mesh)
    if mesh.ignored:
        log.warning("%s: not read or not modelled: %s", mesh.source, "; ".join(mesh.ignored))
    deck = [{k: v for k, v in d.items() if k in ("nodes", "set", "dofs") and v is not None} for d in mesh.supports]
    _supports(s, mesh, deck, f"{where}: the file's own", [d["where"] for d in mesh.supports])
    _supports(s, mesh, support or [], where)


def _frame(s, b, rows, p: dict, w: str, kw: dict) -> None:
    """A set's CBAR/CBEAM members as frame3d: G from the set (a number or parameter name) or from E and nu;
    with E a parameter and no G, the torsion term G J is written E · J / (2 (1 + nu)), exact."""
    J, G = p["J"], p.get("G")
    if G is None:
        if "nu" not in p:
            raise InputError(f"{w}: its {b.source_type} elements need G, or nu to derive it (from the material, or "
                             "G in the set's table)")
        if isinstance(p["E"], str):
            if isinstance(J, str):
                raise InputError(f"{w}: E and J are both parameters; give G (a number or a parameter name)")
            G, J = p["E"], J / (2 * (1 + p["nu"]))
        else:
            G = p["E"] / (2 * (1 + p["nu"]))
    s.frame3d(b.conn[rows], E=p["E"], G=G, A=p["A"], Iy=p["Iy"], Iz=p["Iz"], J=J, rho=p["rho"],
              orientation=b.orientation[rows], offsets=None if b.offsets is None else b.offsets[rows], where=w,
              torsion_mass=b.source_type != "CBAR", **kw)


def _extras(s, mesh: Mesh) -> None:
    """A deck's springs, point masses and exact constraints (Nastran CELAS, CONM2, RBE2; Abaqus couplings)."""
    for sp_ in mesh.springs:
        s.spring(sp_["dofs"], k=sp_["k"], where=sp_["where"])
    for m in mesh.masses:
        s.point_mass(m["node"], m["m"], offset=m["offset"], inertia=m["inertia"], where=m["where"])
    for c in mesh.links:
        if c["kind"] == "rigid":
            s.rigid_link(c["independent"], c["dependent"], c["dofs"], where=c["where"])
        else:
            s.equal_dofs(c["independent"], c["dependent"], c["dofs"], where=c["where"])


def _supports(s, mesh: Mesh, support: Sequence, where: str, named: Sequence[str] = ()) -> None:
    if isinstance(support, Mapping):
        support = [support]
    dirs_at: dict[int, set] = {}
    for b in mesh.blocks:
        for n in np.unique(b.conn):
            dirs_at.setdefault(int(n), set()).update(NODE_DIRS[b.type])
    for c in mesh.links:  # a constraint's independent node (a reference node) has the six
        dirs_at.setdefault(int(c["independent"]), set()).update(_DIRECTIONS)
    for sp_ in mesh.springs:
        for lab in sp_["dofs"]:
            node, d = lab.split(":")
            dirs_at.setdefault(int(node), set()).add(d)
    for m in mesh.masses:  # a point mass: translations, and rotations with an offset or inertia
        full = bool(np.any(np.asarray(m["offset"]) != 0) or np.any(np.asarray(m["inertia"]) != 0))
        dirs_at.setdefault(int(m["node"]), set()).update(_DIRECTIONS if full else _DIRECTIONS[:3])
    for i, sup in enumerate(support, start=1):
        w = named[i - 1] if named else f"{where}: support #{i}"
        if not isinstance(sup, Mapping) or ("set" in sup) == ("nodes" in sup) or set(sup) - {"set", "nodes", "dofs"}:
            raise InputError(f"{w}: expected 'set' (a node set of the mesh) or 'nodes' (ids), and optionally 'dofs' "
                             "(directions such as [\"x\", \"y\", \"z\"])")
        if "set" in sup:
            try:
                name, nodes = mesh.set_of(str(sup["set"]), "node")
            except InputError as exc:
                raise InputError(f"{w}: {exc}") from None
            label = f"node set {name!r}"
        else:
            nodes, label = np.asarray(sup["nodes"]), "nodes"
            if nodes.dtype.kind not in "iu":
                raise InputError(f"{w}: nodes must be integer ids, got {sup['nodes']!r}")
        if "dofs" not in sup:
            s.support_node([int(n) for n in nodes])
            continue
        dirs = sup["dofs"]
        if isinstance(dirs, str) or not all(isinstance(d, str) and d in _DIRECTIONS for d in dirs):
            raise InputError(f"{w}: dofs must be a list of directions ({', '.join(_DIRECTIONS)}), got {dirs!r}")
        labels: list[str] = []
        for n in nodes:
            have = dirs_at.get(int(n))
            if have is None:
                raise InputError(f"{w}: node {int(n)} of {label} is used by no element")
            labels.extend(dof(int(n), d) for d in dirs if d in have)
        if not labels:
            raise InputError(f"{w}: no node of {label} has any of the dofs {', '.join(dirs)}")
        s.support(labels)


def mesh_from_table(s, table: Mapping, source: str) -> None:
    """The model file's ``[mesh]`` table: read its file (relative to the model file) and add it."""
    where = f"{source}: [mesh]"
    if not isinstance(table, Mapping):
        raise InputError(f"{where} must be a table with 'file'")
    unknown = sorted(set(table) - TABLE_KEYS)
    if unknown:
        raise InputError(f"{where}: unknown key(s) {', '.join(unknown)} (allowed: {', '.join(sorted(TABLE_KEYS))})")
    if not isinstance(table.get("file"), str):
        raise InputError(f"{where} needs file = \"NAME\" (a .msh, .inp or .bdf file)")
    base = Path(source).parent if Path(source).suffix else Path(".")
    f = Path(table["file"])
    mesh = read_mesh(f if f.is_absolute() else base / f, table.get("format"))
    add_mesh(s, mesh, table.get("sets", {}), table.get("support", []), where, table.get("units"),
             table.get("check_units", True))


__all__ = ["add_mesh", "mesh_from_table", "SET_KEYS"]
