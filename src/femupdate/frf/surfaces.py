r"""Residual surfaces over two parameters (paper Figures 5-7), vectorised over the grid.

* :func:`modal_surface` — eq. 33:

  .. math::  r_2 = \sum_i \Big(\frac{\lambda_{Ei} - \lambda_{Ai}}{\lambda_{Ai}}\Big)^2
             + \sum_{k \ne \mathrm{ref}} (\phi_{Ek,i} - \phi_{Ak,i})^2,

  shapes scaled to 1 at the reference dof (the paper: "the amplitude of the first freedom
  being one"), test mode i against the i-th model mode (the paper's pairing by order).  The
  denominator is the *analytical* eigenvalue, literally as printed.
* :func:`frf_surface` — eq. 34: :math:`r^2 = \sum_j \sum_i |x_{Ei,j} - x_{Ai,j}|^2` over the
  measured lines j and dofs i (or the relative / log-magnitude residuals of
  :mod:`femupdate.frf.residuals`).

Every grid point's matrices are formed at once from the affine model,
:math:`K(p) = K_b + p_1 K_1 + p_2 K_2`, as stacked dense arrays ``(G, n, n)``; eigenvalue
problems (Cholesky + ``eigh``) and the dynamic-stiffness solves of all points and lines are
single batched LAPACK calls, in memory-bounded blocks of the grid — no Python loop per point.
(Models larger than :data:`SURFACE_DENSE_LIMIT` dofs fall back to one sparse solve per point
and line.)  A point where a line falls exactly on a resonance gives ``inf`` (the paper's
"large spikes").

:func:`local_minima` counts the grid points lower than all 8 neighbours.
"""

from __future__ import annotations

import logging
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import ClassVar, cast

import numpy as np

from .._docs import shared_docs
from .._budget import check_memory
from .._errors import InputError
from ..dofs import canonical
from ..serialise import RunContext, Serialisable
from ..testdata import FRFData, TestData
from . import residuals as R
from .damping import as_damping
from .lines import BLOCK_BYTES, DENSE_LIMIT, LineSystems, force_vector, solve_stacked
from .resonance import dense_eigen_stack

log = logging.getLogger(__name__)

SURFACE_DENSE_LIMIT = DENSE_LIMIT  # the dense stacked evaluation: the same limit as the dense line solves


@dataclass(frozen=True, eq=False)
class Surface(Serialisable):
    """A residual over a grid of two parameters; a result of kind ``surface`` (``femupdate
    surface``): :meth:`~femupdate.serialise.Serialisable.to_json` gives the command's JSON.

    Each parameter is stored as the attribute of the same name.

    Parameters
    ----------
    names : (str, str)
    x, y : ndarray
        Grid values of the first and second parameter.
    values : ndarray (len(x), len(y))
        The residual (``inf`` where a line lies exactly on a resonance).
    residual : str
        Which residual: ``"modal (eq. 33)"`` or ``"frf (eq. 34, FORM)"`` (FORM the residual
        form: ``linear``, ``relative`` or ``log``).
    truth : (float, float) or None
        The true solution, when known (marked on plots).
    info : dict
        What the surface was computed from (lines, dofs and force, or eigenvalues and
        reference dof).
    units : (str, str), default ("", "")
        The two parameters' units (:attr:`Parameter.unit <femupdate.Parameter.unit>`; ``""``
        unknown), for the axes.
    context : RunContext, optional
        The model of the surface (its name goes into the JSON).
    """

    names: tuple[str, str]
    x: np.ndarray
    y: np.ndarray
    values: np.ndarray
    residual: str
    truth: tuple[float, float] | None = None
    info: dict = field(default_factory=dict)
    units: tuple[str, str] = ("", "")
    context: RunContext | None = field(default=None, compare=False, repr=False)

    kind: ClassVar[str] = "surface"

    def payload(self) -> dict:
        from .record import surface_fields

        return surface_fields(self, self.run_context)

    @classmethod
    def from_payload(cls, obj):
        from .record import surface_from

        return surface_from(obj)

    def records(self) -> list[dict]:
        """One record per grid point: the two parameters' values and the residual there."""
        return [{self.names[0]: float(a), self.names[1]: float(b), "value": float(self.values[i, j])}
                for i, a in enumerate(self.x) for j, b in enumerate(self.y)]

    @property
    def minimum(self) -> dict:
        """Lowest grid value and where it is."""
        i, j = np.unravel_index(np.argmin(np.where(np.isfinite(self.values), self.values, np.inf)), self.values.shape)
        return {self.names[0]: float(self.x[i]), self.names[1]: float(self.y[j]), "value": float(self.values[i, j])}

    def minima(self) -> list[dict]:
        """Grid local minima (8 neighbours), lowest first: {names..., value, edge}."""
        out = []
        for i, j, edge in local_minima(self.values):
            out.append({self.names[0]: float(self.x[i]), self.names[1]: float(self.y[j]),
                        "value": float(self.values[i, j]), "edge": bool(edge)})
        return sorted(out, key=lambda m: m["value"])

    def summary(self) -> dict:
        """Grid size, the lowest point, counts of interior and edge minima (the first 20 listed)
        and the number of non-finite points, as a JSON-ready dict."""
        mins = self.minima()
        return {"grid": [len(self.x), len(self.y)], "minimum": self.minimum,
                "local_minima": sum(not m["edge"] for m in mins), "edge_minima": sum(m["edge"] for m in mins),
                "minima": mins[:20], "singular_points": int(np.sum(~np.isfinite(self.values)))}


