r"""Compiled modal residuals and exact Jacobians, and a driver that runs each start to the end.

The batched problems (:class:`femupdate.batch.BatchProblem`, one data set and many starts;
:class:`femupdate.uniqueness.problem.StudyProblem`, many data sets) describe themselves as a
*spec*: a tuple of arrays (:func:`spec`).  :func:`solve_rows` then runs SciPy's trf
(:mod:`femupdate._trf`) for every row inside compiled code, the rows spread over the CPU cores
(numba ``prange``), with no Python between iterations.  Per row and evaluation:

* ``K = K_c + Σ_j p_j K_j`` (and ``M`` alike, or its fixed Cholesky factor), reduction to
  standard form ``A = C⁻¹ K C⁻ᵀ``, all n eigenpairs by LAPACK (``eigh``), ``φ = C⁻ᵀ y``
  mass-normalised; ``model_modes``' rules for negative and rigid-body eigenvalues on the lowest
  ``nm`` modes;
* pairing by MAC on each test mode's measured dofs over the lowest ``nm`` modes, the assignment
  maximising the total MAC (Hungarian algorithm, as ``scipy.optimize.linear_sum_assignment``), a
  test mode below ``min_mac`` failing the start; test modes without a shape take the lowest free
  modes in order;
* residuals ``w_λ (λ − λ_E)/λ_E`` and ``w_ψ (ψ − ψ_E)`` with ψ scaled to unit length (sign of
  the largest entry, then aligned with ψ_E), to 1 at a reference dof (which is dropped) or to
  its largest entry;
* the exact Jacobian: ``λ_t' = φ_tᵀ G_j`` with ``G_j = (K_j − λ_t M_j) φ_t`` (Fox & Kapoor,
  paper eq. 21) and, all modes being at hand, the complete modal method
  ``φ_t' = Σ_{r≠t} φ_r φ_rᵀG_j/(λ_t − λ_r) − ½ (φ_tᵀ M_j φ_t) φ_t`` at the measured dofs, then
  the scaling's derivative and the parametrisation's ``dp/dx``.

These are the rules of ``femupdate.updating._Problem`` (the per-start path), so a row lands
where :func:`femupdate.updating.update` lands from the same start.  Failures are returned as a
code and a few numbers per row (:data:`ERRORS`); :func:`message` turns them into the per-start
path's messages.
"""

from __future__ import annotations

import math

import numpy as np
import scipy.sparse as sp
from numba import njit, prange

from . import _trf
from .sensitivity._common import REPEATED_TOL

jit = njit(cache=True, error_model="numpy", nogil=True)

SCALINGS = {"unit": 0, "ref": 1, "max": 2}
PARAMETRISATIONS = {"relative": 0, "log": 1, "absolute": 2}
# error codes
(OK, E_NONFINITE, E_MASS_DIAG, E_MASS_CHOL, E_NEGATIVE, E_NO_PAIR, E_NO_MODE_LEFT, E_NODE, E_RIGID, E_REPEATED,
 E_DEGENERATE, E_BAD_JACOBIAN) = range(12)
ERRORS = {
    E_NONFINITE: "NumericalError: non-finite residuals (the model became singular at these parameter values)",
    E_MASS_DIAG: "NumericalError: the least-squares solver failed: the mass matrix is not positive definite: a dof has no mass",
    E_MASS_CHOL: ("NumericalError: the least-squares solver failed: the mass matrix is not positive definite (its "
                  "Cholesky factorisation failed)"),
    E_NEGATIVE: ("NumericalError: the least-squares solver failed: K is not positive semi-definite: negative "
                 "eigenvalue {f0:.4g} (check for negative stiffness parameters)"),
    E_NO_PAIR: ("NumericalError: test mode(s) {modes} pair with no model mode (MAC below {min_mac:g} for all {i0} "
                "computed modes): check the dof labels, or lower --min-mac"),
    E_NO_MODE_LEFT: "NumericalError: test mode {k}: no model mode left to pair with",
    E_NODE: "NumericalError: cannot scale the shape to 1 at measured dof #{k}: the mode has a node there",
    E_RIGID: ("NumericalError: mode {k} is a rigid-body mode (zero frequency): its derivatives are not defined; "
              "differentiate the flexible modes only"),
    E_REPEATED: ("NumericalError: modes {k} and {k1} are repeated (eigenvalues {f0:.10g} and {f1:.10g}): eigenvector "
                 "derivatives of repeated modes are not unique; femupdate refuses rather than return a wrong "
                 "derivative (pair modes by subspace, or perturb the model to split them)"),
    E_DEGENERATE: "the least-squares solver failed: the trust-region step is degenerate",
    E_BAD_JACOBIAN: "NumericalError: the least-squares solver failed: non-finite Jacobian",
}


