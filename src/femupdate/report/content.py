"""The sections of a report, built from a command's JSON result (and, when given, what
:mod:`.recompute` recomputed from the model and the data).

Every builder reads the documented JSON keys (docs/file-formats.md) and shows what the result
holds; a key that is absent leaves its table or figure out.  Numbers shown from the JSON carry
their JSON path (:class:`~.document.Cell` ``key``).
"""

from __future__ import annotations

import json
import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from .._errors import InputError
from .document import Cell, Details, Document, Figure, Section, Table, Text, num, numcell, pct, unit_label

#: the kinds of result a report is made of, and the command that writes each
KINDS = {
    "direct": "femupdate direct (direct updating from complete data)",
    "update": "femupdate update (iterative updating)",
    "frf-update": "femupdate frf-update (FRF updating)",
    "update-multi": "femupdate update-multi (several test configurations)",
    "damage": "femupdate damage (damage localisation)",
    "uniqueness": "femupdate uniqueness (uniqueness study)",
    "paper": "femupdate paper (the reference paper reproduced)",
}
#: mode shapes drawn at most (the report says when there are more)
MAX_SHAPES = 8
#: units of the quantities femupdate fixes (docs/file-formats.md, "Units")
HZ, PCT, NONE = "Hz", "%", "–"


def _figures():
    """The report's figure functions (matplotlib, imported on first use)."""
    from ..plot import report as figs

    return figs


def _units(result: dict) -> dict:
    return {k: v for k, v in (result.get("parameter_units") or {}).items()}


def cost_unit(result: dict) -> str:
    """The unit of the cost ½‖r‖²: the squared response unit (m²) for linear FRF residuals that are
    not divided by stated standard deviations, else dimensionless (relative residuals, or
    residuals divided by their standard deviations or RMS)."""
    absolute = bool((result.get("diagnostics") or {}).get("absolute"))
    return "m²" if result.get("residual") == "linear" and not result.get("blocks") and not absolute else NONE


def maccell(mac, key: str | None) -> Cell:
    """A MAC to four decimals (``0.9999``, not rounded up to ``1``)."""
    return Cell(f"{float(mac):.4f}", key, float(mac)) if _fin(mac) else Cell("–")


def _fin(v) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(float(v))


# ====================================================================================== common parts
def _summary(doc: Document, result: dict, model, data, extra: Sequence[tuple[str, str]] = (),
             data_units: bool = True) -> Section:
    """Model and data summary."""
    sec = Section("summary", "Model and data")
    rows: list[list[Cell]] = [[Cell("model"), Cell(str(result.get("model", model.name if model is not None else "–")))]]
    if model is not None:
        kinds = {p.unit for p in model.parameters}
        rows += [[Cell("degrees of freedom"), Cell(str(model.n_dofs))],
                 [Cell("nodes with coordinates"), Cell(str(len(model.nodes)) if model.nodes else "none (lumped model)")],
                 [Cell("parameters"), Cell(f"{len(model.parameters)} ({sum(not p.fixed for p in model.parameters)} "
                                           f"free); units: {', '.join(sorted(u for u in kinds if u)) or 'not stated'}")]]
    if data is not None:
        if data.modes:
            shaped = [m for m in data.modes if len(m.dofs)]
            dofs = sorted({d for m in data.modes for d in m.dofs})
            rows.append([Cell("test modes"), Cell(f"{len(data.modes)} ({len(shaped)} with shapes, measured at "
                                                  f"{len(dofs)} dofs); {', '.join(num(f, 5) for f in data.frequencies_hz)} Hz")])
        if data.frf is not None:
            f = data.frf
            rows.append([Cell("FRFs"), Cell(f"{f.omega.size} lines, {num(f.omega.min(), 4)}–{num(f.omega.max(), 4)} rad/s; "
                                            f"responses at {len(f.dofs)} dofs; force at {', '.join(f.force)}"
                                            + (f"; {data.n_frf_sets} excitation sets" if data.n_frf_sets > 1 else ""))])
        if data.static:
            rows.append([Cell("static load cases"), Cell(str(len(data.static)))])
    for label, text in extra:
        rows.append([Cell(label), Cell(text)])
    units = result.get("units") if data_units else None
    if units:
        rows.append([Cell("units stated by the test data"), Cell(", ".join(f"{k}: {v}" for k, v in units.items()))])
    rows.append([Cell("unit system"), Cell("SI (N, m, kg, s): femupdate converts no units in model and JSON files "
                                           "(universal files are converted to SI when read)")])
    sec.add(Table("", ["item", "value"], rows))
    return sec


