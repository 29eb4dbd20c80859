r"""Iterative sensitivity-based updating from (incomplete) modal data (paper eqs. 16-22).

The residual vector stacks, for every test mode paired with a model mode,

* the relative eigenvalue error ``w_λ (λ_A − λ_E) / λ_E`` (the normalised form of eq. 19), and
* the scaled mode-shape differences ``w_φ (ψ_A − ψ_E)`` at the measured dofs (eq. 19 / eq. 33),

where ψ is the shape scaled alike for test and model (``"ref"``: 1 at a reference dof, as in
eq. 33; ``"unit"``: unit length over the measured dofs; ``"max"``).  It is minimised by
SciPy's least-squares machinery (trust-region reflective by default, Levenberg–Marquardt,
dogbox) with the analytic Jacobian of :mod:`femupdate.sensitivity` — the Gauss–Newton
iteration of eq. 20 made robust.  Test and model modes are re-paired by MAC at every evaluation,
so modes that swap order during updating stay with the right test mode; swaps are reported.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import least_squares

from ._errors import InputError, NumericalError
from .correlation import mac, pair_modes
from .modal import model_modes
from .sensitivity import eigenvalue_derivatives, scaled_shape
from .sensitivity.jacobian import METHODS as SENSITIVITY_METHODS
from .sensitivity.jacobian import jacobian as sensitivity_jacobian
from .sensitivity.subspace import buffered_modes
from .testdata import TestData

log = logging.getLogger(__name__)

PARAMETRISATIONS = ("relative", "log", "absolute")
SHAPE_SCALINGS = ("unit", "ref", "max")
SENSITIVITY_CHOICES = SENSITIVITY_METHODS  # "auto", "nelson", "modal", "static", "subspace", "adjoint", "fd"


@dataclass(frozen=True, eq=False)
class Diagnostics:
    """Identifiability at the solution.

    ``singular_values`` and ``condition_number`` of the normalised sensitivity matrix
    S = ∂r/∂(p/p_ref) (columns scaled by the parameter values, so units do not matter);
    ``poorly_determined`` lists parameters dominating the right singular vectors whose singular
    values are below ``1e-6`` of the largest (or that have more parameters than independent
    data); ``covariance`` and ``std`` are in parameter units (from the measurement
    uncertainties when given, else from the residual variance; NaN when not estimable).
    """

    singular_values: np.ndarray
    condition_number: float
    rank: int
    poorly_determined: list[str]
    covariance: np.ndarray
    std: np.ndarray
    n_residuals: int
    n_parameters: int


@dataclass(frozen=True, eq=False)
class UpdateResult:
    """Result of :func:`update`, in the spirit of :class:`scipy.optimize.OptimizeResult`."""

    parameters: dict[str, float]
    names: tuple[str, ...]
    x: np.ndarray
    success: bool
    status: int
    message: str
    cost: float
    fun: np.ndarray
    jac: np.ndarray
    nfev: int
    njev: int
    iterations: int
    history: list[dict]
    pairs: list[tuple[int, int, float]]
    test_frequencies_hz: np.ndarray
    model_frequencies_hz: np.ndarray
    swaps: list[dict]
    diagnostics: Diagnostics | None
    regularization: dict = field(default_factory=dict)
    start: dict[str, float] = field(default_factory=dict)
    sensitivity: str = ""  # the derivative route used at the solution (``"auto"`` resolved)


class _Parametrised:
    """The optimiser's variables x and the full parameter vector p (shared by every updating problem).

    ``parametrisation``: ``"relative"`` (x = p / |p_start|), ``"log"`` (x = log p) or ``"absolute"``;
    parameters not in ``names`` stay at ``p_base``.
    """

    def __init__(self, model, names, parametrisation, p_base):
        self.idx = np.array([model.parameter_index(n) for n in names], dtype=np.intp)
        self.names = tuple(names)
        self.param = parametrisation
        self.p_base = p_base  # full parameter vector: fixed ones stay at these values
        self.scale = np.where(p_base[self.idx] != 0, np.abs(p_base[self.idx]), 1.0)

    def to_p(self, x):
        p = self.p_base.copy()
        if self.param == "relative":
            p[self.idx] = x * self.scale
        elif self.param == "log":
            p[self.idx] = np.exp(x)
        else:
            p[self.idx] = x
        return p

    def dp_dx(self, x):
        if self.param == "relative":
            return self.scale
        if self.param == "log":
            return np.exp(x)
        return np.ones_like(x)

    def from_p(self, p_sel):
        p_sel = np.asarray(p_sel, float)
        if self.param == "relative":
            return p_sel / self.scale
        if self.param == "log":
            if np.any(p_sel <= 0):
                raise InputError("log parametrisation needs positive parameter values and bounds")
            return np.log(p_sel)
        return p_sel


class _Problem(_Parametrised):
    """Residuals and Jacobian of one updating problem (cached per parameter vector)."""

    def __init__(self, model, data: TestData, names, shape_scaling, ref_dof, weights, min_mac,
                 n_modes, parametrisation, p_base, use_shapes, sensitivity):
        super().__init__(model, names, parametrisation, p_base)
        self.model = model
        self.data = data
        self.min_mac = min_mac
        self.sensitivity = sensitivity
        self.sensitivity_used = sensitivity
        if shape_scaling not in SHAPE_SCALINGS:
            raise InputError(f"unknown shape scaling {shape_scaling!r}: use {', '.join(SHAPE_SCALINGS)}")
        self.scaling = shape_scaling
        if not data.modes:
            raise InputError("iterative modal updating needs measured modes (frequencies and optionally shapes)")
        self.lam_e = data.eigenvalues
        if np.any(self.lam_e <= 0):
            bad = [k + 1 for k in np.flatnonzero(self.lam_e <= 0)]
            raise InputError(f"test mode(s) {bad} have zero frequency: rigid-body modes cannot be used as updating targets")
        w = {"eigenvalue": 1.0, "shape": 1.0} | dict(weights or {})
        self.w_lam = np.broadcast_to(np.asarray(w["eigenvalue"], float), self.lam_e.shape).copy()
        self.w_shape = float(w["shape"])
        # measured shapes, scaled
        self.shape_rows = []  # per test mode: (model dof indices, scaled test shape, ref position)
        for k, m in enumerate(data.modes):
            if not (use_shapes and m.has_shape and len(m.dofs) >= 2):
                self.shape_rows.append(None)
                continue
            pos = model.dof_index(m.dofs, f"test mode {k + 1} shape")
            phi = np.real(m.shape * np.exp(-1j * np.angle(m.shape[np.argmax(np.abs(m.shape))]))) if np.iscomplexobj(m.shape) else m.shape
            ref = None
            if shape_scaling == "ref":
                ref_label = ref_dof or m.dofs[0]
                if ref_label not in m.dofs:
                    raise InputError(f"test mode {k + 1}: reference dof {ref_label} is not measured")
                ref = list(m.dofs).index(ref_label)
            psi_e, _ = scaled_shape(phi, None, shape_scaling, ref)
            self.shape_rows.append((pos, psi_e, ref))
        has_shape = [r is not None for r in self.shape_rows]
        self.any_shape = any(has_shape)
        # the union of the measured dofs: where the shape derivatives are needed
        self.sensors = np.unique(np.concatenate([r[0] for r in self.shape_rows if r is not None] or [np.zeros(0, np.intp)]))
        n_test = len(data.modes)
        # a buffer of modes above the paired ones: room to re-pair, and what the series routes need
        self.n_modes = min(model.n_dofs, n_modes or buffered_modes(n_test))
        self.cache_key = None
        self.pairs_seen: dict[int, int] = {}
        self.swaps: list[dict] = []
        self.nfev = 0
        self.last_pairs = []

    # --------------------------------------------------------------- evaluation
    def _evaluate(self, x):
        key = x.tobytes()
        if key == self.cache_key:
            return self.cache
        p = self.to_p(x)
        modes = model_modes(self.model, p, n_modes=self.n_modes)
        pairs = self._pair(modes)
        self.cache_key, self.cache = key, (p, modes, pairs)
        return self.cache

    def _pair(self, modes):
        n_test = len(self.data.modes)
        with_shape = [k for k in range(n_test) if self.shape_rows[k] is not None]
        pairs: dict[int, tuple[int, float]] = {}
        if with_shape:
            macs = np.zeros((len(with_shape), modes.n_modes))
            for row, k in enumerate(with_shape):
                pos, psi_e, _ = self.shape_rows[k]
                macs[row] = mac(psi_e, modes.shapes[pos, :])[0]
            for r, j, m in pair_modes(macs, self.min_mac):
                pairs[with_shape[r]] = (j, m)
            missing = [k + 1 for k in with_shape if k not in pairs]
            if missing:
                raise NumericalError(
                    f"test mode(s) {missing} pair with no model mode (MAC below {self.min_mac:g} for all "
                    f"{modes.n_modes} computed modes): check the dof labels, or lower --min-mac"
                )
        free_model = [j for j in range(modes.n_modes) if j not in {v[0] for v in pairs.values()}]
        for k in range(n_test):
            if k not in pairs:
                if not free_model:
                    raise NumericalError(f"test mode {k + 1}: no model mode left to pair with")
                pairs[k] = (free_model.pop(0), math.nan)
        out = [(k, pairs[k][0], pairs[k][1]) for k in range(n_test)]
        for k, j, _ in out:
            if k in self.pairs_seen and self.pairs_seen[k] != j:
                self.swaps.append({"evaluation": self.nfev, "test_mode": k, "from_model_mode": self.pairs_seen[k], "to_model_mode": j})
            self.pairs_seen[k] = j
        self.last_pairs = out
        return out

    def residuals(self, x):
        self.nfev += 1
        p, modes, pairs = self._evaluate(x)
        res = []
        for k, j, _ in pairs:
            res.append([self.w_lam[k] * (modes.eigenvalues[j] - self.lam_e[k]) / self.lam_e[k]])
            row = self.shape_rows[k]
            if row is not None:
                pos, psi_e, ref = row
                psi_a, _ = scaled_shape(modes.shapes[pos, j], None, self.scaling, ref)
                if self.scaling == "unit" and psi_a @ psi_e < 0:
                    psi_a = -psi_a
                d = self.w_shape * (psi_a - psi_e)
                res.append(np.delete(d, ref) if ref is not None else d)
        r = np.concatenate(res)
        if not np.all(np.isfinite(r)):
            raise NumericalError("non-finite residuals (the model became singular at these parameter values)")
        return r

    def jacobian(self, x):
        p, modes, pairs = self._evaluate(x)
        which = [j for _, j, _ in pairs]
        L = self.idx.size
        if self.any_shape:
            # mass-normalised derivatives at the measured dofs only, by the route asked for
            # ("auto": Nelson for small models, the adjoint/subspace series for large ones)
            sens = sensitivity_jacobian(self.model, modes, which, self.sensors, params=self.idx, values=p,
                                        method=self.sensitivity, shape_scaling="mass", relative_eigenvalues=False)
            dlam, dphi_s = sens.dlam, sens.dpsi
            self.sensitivity_used = sens.method
        else:
            dlam, dphi_s = eigenvalue_derivatives(self.model, modes, which, self.idx), None
            self.sensitivity_used = "fox-kapoor"
        rows = []
        for c, (k, j, _) in enumerate(pairs):
            rows.append(self.w_lam[k] * dlam[c][None, :] / self.lam_e[k])
            row = self.shape_rows[k]
            if row is not None:
                pos, psi_e, ref = row
                at = np.searchsorted(self.sensors, pos)
                psi_a, dpsi = scaled_shape(modes.shapes[pos, j], dphi_s[at, c, :], self.scaling, ref)
                if self.scaling == "unit" and psi_a @ psi_e < 0:
                    dpsi = -dpsi
                d = self.w_shape * dpsi
                rows.append(np.delete(d, ref, axis=0) if ref is not None else d)
        J = np.vstack(rows) if rows else np.zeros((0, L))
        return J * self.dp_dx(x)[None, :]


def _diagnostics(prob: _Problem, x, r, J, sigma: float | None) -> Diagnostics:
    p = prob.to_p(x)[prob.idx]
    dxdp = 1.0 / prob.dp_dx(x)
    Jp = J * dxdp[None, :]  # ∂r/∂p
    S = Jp * np.where(p != 0, np.abs(p), 1.0)[None, :]  # ∂r/∂(p/|p|): normalised sensitivity
    s = np.linalg.svd(S, compute_uv=False) if S.size else np.zeros(0)
    m, L = J.shape
    U, sv, Vt = np.linalg.svd(S, full_matrices=True) if S.size else (None, s, np.eye(L))
    tol = 1e-6 * (sv[0] if sv.size else 0)
    rank = int(np.sum(sv > tol))
    poor: set[str] = set()
    for k in range(rank, L):
        v = Vt[k]
        for j in np.flatnonzero(np.abs(v) >= 0.3 * np.abs(v).max()):
            poor.add(prob.names[j])
    cond = float(sv[0] / sv[-1]) if sv.size and sv[-1] > 0 and L <= m else math.inf
    cov = np.full((L, L), np.nan)
    if rank == L and m > 0:
        JtJ_inv = np.linalg.pinv(Jp.T @ Jp)
        if sigma is not None:
            cov = JtJ_inv  # residuals already divided by their standard deviations
        elif m > L:
            cov = JtJ_inv * float(r @ r) / (m - L)
    std = np.sqrt(np.clip(np.diag(cov), 0, None)) if np.all(np.isfinite(cov)) else np.full(L, np.nan)
    return Diagnostics(s, cond, rank, sorted(poor), cov, std, m, L)


def _solve(prob: _Parametrised, bounds, *, regularization, method: str, ftol: float, xtol: float, gtol: float,
           max_nfev: int):
    """Minimise ``prob.residuals`` with SciPy's least squares from ``prob.p_base``.

    Shared by every iterative updating problem (modal, FRF): the parameters' ``bounds`` (the
    model's full ``(lo, hi)``) mapped to the optimiser's variables, Tikhonov augmentation
    α (x − x_start) with α fixed or chosen by ``"gcv"`` / ``"lcurve"`` at the start, and the
    iteration history.  ``prob`` provides ``residuals(x)``, ``jacobian(x)`` and the
    :class:`_Parametrised` maps.  Returns ``(sol, history, regularization)``.
    """
    names = prob.names
    parametrisation = prob.param
    lo, hi = bounds
    lo, hi = lo[prob.idx], hi[prob.idx]
    p_start = prob.p_base[prob.idx]
    outside = [n for n, v, a, b in zip(names, p_start, lo, hi) if not a <= v <= b]
    if outside:
        raise InputError(f"starting value(s) outside the bounds for: {', '.join(outside)}")
    if parametrisation == "log" and (np.any(p_start <= 0) or np.any(lo < 0)):
        raise InputError("log parametrisation needs positive starting values and non-negative lower bounds")
    x_start = prob.from_p(p_start)
    with np.errstate(divide="ignore"):
        xl, xh = prob.from_p(lo) if parametrisation != "log" else np.log(np.maximum(lo, 0)), prob.from_p(hi) if parametrisation != "log" else np.log(hi)
    if parametrisation == "relative" and np.any(p_start < 0):
        xl, xh = np.minimum(xl, xh), np.maximum(xl, xh)
    history: list[dict] = []

    # regularisation
    reg: dict = {}
    alpha = 0.0
    if regularization is not None:
        if isinstance(regularization, str):
            from .regularization import choose_alpha

            J0 = prob.jacobian(x_start)
            r0 = prob.residuals(x_start)
            choice = choose_alpha(J0, r0, rule=regularization)
            alpha = float(choice.alpha)
            reg = {"rule": regularization, "alpha": alpha}
        else:
            alpha = float(regularization)
            if not alpha >= 0:
                raise InputError("the regularization factor must be >= 0")
            reg = {"rule": "fixed", "alpha": alpha}

    def fun(x):
        r = prob.residuals(x)
        return np.concatenate([r, alpha * (x - x_start)]) if alpha else r

    def jac(x):
        J = prob.jacobian(x)
        return np.vstack([J, alpha * np.eye(x.size)]) if alpha else J

    def callback(intermediate_result):
        xi = intermediate_result.x
        history.append({"iteration": len(history), "cost": float(intermediate_result.cost),
                        "parameters": dict(zip(names, map(float, prob.to_p(xi)[prob.idx])))})

    bounds = (-np.inf, np.inf) if method == "lm" else (xl, xh)
    if method == "lm" and (np.any(np.isfinite(lo)) or np.any(np.isfinite(hi))):
        log.info("Levenberg-Marquardt ignores the parameter bounds")
    history.append({"iteration": 0, "cost": 0.5 * float(np.sum(fun(x_start) ** 2)),
                    "parameters": dict(zip(names, map(float, p_start)))})
    try:
        sol = least_squares(fun, x_start, jac=jac, bounds=bounds, method=method, x_scale="jac" if method != "lm" else 1.0,
                            ftol=ftol, xtol=xtol, gtol=gtol, max_nfev=max_nfev, callback=callback if method != "lm" else None)
    except NumericalError:
        raise
    except (ValueError, np.linalg.LinAlgError) as exc:
        raise NumericalError(f"the least-squares solver failed: {exc}") from None
    return sol, history, reg


def _modal_weights(weights, measurement_std):
    """User weights of the modal residuals, divided by the measurement standard deviations where
    given: ``(weights, sigma)`` with ``sigma`` the checked ``measurement_std`` (or None)."""
    w = dict(weights or {})
    sigma = None
    if measurement_std:
        sigma = dict(measurement_std)
        for key in ("eigenvalue", "shape"):
            if key in sigma:
                if not np.all(np.asarray(sigma[key], float) > 0):
                    raise InputError(f"measurement_std[{key!r}] must be positive")
                w[key] = np.asarray(w.get(key, 1.0), float) / np.asarray(sigma[key], float)
    return w, sigma


def update(model, data: TestData, *, params: Sequence[str] | None = None, x0: Mapping[str, float] | None = None,
           shape_scaling: str = "unit", ref_dof: str | None = None, weights: Mapping | None = None,
           measurement_std: Mapping | None = None, min_mac: float = 0.5, n_modes: int | None = None,
           parametrisation: str = "relative", method: str = "trf", max_nfev: int = 200,
           ftol: float = 1e-10, xtol: float = 1e-10, gtol: float = 1e-10, use_shapes: bool = True,
           regularization: float | str | None = None, values=None, sensitivity: str = "auto") -> UpdateResult:
    """Update the model's parameters so that its modes match the measured ones.

    Parameters
    ----------
    model : Model
    data : TestData
        Measured modes; shapes may be partial (any subset of model dofs, any scaling).
    params : names of the parameters to update (default: every parameter not ``fixed``).
    x0 : starting values {name: value} (default: the model's nominal values).
    shape_scaling : ``"unit"`` | ``"ref"`` | ``"max"``; ``ref_dof`` for ``"ref"`` (default: the
        first measured dof of each mode, the paper's eq. 33 convention).
    weights : {"eigenvalue": w or per-mode array, "shape": w}.
    measurement_std : {"eigenvalue": relative std of λ, "shape": std of scaled shape entries};
        when given the residuals are divided by them (weights = 1/std) and the covariance is
        absolute, not scaled by the residual.
    min_mac : pairing threshold.
    parametrisation : ``"relative"`` (x = p / p_start, default), ``"log"`` (x = log p) or ``"absolute"``.
    method : ``"trf"`` | ``"dogbox"`` | ``"lm"`` (Levenberg–Marquardt; no bounds).
    sensitivity : derivative route of the Jacobian (:func:`femupdate.sensitivity.jacobian`):
        ``"auto"`` (Nelson up to 1,500 dofs; above, the adjoint series when there are fewer
        measured dofs than parameters, else the subspace series), ``"nelson"``, ``"modal"``,
        ``"static"``, ``"subspace"``, ``"adjoint"`` or ``"fd"``.
    regularization : None, a Tikhonov factor α, or ``"gcv"`` / ``"lcurve"`` to choose it at the
        start; the residual is augmented with α (x − x_start), pulling the scaled parameters
        toward the starting model.
    values : values of the fixed parameters (default nominal).

    Returns
    -------
    UpdateResult
        ``success``/``status``/``message`` report convergence (non-convergence is a status,
        not an exception); ``diagnostics`` holds the identifiability figures.
    """
    if parametrisation not in PARAMETRISATIONS:
        raise InputError(f"unknown parametrisation {parametrisation!r}: use {', '.join(PARAMETRISATIONS)}")
    if method not in ("trf", "dogbox", "lm"):
        raise InputError(f"unknown method {method!r}: use trf, dogbox or lm")
    if sensitivity not in SENSITIVITY_CHOICES:
        raise InputError(f"unknown sensitivity method {sensitivity!r}: use {', '.join(SENSITIVITY_CHOICES)}")
    names = list(params) if params is not None else [model.parameter_names[j] for j in model.free]
    if not names:
        raise InputError("no parameters to update: every parameter is fixed")
    p_base = model.resolve(values)
    for name, v in dict(x0 or {}).items():
        p_base[model.parameter_index(name)] = float(v)
    w, sigma = _modal_weights(weights, measurement_std)
    prob = _Problem(model, data, names, shape_scaling, ref_dof, w, min_mac, n_modes, parametrisation, p_base,
                    use_shapes, sensitivity)
    # each mode: its eigenvalue, plus n_s - 1 independent shape entries (the scaling removes one)
    n_data = sum(1 + (0 if r is None else len(r[1]) - 1) for r in prob.shape_rows)
    if n_data < len(names) and regularization is None:
        raise InputError(
            f"{len(names)} parameters but only {n_data} independent data (eigenvalues and scaled shape entries): "
            "the problem is underdetermined; add data, fix parameters, or use regularization (e.g. --regularization gcv)"
        )
    sol, history, reg = _solve(prob, model.bounds, regularization=regularization, method=method, ftol=ftol,
                               xtol=xtol, gtol=gtol, max_nfev=max_nfev)
    p_final = prob.to_p(sol.x)
    _, modes, pairs = prob._evaluate(sol.x)
    r = prob.residuals(sol.x)
    J = prob.jacobian(sol.x)
    diag = _diagnostics(prob, sol.x, r, J, sigma)
    return UpdateResult(
        parameters=dict(zip(model.parameter_names, map(float, p_final))),
        names=tuple(names), x=p_final[prob.idx], success=bool(sol.success), status=int(sol.status),
        message=str(sol.message), cost=float(0.5 * r @ r), fun=r, jac=J, nfev=int(sol.nfev),
        njev=int(sol.njev or 0), iterations=max(len(history) - 1, int(sol.njev or 0)), history=history,
        pairs=[(k, j, float(m) if np.isfinite(m) else float(mac(prob.shape_rows[k][1], modes.shapes[prob.shape_rows[k][0], j])[0, 0]) if prob.shape_rows[k] is not None else math.nan) for k, j, m in pairs],
        test_frequencies_hz=data.frequencies_hz, model_frequencies_hz=np.array([modes.frequencies_hz[j] for _, j, _ in pairs]),
        swaps=list(prob.swaps), diagnostics=diag, regularization=reg,
        start=dict(zip(names, map(float, p_base[prob.idx]))), sensitivity=prob.sensitivity_used,
    )
