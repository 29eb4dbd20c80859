"""Reproduction of the reference paper's numbered results (``femupdate paper``).

Each section is a function ``(out_dir, figures) -> dict`` registered in :data:`SECTIONS`; the
dict holds the computed values, the paper's printed values where there are any, a one-line
``summary`` and ``agrees_with_paper`` (True / False / None when the paper prints no number).
Later capabilities add their sections to the same registry.
"""

from __future__ import annotations

import json
from pathlib import Path

from ..io.results import to_jsonable, write_json


def _discover() -> dict:
    """Sections of every ``*_sections`` module of this package, ordered by the modules' ``ORDER``.

    A section module defines ``ORDER`` (an int: its place in ``paper.json``) and ``SECTIONS``
    ({name: function(out_dir, figures) -> dict}).
    """
    import importlib
    import pkgutil

    mods = [importlib.import_module(f"{__name__}.{m.name}") for m in pkgutil.iter_modules(__path__)
            if m.name.endswith("_sections")]
    out: dict = {}
    for mod in sorted(mods, key=lambda m: (getattr(m, "ORDER", 1000), m.__name__)):
        for name, fn in mod.SECTIONS.items():
            if name in out:
                raise RuntimeError(f"paper section {name!r} is defined twice")
            out[name] = fn
    return out


SECTIONS = _discover()


TITLE = "Issues concerning the updating of finite-element models from experimental data"


def _no_constant(name: str):
    raise ValueError(f"{name} is not a number femupdate writes")


def previous_sections(path, notes: list) -> dict:
    """The sections of an existing ``paper.json`` that can be kept: known names, each an object
    with a ``summary`` text and ``agrees_with_paper`` true, false or null.

    A file that is unreadable, malformed or not written by ``femupdate paper`` is ignored, and so
    is every section that is unknown or not as femupdate writes it; each is said in ``notes``.
    """
    path = Path(path)
    if not path.exists():
        return {}
    try:
        doc = json.loads(path.read_text(), parse_constant=_no_constant)
    except RecursionError:
        doc, why = None, "nested too deeply"
    except (OSError, ValueError) as exc:  # malformed JSON, not UTF-8, NaN, an integer too long
        doc, why = None, str(exc)
    else:
        why = "not written by femupdate paper"
    if not isinstance(doc, dict) or doc.get("paper") != TITLE or not isinstance(doc.get("sections"), dict):
        notes.append(f"existing {path} ignored and replaced ({why})")
        return {}
    kept, dropped = {}, []
    for name, sec in doc["sections"].items():
        if (name in SECTIONS and isinstance(sec, dict) and isinstance(sec.get("summary"), str)
                and "agrees_with_paper" in sec and any(sec["agrees_with_paper"] is v for v in (True, False, None))):
            kept[name] = sec
        else:
            dropped.append(name)
    if dropped:
        notes.append(f"existing {path}: section(s) {', '.join(map(repr, dropped))} ignored (unknown, or not as femupdate "
                     "paper writes them)")
    return kept


def run_sections(out_dir, names=None, figures: bool = True, notes: list | None = None) -> dict:
    """Run the named sections (default all) and write ``out_dir/paper.json``.

    Sections already in an existing ``paper.json`` and not re-run are kept when they are as
    femupdate writes them (:func:`previous_sections`); what is ignored is appended to ``notes``.
    """
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    names = list(SECTIONS) if not names else list(names)
    path = out_dir / "paper.json"
    sections = previous_sections(path, notes if notes is not None else [])
    for name in names:
        sections[name] = to_jsonable(SECTIONS[name](out_dir, figures))
    result = {"paper": TITLE, "sections": {k: sections[k] for k in SECTIONS if k in sections}}
    write_json(path, result)
    return result