def _notes_section(doc: Document) -> Section:
    sec = Section("notes", "Notes and warnings")
    if not doc.warnings and not doc.notes:
        sec.add(Text("The run reported no notes and no warnings."))
    for w in doc.warnings:
        sec.add(Text(w, "warning"))
    for n in doc.notes:
        sec.add(Text(n, "note"))
    return sec


def _collect_notes(doc: Document, result: dict) -> None:
    for f in result.get("flags") or []:
        doc.warnings.append(f["message"])
    for n in result.get("notes") or []:
        doc.notes.append(str(n))


def _flag_text(name: str, result: dict) -> tuple[str, str]:
    """(flag text, css class) of a parameter: on a bound, outside, not positive; or ''."""
    out = []
    for f in result.get("flags") or []:
        if f.get("parameter") == name:
            out.append({"on_bound": "on a bound", "outside_bounds": "OUTSIDE its bounds",
                        "not_positive": "not > 0"}.get(f.get("kind"), f.get("kind", "")))
    at = ((result.get("diagnostics") or {}).get("at_bounds") or {}).get(name)
    if at and "on a bound" not in out:
        out.append(f"on the {at} bound")
    return "; ".join(out), ("flag" if out else "")


def _parameter_table(result: dict, names, start: dict | None, std: dict | None, caption: str,
                     std_label: str = "std") -> Table:
    """Start, updated, change, bounds, standard deviation and flags of each parameter."""
    units = _units(result)
    bounds = result.get("bounds") or {}
    params = result.get("parameters") or {}
    reasons = ((result.get("diagnostics") or {}).get("poorly_determined_reasons") or {})
    t = Table(caption, ["parameter", "unit", "start", "updated", "change [%]", "lower bound", "upper bound",
                        f"{std_label} [parameter unit]", f"{std_label} [% of value]", "flag"])
    for n in names:
        v = params.get(n)
        p0 = (start or {}).get(n)
        lo, hi = (bounds.get(n) or [None, None])
        sd = (std or {}).get(n)
        flag, cls = _flag_text(n, result)
        if n in reasons:
            flag = "; ".join(x for x in (flag, f"poorly determined: {reasons[n]}") if x)
            cls = "flag"
        t.rows.append([
            Cell(n), Cell(units.get(n) or "not stated"),
            numcell(p0, f"/start/{n}" if "start" in result else None),
            numcell(v, f"/parameters/{n}", cls=cls),
            Cell(pct((v - p0) / p0, 3) if _fin(v) and _fin(p0) and p0 else "–"),
            Cell(num(lo) if lo is not None else "none (−∞)"), Cell(num(hi) if hi is not None else "none (∞)"),
            numcell(sd, None), Cell(pct(sd / abs(v), 3, sign=False) if _fin(sd) and _fin(v) and v else "–"),
            Cell(flag or "–", cls=cls)])
    return t


def _pairs_table(caption: str, pairs, test_hz, model_hz, key: str | None) -> Table:
    """Paired modes: frequencies, error and MAC (``key``: the JSON place of the frequencies)."""
    t = Table(caption, ["test mode", "model mode", f"f test [{HZ}]", f"f model [{HZ}]", f"error [{PCT}]", f"MAC [{NONE}]"])
    for i, (k, j, mac) in enumerate(pairs):
        ft, fm = test_hz[i], model_hz[i]
        t.rows.append([Cell(str(k + 1)), Cell(str(j + 1)),
                       numcell(ft, f"/{key}/test/{i}" if key else None), numcell(fm, f"/{key}/model/{i}" if key else None),
                       Cell(pct((fm - ft) / ft) if _fin(ft) and _fin(fm) and ft else "–"),
                       maccell(mac, f"/pairs/{i}/2" if key else None)])
    return t


