import json

import numpy as np
import pytest

from femupdate import TestData
from femupdate.examples import figure2_test_data
from femupdate.io import parse_testdata
from femupdate.paper import SECTIONS, run_sections


@pytest.fixture(scope="module")
def paper_run(tmp_path_factory):
    """Every section once (in worker processes), shared by the tests below."""
    out = tmp_path_factory.mktemp("paper")
    seen = []
    result = run_sections(out, figures=True, progress=lambda name, s, done, total: seen.append((name, done, total)))
    return out, result, seen


def test_all_sections_reproduce_the_paper(paper_run):
    tmp_path, result, seen = paper_run
    saved = json.loads((tmp_path / "paper.json").read_text())
    assert set(SECTIONS) <= set(saved["sections"])
    assert sorted(n for n, _, _ in seen) == sorted(SECTIONS) and seen[-1][1:] == (len(SECTIONS), len(SECTIONS))
    for name, sec in saved["sections"].items():
        # never null: agree, or differ with the explanation
        assert sec["agrees_with_paper"] in (True, False), name
        assert sec["comparison"] == ("agree" if sec["agrees_with_paper"] else "differ-explained"), name
        if not sec["agrees_with_paper"]:
            assert len(sec["explanation"]) > 80, name
    ch = saved["sections"]["two_dof_characteristic"]
    assert (ch["a2"], ch["a1"], ch["a0"]) == (8.0, 68.0, 48.0)  # the paper's printed coefficients
    sols = [(s["k1"], s["k2"]) for s in ch["solutions"]]
    np.testing.assert_allclose(sols, [(8.0, 6.0), (9.0, 16.0 / 3.0)], rtol=1e-12)
    assert (tmp_path / ch["figure"]).stat().st_size > 1000
    assert result["sections"].keys() == saved["sections"].keys()


def test_new_sections_key_numbers(paper_run):
    tmp_path, result, _ = paper_run
    sec = result["sections"]
    # six-dof: the paper's criterion fails exactly on the two cases it singles out (from the ground); the
    # layout (max-flow) rank bound equals the numerical rank of every case and predicts every verdict
    six = sec["six_dof_uniqueness"]
    assert six["layouts"]["ground"]["paper_criterion_mismatches"] == ["2x3", "3x2"]
    assert not six["layouts"]["spread"]["paper_criterion_mismatches"]
    assert six["layout_criterion"]["holds_on_every_case"] is True
    cs = six["condition_search"]["log10_condition"]["femupdate_six_dof"]
    assert cs["eq19_scaled_analytic"]["2x3"]["1,2"] is None  # inf: rank-deficient
    assert 12.0 < cs["eq17_scaled_perturbation"]["2x3"]["1,2"] < 14.0  # the paper's 1e13 = a perturbation floor
    assert (tmp_path / six["figure_layouts"]).stat().st_size > 1000
    # eigenvector derivatives: the exact routes agree with each other and with finite differences
    for row in sec["eigenvector_derivatives"]["rows"]:
        r = row["routes"]
        assert r["nelson"]["error_vs_fd"] < 1e-5 and r["iterative"]["difference_from_nelson"] < 1e-8
        assert r["truncated_modal"]["error_vs_fd"] > 1e-2  # truncation without correction is visibly off
        if "full_modal" in r:
            assert r["full_modal"]["error_vs_fd"] < 1e-5
    # parameter counts: the paper's 9, 6, 5, 3 for N = 3
    pc = sec["parameter_counts"]["rows"]["Figure 1 (N = 3)"]
    assert (pc["full"], pc["symmetric"], pc["connectivity"], pc["physical"]) == (9, 6, 5, 3)
    assert sec["su_juang_criteria"]["general_criterion_reproduced"] is True
    st = sec["static_deflections"]
    np.testing.assert_allclose(st["by_hand"], [1000.0, 2000.0, 1500.0], rtol=1e-12)
    assert st["figure2"]["one_load_case"]["solved"] is False and st["figure2"]["loads_at_3_and_2"]["max_relative_error"] < 1e-10
    ap = sec["appendix_frame_terms"]
    assert ap["checks_pass"] and ap["length_known"]["max_rel_error"] < 1e-10 and len(ap["length_known"]["unknowns"]) == 3
    # the force location beside every FRF result
    for name in ("figure4_frf_condition", "eq29_frf_direct_two_dof", "eq32_receptance_sensitivity", "figure6_frf_surface",
                 "figure7_frf_surface", "modal_vs_frf_convergence", "noise_modal_vs_frf", "noise_frf_lines"):
        assert "force" in sec[name] and "force" in sec[name]["summary"], name
    # noise: the closely spaced lines of Figure 4 are far less robust than the paper's
    nl = sec["noise_frf_lines"]["line_sets"]
    assert nl["closely spaced (0.02..0.10 rad/s)"]["rms_error"] > 10 * nl["paper (0.5..2.5 rad/s)"]["rms_error"]


def test_direct_frf_noise_prediction_matches_monte_carlo():
    """The linearised error of eq. 29 under relative FRF noise against 400 seeded repetitions."""
    from femupdate.examples import two_dof
    from femupdate.paper.noise_sections import _direct_errors, _predicted_std

    model = two_dof()
    for w in ([0.5, 1.0, 1.5, 2.0, 2.5], [0.3, 0.9, 1.2, 2.4, 3.0]):
        e = _direct_errors(model, np.array(w), {"1:x": 1.0}, 0.01, 400, 7)
        pred = _predicted_std(model, np.array(w), {"1:x": 1.0}, 0.01)
        assert 0.8 < np.sqrt(np.mean(e**2)) / pred < 1.25, w


def test_sections_can_be_run_one_at_a_time(tmp_path):
    run_sections(tmp_path, ["two_dof_characteristic"], figures=False, jobs=1)
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


def _paper_cli(out, capsys, *extra):
    from femupdate.cli import main

    with pytest.raises(SystemExit) as info:
        main(["paper", "--out", str(out), "--section", "two_dof_characteristic", "--no-figures", *extra])
    o, e = capsys.readouterr()
    return info.value.code, o, e


def test_paper_cli_shows_progress_and_is_quiet_with_json_to_stdout(tmp_path, capsys):
    code, out, err = _paper_cli(tmp_path, capsys, "--jobs", "1")
    assert code == 0 and "[1/1] two_dof_characteristic" in out and "section(s) in" in out
    code, out, err = _paper_cli(tmp_path, capsys, "--json", "-")
    assert code == 0 and "[1/1]" not in out + err
    assert json.loads(out)["sections"]["two_dof_characteristic"]["comparison"] == "agree"


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
