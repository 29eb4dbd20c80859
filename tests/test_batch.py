"""The compiled batched route (femupdate.updating.batched): same answers as the local route.

Two routes to one answer throughout: the batched route against ``update()`` per start (same
clusters, same counts), the compiled residuals and Jacobians against the local route's
``Problem`` and against central differences, and the compiled trust-region-reflective solver
against ``scipy.optimize.least_squares`` itself.
"""

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from conftest import heavy
from scipy.optimize import least_squares

from femupdate import InputError, MeasuredMode, NumericalError, Structure, TestData, model_modes
from femupdate.examples import chain, two_dof
from femupdate.generators import shear_building
from femupdate.updating import Problem, UpdateResult, multistart, update
from femupdate.updating.batched import (
    FAILED, BatchedProblem, BatchRun, least_squares_batch, multistart_batched, supports, unsupported,
)

ROOT = Path(__file__).resolve().parents[1]
K6 = np.array([1000.0, 1800.0, 1500.0, 1200.0, 900.0, 1600.0])
M6 = np.array([1.0, 1.2, 0.8, 1.1, 0.9, 1.0])


def measured(model, dofs, n_modes, values=None, scale=1.0):
    mm = model_modes(model, values)
    pos = model.dof_index(dofs)
    return TestData(modes=tuple(MeasuredMode(mm.eigenvalues[r], dofs, mm.shapes[pos, r] * scale) for r in range(n_modes)))


def building(n=10, parameters="storey"):
    k = 2.0e7 * (1.0 - 0.4 * np.arange(n) / (n - 1))
    return shear_building(n, k=k, m=1.0e4, parameters=parameters, bounds=(0.5, 1.5)).build(), k


def assert_same_study(a, b, rtol=1e-6):
    """Same converged count and the same clusters (parameters within rtol, same counts)."""
    assert a.converged == b.converged
    assert len(a.solutions) == len(b.solutions)
    unmatched = list(b.solutions)
    for s in a.solutions:
        pa = np.array(list(s.parameters.values()))
        for t in unmatched:
            pb = np.array(list(t.parameters.values()))
            if t.count == s.count and np.allclose(pa, pb, rtol=rtol, atol=0):
                unmatched.remove(t)
                break
        else:
            raise AssertionError(f"cluster {s.parameters} (count {s.count}) has no counterpart")
    # start by start: the same outcome
    for ra, rb in zip(a.runs, b.runs):
        assert isinstance(ra, str) == isinstance(rb, str), (ra, rb)
        if isinstance(ra, str):
            assert ra.split(":")[0] == rb.split(":")[0]
        else:
            assert ra.success == rb.success
            if ra.success:
                np.testing.assert_allclose(ra.x, rb.x, rtol=rtol)


# ------------------------------------------------------------------ batched == per-start
def test_two_dof_frequencies_only_same_clusters():
    model = two_dof()
    data = measured(model, ["1:x"], 2)
    fast = multistart(model, data, starts=30, seed=7, batched=True)
    slow = multistart(model, data, starts=30, seed=7, batched=False)
    assert all(isinstance(r, BatchRun) for r in fast.runs)
    assert all(isinstance(r, UpdateResult) for r in slow.runs)
    assert_same_study(fast, slow)
    sols = sorted((round(s.parameters["k1"], 6), round(s.parameters["k2"], 6)) for s in fast.solutions)
    assert sols == [(8.0, 6.0), (9.0, round(16 / 3, 6))]
    assert fast.converged == 30
    # the batched path reproduces the per-start solver step for step
    assert [r.nfev for r in fast.runs] == [r.nfev for r in slow.runs]


def test_six_dof_chain_two_sensors_three_modes_same_clusters():
    model = chain(K6, M6, bounds=(100.0, 5000.0))
    data = measured(model, ["2:x", "5:x"], 3)
    fast = multistart(model, data, starts=14, seed=3, batched=True)
    slow = multistart(model, data, starts=14, seed=3, batched=False)
    assert_same_study(fast, slow)
    assert any(np.allclose(list(s.parameters.values()), K6, rtol=1e-6) for s in fast.solutions)


