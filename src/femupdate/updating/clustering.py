"""Distinct solutions of a multi-start study: converged runs clustered by their parameters
(:func:`femupdate.distinct.cluster`)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..distinct import cluster
from .results import Solution


def converged_solutions(runs: Sequence, names: Sequence[str], kind: type, cost_tol: float | None,
                        rel_tol: float) -> tuple[list[int], list[Solution]]:
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
        for g in cluster(pts, costs, rel_tol):
            rep = runs[ok[g[0]]]
            solutions.append(Solution(dict(zip(names, map(float, rep.x))), rep.cost, len(g), [ok[i] for i in g]))
        solutions.sort(key=lambda s: (-s.count, s.cost))
    return ok, solutions


__all__ = ["cluster", "converged_solutions"]
