"""The Bayesian updating verb: :func:`posterior` — the Laplace approximation at each solution, the
ensemble MCMC sampler or TMCMC, with the summaries, diagnostics and predictions of
:class:`~femupdate.bayes.results.PosteriorResult`."""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Callable, Mapping, Sequence

import numpy as np

from .._budget import announce, block_count, check_count, residual_count, start_bytes
from .._checks import callable_arg, mapping_arg, path_arg, problem_args
from .._errors import InputError
from ..options import (SAMPLER_METHODS, ExecutionOptions, SamplerOptions, StartsOptions, UpdateOptions,
                       gather_some)
from .checkpoint import RunCheckpoint, run_key
from .diagnostics import MIN_ESS, RHAT_LIMIT, effective_sample_size, split_rhat
from .laplace import assign, candidates, laplace_modes, log_evidence, mixture_draws
from .likelihood import Posterior
from .mcmc import run_mcmc, stream
from .record import attach
from .results import PosteriorResult, predictive_summary, summarise
from .tasks import Runner
from .tmcmc import run_tmcmc

log = logging.getLogger(__name__)

#: the three levels of answer
METHODS = SAMPLER_METHODS
#: a solution more probable than this (Laplace) counts as one the ensemble sampler should visit
SEVERAL_SOLUTIONS = 0.01
#: below this acceptance rate of TMCMC's last stage its samples barely move from the resampled points
MIN_ACCEPTANCE = 0.05