def _corr_rows(corr):
    """(pairs, test Hz per pair, model Hz per pair) of a :class:`~femupdate.correlation.Correlation`."""
    pairs = [(int(i), int(j), float(m)) for i, j, m in corr.pairs]
    return pairs, [float(corr.test_frequencies_hz[i]) for i, _, _ in pairs], \
        [float(corr.model_frequencies_hz[j]) for _, j, _ in pairs]


def _correlation_section(result: dict, rec, json_pairs: bool = True) -> Section | None:
    """Paired modes before and after, the MAC matrices and the frequency comparison."""
    figs = _figures()
    sec = Section("correlation", "Correlation with the test")
    before = rec.before.correlation if rec is not None and rec.before is not None else None
    after = rec.after.correlation if rec is not None and rec.after is not None else None
    fr = result.get("frequencies_hz") or {}
    pairs = result.get("pairs") or []
    shown = False
    if before is not None and before.pairs:
        p, ft, fm = _corr_rows(before)
        sec.add(_pairs_table("before: the model as given", p, ft, fm, None))
        shown = True
    if json_pairs and pairs and fr.get("test") and fr.get("model"):
        sec.add(_pairs_table("after: the updated model (from the result file)", pairs, fr["test"], fr["model"],
                             "frequencies_hz"))
        shown = True
    elif after is not None and after.pairs:
        p, ft, fm = _corr_rows(after)
        sec.add(_pairs_table("after: the updated model", p, ft, fm, None))
        shown = True
    if not shown:
        return None
    # frequency comparison, test modes in order
    if pairs and fr.get("test") and fr.get("model"):
        test_hz = list(fr["test"])
        after_hz = list(fr["model"])
        before_hz = None
        if before is not None:
            bmap = {i: float(before.model_frequencies_hz[j]) for i, j, _ in before.pairs}
            before_hz = [bmap.get(int(k)) for k, _, _ in pairs]
        sec.add(Figure(figs.frequency_figure(test_hz, before_hz, after_hz),
                       "Relative frequency error of each paired test mode, before (grey) and after (blue) the update."))
    elif after is not None and after.pairs:
        p, ft, fm = _corr_rows(after)
        bhz = None if before is None else {i: float(before.model_frequencies_hz[j]) for i, j, _ in before.pairs}
        sec.add(Figure(figs.frequency_figure(ft, None if bhz is None else [bhz.get(k) for k, _, _ in p], fm),
                       "Relative frequency error of each paired test mode."))
    for st, what in ((before, "before"), (after, "after")):
        if st is not None and st.mac.size and np.isfinite(st.mac).any():
            n_test = st.mac.shape[0]
            shown = min(st.mac.shape[1], max([2 * n_test, *(j + 3 for _, j, _ in st.pairs)]))
            sec.add(Figure(figs.mac_figure(st.mac[:, :shown], f"MAC {what}"),
                           f"MAC of every test mode (rows) with the lowest {shown} model modes (columns), {what} "
                           "the update."))
    if rec is None:
        sec.add(Text("The MAC matrices and the correlation before the update need the model and the test data "
                     "(femupdate report RESULT.json --model MODEL --data DATA).", "note"))
    return sec


