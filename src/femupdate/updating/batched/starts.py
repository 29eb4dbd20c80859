"""Multi-start updating on the compiled route: every start of a :class:`~femupdate.updating.Problem`
run to the end at once (:class:`.driver.BatchedProblem`), clustered as the local route clusters."""

from __future__ import annotations

import dataclasses
import logging
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

from ... import rules
from ..._errors import FemupdateError, InputError
from ..clustering import classify, converged_solutions, parameter_scale
from ..problem import Problem
from ..results import MultiStartResult, RunResult, UpdateResult
from ..solve import pairing_record, result_at, update_modal
from ...options import ExecutionOptions, StartsOptions, UpdateOptions, gather_some
from .driver import BatchedProblem, unsupported
from .lsq import FAILED

log = logging.getLogger(__name__)


@dataclass(frozen=True, eq=False)
class BatchRun(RunResult):
    """Result of one start of a batched study: the fields of
    :class:`~femupdate.updating.results.RunResult` (a light
    :class:`~femupdate.updating.UpdateResult`), and ``optimality`` (‖gradient‖∞), ``pairs``
    [(test mode, model mode, MAC)], the paired ``model_frequencies_hz``, the ``start``, the
    iteration ``history`` (built from ``history_cost`` and ``history_x`` on demand) and
    ``pairing`` (as :attr:`UpdateResult.pairing`: the rule asked for and the rule that made the
    final pairs).
    """

    optimality: float
    pairs: list[tuple[int, int, float]]
    model_frequencies_hz: np.ndarray
    start: dict[str, float] = field(default_factory=dict)
    history_cost: np.ndarray = field(default_factory=lambda: np.zeros(0))  #: (iterations + 1,)
    history_x: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))  #: (iterations + 1, L) values of names
    pairing: dict = field(default_factory=dict)

    @property
    def history(self) -> list[dict]:
        """One entry per iteration, as :attr:`UpdateResult.history` (built on demand)."""
        return [{"iteration": i, "cost": float(c), "parameters": dict(zip(self.names, map(float, x)))}
                for i, (c, x) in enumerate(zip(self.history_cost, self.history_x))]

    def __repr__(self) -> str:
        values = ", ".join(f"{n}={v:.6g}" for n, v in zip(self.names, self.x))
        return f"BatchRun({'converged' if self.success else 'NOT converged'}, cost {self.cost:.4g}: {values})"


def pairing_of(problem: Problem, pairs, macs) -> dict:
    """A start's ``pairing`` record (as :attr:`UpdateResult.pairing`) from its final pairs."""
    return pairing_record(problem, macs, rules.pairing_rule(problem.pairing, pairs, problem.targets.lam_e))


