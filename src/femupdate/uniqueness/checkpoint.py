"""Checkpoints of a uniqueness study: finished work units on disk, resumed by a re-run.

The file is JSON (no pickle): the study's key (a SHA-256 of everything that determines its
results — model matrices, parameters, truth, cases, starts, seed, noise levels, solver options and
the split into work units), a short description, and the raw results of every finished unit.  It
is rewritten atomically (:func:`femupdate.io.results.atomic_write_text`) after each unit, so an
interrupted study — Ctrl-C, a killed process — leaves the last complete version behind.  Floats
are written with ``repr`` precision, so resumed results are bit-identical to computed ones.

Every unit is checked when the file is read: its SHA-256 digest (written beside it since
version 2) and its layout — the pieces the study assigns to it (case, noise level, first start),
one value per start in each list, L values per start in ``x``, numbers where numbers belong.  A
unit that fails is refused by name: a checkpoint never silently changes a verdict.
"""

from __future__ import annotations

import hashlib
import json
import math
from collections.abc import Sequence
from pathlib import Path

from .._errors import InputError
from ..io.results import atomic_write_text, to_jsonable

FORMAT = "femupdate-uniqueness-checkpoint"
VERSION = 2
#: versions this femupdate reads (1: without per-unit digests)
READABLE = (1, 2)


def _refuse_constant(name: str):
    """``parse_constant`` of :func:`json.loads`: a checkpoint never holds NaN or infinities."""
    raise ValueError(f"{name} is not a number a checkpoint holds")


