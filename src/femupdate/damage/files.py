"""Files of the multi-configuration, full-field and damage tools (TOML or JSON, same schema).

Modification (one configuration's known changes; TOML shown, JSON has the same keys)::

    name = "1.5 kg at the tip"      # optional; default the file name
    [[mass]]                        # known lumped mass added on each listed dof
    dofs = ["2:x"]
    m = 1.5
    [[spring]]                      # known spring: one dof (to ground) or two (between them)
    dofs = ["1:x", "2:x"]
    k = 500.0
    [[support]]                     # dofs (or every dof of nodes) fixed in this configuration
    dofs = ["3:x"]
    nodes = [4]
    [values]                        # known (fixed) parameters that take other values here
    k_mount = 2.0e4

Candidates for pre-test ranking: the same tables under ``[[candidate]]`` (TOML:
``[[candidate]]`` with ``name``, then ``[[candidate.mass]]`` ...; JSON:
``{"candidates": [{"name": ..., "mass": [...]}, ...]}``).

Full-field scan (JSON): points by coordinates, measured translation components per point::

    {"points": [[x, y, z], ...],
     "modes": [{"frequency_hz": 8.1, "values": {"y": [v_1, ..., v_n]}}],
     "frf": {"omega_rad_s": [...], "force": {"11:y": 1.0},
             "values": {"y": [[v_1, ..., v_n], ...]}},      # one row per frequency; [re, im] pairs allowed
     "zero": ["x"],                                         # optional: directions known to be zero
     "max_distance": 0.02}                                  # optional: geometry tolerance (m)
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from .._errors import InputError
from ..io.model_file import read_toml
from ..structure.tables import list_of_tables
from .multiconfig import Modification

_MOD_KEYS = {"name", "mass", "spring", "support", "values"}


def _read(path) -> dict:
    path = Path(path)
    if path.suffix.lower() == ".toml":
        return read_toml(path)
    if path.suffix.lower() != ".json":
        raise InputError(f"{path}: expected a .toml or .json file")
    try:
        return json.loads(path.read_text())
    except FileNotFoundError:
        raise InputError(f"{path}: no such file") from None
    except (IsADirectoryError, UnicodeDecodeError):
        raise InputError(f"{path}: not a readable JSON text file") from None
    except json.JSONDecodeError as exc:
        raise InputError(f"{path}: malformed JSON: {exc}") from None


def _labels(v, where: str) -> list[str]:
    if isinstance(v, str):
        v = [v]
    if not isinstance(v, list) or not v or not all(isinstance(x, str) for x in v):
        raise InputError(f"{where}: dofs must be a list of dof labels such as [\"3:x\"], got {v!r}")
    return v


def _num(v, where: str) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
        raise InputError(f"{where}: expected a finite number, got {v!r}")
    return float(v)


def modification_from_dict(raw, source: str = "modification", default_name: str = "modified") -> Modification:
    """A :class:`Modification` from the parsed file (schema in the module docstring)."""
    if not isinstance(raw, Mapping):
        raise InputError(f"{source}: expected a table / object")
    extra = sorted(set(raw) - _MOD_KEYS)
    if extra:
        raise InputError(f"{source}: unknown key(s) {', '.join(map(str, extra))} (allowed: {', '.join(sorted(_MOD_KEYS))})")
    name = raw.get("name", default_name)
    if not isinstance(name, str) or not name:
        raise InputError(f"{source}: name must be a non-empty string")
    masses, springs, supports, nodes = [], [], [], []
    for i, t in enumerate(list_of_tables(raw, "mass", source), start=1):
        where = f"{source}: mass #{i}"
        if set(t) != {"dofs", "m"}:
            raise InputError(f"{where}: needs exactly 'dofs' and 'm', got {', '.join(map(str, t)) or 'nothing'}")
        m = _num(t["m"], f"{where} m")
        masses += [(d, m) for d in _labels(t["dofs"], where)]
    for i, t in enumerate(list_of_tables(raw, "spring", source), start=1):
        where = f"{source}: spring #{i}"
        if set(t) != {"dofs", "k"}:
            raise InputError(f"{where}: needs exactly 'dofs' and 'k', got {', '.join(map(str, t)) or 'nothing'}")
        springs.append((tuple(_labels(t["dofs"], where)), _num(t["k"], f"{where} k")))
    for i, t in enumerate(list_of_tables(raw, "support", source), start=1):
        where = f"{source}: support #{i}"
        if not t or set(t) - {"dofs", "nodes"}:
            raise InputError(f"{where}: expected 'dofs' (labels) and/or 'nodes' (ids)")
        if "dofs" in t:
            supports += _labels(t["dofs"], where)
        if "nodes" in t:
            ids = t["nodes"]
            if not isinstance(ids, list) or not all(isinstance(x, int) and not isinstance(x, bool) for x in ids):
                raise InputError(f"{where}: nodes must be a list of integer ids, got {ids!r}")
            nodes += ids
    values = raw.get("values", {})
    if not isinstance(values, Mapping):
        raise InputError(f"{source}: [values] must be a table {{parameter = value}}")
    values = {str(k): _num(v, f"{source}: values.{k}") for k, v in values.items()}
    try:
        return Modification(name, tuple(masses), tuple(springs), tuple(supports), tuple(nodes), values)
    except InputError as exc:
        raise InputError(f"{source}: {exc}") from None


def load_modification(path) -> Modification:
    """Read one configuration's modification (TOML or JSON)."""
    path = Path(path)
    return modification_from_dict(_read(path), str(path), default_name=path.stem)


