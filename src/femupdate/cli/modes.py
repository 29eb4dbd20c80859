"""``femupdate modes`` (natural frequencies and mode shapes) and ``correlate`` (test against model modes)."""

from __future__ import annotations

from pathlib import Path

import click
from rich.table import Table

from .._errors import InputError
from ._common import (OUTPUT_FILE, Ctx, FiniteFloat, correlation_table, damping_fields, data_fields, emit, fmt,
                      json_option, load_data, measured_dofs_option, model_values, option_dofs, print_damping,
                      print_data_notes, set_option)
from .frf import damping_option, parse_damping


# ---------------------------------------------------------------------------------- modes
@click.command()
@click.argument("model_path", metavar="MODEL", type=click.Path(dir_okay=False, path_type=Path))
@click.option("--n-modes", type=click.IntRange(min=1), default=None, help="Number of modes (default all for small models, 10 for large).")
@click.option("--normalise", "--normalize", "normalisation", default="mass", show_default=True,
              help="mass | unit | max | ref:<dof> (a label, or #N: the N-th model dof)")
@click.option("--method", type=click.Choice(["auto", "dense", "sparse"]), default="auto", show_default=True)
@click.option("--uff", "uff_path", type=OUTPUT_FILE, default=None,
              help="Also write the modes as universal file datasets 55 (with nodes 2411).")
@set_option
@json_option
def modes(model_path, n_modes, normalisation, method, uff_path, set_text, json_path):
    """Natural frequencies and mode shapes of MODEL."""
    from ..io.model_file import load_model
    from ..modal import model_modes

    ctx = Ctx(json_path)
    model = load_model(model_path)
    values = model_values(model, set_text)
    if normalisation.startswith("ref:"):
        normalisation = "ref:" + option_dofs([normalisation[4:]], model, "--normalise")[0]
    if uff_path is not None:
        from ..io.uff.write import uff_dofs

        uff_dofs(model.dofs, "modes --uff")  # before the eigen-solution: named nodes cannot be written
    if n_modes is not None and n_modes > model.n_dofs:
        raise InputError(f"--n-modes {n_modes}: the model has only {model.n_dofs} dofs")
    res = model_modes(model, values, n_modes=n_modes, normalisation=normalisation, method=method)
    t = Table(title=f"{model.name}: {model.n_dofs} dofs, {res.n_modes} modes")
    t.add_column("mode", justify="right")
    t.add_column("frequency [Hz]", justify="right")
    t.add_column("eigenvalue \\[rad²/s²]", justify="right")  # \\[: a bracket, not rich markup
    for r in range(res.n_modes):
        t.add_row(str(r + 1), fmt(res.frequencies_hz[r]), fmt(res.eigenvalues[r]))
    ctx.console.print(t)
    if res.n_rigid:
        ctx.console.print(f"{res.n_rigid} rigid-body mode(s)")
    ctx.console.print(f"eigen-solution: {res.solver}")
    if uff_path is not None:
        from ..io.uff import write_uff_modes

        write_uff_modes(uff_path, res, nodes=model.nodes, model_name=model.name)
        ctx.console.print(f"modes written to {uff_path}")
    emit(ctx, {
        "model": model.name, "eigenvalues": res.eigenvalues, "frequencies_hz": res.frequencies_hz,
        "dofs": list(res.dofs), "shapes": res.shapes.T, "normalisation": res.normalisation,
        "n_rigid": res.n_rigid,
        "parameters": dict(zip(model.parameter_names, model.resolve(values))),
        "solver": res.solver,
    })


# ---------------------------------------------------------------------------------- correlate
@click.command()
@click.argument("model_path", metavar="MODEL", type=click.Path(dir_okay=False, path_type=Path))
@click.argument("data_path", metavar="DATA", type=click.Path(dir_okay=False, path_type=Path))
@click.option("--min-mac", type=FiniteFloat(0, 1), default=0.5, show_default=True,
              help="Pairing threshold, as in update: below it a pair is dropped (--pairing mac) or not confirmed.")
@click.option("--pairing", type=click.Choice(["auto", "mac", "order", "frequency"]), default="auto", show_default=True,
              help="How test modes pair with model modes: the same rule as update's --pairing.")
@click.option("--close-modes", type=FiniteFloat(min=0, max=0.1, max_open=True), default=0.01, show_default=True,
              help="Relative eigenvalue gap below which model modes are paired as a group, as update pairs them: "
                   "the MAC of the best combination of the group's shapes (0: off).")
@measured_dofs_option
@damping_option
@set_option
@json_option
def correlate(model_path, data_path, min_mac, pairing, close_modes, measured_text, damping_text, set_text, json_path):
    """Pair test and model modes by MAC; frequency errors and COMAC; measured damping ratios against
    the model's (--damping)."""
    from ..correlation import correlate as _correlate
    from ..io.model_file import load_model
    from ..modal import model_modes

    ctx = Ctx(json_path)
    model = load_model(model_path)
    values = model_values(model, set_text)
    data = load_data(data_path, model, measured_text)
    if not data.modes:
        raise InputError(f"{data_path}: no modes to correlate")
    mm = model_modes(model, values, n_modes=None if model.n_dofs <= 1500 else max(len(data.modes) + 4, 10))
    corr = _correlate(data, mm, min_mac=min_mac, pairing=pairing, close_modes=close_modes)
    ctx.console.print(correlation_table(corr, f"{model.name} vs {Path(data_path).name}"))
    damping = damping_fields(data, {i: float(corr.model_frequencies_hz[j]) for i, j, _ in corr.pairs},
                             parse_damping(damping_text, data))
    print_damping(ctx.console, data, damping)
    print_data_notes(ctx, data)
    extra = ({"notes": list(data.notes)} if data.notes else {}) | data_fields(data)
    if damping is not None:
        extra["damping_ratio"] = damping
    emit(ctx, {
        "dofs": list(corr.dofs), "mac": corr.mac, "pairs": [[i, j, m] for i, j, m in corr.pairs],
        "frequencies_hz": {"test": corr.test_frequencies_hz, "model": corr.model_frequencies_hz},
        "frequency_error": corr.frequency_error, "comac": dict(zip(corr.dofs, corr.comac)),
        "unpaired_test": corr.unpaired_test, "unconfirmed": corr.unconfirmed, "pairing": pairing, **extra,
    })
