"""The report of ``plan``: the layout drawn on the structure, the sensors, what the plan promises
(standard deviations, verdict, Monte Carlo, the classical plans beside it), the exciters and the
pretest correlation (TAM orthogonality, mass loading)."""

from __future__ import annotations

import math

from .document import Cell, Document, Figure, Section, Table, Text, num, numcell, pct
from .parts import summary_section


def _layout_nodes(result: dict, model) -> dict:
    """Node coordinates to draw on: the model's, else the result's, else (a lumped model) the
    nodes on the x axis in id order, as the universal file places them."""
    if model is not None and getattr(model, "nodes", None):
        return {str(k): list(v) for k, v in model.nodes.items()}
    if result.get("nodes"):
        return dict(result["nodes"])
    from ..dofs import parse_dof

    ids = sorted({str(a) for s in result.get("segments") or [] for a in s}
                 | {str(parse_dof(d)[0]) for d in result.get("dofs") or []},
                 key=lambda n: (0, int(n)) if n.lstrip("-").isdigit() else (1, 0))
    return {n: [float(i + 1), 0.0, 0.0] for i, n in enumerate(ids)}


def build_plan(doc: Document, result: dict, model, data, rec, segments, kind: str) -> None:
    names = list(result.get("parameters") or [])
    u = result.get("uniqueness") or {}
    sensors = result.get("sensors") or []
    verdict = str(u.get("verdict", ""))
    doc.verdict = Cell(f"{len(sensors)} {result.get('sensor_kind', '')} sensor(s): {verdict}",
                       cls="ok" if verdict in ("unique", "locally identifiable") else "bad")
    t = result.get("target") or {}
    doc.facts += [("criterion", Cell(str(result.get("criterion")))), ("parameters", Cell(", ".join(names))),
                  ("target modes", Cell(", ".join(f"{m} ({num(f, 5)} Hz)" for m, f in
                                                  zip(t.get("modes") or [], t.get("frequencies_hz") or []))))]
    doc.sections.append(summary_section(doc, result, model, None, [("verdict", f"{verdict} - {u.get('explanation', '')}")],
                                        data_units=False))
    doc.sections.append(_layout_section(result, model, segments))
    doc.sections.append(_promise_section(result, names))
    for sec in (_comparison_section(result), _exciter_section(result), _pretest_section(result)):
        if sec is not None:
            doc.sections.append(sec)


def _layout_section(result: dict, model, segments) -> Section:
    from ..plot.plan import plan_layout_figure

    sec = Section("layout", "The layout on the structure")
    segs = segments.tolist() if hasattr(segments, "tolist") else segments
    segs = segs if segs is not None and len(segs) else result.get("segments") or []
    nodes = _layout_nodes(result, model)
    ex = (result.get("exciters") or {}).get("dofs") or []
    sec.add(Figure(plan_layout_figure(nodes, segs, result.get("sensors") or [], ex, str(result.get("model", ""))),
                   "The structure (grey), the sensors S1, S2, ... (red; an arrow per measuring direction, a square "
                   "for a triaxial sensor) and the exciters F1, ... (blue)."
                   + ("" if model is not None and getattr(model, "nodes", None) or result.get("nodes") else
                      " The model has no coordinates: its nodes are drawn on the x axis in id order.")))
    tab = Table("sensors", ["sensor", "dofs", "node", "x [m]", "y [m]", "z [m]"])
    for k, s in enumerate(result.get("sensors") or []):
        node = s[0].split(":")[0]
        xyz = (result.get("nodes") or {}).get(node) or [None] * 3
        tab.rows.append([Cell(f"S{k + 1}"), Cell(", ".join(s)), Cell(node), *[Cell(num(v)) for v in xyz]])
    sec.add(tab)
    return sec


def _promise_section(result: dict, names) -> Section:
    sec = Section("promise", "What the plan promises")
    sc = result.get("score") or {}
    sec.add(Text(f"Rank {sc.get('ranks', ['–'])[0]} of {len(names)} at the nominal point, smallest rank "
                 f"{sc.get('min_rank')} over {len(sc.get('ranks') or [])} point(s) of the box; design value "
                 f"{num(sc.get('design'), 5)}" + (" (expected information gain with the prior, nats)" if result.get("prior")
                                                 else f" ({'log det F' if result.get('design') == 'd' else '−trace F⁻¹'})")
                 + f"; largest off-diagonal auto-MAC {num(result.get('automac_max'), 3)}."))
    mc = result.get("monte_carlo") or {}
    cols = ["parameter", "nominal", "predicted std", "relative std"] + (["prior relative std"] if result.get("prior") else [])
    cols += ["Monte Carlo std"] if mc else []
    tab = Table("predicted standard deviations (Cramér-Rao)", cols)
    for n in names:
        row = [Cell(n), numcell((result.get("nominal") or {}).get(n), f"/nominal/{n}"),
               numcell((result.get("predicted_std") or {}).get(n), f"/predicted_std/{n}", 4),
               Cell(pct((result.get("relative_std") or {}).get(n), sign=False))]
        if result.get("prior"):
            row.append(Cell(pct(result["prior"].get(n), sign=False)))
        if mc:
            row.append(numcell((mc.get("std") or {}).get(n), f"/monte_carlo/std/{n}", 4))
        tab.rows.append(row)
    sec.add(tab)
    if mc:
        sec.add(Text(f"Monte Carlo: {mc.get('converged')}/{mc.get('runs')} noisy updates converged; rms relative "
                     f"parameter error {pct(mc.get('rms_relative_error'), sign=False)} (predicted "
                     f"{pct(mc.get('predicted_rms_relative_error'), sign=False)})."))
    return sec


