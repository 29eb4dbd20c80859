"""Per-mode standard deviations and weights, from the test data and the command line: the same
update whichever way they come, a different one from uniform values, and the frequency's
relative std converted to the eigenvalue's (σ_λ/λ = 2 σ_f/f)."""

import json
import math

import numpy as np
import pytest

from femupdate import InputError, MeasuredMode, TestData, model_modes
from femupdate.examples import chain, two_dof
from femupdate.io.testdata_json import load_testdata, parse_testdata
from femupdate.updating import Problem, multistart, update

K6 = np.array([1000.0, 1800.0, 1500.0, 1200.0, 900.0, 1600.0])
M6 = np.array([1.0, 1.2, 0.8, 1.1, 0.9, 1.0])
DOFS = ["2:x", "4:x", "6:x"]
STD_F = [0.005, 0.01, 0.02]  # relative, of the frequencies
STD_PSI = [0.01, 0.03, 0.02]
WEIGHT = [1.0, 2.0, 0.5]


def noisy_modes(seed=3):
    truth = chain(K6, M6, bounds=(100.0, 5000.0))
    mm = model_modes(truth)
    pos = truth.dof_index(DOFS)
    rng = np.random.default_rng(seed)
    out = []
    for r in range(3):
        f = mm.frequencies_hz[r] * (1 + STD_F[r] * rng.standard_normal())
        shape = mm.shapes[pos, r] / np.linalg.norm(mm.shapes[pos, r]) + STD_PSI[r] * rng.standard_normal(3)
        out.append((float(f), dict(zip(DOFS, map(float, shape)))))
    return out


def model():
    return chain(K6 * [0.8, 1.2, 0.9, 1.1, 1.05, 0.95], M6, bounds=(100.0, 5000.0))


def files(tmp_path, **per_mode):
    """The noisy modes as a plain JSON file and as one with the per-mode keys ``per_mode``
    {key: [one value per mode]}."""
    modes = noisy_modes()
    plain = {"modes": [{"frequency_hz": f, "shape": s} for f, s in modes]}
    rich = {"modes": [dict(m, **{k: v[i] for k, v in per_mode.items()}) for i, m in enumerate(plain["modes"])]}
    (tmp_path / "plain.json").write_text(json.dumps(plain))
    (tmp_path / "rich.json").write_text(json.dumps(rich))
    return tmp_path / "plain.json", tmp_path / "rich.json"


def same(a, b):
    assert np.array_equal(a.x, b.x)
    assert a.cost == b.cost
    assert np.array_equal(a.diagnostics.covariance, b.diagnostics.covariance, equal_nan=True)
    assert a.diagnostics.absolute == b.diagnostics.absolute


# ---------------------------------------------------------------------------------- (c) the same update
def test_per_mode_std_in_the_file_is_the_python_list_and_not_the_uniform_value(tmp_path):
    plain, rich = files(tmp_path, std_frequency=STD_F, std_shape=STD_PSI)
    m = model()
    from_file = update(m, load_testdata(rich, m))
    lists = update(m, load_testdata(plain, m), measurement_std={"eigenvalue": [2 * s for s in STD_F],
                                                                  "shape": STD_PSI})
    same(from_file, lists)
    assert from_file.diagnostics.absolute  # every residual divided by a stated std
    uniform = update(m, load_testdata(plain, m), measurement_std={"eigenvalue": 2 * np.mean(STD_F),
                                                                    "shape": float(np.mean(STD_PSI))})
    assert np.max(np.abs(uniform.x / from_file.x - 1)) > 1e-3
    assert np.max(np.abs(uniform.diagnostics.std / from_file.diagnostics.std - 1)) > 1e-2


def test_std_eigenvalue_in_the_file_and_weights(tmp_path):
    plain, rich = files(tmp_path, std_eigenvalue=[2 * s for s in STD_F], weight=WEIGHT)
    m = model()
    from_file = update(m, load_testdata(rich, m))
    lists = update(m, load_testdata(plain, m), measurement_std={"eigenvalue": [2 * s for s in STD_F]},
                   weights={"eigenvalue": WEIGHT, "shape": WEIGHT})
    same(from_file, lists)
    unweighted = update(m, load_testdata(plain, m), measurement_std={"eigenvalue": [2 * s for s in STD_F]})
    assert np.max(np.abs(unweighted.x / from_file.x - 1)) > 1e-3


