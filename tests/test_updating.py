import json

import numpy as np
import pytest

from femupdate import InputError, MeasuredMode, NumericalError, Structure, TestData, model_modes
from femupdate.examples import chain, two_dof
from femupdate.updating import Problem, cluster, draw_starts, multistart, update

K6 = np.array([1000.0, 1800.0, 1500.0, 1200.0, 900.0, 1600.0])
M6 = np.array([1.0, 1.2, 0.8, 1.1, 0.9, 1.0])


def measured(model, dofs, n_modes, values=None, noise=0.0, rng=None, scale=1.0):
    mm = model_modes(model, values)
    pos = model.dof_index(dofs)
    out = []
    for r in range(n_modes):
        shape = mm.shapes[pos, r] * scale
        if noise:
            shape = shape + noise * np.abs(shape).max() * rng.standard_normal(len(dofs))
        out.append(MeasuredMode(mm.eigenvalues[r], dofs, shape))
    return TestData(modes=tuple(out))


def six_dof(bounds=(100.0, 5000.0)):
    return chain(K6, M6, bounds=bounds)


@pytest.mark.parametrize("scaling", ["unit", "ref", "max"])
@pytest.mark.parametrize("parametrisation", ["relative", "log", "absolute"])
def test_closed_loop_incomplete_shapes(scaling, parametrisation):
    model = six_dof()
    data = measured(model, ["2:x", "4:x", "6:x"], 3)
    res = update(model, data, x0=dict(zip(model.parameter_names, K6 * [0.7, 1.3, 0.8, 1.2, 1.1, 0.9])),
                 shape_scaling=scaling, parametrisation=parametrisation)
    assert res.success
    np.testing.assert_allclose(res.x, K6, rtol=1e-6)
    assert res.cost < 1e-16
    assert [p[:2] for p in res.pairs] == [(0, 0), (1, 1), (2, 2)]
    assert res.history[0]["cost"] > res.history[-1]["cost"]


@pytest.mark.parametrize("method", ["trf", "dogbox", "lm"])
def test_methods_agree(method):
    model = six_dof()
    data = measured(model, ["1:x", "3:x", "5:x", "6:x"], 3)
    res = update(model, data, x0=dict(zip(model.parameter_names, K6 * 0.8)), method=method)
    np.testing.assert_allclose(res.x, K6, rtol=1e-6)


def test_analytic_jacobian_matches_finite_differences():
    from scipy.optimize._numdiff import approx_derivative

    model = six_dof()
    data = measured(model, ["2:x", "3:x", "6:x"], 3)
    for scaling, ref in (("unit", None), ("ref", "3:x"), ("max", None)):
        prob = Problem(model, data, x0=dict(zip(model.parameter_names, model.values * 1.1)), shape_scaling=scaling,
                       ref_dof=ref)
        x = np.ones(6)
        J = prob.jacobian(x)
        Jfd = approx_derivative(prob.residuals, x, method="3-point", rel_step=1e-6)
        np.testing.assert_allclose(J, Jfd, atol=1e-6 * np.abs(Jfd).max())


def long_chain(n=1600, k=(2.0e6, 1.5e6, 1.8e6, 1.2e6)):
    """A grounded chain of n unit masses above the dense limit; the springs in len(k) grouped segments."""
    s = Structure("long chain")
    for j, kj in enumerate(k):
        s.parameter(f"k{j + 1}", kj, (1e5, 1e8))
    for i in range(1, n + 1):
        s.spring([f"{i}:x"] if i == 1 else [f"{i - 1}:x", f"{i}:x"], k=f"k{(i - 1) * len(k) // n + 1}")
        s.mass([f"{i}:x"], m=1.0)
    return s.build()


def test_large_model_takes_the_series_jacobian_and_it_matches_nelson():
    model = long_chain()
    assert model.n_dofs > 1500  # "auto" leaves Nelson's dense route
    data = measured(model, ["400:x", "1000:x", "1600:x"], 3)  # 3 sensors < 4 parameters: adjoint
    x = np.array([1.1, 0.9, 1.05, 0.95])
    J = {}
    for how in ("auto", "nelson", "subspace"):
        prob = Problem(model, data, shape_scaling="ref", sensitivity=how)
        J[how] = prob.jacobian(x)
        assert prob.sensitivity_used == ("adjoint" if how == "auto" else how)
    np.testing.assert_allclose(J["auto"], J["nelson"], rtol=0, atol=1e-7 * np.abs(J["nelson"]).max())
    np.testing.assert_allclose(J["subspace"], J["nelson"], rtol=0, atol=1e-7 * np.abs(J["nelson"]).max())
    res = update(model, data, x0=dict(zip(model.parameter_names, model.values * [0.8, 1.2, 0.9, 1.1])), shape_scaling="ref")
    assert res.success and res.sensitivity == "adjoint"
    np.testing.assert_allclose(res.x, model.values, rtol=1e-6)


