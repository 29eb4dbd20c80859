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
    "point_mass": (("m",), {}),
    "rod": (("E", "A", "rho"), {}),
    "beam2d": (("E", "A", "I", "rho"), {}),
    "beam2d_terms": (("EA_l", "k12", "k6", "k2", "rho", "A"), {}),
    "frame3d": (("E", "G", "A", "Iy", "Iz", "J", "rho"), {}),
    "frame3d_terms": (("EA_l", "GJ_l", "rho", "A", "Ip"), {}),
    "mitc4": (("E", "t", "rho"), {}),
    "mitc3": (("E", "t", "rho"), {}),
    "hex8": (("E", "rho"), {}),
    "tet4": (("E", "rho"), {}),
    "tet10": (("E", "rho"), {}),
}
#: shell and solid element types -> number of nodes per element
SHELLS = {"mitc4": 4, "mitc3": 3}
SOLIDS = {"hex8": 8, "tet4": 4, "tet10": 10}
#: the edges of each shell and solid type, as pairs of positions in its node list (for drawing)
EDGES = {
    "mitc4": ((0, 1), (1, 2), (2, 3), (3, 0)),
    "mitc3": ((0, 1), (1, 2), (2, 0)),
    "hex8": ((0, 1), (1, 2), (2, 3), (3, 0), (4, 5), (5, 6), (6, 7), (7, 4), (0, 4), (1, 5), (2, 6), (3, 7)),
    "tet4": ((0, 1), (1, 2), (2, 0), (0, 3), (1, 3), (2, 3)),
    "tet10": ((0, 4), (4, 1), (1, 5), (5, 2), (2, 6), (6, 0), (0, 7), (7, 3), (1, 8), (8, 3), (2, 9), (9, 3)),
}


def node_pairs(g) -> np.ndarray:
    """Node-id pairs to draw a group's elements with: the ends of line elements, the edges of shells
    and solids; ``(0, 2)`` for springs and masses."""
    if g.nodes is None:
        return np.zeros((0, 2), np.int64)
    nodes = np.asarray(g.nodes, dtype=np.int64)
    if g.type not in EDGES:
        return nodes
    idx = np.array(EDGES[g.type])
    return nodes[:, idx].reshape(-1, 2)
BENDING = ("k12", "k6", "k2")
NODE_DIRS = {
    "beam2d": ("x", "y", "rz"),
    "beam2d_terms": ("x", "y", "rz"),
    "frame3d": ("x", "y", "z", "rx", "ry", "rz"),
    "frame3d_terms": ("x", "y", "z", "rx", "ry", "rz"),
    **{t: ("x", "y", "z", "rx", "ry", "rz") for t in ("mitc4", "mitc3")},
    **{t: ("x", "y", "z") for t in ("hex8", "tet4", "tet10")},
}
ELEMENT_TYPES = tuple(PROPS)


class NodeDofs:
    """The dof labels of like elements, made when asked: element ``i``'s labels are
    ``"<node>:<dir>"`` for each of its nodes ``nodes[i]`` and each direction of ``dirs``, node by
    node.  A sequence of lists of str, as :attr:`ElementGroup.labels` (shells and solids keep
    their labels this way: a million-dof mesh has no ten million label strings to make)."""

    def __init__(self, nodes: np.ndarray, dirs: tuple[str, ...]):
        self.nodes = np.asarray(nodes, dtype=np.int64)
        self.dirs = tuple(dirs)

    def __len__(self) -> int:
        return len(self.nodes)

    def _row(self, i) -> list[str]:
        return [f"{a}:{d}" for a in self.nodes[i].tolist() for d in self.dirs]

    def __getitem__(self, i):
        if isinstance(i, slice):
            return [self._row(k) for k in range(*i.indices(len(self)))]
        return self._row(i)

    def __iter__(self):
        for row in self.nodes.tolist():
            yield [f"{a}:{d}" for a in row for d in self.dirs]

    def __eq__(self, other):
        return list(self) == list(other)

    def __repr__(self) -> str:
        return f"NodeDofs({len(self)} elements, dirs {self.dirs})"


@dataclass
class ElementGroup:
    """Like elements added together: one type, mass kind and number of dofs per element.

    Parameters
    ----------
    type : str
        Element type, one of ``ELEMENT_TYPES``.
    props : dict of str to list
        Property name -> one value per element: a number or the name of a declared parameter.
    labels : list of list of str
        Each element's dof labels, in the element's dof order (:mod:`femupdate.elements`).
    nodes : numpy.ndarray of int, shape ``(n_el, 2)`` or ``(n_el, n_nodes)``, optional
        End node ids of line elements, node ids of shells and solids (None for springs and masses).
    mass : {"consistent", "lumped"}, default "consistent"
        Mass matrix of line elements.
    dim : {2, 3}, default 3
        Dimension of a rod group.
    orientation : numpy.ndarray, shape ``(n_el, 3)``, optional
        Orientation vectors of frame elements.
    where : list of str
        Per-element description for messages.
    nu : numpy.ndarray, shape ``(n_el,)``, optional
        Poisson's ratio of shell and solid elements (a fixed number: it enters non-linearly).
    drill : float, default 0.1
        Drilling penalty factor of shell elements (:mod:`femupdate.elements_3d.shells`).
    data : numpy.ndarray, optional
        Per-element numbers of the type: the end offsets of frames ``(n_el, 6)``, the offset
        and inertia of point masses ``(n_el, 12)`` (:mod:`femupdate.structure.links`).
    torsion_mass : bool, default True
        Frames: with the torsional inertia rho (Iy + Iz) (False: without, as Nastran's CBAR).
    """

    type: str
    props: dict[str, list]  # property -> per-element list of float | str
    labels: list[list[str]] | NodeDofs  # per-element dof labels
    nodes: np.ndarray | None = None  # (n_el, 2) node ids
    mass: str = "consistent"
    dim: int = 3
    orientation: np.ndarray | None = None  # (n_el, 3)
    where: list[str] = field(default_factory=list)  # per-element description for messages
    nu: np.ndarray | None = None  # (n_el,) Poisson's ratio of shells and solids
    drill: float = 0.1
    data: np.ndarray | None = None
    torsion_mass: bool = True

    @property
    def key(self):
        """``(type, mass, dim, dofs per element, sorted property names, drill, no data)``: groups with equal keys merge."""
        return (self.type, self.mass, self.dim, len(self.labels[0]), tuple(sorted(self.props)), self.drill,
                self.data is None, self.torsion_mass)