def message(code: int, ints, floats, modes, min_mac: float) -> str:
    """The per-start path's message for error ``code`` with its numbers."""
    return ERRORS[int(code)].format(i0=int(ints[0]), k=int(ints[0]) + 1, k1=int(ints[1]) + 1, f0=float(floats[0]),
                                    f1=float(floats[1]), modes=(np.flatnonzero(modes) + 1).tolist(), min_mac=min_mac)


# ---------------------------------------------------------------------------------------------
# the spec
# ---------------------------------------------------------------------------------------------
def _coo(mats):
    """Per-parameter COO triplets (ptr, rows, cols, values) of the sparse matrices ``mats``."""
    ptr, ri, ci, vv = [0], [], [], []
    for d in mats:
        c = d.tocoo()
        ri.append(c.row)
        ci.append(c.col)
        vv.append(c.data)
        ptr.append(ptr[-1] + c.nnz)
    cat = (lambda a, t: np.concatenate(a).astype(t) if a else np.zeros(0, t))
    return np.array(ptr, np.int64), cat(ri, np.int64), cat(ci, np.int64), cat(vv, float)


def spec(prob, datasets, row_dataset, scaling: str, w_shape: float, min_mac: float):
    """The spec tuple of a batched problem.

    ``prob`` a :class:`~femupdate.batch.BatchProblem` (its dense constant matrices, the updated
    parameters' matrices, the mass factor, the parametrisation and per-row scales);
    ``datasets`` a list of data sets, each a list of test modes ``(lam_e, w_lam, pos, psi_e,
    ref)`` (``pos`` None for a mode without shape; ``ref`` None or the position of the
    reference dof) together with ``nm`` (modes computed and paired): ``(modes, nm)``;
    ``row_dataset`` (R,) each row's data set.  ``datasets`` may also be given as the tuple of
    :func:`data_arrays`.

    Returns (spec, m_row): m_row (R,) the residual count of each row.
    """
    n = prob.n
    model = prob.model
    dK = [model.dK[j] for j in prob.idx]
    dM = [model.dM[j] for j in prob.idx]
    zero = sp.csr_array((n, n))
    dK = [d if d is not None else zero for d in dK]
    dM = [d if d is not None else zero for d in dM]
    kp, ki, kj, kv = _coo(dK)
    mp, mi, mj, mv = _coo(dM)
    supp = [np.union1d(sp.coo_array(a).row, sp.coo_array(b).row) for a, b in zip(dK, dM)]
    sptr = np.cumsum([0] + [len(s) for s in supp]).astype(np.int64)
    sidx = np.concatenate(supp).astype(np.int64) if supp else np.zeros(0, np.int64)
    if prob.M_varies:
        Cinv = np.eye(n)
    elif prob._mass_error:
        raise ValueError(prob._mass_error)  # (the caller refuses the study before)
    else:
        Cinv = prob.Cinv
    data = datasets if isinstance(datasets, tuple) else data_arrays(datasets)
    ds_t0, ds_T, ds_nm, ds_m, lam_e, w_lam, pptr, pos, psi_e, ref = data
    row_dataset = np.asarray(row_dataset, np.int64)
    s = (
        np.ascontiguousarray(prob.K_const, float), kp, ki, kj, kv,
        bool(prob.M_varies), np.ascontiguousarray(prob.M_const, float), mp, mi, mj, mv, np.ascontiguousarray(Cinv, float),
        sptr, sidx, PARAMETRISATIONS[prob.param], np.ascontiguousarray(prob.scale, float),
        ds_t0, ds_T, ds_nm, ds_m, row_dataset, lam_e, w_lam, pptr, pos, psi_e, ref,
        SCALINGS[scaling], float(w_shape), float(min_mac), float(REPEATED_TOL),
    )
    return s, ds_m[row_dataset]


