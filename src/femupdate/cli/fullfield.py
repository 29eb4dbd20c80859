"""``femupdate fullfield MODEL SCAN``: scanning data by coordinates onto the model's dofs, then the
direct solution (:func:`femupdate.fullfield.full_field_direct`)."""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from pathlib import Path

import click

from .._errors import NumericalError
from ..recording import flags
from ._common import OUTPUT_FILE, Ctx, model_values, print_flags
from ._groups import GroupedCommand, option_group
from .damage import _load_structure, _names, _parameter_table, _path
from .outputs import Outputs, outputs_group


@dataclasses.dataclass(frozen=True)
class FullFieldSpec:
    """How the scan is mapped and the parameters solved for (:func:`fullfield_group`)."""

    method: str
    form: str
    unknowns: list[str] | None
    bounded: bool


def fullfield_group() -> Callable:
    """``--method``, ``--form``, ``--unknowns``, ``--bounded`` -> ``solution``: :class:`FullFieldSpec`."""
    return option_group(
        "Mapping and solution", "solution",
        lambda method, form, unknowns, bounded: FullFieldSpec(method, form, _names(unknowns), bounded),
        click.option("--method", type=click.Choice(["rbf", "elements", "local"]), default="rbf", show_default=True,
                     help="Mapping onto the dofs: smoothing spline, element shape functions, or local fits."),
        click.option("--form", type=click.Choice(["projected", "pointwise"]), default="projected", show_default=True,
                     help="Direct equations projected onto the measured shapes, or pointwise (paper eqs. 4-10)."),
        click.option("--unknowns", default=None, help="Parameters to identify (default: all not fixed)."),
        click.option("--bounded", is_flag=True, help="Honour parameter bounds."),
    )


@click.command(cls=GroupedCommand)
@click.argument("model_path", metavar="MODEL", type=_path)
@click.argument("scan_path", metavar="SCAN", type=_path)
@fullfield_group()
@option_group("Model values and outputs", "data_out", lambda data_out: data_out,
              click.option("--write-data", "data_out", type=OUTPUT_FILE, default=None,
                           help="Also write the completed test data (JSON)."))
@outputs_group(report=False)
def fullfield(model_path, scan_path, solution: FullFieldSpec, data_out, outputs: Outputs):
    """Map a full-field SCAN (points by coordinates) onto MODEL's dofs and identify its parameters directly."""
    from ..fullfield import full_field_direct, structure_segments
    from ..fullfield.files import load_scan

    ctx = Ctx(outputs.json_path)
    structure, model = _load_structure(model_path)
    values = model_values(model, outputs.set_text)
    scan = load_scan(scan_path)
    result = full_field_direct(model, scan, method=solution.method, form=solution.form, values=values,
                               unknowns=solution.unknowns, bounded=solution.bounded,
                               segments=structure_segments(structure) if structure is not None else None)
    res, mp = result.direct, result.mapping
    c = ctx.console
    c.print(f"{len(scan.points)} scan points, largest distance from the geometry {mp.max_distance:.3g} (tolerance "
            f"{mp.tolerance:.3g}); mapped by {mp.method}: interpolation error {mp.interpolation_error * 100:.3g} % of the "
            f"largest value; rotations inferred: {', '.join(mp.inferred) or 'none'}; zero: {', '.join(mp.zero) or 'none'}")
    c.print(_parameter_table(f"{model.name}: direct ({solution.form}) from {res.system.n_equations} equations", model,
                             values, res.unknowns, res.x, res.standard_error))
    for n in mp.notes + res.notes:
        c.print(f"note: {n}")
    print_flags(ctx, flags(model, res.parameters, res.unknowns))
    if data_out is not None:
        _write_completed(data_out, mp.data)
        c.print(f"completed test data written to {data_out}")
    outputs.emit(ctx, result.to_json())
    if not res.unique:
        raise NumericalError(f"the data do not determine every parameter uniquely: {res.notes[-1]}")


def _write_completed(path: Path, data) -> None:
    """The test data completed at every model dof, as a test-data JSON file (docs/file-formats.md)."""
    from ..io.results import write_json

    write_json(path, {"modes": [{"eigenvalue": m.eigenvalue, "label": m.label, "shape": dict(zip(m.dofs, m.shape))}
                                for m in data.modes]}
               | ({"frf": {"omega_rad_s": data.frf.omega, "force": data.frf.force,
                           "response": {d: [[complex(v).real, complex(v).imag] for v in data.frf.response[:, j]]
                                        for j, d in enumerate(data.frf.dofs)}}} if data.frf is not None else {}))
