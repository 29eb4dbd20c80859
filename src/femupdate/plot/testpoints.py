"""The test points on the mesh (:mod:`femupdate.testpoints`): the mesh's edges, each test point
and where it was placed."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np


def test_points_figure(nodes: Mapping, segments, points: list[dict], title: str = "") -> dict:
    """The mesh's edges (grey), the test points (red, labelled with their test node ids) and, for a
    point off the mesh, a line to where it was placed (the weighted mesh nodes).

    Parameters
    ----------
    nodes : mapping of int to (x, y, z)
        The mesh's node coordinates.
    segments : array_like of int, shape ``(s, 2)``, optional
        Node pairs to draw (the elements' edges).
    points : list of dict
        ``test_points["points"]`` of a result (:meth:`femupdate.testpoints.PointMap.to_json`).
    title : str, optional

    Returns
    -------
    dict
        The embedded figure (:func:`femupdate.plot.report.embed`).
    """
    from .report import _fig, embed

    fig = _fig(5.2, 4.2)
    ax = fig.add_subplot(projection="3d")
    if segments is not None and len(segments):
        seg = np.asarray(segments, dtype=np.int64)
        keep = [k for k, (a, b) in enumerate(seg) if int(a) in nodes and int(b) in nodes]
        for a, b in seg[keep]:
            xa, xb = np.asarray(nodes[int(a)]), np.asarray(nodes[int(b)])
            ax.plot(*np.column_stack([xa, xb]), color="0.7", lw=0.6)
    for p in points:
        x = np.asarray(p["xyz"], float)
        w = np.asarray(p["weights"], float)
        placed = w @ np.array([nodes[int(n)] for n in p["mesh_nodes"]], float) if p["mesh_nodes"] else x
        ax.scatter(*x, color="tab:red", s=14, depthshade=False)
        if np.linalg.norm(placed - x) > 0:
            ax.plot(*np.column_stack([x, placed]), color="tab:red", lw=0.8)
        ax.text(*x, f" {p['test_node']}", fontsize=7, color="tab:red")
    xyz = np.array([*nodes.values(), *(p["xyz"] for p in points)], float)
    span = np.ptp(xyz, axis=0)
    ax.set_box_aspect(np.maximum(span, 0.05 * max(float(span.max()), 1e-300)))  # true proportions
    ax.set(xlabel="x", ylabel="y", zlabel="z")
    if title:
        ax.set_title(title, fontsize=9)
    return embed(fig)
