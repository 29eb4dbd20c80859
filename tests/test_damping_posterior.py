"""Bayesian updating of a damped model (issue 31, item 4): ``femupdate.posterior`` / ``femupdate
posterior`` with damping parameters among the unknowns, through the damped residuals the update
minimises.

References: the update's covariance at the same point (the Laplace Gaussian of a flat prior is
the least-squares covariance); a second route by noise seeds — over repeated noisy data
simulated with the stated standard deviations, the Mahalanobis distance of the posterior's mode
from the truth under its Laplace covariance is chi-square with L degrees of freedom (mean L); and
the ensemble MCMC sampler against the Laplace approximation on a near-linear case (two dampers,
small noise).
"""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest

import femupdate
from conftest import HEAVY, heavy
from femupdate._errors import InputError
from femupdate.testdata import MeasuredMode, TestData
from test_damping_update import TRUTH, _cli, _modes, _start, _truss, _write_case

NAMES = ["E", "b", "c1", "c2"]


@pytest.fixture(scope="module")
def truss():
    return _truss()


def _noisy(clean: TestData, seed: int) -> TestData:
    """The clean modes with noise of their stated standard deviations: relative eigenvalue,
    absolute damping ratio, complex unit-shape entries (real and imaginary parts)."""
    rng = np.random.default_rng(seed)
    out = []
    for m in clean.modes:
        v = np.asarray(m.shape) / np.linalg.norm(m.shape)
        shape = v + m.std_shape * (rng.standard_normal(v.size) + 1j * rng.standard_normal(v.size))
        out.append(dataclasses.replace(m, eigenvalue=m.eigenvalue * (1 + m.std_eigenvalue * rng.standard_normal()),
                                       damping_ratio=m.damping_ratio + m.std_damping_ratio * rng.standard_normal(),
                                       shape=shape))
    return TestData(modes=tuple(out))


def test_laplace_posterior_of_a_damped_model_is_the_update_s_covariance_at_its_solution(truss):
    data = _noisy(_modes(truss), 0)
    up = femupdate.update(_start(truss), data)
    res = femupdate.posterior(_start(truss), data, starts=1, seed=1)
    assert res.names == tuple(NAMES) and res.route == "local"
    mode = res.modes[0]
    for n, v in up.parameters.items():
        assert mode.parameters[n] == pytest.approx(v, rel=1e-7), n
    C_up, C = np.asarray(up.diagnostics.covariance), np.asarray(mode.covariance)
    scale = np.sqrt(np.outer(np.diag(C_up), np.diag(C_up)))
    assert np.max(np.abs(C - C_up) / scale) < 1e-6
    assert res.damping == {"parameters": ["b", "c1", "c2"], "held": {}}
    # the posterior predictive of the paired modes' damping ratios: near the measured ones
    for e, m in zip(res.predictive["modes"], data.modes):
        z = e["damping_ratio"]
        assert abs(z["mean"] - m.damping_ratio) < 4 * m.std_damping_ratio and 0 < z["std"] < m.std_damping_ratio
    back = femupdate.load_result(_roundtrip(res))
    assert back.damping == res.damping


def _roundtrip(res):
    import tempfile
    from pathlib import Path

    p = Path(tempfile.mkdtemp()) / "p.json"
    p.write_text(json.dumps(res.to_json()))
    return p


@pytest.mark.parametrize("n_seeds", [200 if HEAVY else 25])
def test_laplace_of_a_damped_truss_is_calibrated_over_noise_seeds(truss, n_seeds):
    """Mahalanobis distance of the mode from the truth ~ chi-square(4): its mean over the seeds is
    4 within 3 of its standard errors sqrt(8 / n); and the 95 % intervals cover the truth."""
    clean = _modes(truss)
    truth = np.array([TRUTH[n] for n in NAMES])
    d2, cover = [], np.zeros(len(NAMES))
    for s in range(n_seeds):
        res = femupdate.posterior(_start(truss), _noisy(clean, 100 + s), starts=1, seed=s, samples=2000, predictive=0)
        m = res.modes[0]
        e = np.array([m.parameters[n] for n in NAMES]) - truth
        d2.append(e @ np.linalg.solve(np.asarray(m.covariance), e))
        cover += [res.interval[n][0] <= TRUTH[n] <= res.interval[n][1] for n in NAMES]
    assert abs(np.mean(d2) - len(NAMES)) < 3 * np.sqrt(2 * len(NAMES) / n_seeds), np.mean(d2)
    # each parameter's coverage: binomial(n, 0.95), 3 standard deviations
    assert np.all(np.abs(cover / n_seeds - 0.95) < 3 * np.sqrt(0.95 * 0.05 / n_seeds) + 0.5 / n_seeds), cover / n_seeds


