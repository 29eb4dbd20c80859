"""The updated model out: --write-model (the model file again, with the updated values and a
[provenance] table), --csv (flat tables) and update --uff; each result read back by an
independent route (loading the written model and solving it again, the csv module)."""

import csv
import json
import tomllib

import numpy as np
import pytest
import scipy.sparse as sp

from femupdate import load_model, model_modes
from femupdate.cli import main
from femupdate.io.testdata_json import load_testdata


def run(args, capsys):
    with pytest.raises(SystemExit) as info:
        main(args)
    out, err = capsys.readouterr()
    return (0 if info.value.code is None else info.value.code), out, err


def test_update_writes_a_model_that_loads_and_reproduces_the_update(ex, tmp_path, capsys):
    out = tmp_path / "sub" / "updated.toml"
    out.parent.mkdir()
    code, text, err = run(["update", str(ex / "figure2.toml"), str(ex / "figure2_test.json"), "--write-model", str(out),
                           "--csv", str(tmp_path), "--json", str(tmp_path / "r.json")], capsys)
    assert code == 0, err
    assert f"wrote the updated model {out}" in text
    res = json.loads((tmp_path / "r.json").read_text())
    model = load_model(out)
    for name in res["updated"]:  # the values themselves, not six digits of them
        assert model.values[model.parameter_index(name)] == res["parameters"][name]
    np.testing.assert_allclose(model_modes(model).frequencies_hz[:3], res["frequencies_hz"]["model"], rtol=1e-12)
    prov = tomllib.loads(out.read_text())["provenance"]
    assert prov["command"] == "update" and prov["cost"] == res["cost"] and prov["updated"] == res["updated"]
    assert prov["source_model"].endswith("figure2.toml") and prov["data"].endswith("figure2_test.json")
    # the tables: one row per parameter, modes numbered as on the terminal (1-based)
    rows = list(csv.DictReader((tmp_path / "parameters.csv").open()))
    assert [r["parameter"] for r in rows] == res["updated"]
    assert [float(r["updated"]) for r in rows] == [res["parameters"][n] for n in res["updated"]]
    modes = list(csv.DictReader((tmp_path / "modes.csv").open()))
    assert [(int(m["test_mode"]), int(m["model_mode"])) for m in modes] == [(k + 1, j + 1) for k, j, _ in res["pairs"]]
    np.testing.assert_array_equal([float(m["mac"]) for m in modes], [m for _, _, m in res["pairs"]])


def test_a_matrix_model_written_elsewhere_finds_its_matrices(tmp_path, capsys):
    """Matrix files are referenced relative to the model file: written into another folder, the
    updated model points at the same matrices."""
    src = tmp_path / "export"
    src.mkdir()
    K1 = sp.csr_matrix(np.array([[1.0, 0.0], [0.0, 0.0]]))
    K2 = sp.csr_matrix(np.array([[1.0, -1.0], [-1.0, 1.0]]))
    sp.save_npz(src / "K0.npz", sp.csr_matrix((2, 2)))
    sp.save_npz(src / "M0.npz", sp.csr_matrix(np.diag([2.0, 1.0])))
    sp.save_npz(src / "K1.npz", K1)
    sp.save_npz(src / "K2.npz", K2)
    (src / "dofs.txt").write_text("# exported\n1:x\n2:x\n")
    (src / "m.toml").write_text('[model]\nname = "exported"\n[matrices]\ndofs = "dofs.txt"\nK0 = "K0.npz"\nM0 = "M0.npz"\n'
                                '[parameters.k1]\nvalue = 7.0\nbounds = [1.0, 20.0]\nK = "K1.npz"\n'
                                '[parameters.k2]\nvalue = 5.0\nbounds = [1.0, 20.0]\nK = "K2.npz"\n')
    truth = load_model(src / "m.toml")
    mm = model_modes(truth, {"k1": 8.0, "k2": 6.0})
    (src / "d.json").write_text(json.dumps({"modes": [{"eigenvalue": float(mm.eigenvalues[j]),
                                                        "shape": {"1:x": float(mm.shapes[0, j]), "2:x": float(mm.shapes[1, j])}}
                                                       for j in range(2)]}))
    out = tmp_path / "results" / "deep" / "updated.toml"
    out.parent.mkdir(parents=True)
    code, _, err = run(["update", str(src / "m.toml"), str(src / "d.json"), "--write-model", str(out)], capsys)
    assert code == 0, err
    raw = tomllib.loads(out.read_text())
    assert raw["matrices"]["K0"] == "../../export/K0.npz" and raw["parameters"]["k2"]["K"] == "../../export/K2.npz"
    updated = load_model(out)
    np.testing.assert_allclose(updated.values, [8.0, 6.0], rtol=1e-9)
    np.testing.assert_allclose(model_modes(updated).eigenvalues, mm.eigenvalues, rtol=1e-9)
    load_testdata(src / "d.json", updated)  # the same dofs


def test_direct_writes_the_identified_model(ex, tmp_path, capsys):
    out = tmp_path / "direct.toml"
    code, _, err = run(["direct", str(ex / "figure2.toml"), str(ex / "figure2_test.json"), "--write-model", str(out),
                        "--csv", str(tmp_path), "--json", str(tmp_path / "r.json")], capsys)
    assert code == 0, err
    res = json.loads((tmp_path / "r.json").read_text())
    model = load_model(out)
    for name, v in res["parameters"].items():
        assert model.values[model.parameter_index(name)] == v
    assert tomllib.loads(out.read_text())["provenance"]["command"] == "direct"
    assert [r["parameter"] for r in csv.DictReader((tmp_path / "parameters.csv").open())] == list(res["parameters"])


def test_nothing_is_written_for_an_update_that_did_not_converge(ex, tmp_path, capsys):
    out = tmp_path / "u.toml"
    code, text, _ = run(["update", str(ex / "figure2.toml"), str(ex / "figure2_test.json"), "--max-nfev", "1",
                         "--write-model", str(out)], capsys)
    assert code == 1 and not out.exists() and "not written" in text


def test_the_written_model_must_be_toml_and_a_provenance_must_be_a_table(ex, tmp_path, capsys):
    code, _, err = run(["update", str(ex / "figure2.toml"), str(ex / "figure2_test.json"), "--write-model",
                        str(tmp_path / "u.json")], capsys)
    assert code == 2 and "must end in .toml (a model file)" in err
    bad = tmp_path / "bad.toml"
    bad.write_text('provenance = "from somewhere"\n' + (ex / "figure2.toml").read_text())
    code, _, err = run(["modes", str(bad)], capsys)
    assert code == 2 and "[provenance] must be a table" in err


def test_update_multi_writes_the_updated_base_model(ex, tmp_path, capsys):
    out = tmp_path / "multi.toml"
    code, _, err = run(["update-multi", str(ex / "two_dof.toml"), "--config", str(ex / "two_dof_frequencies.json"),
                        "--config", f"{ex / 'two_dof_plus_2kg.json'}:{ex / 'plus_2kg.toml'}", "--write-model", str(out),
                        "--json", str(tmp_path / "r.json")], capsys)
    assert code == 0, err
    res = json.loads((tmp_path / "r.json").read_text())
    model = load_model(out)
    for name in res["updated"]:
        assert model.values[model.parameter_index(name)] == res["parameters"][name]
    np.testing.assert_allclose(model.values, [8.0, 6.0], rtol=1e-6)  # the two configurations' unique answer
    prov = tomllib.loads(out.read_text())["provenance"]
    assert prov["command"] == "update-multi" and "plus_2kg.toml" in prov["data"]
