"""Runs of an external code: a command template or a Python callable, cached by parameter values.

A *runner* turns parameter values into one :class:`Run` (dof labels, K, M):

* :class:`Command` fills a shell command template (``{name}`` for each parameter's value, written
  with 17 significant digits; ``{python}`` the interpreter running femupdate; ``{base}`` the
  folder of the model file; ``{dir}`` the run's own folder, where the command runs) and reads the
  matrix files the command wrote there;
* :class:`Function` calls ``fn(values)`` returning ``(K, M)`` or ``(K, M, dofs)``.

:func:`run_all` runs a batch: cached runs are read back (the cache key is a SHA-256 hash of the
runner's identity -- the template, the file names, the content of the ``inputs`` files, or the
callable's module, name and source -- and of the values), the others run here, on local worker
processes (``jobs``) or on a Dask cluster (``scheduler``).  A run that fails is an
:class:`~femupdate.InputError` that names its values, its command and the end of its output.
"""

from __future__ import annotations

import contextlib
import hashlib
import inspect
import json
import os
import shlex
import shutil
import string
import subprocess
import sys
import tempfile
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import scipy.sparse as sp

from .._errors import InputError, NumericalError

#: what a run's output is cut to in a message (its last lines)
OUTPUT_TAIL = 2000
FORMATS = ("matrices", "abaqus", "op4", "dmig")


def shown_values(values: Mapping[str, float]) -> str:
    """``E=2.1e+11, h=0.3`` (as messages name a run)."""
    return ", ".join(f"{k}={v:.10g}" for k, v in values.items())


@dataclass(frozen=True, eq=False)
class Run:
    """One run of the code: its dof labels and matrices (CSR)."""

    dofs: tuple[str, ...]
    K: sp.csr_array
    M: sp.csr_array


def _check_run(values: Mapping[str, float], dofs, K, M, source: str, files: Mapping[str, str] | None = None) -> Run:
    """The run's matrices as CSR, square, of one size with the labels, finite (else refused by name)."""
    where = f"the black-box run at {shown_values(values)} ({source})"
    out = []
    for what, A in (("K", K), ("M", M)):
        what = f"{what} ({files[what]})" if files else what
        try:
            A = sp.csr_array(A if sp.issparse(A) else np.asarray(A, dtype=float), dtype=float)
        except (TypeError, ValueError):
            raise InputError(f"{where}: its {what} is not a numeric matrix") from None
        if A.ndim != 2 or A.shape[0] != A.shape[1]:
            raise InputError(f"{where}: its {what} is not square (shape {A.shape})")
        if not np.all(np.isfinite(A.data)):
            raise InputError(f"{where}: its {what} holds NaN or infinite entries")
        out.append(A)
    K, M = out
    if K.shape != M.shape:
        raise InputError(f"{where}: K is {K.shape[0]} × {K.shape[0]} but M is {M.shape[0]} × {M.shape[0]}")
    if dofs is None:
        raise InputError(f"{where}: no dof labels (return (K, M, dofs) or give dofs)")
    dofs = tuple(str(d) for d in dofs)
    if len(dofs) != K.shape[0]:
        raise InputError(f"{where}: {len(dofs)} dof labels for matrices of size {K.shape[0]}")
    return Run(dofs, K, M)