def _shapes_section(model, data, rec, segments, pairs) -> Section | None:
    """Test and model shapes on the model's geometry, per paired mode (after the update)."""
    if model is None or rec is None or rec.after is None or rec.after.modes is None:
        return None
    from ..plot.shapes import NO_GEOMETRY, shape_geometry

    figs = _figures()
    modes = rec.after.modes
    sec = Section("shapes", "Mode shapes on the model")
    geom = shape_geometry(model, segments)
    if geom is None:
        sec.add(Text(f"The model has no node coordinates, so its shapes have no geometry to be drawn on: {NO_GEOMETRY}; "
                     "measured shapes as red circles, scaled to the model shape by least squares.", "note"))
    else:
        sec.add(Text("Deformed (blue) over undeformed (grey, dashed) wireframe of the updated model; measured shapes "
                     "as red circles at the nodes they displace (scaled to the model shape by least squares, "
                     "unmeasured directions at zero). Beams and frames bend with their end rotations; rods and "
                     "springs are straight."))
    items: list[tuple[Any, int, Any]]
    if pairs:
        items = [(int(k), int(j), m) for k, j, m in pairs]
    else:
        items = [(None, j, None) for j in range(min(len(modes.eigenvalues), 4))]
    beyond = [j + 1 for _, j, _ in items if j >= modes.shapes.shape[1]]
    if beyond:  # a model mode the recomputation did not reach
        sec.add(Text(f"Model mode(s) {', '.join(map(str, beyond))} of the pairs are beyond the {modes.shapes.shape[1]} "
                     "modes recomputed and are not drawn.", "note"))
        items = [it for it in items if it[1] < modes.shapes.shape[1]]
    for k, j, mac in items[:MAX_SHAPES]:
        test = None
        f_t = None
        if k is not None and data is not None and k < len(data.modes):
            tm = data.modes[k]
            f_t = tm.frequency_hz
            if len(tm.dofs):
                test = dict(zip(tm.dofs, np.asarray(tm.shape)))
        f_m = float(modes.frequencies_hz[j])
        title = (f"test mode {k + 1} ↔ model mode {j + 1}: " + (f"{num(f_t, 5)} / " if f_t is not None else "")
                 + f"{num(f_m, 5)} Hz" + (f", MAC {mac:.4f}" if mac is not None and _fin(mac) else "")) \
            if k is not None else f"model mode {j + 1}: {num(f_m, 5)} Hz"
        sec.add(Figure(figs.mode_shape_figure(model, modes.shapes[:, j], test, title, segments)))
    if len(items) > MAX_SHAPES:
        sec.add(Text(f"The first {MAX_SHAPES} of {len(items)} paired modes are drawn.", "note"))
    return sec


def _damping_section(result: dict) -> Section | None:
    """The measured modal damping ratios against the model's (the result's ``damping_ratio``:
    ``update`` with damped test modes or ``--damping``) and the Rayleigh damping fitted to them."""
    dr = result.get("damping_ratio")
    if not isinstance(dr, dict) or not dr.get("test"):
        return None
    test, std, model = dr.get("test") or [], dr.get("std") or [], dr.get("model") or []
    sec = Section("damping", "Modal damping")
    t = Table("damping ratio ζ of each test mode (fraction of critical): measured, its standard deviation, the "
              "model's modal damping at its paired mode, and the difference",
              ["test mode", f"ζ test [{NONE}]", f"std [{NONE}]", f"ζ model [{NONE}]", f"model − test [{NONE}]"])
    for i, zt in enumerate(test):
        sd = std[i] if i < len(std) else None
        zm = model[i] if i < len(model) else None
        t.rows.append([Cell(str(i + 1)), numcell(zt, f"/damping_ratio/test/{i}", 4),
                       numcell(sd, f"/damping_ratio/std/{i}", 3), numcell(zm, f"/damping_ratio/model/{i}", 4),
                       Cell(num(zm - zt, 3) if _fin(zm) and _fin(zt) else "–")])
    sec.add(t)
    md = dr.get("model_damping")
    if isinstance(md, dict):
        sec.add(Text(f"The model's damping (--damping): α = {num(md.get('alpha'))} 1/s, β = {num(md.get('beta'))} s, "
                     f"η = {num(md.get('eta'))} (modal ratio α/2ω + βω/2 + η/2)."))
    fit = dr.get("rayleigh_fit")
    if isinstance(fit, dict):
        sec.add(Text(f"Rayleigh damping fitted to the {fit.get('n_modes')} measured ratios: α = {num(fit.get('alpha'))} "
                     f"1/s, β = {num(fit.get('beta'))} s (rms misfit {num(fit.get('rms_error'), 3)}); --damping fit "
                     "uses it for FRFs. Damping ratios are compared, not updated: the model has no damping "
                     "parameters."))
    return sec


