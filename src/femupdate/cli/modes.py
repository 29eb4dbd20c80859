"""``femupdate modes`` (natural frequencies and mode shapes) and ``correlate`` (test against model modes)."""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from pathlib import Path

import click
from rich.table import Table

from .._errors import InputError
from ..options import PairingOptions
from ._common import INPUT_FILE, Ctx, correlation_table, fmt, model_values, option_dofs, print_damping, print_data_notes
from ._groups import GroupedCommand, option_group
from .data_options import DataSpec, pairing_group, test_data_group
from .outputs import Outputs, outputs_group
from .testpoints import TestPointsSpec, test_points_group


@dataclasses.dataclass(frozen=True)
class ModesSpec:
    """``modes``' options of the eigen-solution, as typed (:func:`modes_group`)."""

    n_modes: int | None
    normalisation: str
    method: str

    def normalisation_for(self, model) -> str:
        """The normalisation, a ``ref:`` dof as the model's label (``#N`` resolved)."""
        if self.normalisation.startswith("ref:"):
            return "ref:" + option_dofs([self.normalisation[4:]], model, "--normalise")[0]
        return self.normalisation

    def check(self, model) -> None:
        """Refuse more modes than the model has dofs."""
        if self.n_modes is not None and self.n_modes > model.n_dofs:
            raise InputError(f"--n-modes {self.n_modes}: the model has only {model.n_dofs} dofs")


def modes_group() -> Callable:
    """``--n-modes``, ``--normalise``, ``--method`` -> ``modal``: :class:`ModesSpec`."""
    return option_group(
        "Modes", "modal", lambda **kw: ModesSpec(**kw),
        click.option("--n-modes", type=click.IntRange(min=1), default=None,
                     help="Number of modes (default all for small models, 10 for large)."),
        click.option("--normalise", "--normalize", "normalisation", default="mass", show_default=True,
                     help="mass | unit | max | ref:<dof> (a label, or #N: the N-th model dof)"),
        click.option("--method", type=click.Choice(["auto", "dense", "sparse"]), default="auto", show_default=True),
    )


# ---------------------------------------------------------------------------------- modes
@click.command(cls=GroupedCommand)
@click.argument("model_path", metavar="MODEL", type=INPUT_FILE)
@modes_group()
@outputs_group(uff="Also write the modes as universal file datasets 55 (with nodes 2411).", report=False)
def modes(model_path, modal: ModesSpec, outputs: Outputs):
    """Natural frequencies and mode shapes of MODEL."""
    from ..io.model_file import load_model
    from ..modal import model_modes

    ctx = Ctx(outputs.json_path)
    model = load_model(model_path)
    values = model_values(model, outputs.set_text)
    normalisation = modal.normalisation_for(model)
    if outputs.uff_path is not None:
        from ..io.uff.write import uff_dofs

        uff_dofs(model.dofs, "modes --uff")  # before the eigen-solution: named nodes cannot be written
    modal.check(model)
    res = model_modes(model, values, n_modes=modal.n_modes, normalisation=normalisation, method=modal.method)
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
    if outputs.uff_path is not None:
        from ..io.uff import write_uff_modes

        from types import SimpleNamespace

        from ..constraints import expand_shapes

        dofs, shapes = expand_shapes(model, res.shapes)  # the dofs rigid links eliminated, recovered
        full = SimpleNamespace(eigenvalues=res.eigenvalues, shapes=shapes, dofs=dofs)
        write_uff_modes(outputs.uff_path, full, nodes=model.nodes, model_name=model.name)
        ctx.console.print(f"modes written to {outputs.uff_path}")
    outputs.emit(ctx, res.to_json())


# ---------------------------------------------------------------------------------- correlate
@click.command(cls=GroupedCommand)
@click.argument("model_path", metavar="MODEL", type=INPUT_FILE)
@click.argument("data_path", metavar="DATA", type=INPUT_FILE)
@pairing_group()
@test_data_group(damping=True)
@test_points_group()
@outputs_group(report=False)
def correlate(model_path, data_path, pairing: tuple[PairingOptions, float], data_spec: DataSpec,
              test_points: TestPointsSpec, outputs: Outputs):
    """Pair test and model modes by MAC; frequency errors and COMAC; measured damping ratios against
    the model's (--damping)."""
    from ..correlation import correlate as _correlate
    from ..io.model_file import load_model
    from ..modal import model_modes

    ctx = Ctx(outputs.json_path)
    model = load_model(model_path)
    values = model_values(model, outputs.set_text)
    if test_points.tolerance is None:
        data, mapped = data_spec.load(data_path, model), None
    else:  # test nodes placed on the mesh by their coordinates
        model, data, mapped = test_points.load(model_path, model, data_path, data_spec.measured_text)
    if not data.modes:
        raise InputError(f"{data_path}: no modes to correlate")
    mm = model_modes(model, values, n_modes=None if model.n_dofs <= 1500 else max(len(data.modes) + 4, 10))
    rule, close_modes = pairing
    corr = _correlate(data, mm, min_mac=rule.min_mac, pairing=rule.rule, close_modes=close_modes)
    ctx.console.print(correlation_table(corr, f"{model.name} vs {Path(data_path).name}"))
    corr = corr.with_context(damping=data_spec.damping(data))
    print_damping(ctx.console, data, corr.payload().get("damping_ratio"))  # as computed (the JSON's NaN are null)
    print_data_notes(ctx, data)
    payload = corr.to_json()
    if mapped is not None:
        payload["test_points"] = mapped.to_json()
    outputs.emit(ctx, payload)
