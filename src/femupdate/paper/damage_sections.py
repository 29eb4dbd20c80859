"""Paper sections of "Improving experimental data" and "Damage detection": perturbed boundary
conditions, full-field (scanning) measurements, and Doebling et al.'s (1993) cantilever vs free-free truss.

The paper prints no numbers here; each section measures the claims it makes.
"""

from __future__ import annotations

import numpy as np

from .._errors import InputError
from ..damage import detect_damage, element_parameters
from ..damage.examples import concentrated_mass_truss, noisy_modes
from ..fullfield import complete_direct, map_scan, structure_segments
from ..fullfield.examples import scan_beam, segmented_cantilever
from ..updating.multiconfig import (Configuration, Modification, direct_configurations, rank_modifications, simulate,
                                    update_configurations)
from ..examples import FIGURE2_K4, three_dof, two_dof
from ..modal import model_modes
from ..updating import cluster, draw_starts, multistart
from ..testdata import MeasuredMode, TestData
from ..updating import update
from .direct_sections import two_dof_inverse

SEED = 1993


# ------------------------------------------------------------------------------ perturbed boundary
def _two_config_closed_form(m1, m2, dm2, lam_a, lam_b):
    """(k1, k2) from the frequencies of the two-dof chain and of the same chain with dm2 added at
    dof 2 (eq. 11 twice): a1 = m2 k1 + (m1 + m2) k2 and a1' = (m2 + dm2) k1 + (m1 + m2 + dm2) k2 are
    two linear equations, a1 = m1 m2 (λ1 + λ2), a1' = m1 (m2 + dm2)(λ1' + λ2')."""
    a1 = m1 * m2 * float(np.sum(lam_a))
    a1b = m1 * (m2 + dm2) * float(np.sum(lam_b))
    return np.linalg.solve([[m2, m1 + m2], [m2 + dm2, m1 + m2 + dm2]], [a1, a1b])


