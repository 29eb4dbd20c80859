"""The updated model out: the model file again, with the updated parameter values and a
provenance table, and flat tables (CSV) of parameters and paired modes.

:func:`updated_model_text` re-writes the user's own TOML model file (same schema, every table
kept) with each updated parameter's ``value`` replaced and a ``[provenance]`` table (source model,
data file, date, femupdate version, command, cost, updated parameters) added; the paths of a
``[matrices]`` model are re-written relative to the new file's folder, so it loads from wherever
it is written.  The TOML is written by ``tomli-w``: the values, tables and order of the original
are kept, its comments and layout are not.
"""

from __future__ import annotations

import csv
import datetime as _dt
import io
import math
import os
from collections.abc import Mapping, Sequence
from pathlib import Path

from .._errors import InputError
from .model_file import read_toml
from .results import atomic_write_text

#: keys of a ``[matrices]`` table (and of a matrix-model parameter) that name files
_MATRIX_KEYS = ("dofs", "K0", "M0")
#: keys of an ``[abaqus]`` and a ``[nastran]`` table that name files
_ABAQUS_KEYS = ("stiffness", "mass", "deck")
_NASTRAN_KEYS = ("op4", "op2", "dmig", "deck")
_ANSYS_KEYS = ("full", "deck")
#: keys of a ``[mesh]`` table that name files
_MESH_KEYS = ("file",)


def _moved(spec, src_dir: Path, out_dir: Path):
    """A file reference of the model at ``src_dir`` as seen from ``out_dir`` (``file.mat:VAR``
    keeps its variable)."""
    if not isinstance(spec, str):
        return spec
    path, var = spec, ""
    head, sep, tail = spec.rpartition(":")
    if sep and head.lower().endswith(".mat"):
        path, var = head, sep + tail
    target = (src_dir / path).resolve()
    try:
        rel = os.path.relpath(target, out_dir.resolve())
    except ValueError:  # another drive (Windows): keep it absolute
        rel = str(target)
    return Path(rel).as_posix() + var


def updated_model_text(source, out_path, values: Mapping[str, float], provenance: Mapping) -> str:
    """The TOML text of the model file ``source`` with ``values`` as its parameters' values.

    Parameters
    ----------
    source : str or os.PathLike
        The model file the update started from (TOML).
    out_path : str or os.PathLike
        Where the text will be written (matrix and mesh file paths are made relative to its folder).
    values : mapping of str to float
        The updated parameters' values.
    provenance : mapping
        Written as the ``[provenance]`` table (strings, numbers, lists of strings).

    Returns
    -------
    str
        The TOML document.

    Raises
    ------
    InputError
        ``source`` unreadable (as :func:`~femupdate.io.model_file.read_toml`); a value of
        ``values`` not finite, outside the parameter's bounds, or naming no parameter of the file.
    """
    import tomli_w

    source, out_path = Path(source), Path(out_path)
    raw = read_toml(source)
    params = raw.get("parameters", {})
    for name, v in values.items():
        spec = params.get(name)
        if not isinstance(spec, dict):
            raise InputError(f"{source}: no [parameters.{name}] table to write the updated value into")
        v = float(v)
        lo, hi = (spec.get("bounds") or [-math.inf, math.inf])[:2]
        if not math.isfinite(v) or not lo <= v <= hi:
            raise InputError(f"updated model: {name} = {v:.6g} lies outside its bounds [{lo:g}, {hi:g}] in {source}; "
                             "the model file would not load (update with bounds, not --method lm)")
        exported = ("abaqus" in raw and {"K_elements", "M_elements"} & set(spec)) or ("ansys" in raw and
                                                                                     {"scales", "full"} & set(spec))
        if exported and "exported_at" not in spec:
            spec["exported_at"] = spec["value"]  # the value the element matrices were written at
        spec["value"] = v
    src_dir, out_dir = source.parent, out_path.parent
    param_keys = {"matrices": ("K", "M"), "abaqus": ("K_elements", "M_elements"), "nastran": (), "ansys": ("full",), "mesh": ()}
    for table, keys in (("matrices", _MATRIX_KEYS), ("abaqus", _ABAQUS_KEYS), ("nastran", _NASTRAN_KEYS), ("ansys", _ANSYS_KEYS),
                        ("mesh", _MESH_KEYS)):
        if not isinstance(raw.get(table), dict):
            continue
        mt = raw[table]
        for key in keys:
            if key in mt and isinstance(mt[key], str):
                mt[key] = _moved(mt[key], src_dir, out_dir)
        for spec in params.values():
            for key in param_keys[table]:
                if isinstance(spec, dict) and key in spec:
                    spec[key] = _moved(spec[key], src_dir, out_dir)
    raw["provenance"] = {k: v for k, v in provenance.items() if v is not None}
    return tomli_w.dumps(raw)


