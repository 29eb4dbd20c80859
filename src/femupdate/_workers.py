"""Local worker processes that never outlive the process that started them.

A pool of worker processes (:func:`process_pool`: the per-start pool of multi-start updating, the
paper's sections) ends with its owner however the owner ends:

* an exception in the owner — an error, Ctrl-C (KeyboardInterrupt), SIGTERM (turned into
  :class:`femupdate._errors.Terminated` by the command line) — cancels the queued work and
  terminates the workers at once, instead of waiting for every queued task;
* the owner killed (SIGKILL, or a crash) — on Linux every worker asks the kernel for SIGKILL when
  its parent ends (``prctl(PR_SET_PDEATHSIG)``: a fork server's workers when the fork server
  ends, which it does when its owner's end closes its pipe); everywhere, a watchdog thread in each
  worker ends it within :data:`WATCH_SECONDS` when its parent or its owner is gone.

Workers ignore SIGINT: Ctrl-C at a terminal reaches the whole process group, and the owner ends
its workers itself (a worker interrupted between two tasks would print a traceback); the fork
server starts with SIGINT blocked for the same reason.

:func:`bind_to_owner` does the same for any child process (the compiling process of
:mod:`femupdate.updating.batched.kernel`).  This module imports only the standard library.
"""

from __future__ import annotations

import contextlib
import os
import signal
import sys
import threading
import time

#: seconds between two checks of the watchdog thread
WATCH_SECONDS = 0.2


def _alive(pid: int) -> bool:
    """``pid`` is a running process (a zombie — ended, not yet reaped — counts as ended)."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:  # another user's process
        return True
    try:
        with open(f"/proc/{pid}/stat", "rb") as fh:
            return fh.read().rsplit(b")", 1)[1].split()[0] not in (b"Z", b"X")
    except (OSError, IndexError):
        return True  # no /proc: trust kill(pid, 0)


def _die_with_parent() -> None:
    """Linux: SIGKILL this process when its parent ends (nothing elsewhere)."""
    if not sys.platform.startswith("linux"):
        return
    try:
        import ctypes

        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(1, int(signal.SIGKILL), 0, 0, 0)  # PR_SET_PDEATHSIG = 1
    except (OSError, AttributeError):  # pragma: no cover - no prctl
        pass


def bind_to_owner(owner: int) -> None:
    """Make this (child) process end when its parent ends or ``owner`` (the process that wanted
    it) ends: ``prctl(PR_SET_PDEATHSIG, SIGKILL)`` on Linux, and a daemon watchdog thread.

    Parameters
    ----------
    owner : int
        The PID of the process whose work this process does.
    """
    parent = os.getppid()
    _die_with_parent()
    if not _alive(owner) or os.getppid() != parent:  # it ended before the death signal was asked for
        os._exit(1)

    def watch():
        while True:
            time.sleep(WATCH_SECONDS)
            if os.getppid() != parent or not _alive(owner):
                os._exit(1)

    threading.Thread(target=watch, name="femupdate-owner-watch", daemon=True).start()


def _start_worker(owner: int, initializer, initargs) -> None:
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    bind_to_owner(owner)
    if initializer is not None:
        initializer(*initargs)


def _stop(pool) -> None:
    """Cancel the queued tasks and end the workers now (not after the tasks already sent)."""
    table = dict(getattr(pool, "_processes", None) or {})  # PID -> process, read before shutdown clears it
    procs = list(table.values())
    terminate = getattr(pool, "terminate_workers", None)  # Python 3.14
    pool.shutdown(wait=False, cancel_futures=True)
    if terminate is not None:
        with contextlib.suppress(Exception):
            terminate()
    for p in procs:
        with contextlib.suppress(Exception):
            p.kill()
    for p in procs:
        with contextlib.suppress(Exception):
            p.join(1.0)
    for pid in table:  # in case a process object could not be signalled
        with contextlib.suppress(OSError):
            os.kill(pid, signal.SIGKILL)


def _start_fork_server() -> None:
    """Start the fork server (and multiprocessing's resource tracker) with SIGINT blocked, a mask
    they inherit: Ctrl-C at a terminal reaches the whole process group, and a fork server
    interrupted while it imports its preloaded modules prints a traceback.  They end with this
    process (the fork server when its pipe closes); a Ctrl-C that arrives meanwhile is delivered
    to this process when the mask is restored."""
    from multiprocessing import forkserver, resource_tracker

    if threading.current_thread() is not threading.main_thread() or not hasattr(signal, "pthread_sigmask"):
        forkserver.ensure_running()
        return
    resource_tracker.ensure_running()  # first: it unblocks SIGINT after starting its own process
    old = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    try:
        forkserver.ensure_running()
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, old)


@contextlib.contextmanager
def _signals_held():
    """Hold SIGINT and SIGTERM while the workers start (about a second: the fork server imports
    the preloaded modules), then act on the first that came, as its handler would have — also
    when the start failed meanwhile (a SIGTERM sent to the whole process group ends the fork
    server too, and the next launch meets a broken pipe: the signal is what happened)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    held: list[int] = []
    signals = (signal.SIGINT, signal.SIGTERM)
    previous = {s: signal.signal(s, lambda signum, frame: held.append(signum)) for s in signals}
    try:
        yield
    finally:
        for s, handler in previous.items():
            signal.signal(s, handler)
        if held:
            handler = previous[held[0]]
            if callable(handler):
                handler(held[0], None)  # raises KeyboardInterrupt, or Terminated under the command line
            elif handler == signal.SIG_DFL:
                os.kill(os.getpid(), held[0])


@contextlib.contextmanager
def process_pool(jobs: int, preload: tuple[str, ...] = (), initializer=None, initargs: tuple = ()):
    """A :class:`concurrent.futures.ProcessPoolExecutor` of ``jobs`` workers that end with this
    process (see the module's description).

    The workers are forked from a fork server where there is one (a process forked after OpenMP or
    BLAS threads have run can hang), else spawned.

    Parameters
    ----------
    jobs : int
        Number of worker processes.
    preload : tuple of str
        Modules the fork server imports once for every worker.
    initializer : callable, optional
        Run in each worker after it is bound to this process, with ``initargs``.
    initargs : tuple

    Yields
    ------
    concurrent.futures.ProcessPoolExecutor
    """
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor, wait

    methods = multiprocessing.get_all_start_methods()
    ctx = multiprocessing.get_context("forkserver" if "forkserver" in methods else "spawn")
    if "forkserver" in methods:
        if preload:
            ctx.set_forkserver_preload(list(preload))
        _start_fork_server()
    pool = ProcessPoolExecutor(jobs, mp_context=ctx, initializer=_start_worker,
                               initargs=(os.getpid(), initializer, initargs))
    try:
        with _signals_held():  # a worker whose start is cut short prints a traceback ('pickle data was truncated')
            wait([pool.submit(os.getpid) for _ in range(jobs)])  # every worker started and initialised
        yield pool
    except BaseException:
        _stop(pool)
        raise
    pool.shutdown(wait=True)


__all__ = ["process_pool", "bind_to_owner", "WATCH_SECONDS"]
