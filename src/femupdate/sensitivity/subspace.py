r"""Eigenvector derivatives from the computed modes and ONE shifted factorisation: the omitted
modes' part summed as a Neumann series on the deflated complement (iterative technique).

With the m computed, mass-normalised modes Φ (n × m), a factorisation S = (K − σM)⁻¹ with
σ below every eigenvalue, and the right-hand side f = −(K' − λ_iM')φ_i + λ_i' Mφ_i
(:mod:`._common`), the derivative of mode i is

.. math::

    \phi_i' = \sum_{r \le m,\, r \ne i} \phi_r \frac{\phi_r^T f}{\lambda_r - \lambda_i}
              - \tfrac12 (\phi_i^T M' \phi_i)\, \phi_i + q, \qquad
    q = \sum_{r > m} \phi_r \frac{\phi_r^T f}{\lambda_r - \lambda_i}
      = \sum_{k \ge 0} (\lambda_i - \sigma)^k y_k,

    y_0 = P S P^T f, \quad y_k = P S M y_{k-1}, \qquad P = I - \Phi\Phi^T M,

because :math:`S M \phi_r = \phi_r / (\lambda_r - \sigma)` and P removes the computed modes.
The first term alone is Wang's (1991) static correction (with shift σ,
:func:`~femupdate.sensitivity.modal_static_correction`); the series converges geometrically
with ratio :math:`(\lambda_i - \sigma) / (\lambda_{m+1} - \sigma)`.  This is the iterative
technique of Rudisill & Chu (1975) and Ting's (1992) accelerated subspace iteration, written as
a Neumann series of the deflated operator P S M: every term costs one forward/backward
substitution with one factorisation for all modes — none per mode as in Nelson's method.

The terms T^k y_0 (T = P S M) do not depend on f's mode when f does not (the adjoint's sensor
columns), and they span a Krylov space in which the Galerkin solution of
(I − (λ_i − σ)T) q = y_0 converges like conjugate gradients — about twice as fast as the
partial sums (``series="krylov"`` of :func:`omitted_modes_series`; in the spirit of Ting's
acceleration).

**Differentiate the lowest m_d of m computed modes**: the ratio for the highest differentiated
mode is :math:`(\lambda_{m_d} - \sigma)/(\lambda_{m+1} - \sigma)`, so compute a buffer of modes
above it (:func:`buffered_modes`, the default: twice as many modes, at least 6 more; with a
spectrum growing like r² that gives a ratio near 0.25, about 17 Neumann terms or 10 Krylov
steps for ``tol = 1e-10``).  The modes must be the lowest m of the model (as
:func:`femupdate.model_modes` returns them): with a lower mode missing the Neumann series
diverges, which is detected and reported (the Krylov form still converges to the right answer,
the missing mode being part of the complement, but slowly).

References
----------
Rudisill, C.S., Chu, Y.-Y. (1975) Numerical methods for evaluating the derivatives of
eigenvalues and eigenvectors. AIAA Journal 13(6), 834–837.
Wang, B.P. (1991) Improved approximate methods for computing eigenvector derivatives in
structural dynamics. AIAA Journal 29(6), 1018–1020.
Ting, T. (1992) Accelerated subspace iteration for eigenvector derivatives. AIAA Journal
30(8), 2114–2118.
"""

from __future__ import annotations

import contextlib
import ctypes
import logging
import math

import numpy as np

from .._errors import InputError, NumericalError
from ._common import check_distinct, mode_rhs, resolve_params, resolve_which
from .modal import _modal_part, shifted_factor

log = logging.getLogger(__name__)

MAX_TERMS = 50  # cap on the number of series terms (solves with the factor)
DEFAULT_TOL = 1e-10


def buffered_modes(n_differentiated: int, n_dofs: int | None = None) -> int:
    """Number of modes to compute to differentiate the lowest ``n_differentiated`` by the
    series routes: ``max(2 m_d, m_d + 6)``, capped at ``n_dofs`` when given."""
    m = max(2 * int(n_differentiated), int(n_differentiated) + 6)
    return m if n_dofs is None else min(m, int(n_dofs))


# ---------------------------------------------------------------------------------------------
# solves with one thread of BLAS
# ---------------------------------------------------------------------------------------------
_BLAS_CONTROLS = None
_THREADPOOL_LIMITS = None  # threadpoolctl's context manager, False when not installed