def _convergence_section(result: dict) -> Section | None:
    hist = result.get("history") or []
    if not hist:
        return None
    figs = _figures()
    names = list(result.get("updated") or (hist[0].get("parameters") or {}).keys())
    sec = Section("convergence", "Convergence")
    facts = [("iterations", result.get("iterations")), ("residual evaluations", result.get("nfev")),
             (f"final cost ½‖r‖² [{cost_unit(result)}]", result.get("cost"))]
    t = Table("", ["quantity", "value"])
    keys = ["/iterations", "/nfev", "/cost"]
    for (label, v), key in zip(facts, keys):
        if v is not None:
            t.rows.append([Cell(label), numcell(v, key)])
    if result.get("message"):
        t.rows.append([Cell("optimiser's message"), Cell(str(result["message"]))])
    sec.add(t, Figure(figs.convergence_figure(hist, names, cost_unit(result)),
                      f"Cost (weighted squared residual, [{cost_unit(result)}]) and each updated parameter relative "
                      "to its start, per iteration.", wide=True))
    return sec


def _identifiability_section(result: dict) -> Section | None:
    d = result.get("diagnostics")
    if not d:
        return None
    figs = _figures()
    sec = Section("identifiability", "Identifiability")
    sv = d.get("singular_values") or []
    t = Table("", ["quantity", "value"])
    t.rows.append([Cell("condition number of the normalised sensitivity matrix [–]"),
                   numcell(d.get("condition_number"), "/diagnostics/condition_number", 4)
                   if d.get("condition_number") is not None else Cell("∞ (singular)")])
    if d.get("rank") is not None:
        t.rows.append([Cell("rank / free parameters"), Cell(f"{d['rank']} / {len(d.get('free') or [])}")])
    if d.get("n_residuals") is not None:
        t.rows.append([Cell("residuals"), Cell(str(d["n_residuals"]))])
    t.rows.append([Cell("covariance"), Cell("from the stated measurement standard deviations" if d.get("absolute")
                                            else "scaled by the residual variance (no standard deviations stated)")])
    at = d.get("at_bounds") or {}
    t.rows.append([Cell("parameters on a bound"), Cell(", ".join(f"{n} ({s})" for n, s in at.items()) or "none",
                                                       cls="flag" if at else "")])
    sec.add(t)
    if sv:
        sec.add(Figure(figs.singular_values_figure(sv),
                       "Singular values of the sensitivity matrix with columns scaled by the parameter values "
                       "(∂r/∂(p/|p|)): a small one means a combination of parameters the data hardly determine."))
    reasons = d.get("poorly_determined_reasons") or {}
    if reasons:
        pt = Table("parameters the data cannot move", ["parameter", "reason"])
        for n, why in reasons.items():
            pt.rows.append([Cell(n, cls="flag"), Cell(why)])
        sec.add(pt)
    combos = _combinations(result)
    if combos is not None:
        sec.add(combos)
    return sec