def _mcmc_against_laplace(truss, steps: int, mean_tol: float, std_tol: float) -> None:
    data = _noisy(_modes(truss), 7)
    start = truss.with_values({"c1": 150.0, "c2": 500.0})  # E and b held at the truth
    la = femupdate.posterior(start, data, params=["c1", "c2"], starts=1, seed=3)
    mc = femupdate.posterior(start, data, params=["c1", "c2"], starts=1, seed=3, method="mcmc", steps=steps,
                             walkers=16)
    for n in ("c1", "c2"):
        s = la.modes[0].std[n]
        assert abs(mc.mean[n] - la.modes[0].parameters[n]) < mean_tol * s, n
        assert mc.std[n] == pytest.approx(s, rel=std_tol), n
    assert mc.damping == {"parameters": ["c1", "c2"], "held": {"b": TRUTH["b"]}}


def test_mcmc_of_two_dampers_agrees_with_laplace_short(truss):
    """A short chain (about 150 effective samples a parameter): means within 0.35 std (4 Monte
    Carlo standard errors), standard deviations within 25 %."""
    _mcmc_against_laplace(truss, 150, 0.35, 0.25)


@heavy
def test_mcmc_of_two_dampers_agrees_with_laplace(truss):
    """About 550 effective samples a parameter (seen: means within 0.04 std, stds within 2.5 %)."""
    _mcmc_against_laplace(truss, 400, 0.2, 0.12)


def test_posterior_cli_on_a_model_with_a_damping_table(tmp_path, capsys, truss):
    model, test = _write_case(tmp_path, _noisy(_modes(truss), 0))
    code, out, err = _cli(["posterior", model, test, "--starts", "1", "--seed", "1", "--json", tmp_path / "p.json",
                           "--report", tmp_path / "p.html"], capsys)
    assert code == 0, out + err
    r = json.loads((tmp_path / "p.json").read_text())
    assert r["updated"] == NAMES and r["damping"] == {"parameters": ["b", "c1", "c2"], "held": {}}
    assert r["route"] == "local" and all(e["damping_ratio"] is not None for e in r["predictive"]["modes"])
    assert "[damping] table is read by" not in out + err  # used, not ignored
    assert "posterior predictive of the paired modes' damping ratios" in out
    assert "the damping ratios of the paired complex modes over the posterior" in (tmp_path / "p.html").read_text()
    up = femupdate.update(load_start(model), _noisy(_modes(truss), 0))
    for n in NAMES:  # the CLI's Laplace mode is the update's answer
        assert r["solutions"][0]["parameters"][n] == pytest.approx(up.parameters[n], rel=1e-6), n
        assert r["solutions"][0]["std"][n] == pytest.approx(up.diagnostics.std[list(up.names).index(n)], rel=1e-5), n
    code, out, err = _cli(["posterior", load_truth(tmp_path), test, "--starts", "1", "--params", "E,c1"], capsys)
    assert code == 0 and "damping parameters held: b = 2e-05, c2 = 250" in out, out + err
    # options that do not apply to a damped model: one message each, exit 2
    for args, message in ((["--damping", "alpha=1"], "leave --damping out"),
                          (["--test-points", "0.01"], "--test-points with a [damping] table")):
        code, out, err = _cli(["posterior", model, test, "--starts", "1", *args], capsys)
        assert code == 2 and message in err and err.strip().count("\n") == 0, err


def load_truth(tmp_path):
    """The model file with the true damping values (E, b, c1, c2 as simulated)."""
    from femupdate.examples import truss_damped_model_toml

    p = tmp_path / "truth.toml"
    p.write_text(truss_damped_model_toml())
    return p


def load_start(path):
    from femupdate.damping import load_damped_model

    return load_damped_model(path)


