"""Calibration of update's standard deviations (issue 27, items 2 and 6): over noise seeds the
parameter errors are as large as the reported standard deviations say, with the noise stated and
not stated, and the test of the fit flags a model that lacks a support spring.

The structure: a grounded chain of 8 masses and springs (all 8 stiffnesses updated), 6 modes
measured at every dof, noise 1 % on the frequencies and 3 % of the RMS entry on the unit-scaled
shapes.  The test data come from the true stiffness and mass matrices assembled here and solved by
:func:`scipy.linalg.eigh` (not femupdate's model or eigen-solver).  Targets, over seeds x 8
parameters: RMS z-score (error / std) in [0.8, 1.25]; coverage of the 68 % and 95 % intervals
(Student-t with the effective dof) inside the binomial 99 % band (the errors of one seed taken as
independent); the chi-square test at alpha = 0.01 flags the model without the spring in at least
90 % of seeds and the correct model in no more than the binomial 99 % bound at alpha.
``FEMUPDATE_HEAVY=1``: 50 seeds instead of 12.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from scipy import linalg, stats

import femupdate as fu
from femupdate import Structure
from femupdate.testdata import MeasuredMode, TestData

from conftest import HEAVY  # noqa: E402
SEEDS = 50 if HEAVY else 12
N, T = 8, 6
NOMINAL = np.array([2e6, 1.8e6, 1.7e6, 1.5e6, 1.4e6, 1.2e6, 1.0e6, 0.9e6])
TRUE = NOMINAL * np.array([1.1, 0.9, 1.05, 0.95, 1.0, 1.1, 0.9, 1.0])
MASS = 1000.0
FREQ_NOISE, SHAPE_NOISE = 0.01, 0.03
#: a grounded spring at the top mass the updated model lacks (5.5 % of the top storey's stiffness)
MISSING_SPRING = 5e4


def _model():
    s = Structure("chain")
    for i in range(1, N + 1):
        s.parameter(f"k{i}", float(NOMINAL[i - 1]), (0.0, math.inf))
        s.spring([f"{i}:x"] if i == 1 else [f"{i - 1}:x", f"{i}:x"], k=f"k{i}")
        s.mass([f"{i}:x"], m=MASS)
    return s.build()


def _true_modes(spring: float):
    """The true structure's lowest T modes, assembled and solved here."""
    K = np.zeros((N, N))
    for i, k in enumerate(TRUE):
        K[i, i] += k
        if i:
            K[i - 1, i - 1] += k
            K[i - 1, i] -= k
            K[i, i - 1] -= k
    K[-1, -1] += spring
    lam, phi = linalg.eigh(K, MASS * np.eye(N))
    return lam[:T], phi[:, :T]


def _data(seed: int, stated: bool, spring: float = 0.0) -> TestData:
    lam, phi = _true_modes(spring)
    rng = np.random.default_rng(seed)
    modes = []
    for k in range(T):
        f = math.sqrt(lam[k]) / (2 * math.pi) * (1 + FREQ_NOISE * rng.normal())
        shape = phi[:, k] / np.linalg.norm(phi[:, k])
        rms = math.sqrt(float(np.mean(shape ** 2)))
        shape = shape + SHAPE_NOISE * rms * rng.normal(size=N)
        m = MeasuredMode.from_frequency(f, [f"{i}:x" for i in range(1, N + 1)], shape,
                                        **({"std_frequency": FREQ_NOISE} if stated else {}))
        if stated:  # in the units of the unit-scaled shape the residuals compare
            m = dataclasses.replace(m, std_shape=SHAPE_NOISE * rms / float(np.linalg.norm(shape)))
        modes.append(m)
    return TestData(modes=tuple(modes))


