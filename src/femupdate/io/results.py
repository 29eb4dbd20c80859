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
    remove_stale_temporaries(path)
    try:
        fd, tmp = tempfile.mkstemp(prefix=f"{_temp_prefix(path)}{os.getpid()}.", suffix=".tmp", dir=path.parent)
    except OSError as exc:  # name the file the user asked for, not the temporary one
        raise OSError(exc.errno, exc.strerror, str(path)) from None
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
            fh.flush()
            os.fsync(fh.fileno())
        os.chmod(tmp, _mode_for(path))
        os.replace(tmp, path)
    except BaseException as exc:
        try:
            os.unlink(tmp)
        except FileNotFoundError:
            pass
        if isinstance(exc, OSError):
            raise OSError(exc.errno, exc.strerror, str(path)) from None
        raise


def _temp_prefix(path: Path) -> str:
    # a file name may have 255 bytes; the temporary's adds about 40 (its PID and random part)
    return f".{path.name[:150]}.femupdate-"


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # another user's live process
        return True
    except OSError:
        return True
    return True


def remove_stale_temporaries(path) -> list[Path]:
    """Remove the temporary files that killed writers of ``path`` left behind.

    :func:`atomic_write_bytes` writes ``.NAME.femupdate-PID.XXXX.tmp`` beside ``NAME`` and renames
    it over ``NAME``; a process killed between the two leaves it behind.  Such a file whose
    writer (PID) is no longer running is removed; the temporary file of a live writer — a
    concurrent run writing the same file — is left alone.

    Parameters
    ----------
    path : str or os.PathLike
        The destination file whose temporaries are looked for.

    Returns
    -------
    list of pathlib.Path
        The files removed.
    """
    path = Path(path)
    prefix = _temp_prefix(path)
    removed: list[Path] = []
    try:
        candidates = [c for c in path.parent.iterdir() if c.name.startswith(prefix) and c.name.endswith(".tmp")]
    except OSError:
        return removed
    for c in candidates:
        pid_text = c.name[len(prefix):].split(".", 1)[0]
        if not pid_text.isdigit() or int(pid_text) == os.getpid() or _alive(int(pid_text)):
            continue  # not ours to judge, this process's own, or a live writer's
        try:
            c.unlink()
            removed.append(c)
        except OSError:
            pass
    return removed


def check_output(path, what: str, kind: str = "file") -> Path | None:
    """Check, before any computation, that an output can be written at ``path``.

    Parameters
    ----------
    path : str or os.PathLike
        A file (``kind="file"``; ``"-"`` is standard output and always accepted) or a folder
        (``kind="dir"``, created later if missing).
    what : str
        How the user named it (an option such as ``--json``), for the message.
    kind : ``"file"`` or ``"dir"``

    Returns
    -------
    pathlib.Path or None
        The path (None for ``"-"``).

    Raises
    ------
    InputError
        A file path that is a folder, a folder path that is a file, a parent that is a file, or a
        place the process may not write in — named, with the option.
    """
    from .._errors import InputError

    if kind == "file" and str(path) == "-":
        return None
    p = Path(path)
    if any(len(part.encode()) > 255 for part in p.parts):
        raise InputError(f"{what} {p}: a name in the path is longer than 255 bytes")
    if kind == "file" and p.is_dir():
        raise InputError(f"{what} {p}: is a folder; give a file name")
    if kind == "dir" and p.exists() and not p.is_dir():
        raise InputError(f"{what} {p}: is a file; give a folder")
    if kind == "file" and p.exists() and not os.access(p, os.W_OK):
        raise InputError(f"{what} {p}: the file is not writable")
    here = p if kind == "dir" else p.parent
    while not here.exists():  # the nearest existing folder, where the missing ones would be created
        if here.parent == here:
            break
        here = here.parent
    if here.exists() and not here.is_dir():
        raise InputError(f"{what} {p}: {here} is a file, not a folder")
    if not os.access(here, os.W_OK | os.X_OK):
        raise InputError(f"{what} {p}: cannot write in {here} (permission denied)")
    try:  # a real probe: permissions do not stop root, but a read-only or virtual file system does
        fd, probe = tempfile.mkstemp(prefix=".femupdate-probe-", dir=here)
        os.close(fd)
        os.unlink(probe)
    except OSError as exc:
        raise InputError(f"{what} {p}: cannot write in {here} ({exc.strerror or exc})") from None
    return p


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
        A result object (:mod:`femupdate.serialise`: its :meth:`to_json`), or nested dicts, lists
        and numbers converted by :func:`to_jsonable` (NaN/inf become ``null``); written indented
        by 2 with a final newline.

    Raises
    ------
    ValueError, TypeError
        From :func:`json.dumps`, for objects that :func:`to_jsonable` leaves unconvertible.
    """
    from ..serialise import Serialisable

    if isinstance(obj, Serialisable):
        obj = obj.to_json()
    text = json.dumps(to_jsonable(obj), indent=2, allow_nan=False) + "\n"
    if str(path) == "-":
        sys.stdout.write(text)
        sys.stdout.flush()
    else:
        atomic_write_text(path, text)

