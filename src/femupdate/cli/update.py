"""``femupdate update``: iterative (multi-start) updating from whatever the test data hold —
measured modes, FRFs and static deflections at any dofs, alone or mixed."""

from __future__ import annotations

from pathlib import Path

import click
import numpy as np
from rich.table import Table

from .._errors import InputError, NumericalError
from .._limits import MAX_MAGNITUDE
from ..dofs import is_index
from ._common import (SCHEDULER, OUTPUT_DIR, OUTPUT_FILE, SEED, Ctx, FiniteFloat, connect_timeout_option, csv_option,
                      fitting_table, print_starts, starts_payload, emit, print_diagnostics, print_flags, fmt, json_option,
                      model_values, option_dofs, parse_regularization, parse_std, set_option, update_parameter_table,
                      update_payload, write_model_option, write_model_outputs, measured_dofs_option, load_data,
                      data_fields, damping_fields, print_damping, report_option, write_report_output)
from ..updating.results import pairing_warnings
from ..updating.run import DEFAULT_RESIDUAL
from .frf import apply_reciprocity, frf_fields, frf_line_options, frf_options, parse_damping, reciprocity_option


def problem_options(command):
    """The options of the updating problem that ``update`` and ``posterior`` share: the updated
    parameters, the residuals and pairing of the modes, the kinds of data, their standard
    deviations and the FRF residuals (:func:`problem_setup` reads them)."""
    for option in reversed((
        click.option("--params", "params_text", default=None, help="Parameters to update (default: all not fixed)."),
        click.option("--shape-scaling", type=click.Choice(["unit", "ref", "max"]), default="unit", show_default=True),
        click.option("--ref-dof", default=None,
                     help="Reference dof for --shape-scaling ref, a label or #N (default: first measured dof)."),
        click.option("--parametrisation", type=click.Choice(["relative", "log", "absolute"]), default="relative",
                     show_default=True),
        click.option("--min-mac", type=FiniteFloat(0, 1), default=0.5, show_default=True,
                     help="Pairing threshold: the MAC a pair of shaped modes must reach (--pairing mac), or that "
                          "confirms a pairing (auto)."),
        click.option("--pairing", type=click.Choice(["auto", "mac", "order", "frequency"]), default="auto",
                     show_default=True,
                     help="How test modes pair with model modes: auto (by frequency order until the shapes show a "
                          "swap, then by MAC; never abandons a start), mac (a test mode below --min-mac fails), order, "
                          "or frequency (nearest frequency, MAC deciding within 10 %)."),
        click.option("--n-modes", type=click.IntRange(min=1), default=None,
                     help="Model modes computed and paired among (default max(2T, T + 6) for T test modes)."),
        click.option("--close-modes", type=FiniteFloat(min=0, max=0.1, max_open=True), default=0.01, show_default=True,
                     help="Relative eigenvalue gap below which model modes count as repeated or close: a test mode "
                          "paired into such a group is compared with the combination of the group's shapes that fits "
                          "it best (its pairing inside the group by the measured shapes); 0: off (repeated modes "
                          "fail)."),
        click.option("--formulation", type=click.Choice(["shapes", "mac", "dynamic"]), default="shapes",
                     show_default=True,
                     help="Residuals of the measured modes: shapes (relative eigenvalue errors and scaled shape "
                          "differences), mac (relative eigenvalue errors and 1 - MAC terms), or dynamic (the modal "
                          "dynamic residual (K - lambda M) phi of every dof, the unmeasured shape entries as unknowns; "
                          "every mode needs a shape)."),
        click.option("--eigenvalues-only", is_flag=True, help="Ignore the measured shapes (frequencies only)."),
        measured_dofs_option,
        click.option("--use", "use_text", default=None, metavar="KINDS",
                     help="Kinds of data to use: modes, frf, static, comma-separated (default: all the data hold)."),
        click.option("--std-eigenvalue", "std_eigenvalue", default=None, metavar="S|S1,S2,...",
                     help="Relative std of the measured eigenvalues (for the covariance): one value, or one per test "
                          "mode; replaces the test data's std_frequency / std_eigenvalue."),
        click.option("--std-shape", "std_shape", default=None, metavar="S|S1,S2,...",
                     help="Std of the scaled shape entries (for the covariance): one value, or one per test mode; "
                          "replaces the test data's std_shape."),
        click.option("--std-frf", type=FiniteFloat(min=1 / MAX_MAGNITUDE), default=None,
                     help="Std of the FRF residual entries (weights FRFs against other data)."),
        click.option("--std-static", type=FiniteFloat(min=1 / MAX_MAGNITUDE), default=None,
                     help="Std of measured static deflections, m (weights them)."),
        frf_line_options,
        reciprocity_option,
    )):
        command = option(command)
    return command


