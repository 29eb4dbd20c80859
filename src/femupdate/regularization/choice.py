r"""The choice of the Tikhonov factor α: generalised cross-validation (:func:`gcv`), the corner of
the L-curve (:func:`l_curve`), or a given value (:func:`choose_alpha`); formulas in the package notes."""

from __future__ import annotations

import logging
import numbers
from dataclasses import dataclass

import numpy as np
from scipy.optimize import minimize_scalar

from .._errors import InputError
from .tikhonov import StandardForm, check_alpha, check_alphas, check_problem, standard_form

log = logging.getLogger("femupdate.regularization")  # the package's logger, as before the split into modules

__all__ = ["RegularizationChoice", "gcv", "l_curve", "choose_alpha"]


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

def _grid(sf: StandardForm, alphas) -> np.ndarray:
    if sf.s.size == 0:
        raise InputError("the sensitivity matrix J is zero (J Γ⁻¹ has no nonzero singular value): "
                         "there is no regularisation factor to choose")
    return sf.default_alphas() if alphas is None else check_alphas(alphas)


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
    J, r, gamma, offset = check_problem(J, r, gamma, offset)
    sf = standard_form(J, r, gamma, offset)
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
    analytically from the SVD of :math:`J\Gamma^{-1}` (Hansen's closed form, see the package
    notes):

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
    J, r, gamma, offset = check_problem(J, r, gamma, offset)
    sf = standard_form(J, r, gamma, offset)
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
    alpha = check_alpha(rule)
    J, r, gamma, offset = check_problem(J, r, gamma, offset)
    sf = standard_form(J, r, gamma, offset)
    rho2, eta2, *_ = sf.norms(np.array([alpha]))
    return RegularizationChoice(alpha=alpha, alphas=np.array([alpha]), residual_norms=np.sqrt(rho2),
                                solution_norms=np.sqrt(eta2), criterion=np.array([np.nan]), method="fixed")
