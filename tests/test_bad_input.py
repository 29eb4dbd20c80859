"""Bad input gets one clear message naming the culprit, exit 2 (1 for numerical failure), never a
traceback and never a silent wrong answer (the input-side part of issue 16)."""

import json

import pytest

from femupdate.cli import main


def run(args, capsys):
    with pytest.raises(SystemExit) as info:
        main([str(a) for a in args])
    out, err = capsys.readouterr()
    return info.value.code, out, err


def check_refused(code, err, *fragments, exit_code=2):
    assert code == exit_code, err
    assert "Traceback" not in err
    for f in fragments:
        assert f in err, err


# ---------------------------------------------------------------------------------- 1, 2: CLI options
FLOAT_OPTIONS = [
    (["uniqueness", "{two}", "--rel-tol", "{v}"], "--rel-tol"),
    (["uniqueness", "{two}", "--cost-tol", "{v}"], "--cost-tol"),
    (["uniqueness", "{two}", "--min-mac", "{v}"], "--min-mac"),
    (["uniqueness", "{two}", "--connect-timeout", "{v}"], "--connect-timeout"),
    (["update", "{two}", "{freq}", "--min-mac", "{v}"], "--min-mac"),
    (["update", "{two}", "{freq}", "--std-eigenvalue", "{v}"], "--std-eigenvalue"),
    (["update", "{two}", "{freq}", "--std-shape", "{v}"], "--std-shape"),
    (["update", "{two}", "{freq}", "--std-frf", "{v}"], "--std-frf"),
    (["update", "{two}", "{freq}", "--std-static", "{v}"], "--std-static"),
    (["update", "{two}", "{freq}", "--resonance-tol", "{v}"], "--resonance-tol"),
    (["correlate", "{two}", "{freq}", "--min-mac", "{v}"], "--min-mac"),
    (["frf", "{two}", "--force", "1:x", "--omega", "1,2", "--noise", "{v}"], "--noise"),
    (["frf-update", "{two}", "{frf}", "--std", "{v}"], "--std"),
    (["frf-update", "{two}", "{frf}", "--resonance-tol", "{v}"], "--resonance-tol"),
    (["frf-select", "{two}", "--force", "1:x", "--candidates", "1:3:5", "--lines", "2", "--margin", "{v}"], "--margin"),
    (["update-multi", "{two}", "--config", "{freq}", "--min-mac", "{v}"], "--min-mac"),
    (["damage", "{truss}", "{damaged}", "--alpha", "{v}"], "--alpha"),
    (["damage", "{truss}", "{damaged}", "--min-change", "{v}"], "--min-change"),
    (["damage", "{truss}", "{damaged}", "--noise-frequency", "{v}"], "--noise-frequency"),
    (["damage", "{truss}", "{damaged}", "--noise-shape", "{v}"], "--noise-shape"),
    (["damage", "{truss}", "{damaged}", "--max-frequency-error", "{v}"], "--max-frequency-error"),
    (["damage", "{truss}", "{damaged}", "--min-mac", "{v}"], "--min-mac"),
    (["damage", "{truss}", "{damaged}", "--localise-min-mac", "{v}"], "--localise-min-mac"),
    (["damage", "{truss}", "{damaged}", "--level", "{v}"], "--level"),
]


def fill(args, ex, v=""):
    files = {"two": ex / "two_dof.toml", "freq": ex / "two_dof_frequencies.json", "frf": ex / "two_dof_frf.json",
             "truss": ex / "truss.toml", "damaged": ex / "truss_damaged.json"}
    return [a.format(v=v, **files) for a in args]


@pytest.mark.parametrize("value", ["nan", "inf", "-inf", "NaN"])
@pytest.mark.parametrize("args, option", FLOAT_OPTIONS, ids=[f"{a[0]} {o}" for a, o in FLOAT_OPTIONS])
def test_float_options_refuse_nan_and_inf(ex, capsys, args, option, value):
    code, _, err = run(fill(args, ex, value), capsys)
    check_refused(code, err, option)


