"""A test plan as a universal file the test lab imports (:func:`write_plan_uff`).

One file, written by pyuff, with:

* dataset 164 — SI units;
* dataset 2420 — one Cartesian coordinate system per sensor node, numbered as the node, whose
  local +x axis is the measuring direction of a uniaxial sensor (its rows: the local x, y, z axes
  in global axes, then the origin, the node); at a node with a triaxial sensor, or with several
  uniaxial ones, the system is aligned with the global axes and the directions are the global ones;
* dataset 15 — the sensor nodes, coordinates in the global system (0), data in the node's own
  system (its displacement coordinate system), single precision;
* dataset 2411 — the same nodes, coordinates in double precision (the lab's software reads
  either; 2411 keeps the model's coordinates to the last digit), and, when the plan places
  exciters, their nodes too (data in the global system where no sensor is);
* dataset 82 — one trace line through the sensor nodes in the plan's order, so the lab's software
  draws the layout.

Nodes without coordinates in the model (lumped systems) are placed on the x axis at 1, 2, 3, ...
in candidate order, and the file says so in the 2420 record's part name.
"""

from __future__ import annotations

import numpy as np
import pyuff

from .._errors import InputError
from ..dofs import parse_dof
from .uff.write import _atomic_write, _si_units, uff_dofs

AXES = {"x": 0, "y": 1, "z": 2}


def _frame(direction: str | None) -> np.ndarray:
    """Rows: local x, y, z axes in global axes; local x along ``direction`` (cyclic, right-handed)."""
    if direction is None:
        return np.eye(3)
    k = AXES[direction]
    return np.eye(3)[[k, (k + 1) % 3, (k + 2) % 3]]


def write_plan_uff(path, plan) -> dict:
    """Write the sensors of ``plan`` (a :class:`~femupdate.planning.PlanResult`) as a universal file.

    Parameters
    ----------
    path : str or path-like
        Output file, replaced atomically.
    plan : PlanResult

    Returns
    -------
    dict
        ``nodes`` (node numbers, in order: the sensors', then the exciters'), ``systems`` {node:
        measuring direction or ``"global"``}, ``placed`` (True when coordinates were made up for a
        lumped model), ``datasets`` (the dataset numbers written, in order).

    Raises
    ------
    InputError
        A node that is not an integer, a rotational sensor dof, or an unwritable path.
    """
    where = f"{path}"
    order: list[int] = []
    dirs: dict[int, list[str]] = {}
    for sensor in plan.sensors:
        for node, direction in uff_dofs(sensor, where):
            if direction not in AXES:
                raise InputError(f"{where}: sensor dof {node}:{direction} is a rotation; a sensor plan holds "
                                 "translations")
            if node not in dirs:
                order.append(node)
                dirs[node] = []
            dirs[node].append(direction)
    sensor_nodes = list(order)
    for d in (plan.exciters or {}).get("dofs", []):  # exciter nodes: in the geometry, not on the trace line
        node, direction = uff_dofs([d], where)[0]
        if node not in dirs:
            order.append(node)
            dirs[node] = []
    placed = any(str(n) not in plan.nodes for n in order)
    xyz = {}
    for i, n in enumerate(order):
        c = plan.nodes.get(str(n))
        xyz[n] = np.asarray(c, float) if c is not None and not placed else np.array([float(i + 1), 0.0, 0.0])
    systems = {n: (d[0] if len(d) == 1 and plan.sensor_kind == "uniaxial" else None) for n, d in dirs.items()}
    disp = [n if n in sensor_nodes else 0 for n in order]
    mats = [np.vstack([_frame(systems[n]), xyz[n]]) for n in order]
    part = "femupdate sensor plan" + (" (nodes placed on the x axis: no coordinates in the model)" if placed else "")
    sets = [
        _si_units(),
        pyuff.prepare_2420(Part_UID=1, Part_Name=part[:80], CS_sys_labels=sensor_nodes, CS_types=[0] * len(sensor_nodes),
                           CS_colors=[8] * len(sensor_nodes), CS_names=[f"sensor {n} +x {systems[n] or 'global'}"[:40]
                                                                        for n in sensor_nodes],
                           CS_matrices=[m for n, m in zip(order, mats) if n in sensor_nodes]),
        pyuff.prepare_15(node_nums=order, def_cs=[0] * len(order), disp_cs=disp, color=[1] * len(order),
                         x=[float(xyz[n][0]) for n in order], y=[float(xyz[n][1]) for n in order],
                         z=[float(xyz[n][2]) for n in order]),
        pyuff.prepare_2411(node_nums=np.array(order, dtype=int), def_cs=np.zeros(len(order), dtype=int),
                           disp_cs=np.array(disp, dtype=int), color=np.ones(len(order), dtype=int),
                           x=np.array([xyz[n][0] for n in order], float), y=np.array([xyz[n][1] for n in order], float),
                           z=np.array([xyz[n][2] for n in order], float)),
        pyuff.prepare_82(trace_num=1, n_nodes=len(sensor_nodes), color=1, id=f"{plan.model} sensors"[:80],
                         nodes=np.array(sensor_nodes, dtype=int)),
    ]
    _atomic_write(path, sets)
    return {"nodes": order, "systems": {n: systems[n] or "global" for n in order}, "placed": placed,
            "datasets": [164, 2420, 15, 2411, 82]}


def sensor_node(dof: str) -> str:
    """The node of a sensor dof, as a string."""
    return str(parse_dof(dof)[0])


__all__ = ["write_plan_uff"]
