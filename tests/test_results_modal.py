"""The results of modes, correlate, direct, demo, reduce and fullfield serialise themselves: a
Python user writes the same JSON (and, for direct, the same report) as the command line from the
result object, and a result read back from its JSON writes the same JSON again."""

from __future__ import annotations

import dataclasses
import json
import re
from pathlib import Path

import numpy as np
import pytest

import femupdate as fu
from femupdate.cli import main
from femupdate.serialise import SCHEMA_VERSION

INPUTS = Path(__file__).resolve().parent / "behaviour" / "inputs"


def cli(args, capsys):
    with pytest.raises(SystemExit) as info:
        main(args)
    out, err = capsys.readouterr()
    return info.value.code or 0, out, err


@pytest.fixture(scope="module")
def ex(tmp_path_factory):
    d = tmp_path_factory.mktemp("ex")
    with pytest.raises(SystemExit):
        main(["demo", "--write-files", str(d)])
    return d


def _plain(obj):
    """What a JSON file holds (tuples as lists, NaN as null)."""
    return json.loads(json.dumps(obj))


def _command_json(args, tmp_path, capsys, code=0) -> dict:
    out = tmp_path / "cli.json"
    got, _, err = cli([*map(str, args), "--json", str(out)], capsys)
    assert got == code, err
    return json.loads(out.read_text())


def _round_trip(result, kind: str) -> dict:
    """``result``'s JSON, checked to read back into the same class and to write the same JSON."""
    obj = _plain(result.to_json())
    assert obj["kind"] == kind and obj["schema_version"] == SCHEMA_VERSION
    back = fu.load_result(obj)
    assert type(back) is type(result)
    assert _plain(back.to_json()) == obj
    assert _plain(type(result).from_json(obj).to_json()) == obj
    return obj


def _beam():
    """The full-field example's model and the segments of its structure (as the command takes them)."""
    from femupdate.fullfield import structure_segments
    from femupdate.io.model_file import read_toml

    structure = fu.Structure.from_dict(read_toml(INPUTS / "beam.toml"))
    return structure.build(), structure_segments(structure)


# ---------------------------------------------------------------------------------- the same JSON
@pytest.mark.parametrize("example, args, call", [
    ("figure2", [], dict()),
    ("two_dof", ["--set", "k1=9", "--normalise", "ref:#2"], dict(values={"k1": 9.0}, normalisation="ref:2:x")),
    ("truss", ["--method", "sparse", "--n-modes", "4", "--normalise", "unit"],
     dict(method="sparse", n_modes=4, normalisation="unit")),
])
def test_modes_write_the_json_of_the_command(ex, tmp_path, capsys, example, args, call):
    written = _command_json(["modes", ex / f"{example}.toml", *args], tmp_path, capsys)
    modes = fu.model_modes(fu.load_model(ex / f"{example}.toml"), **call)
    assert _round_trip(modes, "modes") == written
    frame = modes.records()
    assert [r["frequency_hz"] for r in frame] == written["frequencies_hz"]


def test_solved_modes_without_a_model_name_nothing_they_do_not_know():
    modes = fu.solve_modes(np.diag([2.0, 8.0]), np.eye(2))
    obj = _round_trip(modes, "modes")
    assert obj["model"] == "" and obj["parameters"] is None and obj["solver"] == "dense (LAPACK)"
    assert obj["shapes"] == modes.shapes.T.tolist()


def test_modes_read_back_keep_the_solver_that_made_them(ex):
    modes = fu.model_modes(fu.load_model(ex / "truss.toml"), n_modes=3, method="sparse")
    obj = _round_trip(modes, "modes")
    assert obj["solver"].startswith("sparse (ARPACK")  # the factorisation is not read back; its name is
    back = fu.load_result(obj)
    np.testing.assert_array_equal(back.eigenvalues, modes.eigenvalues)
    np.testing.assert_array_equal(back.shapes, modes.shapes)


