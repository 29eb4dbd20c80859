"""Multi-start updating: random starts within the bounds, distinct solutions clustered and counted.

Starts are drawn from one seeded generator, so a study is reproducible; they run locally, or on
an existing Dask cluster when a scheduler address is given (``dask.distributed``), with results
identical for the same seed.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable, Sequence
from functools import partial

import numpy as np

from .._errors import FemupdateError, InputError
from ..dask_cluster import collect, connect, task
from .clustering import classify, converged_solutions, parameter_scale
from .results import MultiStartResult, UpdateResult
from .combined import DATA_KINDS, data_kinds
from .run import update
from .run import frf_update

log = logging.getLogger(__name__)


def draw_starts(model, names: Sequence[str], n: int, seed: int | None, log_uniform: bool = False) -> np.ndarray:
    """``n`` starting vectors uniform (or log-uniform) within the parameters' bounds.

    Parameters
    ----------
    model : Model
        The parametrised model; its :attr:`bounds` give the ranges.
    names : sequence of str
        The parameters to draw, in the order of the columns.
    n : int
        The number of starts.
    seed : int or None
        Seed of :func:`numpy.random.default_rng` (None: a fresh, unreproducible one).
    log_uniform : bool, default False
        Draw ln p uniformly between the logs of the bounds instead of p.

    Returns
    -------
    numpy.ndarray of float, shape ``(n, len(names))``
        The starting values, in the parameters' own units (N/m, kg, ...).

    Raises
    ------
    InputError
        An unknown parameter name; a parameter without finite bounds (all named); a lower bound
        <= 0 with ``log_uniform``.
    """
    idx = [model.parameter_index(nm) for nm in names]
    lo, hi = model.bounds
    lo, hi = lo[idx], hi[idx]
    bad = [nm for nm, a, b in zip(names, lo, hi) if not (np.isfinite(a) and np.isfinite(b))]
    if bad:
        raise InputError(f"random starts need finite bounds; give bounds for: {', '.join(bad)}")
    rng = np.random.default_rng(seed)
    if log_uniform:
        if np.any(lo <= 0):
            raise InputError("log-uniform starts need positive lower bounds")
        return np.exp(rng.uniform(np.log(lo), np.log(hi), size=(n, len(idx))))
    return rng.uniform(lo, hi, size=(n, len(idx)))


def run_with(fn, model, data, names, start, kwargs):
    """``fn(model, data, params=names, x0=start, **kwargs)``; a start that fails is a message, not a crash.

    Parameters
    ----------
    fn : callable
        The update function (:func:`~femupdate.updating.update`, :func:`frf_update`, ...).
    model : Model
        The parametrised model.
    data
        The measured data, passed to ``fn`` as is.
    names : sequence of str
        The updated parameters.
    start : sequence of float, length ``len(names)``
        The starting values, passed as ``x0={name: value}``.
    kwargs : dict
        Further keyword arguments of ``fn``.

    Returns
    -------
    result or str
        ``fn``'s result, or ``"ErrorType: message"`` when ``fn`` raised a
        :class:`~femupdate.FemupdateError` (an :class:`InputError` as well as a
        :class:`NumericalError`).  Other exceptions propagate.
    """
    try:
        return fn(model, data, params=names, x0=dict(zip(names, start)), **kwargs)
    except FemupdateError as exc:  # a start that fails numerically is a result, not a crash
        return f"{type(exc).__name__}: {exc}"


def _run_one(model, data, names, start, kwargs):
    return run_with(update, model, data, names, start, kwargs)


def timed(runner, model, data, names, start, kwargs):
    """``(runner(model, data, names, start, kwargs), wall-clock seconds, CPU seconds)`` (a Dask
    task).  The CPU seconds are those of the process that ran the start (its BLAS threads
    included; on a Dask worker also whatever else that worker ran meanwhile)."""
    t, c = time.perf_counter(), time.process_time()
    out = runner(model, data, names, start, kwargs)
    return out, time.perf_counter() - t, time.process_time() - c


def multistart(model, data, starts: int = 20, seed: int | None = 0, params: Sequence[str] | None = None,
               scheduler: str | None = None, rel_tol: float = 1e-4, cost_tol: float | None = None,
               log_uniform: bool = False, progress: Callable[[int, int], None] | None = None,
               connect_timeout: float = 10.0, batched: bool | None = None, jobs: int | None = None,
               **kwargs) -> MultiStartResult:
    """Run :func:`femupdate.update` from ``starts`` random starting points (any data it takes;
    modal data of small models on the compiled route).

    Parameters
    ----------
    model : Model
        The parametrised model.
    data : TestData, FRFData or other data :func:`update` takes
        The measured data.
    starts : int, default 20
        Number of random starts, drawn within the parameters' bounds (uniform, or log-uniform).
    seed : int or None, default 0
        Seed of the generator (reproducible studies; None: unreproducible).
    params : sequence of str, optional
        Parameters to update (default: the free ones).
    scheduler : str, optional
        Address of an existing Dask scheduler (``tcp://host:port``); local runs otherwise.
    rel_tol : float, default 1e-4
        Relative distance under which two solutions are the same.
    cost_tol : float, optional
        A run counts as converged when the solver reports success and its cost (½‖r‖²) is at most
        this (default: no cost limit, i.e. local minima count as converged solutions too).
    log_uniform : bool, default False
        Draw the starts log-uniformly instead of uniformly (needs positive lower bounds).
    progress : callable ``(done, total)``, optional
        Called as starts finish (locally and on Dask).
    connect_timeout : float, default 10.0
        Seconds to wait for the scheduler (and its first worker) before giving up.
    batched : bool or None, default None
        Advance all starts at once (:mod:`femupdate.updating.batched`, same problem, same answers);
        ``None``: batched when only modal data are used, the model has at most
        :data:`femupdate.updating.batched.AUTO_MAX_DOFS` dofs and the options are supported (the
        compiled route implements ``formulation="shapes"`` only: ``"mac"`` and ``"dynamic"`` run
        one :func:`update` per start) — locally,
        or in chunks on the Dask cluster at ``scheduler``, with the same results; ``False``: one
        :func:`update` per start; ``True``: batched, or an :class:`InputError`.
    jobs : int, optional
        Local worker processes of the per-start route (:func:`run_starts`); default
        (:func:`local_jobs`): one per usable core when the model has at least
        :data:`femupdate.modal.SPARSE_FROM` dofs and there are at least two starts per process,
        else the starts run in this process.  Ignored with ``scheduler`` and on the compiled route.
    **kwargs
        Options of :func:`update` (not ``x0``).

    Returns
    -------
    MultiStartResult
        Every run (a failed start as its ``"ErrorType: message"``), the distinct solutions and the
        best run.

    Raises
    ------
    InputError
        ``starts`` < 1; ``x0`` given; FRF options given when only modal data are used;
        ``batched=True`` with non-modal data or options the batched route does not support; a
        parameter without finite bounds, an unknown parameter, or a bound <= 0 with
        ``log_uniform`` (:func:`draw_starts`); a scheduler not reached within ``connect_timeout``.
        The errors of :func:`update` itself (refused input, numerical failure) do not propagate:
        each start that fails is recorded as its message in ``runs``.
    """
    if starts < 1:
        raise InputError("the number of starts must be at least 1")
    if "x0" in kwargs:
        raise InputError("a multi-start draws its own starting values: give starts, seed and params, not x0")
    names = tuple(params) if params is not None else tuple(model.parameter_names[j] for j in model.free)
    X0 = draw_starts(model, names, starts, seed, log_uniform)
    kinds = data_kinds(data, kwargs.get("use", DATA_KINDS))
    if kinds == ("modes",):
        if kwargs.get("frf_options"):
            raise InputError(f"FRF options ({', '.join(sorted(kwargs['frf_options']))}) given, but no FRF data are used")
        kwargs.pop("use", None)  # modes only: the modal problem, whatever route
        kwargs.pop("frf_options", None)
        if kwargs.get("formulation", "shapes") != "shapes":
            _check_once(model, data, names, kwargs)
    elif batched:
        raise InputError(f"batched=True takes modal data only; these data use {', '.join(kinds)}: use batched=False")
    else:
        batched = False
    # ---- batched path: all starts at once for small dense models ----------------------------------
    if batched is None:
        from .batched import supports

        batched = supports(model, kwargs)
    if batched:
        from .batched import multistart_batched, unsupported

        reason = unsupported(model, kwargs, explicit=True)
        if reason:
            raise InputError(f"batched=True: {reason}; use batched=False")
        return multistart_batched(model, data, names, X0, seed=seed, rel_tol=rel_tol, cost_tol=cost_tol,
                                  progress=progress, scheduler=scheduler, connect_timeout=connect_timeout, **kwargs)
    # ---- end of the batched path ----------------------------------------------------------------
    return run_starts(model, data, names, X0, kwargs, seed=seed, scheduler=scheduler, rel_tol=rel_tol,
                      cost_tol=cost_tol, progress=progress, connect_timeout=connect_timeout, jobs=jobs)


def _check_once(model, data, names, kwargs) -> None:
    """Build the modal problem once, so that input a formulation other than ``"shapes"`` refuses
    (a test mode without a shape for ``"dynamic"``, options it does not take, too few data) is
    refused once, as an :class:`InputError`, rather than recorded as the failure of every start
    (those formulations take the per-start route)."""
    import inspect

    from .problem import Problem, check_determined

    keys = set(inspect.signature(Problem).parameters) - {"model", "data", "params", "x0"}
    prob = Problem(model, data, names, **{k: v for k, v in kwargs.items() if k in keys})
    if kwargs.get("regularization") is None:
        check_determined(prob)


def run_starts(model, data, names, X0, kwargs, *, seed, scheduler=None, rel_tol=1e-4, cost_tol=None, progress=None,
               connect_timeout=10.0, runner=None, jobs=None) -> MultiStartResult:
    """``runner(model, data, names, X0[k], kwargs)`` (default: :func:`update` from start k) for every
    start, locally or on the Dask cluster at ``scheduler``; runs clustered into solutions.

    Parameters
    ----------
    model : Model
        The parametrised model.
    data
        The measured data, passed to ``runner``.
    names : sequence of str
        The updated parameters, in the order of ``X0``'s columns.
    X0 : numpy.ndarray of float, shape ``(n_starts, len(names))``
        The starting values (:func:`draw_starts`).
    kwargs : dict
        Options passed to ``runner`` (neither ``x0`` nor ``params``).
    seed : int or None
        The seed the starts were drawn with (recorded in the result).
    scheduler : str, optional
        Address of a Dask scheduler; local runs otherwise.
    rel_tol : float, default 1e-4
        Relative distance under which two solutions are the same.
    cost_tol : float, optional
        Largest cost of a converged run (default: no limit).
    progress : callable ``(done, total)``, optional
        Called as runs finish (locally and on Dask).
    connect_timeout : float, default 10.0
        Seconds to wait for the scheduler.
    runner : callable, optional
        ``runner(model, data, names, start, kwargs)``; default: :func:`run_with` of :func:`update`.
        On Dask, and with local worker processes, it must be picklable; each Dask task is retried
        up to twice.
    jobs : int, optional
        Local worker processes (without ``scheduler``): :func:`local_jobs` by default; 1 runs the
        starts in this process.  Each start is independent of the others, so the runs are those
        of the sequential route (to round-off: each process chooses its model's factorisation
        route at its own first evaluation).

    Returns
    -------
    MultiStartResult
        The runs in start order, the distinct converged solutions (classified, fitting ones first)
        and the lowest-cost converged :class:`UpdateResult` (None when none converged).

    Raises
    ------
    InputError
        ``x0`` or ``params`` in ``kwargs``; a scheduler not reached within ``connect_timeout``.
    """
    if "x0" in kwargs or "params" in kwargs:
        raise InputError("a multi-start draws its own starting values: give starts, seed and params, not x0")
    runner = runner or _run_one
    if scheduler:
        pairs = _run_dask(scheduler, model, data, names, X0, kwargs, progress, connect_timeout, runner)
    else:
        jobs = local_jobs(model, len(X0)) if jobs is None else max(1, min(int(jobs), len(X0)))
        if jobs > 1:
            pairs = _run_processes(jobs, model, data, names, X0, kwargs, progress, runner)
        else:
            pairs = []
            for k, x in enumerate(X0):
                pairs.append(timed(runner, model, data, names, x, kwargs))
                if progress:
                    progress(k + 1, len(X0))
    runs = [p[0] for p in pairs]
    seconds = [float(p[1]) for p in pairs]
    cpu = [float(p[2]) for p in pairs]
    ok, solutions = converged_solutions(runs, names, UpdateResult, cost_tol, rel_tol, parameter_scale(model, names))
    best = min((runs[k] for k in ok), key=lambda r: r.cost) if ok else None
    return classify(MultiStartResult(best, solutions, runs, X0, tuple(names), len(X0), len(ok), seed,
                                     seconds=seconds, cpu_seconds=cpu))


def local_jobs(model, n_starts: int) -> int:
    """Local worker processes for ``n_starts`` starts of the per-start route: one per usable core
    when a start is worth a process — the model has at least :data:`femupdate.modal.SPARSE_FROM`
    dofs (an evaluation takes milliseconds or more) — and every process gets two starts or more;
    else 1 (this process)."""
    import os

    from ..modal import SPARSE_FROM

    try:
        cores = len(os.sched_getaffinity(0))
    except (AttributeError, OSError):  # pragma: no cover - not Linux
        cores = os.cpu_count() or 1
    if model.n_dofs < SPARSE_FROM or cores < 2:
        return 1
    return max(1, min(cores, n_starts // 2))


_SHARED: dict = {}


def _share(model, data, runner) -> None:
    """A worker process's copy of what every start shares (sent once per process)."""
    _SHARED.update(model=model, data=data, runner=runner)


def _start_in_worker(names, x, kwargs):
    from .._threads import blas_phase, parallel_work

    with parallel_work(), blas_phase("solve"):  # the other cores run the other starts
        return timed(_SHARED["runner"], _SHARED["model"], _SHARED["data"], names, x, kwargs)


def _run_processes(jobs, model, data, names, X0, kwargs, progress, runner):
    """Every start in a pool of ``jobs`` local processes (:func:`femupdate._workers.process_pool`:
    started from a fork server, ended with this process however it ends), the model and data sent
    once to each."""
    from concurrent.futures import as_completed

    from .._workers import process_pool

    pairs: list = [None] * len(X0)
    with process_pool(jobs, ("femupdate.updating",), _share, (model, data, runner)) as pool:
        futures = {pool.submit(_start_in_worker, names, x, kwargs): k for k, x in enumerate(X0)}
        for done, f in enumerate(as_completed(futures), 1):
            pairs[futures[f]] = f.result()
            if progress:
                progress(done, len(X0))
    return pairs


def _run_dask(address, model, data, names, X0, kwargs, progress, timeout, runner):
    """``runner(model, data, names, X0[k], kwargs)`` for every k on the cluster at ``address``."""
    client = connect(address, timeout)
    try:
        m_f, d_f = client.scatter([model, data], broadcast=True)
        futures = {client.submit(task, timed, runner, m_f, d_f, names, x, kwargs, pure=False, retries=2): k
                   for k, x in enumerate(X0)}
        runs: list = [None] * len(futures)

        def keep(k, result):
            runs[k] = result
            if progress:
                progress(sum(r is not None for r in runs), len(runs))

        collect(client, futures, address, timeout, keep)
        return runs
    finally:
        client.close()


def frf_multistart(model, data, starts: int = 20, seed: int | None = 0, params: Sequence[str] | None = None,
                   scheduler: str | None = None, rel_tol: float = 1e-4, cost_tol: float | None = None,
                   log_uniform: bool = False, progress=None, connect_timeout: float = 10.0, **kwargs):
    """:func:`frf_update` from ``starts`` random starts within the bounds (the same seeded starts
    as :func:`femupdate.updating.multistart`), locally or on Dask; a
    :class:`~femupdate.updating.MultiStartResult` in the same format.

    Parameters
    ----------
    model : Model
        The parametrised model.
    data : FRFData or TestData
        The measured FRFs.
    starts : int, default 20
        Number of random starts, drawn within the parameters' bounds.
    seed : int or None, default 0
        Seed of the starts.
    params : sequence of str, optional
        Parameters to update (default: the free ones).
    scheduler : str, optional
        Address of a Dask scheduler (``tcp://host:port``); local runs otherwise.
    rel_tol : float, default 1e-4
        Relative distance under which two solutions are the same.
    cost_tol : float, optional
        A run counts as converged when it reports success and its cost (½‖r‖²) is at most this
        (default: no limit).
    log_uniform : bool, default False
        Draw the starts log-uniformly instead of uniformly.
    progress : callable ``(done, total)``, optional
        Called as starts finish (locally and on Dask).
    connect_timeout : float, default 10.0
        Seconds to wait for the scheduler.
    **kwargs
        Options of :func:`frf_update`.

    Returns
    -------
    MultiStartResult
        Runs, distinct solutions, and the best run (a :class:`FRFUpdateResult`).

    Raises
    ------
    InputError
        Fewer than one start; a parameter without finite bounds, an unknown parameter, or a bound
        <= 0 with ``log_uniform`` (:func:`draw_starts`); ``x0`` among ``kwargs``; an unreachable
        scheduler.  The errors of :func:`frf_update` itself (refused input, numerical
        failure) do not propagate: each start that fails is recorded as its message in ``runs``.
    """
    if starts < 1:
        raise InputError("the number of starts must be at least 1")
    names = tuple(params) if params is not None else tuple(model.parameter_names[j] for j in model.free)
    X0 = draw_starts(model, names, starts, seed, log_uniform)
    return run_starts(model, data, names, X0, kwargs, seed=seed, scheduler=scheduler, rel_tol=rel_tol,
                      cost_tol=cost_tol, progress=progress, connect_timeout=connect_timeout,
                      runner=partial(run_with, frf_update))
