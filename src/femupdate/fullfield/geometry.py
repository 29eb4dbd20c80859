r"""The model's geometry seen by a scan: nodes, line segments, intrinsic coordinates, distances,
and the rotations that follow from measured translations (small rotations: :math:`u = \theta \times r`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy.spatial import cKDTree

from .._errors import InputError
from ..dofs import parse_dof
from .scan import AXES


@dataclass(frozen=True, eq=False)
class Geometry:
    """Nodes, element segments and intrinsic coordinates of a model.

    Built by :func:`model_geometry`; each parameter is stored as the attribute of the same name.

    Parameters
    ----------
    node_ids : ndarray of int, shape ``(n_nodes,)``
        Node ids, sorted.
    xyz : ndarray, shape ``(n_nodes, 3)``
        Node coordinates, in the order of ``node_ids``.
    segments : ndarray of int, shape ``(s, 2)``
        Pairs of node ids (the line elements).
    centre : ndarray, shape ``(3,)``
        Mean of the node coordinates.
    basis : ndarray, shape ``(3, d)``
        Orthonormal directions spanning the structure's ``dim = d`` intrinsic directions (1 line,
        2 surface, 3 solid) around ``centre``.
    length : float
        Largest extent of the nodes along a global axis (the unit of the normalised intrinsic
        coordinates).
    """

    node_ids: np.ndarray
    xyz: np.ndarray
    segments: np.ndarray
    centre: np.ndarray
    basis: np.ndarray
    length: float

    @property
    def dim(self) -> int:
        return self.basis.shape[1]

    def intrinsic(self, x: np.ndarray) -> np.ndarray:
        """Normalised intrinsic coordinates of points: ``(x − centre) @ basis / length``.

        Parameters
        ----------
        x : array_like, shape ``(..., 3)``
            Global coordinates, in the model's length unit.

        Returns
        -------
        numpy.ndarray, shape ``(..., dim)``
            Coordinates along the ``basis`` directions, divided by ``length`` (dimensionless).
        """
        return (np.asarray(x, float) - self.centre) @ self.basis / self.length

    def ends(self) -> tuple[np.ndarray, np.ndarray]:
        """Coordinates of the segments' first and second nodes."""
        pos = {int(i): k for k, i in enumerate(self.node_ids)}
        a = self.xyz[[pos[int(i)] for i in self.segments[:, 0]]].reshape(-1, 3)
        b = self.xyz[[pos[int(i)] for i in self.segments[:, 1]]].reshape(-1, 3)
        return a, b

    def longest_element(self) -> float:
        if not len(self.segments):
            return 0.0
        a, b = self.ends()
        return float(np.max(np.linalg.norm(b - a, axis=1)))


class Segments(np.ndarray):
    """Node-id pairs ``(s, 2)`` of a structure's element edges (:func:`structure_segments`), carrying
    ``faces``: the node-id polygons of its shells and the outer faces of its solids, which mode-shape
    figures draw as surfaces (a plain array of pairs draws edges only)."""

    faces: list

    def __array_finalize__(self, obj) -> None:
        self.faces = getattr(obj, "faces", [])


#: the faces of each solid element type, as positions in its node list (corner nodes)
SOLID_FACES = {"hex8": ((0, 3, 2, 1), (4, 5, 6, 7), (0, 1, 5, 4), (1, 2, 6, 5), (2, 3, 7, 6), (3, 0, 4, 7)),
               "tet4": ((0, 2, 1), (0, 1, 3), (1, 2, 3), (0, 3, 2))}
SOLID_FACES["tet10"] = SOLID_FACES["tet4"]


def structure_faces(structure) -> list:
    """The node-id polygons of a structure's shells (each element) and solids (the faces that
    belong to one element only: the outer surface)."""
    faces: list = []
    solid: dict[tuple, tuple] = {}
    for g in structure.groups:
        if g.nodes is None:
            continue
        nodes = np.asarray(g.nodes, dtype=np.int64)
        if g.type in ("mitc4", "mitc3"):
            faces.extend(tuple(map(int, row)) for row in nodes)
        elif g.type in SOLID_FACES:
            for row in nodes:
                for f in SOLID_FACES[g.type]:
                    poly = tuple(int(row[i]) for i in f)
                    key = tuple(sorted(poly))
                    if key in solid:
                        solid[key] = ()  # shared by two elements: inside
                    else:
                        solid[key] = poly
    return faces + [p for p in solid.values() if p]


