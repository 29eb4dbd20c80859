"""The click group :data:`cli` of the ``femupdate`` command line, with every command added
(imported by :func:`femupdate.cli.main`, see :mod:`femupdate.cli`)."""

from __future__ import annotations

import logging

import click

from .complex_modes import complex_modes_command
from .damage import damage, rank_modifications, update_multi
from .fullfield import fullfield
from .data import convert_data
from .demo import demo
from .direct import direct
from .frf import frf_command, frf_select_command, surface_command
from .frf_update import frf_update_command
from .modes import correlate, modes
from .paper import paper
from .plan import plan
from .posterior import posterior
from .reduce import reduce
from .summary import summary
from .report import report
from .uniqueness import uniqueness
from .update import update
from .write_back import write_back_command

__all__ = ["cli"]


@click.group(context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(package_name="femupdate")
@click.option("-v", "--verbose", count=True, help="Log progress (-v info, -vv debug).")
def cli(verbose: int) -> None:
    """femupdate: update finite-element models so that they match vibration test data."""
    from ..io.outputs import run_files

    from .. import dask_cluster

    logging.basicConfig(level=logging.WARNING - 10 * min(verbose, 2), format="%(levelname)s %(name)s: %(message)s")
    for handler in logging.getLogger().handlers:
        if not isinstance(handler.formatter, _Plain):  # once: a second run in one process (tests) must not nest them
            handler.setFormatter(_Plain(handler.formatter))
    dask_cluster.QUIET_LIBRARY_LOGS = not verbose  # a lost cluster: one message, the library's logs only with -v
    ctx = click.get_current_context()
    files = ctx.with_resource(run_files())  # the run's inputs and outputs (femupdate.io.outputs), until it ends
    ctx.call_on_close(lambda: _say_replaced(files))


class _Plain(logging.Formatter):
    """femupdate's own announcements to the user (the time a long run will take, the first build
    of the compiled solver: messages that start with ``femupdate:``) as they are; every other
    record as the log format says."""

    def __init__(self, inner: logging.Formatter | None):
        super().__init__()
        self.inner = inner or logging.Formatter("%(levelname)s %(name)s: %(message)s")

    def format(self, record: logging.LogRecord) -> str:
        message = record.getMessage()
        if record.name.startswith("femupdate") and message.startswith("femupdate: "):
            return message
        return self.inner.format(record)


def _say_replaced(files) -> None:
    """One line on stderr per existing file the run replaced."""
    for note in files.replaced_notes():
        click.echo(f"note: {note}", err=True)


# in this order (the order of `cli.commands`; `femupdate --help` lists them sorted by name)
for _command in (modes, complex_modes_command, direct, update, posterior, correlate, paper, demo,
                 damage, update_multi, rank_modifications, fullfield,
                 frf_command, frf_update_command, frf_select_command, surface_command,
                 reduce, uniqueness, plan, convert_data, report, summary, write_back_command):
    cli.add_command(_command)
del _command
