r"""Rigid links, equal-dof ties, beam end offsets and point masses of a
:class:`~femupdate.structure.Structure`.

**Rigid link** (:meth:`Structure.rigid_link`): each dependent node d moves with the independent
node i as a rigid body, r = x_d − x_i:

.. math::  u_d = u_i + \theta_i \times r, \qquad \theta_d = \theta_i

(the rows for the dofs d has, or those ``dofs`` names: Nastran RBE2's CM).  **Equal dofs**
(:meth:`Structure.equal_dofs`): ``d:dir = i:dir`` for the named directions.  Both are exact
multipoint constraints, eliminated by :mod:`femupdate.constraints` (``K_r = Tᵀ K T`` for K0 and
every parameter matrix); the dependent dofs are recovered for shapes.  Refused, by name: a dof
dependent in two constraints, a chain or loop (a dependent dof used as independent by another
constraint: link each node straight to the final independent node), a supported dependent dof
whose independent dofs are not all supported too (the support and the link conflict), a node
linked to itself.  An independent dof no element uses (a spider's centre) becomes a model dof.

**Beam end offsets** (``offsets=`` of :meth:`Structure.frame3d`): the element runs between the
offset points x_a + o_a, x_b + o_b, joined rigidly to its nodes: its matrices become
:math:`E^T k E` with :math:`u_{end} = u_{node} + \theta_{node} \times o` — every term
transformed alike, so the decomposition by parameter stays exact.

**Point mass** (:meth:`Structure.point_mass`, Nastran CONM2): mass m whose centre lies at offset
r from its node, with inertia J about its centre: with S the cross-product matrix of r,
:math:`M = m \begin{bmatrix} I & -S \\ S & -S^2 \end{bmatrix} + \begin{bmatrix} 0 & 0 \\ 0 & J \end{bmatrix}`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._errors import InputError
from ..dofs import DIRECTIONS, describe, dof, parse_dof

_TRANSLATIONS = ("x", "y", "z")
_ROTATIONS = ("rx", "ry", "rz")


@dataclass
class Link:
    """One rigid link or tie: ``kind`` ``"rigid"`` or ``"equal"``, the independent node, the
    dependent nodes, the constrained directions (None: every dof the dependent node has) and
    its name in messages."""

    kind: str
    independent: int | str
    dependent: tuple
    dirs: tuple[str, ...] | None
    where: str


def _dirs(dofs, where: str) -> tuple[str, ...] | None:
    if dofs is None:
        return None
    if isinstance(dofs, str):
        dofs = [dofs]
    out = []
    for d in dofs:
        d = {"1": "x", "2": "y", "3": "z", "4": "rx", "5": "ry", "6": "rz"}.get(str(d), d)
        if d not in DIRECTIONS:
            raise InputError(f"{where}: direction {d!r} is not one of {', '.join(DIRECTIONS)} (or 1-6)")
        if d not in out:
            out.append(d)
    if not out:
        raise InputError(f"{where}: no directions given")
    return tuple(out)


def add_link(s, kind: str, independent, dependent, dofs, where: str) -> None:
    """Check and record a rigid link or tie on the structure ``s``."""
    from ..dofs import node_id

    ind = node_id(independent, f"{where}: independent node")
    deps = [dependent] if isinstance(dependent, (int, str, np.integer)) else list(dependent)
    if not deps:
        raise InputError(f"{where}: no dependent node")
    deps = [node_id(d if not isinstance(d, np.integer) else int(d), f"{where}: dependent node") for d in deps]
    if ind in deps:
        raise InputError(f"{where}: node {ind} is both the independent node and a dependent one")
    dup = sorted({d for d in deps if deps.count(d) > 1}, key=str)
    if dup:
        raise InputError(f"{where}: dependent node {dup[0]} listed twice")
    dirs = _dirs(dofs, where)
    s.constraints.append(Link(kind, ind, tuple(deps), dirs, where))


def _coords(s, node, link: Link) -> np.ndarray:
    if node not in s.nodes:
        raise InputError(f"{link.where}: node {node} is not defined in the node table (a rigid link needs its position)")
    return np.array(s.nodes[node], dtype=float)


def _rigid_row(i, direction: str, r: np.ndarray) -> list[tuple[str, float]]:
    """The independent terms of one dependent dof of a rigid link (u_d = u_i + θ_i × r)."""
    if direction in _ROTATIONS:
        return [(dof(i, direction), 1.0)]
    rx, ry, rz = (float(v) for v in r)
    terms = {"x": [("x", 1.0), ("ry", rz), ("rz", -ry)],
             "y": [("y", 1.0), ("rz", rx), ("rx", -rz)],
             "z": [("z", 1.0), ("rx", ry), ("ry", -rx)]}[direction]
    return [(dof(i, d), c) for d, c in terms if c != 0.0]


def constraint_rows(s, present: set[str]) -> tuple[dict, dict, set[str]]:
    """The dependent dofs of every link: ``rows`` {dependent label: [(independent label, coef)]},
    ``source`` {dependent label: link name}, and the independent labels no element uses.

    Raises
    ------
    InputError
        A node with no dof to constrain, a dof dependent twice, a chain or loop of constraints.
    """
    at: dict = {}
    for lab in present:
        nd, d = parse_dof(lab)
        at.setdefault(nd, set()).add(d)
    rows: dict[str, list] = {}
    source: dict[str, str] = {}
    for link in s.constraints:
        xi = _coords(s, link.independent, link) if link.kind == "rigid" else None
        for d in link.dependent:
            have = at.get(d, set())
            dirs = [x for x in (link.dirs or DIRECTIONS) if x in have]
            if link.kind == "equal":
                missing = [x for x in (link.dirs or ()) if x not in have]
                if missing:
                    raise InputError(f"{link.where}: dependent node {d} has no dof {missing[0]} (used by no element)")
            if not dirs:
                raise InputError(f"{link.where}: dependent node {d} has none of the dofs "
                                 f"{', '.join(link.dirs or DIRECTIONS)} (it is used by no element)")
            r = _coords(s, d, link) - xi if xi is not None else None
            for x in dirs:
                lab = dof(d, x)
                if lab in rows:
                    raise InputError(f"dof {lab} is dependent twice: in {source[lab]} and in {link.where}; a dof may "
                                     "follow one constraint only")
                rows[lab] = _rigid_row(link.independent, x, r) if r is not None else [(dof(link.independent, x), 1.0)]
                source[lab] = link.where
    for lab, terms in rows.items():
        for ind, _ in terms:
            if ind in rows:
                raise InputError(f"constraints chained: dof {ind} is dependent in {source[ind]} and independent in "
                                 f"{source[lab]} (for {lab}); chains and loops of constraints are refused: link every "
                                 "dependent node straight to the final independent node")
    extra = {ind for terms in rows.values() for ind, _ in terms} - present
    return rows, source, extra


def supported_rows(rows: dict, source: dict, fixed: set[str]) -> None:
    """Drop (in place) the rows of supported dependent dofs whose independent dofs are all supported
    (both sides zero); refuse a supported dependent dof that would otherwise move."""
    for lab in [lab for lab in rows if lab in fixed]:
        free = [ind for ind, _ in rows[lab] if ind not in fixed]
        if free:
            raise InputError(f"dof {lab} is supported but is a dependent dof of {source[lab]}, which makes it follow "
                             f"{describe(free)} (free): the support and the constraint conflict; support the "
                             "independent node instead")
        del rows[lab]
        del source[lab]


# ---------------------------------------------------------------------- element-level helpers
def skew(r: np.ndarray) -> np.ndarray:
    """Cross-product matrices, ``skew(r) @ a = r × a``, for r of shape ``(..., 3)``."""
    r = np.asarray(r, dtype=float)
    S = np.zeros(r.shape[:-1] + (3, 3))
    S[..., 0, 1], S[..., 0, 2] = -r[..., 2], r[..., 1]
    S[..., 1, 0], S[..., 1, 2] = r[..., 2], -r[..., 0]
    S[..., 2, 0], S[..., 2, 1] = -r[..., 1], r[..., 0]
    return S


def offset_terms(terms, oa: np.ndarray, ob: np.ndarray):
    """A frame group's terms (computed between the offset ends) moved to its nodes: ``Eᵀ k E``
    per term, ``u_end = u_node + θ_node × o`` (12-dof stacks, nodes a and b)."""
    from .. import elements as el

    n = len(oa)
    E = np.broadcast_to(np.eye(12), (n, 12, 12)).copy()
    E[:, 0:3, 3:6] = -skew(oa)
    E[:, 6:9, 9:12] = -skew(ob)

    def move(lst):
        return [(f, np.einsum("eji,ejk,ekl->eil", E, A, E)) for f, A in lst]

    return el.ElementTerms(K=move(terms.K), M=move(terms.M))


def point_mass_terms(data: np.ndarray, n_dofs: int):
    """Point-mass stacks: ``data`` (n_el, 12) holds each offset r (3) and inertia J (9, row-major);
    ``n_dofs`` 3 (translations only) or 6."""
    from .. import elements as el

    n = len(data)
    if n_dofs == 3:
        return el.ElementTerms(K=[], M=[(("m",), np.broadcast_to(np.eye(3), (n, 3, 3)).copy())])
    S = skew(data[:, :3])
    unit = np.zeros((n, 6, 6))
    unit[:, :3, :3] = np.eye(3)
    unit[:, :3, 3:] = -S
    unit[:, 3:, :3] = S
    unit[:, 3:, 3:] = -S @ S
    J = np.zeros((n, 6, 6))
    J[:, 3:, 3:] = data[:, 3:].reshape(n, 3, 3)
    return el.ElementTerms(K=[], M=[(("m",), unit), ((), J)])


def add_point_mass(s, node, m, offset, inertia, where: str) -> None:
    """:meth:`Structure.point_mass`."""
    from ..dofs import node_id

    nd = node_id(node, f"{where}: node")
    r = np.zeros(3) if offset is None else np.asarray(offset, dtype=float)
    if r.shape != (3,) or not np.all(np.isfinite(r)):
        raise InputError(f"{where}: offset must be three finite numbers [dx, dy, dz], got {offset!r}")
    J = np.zeros((3, 3)) if inertia is None else np.asarray(inertia, dtype=float)
    if J.shape == (6,):  # I11, I21, I22, I31, I32, I33 (the lower triangle, row by row)
        a = J
        J = np.array([[a[0], a[1], a[3]], [a[1], a[2], a[4]], [a[3], a[4], a[5]]])
    if J.shape != (3, 3) or not np.all(np.isfinite(J)) or not np.allclose(J, J.T, rtol=0, atol=1e-12 * np.abs(J).max(initial=0)):
        raise InputError(f"{where}: inertia must be a symmetric 3x3 matrix or its six entries [J11, J21, J22, J31, J32, "
                         f"J33], finite, got {inertia!r}")
    if np.any(np.linalg.eigvalsh(J) < -1e-12 * np.abs(J).max(initial=0)):
        raise InputError(f"{where}: inertia is not positive semi-definite (eigenvalues {np.linalg.eigvalsh(J).round(12).tolist()})")
    full = bool(np.any(r != 0) or np.any(J != 0))
    dirs = DIRECTIONS if full else _TRANSLATIONS
    data = np.concatenate([r, J.ravel()])[None]
    s._add("point_mass", [[dof(nd, d) for d in dirs]], {"m": m}, where, data=data)


__all__ = ["Link", "add_link", "constraint_rows", "supported_rows", "skew", "offset_terms", "point_mass_terms",
           "add_point_mass"]
