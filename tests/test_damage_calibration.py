"""Damage confidence that holds (issue 27 items 1-3 and 6, issue 34's damage half), on a 3-D frame
built by femupdate.generators and on spring chains.

* one pairing: test and baseline modes paired by the rule update pairs by; pairs that cross a
  large frequency change or have a low MAC flagged (the old MAC-only rule paired across);
* never worse than update: on noise-free data where the update of every unknown reaches
  chi-square < 1e-12, damage returns exactly the unknowns it changed by more than 1 %, with their
  values to 1e-6 (reference: the update of every unknown, a second route);
* rates simulated for this run, with binomial error (checked against an independent Monte Carlo);
* model error said; an unchecked baseline never confirmed.

The six-unknown frame scenarios, and three seeds instead of one of the noise stated nowhere, run with
FEMUPDATE_HEAVY=1.
"""

import math

import numpy as np
import pytest

from femupdate import model_modes
from femupdate.close_modes import mode_groups
from femupdate.correlation import mac, pair_modes
from femupdate.damage import detect_damage
from femupdate.damage.examples import noisy_modes
from femupdate.damage.judge import UNCHECKED
from femupdate.damage.noise import BASIS_ESTIMATED, BASIS_LOCATED, BASIS_NOT_ESTIMABLE, estimated_noise, stated_noise
from femupdate.damage.localise import LARGE_CHANGE, measured_shapes, pair_with_baseline
from femupdate.examples import chain
from femupdate.generators import frame_lattice
from femupdate.testdata import MeasuredMode, TestData
from femupdate.updating import Problem, update

from conftest import HEAVY, heavy  # noqa: E402


def frame(nx=2, ny=2, nz=3):
    """A 3-D frame (generators.frame_lattice) with two unknowns per storey: the beams' modulus E_s
    and the columns' C_s (a symmetric plan: repeated bending modes, which corner sensors cannot
    tell apart)."""
    s = frame_lattice(nx, ny, nz, parameters="storey")
    for st in range(1, nz):
        p = s.parameters[f"E_{st}"]
        s.parameter(f"C_{st}", p.value, bounds=p.bounds)
    for g in s.groups:
        if g.type == "frame3d" and "z-members" in g.where[0]:
            g.props["E"] = [("C_" + v[2:]) if isinstance(v, str) else v for v in g.props["E"]]
    return s.build()


def _top(nz):
    return [1 + i + 2 * j + 4 * (nz - 1) for i in (0, 1) for j in (0, 1)]


def _values(model, scenario):
    return {n: model.values[j] * scenario.get(n, 1.0) for j, n in enumerate(model.parameter_names)}


# ============================================================================== one pairing
def test_corner_sensors_pair_as_update_pairs_where_the_mac_alone_crossed_to_another_mode():
    model = frame()
    corner = [f"{n}:{d}" for n in _top(3) for d in "xy"]
    data = noisy_modes(model, corner, 6)  # the healthy frame, noise-free
    modes = model_modes(model)
    # the old rule: MAC alone; at the corners the torsion mode 3 (50.6 Hz) looks exactly like mode 7 (155 Hz)
    M = mac(np.column_stack([m.shape for m in data.modes]), modes.shapes[model.dof_index(corner)])
    old = {k: j for k, j, _ in pair_modes(M, 0.0)}
    assert old[2] == 6 and modes.frequencies_hz[2] / modes.frequencies_hz[6] - 1 < -0.6
    pairing = pair_with_baseline(model, measured_shapes(data))
    assert [(k, j) for k, j, _ in pairing.pairs] == [(k, k) for k in range(6)] and pairing.flagged == ()
    assert np.max(np.abs(pairing.frequency_change)) < 1e-9
    # damaged: the pairs are those update makes at the baseline (the one rule, close modes as groups)
    damaged = noisy_modes(model, corner, 6, _values(model, {"C_1": 0.6}))
    prob = Problem(model, damaged, shape_scaling="unit")
    _, _, upd_pairs = prob.evaluate(prob.from_p(model.values[prob.idx]))
    got = pair_with_baseline(model, measured_shapes(damaged))
    # inside a group of repeated modes (the x and y bending pairs) any member is the same pair: the group compares
    group = {j: a for a, b in mode_groups(modes.eigenvalues, 0.01) for j in range(a, b)}
    assert [(k, group.get(j, j)) for k, j, _ in got.pairs] == [(k, group.get(j, j)) for k, j, _ in upd_pairs]
    assert len(group) >= 4  # the frame has repeated modes among the six


