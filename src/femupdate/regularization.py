r"""Tikhonov regularisation of the linearised updating step, with the factor chosen by GCV or the L-curve.

At each Gauss–Newton step of sensitivity-based updating the linearised problem
:math:`J\,\Delta p \approx -r` (``J`` the (m, L) sensitivity matrix in scaled parameters, ``r``
the m residuals) is often ill-conditioned (condition numbers of 1e5..1e13 occur).  Tikhonov
regularisation solves instead

.. math::

    \min_{\Delta p}\; \|J\,\Delta p + r\|^2 + \alpha^2\,\|\Gamma\,(p + \Delta p - p_\mathrm{ref})\|^2 ,

which pulls the *parameters* toward a reference ``p_ref`` (usually the nominal model), not only
the step toward zero.  With ``offset`` :math:`o = p - p_\mathrm{ref}` and :math:`z = \Delta p + o`
this is the general-form problem

.. math::

    \min_z\; \|J z - b\|^2 + \alpha^2 \|\Gamma z\|^2, \qquad b = J o - r .        \tag{1}

**Standard form.**  :math:`\Gamma` is replaced by a matrix :math:`G` (k, L) of full row rank with
:math:`\|\Gamma z\| = \|G z\|` (``G = Γ`` for the identity or an invertible diagonal; otherwise from
the SVD of :math:`\Gamma`).  For an invertible :math:`\Gamma` (k = L), :math:`y = G z` and
:math:`\bar A = J G^{-1}` turn (1) into :math:`\min_y \|\bar A y - b\|^2 + \alpha^2\|y\|^2`.  A
:math:`\Gamma` with a null space (a semi-norm: a zero weight, a difference operator) is handled
by Eldén's transformation with the A-weighted pseudo-inverse
:math:`G_J^\dagger = (I - W (JW)^\dagger J)\,G^\dagger` (W a basis of the null space of
:math:`\Gamma`), :math:`\bar A = J G_J^\dagger`, :math:`\bar b = b - J x_0`,
:math:`x_0 = W (JW)^\dagger b` and :math:`z = G_J^\dagger y + x_0`.  This is equivalent to the
generalised SVD of :math:`(J, \Gamma)` used in Hansen's *Regularization Tools* (Hansen 1994,
2007); the unregularised components of z (those in the null space of :math:`\Gamma`) are then
fitted exactly.

**Filter factors.**  With the SVD :math:`\bar A = \sum_i s_i u_i v_i^T` (numerical rank q),
:math:`\beta_i = u_i^T \bar b` and the filter factors :math:`f_i = s_i^2 / (s_i^2 + \alpha^2)`,

.. math::

    y_\alpha &= \sum_i f_i \frac{\beta_i}{s_i} v_i, \\
    \rho^2(\alpha) &= \|J\,\Delta p_\alpha + r\|^2 = \sum_i (1 - f_i)^2 \beta_i^2 + \delta_0^2,
        \qquad \delta_0^2 = \|\bar b - U U^T \bar b\|^2, \\
    \eta^2(\alpha) &= \|\Gamma(p + \Delta p_\alpha - p_\mathrm{ref})\|^2 = \sum_i f_i^2 \beta_i^2 / s_i^2 .

**GCV** (Golub, Heath & Wahba 1979) minimises

.. math::

    G(\alpha) = \frac{\|J\,\Delta p_\alpha + r\|^2}{\mathrm{trace}(I - A(\alpha))^2}
             = \frac{\rho^2(\alpha)}{\big(m - (L - k) - \sum_i f_i\big)^2},

:math:`A(\alpha) = J (J^T J + \alpha^2 \Gamma^T\Gamma)^{-1} J^T` the influence matrix.

**L-curve** (Hansen 1992; Hansen & O'Leary 1993): the corner of the curve
:math:`(\ln\rho(\alpha), \ln\eta(\alpha))` is the point of maximum curvature.  With
:math:`\hat\eta = \eta^2`, :math:`\hat\rho = \rho^2` and
:math:`\hat\eta' = d\hat\eta/d\alpha = -4\alpha\sum_i s_i^2\beta_i^2/(s_i^2+\alpha^2)^3`
(so that :math:`\hat\rho' = -\alpha^2\hat\eta'`) the curvature is, in closed form,

.. math::

    \kappa(\alpha) = -\,\frac{2\,\hat\eta\,\hat\rho}{\hat\eta'}\;
      \frac{\alpha^2\hat\eta'\hat\rho + 2\alpha\hat\eta\hat\rho + \alpha^4\hat\eta\hat\eta'}
           {(\alpha^4\hat\eta^2 + \hat\rho^2)^{3/2}},

positive where the curve turns counter-clockwise (down its vertical leg, then right along its
horizontal leg).  Both criteria are evaluated on a grid of α at once (arrays of shape
(n_alpha, q), no loop per α) and the grid optimum is polished by a bounded scalar search between
its neighbours, as Regularization Tools' ``gcv`` and ``l_corner`` do with ``fminbnd``.

References
----------
P. C. Hansen, "Analysis of discrete ill-posed problems by means of the L-curve", SIAM Review
34 (1992) 561-580.
P. C. Hansen, D. P. O'Leary, "The use of the L-curve in the regularization of discrete
ill-posed problems", SIAM J. Sci. Comput. 14 (1993) 1487-1503.
G. H. Golub, M. Heath, G. Wahba, "Generalized cross-validation as a method for choosing a good
ridge parameter", Technometrics 21 (1979) 215-223.
P. C. Hansen, "Regularization Tools: a Matlab package for analysis and solution of discrete
ill-posed problems", Numer. Algorithms 6 (1994) 1-35; version 4.0, 46 (2007) 189-194.
P. C. Hansen, *Discrete Inverse Problems: Insight and Algorithms*, SIAM, 2010 (ch. 5).
L. Eldén, "A weighted pseudoinverse, generalized singular values, and constrained least squares
problems", BIT 22 (1982) 487-502.
"""