def test_every_float_option_is_finite():
    """No command has a float option that lets nan through (click's FloatRange does)."""
    import click

    from femupdate.cli import cli
    from femupdate.cli._common import FiniteFloat

    for name, cmd in cli.commands.items():
        for p in cmd.params:
            if isinstance(p.type, (click.types.FloatParamType, click.FloatRange)):
                assert isinstance(p.type, FiniteFloat), f"{name} {p.opts}"


@pytest.mark.parametrize("args", [
    ["update", "{two}", "{freq}", "--starts", "3", "--seed", "-1"],
    ["posterior", "{two}", "{freq}", "--seed", "-1"],
    ["uniqueness", "{two}", "--seed", "-1"],
    ["frf", "{two}", "--force", "1:x", "--omega", "1,2", "--noise", "0.01", "--seed", "-1"],
    ["frf-update", "{two}", "{frf}", "--starts", "2", "--seed", "-5"],
    ["damage", "{truss}", "{damaged}", "--seed", "-1"],
])
def test_negative_seed_is_refused(ex, capsys, args):
    code, _, err = run(fill(args, ex), capsys)
    check_refused(code, err, "--seed")


@pytest.mark.parametrize("args, fragment", [
    (["frf", "{two}", "--force", "1:x=nan", "--omega", "1,2"], "--force"),
    (["frf", "{two}", "--force", "1:x", "--omega", "1,inf"], "--omega"),
    (["uniqueness", "{two}", "--noise", "nan"], "--noise"),
    (["uniqueness", "{two}", "--noise", "-0.1"], "--noise"),
    (["update", "{two}", "{freq}", "--regularization", "nan"], "--regularization"),
    (["update", "{two}", "{freq}", "--regularization", "-1"], "--regularization"),
])
def test_numbers_in_option_strings_must_be_finite(ex, capsys, args, fragment):
    code, _, err = run(fill(args, ex), capsys)
    check_refused(code, err, fragment)


# ---------------------------------------------------------------------------------- 3: --set as the file
@pytest.fixture
def wide_two_dof(ex, tmp_path):
    """The two-dof example with bounds [0, 100]: 0 is within the bounds, but not a stiffness."""
    p = tmp_path / "wide.toml"
    p.write_text((ex / "two_dof.toml").read_text().replace("[3.0, 13.0]", "[0.0, 100.0]").replace("[1.0, 11.0]", "[0.0, 100.0]"))
    return p


@pytest.mark.parametrize("value", ["0", "-1", "-0.0"])
def test_set_refuses_a_non_positive_stiffness_like_the_file(wide_two_dof, tmp_path, capsys, value):
    bad = tmp_path / "bad.toml"
    bad.write_text(wide_two_dof.read_text().replace("value = 7.0", f"value = {value}"))
    code, _, err = run(["modes", bad], capsys)
    check_refused(code, err, "k1")  # the file's check
    code, _, err = run(["modes", wide_two_dof, "--set", f"k1={value}"], capsys)
    check_refused(code, err, "--set", "'k1'")
    assert "> 0" in err or "outside its bounds" in err


@pytest.mark.parametrize("args", [
    ["modes", "{two}", "--set", "k1=20"],
    ["update", "{two}", "{freq}", "--set", "k2=0.5"],
    ["damage", "{truss}", "{damaged}", "--set", "E=0"],
])
def test_set_refuses_values_outside_the_bounds_like_the_file(ex, capsys, args):
    code, _, err = run(fill(args, ex), capsys)
    check_refused(code, err, "--set", "outside its bounds")


# ---------------------------------------------------------------------------------- 4, 5: numbers, duplicate keys
BIG = "9" * 400  # an integer too large for a float
HUGE = "9" * 5000  # above Python's 4,300-digit limit for converting integer strings