def _blas_controls():
    """(get, set) thread-count functions of the OpenBLAS libraries loaded in this process."""
    global _BLAS_CONTROLS
    if _BLAS_CONTROLS is not None:
        return _BLAS_CONTROLS
    controls = []
    try:
        with open("/proc/self/maps") as f:
            paths = sorted({line.split()[-1] for line in f if "openblas" in line.lower() and "/" in line})
    except OSError:
        paths = []
    for path in paths:
        try:
            lib = ctypes.CDLL(path)
        except OSError:
            continue
        for prefix, suffix in (("scipy_openblas", "64_"), ("scipy_openblas", ""), ("openblas", "64_"), ("openblas", "")):
            try:
                get = getattr(lib, f"{prefix}_get_num_threads{suffix}")
                set_ = getattr(lib, f"{prefix}_set_num_threads{suffix}")
            except AttributeError:
                continue
            get.restype, set_.restype = ctypes.c_int, None
            set_.argtypes = [ctypes.c_int]
            controls.append((get, set_))
            break
    _BLAS_CONTROLS = controls
    return controls


@contextlib.contextmanager
def single_thread_blas():
    """Run the enclosed code with one BLAS thread (the previous counts are restored).

    SuperLU's solve with several right-hand sides calls BLAS on every (small) supernode, and
    OpenBLAS's thread hand-off then dominates: on a 35,000-dof frame a 30-column solve takes
    4.1 s with two threads and 0.49 s with one.  ``threadpoolctl`` is used when installed;
    otherwise the OpenBLAS libraries loaded in the process are found (Linux ``/proc``) and set
    directly; elsewhere this does nothing.
    """
    global _THREADPOOL_LIMITS
    if _THREADPOOL_LIMITS is None:
        try:
            from threadpoolctl import threadpool_limits as _THREADPOOL_LIMITS
        except ImportError:
            _THREADPOOL_LIMITS = False
    threadpool_limits = _THREADPOOL_LIMITS
    if threadpool_limits:
        with threadpool_limits(limits=1, user_api="blas"):
            yield
        return
    controls = _blas_controls()
    saved = [get() for get, _ in controls]
    for _, set_ in controls:
        set_(1)
    try:
        yield
    finally:
        for (_, set_), n in zip(controls, saved):
            set_(max(int(n), 1))


def solve(lu, B: np.ndarray) -> np.ndarray:
    """S B with the factorisation ``lu`` (an object with ``.solve``, or a callable)."""
    with single_thread_blas():
        return lu.solve(B) if hasattr(lu, "solve") else np.asarray(lu(B))


# ---------------------------------------------------------------------------------------------
# the shift and the factorisation
# ---------------------------------------------------------------------------------------------
def check_modes(model, modes) -> None:
    """The modes must live on the model's dofs."""
    if modes.shapes.shape[0] != model.n_dofs or tuple(modes.dofs) != tuple(model.dofs):
        raise InputError(
            f"the modes have {modes.shapes.shape[0]} dofs but model {model.name!r} has {model.n_dofs} "
            "(or they are on other dof labels): compute them with model_modes(model, ...)"
        )


def prepare_factor(K, M, modes, sigma=None, lu=None):
    """The factorisation of K − σM and the shift σ for the series routes.

    σ defaults to 0 when the lowest computed eigenvalue is positive, else (rigid-body modes) a
    small negative shift (:func:`~femupdate.sensitivity.modal.shifted_factor`).  A supplied
    ``lu`` must factorise K − σM for the given ``sigma`` (default 0).  Without ``lu`` and
    ``sigma``, the factorisation the sparse eigensolver left in ``modes.factor`` is reused.
    """
    lam_min = float(np.min(modes.eigenvalues))
    if lu is None and sigma is None and getattr(modes, "factor", None) is not None:
        lu, sigma = modes.factor  # the eigensolver's own factorisation of K − σM
    if sigma is None and (lu is not None or lam_min > 0):
        sigma = 0.0
    if sigma is not None:
        sigma = float(sigma)
        if not math.isfinite(sigma) or sigma >= lam_min:
            raise InputError(
                f"sigma = {sigma:g} must lie below the lowest computed eigenvalue ({lam_min:.6g}); "
                "with rigid-body modes (zero eigenvalues) use a negative shift"
            )
    if lu is None:
        with single_thread_blas():
            lu, sigma = shifted_factor(K, M, sigma)
        if sigma >= lam_min:
            raise InputError(f"the shift {sigma:g} is not below the lowest computed eigenvalue {lam_min:.6g}")
    return lu, float(sigma)


