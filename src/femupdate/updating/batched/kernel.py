r"""The modal updating problem compiled: residuals, exact Jacobians and a whole solve per row.

The compiled route evaluates the *same* problem as :class:`femupdate.updating.Problem`: the
rules (parametrisation, spectrum checks, MAC pairing, shape scaling, residuals and their
derivatives) are the functions of :mod:`femupdate.rules`, registered with numba when this module
is imported and called from the kernels below; the test data are the problem's
:class:`~femupdate.updating.problem.Targets`, concatenated over the data sets of a batch.  What
is particular to this route is only how the eigen-solution and its derivatives are obtained —
for a small dense model, every mode at once:

* ``K = K_c + Σ_j p_j K_j`` (and ``M`` alike, or its fixed Cholesky factor), reduction to the
  standard form ``A = C⁻¹ K C⁻ᵀ``, all n eigenpairs by LAPACK (``eigh``), ``φ = C⁻ᵀ y``
  mass-normalised;
* ``λ_t' = φ_tᵀ G_j`` with ``G_j = (K_j − λ_t M_j) φ_t`` (Fox & Kapoor, paper eq. 21) and, all
  modes being at hand, the complete modal method
  ``φ_t' = Σ_{r≠t} φ_r φ_rᵀG_j/(λ_t − λ_r) − ½ (φ_tᵀ M_j φ_t) φ_t`` at the measured dofs.

:func:`solve_rows` runs SciPy's trust-region-reflective method (:mod:`.trf`) for every row
inside compiled code, with no Python between iterations, and without the GIL: the driver spreads
rows over the CPU cores with threads (numba's own parallel loops cost some 25 s more to compile).
Failures are error codes of :mod:`femupdate.rules`, turned into messages by Python.

Everything here is compiled by numba on first use and cached on disk.  numba's cache does not
notice a change in another module that a cached function calls, so the cache of this module is
discarded when the source of the rules, the solver or this module changes (:func:`_fresh_cache`).
"""

from __future__ import annotations

import hashlib
import logging
import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
from numba.extending import overload, register_jitable

from ... import rules
from . import trf
from .jit import inner, jit

log = logging.getLogger(__name__)

for _rule in rules.RULES:  # the rules, callable from the kernels below, with the kernels' error model
    register_jitable(error_model="numpy")(_rule)


@overload(rules.dot, jit_options={"error_model": "numpy"})
def _dot(a, b):
    """:func:`femupdate.rules.dot` in compiled code: a sequential sum, any array layout."""
    def impl(a, b):
        s = 0.0
        for i in range(a.size):
            s += a[i] * b[i]
        return s
    return impl


@overload(rules.dot_col, jit_options={"error_model": "numpy"})
def _dot_col(a, B, j):
    """:func:`femupdate.rules.dot_col` in compiled code: the same sum, reading the column in place."""
    def impl(a, B, j):
        s = 0.0
        for i in range(a.size):
            s += a[i] * B[i, j]
        return s
    return impl


@overload(rules.sumsq_col, jit_options={"error_model": "numpy"})
def _sumsq_col(B, j):
    """:func:`femupdate.rules.sumsq_col` in compiled code: the same sum, reading the column in place."""
    def impl(B, j):
        s = 0.0
        for i in range(B.shape[0]):
            s += B[i, j] * B[i, j]
        return s
    return impl


def _fresh_cache(dispatchers) -> None:
    """Remove the cached compiled code of this package when a source it depends on has changed
    (numba watches only the file that defines a function, not the functions it calls in other
    files).  The cache is wherever numba keeps it: beside the package, under
    ``NUMBA_CACHE_DIR``, or in the user's cache directory for a read-only install."""
    rule_modules = sorted({rules.__name__, rules.dot.__module__, *(fn.__module__ for fn in rules.RULES)})
    sources = [Path(str(sys.modules[m].__file__)) for m in rule_modules] + sorted(Path(__file__).parent.glob("*.py"))
    stamp = hashlib.sha256(b"".join(p.read_bytes() for p in sources)).hexdigest()
    dirs = {Path(__file__).parent / "__pycache__"}
    for d in dispatchers:
        cache_path = getattr(getattr(d, "_cache", None), "_cache_path", None)  # numba's own choice
        if cache_path:
            dirs.add(Path(cache_path))
    for cache in dirs:
        mark = cache / "kernel.sources.sha256"
        try:
            if mark.exists() and mark.read_text() == stamp:
                continue
            for pattern in ("*.nbi", "*.nbc"):  # numba's index and code files: this package's only
                for f in cache.glob(pattern):
                    f.unlink()
            cache.mkdir(parents=True, exist_ok=True)
            mark.write_text(stamp)
        except OSError:  # not ours to write: numba then uses another cache directory
            log.debug("cannot check the compiled-code cache in %s", cache)

