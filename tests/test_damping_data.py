"""Damping ratios and the other spellings of per-mode standard deviations in the test data: read
from JSON and universal files, refused by name when wrong, compared with the model's modal damping
(checked against the damped model's complex eigenvalues, an independent route), fitted by Rayleigh
damping and used for FRFs (``--damping fit``)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from femupdate import InputError, model_modes
from femupdate.cli import main
from femupdate.examples import two_dof, write_example_files
from femupdate.frf import Damping
from femupdate.io.testdata_json import parse_testdata

MODES = [{"frequency_hz": 0.14, "shape": {"1:x": 0.5, "2:x": 1.0}},
         {"frequency_hz": 0.44, "shape": {"1:x": 1.0, "2:x": -0.4}}]


def run(args, capsys):
    with pytest.raises(SystemExit) as e:
        main([str(a) for a in args])
    out, err = capsys.readouterr()
    return e.value.code, out, err


def test_the_issue_spelling_is_the_same_key():
    a = parse_testdata({"modes": [dict(MODES[0], std_frequency=0.01, std_shape=0.02, damping_ratio=0.03,
                                       std_damping_ratio=0.004)]})
    b = parse_testdata({"modes": [dict(MODES[0], frequency_std=0.01, shape_std=0.02, damping_ratio=0.03,
                                       damping_ratio_std=0.004)]})
    ma, mb = a.modes[0], b.modes[0]
    for key in ("eigenvalue", "dofs", "label", "std_eigenvalue", "std_shape", "damping_ratio", "std_damping_ratio"):
        assert getattr(ma, key) == getattr(mb, key), key
    assert (mb.std_eigenvalue, mb.std_shape, mb.damping_ratio, mb.std_damping_ratio) == (0.02, 0.02, 0.03, 0.004)


@pytest.mark.parametrize("extra, message", [
    ({"std_frequency": 0.01, "frequency_std": 0.01}, "give std_frequency or frequency_std (two spellings of one key), not both"),
    ({"std_shape": 0.01, "shape_std": 0.02}, "give std_shape or shape_std"),
    ({"frequency_std": -0.01}, "modes[1] frequency_std: -0.01 is not > 0"),
    ({"frequency_std": 0.01, "std_eigenvalue": 0.02}, "give at most one of frequency_std or std_eigenvalue"),
    ({"damping_ratio": 1.2}, "modes[1] damping_ratio: 1.2 is not a damping ratio in [0, 1)"),
    ({"damping_ratio": -0.01}, "is not a damping ratio"),
    ({"damping_ratio": "0.02"}, "modes[1] damping_ratio: expected a number"),
    ({"damping_ratio_std": 0.01}, "modes[1]: damping_ratio_std is given without damping_ratio"),
    ({"std_damping_ratio": 0.01}, "modes[1]: std_damping_ratio is given without damping_ratio"),
])
def test_bad_keys_are_refused_as_written(extra, message):
    with pytest.raises(InputError) as e:
        parse_testdata({"modes": [dict(MODES[0], **extra)]})
    assert message in str(e.value)


def test_modal_damping_ratio_equals_the_damped_models_complex_eigenvalues():
    """ζ = α/2ω + βω/2 against -Re(s)/|s| of the state-space eigenvalues with C = αM + βK."""
    model = two_dof()
    K, M = model.K(model.values).toarray(), model.M(model.values).toarray()
    d = Damping(alpha=0.05, beta=0.02)
    C = d.alpha * M + d.beta * K
    A = np.block([[np.zeros((2, 2)), np.eye(2)], [-np.linalg.solve(M, K), -np.linalg.solve(M, C)]])
    s = np.linalg.eigvals(A)
    s = s[s.imag > 0]
    s = s[np.argsort(np.abs(s))]
    zeta_eig = -s.real / np.abs(s)
    omega = np.sqrt(model_modes(model).eigenvalues)
    assert np.allclose(d.modal_damping_ratio(omega), zeta_eig, rtol=1e-12)
    assert np.allclose(np.abs(s), omega, rtol=1e-12)  # |s| is the undamped frequency (what the libraries report)


def test_rayleigh_fit_recovers_the_damping_that_made_the_ratios():
    d = Damping(alpha=1.5, beta=3e-4)
    w = 2 * np.pi * np.array([5.0, 17.0, 40.0, 71.0])
    fit, resid = Damping.rayleigh_fit(w, d.modal_damping_ratio(w))
    assert fit.alpha == pytest.approx(1.5, rel=1e-10) and fit.beta == pytest.approx(3e-4, rel=1e-10)
    assert np.max(np.abs(resid)) < 1e-14
    with pytest.raises(InputError, match="Rayleigh fit"):
        Damping.rayleigh_fit([0.0], [0.01])


def test_universal_file_damping(tmp_path):
    pyuff = pytest.importorskip("pyuff")
    from femupdate.io.uff import read_uff

    path = tmp_path / "m.uff"
    u = pyuff.UFF(str(path))
    common = dict(model_type=1, id1="t", data_ch=2, spec_data_type=8, n_data_per_node=3, load_case=1,
                  node_nums=np.array([1, 2]))
    u.write_sets(pyuff.prepare_55(analysis_type=2, data_type=2, r1=np.array([1.0, 0.5]), r2=np.zeros(2),
                                  r3=np.zeros(2), mode_n=1, freq=10.0, modal_m=1.0, modal_damp_vis=0.02,
                                  modal_damp_his=0.0, **common), mode="overwrite")
    u.write_sets(pyuff.prepare_55(analysis_type=2, data_type=2, r1=np.array([1.0, -0.5]), r2=np.zeros(2),
                                  r3=np.zeros(2), mode_n=2, freq=20.0, modal_m=1.0, modal_damp_vis=0.0,
                                  modal_damp_his=0.04, **common), mode="add")
    wn, zeta = 2 * np.pi * 30.0, 0.03
    s = -zeta * wn + 1j * wn * np.sqrt(1 - zeta ** 2)
    u.write_sets(pyuff.prepare_55(analysis_type=3, data_type=5, r1=np.array([1.0, 0.2]) + 0j, r2=np.zeros(2) + 0j,
                                  r3=np.zeros(2) + 0j, mode_n=3, eig=s, modal_a=0j, modal_b=0j, **common), mode="add")
    data = read_uff(path)
    assert data.modes[0].damping_ratio == pytest.approx(0.02)
    assert data.modes[1].damping_ratio is None  # a hysteretic value alone is not converted
    assert any("hysteretic damping value 0.04 is not read" in n for n in data.notes)
    assert data.modes[2].damping_ratio == pytest.approx(zeta, rel=1e-5)  # the file keeps ~6 digits
    assert data.modes[2].frequency_hz == pytest.approx(30.0, rel=1e-5)


def test_universal_file_nan_damping_is_refused_not_dropped(tmp_path):
    """A NaN viscous damping ratio was read as 'not stated', without a word."""
    pyuff = pytest.importorskip("pyuff")
    from femupdate.io.uff import read_uff

    path = tmp_path / "m.uff"
    pyuff.UFF(str(path)).write_sets(pyuff.prepare_55(
        analysis_type=2, data_type=2, r1=np.array([1.0, 0.5]), r2=np.zeros(2), r3=np.zeros(2), mode_n=1, freq=10.0,
        modal_m=1.0, modal_damp_vis=float("nan"), modal_damp_his=0.0, model_type=1, id1="t", data_ch=2,
        spec_data_type=8, n_data_per_node=3, load_case=1, node_nums=np.array([1, 2])), mode="overwrite")
    with pytest.raises(InputError, match=r"m\.uff: dataset 55 record 1: viscous damping ratio nan is not a finite"):
        read_uff(path)


@pytest.fixture(scope="module")
def ex(tmp_path_factory):
    d = tmp_path_factory.mktemp("ex")
    write_example_files(d)
    return d


def test_correlate_and_update_report_damping(ex, tmp_path, capsys):
    """The two-dof example's modes with damping ratios made by a known Rayleigh damping: the table
    and JSON compare them with --damping's modal ratios; the fit gives the damping back."""
    true = Damping(alpha=0.02, beta=0.03)
    mm = model_modes(two_dof())
    zeta = true.modal_damping_ratio(np.sqrt(mm.eigenvalues))
    data = {"modes": [{"eigenvalue": float(lam), "shape": {"1:x": float(mm.shapes[0, r]), "2:x": float(mm.shapes[1, r])},
                       "damping_ratio": float(zeta[r]), "std_damping_ratio": 0.001}
                      for r, lam in enumerate(mm.eigenvalues)]}
    (tmp_path / "d.json").write_text(json.dumps(data))
    code, out, _ = run(["correlate", ex / "two_dof.toml", tmp_path / "d.json", "--set", "k1=8,k2=6",
                        "--damping", "alpha=0.02,beta=0.03", "--json", tmp_path / "c.json"], capsys)
    assert code == 0 and "modal damping ratios" in out and "alpha=0.02" in out
    got = json.loads((tmp_path / "c.json").read_text())["damping_ratio"]
    assert np.allclose(got["model"], zeta, rtol=1e-12) and np.allclose(got["test"], zeta)
    assert got["rayleigh_fit"]["alpha"] == pytest.approx(0.02, rel=1e-8)
    assert got["rayleigh_fit"]["beta"] == pytest.approx(0.03, rel=1e-8)
    code, out, _ = run(["update", ex / "two_dof.toml", tmp_path / "d.json", "--damping", "eta=0.02",
                        "--json", tmp_path / "u.json", "--csv", tmp_path], capsys)
    assert code == 0
    got = json.loads((tmp_path / "u.json").read_text())["damping_ratio"]
    assert got["model"] == pytest.approx([0.01, 0.01]) and got["model_damping"]["eta"] == 0.02
    assert (tmp_path / "modes.csv").read_text().splitlines()[0].endswith("damping_test,damping_test_std,damping_model")
    # data without damping and no --damping: no key, no table (the recorded outputs are unchanged)
    code, out, _ = run(["correlate", ex / "two_dof.toml", ex / "two_dof_frequencies.json", "--json", tmp_path / "n.json"],
                       capsys)
    assert "damping_ratio" not in json.loads((tmp_path / "n.json").read_text()) and "damping" not in out


