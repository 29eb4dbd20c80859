"""Test planning (femupdate.planning, issue 32): placement criteria against independent
implementations and exact bounds, the Fisher information against finite differences, the
predicted standard deviations against a Monte Carlo of noisy updates."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
import scipy.linalg as sla

import femupdate as fu
from femupdate.examples import chain, portal_frame
from femupdate.modal import model_modes
from femupdate.paper.uniqueness_sections import six_dof_model
from femupdate.planning import (Noise, SensitivityBank, candidates, classical_placement, identifiability_placement,
                                monte_carlo, plan, predicted_std, target_modes)
from femupdate.planning.fisher import parameter_points
from femupdate.planning.targets import effective_mass_fractions, influence_vector
from femupdate.uniqueness.chain import chain_rank_bound


def _banks(model, n_modes, n_points=4, seed=0):
    cand = candidates(model)
    names = list(model.parameter_names)
    points, _ = parameter_points(model, names, n_points, seed=seed)
    b0 = SensitivityBank(model, cand.dofs, range(n_modes), names, points[0])
    banks = [b0] + [SensitivityBank(model, cand.dofs, range(n_modes), names, p, reference=b0.shapes_full)
                    for p in points[1:]]
    return cand, banks, [cand.rows([i]) for i in range(len(cand.sensors))]


def _kammer(phi: np.ndarray, n: int) -> list[int]:
    """Kammer (1991) from the definition: delete, one at a time, the candidate of smallest
    E_ii, E = Φ (ΦᵀΦ)⁻¹ Φᵀ recomputed from scratch on the remaining rows."""
    keep = list(range(phi.shape[0]))
    while len(keep) > n:
        P = phi[keep]
        E = np.diag(P @ np.linalg.inv(P.T @ P) @ P.T)
        del keep[int(np.argmin(E))]
    return keep


# ------------------------------------------------------------------ classical criteria
def test_effective_independence_agrees_with_kammer_written_from_the_definition():
    model = portal_frame()
    cand = candidates(model)
    modes = model_modes(model, n_modes=4)
    phi = modes.shapes[model.dof_index(cand.dofs)]
    groups = [[i] for i in range(len(cand.dofs))]
    for n in (4, 6, 9):
        res = classical_placement(phi, groups, n, "efi", exchange=False)
        assert list(res.chosen) == sorted(_kammer(phi, n))
        assert list(res.chosen) == sorted(cand.dofs.index(d) for d in
                                          fu.reduction.effective_independence(model, n, 4, cand.dofs).selected)
        ex = classical_placement(phi, groups, n, "efi")
        assert ex.objective >= res.objective - 1e-12  # the exchange never loses information
        P = phi[list(ex.chosen)] / np.linalg.norm(phi, axis=0)
        assert ex.objective == pytest.approx(np.linalg.slogdet(P.T @ P)[1], rel=1e-12)


def test_triaxial_effective_independence_removes_the_node_that_costs_least_information():
    """A triaxial sensor is removed as a block: each step drops the node whose removal leaves the
    largest det(ΦᵀΦ), checked by trying every removal."""
    model = portal_frame()
    cand = candidates(model, kind="triaxial")
    modes = model_modes(model, n_modes=4)
    phi = modes.shapes[model.dof_index(cand.dofs)]
    phi = phi / np.linalg.norm(phi, axis=0)
    groups = [cand.rows([i]) for i in range(len(cand.sensors))]
    res = classical_placement(phi, groups, 3, "efi", exchange=False)
    active = list(range(len(groups)))
    for removed in res.removed:
        dets = {g: np.linalg.det(phi[[r for h in active if h != g for r in groups[h]]].T
                                 @ phi[[r for h in active if h != g for r in groups[h]]]) for g in active}
        assert removed == max(dets, key=lambda g: dets[g])
        active.remove(removed)
    assert sorted(active) == list(res.chosen)


def test_fixed_sensors_stay_and_kinetic_energy_keeps_the_most_energetic():
    model = portal_frame()
    cand = candidates(model)
    modes = model_modes(model, n_modes=3)
    rows = model.dof_index(cand.dofs)
    phi = modes.shapes[rows]
    energy = phi * (model.M() @ modes.shapes)[rows]
    groups = [[i] for i in range(len(cand.dofs))]
    res = classical_placement(phi, groups, 5, "kinetic", energy=energy, exchange=False)
    assert sorted(res.chosen) == sorted(np.argsort(-energy.sum(axis=1), kind="stable")[:5].tolist())
    res = classical_placement(phi, groups, 5, "efi", fixed=[0, 1])
    assert {0, 1} <= set(res.chosen)
    mac = classical_placement(phi, groups, 4, "mac")
    dpr = classical_placement(phi, groups, 4, "efi-dpr", eigenvalues=modes.eigenvalues[:3])
    assert mac.objective >= mac.objective_eliminated and dpr.objective >= dpr.objective_eliminated


def test_target_modes_by_effective_mass_and_energy():
    model = portal_frame()
    modes = model_modes(model)  # every mode: the effective-mass fractions add up to one
    frac = effective_mass_fractions(model, modes, influence_vector(model, "x"))
    assert frac.sum() == pytest.approx(1.0, rel=1e-10)
    t = target_modes(model, modes, method="mass", direction="x", min_fraction=0.05)
    assert set(t.indices) == set(np.flatnonzero(frac >= 0.05).tolist())
    e = target_modes(model, modes, method="energy", min_fraction=0.999, n_modes=4)
    assert len(e.indices) == 4 and np.allclose(e.fractions, 1.0)  # all dofs: the whole kinetic energy
    with pytest.raises(fu.InputError, match="band"):
        target_modes(model, modes, method="lowest", n_modes=2, band_hz=(50.0, 10.0))


# ------------------------------------------------------------------ identifiability
def test_identifiability_plan_meets_the_exact_layout_rank_bound_on_chains():
    """The greedy plan with exchange reaches, for every number of sensors and modes, the best rank
    that any layout allows (the maximum of the layout rank bound over all layouts)."""
    rng = np.random.default_rng(7)
    for model in (six_dof_model(), chain(rng.uniform(500, 2000, 8), rng.uniform(0.5, 1.5, 8))):
        N = model.n_dofs
        for m in range(1, N + 1) if N == 6 else (2, 3, 4):
            _, banks, groups = _banks(model, m, n_points=2)
            for n in range(1, N + 1) if N == 6 else (2, 3):
                best = max(min(chain_rank_bound(N, s, m), m * n if n > 1 else m)
                           for s in itertools.combinations(range(1, N + 1), n))
                res = identifiability_placement(banks, groups, n, Noise())
                assert res.score.ranks[0] == best, (N, m, n, res.chosen)


def test_smallest_identifiable_plan_agrees_with_the_six_dof_study():
    """The paper's six-dof study: unique iff the layout rank bound is L and n > 1, which spread
    sensors meet with mn >= 6.  The smallest plan is max(2, ceil(6/m)) sensors for every m, and
    femupdate's uniqueness study (random starts, noise-free) finds each plan unique."""
    from femupdate.uniqueness import define_study, run_study

    model = six_dof_model()
    chosen = []
    for m in range(1, 7):
        res = plan(model, n_modes=m, points=4, compare=False)
        assert len(res.dofs) == max(2, math.ceil(6 / m)), (m, res.dofs)
        assert res.uniqueness["layout_rank_bound"] == 6 and res.verdict == "unique"
        assert res.uniqueness["counting_lower_bound"]["n_min"] == max(2, math.ceil(6 / m))
        chosen.append((tuple(res.dofs), m))
    study = run_study(define_study(model, chosen + [(("1:x", "2:x"), 3)], starts=30, seed=1))
    assert [c.verdict for c in study.cases] == ["unique"] * 6 + ["non-unique"]  # 1,2 with 3 modes: rank 5