# ---------------------------------------------------------------------------------------------
# one row
# ---------------------------------------------------------------------------------------------
@inner
def _cholesky_inverse(M):
    """C⁻¹ of the Cholesky factor M = C Cᵀ; a zero first column signals failure."""
    n = M.shape[0]
    C = np.zeros((n, n))
    Cinv = np.zeros((n, n))
    for i in range(n):
        for k in range(i + 1):
            t = M[i, k]
            for q in range(k):
                t -= C[i, q] * C[k, q]
            if i == k:
                if not t > 0:
                    return Cinv, False
                C[i, i] = math.sqrt(t)
            else:
                C[i, k] = t / C[k, k]
    for i in range(n):
        Cinv[i, i] = 1.0 / C[i, i]
        for k in range(i):
            t = 0.0
            for q in range(k, i):
                t += C[i, q] * Cinv[q, k]
            Cinv[i, k] = -t / C[i, i]
    return Cinv, True


@inner
def _shaped(d, t0, T):
    out = np.zeros(T, np.bool_)
    for k in range(T):
        out[k] = d.pptr[t0 + k + 1] > d.pptr[t0 + k]
    return out


@inner
def _widest(d, t0, T):
    """The most measured dofs of any of the T test modes from ``t0``."""
    w = 0
    for k in range(T):
        w = max(w, d.pptr[t0 + k + 1] - d.pptr[t0 + k])
    return w


@inner
def _measured(Phi, pos, j, work):
    """Mode j at the dofs ``pos``: the leading entries of the work array ``work``, filled."""
    out = work[:pos.size]
    for i in range(pos.size):
        out[i] = Phi[pos[i], j]
    return out


@inner
def evaluate_row(sp_, r, x, fout, lam, Phi, pairs, pmac, err_i, err_f, err_modes):
    """Residuals of row r at x into ``fout``; the eigen-solution and the pairs with their MAC
    (NaN without shape) into the work arrays ``lam`` (n,), ``Phi`` (n, n), ``pairs`` and ``pmac``
    (T,).  Returns an error code (OK = 0)."""
    md, sets, d = sp_.model, sp_.sets, sp_.targets
    n = md.K_const.shape[0]
    L = x.size
    ds = sets.row_ds[r]
    t0, T, nm = sets.t0[ds], sets.T[ds], sets.nm[ds]
    p = rules.to_p(md.pcode, x, md.pscale[r])
    for j in range(L):
        if not math.isfinite(p[j]):
            return rules.E_NONFINITE
    K = md.K_const.copy()
    for j in range(L):
        for e in range(md.kp[j], md.kp[j + 1]):
            K[md.ki[e], md.kj[e]] += p[j] * md.kv[e]
    mdiag = np.empty(n)
    if md.M_varies:
        M = md.M_const.copy()
        for j in range(L):
            for e in range(md.mp[j], md.mp[j + 1]):
                M[md.mi[e], md.mj[e]] += p[j] * md.mv[e]
        for i in range(n):
            mdiag[i] = M[i, i]
            if not mdiag[i] > 0:
                return rules.E_MASS_DIAG
        Cinv, ok = _cholesky_inverse(M)
        if not ok:
            return rules.E_MASS_CHOL
    else:
        Cinv = md.Cinv
        for i in range(n):
            mdiag[i] = md.M_const[i, i]
    A = Cinv @ K @ Cinv.T
    As = np.empty((n, n))  # symmetrised (a loop: an array expression compiles a kernel of its own)
    for i in range(n):
        for k in range(n):
            As[i, k] = 0.5 * (A[i, k] + A[k, i])
    w, Y = np.linalg.eigh(As)
    Ph = Cinv.T @ Y
    for i in range(n):
        lam[i] = w[i]
        for k in range(n):
            Phi[i, k] = Ph[i, k]
    pencil = 0.0
    for i in range(n):
        pencil = max(pencil, abs(K[i, i]) / mdiag[i])
    computed = lam[:nm].copy()
    code, low = rules.check_spectrum(lam, nm, pencil)
    if code != rules.OK:
        err_f[0] = low
        return code
    rules.restore_elastic(K, Phi, lam, computed, nm)
    # pairing
    shaped = _shaped(d, t0, T)
    MAC = np.zeros((T, max(nm, 1)))
    B = np.empty((_widest(d, t0, T), nm))  # one work array for every mode's measured rows
    phs = np.empty(B.shape[0])  # and one for a mode's measured shape
    for k in range(T):
        if shaped[k]:
            a, b = d.pptr[t0 + k], d.pptr[t0 + k + 1]
            for i in range(b - a):
                for j in range(nm):
                    B[i, j] = Phi[d.pos[a + i], j]
            rules.mac_vector(d.psi_e[a:b], B[:b - a], MAC[k, :nm])
    code, i0, _ = rules.pair_modes(sp_.pairing, MAC, shaped, lam, d.lam_e[t0:t0 + T], nm, sp_.min_mac, pairs,
                                   err_modes)
    if code != rules.OK:
        err_i[0] = i0
        return code
    for k in range(T):
        pmac[k] = MAC[k, pairs[k]] if shaped[k] else np.nan
    # residuals
    row = 0
    for k in range(T):
        q = t0 + k
        j = pairs[k]
        fout[row] = rules.eigenvalue_residual(lam[j], d.lam_e[q], d.w_lam[q])
        row += 1
        a, b = d.pptr[q], d.pptr[q + 1]
        if b > a:
            ns = rules.n_shape_residuals(b - a, d.ref[q])
            node = rules.shape_residuals(sp_.scaling, _measured(Phi, d.pos[a:b], j, phs),
                                         d.psi_e[a:b], d.ref[q], d.w_psi[q],
                                         fout[row:row + ns])
            if node >= 0:
                err_i[0] = node
                return rules.E_NODE
            row += ns
    for i in range(row):
        if not math.isfinite(fout[i]):
            return rules.E_NONFINITE
    return rules.OK


