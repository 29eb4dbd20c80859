"""The FRF and uniqueness results serialise themselves (kinds frf, frf-select, surface, frf-update,
uniqueness): a Python user writes the same JSON (and, where the command has --report, the same
report) as the command line from the result object, and a result read back writes the same JSON."""

from __future__ import annotations

import json
import math
import re
import sys
from pathlib import Path

import numpy as np
import pytest

import femupdate as fu
from femupdate.frf import Surface, frf_surface, modal_surface, receptance, select_frequencies
from femupdate.options import SelectionOptions
from femupdate.serialise import SCHEMA_VERSION
from femupdate.uniqueness import define_study, nested_dof_sets, run_study

sys.path.insert(0, str(Path(__file__).resolve().parent))
from results_helpers import cli, plain, timeless, without_stamp  # noqa: E402


def _json_of(args, tmp_path, capsys, code=0):
    out = tmp_path / "cli.json"
    got, _, err = cli([*args, "--json", out], capsys)
    assert got == code, err
    return json.loads(out.read_text())


def _read_back(obj):
    """The JSON of the result read back from ``obj`` (by its kind)."""
    return plain(fu.load_result(obj).to_json())


# ---------------------------------------------------------------------------------- frf
def test_simulated_frfs_write_the_json_of_frf(ex, tmp_path, capsys):
    model_path = ex / "two_dof.toml"
    args = ["frf", model_path, "--force", "2:x=2", "--omega", "0.5,1.0,1.5,2.5", "--kind", "mobility",
            "--damping", "alpha=0.01,beta=0.001", "--noise", "0.01", "--seed", "3", "--set", "k1=7.5"]
    obj = _json_of(args, tmp_path, capsys)
    model = fu.load_model(model_path)
    omega = [0.5, 1.0, 1.5, 2.5]
    sim = fu.simulate_frf(model, omega, {"2:x": 2.0}, values={"k1": 7.5}, damping={"alpha": 0.01, "beta": 0.001},
                          noise=0.01, noise_kind="relative", seed=3)
    assert isinstance(sim, fu.FRFData)  # still test data: receptances
    py = plain(sim.with_quantity("mobility").to_json())
    assert py == obj and obj["kind"] == "frf" and obj["quantity"] == "mobility" and obj["schema_version"] == SCHEMA_VERSION
    assert _read_back(obj) == obj
    # a second route: the noise-free mobility is i omega times the receptance Z^-1 f solved column by column
    clean = fu.simulate_frf(model, omega, {"2:x": 2.0}, values={"k1": 7.5}, damping={"alpha": 0.01, "beta": 0.001})
    alpha = receptance(model, omega, ["2:x"], values={"k1": 7.5}, damping={"alpha": 0.01, "beta": 0.001})[:, :, 0]
    mob = np.array([[complex(*p) for p in clean.with_quantity("mobility").to_json()["response"][d]] for d in clean.dofs]).T
    np.testing.assert_allclose(mob, 1j * np.array(omega)[:, None] * 2.0 * alpha, rtol=1e-12)
    # read back, the data are the receptances again (converted from the mobilities)
    back = fu.load_result(obj)
    np.testing.assert_allclose(back.response, sim.response, rtol=1e-12)


def test_frf_test_data_and_the_note_near_a_resonance(ex, tmp_path, capsys):
    model = fu.load_model(ex / "two_dof.toml")
    lam = fu.model_modes(model).eigenvalues
    omega = [0.5, float(np.sqrt(lam[0]) * (1 + 1e-4))]  # within 1e-3 of the first resonance
    args = ["frf", ex / "two_dof.toml", "--force", "1:x", "--omega", ",".join(map(repr, omega)),
            "--test-data", tmp_path / "data.json"]
    obj = _json_of(args, tmp_path, capsys)
    sim = fu.simulate_frf(model, omega, {"1:x": 1.0}, seed=0)
    assert plain(sim.to_json()) == obj
    assert len(obj["notes"]) == 1 and "line 2" in obj["notes"][0]
    assert json.loads((tmp_path / "data.json").read_text()) == plain(sim.test_data())
    assert _read_back(obj)["notes"] == obj["notes"]  # as read: the model is not at hand


# ---------------------------------------------------------------------------------- frf-select
def test_selections_write_the_json_of_frf_select(ex, tmp_path, capsys):
    model_path = ex / "two_dof.toml"
    obj = _json_of(["frf-select", model_path, "--force", "1:x", "--candidates", "0.1:3:30", "--lines", "4",
                    "--kind", "sensitivity", "--dofs", "2:x", "--margin", "0.02"], tmp_path, capsys)
    model = fu.load_model(model_path)
    cand = np.linspace(0.1, 3, 30)
    by_keywords = select_frequencies(model, cand, 4, {"1:x": 1.0}, kind="sensitivity", response=["2:x"], margin=0.02)
    by_options = select_frequencies(model, cand, 4, {"1:x": 1.0}, SelectionOptions(equations="sensitivity", margin=0.02),
                                    response=["2:x"])
    assert plain(by_keywords.to_json()) == plain(by_options.to_json()) == obj
    assert obj["kind"] == "frf-select" and obj["equations"] == "sensitivity"
    assert obj["lines"] == [int(np.argmin(np.abs(cand - w))) + 1 for w in obj["omega_rad_s"]]
    assert _read_back(obj) == obj


