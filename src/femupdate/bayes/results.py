"""The result of Bayesian updating (:class:`PosteriorResult`) and the summaries of samples."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np

from ..serialise import RunContext, Serialisable
from .laplace import Mode


def summarise(P: np.ndarray, level: float) -> dict:
    """Mean, median, standard deviation, equal-tailed credible interval at ``level``, covariance
    and correlation of equally weighted samples P (S, L)."""
    P = np.asarray(P, float)
    a = (1.0 - level) / 2.0
    cov = np.atleast_2d(np.cov(P, rowvar=False)) if P.shape[0] > 1 else np.full((P.shape[1],) * 2, np.nan)
    sd = np.sqrt(np.clip(np.diag(cov), 0, None))
    with np.errstate(invalid="ignore", divide="ignore"):
        corr = cov / np.outer(sd, sd)
    return {"mean": P.mean(axis=0), "median": np.median(P, axis=0), "std": sd,
            "interval": np.quantile(P, [a, 1.0 - a], axis=0).T, "covariance": cov, "correlation": corr}


def predictive_summary(pred: dict | None, scale: np.ndarray | None, level: float, rng: np.random.Generator) -> dict | None:
    """The posterior predictive of the paired modes: per test mode the model's frequency (mean,
    std, interval) and MAC (mean, interval), and the interval of a new measurement of the
    frequency (the model's, with the measurement noise: relative eigenvalue std times the noise
    scale where it is estimated); of a damped model also the damping ratio (mean, std,
    interval)."""
    if pred is None:
        return None
    F, M, sd = pred["frequencies_hz"], pred["mac"], pred["eigenvalue_std"]
    a = (1.0 - level) / 2.0
    out = []
    for k in range(F.shape[1]):
        f = F[:, k][np.isfinite(F[:, k])]
        entry: dict = {"test_mode": k}
        if f.size:
            s = sd[k] * (scale[np.isfinite(F[:, k])] if scale is not None else 1.0)
            lam_new = (f * 2 * math.pi) ** 2 * (1.0 + s * rng.standard_normal(f.size))
            f_new = np.sqrt(np.clip(lam_new, 0, None)) / (2 * math.pi) if np.all(np.isfinite(s)) else np.full(f.size, np.nan)
            entry.update(frequency_hz={"mean": float(f.mean()), "std": float(f.std()),
                                       "interval": np.quantile(f, [a, 1 - a]).tolist()},
                         measured_frequency_hz={"interval": np.quantile(f_new, [a, 1 - a]).tolist()})
        m = M[:, k][np.isfinite(M[:, k])]
        entry["mac"] = {"mean": float(m.mean()), "interval": np.quantile(m, [a, 1 - a]).tolist()} if m.size else None
        if "damping_ratio" in pred:  # a damped model: the paired complex modes' damping ratios
            z = pred["damping_ratio"][:, k]
            z = z[np.isfinite(z)]
            entry["damping_ratio"] = ({"mean": float(z.mean()), "std": float(z.std()),
                                       "interval": np.quantile(z, [a, 1 - a]).tolist()} if z.size else None)
        out.append(entry)
    return {"modes": out, "draws": int(F.shape[0])}


@dataclass(frozen=True, eq=False)
class PosteriorResult(Serialisable):
    """What Bayesian updating found (:func:`femupdate.posterior`); it writes the JSON and report
    of ``femupdate posterior`` (:mod:`femupdate.serialise`: ``to_json``, ``write_json``,
    ``write_report``; :mod:`femupdate.bayes.record`).

    Attributes
    ----------
    method : str
        ``"laplace"``, ``"mcmc"`` or ``"tmcmc"``.
    names : tuple of str
        The updated parameters.
    samples : numpy.ndarray, shape ``(S, L)``
        Equally weighted posterior samples in parameter units (Laplace: draws of its mixture).
    log_likelihood : numpy.ndarray, shape ``(S,)``
        Each sample's log likelihood (Laplace draws: NaN, not evaluated).
    mean, median, std : dict
        {name: value} of the samples.
    interval : dict
        {name: [lower, upper]}: the equal-tailed credible interval at ``level``.
    level : float
        Its probability (default 0.95).
    covariance, correlation : numpy.ndarray, shape ``(L, L)``
        Of the samples.
    modes : list of Mode
        The distinct solutions with their Laplace approximations and probabilities, most probable
        first (:class:`~femupdate.bayes.laplace.Mode`).
    mode_fractions : list of float
        The share of the samples nearest each mode (Mahalanobis distance under its Laplace
        covariance); for ``"laplace"`` the probabilities themselves.
    log_evidence, log_evidence_error : float
        log p(d) (Laplace approximation, or the TMCMC estimate and its Monte Carlo error; NaN for
        ``"mcmc"``), of the weighted residuals (see :mod:`femupdate.bayes.likelihood`).
    noise : dict
        ``{"kind": "stated" | "estimate", "n_residuals": m}`` and for an estimated scale its
        posterior ``scale`` {``median``, ``interval``}.
    predictive : dict or None
        The paired modes' frequencies and MACs over the posterior (:func:`predictive_summary`).
    diagnostics : dict
        By method: MCMC ``ess``, ``rhat``, ``tau``, ``tau_reliable``, ``acceptance``, ``walkers``,
        ``ensembles``, ``steps``, ``burn``; TMCMC ``stages``, ``ess`` (of the final reweighting),
        ``acceptance``, ``distinct``; all: ``evaluations``, ``failures``.
    success : bool
        The method's checks passed (MCMC: split R-hat and effective sample size; TMCMC: the last
        stage's acceptance and the distinct samples; Laplace: a mode was found).
    warnings, notes : list of str
        What makes the answer doubtful; what the user should know.
    route : str
        ``"compiled"`` or ``"local"`` likelihood evaluations.
    seed : object
        The seed (entropy) of the run's random streams.
    seconds : float
        Wall-clock time.
    chain : numpy.ndarray or None
        MCMC: the chains (E, n, W, L) in parameter units, burn-in included (for trace plots).
    prior : dict
        {name: description} of the priors used.
    data_sets : int
        The test-data sets (repeated tests) whose likelihoods were multiplied.
    damping : dict or None
        A damped model's (:class:`~femupdate.damping.DampedModel`): ``parameters``, the damping
        parameters among the updated ones; ``held``, {name: value} of those held at their values.
    context : RunContext, optional
        The model and the first test data set (:mod:`femupdate.serialise`): the JSON's model
        name, notes and units; the report's measured frequencies.
    """

    kind: ClassVar[str] = "posterior"

    method: str
    names: tuple
    samples: np.ndarray
    log_likelihood: np.ndarray
    mean: dict
    median: dict
    std: dict
    interval: dict
    level: float
    covariance: np.ndarray
    correlation: np.ndarray
    modes: list[Mode]
    mode_fractions: list[float]
    log_evidence: float
    log_evidence_error: float
    noise: dict
    predictive: dict | None
    diagnostics: dict
    success: bool
    warnings: list[str] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    route: str = ""
    seed: object = None
    seconds: float = math.nan
    chain: np.ndarray | None = None
    prior: dict = field(default_factory=dict)
    data_sets: int = 1
    damping: dict | None = None
    context: RunContext | None = field(default=None, compare=False, repr=False)

    def payload(self) -> dict:
        from .record import posterior_kind

        return posterior_kind(self, self.run_context)

    @classmethod
    def from_payload(cls, obj):
        from .record import posterior_from

        return posterior_from(obj)

    def records(self) -> list[dict]:
        """One record per parameter: median, mean, std, the credible interval and the prior
        (:meth:`to_frame`'s rows)."""
        return [{"parameter": n, "median": self.median[n], "mean": self.mean[n], "std": self.std[n],
                 "lower": self.interval[n][0], "upper": self.interval[n][1], "level": self.level,
                 "prior": self.prior.get(n)} for n in self.names]

    def report_images(self) -> dict:
        """The figures of the report that need the samples (:mod:`femupdate.report.posterior`):
        ``corner`` and, for MCMC, ``trace`` (a result read back from JSON has no samples: none)."""
        from ..report.posterior import sample_figures

        return sample_figures(self)

    def __repr__(self) -> str:
        values = ", ".join(f"{n}={self.median[n]:.6g} [{self.interval[n][0]:.4g}, {self.interval[n][1]:.4g}]"
                           for n in self.names)
        return (f"PosteriorResult({self.method}, {len(self.modes)} solution(s), "
                f"{'ok' if self.success else 'DOUBTFUL'}: {values})")

    def summary(self) -> str:
        """A few lines: the parameters' medians and intervals, the solutions and their
        probabilities, the evidence and the warnings."""
        fit = (self.noise or {}).get("model_error") or {}
        lines = [f"posterior by {self.method} ({self.samples.shape[0]} samples, {self.route} likelihood)"
                 + ("; MODEL ERROR: the fit does not reproduce the data within the noise"
                    if fit.get("verdict") == "model error" else "")]
        for n in self.names:
            lo, hi = self.interval[n]
            lines.append(f"  {n}: median {self.median[n]:.6g}, mean {self.mean[n]:.6g}, std {self.std[n]:.3g}, "
                         f"{self.level:.0%} interval [{lo:.6g}, {hi:.6g}]")
        for m, frac in zip(self.modes, self.mode_fractions):
            where = ", ".join(f"{n}={v:.6g}" for n, v in m.parameters.items())
            lines.append(f"  solution ({where}): probability {m.probability:.3f} (Laplace), share of samples {frac:.3f}")
        if math.isfinite(self.log_evidence):
            lines.append(f"  log evidence {self.log_evidence:.4f}"
                         + (f" ± {self.log_evidence_error:.2g}" if math.isfinite(self.log_evidence_error) else ""))
        from .noise import noise_lines

        lines += [f"  {line}" for line in noise_lines(self.noise or {}, self.level)]
        lines += [f"  warning: {w}" for w in self.warnings]
        return "\n".join(lines)


def bayes_factor(a: PosteriorResult, b: PosteriorResult) -> tuple[float, float]:
    """log B_ab = log Z_a − log Z_b of two results on the same data (two parametrisations of a
    model), and its Monte Carlo error (the errors added in quadrature; NaN where unknown)."""
    d = a.log_evidence - b.log_evidence
    e = math.hypot(a.log_evidence_error, b.log_evidence_error) if (
        math.isfinite(a.log_evidence_error) and math.isfinite(b.log_evidence_error)) else math.nan
    return d, e


__all__ = ["PosteriorResult", "summarise", "predictive_summary", "bayes_factor"]
