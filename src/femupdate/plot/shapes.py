"""Mode shapes on the model's geometry: a wireframe of the nodes and elements, deformed over
undeformed, with a measured shape drawn at its sensors.

Rods, beams, frames and lumped models whose nodes have coordinates are drawn on their geometry
(in 3-D when the structure or its motion leaves a plane, else in its plane); the translations of
each node displace it.  A member whose ends carry rotations (beams, frames; a fully supported end
counts as clamped) is drawn as the cubic curve that its end translations and rotations give;
other members (rods, springs) as straight lines.  A model without node coordinates (a lumped spring-mass chain) has no
geometry to draw on: its shape is drawn against its dofs in model order, and the title says so.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import scipy.sparse as sp  # noqa: E402

from .._docs import PLOT_DOCS, shared_docs  # noqa: E402
from ..dofs import parse_dof  # noqa: E402

_AXES = {"x": 0, "y": 1, "z": 2}
#: the title's note when a model has no node coordinates
NO_GEOMETRY = "no node coordinates: drawn against the dofs in model order"


@dataclass(frozen=True)
class ShapeGeometry:
    """What a mode shape is drawn on.

    Attributes
    ----------
    node_ids : tuple
        Nodes with coordinates, sorted.
    xyz : numpy.ndarray, shape ``(n_nodes, 3)``
        Their coordinates (the model's length unit, m in SI).
    segments : numpy.ndarray of int, shape ``(s, 2)``
        Element segments as row indices into ``xyz``.
    """

    node_ids: tuple
    xyz: np.ndarray
    segments: np.ndarray

    @property
    def extent(self) -> float:
        """Largest extent of the nodes along a global axis (1 for a single point)."""
        ext = float(np.max(np.ptp(self.xyz, axis=0))) if len(self.xyz) > 1 else 0.0
        return ext if ext > 0 else 1.0


def shape_geometry(model, segments=None) -> ShapeGeometry | None:
    """The nodes and element segments a shape of ``model`` is drawn on, or None without geometry.

    Parameters
    ----------
    model : Model
        With node coordinates (``model.nodes``) for the nodes that carry translations.
    segments : array_like of int, shape ``(s, 2)``, optional
        Node-id pairs of the elements (e.g. :func:`femupdate.fullfield.structure_segments`, which
        includes elements with a supported end); by default the pairs of nodes that the
        stiffness matrices couple (an element to a fully supported node is then not drawn).

    Returns
    -------
    ShapeGeometry or None
        None when the model has no node coordinates, or a node with translations has none.
    """
    if not model.nodes:
        return None
    node_of = [parse_dof(d)[0] for d in _all_dofs(model)]
    dirs = [parse_dof(d)[1] for d in _all_dofs(model)]
    moving = {nd for nd, dr in zip(node_of, dirs) if dr in _AXES}
    if not moving or any(nd not in model.nodes for nd in moving):
        return None
    ids = tuple(sorted(model.nodes))
    pos = {nd: k for k, nd in enumerate(ids)}
    xyz = np.array([model.nodes[i] for i in ids], float).reshape(-1, 3)
    if segments is None:
        pattern = abs(sp.coo_array(model.K0))
        for A in (*model.dK, *(t.K for t in getattr(model, "terms", ()))):  # non-linear terms too
            if A is not None:
                pattern = pattern + abs(sp.coo_array(A))
        coo = sp.coo_array(pattern)
        pairs = {(pos[node_of[r]], pos[node_of[c]]) for r, c in zip(coo.row, coo.col)
                 if node_of[r] in pos and node_of[c] in pos and node_of[r] != node_of[c]}
        dep = getattr(model, "constraints", None)
        if dep is not None:  # a rigid link drawn from each dependent node to the nodes it follows
            R = sp.coo_array(dep.R)
            n = len(model.dofs)
            pairs |= {(pos[node_of[n + r]], pos[node_of[c]]) for r, c in zip(R.row, R.col)
                      if node_of[n + r] in pos and node_of[c] in pos and node_of[n + r] != node_of[c]}
        segs = np.array(sorted({tuple(sorted(p)) for p in pairs}), dtype=np.int64).reshape(-1, 2)
    else:
        raw = np.asarray(segments).reshape(-1, 2)
        segs = np.array([(pos[a], pos[b]) for a, b in raw.tolist() if a in pos and b in pos],
                        dtype=np.int64).reshape(-1, 2)
    return ShapeGeometry(ids, xyz, segs)


def _real(values: np.ndarray) -> np.ndarray:
    """A real shape: a complex one turned so that its largest entry is real, then its real part."""
    v = np.asarray(values)
    if np.iscomplexobj(v):
        k = int(np.argmax(np.abs(v)))
        v = (v * np.exp(-1j * np.angle(v[k]))).real
    return np.asarray(v, float)


def _all_dofs(model) -> tuple[str, ...]:
    """The model's dofs and those its constraints eliminated (:mod:`femupdate.constraints`)."""
    dep = getattr(model, "constraints", None)
    return tuple(model.dofs) + (dep.labels if dep is not None else ())


def _model_shape(model, shape) -> dict[str, float]:
    """A model shape as {dof: value}, the dofs its constraints eliminated recovered."""
    dep = getattr(model, "constraints", None)
    if dep is not None and shape is not None and not isinstance(shape, Mapping):
        v = np.asarray(shape)
        if v.shape == (len(model.dofs),):
            labels, full = dep.expand(model.dofs, v)
            return _as_dict(full, labels)
    return _as_dict(shape, model.dofs)


def _as_dict(shape, dofs) -> dict[str, float]:
    if shape is None:
        return {}
    if isinstance(shape, Mapping):
        keys = list(shape)
        vals = _real(np.array([shape[k] for k in keys]))
        return dict(zip(keys, vals.tolist()))
    vals = _real(np.asarray(shape))
    if vals.shape != (len(dofs),):
        raise ValueError(f"shape has {vals.size} values; the model has {len(dofs)} dofs (give a {{dof: value}} mapping "
                         "for a partial shape)")
    return dict(zip(dofs, vals.tolist()))


def _fit(test: dict, model_shape: dict) -> float:
    """The factor that brings ``test`` closest to ``model_shape`` on their common dofs (least
    squares, sign included); 1/max|test| without common dofs or without a model shape."""
    common = [d for d in test if d in model_shape]
    t = np.array([test[d] for d in common])
    m = np.array([model_shape[d] for d in common])
    if common and t @ t > 0 and np.any(m):
        return float(m @ t / (t @ t))
    peak = max((abs(v) for v in test.values()), default=0.0)
    peak_m = max((abs(v) for v in model_shape.values()), default=0.0)
    return (peak_m or 1.0) / peak if peak > 0 else 1.0


def _displacements(geom: ShapeGeometry, shape: dict) -> tuple[np.ndarray, np.ndarray]:
    """Per node of ``geom``: translation (n, 3) and whether any translation of it is given."""
    pos = {nd: k for k, nd in enumerate(geom.node_ids)}
    u = np.zeros((len(geom.node_ids), 3))
    seen = np.zeros(len(geom.node_ids), bool)
    for d, v in shape.items():
        nd, dr = parse_dof(d)
        if dr in _AXES and nd in pos:
            u[pos[nd], _AXES[dr]] = v
            seen[pos[nd]] = True
    return u, seen


_ROT = {"rx": 0, "ry": 1, "rz": 2}


def _rotations(geom: ShapeGeometry, shape: dict) -> np.ndarray:
    """Per node of ``geom``: the rotation vector (n, 3) of ``shape`` (zero where none is given)."""
    pos = {nd: k for k, nd in enumerate(geom.node_ids)}
    th = np.zeros((len(geom.node_ids), 3))
    for d, v in shape.items():
        nd, dr = parse_dof(d)
        if dr in _ROT and nd in pos:
            th[pos[nd], _ROT[dr]] = v
    return th


def member_points(xa, xb, ua, ub, ta=None, tb=None, scale: float = 1.0, n: int = 9) -> np.ndarray:
    """Points of a deformed member: straight between its moved ends, or — given the end rotations
    — the cubic (Hermite) curve a beam takes, its transverse displacement from the end
    translations and slopes ``du/ds = θ × e`` (small rotations θ, member direction e), its axial
    displacement linear.

    Parameters
    ----------
    xa, xb : array_like, shape ``(3,)``
        End coordinates.
    ua, ub : array_like, shape ``(3,)``
        End translations.
    ta, tb : array_like, shape ``(3,)``, optional
        End rotation vectors (rad); None: a straight member.
    scale : float
        Drawing factor of the displacements.
    n : int
        Points along a curved member.

    Returns
    -------
    numpy.ndarray, shape ``(2, 3)`` or ``(n, 3)``
    """
    xa, xb, ua, ub = (np.asarray(v, float) for v in (xa, xb, ua, ub))
    if ta is None or tb is None:
        return np.array([xa + scale * ua, xb + scale * ub])
    d = xb - xa
    L = float(np.linalg.norm(d))
    if L == 0:
        return np.array([xa + scale * ua, xb + scale * ub])
    e = d / L
    xi = np.linspace(0.0, 1.0, n)[:, None]
    P = np.eye(3) - np.outer(e, e)
    h1, h2, h3, h4 = 1 - 3 * xi**2 + 2 * xi**3, xi - 2 * xi**2 + xi**3, 3 * xi**2 - 2 * xi**3, -xi**2 + xi**3
    trans = h1 * (P @ ua) + h2 * L * np.cross(np.asarray(ta, float), e) + h3 * (P @ ub) \
        + h4 * L * np.cross(np.asarray(tb, float), e)
    axial = ((1 - xi) * (ua @ e) + xi * (ub @ e)) * e
    return xa + xi * d + scale * (axial + trans)


def _rotation_nodes(model, geom: ShapeGeometry) -> np.ndarray:
    """Per node of ``geom``: whether the model has a rotation dof there."""
    have = {parse_dof(d)[0] for d in _all_dofs(model) if parse_dof(d)[1] in _ROT}
    return np.array([nd in have for nd in geom.node_ids])


def _moving_nodes(model, geom: ShapeGeometry) -> np.ndarray:
    """Per node of ``geom``: whether the model has any dof there (a fully supported node has none)."""
    have = {parse_dof(d)[0] for d in _all_dofs(model)}
    return np.array([nd in have for nd in geom.node_ids])


def _wants_3d(geom: ShapeGeometry, motions) -> bool:
    z = np.ptp(geom.xyz[:, 2]) if len(geom.xyz) > 1 else 0.0
    return bool(z > 1e-12 * geom.extent or any(np.any(u[:, 2] != 0) for u in motions))


def needs_3d(model, shape=None, test=None, segments=None) -> bool:
    """Whether a shape of ``model`` is drawn in 3-D: its nodes, or the translations of ``shape``
    or ``test``, leave the x-y plane (False without node coordinates)."""
    geom = shape_geometry(model, segments)
    if geom is None:
        return False
    motions = [_displacements(geom, _model_shape(model, s))[0] for s in (shape, test) if s is not None]
    return _wants_3d(geom, motions)


@shared_docs(**PLOT_DOCS)
def mode_shape_axes(model, shape=None, test=None, *, segments=None, scale=None, ax=None, title=None,
                    projection: str = "auto", labels=("model", "test")):
    """A mode shape on the model's geometry: the deformed wireframe over the undeformed one, and a
    measured shape as markers at its sensors.

    Parameters
    ----------
    model : Model
        The model; its node coordinates (``model.nodes``, m in SI) give the geometry.
    shape : array_like of shape ``(n_dofs,)`` or mapping of str to float, optional
        The model's shape, ordered as ``model.dofs`` or as {dof: value}; complex values are
        turned so that the largest is real and drawn by their real part.
    test : mapping of str to float, optional
        A measured shape {dof: value} at its sensors; scaled (sign included) to fit ``shape`` on
        their common dofs by least squares, and drawn as markers at the nodes it displaces (with
        its unmeasured directions at zero), joined along the elements whose two ends were
        measured.
    segments : array_like of int, shape ``(s, 2)``, optional
        Node-id pairs of the elements (:func:`shape_geometry`).
    scale : float, optional
        Drawing factor of the displacements (default: the largest is 10 % of the structure's
        extent).
    ax : matplotlib.axes.Axes, optional
        Axes to draw on (a 3-D one draws in 3-D); default a new figure, in 3-D when the structure
        or the motion leaves the x-y plane.
    title : str, optional
        Axes title (a model without node coordinates gets the note :data:`NO_GEOMETRY` added).
    projection : {"auto", "2d", "3d"}, default "auto"
        The view of a new figure.
    labels : (str, str), default ("model", "test")
        Legend labels of the two shapes.

    {{AX_RETURNED}}
        The axes drawn on.

    Raises
    ------
    ValueError
        Neither ``shape`` nor ``test`` given; ``shape`` of the wrong length; an unknown
        ``projection``.
    """
    if projection not in ("auto", "2d", "3d"):
        raise ValueError(f"projection must be 'auto', '2d' or '3d', got {projection!r}")
    mshape = _model_shape(model, shape)
    tshape = _as_dict(test, model.dofs)
    if not mshape and not tshape:
        raise ValueError("give a model shape, a test shape or both")
    if tshape:
        alpha = _fit(tshape, mshape)
        tshape = {d: alpha * v for d, v in tshape.items()}
    geom = shape_geometry(model, segments)
    if geom is None:
        return _chain_axes(model, mshape, tshape, ax, title, labels)
    um, _ = _displacements(geom, mshape)
    ut, measured = _displacements(geom, tshape)
    peak = max(float(np.max(np.linalg.norm(um, axis=1))), float(np.max(np.linalg.norm(ut, axis=1))))
    s = scale if scale is not None else (0.1 * geom.extent / peak if peak > 0 else 1.0)
    if ax is None:
        three = projection == "3d" or (projection == "auto" and _wants_3d(geom, (um, ut)))
        fig = plt.figure(figsize=(6, 4.5) if three else (6, 3.8))
        ax = fig.add_subplot(projection="3d") if three else fig.add_subplot()
    three = getattr(ax, "name", "") == "3d"
    cols = slice(0, 3) if three else slice(0, 2)
    moving = _moving_nodes(model, geom)

    def draw(polylines, label, **kw):
        """All members as one collection (fast for thousands of elements)."""
        if three:
            from mpl_toolkits.mplot3d.art3d import Line3DCollection

            ax.add_collection3d(Line3DCollection(polylines, label=label, **kw))
        else:
            from matplotlib.collections import LineCollection

            ax.add_collection(LineCollection(polylines, label=label, **kw))

    straight = [geom.xyz[[a, b], cols] for a, b in geom.segments]
    if straight:
        draw(straight, "undeformed", colors="0.65", linewidths=0.9, linestyles="--")
    ax.plot(*geom.xyz[:, cols].T, ".", color="0.55", ms=3, label=None if straight else "undeformed")
    if mshape:
        deformed = geom.xyz + s * um
        shaded = three and _surfaces(ax, geom, getattr(segments, "faces", None), deformed, np.linalg.norm(um, axis=1))
        th = _rotations(geom, mshape)
        rot = _rotation_nodes(model, geom)
        members = []
        for a, b in geom.segments:
            bends = (rot[a] or rot[b]) and (rot[a] or not moving[a]) and (rot[b] or not moving[b])
            members.append(member_points(geom.xyz[a], geom.xyz[b], um[a], um[b], th[a] if bends else None, th[b],
                                         s)[:, cols])
        if members:
            draw(members, labels[0], colors="C0", linewidths=0.7 if shaded else 1.6)
        ax.plot(*deformed[:, cols].T, "o", color="C0", ms=3, label=None if members else labels[0])
    if tshape:
        pts = geom.xyz + s * ut
        both = [pts[[a, b], cols] for a, b in geom.segments if measured[a] and measured[b]]
        if both:
            draw(both, None, colors="C3", linewidths=1.2, linestyles=":")
        ax.plot(*pts[measured][:, cols].T, "o", mfc="none", mec="C3", mew=1.5, ms=6, ls="none", label=labels[1])
    if not three:
        ax.autoscale_view()
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    if three:
        ax.set_zlabel("z [m]")
        every = np.vstack([geom.xyz, geom.xyz + s * um, geom.xyz + s * ut])
        span = np.maximum(np.ptp(every, axis=0), 0.15 * geom.extent)
        mid = 0.5 * (every.min(axis=0) + every.max(axis=0))
        for setter, c, w in zip((ax.set_xlim, ax.set_ylim, ax.set_zlim), mid, span):
            setter(c - 0.52 * w, c + 0.52 * w)  # the limits of what is drawn (a collection may not update them)
        ax.set_box_aspect(tuple(span))
    else:
        ax.set_aspect("equal", adjustable="datalim")
    ax.legend(fontsize=7, loc="upper left" if three else "best")
    note = f"displacements × {s:.3g}"
    ax.set_title(f"{title}\n{note}" if title else note, fontsize=9)
    return ax


def _surfaces(ax, geom: ShapeGeometry, faces, deformed: np.ndarray, size: np.ndarray) -> bool:
    """The shells and the solids' outer faces (``faces``: node-id polygons, as
    :func:`femupdate.fullfield.structure_segments` carries them) deformed, shaded by the motion's
    size; whether any was drawn."""
    if not faces:
        return False
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    pos = {n: i for i, n in enumerate(geom.node_ids)}
    rows = [[pos[n] for n in f] for f in faces if all(n in pos for n in f)]
    if not rows:
        return False
    peak = float(size.max()) or 1.0
    colours = plt.get_cmap("viridis")([float(np.mean(size[r])) / peak for r in rows])
    ax.add_collection3d(Poly3DCollection([deformed[r] for r in rows], facecolors=colours, edgecolors="none",
                                         alpha=0.85, label=None))
    return True


def _chain_axes(model, mshape: dict, tshape: dict, ax, title, labels):
    """The fallback without node coordinates: the shape against the model's dofs."""
    if ax is None:
        _, ax = plt.subplots(figsize=(6, 3.2))
    x = np.arange(len(model.dofs))
    ax.axhline(0.0, color="0.65", ls="--", lw=0.9, label="undeformed")
    if mshape:
        ax.plot(x, [mshape.get(d, 0.0) for d in model.dofs], "o-", color="C0", ms=4, label=labels[0])
    if tshape:
        idx = [k for k, d in enumerate(model.dofs) if d in tshape]
        ax.plot(idx, [tshape[model.dofs[k]] for k in idx], "o", mfc="none", mec="C3", mew=1.5, ms=7, ls="none",
                label=labels[1])
    shown = np.linspace(0, len(x) - 1, min(len(x), 12)).round().astype(int) if len(x) else x
    ax.set_xticks(shown, [model.dofs[k] for k in shown], fontsize=8, rotation=30 if len(x) > 6 else 0)
    ax.set_xlabel("dof (model order)")
    ax.set_ylabel("shape (model's scaling)")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=7, loc="best")
    ax.set_title(f"{title}\n{NO_GEOMETRY}" if title else NO_GEOMETRY, fontsize=9)
    return ax
