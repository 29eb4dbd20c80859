"""Identifiability diagnostics that say what they found: parameters held by their bounds, a
covariance of the free parameters only, and parameters the data cannot move, each with its
reason (issue "Results that say what they found")."""

import numpy as np
import pytest

from femupdate import MeasuredMode, Structure, TestData, model_modes
from femupdate.flags import parameter_flags
from femupdate.updating import Problem, update
from femupdate.updating.solve import POOR_RELATIVE_STD

K6 = np.array([1000.0, 1800.0, 1500.0, 1200.0, 900.0, 1600.0])
M6 = np.array([1.0, 1.2, 0.8, 1.1, 0.9, 1.0])


def chain(k, bounds, masses=M6):
    s = Structure("chain")
    for i, (ki, mi) in enumerate(zip(k, masses), start=1):
        s.parameter(f"k{i}", float(ki), bounds[i - 1])
        s.spring([f"{i}:x"] if i == 1 else [f"{i - 1}:x", f"{i}:x"], k=f"k{i}")
        s.mass([f"{i}:x"], m=float(mi))
    return s.build()


def measured(model, dofs, n_modes, noise=0.0, seed=0):
    mm = model_modes(model)
    pos = model.dof_index(dofs)
    rng = np.random.default_rng(seed)
    return TestData(modes=tuple(
        MeasuredMode(mm.eigenvalues[r] * (1 + noise * rng.standard_normal()), dofs,
                     mm.shapes[pos, r] + noise * np.abs(mm.shapes[pos, r]).max() * rng.standard_normal(len(dofs)))
        for r in range(n_modes)))


# ---------------------------------------------------------------------------------- (a) unseen parameters
def test_a_spring_whose_modes_are_not_measured_is_reported_with_its_reason():
    """Two oscillators side by side: the chain 1-2 and a separate mass on spring k3.  Only the
    chain's two modes are measured (the shapes are zero at 3:x): the data do not depend on k3."""
    s = Structure("two systems")
    for n, v in (("k1", 1000.0), ("k2", 1500.0), ("k3", 700.0)):
        s.parameter(n, v, (10.0, 1e5))
    s.spring(["1:x"], k="k1")
    s.spring(["1:x", "2:x"], k="k2")
    s.spring(["3:x"], k="k3")
    for d, m in (("1:x", 1.0), ("2:x", 1.5), ("3:x", 2.0)):
        s.mass([d], m=m)
    truth = s.build()
    mm = model_modes(truth)
    on_chain = [r for r in range(3) if abs(mm.shapes[2, r]) < 1e-12]
    assert len(on_chain) == 2
    dofs = ["1:x", "2:x", "3:x"]
    data = TestData(modes=tuple(MeasuredMode(mm.eigenvalues[r], dofs, mm.shapes[:, r]) for r in on_chain))
    std = {"eigenvalue": 0.01, "shape": 0.01}
    res = update(truth, data, x0={"k1": 900.0, "k2": 1600.0, "k3": 800.0}, measurement_std=std)
    d = res.diagnostics
    assert res.success
    np.testing.assert_allclose(res.x[:2], [1000.0, 1500.0], rtol=1e-8)
    assert res.x[2] == 800.0  # never moved
    assert d.poorly_determined == ["k3"]
    assert "do not depend on it" in d.poorly_determined_reasons["k3"]
    assert d.at_bounds == {} and d.rank == 2 and d.condition_number == np.inf
    # k3 has no std; the others' covariance is that of the Jacobian without k3's column
    assert np.isnan(d.std[2])
    Jp = res.jac / np.array([900.0, 1600.0, 800.0])[None, :]  # relative parametrisation: ∂r/∂p
    np.testing.assert_allclose(d.covariance[:2, :2], np.linalg.inv(Jp[:, :2].T @ Jp[:, :2]), rtol=1e-8)


