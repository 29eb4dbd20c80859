"""Reading universal files: :func:`read_uff` (datasets 15, 2411, 55, 58 and 164; see the package notes)."""

from __future__ import annotations

import logging
import math
import os
from collections import Counter
from collections.abc import Iterable, Mapping, Sequence
from typing import Any

import numpy as np
import pyuff

from ..._errors import InputError
from ...dofs import DIRECTIONS, canonical_all, describe, dof, parse_dof
from ...testdata import FRFData, MeasuredMode, TestData
from .conventions import (ABSCISSA_FREQUENCY, AXIS_RTOL, DENOM_FORCE, NODE_SETS, ORD_ACCELERATION, ORD_DISPLACEMENT,
                          ORD_VELOCITY, READ_SETS, UNIT_SYSTEMS, direction_of_code)

__all__ = ["read_uff"]

log = logging.getLogger("femupdate.io.uff")  # the package's logger, as before the split into modules


# ---------------------------------------------------------------------------- small helpers
def _node_id(value, where: str) -> int:
    try:
        v = float(value)
    except (TypeError, ValueError, OverflowError):
        raise InputError(f"{where}: node number {str(value)[:20]!r} is not a number of at most 10 digits") from None
    if not math.isfinite(v) or v != int(v) or abs(v) > 2**31:
        raise InputError(f"{where}: node number {value!r} is not an integer (of at most 10 digits)")
    return int(v)

def _known_dofs(model_dofs, model) -> frozenset[str] | None:
    if model_dofs is not None and model is not None:
        raise InputError("read_uff: give model_dofs or model, not both")
    if model is not None:
        model_dofs = getattr(model, "dofs", None)
        if model_dofs is None:
            raise InputError(f"read_uff: model {model!r} has no dofs")
    if model_dofs is None:
        return None
    if isinstance(model_dofs, str):
        raise InputError("read_uff: model_dofs must be a sequence of labels such as ['1:x', '2:x'], not one string")
    return frozenset(canonical_all(model_dofs, "model_dofs"))


def _check_in_model(labels: Iterable[str], known: frozenset[str] | None, where: str) -> None:
    if known is None:
        return
    missing = [lab for lab in labels if lab not in known]
    if missing:
        raise InputError(f"{where}: dof(s) not in the model: {describe(missing)}")


def _check_nodes(used: Iterable[int], nodes: Mapping[int, object], where: str) -> None:
    if not nodes:
        return
    unknown = sorted({int(n) for n in used} - set(nodes))
    if unknown:
        shown = ", ".join(str(n) for n in unknown[:8]) + (f" … ({len(unknown)} in all)" if len(unknown) > 8 else "")
        raise InputError(f"{where}: unknown node(s) {shown}: not in the file's node datasets (15/2411)")


# ---------------------------------------------------------------------------- reading
def _delimiters(data: bytes) -> list[int]:
    """Offsets of the ``'    -1'`` lines that open and close datasets, found as pyuff finds them."""
    out: list[int] = []
    ind = -1
    while True:
        ind = data.find(b"    -1", ind + 1)
        if ind == -1:
            return out
        end = data[ind + 6:ind + 80]
        if ind + 6 == len(data) or end[:1] in (b"\n", b"\r") or (len(end) == 74 and not end.strip(b" ")):
            out.append(ind)


def _check_complete(name: str, types: list[int]) -> None:
    """A file cut inside its last dataset: pyuff silently drops that dataset (an odd number of
    delimiters), so the data would be read as if the record were not there."""
    with open(name, "rb") as fh:
        data = fh.read()
    tags = _delimiters(data)
    if len(tags) % 2 == 0:
        return
    head = data[tags[-1]:].splitlines()
    try:
        t = int(head[1][:6])
    except (IndexError, ValueError):
        raise InputError(f"{name}: truncated: the file ends inside its last dataset (block {len(types) + 1}), "
                         "which has no closing '    -1' line") from None
    k = sum(1 for x in types if x == t) + 1
    raise InputError(f"{name}: dataset {t} record {k} (block {len(types) + 1} of the file) is truncated: the file ends "
                     "inside it, with no closing '    -1' line")


