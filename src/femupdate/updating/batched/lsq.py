r"""Trust-region-reflective least squares for many independent problems at once.

:func:`least_squares_batch` follows :func:`scipy.optimize.least_squares` with ``method="trf"``,
``x_scale="jac"``, ``tr_solver="exact"`` and a linear loss decision for decision for every row
(the compiled row functions of :mod:`.trf`), with the residuals of all active rows computed in
one call of a Python function per round — for any residual function.  The modal updating problem
runs every row to the end in compiled code instead (:mod:`.kernel`); both share the state, the
start-up and the result of this module.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from . import trf

TERMINATION_MESSAGES = {  # scipy.optimize.least_squares' messages, for identical reports
    0: "The maximum number of function evaluations is exceeded.",
    1: "`gtol` termination condition is satisfied.",
    2: "`ftol` termination condition is satisfied.",
    3: "`xtol` termination condition is satisfied.",
    4: "Both `ftol` and `xtol` termination conditions are satisfied.",
}
FAILED = -3  #: status of a start whose evaluation failed (its message says why)
_RUNNING = trf.RUNNING


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
    pairs: np.ndarray | None = None  #: (R, T) the modal route's pairs at x (model mode of each test mode)
    macs: np.ndarray | None = None  #: (R, T) their MAC (NaN without shape)
    pair_eigenvalues: np.ndarray | None = None  #: (R, T) the paired model modes' eigenvalues
    codes: np.ndarray | None = None  #: (R,) the modal route's error code of a failed row (0: none)

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


def prepare(x0, bounds, max_nfev):
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


def result_of(st, message) -> BatchLSQResult:
    """The solver's state as a :class:`BatchLSQResult` (rows still running: out of evaluations)."""
    status = st.status
    status[status == _RUNNING] = 0
    msgs = [message[r] if status[r] == FAILED else TERMINATION_MESSAGES[int(status[r])] for r in range(status.size)]
    J, f = st.J, st.f
    g = np.matmul(f[:, None, :], J)[:, 0, :]
    return BatchLSQResult(x=st.x, cost=st.cost, fun=f, jac=J, grad=g, optimality=st.g_norm, nfev=st.nfev,
                          njev=st.njev, iterations=st.iterations, status=status, message=msgs,
                          history_cost=st.hist_cost, history_x=st.hist_x)


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
    x0, x, lb, ub, max_nfev, message = prepare(x0, bounds, max_nfev)
    R, n = x0.shape
    refused = np.array([m is not None for m in message], bool)
    rows = np.flatnonzero(~refused)
    if rows.size == 0:
        st = trf.new_state(x, lb, ub, 0, np.zeros(R), np.zeros(R), 1 if history else 0)
        st.status[:] = FAILED
        return result_of(st, message)
    F0, err, token = fun(x[rows], rows)
    m = F0.shape[1]
    m_row = np.full(R, m) if n_residuals is None else np.broadcast_to(np.asarray(n_residuals, dtype=int), (R,))
    st = trf.new_state(x, lb, ub, m, m_row, np.full(R, m), max_nfev + 1 if history else 0)
    status, nfev, f, J = st.status, st.nfev, st.f, st.J
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
        st.njev[rows[ok]] += 1
        fail(rows[ok], jerr)
    trf.rows_init(st, rows.astype(np.int64))
    finished = int(np.sum(status != _RUNNING))
    if progress and finished:
        progress(finished, R)
    degenerate = "the least-squares solver failed: the trust-region step is degenerate"
    while True:
        act = np.flatnonzero(status == _RUNNING).astype(np.int64)
        flags = np.zeros(act.size, np.int64)
        if act.size:
            trf.rows_propose(st, act, gtol, max_nfev, flags)
            for r, fl in zip(act, flags):
                if fl == trf.DEGENERATE:
                    status[r], message[r] = FAILED, degenerate
                elif fl == trf.BAD_JACOBIAN:
                    status[r], message[r] = FAILED, "NumericalError: non-finite Jacobian"
        done = int(np.sum(status != _RUNNING))
        if progress and done != finished:
            progress(done, R)
        finished = done
        act = act[flags == trf.PROPOSED]
        if act.size == 0:
            break
        F_new, err, token = fun(st.x_new[act], act)
        nfev[act] += 1
        good = np.array([e is None for e in err], bool)
        fail(act, err)
        acc = np.zeros(act.size, np.bool_)
        ended = np.zeros(act.size, np.bool_)
        g_rows = act[good]
        trf.rows_judge(st, g_rows, np.ascontiguousarray(F_new[good]), ftol, xtol, max_nfev, acc[: g_rows.size],
                        ended[: g_rows.size])
        accepted = np.flatnonzero(good)[acc[: g_rows.size]]
        if accepted.size:
            J_new, jerr = jac(token, accepted)
            trf.rows_accept(st, act[accepted], np.ascontiguousarray(J_new))
            fail(act[accepted], jerr)
    return result_of(st, message)



__all__ = ["BatchLSQResult", "least_squares_batch", "prepare", "result_of", "FAILED", "TERMINATION_MESSAGES"]
