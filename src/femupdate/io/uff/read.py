"""Reading universal files: :func:`read_uff` (datasets 15, 18, 55, 58, 164, 2411 and 2420; see the package notes)."""

from __future__ import annotations

import logging
import math
import os
from collections import Counter
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pyuff

from ..._errors import InputError
from ..._limits import MAX_MAGNITUDE
from ...dofs import DIRECTIONS, canonical_all, describe, dof, parse_dof
from ...testdata import FRFData, MeasuredMode, TestData
from .conventions import AXIS_RTOL, NODE_SETS, READ_SETS, UNIT_SYSTEMS
from .conventions import check_nodes as _check_nodes, node_id as _node_id
from .frf_records import FRFSet, add_frf_record, frf_sets_of
from .systems import System, read_18, read_2420, resolve_18, unrotatable

__all__ = ["read_uff"]

log = logging.getLogger("femupdate.io.uff")  # the package's logger, as before the split into modules


# ---------------------------------------------------------------------------- small helpers
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
    known = _Known(canonical_all(model_dofs, "model_dofs"))
    known.model = model
    return known


class _Known(frozenset):
    """The model's dofs, and the model (for the note on dofs its constraints eliminated)."""

    model = None


def _check_in_model(labels: Iterable[str], known: frozenset[str] | None, where: str) -> None:
    if known is None:
        return
    missing = [lab for lab in labels if lab not in known]
    if missing:
        from ...constraints import dependent_note

        note = dependent_note(getattr(known, "model", None), missing)
        raise InputError(f"{where}: dof(s) not in the model: {describe(missing)}{note}")


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


@dataclass
class _Nodes:
    """The nodes of the file: global coordinates (file units) and displacement systems."""

    xyz: dict[int, tuple[float, float, float]] = field(default_factory=dict)
    disp: dict[int, int] = field(default_factory=dict)
    where: dict[int, str] = field(default_factory=dict)


def _read_nodes(dset: dict, where: str, out: _Nodes, systems: Mapping[int, System]) -> None:
    try:
        nums = np.atleast_1d(np.asarray(dset["node_nums"], dtype=float))
        xyz = np.column_stack([np.atleast_1d(np.asarray(dset[k], dtype=float)) for k in ("x", "y", "z")])
        cs = {k: np.atleast_1d(np.asarray(dset.get(k, np.zeros(nums.size)), dtype=float)) for k in ("def_cs", "disp_cs")}
    except (KeyError, ValueError, TypeError) as exc:
        raise InputError(f"{where}: node coordinates cannot be read ({exc})") from None
    if xyz.shape[0] != nums.size or any(v.size != nums.size for v in cs.values()):
        raise InputError(f"{where}: {nums.size} node numbers but {xyz.shape[0]} coordinate triples (truncated record?)")
    if not np.all(np.isfinite(xyz)):
        bad = [_node_id(n, where) for n, ok in zip(nums, np.isfinite(xyz).all(axis=1)) if not ok]
        raise InputError(f"{where}: NaN or infinite coordinate(s) at node(s) {', '.join(map(str, bad[:8]))}")
    for n, p, dcs, ucs in zip(nums, xyz, cs["def_cs"], cs["disp_cs"]):
        nid = _node_id(n, where)
        dcs, ucs = _node_id(dcs, f"{where}: node {nid}: coordinate system"), _node_id(ucs, f"{where}: node {nid}: coordinate system")
        if dcs != 0:  # coordinates given in a local system
            s = systems.get(dcs)
            if s is None:
                raise InputError(f"{where}: node {nid}: its definition coordinate system {dcs} is not defined in the "
                                 "file (datasets 2420, 18)")
            try:
                R = s.cartesian(nid, "definition")
            except InputError as exc:
                raise InputError(f"{where}: {exc}") from None
            p = s.origin + R.T @ p
        if ucs != 0 and ucs not in systems:
            raise InputError(f"{where}: node {nid}: its displacement coordinate system {ucs} is not defined in the "
                             "file (datasets 2420, 18)")
        q = (float(p[0]), float(p[1]), float(p[2]))
        old = out.xyz.get(nid)
        if old is not None and (not np.allclose(old, q, rtol=AXIS_RTOL, atol=1e-9) or out.disp[nid] != ucs):
            raise InputError(f"{where}: node {nid} defined twice with different coordinates or systems "
                             f"({out.where[nid].split(': ', 1)[-1]} and here)")
        out.xyz.setdefault(nid, q)
        out.disp.setdefault(nid, ucs)
        out.where.setdefault(nid, where)


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
    for k in ("length", "force"):
        if not units[k] > 0:
            raise InputError(f"{where}: the {k} unit factor {units[k]:g} is not > 0 (file units -> SI: divide by it)")
    return units


