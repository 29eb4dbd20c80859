"""Running a uniqueness study: its work units in process or as tasks of a Dask cluster, finished
units kept in a checkpoint, then summarised (:func:`run_study`)."""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from typing import cast

from ..._budget import Pace, check_processes
from ..._checks import callable_arg, count_arg, path_arg, real_arg, shown, str_arg
from ..._errors import InputError
from ...dask_cluster import Task, collect, connect, quiet_library_logs
from ..checkpoint import Checkpoint
from .definition import Study
from .results import StudyResult, summarise
from .units import solve_unit

log = logging.getLogger("femupdate.uniqueness.study")  # the package's logger, as before the split into modules


def _dask_client(scheduler: str | None, workers: int | None, timeout: float):
    if scheduler:
        return connect(scheduler, timeout, "--scheduler / --workers"), None
    try:
        from dask.distributed import Client, LocalCluster
    except ImportError:
        raise InputError("--scheduler / --workers need dask.distributed: pip install 'femupdate[dask]'") from None
    if workers is None:  # run_study starts a local cluster only when workers is given
        raise RuntimeError("internal error: a local Dask cluster was asked for without a number of workers")
    quiet_library_logs()  # the cluster's own INFO records are for the verbose log (-v) only
    from ... import dask_cluster

    quiet = {"silence_logs": logging.CRITICAL} if dask_cluster.QUIET_LIBRARY_LOGS else {}  # the workers' own logs
    cluster = LocalCluster(n_workers=int(workers), threads_per_worker=1, processes=True, host="127.0.0.1",
                           dashboard_address=None, **quiet)
    return Client(cluster), cluster


def _door(study, scheduler, workers, checkpoint, progress, rel_tol, cost_tol, connect_timeout, alpha=0.01) -> None:
    """:func:`run_study`'s arguments by type (:mod:`femupdate._checks`); at most
    :data:`femupdate._budget.MAX_PROCESSES` local workers."""
    where = "run_study"
    if not isinstance(study, Study):
        raise TypeError(f"{where}: study must be a Study (make one with femupdate.define_study(model, cases, ...)), got "
                        f"{shown(study)}")
    str_arg(scheduler, "scheduler", where, optional=True)
    check_processes("workers", count_arg(workers, "workers", where, optional=True))
    if checkpoint is not None:
        path_arg(checkpoint, "checkpoint", where)
    callable_arg(progress, "progress", where)
    real_arg(rel_tol, "rel_tol", where, low=0.0, high=1.0, low_open=True)
    real_arg(cost_tol, "cost_tol", where, low=0.0)
    real_arg(alpha, "alpha", where, low=0.0, high=0.5, low_open=True)
    real_arg(connect_timeout, "connect_timeout", where, low=0.0, low_open=True)


def run_study(study: Study, *, scheduler: str | None = None, workers: int | None = None, checkpoint=None,
              progress: Callable[[int, int], None] | None = None, rel_tol: float = 1e-4, cost_tol: float = 1e-12,
              connect_timeout: float = 10.0, alpha: float = 0.01) -> StudyResult:
    """Run (or resume) ``study`` and summarise it.

    Parameters
    ----------
    study : Study
        From :func:`define_study`.
    scheduler : str, optional
        Address of an existing Dask scheduler (``tcp://host:port``): units run there.
    workers : int, optional
        Without ``scheduler``, start a local Dask cluster of this many worker processes;
        neither: everything runs in this process.
    checkpoint : str or os.PathLike, optional
        Path of the checkpoint file (created, or resumed when it holds this study); default none
        (kept in memory).
    progress : callable, optional
        ``progress(rows_done, rows_total)``, called as rows finish.
    rel_tol : float, default 1e-4
        Two solutions within this of each other (relative) are always the same (round-off).
    cost_tol : float, default 1e-12
        A converged start reproduces the data when its cost ½‖r‖² is at most this.
    connect_timeout : float, default 10.0
        Seconds to wait for the scheduler (then an InputError).
    alpha : float, default 0.01
        The significance level at which two converged starts are distinct solutions
        (:func:`~femupdate.uniqueness.study.results.summarise`, as
        :class:`~femupdate.options.StartsOptions` documents it).

    Returns
    -------
    StudyResult

    Raises
    ------
    InputError
        A checkpoint that is unreadable or belongs to another study; the scheduler not reached in
        time; Dask needed but not installed.
    """
    _door(study, scheduler, workers, checkpoint, progress, rel_tol, cost_tol, connect_timeout, alpha)
    progress = Pace("updates", progress)
    t0 = time.perf_counter()
    units = study.units()
    ck = Checkpoint(checkpoint, study.key(), study.describe(), layout=units, n_unknowns=len(study.names))
    resumed = [i for i in range(len(units)) if i in ck]
    todo = [i for i in range(len(units)) if i not in ck]
    size = [sum(b - a for _, _, a, b in u) for u in units]
    done = sum(size[i] for i in resumed)
    total = sum(size)
    if progress:
        progress(done, total)
    route = "local"
    if todo and (scheduler or workers):
        client, cluster = _dask_client(scheduler, workers, connect_timeout)
        route = f"dask:{scheduler}" if scheduler else f"dask:local cluster of {workers} workers"
        try:
            # the study travels inside each task (not scattered): a task lost with its worker can
            # always be recomputed, even if every copy of a scattered object were lost with it
            key = study.key()[:16]
            futures = {client.submit(Task(solve_unit), study, i, key=f"femupdate-uniqueness-{key}-unit-{i}", retries=2): i
                       for i in todo}
            finished = [done]

            def keep(i, result):
                ck.add(i, result)
                finished[0] += size[i]
                if progress:
                    progress(finished[0], total)

            collect(client, futures, scheduler or "the local cluster", connect_timeout, keep)
        finally:
            client.close()
            if cluster is not None:
                cluster.close()
    else:
        for i in todo:
            base = done
            # cast: mypy cannot infer a lambda with a default argument against Callable[[int, int], None]
            unit_progress = (cast("Callable[[int, int], None]", lambda k, _n, b=base: progress(b + k, total))
                             if progress else None)
            ck.add(i, solve_unit(study, i, progress=unit_progress))
            done = base + size[i]
    raw = [p for i in range(len(units)) for p in ck.units[i]]
    cases = summarise(study, raw, rel_tol=rel_tol, cost_tol=cost_tol, alpha=alpha)
    log.info("uniqueness study: %d cases, %d rows in %d units (%d resumed), %.2f s", len(study.cases), total,
             len(units), len(resumed), time.perf_counter() - t0)
    return StudyResult(study, cases, time.perf_counter() - t0, len(todo), len(resumed), route, rel_tol, cost_tol, raw,
                       alpha=alpha)


__all__ = ["run_study"]
