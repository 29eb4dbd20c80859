"""The ``femupdate`` command line (docs/cli.md).

Every command prints a readable summary and, with ``--json PATH`` (``-`` = stdout), writes the
machine-readable result atomically.  Exit codes: 0 success, 2 bad input, 1 numerical failure;
errors are one clear message on stderr, never a traceback.

Layout (imports run one way, from the model code to here): :mod:`._entry` is the entry point
(the environment read once into the library's settings, error handling); :mod:`._common` holds
what the commands share (console and JSON output, common options, tables); each other module
defines one command or one family of commands; this module imports them explicitly and adds
them to the :func:`cli` group.
"""

from __future__ import annotations

import logging

import click

from ._entry import run
from .damage import damage, rank_modifications, update_multi
from .data import convert_data
from .demo import demo
from .direct import direct
from .fullfield import fullfield
from .frf import frf_command, frf_select_command, frf_update_command, surface_command
from .modes import correlate, modes
from .paper import paper
from .posterior import posterior
from .reduce import reduce
from .report import report
from .uniqueness import uniqueness
from .update import update

__all__ = ["cli", "main"]


@click.group(context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(package_name="femupdate")
@click.option("-v", "--verbose", count=True, help="Log progress (-v info, -vv debug).")
def cli(verbose: int) -> None:
    """femupdate: update finite-element models so that they match vibration test data."""
    logging.basicConfig(level=logging.WARNING - 10 * min(verbose, 2), format="%(levelname)s %(name)s: %(message)s")


# in this order (the order of `cli.commands`; `femupdate --help` lists them sorted by name)
for _command in (modes, direct, update, posterior, correlate, paper, demo,
                 damage, update_multi, rank_modifications, fullfield,
                 frf_command, frf_update_command, frf_select_command, surface_command,
                 reduce, uniqueness, convert_data, report):
    cli.add_command(_command)
del _command


def main(argv=None) -> None:
    """Entry point: run the CLI, turning femupdate errors into one message and an exit code."""
    run(cli, argv)
