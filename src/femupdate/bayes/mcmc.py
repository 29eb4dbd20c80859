"""The ensemble MCMC level: emcee's affine-invariant stretch move (Goodman & Weare 2010,
Foreman-Mackey et al. 2013), several independent ensembles, the likelihood of all of an
ensemble's proposals evaluated at once.

emcee is an optional dependency (``pip install 'femupdate[bayes]'``), imported here only.  Each
ensemble starts from draws of the Laplace mixture (:mod:`.laplace`) and runs in segments; a
segment is a pure function of the ensemble's state and a random stream derived from the seed,
the ensemble and the segment number (:mod:`.tasks`), so the ensembles may run on a Dask cluster
with the same samples as here, and a checkpoint after each round of segments resumes the run
exactly.  An ensemble's walkers do not move between well-separated solutions: with several
probable solutions the proportions of the walkers in each are those of the start (the Laplace
probabilities), and TMCMC (:mod:`.tmcmc`) is the method to use.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from .._errors import InputError
from .checkpoint import RunCheckpoint
from .diagnostics import effective_sample_size
from .laplace import Mode, mixture_draws
from .likelihood import Posterior
from .tasks import Runner


def _emcee():
    try:
        import emcee
    except ImportError:
        raise InputError("method 'mcmc' needs emcee: pip install 'femupdate[bayes]' (or pip install emcee); "
                         "methods 'laplace' and 'tmcmc' need nothing more") from None
    return emcee


def stream(entropy, *words) -> np.random.SeedSequence:
    """The random stream of a piece of work: ``SeedSequence(entropy, spawn_key=words)``."""
    return np.random.SeedSequence(entropy, spawn_key=tuple(int(w) for w in words))


def ensemble_segment(post: Posterior, coords, log_post, log_like, entropy, ensemble: int, segment: int,
                     n_steps: int) -> dict:
    """``n_steps`` stretch moves of one ensemble from its state (coords (W, L), their log
    posterior and log likelihood (W,)); the chain, log densities and acceptances of the segment."""
    emcee = _emcee()
    W, L = coords.shape

    interrupted: list[BaseException] = []

    def fn(X):
        # emcee prints a traceback for any exception of the log density before passing it on: an
        # interrupt (Ctrl-C, SIGTERM) is kept here and raised again outside emcee, after the step
        if interrupted:
            return np.full((len(X), 2), -np.inf)
        try:
            lp, ll = post.log_posterior(X, with_likelihood=True)
        except KeyboardInterrupt as exc:
            interrupted.append(exc)
            return np.full((len(X), 2), -np.inf)
        return np.column_stack([lp, ll])

    rs = np.random.RandomState(np.random.MT19937(stream(entropy, 2, ensemble, segment)))
    sampler = emcee.EnsembleSampler(W, L, fn, vectorize=True)
    state = emcee.State(np.array(coords, float), log_prob=np.array(log_post, float),
                        blobs=np.array(log_like, float), random_state=rs.get_state())
    for _ in sampler.sample(state, iterations=n_steps, progress=False, skip_initial_state_check=True):
        if interrupted:
            raise interrupted[0]
    return {"chain": sampler.get_chain(), "log_post": sampler.get_log_prob(),
            "log_like": np.asarray(sampler.get_blobs(), float).reshape(n_steps, W), "accepted": np.asarray(sampler.backend.accepted, np.int64)}


def start_ensembles(post: Posterior, modes: list[Mode], ensembles: int, walkers: int, entropy) -> tuple:
    """Each ensemble's walkers drawn from the Laplace mixture (a stream per ensemble), and their log
    densities."""
    coords = np.empty((ensembles, walkers, post.L))
    lp = np.empty((ensembles, walkers))
    ll = np.empty((ensembles, walkers))
    for e in range(ensembles):
        rng = np.random.Generator(np.random.PCG64(stream(entropy, 1, e)))
        coords[e], _ = mixture_draws(post, modes, walkers, rng)
        lp[e], ll[e] = post.log_posterior(coords[e], with_likelihood=True)
        bad = ~np.isfinite(lp[e])
        for _ in range(20):
            if not bad.any():
                break
            redraw, _ = mixture_draws(post, modes, int(bad.sum()), rng)
            coords[e, bad] = redraw
            lp[e, bad], ll[e, bad] = post.log_posterior(redraw, with_likelihood=True)
            bad = ~np.isfinite(lp[e])
        if bad.any():
            raise InputError("the ensemble cannot be started: the model cannot be evaluated at the Laplace "
                             "approximation's draws (see the failures)")
    return coords, lp, ll


def run_mcmc(post: Posterior, runner: Runner, modes: list[Mode], *, walkers: int, ensembles: int, steps: int,
             burn: int | None, segment: int, target_ess: float | None, entropy, checkpoint: RunCheckpoint,
             progress: Callable[[int, int], None] | None = None) -> dict:
    """Run ``ensembles`` ensembles of ``walkers`` walkers for up to ``steps`` steps each (or until
    every parameter's effective sample size after the burn-in reaches ``target_ess``, checked after
    each segment; ``burn`` None: a quarter of the steps done).

    Returns
    -------
    dict
        ``chain`` (E, n, W, L) in the variables x, ``log_post`` and ``log_like`` (E, n, W),
        ``accepted`` (E, W) over all steps, ``steps`` done, ``burn`` used, ``resumed`` (the steps
        read from the checkpoint), ``stopped`` (why the run ended).
    """
    _emcee()
    L = post.L
    if walkers < 2 * L or walkers % 2:
        raise InputError(f"walkers: the ensemble sampler needs an even number of at least 2 L = {2 * L} walkers, "
                         f"got {walkers}")
    E = ensembles
    saved = checkpoint.load()
    if saved is not None:
        arrays, meta = saved
        chain, lpost, llike, acc = (arrays[k] for k in ("chain", "log_post", "log_like", "accepted"))
        if chain.shape[0] != E or chain.shape[2:] != (walkers, L):
            raise InputError(f"checkpoint {checkpoint.path}: its chains do not have this run's shape")
        n_seg = int(meta["state"]["segments"])
        coords, lp, ll = chain[:, -1], lpost[:, -1], llike[:, -1]
    else:
        coords, lp, ll = start_ensembles(post, modes, E, walkers, entropy)
        chain = np.zeros((E, 0, walkers, L))
        lpost = np.zeros((E, 0, walkers))
        llike = np.zeros((E, 0, walkers))
        acc = np.zeros((E, walkers), np.int64)
        n_seg = 0
    resumed = chain.shape[1]
    stopped = "steps"
    if progress:
        progress(chain.shape[1] * E, steps * E)
    def reached() -> bool:
        b = chain.shape[1] // 4 if burn is None else burn
        return bool(target_ess) and chain.shape[1] > b and _ess(post, chain[:, b:]) >= float(target_ess or 0)

    while chain.shape[1] < steps:
        if reached():
            stopped = "target_ess"
            break
        n = min(segment, steps - chain.shape[1])
        parts = runner.map(ensemble_segment, [(coords[e], lp[e], ll[e], entropy, e, n_seg, n) for e in range(E)])
        chain = np.concatenate([chain, np.stack([p["chain"].astype(float) for p in parts])], axis=1)
        lpost = np.concatenate([lpost, np.stack([p["log_post"] for p in parts])], axis=1)
        llike = np.concatenate([llike, np.stack([p["log_like"] for p in parts])], axis=1)
        acc = acc + np.stack([p["accepted"] for p in parts])
        coords, lp, ll = chain[:, -1], lpost[:, -1], llike[:, -1]
        n_seg += 1
        checkpoint.save({"chain": chain, "log_post": lpost, "log_like": llike, "accepted": acc},
                        {"method": "mcmc", "segments": n_seg, "steps": int(chain.shape[1])})
        if progress:
            progress(chain.shape[1] * E, steps * E)
    if stopped == "steps" and reached():
        stopped = "target_ess"
    return {"chain": chain, "log_post": lpost, "log_like": llike, "accepted": acc, "steps": int(chain.shape[1]),
            "burn": chain.shape[1] // 4 if burn is None else burn, "resumed": int(resumed), "stopped": stopped}


def _ess(post: Posterior, chain: np.ndarray) -> float:
    """The smallest effective sample size over the parameters of chains (E, n, W, L) in x."""
    if chain.shape[1] < 4:
        return 0.0
    P = post.to_p(chain.reshape(-1, post.L)).reshape(chain.shape)
    ess, _, _ = effective_sample_size(P)
    return float(np.min(ess)) if ess.size else math.inf


__all__ = ["run_mcmc", "ensemble_segment", "start_ensembles", "stream"]
