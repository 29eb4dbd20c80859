r"""Universal files (UFF / UNV) through :mod:`pyuff`: nodes, modes, FRFs and units.

Datasets read
-------------
* **15**, **2411** -- node coordinates, into :attr:`TestData.nodes` ``{id: (x, y, z)}``;
* **55** -- data at nodes: real normal modes (analysis type 2) and complex modes (analysis
  types 3 and 7), into :class:`~femupdate.testdata.MeasuredMode`, ordered by frequency;
* **58** -- functions at nodal dofs: frequency response functions (function type 4) of one
  excitation dof, into :class:`~femupdate.testdata.FRFData` (receptance, ``omega`` in rad/s);
* **164** -- units, into :attr:`TestData.units`.

Other datasets (trace lines 82, elements 2412, ...) and other kinds of records (coherences,
operating shapes, static data at nodes) are skipped with a log message.

Directions
----------
UFF direction codes 1..6 map to ``x y z rx ry rz`` (:mod:`femupdate.dofs`). A negative code
means that the transducer points the negative way: its data are negated and stored under the
positive label. In dataset 55 the components ``r1 .. r6`` of each node are ``x .. rz``.

Values are kept in the file's units (dataset 164 says which); only the abscissa of FRFs is
converted from Hz to rad/s.

Every malformed or inconsistent file raises :class:`~femupdate.InputError` with one message that
names the file and the record (``"test.uff: dataset 55 record 2: ..."``, records counted
from 1 among the datasets of that type).

Writing goes through a temporary file in the target directory that replaces the target only
when complete (:func:`os.replace`), so a failed write never leaves a truncated file.
"""

from __future__ import annotations

import logging
import math
import os
import shutil
import tempfile
import uuid
from collections import Counter
from collections.abc import Iterable, Mapping, Sequence
from typing import Any

import numpy as np
import pyuff

from .._errors import InputError
from ..dofs import DIRECTIONS, canonical_all, describe, dof, parse_dof
from ..testdata import FRFData, MeasuredMode, TestData

__all__ = ["read_uff", "write_uff_modes", "write_uff_frf"]

log = logging.getLogger(__name__)

_NODE_SETS = (15, 2411)
_READ_SETS = frozenset((15, 2411, 55, 58, 164))

#: Dataset 164 unit-system codes.
UNIT_SYSTEMS = {
    1: "SI",  # meter, newton
    2: "BG",  # foot, pound force
    3: "MG",  # meter, kilogram force
    4: "BA",  # foot, poundal
    5: "MM",  # millimeter, millinewton
    6: "CM",  # centimeter, centinewton
    7: "IN",  # inch, pound force
    8: "GM",  # millimeter, kilogram force
    9: "US",  # user defined
}

# Dataset 58 specific data types (records 8 to 10).
_ABSCISSA_FREQUENCY = frozenset((0, 1, 18))  # unknown, general, frequency
_ORD_DISPLACEMENT = frozenset((0, 1, 8))  # unknown, general, displacement -> receptance
_ORD_VELOCITY = 11  # mobility
_ORD_ACCELERATION = 12  # accelerance
_DENOM_FORCE = frozenset((0, 1, 9, 13))  # unknown, general, reaction force, excitation force

_AXIS_RTOL = 1e-5  # UFF abscissas are single precision (E13.5): equal axes agree to ~5e-6


# ---------------------------------------------------------------------------- small helpers
def _direction(code, where: str, node) -> tuple[str, float]:
    """UFF direction code -> (direction name, sign of the transducer)."""
    try:
        c = int(code)
    except (TypeError, ValueError):
        c = 0
    if c == 0 or abs(c) > 6:
        raise InputError(
            f"{where}: node {node}: direction code {code!r} is not one of ±1..±6 "
            "(x, y, z, rx, ry, rz); scalar (0) and other codes are not supported"
        )
    return DIRECTIONS[abs(c) - 1], (1.0 if c > 0 else -1.0)


def _code(direction: str) -> int:
    return DIRECTIONS.index(direction) + 1


def _node_id(value, where: str) -> int:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise InputError(f"{where}: node number {value!r} is not a number") from None
    if not math.isfinite(v) or v != int(v):
        raise InputError(f"{where}: node number {value!r} is not an integer")
    return int(v)