def batched_runs(model, data, names: Sequence[str], starts, options: UpdateOptions, values=None,
                 progress: Callable[[int, int], None] | None = None) -> list:
    """Every start of ``starts`` run to the end in compiled code: per start a :class:`BatchRun`,
    or the message (str) of its failure, exactly as the local route reports it.  A start that
    meets a group of repeated or close modes (``close_modes`` of the modal options; the compiled
    route does not compare groups, :mod:`femupdate.updating.groups`) is solved again from its
    start on the local route, its ``message`` saying so (its ``optimality`` is then ‖Jᵀr‖∞).

    A pure function of its arguments, and each start's result depends on that start alone (not
    on the other starts of the batch, their order or the number of threads): the starts may be
    split into any chunks — one per Dask task — with bit-identical results.

    Parameters
    ----------
    model, data : as :func:`femupdate.update`.
    names : updated parameters.
    starts : (R, L) starting values.
    options : the update's options (:class:`~femupdate.options.UpdateOptions`; :func:`unsupported`
        says which the route takes).
    values : the fixed parameters' values, as :func:`femupdate.update` takes them.
    progress : ``progress(finished, R)``.

    Returns
    -------
    list
        R entries: :class:`BatchRun` or str.
    """
    names = tuple(names)
    X0 = np.array(starts, dtype=float, ndmin=2)
    R = X0.shape[0]
    o = options
    try:
        problem = _problem(model, data, names, o, values)
        bp = BatchedProblem.from_problem(problem, X0, max_nfev=o.solver.max_nfev, ftol=o.solver.ftol,
                                         xtol=o.solver.xtol, gtol=o.solver.gtol)
    except FemupdateError as exc:  # update() would refuse every start alike
        return [f"{type(exc).__name__}: {exc}"] * R
    res = bp.solve(progress=progress)
    alive = np.flatnonzero(res.status != FAILED)
    runs: list = [m if m.startswith(("NumericalError:", "InputError:")) else f"NumericalError: {m}"
                  for m in res.message]  # (used for the failed starts only)
    if problem.close_modes > 0 and res.codes is not None:
        # groups of repeated or close modes are the local route's (femupdate.updating.groups)
        for handed in np.flatnonzero((res.status == FAILED) & (res.codes == rules.E_REPEATED)):
            runs[int(handed)] = _local_run(model, data, names, X0[int(handed)], o, values)
    P_alive = bp.full_p(res.x[alive], alive)
    m_row = bp.n_residuals
    T = problem.targets.n_test
    assert res.pairs is not None and res.macs is not None and res.pair_eigenvalues is not None
    for i, r in enumerate(alive):
        P = P_alive[i]
        f = res.fun[r, :m_row[r]].copy()
        n_hist = min(int(res.iterations[r]) + 1, res.history_cost.shape[1])
        runs[r] = BatchRun(
            parameters=dict(zip(model.parameter_names, map(float, P))), names=names, x=P[bp.idx],
            success=bool(res.status[r] > 0), status=int(res.status[r]), message=res.message[r],
            cost=float(0.5 * f @ f), fun=f, jac=res.jac[r, :m_row[r]], nfev=int(res.nfev[r]),
            njev=int(res.njev[r]), iterations=int(max(res.iterations[r], res.njev[r])),
            optimality=float(res.optimality[r]),
            pairs=[(k, int(res.pairs[r, k]), float(res.macs[r, k])) for k in range(T)],
            model_frequencies_hz=np.sqrt(np.clip(res.pair_eigenvalues[r, :T], 0, None)) / (2 * np.pi),
            start=dict(zip(names, map(float, X0[r]))),
            history_cost=res.history_cost[r, :n_hist].copy(),
            history_x=bp.to_p(res.history_x[r, :n_hist], np.full(n_hist, r)),
            pairing=pairing_of(problem, res.pairs[r, :T], res.macs[r, :T]),
        )
    return runs


def _local_run(model, data, names, start, o: UpdateOptions, values) -> BatchRun | str:
    """One start solved on the local route (:func:`~femupdate.updating.solve.update_modal`), as a
    :class:`BatchRun`: a start that met a group of repeated or close modes, which the compiled
    route does not compare (its ``message`` says so)."""
    try:
        res = update_modal(model, data, params=list(names), x0=dict(zip(names, map(float, start))), values=values,
                           modal=o.modal, pairing=o.pairing, noise=o.noise, solver=o.solver)
    except FemupdateError as exc:
        return f"{type(exc).__name__}: {exc}"
    hist = res.history
    return BatchRun(
        parameters=dict(res.parameters), names=tuple(names), x=res.x, success=res.success, status=res.status,
        message=f"{res.message} (solved on the local route: it met repeated or close modes)", cost=res.cost,
        fun=res.fun, jac=res.jac, nfev=res.nfev, njev=res.njev, iterations=res.iterations,
        optimality=float(np.max(np.abs(res.jac.T @ res.fun), initial=0.0)), pairs=list(res.pairs),
        model_frequencies_hz=res.model_frequencies_hz, start=dict(zip(names, map(float, start))),
        history_cost=np.array([h["cost"] for h in hist]),
        history_x=np.array([[h["parameters"][n] for n in names] for h in hist]).reshape(len(hist), len(names)),
        pairing=dict(res.pairing))


