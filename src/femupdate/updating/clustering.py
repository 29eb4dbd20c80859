"""Distinct solutions of a multi-start study: converged runs clustered by their parameters
(:func:`femupdate.distinct.cluster`), and told apart: those that fit the data as well as the best
one (:func:`fit_threshold`), and local minima (:func:`classify`)."""

from __future__ import annotations

from typing import TypeVar

from collections.abc import Sequence

import numpy as np

import dataclasses
import math

from ..distinct import cluster
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


def converged_solutions(runs: Sequence, names: Sequence[str], kind: type, cost_tol: float | None,
                        rel_tol: float, scale=None) -> tuple[list[int], list[Solution]]:
    """Indices of the runs of type ``kind`` that converged (and, with ``cost_tol``, fit), and their
    distinct solutions from :func:`cluster`, most frequent first (ties: lowest cost first).

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

    Returns
    -------
    ok : list of int
        Indices into ``runs`` of the counted runs, in run order.
    solutions : list of Solution
        One per cluster, represented by its lowest-cost run; empty when no run counts.
    """
    ok = [k for k, r in enumerate(runs) if isinstance(r, kind) and getattr(r, "success")
          and (cost_tol is None or getattr(r, "cost") <= cost_tol)]
    solutions = []
    if ok:
        pts = np.array([runs[k].x for k in ok])
        costs = np.array([runs[k].cost for k in ok])
        for g in cluster(pts, costs, rel_tol, scale):
            rep = runs[ok[g[0]]]
            solutions.append(Solution(dict(zip(names, map(float, rep.x))), rep.cost, len(g), [ok[i] for i in g]))
        solutions.sort(key=lambda s: (-s.count, s.cost))
    return ok, solutions


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
    c0 = float(best.history[0]["cost"]) if best.history else best.cost
    floor = 1e-14 * max(c0, best.cost)
    return float(best.cost + 0.5 * chi2.ppf(0.95, L) * var + floor)


def classify(ms: _Result) -> _Result:
    """``ms`` with each solution marked as fitting the data (:func:`fit_threshold` of the best run)
    or not, and ordered: the fitting ones first (most frequent first, then lowest cost), then the
    local minima (lowest cost first).

    Parameters
    ----------
    ms : MultiStartResult

    Returns
    -------
    MultiStartResult
        A copy with ``solutions`` marked and reordered and ``fit_cost`` set.
    """
    if ms.best is None or not ms.solutions:
        return ms
    limit = fit_threshold(ms.best)
    marked = [dataclasses.replace(s, fits=bool(s.cost <= limit)) for s in ms.solutions]
    marked.sort(key=lambda s: (not s.fits, -s.count if s.fits else 0, s.cost))
    return dataclasses.replace(ms, solutions=marked, fit_cost=limit if math.isfinite(limit) else math.nan)


__all__ = ["cluster", "converged_solutions", "fit_threshold", "classify", "parameter_scale"]
