r"""The Tikhonov step and what it is computed from: the checked inputs and the standard form.

Problem (1) of the package notes, :math:`\min_z \|J z - b\|^2 + \alpha^2\|\Gamma z\|^2`, is
brought to standard form once (:func:`standard_form`: Γ inverted, or Eldén's transformation for a
Γ with a null space, then the SVD of :math:`\bar A`); :class:`StandardForm` then gives the step
and the norms for any α (the choice of α, :mod:`.choice`, evaluates them on a grid).
"""

from __future__ import annotations

import numbers
from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla

from .._docs import shared_docs
from .._errors import InputError, NumericalError

__all__ = ["N_ALPHA", "StandardForm", "check_alpha", "check_alphas", "check_problem", "standard_form", "tikhonov_step"]

#: number of grid points of the default α grid
N_ALPHA = 200


# ----------------------------------------------------------------------------- validation
def _finite_real(a, what: str, name: str) -> np.ndarray:
    a = np.asarray(a)
    if np.iscomplexobj(a):
        raise InputError(f"{what} {name} must be real, got a complex array")
    if a.dtype == object or not (np.issubdtype(a.dtype, np.number) or a.dtype == bool):
        raise InputError(f"{what} {name} must be numeric, got dtype {a.dtype}")
    a = a.astype(float)
    bad = ~np.isfinite(a)
    if bad.any():
        where = tuple(int(i) for i in np.argwhere(bad)[0])
        raise InputError(f"{what} contains NaN or inf: {name}[{', '.join(map(str, where))}] = {a[where]}")
    return a


def check_problem(J, r, gamma, offset):
    """Check and normalise the inputs of problem (1) of the package notes.

    Parameters
    ----------
    J : array_like or sparse matrix, shape ``(m, L)``
        Sensitivity matrix (a sparse one is made dense).
    r : array_like, shape ``(m,)``
        Residuals.
    gamma : None, float, array_like of shape ``(L,)`` or ``(k, L)``
        Regularisation matrix Γ (see :func:`tikhonov_step`).
    offset : array_like, shape ``(L,)``, or None
        p − p_ref (None: zeros).

    Returns
    -------
    J : numpy.ndarray, shape ``(m, L)``
    r : numpy.ndarray, shape ``(m,)``
    gamma : None or numpy.ndarray of shape ``(L,)`` or ``(k, L)``
        A scalar becomes the constant diagonal of length L.
    offset : numpy.ndarray, shape ``(L,)``
        All as float.

    Raises
    ------
    InputError
        Wrong dimensions or inconsistent shapes, an empty J, or a complex, non-numeric or non-finite
        entry in any input.
    """
    J = np.asarray(J) if not hasattr(J, "toarray") else J.toarray()
    r = np.asarray(r)
    if J.ndim != 2:
        raise InputError(f"the sensitivity matrix J must be 2-D (m, L), got shape {J.shape}")
    if r.ndim != 1:
        raise InputError(f"the residual vector r must be 1-D (m,), got shape {r.shape} (J has shape {J.shape})")
    m, n = J.shape
    if r.shape[0] != m:
        raise InputError(f"J has shape {J.shape} but r has shape {r.shape}: they need the same number of rows m")
    if m == 0 or n == 0:
        raise InputError(f"the sensitivity matrix J is empty (shape {J.shape})")
    J = _finite_real(J, "sensitivity matrix", "J")
    r = _finite_real(r, "residual vector", "r")
    if gamma is not None:
        gamma = _finite_real(gamma, "regularisation matrix", "gamma")
        if gamma.ndim == 0:
            gamma = np.full(n, float(gamma))
        elif gamma.ndim == 1 and gamma.shape[0] != n:
            raise InputError(f"gamma is a diagonal of length {gamma.shape[0]} but J has shape {J.shape}: it needs L = {n} entries")
        elif gamma.ndim == 2 and gamma.shape[1] != n:
            raise InputError(f"gamma has shape {gamma.shape} but J has shape {J.shape}: gamma needs L = {n} columns")
        elif gamma.ndim > 2:
            raise InputError(f"gamma must be a scalar, a diagonal (L,) or a matrix (k, L), got shape {gamma.shape}")
    if offset is None:
        offset = np.zeros(n)
    else:
        offset = _finite_real(offset, "parameter offset", "offset")
        if offset.shape != (n,):
            raise InputError(f"offset = p - p_ref has shape {offset.shape} but J has shape {J.shape}: it needs shape ({n},)")
    return J, r, gamma, offset


