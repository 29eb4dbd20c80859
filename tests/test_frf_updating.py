"""Iterative FRF updating (eqs. 30-32), multi-start and global search: closed loops from perturbed
starts and noisy data, the analytic Jacobian against finite differences, resonance handling, the
same result object as modal updating, and local vs Dask runs."""

import numpy as np
import pytest

from femupdate import InputError, MeasuredMode, NumericalError, TestData, model_modes
from femupdate.examples import chain, three_dof, two_dof
from femupdate.frf import Damping, simulate
from femupdate.updating import GlobalSearchResult, global_search
from femupdate.updating import FRFProblem, FRFUpdateResult, frf_multistart, frf_update
from femupdate.updating import MultiStartResult, UpdateResult, draw_starts

K6 = np.array([120.0, 90.0, 150.0, 80.0, 110.0, 100.0])
M6 = np.array([1.0, 1.4, 0.8, 1.2, 1.0, 0.9])


def six():
    return chain(K6, M6, bounds=(1.0, 1000.0))


def window_two_dof():
    from dataclasses import replace

    m = two_dof()
    return replace(m, parameters=tuple(replace(p, bounds=b) for p, b in zip(m.parameters, ((3.0, 13.0), (1.0, 11.0)))))


@pytest.mark.parametrize("residual", ["linear", "relative", "log"])
def test_closed_loop_from_one_sensor(residual):
    truth = three_dof()
    lam = model_modes(truth).eigenvalues
    # no line next to an anti-resonance: log|x| -> -inf there, a barrier the "log" residual cannot cross
    w = np.sqrt(lam[0]) * np.array([0.5, 0.8, 1.2, 1.5, 1.9, 2.3, 2.9])
    data = simulate(truth, w, {"3:x": 1.0}, response=["3:x"])  # one sensor, three unknowns
    res = frf_update(truth, data, x0={"k1": 800.0, "k2": 2400.0, "k3": 1300.0}, residual=residual)
    assert isinstance(res, FRFUpdateResult) and isinstance(res, UpdateResult)
    assert res.success and res.sensitivity == "brandon"
    np.testing.assert_allclose(res.x, truth.values, rtol=1e-7)
    assert res.frac["3:x"] == pytest.approx(1.0, abs=1e-12)
    assert res.diagnostics.rank == 3 and res.history[0]["cost"] > res.cost


def test_noisy_damped_data_recovered_within_their_uncertainty():
    truth = six()
    damping = Damping(alpha=0.05, eta=0.01)
    lam = model_modes(truth).eigenvalues
    w = np.linspace(0.3, 1.1, 40) * np.sqrt(lam[-1])
    clean = simulate(truth, w, {"6:x": 1.0}, response=["1:x", "4:x", "6:x"], damping=damping)
    sigma = 0.01
    data = simulate(truth, w, {"6:x": 1.0}, response=["1:x", "4:x", "6:x"], damping=damping, noise=sigma, seed=7)
    start = dict(zip(truth.parameter_names, K6 * np.array([1.3, 0.8, 1.2, 0.75, 1.25, 0.9])))
    # relative complex noise of std sigma: each real/imaginary residual of the "relative" form has std sigma/sqrt(2)
    res = frf_update(truth, data, x0=start, residual="relative", damping=damping,
                     measurement_std=sigma / np.sqrt(2) * np.abs(clean.response) / np.abs(data.response))
    std = res.diagnostics.std
    assert res.success and np.all(np.isfinite(std)) and np.all(std > 0)
    z = (res.x - K6) / std
    assert np.max(np.abs(z)) < 4.5, z
    assert np.all(std / K6 < 0.05)


@pytest.mark.parametrize("residual", ["linear", "relative", "log"])
@pytest.mark.parametrize("solver", ["dense", "sparse"])
def test_jacobian_equals_finite_differences(residual, solver):
    m = six()
    damping = Damping(beta=1e-3, eta=0.02)
    w = np.linspace(2, 14, 9)
    data = simulate(m, w, {"6:x": 1.0, "2:x": 0.5j}, response=["1:x", "5:x"], damping=damping)
    prob = FRFProblem(m, data, ["k1", "k3", "k6"], "log", m.values * 1.1, residual, None, np.arange(9), damping, solver)
    x = np.log(m.values[[0, 2, 5]] * 1.2)
    J = prob.jacobian(x)
    h = 1e-6
    Jfd = np.column_stack([(prob.residuals(x + h * e) - prob.residuals(x - h * e)) / (2 * h) for e in np.eye(3)])
    np.testing.assert_allclose(J, Jfd, rtol=1e-5, atol=1e-7 * np.abs(Jfd).max())