def test_a_parameter_the_data_barely_move_is_poorly_determined_by_its_std():
    """A soft spring (5 N/m against about 1000) between the chain's ends changes the measured
    modes so little that, with 1 % noise on eigenvalues and shapes, its standard deviation
    exceeds its value: the Jacobian has full rank (the old diagnostics reported nothing) but the
    data cannot move it."""
    s = Structure("soft brace")
    for n, v in (("k1", 1000.0), ("k2", 1200.0), ("k3", 900.0), ("k4", 5.0)):
        s.parameter(n, v, (0.1, 1e6))
    s.spring(["1:x"], k="k1")
    s.spring(["1:x", "2:x"], k="k2")
    s.spring(["2:x", "3:x"], k="k3")
    s.spring(["1:x", "3:x"], k="k4")
    for d, m in (("1:x", 1.0), ("2:x", 1.5), ("3:x", 2.0)):
        s.mass([d], m=m)
    model = s.build()
    data = measured(model, ["1:x", "2:x", "3:x"], 3)
    res = update(model, data, measurement_std={"eigenvalue": 0.01, "shape": 0.01})
    d = res.diagnostics
    assert d.rank == 4 and d.absolute
    rel = dict(zip(res.names, d.relative_std))
    assert rel["k4"] > POOR_RELATIVE_STD > max(rel["k1"], rel["k2"], rel["k3"])  # the premise
    assert d.poorly_determined == ["k4"]
    assert "standard deviation" in d.poorly_determined_reasons["k4"]
    np.testing.assert_allclose(d.relative_std, d.std / np.abs(res.x), rtol=1e-14)
    # the relative std is that of the parameter's direction in S = ∂r/∂(p/|p|): 1/‖S⁺ row‖ closed form
    S = res.jac  # relative parametrisation from the nominal values = the solution: J = S here
    np.testing.assert_allclose(d.relative_std, np.sqrt(np.diag(np.linalg.inv(S.T @ S))), rtol=1e-8)


def test_a_combination_the_data_cannot_split_names_its_partners():
    """Frequencies only of a 2-dof chain scaled as a whole: k and m appear only as k/m."""
    s = Structure("scaled")
    s.parameter("k", 1000.0, (1.0, 1e6))
    s.parameter("m", 2.0, (0.01, 100.0))
    s.spring(["1:x"], k="k")
    s.mass(["1:x"], m="m")
    model = s.build()
    data = TestData(modes=(MeasuredMode(500.0 * 1.1),))
    res = update(model, data, regularization=1e-8, x0={"k": 1000.0, "m": 2.0})
    d = res.diagnostics
    assert d.poorly_determined == ["k", "m"]
    assert d.poorly_determined_reasons["k"].endswith("combination of it with m")
    assert d.poorly_determined_reasons["m"].endswith("combination of it with k")


# ---------------------------------------------------------------------------------- (b) active bounds
def _bounded_problem():
    """Data of K6 with noise; k1's upper bound (950) and k4's lower bound (1250) exclude the fit."""
    data = measured(chain(K6, [(100.0, 5000.0)] * 6), ["2:x", "4:x", "6:x"], 3, noise=0.01)
    bounds = [(100.0, 5000.0)] * 6
    bounds[0] = (100.0, 950.0)
    bounds[3] = (1250.0, 5000.0)
    return chain(K6 * [0.9, 1, 1, 1.1, 1, 1], bounds), data


