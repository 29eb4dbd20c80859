"""The options of runs made of many solutions: the starts, where the work runs, and the
posterior's sampler."""

from __future__ import annotations

import dataclasses
from typing import ClassVar

from .._budget import CHAIN_BYTES, SAMPLE_BYTES, START_BYTES, check_count, check_memory, size
from .._errors import InputError
from ._base import Options, choice, count, flag, number
from .choices import LIKELIHOOD_ROUTES, SAMPLER_METHODS


@dataclasses.dataclass(frozen=True, repr=False)
class StartsOptions(Options):
    """Multi-start: random starts within the bounds, distinct solutions told apart
    (:func:`femupdate.multistart`).

    Attributes
    ----------
    starts : int, default 20
        The number of random starts.
    seed : int or None, default 0
        The seed of the starts (None: unreproducible, the seed drawn is recorded).
    log_uniform : bool, default False
        Draw the starts log-uniformly within the bounds (for parameters spanning decades).
    rel_tol : float, default 1e-4
        Relative distance below which two solutions are always the same (round-off of the
        solver), and the rule by which they are told apart where no covariance exists.
    alpha : float, default 0.01
        The significance level at which two solutions are told apart: they are distinct only when
        they differ significantly against their own covariances — the Mahalanobis distance
        d² = Δpᵀ (C_a + C_b)⁺ Δp above the χ² quantile at 1 − ``alpha`` (degrees of freedom the
        rank of C_a + C_b) — or differ beyond ``rel_tol`` along a direction the data do not
        determine (no covariance there: that is non-uniqueness).  One minimum found twice is then
        split with probability about ``alpha``; smaller values split less and merge more
        (:func:`femupdate.distinct.significant`).  Where no solution has a covariance (fewer data
        than parameters plus one, without stated noise) ``rel_tol`` alone decides, and the output
        says so.
    cost_tol : float, optional
        Converged starts whose cost exceeds this are failures (default: no limit).
    batched : bool, optional
        Force (True) or forbid (False) the compiled batched route of small modal models (default:
        chosen by the problem).
    """

    starts: int = 20
    seed: int | None = 0
    log_uniform: bool = False
    rel_tol: float = 1e-4
    alpha: float = 0.01
    cost_tol: float | None = None
    batched: bool | None = None

    main: ClassVar[str | None] = "starts"

    def check(self) -> None:
        self.set("starts", count(self.starts, "starts"))
        check_count("starts", self.starts, START_BYTES, "the starts' records")
        self.set("seed", count(self.seed, "seed", low=0, allow_none=True))
        self.set("log_uniform", flag(self.log_uniform, "log_uniform"))
        self.set("rel_tol", number(self.rel_tol, "rel_tol", low=0.0, low_open=True))
        self.set("alpha", number(self.alpha, "alpha", low=0.0, high=1.0, low_open=True, high_open=True))
        if self.cost_tol is not None:
            self.set("cost_tol", number(self.cost_tol, "cost_tol", low=0.0))
        if self.batched is not None:
            self.set("batched", flag(self.batched, "batched"))


@dataclasses.dataclass(frozen=True, repr=False)
class ExecutionOptions(Options):
    """Where the work runs: this process, local worker processes, or an existing Dask cluster.

    Attributes
    ----------
    scheduler : str, optional
        The address of an existing Dask scheduler (``tcp://host:port``); local otherwise.
    connect_timeout : float, default 10.0
        Seconds to wait for the scheduler.
    jobs : int, optional
        Local worker processes for per-start work of large models (default: one per usable core
        when a start is worth a process; 1: this process).  Not with ``scheduler``.
    threads : int, optional
        Threads of the compiled routes (default: the usable cores).
    """

    scheduler: str | None = None
    connect_timeout: float = 10.0
    jobs: int | None = None
    threads: int | None = None

    def check(self) -> None:
        if self.scheduler is not None and not isinstance(self.scheduler, str):
            raise InputError(f"scheduler must be an address such as 'tcp://host:8786', got {self.scheduler!r}")
        self.set("connect_timeout", number(self.connect_timeout, "connect_timeout", low=0.0, low_open=True))
        self.set("jobs", count(self.jobs, "jobs", high=256, allow_none=True))
        self.set("threads", count(self.threads, "threads", high=1024, allow_none=True))
        if self.jobs is not None and self.scheduler:
            raise InputError(f"jobs={self.jobs} with a scheduler: the work runs on the cluster's workers; give one of "
                             "the two")