def per_element(value, n: int, what: str) -> list:
    """One value per element: a scalar (number or parameter name) repeated, or a sequence of ``n``.

    Parameters
    ----------
    value : float, str, numpy scalar or sequence
        The property as given.
    n : int
        Number of elements.
    what : str
        The property and element, for the error messages.

    Returns
    -------
    list
        ``n`` values (numbers or parameter names, unchecked).

    Raises
    ------
    InputError
        ``value`` is neither a scalar nor iterable (a bool counts as neither), or a sequence whose
        length is not ``n``.
    """
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
    """Check a mass-matrix kind.

    Parameters
    ----------
    mass : str
        ``"consistent"`` or ``"lumped"``.
    where : str
        The element, for the error message.

    Returns
    -------
    str
        ``mass`` unchanged.

    Raises
    ------
    InputError
        ``mass`` is not one of ``MASS_KINDS``.
    """
    if mass not in MASS_KINDS:
        raise InputError(f"{where}: mass must be one of {', '.join(MASS_KINDS)}, got {mass!r}")
    return mass

def merge_groups(groups: list[ElementGroup]) -> list[ElementGroup]:
    """Concatenate groups of the same type and options so that element matrices are vectorised.

    Parameters
    ----------
    groups : list of ElementGroup
        Groups in the order they were added.

    Returns
    -------
    list of ElementGroup
        One group per distinct :attr:`ElementGroup.key`, in order of first appearance; a group
        without a partner is returned as is, not copied.
    """
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
        lazy = all(isinstance(g.labels, NodeDofs) and g.labels.dirs == g0.labels.dirs for g in gs)
        labels = (NodeDofs(np.concatenate([g.labels.nodes for g in gs]), g0.labels.dirs) if lazy
                  else [row for g in gs for row in g.labels])
        out.append(ElementGroup(
            type=g0.type, props=props, labels=labels,
            nodes=None if g0.nodes is None else np.concatenate([g.nodes for g in gs]),
            mass=g0.mass, dim=g0.dim,
            orientation=None if g0.orientation is None else np.concatenate([g.orientation for g in gs]),
            where=[w for g in gs for w in g.where],
            nu=None if g0.nu is None else np.concatenate([g.nu for g in gs]), drill=g0.drill,
            data=None if g0.data is None else np.concatenate([g.data for g in gs]), torsion_mass=g0.torsion_mass,
        ))
    return out


def triplets(trip, target, unit, idx, coef, pid) -> None:
    """COO triplets of ``coef * unit`` scattered to ``idx``, split by parameter id.

    Entries at a dof index below 0 (a supported dof) and zero entries are dropped.

    Parameters
    ----------
    trip : dict of (str, int) to list
        Collector, updated in place: ``trip[(target, parameter id)]`` receives one
        ``(rows, cols, values)`` tuple of 1-D arrays per call and parameter id present.
    target : {"K", "M"}
        Matrix the term belongs to.
    unit : numpy.ndarray, shape ``(n_el, n_e, n_e)``
        Unit element matrices of the term.
    idx : numpy.ndarray of int, shape ``(n_el, n_e)``
        Model dof index of each element dof (-1 for a supported dof).
    coef : numpy.ndarray, shape ``(n_el,)``
        Numeric factor of each element's term.
    pid : numpy.ndarray of int, shape ``(n_el,)``
        Parameter multiplying each element's term (-1: none, the constant part).
    """
    ne = idx.shape[1]
    rows = np.broadcast_to(idx[:, :, None], (len(idx), ne, ne))
    cols = np.broadcast_to(idx[:, None, :], (len(idx), ne, ne))
    vals = coef[:, None, None] * unit
    keep = (rows >= 0) & (cols >= 0) & (vals != 0)
    owner = np.broadcast_to(pid[:, None, None], keep.shape)[keep]
    r, c, v = rows[keep], cols[keep], vals[keep]
    for t in np.unique(owner):
        sel = owner == t
        trip.setdefault((target, int(t)), []).append((r[sel], c[sel], v[sel]))


__all__ = ["NodeDofs", "MASS_KINDS", "PROPS", "SHELLS", "SOLIDS", "EDGES", "node_pairs", "BENDING", "NODE_DIRS", "ELEMENT_TYPES", "ElementGroup", "per_element", "mass_kind",
           "merge_groups", "triplets"]
