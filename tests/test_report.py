"""The HTML report (issue 18): every kind of result gives one self-contained page whose numbers
are the result file's; with the model and the data the report recomputes the correlation before
and after, and that recomputation agrees with an independent eigen-solution."""

from __future__ import annotations

import json
import re
from html.parser import HTMLParser
from pathlib import Path

import numpy as np
import pytest
import scipy.linalg

import femupdate as fu
from femupdate.cli import main
from femupdate.report import build_report, detect_kind, write_report

RECORDED = Path(__file__).parent / "behaviour" / "recorded"
#: a recorded result of every kind of report (the JSON the commands wrote, tests/behaviour)
KIND_FILES = {"direct": "direct_figure2.json", "update": "update_two_dof_starts.json",
              "frf-update": "frf_update_two_dof.json", "update-multi": "update_multi_two_dof.json",
              "damage": "damage_truss.json", "uniqueness": "uniqueness_two_dof.json", "paper": "paper.json"}


class _Cells(HTMLParser):
    """Every element carrying data-key, its value and its text; the tags seen; loads named."""

    def __init__(self):
        super().__init__()
        self.cells: list[dict] = []
        self.tags: dict[str, int] = {}
        self.loads: list[str] = []
        self._open: list[dict] = []

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        self.tags[tag] = self.tags.get(tag, 0) + 1
        for k in ("src", "href"):
            if a.get(k) and not a[k].startswith(("data:", "#")):
                self.loads.append(a[k])
        if "data-key" in a:
            self._open.append({"key": a["data-key"], "value": a.get("data-value"), "text": "", "tag": tag})

    def handle_data(self, data):
        for c in self._open:
            c["text"] += data

    def handle_endtag(self, tag):
        if self._open and self._open[-1]["tag"] == tag:
            self.cells.append(self._open.pop())


def lookup(obj, key: str):
    """The value at a JSON pointer ("/parameters/k1", "/pairs/0/2")."""
    assert key.startswith("/"), key
    for part in key[1:].split("/"):
        obj = obj[int(part)] if isinstance(obj, list) else obj[part]
    return obj


def verdict_text(result: dict, key: str) -> str:
    """What the check column of a paper section must show, from the section's own keys: agrees,
    differs (explained) when it explains a difference, DIFFERS when it does not, – without a
    printed value."""
    section = lookup(result, key.rsplit("/", 1)[0])
    want = section.get("agrees_with_paper")
    if want is None or section.get("comparison") == "not-comparable":
        return "–" if want is None and section.get("comparison") != "not-comparable" else "not comparable"
    if want:
        return "agrees"
    return "differs (explained)" if section.get("explanation") or section.get("comparison") == "differ-explained" \
        else "DIFFERS"


def check_numbers(html: str, result: dict) -> int:
    """Every number tied to the JSON shows the JSON's value, at full precision in data-value and
    to its shown digits in the text; returns how many were checked."""
    p = _Cells()
    p.feed(html)
    assert p.loads == [], f"the page loads {p.loads[:3]}"
    checked = 0
    for c in p.cells:
        want = lookup(result, c["key"])
        if isinstance(want, bool):  # a verdict (the paper's sections)
            assert c["text"].strip() == verdict_text(result, c["key"]), c["key"]
            checked += 1
            continue
        if not isinstance(want, (int, float)):
            continue
        assert float(c["value"]) == pytest.approx(want, rel=1e-15, abs=0), c["key"]
        assert_shown(c["text"], want, c["key"])
        checked += 1
    return checked


def assert_shown(text: str, want: float, key: str) -> None:
    """``text`` is ``want`` rounded to the significant digits it shows."""
    text = text.strip().replace("−", "-")
    digits = len(re.sub(r"e.*$", "", text).replace("-", "").replace(".", "").lstrip("0")) or 1
    assert float(text) == pytest.approx(want, rel=10 ** (1 - digits), abs=1e-300), (key, text, want)


@pytest.fixture(scope="module")
def reports():
    """The report of each recorded result, from the JSON alone."""
    out = {}
    for kind, name in KIND_FILES.items():
        result = json.loads((RECORDED / name).read_text())
        out[kind] = (result, build_report(result, source=name))
    return out