@pytest.mark.parametrize("parametrisation", ["relative", "log", "absolute"])
@pytest.mark.parametrize("std", [None, {"eigenvalue": 0.01, "shape": 0.02}])
def test_b_active_bound_reported_and_free_covariance_is_that_without_its_column(parametrisation, std):
    model, data = _bounded_problem()
    res = update(model, data, parametrisation=parametrisation, measurement_std=std)
    d = res.diagnostics
    assert res.success
    assert d.at_bounds == {"k1": "upper"} and d.n_at_bounds == 1
    assert d.free == ("k2", "k3", "k4", "k5", "k6")
    assert res.x[0] == pytest.approx(950.0, rel=1e-9)
    assert any("1 parameter on its bound (k1 upper)" in n and "free parameters only" in n for n in res.notes)
    # second route: ∂r/∂p from the result's Jacobian in x, k1's column removed, the normal equations inverted
    prob = Problem(model, data, x0=res.start, parametrisation=parametrisation)
    dpdx = prob.dp_dx(prob.from_p(res.x))
    Jp = res.jac / dpdx[None, :]
    JF = Jp[:, 1:]
    cov = np.linalg.inv(JF.T @ JF)
    if std is None:
        # the noise not stated is estimated (docs/numerics.md, "Noise and variance components"):
        # 3 eigenvalues and 3 unit-scaled shapes of 3 entries are too few for a component per
        # kind, so one component pools them all (the premise, from the result's record); with one
        # component the REML estimate is the textbook s^2 = |r|^2 / (m - L - c), where each
        # unit-scaled shape loses one degree of freedom to its own normalisation (c = 3: the
        # measured and model shapes both of unit length, their difference has 2 free entries to
        # first order), and the sandwich reduces to s^2 (J_F^T J_F)^-1
        assert [(c["label"], c["n_residuals"]) for c in d.noise] == [("all estimated data", 12)]
        m = res.fun.size
        c = sum(1 for mode in data.modes if len(mode.dofs))  # unit scaling: no reference dof
        cov *= float(res.fun @ res.fun) / (m - 5 - c)
    np.testing.assert_allclose(d.covariance[1:, 1:], cov, rtol=1e-8)
    assert np.all(np.isnan(d.covariance[0])) and np.all(np.isnan(d.covariance[:, 0]))
    assert np.isnan(d.std[0])
    np.testing.assert_allclose(d.std[1:], np.sqrt(np.diag(cov)), rtol=1e-8)
    # the singular values are those of the free columns of S = ∂r/∂(p/|p|)
    S = Jp * np.abs(res.x)[None, :]
    np.testing.assert_allclose(d.singular_values, np.linalg.svd(S[:, 1:], compute_uv=False), rtol=1e-10)
    assert d.rank == 5


def test_b_free_covariance_by_finite_differences():
    """A third route: the residuals differenced in the physical parameters at the solution."""
    model, data = _bounded_problem()
    std = {"eigenvalue": 0.01, "shape": 0.02}
    res = update(model, data, measurement_std=std, parametrisation="absolute")
    prob = Problem(model, data, x0=res.start, measurement_std=std, parametrisation="absolute")
    p = res.x.copy()
    JF = np.empty((res.fun.size, 5))
    for c, j in enumerate(range(1, 6)):
        h = 1e-6 * p[j]
        up, dn = p.copy(), p.copy()
        up[j] += h
        dn[j] -= h
        JF[:, c] = (prob.residuals(up) - prob.residuals(dn)) / (2 * h)
    cov = np.linalg.inv(JF.T @ JF)
    np.testing.assert_allclose(res.diagnostics.covariance[1:, 1:], cov, rtol=1e-5)


def test_b_levenberg_marquardt_ignores_bounds_so_none_is_active():
    model, data = _bounded_problem()
    res = update(model, data, method="lm")
    assert res.diagnostics.at_bounds == {}
    assert res.diagnostics.free == res.names
    assert not any("on its bound" in n for n in res.notes)


def test_b_every_route_fills_the_bounds():
    """Mixed data (modes and a static case: the combined route), FRFs alone, and the best run of a
    multi-start (compiled and one update per start) report the same active bound."""
    from femupdate.frf import frf
    from femupdate.testdata import FRFData, StaticData
    from femupdate.updating import frf_update, multistart

    model, data = _bounded_problem()
    truth = chain(K6, [(100.0, 5000.0)] * 6)
    u = np.linalg.solve(truth.K(truth.values).toarray(), np.eye(6)[:, 5])
    mixed = TestData(modes=data.modes, static=(StaticData({"6:x": 1.0}, ("3:x", "6:x"), u[[2, 5]]),))
    res = update(model, mixed)
    assert res.blocks and res.diagnostics.at_bounds == {"k1": "upper"}
    assert any("on its bound" in n for n in res.notes)
    omega = np.array([5.0, 12.0, 30.0, 45.0])
    dofs, H = frf(truth, omega, {"6:x": 1.0}, ["2:x", "4:x", "6:x"])
    fres = frf_update(model, TestData(frf=FRFData(omega, {"6:x": 1.0}, dofs, H)))
    # exact data of K6: k4 = 1200 lies below its bound too (the noisy modes above put it at 1288)
    assert fres.diagnostics.at_bounds == {"k1": "upper", "k4": "lower"}
    assert any("2 parameters on their bounds (k1 upper, k4 lower)" in n for n in fres.notes)
    for batched in (None, False):
        ms = multistart(model, data, starts=2, seed=2, batched=batched)
        assert ms.best is not None and ms.best.diagnostics.at_bounds == {"k1": "upper"}
        assert any("on its bound" in n for n in ms.best.notes)


