"""Where an output may go, and what a run may not overwrite.

Every file femupdate writes goes through :func:`femupdate.io.results.atomic_write_bytes`, which
asks :func:`resolve_output` what the path is:

* a regular file, or a name not yet taken: written atomically (a temporary file beside it, then
  renamed over it); a symbolic link is followed and its target written, beside the target — the
  link itself is never replaced;
* the process's own standard output or error (``-``, ``/dev/stdout``, ``/dev/stderr``, a
  ``/proc/self/fd/N`` or any other name of the same file): written to that stream;
* a character device (``/dev/null``, a terminal) or a FIFO: written directly, so it stays what it
  is;
* a socket, a block device (a disk), a folder or anything else: refused by name.

During a command-line run (:func:`run_files`), the inputs a run reads (model, test data,
universal files, dofs and matrix files, ...) are noted (:func:`note_input`) and the outputs it
was asked for are declared (:func:`declare_output`); an output that is one of the inputs — the
same file by resolved path and inode, whatever name it was given by — is refused before any
computation, naming both, and so is a file given to two outputs.  The existing files the run
replaced are listed (:meth:`RunFiles.replaced_notes`) for the terminal and the JSON ``notes``.
"""

from __future__ import annotations

import contextlib
import os
import stat
import tempfile
from dataclasses import dataclass, field
from pathlib import Path

from .._errors import InputError

#: what a path is, as an output
STREAM, DEVICE, FILE, NEW = "stream", "device", "file", "new"


@dataclass(frozen=True)
class Target:
    """Where the bytes of an output go.

    Attributes
    ----------
    path : pathlib.Path
        The path as given.
    real : pathlib.Path
        The path with every symbolic link resolved: the file actually written.
    kind : str
        :data:`STREAM` (this process's standard output or error), :data:`DEVICE` (a character
        device or a FIFO), :data:`FILE` (an existing regular file) or :data:`NEW` (nothing there yet).
    fd : int or None
        1 or 2 for a stream.
    """

    path: Path
    real: Path
    kind: str
    fd: int | None = None


def _same_stream(st: os.stat_result) -> int | None:
    for fd in (1, 2):
        try:
            s = os.fstat(fd)
        except OSError:
            continue
        if (s.st_dev, s.st_ino) == (st.st_dev, st.st_ino):
            return fd
    return None


def resolve_output(path, what: str = "output") -> Target:
    """What ``path`` is as an output (see the module's description).

    Parameters
    ----------
    path : str or os.PathLike
        The output as given; ``"-"`` is standard output.
    what : str
        How the user named it (an option), for the messages.

    Returns
    -------
    Target

    Raises
    ------
    InputError
        A socket, a block device, a folder, another kind of special file, or a loop of symbolic
        links — named, with ``what``.
    """
    if str(path) == "-":
        return Target(Path("-"), Path("-"), STREAM, 1)
    p = Path(path)
    try:
        st = os.stat(p)  # follows symbolic links
    except FileNotFoundError:
        st = None
    except OSError as exc:
        if exc.strerror and "symbolic links" in exc.strerror:
            raise InputError(f"{what} {p}: a loop of symbolic links") from None
        st = None  # ENOTDIR, EACCES...: what is wrong is said when the folder is checked
    real = Path(os.path.realpath(p))
    if st is None:
        return Target(p, real, NEW)
    fd = _same_stream(st)
    if fd is not None:
        return Target(p, real, STREAM, fd)
    mode = st.st_mode
    if stat.S_ISREG(mode):
        return Target(p, real, FILE)
    if stat.S_ISCHR(mode) or stat.S_ISFIFO(mode):
        return Target(p, real, DEVICE)
    kind = ("a folder; give a file name" if stat.S_ISDIR(mode) else
            "a socket, not a file" if stat.S_ISSOCK(mode) else
            "a block device (a disk or partition), not a file" if stat.S_ISBLK(mode) else "not a regular file")
    shown = f"{p}" if real == p.absolute() else f"{p} (-> {real})"
    raise InputError(f"{what} {shown}: is {kind}")


def _identity(path) -> tuple[int, int] | None:
    """(device, inode) of an existing regular file (symbolic links followed), else None."""
    try:
        st = os.stat(path)
    except (OSError, ValueError):
        return None
    return (st.st_dev, st.st_ino) if stat.S_ISREG(st.st_mode) else None


