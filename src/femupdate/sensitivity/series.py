r"""The omitted modes' part of eigenvector derivatives as a series on the deflated complement.

:func:`omitted_modes_series` sums :math:`\sum_{r>m} \phi_r \phi_r^T R / (\lambda_r - \lambda_t)`
for several modes at once from one factorisation (:mod:`.factor`): the partial sums of the
Neumann series, or their Galerkin (block Lanczos) acceleration in the Krylov space the same
solves span.  The theory is in :mod:`femupdate.sensitivity.subspace`.
"""

from __future__ import annotations

import logging

import numpy as np

from .._errors import InputError, NumericalError
from .factor import single_thread_blas, solve

log = logging.getLogger("femupdate.sensitivity.subspace")  # the subspace route's logger, as before the split

__all__ = ["MAX_TERMS", "DEFAULT_TOL", "SERIES", "omitted_modes_series"]

MAX_TERMS = 50  # cap on the number of series terms (solves with the factor)
DEFAULT_TOL = 1e-10


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
        The partial sums of the Neumann series (:mod:`~femupdate.sensitivity.subspace`); ratio of convergence
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
    lu : object with ``.solve`` (e.g. SuperLU), or callable
        Factorisation of K − σM.
    M : sparse matrix or numpy.ndarray, shape ``(n, n)``
        Mass matrix.
    Phi : numpy.ndarray, shape ``(n, m)``
        The computed, mass-normalised modes (the lowest m of the model).
    R : numpy.ndarray, shape ``(n, k)``
        Right-hand sides.
    shifts : array_like, shape ``(T,)``
        c_t = λ_t − σ > 0, one per mode, rad²/s².
    tol : float
        Column-wise relative tolerance: the sweep stops when, for every column and shift, the
        estimated remainder (last increment / (1 − ρ), ρ the observed ratio of successive
        increments) is below ``tol`` times the column's sum.
    max_terms : int
        Cap on the number of terms (each one solve with ``k`` right-hand sides).
    labels : sequence of str, optional
        Names of the modes, for the error message.
    strict : bool, default True
        Raise :class:`NumericalError` when not converged (else return what was summed).
    series : {"neumann", "krylov"}, default "neumann"
        Partial sums, or the Galerkin (block Lanczos) acceleration described above.

    Returns
    -------
    Q : numpy.ndarray, shape ``(T, n, k)``
        ``Q[t] ≈ G_t R`` (``(T, n)`` for a 1-D ``R``).
    n_terms : int
        Number of terms (= solves with the factorisation) used.

    Raises
    ------
    InputError
        An unknown ``series``, or a shift c_t that is not positive.
    NumericalError
        With ``strict``, the series did not converge within ``max_terms`` (``partial`` holds Q).

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