@dataclass
class _RawMode:
    """One dataset 55 record as read: values by (node, direction in the node's displacement system)."""

    where: str
    label: str
    eigenvalue: float
    values: dict[tuple[int, str], complex | float]
    damping_ratio: float | None = None


def _read_mode(dset: dict, where: str, nodes: _Nodes, notes: list[str]) -> _RawMode | None:
    """One dataset 55 record -> its values at (node, direction) as the file gives them, and its
    damping ratio (None for records that are not modes): analysis type 2's viscous damping ratio
    (0: not stated), or -Re(s)/|s| of a complex mode's eigenvalue s."""
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
    _check_nodes(node_nums, nodes.xyz, where)
    values: dict[tuple[int, str], Any] = {}
    for i, n in enumerate(node_nums):
        for direction, r in comps:
            v = r[i]
            if not np.isfinite(v):
                raise InputError(f"{where}: NaN or infinite value(s) at dof(s) {dof(n, direction)}")
            if (n, direction) in values:
                raise InputError(f"{where}: node {n} appears twice")
            values[(n, direction)] = v
    mode_n = dset.get("mode_n")
    label = str(int(mode_n)) if mode_n is not None else ""
    try:
        if analysis == 2:
            freq = float(dset["freq"])
            if not math.isfinite(freq) or freq < 0:
                raise InputError(f"frequency {freq!r} Hz must be finite and >= 0")
            if freq > MAX_MAGNITUDE:  # its eigenvalue (2π f)² would overflow
                raise InputError(f"frequency {freq:g} Hz is above {MAX_MAGNITUDE:g}")
            lam = (2 * math.pi * freq) ** 2
            zeta = _number_or_zero(dset.get("modal_damp_vis"))  # viscous damping ratio; 0: not stated
            if zeta == 0 and _not_finite(dset.get("modal_damp_vis")):
                raise InputError(f"viscous damping ratio {dset['modal_damp_vis']!r} is not a finite number")
            damping = zeta if zeta else None
            if damping is None and _number_or_zero(dset.get("modal_damp_his")):
                notes.append(f"{where}: the hysteretic damping value {float(dset['modal_damp_his']):g} is not "
                             "read as a damping ratio (its convention varies between writers); give damping_ratio "
                             "in test-data JSON")
        else:
            eig = complex(dset["eig"])  # s = -zeta*omega_n + i*omega_d, rad/s
            if not (math.isfinite(eig.real) and math.isfinite(eig.imag)):
                raise InputError(f"complex eigenvalue {eig!r} is not finite")
            if max(abs(eig.real), abs(eig.imag)) > MAX_MAGNITUDE:  # |s|² would overflow
                raise InputError(f"complex eigenvalue {eig.real:g}{eig.imag:+g}j rad/s is above {MAX_MAGNITUDE:g} in "
                                 "magnitude")
            lam = abs(eig) ** 2
            damping = -eig.real / abs(eig) if abs(eig) > 0 else None  # ζ = -Re(s)/|s|
            if damping is not None and not 0 <= damping < 1:
                notes.append(f"{where}: the complex eigenvalue {eig:g} gives no damping ratio in [0, 1) "
                             f"({damping:g}); the mode is read without one")
                damping = None
        if damping is not None and not 0 <= damping < 1:
            raise InputError(f"viscous damping ratio {damping:g} is not in [0, 1)")
    except KeyError as exc:
        raise InputError(f"{where}: missing field {exc} for analysis type {analysis}") from None
    except InputError as exc:
        raise InputError(f"{where}: {exc}") from None
    return _RawMode(where, label, lam, values, damping)


