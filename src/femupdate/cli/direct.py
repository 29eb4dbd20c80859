"""``femupdate direct``: parameters identified directly from data measured at every model dof."""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from pathlib import Path

import click
import numpy as np
from rich.table import Table

from .._errors import NumericalError
from ..recording import flags
from ._common import INPUT_FILE, Ctx, correlation_table, fmt, model_values, print_flags, write_model_outputs, write_report_output
from ._groups import GroupedCommand, option_group
from .data_options import DataSpec, test_data_group
from .outputs import Outputs, outputs_group
from .testpoints import TestPointsSpec, test_points_group


@dataclasses.dataclass(frozen=True)
class DirectSpec:
    """What the direct solution uses and identifies (:func:`direct_group`)."""

    use: list[str]
    unknowns: list[str] | None
    bounded: bool


def direct_group() -> Callable:
    """``--use``, ``--unknowns``, ``--bounded`` -> ``solution``: :class:`DirectSpec`."""
    def build(use, unknowns, bounded):
        return DirectSpec([u.strip() for u in use.split(",") if u.strip()],
                          [u.strip() for u in unknowns.split(",")] if unknowns else None, bounded)

    return option_group(
        "Direct solution", "solution", build,
        click.option("--use", default="modes,frf,static", show_default=True, help="Kinds of data to use."),
        click.option("--unknowns", default=None, help="Parameters to identify (default: all not fixed)."),
        click.option("--bounded", is_flag=True, help="Honour parameter bounds (bounded least squares)."),
    )


@click.command(cls=GroupedCommand)
@click.argument("model_path", metavar="MODEL", type=INPUT_FILE)
@click.argument("data_path", metavar="DATA", type=INPUT_FILE)
@direct_group()
@test_data_group()
@test_points_group()
@outputs_group(model_out=True, uff="Write the updated model's modes as universal file datasets 55.", report=True)
def direct(model_path, data_path, solution: DirectSpec, data_spec: DataSpec, test_points: TestPointsSpec,
           outputs: Outputs):
    """Identify MODEL's parameters directly from DATA measured at every model dof."""
    from ..direct import direct_update
    from ..io.model_file import load_model

    ctx = Ctx(outputs.json_path)
    model = load_model(model_path)
    values = model_values(model, outputs.set_text)
    if outputs.uff_path is not None:
        from ..io.uff.write import uff_dofs

        uff_dofs(model.dofs, "direct --uff")  # before the solution: named nodes cannot be written
    base = model  # the structure's own dofs (--uff), whatever the test points add
    model, data, mapped = test_points.load(model_path, model, data_path, data_spec.measured_text)
    test_points.announce(ctx, mapped)
    res = direct_update(model, data, use=solution.use, values=values, unknowns=solution.unknowns,
                        bounded=solution.bounded)
    _print(ctx, model, res)
    after = res.identified  # the identified model's modes and their correlation with the test
    if after.correlation is not None:
        ctx.console.print(correlation_table(after.correlation, "updated model vs test"))
        if outputs.uff_path is not None:
            from ..io.uff import write_uff_modes

            modes = after.modes if mapped is None else _mesh_modes(after.modes, mapped)
            write_uff_modes(outputs.uff_path, modes, nodes=base.nodes, model_name=model.name)
    payload = res.to_json()
    if mapped is not None:
        payload["test_points"] = mapped.to_json()
    for note in payload["notes"]:
        ctx.console.print(f"note: {note}", markup=False)
    outputs.emit(ctx, payload)
    write_report_output(ctx, outputs.report_path, res, model_path=model_path, test_points=mapped)
    if not res.unique:
        if outputs.write_model_path or outputs.csv_dir or outputs.write_back_dir:
            ctx.console.print("not written: the updated model and tables (the parameters are not determined uniquely)")
        raise NumericalError(f"the data do not determine every parameter uniquely: {res.notes[-1]}")
    write_model_outputs(ctx, model_path, data_path, "direct", model, res.parameters, list(res.unknowns), None,
                        outputs.write_model_path, None, write_back_dir=outputs.write_back_dir)
    if outputs.csv_dir is not None:
        from ..io.model_write import write_parameter_table

        p0 = model.resolve(values)
        written = write_parameter_table(Path(outputs.csv_dir) / "parameters.csv", model, res.unknowns,
                                        [p0[model.parameter_index(n)] for n in res.unknowns],
                                        [res.parameters[n] for n in res.unknowns], res.standard_error)
        ctx.console.print(f"wrote {written}")


def _mesh_modes(modes, mapped):
    """The modes of a model test points were placed on, on the mesh's own dofs (u = T q)."""
    return dataclasses.replace(modes, shapes=mapped.mesh_shapes(modes.shapes), dofs=tuple(mapped.base.dofs))


def _print(ctx: Ctx, model, res) -> None:
    """The identified values against the start, the system's figures and the flags."""
    table = Table(title=f"{model.name}: direct update from {res.system.n_equations} equations")
    for col in ("parameter", "unit", "start", "identified", "std. error", "change"):
        table.add_column(col, justify="left" if col in ("parameter", "unit") else "right")
    start = res.run_context.before
    for par in model.parameters:
        name, new, unit, p0 = par.name, res.parameters[par.name], par.unit or "-", start[par.name]
        if name in res.unknowns:
            se = res.standard_error[res.unknowns.index(name)]
            table.add_row(name, unit, fmt(p0), fmt(new), "-" if not np.isfinite(se) else fmt(se),
                          f"{(new - p0) / p0 * 100:+.1f} %" if p0 else "")
        else:
            table.add_row(name, unit, fmt(p0), "(fixed)", "", "")
    ctx.console.print(table)
    ctx.console.print(f"condition number {res.condition_number:.4g} (columns scaled: {res.condition_number_scaled:.4g}), "
                      f"residual {res.residual_norm:.4g} (relative {res.relative_residual:.3g}), rank {res.rank}/{len(res.unknowns)}")
    print_flags(ctx, flags(model, res.parameters, res.unknowns))
