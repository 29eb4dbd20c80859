"""What a command writes, as one option group (:func:`outputs_group`): the JSON result, the HTML
report, figures, the updated model file, CSV tables and universal files, and the model values
``--set`` — and how a long run shows its progress (:func:`progress`)."""

from __future__ import annotations

import contextlib
import dataclasses
import sys
import time
from collections.abc import Callable, Iterator
from pathlib import Path

import click

from ._common import (OUTPUT_DIR, OUTPUT_FILE, Ctx, csv_option, emit, json_option, report_option, set_option,
                      write_back_option, write_model_option)
from ._groups import option_group

#: a run shows progress once it has lasted this long (seconds); shorter runs stay quiet
PROGRESS_AFTER = 5.0
#: when the output is not a terminal, a progress line at most this often (seconds)
PROGRESS_EVERY = 10.0


@dataclasses.dataclass(frozen=True)
class Outputs:
    """The files a command was asked to write, and ``--set``."""

    json_path: object = None
    report_path: Path | None = None
    plot_dir: Path | None = None
    write_model_path: Path | None = None
    csv_dir: Path | None = None
    uff_path: Path | None = None
    set_text: str | None = None
    write_back_dir: Path | None = None

    def emit(self, ctx: Ctx, payload: dict) -> None:
        """Write the JSON result where ``--json`` says."""
        emit(ctx, payload)

    def progress(self, ctx: Ctx, what: str, total: int):
        """:func:`progress` for this command's console (quiet with ``--json -``)."""
        return progress(what, total, console=ctx.console, quiet=self.json_path == "-")


def outputs_group(plot: bool | str = False, model_out: bool = False, uff: bool | str = False, report: bool = True) -> Callable:
    """``--json``, ``--set`` and, as asked, ``--report``, ``--plot`` (``plot`` a string: its help),
    ``--write-model``, ``--write-back``, ``--csv`` and ``--uff`` (``uff`` a string: its help) -> ``outputs``: :class:`Outputs`."""
    options: list = []
    if plot:
        options.append(click.option("--plot", "plot_dir", type=OUTPUT_DIR, default=None,
                                    help=plot if isinstance(plot, str) else
                                    "Write convergence and MAC figures to this folder."))
    if model_out:
        options += [write_model_option, write_back_option, csv_option]
    if uff:
        options.append(click.option("--uff", "uff_path", type=OUTPUT_FILE, default=None,
                                    help=uff if isinstance(uff, str) else
                                    "Write the updated model's modes (with its nodes) as a universal file."))
    if report:
        options.append(report_option)
    options += [set_option, json_option]
    return option_group("Model values and outputs", "outputs", lambda **kw: Outputs(**kw), *options)


@contextlib.contextmanager
def progress(what: str, total: int, *, console=None, quiet: bool = False, stream=None,
             after: float = PROGRESS_AFTER, every: float = PROGRESS_EVERY,
             clock: Callable[[], float] = time.monotonic) -> Iterator[Callable[[int, int], None]]:
    """Progress of a long run: a bar on a terminal, rate-limited lines otherwise.

    Yields a callback ``tick(done, total)``.  Nothing is shown until the run has lasted ``after``
    seconds (short runs stay quiet).  On a terminal (``console.is_terminal``) a transient bar with
    the time left; otherwise one line ``femupdate: WHAT DONE/TOTAL (P %), T s, about R s left`` on
    ``stream`` (default standard error) at most every ``every`` seconds, and one when the run ends.
    ``quiet`` (``--json -``): nothing.
    """
    if quiet:
        def silent(done: int, n: int = total) -> None:
            return None

        yield silent
        return
    stream = stream if stream is not None else sys.stderr
    if console is not None and console.is_terminal:
        from rich.progress import BarColumn, Progress, TextColumn, TimeRemainingColumn

        with Progress(TextColumn("{task.description}"), BarColumn(), TextColumn("{task.completed}/{task.total}"),
                      TimeRemainingColumn(), console=console, transient=True) as bar:
            task = bar.add_task(what, total=total)

            def advance(done: int, n: int = total) -> None:
                bar.update(task, completed=done, total=n)

            yield advance
        return
    state = _State(clock(), total)

    def tick(done: int, n: int = total) -> None:
        state.done, state.total = done, n
        now = clock()
        elapsed = now - state.start
        if elapsed < after or (state.last is not None and now - state.last < every and done < n):
            return
        state.last = now
        stream.write(_line(what, done, n, elapsed) + "\n")
        stream.flush()

    yield tick
    if state.last is not None and state.done < state.total:  # said something, not the end
        stream.write(_line(what, state.done, state.total, clock() - state.start) + "\n")
        stream.flush()


@dataclasses.dataclass
class _State:
    start: float
    total: int
    done: int = 0
    last: float | None = None


@contextlib.contextmanager
def phased_progress(labels: dict[str, str], *, console=None, quiet: bool = False, stream=None,
                    after: float = PROGRESS_AFTER, every: float = PROGRESS_EVERY,
                    clock: Callable[[], float] = time.monotonic) -> Iterator[Callable[[str, int, int], None]]:
    """:func:`progress` of a run in phases: yields ``tick(phase, done, total)``, each phase shown
    under its label (``labels`` {phase: label}) as it starts."""
    with contextlib.ExitStack() as stack:
        ticks: dict[str, Callable] = {}
        t0 = clock()

        def tick(phase: str, done: int, total: int) -> None:
            if phase not in ticks:
                # a later phase counts its own time, but the whole run's for being shown at all
                ticks[phase] = stack.enter_context(progress(
                    labels.get(phase, phase), total, console=console, quiet=quiet, stream=stream,
                    after=max(0.0, after - (clock() - t0)), every=every, clock=clock))
            ticks[phase](done, total)

        yield tick


def _line(what: str, done: int, total: int, elapsed: float) -> str:
    share = done / total if total else 1.0
    left = f", about {elapsed / share - elapsed:.0f} s left" if 0 < share < 1 else ""
    return f"femupdate: {what} {done}/{total} ({share:.0%}), {elapsed:.0f} s{left}"


__all__ = ["Outputs", "outputs_group", "progress", "phased_progress", "PROGRESS_AFTER", "PROGRESS_EVERY"]
