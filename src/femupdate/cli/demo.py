"""``femupdate demo``: the paper's Figure 2 system identified from built-in test data."""

from __future__ import annotations

import dataclasses
from importlib import resources
from pathlib import Path

import click
from rich.table import Table

from .._errors import InputError
from ._common import OUTPUT_DIR, Ctx, correlation_table, emit, fmt, json_option
from ._groups import GroupedCommand, option_group


@dataclasses.dataclass(frozen=True)
class DemoOutputs:
    """What ``demo`` writes: the example files, the JSON result."""

    write_dir: Path | None = None
    json_path: object = None


@click.command(cls=GroupedCommand)
@option_group(
    "Outputs", "outputs", lambda **kw: DemoOutputs(**kw),
    click.option("--write-files", "write_dir", type=OUTPUT_DIR, default=None,
                 help="Also write the example models and test data of every command to this folder (see README)."),
    json_option)
def demo(outputs: DemoOutputs):
    """Identify the paper's Figure 2 system from its built-in (simulated, noisy) test data."""
    from ..correlation import correlate as _correlate
    from ..direct import direct_update
    from ..examples import FIGURE2_TRUE
    from ..examples import demo as _demo
    from ..modal import model_modes

    ctx = Ctx(outputs.json_path)
    if outputs.write_dir is not None:
        _write_files(outputs.write_dir)
    res = _demo()
    model, data = res.run_context.model, res.run_context.data
    c = ctx.console
    c.print(f"[bold]femupdate demo[/bold]: {model.name}; {model.n_dofs} dofs, unknowns {', '.join(model.parameter_names)}")
    c.print(f"test data: {len(data.modes)} modes measured at every dof (simulated at the true values, 1 % noise on the shapes)")
    c.print(correlation_table(_correlate(data, model_modes(model)), "starting model vs test"))
    one = None
    try:
        one = direct_update(model, type(data)(modes=data.modes[:1]))
    except InputError as exc:
        one_msg = str(exc)
    t = Table(title="direct identification (paper eq. 10, all modes stacked)")
    for col in ("parameter", "start", "identified", "std. error", "true", "error"):
        t.add_column(col, justify="right" if col != "parameter" else "left")
    for j, name in enumerate(model.parameter_names):
        v = res.parameters[name]
        t.add_row(name, fmt(model.values[j]), fmt(v), fmt(res.standard_error[j]), fmt(FIGURE2_TRUE[name]),
                  f"{(v - FIGURE2_TRUE[name]) / FIGURE2_TRUE[name] * 100:+.2f} %")
    c.print(t)
    c.print(f"condition number {res.condition_number:.4g}, relative residual {res.relative_residual:.3g}, rank {res.rank}/{len(res.unknowns)}")
    c.print(correlation_table(res.identified.correlation, "updated model vs test"))
    if one is None:
        c.print(f"with one mode only: {one_msg}")
    emit(ctx, res.to_json())


def _write_files(directory: Path) -> None:
    """The demo's model and test data, and the example files of the other commands, into ``directory``."""
    from ..examples import write_example_files
    from ..io.results import atomic_write_text

    data_dir = resources.files("femupdate") / "data"
    for name in ("figure2.toml", "figure2_test.json"):
        with resources.as_file(data_dir / name) as path:
            atomic_write_text(directory / name, Path(path).read_text())
    write_example_files(directory)  # the examples of the other commands