def test_unknown_sensitivity_route_is_input_error():
    model = six_dof()
    with pytest.raises(InputError, match="sensitivity"):
        update(model, measured(model, ["1:x", "6:x"], 3), sensitivity="magic")


def test_bounds_honoured_and_start_outside_refused():
    model = chain(np.full(6, 1000.0), M6, bounds=(100.0, 1400.0))  # excludes the true k2, k3, k6
    data = measured(chain(K6, M6), ["1:x", "2:x", "3:x", "4:x", "5:x", "6:x"], 4)
    res = update(model, data, x0=dict(zip(model.parameter_names, np.full(6, 1000.0))))
    assert np.all(res.x <= 1400.0 + 1e-9) and np.all(res.x >= 100.0 - 1e-9)
    assert np.isclose(res.x, 1400.0).any()
    with pytest.raises(InputError, match="outside the bounds for: k1"):
        update(model, data, x0={"k1": 50.0})


def test_noise_covariance_is_consistent(rng):
    """Predicted standard deviations (from the stated measurement noise) match the scatter."""
    model = six_dof()
    mm = model_modes(chain(K6, M6))
    dofs = ["1:x", "2:x", "4:x", "6:x"]
    pos = model.dof_index(dofs)
    s_lam, s_shape = 2e-3, 4e-3
    errs, stds = [], []
    for _ in range(40):
        modes = []
        for r in range(4):
            psi = mm.shapes[pos, r] / np.linalg.norm(mm.shapes[pos, r])
            modes.append(MeasuredMode(mm.eigenvalues[r] * (1 + s_lam * rng.standard_normal()), dofs,
                                      psi + s_shape * rng.standard_normal(len(dofs))))
        res = update(model, TestData(modes=tuple(modes)), x0=dict(zip(model.parameter_names, K6)),
                     measurement_std={"eigenvalue": s_lam, "shape": s_shape})
        errs.append(res.x - K6)
        stds.append(res.diagnostics.std)
    ratio = np.std(errs, axis=0) / np.mean(stds, axis=0)
    assert np.all((ratio > 0.6) & (ratio < 1.6)), ratio


def test_mode_swap_is_followed_by_mac():
    """Two modes cross during updating: pairing by MAC keeps each test mode with its shape."""
    s = Structure("crossing")
    s.parameter("ka", 1.0, (0.1, 10)); s.parameter("kb", 3.0, (0.1, 10))
    s.spring(["1:x"], k="ka"); s.spring(["2:x"], k="kb"); s.spring(["1:x", "2:x"], k=0.01)
    s.mass(["1:x"], m=1.0); s.mass(["2:x"], m=1.0)
    model = s.build()
    # truth: ka = 3, kb = 1 — the order of the two modes is reversed w.r.t. the start
    data = measured(model, ["1:x", "2:x"], 2, values={"ka": 3.0, "kb": 1.0})
    res = update(model, data)
    np.testing.assert_allclose(res.x, [3.0, 1.0], rtol=1e-6)
    assert res.swaps, "the crossing should be reported"


def test_frequencies_only_two_dof_has_two_solutions():
    model = two_dof()
    data = measured(model, ["1:x"], 2)
    ms = multistart(model, data, starts=30, seed=7)
    sols = sorted((round(s.parameters["k1"], 6), round(s.parameters["k2"], 6)) for s in ms.solutions)
    assert sols == [(8.0, 6.0), (9.0, round(16 / 3, 6))]
    assert sum(s.count for s in ms.solutions) == ms.converged == 30
    again = multistart(model, data, starts=30, seed=7)
    assert [s.count for s in again.solutions] == [s.count for s in ms.solutions]  # reproducible


def test_underdetermined_refused_unless_regularised():
    model = six_dof()
    data = measured(model, ["1:x"], 3)  # 3 eigenvalues, 6 unknowns
    with pytest.raises(InputError, match="6 parameters but only 3 independent data"):
        update(model, data)


def test_unpairable_test_mode_is_a_clear_error():
    model = six_dof()
    bogus = TestData(modes=(MeasuredMode(4e3, ["1:x", "2:x", "3:x"], [1.0, -1.0, 1.0]),))
    with pytest.raises(NumericalError, match="pair with no model mode"):
        update(model, bogus, params=["k1", "k2"], min_mac=0.99, pairing="mac")
    # the default pairing keeps the start alive (by frequency order) and says the pair is not confirmed
    res = update(model, bogus, params=["k1", "k2"], min_mac=0.99)
    assert res.pairing["policy"] == "auto" and res.pairing["used"] == "order" and res.pairing["low_mac"] == [0]
    assert res.pairs[0][1] == 0 and res.pairs[0][2] < 0.99
    assert "the shapes do not confirm this pair" in res.summary()


