"""Checks shared by the TOML and JSON readers: duplicate JSON keys, integers too long or too
large for a float, and numbers above :data:`femupdate._limits.MAX_MAGNITUDE` in magnitude, each
refused with the file and the field named."""

from __future__ import annotations

import json
import math
import re
from collections.abc import Mapping

from .._errors import InputError
from .._limits import MAX_MAGNITUDE


class _DuplicateKeys(dict):
    """A JSON object that repeated a key (the first repeated key in ``duplicate``)."""

    duplicate: str


class _TooLong(float):
    """An integer literal too long to convert (the float it stands for is inf)."""

    digits: int

    def __new__(cls, text):
        obj = super().__new__(cls, "inf")
        obj.digits = len(text.lstrip("-"))
        return obj


def _pairs(pairs):
    out = dict(pairs)
    if len(out) == len(pairs):
        return out
    seen: set = set()
    dup = next(k for k, _ in pairs if k in seen or seen.add(k))
    marked = _DuplicateKeys(out)
    marked.duplicate = dup
    return marked


class _Overflow(float):
    """A number literal beyond the largest float (``1e400``: Python reads it as inf)."""

    text: str

    def __new__(cls, text):
        obj = super().__new__(cls, "inf")
        obj.text = text
        return obj


def parse_float(text: str):
    """A float literal of a JSON or TOML file (their readers' ``parse_float``): one that overflows
    to infinity (``1e400``; not a literal ``inf``) is marked, for :func:`check_magnitudes` to
    refuse it as written."""
    v = float(text)
    return _Overflow(text) if math.isinf(v) and "inf" not in text.lower() else v


def _int(text: str):
    # Python refuses to convert integer strings above 4,300 digits (ValueError); a few hundred
    # digits already overflow a float: both are refused by check_magnitudes, naming the field
    return int(text) if len(text) <= 300 else _TooLong(text)


def _where(loc: list) -> str:
    out = ""
    for part in loc:
        out += f"[{part}]" if isinstance(part, int) else (f".{part}" if out else str(part))
    return out or "the top-level object"


def check_magnitudes(tree, source: str, loc=None) -> None:
    """Refuse numbers above :data:`MAX_MAGNITUDE` in magnitude anywhere in a parsed file (and the
    duplicate keys that :func:`loads_json` marked).

    Infinities and NaN are left to the field's own check (an infinite bound means no bound).
    Array positions in the message count from 1.

    Raises
    ------
    InputError
        Naming ``source`` and the field (e.g. ``modes[2].shape.1:x``).
    """
    loc = [] if loc is None else loc
    if isinstance(tree, _DuplicateKeys):
        raise InputError(f"{source}: {_where(loc)}: duplicate key {tree.duplicate!r} "
                         "(JSON would silently keep only the last value)")
    if isinstance(tree, Mapping):
        for k, v in tree.items():
            check_magnitudes(v, source, loc + [k])
    elif isinstance(tree, list):
        for i, v in enumerate(tree, start=1):
            check_magnitudes(v, source, loc + [i])
    elif isinstance(tree, _Overflow):
        raise InputError(f"{source}: {_where(loc)}: {tree.text} is too large (beyond the largest floating-point "
                         f"number; numbers must be at most {MAX_MAGNITUDE:g} in magnitude)")
    elif isinstance(tree, _TooLong):
        raise InputError(f"{source}: {_where(loc)}: an integer of {tree.digits} digits is too large "
                         f"(numbers must be at most {MAX_MAGNITUDE:g} in magnitude)")
    elif isinstance(tree, (int, float)) and not isinstance(tree, bool):
        too_large = abs(tree) > MAX_MAGNITUDE if isinstance(tree, int) else (math.isfinite(tree) and abs(tree) > MAX_MAGNITUDE)
        if too_large:
            shown = f"an integer of {len(str(abs(tree)))} digits" if isinstance(tree, int) else f"{tree:.3g}"
            raise InputError(f"{source}: {_where(loc)}: {shown} is too large "
                             f"(numbers must be at most {MAX_MAGNITUDE:g} in magnitude)")


def load_json_file(path) -> object:
    """The JSON file ``path`` read as :func:`loads_json` parses text.

    Raises
    ------
    InputError
        No such file, a directory or a file that is not UTF-8 text, and as :func:`loads_json`.
    """
    try:
        text = path.read_text()
    except FileNotFoundError:
        raise InputError(f"{path}: no such file") from None
    except (IsADirectoryError, UnicodeDecodeError):
        raise InputError(f"{path}: not a readable JSON text file") from None
    return loads_json(text, str(path))


def loads_json(text: str, source: str):
    """Parse JSON text, refusing duplicate keys in an object (JSON keeps the last silently) and
    numbers that :func:`check_magnitudes` refuses.

    Raises
    ------
    InputError
        Malformed JSON, a duplicate key (named with its object's path), a too-large number.
    """
    try:
        raw = json.loads(text, object_pairs_hook=_pairs, parse_int=_int, parse_float=parse_float)
        check_magnitudes(raw, source)
    except json.JSONDecodeError as exc:
        raise InputError(f"{source}: malformed JSON: {exc}") from None
    except RecursionError:
        raise InputError(f"{source}: JSON nested too deeply") from None
    return raw


def long_integer_line(text: str) -> int | None:
    """Line number (from 1) of the first integer literal longer than Python converts, or None."""
    m = re.search(r"\d[\d_]{4300,}", text)
    return None if m is None else text.count("\n", 0, m.start()) + 1