def damped_frf_file(path):
    """Test data of the two-dof system with Rayleigh damping alpha=0.02, beta=0.03: its modes with
    their damping ratios and its receptances at 7 lines (exact)."""
    true = Damping(alpha=0.02, beta=0.03)
    model = two_dof()
    mm = model_modes(model)
    zeta = true.modal_damping_ratio(np.sqrt(mm.eigenvalues))
    from femupdate.frf import simulate

    w = 0.4 * np.arange(1, 8)
    frf = simulate(model, w, {"1:x": 1.0}, damping=true)
    data = {"modes": [{"eigenvalue": float(lam), "damping_ratio": float(zeta[r])} for r, lam in enumerate(mm.eigenvalues)],
            "frf": {"omega_rad_s": list(w), "force": {"1:x": 1.0},
                    "response": {d: [[float(v.real), float(v.imag)] for v in frf.response[:, j]]
                                 for j, d in enumerate(frf.dofs)}}}
    path.write_text(json.dumps(data))


def test_damping_fit_is_the_fitted_rayleigh_damping_for_frfs(ex, tmp_path, capsys):
    """frf-update --damping fit on a file holding FRFs and damped modes equals --damping with the
    fitted coefficients written out."""
    damped_frf_file(tmp_path / "f.json")
    code, _, err = run(["frf-update", ex / "two_dof.toml", tmp_path / "f.json", "--damping", "fit",
                        "--json", tmp_path / "a.json"], capsys)
    assert code == 0, err
    code, _, err = run(["frf-update", ex / "two_dof.toml", tmp_path / "f.json", "--damping", "alpha=0.02,beta=0.03",
                        "--json", tmp_path / "b.json"], capsys)
    a = json.loads((tmp_path / "a.json").read_text())["parameters"]
    b = json.loads((tmp_path / "b.json").read_text())["parameters"]
    assert a["k1"] == pytest.approx(b["k1"], rel=1e-7) and a["k1"] == pytest.approx(8.0, rel=1e-6)
    code, _, err = run(["frf-update", ex / "two_dof.toml", ex / "two_dof_frf.json", "--damping", "fit"], capsys)
    assert code == 2 and "--damping fit: fits Rayleigh damping to the test modes' damping ratios and needs two or " \
                         "more; the test data give 0" in err


