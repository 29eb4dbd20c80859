"""Checkpoints of a uniqueness study: finished work units on disk, resumed by a re-run.

The file is JSON (no pickle): the study's key (a SHA-256 of everything that determines its
results — model matrices, parameters, truth, cases, starts, seed, noise levels, solver options and
the split into work units), a short description, and the raw results of every finished unit.  It
is rewritten atomically (:func:`femupdate.io.results.atomic_write_text`) after each unit, so an
interrupted study — Ctrl-C, a killed process — leaves the last complete version behind.  Floats
are written with ``repr`` precision, so resumed results are bit-identical to computed ones.
"""

from __future__ import annotations

import json
from pathlib import Path

from .._errors import InputError
from ..io.results import atomic_write_text, to_jsonable

FORMAT = "femupdate-uniqueness-checkpoint"
VERSION = 1


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

    Raises
    ------
    InputError
        An existing file that is unreadable, not a femupdate uniqueness checkpoint, of another
        format version, of a different study (another key), or with malformed units.
    """

    def __init__(self, path, key: str, description: dict):
        self.path = Path(path) if path is not None else None
        self.key = key
        self.description = description
        self.units: dict[int, list] = {}
        if self.path is not None and self.path.exists():
            self._load()

    def _load(self) -> None:
        if self.path is None:  # only called with a path (see __init__)
            raise RuntimeError("internal error: a checkpoint without a path was loaded")
        try:
            doc = json.loads(self.path.read_text())
        except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
            raise InputError(f"checkpoint {self.path}: not a readable femupdate checkpoint ({exc})") from None
        if not isinstance(doc, dict) or doc.get("format") != FORMAT:
            raise InputError(f"checkpoint {self.path}: not a femupdate uniqueness checkpoint")
        if doc.get("version") != VERSION:
            raise InputError(f"checkpoint {self.path}: version {doc.get('version')!r}, this femupdate writes {VERSION}")
        if doc.get("study") != self.key:
            raise InputError(
                f"checkpoint {self.path} belongs to a different study (the model, cases, starts, seed, noise levels or "
                "solver options differ): delete it, or give another --checkpoint path")
        units = doc.get("units")
        if not isinstance(units, dict):
            raise InputError(f"checkpoint {self.path}: 'units' must be an object")
        try:
            self.units = {int(k): v for k, v in units.items()}
        except ValueError:
            raise InputError(f"checkpoint {self.path}: unit ids must be integers") from None

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
                   "units": {str(k): self.units[k] for k in sorted(self.units)}}
            atomic_write_text(self.path, json.dumps(doc, separators=(",", ":"), allow_nan=False) + "\n")

    def __contains__(self, unit: int) -> bool:
        return int(unit) in self.units


__all__ = ["Checkpoint", "FORMAT", "VERSION"]