def test_draw_starts_and_cluster():
    model = six_dof()
    X = draw_starts(model, model.parameter_names, 50, seed=3)
    assert X.shape == (50, 6) and np.all((X >= 100) & (X <= 5000))
    np.testing.assert_array_equal(X, draw_starts(model, model.parameter_names, 50, seed=3))
    with pytest.raises(InputError, match="finite bounds"):
        draw_starts(chain(K6, M6), ["k1"], 2, 0)
    pts = np.array([[1.0, 2.0], [1.0 + 1e-6, 2.0], [3.0, 1.0]])
    assert cluster(pts, np.array([0.0, 1e-3, 0.0])) == [[0, 1], [2]]


def test_update_cli(tmp_path, capsys):
    from femupdate.cli import main

    toml = ['[model]', 'name = "six"']
    for i, k in enumerate(K6, start=1):
        toml += [f"[parameters.k{i}]", f"value = {k * 1.2}", "bounds = [100.0, 5000.0]"]
    for i, m in enumerate(M6, start=1):
        dofs = f'["{i}:x"]' if i == 1 else f'["{i - 1}:x", "{i}:x"]'
        toml += ["[[element]]", 'type = "spring"', f"dofs = {dofs}", f'k = "k{i}"',
                 "[[element]]", 'type = "mass"', f'dofs = ["{i}:x"]', f"m = {m}"]
    (tmp_path / "m.toml").write_text("\n".join(toml))
    data = measured(chain(K6, M6), ["2:x", "4:x", "6:x"], 3)
    js = {"modes": [{"eigenvalue": m.eigenvalue, "shape": dict(zip(m.dofs, m.shape.tolist()))} for m in data.modes]}
    (tmp_path / "d.json").write_text(json.dumps(js))
    with pytest.raises(SystemExit) as info:
        main(["update", str(tmp_path / "m.toml"), str(tmp_path / "d.json"), "--starts", "4", "--seed", "2", "--json", "-"])
    out, err = capsys.readouterr()
    assert info.value.code == 0, err
    res = json.loads(out)
    for key in ("parameters", "success", "cost", "iterations", "pairs", "frequencies_hz", "starts"):
        assert key in res
    assert set(res["starts"]) >= {"total", "converged", "solutions"} and res["starts"]["total"] == 4
    np.testing.assert_allclose([res["parameters"][f"k{i}"] for i in range(1, 7)], K6, rtol=1e-5)
    assert res["starts"]["solutions"][0]["count"] >= 1


def test_multistart_on_a_dask_cluster_matches_local():
    distributed = pytest.importorskip("distributed")
    model = two_dof()
    data = measured(model, ["1:x"], 2)
    local = multistart(model, data, starts=12, seed=11)
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                                  dashboard_address=None) as cluster:
        remote = multistart(model, data, starts=12, seed=11, scheduler=cluster.scheduler_address)
    # the same route (compiled, in chunks on the workers): bit for bit the same runs and best result
    assert [(s.count, s.parameters, s.cost) for s in remote.solutions] == \
        [(s.count, s.parameters, s.cost) for s in local.solutions]
    np.testing.assert_array_equal(remote.starts, local.starts)
    for a, b in zip(remote.runs, local.runs):
        assert type(a) is type(b) and (isinstance(a, str) and a == b or (np.array_equal(a.x, b.x) and a.nfev == b.nfev))
    np.testing.assert_array_equal(remote.best.x, local.best.x)
    assert remote.best.cost == local.best.cost


def test_a_scheduler_without_workers_is_refused_in_bounded_time():
    distributed = pytest.importorskip("distributed")
    import time

    model = two_dof()
    with distributed.LocalCluster(n_workers=0, processes=False, protocol="tcp", host="127.0.0.1",
                                  dashboard_address=None) as cluster:
        t0 = time.monotonic()
        with pytest.raises(InputError, match="has no workers"):
            multistart(model, measured(model, ["1:x"], 2), starts=4, scheduler=cluster.scheduler_address,
                       connect_timeout=1.0)
        assert time.monotonic() - t0 < 30