@inner
def jacobian_row(sp_, r, x, Jout, lam, Phi, pairs, err_i, err_f):
    """Exact Jacobian ∂r/∂x (m, L) of row r at the point of its last evaluation (work arrays)."""
    md, sets, d = sp_.model, sp_.sets, sp_.targets
    n = md.K_const.shape[0]
    L = x.size
    ds = sets.row_ds[r]
    t0, T, nm = sets.t0[ds], sets.T[ds], sets.nm[ds]
    for k in range(T):  # paired modes must be flexible and distinct
        code, other = rules.check_distinct(lam, nm, pairs[k])
        if code != rules.OK:
            err_i[0] = pairs[k]
            err_i[1] = other
            err_f[0] = lam[pairs[k]]
            err_f[1] = lam[other]
            return code
    if sp_.close_tol > 0.0:  # a group of close modes is the local route's (femupdate.updating.groups)
        for t in range(nm):
            first, stop = rules.group_bounds(lam, nm, t, sp_.close_tol)
            if stop - first > 1:
                err_i[0] = first
                err_i[1] = first + 1
                err_f[0] = lam[first]
                err_f[1] = lam[first + 1]
                return rules.E_REPEATED
    dpdx = rules.dp_dx(md.pcode, x, md.pscale[r])
    G = np.zeros(n)
    coef = np.empty(n)
    dlam = np.empty(L)
    dbuf = np.zeros((_widest(d, t0, T), L))  # one work array for every mode's shape derivatives
    phs = np.empty(dbuf.shape[0])  # and one for its measured shape
    row0 = 0
    for k in range(T):
        q = t0 + k
        t = pairs[k]
        lt = lam[t]
        a, b = d.pptr[q], d.pptr[q + 1]
        ns = b - a
        dphs = dbuf[:ns]
        for j in range(L):
            for e in range(md.sptr[j], md.sptr[j + 1]):
                G[md.sidx[e]] = 0.0
            for e in range(md.kp[j], md.kp[j + 1]):
                G[md.ki[e]] += md.kv[e] * Phi[md.kj[e], t]
            mjj = 0.0
            if md.M_varies:
                for e in range(md.mp[j], md.mp[j + 1]):
                    G[md.mi[e]] -= lt * md.mv[e] * Phi[md.mj[e], t]
                    mjj += Phi[md.mi[e], t] * md.mv[e] * Phi[md.mj[e], t]
            dl = 0.0
            for e in range(md.sptr[j], md.sptr[j + 1]):
                dl += Phi[md.sidx[e], t] * G[md.sidx[e]]
            dlam[j] = dl  # Fox & Kapoor
            if ns == 0:
                continue
            for rr in range(n):  # the complete modal method
                if rr == t:
                    coef[rr] = -0.5 * mjj
                    continue
                h = 0.0
                for e in range(md.sptr[j], md.sptr[j + 1]):
                    h += Phi[md.sidx[e], rr] * G[md.sidx[e]]
                coef[rr] = h / (lt - lam[rr])
            for i in range(ns):
                v = 0.0
                pi = d.pos[a + i]
                for rr in range(n):
                    v += Phi[pi, rr] * coef[rr]
                dphs[i, j] = v
        rules.eigenvalue_gradient(dlam, d.lam_e[q], d.w_lam[q], dpdx, Jout[row0])
        row0 += 1
        if ns:
            nr = rules.n_shape_residuals(ns, d.ref[q])
            rules.shape_jacobian(sp_.scaling, _measured(Phi, d.pos[a:b], t, phs), dphs,
                                 d.psi_e[a:b], d.ref[q], d.w_psi[q], dpdx,
                                 Jout[row0:row0 + nr])
            row0 += nr
    for i in range(row0):
        for j in range(L):
            if not math.isfinite(Jout[i, j]):
                return rules.E_BAD_JACOBIAN
    return rules.OK