@pytest.mark.parametrize("kind", list(KIND_FILES))
def test_each_kind_is_told_from_its_keys_and_reported(kind, reports):
    result, html = reports[kind]
    assert detect_kind(result) == kind
    assert html.startswith("<!DOCTYPE html>") and html.rstrip().endswith("</html>")
    assert check_numbers(html, result) > 0
    assert 'id="notes"' in html
    assert "<svg" in html or "data:image/png;base64," in html or kind == "paper"


def test_update_report_holds_what_a_test_engineer_hands_over(reports):
    result, html = reports["update"]
    for title in ("Model and data", "Parameters", "Correlation with the test", "Convergence", "Identifiability",
                  "Multi-start: distinct solutions", "Notes and warnings"):
        assert f">{title}</h2>" in html, title
    assert "k1 [N/m]" in html and "lower bound" in html  # units on the columns, bounds in the table
    for i, sol in enumerate(result["starts"]["solutions"]):  # both exact solutions of the Figure 3 system
        assert f'data-key="/starts/solutions/{i}/parameters/k1"' in html


def test_damage_and_uniqueness_reports_name_their_findings(reports):
    result, html = reports["damage"]
    assert result["located"] and all(f'data-key="/parameters/{n}"' in html for n in result["located"])
    assert "confirmed" in html and "Pa" in html
    result, html = reports["uniqueness"]
    assert html.count('class=" ok">unique</td>') + html.count("ok\">unique") >= 1
    assert "Counting criteria" in html


def test_paper_report_puts_the_printed_values_beside_the_computed_ones(reports):
    result, html = reports["paper"]
    for name, sec in result["sections"].items():
        assert f'id="s-{name}"' in html
    # eq. 22: the paper prints S and its condition number; the report shows both beside femupdate's
    sec = result["sections"]["eq22_sensitivity"]
    assert "the paper prints" in html and "16.3" in html and "16.3324" in html
    assert sec["agrees_with_paper"] is True


def test_unknown_results_are_refused_by_name(tmp_path):
    with pytest.raises(fu.InputError, match="not the JSON result of"):
        detect_kind({"eigenvalues": [1.0], "shapes": []})
    bad = tmp_path / "bad.json"
    bad.write_text("{not json")
    with pytest.raises(fu.InputError, match="not valid JSON"):
        build_report(bad)
    with pytest.raises(fu.InputError, match="unknown report kind"):
        build_report({"starts": {}, "success": True}, kind="modes")


def _eigen_hz(model, values):
    """Natural frequencies by SciPy's dense generalised eigen-solver (an independent route)."""
    lam = scipy.linalg.eigh(model.K(values).toarray(), model.M(values).toarray(), eigvals_only=True)
    return np.sqrt(np.abs(lam)) / (2 * np.pi)


def test_recomputed_correlation_before_and_after_matches_an_independent_solution(ex):
    from femupdate.report.recompute import recompute

    model = fu.load_model(ex / "figure2.toml")
    data = fu.load_test_data(ex / "figure2_test.json", model)
    res = fu.direct_update(model, data)
    before = {p.name: p.value for p in model.parameters}
    rec = recompute(model, data, before, dict(res.parameters), {})
    for st, values in ((rec.before, before), (rec.after, res.parameters)):
        want = _eigen_hz(model, values)
        got = [st.correlation.model_frequencies_hz[j] for _, j, _ in st.correlation.pairs]
        np.testing.assert_allclose(got, want[:len(got)], rtol=1e-10)
        # MAC of the test shapes with the model shapes, computed by hand on the measured dofs
        for i, j, mac in st.correlation.pairs:
            tm = data.modes[i]
            phi = st.modes.shapes[[model.dofs.index(d) for d in tm.dofs], j]
            t = np.asarray(tm.shape, float)
            assert mac == pytest.approx((phi @ t) ** 2 / ((phi @ phi) * (t @ t)), rel=1e-12)


