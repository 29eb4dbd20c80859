r"""SciPy's trust-region-reflective least squares, compiled, one problem (row) at a time.

A transcription of :func:`scipy.optimize.least_squares` with ``method="trf"``,
``x_scale="jac"``, ``tr_solver="exact"`` and a linear loss (``scipy/optimize/_lsq/trf.py``
``trf_bounds`` and the helpers of ``_lsq/common.py``): the Coleman–Li reflective scaling for the
bounds, Moré's Levenberg–Marquardt parameter for the exact trust-region subproblem, the choice
between the trust-region step, its reflection and the scaled anti-gradient, the radius update and
the ``ftol``/``xtol``/``gtol`` tests and status codes — decision for decision, so that a row lands
where SciPy lands from the same start.  The arithmetic differs only in round-off: the augmented
Jacobian ``[J d; diag_h^½]`` is reduced to its (n, n) R factor by Householder reflections (with
the residual as an extra column, giving ``Qᵀf``), and its SVD is taken of that factor; the
quadratic models are evaluated with the factor.  Decisions can therefore differ only at the
round-off floor of the cost, after convergence.

The state of R rows lives in arrays (one row each), named in :class:`State`.  Two drivers use
the row functions:

* :func:`rows_propose` / :func:`rows_judge` / :func:`rows_accept` advance many rows one
  evaluation at a time, with the residuals computed in between by Python
  (:func:`femupdate.updating.batched.least_squares_batch`, any residual function);
* :mod:`femupdate.updating.batched.kernel` runs rows to the end inside compiled code, with the modal
  residuals and exact Jacobians compiled too, the rows spread over the CPU cores.

Everything here is compiled by numba on first use and cached on disk (``cache=True``).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from . import dense
from .jit import inner, jit

EPS = float(np.finfo(float).eps)
RUNNING = -99  #: status of a row still iterating
FAILED = -3  #: status of a row whose evaluation failed
# flags of rows_propose
PROPOSED, STOPPED, DEGENERATE, BAD_JACOBIAN = 0, 1, 2, 3



class State(NamedTuple):
    """The solver's state for R rows of n variables and at most m residuals (row r of each array
    is start r's); arrays are updated in place."""

    x: np.ndarray  #: (R, n) current point
    f: np.ndarray  #: (R, m) residuals at x
    J: np.ndarray  #: (R, m, n) Jacobian at x
    cost: np.ndarray  #: (R,) ½‖f‖²
    g: np.ndarray  #: (R, n) gradient Jᵀf
    scale_inv: np.ndarray  #: (R, n) inverse of the Jacobian column norms (x_scale="jac")
    lb: np.ndarray  #: (R, n) lower bounds
    ub: np.ndarray  #: (R, n) upper bounds
    m_row: np.ndarray  #: (R,) residual count of each row, for the rank test
    m_qr: np.ndarray  #: (R,) leading residual rows that enter the QR
    Delta: np.ndarray  #: (R,) trust-region radius
    alpha: np.ndarray  #: (R,) Levenberg–Marquardt parameter
    d: np.ndarray  #: (R, n) Coleman–Li scaling
    g_h: np.ndarray  #: (R, n) scaled gradient
    theta: np.ndarray  #: (R,) step-back factor from the bounds
    R11: np.ndarray  #: (R, n, n) R factor of the augmented scaled Jacobian
    r12: np.ndarray  #: (R, n) Qᵀf of the augmented system
    sv: np.ndarray  #: (R, n) singular values of R11
    V: np.ndarray  #: (R, n, n) right singular vectors of R11
    uf: np.ndarray  #: (R, n) Uᵀ Qᵀ f
    p_gn: np.ndarray  #: (R, n) Gauss–Newton step
    full_rank: np.ndarray  #: (R,) bool
    have_svd: np.ndarray  #: (R,) bool: V and uf are current
    need_setup: np.ndarray  #: (R,) bool: the iteration's set-up is to be done
    status: np.ndarray  #: (R,) RUNNING, FAILED or SciPy's status
    pending: np.ndarray  #: (R,) status to take when the row stops
    nfev: np.ndarray  #: (R,) evaluations
    njev: np.ndarray  #: (R,) Jacobian evaluations
    iterations: np.ndarray  #: (R,)
    g_norm: np.ndarray  #: (R,) first-order optimality ‖g‖∞
    x_new: np.ndarray  #: (R, n) proposed point
    step: np.ndarray  #: (R, n) proposed step
    step_h: np.ndarray  #: (R, n) proposed step in the scaled variables
    pred: np.ndarray  #: (R,) predicted reduction
    hist_cost: np.ndarray  #: (R, H) cost after each iteration
    hist_x: np.ndarray  #: (R, H, n) x after each iteration





