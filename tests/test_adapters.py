"""Identification libraries' results in, updated model out (femupdate.io.adapters).

The end-to-end tests simulate the measurement in the test itself (nothing downloaded): femupdate's
own spring-mass chain at its true stiffnesses gives (a) the response to random (ambient) forces,
which pyOMA2 identifies by covariance-driven SSI with its uncertainty propagation, and (b) FRFs with
Rayleigh damping and noise, which sdypy-EMA identifies by LSCF poles and LSFD modal constants.  The
adapters turn the results into test data, and updating a perturbed model must recover the true
stiffnesses within the scatter that the identification errors explain (the update's covariance,
built from the stated standard deviations or the residual).  They are skipped, saying why, where a
library is missing; the test extra installs both, so they run in CI.
"""

from __future__ import annotations

import json
import logging
import re

import numpy as np
import pytest
from scipy.linalg import expm

from femupdate import InputError, model_modes, update
from femupdate.cli import main
from femupdate.examples import chain
from femupdate.frf import Damping, simulate
from femupdate.io.adapters import channel_map, from_pyoma2, from_sdypy_ema, modal_test_data, read_identification

K = np.array([1.0e5, 1.8e5, 1.5e5, 1.2e5])  # N/m: modes at 19.5, 53.1, 93.2 and 116.1 Hz
M = np.array([1.0, 1.2, 0.8, 1.1])  # kg
START = np.array([0.85, 1.15, 0.9, 1.1])  # the model to update starts 10-15 % off
DOFS = ("1:x", "2:x", "3:x", "4:x")


def truth():
    return chain(K, M, bounds=(1e4, 1e6))


def start_model():
    return chain(K * START, M, bounds=(1e4, 1e6))


def ambient_response(zeta=0.02, fs=400.0, seconds=120.0, noise=0.02, seed=0):
    """Displacements of the true chain under independent white-noise forces at every mass, with
    modal damping ``zeta`` in every mode, sampled exactly (zero-order hold on the forces), plus
    measurement noise of ``noise`` x each channel's RMS."""
    model = truth()
    Kd, Md = model.K(model.values).toarray(), model.M(model.values).toarray()
    mm = model_modes(model)  # mass-normalised: C = M Phi diag(2 zeta w) Phi^T M
    C = Md @ mm.shapes @ np.diag(2 * zeta * np.sqrt(mm.eigenvalues)) @ mm.shapes.T @ Md
    n = Kd.shape[0]
    A = np.block([[np.zeros((n, n)), np.eye(n)], [-np.linalg.solve(Md, Kd), -np.linalg.solve(Md, C)]])
    B = np.vstack([np.zeros((n, n)), np.linalg.inv(Md)])
    Ad = expm(A / fs)
    Bd = np.linalg.solve(A, Ad - np.eye(2 * n)) @ B
    rng = np.random.default_rng(seed)
    steps = int(fs * seconds)
    F = rng.standard_normal((steps, n))
    x = np.zeros(2 * n)
    Y = np.empty((steps, n))
    for i in range(steps):
        x = Ad @ x + Bd @ F[i]
        Y[i] = x[:n]
    Y += noise * Y.std(axis=0) * rng.standard_normal(Y.shape)
    return Y, fs


