"""``femupdate posterior`` and what surrounds Bayesian updating: the command line (output, JSON,
exit codes, refusals), samples files, figures, checkpoints (resumed exactly, damaged files
refused) and Dask (the samples of a local run)."""

import csv
import json
import math

import numpy as np
import pytest

import femupdate as fu
from femupdate import InputError
from femupdate.cli import main
from femupdate.examples import two_dof, two_dof_model_toml

pytest.importorskip("emcee")


def run(args, capsys):
    with pytest.raises(SystemExit) as info:
        main(args)
    out, err = capsys.readouterr()
    return info.value.code, out, err


@pytest.fixture
def files(tmp_path):
    """The demo's two-dof model (k1 in [3, 13], k2 in [1, 11]) and its two frequencies, stated to 1 %."""
    model = tmp_path / "two.toml"
    model.write_text(two_dof_model_toml())
    lam = fu.model_modes(two_dof()).eigenvalues
    data = tmp_path / "freq.json"
    data.write_text(json.dumps({"modes": [{"eigenvalue": float(v), "std_eigenvalue": 0.01} for v in lam]}))
    return model, data


def test_posterior_laplace_json_and_terminal(files, tmp_path, capsys):
    model, data = files
    code, out, err = run(["posterior", str(model), str(data), "--json", str(tmp_path / "r.json")], capsys)
    assert code == 0, err
    assert "2 distinct solution(s)" in out and "log evidence" in out
    res = json.loads((tmp_path / "r.json").read_text())
    for key in ("method", "success", "parameters", "mean", "median", "std", "interval", "covariance", "correlation",
                "solutions", "log_evidence", "noise", "prior", "predictive", "diagnostics", "warnings", "notes"):
        assert key in res, key
    sols = sorted((round(s["parameters"]["k1"], 6), round(s["parameters"]["k2"], 6), round(s["probability"], 6))
                  for s in res["solutions"])
    assert sols == [(8.0, 6.0, 0.5), (9.0, round(16 / 3, 6), 0.5)]
    assert res["noise"]["kind"] == "stated" and res["prior"]["k1"] == "uniform on [3, 13]"
    assert len(res["predictive"]["modes"]) == 2


def test_posterior_tmcmc_samples_figures_and_stdout_json(files, tmp_path, capsys):
    model, data = files
    code, out, err = run(["posterior", str(model), str(data), "--method", "tmcmc", "--samples", "400", "--starts", "4",
                          "--samples-out", str(tmp_path / "s.csv"), "--plot", str(tmp_path / "fig"), "--json", "-"],
                         capsys)
    assert code == 0, err
    res = json.loads(out)  # nothing but JSON on stdout
    assert res["method"] == "tmcmc" and math.isfinite(res["log_evidence"]) and res["diagnostics"]["n_stages"] >= 2
    with open(tmp_path / "s.csv", newline="") as fh:
        rows = list(csv.reader(fh))
    assert rows[0] == ["sample", "k1", "k2", "log_likelihood"] and len(rows) == 401
    table = np.genfromtxt(tmp_path / "s.csv", delimiter=",", names=True)
    assert table["k1"].size == 400 and np.all(np.isfinite(table["log_likelihood"]))
    assert np.mean(table["k1"]) == pytest.approx(res["mean"]["k1"], rel=1e-12)
    assert sorted(p.name for p in (tmp_path / "fig").iterdir()) == ["corner.png", "predictive.png", "trace.png"]
    assert not (tmp_path / "-.checkpoint.npz").exists()


def test_mcmc_samples_as_npz_with_the_chains(files, tmp_path, capsys):
    model, data = files
    code, out, err = run(["posterior", str(model), str(data), "--method", "mcmc", "--walkers", "8", "--steps", "30",
                          "--burn", "10", "--starts", "3", "--samples-out", str(tmp_path / "s.npz"),
                          "--json", str(tmp_path / "r.json")], capsys)
    # too short a run: the JSON is written, the sampler's checks fail (exit 1) with the reason
    assert code == 1 and "checks failed" in err
    res = json.loads((tmp_path / "r.json").read_text())
    assert res["success"] is False and any("effective sample size below" in w for w in res["warnings"])
    with np.load(tmp_path / "s.npz") as z:
        assert list(z["names"]) == ["k1", "k2"] and z["chain"].shape == (2, 30, 8, 2) and int(z["burn"]) == 10
        assert z["samples"].shape == (2 * 20 * 8, 2)
        np.testing.assert_array_equal(z["samples"], z["chain"][:, 10:].reshape(-1, 2))
    assert (tmp_path / "r.checkpoint.npz").exists()