def new_state(x0, lb, ub, m: int, m_row, m_qr, history: int):
    """Fresh state arrays for R rows of n variables and at most m residuals.

    ``m_row`` (R,) each row's residual count for SciPy's rank test; ``m_qr`` (R,) how many
    leading residual rows enter the QR (the others are zero); ``history`` the iterations kept
    per row (0: none); an :class:`~femupdate.InputError` names ``max_nfev`` (``history - 1``) when
    those arrays would exceed the available memory.
    """
    R, n = x0.shape
    if history:  # made before any iteration: refused by max_nfev when it would not fit (history = max_nfev + 1)
        from ..._budget import check_memory

        check_memory(f"max_nfev={history - 1}", float(min(8 * R * history * (n + 1), 10**30)),
                     f"the iteration histories of {R} start{'s' if R != 1 else ''} on the compiled route (8 bytes "
                     "per evaluation and parameter)")
    z = np.zeros
    st = dict(
        x=np.array(x0, float), f=z((R, m)), J=z((R, m, n)), cost=z(R), g=z((R, n)), scale_inv=np.ones((R, n)),
        lb=np.array(lb, float), ub=np.array(ub, float), m_row=np.asarray(m_row, np.int64).copy(),
        m_qr=np.asarray(m_qr, np.int64).copy(), Delta=z(R), alpha=z(R), d=z((R, n)), g_h=z((R, n)), theta=z(R),
        R11=z((R, n, n)), r12=z((R, n)), sv=z((R, n)), V=z((R, n, n)), uf=z((R, n)), p_gn=z((R, n)),
        full_rank=z(R, np.bool_), have_svd=z(R, np.bool_), need_setup=np.ones(R, np.bool_),
        status=np.full(R, RUNNING, np.int64), pending=np.full(R, RUNNING, np.int64), nfev=z(R, np.int64),
        njev=z(R, np.int64), iterations=z(R, np.int64), g_norm=np.full(R, np.nan), x_new=z((R, n)), step=z((R, n)),
        step_h=z((R, n)), pred=z(R), hist_cost=z((R, history)), hist_x=z((R, history, n)),
    )
    return State(**st)


# ---------------------------------------------------------------------------------------------
# the row functions
# ---------------------------------------------------------------------------------------------
@inner
def _gradient(st, r):
    """g = Jᵀf of row r; returns the column norms of its J (for the Jacobian scale)."""
    f, J, g = st.f, st.J, st.g
    m, n = J.shape[1], J.shape[2]
    norms = np.empty(n)
    for i in range(n):
        gi = 0.0
        sc = 0.0
        for k in range(m):
            gi += J[r, k, i] * f[r, k]
            sc += J[r, k, i] * J[r, k, i]
        g[r, i] = gi
        norms[i] = math.sqrt(sc)
    return norms