def perturbed_boundary(out_dir, figures=True, starts: int = 24) -> dict:
    m = two_dof()
    m1, m2, dm = 2.0, 4.0, 2.0
    base = simulate(m, None, ["1:x"], 2)  # one sensor: frequencies only (the paper's eqs. 11-12 case)
    mod = Modification(f"+{dm:g} kg at 2:x", masses=(("2:x", dm),))
    pert = simulate(m, mod, ["1:x"], 2)
    # closed forms
    a1, a0 = m1 * m2 * base.eigenvalues.sum(), m1 * m2 * base.eigenvalues.prod()  # eq. 11 with a2 = m1 m2
    alone = two_dof_inverse(a1, a0, m1, m2)
    joint = _two_config_closed_form(m1, m2, dm, base.eigenvalues, pert.eigenvalues)
    # measured: random starts, baseline alone and with the perturbed configuration
    ms = multistart(m, base, starts=starts, seed=SEED)
    alone_found = [(s.parameters["k1"], s.parameters["k2"], s.count) for s in ms.solutions if s.cost < 1e-20]
    X0 = draw_starts(m, m.parameter_names, starts, SEED)
    runs = []
    for x0 in X0:
        r = update_configurations(m, [Configuration(base, name="baseline"), Configuration(pert, mod)], x0=dict(zip(m.parameter_names, x0)))
        if r.success and r.cost < 1e-20:
            runs.append(r)
    groups = cluster(np.array([r.x for r in runs]), np.array([r.cost for r in runs])) if runs else []
    joint_found = [(float(runs[g[0]].x[0]), float(runs[g[0]].x[1]), len(g)) for g in groups]
    cond = runs[0].conditioning if runs else {}
    # direct: the Figure 2 chain (4 unknowns), one complete mode per configuration
    t = three_dof(k4=FIGURE2_K4)
    start = t.with_values(t.values * 0.5)
    one = simulate(t, None, None, 1)
    mod3 = Modification("+1 kg at 1:x", masses=(("1:x", 1.0),))
    try:
        direct_configurations(start, [Configuration(one, name="baseline")])
        refused = None
    except InputError as exc:
        refused = str(exc)
    dres = direct_configurations(start, [Configuration(one, name="baseline"), Configuration(simulate(t, mod3, None, 1), mod3)])
    derr = float(np.max(np.abs(dres.x / t.values - 1)))
    # pre-test ranking, checked by Monte Carlo identification under frequency noise
    cands = [Modification(f"{mm:g} kg at {d}", masses=((d, mm),)) for d in ("1:x", "2:x") for mm in (0.5, 2.0)]
    rk = rank_modifications(m, cands, ["1:x"], 2)
    rng = np.random.default_rng(SEED)
    sigma, n_mc = 0.005, 12

    def noisy(td):
        return TestData(modes=tuple(MeasuredMode(mo.eigenvalue * (1 + sigma * rng.standard_normal()) ** 2, mo.dofs, mo.shape)
                                    for mo in td.modes))

    mc = {}
    for c in cands:
        d = simulate(m, c, ["1:x"], 2)
        errs = [update_configurations(m, [Configuration(noisy(base), name="baseline"), Configuration(noisy(d), c)]).x / m.values - 1
                for _ in range(n_mc)]
        mc[c.name] = float(np.sqrt(np.mean(np.square(errs))))
    order = [c["name"] for c in rk.candidates]
    ranking_agrees = mc[order[0]] < mc[order[-1]]
    ok = (len(alone) == 2 and len(alone_found) == 2 and len(joint_found) == 1
          and np.allclose(joint_found[0][:2], joint, rtol=1e-6) and refused is not None and derr < 1e-8 and ranking_agrees)
    out = {
        "description": "perturbed boundary conditions: one set of unknowns, configurations with known added masses. "
                       "(a) two-dof chain (k1=8, k2=6, m1=2, m2=4), frequencies only: the baseline alone has two "
                       "solutions (eqs. 11-12); adding a configuration with 2 kg at dof 2 leaves one, in closed form and "
                       f"from {starts} random starts. (b) Figure 2 chain, ONE complete mode per configuration: alone 3 "
                       "equations for 4 unknowns (refused), two configurations solve directly. (c) pre-test ranking of "
                       "candidate masses by the condition number of the stacked sensitivities, checked against the "
                       f"RMS error of {n_mc} noisy identifications ({sigma * 100:g} % frequency noise) per candidate.",
        "two_dof": {
            "closed_form": {"baseline_alone": alone, "with_configuration": joint.tolist()},
            "random_starts": {"starts": starts, "baseline_alone": alone_found, "with_configuration": joint_found},
            "conditioning": {"baseline_alone": cond.get("each", [{}])[0].get("condition_number"),
                             "stacked": cond.get("stacked", {}).get("condition_number")},
        },
        "figure2_direct": {"one_configuration": refused, "two_configurations": dres.x, "max_relative_error": derr,
                           "conditioning": {"cumulative": [{"configurations": c["configurations"], "rank": c["rank"],
                                                            "condition_number": c["condition_number"]}
                                                           for c in dres.conditioning["cumulative"]]}},
        "pretest_ranking": {"criterion": rk.criterion, "baseline": rk.baseline,
                            "candidates": [{k: c[k] for k in ("name", "gain", "condition_number", "frequency_shift")}
                                           for c in rk.candidates],
                            "monte_carlo_rms_error": mc, "best_ranked_has_smaller_error_than_worst": ranking_agrees},
        "finding": "The stacked configuration's condition number can be larger than the baseline's (here "
                   f"{cond.get('stacked', {}).get('condition_number', float('nan')):.3g} vs "
                   f"{cond.get('each', [{}])[0].get('condition_number', float('nan')):.3g}) and still remove the "
                   "second solution: local conditioning and global uniqueness are different questions.",
        "agrees_with_paper": bool(ok),
        "summary": f"2-dof, frequencies only: {len(alone_found)} solutions alone -> {len(joint_found)} with +{dm:g} kg at dof 2; "
                   f"Fig. 2 chain: one mode per configuration identifies k (err {derr:.1e}); best candidate "
                   f"'{order[0]}' (MC error {mc[order[0]]:.3f}) vs worst '{order[-1]}' ({mc[order[-1]]:.3f})",
    }
    if figures:
        from ..plot.damage import perturbed_boundary_figure

        out["figure"] = perturbed_boundary_figure(out_dir / "perturbed_boundary.png", alone_found, joint_found, rk, mc)
    return out