def _problem(model, data, names, o: UpdateOptions, values, x0=None) -> Problem:
    return Problem(model, data, names, x0=x0, values=values, parametrisation=o.solver.parametrisation, modal=o.modal,
                   pairing=o.pairing, noise=o.noise)


def _dask_runs(model, data, names, X0, options, values, scheduler: str, timeout: float, progress) -> list:
    """:func:`batched_runs` in chunks, one task each, on the Dask cluster at ``scheduler``."""
    from ...dask_cluster import Task, collect, connect

    client = connect(scheduler, timeout)
    try:
        R = X0.shape[0]
        n_chunks = max(1, min(R, 2 * sum(client.nthreads().values())))
        chunks = [c for c in np.array_split(np.arange(R), n_chunks) if c.size]
        m_f, d_f = client.scatter([model, data], broadcast=True)
        futures = {client.submit(Task(batched_runs), m_f, d_f, tuple(names), X0[c], options, values, pure=False,
                                 retries=2): k
                   for k, c in enumerate(chunks)}
        parts: list = [None] * len(chunks)

        def keep(k, result):
            parts[k] = result
            if progress:
                progress(sum(chunks[i].size for i, r in enumerate(parts) if r is not None), R)

        collect(client, futures, scheduler, timeout, keep)
    finally:
        client.close()
    return [run for part in parts for run in part]


def multistart_batched(model, data, names: Sequence[str], starts, *, study: StartsOptions | None = None,
                       execution: ExecutionOptions | None = None,
                       progress: Callable[[int, int], None] | None = None, polish: bool = True, values=None,
                       options: UpdateOptions | None = None, **shorthand):
    """Multi-start updating with every start run in compiled code; same result as the local route.

    Parameters
    ----------
    model, data : as :func:`femupdate.update`.
    names : updated parameters.
    starts : (R, L) starting values (e.g. from :func:`femupdate.updating.draw_starts`).
    study : its ``seed`` (recorded in the result), ``rel_tol`` and ``cost_tol`` (clustering and
        acceptance, as :func:`femupdate.updating.multistart`; :class:`~femupdate.options.StartsOptions`,
        whose number of starts is that of ``starts``).
    execution : a Dask scheduler to run on (``scheduler``, ``connect_timeout``;
        :class:`~femupdate.options.ExecutionOptions`).
    progress : ``progress(finished, R)``.
    polish : re-run :func:`~femupdate.update` once from the best solution (a final check by the
        local route); its ``start``, ``history``, ``nfev``, ``njev`` and ``iterations`` then
        cover the batched run and the polish together.  Without it (or should the polish fail)
        ``best`` is the full result at the batched solution itself.
        On a Dask scheduler the starts run in chunks, each chunk on the compiled route
        (:func:`batched_runs`), with results bit-identical to a local run; the clustering and the
        polish run here.
    values : the fixed parameters' values, as :func:`femupdate.update` takes them.
    options, **shorthand : the update's options (:class:`~femupdate.options.UpdateOptions`, or
        its fields as keywords; :func:`unsupported` says which the route takes), and the fields
        of ``study`` and ``execution`` as keywords (``seed=``, ``rel_tol=``, ``scheduler=``, ...).

    Returns
    -------
    femupdate.updating.MultiStartResult
        ``runs[k]`` is a :class:`BatchRun`, or the error message (str) of a start that failed,
        exactly as the local route reports it.
    """
    names = tuple(names)
    X0 = np.array(starts, dtype=float, ndmin=2)
    R = X0.shape[0]
    given, rest = gather_some("multistart_batched", shorthand, study=(StartsOptions, study or StartsOptions(starts=R)),
                              execution=(ExecutionOptions, execution))
    st, ex = given["study"], given["execution"]
    seed, rel_tol, cost_tol = st.seed, st.rel_tol, st.cost_tol
    scheduler, connect_timeout = ex.scheduler, ex.connect_timeout
    options = UpdateOptions.of("multistart_batched", rest, options=options)
    reason = unsupported(model, options, explicit=True)
    if reason:
        raise InputError(f"batched multi-start: {reason}")
    t0 = time.perf_counter()
    if scheduler:
        runs = _dask_runs(model, data, names, X0, options, values, scheduler, connect_timeout, progress)
    else:
        runs = batched_runs(model, data, names, X0, options, values, progress=progress)
    batch_seconds = time.perf_counter() - t0
    covariance = _covariances(model, data, names, options, values) if any(isinstance(r, BatchRun) for r in runs) else None
    ok, solutions = converged_solutions(runs, names, BatchRun, cost_tol, rel_tol, parameter_scale(model, names),
                                        st.alpha, covariance)
    best = None
    if ok:
        k_best = min(ok, key=lambda k: runs[k].cost)
        best = _polish(model, data, names, runs[k_best], options, values) if polish else None
        if best is None:  # not asked for, or the polish failed: the full result at the batched solution
            run = runs[k_best]
            at = _problem(model, data, names, options, values, x0=run.start)
            best = dataclasses.replace(result_at(at, at.from_p(run.x), sol=run, history=run.history), swaps=[])
    log.info("batched multi-start: %d starts, %d converged, %d solutions, %d evaluations in total",
             R, len(ok), len(solutions), sum(r.nfev for r in runs if isinstance(r, BatchRun)))
    if best is not None:  # the solution the polish refined shows the values and cost the headline shows
        k_best = min(ok, key=lambda k: runs[k].cost)
        solutions = [dataclasses.replace(sol, parameters=dict(zip(names, map(float, best.x))), cost=float(best.cost))
                     if k_best in sol.starts else sol for sol in solutions]
    return classify(MultiStartResult(best, solutions, runs, X0, names, R, len(ok), seed, batch_seconds=batch_seconds),
                    st.alpha)


