r"""Solvers of the damage equations: L1 (sparse) with a BIC-chosen path and debiasing, Tikhonov.

:math:`\min_\delta \tfrac12\|A\delta - r\|^2 + \alpha\|\delta\|_1` within bounds, by SciPy's
L-BFGS-B on the split variables; α on a path from :math:`\alpha_{max} = \|A^T r\|_\infty`
chosen by the Bayesian information criterion of the refitted (debiased) support.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import lsq_linear, minimize

N_PATH = 20


def l1_solve(A, r, alpha: float, lower: float = -1.0, upper: float = 0.0, x0=None, tol: float = 1e-14) -> np.ndarray:
    r"""Bounded L1-regularised least squares.

    :math:`\min_\delta \tfrac12\|A\delta - r\|^2 + \alpha\|\delta\|_1`, ``lower <= δ <= upper``,
    solved with L-BFGS-B (:func:`scipy.optimize.minimize`) on ``δ = v - u``, ``u, v >= 0``, where the
    objective is smooth: :math:`\tfrac12\|A(v-u) - r\|^2 + \alpha\,1^T(u + v)`.  When
    ``upper <= 0`` only ``u`` is a variable (δ <= 0).  The objective is scaled by ``r^T r``.

    Parameters
    ----------
    A : ndarray or sparse matrix, shape ``(n_equations, n_unknowns)``
        Coefficient matrix, dense or sparse.
    r : ndarray, shape ``(n_equations,)``
        Right-hand side.
    alpha : float
        L1 penalty factor (absolute, same units as ``A^T r``).
    lower : float, default -1.0
        Lower bound of every δ.
    upper : float, default 0.0
        Upper bound of every δ.
    x0 : ndarray, shape ``(n_unknowns,)``, optional
        Starting point, clipped to the bounds (default zeros).
    tol : float, default 1e-14
        ``ftol`` of L-BFGS-B.

    Returns
    -------
    ndarray, shape ``(n_unknowns,)``
        The solution δ.
    """
    L = A.shape[1]
    both = upper > 0
    scale = max(float(r @ r), 1e-300)

    def split(z):
        return z[:L], (z[L:] if both else np.zeros(L))

    def f(z):
        u, v = split(z)
        res = A @ (v - u) - r
        g = A.T @ res
        obj = 0.5 * float(res @ res) + alpha * float(np.sum(u) + np.sum(v))
        grad = np.concatenate([-g + alpha] + ([g + alpha] if both else []))
        return obj / scale, grad / scale

    x0 = np.clip(np.zeros(L) if x0 is None else x0, lower, upper)
    z0 = np.concatenate([np.maximum(-x0, 0)] + ([np.maximum(x0, 0)] if both else []))
    bnds = [(0.0, -lower)] * L + ([(0.0, upper)] * L if both else [])
    sol = minimize(f, z0, jac=True, method="L-BFGS-B", bounds=bnds,
                   options={"maxiter": 20000, "maxfun": 40000, "ftol": tol, "gtol": 1e-14})
    u, v = split(sol.x)
    return v - u


def debias(A, r, support: np.ndarray, lower: float, upper: float) -> np.ndarray:
    """Bounded least squares on the located elements only (removes the L1 shrinkage).

    Parameters
    ----------
    A : ndarray or sparse matrix, shape ``(n_equations, n_unknowns)``
        Coefficient matrix.
    r : ndarray, shape ``(n_equations,)``
        Right-hand side.
    support : ndarray of int, shape ``(n_located,)``
        Columns of ``A`` (located elements) that may be non-zero.
    lower, upper : float
        Bounds of every δ (``upper <= lower`` is widened to ``lower + 1e-12``).

    Returns
    -------
    ndarray, shape ``(n_unknowns,)``
        δ: the bounded least-squares fit (:func:`scipy.optimize.lsq_linear`, BVLS) on ``support``,
        zero elsewhere.
    """
    x = np.zeros(A.shape[1])
    if support.size:
        res = lsq_linear(A[:, support], r, bounds=(lower, upper if upper > lower else lower + 1e-12), method="bvls")
        x[support] = res.x
    return x


def support_of(x: np.ndarray, threshold: float) -> np.ndarray:
    """Indices of the entries of ``x`` whose magnitude is at least ``threshold``.

    Parameters
    ----------
    x : ndarray, shape ``(n,)``
        Values (element changes δ).
    threshold : float
        Smallest magnitude counted.

    Returns
    -------
    ndarray of int
        The positions ``i`` with ``|x[i]| >= threshold``.
    """
    return np.flatnonzero(np.abs(x) >= threshold)


@dataclass(frozen=True, eq=False)
class L1Fit:
    """An L1 solution chosen on the path by :func:`l1_path`.

    Each parameter is stored as the attribute of the same name.

    Parameters
    ----------
    l1 : ndarray, shape ``(n_unknowns,)``
        The L1 solution at the chosen α.
    debiased : ndarray, shape ``(n_unknowns,)``
        Its debiased refit on the located support (:func:`debias`).
    alpha : float
        The chosen α (absolute).
    alpha_max : float
        α_max, the factor above which δ = 0.
    path : list of dict
        One entry per α tried: ``alpha``, ``alpha_fraction``, ``n_located``, ``rss``, ``bic``.
    order : ndarray of int, optional
        Every unknown, in the order it enters the path (first non-zero as α decreases), the
        others after them by decreasing :math:`|A^T r|` (the correlation that brings them in).
    """
    l1: np.ndarray
    debiased: np.ndarray
    alpha: float
    alpha_max: float
    path: list
    order: np.ndarray | None = None


def l1_path(A, r, lower, upper, threshold, alpha=None) -> L1Fit:
    r"""L1 solutions from α_max down, α chosen by the Bayesian information criterion.

    The criterion is that of the debiased support, :math:`\|A\delta_S - r\|^2 + |S|\ln n` (rows
    whitened: unit noise variance), on a geometric path of ``N_PATH`` fractions of α_max from 1 to
    1e-3, stopped once it has risen by more than ``ln n`` above its best three times running; or
    ``alpha`` (a fraction of α_max) alone.  α_max is :math:`\|A^T r\|_\infty` (with ``upper <= 0``,
    the largest entry of :math:`\max(-A^T r, 0)`).

    Parameters
    ----------
    A : ndarray or sparse matrix, shape ``(n, n_unknowns)``
        Coefficient matrix (whitened rows).
    r : ndarray, shape ``(n,)``
        Right-hand side.
    lower, upper : float
        Bounds of every δ.
    threshold : float
        Smallest ``|δ|`` counted as located (:func:`support_of`).
    alpha : float, optional
        α as a fraction of α_max (default: chosen on the path).

    Returns
    -------
    L1Fit
        All zeros with ``alpha = alpha_max = 0`` when α_max <= 0.
    """
    c = A.T @ r
    g = np.abs(c) if upper > 0 else np.maximum(-c, 0.0)
    amax = float(np.max(g)) if g.size else 0.0
    by_correlation = np.argsort(-g, kind="stable")
    if amax <= 0:
        z = np.zeros(A.shape[1])
        return L1Fit(z, z, 0.0, 0.0, [], by_correlation)
    fracs = np.geomspace(1.0, 1e-3, N_PATH) if alpha is None else np.array([float(alpha)])
    n = A.shape[0]
    x, path, worse = None, [], 0
    entered: list[int] = []
    best: tuple[float, float, np.ndarray, np.ndarray] | None = None
    for fr in fracs:
        if worse >= 3:  # the criterion has risen clearly three times running: the rest of the path only adds elements
            break
        x = l1_solve(A, r, fr * amax, lower, upper, x0=x)
        new = np.flatnonzero(np.abs(x) > 1e-9)
        seen = set(entered)
        entered += [int(i) for i in new[np.argsort(-np.abs(x[new]), kind="stable")] if int(i) not in seen]
        S = support_of(x, threshold)
        xd = debias(A, r, S, lower, upper)
        res = A @ xd - r
        rss = float(res @ res)
        bic = rss + S.size * math.log(n)
        path.append({"alpha": fr * amax, "alpha_fraction": float(fr), "n_located": int(S.size), "rss": rss, "bic": bic})
        if best is None or bic < best[0] - 1e-9:
            best = (bic, fr, x.copy(), xd)
        worse = worse + 1 if bic > best[0] + math.log(n) else 0
    if best is None:  # set on the first step of the path
        raise RuntimeError("internal error: an empty regularisation path")
    _, fr, x, xd = best
    seen = set(entered)
    order = np.array(entered + [int(i) for i in by_correlation if int(i) not in seen], dtype=np.intp)
    return L1Fit(x, xd, float(fr * amax), amax, path, order)


def tikhonov(A, r, rule="gcv") -> tuple[np.ndarray, float]:
    """Tikhonov solution of A δ = r, for comparison with L1.

    Parameters
    ----------
    A : ndarray, shape ``(n_equations, n_unknowns)``
        Coefficient matrix.
    r : ndarray, shape ``(n_equations,)``
        Right-hand side.
    rule : {"gcv", "lcurve"} or float, default ``"gcv"``
        How the factor is chosen, as :func:`femupdate.regularization.choose_alpha` (a number: that α).

    Returns
    -------
    delta : ndarray, shape ``(n_unknowns,)``
        The Tikhonov solution.
    alpha : float
        The factor used.

    Raises
    ------
    InputError
        As :func:`femupdate.regularization.choose_alpha` (an unknown rule, a negative α).
    """
    from ..regularization import choose_alpha, tikhonov_step

    choice = choose_alpha(A, -r, rule=rule)
    return tikhonov_step(A, -r, choice.alpha), float(choice.alpha)
