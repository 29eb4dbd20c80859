r"""Global search for the rough FRF residual surfaces of the paper's Figures 6 and 7.

The paper concludes that on such surfaces "other non-linear approaches such as random walks or
genetic algorithms (Larson and Zimmerman 1993) would have to be applied".  Here SciPy's
well-kept global optimisers minimise the FRF cost :math:`\tfrac12\|r\|^2` of
:func:`femupdate.updating.frf_update` (same weights and lines; log-magnitude residuals by
default, ``global_residual``) within the parameters' bounds, and the best point of each run is
polished by the local least-squares FRF update with the chosen residual:

* ``"differential_evolution"`` (Storn & Price; a genetic-type population method) — the whole
  population is evaluated at once with the stacked dense solves of
  :func:`femupdate.frf.surfaces.frf_r2` for small models (``vectorized=True``);
* ``"basinhopping"`` (a random walk between local minima, Wales & Doye) with a bounded
  L-BFGS-B local search on the analytic gradient :math:`J^T r` (eq. 32); every local minimum
  it visits is recorded;
* ``"dual_annealing"`` (generalised simulated annealing).

``runs`` independent runs (seeds ``seed, seed + 1, ...``) are reported exactly like a
multi-start study (:class:`~femupdate.updating.MultiStartResult`: solutions clustered and
counted), locally or on an existing Dask cluster (``scheduler``).
"""

from __future__ import annotations

import logging
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np
from scipy import optimize

from .._budget import Pace, check_memory
from .._checks import callable_arg, choice_arg, count_arg, mapping_arg, problem_args
from .._errors import FemupdateError, InputError
from ..options import ExecutionOptions, FRFOptions, NoiseOptions, SolverOptions, StartsOptions, gather_some
from ..frf.surfaces import SURFACE_DENSE_LIMIT, AffineStack, frf_r2
from .clustering import classify, cluster, converged_solutions, parameter_scale
from .frf import FRFUpdateResult, frf_data, prepare_problem
from .run import DEFAULT_RESIDUAL, frf_update_with
from .results import MultiStartResult, UpdateResult, attach
from .starts import frf_run_options, run_starts

log = logging.getLogger(__name__)

METHODS = ("differential_evolution", "basinhopping", "dual_annealing")
#: the residual forms of the global stage
GLOBAL_RESIDUALS = ("log", "linear", "relative")


@dataclass(frozen=True)
class _GlobalJob:
    """What every run of a global search needs besides the model, data, names and seed."""

    method: str
    method_options: dict
    global_residual: str | None
    frf: FRFOptions
    noise: NoiseOptions
    solver: SolverOptions
    values: object = None


@dataclass(frozen=True, eq=False)
class GlobalSearchResult(MultiStartResult):
    """A :class:`~femupdate.updating.MultiStartResult` of a global search.

    Attributes
    ----------
    best, solutions, names, converged
        As :class:`~femupdate.updating.MultiStartResult` (of the polished runs).
    runs : list
        Per run, the polished :class:`~femupdate.updating.frf.FRFUpdateResult`, or the message
        ``"ErrorType: message"`` of a run that failed.
    starts : numpy.ndarray, shape ``(runs, L)``
        The global optimiser's best point of each run (physical units; NaN for a run whose
        cost could not be set up), from which the polish started (clipped to the bounds).
    total : int
        The number of runs.
    seed : int
        The first run's seed.
    method : str
        The global optimiser.
    global_residual : str or None
        The residual of the global stage (``None``: the polish's).
    optimizer : list of dict
        Per run ``{seed, x {name: value}, cost, nfev, nit, message}``, and for basin hopping
        ``minima``: the distinct local minima it visited, clustered, each
        ``{parameters, cost, count}`` (only ``{seed}`` for a run that failed to start).
    """

    method: str = ""
    optimizer: list = field(default_factory=list)
    global_residual: str | None = "log"

    kind: ClassVar[str] = "frf-update"


