"""Updating from modes, FRFs and static deflections as one problem (femupdate.update on any data).

References: closed-form deflections of a grounded spring chain; the direct (linear) solution of
complete static data (an independent code path); central finite differences of the stacked
residuals; and an independent weighted least-squares problem written here from NumPy alone
(dense eigenvalues, dense solves) and solved by SciPy with finite-difference Jacobians.
"""

import json

import numpy as np
import pytest
from scipy.linalg import eigh
from scipy.optimize import least_squares

from femupdate import InputError, MeasuredMode, NumericalError, StaticData, TestData, direct_update, model_modes, update
from femupdate.examples import chain
from femupdate.frf import Damping, simulate
from femupdate.updating import (CombinedProblem, FRFUpdateResult, UpdateResult, combined_problem, frf_update,
                                multistart, update_modal)

TRUE = np.array([1000.0, 2000.0, 1500.0, 1200.0])
MASS = np.array([1.0, 1.5, 1.0, 0.8])
START = {"k1": 800.0, "k2": 2500.0, "k3": 1300.0, "k4": 1500.0}
DOFS = ("1:x", "2:x", "3:x", "4:x")


def model():
    return chain(TRUE, MASS, bounds=(10.0, 1e5))


def tip_deflection(k, force=10.0):
    """Grounded chain with a tip load: every spring carries the load, u_i = F Σ_{j≤i} 1/k_j."""
    return force * np.cumsum(1.0 / np.asarray(k))


def data_of(kinds, sensors=("1:x", "3:x", "4:x"), n_modes=2):
    m = model()
    modes = model_modes(m)
    at = [DOFS.index(d) for d in sensors]
    out = {}
    if "modes" in kinds:
        out["modes"] = tuple(MeasuredMode(modes.eigenvalues[j], sensors, modes.shapes[at, j]) for j in range(n_modes))
    if "frf" in kinds:
        out["frf"] = simulate(m, np.array([5.0, 20.0, 45.0]), {"1:x": 1.0}, response=("4:x",))
    if "static" in kinds:
        u = tip_deflection(TRUE)
        out["static"] = (StaticData({"4:x": 10.0}, ("2:x", "4:x"), u[[1, 3]]),)
    return TestData(**out)


def test_static_alone_recovers_the_closed_form_stiffnesses_as_the_direct_solution_does():
    u = tip_deflection(TRUE)
    data = TestData(static=(StaticData({"4:x": 10.0}, DOFS, u),))
    res = update(model(), data, x0=START)
    assert type(res) is UpdateResult and res.success
    np.testing.assert_allclose(res.x, TRUE, rtol=1e-9)
    # alone, the deflections (in m) are divided by their RMS: a dimensionless cost, with a note
    assert [b["kind"] for b in res.blocks] == ["static"]
    assert res.blocks[0]["scale"] == pytest.approx(1 / np.sqrt(np.mean(u ** 2)), rel=1e-12)
    assert len(res.notes) == 1 and "divided by the RMS measured deflection" in res.notes[0]
    direct = direct_update(model(), data)  # the linear route of eq. 10 for static data
    np.testing.assert_allclose([direct.parameters[n] for n in res.names], res.x, rtol=1e-9)


@pytest.mark.parametrize("kinds", [("modes", "static"), ("modes", "frf", "static"), ("frf", "static")])
def test_noise_free_mixes_recover_the_truth(kinds):
    res = update(model(), data_of(kinds), x0=START)
    assert res.success
    np.testing.assert_allclose(res.x, TRUE, rtol=1e-7)
    assert tuple(b["kind"] for b in res.blocks) == kinds
    assert isinstance(res, FRFUpdateResult) == ("frf" in kinds)
    # no std stated: the blocks with units are made relative, and the notes say so
    for b in res.blocks:
        assert (b["scale"] != 1.0) == (b["kind"] != "modes")
    # and, with FRFs, the residual auto (the default) says what its two stages did
    assert len(res.notes) == sum(k != "modes" for k in kinds) + ("frf" in kinds)
    assert res.notes[-1].startswith("residual auto: a log-magnitude stage") == ("frf" in kinds)