def structure_segments(structure) -> np.ndarray:
    """Node pairs of every line element (and the edges of shells and solids, and the rigid links and
    ties) of a :class:`~femupdate.Structure`, supported ends included.

    Parameters
    ----------
    structure : Structure
        The structure; groups without node pairs (``nodes`` None) are skipped.

    Returns
    -------
    Segments (an ndarray of int, shape ``(s, 2)``)
        Unique pairs, each sorted (smaller id first); its ``faces`` are the shells' and the solids'
        outer faces (:func:`structure_faces`), drawn as surfaces by the mode-shape figures.
    """
    from ..structure.groups import node_pairs

    pairs = [node_pairs(g) for g in structure.groups if g.nodes is not None]
    links = [(c.independent, d) for c in getattr(structure, "constraints", ()) for d in c.dependent
             if isinstance(c.independent, int) and isinstance(d, int)]  # rigid links and ties, drawn as members
    if links:
        pairs.append(np.array(links, np.int64))
    arr = np.unique(np.sort(np.concatenate(pairs), axis=1), axis=0) if pairs else np.zeros((0, 2), np.int64)
    out: Segments = arr.view(Segments)
    out.faces = structure_faces(structure)
    return out


def model_geometry(model, segments=None) -> Geometry:
    """The model's nodes with coordinates and its element segments.

    Parameters
    ----------
    model : Model
        With node coordinates (``model.nodes``) for every node that has dofs.
    segments : array_like of int, shape ``(s, 2)``, optional
        Node-id pairs of the line elements (:func:`structure_segments`); by default the pairs of
        nodes the stiffness (K0 and every dK) couples (elements with a fully supported end are then
        missing: give ``segments`` for them).

    Returns
    -------
    Geometry

    Raises
    ------
    InputError
        The model has no node coordinates, nodes with dofs lack coordinates, ``segments`` names a node
        without coordinates, or the nodes do not span a line, surface or volume.
    """
    if not model.nodes:
        raise InputError(f"model {model.name!r} has no node coordinates: full-field data need the geometry")
    nodes_of_dofs = [parse_dof(d)[0] for d in model.dofs]
    named = list(dict.fromkeys(nd for nd in nodes_of_dofs if isinstance(nd, str)))
    if named:
        raise InputError(f"model {model.name!r}: named node(s) {', '.join(map(repr, named[:8]))} have dofs but no "
                         "coordinates (full-field data are mapped onto the [[node]] coordinates, whose ids are integers)")
    dof_nodes = np.array(nodes_of_dofs, dtype=np.int64)
    missing = sorted({int(nd) for nd in dof_nodes if int(nd) not in model.nodes})
    if missing:
        raise InputError(f"model {model.name!r}: node(s) {missing[:8]} have dofs but no coordinates")
    ids = np.array(sorted(model.nodes), dtype=np.int64)
    xyz = np.array([model.nodes[int(i)] for i in ids], dtype=float)
    if segments is None:
        pattern = abs(model.K0).tocoo()
        for A in (*model.dK, *(t.K for t in getattr(model, "terms", ()))):  # non-linear terms too
            if A is not None:
                pattern = pattern + abs(A).tocoo()
        pattern = sp.coo_array(pattern)
        a, b = dof_nodes[pattern.row], dof_nodes[pattern.col]
        keep = (a < b) & np.isin(a, ids) & np.isin(b, ids)
        segs = np.unique(np.column_stack([a[keep], b[keep]]), axis=0) if np.any(keep) else np.zeros((0, 2), np.int64)
    else:
        segs = np.asarray(segments, dtype=np.int64).reshape(-1, 2)
        unknown = sorted({int(i) for i in segs.ravel() if int(i) not in model.nodes})
        if unknown:
            raise InputError(f"segments: node(s) {unknown[:8]} have no coordinates in model {model.name!r}")
    centre = xyz.mean(axis=0)
    _, s, Vt = np.linalg.svd(xyz - centre, full_matrices=False)
    length = float(np.max(np.ptp(xyz, axis=0))) if len(xyz) > 1 else 1.0
    dim = int(np.sum(s > 1e-8 * max(s[0], 1e-300))) if len(xyz) > 1 else 0
    if dim == 0:
        raise InputError(f"model {model.name!r}: its nodes do not span a line, surface or volume")
    return Geometry(ids, xyz, segs, centre, Vt[:dim].T, max(length, 1e-300))


