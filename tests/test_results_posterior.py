"""The posterior result serialises itself and has a report: ``femupdate posterior --report`` and
``result.write_report(path)`` write the same page, whose numbers are the JSON's; the JSON written
from Python is the command line's, and a result read back gives the same JSON again."""

from __future__ import annotations

import json
import math
import re

import numpy as np
import pytest

import femupdate as fu
from femupdate.cli import main
from femupdate.examples import two_dof, two_dof_model_toml

from test_report import check_numbers


def cli(args, capsys):
    with pytest.raises(SystemExit) as info:
        main(args)
    out, err = capsys.readouterr()
    return info.value.code or 0, out, err


@pytest.fixture
def files(tmp_path):
    """The demo's two-dof model (k1 in [3, 13], k2 in [1, 11]) and its two frequencies, stated to 1 %."""
    model = tmp_path / "two.toml"
    model.write_text(two_dof_model_toml())
    lam = fu.model_modes(two_dof()).eigenvalues
    data = tmp_path / "freq.json"
    data.write_text(json.dumps({"modes": [{"eigenvalue": float(v), "std_eigenvalue": 0.01, "label": f"m{k}"}
                                          for k, v in enumerate(lam)]}))
    return model, data


def _timeless(obj):
    """``obj`` without wall-clock times (they differ from run to run)."""
    if isinstance(obj, dict):
        return {k: _timeless(v) for k, v in obj.items() if not k.endswith("seconds")}
    if isinstance(obj, list):
        return [_timeless(v) for v in obj]
    return obj


def _without_stamp(html: str) -> str:
    return re.sub(r"\d{4}-\d\d-\d\d \d\d:\d\d UTC", "<stamp>", html)


@pytest.mark.parametrize("method, args, call", [
    ("laplace", [], {}),
    ("tmcmc", ["--samples", "300", "--starts", "4", "--tmcmc-steps", "2"], dict(samples=300, starts=4, tmcmc_steps=2)),
])
def test_python_writes_the_json_and_report_of_the_command_line(files, tmp_path, capsys, method, args, call):
    model_path, data_path = files
    code, out, err = cli(["posterior", str(model_path), str(data_path), "--method", method, *args,
                          "--json", str(tmp_path / "cli.json"), "--report", str(tmp_path / "cli.html")], capsys)
    assert code == 0, err
    assert f"wrote the report {tmp_path / 'cli.html'}" in out
    model = fu.load_model(model_path)
    res = fu.posterior(model, fu.load_test_data(data_path, model), method=method, seed=0, **call)
    written = json.loads((tmp_path / "cli.json").read_text())
    assert _timeless(json.loads(json.dumps(res.to_json()))) == _timeless(written)
    assert written["kind"] == "posterior" and written["data_sets"] == 1
    res.write_report(tmp_path / "py.html", source=f"run on {model_path}")
    html = _without_stamp((tmp_path / "py.html").read_text())
    assert html == _without_stamp((tmp_path / "cli.html").read_text())
    # the page: every number tied to the JSON is the JSON's; the corner figure from the samples
    assert check_numbers(html, written) > 20
    assert "data:image/png;base64," in html and 'id="solutions"' in html and 'id="predictive"' in html
    if method == "tmcmc":
        assert "TMCMC&#39;s stages" in html or "TMCMC's stages" in html
    back = fu.load_result(written)
    assert type(back).__name__ == "PosteriorResult" and json.loads(json.dumps(back.to_json())) == written
    assert back.samples.shape == (0, 2) and back.modes[0].probability == pytest.approx(res.modes[0].probability)


def test_the_report_names_what_it_shows_and_what_it_cannot(files, tmp_path, capsys):
    model_path, data_path = files
    code, _, err = cli(["posterior", str(model_path), str(data_path), "--method", "mcmc", "--walkers", "8",
                        "--steps", "120", "--ensembles", "2", "--json", str(tmp_path / "r.json"), "--report",
                        str(tmp_path / "r.html")], capsys)
    assert code in (0, 1), err  # 1: the short chains fail their checks, and the report says so
    result = json.loads((tmp_path / "r.json").read_text())
    html = (tmp_path / "r.html").read_text()
    assert check_numbers(html, result) > 10
    assert "R-hat" in html and html.count("data:image/png;base64,") == 2  # corner and traces
    for w in result["warnings"]:
        assert w.replace("'", "&#39;") in html or w in html
    if not result["success"]:
        assert "DOUBTFUL" in html
    # from the JSON alone (femupdate report): the tables, no figure of the samples, said so
    code, out, err = cli(["report", str(tmp_path / "r.json"), "-o", str(tmp_path / "j.html")], capsys)
    assert code == 0, err
    assert "predictive figure" in out
    alone = (tmp_path / "j.html").read_text()
    assert check_numbers(alone, result) == check_numbers(html, result)
    assert "data:image/png;base64," not in alone and "The corner figure needs the samples" in alone


def test_a_posterior_result_file_is_told_from_its_keys(files, tmp_path, capsys):
    from femupdate.report import detect_kind

    model_path, data_path = files
    code, out, err = cli(["posterior", str(model_path), str(data_path), "--json", "-"], capsys)
    assert code == 0, err
    result = json.loads(out)
    assert detect_kind(result) == "posterior"
    del result["kind"], result["schema_version"]  # a file written before results named their kind
    assert detect_kind(result) == "posterior"
    with pytest.raises(fu.InputError, match="/noise: expected object"):
        fu.load_result({**result, "kind": "posterior", "noise": [1]})


def test_records_and_frame(files):
    model_path, data_path = files
    model = fu.load_model(model_path)
    res = fu.posterior(model, fu.load_test_data(data_path, model), seed=1)
    rows = res.records()
    assert [r["parameter"] for r in rows] == ["k1", "k2"]
    for r in rows:
        assert r["lower"] <= r["median"] <= r["upper"] and r["std"] == res.std[r["parameter"]]
        assert r["prior"].startswith("uniform") and math.isfinite(r["mean"])
    pd = pytest.importorskip("pandas")
    frame = res.to_frame()
    assert isinstance(frame, pd.DataFrame) and np.allclose(frame["median"], [res.median["k1"], res.median["k2"]])
