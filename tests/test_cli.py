import json
import subprocess
import sys

import numpy as np
import pytest

import femupdate as fu
from femupdate.cli import main
from femupdate.examples import figure2_model_toml, figure2_test_data

TWO_DOF = '''
[model]
name = "two-dof"
[parameters.k1]
value = 8.0
bounds = [0.0, 100.0]
[parameters.k2]
value = 6.0
bounds = [0.0, 100.0]
[[element]]
type = "spring"
dofs = ["1:x"]
k = "k1"
[[element]]
type = "spring"
dofs = ["1:x", "2:x"]
k = "k2"
[[element]]
type = "mass"
dofs = ["1:x"]
m = 2.0
[[element]]
type = "mass"
dofs = ["2:x"]
m = 4.0
'''


def run(args, capsys):
    with pytest.raises(SystemExit) as info:
        main(args)
    out, err = capsys.readouterr()
    return info.value.code, out, err


@pytest.fixture
def two_dof_file(tmp_path):
    p = tmp_path / "two.toml"
    p.write_text(TWO_DOF)
    return p


def test_modes_json(two_dof_file, capsys):
    code, out, err = run(["modes", str(two_dof_file), "--json", "-"], capsys)
    assert code == 0, err
    res = json.loads(out)  # nothing but JSON on stdout in --json - mode
    np.testing.assert_allclose(res["eigenvalues"], np.sort(np.roots([8, -68, 48])), rtol=1e-12)
    assert res["dofs"] == ["1:x", "2:x"] and len(res["shapes"]) == 2 and len(res["shapes"][0]) == 2
    np.testing.assert_allclose(res["frequencies_hz"], np.sqrt(res["eigenvalues"]) / (2 * np.pi))


def test_modes_set_and_normalise(two_dof_file, capsys):
    code, out, _ = run(["modes", str(two_dof_file), "--set", "k1=9,k2=5.333333333333333", "--normalise", "ref:1:x", "--json", "-"], capsys)
    assert code == 0
    res = json.loads(out)
    np.testing.assert_allclose(res["eigenvalues"], np.sort(np.roots([8, -68, 48])), rtol=1e-12)
    np.testing.assert_allclose([s[0] for s in res["shapes"]], 1.0)


def test_modes_readable_summary(two_dof_file, capsys, tmp_path):
    out_json = tmp_path / "r.json"
    code, out, _ = run(["modes", str(two_dof_file), "--json", str(out_json)], capsys)
    assert code == 0 and "frequency" in out and "0.14028" in out
    assert json.loads(out_json.read_text())["n_rigid"] == 0


def test_direct_from_files(tmp_path, capsys):
    (tmp_path / "m.toml").write_text(figure2_model_toml())
    (tmp_path / "d.json").write_text(json.dumps(figure2_test_data(noise=0.0)))
    code, out, err = run(["direct", str(tmp_path / "m.toml"), str(tmp_path / "d.json"), "--json", "-"], capsys)
    assert code == 0, err
    res = json.loads(out)
    # noise-free data rounded to 6 digits in the file: the truth to about 1e-5
    np.testing.assert_allclose([res["parameters"][k] for k in ("k1", "k2", "k3", "k4")], [1000, 2000, 1500, 500], rtol=1e-4)
    assert res["condition_number"] > 1 and res["residual_norm"] >= 0 and res["unique"] is True


@pytest.mark.parametrize("args, code, fragment", [
    (["modes", "{dir}/missing.toml"], 2, "no such file"),
    (["modes", "{model}", "--set", "k9=1"], 2, "parameter 'k9' is not in model"),
    (["modes", "{model}", "--set", "k1=abc"], 2, "not a number"),
    (["modes", "{model}", "--n-modes", "5"], 2, "only 2 dofs"),
    (["direct", "{model}", "{dir}/partial.json"], 2, "missing 1 of 2: 2:x"),
    (["direct", "{model}", "{dir}/nan.json"], 2, "NaN"),
    (["direct", "{model}", "{dir}/short.json"], 2, "no complete data"),
    (["paper", "--out", "{dir}/p", "--section", "nope"], 2, "unknown section"),
    (["frobnicate"], 2, "No such command"),
    (["modes", "{model}", "--json", "{model}/cannot/write.json"], 2, "is a file, not a folder"),
])
def test_bad_input_exit_2_without_traceback(tmp_path, two_dof_file, capsys, args, code, fragment):
    (tmp_path / "partial.json").write_text(json.dumps({"modes": [{"eigenvalue": 1.0, "shape": {"1:x": 1.0}}]}))
    (tmp_path / "nan.json").write_text('{"modes": [{"eigenvalue": 1.0, "shape": {"1:x": NaN, "2:x": 1.0}}]}')
    (tmp_path / "short.json").write_text(json.dumps({"modes": [{"frequency_hz": 0.14}, {"frequency_hz": 0.44}]}))
    args = [a.format(dir=tmp_path, model=two_dof_file) for a in args]
    got, out, err = run(args, capsys)
    assert got == code
    assert fragment in err
    assert "Traceback" not in err + out


