"""Shell and solid elements in a :class:`~femupdate.structure.Structure`: node lists checked,
Poisson's ratio and thickness checked, the group added (:meth:`Structure.shell`,
:meth:`Structure.solid`)."""

from __future__ import annotations

import math

import numpy as np

from .._errors import InputError
from ..elements_3d.shells import DRILL
from .groups import NODE_DIRS, SHELLS, SOLIDS, NodeDofs, mass_kind

def element_nodes(nodes, counts: dict[str, int], kind: str, where: str) -> tuple[str, np.ndarray]:
    """Element type (by node count) and the ``(n_el, n_nodes)`` integer node array."""
    try:
        arr = np.asarray(nodes)
    except (TypeError, ValueError):  # ragged
        arr = np.empty((0, 0))
    if arr.ndim == 1:
        arr = arr[None, :]
    by_count = {n: t for t, n in counts.items()}
    allowed = " or ".join(f"{n} ({t})" for t, n in counts.items())
    if arr.ndim != 2 or arr.shape[1] not in by_count or arr.shape[0] == 0:
        raise InputError(f"{where}: a {kind} element lists {allowed} node ids; got {nodes!r}")
    if arr.dtype.kind not in "iuf" or (arr.dtype.kind == "f" and not np.all(np.isfinite(arr) & (arr == np.round(arr)))):
        raise InputError(f"{where}: node ids must be integers, got {nodes!r}")
    arr = arr.astype(np.int64)
    srt = np.sort(arr, axis=1)
    rep = np.flatnonzero(np.any(srt[:, 1:] == srt[:, :-1], axis=1))
    if rep.size:
        raise InputError(f"{where}{'' if len(arr) == 1 else f' [{rep[0]}]'}: element lists a node twice "
                         f"({arr[rep[0]].tolist()})")
    return by_count[arr.shape[1]], arr


def poisson_ratio(nu, n: int, where: str) -> np.ndarray:
    """Poisson's ratio: a number (or one per element) in (-1, 0.5), never a parameter name."""
    if isinstance(nu, str):
        raise InputError(f"{where}: nu = {nu!r}: Poisson's ratio enters the element matrices non-linearly and cannot be "
                         "a parameter; give a number")
    try:
        v = np.broadcast_to(np.asarray(nu, dtype=float), (n,)).copy()
    except (TypeError, ValueError):
        raise InputError(f"{where}: nu must be a number (or one per element), got {nu!r}") from None
    bad = np.flatnonzero(~((v > -1) & (v < 0.5)))
    if bad.size:
        raise InputError(f"{where}: Poisson's ratio nu = {v[bad[0]]:g} must lie strictly between -1 and 0.5")
    return v


def add_shell(s, nodes, E, nu, t, rho, mass, drill, where) -> None:
    """:meth:`Structure.shell`."""
    type_, arr = element_nodes(nodes, SHELLS, "shell", where)
    if nu is None:
        raise InputError(f"{where}: a shell needs Poisson's ratio nu")
    if isinstance(drill, bool) or not isinstance(drill, (int, float)) or not (math.isfinite(drill) and drill > 0):
        raise InputError(f"{where}: drill must be a positive number, got {drill!r}")
    _add(s, type_, arr, {"E": E, "t": t, "rho": rho}, nu, mass, where, drill=float(drill))


def add_solid(s, nodes, E, nu, rho, mass, where) -> None:
    """:meth:`Structure.solid`."""
    type_, arr = element_nodes(nodes, SOLIDS, "solid", where)
    if nu is None:
        raise InputError(f"{where}: a solid needs Poisson's ratio nu")
    _add(s, type_, arr, {"E": E, "rho": rho}, nu, mass, where, drill=DRILL)


def _add(s, type_, arr, props, nu, mass, where, drill) -> None:
    dirs = NODE_DIRS[type_]
    labels = NodeDofs(arr, dirs)
    nu_arr = poisson_ratio(nu, len(arr), where)
    s._add(type_, labels, props, where, nodes=arr, mass=mass_kind(mass, where), nu=nu_arr, drill=drill)


__all__ = ["add_shell", "add_solid", "element_nodes", "poisson_ratio"]
