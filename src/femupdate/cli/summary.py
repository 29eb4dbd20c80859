"""``femupdate summary``: what a model holds (:func:`femupdate.summary.model_summary`)."""

from __future__ import annotations

from pathlib import Path

import click
from rich.table import Table

from ._common import INPUT_FILE, Ctx, fmt, model_values
from ._groups import GroupedCommand
from .outputs import Outputs, outputs_group


def _structure_of(model_path):
    """The Structure of a structure model file (elements, sets), or None for a matrices model."""
    from ..io.model_file import EXTERNAL, read_toml
    from ..structure import Structure

    raw = read_toml(Path(model_path))
    if "matrices" in raw or set(EXTERNAL) & set(raw):
        return None
    return Structure.from_dict(raw, source=str(model_path))


def _print(ctx: Ctx, s: dict) -> None:
    c = ctx.console
    dirs = ", ".join(f"{n} {d}" for d, n in s["dofs_by_direction"].items())
    c.print(f"{s['name']}: {s['n_dofs']} free dofs ({dirs}) at {s['n_nodes']} nodes", markup=False)
    if s["elements"]:
        c.print("elements: " + ", ".join(f"{n} {t}" for t, n in s["elements"].items()), markup=False)
    if s["sets"]:
        c.print("sets: " + ", ".join(f"{k} ({n} elements)" for k, n in s["sets"].items()), markup=False)
    if s["parameters"]:
        t = Table(title="parameters")
        for col in ("name", "value", "unit", "enters"):
            t.add_column(col)
        for p in s["parameters"]:
            t.add_row(p["name"], fmt(p["value"]), p["unit"], ", ".join(p["enters"]) + (" (fixed)" if p["fixed"] else ""))
        c.print(t)
    m = s["mass"]
    for key, what in (("free", "mass at the free dofs (rᵀ M r)"), ("total", "total mass, supports removed")):
        if m[key]:
            c.print(f"{what}: " + ", ".join(f"{d} {fmt(v)}" for d, v in m[key].items()) + " kg", markup=False)
    if m["by_type"] and len(m["by_type"]) > 1:
        c.print("mass by element type: " + ", ".join(f"{t} {fmt(max(v.values(), default=0.0))}"
                                                    for t, v in m["by_type"].items()) + " kg", markup=False)
    sh = s["stiffness_shares"]
    t = Table(title="share of the stiffness: diagonal (trace) and strain energy in the first flexible modes")
    t.add_column("term")
    t.add_column("trace [%]", justify="right")
    for r, f in zip(sh["modes"], sh["frequencies_hz"]):
        t.add_column(f"mode {r} ({fmt(f)} Hz) [%]", justify="right")
    for name, share in sh["trace"].items():
        t.add_row(name, f"{100 * share:.3g}", *(f"{100 * e:.3g}" for e in sh["energy"][name]))
    c.print(t)


@click.command(cls=GroupedCommand)
@click.argument("model_path", metavar="MODEL", type=INPUT_FILE)
@click.option("--n-modes", type=click.IntRange(min=1, max=50), default=3, show_default=True,
              help="Flexible modes whose strain energy is split among the stiffness terms.")
@outputs_group(report=False)
def summary(model_path, n_modes: int, outputs: Outputs):
    """What MODEL holds: dofs, elements by type, sets, parameters, mass (rigid-body translation
    mass rᵀ M r) and each parameter matrix's share of the stiffness (trace and modal strain energy)."""
    from ..io.model_file import load_model
    from ..summary import model_summary

    ctx = Ctx(outputs.json_path)
    model = load_model(model_path)
    values = model_values(model, outputs.set_text)
    s = model_summary(model, _structure_of(model_path), values, n_modes)
    _print(ctx, s)
    outputs.emit(ctx, s)
