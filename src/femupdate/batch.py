r"""Batched multi-start updating of small dense models: every start advances at once.

:func:`femupdate.multistart.multistart` runs :func:`femupdate.updating.update` once per random
start.  For a small model (tens to a few hundred dofs) each run is dominated by Python overhead
around tiny LAPACK calls.  This module advances ALL ``R`` starts together:

* **Model matrices** for a batch of parameter vectors ``P`` (R, L) as a dense stack
  ``K = K_c + Σ_j P[:, j] K_j`` (R, n, n) — one product of the stacked ``vec(K_j)`` (kept sparse,
  (n², L)) with ``Pᵀ``; ``K_c`` holds K0 and the fixed parameters' terms; ``M`` likewise, or
  factorised once when no updated parameter enters it.
* **Eigen-solutions** of the whole stack: reduction to standard form with the Cholesky factor
  ``M = C Cᵀ`` (``A = C⁻¹ K C⁻ᵀ``) and one call of :func:`numpy.linalg.eigh` on (R, n, n)
  (batched LAPACK), ``φ = C⁻ᵀ y`` mass-normalised; all n modes of every start.
* **Pairing** to the test modes by MAC on the measured dofs, vectorised; the assignment per start
  by :func:`scipy.optimize.linear_sum_assignment` with the rules of ``_Problem._pair`` (same
  ``min_mac``, shape-less test modes take the lowest free model modes).
* **Residuals** exactly those of ``femupdate.updating._Problem.residuals`` (relative eigenvalue
  errors times their weights, scaled shape differences ``ψ_A − ψ_E`` for ``"unit"`` / ``"ref"`` /
  ``"max"``, sign alignment for ``"unit"``, the reference dof removed for ``"ref"``).
* **Exact Jacobians**, batched: :math:`\lambda_i' = \phi_i^T (K_j - \lambda_i M_j)\phi_i`
  (Fox & Kapoor; paper eq. 21) and, since eigh returns every mode, the *complete* modal method
  (exact, not truncated)

  .. math:: \phi_i' = \sum_{r \ne i} \phi_r \frac{\phi_r^T f_i}{\lambda_r - \lambda_i}
            - \tfrac12 (\phi_i^T M_j \phi_i)\,\phi_i, \qquad f_i = -(K_j - \lambda_i M_j)\phi_i ,

  followed by the scaled-shape rules of :mod:`femupdate.sensitivity.scaling` and the parameter
  transformation (``relative`` / ``log`` / ``absolute``) of :mod:`femupdate.updating`.

The optimiser is SciPy's trust-region-reflective method (``scipy.optimize.least_squares(
method="trf", x_scale="jac", tr_solver="exact")``, the per-start path's solver) transcribed
decision for decision and compiled per start (:mod:`femupdate._trf`, numba): the same Coleman–Li
reflective scaling for the bounds, the same exact trust-region subproblem (Moré's
Levenberg–Marquardt parameter on one SVD per iteration), the same choice between the trust-region
step, its reflection and the scaled anti-gradient, the same radius update and the same
``ftol``/``xtol``/``gtol`` tests and status codes.  Reproducing the per-start algorithm (rather
than inventing another damping scheme) is what makes the batched path land in the same basin as
the per-start path from the same start, so both give the same clusters.  The arithmetic differs
only in round-off: the augmented Jacobian is reduced to its R factor by Householder reflections
and the SVD taken of that factor.  Decisions can therefore differ only at the round-off floor of
the cost, after convergence (typically an extra or a missing final evaluation).

Two routes drive it:

* :meth:`BatchProblem.solve` (default): the residuals and Jacobians above compiled too
  (:mod:`femupdate._modal`), every start run to the end inside compiled code, the starts spread
  over the CPU cores — no Python between iterations.  Cost per start and iteration: one
  symmetric eigen-decomposition (n, n), one QR of (m + L, L + 1), singular values of (L, L)
  (the singular vectors too when the trust region cuts the step), and the exact Jacobian.
* :func:`least_squares_batch` with any Python residual function (and
  ``BatchProblem.solve(compiled=False)`` with the NumPy residuals of this module): every active
  start evaluated once per round in one call, the solver's bookkeeping compiled per start.

A start whose evaluation fails — repeated or rigid-body paired modes (their derivatives are not
defined), a test mode that pairs with no model mode, a non-positive-definite mass matrix, a
non-finite residual — is marked failed with the message the per-start path would give; the rest
of the batch carries on.

Use :func:`femupdate.multistart.multistart` (it dispatches here automatically for models of at
most :data:`AUTO_MAX_DOFS` dofs and supported options) or :func:`multistart_batched` directly.
The compiled code is built by numba on first use (some 20 s) and cached on disk beside the
package (or in numba's user cache when that is read-only); later processes load it.
"""

from __future__ import annotations

import dataclasses
import logging
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp
from scipy.optimize import linear_sum_assignment

from ._errors import FemupdateError, InputError
from .modal import DENSE_LIMIT
from .sensitivity._common import REPEATED_TOL
from .updating import PARAMETRISATIONS, UpdateResult, _diagnostics, _modal_weights, _Problem, update

log = logging.getLogger(__name__)

AUTO_MAX_DOFS = 200  #: models up to this size take the batched path by default
#: keyword options of :func:`femupdate.updating.update` the batched path implements
SUPPORTED_OPTIONS = frozenset({
    "shape_scaling", "ref_dof", "weights", "measurement_std", "min_mac", "n_modes", "parametrisation",
    "method", "max_nfev", "ftol", "xtol", "gtol", "use_shapes", "regularization", "values", "sensitivity",
})
_CHUNK_ELEMENTS = 4_000_000  # float64 entries (32 MB) per working array: starts are chunked beyond

TERMINATION_MESSAGES = {  # scipy.optimize.least_squares' messages, for identical reports
    0: "The maximum number of function evaluations is exceeded.",
    1: "`gtol` termination condition is satisfied.",
    2: "`ftol` termination condition is satisfied.",
    3: "`xtol` termination condition is satisfied.",
    4: "Both `ftol` and `xtol` termination conditions are satisfied.",
}
FAILED = -3  #: status of a start whose evaluation failed (its message says why)
_RUNNING = -99


# ====================================================================== options
def unsupported(model, options: Mapping, explicit: bool = False) -> str | None:
    """Why the batched path cannot run this study (None when it can).

    ``explicit``: the caller asked for the batched path, so only hard limits apply (dense models
    up to :data:`femupdate.modal.DENSE_LIMIT` dofs); otherwise the automatic choice also requires
    at most :data:`AUTO_MAX_DOFS` dofs.
    """
    extra = sorted(set(options) - SUPPORTED_OPTIONS)
    if extra:
        return f"option(s) {', '.join(extra)} are not implemented by the batched path"
    if options.get("method", "trf") != "trf":
        return f"method={options['method']!r}: the batched path implements trf only"
    if options.get("regularization") is not None:
        return "regularization: the batched path solves the unregularised problem only"
    if options.get("sensitivity", "auto") != "auto":
        return f"sensitivity={options['sensitivity']!r}: the batched path uses exact derivatives (sensitivity='auto')"
    limit = DENSE_LIMIT if explicit else AUTO_MAX_DOFS
    if model.n_dofs > limit:
        return f"the model has {model.n_dofs} dofs; the batched (dense) path takes at most {limit}"
    return None


def supports(model, options: Mapping) -> bool:
    """True when :func:`multistart` should take the batched path automatically."""
    return unsupported(model, options) is None


