"""Multi-start updating: random starts within the bounds, distinct solutions clustered and counted.

Starts are drawn from one seeded generator, so a study is reproducible; they run locally, or on
an existing Dask cluster when a scheduler address is given (``dask.distributed``), with results
identical for the same seed.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable, Mapping, Sequence
from functools import partial

import numpy as np

from .._budget import Pace, block_count, check_count, residual_count, start_bytes
from .._checks import callable_arg, count_arg, frf_fit, problem_args
from .._errors import FemupdateError, InputError
from ..options import (ExecutionOptions, FRFOptions, NoiseOptions, SolverOptions, StartsOptions, UpdateOptions, gather,
                       gather_some)
from ..dask_cluster import Task, collect, connect
from .clustering import classify, converged_solutions, parameter_scale
from .results import MultiStartResult, UpdateResult, attach
from .combined import DATA_KINDS, data_kinds
from .run import frf_update, frf_update_with, update, update_with

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
        <= 0 with ``log_uniform``; ``n`` not an integer >= 1, or its starting values beyond the
        available memory (:func:`femupdate._budget.check_count`, before they are drawn).
    """
    count_arg(n, "n", "draw_starts")
    check_count("starts", n, 8.0 * max(len(names), 1), "the starting values")
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
        X = rng.uniform(np.log(lo), np.log(hi), size=(n, len(idx)))
        return np.exp(X, out=X)  # in place: the starts' memory once
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


def _update_start(model, data, *, params, x0, options, values):
    """One start of a multi-start study: :func:`update` without the result's context (the model
    and data need not travel back from a worker with every run)."""
    return update_with(model, data, options, params=params, x0=x0, values=values)


def _frf_update_start(model, data, *, params, x0, frf, noise, solver, values):
    """One start of :func:`frf_multistart`: :func:`frf_update` without the result's context."""
    return frf_update_with(model, data, frf, noise, solver, params=params, x0=x0, values=values)


def _run_one(model, data, names, start, kwargs):
    return run_with(_update_start, model, data, names, start, kwargs)


def timed(runner, model, data, names, start, kwargs):
    """``(runner(model, data, names, start, kwargs), wall-clock seconds, CPU seconds)`` (a Dask
    task).  The CPU seconds are those of the process that ran the start (its BLAS threads
    included; on a Dask worker also whatever else that worker ran meanwhile)."""
    t, c = time.perf_counter(), time.process_time()
    out = runner(model, data, names, start, kwargs)
    return out, time.perf_counter() - t, time.process_time() - c


