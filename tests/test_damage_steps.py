"""The steps of damage detection, each alone (femupdate.damage.localise, .verify, .bootstrap,
detect.judge) on the cantilevered truss of the damage tests, and DamageOptions.

References: the projected equations hold exactly for complete noise-free data (K linear in the
element stiffnesses); SEREP reproduces the modes of its basis; the misfit-based shape noise
recovers the noise injected; the truth of the simulated damage; hand-counted replicate shares.
"""

import dataclasses
import math
import re

import numpy as np
import pytest

import femupdate
from femupdate import InputError, model_modes
from femupdate.damage import DamageOptions, detect_damage, element_parameters
from femupdate.damage.bootstrap import (NOTHING_TO_VARY, Replicates, bootstrap, bootstrap_localised, simulated)
from femupdate.damage.judge import UNCHECKED, binomial_rate, judge
from femupdate.damage.examples import concentrated_mass_truss, noisy_modes
from femupdate.damage.localise import (BASIS_ASSUMED, BASIS_CALLER, BASIS_DATA, BASIS_EXPANSION, Equations, Localiser, NoiseLevels, StatedNoise, basis_size, expansion,
                                       localise, make_localiser, measured_shapes, noise_levels, noise_weights,
                                       pair_with_baseline, realised_data, stated_noise)
from femupdate.damage.solvers import L1Fit
from femupdate.damage.verify import Refined, Refiner, Verification, verify
from femupdate.paper.damage_sections import truss_sensors
from femupdate.testdata import MeasuredMode, TestData

DAMAGED, LOSS = "E.4-5", 0.3


@pytest.fixture(scope="module")
def truss():
    base = element_parameters(concentrated_mass_truss("cantilever"))[0].build()
    names = [base.parameter_names[j] for j in base.free]
    theta = base.values.copy()
    theta[base.parameter_index(DAMAGED)] *= 1 - LOSS
    return base, names, truss_sensors(base), theta


def _truth(names):
    d = np.zeros(len(names))
    d[names.index(DAMAGED)] = -LOSS
    return d


def _localiser(base, names, data, options=DamageOptions(), noise=None, seed=0):
    meas = measured_shapes(data)
    pairing = pair_with_baseline(base, meas)
    loc, levels, notes = make_localiser(base, names, meas, pairing, stated_noise(noise), options,
                                        np.random.default_rng(seed))
    return meas, pairing, loc, levels, notes


# ============================================================================== options
def test_every_option_is_documented_once_with_its_default():
    doc = DamageOptions.__doc__
    for f in dataclasses.fields(DamageOptions):
        m = re.search(rf"^    {f.name} : .*?(?:default (\S+))?$", doc, re.M)
        assert m, f"{f.name} is not documented"
        shown = m.group(1)
        if f.default is None:
            assert shown is None and m.group(0).endswith("optional"), f.name
        else:
            assert shown is not None and shown.strip("`\"") == str(f.default), (f.name, shown, f.default)
    assert femupdate.DamageOptions is DamageOptions and "DamageOptions" in femupdate.__all__


def test_shorthand_keywords_are_the_options_and_unknown_ones_are_refused(truss):
    base, names, _, theta = truss
    data = noisy_modes(base, list(base.dofs), 5, theta)
    kw = dict(bootstrap=0, refine=False, iterations=1, noise={"frequency": 1e-5, "shape": 1e-5})
    a = detect_damage(base, data, **kw)
    b = detect_damage(base, data, noise=kw["noise"], options=DamageOptions(bootstrap=0, refine=False, iterations=1))
    c = detect_damage(base, data, noise=kw["noise"], options={"bootstrap": 0, "refine": True}, refine=False,
                      iterations=1)  # the keyword changes the options given
    for r in (b, c):
        assert r.changes == a.changes and r.status == a.status == "unverified" and r.located == [DAMAGED]
    with pytest.raises(TypeError, match="unexpected keyword argument 'bootstraps'"):
        detect_damage(base, data, bootstraps=0)