def data_arrays(datasets):
    """The data sets of :func:`spec` as its flat arrays: per data set the first test mode, the
    number of test modes, of modes to pair among and of residuals; per test mode λ_E, w_λ, the
    pointer into the positions; per position the model dof and ψ_E; per test mode the reference
    position (-1: none)."""
    ds_t0, ds_T, ds_nm, ds_m = [], [], [], []
    lam_e, w_lam, pptr, pos, psi_e, ref = [], [], [0], [], [], []
    q = 0
    for modes, nm in datasets:
        ds_t0.append(q)
        ds_T.append(len(modes))
        ds_nm.append(int(nm))
        m = 0
        for le, wl, ps, pe, rf in modes:
            lam_e.append(float(le))
            w_lam.append(float(wl))
            if ps is None:
                ref.append(-1)
            else:
                pos.extend(int(i) for i in ps)
                psi_e.extend(float(v) for v in pe)
                ref.append(-1 if rf is None else int(rf))
                m += len(ps) - (rf is not None)
            pptr.append(len(pos))
            m += 1
            q += 1
        ds_m.append(m)
    i64 = (lambda a: np.array(a, np.int64))
    return (i64(ds_t0), i64(ds_T), i64(ds_nm), i64(ds_m), np.array(lam_e, float), np.array(w_lam, float), i64(pptr),
            i64(pos), np.array(psi_e, float), i64(ref))


# ---------------------------------------------------------------------------------------------
# evaluation of one row
# ---------------------------------------------------------------------------------------------
@jit
def _assign(C, nr, nc, out):
    """Rows 0..nr-1 of C (nr <= nc) to distinct columns minimising the total cost (Hungarian
    algorithm with potentials, shortest augmenting paths); ``out[i]`` the column of row i."""
    INF = np.inf
    u = np.zeros(nr + 1)
    v = np.zeros(nc + 1)
    p = np.zeros(nc + 1, np.int64)
    way = np.zeros(nc + 1, np.int64)
    for i in range(1, nr + 1):
        p[0] = i
        j0 = 0
        minv = np.full(nc + 1, INF)
        used = np.zeros(nc + 1, np.bool_)
        while True:
            used[j0] = True
            i0 = p[j0]
            delta = INF
            j1 = 0
            for j in range(1, nc + 1):
                if not used[j]:
                    cur = C[i0 - 1, j - 1] - u[i0] - v[j]
                    if cur < minv[j]:
                        minv[j] = cur
                        way[j] = j0
                    if minv[j] < delta:
                        delta = minv[j]
                        j1 = j
            for j in range(nc + 1):
                if used[j]:
                    u[p[j]] += delta
                    v[j] -= delta
                else:
                    minv[j] -= delta
            j0 = j1
            if p[j0] == 0:
                break
        while True:
            j1 = way[j0]
            p[j0] = p[j1]
            j0 = j1
            if j0 == 0:
                break
    for j in range(1, nc + 1):
        if p[j] != 0:
            out[p[j] - 1] = j - 1


@jit
def _to_p(code, x, scale, p):
    for j in range(x.size):
        if code == 0:
            p[j] = x[j] * scale[j]
        elif code == 1:
            p[j] = math.exp(x[j])
        else:
            p[j] = x[j]


@jit
def _scaled(scaling, phs, ref):
    """Scale s and the position k of the scaling entry of a measured shape; node flag."""
    ns = phs.size
    amax = 0.0
    kmax = 0
    for i in range(ns):
        if abs(phs[i]) > amax:
            amax = abs(phs[i])
            kmax = i
    if scaling == 1:
        k = ref
        s = phs[k]
    else:
        k = kmax
        s = phs[k]
    if scaling == 0:
        nrm = math.sqrt(_trf._dot(phs, phs))
        s = nrm if phs[kmax] > 0 else (-nrm if phs[kmax] < 0 else 0.0)
        return s, k, False
    return s, k, not (abs(s) > 1e-12 * amax)


@jit
def _measured_shape(scaling, Phi, pos, psi_e, ref, a, b, j):
    """Model mode j at the positions a..b-1 of a test mode: the shape, its scale s, the position
    k of the scaling entry, whether ref/max scaling meets a node, and the ``"unit"`` sign that
    aligns it with the test shape."""
    phs = np.empty(b - a)
    for i in range(a, b):
        phs[i - a] = Phi[pos[i], j]
    s, k, node = _scaled(scaling, phs, ref)
    sign = 1.0
    if scaling == 0:
        dot = 0.0
        for i in range(a, b):
            dot += phs[i - a] / s * psi_e[i]
        if dot < 0:
            sign = -1.0
    return phs, s, k, node, sign