def test_a_scheduler_lost_mid_run_ends_with_one_message():
    distributed = pytest.importorskip("distributed")
    from femupdate.dask_cluster import ClusterError

    model = two_dof()
    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=True, host="127.0.0.1",
                                  dashboard_address=None) as cluster:
        def progress(done, total):
            if done == 1:
                cluster.close()  # the scheduler goes away with the first result back

        with pytest.raises(ClusterError, match=r"lost the Dask scheduler at tcp://127.0.0.1.*\d of 6 tasks had finished"):
            multistart(model, measured(model, ["1:x"], 2), starts=6, scheduler=cluster.scheduler_address,
                       batched=False, progress=progress)


def test_a_scheduler_address_with_an_unknown_scheme_is_input_error():
    pytest.importorskip("distributed")
    model = two_dof()
    with pytest.raises(InputError, match="not a Dask scheduler address"):
        multistart(model, measured(model, ["1:x"], 2), starts=2, scheduler="foo://127.0.0.1:1", connect_timeout=1.0)


def test_unreachable_scheduler_is_input_error():
    pytest.importorskip("distributed")
    model = two_dof()
    with pytest.raises(InputError, match="cannot reach the Dask scheduler"):
        multistart(model, measured(model, ["1:x"], 2), starts=2, scheduler="tcp://127.0.0.1:9", connect_timeout=1.0)


def test_each_mode_may_name_its_own_reference_dof():
    """Scaling mode k to 1 at its reference_dof equals giving that dof first (the default
    reference is the first measured dof): the same residuals, entry for entry, reordered."""
    model = chain(K6, M6, bounds=(100.0, 5000.0))
    truth = model_modes(model, K6 * np.linspace(1.2, 0.8, 6))
    dofs = ("1:x", "3:x", "5:x", "6:x")
    at = [0, 2, 4, 5]
    refs = ["5:x", "1:x", "6:x"]
    named = TestData(modes=tuple(MeasuredMode(truth.eigenvalues[j], dofs, truth.shapes[at, j], f"m{j}", refs[j])
                                 for j in range(3)))
    first = []
    for j in range(3):
        order = [dofs.index(refs[j])] + [i for i in range(4) if dofs[i] != refs[j]]
        first.append(MeasuredMode(truth.eigenvalues[j], tuple(dofs[i] for i in order), truth.shapes[at, j][order], f"m{j}"))
    a = Problem(model, named, shape_scaling="ref")
    b = Problem(model, TestData(modes=tuple(first)), shape_scaling="ref")
    np.testing.assert_array_equal(a.targets.ref, [2, 0, 3])
    ra, rb = a.residuals(a.x_start), b.residuals(b.x_start)
    np.testing.assert_allclose(np.sort(ra), np.sort(rb), rtol=0, atol=1e-15)
    res = update(model, named, shape_scaling="ref")
    np.testing.assert_allclose(res.x, K6 * np.linspace(1.2, 0.8, 6), rtol=1e-8)
    with pytest.raises(InputError, match="reference_dof 2:x is not among its measured dofs"):
        MeasuredMode(1.0, dofs, truth.shapes[at, 0], "bad", "2:x")


def test_reference_dof_is_read_from_test_data_json(tmp_path):
    from femupdate.io.testdata_json import load_testdata

    path = tmp_path / "d.json"
    path.write_text('{"modes": [{"frequency_hz": 2.0, "shape": {"1:x": 0.5, "2:x": 1.0}, "reference_dof": "2:x"}]}')
    assert load_testdata(path).modes[0].reference_dof == "2:x"
    path.write_text('{"modes": [{"frequency_hz": 2.0, "shape": {"1:x": 0.5}, "reference_dof": "2:x"}]}')
    with pytest.raises(InputError, match=r"modes\[1\]: .*reference_dof 2:x is not among its measured dofs"):
        load_testdata(path)


def test_a_cluster_on_this_machine_is_said_to_be_no_faster():
    """dask_cluster.same_machine_note: every worker here with no more threads than cores gives the
    note; a worker elsewhere, or more threads than cores, gives none."""
    import os

    from femupdate.dask_cluster import same_machine_note

    class Client:
        def __init__(self, workers):
            self.workers = workers

        def scheduler_info(self):
            return {"workers": self.workers}

    cores = os.cpu_count() or 1
    local = {"tcp://127.0.0.1:1": {"host": "127.0.0.1", "nthreads": 1}}
    assert "runs on this machine" in same_machine_note(Client(local))
    assert same_machine_note(Client({**local, "tcp://10.9.8.7:1": {"host": "10.9.8.7", "nthreads": 1}})) is None
    assert same_machine_note(Client({"tcp://127.0.0.1:1": {"host": "127.0.0.1", "nthreads": cores + 1}})) is None
    assert same_machine_note(Client({})) is None
