"""``femupdate uniqueness``: Monte Carlo uniqueness study of a model over measurement plans."""

from __future__ import annotations

import math
from pathlib import Path

import click
from rich.table import Table

from .._errors import InputError
from ._common import INPUT_FILE, CHECKPOINT_FILE, SCHEDULER, OUTPUT_DIR, SEED, Ctx, FiniteFloat, connect_timeout_option, emit, json_option, parameter_fields, report_option, write_report_output, model_values, set_option


def _default_checkpoint(json_path):
    if not json_path or json_path == "-":
        return None
    p = Path(json_path)
    return p.with_name(p.stem + ".checkpoint.json")


def _criteria_agreement(cases) -> dict:
    """Per criterion: on how many cases with a verdict its prediction matches the study's."""
    out = {}
    judged = [c for c in cases if c.unique is not None]
    for name in (judged[0].criteria if judged else {}):
        hits = sum(c.criteria[name].satisfied == c.unique for c in judged)
        wrong = [f"{c.case.n_measured}x{c.case.n_modes}" for c in judged if c.criteria[name].satisfied != c.unique]
        out[name] = {"agrees": hits, "of": len(judged), "wrong_cases": wrong}
    return out


def _exact_for(model, names, case, truth):
    """Exact solution set from the case's frequencies (single-sensor cases), or why not."""
    from ..uniqueness.exact import exact_solutions

    try:
        ex = exact_solutions(model, values=truth, n_modes=case.n_modes, params=names)
    except InputError as exc:
        return {"skipped": str(exc)}
    return {"n_solutions": None if not ex.zero_dimensional else len(ex.solutions), "zero_dimensional": ex.zero_dimensional,
            "n_complex": ex.n_complex, "solutions": [{"parameters": s.parameters, "exact": s.exact} for s in ex.solutions],
            "exact_data": ex.exact_data, "notes": ex.notes}


@click.command()
@click.argument("model_path", metavar="MODEL", type=INPUT_FILE)
@click.option("--measured-dofs", "dofs_text", default=None, metavar="SETS",
              help="Measured dof sets, ';' between sets, ',' within, labels or #N: \"1:x,2:x;1:x\". "
                   "Default: the paper's plans, the first n model dofs for n = 1..N.")
@click.option("--modes", "modes_text", default=None, metavar="LIST",
              help="Numbers of measured (lowest) modes: 1,2,3 or 1-6 (default 1..N).")
@click.option("--starts", type=click.IntRange(min=1), default=100, show_default=True, help="Random starts per case.")
@click.option("--seed", type=SEED, default=0, show_default=True, help="Seed of the random starts (and noise).")
@click.option("--scheduler", type=SCHEDULER, default=None, metavar="ADDR", help="Run on an existing Dask cluster (tcp://host:port).")
@connect_timeout_option
@click.option("--workers", type=click.IntRange(min=1), default=None,
              help="Start a local Dask cluster of N worker processes (default: run in this process).")
@click.option("--params", "params_text", default=None, help="Unknown parameters (default: all not fixed).")
@click.option("--noise", "noise_text", default=None, metavar="LIST",
              help="Relative noise levels to study as well, e.g. 0.001,0.01.")
@click.option("--checkpoint", "checkpoint_path", type=CHECKPOINT_FILE, default=None,
              help="Checkpoint file (default: next to the --json output; none with --json - or without --json).")
@click.option("--unit-rows", type=click.IntRange(min=1), default=4096, show_default=True,
              help="Rows (case x start) solved together per work unit: one checkpoint step, one Dask task "
                   "(lower it to spread a study over a cluster).")
@click.option("--max-nfev", type=click.IntRange(min=1), default=200, show_default=True)
@click.option("--min-mac", type=FiniteFloat(0, 1), default=0.5, show_default=True)
@click.option("--rel-tol", type=FiniteFloat(min=0, max=1, min_open=True), default=1e-4, show_default=True,
              help="Two solutions are the same within this relative tolerance.")
@click.option("--cost-tol", type=FiniteFloat(min=0, max=1e150, min_open=True), default=1e-12, show_default=True,
              help="A converged start reproduces the data when its cost is at most this.")
@click.option("--log-uniform", is_flag=True, help="Draw the starts log-uniformly within the bounds.")
@click.option("--exact", is_flag=True, help="Also solve single-sensor cases exactly (frequencies only; small models).")
@click.option("--plot", "plot_dir", type=OUTPUT_DIR, default=None,
              help="Write the heat map of the (dof set, modes) table to this folder.")
