"""Checkpoints of long posterior runs: the sampler's state after each finished piece of work (an
MCMC segment, a TMCMC stage), resumed by a re-run with the same inputs.

The file is a NumPy ``.npz`` archive read without pickle: the state's arrays, and ``meta`` — a
JSON text with the format, its version, the run's key (a SHA-256 of everything that determines
the result: model matrices, parameters and priors, test data, options, method settings and seed)
and the SHA-256 of every array (:func:`array_digest`).  It is rewritten atomically
(:func:`femupdate.io.results.atomic_write_bytes`) after each piece, so an interrupted run leaves
the last complete state behind; a resumed run continues from it to the very result an
uninterrupted one gives (the random streams are derived from the seed and the piece's number).
A file of another run (another key), of another format or version, or whose arrays do not match
their digests, is refused by name.
"""

from __future__ import annotations

import dataclasses
import hashlib
import io
import json
import math
from pathlib import Path

import numpy as np

from .._errors import InputError
from ..io.results import atomic_write_bytes

FORMAT = "femupdate-posterior-checkpoint"
VERSION = 1


def run_key(*parts) -> str:
    """SHA-256 of ``parts``: numbers (by ``repr``), strings, None, booleans, NumPy arrays (dtype,
    shape and bytes), SciPy sparse matrices (CSR data, indices, pointers), dataclasses (their
    fields), mappings (sorted keys), sequences — nested in any way."""
    h = hashlib.sha256(FORMAT.encode())
    _feed(h, parts)
    return h.hexdigest()


def _feed(h, obj) -> None:
    import scipy.sparse as sp

    if obj is None or isinstance(obj, (bool, np.bool_)):
        h.update(f"<{obj!r}>".encode())
    elif isinstance(obj, (int, np.integer)):
        h.update(f"i{int(obj)}".encode())
    elif isinstance(obj, (float, np.floating)):
        h.update(f"f{float(obj)!r}".encode())
    elif isinstance(obj, str):
        h.update(f"s{len(obj)}:".encode() + obj.encode())
    elif isinstance(obj, np.ndarray):
        a = np.ascontiguousarray(obj)
        h.update(repr((a.dtype.str, a.shape)).encode())
        h.update(a.tobytes())
    elif sp.issparse(obj):
        A = sp.csr_array(obj)
        A.sort_indices()
        h.update(b"csr")
        for part in (A.data, A.indices.astype(np.int64), A.indptr.astype(np.int64), np.array(A.shape)):
            _feed(h, part)
    elif dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        h.update(type(obj).__name__.encode())
        for f in dataclasses.fields(obj):
            h.update(f.name.encode())
            _feed(h, getattr(obj, f.name))
    elif isinstance(obj, dict) or hasattr(obj, "items"):
        h.update(b"{")
        for k in sorted(obj, key=str):
            _feed(h, str(k))
            _feed(h, obj[k])
        h.update(b"}")
    elif isinstance(obj, (list, tuple)):
        h.update(b"[")
        for v in obj:
            _feed(h, v)
        h.update(b"]")
    else:
        h.update(f"o{type(obj).__name__}:{obj!r}".encode())


def array_digest(a: np.ndarray) -> str:
    """SHA-256 of an array's dtype, shape and bytes."""
    h = hashlib.sha256()
    a = np.ascontiguousarray(a)
    h.update(repr((a.dtype.str, a.shape)).encode())
    h.update(a.tobytes())
    return h.hexdigest()


class RunCheckpoint:
    """The checkpoint file of one posterior run (or none: ``path`` None).

    Parameters
    ----------
    path : str, os.PathLike or None
        The file; None keeps nothing.
    key : str
        The run's key (:func:`run_key`).
    description : dict
        A short description written into the file (JSON-compatible).
    """

    def __init__(self, path, key: str, description: dict):
        self.path = Path(path) if path is not None else None
        self.key = key
        self.description = description

    def load(self) -> tuple[dict, dict] | None:
        """The saved state's arrays and its ``meta`` (None when there is no file).

        Raises
        ------
        InputError
            An unreadable file, another format or version, another run's file, or an array that
            is missing or does not match its digest (named).
        """
        if self.path is None or not self.path.exists():
            return None
        where = f"checkpoint {self.path}"
        try:
            with np.load(self.path, allow_pickle=False) as z:
                arrays = {k: z[k] for k in z.files}
        except (OSError, ValueError, EOFError) as exc:
            raise InputError(f"{where}: not a readable femupdate posterior checkpoint ({exc})") from None
        try:
            meta = json.loads(str(arrays.pop("meta")), parse_constant=_refuse)
        except (KeyError, ValueError):
            raise InputError(f"{where}: not a femupdate posterior checkpoint (no readable 'meta')") from None
        if not isinstance(meta, dict) or meta.get("format") != FORMAT:
            raise InputError(f"{where}: not a femupdate posterior checkpoint")
        if meta.get("version") != VERSION:
            raise InputError(f"{where}: format version {meta.get('version')!r}; this femupdate reads {VERSION}")
        if meta.get("run") != self.key:
            raise InputError(f"{where} belongs to a different run (the model, priors, data, options, method settings "
                             "or seed differ): delete it, or give another --checkpoint path")
        digests = meta.get("digests")
        if not isinstance(digests, dict) or set(digests) != set(arrays):
            raise InputError(f"{where}: its arrays do not match its list of digests (the file was edited or damaged); "
                             "delete it, or give another --checkpoint path")
        for name, a in arrays.items():
            if array_digest(a) != digests[name]:
                raise InputError(f"{where}: array {name!r} does not match its digest (the file was edited or damaged); "
                                 "delete it, or give another --checkpoint path")
        return arrays, meta

    def save(self, arrays: dict, state: dict) -> None:
        """Write ``arrays`` and the JSON-compatible ``state`` atomically (nothing without a path)."""
        if self.path is None:
            return
        arrays = {k: np.ascontiguousarray(v) for k, v in arrays.items()}
        meta = {"format": FORMAT, "version": VERSION, "run": self.key, "description": self.description,
                "state": state, "digests": {k: array_digest(v) for k, v in arrays.items()}}
        buf = io.BytesIO()
        np.savez(buf, meta=np.array(json.dumps(meta, allow_nan=False)), **arrays)
        atomic_write_bytes(self.path, buf.getvalue())


def _refuse(name: str):
    raise ValueError(f"{name} is not a number a checkpoint holds")


def finite(value: float) -> float | None:
    """A float for the checkpoint's JSON (None for a non-finite value)."""
    return float(value) if math.isfinite(value) else None


__all__ = ["RunCheckpoint", "run_key", "array_digest", "FORMAT", "VERSION"]
