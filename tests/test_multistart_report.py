"""Honest multi-start: solutions that fit the data told apart from local minima, failures counted
by reason, one record per start, the cost shown for a solution its own, clustering near zero."""

import json

import numpy as np
import pytest
from scipy.stats import chi2

from femupdate import MeasuredMode, TestData, model_modes
from femupdate.cli import main
from femupdate.distinct import cluster
from femupdate.examples import example_files, two_dof
from femupdate.frf import simulate
from femupdate.generators import shear_building
from femupdate.updating import frf_multistart, multistart
from femupdate.updating.clustering import fit_threshold
from femupdate.updating.results import MultiStartResult, failure_reason


def frequencies(model, n, values=None):
    modes = model_modes(model, values)
    return TestData(modes=tuple(MeasuredMode(modes.eigenvalues[j]) for j in range(n)))


def test_both_exact_solutions_of_the_figure_3_system_fit_and_are_the_headline(tmp_path, capsys):
    files = example_files()
    (tmp_path / "m.toml").write_text(files["two_dof.toml"])
    (tmp_path / "d.json").write_text(files["two_dof_frequencies.json"])
    with pytest.raises(SystemExit) as info:
        main(["update", str(tmp_path / "m.toml"), str(tmp_path / "d.json"), "--starts", "40", "--json",
              str(tmp_path / "r.json")])
    out = capsys.readouterr().out
    assert info.value.code == 0
    head = out.split("\n", 1)[0]
    assert head.startswith("2 distinct solutions fit the data equally well")
    table = out.split("the lowest-cost solution in detail")[0]
    assert "9 " in table and "5.33333" in table and "8 " in table and "6 " in table  # (8, 6) and (9, 16/3)
    res = json.loads((tmp_path / "r.json").read_text())["starts"]
    assert res["fitting"] == 2 and [s["fits"] for s in res["solutions"]] == [True, True]
    sols = sorted((round(s["parameters"]["k1"], 6), round(s["parameters"]["k2"], 6)) for s in res["solutions"])
    assert sols == [(8.0, 6.0), (9.0, round(16 / 3, 6))]
    assert len(res["runs"]) == 40 and {r["outcome"] for r in res["runs"]} == {"fits"}
    assert sum(s["count"] for s in res["solutions"]) == 40


def test_local_minima_are_told_apart_from_the_solution_that_fits():
    model = two_dof()
    from dataclasses import replace

    model = replace(model, parameters=tuple(replace(p, bounds=(1.0, 13.0)) for p in model.parameters))
    data = simulate(model, 0.4 * np.arange(1, 8), {"1:x": 1.0}, response=["1:x", "2:x"])  # noise-free
    ms = frf_multistart(model, data, starts=30, seed=4, resonance="keep")
    assert ms.fitting and ms.local_minima, "this case has both (the linear FRF residual's local minima)"
    np.testing.assert_allclose(list(ms.fitting[0].parameters.values()), [8.0, 6.0], rtol=1e-6)
    assert all(s.cost <= ms.fit_cost for s in ms.fitting) and all(s.cost > ms.fit_cost for s in ms.local_minima)
    assert ms.solutions[:len(ms.fitting)] == ms.fitting  # the fitting ones first
    local_costs = [s.cost for s in ms.local_minima]
    assert local_costs == sorted(local_costs)
    outcomes = {r["outcome"] for r in ms.records()}
    assert outcomes <= {"fits", "local minimum", "not converged", "failed"} and "local minimum" in outcomes


def test_with_stated_noise_the_threshold_is_the_likelihood_ratio_bound():
    model = shear_building(4).build()
    rng = np.random.default_rng(3)
    clean = frequencies(model, 4)
    sigma = 1e-3
    data = TestData(modes=tuple(MeasuredMode(m.eigenvalue * (1 + sigma * rng.standard_normal())) for m in clean.modes))
    ms = multistart(model, data, starts=6, seed=1, measurement_std={"eigenvalue": sigma}, batched=False)
    best = ms.best
    assert best.diagnostics.absolute
    L = len(best.names)
    floor = 1e-14 * max(best.history[0]["cost"], best.cost)
    assert ms.fit_cost == pytest.approx(best.cost + 0.5 * chi2.ppf(0.95, L) + floor, rel=1e-12)
    assert fit_threshold(best) == ms.fit_cost


def test_failures_are_counted_by_reason_and_recorded_per_start():
    assert failure_reason("NumericalError: test mode(s) [3] pair with no model mode (MAC below 0.5 for all 12 "
                          "computed modes): check the dof labels") == \
        "test mode(s) [#] pair with no model mode (MAC below # for all # computed modes)"
    # a subject and what befell it: the subject alone ("test mode #") would tell nothing
    assert failure_reason("NumericalError: test mode 2: no model mode left to pair with") == \
        "test mode #: no model mode left to pair with"
    runs = ["NumericalError: test mode(s) [3] pair with no model mode (MAC below 0.5): x",
            "NumericalError: test mode(s) [1] pair with no model mode (MAC below 0.5): y",
            "InputError: starting value(s) outside the bounds for: k1"]
    ms = MultiStartResult(None, [], runs, np.zeros((3, 1)), ("k1",), 3, 0, 0)
    assert ms.failures == {"test mode(s) [#] pair with no model mode (MAC below #)": 2,
                           "starting value(s) outside the bounds for": 1}
    assert [r["outcome"] for r in ms.records()] == ["failed"] * 3


def test_the_cost_shown_for_the_best_solution_is_its_cost_on_the_compiled_route():
    model = shear_building(6).build()
    truth = model_modes(model, model.values * np.linspace(1.1, 0.8, 6))
    sensors = [1, 3, 5]
    data = TestData(modes=tuple(MeasuredMode(truth.eigenvalues[j], tuple(model.dofs[i] for i in sensors),
                                             truth.shapes[sensors, j]) for j in range(4)))
    ms = multistart(model, data, starts=12, seed=2)
    assert type(ms.runs[0]).__name__ == "BatchRun"
    owner = next(s for s in ms.solutions if any(ms.runs[k].cost == min(r.cost for r in ms.runs if not isinstance(r, str))
                                                 for k in s.starts))
    assert owner.cost == ms.best.cost
    assert owner.parameters == dict(zip(ms.names, map(float, ms.best.x)))


def test_parameters_near_zero_cluster_by_absolute_distance_below_their_scale():
    pts = np.array([[1e-9, 5.0], [2e-9, 5.0000001], [0.3, 5.0]])
    costs = np.array([1e-20, 2e-20, 1e-20])
    assert len(cluster(pts, costs, 1e-4)) == 3  # purely relative: 1e-9 and 2e-9 are "far apart"
    assert sorted(map(sorted, cluster(pts, costs, 1e-4, scale=[1.0, 5.0]))) == [[0, 1], [2]]
