"""Figures of the HTML report (:mod:`femupdate.report`), drawn from plain numbers and returned as
text that an HTML file embeds: inline SVG, or a base64 PNG for figures with many polygons.

Figures are made with :class:`matplotlib.figure.Figure` (no pyplot state, nothing to close).
Each ``*_figure`` function returns the embedded figure; the axes functions follow the house rule
(``ax=None``, return the axes).
"""

from __future__ import annotations

import base64
import io
import math
from typing import Any

import matplotlib

matplotlib.use("Agg")
import numpy as np  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402

from .shapes import mode_shape_axes, needs_3d  # noqa: E402
from .uniqueness import uniqueness_axes  # noqa: E402
from .updating import mac_axes  # noqa: E402

_SVG_RC: dict = {"svg.fonttype": "path", "svg.hashsalt": "femupdate"}  # the same run draws the same SVG


def embed(fig: Figure, fmt: str = "svg") -> dict:
    """A figure as the report embeds it.

    Parameters
    ----------
    fig : matplotlib.figure.Figure
    fmt : {"svg", "png"}
        Inline SVG (text drawn as paths: no font is needed to view it), or a PNG at 110 dpi as a
        base64 data URI (for figures of many polygons, such as 3-D surfaces).

    Returns
    -------
    dict
        ``{"svg": "<svg ...>...</svg>"}`` or ``{"png": "data:image/png;base64,..."}``.
    """
    buf = io.BytesIO()
    if fmt == "png":
        fig.savefig(buf, format="png", dpi=110, bbox_inches="tight", metadata={"Software": None})
        return {"png": "data:image/png;base64," + base64.b64encode(buf.getvalue()).decode("ascii")}
    with matplotlib.rc_context(_SVG_RC):
        fig.savefig(buf, format="svg", bbox_inches="tight", metadata={"Date": None})
    text = buf.getvalue().decode("utf-8")
    return {"svg": text[text.index("<svg"):]}


def _fig(w: float = 6.0, h: float = 3.6) -> Figure:
    return Figure(figsize=(w, h), layout="constrained")


def convergence_figure(history, names, cost_unit: str = "–") -> dict:
    """Cost against iteration (log) and each parameter relative to its start.

    Parameters
    ----------
    history : list of dict
        ``{"iteration", "cost", "parameters": {name: value}}`` per iteration (the JSON
        ``history``).
    names : sequence of str
        The updated parameters.
    cost_unit : str
        The unit of the cost, for its axis.
    """
    fig = _fig(9.0, 3.4)
    a1, a2 = fig.subplots(1, 2)
    it = [h.get("iteration", k) for k, h in enumerate(history)]
    cost = np.array([np.nan if h.get("cost") is None else h["cost"] for h in history], float)
    a1.semilogy(it, np.maximum(cost, 1e-300), "o-", ms=3)
    a1.set(xlabel="iteration [–]", ylabel=f"cost ½‖r‖² [{cost_unit}]", title="cost")
    a1.grid(True, which="both", alpha=0.3)
    for n in names:
        v = np.array([h.get("parameters", {}).get(n, np.nan) for h in history], float)
        v0 = v[0] if len(v) and np.isfinite(v[0]) and v[0] != 0 else np.nan
        a2.plot(it, v / v0, "o-", ms=3, label=n)
    a2.set(xlabel="iteration [–]", ylabel="value / start value [–]", title="parameters")
    a2.grid(True, alpha=0.3)
    if 0 < len(names) <= 12:
        a2.legend(fontsize=7, ncols=2 if len(names) > 6 else 1)
    return embed(fig)


def mac_figure(mac, title: str) -> dict:
    """A MAC matrix (test modes × model modes) with its values (:func:`~femupdate.plot.updating.mac_axes`)."""
    m = np.asarray(mac, float)
    fig = _fig(0.45 * m.shape[1] + 2.6, 0.4 * m.shape[0] + 2.0)
    ax = fig.subplots()
    mac_axes(m, ax, title)
    ax.set(xlabel="model mode [–]", ylabel="test mode [–]")
    return embed(fig)


def frequency_figure(test_hz, before_hz, after_hz) -> dict:
    """Paired frequencies: the relative error of each test mode before and after (bars, %).

    Parameters
    ----------
    test_hz : sequence of float
        Test frequencies of the paired modes, Hz.
    before_hz, after_hz : sequence of float or None
        The paired model frequencies before and after (None entries: unpaired), Hz; either may
        be None as a whole.
    """
    test = np.asarray(test_hz, float)
    fig = _fig(max(4.5, 0.6 * len(test) + 2.5), 3.2)
    ax = fig.subplots()
    k = np.arange(1, len(test) + 1)
    series = [(s, lab, c) for s, lab, c in ((before_hz, "before", "0.6"), (after_hz, "after", "C0")) if s is not None]
    w = 0.8 / max(len(series), 1)
    for i, (s, lab, c) in enumerate(series):
        f = np.array([np.nan if v is None else v for v in s], float)
        ax.bar(k + (i - (len(series) - 1) / 2) * w, (f - test) / test * 100, w, label=lab, color=c)
    ax.axhline(0, color="k", lw=0.8)
    ax.set(xlabel="test mode [–]", ylabel="(f model − f test) / f test [%]", title="frequency errors",
           xticks=k)
    ax.grid(True, axis="y", alpha=0.3)
    if series:
        ax.legend(fontsize=8)
    return embed(fig)