def multistart(model, data, starts: StartsOptions | int | None = None, *, params: Sequence[str] | None = None,
               values=None, execution: ExecutionOptions | None = None,
               progress: Callable[[int, int], None] | None = None, options: UpdateOptions | None = None,
               **shorthand) -> MultiStartResult:
    """Run :func:`femupdate.update` from random starting points (any data it takes; modal data of
    small models on the compiled route).

    Parameters
    ----------
    model : Model
        The parametrised model.
    data : TestData, FRFData or other data :func:`update` takes
        The measured data.
    starts : StartsOptions or int, optional
        The starts and how solutions are told apart (:class:`~femupdate.options.StartsOptions`:
        number — an int is that —, seed, log-uniform draws, ``alpha`` and ``rel_tol`` (how
        solutions are told apart), ``cost_tol`` and the
        compiled ``batched`` route: ``None`` takes it when only modal data are used, the model
        has at most :data:`femupdate.updating.batched.AUTO_MAX_DOFS` dofs and the options are
        supported — the compiled route implements ``formulation="shapes"`` only —, locally or in
        chunks on the Dask cluster, with the same results; ``False``: one :func:`update` per
        start; ``True``: batched, or an :class:`InputError`).
    params : sequence of str, optional
        Parameters to update (default: the free ones).
    values : None, mapping of str to float, or array_like, optional
        Values of the fixed parameters (default nominal).
    execution : ExecutionOptions, optional
        Where the starts run (:class:`~femupdate.options.ExecutionOptions`): an existing Dask
        cluster (``scheduler``, ``connect_timeout``), or local worker processes of the per-start
        route (``jobs``; default, :func:`local_jobs`: one per usable core when the model has at
        least :data:`femupdate.modal.SPARSE_FROM` dofs and there are at least two starts per
        process, else the starts run in this process; not used on the compiled route).
    progress : callable ``(done, total)``, optional
        Called as starts finish (locally and on Dask).
    options : UpdateOptions, optional
        The options of every start's :func:`update`.
    **shorthand
        Fields of :class:`~femupdate.options.StartsOptions`, :class:`~femupdate.options.ExecutionOptions`
        and of the update's option objects as keywords (``seed=3``, ``scheduler=...``,
        ``min_mac=0.8``, ...); not ``x0``.

    Returns
    -------
    MultiStartResult
        Every run (a failed start as its ``"ErrorType: message"``), the distinct solutions and the
        best run.

    Raises
    ------
    InputError
        ``x0`` given; FRF options given when only modal data are used; ``batched=True`` with
        non-modal data or options the batched route does not support; a parameter without
        finite bounds, an unknown parameter, or a bound <= 0 with ``log_uniform``
        (:func:`draw_starts`); a scheduler not reached within ``connect_timeout``; more starts
        than the available memory holds the records of (estimated from the data's residuals and
        the parameters, :func:`femupdate._budget.start_bytes`; named with the estimate, before any
        start is drawn); input that :func:`update` refuses alike at every start (the same
        InputError).  Otherwise the errors of :func:`update` itself (refused input, numerical
        failure) do not propagate: each start that fails is recorded as its message in ``runs``.
    TypeError
        A keyword no option object has.
    """
    from .run import damped_doors

    view = damped_doors("multistart", model, data, params=params, values=values)
    callable_arg(progress, "progress", "multistart")
    st, ex, rest = _starts_options("multistart", shorthand, starts, execution)
    uo = UpdateOptions.of("multistart", rest, options=options)
    frf_fit(uo.frf, uo.noise, data, "multistart")
    if view is not None:  # a damped model: the per-start route (the compiled one has no damping)
        return _damped_multistart(view, data, st, ex, uo, params, values, progress)
    names = tuple(params) if params is not None else tuple(model.parameter_names[j] for j in model.free)
    kinds = data_kinds(data, uo.use)
    batched = st.batched
    if kinds == ("modes",):
        if uo.frf.changed():
            raise InputError(f"FRF options ({', '.join(sorted(uo.frf.changed()))}) given, but no FRF data are used")
        if uo.modal.formulation != "shapes":
            _check_once(model, data, names, uo, values)
    elif batched:
        raise InputError(f"batched=True takes modal data only; these data use {', '.join(kinds)}: use batched=False")
    else:
        batched = False
    if batched is None:
        from .batched import supports

        batched = supports(model, uo)
    if batched:
        from .batched import unsupported

        reason = unsupported(model, uo, explicit=True)
        if reason:
            raise InputError(f"batched=True: {reason}; use batched=False")
    n_res = residual_count(data)
    check_count("starts", st.starts, start_bytes(n_res, len(names), bool(batched), block_count(data)),
                "the starts' records")
    X0 = draw_starts(model, names, st.starts, st.seed, st.log_uniform)
    if batched:  # all starts at once for small dense models
        from .batched import multistart_batched

        ms = multistart_batched(model, data, names, X0, study=st, execution=ex, progress=Pace("starts", progress),
                                values=values, options=uo)
    else:
        ms = run_starts(model, data, names, X0, {"options": uo, "values": values}, starts=st, execution=ex,
                        progress=Pace("starts", progress))
    from .run import _damping_of

    refused_alike(ms)
    return attach(ms, model, data, "update", damping=_damping_of(uo))


def _damped_multistart(view, data, st: StartsOptions, ex: ExecutionOptions, uo: UpdateOptions, params, values,
                       progress) -> MultiStartResult:
    """Multi-start of a damped model (:class:`~femupdate.damping.view.DampedView`): one
    :func:`update` per start (``batched=True`` refused: the compiled route has no damping)."""
    if st.batched:
        raise InputError("batched=True: the compiled route does not take damped models (a [damping] table, "
                         "DampedModel); use batched=False (each start then runs the damped update)")
    from .damped_run import damped_problem

    names = tuple(params) if params is not None else None
    if names is None:  # the parameters the damped update moves (the damping ones only with damping data)
        names = tuple(damped_problem(view, data, uo, None, values=values).names)
    n_res = residual_count(data)
    check_count("starts", st.starts, start_bytes(n_res, len(names), False, block_count(data)), "the starts' records")
    X0 = draw_starts(view, names, st.starts, st.seed, st.log_uniform)
    ms = run_starts(view, data, names, X0, {"options": uo, "values": values}, starts=st, execution=ex,
                    progress=Pace("starts", progress))
    refused_alike(ms)
    return attach(ms, view, data, "update")