def _read_records(name: str) -> list[tuple[int, int, dict]]:
    """``(dataset type, record number within the type, pyuff dict)`` of the sets we read."""
    if not os.path.exists(name):
        raise InputError(f"{name}: file not found")
    if os.path.isdir(name):
        raise InputError(f"{name}: is a directory, not a universal file")
    try:
        uff = pyuff.UFF(name)
        types = [int(t) for t in np.atleast_1d(uff.get_set_types())]
    except Exception as exc:  # pyuff raises bare Exception for unreadable files
        log.debug("pyuff failed to scan %s", name, exc_info=True)
        raise InputError(f"{name}: cannot be read as a universal file ({exc})") from None
    _check_complete(name, types)
    if not types:
        raise InputError(f"{name}: not a universal file (UFF): no datasets delimited by '    -1' lines")
    counts: Counter[int] = Counter()
    out = []
    for i, t in enumerate(types):
        if t not in READ_SETS:
            log.debug("%s: block %d: dataset %d skipped", name, i + 1, t)
            continue
        counts[t] += 1
        where = f"{name}: dataset {t} record {counts[t]}"
        try:
            dset = uff.read_sets(i)  # one index -> one dict (pyuff unwraps one-element lists)
        except Exception as exc:
            log.debug("pyuff failed on block %d of %s", i + 1, name, exc_info=True)
            raise InputError(f"{where} (block {i + 1} of the file) is malformed: pyuff: {exc}") from None
        if isinstance(dset, list):  # defensive: other pyuff versions
            dset = dset[0] if dset else {}
        out.append((t, counts[t], dset))
    return out


def _read_nodes(dset: dict, where: str, nodes: dict[int, tuple[float, float, float]]) -> None:
    try:
        nums = np.atleast_1d(np.asarray(dset["node_nums"], dtype=float))
        xyz = np.column_stack([np.atleast_1d(np.asarray(dset[k], dtype=float)) for k in ("x", "y", "z")])
    except (KeyError, ValueError, TypeError) as exc:
        raise InputError(f"{where}: node coordinates cannot be read ({exc})") from None
    if xyz.shape[0] != nums.size:
        raise InputError(f"{where}: {nums.size} node numbers but {xyz.shape[0]} coordinate triples (truncated record?)")
    if not np.all(np.isfinite(xyz)):
        bad = [_node_id(n, where) for n, ok in zip(nums, np.isfinite(xyz).all(axis=1)) if not ok]
        raise InputError(f"{where}: NaN or infinite coordinate(s) at node(s) {', '.join(map(str, bad[:8]))}")
    for n, p in zip(nums, xyz):
        nid = _node_id(n, where)
        p = (float(p[0]), float(p[1]), float(p[2]))
        old = nodes.get(nid)
        if old is not None and not np.allclose(old, p, rtol=AXIS_RTOL, atol=1e-9):
            raise InputError(f"{where}: node {nid} defined twice with different coordinates {old} and {p}")
        nodes.setdefault(nid, p)


def _read_units(dset: dict, where: str) -> dict:
    try:
        code = int(dset["units_code"])
        units: dict[str, Any] = {
            "code": code,
            "system": UNIT_SYSTEMS.get(code, "unknown"),
            "description": str(dset.get("units_description", "")).strip(),
            "temperature_mode": int(dset.get("temp_mode", 0)),
            "length": float(dset["length"]),
            "force": float(dset["force"]),
            "temperature": float(dset["temp"]),
            "temperature_offset": float(dset["temp_offset"]),
        }
    except (KeyError, ValueError, TypeError) as exc:
        raise InputError(f"{where}: units cannot be read ({exc})") from None
    factors = [units[k] for k in ("length", "force", "temperature", "temperature_offset")]
    if not all(math.isfinite(v) for v in factors):
        raise InputError(f"{where}: NaN or infinite unit factor(s)")
    return units