def _id_line(text: str) -> str:
    """An ID line: one line of at most 80 characters, never blank (UFF uses "NONE")."""
    text = " ".join(str(text).split())[:80]
    return text or "NONE"


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
    if not types:
        raise InputError(f"{name}: not a universal file (UFF): no datasets delimited by '    -1' lines")
    counts: Counter[int] = Counter()
    out = []
    for i, t in enumerate(types):
        if t not in _READ_SETS:
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
        if old is not None and not np.allclose(old, p, rtol=_AXIS_RTOL, atol=1e-9):
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
        rsp_dir, rsp_sign = _direction(dset["rsp_dir"], f"{where}: response", rsp_node)
        ref_dir, ref_sign = _direction(dset["ref_dir"], f"{where}: reference (excitation)", ref_node)
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
    if abscissa not in _ABSCISSA_FREQUENCY:
        raise InputError(f"{where}: abscissa specific data type {abscissa} is not frequency (18)")
    units_label = str(dset.get("abscissa_axis_units_lab", "")).lower().replace(" ", "")
    omega = x.copy() if "rad" in units_label else 2.0 * np.pi * x
    if np.any(omega < 0):
        raise InputError(f"{where}: negative frequencies")
    ordinate = int(dset.get("ordinate_spec_data_type", 0))
    denominator = int(dset.get("orddenom_spec_data_type", 0))
    if denominator not in _DENOM_FORCE:
        raise InputError(f"{where}: ordinate denominator specific data type {denominator} is not a force (13); "
                         "only receptance, mobility and accelerance FRFs are read")
    h = y.astype(complex if np.iscomplexobj(y) else float)
    if ordinate in (_ORD_VELOCITY, _ORD_ACCELERATION):
        if np.any(omega == 0):
            raise InputError(f"{where}: a {'mobility' if ordinate == _ORD_VELOCITY else 'accelerance'} "
                             "cannot be converted to receptance at zero frequency")
        h = h / (1j * omega) if ordinate == _ORD_VELOCITY else h / (-(omega**2))
    elif ordinate not in _ORD_DISPLACEMENT:
        raise InputError(f"{where}: ordinate specific data type {ordinate} is not displacement (8), "
                         "velocity (11) or acceleration (12)")
    # H measured between transducers oriented s_rsp, s_ref: H_+ = s_rsp * s_ref * H_measured
    h = h * (rsp_sign * ref_sign)
    return x, omega, dof(rsp_node, rsp_dir), dof(ref_node, ref_dir), (rsp_node, ref_node), h


def _same_axis(a: np.ndarray, b: np.ndarray) -> bool:
    if a.shape != b.shape:
        return False
    tol = _AXIS_RTOL * np.abs(a) + 1e-12 * max(float(np.max(np.abs(a))), 1e-300)
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
        if t in _NODE_SETS:
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
                raise AttributeError("'NoneType' object has no attribute 'shape'")
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


# ---------------------------------------------------------------------------- writing
def _si_units() -> dict:
    return pyuff.prepare_164(
        units_code=1,
        units_description="SI: Meter (newton)",
        temp_mode=2,
        length=1.0,
        force=1.0,
        temp=1.0,
        temp_offset=273.15,
    )


def _nodes_dataset(nodes: Mapping[int, Sequence[float]], used: Iterable[int], what: str) -> dict:
    ids = sorted(int(n) for n in nodes)
    missing = sorted(set(used) - set(ids))
    if missing:
        raise InputError(f"{what}: node(s) without coordinates in `nodes`: {', '.join(map(str, missing[:8]))}")
    try:
        xyz = np.array([[float(c) for c in nodes[n]] for n in ids], dtype=float).reshape(len(ids), 3)
    except (TypeError, ValueError):
        raise InputError(f"{what}: `nodes` must map node ids to (x, y, z)") from None
    if not np.all(np.isfinite(xyz)):
        raise InputError(f"{what}: `nodes` has NaN or infinite coordinates")
    zeros = np.zeros(len(ids), dtype=int)
    return pyuff.prepare_2411(
        node_nums=np.array(ids, dtype=int),
        def_cs=zeros,
        disp_cs=zeros,
        color=zeros,
        x=xyz[:, 0].copy(),
        y=xyz[:, 1].copy(),
        z=xyz[:, 2].copy(),
    )


def _atomic_write(path: str | os.PathLike, datasets: Sequence[dict]) -> None:
    """Write ``datasets`` with pyuff into a temporary file next to ``path``, then replace it.

    pyuff re-scans the whole file after every dataset it appends, which is quadratic in the
    number of datasets; each dataset is therefore written to a small scratch file and copied.
    """
    target = os.fspath(path)
    folder = os.path.dirname(os.path.abspath(target))
    if not os.path.isdir(folder):
        raise InputError(f"{target}: cannot write: directory {folder} does not exist")
    tmp = os.path.join(folder, f".{os.path.basename(target)}.{uuid.uuid4().hex[:12]}.tmp")
    current = None
    try:
        with tempfile.TemporaryDirectory(prefix="femupdate-uff-") as scratch_dir, open(tmp, "xb") as out:
            scratch = os.path.join(scratch_dir, "set.uff")
            for current in datasets:
                pyuff.UFF(scratch).write_sets(current, mode="overwrite")
                with open(scratch, "rb") as fh:
                    shutil.copyfileobj(fh, out)
            out.flush()
            os.fsync(out.fileno())
        os.replace(tmp, target)
    except OSError as exc:
        _remove(tmp)
        raise InputError(f"{target}: cannot write: {exc.strerror or exc}") from None
    except Exception as exc:
        _remove(tmp)
        log.debug("pyuff failed writing %s", target, exc_info=True)
        kind = current.get("type", "?") if isinstance(current, dict) else "?"
        raise InputError(f"{target}: pyuff could not write dataset {kind}: {exc}") from None


