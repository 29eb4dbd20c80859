"""Distinct solutions of a multi-start study: converged runs grouped when they do not differ
significantly against their own covariances (:func:`femupdate.distinct.significant`; by the
relative tolerance where no covariance exists), and told apart: those that fit the data as well as
the best one (:func:`fit_threshold`), and local minima (:func:`classify`); the best solution's
conditioning stated apart from non-uniqueness (:func:`classify`)."""

from __future__ import annotations

from typing import TypeVar

from collections.abc import Sequence

import numpy as np

import dataclasses
import math

from ..distinct import ALPHA, cluster, conditioning, significant
from .results import MultiStartResult, Solution

_Result = TypeVar("_Result", bound=MultiStartResult)


def parameter_scale(model, names: Sequence[str]) -> np.ndarray:
    """A typical magnitude of each of the parameters ``names`` (L,): ``|nominal value|``, or, for a
    nominal value of zero, the width of the finite bounds (else 1) — below it, solutions are
    compared by absolute distance (:func:`femupdate.distinct.cluster`).

    Parameters
    ----------
    model : Model
    names : sequence of str

    Returns
    -------
    numpy.ndarray, shape ``(L,)``
    """
    idx = [model.parameter_index(n) for n in names]
    nominal = np.abs(np.asarray(model.resolve(None), float)[idx])
    lo, hi = (np.asarray(b, float)[idx] for b in model.bounds)
    width = np.where(np.isfinite(lo) & np.isfinite(hi), hi - lo, 1.0)
    return np.where(nominal > 0, nominal, np.where(width > 0, width, 1.0))


def run_covariance(run):
    """The covariance a run carries (``run.diagnostics.covariance``, physical units) and whether it
    is absolute (from stated standard deviations; else scaled by the run's residual variance), or
    None."""
    d = getattr(run, "diagnostics", None)
    cov = getattr(d, "covariance", None)
    return None if cov is None or np.size(cov) == 0 else (np.asarray(cov, float), bool(d.absolute))


def common_noise(covs, costs, floor: float = 0.0) -> list:
    """The runs' covariances on one noise level: one data set has one noise variance, estimated at
    the best fit (the lowest cost, at least ``floor``: the round-off floor of
    :func:`fit_threshold`, so that exact solutions of noise-free data are compared at round-off,
    not at zero); a covariance scaled by a run's own residual variance — larger at a local minimum,
    where the excess is misfit, not noise — is rescaled by that cost / cost_run.  Absolute
    covariances (stated noise) are kept."""
    best = max(float(np.min(costs)), float(floor)) if len(costs) else 0.0
    out: list = []
    for c, cost in zip(covs, costs):
        if c is None:
            out.append(None)
        elif c[1] or not cost > 0:
            out.append(c[0])
        else:
            out.append(c[0] * (best / float(cost)))
    return out


def converged_solutions(runs: Sequence, names: Sequence[str], kind: type, cost_tol: float | None,
                        rel_tol: float, scale=None, alpha: float = ALPHA,
                        covariance=run_covariance) -> tuple[list[int], list[Solution]]:
    """Indices of the runs of type ``kind`` that converged (and, with ``cost_tol``, fit), and their
    distinct solutions from :func:`~femupdate.distinct.significant`, most frequent first (ties:
    lowest cost first).

    Parameters
    ----------
    runs : sequence
        The runs' results; entries of another type (error messages) are left out.
    names : sequence of str
        The updated parameters, in the order of each run's ``x``.
    kind : type
        The result type counted (e.g. :class:`~femupdate.updating.UpdateResult`); a run must
        have ``success``, ``cost`` and ``x``.
    cost_tol : float or None
        Largest ``cost`` (½‖r‖²) of a counted run; None: any.
    rel_tol : float
        Relative tolerance of the clustering, per parameter.
    scale : array_like, shape ``(L,)``, optional
        Typical magnitudes of the parameters (:func:`parameter_scale`): below them the distance
        is absolute.
    alpha : float, default 0.01
        The significance level at which two runs are distinct solutions.
    covariance : callable ``run -> ((L, L) array, absolute) or None``, optional
        Each counted run's covariance and whether it is absolute (default :func:`run_covariance`;
        on one noise level, :func:`common_noise`); None: the tolerance.

    Returns
    -------
    ok : list of int
        Indices into ``runs`` of the counted runs, in run order.
    solutions : list of Solution
        One per group, represented by its lowest-cost run, with its ``separation`` from the
        lowest-cost group and the ``basis`` of the grouping; empty when no run counts.
    """
    ok = [k for k, r in enumerate(runs) if isinstance(r, kind) and getattr(r, "success")
          and (cost_tol is None or getattr(r, "cost") <= cost_tol)]
    solutions = []
    if ok:
        pts = np.array([runs[k].x for k in ok])
        costs = np.array([runs[k].cost for k in ok])
        covs = (common_noise([covariance(runs[k]) for k in ok], costs, round_off(runs[ok[int(np.argmin(costs))]]))
                if covariance is not None else None)
        grouping = significant(pts, costs, covs, alpha, rel_tol, scale)
        for g, sep in zip(grouping.groups, grouping.separations):
            rep = runs[ok[g[0]]]
            solutions.append(Solution(dict(zip(names, map(float, rep.x))), rep.cost, len(g), [ok[i] for i in g],
                                      separation=sep, basis=grouping.basis))
        solutions.sort(key=lambda s: (-s.count, s.cost))
    return ok, solutions