@pytest.mark.parametrize("args, message", [
    (["--prior", "k1=gauss(8,1)"], "--prior k1: unknown prior 'gauss'"),
    (["--prior", "k1"], "--prior: 'k1' is not of the form NAME=SPEC"),
    (["--prior", "k9=uniform"], "prior given for 'k9', which is not an updated parameter"),
    (["--noise", "stated", "--std-eigenvalue", "0.01", "--eigenvalues-only"], None),
    (["--std-shape", "0.01", "--noise", "stated"], "--std-shape: the data used have no mode shapes"),
])
def test_bad_options_are_refused_by_name(files, tmp_path, capsys, args, message):
    model, data = files
    code, out, err = run(["posterior", str(model), str(data), "--starts", "2", *args], capsys)
    if message is None:
        assert code == 0, err
        return
    assert code == 2 and message in err and "Traceback" not in err


def test_noise_stated_without_std_is_refused(tmp_path, capsys):
    model = tmp_path / "two.toml"
    model.write_text(two_dof_model_toml())
    data = tmp_path / "d.json"
    data.write_text(json.dumps({"modes": [{"eigenvalue": float(v)} for v in fu.model_modes(two_dof()).eigenvalues]}))
    code, out, err = run(["posterior", str(model), str(data), "--noise", "stated"], capsys)
    assert code == 2 and "needs a standard deviation for every residual" in err
    # auto: two residuals for two parameters, nothing to estimate a noise scale from
    code, out, err = run(["posterior", str(model), str(data)], capsys)
    assert code == 2 and "a noise scale cannot be estimated" in err


def test_repeated_tests_and_a_prior_from_the_command_line(files, tmp_path, capsys):
    model, data = files
    code, out, err = run(["posterior", str(model), str(data), str(data), "--prior", "k2=normal(6,0.5)", "--starts", "4",
                          "--json", "-"], capsys)
    assert code == 0, err
    res = json.loads(out)
    assert res["data_sets"] == 2 and res["prior"]["k2"] == "normal(6, 0.5) on [1, 11]"
    probs = {round(s["parameters"]["k1"]): s["probability"] for s in res["solutions"]}
    assert probs[8] > 0.5  # the prior favours k2 = 6


# ----------------------------------------------------------------------------------- checkpoints
def _data(sigma=0.01):
    return fu.TestData(modes=tuple(fu.MeasuredMode(v, std_eigenvalue=sigma) for v in fu.model_modes(two_dof()).eigenvalues))


class Stop(Exception):
    pass


@pytest.mark.parametrize("method, phase, opts", [
    ("tmcmc", "tmcmc", dict(samples=300, tmcmc_steps=3)),
    ("mcmc", "mcmc", dict(walkers=8, steps=60, segment=20, burn=10)),
])
def test_an_interrupted_run_resumes_to_the_same_samples(tmp_path, method, phase, opts):
    model = two_dof()
    common = dict(method=method, starts=3, seed=5, **opts)
    whole = fu.posterior(model, _data(), **common)
    calls = []

    def progress(ph, done, total):
        if ph == phase:
            calls.append(done)
            if len(calls) == 3:
                raise Stop

    ck = tmp_path / "run.npz"
    with pytest.raises(Stop):
        fu.posterior(model, _data(), checkpoint=ck, progress=progress, **common)
    assert ck.exists()
    resumed = fu.posterior(model, _data(), checkpoint=ck, **common)
    np.testing.assert_array_equal(resumed.samples, whole.samples)
    if method == "tmcmc":
        assert resumed.log_evidence == whole.log_evidence and resumed.diagnostics["resumed_stages"] >= 1
    else:
        assert resumed.diagnostics["resumed_steps"] == 40
        np.testing.assert_array_equal(resumed.chain, whole.chain)