@pytest.mark.parametrize("given, message", [
    ({"method": "l2"}, "unknown method 'l2': use l1, tikhonov"),
    ({"min_change": 1.0}, r"min_change must lie in \(0, 1\), got 1.0"),
    ({"alpha": 0.0}, r"alpha is a fraction of alpha_max in \(0, 1\], got 0.0"),
    ({"iterations": 0}, "iterations must be >= 1 and bootstrap >= 0"),
    ({"bootstrap": -1}, "iterations must be >= 1 and bootstrap >= 0"),
    ({"level": 0.5}, r"level must lie in \(0.5, 1\), got 0.5"),
    ({"max_located": 0}, "max_located must be >= 1, got 0"),
    ({"expansion": "modal"}, "unknown expansion 'modal'"),
    ({"refine": "no"}, "refine must be True or False, got 'no'"),
    ({"n_noise": 1}, "n_noise must be an integer >= 2"),
    ({"localise_min_mac": 1.5}, "localise_min_mac must be a finite number"),
    ({"seed": -1}, "seed must be an integer >= 0"),
])
def test_options_refuse_bad_values_by_name(given, message):
    with pytest.raises(InputError, match=message):
        DamageOptions(**given)
    with pytest.raises(InputError, match=message):
        DamageOptions().replace(**given)


# ============================================================================== localise
def test_measured_shapes_keep_the_common_dofs_real_and_refuse_rigid_modes():
    a = MeasuredMode(4.0, ("1:x", "2:x", "3:x"), np.array([1.0, 2.0, 3.0]) * np.exp(0.7j), "a")
    b = MeasuredMode(9.0, ("3:x", "1:x"), np.array([-1.0, 0.5]), "b")
    meas = measured_shapes(TestData(modes=(a, b, MeasuredMode(16.0, label="no shape"))))
    assert meas.dofs == ("1:x", "3:x") and meas.n_modes == 2 and "b lacks 2:x" in meas.note
    np.testing.assert_allclose(meas.shapes, [[1.0, 0.5], [3.0, -1.0]], atol=1e-12)  # rotated to real, reordered
    np.testing.assert_array_equal(meas.eigenvalues, [4.0, 9.0])
    with pytest.raises(InputError, match="b: zero frequency"):
        measured_shapes(TestData(modes=(a, dataclasses.replace(b, eigenvalue=0.0))))
    with pytest.raises(InputError, match="fewer than two dofs"):
        measured_shapes(TestData(modes=(a, MeasuredMode(9.0, ("3:x", "4:x"), np.array([1.0, 2.0])))))


def test_stated_noise_is_checked():
    assert stated_noise(None) == StatedNoise(0.001, None)  # assumed, and said to be
    assert dict(stated_noise(None).basis) == {"frequency": BASIS_ASSUMED, "shape": None}
    caller = stated_noise({"frequency": 0.0, "shape": 0.01})
    assert (caller.frequency, caller.shape) == (0.0, 0.01)
    assert dict(caller.basis) == {"frequency": BASIS_CALLER, "shape": BASIS_CALLER}
    with pytest.raises(InputError, match="unknown key"):
        stated_noise({"shapes": 0.01})
    with pytest.raises(InputError, match="must be >= 0"):
        stated_noise({"shape": -0.01})


def test_the_noise_the_test_data_state_is_taken_per_mode_unless_the_caller_states_it():
    # std_frequency 0.4 % and 1 %; std_shape (unit-length scaling, as update reads it) 0.002 and 0.004
    a = MeasuredMode.from_frequency(10.0, ("1:x", "2:x", "3:x"), np.array([1.0, 2.0, 2.0]), std_frequency=0.004,
                                    std_shape=0.002)
    b = MeasuredMode.from_frequency(20.0, ("1:x", "2:x", "3:x"), np.array([2.0, -1.0, 0.0]), std_frequency=0.01,
                                    std_shape=0.004)
    st = stated_noise(None, TestData(modes=(a, b)))
    assert st.frequency_modes == pytest.approx((0.004, 0.01))  # std_eigenvalue = 2 std_frequency, halved back
    # relative to each shape's largest value: std_shape * |phi| / max|phi| (|phi| = 3 and sqrt(5); max 2 and 2)
    assert st.shape_modes == pytest.approx((0.002 * 3 / 2, 0.004 * np.sqrt(5) / 2))
    assert dict(st.basis) == {"frequency": BASIS_DATA, "shape": BASIS_DATA}
    mixed = stated_noise({"frequency": 0.02}, TestData(modes=(a, b)))
    assert mixed.frequency == 0.02 and mixed.frequency_modes is None and mixed.shape_modes is not None
    assert dict(mixed.basis) == {"frequency": BASIS_CALLER, "shape": BASIS_DATA}
    with pytest.raises(InputError, match="state it for every mode"):  # as update refuses it
        stated_noise(None, TestData(modes=(a, MeasuredMode.from_frequency(20.0, ("1:x", "2:x"), np.array([1.0, 2.0])))))