def check_alpha(alpha) -> float:
    """Check one Tikhonov factor.

    Parameters
    ----------
    alpha : float
        A real number (not a bool).

    Returns
    -------
    float

    Raises
    ------
    InputError
        ``alpha`` is not a real number, not finite, or negative.
    """
    if isinstance(alpha, (bool, np.bool_)) or not isinstance(alpha, numbers.Real):
        raise InputError(f"the regularisation factor alpha must be a real number, got {alpha!r}")
    alpha = float(alpha)
    if not (np.isfinite(alpha) and alpha >= 0):
        raise InputError(f"the regularisation factor alpha must be finite and >= 0, got {alpha!r}")
    return alpha


def check_alphas(alphas) -> np.ndarray:
    """Check a grid of Tikhonov factors.

    Parameters
    ----------
    alphas : array_like, shape ``(n_alpha,)``
        Positive, finite values.

    Returns
    -------
    numpy.ndarray, shape ``(n_alpha,)``
        The grid sorted ascending, as float.

    Raises
    ------
    InputError
        Not real and finite, not a non-empty 1-D array, or a value <= 0.
    """
    a = _finite_real(alphas, "alpha grid", "alphas")
    if a.ndim != 1 or a.size == 0:
        raise InputError(f"alphas must be a non-empty 1-D array, got shape {a.shape}")
    if np.any(a <= 0):
        raise InputError(f"alphas must be positive, got {a[a <= 0][0]!r}")
    return np.sort(a)


# ----------------------------------------------------------------------------- standard form
#: the grid of the Tikhonov factor, the argument of the curve functions (femupdate._docs)
_ALPHAS = """\
Parameters
----------
alphas : numpy.ndarray, shape ``(n_alpha,)``
    Tikhonov factors α > 0.

Returns
-------"""


@dataclass(frozen=True, eq=False)
class StandardForm:
    """Problem (1) in standard form: SVD of ``Ā`` and the map back to ``Δp``.

    ``Δp(α) = TV @ (s β / (s² + α²)) + x0 - offset``.

    Parameters
    ----------
    m : int
        Rows of J.
    n : int
        Columns L of J (parameters).
    n_null : int
        L − k: dimension of the null space of Γ (unregularised directions).
    s : numpy.ndarray, shape ``(q,)``
        Nonzero singular values of Ā, descending (q its numerical rank).
    beta : numpy.ndarray, shape ``(q,)``
        β_i = u_iᵀ b̄.
    delta0_sq : float
        δ₀² = ‖b̄ − U Uᵀ b̄‖², the part of b̄ outside the range of Ā (and of J W).
    TV : numpy.ndarray, shape ``(L, q)``
        G_J^† V (V when Γ is the identity).
    x0 : numpy.ndarray, shape ``(L,)``
        Unregularised component of z.
    offset : numpy.ndarray, shape ``(L,)``
        p − p_ref.
    """

    m: int
    n: int
    n_null: int          # L - k: dimension of the null space of Γ (unregularised directions)
    s: np.ndarray        # (q,) nonzero singular values of Ā, descending
    beta: np.ndarray     # (q,) u_i^T b̄
    delta0_sq: float     # part of b̄ outside the range of Ā (and of J W)
    TV: np.ndarray       # (L, q)  G_J^† V
    x0: np.ndarray       # (L,)   unregularised component
    offset: np.ndarray   # (L,)

    def step(self, alpha: float) -> np.ndarray:
        """The step Δp(α).

        Parameters
        ----------
        alpha : float
            Tikhonov factor α >= 0 (not checked; see :func:`check_alpha`).

        Returns
        -------
        numpy.ndarray, shape ``(L,)``
        """
        s = self.s
        coef = s * self.beta / (s * s + alpha * alpha)
        return self.TV @ coef + self.x0 - self.offset

    @shared_docs(ALPHAS=_ALPHAS)
    def norms(self, alphas: np.ndarray):
        """ρ², η², dη²/dα and Σ(1 - f) on a grid of α (vectorised: arrays (n_alpha, q)).

        {{ALPHAS}}
        rho2 : numpy.ndarray, shape ``(n_alpha,)``
            ρ²(α) = ‖J Δp_α + r‖².
        eta2 : numpy.ndarray, shape ``(n_alpha,)``
            η²(α) = ‖Γ(p + Δp_α − p_ref)‖².
        deta2 : numpy.ndarray, shape ``(n_alpha,)``
            dη²/dα.
        sum_1mf : numpy.ndarray, shape ``(n_alpha,)``
            Σ_i (1 − f_i).
        """
        a2 = (alphas * alphas)[:, None]                  # (na, 1)
        s2 = (self.s * self.s)[None, :]                  # (1, q)
        b2 = (self.beta * self.beta)[None, :]
        d = s2 + a2
        one_minus_f = a2 / d                             # 1 - f without cancellation
        rho2 = np.sum(one_minus_f**2 * b2, axis=1) + self.delta0_sq
        eta2 = np.sum(s2 * b2 / d**2, axis=1)
        deta2 = -4.0 * alphas * np.sum(s2 * b2 / d**3, axis=1)
        sum_1mf = np.sum(one_minus_f, axis=1)
        return rho2, eta2, deta2, sum_1mf

    @shared_docs(ALPHAS=_ALPHAS)
    def gcv_function(self, alphas: np.ndarray):
        """The GCV function G(α) = ρ²(α) / trace(I − A(α))² of the package notes.

        {{ALPHAS}}
        g : numpy.ndarray, shape ``(n_alpha,)``
            G(α); NaN where the trace is not positive.
        rho2, eta2 : numpy.ndarray, shape ``(n_alpha,)``
            As :meth:`norms`.
        """
        rho2, eta2, _, sum_1mf = self.norms(alphas)
        # trace(I - A(α)) = m - (L - k) - Σ f_i = (m - (L - k) - q) + Σ (1 - f_i)
        trace = (self.m - self.n_null - self.s.size) + sum_1mf
        with np.errstate(divide="ignore", invalid="ignore"):
            g = np.where(trace > 0, rho2 / np.where(trace > 0, trace, 1.0) ** 2, np.nan)
        return g, rho2, eta2

    @shared_docs(ALPHAS=_ALPHAS)
    def curvature(self, alphas: np.ndarray):
        """Curvature κ(α) of the L-curve (ln ρ, ln η), in the closed form of the package notes.

        {{ALPHAS}}
        kappa : numpy.ndarray, shape ``(n_alpha,)``
            κ(α); NaN where ρ² or η² is 0, dη²/dα is not negative or κ is not finite.
        rho2, eta2 : numpy.ndarray, shape ``(n_alpha,)``
            As :meth:`norms`.
        """
        rho2, eta2, deta2, _ = self.norms(alphas)
        a = alphas
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            num = a**2 * deta2 * rho2 + 2.0 * a * eta2 * rho2 + a**4 * eta2 * deta2
            den = (a**4 * eta2**2 + rho2**2) ** 1.5
            kappa = -2.0 * (eta2 * rho2 / deta2) * num / den
        ok = (rho2 > 0) & (eta2 > 0) & (deta2 < 0) & np.isfinite(kappa)
        return np.where(ok, kappa, np.nan), rho2, eta2

    def default_alphas(self) -> np.ndarray:
        """``N_ALPHA`` factors spaced geometrically from s_min / 10 to 10 s_max."""
        return np.geomspace(self.s[-1] / 10.0, self.s[0] * 10.0, N_ALPHA)


