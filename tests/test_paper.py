import json

import numpy as np
import pytest

from femupdate import TestData
from femupdate.examples import figure2_test_data
from femupdate.io import parse_testdata
from femupdate.paper import SECTIONS, run_sections


def test_all_sections_reproduce_the_paper(tmp_path):
    result = run_sections(tmp_path, figures=True)
    saved = json.loads((tmp_path / "paper.json").read_text())
    assert set(SECTIONS) <= set(saved["sections"])
    for name, sec in saved["sections"].items():
        assert sec["agrees_with_paper"] is not False, name
    ch = saved["sections"]["two_dof_characteristic"]
    assert (ch["a2"], ch["a1"], ch["a0"]) == (8.0, 68.0, 48.0)  # the paper's printed coefficients
    sols = [(s["k1"], s["k2"]) for s in ch["solutions"]]
    np.testing.assert_allclose(sols, [(8.0, 6.0), (9.0, 16.0 / 3.0)], rtol=1e-12)
    assert (tmp_path / ch["figure"]).stat().st_size > 1000
    assert result["sections"].keys() == saved["sections"].keys()


def test_sections_can_be_run_one_at_a_time(tmp_path):
    run_sections(tmp_path, ["two_dof_characteristic"], figures=False)
    run_sections(tmp_path, ["figure2_direct"], figures=False)
    saved = json.loads((tmp_path / "paper.json").read_text())
    assert set(saved["sections"]) == {"two_dof_characteristic", "figure2_direct"}  # nothing lost


def test_builtin_demo_data_is_what_the_generator_makes():
    from importlib import resources

    shipped = json.loads((resources.files("femupdate") / "data" / "figure2_test.json").read_text())
    assert shipped == json.loads(json.dumps(figure2_test_data()))
    assert isinstance(parse_testdata(shipped), TestData)


def test_appendix_section_checks_the_element_and_the_printed_row_7(tmp_path):
    from femupdate.paper.element_sections import appendix_frame_terms

    sec = appendix_frame_terms(tmp_path, figures=False)
    assert sec["max_rel_difference_corrected"] < 1e-12  # femupdate's element = corrected Appendix matrix
    assert sec["rigid_axial_translation_force"]["corrected"] == 0.0
    assert sec["rigid_axial_translation_force"]["as_printed"] > 0.0  # printed row 7 breaks equilibrium
    assert sec["identification_from_one_state"]["max_rel_error"] < 1e-10


def _paper_cli(out, capsys):
    from femupdate.cli import main

    with pytest.raises(SystemExit) as info:
        main(["paper", "--out", str(out), "--section", "two_dof_characteristic", "--no-figures"])
    o, e = capsys.readouterr()
    return info.value.code, o, e


def test_a_malformed_or_foreign_paper_json_is_ignored_with_a_note(tmp_path, capsys):
    title = "Issues concerning the updating of finite-element models from experimental data"
    cases = {
        "deep": "[" * 100_000 + "]" * 100_000,
        "nan": '{"paper": "%s", "sections": {"figure2_direct": {"summary": "s", "agrees_with_paper": NaN}}}' % title,
        "not an object": '"x"',
        "sections not an object": json.dumps({"paper": title, "sections": [1, 2]}),
        "foreign": json.dumps({"paper": "another paper", "sections": {"figure2_direct": {"summary": "s",
                                                                                          "agrees_with_paper": True}}}),
    }
    for what, text in cases.items():
        (tmp_path / "paper.json").write_text(text)
        code, out, err = _paper_cli(tmp_path, capsys)
        assert code == 0 and "Traceback" not in err, (what, err)
        assert "ignored" in out and str(tmp_path / "paper.json") in out, (what, out)
        saved = json.loads((tmp_path / "paper.json").read_text())
        assert set(saved["sections"]) == {"two_dof_characteristic"}, what
    # sections not as femupdate writes them are dropped by name; kept ones are marked as earlier results
    (tmp_path / "paper.json").write_text(json.dumps({"paper": title, "sections": {
        "figure2_direct": {"summary": "kept", "agrees_with_paper": True},
        "eq5_direct_three_dof": [1],
        "eq22_sensitivity": {"summary": "s", "agrees_with_paper": "maybe"},
        "forged_section": {"summary": "all fine", "agrees_with_paper": True}}}))
    code, out, err = _paper_cli(tmp_path, capsys)
    assert code == 0 and "Traceback" not in err, err
    for name in ("'eq5_direct_three_dof'", "'eq22_sensitivity'", "'forged_section'"):
        assert name in out, out
    assert "ok (earlier run)" in out and "all fine" not in out
    saved = json.loads((tmp_path / "paper.json").read_text())
    assert set(saved["sections"]) == {"figure2_direct", "two_dof_characteristic"}
