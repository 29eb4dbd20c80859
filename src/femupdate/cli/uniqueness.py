"""``femupdate uniqueness``: Monte Carlo uniqueness study of a model over measurement plans, built
from option groups; the study's result writes its own JSON and report
(:mod:`femupdate.uniqueness.study.record`, kind ``uniqueness``)."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import click
from rich.table import Table

from .._errors import InputError
from ._common import CHECKPOINT_FILE, INPUT_FILE, Ctx, FiniteFloat, model_values, write_report_output
from ._groups import GroupedCommand, execution_group, option_group, starts_group
from .outputs import Outputs, outputs_group


@dataclasses.dataclass(frozen=True)
class Plans:
    """The cases of the study as typed: the measured dof sets, the numbers of modes, the unknowns,
    the noise levels and ``--exact`` (:func:`plans_group`)."""

    dofs_text: str | None
    modes_text: str | None
    params_text: str | None
    noise_text: str | None
    exact: bool

    def resolve(self, model) -> tuple[list[tuple[tuple[str, ...], int]], list[str] | None, list[float]]:
        """The cases ``[(measured dofs, number of modes)]`` (default: the paper's nested plans,
        the first n dofs for n = 1..N, times 1..N modes), the unknowns and the noise levels.

        Raises
        ------
        InputError
            Models of more than 12 dofs without ``--measured-dofs`` or ``--modes``; sets, modes
            or noise levels that do not parse (the option named).
        """
        from ..uniqueness.study import nested_dof_sets, parse_measured_dofs, parse_modes

        N = model.n_dofs
        if self.dofs_text is None and N > 12:
            raise InputError(f"--measured-dofs is required for models of more than 12 dofs (this one has {N})")
        if self.modes_text is None and N > 12:
            raise InputError(f"--modes is required for models of more than 12 dofs (this one has {N})")
        sets = parse_measured_dofs(self.dofs_text, model.dofs) if self.dofs_text is not None else nested_dof_sets(model)
        modes = parse_modes(self.modes_text) if self.modes_text is not None else list(range(1, N + 1))
        params = [p.strip() for p in self.params_text.split(",") if p.strip()] if self.params_text else None
        return [(s, m) for s in sets for m in modes], params, _noise_levels(self.noise_text)


def _noise_levels(text: str | None) -> list[float]:
    noise = []
    for item in (text or "").split(","):
        if item.strip():
            try:
                noise.append(float(item))
            except ValueError:
                raise InputError(f"--noise: {item.strip()!r} is not a number") from None
            if not (math.isfinite(noise[-1]) and 0 <= noise[-1] <= 1):
                raise InputError(f"--noise: {item.strip()!r} is not a relative level from 0 to 1")
    return noise


def plans_group():
    """``--measured-dofs``, ``--modes``, ``--params``, ``--noise``, ``--exact`` -> ``plans``: :class:`Plans`."""
    return option_group(
        "Cases", "plans", Plans,
        click.option("--measured-dofs", "dofs_text", default=None, metavar="SETS",
                     help="Measured dof sets, ';' between sets, ',' within, labels or #N: \"1:x,2:x;1:x\". "
                          "Default: the paper's plans, the first n model dofs for n = 1..N."),
        click.option("--modes", "modes_text", default=None, metavar="LIST",
                     help="Numbers of measured (lowest) modes: 1,2,3 or 1-6 (default 1..N)."),
        click.option("--params", "params_text", default=None, help="Unknown parameters (default: all not fixed)."),
        click.option("--noise", "noise_text", default=None, metavar="LIST",
                     help="Relative noise levels to study as well, e.g. 0.001,0.01."),
        click.option("--exact", is_flag=True,
                     help="Also solve single-sensor cases exactly (frequencies only; small models)."),
    )


@dataclasses.dataclass(frozen=True)
class Updates:
    """What every update of the study does (:func:`updates_group`): its evaluations, pairing
    threshold, the draw of the starts and when two solutions are the same."""

    max_nfev: int
    min_mac: float
    rel_tol: float
    cost_tol: float
    log_uniform: bool


def updates_group():
    """``--max-nfev``, ``--min-mac``, ``--rel-tol``, ``--cost-tol``, ``--log-uniform`` -> ``updates``: :class:`Updates`."""
    return option_group(
        "Each update", "updates", Updates,
        click.option("--max-nfev", type=click.IntRange(min=1), default=200, show_default=True),
        click.option("--min-mac", type=FiniteFloat(0, 1), default=0.5, show_default=True),
        click.option("--rel-tol", type=FiniteFloat(min=0, max=1, min_open=True), default=1e-4, show_default=True,
                     help="Two solutions are the same within this relative tolerance."),
        click.option("--cost-tol", type=FiniteFloat(min=0, max=1e150, min_open=True), default=1e-12, show_default=True,
                     help="A converged start reproduces the data when its cost is at most this."),
        click.option("--log-uniform", is_flag=True, help="Draw the starts log-uniformly within the bounds."),
    )


@dataclasses.dataclass(frozen=True)
class Units:
    """How the study's work is split and kept (:func:`units_group`): a local Dask cluster, the
    checkpoint and the rows per work unit."""

    workers: int | None
    checkpoint_path: Path | None
    unit_rows: int

    def checkpoint(self, json_path) -> Path | None:
        """``--checkpoint``, or by default next to the ``--json`` output (none with ``--json -``
        or without ``--json``)."""
        if self.checkpoint_path is not None:
            return self.checkpoint_path
        if not json_path or json_path == "-":
            return None
        p = Path(json_path)
        return p.with_name(p.stem + ".checkpoint.json")


def units_group():
    """``--workers``, ``--checkpoint``, ``--unit-rows`` -> ``units``: :class:`Units`."""
    return option_group(
        "Work units", "units", Units,
        click.option("--workers", type=click.IntRange(min=1), default=None,
                     help="Start a local Dask cluster of N worker processes (default: run in this process)."),
        click.option("--checkpoint", "checkpoint_path", type=CHECKPOINT_FILE, default=None,
                     help="Checkpoint file (default: next to the --json output; none with --json - or without --json)."),
        click.option("--unit-rows", type=click.IntRange(min=1), default=4096, show_default=True,
                     help="Rows (case x start) solved together per work unit: one checkpoint step, one Dask task "
                          "(lower it to spread a study over a cluster)."),
    )


@click.command(cls=GroupedCommand)
@click.argument("model_path", metavar="MODEL", type=INPUT_FILE)
@plans_group()
@starts_group(default=100, starts_help="Random starts per case.", seed_help="Seed of the random starts (and noise).")
@execution_group(jobs=False, scheduler_help="Run on an existing Dask cluster (tcp://host:port).")
@units_group()
@updates_group()
@outputs_group(plot="Write the heat map of the (dof set, modes) table to this folder.", report=True)
def uniqueness(model_path, plans: Plans, starts, execution, units: Units, updates: Updates, outputs: Outputs):
    """Can MODEL's parameters be identified from these measurements? Random-start updates per case.

    The model's parameter values (or --set) are the truth; for every measured dof set and number
    of modes, noise-free data are simulated and the update is run from --starts random starts
    within the parameter bounds; the converged solutions are clustered and counted.
    """
    from ..io.model_file import load_model
    from ..uniqueness.study import define_study, run_study

    ctx = Ctx(outputs.json_path)
    model = load_model(model_path)
    values = model_values(model, outputs.set_text)
    cases, params, noise = plans.resolve(model)
    study = define_study(model, cases, starts=starts.starts, seed=starts.seed, values=values, params=params,
                         noise=noise, min_mac=updates.min_mac, max_nfev=updates.max_nfev, unit_rows=units.unit_rows,
                         log_uniform=updates.log_uniform)
    checkpoint = units.checkpoint(outputs.json_path)
    c = ctx.console
    c.print(f"{model.name}: {model.n_dofs} dofs, {len(study.names)} unknowns ({', '.join(study.names)}); "
            f"{len(study.cases)} cases x {starts.starts} starts" + (f" x {1 + len(noise)} noise levels" if noise else "")
            + f" = {study.n_rows} updates in {len(study.units())} unit(s)"
            + (f"; checkpoint {checkpoint}" if checkpoint else ""))
    try:
        with outputs.progress(ctx, "updates", study.n_rows) as tick:
            res = run_study(study, scheduler=execution.scheduler, workers=units.workers, checkpoint=checkpoint,
                            rel_tol=updates.rel_tol, connect_timeout=execution.connect_timeout, alpha=starts.alpha,
                            cost_tol=updates.cost_tol, progress=tick)
    except KeyboardInterrupt:
        if checkpoint:
            c.print(f"interrupted: finished units are in {checkpoint}; run the same command again to resume")
        raise
    if plans.exact:
        res = res.with_exact()
    _print_table(c, res)
    _print_agreement(c, res.criteria_agreement())
    c.print(f"{res.route}: {res.units_computed} unit(s) computed, {res.units_resumed} resumed, {res.seconds:.2f} s")
    if outputs.plot_dir is not None:
        from ..plot.uniqueness import save_uniqueness_figure

        name = save_uniqueness_figure(Path(outputs.plot_dir) / "uniqueness.png", [case.to_dict(study.names)
                                                                                 for case in res.cases],
                                      title=f"{model.name}: {starts.starts} starts per case")
        res = res.with_figure(Path(outputs.plot_dir) / name)
        c.print(f"figure: {res.figure}")
    outputs.emit(ctx, res.to_json())
    write_report_output(ctx, outputs.report_path, res, model_path=model_path)


def _print_table(console, res) -> None:
    """Cases as a table: one row per case with verdict, counts and conditioning."""
    t = Table(title=f"uniqueness study: {res.study.n_starts} random starts per case")
    for col in ("dofs", "m", "verdict", "sol.", "conv.", "loc.", "n.c.", "fail", "cond(S)", "paper"):
        t.add_column(col, justify="left" if col in ("dofs", "verdict") else "right", no_wrap=col != "dofs",
                     min_width=8 if col == "dofs" else None)
    for cr in res.cases:
        d = cr.case.measured_dofs
        label = f"first {len(d)}" if d == res.study.model.dofs[:len(d)] else ",".join(d)
        cond = "inf" if not math.isfinite(cr.condition_number) else f"{cr.condition_number:.3g}"
        t.add_row(label, str(cr.case.n_modes), cr.verdict, str(len(cr.solutions)), str(cr.converged),
                  str(cr.local_minima), str(cr.not_converged), str(cr.failed), cond,
                  "yes" if cr.criteria["paper"].satisfied else "no")
    console.print(t)
    console.print("sol.: distinct solutions reproducing the data; conv./loc./n.c./fail: starts converged, at a local "
                  "minimum, out of evaluations, failed; cond(S): normalised sensitivity matrix at the truth; "
                  "paper: mn >= L and n > 1")
    for line in _distinct_lines(res):
        console.print(line, markup=False)


def _distinct_lines(res) -> list[str]:
    """How solutions were told apart, and per case ill-conditioning said apart from non-uniqueness:
    a unique but ill-conditioned case with its ± statement, a non-unique one with why its
    solutions are separated."""
    from ..distinct import conditioning_line

    bases = {cr.distinct.get("basis") for cr in res.cases if cr.distinct and cr.solutions}
    out = [f"solutions told apart at alpha = {res.alpha:g} against the covariance of a fit at the cost tolerance "
           "(sensitivity at the truth)" + ("; by the relative tolerance where a case has none" if "tolerance" in bases
                                          else "")]
    for cr in res.cases:
        d = cr.case.measured_dofs
        name = f"dofs {','.join(d)}, {cr.case.n_modes} mode(s)"
        cond = (cr.distinct or {}).get("conditioning")
        if cr.unique and cond and cond.get("ill_conditioned"):
            out.append(f"{name}: unique, {conditioning_line(cond)}")
        elif cr.unique is False and len(cr.solutions) > 1:
            seps = [s for s in (cr.distinct or {}).get("separations", []) if s]
            kinds = sorted({s["basis"] for s in seps})
            out.append(f"{name}: non-unique: {len(cr.solutions)} separated solutions reproduce the data"
                       + (f" (separated by: {', '.join(kinds)})" if kinds else ""))
    return out if len(out) <= 21 else out[:21] + [f"... and {len(out) - 21} more case(s): see cases[].distinct in the JSON"]


def _print_agreement(console, agree: dict) -> None:
    """Each counting criterion against the study's verdicts (nothing when no case has a verdict)."""
    from ..uniqueness.criteria import CRITERIA

    t = Table(title="counting criteria against the study's verdicts")
    for col in ("criterion", "formula", "agrees", "wrong on (n x m)"):
        t.add_column(col, no_wrap=col != "wrong on (n x m)")
    for name, a in agree.items():
        wrong = a["wrong_cases"]
        t.add_row(name, CRITERIA[name][1], f"{a['agrees']}/{a['of']}", ", ".join(wrong[:8]) + (" ..." if len(wrong) > 8 else ""))
    if agree:
        console.print(t)


__all__ = ["uniqueness", "Plans", "Updates", "Units", "plans_group", "updates_group", "units_group"]