#: the parameters of :func:`problem_options`, as the commands' functions receive them
PROBLEM_PARAMS = ("params_text", "shape_scaling", "ref_dof", "parametrisation", "min_mac", "pairing", "n_modes",
                  "close_modes", "formulation", "eigenvalues_only", "use_text", "std_eigenvalue", "std_shape", "std_frf", "std_static",
                  "residual", "lines_text", "select", "resonance", "resonance_tol", "damping_text", "reciprocity")


def problem_from_command_line(model, data):
    """:func:`problem_setup` with the options of :func:`problem_options` as the running command was
    given them."""
    params = click.get_current_context().params
    return problem_setup(model, data, **{k: params[k] for k in PROBLEM_PARAMS})


def problem_setup(model, data, *, params_text, shape_scaling, ref_dof, parametrisation, min_mac, pairing, n_modes,
                  close_modes, formulation, eigenvalues_only, use_text, std_eigenvalue, std_shape, std_frf, std_static, residual,
                  lines_text, select, resonance, resonance_tol, damping_text, reciprocity):
    """The updated parameters, the test data (regrouped by ``--reciprocity``), the kinds of data used,
    the problem's keyword options (as :func:`femupdate.update` takes them) and the ``--damping``
    given (:func:`~femupdate.cli.frf.parse_damping`; with modes alone it is compared with their
    damping ratios) from the options of :func:`problem_options`.

    Raises
    ------
    InputError
        A reference dof, standard deviations or FRF options that do not fit the data (named).
    """
    if ref_dof is not None and is_index(ref_dof):  # a label is checked, and named, by the updating itself
        (ref_dof,) = option_dofs([ref_dof], model, "--ref-dof")
    params = [p.strip() for p in params_text.split(",") if p.strip()] if params_text else None
    std_eigenvalue = parse_std(std_eigenvalue, "--std-eigenvalue", len(data.modes))
    std_shape = parse_std(std_shape, "--std-shape", len(data.modes))
    std = {k: v for k, v in (("eigenvalue", std_eigenvalue), ("shape", std_shape), ("frf", std_frf),
                             ("static", std_static)) if v is not None} or None
    use = tuple(u.strip() for u in use_text.split(",") if u.strip()) if use_text else ("modes", "frf", "static")
    from ..updating import data_kinds

    kinds = data_kinds(data, use)
    if reciprocity and "frf" not in kinds:
        raise InputError(f"--reciprocity: no FRF data are used ({', '.join(kinds)})")
    data = apply_reciprocity(data, reciprocity)
    kw = dict(shape_scaling=shape_scaling, ref_dof=ref_dof, parametrisation=parametrisation, min_mac=min_mac,
              pairing=pairing, n_modes=n_modes, use_shapes=not eigenvalues_only, measurement_std=std, use=kinds,
              formulation=formulation, close_modes=close_modes)
    damping = parse_damping(damping_text, data)  # with modes alone: compared with their damping ratios
    if "frf" in kinds:
        kw["frf_options"] = frf_options(residual, lines_text, select, resonance, resonance_tol, damping_text, data)
    else:
        given = [opt for opt, v in (("--residual", residual != DEFAULT_RESIDUAL), ("--lines", bool(lines_text)),
                                    ("--select", select is not None), ("--resonance", resonance != "skip"),
                                    ("--resonance-tol", resonance_tol != 1e-3)) if v]
        if given:
            raise InputError(f"{', '.join(given)}: FRF option(s) given, but no FRF data are used ({', '.join(kinds)})")
    return params, data, kinds, kw, damping


@click.command()
@click.argument("model_path", metavar="MODEL", type=click.Path(dir_okay=False, path_type=Path))
@click.argument("data_path", metavar="DATA", type=click.Path(dir_okay=False, path_type=Path))
@click.option("--starts", type=click.IntRange(min=1), default=1, show_default=True,
              help="1: start from the model's values; R > 1: R random starts within the bounds.")
@click.option("--seed", type=SEED, default=0, show_default=True, help="Seed of the random starts.")
@click.option("--scheduler", type=SCHEDULER, default=None, metavar="ADDR", help="Run the starts on an existing Dask cluster (tcp://host:port).")
@connect_timeout_option
@click.option("--jobs", type=click.IntRange(min=1, max=256), default=None,
              help="Local processes for the starts of large models (default: one per core when a start is worth "
                   "a process; 1: this process). The compiled route of small models uses threads instead.")
