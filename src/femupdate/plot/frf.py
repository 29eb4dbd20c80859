"""Figures of FRF-based updating: condition of X (Figure 4), residual surfaces (Figures 5-7),
receptance-sensitivity accuracy near resonance (eq. 32), starts reaching the truth, FRF overlays."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from .._docs import PLOT_DOCS, shared_docs  # noqa: E402
from .paper_figures import save_figure  # noqa: E402


def _log10(values):
    v = np.asarray(values, float)
    finite = np.isfinite(v) & (v > 0)
    lo = np.min(v[finite]) if finite.any() else 1e-300
    hi = np.max(v[finite]) if finite.any() else 1.0
    return np.log10(np.clip(np.where(np.isfinite(v), v, hi), lo, hi))


@shared_docs(**PLOT_DOCS)
def condition_axes(spacings, curves: dict, ax=None):
    """cond(X) against the spacing, lowest line = spacing (Figure 4); one curve per label.

    Parameters
    ----------
    spacings : array_like, shape ``(n_spacings,)``
        Spacings, rad/s.
    curves : dict of str to array_like
        Legend label -> cond(X) per spacing (log scale).
    {{AX}}

    {{AX_RETURNED}}
    """
    if ax is None:
        _, ax = plt.subplots(figsize=(5.5, 4))
    for label, c in curves.items():
        ax.semilogy(spacings, c, label=label)
    ax.set(xlabel="lowest frequency = spacing [rad/s]", ylabel="cond(X)", title="condition of X, 5 lines (eq. 28)")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend()
    return ax


@shared_docs(**PLOT_DOCS)
def condition_map_axes(starts, spacings, cond, ax=None, title="log10 cond(X)"):
    """log10 cond(X) over lowest frequency × spacing.

    Non-finite values are drawn at the largest finite one; the line lowest = spacing is dashed.

    Parameters
    ----------
    starts : array_like, shape ``(n_starts,)``
        Lowest lines, rad/s (rows of ``cond``).
    spacings : array_like, shape ``(n_spacings,)``
        Spacings, rad/s (columns of ``cond``).
    cond : array_like, shape ``(n_starts, n_spacings)``
        cond(X), e.g. :attr:`femupdate.frf.ConditionStudy.condition`.
    {{AX}}
    title : str, default "log10 cond(X)"
        Axes title.

    {{AX_RETURNED}}
    """
    if ax is None:
        _, ax = plt.subplots(figsize=(5.5, 4))
    im = ax.pcolormesh(spacings, starts, _log10(cond), shading="auto", cmap="viridis")
    ax.plot(spacings, spacings, "w--", lw=1, label="lowest = spacing (Figure 4)")
    ax.set(xlabel="spacing [rad/s]", ylabel="lowest frequency [rad/s]", title=title)
    ax.figure.colorbar(im, ax=ax, shrink=0.85)
    ax.legend(loc="upper right", fontsize=8)
    return ax


@shared_docs(**PLOT_DOCS)
def save_condition_figure(path, spacings, curves, starts, map_spacings, cond_map) -> str:
    """Save :func:`condition_axes` and :func:`condition_map_axes` side by side.

    Parameters
    ----------
    {{FIGURE_PATH}}
    spacings, curves
        As :func:`condition_axes`.
    starts, map_spacings, cond_map
        ``starts``, ``spacings`` and ``cond`` of :func:`condition_map_axes`.

    {{FIGURE_NAME}}
    """
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2))
    condition_axes(spacings, curves, axes[0])
    condition_map_axes(starts, map_spacings, cond_map, axes[1])
    fig.tight_layout()
    return save_figure(fig, path)


def _clipped_log10(surface):
    """log10 of the residual, clipped for display: spikes (lines on resonance) at three decades
    above the 99th percentile, the exact zero at the truth at 1e-10 of the median."""
    v = np.asarray(surface.values, float)
    pos = v[np.isfinite(v) & (v > 0)]
    if not pos.size:
        return np.zeros_like(v)
    lo = max(float(pos.min()), 1e-10 * float(np.median(pos)))
    hi = min(float(pos.max()), 1e3 * float(np.percentile(pos, 99)))
    return np.log10(np.clip(np.where(np.isfinite(v), v, hi), lo, hi))


def _axis(surface, i: int) -> str:
    """Axis label of a surface parameter, with its unit when known: ``"k1 [N/m]"``."""
    unit = getattr(surface, "units", ("", ""))[i]
    return f"{surface.names[i]} [{unit}]" if unit else surface.names[i]


def surface_axes(surface, ax=None):
    """3-D surface of log10 of the residual (the paper's plots; spikes clipped for display).

    Values are clipped to [max(min, 1e-10 · median), min(max, 1e3 · 99th percentile)] of the
    positive finite ones; the truth, when known, is marked in red.

    Parameters
    ----------
    surface : Surface
        A residual over a grid of two parameters (:class:`femupdate.frf.surfaces.Surface`).
    ax : mpl_toolkits.mplot3d.Axes3D, optional
        3-D axes to draw on (default: a new figure).

    Returns
    -------
    mpl_toolkits.mplot3d.Axes3D
    """
    if ax is None:
        fig = plt.figure(figsize=(6, 4.5))
        ax = fig.add_subplot(projection="3d")
    X, Y = np.meshgrid(surface.x, surface.y, indexing="ij")
    Z = _clipped_log10(surface)
    ax.plot_surface(X, Y, Z, cmap="viridis", linewidth=0, antialiased=False, rcount=150, ccount=150)
    if surface.truth is not None:
        ax.scatter(*surface.truth, float(np.min(Z)), color="r", s=40, depthshade=False)
    ax.set(xlabel=_axis(surface, 0), ylabel=_axis(surface, 1), zlabel="log10 r")
    return ax


@shared_docs(**PLOT_DOCS)
def contour_axes(surface, ax=None, minima=None):
    """Filled contours of log10 residual, the true solution (red star) and grid local minima (white).

    Parameters
    ----------
    surface : Surface
        A residual over a grid of two parameters (:class:`femupdate.frf.surfaces.Surface`).
    {{AX}}
    minima : list of dict, optional
        Points to circle, keyed by the parameter names (default ``surface.minima()``).

    {{AX_RETURNED}}
    """
    if ax is None:
        _, ax = plt.subplots(figsize=(5.5, 4.5))
    Z = _clipped_log10(surface)
    cs = ax.contourf(surface.x, surface.y, Z.T, levels=30, cmap="viridis")
    ax.figure.colorbar(cs, ax=ax, shrink=0.85, label="log10 r")
    for m in (minima if minima is not None else surface.minima()):
        ax.plot(m[surface.names[0]], m[surface.names[1]], "o", mfc="none", mec="w", ms=5)
    if surface.truth is not None:
        ax.plot(*surface.truth, "r*", ms=12, label=f"true ({surface.truth[0]:g}, {surface.truth[1]:g})")
        ax.legend(loc="upper right", fontsize=8)
    ax.set(xlabel=_axis(surface, 0), ylabel=_axis(surface, 1))
    return ax


@shared_docs(**PLOT_DOCS)
def save_surface_figure(path, surface, title: str) -> str:
    """Save :func:`surface_axes` and :func:`contour_axes` side by side.

    Parameters
    ----------
    {{FIGURE_PATH}}
    surface : Surface
        A residual over a grid of two parameters (:class:`femupdate.frf.surfaces.Surface`).
    title : str
        Title of the 3-D panel.

    {{FIGURE_NAME}}
    """
    fig = plt.figure(figsize=(12, 4.8))
    ax3 = fig.add_subplot(1, 2, 1, projection="3d")
    surface_axes(surface, ax3)
    ax3.set_title(title, fontsize=9)
    ax2 = fig.add_subplot(1, 2, 2)
    contour_axes(surface, ax2)
    ax2.set_title("contours; circles: grid local minima", fontsize=9)
    fig.tight_layout()
    return save_figure(fig, path)


@shared_docs(**PLOT_DOCS)
def accuracy_axes(omega, curves: dict, resonances_rad_s=(), ax=None):
    """Relative errors against frequency (log scale), model resonances as dotted lines.

    Parameters
    ----------
    omega : array_like, shape ``(n_lines,)``
        Spectral lines, rad/s.
    curves : dict of str to array_like
        Legend label -> relative error per line (values below 1e-17 drawn at 1e-17).
    resonances_rad_s : iterable of float, default ()
        Model natural frequencies, rad/s.
    {{AX}}

    {{AX_RETURNED}}
    """
    if ax is None:
        _, ax = plt.subplots(figsize=(6, 4))
    for label, e in curves.items():
        ax.semilogy(omega, np.maximum(np.asarray(e, float), 1e-17), label=label)
    for w in resonances_rad_s:
        ax.axvline(w, color="k", ls=":", lw=0.8)
    ax.set(xlabel="omega [rad/s]", ylabel="relative error", title="receptance sensitivity near resonances (eq. 32)")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    return ax


@shared_docs(**PLOT_DOCS)
def save_accuracy_figure(path, omega, curves, resonances_rad_s) -> str:
    """Save :func:`accuracy_axes` to ``path``.

    Parameters
    ----------
    {{FIGURE_PATH}}
    omega, curves, resonances_rad_s
        As :func:`accuracy_axes`.

    {{FIGURE_NAME}}
    """
    fig, ax = plt.subplots(figsize=(6.5, 4.2))
    accuracy_axes(omega, curves, resonances_rad_s, ax)
    return save_figure(fig, path)


@shared_docs(**PLOT_DOCS)
def starts_axes(starts, reached, title, truth=None, ax=None):
    """Random starts: green if the local update from there reached the truth, red otherwise.

    Parameters
    ----------
    starts : array_like, shape ``(n_starts, 2)``
        Starting (k1, k2), N/m (the axes are labelled k1 and k2).
    reached : array_like of bool, shape ``(n_starts,)``
        Whether each start reached the truth.
    title : str
        Axes title.
    truth : (float, float), optional
        Marked with a black star.
    {{AX}}

    {{AX_RETURNED}}
    """
    if ax is None:
        _, ax = plt.subplots(figsize=(4.5, 4))
    starts = np.asarray(starts)
    reached = np.asarray(reached, bool)
    ax.plot(starts[reached, 0], starts[reached, 1], "o", color="tab:green", ms=4, label=f"reached truth ({reached.sum()})")
    ax.plot(starts[~reached, 0], starts[~reached, 1], "x", color="tab:red", ms=4, label=f"did not ({(~reached).sum()})")
    if truth is not None:
        ax.plot(*truth, "k*", ms=12)
    ax.set(title=title, xlabel="k1", ylabel="k2")
    ax.legend(loc="upper right", fontsize=7)
    return ax


@shared_docs(**PLOT_DOCS)
def save_starts_figure(path, panels) -> str:
    """``panels``: list of (starts, reached, title, truth).

    Parameters
    ----------
    {{FIGURE_PATH}}
    panels : list of tuple
        ``(starts, reached, title, truth)`` per panel, as :func:`starts_axes`; panels side by side.

    {{FIGURE_NAME}}
    """
    fig, axes = plt.subplots(1, len(panels), figsize=(4.2 * len(panels), 4), squeeze=False)
    for ax, (starts, reached, title, truth) in zip(axes[0], panels):
        starts_axes(starts, reached, title, truth, ax)
    fig.tight_layout()
    return save_figure(fig, path)


@shared_docs(**PLOT_DOCS)
def frf_axes(omega, dofs, measured, model, ax=None, start=None, hz: bool = False):
    """Magnitude of measured (dots) and model (lines) FRFs, log scale.

    Parameters
    ----------
    omega : array_like, shape ``(n_lines,)``
        Spectral lines, rad/s.
    dofs : sequence of str
        Response dofs (columns of ``measured`` and ``model``).
    measured, model : numpy.ndarray, shape ``(n_lines, len(dofs))``
        Measured and model receptances, m/N (real or complex).
    {{AX}}
    start : numpy.ndarray, shape ``(n_lines, len(dofs))``, optional
        The model's receptances before updating, drawn dashed.
    hz : bool, default False
        Frequency axis in Hz (ω/2π) instead of rad/s.

    {{AX_RETURNED}}
    """
    if ax is None:
        _, ax = plt.subplots(figsize=(6, 4))
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    x = np.asarray(omega, float) / (2 * np.pi) if hz else omega
    for k, d in enumerate(dofs):
        c = colours[k % len(colours)]
        if start is not None:
            ax.semilogy(x, np.abs(start[:, k]), "--", color=c, lw=0.8, alpha=0.6, label=f"{d} model, start")
        ax.semilogy(x, np.abs(measured[:, k]), "o", color=c, ms=3, label=f"{d} test")
        ax.semilogy(x, np.abs(model[:, k]), "-", color=c, lw=1, label=f"{d} model" + (", updated" if start is not None else ""))
    ax.set(xlabel="frequency [Hz]" if hz else "omega [rad/s]", ylabel="|receptance|", title="FRF: test vs updated model")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7)
    return ax


@shared_docs(**PLOT_DOCS)
def save_frf_update_figures(out_dir, history, omega, dofs, measured, model) -> list[str]:
    """``frf.png`` (test vs updated model) and ``convergence.png`` (cost per iteration).

    Parameters
    ----------
    out_dir : str or os.PathLike
        Directory to write into (created if absent).
    history : list of dict
        Iteration history with a ``"cost"`` per entry (:func:`~femupdate.plot.updating.convergence_axes`).
    omega, dofs, measured, model
        As :func:`frf_axes`.

    {{FIGURE_NAMES}}
    """
    from .updating import convergence_axes

    out_dir = Path(out_dir)
    fig, ax = plt.subplots(figsize=(6.5, 4.2))
    frf_axes(omega, dofs, measured, model, ax)
    names = [save_figure(fig, out_dir / "frf.png")]
    fig, ax = plt.subplots(figsize=(5, 3.5))
    convergence_axes(history, ax)
    names.append(save_figure(fig, out_dir / "convergence.png"))
    return names