def test_ten_storey_building_partial_sensors_same_clusters():
    model, k = building(10)
    data = measured(model, [f"{i}:x" for i in range(2, 11, 2)], 6)
    fast = multistart(model, data, starts=16, seed=5, batched=True)
    slow = multistart(model, data, starts=16, seed=5, batched=False)
    assert_same_study(fast, slow)
    assert fast.converged >= 8
    truth = [s for s in fast.solutions if np.allclose(list(s.parameters.values()), k, rtol=1e-6)]
    assert truth and truth[0] is fast.solutions[0]
    # best: a full UpdateResult (polished by update()), reporting the random start it came from
    best = fast.best
    assert isinstance(best, UpdateResult) and best.success and best.diagnostics is not None
    np.testing.assert_allclose(best.x, k, rtol=1e-8)
    k_best = min(truth[0].starts, key=lambda i: fast.runs[i].cost)
    assert best.start == dict(zip(fast.names, fast.starts[k_best]))
    assert best.history[0]["parameters"] == best.start
    # without the polish: the full result at the batched solution, the same diagnostics
    raw = multistart_batched(model, data, fast.names, fast.starts, polish=False).best
    assert isinstance(raw, UpdateResult) and raw.nfev == fast.runs[k_best].nfev
    np.testing.assert_allclose(raw.x, best.x, rtol=1e-8)
    np.testing.assert_allclose(raw.diagnostics.singular_values, best.diagnostics.singular_values, rtol=1e-5)


# ------------------------------------------------------------------ residuals and Jacobians
def mixed_data(model, values):
    """Modes measured at different dof sets, one without a shape, arbitrary shape scaling."""
    mm = model_modes(model, values)
    sets = [["2:x", "4:x", "6:x"], ["2:x", "4:x", "6:x"], ["1:x", "3:x", "5:x"], []]
    modes = []
    for r, dofs in enumerate(sets):
        pos = model.dof_index(dofs) if dofs else []
        modes.append(MeasuredMode(mm.eigenvalues[r], dofs, -3.0 * mm.shapes[pos, r] if dofs else ()))
    return TestData(modes=tuple(modes))


@pytest.mark.parametrize("scaling, ref_dof", [("unit", None), ("ref", None), ("ref", "4:x"), ("max", None)])
@pytest.mark.parametrize("parametrisation", ["relative", "log", "absolute"])
@pytest.mark.parametrize("mass_parameters", [False, True])
def test_residuals_and_jacobians_equal_problem(scaling, ref_dof, parametrisation, mass_parameters, rng):
    model, _ = building(6, "storey_mass" if mass_parameters else "storey")
    truth = model.values * rng.uniform(0.9, 1.1, model.values.size)
    data = mixed_data(model, truth)
    if scaling == "ref" and ref_dof is not None:
        data = TestData(modes=data.modes[:2] + data.modes[3:])  # mode 3 does not measure 4:x
    names = [f"k_{i}" for i in range(1, 7)] + (["m_3"] if mass_parameters else [])
    idx = [model.parameter_index(nm) for nm in names]
    lo, hi = model.bounds
    starts = rng.uniform(lo[idx], hi[idx], size=(4, len(names)))
    opts = dict(shape_scaling=scaling, ref_dof=ref_dof, parametrisation=parametrisation,
                weights={"eigenvalue": np.linspace(1.0, 2.0, len(data.modes)), "shape": 0.7})
    local = [Problem(model, data, names, x0=dict(zip(names, starts[r])), **opts) for r in range(4)]
    bp = BatchedProblem.from_problem(local[0], starts)
    X = bp.x_start + rng.uniform(-0.05, 0.05, starts.shape) * np.abs(bp.x_start)
    ev = bp.evaluate(X)
    assert ev.messages == [None] * 4
    for r in range(4):
        prob = local[r]
        f, Jp = prob.residuals(X[r]), prob.jacobian(X[r])
        _, _, pairs = prob.evaluate(X[r])
        assert [(k, j) for k, j, _ in pairs] == [(k, int(j)) for k, j in enumerate(ev.pairs[r])]
        np.testing.assert_allclose(ev.macs[r], [m for _, _, m in pairs], rtol=1e-12)
        np.testing.assert_allclose(ev.fun[r], f, rtol=0, atol=1e-12 * max(1.0, np.abs(f).max()))
        np.testing.assert_allclose(ev.jac[r], Jp, rtol=0, atol=1e-9 * np.abs(Jp).max())


