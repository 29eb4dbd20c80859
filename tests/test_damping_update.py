"""Damping through the updating engine (issue 31, second slice): damped modes and damped FRF
blocks, ``femupdate update`` / ``frf-update`` on a model with a ``[damping]`` table, multi-start.

References: central finite differences for the exact Jacobians and the damped receptance
derivatives; the dense inverse of K + iD - ω²M + iωC for the receptances; recovery of the truth
(to 1e-6) from noise-free complex modes and FRFs simulated by the model itself; the undamped
update as a second route for a proportionally damped model (|λ| = ω and complex shapes that are
complex multiples of the real ones: the same residuals, so the same stiffness).
"""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest

import femupdate
from femupdate import Model
from femupdate._errors import InputError
from femupdate.damping import DampedModel, Damper, LossFactor, complex_modes, load_damped_model
from femupdate.damping.frf import damped_response
from femupdate.damping.view import DampedView
from femupdate.examples import TRUSS_DAMPING, truss_damped_model_toml
from femupdate.model import Parameter
from femupdate.testdata import FRFData, MeasuredMode, TestData
from femupdate.updating.damped import DampedFRFProblem, DampedModesProblem

DOFS = ("2:x", "2:y", "3:x", "3:y", "4:x", "4:y", "102:y", "103:y", "104:y")
TRUTH = {"E": 7.0e10, "b": TRUSS_DAMPING["beta"], "c1": TRUSS_DAMPING["c1"], "c2": TRUSS_DAMPING["c2"]}


def _truss() -> DampedModel:
    """The example truss with Rayleigh damping and two dampers (``truss_damped.toml``)."""
    import tempfile

    with tempfile.TemporaryDirectory() as d:
        p = Path(d) / "t.toml"
        p.write_text(truss_damped_model_toml())
        return load_damped_model(p)


def _modes(dm: DampedModel, n=4, std=True, dofs=DOFS) -> TestData:
    cm = complex_modes(dm, n_modes=n)
    idx = dm.model.dof_index(list(dofs))
    extra = dict(std_eigenvalue=2e-4, std_shape=1e-3) if std else {}
    return TestData(modes=tuple(MeasuredMode(float(abs(lam)) ** 2, tuple(dofs), cm.shapes[idx, r], damping_ratio=float(z),
                                             std_damping_ratio=1e-4 if std else None, **extra)
                                for r, (lam, z) in enumerate(zip(cm.eigenvalues, cm.damping_ratios))))


def _start(dm: DampedModel) -> DampedModel:
    return dm.with_values({"E": 6.0e10, "b": 5e-5, "c1": 100.0, "c2": 600.0})


def _fd(prob, x, h=1e-6):
    J = np.zeros((prob.n_residuals, x.size))
    for j in range(x.size):
        e = np.zeros_like(x)
        e[j] = h
        J[:, j] = (prob.residuals(x + e) - prob.residuals(x - e)) / (2 * h)
    return J


@pytest.fixture(scope="module")
def truss():
    return _truss()


def test_damped_modes_and_frf_jacobians_match_central_differences(truss):
    view = DampedView(_start(truss))
    names = ["E", "b", "c1", "c2"]
    prob = DampedModesProblem(view, _modes(truss, std=False), names, view.resolve(None))
    x = prob.x_start
    J = prob.jacobian(x)
    assert np.max(np.abs(J - _fd(prob, x))) <= 1e-6 * np.max(np.abs(J))
    om = np.linspace(20.0, 400.0, 12)
    X, _ = damped_response(truss, om, {"4:y": 1.0}, DOFS)
    fp = DampedFRFProblem(view, FRFData(om, {"4:y": 1.0}, DOFS, X), names, view.resolve(None))
    J = fp.jacobian(x)
    assert np.max(np.abs(J - _fd(fp, x))) <= 1e-6 * np.max(np.abs(J))
    # at the truth every residual vanishes
    xt = prob.from_p(np.array([TRUTH[n] for n in names]))
    assert np.max(np.abs(prob.residuals(xt))) < 1e-12 and np.max(np.abs(fp.residuals(xt))) < 1e-12


