"""Bounded resources (issue 34, item 2): every count a user gives is refused above the available
memory (or a hard cap) with the estimate named, before anything is allocated for it; the time
of a long run is announced once its pace is measured.

The estimates are checked against memory measured with tracemalloc on the example models (a
start's record), and the refusals against the formulas of :mod:`femupdate._budget` computed
here from the model and data sizes.
"""

from __future__ import annotations

import gc
import logging
import re
import resource
import tracemalloc
from pathlib import Path

import numpy as np
import pytest

import femupdate as fu
from femupdate import InputError
from femupdate import _budget
from femupdate.damage import DamageOptions
from femupdate.options import SamplerOptions, StartsOptions
from femupdate.updating import draw_starts

DATA = Path(fu.__file__).parent / "data"


@pytest.fixture(scope="module")
def two_dof(ex):
    return fu.load_model(ex / "two_dof.toml"), fu.load_test_data(ex / "two_dof_frequencies.json")


@pytest.fixture
def memory(monkeypatch):
    """Pretend the machine has ``memory(n)`` bytes available (and check every estimate)."""
    monkeypatch.setattr(_budget, "SMALL", 0)

    def set_available(n: int) -> None:
        monkeypatch.setattr(_budget, "available_memory", lambda: n)
    return set_available


# ------------------------------------------------------------------------------ the billion starts
def test_a_billion_starts_are_refused_at_once_with_bounded_memory(two_dof):
    """Before: the starts were drawn up front (16 GB for two parameters) and memory grew about
    130 MB/s until the process was killed.  Now the count is refused before any allocation."""
    model, data = two_dof
    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss  # kB on Linux
    tracemalloc.start()
    try:
        with pytest.raises(InputError) as info:
            fu.multistart(model, data, starts=1_000_000_000)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert peak < 1_000_000, f"{peak} bytes allocated while refusing"
    assert resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - rss < 50_000  # kB
    text = str(info.value)
    # the floor of a start's record: 4.0 kB, so 4.0 TB for a billion
    assert re.match(r"starts=1000000000: about 4\.0 TB for the starts' records \(about 4\.0 kB each\), more than "
                    r"the [\d.]+ [kMGT]?B available", text), text


def test_the_command_line_names_the_option_as_written(ex, capsys):
    from femupdate.cli import main

    tracemalloc.start()
    try:
        with pytest.raises(SystemExit) as info:
            main(["update", str(ex / "two_dof.toml"), str(ex / "two_dof_frequencies.json"), "--starts", "1000000000"])
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert info.value.code == 2
    assert "--starts 1000000000: about 4.0 TB for the starts' records" in capsys.readouterr().err
    assert peak < 20_000_000  # the command's own imports and parsing; no starts


def test_starts_are_drawn_in_their_own_memory_only(two_dof):
    """An accepted count allocates the starts once: 8 bytes a parameter and start (log-uniform
    draws took twice that before: the logs and their exponentials)."""
    model, _ = two_dof
    n = 500_000
    for log_uniform in (False, True):
        gc.collect()
        tracemalloc.start()
        try:
            X = draw_starts(model, ("k1", "k2"), n, 0, log_uniform)
            _, peak = tracemalloc.get_traced_memory()
        finally:
            tracemalloc.stop()
        assert X.nbytes == 8 * 2 * n
        assert peak < 1.1 * X.nbytes, (log_uniform, peak)
    # the same numbers as one draw by NumPy itself
    rng = np.random.default_rng(0)
    lo, hi = model.bounds
    assert np.array_equal(draw_starts(model, ("k1", "k2"), 7, 0, True),
                          np.exp(rng.uniform(np.log(lo), np.log(hi), size=(7, 2))))