def test_fisher_information_against_finite_differences():
    model = six_dof_model()
    cand, banks, _ = _banks(model, 3, n_points=0)
    rows = [0, 2, 3, 5]
    noise = Noise(1e-3, 2e-3)
    S = banks[0].matrix(rows, noise)
    p0 = model.values.copy()
    K0, M0 = model.K(p0).toarray(), model.M(p0).toarray()
    lam0, P0 = sla.eigh(K0, M0)

    def data(p):
        lam, P = sla.eigh(model.K(p).toarray(), model.M(p).toarray())
        P = P * np.sign(np.sum(P * P0, axis=0))
        out = [lam[:3] / lam0[:3] / noise.eigenvalue]
        for i in range(3):
            v = P[rows, i]
            out.append(v / np.linalg.norm(v) / noise.shape)
        return np.concatenate(out)

    cols = []
    for j in range(model.n_dofs):
        h = 1e-6 * p0[j]
        pp, pm = p0.copy(), p0.copy()
        pp[j] += h
        pm[j] -= h
        cols.append((data(pp) - data(pm)) / (2 * h))
    S_fd = np.array(cols).T
    F, F_fd = S.T @ S, S_fd.T @ S_fd
    assert np.max(np.abs(F - F_fd)) <= 1e-6 * np.max(np.abs(F_fd))


