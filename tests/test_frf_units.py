"""Residuals in the data's units must not make the answer depend on the units.

The same structure described twice: a six-spring chain with stiffnesses of about 100 N/m and
masses of about 1 kg, and the same chain with both multiplied by 1e6 (the same natural
frequencies; receptances 1e-6 times smaller, about 1e-8 m/N).  The test data of the second are
those of the first times 1e-6 (the same noise draws), so every update of the second must give
the first's parameters times 1e6, the same cost and the same standard deviations relative to the
values.  Before the linear residuals were divided by the RMS of the measured values, SciPy's
gradient tolerance (absolute) stopped the second at its start.
"""

import numpy as np
import pytest

from femupdate import TestData
from femupdate.examples import chain
from femupdate.frf import Damping, simulate
from femupdate.testdata import StaticData
from femupdate.updating import frf_multistart, frf_update, global_search, update

K6 = np.array([120.0, 90.0, 150.0, 80.0, 110.0, 100.0])
M6 = np.array([1.0, 1.4, 0.8, 1.2, 1.0, 0.9])
FACTOR = 1e6
DAMPING = Damping(eta=0.02)
START = np.array([1.2, 0.85, 1.15, 0.9, 1.1, 0.95])  # within the basin of the linear residual


def pair():
    """The chain in its own units and scaled by FACTOR, with the lines and sensors of the tests."""
    small = chain(K6, M6, bounds=(1.0, 1000.0))
    big = chain(K6 * FACTOR, M6 * FACTOR, bounds=(FACTOR, 1000.0 * FACTOR))
    w = np.linspace(0.3, 1.1, 30) * np.sqrt(np.max(np.linalg.eigvalsh(np.diag(1 / M6) @ _k(K6))))
    return small, big, w


def _k(k):
    n = k.size
    K = np.zeros((n, n))
    for i in range(n):
        K[i, i] += k[i]
        if i + 1 < n:
            K[i, i] += k[i + 1]
            K[i, i + 1] = K[i + 1, i] = -k[i + 1]
    return K


def scaled(data, factor):
    """The FRF data of ``data`` times ``factor`` (the same draws of noise)."""
    from femupdate.testdata import FRFData

    return FRFData(data.omega, dict(data.force), data.dofs, data.response * factor)


def start(model, factor=1.0):
    return dict(zip(model.parameter_names, K6 * START * factor))


def same_answer(a, b):
    """b is a's update of the chain scaled by FACTOR."""
    np.testing.assert_allclose(b.x / FACTOR, a.x, rtol=1e-7)
    assert b.cost == pytest.approx(a.cost, rel=1e-6)
    np.testing.assert_allclose(b.diagnostics.relative_std, a.diagnostics.relative_std, rtol=1e-5)
    assert b.nfev == a.nfev and a.nfev > 3


@pytest.fixture(scope="module")
def frf_pair():
    small, big, w = pair()
    data = simulate(small, w, {"6:x": 1.0}, response=["2:x", "4:x", "6:x"], damping=DAMPING, noise=0.01, seed=3)
    return small, big, data


def test_frf_update_gives_the_same_answer_in_other_units(frf_pair):
    small, big, data = frf_pair
    a = frf_update(small, data, x0=start(small), damping=DAMPING)
    b = frf_update(big, scaled(data, 1 / FACTOR), x0=start(big, FACTOR), damping=DAMPING)
    assert a.success and b.success
    same_answer(a, b)
    np.testing.assert_allclose(a.x, K6, rtol=0.02)  # near the truth (1 % noise)
    rms = np.sqrt(np.mean(np.abs(data.response) ** 2))
    note = [n for n in b.notes if "divided by the RMS measured response" in n]
    assert len(note) == 1 and f"({rms / FACTOR:.4g})" in note[0] and "--std" in note[0]
    # the cost is that of the residuals divided by the RMS: dimensionless
    r = (frf_update(small, data, x0=dict(zip(small.parameter_names, a.x)), damping=DAMPING, max_nfev=1).fun)
    assert a.cost == pytest.approx(0.5 * float(r @ r), rel=1e-12)