def _comparison_section(result: dict) -> Section | None:
    comp = result.get("comparison") or {}
    if not comp:
        return None
    tab = Table("the same number of sensors by the other criteria",
                ["criterion", "sensors", "identifiable", "rank", "mean relative std", "Monte Carlo rms error"])
    for crit, v in comp.items():
        if "error" in v:
            tab.rows.append([Cell(crit), Cell(str(v["error"])), *[Cell("–")] * 4])
            continue
        m = v.get("mean_relative_std")
        mc = v.get("monte_carlo") or {}
        tab.rows.append([Cell(crit), Cell("; ".join(",".join(s) for s in v.get("sensors") or [])),
                         Cell("yes" if v.get("identifiable") else "no", cls="ok" if v.get("identifiable") else "bad"),
                         Cell(str(v.get("rank"))), Cell(pct(m, sign=False) if m is not None and math.isfinite(m) else "∞"),
                         Cell(pct(mc.get("rms_relative_error"), sign=False) if mc else "not run")])
    return Section("comparison", "Against the classical plans").add(tab)


def _exciter_section(result: dict) -> Section | None:
    ex = result.get("exciters")
    if not ex:
        return None
    sc = ex.get("score") or {}
    sec = Section("exciters", "Exciters (FRF test)")
    sec.add(Text(f"Exciter(s) {', '.join(ex.get('dofs') or [])}: every target mode excited: "
                 f"{'yes' if ex.get('excites_all_modes') else 'no'}; FRF Fisher information rank {sc.get('min_rank')} "
                 f"of {len(result.get('parameters') or [])} over the points (noise floor {num(ex.get('noise_floor'), 3)} "
                 f"m/N, {pct(ex.get('std_frf'), sign=False)} of the largest receptance; damping ratio "
                 f"{num(ex.get('damping_ratio'), 3)}). ODP = Π|φ_dr| (zero at a node of a target mode), NODP = min|φ_dr|, "
                 "DPR = Σ φ_dr²/ω_r of the mass-normalised target modes."))
    tab = Table("driving points, best ODP first (the first 12)", ["dof", "ODP", "NODP", "DPR", "chosen"])
    chosen = set(ex.get("dofs") or [])
    for d, v in list((ex.get("driving_points") or {}).items())[:12]:
        tab.rows.append([Cell(d), Cell(num(v.get("odp"), 4)), Cell(num(v.get("nodp"), 4)), Cell(num(v.get("dpr"), 4)),
                         Cell("yes" if d in chosen else "")])
    return sec.add(tab)


def _pretest_section(result: dict) -> Section | None:
    pre = result.get("pretest") or {}
    if not pre:
        return None
    sec = Section("pretest", "Pretest correlation")
    t = pre.get("tam")
    modes = (result.get("target") or {}).get("modes") or []
    if t and "error" in t:
        sec.add(Text(f"TAM ({t.get('method')}): not built - {t['error']}", "warning"))
    elif t:
        sec.add(Text(f"{t.get('method')} TAM on the {len(t.get('dofs') or [])} measured dofs: self-orthogonality of the "
                     f"target modes with the TAM mass, largest off-diagonal {num(t.get('self_max_offdiag'), 3)} (held to "
                     f"0.1 in practice); cross-orthogonality of the TAM's modes with the full model's, smallest "
                     f"diagonal {num(t.get('cross_min_diag'), 3)}, largest off-diagonal {num(t.get('cross_max_offdiag'), 3)}."))
        tab = Table("TAM frequencies against the full model", ["mode", "full [Hz]", "TAM [Hz]", "error", "MAC"])
        for k, m in enumerate(modes):
            tab.rows.append([Cell(str(m)), Cell(num(t["full_frequencies_hz"][k], 6)), Cell(num(t["tam_frequencies_hz"][k], 6)),
                             Cell(pct(t["frequency_error"][k])), Cell(num(t["mac"][k], 4))])
        sec.add(tab)
    ml = pre.get("mass_loading")
    if ml:
        tab = Table(f"mass loading: {ml.get('n_sensors')} sensor(s) of {num(ml.get('sensor_mass'))} kg "
                    f"({num(ml.get('total_mass'))} kg on the translations of their nodes)",
                    ["mode", "unloaded [Hz]", "loaded [Hz]", "shift (re-solved)", "shift (first order)"])
        for k, m in enumerate(modes):
            tab.rows.append([Cell(str(m)), Cell(num(ml["frequencies_hz"][k])), Cell(num(ml["loaded_frequencies_hz"][k])),
                             Cell(pct(ml["relative_shift"][k])), Cell(pct(ml["first_order_relative_shift"][k]))])
        sec.add(tab)
    return sec