def test_monte_carlo_standard_deviations_agree_with_the_predicted_ones():
    model = six_dof_model()
    res = plan(model, n_modes=3, std_eigenvalue=1e-3, std_shape=1e-3, points=2, monte_carlo=100, seed=4,
               compare=False)
    mc = res.monte_carlo
    assert mc["converged"] == 100
    # the relative standard error of a sample std is 1/sqrt(2(n-1)); 4 of them over 6 parameters
    assert np.all(np.abs(mc["ratio"] - 1) <= 4 * mc["sampling_error"]), mc["ratio"]
    assert np.all(np.abs(mc["bias"]) <= 4 * mc["predicted_std"] / math.sqrt(mc["runs"]))
    std = np.array([res.predicted_std[n] for n in res.parameters])
    assert np.allclose(mc["predicted_std"], std)


def test_triaxial_sensors_and_the_frame():
    model = portal_frame()
    res = plan(model, n_modes=4, kind="triaxial", n_sensors=2, points=3, fixed=["6"])
    assert all(len(s) == 2 for s in res.sensors)  # the planar frame's nodes have x and y
    assert ["6:x", "6:y"] in res.sensors
    assert res.score["identifiable"] and res.verdict == "locally identifiable"
    assert res.uniqueness["layout_rank_bound"] is None  # not a chain
    back = type(res).from_json(res.to_json())
    assert back.sensors == res.sensors and back.predicted_std == pytest.approx(res.predicted_std)


# ------------------------------------------------------------------ bad input
def test_bad_input_is_named():
    model = six_dof_model()
    with pytest.raises(fu.InputError, match="7 asked, but there are only 6 candidate"):
        plan(model, n_sensors=7)
    with pytest.raises(fu.InputError, match=r"unknown candidate dof\(s\) 9:x, 12:X"):
        plan(model, candidates=["1:x", "9:x", "12:X"])
    with pytest.raises(fu.InputError, match="k2 has lower 5000 >= upper 100"):
        plan(model, box={"k2": (5000.0, 100.0)})
    with pytest.raises(fu.InputError, match="std_shape must be > 0"):
        plan(model, std_shape=0.0)
    with pytest.raises(fu.InputError, match="unknown candidate node"):
        plan(portal_frame(), kind="triaxial", candidates=["99"])


def test_too_few_candidates_for_the_rank_bound_are_refused_with_the_bound():
    """Issue 32 item 7: the bound is said.  m eigenvalues and unit-scaled shapes at n dofs give at
    most mn rows (mn = 3 < 6: at least ceil(6/3) = 2 dofs); on the chain the layout rank bound with
    every candidate measured, checked against the rank of S itself (a second route)."""
    model = six_dof_model()
    with pytest.raises(fu.InputError, match=r"candidates: 1 candidate dof\(s\) \(1:x\) with 3 target mode\(s\) bound "
                                            r"the rank by mn = 3 < 6 parameters.*at least 2 candidate dofs"):
        plan(model, n_modes=3, candidates=["1:x"], points=1, compare=False, tam="none")
    for cands, bound in ((["1:x", "2:x"], chain_rank_bound(6, [1, 2], 3)), (["5:x", "6:x"], chain_rank_bound(6, [5, 6], 3))):
        bank = SensitivityBank(model, cands, [0, 1, 2], list(model.parameter_names), model.values)
        rank = int(np.linalg.matrix_rank(bank.matrix([0, 1], normalised=True)))
        assert rank == bound < 6, (cands, rank, bound)
        with pytest.raises(fu.InputError, match=rf"layout rank bound of this grounded chain is {bound} < 6 parameters"):
            plan(model, n_modes=3, candidates=cands, points=1, compare=False, tam="none")
    res = plan(model, n_modes=3, candidates=["1:x", "6:x"], points=1, compare=False, tam="none")  # bound 6: accepted
    assert res.verdict == "unique"