def test_lines_on_a_resonance_are_skipped_refused_or_kept(caplog):
    m = two_dof()
    lam = model_modes(m).eigenvalues
    w = np.array([0.5, 1.0, 1.5, np.sqrt(lam[1]) * (1 + 1e-5), 2.0])
    data = simulate(window_two_dof(), w, {"2:x": 1.0}, values=[7.0, 5.0])  # the "test" structure differs
    res = frf_update(m, data)
    assert [s["line"] for s in res.skipped] == [4] and res.omega.size == 4
    assert "line 4" in caplog.text and "skipped near resonance" in res.notes[0]
    np.testing.assert_allclose(res.x, [7.0, 5.0], rtol=1e-7)
    with pytest.raises(InputError, match=r"coincide with resonances of the model: line 4 \(2.77908 rad/s"):
        frf_update(m, data, resonance="error")
    kept = frf_update(m, data, resonance="keep")
    assert kept.omega.size == 5 and not kept.skipped


def test_line_choice_selection_regularisation_and_modal_report():
    m = two_dof()
    w = 0.25 * np.arange(1, 13)
    data = simulate(m, w, {"1:x": 1.0}, response=["2:x"])
    modes = model_modes(m)
    both = TestData(modes=(MeasuredMode(modes.eigenvalues[0], ("1:x", "2:x"), modes.shapes[:, 0]),), frf=data)
    res = frf_update(m, both, lines=[0, 4, 8], x0={"k1": 6.0, "k2": 7.0})
    np.testing.assert_allclose(res.omega, w[[0, 4, 8]])
    np.testing.assert_allclose(res.x, [8, 6], rtol=1e-8)
    assert res.pairs[0][:2] == (0, 0) and res.pairs[0][2] == pytest.approx(1.0)
    np.testing.assert_allclose(res.model_frequencies_hz, modes.frequencies_hz[:1], rtol=1e-8)
    sel = frf_update(m, data, select=3, x0={"k1": 6.0, "k2": 7.0})
    assert sel.omega.size == 3 and any("selected 3 lines" in n for n in sel.notes)
    mask = np.zeros(12, bool)
    mask[[1, 2]] = True
    reg = frf_update(m, data, lines=mask, regularization="gcv", x0={"k1": 6.0, "k2": 7.0})
    assert reg.regularization["rule"] == "gcv" and reg.regularization["alpha"] >= 0
    with pytest.raises(InputError, match="2 parameters but only 1 residuals"):
        frf_update(m, data, lines=[3])
    with pytest.raises(InputError, match=r"line\(s\) 13 \(counted from 1; index\(es\) 12 from 0\) outside the data's 12 lines"):
        frf_update(m, data, lines=[12])
    with pytest.raises(InputError, match="unknown FRF residual"):
        frf_update(m, data, residual="cubic")
    with pytest.raises(InputError, match="FRF updating needs FRF test data"):
        frf_update(m, TestData(modes=both.modes))


def test_non_convergence_is_a_status():
    m = two_dof()
    data = simulate(m, 0.5 * np.arange(1, 6), {"1:x": 1.0})
    res = frf_update(m, data, x0={"k1": 60.0, "k2": 70.0}, max_nfev=2)
    assert not res.success and res.status == 0


def test_multistart_uses_the_modal_starts_and_format():
    m = window_two_dof()
    data = simulate(m, 0.4 * np.arange(1, 8), {"1:x": 1.0})
    ms = frf_multistart(m, data, starts=12, seed=4, resonance="keep")
    assert isinstance(ms, MultiStartResult) and ms.total == 12
    np.testing.assert_array_equal(ms.starts, draw_starts(m, ("k1", "k2"), 12, 4))
    assert sum(s.count for s in ms.solutions) == ms.converged
    truth = [s for s in ms.solutions if abs(s.parameters["k1"] - 8) < 1e-6]
    assert truth and truth[0].cost < 1e-20
    assert ms.best.cost == min(s.cost for s in ms.solutions)


