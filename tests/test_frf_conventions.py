"""FRFs as analysers export them: a frequency axis in Hz, a 0 Hz line (the DC bin) skipped with a
note, a dead (all-zero) channel left out with a note whatever the residual."""

import json
import math

import numpy as np
import pytest

from femupdate import InputError
from femupdate.examples import two_dof
from femupdate.frf import frf as model_frf
from femupdate.io.testdata_json import parse_testdata
from femupdate.updating import frf_update

TRUE = {"k1": 8.0, "k2": 6.0}


def frf_json(omega, dead=False, hz=False):
    model = two_dof()
    _, x = model_frf(model, omega, {"1:x": 1.0}, ["1:x", "2:x"], TRUE)
    x = np.asarray(x)
    resp = {d: [[float(v.real), float(v.imag)] for v in x[:, j]] for j, d in enumerate(["1:x", "2:x"])}
    if dead:
        resp["2:x"] = [[0.0, 0.0]] * len(omega)
    axis = {"frequency_hz": (np.asarray(omega) / (2 * math.pi)).tolist()} if hz else {"omega_rad_s": list(omega)}
    return {"frf": {**axis, "force": {"1:x": 1.0}, "response": resp}}


def test_a_frequency_axis_in_hz_is_the_same_data_as_in_rad_s():
    omega = [0.4, 0.8, 1.6, 2.4]
    a = parse_testdata(frf_json(omega)).frf
    b = parse_testdata(frf_json(omega, hz=True)).frf
    np.testing.assert_allclose(b.omega, a.omega, rtol=1e-15)
    with pytest.raises(InputError, match="exactly one of omega_rad_s"):
        both = frf_json(omega)
        both["frf"]["frequency_hz"] = [0.1] * 4
        parse_testdata(both)


@pytest.mark.parametrize("residual", ["linear", "relative", "log"])
def test_a_dc_line_and_a_dead_channel_are_left_out_with_notes(residual):
    omega = [0.0, 0.4, 0.8, 1.6, 2.4]
    data = parse_testdata(frf_json(omega, dead=True))
    res = frf_update(two_dof(), data, residual=residual)
    np.testing.assert_allclose(res.x, [TRUE["k1"], TRUE["k2"]], rtol=1e-7)
    assert [s["line"] for s in res.skipped] == [1] and res.omega.size == 4
    assert any("2:x zero at every line" in n for n in res.notes) and any("0 Hz" in n for n in res.notes)


def test_the_dead_channel_changes_nothing_but_its_own_rows():
    """The same data without the dead channel give the same answer: it carries no weight."""
    omega = [0.4, 0.8, 1.6, 2.4]
    with_dead = frf_update(two_dof(), parse_testdata(frf_json(omega, dead=True)), residual="relative", x0={"k1": 10, "k2": 4})
    raw = frf_json(omega)
    del raw["frf"]["response"]["2:x"]
    alone = frf_update(two_dof(), parse_testdata(raw), residual="relative", x0={"k1": 10, "k2": 4})
    np.testing.assert_allclose(with_dead.x, alone.x, rtol=1e-10)


def test_isolated_zeros_are_still_refused_by_the_log_residual_and_all_dead_is_refused():
    omega = [0.4, 0.8, 1.6, 2.4]
    raw = frf_json(omega)
    raw["frf"]["response"]["1:x"][2] = [0.0, 0.0]
    with pytest.raises(InputError, match="non-zero measured values"):
        frf_update(two_dof(), parse_testdata(raw), residual="log")
    raw = frf_json(omega, dead=True)
    raw["frf"]["response"]["1:x"] = [[0.0, 0.0]] * 4
    with pytest.raises(InputError, match="every FRF channel is zero"):
        frf_update(two_dof(), parse_testdata(raw))


def test_cli_frf_takes_hz(tmp_path, capsys):
    from femupdate.cli import main

    with pytest.raises(SystemExit):
        main(["demo", "--write-files", str(tmp_path)])
    capsys.readouterr()
    with pytest.raises(SystemExit) as info:
        main(["frf", str(tmp_path / "two_dof.toml"), "--force", "1:x", "--frequency-hz", "0.1,0.2", "--json", "-"])
    assert info.value.code in (0, None)
    np.testing.assert_allclose(json.loads(capsys.readouterr().out)["omega_rad_s"], [0.2 * math.pi, 0.4 * math.pi])
    with pytest.raises(SystemExit) as info:
        main(["frf", str(tmp_path / "two_dof.toml"), "--force", "1:x"])
    assert info.value.code == 2 and "exactly one of --omega" in capsys.readouterr().err