def load_candidates(path) -> list[Modification]:
    """Read candidate modifications for :func:`~femupdate.damage.rank_modifications`."""
    path = Path(path)
    raw = _read(path)
    key = "candidate" if "candidate" in raw else "candidates"
    if not isinstance(raw, Mapping) or key not in raw or set(raw) != {key}:
        raise InputError(f"{path}: expected only [[candidate]] tables (TOML) or {{\"candidates\": [...]}} (JSON)")
    out = [modification_from_dict(t, f"{path}: candidate #{i}", default_name=f"candidate {i}")
           for i, t in enumerate(list_of_tables(raw, key, str(path)), start=1)]
    if not out:
        raise InputError(f"{path}: no candidates")
    return out


def split_config_spec(spec: str) -> tuple[Path, Path | None]:
    """``"DATA"`` or ``"DATA:MODIFICATION.toml"`` (the modification ends in .toml or .json)."""
    head, sep, tail = spec.rpartition(":")
    if sep and Path(tail).suffix.lower() in (".toml", ".json") and head:
        return Path(head), Path(tail)
    return Path(spec), None


# ------------------------------------------------------------------------------ scans
def _complex_rows(v, n: int, where: str) -> np.ndarray:
    if not isinstance(v, list) or len(v) != n:
        raise InputError(f"{where}: expected {n} values (one per scan point), got {len(v) if isinstance(v, list) else v!r}")
    out = np.empty(n, dtype=complex)
    for i, x in enumerate(v):
        if isinstance(x, list):
            if len(x) != 2:
                raise InputError(f"{where}[{i}]: a complex value is a pair [re, im], got {x!r}")
            out[i] = complex(_num(x[0], f"{where}[{i}]"), _num(x[1], f"{where}[{i}]"))
        else:
            out[i] = _num(x, f"{where}[{i}]")
    return out


def scan_from_dict(raw, source: str = "scan"):
    """A :class:`~femupdate.damage.fullfield.ScanData` from the parsed JSON (module docstring)."""
    from ..testdata import MeasuredMode
    from .fullfield import ScanData, ScanFRF, ScanMode

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
        rows.append([_num(c, f"{source}: points[{i}]") for c in p] + [0.0] * (3 - len(p)))
    n = len(rows)
    modes = []
    for k, m in enumerate(raw.get("modes", []) or [], start=1):
        where = f"{source}: modes[{k}]"
        if not isinstance(m, Mapping) or set(m) - {"frequency_hz", "eigenvalue", "values", "label"} or "values" not in m:
            raise InputError(f"{where}: expected frequency_hz or eigenvalue, and values {{direction: [...]}}")
        if ("frequency_hz" in m) == ("eigenvalue" in m):
            raise InputError(f"{where}: give exactly one of frequency_hz or eigenvalue")
        lam = (2 * math.pi * _num(m["frequency_hz"], f"{where} frequency_hz")) ** 2 if "frequency_hz" in m \
            else _num(m["eigenvalue"], f"{where} eigenvalue")
        MeasuredMode(lam, label=str(m.get("label", f"mode {k}")))  # validates the eigenvalue
        vals = _values(m["values"], n, where, lambda v, w: _complex_rows(v, n, w))
        modes.append(ScanMode(lam, vals, str(m.get("label", f"mode {k}"))))
    frf = None
    if raw.get("frf") is not None:
        f = raw["frf"]
        where = f"{source}: frf"
        if not isinstance(f, Mapping) or set(f) != {"omega_rad_s", "force", "values"}:
            raise InputError(f"{where}: expected exactly omega_rad_s, force and values")
        if not isinstance(f["omega_rad_s"], list) or not f["omega_rad_s"]:
            raise InputError(f"{where}: omega_rad_s must be a non-empty list")
        omega = np.array([_num(w, f"{where} omega_rad_s") for w in f["omega_rad_s"]])
        if not isinstance(f["force"], Mapping) or not f["force"]:
            raise InputError(f"{where}: force must be an object {{dof: value}}")
        force = {str(d): _num(v, f"{where} force {d}") for d, v in f["force"].items()}

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
    md = None if md is None else _num(md, f"{source}: max_distance")
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
    """Read a full-field scan (JSON, schema in the module docstring)."""
    path = Path(path)
    if path.suffix.lower() != ".json":
        raise InputError(f"{path}: a scan file is JSON (.json)")
    try:
        return scan_from_dict(_read(path), str(path))
    except InputError as exc:
        msg = str(exc)
        raise InputError(msg if msg.startswith(str(path)) else f"{path}: {msg}") from None