def _combinations(result: dict) -> Table | None:
    """The least determined parameter combinations: eigenvectors of the relative covariance
    C_ij / (p_i p_j) (the right singular vectors of the normalised sensitivity matrix), largest
    relative standard deviation first."""
    d = result.get("diagnostics") or {}
    names = list(result.get("updated") or [])
    cov = d.get("covariance")
    free = list(d.get("free") or names)
    params = result.get("parameters") or {}
    if not cov or len(names) < 2:
        return None
    C = np.array([[np.nan if v is None else v for v in row] for row in cov], float)
    idx = [names.index(n) for n in free if n in names]
    if len(idx) < 2 or C.shape != (len(names), len(names)):
        return None
    C = C[np.ix_(idx, idx)]
    p = np.array([params[names[i]] for i in idx], float)
    if not (np.all(np.isfinite(C)) and np.all(p != 0)):
        return None
    R = C / np.outer(p, p)
    w, V = np.linalg.eigh((R + R.T) / 2)
    order = np.argsort(w)[::-1]
    t = Table("parameter combinations, least determined first (eigenvectors of the relative covariance)",
              ["relative std of the combination [%]", "combination of relative changes Δp/p [–]"])
    for k in order[:min(3, len(order))]:
        v = V[:, k] / V[int(np.argmax(np.abs(V[:, k]))), k]  # the largest coefficient +1
        terms = " ".join(f"{'+' if c >= 0 else '−'} {abs(c):.2f} Δ{free[i]}/{free[i]}"
                         for i, c in sorted(enumerate(v), key=lambda x: -abs(x[1])) if abs(c) >= 0.05)
        t.rows.append([Cell(pct(math.sqrt(max(w[k], 0.0)), 3, sign=False)), Cell(terms.lstrip("+ "))])
    return t


def _starts_section(result: dict) -> Section | None:
    st = result.get("starts") or {}
    sols = st.get("solutions") or []
    if (st.get("total") or 1) <= 1:
        return None
    figs = _figures()
    units = _units(result)
    names = list(result.get("updated") or (sols[0]["parameters"].keys() if sols else []))
    sec = Section("starts", "Multi-start: distinct solutions")
    fitting = sum(1 for s in sols if s.get("fits", True))
    sec.add(Text(f"{st.get('converged', 0)} of {st.get('total')} starts converged (seed {st.get('seed', '–')}); "
                 f"{len(sols)} distinct solution(s), {fitting} of which fit the data as well as the best "
                 "(a likelihood-ratio test at 95 %)."
                 + (" The data do not determine the parameters uniquely." if fitting > 1 else ""),
                 "warning" if fitting > 1 else ""))
    t = Table("", ["solution", *[unit_label(n, units.get(n)) for n in names], f"cost ½‖r‖² [{cost_unit(result)}]",
                   "starts [–]", "fits the data"])
    for i, s in enumerate(sols):
        t.rows.append([Cell(str(i + 1)), *[numcell(s["parameters"].get(n), f"/starts/solutions/{i}/parameters/{n}")
                                           for n in names],
                       numcell(s.get("cost"), f"/starts/solutions/{i}/cost", 3), numcell(s.get("count"), f"/starts/solutions/{i}/count"),
                       Cell("yes" if s.get("fits", True) else "no (local minimum)", cls="ok" if s.get("fits", True) else "bad")])
    sec.add(t)
    if len(names) >= 2 and sols:
        sec.add(Figure(figs.solutions_figure(sols, names, units),
                       f"The distinct solutions over {names[0]} and {names[1]}; marker area ∝ number of starts."))
    failures = st.get("failures") or {}
    if failures:
        ft = Table("starts without a solution", ["reason", "starts"])
        for why, count in failures.items():
            ft.rows.append([Cell(why), Cell(str(count))])
        sec.add(ft)
    return sec


