"""Figures of Bayesian updating: corner plot of the samples, MCMC traces or TMCMC stages, and the
posterior predictive of the frequencies.

The multi-panel figures (:func:`corner_figure`, :func:`trace_figure`) return their Figure; the
single-panel ones take ``ax=None`` and return the Axes.
"""

from __future__ import annotations

import math

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from .._docs import PLOT_DOCS, shared_docs  # noqa: E402
from .paper_figures import save_figure  # noqa: E402

_MODE_COLOURS = ("#d62728", "#1f77b4", "#2ca02c", "#9467bd", "#ff7f0e", "#8c564b")


def _gauss_mixture_marginal(result, j: int, grid: np.ndarray) -> np.ndarray:
    """The Laplace mixture's marginal density of parameter j on ``grid``."""
    out = np.zeros_like(grid)
    for m in result.modes:
        sd = float(np.sqrt(m.covariance[j, j])) if np.isfinite(m.covariance[j, j]) else math.nan
        if not (sd > 0) or not m.probability > 0:
            continue
        mu = m.parameters[result.names[j]]
        out += m.probability * np.exp(-0.5 * ((grid - mu) / sd) ** 2) / (sd * math.sqrt(2 * math.pi))
    return out


def corner_figure(result, truth: dict | None = None, bins: int = 40, max_points: int = 4000):
    """The samples' marginal histograms (diagonal, with the Laplace mixture's marginal density) and
    pairwise 2-D histograms (below it), the solutions marked.

    Parameters
    ----------
    result : PosteriorResult
    truth : dict, optional
        {name: value} marked as lines (e.g. the values that simulated the data).
    bins : int, default 40
        Histogram bins per parameter.
    max_points : int, default 4000
        Unused samples above this are thinned for the 2-D panels' scatter of the solutions.

    Returns
    -------
    matplotlib.figure.Figure
    """
    names = list(result.names)
    L = len(names)
    P = np.asarray(result.samples)
    size = min(2.2 * L, 14.0)
    fig, axes = plt.subplots(L, L, figsize=(size + 1, size + 1), squeeze=False)
    lims = []
    for j in range(L):
        lo, hi = np.quantile(P[:, j], [0.0005, 0.9995])
        pad = 0.05 * (hi - lo) if hi > lo else max(abs(lo), 1.0) * 1e-3
        lims.append((lo - pad, hi + pad))
    for i in range(L):
        for j in range(L):
            ax = axes[i, j]
            if j > i:
                ax.set_visible(False)
                continue
            if i == j:
                ax.hist(P[:, j], bins=bins, range=lims[j], density=True, color="#8fb3d9", edgecolor="none")
                grid = np.linspace(*lims[j], 300)
                dens = _gauss_mixture_marginal(result, j, grid)
                if dens.any():
                    ax.plot(grid, dens, "k--", lw=1, label="Laplace")
                ax.set_yticks([])
                ax.set_xlim(lims[j])
            else:
                ax.hist2d(P[:, j], P[:, i], bins=bins, range=[lims[j], lims[i]], cmap="Blues")
                for k, m in enumerate(result.modes):
                    ax.plot(m.parameters[names[j]], m.parameters[names[i]], "x", ms=7, mew=2,
                            color=_MODE_COLOURS[k % len(_MODE_COLOURS)])
                if truth:
                    ax.axhline(truth.get(names[i], math.nan), color="k", lw=0.7, ls=":")
                    ax.axvline(truth.get(names[j], math.nan), color="k", lw=0.7, ls=":")
            if truth and i == j and names[j] in truth:
                ax.axvline(truth[names[j]], color="k", lw=0.7, ls=":")
            if i == L - 1:
                ax.set_xlabel(names[j])
            else:
                ax.set_xticklabels([])
            if j == 0 and i > 0:
                ax.set_ylabel(names[i])
            elif j > 0:
                ax.set_yticklabels([])
    probs = ", ".join(f"{m.probability:.2f}" for m in result.modes[:6])
    fig.suptitle(f"posterior ({result.method}, {P.shape[0]} samples); solutions (x) with Laplace probabilities {probs}",
                 fontsize=9)
    fig.subplots_adjust(wspace=0.08, hspace=0.08)
    return fig


