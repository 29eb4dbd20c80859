r"""Convergence diagnostics of Markov chains: integrated autocorrelation time, effective sample
size and the rank-normalised split :math:`\hat R`.

* :func:`integrated_time` — the integrated autocorrelation time τ of an ensemble's chains: the
  normalised autocorrelation function of each walker's chain (by FFT), averaged over the walkers,
  summed up to Sokal's automatic window (the smallest M with M ≥ c τ(M), c = 5) — the estimator
  the ensemble samplers' authors recommend (Goodman & Weare 2010; Foreman-Mackey et al. 2013).
  A chain shorter than about 50 τ gives an unreliable τ (:func:`integrated_time` says so).
* :func:`effective_sample_size` — N / τ over all draws of all ensembles.
* :func:`split_rhat` — Vehtari, Gelman, Simpson, Carpenter & Bürkner (2021): every chain split in
  halves, the draws replaced by their normal scores (ranks), the potential scale reduction of the
  bulk and of the folded draws ``|θ − median|``, the larger of the two.  Values above
  :data:`RHAT_LIMIT` = 1.01 say the chains have not mixed (e.g. walkers left in different modes).

Plain NumPy (and SciPy's normal quantile); used by the samplers of :mod:`femupdate.bayes` and
independent of them.
"""

from __future__ import annotations

import math

import numpy as np

#: above this split R-hat the chains are taken as not mixed (Vehtari et al. 2021)
RHAT_LIMIT = 1.01
#: below this effective sample size the posterior summaries are too noisy to report without a warning
MIN_ESS = 400
#: a chain should be at least this many autocorrelation times long for τ to be reliable
TAU_FACTOR = 50
#: Sokal's window constant
WINDOW_C = 5.0


def autocorrelation(x: np.ndarray) -> np.ndarray:
    """Normalised autocorrelation function of a 1-D series (FFT; lag 0 = 1; a constant series
    gives zeros after lag 0)."""
    x = np.asarray(x, float)
    n = x.size
    size = 1 << int(2 * n - 1).bit_length()
    d = x - x.mean()
    f = np.fft.rfft(d, n=size)
    acf = np.fft.irfft(f * np.conjugate(f), n=size)[:n]
    if acf[0] <= 0:
        out = np.zeros(n)
        out[0] = 1.0
        return out
    return acf / acf[0]


def integrated_time(chain: np.ndarray, c: float = WINDOW_C) -> tuple[float, bool]:
    """Integrated autocorrelation time of one quantity sampled by an ensemble.

    Parameters
    ----------
    chain : array_like, shape ``(n_steps, n_walkers)``
        The draws, one column per walker.
    c : float, default 5
        Sokal's window constant.

    Returns
    -------
    tau : float
        τ ≥ 1 (in steps).
    reliable : bool
        The chain is at least :data:`TAU_FACTOR` τ long.
    """
    chain = np.asarray(chain, float)
    if chain.ndim == 1:
        chain = chain[:, None]
    n = chain.shape[0]
    if n < 2:
        return math.inf, False
    f = np.mean([autocorrelation(chain[:, k]) for k in range(chain.shape[1])], axis=0)
    taus = 2.0 * np.cumsum(f) - 1.0
    window = np.arange(taus.size) < c * taus
    M = int(np.argmin(window)) if not window.all() else taus.size - 1
    tau = max(float(taus[M]), 1.0)
    return tau, bool(n >= TAU_FACTOR * tau)


def effective_sample_size(chains: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Effective sample size of each parameter over every ensemble's chains.

    Parameters
    ----------
    chains : array_like, shape ``(n_ensembles, n_steps, n_walkers, L)``
        The draws after burn-in.

    Returns
    -------
    ess : numpy.ndarray, shape ``(L,)``
        N / τ with N all draws and τ the mean over the ensembles of :func:`integrated_time`.
    tau : numpy.ndarray, shape ``(L,)``
        That τ, in steps.
    reliable : numpy.ndarray of bool, shape ``(L,)``
        Every ensemble's chain is long enough for its τ (:data:`TAU_FACTOR`).
    """
    chains = np.asarray(chains, float)
    E, n, W, L = chains.shape
    tau = np.empty(L)
    ok = np.ones(L, bool)
    for j in range(L):
        ts = [integrated_time(chains[e, :, :, j]) for e in range(E)]
        tau[j] = float(np.mean([t for t, _ in ts]))
        ok[j] = all(r for _, r in ts)
    return E * n * W / tau, tau, ok


def _rhat(x: np.ndarray) -> float:
    """Potential scale reduction of draws (n, C) (one column per chain)."""
    n, C = x.shape
    if n < 2 or C < 2:
        return math.nan
    means = x.mean(axis=0)
    W = float(np.mean(x.var(axis=0, ddof=1)))
    B = n * float(np.var(means, ddof=1))
    if W <= 0:
        return 1.0 if B <= 0 else math.inf
    var = (n - 1) / n * W + B / n
    return math.sqrt(var / W)


def _normal_scores(x: np.ndarray) -> np.ndarray:
    from scipy.special import ndtri
    from scipy.stats import rankdata

    r = rankdata(x, method="average").reshape(x.shape)
    return ndtri((r - 0.375) / (x.size + 0.25))


def split_rhat(chains: np.ndarray) -> float:
    """Rank-normalised split R̂ of one quantity (Vehtari et al. 2021).

    Parameters
    ----------
    chains : array_like, shape ``(n_steps, n_chains)``

    Returns
    -------
    float
        max(R̂ of the normal scores, R̂ of the folded normal scores); NaN with fewer than 4 steps.
    """
    x = np.asarray(chains, float)
    n = x.shape[0] // 2
    if n < 2:
        return math.nan
    halves = np.concatenate([x[:n], x[x.shape[0] - n:]], axis=1)
    bulk = _rhat(_normal_scores(halves))
    folded = _rhat(_normal_scores(np.abs(halves - np.median(halves))))
    return float(max(bulk, folded))


__all__ = ["autocorrelation", "integrated_time", "effective_sample_size", "split_rhat", "RHAT_LIMIT", "MIN_ESS",
           "TAU_FACTOR"]
