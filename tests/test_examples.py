"""The example files of `femupdate demo --write-files` and the README's commands on them."""

import json

import pytest

from femupdate.cli import main


def run(args, capsys):
    with pytest.raises(SystemExit) as info:
        main(args)
    out, err = capsys.readouterr()
    assert info.value.code == 0, err
    return json.loads(out) if "--json" in args else out


@pytest.fixture(scope="module")
def ex(tmp_path_factory):
    d = tmp_path_factory.mktemp("ex")
    with pytest.raises(SystemExit) as info:
        main(["demo", "--write-files", str(d), "--json", str(d / "demo.json")])
    assert info.value.code == 0
    return d


def test_every_example_file_is_written(ex):
    from femupdate.examples import example_files

    for name in example_files():
        assert (ex / name).stat().st_size > 0, name


def test_frequencies_alone_give_both_solutions_and_a_modified_test_removes_one(ex, capsys):
    res = run(["update", str(ex / "two_dof.toml"), str(ex / "two_dof_frequencies.json"), "--starts", "40", "--seed", "1",
               "--json", "-"], capsys)
    sols = sorted((round(s["parameters"]["k1"], 6), round(s["parameters"]["k2"], 6)) for s in res["starts"]["solutions"])
    assert sols == [(8.0, 6.0), (9.0, round(16 / 3, 6))]
    res = run(["update-multi", str(ex / "two_dof.toml"), "--config", str(ex / "two_dof_frequencies.json"), "--config",
               f"{ex / 'two_dof_plus_2kg.json'}:{ex / 'plus_2kg.toml'}", "--json", "-"], capsys)
    assert res["parameters"] == pytest.approx({"k1": 8.0, "k2": 6.0}, rel=1e-8)
    res = run(["rank-modifications", str(ex / "two_dof.toml"), str(ex / "candidates.toml"), "--measured-dofs", "1:x",
               "--modes", "2", "--eigenvalues-only", "--json", "-"], capsys)
    assert len(res["candidates"]) == 3


def test_frf_update_and_surface_find_the_truth(ex, capsys):
    res = run(["frf-update", str(ex / "two_dof.toml"), str(ex / "two_dof_frf.json"), "--json", "-"], capsys)
    assert res["parameters"] == pytest.approx({"k1": 8.0, "k2": 6.0}, rel=2e-3)  # 0.1 % noise
    res = run(["surface", str(ex / "two_dof.toml"), str(ex / "two_dof_frf.json"), "--params", "k1,k2", "--x", "3:13:51",
               "--y", "1:11:51", "--json", "-"], capsys)
    assert (res["minimum"]["k1"], res["minimum"]["k2"]) == pytest.approx((8.0, 6.0))  # the grid point of the truth


def test_damage_example_locates_the_damaged_member(ex, capsys):
    from femupdate.examples import TRUSS_DAMAGED, TRUSS_LOSS

    res = run(["damage", str(ex / "truss.toml"), str(ex / "truss_damaged.json"), "--undamaged",
               str(ex / "truss_undamaged.json"), "--bootstrap", "4", "--json", "-"], capsys)
    assert res["located"] == [TRUSS_DAMAGED]
    assert res["changes"][TRUSS_DAMAGED] == pytest.approx(-TRUSS_LOSS, abs=0.03)  # 0.1 % noise


def test_uniqueness_and_reduce_run_on_the_examples(ex, capsys):
    res = run(["uniqueness", str(ex / "two_dof.toml"), "--starts", "20", "--json", "-"], capsys)
    verdicts = {(len(c["measured_dofs"]), c["n_modes"]): c["unique"] for c in res["cases"]}
    assert verdicts[(1, 2)] is False and verdicts[(2, 2)] is True  # one sensor, two modes: two solutions
    res = run(["reduce", str(ex / "truss.toml"), "--keep", "4:x,4:y,104:x,104:y,3:y,103:y", "--json", "-"], capsys)
    assert len(res["K"]) == 6


def test_posterior_example_gives_both_solutions_equal_probability(ex, capsys):
    pytest.importorskip("emcee")
    res = run(["posterior", str(ex / "two_dof.toml"), str(ex / "two_dof_frequencies.json"), "--std-eigenvalue", "0.002",
               "--method", "tmcmc", "--samples", "1000", "--json", "-"], capsys)
    probs = sorted((round(s["parameters"]["k1"], 6), round(s["probability"], 6)) for s in res["solutions"])
    assert probs == [(8.0, 0.5), (9.0, 0.5)] and res["success"]


def test_damped_truss_updated_to_the_truth_from_its_complex_modes_and_from_its_frfs(ex, capsys):
    """Issue 31's "done when" on the example files of docs/damping.md: the truss with two dampers
    (and Rayleigh β) from a start 14-300 % away, to the truth that made the noise-free data."""
    from femupdate.examples import TRUSS_DAMPED_START, TRUSS_DAMPING

    truth = {"E": 7.0e10, "b": TRUSS_DAMPING["beta"], "c1": TRUSS_DAMPING["c1"], "c2": TRUSS_DAMPING["c2"]}
    start = ",".join(f"{k}={v:g}" for k, v in TRUSS_DAMPED_START.items())
    assert all(abs(TRUSS_DAMPED_START[k] / v - 1) > 0.1 for k, v in truth.items())
    for command, data in (("update", "truss_damped_modes.json"), ("frf-update", "truss_damped_frf.json")):
        res = run([command, str(ex / "truss_damped.toml"), str(ex / data), "--set", start, "--json", "-"], capsys)
        assert res["damping"]["parameters"] == ["b", "c1", "c2"], command
        for name, value in truth.items():
            assert res["parameters"][name] == pytest.approx(value, rel=1e-7), (command, name)
    assert min(res["frac"].values()) > 1 - 1e-12  # the FRFs, peaks included, fitted