@jit
def evaluate_row(sp_, r, x, fout, lam, Phi, pairs, err_i, err_f, err_modes):
    """Residuals of row r at x into ``fout``; eigen-solution and pairs into the work arrays.
    Returns an error code (OK = 0)."""
    (K_const, kp, ki, kj, kv, M_varies, M_const, mp, mi, mj, mv, Cinv_fixed, sptr, sidx, pcode, pscale,
     ds_t0, ds_T, ds_nm, ds_m, row_ds, lam_e, w_lam, pptr, pos, psi_e, ref, scaling, w_shape, min_mac, rtol) = sp_
    n = K_const.shape[0]
    L = x.size
    ds = row_ds[r]
    t0, T, nm = ds_t0[ds], ds_T[ds], ds_nm[ds]
    p = np.empty(L)
    _to_p(pcode, x, pscale[r], p)
    for j in range(L):
        if not np.isfinite(p[j]):
            return E_NONFINITE
    K = K_const.copy()
    for j in range(L):
        for e in range(kp[j], kp[j + 1]):
            K[ki[e], kj[e]] += p[j] * kv[e]
    md = np.empty(n)
    if M_varies:
        M = M_const.copy()
        for j in range(L):
            for e in range(mp[j], mp[j + 1]):
                M[mi[e], mj[e]] += p[j] * mv[e]
        for i in range(n):
            md[i] = M[i, i]
            if not md[i] > 0:
                return E_MASS_DIAG
        C = np.zeros((n, n))  # Cholesky factor M = C Cᵀ
        for i in range(n):
            for k in range(i + 1):
                t = M[i, k]
                for q in range(k):
                    t -= C[i, q] * C[k, q]
                if i == k:
                    if not t > 0:
                        return E_MASS_CHOL
                    C[i, i] = math.sqrt(t)
                else:
                    C[i, k] = t / C[k, k]
        Cinv = np.zeros((n, n))  # C⁻¹, lower triangular
        for i in range(n):
            Cinv[i, i] = 1.0 / C[i, i]
            for k in range(i):
                t = 0.0
                for q in range(k, i):
                    t += C[i, q] * Cinv[q, k]
                Cinv[i, k] = -t / C[i, i]
    else:
        Cinv = Cinv_fixed
        for i in range(n):
            md[i] = M_const[i, i]
    A = Cinv @ K @ Cinv.T
    A = 0.5 * (A + A.T)
    w, Y = np.linalg.eigh(A)
    Ph = Cinv.T @ Y
    for i in range(n):
        lam[i] = w[i]
        for k in range(n):
            Phi[i, k] = Ph[i, k]
    # model_modes' rules on the lowest nm modes: no negative eigenvalue, rigid ones zeroed
    scale = 0.0
    for i in range(nm):
        scale = max(scale, abs(lam[i]))
    for i in range(n):
        scale = max(scale, abs(K[i, i]) / md[i])
    scale = max(scale, 1e-300)
    low = 0.0
    for i in range(nm):
        low = min(low, lam[i])
    if low < -1e-12 * scale:
        err_f[0] = low
        return E_NEGATIVE
    for i in range(nm):
        if abs(lam[i]) <= 1e-12 * scale:
            lam[i] = 0.0
    # pairing: MAC on each test mode's measured dofs, over the lowest nm modes
    nws = 0
    for k in range(T):
        if pptr[t0 + k + 1] > pptr[t0 + k]:
            nws += 1
    taken = np.zeros(n, np.bool_)
    if nws:
        ws = np.empty(nws, np.int64)
        MAC = np.zeros((nws, nm))
        c = 0
        for k in range(T):
            a, b = pptr[t0 + k], pptr[t0 + k + 1]
            if b > a:
                ws[c] = k
                ee = 0.0
                for i in range(a, b):
                    ee += psi_e[i] * psi_e[i]
                for j in range(nm):
                    num = 0.0
                    aa = 0.0
                    for i in range(a, b):
                        num += psi_e[i] * Phi[pos[i], j]
                        aa += Phi[pos[i], j] * Phi[pos[i], j]
                    den = ee * aa
                    v = num * num / den if den > 0 else 0.0
                    MAC[c, j] = min(max(v, 0.0), 1.0)
                c += 1
        col = np.empty(nws, np.int64)
        fast = True  # every test mode's best mode strictly best, distinct, above min_mac: the optimum
        for c in range(nws):
            best = 0
            for j in range(1, nm):
                if MAC[c, j] > MAC[c, best]:
                    best = j
            col[c] = best
            for j in range(nm):
                if j != best and not MAC[c, best] > MAC[c, j]:
                    fast = False
            if not MAC[c, best] >= min_mac:
                fast = False
            for c2 in range(c):
                if col[c2] == best:
                    fast = False
        if not fast:
            if nws > nm:
                for c in range(nws):
                    err_modes[ws[c]] = True
                err_i[0] = nm
                return E_NO_PAIR
            _assign(-MAC, nws, nm, col)
            bad = False
            for c in range(nws):
                if not MAC[c, col[c]] >= min_mac:
                    err_modes[ws[c]] = True
                    bad = True
            if bad:
                err_i[0] = nm
                return E_NO_PAIR
        for c in range(nws):
            pairs[ws[c]] = col[c]
            taken[col[c]] = True
    nxt = 0
    for k in range(T):
        if pptr[t0 + k + 1] == pptr[t0 + k]:
            while nxt < nm and taken[nxt]:
                nxt += 1
            if nxt >= nm:
                err_i[0] = k
                return E_NO_MODE_LEFT
            pairs[k] = nxt
            taken[nxt] = True
    # residuals
    row = 0
    for k in range(T):
        q = t0 + k
        j = pairs[k]
        fout[row] = w_lam[q] * (lam[j] - lam_e[q]) / lam_e[q]
        row += 1
        a, b = pptr[q], pptr[q + 1]
        if b > a:
            phs, s, kk, node, sign = _measured_shape(scaling, Phi, pos, psi_e, ref[q], a, b, j)
            if node:
                err_i[0] = kk
                return E_NODE
            for i in range(a, b):
                if i - a == ref[q]:
                    continue
                fout[row] = w_shape * (sign * phs[i - a] / s - psi_e[i])
                row += 1
    for i in range(row):
        if not np.isfinite(fout[i]):
            return E_NONFINITE
    return OK