@dataclasses.dataclass(frozen=True, repr=False)
class SamplerOptions(Options):
    """How the posterior is explored (:func:`femupdate.posterior`).

    Attributes
    ----------
    method : {"laplace", "mcmc", "tmcmc"}, default ``"laplace"``
        ``"laplace"``: a mixture of Gaussians at the distinct solutions (samples drawn from it);
        ``"mcmc"``: ``ensembles`` emcee ensembles of ``walkers`` walkers started from it run
        ``steps`` steps; ``"tmcmc"``: ``samples`` samples moved from the prior to the posterior
        (Ching & Chen 2007), with the log-evidence — the one to use when several solutions are
        probable.
    samples : int, default 4000
        Laplace draws, or TMCMC's population.
    walkers : int, optional
        MCMC walkers per ensemble, even (default max(64, 8 L) on the compiled route, whose
        likelihood of a half-ensemble costs little more than of one walker; max(32, 4 L) on the
        local route).
    ensembles : int, default 2
        Independent MCMC ensembles (one Dask task each).
    steps : int, default 2000
        MCMC steps per walker.
    burn : int, optional
        MCMC steps discarded (default a quarter: of ``steps``, or with ``target_ess`` of the
        steps done).
    segment : int, default 250
        MCMC steps between checkpoints (and Dask rounds).
    target_ess : float, optional
        Stop MCMC once every parameter's effective sample size reaches this.
    tmcmc_steps : int, default 5
        Metropolis moves per chain and TMCMC stage.
    target_cov : float, default 1.0
        The coefficient of variation of TMCMC's stage weights.
    chunks : int, default 8
        TMCMC's chains in this many pieces (random streams, Dask tasks).
    level : float, default 0.95
        Probability of the credible intervals.
    predictive : int, default 200
        Posterior draws at which the paired modes are predicted (frequencies, MACs).
    route : {"auto", "compiled", "local"}, default ``"auto"``
        How likelihoods are evaluated: ``"auto"`` compiled when the batched route supports the
        model and options (modal data, at most 200 dofs, formulation ``shapes``), else local.
    """

    method: str = "laplace"
    samples: int = 4000
    walkers: int | None = None
    ensembles: int = 2
    steps: int = 2000
    burn: int | None = None
    segment: int = 250
    target_ess: float | None = None
    tmcmc_steps: int = 5
    target_cov: float = 1.0
    chunks: int = 8
    level: float = 0.95
    predictive: int = 200
    route: str = "auto"

    main: ClassVar[str | None] = "method"

    def check(self) -> None:
        choice(self.method, SAMPLER_METHODS, "method")
        choice(self.route, LIKELIHOOD_ROUTES, "route")
        for name, low in (("samples", 2), ("ensembles", 1), ("steps", 2), ("segment", 1), ("tmcmc_steps", 1),
                          ("chunks", 1), ("predictive", 0)):
            self.set(name, count(getattr(self, name), name, low=low))
        self.set("walkers", count(self.walkers, "walkers", low=2, allow_none=True))
        self.set("burn", count(self.burn, "burn", low=0, allow_none=True))
        if self.walkers is not None and self.walkers % 2:
            raise InputError(f"walkers={self.walkers}: the ensemble sampler needs an even number of walkers")
        if self.method != "mcmc":  # options of the chains only, said rather than ignored
            given = [n for n in ("walkers", "burn", "target_ess") if getattr(self, n) is not None]
            if given:
                raise InputError(f"{given[0]}={getattr(self, given[0])} applies to method=mcmc only, not "
                                 f"method={self.method}")
        self.bound()
        self.set("level", number(self.level, "level", low=0.0, high=1.0, low_open=True, high_open=True))
        self.set("target_cov", number(self.target_cov, "target_cov", low=0.0, low_open=True))
        if self.target_ess is not None:
            self.set("target_ess", number(self.target_ess, "target_ess", low=0.0, low_open=True))
        if self.method == "mcmc" and self.burn is not None and self.burn >= self.steps:
            raise InputError(f"burn ({self.burn}) must be smaller than steps ({self.steps})")

    def bound(self, n_params: int = 1, walkers: int | None = None) -> None:
        """Refuse counts whose samples or chains (of ``n_params`` parameters, ``walkers`` walkers;
        when the options are made: one parameter and the least default of walkers, 32) would
        exceed the available memory (:mod:`femupdate._budget`)."""
        check_count("samples", self.samples, SAMPLE_BYTES * n_params, "the samples")
        check_count("predictive", self.predictive, SAMPLE_BYTES * n_params, "the predictive draws")
        if self.method == "mcmc":
            walkers = walkers if walkers is not None else self.walkers if self.walkers is not None else 32
            check_memory(f"ensembles={self.ensembles}, walkers={walkers}, steps={self.steps}",
                         float(self.ensembles) * walkers * self.steps * CHAIN_BYTES * n_params,
                         f"the MCMC chains ({size(CHAIN_BYTES * n_params)} a walker and step)")


__all__ = ["StartsOptions", "ExecutionOptions", "SamplerOptions"]