# ====================================================================== results
@dataclass(frozen=True, eq=False)
class BatchRun:
    """Result of one start of a batched study (a light :class:`~femupdate.updating.UpdateResult`).

    ``x`` are the updated parameters' values (``names`` order) and ``parameters`` every model
    parameter; ``cost`` = ½‖r‖²; ``fun`` (m,) and ``jac`` (m, L, in the solver's variables) at the
    solution; ``pairs`` [(test mode, model mode, MAC)]; ``status``/``message``/``success`` as
    :func:`scipy.optimize.least_squares` reports them; ``history`` one entry per iteration.
    """

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
    optimality: float
    pairs: list[tuple[int, int, float]]
    model_frequencies_hz: np.ndarray
    start: dict[str, float] = field(default_factory=dict)
    history_cost: np.ndarray = field(default_factory=lambda: np.zeros(0))  #: (iterations + 1,)
    history_x: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))  #: (iterations + 1, L) values of names

    @property
    def history(self) -> list[dict]:
        """One entry per iteration, as :attr:`UpdateResult.history` (built on demand)."""
        return [{"iteration": i, "cost": float(c), "parameters": dict(zip(self.names, map(float, x)))}
                for i, (c, x) in enumerate(zip(self.history_cost, self.history_x))]


@dataclass(frozen=True, eq=False)
class BatchLSQResult:
    """Result of :func:`least_squares_batch`: one row per start.

    ``status`` as :func:`scipy.optimize.least_squares` (0 evaluations exhausted, 1 gtol, 2 ftol,
    3 xtol, 4 ftol and xtol) or :data:`FAILED`; ``message`` the termination message or the error;
    ``history`` per start a list of (cost, x) after each iteration (the first entry: the start),
    built from the arrays ``history_cost`` and ``history_x``.
    """

    x: np.ndarray
    cost: np.ndarray
    fun: np.ndarray
    jac: np.ndarray
    grad: np.ndarray
    optimality: np.ndarray
    nfev: np.ndarray
    njev: np.ndarray
    iterations: np.ndarray
    status: np.ndarray
    message: list[str]
    history_cost: np.ndarray  #: (R, H) cost after each iteration (entries up to ``iterations``)
    history_x: np.ndarray  #: (R, H, n) the variables after each iteration

    @property
    def success(self) -> np.ndarray:
        return self.status > 0

    @property
    def history(self) -> list[list[tuple[float, np.ndarray]]]:
        """Per start a list of (cost, x) after each iteration, the first entry the start (empty
        when no history was kept)."""
        H = self.history_cost.shape[1]
        return [[(float(self.history_cost[r, k]), self.history_x[r, k].copy())
                 for k in range(min(int(self.iterations[r]) + 1, H))] if self.status[r] != FAILED or self.nfev[r] else []
                for r in range(self.x.shape[0])]


# ====================================================================== the batched solver
def _make_strictly_feasible(x, lb, ub, rstep):
    """scipy ``make_strictly_feasible`` row-wise, for the starting points (``rstep`` > 0)."""
    x_new = x.copy()
    with np.errstate(invalid="ignore", over="ignore"):  # infinite bounds: masked out below
        lower_dist, upper_dist = x - lb, ub - x
        lower = np.isfinite(lb) & (lower_dist <= np.minimum(upper_dist, rstep * np.maximum(1, np.abs(lb))))
        upper = np.isfinite(ub) & (upper_dist <= np.minimum(lower_dist, rstep * np.maximum(1, np.abs(ub))))
        x_new = np.where(lower & ~upper, lb + rstep * np.maximum(1, np.abs(lb)), x_new)
        x_new = np.where(upper, ub - rstep * np.maximum(1, np.abs(ub)), x_new)
        tight = (x_new < lb) | (x_new > ub)
        return np.where(tight, 0.5 * (lb + ub), x_new)


def _prepare(x0, bounds, max_nfev):
    """Starting points, bounds, the rows refused before any evaluation, and max_nfev."""
    x0 = np.array(x0, dtype=float, ndmin=2)
    R, n = x0.shape
    lb = np.broadcast_to(np.asarray(bounds[0], float), (R, n)).copy()
    ub = np.broadcast_to(np.asarray(bounds[1], float), (R, n)).copy()
    if max_nfev is None:
        max_nfev = 100 * n
    message: list[str | None] = [None] * R
    for r in np.flatnonzero(np.any(lb >= ub, axis=1)):
        message[r] = "each lower bound must be strictly less than each upper bound"
    for r in np.flatnonzero(~np.all((x0 >= lb) & (x0 <= ub), axis=1)):
        message[r] = message[r] or "the initial guess is outside of the provided bounds"
    return x0, _make_strictly_feasible(x0, lb, ub, rstep=1e-10), lb, ub, int(max_nfev), message


def _result(st, message) -> BatchLSQResult:
    """The solver's state as a :class:`BatchLSQResult` (rows still running: out of evaluations)."""
    from . import _trf

    S = dict(zip(_trf.STATE, st))
    status = S["status"]
    status[status == _RUNNING] = 0
    msgs = [message[r] if status[r] == FAILED else TERMINATION_MESSAGES[int(status[r])] for r in range(status.size)]
    J, f = S["J"], S["f"]
    g = np.matmul(f[:, None, :], J)[:, 0, :]
    return BatchLSQResult(x=S["x"], cost=S["cost"], fun=f, jac=J, grad=g, optimality=S["g_norm"], nfev=S["nfev"],
                          njev=S["njev"], iterations=S["iterations"], status=status, message=msgs,
                          history_cost=S["hist_cost"], history_x=S["hist_x"])


def least_squares_batch(fun, jac, x0, bounds, *, ftol: float = 1e-8, xtol: float = 1e-8, gtol: float = 1e-8,
                        max_nfev: int | None = None, progress: Callable[[int, int], None] | None = None,
                        n_residuals=None, history: bool = True) -> BatchLSQResult:
    r"""Trust-region-reflective least squares for R independent problems at once.

    Each row follows :func:`scipy.optimize.least_squares` with ``method="trf"``,
    ``x_scale="jac"``, ``tr_solver="exact"`` and a linear loss decision for decision (the
    compiled transcription :mod:`femupdate._trf`; see the module notes): for the same residuals
    each row takes the same steps as that function would, up to round-off at the floor of the
    cost.  Bounds are handled as trf does: Coleman–Li reflective scaling, iterates kept strictly
    feasible, steps reflected at the bounds.  A round evaluates every active row once, in one
    call of ``fun``.

    Parameters
    ----------
    fun : callable ``fun(X, rows) -> (F, errors, token)``
        Residuals at ``X`` (S, n) for the starts ``rows`` (S,): ``F`` (S, m); ``errors`` a list
        of S messages (None where the evaluation succeeded; a failed start stops there);
        ``token`` anything :func:`jac` needs.
    jac : callable ``jac(token, sel) -> (J, errors)``
        Jacobians (len(sel), m, n) at the points of the evaluation ``token`` for its rows ``sel``.
    x0 : (R, n) starting points.
    bounds : (lb, ub), each broadcastable to (R, n).
    ftol, xtol, gtol, max_nfev : as :func:`scipy.optimize.least_squares` (default
        ``max_nfev = 100 n``).
    progress : called as ``progress(finished, R)`` when starts finish.
    n_residuals : (R,) per start, the number of residuals that are its own when the rows of F
        are zero-padded to a common width (several problems solved together); SciPy's rank
        test ``σ_min > eps·m·σ_max`` then uses each start's own ``m``.  Default: F's width.
    history : keep (cost, x) after every iteration of every row.

    Returns
    -------
    BatchLSQResult
    """
    from . import _trf

    x0, x, lb, ub, max_nfev, message = _prepare(x0, bounds, max_nfev)
    R, n = x0.shape
    refused = np.array([m is not None for m in message], bool)
    rows = np.flatnonzero(~refused)
    if rows.size == 0:
        st = _trf.new_state(x, lb, ub, 0, np.zeros(R), np.zeros(R), 1 if history else 0)
        st[_trf.STATE.index("status")][:] = FAILED
        return _result(st, message)
    F0, err, token = fun(x[rows], rows)
    m = F0.shape[1]
    m_row = np.full(R, m) if n_residuals is None else np.broadcast_to(np.asarray(n_residuals, dtype=int), (R,))
    st = _trf.new_state(x, lb, ub, m, m_row, np.full(R, m), max_nfev + 1 if history else 0)
    S = dict(zip(_trf.STATE, st))
    status, nfev, f, J = S["status"], S["nfev"], S["f"], S["J"]
    status[refused] = FAILED

    def fail(rows, errors):
        for r, e in zip(rows, errors):
            if e is not None:
                status[r], message[r] = FAILED, e

    nfev[rows] += 1
    f[rows] = F0
    fail(rows, err)
    ok = np.array([e is None for e in err], bool)
    if ok.any():
        J0, jerr = jac(token, np.flatnonzero(ok))
        J[rows[ok]] = J0
        S["njev"][rows[ok]] += 1
        fail(rows[ok], jerr)
    _trf.rows_init(st, rows.astype(np.int64))
    finished = int(np.sum(status != _RUNNING))
    if progress and finished:
        progress(finished, R)
    degenerate = "the least-squares solver failed: the trust-region step is degenerate"
    while True:
        act = np.flatnonzero(status == _RUNNING).astype(np.int64)
        flags = np.zeros(act.size, np.int64)
        if act.size:
            _trf.rows_propose(st, act, gtol, max_nfev, flags)
            for r, fl in zip(act, flags):
                if fl == _trf.DEGENERATE:
                    status[r], message[r] = FAILED, degenerate
                elif fl == _trf.BAD_JACOBIAN:
                    status[r], message[r] = FAILED, "NumericalError: non-finite Jacobian"
        done = int(np.sum(status != _RUNNING))
        if progress and done != finished:
            progress(done, R)
        finished = done
        act = act[flags == _trf.PROPOSED]
        if act.size == 0:
            break
        F_new, err, token = fun(S["x_new"][act], act)
        nfev[act] += 1
        good = np.array([e is None for e in err], bool)
        fail(act, err)
        acc = np.zeros(act.size, np.bool_)
        ended = np.zeros(act.size, np.bool_)
        g_rows = act[good]
        _trf.rows_judge(st, g_rows, np.ascontiguousarray(F_new[good]), ftol, xtol, max_nfev, acc[: g_rows.size],
                        ended[: g_rows.size])
        accepted = np.flatnonzero(good)[acc[: g_rows.size]]
        if accepted.size:
            J_new, jerr = jac(token, accepted)
            _trf.rows_accept(st, act[accepted], np.ascontiguousarray(J_new))
            fail(act[accepted], jerr)
    return _result(st, message)