def posterior(model, data, *, params: Sequence[str] | None = None, values=None, x0: Mapping | None = None,
              priors: Mapping | None = None, sampler: SamplerOptions | str | None = None,
              starts: StartsOptions | int | None = None, execution: ExecutionOptions | None = None, checkpoint=None,
              progress: Callable[[str, int, int], None] | None = None, options: UpdateOptions | None = None,
              **shorthand) -> PosteriorResult:
    """The posterior of the updated parameters given the test data: how far to trust the updated
    model.

    The likelihood is built on the updating core's residuals (those :func:`femupdate.update`
    minimises, with the same pairing, weights and standard deviations;
    :class:`~femupdate.bayes.likelihood.Posterior`), the priors are the parameters' own (model
    file, :class:`~femupdate.Structure`) or ``priors``.  Every method first looks for the distinct
    solutions by multi-start and gives each its Laplace approximation and probability; then

    * ``"laplace"``: the posterior is that mixture of Gaussians (samples drawn from it);
    * ``"mcmc"``: ``ensembles`` emcee ensembles of ``walkers`` walkers started from it run
      ``steps`` steps (the first ``burn`` discarded), or until every parameter's effective sample
      size reaches ``target_ess``; diagnosed by the effective sample size and split R-hat;
    * ``"tmcmc"``: ``samples`` samples moved from the prior to the posterior (Ching & Chen 2007),
      each stage's chains ``tmcmc_steps`` Metropolis moves long; the log-evidence for comparing
      parametrisations; the one to use when several solutions are probable.

    Parameters
    ----------
    model : Model or DampedModel
        The model (its parameters' bounds and priors).  A
        :class:`~femupdate.damping.DampedModel` (a model file's ``[damping]`` table) puts its
        damping parameters among the unknowns: the likelihood is built on the damped residuals
        its update minimises (complex modes: frequencies, damping ratios, complex shapes; damped
        receptances), evaluated point by point (the local route).
    data : TestData or sequence of TestData
        The test data; several sets are repeated tests whose likelihoods multiply.
    params : sequence of str, optional
        The updated parameters (default: the free ones).
    values : None, mapping of str to float, or array_like, optional
        Values of the fixed parameters (default nominal).
    x0 : mapping of str to float, optional
        The reference values of the updated parameters (the parametrisation's scale, and the
        start of the search for solutions with one start; default nominal).
    priors : mapping, optional
        {name: prior} replacing the model's (:mod:`femupdate.priors`: ``"normal(8, 1)"``, ...).
    sampler : SamplerOptions or str, optional
        The method and its settings (:class:`~femupdate.options.SamplerOptions`; a string is the
        method: ``"laplace"``, ``"mcmc"`` or ``"tmcmc"``).
    starts : StartsOptions or int, optional
        The search for solutions (:class:`~femupdate.options.StartsOptions`: random starts — 20
        by default, 1: one update from the nominal values —, ``rel_tol`` under which two
        solutions are one, and ``seed``, the seed of every random stream of the run: None draws
        a fresh one, recorded in the result).
    execution : ExecutionOptions, optional
        A Dask scheduler for the multi-start, MCMC ensembles and TMCMC chunks (with the samples
        of a local run), and the compiled route's ``threads``
        (:class:`~femupdate.options.ExecutionOptions`).
    checkpoint : str or os.PathLike, optional
        A file keeping the sampler's state after each MCMC segment or TMCMC stage; an existing
        one of the same run is resumed.
    progress : callable ``(phase, done, total)``, optional
        Called as the work advances (phases ``"solutions"``, ``"mcmc"``, ``"tmcmc"``).
    options : UpdateOptions, optional
        The updating problem whose residuals make the likelihood, as :func:`femupdate.update`
        takes it; its ``noise.basis`` (shorthand ``noise=``) says whether the standard deviations
        are the stated ones (``"stated"``), a noise scale estimated under Jeffreys' prior and
        integrated out (``"estimate"``), or ``"auto"``: stated when every residual has one.
    **shorthand
        Fields of any of those option objects as keywords (``method="tmcmc"``, ``samples=2000``,
        ``seed=3``, ``noise="estimate"``, ``min_mac=0.8``, ...).

    Returns
    -------
    PosteriorResult
        With its context (the model and the first data set): ``to_json()`` and
        ``write_report(path)`` give the JSON and report of ``femupdate posterior``.

    Raises
    ------
    InputError
        Bad options, data or priors (named); ``"mcmc"`` without emcee; ``"tmcmc"`` with an
        improper prior; a checkpoint of another run; samples, predictive draws, MCMC chains or
        starts beyond the available memory (the estimate named, before the run).
    TypeError
        An argument of the wrong type (named).
    NumericalError
        No solution found; no mode with a positive definite Hessian; TMCMC without end.
    """
    t0 = time.perf_counter()
    _door(model, data, params, x0, values, priors, progress, checkpoint)
    given, rest = gather_some("posterior", shorthand, sampler=(SamplerOptions, sampler),
                              starts=(StartsOptions, starts), execution=(ExecutionOptions, execution))
    so, st, ex = given["sampler"], given["starts"], given["execution"]
    _no_alpha(st)
    uo = UpdateOptions.of("posterior", rest, options=options)
    method, samples, ensembles, steps, burn = so.method, so.samples, so.ensembles, so.steps, so.burn
    segment, target_ess, tmcmc_steps, target_cov, chunks = so.segment, so.target_ess, so.tmcmc_steps, so.target_cov, so.chunks
    level, predictive = so.level, so.predictive
    starts_n, seed, rel_tol = st.starts, st.seed, st.rel_tol
    scheduler, connect_timeout = ex.scheduler, ex.connect_timeout
    entropy = _entropy(seed)
    post = Posterior(model, data, params, priors=priors, values=values, x0=x0, route=so.route, threads=ex.threads,
                     options=uo)
    L = post.L
    # the compiled route evaluates a half-ensemble at once: more walkers cost little more per step
    walkers = so.walkers if so.walkers is not None else (max(64, 8 * L) if post.route == "compiled" else max(32, 4 * L))
    so.bound(L, walkers)
    check_count("starts", starts_n, start_bytes(residual_count(data), L, blocks=block_count(data)), "the starts' records")
    if burn is None and target_ess is None:
        burn = steps // 4
    if method == "tmcmc" and post.improper:
        post.sample_prior(np.random.default_rng(0), 1)  # refuses, naming the parameters
    key = run_key(model, post.sets, {k: v for k, v in post.definition.items() if k != "route"}, post.route,
                  _settings(so, st, walkers, burn), entropy)
    ckpt = RunCheckpoint(checkpoint, key, {"method": method, "model": model.name, "parameters": list(post.names)})

    def tell(phase):
        return (lambda done, total: progress(phase, done, total)) if progress else None

    runner = None
    try:
        points, notes = candidates(post, starts_n, seed, tell("solutions"), scheduler, connect_timeout)
        from .noise import calibrate

        calibrate(post, points[0][0])  # the relative weights of kinds that share a noise scale (REML)
        t_modes, n_modes = time.perf_counter(), post.evaluations
        modes, more = laplace_modes(post, points, np.random.Generator(np.random.PCG64(stream(entropy, 0))), rel_tol)
        _announce_sampling(so, walkers, time.perf_counter() - t_modes, post.evaluations - n_modes)
        notes = list(post.notes) + notes + more
        warnings: list[str] = []
        diag: dict = {}
        chain_p = None
        rng = np.random.Generator(np.random.PCG64(stream(entropy, 6)))
        if method == "laplace":
            X, _ = mixture_draws(post, modes, samples, rng)
            ll = np.full(X.shape[0], np.nan)
            fractions = [m.probability for m in modes]
            logz, logz_err = log_evidence(modes), math.nan
            success = True
        else:
            runner = Runner(post, key, scheduler, connect_timeout)
            t_sample = time.perf_counter()
            if method == "mcmc":
                out = run_mcmc(post, runner, modes, walkers=walkers, ensembles=ensembles, steps=steps, burn=burn,
                               segment=segment, target_ess=target_ess, entropy=entropy, checkpoint=ckpt,
                               progress=tell("mcmc"))
                chain = out["chain"]
                burn = out["burn"]
                chain_p = post.to_p(chain.reshape(-1, L)).reshape(chain.shape)
                kept = chain_p[:, burn:]
                X = chain[:, burn:].reshape(-1, L)
                ll = out["log_like"][:, burn:].reshape(-1)
                diag, warnings, success = _mcmc_diagnostics(post, kept, out, walkers, ensembles, burn, modes)
                diag["mcmc_seconds"] = time.perf_counter() - t_sample
                logz, logz_err = math.nan, math.nan
            else:
                out = run_tmcmc(post, runner, samples=samples, steps=tmcmc_steps, target_cov=target_cov, chunks=chunks,
                                entropy=entropy, checkpoint=ckpt, progress=tell("tmcmc"))
                X, ll = out["x"], out["log_like"]
                diag, warnings, success = _tmcmc_diagnostics(out, samples)
                diag["tmcmc_seconds"] = time.perf_counter() - t_sample
                logz, logz_err = out["log_evidence"], out["log_evidence_error"]
            near = assign(modes, X)
            fractions = [float(np.mean(near == k)) for k in range(len(modes))]
        P = post.to_p(X)
        stats = summarise(P, level)
        noise_info, pred = _noise_and_predictions(post, X, level, predictive, rng)
        from .noise import fit_check

        noise_info["model_error"] = fit_check(post, modes[0].x) or None  # at the most probable mode
        diag.update(evaluations=post.evaluations, failures=dict(post.failures))
        notes += _failure_notes(post)
        names = post.names
        prior = {n: _describe(post, j) for j, n in enumerate(names)}
        return attach(PosteriorResult(
            method=method, names=tuple(names), samples=P, log_likelihood=ll,
            mean=dict(zip(names, map(float, stats["mean"]))), median=dict(zip(names, map(float, stats["median"]))),
            std=dict(zip(names, map(float, stats["std"]))),
            interval={n: [float(a), float(b)] for n, (a, b) in zip(names, stats["interval"])}, level=float(level),
            covariance=stats["covariance"], correlation=stats["correlation"], modes=modes, mode_fractions=fractions,
            log_evidence=float(logz), log_evidence_error=float(logz_err), noise=noise_info, predictive=pred,
            diagnostics=diag, success=bool(success), warnings=warnings, notes=notes, route=post.route, seed=entropy,
            seconds=time.perf_counter() - t0, chain=chain_p, prior=prior, data_sets=len(post.sets),
            damping=_damping_record(post)), post.damped or model, data)
    finally:
        if runner is not None:
            runner.close()
        post.close()