def test_jacobian_against_finite_differences_with_mass_parameters(rng):
    """Independent of the local route: central differences of the compiled residuals themselves."""
    model, _ = building(5, "storey_mass")
    names = ["k_1", "k_2", "k_3", "k_4", "k_5", "m_2", "m_4"]
    data = measured(model, ["1:x", "3:x", "5:x"], 4, values=model.values * rng.uniform(0.9, 1.1, 10))
    idx = [model.parameter_index(nm) for nm in names]
    starts = model.values[idx][None, :] * rng.uniform(0.8, 1.2, (3, len(names)))
    bp = BatchedProblem.from_problem(Problem(model, data, names), starts)
    assert bp.M_varies
    X = bp.x_start.copy()
    J = bp.evaluate(X).jac
    h = 1e-6
    for c in range(X.shape[1]):
        Xp, Xm = X.copy(), X.copy()
        Xp[:, c] += h
        Xm[:, c] -= h
        Jfd = (bp.evaluate(Xp).fun - bp.evaluate(Xm).fun) / (2 * h)
        np.testing.assert_allclose(J[:, :, c], Jfd, atol=1e-6 * np.abs(J).max())


def test_dense_parameter_matrices(rng):
    """Parameters whose matrices couple every dof (as exported from an FE code): the wide-support
    route of the batched Jacobian, with a mass parameter."""
    from femupdate import Parameter, from_matrices

    n = 7
    def spd(scale):
        A = rng.standard_normal((n, n))
        return scale * (A @ A.T / n + np.eye(n))

    K0, K1, K2, M0, M1 = spd(100.0), spd(40.0), spd(60.0), spd(1.0), spd(0.2)
    model = from_matrices([f"{i}:x" for i in range(1, n + 1)], K0, M0,
                          [Parameter("a", 1.0, (0.5, 2.0)), Parameter("b", 1.0, (0.5, 2.0)), Parameter("c", 1.0, (0.5, 2.0))],
                          dK=[K1, K2, None], dM=[None, None, M1])
    data = measured(model, ["1:x", "3:x", "4:x", "6:x"], 3, values={"a": 1.3, "b": 0.8, "c": 1.2})
    starts = rng.uniform(0.5, 2.0, (5, 3))
    opts = dict(shape_scaling="max", parametrisation="log")
    bp = BatchedProblem.from_problem(Problem(model, data, **opts), starts)
    assert bp.M_varies
    X = bp.x_start + rng.uniform(-0.05, 0.05, starts.shape)
    ev = bp.evaluate(X)
    for r in range(5):
        prob = Problem(model, data, x0=dict(zip(model.parameter_names, starts[r])), **opts)
        np.testing.assert_allclose(ev.fun[r], prob.residuals(X[r]), atol=1e-12)
        Jp = prob.jacobian(X[r])
        np.testing.assert_allclose(ev.jac[r], Jp, atol=1e-9 * np.abs(Jp).max())
    fast = multistart(model, data, starts=6, seed=1, shape_scaling="max", parametrisation="log")
    slow = multistart(model, data, starts=6, seed=1, shape_scaling="max", parametrisation="log", batched=False)
    assert_same_study(fast, slow)
    assert np.allclose(fast.best.x, [1.3, 0.8, 1.2], rtol=1e-6)