# ---------------------------------------------------------------------------------------------
# the series
# ---------------------------------------------------------------------------------------------
SERIES = ("neumann", "krylov")


def omitted_modes_series(lu, M, Phi, R, shifts, *, tol: float = DEFAULT_TOL, max_terms: int = MAX_TERMS,
                         labels=None, strict: bool = True, series: str = "neumann"):
    r"""G_t R = Σ_{r>m} φ_r φ_rᵀ R / (λ_r − λ_t) for several modes t at once, from one factorisation.

    With T = P S M (S = (K − σM)⁻¹, P = I − ΦΦᵀM) and Y_0 = P S Pᵀ R,
    G_t R = Σ_k c_t^k T^k Y_0 = (I − c_t T)⁻¹ Y_0 with c_t = λ_t − σ.

    ``series="neumann"``
        The partial sums of the Neumann series (module docstring); ratio of convergence
        ρ_t = c_t / (λ_{m+1} − σ).
    ``series="krylov"``
        The same solves, Y_0, T Y_0, T² Y_0, …, span a block Krylov space that does not depend
        on the mode; the Galerkin solution of (I − c_t T) W = Y_0 in it (T is self-adjoint in
        the M inner product on the complement: block Lanczos with full reorthogonalisation) is
        at least as accurate as the partial sum of as many terms, and converges like conjugate
        gradients, with ratio ≈ (1 − √(1 − ρ_t)) / (1 + √(1 − ρ_t)): 0.07 instead of 0.25 for
        ρ = 0.25, i.e. about half the solves.  It stores the basis, (terms × k) columns of
        length n, so it is meant for few right-hand sides (the adjoint's sensors).

    Parameters
    ----------
    lu : factorisation of K − σM (``.solve`` or callable).
    M : (n, n) mass matrix.
    Phi : (n, m) the computed, mass-normalised modes (the lowest m of the model).
    R : (n, k) right-hand sides.
    shifts : (T,) c_t = λ_t − σ > 0, one per mode.
    tol : float
        Column-wise relative tolerance: the sweep stops when, for every column and shift, the
        estimated remainder (last increment / (1 − ρ), ρ the observed ratio of successive
        increments) is below ``tol`` times the column's sum.
    max_terms : int
        Cap on the number of terms (each one solve with ``k`` right-hand sides).
    labels : sequence of str, optional
        Names of the modes, for the error message.
    strict : bool
        Raise :class:`NumericalError` when not converged (else return what was summed).
    series : ``"neumann"`` | ``"krylov"``

    Returns
    -------
    Q : (T, n, k)
        ``Q[t] ≈ G_t R``.
    n_terms : int
        Number of terms (= solves with the factorisation) used.

    Notes
    -----
    The terms T^k Y_0 do not depend on the mode, so one sweep serves every shift: this is what
    lets the adjoint route (:func:`~femupdate.sensitivity.adjoint`) cost one solve per sensor
    and term for all modes together.  Neumann terms are carried scaled by c_max^k, so that
    nothing under- or overflows however large the eigenvalues are.  The sweep stops early, with
    the error, when the observed ratio shows that ``max_terms`` cannot suffice.
    """
    if series not in SERIES:
        raise InputError(f"unknown series {series!r}: use {' or '.join(SERIES)}")
    shifts = np.atleast_1d(np.asarray(shifts, dtype=float))
    if np.any(~(shifts > 0)):
        raise InputError("the series needs lambda_i - sigma > 0 for every mode")
    labels = list(labels) if labels is not None else [f"#{t + 1}" for t in range(shifts.size)]
    R = np.asarray(R, dtype=float)
    squeeze = R.ndim == 1
    if squeeze:
        R = R[:, None]
    MPhi = M @ Phi

    def P(X):  # X <- P X, in place
        X -= Phi @ (MPhi.T @ X)
        return X

    monitor = _Monitor(shifts.size, R.shape[1], tol, max_terms, strict)
    # Columns of very different size (stiffness and mass parameters) are balanced first: the
    # Krylov basis drops directions that are small relative to the block's largest.
    col = np.linalg.norm(R, axis=0)
    col = np.where(col > 0, col, 1.0)
    # One BLAS thread for the whole sweep: the solves need it (see single_thread_blas), and the
    # rest is memory-bound products of tall, thin blocks.  With NumPy's two-thread OpenBLAS
    # around single-threaded solves, the non-solve work of the sweep took 2.6 times longer on
    # the 102,600-dof benchmark (13.7 s against 5.2 s).
    with single_thread_blas():
        Y0 = P(solve(lu, (R - MPhi @ (Phi.T @ R)) / col))  # y_0 = P S P^T R
        if series == "neumann":
            Q = _neumann(lu, M, P, Y0, shifts, monitor)
        else:
            Q = _krylov(lu, M, P, Y0, shifts, monitor, labels)
    Q *= col
    if squeeze:
        Q = Q[:, :, 0]
    if strict and not monitor.done:
        bad = np.flatnonzero(~monitor.converged)
        worst = float(np.max(monitor.rho[bad]))
        names = ", ".join(labels[t] for t in bad[:8])
        raise NumericalError(
            f"mode(s) {names}: the {series} series for the omitted modes did not converge "
            f"(stopped after {monitor.n_terms} of at most {max_terms} terms; observed ratio of successive "
            f"terms {worst:.3g}, about (lambda_i - sigma)/(lambda_m+1 - sigma)"
            f"{', >= 1: the series diverges' if worst >= 1 else ', too close to 1'}): compute more modes "
            "above the highest differentiated one (buffered_modes), and make sure the modes are the "
            "lowest of the model",
            partial=Q,
        )
    log.debug("omitted-modes %s series: %d terms for %d modes, %d columns", series, monitor.n_terms, shifts.size,
              R.shape[1])
    return Q, monitor.n_terms


