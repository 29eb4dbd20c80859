r"""Transitional Markov chain Monte Carlo (TMCMC; Ching & Chen 2007): samples of a posterior with
several separated solutions, and the log-evidence.

The population moves from the prior to the posterior through tempered densities
:math:`p_j(\theta) \propto \pi(\theta)\,L(\theta)^{\beta_j}`, 0 = β₀ < β₁ < … < β_J = 1:

1. N samples are drawn from the prior (β₀ = 0) and their likelihoods evaluated.
2. The next exponent is the one at which the weights :math:`w_i = L(\theta_i)^{\beta_{j+1}-\beta_j}`
   have a coefficient of variation of ``target_cov`` (1: Ching & Chen's choice), found by
   bisection, or 1 when the weights at β = 1 vary less.
3. :math:`S_j = \overline{w}` multiplies the evidence estimate:
   :math:`\log Z = \sum_j \log S_j` (unbiased stage by stage for exact samples of p_j).
4. The population is resampled in proportion to the weights (systematic resampling) and each
   resampled point starts a Metropolis chain of ``steps`` moves that leaves :math:`p_{j+1}`
   invariant, proposing Gaussian steps with the weighted sample covariance times c².  c starts at
   2.4/√L (the optimal scaling of a random walk on a Gaussian target) and after each stage is
   multiplied by exp(2 (a − 0.234)), a the stage's acceptance rate, pushing it toward 0.234.

Separated solutions are kept in proportion to their posterior mass: the reweighting carries the
mass from one stage to the next, and the chains need not cross between solutions.  The chains are
split into ``chunks`` pieces with random streams derived from the seed, the stage and the piece,
run here or as Dask tasks (:mod:`.tasks`) with the same samples; a checkpoint after each stage
resumes the run exactly.

The log-evidence's Monte Carlo error is reported as :math:`\big(\sum_j \mathrm{cov}_j^2 / N\big)^{1/2}`
(the stages' weight variation, as if the samples were independent — a lower bound).
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from .._errors import InputError, NumericalError
from .checkpoint import RunCheckpoint, finite
from .likelihood import Posterior
from .mcmc import stream
from .tasks import Runner

#: the acceptance rate the proposal scale is tuned toward (Roberts, Gelman & Gilks 1997)
TARGET_ACCEPTANCE = 0.234


def log_likelihoods(post: Posterior, X) -> np.ndarray:
    """The log likelihoods of the points X (a Dask task of stage 0)."""
    return post.log_likelihood(X)


def next_beta(ll: np.ndarray, beta: float, target_cov: float) -> float:
    """The next tempering exponent: the weights L^(β' − β) have a coefficient of variation of
    ``target_cov`` (bisection on β' − β), or β' = 1 when they vary less than that at 1."""
    ok = np.isfinite(ll)
    if not ok.any():
        raise NumericalError("TMCMC: the likelihood is zero at every sample")
    d = ll[ok] - np.max(ll[ok])
    n = ll.size

    def cov(delta):
        w = np.exp(delta * d)
        s = w.sum() / n
        return math.sqrt(max(float(np.sum(w * w)) / n - s * s, 0.0)) / s

    top = 1.0 - beta
    if cov(top) <= target_cov:
        return 1.0
    lo, hi = 0.0, top
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if cov(mid) > target_cov:
            hi = mid
        else:
            lo = mid
        if hi - lo <= 1e-14 * max(hi, 1e-300):
            break
    return beta + max(lo, 1e-300)


def systematic(weights: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """Systematic resampling: N indices in proportion to ``weights`` (sorted)."""
    n = weights.size
    c = np.cumsum(weights / weights.sum())
    c[-1] = 1.0
    u = (rng.random() + np.arange(n)) / n
    return np.searchsorted(c, u, side="right").clip(0, n - 1)


def mh_chunk(post: Posterior, X, lprior, ll, beta: float, chol, n_steps: int, entropy, stage: int,
             chunk: int) -> dict:
    """``n_steps`` Metropolis moves of each chain of a chunk (X (n, L) and its log prior and log
    likelihood) under π L^β, with Gaussian proposals of Cholesky factor ``chol``."""
    rng = np.random.Generator(np.random.PCG64(stream(entropy, 4, stage, chunk)))
    X, lprior, ll = np.array(X, float), np.array(lprior, float), np.array(ll, float)
    n, L = X.shape
    accepted = 0
    for _ in range(n_steps):
        Y = X + rng.standard_normal((n, L)) @ chol.T
        lp_y = post.log_prior(Y)
        ll_y = np.full(n, -np.inf)
        ok = np.isfinite(lp_y)
        if ok.any():
            ll_y[ok] = post.log_likelihood(Y[ok])
        with np.errstate(invalid="ignore"):
            log_ratio = (lp_y - lprior) + beta * (ll_y - ll)
        u = rng.random(n)
        take = np.isfinite(lp_y) & np.isfinite(ll_y) & (np.log(u) < np.where(np.isnan(log_ratio), -np.inf, log_ratio))
        X[take], lprior[take], ll[take] = Y[take], lp_y[take], ll_y[take]
        accepted += int(take.sum())
    return {"x": X, "log_prior": lprior, "log_like": ll, "accepted": accepted}


def _chol(C: np.ndarray) -> np.ndarray:
    """A Cholesky factor of the covariance C, made positive definite when it is not."""
    C = 0.5 * (C + C.T)
    try:
        return np.linalg.cholesky(C)
    except np.linalg.LinAlgError:
        w, V = np.linalg.eigh(C)
        w = np.maximum(w, max(float(w.max()), 1e-300) * 1e-12)
        return np.linalg.cholesky((V * w) @ V.T)


def run_tmcmc(post: Posterior, runner: Runner, *, samples: int, steps: int, target_cov: float, chunks: int,
              entropy, checkpoint: RunCheckpoint, progress: Callable[[int, int], None] | None = None,
              max_stages: int = 200) -> dict:
    """Run TMCMC with ``samples`` samples, ``steps`` Metropolis moves per chain and stage.

    Returns
    -------
    dict
        ``x`` (N, L) the final samples in the variables x, ``log_like`` (N,), ``log_evidence``,
        ``log_evidence_error``, ``stages`` (per stage: ``beta``, ``cov``, ``log_S``, ``acceptance``,
        ``scale``, ``ess`` (the Kish effective size of its weights), ``distinct`` (distinct resampled
        points), ``mean``/``std`` of the parameters after it), ``resumed`` (stages read from the
        checkpoint).

    Raises
    ------
    InputError
        A parameter with an improper prior; too few samples.
    NumericalError
        The likelihood is zero at every sample; more than ``max_stages`` stages.
    """
    L = post.L
    N = int(samples)
    if N < max(10, 2 * L):
        raise InputError(f"samples: TMCMC needs at least {max(10, 2 * L)} samples, got {N}")
    cuts = np.linspace(0, N, max(1, min(chunks, N)) + 1).astype(int)
    ranges = [(int(a), int(b)) for a, b in zip(cuts[:-1], cuts[1:]) if b > a]
    saved = checkpoint.load()
    if saved is not None:
        arrays, meta = saved
        st = meta["state"]
        X, lprior, ll = arrays["x"], arrays["log_prior"], arrays["log_like"]
        if X.shape != (N, L):
            raise InputError(f"checkpoint {checkpoint.path}: its samples do not have this run's shape")
        beta, log_z, scale = float(st["beta"]), float(st["log_evidence"]), float(st["scale"])
        stages = list(st["stages"])
    else:
        rng = np.random.Generator(np.random.PCG64(stream(entropy, 3, 0)))
        X = post.sample_prior(rng, N)
        lprior = post.log_prior(X)
        ll = np.concatenate(runner.map(log_likelihoods, [(X[a:b],) for a, b in ranges]))
        beta, log_z, scale = 0.0, 0.0, 2.4 / math.sqrt(L)
        stages = []
    resumed = len(stages)
    while beta < 1.0:
        j = len(stages) + 1
        if j > max_stages:
            raise NumericalError(f"TMCMC did not reach the posterior in {max_stages} stages (the likelihood is very "
                                 "concentrated): use more samples, or state wider standard deviations")
        if progress:
            progress(int(round(1000 * beta)), 1000)
        new = next_beta(ll, beta, target_cov)
        d = new - beta
        ok = np.isfinite(ll)
        top = float(np.max(ll[ok]))
        w = np.where(ok, np.exp(d * (np.where(ok, ll, top) - top)), 0.0)
        mean_w = float(w.mean())
        log_s = math.log(mean_w) + d * top
        cov = float(w.std() / mean_w)
        wn = w / w.sum()
        xbar = wn @ X
        C = (X - xbar).T @ ((X - xbar) * wn[:, None])
        chol = scale * _chol(C)
        rng = np.random.Generator(np.random.PCG64(stream(entropy, 5, j)))
        idx = systematic(wn, rng)
        parts = runner.map(mh_chunk, [(X[idx[a:b]], lprior[idx[a:b]], ll[idx[a:b]], new, chol, steps, entropy, j, k)
                                      for k, (a, b) in enumerate(ranges)])
        X = np.concatenate([p["x"] for p in parts])
        lprior = np.concatenate([p["log_prior"] for p in parts])
        ll = np.concatenate([p["log_like"] for p in parts])
        acc = sum(p["accepted"] for p in parts) / (N * max(steps, 1))
        P = post.to_p(X)
        stages.append({"stage": j, "beta": new, "cov": cov, "log_S": log_s, "acceptance": acc, "scale": scale,
                       "ess": float(1.0 / np.sum(wn * wn)), "distinct": int(np.unique(idx).size),
                       "mean": P.mean(axis=0).tolist(), "std": P.std(axis=0).tolist()})
        log_z += log_s
        beta = new
        scale *= math.exp(2.0 * (acc - TARGET_ACCEPTANCE))
        checkpoint.save({"x": X, "log_prior": lprior, "log_like": ll},
                        {"method": "tmcmc", "beta": beta, "log_evidence": log_z, "scale": scale,
                         "stages": [{k: (finite(v) if isinstance(v, float) else v) for k, v in s.items()}
                                    for s in stages]})
    if progress:
        progress(1000, 1000)
    err = math.sqrt(sum(s["cov"] ** 2 for s in stages) / N)
    return {"x": X, "log_like": ll, "log_evidence": log_z, "log_evidence_error": err, "stages": stages,
            "resumed": resumed}


__all__ = ["run_tmcmc", "next_beta", "systematic", "mh_chunk", "log_likelihoods", "TARGET_ACCEPTANCE"]