@dataclass(frozen=True)
class Command:
    """A shell command that writes K and M for given parameter values (module docstring).

    Parameters
    ----------
    template : str
        The command, with ``{name}`` placeholders (``{{`` for a brace).
    K, M : str
        The files the command writes in its folder (the matrix names of an OP4 or DMIG file when
        ``format`` is ``"op4"`` or ``"dmig"``).
    dofs : str, optional
        The dof-label file (one ``node:dir`` a line) for ``format = "matrices"``; the OP2 file for
        ``"op4"``.
    format : {"matrices", "abaqus", "op4", "dmig"}
        ``matrices``: Matrix Market, ``.npz``, ``.npy`` or ``.mat`` files and a dof file;
        ``abaqus``: ``*MATRIX GENERATE`` files (their own labels); ``op4``: an OP4 file (``file``)
        with the dofs of ``set`` in the OP2 ``dofs``; ``dmig``: a punch file ``file``.
    file : str, optional
        The OP4 or DMIG file, for those formats.
    set : str
        The OP2 dof set of an OP4 export (default ``"a"``).
    base : str
        The folder ``{base}`` stands for (the model file's).
    inputs : tuple of str
        Files (relative to ``base``) whose content is part of the cache key (the script the
        command runs): edit one and the old runs are not reused.
    timeout : float, optional
        Seconds a run may take.
    """

    template: str
    K: str = "K.mtx"
    M: str = "M.mtx"
    dofs: str | None = "dofs.txt"
    format: str = "matrices"
    file: str | None = None
    set: str = "a"
    base: str = "."
    inputs: tuple[str, ...] = ()
    timeout: float | None = None

    def __post_init__(self):
        if not isinstance(self.template, str) or not self.template.strip():
            raise InputError(f"black-box command: give a command template (a string), got {self.template!r}")
        if self.format not in FORMATS:
            raise InputError(f"black-box command: format {self.format!r} is not one of {', '.join(FORMATS)}")
        self.placeholders()

    def placeholders(self) -> list[str]:
        """The names in the template's braces."""
        try:
            return [f for _, f, _, _ in string.Formatter().parse(self.template) if f is not None]
        except ValueError as exc:
            raise InputError(f"black-box command {self.template!r}: {exc} (write {{{{ for a literal brace)") from None

    def check_placeholders(self, names: Sequence[str]) -> None:
        """Refuse placeholders that name neither a parameter nor ``python``, ``base`` or ``dir``."""
        known = {*names, "python", "base", "dir"}
        bad = [f for f in self.placeholders() if f not in known]
        if bad:
            raise InputError(f"black-box command {self.template!r}: placeholder(s) {', '.join('{' + b + '}' for b in bad)} "
                             f"name no parameter (parameters: {', '.join(names)}; also {{python}}, {{base}}, {{dir}})")

    def identity(self) -> str:
        digests = []
        for name in self.inputs:
            p = Path(self.base) / name
            try:
                digests.append(hashlib.sha256(p.read_bytes()).hexdigest())
            except OSError as exc:
                raise InputError(f"black-box inputs: cannot read {p} ({exc.strerror or exc})") from None
        return json.dumps(["command", self.template, self.K, self.M, self.dofs, self.format, self.file, self.set,
                           os.path.abspath(self.base), digests])

    def command(self, values: Mapping[str, float], folder: str) -> str:
        filled = {k: repr(float(v)) for k, v in values.items()}
        filled.update(python=shlex.quote(sys.executable), base=shlex.quote(os.path.abspath(self.base)),
                      dir=shlex.quote(folder))
        return self.template.format(**filled)

    def __call__(self, values: Mapping[str, float]) -> Run:
        folder = tempfile.mkdtemp(prefix="femupdate-run-")
        try:
            cmd = self.command(values, folder)
            output, code = _shell(cmd, folder, self.timeout, values)
            if code != 0:
                raise InputError(f"the black-box run at {shown_values(values)}: command `{cmd}` failed with exit "
                                 f"status {code}{_tail(output)}")
            return self._read(Path(folder), values, cmd, output)
        finally:
            shutil.rmtree(folder, ignore_errors=True)

    def _read(self, folder: Path, values, cmd: str, output: str) -> Run:
        wanted = [self.K, self.M] if self.format in ("matrices", "abaqus") else [self.file or ""]
        if self.format == "matrices" and self.dofs:
            wanted.append(self.dofs)
        if self.format == "op4":
            wanted.append(self.dofs or "")
        missing = [w for w in wanted if not (folder / w).is_file()]
        if missing:
            wrote = sorted(p.name for p in folder.iterdir())
            raise InputError(f"the black-box run at {shown_values(values)}: command `{cmd}` ended (status 0) but wrote "
                             f"no {', '.join(missing)} in its folder (it wrote: {', '.join(wrote) or 'nothing'})"
                             f"{_tail(output)}")
        source = f"command `{cmd}`"
        where = f"the black-box run at {shown_values(values)}"
        if self.format == "matrices":
            from ..io.model_file import _read_dofs_file, load_matrix

            K = load_matrix(self.K, folder, f"{where}: K")
            M = load_matrix(self.M, folder, f"{where}: M")
            dofs = _read_dofs_file(folder / self.dofs, where) if self.dofs else None
        elif self.format == "abaqus":
            from ..io.abaqus import assembled_matrices

            dofs, K, M, _ = assembled_matrices(folder / self.K, folder / self.M, where)
        elif self.format == "op4":
            from ..io.nastran import read_op4, set_labels

            dofs = set_labels(folder / str(self.dofs), self.set, where)
            K, M = (read_op4(folder / str(self.file), n, where) for n in (self.K, self.M))
        else:
            from ..io.nastran import read_dmig

            dofs, K = read_dmig(folder / str(self.file), self.K, where)
            _, M = read_dmig(folder / str(self.file), self.M, where)
        named = {"K": self.K, "M": self.M} if self.format in ("matrices", "abaqus") else \
            {k: f"{getattr(self, k)} of {self.file}" for k in ("K", "M")}
        return _check_run(values, dofs, K, M, source, named)