def test_damped_receptance_is_the_inverse_and_its_derivative_exact_with_hysteretic_damping():
    k1, k2 = np.array([[1.0, 0.0], [0.0, 0.0]]), np.array([[1.0, -1.0], [-1.0, 1.0]])
    m = Model(["1:x", "2:x"], np.zeros((2, 2)), np.diag([1.0, 2.0]), (Parameter("k1", 1000.0), Parameter("k2", 500.0)),
              (k1, k2), (None, None))
    dm = DampedModel(m, (Parameter("c", 3.0), Parameter("b", 2e-3), Parameter("eta", 0.02)), alpha=0.1, beta="b",
                     dampers=(Damper(("1:x",), "c"),), losses=(LossFactor("eta", "k2"),))
    om = np.array([5.0, 17.0, 31.0])
    names = list(dm.parameter_names)
    x, dx = damped_response(dm, om, {"2:x": 1.0}, ["1:x", "2:x"], None, names)
    p = dm.resolve(None)
    for i, w in enumerate(om):
        Z = (dm.K(p) + 1j * dm.D(p) - w * w * dm.M(p) + 1j * w * dm.C(p)).toarray()
        np.testing.assert_allclose(x[i], np.linalg.inv(Z)[:, 1], rtol=1e-12)
    for j, name in enumerate(names):
        h = 1e-6 * abs(p[j])
        up, dn = p.copy(), p.copy()
        up[j] += h
        dn[j] -= h
        fd = (damped_response(dm, om, {"2:x": 1.0}, ["1:x", "2:x"], up)[0]
              - damped_response(dm, om, {"2:x": 1.0}, ["1:x", "2:x"], dn)[0]) / (2 * h)
        np.testing.assert_allclose(dx[:, :, j], fd, rtol=1e-6, atol=1e-9 * np.max(np.abs(dx[:, :, j])), err_msg=name)


def _write_case(tmp_path: Path, data: TestData) -> tuple[Path, Path]:
    text = truss_damped_model_toml()
    for old, new in (("value = 7.0e10", "value = 6.0e10"), ("value = 2.0e-05", "value = 5.0e-05"),
                     ("value = 400.0", "value = 100.0"), ("value = 250.0", "value = 600.0")):
        assert old in text
        text = text.replace(old, new)
    (tmp_path / "start.toml").write_text(text)
    modes = [{"frequency_hz": float(np.sqrt(m.eigenvalue) / (2 * np.pi)), "damping_ratio": m.damping_ratio,
              "std_frequency": m.std_eigenvalue / 2, "std_damping_ratio": m.std_damping_ratio, "std_shape": m.std_shape,
              "shape": {d: [float(v.real), float(v.imag)] for d, v in zip(m.dofs, m.shape)}} for m in data.modes]
    (tmp_path / "test.json").write_text(json.dumps({"modes": modes}))
    return tmp_path / "start.toml", tmp_path / "test.json"


def _cli(args, capsys):
    from femupdate.cli import main

    with pytest.raises(SystemExit) as info:
        main([*map(str, args)])
    out, err = capsys.readouterr()
    return info.value.code, out, err


