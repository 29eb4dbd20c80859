"""Benchmark: damping identification under noise through sdypy-EMA (issue 31, item 5; no
wall-clock figures).

Usage::

    python benchmarks/bench_damping.py                       # 1 % and 5 % noise, 20 seeds each
    python benchmarks/bench_damping.py --seeds 5 --levels 0.01
    python benchmarks/bench_damping.py --quick               # 2 seeds, no FRF route
    python benchmarks/bench_damping.py --families rayleigh

The structure is the damped truss of the example files (``truss_damped.toml``: 3-bay plane truss,
E = 70 GPa, Rayleigh α = 0.5 1/s fixed, β = ``b`` = 2e-5 s, dampers ``c1`` = 400 N s/m across the
right bay's diagonal and ``c2`` = 250 N s/m from joint 103 to the ground). Its FRFs are simulated
here by a second route (the dense solve of (K − ω²M + iωC) x = f per line with the model's
matrices, not femupdate's damped receptances): a unit force at 102:x, the responses at the 12 joint
dofs, 10 to 400 Hz every 0.5 Hz (781 lines; five modes: 46.5, 146.5, 201.5, 263.3, 334.6 Hz,
ζ 6.8, 1.3, 2.7, 1.9, 3.4 %). Noise: complex Gaussian, per response dof ``level`` times the RMS of that response over
the band (real and imaginary parts each of std level·rms/√2), for each seed.

Two families of unknowns, updated from the same data: ``dampers`` — E, β (``b``) and both
dampers' coefficients (α fixed); ``rayleigh`` — E and both Rayleigh coefficients, α (``a``, a
damping parameter here) and β, with the dampers held at their true values.

Per noise level and seed:

* **identification** by sdypy-EMA: LSCF poles up to order ``--order`` (30) over the band,
  ``select_closest_poles`` at the true natural frequencies (window 10 Hz), LSFD modal constants
  with the driving point (102:x) scaling them to shapes; read by
  :func:`femupdate.io.adapters.from_sdypy_ema`. Recorded: the identified frequencies and damping
  ratios against the true complex modes', and the unit-length shapes' error (phase-aligned).
* ``ema``: :func:`femupdate.update` of the family's unknowns from the identified modes (frequencies,
  damping ratios, complex shapes) as read — sdypy-EMA states no standard deviations, so every
  residual has weight 1 and femupdate estimates the noise from the fit (its default);
* ``ema+std``: the same modes with standard deviations stated per mode (``std_frequency``,
  ``std_damping_ratio``, ``std_shape``): the RMS identification errors of that mode over all the
  level's seeds (a calibration of the identification by simulating the test, as a test engineer
  can; it uses the truth, so it is the best statement available, bias included);
* ``frf-update``: :func:`femupdate.updating.frf_update` of the same parameters directly on
  the noisy FRFs, with their noise standard deviation stated (the level's σ per dof).

Every update starts at E, b, c1, c2 = 6e10, 5e-5, 100, 600 (the start of docs/damping.md; α at
2.0 in the ``rayleigh`` family). The table gives, per family, route and parameter, the mean estimate, the bias (mean − true, % of true), the
scatter (standard deviation over seeds, % of true), the RMS z-score (estimate − true) / std with
femupdate's standard deviation (seeds with the parameter on a bound, whose std is not given,
left out; their number is given), and failures.

The table is printed as Markdown and written to ``benchmarks/results/bench_damping.json``
(``--output``).
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import sys
import tempfile
import warnings
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "src"))

from femupdate.examples import TRUSS_DAMPED_START, TRUSS_DAMPING, truss_damped_model_toml  # noqa: E402

#: per family, the updated parameters' true values and starting values: ``dampers`` (β and both
#: dampers, α fixed), ``rayleigh`` (α and β, the dampers held at their true values)
FAMILIES = {
    "dampers": ({"E": 7.0e10, "b": TRUSS_DAMPING["beta"], "c1": TRUSS_DAMPING["c1"], "c2": TRUSS_DAMPING["c2"]},
                dict(TRUSS_DAMPED_START)),
    "rayleigh": ({"E": 7.0e10, "a": TRUSS_DAMPING["alpha"], "b": TRUSS_DAMPING["beta"]},
                 {"E": 6.0e10, "a": 2.0, "b": 5.0e-5}),
}
TRUTH = FAMILIES["dampers"][0]
DRIVE = "102:x"
BAND_HZ = (10.0, 400.0, 0.5)
N_MODES = 5
ROUTES = ("ema", "ema+std", "frf-update")


def truss():
    """The damped truss of the example files (:class:`~femupdate.damping.DampedModel`)."""
    from femupdate.damping import load_damped_model

    with tempfile.TemporaryDirectory() as d:
        path = Path(d) / "truss_damped.toml"
        path.write_text(truss_damped_model_toml(), encoding="utf-8")
        return load_damped_model(path)


def family_model(dm, family: str):
    """The model a family updates: the truss itself (``dampers``), or with α a damping parameter
    ``a`` (``rayleigh``; the same structure at the truth)."""
    if family == "dampers":
        return dm
    from femupdate.damping import DampedModel
    from femupdate.model import Parameter

    return DampedModel(dm.model, dm.parameters + (Parameter("a", TRUSS_DAMPING["alpha"], (0.0, 10.0)),), alpha="a",
                       beta=dm.beta, dampers=dm.dampers)


def band() -> np.ndarray:
    lo, hi, step = BAND_HZ
    return np.arange(lo, hi + step / 2, step)


def exact_receptances(dm, f_hz: np.ndarray) -> np.ndarray:
    """H[line, dof] = ((K + iD) − ω²M + iωC)⁻¹ e_drive by dense solves (a second route to
    femupdate's damped receptances)."""
    p = dm.resolve(None)
    K, M, C, D = (A.toarray() for A in (dm.K(p), dm.M(p), dm.C(p), dm.D(p)))
    e = np.zeros(len(dm.model.dofs))
    e[list(dm.model.dofs).index(DRIVE)] = 1.0
    return np.array([np.linalg.solve(K + 1j * D - w * w * M + 1j * w * C, e) for w in 2 * np.pi * f_hz])


def noisy(H: np.ndarray, level: float, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """H with complex Gaussian noise of ``level`` times each response's RMS; (noisy H, σ per
    real and imaginary part, per dof)."""
    rng = np.random.default_rng(seed)
    sigma = level * np.sqrt(np.mean(np.abs(H) ** 2, axis=0)) / math.sqrt(2)
    return H + sigma * (rng.standard_normal(H.shape) + 1j * rng.standard_normal(H.shape)), sigma


def true_modes(dm, n: int = N_MODES):
    """(frequencies Hz, damping ratios, unit shapes dofs × modes) of the truth's complex modes."""
    from femupdate.damping import complex_modes

    cm = complex_modes(dm, n_modes=n)
    return cm.natural_frequencies_hz, cm.damping_ratios, cm.shapes / np.linalg.norm(cm.shapes, axis=0)


def shape_error(psi: np.ndarray, phi: np.ndarray) -> np.ndarray:
    """Real and imaginary parts of g ψ̂ − φ̂ for unit shapes, ψ̂ turned by the unit factor that
    aligns it best with φ̂ (as femupdate's damped shape residual)."""
    psi, phi = psi / np.linalg.norm(psi), phi / np.linalg.norm(phi)
    a = np.vdot(psi, phi)
    e = psi * (a / abs(a)) - phi
    return np.concatenate([e.real, e.imag])


def identify(Hn: np.ndarray, f_hz: np.ndarray, dofs, f_true, order: int = 30):
    """sdypy-EMA's modes of the noisy FRFs as femupdate test data (LSCF, closest stable poles,
    LSFD)."""
    from sdypy import EMA

    from femupdate.io.adapters import from_sdypy_ema

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the library's clamping and stabilisation warnings
        ema = EMA.Model(frf=Hn.T, freq=f_hz, lower=f_hz[0], upper=f_hz[-1] - 1.0, pol_order_high=order,
                        frf_form="receptance", driving_point=list(dofs).index(DRIVE))
        ema.get_poles(show_progress=False)
        ema.select_closest_poles(list(f_true), f_window=10)
        ema.get_constants()
    return from_sdypy_ema(ema, channels=list(dofs))


def _estimates(res, truth) -> dict:
    std = dict(zip(res.names, map(float, res.diagnostics.std)))
    return {"success": bool(res.success), "values": {n: float(res.parameters[n]) for n in truth},
            "std": {n: (std[n] if np.isfinite(std.get(n, np.nan)) else None) for n in truth}}


def update_modes(dm, data, family: str = "dampers") -> dict:
    import femupdate

    truth, start = FAMILIES[family]
    try:
        return _estimates(femupdate.update(family_model(dm, family).with_values(start), data, params=list(truth)), truth)
    except Exception as exc:  # a failed update is counted, not fatal
        return {"success": False, "error": f"{type(exc).__name__}: {exc}"}


def update_frf(dm, f_hz, Hn, sigma, family: str = "dampers") -> dict:
    from femupdate.testdata import FRFData, TestData
    from femupdate.updating import frf_update

    truth, start = FAMILIES[family]
    data = TestData(frf=FRFData(2 * np.pi * f_hz, {DRIVE: 1.0}, tuple(dm.model.dofs), Hn))
    try:
        return _estimates(frf_update(family_model(dm, family).with_values(start), data, params=list(truth),
                                     measurement_std=sigma), truth)
    except Exception as exc:
        return {"success": False, "error": f"{type(exc).__name__}: {exc}"}


def with_std(data, f_std, z_std, s_std):
    """The modes with per-mode standard deviations stated."""
    from femupdate.testdata import TestData

    return TestData(modes=tuple(dataclasses.replace(m, std_eigenvalue=2 * float(a),
                                                    std_damping_ratio=float(b), std_shape=float(c))
                                for m, a, b, c in zip(data.modes, f_std, z_std, s_std)), notes=data.notes)


def run_level(dm, H, level: float, seeds, frf: bool = True, order: int = 30, log=print,
              families=("dampers",)) -> dict:
    """Identification and the three routes of each family at one noise level over ``seeds``."""
    f_hz = band()
    dofs = list(dm.model.dofs)
    f0, z0, phi0 = true_modes(dm)
    runs = []
    for seed in seeds:
        Hn, sigma = noisy(H, level, seed)
        data = identify(Hn, f_hz, dofs, f0, order)
        idx = dm.model.dof_index(list(data.modes[0].dofs))
        ident = {"f_rel_error": (data.frequencies_hz / f0 - 1).tolist(),
                 "zeta": [m.damping_ratio for m in data.modes],
                 "shape_rms": [float(np.sqrt(np.mean(shape_error(np.asarray(m.shape, complex), phi0[idx, r]) ** 2)))
                               for r, m in enumerate(data.modes)]}
        run = {"seed": int(seed), "identified": ident, "_data": data, "_H": (Hn, sigma)}
        for fam in families:
            run[fam] = {"ema": update_modes(dm, data, fam)}
        runs.append(run)
        log(f"level {level:g} seed {seed}: zeta {np.round(ident['zeta'], 4).tolist()}, "
            + "; ".join(f"{fam} ema {run[fam]['ema'].get('values')}" for fam in families))
    # the identification's RMS errors over the level's seeds, stated as the modes' deviations
    fe = np.array([r["identified"]["f_rel_error"] for r in runs])
    ze = np.array([[np.nan if z is None else z for z in r["identified"]["zeta"]] for r in runs]) - z0
    se = np.array([r["identified"]["shape_rms"] for r in runs])
    f_std, z_std, s_std = (np.sqrt(np.nanmean(a ** 2, axis=0)) for a in (fe, ze, se))
    for run in runs:
        stated = with_std(run.pop("_data"), f_std, z_std, s_std)
        Hn, sigma = run.pop("_H")
        for fam in families:
            run[fam]["ema+std"] = update_modes(dm, stated, fam)
            if frf:
                run[fam]["frf-update"] = update_frf(dm, f_hz, Hn, sigma, fam)
                log(f"level {level:g} seed {run['seed']}: {fam} frf-update {run[fam]['frf-update'].get('values')}")
    return {"level": level, "runs": runs, "families": list(families), "true_modes": {"frequency_hz": f0.tolist(), "damping_ratio": z0.tolist()},
            "stated": {"std_frequency": f_std.tolist(), "std_damping_ratio": z_std.tolist(), "std_shape": s_std.tolist()}}


def summarise(level: dict) -> dict:
    """Per family, route and parameter: n, failures, mean, bias %, scatter %, RMS z, seeds on a
    bound; per mode: the identified damping ratio's bias and scatter (% of true)."""
    out: dict = {"routes": {}, "modes": []}
    z0 = np.array(level["true_modes"]["damping_ratio"])
    zeta = np.array([[np.nan if z is None else z for z in r["identified"]["zeta"]] for r in level["runs"]])
    fe = np.array([r["identified"]["f_rel_error"] for r in level["runs"]])
    for k in range(z0.size):
        out["modes"].append({"mode": k + 1, "f_hz": level["true_modes"]["frequency_hz"][k], "zeta_true": float(z0[k]),
                             "zeta_bias_pct": float(100 * (np.nanmean(zeta[:, k]) / z0[k] - 1)),
                             "zeta_scatter_pct": float(100 * np.nanstd(zeta[:, k], ddof=1) / z0[k]) if len(zeta) > 1 else None,
                             "f_rms_error_pct": float(100 * np.sqrt(np.mean(fe[:, k] ** 2)))})
    for fam, route in ((f, r) for f in level.get("families", ["dampers"]) for r in ROUTES):
        truth = FAMILIES[fam][0]
        rows = [r[fam][route] for r in level["runs"] if route in r.get(fam, {})]
        if not rows:
            continue
        ok = [r for r in rows if r.get("success")]
        per = {}
        for name, true in truth.items():
            v = np.array([r["values"][name] for r in ok])
            s = [r["std"][name] for r in ok]
            z = np.array([(vi - true) / si for vi, si in zip(v, s) if si])
            per[name] = {"true": true, "mean": float(v.mean()) if v.size else None,
                         "bias_pct": float(100 * (v.mean() / true - 1)) if v.size else None,
                         "scatter_pct": float(100 * v.std(ddof=1) / true) if v.size > 1 else None,
                         "rms_z": float(np.sqrt(np.mean(z ** 2))) if z.size else None,
                         "no_std": int(sum(si is None for si in s))}
        out["routes"][f"{fam}/{route}"] = {"n": len(rows), "failed": len(rows) - len(ok), "parameters": per}
    return out


def _f(v, spec: str, unit: str = "") -> str:
    return "–" if v is None or (isinstance(v, float) and not math.isfinite(v)) else format(v, spec) + unit


def markdown(results: dict) -> str:
    """The Markdown tables of a run: identification per mode, then the updates."""
    lines = ["| noise | mode | f [Hz] | ζ true | ζ bias (sdypy-EMA) | ζ scatter | f RMS error |", "|---|---|---|---|---|---|---|"]
    for lv in results["levels"]:
        for m in lv["summary"]["modes"]:
            lines.append(f"| {100 * lv['level']:g} % | {m['mode']} | {m['f_hz']:.1f} | {m['zeta_true']:.4f} | "
                         f"{_f(m['zeta_bias_pct'], '+.1f', ' %')} | {_f(m['zeta_scatter_pct'], '.1f', ' %')} | "
                         f"{_f(m['f_rms_error_pct'], '.3f', ' %')} |")
    lines += ["", "| noise | family/route | seeds (failed) | parameter | mean | bias | scatter | RMS z | no std |",
              "|---|---|---|---|---|---|---|---|---|"]
    for lv in results["levels"]:
        for route, r in lv["summary"]["routes"].items():
            for name, p in r["parameters"].items():
                lines.append(f"| {100 * lv['level']:g} % | {route} | {r['n']} ({r['failed']}) | {name} | "
                             f"{_f(p['mean'], '.4g')} | {_f(p['bias_pct'], '+.2f', ' %')} | "
                             f"{_f(p['scatter_pct'], '.2f', ' %')} | {_f(p['rms_z'], '.2f')} | {p['no_std']} |")
    return "\n".join(lines)


def run(levels=(0.01, 0.05), seeds: int = 20, first_seed: int = 0, frf: bool = True, order: int = 30,
        log=print, families=tuple(FAMILIES)) -> dict:
    """Every level at ``seeds`` seeds; the results as one JSON-ready dict."""
    dm = truss()
    H = exact_receptances(dm, band())
    out = {"families": {f: {"truth": FAMILIES[f][0], "start": FAMILIES[f][1]} for f in families}, "band_hz": BAND_HZ, "drive": DRIVE, "order": order, "levels": []}
    for level in levels:
        lv = run_level(dm, H, level, range(first_seed, first_seed + seeds), frf, order, log, families)
        lv["summary"] = summarise(lv)
        out["levels"].append(lv)
    return out


def _parse(argv):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--levels", nargs="*", type=float, default=[0.01, 0.05], help="noise levels (fractions of the RMS)")
    ap.add_argument("--seeds", type=int, default=20, help="seeds per level")
    ap.add_argument("--first-seed", type=int, default=0)
    ap.add_argument("--order", type=int, default=30, help="highest LSCF polynomial order")
    ap.add_argument("--no-frf", action="store_true", help="leave out the frf-update route")
    ap.add_argument("--families", nargs="*", default=list(FAMILIES), choices=list(FAMILIES))
    ap.add_argument("--quick", action="store_true", help="2 seeds, no frf-update")
    ap.add_argument("--output", default=None)
    a = ap.parse_args(argv)
    if a.quick:
        a.seeds, a.no_frf = 2, True
    return a


def main(argv=None) -> int:
    a = _parse(argv)
    res = run(a.levels, a.seeds, a.first_seed, not a.no_frf, a.order, log=lambda s: print(s, file=sys.stderr, flush=True),
              families=tuple(a.families))
    res["command"] = "python benchmarks/bench_damping.py " + " ".join(sys.argv[1:] if argv is None else argv)
    print(markdown(res))
    sys.path.insert(0, str(HERE))
    from _probes import save_json

    save_json(res, Path(a.output) if a.output else HERE / "results" / "bench_damping.json")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