# ------------------------------------------------------------------------------ every count
@pytest.mark.parametrize("make, count, each", [
    (lambda: StartsOptions(starts=10**9), "starts=1000000000", _budget.START_BYTES),
    (lambda: SamplerOptions(samples=10**12), "samples=1000000000000", _budget.SAMPLE_BYTES),
    (lambda: SamplerOptions(predictive=10**12), "predictive=1000000000000", _budget.SAMPLE_BYTES),
    (lambda: DamageOptions(bootstrap=10**10), "bootstrap=10000000000", _budget.REPLICATE_BYTES),
    (lambda: DamageOptions(n_noise=10**12), "n_noise=1000000000000", _budget.NOISE_DRAW_BYTES),
], ids=["starts", "samples", "predictive", "bootstrap", "n_noise"])
def test_each_count_of_the_options_is_refused_above_the_memory(make, count, each):
    n = int(count.split("=")[1])
    with pytest.raises(InputError) as info:
        make()
    text = str(info.value)
    assert text.startswith(f"{count}: about {_budget.size(n * each)} for "), text
    assert f"(about {_budget.size(each)} each), more than the " in text


def test_the_mcmc_chains_are_refused_above_the_memory():
    with pytest.raises(InputError, match=r"^ensembles=4, walkers=1000000, steps=1000000: about 128 TB for the MCMC "
                                         r"chains \(32 bytes a walker and step\)"):
        SamplerOptions(method="mcmc", ensembles=4, walkers=10**6, steps=10**6)
    SamplerOptions(method="tmcmc", ensembles=4, steps=10**6)  # no chains without MCMC


def test_a_multistart_is_bounded_by_its_records_from_the_model_and_data(ex, memory):
    """The starts' floor passes, the estimate from the FRF data's residuals does not."""
    model, frf = fu.load_model(ex / "two_dof.toml"), fu.load_test_data(ex / "two_dof_frf.json")
    n_res = 2 * frf.frf.omega.size * len(frf.frf.dofs)  # complex residuals
    # the record, its residuals and Jacobian, its covariance-sized matrices and std dof, its noise record
    # (once, and the one FRF set's component and test)
    each = 13_000 + 16 * n_res * (2 + 2) + 32 * 2**2 + 8 * 2 + 2_300 + (700 + 400) * 1
    memory(10_000_000)
    StartsOptions(starts=1000)  # 4.0 MB: within
    for call in (fu.multistart, fu.frf_multistart):
        with pytest.raises(InputError, match=rf"^starts=1000: about {_budget.size(1000 * each)} for the starts' "
                                             rf"records \(about {_budget.size(each)} each\)"):
            call(model, frf, starts=1000)


def test_modes_are_bounded_by_the_model(two_dof, memory):
    model, _ = two_dof
    memory(50)
    with pytest.raises(InputError, match=r"^n_modes=2: about 96 bytes for the mode shapes"):
        fu.model_modes(model, n_modes=2)  # 24 bytes x 2 modes x 2 dofs
    with pytest.raises(InputError, match="n_modes must be between 1 and the number of dofs"):
        fu.model_modes(model, n_modes=3)


def test_frf_lines_are_bounded(two_dof, memory):
    model, _ = two_dof
    memory(100_000)
    with pytest.raises(InputError, match=r"^omega=1000: about 128 kB for the responses at the lines"):
        fu.simulate_frf(model, np.linspace(0.1, 1.0, 1000), {"1:x": 1.0})  # 64 bytes x 2 dofs a line


def test_frf_lines_of_the_command_line_are_refused_before_they_are_made():
    from femupdate.cli.frf import parse_omega

    tracemalloc.start()
    try:
        with pytest.raises(InputError, match=r"^--omega 0:1:1000000000000: N=1000000000000: about 64 TB"):
            parse_omega("0:1:1000000000000")
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert peak < 1_000_000


def test_a_surface_grid_is_bounded(ex):
    from femupdate.frf.surfaces import frf_surface

    model, frf = fu.load_model(ex / "two_dof.toml"), fu.load_test_data(ex / "two_dof_frf.json")
    g = np.linspace(4, 12, 10**6)
    with pytest.raises(InputError, match=r"^grid of 1000000 x 1000000 points: about 64 TB"):
        frf_surface(model, frf.frf, ["k1", "k2"], g, g)


def test_a_uniqueness_study_is_bounded_by_its_rows(two_dof):
    model, _ = two_dof
    cases = [(["1:x"], 1), (["1:x", "2:x"], 2)]
    rows = 2 * 10**12 * 3
    with pytest.raises(InputError, match=rf"^starts=1000000000000 \(2 cases x 3 noise levels: {rows} updates\): about "
                                         rf"{_budget.size(rows * _budget.STUDY_ROW_BYTES)} for the study's rows"):
        fu.define_study(model, cases, starts=10**12, noise=[0.01, 0.02])