def _not_finite(v) -> bool:
    """A record's field that is a number but NaN or infinite."""
    try:
        return not math.isfinite(float(v))
    except (TypeError, ValueError):
        return False


def _number_or_zero(v) -> float:
    """A record's optional real field as a float (0 for a missing or non-finite one)."""
    try:
        x = float(v)
    except (TypeError, ValueError):
        return 0.0
    return x if math.isfinite(x) else 0.0


def _is_zero(v) -> bool:
    return bool(v == 0)


def _to_global(raw: _RawMode, measured: set[tuple[int, str]], nodes: _Nodes, systems: Mapping[int, System],
               kept: Mapping[int, Any] | None = None) -> dict[str, Any]:
    """The mode's measured values in the global axes, {label: value}, node by node in the order of
    the record.  At a node whose displacement system is a local one, a global component is
    measured when every local component it is made of is measured; a measured local component
    that enters no measured global component is refused (it cannot be rotated alone)."""
    out: dict[str, Any] = {}
    by_node: dict[int, dict[str, Any]] = {}
    for (n, d), v in raw.values.items():
        by_node.setdefault(n, {})[d] = v
    for n, vals in by_node.items():
        cs = nodes.disp.get(n, 0)
        if cs == 0 or n in (kept or {}):  # global, or kept along the node's own axes (keep_local)
            for d, v in vals.items():
                if (n, d) in measured:
                    out[dof(n, d)] = v
            continue
        s = systems[cs]
        try:
            R = s.cartesian(n, "displacement")
        except InputError as exc:
            raise InputError(f"{raw.where}: {exc}") from None
        for group in (DIRECTIONS[:3], DIRECTIONS[3:]):
            have = [d in vals for d in group]
            if not any(have):
                continue
            known = np.array([(n, d) in measured for d in group])
            local = np.array([vals.get(d, 0) for d in group])
            lost = set(np.flatnonzero(known))
            for i, g in enumerate(group):
                needs = np.flatnonzero(R[:, i] != 0)
                if known[needs].all():
                    out[dof(n, g)] = (R[:, i] @ local).item()
                    lost -= set(needs.tolist())
            if lost:
                comps = ", ".join(group[j] for j in sorted(lost))
                raise InputError(f"{raw.where}: node {n}: the measured component(s) {comps} along the axes of "
                                 f"{s.describe()} do not lie along the model's axes, and the node's other components "
                                 "in that system are not measured: they cannot be rotated into the model's axes; "
                                 "give the node's three components, or the data in the global system")
    return out