from __future__ import annotations

import logging
import numbers
from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla
from scipy.optimize import minimize_scalar

from ._errors import InputError, NumericalError

log = logging.getLogger(__name__)

__all__ = ["RegularizationChoice", "tikhonov_step", "gcv", "l_curve", "choose_alpha"]

#: number of grid points of the default α grid
N_ALPHA = 200


@dataclass(frozen=True, eq=False)
class RegularizationChoice:
    r"""A regularisation factor and the evidence it was chosen from.

    Attributes
    ----------
    alpha : float
        The chosen Tikhonov factor α (the grid optimum, polished between its neighbours).
    alphas : ndarray, shape (n_alpha,)
        The grid of α, ascending.
    residual_norms : ndarray, shape (n_alpha,)
        :math:`\|J\,\Delta p_\alpha + r\|` on the grid.
    solution_norms : ndarray, shape (n_alpha,)
        :math:`\|\Gamma (p + \Delta p_\alpha - p_\mathrm{ref})\|` on the grid.
    criterion : ndarray, shape (n_alpha,)
        The GCV function :math:`G(\alpha)` (``method`` "gcv"), the L-curve curvature
        :math:`\kappa(\alpha)` in the (ln ρ, ln η) plane (``method`` "lcurve"), or NaN
        (``method`` "fixed").
    method : str
        "gcv", "lcurve" or "fixed", followed by a note in parentheses when the criterion had no
        interior optimum (e.g. ``"lcurve (no corner: ...; smallest alpha of the grid)"``).

    The arrays are read-only.
    """

    alpha: float
    alphas: np.ndarray
    residual_norms: np.ndarray
    solution_norms: np.ndarray
    criterion: np.ndarray
    method: str

    def __post_init__(self):
        for name in ("alphas", "residual_norms", "solution_norms", "criterion"):
            a = np.array(getattr(self, name), dtype=float)
            a.setflags(write=False)
            object.__setattr__(self, name, a)
        object.__setattr__(self, "alpha", float(self.alpha))


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


def _check_problem(J, r, gamma, offset):
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


def _check_alpha(alpha) -> float:
    if isinstance(alpha, (bool, np.bool_)) or not isinstance(alpha, numbers.Real):
        raise InputError(f"the regularisation factor alpha must be a real number, got {alpha!r}")
    alpha = float(alpha)
    if not (np.isfinite(alpha) and alpha >= 0):
        raise InputError(f"the regularisation factor alpha must be finite and >= 0, got {alpha!r}")
    return alpha


def _check_alphas(alphas) -> np.ndarray:
    a = _finite_real(alphas, "alpha grid", "alphas")
    if a.ndim != 1 or a.size == 0:
        raise InputError(f"alphas must be a non-empty 1-D array, got shape {a.shape}")
    if np.any(a <= 0):
        raise InputError(f"alphas must be positive, got {a[a <= 0][0]!r}")
    return np.sort(a)


