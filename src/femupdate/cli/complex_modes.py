"""``femupdate complex-modes``: the complex modes of a model with a ``[damping]`` table."""

from __future__ import annotations

import click
from rich.table import Table

from ._common import INPUT_FILE, Ctx, emit, fmt, json_option


@click.command("complex-modes")
@click.argument("model_path", metavar="MODEL", type=INPUT_FILE)
@click.option("--n-modes", type=click.IntRange(min=1), default=None,
              help="Number of underdamped modes (default all for small models, 6 for large).")
@click.option("--method", type=click.Choice(["auto", "dense", "sparse"]), default="auto", show_default=True)
@json_option
def complex_modes_command(model_path, n_modes, method, json_path):
    """Complex modes of MODEL with its damping: eigenvalues, frequencies, damping ratios and the
    complexity of each shape (MPC, MPD).

    The damping is the model file's [damping] table (Rayleigh alpha and beta, dampers, loss
    factors, C matrices, modal damping ratios); without one the modes are undamped.
    """
    from ..damping import complex_modes, load_damped_model

    from .._errors import InputError

    ctx = Ctx(json_path)
    dm = load_damped_model(model_path)
    try:
        res = complex_modes(dm, n_modes=n_modes, method=method)
    except InputError as exc:
        raise InputError(f"{model_path}: {exc}") from None
    t = Table(title=f"{dm.name}: {dm.n_dofs} dofs, {res.n_modes} complex modes (f = |λ|/2π, ζ = -Re λ/|λ|)")
    for col in ("mode", "f [Hz]", "ζ", "Re λ \\[1/s]", "Im λ \\[rad/s]", "MPC", "MPD [°]"):
        t.add_column(col, justify="right")
    for r in range(res.n_modes):
        lam = res.eigenvalues[r]
        t.add_row(str(r + 1), fmt(res.natural_frequencies_hz[r]), f"{res.damping_ratios[r]:.4g}", f"{lam.real:.5g}",
                  f"{lam.imag:.5g}", f"{res.mpc[r]:.4f}", f"{res.mpd[r]:.2g}")
    ctx.console.print(t)
    notes = []
    if res.n_rigid:
        notes.append(f"{res.n_rigid} zero eigenvalue(s) (rigid-body motion) left out")
    if res.n_overdamped:
        notes.append(f"{res.n_overdamped} real eigenvalue(s) (overdamped motion) left out")
    for note in notes:
        ctx.console.print(note, markup=False)
    norm = "in modal coordinates" if res.modal else "phi^T (2 lambda M + C) phi = 1"
    ctx.console.print(f"eigen-solution: {res.solver}; shapes normalised {norm}", markup=False)
    emit(ctx, res.to_json(dm.name, dict(zip(dm.parameter_names, dm.resolve().tolist()))))
