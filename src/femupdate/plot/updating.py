"""Figures of an updating run: convergence history and the test/model MAC matrix."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from .._docs import PLOT_DOCS, shared_docs  # noqa: E402
from .paper_figures import save_figure  # noqa: E402


@shared_docs(**PLOT_DOCS)
def convergence_axes(history, ax=None):
    """Cost (log scale) against iteration.

    Parameters
    ----------
    history : list of dict
        One entry per iteration with its ``"cost"`` ½‖r‖² (e.g. ``UpdateResult.history``).
    {{AX}}

    {{AX_RETURNED}}
    """
    if ax is None:
        _, ax = plt.subplots(figsize=(5, 3.5))
    cost = np.array([h["cost"] for h in history], float)
    ax.semilogy(np.arange(len(cost)), np.maximum(cost, 1e-300), "o-")
    ax.set(xlabel="iteration", ylabel="cost ½‖r‖²", title="convergence")
    ax.grid(True, which="both", alpha=0.3)
    return ax


@shared_docs(**PLOT_DOCS)
def mac_axes(mac_matrix, ax=None, title="MAC"):
    """MAC matrix as an image with its values.

    Parameters
    ----------
    mac_matrix : array_like, shape ``(n_test, n_model)``
        MAC of test modes (rows) with model modes (columns), in [0, 1].
    {{AX}}
    title : str, default "MAC"
        Axes title.

    {{AX_RETURNED}}
    """
    if ax is None:
        _, ax = plt.subplots(figsize=(4.5, 4))
    m = np.asarray(mac_matrix)
    im = ax.imshow(m, vmin=0, vmax=1, cmap="viridis")
    for (i, j), v in np.ndenumerate(m):
        ax.text(j, i, f"{v:.2f}", ha="center", va="center", color="w" if v < 0.6 else "k", fontsize=8)
    ax.set(xlabel="model mode", ylabel="test mode", title=title,
           xticks=range(m.shape[1]), xticklabels=range(1, m.shape[1] + 1),
           yticks=range(m.shape[0]), yticklabels=range(1, m.shape[0] + 1))
    ax.figure.colorbar(im, ax=ax, shrink=0.8)
    return ax


@shared_docs(**PLOT_DOCS)
def save_update_figures(out_dir, history, mac_matrix) -> list[str]:
    """``convergence.png`` (:func:`convergence_axes`) and ``mac.png`` (:func:`mac_axes`).

    Parameters
    ----------
    out_dir : str or os.PathLike
        Directory to write into (created if absent).
    history : list of dict
        As :func:`convergence_axes`.
    mac_matrix : array_like, shape ``(n_test, n_model)``
        As :func:`mac_axes`.

    {{FIGURE_NAMES}}
    """
    from pathlib import Path

    out_dir = Path(out_dir)
    fig, ax = plt.subplots(figsize=(5, 3.5))
    convergence_axes(history, ax)
    names = [save_figure(fig, out_dir / "convergence.png")]
    fig, ax = plt.subplots(figsize=(4.5, 4))
    mac_axes(mac_matrix, ax, "MAC, updated model vs test")
    names.append(save_figure(fig, out_dir / "mac.png"))
    return names