def test_the_caller_s_values_replace_the_file_s(tmp_path):
    """Python (and the command line) over the file, key by key."""
    plain, rich = files(tmp_path, std_frequency=STD_F, std_shape=STD_PSI, weight=WEIGHT)
    m = model()
    data, bare = load_testdata(rich, m), load_testdata(plain, m)
    same(update(m, data, measurement_std={"eigenvalue": 0.02}),
         update(m, bare, measurement_std={"eigenvalue": 0.02, "shape": STD_PSI}, weights={"eigenvalue": WEIGHT,
                                                                                           "shape": WEIGHT}))
    same(update(m, data, measurement_std={"eigenvalue": 0.02, "shape": 0.05}, weights={"shape": 1.0}),
         update(m, bare, measurement_std={"eigenvalue": 0.02, "shape": 0.05}, weights={"eigenvalue": WEIGHT}))


def test_per_mode_values_reach_multistart_and_the_mixed_route(tmp_path):
    plain, rich = files(tmp_path, std_frequency=STD_F, std_shape=STD_PSI)
    m = model()
    data, bare = load_testdata(rich, m), load_testdata(plain, m)
    std = {"eigenvalue": [2 * s for s in STD_F], "shape": STD_PSI}
    for batched in (None, False):
        a = multistart(m, data, starts=2, seed=5, batched=batched).best
        b = multistart(m, bare, starts=2, seed=5, batched=batched, measurement_std=std).best
        same(a, b)
    # with a static case: the modal block counts as stated by the file (its weighting, the covariance)
    truth = chain(K6, M6, bounds=(100.0, 5000.0))
    u = np.linalg.solve(truth.K(truth.values).toarray(), np.eye(6)[:, 5])
    from femupdate.testdata import StaticData

    case = (StaticData({"6:x": 1.0}, ("6:x",), u[[5]]),)
    mixed = update(m, TestData(modes=data.modes, static=case), measurement_std={"static": 1e-6})
    listed = update(m, TestData(modes=bare.modes, static=case), measurement_std=dict(std, static=1e-6))
    same(mixed, listed)
    assert mixed.blocks[0]["weighting"] == "stated std" and mixed.diagnostics.absolute


def test_per_mode_values_reach_update_multi():
    """Two configurations (as tested, and with 1 kg added at 1:x), frequencies only with their
    relative stds in the data: the joint update and its absolute covariance are those of the stds
    given as lists."""
    from femupdate.updating.multiconfig import Configuration, Modification, configure, update_configurations

    base = two_dof(7.0, 6.5)
    mod = Modification("+1 kg", masses=(("1:x", 1.0),))
    s = [0.004, 0.01]
    rich, plain = [], []
    for modification in (Modification("as tested"), mod):
        f = model_modes(configure(two_dof(), modification).model).frequencies_hz
        rich.append(Configuration(TestData(modes=tuple(MeasuredMode.from_frequency(f[i] * (1.002, 0.997)[i],
                                                                                   std_frequency=s[i])
                                                      for i in range(2))), modification))
        plain.append(Configuration(TestData(modes=tuple(MeasuredMode.from_frequency(f[i] * (1.002, 0.997)[i])
                                                       for i in range(2))), modification))
    a = update_configurations(base, rich)
    b = update_configurations(base, plain, measurement_std={"eigenvalue": [2 * v for v in s]})
    assert np.array_equal(a.x, b.x) and a.cost == b.cost
    assert a.diagnostics.absolute and b.diagnostics.absolute
    assert np.array_equal(a.diagnostics.covariance, b.diagnostics.covariance)
    c = update_configurations(base, plain)
    assert not c.diagnostics.absolute and not np.allclose(c.x, a.x, rtol=1e-6)


def test_a_std_stated_for_some_modes_only_is_refused_unless_given_for_all(tmp_path):
    plain, _ = files(tmp_path)
    raw = json.loads(plain.read_text())
    raw["modes"][0]["std_frequency"] = 0.01
    raw["modes"][2]["std_frequency"] = 0.01
    m = model()
    data = parse_testdata(raw)
    with pytest.raises(InputError, match=r"std_frequency or std_eigenvalue for test modes 1, 3 but not for test "
                                         r"mode 2: .*--std-eigenvalue"):
        update(m, data)
    update(m, data, measurement_std={"eigenvalue": 0.01})  # the caller's value for all: fine
    raw["modes"][1]["std_shape"] = 0.01
    raw["modes"][1]["std_frequency"] = 0.02
    with pytest.raises(InputError, match=r"std_shape for test mode 2 but not for test modes 1, 3"):
        update(m, parse_testdata(raw))
    # no shape compared: no std_shape needed (the refusal is then that of too few data)
    with pytest.raises(InputError, match="6 parameters but only 3 independent data"):
        update(m, parse_testdata(raw), use_shapes=False)


def test_a_list_of_the_wrong_length_names_the_key():
    m = model()
    data = TestData(modes=tuple(MeasuredMode.from_frequency(f, list(s), list(s.values())) for f, s in noisy_modes()))
    with pytest.raises(InputError, match=r"measurement_std\['shape'\]: give one value or one per test mode \(3\), got 2"):
        update(m, data, measurement_std={"eigenvalue": 0.01, "shape": [0.1, 0.2]})