def test_global_search_finds_the_truth_on_the_rough_surface():
    m = window_two_dof()
    data = simulate(m, 0.4 * np.arange(1, 8), {"1:x": 1.0}, response=["2:x"])
    local = frf_multistart(m, data, starts=20, seed=0, resonance="keep", residual="linear")  # the paper's eq. 34
    local_hits = sum(s.count for s in local.solutions if abs(s.parameters["k1"] - 8) < 1e-6)
    de = global_search(m, data, runs=3, seed=0, resonance="keep")
    assert isinstance(de, GlobalSearchResult) and de.method == "differential_evolution"
    assert de.solutions[0].count == 3 and de.best.x == pytest.approx([8.0, 6.0], rel=1e-8)
    # the solution at the truth fits the data (it used to be listed as a local minimum, fit_cost NaN)
    assert de.solutions[0].fits and len(de.fitting) == 1 and de.local_minima == [] and np.isfinite(de.fit_cost)
    assert local_hits < 10  # most local starts fail on this surface (the paper's point)
    bh = global_search(m, data, method="basinhopping", runs=1, seed=1, resonance="keep", options={"niter": 15})
    assert len(bh.optimizer[0]["minima"]) >= 2  # the random walk visits several local minima
    da = global_search(m, data, method="dual_annealing", runs=1, seed=2, resonance="keep", options={"maxiter": 200})
    assert da.optimizer[0]["nfev"] > 100 and np.isfinite(da.best.cost)
    with pytest.raises(InputError, match="unknown global method"):
        global_search(m, data, method="genetic")
    with pytest.raises(InputError, match="finite bounds; give bounds for: k1"):
        global_search(chain([8.0, 6.0], [2.0, 4.0]), data)


def test_dask_runs_match_local_runs():
    distributed = pytest.importorskip("distributed")
    m = window_two_dof()
    data = simulate(m, 0.4 * np.arange(1, 8), {"1:x": 1.0})
    local = frf_multistart(m, data, starts=6, seed=3, resonance="keep")
    glocal = global_search(m, data, runs=2, seed=5, resonance="keep", options={"maxiter": 30})
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                                  dashboard_address=None) as cluster:
        remote = frf_multistart(m, data, starts=6, seed=3, resonance="keep", scheduler=cluster.scheduler_address)
        gremote = global_search(m, data, runs=2, seed=5, resonance="keep", options={"maxiter": 30},
                                scheduler=cluster.scheduler_address)
    assert [(s.count, round(s.parameters["k1"], 8)) for s in remote.solutions] == \
        [(s.count, round(s.parameters["k1"], 8)) for s in local.solutions]
    np.testing.assert_array_equal(gremote.starts, glocal.starts)
    assert [r.cost for r in gremote.runs] == pytest.approx([r.cost for r in glocal.runs], rel=1e-9, abs=1e-25)


def test_singular_evaluation_is_a_numerical_error():
    from femupdate import Structure

    s = Structure("unit")
    s.parameter("k", 2.0, (0.1, 10))
    s.spring(["1:x"], k="k")
    s.mass(["1:x"], m=1.0)
    m = s.build()
    data = simulate(m, [1.0, 3.0], {"1:x": 1.0})
    prob = FRFProblem(m, data, ["k"], "absolute", m.values, "linear", None, np.arange(2), Damping(), "auto")
    with pytest.raises(NumericalError, match=r"line 1 \(omega = 1 rad/s\)"):
        prob.residuals(np.array([1.0]))  # k = 1: the line at 1 rad/s is exactly on the resonance


def test_readme_example():
    """The FRF example of docs/python-api.md, as printed there (tests/test_docs_examples.py runs the page too)."""
    from femupdate.examples import two_dof
    from femupdate.frf import receptance_sensitivity, simulate
    from femupdate.updating import frf_update, global_search

    model = two_dof()                                    # the paper's Figure 3 system: k1 = 8, k2 = 6 N/m
    lines = 0.4 * np.arange(1, 8)                        # Figure 7's seven lines, 0.4 rad/s apart
    data = simulate(model, lines, {"1:x": 1.0}, response=["2:x"], noise=1e-3, seed=1)
    res = frf_update(model, data, x0={"k1": 7.0, "k2": 6.5})          # eqs. 30-32, one sensor
    sens = receptance_sensitivity(model, lines, ["2:x"], ["1:x"])      # eq. 32: (7, 1, 1, 2)
    best = global_search(model, data, runs=2, seed=0)                  # differential evolution + polish
    assert sens.dalpha.shape == (7, 1, 1, 2)
    for p in (res.x, best.best.x):
        np.testing.assert_allclose(p, [8.0, 6.0], rtol=2e-3)  # 0.1 % noise