# ------------------------------------------------------------------------------ full field
E_TRUE = (2.0e11, 2.2e11, 1.9e11, 2.1e11)
E_START = (2.1e11,) * 4


def full_field_direct(out_dir, figures=True, n_points: int = 200) -> dict:
    truth = segmented_cantilever(48, E_TRUE).build()
    sc = segmented_cantilever(12, E_START)
    model, segs = sc.build(), structure_segments(sc)
    e_true = np.array(E_TRUE)
    rng = np.random.default_rng(SEED)
    xs = np.sort(rng.uniform(0.0, 1.0, n_points))
    # reference: the truth's own values at the coarse nodes (they are truth nodes too): the model-error floor
    tm = model_modes(truth, n_modes=4)
    ratio = (truth.n_dofs // 3) // (model.n_dofs // 3)  # coarse node i is truth node ratio * i
    at = [f"{int(d.split(':')[0]) * ratio}:{d.split(':')[1]}" for d in model.dofs]
    exact = TestData(modes=tuple(MeasuredMode(tm.eigenvalues[r], model.dofs, tm.at(at)[:, r]) for r in range(4)))
    floor = {f: float(np.max(np.abs(complete_direct(model, exact, form=f).x / e_true - 1))) for f in ("pointwise", "projected")}
    rows = []
    for noise, seeds in ((0.0, (0,)), (1e-3, (1, 2)), (1e-2, (1, 2))):
        for method in ("elements", "rbf", "local"):
            errs: dict[str, list[float]] = {"pointwise": [], "projected": []}
            interp = []
            for seed in seeds:
                scan = scan_beam(truth, xs, 4, noise, seed)
                mp = map_scan(model, scan, method=method, segments=segs)
                interp.append(mp.interpolation_error)
                for form in errs:
                    errs[form].append(float(np.max(np.abs(complete_direct(model, mp.data, form=form).x / e_true - 1))))
            rows.append({"noise": noise, "method": method, "interpolation_error": float(np.mean(interp)),
                         "max_relative_error": {k: float(np.mean(v)) for k, v in errs.items()}})
    # an iterative (output-error) update on the same mapped 1 % data, for reference
    mp = map_scan(model, scan_beam(truth, xs, 4, 1e-2, 1), method="rbf", segments=segs)
    it = update(model, mp.data)
    it_err = float(np.max(np.abs(it.x / e_true - 1)))

    def get(noise, method, form):
        return next(r["max_relative_error"][form] for r in rows if r["noise"] == noise and r["method"] == method)

    bias = abs(get(0.0, "rbf", "projected") - floor["projected"])
    ok = (get(0.0, "rbf", "projected") < 5e-3 and get(0.0, "elements", "projected") < 5e-3 and bias < 2e-3)
    out = {
        "description": f"cantilever, 12 beam elements, E unknown in 4 segments (truth {list(E_TRUE)} Pa, a 48-element "
                       f"mesh); scanning test: y at {n_points} random points (not nodes), 4 modes, noise 0, 0.1 %, 1 % of "
                       "the largest value; axial motion declared zero; mapped onto the 36 dofs by the elements' shape "
                       "functions, a smoothing spline (RBF, cross-validated) or a local quadratic through the nearest "
                       "points (the data at the points of interest only), rotations from slopes; direct solution with the "
                       "paper's pointwise equations (eqs. 4-10) and projected onto the measured shapes",
        "model_error_floor": floor,
        "cases": rows,
        "iterative_on_rbf_1pct": {"max_relative_error": it_err},
        "interpolation_bias_noise_free": bias,
        "finding": "With noise-free scans the direct solution recovers E to the model-error floor whichever mapping is "
                   "used (the paper: 'the potential for bias by a well chosen interpolation routine would be small'). "
                   "With noise the paper's pointwise equations fail: the stiffness applied to the measured shapes is a "
                   "discrete fourth derivative, so the shape noise is amplified and the least-squares estimate is "
                   "pulled towards zero (errors in variables). Projecting the same linear equations onto the measured "
                   "shapes (energy and orthogonality relations) and smoothing the scan (cross-validated spline) keep "
                   "the direct solution usable; the local fit without smoothing does not.",
        "agrees_with_paper": bool(ok),
        "summary": f"noise-free: rbf {get(0.0, 'rbf', 'projected') * 100:.2f} % (floor {floor['projected'] * 100:.2f} %); "
                   f"1 % noise: pointwise {get(1e-2, 'rbf', 'pointwise') * 100:.0f} % vs projected "
                   f"{get(1e-2, 'rbf', 'projected') * 100:.1f} % (rbf), local {get(1e-2, 'local', 'projected') * 100:.0f} %; "
                   f"iterative {it_err * 100:.1f} %",
    }
    if figures:
        from ..plot.damage import full_field_figure

        scan = scan_beam(truth, xs, 4, 1e-2, 1)
        out["figure"] = full_field_figure(out_dir / "full_field_direct.png", model, scan, mp, tm)
    return out


# ------------------------------------------------------------------------------ Doebling et al.
DAMAGE_CASES = ("E.1-2", "E.2-3", "E.4-5", "E.104-105", "E.107-108", "E.4-105", "E.3-103", "k.201y-105y")
LOSS = 0.3


def truss_sensors(model) -> list[str]:
    """Every joint's y, the top chord's x, and the packages (no bottom-chord x)."""
    return [d for d in model.dofs if not (d.endswith(":x") and int(d.split(":")[0]) < 100)]


def mount_strain_share(model, modes, which) -> np.ndarray:
    """Per mode, the share of its strain energy in the package mounts (``k.*`` parameters): ~1 for a
    local mode of a concentrated mass, ~0 for a global mode of the truss."""
    K = model.K()
    mounts = [j for j, nm in enumerate(model.parameter_names) if nm.startswith("k.")]
    out = []
    for r in which:
        phi = modes.shapes[:, r]
        e = sum(model.values[j] * float(phi @ (model.dK_dp(j) @ phi)) for j in mounts)
        out.append(e / float(phi @ (K @ phi)))
    return np.array(out)


def _outcome(located, true) -> str:
    if located == [true]:
        return "exact"
    if located and located[0] == true:
        return "found first"
    return "found" if true in located else "missed"


REPLICATES = 3      # noise draws per damage case
BAND_HZ = 90.0      # the test's frequency band, the same for both configurations
WIDE_BAND_HZ = 170.0  # free-free again, with a band wide enough to reach its global modes


def damage_cantilever_vs_free(out_dir, figures=True) -> dict:
    study = {}
    for support, band in (("cantilever", BAND_HZ), ("free", BAND_HZ), ("free_wide_band", WIDE_BAND_HZ)):
        base = element_parameters(concentrated_mass_truss("free" if support.startswith("free") else "cantilever"))[0].build()
        sensors = truss_sensors(base)
        modes = model_modes(base)
        elastic = np.flatnonzero(modes.eigenvalues > 0)
        inband = elastic[modes.frequencies_hz[elastic] <= band]
        share = mount_strain_share(base, modes, inband)
        runs = []
        for k, member in enumerate(DAMAGE_CASES):
            dam = {member: base.values[base.parameter_index(member)] * (1 - LOSS)}
            for rep in range(REPLICATES):
                data = noisy_modes(base, sensors, inband.size, dam, 0.001, 0.005, seed=SEED + 100 * k + rep)
                # localisation only (one expansion, no refinement): the claim is about what the modes in band locate
                res = detect_damage(base, data, bootstrap=0, iterations=1, refine=False)
                runs.append({"damaged": member, "noise_seed": SEED + 100 * k + rep, "localised": res.localised,
                             "located": res.located, "loss": res.loss,
                             "outcome": _outcome(res.located, member) if res.localised else "not localisable",
                             "estimated_loss": res.loss.get(member), "separation": res.confidence.get("separation"),
                             "frequency_change": res.frequency_change, "reason": res.reason})
        study[support] = {"band_hz": band, "n_dofs": base.n_dofs, "n_elements": len(base.parameters),
                          "n_sensors": len(sensors), "frequencies_hz": modes.frequencies_hz[inband],
                          "mount_strain_share": share, "n_modes": int(inband.size),
                          "global_modes": int(np.sum(share < 0.5)), "runs": runs}

    def count(support, what=("exact", "found first")):
        return sum(r["outcome"] in what for r in study[support]["runs"])

    n = len(DAMAGE_CASES) * REPLICATES
    c, f, w = count("cantilever"), count("free"), count("free_wide_band")

    def missed(support):
        out = {}
        for r in study[support]["runs"]:
            if r["outcome"] not in ("exact", "found first"):
                out[r["damaged"]] = out.get(r["damaged"], 0) + 1
        return ", ".join(f"{k} {v}/{REPLICATES}" for k, v in out.items()) or "none"

    missed_f, missed_c = missed("free"), missed("cantilever")
    out = {
        "description": f"8-bay plane truss (aluminium rods, 2 kg joints) with four 15 kg instrument packages on mounts "
                       f"tuned to 22-40 Hz, tested cantilevered and free-free over the same band (0-{BAND_HZ:g} Hz); the "
                       f"same {LOSS * 100:g} % stiffness loss in one of {len(DAMAGE_CASES)} members at a time, "
                       f"{REPLICATES} noise draws each; every mode in the band "
                       "measured at every joint (y), the top chord (x) and the packages, 0.1 % frequency and 0.5 % shape "
                       "noise; detection from the validated baseline (one stiffness per element, SEREP expansion, "
                       "projected equations, L1 regularisation). A mode is local when most of its strain energy is in "
                       "the package mounts",
        "study": study,
        "located_first": {"cantilever": c, "free": f, "free_wide_band": w, "cases": n},
        "finding": f"In the band, cantilevered: {study['cantilever']['n_modes']} modes of which "
                   f"{study['cantilever']['global_modes']} global; free-free: {study['free']['n_modes']} modes of which "
                   f"{study['free']['global_modes']} global (the local modes of the concentrated masses take the low "
                   f"frequencies). The damaged member is located (alone or first) in {c}/{n} runs cantilevered and "
                   f"{f}/{n} free-free (free-free missed: {missed_f}; cantilever missed: {missed_c}); widening the free-free band to {WIDE_BAND_HZ:g} Hz "
                   f"({study['free_wide_band']['global_modes']} global modes) gives {w}/{n}. Damage in a package mount "
                   "changes its local mode by far more than a shift, yet is located when the packages are instrumented.",
        "agrees_with_paper": bool(c > f),
        "summary": f"same 0-{BAND_HZ:g} Hz band: damaged member located in {c}/{n} runs cantilevered, {f}/{n} free-free "
                   f"({study['free']['global_modes']} global modes in band); free-free to {WIDE_BAND_HZ:g} Hz: {w}/{n}",
    }
    if figures:
        from ..plot.damage import damage_study_figure

        out["figure"] = damage_study_figure(out_dir / "damage_cantilever_vs_free.png", study, DAMAGE_CASES)
    return out


ORDER = 60
SECTIONS = {"perturbed_boundary": perturbed_boundary, "full_field_direct": full_field_direct,
            "damage_cantilever_vs_free": damage_cantilever_vs_free}
