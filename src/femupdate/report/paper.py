"""The report of ``paper``: one row per section with its check, and per section the paper's printed
values beside femupdate's."""

from __future__ import annotations

import json
import math

from .document import Cell, Details, Document, Figure, Section, Table, Text, num, numcell
from .parts import fin

def _find(obj, key: str, skip: str = "paper", path: tuple = ()):
    """(path as a tuple of keys, value) of the first ``key`` in ``obj`` (depth first, in order),
    outside the ``skip`` subtree; None when there is none."""
    if isinstance(obj, dict):
        if key in obj:
            return (*path, key), obj[key]
        for k, v in obj.items():
            if k == skip:
                continue
            hit = _find(v, key, skip, (*path, k))
            if hit is not None:
                return hit
    return None


def _short(v, limit: int = 220) -> str:
    """A value in one line: numbers to 6 digits, lists and objects compactly."""
    def conv(x):
        if isinstance(x, float):
            return float(num(x).replace("−", "-")) if math.isfinite(x) else str(x)
        if isinstance(x, dict):
            return {k: conv(y) for k, y in x.items()}
        if isinstance(x, list):
            return [conv(y) for y in x]
        return x
    text = v if isinstance(v, str) else json.dumps(conv(v), ensure_ascii=False)
    return text if len(text) <= limit else text[:limit] + " …"


#: a section's verdict -> (check column, its class, the sentence under the section)
_VERDICT_TEXT = {
    "agree": ("agrees", "ok", "Agrees with the paper."),
    "differ-explained": ("differs (explained)", "", "Differs from the paper, for the reason explained below."),
    "differ": ("DIFFERS", "bad", "DIFFERS from the paper, with no explanation recorded."),
    "not-comparable": ("not comparable", "", "Not comparable with the paper (the reason below)."),
    None: ("–", "", "The paper prints nothing to compare with."),
}


def _paper_verdict(s: dict) -> str | None:
    """A section's verdict: its ``comparison`` (agree, differ-explained, not-comparable) when it
    states one, else read from ``agrees_with_paper`` (False without an explanation: differ)."""
    c = s.get("comparison")
    if c in ("agree", "differ-explained", "not-comparable"):
        return c
    a = s.get("agrees_with_paper")
    if a is True:
        return "agree"
    if a is False:
        return "differ-explained" if s.get("explanation") else "differ"
    return None


def build_paper(doc: Document, result: dict, model, data, rec, segments, kind: str, images: dict | None = None) -> None:
    sections = result.get("sections") or {}
    verdicts = [_paper_verdict(s) for s in sections.values()]
    count = {v: verdicts.count(v) for v in ("agree", "differ-explained", "differ", "not-comparable", None)}
    doc.title = str(result.get("paper") or "the reference paper")
    parts = [f"{count['agree']} agree", f"{count['differ-explained']} differ (explained)"]
    parts += [f"{count['differ']} DIFFER unexplained"] if count["differ"] else []
    parts += [f"{count['not-comparable'] + count[None]} not comparable"]
    doc.verdict = Cell(", ".join(parts), cls="ok" if not count["differ"] else "bad")
    doc.facts += [("sections", Cell(str(len(sections))))]
    ov = Section("overview", "Sections")
    t = Table("", ["section", "paper", "result", "check"])
    for name, s in sections.items():
        v = _paper_verdict(s)
        ref = ", ".join(f"{w} {s[k]}" for k, w in (("equations", "eqs."), ("figure", "Fig.")) if s.get(k)
                        and isinstance(s.get(k), str) and not str(s.get(k)).endswith(".png"))
        t.rows.append([Cell(name), Cell(ref or "–"), Cell(str(s.get("summary", ""))),
                       Cell(_VERDICT_TEXT[v][0], key=f"/sections/{name}/agrees_with_paper", cls=_VERDICT_TEXT[v][1])])
    ov.add(t)
    doc.sections.append(ov)
    for name, s in sections.items():
        sec = Section(f"s-{name}", name)
        if s.get("description"):
            sec.add(Text(str(s["description"])))
        printed = s.get("paper")
        if isinstance(printed, dict) and printed:
            pt = Table("the paper's printed values beside femupdate's", ["quantity", "the paper prints", "femupdate computes",
                                                                            "where in paper.json"])
            for k, v in printed.items():
                hit = _find(s, k)
                got = (numcell(hit[1], "/" + "/".join(("sections", name, *hit[0])))
                       if hit and fin(hit[1]) else Cell(_short(hit[1]) if hit else "–"))
                pt.rows.append([Cell(k), Cell(_short(v)), got,
                                Cell(".".join(("sections", name, *hit[0])) if hit else "(no value of that name)")])
            sec.add(pt)
        elif printed is not None:
            sec.add(Text(f"The paper: {_short(printed, 600)}"))
        for k in ("finding", "notes"):
            v = s.get(k)
            if v:
                for line in (v if isinstance(v, list) else [v]):
                    sec.add(Text(str(line), "note"))
        v = _paper_verdict(s)
        sec.add(Text(_VERDICT_TEXT[v][2], {"agree": "", "differ": "warning"}.get(v or "", "note")))
        if s.get("explanation"):
            sec.add(Text(f"Why: {s['explanation']}", "note"))
        for img in (images or {}).get(name, []):
            sec.add(Figure(img, f"{name}: the figure written by femupdate paper"))
        sec.add(Details("every computed value (JSON)", json.dumps(s, indent=1, ensure_ascii=False)))
        doc.sections.append(sec)
