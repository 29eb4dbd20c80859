"""Test data in the JSON format of docs/file-formats.md (and dispatch to UFF by suffix)."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import replace
from pathlib import Path

import numpy as np

from .._checks import model_arg, path_arg, strings_arg
from .._errors import InputError
from ..dofs import resolve_all, resolve_dof
from .numbers import load_json_file
from .outputs import note_input
from ..testdata import (FRFData, MeasuredMode, StaticData, TestData, check_damping_ratio, check_std_damping_ratio,
                        positive)

UFF_SUFFIXES = (".uff", ".unv")
#: other spellings of a mode's keys, accepted as the key itself (the issue tracker's and other
#: tools' spelling): alias -> key
MODE_ALIASES = {"frequency_std": "std_frequency", "shape_std": "std_shape", "damping_ratio_std": "std_damping_ratio"}
#: the keys of a mode object (docs/file-formats.md, "modes")
MODE_KEYS = frozenset({"frequency_hz", "eigenvalue", "shape", "label", "reference_dof", "std_frequency",
                       "std_eigenvalue", "std_shape", "weight", "sensors", "damping_ratio", "std_damping_ratio",
                       *MODE_ALIASES})


def load_testdata(path, model=None, numbering=None, sensors=None, channels=None, keep_local=None) -> TestData:
    """Read test data from JSON or a universal file (``.uff``/``.unv``).

    With ``model``, every dof in the data must be a model dof (the message names the others), and
    a JSON dof written ``"#N"`` is the N-th dof of the model's dof list (1-based), resolved here to
    its label.

    Parameters
    ----------
    path : str or os.PathLike
        A JSON file (format in docs/file-formats.md), a universal file by its suffix
        ``.uff``/``.unv`` (read by :func:`femupdate.io.uff.read_uff`), or an identification
        result saved with ``numpy.savez`` by its suffix ``.npz`` (a pyOMA2 result's or an
        sdypy-EMA model's arrays with their channel map, read by
        :func:`femupdate.io.adapters.read_identification`).
    model : Model, optional
        Model whose dofs the data must use.
    numbering : sequence of str, optional
        The dof list that ``"#N"`` counts in (default ``model.dofs``); ``update-multi`` passes the
        baseline model's list while checking the data against a configuration's model.
    sensors : sequence of str, optional
        The measured dofs of the modes (labels, or ``"#N"`` with a model): each mode keeps its
        shape at these dofs only, zeros included; it replaces the JSON's ``sensors`` and a
        universal file's own rule (``--measured-dofs``).
    channels : sequence or mapping, optional
        The channel map of an identification result (``.npz`` only), replacing the file's
        (:func:`femupdate.io.adapters.channel_map`).
    keep_local : dict, optional
        A universal file's ``keep_local`` (:func:`femupdate.io.uff.read_uff`; test points only);
        other formats have no local axes and leave it empty.

    Returns
    -------
    TestData
        With labels only (indices resolved).

    Raises
    ------
    InputError
        A missing, unreadable or malformed file; data that :func:`parse_testdata` or the
        universal-file reader reject; ``"#N"`` out of range or malformed (the message gives the
        model's dof count), or without a model; with ``model``, a dof not in the model.
    """
    path = path_arg(path, "path", "load_test_data")
    note_input(path, "the test data")
    if model is not None:
        model_arg(model, "model", "load_test_data")
    strings_arg(numbering, "numbering", "load_test_data", what="dof label")
    strings_arg(sensors, "sensors", "load_test_data", what="dof label")
    if numbering is None and model is not None:
        numbering = model.dofs
    if channels is not None and path.suffix.lower() != ".npz":
        raise InputError(f"{path}: a channel map is for an identification result saved as .npz")
    if sensors is not None:
        sensors = resolve_all(list(sensors), numbering, "sensors")
    if path.suffix.lower() in UFF_SUFFIXES:
        from .uff import read_uff

        data = read_uff(path, model=model, sensors=sensors, keep_local=keep_local)  # sensors, FRF records or zero rule
    elif path.suffix.lower() == ".npz":
        from .adapters import read_identification

        data = read_identification(path, numbering, channels)
        if sensors is not None:
            notes = list(data.notes)
            modes = tuple(_keep_sensors(m, sensors, f"modes[{k}]", notes) for k, m in enumerate(data.modes, start=1))
            data = TestData(modes=modes, notes=tuple(notes))
    else:
        raw = load_json_file(path)
        try:
            data = parse_testdata(raw, numbering, sensors)
        except InputError as exc:
            raise InputError(f"{path}: {exc}") from None
    if model is not None:
        check_dofs(data, model, str(path))
    return data


def check_dofs(data: TestData, model, source: str) -> None:
    """Check that every dof of the data (mode shapes, FRF response and force, static
    displacements and forces) is a model dof.

    Parameters
    ----------
    data : TestData
        The test data.
    model : Model
        The model.
    source : str
        Where the data came from, for the message.

    Raises
    ------
    InputError
        Naming the dofs that are not in the model.
    """
    known = set(model.dofs)
    bad: dict[str, None] = {}
    for m in data.modes:
        for d in m.dofs:
            if d not in known:
                bad.setdefault(d)
    for fs in data.frf_sets:
        for d in list(fs.dofs) + list(fs.force):
            if d not in known:
                bad.setdefault(d)
    for s in data.static:
        for d in list(s.dofs) + list(s.force):
            if d not in known:
                bad.setdefault(d)
    if bad:
        from ..dofs import describe

        from ..constraints import dependent_note

        raise InputError(f"{source}: dof(s) not in the model {model.name!r}: {describe(list(bad))}"
                         f"{dependent_note(model, list(bad))}")


def _number(v, what):
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        raise InputError(f"{what}: expected a number, got {v!r}")
    if not math.isfinite(v):
        raise InputError(f"{what}: NaN or infinite value")
    return float(v)


def _complex(v, what):
    if isinstance(v, list):
        if len(v) != 2:
            raise InputError(f"{what}: a complex value is a pair [re, im], got {v!r}")
        return complex(_number(v[0], what), _number(v[1], what))
    return _number(v, what)


def _sensor_list(value, dofs, what: str) -> tuple[str, ...]:
    if not isinstance(value, list) or not all(isinstance(v, str) for v in value):
        raise InputError(f"{what}: expected a list of dofs (labels such as \"3:x\", or \"#N\")")
    return resolve_all(value, dofs, what)


def _keep_sensors(mode: MeasuredMode, sensors: tuple[str, ...], where: str, notes: list[str]) -> MeasuredMode:
    """The mode with its shape at ``sensors`` only (a note names what was left out)."""
    keep = set(sensors)
    mask = np.array([d in keep for d in mode.dofs], dtype=bool)
    if mask.all():
        return mode
    out = [d for d, k in zip(mode.dofs, mask) if not k]
    nonzero = [d for d, k, v in zip(mode.dofs, mask, mode.shape) if not k and v != 0]
    from ..dofs import describe

    notes.append(f"{where}: shape entries at dofs outside the sensors left out: {describe(out)}"
                 + (f" (non-zero at {describe(nonzero)})" if nonzero else ""))
    return replace(mode, dofs=tuple(d for d, k in zip(mode.dofs, mask) if k), shape=mode.shape[mask])


def parse_testdata(raw, dofs=None, sensors=None) -> TestData:
    """Build :class:`TestData` from the parsed JSON object.

    Parameters
    ----------
    raw : mapping
        The parsed JSON: ``"modes"`` (list of objects with exactly one of ``frequency_hz`` (Hz)
        or ``eigenvalue`` (rad²/s²), an optional ``shape`` {dof: value}, ``label`` and ``reference_dof``,
        and optionally at most one of ``std_frequency`` (relative, of f; kept as
        ``std_eigenvalue`` = 2 ``std_frequency``, to first order) or ``std_eigenvalue``
        (relative, of λ), ``std_shape`` (of the scaled shape entries), ``weight``,
        ``damping_ratio`` (ζ, fraction of critical) and ``std_damping_ratio`` (absolute, of ζ);
        ``frequency_std``, ``shape_std`` and ``damping_ratio_std`` are other spellings of
        ``std_frequency``, ``std_shape`` and ``std_damping_ratio`` (both spellings of one key
        together are refused); null: not given),
        ``"frf"`` (``omega_rad_s``, ``force`` {dof: value}, ``response`` {dof: one value per
        frequency}; complex values as ``[re, im]``), ``"static"`` (an object or a list of them
        with ``force`` and ``displacement`` {dof: value}), ``"units"`` (an object), ``"notes"`` (a list of
        strings, kept as the data's notes: what a conversion decided) and
        ``"sensors"`` (a list of dofs: the measured dofs of every mode; a mode's own
        ``sensors`` replace it for that mode; each mode keeps its shape at its sensors only,
        with a note naming what was left out).  A dof is a label or ``"#N"``, the N-th entry of
        ``dofs``.
    dofs : sequence of str, optional
        The model's dof list that ``"#N"`` counts in (without it, ``"#N"`` is refused).
    sensors : sequence of str, optional
        Measured dofs (canonical labels) that replace the file's ``sensors`` (top-level and per
        mode).

    Returns
    -------
    TestData
        With labels only.

    Raises
    ------
    InputError
        Not an object; unknown keys; missing or malformed entries; ``"#N"`` out of range,
        malformed or without ``dofs``; the same dof twice in one object (e.g. as ``"1:x"`` and
        ``"#1"``); no modes, FRF or static data at all; and as the :class:`TestData` value classes.
    """
    if not isinstance(raw, Mapping):
        raise InputError("test data must be a JSON object with 'modes', 'frf' and/or 'static'")
    unknown = sorted(set(raw) - {"modes", "frf", "static", "units", "sensors", "notes"})
    if unknown:
        raise InputError(f"unknown key(s) {', '.join(unknown)} (expected modes, frf, static)")
    notes: list[str] = []
    given_notes = raw.get("notes") or []
    if not isinstance(given_notes, list) or not all(isinstance(n, str) for n in given_notes):
        raise InputError("'notes' must be a list of strings")
    notes.extend(given_notes)
    top_sensors = None if raw.get("sensors") is None else _sensor_list(raw["sensors"], dofs, "sensors")
    modes = []
    modes_raw = raw.get("modes", []) or []
    if not isinstance(modes_raw, list):
        raise InputError("'modes' must be a list of mode objects")
    for i, m in enumerate(modes_raw, start=1):
        where = f"modes[{i}]"
        if not isinstance(m, Mapping):
            raise InputError(f"{where}: expected an object")
        unknown = sorted(set(m) - MODE_KEYS)
        if unknown:
            raise InputError(f"{where}: unknown key(s) {', '.join(unknown)}")
        if ("frequency_hz" in m) == ("eigenvalue" in m):
            raise InputError(f"{where}: give exactly one of frequency_hz or eigenvalue")
        for alias, key in MODE_ALIASES.items():
            if alias in m and key in m:
                raise InputError(f"{where}: give {key} or {alias} (two spellings of one key), not both")
        written = {MODE_ALIASES.get(k, k): k for k in m}  # each key as the file spells it, for the messages
        m = {MODE_ALIASES.get(k, k): v for k, v in m.items()}
        # per-mode uncertainty, weight and damping (null: not given), named as the file names them
        extra = {k: (check_std_damping_ratio if k == "std_damping_ratio" else positive)(m[k], f"{where} {written[k]}")
                 for k in ("std_frequency", "std_eigenvalue", "std_shape", "weight", "std_damping_ratio")
                 if m.get(k) is not None}
        if m.get("damping_ratio") is not None:
            extra["damping_ratio"] = check_damping_ratio(m["damping_ratio"], f"{where} damping_ratio")
        elif "std_damping_ratio" in extra:
            raise InputError(f"{where}: {written['std_damping_ratio']} is given without damping_ratio")
        if "std_frequency" in extra and "std_eigenvalue" in extra:
            raise InputError(f"{where}: give at most one of {written['std_frequency']} or std_eigenvalue")
        if "std_frequency" in extra:  # λ ∝ f²: σ_λ/λ = 2 σ_f/f to first order
            extra["std_eigenvalue"] = 2.0 * extra.pop("std_frequency")
        shape = m.get("shape", {}) or {}
        if not isinstance(shape, Mapping):
            raise InputError(f"{where}: shape must be an object {{dof: value}}")
        vals = [_complex(v, f"{where} shape {d}") for d, v in shape.items()]
        arr = np.array(vals, dtype=complex if any(isinstance(v, complex) for v in vals) else float)
        label = str(m.get("label", f"mode {i}"))
        value = (_number(m["frequency_hz"], f"{where} frequency_hz") if "frequency_hz" in m
                 else _number(m["eigenvalue"], f"{where} eigenvalue"))  # these name the mode themselves
        ref = m.get("reference_dof")
        if ref is not None and not isinstance(ref, str):
            raise InputError(f"{where}: reference_dof must be a dof label such as \"3:x\"")
        try:
            shape_dofs = resolve_all(shape, dofs, "shape")
            if ref is not None:
                ref = resolve_dof(ref, dofs, "reference_dof")
            mode_sensors = sensors
            if mode_sensors is None and m.get("sensors") is not None:
                mode_sensors = _sensor_list(m["sensors"], dofs, "sensors")
            if mode_sensors is None:
                mode_sensors = top_sensors
            if "frequency_hz" in m:
                mode = MeasuredMode.from_frequency(value, shape_dofs, arr, label)
                mode = MeasuredMode(mode.eigenvalue, mode.dofs, mode.shape, label, ref, **extra)
            else:
                mode = MeasuredMode(value, shape_dofs, arr, label, ref, **extra)
            if mode_sensors is not None:
                mode = _keep_sensors(mode, mode_sensors, where, notes)
            modes.append(mode)
        except InputError as exc:
            msg = str(exc)
            raise InputError(msg if msg.startswith(where) else f"{where}: {msg}") from None
    frf = None
    if raw.get("frf") is not None:
        frf = _frf(raw["frf"], dofs)
    static_raw = raw.get("static") or []
    if isinstance(static_raw, Mapping):
        static_raw = [static_raw]
    if not isinstance(static_raw, list):
        raise InputError("'static' must be an object or a list of objects")
    static = []
    for i, s in enumerate(static_raw, start=1):
        where = f"static[{i}]"
        if not isinstance(s, Mapping) or not isinstance(s.get("force"), Mapping) or not isinstance(s.get("displacement"), Mapping):
            raise InputError(f"{where}: needs 'force' and 'displacement' objects {{dof: value}}")
        force_values = [_number(v, f"{where} force {d}") for d, v in s["force"].items()]
        disp = s["displacement"]
        u = np.array([_number(v, f"{where} displacement {d}") for d, v in disp.items()])
        try:
            force = dict(zip(resolve_all(s["force"], dofs, "force"), force_values))
            static.append(StaticData(force, resolve_all(disp, dofs, "displacement"), u))
        except InputError as exc:
            msg = str(exc)
            raise InputError(msg if msg.startswith(where) else f"{where}: {msg.removeprefix('static: ')}") from None
    if not modes and frf is None and not static:
        raise InputError("no test data: expected at least one of modes, frf, static")
    units = raw.get("units", {}) or {}
    if not isinstance(units, Mapping):
        raise InputError("'units' must be an object")
    return TestData(tuple(modes), frf, tuple(static), dict(units), notes=tuple(notes))


def _frf(f, model_dofs=None) -> FRFData:
    if not isinstance(f, Mapping):
        raise InputError("frf must be an object")
    axes = [k for k in ("omega_rad_s", "frequency_hz") if k in f]
    if len(axes) != 1:
        raise InputError("frf: give exactly one of omega_rad_s (rad/s) or frequency_hz (Hz) for the frequency axis"
                         + (", not both" if len(axes) == 2 else ""))
    axis = axes[0]
    for k in ("force", "response"):
        if k not in f:
            raise InputError(f"frf: missing '{k}'")
    unknown = sorted(set(f) - {"omega_rad_s", "frequency_hz", "force", "response"})
    if unknown:
        raise InputError(f"frf: unknown key(s) {', '.join(unknown)}")
    if not isinstance(f[axis], list):
        raise InputError(f"frf: {axis} must be a list of numbers")
    if not isinstance(f["force"], Mapping) or not isinstance(f["response"], Mapping):
        raise InputError("frf: force and response must be objects {dof: ...}")
    omega = [_number(w, f"frf {axis}") for w in f[axis]]
    if axis == "frequency_hz":
        omega = [2 * math.pi * w for w in omega]
    force_values = [_complex(v, f"frf force {d}") for d, v in f["force"].items()]
    force = dict(zip(resolve_all(f["force"], model_dofs, "frf force"), force_values))
    dofs, cols = [], []
    for d, series in f["response"].items():
        if not isinstance(series, list) or len(series) != len(omega):
            raise InputError(f"frf response {d}: expected {len(omega)} values (one per frequency), got {len(series) if isinstance(series, list) else series!r}")
        dofs.append(d)
        cols.append([_complex(v, f"frf response {d}") for v in series])
    if not dofs:
        raise InputError("frf: response is empty")
    arr = np.array(cols).T
    if np.iscomplexobj(arr) and not np.any(arr.imag):
        arr = arr.real
    return FRFData(np.array(omega), force, resolve_all(dofs, model_dofs, "frf response"), arr)


def _value(v):
    """A shape or FRF value as the JSON writes it: a number, or ``[re, im]``."""
    return [float(v.real), float(v.imag)] if isinstance(v, complex | np.complexfloating) else float(v)


def testdata_object(data: TestData) -> dict:
    """The test-data JSON object of ``data`` (docs/file-formats.md), which :func:`parse_testdata`
    reads back to the same data (the eigenvalue through ``frequency_hz``, to round-off).

    Parameters
    ----------
    data : TestData
        Modes (with their labels, reference dofs, standard deviations, weights and damping
        ratios), at most one FRF set, static cases, units and notes.

    Returns
    -------
    dict
        ``modes``, and ``frf``, ``static``, ``units``, ``notes`` where the data have them.

    Raises
    ------
    InputError
        Several FRF sets (the JSON format holds one).
    """
    out: dict = {"modes": []}
    for m in data.modes:
        obj: dict = {"label": m.label, "frequency_hz": m.frequency_hz}
        if m.has_shape:
            obj["shape"] = {d: _value(v) for d, v in zip(m.dofs, m.shape)}
        for key in ("reference_dof", "std_eigenvalue", "std_shape", "weight", "damping_ratio", "std_damping_ratio"):
            if getattr(m, key) is not None:
                obj[key] = getattr(m, key)
        out["modes"].append(obj)
    if data.n_frf_sets > 1:
        raise InputError(f"the test data hold {data.n_frf_sets} FRF sets (one per excitation); the test-data JSON "
                         "holds one: keep the universal file, or convert the modes alone")
    if data.frf is not None:
        f = data.frf
        out["frf"] = {"omega_rad_s": [float(w) for w in f.omega], "force": {d: _value(v) for d, v in f.force.items()},
                      "response": {d: [_value(v) for v in f.response[:, j]] for j, d in enumerate(f.dofs)}}
    if data.static:
        out["static"] = [{"force": dict(s.force), "displacement": dict(zip(s.dofs, map(float, s.displacement)))}
                         for s in data.static]
    if not out["modes"]:
        del out["modes"]
    if data.units:
        out["units"] = dict(data.units)
    if data.notes:
        out["notes"] = list(data.notes)
    return out
