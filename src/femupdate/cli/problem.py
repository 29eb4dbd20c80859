"""The options of the updating problem that ``update`` and ``posterior`` share — the updated
parameters, the residuals and pairing of the modes, the kinds of data, their standard deviations
and the FRF residuals — as one option group (:func:`problem_group`) that hands the command a
:class:`ProblemSpec`: the options as typed, resolved against the model and data the command
loads into the parameters, the data and one :class:`~femupdate.options.UpdateOptions`."""

from __future__ import annotations

import dataclasses
from collections.abc import Callable

import click

from .._errors import InputError
from .._limits import MAX_MAGNITUDE
from ..dofs import is_index
from ..options import FRFOptions, ModalOptions, NoiseOptions, PairingOptions, SolverOptions, UpdateOptions
from ..testdata import TestData
from ._common import FiniteFloat, measured_dofs_option, option_dofs, parse_std
from ._groups import option_group
from .frf import apply_reciprocity, frf_line_options, frf_options, parse_damping, reciprocity_option


@dataclasses.dataclass(frozen=True)
class Resolved:
    """The problem of a command: what :func:`femupdate.update` takes, and the model damping the
    data's damping ratios are compared with."""

    params: list[str] | None
    data: TestData
    kinds: tuple[str, ...]
    options: UpdateOptions
    damping: object


@dataclasses.dataclass(frozen=True)
class ProblemSpec:
    """The problem's options as the command line gave them (:func:`problem_group`)."""

    params_text: str | None
    shape_scaling: str
    ref_dof: str | None
    parametrisation: str
    min_mac: float
    pairing: str
    n_modes: int | None
    formulation: str
    eigenvalues_only: bool
    measured_text: str | None
    use_text: str | None
    std_eigenvalue: str | None
    std_shape: str | None
    std_damping_ratio: str | None
    std_frf: float | None
    std_static: float | None
    residual: str
    lines_text: str | None
    select: int | None
    resonance: str
    resonance_tol: float
    damping_text: str | None
    reciprocity: bool
    close_modes: float = 1e-2
    sensitivity: str = "auto"

    def resolve(self, model, data, solver: SolverOptions | None = None) -> Resolved:
        """The parameters, the test data (regrouped by ``--reciprocity``), the kinds of data used,
        the update's options (with ``solver``, its parametrisation this group's) and the
        ``--damping`` given (with modes alone it is compared with their damping ratios).

        Raises
        ------
        InputError
            A reference dof, standard deviations or FRF options that do not fit the data (named).
        """
        ref_dof = self.ref_dof
        if ref_dof is not None and is_index(ref_dof):  # a label is checked, and named, by the updating itself
            (ref_dof,) = option_dofs([ref_dof], model, "--ref-dof")
        params = [p.strip() for p in self.params_text.split(",") if p.strip()] if self.params_text else None
        std_eigenvalue = parse_std(self.std_eigenvalue, "--std-eigenvalue", len(data.modes))
        std_shape = parse_std(self.std_shape, "--std-shape", len(data.modes))
        std_zeta = parse_std(self.std_damping_ratio, "--std-damping-ratio", len(data.modes))
        if std_zeta is not None:
            from ..testdata import check_std_damping_ratio

            for v in (std_zeta if isinstance(std_zeta, list) else [std_zeta]):
                check_std_damping_ratio(v, "--std-damping-ratio")
        std = {k: v for k, v in (("eigenvalue", std_eigenvalue), ("shape", std_shape), ("damping_ratio", std_zeta),
                                 ("frf", self.std_frf), ("static", self.std_static)) if v is not None} or None
        use = (tuple(u.strip() for u in self.use_text.split(",") if u.strip()) if self.use_text
               else ("modes", "frf", "static"))
        from ..updating import data_kinds

        kinds = data_kinds(data, use)
        if self.reciprocity and "frf" not in kinds:
            raise InputError(f"--reciprocity: no FRF data are used ({', '.join(kinds)})")
        data = apply_reciprocity(data, self.reciprocity)
        if std_shape is not None:  # said rather than ignored
            if "modes" not in kinds or not any(m.dofs for m in data.modes):
                raise InputError("--std-shape: the data used have no mode shapes")
            if self.eigenvalues_only:
                raise InputError("--std-shape with --eigenvalues-only: the mode shapes are not used")
        damping = parse_damping(self.damping_text, data)  # with modes alone: compared with their damping ratios
        frf = FRFOptions()
        if "frf" in kinds:
            frf = FRFOptions(**frf_options(self.residual, self.lines_text, self.select, self.resonance,
                                           self.resonance_tol, self.damping_text, data))
        else:
            given = [opt for opt, v in (("--residual", self.residual != FRFOptions.residual),
                                        ("--lines", bool(self.lines_text)), ("--select", self.select is not None),
                                        ("--resonance", self.resonance != "skip"),
                                        ("--resonance-tol", self.resonance_tol != 1e-3)) if v]
            if given:
                raise InputError(f"{', '.join(given)}: FRF option(s) given, but no FRF data are used "
                                 f"({', '.join(kinds)})")
        solver = (solver or SolverOptions()).replace(parametrisation=self.parametrisation)
        options = UpdateOptions(
            use=kinds, solver=solver, frf=frf, noise=NoiseOptions(std=std),
            modal=ModalOptions(formulation=self.formulation, shape_scaling=self.shape_scaling, ref_dof=ref_dof,
                               use_shapes=not self.eigenvalues_only, sensitivity=self.sensitivity,
                               close_modes=self.close_modes),
            pairing=PairingOptions(rule=self.pairing, min_mac=self.min_mac, n_modes=self.n_modes))
        return Resolved(params, data, kinds, options, damping)


