"""The parts several kinds of report share, built from a command's JSON result (and, when
given, what :mod:`.recompute` recomputed from the model and the data): the model and data summary,
the notes, the parameter and pair tables, the correlation with the test, the mode shapes and the
modal damping.  The kinds' own builders are in :mod:`femupdate.report.update`,
:mod:`femupdate.report.damage`, :mod:`femupdate.report.uniqueness`, :mod:`femupdate.report.paper`
and :mod:`femupdate.report.posterior` (:mod:`femupdate.report.content` lists them).

Every builder reads the documented JSON keys (docs/file-formats.md) and shows what the result
holds; a key that is absent leaves its table or figure out.  Numbers shown from the JSON carry
their JSON path (:class:`~.document.Cell` ``key``).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from .document import Cell, Document, Figure, Section, Table, Text, num, numcell, pct

#: mode shapes drawn at most (the report says when there are more)
MAX_SHAPES = 8
#: units of the quantities femupdate fixes (docs/file-formats.md, "Units")
HZ, PCT, NONE = "Hz", "%", "–"


def figures():
    """The report's figure functions (matplotlib, imported on first use)."""
    from ..plot import report as figs

    return figs


def units_of(result: dict) -> dict:
    return {k: v for k, v in (result.get("parameter_units") or {}).items()}


def cost_unit(result: dict) -> str:
    """The unit of the cost ½‖r‖²: the squared response unit (m²) for linear FRF residuals that are
    not divided by stated standard deviations, else dimensionless (relative residuals, or
    residuals divided by their standard deviations or RMS)."""
    absolute = bool((result.get("diagnostics") or {}).get("absolute"))
    return "m²" if result.get("residual") == "linear" and not result.get("blocks") and not absolute else NONE


def maccell(mac, key: str | None) -> Cell:
    """A MAC to four decimals (``0.9999``, not rounded up to ``1``)."""
    return Cell(f"{float(mac):.4f}", key, float(mac)) if fin(mac) else Cell("–")


def fin(v) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(float(v))