def _frf_section(result: dict, rec) -> Section | None:
    figs = _figures()
    omega = result.get("omega_rad_s")
    frac = result.get("frac") or {}
    if omega is None and (rec is None or rec.frf is None):
        return None
    sec = Section("frf", "FRFs")
    t = Table("", ["quantity", "value"])
    if omega:
        t.rows.append([Cell("spectral lines used [rad/s]"), Cell(", ".join(num(w, 4) for w in omega))])
    if result.get("residual"):
        t.rows.append([Cell("residual form"), Cell(str(result["residual"]))])
    for d, v in frac.items():
        t.rows.append([Cell(f"FRAC at {d} [–]"), numcell(v, f"/frac/{d}", 6)])
    nat = result.get("natural_frequencies_hz")
    if nat:
        t.rows.append([Cell(f"natural frequencies of the updated model [{HZ}]"), Cell(", ".join(num(f, 6) for f in nat))])
    sec.add(t)
    for s in result.get("skipped") or []:
        sec.add(Text(f"line {s.get('line')} ({num(s.get('omega_rad_s'), 5)} rad/s) skipped: {s.get('reason')}", "note"))
    if rec is not None and rec.frf is not None:
        f = rec.frf
        amp = ", ".join(f"{d} = {num(a.real if isinstance(a, complex) else a, 4)} N" for d, a in f["force"].items())
        sec.add(Figure(figs.frf_figure(f["omega"], f["dofs"], f["measured"], f["model_omega"], f["before"], f["after"],
                                       unit="m"),
                       f"Response magnitude to the measured force ({amp}): test (circles), the model before (dashed) "
                       "and after (solid) the update; the model undamped unless the run stated damping.",
                       wide=len(f["dofs"]) > 1))
    if rec is not None and rec.surface is not None:
        s = rec.surface
        after: Any = rec.after.values if rec.after is not None else result.get("parameters")
        sec.add(Figure(figs.surface_figure(s, (after[s.names[0]], after[s.names[1]])),
                       f"The FRF residual over {s.names[0]} and {s.names[1]} (±50 % of the updated values, within "
                       "the bounds; other parameters at their updated values); circles: grid local minima."))
    elif rec is None:
        sec.add(Text("FRF overlays and the residual surface need the model and the test data.", "note"))
    return sec


# ====================================================================================== per kind
def _verdict_update(result: dict) -> Cell:
    ok = bool(result.get("success"))
    fl = result.get("flags") or []
    text = ("converged" if ok else "NOT converged") + (f"; {len(fl)} flag(s)" if fl else "")
    return Cell(text, cls="ok" if ok and not fl else "bad")


def build_update(doc: Document, result: dict, model, data, rec, segments, kind: str) -> None:
    """``update`` and ``frf-update``."""
    _collect_notes(doc, result)
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
    doc.sections.append(_summary(doc, result, model, data, extra))
    if names:
        std = (result.get("diagnostics") or {}).get("std")
        doc.sections.append(Section("parameters", "Parameters").add(
            _parameter_table(result, names, result.get("start"), std, "start and updated values")))
    for sec in (_correlation_section(result, rec), _damping_section(result),
                _shapes_section(model, data, rec, segments, result.get("pairs")),
                _frf_section(result, rec) if kind == "frf-update" or result.get("omega_rad_s") else None,
                _convergence_section(result), _identifiability_section(result), _starts_section(result)):
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
    _collect_notes(doc, result)
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
    doc.sections.append(_summary(doc, result, model, data, extra))
    se = result.get("standard_error") or {}
    sec = Section("parameters", "Parameters")
    sec.add(_parameter_table(result, unknowns, result.get("start"), se, "identified values", "std. error"))
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
    for s in (_correlation_section(result, rec), _shapes_section(model, data, rec, segments, result.get("pairs"))):
        if s is not None:
            doc.sections.append(s)


def build_multi(doc: Document, result: dict, model, data, rec, segments, kind: str) -> None:
    _collect_notes(doc, result)
    names = list(result.get("updated") or [])
    doc.verdict = _verdict_update(result)
    cfgs = result.get("configurations") or []
    doc.facts += [("configurations", Cell(str(len(cfgs)))), ("method", Cell(str(result.get("method")))),
                  ("cost ½‖r‖² [–]", numcell(result.get("cost"), "/cost", 4))]
    doc.sections.append(_summary(doc, result, model, None, [("configurations", "; ".join(
        f"{c.get('name')}: {c.get('modification')} ({c.get('n_data')} data)" for c in cfgs))]))
    se = result.get("standard_error") or {}
    doc.sections.append(Section("parameters", "Parameters").add(
        _parameter_table(result, names, (result.get("history") or [{}])[0].get("parameters"), se,
                         "identified values (start: the first iterate)", "std. error")))
    sec = Section("configurations", "Configurations")
    figs = _figures()
    for ci, c in enumerate(cfgs):
        fr = c.get("frequencies_hz") or {}
        if c.get("pairs") and fr.get("test"):
            t = _pairs_table(f"{c.get('name')} ({c.get('modification')})", c["pairs"], fr["test"], fr["model"], None)
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
    for s in (_convergence_section(result), _identifiability_section(result)):
        if s is not None:
            doc.sections.append(s)