class _Monitor:
    """Convergence of a sweep: per shift and column, increment norms against sum norms."""

    def __init__(self, n_shifts, n_cols, tol, max_terms, strict):
        self.tol, self.max_terms, self.strict = float(tol), int(max_terms), strict
        self.prev = None
        self.rho = np.zeros((n_shifts, n_cols))
        self.converged = np.zeros(n_shifts, dtype=bool)
        self.n_terms = 1
        self.done = False
        self.ok = None

    def update(self, a, qn) -> bool:
        """Record increment norms ``a`` and sum norms ``qn`` (T, k); True to stop the sweep."""
        if self.prev is None:  # the first term: nothing to compare with yet
            self.prev = a
            return self.n_terms >= self.max_terms
        with np.errstate(divide="ignore", invalid="ignore"):
            self.rho = np.where(self.prev > 0, a / np.where(self.prev > 0, self.prev, 1.0), 0.0)
        self.prev = a
        ok = (a <= self.tol * qn * (1.0 - np.minimum(self.rho, 1.0))) | (a <= 64 * np.finfo(float).eps * qn)
        # once converged, a column stays converged: increments at round-off level fluctuate
        self.ok = ok if self.ok is None else (self.ok | ok)
        ok = self.ok
        self.converged = np.all(ok, axis=1)
        if np.all(self.converged):
            self.done = True
            return True
        if self.n_terms >= self.max_terms:
            return True
        # give up early when even the observed (optimistic) ratio needs more terms than allowed
        if self.strict and self.n_terms >= 5:
            with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
                r = np.clip(self.rho, 1e-300, None)
                more = np.log(self.tol * qn * (1.0 - np.minimum(r, 1.0)) / a) / np.log(r)
            more = np.where(ok, 0.0, np.where(r < 1.0, np.nan_to_num(more, nan=np.inf), np.inf))
            if np.any(self.n_terms + more > self.max_terms):
                return True
        return False


def _neumann(lu, M, P, Z, shifts, monitor):
    cmax = float(shifts.max())
    scale = shifts / cmax  # (T,) <= 1
    Q = np.repeat(Z[None], shifts.size, axis=0)
    k = 0
    stop = monitor.update(np.repeat(np.linalg.norm(Z, axis=0)[None], shifts.size, axis=0), None)
    while not stop:
        k += 1
        Z = cmax * P(solve(lu, M @ Z))
        monitor.n_terms += 1
        f = scale**k
        Q += f[:, None, None] * Z[None]
        a = f[:, None] * np.linalg.norm(Z, axis=0)[None, :]  # (T, k) norms of this term
        stop = monitor.update(a, np.linalg.norm(Q, axis=1))
    return Q


