"""``femupdate reduce``: reduce a model to its kept (measured) dofs (docs/cli.md)."""

from __future__ import annotations

from pathlib import Path

import click
from rich.table import Table

from ._common import INPUT_FILE, Ctx, emit, fmt, json_option, model_values, option_dofs, set_option

METHOD_CHOICES = ["guyan", "irs", "modal", "hybrid", "serep"]


def _keep_list(text: str) -> list[str]:
    from .._errors import InputError

    items = [k.strip() for k in text.replace(";", ",").split(",") if k.strip()]
    if not items:
        raise InputError("--keep: no dofs given (e.g. --keep 2:x,4:x)")
    return items


@click.command()
@click.argument("model_path", metavar="MODEL", type=INPUT_FILE)
@click.option("--keep", "keep_text", required=True, metavar="DOFS", help="Dofs to retain, comma-separated labels or #N (e.g. 2:x,4:x or #2,#4).")
@click.option("--method", type=click.Choice(METHOD_CHOICES), default="guyan", show_default=True)
@click.option("--n-modes", type=click.IntRange(min=1), default=None,
              help="Modes used by modal / hybrid / serep (at most the number of kept dofs; default: that number).")
@click.option("--compare/--no-compare", default=True, show_default=True,
              help="Also tabulate the frequency errors of every other method.")
@set_option
@json_option
def reduce(model_path, keep_text, method, n_modes, compare, set_text, json_path):
    """Reduce MODEL to the dofs in --keep (Guyan, IRS, Kammer modal or hybrid, SEREP)."""
    import numpy as np

    from .._errors import FemupdateError
    from ..io.model_file import load_model
    from ..reduction import Reducer, mass_fraction, reduction_criteria
    from ..reduction.projection import project, reduced_eigenvalues

    ctx = Ctx(json_path)
    model = load_model(model_path)
    values = model_values(model, set_text)
    red = Reducer(model, list(option_dofs(_keep_list(keep_text), model, "--keep")), values)
    a = red.n_keep
    n_full = min(model.n_dofs, a)
    f_full = red.modes(n_full).frequencies_hz  # cached: modal, hybrid and SEREP reuse these modes

    def run(meth):
        t = red.transformation(meth, n_modes)
        K_r, M_r = project(red.K, t.T), project(red.M, t.T)
        f = np.sqrt(np.clip(reduced_eigenvalues(K_r, M_r), 0, None)) / (2 * np.pi)
        k = min(f.size, f_full.size)
        with np.errstate(divide="ignore", invalid="ignore"):
            err = np.where(f_full[:k] > 0, f[:k] / np.where(f_full[:k] > 0, f_full[:k], 1.0) - 1.0, f[:k] - f_full[:k])
        return t, K_r, M_r, f, err

    t, K_r, M_r, f_red, err = run(method)
    errors = {method: err}
    if compare:
        for other in METHOD_CHOICES:
            if other != method:
                try:
                    errors[other] = run(other)[4]
                except FemupdateError as exc:  # a method that cannot apply here is reported, not fatal
                    errors[other] = str(exc)
    crit = reduction_criteria(model, red.keep, reducer=red, warn=False)
    frac = mass_fraction(model, red.keep, red.values)

    c = ctx.console
    tab = Table(title=f"{model.name}: {model.n_dofs} -> {a} dofs ({method}"
                      + (f", {t.n_modes} modes" if t.n_modes else "") + ")")
    for col in ("mode", "full [Hz]", "reduced [Hz]", "error"):
        tab.add_column(col, justify="right")
    for i in range(max(f_red.size, f_full.size)):
        tab.add_row(str(i + 1), fmt(f_full[i]) if i < f_full.size else "-", fmt(f_red[i]) if i < f_red.size else "-",
                    f"{err[i] * 100:+.4f} %" if i < err.size else "-")
    c.print(tab)
    if compare:
        t2 = Table(title="frequency error per method (reduced vs full)")
        for col in ("method", "mode 1", "max over modes", "worst mode"):
            t2.add_column(col, justify="left" if col == "method" else "right")
        for meth, e in errors.items():
            if isinstance(e, str):
                t2.add_row(meth, "-", "-", e[:60])
            else:
                w = int(np.argmax(np.abs(e)))
                t2.add_row(meth, f"{e[0] * 100:+.4f} %", f"{np.max(np.abs(e)) * 100:.4f} %", str(w + 1))
        c.print(t2)
    c.print(f"retained mass fraction {frac:.1%}; lowest frequency with the kept dofs grounded "
            f"{crit.grounded_frequency_hz:.6g} Hz (Larsson & Sas); Gordis overlap {crit.overlap}")
    for m in crit.messages:
        c.print(f"warning: {m}")
    emit(ctx, {
        "model": model.name, "method": method, "keep": list(red.keep), "n_modes": t.n_modes,
        "frequencies_hz": {"full": f_full, "reduced": f_red},
        "K": K_r, "M": M_r,
        "frequency_error": {k: (v if isinstance(v, str) else list(v)) for k, v in errors.items()},
        "mass_fraction": frac,
        "criteria": {"grounded_frequency_hz": crit.grounded_frequency_hz, "gordis_overlap": crit.overlap,
                     "omitted_eigenvalues": crit.omitted_eigenvalues, "messages": crit.messages},
        "parameters": dict(zip(model.parameter_names, red.values)),
    })