def _read_mode(dset: dict, where: str, nodes: Mapping[int, object], known: frozenset[str] | None):
    """One dataset 55 record -> MeasuredMode (or None for records that are not modes)."""
    analysis = int(dset.get("analysis_type", 0))
    if analysis not in (2, 3, 7):
        log.warning("%s: analysis type %d is not a mode (2, 3 or 7); record skipped", where, analysis)
        return None
    ndv = int(dset.get("n_data_per_node", 0))
    data_ch = int(dset.get("data_ch", 0))
    if ndv not in (3, 6) or data_ch not in (0, 2, 3):
        raise InputError(
            f"{where}: data characteristic {data_ch} with {ndv} value(s) per node is not a mode shape "
            "(expected 3-dof translations or 6-dof translations and rotations)"
        )
    node_nums = [_node_id(n, where) for n in np.atleast_1d(dset.get("node_nums", []))]
    comps = []
    for j in range(6):
        r = dset.get(f"r{j + 1}")
        if r is None:
            continue
        r = np.atleast_1d(np.asarray(r))
        if r.size == 0 and not node_nums:
            continue
        if r.size != len(node_nums):
            raise InputError(
                f"{where}: {len(node_nums)} nodes but {r.size} values of component r{j + 1} (truncated record?)"
            )
        comps.append((DIRECTIONS[j], r))
    _check_nodes(node_nums, nodes, where)
    labels, values = [], []
    for i, n in enumerate(node_nums):
        for direction, r in comps:
            labels.append(dof(n, direction))
            values.append(r[i])
    shape = np.asarray(values) if values else np.zeros(0)
    if shape.size and not np.all(np.isfinite(shape)):
        bad = [lab for lab, v in zip(labels, shape) if not np.isfinite(v)]
        raise InputError(f"{where}: NaN or infinite value(s) at dof(s) {describe(bad)}")
    if known is not None and labels:
        # UFF pads 3- and 6-dof vectors with zeros (dataset 55 note 15); drop zero padding at
        # dofs the model lacks, at nodes the model has.  Anything else must be in the model.
        model_nodes = {parse_dof(k)[0] for k in known}
        keep = [
            lab in known or not (parse_dof(lab)[0] in model_nodes and v == 0)
            for lab, v in zip(labels, shape)
        ]
        labels = [lab for lab, k in zip(labels, keep) if k]
        shape = shape[np.asarray(keep, dtype=bool)]
        _check_in_model(labels, known, where)
    mode_n = dset.get("mode_n")
    label = str(int(mode_n)) if mode_n is not None else ""
    try:
        if analysis == 2:
            freq = float(dset["freq"])
            if not math.isfinite(freq) or freq < 0:
                raise InputError(f"frequency {freq!r} Hz must be finite and >= 0")
            return MeasuredMode.from_frequency(freq, tuple(labels), shape, label)
        eig = complex(dset["eig"])  # s = -zeta*omega_n + i*omega_d, rad/s
        if not (math.isfinite(eig.real) and math.isfinite(eig.imag)):
            raise InputError(f"complex eigenvalue {eig!r} is not finite")
        return MeasuredMode(abs(eig) ** 2, tuple(labels), shape, label)
    except KeyError as exc:
        raise InputError(f"{where}: missing field {exc} for analysis type {analysis}") from None
    except InputError as exc:
        raise InputError(f"{where}: {exc}") from None