def test_stacked_jacobian_equals_central_differences():
    damping = Damping(alpha=0.5, beta=1e-4)
    m = model()
    data = data_of(("modes", "static"))
    frf = simulate(m, np.array([5.0, 20.0, 45.0]), {"1:x": 1.0}, response=("2:x", "4:x"), damping=damping)
    data = TestData(modes=data.modes, frf=frf, static=data.static + (StaticData({"2:x": -3.0}, ("1:x", "3:x"),
                                                                                [0.01, 0.02]),))
    prob = combined_problem(m, data, x0=START, frf_options={"damping": damping})
    assert isinstance(prob, CombinedProblem) and len(prob.blocks) == 4
    x = prob.x_start
    J = prob.jacobian(x)
    h = 1e-6
    fd = np.column_stack([(prob.residuals(x + h * e) - prob.residuals(x - h * e)) / (2 * h) for e in np.eye(x.size)])
    assert J.shape == (prob.n_residuals, 4)
    assert np.abs(J - fd).max() <= 1e-6 * np.abs(J).max()


def test_one_kind_gives_exactly_the_single_kind_answer():
    data = data_of(("modes",))
    a, b = update(model(), data, x0=START), update_modal(model(), data, x0=START)
    np.testing.assert_array_equal(a.x, b.x)
    assert a.blocks == [] and a.notes == []
    data = data_of(("frf",))
    a, b = update(model(), data, x0=START, params=["k1", "k2", "k3"]), frf_update(model(), data, x0=START,
                                                                                    params=["k1", "k2", "k3"])
    np.testing.assert_array_equal(a.x, b.x)
    assert isinstance(a, FRFUpdateResult) and a.cost == b.cost


def _independent_problem(m, data, sigma):
    """The weighted residuals of frequencies, FRFs and static deflections from NumPy alone."""
    K0 = [m.K(np.eye(4)[j]).toarray() for j in range(4)]  # K is linear in the four stiffnesses
    M = m.M(TRUE).toarray()
    lam_e = data.eigenvalues
    frf = data.frf
    S = [DOFS.index(d) for d in frf.dofs]
    f = np.zeros(4)
    f[DOFS.index("1:x")] = 1.0
    case = data.static[0]
    Ss = [DOFS.index(d) for d in case.dofs]
    fs = np.zeros(4)
    fs[DOFS.index("4:x")] = 10.0

    def residuals(k):
        K = sum(kj * Kj for kj, Kj in zip(k, K0))
        lam = eigh(K, M, eigvals_only=True)[:lam_e.size]
        r_modes = (lam - lam_e) / lam_e / sigma["eigenvalue"]
        r_frf = np.concatenate([np.linalg.solve(K - w * w * M, f)[S] for w in frf.omega]) - frf.response.ravel()
        r_static = np.linalg.solve(K, fs)[Ss] - case.displacement
        return np.concatenate([r_modes, r_frf / sigma["frf"], r_static / sigma["static"]])

    return residuals


def test_weighted_mix_with_noise_equals_an_independent_weighted_least_squares():
    m = model()
    rng = np.random.default_rng(7)
    clean = data_of(("modes", "frf", "static"))
    sigma = {"eigenvalue": 0.002, "frf": 2e-5, "static": 1e-4}
    modes = tuple(MeasuredMode(md.eigenvalue * (1 + sigma["eigenvalue"] * rng.standard_normal())) for md in clean.modes)
    frf = clean.frf
    noisy_frf = type(frf)(frf.omega, frf.force, frf.dofs, frf.response + sigma["frf"] * rng.standard_normal(frf.response.shape))
    st = clean.static[0]
    noisy_static = StaticData(st.force, st.dofs, st.displacement + sigma["static"] * rng.standard_normal(2))
    data = TestData(modes=modes + (MeasuredMode(model_modes(m).eigenvalues[2]),), frf=noisy_frf, static=(noisy_static,))
    res = update(m, data, x0=START, measurement_std=sigma, parametrisation="absolute")
    assert res.success and [b["weighting"] for b in res.blocks] == ["stated std"] * 3

    fun = _independent_problem(m, data, sigma)
    ref = least_squares(fun, np.array(list(START.values())), jac="3-point", x_scale="jac", ftol=1e-14, xtol=1e-14,
                        gtol=1e-14, bounds=(10.0, 1e5))
    np.testing.assert_allclose(res.x, ref.x, rtol=2e-6)
    np.testing.assert_allclose(res.fun, fun(res.x), rtol=1e-8, atol=1e-10)
    # every block's std stated: the covariance is absolute, (JᵀJ)⁻¹ of the independent residuals
    Jref = np.column_stack([(fun(ref.x + h) - fun(ref.x - h)) / (2 * np.linalg.norm(h))
                            for h in np.diag(1e-6 * ref.x)])
    cov = np.linalg.inv(Jref.T @ Jref)
    np.testing.assert_allclose(res.diagnostics.std, np.sqrt(np.diag(cov)), rtol=1e-4)
    assert not np.allclose(res.x, TRUE, rtol=1e-6)  # the noise moved the answer: not a noise-free loop