def test_pairing_gives_the_frequency_change_of_each_mode(truss):
    base, _, sensors, theta = truss
    data = noisy_modes(base, sensors, 5, theta)
    p = pair_with_baseline(base, measured_shapes(data))
    f0 = model_modes(base).frequencies_hz
    f1 = model_modes(base, theta).frequencies_hz
    assert [(k, j) for k, j, _ in p.pairs] == [(k, k) for k in range(5)] and p.n_rigid == 0
    np.testing.assert_allclose(p.frequency_change, f1[:5] / f0[:5] - 1, rtol=1e-9, atol=1e-12)
    assert np.all(p.frequency_change <= 0) and p.highest == 4
    assert p.poor(0.8) == [] and p.poor(1.0) == list(range(5))  # the MACs are below 1 with damage


def test_projected_equations_hold_exactly_for_complete_noise_free_data(truss):
    base, names, _, theta = truss
    meas = measured_shapes(noisy_modes(base, list(base.dofs), 5, theta))
    eq = Equations(base, names, base.values)
    exp, notes = expansion(base, base.values, meas, pair_with_baseline(base, meas), "serep", 5, False)
    assert exp.full and notes == [] and np.max(exp.error) < 1e-12
    A, r = eq.build(meas.eigenvalues, exp.T0 @ meas.shapes)
    assert A.shape == (25, len(names)) and np.linalg.norm(r) > 1e-3
    assert np.linalg.norm(A @ _truth(names) - r) < 1e-9 * np.linalg.norm(r)
    np.testing.assert_array_equal(eq.theta(_truth(names)), theta)
    heavy = _with_mass_parameter(base)
    with pytest.raises(InputError, match="must be stiffness parameters; rho enters the mass matrix too"):
        Equations(heavy, names[:1] + ["rho"], heavy.values)


def _with_mass_parameter(base):
    from femupdate import Parameter

    return dataclasses.replace(base, parameters=base.parameters + (Parameter("rho", 1.0),),
                               dK=base.dK + (None,), dM=base.dM + (base.M(),))


def test_serep_expansion_reproduces_the_baseline_modes_and_its_basis_is_checked(truss):
    base, names, sensors, _ = truss
    meas = measured_shapes(noisy_modes(base, sensors, 5))
    pairing = pair_with_baseline(base, meas)
    n = basis_size(meas, pairing, base.n_dofs, None)
    assert n == 10  # twice the highest paired mode
    exp, _ = expansion(base, base.values, meas, pairing, "serep", n, True)
    assert not exp.full and np.max(exp.error) < 1e-10
    full = model_modes(base).shapes[:, :5]
    exp_shapes = exp.T0 @ meas.shapes
    for k in range(5):
        c = abs(full[:, k] @ exp_shapes[:, k]) / np.linalg.norm(full[:, k]) / np.linalg.norm(exp_shapes[:, k])
        assert c == pytest.approx(1.0, abs=1e-10)
    with pytest.raises(InputError, match=r"n_basis must lie between 1 and the number of measured dofs \(28\), got 29"):
        basis_size(meas, pairing, base.n_dofs, 29)


@pytest.mark.parametrize("sigma", [0.005, 0.02])
def test_unstated_shape_noise_is_recovered_from_the_expansion_misfit(truss, sigma):
    base, _, sensors, _ = truss
    meas = measured_shapes(noisy_modes(base, sensors, 5, None, 0.0, sigma, seed=4))
    pairing = pair_with_baseline(base, meas)
    exp, _ = expansion(base, base.values, meas, pairing, "serep", basis_size(meas, pairing, base.n_dofs, None), True)
    levels, notes = noise_levels(StatedNoise(), meas, exp)
    assert levels.shape == pytest.approx(sigma, rel=0.25)
    assert levels.shape < levels.shape_verify < 1.5 * levels.shape  # the upper end of its confidence interval
    assert len(notes) == 2 and "0.001 assumed" in notes[0] and f"{levels.shape_verify:.3g}" in notes[1]
    assert dict(levels.basis) == {"frequency": BASIS_ASSUMED, "shape": BASIS_EXPANSION}
    stated, notes = noise_levels(stated_noise({"frequency": 0.002, "shape": 0.01}), meas, exp)
    assert (stated.frequency, stated.shape, stated.shape_verify) == (0.002, 0.01, 0.01) and notes == []


