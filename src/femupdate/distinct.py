"""Distinct points: solutions (or minima) that agree within a relative tolerance are one.

Used by every driver that counts solutions — multi-start updating, global search, uniqueness
studies — and by the residual surfaces' local minima; it depends on NumPy only.
"""

from __future__ import annotations

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


__all__ = ["cluster"]
