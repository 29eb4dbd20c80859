"""``femupdate convert-data``: test data from another source (an identification library's saved
result, a universal file, test-data JSON) written as test-data JSON."""

from __future__ import annotations

import click
from rich.table import Table

from .._errors import InputError
from ._common import INPUT_FILE, OutputPath, Ctx, emit, fmt, json_option, measured_dofs_option, print_data_notes


@click.command("convert-data")
@click.argument("source", metavar="SOURCE", type=INPUT_FILE)
@click.argument("out_path", metavar="OUT", type=OutputPath("file", dash=True))
@click.option("--channels", "channels_text", default=None, metavar="DOFS",
              help="Channel map of an identification result (.npz): one dof per channel in the library's order, "
                   "comma-separated ('-3:x' for a sensor along -x, an empty entry leaves a channel out); replaces "
                   "the file's 'channels'.")
@click.option("--model", "model_path", default=None, type=INPUT_FILE,
              help="Check the data's dofs against this model (and read #N as its N-th dof).")
@measured_dofs_option
@json_option
def convert_data(source, out_path, channels_text, model_path, measured_text, json_path):
    """Write the test data in SOURCE as test-data JSON to OUT ('-' = stdout): a pyOMA2 result or an
    sdypy-EMA model saved with numpy.savez (.npz, with its channel map), a universal file, or
    test-data JSON."""
    from ..io.results import write_json
    from ..io.testdata_json import load_testdata, testdata_object

    if json_path == "-" and out_path == "-":
        raise InputError("convert-data: OUT and --json cannot both be '-' (standard output)")
    ctx = Ctx(json_path)
    if out_path == "-":
        ctx.console.quiet = True
    model = None
    if model_path is not None:
        from ..io.model_file import load_model

        model = load_model(model_path)
    sensors = None
    if measured_text is not None:
        from ..dofs import resolve_all

        items = [t.strip() for t in str(measured_text).split(",") if t.strip()]
        if not items:
            raise InputError("--measured-dofs: no dofs given (comma-separated labels such as 3:x, or #N)")
        sensors = resolve_all(items, None if model is None else model.dofs, "--measured-dofs")
    channels = None
    if channels_text is not None:
        if source.suffix.lower() != ".npz":
            raise InputError(f"--channels: maps the channels of an identification result (.npz); {source.name} is "
                             "not one")
        channels = [t.strip() for t in str(channels_text).split(",")]
    try:
        data = load_testdata(source, model, sensors=sensors, channels=channels)
    except InputError as exc:  # the map the option gave is named as the option
        msg = str(exc)
        raise InputError(f"--{msg}" if channels is not None and msg.startswith("channels:") else msg) from None
    obj = testdata_object(data)
    write_json(out_path, obj)
    if not ctx.console.quiet:
        t = Table(title=f"{source.name} -> {out_path}: {len(data.modes)} mode(s)")
        for col in ("mode", "f [Hz]", "damping ratio", "std f", "std damping", "std shape", "dofs"):
            t.add_column(col, justify="right")
        for k, m in enumerate(data.modes, start=1):
            sf = None if m.std_eigenvalue is None else m.std_eigenvalue / 2
            t.add_row(str(k), fmt(m.frequency_hz), "-" if m.damping_ratio is None else f"{m.damping_ratio:.4g}",
                      "-" if sf is None else f"{sf * 100:.3g} %",
                      "-" if m.std_damping_ratio is None else f"{m.std_damping_ratio:.3g}",
                      "-" if m.std_shape is None else f"{m.std_shape:.3g}", str(len(m.dofs)))
        ctx.console.print(t)
        print_data_notes(ctx, data)
        ctx.console.print(f"wrote the test data {out_path}")
    emit(ctx, {"source": str(source), "out": str(out_path), "n_modes": len(data.modes),
               "frequencies_hz": list(data.frequencies_hz), "damping_ratio": list(data.damping_ratios),
               "notes": list(data.notes)})