def _remove(p: str) -> None:
    try:
        os.remove(p)
    except OSError:
        pass


def write_uff_modes(
    path: str | os.PathLike,
    modes,
    nodes: Mapping[int, Sequence[float]] | None = None,
    model_name: str = "femupdate",
    *,
    units: bool = True,
) -> None:
    """Write real normal modes as a universal file.

    Parameters
    ----------
    path : str or path-like
        Output file, replaced atomically.
    modes : Modes
        ``eigenvalues`` (m,) in rad^2/s^2, real ``shapes`` (n, m) on ``dofs``.
    nodes : mapping int -> (x, y, z), optional
        Node coordinates, written as dataset 2411; must cover every node of ``modes.dofs``.
    model_name : str
        ID line 1 of every record.
    units : bool
        Write dataset 164 (SI units) first.

    Notes
    -----
    One dataset 55 per mode: model type structural, analysis type 2 (normal mode), specific
    data type 8 (displacement), real data, frequency :math:`\\sqrt{\\lambda}/2\\pi` Hz, modal
    mass 1 for mass-normalised modes (else 0, unknown), load case 1, modes numbered from 1.
    Dofs are grouped by node (ascending); the data characteristic is 2 (3-dof translation
    vector, ``x y z``) when every dof is a translation, otherwise 3 (6-dof translation and
    rotation vector, ``x .. rz``). Components a node lacks are written as 0. pyuff writes values
    and frequencies in E13.5 format: six significant digits.

    Raises
    ------
    InputError
        Complex or non-finite shapes, inconsistent shapes, nodes without coordinates, or a
        failed write (naming the file).
    """
    target = os.fspath(path)
    lam = np.atleast_1d(np.asarray(modes.eigenvalues, dtype=float))
    phi = np.asarray(modes.shapes)
    labels = canonical_all(modes.dofs, f"{target}: mode shapes")
    if phi.ndim == 1:
        phi = phi.reshape(-1, 1)
    if phi.shape != (len(labels), lam.size):
        raise InputError(f"{target}: shapes have shape {phi.shape}, expected ({len(labels)} dofs, {lam.size} modes)")
    if lam.size == 0:
        raise InputError(f"{target}: no modes to write")
    if np.iscomplexobj(phi):
        if np.any(phi.imag != 0):
            raise InputError(f"{target}: complex mode shapes cannot be written as real normal modes")
        phi = phi.real
    phi = phi.astype(float)
    if not np.all(np.isfinite(lam)) or not np.all(np.isfinite(phi)):
        raise InputError(f"{target}: NaN or infinite eigenvalues or shape values")
    freqs = np.sqrt(np.clip(lam, 0.0, None)) / (2 * np.pi)

    rows: dict[int, dict[int, int]] = {}
    for i, lab in enumerate(labels):
        n, d = parse_dof(lab)
        rows.setdefault(n, {})[DIRECTIONS.index(d)] = i
    node_ids = sorted(rows)
    ncomp = 3 if all(j < 3 for r in rows.values() for j in r) else 6
    data_ch = 2 if ncomp == 3 else 3
    # (n_nodes, ncomp) row indices into phi, -1 where the node lacks that component
    idx = np.full((len(node_ids), ncomp), -1, dtype=int)
    for a, n in enumerate(node_ids):
        for j, i in rows[n].items():
            idx[a, j] = i

    datasets = []
    if units:
        datasets.append(_si_units())
    if nodes:
        datasets.append(_nodes_dataset(nodes, node_ids, target))
    modal_m = 1.0 if getattr(modes, "normalisation", "") == "mass" else 0.0
    padded = np.vstack([phi, np.zeros((1, lam.size))])  # row -1 = zeros
    for r in range(lam.size):
        comp = padded[idx, r]  # (n_nodes, ncomp)
        kw = {f"r{j + 1}": comp[:, j].copy() for j in range(ncomp)}
        datasets.append(
            pyuff.prepare_55(
                id1=_id_line(model_name),
                id2=_id_line(f"Mode {r + 1}"),
                id3="NONE",
                id4="NONE",
                id5=_id_line(f"Mode {r + 1} frequency {freqs[r]:.6g} Hz"),
                model_type=1,
                analysis_type=2,
                data_ch=data_ch,
                spec_data_type=8,
                data_type=2,
                n_data_per_node=ncomp,
                node_nums=np.array(node_ids, dtype=int),
                load_case=1,
                mode_n=r + 1,
                freq=float(freqs[r]),
                modal_m=modal_m,
                modal_damp_vis=0.0,
                modal_damp_his=0.0,
                **kw,
            )
        )
    _atomic_write(target, datasets)
    log.info("%s: wrote %d mode(s) at %d node(s)", target, lam.size, len(node_ids))