def _build_modes(raws: list[_RawMode], nodes: _Nodes, systems: Mapping[int, System], sensors: frozenset[str] | None,
                 sensor_source: str, units: Mapping[str, Any], known: frozenset[str] | None, name: str,
                 notes: list[str], keep: dict | None = None) -> list[MeasuredMode]:
    """The measured modes from the records: measured components chosen (the sensor list, or the
    zero rule), rotated into the global axes, converted to SI, checked against the model."""
    keys: dict[tuple[int, str], None] = {}
    for r in raws:
        keys.update(dict.fromkeys(r.values))
    if sensors is not None:
        measured = set(keys)  # every component read; the sensor list picks the global dofs below
    else:
        # the zero rule: a component that is exactly zero in every mode record that holds it is
        # an unmeasured one that the record pads (UFF records carry 3 or 6 values per node)
        zero_all = {k for k in keys if all(_is_zero(r.values[k]) for r in raws if k in r.values)}
        measured = set(keys) - zero_all
        if zero_all:
            padded = [dof(n, d) for n, d in keys if (n, d) in zero_all]
            local = sorted({n for n, _ in zero_all if nodes.disp.get(n, 0) != 0})
            where = f" (in the nodes' own coordinate systems at node(s) {', '.join(map(str, local[:8]))})" if local else ""
            notes.append(f"{name}: datasets 55: {len(padded)} component(s) exactly zero in every mode taken as "
                         f"unmeasured (padding of the 3- or 6-value records) and left out{where}: "
                         f"{describe(padded, 12)}; give the measured dofs (--measured-dofs, or sensors) to "
                         "keep a measured zero")
        partial = [k for k in keys if k in measured and any(_is_zero(r.values[k]) for r in raws if k in r.values)]
        if partial:
            which = {}
            for k in partial:
                which[dof(*k)] = [r.label or str(i + 1) for i, r in enumerate(raws) if k in r.values
                                  and _is_zero(r.values[k])]
            shown = "; ".join(f"{lab} (mode {', '.join(m)})" for lab, m in list(which.items())[:8])
            more = f"; … ({len(which)} in all)" if len(which) > 8 else ""
            notes.append(f"{name}: datasets 55: zero values kept as measured (the component is not zero in every "
                         f"mode): {shown}{more}")
    length = float(units.get("length", 1.0)) if units else 1.0
    modes = []
    dropped: dict[str, None] = {}
    dropped_nonzero: dict[str, None] = {}
    model_padding: dict[str, None] = {}
    model_nodes = {parse_dof(k)[0] for k in known} if known is not None else set()
    if keep is not None:
        keep.update(unrotatable(measured, nodes.disp, systems))
    for r in raws:
        vals = _to_global(r, measured, nodes, systems, keep)
        if sensors is not None:
            for lab, v in vals.items():
                if lab not in sensors:
                    dropped.setdefault(lab)
                    if not _is_zero(v):
                        dropped_nonzero.setdefault(lab)
            vals = {lab: v for lab, v in vals.items() if lab in sensors}
        if known is not None:
            # a zero at a dof the model lacks, at a node it has (a 6-value record read for a planar
            # model): padding too; anything else must be in the model
            for lab in [lab for lab, v in vals.items() if lab not in known and parse_dof(lab)[0] in model_nodes
                        and _is_zero(v)]:
                model_padding.setdefault(lab)
                del vals[lab]
            _check_in_model(vals, known, r.where)
        labels = tuple(vals)
        shape = np.array([vals[lab] for lab in labels]) if labels else np.zeros(0)
        if length != 1.0 and labels:  # translations file units -> m; rotations are radians
            trans = np.array([parse_dof(lab)[1] in DIRECTIONS[:3] for lab in labels])
            with np.errstate(over="ignore", under="ignore"):
                shape = np.where(trans, shape / length, shape)
            if not np.all(np.isfinite(shape)):
                raise InputError(f"{r.where}: shape value(s) too large to convert to SI (divided by the length unit "
                                 f"factor {length:g} of dataset 164, they overflow)")
        try:
            modes.append(MeasuredMode(r.eigenvalue, labels, shape, r.label, damping_ratio=r.damping_ratio))
        except InputError as exc:
            raise InputError(f"{r.where}: {exc}") from None
    if sensors is not None:
        notes.append(f"{name}: the modes' measured dofs are {sensor_source} ({len(sensors)} dofs)"
                     + (f"; components at other dofs left out: {describe(list(dropped), 12)}" if dropped else ""))
        if dropped_nonzero:
            notes.append(f"{name}: non-zero values left out at dofs outside {sensor_source}: "
                         f"{describe(list(dropped_nonzero), 12)}")
    if model_padding:
        notes.append(f"{name}: zero values at dofs the model lacks left out: {describe(list(model_padding), 12)}")
    return modes


