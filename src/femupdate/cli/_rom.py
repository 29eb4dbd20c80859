"""``--reduced-basis`` and its options (``update``): update on a parametric reduced model, every
answer checked on the full model (:mod:`femupdate.rom`; docs/reduced-models.md)."""

from __future__ import annotations

from collections.abc import Callable

import click

from ._common import FiniteFloat
from ._groups import option_group


def _build(reduced_basis: bool, rom_freq_tol: float, rom_shape_tol: float, rom_modes: int | None,
           rom_points: int, rom_rounds: int):
    if not reduced_basis:
        return None
    from ..rom.update import ROMOptions

    return ROMOptions(n_modes=rom_modes, freq_tol=rom_freq_tol, shape_tol=rom_shape_tol, max_points=rom_points,
                      max_rounds=rom_rounds)


def rom_group() -> Callable:
    """The option group ``Reduced model`` -> ``rom``: a ROMOptions, or None without ``--reduced-basis``."""
    return option_group(
        "Reduced model", "rom", _build,
        click.option("--reduced-basis", "--rom", "reduced_basis", is_flag=True, default=False,
                     help="Update on a parametric reduced model (a greedy Ritz basis of the full model's modes and "
                          "their static corrections); every start's answer is checked on the full model and the "
                          "basis enriched there until the check passes."),
        click.option("--rom-freq-tol", type=FiniteFloat(min=0, min_open=True), default=1e-6, show_default=True,
                     help="Largest relative frequency error of a paired mode at a checked answer (full model)."),
        click.option("--rom-shape-tol", type=FiniteFloat(min=0, min_open=True), default=1e-6, show_default=True,
                     help="Largest 1 - MAC at the data's dofs between a reduced mode and the full one."),
        click.option("--rom-modes", type=click.IntRange(min=1), default=None,
                     help="Modes per snapshot of the basis (default: the test modes plus 4)."),
        click.option("--rom-points", type=click.IntRange(min=1), default=4, show_default=True,
                     help="Most parameter points of the greedy basis (the nominal one included)."),
        click.option("--rom-rounds", type=click.IntRange(min=1), default=4, show_default=True,
                     help="Most check-and-enrich rounds of a start."),
    )