def trace_figure(result, max_walkers: int = 64):
    """MCMC: each parameter's chains against the step (burn-in shaded); TMCMC: the tempering
    exponent and each parameter's mean ± std against the stage.

    Parameters
    ----------
    result : PosteriorResult
        Of ``"mcmc"`` or ``"tmcmc"``.
    max_walkers : int, default 64
        At most this many walkers drawn per parameter.

    Returns
    -------
    matplotlib.figure.Figure

    Raises
    ------
    ValueError
        A Laplace result (it has no chains or stages).
    """
    names = list(result.names)
    L = len(names)
    if result.method == "mcmc" and result.chain is not None:
        E, n, W, _ = result.chain.shape
        fig, axes = plt.subplots(L, 1, figsize=(7, 1.6 * L + 0.6), sharex=True, squeeze=False)
        burn = int(result.diagnostics.get("burn", 0))
        walkers = [(e, w) for e in range(E) for w in range(W)][:max_walkers]
        for j, ax in enumerate(axes[:, 0]):
            for e, w in walkers:
                ax.plot(result.chain[e, :, w, j], lw=0.4, alpha=0.5)
            ax.axvspan(0, burn, color="0.85", zorder=0)
            ax.set_ylabel(names[j])
            rh = result.diagnostics.get("rhat", {}).get(names[j], math.nan)
            ess = result.diagnostics.get("ess", {}).get(names[j], math.nan)
            ax.set_title(f"R-hat {rh:.3f}, ESS {ess:.0f}", fontsize=8, loc="right")
        axes[-1, 0].set_xlabel("step (burn-in shaded)")
        fig.suptitle(f"MCMC traces ({E} ensemble(s) of {W} walkers)", fontsize=9)
        return fig
    if result.method == "tmcmc":
        stages = result.diagnostics.get("stages", [])
        fig, axes = plt.subplots(L + 1, 1, figsize=(7, 1.5 * (L + 1) + 0.6), sharex=True, squeeze=False)
        k = np.arange(1, len(stages) + 1)
        ax = axes[0, 0]
        ax.semilogy(k, [max(s["beta"], 1e-12) for s in stages], "o-")
        ax.set_ylabel("β")
        ax2 = ax.twinx()
        ax2.plot(k, [s["acceptance"] for s in stages], "s:", color="C1")
        ax2.set_ylabel("acceptance", color="C1")
        for j, a in enumerate(axes[1:, 0]):
            mu = np.array([s["mean"][j] for s in stages])
            sd = np.array([s["std"][j] for s in stages])
            a.plot(k, mu, "o-")
            a.fill_between(k, mu - sd, mu + sd, alpha=0.3)
            a.set_ylabel(names[j])
        axes[-1, 0].set_xlabel("stage")
        fig.suptitle("TMCMC stages: tempering exponent, acceptance, parameters' mean ± std", fontsize=9)
        return fig
    raise ValueError(f"a {result.method} result has no chains or stages to trace")


@shared_docs(**PLOT_DOCS)
def predictive_axes(result, test_frequencies_hz, ax=None):
    """The posterior predictive of the paired frequencies against the measured ones: per test mode
    the model's frequency interval and that of a new measurement, as errors in % of the measured
    frequency.

    Parameters
    ----------
    result : PosteriorResult
        With ``predictive`` (measured modes).
    test_frequencies_hz : array_like, shape ``(T,)``
        The measured frequencies.
    ax : matplotlib.axes.Axes, optional

    {{AX_RETURNED}}
    """
    if ax is None:
        _, ax = plt.subplots(figsize=(5.5, 3.5))
    ft = np.asarray(test_frequencies_hz, float)
    pred = (result.predictive or {}).get("modes", [])
    for e in pred:
        k = e["test_mode"]
        f = e.get("frequency_hz")
        if not f:
            continue
        lo, hi = (100 * (np.asarray(f["interval"]) - ft[k]) / ft[k])
        mid = 100 * (f["mean"] - ft[k]) / ft[k]
        ax.errorbar(k + 1, mid, yerr=[[mid - lo], [hi - mid]], fmt="o", color="C0", capsize=4,
                    label="model" if k == 0 else None)
        meas = e.get("measured_frequency_hz", {}).get("interval")
        if meas and np.all(np.isfinite(meas)):
            mlo, mhi = (100 * (np.asarray(meas) - ft[k]) / ft[k])
            ax.plot([k + 1.15, k + 1.15], [mlo, mhi], color="C1", lw=3, alpha=0.6,
                    label="new measurement" if k == 0 else None)
    ax.axhline(0, color="k", lw=0.7)
    ax.set(xlabel="test mode", ylabel="frequency − measured (%)",
           title=f"posterior predictive ({result.level:.0%} intervals)")
    ax.legend(fontsize=8)
    ax.grid(True, alpha=0.3)
    return ax


def save_posterior_figures(out_dir, result, test_frequencies_hz=None, truth: dict | None = None) -> list[str]:
    """``corner.png`` (:func:`corner_figure`), ``trace.png`` (:func:`trace_figure`, samplers) and
    ``predictive.png`` (:func:`predictive_axes`, with measured modes) in ``out_dir``; the names
    written."""
    from pathlib import Path

    out_dir = Path(out_dir)
    names = [save_figure(corner_figure(result, truth), out_dir / "corner.png")]
    if result.method in ("mcmc", "tmcmc"):
        names.append(save_figure(trace_figure(result), out_dir / "trace.png"))
    if result.predictive and test_frequencies_hz is not None and len(test_frequencies_hz):
        fig, ax = plt.subplots(figsize=(5.5, 3.5))
        predictive_axes(result, test_frequencies_hz, ax)
        names.append(save_figure(fig, out_dir / "predictive.png"))
    return names


__all__ = ["corner_figure", "trace_figure", "predictive_axes", "save_posterior_figures"]