def build_damage(doc: Document, result: dict, model, data, rec, segments, kind: str) -> None:
    _collect_notes(doc, result)
    status = str(result.get("status") or ("localised" if result.get("localised") else "not localised"))
    doc.verdict = Cell(status, cls={"confirmed": "ok"}.get(status, "bad"))
    located = list(result.get("located") or [])
    changes = result.get("changes") or {}
    doc.facts += [("unknowns", Cell(f"{len(changes)} ({result.get('unknowns', 'parameters')})")),
                  ("located", Cell(", ".join(located) or "none"))]
    for d in result.get("doubts") or []:
        doc.warnings.append(f"doubtful: {d}")
    if result.get("reason"):
        doc.warnings.append(f"not localised: {result['reason']}")
    doc.sections.append(_summary(doc, result, model, data))
    units = _units(result)
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
    rate = conf.get("false_positive_rate")
    if rate:
        sec.add(Text(f"Benchmark for comparable data: a healthy unknown was reported damaged in {rate.get('false_positives')} "
                     f"of {rate.get('scenarios')} scenarios ({pct(rate.get('false_positive_rate'), 2, sign=False)}); every "
                     f"damaged one found in {pct(rate.get('detection_rate'), 3, sign=False)} (noise "
                     f"{pct(rate.get('noise'), 2, sign=False)}; {rate.get('date', '')}).", "note"))
    names = list(changes)
    if names:
        sec.add(Figure(_figures().damage_figure(names, changes, set(located), conf.get("standard_error")),
                       "Identified relative change of every unknown; located ones in red with their standard error.",
                       wide=len(names) > 16))
    members = _members(model, names) if model is not None and model.nodes else {}
    if any(members.values()):
        sec.add(Figure(_figures().damage_map_figure(model, members, changes, set(located), segments),
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
    shapes = _shapes_section(model, data, rec, segments, None if rec is None or rec.after is None or
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


def build_uniqueness(doc: Document, result: dict, model, data, rec, segments, kind: str) -> None:
    _collect_notes(doc, result)
    cases = result.get("cases") or []
    units = _units(result)
    names = list(result.get("parameters") or [])
    verdicts = [c.get("verdict") for c in cases]
    doc.verdict = Cell(f"{verdicts.count('unique')} of {len(cases)} cases unique", cls="ok")
    doc.facts += [("unknowns", Cell(", ".join(names))), ("starts per case", numcell(result.get("starts"), "/starts")),
                  ("cases", Cell(str(len(cases))))]
    truth = result.get("truth") or {}
    rows = [(f"truth {unit_label(n, units.get(n))}", num(truth.get(n))) for n in names]
    doc.sections.append(_summary(doc, result, model, None, rows + [("route", str(result.get("route", "")))],
                                 data_units=False))  # a study's "units" are its work units
    sec = Section("cases", "Cases")
    if cases:
        sec.add(Figure(_figures().uniqueness_figure(cases, f"{result.get('model', '')}: {result.get('starts')} starts per case"),
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


# ---------------------------------------------------------------------------------- paper
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
                       if hit and _fin(hit[1]) else Cell(_short(hit[1]) if hit else "–"))
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


BUILDERS = {"direct": build_direct, "update": build_update, "frf-update": build_update, "update-multi": build_multi,
            "damage": build_damage, "uniqueness": build_uniqueness, "paper": build_paper}