# ------------------------------------------------------------------ failures stay local
def uncoupled_model():
    s = Structure("three uncoupled oscillators")
    for name, k in (("ka", 1.0), ("kb", 3.0), ("kc", 10.0)):
        s.parameter(name, k, (0.5, 12.0))
    s.spring(["1:x"], k="ka")
    s.spring(["2:x"], k="kb")
    s.spring(["3:x"], k="kc")
    s.mass(["1:x"], m=1.0)
    s.mass(["2:x"], m=1.0)
    s.mass(["3:x"], m=2.0)
    return s.build()


def test_repeated_mode_start_goes_to_the_local_route():
    """A start at repeated modes (ka = kb) used to fail ("modes 1 and 2 are repeated"); the local
    route compares the group with the measured shapes, and the compiled route hands the start to
    it.  With close_modes=0 the old refusal stays, alone, on both routes."""
    model = uncoupled_model()
    data = measured(model, ["1:x", "2:x", "3:x"], 3)
    starts = np.array([[2.0, 2.0, 8.0],  # ka = kb: modes 1 and 2 repeated at the start
                       [1.5, 2.5, 8.0], [0.8, 4.0, 11.0], [2.0, 2.0 * (1 + 1e-3), 6.0]])
    ms = multistart_batched(model, data, model.parameter_names, starts, min_mac=0.0)
    for r in ms.runs:
        assert isinstance(r, BatchRun) and r.success
        np.testing.assert_allclose(r.x, [1.0, 3.0, 10.0], rtol=1e-8)
    assert "local route" in ms.runs[0].message and "local route" not in ms.runs[1].message
    assert ms.converged == 4 and ms.solutions[0].count == 4
    local = update(model, data, x0=dict(zip(model.parameter_names, starts[0])), min_mac=0.0)
    np.testing.assert_allclose(ms.runs[0].x, local.x, rtol=0, atol=0)  # the local route's own answer
    old = multistart_batched(model, data, model.parameter_names, starts, min_mac=0.0, close_modes=0.0)
    assert isinstance(old.runs[0], str) and "repeated" in old.runs[0]
    assert old.converged == 3 and old.solutions[0].count == 3
    with pytest.raises(NumericalError, match="repeated"):  # the per-start path refuses it alike
        update(model, data, x0=dict(zip(model.parameter_names, starts[0])), min_mac=0.0, close_modes=0.0)


def test_solver_failed_rows_do_not_stop_the_batch():
    def fun(X, rows):
        F = np.column_stack([X[:, 0] - 1.0, 10.0 * (X[:, 1] - X[:, 0] ** 2)])
        errors = ["non-finite residuals" if (r == 1 and X[i, 0] != -1.5) else None for i, r in enumerate(rows)]
        F[[e is not None for e in errors]] = np.nan
        return F, errors, X

    def jac(X, sel):
        X = X[sel]
        J = np.zeros((len(sel), 2, 2))
        J[:, 0, 0] = 1.0
        J[:, 1, 0] = -20.0 * X[:, 0]
        J[:, 1, 1] = 10.0
        return J, [None] * len(sel)

    res = least_squares_batch(fun, jac, [[-1.5, 2.0], [-1.5, 2.0], [0.5, 0.5]], ([-2, -2], [2, 2]), ftol=1e-12,
                              xtol=1e-12, gtol=1e-12)
    assert list(res.success) == [True, False, True]
    assert res.status[1] == FAILED and res.message[1] == "non-finite residuals" and res.nfev[1] == 2
    np.testing.assert_allclose(res.x[[0, 2]], 1.0, rtol=1e-8)


