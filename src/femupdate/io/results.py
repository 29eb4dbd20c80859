"""Machine-readable results: JSON written atomically, NaN/inf as null, numpy converted."""

from __future__ import annotations

import json
import math
import os
import sys
import tempfile
from pathlib import Path

import numpy as np

from .outputs import check_output  # noqa: F401  (its home before femupdate.io.outputs)


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
    """Write ``data`` to ``path`` without ever destroying what the path is
    (:func:`femupdate.io.outputs.resolve_output`).

    A regular file (or a new name) is written atomically: a temporary file in the same folder,
    flushed to disk, then renamed over the file (readers see the old file or the new one, never a
    part); the missing parent folders are created; the file keeps the permissions (and, where this
    process may set them, the owner) of the one it replaces; a new file gets 0o666 less the umask.
    A symbolic link is followed: its target is written that way, beside the target, and the link
    stays.  ``"-"`` and any name of this process's standard output or error are written to that
    stream; a character device or a FIFO is written directly.  During a command-line run, a file
    that is one of the run's inputs is refused (:class:`femupdate.io.outputs.RunFiles`).

    Parameters
    ----------
    path : str or os.PathLike
        Destination.
    data : bytes
        Contents.

    Raises
    ------
    InputError
        A socket, a block device or a folder; an input of the running command.
    OSError
        The file cannot be written (named as given).
    """
    from . import outputs

    target = outputs.resolve_output(path)
    run = outputs.active()
    if run is not None:
        run.check_write(target, path)
    if target.kind == outputs.STREAM:
        _write_stream(sys.stdout if target.fd == 1 else sys.stderr, data)
        return
    if target.kind == outputs.DEVICE:
        try:
            with open(target.real, "wb") as fh:
                fh.write(data)
        except OSError as exc:
            raise OSError(exc.errno, exc.strerror, str(path)) from None
        return
    _replace_atomically(target.real, data, str(path))
    if run is not None:
        run.note_written(target, path)


def _write_stream(stream, data: bytes) -> None:
    stream.flush()
    buffer = getattr(stream, "buffer", None)
    if buffer is not None:
        buffer.write(data)
        buffer.flush()
    else:  # a text stream without bytes underneath (io.StringIO)
        stream.write(data.decode("utf-8", "replace"))
        stream.flush()


def _replace_atomically(path: Path, data: bytes, shown: str) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    remove_stale_temporaries(path)
    try:
        fd, tmp = tempfile.mkstemp(prefix=f"{_temp_prefix(path)}{os.getpid()}.", suffix=".tmp", dir=path.parent)
    except OSError as exc:  # name the file the user asked for, not the temporary one
        raise OSError(exc.errno, exc.strerror, shown) from None
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
            fh.flush()
            os.fsync(fh.fileno())
        os.chmod(tmp, _mode_for(path))
        _keep_owner(tmp, path)
        os.replace(tmp, path)
    except BaseException as exc:
        try:
            os.unlink(tmp)
        except FileNotFoundError:
            pass
        if isinstance(exc, OSError):
            raise OSError(exc.errno, exc.strerror, shown) from None
        raise


def _keep_owner(tmp: str, path: Path) -> None:
    """The replacement keeps the owner and group of the file it replaces (root writing another
    user's file would otherwise hand it to root); nothing happens where that is not allowed."""
    try:
        st = path.stat()
    except OSError:
        return
    if (st.st_uid, st.st_gid) != (os.geteuid(), os.getegid()):
        try:
            os.chown(tmp, st.st_uid, st.st_gid)
        except OSError:
            pass


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
    TypeError
        ``path`` not a file name, or ``obj`` neither a result object nor a JSON object or list
        (named); and from :func:`json.dumps`, for values :func:`to_jsonable` leaves unconvertible.
    """
    from collections.abc import Mapping

    from .._checks import path_arg, shown
    from ..serialise import Serialisable

    if str(path) != "-":
        path_arg(path, "path", "write_json")
    if isinstance(obj, Serialisable):
        obj = obj.to_json()
    elif not isinstance(obj, (Mapping, list, tuple)):
        raise TypeError(f"write_json: obj must be a result object or a JSON object (a dict) or list, got {shown(obj)}")
    text = json.dumps(to_jsonable(obj), indent=2, allow_nan=False) + "\n"
    if str(path) == "-":
        sys.stdout.write(text)
        sys.stdout.flush()
    else:
        atomic_write_text(path, text)

