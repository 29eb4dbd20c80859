"""The ``femupdate`` command line (docs/cli.md).

Every command prints a readable summary and, with ``--json PATH`` (``-`` = stdout), writes the
machine-readable result.  Exit codes: 0 success, 2 bad input, 1 numerical failure, 130
interrupted (Ctrl-C), 143 terminated (SIGTERM); errors are one clear message on stderr, never a
traceback.

Layout (imports run one way, from the model code to here): :mod:`._common` holds what the
commands share (console and JSON output, common options, tables, error handling); each other
module defines one command or one family of commands; :mod:`._app` imports them and adds them to
the click group :data:`cli`.  This module stays light — it imports the commands (about 1.5 s of
imports) inside :func:`main`, where an interrupt already ends the program cleanly.
"""

from __future__ import annotations

import os
import signal
import sys

__all__ = ["cli", "main"]


def _terminated(signum, frame):
    from .._errors import Terminated

    raise Terminated()


def _leave_now(signum, frame):  # pragma: no cover - runs while the interpreter shuts down
    code = 143 if signum == signal.SIGTERM else 130
    try:
        sys.stderr.write(f"femupdate: {'terminated' if code == 143 else 'interrupted'}\n")
        sys.stderr.flush()
    finally:
        os._exit(code)


def main(argv=None) -> None:
    """Entry point: run the CLI, turning femupdate errors into one message and an exit code.

    Ctrl-C (SIGINT) ends it with exit code 130 and SIGTERM with 143, at any moment — while the
    commands are imported, during the work (clean-up runs: worker processes end, checkpoints
    stay), or while the interpreter shuts down — with one line on stderr and no traceback.

    Parameters
    ----------
    argv : list of str, optional
        The arguments (default: ``sys.argv[1:]``).  Without them the process is the command's
        own, and an interrupt after the command has finished ends it at once.
    """
    owned = argv is None
    previous = None
    hook = sys.unraisablehook
    sys.unraisablehook = _interrupt_hook
    try:
        previous = _catch_sigterm()
        from ._app import cli
        from ._entry import run

        run(cli, argv)
    except KeyboardInterrupt as exc:  # before run() could catch it: while the commands were imported
        from .._errors import Terminated

        signal.signal(signal.SIGINT, signal.SIG_IGN)  # a second Ctrl-C does not interrupt the goodbye
        terminated = isinstance(exc, Terminated)
        sys.stderr.write(f"femupdate: {'terminated' if terminated else 'interrupted'}\n")
        if owned:  # nothing is written yet; and an interrupt inside a library's exec() of a string
            sys.stderr.flush()  # marks the interpreter to end by SIGINT (-2) however it is handled
            os._exit(143 if terminated else 130)
        sys.exit(143 if terminated else 130)
    finally:
        sys.unraisablehook = hook
        if previous is not None:
            if owned:  # the result is decided: a signal now only ends the process
                signal.signal(signal.SIGINT, _leave_now)
                signal.signal(signal.SIGTERM, _leave_now)
            else:  # a caller's process (tests): leave it as it was
                signal.signal(signal.SIGINT, previous[0])
                signal.signal(signal.SIGTERM, previous[1])


def _interrupt_hook(unraisable) -> None:
    """``sys.unraisablehook`` of a command: an interrupt that lands where Python cannot raise it
    (a callback of the import system, a finaliser: "Exception ignored in ...", with a traceback)
    is delivered again to the main thread, as the same signal, instead of being printed and lost;
    any other unraisable exception goes to the default hook."""
    from .._errors import Terminated

    exc_type = unraisable.exc_type
    if exc_type is not None and issubclass(exc_type, KeyboardInterrupt):
        os.kill(os.getpid(), signal.SIGTERM if issubclass(exc_type, Terminated) else signal.SIGINT)
        return
    sys.__unraisablehook__(unraisable)


def _catch_sigterm():
    """SIGTERM raises :class:`femupdate._errors.Terminated` (a KeyboardInterrupt: the same clean-up
    runs); the previous (SIGINT, SIGTERM) handlers, or None off the main thread (signals belong to
    it)."""
    import threading

    if threading.current_thread() is not threading.main_thread():
        return None
    previous = (signal.getsignal(signal.SIGINT), signal.getsignal(signal.SIGTERM))
    signal.signal(signal.SIGTERM, _terminated)
    return tuple(signal.SIG_DFL if h is None else h for h in previous)


def __getattr__(name: str):
    if name == "cli":  # the click group, imported on first use
        from ._app import cli

        return cli
    raise AttributeError(f"module 'femupdate.cli' has no attribute {name!r}")