def test_noise_weights_whiten_the_equations_and_are_the_identity_without_noise(truss):
    base, names, sensors, theta = truss
    meas, _, loc, levels, _ = _localiser(base, names, noisy_modes(base, sensors, 4, theta), noise={"shape": 0.01})
    W = loc.weights
    # the whitened right-hand sides of fresh noise draws have unit covariance (to sampling error)
    rng = np.random.default_rng(99)
    R = np.array([W @ loc.equations.build(*_draw(meas, levels, rng, loc))[1] for _ in range(400)])
    C = np.cov(R, rowvar=False)
    assert np.median(np.diag(C)) == pytest.approx(1.0, rel=0.3)
    quiet = noise_weights(loc.equations, loc.expansion, meas, NoiseLevels(0.0, 0.0, 0.0), 10, rng)
    np.testing.assert_array_equal(quiet, np.eye(16))


def _draw(meas, levels, rng, loc):
    from femupdate.damage.localise import perturbed

    lam, Phi = perturbed(meas, levels, rng)
    return lam, loc.expansion.T0 @ Phi


def test_localisation_of_complete_noise_free_data_is_exact(truss):
    base, names, _, theta = truss
    data = noisy_modes(base, list(base.dofs), 5, theta)
    meas, _, loc, _, _ = _localiser(base, names, data, noise={"frequency": 1e-5, "shape": 1e-5})
    res = localise(loc, names, meas)
    assert res.record["located"] == [DAMAGED] and res.record["changes"][DAMAGED] == pytest.approx(-LOSS, abs=1e-6)
    j = names.index(DAMAGED)
    others = np.abs(np.delete(res.fit.l1, j))
    assert res.separation == pytest.approx(LOSS / np.max(others), rel=1e-6) and res.separation > 2
    assert res.tikhonov["n_above_threshold"] >= 1
    assert np.isfinite(res.fit.alpha_max) and res.fit.path
    tk = localise(dataclasses.replace(loc, method="tikhonov"), names, meas)
    assert tk.tikhonov == {} and math.isnan(tk.fit.alpha_max) and tk.fit.path == []


def test_the_score_vanishes_at_the_exact_change_and_points_at_the_damage_from_the_baseline(truss):
    base, names, _, theta = truss
    meas, _, loc, _, _ = _localiser(base, names, noisy_modes(base, list(base.dofs), 5, theta),
                                    noise={"frequency": 1e-5, "shape": 1e-5})
    score = loc.scorer(meas.eigenvalues, meas.shapes)
    s0 = score(np.zeros(len(names)))
    assert int(np.argmax(s0)) == names.index(DAMAGED)
    assert np.max(score(_truth(names))) < 1e-6 * np.max(s0)


# ============================================================================== refine and verify
@pytest.fixture(scope="module")
def refined_truss(truss):
    """Noise-free sensor data; the refinement started from a wrong candidate."""
    base, names, sensors, theta = truss
    data = realised_data(noisy_modes(base, sensors, 6, theta))
    noise = {"frequency": 1e-5, "shape": 1e-5}
    meas, pairing, loc, levels, _ = _localiser(base, names, data, noise=noise)
    refiner = Refiner.of(base, names, loc, levels, DamageOptions(), pairing.n_rigid)
    wrong = np.zeros(len(names))
    wrong[names.index("E.104-105")] = -0.3
    start = L1Fit(wrong, wrong, 0.0, 0.0, [], None)
    return refiner, refiner.refine(data, meas.eigenvalues, meas.shapes, start), data, meas


def test_refinement_leaves_a_wrong_candidate_for_the_damaged_member(refined_truss, truss):
    refiner, ref, _, _ = refined_truss
    names = truss[1]
    first = ref.search.trail[0]
    assert [names[i] for i in first.members] == ["E.104-105"] and not first.fits
    assert ref.final.fits and [names[i] for i in ref.final.members] == [DAMAGED]
    np.testing.assert_allclose(ref.delta, _truth(names), atol=1e-6)
    assert ref.support.tolist() == [names.index(DAMAGED)]
    assert ref.evidence[names.index(DAMAGED)] > ref.final.limit  # leaving it out ruins the fit
    assert refiner.max_located == 8 and refiner.pairing == "auto"


