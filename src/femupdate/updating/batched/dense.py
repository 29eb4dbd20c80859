"""Small dense linear algebra of the compiled row solver (:mod:`.trf`): inner products, the
quadratic models of the trust-region step, the step to the bounds, Coleman–Li scaling, the
Householder R factor and singular values."""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
from numba import config

from .jit import inner

# Singular values only (LAPACK gesdd, JOBZ='N') cost half the full SVD.  numba has no public
# function for them, so its internal one is used when present and compiled code runs; otherwise
# (another numba, or NUMBA_DISABLE_JIT=1 where the internal one cannot run) the full SVD.
_sv_only: Callable | None = None
if not getattr(config, "DISABLE_JIT", False):
    try:
        from numba.np.linalg import _compute_singular_values as _sv_only
    except ImportError:  # pragma: no cover - a numba without the helper
        _sv_only = None

# Elementwise operations written as loops: NumPy's array expressions and ``a[i] = b`` with an
# array b each compile much more code (a ufunc kernel; a shape check whose error message needs
# numba's string formatting) for the same arithmetic, operation for operation.
@inner
def copy_to(out, a):
    """out[:] = a (same length)."""
    for i in range(a.size):
        out[i] = a[i]


@inner
def mul(a, b):
    """a * b, elementwise, a new array."""
    out = np.empty(a.size)
    for i in range(a.size):
        out[i] = a[i] * b[i]
    return out


@inner
def scaled(a, t):
    """a * t for a scalar t, a new array."""
    out = np.empty(a.size)
    for i in range(a.size):
        out[i] = a[i] * t
    return out


@inner
def add(a, b):
    """a + b, elementwise, a new array."""
    out = np.empty(a.size)
    for i in range(a.size):
        out[i] = a[i] + b[i]
    return out


@inner
def dot(a, b):
    s = 0.0
    for i in range(a.size):
        s += a[i] * b[i]
    return s


@inner
def norm(a):
    return math.sqrt(dot(a, a))


@inner
def half_sq(R11, s):
    """½‖R11 s‖² for upper-triangular R11."""
    n = s.size
    a = 0.0
    for i in range(n):
        v = 0.0
        for k in range(i, n):
            v += R11[i, k] * s[k]
        a += v * v
    return 0.5 * a


@inner
def quad(R11, g, s):
    """½‖R11 s‖² + gᵀs: SciPy's ``evaluate_quadratic`` with ``R11ᵀR11 = J_hᵀJ_h + diag_h``."""
    return half_sq(R11, s) + dot(g, s)


@inner
def quad_1d(R11, g, s, s0):
    """Coefficients (a, b, c) of t ↦ q(s0 + t s) (SciPy's ``build_quadratic_1d``)."""
    n = s.size
    a = 0.0
    b = 0.0
    c = 0.0
    for i in range(n):
        v = 0.0
        u = 0.0
        for k in range(i, n):
            v += R11[i, k] * s[k]
            u += R11[i, k] * s0[k]
        a += v * v
        b += u * v
        c += u * u
    return 0.5 * a, dot(g, s) + b, 0.5 * c + dot(g, s0)


@inner
def min_quad_1d(a, b, lo, hi, c):
    """argmin of a t² + b t + c over [lo, hi], candidates in SciPy's order (lo, hi, extremum)."""
    t_best = lo
    y_best = lo * (a * lo + b) + c
    y = hi * (a * hi + b) + c
    if y < y_best:
        t_best, y_best = hi, y
    if a != 0:
        ext = -0.5 * b / a
        if lo < ext < hi:
            y = ext * (a * ext + b) + c
            if y < y_best:
                t_best, y_best = ext, y
    return t_best, y_best


@inner
def step_to_bound(x, s, lb, ub, hits):
    """Smallest t >= 0 with x + t s on a bound; ``hits`` (out) marks the variables that hit it."""
    n = x.size
    t = np.inf
    for i in range(n):
        if s[i] != 0:
            st = max((lb[i] - x[i]) / s[i], (ub[i] - x[i]) / s[i])
            if st < t:
                t = st
    for i in range(n):
        if s[i] != 0:
            st = max((lb[i] - x[i]) / s[i], (ub[i] - x[i]) / s[i])
            hits[i] = st == t
        else:
            hits[i] = False
    return t


@inner
def cl_scaling(x, g, lb, ub, v, dv):
    """Coleman–Li scaling vector v and its derivative dv (SciPy's ``CL_scaling_vector``)."""
    for i in range(x.size):
        v[i] = 1.0
        dv[i] = 0.0
        if g[i] < 0 and math.isfinite(ub[i]):
            v[i] = ub[i] - x[i]
            dv[i] = -1.0
        if g[i] > 0 and math.isfinite(lb[i]):
            v[i] = x[i] - lb[i]
            dv[i] = 1.0


@inner
def householder_r(A, ncols):
    """Overwrite A (p, q) with the R factor of its QR decomposition in the first ``ncols``
    columns; the later columns receive Qᵀ times themselves."""
    p, q = A.shape
    for k in range(ncols):
        tail = 0.0
        for i in range(k + 1, p):
            tail += A[i, k] * A[i, k]
        if tail == 0.0:  # nothing below the diagonal: no reflection (LAPACK's dlarfg alike)
            continue
        nx = math.sqrt(A[k, k] * A[k, k] + tail)
        beta = -nx if A[k, k] >= 0 else nx
        v0 = A[k, k] - beta
        vn = v0 * v0 + tail  # ‖v‖² with v = (A[k,k] − β, A[k+1:, k])
        if vn <= 0.0:
            A[k, k] = beta
            continue
        for c in range(k + 1, q):
            t = v0 * A[k, c]
            for i in range(k + 1, p):
                t += A[i, k] * A[i, c]
            t = 2.0 * t / vn
            A[k, c] -= t * v0
            for i in range(k + 1, p):
                A[i, c] -= t * A[i, k]
        A[k, k] = beta
        for i in range(k + 1, p):
            A[i, k] = 0.0


@inner
def singular_values(A):
    if _sv_only is not None:
        return _sv_only(A)
    return np.linalg.svd(A)[1]


__all__ = ["copy_to", "mul", "scaled", "add", "dot", "norm", "half_sq", "quad_1d", "quad", "min_quad_1d", "step_to_bound", "cl_scaling", "householder_r", "singular_values"]