def test_commands_write_their_report_and_it_is_self_contained(ex, tmp_path, capsys):
    out = tmp_path / "u.html"
    js = tmp_path / "u.json"
    with pytest.raises(SystemExit) as e:
        main(["update", str(ex / "figure2.toml"), str(ex / "figure2_test.json"), "--json", str(js), "--report", str(out)])
    assert e.value.code == 0
    assert f"wrote the report {out}" in capsys.readouterr().out
    html = out.read_text()
    result = json.loads(js.read_text())
    assert check_numbers(html, result) >= 8
    assert "before: the model as given" in html and "MAC of every test mode" in html
    assert ">Mode shapes on the model</h2>" in html
    # the same report from the files
    out2 = tmp_path / "u2.html"
    with pytest.raises(SystemExit) as e:
        main(["report", str(js), "--model", str(ex / "figure2.toml"), "--data", str(ex / "figure2_test.json"), "-o", str(out2)])
    assert e.value.code == 0
    assert check_numbers(out2.read_text(), result) >= 8


@pytest.mark.parametrize("args, message", [
    (["--data", "D"], "--data needs --model"),
    (["--kind", "paper", "--model", "M"], "a paper result needs no model"),
])
def test_report_command_refuses_bad_combinations(ex, tmp_path, capsys, args, message):
    js = RECORDED / ("paper.json" if "paper" in args else "update_figure2.json")
    args = [a.replace("D", str(ex / "figure2_test.json")).replace("M", str(ex / "figure2.toml")) if len(a) == 1 else a
            for a in args]
    with pytest.raises(SystemExit) as e:
        main(["report", str(js), "-o", str(tmp_path / "r.html"), *args])
    assert e.value.code == 2
    assert message in capsys.readouterr().err
    assert not (tmp_path / "r.html").exists()


def test_report_path_is_checked_before_the_run(ex, tmp_path, capsys):
    with pytest.raises(SystemExit) as e:
        main(["direct", str(ex / "figure2.toml"), str(ex / "figure2_test.json"), "--report", str(tmp_path / "r.txt")])
    assert e.value.code == 2
    assert "must end in one of .html, .htm" in capsys.readouterr().err


def test_write_report_is_atomic_and_returns_the_path(tmp_path):
    result = json.loads((RECORDED / "direct_figure2.json").read_text())
    p = write_report(tmp_path / "d.html", result)
    assert p == tmp_path / "d.html" and p.read_text().startswith("<!DOCTYPE html>")
    assert [f.name for f in tmp_path.iterdir()] == ["d.html"]


def test_write_report_never_writes_over_the_result_it_reads(tmp_path):
    """write_report("u.json", "u.json") replaced the result file with its report (exit 0 of a
    script, the result lost), by its name or any other name of the same file."""
    src = tmp_path / "u.json"
    text = (RECORDED / "update_figure2.json").read_text()
    src.write_text(text)
    (tmp_path / "link.json").symlink_to(src)
    for out in (src, str(src), tmp_path / "link.json", tmp_path / "." / "u.json"):
        with pytest.raises(fu.InputError, match=r"is the result file .* it reads: writing there would destroy it"):
            write_report(out, src)
        assert src.read_text() == text
    with pytest.raises(fu.InputError, match="the arguments look swapped"):
        write_report(src, tmp_path / "u.html")    # the report's name where the result goes
    assert src.read_text() == text


def test_a_model_or_data_of_the_wrong_type_is_named(ex, tmp_path):
    """A file name or a Model given as data ended in AttributeError ('str' object has no
    attribute 'parameter_names', 'Model' object has no attribute 'modes')."""
    result = json.loads((RECORDED / "update_figure2.json").read_text())
    model = fu.load_model(ex / "figure2.toml")
    with pytest.raises(TypeError, match=r"^write_report: model must be a Model, got the str .*load_model"):
        write_report(tmp_path / "r.html", result, model=str(ex / "figure2.toml"))
    with pytest.raises(TypeError, match=r"^build_report: data must be a TestData or FRFData or None, got a Model"):
        build_report(result, model=model, data=model)
    assert not (tmp_path / "r.html").exists()