def _read_frf_record(dset: dict, where: str):
    """One function-type-4 dataset 58 record -> (abscissa in file units, omega, response dof,
    excitation dof, receptance)."""
    try:
        rsp_node = _node_id(dset["rsp_node"], where)
        ref_node = _node_id(dset["ref_node"], where)
        rsp_dir, rsp_sign = direction_of_code(dset["rsp_dir"], f"{where}: response", rsp_node)
        ref_dir, ref_sign = direction_of_code(dset["ref_dir"], f"{where}: reference (excitation)", ref_node)
        x = np.atleast_1d(np.asarray(dset["x"], dtype=float))
        y = np.atleast_1d(np.asarray(dset["data"]))
    except KeyError as exc:
        raise InputError(f"{where}: missing field {exc}") from None
    except (TypeError, ValueError) as exc:
        raise InputError(f"{where}: cannot be read ({exc})") from None
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
    abscissa = int(dset.get("abscissa_spec_data_type", 0))
    if abscissa not in ABSCISSA_FREQUENCY:
        raise InputError(f"{where}: abscissa specific data type {abscissa} is not frequency (18)")
    units_label = str(dset.get("abscissa_axis_units_lab", "")).lower().replace(" ", "")
    omega = x.copy() if "rad" in units_label else 2.0 * np.pi * x
    if np.any(omega < 0):
        raise InputError(f"{where}: negative frequencies")
    ordinate = int(dset.get("ordinate_spec_data_type", 0))
    denominator = int(dset.get("orddenom_spec_data_type", 0))
    if denominator not in DENOM_FORCE:
        raise InputError(f"{where}: ordinate denominator specific data type {denominator} is not a force (13); "
                         "only receptance, mobility and accelerance FRFs are read")
    h = y.astype(complex if np.iscomplexobj(y) else float)
    if ordinate in (ORD_VELOCITY, ORD_ACCELERATION):
        if np.any(omega == 0):
            raise InputError(f"{where}: a {'mobility' if ordinate == ORD_VELOCITY else 'accelerance'} "
                             "cannot be converted to receptance at zero frequency")
        h = h / (1j * omega) if ordinate == ORD_VELOCITY else h / (-(omega**2))
    elif ordinate not in ORD_DISPLACEMENT:
        raise InputError(f"{where}: ordinate specific data type {ordinate} is not displacement (8), "
                         "velocity (11) or acceleration (12)")
    # H measured between transducers oriented s_rsp, s_ref: H_+ = s_rsp * s_ref * H_measured
    h = h * (rsp_sign * ref_sign)
    return x, omega, dof(rsp_node, rsp_dir), dof(ref_node, ref_dir), (rsp_node, ref_node), h


def _same_axis(a: np.ndarray, b: np.ndarray) -> bool:
    if a.shape != b.shape:
        return False
    tol = AXIS_RTOL * np.abs(a) + 1e-12 * max(float(np.max(np.abs(a))), 1e-300)
    return bool(np.all(np.abs(a - b) <= tol))


