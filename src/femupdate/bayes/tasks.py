"""Pieces of sampler work run where the caller chooses: here, or as tasks on a Dask cluster.

A piece (an MCMC segment of one ensemble, the Metropolis moves of one chunk of TMCMC chains) is a
pure function of the posterior's definition, its state and its random stream, which is derived
from the seed and the piece's numbers; so a run gives the same samples locally and on a cluster.
On a worker the :class:`~femupdate.bayes.likelihood.Posterior` is built once per run (kept under
the run's key) and reused by that run's later pieces.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

from .likelihood import Posterior

#: posteriors built on this process for remote pieces, by run key (the last few runs)
_BUILT: dict[str, Posterior] = {}
_KEEP = 4


def posterior_on_worker(key: str, model, data, options: dict) -> Posterior:
    """The run's posterior on this process (built from its definition the first time)."""
    post = _BUILT.get(key)
    if post is None:
        post = Posterior(model, data, **options)
        _BUILT[key] = post
        while len(_BUILT) > _KEEP:
            old = _BUILT.pop(next(iter(_BUILT)))
            old.close()
    return post


def remote(fn, key: str, model, data, options: dict, *args):
    """``fn(posterior, *args)`` with the run's posterior built (or found) on this process: the
    Dask task of a piece; returns ``(result, evaluations, failures)``."""
    post = posterior_on_worker(key, model, data, options)
    before, failed = post.evaluations, dict(post.failures)
    out = fn(post, *args)
    delta = {m: c - failed.get(m, 0) for m, c in post.failures.items() if c - failed.get(m, 0)}
    return out, post.evaluations - before, delta


class Runner:
    """Runs pieces of a posterior run here, or on the Dask cluster at ``scheduler``.

    Parameters
    ----------
    post : Posterior
        The posterior (used as it is for local pieces).
    key : str
        The run's key (names the posterior on the workers).
    scheduler : str, optional
        A Dask scheduler's address; None: local.
    connect_timeout : float
        Seconds to wait for the scheduler.
    """

    def __init__(self, post: Posterior, key: str, scheduler: str | None = None, connect_timeout: float = 10.0):
        self.post = post
        self.key = key
        self.scheduler = scheduler
        self.timeout = connect_timeout
        self.client = None
        if scheduler:
            from ..dask_cluster import connect

            self.client = connect(scheduler, connect_timeout)
            self._scattered = self.client.scatter([post.model, post.sets], broadcast=True)

    def map(self, fn: Callable, args: Sequence[tuple]) -> list:
        """``[fn(post, *a) for a in args]``, in order — locally, or one Dask task per entry."""
        if self.client is None:
            return [fn(self.post, *a) for a in args]
        from ..dask_cluster import Task, collect

        m_f, d_f = self._scattered
        piece = Task(remote, parallel=False)  # under this process's settings (femupdate.settings)
        futures = {self.client.submit(piece, fn, self.key, m_f, d_f, self.post.definition, *a, pure=False, retries=2): k
                   for k, a in enumerate(args)}
        out: list = [None] * len(args)

        def keep(k, result):
            out[k] = result

        collect(self.client, futures, str(self.scheduler), self.timeout, keep)
        results = []
        for value, n_eval, failures in out:
            self.post.evaluations += n_eval
            self.post.failures.update(failures)
            results.append(value)
        return results

    def close(self) -> None:
        if self.client is not None:
            self.client.close()
            self.client = None


__all__ = ["Runner", "remote", "posterior_on_worker"]
