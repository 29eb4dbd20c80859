"""Process-wide settings of femupdate's numerics: the sparse factorisation backend and BLAS threads.

The library reads no environment variable.  These two choices are a value, :class:`Settings`,
checked once when it is made, installed for the process (:func:`configure`, :func:`install`) or
for a block of code (:func:`using`), and read where they apply: the factorisation layer
(:func:`femupdate.workspace.backend`, when no backend is passed explicitly) and the BLAS threading
policy (:func:`femupdate._threads.threads_for`).

Work sent elsewhere carries the caller's settings with it: local worker processes install them
when they start (their pool's initializer), Dask tasks when they run
(:class:`femupdate.dask_cluster.Task`).  The command line makes them once per command from the
environment variables ``FEMUPDATE_FACTORISATION`` and ``FEMUPDATE_BLAS_THREADS`` (docs/cli.md)
and runs the command under them.

Examples
--------
>>> from femupdate import settings
>>> with settings.using(factorisation="superlu", blas_threads=2):
...     settings.current()
Settings(factorisation='superlu', blas_threads=2)
"""

from __future__ import annotations

import contextlib
import dataclasses
from collections.abc import Iterator

from ._errors import InputError

__all__ = ["Settings", "FACTORISATIONS", "current", "install", "configure", "using"]

#: the sparse factorisation backends: ``auto`` (CHOLMOD where scikit-sparse is installed, else MKL
#: PARDISO where the mkl package is, else SuperLU), ``cholmod``, ``pardiso`` or ``superlu``
#: (:func:`femupdate.workspace.backend`)
FACTORISATIONS = ("auto", "cholmod", "pardiso", "superlu")


@dataclasses.dataclass(frozen=True)
class Settings:
    """The numerics' process-wide choices, checked when made.

    Attributes
    ----------
    factorisation : {"auto", "cholmod", "pardiso", "superlu"}, default ``"auto"``
        The backend of the sparse factorisations (:func:`femupdate.workspace.backend`): CHOLMOD's
        supernodal Cholesky where scikit-sparse is installed, else MKL PARDISO's where the mkl
        package is (``auto``), or the one named.  Whether they are installed is checked when a
        factorisation needs them.
    blas_threads : int, "keep" or None, default None
        None: femupdate's BLAS threading policy (:mod:`femupdate._threads`); a positive integer:
        that many threads in every phase; ``"keep"``: BLAS left as the process found it.

    Raises
    ------
    InputError
        An unknown backend, or a thread count that is neither a positive integer nor ``"keep"``.
    """

    factorisation: str = "auto"
    blas_threads: int | str | None = None

    def __post_init__(self) -> None:
        if self.factorisation not in FACTORISATIONS:
            raise InputError(f"factorisation={self.factorisation!r}: not a factorisation backend (give one of "
                             f"{', '.join(FACTORISATIONS)})")
        t = self.blas_threads
        if not (t is None or t == "keep" or (isinstance(t, int) and not isinstance(t, bool) and t >= 1)):
            raise InputError(f"blas_threads={t!r}: give a positive number of threads, 'keep' or None")

    def replace(self, **changes) -> Settings:
        """A copy with ``changes`` (field names), checked like a new object."""
        return dataclasses.replace(self, **changes)


_current = Settings()


def current() -> Settings:
    """The settings installed for this process.

    Returns
    -------
    Settings
    """
    return _current


def install(settings: Settings) -> Settings:
    """Install ``settings`` for this process (a worker process or Dask task adopting its caller's).

    Parameters
    ----------
    settings : Settings

    Returns
    -------
    Settings
        The settings installed before.
    """
    global _current
    if not isinstance(settings, Settings):
        raise TypeError(f"expected Settings, got {type(settings).__name__}")
    before, _current = _current, settings
    return before


def configure(**changes) -> Settings:
    """Change the process's settings: ``configure(factorisation="superlu")``.

    Parameters
    ----------
    **changes
        Fields of :class:`Settings`.

    Returns
    -------
    Settings
        The settings installed before.
    """
    return install(_current.replace(**changes))


@contextlib.contextmanager
def using(settings: Settings | None = None, **changes) -> Iterator[Settings]:
    """Run the enclosed code under ``settings`` (default: the current ones) changed by
    ``changes``; the previous settings are restored on exit.

    Parameters
    ----------
    settings : Settings, optional
    **changes
        Fields of :class:`Settings`.

    Yields
    ------
    Settings
        The settings in force.
    """
    chosen = (settings if settings is not None else _current).replace(**changes)
    before = install(chosen)
    try:
        yield chosen
    finally:
        install(before)