def _runs(stated: bool, spring: float = 0.0, seeds: int = SEEDS):
    model = _model()
    z, in68, in95, flagged, bases = [], [], [], [], set()
    for seed in range(seeds):
        res = fu.update(model, _data(1000 + seed, stated, spring))
        assert res.success
        d = res.diagnostics
        err = np.abs(res.x - TRUE)
        z.append(err / d.std)
        in68.append(err <= d.interval(0.6827))
        in95.append(err <= d.interval(0.95))
        flagged.append(d.model_error["verdict"] == "model error")
        bases |= {c["basis"] for c in d.noise}
    return np.array(z), np.array(in68), np.array(in95), np.array(flagged), bases


def _band(p: float, n: int) -> tuple[float, float]:
    lo, hi = stats.binom.ppf([0.005, 0.995], n, p)
    return lo / n, hi / n


@pytest.mark.parametrize("stated", [False, True], ids=["noise estimated", "noise stated"])
def test_standard_deviations_are_calibrated(stated):
    z, in68, in95, flagged, bases = _runs(stated)
    assert bases == ({"stated"} if stated else {"estimated", "pooled"})
    rms = math.sqrt(float(np.mean(z ** 2)))
    assert 0.8 <= rms <= 1.25, f"RMS z-score {rms:.3f}"
    n = z.size
    lo, hi = _band(0.6827, n)
    assert lo <= in68.mean() <= hi, f"68 % coverage {in68.mean():.3f} outside [{lo:.3f}, {hi:.3f}]"
    lo, hi = _band(0.95, n)
    assert lo <= in95.mean() <= hi, f"95 % coverage {in95.mean():.3f} outside [{lo:.3f}, {hi:.3f}]"
    if stated:  # the correct model: flagged no more often than alpha allows
        assert flagged.sum() <= stats.binom.ppf(0.99, flagged.size, 0.01)


def test_missing_support_spring_is_flagged():
    seeds = SEEDS
    *_, flagged, _ = _runs(True, MISSING_SPRING, seeds)
    assert flagged.mean() >= 0.9, f"flagged in {flagged.sum()} of {seeds} seeds"


@pytest.mark.skipif(not HEAVY, reason="set FEMUPDATE_HEAVY=1 for the space frame (40 updates)")
def test_space_frame_with_noise_not_stated_is_calibrated():
    """The case of issue 27: a 3-storey space frame (femupdate's generator, 2 x 2 bays, plan 1 x
    1.4 m), three storey moduli, 6 modes at the 24 horizontal dofs above the base, 1 % / 3 % noise
    not stated, 40 seeds (its data from femupdate's modal solution at the true values)."""
    from femupdate.generators import frame_lattice

    model = frame_lattice(2, 2, 4, spacing=(1.0, 1.4, 1.0)).build()
    true = np.array([0.9, 1.1, 0.95]) * np.array([p.value for p in model.parameters])
    from femupdate.modal import model_modes

    modes = model_modes(model, dict(zip(model.parameter_names, true)), n_modes=T)
    sensors = [d for d in model.dofs if d.endswith((":x", ":y")) and not d.startswith(("1:", "2:", "3:", "4:"))]
    pos = [model.dofs.index(d) for d in sensors]
    z, in95 = [], []
    for seed in range(40):
        rng = np.random.default_rng(seed)
        ms = []
        for k in range(T):
            phi = modes.shapes[pos, k] / np.linalg.norm(modes.shapes[pos, k])
            phi = phi + SHAPE_NOISE * math.sqrt(float(np.mean(phi ** 2))) * rng.normal(size=phi.size)
            ms.append(MeasuredMode.from_frequency(modes.frequencies_hz[k] * (1 + FREQ_NOISE * rng.normal()), sensors,
                                                  phi))
        res = fu.update(model, TestData(modes=tuple(ms)))
        err = np.abs(res.x - true)
        z.append(err / res.diagnostics.std)
        in95.append(err <= res.diagnostics.interval(0.95))
    rms = math.sqrt(float(np.mean(np.square(z))))
    assert 0.8 <= rms <= 1.25, f"RMS z-score {rms:.3f}"
    lo, hi = _band(0.95, np.size(in95))
    assert lo <= np.mean(in95) <= hi