def write_uff_frf(
    path: str | os.PathLike,
    frf: FRFData,
    nodes: Mapping[int, Sequence[float]] | None = None,
    model_name: str = "femupdate",
    *,
    units: bool = True,
) -> None:
    """Write FRFs as a universal file: one dataset 58 per response dof.

    Parameters
    ----------
    path : str or path-like
        Output file, replaced atomically.
    frf : FRFData
        Responses ``(n_freq, n_dofs)`` to one excitation dof (a single non-zero entry in
        ``frf.force``); written as receptance ``response / force``.
    nodes : mapping int -> (x, y, z), optional
        Node coordinates, written as dataset 2411; must cover every node used.
    model_name : str
        ID line 1 of every record.
    units : bool
        Write dataset 164 (SI units) first.

    Notes
    -----
    Function type 4 (FRF), complex double-precision ordinate, abscissa frequency in Hz
    (:math:`f = \\omega / 2\\pi`, specific data type 18), ordinate displacement (8) over
    excitation force (13). The abscissa is written in E13.5 format (six significant digits,
    as the UFF standard has it), so ``omega`` read back agrees to about 5e-6 relative.

    Raises
    ------
    InputError
        More than one excitation dof, nodes without coordinates, or a failed write.
    """
    target = os.fspath(path)
    loads = {k: v for k, v in dict(frf.force).items() if v != 0}
    if len(loads) != 1:
        raise InputError(
            f"{target}: dataset 58 holds FRFs of one excitation dof; the force acts at {describe(list(loads))}"
        )
    ((ref, amplitude),) = loads.items()
    ref_node, ref_dir = parse_dof(ref)
    omega = np.atleast_1d(np.asarray(frf.omega, dtype=float))
    h = np.asarray(frf.response, dtype=complex).reshape(omega.size, -1) / amplitude
    if not np.all(np.isfinite(h)) or not np.all(np.isfinite(omega)):
        raise InputError(f"{target}: NaN or infinite FRF values")
    labels = tuple(frf.dofs)
    f_hz = omega / (2 * np.pi)
    even = f_hz.size == 1  # pyuff needs two abscissas to write an uneven axis
    x = np.array([f_hz[0], f_hz[0] + 1.0]) if even else f_hz.copy()
    used = {ref_node} | {parse_dof(lab)[0] for lab in labels}

    datasets = []
    if units:
        datasets.append(_si_units())
    if nodes:
        datasets.append(_nodes_dataset(nodes, used, target))
    for j, lab in enumerate(labels):
        node, direction = parse_dof(lab)
        ds = pyuff.prepare_58(
            binary=0,
            id1=_id_line(model_name),
            id2=_id_line(f"Receptance {lab} / {ref}"),
            id3="NONE",
            id4="NONE",
            id5="NONE",
            func_type=4,
            ver_num=0,
            load_case_id=0,
            rsp_ent_name="NONE",
            rsp_node=int(node),
            rsp_dir=_code(direction),
            ref_ent_name="NONE",
            ref_node=int(ref_node),
            ref_dir=_code(ref_dir),
            ord_data_type=6,
            num_pts=int(omega.size),
            abscissa_spacing=1 if even else 0,
            abscissa_min=0.0,
            abscissa_inc=0.0,
            z_axis_value=0.0,
            abscissa_spec_data_type=18,
            abscissa_len_unit_exp=0,
            abscissa_force_unit_exp=0,
            abscissa_temp_unit_exp=0,
            abscissa_axis_units_lab="Hz",
            ordinate_spec_data_type=8,
            ordinate_len_unit_exp=0,
            ordinate_force_unit_exp=0,
            ordinate_temp_unit_exp=0,
            ordinate_axis_units_lab="NONE",
            orddenom_spec_data_type=13,
            orddenom_len_unit_exp=0,
            orddenom_force_unit_exp=0,
            orddenom_temp_unit_exp=0,
            orddenom_axis_units_lab="NONE",
            z_axis_spec_data_type=0,
            z_axis_len_unit_exp=0,
            z_axis_force_unit_exp=0,
            z_axis_temp_unit_exp=0,
            z_axis_axis_units_lab="NONE",
            data=h[:, j].copy(),
            x=x,
        )
        ds["func_id"] = j + 1
        datasets.append(ds)
    _atomic_write(target, datasets)
    log.info("%s: wrote %d FRF(s) of excitation %s, %d frequencies", target, len(labels), ref, omega.size)