class Checkpoint:
    """Finished work units of one study, kept in a JSON file (module docstring) or in memory.

    An existing file at ``path`` is loaded on construction; :meth:`add` records a unit and rewrites
    the file atomically.

    Parameters
    ----------
    path : str, os.PathLike or None
        The checkpoint file (created on the first :meth:`add`, resumed when it exists); ``None``:
        keep the units in memory only.
    key : str
        The study's key (:meth:`~femupdate.uniqueness.study.Study.key`); an existing file must hold it.
    description : dict
        Short description of the study written into the file.
    layout : sequence, optional
        The study's work units (:meth:`~femupdate.uniqueness.study.Study.units`: per unit its
        pieces ``(case, level, first start, end start)``) and ``n_unknowns`` the number of
        unknowns: with them every unit read from the file is checked against what the study
        would compute.

    Raises
    ------
    InputError
        An existing file that is unreadable, not a femupdate uniqueness checkpoint, of another
        format version, of a different study (another key), or with a unit that is malformed,
        unknown to the study or whose digest does not match its content (named).
    """

    def __init__(self, path, key: str, description: dict, layout: Sequence | None = None,
                 n_unknowns: int | None = None):
        self.path = Path(path) if path is not None else None
        self.key = key
        self.description = description
        self.layout = layout
        self.n_unknowns = n_unknowns
        self.units: dict[int, list] = {}
        if self.path is not None and self.path.exists():
            self._load()

    def _load(self) -> None:
        if self.path is None:  # only called with a path (see __init__)
            raise RuntimeError("internal error: a checkpoint without a path was loaded")
        try:
            doc = json.loads(self.path.read_text(), parse_constant=_refuse_constant)
        except RecursionError:
            raise InputError(f"checkpoint {self.path}: not a readable femupdate checkpoint (nested too deeply)") from None
        except (OSError, ValueError) as exc:  # malformed JSON, not UTF-8, NaN, an integer too long to convert
            raise InputError(f"checkpoint {self.path}: not a readable femupdate checkpoint ({exc})") from None
        if not isinstance(doc, dict) or doc.get("format") != FORMAT:
            raise InputError(f"checkpoint {self.path}: not a femupdate uniqueness checkpoint")
        version = doc.get("version")
        if version not in READABLE:
            raise InputError(f"checkpoint {self.path}: format version {version!r}; this femupdate reads "
                             f"{', '.join(map(str, READABLE))}")
        if doc.get("study") != self.key:
            raise InputError(
                f"checkpoint {self.path} belongs to a different study (the model, cases, starts, seed, noise levels or "
                "solver options differ): delete it, or give another --checkpoint path")
        units = doc.get("units")
        if not isinstance(units, dict):
            raise InputError(f"checkpoint {self.path}: 'units' must be an object")
        digests = doc.get("digests", {}) if version >= 2 else None
        if digests is not None and not isinstance(digests, dict):
            raise InputError(f"checkpoint {self.path}: 'digests' must be an object")
        for k, v in units.items():
            if not (isinstance(k, str) and k.isdigit()):
                raise InputError(f"checkpoint {self.path}: unit id {k!r} is not a non-negative integer")
            unit = int(k)
            where = f"checkpoint {self.path}: unit {unit}"
            if digests is not None and digests.get(k) != digest(v):
                raise InputError(f"{where}: its content does not match its digest (the file was edited or damaged); "
                                 "delete the checkpoint, or give another --checkpoint path")
            problem = self._check_unit(unit, v)
            if problem:
                raise InputError(f"{where}: {problem}; delete the checkpoint, or give another --checkpoint path")
            self.units[unit] = v

    def _check_unit(self, unit: int, value) -> str | None:
        """Why the recorded ``value`` of ``unit`` cannot be the study's (None when it can)."""
        if not isinstance(value, list):
            return "not a list of pieces"
        if self.layout is None:
            return None
        if unit >= len(self.layout):
            return f"the study has {len(self.layout)} units (0 to {len(self.layout) - 1})"
        pieces = self.layout[unit]
        if len(value) != len(pieces):
            return f"{len(value)} pieces recorded, the study's unit has {len(pieces)}"
        for j, (rec, (c, lv, a, b)) in enumerate(zip(value, pieces)):
            where = f"piece {j}"
            if not isinstance(rec, dict):
                return f"{where} is not an object"
            missing = sorted({"case", "level", "start", "x", "cost", "status", "nfev", "messages"} - set(rec))
            if missing:
                return f"{where} lacks {', '.join(missing)}"
            if (rec["case"], rec["level"], rec["start"]) != (c, lv, a) or not all(
                    type(rec[f]) is int for f in ("case", "level", "start")):
                return (f"{where} is case {rec['case']!r}, level {rec['level']!r}, start {rec['start']!r}; the study's is "
                        f"case {c}, level {lv}, start {a}")
            n = b - a
            for f in ("x", "cost", "status", "nfev"):
                if not isinstance(rec[f], list) or len(rec[f]) != n:
                    return f"{where}: {f!r} must hold {n} values (one per start)"
            if not all(type(v) is int for f in ("status", "nfev") for v in rec[f]):
                return f"{where}: 'status' and 'nfev' must be integers"
            if not all(v is None or (type(v) in (int, float) and math.isfinite(v)) for v in rec["cost"]):
                return f"{where}: 'cost' must hold numbers (or null)"
            L = self.n_unknowns
            for x in rec["x"]:
                if not isinstance(x, list) or (L is not None and len(x) != L) or not all(
                        v is None or (type(v) in (int, float) and math.isfinite(v)) for v in x):
                    return f"{where}: 'x' must hold {L if L is not None else 'L'} numbers per start"
            if not isinstance(rec["messages"], dict) or not all(
                    isinstance(k, str) and isinstance(m, str) for k, m in rec["messages"].items()):
                return f"{where}: 'messages' must map start numbers to text"
        return None

    def add(self, unit: int, result: list) -> None:
        """Record a finished unit and rewrite the file atomically.

        Parameters
        ----------
        unit : int
            Id of the unit (replaces an earlier record of the same id).
        result : list
            Its result, stored as :func:`~femupdate.io.results.to_jsonable` makes it (NaN/inf as None);
            the file, when the checkpoint has one, holds every unit so far.

        Raises
        ------
        TypeError
            The result holds an object JSON cannot represent (written to file only).
        OSError
            The file cannot be written.
        """
        self.units[int(unit)] = to_jsonable(result)
        if self.path is not None:
            doc = {"format": FORMAT, "version": VERSION, "study": self.key, "description": self.description,
                   "units": {str(k): self.units[k] for k in sorted(self.units)},
                   "digests": {str(k): digest(self.units[k]) for k in sorted(self.units)}}
            atomic_write_text(self.path, json.dumps(doc, separators=(",", ":"), allow_nan=False) + "\n")

    def __contains__(self, unit: int) -> bool:
        return int(unit) in self.units


def digest(unit) -> str:
    """SHA-256 of a unit's content as JSON (keys sorted, no spaces, floats as ``repr``).

    Parameters
    ----------
    unit : object
        A unit's recorded (JSON-compatible) result.

    Returns
    -------
    str
        The hexadecimal digest.
    """
    return hashlib.sha256(json.dumps(unit, sort_keys=True, separators=(",", ":"), allow_nan=False).encode()).hexdigest()


__all__ = ["Checkpoint", "FORMAT", "VERSION", "READABLE", "digest"]