# ---------------------------------------------------------------------------------- pyOMA2
def test_pyoma2_ssi_result_updates_a_model_end_to_end():
    pytest.importorskip("pyoma2", reason="pyOMA2 is not installed (pip install 'femupdate[oma]')")
    from pyoma2.algorithms import SSI
    from pyoma2.setup import SingleSetup

    logging.getLogger("pyoma2").setLevel(logging.WARNING)
    Y, fs = ambient_response()
    Y[:, 1] *= -1  # the sensor at 2:x points along -x: the channel map says so
    setup = SingleSetup(Y, fs)
    setup.add_algorithms(SSI(name="ssi", method="cov", br=12, ordmax=16, calc_unc=True))
    setup.run_all()
    true_modes = model_modes(truth())
    setup.mpe("ssi", sel_freq=list(true_modes.frequencies_hz), order_in=16)  # an order where all four are stable
    res = setup["ssi"].result

    data = from_pyoma2(setup["ssi"], channels=["1:x", "-2:x", "3:x", "4:x"])
    assert len(data.modes) == 4
    # the identification's errors are those its standard deviations state (within 4 sigma)
    f_err = data.frequencies_hz - true_modes.frequencies_hz
    assert np.all(np.abs(f_err) < 4 * res.Fn_std), (f_err, res.Fn_std)
    assert np.all(np.abs(data.damping_ratios - 0.02) < 4 * res.Xi_std + 1e-12), (data.damping_ratios, res.Xi_std)
    for k, m in enumerate(data.modes):  # stds carried: relative eigenvalue std = 2 sigma_f / f
        assert m.std_eigenvalue == pytest.approx(2 * res.Fn_std[k] / res.Fn[k], rel=1e-12)
        assert m.std_damping_ratio == pytest.approx(res.Xi_std[k], rel=1e-12)
        assert m.std_shape is not None and m.std_shape > 0
        # the sign of the -x sensor is undone: the shape correlates with the truth at MAC ~ 1
        truth_shape = true_modes.shapes[:, k]
        re = np.real(m.shape * np.exp(-1j * np.angle(m.shape[np.argmax(np.abs(m.shape))])))
        assert abs(re @ truth_shape) / np.linalg.norm(re) / np.linalg.norm(truth_shape) > 0.99

    result = update(start_model(), data)
    assert result.success
    p = np.array([result.parameters[f"k{j}"] for j in range(1, 5)])
    std = np.array([result.diagnostics.std[j] for j in range(4)])
    # tolerance from the identification error: the covariance that the adapter's stds give
    assert np.all(np.abs(p - K) < 4 * std), (p / K - 1, std / K)
    assert np.all(np.abs(p / K - 1) < 0.03), p / K - 1  # and the stds are not vacuous
    assert np.all(np.abs(START - 1) > 0.05)  # the start was far from the truth


# ---------------------------------------------------------------------------------- sdypy-EMA
def test_sdypy_ema_lscf_result_updates_a_model_end_to_end():
    pytest.importorskip("sdypy.EMA", reason="sdypy-EMA is not installed (pip install 'femupdate[ema]')")
    from sdypy import EMA

    damping = Damping(alpha=2.0, beta=5e-5)  # Rayleigh: zeta 1.1 %, 1.1 %, 1.6 %, 1.9 % at the four modes
    f_hz = np.arange(4.0, 160.0, 0.25)
    clean = simulate(truth(), 2 * np.pi * f_hz, {"4:x": 1.0}, damping=damping)
    rng = np.random.default_rng(2)
    H = clean.response * (1 + 0.01 * (rng.standard_normal(clean.response.shape)
                                      + 1j * rng.standard_normal(clean.response.shape)) / np.sqrt(2))
    true_modes = model_modes(truth())
    ema = EMA.Model(frf=H.T, freq=f_hz, lower=f_hz[0], upper=f_hz[-1], pol_order_high=30, frf_form="receptance",
                    driving_point=3)
    ema.get_poles(show_progress=False)
    ema.select_closest_poles(list(true_modes.frequencies_hz), f_window=20)
    ema.get_constants()

    data = from_sdypy_ema(ema, channels=list(clean.dofs))
    assert len(data.modes) == 4 and all(m.std_eigenvalue is None for m in data.modes)
    f_rel = data.frequencies_hz / true_modes.frequencies_hz - 1
    assert np.all(np.abs(f_rel) < 2e-3), f_rel
    # the identified damping is the Rayleigh damping's modal ratio at each mode (a second route)
    zeta_model = damping.modal_damping_ratio(np.sqrt(true_modes.eigenvalues))
    assert np.allclose(data.damping_ratios, zeta_model, rtol=0.05), (data.damping_ratios, zeta_model)

    result = update(start_model(), data)
    assert result.success
    p = np.array([result.parameters[f"k{j}"] for j in range(1, 5)])
    std = np.array([result.diagnostics.std[j] for j in range(4)])  # from the residual: no stated stds
    assert np.all(np.abs(p - K) < 4 * std + 1e-9 * K), (p / K - 1, std / K)
    assert np.all(np.abs(p / K - 1) < 0.02), p / K - 1