def distance_to_geometry(geom: Geometry, points: np.ndarray, chunk: int = 2048):
    """Distance of points to the geometry (nearest node or segment), nearest segment and position on it.

    Parameters
    ----------
    geom : Geometry
        The model's geometry.
    points : array_like, shape ``(n_points, 3)``
        Point coordinates (same frame and units as the nodes).
    chunk : int, default 2048
        Points processed at a time (memory ``chunk * s * 3``).

    Returns
    -------
    distance : ndarray, shape ``(n_points,)``
        Distance to the nearest node or segment.
    segment : ndarray of int, shape ``(n_points,)``
        Index of the nearest segment (-1 if the geometry has none).
    along : ndarray, shape ``(n_points,)``
        Position on that segment, in [0, 1] from its first node.
    """
    pts = np.asarray(points, float)
    best, _ = cKDTree(geom.xyz).query(pts)
    which = np.full(len(pts), -1, dtype=np.int64)
    along = np.zeros(len(pts))
    if len(geom.segments):
        A, B = geom.ends()
        D = B - A
        dd = np.einsum("ij,ij->i", D, D)
        for s in range(0, len(pts), chunk):
            P = pts[s:s + chunk, None, :] - A[None, :, :]  # (p, segs, 3)
            t = np.clip(np.einsum("psk,sk->ps", P, D) / np.where(dd > 0, dd, 1.0), 0.0, 1.0)
            dist = np.linalg.norm(P - t[..., None] * D[None], axis=2)
            k = np.argmin(dist, axis=1)
            rows = np.arange(len(k))
            which[s:s + chunk] = k
            along[s:s + chunk] = t[rows, k]
            best[s:s + chunk] = np.minimum(best[s:s + chunk], dist[rows, k])
    return best, which, along


# ------------------------------------------------------------------------------ rotations
def _cross_matrix(e: np.ndarray) -> np.ndarray:
    """[e]_x with [e]_x g = e x g."""
    return np.array([[0.0, -e[2], e[1]], [e[2], 0.0, -e[0]], [-e[1], e[0], 0.0]])


def rotation_operators(geom: Geometry, components) -> dict[str, np.ndarray]:
    r"""Per measured component c, the 3x3 matrix G_c with :math:`\theta = \sum_c G_c \nabla u_c`.

    Gradients in global coordinates, within the structure's tangent space (module docstring of
    :mod:`femupdate.fullfield.mapping`, step 3): on a line :math:`\nabla u_c \times e_c`; on a surface
    with normal n the normal part :math:`(e_c\cdot n)\,\nabla u_c\times n` plus half the drilling
    rotation from the in-plane part; in a solid half the curl.

    Parameters
    ----------
    geom : Geometry
        The geometry (its ``dim`` and, on a surface, its ``basis``).
    components : iterable of {"x", "y", "z"}
        The measured translation components.

    Returns
    -------
    dict of str to ndarray, shape ``(3, 3)``
        G_c per component.
    """
    out = {}
    if geom.dim == 1:
        for c in components:
            out[c] = -_cross_matrix(AXES[c])  # g x e_c = -e_c x g
    elif geom.dim == 2:
        n = np.cross(geom.basis[:, 0], geom.basis[:, 1])
        n /= np.linalg.norm(n)
        for c in components:
            e = AXES[c]
            en = float(e @ n)
            et = e - en * n
            # normal part: en * (g x n); in-plane part: 1/2 n n.(g x e_t)
            out[c] = -en * _cross_matrix(n) + 0.5 * np.outer(n, n) @ (-_cross_matrix(et))
    else:
        for c in components:
            out[c] = -0.5 * _cross_matrix(AXES[c])
    return out


def inferable_rotations(geom: Geometry, components) -> list[str]:
    """Rotation directions (``rx``, ``ry``, ``rz``) the measured components determine.

    A direction counts when its global axis lies in the span of ``G_c T`` (:func:`rotation_operators`,
    T the projector onto the tangent space).

    Parameters
    ----------
    geom : Geometry
        The geometry.
    components : sequence of {"x", "y", "z"}
        The measured translation components.

    Returns
    -------
    list of str
        Subset of ``["rx", "ry", "rz"]``, in that order.
    """
    G = rotation_operators(geom, components)
    T = geom.basis @ geom.basis.T  # gradients lie in the tangent space
    span = np.hstack([G[c] @ T for c in components]) if components else np.zeros((3, 0))
    U, s, _ = np.linalg.svd(span)
    Q = U[:, : int(np.sum(s > 1e-9))]
    out = []
    for r, e in (("rx", AXES["x"]), ("ry", AXES["y"]), ("rz", AXES["z"])):
        if np.linalg.norm(e - Q @ (Q.T @ e)) < 1e-8:
            out.append(r)
    return out
