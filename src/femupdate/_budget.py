"""Bounds on the work a count asks for: the memory a run will hold, estimated from the count and
the model before any work and refused above what the machine has, and the time a long run will
take, said once its pace is measured.

Every count a user gives (starts, samples, walkers, ensembles, steps, chunks, FRF lines, modes,
Monte Carlo repeats, bootstrap replicates) passes :func:`check_memory` where it enters the
library: the option objects' checks with the least a unit of the count holds (a model-independent
floor, measured), the verbs with an estimate from the model and the data.  A count whose estimate
exceeds the available memory (:func:`available_memory`) is an :class:`~femupdate.InputError` that
names the count and the estimate, before anything is allocated for it (docs/python-api.md,
"Bounds").
"""

from __future__ import annotations

import logging
import os
import time
from collections.abc import Callable

from ._errors import InputError

log = logging.getLogger(__name__)

# ------------------------------------------------------------------ what one unit holds (bytes)
#: the least one start's record holds on the compiled route (its arrays aside): 3.2-5.0 kB
#: measured (tracemalloc) per start of the examples' models (two-dof, Figure 2, truss)
START_BYTES = 4_000
#: the per-start route's record beyond its arrays: 8.6-14 kB measured on the same models
START_RECORD_BYTES = 13_000
#: the per-start route's noise record of a fit beyond START_RECORD_BYTES (its diagnostics, since the
#: per-block noise components), once: the fit's test (``model_error``, a dict of 7 entries: 860
#: bytes measured), up to three pooling notes (650 measured on Figure 2), the χ² test of the stated
#: blocks and the plausibility test of the pooled eigenvalues in its detail (390 each)
NOISE_RECORD_BYTES = 2_300
#: a noise component's record (a dict of 10 entries with its label and members: 700 bytes measured
#: on the truss); at most one per block of residuals
NOISE_COMPONENT_BYTES = 700
#: a plausibility test's record in ``model_error``'s detail (390 bytes measured); at most one per
#: block of more than one residual (a mode's shape, an FRF set, a static case): a single
#: eigenvalue is stated (tested in the one χ²) or pooled with the other eigenvalues
NOISE_TEST_BYTES = 400
#: one uniqueness-study row (case x noise level x start): its start, solution, cost and status
STUDY_ROW_BYTES = 200
#: one posterior sample of one parameter: the sample, its parameter value and the copies the
#: summaries make (8 bytes each, 6 arrays)
SAMPLE_BYTES = 48
#: one MCMC walker-step of one parameter: the chain, its parameter values, log-posterior and
#: log-likelihood (8 bytes each)
CHAIN_BYTES = 32
#: one bootstrap replicate of damage detection: its located set, changes and verdict
REPLICATE_BYTES = 2_000
#: one noise replicate of the damage weights: one equation's draw at least (8 bytes each, with
#: its copies)
NOISE_DRAW_BYTES = 64
#: one FRF line of one response dof: complex response, its model prediction and residuals
LINE_BYTES = 64
#: hard cap on the worker processes a command starts on this machine
MAX_PROCESSES = 256

#: estimates up to this many bytes (64 MB) pass without reading the available memory
SMALL = 2**26
#: a run whose remaining time is estimated above this (s) is announced as a warning (else info)
LONG_RUN = 60.0
#: seconds of work measured before the pace is trusted
PACE_WINDOW = 2.0