# ---------------------------------------------------------------------------------- files and maps
def pyoma2_arrays():
    """A result with pyOMA2's attribute names, built from the true modes (no library needed)."""
    mm = model_modes(truth())
    phi = mm.shapes / mm.shapes[np.argmax(np.abs(mm.shapes), axis=0), np.arange(4)]
    return {"Fn": mm.frequencies_hz, "Phi": phi.astype(complex), "Xi": np.full(4, 0.02),
            "Fn_std": 0.001 * mm.frequencies_hz, "Xi_std": np.full(4, 0.002), "Phi_std": np.full((4, 4), 0.01)}


def test_a_saved_result_updates_from_the_command_line_and_converts(tmp_path, capsys):
    arrays = pyoma2_arrays()
    np.savez(tmp_path / "ssi.npz", channels=np.array(["1:x", "-2:x", "3:x", ""]),
             **dict(arrays, Phi=arrays["Phi"] * np.array([1, -1, 1, 1])[:, None]))
    model = tmp_path / "chain.toml"
    model.write_text(chain_toml(K * START))
    out = tmp_path / "r.json"
    with pytest.raises(SystemExit) as e:
        main(["update", str(model), str(tmp_path / "ssi.npz"), "--json", str(out)])
    assert e.value.code == 0
    got = json.loads(out.read_text())
    assert np.allclose([got["parameters"][f"k{j}"] for j in range(1, 5)], K, rtol=1e-6)
    assert got["damping_ratio"]["test"] == pytest.approx([0.02] * 4)
    # one pairing everywhere: correlate at the updated values pairs the identified modes as update did
    values = ",".join(f"{k}={v!r}" for k, v in got["parameters"].items())
    with pytest.raises(SystemExit) as e:
        main(["correlate", str(model), str(tmp_path / "ssi.npz"), "--set", values, "--json", str(tmp_path / "c.json")])
    assert e.value.code == 0
    corr = json.loads((tmp_path / "c.json").read_text())
    assert [p[:2] for p in corr["pairs"]] == [p[:2] for p in got["pairs"]] == [[k, k] for k in range(4)]
    with pytest.raises(SystemExit) as e:
        main(["convert-data", str(tmp_path / "ssi.npz"), str(tmp_path / "test.json"), "--model", str(model)])
    assert e.value.code == 0
    written = json.loads((tmp_path / "test.json").read_text())
    assert [list(m["shape"]) for m in written["modes"]] == [["1:x", "2:x", "3:x"]] * 4
    assert written["modes"][0]["std_eigenvalue"] == pytest.approx(0.002)
    assert written["modes"][0]["damping_ratio"] == 0.02
    # the JSON reads back to the same data as the .npz
    a = read_identification(tmp_path / "ssi.npz")
    from femupdate.io.testdata_json import load_testdata

    b = load_testdata(tmp_path / "test.json")
    for ma, mb in zip(a.modes, b.modes):
        assert mb.eigenvalue == pytest.approx(ma.eigenvalue, rel=1e-14)
        assert np.allclose(mb.shape, ma.shape, rtol=0, atol=1e-15)
        assert (mb.std_eigenvalue, mb.std_shape, mb.damping_ratio, mb.std_damping_ratio) == \
            (ma.std_eigenvalue, ma.std_shape, ma.damping_ratio, ma.std_damping_ratio)


def chain_toml(k) -> str:
    lines = ["[model]", 'name = "chain"']
    for j, v in enumerate(k, start=1):
        lines += [f"[parameters.k{j}]", f"value = {float(v)!r}", "bounds = [1.0e4, 1.0e6]"]
    prev = None
    for j in range(1, 5):
        dofs = f'["{j}:x"]' if prev is None else f'["{prev}", "{j}:x"]'
        lines += ["[[element]]", 'type = "spring"', f"dofs = {dofs}", f'k = "k{j}"',
                  "[[element]]", 'type = "mass"', f'dofs = ["{j}:x"]', f"m = {float(M[j - 1])!r}"]
        prev = f"{j}:x"
    return "\n".join(lines) + "\n"


