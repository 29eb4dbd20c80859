"""Inputs that used to give a wrong answer with exit 0, a hang or a misleading message, found by a
hostile review of the command line: each is now refused by name, in bounded time."""

import json
import socket
import threading
import time

import numpy as np
import pytest

from femupdate import InputError, MeasuredMode, StaticData, Structure, TestData, direct_update, model_modes, update
from femupdate.cli import main
from femupdate.examples import example_files, two_dof
from femupdate.uniqueness import define_study


def run(args, capsys):
    with pytest.raises(SystemExit) as info:
        main(args)
    out, err = capsys.readouterr()
    return info.value.code, out + err


@pytest.fixture
def ex(tmp_path):
    for name, text in example_files().items():
        (tmp_path / name).write_text(text)
    return tmp_path


def test_a_service_that_is_not_a_dask_scheduler_is_refused_within_the_timeout():
    pytest.importorskip("distributed")
    from femupdate.dask_cluster import connect

    server = socket.socket()
    server.bind(("127.0.0.1", 0))
    server.listen()
    accepted = []
    threading.Thread(target=lambda: accepted.append(server.accept()), daemon=True).start()  # accepts, never answers
    t0 = time.monotonic()
    try:
        with pytest.raises(InputError, match="no Dask scheduler answered"):
            connect(f"tcp://127.0.0.1:{server.getsockname()[1]}", timeout=1.0)
    finally:
        server.close()
    assert time.monotonic() - t0 < 20  # used to wait forever


def test_an_empty_scheduler_address_is_refused(ex, capsys):
    code, out = run(["update", str(ex / "two_dof.toml"), str(ex / "two_dof_frequencies.json"), "--starts", "2",
                     "--scheduler", " "], capsys)
    assert code == 2 and "'--scheduler'" in out and "empty" in out


def test_jobs_with_a_scheduler_is_refused(ex, capsys):
    # local processes and a cluster exclude each other: the option that would be ignored is refused
    code, out = run(["update", str(ex / "two_dof.toml"), str(ex / "two_dof_frequencies.json"), "--starts", "2",
                     "--jobs", "2", "--scheduler", "tcp://127.0.0.1:1"], capsys)
    assert code == 2 and "--jobs 2 with --scheduler" in out and "Traceback" not in out


def test_a_parameter_listed_twice_is_refused_everywhere():
    model = two_dof()
    data = TestData(modes=tuple(MeasuredMode(lam) for lam in model_modes(model).eigenvalues))
    with pytest.raises(InputError, match="listed twice: k1"):
        update(model, data, params=["k1", "k1"])
    with pytest.raises(InputError, match="listed twice: k1"):
        define_study(model, [(("1:x",), 2)], params=["k1", "k1"], starts=2)
    u = np.linalg.solve(model.K(model.values).toarray(), [0.0, 1.0])
    static = TestData(static=(StaticData({"2:x": 1.0}, ("1:x", "2:x"), u),))
    with pytest.raises(InputError, match="listed twice: k2"):
        direct_update(model, static, unknowns=["k2", "k2"])


def free_pair():
    s = Structure("free pair")
    s.parameter("k", 100.0, (1.0, 1e4))
    s.spring(["1:x", "2:x"], k="k")
    s.mass(["1:x"], m=1.0)
    s.mass(["2:x"], m=1.0)
    return s.build()


def test_a_static_load_a_free_model_cannot_carry_is_refused_not_fitted():
    model = free_pair()
    unbalanced = TestData(static=(StaticData({"2:x": 1.0}, ("1:x", "2:x"), [0.0, 0.01]),))
    with pytest.raises(InputError, match="static case 1: the model has 1 rigid-body mode.*not in equilibrium"):
        direct_update(model, unbalanced)  # used to answer k = 2.5 with a 0.71 relative residual, exit 0
    balanced = TestData(static=(StaticData({"1:x": -1.0, "2:x": 1.0}, ("1:x", "2:x"), [-0.005, 0.005]),))
    res = direct_update(model, balanced)  # a self-equilibrated load is fine for the direct method: k = 1 / 0.01
    assert res.parameters["k"] == pytest.approx(100.0, rel=1e-12)
    with pytest.raises(InputError, match="static case 1: the model has 1 rigid-body mode.*needs a supported model"):
        update(model, balanced)


