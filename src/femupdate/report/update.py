"""The reports of ``update`` and ``frf-update``, ``direct`` and ``update-multi``."""

from __future__ import annotations

from .document import Cell, Document, Figure, Section, Table, num, numcell
from .parts import (collect_notes, correlation_section, cost_unit, damping_section, figures, pairs_table,
                    parameter_table, shapes_section, summary_section)
from .sections import convergence_section, damped_section, frf_section, identifiability_section, starts_section
from .testpoints import test_points_section

# ====================================================================================== per kind
def _verdict_update(result: dict) -> Cell:
    ok = bool(result.get("success"))
    fl = result.get("flags") or []
    text = ("converged" if ok else "NOT converged") + (f"; {len(fl)} flag(s)" if fl else "")
    return Cell(text, cls="ok" if ok and not fl else "bad")


def build_update(doc: Document, result: dict, model, data, rec, segments, kind: str) -> None:
    """``update`` and ``frf-update``."""
    collect_notes(doc, result)
    names = list(result.get("updated") or [])
    doc.verdict = _verdict_update(result)
    doc.facts += [("parameters updated", Cell(str(len(names)))),
                  (f"cost ½‖r‖² [{cost_unit(result)}]", numcell(result.get("cost"), "/cost", 4)),
                  ("iterations", numcell(result.get("iterations"), "/iterations"))]
    if result.get("formulation"):
        doc.facts.append(("formulation", Cell(str(result["formulation"]))))
    extra = []
    if result.get("pairing"):
        pr = result["pairing"]
        extra.append(("pairing", f"{pr.get('policy')} (final pairs by {pr.get('used')}, MAC threshold {pr.get('min_mac')})"))
    if result.get("sensitivity"):
        extra.append(("sensitivity route", str(result["sensitivity"])))
    doc.sections.append(summary_section(doc, result, model, data, extra))
    if names:
        std = (result.get("diagnostics") or {}).get("std")
        doc.sections.append(Section("parameters", "Parameters").add(
            parameter_table(result, names, result.get("start"), std, "start and updated values")))
    for sec in (correlation_section(result, rec), damped_section(result) if result.get("damping") else damping_section(result),
                shapes_section(model, data, rec, segments, result.get("pairs")),
                test_points_section(result, model, segments),
                frf_section(result, rec) if kind == "frf-update" or result.get("omega_rad_s") else None,
                convergence_section(result), identifiability_section(result), starts_section(result)):
        if sec is not None:
            doc.sections.append(sec)
    blocks = result.get("blocks")
    if blocks:
        t = Table("data blocks (how each kind of data was weighted)", ["block", "residuals", "scale", "cost [–]", "weighting"])
        for b in blocks:
            t.rows.append([Cell(str(b.get("label"))), Cell(str(b.get("n_residuals"))), Cell(num(b.get("scale"))),
                           Cell(num(b.get("cost"), 4)), Cell(str(b.get("weighting")))])
        doc.sections.append(Section("blocks", "Data blocks").add(t))
    pg = result.get("pairing") or {}
    macs = {int(k): (int(j), m) for k, j, m in result.get("pairs") or []}
    for k in pg.get("low_mac") or []:
        if int(k) in macs:
            j, m = macs[int(k)]
            doc.warnings.append(f"test mode {int(k) + 1} is paired by {pg.get('used', '?')} with model mode {j + 1} at MAC "
                                f"{num(m, 3)}, below the pairing threshold {num(pg.get('min_mac', 0.5))}: the shapes do not "
                                "confirm this pair, so the updated values are doubtful")
    if result.get("success") is False:
        doc.warnings.append(f"the update did not converge: {result.get('message', '')}".rstrip(": "))
    for sw in (result.get("swaps") or [])[:10]:
        doc.notes.append(f"mode swap: test mode {sw['test_mode'] + 1} moved from model mode {sw['from_model_mode'] + 1} "
                         f"to {sw['to_model_mode'] + 1} (evaluation {sw['evaluation']})")


