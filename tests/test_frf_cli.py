"""The FRF commands (femupdate frf, frf-update, frf-select, surface): JSON of docs/file-formats.md,
UFF 58 export, round trips, and one clear message with the right exit code for bad input; the
benchmark's smoke mode."""

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from femupdate.io import read_uff
from test_cli import TWO_DOF as CLI_TWO_DOF
from test_cli import run

ROOT = Path(__file__).resolve().parents[1]

# the two-dof model of test_cli.py with the paper's k1, k2 ranges as bounds
TWO_DOF = (CLI_TWO_DOF.replace("bounds = [0.0, 100.0]", "bounds = [3.0, 13.0]", 1)
           .replace("bounds = [0.0, 100.0]", "bounds = [1.0, 11.0]", 1))


@pytest.fixture
def model_file(tmp_path):
    p = tmp_path / "two.toml"
    p.write_text(TWO_DOF)
    return p


def closed_form(w, col):
    a, b, d = 14 - 2 * w**2, -6.0, 6 - 4 * w**2
    A = np.array([[d, -b], [-b, a]]) / (a * d - b * b)
    return A[:, col]


def test_frf_json_is_the_interface(model_file, capsys):
    code, out, err = run(["frf", str(model_file), "--force", "2:x", "--omega", "0.5,1.0,1.5", "--json", "-"], capsys)
    assert code == 0, err
    res = json.loads(out)  # nothing but JSON on stdout
    assert res["omega_rad_s"] == [0.5, 1.0, 1.5] and res["dofs"] == ["1:x", "2:x"]
    for k, d in enumerate(res["dofs"]):
        pairs = np.array(res["response"][d])
        assert pairs.shape == (3, 2)  # [re, im] pairs
        np.testing.assert_allclose(pairs[:, 0], [closed_form(w, 1)[k] for w in (0.5, 1.0, 1.5)], rtol=1e-12)
        assert not np.any(pairs[:, 1])
    code, out, _ = run(["frf", str(model_file), "--force", "1:x=2", "--omega", "1:2:3", "--kind", "mobility",
                        "--damping", "eta=0.02", "--set", "k1=9", "--json", "-"], capsys)
    res = json.loads(out)
    assert code == 0 and res["kind"] == "frf" and res["quantity"] == "mobility" and res["damping"]["eta"] == 0.02
    assert res["parameters"]["k1"] == 9.0 and np.any(np.array(res["response"]["1:x"])[:, 1])


def test_frf_exports_uff_and_test_data_that_update_back(model_file, tmp_path, capsys):
    uff, data = tmp_path / "t.uff", tmp_path / "t.json"
    code, _, err = run(["frf", str(model_file), "--force", "1:x", "--omega", "0.4:2.8:7", "--dofs", "2:x",
                        "--uff", str(uff), "--test-data", str(data)], capsys)
    assert code == 0, err
    back = read_uff(uff).frf
    assert back.dofs == ("2:x",) and back.force == {"1:x": 1.0}
    np.testing.assert_allclose(back.omega, 0.4 * np.arange(1, 8), rtol=1e-5)
    np.testing.assert_allclose(back.response[:, 0].real, [closed_form(w, 0)[1] for w in 0.4 * np.arange(1, 8)], rtol=1e-5)
    code, out, err = run(["frf-update", str(model_file), str(data), "--set", "k1=7,k2=6.5", "--resonance", "keep",
                          "--json", "-"], capsys)
    assert code == 0, err
    res = json.loads(out)
    for key in ("parameters", "success", "cost", "iterations", "pairs", "frequencies_hz", "starts", "omega_rad_s",
                "skipped", "residual", "frac", "natural_frequencies_hz", "diagnostics", "history"):
        assert key in res, key
    np.testing.assert_allclose([res["parameters"]["k1"], res["parameters"]["k2"]], [8, 6], rtol=1e-8)
    assert res["starts"]["total"] == 1 and res["frac"]["2:x"] == pytest.approx(1.0)
    code, out, err = run(["frf-update", str(model_file), str(uff), "--starts", "8", "--seed", "1", "--resonance", "keep",
                          "--json", "-"], capsys)
    res = json.loads(out)
    assert code == 0, err
    assert res["starts"]["total"] == 8 and sum(s["count"] for s in res["starts"]["solutions"]) == res["starts"]["converged"]
    code, out, err = run(["frf-update", str(model_file), str(data), "--global", "differential_evolution", "--runs", "2",
                          "--resonance", "keep", "--plot", str(tmp_path / "plots"), "--json", "-"], capsys)
    res = json.loads(out)
    assert code == 0, err
    assert res["global"]["method"] == "differential_evolution" and len(res["global"]["optimizer"]) == 2
    np.testing.assert_allclose([res["parameters"]["k1"], res["parameters"]["k2"]], [8, 6], rtol=1e-8)
    assert (tmp_path / "plots" / "frf.png").exists() and (tmp_path / "plots" / "convergence.png").exists()
    # the local options reach the polish of a global search
    code, out, err = run(["frf-update", str(model_file), str(data), "--global", "differential_evolution",
                          "--resonance", "keep", "--regularization", "0.5", "--json", "-"], capsys)
    assert code == 0, err
    assert json.loads(out)["regularization"] == {"rule": "fixed", "alpha": 0.5}


