"""``femupdate reduce``: reduce a model to its kept (measured) dofs (docs/cli.md)."""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from pathlib import Path

import click
import numpy as np
from rich.table import Table

from .._errors import InputError
from ._common import INPUT_FILE, Ctx, fmt, model_values, option_dofs, percent
from ._groups import GroupedCommand, option_group
from .outputs import Outputs, outputs_group

METHOD_CHOICES = ["guyan", "irs", "modal", "hybrid", "serep"]


@dataclasses.dataclass(frozen=True)
class ReductionSpec:
    """``reduce``'s options as typed (:func:`reduction_group`)."""

    keep_text: str
    method: str
    n_modes: int | None
    compare: bool

    def keep(self, model) -> list[str]:
        """The kept dofs as the model's labels (``#N`` resolved; the messages name ``--keep``)."""
        items = [k.strip() for k in self.keep_text.replace(";", ",").split(",") if k.strip()]
        if not items:
            raise InputError("--keep: no dofs given (e.g. --keep 2:x,4:x)")
        return list(option_dofs(items, model, "--keep"))


def reduction_group() -> Callable:
    """``--keep``, ``--method``, ``--n-modes``, ``--compare`` -> ``reduction``: :class:`ReductionSpec`."""
    return option_group(
        "Reduction", "reduction", lambda **kw: ReductionSpec(**kw),
        click.option("--keep", "keep_text", required=True, metavar="DOFS",
                     help="Dofs to retain, comma-separated labels or #N (e.g. 2:x,4:x or #2,#4)."),
        click.option("--method", type=click.Choice(METHOD_CHOICES), default="guyan", show_default=True),
        click.option("--n-modes", type=click.IntRange(min=1), default=None,
                     help="Modes used by modal / hybrid / serep (at most the number of kept dofs; default: that "
                          "number)."),
        click.option("--compare/--no-compare", default=True, show_default=True,
                     help="Also tabulate the frequency errors of every other method."),
    )


@click.command(cls=GroupedCommand)
@click.argument("model_path", metavar="MODEL", type=INPUT_FILE)
@reduction_group()
@outputs_group(report=False)
def reduce(model_path, reduction: ReductionSpec, outputs: Outputs):
    """Reduce MODEL to the dofs in --keep (Guyan, IRS, Kammer modal or hybrid, SEREP)."""
    from ..io.model_file import load_model
    from ..reduction import reduce_model

    ctx = Ctx(outputs.json_path)
    model = load_model(model_path)
    values = model_values(model, outputs.set_text)
    res = reduce_model(model, reduction.keep(model), reduction.method, reduction.n_modes, reduction.compare, values)
    _print(ctx.console, model, res)
    outputs.emit(ctx, res.to_json())


def _print(c, model, res) -> None:
    """Full and reduced frequencies with the error, every method's errors compared, the mass
    fraction and the criteria's figures and warnings."""
    f_full, f_red, err = res.full_frequencies_hz, res.reduced_frequencies_hz, res.error
    tab = Table(title=f"{model.name}: {model.n_dofs} -> {len(res.keep)} dofs ({res.method}"
                      + (f", {res.n_modes} modes" if res.n_modes else "") + ")")
    for col in ("mode", "full [Hz]", "reduced [Hz]", "error"):
        tab.add_column(col, justify="right")
    for i in range(max(f_red.size, f_full.size)):
        tab.add_row(str(i + 1), fmt(f_full[i]) if i < f_full.size else "-", fmt(f_red[i]) if i < f_red.size else "-",
                    _percent(err[i]) if i < err.size else "-")
    c.print(tab)
    if len(res.frequency_error) > 1:
        t2 = Table(title="frequency error per method (reduced vs full)")
        for col in ("method", "mode 1", "max over modes", "worst mode"):
            t2.add_column(col, justify="left" if col == "method" else "right")
        for meth, e in res.frequency_error.items():
            if isinstance(e, str):
                t2.add_row(meth, "-", "-", e[:60])
            else:
                w = int(np.argmax(np.abs(e)))
                t2.add_row(meth, _percent(e[0]), f"{np.max(np.abs(e)) * 100:.4f} %", str(w + 1))
        c.print(t2)
    crit = res.criteria
    c.print(f"retained mass fraction {res.mass_fraction:.1%}; lowest frequency with the kept dofs grounded "
            f"{crit.grounded_frequency_hz:.6g} Hz (Larsson & Sas); Gordis overlap {crit.overlap}")
    for m in crit.messages:
        c.print(f"warning: {m}")


def _percent(x: float) -> str:
    """A relative error in per cent with its sign, four decimals (:func:`percent`)."""
    return percent(x, 4)
