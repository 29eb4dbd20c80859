"""Exception hierarchy.

Every error a user can provoke is a :class:`FemupdateError` whose message names the culprit
(file, field, dof or parameter).  The command line maps :class:`InputError` to exit code 2 and
:class:`NumericalError` to exit code 1, printing the message without a traceback.
"""

from __future__ import annotations


class FemupdateError(Exception):
    """Base class of femupdate's own errors."""

    exit_code = 1


class InputError(FemupdateError, ValueError):
    """Bad input: malformed or inconsistent files, unknown dofs, NaN, non-physical values."""

    exit_code = 2

    #: offending positions in an element group; set only on the errors of
    #: :mod:`femupdate.elements` (read with ``getattr(exc, "positions", None)``)
    positions: list[int]


class NumericalError(FemupdateError, ArithmeticError):
    """A numerical failure (singular system, no convergence).

    ``partial`` carries whatever partial result was available when the failure occurred.
    """

    exit_code = 1

    def __init__(self, message: str, partial=None):
        super().__init__(message)
        self.partial = partial


class Terminated(KeyboardInterrupt):
    """The process received SIGTERM (a job scheduler or a time limit ending it).

    The command line turns the signal into this exception, a :class:`KeyboardInterrupt`, so that
    what runs on Ctrl-C runs too — worker processes end, finished work stays in the checkpoints —
    and then exits with code 143.
    """