def test_local_workers_have_a_hard_cap(two_dof):
    model, _ = two_dof
    study = fu.define_study(model, [(["1:x", "2:x"], 2)], starts=2)
    with pytest.raises(InputError, match="workers=100000: at most 256 worker processes"):
        fu.run_study(study, workers=100_000)


def test_a_global_search_population_is_bounded(ex):
    model, frf = fu.load_model(ex / "two_dof.toml"), fu.load_test_data(ex / "two_dof_frf.json")
    with pytest.raises(InputError, match=r"^method_options\['popsize'\]=1000000000000: about 128 TB"):
        fu.global_search(model, frf, method_options={"popsize": 10**12})  # 32 bytes x 2 x 2 parameters
    with pytest.raises(TypeError, match=r"global_search: method_options\['maxiter'\] must be an integer"):
        fu.global_search(model, frf, method_options={"maxiter": "many"})


def test_posterior_counts_are_bounded_by_the_parameters(two_dof, memory):
    model, data = two_dof
    memory(500_000)
    # 5,000 samples of two parameters: 5,000 x 48 x 2 = 480 kB: within; 6,000: 576 kB: not
    with pytest.raises(InputError, match=r"^samples=6000: about 576 kB for the samples \(about 96 bytes each\)"):
        fu.posterior(model, data, samples=6000, predictive=0, starts=1, measurement_std={"eigenvalue": 0.01})


# ------------------------------------------------------------------------------ the estimates
@pytest.mark.parametrize("model_file, data_file, batched", [
    ("two_dof.toml", "two_dof_frequencies.json", None), ("two_dof.toml", "two_dof_frequencies.json", False),
    (DATA / "figure2.toml", DATA / "figure2_test.json", None), (DATA / "figure2.toml", DATA / "figure2_test.json", False),
    ("truss.toml", "truss_damaged.json", False), ("two_dof.toml", "two_dof_frf.json", False),
])
def test_a_starts_record_is_what_the_estimate_says(ex, model_file, data_file, batched):
    """The estimate of a start's record bounds what it holds (tracemalloc) from above, within a
    factor of two."""
    model, data = fu.load_model(ex / model_file), fu.load_test_data(ex / data_file)
    fu.multistart(model, data, starts=2, batched=batched, max_nfev=20)  # caches, compilation
    n = 30
    gc.collect()
    tracemalloc.start()
    try:
        res = fu.multistart(model, data, starts=n, batched=batched, max_nfev=50)
        gc.collect()
        held, _ = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    estimate = _budget.start_bytes(_budget.residual_count(data), len(res.names), batched is None,
                                _budget.block_count(data))
    assert 0.5 * estimate <= held / n <= estimate, (held / n, estimate)


def test_available_memory_is_what_the_kernel_says():
    text = Path("/proc/meminfo").read_text()
    avail = int(re.search(r"MemAvailable:\s+(\d+) kB", text).group(1)) * 1024
    assert abs(_budget.available_memory() - avail) < 0.2 * avail + 2**28


# ------------------------------------------------------------------------------ time
class Clock:
    def __init__(self):
        self.t = 0.0

    def __call__(self):
        return self.t


def test_the_pace_of_the_first_units_announces_the_rest(monkeypatch, caplog):
    clock = Clock()
    monkeypatch.setattr(_budget.time, "perf_counter", clock)
    seen = []
    pace = _budget.Pace("starts", lambda d, t: seen.append(d))
    with caplog.at_level(logging.INFO, logger="femupdate._budget"):
        for done in range(1, 101):  # one second a start
            pace(done, 100)
            clock.t += 1.0
    assert seen == list(range(1, 101))  # the caller's progress, every time
    records = [r for r in caplog.records if r.name == "femupdate._budget"]
    assert len(records) == 1
    # the first report at t = 0 (its setup not counted), measured over two more: 97 to go at 1 s
    assert records[0].levelno == logging.WARNING
    assert records[0].getMessage() == ("femupdate: 100 starts, 97 to go: about 2 min (1 s each, measured over the 2 "
                                       "after the first)")


