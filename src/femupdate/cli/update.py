"""``femupdate update``: iterative (multi-start) updating from whatever the test data hold —
measured modes, FRFs and static deflections at any dofs, alone or mixed."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import click
import numpy as np
from rich.table import Table

from .._errors import InputError, NumericalError
from ._common import (INPUT_FILE, Ctx, fitting_table, fmt, percent, model_values, print_diagnostics, print_damping, print_flags,
                      print_starts, update_parameter_table, write_model_outputs, write_report_output)
from ._damping import damped_figures, damped_model as _damped_model, model_part as _model_part, print_damped, view as _view
from ._groups import GroupedCommand, execution_group, solver_group, starts_group
from .outputs import Outputs, outputs_group
from .problem import ProblemSpec, problem_group
from .testpoints import TestPointsSpec, test_points_group
from ._rom import rom_group
from ..updating.results import MultiStartResult, UpdateResult, pairing_warnings

if TYPE_CHECKING:
    from ..blackbox import BlackBoxResult



@click.command(cls=GroupedCommand)
@click.argument("model_path", metavar="MODEL", type=INPUT_FILE)
@click.argument("data_path", metavar="DATA", type=INPUT_FILE)
@starts_group()
@execution_group()
@problem_group(sensitivity=True)
@test_points_group()
@solver_group()
@rom_group()
@outputs_group(plot=True, model_out=True, uff=True, report=True)
def update(model_path, data_path, starts, execution, problem: ProblemSpec, test_points: TestPointsSpec, solver,
           rom, outputs: Outputs):
    """Update MODEL's parameters iteratively from the test data in DATA: measured modes, FRFs and
    static deflections at any dofs, alone or mixed, as one problem."""
    from ..io.model_file import load_model
    from ..updating import multistart
    from ..updating import update as _update

    ctx = Ctx(outputs.json_path)
    damped = _damped_model(model_path)  # a [damping] table: stiffness, mass and damping updated together
    model = load_model(model_path) if damped is None else damped.model
    if outputs.uff_path is not None:
        from ..io.uff.write import uff_dofs

        uff_dofs(model.dofs, "update --uff")  # before the solution: named nodes cannot be written
    if damped is not None and test_points.tolerance is not None:  # before the test points read the model file
        _damped_run(damped, True, None)
    values = model_values(model if damped is None else _view(damped), outputs.set_text)
    base = model  # the structure's own dofs (--uff), whatever the test points add
    model, data, mapped = test_points.load(model_path, model, data_path, problem.measured_text)
    test_points.announce(ctx, mapped)
    run = problem.resolve(model, data, solver)
    data = run.data
    if damped is not None:
        model = _damped_run(damped, mapped, run)
    before = None if values is None else dict(zip(model.parameter_names, values))
    result: UpdateResult | MultiStartResult
    res: UpdateResult | None
    ms: MultiStartResult | None = None
    box = _black_box(model_path) if damped is None else None
    bb: BlackBoxResult | None = None
    if rom is not None:
        if damped is not None:
            raise InputError("--reduced-basis with a [damping] table: the reduced route takes undamped models")
        if box is not None:
            raise InputError("--reduced-basis with a [blackbox] model: the black box's fitted model is "
                             "re-probed near the answer, not reduced; give one of the two")
        result, res, ms = _reduced(ctx, outputs, model, data, starts, execution, run, values, rom)
    elif box is not None and starts.starts == 1:
        bb = _black_box_update(ctx, box, execution, data, run, values)
        result = res = bb.result
        model = bb.model
    elif starts.starts == 1 and not execution.scheduler:
        result = res = _update(damped or model, data, params=run.params, values=values, options=run.options)
    else:
        with outputs.progress(ctx, "starts", starts.starts) as tick:
            result = ms = multistart(damped or model, data, starts, params=run.params, values=values, execution=execution,
                                     progress=tick, options=run.options)
        res = ms.best
    result = result.with_context(damping=run.damping, before=before)
    payload, report_of = _payload(result, mapped, bb)
    if res is None:
        assert ms is not None
        outputs.emit(ctx, payload)
        print_starts(ctx.console, ms)
        write_report_output(ctx, outputs.report_path, result, model_path=model_path, test_points=mapped)
        raise NumericalError(f"none of the {starts.starts} starts converged")
    _print(ctx, model, data, run.kinds, res, ms, payload)
    if outputs.plot_dir is not None and damped is not None:
        damped_figures(ctx, damped, data, res, outputs.plot_dir)
    elif outputs.plot_dir is not None:
        _figures(ctx, model, data, run, res, outputs.plot_dir)
    outputs.emit(ctx, payload)
    if mapped is None:
        write_report_output(ctx, outputs.report_path, result, model_path=model_path)
    else:
        write_report_output(ctx, outputs.report_path, report_of, model=model, data=data, model_path=model_path,
                            before=before, damping=run.damping, kind="update", test_points=mapped)
    if not res.success:
        if outputs.write_model_path or outputs.csv_dir or outputs.uff_path or outputs.write_back_dir:
            ctx.console.print("not written: the updated model, tables and modes (the update did not converge)")
        raise NumericalError(f"the update did not converge: {res.message}")
    rb = payload.get("reduced_basis")
    if rb is not None and not rb["passed"]:
        raise NumericalError("the reduced model's answer did not pass its full-model check (reduced_basis.checks "
                             "in the JSON); raise --rom-rounds or --rom-points")
    if damped is not None:
        res = _model_part(ctx, damped, res, outputs)
    write_model_outputs(ctx, model_path, data_path, "update", model, res.parameters, res.names, res.cost,
                        outputs.write_model_path, outputs.csv_dir, res, payload.get("damping_ratio"), outputs.write_back_dir)
    if outputs.uff_path is not None:
        from ..io.uff import write_uff_modes
        from ..modal import model_modes

        write_uff_modes(outputs.uff_path, model_modes(base, res.parameters), nodes=base.nodes, model_name=model.name)
        ctx.console.print(f"wrote the updated model's modes {outputs.uff_path}")


def _black_box_update(ctx: Ctx, box, execution, data, run, values) -> BlackBoxResult:
    """One start on a ``[blackbox]`` model: updated, its code re-run near the answer (said)."""
    from ..blackbox import update_black_box

    if execution.scheduler:  # the runs of the command go to the cluster
        box.scheduler, box.connect_timeout = execution.scheduler, execution.connect_timeout
    if execution.jobs:
        box.jobs = execution.jobs
    bb = update_black_box(box, data, params=run.params, values=values, options=run.options)
    last = bb.rounds[-1]
    ctx.console.print(f"black box: {len(bb.rounds)} round(s), {bb.runs} run(s) of the command "
                      f"({bb.cache_hits} from the cache); at the answer the command's own run and the fitted model "
                      f"agree to {last['matrix_deviation']:.2g} (matrices) and {last['frequency_deviation']:.2g} "
                      "(paired frequencies)")
    return bb


def _payload(result, mapped, bb) -> tuple[dict, object]:
    """The result's JSON with the test points' map and the black box's rounds, and what the
    report is drawn from (the JSON when there is a map, else the result)."""
    payload = result.to_json()
    report_of: object = result
    if mapped is not None:  # the map into the result, and the report drawn from it
        payload["test_points"] = mapped.to_json()
        if payload.get("expanded_shapes"):  # on the mesh's own dofs, u = T q
            payload["expanded_shapes"] = [mapped.mesh_shape_json(sh) for sh in payload["expanded_shapes"]]
        report_of = payload
    if bb is not None:
        payload["black_box"] = {"rounds": bb.rounds, "runs": bb.runs, "cache_hits": bb.cache_hits}
    return payload, report_of


def _damped_run(damped, mapped, run):
    """The engine's view of a damped model; options that do not apply to it refused by name."""
    if mapped is not None:
        raise InputError("--test-points with a [damping] table: not taken in this version; give the test data at "
                         "the model's dofs")
    if run.damping is not None and not run.damping.undamped:
        raise InputError("--damping sets the FRF damping of an undamped model; this model's damping is its [damping] "
                         "table (updated with the other parameters): leave --damping out")
    return _view(damped)