@jit
def jacobian_row(sp_, r, x, Jout, lam, Phi, pairs, err_i, err_f):
    """Exact Jacobian ∂r/∂x of row r at the point of its last evaluation (work arrays)."""
    (K_const, kp, ki, kj, kv, M_varies, M_const, mp, mi, mj, mv, Cinv_fixed, sptr, sidx, pcode, pscale,
     ds_t0, ds_T, ds_nm, ds_m, row_ds, lam_e, w_lam, pptr, pos, psi_e, ref, scaling, w_shape, min_mac, rtol) = sp_
    n = K_const.shape[0]
    L = x.size
    ds = row_ds[r]
    t0, T, nm = ds_t0[ds], ds_T[ds], ds_nm[ds]
    # check_distinct: paired modes must be flexible and distinct among the computed ones
    scale = 0.0
    for i in range(nm):
        scale = max(scale, abs(lam[i]))
    scale = max(scale, 1e-300)
    for k in range(T):
        t = pairs[k]
        li = lam[t]
        if li == 0.0:
            err_i[0] = t
            return E_RIGID
        tol = rtol * max(abs(li), 1e-12 * scale)
        for j in range(nm):
            if j != t and abs(lam[j] - li) <= tol:
                err_i[0] = t
                err_i[1] = j
                err_f[0] = li
                err_f[1] = lam[j]
                return E_REPEATED
    dpdx = np.empty(L)
    for j in range(L):
        if pcode == 0:
            dpdx[j] = pscale[r, j]
        elif pcode == 1:
            dpdx[j] = math.exp(x[j])
        else:
            dpdx[j] = 1.0
    G = np.zeros(n)
    coef = np.empty(n)
    row0 = 0
    for k in range(T):
        q = t0 + k
        t = pairs[k]
        lt = lam[t]
        a, b = pptr[q], pptr[q + 1]
        ns = b - a
        if ns:
            phs, s, kk, node, sign = _measured_shape(scaling, Phi, pos, psi_e, ref[q], a, b, t)
            fct = w_shape * sign / s
            dd = np.empty(ns)
        for j in range(L):
            for e in range(sptr[j], sptr[j + 1]):
                G[sidx[e]] = 0.0
            for e in range(kp[j], kp[j + 1]):
                G[ki[e]] += kv[e] * Phi[kj[e], t]
            mjj = 0.0
            if M_varies:
                for e in range(mp[j], mp[j + 1]):
                    G[mi[e]] -= lt * mv[e] * Phi[mj[e], t]
                    mjj += Phi[mi[e], t] * mv[e] * Phi[mj[e], t]
            dl = 0.0
            for e in range(sptr[j], sptr[j + 1]):
                dl += Phi[sidx[e], t] * G[sidx[e]]
            Jout[row0, j] = w_lam[q] * dl / lam_e[q] * dpdx[j]
            if ns == 0:
                continue
            for rr in range(n):  # complete modal method
                if rr == t:
                    coef[rr] = -0.5 * mjj
                    continue
                h = 0.0
                for e in range(sptr[j], sptr[j + 1]):
                    h += Phi[sidx[e], rr] * G[sidx[e]]
                coef[rr] = h / (lt - lam[rr])
            for i in range(ns):
                v = 0.0
                pi = pos[a + i]
                for rr in range(n):
                    v += Phi[pi, rr] * coef[rr]
                dd[i] = v
            if scaling == 0:
                ds_ = _trf._dot(phs, dd) / s
            else:
                ds_ = dd[kk]
            row = row0 + 1
            for i in range(ns):
                if i == ref[q]:
                    continue
                Jout[row, j] = fct * (dd[i] - phs[i] / s * ds_) * dpdx[j]
                row += 1
        row0 += 1 + (ns - (1 if ref[q] >= 0 and ns else 0))
    for i in range(row0):
        for j in range(L):
            if not np.isfinite(Jout[i, j]):
                return E_BAD_JACOBIAN
    return OK