def test_selection_options_refuse_by_name(ex):
    model = fu.load_model(ex / "two_dof.toml")
    with pytest.raises(fu.InputError, match="unknown selection equations 'complete'"):
        select_frequencies(model, [0.5, 1.0, 2.0], 2, {"1:x": 1.0}, kind="complete")
    with pytest.raises(fu.InputError, match="margin must be a finite number >= 0"):
        SelectionOptions(margin=-1)
    with pytest.raises(TypeError, match="lines_per_start"):
        select_frequencies(model, [0.5, 1.0, 2.0], 2, {"1:x": 1.0}, lines_per_start=3)


# ---------------------------------------------------------------------------------- surface
@pytest.mark.parametrize("kind", ["frf", "modal"])
def test_surfaces_write_the_json_of_surface(ex, tmp_path, capsys, kind):
    if kind == "frf":
        model_path, data_path = ex / "two_dof.toml", ex / "two_dof_frf.json"
        args = ["--params", "k1,k2", "--x", "3:13:21", "--y", "1:11:21", "--residual", "log", "--truth", "k1=8,k2=6"]
    else:
        model_path, data_path = ex / "figure2.toml", ex / "figure2_test.json"
        args = ["--kind", "modal", "--params", "k1,k2", "--x", "500:1500:11", "--y", "1500:2500:11"]
    obj = _json_of(["surface", model_path, data_path, *args], tmp_path, capsys)
    model = fu.load_model(model_path)
    data = fu.load_test_data(data_path, model)
    if kind == "frf":
        surf = frf_surface(model, data.frf, ["k1", "k2"], np.linspace(3, 13, 21), np.linspace(1, 11, 21),
                           residual="log", truth=(8, 6))
    else:
        surf = modal_surface(model, data, ["k1", "k2"], np.linspace(500, 1500, 11), np.linspace(1500, 2500, 11))
    assert plain(surf.to_json()) == obj and obj["kind"] == "surface"
    assert obj["residual"] == ("frf (eq. 34, log)" if kind == "frf" else "modal (eq. 33)")
    assert _read_back(obj) == obj


def test_a_singular_grid_point_is_null_and_reads_back_as_inf():
    values = np.arange(12.0).reshape(3, 4) + 1
    values[1, 2] = math.inf
    s = Surface(("a", "b"), np.arange(3.0), np.arange(4.0), values, "test")
    obj = plain(s.to_json())
    assert obj["values"][1][2] is None and obj["singular_points"] == 1 and obj["model"] == ""
    back = fu.load_result(obj)
    assert back.values[1, 2] == math.inf and back.summary() == s.summary()


# ---------------------------------------------------------------------------------- frf-update
@pytest.mark.parametrize("args, call", [
    ([], dict()),
    (["--set", "k1=7.5", "--residual", "log", "--damping", "alpha=0.001", "--std", "0.01"],
     dict(values={"k1": 7.5}, residual="log", damping={"alpha": 0.001}, measurement_std=0.01)),
    (["--starts", "6", "--seed", "2", "--residual", "linear"], dict(starts=6, seed=2, residual="linear")),
    (["--global", "differential_evolution", "--runs", "2", "--seed", "1"],
     dict(method="differential_evolution", runs=2, seed=1)),
])
def test_frf_updates_write_the_json_and_report_of_frf_update(ex, tmp_path, capsys, args, call):
    model_path, data_path = ex / "two_dof.toml", ex / "two_dof_frf.json"
    code, _, err = cli(["frf-update", model_path, data_path, *args, "--json", tmp_path / "cli.json",
                        "--report", tmp_path / "cli.html"], capsys)
    assert code == 0, err
    obj = json.loads((tmp_path / "cli.json").read_text())
    model = fu.load_model(model_path)
    data = fu.load_test_data(data_path, model)
    call = dict(call)
    if "method" in call:
        result = fu.global_search(model, data, **call)
    elif "starts" in call:
        result = fu.frf_multistart(model, data, **call)
    else:
        result = fu.frf_update(model, data, **call)
    assert timeless(plain(result.to_json())) == timeless(obj) and obj["kind"] == "frf-update"
    assert timeless(_read_back(obj)) == timeless(obj)
    damping = call.get("damping")
    result = result.with_context(damping=None if damping is None else fu.frf.Damping(**damping),
                                 before=None if "values" not in call else dict(zip(model.parameter_names,
                                                                                   model.resolve(call["values"]))))
    result.write_report(tmp_path / "py.html", source=f"run on {model_path}")
    assert without_stamp((tmp_path / "py.html").read_text()) == without_stamp((tmp_path / "cli.html").read_text())