# ====================================================================== the batched problem
def _reject_nonfinite(F, ok, errors) -> None:
    """Rows of residuals F that are not finite fail (``ok`` and ``errors`` updated in place)."""
    bad = ok & ~np.all(np.isfinite(F), axis=1)
    for r in np.flatnonzero(bad):
        errors[r] = "NumericalError: non-finite residuals (the model became singular at these parameter values)"
    ok &= ~bad


def _distinct_errors(lam, pairs, computed=None, real=None):
    """``check_distinct`` per row: the first paired mode (among the ``real`` test modes) that is a
    rigid-body mode or repeats another ``computed`` mode gives that row's error; None where none does.

    lam (S, n) eigenvalues; pairs (S, t) paired mode of each test mode; computed (S, n) and real (S, t)
    masks (default all True) for batches whose rows compute or measure different numbers of modes."""
    S, n = lam.shape
    if computed is None:
        computed = np.ones((S, n), bool)
    scale = np.maximum(np.max(np.where(computed, np.abs(lam), 0.0), axis=1), 1e-300)
    li = np.take_along_axis(lam, pairs, axis=1)  # (S, t)
    tol = REPEATED_TOL * np.maximum(np.abs(li), 1e-12 * scale[:, None])
    gap = (np.abs(lam[:, None, :] - li[:, :, None]) <= tol[:, :, None]) & computed[:, None, :]  # (S, t, n)
    np.put_along_axis(gap, pairs[:, :, None], False, axis=2)
    bad = (li == 0.0) | gap.any(axis=2)
    if real is not None:
        bad &= real
    out: list[str | None] = [None] * S
    for r in np.flatnonzero(bad.any(axis=1)):
        t = int(np.flatnonzero(bad[r])[0])  # the first offending test mode, as check_distinct
        i = int(pairs[r, t])
        if li[r, t] == 0.0:
            out[r] = (f"NumericalError: mode {i + 1} is a rigid-body mode (zero frequency): its derivatives are "
                      "not defined; differentiate the flexible modes only")
        else:
            j = int(np.flatnonzero(gap[r, t])[0])
            out[r] = (f"NumericalError: modes {i + 1} and {j + 1} are repeated (eigenvalues {li[r, t]:.10g} and "
                      f"{lam[r, j]:.10g}): eigenvector derivatives of repeated modes are not unique; femupdate "
                      "refuses rather than return a wrong derivative (pair modes by subspace, or perturb the model "
                      "to split them)")
    return out


@dataclass(eq=False)
class _Evaluation:
    """Eigen-solutions, pairs and residuals of a batch of parameter vectors (rows of one call)."""

    rows: np.ndarray  # start indices
    X: np.ndarray  # (S, L) solver variables
    lam: np.ndarray  # (S, n) all eigenvalues, ascending (rigid ones of the computed set zeroed)
    Phi: np.ndarray  # (S, n, n) mass-normalised modes
    pairs: np.ndarray  # (S, n_test) model mode of each test mode
    macs: np.ndarray  # (S, n_test) pairing MAC (NaN for shape-less test modes)
    fun: np.ndarray  # (S, m)
    errors: list  # (S,) None or message


