r"""The Ritz basis of a parametric reduced model: snapshots of the full model, M-orthonormalised.

At a parameter point :math:`p` a *snapshot* is the lowest modes :math:`\phi_i` of the full model
(shift-invert Lanczos on one factorisation of :math:`A = K(p) - \sigma M(p)`, :math:`\sigma = 0`
unless K is singular) and, for each mode and parameter, its *static correction*

.. math::  w_{ij} = A^{-1} \Big(\frac{\partial K}{\partial p_j} - \lambda_i \frac{\partial M}{\partial p_j}\Big)\phi_i ,

the part of :math:`\partial\phi_i/\partial p_j` the modes themselves do not hold (Nelson's
particular solution without its modal part), from the same factorisation.  The vectors are
added to the basis :math:`V` by block Gram–Schmidt in the mass inner product, twice, then
column by column against each other (Gram–Schmidt, twice); a direction whose M-norm left after
the projections is below ``deflation`` times its own is
*deflated* (dropped as already held), so that :math:`V^T M V = I` stays well conditioned however
many snapshots are near-dependent.  Nothing of size n × n is formed: the basis is n × r.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from .._errors import NumericalError

#: the relative M-norm below which a new direction counts as already held by the basis
DEFLATION = 1e-8


def m_norms(V: np.ndarray, M) -> np.ndarray:
    """The M-norm of each column of ``V`` (``sqrt(v^T M v)``; 0 for a massless direction)."""
    return np.sqrt(np.maximum(np.einsum("ij,ij->j", V, M @ V), 0.0))


def orthonormalise(W: np.ndarray, M, V: np.ndarray | None = None, deflation: float = DEFLATION) -> np.ndarray:
    """The new M-orthonormal directions of ``W`` (n × k) beyond the M-orthonormal ``V`` (n × r).

    Parameters
    ----------
    W : numpy.ndarray, shape ``(n, k)``
        Candidate vectors.
    M : sparse matrix, shape ``(n, n)``
        The mass matrix of the inner product (positive semi-definite).
    V : numpy.ndarray, shape ``(n, r)``, optional
        The basis so far (``V^T M V = I``).
    deflation : float
        Relative M-norm below which a direction is dropped.

    Returns
    -------
    numpy.ndarray, shape ``(n, k')``, ``k' <= k``
        ``Q`` with ``Q^T M Q = I`` and ``V^T M Q = 0``.
    """
    W = np.array(W, dtype=float, copy=True)
    if W.ndim == 1:
        W = W[:, None]
    s = m_norms(W, M)
    keep = s > 0
    W = W[:, keep] / s[keep]
    if not W.shape[1]:
        return W
    for _ in range(2):  # classical Gram-Schmidt twice against V is as stable as the modified one
        if V is not None and V.shape[1]:
            W -= V @ (V.T @ (M @ W))
    Q = np.empty_like(W)
    k = 0
    for i in range(W.shape[1]):  # within the block: Gram-Schmidt column by column, twice
        w = W[:, i]
        for _ in range(2):
            if V is not None and V.shape[1]:
                w = w - V @ (V.T @ (M @ w))
            if k:
                w = w - Q[:, :k] @ (Q[:, :k].T @ (M @ w))
        nw = float(np.sqrt(max(w @ (M @ w), 0.0)))
        if nw > deflation:  # the column had M-norm 1: nw is what is new in it, relative
            Q[:, k] = w / nw
            k += 1
    return Q[:, :k]


def shift_of(K, M):
    """The shift σ of the snapshot factorisation and, for σ = 0, the factor of K: 0 for a positive
    definite K, else just below zero (:func:`femupdate.modal_sparse.rigid_body_shift`) and None."""
    from ..workspace import NotPositiveDefinite, factorize, nearly_singular

    try:
        lu = factorize(sp.csc_array(K), definite=True)
        if not nearly_singular(lu):
            return 0.0, lu
    except (RuntimeError, NotPositiveDefinite):
        pass
    from ..modal_sparse import rigid_body_shift

    return rigid_body_shift(K, M), None


def factor_pencil(model, p: np.ndarray, sigma: float | None = None):
    """``(K, M, factor of K - σM, σ)`` of the full model at ``p`` (one factorisation when K is
    positive definite)."""
    from ..workspace import factorize

    K, M = model.K(p), model.M(p)
    lu = None
    if sigma is None:
        sigma, lu = shift_of(K, M)
    if lu is None:
        try:
            lu = factorize(sp.csc_array(K - sigma * M))
        except RuntimeError as exc:
            raise NumericalError(f"the full model's K - sigma M is singular at sigma = {sigma:g} ({exc})") from None
    return K, M, lu, float(sigma)


def full_modes(model, p: np.ndarray, n_modes: int, pencil=None):
    """The lowest ``n_modes`` eigenpairs of the full model at ``p`` (ascending, mass-normalised),
    with the pencil ``(K, M, lu, σ)`` they were computed on."""
    from ..modal_sparse import _arpack

    K, M, lu, sigma = pencil if pencil is not None else factor_pencil(model, p)
    n = K.shape[0]
    if n_modes >= n - 1:
        raise NumericalError(f"the reduced route needs fewer modes ({n_modes}) than the model has dofs ({n})")
    lam, Phi = _arpack(sp.csc_array(K), sp.csc_array(M), n_modes, sigma, 1e-12, lu)
    order = np.argsort(lam)
    lam, Phi = lam[order], Phi[:, order]
    Phi = Phi / m_norms(Phi, M)
    return lam, Phi, (K, M, lu, sigma)


def static_corrections(model, p: np.ndarray, lam: np.ndarray, Phi: np.ndarray, pencil, params=None) -> np.ndarray:
    """``A^{-1} (∂K/∂p_j - λ_i ∂M/∂p_j) φ_i`` for every mode i and parameter j in ``params``
    (default every parameter), from the snapshot's factorisation; n × (modes · parameters)."""
    _, _, lu, _ = pencil
    idx = range(len(model.parameters)) if params is None else params
    cols = []
    for j in idx:
        dK, dM = model.dK_dp(j, p), model.dM_dp(j, p)
        R = dK @ Phi if dK.nnz else np.zeros_like(Phi)
        if dM.nnz:
            R = R - (dM @ Phi) * lam
        if np.any(R):
            cols.append(R)
    if not cols:
        return np.zeros((Phi.shape[0], 0))
    B = np.hstack(cols)
    return np.asarray(lu.solve(B), dtype=float).reshape(B.shape)


def snapshot(model, p: np.ndarray, n_modes: int, corrections: bool = True, params=None):
    """The snapshot vectors at ``p`` (modes, then their static corrections) and the modes."""
    lam, Phi, pencil = full_modes(model, p, n_modes)
    W = Phi
    if corrections:
        W = np.hstack([Phi, static_corrections(model, p, lam, Phi, pencil, params)])
    return W, lam, Phi, pencil


__all__ = ["orthonormalise", "m_norms", "snapshot", "full_modes", "factor_pencil", "static_corrections", "DEFLATION"]
