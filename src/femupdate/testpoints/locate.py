r"""Where each test point lies on a mesh: the nearest node, or a point inside a shell face or a solid
element with the element's shape-function weights.

Test nodes (a universal file's datasets 15/2411) carry their own ids, which never refer to the
mesh's: a test point is placed on the mesh by its coordinates only.

* ``method="nearest"``: the mesh node nearest the point; its distance is the point's distance.
* ``method="interpolate"``: the point of the mesh's shells (``mitc4``, ``mitc3``) and solids
  (``hex8``, ``tet4``, ``tet10``) nearest the test point, as natural coordinates
  :math:`\xi` of one element: Gauss-Newton on :math:`|x(\xi) - p|^2` with
  :math:`x(\xi) = \sum_i N_i(\xi) X_i`, :math:`\xi` kept in the element's reference domain
  (square, cube or simplex), over the elements that hold one of the 8 mesh nodes nearest the
  point and those whose bounding box (widened by the tolerance) holds it.  The measured motion
  is then :math:`u(p) = \sum_i N_i(\xi)\, u_i` — the element's own interpolation (exact for
  a field the element represents exactly: a linear field in every element here).  A point on a
  shell's face at an offset (the surface of a plate of thickness t) lies at that offset from the
  mid-surface: the tolerance must cover it.

A point farther than ``tolerance`` (in the mesh's length unit) from the mesh is refused, naming
it and its distance.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy.spatial import cKDTree

from .._errors import InputError
from ..elements_3d.shells import _quad_shape, _tri_shape
from ..elements_3d.solids import hex8_shape, tet_shape
from ..structure.groups import SHELLS, SOLIDS

METHODS = ("interpolate", "nearest")
NEAREST_NODES = 8  # elements holding one of this many nearest nodes are searched
ITERATIONS = 30  # Gauss-Newton steps (bilinear and trilinear maps converge in a few)
WEIGHT_ZERO = 1e-12  # shape-function values below this (in magnitude) are dropped

# element type -> (shape functions of natural points (g, d) -> N (g, nn), dN (g, nn, d), d, simplex?)
_SHAPES = {
    "mitc4": (_quad_shape, 2, False),
    "mitc3": (_tri_shape, 2, True),
    "hex8": (hex8_shape, 3, False),
    "tet4": (lambda p: tet_shape(p, False), 3, True),
    "tet10": (lambda p: tet_shape(p, True), 3, True),
}


@dataclass(frozen=True)
class PointLink:
    """One test point placed on the mesh.

    Attributes
    ----------
    test_node : int or str
        The test node's id, as the test file numbers it.
    xyz : tuple of float
        Its coordinates (global axes, the mesh's length unit).
    kind : {"node", "element"}
        Mapped to one node (the nearest, or an element's node the point lies on), or
        interpolated in an element.
    mesh_nodes : tuple of int
        The mesh nodes its motion is made of (one for ``"node"``).
    weights : tuple of float
        Their weights (shape-function values; ``(1.0,)`` for ``"node"``), summing to 1.
    element : str
        The element (``"hex8 element 12"``, as the mesh names it), or ``""`` for ``"node"``.
    natural : tuple of float
        The point's natural coordinates in that element (empty for ``"node"``).
    distance : float
        Distance from the test point to where it is placed (mesh length unit).
    """

    test_node: int | str
    xyz: tuple[float, float, float]
    kind: str
    mesh_nodes: tuple[int, ...]
    weights: tuple[float, ...]
    element: str
    natural: tuple[float, ...]
    distance: float

    def to_json(self) -> dict:
        return {"test_node": self.test_node, "xyz": list(self.xyz), "kind": self.kind,
                "mesh_nodes": list(self.mesh_nodes), "weights": list(self.weights), "element": self.element,
                "natural": list(self.natural), "distance": self.distance}


@dataclass(frozen=True)
class PointMap:
    """Every test point's place on the mesh (:func:`locate_points`).

    Attributes
    ----------
    links : tuple of PointLink
        One per test point, in the order given.
    method : {"interpolate", "nearest"}
    tolerance : float
        The largest distance accepted (mesh length unit).
    """

    links: tuple[PointLink, ...]
    method: str
    tolerance: float

    def link(self, node) -> PointLink:
        """The link of test node ``node``."""
        for lk in self.links:
            if lk.test_node == node:
                return lk
        raise InputError(f"test node {node!r} has no coordinates: give it in the test file's geometry "
                         "(dataset 15 or 2411)")

    def to_json(self) -> dict:
        """``{"method", "tolerance", "largest_distance", "points": [...]}`` for results."""
        d = max((lk.distance for lk in self.links), default=0.0)
        return {"method": self.method, "tolerance": self.tolerance, "largest_distance": d,
                "points": [lk.to_json() for lk in self.links]}


def _clamp(xi: np.ndarray, simplex: bool) -> np.ndarray:
    if not simplex:
        return np.clip(xi, -1.0, 1.0)
    xi = np.maximum(xi, 0.0)
    s = xi.sum(axis=1, keepdims=True)
    return np.where(s > 1.0, xi / np.where(s > 0, s, 1.0), xi)


def closest_in_elements(kind: str, X: np.ndarray, p: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The point of each element nearest ``p``: natural coordinates, shape-function values, distance.

    Parameters
    ----------
    kind : {"mitc4", "mitc3", "hex8", "tet4", "tet10"}
        The element type.
    X : ndarray, shape ``(c, nn, 3)``
        Node coordinates of ``c`` elements of that type.
    p : ndarray, shape ``(3,)``
        The point.

    Returns
    -------
    xi : ndarray, shape ``(c, d)``
        Natural coordinates (``d`` = 2 for shells, 3 for solids), in the reference domain.
    N : ndarray, shape ``(c, nn)``
        Shape functions at ``xi``.
    distance : ndarray, shape ``(c,)``
        ``|x(xi) - p|``: 0 for a point inside; for a point outside, the distance to the point
        reached (the nearest point of the element's boundary, or an upper bound of it).
    """
    shape, d, simplex = _SHAPES[kind]
    xi = np.full((len(X), d), 1.0 / (d + 1) if simplex else 0.0)
    for _ in range(ITERATIONS):
        N, dN = shape(xi)
        r = np.einsum("cn,cnk->ck", N, X) - p
        J = np.einsum("cnk,cnj->ckj", X, dN)  # dx/dxi, (c, 3, d)
        JtJ = np.einsum("ckj,cki->cji", J, J)
        g = np.einsum("ckj,ck->cj", J, r)
        step = -np.linalg.solve(JtJ + 1e-300 * np.eye(d), g[..., None])[..., 0]
        new = _clamp(xi + step, simplex)
        if np.max(np.abs(new - xi), initial=0.0) < 1e-14:
            xi = new
            break
        xi = new
    N, _ = shape(xi)
    dist = np.linalg.norm(np.einsum("cn,cnk->ck", N, X) - p, axis=1)
    return xi, N, dist


def _element_sets(structure) -> list[tuple[str, np.ndarray, list[str]]]:
    """``(type, node ids (n_el, nn), names)`` of every shell and solid group."""
    out = []
    for g in structure.groups:
        if g.type in SHELLS or g.type in SOLIDS:
            conn = np.asarray(g.nodes, dtype=np.int64)
            names = [w if w else f"{g.type} element {i + 1}" for i, w in
                     enumerate(g.where if len(g.where) == len(conn) else [""] * len(conn))]
            out.append((g.type, conn, names))
    return out


def _node_table(structure) -> tuple[np.ndarray, np.ndarray]:
    used = sorted({int(n) for g in structure.groups if g.nodes is not None for n in np.ravel(g.nodes)}
                  & set(structure.nodes))
    ids = np.array(used if used else sorted(structure.nodes), dtype=np.int64)
    if not len(ids):
        raise InputError(f"structure {structure.name!r} has no node coordinates: test points cannot be placed on it")
    return ids, np.array([structure.nodes[int(i)] for i in ids], dtype=float)


def _interpolate(structure, ids, xyz, points, tolerance: float) -> list[tuple]:
    sets = _element_sets(structure)
    if not sets:
        raise InputError(f"structure {structure.name!r} has no shell or solid elements to interpolate in; map the "
                         "test points to the nearest nodes (method 'nearest')")
    tree = cKDTree(xyz)
    pos = {int(i): k for k, i in enumerate(ids)}
    incid, boxes, coords = [], [], []
    for _, conn, _ in sets:  # node position -> elements holding it; each element's box, widened by the tolerance
        rows = np.array([pos.get(int(n), -1) for n in conn.ravel()]).reshape(conn.shape)
        el = np.repeat(np.arange(len(conn)), conn.shape[1])
        ok = rows.ravel() >= 0
        incid.append(sp.csr_array((np.ones(ok.sum()), (rows.ravel()[ok], el[ok])), shape=(len(ids), len(conn))))
        X = np.array([[structure.nodes[int(n)] for n in row] for row in conn], dtype=float).reshape(*conn.shape, 3)
        coords.append(X)
        boxes.append((X.min(axis=1) - tolerance, X.max(axis=1) + tolerance))
    out: list[tuple] = []
    for p in points:
        _, near = tree.query(p, k=min(NEAREST_NODES, len(ids)))
        near = np.atleast_1d(near)
        best: tuple | None = None
        for (kind, conn, names), inc, (lo, hi), X in zip(sets, incid, boxes, coords):
            inside = np.flatnonzero(np.all((lo <= p) & (p <= hi), axis=1))  # elements the point may lie in
            cand = np.union1d(inc[near].tocoo().col, inside)
            if not len(cand):
                continue
            xi, N, dist = closest_in_elements(kind, X[cand], p)
            k = int(np.argmin(dist))
            if best is None or dist[k] < best[-1]:
                best = (kind, conn[cand[k]], names[cand[k]], xi[k], N[k], float(dist[k]))
        if best is None:
            d, k = tree.query(p)
            out.append(("node", (int(ids[k]),), (1.0,), "", (), float(d)))
            continue
        kind, nodes, name, xi, N, dist = best
        keep = np.abs(N) > WEIGHT_ZERO
        w = N[keep] / N[keep].sum()
        out.append(("node" if keep.sum() == 1 else "element", tuple(int(n) for n in nodes[keep]),
                    tuple(float(v) for v in w), name if name.startswith(kind) else f"{kind} {name}",
                    tuple(float(v) for v in xi), dist))
    return out


def locate_points(structure, points: Mapping, tolerance: float, method: str = "interpolate") -> PointMap:
    """Place test points on a structure's mesh (module docstring).

    Parameters
    ----------
    structure : Structure
        With node coordinates (and shells or solids for ``"interpolate"``).
    points : mapping of node to (x, y, z)
        Test node id -> coordinates in the global axes and the mesh's length unit (a universal
        file's ``TestData.nodes``, coordinate systems already applied).
    tolerance : float
        Largest distance accepted, > 0, in the mesh's length unit.
    method : {"interpolate", "nearest"}, default "interpolate"

    Returns
    -------
    PointMap

    Raises
    ------
    InputError
        An unknown method, a tolerance that is not a positive number, no test points, a
        structure without coordinates (or without shells and solids for ``"interpolate"``), test
        points farther than ``tolerance`` from the mesh (named with their distance).
    """
    if method not in METHODS:
        raise InputError(f"test points: method must be one of {', '.join(METHODS)}, got {method!r}")
    if isinstance(tolerance, bool) or not isinstance(tolerance, (int, float)) or not math.isfinite(tolerance) \
            or tolerance <= 0:
        raise InputError(f"test points: the tolerance must be a positive number (a length), got {tolerance!r}")
    if not points:
        raise InputError("test points: the test data give no node coordinates (datasets 15 or 2411)")
    names = list(points)
    P = np.array([points[n] for n in names], dtype=float).reshape(len(names), 3)
    if not np.all(np.isfinite(P)):
        bad = [names[i] for i in np.flatnonzero(~np.isfinite(P).all(axis=1))]
        raise InputError(f"test points: node(s) {bad[:8]} have non-finite coordinates")
    ids, xyz = _node_table(structure)
    if method == "nearest":
        d, k = cKDTree(xyz).query(P)
        placed: list[tuple] = [("node", (int(ids[j]),), (1.0,), "", (), float(dd)) for dd, j in zip(d, k)]
    else:
        placed = _interpolate(structure, ids, xyz, P, float(tolerance))
    links = tuple(PointLink(n, (float(P[i, 0]), float(P[i, 1]), float(P[i, 2])), *placed[i]) for i, n in enumerate(names))
    far = [lk for lk in links if lk.distance > tolerance]
    if far:
        shown = "; ".join(f"test node {lk.test_node} at ({', '.join(f'{v:.6g}' for v in lk.xyz)}): {lk.distance:.4g} "
                          f"from {'node ' + str(lk.mesh_nodes[0]) if lk.kind == 'node' else lk.element}"
                          for lk in far[:8])
        raise InputError(f"test points farther than the tolerance {tolerance:g} from the mesh "
                         f"({len(far)} of {len(links)}): {shown}{' …' if len(far) > 8 else ''}")
    return PointMap(links, method, float(tolerance))


__all__ = ["METHODS", "PointLink", "PointMap", "closest_in_elements", "locate_points"]