def _rank_tol(sv: np.ndarray, shape) -> float:
    return max(shape) * np.finfo(float).eps * (sv[0] if sv.size else 0.0)


def standard_form(J, r, gamma, offset) -> StandardForm:
    """Bring problem (1) of the package notes to standard form and take the SVD of Ā.

    Γ is replaced by a full-row-rank G (its nonzero diagonal, or from its SVD); a Γ with a null
    space is handled by Eldén's transformation.  Singular values below ``max(shape) · eps · s_max``
    count as zero.

    Parameters
    ----------
    J, r, gamma, offset
        As :func:`check_problem` returns them.

    Returns
    -------
    StandardForm

    Raises
    ------
    InputError
        Γ is zero; Γ leaves more directions unregularised than J has rows; or J and Γ share a null
        space (the regularised problem has no unique solution).
    NumericalError
        The SVD does not converge (with either LAPACK driver).
    """
    m, n = J.shape
    b = J @ offset - r
    # G (k, L) of full row rank with ||Γ z|| = ||G z||: its pseudo-inverse Gp (L, k), null basis W (L, L-k)
    if gamma is None:
        Gp, W = None, np.zeros((n, 0))
    elif gamma.ndim == 1:
        mag = np.abs(gamma)
        nz = mag > (n * np.finfo(float).eps * mag.max() if mag.max() > 0 else 0.0)
        if not nz.any():
            raise InputError("gamma is zero: there is nothing to regularise")
        Gp = np.zeros((n, int(nz.sum())))
        Gp[np.flatnonzero(nz), np.arange(Gp.shape[1])] = 1.0 / gamma[nz]
        W = np.eye(n)[:, ~nz]
    else:
        _, sg, Vgt = sla.svd(gamma, full_matrices=True, lapack_driver="gesvd")
        k = int(np.sum(sg > _rank_tol(sg, gamma.shape))) if sg.size and sg[0] > 0 else 0
        if k == 0:
            raise InputError("gamma is zero: there is nothing to regularise")
        Gp = Vgt[:k].T / sg[:k]
        W = Vgt[k:].T
    JG = J if Gp is None else J @ Gp
    x0 = np.zeros(n)
    T = Gp                                   # G_J^† (None: identity)
    bbar = b
    if W.shape[1]:
        JW = J @ W
        if m < W.shape[1]:
            raise InputError(
                f"gamma leaves {W.shape[1]} parameter combinations unregularised but J has only {m} rows "
                f"(J shape {J.shape}, gamma shape {gamma.shape}): the regularised problem has no unique solution")
        Qw, Rw = sla.qr(JW, mode="economic")
        sw = sla.svdvals(JW)
        if sw[0] == 0 or sw[-1] <= _rank_tol(sw, JW.shape) * 10:
            raise InputError(
                f"J and gamma have a common null space (J shape {J.shape}, gamma shape {gamma.shape}): some parameter "
                "combinations are neither measured nor regularised, so the regularised problem has no unique solution")
        # x0 = W (JW)^† b ;  G_J^† = (I - W (JW)^† J) G^† ;  Ā = J G_J^† = (I - Qw Qw^T) J G^†
        x0 = W @ sla.solve_triangular(Rw, Qw.T @ b)
        T = Gp - W @ sla.solve_triangular(Rw, Qw.T @ JG)
        JG = JG - Qw @ (Qw.T @ JG)
        bbar = b - Qw @ (Qw.T @ b)
    try:
        U, s, Vt = sla.svd(JG, full_matrices=False, lapack_driver="gesdd")
    except np.linalg.LinAlgError:            # gesdd occasionally fails to converge; gesvd is slower, sturdier
        try:
            U, s, Vt = sla.svd(JG, full_matrices=False, lapack_driver="gesvd")
        except np.linalg.LinAlgError as exc:
            raise NumericalError(f"the SVD of the {JG.shape} standard-form sensitivity matrix did not converge: {exc}") from None
    q = int(np.sum(s > _rank_tol(s, JG.shape))) if s.size and s[0] > 0 else 0
    U, s, Vt = U[:, :q], s[:q], Vt[:q]
    beta = U.T @ bbar
    delta0_sq = float(np.sum((bbar - U @ beta) ** 2))
    return StandardForm(m=m, n=n, n_null=W.shape[1], s=s, beta=beta, delta0_sq=delta0_sq,
                         TV=Vt.T if T is None else T @ Vt.T, x0=x0, offset=offset)