def test_pairs_across_a_large_frequency_change_or_with_a_low_mac_are_flagged_never_silent():
    model = frame()
    sensors = [f"{n}:{d}" for n in _top(3) + [5, 8] for d in "xyz"]
    data = noisy_modes(model, sensors, 6, _values(model, {"E_2": 0.6, "C_1": 0.8}))
    rng = np.random.default_rng(1)
    bad = data.modes[3]  # a shape the baseline has no mode like (a wrong channel map, say)
    modes = list(data.modes)
    modes[3] = MeasuredMode(bad.eigenvalue, bad.dofs, rng.standard_normal(len(bad.dofs)), bad.label)
    data = TestData(modes=tuple(modes))
    res = detect_damage(model, data, refine=False, bootstrap=0)
    flagged = {f["test_mode"]: f for f in res.pairing["flagged"]}
    fc = np.asarray(res.frequency_change)
    for k in range(6):  # every pair beyond the frequency window is flagged, and said
        assert (abs(fc[k]) > LARGE_CHANGE) <= ((k + 1) in flagged and "frequency change" in flagged[k + 1]["why"])
    assert any(abs(v) > LARGE_CHANGE for v in fc)
    assert "MAC" in flagged[4]["why"] and flagged[4]["mac"] < 0.8
    assert any(n.startswith("pairs to doubt") and "test mode 4 with baseline mode" in n for n in res.to_json()["notes"])


# ============================================================================== never worse than update
def _update_and_damage(model, data):
    up = update(model, data)
    ref = {n: up.parameters[n] / model.values[j] - 1 for j, n in enumerate(model.parameter_names)}
    res = detect_damage(model, data, noise={"frequency": 0.0, "shape": 0.0}, bootstrap=0, baseline_checked=True)
    return up, ref, res


def _same_as_update(up, ref, res):
    assert 2 * up.cost < 1e-12  # the update of every unknown reproduces the noise-free data
    assert set(res.located) == {n for n, v in ref.items() if abs(v) > 0.01}
    for n, v in ref.items():
        assert res.changes[n] == pytest.approx(v, abs=1e-6), n
    assert res.status == "confirmed"


@pytest.mark.parametrize("scenario", [{"C_1": 0.7}, {"E_2": 0.6, "C_1": 0.8}, {"E_1": 0.75}])
def test_noise_free_damage_returns_what_the_update_of_every_unknown_returns(scenario):
    model = frame()
    sensors = [f"{n}:{d}" for n in _top(3) + [5, 8] for d in "xyz"]
    _same_as_update(*_update_and_damage(model, noisy_modes(model, sensors, 6, _values(model, scenario))))


@heavy
@pytest.mark.parametrize("scenario", [{"C_1": 0.7}, {"E_2": 0.65, "C_3": 0.65}, {"E_3": 0.6, "C_2": 0.8},
                                      {"C_2": 0.5}])
def test_noise_free_damage_equals_update_on_a_four_storey_frame(scenario):
    model = frame(2, 2, 4)
    sensors = [f"{n}:{d}" for n in _top(4) + [9, 8] for d in "xyz"]
    _same_as_update(*_update_and_damage(model, noisy_modes(model, sensors, 8, _values(model, scenario))))


# ============================================================================== rates for this structure
def test_the_quoted_false_positive_rate_is_that_of_independent_healthy_runs():
    k, m = [1000.0, 1200.0, 900.0, 1100.0, 1000.0], [1.0, 1.1, 0.9, 1.0, 1.2]
    model = chain(k, m)
    sensors = ["1:x", "3:x", "5:x"]
    noise = {"frequency": 0.01, "shape": 0.02}
    theta = model.values.copy()
    theta[model.parameter_index("k3")] *= 0.6
    n = 12
    data = noisy_modes(model, sensors, 3, theta, 0.01, 0.02, seed=5)
    res = detect_damage(model, data, noise=noise, bootstrap=n, baseline_checked=True, seed=2)
    fp = res.confidence["false_positive_rate"]
    assert fp["n"] == n and "healthy" in fp["basis"]
    # a second route: the whole detection run on independent healthy data sets with the same noise
    hits = sum(bool(detect_damage(model, noisy_modes(model, sensors, 3, None, 0.01, 0.02, seed=100 + s), noise=noise,
                                  bootstrap=0, baseline_checked=True).located) for s in range(n))
    p1, p2 = fp["count"] / n, hits / n
    pooled = (fp["count"] + hits) / (2 * n)
    z = abs(p1 - p2) / math.sqrt(max(pooled * (1 - pooled), 1e-12) * 2 / n)
    assert z < 2.576 or pooled in (0.0, 1.0), (fp, hits)  # the binomial 99 % band of two proportions
    det = res.confidence["detection_rate"]
    assert det["n"] == n and det["interval"][0] <= det["rate"] <= det["interval"][1]