def build_direct(doc: Document, result: dict, model, data, rec, segments, kind: str) -> None:
    collect_notes(doc, result)
    unknowns = list(result.get("unknowns") or [])
    ok = bool(result.get("unique", True))
    doc.verdict = Cell("unique solution" if ok else "NOT unique (rank-deficient)", cls="ok" if ok else "bad")
    doc.facts += [("unknowns", Cell(str(len(unknowns)))), ("equations", numcell(result.get("n_equations"), "/n_equations")),
                  ("condition number [–]", numcell(result.get("condition_number"), "/condition_number", 4))]
    extra = []
    if result.get("mapping"):
        m = result["mapping"]
        extra.append(("full-field mapping", f"{m.get('method')}, interpolation error {num(m.get('interpolation_error'), 3)} "
                                            f"(relative), largest distance {num(m.get('max_distance'), 3)} m"))
    doc.sections.append(summary_section(doc, result, model, data, extra))
    se = result.get("standard_error") or {}
    sec = Section("parameters", "Parameters")
    sec.add(parameter_table(result, unknowns, result.get("start"), se, "identified values", "std. error"))
    t = Table("the stacked linear system", ["quantity", "value"])
    for label, key in (("condition number [–]", "condition_number"),
                       ("condition number, columns scaled to unit length [–]", "condition_number_scaled"),
                       ("residual norm ‖A p − b‖ [units of b]", "residual_norm"), ("relative residual [–]", "relative_residual"),
                       ("rank", "rank"), ("equations", "n_equations")):
        if result.get(key) is not None:
            t.rows.append([Cell(label), numcell(result[key], f"/{key}", 4)])
    t.rows.append([Cell("bounded least squares"), Cell("yes" if result.get("bounded") else "no")])
    sec.add(t)
    doc.sections.append(sec)
    for s in (correlation_section(result, rec), shapes_section(model, data, rec, segments, result.get("pairs"))):
        if s is not None:
            doc.sections.append(s)


def build_multi(doc: Document, result: dict, model, data, rec, segments, kind: str) -> None:
    collect_notes(doc, result)
    names = list(result.get("updated") or [])
    doc.verdict = _verdict_update(result)
    cfgs = result.get("configurations") or []
    doc.facts += [("configurations", Cell(str(len(cfgs)))), ("method", Cell(str(result.get("method")))),
                  ("cost ½‖r‖² [–]", numcell(result.get("cost"), "/cost", 4))]
    doc.sections.append(summary_section(doc, result, model, None, [("configurations", "; ".join(
        f"{c.get('name')}: {c.get('modification')} ({c.get('n_data')} data)" for c in cfgs))]))
    se = result.get("standard_error") or {}
    doc.sections.append(Section("parameters", "Parameters").add(
        parameter_table(result, names, (result.get("history") or [{}])[0].get("parameters"), se,
                         "identified values (start: the first iterate)", "std. error")))
    sec = Section("configurations", "Configurations")
    figs = figures()
    for ci, c in enumerate(cfgs):
        fr = c.get("frequencies_hz") or {}
        if c.get("pairs") and fr.get("test"):
            t = pairs_table(f"{c.get('name')} ({c.get('modification')})", c["pairs"], fr["test"], fr["model"], None)
            for i, row in enumerate(t.rows):
                row[2] = numcell(fr["test"][i], f"/configurations/{ci}/frequencies_hz/test/{i}")
                row[3] = numcell(fr["model"][i], f"/configurations/{ci}/frequencies_hz/model/{i}")
            sec.add(t)
            sec.add(Figure(figs.frequency_figure(fr["test"], None, fr["model"]),
                           f"{c.get('name')}: relative frequency error after the update."))
    cond = result.get("conditioning") or {}
    if cond.get("cumulative"):
        t = Table("conditioning: configurations added one by one (columns scaled)",
                  ["configurations", "rank", "condition number [–]", "smallest singular value [–]"])
        for row in cond["cumulative"]:
            t.rows.append([Cell(" + ".join(row.get("configurations", []))), Cell(str(row.get("rank"))),
                           Cell(num(row.get("condition_number"), 4)), Cell(num(row.get("min_singular"), 4))])
        sec.add(t)
    doc.sections.append(sec)
    for s in (convergence_section(result), identifiability_section(result)):
        if s is not None:
            doc.sections.append(s)
