"""Test planning, second slice (issue 32): the pretest TAM and its orthogonality, the mass loading
of the accelerometers, exciter placement by driving points and FRF Fisher information, and the
expected information gain with a prior; references from closed forms and second routes."""

from __future__ import annotations

import math

import numpy as np
import pytest
import scipy.linalg as sla

from femupdate import Structure
from femupdate.examples import portal_frame
from femupdate.modal import model_modes
from femupdate.paper.uniqueness_sections import six_dof_model
from femupdate.planning import SensitivityBank, candidates, plan
from femupdate.planning.exciters import driving_point_criteria, exciter_placement, frf_lines, frf_sensitivity
from femupdate.planning.fisher import Design, design_value
from femupdate.planning.pretest import mass_loading, tam

N_FF = 5  # the fixed-fixed chain: 5 equal masses between 6 equal springs


def fixed_fixed_chain(k=1000.0, m=2.0, n=N_FF):
    """Equal masses m between n + 1 equal springs k, both ends grounded: mode r has
    φ_jr = sqrt(2 / ((n + 1) m)) sin(j r π / (n + 1)) and ω_r² = (4k/m) sin²(r π / (2(n + 1)))."""
    s = Structure("fixed-fixed chain")
    for i in range(1, n + 2):
        s.parameter(f"k{i}", k, (0.3 * k, 3 * k))
    for i in range(1, n + 1):
        s.spring([f"{i}:x"] if i == 1 else [f"{i - 1}:x", f"{i}:x"], k=f"k{i}")
        s.mass([f"{i}:x"], m=m)
    s.spring([f"{n}:x"], k=f"k{n + 1}")
    return s.build()


def closed_form_shapes(m=2.0, n=N_FF):
    j = np.arange(1, n + 1)[:, None]
    r = np.arange(1, n + 1)[None, :]
    return np.sqrt(2 / ((n + 1) * m)) * np.sin(j * r * np.pi / (n + 1))


# ------------------------------------------------------------------ TAM
def test_serep_tam_is_exact_at_the_target_modes_and_guyan_bounds_them_from_above():
    model = portal_frame()
    modes = model_modes(model, n_modes=6)
    dofs = ["3:x", "5:y", "8:x", "7:y", "10:x", "11:y"]
    Phi, lam = modes.shapes[:, [0, 2, 3]], modes.eigenvalues[[0, 2, 3]]  # not the lowest three: SEREP of the targets
    se = tam(model, dofs, Phi, lam, "serep")
    np.testing.assert_allclose(se["tam_frequencies_hz"], modes.frequencies_hz[[0, 2, 3]], rtol=1e-9)
    np.testing.assert_allclose(se["self_orthogonality"], np.eye(3), atol=1e-9)
    np.testing.assert_allclose(se["cross_orthogonality"], np.eye(3), atol=1e-9)
    gu = tam(model, dofs, modes.shapes[:, :3], modes.eigenvalues[:3], "guyan")
    # Guyan is a Rayleigh-Ritz reduction: its r-th eigenvalue is at least the full model's r-th
    assert np.all(gu["tam_frequencies_hz"] >= modes.frequencies_hz[:3] * (1 - 1e-12))
    ir = tam(model, dofs, modes.shapes[:, :3], modes.eigenvalues[:3], "irs")
    assert abs(ir["frequency_error"][0]) < abs(gu["frequency_error"][0])  # IRS improves the first mode


def test_tam_on_every_dof_gives_identity_orthogonality():
    model = portal_frame()
    modes = model_modes(model, n_modes=4)
    for method in ("guyan", "irs"):
        r = tam(model, list(model.dofs), modes.shapes, modes.eigenvalues, method)
        np.testing.assert_allclose(r["self_orthogonality"], np.eye(4), atol=1e-10)
        np.testing.assert_allclose(r["cross_orthogonality"], np.eye(4), atol=1e-10)
        np.testing.assert_allclose(r["frequency_error"], 0.0, atol=1e-10)


def test_guyan_tam_is_exact_when_the_omitted_dofs_carry_no_mass():
    s = Structure("massless omitted")
    for i in range(1, 5):
        s.parameter(f"k{i}", 1000.0 * i)
        s.spring([f"{i}:x"] if i == 1 else [f"{i - 1}:x", f"{i}:x"], k=f"k{i}")
    s.mass(["2:x"], m=1.5)
    s.mass(["4:x"], m=0.7)
    model = s.build()
    modes = model_modes(model, n_modes=2)
    r = tam(model, ["2:x", "4:x"], modes.shapes, modes.eigenvalues, "guyan")
    np.testing.assert_allclose(r["frequency_error"], 0.0, atol=1e-10)