def _shell(cmd: str, folder: str, timeout: float | None, values) -> tuple[str, int]:
    """Run ``cmd`` in ``folder`` in a process group of its own, which is ended with it on a timeout
    or an interrupt (a solver the script started does not outlive the run); its output and status."""
    import signal

    proc = subprocess.Popen(cmd, shell=True, cwd=folder, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                            errors="replace", start_new_session=True)
    try:
        out, _ = proc.communicate(timeout=timeout)
    except BaseException as exc:
        with contextlib.suppress(OSError):
            os.killpg(proc.pid, signal.SIGKILL)
        out, _ = proc.communicate()
        if isinstance(exc, subprocess.TimeoutExpired):
            raise InputError(f"the black-box run at {shown_values(values)}: command `{cmd}` took more than "
                             f"{timeout:g} s{_tail(out)}") from None
        raise
    return out, proc.returncode


def _tail(output: str) -> str:
    output = output.strip()
    if not output:
        return "; it printed nothing"
    cut = output[-OUTPUT_TAIL:]
    return f"; its output{' (end)' if len(cut) < len(output) else ''}:\n{cut}"


@dataclass(frozen=True)
class Function:
    """A Python callable ``fn(values) -> (K, M)`` or ``(K, M, dofs)``, values a dict {name: value}.

    Parameters
    ----------
    fn : callable
        Picklable (a module-level function) for ``jobs`` > 1 or a Dask scheduler.
    dofs : sequence of str, optional
        The dof labels, when ``fn`` returns only (K, M).
    """

    fn: Callable
    dofs: tuple[str, ...] | None = None

    def __post_init__(self):
        if not callable(self.fn):
            raise InputError(f"black box: expected a callable returning (K, M), got {self.fn!r}")
        if self.dofs is not None:
            object.__setattr__(self, "dofs", tuple(self.dofs))

    def check_placeholders(self, names: Sequence[str]) -> None:
        """(Nothing to check for a callable.)"""

    def identity(self) -> str:
        fn = self.fn
        try:
            source = inspect.getsource(fn)
        except (OSError, TypeError):
            source = ""
        return json.dumps(["function", getattr(fn, "__module__", ""), getattr(fn, "__qualname__", repr(fn)), source,
                           list(self.dofs or ())])

    def __call__(self, values: Mapping[str, float]) -> Run:
        name = getattr(self.fn, "__qualname__", repr(self.fn))
        try:
            out = self.fn(dict(values))
        except InputError:
            raise
        except Exception as exc:  # the user's code: any error, named with the call
            raise InputError(f"the black-box run at {shown_values(values)}: {name}() raised "
                             f"{type(exc).__name__}: {exc}") from None
        if not isinstance(out, (tuple, list)) or len(out) not in (2, 3):
            raise InputError(f"the black-box run at {shown_values(values)}: {name}() must return (K, M) or "
                             f"(K, M, dofs), got {type(out).__name__}")
        dofs = out[2] if len(out) == 3 else self.dofs
        return _check_run(values, dofs, out[0], out[1], f"{name}()")


