"""The entry point of every command (:func:`run`): the environment read once into the library's
:class:`~femupdate.settings.Settings` (the library itself reads no environment variable), the
command run under them, its errors, interrupts and signals turned into one message on stderr and
an exit code (0 success, 2 bad input, 1 numerical failure, 130 Ctrl-C, 143 SIGTERM), never a
traceback.

``FEMUPDATE_FACTORISATION``: ``auto`` (default), ``cholmod`` or ``superlu``, the sparse
factorisation backend.  ``FEMUPDATE_BLAS_THREADS``: a positive integer or ``keep``, overriding the
BLAS threading policy.  A bad value exits 2 with one message naming the variable as it was set.
"""

from __future__ import annotations

import sys
from collections.abc import Mapping

import click

from .._errors import FemupdateError, InputError
from ..settings import FACTORISATIONS, Settings

__all__ = ["FACTORISATION_VARIABLE", "THREADS_VARIABLE", "settings_from", "run"]

#: chooses the sparse factorisation backend (:attr:`Settings.factorisation`)
FACTORISATION_VARIABLE = "FEMUPDATE_FACTORISATION"
#: overrides the BLAS threading policy (:attr:`Settings.blas_threads`)
THREADS_VARIABLE = "FEMUPDATE_BLAS_THREADS"


def settings_from(environ: Mapping[str, str]) -> Settings:
    """The settings a command runs under, from its environment.

    Parameters
    ----------
    environ : mapping of str to str
        ``os.environ``, or a stand-in.

    Returns
    -------
    Settings

    Raises
    ------
    InputError
        A variable with a value it does not take, or ``FEMUPDATE_FACTORISATION=cholmod`` without
        scikit-sparse (``pardiso`` without MKL); the message names the variable and its value.
    """
    raw = environ.get(FACTORISATION_VARIABLE)
    choice = (raw or "").strip().lower() or "auto"
    if choice not in FACTORISATIONS:
        raise InputError(f"{FACTORISATION_VARIABLE}={raw!r}: not a factorisation backend "
                         f"(give one of {', '.join(FACTORISATIONS)})")
    if choice == "cholmod":
        from ..workspace import cholmod_installed

        if not cholmod_installed():
            raise InputError(f"{FACTORISATION_VARIABLE}=cholmod needs scikit-sparse (pip install 'femupdate[cholmod]', "
                             "with SuiteSparse's headers installed)")
    if choice == "pardiso":
        from ..workspace import pardiso_installed

        if not pardiso_installed():
            raise InputError(f"{FACTORISATION_VARIABLE}=pardiso needs MKL (pip install mkl, on x86_64; "
                             "pip install femupdate brings it there)")
    raw = environ.get(THREADS_VARIABLE)
    text = (raw or "").strip().lower()
    threads: int | str | None = None
    if text == "keep":
        threads = "keep"
    elif text:
        if not text.isdecimal() or int(text) < 1:
            raise InputError(f"{THREADS_VARIABLE}={raw!r}: give a positive number of threads, or keep")
        threads = int(text)
    return Settings(factorisation=choice, blas_threads=threads)


# ---------------------------------------------------------------------------------- entry point
def _interrupted(exc: BaseException) -> None:
    """Exit 143 after SIGTERM (:class:`femupdate._errors.Terminated`), 130 after Ctrl-C."""
    from .._errors import Terminated

    terminated = isinstance(exc, Terminated) or isinstance(exc.__cause__, Terminated)
    click.echo(f"femupdate: {'terminated' if terminated else 'interrupted'}", err=True)
    sys.exit(143 if terminated else 130)


def run(group: click.Group, argv=None) -> None:
    """Run ``group``, turning femupdate errors into one message and an exit code (2 bad input, 1
    numerical failure, 130 Ctrl-C, 143 SIGTERM)."""
    import os

    from .. import dask_cluster, settings
    from .._threads import blas_phase

    dask_cluster.QUIET_LIBRARY_LOGS = True  # a lost cluster ends with one message (with -v: the logs too, cli._app)
    try:
        # the environment read once (FEMUPDATE_FACTORISATION, FEMUPDATE_BLAS_THREADS; a bad value exits 2), the
        # command run under those settings (restored after it), BLAS threads by phase (femupdate._threads)
        with settings.using(settings_from(os.environ)), blas_phase("solve"):
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