def _black_box(model_path):
    """The black box of a model file with a ``[blackbox]`` table (its runs re-probed near the
    answer), else None."""
    from ..io.model_file import read_toml

    if Path(model_path).suffix.lower() != ".toml" or "blackbox" not in read_toml(model_path):
        return None
    from ..blackbox import load_black_box

    return load_black_box(model_path)


def _reduced(ctx: Ctx, outputs: Outputs, model, data, starts, execution, run, values, rom):
    """``update --reduced-basis``: the reduced route, one start or several."""
    from ..rom.update import rom_multistart, rom_update

    if starts.starts == 1 and not execution.scheduler:
        res = rom_update(model, data, rom=rom, params=run.params, values=values, options=run.options)
        return res, res, None
    with outputs.progress(ctx, "starts", starts.starts) as tick:
        ms = rom_multistart(model, data, starts, rom=rom, params=run.params, values=values, execution=execution,
                            progress=tick, options=run.options)
    return ms, ms.best, ms


def _print(ctx: Ctx, model, data, kinds, res, ms, payload: dict) -> None:
    """The terminal summary of an update: the parameters, the pairs, the data blocks, the FRF
    figures, the diagnostics, the pairing, the damping ratios, the starts and the notes."""
    c = ctx.console
    title = f"{model.name}: iterative update from {', '.join(kinds)} ({res.iterations} iterations, {res.nfev} evaluations)"
    if (res.diagnostics is not None and res.diagnostics.model_error.get("verdict") == "model error"):
        title = f"MODEL ERROR (the best fit does not reproduce the data within the noise) — {title}"
    if ms is not None and len(ms.fitting) > 1:
        c.print(fitting_table(ms))
        title = f"the lowest-cost solution in detail — {title}"
    c.print(update_parameter_table(res, title, {p.name: p.unit for p in model.parameters}))
    if res.damping:
        print_damped(c, res)
    if res.pairs:
        c.print(_pairs_table(res))
    if res.blocks:
        t3 = Table(title="data blocks")
        for col in ("block", "residuals", "scale", "cost", "weighting"):
            t3.add_column(col, justify="left" if col in ("block", "weighting") else "right")
        for b in res.blocks:
            t3.add_row(b["label"], str(b["n_residuals"]), fmt(b["scale"]), f"{b['cost']:.4g}", b["weighting"])
        c.print(t3)
    if hasattr(res, "frac"):
        c.print("FRAC per dof: " + ", ".join(f"{d} {v:.4f}" for d, v in res.frac.items()))
        for s in res.skipped:
            c.print(f"skipped FRF line {s['line']} ({fmt(s['omega_rad_s'])} rad/s): {s['reason']}")
    print_diagnostics(c, res)
    if res.formulation:
        c.print(f"formulation: {res.formulation}")
    if getattr(res, "solver", ""):
        c.print(f"eigen-solutions: {res.solver}")
    _print_pairing(c, res)
    print_damping(c, data, payload.get("damping_ratio"))
    if ms is not None:
        print_starts(c, ms)
    for note in payload["notes"]:
        c.print(f"note: {note}", markup=False)
    print_flags(ctx, payload["flags"])