# ----------------------------------------------------------------------------- standard form
@dataclass(frozen=True, eq=False)
class _StandardForm:
    """Problem (1) in standard form: SVD of ``Ā`` and the map back to ``Δp``.

    ``Δp(α) = TV @ (s β / (s² + α²)) + x0 - offset``.
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
        s = self.s
        coef = s * self.beta / (s * s + alpha * alpha)
        return self.TV @ coef + self.x0 - self.offset

    def norms(self, alphas: np.ndarray):
        """ρ², η², dη²/dα and Σ(1 - f) on a grid of α (vectorised: arrays (n_alpha, q))."""
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

    def gcv_function(self, alphas: np.ndarray):
        rho2, eta2, _, sum_1mf = self.norms(alphas)
        # trace(I - A(α)) = m - (L - k) - Σ f_i = (m - (L - k) - q) + Σ (1 - f_i)
        trace = (self.m - self.n_null - self.s.size) + sum_1mf
        with np.errstate(divide="ignore", invalid="ignore"):
            g = np.where(trace > 0, rho2 / np.where(trace > 0, trace, 1.0) ** 2, np.nan)
        return g, rho2, eta2

    def curvature(self, alphas: np.ndarray):
        rho2, eta2, deta2, _ = self.norms(alphas)
        a = alphas
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            num = a**2 * deta2 * rho2 + 2.0 * a * eta2 * rho2 + a**4 * eta2 * deta2
            den = (a**4 * eta2**2 + rho2**2) ** 1.5
            kappa = -2.0 * (eta2 * rho2 / deta2) * num / den
        ok = (rho2 > 0) & (eta2 > 0) & (deta2 < 0) & np.isfinite(kappa)
        return np.where(ok, kappa, np.nan), rho2, eta2

    def default_alphas(self) -> np.ndarray:
        return np.geomspace(self.s[-1] / 10.0, self.s[0] * 10.0, N_ALPHA)


def _rank_tol(sv: np.ndarray, shape) -> float:
    return max(shape) * np.finfo(float).eps * (sv[0] if sv.size else 0.0)


def _standard_form(J, r, gamma, offset) -> _StandardForm:
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
    return _StandardForm(m=m, n=n, n_null=W.shape[1], s=s, beta=beta, delta0_sq=delta0_sq,
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
    (see the module docstring), never through the normal equations.

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
    J, r, gamma, offset = _check_problem(J, r, gamma, offset)
    alpha = _check_alpha(alpha)
    return _standard_form(J, r, gamma, offset).step(alpha)


def _grid(sf: _StandardForm, alphas) -> np.ndarray:
    if sf.s.size == 0:
        raise InputError("the sensitivity matrix J is zero (J Γ⁻¹ has no nonzero singular value): "
                         "there is no regularisation factor to choose")
    return sf.default_alphas() if alphas is None else _check_alphas(alphas)


def _refine(fun, alphas: np.ndarray, i: int) -> float:
    """Minimise ``fun`` (of one α) over ln α between the grid neighbours of ``alphas[i]``."""
    lo, hi = alphas[max(i - 1, 0)], alphas[min(i + 1, alphas.size - 1)]
    best = alphas[i]
    if hi <= lo:
        return float(best)
    f_best = fun(best)
    res = minimize_scalar(lambda t: fun(np.exp(t)), bounds=(np.log(lo), np.log(hi)), method="bounded",
                          options={"xatol": 1e-6})
    if np.isfinite(res.fun) and res.fun < f_best:
        best = float(np.exp(res.x))
    return float(best)


def gcv(J, r, alphas=None, gamma=None, offset=None, *, refine: bool = True) -> RegularizationChoice:
    r"""Choose α by generalised cross-validation (Golub, Heath & Wahba 1979).

    Minimises

    .. math::

        G(\alpha) = \frac{\|J\,\Delta p_\alpha + r\|^2}{\mathrm{trace}(I - A(\alpha))^2}
                  = \frac{\sum_i (1-f_i)^2\beta_i^2 + \delta_0^2}{\big(m - (L - k) - \sum_i f_i\big)^2},

    with :math:`A(\alpha) = J(J^TJ + \alpha^2\Gamma^T\Gamma)^{-1}J^T` the influence matrix,
    :math:`f_i = s_i^2/(s_i^2+\alpha^2)` the filter factors of the SVD of the standard-form
    matrix :math:`J\Gamma^{-1}` and k the rank of Γ (Hansen, Regularization Tools ``gcv``).  The
    function is evaluated on the whole grid at once and its grid minimum polished by a bounded
    search in ln α between the neighbouring grid points (``refine``).

    Parameters
    ----------
    J, r, gamma, offset
        As in :func:`tikhonov_step`.
    alphas : array_like, optional
        Positive grid of α; default 200 log-spaced values from :math:`s_\min/10` to
        :math:`10\,s_\max` (s the nonzero singular values of :math:`J\Gamma^{-1}`).
    refine : bool, optional
        Polish the grid optimum between its neighbours (default True); False returns a grid value.

    Returns
    -------
    RegularizationChoice
        ``criterion`` holds :math:`G(\alpha)`.  A minimum at an end of the grid is returned as it
        is, with a note in ``method``: at the smallest α, a well-conditioned or consistent problem
        that needs no regularisation; at the largest α, data that GCV finds uninformative (e.g. a
        square J, as many data as parameters, where leaving one datum out leaves the fit
        undetermined) or a user grid that is too narrow.  GCV is known to undersmooth now and
        then when :math:`G` is very flat (Hansen 2010, sec. 5.4); compare with :func:`l_curve`
        when the choice matters.
    """
    J, r, gamma, offset = _check_problem(J, r, gamma, offset)
    sf = _standard_form(J, r, gamma, offset)
    grid = _grid(sf, alphas)
    g, rho2, eta2 = sf.gcv_function(grid)
    method = "gcv"
    valid = np.isfinite(g)
    if not valid.any() or not np.any(g[valid] > 0):
        i = 0
        method = "gcv (zero residual for every alpha; smallest alpha of the grid)"
        alpha = grid[0]
    else:
        i = int(np.nanargmin(g))
        if i == 0:
            method = "gcv (minimum at the smallest alpha of the grid: little or no regularisation needed)"
            alpha = grid[0]
        else:
            if i == grid.size - 1:
                method = ("gcv (minimum at the largest alpha of the grid: the data do not constrain the parameters "
                          "beyond the reference, or the grid is too narrow)")
            alpha = _refine(lambda a: float(sf.gcv_function(np.atleast_1d(a))[0][0]), grid, i) if refine else grid[i]
    if method != "gcv":
        log.info("GCV: %s; alpha = %.3g", method, alpha)
    log.debug("GCV: alpha = %.6g (%s)", alpha, method)
    return RegularizationChoice(alpha=alpha, alphas=grid, residual_norms=np.sqrt(rho2), solution_norms=np.sqrt(eta2),
                                criterion=g, method=method)


def l_curve(J, r, alphas=None, gamma=None, offset=None, *, refine: bool = True) -> RegularizationChoice:
    r"""Choose α at the corner of the L-curve (Hansen 1992; Hansen & O'Leary 1993).

    The L-curve is the parametric curve :math:`(\ln\rho(\alpha), \ln\eta(\alpha))` of the residual
    norm :math:`\rho = \|J\Delta p_\alpha + r\|` and the solution semi-norm
    :math:`\eta = \|\Gamma(p + \Delta p_\alpha - p_\mathrm{ref})\|`.  Its curvature is computed
    analytically from the SVD of :math:`J\Gamma^{-1}` (Hansen's closed form, see the module
    docstring):

    .. math::

        \kappa(\alpha) = -\,\frac{2\,\hat\eta\,\hat\rho}{\hat\eta'}\;
          \frac{\alpha^2\hat\eta'\hat\rho + 2\alpha\hat\eta\hat\rho + \alpha^4\hat\eta\hat\eta'}
               {(\alpha^4\hat\eta^2 + \hat\rho^2)^{3/2}},
        \qquad \hat\eta = \eta^2,\ \hat\rho = \rho^2,\
        \hat\eta' = -4\alpha\sum_i \frac{s_i^2\beta_i^2}{(s_i^2+\alpha^2)^3},

    on the whole grid at once; the grid maximum is polished by a bounded search in ln α between
    its neighbours (``refine``), as Regularization Tools' ``l_corner`` does.

    Degenerate curves never raise.  The smallest α of the grid is returned, and ``method`` says
    why, when

    * the data are consistent: r lies in the range of J (least-squares residual
      :math:`\delta_0^2 \le \epsilon\,\|\bar b\|^2`) although J has more rows than rank, so
      there is no noise to filter (a spurious shallow bend of the curve is not a corner);
    * the curvature is nowhere positive (no corner), or is largest at the smallest α of the grid
      (a well-conditioned J: there is no vertical leg);
    * the solution does not depend on α (:math:`\bar b` orthogonal to the range of :math:`J\Gamma^{-1}`).

    A maximum at the *largest* α of a user grid is returned as it is, with a note that the grid
    may be too narrow.  For a square (or underdetermined) J the residual cannot reveal
    consistency; a weak corner is then taken as found (Hansen's ``l_corner`` rule).

    Parameters
    ----------
    J, r, alphas, gamma, offset, refine
        As in :func:`gcv`.

    Returns
    -------
    RegularizationChoice
        ``criterion`` holds κ(α) (NaN where the curve is undefined, e.g. zero norms).
    """
    J, r, gamma, offset = _check_problem(J, r, gamma, offset)
    sf = _standard_form(J, r, gamma, offset)
    grid = _grid(sf, alphas)
    kappa, rho2, eta2 = sf.curvature(grid)
    valid = np.isfinite(kappa)
    note = None
    consistent = (sf.m - sf.n_null - sf.s.size > 0
                  and sf.delta0_sq <= np.finfo(float).eps * (sf.delta0_sq + float(sf.beta @ sf.beta)))
    if not np.any(sf.beta != 0):
        note = "the regularised solution does not depend on alpha"
    elif consistent:
        note = "no corner: r lies in the range of J (zero least-squares residual), consistent data need no regularisation"
    elif not valid.any():
        note = "no corner: the curve is undefined (zero residual or solution norm)"
    elif not np.nanmax(kappa) > 0:
        note = "no corner: the curvature is nowhere positive"
    else:
        i = int(np.nanargmax(kappa))
        if i == 0:
            note = "no corner: the maximum curvature is at the smallest alpha of the grid"
        elif i == grid.size - 1:
            alpha = grid[i]
            method = "lcurve (maximum curvature at the largest alpha of the grid: consider a wider grid)"
        else:
            method = "lcurve"
            alpha = _refine(lambda a: -float(np.nan_to_num(sf.curvature(np.atleast_1d(a))[0][0], nan=np.inf)),
                            grid, i) if refine else grid[i]
    if note is not None:
        alpha = grid[0]
        method = f"lcurve ({note}; smallest alpha of the grid)"
        log.info("L-curve: %s; using the smallest alpha of the grid, %.3g", note, alpha)
    log.debug("L-curve: alpha = %.6g (%s)", alpha, method)
    return RegularizationChoice(alpha=alpha, alphas=grid, residual_norms=np.sqrt(rho2), solution_norms=np.sqrt(eta2),
                                criterion=kappa, method=method)


_RULES = {"gcv": gcv, "lcurve": l_curve, "l-curve": l_curve, "l_curve": l_curve}


def choose_alpha(J, r, rule="gcv", alphas=None, gamma=None, offset=None, *, refine: bool = True) -> RegularizationChoice:
    """Choose the Tikhonov factor α by a named rule, or take a given one.

    Parameters
    ----------
    J, r, alphas, gamma, offset, refine
        As in :func:`gcv`.
    rule : {"gcv", "lcurve"} or float
        ``"gcv"`` → :func:`gcv`; ``"lcurve"`` (also ``"l-curve"``, ``"l_curve"``) →
        :func:`l_curve`; a number α >= 0 is taken as it is (``method`` "fixed", the norms at that
        α, ``criterion`` NaN).

    Returns
    -------
    RegularizationChoice

    Raises
    ------
    InputError
        An unknown rule (named in the message), a negative α, or bad J, r, gamma, offset.
    """
    if isinstance(rule, str):
        fn = _RULES.get(rule.strip().lower())
        if fn is None:
            raise InputError(f"unknown regularisation rule {rule!r}: use 'gcv', 'lcurve' or a number alpha >= 0")
        return fn(J, r, alphas=alphas, gamma=gamma, offset=offset, refine=refine)
    if isinstance(rule, (bool, np.bool_)) or not isinstance(rule, numbers.Real):
        raise InputError(f"unknown regularisation rule {rule!r}: use 'gcv', 'lcurve' or a number alpha >= 0")
    alpha = _check_alpha(rule)
    J, r, gamma, offset = _check_problem(J, r, gamma, offset)
    sf = _standard_form(J, r, gamma, offset)
    rho2, eta2, *_ = sf.norms(np.array([alpha]))
    return RegularizationChoice(alpha=alpha, alphas=np.array([alpha]), residual_norms=np.sqrt(rho2),
                                solution_norms=np.sqrt(eta2), criterion=np.array([np.nan]), method="fixed")
