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
    r"""Bounded L1-regularised least squares:
    :math:`\min_\delta \tfrac12\|A\delta - r\|^2 + \alpha\|\delta\|_1`, ``lower <= δ <= upper``.

    Solved with L-BFGS-B (:func:`scipy.optimize.minimize`) on ``δ = v - u``, ``u, v >= 0``, where the
    objective is smooth: :math:`\tfrac12\|A(v-u) - r\|^2 + \alpha\,1^T(u + v)`.  ``A`` dense or sparse.
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
    """Bounded least squares on the located elements only (removes the L1 shrinkage)."""
    x = np.zeros(A.shape[1])
    if support.size:
        res = lsq_linear(A[:, support], r, bounds=(lower, upper if upper > lower else lower + 1e-12), method="bvls")
        x[support] = res.x
    return x


def support_of(x: np.ndarray, threshold: float) -> np.ndarray:
    return np.flatnonzero(np.abs(x) >= threshold)


@dataclass(frozen=True, eq=False)
class L1Fit:
    l1: np.ndarray
    debiased: np.ndarray
    alpha: float
    alpha_max: float
    path: list


def l1_path(A, r, lower, upper, threshold, alpha=None) -> L1Fit:
    r"""L1 solutions from α_max down; α chosen by the Bayesian information criterion of the
    debiased support, :math:`\|A\delta_S - r\|^2 + |S|\ln n` (rows whitened: unit noise variance),
    or ``alpha`` (a fraction of α_max)."""
    c = A.T @ r
    g = np.abs(c) if upper > 0 else np.maximum(-c, 0.0)
    amax = float(np.max(g)) if g.size else 0.0
    if amax <= 0:
        z = np.zeros(A.shape[1])
        return L1Fit(z, z, 0.0, 0.0, [])
    fracs = np.geomspace(1.0, 1e-3, N_PATH) if alpha is None else np.array([float(alpha)])
    n = A.shape[0]
    x, path, worse = None, [], 0
    best: tuple[float, float, np.ndarray, np.ndarray] | None = None
    for fr in fracs:
        if worse >= 3:  # the criterion has risen clearly three times running: the rest of the path only adds elements
            break
        x = l1_solve(A, r, fr * amax, lower, upper, x0=x)
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
        raise TypeError("cannot unpack non-iterable NoneType object")
    _, fr, x, xd = best
    return L1Fit(x, xd, float(fr * amax), amax, path)


def tikhonov(A, r, rule="gcv") -> tuple[np.ndarray, float]:
    """Tikhonov solution of A δ = r, the factor by GCV (or given), for comparison with L1."""
    from ..regularization import choose_alpha, tikhonov_step

    choice = choose_alpha(A, -r, rule=rule)
    return tikhonov_step(A, -r, choice.alpha), float(choice.alpha)