@inner
def init_row(st, r):
    """SciPy's set-up after the first evaluation and Jacobian of row r (f, J in the state)."""
    (x, f, J, cost, g, scale_inv, lb, ub, m_row, m_qr, Delta, alpha, d, g_h, theta, R11, r12, sv, V, uf, p_gn,
     full_rank, have_svd, need_setup, status, pending, nfev, njev, iterations, g_norm, x_new, step, step_h, pred,
     hist_cost, hist_x) = st
    n = x.shape[1]
    cost[r] = 0.5 * dense.dot(f[r], f[r])
    norms = _gradient(st, r)
    for i in range(n):
        scale_inv[r, i] = norms[i] if norms[i] != 0 else 1.0
    v = np.empty(n)
    dv = np.empty(n)
    dense.cl_scaling(x[r], g[r], lb[r], ub[r], v, dv)
    D = 0.0
    for i in range(n):
        if dv[i] != 0:
            v[i] *= scale_inv[r, i]
        t = x[r, i] * scale_inv[r, i] / v[i] ** 0.5
        D += t * t
    D = math.sqrt(D)
    Delta[r] = D if D != 0 else 1.0
    alpha[r] = 0.0
    need_setup[r] = True
    record(st, r)


@inner
def record(st, r):
    """Keep (cost, x) of row r after its current iteration (when history is kept)."""
    cost, x, iterations, hist_cost, hist_x = st.cost, st.x, st.iterations, st.hist_cost, st.hist_x
    k = iterations[r]
    if k < hist_cost.shape[1]:
        hist_cost[r, k] = cost[r]
        dense.copy_to(hist_x[r, k], x[r])


@inner
def _top(st, r, gtol, max_nfev):
    """Top of SciPy's outer loop for row r: the termination tests, then the scaled augmented
    system, its R factor and singular values, and the Gauss–Newton step.  Returns 1 when the row
    goes on, 0 when it terminated, -1 when its Jacobian is not finite (the row must fail)."""
    (x, f, J, cost, g, scale_inv, lb, ub, m_row, m_qr, Delta, alpha, d, g_h, theta, R11, r12, sv, V, uf, p_gn,
     full_rank, have_svd, need_setup, status, pending, nfev, njev, iterations, g_norm, x_new, step, step_h, pred,
     hist_cost, hist_x) = st
    n = x.shape[1]
    v = np.empty(n)
    dv = np.empty(n)
    dense.cl_scaling(x[r], g[r], lb[r], ub[r], v, dv)
    gn = 0.0
    for i in range(n):
        gn = max(gn, abs(g[r, i] * v[i]))
    g_norm[r] = gn
    stt = pending[r]
    if gn < gtol:
        stt = 1
    if stt == RUNNING and nfev[r] >= max_nfev:
        stt = 0
    status[r] = stt
    if stt != RUNNING:
        return 0
    mq = m_qr[r]
    A = np.zeros((mq + n, n + 1))
    for i in range(n):
        if dv[i] != 0:
            v[i] *= scale_inv[r, i]
        scale = 1 / scale_inv[r, i]
        d[r, i] = v[i] ** 0.5 * scale
        g_h[r, i] = d[r, i] * g[r, i]
        A[mq + i, i] = (g[r, i] * dv[i] * scale) ** 0.5  # diag_h^½
    for k in range(mq):
        for i in range(n):
            A[k, i] = J[r, k, i] * d[r, i]
        A[k, n] = f[r, k]
    for k in range(mq + n):
        for i in range(n + 1):
            if not math.isfinite(A[k, i]):
                return -1
    dense.householder_r(A, n)
    for i in range(n):
        r12[r, i] = A[i, n]
        for k in range(n):
            R11[r, i, k] = A[i, k] if k >= i else 0.0
    s = dense.singular_values(R11[r])
    for i in range(n):
        sv[r, i] = s[i]
    full_rank[r] = n == 0 or (m_row[r] >= n and s[n - 1] > EPS * m_row[r] * s[0])
    if full_rank[r]:  # Gauss–Newton step p = −R11⁻¹ r12 by back-substitution
        for i in range(n - 1, -1, -1):
            t = -r12[r, i]
            for k in range(i + 1, n):
                t -= R11[r, i, k] * p_gn[r, k]
            p_gn[r, i] = t / R11[r, i, i]
    have_svd[r] = False
    theta[r] = max(0.995, 1 - gn)
    need_setup[r] = False
    return 1


