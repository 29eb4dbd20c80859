"""Abaqus kinematic constraints read as exact multipoint constraints (:mod:`femupdate.constraints`):

* ``*KINEMATIC COUPLING, REF NODE=r`` with data lines ``node or node set, first dof[, last dof]``
  (first dof blank or 0: all six): the listed dofs of each node follow node r rigidly — a rigid
  link (Nastran's RBE2).
* ``*MPC`` with data lines ``BEAM, p, a`` (node or node set p follows node a as a rigid beam) or
  ``TIE, p, a`` (every dof p has equals a's).  Other MPC types (PIN, LINK, SLIDER, ...) are
  refused, named with their line.

Other options (``ORIENTATION=``, ``*COUPLING`` distributing constraints) are refused by name.
"""

from __future__ import annotations

from .._errors import InputError
from .core import DIRS, int_id

MPC_TYPES = {"BEAM": "rigid", "TIE": "equal"}


def _target(text: str, w: str) -> tuple[list[int] | None, str | None]:
    t = text.strip()
    return ([int_id(t, w)], None) if t.lstrip("-").isdigit() else (None, t)


def kinematic_coupling(path, opts, data, where, pending: list) -> None:
    """``*KINEMATIC COUPLING``: one rigid link per data line (resolved by :func:`resolve`)."""
    extra = sorted(set(opts) - {"REF NODE"})
    if extra:
        raise InputError(f"{where}: option(s) {', '.join(extra)} are not read (REF NODE only: global axes)")
    if "REF NODE" not in opts:
        raise InputError(f"{where}: needs REF NODE=")
    ref = opts["REF NODE"]
    for ln, f in data:
        w = f"{path}: line {ln} (*KINEMATIC COUPLING)"
        f = [v for v in f if v != ""]
        if not 1 <= len(f) <= 3:
            raise InputError(f"{w}: a coupling line is 'node or set[, first dof[, last dof]]', got {', '.join(f)}")
        a = int_id(f[1], w) if len(f) > 1 else 0
        b = int_id(f[2], w) if len(f) > 2 else (6 if a == 0 else a)
        a = a or 1
        if not 1 <= a <= b <= 6:
            raise InputError(f"{w}: dofs {a} to {b}: Abaqus dofs are 1 to 6")
        pending.append({"kind": "rigid", "ref": ref, "target": f[0], "dofs": [DIRS[str(k)] for k in range(a, b + 1)],
                         "where": w})


def mpc(path, opts, data, where, pending: list) -> None:
    """``*MPC``: BEAM and TIE lines (resolved by :func:`resolve`)."""
    if opts:
        raise InputError(f"{where}: options {', '.join(opts)} are not read")
    for ln, f in data:
        w = f"{path}: line {ln} (*MPC)"
        f = [v for v in f if v != ""]
        kind = MPC_TYPES.get(f[0].upper()) if f else None
        if kind is None:
            raise InputError(f"{w}: MPC type {f[0] if f else '(none)'!r} is not supported (femupdate reads BEAM and TIE "
                             "as exact constraints)")
        if len(f) != 3:
            raise InputError(f"{w}: an MPC line is 'type, dependent node or set, independent node', got {', '.join(f)}")
        pending.append({"kind": kind, "ref": f[2], "target": f[1], "dofs": None, "where": w})


def resolve(mesh, pending: list) -> None:
    """Node sets resolved (now that every ``*NSET`` is read) into ``mesh.links``."""
    for c in pending:
        w = c["where"]
        ref_nodes, ref_set = _target(c["ref"], w)
        if ref_nodes is None:
            assert ref_set is not None
            try:
                _, ids = mesh.set_of(ref_set, "node")
            except InputError as exc:
                raise InputError(f"{w}: {exc}") from None
            if len(ids) != 1:
                raise InputError(f"{w}: the independent (reference) node set {ref_set!r} has {len(ids)} nodes; one needed")
            ref_nodes = [int(ids[0])]
        nodes, name = _target(c["target"], w)
        if nodes is None:
            assert name is not None
            try:
                _, ids = mesh.set_of(name, "node")
            except InputError as exc:
                raise InputError(f"{w}: {exc}") from None
            nodes = [int(i) for i in ids if int(i) != ref_nodes[0]]  # a set may hold the reference node too
        mesh.links.append({"kind": c["kind"], "independent": ref_nodes[0], "dependent": nodes, "dofs": c["dofs"],
                           "where": w})


__all__ = ["kinematic_coupling", "mpc", "resolve", "MPC_TYPES"]
