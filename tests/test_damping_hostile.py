"""Bad input to the damping features (issue 31, item 6), found by a hostile test pass: each is one
message naming the culprit as the user wrote it, exit 2, no traceback."""

from __future__ import annotations

import json

import pytest

from femupdate.examples import truss_damped_model_toml, truss_damped_test_files


def _run(args, capsys):
    from femupdate.cli import main

    with pytest.raises(SystemExit) as info:
        main([*map(str, args)])
    out, err = capsys.readouterr()
    return info.value.code, out, err


def _files(tmp_path):
    (tmp_path / "m.toml").write_text(truss_damped_model_toml())
    for name, text in truss_damped_test_files().items():
        (tmp_path / name).write_text(text)
    return tmp_path / "m.toml", tmp_path / "truss_damped_modes.json", tmp_path / "truss_damped_frf.json"


def _refused(code, out, err, message):
    assert code == 2, out + err
    assert message in err and "Traceback" not in err, err
    assert err.strip().count("\n") == 0, err  # one message


def test_update_test_points_refused_by_name(tmp_path, capsys):
    # was: "unknown top-level key(s) damping", the test points' reader blaming the model file
    model, modes, _ = _files(tmp_path)
    _refused(*_run(["update", model, modes, "--test-points", "0.01"], capsys), "--test-points with a [damping] table")


def test_frf_data_zero_everywhere_refused(tmp_path, capsys):
    # was: exit 0, "converged" at the start values with FRAC nan and cost 0
    model, _, frf = _files(tmp_path)
    obj = json.loads(frf.read_text())
    obj["frf"]["response"] = {d: [[0.0, 0.0]] * len(obj["frf"]["omega_rad_s"]) for d in obj["frf"]["response"]}
    frf.write_text(json.dumps(obj))
    _refused(*_run(["frf-update", model, frf], capsys), "frf: every FRF channel is zero at every line")


@pytest.mark.parametrize("key", ["c", "eta"])
def test_damper_without_c_or_loss_without_eta_refused(tmp_path, capsys, key):
    # was: exit 0, the damper or loss factor taken as 0 without a word
    text = truss_damped_model_toml()
    if key == "c":
        text = text.replace('dofs = ["103:y"]\nc = "c2"\n', 'dofs = ["103:y"]\n').replace(
            "[damping.parameters.c2]\nvalue = 250.0\nbounds = [0.0, 1.0e4]\n", "")
        assert 'c = "c2"' not in text and "parameters.c2" not in text
        where = "[damping] damper #2: needs c"
    else:
        text += '\n[[damping.loss]]\non = "K"\n'
        where = "[damping] loss #1: needs eta"
    (tmp_path / "m.toml").write_text(text)
    _refused(*_run(["complex-modes", tmp_path / "m.toml"], capsys), where)


def test_std_damping_ratio_in_percent_refused(tmp_path, capsys):
    # was: exit 0, the damping ratios weighted by 1/5 (a std of 5 on fractions below 1)
    model, modes, _ = _files(tmp_path)
    _refused(*_run(["update", model, modes, "--std-damping-ratio", "1"], capsys),
             "--std-damping-ratio: 1 is not below 1")
    obj = json.loads(modes.read_text())
    for m in obj["modes"]:
        m["std_damping_ratio"] = 5.0
    modes.write_text(json.dumps(obj))
    _refused(*_run(["update", model, modes], capsys),
             "modes[1] std_damping_ratio: 5 is not below 1: the standard deviation of a damping ratio is a fraction")


def test_std_damping_ratio_in_percent_refused_in_python(tmp_path):
    import femupdate
    from femupdate._errors import InputError
    from femupdate.damping import load_damped_model

    model, modes, _ = _files(tmp_path)
    with pytest.raises(InputError, match=r"measurement_std\['damping_ratio'\]: 2 is not below 1"):
        femupdate.update(load_damped_model(model), femupdate.load_test_data(modes), measurement_std={"damping_ratio": 2.0})


def test_bad_prior_of_a_damping_parameter_names_the_file_once(tmp_path, capsys):
    # was: "m.toml: [damping] parameters.b: m.toml: [damping] parameters.b prior: ..." (the file named twice)
    text = truss_damped_model_toml().replace("[damping.parameters.b]\n", "[damping.parameters.b]\nprior = {mean = 1.0}\n")
    assert "prior = {mean" in text
    (tmp_path / "m.toml").write_text(text)
    code, out, err = _run(["complex-modes", tmp_path / "m.toml"], capsys)
    _refused(code, out, err, "[damping] parameters.b prior: an inline table needs type")
    assert err.count("m.toml") == 1, err


def test_loss_factor_of_one_or_more_is_said_to_look_like_a_percentage(tmp_path, caplog):
    # was: eta = 2.0 (2 % meant) taken without a word: the truss's first mode at zeta 0.56 instead of ~0.08
    from femupdate.damping import load_damped_model

    (tmp_path / "m.toml").write_text(truss_damped_model_toml() + '\n[[damping.loss]]\neta = 2.0\non = "K"\n')
    with caplog.at_level("WARNING"):
        dm = load_damped_model(tmp_path / "m.toml")
    assert dm.losses[0].eta == 2.0  # taken (some viscoelastic layers reach 1), but said
    assert "loss #1 eta = 2 is 1 or more: loss factors are fractions" in caplog.text
    assert "write 0.02" in caplog.text


def test_start_at_critical_modal_ratio_refused_by_name(tmp_path, capsys):
    # was: exit 1, "damped modes: test mode 2: no model mode left to pair with" (z = 1 within its bounds [0, 1])
    model, modes, _ = _files(tmp_path)
    text = truss_damped_model_toml()
    text = text[:text.index("[damping]")] + '[damping]\nmodal = ["z", "z", "z", "z"]\n[damping.parameters.z]\nvalue = 0.02\n'
    model.write_text(text)
    _refused(*_run(["update", model, modes, "--set", "z=1"], capsys),
             "the start value of damping parameter 'z' (a modal damping ratio) = 1 is critical damping")