def test_update_cli_recovers_dampers_and_stiffness_from_noise_free_complex_modes(tmp_path, capsys, truss):
    model, test = _write_case(tmp_path, _modes(truss))
    code, out, err = _cli(["update", model, test, "--json", tmp_path / "r.json", "--report", tmp_path / "r.html"], capsys)
    assert code == 0, out + err
    r = json.loads((tmp_path / "r.json").read_text())
    for name, true in TRUTH.items():
        assert r["parameters"][name] == pytest.approx(true, rel=1e-6), name
    assert r["damping"]["parameters"] == ["b", "c1", "c2"] and r["formulation"] == "damped"
    assert set(r["damping"]["std"]) == {"b", "c1", "c2"} and all(v > 0 for v in r["damping"]["std"].values())
    np.testing.assert_allclose(r["damping"]["damping_ratios"]["model"], r["damping"]["damping_ratios"]["test"],
                               atol=1e-9)
    assert r["diagnostics"]["absolute"] is True  # every residual divided by the data file's deviations
    assert "damping parameters updated: b = 2e-05 ±" in out and "damping ratios of the paired modes" in out
    # the complexity table: the test shapes' MPC and MPD are data_complexity's, the model's those of
    # complex_modes' shapes at the measured dofs (the truth's, where the data were made)
    from femupdate.damping import data_complexity, mean_phase_deviation, modal_phase_collinearity

    cx = r["damping"]["complexity"]
    data = _modes(truss)
    assert cx["test"]["mpc"] == pytest.approx([c["mpc"] for c in data_complexity(data)], abs=1e-12)
    assert cx["test"]["mpd_deg"] == pytest.approx([c["mpd_deg"] for c in data_complexity(data)], abs=1e-9)
    U = complex_modes(truss, n_modes=4).shapes[truss.model.dof_index(list(DOFS)), :]
    assert cx["model"]["mpc"] == pytest.approx(modal_phase_collinearity(U).tolist(), abs=1e-9)
    assert cx["model"]["mpd_deg"] == pytest.approx(mean_phase_deviation(U).tolist(), abs=1e-6)
    assert min(cx["model"]["mpc"]) < 0.999  # the dampers make the shapes measurably complex
    assert "complexity of the paired shapes at the measured dofs" in out
    assert "complexity of each paired shape at the measured dofs" in (tmp_path / "r.html").read_text()
    assert "[damping] table is read by" not in err + out  # used, not ignored
    # the result reads back with its damping record
    back = femupdate.load_result(tmp_path / "r.json")
    assert back.damping["parameters"] == ["b", "c1", "c2"]


def test_frf_update_recovers_a_damper_and_both_rayleigh_coefficients_from_noise_free_frfs(truss):
    dm = DampedModel(truss.model, truss.parameters + (Parameter("a", 0.5, (0.0, 10.0)),), alpha="a", beta="b",
                     dampers=truss.dampers)
    truth = {"a": 0.5, "b": 2e-5, "c1": 400.0}
    om = 2 * np.pi * np.linspace(20.0, 300.0, 41)  # the three lowest peaks
    X, _ = damped_response(dm, om, {"4:y": 1.0}, DOFS[4:])
    data = TestData(frf=FRFData(om, {"4:y": 1.0}, DOFS[4:], X))
    start = dm.with_values({"a": 2.0, "b": 6e-5, "c1": 150.0})
    res = femupdate.updating.frf_update(start, data, params=["a", "b", "c1"])
    assert res.success
    for name, true in truth.items():
        assert res.parameters[name] == pytest.approx(true, rel=1e-6), name
    assert min(res.frac.values()) > 1 - 1e-10  # the peaks fitted
    assert res.damping["parameters"] == ["a", "b", "c1"]
    assert res.to_json()["kind"] == "frf-update"