# ====================================================================================== common parts
def summary_section(doc: Document, result: dict, model, data, extra: Sequence[tuple[str, str]] = (),
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


def notes_section(doc: Document) -> Section:
    sec = Section("notes", "Notes and warnings")
    if not doc.warnings and not doc.notes:
        sec.add(Text("The run reported no notes and no warnings."))
    for w in doc.warnings:
        sec.add(Text(w, "warning"))
    for n in doc.notes:
        sec.add(Text(n, "note"))
    return sec


def collect_notes(doc: Document, result: dict) -> None:
    for f in result.get("flags") or []:
        doc.warnings.append(f["message"])
    for n in result.get("notes") or []:
        doc.notes.append(str(n))


def flag_text(name: str, result: dict) -> tuple[str, str]:
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


def parameter_table(result: dict, names, start: dict | None, std: dict | None, caption: str,
                     std_label: str = "std") -> Table:
    """Start, updated, change, bounds, standard deviation and flags of each parameter."""
    units = units_of(result)
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
        flag, cls = flag_text(n, result)
        if n in reasons:
            flag = "; ".join(x for x in (flag, f"poorly determined: {reasons[n]}") if x)
            cls = "flag"
        t.rows.append([
            Cell(n), Cell(units.get(n) or "not stated"),
            numcell(p0, f"/start/{n}" if "start" in result else None),
            numcell(v, f"/parameters/{n}", cls=cls),
            Cell(pct((v - p0) / p0, 3) if fin(v) and fin(p0) and p0 else "–"),
            Cell(num(lo) if lo is not None else "none (−∞)"), Cell(num(hi) if hi is not None else "none (∞)"),
            numcell(sd, None), Cell(pct(sd / abs(v), 3, sign=False) if fin(sd) and fin(v) and v else "–"),
            Cell(flag or "–", cls=cls)])
    return t


def pairs_table(caption: str, pairs, test_hz, model_hz, key: str | None) -> Table:
    """Paired modes: frequencies, error and MAC (``key``: the JSON place of the frequencies)."""
    t = Table(caption, ["test mode", "model mode", f"f test [{HZ}]", f"f model [{HZ}]", f"error [{PCT}]", f"MAC [{NONE}]"])
    for i, (k, j, mac) in enumerate(pairs):
        ft, fm = test_hz[i], model_hz[i]
        t.rows.append([Cell(str(k + 1)), Cell(str(j + 1)),
                       numcell(ft, f"/{key}/test/{i}" if key else None), numcell(fm, f"/{key}/model/{i}" if key else None),
                       Cell(pct((fm - ft) / ft) if fin(ft) and fin(fm) and ft else "–"),
                       maccell(mac, f"/pairs/{i}/2" if key else None)])
    return t


def corr_rows(corr):
    """(pairs, test Hz per pair, model Hz per pair) of a :class:`~femupdate.correlation.Correlation`."""
    pairs = [(int(i), int(j), float(m)) for i, j, m in corr.pairs]
    return pairs, [float(corr.test_frequencies_hz[i]) for i, _, _ in pairs], \
        [float(corr.model_frequencies_hz[j]) for _, j, _ in pairs]


def correlation_section(result: dict, rec, json_pairs: bool = True) -> Section | None:
    """Paired modes before and after, the MAC matrices and the frequency comparison."""
    figs = figures()
    sec = Section("correlation", "Correlation with the test")
    before = rec.before.correlation if rec is not None and rec.before is not None else None
    after = rec.after.correlation if rec is not None and rec.after is not None else None
    fr = result.get("frequencies_hz") or {}
    pairs = result.get("pairs") or []
    shown = False
    if before is not None and before.pairs:
        p, ft, fm = corr_rows(before)
        sec.add(pairs_table("before: the model as given", p, ft, fm, None))
        shown = True
    if json_pairs and pairs and fr.get("test") and fr.get("model"):
        sec.add(pairs_table("after: the updated model (from the result file)", pairs, fr["test"], fr["model"],
                             "frequencies_hz"))
        shown = True
    elif after is not None and after.pairs:
        p, ft, fm = corr_rows(after)
        sec.add(pairs_table("after: the updated model", p, ft, fm, None))
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
        p, ft, fm = corr_rows(after)
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


def shapes_section(model, data, rec, segments, pairs) -> Section | None:
    """Test and model shapes on the model's geometry, per paired mode (after the update)."""
    if model is None or rec is None or rec.after is None or rec.after.modes is None:
        return None
    from ..plot.shapes import NO_GEOMETRY, shape_geometry

    figs = figures()
    modes = rec.after.modes
    sec = Section("shapes", "Mode shapes on the model")
    tp = rec.test_points  # test points placed on a mesh: drawn on the mesh's own dofs, u = T q
    drawn = model if tp is None or tp.base is None else tp.base
    geom = shape_geometry(drawn, segments)
    if geom is None:
        sec.add(Text(f"The model has no node coordinates, so its shapes have no geometry to be drawn on: {NO_GEOMETRY}; "
                     "measured shapes as red circles, scaled to the model shape by least squares.", "note"))
    else:
        sec.add(Text("Deformed (blue) over undeformed (grey, dashed) wireframe of the updated model; measured shapes "
                     "as red circles at the nodes they displace (scaled to the model shape by least squares, "
                     "unmeasured directions at zero). Beams and frames bend with their end rotations; rods and "
                     "springs are straight."))
    on_mesh = set(drawn.dofs)
    if drawn is not model:
        sec.add(Text("Test points were placed on the mesh: the model's shapes are drawn on every mesh dof (u = T q); "
                     "measured values at test points inside elements are not drawn here (the test points' section "
                     "shows where they lie).", "note"))
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
                if drawn is not model:  # a test point inside an element is no node of the mesh
                    test = {d: v for d, v in test.items() if d in on_mesh} or None
        f_m = float(modes.frequencies_hz[j])
        title = (f"test mode {k + 1} ↔ model mode {j + 1}: " + (f"{num(f_t, 5)} / " if f_t is not None else "")
                 + f"{num(f_m, 5)} Hz" + (f", MAC {mac:.4f}" if mac is not None and fin(mac) else "")) \
            if k is not None else f"model mode {j + 1}: {num(f_m, 5)} Hz"
        shape = modes.shapes[:, j] if drawn is model else tp.mesh_shapes(modes.shapes[:, j])
        sec.add(Figure(figs.mode_shape_figure(drawn, shape, test, title, segments)))
    if len(items) > MAX_SHAPES:
        sec.add(Text(f"The first {MAX_SHAPES} of {len(items)} paired modes are drawn.", "note"))
    return sec


def damping_section(result: dict) -> Section | None:
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
                       Cell(num(zm - zt, 3) if fin(zm) and fin(zt) else "–")])
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