def _m_orthonormal(X, M, P, V=None):
    """M-orthonormal basis (Fortran order) of the part of X (n, p) in the complement of the
    computed modes and M-orthogonal to the basis ``V`` (n, d).

    Block Gram–Schmidt against ``V`` and the deflation P (twice), then a thin SVD of the result
    for its rank (directions below 1e-12 of the largest are round-off: the usual deflation of
    block Lanczos), then M-orthonormalisation of those directions through their Gram matrix,
    re-projected once and normalised again, so that the basis stays in the complement to
    round-off.  Also returns the M-norm of the projected part relative to X's (about 0 when X
    lies in span V: the Krylov space is invariant).
    """
    def project(Y):
        if V is not None and V.shape[1]:
            Y -= V @ (V.T @ (M @ Y))
        return P(Y)

    def normalise(Q):
        G = Q.T @ (M @ Q)
        d, W = np.linalg.eigh(0.5 * (G + G.T))
        keep = d > 1e-12 * max(float(d[-1]) if d.size else 0.0, 1e-300)
        return ((W[:, keep] / np.sqrt(d[keep])).T @ Q.T).T  # = Q W d^-1/2, in Fortran order

    x_norm = float(np.sqrt(max(np.max(np.einsum("ij,ij->j", X, M @ X), initial=0.0), 0.0)))
    X = project(project(np.array(X, dtype=float, copy=True)))
    y_norm = float(np.sqrt(max(np.max(np.einsum("ij,ij->j", X, M @ X), initial=0.0), 0.0)))
    size = y_norm / x_norm if x_norm > 0 else 0.0
    if X.shape[1] == 0 or y_norm == 0.0:
        return X[:, :0], 0.0
    U, sv, _ = np.linalg.svd(X, full_matrices=False)
    return normalise(project(normalise(U[:, sv > 1e-12 * sv[0]]))), size


class _Basis:
    """Growing (n, d) block basis in a column-major buffer whose capacity doubles."""

    def __init__(self, n, k):
        self.V = np.empty((n, 4 * k), order="F")
        self.d = 0

    def add(self, Vn):
        p = Vn.shape[1]
        if self.d + p > self.V.shape[1]:
            new = np.empty((self.V.shape[0], max(2 * self.V.shape[1], self.d + p)), order="F")
            new[:, : self.d] = self.V[:, : self.d]
            self.V = new
        self.V[:, self.d : self.d + p] = Vn
        self.d += p
        return slice(self.d - p, self.d)

    @property
    def view(self):
        return self.V[:, : self.d]


def _krylov(lu, M, P, Y0, shifts, monitor, labels):
    n, k = Y0.shape
    T = shifts.size
    if monitor.max_terms <= 1:  # no room for a Krylov step: the first term, as for Neumann
        return np.repeat(Y0[None], T, axis=0)
    V0, size = _m_orthonormal(Y0, M, P)
    if V0.shape[1] == 0 or size == 0.0:
        monitor.done = True
        monitor.converged[:] = True
        return np.zeros((T, n, k))
    basis = _Basis(n, k)
    last = basis.add(V0)  # columns of the newest block
    MVj = M @ V0
    B0 = MVj.T @ Y0  # Y0 = V0 B0
    H = np.zeros((0, 0))
    z_prev = None
    while True:
        X = P(solve(lu, MVj))  # T V_j
        monitor.n_terms += 1
        V = basis.view
        C = V.T @ (M @ X)  # V^T M T V_j: the new block column of H
        d_old, d = H.shape[0], V.shape[1]
        Hn = np.zeros((d, d))
        Hn[:d_old, :d_old] = H
        Hn[:, last] = C
        Hn[last, :] = C.T
        H = 0.5 * (Hn + Hn.T)
        theta, U = np.linalg.eigh(H)
        rhs = np.zeros((d, k))
        rhs[: B0.shape[0]] = B0
        Ur = U.T @ rhs
        den = 1.0 - shifts[:, None] * theta[None, :]  # (T, d)
        near = np.min(np.abs(den), axis=1) < 1e-10
        if np.any(near):
            t = int(np.flatnonzero(near)[0])
            raise NumericalError(
                f"mode {labels[t]}: its eigenvalue is (nearly) an eigenvalue of the modes left out of the "
                "modes given (a repeated mode, or the modes are not the lowest of the model)"
            )
        z = np.stack([U @ (Ur / den[t][:, None]) for t in range(T)])  # (T, d, k) Galerkin solutions
        qn = np.linalg.norm(z, axis=1)  # M-norms of the columns of W = V z
        if z_prev is None:
            a = qn
        else:
            diff = z.copy()
            diff[:, :d_old] -= z_prev
            a = np.linalg.norm(diff, axis=1)
        z_prev = z
        if monitor.update(a, qn):
            break
        Vn, size = _m_orthonormal(X, M, P, V)
        if Vn.shape[1] == 0 or size <= 1e-13:
            monitor.done = True  # invariant subspace: the Galerkin solution is exact
            monitor.converged[:] = True
            break
        last = basis.add(Vn)
        MVj = M @ Vn
    V = basis.view[:, : z.shape[1]]
    Q = np.empty((T, n, k))
    for t in range(T):  # W_t = V z_t
        np.matmul(V, z[t], out=Q[t])
    return Q


