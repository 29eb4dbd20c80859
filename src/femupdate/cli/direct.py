"""``femupdate direct``: parameters identified directly from data measured at every model dof."""

from __future__ import annotations

from pathlib import Path

import click
import numpy as np
from rich.table import Table

from .._errors import NumericalError
from .._errors import InputError
from ._common import (INPUT_FILE, OUTPUT_FILE, Ctx, correlation_table, csv_option, data_fields, direct_payload, emit, fmt, json_option,
                      load_data, measured_dofs_option, model_values, print_flags, report_option, set_option,
                      write_model_option, write_model_outputs, write_report_output)


def _correlation_rows(data, model, values):
    from ..correlation import correlate
    from ..modal import model_modes

    if not data.modes:
        return None, None
    mm = model_modes(model, values, n_modes=min(model.n_dofs, max(len(data.modes) + 4, 10)) if model.n_dofs > 1500 else None)
    return mm, correlate(data, mm)


@click.command()
@click.argument("model_path", metavar="MODEL", type=INPUT_FILE)
@click.argument("data_path", metavar="DATA", type=INPUT_FILE)
@click.option("--use", default="modes,frf,static", show_default=True, help="Kinds of data to use.")
@click.option("--unknowns", default=None, help="Parameters to identify (default: all not fixed).")
@click.option("--bounded", is_flag=True, help="Honour parameter bounds (bounded least squares).")
@click.option("--uff", "uff_path", type=OUTPUT_FILE, default=None,
              help="Write the updated model's modes as universal file datasets 55.")
@measured_dofs_option
@write_model_option
@csv_option
@report_option
@set_option
@json_option
def direct(model_path, data_path, use, unknowns, bounded, uff_path, measured_text, write_model_path, csv_dir, report_path,
           set_text, json_path):
    """Identify MODEL's parameters directly from DATA measured at every model dof."""
    from ..direct import direct_update
    from ..io.model_file import load_model

    ctx = Ctx(json_path)
    model = load_model(model_path)
    values = model_values(model, set_text)
    if uff_path is not None:
        from ..io.uff.write import uff_dofs

        uff_dofs(model.dofs, "direct --uff")  # before the solution: named nodes cannot be written
    data = load_data(data_path, model, measured_text)
    kinds = [u.strip() for u in use.split(",") if u.strip()]
    names = [u.strip() for u in unknowns.split(",")] if unknowns else None
    res = direct_update(model, data, use=kinds, values=values, unknowns=names, bounded=bounded)
    payload = direct_payload(model, res, data)
    payload["notes"] = [*data.notes, *payload["notes"]]
    payload.update(data_fields(data))
    table = Table(title=f"{model.name}: direct update from {res.system.n_equations} equations")
    for col in ("parameter", "unit", "start", "identified", "std. error", "change"):
        table.add_column(col, justify="left" if col in ("parameter", "unit") else "right")
    p0 = model.resolve(values)
    payload["start"] = dict(zip(model.parameter_names, map(float, p0)))
    for j, par in enumerate(model.parameters):
        name, new, unit = par.name, res.parameters[par.name], par.unit or "-"
        if name in res.unknowns:
            se = res.standard_error[res.unknowns.index(name)]
            table.add_row(name, unit, fmt(p0[j]), fmt(new), "-" if not np.isfinite(se) else fmt(se),
                          f"{(new - p0[j]) / p0[j] * 100:+.1f} %" if p0[j] else "")
        else:
            table.add_row(name, unit, fmt(p0[j]), "(fixed)", "", "")
    ctx.console.print(table)
    ctx.console.print(f"condition number {res.condition_number:.4g} (columns scaled: {res.condition_number_scaled:.4g}), "
                      f"residual {res.residual_norm:.4g} (relative {res.relative_residual:.3g}), rank {res.rank}/{len(res.unknowns)}")
    print_flags(ctx, payload["flags"])
    try:
        mm, corr = _correlation_rows(data, model, res.parameters)
    except InputError as exc:  # a negative stiffness, flagged above, can make K indefinite
        if not payload["flags"]:
            raise
        mm = corr = None
        payload["notes"] = [*data.notes, *res.notes, f"no correlation of the identified model with the test: {exc}"]
    if corr is not None:
        payload["frequencies_hz"] = {"test": data.frequencies_hz, "model": [mm.frequencies_hz[j] for _, j, _ in corr.pairs]}
        payload["pairs"] = [[i, j, m] for i, j, m in corr.pairs]
        ctx.console.print(correlation_table(corr, "updated model vs test"))
        if uff_path is not None:
            from ..io.uff import write_uff_modes

            write_uff_modes(uff_path, mm, nodes=model.nodes, model_name=model.name)
    for note in payload["notes"]:
        ctx.console.print(f"note: {note}", markup=False)
    emit(ctx, payload)
    write_report_output(ctx, report_path, payload, model=model, data=data, model_path=model_path, kind="direct",
                        before=payload["start"])
    if not res.unique:
        if write_model_path or csv_dir:
            ctx.console.print("not written: the updated model and tables (the parameters are not determined uniquely)")
        raise NumericalError(f"the data do not determine every parameter uniquely: {res.notes[-1]}")
    write_model_outputs(ctx, model_path, data_path, "direct", model, res.parameters, list(res.unknowns), None,
                        write_model_path, None)
    if csv_dir is not None:
        from ..io.model_write import write_parameter_table

        p0 = model.resolve(values)
        written = write_parameter_table(Path(csv_dir) / "parameters.csv", model, res.unknowns,
                                        [p0[model.parameter_index(n)] for n in res.unknowns],
                                        [res.parameters[n] for n in res.unknowns], res.standard_error)
        ctx.console.print(f"wrote {written}")
