"""The code blocks of the Markdown documentation, as a test runs them (tests/test_docs_examples.py).

A page's ``python``, ``bash``, ``console``, ``sh`` and ``shell`` blocks are found in order.  A
block that cannot run here is marked on the line before its fence (or the line after its closing
fence)::

    <!-- not run: the reason, which the test prints -->

A block of any language that is the text of a file the next examples use (a model file, a
script run as ``python NAME.py``) is marked the same way, and written, not run::

    <!-- file: beam.toml -->

HTML comments: invisible on the rendered page (GitHub and the documentation site alike).
"""

from __future__ import annotations

import re
import shlex
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
RUN_LANGUAGES = {"python", "bash", "console", "sh", "shell"}
_FENCE = re.compile(r"^(?P<indent> *)(?P<fence>`{3,}|~{3,})(?P<lang>[^\s`{}]*)\s*$")
_NOT_RUN = re.compile(r"^\s*<!--\s*not run:\s*(?P<reason>.+?)\s*-->\s*$")
_FILE = re.compile(r"^\s*<!--\s*file:\s*(?P<name>[\w./-]+)\s*-->\s*$")


@dataclass
class Block:
    page: str
    line: int  # 1-based line of the opening fence
    lang: str
    text: str
    not_run: str | None  # the reason, when marked
    file: str | None = None  # the file this block is the text of, when marked

    @property
    def where(self) -> str:
        return f"{self.page}:{self.line} ({self.lang})"


def pages() -> list[Path]:
    """The Markdown pages of the repository that a user reads: README, CHANGELOG, docs/."""
    found = [ROOT / "README.md", ROOT / "CHANGELOG.md"]
    docs = ROOT / "docs"
    skip = {"_build", "auto_examples", "generated"}
    found += sorted(p for p in docs.rglob("*.md") if not skip & set(p.relative_to(docs).parts))
    return [p for p in found if p.is_file()]


def blocks(path: Path) -> list[Block]:
    """Every fenced block of one page whose language runs, in order."""
    lines = path.read_text(encoding="utf-8").split("\n")
    out, i = [], 0
    while i < len(lines):
        m = _FENCE.match(lines[i])
        if not m:
            i += 1
            continue
        fence, lang, indent = m["fence"], m["lang"].lower(), len(m["indent"])
        j = i + 1
        while j < len(lines) and not re.match(rf"^ *{re.escape(fence[0])}{{{len(fence)},}}\s*$", lines[j]):
            j += 1
        body = "\n".join(line[indent:] for line in lines[i + 1:j]) + "\n"
        k = i - 1
        while k >= 0 and not lines[k].strip():
            k -= 1
        before = lines[k] if k >= 0 else ""
        after = lines[j + 1] if j + 1 < len(lines) else ""
        marked = _NOT_RUN.match(before) or _NOT_RUN.match(after)
        file = _FILE.match(before)
        if lang in RUN_LANGUAGES or file:
            out.append(Block(str(path.relative_to(ROOT)), i + 1, lang, body, marked["reason"] if marked else None,
                             file["name"] if file else None))
        i = j + 1
    return out


@dataclass
class Command:
    argv: list[str]
    expected: list[str]  # the output printed under it (console blocks); [] for bash


def commands(block: Block) -> list[Command]:
    """The commands of a shell block: ``$ ``-prompted lines of a console block (the lines up to the
    next prompt are its output), every line of a bash block; ``\\`` continues a line, ``#`` starts a
    comment."""
    out: list[Command] = []
    lines = block.text.rstrip("\n").split("\n")
    console = block.lang == "console"
    i = 0
    while i < len(lines):
        line = lines[i]
        if console and not line.startswith("$ "):
            if not out:
                raise ValueError(f"{block.where}: output before the first '$ ' prompt: {line!r}")
            out[-1].expected.append(line)
            i += 1
            continue
        cmd = line[2:] if console else line
        while cmd.endswith("\\") and i + 1 < len(lines):
            i += 1
            cmd = cmd[:-1] + " " + lines[i].strip()
        i += 1
        argv = shlex.split(cmd, comments=True)
        if argv:
            out.append(Command(argv, []))
    return out


def femupdate_args(argv: list[str]) -> list[str] | None:
    """The arguments after ``femupdate`` / ``python -m femupdate``; None for any other program."""
    if argv[:1] == ["femupdate"]:
        return argv[1:]
    if len(argv) >= 3 and argv[0] in ("python", "python3") and argv[1:3] == ["-m", "femupdate"]:
        return argv[3:]
    return None


def output_matches(expected: list[str], actual: str) -> str | None:
    """None when the printed output shows what the page says, else why not.  A line that is ``...``
    alone stands for any output, and ``...`` within a line for any text there (a time, a count
    that varies); the rest must appear in order and whole, compared word by word (so a line the
    page wraps where a terminal wrapped it still matches)."""
    got = " " + " ".join(actual.split()) + " "
    chunks, cur = [], []
    for line in expected:
        if line.strip() == "...":
            chunks.append(cur)
            cur = []
        else:
            cur.append(line)
    chunks.append(cur)
    pos = 0
    for chunk in chunks:
        words = " ".join(" ".join(chunk).split())
        if not words:
            continue
        pattern = " " + ".*?".join(re.escape(part) for part in words.split("...")) + " "
        found = re.compile(pattern, re.S).search(got, pos)
        if found is None:
            return "not found in order:\n  " + "\n  ".join(chunk)
        pos = found.end() - 1
    return None
