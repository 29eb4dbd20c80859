"""The paths of the command line: the outputs a command writes (:class:`OutputPath`, checked
and declared when the command line is read) and the files it reads (:class:`InputPath`, noted as
inputs of the run), see :mod:`femupdate.io.outputs`; and the notes of the existing files a run
replaces (:func:`with_output_notes`)."""

from __future__ import annotations

from pathlib import Path

import click

from .._errors import FemupdateError


class OutputPath(click.ParamType):
    """A path the command will write — a file (``"-"``: standard output where ``dash``) or a
    folder — checked when the command line is read, before any computation
    (:func:`femupdate.io.outputs.check_output`): a folder given for a file, a file for a folder, a
    socket or a block device, a place that cannot be written, an input of the run or a file given
    to another output are refused at once, naming the option (:mod:`femupdate.io.outputs`)."""

    name = "path"

    def __init__(self, kind: str = "file", dash: bool = False, suffixes: tuple[str, ...] = (),
                 why: str = "the figure's format", note: bool = True):
        self.kind = kind
        self.dash = dash
        self.suffixes = suffixes
        self.why = why
        self.note = note  # False: rewritten by design (a checkpoint), not noted as replaced

    def convert(self, value, param, ctx):
        from ..io.outputs import check_output, declare_output

        if value is None or isinstance(value, Path):
            text = value
        else:
            text = str(value)
        if text is None:
            return None
        if str(text) == "-":
            if self.dash:
                return "-"
            self.fail("'-' (standard output) is not accepted here; give a path", param, ctx)
        if param is None:
            what = "output"
        else:  # an option as typed (--json), an argument by its metavar (OUT)
            what = param.opts[0] if isinstance(param, click.Option) else (param.metavar or param.name or "output").upper()
        if self.suffixes and Path(text).suffix.lower() not in self.suffixes:
            ends = f"one of {', '.join(self.suffixes)}" if len(self.suffixes) > 1 else self.suffixes[0]
            self.fail(f"{text}: the file name must end in {ends} ({self.why})", param, ctx)
        try:
            check_output(text, what, self.kind)
        except FemupdateError as exc:
            self.fail(str(exc).removeprefix(f"{what} "), param, ctx)
        declare_output(text, what, self.kind, self.note)  # an input of the run: InputError, naming both
        return Path(text)


class InputPath(click.Path):
    """A file the command reads (click's ``Path``, folders refused), noted as an input of the run
    (:func:`femupdate.io.outputs.note_input`) so that no output can be written over it."""

    def __init__(self):
        super().__init__(dir_okay=False, path_type=Path)

    def convert(self, value, param, ctx):
        from ..io.outputs import note_input

        path = super().convert(value, param, ctx)
        if param is None:
            what = "an input"
        elif isinstance(param, click.Option):
            what = f"the input of {param.opts[0]}"
        else:
            what = f"the input {(param.metavar or param.name or '').upper()}".rstrip()
        note_input(path, what)
        return path


#: a file the command reads (:class:`InputPath`)
INPUT_FILE = InputPath()

OUTPUT_FILE = OutputPath("file")
OUTPUT_DIR = OutputPath("dir")
#: ``--checkpoint``: written after each piece of work and read back to resume
CHECKPOINT_FILE = OutputPath("file", note=False)
#: a figure file: its suffix chooses the format (those matplotlib writes without extra packages)
OUTPUT_FIGURE = OutputPath("file", suffixes=(".png", ".pdf", ".svg", ".eps", ".ps", ".jpg", ".jpeg", ".tif", ".tiff",
                                             ".webp"))

REPORT_FILE = OutputPath("file", suffixes=(".html", ".htm"), why="an HTML report")


def with_output_notes(payload: dict) -> dict:
    """``payload`` with one note per output of the run that replaces an existing file, when it
    has ``notes`` (:meth:`femupdate.io.outputs.RunFiles.declared_existing_notes`)."""
    from ..io.outputs import active

    run = active()
    notes = payload.get("notes") if isinstance(payload, dict) else None
    if run is None or not isinstance(notes, list):
        return payload
    extra = [n for n in run.declared_existing_notes() if n not in notes]
    return {**payload, "notes": notes + extra} if extra else payload