def _pairs_table(res) -> Table:
    t = Table(title="paired modes")
    for col in ("test", "model", "f test [Hz]", "f model [Hz]", "error", "MAC"):
        t.add_column(col, justify="right")
    for (k, j, m), ft, fm in zip(res.pairs, res.test_frequencies_hz, res.model_frequencies_hz):
        t.add_row(str(k + 1), str(j + 1), fmt(ft), fmt(fm), percent((fm - ft) / ft, 3),
                  "-" if not np.isfinite(m) else f"{m:.4f}")
    return t


def _print_pairing(c, res) -> None:
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


def _figures(ctx: Ctx, model, data, run, res, plot_dir) -> None:
    """Convergence and MAC figures (modes), the FRF overlay (FRFs)."""
    names: list[str] = []
    if "modes" in run.kinds:
        from ..correlation import correlate as _correlate
        from ..modal import model_modes
        from ..plot.updating import save_update_figures

        corr = _correlate(data, model_modes(model, res.parameters, n_modes=min(model.n_dofs, 2 * len(data.modes) + 4)))
        names += save_update_figures(plot_dir, res.history, corr.mac)
    if hasattr(res, "frac") and data.frf is not None:
        from ..frf import frf as model_frf
        from ..plot.frf import save_frf_update_figures

        frf = data.frf
        used = np.isin(frf.omega, res.omega)
        _, xa = model_frf(model, frf.omega[used], frf.force, frf.dofs, res.parameters, run.options.frf.damping)
        names += [n for n in save_frf_update_figures(plot_dir, res.history, frf.omega[used], frf.dofs,
                                                     frf.response[used], xa) if n not in names]
        if data.n_frf_sets > 1:
            ctx.console.print(f"the FRF overlay shows the first excitation's set ({', '.join(frf.force)})")
    ctx.console.print(f"figures: {', '.join(str(plot_dir / n) for n in names)}")


__all__ = ["update"]