def _check_folder(p: Path, here: Path, what: str) -> None:
    """``here`` (or its nearest existing ancestor) is a folder this process can create files in."""
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
        A file path that is a folder, a socket or a block device; a folder path that is a file;
        a parent that is a file; a file, device or place the process may not write in — named,
        with the option.
    """
    if kind == "file" and str(path) == "-":
        return None
    p = Path(path)
    if kind == "file" and str(os.fspath(path)).endswith(("/", os.sep)):  # Path() would drop the slash
        raise InputError(f"{what} {os.fspath(path)}: ends with '/', so names a folder; give a file name")
    if any(len(part.encode()) > 255 for part in p.parts):
        raise InputError(f"{what} {p}: a name in the path is longer than 255 bytes")
    if kind == "dir":
        if p.exists() and not p.is_dir():
            raise InputError(f"{what} {p}: is a file; give a folder")
        _check_folder(p, p, what)
        return p
    t = resolve_output(p, what)
    if t.kind == STREAM:
        return p
    if t.kind in (DEVICE, FILE) and not os.access(t.real, os.W_OK):
        raise InputError(f"{what} {p}: the {'device' if t.kind == DEVICE else 'file'} is not writable")
    if t.kind != DEVICE:  # a file is replaced by a new one written beside it (beside the link's target)
        _check_folder(p, t.real.parent, what)
    return p


# ---------------------------------------------------------------------------------- one run's files
@dataclass
class RunFiles:
    """The inputs a run read and the outputs it was asked for (see the module's description)."""

    inputs: dict = field(default_factory=dict)  #: (device, inode) -> (what, path)
    outputs: list = field(default_factory=list)  #: (what, path, Target, existed)
    replaced: list = field(default_factory=list)  #: (what, path) of the existing files replaced
    created: set = field(default_factory=set)  #: the files this run created (resolved)
    quiet: set = field(default_factory=set)  #: outputs rewritten by design (checkpoints): no note

    def input(self, path, what: str) -> None:
        """Note an input; refuse it if it is one of the declared outputs."""
        key = _identity(path)
        if key is None:
            return
        self.inputs.setdefault(key, (what, Path(path)))
        for out_what, out_path, t, _ in self.outputs:
            if t.kind == FILE and _identity(t.real) == key:
                raise InputError(_clash(out_what, out_path, what, Path(path)))

    def output(self, path, what: str, kind: str = "file", note: bool = True) -> None:
        """Declare an output (checked with :func:`check_output` first); refuse it if it is an input
        of the run or a file already given to another output.  ``note=False``: a file the run
        rewrites by design (a checkpoint it resumes from), not noted as replaced."""
        if kind != "file":
            return
        t = resolve_output(path, what)
        key = _identity(t.real) if t.kind == FILE else None
        if key is not None and key in self.inputs:
            in_what, in_path = self.inputs[key]
            raise InputError(_clash(what, Path(path), in_what, in_path))
        for other_what, other_path, o, _ in self.outputs:
            if t.kind in (FILE, NEW) and o.kind in (FILE, NEW) and o.real == t.real and other_what != what:
                raise InputError(f"{what} {path}: the same file as {other_what} {other_path}; give each output its "
                                 "own file")
        self.outputs.append((what, Path(path), t, t.kind == FILE))
        if not note:
            self.quiet.add(t.real)

    def check_write(self, target: Target, path) -> None:
        """At the moment of writing: refuse a file that is an input of the run."""
        key = _identity(target.real) if target.kind == FILE else None
        if key is not None and key in self.inputs:
            in_what, in_path = self.inputs[key]
            raise InputError(_clash(self.option_of(target) or "output", Path(path), in_what, in_path))

    def option_of(self, target: Target) -> str | None:
        """The option that declared ``target``'s file, if any."""
        return next((w for w, _, t, _ in self.outputs if t.real == target.real), None)

    def note_written(self, target: Target, path) -> None:
        """Note a file written: an existing file that this run did not create is one replaced."""
        if target.kind == NEW:
            self.created.add(target.real)
        elif target.kind == FILE and target.real not in self.created and target.real not in self.quiet:
            entry = (self.option_of(target), Path(path))
            if entry not in self.replaced:
                self.replaced.append(entry)

    def replaced_notes(self) -> list[str]:
        """One note per existing file replaced, e.g. ``"--json out.json: replaced the existing file"``."""
        return [f"{what + ' ' if what else ''}{p}: replaced the existing file" for what, p in self.replaced]

    def declared_existing_notes(self) -> list[str]:
        """One note per declared output that existed when the run started (it is replaced)."""
        return [f"{what} {p}: replaced the existing file" for what, p, t, existed in self.outputs
                if existed and t.real not in self.quiet]


def _clash(out_what: str, out_path: Path, in_what: str, in_path: Path) -> str:
    return (f"{out_what} {out_path}: is {in_what} ({in_path}), which this run reads: writing there would destroy it; "
            "give the output another name")


_ACTIVE: RunFiles | None = None


@contextlib.contextmanager
def run_files():
    """The :class:`RunFiles` of one command-line run, active (for :func:`note_input`,
    :func:`declare_output` and the writers) until the ``with`` block ends."""
    global _ACTIVE
    previous, _ACTIVE = _ACTIVE, RunFiles()
    try:
        yield _ACTIVE
    finally:
        _ACTIVE = previous


def active() -> RunFiles | None:
    """The active run's files, or None outside a command-line run."""
    return _ACTIVE


def note_input(path, what: str) -> None:
    """Note that the run reads ``path`` (described as ``what``: ``"the model file"``, ``"DATA"``,
    ...); refused when it is one of the run's declared outputs.  Nothing happens outside a run."""
    if _ACTIVE is not None:
        _ACTIVE.input(path, what)


def declare_output(path, what: str, kind: str = "file", note: bool = True) -> None:
    """Declare an output of the run (nothing happens outside a run); see :meth:`RunFiles.output`."""
    if _ACTIVE is not None:
        _ACTIVE.output(path, what, kind, note)


__all__ = ["Target", "resolve_output", "check_output", "RunFiles", "run_files", "active", "note_input",
           "declare_output", "STREAM", "DEVICE", "FILE", "NEW"]