def _bounds(model, names):
    lo, hi = model.bounds
    idx = [model.parameter_index(n) for n in names]
    lo, hi = lo[idx], hi[idx]
    bad = [n for n, a, b in zip(names, lo, hi) if not (np.isfinite(a) and np.isfinite(b))]
    if bad:
        raise InputError(f"a global search needs finite bounds; give bounds for: {', '.join(bad)}")
    return lo, hi


class _Cost:
    """½ r² of the FRF problem at parameter points (batched for small models)."""

    def __init__(self, model, data, names, frf: FRFOptions, std, values):
        prob, _, _, _ = prepare_problem(model, data, names, None, frf, SolverOptions(parametrisation="absolute"),
                                        measurement_std=std, values=values)
        self.values, self.damping = values, frf.damping
        self.prob = prob
        measured = frf_data(data)
        from ..testdata import FRFData

        self.sub = FRFData(prob.omega, dict(measured.force), measured.dofs, prob.xe)
        self.batched = model.n_dofs <= SURFACE_DENSE_LIMIT
        self.model, self.names = model, list(names)
        self.stack = AffineStack(model, names, values) if self.batched else None
        self.w = prob.w if prob.kind != "relative" else prob.w * np.abs(prob.xe)  # frf_r2 re-applies 1/|x_E|
        self.nfev = 0

    def population(self, P: np.ndarray) -> np.ndarray:
        """Costs of the points ``P`` ``(G, L)`` (inf where singular)."""
        self.nfev += P.shape[0]
        if self.batched:
            r2 = frf_r2(self.model, self.sub, self.names, P, self.values, self.damping, self.prob.kind, self.w,
                        stack=self.stack)
            return 0.5 * r2
        out = np.empty(P.shape[0])
        for g, x in enumerate(P):
            try:
                r = self.prob.residuals(np.asarray(x, float))
                out[g] = 0.5 * float(r @ r)
            except FemupdateError:
                out[g] = np.inf
        return out

    def __call__(self, x):
        return float(self.population(np.asarray(x, float)[None, :])[0])

    def local_minimizer(self, lo, hi):
        """A bounded local minimiser for :func:`scipy.optimize.basinhopping`: trust-region
        least squares on the residuals with the analytic Jacobian (eq. 32), a few iterations."""
        prob = self.prob

        def fun(x):
            self.nfev += 1
            return prob.residuals(x)

        def minimize(_f, x0, *args, **kw):
            try:
                sol = optimize.least_squares(fun, np.clip(x0, lo, hi), jac=prob.jacobian, bounds=(lo, hi),
                                             x_scale="jac", max_nfev=100)
                return optimize.OptimizeResult(x=sol.x, fun=sol.cost, success=sol.success, nfev=sol.nfev)
            except FemupdateError:
                return optimize.OptimizeResult(x=np.asarray(x0, float), fun=np.inf, success=False, nfev=1)

        return minimize


class _BoundedStep:
    """Basin-hopping step: uniform displacement of ``stepsize`` × (bound width), clipped to the bounds."""

    def __init__(self, lo, hi, rng, stepsize=0.25):
        self.lo, self.hi, self.rng, self.stepsize = lo, hi, rng, stepsize

    def __call__(self, x):
        step = self.rng.uniform(-1, 1, size=x.shape) * self.stepsize * (self.hi - self.lo)
        return np.clip(x + step, self.lo, self.hi)


