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
from ._common import (OUTPUT_DIR, OUTPUT_FILE, SCHEDULER, SEED, Ctx, FiniteFloat, OutputPath, connect_timeout_option,
                      data_fields, emit, fmt, json_option, load_data, model_values, set_option)
from .update import problem_from_command_line, problem_options


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


def posterior_payload(model, res, data_sets) -> dict:
    """The JSON of a posterior run (docs/file-formats.md, ``posterior``)."""
    names = list(res.names)
    modes = []
    for m, frac in zip(res.modes, res.mode_fractions):
        modes.append({"parameters": m.parameters, "probability": m.probability, "sample_share": frac,
                      "std": m.std, "covariance": m.covariance, "log_weight": m.log_weight, "cost": m.cost,
                      "count": m.count, "inside_bounds": m.inside, "at_bounds": list(m.at_bounds),
                      "note": m.note or None})
    return {
        "model": model.name,
        "method": res.method,
        "success": res.success,
        "updated": names,
        "parameters": res.median,
        "mean": res.mean, "median": res.median, "std": res.std, "interval": res.interval, "level": res.level,
        "covariance": res.covariance, "correlation": res.correlation,
        "solutions": modes,
        "log_evidence": res.log_evidence, "log_evidence_error": res.log_evidence_error,
        "noise": res.noise,
        "prior": res.prior,
        "predictive": res.predictive,
        "diagnostics": res.diagnostics,
        "n_samples": int(res.samples.shape[0]),
        "data_sets": len(data_sets),
        "route": res.route, "seed": res.seed, "seconds": res.seconds,
        "warnings": res.warnings, "notes": res.notes,
    }


@click.command()
@click.argument("model_path", metavar="MODEL", type=click.Path(dir_okay=False, path_type=Path))
@click.argument("data_paths", metavar="DATA...", nargs=-1, required=True, type=click.Path(dir_okay=False, path_type=Path))
@click.option("--method", type=click.Choice(["laplace", "mcmc", "tmcmc"]), default="laplace", show_default=True,
              help="laplace: a Gaussian at each solution, with its probability; mcmc: ensemble sampler (emcee) for "
                   "one solution; tmcmc: transitional MCMC for several solutions, with the log-evidence.")
@click.option("--prior", "prior_items", multiple=True, metavar="NAME=SPEC",
              help="A parameter's prior, replacing the model file's: uniform, normal(MEAN,STD) or "
                   "lognormal(MEDIAN,STD_LOG); repeat for several (default: uniform within the bounds).")
@click.option("--noise", type=click.Choice(["auto", "stated", "estimate"]), default="auto", show_default=True,
              help="stated: the test data's (or --std-*) standard deviations; estimate: a common noise scale on the "
                   "residuals, estimated (Jeffreys' prior, integrated out); auto: stated when every residual has one.")
@click.option("--starts", type=click.IntRange(min=1), default=20, show_default=True,
              help="Random starts of the search for distinct solutions (1: one update from the model's values).")
@click.option("--seed", type=SEED, default=0, show_default=True, help="Seed of every random stream.")
@click.option("--samples", type=click.IntRange(min=2), default=4000, show_default=True,
              help="Laplace draws, or the TMCMC population.")
@click.option("--walkers", type=click.IntRange(min=2), default=None, help="MCMC walkers per ensemble (default max(64, 8 L) on the compiled route, max(32, 4 L) "
                   "otherwise).")
@click.option("--ensembles", type=click.IntRange(min=1), default=2, show_default=True,
              help="Independent MCMC ensembles (one Dask task each).")
@click.option("--steps", type=click.IntRange(min=2), default=2000, show_default=True, help="MCMC steps per walker.")
@click.option("--burn", type=click.IntRange(min=0), default=None, help="MCMC steps discarded (default steps / 4).")
@click.option("--segment", type=click.IntRange(min=1), default=250, show_default=True,
              help="MCMC steps between checkpoints (one Dask round).")
@click.option("--target-ess", type=FiniteFloat(min=1), default=None,
              help="Stop MCMC once every parameter's effective sample size reaches this.")
@click.option("--tmcmc-steps", type=click.IntRange(min=1), default=5, show_default=True,
              help="Metropolis moves per chain and TMCMC stage.")
@click.option("--chunks", type=click.IntRange(min=1), default=8, show_default=True,
              help="TMCMC's chains in this many pieces (random streams; Dask tasks).")
@click.option("--level", type=FiniteFloat(0, 1, min_open=True, max_open=True), default=0.95, show_default=True,
              help="Probability of the credible intervals.")
@click.option("--scheduler", type=SCHEDULER, default=None, metavar="ADDR",
              help="Run the starts, MCMC ensembles and TMCMC chunks on an existing Dask cluster (tcp://host:port).")
@connect_timeout_option
@click.option("--checkpoint", "checkpoint_path", type=OUTPUT_FILE, default=None,
              help="The sampler's state after each MCMC segment or TMCMC stage, resumed by a re-run (default: next "
                   "to the --json output; none with --json - or without --json).")