# ---------------------------------------------------------------------------------------------
# the forward route
# ---------------------------------------------------------------------------------------------
def subspace_details(model, modes, which=None, params=None, values=None, sigma=None, tol: float = DEFAULT_TOL,
                     lu=None, max_terms: int = MAX_TERMS, series: str = "neumann"):
    """:func:`subspace`, also returning the number of series terms used for each mode ``(m_d,)``."""
    check_modes(model, modes)
    which = resolve_which(modes, which)
    params = resolve_params(model, params)
    check_distinct(modes, which)
    K, M = model.K(values), model.M(values)
    lu, sigma = prepare_factor(K, M, modes, sigma, lu)
    lam, Phi = modes.eigenvalues, modes.shapes
    n = model.n_dofs
    dlam = np.zeros((which.size, params.size))
    dphi = np.zeros((n, which.size, params.size))
    n_terms = np.zeros(which.size, dtype=int)
    for r, i in enumerate(which):
        phi = Phi[:, i]
        dl, F, mjj = mode_rhs(model, params, lam[i], phi, M @ phi)
        Q, n_terms[r] = omitted_modes_series(lu, M, Phi, F, [lam[i] - sigma], tol=tol, max_terms=max_terms,
                                             labels=[str(i + 1)], series=series)
        dlam[r] = dl
        dphi[:, r, :] = _modal_part(modes, i, F, mjj) + Q[0]
    return dlam, dphi, n_terms


def subspace(model, modes, which=None, params=None, values=None, sigma=None, tol: float = DEFAULT_TOL, lu=None,
             max_terms: int = MAX_TERMS, series: str = "neumann"):
    r"""Eigenvalue and eigenvector derivatives from the computed modes plus the deflated series.

    φ_i' = Σ_{r≤m, r≠i} φ_r (φ_rᵀf)/(λ_r − λ_i) − ½(φ_iᵀM'φ_i)φ_i + Σ_k (λ_i − σ)^k y_k, with
    y_0 = P S Pᵀ f, y_k = P S M y_{k−1}, S = (K − σM)⁻¹, P = I − ΦΦᵀM (see the module
    docstring; Rudisill & Chu 1975, Ting 1992).  Exact to ``tol`` whatever the number of
    computed modes, provided they are the lowest of the model and a buffer lies above the
    differentiated ones.

    Parameters
    ----------
    model : Model
    modes : Modes
        The lowest m modes of ``model`` at ``values``, mass-normalised.
    which : sequence of int, optional
        Modes to differentiate (default all; better the lowest m_d < m, see
        :func:`buffered_modes`).
    params : sequence of int or str, optional
        Parameters (default the free ones).
    values : parameter values of ``modes`` (default nominal).
    sigma : float, optional
        Shift of the factorisation, below every computed eigenvalue (default 0, or a small
        negative shift when there are rigid-body modes).
    tol : float
        Relative accuracy of the omitted modes' part (see :func:`omitted_modes_series`).
    lu : factorisation of K − σM, optional
        Reuse one; ``sigma`` must then be its shift (default 0).
    max_terms : int
        Cap on the series; :class:`NumericalError` names the mode when it is not enough.
    series : ``"neumann"`` | ``"krylov"``
        Partial sums, or the Galerkin (block Lanczos) acceleration of
        :func:`omitted_modes_series`; the latter stores (terms × L) vectors per mode, so use it
        with few parameters.

    Returns
    -------
    dlam : ndarray (len(which), L)
    dphi : ndarray (n_dofs, len(which), L)
        Derivatives of the mass-normalised shapes.
    """
    dlam, dphi, _ = subspace_details(model, modes, which, params, values, sigma, tol, lu, max_terms, series)
    return dlam, dphi


__all__ = ["subspace", "subspace_details", "omitted_modes_series", "buffered_modes", "single_thread_blas",
           "prepare_factor", "solve"]