@dataclass
class Cache:
    """Finished runs by key: in memory, and in ``folder`` (one ``.npz`` a run) when given."""

    folder: Path | None = None
    memory: dict = field(default_factory=dict)
    hits: int = 0
    runs: int = 0

    def key(self, identity: str, values: Mapping[str, float]) -> str:
        text = json.dumps([identity, [[k, repr(float(v))] for k, v in values.items()]])
        return hashlib.sha256(text.encode()).hexdigest()

    def get(self, key: str) -> Run | None:
        if key in self.memory:
            return self.memory[key]
        if self.folder is None:
            return None
        p = self.folder / f"{key}.npz"
        if not p.is_file():
            return None
        try:
            with np.load(p, allow_pickle=False) as z:
                n = int(z["n"])
                K = sp.csr_array((z["K_data"], z["K_indices"], z["K_indptr"]), shape=(n, n))
                M = sp.csr_array((z["M_data"], z["M_indices"], z["M_indptr"]), shape=(n, n))
                run = Run(tuple(str(d) for d in z["dofs"]), K, M)
        except Exception:  # noqa: BLE001 - a damaged entry is run again
            return None
        self.memory[key] = run
        return run

    def put(self, key: str, run: Run) -> None:
        self.memory[key] = run
        if self.folder is None:
            return
        tmp = self.folder / f".{key}.{os.getpid()}.npz"
        try:
            self.folder.mkdir(parents=True, exist_ok=True)
            np.savez(tmp, n=run.K.shape[0], dofs=np.array(run.dofs), K_data=run.K.data, K_indices=run.K.indices,
                     K_indptr=run.K.indptr, M_data=run.M.data, M_indices=run.M.indices, M_indptr=run.M.indptr)
            os.replace(tmp, self.folder / f"{key}.npz")
        except OSError as exc:
            raise InputError(f"black box: cannot write the cache folder {self.folder} ({exc.strerror or exc}); "
                             "name another with cache = \"FOLDER\" in [blackbox]") from None


def _execute(runner, values: dict) -> Run:
    return runner(values)


def run_all(runner, batch: Sequence[Mapping[str, float]], cache: Cache, jobs: int = 1, scheduler: str | None = None,
            timeout: float = 30.0) -> list[Run]:
    """Runs of ``runner`` at every point of ``batch`` (in order), from ``cache`` where it has them.

    Parameters
    ----------
    runner : Command or Function
    batch : sequence of mapping of str to float
    cache : Cache
    jobs : int
        Local worker processes for the runs not cached (1: here, one after the other).
    scheduler : str, optional
        A Dask scheduler's address: the runs go there instead.
    timeout : float
        Seconds to wait for the scheduler (and its workers).

    Returns
    -------
    list of Run
    """
    identity = runner.identity()
    keys = [cache.key(identity, v) for v in batch]
    todo: dict[str, dict] = {}
    for k, v in zip(keys, batch):
        if cache.get(k) is None and k not in todo:
            todo[k] = dict(v)
    cache.hits += len(set(keys)) - len(todo)
    if todo and scheduler:
        from ..dask_cluster import Task, collect, connect

        client = connect(scheduler, timeout)
        try:
            futures = {client.submit(Task(_execute, parallel=False), runner, v, pure=False): k for k, v in todo.items()}
            def keep(key, run) -> None:
                cache.put(str(key), run)

            collect(client, futures, scheduler, timeout, keep)
        finally:
            client.close()
    elif len(todo) > 1 and jobs > 1:
        import pickle

        from .._workers import process_pool

        try:
            pickle.dumps(runner)
        except Exception as exc:  # noqa: BLE001 - lambdas, closures, local functions
            raise InputError(f"black box: runs on {jobs} processes need a picklable runner (a module-level "
                             f"function), not {getattr(runner, 'fn', runner)!r} ({exc})") from None
        from concurrent.futures.process import BrokenProcessPool

        try:
            with process_pool(min(jobs, len(todo))) as pool:
                futures = {pool.submit(_execute, runner, v): k for k, v in todo.items()}
                for fut, k in futures.items():
                    cache.put(k, fut.result())
        except BrokenProcessPool:
            raise NumericalError(f"black box: a worker process running the code died ({len(todo)} run(s) on {jobs} "
                                 "processes: out of memory, or the code crashed); the runs finished so far are "
                                 "cached: run again with fewer jobs") from None
    else:
        for k, v in todo.items():
            cache.put(k, runner(v))
    cache.runs += len(todo)
    out = [cache.get(k) for k in keys]
    return [r for r in out if r is not None]


__all__ = ["Run", "Command", "Function", "Cache", "run_all", "shown_values", "FORMATS"]
