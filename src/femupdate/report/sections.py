"""Sections of the iterative runs' reports (:mod:`femupdate.report.update`): convergence, identifiability, the
multi-start solutions and the FRFs."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from .document import Cell, Figure, Section, Table, Text, num, numcell, pct, unit_label
from .parts import HZ, cost_unit, figures, units_of

def convergence_section(result: dict) -> Section | None:
    hist = result.get("history") or []
    if not hist:
        return None
    figs = figures()
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


def identifiability_section(result: dict) -> Section | None:
    d = result.get("diagnostics")
    if not d:
        return None
    figs = figures()
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
    noise = d.get("noise") or []
    if noise:
        from ..updating.noise import basis_lines, model_error_line
        from ..variance import METHOD

        for line in basis_lines(noise, METHOD):
            t.rows.append([Cell("covariance basis"), Cell(line)])
        fit = result.get("model_error") or d.get("model_error")
        if fit:
            t.rows.append([Cell("model error"), Cell(model_error_line(fit),
                                                     cls="flag" if fit.get("verdict") == "model error" else "")])
    else:
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
    combos = combinations(result)
    if combos is not None:
        sec.add(combos)
    return sec


def combinations(result: dict) -> Table | None:
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


def distinct_texts(rec: dict | None, fitting: int) -> list[str]:
    """How the solutions were told apart, and the best solution's conditioning said apart from
    non-uniqueness (``starts.distinct``)."""
    from ..distinct import conditioning_line

    if not rec:
        return []
    out = [f"Solutions are told apart at α = {rec.get('alpha', 0.01):g} against their own covariances (the "
           "Mahalanobis distance above the χ² quantile)" if rec.get("basis") != "tolerance" else
           "Solutions are told apart by the relative tolerance only: no solution has a covariance."]
    cond = rec.get("conditioning")
    if cond:
        out.append(("The best solution: " if fitting > 1 else "The solution: ") + conditioning_line(cond) +
                   ("" if fitting > 1 else " — one solution: the data determine it uniquely, "
                    + ("though some combination poorly." if cond.get("ill_conditioned") else "and well.")))
    return out


def starts_section(result: dict) -> Section | None:
    st = result.get("starts") or {}
    sols = st.get("solutions") or []
    if (st.get("total") or 1) <= 1:
        return None
    figs = figures()
    units = units_of(result)
    names = list(result.get("updated") or (sols[0]["parameters"].keys() if sols else []))
    sec = Section("starts", "Multi-start: distinct solutions")
    fitting = sum(1 for s in sols if s.get("fits", True))
    sec.add(Text(f"{st.get('converged', 0)} of {st.get('total')} starts converged (seed {st.get('seed', '–')}); "
                 f"{len(sols)} distinct solution(s), {fitting} of which fit the data as well as the best "
                 "(a likelihood-ratio test at 95 %)."
                 + (" The data do not determine the parameters uniquely." if fitting > 1 else ""),
                 "warning" if fitting > 1 else ""))
    for line in distinct_texts(st.get("distinct"), fitting):
        sec.add(Text(line, "note"))
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


def frf_section(result: dict, rec) -> Section | None:
    figs = figures()
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
                       "and after (solid) the update; "
                       + ("the damped receptances of the model's [damping] table, its damping parameters updated "
                          f"({', '.join(result['damping'].get('parameters') or []) or 'none'})."
                          if result.get("damping") else "the model undamped unless the run stated damping."),
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


def damped_section(result: dict) -> Section | None:
    """A damped model's update (the result's ``damping``): the damping parameters updated with
    their standard deviations, those held, per paired mode the measured and model damping
    ratios and the model mode's MPC, and the complexity (MPC, MPD) of the paired shapes."""
    d = result.get("damping")
    if not isinstance(d, dict) or not d:
        return None
    sec = Section("damping", "Damping parameters")
    updated = list(d.get("parameters") or [])
    values, std = d.get("values") or {}, d.get("std") or {}
    t = Table("the damping parameters of the model's [damping] table: updated (with their standard deviations) or "
              "held at their values", ["parameter", "value", "std", "updated"])
    for n, v in values.items():
        t.rows.append([Cell(n), numcell(v, f"/damping/values/{n}", 6),
                       numcell(std.get(n), f"/damping/std/{n}", 3) if n in updated else Cell("–"),
                       Cell("yes" if n in updated else "held")])
    sec.add(t)
    ratios = d.get("damping_ratios")
    if isinstance(ratios, dict):
        pairs = result.get("pairs") or []
        zr = Table("damping ratio ζ of each paired mode (fraction of critical): measured, the damped model's at the "
                   "solution (ζ = −Re λ/|λ|), the difference, and the model mode's MPC",
                   ["test mode", "model mode", "ζ test", "ζ model", "model − test", "MPC model"])
        for i, (zt, zm) in enumerate(zip(ratios.get("test") or [], ratios.get("model") or [])):
            k, j = (pairs[i][0], pairs[i][1]) if i < len(pairs) else (i, i)
            mpc = (d.get("mpc") or [None] * (i + 1))[i]
            zr.rows.append([Cell(str(int(k) + 1)), Cell(str(int(j) + 1)), numcell(zt, f"/damping/damping_ratios/test/{i}", 5),
                            numcell(zm, f"/damping/damping_ratios/model/{i}", 5),
                            Cell(num(zm - zt, 3) if zt is not None and zm is not None else "–"),
                            numcell(mpc, f"/damping/mpc/{i}", 4)])
        sec.add(zr)
    cx = d.get("complexity")
    if isinstance(cx, dict) and any(v is not None for v in (cx.get("test") or {}).get("mpc") or []):
        pairs = result.get("pairs") or []
        ct = Table("complexity of each paired shape at the measured dofs: MPC (modal phase collinearity, 1 for a real "
                   "mode) and MPD (mean phase deviation, 0° for a real mode) of the test shape and of the model's",
                   ["test mode", "model mode", "MPC test", "MPC model", "MPD test [°]", "MPD model [°]"])
        for i in range(len(cx["test"]["mpc"])):
            k, j = (pairs[i][0], pairs[i][1]) if i < len(pairs) else (i, i)
            ct.rows.append([Cell(str(int(k) + 1)), Cell(str(int(j) + 1))]
                           + [numcell(cx[side][key][i], f"/damping/complexity/{side}/{key}/{i}", 4 if key == "mpc" else 3)
                              for key in ("mpc", "mpd_deg") for side in ("test", "model")])
        sec.add(ct)
    return sec
