r"""A-posteriori error control of the reduced model's modes, on the full model.

A reduced mode :math:`y` (eigenvalue :math:`\tilde\lambda`) lifts to the full-model Ritz vector
:math:`x = \hat V y`; its *eigen-residual* on the full model is

.. math::  r = K(p)\,x - \tilde\lambda\, M(p)\,x .

Measured in the norm of :math:`A^{-1}`, :math:`A = K(p) - \sigma M(p)` positive definite
(:math:`\sigma = 0` unless K is singular),

.. math::  \eta = \frac{\|r\|_{A^{-1}}}{\|x\|_A}, \qquad
           \|r\|_{A^{-1}}^2 = r^T A^{-1} r, \quad \|x\|_A^2 = x^T A x = \tilde\lambda - \sigma ,

is the relative residual of the symmetric problem :math:`A^{-1} M x = \mu x`,
:math:`\mu = 1/(\lambda - \sigma)`, in the A-inner product.  Two bounds follow (Parlett, *The
Symmetric Eigenvalue Problem*, §4.5 and §10.5):

* **linear** (Krylov–Weinstein): some eigenvalue :math:`\lambda` of the full model satisfies
  :math:`|\mu - \tilde\mu| \le \tilde\mu\,\eta`;
* **quadratic** (Kato–Temple): if no other eigenvalue lies nearer :math:`\tilde\mu` than
  ``gap``, :math:`|\mu - \tilde\mu| \le (\tilde\mu\eta)^2/\text{gap}`; the gap is taken from the
  other Ritz values, each moved towards :math:`\tilde\mu` by its own linear bound.

Since a Ritz value lies above the eigenvalue of its rank (Poincaré), the bound on
:math:`\tilde\lambda - \lambda` gives the relative *frequency* error bound
:math:`\sqrt{\tilde\lambda/\lambda_{\min}} - 1` reported.  The quadratic one is rigorous when no
mode of the full model is missing from the basis in the band it assumes; the check at each
start's answer (:mod:`femupdate.rom.check`) settles that with one full eigen-solution.

During the greedy construction the norm is that of a reference :math:`A_0` factorised once
(:math:`A(p_0)`): an equivalent norm, so the estimate ranks the parameter points without a
factorisation at each (``exact=False`` in the records).
"""

from __future__ import annotations

import numpy as np

from .basis import m_norms


def ritz_pairs(reduced, Vh: np.ndarray, p: np.ndarray, n_modes: int):
    """The lowest ``n_modes`` Ritz pairs of the reduced model at ``p``, lifted: ``(λ̃, X)``, X n × m,
    ``X^T M X = I``."""
    import scipy.linalg as sl

    n_modes = min(n_modes, reduced.n_dofs)
    lam, Y = sl.eigh(reduced.K(p).toarray(), reduced.M(p).toarray(), subset_by_index=[0, n_modes - 1])
    return lam, Vh @ Y


def _freq_bound(lam: np.ndarray, sigma: float, e_mu: np.ndarray) -> np.ndarray:
    """The relative frequency error bound from ``|μ - μ̃| <= e_mu``."""
    mu = 1.0 / (lam - sigma)
    low = 1.0 / (mu + e_mu) + sigma
    with np.errstate(divide="ignore", invalid="ignore"):
        out = np.sqrt(np.maximum(lam, 0.0) / low) - 1.0
    return np.where(low > 0, np.maximum(out, 0.0), np.inf)


def residual_bounds(K, M, lam: np.ndarray, X: np.ndarray, lu, A=None, sigma: float = 0.0, n_bounded=None) -> dict:
    """The residual measures and bounds of Ritz pairs ``(lam, X)`` of the pencil ``(K, M)``.

    Parameters
    ----------
    K, M : sparse matrices
        The full model's matrices at the point.
    lam, X : numpy.ndarray
        Ritz values (ascending) and lifted Ritz vectors (n × m, M-normalised).
    lu : Factor
        Factorisation of the norm's matrix ``A`` (``K - σM`` at the point, or a reference one).
    A : sparse matrix, optional
        The norm's matrix when it is not ``K - σM`` at the point (reference norm: the estimate).
    sigma : float
        The shift σ of ``K - σM``.
    n_bounded : int, optional
        Bound the first this many pairs (default: all but the last, whose neighbour above is
        unknown); the others serve as gaps.

    Returns
    -------
    dict
        Arrays over the bounded pairs: ``residual`` (‖r‖_{A⁻¹}), ``eta`` (relative residual),
        ``linear`` and ``quadratic`` (relative frequency error bounds), ``estimate`` (the
        smaller of the two), ``gap`` (in μ; ≤ 0 where the neighbours overlap: no quadratic bound).
    """
    m = lam.size if n_bounded is None else min(n_bounded, lam.size)
    R = K @ X - (M @ X) * lam
    Z = np.asarray(lu.solve(R), float).reshape(R.shape)
    res = np.sqrt(np.maximum(np.einsum("ij,ij->j", R, Z), 0.0))
    if A is None:
        xn = np.sqrt(np.maximum(lam - sigma, 1e-300))
    else:
        xn = m_norms(X, A)
    eta = res / xn
    mu = 1.0 / (lam - sigma)
    e_lin = mu * eta
    gap = np.full(lam.size, np.inf)
    for i in range(lam.size):
        others = np.delete(np.arange(lam.size), i)
        if others.size:
            gap[i] = float(np.min(np.abs(mu[others] - mu[i]) - e_lin[others]))
    if lam.size and n_bounded is None:
        m = max(lam.size - 1, 1)
    e_quad = np.where(gap > 0, (mu * eta) ** 2 / np.where(gap > 0, gap, 1.0), np.inf)
    lin = _freq_bound(lam, sigma, e_lin)
    quad = _freq_bound(lam, sigma, e_quad)
    return {"residual": res[:m], "eta": eta[:m], "linear": lin[:m], "quadratic": quad[:m],
            "estimate": np.minimum(lin, quad)[:m], "gap": gap[:m]}


__all__ = ["ritz_pairs", "residual_bounds"]