def available_memory() -> int:
    """Bytes this process can still allocate: the kernel's ``MemAvailable`` (``/proc/meminfo``,
    else ``os.sysconf``), lowered by a cgroup (v2) memory limit and an address-space rlimit."""
    avail = None
    try:
        with open("/proc/meminfo", encoding="ascii") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    avail = int(line.split()[1]) * 1024
                    break
    except (OSError, ValueError):
        pass
    if avail is None:
        try:
            avail = os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
        except (AttributeError, ValueError, OSError):  # pragma: no cover - not POSIX
            avail = 8 * 2**30
    for limit, used in (("/sys/fs/cgroup/memory.max", "/sys/fs/cgroup/memory.current"),):
        try:
            with open(limit, encoding="ascii") as fh:
                text = fh.read().strip()
            if text != "max":
                with open(used, encoding="ascii") as fh:
                    avail = min(avail, int(text) - int(fh.read().strip()))
        except (OSError, ValueError):
            pass
    try:
        import resource

        soft, _ = resource.getrlimit(resource.RLIMIT_AS)
        if soft != resource.RLIM_INFINITY:
            with open("/proc/self/statm", encoding="ascii") as fh:
                vm = int(fh.read().split()[0]) * os.sysconf("SC_PAGE_SIZE")
            avail = min(avail, soft - vm)
    except (ImportError, OSError, ValueError):  # pragma: no cover - not Linux
        pass
    return max(int(avail), 0)


def size(nbytes: float) -> str:
    """``nbytes`` in decimal units: ``'120 GB'``, ``'3.0 kB'``."""
    for unit, scale in (("PB", 1e15), ("TB", 1e12), ("GB", 1e9), ("MB", 1e6), ("kB", 1e3)):
        if nbytes >= scale:
            v = nbytes / scale
            return f"{v:.1f} {unit}" if v < 10 else f"{v:.0f} {unit}"
    return f"{nbytes:.0f} bytes"


def check_memory(what: str, nbytes: float, holds: str) -> None:
    """Refuse a count whose run would hold more than the available memory.

    Parameters
    ----------
    what : str
        The count as the user gave it (``"starts=1000000000"``).
    nbytes : float
        The estimate of the bytes the run will hold for it.
    holds : str
        What those bytes are (``"the starts' records (at least 3.0 kB each)"``).

    Raises
    ------
    InputError
        ``about 3.0 TB for the starts' records ..., more than the 20 GB available``.
    """
    if nbytes <= SMALL:  # never worth reading /proc
        return
    avail = available_memory()
    if nbytes > avail:
        raise InputError(f"{what}: about {size(nbytes)} for {holds}, more than the {size(avail)} available; "
                         "give a smaller number")


def check_count(what: str, n: int, unit_bytes: float, holds: str) -> int:
    """:func:`check_memory` for ``n`` units of ``unit_bytes`` each; ``n`` returned."""
    check_memory(f"{what}={n}", float(n) * unit_bytes, f"{holds} (about {size(unit_bytes)} each)")
    return n


def residual_count(data) -> int:
    """The residuals test data give at most (each mode: its eigenvalue and shape entries; each FRF
    line and response dof: a complex pair; each static deflection), for the estimates; data of
    another kind (a sequence of sets, FRF data alone) are counted by what they hold."""
    if isinstance(data, (list, tuple)):
        return sum(residual_count(d) for d in data)
    n = sum(1 + len(getattr(m, "dofs", ())) for m in getattr(data, "modes", ()))
    sets = getattr(data, "frf_sets", None)
    if sets is None and hasattr(data, "omega"):
        sets = (data,)
    n += sum(2 * len(f.omega) * len(f.dofs) for f in sets or ())
    n += sum(len(c.dofs) for c in getattr(data, "static", ()))
    return max(n, 1)


def block_count(data) -> tuple[int, int]:
    """The blocks of residuals whose noise is stated or estimated apart
    (:func:`femupdate.updating.noise.layout`) test data give at most: ``(single, larger)``, the
    blocks of one residual (each mode's eigenvalue) and the larger ones (each mode's shape, FRF
    set, static case); a sequence of sets: their sum."""
    if isinstance(data, (list, tuple)):
        counts = [block_count(d) for d in data]
        return sum(c[0] for c in counts), sum(c[1] for c in counts)
    modes = getattr(data, "modes", ())
    larger = sum(1 for m in modes if len(getattr(m, "dofs", ())))
    sets = getattr(data, "frf_sets", None)
    if sets is None and hasattr(data, "omega"):
        sets = (data,)
    larger += len(sets or ()) + len(getattr(data, "static", ()))
    return len(modes), larger