@pytest.mark.parametrize("old, new, field", [
    ("value = 7.0", f"value = {BIG}", "parameters.k1.value"),
    ("value = 7.0", f"value = {HUGE}", "line 5"),
    ("m = 2.0", f"m = {BIG}", "element[3].m"),
    ("m = 2.0", "m = 1e300", "element[3].m"),
    ("bounds = [3.0, 13.0]", "bounds = [3.0, 1e200]", "parameters.k1.bounds[2]"),
])
def test_model_file_refuses_numbers_too_large(ex, tmp_path, capsys, old, new, field):
    p = tmp_path / "m.toml"
    p.write_text((ex / "two_dof.toml").read_text().replace(old, new, 1))
    code, _, err = run(["modes", p], capsys)
    check_refused(code, err, str(p), field)


@pytest.mark.parametrize("old, new, field", [
    ('"frequency_hz": 2.074222', f'"frequency_hz": {BIG}', "modes[1].frequency_hz"),
    ('"frequency_hz": 2.074222', f'"frequency_hz": {HUGE}', "modes[1].frequency_hz"),
    ('"frequency_hz": 2.074222', '"frequency_hz": 1e300', "modes[1].frequency_hz"),
    ('"frequency_hz": 2.074222', '"frequency_hz": 1.7e308', "modes[1].frequency_hz"),
    ('"1:x": 0.672532', '"1:x": 1e300', "modes[1].shape.1:x"),
    ('"1:x": 0.672532', f'"1:x": -{BIG}', "modes[1].shape.1:x"),
])
def test_test_data_refuses_numbers_too_large(ex, tmp_path, capsys, old, new, field):
    p = tmp_path / "d.json"
    p.write_text((ex / "figure2_test.json").read_text().replace(old, new, 1))
    for cmd in ("correlate", "update"):
        code, _, err = run([cmd, ex / "figure2.toml", p], capsys)
        check_refused(code, err, str(p), field, "1e+150")


def test_frf_omega_too_large_is_refused(ex, tmp_path, capsys):
    raw = json.loads((ex / "two_dof_frf.json").read_text())
    raw["frf"]["omega_rad_s"][0] = 1e200
    p = tmp_path / "f.json"
    p.write_text(json.dumps(raw))
    code, _, err = run(["frf-update", ex / "two_dof.toml", p], capsys)
    check_refused(code, err, str(p), "frf.omega_rad_s[1]")


def test_frequencies_within_the_limit_have_finite_eigenvalues():
    from femupdate._limits import MAX_MAGNITUDE
    from femupdate.testdata import MeasuredMode

    import math
    assert math.isfinite(MeasuredMode.from_frequency(MAX_MAGNITUDE).eigenvalue)


@pytest.mark.parametrize("text, where, key", [
    ('{"modes": [{"frequency_hz": 1.0, "shape": {"1:x": 1.0, "1:x": 2.0}}]}', "modes[1].shape", "'1:x'"),
    ('{"modes": [{"frequency_hz": 1.0, "frequency_hz": 2.0}]}', "modes[1]", "'frequency_hz'"),
    ('{"modes": [{"frequency_hz": 1.0}], "modes": [{"frequency_hz": 2.0}]}', "top-level", "'modes'"),
])
def test_json_duplicate_keys_are_refused(ex, tmp_path, capsys, text, where, key):
    p = tmp_path / "dup.json"
    p.write_text(text)
    code, _, err = run(["correlate", ex / "two_dof.toml", p], capsys)
    check_refused(code, err, str(p), where, "duplicate key", key)


def test_toml_duplicate_keys_are_refused_by_the_parser(ex, tmp_path, capsys):
    p = tmp_path / "dup.toml"
    p.write_text((ex / "two_dof.toml").read_text().replace("value = 7.0", "value = 7.0\nvalue = 8.0", 1))
    code, _, err = run(["modes", p], capsys)
    check_refused(code, err, str(p), "malformed TOML")


def test_duplicate_keys_in_other_json_inputs(ex, tmp_path, capsys):
    p = tmp_path / "plus.json"
    p.write_text('{"name": "a", "name": "b"}')
    code, _, err = run(["update-multi", ex / "two_dof.toml", "--config", f"{ex / 'two_dof_frequencies.json'}:{p}"], capsys)
    check_refused(code, err, str(p), "duplicate key 'name'")


