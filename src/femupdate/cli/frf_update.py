"""``femupdate frf-update``: iterative, multi-start or global updating from FRFs measured at any
dofs (eqs. 30-32), built from option groups; the result writes its own JSON and report
(:mod:`femupdate.updating.record`, kind ``frf-update``)."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import click
import numpy as np

from .._errors import InputError, NumericalError
from .._limits import MAX_MAGNITUDE
from ..options import NoiseOptions, SolverOptions
from ._common import (INPUT_FILE, Ctx, FiniteFloat, fitting_table, fmt, model_values, parse_regularization, print_diagnostics,
                      print_flags, print_starts, update_parameter_table, write_model_outputs, write_report_output)
from ._groups import GroupedCommand, execution_group, option_group, starts_group
from ._damping import damped_figures, damped_model, model_part, print_damped, view
from .frf import apply_reciprocity, frf_line_options, frf_options, reciprocity_option
from .outputs import Outputs, outputs_group
from .testpoints import TestPointsSpec, test_points_group


@dataclasses.dataclass(frozen=True)
class FRFProblemSpec:
    """The FRF updating problem as typed: the updated parameters, the residual's options, the
    standard deviation of its entries and ``--reciprocity`` (:func:`frf_problem_group`)."""

    params_text: str | None
    lines: dict  #: the options of the FRF residual as typed (:func:`~femupdate.cli.frf.frf_line_options`)
    std: float | None
    reciprocity: bool

    def resolve(self, data):
        """The parameters (None: every one not fixed), the :class:`~femupdate.options.FRFOptions`
        (``--damping fit`` fitted to ``data``'s damping ratios) and the
        :class:`~femupdate.options.NoiseOptions` of ``--std``.

        Raises
        ------
        InputError
            ``--lines`` or ``--damping`` that do not parse or do not fit the data (named).
        """
        from ..options import FRFOptions

        params = [p.strip() for p in self.params_text.split(",") if p.strip()] if self.params_text else None
        frf = FRFOptions(**frf_options(**self.lines, data=data))
        return params, frf, NoiseOptions(std=None if self.std is None else {"frf": self.std})


def frf_problem_group():
    """``--params``, the FRF residual's options, ``--std``, ``--reciprocity`` -> ``problem``:
    :class:`FRFProblemSpec`."""
    return option_group(
        "Updating problem", "problem",
        lambda params_text, std, reciprocity, **lines: FRFProblemSpec(params_text, lines, std, reciprocity),
        click.option("--params", "params_text", default=None, help="Parameters to update (default: all not fixed)."),
        frf_line_options,
        click.option("--std", type=FiniteFloat(min=1 / MAX_MAGNITUDE), default=None,
                     help="Std of the residual entries (covariance)."),
        reciprocity_option,
    )


@dataclasses.dataclass(frozen=True)
class GlobalSearch:
    """``--global METHOD``, ``--runs``, ``--global-residual``: a global search, then a local polish."""

    method: str
    runs: int
    residual: str


def global_group():
    """``--global``, ``--runs``, ``--global-residual`` -> ``search``: a :class:`GlobalSearch`, or
    None without ``--global``."""
    return option_group(
        "Global search", "search",
        lambda global_method, runs, global_residual: (
            None if global_method is None else GlobalSearch(global_method, runs, global_residual)),
        click.option("--global", "global_method",
                     type=click.Choice(["differential_evolution", "basinhopping", "dual_annealing"]),
                     default=None, help="Global search within the bounds, then a local polish."),
        click.option("--runs", type=click.IntRange(min=1), default=1, show_default=True, help="Independent global runs."),
        click.option("--global-residual", type=click.Choice(["linear", "relative", "log"]), default="log",
                     show_default=True, help="Residual of the global stage (the polish uses --residual)."),
    )


def _solver_group():
    """``--parametrisation``, ``--method``, ``--regularization``, ``--max-nfev`` -> ``solver``:
    :class:`~femupdate.options.SolverOptions`."""
    return option_group(
        "Solver", "solver",
        lambda parametrisation, method, reg_text, max_nfev: SolverOptions(
            method=method, max_nfev=max_nfev, parametrisation=parametrisation,
            regularization=parse_regularization(reg_text)),
        click.option("--parametrisation", type=click.Choice(["relative", "log", "absolute"]), default="relative",
                     show_default=True),
        click.option("--method", type=click.Choice(["trf", "dogbox", "lm"]), default="trf", show_default=True),
        click.option("--regularization", "reg_text", default=None, help="Tikhonov factor, or gcv / lcurve."),
        click.option("--max-nfev", type=click.IntRange(min=1), default=200, show_default=True),
    )


@click.command("frf-update", cls=GroupedCommand)
@click.argument("model_path", metavar="MODEL", type=INPUT_FILE)
@click.argument("data_path", metavar="DATA", type=INPUT_FILE)
@starts_group(seed_help=None)
@execution_group(jobs=False, scheduler_help="Run the starts / runs on an existing Dask cluster.")
@global_group()
@frf_problem_group()
@_solver_group()
@test_points_group()
@outputs_group(plot="Write the FRF overlay and convergence figures to this folder.", model_out=True, report=True)
def frf_update_command(model_path, data_path, starts, execution, search: GlobalSearch | None,
                       problem: FRFProblemSpec, solver: SolverOptions, test_points: TestPointsSpec, outputs: Outputs):
    """Update MODEL's parameters from FRFs in DATA measured at any dofs (eqs. 30-32)."""
    from ..io.model_file import load_model
    from ..io.testdata_json import load_testdata
    from ..updating.frf import frf_data
    from ..updating.results import MultiStartResult

    ctx = Ctx(outputs.json_path)
    damped = damped_model(model_path)  # a [damping] table: damping parameters among the unknowns
    model = load_model(model_path) if damped is None else damped.model
    values = model_values(model if damped is None else view(damped), outputs.set_text)
    mapped = None
    if test_points.tolerance is None:
        data = load_testdata(data_path, model)
    elif damped is not None:
        raise InputError("--test-points with a [damping] table: a damped model is not mapped onto test points yet")
    else:  # FRFs at test points are C H: the transformed model's FRFs at their dofs
        model, data, mapped = test_points.load(model_path, model, data_path)
        test_points.announce(ctx, mapped)
    data = apply_reciprocity(data, problem.reciprocity)
    if search is not None or data.n_frf_sets <= 1:
        frf_data(data)  # no FRF data, or several sets for the global search: refused by name
    params, frf, noise = problem.resolve(data)
    if damped is not None:
        if search is not None:
            raise InputError("--global with a [damping] table: not taken in this version; use --starts")
        if frf.damping is not None and not getattr(frf.damping, "undamped", True):
            raise InputError("--damping sets the FRF damping of an undamped model; this model's damping is its "
                             "[damping] table (updated with the other parameters): leave --damping out")
        model = view(damped)
    result = _run(ctx, outputs, damped or model, data, dict(params=params, values=values, frf=frf, noise=noise),
                  starts, execution, search, solver)
    result = result.with_context(damping=frf.damping,
                                 before=None if values is None else dict(zip(model.parameter_names, values)))
    ms = result if isinstance(result, MultiStartResult) else None
    res = ms.best if ms is not None else result
    what = f"{search.method} runs" if search is not None else "starts"
    payload = result.to_json()
    if mapped is not None:
        payload["test_points"] = mapped.to_json()
    if res is None:
        assert ms is not None
        outputs.emit(ctx, payload)
        print_starts(ctx.console, ms, what)
        write_report_output(ctx, outputs.report_path, result, model_path=model_path, test_points=mapped)
        raise NumericalError(f"none of the {ms.total} {'runs' if search is not None else 'starts'} converged")
    _print(ctx, model, data, res, ms, what, payload)
    if outputs.plot_dir is not None and damped is not None:
        damped_figures(ctx, damped, data, res, outputs.plot_dir)
    elif outputs.plot_dir is not None:
        _figures(ctx, model, data, res, frf.damping, outputs.plot_dir)
    outputs.emit(ctx, payload)
    write_report_output(ctx, outputs.report_path, result, model_path=model_path, test_points=mapped)
    if not res.success:
        if outputs.write_model_path or outputs.csv_dir or outputs.write_back_dir:
            ctx.console.print("not written: the updated model and tables (the update did not converge)")
        raise NumericalError(f"the FRF update did not converge: {res.message}")
    if damped is not None:
        model, res = damped.model, model_part(ctx, damped, res, outputs)
    write_model_outputs(ctx, model_path, data_path, "frf-update", model, res.parameters, res.names, res.cost,
                        outputs.write_model_path, outputs.csv_dir, res, write_back_dir=outputs.write_back_dir)


def _run(ctx: Ctx, outputs: Outputs, model, data, problem: dict, starts, execution, search, solver):
    """The library's verb for the command's options: a global search, a multi-start study or
    one update (the result carries its model and data)."""
    from ..updating import frf_multistart, frf_update, global_search

    if search is not None:
        # every local option reaches the polish except --method (the global search's method is the global one)
        with outputs.progress(ctx, f"{search.method} runs", search.runs) as tick:
            return global_search(model, data, method=search.method, global_residual=search.residual,
                                 starts=starts.replace(starts=search.runs), execution=execution, progress=tick,
                                 solver=solver.replace(method="trf"), **problem)
    if starts.starts > 1 or execution.scheduler:
        with outputs.progress(ctx, "starts", starts.starts) as tick:
            return frf_multistart(model, data, starts, execution=execution, progress=tick, solver=solver, **problem)
    return frf_update(model, data, solver=solver, **problem)


def _print(ctx: Ctx, model, data, res, ms, what: str, payload: dict) -> None:
    """The terminal summary: the solutions that fit (several), the parameters, FRAC per dof, the
    diagnostics, the lines skipped, the notes, the flags and the starts."""
    c = ctx.console
    sets = (f"{res.omega.size} lines x {len(data.frf.dofs)} dofs" if data.n_frf_sets == 1
            else f"{data.n_frf_sets} excitations, {sum(len(s.dofs) for s in data.frf_sets)} responses")
    title = (f"{model.name}: FRF update ({res.iterations} iterations, {res.nfev} evaluations, "
             f"{sets}, {res.residual} residual)")
    if ms is not None and len(ms.fitting) > 1:
        c.print(fitting_table(ms, what))
        title = f"the lowest-cost solution in detail — {title}"
    c.print(update_parameter_table(res, title, {p.name: p.unit for p in model.parameters}))
    if getattr(res, "damping", None):
        print_damped(c, res)
    c.print("FRAC per dof: " + ", ".join(f"{d} {v:.4f}" for d, v in res.frac.items()))
    print_diagnostics(c, res)
    for s in res.skipped:
        c.print(f"skipped line {s['line']} ({fmt(s['omega_rad_s'])} rad/s): {s['reason']}")
    for note in payload["notes"]:
        c.print(f"note: {note}", markup=False)
    print_flags(ctx, payload["flags"])
    if ms is not None:
        print_starts(c, ms, what)


def _figures(ctx: Ctx, model, data, res, damping, plot_dir) -> None:
    """The FRF overlay (of the first excitation's set) and the convergence figure."""
    from ..frf import frf as model_frf
    from ..plot.frf import save_frf_update_figures

    frf = data.frf
    use = np.isin(frf.omega, res.omega)
    _, xa = model_frf(model, frf.omega[use], frf.force, frf.dofs, res.parameters, damping)
    names = save_frf_update_figures(plot_dir, res.history, frf.omega[use], frf.dofs, frf.response[use], xa)
    ctx.console.print(f"figures: {', '.join(str(plot_dir / n) for n in names)}"
                      + (f" (the FRF overlay shows the first excitation's set, {', '.join(frf.force)})"
                         if data.n_frf_sets > 1 else ""))


__all__ = ["frf_update_command", "FRFProblemSpec", "GlobalSearch", "frf_problem_group", "global_group"]
