"""Dataset 58 records (function type 4, FRFs) into FRF sets, one per excitation dof: the axis,
the dofs and their signs, the ordinate (:mod:`.ordinate`) and the units (dataset 164)."""

from __future__ import annotations

import logging
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..._errors import InputError
from ...dofs import DIRECTIONS, dof
from ...testdata import FRFData
from .conventions import ABSCISSA_FREQUENCY, AXIS_RTOL, DENOM_FORCE, check_nodes, direction_of_code, node_id
from .ordinate import read_ordinate
from .systems import System, aligned_axis

log = logging.getLogger("femupdate.io.uff")


@dataclass
class FRFSet:
    """The FRF records of one excitation dof."""

    first: str
    axis: np.ndarray
    omega: np.ndarray
    dofs: list[str] = field(default_factory=list)
    cols: list[np.ndarray] = field(default_factory=list)


def _frf_dof(node: int, direction: str, sign: float, nodes, systems: Mapping[int, System], where: str,
             role: str, keep: dict | None = None) -> tuple[str, float]:
    """The global dof and sign of a transducer along ``direction`` of its node's displacement
    system; a direction that does not lie along a global axis is refused.  With ``keep`` (test
    points only) a node in a local system keeps its own axes: ``keep[node] = R``."""
    cs = nodes.disp.get(node, 0)
    if cs == 0:
        return dof(node, direction), sign
    s = systems[cs]
    try:
        R = s.cartesian(node, "displacement")
    except InputError as exc:
        raise InputError(f"{where}: {role}: {exc}") from None
    if keep is not None:  # along the node's own axes, placed by their direction cosines (test points)
        keep[node] = R
        return dof(node, direction), sign
    j = DIRECTIONS.index(direction)
    axis = aligned_axis(R[j % 3])
    if axis is None:
        raise InputError(f"{where}: {role} node {node}: direction {direction} of {s.describe()} does not lie along "
                         f"one of the model's axes ({np.round(R[j % 3], 6).tolist()} in global axes): FRFs are read "
                         "along the model's axes only; give the data in the global system")
    i, g = axis
    return dof(node, DIRECTIONS[i + 3 * (j // 3)]), sign * g


def _values(dset: dict, where: str, nodes):
    """(response node, direction, sign), (reference ...), abscissa, ordinate values — checked."""
    try:
        rsp_node = node_id(dset["rsp_node"], where)
        ref_node = node_id(dset["ref_node"], where)
        rsp = (rsp_node, *direction_of_code(dset["rsp_dir"], f"{where}: response", rsp_node))
        ref = (ref_node, *direction_of_code(dset["ref_dir"], f"{where}: reference (excitation)", ref_node))
        x = np.atleast_1d(np.asarray(dset["x"], dtype=float))
        y = np.atleast_1d(np.asarray(dset["data"]))
    except KeyError as exc:
        raise InputError(f"{where}: missing field {exc}") from None
    except (TypeError, ValueError) as exc:
        raise InputError(f"{where}: cannot be read ({exc})") from None
    check_nodes((rsp_node, ref_node), nodes.xyz, where)
    n_pts = int(dset.get("num_pts", 0) or 0)
    if x.size != y.size or (n_pts and y.size != n_pts):
        raise InputError(
            f"{where}: header announces {n_pts} points but {y.size} values and {x.size} abscissas "
            "were read (truncated record?)"
        )
    if y.size == 0:
        raise InputError(f"{where}: no data values")
    if not np.all(np.isfinite(x)):
        raise InputError(f"{where}: NaN or infinite abscissa value(s)")
    if not np.all(np.isfinite(y)):
        raise InputError(f"{where}: NaN or infinite ordinate value(s) at {int(np.sum(~np.isfinite(y)))} frequencies")
    return rsp, ref, x, y


def _omega(dset: dict, x: np.ndarray, where: str) -> np.ndarray:
    abscissa = int(dset.get("abscissa_spec_data_type", 0))
    if abscissa not in ABSCISSA_FREQUENCY:
        raise InputError(f"{where}: abscissa specific data type {abscissa} is not frequency (18)")
    units_label = str(dset.get("abscissa_axis_units_lab", "")).lower().replace(" ", "")
    omega = x.copy() if "rad" in units_label else 2.0 * np.pi * x
    if np.any(omega < 0):
        raise InputError(f"{where}: negative frequencies")
    return omega


def _receptance(h: np.ndarray, omega: np.ndarray, kind: str, where: str) -> np.ndarray:
    """A mobility or an accelerance divided by iω or −ω²; refused where that is not finite (zero
    frequency, or a value that would overflow)."""
    if kind == "displacement":
        return h
    what = "mobility" if kind == "velocity" else "accelerance"
    if np.any(omega == 0):
        raise InputError(f"{where}: a {what} cannot be converted to receptance at zero frequency")
    with np.errstate(over="ignore", divide="ignore", invalid="ignore", under="ignore"):
        out = h / (1j * omega) if kind == "velocity" else h / (-(omega ** 2))
    if not np.all(np.isfinite(out)):
        raise InputError(f"{where}: a {what} too large for its frequencies to be converted to receptance "
                         "(a value overflows)")
    return out


def _si_factor(units: Mapping[str, Any], rsp_dir: str, ref_dir: str) -> float:
    """File units -> SI for H = response / force (dataset 164): a length L_file = L_SI * length,
    a force F_file = F_SI * force."""
    factor = float(units["force"])
    factor /= float(units["length"]) if rsp_dir in DIRECTIONS[:3] else 1.0  # a displacement (a rotation: rad)
    factor *= float(units["length"]) if ref_dir in DIRECTIONS[3:] else 1.0  # a moment excitation: force x length
    return factor


def read_frf_record(dset: dict, where: str, nodes, systems: Mapping[int, System], units: Mapping[str, Any],
                    notes: list[str], keep: dict | None = None):
    """One function-type-4 dataset 58 record -> (abscissa in file units, omega, response dof,
    excitation dof, receptance in SI); what was decided about its ordinate goes to ``notes``."""
    (rsp_node, rsp_dir, rsp_sign), (ref_node, ref_dir, ref_sign), x, y = _values(dset, where, nodes)
    omega = _omega(dset, x, where)
    denominator = int(dset.get("orddenom_spec_data_type", 0))
    if denominator not in DENOM_FORCE:
        raise InputError(f"{where}: ordinate denominator specific data type {denominator} is not a force (13); "
                         "only receptance, mobility and accelerance FRFs are read")
    ordinate = read_ordinate(dset, where, np.iscomplexobj(y))
    if ordinate.factor is not None and (rsp_dir in DIRECTIONS[3:] or ref_dir in DIRECTIONS[3:]):
        raise InputError(f"{where}: ordinate units label {str(dset.get('ordinate_axis_units_lab')).strip()!r} "
                         "(record 9, field 6) is a translation per force, but the response or the excitation is a "
                         f"rotation ({rsp_dir} / {ref_dir})")
    if ordinate.note:
        notes.append(ordinate.note)
    h = _receptance(y.astype(complex if np.iscomplexobj(y) else float), omega, ordinate.kind, where)
    rsp, rsp_sign = _frf_dof(rsp_node, rsp_dir, rsp_sign, nodes, systems, where, "response", keep)
    ref, ref_sign = _frf_dof(ref_node, ref_dir, ref_sign, nodes, systems, where, "reference (excitation)", keep)
    # H measured between transducers oriented s_rsp, s_ref: H_+ = s_rsp * s_ref * H_measured
    h = h * (rsp_sign * ref_sign)
    if ordinate.factor is not None:  # the record's own units label: dataset 164's length does not apply
        factor = ordinate.factor * (float(units["force"]) if ordinate.file_force and units else 1.0)
    else:
        factor = _si_factor(units, rsp_dir, ref_dir) if units else 1.0
    if factor != 1.0:
        with np.errstate(over="ignore", invalid="ignore", under="ignore"):
            h = h * factor
        if not np.all(np.isfinite(h)):
            raise InputError(f"{where}: ordinate value(s) too large to convert to SI (x {factor:g} overflows)")
    return x, omega, rsp, ref, h


def same_axis(a: np.ndarray, b: np.ndarray) -> bool:
    """Two frequency axes equal within the single precision of UFF abscissas."""
    if a.shape != b.shape:
        return False
    tol = AXIS_RTOL * np.abs(a) + 1e-12 * max(float(np.max(np.abs(a))), 1e-300)
    return bool(np.all(np.abs(a - b) <= tol))


def add_frf_record(sets: dict[str, FRFSet], dset: dict, where: str, k: int, nodes, systems: Mapping[int, System],
                   units: Mapping[str, Any], notes: list[str], keep: dict | None = None) -> tuple[str, str] | None:
    """Add dataset 58 record ``k`` to the FRF set of its excitation dof; (response, excitation)
    dofs, or None for a record that is not an FRF (skipped)."""
    func = int(dset.get("func_type", 0))
    if func != 4:
        log.info("%s: function type %d is not an FRF (4); record skipped", where, func)
        return None
    x, omega, rsp, ref, h = read_frf_record(dset, where, nodes, systems, units, notes, keep)
    fs = sets.get(ref)
    if fs is None:
        fs = sets[ref] = FRFSet(f"dataset 58 record {k}", x, omega)
    elif not same_axis(fs.axis, x):
        raise InputError(
            f"{where}: frequency axis ({x.size} points, {x[0]:g} .. {x[-1]:g}) differs from that of "
            f"{fs.first} ({fs.axis.size} points, {fs.axis[0]:g} .. {fs.axis[-1]:g}), the first record of "
            f"excitation dof {ref}"
        )
    if rsp in fs.dofs:
        raise InputError(f"{where}: response dof {rsp} appears in two FRF records of excitation dof {ref}")
    fs.dofs.append(rsp)
    fs.cols.append(h)
    return rsp, ref


def frf_sets_of(sets: Mapping[str, FRFSet], name: str, notes: list[str]) -> list[FRFData]:
    """One :class:`FRFData` per excitation dof (force 1 there); a note when there are several."""
    frf_sets: list[FRFData] = []
    for ref, group in sets.items():
        cplx = any(np.iscomplexobj(c) for c in group.cols)
        resp = np.column_stack([c.astype(complex) if cplx else c for c in group.cols])
        try:
            frf_sets.append(FRFData(group.omega, {ref: 1.0}, tuple(group.dofs), resp))
        except InputError as exc:
            raise InputError(f"{name}: datasets 58 of excitation dof {ref}: {exc}") from None
    if len(frf_sets) > 1:
        notes.append(f"{name}: datasets 58: {len(frf_sets)} excitation dofs (a roving-hammer or multi-reference "
                     "test), one FRF set each: " + "; ".join(f"{r} ({len(g.dofs)} response(s))"
                                                             for r, g in sets.items()))
    return frf_sets


__all__ = ["FRFSet", "read_frf_record", "add_frf_record", "frf_sets_of", "same_axis"]