def provenance(model_path, data_path, command: str, cost: float | None, updated: Sequence[str]) -> dict:
    """The ``[provenance]`` table of an updated model file.

    Parameters
    ----------
    model_path, data_path : str or os.PathLike or None
        The model file and the test data the update used.
    command : str
        The femupdate command (``"update"``, ``"direct"``, ...).
    cost : float or None
        The final cost (½‖r‖²) where the command has one.
    updated : sequence of str
        The parameters the command identified.

    Returns
    -------
    dict
    """
    from .._version import __version__

    out: dict = {"source_model": str(model_path), "data": None if data_path is None else str(data_path),
                 "command": command, "femupdate_version": __version__,
                 "date": _dt.datetime.now(_dt.timezone.utc).replace(microsecond=0).isoformat(),
                 "updated": list(updated)}
    if cost is not None and math.isfinite(cost):
        out["cost"] = float(cost)
    return out


def write_updated_model(source, out_path, values: Mapping[str, float], provenance: Mapping) -> None:
    """Write :func:`updated_model_text` to ``out_path`` atomically.

    Parameters
    ----------
    source, out_path, values, provenance
        As :func:`updated_model_text`.

    Raises
    ------
    InputError
        As :func:`updated_model_text`; the file cannot be written.
    """
    atomic_write_text(out_path, updated_model_text(source, out_path, values, provenance))


def csv_text(header: Sequence[str], rows: Sequence[Sequence]) -> str:
    """A CSV table (``pandas.read_csv`` reads it as is): numbers in full precision (``repr``),
    missing values empty.

    Parameters
    ----------
    header : sequence of str
        Column names.
    rows : sequence of sequences
        One row per record, in the order of ``header``.

    Returns
    -------
    str
    """
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(header)
    for row in rows:
        w.writerow(["" if v is None or (isinstance(v, float) and not math.isfinite(v)) else
                    repr(float(v)) if isinstance(v, float) else v for v in row])
    return buf.getvalue()


def write_parameter_table(path, model, names, start, updated, std, at_bounds=None) -> Path:
    """``parameters.csv``: ``parameter, start, updated, change_percent, std, lower, upper``, and
    ``on_bound`` when ``at_bounds`` is given.

    Parameters
    ----------
    path : str or os.PathLike
        The file (written atomically).
    model : Model
        Its bounds.
    names : sequence of str
        The identified parameters, one row each.
    start, updated, std : sequence of float
        Their starting and identified values and standard deviations (NaN: none).
    at_bounds : mapping of str to str, optional
        ``{name: "lower" | "upper"}`` of the parameters on a bound.

    Returns
    -------
    pathlib.Path
    """
    rows = []
    for n, s0, v, sd in zip(names, start, updated, std):
        lo, hi = model.parameters[model.parameter_index(n)].bounds
        s0, v = float(s0), float(v)
        row = [n, s0, v, (v / s0 - 1) * 100 if s0 else math.nan, float(sd), float(lo), float(hi)]
        rows.append(row + ([at_bounds.get(n, "")] if at_bounds is not None else []))
    header = ["parameter", "start", "updated", "change_percent", "std", "lower", "upper"]
    atomic_write_text(path, csv_text(header + (["on_bound"] if at_bounds is not None else []), rows))
    return Path(path)


def write_result_tables(folder, model, res, damping: dict | None = None) -> list[Path]:
    """``parameters.csv`` and, with paired modes, ``modes.csv`` of an update result in ``folder``.

    ``parameters.csv``: ``parameter, start, updated, change_percent, std, lower, upper,
    on_bound``; ``modes.csv``: ``test_mode, model_mode`` (1-based, as on the terminal),
    ``f_test_hz, f_model_hz, error_percent, mac``, and with ``damping``
    ``damping_test, damping_test_std, damping_model`` (empty where not known).

    Parameters
    ----------
    folder : str or os.PathLike
        An existing folder.
    model : Model
        Its bounds.
    res : UpdateResult
        The result.
    damping : dict, optional
        The result's ``damping_ratio`` fields (``test``, ``std``, ``model``: one per test mode).

    Returns
    -------
    list of pathlib.Path
        The files written (atomically).
    """
    folder = Path(folder)
    d = res.diagnostics
    std = [float(d.std[j]) if d is not None and j < len(d.std) else math.nan for j in range(len(res.names))]
    out = [write_parameter_table(folder / "parameters.csv", model, res.names,
                                 [res.start.get(n, math.nan) for n in res.names], res.x, std,
                                 getattr(d, "at_bounds", {}) or {})]
    if res.pairs:
        mrows = [[k + 1, j + 1, float(ft), float(fa), (float(fa) - ft) / ft * 100 if ft else math.nan, float(m)]
                 for (k, j, m), ft, fa in zip(res.pairs, res.test_frequencies_hz, res.model_frequencies_hz)]
        header = ["test_mode", "model_mode", "f_test_hz", "f_model_hz", "error_percent", "mac"]
        if damping:
            header += ["damping_test", "damping_test_std", "damping_model"]
            for row, (k, _, _) in zip(mrows, res.pairs):
                row += [math.nan if v is None else v for v in (damping["test"][k], damping["std"][k],
                                                              damping["model"][k])]
        out.append(folder / "modes.csv")
        atomic_write_text(out[1], csv_text(header, mrows))
    return out


__all__ = ["updated_model_text", "write_updated_model", "provenance", "csv_text", "write_parameter_table",
           "write_result_tables"]