_OPTIONS = (
    click.option("--params", "params_text", default=None, help="Parameters to update (default: all not fixed)."),
    click.option("--shape-scaling", type=click.Choice(["unit", "ref", "max"]), default="unit", show_default=True),
    click.option("--ref-dof", default=None,
                 help="Reference dof for --shape-scaling ref, a label or #N (default: first measured dof)."),
    click.option("--parametrisation", type=click.Choice(["relative", "log", "absolute"]), default="relative",
                 show_default=True),
    click.option("--min-mac", type=FiniteFloat(0, 1), default=0.5, show_default=True,
                 help="Pairing threshold: the MAC a pair of shaped modes must reach (--pairing mac), or that "
                      "confirms a pairing (auto)."),
    click.option("--pairing", type=click.Choice(["auto", "mac", "order", "frequency"]), default="auto",
                 show_default=True,
                 help="How test modes pair with model modes: auto (by frequency order until the shapes show a "
                      "swap, then by MAC; never abandons a start), mac (a test mode below --min-mac fails), order, "
                      "or frequency (nearest frequency, MAC deciding within 10 %)."),
    click.option("--n-modes", type=click.IntRange(min=1), default=None,
                 help="Model modes computed and paired among (default max(2T, T + 6) for T test modes)."),
    click.option("--close-modes", type=FiniteFloat(min=0, max=0.1, max_open=True), default=0.01, show_default=True,
                 help="Relative eigenvalue gap below which model modes count as repeated or close: a test mode "
                      "paired into such a group is compared with the combination of the group's shapes that fits "
                      "it best (its pairing inside the group by the measured shapes); 0: off (repeated modes "
                      "fail)."),
    click.option("--formulation", type=click.Choice(["shapes", "mac", "dynamic"]), default="shapes",
                 show_default=True,
                 help="Residuals of the measured modes: shapes (relative eigenvalue errors and scaled shape "
                      "differences), mac (relative eigenvalue errors and 1 - MAC terms), or dynamic (the modal "
                      "dynamic residual (K - lambda M) phi of every dof, the unmeasured shape entries as unknowns; "
                      "every mode needs a shape)."),
    click.option("--eigenvalues-only", is_flag=True, help="Ignore the measured shapes (frequencies only)."),
    measured_dofs_option,
    click.option("--use", "use_text", default=None, metavar="KINDS",
                 help="Kinds of data to use: modes, frf, static, comma-separated (default: all the data hold)."),
    click.option("--std-eigenvalue", "std_eigenvalue", default=None, metavar="S|S1,S2,...",
                 help="Relative std of the measured eigenvalues (for the covariance): one value, or one per test "
                      "mode; replaces the test data's std_frequency / std_eigenvalue."),
    click.option("--std-shape", "std_shape", default=None, metavar="S|S1,S2,...",
                 help="Std of the scaled shape entries (for the covariance): one value, or one per test mode; "
                      "replaces the test data's std_shape."),
    click.option("--std-damping-ratio", "std_damping_ratio", default=None, metavar="S|S1,S2,...",
                 help="Std of the measured damping ratios (absolute, fractions of critical): one value, or one per "
                      "test mode; replaces the test data's std_damping_ratio (a model with a [damping] table)."),
    click.option("--std-frf", type=FiniteFloat(min=1 / MAX_MAGNITUDE), default=None,
                 help="Std of the FRF residual entries (weights FRFs against other data)."),
    click.option("--std-static", type=FiniteFloat(min=1 / MAX_MAGNITUDE), default=None,
                 help="Std of measured static deflections, m (weights them)."),
    frf_line_options,
    reciprocity_option,
)

_SENSITIVITY = click.option(
    "--sensitivity", type=click.Choice(["auto", "nelson", "modal", "static", "subspace", "adjoint", "fd"]),
    default="auto", show_default=True,
    help="Route of the eigenvector derivatives (auto: Nelson up to 1,500 dofs, adjoint/subspace above).")


def problem_group(sensitivity: bool = False) -> Callable:
    """The problem's options (and ``--sensitivity`` where the command offers it) -> ``problem``:
    a :class:`ProblemSpec`."""
    options = (*_OPTIONS, _SENSITIVITY) if sensitivity else _OPTIONS
    return option_group("Updating problem", "problem", ProblemSpec, *options)


__all__ = ["ProblemSpec", "Resolved", "problem_group"]