def test_infinite_bounds_are_never_sat_on():
    """A parameter bounded (0, inf) was flagged as sitting on its upper bound, whatever its value."""
    model = chain([1000.0, 2000.0], [(0.0, np.inf)] * 2, masses=[1.0, 1.0])
    assert parameter_flags(model, dict(zip(model.parameter_names, model.values))) == []
    # a bound of 0 has no size of its own: the nominal value (1000) gives the scale of "on it"
    assert [f["kind"] for f in parameter_flags(model, {"k1": 1e-4, "k2": 2000.0})] == ["on_bound"]
    assert parameter_flags(model, {"k1": 1e-2, "k2": 2000.0}) == []


# ---------------------------------------------------------------------------------- the command line
def _cli(args, capsys):
    from femupdate.cli import main

    with pytest.raises(SystemExit) as info:
        main([str(a) for a in args])
    out, err = capsys.readouterr()
    return info.value.code, out, err


TWO_DOF = """[model]
name = "two-dof chain"

[parameters.k1]
value = 7.0
bounds = [3.0, {hi}]

[parameters.k2]
value = 6.5
bounds = [1.0, 11.0]

[parameters.k3]
value = 2.0
bounds = [0.5, 5.0]

[[element]]
type = "spring"
dofs = ["1:x"]
k = "k1"

[[element]]
type = "spring"
dofs = ["1:x", "2:x"]
k = "k2"

[[element]]
type = "spring"
dofs = ["3:x"]
k = "k3"

[[element]]
type = "mass"
dofs = ["1:x"]
m = 2.0

[[element]]
type = "mass"
dofs = ["2:x"]
m = 4.0

[[element]]
type = "mass"
dofs = ["3:x"]
m = 1.0
"""


def test_update_prints_and_writes_active_bounds_and_what_the_data_cannot_move(tmp_path, capsys):
    """The Figure 3 system (k1 = 8, k2 = 6) with k1's upper bound at 7.5, and a third oscillator
    (k3 on its own mass) whose mode is not measured."""
    import json

    model = tmp_path / "m.toml"
    model.write_text(TWO_DOF.format(hi=7.5))
    lam = [0.7768890026375489, 7.723110997362449]  # the Figure 3 system's eigenvalues
    shapes = model_modes(chain([8.0, 6.0], [(0, 1e3)] * 2, masses=[2.0, 4.0])).shapes
    data = tmp_path / "d.json"
    data.write_text(json.dumps({"modes": [
        {"eigenvalue": lam[r], "shape": {"1:x": float(shapes[0, r]), "2:x": float(shapes[1, r]), "3:x": 0.0}}
        for r in range(2)]}))
    out_json = tmp_path / "o.json"
    code, out, err = _cli(["update", model, data, "--json", out_json], capsys)
    assert code == 0, err
    assert "active bounds: 1 of 3 parameters on a bound (k1 upper)" in out
    assert "poorly determined (the data cannot move them): 1 of 3" in out
    assert "  k3: the data do not depend on it (zero sensitivity)" in out
    assert "note: 1 parameter on its bound (k1 upper)" in out
    assert "upper bound" in out  # in the std column
    d = json.loads(out_json.read_text())["diagnostics"]
    assert d["at_bounds"] == {"k1": "upper"} and d["n_at_bounds"] == 1
    assert d["free"] == ["k2", "k3"]
    assert d["poorly_determined"] == ["k3"] and list(d["poorly_determined_reasons"]) == ["k3"]
    assert d["std"]["k1"] is None and d["relative_std"]["k1"] is None and d["std"]["k3"] is None
    assert d["std"]["k2"] is not None  # k2's std is that of the free parameters the data see
    assert set(d) >= {"singular_values", "condition_number", "rank", "covariance", "n_residuals", "n_parameters"}
    # no bound active: the count is still printed
    model.write_text(TWO_DOF.format(hi=13.0))
    code, out, err = _cli(["update", model, data, "--json", out_json], capsys)
    assert code == 0, err
    assert "active bounds: 0 of 3 parameters on a bound" in out
    assert json.loads(out_json.read_text())["diagnostics"]["at_bounds"] == {}