@inner
def _phi_and_derivative(suf, s, a, D):
    """‖p(α)‖ − Δ and its derivative in α (SciPy's ``phi_and_derivative``)."""
    pn = 0.0
    der = 0.0
    for i in range(s.size):
        den = s[i] ** 2 + a
        pn += (suf[i] / den) ** 2
        der += suf[i] ** 2 / den**3
    pn = math.sqrt(pn)
    return pn - D, -der / pn


@inner
def _tr_subproblem(st, r, p_h):
    """Moré's trust-region subproblem on the SVD of R11 (SciPy's ``solve_lsq_trust_region``),
    for a row whose Gauss–Newton step is not available or not inside the radius."""
    R11, r12, sv, V, uf, alpha, Delta, full_rank, have_svd = (st.R11, st.r12, st.sv, st.V, st.uf, st.alpha, st.Delta,
                                                              st.full_rank, st.have_svd)
    n = p_h.size
    if not have_svd[r]:
        U, s, Vt = np.linalg.svd(R11[r])
        for i in range(n):
            sv[r, i] = s[i]
            t = 0.0
            for k in range(n):
                V[r, i, k] = Vt[k, i]
                t += U[k, i] * r12[r, k]
            uf[r, i] = t
        have_svd[r] = True
    s = sv[r]
    D = Delta[r]
    suf = dense.mul(s, uf[r])
    fr = full_rank[r]

    alpha_upper = dense.norm(suf) / D
    if fr:
        phi, phi_prime = _phi_and_derivative(suf, s, 0.0, D)
        alpha_lower = -phi / phi_prime
    else:
        alpha_lower = 0.0
    a = alpha[r]
    if not fr and a == 0:
        a = max(0.001 * alpha_upper, (alpha_lower * alpha_upper) ** 0.5)
    for _ in range(10):
        if a < alpha_lower or a > alpha_upper:
            a = max(0.001 * alpha_upper, (alpha_lower * alpha_upper) ** 0.5)
        phi, phi_prime = _phi_and_derivative(suf, s, a, D)
        if phi < 0:
            alpha_upper = a
        ratio = phi / phi_prime
        alpha_lower = max(alpha_lower, a - ratio)
        a -= (phi + D) * ratio / D
        if abs(phi) < 0.01 * D:
            break
    for i in range(n):
        t = 0.0
        for k in range(n):
            t -= V[r, i, k] * suf[k] / (s[k] ** 2 + a)
        p_h[i] = t
    pn = dense.norm(p_h)
    for i in range(n):
        p_h[i] *= D / pn
    alpha[r] = a