# ---------------------------------------------------------------------------------- 6: matrix models
@pytest.fixture
def matrix_dir(tmp_path):
    import numpy as np

    np.save(tmp_path / "K0.npy", np.diag([2.0, 1.0]))
    np.save(tmp_path / "M0.npy", np.eye(2))
    np.save(tmp_path / "dK.npy", np.diag([1.0, 0.0]))
    np.save(tmp_path / "K3.npy", np.zeros((2, 2, 2)))
    (tmp_path / "dofs.txt").write_text("1:x\n2:x\n")
    (tmp_path / "latin1.txt").write_bytes(b"\xff\xfe1:x\n2:x\n")
    return tmp_path


MATRIX_TOML = '''[matrices]
dofs = "dofs.txt"
K0 = "K0.npy"
M0 = "M0.npy"
[parameters.k1]
value = 1.0
K = "dK.npy"
'''


@pytest.mark.parametrize("old, new, fragments", [
    ('dofs = "dofs.txt"', "dofs = 5", ["dofs must be a file name or a list"]),
    ('dofs = "dofs.txt"', "dofs = {a = 1}", ["dofs must be a file name or a list"]),
    ('dofs = "dofs.txt"', 'dofs = "latin1.txt"', ["latin1.txt", "not UTF-8"]),
    ('K0 = "K0.npy"', 'K0 = "K3.npy"', ["K0", "3-dimensional"]),
    ('K0 = "K0.npy"', "K0 = [1]", ["K0", "matrix file name"]),
    ("value = 1.0", "value = 1.0\nbounds = 3", ["[parameters.k1]", "bounds"]),
    ("value = 1.0", "value = 1.0\nfixed = 3", ["[parameters.k1]", "fixed"]),
    ("[matrices]", "model = 5\n[matrices]", ["[model]"]),
])
def test_matrix_model_malformed(matrix_dir, capsys, old, new, fragments):
    p = matrix_dir / "m.toml"
    p.write_text(MATRIX_TOML.replace(old, new, 1))
    code, _, err = run(["modes", p], capsys)
    check_refused(code, err, str(p), *fragments)


def test_from_matrices_refuses_a_three_dimensional_array():
    import numpy as np

    from femupdate import InputError
    from femupdate.model import from_matrices

    with pytest.raises(InputError, match="K0 must be a square matrix"):
        from_matrices(["1:x", "2:x"], np.zeros((2, 2, 2)), np.eye(2))


# ---------------------------------------------------------------------------------- 7: damage, uneven dof sets
def test_damage_with_a_mode_lacking_a_dof_uses_the_common_dofs_and_says_so(ex, tmp_path, capsys):
    raw = json.loads((ex / "truss_damaged.json").read_text())
    del raw["modes"][1]["shape"]["3:y"]
    p = tmp_path / "d.json"
    p.write_text(json.dumps(raw))
    code, out, err = run(["damage", ex / "truss.toml", p, "--bootstrap", "2", "--json", "-"], capsys)
    assert code in (0, 1) and "Traceback" not in err, err
    notes = json.loads(out)["notes"]
    assert any("mode 2 lacks 3:y" in n and "3:y dropped" in n for n in notes), notes


# ---------------------------------------------------------------------------------- 8: truncated universal file
def test_uff_cut_inside_its_last_mode_record_is_refused(ex, tmp_path, capsys):
    full = tmp_path / "m.uff"
    code, _, err = run(["modes", ex / "figure2.toml", "--uff", full], capsys)
    assert code == 0, err
    lines = full.read_text().splitlines(keepends=True)
    assert lines[-1].rstrip() == "    -1"
    opening = max(i for i, ln in enumerate(lines[:-1]) if ln.rstrip() == "    -1")  # opens the last record
    for n in range(opening + 1, len(lines)):  # every cut after the last record's opening line
        cut = tmp_path / f"cut{n}.uff"
        cut.write_text("".join(lines[:n]))
        code, _, err = run(["correlate", ex / "figure2.toml", cut], capsys)
        check_refused(code, err, str(cut), "truncated")
        if n > opening + 1:
            assert "dataset 55 record 3" in err, err