def local_minima(values: np.ndarray) -> list[tuple[int, int, bool]]:
    """Grid points strictly lower than each of their (up to) 8 neighbours, as ``(i, j, on_edge)``.

    Vectorised: the array is padded with +inf and compared with its 8 shifted copies.
    ``inf`` / NaN points are never minima.  Points on the grid's border are flagged
    ``on_edge``: the residual may simply keep falling beyond the window there.

    Parameters
    ----------
    values : numpy.ndarray, shape ``(n1, n2)``
        Grid values.

    Returns
    -------
    list of (int, int, bool)
        Row index, column index and ``on_edge`` of each minimum.
    """
    v = np.where(np.isfinite(values), values, np.inf)
    P = np.pad(v, 1, constant_values=np.inf)
    n1, n2 = v.shape
    is_min = np.isfinite(v)
    for di in (-1, 0, 1):
        for dj in (-1, 0, 1):
            if di or dj:
                is_min &= v < P[1 + di:1 + di + n1, 1 + dj:1 + dj + n2]
    ii, jj = np.nonzero(is_min)
    edge = (ii == 0) | (jj == 0) | (ii == n1 - 1) | (jj == n2 - 1)
    return list(zip(ii.tolist(), jj.tolist(), edge.tolist()))


def _units(model, names: Sequence[str]) -> tuple[str, str]:
    """The two surface parameters' units."""
    u = [model.parameters[model.parameter_index(n)].unit for n in names]
    return u[0], u[1]


def _grid(model, names: Sequence[str], x, y):
    if len(names) != 2:
        raise InputError(f"a residual surface needs exactly two parameters, got {list(names)}")
    if model.parameter_index(names[0]) == model.parameter_index(names[1]):
        raise InputError(f"the two surface parameters must differ (both {names[0]!r})")
    gx, gy = (np.asarray(g, float).ravel() for g in (x, y))
    for nm, g in zip(names, (gx, gy)):
        if g.size < 2 or not np.all(np.isfinite(g)):
            raise InputError(f"grid of {nm}: need at least two finite values")
    check_memory(f"grid of {gx.size} x {gy.size} points", 64.0 * gx.size * gy.size,
                 "the surface's points, their values and copies (64 bytes a point)")
    P1, P2 = np.meshgrid(gx, gy, indexing="ij")
    return gx, gy, np.column_stack([P1.ravel(), P2.ravel()])