def test_a_short_run_is_announced_quietly(monkeypatch, caplog):
    clock = Clock()
    monkeypatch.setattr(_budget.time, "perf_counter", clock)
    pace = _budget.Pace("updates")
    with caplog.at_level(logging.INFO, logger="femupdate._budget"):
        for done in range(0, 1000, 10):
            pace(done, 1000)
            clock.t += 0.5
    (record,) = [r for r in caplog.records if r.name == "femupdate._budget"]
    assert record.levelno == logging.INFO
    # measured from t = 0 (done 0) to t = 2 s (done 40): 0.05 s an update, 960 to go
    assert "1000 updates, 960 to go: about 48 s (0.05 s each" in record.getMessage()


def test_a_multistart_says_how_long_its_starts_will_take(ex, monkeypatch, caplog):
    monkeypatch.setattr(_budget, "PACE_WINDOW", 0.0)
    model, data = fu.load_model(ex / "truss.toml"), fu.load_test_data(ex / "truss_damaged.json")
    with caplog.at_level(logging.INFO, logger="femupdate._budget"):
        fu.multistart(model, data, starts=6, batched=False)
    (record,) = [r for r in caplog.records if r.name == "femupdate._budget"]
    assert re.match(r"femupdate: 6 starts, 4 to go: about \d+ s \([\d.e-]+ s each, measured over the 1 after the "
                    r"first\)", record.getMessage()), record.getMessage()


def test_the_sampling_is_announced_from_the_measured_likelihood(caplog):
    from femupdate.bayes.run import _announce_sampling

    with caplog.at_level(logging.INFO, logger="femupdate._budget"):
        _announce_sampling(SamplerOptions(method="mcmc", ensembles=2, steps=1000), 32, 2.0, 1000)
        _announce_sampling(SamplerOptions(method="tmcmc", samples=2000, tmcmc_steps=5), 0, 0.5, 1000)
        _announce_sampling(SamplerOptions(method="laplace"), 0, 0.5, 1000)
    mcmc, tmcmc = [r for r in caplog.records if r.name == "femupdate._budget"]
    assert mcmc.levelno == logging.WARNING  # 64,000 evaluations at 2 ms: 128 s
    assert mcmc.getMessage().startswith("femupdate: MCMC, 2 x 32 walkers x 1000 steps = 64000 evaluations: about 2 min "
                                        "(2 ms a likelihood evaluation, measured in the search for the modes")
    assert tmcmc.levelno == logging.INFO  # 10,000 at 0.5 ms: 5 s
    assert "each TMCMC stage, 2000 samples x 5 moves = 10000 evaluations" in tmcmc.getMessage()
    assert ": about 5 s (0.5 ms a likelihood evaluation" in tmcmc.getMessage()


# ------------------------------------------------------------------------------ max_nfev on the compiled route
def test_max_nfev_is_bounded_by_the_iteration_histories_of_the_compiled_route(two_dof, memory):
    """The compiled route keeps every start's iterations (cost and parameters) in arrays of
    max_nfev + 1 entries made before the first iteration.  Before: max_nfev=10**7 with 200 starts
    asked NumPy for 29.8 GiB ('out of memory (try fewer modes ...)', exit 1) and 10**20 raised
    'ValueError: Maximum allowed dimension exceeded' with a traceback on the command line."""
    model, data = two_dof
    memory(10**6)
    # 10 starts x 100001 entries x (cost + 2 parameters) x 8 bytes = 24 MB
    with pytest.raises(InputError, match=r"^max_nfev=100000: about 24 MB for the iteration histories of 10 starts"):
        fu.multistart(model, data, starts=10, max_nfev=100_000, batched=True)


def test_an_astronomical_max_nfev_is_refused_by_name(two_dof):
    model, data = two_dof
    with pytest.raises(InputError, match=r"^max_nfev=100000000000000000000: about .* more than the"):
        fu.multistart(model, data, starts=3, max_nfev=10**20, batched=True)
    res = fu.multistart(model, data, starts=3, max_nfev=10**20, batched=False)   # SciPy keeps no history up front
    assert res.best is not None and res.best.success