def test_every_warning_of_the_run_is_in_the_report():
    result = json.loads((RECORDED / "update_figure2.json").read_text())
    result["success"], result["message"] = False, "The maximum number of function evaluations is exceeded."
    result["pairing"] = {**result["pairing"], "low_mac": [1]}
    result["flags"] = [{"parameter": "k4", "value": 0.0, "kind": "on_bound", "bounds": [0.0, 1e5],
                        "message": "k4 = 0 is on its lower bound 0"}]
    html = build_report(result)
    notes = html[html.index('id="notes"'):]
    for text in ("the update did not converge: The maximum number of function evaluations is exceeded.",
                 "test mode 2 is paired by", "k4 = 0 is on its lower bound 0"):
        assert text in notes, text
    assert "NOT converged" in html and 'class="fact verdict bad"' in html
    assert '<td class=" flag">on a bound</td>' in html  # the flagged parameter's row says so


# ---------------------------------------------------------------------------------- hostile input
def _report(args, capsys):
    with pytest.raises(SystemExit) as e:
        main(["report", *map(str, args)])
    err = capsys.readouterr().err
    assert "Traceback" not in err
    return e.value.code, err


def test_report_refuses_a_model_with_parameters_the_result_does_not_have(ex, tmp_path, capsys):
    """A two-dof update reported with --model figure2.toml (k1..k4, of which the result has k1
    and k2) exited 0 with a report of "degrees of freedom 3, parameters 4" and the three-dof
    model's shapes at k1 = 8, k2 = 6: another model's report."""
    result = tmp_path / "u.json"
    code, _ = _report_cli(["update", ex / "two_dof.toml", ex / "two_dof_frequencies.json", "--json", result], capsys)
    assert code == 0
    out = tmp_path / "r.html"
    code, err = _report([result, "-o", out, "--model", ex / "figure2.toml"], capsys)
    assert code == 2 and "the model 'three-dof chain with k4 (paper Figure 2)' has parameter(s) k3, k4 the result " \
                          "does not have" in err, err
    assert not out.exists()
    code, err = _report([result, "-o", out, "--model", ex / "two_dof.toml"], capsys)
    assert code == 0, err


def _report_cli(args, capsys):
    with pytest.raises(SystemExit) as e:
        main(list(map(str, args)))
    capsys.readouterr()
    return e.value.code, None


def test_report_with_the_model_alone_draws_its_shapes(ex, tmp_path, capsys):
    """--model without --data (the documented form [--model MODEL [--data DATA]]) ended in an
    AttributeError: the shape titles read the test frequencies from the missing data."""
    out = tmp_path / "r.html"
    code, err = _report([RECORDED / "update_figure2.json", "-o", out, "--model", ex / "figure2.toml"], capsys)
    assert code == 0, err
    html = out.read_text()
    assert ">Mode shapes on the model</h2>" in html and "test mode 1 ↔ model mode 1: " in html


def test_report_refuses_a_model_or_data_of_another_run(ex, tmp_path, capsys):
    """Another model (AttributeError before) or test data with fewer modes than the result pairs
    (IndexError before) are refused naming the option and the file."""
    out = tmp_path / "r.html"
    result = RECORDED / "update_figure2.json"
    code, err = _report([result, "-o", out, "--model", ex / "two_dof.toml"], capsys)
    assert code == 2 and f"--model {ex / 'two_dof.toml'}: the model 'two-dof chain (paper Figure 3)' has no " \
                          "parameter(s) k3, k4 of the result" in err
    one = tmp_path / "one.json"
    test = json.loads((ex / "figure2_test.json").read_text())
    one.write_text(json.dumps({"modes": test["modes"][:1]}))
    code, err = _report([result, "-o", out, "--model", ex / "figure2.toml", "--data", one], capsys)
    assert code == 2 and f"--data {one}: the result pairs test mode 3, but the test data hold 1 mode(s)" in err
    assert not out.exists()


def test_report_refuses_a_kind_the_keys_contradict(tmp_path, capsys):
    """--kind damage on an update result wrote an empty damage report with exit 0."""
    out = tmp_path / "r.html"
    result = RECORDED / "update_figure2.json"
    code, err = _report([result, "-o", out, "--kind", "damage"], capsys)
    assert code == 2 and "the result of update, not of damage (told from its keys)" in err
    code, err = _report([result, "-o", out, "--kind", "frf-update"], capsys)  # reported alike
    assert code == 0 and out.exists()