@report_option
@set_option
@json_option
def uniqueness(model_path, dofs_text, modes_text, starts, seed, scheduler, connect_timeout, workers, params_text, noise_text,
               checkpoint_path, unit_rows, max_nfev, min_mac, rel_tol, cost_tol, log_uniform, exact, plot_dir,
               report_path, set_text, json_path):
    """Can MODEL's parameters be identified from these measurements? Random-start updates per case.

    The model's parameter values (or --set) are the truth; for every measured dof set and number
    of modes, noise-free data are simulated and the update is run from --starts random starts
    within the parameter bounds; the converged solutions are clustered and counted.
    """
    from rich.progress import BarColumn, Progress, TextColumn, TimeRemainingColumn

    from ..io.model_file import load_model
    from ..uniqueness.study import define_study, nested_dof_sets, parse_measured_dofs, parse_modes, run_study

    ctx = Ctx(json_path)
    model = load_model(model_path)
    values = model_values(model, set_text)
    N = model.n_dofs
    if dofs_text is None and N > 12:
        raise InputError(f"--measured-dofs is required for models of more than 12 dofs (this one has {N})")
    if modes_text is None and N > 12:
        raise InputError(f"--modes is required for models of more than 12 dofs (this one has {N})")
    sets = parse_measured_dofs(dofs_text, model.dofs) if dofs_text is not None else nested_dof_sets(model)
    modes = parse_modes(modes_text) if modes_text is not None else list(range(1, N + 1))
    params = [p.strip() for p in params_text.split(",") if p.strip()] if params_text else None
    noise = []
    for item in (noise_text or "").split(","):
        if item.strip():
            try:
                noise.append(float(item))
            except ValueError:
                raise InputError(f"--noise: {item.strip()!r} is not a number") from None
            if not (math.isfinite(noise[-1]) and 0 <= noise[-1] <= 1):
                raise InputError(f"--noise: {item.strip()!r} is not a relative level from 0 to 1")
    study = define_study(model, [(s, m) for s in sets for m in modes], starts=starts, seed=seed, values=values,
                         params=params, noise=noise, min_mac=min_mac, max_nfev=max_nfev, unit_rows=unit_rows,
                         log_uniform=log_uniform)
    checkpoint = checkpoint_path if checkpoint_path is not None else _default_checkpoint(json_path)
    c = ctx.console
    c.print(f"{model.name}: {N} dofs, {len(study.names)} unknowns ({', '.join(study.names)}); "
            f"{len(study.cases)} cases x {starts} starts" + (f" x {1 + len(noise)} noise levels" if noise else "")
            + f" = {study.n_rows} updates in {len(study.units())} unit(s)"
            + (f"; checkpoint {checkpoint}" if checkpoint else ""))
    try:
        with Progress(TextColumn("{task.description}"), BarColumn(), TextColumn("{task.completed}/{task.total}"),
                      TimeRemainingColumn(), console=c, transient=True,
                      disable=json_path == "-" or not c.is_terminal) as bar:
            task = bar.add_task("updates", total=study.n_rows)
            res = run_study(study, scheduler=scheduler, workers=workers, checkpoint=checkpoint, rel_tol=rel_tol,
                            connect_timeout=connect_timeout,
                            cost_tol=cost_tol, progress=lambda done, total: bar.update(task, completed=done))
    except KeyboardInterrupt:
        if checkpoint:
            c.print(f"interrupted: finished units are in {checkpoint}; run the same command again to resume")
        raise
    payload = res.to_dict()
    payload["criteria_agreement"] = _criteria_agreement(res.cases)
    payload.update(parameter_fields(model, list(study.names)))
    if exact:
        truth = dict(zip(model.parameter_names, study.truth))
        exact: dict[int, dict] = {}  # frequencies only: the answer depends on the number of modes alone
        for case, cd in zip(res.cases, payload["cases"]):
            if case.case.n_measured == 1:
                m = case.case.n_modes
                if m not in exact:
                    exact[m] = _exact_for(model, list(study.names), case.case, truth)
                cd["exact"] = exact[m]
    _print_table(c, res)
    agree = payload["criteria_agreement"]
    t = Table(title="counting criteria against the study's verdicts")
    for col in ("criterion", "formula", "agrees", "wrong on (n x m)"):
        t.add_column(col, no_wrap=col != "wrong on (n x m)")
    from ..uniqueness.criteria import CRITERIA

    for name, a in agree.items():
        wrong = a["wrong_cases"]
        t.add_row(name, CRITERIA[name][1], f"{a['agrees']}/{a['of']}", ", ".join(wrong[:8]) + (" ..." if len(wrong) > 8 else ""))
    if agree:
        c.print(t)
    c.print(f"{res.route}: {res.units_computed} unit(s) computed, {res.units_resumed} resumed, {res.seconds:.2f} s")
    if plot_dir is not None:
        from ..plot.uniqueness import save_uniqueness_figure

        name = save_uniqueness_figure(Path(plot_dir) / "uniqueness.png", payload["cases"],
                                      title=f"{model.name}: {starts} starts per case")
        payload["figure"] = str(Path(plot_dir) / name)
        c.print(f"figure: {payload['figure']}")
    emit(ctx, payload)
    write_report_output(ctx, report_path, payload, model=model, model_path=model_path, kind="uniqueness")


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