def test_surface_takes_damping_fit_and_commands_without_test_data_say_so(ex, tmp_path, capsys):
    """surface reads test data but refused --damping fit with 'the test data give 0' whatever the
    data held; frf, which reads none, said the same."""
    damped_frf_file(tmp_path / "f.json")
    grid = ["--params", "k1,k2", "--x", "6:10:5", "--y", "4:8:5"]
    outs = []
    for damping in ("fit", "alpha=0.02,beta=0.03"):
        code, _, err = run(["surface", ex / "two_dof.toml", tmp_path / "f.json", *grid, "--damping", damping,
                            "--json", tmp_path / "s.json"], capsys)
        assert code == 0, err
        outs.append(json.loads((tmp_path / "s.json").read_text()))
    a, b = (np.array(o["values"], float) for o in outs)
    np.testing.assert_allclose(a, b, rtol=1e-6, atol=1e-30)
    assert outs[0]["minimum"]["k1"] == 8 and outs[0]["minimum"]["k2"] == 6  # the truth, on the grid
    assert a.min() < 1e-20  # the fitted damping is the true one
    code, _, err = run(["frf", ex / "two_dof.toml", "--force", "1:x", "--omega", "1,2", "--damping", "fit"], capsys)
    assert code == 2 and "--damping fit: fits Rayleigh damping to the test modes' damping ratios, and this command " \
                         "reads no test data" in err
