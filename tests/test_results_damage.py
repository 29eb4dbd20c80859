"""Damage, update-multi, rank-modifications and paper results serialise themselves: a Python user
writes the JSON and report the command line writes from the result object, and a result read
back gives the same JSON again (femupdate.serialise)."""

from __future__ import annotations

import json
import re

import pytest

import femupdate as fu
from femupdate.cli import main
from femupdate.io.model_file import read_toml


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
    return json.loads(json.dumps(obj))


def _without_stamp(html: str) -> str:
    return re.sub(r"\d{4}-\d\d-\d\d \d\d:\d\d UTC", "<stamp>", html)


def _truss(ex):
    from femupdate.damage import damage_unknowns

    path = ex / "truss.toml"
    structure = fu.Structure.from_dict(read_toml(path), source=str(path))
    du = damage_unknowns(structure)
    return structure, du


def test_damage_python_writes_the_json_and_report_of_the_command_line(ex, tmp_path, capsys):
    from femupdate.damage import detect_damage
    from femupdate.fullfield import structure_segments

    code, _, err = cli(["damage", str(ex / "truss.toml"), str(ex / "truss_damaged.json"), "--undamaged",
                        str(ex / "truss_undamaged.json"), "--bootstrap", "4", "--json", str(tmp_path / "cli.json"),
                        "--report", str(tmp_path / "cli.html")], capsys)
    assert code == 0, err
    structure, du = _truss(ex)
    data = fu.load_test_data(ex / "truss_damaged.json", du.model)
    undamaged = fu.load_test_data(ex / "truss_undamaged.json", du.model)
    seen = []
    res = detect_damage(du, data, undamaged=undamaged, bootstrap=4, progress=lambda *a: seen.append(a))
    written = json.loads((tmp_path / "cli.json").read_text())
    assert _plain(res.to_json()) == written
    assert written["kind"] == "damage" and written["unknowns"] == "elements" and du.notes[0] in written["notes"]
    # the bootstrap's progress, replicate by replicate, after the refinement; then the healthy baseline's replicates
    assert seen[:2] == [("refine", 0, 1), ("refine", 1, 1)] and seen[2:6] == [("bootstrap", k, 4) for k in range(1, 5)]
    assert seen[6:] == [("healthy", k, 4) for k in range(1, 5)]
    res.write_report(tmp_path / "py.html", segments=structure_segments(structure))
    assert _without_stamp((tmp_path / "py.html").read_text()) == _without_stamp((tmp_path / "cli.html").read_text())
    back = fu.load_result(written)
    assert type(back).__name__ == "DamageResult" and _plain(back.to_json()) == written
    assert back.located == res.located and back.changes == pytest.approx(res.changes, rel=1e-15)


def test_damage_without_undamaged_data_says_so_in_python_too(ex):
    from femupdate.damage import detect_damage

    _, du = _truss(ex)
    res = detect_damage(du, fu.load_test_data(ex / "truss_damaged.json", du.model), bootstrap=0)
    notes = res.to_json()["notes"]
    assert "no --undamaged data: the baseline was not checked against the undamaged structure" in notes
    assert notes.index(du.notes[0]) < len(notes) - len(res.notes)  # the run's notes before the result's own
    frame = pytest.importorskip("pandas") and res.to_frame()
    assert list(frame["unknown"]) == list(res.changes) and frame["located"].sum() == len(res.located)


