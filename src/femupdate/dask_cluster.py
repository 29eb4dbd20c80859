"""Tasks on an existing Dask cluster: connect, run, collect — and fail in bounded time, by name.

Every driver that takes a ``scheduler`` address (multi-start updating, FRF global search,
uniqueness studies) goes through :func:`connect` and :func:`collect`:

* an address with an unknown scheme, or a scheduler that cannot be reached within the timeout, is
  an :class:`~femupdate.InputError` naming the address;
* a scheduler with no workers is refused after the same timeout (instead of waiting forever);
* a scheduler lost during the run, or every worker gone for longer than the timeout, ends the
  run with one :class:`ClusterError` (exit code 1) that names the scheduler and says how many
  tasks had finished — the finished work is not lost where the driver keeps it (the uniqueness
  checkpoints);
* a worker lost while others remain costs nothing but time: its tasks run again elsewhere
  (``retries``), with the same results, since every task is a pure function of its arguments.

Dask is imported only here, and only when a scheduler is given.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable, Hashable, Mapping

from ._errors import FemupdateError, InputError

#: set by the command line without ``-v``: library log records of a lost connection are not shown
#: (the run ends with one message of its own); with ``-v`` they stay in the verbose log
QUIET_LIBRARY_LOGS = False
_NOISY = ("distributed", "tornado", "asyncio")


class ClusterError(FemupdateError):
    """The Dask cluster failed during a run: the scheduler was lost, or every worker left."""

    exit_code = 1


def quiet_library_logs() -> None:
    """Silence Dask's, Tornado's and asyncio's loggers (see :data:`QUIET_LIBRARY_LOGS`): every one
    of their loggers, since Dask gives some of its own (``distributed.client``...) a level of their
    own, which a level on ``distributed`` would not override."""
    if QUIET_LIBRARY_LOGS:
        existing = [n for n in list(logging.root.manager.loggerDict) if n.split(".", 1)[0] in _NOISY]
        for name in (*_NOISY, *existing):
            logging.getLogger(name).setLevel(logging.CRITICAL + 1)


def _refused(address: str, timeout: float) -> str | None:
    """Why a plain TCP connection to a ``tcp://host:port`` address fails (connection refused, no
    route), or None when it opens, the address has another scheme or cannot be split (Dask then
    decides). Deterministic where Dask's own connection retries are not: under load, its client
    can take longer than any margin to report a closed port."""
    import socket

    if not address.startswith("tcp://"):
        return None
    host, sep, port = address[len("tcp://"):].rpartition(":")
    if not sep or not port.isdigit() or not host:
        return None
    try:
        with socket.create_connection((host.strip("[]"), int(port)), timeout=timeout):
            return None
    except (OSError, ValueError, OverflowError) as exc:
        return str(exc) or type(exc).__name__


def _client_within(Client, address: str, timeout: float, what: str):
    """``Client(address)`` with a hard limit: a service that accepts the connection but is not a
    Dask scheduler (a web server, say) can keep the handshake waiting past Dask's own timeout."""
    import threading

    refused = _refused(address, timeout)
    if refused is not None:  # nothing listens there: no need to wait for Dask's own retries
        raise InputError(f"cannot reach the Dask scheduler at {address} within {timeout:g} s: {refused}")
    box: dict = {}

    def attempt():
        try:
            box["client"] = Client(address, timeout=timeout)
        except BaseException as exc:  # handed to the caller below
            box["error"] = exc

    worker = threading.Thread(target=attempt, name="femupdate-dask-connect", daemon=True)
    worker.start()
    worker.join(timeout + 5.0)
    if worker.is_alive():
        raise InputError(f"no Dask scheduler answered at {address} within {timeout:g} s (is it a Dask scheduler?)")
    exc = box.get("error")
    if exc is None:
        return box["client"]
    if isinstance(exc, ValueError):
        raise InputError(f"{what} {address!r}: not a Dask scheduler address ({str(exc).split(' (known')[0]}); give "
                         "tcp://host:port") from None
    if isinstance(exc, (OSError, TimeoutError)):
        raise InputError(f"cannot reach the Dask scheduler at {address} within {timeout:g} s: {exc}") from None
    if isinstance(exc, (MemoryError, RuntimeError, TypeError, EOFError)):
        raise InputError(f"no Dask scheduler answered at {address}: the service there is not one "
                         f"({type(exc).__name__})") from None
    raise exc


def connect(address: str, timeout: float, what: str = "--scheduler"):
    """A ``dask.distributed.Client`` of the scheduler at ``address`` that has at least one worker.

    Parameters
    ----------
    address : str
        The scheduler's address (``tcp://host:port``, or another scheme Dask knows).
    timeout : float
        Seconds to wait for the scheduler, and then for its first worker.
    what : str
        How the user gave the address (an option), for messages.

    Returns
    -------
    dask.distributed.Client

    Raises
    ------
    InputError
        Dask not installed; an address Dask cannot parse; a scheduler not reached, or without
        workers, within ``timeout`` s.
    """
    try:
        from dask.distributed import Client
    except ImportError:
        raise InputError(f"{what} needs dask.distributed: pip install 'femupdate[dask]'") from None
    quiet_library_logs()
    if not isinstance(address, str) or not address.strip():
        raise InputError(f"{what}: give the scheduler's address (tcp://host:port)")
    client = _client_within(Client, address, timeout, what)
    try:
        client.wait_for_workers(1, timeout=timeout)
    except (OSError, TimeoutError):
        client.close()
        raise InputError(f"the Dask scheduler at {address} has no workers (waited {timeout:g} s): start workers "
                         f"(dask worker {address}), or wait longer (--connect-timeout)") from None
    note = same_machine_note(client)
    if note:
        logging.getLogger("femupdate.dask").warning(note)
    return client