@problem_options
@click.option("--samples-out", "samples_path", type=OutputPath("file", suffixes=(".csv", ".npz"), why="its format"),
              default=None, metavar="FILE.csv|.npz", help="Write the posterior samples (CSV or NumPy .npz).")
@click.option("--plot", "plot_dir", type=OUTPUT_DIR, default=None,
              help="Write corner, trace and predictive figures to this folder.")
@set_option
@json_option
def posterior(model_path, data_paths, method, prior_items, noise, starts, seed, samples, walkers, ensembles, steps, burn,
              segment, target_ess, tmcmc_steps, chunks, level, scheduler, connect_timeout, checkpoint_path, params_text,
              shape_scaling, ref_dof, parametrisation, min_mac, pairing, n_modes, close_modes, formulation, eigenvalues_only,
              measured_text, use_text, std_eigenvalue, std_shape, std_frf, std_static, residual, lines_text, select,
              resonance, resonance_tol, damping_text, reciprocity, samples_path, plot_dir, set_text, json_path):
    """The posterior of MODEL's parameters given the test data in DATA (several files: repeated tests,
    their likelihoods multiplied): how far to trust the updated model."""
    from ..bayes import posterior as _posterior
    from ..io.model_file import load_model

    ctx = Ctx(json_path)
    model = load_model(model_path)
    values = model_values(model, set_text)
    priors = parse_priors(prior_items)
    sets = []
    kw: dict = {}
    for path in data_paths:
        data = load_data(path, model, measured_text)
        params, data, kinds, kw, _ = problem_from_command_line(model, data)
        sets.append(data)
    checkpoint = checkpoint_path if checkpoint_path is not None else _default_checkpoint(json_path, method)
    c = ctx.console
    from rich.progress import BarColumn, Progress, TextColumn, TimeRemainingColumn

    with Progress(TextColumn("{task.description}"), BarColumn(), TextColumn("{task.percentage:>3.0f} %"),
                  TimeRemainingColumn(), console=c, transient=True,
                  disable=json_path == "-" or not c.is_terminal) as bar:
        tasks: dict = {}

        def progress(phase, done, total):
            label = {"solutions": "searching solutions", "mcmc": "MCMC steps", "tmcmc": "TMCMC (tempering)"}[phase]
            if phase not in tasks:
                tasks[phase] = bar.add_task(label, total=total)
            bar.update(tasks[phase], completed=done, total=total)

        res = _posterior(model, sets if len(sets) > 1 else sets[0], method=method, params=params, priors=priors,
                         noise=noise, starts=starts, seed=seed, samples=samples, walkers=walkers, ensembles=ensembles,
                         steps=steps, burn=burn, segment=segment, target_ess=target_ess, tmcmc_steps=tmcmc_steps,
                         chunks=chunks, level=level, scheduler=scheduler, connect_timeout=connect_timeout,
                         checkpoint=checkpoint, progress=progress, values=values, **kw)
    _print(c, model, res, sets[0], checkpoint)
    payload = posterior_payload(model, res, sets)
    payload.update(data_fields(sets[0]))
    payload["notes"] = [*sets[0].notes, *payload["notes"]]
    if samples_path is not None:
        from ..io.samples import write_samples

        write_samples(samples_path, res)
        c.print(f"wrote {res.samples.shape[0]} samples to {samples_path}")
    if plot_dir is not None:
        from ..plot.posterior import save_posterior_figures

        names = save_posterior_figures(plot_dir, res, sets[0].frequencies_hz if sets[0].modes else None)
        c.print(f"figures: {', '.join(str(plot_dir / n) for n in names)}")
    emit(ctx, payload)
    if not res.success:
        raise NumericalError(f"the {method} sampler's checks failed (see the warnings): the posterior is doubtful")


def _print(c, model, res, data, checkpoint) -> None:
    names = list(res.names)
    t = Table(title=f"{model.name}: posterior by {res.method} ({res.samples.shape[0]} samples, {res.route} likelihood, "
                    f"{res.diagnostics.get('evaluations', 0)} evaluations, {res.seconds:.1f} s)")
    for col in ("parameter", "prior", "median", "mean", "std", f"{res.level:.0%} interval"):
        t.add_column(col, justify="left" if col in ("parameter", "prior") else "right")
    units = {p.name: p.unit for p in model.parameters}
    for n in names:
        lo, hi = res.interval[n]
        t.add_row(f"{n} [{units[n]}]" if units.get(n) else n, res.prior.get(n, ""), fmt(res.median[n]), fmt(res.mean[n]), fmt(res.std[n]),
                  f"[{fmt(lo)}, {fmt(hi)}]")
    c.print(t)
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
    if nz.get("scale"):
        s = nz["scale"]
        c.print(f"noise scale (estimated): median {s['median']:.4g}, {res.level:.0%} interval "
                f"[{s['interval'][0]:.4g}, {s['interval'][1]:.4g}]")
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
    if checkpoint is not None and res.method != "laplace":
        c.print(f"checkpoint: {checkpoint}")
    for w in res.warnings:
        c.print(f"warning: {w}", markup=False)
    for n in [*data.notes, *res.notes]:
        c.print(f"note: {n}", markup=False)


__all__ = ["posterior", "posterior_payload", "parse_priors"]