def start_bytes(n_residuals: int, n_params: int, batched: bool = False, blocks: tuple[int, int] = (0, 1)) -> float:
    """What one start's record holds: on the per-start route :data:`START_RECORD_BYTES`, its
    residuals, Jacobian and parameter-sized matrices (covariance, correlation, ...; the standard
    deviations' degrees of freedom) and its noise record (:data:`NOISE_RECORD_BYTES`, a component
    per block and a test per larger block, ``blocks`` as :func:`block_count` gives them); on the
    compiled route :data:`START_BYTES` and its residuals and Jacobian with their copies (it keeps
    no noise record)."""
    if batched:
        return START_BYTES + 16.0 * n_residuals * (n_params + 2)
    single, larger = blocks
    noise = NOISE_RECORD_BYTES + NOISE_COMPONENT_BYTES * (single + larger) + NOISE_TEST_BYTES * larger
    return START_RECORD_BYTES + 16.0 * n_residuals * (n_params + 2) + 32.0 * n_params ** 2 + 8.0 * n_params + noise


def check_processes(what: str, n: int | None) -> int | None:
    """Refuse more than :data:`MAX_PROCESSES` worker processes (a hard cap)."""
    if n is not None and n > MAX_PROCESSES:
        raise InputError(f"{what}={n}: at most {MAX_PROCESSES} worker processes are started on one machine")
    return n


def duration(seconds: float) -> str:
    """``seconds`` as ``'40 s'``, ``'12 min'``, ``'3.5 h'`` or ``'2.0 days'``."""
    if seconds < 90:
        return f"{seconds:.0f} s"
    if seconds < 5400:
        return f"{seconds / 60:.0f} min"
    if seconds < 172800:
        return f"{seconds / 3600:.1f} h"
    return f"{seconds / 86400:.1f} days"


def announce(what: str, seconds: float, basis: str) -> None:
    """Say how long ``what`` will take (one line, a warning above :data:`LONG_RUN`), and on what
    the estimate rests."""
    level = logging.WARNING if seconds > LONG_RUN else logging.INFO
    log.log(level, "femupdate: %s: about %s (%s)", what, duration(seconds), basis)


class Pace:
    """A progress callback ``(done, total)`` that measures the pace of the first units of a run
    and, once :data:`PACE_WINDOW` seconds of them are measured, announces once how long the rest
    will take (:func:`announce`); then calls ``progress``.

    The clock starts at the first report (the first unit carries the run's setup: building the
    problem, compiling), so the estimate rests on the units done after it.

    Parameters
    ----------
    unit : str
        What is counted (``"starts"``, ``"updates"``).
    progress : callable ``(done, total)``, optional
        The caller's callback, called on every report.
    """

    def __init__(self, unit: str, progress: Callable[[int, int], None] | None = None):
        self.unit, self.progress = unit, progress
        self.first: tuple[float, int] | None = None
        self.said = False

    def __call__(self, done: int, total: int) -> None:
        now = time.perf_counter()
        if self.first is None:
            self.first = (now, done)
        elif not self.said and done > self.first[1] and now - self.first[0] >= PACE_WINDOW:
            self.said = True
            per = (now - self.first[0]) / (done - self.first[1])
            if done < total:
                announce(f"{total} {self.unit}, {total - done} to go", per * (total - done),
                         f"{per:.3g} s each, measured over the {done - self.first[1]} after the first")
        if self.progress is not None:
            self.progress(done, total)


__all__ = ["available_memory", "size", "check_memory", "check_count", "check_processes", "residual_count", "block_count", "start_bytes",
           "duration", "announce", "Pace", "START_BYTES", "START_RECORD_BYTES", "NOISE_RECORD_BYTES", "NOISE_COMPONENT_BYTES",
           "NOISE_TEST_BYTES",
           "STUDY_ROW_BYTES", "SAMPLE_BYTES",
           "CHAIN_BYTES", "REPLICATE_BYTES", "NOISE_DRAW_BYTES", "LINE_BYTES", "MAX_PROCESSES"]