def read_uff(
    path: str | os.PathLike,
    *,
    model_dofs: Sequence[str] | None = None,
    model=None,
    sensors: Iterable[str] | None = None,
    keep_local: dict | None = None,
) -> TestData:
    r"""Read test data from a universal file.

    Parameters
    ----------
    path : str or path-like
        The universal file (ASCII; binary 58b records are read too).
    model_dofs : sequence of str, optional
        Dof labels of the model the data will be compared with. Every dof in the data must be
        one of them, except zero values of dataset 55 (a 6-dof record read for a planar model)
        at dofs the model lacks at nodes it has, which are dropped with a note.
    model : Model, optional
        Alternative to ``model_dofs``: its ``dofs`` are used.
    sensors : iterable of str, optional
        The measured dofs (labels in the global axes): the modes keep their components at these
        dofs only, zeros included (:ref:`the measured dofs <uff-measured>` below).
    keep_local : dict, optional
        For test points on a mesh only (:func:`femupdate.testpoints.map_test_data`'s ``axes``):
        a mode's components at a node that cannot be rotated into the global axes (a single one
        along a skewed axis) are kept along the node's own axes, labels ``"<node>:<dir>"`` in
        them, instead of refused, and ``keep_local[node]`` is set to R (rows: those axes in
        global axes); an FRF's response or excitation at a node in a local system is kept so too.

    Returns
    -------
    TestData
        ``modes`` (ordered by frequency), ``frf`` and ``frf_sets`` (one set per excitation dof),
        ``units``, ``nodes`` and ``notes`` (what was left out, converted or rotated).

        * **Measured dofs of the modes** (dataset 55 records carry 3 or 6 values at every node,
          measured or not): with ``sensors``, those dofs; else, when the file holds FRF records
          (dataset 58), their response dofs (and their excitation dofs when there are several);
          else every component that is non-zero in at least one mode record: a component exactly
          zero in every mode record is taken as unmeasured padding and left out, and a zero in
          some modes only is kept as a measured zero -- each named in ``notes``.
        * Dataset 55, analysis type 2 (normal mode): the eigenvalue is
          :math:`\lambda = (2\pi f)^2` from the record's frequency :math:`f` in Hz.
          Analysis types 3 and 7 (complex modes): the record's complex eigenvalue
          :math:`s = -\zeta\omega_n + i\omega_d` (rad/s) gives :math:`\lambda = |s|^2 = \omega_n^2`
          and the damping ratio :math:`\zeta = -\mathrm{Re}(s)/|s|`;
          shapes stay complex, labelled node by node ``x y z`` or ``x y z rx ry rz``.
          A normal mode's viscous damping ratio (``modal_damp_vis``) is its ``damping_ratio``
          when it is not 0; a hysteretic value alone is not converted (a note says so).
        * Dataset 58, function type 4 (FRF; other function types are skipped): the records are
          grouped by excitation (reference) dof into one :class:`FRFData` each (a roving-hammer
          or multi-reference test gives several), every record of a group on one frequency
          axis (even or uneven spacing). The abscissa is in Hz
          (converted to :math:`\omega = 2\pi f` rad/s) unless its units label says rad/s. The
          ordinate is a receptance (displacement / force) unless the ordinate specific data type
          says velocity (mobility, divided by :math:`i\omega`) or acceleration (accelerance,
          divided by :math:`-\omega^2`). Negative direction codes negate the data, for the
          response and for the reference alike. The force is 1 at the excitation dof.
        * Dataset 164: ``units`` = {``code``, ``system`` (e.g. ``"MM"``), ``description``,
          ``temperature_mode``, ``length``, ``force``, ``temperature``,
          ``temperature_offset``, ``data``: ``"SI"``}; the factors are pyuff's (file units ->
          SI: divide by them). Node coordinates, mode shape translations (rotations are radians)
          and FRFs are converted to SI (m, N): a receptance in mm/N is multiplied by
          force / length. Without dataset 164 values are kept as they are (``units`` empty).
        * Datasets 2420 and 18 (coordinate systems) with 15 and 2411 (nodes): coordinates given
          in a local Cartesian system are moved to global ones, and data at a node whose
          displacement system is a local Cartesian one are rotated into the global axes
          (:mod:`femupdate.io.uff.systems`); cylindrical and spherical systems are refused.
        * Datasets 15 and 2411: ``nodes`` = {id: (x, y, z)} in global coordinates. When present,
          every node used by a mode or FRF record must be among them.

    Raises
    ------
    InputError
        Missing, unreadable or non-UFF file; a malformed or truncated record; NaN values;
        direction codes other than ±1..±6; FRFs of one excitation dof on different frequency
        axes; unknown nodes or dofs not in the model; an undefined, cylindrical or spherical
        coordinate system, or data that cannot be rotated into the global axes; a file with
        neither modes nor FRFs. The message names the file and the record
        (``"f.uff: dataset 58 record 3: ..."``), and the node or system where it applies.
    """
    from ..._checks import path_arg

    path = path_arg(path, "path", "read_uff")
    name = os.fspath(path)
    known = _known_dofs(model_dofs, model)
    given = None if sensors is None else frozenset(canonical_all(list(sensors), "sensors"))
    records = _read_records(name)
    notes: list[str] = []

    systems: dict[int, System] = {}
    raw18: list = []
    units: dict = {}
    for t, k, dset in records:
        where = f"{name}: dataset {t} record {k}"
        if t == 2420:
            read_2420(dset, where, systems)
        elif t == 18:
            raw18 += read_18(dset, where)
        elif t == 164:
            u = _read_units(dset, where)
            if units and u != units:
                raise InputError(
                    f"{where}: a second units dataset ({u['system']}) differs from the first ({units['system']})"
                )
            units = u
    resolve_18(raw18, systems)
    nodes = _Nodes()
    for t, k, dset in records:
        if t in NODE_SETS:
            _read_nodes(dset, f"{name}: dataset {t} record {k}", nodes, systems)

    raws: list[_RawMode] = []
    sets: dict[str, FRFSet] = {}
    for t, k, dset in records:
        where = f"{name}: dataset {t} record {k}"
        if t == 55:
            m = _read_mode(dset, where, nodes, notes)
            if m is not None:
                raws.append(m)
        elif t == 58:
            rsp_ref = add_frf_record(sets, dset, where, k, nodes, systems, units, notes, keep_local)
            if rsp_ref is not None:
                _check_in_model(rsp_ref, known, where)
    frf_sets = frf_sets_of(sets, name, notes)
    if units and (units["length"] != 1.0 or units["force"] != 1.0):
        notes.append(f"{name}: dataset 164: units {units['system']} ({units['description'] or 'no description'}): "
                     f"converted to SI, lengths divided by {units['length']:g} and forces by {units['force']:g} "
                     "(node coordinates, mode shape translations, FRFs)")
    if units:
        units["data"] = "SI"
    local = sorted({n for n, cs in nodes.disp.items() if cs != 0})
    moved = sorted({s.label for s in systems.values()} & set(nodes.disp.values()))
    if local:
        notes.append(f"{name}: data at {len(local)} node(s) in local displacement coordinate systems "
                     f"({', '.join(map(str, moved))}) rotated into the global axes: node(s) "
                     f"{', '.join(map(str, local[:12]))}{' …' if len(local) > 12 else ''}")

    sensor_source = "the dofs given (sensors)"
    if given is None and raws and frf_sets:
        measured_at: dict[str, None] = {}
        for data_set in frf_sets:
            measured_at.update(dict.fromkeys(data_set.dofs))
        if len(frf_sets) > 1:
            for data_set in frf_sets:
                measured_at.update(dict.fromkeys(data_set.force))
        given = frozenset(measured_at)
        sensor_source = "the dofs of the file's FRF records (dataset 58)"
    modes = _build_modes(raws, nodes, systems, given, sensor_source, units, known, name, notes, keep_local)
    if keep_local:
        notes.append(f"{name}: node(s) {', '.join(map(str, sorted(keep_local)[:12]))}: measured components kept along "
                     "their own displacement system's axes (they cannot be rotated into the global axes alone)")
    if not modes and not frf_sets:
        raise InputError(f"{name}: no usable data: no mode records (dataset 55) and no FRF records (dataset 58)")
    length = float(units.get("length", 1.0)) if units else 1.0
    xyz = {n: (p[0] / length, p[1] / length, p[2] / length) if length != 1.0 else p for n, p in nodes.xyz.items()}
    order = sorted(range(len(modes)), key=lambda i: modes[i].eigenvalue)
    for note in notes:
        log.info("%s", note)
    log.info("%s: %d mode(s), %d FRF set(s), %d node(s)", name, len(modes), len(frf_sets), len(xyz))
    return TestData(modes=tuple(modes[i] for i in order), units=units, nodes=xyz, frf_sets=tuple(frf_sets),
                    notes=tuple(notes))
