"""How many threads BLAS gets inside femupdate: a policy per phase that holds on a busy machine.

OpenBLAS (NumPy's, SciPy's, and the system's behind CHOLMOD) starts one thread per core and
makes them wait for each other at every call.  When another process keeps a core busy, a thread
of the pair is descheduled and every BLAS call waits for it: the many small kernels of sparse
solves, of ARPACK's iterations and of a dense eigen-solution of a few hundred dofs then run
several times *slower* with two threads than with one.  Measured on the 2-core machine with the
other core busy (``python benchmarks/bench_threads.py``): a dense eigen-solution of a 408-dof
frame 2.4 times slower, the 10 lowest modes of a 1,512-dof frame (dense) 12 times slower, the
sparse eigen-solution of a 20,304-dof tower 2.3 times slower.  An idle core, on the other hand,
helps only large dense kernels — and only while it stays idle.

The policy (:func:`threads_for`):

* ``"solve"`` — sparse factorisations and solves, ARPACK, the sensitivities' series, everything
  run per start or per case (processes or threads already run in parallel there): **one
  thread**, always;
* ``"dense"`` — a large dense kernel (a dense eigen-solution of at least :data:`LARGE_DENSE`
  dofs): **every core that is free**, judged from the one-minute load average at the start of
  the kernel (this process counts for one); one thread on a busy machine, or inside parallel
  work (a Dask worker, a start among others).

:attr:`femupdate.settings.Settings.blas_threads` overrides the policy: a positive integer is used
for every phase; ``"keep"`` leaves BLAS as it is found (the caller's own setting).  The command
line sets it from ``FEMUPDATE_BLAS_THREADS``; the library reads no environment variable.  The
limits are applied with threadpoolctl, which finds every BLAS library loaded in the process;
nested phases cost one integer comparison.
"""

from __future__ import annotations

import contextlib
import os
import threading

from . import settings

__all__ = ["LARGE_DENSE", "threads_for", "blas_phase", "in_parallel_work", "parallel_work", "forget_libraries",
           "phase_threads"]

#: dense eigen-solutions of at least this many dofs may use every free core
LARGE_DENSE = 800

_controller = None
_state = threading.local()  # .depth: phases entered in this thread; .parallel: inside parallel work


def _cores() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except (AttributeError, OSError):  # pragma: no cover - not Linux
        return os.cpu_count() or 1


def _free_cores() -> int:
    """Cores not busy with other processes, from the one-minute load average (this process,
    about to compute, counts for one)."""
    cores = _cores()
    try:
        load = os.getloadavg()[0]
    except (AttributeError, OSError):  # pragma: no cover - no load average
        return 1
    return max(1, min(cores, int(cores - max(load - 1.0, 0.0) + 0.25)))


def threads_for(phase: str) -> int | None:
    """BLAS threads for a phase of work (``"solve"`` or ``"dense"``), or None to leave BLAS
    as found.

    Parameters
    ----------
    phase : {"solve", "dense"}

    Returns
    -------
    int or None
        The override of :attr:`femupdate.settings.Settings.blas_threads` if one is installed
        (None for ``"keep"``), else the policy's count.
    """
    override = settings.current().blas_threads
    if override is not None:
        return None if override == "keep" else int(override)
    if phase == "dense" and not in_parallel_work():
        return _free_cores()
    return 1


def in_parallel_work() -> bool:
    """Whether this thread runs one of several pieces of work in parallel (a Dask task, a start
    among others): then BLAS gets one thread whatever the phase."""
    return bool(getattr(_state, "parallel", False))


@contextlib.contextmanager
def parallel_work():
    """Mark the enclosed work as one of several running in parallel (see :func:`in_parallel_work`)."""
    before = getattr(_state, "parallel", False)
    _state.parallel = True
    try:
        yield
    finally:
        _state.parallel = before


def _limiter():
    """threadpoolctl's controller of the BLAS libraries loaded now (rebuilt when a library was
    loaded since: CHOLMOD brings the system's OpenBLAS)."""
    global _controller
    from threadpoolctl import ThreadpoolController

    if _controller is None or _controller[0] != _loaded_count():
        _controller = (_loaded_count(), ThreadpoolController())
    return _controller[1]


def forget_libraries() -> None:
    """Make the next phase look for BLAS libraries afresh (called when a library is loaded by
    ctypes, which no module count shows: MKL for PARDISO)."""
    global _controller
    _controller = None


def _loaded_count() -> int:
    import sys

    return len(sys.modules)  # a cheap proxy: a new extension module may bring a new BLAS


@contextlib.contextmanager
def blas_phase(phase: str = "solve"):
    """Run the enclosed code with the policy's BLAS threads for ``phase``.

    The outermost phase of a thread sets the limit; a phase inside one of the same kind keeps
    it (one integer comparison), a phase of the other kind sets its own for its duration.

    Parameters
    ----------
    phase : {"solve", "dense"}
    """
    depth = getattr(_state, "depth", 0)
    current = getattr(_state, "phase", None)
    if depth and phase == current:
        _state.depth = depth + 1
        try:
            yield
        finally:
            _state.depth = depth
        return
    n = threads_for(phase)
    before = getattr(_state, "threads", None)
    _state.depth, _state.phase, _state.threads = depth + 1, phase, n
    try:
        if n is None:
            yield
        else:
            with _limiter().limit(limits=n, user_api="blas"):
                yield
    finally:
        _state.depth, _state.phase, _state.threads = depth, current, before


def phase_threads() -> int | None:
    """The BLAS threads of the phase this thread is in (None outside a phase, or when BLAS is
    left as found): for a library loaded inside the phase, which the phase's limit did not reach
    (MKL, loaded by the first PARDISO factorisation), to apply itself."""
    return getattr(_state, "threads", None) if getattr(_state, "depth", 0) else None
