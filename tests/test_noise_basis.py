"""Every standard deviation says what it rests on (issue 27, item 2): the terminal's ``std basis``
lines and the JSON's ``diagnostics.noise`` name stated (data file or option), estimated and pooled
noise, and the fit's test (item 6) is printed and stored under ``model_error``."""

import json

import pytest

from femupdate.cli import main
from femupdate.examples import figure2_model_toml, figure2_test_data


def run(args, capsys):
    with pytest.raises(SystemExit) as info:
        main(args)
    out, err = capsys.readouterr()
    return info.value.code, out, err


@pytest.fixture
def figure2(tmp_path):
    model = tmp_path / "figure2.toml"
    model.write_text(figure2_model_toml())
    data = figure2_test_data()
    plain = tmp_path / "test.json"
    plain.write_text(json.dumps(data))
    stated = tmp_path / "stated.json"
    for m in data["modes"]:
        m["std_frequency"] = 0.0005
        m["std_shape"] = 0.01
    stated.write_text(json.dumps(data))
    return model, plain, stated, tmp_path


def _basis(out):
    return [line for line in out.splitlines() if line.startswith("std basis:")]


def test_estimated_noise_is_said_pooled_with_its_dof(figure2, capsys):
    model, plain, _, tmp = figure2
    code, out, _ = run(["update", str(model), str(plain), "--json", str(tmp / "r.json")], capsys)
    assert code in (0, None)
    lines = _basis(out)
    assert any("estimated from the fit, pooled" in line and " dof" in line for line in lines)
    assert any("REML" in line for line in lines)
    res = json.loads((tmp / "r.json").read_text())
    noise = res["diagnostics"]["noise"]
    assert {c["basis"] for c in noise} <= {"estimated", "pooled"} and all(c["dof"] > 0 for c in noise)
    assert res["diagnostics"]["absolute"] is False
    assert set(res["diagnostics"]["std_dof"]) == set(res["updated"])
    assert res["model_error"]["verdict"] in ("consistent", "untested")


def test_stated_noise_says_where_it_came_from(figure2, capsys):
    model, plain, stated, tmp = figure2
    code, out, _ = run(["update", str(model), str(stated), "--json", str(tmp / "s.json")], capsys)
    assert code in (0, None)
    assert any("stated in the data file" in line for line in _basis(out))
    res = json.loads((tmp / "s.json").read_text())
    assert res["diagnostics"]["absolute"] is True
    assert {c["source"] for c in res["diagnostics"]["noise"]} == {"stated in the data file"}
    assert res["model_error"]["test"] == "chi-square"
    assert all(v == "inf" for v in res["diagnostics"]["std_dof"].values())
    code, out, _ = run(["update", str(model), str(plain), "--std-eigenvalue", "0.001", "--json",
                        str(tmp / "m.json")], capsys)
    res = json.loads((tmp / "m.json").read_text())
    sources = {c["kind"]: c["source"] for c in res["diagnostics"]["noise"]}
    assert sources["eigenvalue"] == "given as an option"
    assert res["diagnostics"]["absolute"] is False  # the shapes' noise is estimated


def test_a_wrong_model_is_flagged_in_the_headline(figure2, capsys):
    """The stated noise 100 times smaller than the data's: the chi-square test says MODEL ERROR."""
    model, plain, _, tmp = figure2
    code, out, _ = run(["update", str(model), str(plain), "--std-eigenvalue", "1e-6", "--std-shape", "1e-5",
                        "--json", str(tmp / "w.json")], capsys)
    assert "MODEL ERROR" in out
    assert json.loads((tmp / "w.json").read_text())["model_error"]["verdict"] == "model error"