# ---------------------------------------------------------------------------------------------
# the driver: every row to the end
# ---------------------------------------------------------------------------------------------
@jit
def _run_row(sp_, st, r, gtol, ftol, xtol, max_nfev, err_code, err_i, err_f, err_modes):
    x, f, J, status, nfev, njev, x_new = st[0], st[1], st[2], st[24], st[26], st[27], st[30]
    n = sp_[0].shape[0]
    m = f.shape[1]
    lam = np.zeros(n)
    Phi = np.zeros((n, n))
    pairs = np.zeros(err_modes.shape[1], np.int64)
    code = evaluate_row(sp_, r, x[r], f[r], lam, Phi, pairs, err_i[r], err_f[r], err_modes[r])
    nfev[r] += 1
    if code != OK:
        status[r] = _trf.FAILED
        err_code[r] = code
        return
    code = jacobian_row(sp_, r, x[r], J[r], lam, Phi, pairs, err_i[r], err_f[r])
    njev[r] += 1
    _trf.init_row(st, r)
    if code != OK:
        status[r] = _trf.FAILED
        err_code[r] = code
        return
    f_new = np.zeros(m)
    while True:
        flag = _trf.propose(st, r, gtol, max_nfev)
        if flag == _trf.STOPPED:
            return
        if flag != _trf.PROPOSED:
            status[r] = _trf.FAILED
            err_code[r] = E_DEGENERATE if flag == _trf.DEGENERATE else E_BAD_JACOBIAN
            return
        f_new[:] = 0.0
        code = evaluate_row(sp_, r, x_new[r], f_new, lam, Phi, pairs, err_i[r], err_f[r], err_modes[r])
        nfev[r] += 1
        if code != OK:
            status[r] = _trf.FAILED
            err_code[r] = code
            return
        accepted, ended = _trf.judge(st, r, f_new, ftol, xtol, max_nfev)
        if accepted:
            J[r] = 0.0
            code = jacobian_row(sp_, r, x[r], J[r], lam, Phi, pairs, err_i[r], err_f[r])
            _trf.accept(st, r)
            if code != OK:
                status[r] = _trf.FAILED
                err_code[r] = code
                return


@njit(cache=True, error_model="numpy", nogil=True, parallel=True)
def solve_rows(sp_, st, rows, gtol, ftol, xtol, max_nfev, err_code, err_i, err_f, err_modes):
    """Run each of ``rows`` to the end (rows in parallel)."""
    for i in prange(rows.size):
        _run_row(sp_, st, rows[i], gtol, ftol, xtol, max_nfev, err_code, err_i, err_f, err_modes)


@jit
def evaluate_rows(sp_, rows, X, F, LAM, PHI, PAIRS, err_code, err_i, err_f, err_modes):
    """Residuals (and eigen-solutions, pairs) of ``rows`` at X, one after the other."""
    for i in range(rows.size):
        err_code[i] = evaluate_row(sp_, rows[i], X[i], F[i], LAM[i], PHI[i], PAIRS[i], err_i[i], err_f[i],
                                   err_modes[i])


@jit
def jacobian_rows(sp_, rows, X, J, LAM, PHI, PAIRS, err_code, err_i, err_f):
    for i in range(rows.size):
        err_code[i] = jacobian_row(sp_, rows[i], X[i], J[i], LAM[i], PHI[i], PAIRS[i], err_i[i], err_f[i])