# ---------------------------------------------------------------------------------- found by tests/test_fuzz.py
@pytest.mark.parametrize("eigenvalue", [0.0, 5e-324])
def test_zero_or_subnormal_test_eigenvalue(ex, tmp_path, capsys, eigenvalue):
    p = tmp_path / "d.json"
    p.write_text(json.dumps({"modes": [{"eigenvalue": eigenvalue}, {"eigenvalue": 7.72}]}))
    code, out, err = run(["correlate", ex / "two_dof.toml", p], capsys)  # was a division by zero
    assert code == 0 and "Traceback" not in err, err
    code, _, err = run(["update", ex / "two_dof.toml", p], capsys)  # 5e-324 overflowed the residual
    check_refused(code, err, "test mode(s) 1 have zero frequency")


def test_damage_refuses_a_rigid_body_test_mode(ex, tmp_path, capsys):
    raw = json.loads((ex / "truss_damaged.json").read_text())
    raw["modes"][0]["eigenvalue"] = 0.0
    p = tmp_path / "d.json"
    p.write_text(json.dumps(raw))
    code, _, err = run(["damage", ex / "truss.toml", p, "--bootstrap", "0"], capsys)  # was a division by zero
    check_refused(code, err, "mode 1", "zero frequency")


@pytest.mark.parametrize("omega", ["1,1e308", "0:1e308:3"])
def test_omega_above_the_magnitude_limit(ex, capsys, omega):
    code, _, err = run(["frf", ex / "two_dof.toml", "--force", "1:x", "--omega", omega], capsys)  # overflowed in ω²
    check_refused(code, err, "--omega")


# ---------------------------------------------------------------------------------- 9-11, 13: flags on results
def _eigen_data(tmp_path, k1, k2, name):
    """Exact modes of the two-dof example (masses 2 and 4) at k1, k2."""
    import numpy as np
    import scipy.linalg as sl

    lam, phi = sl.eigh(np.array([[k1 + k2, -k2], [-k2, k2]]), np.diag([2.0, 4.0]))
    p = tmp_path / name
    p.write_text(json.dumps({"modes": [{"eigenvalue": float(v), "shape": {"1:x": float(s[0]), "2:x": float(s[1])}}
                                       for v, s in zip(lam, phi.T)]}))
    return p


def test_direct_flags_a_negative_stiffness(ex, tmp_path, capsys):
    # one mode, eigenvalue 1, shape [1, -1]: exactly k1 = -2, k2 = 2 (bounds [3, 13] and [1, 11])
    p = tmp_path / "neg.json"
    p.write_text('{"modes": [{"eigenvalue": 1.0, "shape": {"1:x": 1.0, "2:x": -1.0}}]}')
    code, out, err = run(["direct", ex / "two_dof.toml", p], capsys)
    assert code == 0 and "Traceback" not in err, err
    assert "warning: k1 = -2 is not > 0" in out
    assert "at parameter value(s) k1 = -2 (bounds [3, 13])" in out  # item 13: K indefinite, the culprit named
    code, out, err = run(["direct", ex / "two_dof.toml", p, "--json", "-"], capsys)
    flags = json.loads(out)["flags"]
    assert [(f["parameter"], f["kind"]) for f in flags] == [("k1", "not_positive")]


def test_direct_bounded_flags_values_on_their_bounds(ex, tmp_path, capsys):
    p = tmp_path / "neg.json"
    p.write_text('{"modes": [{"eigenvalue": 1.0, "shape": {"1:x": 1.0, "2:x": -1.0}}]}')
    code, out, err = run(["direct", ex / "two_dof.toml", p, "--bounded", "--json", "-"], capsys)
    assert code == 0, err
    assert {(f["parameter"], f["kind"]) for f in json.loads(out)["flags"]} == {("k1", "on_bound"), ("k2", "on_bound")}