# ============================================================================== model error, unchecked baseline
def test_data_the_model_cannot_reproduce_are_said_to_show_a_model_error():
    k, m = [1000.0, 1200.0, 900.0, 1100.0, 1000.0], [1.0, 1.1, 0.9, 1.0, 1.2]
    heavier = list(m)
    heavier[2] *= 1.4  # the structure holds a mass the model lacks
    truth = chain(k, heavier)
    theta = truth.values.copy()
    theta[truth.parameter_index("k4")] *= 0.7
    data = noisy_modes(truth, ["1:x", "2:x", "3:x", "5:x"], 3, theta)
    res = detect_damage(chain(k, m), data, noise={"frequency": 0.001, "shape": 0.002}, bootstrap=0,
                        baseline_checked=True)
    me = res.verification["model_error"]
    assert not me["fits"] and me["chi2"] > me["limit"] and me["p_value"] < 0.01
    assert res.status != "confirmed" and res.to_json()["headline"].startswith("MODEL ERROR")
    # the same structure without the extra mass: no model error, the damage confirmed
    right = noisy_modes(chain(k, m), ["1:x", "2:x", "3:x", "5:x"], 3, {"k4": 0.7 * 1100.0})
    ok = detect_damage(chain(k, m), right, noise={"frequency": 0.001, "shape": 0.002}, bootstrap=0,
                       baseline_checked=True)
    assert ok.status == "confirmed" and ok.located == ["k4"] and not ok.to_json()["headline"].startswith("MODEL")


def test_a_baseline_too_stiff_without_undamaged_data_is_never_confirmed():
    # issue 34: baseline 10 % too stiff, no undamaged data: eight springs were reported damaged, "confirmed"
    k, m = [1000.0, 1200, 900, 1100, 1000, 1300, 950, 1050], [1.0, 1.1, 0.9, 1.0, 1.2, 0.8, 1.0, 1.1]
    truth = chain(k, m)
    theta = truth.values.copy()
    theta[truth.parameter_index("k3")] *= 0.6
    data = noisy_modes(truth, ["1:x", "3:x", "5:x", "6:x", "8:x"], 4, theta)
    stiff = chain([v * 1.1 for v in k], m)
    res = detect_damage(stiff, data, noise={"frequency": 0.001, "shape": 0.002}, bootstrap=0)
    assert res.status == "doubtful" and UNCHECKED in res.doubts
    together = next(d for d in res.doubts if "changed together" in d)
    # closed form: a uniform 10 % excess reads as 1/1.1 - 1 = -9.09 %; k3's loss relative to them is the true 40 %
    assert "7 of the 8" in together and "-9.1 %" in together and "k3 -40.0 % relative to them" in together
    assert "undamaged data or a checked baseline" in res.to_json()["headline"]
    # with the undamaged structure's data the baseline is checked first, and refused
    from femupdate import InputError

    with pytest.raises(InputError, match="does not match the undamaged data"):
        detect_damage(stiff, data, undamaged=noisy_modes(truth, ["1:x", "3:x", "5:x", "6:x", "8:x"], 4),
                      bootstrap=0)


# ============================================================================== noise not stated
def test_noise_stated_nowhere_is_estimated_from_the_fit_of_every_unknown_or_said_assumed():
    k, m = [1000.0, 1200, 900, 1100, 1000, 1300, 950, 1050], [1.0, 1.1, 0.9, 1.0, 1.2, 0.8, 1.0, 1.1]
    model = chain(k, m)
    theta = model.values.copy()
    theta[model.parameter_index("k3")] *= 0.6
    sensors = ["1:x", "2:x", "3:x", "5:x", "6:x", "7:x", "8:x"]
    try:
        import femupdate.variance  # noqa: F401  (the variance components of issue 27 item 2)
    except ImportError:
        res = detect_damage(model, noisy_modes(model, sensors, 5, theta, 0.005, 0.01, seed=0), bootstrap=0,
                            baseline_checked=True)
        basis = res.confidence["noise"]["basis"]
        assert basis["frequency"].startswith("assumed") and any("0.001 assumed" in n for n in res.notes)
        return
    for seed in range(3 if HEAVY else 1):  # true noise: 0.5 % on frequencies, 1 % of the largest entry on shapes
        res = detect_damage(model, noisy_modes(model, sensors, 5, theta, 0.005, 0.01, seed=seed), bootstrap=0,
                            baseline_checked=True)
        noise = res.confidence["noise"]
        assert 0.4 < noise["shape"] / 0.01 < 2.5, noise
        assert 0.4 < noise["frequency"] / 0.005 < 2.5, noise  # never the assumed 0.001
        if noise["basis"]["frequency"] == BASIS_LOCATED:
            # 5 eigenvalues for 8 unknowns: too few for the fit of every unknown, said so; the located set's fit tells it
            assert any("frequency noise cannot be estimated on its own" in n for n in res.notes)
            assert noise["basis"]["shape"] == BASIS_LOCATED and "conditional_on" not in res.confidence
        else:
            assert noise["basis"] == {"frequency": BASIS_ESTIMATED, "shape": BASIS_ESTIMATED}
        assert res.located == ["k3"] and any(n.startswith("noise not stated: estimated") for n in res.notes)


