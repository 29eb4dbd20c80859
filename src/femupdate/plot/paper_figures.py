"""Figures of the reference paper's sections."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from .._docs import PLOT_DOCS, shared_docs  # noqa: E402
from ..io.results import atomic_write_bytes  # noqa: E402


@shared_docs(**PLOT_DOCS)
def save_figure(fig, path) -> str:
    """Write ``fig`` to ``path`` atomically (120 dpi, tight bounding box) and close it.

    Parameters
    ----------
    fig : matplotlib.figure.Figure
        The figure; closed afterwards.
    path : str or os.PathLike
        Image file; its suffix selects the format (png when there is none).

    {{FIGURE_NAME}}

    Raises
    ------
    ValueError
        Matplotlib does not know the format.
    OSError
        The file cannot be written.
    """
    import io

    buf = io.BytesIO()
    fig.savefig(buf, format=Path(path).suffix.lstrip(".") or "png", dpi=120, bbox_inches="tight")
    plt.close(fig)
    atomic_write_bytes(path, buf.getvalue())
    return Path(path).name


@shared_docs(**PLOT_DOCS)
def characteristic_axes(a1, a0, m1, m2, solutions, ax=None):
    """Curves a1(k1, k2) = a1 and a0(k1, k2) = a0 in the (k1, k2) plane: their crossings are
    every stiffness pair with the measured eigenvalues (eqs. 11-12).

    The axes span the paper's range, k1 = 3 .. 13 and k2 = 1 .. 11 N/m.

    Parameters
    ----------
    a1, a0 : float
        Right-hand sides of m2 k1 + (m1 + m2) k2 = a1 and k1 k2 = a0 (eqs. 11-12).
    m1, m2 : float
        Masses, kg.
    solutions : iterable of (float, float)
        The crossings (k1, k2), N/m, marked and labelled.
    {{AX}}

    {{AX_RETURNED}}
    """
    if ax is None:
        _, ax = plt.subplots(figsize=(5.5, 4.5))
    k1 = np.linspace(3, 13, 400)
    ax.plot(k1, (a1 - m2 * k1) / (m1 + m2), label=r"$m_2k_1+(m_1+m_2)k_2=a_1$")
    ax.plot(k1, a0 / k1, label=r"$k_1k_2=a_0$")
    for s in solutions:
        ax.plot(*s, "ko")
        ax.annotate(f"({s[0]:.4g}, {s[1]:.4g})", s, textcoords="offset points", xytext=(6, 6))
    ax.set(xlabel=r"$k_1$ [N/m]", ylabel=r"$k_2$ [N/m]", xlim=(3, 13), ylim=(1, 11),
           title="two stiffness sets, identical eigenvalues")
    ax.legend(loc="upper right")
    return ax


@shared_docs(**PLOT_DOCS)
def characteristic_curves(path, a1, a0, m1, m2, solutions) -> str:
    """Save :func:`characteristic_axes` to ``path``.

    Parameters
    ----------
    {{FIGURE_PATH}}
    a1, a0, m1, m2, solutions
        As :func:`characteristic_axes`.

    {{FIGURE_NAME}}
    """
    fig, ax = plt.subplots(figsize=(5.5, 4.5))
    characteristic_axes(a1, a0, m1, m2, solutions, ax=ax)
    return save_figure(fig, path)


@shared_docs(**PLOT_DOCS)
def multistart_axes(ms, ax=None):
    """Random starts (grey) joined to where they converged (coloured by solution).

    The first two parameters are plotted.

    Parameters
    ----------
    ms : MultiStartResult
        Result of :func:`femupdate.multistart` (``starts``, ``runs``, ``solutions``, ``names``).
    {{AX}}

    {{AX_RETURNED}}
    """
    if ax is None:
        _, ax = plt.subplots(figsize=(5.5, 4.5))
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    where = {}
    for c, sol in enumerate(ms.solutions):
        for k in sol.starts:
            where[k] = c
    for k, x0 in enumerate(ms.starts):
        run = ms.runs[k]
        if k in where:
            ax.plot([x0[0], run.x[0]], [x0[1], run.x[1]], "-", color=colours[where[k] % len(colours)], alpha=0.25, lw=0.8)
        ax.plot(*x0[:2], ".", color="0.5", ms=3)
    for c, sol in enumerate(ms.solutions):
        v = list(sol.parameters.values())
        ax.plot(v[0], v[1], "o", color=colours[c % len(colours)], ms=9, mec="k",
                label=f"({v[0]:.4g}, {v[1]:.4g}): {sol.count} starts")
    ax.set(xlabel=ms.names[0], ylabel=ms.names[1], title="multi-start updating, one sensor, two modes")
    ax.legend(loc="upper right")
    return ax


@shared_docs(**PLOT_DOCS)
def multistart_scatter(path, ms) -> str:
    """Save :func:`multistart_axes` to ``path``.

    Parameters
    ----------
    {{FIGURE_PATH}}
    ms : MultiStartResult
        As :func:`multistart_axes`.

    {{FIGURE_NAME}}
    """
    fig, ax = plt.subplots(figsize=(5.5, 4.5))
    multistart_axes(ms, ax)
    return save_figure(fig, path)


@shared_docs(**PLOT_DOCS)
def eigvec_cost_figure(path, rows) -> str:
    """CPU time and error against finite differences of each eigenvector-derivative route, by model size.

    Parameters
    ----------
    {{FIGURE_PATH}}
    rows : list of dict
        The ``rows`` of the ``eigenvector_derivatives`` paper section: ``n_dofs``, ``n_parameters``
        and ``routes`` (route → ``seconds``, ``error_vs_fd``).

    {{FIGURE_NAME}}
    """
    fig, (a0, a1) = plt.subplots(1, 2, figsize=(11, 4.2))
    routes = list(dict.fromkeys(k for r in rows for k in r["routes"]))
    styles = {L: ls for L, ls in zip(sorted({r["n_parameters"] for r in rows}), ("-", "--", ":"))}
    for i, route in enumerate(routes):
        for L, ls in styles.items():
            sel = [r for r in rows if r["n_parameters"] == L and route in r["routes"]]
            x = [r["n_dofs"] for r in sel]
            a0.plot(x, [r["routes"][route]["seconds"] for r in sel], ls, marker="o", color=f"C{i}",
                    label=f"{route} (L={L})")
            if ls == "-":
                a1.plot(x, [max(r["routes"][route]["error_vs_fd"], 1e-16) for r in sel], ls, marker="o",
                        color=f"C{i}", label=route)
    a0.set(xscale="log", yscale="log", xlabel="dofs N", ylabel="CPU s (best of 3)", title="cost of the derivatives")
    a1.set(xscale="log", yscale="log", xlabel="dofs N", ylabel="max error / max |dφ|", title="error against finite differences")
    a0.legend(fontsize=7)
    a1.legend(fontsize=7)
    fig.tight_layout()
    return save_figure(fig, path)


@shared_docs(**PLOT_DOCS)
def grouped_bars_figure(path, groups: dict, ylabel: str, title: str, log: bool = False) -> str:
    """Grouped bar chart: ``groups`` maps a series name to {category: value}.

    Parameters
    ----------
    {{FIGURE_PATH}}
    groups : dict of str to dict of str to float
        One bar colour per series; the categories share the x axis.
    ylabel, title : str
    log : bool, default False
        Logarithmic y axis.

    {{FIGURE_NAME}}
    """
    cats = list(dict.fromkeys(c for g in groups.values() for c in g))
    fig, ax = plt.subplots(figsize=(max(6.0, 0.9 * len(cats) * len(groups) ** 0.5 + 2), 4.2))
    x = np.arange(len(cats))
    w = 0.8 / max(1, len(groups))
    for k, (name, g) in enumerate(groups.items()):
        ax.bar(x + k * w, [max(g.get(c, np.nan), 1e-16) for c in cats], w, label=name)
    ax.set_xticks(x + 0.4 - w / 2, cats, rotation=20, ha="right", fontsize=8)
    ax.set(ylabel=ylabel, title=title, yscale="log" if log else "linear")
    ax.legend(fontsize=8)
    fig.tight_layout()
    return save_figure(fig, path)


@shared_docs(**PLOT_DOCS)
def error_vs_condition_figure(path, cond, err, named: dict, sigma: float) -> str:
    """Median parameter error of the direct FRF solution against cond(X): random line sets as dots,
    ``named`` sets ({label: (cond, error)}) as labelled markers.

    Parameters
    ----------
    {{FIGURE_PATH}}
    cond, err : array_like
        Condition numbers and median errors of the random sets.
    named : dict of str to (float, float)
    sigma : float
        The noise level (title).

    {{FIGURE_NAME}}
    """
    fig, ax = plt.subplots(figsize=(6.5, 4.5))
    ax.loglog(cond, err, "o", color="0.6", label="random 5-line sets")
    for i, (name, (c, e)) in enumerate(named.items()):
        ax.loglog([c], [e], "s", ms=9, color=f"C{i}", label=name)
    ax.set(xlabel="cond(X) (eq. 28)", ylabel="RMS of the largest relative error of k",
           title=f"Figure 4 with {sigma:.0%} FRF noise: direct solution error vs conditioning")
    ax.legend(fontsize=8)
    fig.tight_layout()
    return save_figure(fig, path)


@shared_docs(**PLOT_DOCS)
def identifiability_grids_figure(path, tables: dict, N: int) -> str:
    """Sensors × actuators grids (rank / unknowns; green where identifiable), one row per variant
    and one column per placement (the ``su_juang_criteria`` paper section).

    Parameters
    ----------
    {{FIGURE_PATH}}
    tables : dict of str to dict of str to dict
        Variant → placement → ``"s x a"`` → {sensors, actuators, rank, unknowns, identifiable}.
    N : int
        Number of dofs.

    {{FIGURE_NAME}}
    """
    rows, cols = list(tables), list(next(iter(tables.values())))
    fig, axes = plt.subplots(len(rows), len(cols), figsize=(4.2 * len(cols), 3.3 * len(rows)), squeeze=False)
    for i, v in enumerate(rows):
        for j, p in enumerate(cols):
            ax = axes[i][j]
            grid = np.zeros((N, N))
            for c in tables[v][p].values():
                s, a = c["sensors"], c["actuators"]
                grid[s - 1, a - 1] = 1.0 if c["identifiable"] else 0.0
                ax.text(a - 1, s - 1, f"{c['rank']}/{c['unknowns']}", ha="center", va="center", fontsize=8)
            ax.imshow(grid, cmap="RdYlGn", vmin=-0.3, vmax=1.3, origin="lower")
            ax.set(xticks=range(N), xticklabels=range(1, N + 1), yticks=range(N), yticklabels=range(1, N + 1),
                   xlabel="actuators", ylabel="sensors", title=f"{v}\n{p.split(' (')[0]}")
            ax.title.set_fontsize(9)
    fig.tight_layout()
    return save_figure(fig, path)
