"""The bootstrap step of :func:`~femupdate.damage.detect_damage` (its module docstring, step 7):
replicates simulated from the identified model with the stated noise (:func:`simulated`), each
localised, refined and verified anew (:func:`bootstrap_refined`); without refinement, the measured
data perturbed and the localisation alone re-run (:func:`bootstrap_localised`).  :class:`Replicates`
holds what they locate and sums it up.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ..sensitivity.factor import single_thread_blas
from ..testdata import MeasuredMode, TestData
from .localise import Localiser, Measured, NoiseLevels, measured_shapes, perturbed, realised
from .solvers import support_of
from .verify import Refined, Refiner

#: the note of a bootstrap skipped because the stated noise is zero
NOTHING_TO_VARY = "no noise stated (zero): the bootstrap has nothing to vary and was skipped"


def simulated(model, theta, data: TestData, pairs, sig_f, sig_s, rng: np.random.Generator) -> TestData:
    """Replicate test data from the model at ``theta``: each test mode's paired model mode at its
    dofs, scaled to 1 at its largest entry with the measured sign, plus the stated noise (``sig_f``,
    ``sig_s``: one level, or one per test mode)."""
    from ..modal import model_modes

    T = len(data.modes)
    modes = model_modes(model, theta, n_modes=min(model.n_dofs, max(2 * T, T + 6)))
    by_test = {k: j for k, j, _ in pairs}
    sf = np.broadcast_to(np.asarray(sig_f, float), (T,))
    ss = np.broadcast_to(np.asarray(sig_s, float), (T,))
    out = []
    for k, m in enumerate(data.modes):
        j = by_test.get(k, k)
        lam = modes.eigenvalues[j] * (1 + sf[k] * rng.standard_normal()) ** 2
        if m.has_shape and len(m.dofs) >= 2:
            sh = modes.shapes[model.dof_index(m.dofs), j]
            sh = sh / sh[np.argmax(np.abs(sh))]
            if sh @ realised(m) < 0:
                sh = -sh
            out.append(MeasuredMode(lam, m.dofs, sh + ss[k] * rng.standard_normal(sh.size), m.label))
        else:
            out.append(MeasuredMode(lam, label=m.label))
    return TestData(modes=tuple(out))


@dataclass(frozen=True, eq=False)
class Replicates:
    """What the bootstrap replicates located.

    Attributes
    ----------
    sets : list of set of int
        The unknowns each replicate located (empty where it found no set that fits).
    changes : list of ndarray
        Each replicate's change of every unknown.
    n : int
        The replicates run (0 when the bootstrap was skipped).
    note : str or None
        Why it was skipped, when the user should know.
    """

    sets: list[set[int]]
    changes: list[np.ndarray]
    n: int
    note: str | None = None

    @classmethod
    def none(cls, note: str | None = None) -> Replicates:
        return cls([], [], 0, note)

    def summary(self, n_unknowns: int, located) -> tuple[np.ndarray, np.ndarray, float]:
        """Selection frequency and standard error of each unknown's change, and the share of the
        replicates that locate exactly ``located`` (NaN without replicates)."""
        if not self.sets:
            return np.full(n_unknowns, math.nan), np.full(n_unknowns, math.nan), math.nan
        D = np.array(self.changes)
        sel = np.array([[i in s for i in range(n_unknowns)] for s in self.sets]).mean(axis=0)
        se = D.std(axis=0, ddof=1) if len(self.sets) > 1 else np.full(n_unknowns, math.nan)
        same = float(np.mean([s == set(located) for s in self.sets]))
        return sel, se, same


def chain(refiner: Refiner, data: TestData, alpha: float | None) -> tuple[set[int], np.ndarray]:
    """The whole chain on one data set: localised, refined and verified; (located set, changes)."""
    L = len(refiner.names)
    meas_k = measured_shapes(data)
    fit_k, _, _ = refiner.localiser.solve(meas_k.eigenvalues, meas_k.shapes, alpha)
    with single_thread_blas():
        _, f_k = refiner.search(data, meas_k.eigenvalues, meas_k.shapes, fit_k)
    d_k = f_k.delta if f_k.fits else np.zeros(L)
    return ({i for i in f_k.members if abs(d_k[i]) >= refiner.min_change} if f_k.fits else set()), d_k


def bootstrap_refined(n: int, refiner: Refiner, refined: Refined, data: TestData, alpha: float | None,
                      rng: np.random.Generator, progress: Callable[[int, int], None] | None = None,
                      delta: np.ndarray | None = None, pairs=None) -> Replicates:
    """``n`` replicates simulated from the refined model (its change ``refined.delta``, the data's
    modes paired as the final fit paired them) — or from the change ``delta`` with ``pairs`` (the
    healthy baseline: zero) — each localised, refined and verified anew; ``progress(done, n)`` after each."""
    levels = refiner.levels
    theta_hat = refiner.localiser.equations.theta(refined.delta if delta is None else delta)
    pairs = refined.final.pairs if pairs is None else pairs
    sets, changes = [], []
    for _ in range(n):
        sig_f, sig_s = levels.verify_levels
        data_k = simulated(refiner.model, theta_hat, data, pairs, sig_f, sig_s, rng)
        s_k, d_k = chain(refiner, data_k, alpha)
        sets.append(s_k)
        changes.append(d_k)
        if progress is not None:
            progress(len(sets), n)
    return Replicates(sets, changes, n)


def bootstrap_healthy(n: int, refiner: Refiner, refined: Refined, data: TestData, pairs, alpha: float | None,
                      rng: np.random.Generator, progress: Callable[[int, int], None] | None = None) -> Replicates:
    """``n`` replicates simulated from the healthy baseline (every change zero; the test modes paired
    with the baseline's as ``pairs``), each through the whole chain: the false-positive rate of this
    run's model, sensors, modes and noise (none when the noise is zero or no set fits the data)."""
    if not n or refiner.levels.zero or not refined.final.fits:
        return Replicates.none()
    return bootstrap_refined(n, refiner, refined, data, alpha, rng, progress, delta=np.zeros(len(refiner.names)),
                             pairs=pairs)


def bootstrap_localised(n: int, localiser: Localiser, meas: Measured, levels: NoiseLevels, alpha: float | None,
                        rng: np.random.Generator, progress: Callable[[int, int], None] | None = None) -> Replicates:
    """``n`` perturbations of the measured modes, each localised anew (no refinement);
    ``progress(done, n)`` after each."""
    sets, changes = [], []
    for _ in range(n):
        d_k = localiser.solve(*perturbed(meas, levels, rng), alpha)[0].debiased
        sets.append(set(support_of(d_k, localiser.min_change).tolist()))
        changes.append(d_k)
        if progress is not None:
            progress(len(sets), n)
    return Replicates(sets, changes, n)


def bootstrap(n: int, localiser: Localiser, meas: Measured, levels: NoiseLevels, alpha: float | None,
              rng: np.random.Generator, refiner: Refiner | None = None, refined: Refined | None = None,
              data: TestData | None = None, progress: Callable[[int, int], None] | None = None) -> Replicates:
    """The replicates :func:`~femupdate.damage.detect_damage` runs: with a refinement (``refiner``,
    ``refined`` and the refined ``data``), simulated from a refined set that fits (none when it
    does not, or when the stated noise is zero: a note says so); without, the localisation of the
    perturbed measured modes.  ``progress(done, n)`` after each replicate."""
    if not n:
        return Replicates.none()
    if refiner is None or refined is None or data is None:
        return bootstrap_localised(n, localiser, meas, levels, alpha, rng, progress)
    if not refined.final.fits:
        return Replicates.none()
    if levels.zero:
        return Replicates.none(NOTHING_TO_VARY)
    return bootstrap_refined(n, refiner, refined, data, alpha, rng, progress)


__all__ = ["simulated", "Replicates", "bootstrap", "bootstrap_refined", "bootstrap_healthy", "chain", "bootstrap_localised", "NOTHING_TO_VARY"]
