"""The report of ``damage``: the located unknowns, their verification and confidence, the change
of every unknown (on the structure), the damaged modes against the baseline."""

from __future__ import annotations

from .._errors import InputError
from .document import Cell, Document, Figure, Section, Table, Text, num, numcell, pct
from .parts import NONE, PCT, collect_notes, figures, maccell, shapes_section, summary_section, units_of

def build_damage(doc: Document, result: dict, model, data, rec, segments, kind: str) -> None:
    collect_notes(doc, result)
    status = str(result.get("status") or ("localised" if result.get("localised") else "not localised"))
    doc.verdict = Cell(status, cls={"confirmed": "ok"}.get(status, "bad"))
    located = list(result.get("located") or [])
    changes = result.get("changes") or {}
    doc.facts += ([("verdict", Cell(str(result["headline"])))] if result.get("headline") else []) + [
                  ("unknowns", Cell(f"{len(changes)} ({result.get('unknowns', 'parameters')})")),
                  ("located", Cell(", ".join(located) or "none"))]
    for d in result.get("doubts") or []:
        doc.warnings.append(f"doubtful: {d}")
    if result.get("reason"):
        doc.warnings.append(f"not localised: {result['reason']}")
    doc.sections.append(summary_section(doc, result, model, data))
    units = units_of(result)
    conf = result.get("confidence") or {}
    sec = Section("damage", "Located damage")
    t = Table("located unknowns", ["unknown", "what", "baseline", "identified", "unit", f"change [{PCT}]",
                                   f"std. error [{PCT} of baseline]", f"selected in bootstrap replicates [{PCT}]",
                                   "misfit without it [–]"])
    desc = result.get("descriptions") or {}
    for n in located:
        se = (conf.get("standard_error") or {}).get(n)
        sel = (conf.get("selection_frequency") or {}).get(n)
        ev = (conf.get("evidence") or {}).get(n)
        t.rows.append([Cell(n, cls="flag"), Cell(desc.get(n, "")), numcell((result.get("baseline") or {}).get(n)),
                       numcell((result.get("parameters") or {}).get(n), f"/parameters/{n}"), Cell(units.get(n) or "not stated"),
                       Cell(pct(changes.get(n), 4)), Cell(pct(se, 3, sign=False)),
                       Cell(pct(sel, 3, sign=False) if status == "confirmed" else "–"), Cell(num(ev, 4))])
    if located:
        sec.add(t)
    else:
        sec.add(Text("No unknown changed by more than the threshold.", "note"))
    v = result.get("verification") or {}
    if v:
        sec.add(Text(f"Verification: chi-square {num(v.get('chi2'), 4)} against a limit of {num(v.get('limit'), 4)} "
                     f"({v.get('dof')} degrees of freedom, level {num(v.get('level'))}; noise: frequency "
                     f"{num((v.get('noise') or {}).get('frequency'))}, shape {num((v.get('noise') or {}).get('shape'))}): "
                     + ("the located set reproduces the data." if v.get("fits") else "the located set does NOT reproduce "
                        "the data."), "" if v.get("fits") else "warning"))
    if conf.get("bootstrap"):
        sec.add(Text(f"Bootstrap: {conf['bootstrap']} replicates simulated from the identified model, each re-localised, "
                     f"refined and verified; {pct(conf.get('same_set'), 3, sign=False)} locate exactly this set."))
    for key, what in (("false_positive_rate", "Healthy baseline simulated with this run's sensors, modes and noise: some "
                                              "unknown reported damaged in"),
                      ("detection_rate", "Located model simulated likewise: every located unknown found again in")):
        rate = conf.get(key)
        if isinstance(rate, dict) and "count" in rate:
            lo, hi = (rate.get("interval") or [None, None])[:2]
            sec.add(Text(f"{what} {rate['count']} of {rate['n']} replicates ({pct(rate.get('rate'), 2, sign=False)}; "
                         f"95 % interval {pct(lo, 2, sign=False)} to {pct(hi, 2, sign=False)}).", "note"))
    names = list(changes)
    if names:
        sec.add(Figure(figures().damage_figure(names, changes, set(located), conf.get("standard_error")),
                       "Identified relative change of every unknown; located ones in red with their standard error.",
                       wide=len(names) > 16))
    members = _members(model, names) if model is not None and model.nodes else {}
    if any(members.values()):
        sec.add(Figure(figures().damage_map_figure(model, members, changes, set(located), segments),
                       "The structure, each unknown's members coloured by its identified change (blue: softer); "
                       "the located ones thick."))
    doc.sections.append(sec)
    pairs = result.get("pairs") or []
    if pairs:
        ct = Table("damaged test modes against the baseline", ["test mode", "baseline mode", f"MAC [{NONE}]",
                                                               f"frequency change [{PCT}]"])
        for i, ((k, j, mac), fc) in enumerate(zip(pairs, result.get("frequency_change") or [])):
            ct.rows.append([Cell(str(k + 1)), Cell(str(j + 1)), maccell(mac, f"/pairs/{i}/2"), Cell(pct(fc))])
        doc.sections.append(Section("pairs", "Test modes against the baseline").add(ct))
    bc = result.get("baseline_check")
    if bc:
        doc.sections[-1].add(Text("Baseline check against the undamaged data: " + ("passed." if bc.get("ok") else
                                  "FAILED: " + "; ".join(bc.get("reasons") or [])), "" if bc.get("ok") else "warning"))
    shapes = shapes_section(model, data, rec, segments, None if rec is None or rec.after is None or
                             rec.after.correlation is None else rec.after.correlation.pairs)
    if shapes is not None:
        shapes.title = "Mode shapes of the identified (damaged) model"
        doc.sections.append(shapes)


def _members(model, names) -> dict:
    """{unknown: [(node a, node b), ...]}: the members each damage unknown scales — from an
    element-wise name (``E.A-B``, ``E.A-B.2``) or, for a model parameter, the node pairs its
    stiffness derivative couples."""
    import re

    from ..dofs import parse_dof

    node_of = [parse_dof(d)[0] for d in model.dofs]
    out: dict = {}
    for n in names:
        m = re.fullmatch(r"[A-Za-z]+\.(\d+)-(\d+)(?:\.\d+)?", n)
        if m and int(m.group(1)) in model.nodes and int(m.group(2)) in model.nodes:
            out[n] = [(int(m.group(1)), int(m.group(2)))]
            continue
        try:
            dK = model.dK[model.parameter_index(n)]
        except InputError:  # a name the model does not have: nothing to draw
            continue
        if dK is None:
            continue
        coo = dK.tocoo()
        out[n] = sorted({tuple(sorted((node_of[r], node_of[c]))) for r, c in zip(coo.row, coo.col)
                         if node_of[r] != node_of[c] and node_of[r] in model.nodes and node_of[c] in model.nodes})
    return out