def test_channel_maps_by_list_index_and_name():
    by_list = channel_map(["1:x", "", "-3:x"], 3)
    assert by_list == [(0, "1:x", 1.0), (2, "3:x", -1.0)]
    assert channel_map({2: "-3:x", 0: "1:x"}, 3) == by_list
    assert channel_map({"c3": "-3:x", "c1": "1:x"}, 3, channel_names=["c1", "c2", "c3"]) == by_list
    assert channel_map(["#1", "#3"], 2, dofs=DOFS) == [(0, "1:x", 1.0), (1, "3:x", 1.0)]


@pytest.mark.parametrize("channels, names, fragment", [
    (["1:x", "2:x"], None, "2 entries for 3 channels"),
    ({5: "1:x"}, None, "channel 5 is out of range"),
    ({"c9": "1:x"}, ["c1", "c2", "c3"], "'c9' is neither"),
    (["1:x", "1:x", ""], None, "channels 0 and 1 both measure 1:x"),
    (["", "", ""], None, "no channel is mapped"),
    (["1:x", "2:q", ""], None, "channel 1"),
    ("1:x,2:x,3:x", None, "expected one dof per channel"),
])
def test_bad_channel_maps_are_refused_by_name(channels, names, fragment):
    with pytest.raises(InputError, match=fragment):
        channel_map(channels, 3, channel_names=names)


def test_standard_deviations_missing_for_some_modes_are_noted_not_invented():
    arrays = pyoma2_arrays()
    arrays["Fn_std"][2] = np.nan
    data = modal_test_data(arrays["Fn"], arrays["Phi"], list(DOFS), frequency_std_hz=arrays["Fn_std"])
    assert [m.std_eigenvalue is None for m in data.modes] == [False, False, True, False]
    assert any("mode(s) 3" in n for n in data.notes)
    with pytest.raises(InputError, match="std_frequency or std_eigenvalue for test modes 1, 2, 4 but not for test mode 3"):
        update(start_model(), data)


@pytest.mark.parametrize("content, fragment", [
    ({"Fn": [1.0]}, "no 'channels' array"),
    ({"x": [1.0], "channels": np.array(["1:x"])}, "neither a pyOMA2 result"),
    ({"Fn": [1.0, np.nan], "Phi": np.ones((1, 2)), "channels": np.array(["1:x"])}, r"mode\(s\) 2 is not finite"),
    ({"Fn": [1.0], "Phi": np.ones((2, 2)), "channels": np.array(["1:x", "2:x"])}, r"expected \(channels, 1 modes\)"),
    ({"Fn": [1.0], "Phi": np.ones((2, 1)), "Xi": [1.5], "channels": np.array(["1:x", "2:x"])}, None),
    ({"nat_freq": [1.0], "channels": np.array([1.0])}, "'channels' must be strings"),
])
def test_saved_results_refused_by_name(tmp_path, content, fragment):
    np.savez(tmp_path / "r.npz", **content)
    if fragment is None:  # a damping ratio out of [0, 1) is left out with a note, not used
        data = read_identification(tmp_path / "r.npz")
        assert data.modes[0].damping_ratio is None and any("not in [0, 1)" in n for n in data.notes)
        return
    with pytest.raises(InputError, match=fragment):
        read_identification(tmp_path / "r.npz")


def test_object_arrays_are_not_unpickled(tmp_path, capsys):
    np.savez(tmp_path / "o.npz", Fn=np.array([{"a": 1}], dtype=object))
    with pytest.raises(SystemExit) as e:
        main(["convert-data", str(tmp_path / "o.npz"), str(tmp_path / "o.json")])
    assert e.value.code == 2
    assert "does not unpickle" in capsys.readouterr().err
    with pytest.raises(SystemExit) as e:
        main(["convert-data", str(tmp_path / "o.npz"), str(tmp_path / "o.json"), "--channels", "1:x,2:x"])
    assert e.value.code == 2
    np.savez(tmp_path / "p.npz", **pyoma2_arrays())
    with pytest.raises(SystemExit) as e:
        main(["convert-data", str(tmp_path / "p.npz"), str(tmp_path / "o.json"), "--channels", "1:x,2:x"])
    assert e.value.code == 2
    assert "--channels: 2 entries for 4 channels" in capsys.readouterr().err
    assert not (tmp_path / "o.json").exists()