def _damping_record(post: Posterior) -> dict | None:
    """A damped model's ``damping``: the damping parameters updated, and those held with their values."""
    view = post.damped
    if view is None:
        return None
    p = view.resolve(post.options["values"])
    return {"parameters": [n for n in post.names if view.is_damping(n)],
            "held": {n: float(p[view.parameter_index(n)]) for n in view.damping_names if n not in post.names}}


def _entropy(seed: int | None) -> int:
    """The run's seed: ``seed``, or a fresh one (recorded in the result) when it is None."""
    fresh = np.random.SeedSequence().entropy
    return int(seed) if seed is not None else int(fresh) if isinstance(fresh, int) else 0


def _failure_notes(post: Posterior) -> list[str]:
    """A note on the likelihood evaluations that failed, if any."""
    if not post.failures:
        return []
    n_fail = sum(post.failures.values())
    top = post.failures.most_common(1)[0][0]
    return [f"{n_fail} of {post.evaluations} likelihood evaluations failed (the model could not be evaluated "
            f"there; the posterior density is taken as zero), e.g. {top}"]


def _door(model, data, params, x0, values, priors, progress, checkpoint) -> None:
    """:func:`posterior`'s arguments by type (:mod:`femupdate._checks`); a damped model
    (:class:`~femupdate.damping.DampedModel`) by its engine view."""
    from ..damping.view import as_view

    view = as_view(model)
    if view is None:
        problem_args("posterior", model, data, params=params, x0=x0, values=values, sets=True)
    else:
        from .._checks import data_arg, params_arg, values_arg, x0_arg

        data_arg(data, "data", "posterior", sets=True)
        params_arg(params, "params", "posterior")
        x0_arg(view, x0, "x0", "posterior")
        values_arg(view, values, "values", "posterior")
    mapping_arg(priors, "priors", "posterior")
    callable_arg(progress, "progress", "posterior")
    if checkpoint is not None:
        path_arg(checkpoint, "checkpoint", "posterior")