def test_a_checkpoint_of_another_run_or_damaged_is_refused(tmp_path):
    model = two_dof()
    ck = tmp_path / "run.npz"
    fu.posterior(model, _data(), method="tmcmc", samples=200, tmcmc_steps=2, starts=2, checkpoint=ck)
    with pytest.raises(InputError, match="belongs to a different run"):
        fu.posterior(model, _data(), method="tmcmc", samples=200, tmcmc_steps=2, starts=2, checkpoint=ck, seed=9)
    with np.load(ck) as z:
        arrays = {k: z[k] for k in z.files}
    arrays["x"] = arrays["x"].copy()
    arrays["x"][0, 0] += 1e-9
    np.savez(ck, **arrays)
    with pytest.raises(InputError, match="array 'x' does not match its digest"):
        fu.posterior(model, _data(), method="tmcmc", samples=200, tmcmc_steps=2, starts=2, checkpoint=ck)
    ck.write_bytes(b"not a checkpoint")
    with pytest.raises(InputError, match="not a readable femupdate posterior checkpoint"):
        fu.posterior(model, _data(), method="tmcmc", samples=200, tmcmc_steps=2, starts=2, checkpoint=ck)


# ----------------------------------------------------------------------------------- Dask
def test_a_dask_run_gives_the_samples_of_a_local_run():
    distributed = pytest.importorskip("distributed")
    model = two_dof()
    tm = dict(method="tmcmc", samples=240, tmcmc_steps=2, chunks=3, starts=3, seed=2)
    mc = dict(method="mcmc", walkers=8, ensembles=2, steps=40, segment=20, burn=10, starts=3, seed=2)
    local_t = fu.posterior(model, _data(), **tm)
    local_m = fu.posterior(model, _data(), **mc)
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                                  dashboard_address=None) as cluster:
        remote_t = fu.posterior(model, _data(), scheduler=cluster.scheduler_address, **tm)
        remote_m = fu.posterior(model, _data(), scheduler=cluster.scheduler_address, **mc)
    np.testing.assert_array_equal(remote_t.samples, local_t.samples)
    assert remote_t.log_evidence == local_t.log_evidence
    np.testing.assert_array_equal(remote_m.chain, local_m.chain)
    assert remote_t.diagnostics["evaluations"] == local_t.diagnostics["evaluations"]


# ----------------------------------------------------------------------------------- figures
def test_figures_return_their_figure_and_axes():
    from femupdate.plot.posterior import corner_figure, predictive_axes, trace_figure

    model = two_dof()
    res = fu.posterior(model, _data(), method="tmcmc", samples=200, tmcmc_steps=2, starts=2)
    fig = corner_figure(res, truth={"k1": 8.0, "k2": 6.0})
    assert len(fig.axes) == 4 and sum(a.get_visible() for a in fig.axes) == 3
    assert len(trace_figure(res).axes) >= 3
    ax = predictive_axes(res, _data().frequencies_hz)
    assert ax.get_ylabel().startswith("frequency")
    lap = fu.posterior(model, _data(), method="laplace", starts=2)
    with pytest.raises(ValueError, match="no chains or stages"):
        trace_figure(lap)


@pytest.mark.parametrize("args, message", [
    (["--walkers", "8"], "--walkers applies to --method mcmc only, not --method laplace"),
    (["--steps", "100"], "--steps applies to --method mcmc only, not --method laplace"),
    (["--method", "tmcmc", "--segment", "10"], "--segment applies to --method mcmc only, not --method tmcmc"),
    (["--method", "mcmc", "--chunks", "4"], "--chunks applies to --method tmcmc only, not --method mcmc"),
    (["--method", "mcmc", "--samples", "100"], "--samples applies to --method laplace or tmcmc only, not --method mcmc"),
    (["--method", "mcmc", "--walkers", "9"], "--walkers 9: the ensemble sampler needs an even number of walkers"),
])
def test_a_sampler_option_that_would_do_nothing_is_refused(files, capsys, args, message):
    """An option the chosen method does not use is said, not silently ignored (exit 2, before any work)."""
    model, data = files
    code, out, err = run(["posterior", str(model), str(data), *args], capsys)
    assert code == 2 and message in err and "Traceback" not in err


def test_the_default_of_an_option_is_not_taken_for_a_choice(files, capsys, tmp_path):
    """The check looks at what the command line gave, not at values equal to the defaults."""
    model, data = files
    code, out, err = run(["posterior", str(model), str(data), "--samples", "300", "--json", str(tmp_path / "r.json")],
                         capsys)
    assert code == 0, err
