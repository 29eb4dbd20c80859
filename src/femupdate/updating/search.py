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
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from scipy import optimize

from .._errors import FemupdateError, InputError
from ..frf.surfaces import SURFACE_DENSE_LIMIT, AffineStack, frf_r2
from .clustering import classify, cluster, converged_solutions, parameter_scale
from .frf import FRFUpdateResult, frf_data, prepare_problem
from .run import DEFAULT_RESIDUAL, frf_update
from .results import MultiStartResult, UpdateResult
from .starts import run_starts

log = logging.getLogger(__name__)

METHODS = ("differential_evolution", "basinhopping", "dual_annealing")
_LOCAL_KEYS = ("residual", "weights", "measurement_std", "lines", "select", "resonance", "resonance_tol", "damping",
               "values", "solver")


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
    optimizer : list of dict
        Per run ``{seed, x {name: value}, cost, nfev, nit, message}``, and for basin hopping
        ``minima``: the distinct local minima it visited, clustered, each
        ``{parameters, cost, count}`` (only ``{seed}`` for a run that failed to start).
    """

    method: str = ""
    optimizer: list = field(default_factory=list)


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

    def __init__(self, model, data, names, local):
        prob, _, _, _ = prepare_problem(model, data, names, None, local.get("residual", "linear"), local.get("weights"),
                                 local.get("measurement_std"), local.get("lines"), local.get("select"),
                                 local.get("resonance", "skip"), local.get("resonance_tol", 1e-3), local.get("damping"),
                                 "absolute", local.get("values"), local.get("solver", "auto"), False)
        self.prob = prob
        frf = frf_data(data)
        from ..testdata import FRFData

        self.sub = FRFData(prob.omega, dict(frf.force), frf.dofs, prob.xe)
        self.batched = model.n_dofs <= SURFACE_DENSE_LIMIT
        self.model, self.names = model, list(names)
        self.stack = AffineStack(model, names, local.get("values")) if self.batched else None
        self.w = prob.w if prob.kind != "relative" else prob.w * np.abs(prob.xe)  # frf_r2 re-applies 1/|x_E|
        self.local = local
        self.nfev = 0

    def population(self, P: np.ndarray) -> np.ndarray:
        """Costs of the points ``P`` ``(G, L)`` (inf where singular)."""
        self.nfev += P.shape[0]
        if self.batched:
            r2 = frf_r2(self.model, self.sub, self.names, P, self.local.get("values"), self.local.get("damping"),
                        self.prob.kind, self.w, stack=self.stack)
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


def _run_global(model, data, names, seed, kwargs) -> tuple:
    """One global run + local polish; returns (FRFUpdateResult or error message, optimiser info)."""
    method = kwargs.get("method", "differential_evolution")
    opts = dict(kwargs.get("options") or {})
    local = {k: v for k, v in kwargs.items() if k in _LOCAL_KEYS}
    stage = kwargs.get("global_residual") or local.get("residual", DEFAULT_RESIDUAL)
    local["residual"] = "log" if stage == "auto" else stage  # "auto" finds the basin with log magnitudes
    seed = int(np.ravel(seed)[0])
    lo, hi = _bounds(model, names)
    try:
        cost = _Cost(model, data, names, local)
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
    polish = {k: v for k, v in kwargs.items() if k not in ("method", "options", "global_residual")}
    run: FRFUpdateResult | str
    try:
        run = frf_update(model, data, params=names, x0=dict(zip(names, np.clip(res.x, lo, hi))), **polish)
    except FemupdateError as exc:
        run = f"{type(exc).__name__}: {exc}"
    return run, info


def _runner(model, data, names, seed, kwargs):
    return _run_global(model, data, names, seed, kwargs)


def global_search(model, data, *, method: str = "differential_evolution", params: Sequence[str] | None = None,
                  runs: int = 1, seed: int = 0, scheduler: str | None = None, rel_tol: float = 1e-4,
                  cost_tol: float | None = None, options: dict | None = None, global_residual: str | None = "log",
                  progress=None, connect_timeout: float = 10.0, **kwargs) -> GlobalSearchResult:
    """Global minimisation of the FRF residual within the bounds, then a local polish.

    Parameters
    ----------
    model, data
        As for :func:`femupdate.updating.frf_update` (finite bounds needed).
    method : {"differential_evolution", "basinhopping", "dual_annealing"}, default ``"differential_evolution"``
        The SciPy global optimiser (module docstring).
    params : sequence of str, optional
        Names of the parameters searched (default every parameter not ``fixed``).
    runs : int, default 1
        Independent runs with seeds ``seed .. seed + runs - 1``.
    seed : int, default 0
        Seed of the first run.
    scheduler : str, optional
        Address of an existing Dask scheduler: the runs go to the cluster (default: locally, one
        after another).
    rel_tol : float, default 1e-4
        Relative tolerance of the clustering of the polished solutions, as in multi-start studies.
    cost_tol : float, optional
        Largest cost of a polished solution counted (default: any converged one).
    options : dict, optional
        Passed to the SciPy optimiser (e.g. ``{"popsize": 30, "maxiter": 500}``; defaults
        popsize 50, maxiter 300, tol 1e-10 for differential evolution, niter 60 and stepsize
        0.25 of the bound widths for basin hopping, maxiter 500 for dual annealing).
    global_residual : {"log", "linear", "relative"} or None, default ``"log"``
        Residual form of the global stage (``"log"``: log-magnitudes; the polish uses
        ``residual``).  On the linear scale the spikes of lines near resonances span tens of
        decades and mislead population methods; logarithms compress them, with the same
        minimiser for noise-free data.  ``None``: the polish's residual throughout (``"log"``
        when it is ``"auto"``).
    progress : callable, optional
        Called as ``progress(done, total)`` after each run.
    connect_timeout : float, default 10.0
        Seconds to wait for the Dask scheduler.
    **kwargs
        Passed to :func:`~femupdate.updating.frf_update` (``residual``, ``weights``,
        ``lines``, ``damping``, ...), for the cost and for the polish.

    Returns
    -------
    GlobalSearchResult

    Raises
    ------
    InputError
        An unknown method; fewer than one run; no parameters; a searched parameter without
        finite bounds; an unreachable scheduler.  A run that fails is recorded in ``runs`` as
        a message, not raised.
    """
    if method not in METHODS:
        raise InputError(f"unknown global method {method!r}: use {', '.join(METHODS)}")
    if runs < 1:
        raise InputError("the number of runs must be at least 1")
    names = tuple(params) if params is not None else tuple(model.parameter_names[j] for j in model.free)
    if not names:
        raise InputError("no parameters to search: every parameter is fixed")
    _bounds(model, names)
    seeds = (int(seed) + np.arange(runs))[:, None]
    kw = dict(kwargs, method=method, options=options, global_residual=global_residual)
    pairs = run_starts(model, data, names, seeds, kw, seed=seed, scheduler=scheduler, rel_tol=rel_tol,
                       cost_tol=cost_tol, progress=progress, connect_timeout=connect_timeout, runner=_runner).runs
    results = [p[0] for p in pairs]
    infos = [p[1] for p in pairs]

    ok, solutions = converged_solutions(results, names, UpdateResult, cost_tol, rel_tol, parameter_scale(model, names))
    best = min((results[k] for k in ok), key=lambda r: r.cost) if ok else None
    starts = np.array([[i.get("x", {}).get(n, np.nan) for n in names] for i in infos])
    # marked as fitting or not, as multi-start results are (else every run is listed as a local minimum)
    return classify(GlobalSearchResult(best, solutions, results, starts, names, runs, len(ok), seed, method, infos))
