"""Machine-readable results: JSON written atomically, NaN/inf as null, numpy converted."""

from __future__ import annotations

import json
import math
import os
import sys
import tempfile
from pathlib import Path

import numpy as np


def to_jsonable(obj):
    """Convert numpy scalars/arrays, tuples and non-finite floats (-> None) recursively.

    Parameters
    ----------
    obj : object
        Nested dicts, lists, tuples, NumPy arrays and scalars, numbers.

    Returns
    -------
    object
        The same structure with dict keys as str, tuples and arrays as lists, NumPy scalars as
        Python ones, NaN/inf as ``None`` and complex numbers as ``[re, im]``; other objects are
        returned unchanged.
    """
    if isinstance(obj, dict):
        return {str(k): to_jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [to_jsonable(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return to_jsonable(obj.tolist())
    if isinstance(obj, (np.bool_, bool)):
        return bool(obj)
    if isinstance(obj, (np.integer, int)):
        return int(obj)
    if isinstance(obj, (np.floating, float)):
        v = float(obj)
        return v if math.isfinite(v) else None
    if isinstance(obj, (complex, np.complexfloating)):
        return [to_jsonable(obj.real), to_jsonable(obj.imag)]
    return obj


def _mode_for(path: Path) -> int:
    """Permissions of a written file: those of the file it replaces, else 0o666 less the umask
    (what ``open(path, "w")`` gives; mkstemp's private 0o600 would surprise the user)."""
    try:
        return path.stat().st_mode & 0o777
    except FileNotFoundError:
        umask = os.umask(0)
        os.umask(umask)
        return 0o666 & ~umask


def atomic_write_bytes(path, data: bytes) -> None:
    """Write ``data`` to ``path`` atomically: a temporary file in the same folder, flushed to
    disk, then renamed over ``path`` (readers see the old file or the new one, never a part).

    The parent folders are created; the file keeps the permissions of the one it replaces (a
    new file gets 0o666 less the umask).

    Parameters
    ----------
    path : str or os.PathLike
        Destination file.
    data : bytes
        Contents.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
            fh.flush()
            os.fsync(fh.fileno())
        os.chmod(tmp, _mode_for(path))
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except FileNotFoundError:
            pass
        raise


def atomic_write_text(path, text: str) -> None:
    """Text (UTF-8) counterpart of :func:`atomic_write_bytes`.

    Parameters
    ----------
    path : str or os.PathLike
        Destination file.
    text : str
        Contents, written as UTF-8.
    """
    atomic_write_bytes(path, text.encode("utf-8"))


def write_json(path, obj) -> None:
    """Write ``obj`` as JSON to ``path`` (``"-"`` = standard output), atomically.

    Parameters
    ----------
    path : str or os.PathLike
        Destination file, or ``"-"`` for standard output.
    obj : object
        Converted by :func:`to_jsonable` (NaN/inf become ``null``), then written indented by 2
        with a final newline.

    Raises
    ------
    ValueError, TypeError
        From :func:`json.dumps`, for objects that :func:`to_jsonable` leaves unconvertible.
    """
    text = json.dumps(to_jsonable(obj), indent=2, allow_nan=False) + "\n"
    if str(path) == "-":
        sys.stdout.write(text)
        sys.stdout.flush()
    else:
        atomic_write_text(path, text)