@pytest.mark.parametrize("args, damping", [([], None), (["--damping", "alpha=0.5,beta=0.0002"], (0.5, 0.0002))])
def test_correlation_writes_the_json_of_the_command(ex, tmp_path, capsys, args, damping):
    from femupdate.frf import Damping

    model = fu.load_model(ex / "figure2.toml")
    data = fu.load_test_data(ex / "figure2_test.json", model)
    written = _command_json(["correlate", ex / "figure2.toml", ex / "figure2_test.json", *args], tmp_path, capsys)
    corr = fu.correlate(data, fu.model_modes(model))
    if damping is not None:
        corr = corr.with_context(damping=Damping(alpha=damping[0], beta=damping[1]))
        assert written["damping_ratio"]["model"][0] is not None
    assert _round_trip(corr, "correlate") == written
    frame = corr.records()
    assert [(r["test"], r["model"]) for r in frame] == [tuple(p[:2]) for p in written["pairs"]]


def test_correlation_of_the_damaged_truss_and_its_frame(ex, tmp_path, capsys):
    pd = pytest.importorskip("pandas")
    model = fu.load_model(ex / "truss.toml")
    data = fu.load_test_data(ex / "truss_damaged.json", model)
    args = ["correlate", ex / "truss.toml", ex / "truss_damaged.json", "--pairing", "mac", "--min-mac", "0.8"]
    written = _command_json(args, tmp_path, capsys)
    corr = fu.correlate(data, fu.model_modes(model), min_mac=0.8, pairing="mac")
    assert _round_trip(corr, "correlate") == written
    frame = corr.to_frame()
    assert isinstance(frame, pd.DataFrame) and len(frame) == len(written["pairs"]) + len(written["unpaired_test"])
    np.testing.assert_allclose(frame["frequency_error"][:len(written["pairs"])], written["frequency_error"], rtol=0)


@pytest.mark.parametrize("args, call", [
    ([], dict()),
    (["--bounded", "--unknowns", "k1,k2,k4", "--set", "k3=1400"],
     dict(bounded=True, unknowns=["k1", "k2", "k4"], values={"k3": 1400.0})),
])
def test_direct_writes_the_json_of_the_command(ex, tmp_path, capsys, args, call):
    model = fu.load_model(ex / "figure2.toml")
    data = fu.load_test_data(ex / "figure2_test.json", model)
    written = _command_json(["direct", ex / "figure2.toml", ex / "figure2_test.json", *args], tmp_path, capsys)
    res = fu.direct_update(model, data, **call)
    assert _round_trip(res, "direct") == written
    assert written["start"]["k3"] == call.get("values", {}).get("k3", 1200.0)
    rows = res.records()
    assert [r["start"] for r in rows] == [written["start"][r["parameter"]] for r in rows]
    assert [r["std"] for r in rows if r["parameter"] in res.unknowns] == list(written["standard_error"].values())


def test_direct_from_frfs_has_no_pairs(ex, tmp_path, capsys):
    model = fu.load_model(ex / "two_dof.toml")
    data = fu.load_test_data(ex / "two_dof_frf.json", model)
    written = _command_json(["direct", ex / "two_dof.toml", ex / "two_dof_frf.json"], tmp_path, capsys)
    res = fu.direct_update(model, data)
    assert "pairs" not in written and res.identified.correlation is None
    assert _round_trip(res, "direct") == written


def _without_stamp(html: str) -> str:
    return re.sub(r"\d{4}-\d\d-\d\d \d\d:\d\d UTC", "<stamp>", html)


def test_direct_writes_the_report_of_the_command(ex, tmp_path, capsys):
    model_path, data_path = ex / "figure2.toml", ex / "figure2_test.json"
    code, _, err = cli(["direct", str(model_path), str(data_path), "--report", str(tmp_path / "cli.html")], capsys)
    assert code == 0, err
    model = fu.load_model(model_path)
    res = fu.direct_update(model, fu.load_test_data(data_path, model))
    res.write_report(tmp_path / "py.html", source=f"run on {model_path}")
    cli_html = (tmp_path / "cli.html").read_text()
    assert _without_stamp((tmp_path / "py.html").read_text()) == _without_stamp(cli_html)
    assert "updated model vs test" in cli_html or "MAC" in cli_html  # a report with the correlation, not a stub


def test_demo_writes_the_json_of_the_command(tmp_path, capsys):
    from femupdate.examples import FIGURE2_TRUE, demo

    written = _command_json(["demo"], tmp_path, capsys)
    res = demo()
    assert _round_trip(res, "demo") == written
    assert written["true"] == FIGURE2_TRUE and "start" not in written
    assert res.run_context.model.name == written["model"]
    html = res.write_report(tmp_path / "demo.html")  # a demo is a direct solution: its report is direct's
    assert "direct" in html.read_text()