def _run_global(model, data, names, seed, job: _GlobalJob) -> tuple:
    """One global run + local polish; returns (FRFUpdateResult or error message, optimiser info)."""
    method = job.method
    opts = dict(job.method_options or {})
    stage = job.global_residual or job.frf.residual
    stage = "log" if stage == "auto" else stage  # "auto" finds the basin with log magnitudes
    seed = int(np.ravel(seed)[0])
    lo, hi = _bounds(model, names)
    try:
        cost = _Cost(model, data, names, job.frf.replace(residual=stage), dict(job.noise.std or {}).get("frf"),
                     job.values)
    except FemupdateError as exc:
        return f"{type(exc).__name__}: {exc}", {"seed": seed}
    info: dict = {"seed": seed}
    if method == "differential_evolution":
        opts.setdefault("popsize", 50)
        opts.setdefault("maxiter", 300)
        opts.setdefault("tol", 1e-10)
        if cost.batched:
            res = optimize.differential_evolution(lambda X: cost.population(np.asarray(X).T), list(zip(lo, hi)),
                                                  rng=np.random.default_rng(seed), polish=False, vectorized=True,
                                                  updating="deferred", **opts)
        else:
            res = optimize.differential_evolution(cost, list(zip(lo, hi)), rng=np.random.default_rng(seed),
                                                  polish=False, **opts)
    elif method == "basinhopping":
        rng = np.random.default_rng(seed)
        x0 = rng.uniform(lo, hi)
        minima: list = []
        opts.setdefault("niter", 60)
        stepsize = opts.pop("stepsize", 0.25)
        res = optimize.basinhopping(
            cost, x0, minimizer_kwargs={"method": cost.local_minimizer(lo, hi)},
            take_step=_BoundedStep(lo, hi, rng, stepsize), rng=rng,
            callback=lambda x, f, accept: minima.append((np.array(x, float), float(f))), **opts)
        if minima:
            pts = np.array([m[0] for m in minima])
            fs = np.array([m[1] for m in minima])
            info["minima"] = [{"parameters": dict(zip(names, map(float, pts[g[0]]))), "cost": float(fs[g[0]]),
                               "count": len(g)} for g in cluster(pts, fs, 1e-4)]
    elif method == "dual_annealing":
        opts.setdefault("maxiter", 500)
        res = optimize.dual_annealing(cost, list(zip(lo, hi)), rng=np.random.default_rng(seed), no_local_search=True,
                                      **opts)
    else:
        raise InputError(f"unknown global method {method!r}: use {', '.join(METHODS)}")
    info.update({"x": dict(zip(names, map(float, res.x))), "cost": float(res.fun), "nfev": int(cost.nfev),
                 "nit": int(getattr(res, "nit", 0)), "message": str(getattr(res, "message", ""))})
    run: FRFUpdateResult | str
    try:
        run = frf_update_with(model, data, job.frf, job.noise, job.solver, params=names,
                              x0=dict(zip(names, np.clip(res.x, lo, hi))), values=job.values)
    except FemupdateError as exc:
        run = f"{type(exc).__name__}: {exc}"
    return run, info


def _population_bounds(options: Mapping, n_params: int) -> None:
    """Refuse counts of the SciPy optimiser's options that are not integers >= 1, or a population
    whose records (every member, its cost and SciPy's copies: 32 bytes a parameter) exceed the
    available memory."""
    for key in ("popsize", "maxiter", "niter", "maxfun"):
        if key in options:
            count_arg(options[key], f"method_options[{key!r}]", "global_search")
    if "popsize" in options:
        check_memory(f"method_options['popsize']={options['popsize']}",
                     32.0 * options["popsize"] * n_params * max(n_params, 1), "the population of differential evolution")


def _runner(model, data, names, seed, kwargs):
    return _run_global(model, data, names, seed, kwargs["job"])