def test_direct_flags_a_value_outside_its_bounds(ex, tmp_path, capsys):
    p = _eigen_data(tmp_path, 7.0, 20.0, "k2_20.json")  # k2 = 20 > 11, positive
    code, out, err = run(["direct", ex / "two_dof.toml", p], capsys)
    assert code == 0, err
    assert "warning: k2 = 20 lies outside its bounds [1, 11]" in out


def test_update_converged_on_a_bound_is_flagged(ex, tmp_path, capsys):
    p = _eigen_data(tmp_path, 7.0, 0.3, "k2low.json")  # the truth k2 = 0.3 is below the bound 1
    code, out, err = run(["update", ex / "two_dof.toml", p], capsys)
    assert code == 0, err
    assert "k2 = 1 sits on its lower bound [1, 11]" in out
    code, out, err = run(["update", ex / "two_dof.toml", p, "--json", "-"], capsys)
    assert ("k2", "on_bound") in {(f["parameter"], f["kind"]) for f in json.loads(out)["flags"]}


def test_nominal_results_have_no_flags(ex, capsys):
    code, out, err = run(["direct", ex / "figure2.toml", ex / "figure2_test.json", "--json", "-"], capsys)
    assert code == 0 and json.loads(out)["flags"] == []


@pytest.mark.parametrize("grid, option, value", [
    (["--x", "-3:13:5", "--y", "1:11:5"], "--x", "-3"),
    (["--x", "3:13:5", "--y", "0:11:5"], "--y", "0"),
    (["--x", "3:13:5", "--y", "1,5,20"], "--y", "20"),
])
def test_surface_refuses_grids_outside_the_bounds(ex, capsys, grid, option, value):
    code, _, err = run(["surface", ex / "two_dof.toml", ex / "two_dof_frf.json", "--params", "k1,k2", *grid], capsys)
    check_refused(code, err, option, f"value {value} lies outside its bounds")


def test_indefinite_stiffness_names_the_parameter_value():
    import numpy as np

    from femupdate import InputError
    from femupdate.modal import model_modes
    from femupdate.model import Parameter, from_matrices

    m = from_matrices(["1:x", "2:x"], np.zeros((2, 2)), np.eye(2), [Parameter("a", 1.0, (0.0, 10.0))], [np.eye(2)])
    with pytest.raises(InputError, match=r"at parameter value\(s\) a = -1 \(bounds \[0, 10\]\)"):
        model_modes(m, {"a": -1.0})


# ---------------------------------------------------------------------------------- found by the offline fuzz profile
def test_subnormal_mass_is_refused(ex, tmp_path, capsys):
    p = tmp_path / "m.toml"
    p.write_text((ex / "two_dof.toml").read_text().replace("m = 4.0", "m = 1e-320"))
    code, _, err = run(["modes", p], capsys)  # overflowed in the stiffness/mass scale
    check_refused(code, err, "element #4", "property m", "below 1e-150")


def test_badly_scaled_matrix_model_names_the_dof(matrix_dir, capsys):
    import numpy as np

    np.save(matrix_dir / "M0.npy", np.diag([1.0, 1e-320]))
    p = matrix_dir / "m.toml"
    p.write_text(MATRIX_TOML)
    code, _, err = run(["modes", p], capsys)
    check_refused(code, err, "badly scaled", "2:x")


def test_std_options_refuse_subnormal_values(ex, capsys):
    code, _, err = run(["update", ex / "two_dof.toml", ex / "two_dof_frequencies.json", "--std-eigenvalue", "5e-324"], capsys)
    check_refused(code, err, "--std-eigenvalue")


