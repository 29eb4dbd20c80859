"""The report of ``posterior``: the parameters' medians, credible intervals and priors, the distinct
solutions with their probabilities, the correlation matrix, the noise, the sampler's diagnostics
(effective sample size, R-hat, TMCMC's stages), the posterior predictive of the paired modes, the
corner and trace figures (:mod:`femupdate.plot.posterior`), and the warnings and notes.

The JSON holds no samples: the corner figure and MCMC's traces come from the result object
(:meth:`~femupdate.bayes.PosteriorResult.report_images`, :func:`sample_figures`); TMCMC's stages
and the predictive intervals are in the JSON (the predictive figure needs the test data's
frequencies).
"""

from __future__ import annotations

import math
from types import SimpleNamespace

from .document import Cell, Document, Figure, Section, Table, Text, num, numcell, pct, unit_label
from .parts import HZ, NONE, collect_notes, fin, maccell, summary_section, units_of


def _embed(fig, fmt: str) -> dict:
    """A pyplot figure of :mod:`femupdate.plot.posterior` embedded (and closed)."""
    import matplotlib.pyplot as plt

    from ..plot.report import embed

    try:
        return embed(fig, fmt)
    finally:
        plt.close(fig)


def sample_figures(result) -> dict:
    """The figures that need a :class:`~femupdate.bayes.PosteriorResult`'s samples: ``corner``
    (histograms and pairwise densities, the solutions marked) and, for MCMC, ``trace`` (the
    chains, burn-in shaded); PNG images.  Empty for a result without samples (read back from
    JSON)."""
    if result.samples.size == 0 or not len(result.names):
        return {}
    from ..plot.posterior import corner_figure, trace_figure

    out = {"corner": _embed(corner_figure(result), "png")}
    if result.method == "mcmc" and result.chain is not None:
        out["trace"] = _embed(trace_figure(result), "png")
    return out


def _verdict(result: dict) -> Cell:
    ok = bool(result.get("success"))
    return Cell("the sampler's checks passed" if ok else "DOUBTFUL: the sampler's checks failed", cls="ok" if ok else "bad")


def _parameters(result: dict) -> Section:
    names = list(result.get("updated") or [])
    units = units_of(result)
    level = result.get("level")
    t = Table(f"the posterior of each parameter (credible interval of probability {num(level, 3)})",
              ["parameter", "unit", "prior", "median", "mean", "std", "lower", "upper", "std [% of median]"])
    for n in names:
        med, sd = (result.get("median") or {}).get(n), (result.get("std") or {}).get(n)
        lo, hi = ((result.get("interval") or {}).get(n) or [None, None])
        t.rows.append([Cell(n), Cell(units.get(n) or "not stated"), Cell(str((result.get("prior") or {}).get(n, "–"))),
                       numcell(med, f"/median/{n}"), numcell((result.get("mean") or {}).get(n), f"/mean/{n}"),
                       numcell(sd, f"/std/{n}", 4), numcell(lo, f"/interval/{n}/0"), numcell(hi, f"/interval/{n}/1"),
                       Cell(pct(sd / abs(med), 3, sign=False) if fin(sd) and fin(med) and med else "–")])
    sec = Section("parameters", "Parameters").add(t)
    corr = result.get("correlation") or []
    if len(names) > 1 and corr:
        ct = Table("correlation of the samples", ["", *names])
        for i, n in enumerate(names):
            ct.rows.append([Cell(n), *(numcell(v, f"/correlation/{i}/{j}", 3) for j, v in enumerate(corr[i]))])
        sec.add(ct)
    return sec


