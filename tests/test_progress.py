"""Progress of long runs: nothing for short ones, a bar on a terminal, rate-limited lines when the
output is piped (femupdate.cli.outputs.progress)."""

from __future__ import annotations

import io

from femupdate.cli.outputs import phased_progress, progress


class Clock:
    def __init__(self):
        self.t = 0.0

    def __call__(self):
        return self.t


def test_piped_progress_is_quiet_first_then_rate_limited():
    clock, out = Clock(), io.StringIO()
    with progress("starts", 100, stream=out, after=5.0, every=10.0, clock=clock) as tick:
        for k in range(1, 101):
            clock.t = k * 0.5  # 0.5 s per start: 50 s in all
            tick(k)
    lines = out.getvalue().splitlines()
    # nothing in the first 5 s, then at most one line per 10 s, and the last start said
    assert lines[0].startswith("femupdate: starts 10/100 (10%), 5 s, about 45 s left")
    assert len(lines) == 6 and lines[-1].startswith("femupdate: starts 100/100 (100%)")


def test_short_and_quiet_runs_print_nothing():
    clock, out = Clock(), io.StringIO()
    with progress("starts", 10, stream=out, clock=clock) as tick:
        for k in range(1, 11):
            clock.t = k * 0.1
            tick(k)
    with progress("starts", 10, stream=out, quiet=True, clock=clock) as tick:
        clock.t = 1e6
        tick(3)
    assert out.getvalue() == ""


def test_a_run_that_ends_early_says_where_it_stopped():
    clock, out = Clock(), io.StringIO()
    with progress("MCMC steps", 1000, stream=out, after=1.0, every=100.0, clock=clock) as tick:
        clock.t = 2.0
        tick(100)
        clock.t = 3.0
        tick(150)  # rate-limited: not shown until the run ends (here, early: a sampler that stopped at its target)
    assert out.getvalue().splitlines()[-1].startswith("femupdate: MCMC steps 150/1000")


def test_phases_each_under_their_label():
    clock, out = Clock(), io.StringIO()
    with phased_progress({"solutions": "searching solutions", "tmcmc": "TMCMC"}, stream=out, clock=clock) as tick:
        for k in range(1, 21):
            clock.t = k
            tick("solutions", k, 20)
        for k in range(1, 6):
            clock.t = 20 + 30 * k
            tick("tmcmc", k, 5)
    text = out.getvalue()
    assert "searching solutions 20/20" in text and "TMCMC 5/5" in text


def test_the_first_build_notice_gives_a_measured_estimate(tmp_path, monkeypatch):
    from femupdate.updating.batched import driver

    monkeypatch.setattr(driver, "_record_path", lambda: tmp_path / driver.BUILD_RECORD)
    # no build recorded here: the idle figure, scaled by the load (two processes share the cores)
    idle = driver.build_estimate(cores=2, load=0.0)
    busy = driver.build_estimate(cores=2, load=6.0)
    assert f"about {driver.BUILD_SECONDS_IDLE:.0f} s on an idle machine" in idle
    assert f"about {driver.BUILD_SECONDS_IDLE * 4:.0f} s at the current load (6.0 on 2 cores)" in busy
    # once a build has been timed here, its own time
    driver._record_build(47.2)
    assert driver.build_estimate(cores=2, load=0.0).startswith("the last build here took 47 s")


def test_many_runs_in_one_process_keep_one_announcement_formatter():
    """Each run of the command line sets femupdate's announcement formatter on the log handlers;
    runs in one process (as the tests, or a notebook, run them) must not wrap it again and again
    (after some hundred runs a log record raised RecursionError)."""
    import logging

    from click.testing import CliRunner

    from femupdate.cli._app import _Plain, cli

    runner = CliRunner()
    for _ in range(3):
        runner.invoke(cli, ["report", "no-such-result.json"])
    wrapped = [h.formatter for h in logging.getLogger().handlers if isinstance(h.formatter, _Plain)]
    assert wrapped and all(not isinstance(f.inner, _Plain) for f in wrapped)
