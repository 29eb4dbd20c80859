"""A test plan's layout drawn on the structure (:mod:`femupdate.planning`): the elements (grey),
the sensors (red arrows along their measuring directions) and the exciters (blue)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

_AXIS = {"x": 0, "y": 1, "z": 2}


def plan_layout_figure(nodes: Mapping[str, Sequence[float]], segments: Sequence[Sequence], sensors: Sequence[Sequence[str]],
                       exciters: Sequence[str] = (), title: str = "") -> dict:
    """The layout of a plan on the structure.

    Parameters
    ----------
    nodes : mapping of str to (x, y, z)
        Node coordinates (node ids as strings).
    segments : sequence of (node, node)
        Element edges to draw (node ids); may be empty.
    sensors : sequence of sequence of str
        The plan's sensors, each as its dof labels (``"3:y"``).
    exciters : sequence of str
        The exciters' dofs.
    title : str, optional

    Returns
    -------
    dict
        The embedded figure (:func:`femupdate.plot.report.embed`).
    """
    from ..dofs import parse_dof
    from .report import _fig, embed

    xyz = {str(k): np.asarray(v, float).reshape(3) for k, v in nodes.items()}
    pts = np.array(list(xyz.values())) if xyz else np.zeros((1, 3))
    three = bool(np.ptp(pts[:, 2]) > 0)
    span = float(np.max(np.ptp(pts, axis=0))) or 1.0
    fig = _fig(5.6, 4.2)
    ax: Any = fig.add_subplot(projection="3d") if three else fig.add_subplot()
    dim = 3 if three else 2

    def line(a, b, **kw):
        ax.plot(*np.column_stack([a[:dim], b[:dim]]), **kw)

    for a, b in segments:
        if str(a) in xyz and str(b) in xyz:
            line(xyz[str(a)], xyz[str(b)], color="0.7", lw=0.8)
    ax.scatter(*pts[:, :dim].T, color="0.55", s=4)
    arrow = 0.08 * span
    labels: dict[str, list[str]] = {}
    for k, sensor in enumerate(sensors):
        node = str(parse_dof(sensor[0])[0])
        if node not in xyz:
            continue
        x = xyz[node]
        ax.scatter(*x[:dim], color="tab:red", s=22, marker="s" if len(sensor) > 1 else "o", zorder=3)
        for d in sensor:
            direction = parse_dof(d)[1]
            if direction in _AXIS:
                e = np.eye(3)[_AXIS[direction]]
                line(x, x + arrow * e, color="tab:red", lw=1.6)
        labels.setdefault(node, []).append(f"S{k + 1}")
    for node, lab in labels.items():  # one label per node: "S1,S2" for two uniaxial sensors there
        text = " " + ",".join(lab)
        ax.annotate(text, tuple(xyz[node][:2]), fontsize=7, color="tab:red") if not three else ax.text(
            *xyz[node], text, fontsize=7, color="tab:red")
    for k, d in enumerate(exciters):
        ex_node, direction = parse_dof(d)
        at = xyz.get(str(ex_node))
        if at is None:
            continue
        x = at
        ax.scatter(*x[:dim], color="tab:blue", s=60, marker="^", zorder=4, facecolors="none")
        if direction in _AXIS:
            e = np.eye(3)[_AXIS[direction]]
            line(x - 1.3 * arrow * e, x, color="tab:blue", lw=2.0)
        ax.annotate(f" F{k + 1}", tuple(x[:2]), xytext=(4, -10), textcoords="offset points", fontsize=7,
                    color="tab:blue") if not three else ax.text(*x, f" F{k + 1}", fontsize=7, color="tab:blue")
    if three:
        ax.set_box_aspect(np.maximum(np.ptp(pts, axis=0), 0.05 * span))
        ax.set(xlabel="x", ylabel="y", zlabel="z")
    else:
        ax.set_aspect("equal", adjustable="datalim")
        ax.set(xlabel="x", ylabel="y")
    if title:
        ax.set_title(title, fontsize=9)
    return embed(fig)


__all__ = ["plan_layout_figure"]