def test_proportional_damping_gives_the_undamped_update_s_stiffness(truss):
    """Rayleigh damping: |λ| = ω and complex shapes proportional to the real ones, so the damped
    residuals of frequencies and shapes are the undamped ones; damping ratios generated by the
    Rayleigh model at the undamped answer's frequencies are met there exactly, so updating α, β
    as well leaves the stiffness where the undamped update puts it."""
    from femupdate.modal import model_modes

    model = truss.model
    rng = np.random.default_rng(3)
    truth = model_modes(model, n_modes=4)
    idx = model.dof_index(list(DOFS))
    noisy = TestData(modes=tuple(
        MeasuredMode(float(lam * (1 + 0.01 * rng.standard_normal())), DOFS,
                     truth.shapes[idx, r] * (1 + 0.02 * rng.standard_normal(idx.size)))
        for r, lam in enumerate(truth.eigenvalues)))
    undamped = femupdate.update(model.with_values({"E": 6e10}), noisy)
    E = undamped.parameters["E"]
    w = np.sqrt(model_modes(model, {"E": E}, n_modes=4).eigenvalues)
    a_true, b_true = 0.8, 3e-5
    zeta = a_true / (2 * w) + b_true * w / 2
    data = TestData(modes=tuple(dataclasses.replace(m, damping_ratio=float(z)) for m, z in zip(noisy.modes, zeta)))
    dm = DampedModel(model.with_values({"E": 6e10}), (Parameter("a", 0.2, (0, 10)), Parameter("b", 1e-5, (0, 1e-3))),
                     alpha="a", beta="b")
    res = femupdate.update(dm, data)
    assert res.success
    assert res.parameters["E"] == pytest.approx(E, rel=1e-8)
    assert res.parameters["a"] == pytest.approx(a_true, rel=1e-6)
    assert res.parameters["b"] == pytest.approx(b_true, rel=1e-6)
    assert not any("not updated" in n for n in res.notes)


def test_multistart_of_a_damped_model_and_the_compiled_route_refuses_it(truss):
    bounded = DampedModel(truss.model, tuple(dataclasses.replace(p, bounds=(0.0, 4 * p.value)) for p in truss.parameters),
                          alpha=truss.alpha, beta=truss.beta, dampers=truss.dampers)
    data = _modes(truss, n=3, std=False)
    ms = femupdate.multistart(_start(bounded), data, 3, seed=2)
    assert ms.converged == 3 and ms.best is not None
    for name, true in TRUTH.items():
        assert ms.best.parameters[name] == pytest.approx(true, rel=1e-5), name
    assert ms.to_json()["damping"]["parameters"] == ["b", "c1", "c2"]
    with pytest.raises(InputError, match="compiled route does not take damped models"):
        femupdate.multistart(bounded, data, 2, batched=True)


def test_damping_parameters_held_without_damping_data_and_static_data_refused(truss):
    cm = complex_modes(truss, n_modes=3)
    freq_only = TestData(modes=tuple(MeasuredMode(float(abs(lam)) ** 2) for lam in cm.eigenvalues))
    res = femupdate.update(truss.with_values({"E": 6.5e10}), freq_only)
    assert res.names == ("E",) and res.parameters["E"] == pytest.approx(7e10, rel=1e-8)
    assert any("damping parameters b, c1, c2 are not updated" in n for n in res.notes)
    from femupdate.testdata import StaticData

    static = TestData(modes=freq_only.modes, static=(StaticData({"4:y": 1.0}, ("4:y",), np.array([1e-6])),))
    with pytest.raises(InputError, match="static deflections with a damped model"):
        femupdate.update(truss, static)


def test_complex_data_to_an_undamped_model_is_said_with_what_is_used(truss):
    data = _modes(truss, n=3, std=False)
    res = femupdate.update(truss.model.with_values({"E": 6.5e10}), data)
    notes = " ".join(res.notes)
    assert "the test data hold complex shapes (test mode(s) 1, 2, 3) but the model is undamped: their real form" in notes
    assert "hold damping ratios (test mode(s) 1, 2, 3) but the model is undamped: the frequencies are used" in notes


