"""Figures of the perturbed-boundary, full-field and damage sections (matplotlib, Agg)."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from .._docs import PLOT_DOCS, shared_docs  # noqa: E402
from .paper_figures import save_figure  # noqa: E402


@shared_docs(**PLOT_DOCS)
def perturbed_boundary_axes(alone, joint, ranking, mc, axes=None):
    """Left: solutions from random starts, baseline alone vs with the added configuration.
    Right: candidates' stacked condition number against the Monte Carlo identification error.

    Parameters
    ----------
    alone, joint : iterable of (float, float, int)
        Solutions (k1, k2) in N/m and the number of starts reaching each, from the baseline alone
        and with the added configuration (marker size grows with the count).
    ranking : Ranking
        Result of :func:`~femupdate.updating.multiconfig.rank_modifications`; its ``candidates``
        (dicts with ``name`` and ``condition_number``) are plotted.
    mc : dict of str to float
        RMS relative identification error per candidate name.
    {{AXES_PAIR}}
    """
    if axes is None:
        _, axes = plt.subplots(1, 2, figsize=(10, 4))
    ax = axes[0]
    for k1, k2, n in alone:
        ax.plot(k1, k2, "o", ms=6 + n / 2, mfc="none", mec="C0")
        ax.annotate(f"alone: {n}", (k1, k2), textcoords="offset points", xytext=(6, -12))
    for k1, k2, n in joint:
        ax.plot(k1, k2, "s", ms=5 + n / 3, color="C3")
        ax.annotate(f"with config.: {n}", (k1, k2), textcoords="offset points", xytext=(6, 6))
    ax.set(xlabel="k1 [N/m]", ylabel="k2 [N/m]", title="two-dof chain, frequencies only: solutions")
    ax = axes[1]
    for c in ranking.candidates:
        ax.plot(c["condition_number"], mc[c["name"]], "o")
        ax.annotate(c["name"], (c["condition_number"], mc[c["name"]]), textcoords="offset points", xytext=(4, 4), fontsize=8)
    ax.set(xlabel="condition number, baseline + candidate", ylabel="RMS relative error (Monte Carlo)",
           title="pre-test ranking vs identification error")
    return axes


@shared_docs(**PLOT_DOCS)
def perturbed_boundary_figure(path, alone, joint, ranking, mc) -> str:
    """Save :func:`perturbed_boundary_axes` to ``path``.

    Parameters
    ----------
    {{FIGURE_PATH}}
    alone, joint, ranking, mc
        As :func:`perturbed_boundary_axes`.

    {{FIGURE_NAME}}
    """
    fig, axes = plt.subplots(1, 2, figsize=(10, 4))
    perturbed_boundary_axes(alone, joint, ranking, mc, axes)
    fig.tight_layout()
    return save_figure(fig, path)


@shared_docs(**PLOT_DOCS)
def full_field_axes(model, scan, mapping, truth_modes, mode: int = 1, axes=None):
    """Scan points, the shape mapped onto the model's nodes (translation and inferred rotation).

    For a beam along x: the top panel shows the scan's ``y`` values and the mapped ``y`` dofs,
    the bottom one the mapped ``rz`` dofs, against x.

    Parameters
    ----------
    model : Model
        Model with ``nodes`` coordinates and ``y``/``rz`` dofs.
    scan : ScanData
        The scan (its ``points`` and ``modes``).
    mapping : FullFieldMapping
        Result of :func:`~femupdate.fullfield.map_scan` for ``scan`` on ``model``.
    truth_modes : Modes
        Not used by the plot.
    mode : int, default 1
        0-based index of the mode shown (the title numbers it from 1).
    {{AXES_PAIR}}
    """
    if axes is None:
        _, axes = plt.subplots(2, 1, figsize=(7, 5.5), sharex=True)
    x = scan.points[:, 0]
    vals = scan.modes[mode].values["y"]
    sh = mapping.data.modes[mode].shape
    ys = [d for d in model.dofs if d.endswith(":y")]
    rz = [d for d in model.dofs if d.endswith(":rz")]
    xn = np.array([model.nodes[int(d.split(":")[0])][0] for d in ys])
    v = sh[[model.dofs.index(d) for d in ys]]
    th = sh[[model.dofs.index(d) for d in rz]]
    ax = axes[0]
    ax.plot(x, vals, ".", ms=3, color="0.6", label="scan (1 % noise)")
    ax.plot(xn, v, "o-", color="C3", label=f"on the nodes ({mapping.method})")
    ax.set(ylabel="y", title=f"mode {mode + 1}: scan mapped onto the model")
    ax.legend()
    ax = axes[1]
    ax.plot(xn, th, "o-", color="C3", label="rz inferred from the slope")
    ax.set(xlabel="x [m]", ylabel="rz")
    ax.legend()
    return axes


@shared_docs(**PLOT_DOCS)
def full_field_figure(path, model, scan, mapping, truth_modes) -> str:
    """Save :func:`full_field_axes` of mode index 1 (the second mode) to ``path``.

    Parameters
    ----------
    {{FIGURE_PATH}}
    model, scan, mapping, truth_modes
        As :func:`full_field_axes`.

    {{FIGURE_NAME}}
    """
    fig, axes = plt.subplots(2, 1, figsize=(7, 5.5), sharex=True)
    full_field_axes(model, scan, mapping, truth_modes, 1, axes)
    fig.tight_layout()
    return save_figure(fig, path)


_COLOURS = {"exact": "#2a9d2a", "found first": "#9acd32", "found": "#f0c040", "missed": "#d04040", "not localisable": "#808080"}


@shared_docs(**PLOT_DOCS)
def damage_study_axes(study, cases, ax=None):
    """Outcome per damaged member (rows) and configuration (columns), one cell per noise draw.

    Parameters
    ----------
    study : dict
        Per configuration (support) name: ``band_hz``, ``global_modes``, ``n_modes`` and ``runs``, a
        list of dicts with ``damaged`` (member) and ``outcome`` (``"exact"``, ``"found first"``,
        ``"found"``, ``"missed"`` or ``"not localisable"``).
    cases : sequence of str
        Damaged members, one row each.
    {{AX}}

    {{AX_RETURNED}}

    Raises
    ------
    KeyError
        An outcome not among the five above.
    """
    if ax is None:
        _, ax = plt.subplots(figsize=(7, 4.5))
    supports = list(study)
    for c, sup in enumerate(supports):
        runs = study[sup]["runs"]
        for r, member in enumerate(cases):
            mine = [x for x in runs if x["damaged"] == member]
            w = 1.0 / max(len(mine), 1)
            for k, run in enumerate(mine):
                ax.add_patch(plt.Rectangle((c + k * w, r), w * 0.95, 0.9, color=_COLOURS[run["outcome"]]))
    ax.set_xlim(0, len(supports))
    ax.set_ylim(0, len(cases))
    ax.set_xticks(np.arange(len(supports)) + 0.5,
                  [f"{s}\n0-{study[s]['band_hz']:g} Hz, {study[s]['global_modes']}/{study[s]['n_modes']} global" for s in supports])
    ax.set_yticks(np.arange(len(cases)) + 0.45, cases)
    handles = [plt.Rectangle((0, 0), 1, 1, color=v) for v in _COLOURS.values()]
    ax.legend(handles, list(_COLOURS), loc="upper center", bbox_to_anchor=(0.5, -0.18), ncol=5, fontsize=8)
    ax.set_title("damage localisation: cantilever vs free-free")
    return ax


@shared_docs(**PLOT_DOCS)
def damage_study_figure(path, study, cases) -> str:
    """Save :func:`damage_study_axes` to ``path``.

    Parameters
    ----------
    {{FIGURE_PATH}}
    study, cases
        As :func:`damage_study_axes`.

    {{FIGURE_NAME}}
    """
    fig, ax = plt.subplots(figsize=(7.5, 5))
    damage_study_axes(study, cases, ax)
    fig.tight_layout()
    return save_figure(fig, path)
