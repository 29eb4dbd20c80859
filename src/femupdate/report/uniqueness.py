"""The report of ``uniqueness``: the verdict of each case, the counting criteria, the distinct
solutions of the non-unique cases."""

from __future__ import annotations

from .document import Cell, Document, Figure, Section, Table, Text, num, numcell, unit_label
from .parts import collect_notes, figures, summary_section, units_of

def build_uniqueness(doc: Document, result: dict, model, data, rec, segments, kind: str) -> None:
    collect_notes(doc, result)
    cases = result.get("cases") or []
    units = units_of(result)
    names = list(result.get("parameters") or [])
    verdicts = [c.get("verdict") for c in cases]
    doc.verdict = Cell(f"{verdicts.count('unique')} of {len(cases)} cases unique", cls="ok")
    doc.facts += [("unknowns", Cell(", ".join(names))), ("starts per case", numcell(result.get("starts"), "/starts")),
                  ("cases", Cell(str(len(cases))))]
    truth = result.get("truth") or {}
    rows = [(f"truth {unit_label(n, units.get(n))}", num(truth.get(n))) for n in names]
    doc.sections.append(summary_section(doc, result, model, None, rows + [("route", str(result.get("route", "")))],
                                 data_units=False))  # a study's "units" are its work units
    sec = Section("cases", "Cases")
    if cases:
        sec.add(Figure(figures().uniqueness_figure(cases, f"{result.get('model', '')}: {result.get('starts')} starts per case"),
                       "Verdict of each case (measured dofs × number of measured modes); text: distinct solutions "
                       "and log10 of the condition number at the truth."))
    t = Table("", ["measured dofs", "modes m", "verdict", "distinct solutions", "converged", "local minima",
                   "cond(S) at the truth [–]", "paper's criterion mn ≥ L, n > 1"])
    for i, c in enumerate(cases):
        d = c.get("measured_dofs") or []
        t.rows.append([Cell(", ".join(d) if len(d) <= 4 else f"{d[0]} … {d[-1]} ({len(d)})"), Cell(str(c.get("n_modes"))),
                       Cell(str(c.get("verdict")), cls="ok" if c.get("verdict") == "unique" else "bad"),
                       numcell(len(c.get("solutions") or []), None), numcell(c.get("converged"), f"/cases/{i}/converged"),
                       Cell(str(c.get("local_minima", "–"))),
                       numcell(c.get("condition_number"), f"/cases/{i}/condition_number", 3)
                       if c.get("condition_number") is not None else Cell("∞"),
                       Cell("yes" if (c.get("criteria") or {}).get("paper") else "no")])
    sec.add(t)
    doc.sections.append(sec)
    _conditioning(doc, cases, result.get("alpha"))
    agree = result.get("criteria_agreement") or {}
    if agree:
        at = Table("counting criteria against the study's verdicts", ["criterion", "agrees", "wrong on (n × m)"])
        for n, a in agree.items():
            at.rows.append([Cell(n), Cell(f"{a.get('agrees')}/{a.get('of')}"), Cell(", ".join(a.get("wrong_cases") or []) or "–")])
        doc.sections.append(Section("criteria", "Counting criteria").add(at))
    non_unique = [(i, c) for i, c in enumerate(cases) if c.get("verdict") == "non-unique"]
    if non_unique:
        sec = Section("solutions", "Distinct solutions of the non-unique cases")
        for i, c in non_unique[:6]:
            st = Table(f"{', '.join(c.get('measured_dofs') or [])}; {c.get('n_modes')} mode(s)",
                       ["solution", *[unit_label(n, units.get(n)) for n in names], "starts", "truth"])
            sols = c.get("solutions") or []
            for k, s in enumerate(sols[:10]):
                st.rows.append([Cell(str(k + 1)), *[numcell(s["parameters"].get(n), f"/cases/{i}/solutions/{k}/parameters/{n}")
                                                    for n in names], Cell(str(s.get("count"))),
                                Cell("yes" if s.get("is_truth") else "no")])
            if len(sols) > 10:
                st.note = f"the first 10 of {len(sols)} distinct solutions"
            sec.add(st)
            ex = c.get("exact") or {}
            if ex.get("solutions"):
                sec.add(Text(f"Exact solution set from the frequencies (Gröbner basis): {len(ex['solutions'])} real "
                             "solution(s): " + "; ".join("(" + ", ".join(f"{n} = {s['exact'].get(n, num(s['parameters'].get(n)))}"
                                                                        if isinstance(s.get('exact'), dict) else
                                                                        f"{n} = {num(s['parameters'].get(n))}" for n in names) + ")"
                                                        for s in ex["solutions"][:8])))
            elif ex.get("zero_dimensional") is False:
                sec.add(Text("Exact solution set from the frequencies: infinitely many solutions (a curve or surface "
                             "of parameter values).", "note"))
        if len(non_unique) > 6:
            sec.add(Text(f"The first 6 of {len(non_unique)} non-unique cases are listed.", "note"))
        doc.sections.append(sec)


def _conditioning(doc: Document, cases: list, alpha) -> None:
    """Unique but ill-conditioned cases, with their ± statement: ill-conditioning is not
    non-uniqueness."""
    from ..distinct import conditioning_line

    rows = [(c, (c.get("distinct") or {}).get("conditioning")) for c in cases if c.get("verdict") == "unique"]
    rows = [(c, k) for c, k in rows if k and k.get("ill_conditioned")]
    if not rows:
        return
    sec = Section("conditioning", "Unique but ill-conditioned cases")
    sec.add(Text(f"Solutions are told apart at α = {alpha if alpha is not None else 0.01:g} against their covariance; "
                 "these cases have one solution, some combination of the unknowns determined poorly.", "note"))
    t = Table("", ["measured dofs", "modes m", "conditioning"])
    for c, k in rows[:20]:
        t.rows.append([Cell(", ".join(c.get("measured_dofs") or [])), Cell(str(c.get("n_modes"))),
                       Cell(conditioning_line(k or {}))])
    sec.add(t)
    doc.sections.append(sec)