class BatchProblem:
    """Residuals and exact Jacobians of one updating problem at R parameter vectors at once.

    The problem is the one :func:`femupdate.updating.update` solves from each start: start ``r``
    has ``p_base`` = the model's values (or ``values``) with the updated parameters set to
    ``starts[r]``, so the ``"relative"`` variables are x = p / |p_start| per start.

    Parameters
    ----------
    model : Model
    data : TestData
    names : updated parameters.
    starts : (R, L) starting values of ``names`` (physical units).
    **options : the options of :func:`~femupdate.updating.update` listed in
        :data:`SUPPORTED_OPTIONS`.

    Attributes
    ----------
    x_start, lb, ub : (R, L) starting point and bounds in the solver's variables.
    n_residuals : int
    start_errors : list of (R,) None or the message of a start ``update`` would refuse.
    """

    def __init__(self, model, data, names: Sequence[str], starts, *, shape_scaling: str = "unit",
                 ref_dof: str | None = None, weights: Mapping | None = None, measurement_std: Mapping | None = None,
                 min_mac: float = 0.5, n_modes: int | None = None, parametrisation: str = "relative",
                 use_shapes: bool = True, values=None, sensitivity: str = "auto", method: str = "trf",
                 regularization=None, max_nfev: int = 200, ftol: float = 1e-10, xtol: float = 1e-10,
                 gtol: float = 1e-10):
        # --- the checks and set-up of update(), once for all starts
        if parametrisation not in PARAMETRISATIONS:
            raise InputError(f"unknown parametrisation {parametrisation!r}: use {', '.join(PARAMETRISATIONS)}")
        reason = unsupported(model, dict(method=method, regularization=regularization, sensitivity=sensitivity),
                             explicit=True)
        if reason:
            raise InputError(f"batched updating: {reason}")
        names = list(names)
        if not names:
            raise InputError("no parameters to update: every parameter is fixed")
        starts = np.array(starts, dtype=float, ndmin=2)
        if starts.shape[1] != len(names):
            raise InputError(f"starts has shape {starts.shape}, expected (R, {len(names)}) for {', '.join(names)}")
        self.model = model
        self.names = tuple(names)
        self.options = dict(max_nfev=max_nfev, ftol=ftol, xtol=xtol, gtol=gtol)
        p_base = model.resolve(values)
        w, self.sigma = _modal_weights(weights, measurement_std)
        self._problem_args = (model, data, names, shape_scaling, ref_dof, w, min_mac, n_modes, parametrisation)
        self._problem_kw = (use_shapes, sensitivity)
        tpl = _Problem(model, data, names, shape_scaling, ref_dof, w, min_mac, n_modes, parametrisation, p_base,
                       use_shapes, sensitivity)
        self.template = tpl
        self.idx = tpl.idx
        self.param = parametrisation
        self.scaling = shape_scaling
        self.min_mac = float(min_mac)
        self.lam_e = tpl.lam_e
        self.w_lam = tpl.w_lam
        self.w_shape = tpl.w_shape
        self.shape_rows = tpl.shape_rows
        self.n_test = len(tpl.shape_rows)
        self.nm = tpl.n_modes
        self.with_shape = [k for k in range(self.n_test) if self.shape_rows[k] is not None]
        self.any_shape = bool(self.with_shape)
        self.n_residuals = sum(1 + (0 if r is None else len(r[1]) - (r[2] is not None)) for r in self.shape_rows)
        n_data = sum(1 + (0 if r is None else len(r[1]) - 1) for r in self.shape_rows)
        if n_data < len(names):
            raise InputError(
                f"{len(names)} parameters but only {n_data} independent data (eigenvalues and scaled shape entries): "
                "the problem is underdetermined; add data, fix parameters, or use regularization (e.g. --regularization gcv)"
            )
        lo, hi = model.bounds
        lo, hi = lo[self.idx], hi[self.idx]
        if parametrisation == "log" and np.any(lo < 0):
            raise InputError("log parametrisation needs positive starting values and non-negative lower bounds")
        # --- per start: p_base, scale, x_start and bounds in the solver's variables
        R = starts.shape[0]
        self.R = R
        self.starts = starts
        self.p_fixed = p_base
        self.scale = np.where(starts != 0, np.abs(starts), 1.0)
        errors: list[str | None] = [None] * R
        for r in range(R):
            outside = [nm for nm, v, a, b in zip(names, starts[r], lo, hi) if not a <= v <= b]
            if outside:
                errors[r] = f"InputError: starting value(s) outside the bounds for: {', '.join(outside)}"
            elif parametrisation == "log" and np.any(starts[r] <= 0):
                errors[r] = "InputError: log parametrisation needs positive starting values and non-negative lower bounds"
        self.start_errors = errors
        # (a refused start keeps a harmless placeholder; it fails at its first evaluation)
        self.x_start = self._from_p(np.where(starts > 0, starts, 1.0) if parametrisation == "log" else starts)
        with np.errstate(divide="ignore"):
            if parametrisation == "log":
                xl = np.broadcast_to(np.log(np.maximum(lo, 0)), (R, len(names)))
                xh = np.broadcast_to(np.log(hi), (R, len(names)))
            else:
                xl, xh = self._from_p(np.broadcast_to(lo, (R, len(names)))), self._from_p(np.broadcast_to(hi, (R, len(names))))
        if parametrisation == "relative":
            xl, xh = np.minimum(xl, xh), np.maximum(xl, xh)
        self.lb, self.ub = np.array(xl, float), np.array(xh, float)
        # --- dense model data
        n = model.n_dofs
        self.n = n
        fixed = np.setdiff1d(np.arange(len(model.parameters)), self.idx)

        def stack(base, derivs):
            const = base.toarray()
            for j in fixed:
                if derivs[j] is not None:
                    const = const + p_base[j] * derivs[j].toarray()
            used = [derivs[j] if derivs[j] is not None else sp.csr_array((n, n)) for j in self.idx]
            vec = sp.vstack([sp.csr_array(d.reshape((1, n * n))) for d in used]).T.tocsr()  # (n², L)
            return const, used, vec, any(d.nnz for d in used)

        self.K_const, dK, self.K_vec, _ = stack(model.K0, model.dK)
        self.M_const, dM, self.M_vec, self.M_varies = stack(model.M0, model.dM)
        # Supports: the rows where K_j or M_j are nonzero (an element parameter touches few dofs).
        # φ_rᵀ K_j φ_t needs only those rows, so Φᵀ(K_j − λM_j)φ costs O(n w) per (j, mode), w the
        # widest support, instead of O(n²).  Padded with row 0 and zero coefficients.
        supp = [np.union1d(np.unique(a.tocoo().row), np.unique(b.tocoo().row)) for a, b in zip(dK, dM)]
        w = max(1, max((len(x) for x in supp), default=1))
        self.full_support = 2 * w > n  # wide supports: work with whole columns, no gather
        if self.full_support:
            w = n
            supp = [np.arange(n)] * len(supp)
        self.sup_w = w
        self.sup_idx = np.zeros((len(supp), w), dtype=np.intp)
        for j, x in enumerate(supp):
            self.sup_idx[j, : len(x)] = x

        def restrict(mats):
            rows = []
            for j, d in enumerate(mats):
                sel = np.zeros((w, n))
                x = supp[j]
                sel[np.arange(len(x)), x] = 1.0
                rows.append(sp.csr_array(sel) @ d)
            return sp.vstack(rows).tocsr() if rows else sp.csr_array((0, n))  # (L w, n)

        self.K_sup = restrict(dK)
        self.M_sup = restrict(dM)
        if not self.M_varies:
            md = np.diag(self.M_const)
            self._mass_error = None
            if np.any(~(md > 0)):
                self._mass_error = "InputError: the mass matrix is not positive definite (a dof has no mass)"
            else:
                try:
                    C = np.linalg.cholesky(self.M_const)
                    self.Cinv = np.linalg.inv(C)
                except np.linalg.LinAlgError:
                    self._mass_error = ("NumericalError: the least-squares solver failed: the mass matrix is not "
                                        "positive definite (its Cholesky factorisation failed)")
        # --- residual layout: per test mode, its eigenvalue then its scaled shape entries; test
        # modes measured at the same dofs (and reference) form a group, handled in one go
        self.eig_col = np.zeros(self.n_test, dtype=np.intp)
        shape_cols, col = {}, 0
        for k, row in enumerate(self.shape_rows):
            self.eig_col[k] = col
            col += 1
            if row is not None:
                ncols = len(row[1]) - (row[2] is not None)
                shape_cols[k] = np.arange(col, col + ncols)
                col += ncols
        groups: dict = {}
        for k in self.with_shape:
            pos, _, ref = self.shape_rows[k]
            groups.setdefault((tuple(pos.tolist()), ref), []).append(k)
        self.groups = []
        for (pos, ref), ks in groups.items():
            psi_e = np.column_stack([self.shape_rows[k][1] for k in ks])  # (n_s, g)
            cols = np.column_stack([shape_cols[k] for k in ks])  # (n_s', g)
            self.groups.append((np.array(ks, dtype=np.intp), np.array(pos, dtype=np.intp), psi_e, ref, cols))
        self.n_eval = np.zeros(R, int)

    # ------------------------------------------------------------------ parameters
    def _from_p(self, p):
        if self.param == "relative":
            return p / self.scale
        if self.param == "log":
            with np.errstate(divide="ignore", invalid="ignore"):
                return np.log(p)
        return np.array(p, float)

    def to_p(self, X, rows) -> np.ndarray:
        """Updated parameters' values (S, L) at solver variables X (S, L) of the starts ``rows``."""
        if self.param == "relative":
            return X * self.scale[rows]
        if self.param == "log":
            with np.errstate(over="ignore"):
                return np.exp(X)
        return np.array(X, float)

    def dp_dx(self, X, rows) -> np.ndarray:
        if self.param == "relative":
            return self.scale[rows]
        if self.param == "log":
            with np.errstate(over="ignore"):
                return np.exp(X)
        return np.ones_like(X)

    def full_p(self, X, rows) -> np.ndarray:
        """Full parameter vectors (S, n_parameters)."""
        P = np.broadcast_to(self.p_fixed, (len(rows), self.p_fixed.size)).copy()
        P[:, self.idx] = self.to_p(X, rows)
        return P

    # ------------------------------------------------------------------ evaluation
    def _chunks(self, S, per_row):
        step = max(1, int(_CHUNK_ELEMENTS // max(per_row, 1)))
        return [slice(a, min(a + step, S)) for a in range(0, S, step)]

    def _modes(self, Pu):
        """Eigenvalues (S, n) and mass-normalised modes (S, n, n) of the stacks K(p), M(p)."""
        S, n = Pu.shape[0], self.n
        errors: list[str | None] = [None] * S
        K = self.K_const + (self.K_vec @ Pu.T).T.reshape(S, n, n)
        finite = np.all(np.isfinite(Pu), axis=1)
        if self.M_varies:
            M = self.M_const + (self.M_vec @ Pu.T).T.reshape(S, n, n)
            md = np.diagonal(M, axis1=1, axis2=2)
            ok = finite & np.all(md > 0, axis=1)
            for r in np.flatnonzero(finite & ~ok):
                errors[r] = "NumericalError: the least-squares solver failed: the mass matrix is not positive definite: a dof has no mass"
            C = np.tile(np.eye(n), (S, 1, 1))
            good = np.flatnonzero(ok)
            try:
                C[good] = np.linalg.cholesky(M[good])
            except np.linalg.LinAlgError:
                for r in good:
                    try:
                        C[r] = np.linalg.cholesky(M[r])
                    except np.linalg.LinAlgError:
                        ok[r] = False
                        errors[r] = ("NumericalError: the least-squares solver failed: the mass matrix is not "
                                     "positive definite (its Cholesky factorisation failed)")
            Cinv = np.linalg.inv(C)
        else:
            if self._mass_error:
                return None, None, [self._mass_error] * S, None, None
            M = None
            ok = finite.copy()
            Cinv = self.Cinv
        for r in np.flatnonzero(~finite):
            errors[r] = "NumericalError: non-finite residuals (the model became singular at these parameter values)"
        A = Cinv @ K @ np.swapaxes(Cinv, -1, -2)
        A = 0.5 * (A + np.swapaxes(A, 1, 2))
        A[~ok] = np.eye(n)
        lam = np.zeros((S, n))
        Y = np.zeros((S, n, n))
        try:
            lam, Y = np.linalg.eigh(A)
        except np.linalg.LinAlgError:
            for r in range(S):
                try:
                    lam[r], Y[r] = np.linalg.eigh(A[r])
                except np.linalg.LinAlgError:
                    ok[r] = False
                    errors[r] = "NumericalError: the least-squares solver failed: the eigenvalue solver did not converge"
        Phi = np.swapaxes(Cinv, -1, -2) @ Y
        # model_modes' rigid-body and definiteness rules, on the modes it would compute
        kd = np.abs(np.diagonal(K, axis1=1, axis2=2))
        md = np.diagonal(M, axis1=1, axis2=2) if M is not None else np.diag(self.M_const)[None, :]
        with np.errstate(divide="ignore", invalid="ignore"):
            scale = np.maximum(np.maximum(np.max(np.abs(lam[:, :self.nm]), axis=1), np.max(kd / md, axis=1)), 1e-300)
        neg = ok & np.any(lam[:, :self.nm] < -1e-12 * scale[:, None], axis=1)
        for r in np.flatnonzero(neg):
            errors[r] = ("NumericalError: the least-squares solver failed: K is not positive semi-definite: negative "
                         f"eigenvalue {lam[r, :self.nm].min():.4g} (check for negative stiffness parameters)")
        ok &= ~neg
        head = lam[:, :self.nm]
        lam[:, :self.nm] = np.where(np.abs(head) <= 1e-12 * scale[:, None], 0.0, head)
        return lam, Phi, errors, ok, scale

    def _modes_of_rows(self, Pu, errors, ok):
        """:meth:`_modes` of the parameter rows ``Pu`` (S, L), in chunks: eigenvalues (S, n) and
        modes (S, n, n); a failed row's message goes to ``errors`` and ``ok`` (both updated in place)."""
        S, n = Pu.shape[0], self.n
        lam = np.zeros((S, n))
        Phi = np.zeros((S, n, n))
        for c in self._chunks(S, 4 * n * n):
            lam_c, Phi_c, err_c, ok_c, _ = self._modes(Pu[c])
            if lam_c is None:
                for i, e in zip(range(c.start, c.stop), err_c):
                    errors[i] = errors[i] or e
                ok[c] = False
                continue
            lam[c], Phi[c] = lam_c, Phi_c
            for i, e in zip(range(c.start, c.stop), err_c):
                if e is not None and errors[i] is None:
                    errors[i] = e
            ok[c] &= ok_c
        return lam, Phi

    def _pair(self, lam, Phi, ok, errors):
        """Pairs (S, n_test) and pairing MACs, by the rules of ``_Problem._pair``.

        The assignment maximising the total MAC is the Hungarian algorithm's
        (:func:`scipy.optimize.linear_sum_assignment`).  When every test mode's best model mode
        is strictly better than its second best and no two test modes share it, that row-wise
        choice is the unique optimum, so it is taken without the call; the rest go through it.
        """
        S, nm, nt = lam.shape[0], self.nm, self.n_test
        pairs = np.zeros((S, nt), dtype=np.intp)
        macs = np.full((S, nt), np.nan)
        if not self.with_shape:
            pairs[:] = np.arange(nt)  # frequencies only: the lowest modes, in order
            if nt > nm:
                for r in np.flatnonzero(ok):
                    errors[r] = f"NumericalError: test mode {nm + 1}: no model mode left to pair with"
                ok[:] = False
            return pairs, macs
        nws = len(self.with_shape)
        M = np.zeros((S, nws, nm))
        for ks, pos, psi_e, _, _ in self.groups:
            rows = [self.with_shape.index(k) for k in ks]
            B = Phi[:, pos, :nm]  # (S, n_s, nm)
            num = np.einsum("ig,sij->sgj", psi_e, B) ** 2
            den = np.sum(psi_e**2, axis=0)[None, :, None] * np.einsum("sij,sij->sj", B, B)[:, None, :]
            with np.errstate(invalid="ignore", divide="ignore"):
                M[:, rows] = np.clip(np.where(den > 0, num / np.where(den > 0, den, 1.0), 0.0), 0.0, 1.0)
        fast = np.zeros(S, bool)
        if S > 4 and nws == nt:  # (for a few rows the vector test costs more than the calls)
            best = np.argmax(M, axis=2)  # (S, nws)
            top = np.take_along_axis(M, best[:, :, None], axis=2)[:, :, 0]
            if nm > 1:
                M2 = M.copy()
                np.put_along_axis(M2, best[:, :, None], -np.inf, axis=2)
                strict = np.all(top > np.max(M2, axis=2), axis=1)
            else:
                strict = np.ones(S, bool)
            srt = np.sort(best, axis=1)
            distinct = np.all(srt[:, 1:] != srt[:, :-1], axis=1) if nws > 1 else np.ones(S, bool)
            fast = ok & strict & distinct & np.all(top >= self.min_mac, axis=1)
            ws = np.array(self.with_shape, dtype=np.intp)
            pairs[np.ix_(fast, ws)] = best[fast]
            macs[np.ix_(fast, ws)] = top[fast]
        for r in np.flatnonzero(ok & ~fast):
            rr, cc = linear_sum_assignment(M[r], maximize=True)
            got = {}
            for a, b in zip(rr, cc):
                if M[r, a, b] >= self.min_mac:
                    got[self.with_shape[a]] = (int(b), float(M[r, a, b]))
            missing = [k + 1 for k in self.with_shape if k not in got]
            if missing:
                errors[r] = (f"NumericalError: test mode(s) {missing} pair with no model mode (MAC below {self.min_mac:g} "
                             f"for all {nm} computed modes): check the dof labels, or lower --min-mac")
                ok[r] = False
                continue
            used = {b for b, _ in got.values()}
            free = [j for j in range(nm) if j not in used]
            for k in range(nt):
                if k in got:
                    pairs[r, k], macs[r, k] = got[k]
                elif free:
                    pairs[r, k] = free.pop(0)
                else:
                    errors[r] = f"NumericalError: test mode {k + 1}: no model mode left to pair with"
                    ok[r] = False
                    break
        return pairs, macs

    def _scaled(self, phs, ref):
        """Scaled measured model shapes, along axis 1 of ``phs`` (S, n_s, g).

        Returns psi (S, n_s, g), the scale s (S, g), the position k of the scaling entry (S, g)
        and where ``"ref"``/``"max"`` scaling meets a node (S, g), as ``scaled_shape``.
        """
        S, _, g = phs.shape
        a = np.abs(phs)
        if self.scaling == "ref":
            k = np.full((S, g), ref, dtype=np.intp)
        else:
            k = np.argmax(a, axis=1)
        s = phs[np.arange(S)[:, None], k, np.arange(g)[None, :]]
        if self.scaling in ("ref", "max"):
            node = ~(np.abs(s) > 1e-12 * np.max(a, axis=1))
        else:
            s = np.sign(s) * np.sqrt(np.einsum("sig,sig->sg", phs, phs))
            node = np.zeros((S, g), bool)
        with np.errstate(divide="ignore", invalid="ignore"):
            psi = phs / s[:, None, :]
        return psi, s, k, node

    def _group_shapes(self, Phi, pairs, ks, pos):
        """Model shapes of the paired modes of test modes ``ks`` at ``pos``: (S, n_s, g)."""
        S = Phi.shape[0]
        return Phi[np.arange(S)[:, None, None], pos[None, :, None], pairs[:, ks][:, None, :]]

    def _begin_evaluation(self, X, rows):
        """Solver variables as (S, L), their rows, each row's inherited error and the ok mask."""
        X = np.array(X, dtype=float, ndmin=2)
        rows = np.arange(X.shape[0]) if rows is None else np.asarray(rows, dtype=np.intp)
        self.n_eval[rows] += 1
        errors: list[str | None] = [self.start_errors[r] for r in rows]
        ok = np.array([e is None for e in errors], bool)
        return X, rows, errors, ok

    def evaluate(self, X, rows=None) -> _Evaluation:
        """Eigen-solutions, pairs and residuals (S, m) at solver variables X (S, L)."""
        X, rows, errors, ok = self._begin_evaluation(X, rows)
        S = X.shape[0]
        with np.errstate(all="ignore"):
            lam, Phi = self._modes_of_rows(self.to_p(X, rows), errors, ok)
            pairs, macs = self._pair(lam, Phi, ok, errors)
            F = np.zeros((S, self.n_residuals))
            lam_p = np.take_along_axis(lam, pairs, axis=1)
            F[:, self.eig_col] = self.w_lam * (lam_p - self.lam_e) / self.lam_e
            for ks, pos, psi_e, ref, cols in self.groups:
                psi, _, kk, node = self._scaled(self._group_shapes(Phi, pairs, ks, pos), ref)
                for r, g in zip(*np.nonzero(node & ok[:, None])):
                    if ok[r]:
                        errors[r] = (f"NumericalError: cannot scale the shape to 1 at measured dof #{kk[r, g] + 1}: "
                                     "the mode has a node there")
                        ok[r] = False
                if self.scaling == "unit":
                    psi = psi * np.where(np.einsum("sig,ig->sg", psi, psi_e) < 0, -1.0, 1.0)[:, None, :]
                dd = self.w_shape * (psi - psi_e)
                F[:, cols] = np.delete(dd, ref, axis=1) if ref is not None else dd
        _reject_nonfinite(F, ok, errors)
        for r in np.flatnonzero(~ok):
            if errors[r] is None:  # pragma: no cover - every failure above leaves a message
                errors[r] = "NumericalError: evaluation failed"
        F[~ok] = 0.0
        return _Evaluation(rows, X, lam, Phi, pairs, macs, F, errors)

    def _check_distinct(self, lam, pairs):
        """``check_distinct`` on the paired modes among the computed ones: error or None per row."""
        return _distinct_errors(lam[:, :self.nm], pairs)

    def jacobian(self, ev: _Evaluation, sel=None):
        """Exact Jacobians ∂r/∂x (len(sel), m, L) at the points of ``ev`` (its rows ``sel``).

        Returns ``(J, errors)``; a row whose paired modes are repeated or rigid gets an error.
        """
        sel = np.arange(len(ev.rows)) if sel is None else np.asarray(sel, dtype=np.intp)
        S, n, L, nt = sel.size, self.n, self.idx.size, self.n_test
        JT = np.zeros((S, L, self.n_residuals))  # parameter-major; returned as a (S, m, L) view
        errors = self._check_distinct(ev.lam[sel], ev.pairs[sel])
        per_row = L * nt * (self.sup_w + 3 * n if self.any_shape else self.sup_w) + n * n
        if self.any_shape and not self.full_support:
            per_row += L * self.sup_w * n
        with np.errstate(all="ignore"):
            for c in self._chunks(S, per_row):
                JT[c] = self._jacobian_chunk(ev, sel[c]).transpose(0, 2, 1)
            JT *= self.dp_dx(ev.X[sel], ev.rows[sel])[:, :, None]
        for r, e in enumerate(errors):
            if e is not None:
                JT[r] = 0.0
        return JT.transpose(0, 2, 1), errors

    def _jacobian_chunk(self, ev, sel):
        r"""Rows ``sel`` of the Jacobian in the model parameters, ∂r/∂p (S, m, L).

        With G_j = (K_j − λ_t M_j) φ_t, nonzero only on the support of parameter j:
        λ_t' = φ_tᵀ G_j (eq. 21) and, by the complete modal method,
        φ_t' = Σ_{r≠t} φ_r (−φ_rᵀ G_j)/(λ_r − λ_t) − ½ (φ_tᵀ M_j φ_t) φ_t.
        """
        S, n, L, nt, w = sel.size, self.n, self.idx.size, self.n_test, self.sup_w
        ar = np.arange(S)
        lam, Phi, pairs = ev.lam[sel], ev.Phi[sel], ev.pairs[sel]
        lam_p = np.take_along_axis(lam, pairs, axis=1)  # (S, nt)
        Phi_p = np.take_along_axis(Phi, pairs[:, None, :], axis=2)  # (S, n, nt)
        flat = np.swapaxes(Phi_p, 0, 1).reshape(n, S * nt)
        G = (self.K_sup @ flat).reshape(L, w, S, nt).transpose(2, 0, 1, 3)  # (S, L, w, nt) on the supports
        Phi_pw = Phi_p[:, self.sup_idx.ravel(), :].reshape(S, L, w, nt)
        if self.M_varies:
            GM = (self.M_sup @ flat).reshape(L, w, S, nt).transpose(2, 0, 1, 3)
            G = G - lam_p[:, None, None, :] * GM
            mjj = np.einsum("slwt,slwt->stl", Phi_pw, GM)
        else:
            mjj = np.zeros((S, nt, L))
        # J is filled parameter-major, (S, L, m), and returned as a (S, m, L) view
        JT = np.zeros((S, L, self.n_residuals))
        JT[:, :, self.eig_col] = np.einsum("slwt,slwt->slt", Phi_pw, G) * (self.w_lam / self.lam_e)
        if not self.groups:
            return JT.transpose(0, 2, 1)
        # H[s, l, r, t] = φ_rᵀ G_l,t over the supports: a batched (n, w) @ (w, nt) product
        if self.full_support:
            H = np.matmul(np.swapaxes(Phi, 1, 2)[:, None, :, :], G)
        else:
            H = np.matmul(np.swapaxes(Phi[:, self.sup_idx.ravel(), :].reshape(S, L, w, n), 2, 3), G)
        for ks, pos, psi_e, ref, cols in self.groups:
            g = ks.size
            gi = np.arange(g)
            jt = pairs[:, ks]  # (S, g)
            inv = 1.0 / (lam_p[:, None, ks] - lam[:, :, None])  # (S, n, g): −1/(λ_r − λ_t)
            inv[ar[:, None], jt, gi[None, :]] = 0.0
            Hk = H[..., ks[0]: ks[-1] + 1] if np.all(np.diff(ks) == 1) else H[..., ks]
            coef = Hk * inv[:, None, :, :]  # (S, L, n, g): φ_rᵀf/(λ_r − λ_t)
            coef[ar[:, None], :, jt, gi[None, :]] = -0.5 * mjj[:, ks, :]
            dd = np.matmul(Phi[:, None, pos, :], coef)  # (S, L, n_s, g): φ' at the measured dofs
            phs = self._group_shapes(Phi, pairs, ks, pos)
            psi, s_, kk, _ = self._scaled(phs, ref)
            if self.scaling in ("ref", "max"):
                ds = np.take_along_axis(dd, kk[:, None, None, :], axis=2)[:, :, 0, :]  # (S, L, g)
            else:
                ds = np.einsum("sig,slig->slg", phs, dd) / s_[:, None, :]
            # ψ' = φ'/s − ψ s'/s, times the weight and the "unit" sign
            f = self.w_shape / s_
            if self.scaling == "unit":
                f = f * np.where(np.einsum("sig,ig->sg", psi, psi_e) < 0, -1.0, 1.0)
            dd *= f[:, None, None, :]
            dd -= psi[:, None, :, :] * (ds * f[:, None, :])[:, :, None, :]
            if ref is not None:
                dd = np.delete(dd, ref, axis=2)
            for c in range(g):  # each test mode's entries are contiguous in r
                JT[:, :, cols[0, c]: cols[-1, c] + 1] = dd[:, :, :, c]
        return JT.transpose(0, 2, 1)

    # convenience for tests and users -----------------------------------------------------
    def residuals(self, X):
        """Residuals (R, m) at solver variables X (R, L), one row per start; NaN rows where the
        evaluation fails (``evaluate(X).errors`` says why)."""
        ev = self.evaluate(X)
        F = ev.fun.copy()
        F[[e is not None for e in ev.errors]] = np.nan
        return F

    def jacobians(self, X):
        """Exact Jacobians (R, m, L) at solver variables X (R, L); NaN where the evaluation fails."""
        ev = self.evaluate(X)
        J, errors = self.jacobian(ev)
        J[[e is not None or f is not None for e, f in zip(ev.errors, errors)]] = np.nan
        return J

    # the solver interface of least_squares_batch -------------------------------------------
    def _fun(self, X, rows):
        ev = self.evaluate(X, rows)
        return ev.fun, ev.errors, ev

    def _jac(self, ev, sel):
        return self.jacobian(ev, sel)

    own_residuals = None  #: (R,) residuals of each row's own when rows are zero-padded (None: all)

    def solve(self, progress=None, compiled: bool = True) -> BatchLSQResult:
        """Every start from its ``x_start`` within ``(lb, ub)`` to the end: compiled, each start
        run through by :func:`femupdate._modal.solve_rows` (the default), or round by round by
        :func:`least_squares_batch` with the NumPy residuals and Jacobians of this class."""
        if compiled:
            return solve_compiled(self, self.datasets(), self.row_datasets(), progress=progress)
        return least_squares_batch(self._fun, self._jac, self.x_start, (self.lb, self.ub), progress=progress,
                                   n_residuals=self.own_residuals, **self.options)

    def evaluate_compiled(self, X, rows=None):
        """Residuals (S, m), exact Jacobians (S, m, L) and messages (None where fine) of the
        compiled kernels (:mod:`femupdate._modal`) at solver variables X (S, L) of ``rows``; each
        row's own residuals first (in :func:`femupdate.updating.update`'s order), zeros after."""
        from . import _modal

        X = np.array(X, dtype=float, ndmin=2)
        rows = np.arange(X.shape[0]) if rows is None else np.asarray(rows, dtype=np.int64)
        S, n = X.shape[0], self.n
        sp_, m_row = _modal.spec(self, self.datasets(), self.row_datasets(), self.scaling, self.w_shape, self.min_mac)
        m, T = int(m_row.max()), int(self.n_test)
        F, J = np.zeros((S, m)), np.zeros((S, m, X.shape[1]))
        LAM, PHI, PAIRS = np.zeros((S, n)), np.zeros((S, n, n)), np.zeros((S, T), np.int64)
        code, ci, cf, cm = np.zeros(S, np.int64), np.zeros((S, 2), np.int64), np.zeros((S, 2)), np.zeros((S, T), bool)
        _modal.evaluate_rows(sp_, rows.astype(np.int64), X, F, LAM, PHI, PAIRS, code, ci, cf, cm)
        ok = np.flatnonzero(code == 0)
        c2 = np.zeros(ok.size, np.int64)
        Jok = np.zeros((ok.size, m, X.shape[1]))
        _modal.jacobian_rows(sp_, rows[ok].astype(np.int64), X[ok], Jok, LAM[ok], PHI[ok], PAIRS[ok], c2, ci[ok], cf[ok])
        J[ok] = Jok
        code[ok] = c2
        msgs = [None if c == 0 else _modal.message(c, ci[i], cf[i], cm[i], self.min_mac) for i, c in enumerate(code)]
        return F, J, msgs

    def row_datasets(self):
        """The data set of each start (here one for all)."""
        return np.zeros(self.R, np.int64)

    def datasets(self):
        """The test data as :func:`femupdate._modal.spec` takes it: one data set."""
        modes = [(self.lam_e[k], self.w_lam[k], *(row if row is not None else (None, None, None)))
                 for k, row in enumerate(self.shape_rows)]
        return [(modes, self.nm)]


def solve_compiled(prob: BatchProblem, datasets, row_dataset, *, progress=None, history: bool = True,
                   chunk: int = 256) -> BatchLSQResult:
    """Run every start of ``prob`` to the end in compiled code (:func:`femupdate._modal.solve_rows`).

    ``datasets`` and ``row_dataset`` as :func:`femupdate._modal.spec`.  Rows go in a fixed
    shuffled order, ``chunk`` at a time (the rows of a chunk in parallel over the cores; progress
    reported and Ctrl-C taken between chunks); the result does not depend on the order.
    """
    from . import _modal, _trf

    o = prob.options
    x0, x, lb, ub, max_nfev, message = _prepare(prob.x_start, (prob.lb, prob.ub), o["max_nfev"])
    R, L = x0.shape
    refused = np.array([m is not None for m in message], bool)
    mass_error = None if prob.M_varies else prob._mass_error  # a fixed M that is not positive definite
    early = [None if refused[r] else (prob.start_errors[r] or mass_error) for r in range(R)]
    if mass_error:  # every start fails at its first evaluation
        sp_, m_row = None, np.zeros(R, np.int64)
    else:
        sp_, m_row = _modal.spec(prob, datasets, row_dataset, prob.scaling, prob.w_shape, prob.min_mac)
    m = int(max(m_row.max(initial=0), 1))
    st = _trf.new_state(x, lb, ub, m, m_row, m_row, max_nfev + 1 if history else 0)
    S = dict(zip(_trf.STATE, st))
    status, nfev = S["status"], S["nfev"]
    status[refused] = FAILED
    for r, e in enumerate(early):
        if e is not None:
            status[r], message[r] = FAILED, e
            nfev[r] = 1
    T = int(datasets[1].max(initial=1)) if isinstance(datasets, tuple) else max((len(d[0]) for d in datasets), default=1)
    err_code = np.zeros(R, np.int64)
    err_i = np.zeros((R, 2), np.int64)
    err_f = np.zeros((R, 2))
    err_modes = np.zeros((R, max(T, 1)), np.bool_)
    todo = np.random.default_rng(0).permutation(np.flatnonzero(status == _RUNNING)).astype(np.int64)
    done = R - todo.size
    if progress and done:
        progress(done, R)
    for a in range(0, todo.size, chunk):
        rows = todo[a:a + chunk]
        _modal.solve_rows(sp_, st, rows, o["gtol"], o["ftol"], o["xtol"], max_nfev, err_code, err_i, err_f, err_modes)
        done += rows.size
        if progress:
            progress(done, R)
    for r in np.flatnonzero(err_code):
        message[r] = _modal.message(err_code[r], err_i[r], err_f[r], err_modes[r], prob.min_mac)
    return _result(st, message)


# ====================================================================== multi-start driver
def multistart_batched(model, data, names: Sequence[str], starts, *, seed: int | None = None, rel_tol: float = 1e-4,
                       cost_tol: float | None = None, progress: Callable[[int, int], None] | None = None,
                       polish: bool = True, **options):
    """Multi-start updating with every start advanced at once; same result as the per-start path.

    Parameters
    ----------
    model, data : as :func:`femupdate.updating.update`.
    names : updated parameters.
    starts : (R, L) starting values (e.g. from :func:`femupdate.multistart.draw_starts`).
    seed : recorded in the result.
    rel_tol, cost_tol : clustering and acceptance, as :func:`femupdate.multistart.multistart`.
    progress : ``progress(finished, R)``.
    polish : re-run :func:`~femupdate.updating.update` once from the best solution (a final
        check by the per-start machinery); its ``start``, ``history``, ``nfev``, ``njev`` and
        ``iterations`` then cover the batched run and the polish together.  Without it (or should
        the polish fail) ``best`` is the full result at the batched solution itself.  Either way
        ``best`` is a :class:`~femupdate.updating.UpdateResult` with diagnostics.
    **options : options of :func:`~femupdate.updating.update` (see :data:`SUPPORTED_OPTIONS`).

    Returns
    -------
    femupdate.multistart.MultiStartResult
        ``runs[k]`` is a :class:`BatchRun`, or the error message (str) of a start that failed,
        exactly as the per-start path reports it.
    """
    from .multistart import MultiStartResult, converged_solutions

    names = tuple(names)
    X0 = np.array(starts, dtype=float, ndmin=2)
    R = X0.shape[0]
    reason = unsupported(model, options, explicit=True)
    if reason:
        raise InputError(f"batched multi-start: {reason}")
    try:
        prob = BatchProblem(model, data, names, X0, **options)
    except FemupdateError as exc:  # update() would refuse every start alike
        msg = f"{type(exc).__name__}: {exc}"
        return MultiStartResult(None, [], [msg] * R, X0, names, R, 0, seed)
    res = prob.solve(progress=progress)
    alive = np.flatnonzero(res.status != FAILED)
    final = prob.evaluate(res.x[alive], alive)  # pairs and MACs at the solutions, in one batch
    n_hist = np.minimum(res.iterations + 1, res.history_cost.shape[1])
    runs: list = [m if m.startswith(("NumericalError:", "InputError:")) else f"NumericalError: the least-squares solver failed: {m}"
                  for m in res.message]  # (used for the failed starts only)
    for i, r in enumerate(alive):
        if final.errors[i] is not None:  # pragma: no cover - the solver evaluated this point already
            runs[r] = final.errors[i]
            continue
        P = prob.full_p(res.x[r][None, :], np.array([r]))[0]
        pairs = [(k, int(final.pairs[i, k]), float(final.macs[i, k])) for k in range(prob.n_test)]
        lam = final.lam[i, final.pairs[i]]
        runs[r] = BatchRun(
            parameters=dict(zip(model.parameter_names, map(float, P))), names=names, x=P[prob.idx],
            success=bool(res.status[r] > 0), status=int(res.status[r]), message=res.message[r],
            cost=float(0.5 * final.fun[i] @ final.fun[i]), fun=final.fun[i], jac=res.jac[r], nfev=int(res.nfev[r]),
            njev=int(res.njev[r]), iterations=int(max(res.iterations[r], res.njev[r])),
            optimality=float(res.optimality[r]), pairs=pairs,
            model_frequencies_hz=np.sqrt(np.clip(lam, 0, None)) / (2 * np.pi),
            start=dict(zip(names, map(float, X0[r]))),
            history_cost=res.history_cost[r, :n_hist[r]].copy(),
            history_x=prob.to_p(res.history_x[r, :n_hist[r]], np.full(n_hist[r], r)),
        )
    ok, solutions = converged_solutions(runs, names, BatchRun, cost_tol, rel_tol)
    best = None
    if ok:
        k_best = min(ok, key=lambda k: runs[k].cost)
        best = _polish(model, data, names, runs[k_best], options) if polish else None
        if best is None:  # not asked for, or the polish failed: the full result at the batched solution
            best = _result_at(prob, k_best, runs[k_best])
    log.info("batched multi-start: %d starts, %d converged, %d solutions, %d evaluations in total",
             R, len(ok), len(solutions), int(res.nfev.sum()))
    return MultiStartResult(best, solutions, runs, X0, names, R, len(ok), seed)


def _result_at(prob: BatchProblem, r: int, run: BatchRun) -> UpdateResult:
    """The :class:`UpdateResult` of start ``r`` at its batched solution (no further iteration):
    residuals, Jacobian, pairs and diagnostics exactly as :func:`update` reports them."""
    p_base = prob.p_fixed.copy()
    p_base[prob.idx] = prob.starts[r]
    pr = _Problem(*prob._problem_args, p_base, *prob._problem_kw)
    x = pr.from_p(run.x)
    _, modes, pairs = pr._evaluate(x)
    f = pr.residuals(x)
    J = pr.jacobian(x)
    data = prob._problem_args[1]
    return UpdateResult(
        parameters=dict(run.parameters), names=run.names, x=run.x.copy(), success=run.success, status=run.status,
        message=run.message, cost=float(0.5 * f @ f), fun=f, jac=J, nfev=run.nfev, njev=run.njev,
        iterations=run.iterations, history=run.history, pairs=list(run.pairs),
        test_frequencies_hz=data.frequencies_hz, model_frequencies_hz=np.array([modes.frequencies_hz[j] for _, j, _ in pairs]),
        swaps=[], diagnostics=_diagnostics(pr, x, f, J, prob.sigma), regularization={}, start=dict(run.start),
        sensitivity=pr.sensitivity_used,
    )


def _polish(model, data, names, run: BatchRun, options) -> UpdateResult | None:
    """One full :func:`update` from a batched solution: diagnostics, swaps and a final check."""
    try:
        res = update(model, data, params=list(names), x0=dict(zip(names, map(float, run.x))), **options)
    except FemupdateError as exc:
        log.warning("polishing the best batched solution failed: %s", exc)
        return None
    if not res.success:
        return None
    offset = len(run.history)
    history = list(run.history) + [dict(h, iteration=h["iteration"] + offset) for h in res.history[1:]]
    return dataclasses.replace(
        res, start=dict(run.start), history=history, nfev=res.nfev + run.nfev, njev=res.njev + run.njev,
        iterations=res.iterations + run.iterations,
    )


__all__ = [
    "AUTO_MAX_DOFS", "SUPPORTED_OPTIONS", "FAILED", "BatchRun", "BatchLSQResult", "BatchProblem",
    "least_squares_batch", "multistart_batched", "supports", "unsupported",
]
