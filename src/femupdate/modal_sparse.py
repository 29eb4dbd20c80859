"""The sparse path of :func:`femupdate.modal.solve_modes`: shift-invert Lanczos (ARPACK through
:func:`scipy.sparse.linalg.eigsh`) with one factorisation of K − σM, afresh or through a model's
:class:`~femupdate.workspace.SparseWorkspace`, warm-started from a nearby solution."""

from __future__ import annotations

import logging

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from ._errors import NumericalError
from .workspace import NotPositiveDefinite, factorize, nearly_singular

log = logging.getLogger("femupdate.modal")


def arpack_options() -> dict:
    """Keyword arguments of :func:`scipy.sparse.linalg.eigsh` that make its result reproducible:
    ARPACK's start and restart vectors from a fixed seed (left alone, SciPy draws them from the
    operating system's entropy, and eigenpairs change by round-off from run to run)."""
    return {"rng": np.random.default_rng(0)}


def rigid_body_shift(K, M) -> float:
    """The shift of a singular K (rigid-body modes): just below zero, −1e-6 times the median
    K_ii / M_ii (the pencil's scale), so that K − σM is positive definite."""
    d, md = K.diagonal(), M.diagonal()
    both = (d > 0) & (md > 0)
    s = float(np.median(d[both] / md[both])) if np.any(both) else 1.0
    sigma = -1e-6 * s
    log.info("K is singular (rigid-body modes): shift-invert with sigma = %.3g", sigma)
    return sigma


def _sparse(K, M, n_modes, sigma, tol):
    """Shift-invert Lanczos with ONE factorisation of K - sigma M, handed to ARPACK."""
    K = sp.csc_array(K)
    M = sp.csc_array(M)
    lu = None
    if sigma is None:
        sigma = 0.0
        try:
            lu = factorize(K, definite=True)
            if nearly_singular(lu):
                raise RuntimeError("nearly singular")
        except (RuntimeError, NotPositiveDefinite):
            lu, sigma = None, rigid_body_shift(K, M)
    if lu is None:
        try:
            lu = factorize(K - sigma * M)
        except RuntimeError as exc:
            raise _arpack_failed(sigma, exc) from None
    lam, Phi = _arpack(K, M, n_modes, sigma, tol, lu)
    return lam, Phi, (lu, float(sigma))


#: with a previous solution to start from, the shift of shift-invert is this fraction of its lowest
#: eigenvalue: the omitted modes' series of the sensitivities then converge with ratio
#: (λ_i − σ)/(λ_{m+1} − σ) instead of λ_i/λ_{m+1}, and ARPACK separates the lowest modes sooner
SHIFT_FRACTION = 0.9


def _arpack(K, M, n_modes, sigma, tol, lu, v0=None):
    OPinv = spla.LinearOperator(K.shape, matvec=lu.solve, dtype=float)
    try:
        return spla.eigsh(K, k=n_modes, M=M, sigma=sigma, which="LM", tol=tol, OPinv=OPinv, v0=v0, **arpack_options())
    except spla.ArpackNoConvergence as exc:
        raise NumericalError(
            f"the sparse eigensolver did not converge for {n_modes} modes "
            f"({len(exc.eigenvalues)} converged)", partial=exc.eigenvalues
        ) from None
    except RuntimeError as exc:
        raise _arpack_failed(sigma, exc) from None


def _arpack_failed(sigma: float, exc: RuntimeError) -> NumericalError:
    """The message of a failed shift-invert solution (SuperLU's or ARPACK's error, first line)."""
    first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
    return NumericalError(f"the sparse eigensolver (ARPACK) failed at shift {sigma:g} ({first}); for a small model "
                          "use the dense one (--method dense)")


def _is_singular(lu) -> bool:
    return lu.nearly_singular() if hasattr(lu, "nearly_singular") else nearly_singular(lu)


def _mass_operator(M):
    """M for ARPACK's products: a diagonal M (lumped masses) as an elementwise product (the same
    numbers as the sparse product, without its per-call overhead), else M in CSC."""
    Mr = sp.csr_array(M)
    n = Mr.shape[0]
    if Mr.nnz <= n and np.array_equal(Mr.indices, np.repeat(np.arange(n), np.diff(Mr.indptr))):
        d = Mr.diagonal()
        return spla.LinearOperator(Mr.shape, matvec=lambda x: d * np.ravel(x), dtype=float)
    return sp.csc_array(M)


def _sparse_reused(K, M, n_modes, sigma, tol, ws, start):
    """:func:`_sparse` with the workspace's factorisation route, warm-started from ``start``.

    The same eigenpairs (to round-off): only the factorisation's ordering and kernel, ARPACK's
    starting vector and, with ``start``, the shift change.  A shift taken from ``start`` is
    accepted only when every computed eigenvalue lies above it and the highest at least twice
    it: any eigenvalue below σ would then lie nearer σ than the highest computed one and have
    been found, so the modes are the lowest of the model; otherwise the solution is repeated at
    σ = 0."""
    Mc = _mass_operator(M)
    v0 = guess = None
    if start is not None:
        lam0, Phi0 = (start.eigenvalues, start.shapes) if hasattr(start, "eigenvalues") else start
        lam0, Phi0 = np.asarray(lam0, float), np.asarray(Phi0, float)
        if Phi0.ndim == 2 and Phi0.shape[0] == K.shape[0] and Phi0.shape[1] and np.all(np.isfinite(Phi0)):
            v = Phi0[:, :n_modes].sum(axis=1)
            if np.any(Mc @ v):
                v0 = v
        if sigma is None and lam0.size and np.isfinite(lam0[0]) and lam0[0] > 0:
            guess = SHIFT_FRACTION * float(lam0[0])
    if guess is not None:
        try:
            lu = ws.factor(K, M, guess)
        except (NotPositiveDefinite, RuntimeError):
            lu = None
        if lu is not None:
            lam, Phi = _arpack(K, Mc, n_modes, guess, tol, lu, v0)
            if np.min(lam) > guess and np.max(lam) >= 2.0 * guess:
                return lam, Phi, (lu, guess)
            log.debug("shift %.6g from the previous solution rejected (eigenvalues %.6g..%.6g): sigma = 0",
                      guess, np.min(lam), np.max(lam))
    lu = None
    if sigma is None:
        sigma = 0.0
        try:
            lu = ws.factor(K, M, 0.0)
            if _is_singular(lu):
                raise RuntimeError("nearly singular")
        except (NotPositiveDefinite, RuntimeError):
            lu, sigma = None, rigid_body_shift(K, M)
    if lu is None:
        try:
            lu = ws.factor(K, M, sigma)
        except NotPositiveDefinite:  # an indefinite K - sigma M: LU with pivoting
            lu = factorize(K - sigma * M)
        except RuntimeError as exc:
            raise NumericalError(f"the sparse eigensolver (ARPACK) failed at shift {sigma:g} (K - sigma M is singular: "
                                 f"{exc})") from None
    lam, Phi = _arpack(K, Mc, n_modes, sigma, tol, lu, v0)
    return lam, Phi, (lu, float(sigma))
