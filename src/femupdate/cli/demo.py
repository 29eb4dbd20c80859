"""``femupdate demo``: the paper's Figure 2 system identified from built-in test data."""

from __future__ import annotations

from importlib import resources
from pathlib import Path

import click
from rich.table import Table

from .._errors import InputError
from ._common import OUTPUT_DIR, Ctx, correlation_table, direct_payload, emit, fmt, json_option


@click.command()
@click.option("--write-files", "write_dir", type=OUTPUT_DIR, default=None,
              help="Also write the example models and test data of every command to this folder (see README).")
@json_option
def demo(write_dir, json_path):
    """Identify the paper's Figure 2 system from its built-in (simulated, noisy) test data."""
    from ..correlation import correlate as _correlate
    from ..direct import direct_update
    from ..examples import FIGURE2_TRUE
    from ..io.model_file import load_model
    from ..io.testdata_json import load_testdata
    from ..modal import model_modes

    ctx = Ctx(json_path)
    data_dir = resources.files("femupdate") / "data"
    with resources.as_file(data_dir / "figure2.toml") as mpath, resources.as_file(data_dir / "figure2_test.json") as dpath:
        model = load_model(mpath)
        data = load_testdata(dpath, model)
        if write_dir is not None:
            from ..io.results import atomic_write_text

            atomic_write_text(write_dir / "figure2.toml", Path(mpath).read_text())
            atomic_write_text(write_dir / "figure2_test.json", Path(dpath).read_text())
            from ..examples import write_example_files

            write_example_files(write_dir)  # the examples of the other commands
    c = ctx.console
    c.print(f"[bold]femupdate demo[/bold]: {model.name}; {model.n_dofs} dofs, unknowns {', '.join(model.parameter_names)}")
    c.print(f"test data: {len(data.modes)} modes measured at every dof (simulated at the true values, 1 % noise on the shapes)")
    before = _correlate(data, model_modes(model))
    c.print(correlation_table(before, "starting model vs test"))
    res = direct_update(model, data)
    one = None
    try:
        one = direct_update(model, type(data)(modes=data.modes[:1]))
    except InputError as exc:
        one_msg = str(exc)
    after = _correlate(data, model_modes(model, res.parameters))
    t = Table(title="direct identification (paper eq. 10, all modes stacked)")
    for col in ("parameter", "start", "identified", "std. error", "true", "error"):
        t.add_column(col, justify="right" if col != "parameter" else "left")
    for j, name in enumerate(model.parameter_names):
        v = res.parameters[name]
        t.add_row(name, fmt(model.values[j]), fmt(v), fmt(res.standard_error[j]), fmt(FIGURE2_TRUE[name]),
                  f"{(v - FIGURE2_TRUE[name]) / FIGURE2_TRUE[name] * 100:+.2f} %")
    c.print(t)
    c.print(f"condition number {res.condition_number:.4g}, relative residual {res.relative_residual:.3g}, rank {res.rank}/{len(res.unknowns)}")
    c.print(correlation_table(after, "updated model vs test"))
    if one is None:
        c.print(f"with one mode only: {one_msg}")
    emit(ctx, {
        "model": model.name, "true": FIGURE2_TRUE,
        **direct_payload(model, res, data),
        "frequencies_hz": {"test": data.frequencies_hz, "model": [after.model_frequencies_hz[j] for _, j, _ in after.pairs]},
        "pairs": [[i, j, m] for i, j, m in after.pairs],
    })