# ------------------------------------------------------------------ mass loading
def test_mass_loading_single_dof_closed_form_and_first_order():
    s = Structure("oscillator")
    s.parameter("k", 4000.0)
    s.spring(["1:x"], k="k")
    s.mass(["1:x"], m=2.0)
    model = s.build()
    r = mass_loading(model, [("1:x",)], 0.1, [0])
    np.testing.assert_allclose(r["loaded_frequencies_hz"][0], math.sqrt(4000 / 2.1) / (2 * math.pi), rtol=1e-12)
    np.testing.assert_allclose(r["first_order_relative_shift"][0], -0.5 * 0.1 / 2.0, rtol=1e-12)


def test_mass_loading_first_order_agrees_with_the_re_solve_to_second_order():
    model = portal_frame()
    sensors = [("3:x",), ("8:y",), ("12:x",), ("12:y",)]  # two uniaxial sensors at node 12: two masses
    diffs = []
    for mass in (0.4, 0.2, 0.1):
        r = mass_loading(model, sensors, mass, [0, 1, 2])
        assert r["total_mass"] == pytest.approx(2 * 4 * mass)  # every translation of a planar node, per sensor
        assert np.all(r["relative_shift"] < 0) and np.all(r["mac"] > 0.99)
        diffs.append(np.abs(r["relative_shift"] - r["first_order_relative_shift"]))
    # halving the mass divides the first-order error by about four (O(m^2)); first order itself is O(m)
    ratio = diffs[1] / diffs[2]
    assert np.all((ratio > 3.5) & (ratio < 4.5)), ratio
    assert np.all(diffs[2] < 0.05 * np.abs(r["relative_shift"]))


# ------------------------------------------------------------------ exciters
def test_driving_point_criteria_match_the_closed_form_shapes():
    model = fixed_fixed_chain()
    bank = SensitivityBank(model, model.dofs, [0, 1, 2], list(model.parameter_names))
    ref = np.abs(closed_form_shapes()[:, :3])
    c = driving_point_criteria(bank)
    np.testing.assert_allclose(np.abs(bank.phi), ref, atol=1e-10)
    np.testing.assert_allclose(c["odp"], np.prod(ref, axis=1), atol=1e-10)
    np.testing.assert_allclose(c["nodp"], ref.min(axis=1), atol=1e-10)
    assert c["odp"][2] < 1e-14  # dof 3 is a node of mode 2: sin(3·2π/6) = 0


def test_exciter_is_never_placed_at_a_node_of_a_target_mode():
    model = fixed_fixed_chain()
    names = list(model.parameter_names)
    b0 = SensitivityBank(model, model.dofs, [0, 1, 2], names)
    rng = np.random.default_rng(3)
    banks = [b0] + [SensitivityBank(model, model.dofs, [0, 1, 2], names, model.values * rng.uniform(0.8, 1.2, 6),
                                    reference=b0.shapes_full) for _ in range(2)]
    for sensors in ([0, 1, 2, 3, 4], [1, 2, 3], [2, 4], [0, 2]):
        ex = exciter_placement(banks, sensors, 1)
        assert 2 not in ex.chosen and ex.excites_all, (sensors, ex.chosen)
    only_node = exciter_placement(banks, [0, 1, 3, 4], 1, candidates=[2])
    assert only_node.chosen == (2,) and not only_node.excites_all
    assert exciter_placement(banks, [0, 1, 3, 4], 1, candidates=[1, 2]).chosen == (1,)


def test_modal_frf_and_its_derivative_against_direct_solution_and_finite_differences():
    model = fixed_fixed_chain()
    names = list(model.parameter_names)
    p0 = model.values.copy() * np.array([1.0, 1.1, 0.9, 1.2, 0.95, 1.05])
    bank = SensitivityBank(model, model.dofs, range(N_FF), names, p0)  # every mode: the modal sum is exact
    eta = 0.04
    w2 = frf_lines(bank.eigenvalues[:2], eta)
    H, dH = frf_sensitivity(bank, [0, 3], 1, eta, w2)
    K, M = model.K(p0).toarray(), model.M(p0).toarray()
    direct = np.array([np.linalg.solve(K * (1 + 1j * eta) - w * M, np.eye(N_FF)[:, 1])[[0, 3]] for w in w2])
    np.testing.assert_allclose(H, np.concatenate([direct.real.ravel(), direct.imag.ravel()]), rtol=1e-9,
                               atol=1e-12 * np.abs(H).max())
    for j in (0, 3):
        h = 1e-6 * p0[j]
        pp, pm = p0.copy(), p0.copy()
        pp[j] += h
        pm[j] -= h
        Hp = frf_sensitivity(SensitivityBank(model, model.dofs, range(N_FF), names, pp), [0, 3], 1, eta, w2)[0]
        Hm = frf_sensitivity(SensitivityBank(model, model.dofs, range(N_FF), names, pm), [0, 3], 1, eta, w2)[0]
        np.testing.assert_allclose(dH[:, j], (Hp - Hm) / (2 * h), rtol=1e-5, atol=1e-7 * np.abs(dH[:, j]).max())


