"""``--test-points`` of the commands that read test data: test nodes placed on a structure's mesh by
their coordinates (:func:`femupdate.testpoints.map_test_data`)."""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from typing import Any

import click
import numpy as np

from .._errors import InputError
from ._common import FiniteFloat
from ._groups import option_group


@dataclasses.dataclass(frozen=True)
class TestPointsSpec:
    """``--test-points TOL`` and ``--test-points-method``, as typed."""

    __test__ = False  # not a pytest test class

    tolerance: float | None = None
    method: str = "interpolate"

    def load(self, model_path, model, data_path, measured_text: str | None = None):
        """``(model, data, mapped)``: without ``--test-points`` the model, the data read against it
        and None; with it, the data read without the model (their own node ids), placed on the
        mesh of ``model_path``, and the model in the coordinates that hold the measured dofs.

        Raises
        ------
        InputError
            A matrices model (no mesh), and as :func:`femupdate.testpoints.map_test_data`.
        """
        from ._common import load_data

        if self.tolerance is None:
            return model, load_data(data_path, model, measured_text), None
        from .summary import _structure_of

        mapped = self.place(_structure_of(model_path), model, *self.read(data_path, measured_text), data_path,
                            model_path)
        return mapped.model, mapped.data, mapped

    def read(self, data_path, measured_text: str | None = None) -> tuple[Any, dict]:
        """``(data, axes)``: the test data of ``data_path`` read without a model, their own node ids,
        global axes except at the nodes of ``axes`` ({node: R}), whose components a universal file
        gives along a local system's axes that cannot be rotated alone (a single one along a skewed
        axis: kept along those axes; :func:`femupdate.io.uff.read_uff`'s ``keep_local``).
        ``--measured-dofs``, if given, in the same terms, each one checked to be in the file."""
        from ..dofs import canonical_all
        from ..io.testdata_json import load_testdata

        sensors = None
        if measured_text is not None:
            items = [t.strip() for t in str(measured_text).split(",") if t.strip()]
            sensors = canonical_all(items, "--measured-dofs")
        axes: dict = {}
        data = load_testdata(data_path, None, sensors=sensors, keep_local=axes)
        if sensors is not None:  # read without a model, a sensor the file does not hold would pass unseen
            from ..testpoints import measured_labels

            held = set(measured_labels(data))
            absent = [d for d in sensors if d not in held]
            if absent:
                raise InputError(f"--measured-dofs: {', '.join(absent[:8])} not in {data_path} (its test nodes and "
                                 "directions in the global axes)")
        return data, axes

    def place(self, structure, model, data, axes, data_path, model_path):
        """:func:`femupdate.testpoints.map_test_data` of ``data`` (:meth:`read`) on ``structure``'s
        mesh, ``model`` its model (a damage run's element-wise one), ``axes`` as :meth:`read` gives
        them; None for ``structure``: a matrices model, refused."""
        from ..testpoints import map_test_data

        if structure is None:
            raise InputError(f"--test-points: {model_path} is a matrices model; test points are placed on a "
                             "structure's or a mesh's nodes and elements")
        try:
            return map_test_data(structure, data, self.tolerance, self.method, model=model, axes=axes)
        except InputError as exc:
            raise InputError(f"--test-points {self.tolerance:g}: {data_path}: {exc}") from None

    def relabel(self, mapped, read, data_path):
        """Further test data (``--undamaged``, a repeated test) on the test points of ``mapped``:
        their labels renamed as the first file's; a dof the first file does not measure, a test node
        elsewhere or measured along other axes is refused by name (no place in the transformed
        model).  ``read``: :meth:`read`'s ``(data, axes)``."""
        from ..dofs import parse_dof
        from ..testpoints import measured_labels, relabel

        data, axes = read
        labels = measured_labels(data)
        lost = [d for d in labels if d not in mapped.rename]
        if lost:
            raise InputError(f"--test-points: {data_path}: test dof(s) {', '.join(lost[:8])} are not measured in the "
                             "first test file, whose test points the model holds; measure the same points, or leave "
                             "them out (--measured-dofs)")
        first = mapped.data.nodes
        for node in dict.fromkeys(parse_dof(d)[0] for d in labels):  # the same id must be the same point
            if node not in data.nodes:
                raise InputError(f"--test-points: {data_path}: test node {node} has measured dofs but no coordinates")
            gap = float(np.linalg.norm(np.subtract(data.nodes[node], first[node])))
            if gap > self.tolerance:
                raise InputError(f"--test-points: {data_path}: test node {node} lies {gap:.3g} from where the first "
                                 f"test file puts it (more than the tolerance {self.tolerance:g}): the model holds the "
                                 "first file's test points; number the points alike in both files")
            if (node in axes) != (node in mapped.axes) or (
                    node in axes and not np.allclose(axes[node], mapped.axes[node], rtol=0, atol=1e-9)):
                raise InputError(f"--test-points: {data_path}: test node {node} is measured along other axes than in "
                                 "the first test file (its displacement coordinate system, or which of its components "
                                 "are measured); measure the points alike in both files")
        return relabel(data, mapped.rename)

    def announce(self, ctx, mapped) -> None:
        """The terminal's one line on where the test points went."""
        if mapped is None:
            return
        lk = mapped.map.links
        ctx.console.print(f"test points: {len(lk)} placed on the mesh ({mapped.map.method}; "
                          f"{sum(x.kind == 'element' for x in lk)} inside elements, largest distance "
                          f"{max(x.distance for x in lk):.3g})", markup=False)


def test_points_group() -> Callable:
    """``--test-points``, ``--test-points-method`` -> ``test_points``: :class:`TestPointsSpec`."""
    return option_group(
        "Test points", "test_points", lambda tp_tolerance, tp_method: TestPointsSpec(tp_tolerance, tp_method),
        click.option("--test-points", "tp_tolerance", type=FiniteFloat(min=0, min_open=True), default=None,
                     metavar="TOL",
                     help="Place the test data's nodes on MODEL's mesh by their coordinates (a universal file's "
                          "datasets 15/2411, coordinate systems applied) instead of by id: a point farther than "
                          "TOL (model length unit) from the mesh is refused by name."),
        click.option("--test-points-method", "tp_method", type=click.Choice(["interpolate", "nearest"]),
                     default="interpolate", show_default=True,
                     help="interpolate: by the shape functions of the shell or solid element the point lies in; "
                          "nearest: the nearest mesh node."),
    )
