"""The entry point's error handling: femupdate's errors, click's, interrupts and signals turned into
one message on stderr and an exit code (0 success, 2 bad input, 1 numerical failure, 130
Ctrl-C, 143 SIGTERM), never a traceback."""

from __future__ import annotations

import sys

import click

from .._errors import FemupdateError


def _interrupted(exc: BaseException) -> None:
    """Exit 143 after SIGTERM (:class:`femupdate._errors.Terminated`), 130 after Ctrl-C."""
    from .._errors import Terminated

    terminated = isinstance(exc, Terminated) or isinstance(exc.__cause__, Terminated)
    click.echo(f"femupdate: {'terminated' if terminated else 'interrupted'}", err=True)
    sys.exit(143 if terminated else 130)


def run(group: click.Group, argv=None) -> None:
    """Run ``group``, turning femupdate errors into one message and an exit code (2 bad input, 1
    numerical failure, 130 Ctrl-C, 143 SIGTERM)."""
    from .. import dask_cluster

    from .._threads import blas_phase

    dask_cluster.QUIET_LIBRARY_LOGS = True  # a lost cluster ends with one message (with -v: the logs too, cli._app)
    try:
        with blas_phase("solve"):  # BLAS threads by phase (femupdate._threads); a bad FEMUPDATE_BLAS_THREADS exits 2
            rv = group.main(args=argv, prog_name="femupdate", standalone_mode=False)
    except click.exceptions.Abort as exc:  # click's name for a KeyboardInterrupt (its cause)
        _interrupted(exc)
    except click.ClickException as exc:
        exc.show()
        sys.exit(exc.exit_code)
    except FemupdateError as exc:
        click.echo(f"femupdate: error: {exc}", err=True)
        sys.exit(exc.exit_code)
    except KeyboardInterrupt as exc:
        _interrupted(exc)
    except OSError as exc:  # e.g. an output folder that cannot be created or written
        where = f"{exc.filename}: " if getattr(exc, "filename", None) else ""
        click.echo(f"femupdate: error: {where}{exc.strerror or exc}", err=True)
        sys.exit(2)
    except MemoryError:
        click.echo("femupdate: error: out of memory (try fewer modes or a smaller model)", err=True)
        sys.exit(1)
    sys.exit(rv if isinstance(rv, int) else 0)
