"""The environment variables of the command line, read once per command into the library's
:class:`~femupdate.settings.Settings` (the library itself reads no environment variable).

``FEMUPDATE_FACTORISATION``: ``auto`` (default), ``cholmod`` or ``superlu``, the sparse
factorisation backend.  ``FEMUPDATE_BLAS_THREADS``: a positive integer or ``keep``, overriding the
BLAS threading policy.  A bad value exits 2 with one message naming the variable as it was set.
"""

from __future__ import annotations

from collections.abc import Mapping

from .._errors import InputError
from ..settings import FACTORISATIONS, Settings

__all__ = ["FACTORISATION_VARIABLE", "THREADS_VARIABLE", "settings_from"]

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
        scikit-sparse; the message names the variable and its value.
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