def test_damping_parameters_held_without_damping_data(truss):
    from femupdate.damping import complex_modes

    cm = complex_modes(truss, n_modes=3)
    freq_only = TestData(modes=tuple(MeasuredMode(float(abs(lam)) ** 2, std_eigenvalue=1e-3) for lam in cm.eigenvalues))
    res = femupdate.posterior(truss.with_values({"E": 6.5e10}), freq_only, starts=1, seed=0)
    assert res.names == ("E",) and res.modes[0].parameters["E"] == pytest.approx(7e10, rel=1e-8)
    assert res.damping == {"parameters": [], "held": {"b": TRUTH["b"], "c1": TRUTH["c1"], "c2": TRUTH["c2"]}}
    assert any("damping parameters b, c1, c2 are not updated" in n for n in res.notes)
    with pytest.raises(InputError, match="route 'compiled': the model is damped"):
        femupdate.posterior(truss, freq_only, starts=1, route="compiled")


def test_posterior_of_modal_ratio_parameters_is_the_update_s_covariance(truss):
    """Modal damping ratios that are damping parameters (one per mode, one on a group) beside a
    damper: the Laplace Gaussian at the update's answer is the update's covariance."""
    from test_damping_modal import _modal

    dm = _modal(truss)
    clean = _modes(dm, n=4)
    data = _noisy(clean, 5)
    start = dm.with_values({"z1": 0.05, "z23": 0.01, "c1": 250.0})
    names = ["z1", "z23", "c1"]
    up = femupdate.update(start, data, params=names)
    res = femupdate.posterior(start, data, params=names, starts=1, seed=2, predictive=0)
    mode = res.modes[0]
    for n in names:
        assert mode.parameters[n] == pytest.approx(up.parameters[n], rel=1e-7), n
    C_up, C = np.asarray(up.diagnostics.covariance), np.asarray(mode.covariance)
    assert np.max(np.abs(C - C_up) / np.sqrt(np.outer(np.diag(C_up), np.diag(C_up)))) < 1e-6
    assert res.damping == {"parameters": names, "held": {"eta": 0.01}}


@heavy
def test_tmcmc_of_two_dampers_agrees_with_laplace(truss):
    """TMCMC (300 samples) on the near-linear case (seen: means within 0.1 std, stds within 0.4 %,
    log-evidence -117.16 against Laplace's -117.34)."""
    data = _noisy(_modes(truss), 7)
    start = truss.with_values({"c1": 150.0, "c2": 500.0})
    la = femupdate.posterior(start, data, params=["c1", "c2"], starts=1, seed=3)
    tm = femupdate.posterior(start, data, params=["c1", "c2"], starts=1, seed=3, method="tmcmc", samples=300)
    assert tm.success
    for n in ("c1", "c2"):
        s = la.modes[0].std[n]
        assert abs(tm.mean[n] - la.modes[0].parameters[n]) < 0.3 * s, n
        assert tm.std[n] == pytest.approx(s, rel=0.15), n
    assert abs(tm.log_evidence - la.log_evidence) < 0.5


@pytest.mark.parametrize("stated", [pytest.param(True, marks=heavy), False], ids=["stated", "estimated"])
def test_new_measurement_interval_of_a_damped_model_carries_the_noise(truss, stated):
    """The posterior predictive's interval of a new measured frequency is the model's frequency
    with the measurement noise: relative eigenvalue std sigma (stated, or the estimated scale of
    the one "damped modes" noise pool times its unit weight), so a new f = f_model sqrt(1 + sigma z)
    has a 95 % half-width of about sqrt((1.96 f sigma / 2)^2 + h_model^2). The estimated scale was
    once left out for damped models (a relative std of 1: intervals like [0, 77] Hz at 46.5 Hz).
    2000 predictive draws keep the quantiles' sampling error to a few per cent. The estimated
    noise (where the defect was) runs everywhere, the stated noise with the heavy checks."""
    noisy = _noisy(_modes(truss), 3)
    unstated = TestData(modes=tuple(dataclasses.replace(m, std_eigenvalue=None, std_shape=None, std_damping_ratio=None)
                                    for m in noisy.modes))
    for data in ((noisy,) if stated else (unstated,)):
        res = femupdate.posterior(_start(truss), data, starts=1, seed=4, samples=4000, predictive=2000)
        sigma = (data.modes[0].std_eigenvalue if data.modes[0].std_eigenvalue is not None
                 else res.noise["scale"]["median"])
        for e in res.predictive["modes"]:
            f, (lo, hi) = e["frequency_hz"]["mean"], e["measured_frequency_hz"]["interval"]
            h_model = (e["frequency_hz"]["interval"][1] - e["frequency_hz"]["interval"][0]) / 2
            expected = np.hypot(1.96 * f * sigma / 2, h_model)
            assert lo < f < hi and 0.8 < (hi - lo) / 2 / expected < 1.25, (e, sigma)