@heavy
def test_standard_errors_of_the_whole_chain_hold_over_noise_seeds():
    # noise stated as drawn; |identified - true change| / standard error over seeds: RMS z near 1 (issue 27: 4.5)
    k, m = [1000.0, 1200.0, 900.0, 1100.0, 1000.0], [1.0, 1.1, 0.9, 1.0, 1.2]
    model = chain(k, m)
    theta = model.values.copy()
    theta[model.parameter_index("k3")] *= 0.6
    z = []
    for seed in range(10):
        data = noisy_modes(model, ["1:x", "3:x", "4:x", "5:x"], 4, theta, 0.005, 0.01, seed=200 + seed)
        res = detect_damage(model, data, noise={"frequency": 0.005, "shape": 0.01}, bootstrap=20, baseline_checked=True,
                            seed=seed)
        if res.located == ["k3"]:
            z.append((res.changes["k3"] + 0.4) / res.confidence["standard_error"]["k3"])
    assert len(z) >= 8
    from scipy.stats import chi2

    n = len(z)
    rms = float(np.sqrt(np.mean(np.square(z))))
    # with calibrated errors n rms^2 is chi-square with n dof: its two-sided 99 % band
    assert math.sqrt(chi2.ppf(0.005, n) / n) < rms < math.sqrt(chi2.ppf(0.995, n) / n), z


def test_the_fit_of_every_unknown_is_made_afresh_not_taken_from_a_fit_from_another_start():
    # the reported failure: the search had fitted every unknown from a start at the lower bound (the
    # localisation's -99.9999 %), the cache gave that local minimum back as "the fit of every unknown",
    # and the noise was raised to make it fit
    from femupdate.damage.refine import SetSearch

    model = frame()
    sensors = [f"{n}:{d}" for n in _top(3) + [5, 8] for d in "xyz"]
    data = noisy_modes(model, sensors, 6, _values(model, {"C_1": 0.7}))
    names = list(model.parameter_names)
    srch = SetSearch(model, names, data, (0.0, 0.0), allow_increase=False, min_change=0.05, level=0.99,
                     max_located=len(names))
    start = np.zeros(len(names))
    start[names.index("C_1")] = -0.999999  # from there the old search ended at chi-square 6e16, every unknown near -90 %
    bad = srch.fit(range(len(names)), start)
    e = srch.every()
    assert e.chi2 <= bad.chi2 and e.fits and e.chi2 < 1e-6 * e.limit
    assert e.delta[names.index("C_1")] == pytest.approx(-0.3, abs=1e-6)
    assert np.max(np.abs(np.delete(e.delta, names.index("C_1")))) < 1e-6


def test_healthy_data_say_no_damage_with_the_false_positive_rate_of_their_own_replicates():
    k, m = [1000.0, 1200.0, 900.0, 1100.0, 1000.0], [1.0, 1.1, 0.9, 1.0, 1.2]
    model = chain(k, m)
    data = noisy_modes(model, ["1:x", "3:x", "5:x"], 3, None, 0.002, 0.005, seed=9)
    res = detect_damage(model, data, noise={"frequency": 0.002, "shape": 0.005}, bootstrap=6, baseline_checked=True)
    assert res.located == [] and res.status == "confirmed"
    assert res.to_json()["headline"] == "no damage: the baseline reproduces the data"
    fp = res.confidence["false_positive_rate"]
    assert fp["n"] == 6 and fp["rate"] == fp["count"] / 6 and res.confidence["detection_rate"] is None
    # a replicate that selects any unknown is a false positive: no unknown is selected more often than the rate
    assert max(res.confidence["selection_frequency"].values(), default=0.0) <= fp["rate"]
