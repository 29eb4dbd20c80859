"""``femupdate report``: the HTML report of a result file written by ``--json``."""

from __future__ import annotations

from pathlib import Path

import click

from .._errors import InputError
from ._common import INPUT_FILE, REPORT_FILE, Ctx, load_data, measured_dofs_option, model_segments

_path = INPUT_FILE


def _report_model(model_path: Path, result: dict, kind: str):
    """The model a result names: the model file's, or for a damage run the element-wise (or
    parameter-wise) model of its unknowns."""
    from ..io.model_file import load_model, read_toml

    if kind != "damage" or Path(model_path).suffix.lower() != ".toml" or {"matrices", "abaqus", "nastran", "ansys"} & set(read_toml(model_path)):
        return load_model(model_path)
    from ..damage import damage_unknowns
    from ..structure import Structure

    structure = Structure.from_dict(read_toml(model_path), source=str(model_path))
    model = damage_unknowns(structure, {}, result.get("unknowns") or "auto").model
    missing = [n for n in (result.get("changes") or {}) if n not in model.parameter_names]
    if missing:
        raise InputError(f"--model {model_path}: the damage result's unknowns {', '.join(missing[:6])} are not in the "
                         f"model's {result.get('unknowns', 'auto')} unknowns (is it the baseline of this run?)")
    return model


@click.command("report")
@click.argument("result_path", metavar="RESULT.json", type=_path)
@click.option("-o", "--out", "out_path", required=True, type=REPORT_FILE, metavar="FILE.html",
              help="The HTML report to write.")
@click.option("--model", "model_path", type=_path, default=None,
              help="The model of the run: adds what needs recomputing (correlation before the update, MAC matrices, "
                   "mode shapes on the model, FRF overlays, residual surface).")
@click.option("--data", "data_path", type=_path, default=None, help="The test data of the run (needs --model).")
@click.option("--kind", type=click.Choice(["direct", "update", "frf-update", "update-multi", "damage", "uniqueness",
                                           "paper", "posterior", "plan"]), default=None,
              help="The command that wrote RESULT.json (default: told from its keys).")
@measured_dofs_option
def report(result_path, out_path, model_path, data_path, kind, measured_text):
    """Write one self-contained HTML report of RESULT.json (the --json result of direct, update,
    frf-update, update-multi, damage, uniqueness, paper, posterior or plan)."""
    from ..report import build_report, paper_images
    from ..report.build import _jsonable, check_kind
    from ..io.results import atomic_write_text

    ctx = Ctx(None)
    result = _jsonable(result_path)
    kind = check_kind(result, kind, f"{result_path}: ")
    if data_path is not None and model_path is None:
        raise InputError("--data needs --model (the test data are read for the model's dofs)")
    if measured_text is not None and data_path is None:
        raise InputError("--measured-dofs needs --data")
    model = data = segments = None
    if model_path is not None:
        if kind in ("paper",):
            raise InputError(f"--model: a {kind} result needs no model")
        model = _report_model(model_path, result, kind)
        segments = model_segments(model_path) if Path(model_path).suffix.lower() == ".toml" else None
    if data_path is not None:
        if kind in ("uniqueness", "update-multi"):
            raise InputError(f"--data: a {kind} result is reported from its own file (its data are simulated or "
                             "given per configuration)")
        data = load_data(data_path, model, measured_text)
    from ..report.build import check_model_and_data

    check_model_and_data(result, kind, model, data, f"--model {model_path}: ", f"--data {data_path}: ")
    images = paper_images(Path(result_path).parent, result) if kind == "paper" else None
    html = build_report(result, model=model, data=data, kind=kind, segments=segments, images=images,
                        source=str(result_path))
    atomic_write_text(out_path, html)
    hint = (" (from the result alone: give --model and --data for the predictive figure; the corner figure needs "
            "the samples: --report on the posterior command)" if kind == "posterior" else
            " (from the result alone: give --model and --data for the correlation before the update and the mode "
            "shapes)")
    ctx.console.print(f"wrote the report {out_path}" + ("" if model is not None or kind in ("paper", "uniqueness", "plan")
                                                        else hint))