class AffineStack:
    r"""Dense K and M of many parameter points of a small affine model at once:
    :math:`K(P_g) = K_b + \sum_j P_{gj} K_j` for the parameters ``names`` (the others at ``values``).

    Parameters
    ----------
    model : Model
        At most :data:`SURFACE_DENSE_LIMIT` dofs.
    names : sequence of str
        The parameters that vary.
    values : None, mapping of str to float, or array_like, optional
        Values of the other parameters (default nominal).

    Raises
    ------
    InputError
        A model above the dense limit; an unknown parameter name; and as :meth:`Model.resolve`.
    """

    def __init__(self, model, names: Sequence[str], values=None):
        from ..coefficients import route_refusal
        route_refusal(model, 'the FRF and modal residual surfaces')
        if model.n_dofs > SURFACE_DENSE_LIMIT:
            raise InputError(f"stacked dense evaluation is for models up to {SURFACE_DENSE_LIMIT} dofs; "
                             f"{model.name!r} has {model.n_dofs}")
        self.idx = [model.parameter_index(n) for n in names]
        p = model.resolve(values)
        base = p.copy()
        base[self.idx] = 0.0
        self.K0, self.M0 = model.K(base).toarray(), model.M(base).toarray()
        self.dK = np.stack([model.dK_dp(j).toarray() for j in self.idx])
        self.dM = np.stack([model.dM_dp(j).toarray() for j in self.idx])
        self.n = model.n_dofs

    def K(self, P: np.ndarray) -> np.ndarray:
        """Stiffness matrices at the points ``P`` ``(G, L)``: shape ``(G, n_dofs, n_dofs)``.

        Parameters
        ----------
        P : numpy.ndarray, shape ``(G, L)``
            Values of the parameters ``names`` (in that order) at G points.

        Returns
        -------
        numpy.ndarray, shape ``(G, n_dofs, n_dofs)``
            Dense K at each point, N/m.
        """
        return self.K0[None] + np.einsum("gj,jab->gab", P, self.dK)

    def M(self, P: np.ndarray) -> np.ndarray:
        """Mass matrices at the points ``P`` ``(G, L)``, as :meth:`K` gives the stiffness
        matrices: dense M at each point, kg, shape ``(G, n_dofs, n_dofs)``."""
        return self.M0[None] + np.einsum("gj,jab->gab", P, self.dM)


# the arguments of the batched residuals, written once (femupdate._docs)
_POINTS = """\
names : sequence of str
    The parameters varied (the columns of ``P``).
P : array_like, shape ``(G, len(names))``
    Parameter points.
values : None, mapping of str to float, or array_like, optional
    Values of the other parameters (default nominal)."""
_DOCS = {
    "FRF_POINTS": "\n".join([
        "model : Model", "    The parametrised model.",
        "data : FRFData", "    Measured lines (ω in rad/s), force and responses (any subset of dofs).", _POINTS,
        "damping : Damping or mapping, optional", "    Default undamped.",
        "residual : str, default ``\"linear\"``",
        "    ``\"linear\"`` (eq. 34), ``\"relative\"`` or ``\"log\"`` (:mod:`femupdate.frf.residuals`).",
        "weights : float or array_like broadcastable to ``(n_lines, n_dofs)``, optional",
        "    Non-negative weights (default 1).",
        "stack : AffineStack, optional", "    Reuse the dense stacked matrices (small models)."]),
    "MODAL_POINTS": "\n".join([
        "model : Model", "    The parametrised model (at most :data:`SURFACE_DENSE_LIMIT` dofs).",
        "data : TestData", "    Measured modes; test mode i is compared with model mode i.", _POINTS,
        "ref_dof : str, optional", "    Dof at which shapes are scaled to 1 (default: each mode's first measured dof).",
        "stack : AffineStack, optional", "    Reuse the dense stacked matrices."]),
    # the end of the surfaces' parameters
    "TRUTH_RETURNS": "truth : (float, float), optional\n    The true solution, recorded for plots.\n\nReturns\n-------\nSurface",
}