@inner
def propose(st, r, gtol, max_nfev):
    """The next trial point of row r (``x_new``, with ``step``, ``step_h`` and the predicted
    reduction ``pred``): PROPOSED, or STOPPED (terminated: ``status`` says how), DEGENERATE
    (SciPy would raise in ``intersect_trust_region``) or BAD_JACOBIAN (not finite)."""
    (x, f, J, cost, g, scale_inv, lb, ub, m_row, m_qr, Delta, alpha, d, g_h, theta, R11, r12, sv, V, uf, p_gn,
     full_rank, have_svd, need_setup, status, pending, nfev, njev, iterations, g_norm, x_new, step, step_h, pred,
     hist_cost, hist_x) = st
    if need_setup[r]:
        go = _top(st, r, gtol, max_nfev)
        if go == 0:
            return STOPPED
        if go < 0:
            return BAD_JACOBIAN
    n = x.shape[1]
    D = Delta[r]
    p_h = np.empty(n)
    if full_rank[r] and dense.norm(p_gn[r]) <= D:
        for i in range(n):
            p_h[i] = p_gn[r, i]
        alpha[r] = 0.0
    else:
        _tr_subproblem(st, r, p_h)
    xr, lbr, ubr, dr, ghr, Rr, th = x[r], lb[r], ub[r], d[r], g_h[r], R11[r], theta[r]
    p = dense.mul(dr, p_h)
    inside = True
    for i in range(n):
        xp = xr[i] + p[i]
        if not (xp >= lbr[i] and xp <= ubr[i]):
            inside = False
    if inside:
        dense.copy_to(step[r], p)
        dense.copy_to(step_h[r], p_h)
        pred[r] = -dense.quad(Rr, ghr, p_h)
    else:  # SciPy's select_step: the step cut at the bound, its reflection, the anti-gradient
        hits = np.empty(n, np.bool_)
        p_stride = dense.step_to_bound(xr, p, lbr, ubr, hits)
        r_h = p_h.copy()
        for i in range(n):
            if hits[i]:
                r_h[i] = -r_h[i]
        rr = dense.mul(dr, r_h)
        p = dense.scaled(p, p_stride)
        p_h = dense.scaled(p_h, p_stride)
        x_on_bound = dense.add(xr, p)
        # intersect_trust_region(p_h, r_h, Delta)
        a2 = dense.dot(r_h, r_h)
        b2 = dense.dot(p_h, r_h)
        c2 = dense.dot(p_h, p_h) - D**2
        if a2 == 0 or c2 > 0:
            return DEGENERATE
        dd = math.sqrt(b2 * b2 - a2 * c2)
        q = -(b2 + math.copysign(dd, b2))
        to_tr = max(q / a2, c2 / q)
        to_bound = dense.step_to_bound(x_on_bound, rr, lbr, ubr, hits)
        r_stride = min(to_bound, to_tr)
        if r_stride > 0:
            r_lo = (1 - th) * p_stride / r_stride
            r_hi = th * to_bound if r_stride == to_bound else to_tr
        else:
            r_lo = 0.0
            r_hi = -1.0
        if r_lo <= r_hi:
            qa, qb, qc = dense.quad_1d(Rr, ghr, r_h, p_h)
            r_t, r_value = dense.min_quad_1d(qa, qb, r_lo, r_hi, qc)
            r_h = dense.add(dense.scaled(r_h, r_t), p_h)
            rr = dense.mul(r_h, dr)
        else:
            r_value = np.inf
        p = dense.scaled(p, th)
        p_h = dense.scaled(p_h, th)
        p_value = dense.quad(Rr, ghr, p_h)
        ag_h = dense.scaled(ghr, -1.0)
        ag = dense.mul(dr, ag_h)
        to_tr = D / dense.norm(ag_h)
        to_bound = dense.step_to_bound(xr, ag, lbr, ubr, hits)
        ag_stride = th * to_bound if to_bound < to_tr else to_tr
        ag_stride, ag_value = dense.min_quad_1d(dense.half_sq(Rr, ag_h), dense.dot(ghr, ag_h), 0.0, ag_stride, 0.0)
        if p_value < r_value and p_value < ag_value:
            dense.copy_to(step[r], p)
            dense.copy_to(step_h[r], p_h)
            pred[r] = -p_value
        elif r_value < p_value and r_value < ag_value:
            dense.copy_to(step[r], rr)
            dense.copy_to(step_h[r], r_h)
            pred[r] = -r_value
        else:
            dense.copy_to(step[r], dense.scaled(ag, ag_stride))
            dense.copy_to(step_h[r], dense.scaled(ag_h, ag_stride))
            pred[r] = -ag_value
    for i in range(n):  # make_strictly_feasible(x + step, rstep=0)
        xi = xr[i] + step[r, i]
        if xi <= lbr[i]:
            xi = np.nextafter(lbr[i], ubr[i])
        if xr[i] + step[r, i] >= ubr[i]:
            xi = np.nextafter(ubr[i], lbr[i])
        if xi < lbr[i] or xi > ubr[i]:
            xi = 0.5 * (lbr[i] + ubr[i])
        x_new[r, i] = xi
    return PROPOSED