def test_update_multi_and_rank_modifications_write_the_json_of_the_command_line(ex, tmp_path, capsys):
    from femupdate.updating.multiconfig import Configuration, configure, rank_modifications, solve_configurations
    from femupdate.updating.multiconfig.files import load_candidates, load_modification

    model_path = ex / "two_dof.toml"
    code, _, err = cli(["update-multi", str(model_path), "--config", str(ex / "two_dof_frequencies.json"), "--config",
                        f"{ex / 'two_dof_plus_2kg.json'}:{ex / 'plus_2kg.toml'}", "--max-nfev", "150",
                        "--json", str(tmp_path / "multi.json"), "--report", str(tmp_path / "multi.html")], capsys)
    assert code == 0, err
    model = fu.load_model(model_path)
    mod = load_modification(ex / "plus_2kg.toml")
    cfgs = [Configuration(fu.load_test_data(ex / "two_dof_frequencies.json", model), name="two_dof_frequencies"),
            Configuration(fu.load_test_data(ex / "two_dof_plus_2kg.json", configure(model, mod).model), mod)]
    res = solve_configurations(model, cfgs, max_nfev=150)
    written = json.loads((tmp_path / "multi.json").read_text())
    assert _plain(res.to_json()) == written and written["kind"] == "update-multi"
    res.write_report(tmp_path / "py.html", source=f"run on {model_path}")
    assert _without_stamp((tmp_path / "py.html").read_text()) == _without_stamp((tmp_path / "multi.html").read_text())
    back = fu.load_result(written)
    assert _plain(back.to_json()) == written and back.names == res.names

    code, _, err = cli(["rank-modifications", str(model_path), str(ex / "candidates.toml"), "--measured-dofs", "1:x,2:x",
                        "--modes", "1", "--criterion", "logdet", "--select", "2", "--json", str(tmp_path / "r.json")],
                       capsys)
    assert code == 0, err
    ranking = rank_modifications(model, load_candidates(ex / "candidates.toml"), ["1:x", "2:x"], 1, criterion="logdet",
                                 select=2)
    written = json.loads((tmp_path / "r.json").read_text())
    assert _plain(ranking.to_json()) == written and written["kind"] == "rank-modifications"
    assert _plain(fu.load_result(written).to_json()) == written
    assert [r["name"] for r in ranking.records()] == [c["name"] for c in written["candidates"]]


def test_paper_result_writes_paper_json_and_its_report(tmp_path, capsys):
    from femupdate.paper import run_sections

    cli_dir, py_dir = tmp_path / "cli", tmp_path / "py"
    code, _, err = cli(["paper", "--out", str(cli_dir), "--section", "two_dof_characteristic", "--jobs", "1",
                        "--json", str(tmp_path / "p.json"), "--report", str(tmp_path / "cli.html")], capsys)
    assert code == 0, err
    res = run_sections(py_dir, ["two_dof_characteristic"], jobs=1)
    on_disk = json.loads((py_dir / "paper.json").read_text())
    assert on_disk == _plain(res.to_json()) == json.loads((tmp_path / "p.json").read_text())
    assert on_disk["kind"] == "paper" and res["sections"] == res.sections  # the dict's keys, as before
    res.write_report(tmp_path / "py.html", source=str(cli_dir))
    py_html = _without_stamp((tmp_path / "py.html").read_text())
    assert py_html == _without_stamp((tmp_path / "cli.html").read_text())
    assert "data:image/png;base64," in py_html  # the section's figure, from the folder
    back = fu.load_result(py_dir / "paper.json")
    assert type(back).__name__ == "PaperResult" and _plain(back.to_json()) == on_disk and back.folder is None


def test_damage_command_shows_the_bootstrap_progress_when_piped(ex, capsys, monkeypatch):
    import importlib

    command = importlib.import_module("femupdate.cli.damage")  # the module (the package's name is the command)
    shown = command.phased_progress
    monkeypatch.setattr(command, "phased_progress", lambda labels, **kw: shown(labels, after=0.0, every=0.0, **kw))
    code, out, err = cli(["damage", str(ex / "truss.toml"), str(ex / "truss_damaged.json"), "--bootstrap", "3"], capsys)
    assert code == 0, err
    lines = [line for line in err.splitlines() if line.startswith("femupdate: ")]
    assert lines[0].startswith("femupdate: refining and verifying 0/1")
    assert [line.split()[3] for line in lines if "bootstrap" in line] == ["1/3", "2/3", "3/3"]
    code, out, err = cli(["damage", str(ex / "truss.toml"), str(ex / "truss_damaged.json"), "--bootstrap", "3",
                          "--json", "-"], capsys)
    assert code == 0 and "femupdate: " not in err and json.loads(out)["kind"] == "damage"  # quiet with --json -