def _noise_and_predictions(post: Posterior, X: np.ndarray, level: float, predictive: int,
                           rng: np.random.Generator) -> tuple[dict, dict | None]:
    """The result's ``noise`` (with an estimated scale's posterior) and ``predictive``, at a
    subset of ``predictive`` of the samples X (in the sampler's variables)."""
    sub = rng.choice(X.shape[0], size=min(predictive, X.shape[0]), replace=False) if predictive else np.zeros(0, int)
    Xs = X[np.sort(sub)]
    Qp, _ = post.pool_squares(Xs) if Xs.size else (np.zeros((0, len(post.pools))), [])
    draws = post.noise_scale(Qp, rng)
    noise_info: dict = {"kind": post.noise, "n_residuals": post.n_residuals, "pools": []}
    a = (1 - level) / 2
    for pool in post.pools:
        rec = pool.record()
        s = draws.get(pool.label)
        if s is not None and np.isfinite(s).any():
            s = s[np.isfinite(s)]
            rec["scale"] = {"median": float(np.median(s)), "interval": np.quantile(s, [a, 1 - a]).tolist()}
        noise_info["pools"].append(rec)
    # the scale of the eigenvalues' noise (the frequencies' predictions): their pool's (a damped
    # model's frequencies are in its one "damped modes" block)
    eig = next((p.label for p in post.pools if p.basis == "estimated" and any(
        mb.startswith(("eigenvalue", "dynamic", "damped modes")) for mb in p.members)), None)
    scale = draws.get(eig) if eig is not None else None
    if scale is not None and np.isfinite(scale).any():
        s = scale[np.isfinite(scale)]
        noise_info["scale"] = {"median": float(np.median(s)), "interval": np.quantile(s, [a, 1 - a]).tolist()}
        noise_info["draws"] = int(s.size)
    return noise_info, predictive_summary(post.predict(Xs) if Xs.size else None, scale, level, rng)


def _describe(post: Posterior, j: int) -> str:
    pr = post.priors[j]
    lo, hi = post.lo[j], post.hi[j]
    if pr is None:
        return f"uniform on [{lo:g}, {hi:g}]" if math.isfinite(lo) and math.isfinite(hi) else \
            f"flat (improper) on [{lo:g}, {hi:g}]"
    return f"{pr} on [{lo:g}, {hi:g}]" if pr.kind != "uniform" else f"uniform on [{lo:g}, {hi:g}]"


def _no_alpha(st: StartsOptions) -> None:
    """Refuse a significance level for telling solutions apart: it does not apply to a posterior."""
    if st.alpha != StartsOptions().alpha:
        raise InputError(f"posterior: alpha = {st.alpha:g} does not apply: the mode search keeps every separate minimum "
                         "as a candidate mode (two minima within each other's noise are two peaks of one posterior, "
                         "whose samples say how well the data tell them apart)")


def _settings(so: SamplerOptions, st: StartsOptions, walkers: int, burn) -> dict:
    """What identifies a posterior run's sampling in its checkpoint key (with the walkers and burn-in
    as the run resolved them)."""
    settings = {"method": so.method, "samples": so.samples, "walkers": walkers, "ensembles": so.ensembles,
                "steps": so.steps, "burn": burn, "segment": so.segment, "target_ess": so.target_ess,
                "tmcmc_steps": so.tmcmc_steps, "target_cov": so.target_cov, "chunks": so.chunks,
                "starts": st.starts, "rel_tol": st.rel_tol}
    return settings


