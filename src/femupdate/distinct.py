"""Distinct points: solutions that do not differ significantly against their own covariances are
one (:func:`significant`); points with no covariance — the residual surfaces' local minima — are
one when they agree within a relative tolerance (:func:`cluster`).

Used by every driver that counts solutions — multi-start updating, global search, uniqueness
studies — and by the residual surfaces' local minima; NumPy (and SciPy's χ² quantile).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


def cluster(points: np.ndarray, costs: np.ndarray, rel_tol: float = 1e-4, scale=None) -> list[list[int]]:
    """Group solutions whose parameters agree within ``rel_tol`` (relative, per parameter).

    Greedy in order of increasing cost: each point joins the first cluster (in order of creation)
    whose representative — its lowest-cost member — it is within ``rel_tol`` of, else founds a
    new one.  One NumPy pass per cluster: the lowest-cost unclaimed point founds the next
    cluster and claims every unclaimed point near it.  Members are listed in increasing cost.

    Parameters
    ----------
    points : array_like, shape ``(n_points, L)``
        The solutions' parameter values.
    costs : array_like, shape ``(n_points,)``
        Their costs (the order in which they are taken).
    rel_tol : float, default 1e-4
        Point q is near representative p when ``|q_j − p_j|`` <= rel_tol max(``|p_j|``, scale_j) for every
        j.
    scale : array_like, shape ``(L,)``, optional
        A typical magnitude of each parameter: below it the distance is absolute
        (rel_tol · scale_j), so that parameters near zero — relative changes, offsets — do not
        split one minimum into many.  Default none (purely relative: a zero entry of p needs an
        exact match).

    Returns
    -------
    list of list of int
        Indices into ``points``, one list per cluster in order of creation (the first is that of
        the lowest cost), each led by its representative; empty for no points.
    """
    order = np.argsort(costs)
    P = np.asarray(points, float)[order]
    floor = np.maximum(np.abs(np.asarray(scale, float)), 1e-300) if scale is not None else 1e-300
    free = np.ones(len(order), bool)
    groups: list[list[int]] = []
    while free.any():
        i = int(np.argmax(free))
        size = np.maximum(np.abs(P[i]), floor)
        near = free & np.all(np.abs(P - P[i]) <= rel_tol * size, axis=1)
        near[i] = True
        groups.append([int(order[j]) for j in np.flatnonzero(near)])
        free &= ~near
    return groups


#: the significance level at which two solutions are told apart by default (:func:`significant`)
ALPHA = 0.01


@dataclass(frozen=True)
class Separation:
    """Why a solution is distinct from the first (lowest-cost) one (:func:`significant`).

    Attributes
    ----------
    basis : str
        ``"statistic"``: the Mahalanobis distance against the two solutions' summed covariance
        exceeds the χ² quantile; ``"non-identifiable"``: they differ beyond ``rel_tol`` in a
        parameter or direction without a covariance — one the data do not determine (a null
        direction of the sensitivity, a parameter on a bound): solutions along it that fit equally
        well *are* the non-uniqueness; ``"tolerance"``: no covariance at all, told apart by the
        relative tolerance alone (the old rule).
    statistic : float
        d² = Δpᵀ (C_a + C_b)⁺ Δp over the directions with a covariance (NaN without one).
    dof : int
        The number of those directions (the χ² degrees of freedom).
    threshold : float
        The χ² quantile at 1 − α for ``dof`` (NaN without a covariance).
    """

    basis: str
    statistic: float = math.nan
    dof: int = 0
    threshold: float = math.nan

    def to_dict(self) -> dict:
        """``{basis, statistic, dof, threshold}`` (NaN as None)."""
        fin = (lambda v: float(v) if math.isfinite(v) else None)
        return {"basis": self.basis, "statistic": fin(self.statistic), "dof": int(self.dof),
                "threshold": fin(self.threshold)}


def compare(pa, pb, Ca, Cb, alpha: float = ALPHA, rel_tol: float = 1e-4, scale=None) -> Separation | None:
    """Whether two solutions are distinct: None when they are the same, else why they are not.

    Two solutions are the same when every parameter agrees within ``rel_tol`` (relative, with the
    floor ``scale`` as :func:`cluster`: round-off of the solver, never a difference the data
    make), or when they do not differ significantly against their own covariances:
    d² = Δpᵀ (C_a + C_b)⁺ Δp ≤ χ²_k(1 − α), with k the rank of C_a + C_b (the pseudo-inverse over
    the directions it has), *and* the part of Δp outside those directions — parameters with no
    covariance (NaN rows: a parameter on a bound, one the data do not see, a rank-deficient
    solution) — agrees within ``rel_tol``.

    Parameters
    ----------
    pa, pb : array_like, shape ``(L,)``
        The two solutions (physical units).
    Ca, Cb : array_like, shape ``(L, L)``, or None
        Their covariances (NaN where not estimable); None: none (the tolerance alone decides).
    alpha : float, default :data:`ALPHA`
        The significance level: one minimum found twice is split with probability about α.
    rel_tol : float, default 1e-4
        The round-off floor, and the rule where no covariance exists.
    scale : array_like, shape ``(L,)``, optional
        Typical magnitudes (:func:`cluster`).

    Returns
    -------
    Separation or None
    """
    from scipy.stats import chi2

    pa, pb = np.asarray(pa, float), np.asarray(pb, float)
    dp = pb - pa
    floor = np.maximum(np.abs(np.asarray(scale, float)), 1e-300) if scale is not None else 1e-300
    size = np.maximum(np.abs(pa), floor)
    beyond = np.abs(dp) > rel_tol * size
    if not beyond.any():
        return None
    if Ca is None or Cb is None:
        return Separation("tolerance")
    C = np.asarray(Ca, float) + np.asarray(Cb, float)
    idx = np.flatnonzero(np.isfinite(np.diag(C)))
    k = idx[np.all(np.isfinite(C[np.ix_(idx, idx)]), axis=0)] if idx.size else idx
    have = np.zeros(dp.size, bool)
    have[k] = True
    if k.size == 0:
        return Separation("tolerance")
    if np.any(beyond[~have]):
        return Separation("non-identifiable")
    Cn = C[np.ix_(k, k)] / np.outer(size[k], size[k])  # relative units: comparable eigenvalues
    dn = dp[k] / size[k]
    w, U = np.linalg.eigh(0.5 * (Cn + Cn.T))
    # eigh's error is about eps max(w); a covariance's eigenvalues span cond(S)² (up to 1e12 below the
    # rank tolerance of the diagnostics), so the directions kept are those above 1e-14 max(w)
    keep = w > 1e-14 * max(float(w.max()), 1e-300)
    proj = U[:, keep].T @ dn
    d2 = float(np.sum(proj ** 2 / w[keep]))
    dof = int(keep.sum())
    rest = dn - U[:, keep] @ proj  # outside the covariance's range (a null direction): compared by tolerance
    limit = float(chi2.ppf(1.0 - alpha, dof)) if dof else math.nan
    if np.any(np.abs(rest) > rel_tol):
        return Separation("non-identifiable", d2, dof, limit)
    if dof and d2 > limit:
        return Separation("statistic", d2, dof, limit)
    return None


@dataclass(frozen=True)
class Grouping:
    """Solutions grouped by :func:`significant`.

    Attributes
    ----------
    groups : list of list of int
        As :func:`cluster` returns them: indices, one list per group in order of creation (the
        first is that of the lowest cost), each led by its representative (lowest cost).
    separations : list of Separation or None
        Per group, why its representative is distinct from the first group's (None for the
        first).
    alpha : float
        The significance level.
    basis : str
        ``"statistic"`` when every point had a covariance, ``"tolerance"`` when none had,
        ``"mixed"`` otherwise.
    """

    groups: list[list[int]]
    separations: list[Separation | None]
    alpha: float
    basis: str


def significant(points, costs, covariances=None, alpha: float = ALPHA, rel_tol: float = 1e-4,
                scale=None) -> Grouping:
    """Group solutions that do not differ significantly against their own covariances.

    Greedy in order of increasing cost, as :func:`cluster`: the lowest-cost unclaimed point
    founds a group and claims every unclaimed point that :func:`compare` finds the same as it.
    With no covariance for a point the rule is :func:`cluster`'s tolerance (said in ``basis``).

    Parameters
    ----------
    points : array_like, shape ``(n_points, L)``
    costs : array_like, shape ``(n_points,)``
    covariances : sequence of (array_like ``(L, L)`` or None), optional
        Each point's covariance (physical units; NaN where not estimable); default none.
    alpha : float, default :data:`ALPHA`
    rel_tol : float, default 1e-4
    scale : array_like, shape ``(L,)``, optional

    Returns
    -------
    Grouping
    """
    P = np.asarray(points, float)
    n = len(P)
    covs = list(covariances) if covariances is not None else [None] * n
    order = [int(i) for i in np.argsort(costs)]
    free = dict.fromkeys(order)
    groups: list[list[int]] = []
    while free:
        i = next(iter(free))
        g = [j for j in free if j == i or compare(P[i], P[j], covs[i], covs[j], alpha, rel_tol, scale) is None]
        for j in g:
            del free[j]
        groups.append(g)
    first = groups[0][0] if groups else 0
    seps: list[Separation | None] = [None] + [compare(P[first], P[g[0]], covs[first], covs[g[0]], alpha, rel_tol, scale) or Separation("tolerance")
                     for g in groups[1:]]
    have = [c is not None and np.isfinite(np.diag(np.asarray(c, float))).any() for c in covs]
    basis = "statistic" if all(have) else "tolerance" if not any(have) else "mixed"
    return Grouping(groups, seps, float(alpha), basis)


#: a condition number (of the normalised sensitivity matrix) from which a solution is reported as
#: ill-conditioned: some combination of its parameters is known far less well than the best one
ILL_CONDITIONED = 100.0


def conditioning(names, values, covariance, condition_number: float, basis: str = "") -> dict:
    """How well one solution is determined: the ill-conditioning statement of a multi-start study
    or uniqueness case — apart from non-uniqueness, which is several separated solutions.

    Parameters
    ----------
    names : sequence of str
    values : array_like, shape ``(L,)``
        The solution (physical units).
    covariance : array_like, shape ``(L, L)``
        Its covariance (physical units; NaN where not estimable).
    condition_number : float
        Of the normalised sensitivity matrix at the solution.
    basis : str, optional
        What the covariance rests on (stated noise, residual variance, ...), repeated in the record.

    Returns
    -------
    dict
        ``condition_number``, ``ill_conditioned`` (at least :data:`ILL_CONDITIONED`, or infinite),
        ``relative_std`` {name: std / ``|value|``} (None where not estimable), ``weakest``
        {``direction`` {name: component} (unit vector in relative units, largest component
        positive), ``relative_std``} — the combination the data determine least, the eigenvector
        of the relative covariance with the largest eigenvalue (None without a covariance) — and
        ``basis``.
    """
    x = np.asarray(values, float)
    size = np.where(x != 0, np.abs(x), 1.0)
    C = np.asarray(covariance, float) / np.outer(size, size)
    d = np.diag(C)
    rel = {n: (float(math.sqrt(max(v, 0.0))) if math.isfinite(v) else None) for n, v in zip(names, d)}
    weakest = None
    if C.size and np.all(np.isfinite(C)):
        w, U = np.linalg.eigh(0.5 * (C + C.T))
        u = U[:, -1] * (1.0 if U[np.argmax(np.abs(U[:, -1])), -1] >= 0 else -1.0)
        weakest = {"direction": {n: float(c) for n, c in zip(names, u)}, "relative_std": float(math.sqrt(max(w[-1], 0.0)))}
    cond = float(condition_number)
    return {"condition_number": cond if math.isfinite(cond) else None,
            "ill_conditioned": bool(not math.isfinite(cond) or cond >= ILL_CONDITIONED),
            "relative_std": rel, "weakest": weakest, "basis": basis}


def conditioning_line(stmt: dict) -> str:
    """One line of a :func:`conditioning` record: ``"ill-conditioned (condition number 2.4e+03),
    unique: k1 known to ±0.12 %, k2 to ±3.4 %; weakest direction 0.71 k1 − 0.70 k2 (±3.5 %)"``."""
    cond = stmt.get("condition_number")
    head = ("ill-conditioned" if stmt.get("ill_conditioned") else "well-conditioned") + \
        f" (condition number {cond:.3g})" if cond is not None else "rank-deficient (condition number infinite)"
    known = [(n, v) for n, v in (stmt.get("relative_std") or {}).items() if v is not None]
    parts = [f"{n} known to ±{v * 100:.3g} %" if i == 0 else f"{n} to ±{v * 100:.3g} %" for i, (n, v) in enumerate(known)]
    line = head + (": " + ", ".join(parts) if parts else
                   ": no standard deviation (not estimable: too few data for the residual variance; state the "
                   "measurement noise)")
    wk = stmt.get("weakest")
    if wk and len(wk["direction"]) > 1:
        big = [(n, c) for n, c in wk["direction"].items() if abs(c) >= 0.05]
        terms = " ".join((f"{c:.2f} {n}" if i == 0 else f"{'-' if c < 0 else '+'} {abs(c):.2f} {n}")
                         for i, (n, c) in enumerate(big))
        line += f"; weakest direction {terms} (±{wk['relative_std'] * 100:.3g} %)"
    if stmt.get("basis") and parts:
        line += f" [{stmt['basis']}]"
    return line


__all__ = ["cluster", "compare", "significant", "conditioning", "conditioning_line", "Grouping", "Separation", "ALPHA",
           "ILL_CONDITIONED"]