def test_parameters_no_sensor_set_identifies_are_named():
    s = fu.Structure("two springs side by side")  # ka and kb act only through ka + kb
    for name, v in (("ka", 100.0), ("kb", 200.0), ("kc", 300.0)):
        s.parameter(name, v, (10.0, 1000.0))
    s.spring(["1:x"], k="ka")
    s.spring(["1:x"], k="kb")
    s.spring(["1:x", "2:x"], k="kc")
    s.mass(["1:x"], m=1.0)
    s.mass(["2:x"], m=1.0)
    with pytest.raises(fu.InputError, match=r"no sensor set identifies ka, kb from these 2 target mode\(s\).*only 2 "
                                            "of the 3"):
        plan(s.build(), n_modes=2)


def _plate(nx=4, ny=3, a=0.6, b=0.35):
    """A cantilever aluminium plate of shells in three zones of E (nodes slightly skewed: no symmetry)."""
    s = fu.Structure("cantilever plate")
    for name in ("E_root", "E_mid", "E_tip"):
        s.parameter(name, 7.0e10, (3.5e10, 1.4e11))

    def nid(i, j):
        return 1 + i + (nx + 1) * j

    for j in range(ny + 1):
        for i in range(nx + 1):
            s.node(nid(i, j), (a * i / nx, b * j / ny + 0.02 * (i / nx) ** 2, 0.0))
    for j in range(ny):
        for i in range(nx):
            zone = ("E_root", "E_mid", "E_tip")[min(2, 3 * i // nx)]
            s.shell([nid(i, j), nid(i + 1, j), nid(i + 1, j + 1), nid(i, j + 1)], E=zone, nu=0.33, t=0.003,
                    rho=2700.0)
    s.support_node([nid(0, j) for j in range(ny + 1)])
    return s.build()


def test_plate_plan_tells_the_target_modes_apart_when_asked(tmp_path):
    from femupdate.io.plan_uff import write_plan_uff

    model = _plate()
    loose = plan(model, n_modes=4, kind="triaxial", points=2, compare=False)
    strict = plan(model, n_modes=4, kind="triaxial", points=2, compare=False, max_automac=0.8)
    assert loose.score["identifiable"] and strict.score["identifiable"]
    assert strict.automac_max <= 0.8 < loose.automac_max  # one node sees the modes alike; more sensors do not
    assert len(strict.sensors) > len(loose.sensors)
    info = write_plan_uff(tmp_path / "plate.uff", strict)
    assert not info["placed"] and set(info["systems"].values()) == {"global"}  # triaxial: global axes


def test_design_criteria_exchange_against_every_set():
    """D- and A-optimal: the exhaustive route finds the best of all sets (checked by scoring every
    set here), and greedy selection with exchange never beats it."""
    from femupdate.planning import score_set

    model = six_dof_model()
    for m in (2, 3):
        _, banks, groups = _banks(model, m, n_points=2)
        for design in ("d", "a"):
            every = {s: score_set(banks, list(s), Noise(), design) for s in itertools.combinations(range(6), 3)}
            best = max(s.design for s in every.values() if s.identifiable)
            exact = identifiability_placement(banks, groups, 3, Noise(), design=design, exhaustive_limit=100)
            greedy = identifiability_placement(banks, groups, 3, Noise(), design=design)
            assert exact.score.identifiable and exact.score.design == best
            assert greedy.score.identifiable and greedy.score.design <= best


def test_fixed_sensors_are_kept_and_completed_only_as_needed():
    model = six_dof_model()
    assert plan(model, n_modes=3, fixed=["1:x", "5:x"], points=2, compare=False).dofs == ["1:x", "5:x"]
    res = plan(model, n_modes=3, fixed=["1:x", "2:x"], points=2, compare=False)  # rank 5 alone (layout bound)
    assert res.dofs[:2] == ["1:x", "2:x"] and len(res.dofs) == 3 and res.verdict == "unique"