def singular_values_figure(sv) -> dict:
    """Normalised singular values of the sensitivity matrix (log scale)."""
    s = np.asarray([np.nan if v is None else v for v in sv], float)
    fig = _fig(max(3.5, 0.4 * len(s) + 2.0), 3.0)
    ax = fig.subplots()
    ax.semilogy(np.arange(1, len(s) + 1), np.maximum(s, 1e-300), "o-")
    ax.set(xlabel="index [–]", ylabel="singular value of ∂r/∂(p/|p|) [–]",
           title="normalised sensitivity: singular values", xticks=np.arange(1, len(s) + 1))
    ax.grid(True, which="both", alpha=0.3)
    return embed(fig)


def solutions_figure(solutions, names, units, truth=None) -> dict:
    """Distinct solutions of a multi-start study over their first two parameters (marker area ∝
    the number of starts; filled: fits the data as well as the best)."""
    fig = _fig(4.8, 4.0)
    ax = fig.subplots()
    a, b = names[:2]
    for s in solutions:
        p = s["parameters"]
        fits = s.get("fits", True)
        ax.scatter(p[a], p[b], s=30 + 300 * s.get("count", 1) / max(x.get("count", 1) for x in solutions),
                   facecolors="C0" if fits else "none", edgecolors="C0" if fits else "C3", zorder=3)
        ax.annotate(f"×{s.get('count', 1)}", (p[a], p[b]), textcoords="offset points", xytext=(6, 6), fontsize=8)
    if truth is not None:
        ax.plot(truth[a], truth[b], "k+", ms=12, label="truth")
        ax.legend(fontsize=8)
    ax.set(xlabel=_label(a, units), ylabel=_label(b, units), title="distinct solutions (open: local minima)")
    ax.grid(True, alpha=0.3)
    return embed(fig)


def _label(name, units) -> str:
    u = (units or {}).get(name)
    return f"{name} [{u}]" if u else f"{name} [unit not stated]"


def frf_figure(omega, dofs, measured, model_omega, before, after, unit: str = "m") -> dict:
    """FRF magnitudes at each response dof: test (markers) and the model before and after (lines).

    Parameters
    ----------
    omega : array_like, shape ``(n_lines,)``
        The measured lines, rad/s.
    dofs : sequence of str
    measured : array_like, shape ``(n_lines, len(dofs))``
        Complex or real responses.
    model_omega : array_like, shape ``(n,)``
        The lines of the model's curves, rad/s.
    before, after : array_like, shape ``(n, len(dofs))``
        The model's responses (``before`` may be None).
    unit : str
        The response unit for the axis (m for a force in N).
    """
    dofs = list(dofs)
    n = len(dofs)
    cols = min(n, 2)
    rows = math.ceil(n / cols)
    fig = _fig(4.6 * cols, 3.0 * rows)
    axes = np.atleast_1d(fig.subplots(rows, cols)).ravel()
    w = np.asarray(omega, float)
    order = np.argsort(w)
    for k, d in enumerate(dofs):
        ax = axes[k]
        ax.semilogy(w[order], np.abs(np.asarray(measured)[order, k]), "o", mfc="none", color="C3", ms=4, label="test")
        if before is not None:
            ax.semilogy(model_omega, np.abs(np.asarray(before)[:, k]), "--", color="0.55", label="before")
        ax.semilogy(model_omega, np.abs(np.asarray(after)[:, k]), "-", color="C0", label="after")
        ax.set(xlabel="ω [rad/s]", ylabel=f"|response| [{unit}]", title=f"response {d}")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=7)
    for ax in axes[n:]:
        ax.set_visible(False)
    return embed(fig)


def surface_figure(surface, point) -> dict:
    """Filled contours of log10 of a residual over two parameters, with the updated point (PNG)."""
    from .frf import contour_axes

    fig = _fig(5.4, 4.2)
    ax = fig.subplots()
    contour_axes(surface, ax)
    ax.plot(point[0], point[1], "w*", ms=12, mec="k", label="updated")
    ax.legend(fontsize=8, loc="upper right")
    ax.set_title(f"residual r² = ‖r‖² ({surface.residual})", fontsize=9)
    return embed(fig, "png")