def global_search(model, data, *, method: str = "differential_evolution", method_options: dict | None = None,
                  global_residual: str | None = "log", params: Sequence[str] | None = None, values=None,
                  starts: StartsOptions | int | None = None, execution: ExecutionOptions | None = None,
                  progress=None, **shorthand) -> GlobalSearchResult:
    """Global minimisation of the FRF residual within the bounds, then a local polish.

    Parameters
    ----------
    model, data
        As for :func:`femupdate.updating.frf_update` (finite bounds needed).
    method : {"differential_evolution", "basinhopping", "dual_annealing"}, default ``"differential_evolution"``
        The SciPy global optimiser (module docstring).
    method_options : dict, optional
        Passed to the SciPy optimiser (e.g. ``{"popsize": 30, "maxiter": 500}``; defaults
        popsize 50, maxiter 300, tol 1e-10 for differential evolution, niter 60 and stepsize
        0.25 of the bound widths for basin hopping, maxiter 500 for dual annealing).  The
        keyword ``options`` is its older name.
    global_residual : {"log", "linear", "relative"} or None, default ``"log"``
        Residual form of the global stage (``"log"``: log-magnitudes; the polish uses
        ``residual``).  On the linear scale the spikes of lines near resonances span tens of
        decades and mislead population methods; logarithms compress them, with the same
        minimiser for noise-free data.  ``None``: the polish's residual throughout (``"log"``
        when it is ``"auto"``).
    params : sequence of str, optional
        Names of the parameters searched (default every parameter not ``fixed``).
    values : None, mapping of str to float, or array_like, optional
        Values of the fixed parameters (default nominal).
    starts : StartsOptions or int, optional
        The runs (:class:`~femupdate.options.StartsOptions`: their number — one by default, an
        int is that —, with seeds ``seed .. seed + runs - 1``; ``rel_tol`` and ``cost_tol`` of
        the clustering of the polished solutions, as in multi-start studies).  The keyword
        ``runs`` is the number.
    execution : ExecutionOptions, optional
        A Dask cluster for the runs (``scheduler``, ``connect_timeout``; default: locally, one
        after another).
    progress : callable, optional
        Called as ``progress(done, total)`` after each run.
    **shorthand
        Fields of those option objects and the options of :func:`~femupdate.updating.frf_update`
        (``residual``, ``weights``, ``lines``, ``damping``, ``noise=``, ``solver=``, ...) as
        keywords, for the cost and for the polish.

    Returns
    -------
    GlobalSearchResult

    Raises
    ------
    InputError
        An unknown method; fewer than one run; no parameters; a searched parameter without
        finite bounds; an unreachable scheduler.  A run that fails is recorded in ``runs`` as
        a message, not raised.
    TypeError
        A keyword no option object has.
    """
    problem_args("global_search", model, data, params=params, values=values, frf=True)
    callable_arg(progress, "progress", "global_search")
    shorthand = dict(shorthand)
    runs_given = shorthand.pop("runs", None)
    if "options" in shorthand:
        method_options = shorthand.pop("options")
    if starts is None and runs_given is not None:
        starts = runs_given
    given, rest = gather_some("global_search", shorthand, starts=(StartsOptions, 1 if starts is None else starts),
                              execution=(ExecutionOptions, execution))
    st, ex = given["starts"], given["execution"]
    o = frf_run_options("global_search", rest, data)
    choice_arg(method, METHODS, "global method", "global_search")
    mapping_arg(method_options, "method_options", "global_search")
    if global_residual is not None:
        choice_arg(global_residual, GLOBAL_RESIDUALS, "global_residual", "global_search")
    runs, seed = st.starts, (0 if st.seed is None else st.seed)
    names = tuple(params) if params is not None else tuple(model.parameter_names[j] for j in model.free)
    if not names:
        raise InputError("no parameters to search: every parameter is fixed")
    _population_bounds(method_options or {}, len(names))
    _bounds(model, names)
    seeds = (int(seed) + np.arange(runs))[:, None]
    job = _GlobalJob(method, dict(method_options or {}), global_residual, o["frf"], o["noise"], o["solver"], values)
    pairs = run_starts(model, data, names, seeds, {"job": job}, starts=st.replace(seed=seed),
                       execution=ex.replace(jobs=None), progress=Pace("global runs", progress), runner=_runner).runs
    results = [p[0] for p in pairs]
    infos = [p[1] for p in pairs]

    ok, solutions = converged_solutions(results, names, UpdateResult, st.cost_tol, st.rel_tol,
                                        parameter_scale(model, names), st.alpha)
    best = min((results[k] for k in ok), key=lambda r: r.cost) if ok else None
    starts_x = np.array([[i.get("x", {}).get(n, np.nan) for n in names] for i in infos])
    # marked as fitting or not, as multi-start results are (else every run is listed as a local minimum)
    return attach(classify(GlobalSearchResult(best, solutions, results, starts_x, names, runs, len(ok), seed, method,
                                              infos, global_residual=global_residual), st.alpha),
                  model, data, "frf-update")