def round_off(best) -> float:
    """The round-off floor of a cost: 1e-14 times the larger of ``best``'s starting cost and its cost."""
    c0 = float(best.history[0]["cost"]) if best.history else float(best.cost)
    return 1e-14 * max(c0, float(best.cost))


def fit_threshold(best) -> float:
    r"""The largest cost of a solution that fits the data as well as ``best`` does.

    A likelihood-ratio test at 95 %: a solution whose cost exceeds the best one's by Δ fits as
    well when :math:`2\Delta \le \chi^2_{0.95}(L)\,\hat\sigma^2`, with
    :math:`\hat\sigma^2 = 1` when the residuals are divided by stated standard deviations, else
    the residual variance of the best fit :math:`2\,c_{best}/(m - L)` (0 when m ≤ L). A floor of
    1e-14 times the best run's starting cost stands for round-off: exact solutions of noise-free
    data all fit, whatever their round-off costs.

    Parameters
    ----------
    best : UpdateResult
        The lowest-cost converged run (``fun``, ``names``, ``cost``, ``history``, ``diagnostics``).

    Returns
    -------
    float
        The threshold on ½‖r‖².
    """
    from scipy.stats import chi2

    m, L = int(best.fun.size), len(best.names)
    d = best.diagnostics
    var = 1.0 if d is not None and d.absolute else (2.0 * best.cost / (m - L) if m > L else 0.0)
    return float(best.cost + 0.5 * chi2.ppf(0.95, L) * var + round_off(best))


def classify(ms: _Result, alpha: float = ALPHA) -> _Result:
    """``ms`` with each solution marked as fitting the data (:func:`fit_threshold` of the best run)
    or not, and ordered: the fitting ones first (most frequent first, then lowest cost), then the
    local minima (lowest cost first).

    Parameters
    ----------
    ms : MultiStartResult
    alpha : float, default 0.01
        The significance level the solutions were told apart at (recorded).

    Returns
    -------
    MultiStartResult
        A copy with ``solutions`` marked and reordered, ``fit_cost`` and ``distinct``
        (:func:`distinct_record`) set.
    """
    if ms.best is None or not ms.solutions:
        return ms
    limit = fit_threshold(ms.best)
    marked = [dataclasses.replace(s, fits=bool(s.cost <= limit)) for s in ms.solutions]
    marked.sort(key=lambda s: (not s.fits, -s.count if s.fits else 0, s.cost))
    return dataclasses.replace(ms, solutions=marked, fit_cost=limit if math.isfinite(limit) else math.nan,
                               distinct=distinct_record(ms.best, marked, alpha))


def covariance_basis(d) -> str:
    """What a result's covariance rests on, in words (its ``diagnostics``)."""
    if d is None:
        return "no covariance"
    said = getattr(d, "basis", None)  # a result that states it itself
    if isinstance(said, str) and said:
        return said
    return "stated measurement standard deviations" if d.absolute else "residual variance of the fit (no noise stated)"


def distinct_record(best, solutions, alpha: float) -> dict:
    """How the solutions were told apart and how well the best one is determined: ``alpha``,
    ``basis`` (``"statistic"``, ``"tolerance"`` or ``"mixed"``, :func:`~femupdate.distinct.significant`),
    ``non_unique`` (more than one solution fits the data as well as the best), ``separations``
    (per solution its :class:`~femupdate.distinct.Separation` from the lowest-cost one) and
    ``conditioning`` (:func:`~femupdate.distinct.conditioning` of the best run; None without
    diagnostics)."""
    d = getattr(best, "diagnostics", None)
    basis = solutions[0].basis if solutions else "tolerance"
    cond = None
    if d is not None and np.size(d.covariance):
        cond = conditioning(best.names, best.x, d.covariance, d.condition_number, covariance_basis(d))
    return {"alpha": float(alpha), "basis": basis, "non_unique": sum(s.fits for s in solutions) > 1,
            "separations": [None if s.separation is None else s.separation.to_dict() for s in solutions],
            "conditioning": cond}


__all__ = ["cluster", "converged_solutions", "fit_threshold", "classify", "parameter_scale", "run_covariance",
           "distinct_record", "covariance_basis", "common_noise", "round_off"]