def test_an_frf_study_without_a_converged_start(ex, tmp_path, capsys):
    model_path, data_path = ex / "two_dof.toml", ex / "two_dof_frf.json"
    obj = _json_of(["frf-update", model_path, data_path, "--starts", "3", "--max-nfev", "1"], tmp_path, capsys, code=1)
    assert set(obj) == {"kind", "schema_version", "model", "success", "starts"} and obj["success"] is False
    model = fu.load_model(model_path)
    ms = fu.frf_multistart(model, fu.load_test_data(data_path, model), starts=3, max_nfev=1)
    assert ms.best is None and timeless(plain(ms.to_json())) == timeless(obj)


# ---------------------------------------------------------------------------------- uniqueness
def test_a_study_writes_the_json_and_report_of_uniqueness(ex, tmp_path, capsys):
    model_path = ex / "two_dof.toml"
    code, out, err = cli(["uniqueness", model_path, "--starts", "20", "--seed", "3", "--exact", "--plot", tmp_path,
                          "--json", tmp_path / "cli.json", "--report", tmp_path / "cli.html"], capsys)
    assert code == 0, err
    obj = json.loads((tmp_path / "cli.json").read_text())
    model = fu.load_model(model_path)
    study = define_study(model, [(s, m) for s in nested_dof_sets(model) for m in (1, 2)], starts=20, seed=3)
    res = run_study(study).with_exact().with_figure(tmp_path / "uniqueness.png")
    py = plain(res.to_json())
    assert timeless(py) == timeless(obj) and obj["kind"] == "uniqueness" and obj["figure"].endswith("uniqueness.png")
    # the exact solution sets of the one-sensor, two-mode case: the truth and (39/4, 14/3) (docs/cli.md)
    one_sensor = next(c for c in obj["cases"] if c["n_measured"] == 1 and c["n_modes"] == 2)
    assert {(s["exact"]["k1"], s["exact"]["k2"]) for s in one_sensor["exact"]["solutions"]} == {("7", "13/2"),
                                                                                                ("39/4", "14/3")}
    back = fu.load_result(tmp_path / "cli.json")
    assert back.study is None and plain(back.to_json()) == obj
    assert back.criteria_agreement() == obj["criteria_agreement"] == res.criteria_agreement()
    res.write_report(tmp_path / "py.html", source=f"run on {model_path}")
    assert without_stamp((tmp_path / "py.html").read_text()) == without_stamp((tmp_path / "cli.html").read_text())


def test_a_study_with_noise_reads_back(ex):
    model = fu.load_model(ex / "figure2.toml")
    study = define_study(model, [(("1:x",), 1), (("1:x", "2:x", "3:x"), 2)], starts=6, seed=5, noise=[0.01])
    obj = plain(run_study(study).to_json())
    assert obj["noise_levels"] == [0.01] and len(obj["cases"][1]["noise"]) == 1
    assert _read_back(obj) == obj
    frame_rows = fu.load_result(obj).records()
    assert [r["verdict"] for r in frame_rows] == [c["verdict"] for c in obj["cases"]]
    with pytest.raises(fu.InputError, match="a result read back from JSON has none"):
        fu.load_result(obj).with_exact()


# ---------------------------------------------------------------------------------- progress
@pytest.mark.parametrize("args, what", [
    (["uniqueness", "{ex}/two_dof.toml", "--starts", "10"], "updates"),
    (["frf-update", "{ex}/two_dof.toml", "{ex}/two_dof_frf.json", "--starts", "4"], "starts"),
    (["frf-update", "{ex}/two_dof.toml", "{ex}/two_dof_frf.json", "--global", "dual_annealing", "--runs", "2"],
     "dual_annealing runs"),
])
def test_long_runs_say_how_far_they_are_when_piped(ex, capsys, monkeypatch, args, what):
    """Through outputs.progress (here with no quiet start and no rate limit): lines on stderr."""
    import functools

    from femupdate.cli import outputs

    monkeypatch.setattr(outputs, "progress", functools.partial(outputs.progress, after=0.0, every=0.0))
    code, _, err = cli([a.format(ex=ex) for a in args], capsys)
    assert code == 0, err
    lines = [line for line in err.splitlines() if line.startswith(f"femupdate: {what} ")]
    assert lines and re.match(rf"femupdate: {what} (\d+)/\1 \(100%\)", lines[-1]), err