# ------------------------------------------------------------------ expected information gain
def test_information_gain_is_the_mutual_information_of_the_linear_gaussian_model():
    rng = np.random.default_rng(7)
    S = rng.standard_normal((5, 3))
    S[:, 2] = S[:, 0] + S[:, 1]  # rank-deficient: D-optimal is -inf, the gain with a prior is finite
    F = S.T @ S
    prior = np.array([0.04, 0.25, 0.01])
    post = np.linalg.inv(np.diag(1 / prior) + F)
    mutual = 0.5 * (np.sum(np.log(prior)) - np.linalg.slogdet(post)[1])
    assert design_value(F, "d") == -math.inf
    assert design_value(F, Design("d", prior)) == pytest.approx(mutual, rel=1e-12)
    assert design_value(F, Design("a", prior)) == pytest.approx(-np.trace(post), rel=1e-12)
    F2 = F + np.outer(S[0], S[0])  # more data never lowers the gain
    assert design_value(F2, Design("d", prior)) >= design_value(F, Design("d", prior))


def test_plan_with_pretest_exciters_and_information_gain():
    model = six_dof_model()
    r = plan(model, n_modes=3, points=2, n_sensors=3, n_exciters=1, sensor_mass=0.02, tam="serep",
             information_gain=True, compare=False)
    assert set(r.prior) == set(model.parameter_names)
    lo, hi = model.bounds
    np.testing.assert_allclose(list(r.prior.values()), (hi - lo) / math.sqrt(12) / model.values, rtol=1e-12)
    assert r.score["identifiable"]
    bank = SensitivityBank(model, model.dofs, range(3), list(model.parameter_names))
    S = bank.matrix(model.dof_index(r.dofs), __import__("femupdate").planning.Noise(0.002, 0.01), normalised=True)
    prior = np.array(list(r.prior.values())) ** 2
    assert r.score["design"] == pytest.approx(0.5 * np.linalg.slogdet(np.eye(6) + np.diag(prior) @ S.T @ S)[1], rel=1e-9)
    t = r.pretest["tam"]
    np.testing.assert_allclose(t["frequency_error"], 0.0, atol=1e-9)  # three dofs, three targets: SEREP exact
    ml = r.pretest["mass_loading"]
    assert np.all(np.asarray(ml["relative_shift"]) < 0)
    ex = r.exciters
    assert ex["excites_all_modes"] and len(ex["dofs"]) == 1 and ex["score"]["full_rank"]
    back = type(r).from_json(r.to_json())
    assert back.exciters["dofs"] == ex["dofs"] and back.pretest["tam"]["method"] == "serep"
    assert sla.norm(np.asarray(back.pretest["tam"]["self_orthogonality"]) - np.eye(3)) < 1e-9


def test_information_gain_needs_a_prior_or_finite_bounds_and_exciters_a_candidate_each():
    from femupdate import InputError
    from femupdate.examples import chain

    model = chain([1000.0, 1500.0, 1200.0], [1.0, 1.0, 1.0])  # bounds (0, inf): no uniform prior
    with pytest.raises(InputError, match=r"prior: parameter k1 has no normal or lognormal prior and no finite bounds"):
        plan(model, n_modes=3, points=1, information_gain=True, compare=False)
    with pytest.raises(InputError, match=r"exciters: 4 asked, but there are 3 candidate driving points"):
        plan(model, n_modes=3, points=1, n_exciters=4, compare=False)


def test_information_gain_placement_is_the_best_set_by_the_gain_computed_here():
    """Exhaustive placement by the gain against every set scored here from S, with priors that
    make it differ from the plain D-optimal set (k1..k3 known to 1 %, k4..k6 to 50 %)."""
    import itertools

    from femupdate.planning import Noise, identifiability_placement

    model = six_dof_model()
    names = list(model.parameter_names)
    bank = SensitivityBank(model, model.dofs, range(2), names)
    groups = [[i] for i in range(6)]
    prior = np.array([0.01] * 3 + [0.5] * 3) ** 2
    gain = {}
    for s in itertools.combinations(range(6), 3):
        S = bank.matrix(list(s), Noise(), normalised=True)
        gain[s] = 0.5 * np.linalg.slogdet(np.eye(6) + np.sqrt(prior)[:, None] * (S.T @ S) * np.sqrt(prior)[None, :])[1]
    eig = identifiability_placement([bank], groups, 3, Noise(), design=Design("d", prior), exhaustive_limit=100,
                                    max_condition=1e12)
    plain = identifiability_placement([bank], groups, 3, Noise(), design="d", exhaustive_limit=100, max_condition=1e12)
    ranks = {s: np.linalg.matrix_rank(bank.matrix(list(s), Noise(), normalised=True)) for s in gain}
    full = [s for s in gain if ranks[s] == 6]
    assert full and len(full) < len(gain)  # identifiability first: the rank-deficient sets are out
    assert eig.chosen == max(full, key=gain.get)
    assert eig.score.design == pytest.approx(gain[eig.chosen], rel=1e-10)
    assert plain.chosen != eig.chosen  # the prior changes the plan