@pytest.mark.parametrize("edit, message", [
    (lambda r: r.update(kind="damage"), "/kind: 'damage', but the keys are those of the result of update"),
    (lambda r: r.update(schema_version=99), "schema_version 99: this femupdate reads results of schema 1 and older"),
])
def test_a_result_file_whose_kind_or_schema_cannot_be_reported_is_refused(tmp_path, capsys, edit, message):
    """An update result whose "kind" says damage gave an empty damage report ("located none"),
    and a result of a newer schema was reported as if it were this one's, both with exit 0
    (load_result refused the second)."""
    result = json.loads((RECORDED / "update_figure2.json").read_text())
    edit(result)
    path = tmp_path / "u.json"
    path.write_text(json.dumps(result))
    out = tmp_path / "r.html"
    code, err = _report([path, "-o", out], capsys)
    assert code == 2 and message in err, err
    assert f"error: {path}: " in err and not out.exists()
    with pytest.raises(fu.InputError, match=re.escape(message)):
        write_report(out, result)


@pytest.mark.parametrize("edit, message", [
    (lambda r: r.update(parameters="k1=3"), "/parameters: expected an object or a list, got a text"),
    (lambda r: r["parameters"].update(k2="2000"), "/parameters/k2: expected a number, got a text"),
    (lambda r: r["bounds"].update(k1=[0]), r"/bounds/k1: expected \[lower, upper\]"),
    (lambda r: r["pairs"].__setitem__(1, [1, "x", 0.5]), r"/pairs/1: expected \[test mode, model mode, MAC\]"),
    (lambda r: r["frequencies_hz"]["test"].__setitem__(0, "2.07"), "/frequencies_hz/test/0: expected a number"),
    (lambda r: r.update(notes="one note"), "/notes: expected a list, got a text"),
    (lambda r: r.update(flags=[{}]), "the update result is not as femupdate writes it"),
    (lambda r: r["history"].__setitem__(0, "x"), "the update result is not as femupdate writes it"),
    (lambda r: r.update(diagnostics=3), "/diagnostics: expected an object, got a number"),
])
def test_an_edited_result_is_refused_naming_the_key(tmp_path, capsys, edit, message):
    """Each of these ended in a traceback (AttributeError, TypeError, ValueError, KeyError)."""
    result = json.loads((RECORDED / "update_figure2.json").read_text())
    edit(result)
    path = tmp_path / "u.json"
    path.write_text(json.dumps(result))
    code, err = _report([path, "-o", tmp_path / "r.html"], capsys)
    assert code == 2 and re.search(message, err), err
    assert f"error: {path}: " in err


def test_a_result_that_is_no_object_or_too_deep_names_the_file(tmp_path, capsys):
    path = tmp_path / "l.json"
    path.write_text("[1, 2]")
    code, err = _report([path, "-o", tmp_path / "r.html"], capsys)
    assert code == 2 and f"{path}: a result must be a JSON object, got a list" in err
    path.write_text("[" * 100000 + "]" * 100000)
    code, err = _report([path, "-o", tmp_path / "r.html"], capsys)
    assert code == 2 and f"{path}: JSON nested too deeply" in err


def test_update_report_shows_the_damping_ratios_of_the_run(ex, tmp_path, capsys):
    """update's JSON holds damping_ratio (measured, std, model, Rayleigh fit) for damped test
    modes; the report left it out."""
    test = json.loads((ex / "figure2_test.json").read_text())
    for k, m in enumerate(test["modes"]):
        m.update(damping_ratio=0.01 * (k + 1), std_damping_ratio=0.001 * (k + 1))
    data = tmp_path / "d.json"
    data.write_text(json.dumps(test))
    js, out = tmp_path / "u.json", tmp_path / "u.html"
    with pytest.raises(SystemExit) as e:
        main(["update", str(ex / "figure2.toml"), str(data), "--damping", "alpha=0.1,beta=0.001", "--json", str(js),
              "--report", str(out)])
    assert e.value.code == 0
    result = json.loads(js.read_text())
    html = out.read_text()
    assert ">Modal damping</h2>" in html and "Rayleigh damping fitted to the 3 measured ratios" in html
    for i in range(3):
        for side in ("test", "std", "model"):
            assert f'data-key="/damping_ratio/{side}/{i}"' in html
    assert check_numbers(html, result) >= 9 + 8