# ---------------------------------------------------------------------------------------------
# the driver: every row to the end
# ---------------------------------------------------------------------------------------------
@inner
def _keep(rep, r, lam, pairs, pmac):
    """The pairs of row r's current point into the report."""
    for k in range(rep.pairs.shape[1]):
        rep.pairs[r, k] = pairs[k]
        rep.macs[r, k] = pmac[k]
        rep.eigenvalues[r, k] = lam[pairs[k]]


@jit
def solve_rows(sp_, st, rows, gtol, ftol, xtol, max_nfev, rep):
    """Run each of ``rows`` to the end, one after the other, the GIL released (the driver runs
    several calls at once, one per core).  A failure stops its row: ``status`` FAILED and the
    error in ``rep``."""
    n = sp_.model.K_const.shape[0]
    m = st.f.shape[1]
    T = rep.pairs.shape[1]
    lam = np.zeros(n)
    Phi = np.zeros((n, n))
    pairs = np.zeros(T, np.int64)
    pmac = np.zeros(T)
    f_new = np.zeros(m)
    for i in range(rows.size):
        r = rows[i]
        code = evaluate_row(sp_, r, st.x[r], st.f[r], lam, Phi, pairs, pmac, rep.ints[r], rep.floats[r], rep.modes[r])
        st.nfev[r] += 1
        if code == rules.OK:
            _keep(rep, r, lam, pairs, pmac)
            code = jacobian_row(sp_, r, st.x[r], st.J[r], lam, Phi, pairs, rep.ints[r], rep.floats[r])
            st.njev[r] += 1
            trf.init_row(st, r)
        while code == rules.OK:
            flag = trf.propose(st, r, gtol, max_nfev)
            if flag == trf.STOPPED:
                break
            if flag != trf.PROPOSED:
                code = rules.E_DEGENERATE if flag == trf.DEGENERATE else rules.E_BAD_JACOBIAN
                break
            f_new[:] = 0.0
            code = evaluate_row(sp_, r, st.x_new[r], f_new, lam, Phi, pairs, pmac, rep.ints[r], rep.floats[r],
                                rep.modes[r])
            st.nfev[r] += 1
            if code != rules.OK:
                break
            accepted, ended = trf.judge(st, r, f_new, ftol, xtol, max_nfev)
            if accepted:
                _keep(rep, r, lam, pairs, pmac)
                st.J[r] = 0.0
                code = jacobian_row(sp_, r, st.x[r], st.J[r], lam, Phi, pairs, rep.ints[r], rep.floats[r])
                trf.accept(st, r)
        if code != rules.OK:
            st.status[r] = trf.FAILED
            rep.code[r] = code