def _solutions(result: dict) -> Section | None:
    sols = result.get("solutions") or []
    if not sols:
        return None
    names = list(result.get("updated") or [])
    units = units_of(result)
    t = Table("the distinct solutions, most probable first: each a mode of the posterior with its Laplace Gaussian",
              ["solution", *[unit_label(n, units.get(n)) for n in names], f"probability (Laplace) [{NONE}]",
               f"share of the samples [{NONE}]", f"cost ½‖r‖² [{NONE}]", "starts", "inside the bounds", "on a bound",
               "note"])
    for i, s in enumerate(sols):
        t.rows.append([Cell(str(i + 1)), *(numcell((s.get("parameters") or {}).get(n), f"/solutions/{i}/parameters/{n}")
                                           for n in names),
                       numcell(s.get("probability"), f"/solutions/{i}/probability", 3),
                       numcell(s.get("sample_share"), f"/solutions/{i}/sample_share", 3),
                       numcell(s.get("cost"), f"/solutions/{i}/cost", 4), numcell(s.get("count"), f"/solutions/{i}/count"),
                       Cell(pct(s.get("inside_bounds"), 3, sign=False)),
                       Cell(", ".join(s.get("at_bounds") or []) or "–", cls="flag" if s.get("at_bounds") else ""),
                       Cell(str(s.get("note") or "–"))])
    sec = Section("solutions", "Distinct solutions").add(t)
    if sum(1 for s in sols if fin(s.get("probability")) and s["probability"] > 0.01) > 1:
        sec.add(Text("More than one solution is probable: the data do not tell them apart (a prior or more data "
                     "would).", "warning"))
    return sec


def _evidence_and_noise(result: dict) -> Section:
    t = Table("", ["quantity", "value"])
    logz = result.get("log_evidence")
    if logz is not None:
        how = "TMCMC's estimate" if result.get("method") == "tmcmc" else "Laplace approximation"
        t.rows.append([Cell(f"log evidence log p(data) ({how})"), numcell(logz, "/log_evidence", 6)])
        if result.get("log_evidence_error") is not None:
            t.rows.append([Cell("its Monte Carlo error"), numcell(result["log_evidence_error"], "/log_evidence_error", 2)])
    nz = result.get("noise") or {}
    t.rows.append([Cell("noise"), Cell({"stated": "the stated standard deviations", "estimate":
                                        "a common scale on the residuals, estimated (Jeffreys' prior)"}.get(
                                            str(nz.get("kind")), str(nz.get("kind", "–"))))])
    if nz.get("n_residuals") is not None:
        t.rows.append([Cell("residuals"), numcell(nz["n_residuals"], "/noise/n_residuals")])
    sc = nz.get("scale")
    if isinstance(sc, dict):
        lo, hi = (sc.get("interval") or [None, None])
        t.rows.append([Cell(f"noise scale s [{NONE}]: median"), numcell(sc.get("median"), "/noise/scale/median", 4)])
        t.rows.append([Cell("noise scale s: interval"),
                       Cell(f"[{num(lo, 4)}, {num(hi, 4)}]")])
    return Section("evidence", "Evidence and noise").add(t)