# ---------------------------------------------------------------------------------- hostile input
@pytest.mark.parametrize("key, value, fragment", [
    ("Fn", np.array(["19.5", "53.1", "93.2", "116.1"]), r"r.npz: Fn: expected numbers, got text \('19.5'"),
    ("Phi", np.full((4, 4), "a"), "r.npz: Phi: expected numbers, got text"),
    ("Xi", np.array(["x"] * 4), "r.npz: Xi: expected numbers"),
    ("Fn_std", np.array(["x"] * 4), "r.npz: Fn_std: expected numbers"),
    ("Phi_std", np.full((4, 4), "a"), "r.npz: Phi_std: expected numbers"),
    ("Fn", np.array([19.5, 53.1, 93.2, 116.1]) * (1 + 0.1j), "r.npz: Fn: complex values; expected real numbers"),
    ("Xi", np.full(4, 0.02 + 0.01j), "r.npz: Xi: complex values"),
    ("Fn", np.ones(4, dtype=bool), r"r.npz: Fn: booleans \(True/False\), not numbers"),
    ("Phi", np.ones((4, 4), dtype=bool), "r.npz: Phi: booleans"),
])
def test_arrays_that_are_not_numbers_are_refused_by_key(tmp_path, capsys, key, value, fragment):
    """Text, booleans or complex frequencies in a saved result: before, a traceback (text), the
    imaginary part dropped with NumPy's warning (Fn) or |Xi| taken, or True read as 1 Hz."""
    arrays = dict(pyoma2_arrays(), **{key: value})
    np.savez(tmp_path / "r.npz", channels=np.array(DOFS), **arrays)
    with pytest.raises(InputError, match=fragment):
        read_identification(tmp_path / "r.npz")
    with pytest.raises(SystemExit) as e:
        main(["convert-data", str(tmp_path / "r.npz"), str(tmp_path / "o.json")])
    err = capsys.readouterr().err
    assert e.value.code == 2 and "Traceback" not in err and "Warning" not in err
    assert not (tmp_path / "o.json").exists()


@pytest.mark.parametrize("content, fragment", [
    (b"hello, not a result", r"not a \.npz file of arrays \(not a zip archive\)"),
    (b"", r"\(an empty file\)"),
    (None, r"\(one array saved with numpy\.save \(\.npy\)\)"),
])
def test_files_that_are_no_npz_archive_are_named_for_what_they_are(tmp_path, content, fragment):
    """A text file used to be refused as 'an array of Python objects' (np.load tried to unpickle it)."""
    path = tmp_path / "r.npz"
    if content is None:
        with open(path, "wb") as fh:
            np.save(fh, np.ones(3))
    else:
        path.write_bytes(content)
    with pytest.raises(InputError, match=fragment):
        read_identification(path)


@pytest.mark.parametrize("entry", ["--2:x", "+-2:x", "-"])
def test_a_channel_with_two_signs_or_a_sign_alone_is_refused_as_written(entry):
    """'--2:x' was read as a sensor along -x (both signs stripped, one applied)."""
    with pytest.raises(InputError, match=re.escape(f"channel 1: '{entry}' is not a dof label with at most one sign")):
        channel_map(["1:x", entry, "3:x"], 3)


