"""The JSON results' schema, in one place: for every kind of result (the command that writes it)
its keys, their JSON types and meaning, and which form the stable core scripts can rely on.

The result classes write (:meth:`~femupdate.serialise.Serialisable.to_json`) and read
(:meth:`~femupdate.serialise.Serialisable.from_json`) these keys; :func:`check` tells a JSON
object that does not hold what its kind writes; and docs/file-formats.md's section on JSON results
is generated from here (:func:`markdown`; ``python -m femupdate.schema docs/file-formats.md``
rewrites the marked parts, and a test keeps them equal).  The version is
:data:`femupdate.serialise.SCHEMA_VERSION`.
"""

from __future__ import annotations

import dataclasses
import importlib
from collections.abc import Mapping

from .._errors import InputError

#: JSON types, as :func:`check` tells them
OBJECT, ARRAY, NUMBER, INTEGER, STRING, BOOLEAN = "object", "array", "number", "integer", "string", "boolean"


@dataclasses.dataclass(frozen=True)
class Key:
    """One key of a kind of result.

    Attributes
    ----------
    name : str
        The key (several names that share a row: ``"status, message"``).
    type : str
        Its type as the documentation says it (``{name: value}``, ``list``, ...).
    meaning : str
        What it holds (Markdown).
    json : tuple of str
        The JSON types it may hold (:data:`OBJECT`, ...; null is always allowed); empty: not
        checked.
    core : bool
        Part of the stable core scripts can rely on (bold in the documentation).
    """

    name: str
    type: str
    meaning: str = ""
    json: tuple[str, ...] = ()
    core: bool = False


@dataclasses.dataclass(frozen=True)
class Kind:
    """A kind of result: its name (the command), the text before and after its table of keys."""

    name: str
    keys: tuple[Key, ...]
    heading: str = ""
    intro: str = ""
    outro: str = ""
    tables: tuple[tuple[str, tuple[Key, ...]], ...] = ()
    extends: str = ""  #: a kind whose keys this one has too
    may_add: str = ""  #: a kind whose own keys this one may add (an update with FRF data: frf-update's)

    def all_keys(self) -> tuple[Key, ...]:
        """Its keys with those of the kind it extends or may add, and of its further tables."""
        parent = kinds()[self.extends].all_keys() if self.extends else ()
        added = kinds()[self.may_add].keys if self.may_add else ()
        return (*parent, *self.keys, *(k for _, keys in self.tables for k in keys), *added)


#: the keys every result has
COMMON = (
    Key("kind", "string", "the kind of result: the command that wrote it (`update`, `frf-update`, ...)", (STRING,), True),
    Key("schema_version", "integer", "the version of this schema (1)", (INTEGER,), True),
)

#: kind -> its description (filled by the modules of :data:`MODULES`)
KINDS: dict[str, Kind] = {}
#: the modules that describe kinds
MODULES: tuple[str, ...] = ("femupdate.schema.update",)
MODULES += ("femupdate.schema.frf", "femupdate.schema.uniqueness")
MODULES += ("femupdate.schema.modes", "femupdate.schema.direct", "femupdate.schema.reduction")
MODULES += ("femupdate.schema.damage", "femupdate.schema.posterior")
MODULES += ("femupdate.schema.summary",)
MODULES += ("femupdate.schema.plan",)


def register(kind: Kind) -> Kind:
    KINDS[kind.name] = kind
    return kind


def kinds() -> dict[str, Kind]:
    """Every described kind (importing the modules that describe them)."""
    for m in MODULES:
        importlib.import_module(m)
    return KINDS


def _json_type(v) -> str:
    if isinstance(v, Mapping):
        return OBJECT
    if isinstance(v, list):
        return ARRAY
    if isinstance(v, bool):
        return BOOLEAN
    if isinstance(v, int):
        return INTEGER
    if isinstance(v, float):
        return NUMBER
    if isinstance(v, str):
        return STRING
    return type(v).__name__


def check(obj: Mapping, kind: str) -> None:
    """Refuse a JSON result whose keys do not hold what ``kind`` writes (their JSON types; null
    is allowed everywhere, and keys the schema does not know are left alone).

    Raises
    ------
    InputError
        Naming the key (as a JSON pointer) and what it holds instead.
    """
    described = kinds().get(kind)
    if described is None:
        return
    for key in (*COMMON, *described.all_keys()):
        for name in (n.strip() for n in key.name.split(",")):
            v = obj.get(name)
            if v is None or not key.json:
                continue
            t = _json_type(v)
            if t not in key.json and not (t == INTEGER and NUMBER in key.json):
                raise InputError(f"/{name}: expected {' or '.join(key.json)}, got {t}; the {kind} result is not as "
                                 "femupdate writes it (docs/file-formats.md)")


def _table(keys) -> list[str]:
    lines = ["| key | type | meaning |", "|---|---|---|"]
    for k in keys:
        names = ", ".join(f"**`{n.strip()}`**" if k.core else f"`{n.strip()}`" for n in k.name.split(","))
        lines.append(f"| {names} | {k.type} | {k.meaning} |")
    return lines


def markdown(name: str) -> str:
    """The documentation of kind ``name`` (Markdown: heading, text, table of keys)."""
    kind = kinds()[name]
    lines = [f"#### {kind.heading or f'`{kind.name}`'}", ""]
    if kind.intro:
        lines += [kind.intro, ""]
    if kind.keys:
        lines += _table(kind.keys) + [""]
    for title, keys in kind.tables:
        lines += [title, ""] + _table(keys) + [""]
    if kind.outro:
        lines += [kind.outro, ""]
    return "\n".join(lines).rstrip() + "\n"


def rewrite(text: str) -> str:
    """``text`` with every part between ``<!-- schema: NAME -->`` and ``<!-- /schema -->``
    replaced by :func:`markdown` of NAME.

    Raises
    ------
    InputError
        A marker without its end, or a kind not described.
    """
    out, pos = [], 0
    while True:
        start = text.find("<!-- schema: ", pos)
        if start < 0:
            out.append(text[pos:])
            return "".join(out)
        head_end = text.index("-->", start) + 3
        name = text[start + len("<!-- schema: "):head_end - 3].strip()
        end = text.find("<!-- /schema -->", head_end)
        if end < 0:
            raise InputError(f"<!-- schema: {name} --> without its <!-- /schema -->")
        if name not in kinds():
            raise InputError(f"<!-- schema: {name} -->: no such kind of result (known: {', '.join(sorted(KINDS))})")
        out += [text[pos:head_end], "\n", markdown(name), "\n"]
        pos = end


__all__ = ["Key", "Kind", "KINDS", "COMMON", "register", "kinds", "check", "markdown", "rewrite"]