BAD = {
    "percent ratio": ('"damping_ratio": 2.0', "damping_ratio: 2 is not a damping ratio in [0, 1)"),
    "negative ratio": ('"damping_ratio": -0.01', "damping_ratio: -0.01 is not a damping ratio in [0, 1)"),
    "negative damper": (None, "damper ['4:x', '104:y'] c = -3.0 is negative"),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_bad_damping_input_to_update_one_message_exit_2(tmp_path, capsys, truss, case):
    model, test = _write_case(tmp_path, _modes(truss, n=2))
    change, message = BAD[case]
    if change is None:
        model.write_text(model.read_text().replace('c = "c1"', "c = -3.0"))
    else:
        obj = json.loads(test.read_text())
        key, value = change.split(": ")
        obj["modes"][0]["damping_ratio"] = float(value)
        test.write_text(json.dumps(obj))
    code, out, err = _cli(["update", model, test], capsys)
    assert code == 2, out + err
    assert message in err and "Traceback" not in err and err.strip().count("\n") == 0, err


def test_large_damping_ratios_are_flagged_as_possible_percentages(truss):
    data = _modes(truss, n=3, std=False)
    data = TestData(modes=(dataclasses.replace(data.modes[0], damping_ratio=0.5),) + data.modes[1:])
    res = femupdate.update(truss, data, max_nfev=3)
    assert any("test mode(s) 1 have damping ratios above 0.2" in n and "percent" in n for n in res.notes)


def test_frf_update_cli_on_a_damped_model_fits_the_peaks_with_report_and_overlay(tmp_path, capsys, truss):
    model, _ = _write_case(tmp_path, _modes(truss, n=2))
    dofs = ("3:y", "4:y", "104:y")
    om = 2 * np.pi * np.linspace(20.0, 300.0, 29)
    X, _ = damped_response(truss, om, {"4:y": 1.0}, dofs)
    (tmp_path / "frf.json").write_text(json.dumps({"frf": {
        "omega_rad_s": om.tolist(), "force": {"4:y": 1.0},
        "response": {d: [[float(v.real), float(v.imag)] for v in X[:, i]] for i, d in enumerate(dofs)}}}))
    code, out, err = _cli(["frf-update", model, tmp_path / "frf.json", "--json", tmp_path / "f.json", "--report",
                           tmp_path / "f.html", "--plot", tmp_path / "figs"], capsys)
    assert code == 0, out + err
    r = json.loads((tmp_path / "f.json").read_text())
    for name, true in TRUTH.items():
        assert r["parameters"][name] == pytest.approx(true, rel=1e-6), name
    assert r["kind"] == "frf-update" and r["damping"]["parameters"] == ["b", "c1", "c2"]
    assert min(r["frac"].values()) > 1 - 1e-10
    assert (tmp_path / "figs" / "frf.png").exists()
    html = (tmp_path / "f.html").read_text()
    assert "the damped receptances of the model&#39;s [damping] table" in html
    assert "the damping parameters of the model&#39;s [damping] table: updated (with their standard deviations)" in html
    # --damping is for undamped models: refused with a [damping] table
    code, out, err = _cli(["frf-update", model, tmp_path / "frf.json", "--damping", "alpha=1"], capsys)
    assert code == 2 and "leave --damping out" in err and err.strip().count("\n") == 0, err


def test_a_loss_factor_is_updated_with_the_dampers_and_the_stiffness(truss):
    dm = DampedModel(truss.model, truss.parameters + (Parameter("eta", 0.02, (0.0, 0.5)),), alpha=truss.alpha,
                     beta=truss.beta, dampers=truss.dampers, losses=(LossFactor("eta", "E"),))
    res = femupdate.update(dm.with_values({"eta": 0.05, "c1": 200.0, "E": 6.6e10}), _modes(dm, std=False))
    assert res.success
    for name, true in {**TRUTH, "eta": 0.02}.items():
        assert res.parameters[name] == pytest.approx(true, rel=1e-6), name


def test_deviations_stated_for_some_modes_only_are_said_and_not_used(truss):
    data = _modes(truss, n=3, std=False)
    data = TestData(modes=(dataclasses.replace(data.modes[0], std_damping_ratio=1e-3),) + data.modes[1:])
    res = femupdate.update(truss.with_values({"c1": 300.0}), data)
    assert res.parameters["c1"] == pytest.approx(400.0, rel=1e-6)
    assert any("standard deviation of the damping ratio for some modes but not all: not used" in n for n in res.notes)
    assert res.diagnostics is not None and not res.diagnostics.absolute


def test_estimated_noise_of_damped_modes_counts_the_shapes_norm_and_phase(truss):
    """A unit-length, phase-aligned complex shape at n dofs gives 2n residuals but 2n - 2 degrees
    of freedom (its norm and its phase are fitted away), as the undamped unit shape loses one. The
    estimated noise of a damped modes block divides by n_residuals - 2 (shaped modes) - L; with
    the old count (n_residuals - L) the variance came 20/28 = 0.71 of the truth here (seen: 0.70)
    and the standard deviations 16 % short. Reference: over noise seeds the REML variance of one
    pool with equal noise sigma on every residual is unbiased, mean s^2/sigma^2 = 1 (seen: 0.98;
    std of the mean sqrt(2/20/40) = 0.05)."""
    dofs, sigma = ("3:y", "4:y", "104:y"), 1e-3
    clean = _modes(truss, dofs=dofs, std=False)
    ratios = []
    for seed in range(40):
        rng = np.random.default_rng(seed)
        noisy = []
        for m in clean.modes:
            v = np.asarray(m.shape) / np.linalg.norm(m.shape)
            noisy.append(dataclasses.replace(
                m, eigenvalue=m.eigenvalue * (1 + sigma * rng.standard_normal()),
                damping_ratio=m.damping_ratio + sigma * rng.standard_normal(),
                shape=v + sigma * (rng.standard_normal(v.size) + 1j * rng.standard_normal(v.size))))
        res = femupdate.update(truss, TestData(modes=tuple(noisy)))
        (comp,) = res.diagnostics.noise
        assert comp["n_residuals"] == 32 and comp["dof"] == pytest.approx(32 - 2 * 4 - 4, abs=1e-6)
        ratios.append(comp["std"] ** 2 / sigma ** 2)
    assert 0.85 < np.mean(ratios) < 1.15, np.mean(ratios)


def test_a_damper_driven_to_its_lower_bound_is_not_called_unseen(truss):
    """Data made without the damper c2 (c2 = 0, its lower bound): the update drives c2 to ~1e-30
    on the bound. The data do depend on c2 (its column at the start's scale is far from zero), so
    it is reported on its bound, not as "the data do not depend on it (zero sensitivity)", which
    the normalised column |p| dr/dp at |p| ~ 1e-30 used to say."""
    data = _modes(truss.with_values({"c2": 0.0}))
    res = femupdate.update(_start(truss), data)
    assert res.parameters["c2"] < 1e-6 and res.parameters["c1"] == pytest.approx(TRUTH["c1"], rel=1e-4)
    assert "c2" in res.diagnostics.at_bounds
    assert "c2" not in res.diagnostics.poorly_determined_reasons, res.diagnostics.poorly_determined_reasons


def test_deviations_stated_for_some_kinds_only_are_said(truss):
    """--std-damping-ratio alone (sdypy-EMA's modes state none): the damped modes block's noise is
    still one estimated scale on all its residuals, which then multiplies the stated damping-ratio
    deviations too; a note says so and names the options that complete the statement."""
    data = _modes(truss, std=False)
    start = _start(truss)
    partial = femupdate.update(start, data, measurement_std={"damping_ratio": 1e-4})
    msg = ("standard deviations stated for the damping ratios of the damped modes but not for the frequencies and "
           "shapes")
    assert any(msg in n and "--std-eigenvalue, --std-shape" in n for n in partial.notes), partial.notes
    for std in (None, {"damping_ratio": 1e-4, "eigenvalue": 2e-4, "shape": 1e-3}):
        res = femupdate.update(start, data, measurement_std=std)
        assert not any("standard deviations stated for the" in n for n in res.notes), res.notes