def test_a_files_own_channel_map_is_named_with_the_file(tmp_path, capsys):
    np.savez(tmp_path / "r.npz", channels=np.array(["1:x", "1:x", "3:x", "4:x"]), **pyoma2_arrays())
    with pytest.raises(InputError, match=r"r\.npz: channels: channels 0 and 1 both measure 1:x"):
        read_identification(tmp_path / "r.npz")
    np.savez(tmp_path / "n.npz", channels=np.array(DOFS), channel_names=np.array(["a", "b"]), **pyoma2_arrays())
    with pytest.raises(InputError, match=r"n\.npz: channel_names: 2 names for 4 channels"):
        read_identification(tmp_path / "n.npz")
    with pytest.raises(SystemExit):  # a map given on the command line is named as the option
        main(["convert-data", str(tmp_path / "r.npz"), str(tmp_path / "o.json"), "--channels", "1:x,1:x,3:x,4:x"])
    assert "error: --channels: channels 0 and 1 both measure 1:x" in capsys.readouterr().err


def test_negative_zero_and_huge_shape_standard_deviations(tmp_path):
    """A negative Phi_std was taken by its magnitude; a zero one was noted as 'not finite'; a
    huge one overflowed with NumPy's warning before it was refused."""
    arrays = pyoma2_arrays()
    phi_std = arrays["Phi_std"].copy()
    phi_std[:, 1] = -0.01
    fn_std = arrays["Fn_std"].copy()
    fn_std[2] = 0.0
    data = modal_test_data(arrays["Fn"], arrays["Phi"], list(DOFS), frequency_std_hz=fn_std, shape_std=phi_std)
    assert [m.std_shape is None for m in data.modes] == [False, True, False, False]
    assert [m.std_eigenvalue is None for m in data.modes] == [False, False, True, False]
    assert any("no finite positive shape standard deviation for mode(s) 2" in n for n in data.notes)
    assert any("no finite positive frequency standard deviation for mode(s) 3" in n for n in data.notes)
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(InputError, match=r"std_shape: .* is outside \[1e-150, 1e\+150\]"):
            modal_test_data(arrays["Fn"], arrays["Phi"], list(DOFS), shape_std=np.full((4, 4), 1e200))


def test_objects_that_are_no_library_result_are_named():
    class Ragged:
        Fn = [[1.0, 2.0], [3.0]]
        Phi = None

    with pytest.raises(InputError, match="pyOMA2: expected a pyOMA2 result .* got object"):
        from_pyoma2(object(), list(DOFS))
    with pytest.raises(InputError, match="pyOMA2: Fn: not an array of numbers"):
        from_pyoma2(Ragged(), list(DOFS))
    with pytest.raises(InputError, match="sdypy-EMA: expected an sdypy-EMA Model .* got dict"):
        from_sdypy_ema({"nat_freq": [1.0]}, list(DOFS))
    with pytest.raises(InputError, match="identification: shapes: expected numbers, got Python objects"):
        modal_test_data([1.0], [[{}]], ["1:x"])


def test_the_identification_extras_install_their_library_alone():
    """The merge of the report work put the browser test's websocket-client into the 'ema' extra."""
    import tomllib
    from pathlib import Path

    extras = tomllib.loads((Path(__file__).resolve().parents[1] / "pyproject.toml").read_text())["project"][
        "optional-dependencies"]
    names = {k: [re.split(r"[<>=\[ ]", r)[0].lower() for r in v] for k, v in extras.items()}
    assert names["oma"] == ["pyoma-2"] and names["ema"] == ["sdypy-ema"]
    assert "websocket-client" in names["test"]


def test_convert_data_does_not_write_over_its_source(tmp_path, capsys):
    """convert-data r.npz r.npz wrote the JSON over the identification result it read."""
    np.savez(tmp_path / "r.npz", channels=np.array(DOFS), **pyoma2_arrays())
    before = (tmp_path / "r.npz").read_bytes()
    for args in (["r.npz", "r.npz"], ["r.npz", "o.json", "--json", "r.npz"], ["r.npz", "./sub/../r.npz"]):
        (tmp_path / "sub").mkdir(exist_ok=True)
        with pytest.raises(SystemExit) as e:
            main(["convert-data", *[a if a.startswith("-") else str(tmp_path / a) for a in args]])
        assert e.value.code == 2 and "is the input SOURCE" in capsys.readouterr().err  # femupdate.io.outputs
        assert (tmp_path / "r.npz").read_bytes() == before
