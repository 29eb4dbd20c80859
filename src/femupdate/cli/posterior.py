"""``femupdate posterior``: Bayesian updating — the posterior of the updated parameters (Laplace at
each solution, ensemble MCMC, or TMCMC with the evidence), its summaries, solutions, diagnostics
and predictions."""

from __future__ import annotations

import math
from pathlib import Path

import click
import numpy as np
from rich.table import Table

from .._errors import InputError, NumericalError
from ..bayes.noise import noise_lines
from ..damping.view import DampedView
from ._common import CHECKPOINT_FILE, INPUT_FILE, OUTPUT_FILE, Ctx, OutputPath, fmt, load_data, model_values, write_report_output
from ._groups import GroupedCommand, execution_group, sampler_group, starts_group
from .outputs import Outputs, outputs_group, phased_progress
from .problem import ProblemSpec, problem_group
from .testpoints import TestPointsSpec, test_points_group


def _default_checkpoint(json_path, method: str):
    if method == "laplace" or not json_path or json_path == "-":
        return None
    p = Path(json_path)
    return p.with_name(p.stem + ".checkpoint.npz")


def parse_priors(items) -> dict:
    """``--prior NAME=SPEC`` (repeatable; ``k1=normal(8,1)``) as {name: prior}."""
    from ..priors import parse_prior

    out: dict = {}
    for item in items or ():
        name, eq, spec = str(item).partition("=")
        name = name.strip()
        if not eq or not name:
            raise InputError(f"--prior: {item!r} is not of the form NAME=SPEC (e.g. k1=normal(8,1))")
        if name in out:
            raise InputError(f"--prior: {name!r} is given twice")
        out[name] = parse_prior(spec, f"--prior {name}")
    return out


@click.command(cls=GroupedCommand)
@click.argument("model_path", metavar="MODEL", type=INPUT_FILE)
@click.argument("data_paths", metavar="DATA...", nargs=-1, required=True, type=INPUT_FILE)
@sampler_group()
@click.option("--prior", "prior_items", multiple=True, metavar="NAME=SPEC",
              help="A parameter's prior, replacing the model file's: uniform, normal(MEAN,STD) or "
                   "lognormal(MEDIAN,STD_LOG); repeat for several (default: uniform within the bounds).")
@click.option("--noise", type=click.Choice(["auto", "stated", "estimate"]), default="auto", show_default=True,
              help="stated: the test data's (or --std-*) standard deviations; estimate: a common noise scale on the "
                   "residuals, estimated (Jeffreys' prior, integrated out); auto: stated when every residual has one.")
@starts_group(default=20, starts_help="Random starts of the search for distinct solutions (1: one update from the "
                                      "model's values).", seed_help="Seed of every random stream.",
              title="Search for solutions", alpha=False)
@execution_group(jobs=False, scheduler_help="Run the starts, MCMC ensembles and TMCMC chunks on an existing Dask "
                                            "cluster (tcp://host:port).")
@click.option("--checkpoint", "checkpoint_path", type=CHECKPOINT_FILE, default=None,
              help="The sampler's state after each MCMC segment or TMCMC stage, resumed by a re-run (default: next "
                   "to the --json output; none with --json - or without --json).")
@problem_group()
@test_points_group()
@click.option("--samples-out", "samples_path", type=OutputPath("file", suffixes=(".csv", ".npz"), why="its format"),
              default=None, metavar="FILE.csv|.npz", help="Write the posterior samples (CSV or NumPy .npz).")