# ------------------------------------------------------------------ the solver is scipy's trf
@pytest.mark.parametrize("case", ["rosenbrock-bounded", "rank-deficient", "upper-bound-active"])
def test_least_squares_batch_reproduces_scipy_trf(case, rng):
    if case == "rosenbrock-bounded":
        def f1(x):
            return np.array([10.0 * (x[1] - x[0] ** 2), 1.0 - x[0], 0.1 * np.sin(3 * x[1])])
        lb, ub = np.array([-2.0, -1.0]), np.array([0.8, 3.0])
    elif case == "rank-deficient":
        def f1(x):
            return np.array([x[0] + 2.0 * x[1] - 1.0 + 0.1 * x[2] ** 2])
        lb, ub = np.array([-1.0, -1.0, -np.inf]), np.array([1.0, 1.0, 1.0])
    else:
        def f1(x):
            return np.array([x[0] - 3.0, x[1] ** 2 + x[0] - 2.0, np.exp(0.3 * x[1]) - 1.5])
        lb, ub = np.array([0.0, -5.0]), np.array([2.0, 5.0])

    def jac1(x):
        from scipy.optimize._numdiff import approx_derivative

        return np.atleast_2d(approx_derivative(f1, x, method="cs"))

    lo = np.where(np.isfinite(lb), lb, -3.0)
    hi = np.where(np.isfinite(ub), ub, 3.0)
    X0 = rng.uniform(lo, hi, size=(12, lb.size))
    paths = {r: [] for r in range(len(X0))}

    def fun(X, rows):
        for x, r in zip(X, rows):
            paths[r].append(x.copy())
        return np.array([f1(x) for x in X]), [None] * len(X), X

    def jac(X, sel):
        return np.array([jac1(x) for x in X[sel]]), [None] * len(sel)

    res = least_squares_batch(fun, jac, X0, (lb, ub), ftol=1e-10, xtol=1e-10, gtol=1e-10, max_nfev=60)
    same_counts = 0
    for r, x0 in enumerate(X0):
        ref_path = []
        ref = least_squares(lambda x: ref_path.append(x.copy()) or f1(x), x0, jac=jac1, bounds=(lb, ub), method="trf",
                            x_scale="jac", ftol=1e-10, xtol=1e-10, gtol=1e-10, max_nfev=60)
        assert res.success[r] == ref.success and (res.status[r] > 0) == (ref.status > 0)
        np.testing.assert_allclose(res.x[r], ref.x, rtol=1e-7, atol=1e-9)
        # every trial point is the same until the cost reaches its round-off floor, where the
        # accept/reject decisions depend on the last bits of the arithmetic
        floor = min(res.cost[r], ref.cost) * (1 + 1e-9) + 1e-20
        n_cmp = next((i for i, x in enumerate(ref_path) if 0.5 * f1(x) @ f1(x) <= floor), len(ref_path))
        assert n_cmp >= 3 and len(paths[r]) >= n_cmp
        np.testing.assert_allclose(np.array(paths[r][:n_cmp]), np.array(ref_path[:n_cmp]), rtol=1e-9, atol=1e-12)
        same_counts += (res.nfev[r], res.njev[r], res.status[r]) == (ref.nfev, ref.njev, ref.status)
    assert same_counts >= len(X0) // 2  # most runs agree to the last evaluation


# ------------------------------------------------------------------ dispatch
def test_dispatch_and_options():
    model = two_dof()
    data = measured(model, ["1:x"], 2)
    assert supports(model, {}) and supports(model, {"shape_scaling": "ref", "max_nfev": 50})
    assert not supports(model, {"method": "dogbox"})
    assert not supports(model, {"regularization": 0.1})
    assert "dofs" in unsupported(shear_building(201).build(), {})
    auto = multistart(model, data, starts=3, seed=1, method="dogbox")  # falls back to update() per start
    assert all(isinstance(r, UpdateResult) for r in auto.runs)
    with pytest.raises(InputError, match="trf only"):
        multistart(model, data, starts=3, seed=1, method="dogbox", batched=True)
    with pytest.raises(InputError, match="cannot reach"):  # batched with a scheduler: chunks on its workers
        multistart(model, data, starts=3, seed=1, batched=True, scheduler="tcp://127.0.0.1:9", connect_timeout=0.5)
    # update() refuses every start alike (underdetermined): the input is refused, as update refuses it
    # (before: a result without a solution, every run carrying the message; the command line said
    # "none of the starts converged", exit 1, for bad input)
    with pytest.raises(InputError, match="underdetermined"):
        multistart(chain(K6, M6, bounds=(100.0, 5000.0)), measured(chain(K6, M6), ["1:x"], 3), starts=2, seed=0)