def test_multistart_on_mixed_data_runs_every_start_locally():
    data = data_of(("modes", "static"))
    ms = multistart(model(), data, starts=4, seed=3)
    assert ms.total == 4 and ms.converged == 4 and len(ms.solutions) == 1
    np.testing.assert_allclose(ms.best.x, TRUE, rtol=1e-7)
    with pytest.raises(InputError, match="batched=True takes modal data only"):
        multistart(model(), data, starts=2, batched=True)


def test_refusals_name_the_culprit():
    data = data_of(("modes", "static"))
    with pytest.raises(InputError, match="unknown data kind"):
        update(model(), data, use=("modes", "strain"))
    with pytest.raises(InputError, match="hold no frf data"):
        update(model(), data, use=("frf",))
    with pytest.raises(InputError, match="unknown measurement_std key 'displacement'"):
        update(model(), data, measurement_std={"displacement": 1e-3})
    with pytest.raises(InputError, match=r"measurement_std\['static'\] must be positive"):
        update(model(), data, measurement_std={"static": float("nan")})
    with pytest.raises(InputError, match="FRF options"):
        update(model(), data, frf_options={"residual": "log"})
    with pytest.raises(InputError, match="underdetermined"):
        update(model(), TestData(static=data.static))
    with pytest.raises(InputError, match="static case 1: .*9:x"):
        update(model(), TestData(modes=data.modes, static=(StaticData({"9:x": 1.0}, ("1:x",), [0.1]),)))


def test_static_data_on_a_model_with_a_rigid_body_mode_fail_by_name():
    from femupdate import Structure

    s = Structure("free pair")
    s.parameter("k", 100.0, (1.0, 1e4))
    s.spring(["1:x", "2:x"], k="k")
    s.mass(["1:x"], m=1.0)
    s.mass(["2:x"], m=1.0)
    free = s.build()
    data = TestData(modes=(MeasuredMode(150.0),), static=(StaticData({"2:x": 1.0}, ("2:x",), [0.01]),))
    with pytest.raises(InputError, match="static case 1: the model has 1 rigid-body mode"):
        update(free, data)


def run_cli(args, capsys):
    from femupdate.cli import main

    with pytest.raises(SystemExit) as info:
        main(args)
    out, err = capsys.readouterr()
    return info.value.code, out + err


def test_cli_update_takes_mixed_data(tmp_path, capsys):
    from femupdate.examples import example_files

    files = example_files()
    (tmp_path / "m.toml").write_text(files["two_dof.toml"])
    frf = json.loads(files["two_dof_frf.json"])
    k1, k2 = 8.0, 6.0  # the example's true stiffnesses; tip load 1 N at 2:x
    frf["static"] = {"force": {"2:x": 1.0}, "displacement": {"1:x": 1 / k1, "2:x": 1 / k1 + 1 / k2}}
    frf["modes"] = json.loads(files["two_dof_frequencies.json"])["modes"]
    (tmp_path / "d.json").write_text(json.dumps(frf))
    rc, out = run_cli(capsys=capsys, args=["update", str(tmp_path / "m.toml"), str(tmp_path / "d.json"), "--json", "-"])
    assert rc == 0
    payload = json.loads(out)
    assert [b["kind"] for b in payload["blocks"]] == ["modes", "frf", "static"]
    assert len(payload["notes"]) == 3 and "frac" in payload  # the RMS of the FRFs and of the deflections, auto
    assert payload["notes"][-1].startswith("residual auto: a log-magnitude stage")
    np.testing.assert_allclose([payload["parameters"]["k1"], payload["parameters"]["k2"]], [k1, k2], rtol=2e-3)
    rc, out = run_cli(capsys=capsys, args=["update", str(tmp_path / "m.toml"), str(tmp_path / "d.json"), "--use", "static", "--json", "-"])
    assert rc == 0
    np.testing.assert_allclose([json.loads(out)["parameters"][n] for n in ("k1", "k2")], [k1, k2], rtol=1e-8)
    rc, out = run_cli(capsys=capsys, args=["update", str(tmp_path / "m.toml"), str(tmp_path / "d.json"), "--use", "strain"])
    assert rc == 2 and "unknown data kind(s) strain" in out
