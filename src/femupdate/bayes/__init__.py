"""Bayesian updating: how far to trust the updated model.

* :func:`posterior` — the posterior of the updated parameters given the test data, at three levels:
  the Laplace approximation at each distinct solution with each solution's probability
  (:mod:`.laplace`), an ensemble MCMC sampler (emcee, :mod:`.mcmc`) and transitional MCMC with
  the log-evidence (:mod:`.tmcmc`); :class:`PosteriorResult` holds the samples, summaries,
  solutions, diagnostics and predictions;
* :class:`Posterior` — the log posterior density itself: the updating core's residuals as a
  Gaussian likelihood (stated standard deviations, or an estimated noise scale) times the
  parameters' priors (:mod:`femupdate.priors`), evaluated on the compiled route for small models;
* :func:`effective_sample_size`, :func:`split_rhat`, :func:`integrated_time` — convergence
  diagnostics of Markov chains; :func:`bayes_factor` compares two results' evidences.
"""

from .diagnostics import MIN_ESS, RHAT_LIMIT, effective_sample_size, integrated_time, split_rhat
from .laplace import Mode
from .likelihood import NOISE, Posterior
from .results import PosteriorResult, bayes_factor, summarise
from .run import METHODS, posterior

__all__ = ["posterior", "PosteriorResult", "Posterior", "Mode", "METHODS", "NOISE", "bayes_factor", "summarise",
           "effective_sample_size", "split_rhat", "integrated_time", "RHAT_LIMIT", "MIN_ESS"]