# ---------------------------------------------------------------------------------- (c) the conversion
def test_std_frequency_converts_to_the_eigenvalue_std_on_the_two_dof_system():
    """Figure 3 (k1 = 8, k2 = 6, m = 2, 4), its two frequencies with relative stds 1 % and 3 %."""
    truth = two_dof()
    f = model_modes(truth).frequencies_hz
    s = [0.01, 0.03]
    data = parse_testdata({"modes": [{"frequency_hz": float(f[i]), "std_frequency": s[i]} for i in range(2)]})
    assert [mo.std_eigenvalue for mo in data.modes] == [2 * s[0], 2 * s[1]]
    # (1) a test frequency off by ε of itself gives a residual of −ε/s_f (first order): the residual
    # is the frequency error in units of its standard deviation
    eps = 1e-6
    off = parse_testdata({"modes": [{"frequency_hz": float(f[i] * (1 + eps)), "std_frequency": s[i]} for i in range(2)]})
    r = Problem(truth, off).residuals(np.ones(2))
    np.testing.assert_allclose(r, [-eps / s[0], -eps / s[1]], rtol=3 * eps)
    # (2) the covariance of (k1, k2) in closed form: dλ_i/dk_j = φ_iᵀ K_j φ_i (mass-normalised),
    # each row divided by λ_i · 2 s_i
    res = update(two_dof(7.0, 6.5), data)
    np.testing.assert_allclose(res.x, [8.0, 6.0], rtol=1e-9)
    K = np.array([[14.0, -6.0], [-6.0, 6.0]])
    M = np.diag([2.0, 4.0])
    lam, phi = np.linalg.eigh(np.linalg.solve(np.sqrt(M), np.linalg.solve(np.sqrt(M), K).T))
    phi = np.linalg.solve(np.sqrt(M), phi)  # mass-normalised: φᵀ M φ = I
    dK = [np.array([[1.0, 0.0], [0.0, 0.0]]), np.array([[1.0, -1.0], [-1.0, 1.0]])]
    J = np.array([[phi[:, i] @ dK[j] @ phi[:, i] / (lam[i] * 2 * s[i]) for j in range(2)] for i in range(2)])
    np.testing.assert_allclose(res.diagnostics.covariance, np.linalg.inv(J.T @ J), rtol=1e-8)
    assert res.diagnostics.absolute
    assert math.isclose(lam[0], data.modes[0].eigenvalue, rel_tol=1e-12)


def test_uff_modes_have_no_per_mode_std(tmp_path, capsys):
    from femupdate.cli import main
    from femupdate.io.uff import read_uff

    ex = tmp_path / "ex"
    with pytest.raises(SystemExit):
        main(["demo", "--write-files", str(ex)])
    with pytest.raises(SystemExit) as info:
        main(["modes", str(ex / "figure2.toml"), "--uff", str(tmp_path / "m.uff")])
    capsys.readouterr()
    assert info.value.code in (0, None)
    data = read_uff(tmp_path / "m.uff")
    assert data.modes
    assert all(mo.std_eigenvalue is None and mo.std_shape is None and mo.weight is None for mo in data.modes)


# ---------------------------------------------------------------------------------- the test-data file
@pytest.mark.parametrize("key, value, message", [
    ("std_frequency", -0.01, "modes[2] std_frequency: -0.01 is not > 0"),
    ("std_frequency", 0, "modes[2] std_frequency: 0 is not > 0"),
    ("std_eigenvalue", "0.01", "modes[2] std_eigenvalue: expected a number, got '0.01'"),
    ("std_shape", True, "modes[2] std_shape: expected a number, got True"),
    ("std_shape", [0.01], "modes[2] std_shape: expected a number, got [0.01]"),
    ("weight", 0.0, "modes[2] weight: 0 is not > 0"),
    ("weight", -2, "modes[2] weight: -2 is not > 0"),
    ("std_shape", 1e-200, "modes[2] std_shape: 1e-200 is outside [1e-150, 1e+150]"),
])
def test_bad_per_mode_values_are_refused_by_name(key, value, message):
    with pytest.raises(InputError) as info:
        parse_testdata({"modes": [{"frequency_hz": 1.0}, {"frequency_hz": 2.0, key: value}]})
    assert str(info.value) == message


def test_both_stds_of_a_mode_are_refused():
    with pytest.raises(InputError, match=r"modes\[1\]: give at most one of std_frequency or std_eigenvalue"):
        parse_testdata({"modes": [{"frequency_hz": 1.0, "std_frequency": 0.01, "std_eigenvalue": 0.02}]})