def test_uff_node_number_too_large(ex, tmp_path, capsys):
    full = tmp_path / "m.uff"
    run(["modes", ex / "figure2.toml", "--uff", full], capsys)
    lines = full.read_text().splitlines(keepends=True)
    i = next(k for k, ln in enumerate(lines) if ln.split() == ["1"])  # the first node line of a mode record
    lines[i] = "9" * 400 + "\n"
    bad = tmp_path / "bad.uff"
    bad.write_text("".join(lines))
    code, _, err = run(["correlate", ex / "figure2.toml", bad], capsys)  # OverflowError in float()
    check_refused(code, err, str(bad), "node number")


# ---------------------------------------------------------------------------------- 12: no numpy reprs in messages
def test_messages_show_numbers_not_numpy_reprs():
    import numpy as np

    from femupdate import InputError
    from femupdate.model import Parameter
    from femupdate.testdata import MeasuredMode

    for make in (lambda: MeasuredMode(np.float64(-1.0)), lambda: Parameter("a", np.float64(np.inf)),
                 lambda: MeasuredMode.from_frequency(np.float64(-2.0))):
        with pytest.raises(InputError) as info:
            make()
        assert "np." not in str(info.value), str(info.value)


@pytest.mark.parametrize("args, option", [
    (["uniqueness", "{two}", "--starts", "2", "--rel-tol", "1e308"], "--rel-tol"),  # overflowed in the clustering
    (["frf-update", "{two}", "{frf}", "--lines", "9" * 100], "--lines"),  # OverflowError converting to a C long
    (["frf-update", "{two}", "{frf}", "--lines", "0"], "--lines"),
])
def test_options_out_of_range_found_offline(ex, capsys, args, option):
    code, _, err = run(fill(args, ex), capsys)
    check_refused(code, err, option)


@pytest.mark.parametrize("args, option", [
    (["uniqueness", "{two}", "--starts", "2", "--noise", "1e308"], "--noise"),  # overflowed in the noise
    (["frf-select", "{two}", "--force", "1:x", "--candidates", "1:3:5", "--lines", "2", "--margin", "1e308"], "--margin"),
    (["frf-update", "{two}", "{frf}", "--resonance-tol", "1e200"], "--resonance-tol"),
])
def test_float_options_above_the_magnitude_limit(ex, capsys, args, option):
    code, _, err = run(fill(args, ex), capsys)
    check_refused(code, err, option)


# ---------------------------------------------------------------------------------- deeply nested files
DEEP_TOML = "x = " + "[" * 100_000 + "]" * 100_000 + "\n"


def test_deeply_nested_toml_model_is_refused(tmp_path, capsys):
    p = tmp_path / "deep.toml"
    p.write_text(DEEP_TOML)
    code, _, err = run(["modes", p], capsys)
    check_refused(code, err, str(p), "nested too deeply")


def test_deeply_nested_toml_modification_is_refused(ex, tmp_path, capsys):
    p = tmp_path / "deepmod.toml"
    p.write_text(DEEP_TOML)
    code, _, err = run(["update-multi", ex / "two_dof.toml", "--config", f"{ex / 'two_dof_frequencies.json'}:{p}"],
                       capsys)
    check_refused(code, err, str(p), "nested too deeply")


def test_deeply_nested_toml_candidates_are_refused(ex, tmp_path, capsys):
    p = tmp_path / "deepcand.toml"
    p.write_text(DEEP_TOML)
    code, _, err = run(["rank-modifications", ex / "two_dof.toml", p, "--measured-dofs", "1:x,2:x", "--modes", "2"], capsys)
    check_refused(code, err, str(p), "nested too deeply")