@inner
def judge(st, r, f_new, ftol, xtol, max_nfev):
    """SciPy's inner-loop bookkeeping after evaluating row r's trial point at residuals f_new:
    radius update, termination tests, acceptance.  Returns (accepted, iteration_ended); an
    accepted point's x, f and cost are taken over (its Jacobian goes to :func:`accept`), and an
    ended iteration is counted (recorded in the history once the Jacobian is in)."""
    (x, f, J, cost, g, scale_inv, lb, ub, m_row, m_qr, Delta, alpha, d, g_h, theta, R11, r12, sv, V, uf, p_gn,
     full_rank, have_svd, need_setup, status, pending, nfev, njev, iterations, g_norm, x_new, step, step_h, pred,
     hist_cost, hist_x) = st
    cost_new = 0.5 * dense.dot(f_new, f_new)
    actual = cost[r] - cost_new
    predicted = pred[r]
    shn = dense.norm(step_h[r])
    D = Delta[r]
    if predicted > 0:
        ratio = actual / predicted
    elif predicted == 0 and actual == 0:
        ratio = 1.0
    else:
        ratio = 0.0
    if ratio < 0.25:
        D_new = 0.25 * shn
    elif ratio > 0.75 and shn > 0.95 * D:
        D_new = 2.0 * D
    else:
        D_new = D
    ftol_ok = actual < ftol * cost[r] and ratio > 0.25
    xtol_ok = dense.norm(step[r]) < xtol * (xtol + dense.norm(x[r]))
    term = RUNNING
    if ftol_ok and xtol_ok:
        term = 4
    elif ftol_ok:
        term = 2
    elif xtol_ok:
        term = 3
    if term == RUNNING:
        alpha[r] *= D / D_new
        Delta[r] = D_new
    else:
        pending[r] = term
    accepted = actual > 0
    if accepted:
        dense.copy_to(x[r], x_new[r])
        dense.copy_to(f[r], f_new)
        cost[r] = cost_new
    ended = accepted or term != RUNNING or nfev[r] >= max_nfev
    if ended:
        iterations[r] += 1
        need_setup[r] = True
        record(st, r)
    return accepted, ended


@inner
def accept(st, r):
    """After an accepted step, with the new Jacobian in ``J[r]``: gradient and Jacobian scale."""
    scale_inv, njev = st.scale_inv, st.njev
    njev[r] += 1
    norms = _gradient(st, r)
    for i in range(norms.size):
        scale_inv[r, i] = max(norms[i], scale_inv[r, i])


# ---------------------------------------------------------------------------------------------
# compiled ahead of the first solve (see kernel.build)
# ---------------------------------------------------------------------------------------------
def row_signatures(state_type) -> list:
    """The row functions that :func:`femupdate.updating.batched.kernel.solve_rows` calls, each
    with the argument types of its call there (``state_type`` the numba type of the
    :class:`State`)."""
    from numba import types

    i, f, v = types.int64, types.float64, types.float64[::1]
    return [(init_row, (state_type, i)), (propose, (state_type, i, f, i)), (judge, (state_type, i, v, f, f, i)),
            (accept, (state_type, i))]


def compile_rows() -> None:
    """Compile the functions of :func:`row_signatures` into numba's disk cache (run in a second
    process while the first compiles the modal functions; the type of a state does not depend on
    its size)."""
    from numba import typeof

    one = np.zeros((1, 1))
    st = new_state(one, one, one, 1, np.ones(1, np.int64), np.ones(1, np.int64), 0)
    for fn, sig in row_signatures(typeof(st)):
        fn.compile(sig)


# ---------------------------------------------------------------------------------------------
# many rows, one evaluation at a time (the residuals computed by Python in between)
# ---------------------------------------------------------------------------------------------
@jit
def rows_init(st, rows):
    for r in rows:
        init_row(st, r)


@jit
def rows_propose(st, rows, gtol, max_nfev, flags):
    """:func:`propose` for each of ``rows`` (flags out)."""
    for i in range(rows.size):
        flags[i] = propose(st, rows[i], gtol, max_nfev)


@jit
def rows_judge(st, rows, F_new, ftol, xtol, max_nfev, accepted, ended):
    """:func:`judge` for each of ``rows`` with its residuals ``F_new[i]`` (flags out)."""
    for i in range(rows.size):
        accepted[i], ended[i] = judge(st, rows[i], F_new[i], ftol, xtol, max_nfev)


@jit
def rows_accept(st, rows, J_new):
    for i in range(rows.size):
        st.J[rows[i]] = J_new[i]
        accept(st, rows[i])