@jit
def evaluate_rows(sp_, rows, X, F, J, LAM, PAIRS, PMAC, err):
    """Residuals F (S, m), eigenvalues LAM (S, n), pairs and their MAC (S, T) and
    Jacobians J (S, m, L) of ``rows`` at X (S, L), one after the other;
    ``err`` per row of X."""
    n = sp_.model.K_const.shape[0]
    for i in range(rows.size):
        Phi = np.zeros((n, n))
        code = evaluate_row(sp_, rows[i], X[i], F[i], LAM[i], Phi, PAIRS[i], PMAC[i], err.ints[i], err.floats[i],
                            err.modes[i])
        if code == rules.OK:
            code = jacobian_row(sp_, rows[i], X[i], J[i], LAM[i], Phi, PAIRS[i], err.ints[i], err.floats[i])
        err.code[i] = code


@jit
def residual_rows(sp_, rows, X, F, LAM, PAIRS, PMAC, err):
    """:func:`evaluate_rows` without the Jacobians: residuals F (S, m), eigenvalues LAM (S, n),
    pairs and their MAC (S, T) of ``rows`` at X (S, L) — what a likelihood needs at many points
    (:mod:`femupdate.bayes`)."""
    n = sp_.model.K_const.shape[0]
    Phi = np.zeros((n, n))
    for i in range(rows.size):
        err.code[i] = evaluate_row(sp_, rows[i], X[i], F[i], LAM[i], Phi, PAIRS[i], PMAC[i], err.ints[i], err.floats[i],
                                   err.modes[i])


_fresh_cache([solve_rows, evaluate_rows, residual_rows, trf.rows_propose])


def cached() -> bool:
    """Whether numba's disk cache holds a build of :func:`solve_rows` for these sources."""
    cache_path = getattr(getattr(solve_rows, "_cache", None), "_cache_path", None)
    return cache_path is not None and any(Path(str(cache_path)).glob("kernel.solve_rows-*.nbi"))


def _row_signatures(sp_) -> list:
    """:func:`evaluate_row` and :func:`jacobian_row` with the argument types of their calls in
    :func:`solve_rows` (``sp_`` the spec)."""
    from numba import typeof, types

    S, i, v, m = typeof(sp_), types.int64, types.float64[::1], types.float64[:, ::1]
    iv, bv = types.int64[::1], types.boolean[::1]
    return [(evaluate_row, (S, i, v, v, v, m, iv, v, iv, v, bv)), (jacobian_row, (S, i, v, m, v, m, iv, iv, v))]


def build(sp_, cores: int) -> None:
    """Compile what :func:`solve_rows` needs for the spec ``sp_`` before its first call, when
    numba's cache does not have it: with two cores or more, a second Python process compiles the
    solver's row functions into the cache (:func:`.trf.compile_rows`) while this one compiles
    the modal ones; :func:`solve_rows` then loads the former, compiles the latter into itself,
    and the build takes about the time of the larger half plus solve_rows' own.  Without a second
    process (one core, or it fails) :func:`solve_rows` compiles everything itself: the same code."""
    from numba import config

    if getattr(config, "DISABLE_JIT", False) or cores < 2 or solve_rows.signatures or cached() or not sys.executable:
        return
    env = dict(os.environ)
    root = str(Path(__file__).resolve().parents[3])  # the folder holding this femupdate, wherever installed
    env["PYTHONPATH"] = os.pathsep.join([root] + ([env["PYTHONPATH"]] if env.get("PYTHONPATH") else []))
    cache_dir = getattr(config, "CACHE_DIR", "")
    if cache_dir:  # the same cache as this process's, however it was set
        env["NUMBA_CACHE_DIR"] = cache_dir
    try:
        code = (f"from femupdate._workers import bind_to_owner; bind_to_owner({os.getpid()}); "  # ends with this process
                "from femupdate.updating.batched import trf; trf.compile_rows()")
        child = subprocess.Popen([sys.executable, "-c", code],
                                 env=env, stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                                 stderr=subprocess.PIPE)
    except OSError as e:
        log.debug("no second process to compile in: %s", e)
        return
    err = b""
    try:
        for fn, sig in _row_signatures(sp_):
            fn.compile(sig)
        _, err = child.communicate(timeout=600)
    except subprocess.TimeoutExpired:
        err = b"timed out"
    finally:
        if child.poll() is None:  # timed out, or this process was interrupted
            child.kill()
            child.communicate()
    if child.returncode:
        log.debug("the second compiling process failed (exit %s): %s", child.returncode, err[-2000:])


__all__ = ["evaluate_row", "jacobian_row", "solve_rows", "evaluate_rows", "residual_rows", "cached", "build"]
