"""Test points on a mesh: test nodes placed on a shell or solid mesh by their coordinates
(:mod:`.locate`), and measured dofs that are combinations of the mesh's dofs carried as dofs of an
exactly transformed model (:mod:`.observe`).  :func:`map_test_data` does both."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
import scipy.sparse as sp

from .._errors import InputError
from ..dofs import parse_dof
from .locate import METHODS, PointLink, PointMap, closest_in_elements, locate_points
from .observe import measured_labels, observation_rows, observed_model, relabel


@dataclass(frozen=True, eq=False)
class MappedTest:
    """Test data placed on a mesh (:func:`map_test_data`).

    Attributes
    ----------
    model : Model
        The model in coordinates holding every measured combination (:func:`observed_model`);
        the structure's model itself when every test dof is a model dof.
    data : TestData
        The test data with labels of ``model``.
    map : PointMap
        Where each test node lies.
    rename : dict of str to str
        Test label (test node id, global direction) -> label in ``data``.
    T : scipy.sparse.csr_array
        ``u = T q``: the structure model's dofs from ``model``'s.
    base : Model or None
        The structure's model itself (its dofs are the rows of ``T``).
    axes : dict
        Test nodes measured along their own axes: {node: R, rows the axes in global axes}.
    """

    model: Any
    data: object
    map: PointMap
    rename: dict
    T: sp.csr_array
    base: Any = None
    axes: dict = field(default_factory=dict)

    def mesh_shapes(self, shapes) -> np.ndarray:
        """Shapes of ``model`` (its dofs, one column per shape) on the structure's own dofs:
        ``u = T q``, the mesh dofs a test point replaced given back their values.

        Parameters
        ----------
        shapes : array_like, shape ``(n,)`` or ``(n, r)``
            In ``model``'s dofs (e.g. ``model_modes(mapped.model).shapes``).

        Returns
        -------
        numpy.ndarray
            Same number of columns, one row per dof of ``base`` (``base.dofs``).
        """
        q = np.asarray(shapes)
        return np.asarray(self.T @ q)

    def mesh_shape_json(self, shape: dict) -> dict:
        """A shape written ``{dof: value}`` at every dof of ``model`` (an update's
        ``expanded_shapes``) on the structure's dofs (:meth:`mesh_shapes`), followed by the values at
        the test points' own dofs (``T<test node>:<dir>``, the observed combinations)."""
        assert self.base is not None
        q = np.array([float(shape.get(d, 0.0)) for d in self.model.dofs])
        u = self.mesh_shapes(q)
        out = {d: float(v) for d, v in zip(self.base.dofs, u)}
        base = set(self.base.dofs)
        out.update({d: float(shape[d]) for d in self.model.dofs if d not in base and d in shape})
        return out

    def to_json(self) -> dict:
        """The map for results: :meth:`PointMap.to_json` with each point's dofs as the data now label them."""
        out = self.map.to_json()
        by_node: dict = {}
        for old, new in self.rename.items():
            node = old.rsplit(":", 1)[0]
            by_node.setdefault(node, {})[old.rsplit(":", 1)[1]] = new
        for p in out["points"]:
            p["dofs"] = by_node.get(str(p["test_node"]), {})
            if p["test_node"] in self.axes:  # its directions are along these axes, not the global ones
                p["axes"] = np.asarray(self.axes[p["test_node"]], float).tolist()
        return out


def map_test_data(structure, data, tolerance: float, method: str = "interpolate", *, model=None,
                  prefix: str = "T", axes=None) -> MappedTest:
    """Place test data measured at test nodes on a structure's mesh.

    Parameters
    ----------
    structure : Structure
        The mesh (node coordinates, shells and solids).
    data : TestData
        Read without a model (:func:`femupdate.io.uff.read_uff` ``(path)``): labels
        ``"<test node>:<dir>"`` in the global axes (local displacement systems already rotated),
        ``data.nodes`` the test nodes' global coordinates in the mesh's length unit.  Only the
        nodes with measured dofs are placed (geometry-only nodes of the file are not).
    tolerance : float
        Largest distance from a test point to the mesh (mesh length unit).
    method : {"interpolate", "nearest"}, default "interpolate"
        :func:`locate_points`.
    model : Model, optional
        ``structure.build()`` if not given.
    prefix : str, default "T"
        Node-name prefix of the new dofs (``"T101:z"``).
    axes : mapping of node to array_like (3, 3), optional
        Test nodes whose labels are along their own axes (rows: those axes in global axes):
        :func:`femupdate.io.uff.read_uff`'s ``keep_local``, a single component along a skewed
        axis (:func:`observation_rows`).

    Returns
    -------
    MappedTest

    Raises
    ------
    InputError
        As :func:`locate_points`, :func:`observation_rows` and :func:`observed_model`.
    """
    if model is None:
        model = structure.build()
    labels = measured_labels(data)
    if not labels:
        raise InputError("test points: the test data measure no dof")
    used = list(dict.fromkeys(parse_dof(lab)[0] for lab in labels))  # nodes of the geometry only are not placed
    lost = [n for n in used if n not in data.nodes]
    if lost:
        raise InputError(f"test node(s) {', '.join(map(str, lost[:8]))} have measured dofs but no coordinates: give "
                         "them in the test file's geometry (dataset 15 or 2411)")
    pmap = locate_points(structure, {n: data.nodes[n] for n in used}, tolerance, method)
    sdofs = {lab for g in structure.groups for row in g.labels for lab in row}
    rename, rows = observation_rows(pmap, labels, model, sdofs, prefix, axes)
    index = {d: i for i, d in enumerate(model.dofs)}
    direct = [index[v] for v in rename.values() if v in index]
    new, T = observed_model(model, rows, direct)
    return MappedTest(new, relabel(data, rename), pmap, rename, T, model, dict(axes or {}))


__all__ = ["METHODS", "MappedTest", "PointLink", "PointMap", "closest_in_elements", "locate_points",
           "map_test_data", "measured_labels", "observation_rows", "observed_model", "relabel"]