# ---------------------------------------------------------------------------------- (d) the command line
def _cli(args, capsys):
    from femupdate.cli import main

    with pytest.raises(SystemExit) as info:
        main([str(a) for a in args])
    out, err = capsys.readouterr()
    return info.value.code, out, err


def _model_file(tmp_path):
    lines = ['[model]', 'name = "chain"']
    for i, k in enumerate(K6 * [0.8, 1.2, 0.9, 1.1, 1.05, 0.95], start=1):
        lines += [f"[parameters.k{i}]", f"value = {float(k)!r}", "bounds = [100.0, 5000.0]"]
    for i, mass in enumerate(M6, start=1):
        dofs = f'["{i}:x"]' if i == 1 else f'["{i - 1}:x", "{i}:x"]'
        lines += ["[[element]]", 'type = "spring"', f"dofs = {dofs}", f'k = "k{i}"',
                  "[[element]]", 'type = "mass"', f'dofs = ["{i}:x"]', f"m = {float(mass)!r}"]
    p = tmp_path / "chain.toml"
    p.write_text("\n".join(lines) + "\n")
    return p


def test_cli_lists_equal_the_file_and_win_over_it(tmp_path, capsys):
    plain, rich = files(tmp_path, std_frequency=STD_F, std_shape=STD_PSI)
    mf = _model_file(tmp_path)
    outs = {}
    for name, args in {"file": [rich],
                       "lists": [plain, "--std-eigenvalue", ",".join(repr(2 * s) for s in STD_F),
                                 "--std-shape", ",".join(map(repr, STD_PSI))],
                       "override": [rich, "--std-eigenvalue", "0.02", "--std-shape", "0.02"],
                       "uniform": [plain, "--std-eigenvalue", "0.02", "--std-shape", "0.02"]}.items():
        code, _, err = _cli(["update", mf, *args, "--json", tmp_path / f"{name}.json"], capsys)
        assert code == 0, err
        outs[name] = json.loads((tmp_path / f"{name}.json").read_text())
    assert outs["file"]["parameters"] == outs["lists"]["parameters"]
    assert outs["file"]["diagnostics"]["std"] == outs["lists"]["diagnostics"]["std"]
    assert outs["override"]["parameters"] == outs["uniform"]["parameters"]
    assert outs["file"]["parameters"] != outs["uniform"]["parameters"]
    # and the same as the Python API with lists
    m = model()
    res = update(m, load_testdata(plain, m), measurement_std={"eigenvalue": [2 * s for s in STD_F], "shape": STD_PSI})
    assert [outs["file"]["parameters"][n] for n in res.names] == list(res.x)


@pytest.mark.parametrize("option, value, fragment", [
    ("--std-eigenvalue", "0.01,0.02", "--std-eigenvalue: 2 values given, but the test data hold 3 test modes"),
    ("--std-shape", "0.01,0.02,0.03,0.04", "--std-shape: 4 values given, but the test data hold 3 test modes"),
    ("--std-eigenvalue", "-0.01", "--std-eigenvalue: -0.01 is not > 0"),
    ("--std-shape", "0.01,-0.02,0.03", "--std-shape: -0.02 is not > 0"),
    ("--std-shape", "0.01,0,0.03", "--std-shape: 0 is not > 0"),
    ("--std-eigenvalue", "0.01,abc,0.03", "--std-eigenvalue: 'abc' is not a number"),
    ("--std-eigenvalue", "0.01,,0.03", "--std-eigenvalue: empty value"),
    ("--std-eigenvalue", "0.01,inf,0.03", "--std-eigenvalue: 'inf' is not a finite number"),
])
def test_cli_bad_std_lists_exit_2_with_one_line(tmp_path, capsys, option, value, fragment):
    plain, _ = files(tmp_path)
    code, out, err = _cli(["update", _model_file(tmp_path), plain, option, value], capsys)
    assert code == 2
    assert "Traceback" not in err
    assert err.count("\n") == 1 and err.startswith("femupdate: error: ") and fragment in err, err


def test_cli_file_with_bad_or_partial_per_mode_values(tmp_path, capsys):
    plain, _ = files(tmp_path)
    raw = json.loads(plain.read_text())
    raw["modes"][1]["std_frequency"] = -0.5
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps(raw))
    code, _, err = _cli(["update", _model_file(tmp_path), bad], capsys)
    assert code == 2 and err.strip() == f"femupdate: error: {bad}: modes[2] std_frequency: -0.5 is not > 0"
    raw["modes"][1]["std_frequency"] = 0.01
    bad.write_text(json.dumps(raw))
    code, _, err = _cli(["update", _model_file(tmp_path), bad], capsys)
    assert code == 2 and err.count("\n") == 1 and "but not for test modes 1, 3" in err, err
    code, _, err = _cli(["update", _model_file(tmp_path), bad, "--std-eigenvalue", "0.01"], capsys)
    assert code == 0, err
