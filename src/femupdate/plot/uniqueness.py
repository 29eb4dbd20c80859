"""Heat map of a uniqueness study: measured-dof sets × numbers of modes."""

from __future__ import annotations

import math

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.colors import ListedColormap  # noqa: E402
from matplotlib.patches import Patch, Rectangle  # noqa: E402

from .._docs import PLOT_DOCS, shared_docs  # noqa: E402
from .paper_figures import save_figure  # noqa: E402

VERDICTS = ("unique", "non-unique", "not converging")
_COLOURS = ("#4daf4a", "#e41a1c", "#bdbdbd")


def _row_label(dofs, nested):
    return f"n = {len(dofs)}" if nested else ",".join(dofs) if len(dofs) <= 3 else f"{dofs[0]}..{dofs[-1]} ({len(dofs)})"


@shared_docs(**PLOT_DOCS)
def uniqueness_axes(cases, ax=None, title: str | None = None):
    """The (dof set, m) table of a study's ``cases`` (the JSON ``cases`` of ``femupdate
    uniqueness``): colour = verdict; text = distinct solutions found and log10 of the condition
    number at the truth; hatched where the paper's criterion (mn >= L and n > 1) predicts a unique
    solution.

    Parameters
    ----------
    cases : list of dict
        Each with ``measured_dofs``, ``n_modes``, ``verdict`` (one of ``VERDICTS``), ``solutions``,
        ``criteria`` (with ``paper``) and optionally ``condition_number`` (None or inf shown as ∞).
    {{AX}}
    title : str, optional
        Axes title (default "uniqueness: solutions found / log10 cond(S)").

    {{AX_RETURNED}}

    Raises
    ------
    ValueError
        A verdict not in ``VERDICTS``.
    """
    if ax is None:
        _, ax = plt.subplots(figsize=(6.5, 5))
    sets = list(dict.fromkeys(tuple(c["measured_dofs"]) for c in cases))
    modes = sorted({int(c["n_modes"]) for c in cases})
    nested = all(s == sets[-1][: len(s)] for s in sets)
    grid = np.full((len(sets), len(modes)), np.nan)
    ax.set_facecolor("white")
    for c in cases:
        i, j = sets.index(tuple(c["measured_dofs"])), modes.index(int(c["n_modes"]))
        grid[i, j] = VERDICTS.index(c["verdict"])
        cond = c.get("condition_number")
        cond_txt = "∞" if cond is None or not math.isfinite(cond) else f"{math.log10(cond):.0f}"
        n_sol = len(c["solutions"])
        ax.text(j, i, f"{n_sol if n_sol < 100 else '≥100'}\n{cond_txt}", ha="center", va="center", fontsize=8)
        if c["criteria"]["paper"]:
            ax.add_patch(Rectangle((j - 0.5, i - 0.5), 1, 1, fill=False, lw=0, hatch="//", ec="0.25"))
    ax.imshow(np.ma.masked_invalid(grid), cmap=ListedColormap(_COLOURS), vmin=-0.5, vmax=2.5, aspect="auto")
    ax.set(xticks=range(len(modes)), xticklabels=modes, yticks=range(len(sets)),
           yticklabels=[_row_label(s, nested) for s in sets], xlabel="measured modes m",
           ylabel="measured dofs" + (" (the first n)" if nested else ""),
           title=title or "uniqueness: solutions found / log10 cond(S)")
    handles = [Patch(color=col, label=v) for v, col in zip(VERDICTS, _COLOURS)]
    handles.append(Patch(fill=False, ec="0.25", hatch="//", label="paper: mn ≥ L and n > 1"))
    ax.legend(handles=handles, loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8)
    return ax


@shared_docs(**PLOT_DOCS)
def save_uniqueness_figure(path, cases, title: str | None = None) -> str:
    """Write :func:`uniqueness_axes` to ``path`` (atomically); returns the file name.

    Parameters
    ----------
    {{FIGURE_PATH}}
    cases, title
        As :func:`uniqueness_axes`.

    {{FIGURE_NAME}}
    """
    fig, ax = plt.subplots(figsize=(7.5, 5))
    uniqueness_axes(cases, ax, title)
    return save_figure(fig, path)


@shared_docs(**PLOT_DOCS)
def save_layouts_figure(path, panels: dict, title: str | None = None) -> str:
    """Several uniqueness heat maps side by side (one per sensor layout); returns the file name.

    Parameters
    ----------
    {{FIGURE_PATH}}
    panels : dict of str to list of dict
        Panel title → that layout's ``cases`` (as :func:`uniqueness_axes`).
    title : str, optional
        Figure title.

    {{FIGURE_NAME}}
    """
    fig, axes = plt.subplots(1, len(panels), figsize=(6.2 * len(panels), 5.2))
    for ax, (name, cases) in zip(np.atleast_1d(axes), panels.items()):
        uniqueness_axes(cases, ax, name)
        if ax is not np.atleast_1d(axes)[-1]:
            ax.get_legend().remove()
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    return save_figure(fig, path)