def _covariances(model, data, names, o: UpdateOptions, values):
    """``run -> covariance`` of a :class:`BatchRun` (physical units), as the local route's
    :func:`~femupdate.updating.solve.diagnostics` computes it from the run's residuals and
    Jacobian (in the variables of the parametrisation from the run's start); None where it
    cannot be had."""
    from ..parametrisation import Parametrisation
    from ..solve import diagnostics

    try:
        prob = _problem(model, data, names, o, values)
    except FemupdateError:
        return None

    def cov(run):
        if not isinstance(run, BatchRun) or run.jac.size == 0:
            return None
        try:
            base = np.array(prob.p_base, float)
            base[prob.idx] = [run.start.get(n, v) for n, v in zip(names, run.x)]
            par = Parametrisation(model, names, o.solver.parametrisation, base)
            par.residual_dof = getattr(prob, "residual_dof", run.fun.size)
            d = diagnostics(par, par.from_p(run.x), run.fun, run.jac, prob.sigma, bounds=model.bounds)
        except (FemupdateError, np.linalg.LinAlgError, ValueError):
            return None
        return d.covariance, prob.sigma is not None

    return cov


def _polish(model, data, names, run: BatchRun, o: UpdateOptions, values) -> UpdateResult | None:
    """One full :func:`update` from a batched solution: diagnostics, swaps and a final check."""
    try:
        res = update_modal(model, data, params=list(names), x0=dict(zip(names, map(float, run.x))), values=values,
                           modal=o.modal, pairing=o.pairing, noise=o.noise, solver=o.solver)
    except FemupdateError as exc:
        log.warning("polishing the best batched solution failed: %s", exc)
        return None
    if not res.success:
        return None
    offset = len(run.history)
    history = list(run.history) + [dict(h, iteration=h["iteration"] + offset) for h in res.history[1:]]
    return dataclasses.replace(
        res, start=dict(run.start), history=history, nfev=res.nfev + run.nfev, njev=res.njev + run.njev,
        iterations=res.iterations + run.iterations,
    )


__all__ = ["BatchRun", "multistart_batched", "batched_runs"]