def test_verify_confirms_a_set_that_fits_alone(refined_truss, truss):
    _, ref, _, _ = refined_truss
    v = verify(ref)
    assert v.status == "confirmed" and v.doubts == [] and v.reason == ""
    rec = v.record
    assert rec["fits"] and rec["chi2"] <= rec["limit"] and rec["members"] == [DAMAGED]
    assert rec["sets"][0]["members"] == ["E.104-105"] and len(rec["sets"]) == len(ref.search.trail)
    assert rec["noise"] == {"frequency": 1e-5, "shape": 1e-5} and rec["level"] == 0.99


def test_verify_doubts_a_set_when_another_fits_or_the_noise_was_understated(refined_truss):
    _, ref, _, _ = refined_truss
    other = dataclasses.replace(ref.final, members=(0,), chi2=1.5, limit=2.0)
    v = verify(dataclasses.replace(ref, alternatives=[other]))
    assert v.status == "doubtful" and v.doubts == [
        f"1 other set(s) of the same size fit the data as well, e.g. {ref.search.names[0]} (chi-square 1.5, limit 2)"]
    search = ref.search
    search.noise_factor = 3.0
    try:
        v = verify(ref)
    finally:
        search.noise_factor = 1.0
    assert v.status == "doubtful" and "noise taken 3 times the stated one" in v.doubts[0]
    assert v.record["noise"]["frequency"] == pytest.approx(3e-5)


def test_verify_says_why_a_set_too_large_is_not_localised(truss):
    base, names, sensors, theta = truss
    theta2 = theta.copy()
    theta2[base.parameter_index("E.107-108")] *= 0.6
    data = realised_data(noisy_modes(base, list(base.dofs), 6, theta2))
    meas, pairing, loc, levels, _ = _localiser(base, names, data, noise={"frequency": 1e-5, "shape": 1e-5})
    refiner = Refiner.of(base, names, loc, levels, DamageOptions(max_located=1), pairing.n_rigid)
    fit, _, _ = loc.solve(meas.eigenvalues, meas.shapes)
    ref = refiner.refine(data, meas.eigenvalues, meas.shapes, fit)
    v = verify(ref)
    assert v.status == "not localised" and not ref.final.fits and ref.delta.tolist() == [0.0] * len(names)
    assert "has more than 1 unknown(s) (max_located)" in v.reason and v.record["fits"] is False


# ============================================================================== bootstrap
def test_replicate_summary_counts_by_hand():
    reps = Replicates([{0, 2}, {0}, set()], [np.array([-0.3, 0.0, -0.1]), np.array([-0.5, 0.0, 0.0]),
                                             np.zeros(3)], 3)
    sel, se, same = reps.summary(3, [0])
    np.testing.assert_allclose(sel, [2 / 3, 0.0, 1 / 3])
    np.testing.assert_allclose(se, [np.std([-0.3, -0.5, 0.0], ddof=1), 0.0, np.std([-0.1, 0, 0], ddof=1)])
    assert same == pytest.approx(1 / 3)
    sel, se, same = Replicates.none().summary(3, [0])
    assert np.all(np.isnan(sel)) and np.all(np.isnan(se)) and math.isnan(same)


def test_simulated_replicates_are_the_model_modes_plus_the_stated_noise(truss):
    base, _, sensors, theta = truss
    data = noisy_modes(base, sensors, 4, theta)
    pairs = [(k, k, 1.0) for k in range(4)]
    exact = simulated(base, theta, data, pairs, 0.0, 0.0, np.random.default_rng(0))
    for m, s in zip(data.modes, exact.modes):
        assert s.eigenvalue == pytest.approx(m.eigenvalue, rel=1e-10) and s.dofs == m.dofs
        np.testing.assert_allclose(s.shape, m.shape, atol=1e-10)  # scaled to 1 at its largest, measured sign
    noisy = simulated(base, theta, data, pairs, 0.0, 0.01, np.random.default_rng(0))
    spread = np.concatenate([s.shape - m.shape for m, s in zip(exact.modes, noisy.modes)])
    assert np.std(spread) == pytest.approx(0.01, rel=0.25)