def test_input_every_start_refuses_alike_is_refused_by_name():
    """--starts 3 --shape-scaling ref --ref-dof 9:x (a dof the test modes do not measure) exited
    1 with "3 starts without a solution: 3 x test mode #" and "none of the 3 starts converged";
    one start exits 2 naming the reference dof.  Both routes, and the command line."""
    model = two_dof()
    data = measured(model, ["1:x", "2:x"], 2)
    for batched in (True, False):
        with pytest.raises(InputError, match="reference dof 9:x is not measured"):
            multistart(model, data, starts=3, seed=1, shape_scaling="ref", ref_dof="9:x", batched=batched)
    # starts that fail for reasons of their own are still recorded, not raised
    ms = multistart(model, data, starts=3, seed=1, max_nfev=1)
    assert ms.total == 3


def test_progress_is_reported():
    model = two_dof()
    seen = []
    multistart(model, measured(model, ["1:x"], 2), starts=6, seed=2, progress=lambda done, total: seen.append((done, total)))
    assert seen and seen[-1] == (6, 6) and all(t == 6 for _, t in seen)
    assert [d for d, _ in seen] == sorted(d for d, _ in seen)


# ------------------------------------------------------------------ benchmark smoke test
def test_bench_multistart_quick_runs(tmp_path):
    out = tmp_path / "bench.json"
    proc = subprocess.run([sys.executable, str(ROOT / "benchmarks" / "bench_multistart.py"), "--quick", "--output", str(out)],
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    res = json.loads(out.read_text())
    (size,) = res["sizes"]
    assert size["ratio_a_over_f"] > 0 and size["seconds"]["f_batched"] > 0
    assert size["agreement_f_a"]["of"] == size["starts"] == 12
    assert size["outcomes"]["f_batched"]["truth"] >= 1


# ------------------------------------------------------------------ the first compile
FIRST_SOLVE = """
import json, numpy as np
from numba import typeof
from femupdate import MeasuredMode, TestData, model_modes
from femupdate.generators import shear_building
from femupdate.updating import multistart
from femupdate.updating.batched import kernel, trf

model = shear_building(4, k=[2e7, 1.8e7, 1.6e7, 1.4e7], m=1e4, bounds=(0.5, 1.5)).build()
mm = model_modes(model)
pos = model.dof_index(["2:x", "4:x"])
data = TestData(modes=tuple(MeasuredMode(mm.eigenvalues[r], ["2:x", "4:x"], mm.shapes[pos, r]) for r in range(3)))
ms = multistart(model, data, starts=4, seed=0, batched=True)
st = trf.new_state(np.zeros((1, 1)), np.zeros((1, 1)), np.zeros((1, 1)), 1, np.ones(1, np.int64), np.ones(1, np.int64), 0)
ahead = [(fn, sig) for fn, sig in trf.row_signatures(typeof(st))]
print(json.dumps({"converged": ms.converged,
                  "ahead": {fn.__name__: [str(s) for s in fn.signatures] == [str(tuple(sig))] for fn, sig in ahead},
                  "modal": {fn.__name__: len(fn.signatures) for fn in (kernel.evaluate_row, kernel.jacobian_row)}}))
"""


@heavy  # a second full compilation on an empty cache (about a minute); every other test here runs the compiled code
def test_first_solve_compiles_every_function_once(tmp_path):
    """On an empty cache, the functions compiled ahead of solve_rows (kernel.build; trf's in a
    second process) have the very types solve_rows calls them with: solve_rows loads trf's from
    the cache, and every function has one specialisation in it."""
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path), PYTHONPATH=str(ROOT / "src"))
    env.pop("NUMBA_DISABLE_JIT", None)
    proc = subprocess.run([sys.executable, "-c", FIRST_SOLVE], capture_output=True, text=True, timeout=600, env=env)
    assert proc.returncode == 0, proc.stderr
    res = json.loads(proc.stdout.strip().splitlines()[-1])
    assert res["converged"] >= 1
    assert all(res["ahead"].values()), res  # loaded from the cache with the signature compiled ahead
    assert res["modal"] == {"evaluate_row": 1, "jacobian_row": 1}
    index = [f.name for f in tmp_path.rglob("*.nbi")]
    assert any(n.startswith("trf.propose-") for n in index) and any(n.startswith("kernel.solve_rows-") for n in index)
    assert not list(tmp_path.rglob("*.2.nbc")), sorted(f.name for f in tmp_path.rglob("*.nbc"))