def refused_alike(ms: MultiStartResult) -> None:
    """Raise the :class:`InputError` that every start was refused with, when it is one message:
    the input itself is refused (as one :func:`update` refuses it), not its starts."""
    runs = ms.runs
    head = "InputError: "
    if runs and all(isinstance(r, str) and r.startswith(head) for r in runs) and len(set(runs)) == 1:
        raise InputError(runs[0][len(head):])


def _check_once(model, data, names, o: UpdateOptions, values) -> None:
    """Build the modal problem once, so that input a formulation other than ``"shapes"`` refuses
    (a test mode without a shape for ``"dynamic"``, options it does not take, too few data) is
    refused once, as an :class:`InputError`, rather than recorded as the failure of every start
    (those formulations take the per-start route)."""
    from .problem import Problem, check_determined

    prob = Problem(model, data, names, values=values, parametrisation=o.solver.parametrisation, modal=o.modal,
                   pairing=o.pairing, noise=o.noise)
    if o.solver.regularization is None:
        check_determined(prob)


def run_starts(model, data, names, X0, kwargs, *, starts: StartsOptions | None = None,
               execution: ExecutionOptions | None = None, progress=None, runner=None) -> MultiStartResult:
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
    starts : StartsOptions, optional
        Its ``seed`` (the seed the starts were drawn with, recorded in the result), ``alpha`` and
        ``rel_tol`` (how two solutions are told apart, :class:`~femupdate.options.StartsOptions`) and ``cost_tol`` (largest
        cost of a converged run; default no limit); its number of starts is ``len(X0)``.
    execution : ExecutionOptions, optional
        ``scheduler`` (a Dask scheduler's address; local runs otherwise), ``connect_timeout``
        (seconds to wait for it) and ``jobs``: local worker processes (without ``scheduler``;
        :func:`local_jobs` by default; 1 runs the starts in this process).  Each start is
        independent of the others, so the runs are those of the sequential route (to round-off:
        each process chooses its model's factorisation route at its own first evaluation).
    progress : callable ``(done, total)``, optional
        Called as runs finish (locally and on Dask).
    runner : callable, optional
        ``runner(model, data, names, start, kwargs)``; default: :func:`run_with` of :func:`update`.
        On Dask, and with local worker processes, it must be picklable; each Dask task is retried
        up to twice.

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
    st, ex = starts or StartsOptions(), execution or ExecutionOptions()
    runner = runner or _run_one
    if ex.scheduler:
        pairs = _run_dask(ex.scheduler, model, data, names, X0, kwargs, progress, ex.connect_timeout, runner)
    else:
        jobs = local_jobs(model, len(X0)) if ex.jobs is None else max(1, min(int(ex.jobs), len(X0)))
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
    ok, solutions = converged_solutions(runs, names, UpdateResult, st.cost_tol, st.rel_tol,
                                        parameter_scale(model, names), st.alpha)
    best = min((runs[k] for k in ok), key=lambda r: r.cost) if ok else None
    return classify(MultiStartResult(best, solutions, runs, X0, tuple(names), len(X0), len(ok), st.seed,
                                     seconds=seconds, cpu_seconds=cpu), st.alpha)


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


def _share(model, data, runner, settings) -> None:
    """A worker process's copy of what every start shares (sent once per process), and the
    caller's settings (:mod:`femupdate.settings`) installed."""
    from .. import settings as _settings

    _settings.install(settings)
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

    from .. import settings

    pairs: list = [None] * len(X0)
    # the workers end with this process, however it ends (femupdate._workers); each gets the caller's settings
    with process_pool(jobs, ("femupdate.updating",), _share, (model, data, runner, settings.current())) as pool:
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
        futures = {client.submit(Task(timed), runner, m_f, d_f, names, x, kwargs, pure=False, retries=2): k
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


def _starts_options(where: str, shorthand: Mapping, starts, execution) -> tuple[StartsOptions, ExecutionOptions, dict]:
    """A multi-start's :class:`StartsOptions` and :class:`ExecutionOptions` from its arguments and
    keywords, and the keywords left for the update; ``x0`` refused (the starts are drawn)."""
    given, rest = gather_some(where, shorthand, starts=(StartsOptions, starts), execution=(ExecutionOptions, execution))
    if "x0" in rest:
        raise InputError("a multi-start draws its own starting values: give starts, seed and params, not x0")
    return given["starts"], given["execution"], rest


def frf_run_options(where: str, rest: Mapping, data) -> dict:
    """The option objects of an FRF update run from a call's keywords ``rest`` (``frf``,
    ``noise``, ``solver`` and their fields as shorthand; a plain ``measurement_std`` is the
    FRF entries' std), checked against ``data`` (:func:`~femupdate._checks.frf_fit`)."""
    rest = dict(rest)
    std_given = rest.get("measurement_std")
    if std_given is not None and not isinstance(std_given, Mapping):  # the std of the FRF entries
        rest["measurement_std"] = {"frf": std_given}
    o = gather(where, {k: v for k, v in rest.items() if k not in ("frf", "noise", "solver")},
               frf=(FRFOptions, rest.get("frf")), noise=(NoiseOptions, rest.get("noise")),
               solver=(SolverOptions, rest.get("solver")))
    frf_fit(o["frf"], o["noise"], data, where)
    return o


def frf_multistart(model, data, starts: StartsOptions | int | None = None, *, params: Sequence[str] | None = None,
                   values=None, execution: ExecutionOptions | None = None, progress=None, **shorthand):
    """:func:`frf_update` from random starts within the bounds (the same seeded starts as
    :func:`femupdate.updating.multistart`), locally or on Dask; a
    :class:`~femupdate.updating.MultiStartResult` in the same format.

    Parameters
    ----------
    model : Model
        The parametrised model.
    data : FRFData or TestData
        The measured FRFs.
    starts : StartsOptions or int, optional
        The starts (:class:`~femupdate.options.StartsOptions`; an int is their number).
    params : sequence of str, optional
        Parameters to update (default: the free ones).
    values : None, mapping of str to float, or array_like, optional
        Values of the fixed parameters (default nominal).
    execution : ExecutionOptions, optional
        A Dask cluster to run on (``scheduler``, ``connect_timeout``); local runs otherwise.
    progress : callable ``(done, total)``, optional
        Called as starts finish (locally and on Dask).
    **shorthand
        Fields of :class:`~femupdate.options.StartsOptions` and
        :class:`~femupdate.options.ExecutionOptions`, and the options of :func:`frf_update`
        (``frf=``, ``noise=``, ``solver=`` or their fields), as keywords; not ``x0``.

    Returns
    -------
    MultiStartResult
        Runs, distinct solutions, and the best run (a :class:`FRFUpdateResult`).

    Raises
    ------
    InputError
        A parameter without finite bounds, an unknown parameter, or a bound <= 0 with
        ``log_uniform`` (:func:`draw_starts`); ``x0`` given; an unreachable scheduler.  The
        errors of :func:`frf_update` itself (refused input, numerical failure) do not propagate:
        each start that fails is recorded as its message in ``runs`` — unless every start is
        refused with the same InputError, which is raised.
    TypeError
        A keyword no option object has.
    """
    from .run import damped_doors

    model = damped_doors("frf_multistart", model, data, params=params, values=values, frf=True) or model
    callable_arg(progress, "progress", "frf_multistart")
    st, ex, rest = _starts_options("frf_multistart", shorthand, starts, execution)
    o = frf_run_options("frf_multistart", rest, data)
    names = tuple(params) if params is not None else tuple(model.parameter_names[j] for j in model.free)
    check_count("starts", st.starts, start_bytes(residual_count(data), len(names), blocks=block_count(data)),
                "the starts' records")
    X0 = draw_starts(model, names, st.starts, st.seed, st.log_uniform)
    ms = run_starts(model, data, names, X0, dict(o, values=values), starts=st, execution=ex.replace(jobs=None),
                    progress=Pace("starts", progress), runner=partial(run_with, _frf_update_start))
    refused_alike(ms)
    return attach(ms, model, data, "frf-update")