def read_uff(
    path: str | os.PathLike,
    *,
    model_dofs: Sequence[str] | None = None,
    model=None,
) -> TestData:
    r"""Read test data from a universal file.

    Parameters
    ----------
    path : str or path-like
        The universal file (ASCII; binary 58b records are read too).
    model_dofs : sequence of str, optional
        Dof labels of the model the data will be compared with. Every dof in the data must be
        one of them, except zero-valued padding components of dataset 55 (a 6-dof record read
        for a planar model) at nodes the model has, which are dropped.
    model : Model, optional
        Alternative to ``model_dofs``: its ``dofs`` are used.

    Returns
    -------
    TestData
        ``modes`` (ordered by frequency), ``frf`` (or ``None``), ``units`` and ``nodes``.

        * Dataset 55, analysis type 2 (normal mode): the eigenvalue is
          :math:`\lambda = (2\pi f)^2` from the record's frequency :math:`f` in Hz.
          Analysis types 3 and 7 (complex modes): the record's complex eigenvalue
          :math:`s = -\zeta\omega_n + i\omega_d` (rad/s) gives :math:`\lambda = |s|^2 = \omega_n^2`;
          shapes stay complex. All components a record provides are kept (zeros included),
          labelled node by node ``x y z`` or ``x y z rx ry rz``.
        * Dataset 58, function type 4 (FRF; other function types are skipped): every record
          must share one excitation (reference) dof and one frequency axis. The abscissa is in Hz
          (converted to :math:`\omega = 2\pi f` rad/s) unless its units label says rad/s. The
          ordinate is a receptance (displacement / force) unless the ordinate specific data type
          says velocity (mobility, divided by :math:`i\omega`) or acceleration (accelerance,
          divided by :math:`-\omega^2`). Negative direction codes negate the data, for the
          response and for the reference alike. The force is 1 at the excitation dof.
        * Dataset 164: ``units`` = {``code``, ``system`` (e.g. ``"SI"``), ``description``,
          ``temperature_mode``, ``length``, ``force``, ``temperature``,
          ``temperature_offset``}; the factors are pyuff's (file units -> SI: divide by them).
          Data are *not* converted to SI.
        * Datasets 15 and 2411: ``nodes`` = {id: (x, y, z)}. When present, every node used by a
          mode or FRF record must be among them.

    Raises
    ------
    InputError
        Missing, unreadable or non-UFF file; a malformed record; NaN values; direction codes
        other than ±1..±6; FRFs with different excitation dofs or frequency axes; unknown nodes
        or dofs not in the model; a file with neither modes nor FRFs. The message names the file
        and the record (``"f.uff: dataset 58 record 3: ..."``).
    """
    name = os.fspath(path)
    known = _known_dofs(model_dofs, model)
    records = _read_records(name)

    nodes: dict[int, tuple[float, float, float]] = {}
    units: dict = {}
    for t, k, dset in records:
        where = f"{name}: dataset {t} record {k}"
        if t in NODE_SETS:
            _read_nodes(dset, where, nodes)
        elif t == 164:
            u = _read_units(dset, where)
            if units and u != units:
                raise InputError(
                    f"{where}: a second units dataset ({u['system']}) differs from the first ({units['system']})"
                )
            units = u

    modes: list[MeasuredMode] = []
    frf_axis: np.ndarray | None = None
    frf_omega: np.ndarray | None = None
    frf_ref: str | None = None
    frf_first: str | None = None
    frf_dofs: list[str] = []
    frf_cols: list[np.ndarray] = []
    for t, k, dset in records:
        where = f"{name}: dataset {t} record {k}"
        if t == 55:
            m = _read_mode(dset, where, nodes, known)
            if m is not None:
                modes.append(m)
        elif t == 58:
            func = int(dset.get("func_type", 0))
            if func != 4:
                log.info("%s: function type %d is not an FRF (4); record skipped", where, func)
                continue
            x, omega, rsp, ref, used_nodes, h = _read_frf_record(dset, where)
            _check_nodes(used_nodes, nodes, where)
            _check_in_model([rsp, ref], known, where)
            if frf_ref is None:
                frf_ref, frf_first, frf_axis, frf_omega = ref, f"dataset 58 record {k}", x, omega
            elif ref != frf_ref:
                raise InputError(
                    f"{where}: excitation dof {ref} differs from {frf_ref} of {frf_first}; "
                    "one file must hold the FRFs of one excitation dof"
                )
            elif frf_axis is None:  # set together with frf_ref
                raise RuntimeError("internal error: an FRF reference without its frequency axis")
            elif not _same_axis(frf_axis, x):
                raise InputError(
                    f"{where}: frequency axis ({x.size} points, {x[0]:g} .. {x[-1]:g}) differs from that of "
                    f"{frf_first} ({frf_axis.size} points, {frf_axis[0]:g} .. {frf_axis[-1]:g})"
                )
            if rsp in frf_dofs:
                raise InputError(f"{where}: response dof {rsp} appears in two FRF records")
            frf_dofs.append(rsp)
            frf_cols.append(h)

    frf = None
    if frf_cols:
        cplx = any(np.iscomplexobj(c) for c in frf_cols)
        resp = np.column_stack([c.astype(complex) if cplx else c for c in frf_cols])
        if frf_omega is None or frf_ref is None:  # both set with the first FRF record
            raise InputError(f"{name}: datasets 58: no frequency axis or excitation dof")
        try:
            frf = FRFData(frf_omega, {frf_ref: 1.0}, tuple(frf_dofs), resp)
        except InputError as exc:
            raise InputError(f"{name}: datasets 58: {exc}") from None
    if not modes and frf is None:
        raise InputError(f"{name}: no usable data: no mode records (dataset 55) and no FRF records (dataset 58)")
    order = sorted(range(len(modes)), key=lambda i: modes[i].eigenvalue)
    log.info("%s: %d mode(s), %d FRF(s), %d node(s)", name, len(modes), len(frf_dofs), len(nodes))
    return TestData(modes=tuple(modes[i] for i in order), frf=frf, units=units, nodes=nodes)
