"""Distinct solutions of a multi-start study: converged runs clustered by their parameters."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from .results import Solution


def cluster(points: np.ndarray, costs: np.ndarray, rel_tol: float = 1e-4) -> list[list[int]]:
    """Group solutions whose parameters agree within ``rel_tol`` (relative, per parameter).

    Greedy in order of increasing cost: each point joins the first cluster (in order of creation)
    whose representative — its lowest-cost member — it is within ``rel_tol`` of, else founds a
    new one.  One NumPy pass per cluster: the lowest-cost unclaimed point founds the next
    cluster and claims every unclaimed point near it.  Members are listed in increasing cost.
    """
    order = np.argsort(costs)
    P = np.asarray(points, float)[order]
    free = np.ones(len(order), bool)
    groups: list[list[int]] = []
    while free.any():
        i = int(np.argmax(free))
        scale = np.maximum(np.abs(P[i]), 1e-300)
        near = free & np.all(np.abs(P - P[i]) <= rel_tol * scale, axis=1)
        near[i] = True
        groups.append([int(order[j]) for j in np.flatnonzero(near)])
        free &= ~near
    return groups


def converged_solutions(runs: Sequence, names: Sequence[str], kind: type, cost_tol: float | None,
                        rel_tol: float) -> tuple[list[int], list[Solution]]:
    """Indices of the runs of type ``kind`` that converged (and, with ``cost_tol``, fit), and their
    distinct solutions from :func:`cluster`, most frequent first (ties: lowest cost first)."""
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