# ------------------------------------------------------------------ the two solve routes
def local_rows(problems):
    """``least_squares_batch``'s residual and Jacobian functions from the local route's
    Problem of each start (model_modes, MAC pairing, Nelson's derivatives)."""
    from femupdate import FemupdateError

    def fun(X, rows):
        F = np.zeros((len(rows), problems[0].n_residuals))
        errors = []
        for i, r in enumerate(rows):
            try:
                F[i] = problems[r].residuals(X[i])
                errors.append(None)
            except FemupdateError as exc:
                errors.append(f"{type(exc).__name__}: {exc}")
        return F, errors, (X.copy(), np.asarray(rows))

    def jac(token, sel):
        X, rows = token
        J = np.zeros((len(sel), problems[0].n_residuals, X.shape[1]))
        for i, s_ in enumerate(sel):
            J[i] = problems[rows[s_]].jacobian(X[s_])
        return J, [None] * len(sel)

    return fun, jac


def test_compiled_route_equals_local_residuals_driven_by_the_same_solver():
    """BatchedProblem.solve (everything compiled) against least_squares_batch driven by the local
    route's residuals and Jacobians: the same outcome, start by start."""
    from femupdate.updating import draw_starts

    model, k = building(8)
    data = measured(model, [f"{i}:x" for i in range(2, 9, 2)], 5)
    names = model.parameter_names
    starts = draw_starts(model, names, 24, 11)
    problems = [Problem(model, data, x0=dict(zip(names, starts[r]))) for r in range(len(starts))]
    bp = BatchedProblem.from_problem(problems[0], starts)
    a = bp.solve()
    fun, jac = local_rows(problems)
    b = least_squares_batch(fun, jac, bp.x_start, (bp.lb, bp.ub), ftol=1e-10, xtol=1e-10, gtol=1e-10, max_nfev=200)
    assert [s > 0 for s in a.status] == [s > 0 for s in b.status]
    ok = a.status > 0
    assert ok.sum() >= 12
    np.testing.assert_allclose(a.x[ok], b.x[ok], rtol=1e-8)
    assert np.mean(a.nfev == b.nfev) >= 0.9  # counts agree but at the round-off floor of the cost
    np.testing.assert_allclose(a.history_cost[:, 0], b.history_cost[:, 0], rtol=1e-12)


def test_compiled_route_failure_messages_equal_local_route():
    model = two_dof()
    data = measured(model, ["1:x", "2:x"], 2)
    starts = np.array([[9.0, 5.5], [90.0, 1.0], [8.5, 6.2]])
    for opts in ({"min_mac": 0.9999999, "pairing": "mac"}, {"min_mac": 0.5, "pairing": "mac"}):
        a = BatchedProblem.from_problem(Problem(model, data, **opts), starts).solve()
        for r in range(3):
            try:
                update(model, data, x0=dict(zip(model.parameter_names, starts[r])), **opts)
                local = None
            except NumericalError as exc:
                local = f"NumericalError: {exc}"
            if local is None:
                assert a.status[r] > 0
            else:
                assert a.status[r] == FAILED and a.message[r] == local
        if opts["min_mac"] > 0.99:  # no start pairs its modes that well
            assert all(s == FAILED for s in a.status) and all("pair with no model mode" in m for m in a.message)
        else:
            assert all(a.status > 0)