# ----------------------------------------------------------------------------- public API
def tikhonov_step(J, r, alpha, gamma=None, offset=None) -> np.ndarray:
    r"""Tikhonov-regularised Gauss–Newton step.

    .. math::

        \Delta p = \arg\min_{\Delta}\; \|J\Delta + r\|^2 + \alpha^2 \|\Gamma(\Delta + o)\|^2,
        \qquad o = p - p_\mathrm{ref},

    i.e. the least-squares solution of the stacked system
    :math:`\begin{bmatrix} J \\ \alpha\Gamma \end{bmatrix}\Delta \approx
    -\begin{bmatrix} r \\ \alpha\Gamma o \end{bmatrix}`, computed from the SVD of the
    standard-form matrix :math:`J\Gamma^{-1}` (or :math:`J\Gamma_J^\dagger`, Eldén 1982, when
    Γ has a null space) with the filter factors :math:`f_i = s_i^2/(s_i^2 + \alpha^2)`
    (see the package notes, :mod:`femupdate.regularization`), never through the normal equations.

    Parameters
    ----------
    J : array_like, shape (m, L)
        Sensitivity matrix (in scaled parameters).
    r : array_like, shape (m,)
        Residuals; the unregularised step solves :math:`J\Delta \approx -r`.
    alpha : float
        Tikhonov factor α >= 0.  α = 0 gives the least-squares step of minimum
        :math:`\|\Gamma(\Delta + o)\|` (for Γ = I and o = 0: the pseudo-inverse step
        :math:`-J^+ r`); singular values below ``max(m, L) * eps * s_max`` count as zero.
    gamma : None, float, array_like (L,) or (k, L), optional
        Regularisation matrix Γ: identity (None), a multiple of it, a diagonal, or any matrix
        with L columns (a semi-norm is allowed as long as J and Γ have no common null space).
    offset : array_like, shape (L,), optional
        :math:`p - p_\mathrm{ref}` in the same scaled parameters; None means 0 (the regulariser
        then only penalises the step).

    Returns
    -------
    ndarray, shape (L,)
        The step Δp.

    Raises
    ------
    InputError
        NaN/inf in any input, inconsistent shapes, α < 0, or J and Γ sharing a null space.
    """
    J, r, gamma, offset = check_problem(J, r, gamma, offset)
    alpha = check_alpha(alpha)
    return standard_form(J, r, gamma, offset).step(alpha)

