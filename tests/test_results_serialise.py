"""Results serialise themselves: a Python user writes the same JSON and report as the command line
from a result object, reads the JSON back into the typed result, and gets the same JSON again."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pytest

import femupdate as fu
from femupdate.cli import main
from femupdate.serialise import SCHEMA_VERSION, Serialisable

sys.path.insert(0, str(Path(__file__).resolve().parent))
from results_helpers import cli, plain as _plain, timeless as _timeless, without_stamp as _without_stamp  # noqa: E402


@pytest.fixture(scope="module")
def ex(tmp_path_factory):
    d = tmp_path_factory.mktemp("ex")
    with pytest.raises(SystemExit):
        main(["demo", "--write-files", str(d)])
    return d


@pytest.mark.parametrize("example, args, call", [
    ("figure2", [], dict()),
    ("figure2", ["--parametrisation", "log", "--shape-scaling", "ref", "--min-mac", "0.6"],
     dict(solver=fu.SolverOptions(parametrisation="log"), shape_scaling="ref", min_mac=0.6)),
    ("two_dof", ["--starts", "12", "--seed", "3"], dict(starts=12, seed=3)),
])
def test_python_writes_the_json_the_command_line_writes(ex, tmp_path, capsys, example, args, call):
    model_path = ex / f"{example}.toml"
    data_path = ex / ("figure2_test.json" if example == "figure2" else "two_dof_frequencies.json")
    out = tmp_path / "cli.json"
    code, _, err = cli(["update", str(model_path), str(data_path), *args, "--json", str(out)], capsys)
    assert code == 0, err
    model = fu.load_model(model_path)
    data = fu.load_test_data(data_path, model)
    if "starts" in call:
        result = fu.multistart(model, data, **call)
    else:
        result = fu.update(model, data, **call)
    py = tmp_path / "py.json"
    result.write_json(py)
    written = json.loads(py.read_text())
    assert _timeless(written) == _timeless(json.loads(out.read_text()))
    assert written["kind"] == "update" and written["schema_version"] == SCHEMA_VERSION
    fu.write_json(tmp_path / "again.json", result)  # the module's writer takes result objects too
    assert _timeless(json.loads((tmp_path / "again.json").read_text())) == _timeless(written)


def test_a_result_read_back_writes_the_same_json(ex):
    model = fu.load_model(ex / "figure2.toml")
    data = fu.load_test_data(ex / "figure2_test.json", model)
    res = fu.update(model, data)
    first = _plain(res.to_json())
    back = fu.UpdateResult.from_json(first)
    assert isinstance(back, fu.UpdateResult)
    assert _plain(back.to_json()) == first
    np.testing.assert_array_equal(back.x, res.x)
    np.testing.assert_allclose(back.diagnostics.std, res.diagnostics.std, rtol=1e-15)
    assert back.pairs[0][:2] == res.pairs[0][:2]
    # any result file, by its kind
    again = fu.load_result(first)
    assert _plain(again.to_json()) == first


def test_frf_results_and_multi_start_read_back(ex, tmp_path):
    model = fu.load_model(ex / "two_dof.toml")
    data = fu.load_test_data(ex / "two_dof_frf.json", model)
    res = fu.frf_update(model, data)
    obj = _plain(res.to_json())
    assert obj["kind"] == "frf-update" and "frac" in obj and "formulation" not in obj
    back = fu.load_result(obj)
    assert type(back).__name__ == "FRFUpdateResult" and _plain(back.to_json()) == obj
    via_update = _plain(fu.update(model, data).to_json())  # FRFs through the one verb: kind update
    assert via_update["kind"] == "update" and via_update["formulation"] is None
    ms = fu.multistart(model, fu.load_test_data(ex / "two_dof_frequencies.json", model), starts=8, seed=1)
    obj = _plain(ms.to_json())
    assert obj["starts"]["total"] == 8 and len(obj["starts"]["runs"]) == 8
    assert _plain(fu.load_result(obj).to_json()) == obj  # the study's starts kept as read


def test_python_writes_the_report_the_command_line_writes(ex, tmp_path, capsys):
    model_path, data_path = ex / "figure2.toml", ex / "figure2_test.json"
    code, _, err = cli(["update", str(model_path), str(data_path), "--report", str(tmp_path / "cli.html")], capsys)
    assert code == 0, err
    model = fu.load_model(model_path)
    res = fu.update(model, fu.load_test_data(data_path, model))
    res.write_report(tmp_path / "py.html", source=f"run on {model_path}")
    assert _without_stamp((tmp_path / "py.html").read_text()) == _without_stamp((tmp_path / "cli.html").read_text())
    fu.write_report(tmp_path / "py2.html", res, source=f"run on {model_path}")  # the module's function, the same
    assert _without_stamp((tmp_path / "py2.html").read_text()) == _without_stamp((tmp_path / "py.html").read_text())


def test_tables_as_frames(ex):
    pd = pytest.importorskip("pandas")
    model = fu.load_model(ex / "two_dof.toml")
    data = fu.load_test_data(ex / "two_dof_frequencies.json", model)
    res = fu.update(model, data)
    frame = res.to_frame()
    assert isinstance(frame, pd.DataFrame) and list(frame["parameter"]) == ["k1", "k2"]
    assert frame["value"].tolist() == [res.parameters["k1"], res.parameters["k2"]]
    ms = fu.multistart(model, data, starts=10, seed=0)
    solutions = ms.to_frame()
    assert len(solutions) == len(ms.solutions) and {"k1", "k2", "cost", "count", "fits"} <= set(solutions)


def test_reading_refuses_what_it_cannot_read(tmp_path):
    with pytest.raises(fu.InputError, match="newer femupdate"):
        fu.UpdateResult.from_json({"kind": "update", "schema_version": SCHEMA_VERSION + 1, "parameters": {}})
    with pytest.raises(fu.InputError, match="a 'damage' result"):
        fu.UpdateResult.from_json({"kind": "damage", "located": [], "changes": {}})
    bad = tmp_path / "bad.json"
    bad.write_text("[1, 2]")
    with pytest.raises(fu.InputError, match="JSON object"):
        fu.load_result(bad)
    with pytest.raises(fu.InputError, match="/pairs/0"):
        fu.UpdateResult.from_json({"kind": "update", "parameters": {"k1": 1.0}, "pairs": [["a", 0, 1.0]]})
    assert issubclass(fu.UpdateResult, Serialisable)


def test_a_null_parameter_reads_back_as_nan_and_a_missing_one_is_named():
    """to_json writes NaN as null; reading it back raised "TypeError: float() argument must be a
    string or a real number, not 'NoneType'".  A parameter named in "updated" with no value read
    back as NaN without a word."""
    obj = {"kind": "update", "updated": ["k1", "k2"], "parameters": {"k1": None, "k2": 6.0}}
    back = fu.load_result(obj)
    assert np.isnan(back.parameters["k1"]) and back.parameters["k2"] == 6.0
    assert back.to_json()["parameters"] == {"k1": None, "k2": 6.0}
    with pytest.raises(fu.InputError, match=r"^/parameters: no value of the updated parameter 'k2'"):
        fu.load_result({"kind": "update", "updated": ["k1", "k2"], "parameters": {"k1": 8.0}})


def test_a_schema_version_that_is_no_integer_is_not_called_newer():
    with pytest.raises(fu.InputError, match=r"^/schema_version: expected an integer, got '1'"):
        fu.load_result({"kind": "update", "schema_version": "1", "parameters": {}})