@pytest.mark.parametrize("args, call", [
    ([], dict()),
    (["--method", "serep", "--n-modes", "4", "--no-compare"], dict(method="serep", n_modes=4, compare=False)),
])
def test_reduction_writes_the_json_of_the_command(ex, tmp_path, capsys, args, call):
    from femupdate.reduction import ReductionResult, reduce_model

    keep = ["4:x", "4:y", "104:x", "104:y", "3:y", "103:y"]
    written = _command_json(["reduce", ex / "truss.toml", "--keep", ",".join(keep), *args], tmp_path, capsys)
    res = reduce_model(fu.load_model(ex / "truss.toml"), keep, **call)
    assert isinstance(res, ReductionResult)
    assert _round_trip(res, "reduce") == written
    assert set(written["frequency_error"]) == ({call["method"]} if "method" in call else
                                               {"guyan", "irs", "modal", "hybrid", "serep"})
    if "method" not in call:  # Guyan's reduced matrices reproduce the reduced frequencies (a second route)
        import scipy.linalg as sla

        lam = sla.eigh(res.K, res.M, eigvals_only=True)
        np.testing.assert_allclose(np.sqrt(lam) / (2 * np.pi), written["frequencies_hz"]["reduced"], rtol=1e-9)
    rows = res.records()
    assert [r["error"] for r in rows] == [*res.error, *[None] * (len(rows) - res.error.size)]
    assert [r["reduced_hz"] for r in rows][:len(written["frequencies_hz"]["reduced"])] == \
        written["frequencies_hz"]["reduced"]


@pytest.mark.parametrize("args, call", [
    ([], dict(method="rbf")),  # the command's default mapping (map_scan's is "elements")
    (["--method", "elements", "--form", "pointwise"], dict(method="elements", form="pointwise")),
])
def test_fullfield_writes_the_json_of_the_command(tmp_path, capsys, args, call):
    from femupdate.fullfield import FullFieldResult, full_field_direct
    from femupdate.fullfield.files import load_scan

    written = _command_json(["fullfield", INPUTS / "beam.toml", INPUTS / "beam_scan.json", *args], tmp_path, capsys)
    model, segments = _beam()
    result = full_field_direct(model, load_scan(INPUTS / "beam_scan.json"), segments=segments, **call)
    assert isinstance(result, FullFieldResult)
    assert _round_trip(result, "fullfield") == written
    res, mapping = result  # unpacks as before
    assert res is result.direct and mapping is result.mapping
    assert [r["value"] for r in result.records()] == list(written["parameters"].values())


# ---------------------------------------------------------------------------------- refusals and failures
def test_results_without_a_report_say_so(ex, tmp_path):
    modes = fu.model_modes(fu.load_model(ex / "two_dof.toml"))
    with pytest.raises(fu.InputError, match="results of kind 'modes' have no report"):
        modes.write_report(tmp_path / "m.html")
    with pytest.raises(fu.InputError, match="a 'modes' result, not 'correlate'"):
        fu.Correlation.from_json(_plain(modes.to_json()))
    bad = dict(_plain(modes.to_json()), n_rigid="none")
    with pytest.raises(fu.InputError, match="/n_rigid: expected integer"):
        fu.load_result(bad)


def test_an_identified_model_without_modes_is_a_note(ex):
    """Identified values that make K indefinite: no correlation, a note saying why (the value is
    flagged), and the JSON without pairs."""
    model = fu.load_model(ex / "figure2.toml")
    res = fu.direct_update(model, fu.load_test_data(ex / "figure2_test.json", model))
    bad = dataclasses.replace(res, parameters={**res.parameters, "k2": -3000.0})
    assert bad.identified.correlation is None
    assert bad.identified.note.startswith("no correlation of the identified model with the test:")
    obj = _plain(bad.to_json())
    assert "pairs" not in obj and obj["notes"][-1] == bad.identified.note
    assert [f["parameter"] for f in obj["flags"]] == ["k2"]
    assert res.identified.correlation is not None  # the real result correlates
