r"""Full-field (scanning laser-Doppler) data onto the model's dofs.

A scanning vibrometer gives the motion at many points whose coordinates do not coincide with
the model's nodes — "too much data" (the reference paper, "Improving experimental data") — and
no rotations.  :func:`map_scan` turns such a scan into complete test data on the model's dofs:

1. **Geometry.** The scan points must lie on the structure: the distance of every point to the
   model's geometry (its nodes and the segments between nodes its stiffness couples) is checked
   against a tolerance; a point too far is refused with its distance.
2. **Smoothing interpolation.** Each measured field (one translation component of one mode, or
   of one FRF line, real and imaginary parts apart) is fitted over the structure's intrinsic
   coordinates (1 along a beam, 2 over a plate or grillage) by a polyharmonic smoothing spline,
   :class:`scipy.interpolate.RBFInterpolator` — the minimum-curvature spline of that dimension
   (``r^3`` on a line: the natural cubic smoothing spline; ``r^2 log r`` on a surface: the thin
   plate spline).  The smoothing is chosen by K-fold cross-validation, whose held-out error is the
   reported interpolation error (it includes the measurement noise).  ``method="local"`` instead
   fits a quadratic through the few scan points nearest each node: only "the data at the points
   of interest", no smoothing across the field.
3. **Rotations from translations.** With small rotations, a fibre at offset r from the reference
   surface moves by :math:`u = \theta \times r`, so the slope of a transverse component
   :math:`u_c` along the tangent t is :math:`\partial_t u_c = \theta\cdot(t \times e_c)`.  Hence

   * on a line (Euler-Bernoulli beam): :math:`\theta = \sum_c \nabla u_c \times e_c` (e.g. a beam
     along x: :math:`\theta_z = \partial v/\partial x`, :math:`\theta_y = -\partial w/\partial x`);
   * on a surface with normal n (Kirchhoff plate): :math:`\theta = \nabla w \times n` for the
     normal component and, from in-plane components, the drilling rotation
     :math:`\tfrac12\, n\cdot\mathrm{curl}\,u`;
   * in a solid: :math:`\theta = \tfrac12\,\mathrm{curl}\,u`.

   Rotations about axes the measured components cannot give (torsion of a beam, for one)
   must be declared zero, like unmeasured translations (e.g. the axial motion of bending modes).
4. **Direct solution** (paper eqs. 1-10, 23-29) on the completed data:
   :func:`femupdate.fullfield.direct.full_field_direct`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp
from scipy.interpolate import RBFInterpolator
from scipy.spatial import cKDTree

from .._errors import InputError
from ..dofs import describe, parse_dof
from ..testdata import FRFData, MeasuredMode, TestData
from .geometry import Geometry, distance_to_geometry, inferable_rotations, model_geometry, rotation_operators
from .scan import AXES, ScanData

METHODS = ("elements", "rbf", "local")
KERNELS = {1: "cubic", 2: "thin_plate_spline", 3: "linear"}  # polyharmonic splines of minimum curvature
SMOOTHING_GRID = np.concatenate(([0.0], np.geomspace(1e-10, 1e1, 12)))
TOLERANCE_FACTOR = 0.6  # default geometry tolerance: this fraction of the longest element


# ------------------------------------------------------------------------------ fitting
def _folds(n: int, k: int, seed: int) -> list[np.ndarray]:
    perm = np.random.default_rng(seed).permutation(n)
    return [np.sort(perm[i::k]) for i in range(k)]


def _fit(xi, F, kernel, smoothing, neighbors):
    return RBFInterpolator(xi, F, kernel=kernel, smoothing=smoothing, neighbors=neighbors, degree=1)


def _choose_smoothing(xi, F, kernel, neighbors, folds, seed, grid) -> tuple[np.ndarray, np.ndarray]:
    """Per column of F: the smoothing of least K-fold cross-validation error, and that error (RMS)."""
    n = len(xi)
    err = np.zeros((len(grid), F.shape[1]))
    for test in _folds(n, min(folds, n), seed):
        train = np.setdiff1d(np.arange(n), test)
        for g, s in enumerate(grid):
            try:
                pred = _fit(xi[train], F[train], kernel, s, neighbors)(xi[test])
            except (np.linalg.LinAlgError, ValueError):
                err[g] = np.inf
                continue
            err[g] += np.sum((pred - F[test]) ** 2, axis=0)
    best = np.argmin(err, axis=0)
    return grid[best], np.sqrt(err[best, np.arange(F.shape[1])] / n)


def _rbf(xi_pts, F, xi_nodes, kernel, smoothing, folds, seed, neighbors):
    """Values and gradients (normalised intrinsic coordinates) at the nodes, and the fit report."""
    if smoothing == "cv":
        s_col, cv = _choose_smoothing(xi_pts, F, kernel, neighbors, folds, seed, SMOOTHING_GRID)
    else:
        s_col, cv = np.full(F.shape[1], float(smoothing)), np.full(F.shape[1], np.nan)
    d = xi_pts.shape[1]
    h = 1e-5
    val = np.zeros((len(xi_nodes), F.shape[1]))
    grad = np.zeros((len(xi_nodes), d, F.shape[1]))
    resid = np.zeros(F.shape[1])
    for s in np.unique(s_col):
        cols = np.flatnonzero(s_col == s)
        try:
            f = _fit(xi_pts, F[:, cols], kernel, s, neighbors)
        except np.linalg.LinAlgError:
            raise InputError(f"the scan points do not spread over the structure enough to fit a spline through them "
                             f"({len(np.unique(xi_pts, axis=0))} distinct position(s); a fit over {d} dimension(s) needs at least "
                             f"{d + 1} not all on one {'point' if d == 1 else 'line'}); add scan points") from None
        val[:, cols] = f(xi_nodes)
        resid[cols] = np.sqrt(np.mean((f(xi_pts) - F[:, cols]) ** 2, axis=0))
        for a in range(d):
            step = np.zeros(d)
            step[a] = h
            grad[:, a, cols] = (f(xi_nodes + step) - f(xi_nodes - step)) / (2 * h)
    return val, grad, {"smoothing": s_col, "cv_rms": cv, "fit_rms": resid}


def _local(xi_pts, F, xi_nodes):
    """Quadratic least-squares fit through the nearest scan points of each node (no smoothing)."""
    d = xi_pts.shape[1]
    nb = 1 + d + d * (d + 1) // 2
    k = min(len(xi_pts), 2 * nb - 1)
    if len(xi_pts) < nb:
        raise InputError(f"local fitting needs at least {nb} scan points, the scan has {len(xi_pts)}")
    _, idx = cKDTree(xi_pts).query(xi_nodes, k=k)
    X = xi_pts[idx] - xi_nodes[:, None, :]  # (nodes, k, d)
    cols = [np.ones(X.shape[:2])] + [X[..., a] for a in range(d)]
    cols += [X[..., a] * X[..., b] for a in range(d) for b in range(a, d)]
    B = np.stack(cols, axis=2)  # (nodes, k, nb)
    coef = np.linalg.pinv(B) @ F[idx]  # (nodes, nb, fields)
    resid = np.sqrt(np.mean((B @ coef - F[idx]) ** 2, axis=(0, 1)))
    return coef[:, 0, :], coef[:, 1:1 + d, :], {"smoothing": np.zeros(F.shape[1]), "cv_rms": np.full(F.shape[1], np.nan),
                                                 "fit_rms": resid}


def element_design(model, geom: Geometry, points, seg, along, comps, zero) -> tuple[sp.csr_array, np.ndarray]:
    r"""Design matrix of the element shape functions: scan values = N q, q the model dofs.

    Each point lies on its nearest element (node pair a-b, length l, tangent t) at ``s`` in [0, 1].
    A measured component :math:`u_c = e_c\cdot u` splits into the axial part, interpolated
    linearly, and the transverse part along :math:`\hat e = (e_c - (e_c\cdot t)t)/|\cdot|`,
    interpolated by the cubic Hermite functions of a beam with the end rotations about
    :math:`a = t\times\hat e` (:math:`\theta\cdot a = \partial_x(u\cdot\hat e)`) — the element's own
    displacement field — or linearly where neither end node has rotation dofs (rods).
    Rows are point-major within each component block (component blocks in ``comps`` order).
    Terms on dofs the model lacks, or in a direction in ``zero``, are left out.

    Parameters
    ----------
    model : Model
        The model (its dof labels).
    geom : Geometry
        Its geometry (:func:`~femupdate.fullfield.geometry.model_geometry`).
    points : array_like, shape ``(n_points, 3)``
        Scan points (only their number is used).
    seg : ndarray of int, shape ``(n_points,)``
        Segment of ``geom`` each point lies on (:func:`~femupdate.fullfield.geometry.distance_to_geometry`).
    along : ndarray, shape ``(n_points,)``
        Position ``s`` of each point on its segment, in [0, 1].
    comps : sequence of {"x", "y", "z"}
        Measured translation components.
    zero : collection of str
        Directions (``"x"`` ... ``"rz"``) declared zero: their dofs get no terms.

    Returns
    -------
    N : scipy.sparse.csr_array, shape ``(n_points * n_comps, n_dofs)``
        The design matrix.
    seen : ndarray of bool, shape ``(n_dofs,)``
        The dofs some row involves.
    """
    index = {d: i for i, d in enumerate(model.dofs)}
    has_rot = {parse_dof(d)[0] for d in model.dofs if parse_dof(d)[1].startswith("r")}
    A, B = geom.ends()
    a_id, b_id = geom.segments[seg, 0], geom.segments[seg, 1]
    D = (B - A)[seg]
    ell = np.linalg.norm(D, axis=1)
    t = D / ell[:, None]
    s = along
    H = np.stack([1 - 3 * s**2 + 2 * s**3, (s - 2 * s**2 + s**3) * ell, 3 * s**2 - 2 * s**3, (-s**2 + s**3) * ell], axis=1)
    hermite = np.array([int(a) in has_rot or int(b) in has_rot for a, b in zip(a_id, b_id)])
    n = len(points)
    rows, cols, vals = [], [], []

    def put(r, node_ids, direction_vectors, coef, rot):
        """coef * (direction . u) (or . theta) at the nodes, over the dofs the model has."""
        for k, lab in enumerate(("rx", "ry", "rz") if rot else ("x", "y", "z")):
            c = coef * direction_vectors[:, k]
            nz = np.flatnonzero(c != 0)
            if lab in zero or not nz.size:
                continue
            j = np.array([index.get(f"{int(node_ids[i])}:{lab}", -1) for i in nz], dtype=np.intp)
            ok = j >= 0
            rows.append(r[nz[ok]])
            cols.append(j[ok])
            vals.append(c[nz[ok]])

    for ci, c in enumerate(comps):
        e = AXES[c]
        r = ci * n + np.arange(n)
        alpha = t @ e
        perp = e[None, :] - alpha[:, None] * t
        beta = np.linalg.norm(perp, axis=1)
        ehat = perp / np.where(beta > 1e-12, beta, 1.0)[:, None]
        axis = np.cross(t, ehat)
        lin = ~hermite
        put(r, a_id, t, alpha * (1 - s), False)
        put(r, b_id, t, alpha * s, False)
        put(r, a_id, ehat, beta * np.where(lin, 1 - s, H[:, 0]), False)
        put(r, b_id, ehat, beta * np.where(lin, s, H[:, 2]), False)
        put(r, a_id, axis, beta * np.where(lin, 0.0, H[:, 1]), True)
        put(r, b_id, axis, beta * np.where(lin, 0.0, H[:, 3]), True)
    r_all, c_all, v_all = (np.concatenate(x) if x else np.zeros(0) for x in (rows, cols, vals))
    N = sp.csr_array((v_all, (r_all.astype(np.intp), c_all.astype(np.intp))), shape=(n * len(comps), model.n_dofs))
    N.sum_duplicates()
    seen = np.zeros(model.n_dofs, dtype=bool)
    seen[np.unique(c_all.astype(np.intp))] = True
    return N, seen


def _lstsq(N: np.ndarray, R: np.ndarray):
    """Least squares N q = R (columns of R), with the rank."""
    q, _, rank, sv = np.linalg.lstsq(N, R, rcond=None)
    return q, rank, sv


def _elements(N: sp.csr_array, R: np.ndarray, n_pts: int, n_comp: int, folds: int, seed: int):
    """Fit the nodal dofs to the scan (columns of R), with K-fold held-out error and standard errors."""
    Nd = N.toarray()
    q, rank, sv = _lstsq(Nd, R)
    if rank < Nd.shape[1]:
        return None, rank, sv
    fit = Nd @ q - R
    dof_resid = max(Nd.shape[0] - Nd.shape[1], 1)
    sigma2 = np.sum(fit**2, axis=0) / dof_resid
    cov_diag = np.diag(np.linalg.inv(Nd.T @ Nd))
    stderr = np.sqrt(np.outer(cov_diag, sigma2))  # (dofs, fields)
    cv = np.zeros(R.shape[1])
    for test in _folds(n_pts, min(folds, n_pts), seed):
        rows_t = (np.arange(n_comp)[:, None] * n_pts + test[None, :]).ravel()
        train = np.setdiff1d(np.arange(Nd.shape[0]), rows_t)
        qt, rk, _ = _lstsq(Nd[train], R[train])
        if rk < Nd.shape[1]:
            cv[:] = np.nan
            break
        cv += np.sum((Nd[rows_t] @ qt - R[rows_t]) ** 2, axis=0)
    cv = np.sqrt(cv / Nd.shape[0])
    return (q, {"fit_rms": np.sqrt(np.mean(fit**2, axis=0)), "cv_rms": cv, "stderr": stderr}), rank, sv


# ------------------------------------------------------------------------------ mapping
@dataclass(frozen=True, eq=False)
class FullFieldMapping:
    """Scan data on the model's dofs.

    Attributes
    ----------
    data : TestData
        Modes (and FRF lines) at every model dof.
    method : str
    fields : list of dict
        Per fitted field: ``label`` (mode or line), ``part`` (re/im), ``direction`` (the fitted
        component(s)), ``smoothing`` (RBF), ``cv_error`` (K-fold held-out RMS error / the field's
        largest value: the interpolation error, noise included), ``fit_error`` (RMS misfit at the
        scan points / largest value) and, for ``elements``, ``std_error`` (largest standard error
        of a nodal translation / largest value).
    interpolation_error : float
        The largest ``cv_error`` (``fit_error`` where no cross-validation was run).
    max_distance : float
        Largest distance of a scan point from the geometry.
    tolerance : float
        The distance allowed.
    inferred : list of str
        Rotation directions obtained from slopes.
    zero : list of str
        Directions set to zero.
    node_gap : dict
        Nodes farther than twice the scan spacing from any scan point {node: distance} (extrapolated).
    notes : list of str
    """

    data: TestData
    method: str
    fields: list[dict]
    interpolation_error: float
    max_distance: float
    tolerance: float
    inferred: list[str]
    zero: list[str]
    node_gap: dict = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)


def _real_mode(values: dict) -> dict:
    """A real normal mode from (lightly damped) complex values: rotate to the real axis."""
    allv = np.concatenate([np.ravel(v) for v in values.values()])
    if not np.iscomplexobj(allv) or not np.any(np.imag(allv)):
        return {d: np.real(np.asarray(v)) for d, v in values.items()}
    ph = np.exp(-1j * np.angle(allv[np.argmax(np.abs(allv))]))
    return {d: np.real(np.asarray(v) * ph) for d, v in values.items()}


def _items(scan: ScanData, comps):
    """(label, eigenvalue or None, values) per mode and FRF line, and the real fields F with their
    meta (item, part): F has one column per (item, part), components stacked point-major."""
    items = [(m.label or f"mode {k}", m.eigenvalue, _real_mode(m.values)) for k, m in enumerate(scan.modes, start=1)]
    if scan.frf is not None:
        for i, w in enumerate(np.asarray(scan.frf.omega, float)):
            items.append((f"line {i + 1} ({w:g} rad/s)", None, {d: np.asarray(v)[i] for d, v in scan.frf.values.items()}))
    cols, meta = [], []
    for t, (_, _, vals) in enumerate(items):
        stacked = np.concatenate([np.asarray(vals[c]) for c in comps])
        cols.append(np.real(stacked))
        meta.append((t, "re"))
        if np.iscomplexobj(stacked) and np.any(np.imag(stacked)):
            cols.append(np.imag(stacked))
            meta.append((t, "im"))
    return items, np.column_stack(cols), meta


def map_scan(model, scan: ScanData, *, method: str = "elements", smoothing="cv", folds: int = 5, seed: int = 0,
             neighbors: int | None = None, kernel: str | None = None, segments=None) -> FullFieldMapping:
    """Scan data (points by coordinates) onto every dof of ``model``.

    Parameters
    ----------
    model : Model
        With node coordinates (``model.nodes``).
    scan : ScanData
        The scan: points by coordinates and their measured components.
    method : {"elements", "rbf", "local"}, default "elements"
        ``"elements"``: least-squares fit of the elements' own shape functions, nodal rotations
        included; ``"rbf"``: smoothing polyharmonic spline over the structure, rotations from its
        slopes; ``"local"``: quadratic through the nearest scan points of each node (the data at
        the points of interest only).
    smoothing : "cv" or float, default "cv"
        ``"cv"`` (K-fold cross-validation) or a non-negative smoothing factor (RBF only).
    folds : int, default 5
        Cross-validation folds (the RBF smoothing choice; the held-out error of the elements fit).
    seed : int, default 0
        Seed of the folds' random split.
    neighbors : int, optional
        RBF with this many nearest points (default: global up to 1,500 points, 64 above).
    kernel : str, optional
        RBF kernel (default the polyharmonic spline of the structure's dimension).
    segments : array_like of int, shape ``(s, 2)``, optional
        Node-id pairs of the line elements (default: from the stiffness pattern; give them, e.g.
        :func:`structure_segments`, when elements end at fully supported nodes).

    Returns
    -------
    FullFieldMapping

    Raises
    ------
    InputError
        A scan point farther from the geometry than the tolerance (the message gives its index,
        coordinates and distance), model dofs the scan cannot give and that are not declared zero
        (named), a model without node coordinates, an unknown ``method``, a ``smoothing`` that is
        neither "cv" nor a non-negative number.
    """
    if method not in METHODS:
        raise InputError(f"unknown mapping method {method!r}: use {', '.join(METHODS)}")
    if not (smoothing == "cv" or (isinstance(smoothing, (int, float)) and not isinstance(smoothing, bool) and smoothing >= 0)):
        raise InputError(f"smoothing must be 'cv' or a non-negative number, got {smoothing!r}")
    geom = model_geometry(model, segments)
    pts = scan.points
    dist, seg, along = distance_to_geometry(geom, pts)
    tol = scan.max_distance if scan.max_distance is not None else TOLERANCE_FACTOR * (geom.longest_element() or geom.length)
    far = np.flatnonzero(dist > tol)
    if far.size:
        i = int(far[np.argmax(dist[far])])
        near = (f"element between nodes {geom.segments[seg[i], 0]} and {geom.segments[seg[i], 1]}" if seg[i] >= 0
                else "a node")
        raise InputError(
            f"{far.size} scan point(s) lie off the model's geometry: point #{i} at "
            f"({', '.join(f'{c:.4g}' for c in pts[i])}) is {dist[i]:.4g} from it (nearest: {near}); "
            f"tolerance {tol:.4g} (max_distance). Check the units and the frame of the scan coordinates"
        )
    comps = list(scan.components)
    zero = set(scan.zero)
    items, F, meta = _items(scan, comps)
    n_pts = len(pts)
    notes: list[str] = []
    fields = []
    scale = np.max(np.abs(F), axis=0)
    scale = np.where(scale > 0, scale, 1.0)
    if method == "elements":
        if not len(geom.segments):
            raise InputError(f"model {model.name!r} has no line elements to fit the scan along; use method 'rbf'")
        N, seen = element_design(model, geom, pts, seg, along, comps, zero)
        missing = [d for j, d in enumerate(model.dofs) if not seen[j] and parse_dof(d)[1] not in zero]
        _refuse_missing(missing, comps)
        cols = np.flatnonzero(seen)
        out, rank, sv = _elements(N[:, cols], F, n_pts, len(comps), folds, seed)
        if out is None:
            raise InputError(
                f"the scan points do not determine every dof of the model (rank {rank} of {cols.size}): "
                "some elements carry too few points; add scan points on them or use method 'rbf'"
            )
        q, rep = out
        Q = np.zeros((model.n_dofs, F.shape[1]))
        Q[cols] = q
        trans = np.array([not parse_dof(model.dofs[j])[1].startswith("r") for j in cols])
        for c, (t, part) in enumerate(meta):
            fields.append({"label": items[t][0], "part": part, "direction": ",".join(comps), "smoothing": None,
                           "cv_error": float(rep["cv_rms"][c] / scale[c]), "fit_error": float(rep["fit_rms"][c] / scale[c]),
                           "std_error": float(np.max(rep["stderr"][trans, c]) / scale[c]) if trans.any() else math.nan})
        inferred = sorted({parse_dof(model.dofs[j])[1] for j in cols if parse_dof(model.dofs[j])[1].startswith("r")})
        err_key = "cv_error"
    else:
        Q, fields, inferred, err_key = _smooth_route(model, geom, pts, F, meta, items, comps, zero, method, smoothing,
                                                     folds, seed, neighbors, kernel, scale)
    shapes = []
    for t in range(len(items)):
        v = np.zeros(model.n_dofs, dtype=complex)
        for c, (tt, part) in enumerate(meta):
            if tt == t:
                v += (1.0 if part == "re" else 1j) * Q[:, c]
        shapes.append(v)
    modes = tuple(MeasuredMode(lam, model.dofs, np.real(shapes[t]), label)
                  for t, (label, lam, _) in enumerate(items) if lam is not None)
    frf = None
    if scan.frf is not None:
        resp = np.array(shapes[len(scan.modes):])
        if not np.any(np.imag(resp)):
            resp = np.real(resp)
        frf = FRFData(np.asarray(scan.frf.omega, float), dict(scan.frf.force), model.dofs, resp)
    # nodes far from every scan point (extrapolated)
    tree = cKDTree(pts)
    dnode, _ = tree.query(geom.xyz)
    spacing = float(np.median(tree.query(pts, k=2)[0][:, 1])) if n_pts > 1 else 0.0
    used = {parse_dof(d)[0] for d in model.dofs}
    gap = {int(i): float(dn) for i, dn in zip(geom.node_ids, dnode) if int(i) in used and dn > 2 * spacing}
    if gap:
        notes.append(f"{len(gap)} node(s) lie more than twice the scan spacing ({spacing:.3g}) from any scan point: "
                     f"extrapolated ({', '.join(str(k) for k in list(gap)[:8])})")
    errs = [f[err_key] for f in fields if np.isfinite(f[err_key])] or [f["fit_error"] for f in fields]
    return FullFieldMapping(TestData(modes=modes, frf=frf), method, fields, float(max(errs)), float(dist.max()), float(tol),
                            inferred, sorted(zero & {parse_dof(d)[1] for d in model.dofs}), gap, notes)


def _refuse_missing(missing, comps) -> None:
    if missing:
        kinds = sorted({parse_dof(m)[1] for m in missing})
        raise InputError(
            f"the scan measures {', '.join(comps)}, so model dof(s) {describe(missing)} cannot be completed; "
            f"measure those directions or declare them zero (\"zero\": {kinds!r}, e.g. the axial motion or "
            "the torsion of bending modes)"
        )


def _smooth_route(model, geom, pts, F, meta, items, comps, zero, method, smoothing, folds, seed, neighbors, kernel, scale):
    """RBF / local fits of each component, rotations from the slopes (module docstring)."""
    rots = inferable_rotations(geom, comps)
    pos_node = {int(i): k for k, i in enumerate(geom.node_ids)}
    plan, missing = [], []
    for lab in model.dofs:
        nd, dr = parse_dof(lab)
        if dr in comps:
            plan.append(("t", dr, pos_node[nd]))
        elif dr in zero:
            plan.append(("0", dr, pos_node[nd]))
        elif dr in rots:
            plan.append(("r", dr, pos_node[nd]))
        else:
            missing.append(lab)
    _refuse_missing(missing, comps)
    n = len(pts)
    # one column per (item, part, component)
    Fc = np.column_stack([F[k * n:(k + 1) * n, c] for c in range(F.shape[1]) for k in range(len(comps))])
    cmeta = [(c, comps[k]) for c in range(F.shape[1]) for k in range(len(comps))]
    xi_pts, xi_nodes = geom.intrinsic(pts), geom.intrinsic(geom.xyz)
    if neighbors is None and n > 1500:
        neighbors = 64
    if method == "rbf":
        val, grad, rep = _rbf(xi_pts, Fc, xi_nodes, kernel or KERNELS[geom.dim], smoothing, folds, seed, neighbors)
    else:
        val, grad, rep = _local(xi_pts, Fc, xi_nodes)
    grad3 = np.einsum("ka,nag->nkg", geom.basis, grad) / geom.length  # global gradients (nodes, 3, columns)
    G = rotation_operators(geom, comps)
    Q = np.zeros((model.n_dofs, F.shape[1]))
    fields = []
    for c in range(F.shape[1]):
        own = {d: k for k, (cc, d) in enumerate(cmeta) if cc == c}
        theta = np.zeros((len(geom.node_ids), 3))
        for d, k in own.items():
            theta += grad3[:, :, k] @ G[d].T
        for j, (kind, dr, pn) in enumerate(plan):
            if kind == "t":
                Q[j, c] = val[pn, own[dr]]
            elif kind == "r":
                Q[j, c] = theta[pn, "xyz".index(dr[1])]
        t, part = meta[c]
        for d, k in own.items():
            sc = max(np.max(np.abs(Fc[:, k])), 1e-300)
            fields.append({"label": items[t][0], "part": part, "direction": d, "smoothing": float(rep["smoothing"][k]),
                           "cv_error": float(rep["cv_rms"][k] / sc), "fit_error": float(rep["fit_rms"][k] / sc)})
    err_key = "cv_error" if method == "rbf" and smoothing == "cv" else "fit_error"
    return Q, fields, sorted({dr for kind, dr, _ in plan if kind == "r"}), err_key
