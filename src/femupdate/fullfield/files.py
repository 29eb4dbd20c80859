"""Full-field scan files (JSON).

Points by coordinates, measured translation components per point::

    {"points": [[x, y, z], ...],
     "modes": [{"frequency_hz": 8.1, "values": {"y": [v_1, ..., v_n]}}],
     "frf": {"omega_rad_s": [...], "force": {"11:y": 1.0},
             "values": {"y": [[v_1, ..., v_n], ...]}},      # one row per frequency; [re, im] pairs allowed
     "zero": ["x"],                                         # optional: directions known to be zero
     "max_distance": 0.02}                                  # optional: geometry tolerance (m)
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from .._errors import InputError
from ..io.tables import finite_number, read_table_file
from ..testdata import MeasuredMode
from .scan import ScanData, ScanFRF, ScanMode


def _complex_rows(v, n: int, where: str) -> np.ndarray:
    if not isinstance(v, list) or len(v) != n:
        raise InputError(f"{where}: expected {n} values (one per scan point), got {len(v) if isinstance(v, list) else v!r}")
    out = np.empty(n, dtype=complex)
    for i, x in enumerate(v):
        if isinstance(x, list):
            if len(x) != 2:
                raise InputError(f"{where}[{i}]: a complex value is a pair [re, im], got {x!r}")
            out[i] = complex(finite_number(x[0], f"{where}[{i}]"), finite_number(x[1], f"{where}[{i}]"))
        else:
            out[i] = finite_number(x, f"{where}[{i}]")
    return out


def scan_from_dict(raw, source: str = "scan"):
    """A :class:`~femupdate.fullfield.ScanData` from the parsed JSON (schema in the module docstring).

    A mode gives exactly one of ``frequency_hz`` (Hz) or ``eigenvalue`` (λ = ω², rad²/s²); values
    are real or ``[re, im]`` pairs, one per point; FRF ``values`` have one row per ``omega_rad_s``
    (rad/s) entry.

    Parameters
    ----------
    raw : mapping
        The parsed JSON object.
    source : str, default ``"scan"``
        Name used in error messages (e.g. the file name).

    Returns
    -------
    ScanData

    Raises
    ------
    InputError
        Not an object, an unknown key, malformed or non-finite points or values, a mode with both or
        neither of ``frequency_hz`` and ``eigenvalue``, a direction other than x, y, z, or neither modes
        nor frf; and as :class:`~femupdate.fullfield.ScanData`.
    """
    if not isinstance(raw, Mapping):
        raise InputError(f"{source}: expected a JSON object with 'points' and 'modes' and/or 'frf'")
    extra = sorted(set(raw) - {"points", "modes", "frf", "zero", "max_distance", "units"})
    if extra:
        raise InputError(f"{source}: unknown key(s) {', '.join(extra)} (allowed: points, modes, frf, zero, max_distance)")
    pts = raw.get("points")
    if not isinstance(pts, list) or not pts:
        raise InputError(f"{source}: 'points' must be a non-empty list of [x, y, z] (or [x, y]) coordinates")
    rows = []
    for i, p in enumerate(pts):
        if not isinstance(p, list) or len(p) not in (2, 3):
            raise InputError(f"{source}: points[{i}] must be [x, y] or [x, y, z], got {p!r}")
        rows.append([finite_number(c, f"{source}: points[{i}]") for c in p] + [0.0] * (3 - len(p)))
    n = len(rows)
    modes = []
    for k, m in enumerate(raw.get("modes", []) or [], start=1):
        where = f"{source}: modes[{k}]"
        if not isinstance(m, Mapping) or set(m) - {"frequency_hz", "eigenvalue", "values", "label"} or "values" not in m:
            raise InputError(f"{where}: expected frequency_hz or eigenvalue, and values {{direction: [...]}}")
        if ("frequency_hz" in m) == ("eigenvalue" in m):
            raise InputError(f"{where}: give exactly one of frequency_hz or eigenvalue")
        label = str(m.get("label", f"mode {k}"))
        if "frequency_hz" in m:
            f = finite_number(m["frequency_hz"], f"{where} frequency_hz")
            if f < 0:  # it is squared below: -f would pass for f
                raise InputError(f"{where}: frequency_hz {f:g} is negative")
            lam = (2 * math.pi * f) ** 2
        else:
            lam = finite_number(m["eigenvalue"], f"{where} eigenvalue")
        if lam == 0:
            raise InputError(f"{where}: zero frequency: a rigid-body mode carries no stiffness information and cannot be "
                             "a target of the identification; leave it out")
        try:
            MeasuredMode(lam, label=label)  # validates the eigenvalue
        except InputError as exc:
            raise InputError(f"{where}: {exc}") from None
        vals = _values(m["values"], n, where, lambda v, w: _complex_rows(v, n, w))
        modes.append(ScanMode(lam, vals, label))
    frf = None
    if raw.get("frf") is not None:
        f = raw["frf"]
        where = f"{source}: frf"
        if not isinstance(f, Mapping) or set(f) != {"omega_rad_s", "force", "values"}:
            raise InputError(f"{where}: expected exactly omega_rad_s, force and values")
        if not isinstance(f["omega_rad_s"], list) or not f["omega_rad_s"]:
            raise InputError(f"{where}: omega_rad_s must be a non-empty list")
        omega = np.array([finite_number(w, f"{where} omega_rad_s") for w in f["omega_rad_s"]])
        if not isinstance(f["force"], Mapping) or not f["force"]:
            raise InputError(f"{where}: force must be an object {{dof: value}}")
        force = {str(d): finite_number(v, f"{where} force {d}") for d, v in f["force"].items()}

        def lines(v, w):
            if not isinstance(v, list) or len(v) != omega.size:
                raise InputError(f"{w}: expected {omega.size} rows (one per frequency)")
            return np.array([_complex_rows(row, n, f"{w}[{i}]") for i, row in enumerate(v)])

        frf = ScanFRF(omega, force, _values(f["values"], n, where, lines))
    if not modes and frf is None:
        raise InputError(f"{source}: no modes and no frf: nothing was measured")
    zero = raw.get("zero", [])
    if not isinstance(zero, list) or not all(isinstance(z, str) for z in zero):
        raise InputError(f"{source}: 'zero' must be a list of directions such as [\"x\", \"rx\"]")
    md = raw.get("max_distance")
    md = None if md is None else finite_number(md, f"{source}: max_distance")
    return ScanData(np.array(rows), tuple(modes), frf, tuple(zero), md)


def _values(v, n, where, parse) -> dict:
    if not isinstance(v, Mapping) or not v:
        raise InputError(f"{where}: values must be an object {{direction: [...]}} with x, y and/or z")
    out = {}
    for d, series in v.items():
        if d not in ("x", "y", "z"):
            raise InputError(f"{where}: measured direction {d!r} must be x, y or z (translations)")
        out[d] = parse(series, f"{where} values.{d}")
    return out


def load_scan(path):
    """Read a full-field scan file (JSON, schema in the module docstring).

    Parameters
    ----------
    path : str or os.PathLike
        Path of the ``.json`` file.

    Returns
    -------
    ScanData

    Raises
    ------
    InputError
        Not a ``.json`` file, unreadable, or invalid as :func:`scan_from_dict` (the message starts
        with the path).
    """
    path = Path(path)
    if path.suffix.lower() != ".json":
        raise InputError(f"{path}: a scan file is JSON (.json)")
    try:
        return scan_from_dict(read_table_file(path), str(path))
    except InputError as exc:
        msg = str(exc)
        raise InputError(msg if msg.startswith(str(path)) else f"{path}: {msg}") from None