@problem_options
@click.option("--method", type=click.Choice(["trf", "dogbox", "lm"]), default="trf", show_default=True)
@click.option("--regularization", "reg_text", default=None, help="Tikhonov factor, or gcv / lcurve to choose it.")
@click.option("--max-nfev", type=click.IntRange(min=1), default=200, show_default=True)
@click.option("--sensitivity", type=click.Choice(["auto", "nelson", "modal", "static", "subspace", "adjoint", "fd"]),
              default="auto", show_default=True,
              help="Route of the eigenvector derivatives (auto: Nelson up to 1,500 dofs, adjoint/subspace above).")
@click.option("--plot", "plot_dir", type=OUTPUT_DIR, default=None,
              help="Write convergence and MAC figures to this folder.")
@write_model_option
@csv_option
@click.option("--uff", "uff_path", type=OUTPUT_FILE, default=None,
              help="Write the updated model's modes (with its nodes) as a universal file.")
@report_option
@set_option
@json_option
def update(model_path, data_path, starts, seed, scheduler, connect_timeout, jobs, params_text, shape_scaling, ref_dof, parametrisation,
           method, reg_text, min_mac, pairing, n_modes, close_modes, formulation, max_nfev, eigenvalues_only, measured_text, sensitivity, use_text, std_eigenvalue, std_shape,
           std_frf, std_static, residual, lines_text, select, resonance, resonance_tol, damping_text, reciprocity, plot_dir,
           write_model_path, csv_dir, uff_path, report_path, set_text, json_path):
    """Update MODEL's parameters iteratively from the test data in DATA: measured modes, FRFs and
    static deflections at any dofs, alone or mixed, as one problem."""
    from ..io.model_file import load_model
    from ..updating import multistart
    from ..updating import update as _update

    if jobs is not None and scheduler:
        raise InputError(f"--jobs {jobs} with --scheduler: the starts run on the cluster's workers; give one of the two")
    ctx = Ctx(json_path)
    model = load_model(model_path)
    if uff_path is not None:
        from ..io.uff.write import uff_dofs

        uff_dofs(model.dofs, "update --uff")  # before the solution: named nodes cannot be written
    values = model_values(model, set_text)
    data = load_data(data_path, model, measured_text)
    params, data, kinds, kw, damping = problem_from_command_line(model, data)
    kw.update(method=method, regularization=parse_regularization(reg_text), max_nfev=max_nfev, values=values,
              sensitivity=sensitivity)
    ms = None
    if starts == 1 and not scheduler:
        res = _update(model, data, params=params, **kw)
    else:
        from rich.progress import Progress

        with Progress(console=ctx.console, transient=True, disable=json_path == "-" or not ctx.console.is_terminal) as bar:
            task = bar.add_task("starts", total=starts)
            ms = multistart(model, data, starts=starts, seed=seed, params=params, scheduler=scheduler,
                            connect_timeout=connect_timeout, jobs=jobs,
                            progress=lambda done, total: bar.update(task, completed=done), **kw)
        if ms.best is None:
            failed = {"model": model.name, "success": False, "starts": starts_payload(ms)}
            emit(ctx, failed)
            print_starts(ctx.console, ms)
            write_report_output(ctx, report_path, failed, model=model, model_path=model_path, kind="update")
            raise NumericalError(f"none of the {starts} starts converged")
        res = ms.best
    c = ctx.console
    title = f"{model.name}: iterative update from {', '.join(kinds)} ({res.iterations} iterations, {res.nfev} evaluations)"
    if ms is not None and len(ms.fitting) > 1:
        c.print(fitting_table(ms))
        title = f"the lowest-cost solution in detail — {title}"
    c.print(update_parameter_table(res, title, {p.name: p.unit for p in model.parameters}))
    if res.pairs:
        t2 = Table(title="paired modes")
        for col in ("test", "model", "f test [Hz]", "f model [Hz]", "error", "MAC"):
            t2.add_column(col, justify="right")
        for (k, j, m), ft, fm in zip(res.pairs, res.test_frequencies_hz, res.model_frequencies_hz):
            t2.add_row(str(k + 1), str(j + 1), fmt(ft), fmt(fm), f"{(fm - ft) / ft * 100:+.3f} %",
                       "-" if not np.isfinite(m) else f"{m:.4f}")
        c.print(t2)
    if res.blocks:
        t3 = Table(title="data blocks")
        for col in ("block", "residuals", "scale", "cost", "weighting"):
            t3.add_column(col, justify="left" if col in ("block", "weighting") else "right")
        for b in res.blocks:
            t3.add_row(b["label"], str(b["n_residuals"]), fmt(b["scale"]), f"{b['cost']:.4g}", b["weighting"])
        c.print(t3)
    is_frf = hasattr(res, "frac")
    if is_frf:
        c.print("FRAC per dof: " + ", ".join(f"{d} {v:.4f}" for d, v in res.frac.items()))
        for s in res.skipped:
            c.print(f"skipped FRF line {s['line']} ({fmt(s['omega_rad_s'])} rad/s): {s['reason']}")
    print_diagnostics(c, res)
    if res.formulation:
        c.print(f"formulation: {res.formulation}")
    if getattr(res, "solver", ""):
        c.print(f"eigen-solutions: {res.solver}")
    if res.pairing:
        how = ("the dynamic formulation pairs no modes while it solves: the model's modes at the solution paired for "
               "this report" if res.formulation == "dynamic" else "the pairs at the solution made")
        c.print(f"pairing: {res.pairing['policy']} ({how} by {res.pairing['used']})")
    for sw in res.swaps[:5]:
        c.print(f"mode swap: test mode {sw['test_mode'] + 1} moved from model mode {sw['from_model_mode'] + 1} to "
                f"{sw['to_model_mode'] + 1} (by {sw.get('rule', 'mac')}, evaluation {sw['evaluation']})")
    if len(res.swaps) > 5:
        c.print(f"... and {len(res.swaps) - 5} more mode swap(s) (all in the JSON under 'swaps')")
    for line in pairing_warnings(res):
        c.print(line)
    damping_out = damping_fields(data, {k: float(fm) for (k, _, _), fm in zip(res.pairs, res.model_frequencies_hz)},
                                 damping)
    print_damping(c, data, damping_out)
    if ms is not None:
        print_starts(c, ms)
    for note in [*data.notes, *res.notes]:
        c.print(f"note: {note}", markup=False)
    payload = update_payload(model, data, res, ms)
    payload["notes"] = [*data.notes, *payload["notes"]]
    payload.update(data_fields(data))
    payload["formulation"] = res.formulation or None
    payload["solver"] = getattr(res, "solver", "") or None
    if damping_out is not None:
        payload["damping_ratio"] = damping_out
    if res.expanded_shapes is not None:  # the dynamic formulation's full shapes, per test mode {dof: value}
        payload["expanded_shapes"] = [dict(zip(model.dofs, map(float, col))) for col in res.expanded_shapes.T]
    print_flags(ctx, payload["flags"])
    if plot_dir is not None:
        names = []
        if "modes" in kinds:
            from ..correlation import correlate as _correlate
            from ..modal import model_modes
            from ..plot.updating import save_update_figures

            corr = _correlate(data, model_modes(model, res.parameters, n_modes=min(model.n_dofs, 2 * len(data.modes) + 4)))
            names += save_update_figures(plot_dir, res.history, corr.mac)
        if is_frf and data.frf is not None:
            from ..frf import frf as model_frf
            from ..plot.frf import save_frf_update_figures

            frf = data.frf
            used = np.isin(frf.omega, res.omega)
            _, xa = model_frf(model, frf.omega[used], frf.force, frf.dofs, res.parameters, kw["frf_options"]["damping"])
            names += [n for n in save_frf_update_figures(plot_dir, res.history, frf.omega[used], frf.dofs,
                                                         frf.response[used], xa) if n not in names]
            if data.n_frf_sets > 1:
                c.print(f"the FRF overlay shows the first excitation's set ({', '.join(frf.force)})")
        c.print(f"figures: {', '.join(str(plot_dir / n) for n in names)}")
    if is_frf:
        payload.update(frf_fields(res))
    emit(ctx, payload)
    write_report_output(ctx, report_path, payload, model=model, data=data, model_path=model_path, kind="update",
                        before=None if values is None else dict(zip(model.parameter_names, values)),
                        damping=kw.get("frf_options", {}).get("damping"))
    if not res.success:
        if write_model_path or csv_dir or uff_path:
            c.print("not written: the updated model, tables and modes (the update did not converge)")
        raise NumericalError(f"the update did not converge: {res.message}")
    write_model_outputs(ctx, model_path, data_path, "update", model, res.parameters, res.names, res.cost,
                        write_model_path, csv_dir, res, damping_out)
    if uff_path is not None:
        from ..io.uff import write_uff_modes
        from ..modal import model_modes

        write_uff_modes(uff_path, model_modes(model, res.parameters), nodes=model.nodes, model_name=model.name)
        c.print(f"wrote the updated model's modes {uff_path}")