def test_bootstrap_skips_what_has_nothing_to_vary(refined_truss):
    refiner, ref, data, meas = refined_truss
    rng = np.random.default_rng(0)
    loc, levels = refiner.localiser, refiner.levels
    assert bootstrap(0, loc, meas, levels, None, rng, refiner, ref, data).n == 0
    quiet = dataclasses.replace(refiner, levels=NoiseLevels(0.0, 0.0, 0.0))
    reps = bootstrap(5, loc, meas, quiet.levels, None, rng, quiet, ref, data)
    assert reps.n == 0 and reps.note == NOTHING_TO_VARY
    failed = dataclasses.replace(ref, final=dataclasses.replace(ref.final, fits=False))
    reps = bootstrap(5, loc, meas, levels, None, rng, refiner, failed, data)
    assert reps.n == 0 and reps.note is None


def test_bootstrap_replicates_locate_a_clear_loss(truss):
    base, names, sensors, theta = truss
    data = realised_data(noisy_modes(base, list(base.dofs), 5, theta, 0.001, 0.002, seed=5))
    meas, pairing, loc, levels, _ = _localiser(base, names, data, noise={"frequency": 0.001, "shape": 0.002})
    refiner = Refiner.of(base, names, loc, levels, DamageOptions(), pairing.n_rigid)
    fit, _, _ = loc.solve(meas.eigenvalues, meas.shapes)
    ref = refiner.refine(data, meas.eigenvalues, meas.shapes, fit)
    assert [names[i] for i in ref.support] == [DAMAGED]
    reps = bootstrap(3, loc, meas, levels, None, np.random.default_rng(1), refiner, ref, data)
    assert reps.n == 3 and all(s == {names.index(DAMAGED)} for s in reps.sets)
    sel, se, same = reps.summary(len(names), ref.support.tolist())
    assert same == 1.0 and sel[names.index(DAMAGED)] == 1.0 and 0 < se[names.index(DAMAGED)] < 0.05
    local = bootstrap_localised(3, loc, meas, levels, None, np.random.default_rng(1))
    assert local.n == 3 and all(names.index(DAMAGED) in s for s in local.sets)


# ============================================================================== judge
def _localisation(names, located, change=-0.3):
    from femupdate.damage.localise import Localisation

    d = np.zeros(len(names))
    d[located] = change
    return Localisation(L1Fit(d, d, 0.1, 1.0, [], None), np.array(located, dtype=np.intp), {}, 2.0,
                        {"method": "l1", "located": [names[i] for i in located], "changes": {}})


def _refined(names, members, change=-0.3):
    d = np.zeros(len(names))
    d[members] = change
    return Refined(None, [], {i: 50.0 for i in members}, None, d, np.array(members, dtype=np.intp))


def test_judge_keeps_a_confirmed_set_the_replicates_agree_with():
    names = ["a", "b", "c"]
    reps = Replicates([{1}, {1}, {1, 2}], [np.array([0, -0.3, 0]), np.array([0, -0.32, 0]), np.array([0, -0.3, -0.1])], 3)
    levels = NoiseLevels(0.001, 0.004, 0.006)
    healthy = Replicates([set(), {2}, set(), set()], [np.zeros(3)] * 4, 4)
    j = judge(names, _localisation(names, [1, 2]), Verification("confirmed"), _refined(names, [1]), reps, levels,
              detected=True, healthy=healthy, baseline_checked=True)
    assert j.status == "confirmed" and j.doubts == [] and j.order.tolist() == [1]
    conf = j.confidence
    assert conf["selection_frequency"] == {"b": 1.0, "c": pytest.approx(1 / 3)} and conf["same_set"] == pytest.approx(2 / 3)
    assert conf["standard_error"] == {"b": pytest.approx(np.std([-0.3, -0.32, -0.3], ddof=1))}
    assert conf["evidence"] == {"b": 50.0} and conf["bootstrap"] == 3 and conf["separation"] == 2.0
    assert conf["noise"] == {"frequency": 0.001, "shape": 0.004, "shape_verify": 0.006, "basis": {}}
    # the rates are those of the replicates: 1 healthy replicate of 4 located something; 3 of 3 found b
    assert conf["false_positive_rate"]["rate"] == 0.25 and conf["false_positive_rate"]["n"] == 4
    assert conf["detection_rate"]["rate"] == 1.0 and conf["detection_rate"]["count"] == 3
    # the same set, its baseline unchecked: never confirmed, and the doubt says what is needed
    u = judge(names, _localisation(names, [1, 2]), Verification("confirmed"), _refined(names, [1]), reps, levels,
              detected=True, healthy=healthy)
    assert u.status == "doubtful" and u.doubts == [UNCHECKED] and "--undamaged" in UNCHECKED