def test_a_stated_std_is_used_as_it_is(frf_pair):
    """With a standard deviation the residuals are divided by it, not by the RMS: the cost is
    half the chi-square, in either unit system."""
    small, big, data = frf_pair
    sigma = 1e-4
    a = frf_update(small, data, x0=start(small), damping=DAMPING, measurement_std=sigma)
    b = frf_update(big, scaled(data, 1 / FACTOR), x0=start(big, FACTOR), damping=DAMPING,
                   measurement_std=sigma / FACTOR)
    same_answer(a, b)
    assert not any("RMS" in n for n in a.notes) and a.diagnostics.absolute
    xa = simulate(small, a.omega, {"6:x": 1.0}, response=["2:x", "4:x", "6:x"], values=a.parameters,
                  damping=DAMPING).response
    used = np.isin(data.omega, a.omega)
    assert a.cost == pytest.approx(0.5 * np.sum(np.abs(xa - data.response[used]) ** 2) / sigma ** 2, rel=1e-9)


def test_update_with_frf_data_gives_the_same_answer(frf_pair):
    small, big, data = frf_pair
    a = update(small, TestData(frf=data), x0=start(small), frf_options={"damping": DAMPING})
    b = update(big, TestData(frf=scaled(data, 1 / FACTOR)), x0=start(big, FACTOR), frf_options={"damping": DAMPING})
    same_answer(a, b)


def test_several_excitations_one_factor(frf_pair):
    """A multi-reference test alone: every set divided by one RMS (their weights against each
    other unchanged), the same answer in either unit system."""
    small, big, _ = frf_pair
    _, _, w = pair()
    sets = [simulate(small, w, {d: 1.0}, response=["2:x", "4:x", "6:x"], damping=DAMPING, noise=0.01, seed=s)
            for s, d in ((4, "6:x"), (5, "3:x"))]
    a = frf_update(small, TestData(frf_sets=tuple(sets)), x0=start(small), damping=DAMPING)
    b = frf_update(big, TestData(frf_sets=tuple(scaled(s, 1 / FACTOR) for s in sets)), x0=start(big, FACTOR), damping=DAMPING)
    same_answer(a, b)
    rms = np.sqrt(np.mean(np.concatenate([np.abs(s.response).ravel() for s in sets]) ** 2))
    assert [blk["scale"] for blk in a.blocks] == pytest.approx([1 / rms, 1 / rms], rel=1e-12)
    assert sum("divided by the RMS measured response" in n for n in a.notes) == 1


def test_static_deflections_alone_give_the_same_answer():
    small, big, _ = pair()
    f = {"3:x": 1.0, "6:x": 2.0}
    u = np.linalg.solve(_k(K6), np.array([0, 0, 1.0, 0, 0, 2.0]))
    u = u * (1 + 0.01 * np.random.default_rng(2).standard_normal(6))
    dofs = tuple(f"{i}:x" for i in range(1, 7))
    a = update(small, TestData(static=(StaticData(f, dofs, u),)), x0=start(small))
    b = update(big, TestData(static=(StaticData(f, dofs, u / FACTOR),)), x0=start(big, FACTOR))
    same_answer(a, b)
    assert any("divided by the RMS measured deflection" in n for n in a.notes)


def test_multistart_and_global_search_give_the_same_answer(frf_pair):
    small, big, data = frf_pair
    tiny = scaled(data, 1 / FACTOR)
    a = frf_multistart(small, data, starts=3, seed=4, damping=DAMPING)
    b = frf_multistart(big, tiny, starts=3, seed=4, damping=DAMPING)
    assert [not isinstance(r, str) and r.success for r in a.runs] == [not isinstance(r, str) and r.success
                                                                      for r in b.runs]
    for ra, rb in zip(a.runs, b.runs):
        if not isinstance(ra, str):
            np.testing.assert_allclose(rb.x / FACTOR, ra.x, rtol=1e-6)
    opts = {"popsize": 8, "maxiter": 15}
    ga = global_search(small, data, runs=1, seed=1, global_residual="linear", options=opts, damping=DAMPING)
    gb = global_search(big, tiny, runs=1, seed=1, global_residual="linear", options=opts, damping=DAMPING)
    np.testing.assert_allclose(gb.runs[0].x / FACTOR, ga.runs[0].x, rtol=1e-6)
    assert gb.runs[0].cost == pytest.approx(ga.runs[0].cost, rel=1e-6)
