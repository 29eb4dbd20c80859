r"""Identifiability-first sensor placement: greedy selection with exchange.

A sensor set is judged, at the nominal point and at N random points of the parameter box, by the
noise-weighted sensitivity matrix of :mod:`.fisher` with its columns scaled by the parameter
values (unit-free: the Fisher information of the relative parameters).  Sets are compared by, in
this order:

1. the smallest rank over the points (full rank L everywhere: locally identifiable everywhere);
2. whether every point is well conditioned (condition number of S at most ``max_condition``);
3. at least two measured dofs, and (with ``max_automac``) the target modes told apart at the
   sensors: the largest off-diagonal auto-MAC at the nominal point at most ``max_automac``;
4. the design criterion at the nominal point: D-optimal ``log det F`` or A-optimal
   ``-trace F^-1`` (the sum of the relative variances); for a rank-deficient set the sum of the
   logarithms of its non-zero squared singular values instead (how far it has got).

Greedy: from the fixed sensors add, one at a time, the candidate that gives the best set; then
exchange (swap a chosen sensor for an unchosen one while that improves the set); ``restarts``
random sets are exchanged as well and the best kept.  The exchange ends at a set no single swap
improves, which need not be the best set; with ``exhaustive_limit`` small problems (at most that
many sets) are solved exactly by scoring every set.  With ``n_sensors=None`` the plan grows
until it is identifiable and well conditioned at every point (the smallest identifiable plan the
greedy search finds) — with at least two measured dofs, the paper's n > 1: one sensor's
frequencies can be full rank and still have several solutions.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from .._errors import InputError
from .classical import _better, automac_max, exchange_pass
from .fisher import Noise, SensitivityBank, design_kind, design_value, rank_and_condition

DESIGNS = ("d", "a")


@dataclass(frozen=True, eq=False)
class SetScore:
    """How a sensor set fares at the parameter points (:func:`score_set`).

    Each parameter is stored as the attribute of the same name.

    Parameters
    ----------
    ranks : tuple of int
        Rank of S at each point (nominal first).
    conditions : tuple of float
        Condition number of the value-scaled S at each point (inf when rank-deficient).
    design : float
        The design criterion at the nominal point (module docstring).
    n_parameters : int
    max_condition : float
    n_dofs : int
        Measured dofs of the set.
    automac_max : float
        The largest off-diagonal auto-MAC of the target modes at the set's dofs (nominal point).
    max_automac : float
        The largest counted as telling the modes apart (1: no requirement).
    """

    ranks: tuple[int, ...]
    conditions: tuple[float, ...]
    design: float
    n_parameters: int
    max_condition: float
    n_dofs: int
    automac_max: float = 0.0
    max_automac: float = 1.0

    @property
    def min_rank(self) -> int:
        return min(self.ranks)

    @property
    def full_rank(self) -> bool:
        """Rank L at every point."""
        return self.min_rank == self.n_parameters

    @property
    def well_conditioned(self) -> bool:
        """Full rank and condition at most ``max_condition`` at every point."""
        return self.full_rank and max(self.conditions) <= self.max_condition

    @property
    def distinct_modes(self) -> bool:
        """The largest off-diagonal auto-MAC is at most ``max_automac``."""
        return self.automac_max <= self.max_automac + 1e-12

    @property
    def identifiable(self) -> bool:
        """Well conditioned everywhere, with at least two measured dofs (the paper's n > 1) and the
        target modes told apart as ``max_automac`` asks."""
        return self.well_conditioned and self.n_dofs > 1 and self.distinct_modes

    def key(self) -> tuple:
        return (self.min_rank, int(self.well_conditioned), int(self.n_dofs > 1), int(self.distinct_modes), self.design)

    def to_dict(self) -> dict:
        return {"ranks": list(self.ranks), "conditions": list(self.conditions), "design": self.design,
                "min_rank": self.min_rank, "full_rank": self.full_rank, "well_conditioned": self.well_conditioned,
                "identifiable": self.identifiable, "max_condition": self.max_condition,
                "automac_max": self.automac_max, "max_automac": self.max_automac}


def score_set(banks: Sequence[SensitivityBank], rows: Sequence[int], noise: Noise, design="d",
              max_condition: float = 1e6, max_automac: float = 1.0) -> SetScore:
    """Ranks and conditions at every point, and the design criterion at the first (nominal).

    ``rows``: the measured dofs of the set, as positions among the banks' candidate dofs;
    ``design``: ``"d"``, ``"a"`` or a :class:`~.fisher.Design` with a prior (expected information
    gain).
    """
    ranks, conds = [], []
    value = -math.inf
    for b, bank in enumerate(banks):
        S = bank.matrix(rows, noise, normalised=True)
        r, c, s = rank_and_condition(S)
        ranks.append(r)
        conds.append(c)
        if b == 0:
            L = S.shape[1]
            if r == L or not isinstance(design, str) and design.prior_var is not None:
                value = design_value(S.T @ S, design)
            else:
                nz = s[s > max(S.shape) * np.finfo(float).eps * s[0]] if s.size and s[0] > 0 else s[:0]
                value = float(np.sum(np.log(nz ** 2))) if nz.size else -math.inf
    P = banks[0].phi[list(rows)]
    return SetScore(tuple(ranks), tuple(conds), value, banks[0].dlam.shape[1], max_condition, len(rows),
                    automac_max(P), max_automac)


@dataclass(frozen=True, eq=False)
class IdentifiabilityPlacement:
    """An identifiability-first placement (:func:`identifiability_placement`).

    Each parameter is stored as the attribute of the same name.

    Parameters
    ----------
    chosen : tuple of int
        The chosen sensors (positions among the candidates), ascending.
    greedy : tuple of int
        The greedy set before the exchanges.
    score : SetScore
        The chosen set's score.
    swaps : int
        Exchanges that improved the greedy set (or a restart's).
    evaluations : int
        Sensor sets scored.
    design : str
    """

    chosen: tuple[int, ...]
    greedy: tuple[int, ...]
    score: SetScore
    swaps: int
    evaluations: int
    design: str


def identifiability_placement(banks: Sequence[SensitivityBank], groups: Sequence[Sequence[int]],
                              n_sensors: int | None, noise: Noise, *, fixed: Sequence[int] = (), design="d",
                              max_condition: float = 1e6, restarts: int = 0, seed: int = 0,
                              max_passes: int = 50, max_automac: float = 1.0,
                              exhaustive_limit: int = 0) -> IdentifiabilityPlacement:
    """Greedy selection with exchange of the sensors that identify the parameters (module docstring).

    Parameters
    ----------
    banks : sequence of SensitivityBank
        Sensitivities at the nominal point (first) and the random points of the box.
    groups : sequence of sequence of int
        The rows (candidate dofs) of each candidate sensor.
    n_sensors : int or None
        Sensors in the plan (fixed ones included); None: the smallest identifiable plan found.
    noise : Noise
    fixed : sequence of int
        Sensors always in the plan.
    design : {"d", "a"} or Design, default "d"
        A :class:`~.fisher.Design` with a prior: the expected information gain (Laplace).
    max_condition : float, default 1e6
        The largest condition number of the value-scaled S counted as well conditioned.
    restarts : int, default 0
        Random starting sets exchanged besides the greedy one.
    seed : int, default 0
    max_passes : int, default 50
        The most exchanges per start.
    max_automac : float, default 1.0
        The largest off-diagonal auto-MAC of the target modes at the sensors that tells them
        apart (1: no requirement).
    exhaustive_limit : int, default 0
        With ``n_sensors`` given and at most this many sets of the free sensors, every set is
        scored and the best kept (the exact optimum; ``greedy`` is then that set, ``swaps`` 0).

    Returns
    -------
    IdentifiabilityPlacement

    Raises
    ------
    InputError
        An unknown design; ``n_sensors`` below the fixed sensors or above the candidates.
    """
    if design_kind(design) not in DESIGNS:
        raise InputError(f"unknown design criterion {design!r}: use d (log det F) or a (trace of F^-1)")
    n_c = len(groups)
    fixed = tuple(sorted(set(int(i) for i in fixed)))
    if n_sensors is not None and not max(len(fixed), 1) <= n_sensors <= n_c:
        raise InputError(f"sensors: {n_sensors} asked, but there are {n_c} candidate sensors"
                         + (f" and {len(fixed)} fixed ones" if fixed else ""))
    count = [0]

    def score(sel):
        count[0] += 1
        return score_set(banks, [r for g in sorted(sel) for r in groups[g]], noise, design, max_condition,
                         max_automac)

    def key(sel):
        return score(sel).key()

    free = [h for h in range(n_c) if h not in fixed]
    if n_sensors is not None and 0 < math.comb(len(free), n_sensors - len(fixed)) <= exhaustive_limit:
        sets = [sorted(list(fixed) + list(c)) for c in itertools.combinations(free, n_sensors - len(fixed))]
        best_set, best_key = sets[0], key(sets[0])
        for sel in sets[1:]:
            k = key(sel)
            if _better(k, best_key):
                best_set, best_key = sel, k
        chosen = tuple(best_set)
        return IdentifiabilityPlacement(chosen, chosen, score(chosen), 0, count[0], design_kind(design))
    cur = list(fixed)
    target = n_c if n_sensors is None else n_sensors
    if n_sensors is None and cur and score(cur).identifiable:  # the fixed sensors suffice
        target = len(cur)
    while len(cur) < target:
        best_h, best_k = None, None
        for h in range(n_c):
            if h in cur:
                continue
            k = key(cur + [h])
            if best_k is None or _better(k, best_k):
                best_h, best_k = h, k
        cur.append(int(best_h))  # type: ignore[arg-type]
        if n_sensors is None and len(cur) >= max(len(fixed), 1):
            ex, _ = exchange_pass(cur, n_c, fixed, key, max_passes)
            if score(ex).identifiable:
                cur = ex
                break
    greedy = tuple(sorted(cur))
    best, swaps = exchange_pass(cur, n_c, fixed, key, max_passes)
    best_key = key(best)
    rng = np.random.default_rng(seed)
    for _ in range(int(restarts)):
        start = list(fixed) + [int(h) for h in rng.choice(free, size=len(best) - len(fixed), replace=False)]
        cand, s = exchange_pass(start, n_c, fixed, key, max_passes)
        k = key(cand)
        if _better(k, best_key):
            best, best_key, swaps = cand, k, s
    chosen = tuple(sorted(best))
    return IdentifiabilityPlacement(chosen, greedy, score(chosen), swaps, count[0], design_kind(design))


__all__ = ["DESIGNS", "SetScore", "score_set", "IdentifiabilityPlacement", "identifiability_placement"]