def damage_figure(names, changes, located, stderr) -> dict:
    """Relative change of every damage unknown (bars, %), the located ones in red with their
    standard error."""
    fig = _fig(max(5.0, 0.35 * len(names) + 2.5), 3.4)
    ax = fig.subplots()
    x = np.arange(len(names))
    ch = np.array([changes[n] * 100 for n in names], float)
    colours = ["C3" if n in located else "0.6" for n in names]
    err = np.array([np.nan if e is None else e * 100 for e in ((stderr or {}).get(n) for n in names)], float)
    ax.bar(x, ch, color=colours, yerr=np.where(np.isfinite(err), err, 0.0), capsize=3)
    ax.axhline(0, color="k", lw=0.8)
    ax.set_xticks(x, names, rotation=60 if len(names) > 6 else 0, fontsize=7, ha="right" if len(names) > 6 else "center")
    ax.set(ylabel="stiffness change [%]", title="identified change of each unknown (red: located)")
    ax.grid(True, axis="y", alpha=0.3)
    return embed(fig)


def mode_shape_figure(model, shape, test, title: str, segments=None) -> dict:
    """One mode shape on the model's geometry (:func:`~femupdate.plot.shapes.mode_shape_axes`)."""
    three = needs_3d(model, shape, test, segments)
    fig = _fig(4.6, 3.8)
    ax = fig.add_subplot(projection="3d") if three else fig.add_subplot()
    mode_shape_axes(model, shape, test, segments=segments, ax=ax, title=title)
    return embed(fig)


def uniqueness_figure(cases, title: str) -> dict:
    """The (measured dofs × modes) verdict map of a uniqueness study (:func:`~femupdate.plot.uniqueness.uniqueness_axes`)."""
    modes = sorted({c["n_modes"] for c in cases})
    sets = {tuple(c["measured_dofs"]) for c in cases}
    fig = _fig(max(5.0, 0.7 * len(modes) + 4.0), max(3.0, 0.45 * len(sets) + 1.8))
    ax = fig.subplots()
    uniqueness_axes(cases, ax, title)
    ax.set(xlabel="measured modes m [–]", ylabel="measured dofs")
    return embed(fig)


def damage_map_figure(model, members: dict, changes: dict, located, segments=None) -> dict:
    """The structure with each damage unknown's members coloured by its identified change (%),
    the located ones drawn thick.

    Parameters
    ----------
    model : Model
        With node coordinates.
    members : dict
        {unknown: [(node a, node b), ...]} the members each unknown scales.
    changes : dict
        {unknown: relative change}.
    located : collection of str
    segments : array_like, optional
        Every element's node pair (drawn thin, grey), as :func:`~femupdate.plot.shapes.shape_geometry`.
    """
    from matplotlib import colormaps
    from matplotlib.cm import ScalarMappable
    from matplotlib.colors import TwoSlopeNorm

    from .shapes import shape_geometry

    geom = shape_geometry(model, segments)
    three = geom is not None and float(np.ptp(geom.xyz[:, 2])) > 1e-12 * geom.extent
    fig = _fig(6.0, 4.0)
    ax: Any = fig.add_subplot(projection="3d") if three else fig.add_subplot()
    cols = slice(0, 3) if three else slice(0, 2)
    xyz = {nd: np.asarray(model.nodes[nd], float) for nd in model.nodes}
    if geom is not None:
        for a, b in geom.segments:
            ax.plot(*geom.xyz[[a, b], cols].T, "-", color="0.8", lw=1.0)
    vals = [changes[n] * 100 for n in members if n in changes]
    lim = max([abs(v) for v in vals] + [1e-9])
    norm = TwoSlopeNorm(vcenter=0.0, vmin=-lim, vmax=lim)
    cmap = colormaps["RdBu"]
    for n, pairs in members.items():
        c = changes.get(n)
        if c is None:
            continue
        colour = cmap(norm(c * 100)) if n in located or abs(c) >= 0.005 else "0.6"  # unchanged: grey
        for a, b in pairs:
            if a in xyz and b in xyz:
                pts = np.array([xyz[a], xyz[b]])
                ax.plot(*pts[:, cols].T, "-", color=colour, lw=4.0 if n in located else 1.5, solid_capstyle="round")
                if n in located:
                    mid = pts.mean(axis=0)[cols]
                    ax.text(*mid, f" {n}: {c * 100:+.1f} %", fontsize=8, color="k")
    fig.colorbar(ScalarMappable(norm=norm, cmap=cmap), ax=ax, shrink=0.8, label="stiffness change [%]")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    if three:
        ax.set_zlabel("z [m]")
    else:
        ax.set_aspect("equal", adjustable="datalim")
    ax.set_title("identified change per member (thick: located)", fontsize=9)
    return embed(fig)