def test_non_unique_direct_exits_1(tmp_path, capsys):
    text = TWO_DOF + '[parameters.k2b]\nvalue = 1.0\n[[element]]\ntype = "spring"\ndofs = ["1:x", "2:x"]\nk = "k2b"\n'
    (tmp_path / "m.toml").write_text(text)
    lam = np.sort(np.roots([8, -68, 48]))
    data = {"modes": []}
    K = np.array([[14.0, -6.0], [-6.0, 6.0]])
    for l in lam:
        w, v = np.linalg.eigh(np.linalg.solve(np.diag([2.0, 4.0]), K))
        vec = np.linalg.svd(K - l * np.diag([2.0, 4.0]))[2][-1]
        data["modes"].append({"eigenvalue": float(l), "shape": {"1:x": float(vec[0]), "2:x": float(vec[1])}})
    (tmp_path / "d.json").write_text(json.dumps(data))
    code, out, err = run(["direct", str(tmp_path / "m.toml"), str(tmp_path / "d.json"), "--json", str(tmp_path / "r.json")], capsys)
    assert code == 1 and "not unique" in err and "Traceback" not in err
    assert json.loads((tmp_path / "r.json").read_text())["unique"] is False  # the result is still written


def test_demo_json(capsys):
    code, out, err = run(["demo", "--json", "-"], capsys)
    assert code == 0, err
    res = json.loads(out)
    truth = res["true"]
    for name, se in res["standard_error"].items():
        assert abs(res["parameters"][name] - truth[name]) < 4 * se  # the truth within 4 standard errors
    assert res["unique"] and len(res["pairs"]) == 3


def test_console_script_end_to_end(tmp_path):
    """The installed entry point, as a user runs it: readable output, exit codes, no traceback."""
    ok = subprocess.run([sys.executable, "-m", "femupdate", "demo"], capture_output=True, text=True, timeout=120)
    assert ok.returncode == 0 and "identified" in ok.stdout
    bad = subprocess.run([sys.executable, "-m", "femupdate", "modes", str(tmp_path / "x.toml")], capture_output=True, text=True, timeout=120)
    assert bad.returncode == 2 and "no such file" in bad.stderr and "Traceback" not in bad.stderr


def test_uff_round_trip_through_the_cli(tmp_path, capsys):
    """Model modes written as UFF 55 (3-component nodes, zero-padded) are test data for direct."""
    (tmp_path / "m.toml").write_text(figure2_model_toml())
    truth = "k1=1000,k2=2000,k3=1500,k4=500"
    code, _, err = run(["modes", str(tmp_path / "m.toml"), "--set", truth, "--uff", str(tmp_path / "t.uff")], capsys)
    assert code == 0, err
    code, out, err = run(["direct", str(tmp_path / "m.toml"), str(tmp_path / "t.uff"), "--json", "-"], capsys)
    assert code == 0, err
    res = json.loads(out)
    # universal files keep about six significant digits
    np.testing.assert_allclose([res["parameters"][k] for k in ("k1", "k2", "k3", "k4")], [1000, 2000, 1500, 500], rtol=1e-4)


def test_terminal_output_keeps_dof_labels_literal(capsys):
    """Rich would turn ":x:" between two dof labels ("1:x:2:x", "3:x:ok") into emoji."""
    from femupdate.cli._common import Ctx

    ctx = Ctx(None)
    ctx.console.print("pairs 1:x:2:x and 3:cross_mark:")
    assert "pairs 1:x:2:x and 3:cross_mark:" in capsys.readouterr().out


def test_modes_table_shows_the_units_of_every_column(tmp_path, capsys):
    """Units in brackets are text, not terminal markup: the eigenvalue column keeps [rad²/s²]."""
    from femupdate.examples import two_dof_model_toml

    model = tmp_path / "m.toml"
    model.write_text(two_dof_model_toml())
    with pytest.raises(SystemExit) as info:
        main(["modes", str(model)])
    assert info.value.code in (0, None)
    out = capsys.readouterr().out
    assert "frequency [Hz]" in out and "eigenvalue [rad²/s²]" in out


def test_a_shape_noise_for_data_without_shapes_in_use_is_refused(tmp_path, capsys):
    """--std-shape where no shape is used would be silently ignored: it is refused, with the reason."""
    from femupdate.examples import two_dof, two_dof_model_toml

    model = tmp_path / "m.toml"
    model.write_text(two_dof_model_toml())
    modes = fu.model_modes(two_dof())
    freq = tmp_path / "freq.json"
    freq.write_text(json.dumps({"modes": [{"eigenvalue": float(v)} for v in modes.eigenvalues]}))
    shapes = tmp_path / "shapes.json"
    shapes.write_text(json.dumps({"modes": [{"eigenvalue": float(v),
                                             "shape": dict(zip(modes.dofs, map(float, modes.shapes[:, i])))}
                                            for i, v in enumerate(modes.eigenvalues)]}))
    for data, extra, message in ((freq, [], "--std-shape: the data used have no mode shapes"),
                                 (shapes, ["--eigenvalues-only"],
                                  "--std-shape with --eigenvalues-only: the mode shapes are not used")):
        with pytest.raises(SystemExit) as info:
            main(["update", str(model), str(data), "--std-shape", "0.01", *extra])
        err = capsys.readouterr().err
        assert info.value.code == 2 and message in err and "Traceback" not in err
