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


def run_sections(out_dir, names=None, figures: bool = True) -> dict:
    """Run the named sections (default all) and write ``out_dir/paper.json``.

    Sections already in an existing ``paper.json`` and not re-run are kept.
    """
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    names = list(SECTIONS) if not names else list(names)
    path = out_dir / "paper.json"
    previous = {}
    if path.exists():
        try:
            previous = json.loads(path.read_text()).get("sections", {})
        except (json.JSONDecodeError, AttributeError):
            previous = {}
    sections = dict(previous)
    for name in names:
        sections[name] = to_jsonable(SECTIONS[name](out_dir, figures))
    result = {
        "paper": "Issues concerning the updating of finite-element models from experimental data",
        "sections": {k: sections[k] for k in SECTIONS if k in sections} | {k: v for k, v in sections.items() if k not in SECTIONS},
    }
    write_json(path, result)
    return result