def _diagnostics(result: dict, images: dict) -> Section:
    d = result.get("diagnostics") or {}
    method = result.get("method")
    names = list(result.get("updated") or [])
    sec = Section("diagnostics", "Sampler diagnostics")
    t = Table("", ["quantity", "value"])
    t.rows.append([Cell("method"), Cell(str(method))])
    for label, key in (("samples summarised", "/n_samples"), ("likelihood evaluations", "/diagnostics/evaluations")):
        obj = result if key.count("/") == 1 else d
        v = obj.get(key.rsplit("/", 1)[1])
        if v is not None:
            t.rows.append([Cell(label), numcell(v, key)])
    for label, key in (("walkers", "walkers"), ("ensembles", "ensembles"), ("steps", "steps"), ("burn-in steps", "burn"),
                       ("acceptance rate", "acceptance"), ("TMCMC stages", "n_stages"),
                       ("distinct resampled points", "distinct"), ("samples", "samples")):
        if d.get(key) is not None:
            t.rows.append([Cell(label), numcell(d[key], f"/diagnostics/{key}", 3)])
    for msg, n in (d.get("failures") or {}).items():
        t.rows.append([Cell("failed evaluations"), Cell(f"{n} × {msg}")])
    sec.add(t)
    if method == "mcmc" and d.get("ess"):
        limits = d.get("limits") or {}
        mt = Table(f"per parameter: effective sample size (at least {num(limits.get('ess'))}), split R-hat (at most "
                   f"{num(limits.get('rhat'))}) and integrated autocorrelation time",
                   ["parameter", "ESS", "R-hat", "τ [steps]", "τ reliable"])
        for n in names:
            ess, rh = (d.get("ess") or {}).get(n), (d.get("rhat") or {}).get(n)
            ok_e = fin(ess) and ess >= (limits.get("ess") or 0)  # type: ignore[operator]
            ok_r = fin(rh) and rh <= (limits.get("rhat") or math.inf)  # type: ignore[operator]
            mt.rows.append([Cell(n), numcell(ess, f"/diagnostics/ess/{n}", 4, "" if ok_e else "bad"),
                            numcell(rh, f"/diagnostics/rhat/{n}", 4, "" if ok_r else "bad"),
                            numcell((d.get("tau") or {}).get(n), f"/diagnostics/tau/{n}", 4),
                            Cell("yes" if (d.get("tau_reliable") or {}).get(n) else "no")])
        sec.add(mt)
    stages = d.get("stages") or []
    if method == "tmcmc" and stages:
        st = Table("TMCMC's stages", ["stage", "tempering exponent β", "weights' c.o.v.", "acceptance", "ESS",
                                      "distinct points"])
        for i, s in enumerate(stages):
            st.rows.append([Cell(str(s.get("stage", i + 1))), numcell(s.get("beta"), f"/diagnostics/stages/{i}/beta", 4),
                            numcell(s.get("cov"), f"/diagnostics/stages/{i}/cov", 3),
                            numcell(s.get("acceptance"), f"/diagnostics/stages/{i}/acceptance", 3),
                            numcell(s.get("ess"), f"/diagnostics/stages/{i}/ess", 4),
                            numcell(s.get("distinct"), f"/diagnostics/stages/{i}/distinct")])
        sec.add(st)
    trace = images.get("trace") or (_tmcmc_trace(result) if method == "tmcmc" and stages else None)
    if trace is not None:
        sec.add(Figure(trace, "MCMC: each parameter's chains against the step (burn-in shaded)." if method == "mcmc"
                       else "TMCMC: the tempering exponent and acceptance, and each parameter's mean ± std, per stage.",
                       wide=True))
    return sec


def _tmcmc_trace(result: dict) -> dict | None:
    from ..plot.posterior import trace_figure

    light = SimpleNamespace(method="tmcmc", names=tuple(result.get("updated") or ()),
                            diagnostics=result.get("diagnostics") or {})
    try:
        return _embed(trace_figure(light), "svg")
    except (KeyError, TypeError, IndexError):  # stages without their means: no figure
        return None


def _predictive(result: dict, data) -> Section | None:
    pred = (result.get("predictive") or {}).get("modes") or []
    if not pred:
        return None
    level = result.get("level")
    ft = list(data.frequencies_hz) if data is not None and data.modes else None
    t = Table(f"the paired modes over the posterior ({num(level, 3)} intervals; "
              f"{(result.get('predictive') or {}).get('draws', '–')} samples predicted)",
              ["test mode", f"f test [{HZ}]", f"f model mean [{HZ}]", f"f model std [{HZ}]", f"lower [{HZ}]",
               f"upper [{HZ}]", f"new measurement [{HZ}]", f"MAC mean [{NONE}]"])
    for i, e in enumerate(pred):
        k = int(e.get("test_mode", i))
        f = e.get("frequency_hz") or {}
        lo, hi = (f.get("interval") or [None, None])
        meas = (e.get("measured_frequency_hz") or {}).get("interval")
        mac = e.get("mac") or {}
        t.rows.append([Cell(str(k + 1)), numcell(ft[k] if ft is not None and k < len(ft) else None),
                       numcell(f.get("mean"), f"/predictive/modes/{i}/frequency_hz/mean"),
                       numcell(f.get("std"), f"/predictive/modes/{i}/frequency_hz/std", 3),
                       numcell(lo, f"/predictive/modes/{i}/frequency_hz/interval/0"),
                       numcell(hi, f"/predictive/modes/{i}/frequency_hz/interval/1"),
                       Cell(f"[{num(meas[0])}, {num(meas[1])}]" if meas and all(fin(v) for v in meas) else "–"),
                       maccell(mac.get("mean"), f"/predictive/modes/{i}/mac/mean")])
    sec = Section("predictive", "Posterior predictive").add(t)
    zeta = _damping_ratios(pred, level, data)
    if zeta is not None:
        sec.add(zeta)
    if ft is not None:
        from matplotlib.figure import Figure as MplFigure

        from ..plot.posterior import predictive_axes
        from ..plot.report import embed

        fig = MplFigure(figsize=(5.5, 3.5), layout="constrained")
        predictive_axes(SimpleNamespace(predictive=result.get("predictive"), level=level), ft, fig.add_subplot())
        sec.add(Figure(embed(fig), "The model's frequency interval (blue) and that of a new measurement (orange) per "
                                   "test mode, as errors from the measured frequency."))
    else:
        sec.add(Text("The predictive figure needs the test data (femupdate report RESULT.json --model MODEL --data "
                     "DATA).", "note"))
    return sec