def _announce_sampling(so: SamplerOptions, walkers: int, seconds: float, evaluations: int) -> None:
    """Say how long the sampling will take, from the likelihood evaluations of the search for the
    posterior's modes (one point at a time: the compiled route's batches cost less a point)."""
    if evaluations <= 0 or so.method == "laplace":
        return
    per = seconds / evaluations
    basis = (f"{per * 1e3:.3g} ms a likelihood evaluation, measured in the search for the modes; the compiled route "
             "evaluates batches of points and often takes less")
    if so.method == "mcmc":
        n = so.ensembles * walkers * so.steps
        announce(f"MCMC, {so.ensembles} x {walkers} walkers x {so.steps} steps = {n} evaluations", per * n, basis)
    else:
        n = so.samples * so.tmcmc_steps
        announce(f"each TMCMC stage, {so.samples} samples x {so.tmcmc_steps} moves = {n} evaluations (the stages "
                 "number as many as the data need, often 5 to 20)", per * n, basis)


def _mcmc_diagnostics(post: Posterior, kept: np.ndarray, out: dict, walkers: int, ensembles: int, burn: int,
                      modes) -> tuple[dict, list[str], bool]:
    """Effective sample size, autocorrelation time, split R-hat (the ensembles as the chains, each
    split in halves) and acceptance; the warnings when they fail."""
    names = post.names
    E, n, W, L = kept.shape
    warnings: list[str] = []
    if n < 4:
        ess = np.zeros(L)
        tau = np.full(L, np.nan)
        reliable = np.zeros(L, bool)
        rhat = np.full(L, np.nan)
    else:
        ess, tau, reliable = effective_sample_size(kept)
        # the chains R-hat compares are the independent ensembles (all walkers' draws, step after step),
        # each split in halves: their walkers are not independent of one another
        rhat = np.array([split_rhat(kept[:, :, :, j].reshape(E, n * W).T) for j in range(L)])
    acceptance = float(out["accepted"].sum() / (out["steps"] * E * W))
    diag = {"ess": dict(zip(names, map(float, ess))), "tau": dict(zip(names, map(float, tau))),
            "tau_reliable": dict(zip(names, map(bool, reliable))), "rhat": dict(zip(names, map(float, rhat))),
            "acceptance": acceptance, "walkers": walkers, "ensembles": ensembles, "steps": out["steps"], "burn": burn,
            "kept_steps": n, "stopped": out["stopped"], "resumed_steps": out["resumed"],
            "limits": {"rhat": RHAT_LIMIT, "ess": MIN_ESS}}
    bad_r = [f"{nm} ({r:.3f})" for nm, r in zip(names, rhat) if not r <= RHAT_LIMIT]
    if bad_r:
        warnings.append(f"split R-hat above {RHAT_LIMIT} for {', '.join(bad_r)}: the chains have not mixed; run longer "
                        "(--steps) or, with several solutions, use tmcmc")
    bad_e = [f"{nm} ({e:.0f})" for nm, e in zip(names, ess) if not e >= MIN_ESS]
    if bad_e:
        warnings.append(f"effective sample size below {MIN_ESS} for {', '.join(bad_e)}: the summaries are noisy; run "
                        "longer (--steps)")
    short = [nm for nm, ok in zip(names, reliable) if not ok]
    if short and not bad_e:
        warnings.append(f"the chains are shorter than 50 autocorrelation times for {', '.join(short)}: the effective "
                        "sample size is itself uncertain")
    probable = [m for m in modes if m.probability > SEVERAL_SOLUTIONS]
    if len(probable) > 1:
        warnings.append(f"{len(probable)} solutions are probable: the ensemble sampler does not move between separated "
                        "solutions, so its shares of them are those of its start (the Laplace probabilities); use "
                        "tmcmc for their proportions")
    success = not bad_r and not bad_e
    return diag, warnings, success


def _tmcmc_diagnostics(out: dict, samples: int) -> tuple[dict, list[str], bool]:
    """The stages, the last stage's acceptance and distinct resampled points; the warnings."""
    stages = out["stages"]
    last = stages[-1] if stages else {}
    diag = {"stages": stages, "n_stages": len(stages), "acceptance": last.get("acceptance", math.nan),
            "ess": last.get("ess", math.nan), "distinct": last.get("distinct", 0), "samples": samples,
            "resumed_stages": out["resumed"]}
    warnings = []
    success = True
    if last and last["acceptance"] < MIN_ACCEPTANCE:
        success = False
        warnings.append(f"the last stage's Metropolis moves were accepted {last['acceptance']:.1%} of the time (below "
                        f"{MIN_ACCEPTANCE:.0%}): the samples repeat the resampled points; use more --tmcmc-steps or "
                        "samples")
    return diag, warnings, success


__all__ = ["posterior", "METHODS"]
