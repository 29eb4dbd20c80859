"""The report as plain data before it becomes HTML: sections of tables, figures, texts and
notes.  A table cell may carry the JSON path of the number it shows (``key``) and the number at
full precision (``value``), written into the HTML as ``data-key`` and ``data-value`` so that a
reader — or a test in a browser — can check the page against the result file."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import ClassVar


@dataclass
class Cell:
    """One table cell: its text; optionally the place in the JSON of the value it shows (a JSON
    pointer, ``"/parameters/k1"``) and that value at full precision, and a CSS class (``flag`` for
    a value on a bound, ``ok`` / ``bad`` for verdicts)."""

    text: str
    key: str | None = None
    value: float | None = None
    cls: str = ""


@dataclass
class Table:
    """A table: caption, column headings (each with its unit in brackets) and rows of cells."""

    type: ClassVar[str] = "table"

    caption: str
    columns: list[str]
    rows: list[list[Cell]] = field(default_factory=list)
    note: str = ""


@dataclass
class Figure:
    """An embedded figure (``{"svg": ...}`` or ``{"png": data URI}``) with its caption; ``wide`` for
    figures of several panels."""

    type: ClassVar[str] = "figure"

    image: dict
    caption: str = ""
    wide: bool = False


@dataclass
class Text:
    """A paragraph (``cls`` ``"warning"`` or ``"note"`` styles it)."""

    type: ClassVar[str] = "text"

    text: str
    cls: str = ""


@dataclass
class Details:
    """A collapsed block of preformatted text (e.g. a section's JSON)."""

    type: ClassVar[str] = "details"

    summary: str
    text: str


@dataclass
class Section:
    """A titled part of the report; ``id`` is its HTML anchor."""

    id: str
    title: str
    blocks: list = field(default_factory=list)

    def add(self, *blocks) -> "Section":
        self.blocks.extend(b for b in blocks if b is not None)
        return self


@dataclass
class Document:
    """The whole report: title, kind of run, key facts, sections, and every note and warning."""

    title: str
    kind: str
    facts: list[tuple[str, Cell]] = field(default_factory=list)
    sections: list[Section] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    source: str = ""
    verdict: Cell | None = None


# ------------------------------------------------------------------------------ number formatting
def num(v, digits: int = 6) -> str:
    """A number as shown in the report: ``digits`` significant digits, ``–`` for none, ``∞``."""
    if v is None:
        return "–"
    if isinstance(v, bool):
        return "yes" if v else "no"
    try:
        x = float(v)
    except (TypeError, ValueError):
        return str(v)
    if math.isnan(x):
        return "–"
    if math.isinf(x):
        return "∞" if x > 0 else "−∞"
    return f"{x:.{digits}g}".replace("-", "−")


def pct(v, digits: int = 3, sign: bool = True) -> str:
    """A fraction shown in per cent: ``-0.0123`` -> ``−1.23 %`` (``sign``: always a sign)."""
    if v is None or (isinstance(v, float) and not math.isfinite(v)):
        return "–"
    return f"{float(v) * 100:{'+' if sign else ''}.{digits}g} %".replace("-", "−")


def numcell(v, key: str | None = None, digits: int = 6, cls: str = "") -> Cell:
    """A cell showing the number ``v`` and, with ``key``, tied to its place in the JSON."""
    finite = isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(float(v))
    return Cell(num(v, digits), key if finite else None, float(v) if finite else None, cls)


def unit_label(name: str, unit: str | None) -> str:
    """``"k1 [N/m]"``; ``"k1 [unit not stated]"`` when the unit is unknown."""
    return f"{name} [{unit}]" if unit else f"{name} [unit not stated]"