def test_judge_calls_out_changes_a_uniform_baseline_error_would_explain():
    names = ["a", "b", "c", "d"]
    reps = Replicates([{0, 1, 2, 3}] * 3, [np.full(4, -0.09)] * 3, 3)
    j = judge(names, _localisation(names, [0, 1, 2, 3]), Verification("confirmed"),
              _refined(names, [0, 1, 2, 3], change=-0.09), reps, NoiseLevels(0.001, 0.004, 0.006), detected=True)
    assert j.status == "doubtful" and j.doubts[0] == UNCHECKED and "4 of the 4 unknowns changed together" in j.doubts[1]
    one = judge(names, _localisation(names, [1]), Verification("confirmed"), _refined(names, [1]), reps,
                NoiseLevels(0.001, 0.004, 0.006), detected=True)
    assert one.doubts[-1] == UNCHECKED and not any("together" in d for d in one.doubts)  # one member: nothing uniform


@pytest.mark.parametrize("k, n", [(0, 20), (3, 20), (20, 20), (7, 50)])
def test_binomial_rate_is_the_clopper_pearson_interval(k, n):
    from scipy.stats import binomtest

    r = binomial_rate(k, n)
    ci = binomtest(k, n).proportion_ci(0.95, method="exact")  # SciPy's own route to the exact interval
    assert r["rate"] == k / n and r["interval"] == pytest.approx([ci.low, ci.high], abs=1e-12)
    assert r["standard_error"] == pytest.approx(np.sqrt(k / n * (1 - k / n) / n))


def test_judge_doubts_a_set_most_replicates_do_not_locate():
    names = ["a", "b", "c"]
    reps = Replicates([{1}, {2}, {2}], [np.zeros(3)] * 3, 3)
    j = judge(names, _localisation(names, [1]), Verification("confirmed"), _refined(names, [1]), reps,
              NoiseLevels(0.001, 0.004, 0.006), detected=True, baseline_checked=True)
    assert j.status == "doubtful" and j.doubts == ["only 33 % of the 3 bootstrap replicates locate this set"]


def test_judge_of_the_localisation_alone_and_of_nothing_located():
    names = ["a", "b", "c"]
    reps = Replicates([{2}, {2}], [np.zeros(3)] * 2, 2)
    j = judge(names, _localisation(names, [0, 2]), Verification(), None, reps, NoiseLevels(0.001, 0.004, 0.004),
              detected=False)
    assert j.status == "unverified" and j.order.tolist() in ([0, 2], [2, 0]) and j.confidence["evidence"] == {}
    assert j.confidence["same_set"] == 0.0 and j.doubts == []  # no refinement: the replicates do not judge
    assert UNCHECKED in j.notes
    nothing = judge(names, _localisation(names, []), Verification("confirmed", notes=["v"]), _refined(names, []),
                    Replicates.none(NOTHING_TO_VARY), NoiseLevels(0.0, 0.0, 0.0), detected=True)
    assert nothing.notes == ["v", NOTHING_TO_VARY, "no unknown changed by more than min_change although the "
                                                    "frequencies changed"]
    refused = judge(names, _localisation(names, []), Verification("not localised", reason="r"), _refined(names, []),
                    Replicates.none(), NoiseLevels(0.0, 0.0, 0.0), detected=True)
    assert refused.status == "not localised" and refused.reason == "r" and refused.notes == []


def test_localiser_is_a_frozen_step_object(truss):
    base, names, sensors, theta = truss
    _, _, loc, _, notes = _localiser(base, names, noisy_modes(base, sensors, 4, theta))
    assert isinstance(loc, Localiser) and loc.bounds == (-1.0 + 1e-9, 0.0)
    assert dataclasses.replace(loc, allow_increase=True).bounds[1] == 1.0
    with pytest.raises(dataclasses.FrozenInstanceError):
        loc.method = "tikhonov"
    assert any("shape noise not stated" in n for n in notes)