def _damping_ratios(pred: list, level, data) -> Table | None:
    """A damped model's paired modes' damping ratios over the posterior (None otherwise)."""
    if not any(e.get("damping_ratio") for e in pred):
        return None
    t = Table(f"the damping ratios of the paired complex modes over the posterior ({num(level, 3)} intervals)",
              ["test mode", f"ζ test [{NONE}]", f"ζ model mean [{NONE}]", f"ζ model std [{NONE}]", f"lower [{NONE}]",
               f"upper [{NONE}]"])
    for i, e in enumerate(pred):
        z = e.get("damping_ratio") or {}
        k = int(e.get("test_mode", i))
        zt = data.modes[k].damping_ratio if data is not None and k < len(data.modes) else None
        lo, hi = (z.get("interval") or [None, None])
        t.rows.append([Cell(str(k + 1)), numcell(zt), numcell(z.get("mean"), f"/predictive/modes/{i}/damping_ratio/mean"),
                       numcell(z.get("std"), f"/predictive/modes/{i}/damping_ratio/std", 3),
                       numcell(lo, f"/predictive/modes/{i}/damping_ratio/interval/0"),
                       numcell(hi, f"/predictive/modes/{i}/damping_ratio/interval/1")])
    return t


def build_posterior(doc: Document, result: dict, model, data, rec, segments, kind: str,
                    images: dict | None = None) -> None:
    """``posterior``; ``images``: :func:`sample_figures` of the result object, when there is one."""
    images = dict(images or {})
    collect_notes(doc, result)
    doc.warnings.extend(str(w) for w in result.get("warnings") or [])
    doc.verdict = _verdict(result)
    sols = result.get("solutions") or []
    doc.facts += [("method", Cell(str(result.get("method")))), ("samples", numcell(result.get("n_samples"), "/n_samples")),
                  ("solutions", Cell(str(len(sols))))]
    if result.get("log_evidence") is not None:
        doc.facts.append(("log evidence", numcell(result["log_evidence"], "/log_evidence", 5)))
    extra = [("likelihood", f"{result.get('route', '–')} route; {result.get('data_sets', 1)} test-data set(s)"),
             ("seed", str(result.get("seed")))]
    doc.sections.append(summary_section(doc, result, model, data, extra))
    doc.sections.append(_parameters(result))
    if images.get("corner") is not None:
        doc.sections[-1].add(Figure(images["corner"], "The samples' marginal histograms (the Laplace mixture dashed) "
                                                      "and pairwise densities; the solutions marked ×.", wide=True))
    else:
        doc.sections[-1].add(Text("The corner figure needs the samples, which the JSON does not hold: it is drawn by "
                                  "--report on the command and by the result object's write_report.", "note"))
    for sec in (_solutions(result), _evidence_and_noise(result), _diagnostics(result, images),
                _predictive(result, data)):
        if sec is not None:
            doc.sections.append(sec)