def _blocks(G: int, per_point_bytes: int):
    step = max(1, BLOCK_BYTES // max(per_point_bytes, 1))
    for s in range(0, G, step):
        yield slice(s, min(G, s + step))


@shared_docs(**_DOCS)
def frf_residuals(model, data: FRFData, names: Sequence[str], P: np.ndarray, values=None, damping=None,
                  residual: str = "linear", weights=None, stack: AffineStack | None = None) -> np.ndarray:
    r"""FRF residual vectors at many parameter points ``P`` ``(G, len(names))`` at once, ``(G, m)``:
    stacked dense solves of every point and line (rows of ``inf`` where a line lies exactly on a
    resonance).  Larger models: one sparse solve per point and line.

    Parameters
    ----------
    {{FRF_POINTS}}

    Returns
    -------
    numpy.ndarray, shape ``(G, m)``
        Residuals per point (complex data: real and imaginary parts as separate residuals);
        rows with any non-finite value set to ``inf``.

    Raises
    ------
    InputError
        An unknown residual kind; bad weights; a malformed force; response dofs not in the model;
        zero measured values with ``"log"``.
    """
    R.check_kind(residual)
    damping = as_damping(damping)
    P = np.atleast_2d(np.asarray(P, float))
    f = force_vector(model, data.force, "frf force")
    S = model.dof_index(data.dofs, "frf response")
    w_, target = R.prepare(data.response, residual, weights, damping.undamped and not np.iscomplexobj(f))
    cK, cM = damping.coefficients(data.omega)
    n, nl = model.n_dofs, data.omega.size
    rows = []
    if n <= SURFACE_DENSE_LIMIT:
        stack = stack or AffineStack(model, names, values)
        for sl in _blocks(P.shape[0], nl * n * n * 16 * 2):
            K, M = stack.K(P[sl]), stack.M(P[sl])
            Z = cK[None, :, None, None] * K[:, None] + cM[None, :, None, None] * M[:, None]  # (g, nl, n, n)
            X = solve_stacked(Z, np.broadcast_to(f[:, None], Z.shape[:-1] + (1,)).astype(Z.dtype), "inf")[..., 0]
            with np.errstate(invalid="ignore", over="ignore"):
                r = R.values(X[..., S], target, w_, residual)
            rows.append(r.reshape(r.shape[0], -1))
    else:
        log.info("frf_residuals: %d dofs, one sparse solve per point and line", n)
        p = model.resolve(values)
        j = [model.parameter_index(nm) for nm in names]
        for g in range(P.shape[0]):
            p[j] = P[g]
            xa = LineSystems(model, p, data.omega, damping).solve(f, on_singular="inf")[:, S]
            with np.errstate(invalid="ignore", over="ignore"):
                rows.append(R.values(xa, target, w_, residual).reshape(1, -1))
    out = np.concatenate(rows, axis=0)
    out[~np.all(np.isfinite(out), axis=1)] = np.inf
    return out


@shared_docs(**_DOCS)
def frf_r2(model, data: FRFData, names: Sequence[str], P: np.ndarray, values=None, damping=None,
           residual: str = "linear", weights=None, stack: AffineStack | None = None) -> np.ndarray:
    r"""Eq. 34's :math:`r^2` (sum of squared FRF residuals) at many points ``P`` at once (``inf``
    where a line lies exactly on a resonance).

    Parameters
    ----------
    {{FRF_POINTS}}

    Returns
    -------
    numpy.ndarray, shape ``(G,)``
        Sum of squared residuals per point.

    Raises
    ------
    InputError
        As :func:`frf_residuals`.
    """
    with np.errstate(over="ignore", invalid="ignore"):
        r2 = np.sum(frf_residuals(model, data, names, P, values, damping, residual, weights, stack) ** 2, axis=1)
    return np.where(np.isfinite(r2), r2, np.inf)


@shared_docs(**_DOCS)
def frf_surface(model, data: FRFData, names: Sequence[str], x, y, values=None, damping=None,
                residual: str = "linear", weights=None, truth=None) -> Surface:
    r"""Eq. 34 over the grid ``x`` × ``y`` of parameters ``names`` (others at ``values``).

    ``data`` gives the lines, the force and the measured responses (any subset of dofs).
    Returns a :class:`Surface` of :math:`r^2` (the sum of squared residuals).

    Parameters
    ----------
    model : Model
        The parametrised model.
    data : FRFData
        Measured lines, force and responses.
    names : (str, str)
        The two parameters of the grid (different).
    x, y : array_like
        Grid values of the first and second parameter (at least two finite values each).
    values, damping, residual, weights
        As :func:`frf_residuals`.
    {{TRUTH_RETURNS}}

    Raises
    ------
    InputError
        Not exactly two different parameters; a bad grid; and as :func:`frf_residuals`.
    """
    gx, gy, P = _grid(model, names, x, y)
    out = frf_r2(model, data, names, P, values, damping, residual, weights)
    return Surface(cast("tuple[str, str]", tuple(names)), gx, gy, out.reshape(gx.size, gy.size),
                   f"frf (eq. 34, {residual})",
                   None if truth is None else cast("tuple[float, float]", tuple(map(float, truth))),
                   {"omega_rad_s": data.omega.tolist(), "dofs": list(data.dofs), "force": dict(data.force)},
                   _units(model, names), context=RunContext(model=model))


@shared_docs(**_DOCS)
def modal_residuals(model, data: TestData, names: Sequence[str], P: np.ndarray, values=None,
                    ref_dof: str | None = None, stack: AffineStack | None = None) -> np.ndarray:
    r"""Eq. 33's residual vectors at many parameter points ``P`` ``(G, len(names))`` at once
    (batched Cholesky and ``eigh`` of every point's pencil), ``(G, m)``: relative eigenvalue
    errors, then the scaled shape differences.

    The eigenvalue errors are (λ_E − λ_A)/λ_A (divided by the analytical eigenvalue, as eq. 33
    is printed); modes with fewer than two measured dofs contribute no shape rows.

    Parameters
    ----------
    {{MODAL_POINTS}}

    Returns
    -------
    numpy.ndarray, shape ``(G, m)``
        Residuals per point; rows with any non-finite value set to ``inf``.

    Raises
    ------
    InputError
        No measured modes; more test modes than model dofs; a reference dof not measured; shape
        dofs not in the model; and as :class:`AffineStack`.
    """
    if not data.modes:
        raise InputError("a modal residual needs measured modes")
    P = np.atleast_2d(np.asarray(P, float))
    stack = stack or AffineStack(model, names, values)
    n = model.n_dofs
    m = len(data.modes)
    if m > n:
        raise InputError(f"{m} test modes but the model has only {n} dofs")
    lam_e = data.eigenvalues
    shape_rows = []
    for k, mode in enumerate(data.modes):
        if len(mode.dofs) < 2:
            continue  # one measured dof: no information once scaled
        ref = canonical(ref_dof) if ref_dof else mode.dofs[0]
        if ref not in mode.dofs:
            raise InputError(f"test mode {k + 1}: reference dof {ref} is not measured")
        pos = model.dof_index(mode.dofs, f"test mode {k + 1} shape")
        r = list(mode.dofs).index(ref)
        phi = np.real(mode.shape) / np.real(mode.shape[r])
        keep = np.arange(len(mode.dofs)) != r
        shape_rows.append((k, pos, r, phi[keep], keep))
    rows = []
    for sl in _blocks(P.shape[0], n * n * 8 * 4):
        lam, Phi = dense_eigen_stack(stack.K(P[sl]), stack.M(P[sl]))
        with np.errstate(divide="ignore", invalid="ignore"):
            parts = [(lam_e[None, :] - lam[:, :m]) / lam[:, :m]]
            for k, pos, r, phi_e, keep in shape_rows:
                ph = Phi[:, pos, k]
                parts.append(phi_e[None, :] - (ph / ph[:, [r]])[:, keep])
        rows.append(np.concatenate(parts, axis=1))
    out = np.concatenate(rows, axis=0)
    out[~np.all(np.isfinite(out), axis=1)] = np.inf
    return out


@shared_docs(**_DOCS)
def modal_r2(model, data: TestData, names: Sequence[str], P: np.ndarray, values=None, ref_dof: str | None = None,
             stack: AffineStack | None = None) -> np.ndarray:
    r"""Eq. 33's :math:`r_2` at many parameter points at once.

    Parameters
    ----------
    {{MODAL_POINTS}}

    Returns
    -------
    numpy.ndarray, shape ``(G,)``
        Sum of squared residuals per point (``inf`` where not finite).

    Raises
    ------
    InputError
        As :func:`modal_residuals`.
    """
    with np.errstate(over="ignore", invalid="ignore"):
        r2 = np.sum(modal_residuals(model, data, names, P, values, ref_dof, stack) ** 2, axis=1)
    return np.where(np.isfinite(r2), r2, np.inf)


@shared_docs(**_DOCS)
def modal_surface(model, data: TestData, names: Sequence[str], x, y, values=None, ref_dof: str | None = None,
                  truth=None) -> Surface:
    r"""Eq. 33 over the grid: relative eigenvalue errors (divided by the analytical eigenvalue, as
    printed) plus differences of the shapes scaled to 1 at ``ref_dof`` (default: the first
    measured dof of each mode), test mode i against model mode i.

    Parameters
    ----------
    model : Model
        The parametrised model (dense limit as :class:`AffineStack`).
    data : TestData
        Measured modes.
    names : (str, str)
        The two parameters of the grid.
    x, y : array_like
        Grid values (at least two finite values each).
    values, ref_dof
        As :func:`modal_residuals`.
    {{TRUTH_RETURNS}}

    Raises
    ------
    InputError
        Not exactly two different parameters; a bad grid; and as :func:`modal_residuals`.
    """
    gx, gy, P = _grid(model, names, x, y)
    out = modal_r2(model, data, names, P, values, ref_dof)
    return Surface(cast("tuple[str, str]", tuple(names)), gx, gy, out.reshape(gx.size, gy.size), "modal (eq. 33)",
                   None if truth is None else cast("tuple[float, float]", tuple(map(float, truth))),
                   {"eigenvalues": data.eigenvalues.tolist(), "ref_dof": ref_dof}, _units(model, names),
                   context=RunContext(model=model))


def distinct_minima(surface: Surface, residuals, bounds=None, rel_tol: float = 1e-3) -> list[dict]:
    """Polish every interior grid minimum of ``surface`` by a local least-squares search on
    ``residuals`` (points ``(G, 2)`` -> residual vectors ``(G, m)``, e.g. :func:`frf_residuals`)
    and cluster the results: the surface's true local minima, with how many grid minima led to
    each.  Grid minima along a narrow curved valley are artefacts of the grid; they polish into
    one minimum.  ``on_boundary``: the search ran into the window's edge (the residual keeps
    falling outside it).

    Parameters
    ----------
    surface : Surface
        The grid whose interior minima are polished.
    residuals : callable
        Points ``(G, 2)`` -> residual vectors ``(G, m)``.
    bounds : (array_like, array_like), optional
        Lower and upper bounds of the search (default: the grid's window).
    rel_tol : float, default 1e-3
        Relative distance under which two polished minima are one.

    Returns
    -------
    list of dict
        ``{name1, name2, value (r²), grid_minima, on_boundary}`` per distinct minimum, lowest
        first (empty if no interior grid minimum).
    """
    from scipy.optimize import least_squares

    from ..distinct import cluster

    lo = np.array([surface.x.min(), surface.y.min()]) if bounds is None else np.asarray(bounds[0], float)
    hi = np.array([surface.x.max(), surface.y.max()]) if bounds is None else np.asarray(bounds[1], float)
    n1, n2 = surface.names
    pts, vals = [], []
    for m in surface.minima():
        if m["edge"]:
            continue
        try:
            sol = least_squares(lambda x: residuals(np.asarray(x)[None, :])[0], np.array([m[n1], m[n2]]),
                                bounds=(lo, hi), x_scale="jac", ftol=1e-14, xtol=1e-14, gtol=1e-14, max_nfev=500)
        except ValueError:  # started on a spike (a line on resonance)
            continue
        pts.append(sol.x)
        vals.append(2 * sol.cost)
    if not pts:
        return []
    P, V = np.array(pts), np.array(vals)
    span = hi - lo
    out = []
    for g in cluster(P, V, rel_tol):
        x = P[g[0]]
        out.append({n1: float(x[0]), n2: float(x[1]), "value": float(V[g[0]]), "grid_minima": len(g),
                    "on_boundary": bool(np.any((x - lo) < 1e-6 * span) or np.any((hi - x) < 1e-6 * span))})
    return sorted(out, key=lambda m: m["value"])