# ---------------------------------------------------------------------------------- TOML booleans and strings
@pytest.mark.parametrize("model, old, new, fragment", [
    ("two_dof.toml", "value = 7.0", "value = true", "parameter 'k1': value must be a number, got true"),
    ("two_dof.toml", "bounds = [3.0, 13.0]", "bounds = [true, 13.0]", "parameter 'k1': bounds must be numbers, got [true, 13.0]"),
    ("two_dof.toml", "m = 2.0", "m = true", "element #3 (mass): m must be a number or a parameter name, got true"),
    ("truss.toml", "xyz = [1.0, 0.0]", "xyz = [1.0, false]", "node #2: xyz must be numbers, got [1.0, false]"),
    ("truss.toml", "nodes = [1, 2]", "nodes = [true, 2]", "element #1 (rod): nodes must be numbers, got [true, 2]"),
    ("truss.toml", "dim = 2", "dim = true", "element #1 (rod): dim must be a number, got true"),
    ("truss.toml", "A = 4e-4", "A = true", "element #1 (rod): A must be a number or a parameter name, got true"),
], ids=["value", "bounds", "mass", "xyz", "element nodes", "dim", "property"])
def test_model_file_refuses_booleans_where_numbers_belong(ex, tmp_path, capsys, model, old, new, fragment):
    p = tmp_path / model
    text = (ex / model).read_text()
    assert old in text
    p.write_text(text.replace(old, new, 1))
    code, _, err = run(["modes", p], capsys)
    check_refused(code, err, str(p), fragment)


def test_model_file_refuses_a_boolean_support_node(ex, tmp_path, capsys):
    p = tmp_path / "truss.toml"
    p.write_text((ex / "truss.toml").read_text() + "\n[[support]]\nnodes = [false]\n")
    code, _, err = run(["modes", p], capsys)
    check_refused(code, err, str(p), "support #2: nodes must be numbers, got [false]")


def test_matrix_model_parameter_refuses_a_boolean_value():
    from femupdate.model import Parameter
    from femupdate._errors import InputError

    with pytest.raises(InputError, match="value must be a number, got true"):
        Parameter("k", True)
    with pytest.raises(InputError, match=r"bounds must be numbers, got \[true, 5\]"):
        Parameter("k", 2.0, (True, 5))


# ---------------------------------------------------------------------------------- static load cases
@pytest.mark.parametrize("static, fragment", [
    ({"force": {"2:x": 1.0}, "displacement": {}}, "static[1]: no measured displacement"),
    ([{"force": {"2:x": 1.0}, "displacement": {"1:x": 0.125}}, {"force": {"2:x": 1.0}, "displacement": {"1:x": 0.0, "2:x": 0}}],
     "static[2]: every measured displacement is zero"),
    ({"force": {"2:x": 0.0}, "displacement": {"1:x": 0.125}}, "static[1]: the force vector is empty or zero"),
], ids=["no displacement", "all zero", "zero force"])
def test_static_load_case_without_information_is_refused(ex, tmp_path, capsys, static, fragment):
    p = tmp_path / "d.json"
    p.write_text(json.dumps({"modes": [{"eigenvalue": 0.7768890026375489}], "static": static}))
    code, _, err = run(["update", ex / "two_dof.toml", p], capsys)
    check_refused(code, err, str(p), fragment)


def test_an_empty_static_list_is_like_an_empty_modes_list(ex, tmp_path, capsys):
    for key in ("modes", "static"):
        p = tmp_path / f"{key}.json"
        p.write_text(json.dumps({key: []}))
        code, _, err = run(["update", ex / "two_dof.toml", p], capsys)
        check_refused(code, err, str(p), "no test data")


@pytest.mark.parametrize("command", ["correlate", "update"])
def test_a_shape_too_small_to_compute_with_is_refused_by_every_command(ex, tmp_path, capsys, command):
    p = tmp_path / "d.json"
    p.write_text(json.dumps({"modes": [{"frequency_hz": 0.14, "shape": {"1:x": 1e-200, "2:x": 1e-200}}]}))
    code, _, err = run([command, ex / "two_dof.toml", p], capsys)  # correlate left it unpaired, exit 0
    check_refused(code, err, str(p), "modes[1]", "too small to compute with")
    p.write_text(json.dumps({"modes": [{"frequency_hz": 0.14, "shape": {"1:x": 1e-140, "2:x": 2e-140}}]}))
    code, _, err = run([command, ex / "two_dof.toml", p], capsys)
    assert code == 0, err
