"""Option groups of the commands that read test data without updating iteratively (``correlate``,
``direct``): the test data's measured dofs and the model's damping (:func:`test_data_group`), and
how test modes pair with model modes (:func:`pairing_group`)."""

from __future__ import annotations

import dataclasses
from collections.abc import Callable

import click

from ..options import PairingOptions
from ._common import FiniteFloat, load_data, measured_dofs_option
from ._groups import option_group
from .frf import damping_option, parse_damping


@dataclasses.dataclass(frozen=True)
class DataSpec:
    """The test data's options as typed (:func:`test_data_group`)."""

    measured_text: str | None = None
    damping_text: str | None = None

    def load(self, path, model):
        """The test data in ``path`` for ``model``, ``--measured-dofs`` their sensors
        (:func:`~femupdate.cli._common.load_data`)."""
        return load_data(path, model, self.measured_text)

    def damping(self, data):
        """The model's damping of ``--damping`` (``fit``: fitted to ``data``'s damping ratios)."""
        return parse_damping(self.damping_text, data)


def test_data_group(damping: bool = False) -> Callable:
    """``--measured-dofs`` (and ``--damping``) -> ``data_spec``: :class:`DataSpec`."""
    options = [measured_dofs_option]
    if damping:
        options.append(damping_option)
    return option_group("Test data", "data_spec", lambda **kw: DataSpec(**kw), *options)


def pairing_group() -> Callable:
    """``--min-mac``, ``--pairing``, ``--close-modes`` -> ``pairing``: (:class:`~femupdate.options.PairingOptions`,
    the relative gap of close modes)."""
    return option_group(
        "Pairing", "pairing",
        lambda min_mac, rule, close_modes: (PairingOptions(rule=rule, min_mac=min_mac), close_modes),
        click.option("--min-mac", type=FiniteFloat(0, 1), default=0.5, show_default=True,
                     help="Pairing threshold, as in update: below it a pair is dropped (--pairing mac) or not "
                          "confirmed."),
        click.option("--pairing", "rule", type=click.Choice(["auto", "mac", "order", "frequency"]), default="auto",
                     show_default=True, help="How test modes pair with model modes: the same rule as update's "
                                             "--pairing."),
        click.option("--close-modes", type=FiniteFloat(min=0, max=0.1, max_open=True), default=0.01, show_default=True,
                     help="Relative eigenvalue gap below which model modes are paired as a group, as update pairs "
                          "them: the MAC of the best combination of the group's shapes (0: off)."),
    )


__all__ = ["DataSpec", "test_data_group", "pairing_group"]