def same_machine_note(client) -> str | None:
    """A note when every worker of the cluster runs on this machine with no more threads than its
    cores: the cluster then adds transfers and task overheads to the same cores a local run uses
    (measured: a uniqueness study 2.2 times slower on two local workers than in process, on two
    cores), so it is for testing the route, not for speed."""
    import os
    import socket

    try:
        workers = client.scheduler_info().get("workers", {})
    except Exception:  # noqa: BLE001 - a note is not worth a failure
        return None
    if not workers:
        return None
    here = {"127.0.0.1", "localhost", "::1", socket.gethostname()}
    try:
        here.add(socket.gethostbyname(socket.gethostname()))
    except OSError:
        pass
    hosts = {str(w.get("host", "")) for w in workers.values()}
    threads = sum(int(w.get("nthreads", 1)) for w in workers.values())
    cores = os.cpu_count() or 1
    if hosts <= here and threads <= cores:
        return (f"every worker of the Dask cluster runs on this machine ({len(workers)} worker(s), {threads} "
                f"thread(s) on {cores} core(s)): the cluster uses the same cores as a local run and adds transfers, "
                "so a local run (without --scheduler) is usually faster here")
    return None


class Task:
    """``fn`` as a Dask task: submit ``Task(fn)`` with ``fn``'s arguments.

    The task runs under the settings of the process that made it (:mod:`femupdate.settings`: the
    factorisation backend, the BLAS threads), installed on the worker when it runs (a worker keeps
    the settings of its last task); with ``parallel`` (the default) as one of a cluster's parallel
    tasks, BLAS on one thread (:func:`femupdate._threads.parallel_work`), since the worker's
    other tasks use the other cores.

    Parameters
    ----------
    fn : callable
        A picklable function.
    parallel : bool, default True
        Run ``fn`` as parallel work (else under the worker's BLAS policy as it stands).
    """

    def __init__(self, fn: Callable, parallel: bool = True):
        from . import settings

        self.fn, self.parallel, self.settings = fn, parallel, settings.current()

    def __call__(self, *args, **kwargs):
        from . import settings
        from ._threads import blas_phase, parallel_work

        settings.install(self.settings)
        if not self.parallel:
            return self.fn(*args, **kwargs)
        with parallel_work(), blas_phase("solve"):
            return self.fn(*args, **kwargs)


def task(fn: Callable, *args, **kwargs):
    """Run ``fn(*args, **kwargs)`` here as a :class:`Task` runs it on a worker."""
    return Task(fn)(*args, **kwargs)


def collect(client, futures: Mapping, address: str, timeout: float, on_result: Callable[[Hashable, object], None],
            poll: float = 1.0) -> None:
    """Wait for ``futures`` ({future: key}) and hand each result to ``on_result(key, result)`` as it
    finishes.

    Parameters
    ----------
    client : dask.distributed.Client
    futures : mapping of dask futures to keys
    address : str
        The scheduler's address, for messages.
    timeout : float
        How long the cluster may be without workers before the run is given up.
    on_result : callable
        Called with each finished task's key and result, in order of completion.
    poll : float
        Seconds between checks of the cluster while nothing finishes.

    Raises
    ------
    ClusterError
        The scheduler was lost, or no worker was left for ``timeout`` s.
    FemupdateError
        Raised by a task, as the task raised it.
    """
    from concurrent.futures import CancelledError

    from dask.distributed import wait

    remaining = set(futures)
    n = len(remaining)
    no_workers_since: float | None = None
    try:
        while remaining:
            try:
                done, _ = wait(list(remaining), timeout=poll, return_when="FIRST_COMPLETED")
            except TimeoutError:  # nothing finished within ``poll``
                done = set()
            for fut in done:
                remaining.discard(fut)
                on_result(futures[fut], fut.result())
            if done:
                no_workers_since = None
                continue
            if client.status not in ("running", "connecting"):
                raise ClusterError(f"lost the Dask scheduler at {address}: {n - len(remaining)} of {n} tasks had "
                                   "finished")
            if not client.nthreads():  # asks the scheduler: raises if it is gone
                now = time.monotonic()
                no_workers_since = no_workers_since or now
                if now - no_workers_since > timeout:
                    raise ClusterError(f"the Dask scheduler at {address} has had no workers for {timeout:g} s: "
                                       f"{n - len(remaining)} of {n} tasks had finished")
            else:
                no_workers_since = None
    except (FemupdateError, KeyboardInterrupt):
        raise
    except (CancelledError, OSError, TimeoutError) as exc:
        raise ClusterError(f"lost the Dask scheduler at {address} ({type(exc).__name__}: {str(exc).splitlines()[0]}): "
                           f"{n - len(remaining)} of {n} tasks had finished") from None


__all__ = ["connect", "collect", "ClusterError", "QUIET_LIBRARY_LOGS", "quiet_library_logs"]