@outputs_group(plot="Write corner, trace and predictive figures to this folder.", report=True)
def posterior(model_path, data_paths, sampler, prior_items, noise, starts, execution, checkpoint_path,
              problem: ProblemSpec, test_points: TestPointsSpec, samples_path, outputs: Outputs):
    """The posterior of MODEL's parameters given the test data in DATA (several files: repeated tests,
    their likelihoods multiplied): how far to trust the updated model."""
    from ..bayes import posterior as _posterior
    from ..io.model_file import load_model

    from ._damping import damped_model

    ctx = Ctx(outputs.json_path)
    damped = damped_model(model_path)  # a [damping] table: damping parameters among the unknowns
    model = load_model(model_path) if damped is None else damped.model
    if damped is not None and test_points.tolerance is not None:
        raise InputError("--test-points with a [damping] table: not taken in this version; give the test data at "
                         "the model's dofs")
    values = model_values(model if damped is None else DampedView(damped), outputs.set_text)
    priors = parse_priors(prior_items)
    sets, run, mapped = [], None, None
    for path in data_paths:
        if test_points.tolerance is None:
            data = load_data(path, model, problem.measured_text)
        elif mapped is None:  # the first file's test points placed on the mesh; the others' renamed as its
            model, data, mapped = test_points.load(model_path, model, path, problem.measured_text)
            test_points.announce(ctx, mapped)
        else:
            data = test_points.relabel(mapped, test_points.read(path, problem.measured_text), path)
        run = problem.resolve(model, data)
        sets.append(run.data)
    assert run is not None
    if damped is not None and run.damping is not None and not getattr(run.damping, "undamped", True):
        raise InputError("--damping sets the FRF damping of an undamped model; this model's damping is its [damping] "
                         "table (its parameters in the posterior): leave --damping out")
    options = run.options.replace(noise=run.options.noise.replace(basis=noise))
    checkpoint = checkpoint_path if checkpoint_path is not None else _default_checkpoint(outputs.json_path,
                                                                                         sampler.method)
    c = ctx.console
    labels = {"solutions": "searching solutions", "mcmc": "MCMC steps", "tmcmc": "TMCMC (tempering)"}
    with phased_progress(labels, console=c, quiet=outputs.json_path == "-") as tick:
        try:
            res = _posterior(damped or model, sets if len(sets) > 1 else sets[0], params=run.params, values=values,
                             priors=priors, sampler=sampler, starts=starts, execution=execution, checkpoint=checkpoint,
                             progress=tick, options=options)
        except KeyboardInterrupt:  # Ctrl-C or SIGTERM: the checkpoint holds the finished steps
            if checkpoint is not None and sampler.method != "laplace" and Path(checkpoint).exists():
                c.print(f"interrupted: the finished steps are in {checkpoint}; run the same command again to resume",
                        markup=False)
            raise
    _print(c, DampedView(damped) if damped is not None else model, res, sets[0], checkpoint)
    payload = res.to_json()
    if mapped is not None:
        payload["test_points"] = mapped.to_json()
    if samples_path is not None:
        from ..io.samples import write_samples

        write_samples(samples_path, res)
        c.print(f"wrote {res.samples.shape[0]} samples to {samples_path}")
    if outputs.plot_dir is not None:
        from ..plot.posterior import save_posterior_figures

        names = save_posterior_figures(outputs.plot_dir, res, sets[0].frequencies_hz if sets[0].modes else None)
        c.print(f"figures: {', '.join(str(outputs.plot_dir / n) for n in names)}")
    outputs.emit(ctx, payload)
    write_report_output(ctx, outputs.report_path, res, model_path=model_path)
    if not res.success:
        raise NumericalError(f"the {sampler.method} sampler's checks failed (see the warnings): the posterior is "
                             "doubtful")