def test_select_and_surface_commands(model_file, tmp_path, capsys):
    code, out, err = run(["frf-select", str(model_file), "--force", "1:x", "--candidates", "0.1:3:30", "--lines", "3",
                          "--json", "-"], capsys)
    assert code == 0, err
    res = json.loads(out)
    assert len(res["omega_rad_s"]) == 3 and res["condition_number"] <= res["uniform"]["condition_number"]
    data = tmp_path / "t.json"
    run(["frf", str(model_file), "--force", "1:x", "--omega", "0.5:2.5:5", "--test-data", str(data)], capsys)
    code, out, err = run(["surface", str(model_file), str(data), "--params", "k1,k2", "--x", "3:13:51", "--y", "1:11:51",
                          "--truth", "k1=8,k2=6", "--plot", str(tmp_path / "s.png"), "--json", "-"], capsys)
    assert code == 0, err
    res = json.loads(out)
    assert res["minimum"] == {"k1": 8.0, "k2": 6.0, "value": 0.0}
    assert np.array(res["values"]).shape == (51, 51) and res["local_minima"] >= 1
    assert (tmp_path / "s.png").stat().st_size > 10_000


@pytest.mark.parametrize("args, message", [
    (["frf", "{m}", "--force", "7:x", "--omega", "1"], "lacks: 7:x"),
    (["frf", "{m}", "--force", "1:x", "--omega", "1,abc"], "'abc' is not a number"),
    (["frf", "{m}", "--force", "1:x", "--omega", "0.5,2.7790500"], None),  # near, not on: fine
    (["frf", "{m}", "--force", "1:x=big", "--omega", "1"], "amplitude of '1:x' is not a number"),
    (["frf", "{m}", "--force", "1:x", "--omega", "1", "--damping", "zeta=0.1"], "unknown key"),
    (["frf", "{m}", "--force", "1:x", "--omega", "-1"], "not finite or negative"),
    (["frf-update", "{m}", "{c}"], "complex"),
    (["frf-update", "{m}", "{c}", "--lines", "x"], "not a list of line numbers"),
    (["surface", "{m}", "{d}", "--params", "k1,k2", "--x", "3:13:1", "--y", "1:11:5"], "at least two values"),
])
def test_bad_input_exit_2_with_one_message(model_file, tmp_path, capsys, args, message):
    cplx = tmp_path / "c.json"
    cplx.write_text(json.dumps({"frf": {"omega_rad_s": [0.5, 1.0], "force": {"2:x": 1.0},
                                        "response": {"1:x": [[0.1, 0.05], [0.2, 0.0]]}}}))
    good = tmp_path / "d.json"
    good.write_text(json.dumps({"frf": {"omega_rad_s": [0.5, 1.0], "force": {"2:x": 1.0},
                                        "response": {"1:x": [0.1, 0.2]}}}))
    argv = [a.format(m=model_file, c=cplx, d=good) for a in args]
    code, _, err = run(argv, capsys)
    if message is None:
        assert code == 0, err
        return
    assert code == 2, err
    assert message in err and "Traceback" not in err and err.count("error:") == 1


def test_resonance_and_non_convergence_messages(model_file, tmp_path, capsys):
    lam = np.sort(np.roots([8, -68, 48]))
    code, _, err = run(["frf", str(model_file), "--force", "1:x", "--omega", f"0.5,{float(np.sqrt(lam[1]))!r}"], capsys)
    assert code == 2 and "line 2 (omega = 2.77905 rad/s)" in err and "coincide" in err
    data = tmp_path / "d.json"
    run(["frf", str(model_file), "--force", "1:x", "--omega", f"0.5,1.0,1.5,{float(np.sqrt(lam[1]) * (1 + 1e-6))!r}",
         "--test-data", str(data)], capsys)
    code, _, err = run(["frf-update", str(model_file), str(data), "--resonance", "error"], capsys)
    assert code == 2 and "line 4" in err
    code, out, err = run(["frf-update", str(model_file), str(data), "--set", "k1=12,k2=2", "--max-nfev", "1",
                          "--json", "-"], capsys)
    assert code == 1 and "did not converge" in err and json.loads(out)["success"] is False


def test_bench_frf_quick_runs(tmp_path):
    out = tmp_path / "b.json"
    proc = subprocess.run([sys.executable, str(ROOT / "benchmarks" / "bench_frf.py"), "--quick", "--output", str(out)],
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    res = json.loads(out.read_text())
    assert res["surface"]["ok"] and res["sensitivity"]["ok"]
    assert res["sensitivity"]["fd"]["pairs_run"] == 4 and res["load_before"]
