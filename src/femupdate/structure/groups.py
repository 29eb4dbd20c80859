"""Element groups: the element types and their properties, one group of like elements, and the
vectorised scatter of element matrices into COO triplets split by parameter."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .. import elements as el
from .._errors import InputError

MASS_KINDS = el.MASS_KINDS

# element type -> (required properties, optional properties with defaults, stiffness-only?)
PROPS: dict[str, tuple[tuple[str, ...], dict]] = {
    "spring": (("k",), {}),
    "mass": (("m",), {}),
    "rod": (("E", "A", "rho"), {}),
    "beam2d": (("E", "A", "I", "rho"), {}),
    "beam2d_terms": (("EA_l", "k12", "k6", "k2", "rho", "A"), {}),
    "frame3d": (("E", "G", "A", "Iy", "Iz", "J", "rho"), {}),
    "frame3d_terms": (("EA_l", "GJ_l", "rho", "A", "Ip"), {}),
}
BENDING = ("k12", "k6", "k2")
NODE_DIRS = {
    "beam2d": ("x", "y", "rz"),
    "beam2d_terms": ("x", "y", "rz"),
    "frame3d": ("x", "y", "z", "rx", "ry", "rz"),
    "frame3d_terms": ("x", "y", "z", "rx", "ry", "rz"),
}
ELEMENT_TYPES = tuple(PROPS)


@dataclass
class ElementGroup:
    type: str
    props: dict[str, list]  # property -> per-element list of float | str
    labels: list[list[str]]  # per-element dof labels
    nodes: np.ndarray | None = None  # (n_el, 2) node ids
    mass: str = "consistent"
    dim: int = 3
    orientation: np.ndarray | None = None  # (n_el, 3)
    where: list[str] = field(default_factory=list)  # per-element description for messages

    @property
    def key(self):
        return (self.type, self.mass, self.dim, len(self.labels[0]), tuple(sorted(self.props)))


def per_element(value, n: int, what: str) -> list:
    if isinstance(value, (str, int, float, np.number)) and not isinstance(value, bool):
        return [value] * n
    if isinstance(value, np.ndarray) and value.ndim == 0:
        return [value.item()] * n
    try:
        seq = list(value)
    except TypeError:
        raise InputError(f"{what}: expected a number, a parameter name or one per element, got {value!r}") from None
    if len(seq) != n:
        raise InputError(f"{what}: {len(seq)} values given for {n} elements")
    return seq

def mass_kind(mass, where):
    if mass not in MASS_KINDS:
        raise InputError(f"{where}: mass must be one of {', '.join(MASS_KINDS)}, got {mass!r}")
    return mass

def merge_groups(groups: list[ElementGroup]) -> list[ElementGroup]:
    """Concatenate groups of the same type and options so that element matrices are vectorised."""
    by_key: dict = {}
    for g in groups:
        by_key.setdefault(g.key, []).append(g)
    out = []
    for gs in by_key.values():
        if len(gs) == 1:
            out.append(gs[0])
            continue
        g0 = gs[0]
        props = {k: [v for g in gs for v in g.props[k]] for k in g0.props}
        out.append(ElementGroup(
            type=g0.type, props=props, labels=[row for g in gs for row in g.labels],
            nodes=None if g0.nodes is None else np.concatenate([g.nodes for g in gs]),
            mass=g0.mass, dim=g0.dim,
            orientation=None if g0.orientation is None else np.concatenate([g.orientation for g in gs]),
            where=[w for g in gs for w in g.where],
        ))
    return out


def triplets(trip, target, unit, idx, coef, pid) -> None:
    """COO triplets of ``coef * unit`` scattered to ``idx``, split by parameter id."""
    ne = idx.shape[1]
    rows = np.broadcast_to(idx[:, :, None], (len(idx), ne, ne))
    cols = np.broadcast_to(idx[:, None, :], (len(idx), ne, ne))
    vals = coef[:, None, None] * unit
    keep = (rows >= 0) & (cols >= 0) & (vals != 0)
    owner = np.broadcast_to(pid[:, None, None], keep.shape)[keep]
    r, c, v = rows[keep], cols[keep], vals[keep]
    for t in np.unique(owner):
        sel = owner == t
        trip[(target, int(t))].append((r[sel], c[sel], v[sel]))


__all__ = ["MASS_KINDS", "PROPS", "BENDING", "NODE_DIRS", "ELEMENT_TYPES", "ElementGroup", "per_element", "mass_kind",
           "merge_groups", "triplets"]