def _print(c, model, res, data, checkpoint) -> None:
    names = list(res.names)
    flagged = ((res.noise or {}).get("model_error") or {}).get("verdict") == "model error"
    t = Table(title=("MODEL ERROR (the best fit does not reproduce the data within the noise) — " if flagged else "")
              + f"{model.name}: posterior by {res.method} ({res.samples.shape[0]} samples, {res.route} likelihood, "
                f"{res.diagnostics.get('evaluations', 0)} evaluations, {res.seconds:.1f} s)")
    for col in ("parameter", "prior", "median", "mean", "std", f"{res.level:.0%} interval"):
        t.add_column(col, justify="left" if col in ("parameter", "prior") else "right")
    units = {p.name: p.unit for p in model.parameters}
    for n in names:
        lo, hi = res.interval[n]
        t.add_row(f"{n} [{units[n]}]" if units.get(n) else n, res.prior.get(n, ""), fmt(res.median[n]), fmt(res.mean[n]), fmt(res.std[n]),
                  f"[{fmt(lo)}, {fmt(hi)}]")
    c.print(t)
    held = (res.damping or {}).get("held") or {}
    if held:
        c.print("damping parameters held: " + ", ".join(f"{n} = {fmt(v)}" for n, v in held.items()), markup=False)
    if len(names) > 1:
        corr = res.correlation
        pairs = [(abs(corr[i, j]), i, j) for i in range(len(names)) for j in range(i) if np.isfinite(corr[i, j])]
        strong = sorted(pairs, reverse=True)[:5]
        if strong:
            c.print("largest correlations: " + ", ".join(f"{names[i]}-{names[j]} {corr[i, j]:+.2f}" for _, i, j in strong))
    shown = [k for k, (m, f) in enumerate(zip(res.modes, res.mode_fractions)) if k == 0 or max(m.probability, f) >= 1e-4]
    ts = Table(title=f"{len(res.modes)} distinct solution(s)")
    ts.add_column("solution", justify="right")
    for n in names:
        ts.add_column(n, justify="right")
    ts.add_column("probability (Laplace)", justify="right")
    ts.add_column("share of samples", justify="right")
    ts.add_column("starts", justify="right")
    for k in shown:
        m, frac = res.modes[k], res.mode_fractions[k]
        ts.add_row(str(k + 1), *(fmt(m.parameters[n]) for n in names), f"{m.probability:.3f}", f"{frac:.3f}",
                   str(m.count))
    if len(shown) < len(res.modes):
        ts.caption = (f"and {len(res.modes) - len(shown)} more with probability and share below 1e-4 (local minima; "
                      "all in the JSON under 'solutions')")
    c.print(ts)
    if math.isfinite(res.log_evidence):
        err = f" ± {res.log_evidence_error:.2g}" if math.isfinite(res.log_evidence_error) else ""
        c.print(f"log evidence: {res.log_evidence:.4f}{err} ({'TMCMC' if res.method == 'tmcmc' else 'Laplace'})")
    nz = res.noise
    for line in noise_lines(nz, res.level):
        c.print(line, markup=False)
    d = res.diagnostics
    if res.method == "mcmc":
        c.print(f"MCMC: {d['ensembles']} ensemble(s) x {d['walkers']} walkers x {d['steps']} steps ({d['burn']} burn-in), "
                f"acceptance {d['acceptance']:.2f}; ESS " + ", ".join(f"{n} {d['ess'][n]:.0f}" for n in names)
                + "; split R-hat " + ", ".join(f"{n} {d['rhat'][n]:.3f}" for n in names))
    elif res.method == "tmcmc":
        c.print(f"TMCMC: {d['n_stages']} stages, last stage acceptance {d['acceptance']:.2f}, "
                f"{d['distinct']} distinct resampled points of {d['samples']}")
    if res.predictive and data.modes:
        tp = Table(title="posterior predictive of the paired modes")
        for col in ("test", "f test [Hz]", "f model [Hz]", f"{res.level:.0%} interval", "new measurement", "MAC"):
            tp.add_column(col, justify="right")
        for e in res.predictive["modes"]:
            k = e["test_mode"]
            f = e.get("frequency_hz")
            meas = (e.get("measured_frequency_hz") or {}).get("interval")
            mac = e.get("mac")
            tp.add_row(str(k + 1), fmt(data.frequencies_hz[k]), fmt(f["mean"]) if f else "-",
                       f"[{fmt(f['interval'][0])}, {fmt(f['interval'][1])}]" if f else "-",
                       f"[{fmt(meas[0])}, {fmt(meas[1])}]" if meas and all(map(math.isfinite, meas)) else "-",
                       f"{mac['mean']:.4f}" if mac else "-")
        c.print(tp)
        _print_damping_ratios(c, res, data)
    if checkpoint is not None and res.method != "laplace":
        c.print(f"checkpoint: {checkpoint}")
    for w in res.warnings:
        c.print(f"warning: {w}", markup=False)
    for n in [*data.notes, *res.notes]:
        c.print(f"note: {n}", markup=False)


def _print_damping_ratios(c, res, data) -> None:
    """A damped model's posterior predictive of the paired modes' damping ratios."""
    rows = [e for e in res.predictive["modes"] if e.get("damping_ratio")]
    if not rows:
        return
    t = Table(title="posterior predictive of the paired modes' damping ratios")
    for col in ("test", "ζ test", "ζ model", "std", f"{res.level:.0%} interval"):
        t.add_column(col, justify="right")
    for e in rows:
        k, z = e["test_mode"], e["damping_ratio"]
        zt = data.modes[k].damping_ratio
        t.add_row(str(k + 1), "-" if zt is None else f"{zt:.5g}", f"{z['mean']:.5g}", f"{z['std']:.2g}",
                  f"[{z['interval'][0]:.5g}, {z['interval'][1]:.5g}]")
    c.print(t)


__all__ = ["posterior", "parse_priors"]