def test_frequency_only_test_modes_out_of_order_are_refused():
    model = two_dof()
    lam = model_modes(model).eigenvalues
    with pytest.raises(InputError, match="list them by increasing frequency.*test mode 2"):
        update(model, TestData(modes=(MeasuredMode(lam[1]), MeasuredMode(lam[0]))))


def test_output_probes_catch_what_permissions_do_not(ex, capsys, tmp_path):
    code, out = run(["update", str(ex / "two_dof.toml"), str(ex / "two_dof_frequencies.json"), "--json",
                     "/proc/femupdate-test.json"], capsys)
    assert code == 2 and "'--json'" in out and "cannot write in /proc" in out
    code, out = run(["update", str(ex / "two_dof.toml"), str(ex / "two_dof_frequencies.json"), "--json",
                     str(tmp_path / ("a" * 260 + ".json"))], capsys)
    assert code == 2 and "longer than 255 bytes" in out and "--json" in out
    long = tmp_path / ("b" * 250 + ".json")  # legal, but its temporary's name used to be too long
    code, out = run(["update", str(ex / "two_dof.toml"), str(ex / "two_dof_frequencies.json"), "--json", str(long)],
                    capsys)
    assert code == 0 and json.loads(long.read_text())["success"]
    code, out = run(["surface", str(ex / "two_dof.toml"), str(ex / "two_dof_frf.json"), "--params", "k1,k2", "--x",
                     "3:13:3", "--y", "1:11:3", "--plot", str(tmp_path / "s.txt")], capsys)
    assert code == 2 and "must end in one of .png" in out


def test_options_for_data_not_used_are_refused(ex, capsys):
    args = ["update", str(ex / "two_dof.toml"), str(ex / "two_dof_frequencies.json")]
    code, out = run(args + ["--select", "3"], capsys)
    assert code == 2 and "--select: FRF option(s) given, but no FRF data are used" in out
    code, out = run(args + ["--std-static", "0.001"], capsys)
    assert code == 2 and "standard deviations given for static data (--std-static)" in out


def test_values_given_twice_on_the_command_line_are_refused(ex, capsys):
    code, out = run(["modes", str(ex / "two_dof.toml"), "--set", "k1=9,k1=10"], capsys)
    assert code == 2 and "--set: 'k1' is given twice" in out  # the last value used to win silently
    code, out = run(["frf", str(ex / "two_dof.toml"), "--force", "1:x=1,1:x=2", "--omega", "1,2"], capsys)
    assert code == 2 and "--force: '1:x' is given twice" in out
    code, out = run(["frf-update", str(ex / "two_dof.toml"), str(ex / "two_dof_frf.json"), "--lines", "1,2,2"], capsys)
    assert code == 2 and "--lines: line(s) 2 given twice" in out


def test_the_reference_dof_is_read_as_the_user_may_type_it(ex, capsys):
    from femupdate.examples import figure2_model_toml, figure2_test_data

    (ex / "figure2.toml").write_text(figure2_model_toml())
    (ex / "figure2_test.json").write_text(json.dumps(figure2_test_data()))
    args = ["update", str(ex / "figure2.toml"), str(ex / "figure2_test.json"), "--shape-scaling", "ref", "--json", "-"]
    code, out = run(args + ["--ref-dof", " 1 : X"], capsys)
    code_canonical, out_canonical = run(args + ["--ref-dof", "1:x"], capsys)
    assert code == code_canonical == 0
    assert json.loads(out)["parameters"] == json.loads(out_canonical)["parameters"]
    code, out = run(args[:-2] + ["--ref-dof", "1x"], capsys)
    assert code == 2 and "reference dof (--ref-dof): dof label '1x' is not of the form" in out
