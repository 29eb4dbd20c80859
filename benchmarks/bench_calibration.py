"""Benchmark: do femupdate's confidence statements hold over noise seeds? (issue 27, item 7; no
wall-clock figures).

Usage::

    python benchmarks/bench_calibration.py                          # 200 / 50 seeds (the issue's sizes)
    python benchmarks/bench_calibration.py --seeds 20 --damage-seeds 10 --families chain
    python benchmarks/bench_calibration.py --quick                  # 3 / 2 seeds, every family

Families (the updated model is built by :mod:`femupdate.generators`):

* ``chain``  — a shear building of 8 storeys (``shear_building``, 8 storey stiffnesses updated),
  6 modes at every floor;
* ``planar`` — a planar frame, 3 bays x 3 storeys in one plane (``frame_lattice(4, 1, 4)``, 3
  storey moduli), 6 modes at the translations (x, y, z) of the nodes above the base (its lowest
  modes include out-of-plane ones, which in-plane sensors alone would not see);
* ``space``  — a space frame, 2 x 2 bays x 3 storeys (``frame_lattice(2, 2, 4)``, plan 1 x 1.4 m,
  3 storey moduli), 6 modes at the 24 horizontal dofs above the base;
* ``model-error`` — the chain's structure holds a grounded spring at the top floor (5.5 % of the
  top storey's stiffness) that the updated model lacks.

Test data by a second route: the true structure's stiffness and mass are assembled (by hand for
the chains, by the model's own assembly for the frames) and solved here by
:func:`scipy.linalg.eigh` (not femupdate's modal solver); noise is added here: 1 % on the
frequencies, 3 % of the RMS entry on the unit-length shapes, stated as their standard deviations
(setting ``stated``) or not at all (``estimated``).  True values: the nominal values times fixed
factors (0.9 ... 1.1).

Per family and setting, over ``--seeds`` seeds: ``update`` and the Laplace ``posterior``
(``sampler="laplace"``, one start) — coverage of the 68 % and 95 % intervals pooled over
parameters (update: its Student-t intervals; posterior: its 95 % interval and median ± 0.9945 std
for 68 %), each against the binomial 99 % band around 68 % and 95 % (the parameters of one seed
taken as independent: an approximation), the RMS z-score, and the fraction of seeds the test of
the fit flags a model error (target >= 90 % in the model-error family with the noise stated; in
the others at most the binomial 99 % bound at alpha 0.01).  ``--distinct-seeds`` seeds per family
and setting run ``multistart`` (``--starts`` starts): the truth is one minimum, so the count of
fitting distinct solutions should be 1 (no split of one minimum).

``damage`` (``--damage-seeds`` seeds, bootstrap ``--bootstrap`` replicates each) on a 5-spring
chain with k3 at 60 % (measured at dofs 1, 3, 4, 5, 4 modes, 0.5 % / 1 % of the largest entry
noise, shapes scaled to 1 at their largest entry as :func:`femupdate.damage.examples.noisy_modes`
does): RMS z-score of the located true change (target <= 1.3) and, on as many healthy data
sets, the observed false-positive rate (any unknown located) against the mean quoted rate (within
the binomial 99 % band around the quoted rate).

The table is printed as Markdown and written to ``benchmarks/results/bench_calibration.json``
(``--output``).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import sys
from pathlib import Path

import numpy as np
from scipy import linalg, stats

HERE = Path(__file__).resolve().parent
if (HERE.parent / "src" / "femupdate").is_dir():  # benchmark the checked-out source tree
    sys.path.insert(0, str(HERE.parent / "src"))

import femupdate as fu  # noqa: E402
from femupdate.generators import frame_lattice, shear_building  # noqa: E402
from femupdate.testdata import MeasuredMode, TestData  # noqa: E402

FREQ_NOISE, SHAPE_NOISE = 0.01, 0.03
Z68 = stats.norm.ppf(0.5 + 0.6827 / 2)
FAMILIES = ("chain", "planar", "space", "model-error")
SETTINGS = ("stated", "estimated")
CHAIN_K = np.array([2e6, 1.8e6, 1.7e6, 1.5e6, 1.4e6, 1.2e6, 1.0e6, 0.9e6])
CHAIN_FACTORS = np.array([1.1, 0.9, 1.05, 0.95, 1.0, 1.1, 0.9, 1.0])
MASS = 1000.0
MISSING_SPRING = 5e4


def binomial_band(p: float, n: int, level: float = 0.99) -> tuple[float, float]:
    """The central ``level`` band of the fraction of successes in ``n`` Bernoulli(p) trials."""
    if n <= 0:
        return (math.nan, math.nan)
    a = (1 - level) / 2
    lo, hi = stats.binom.ppf([a, 1 - a], n, p)
    return float(lo) / n, float(hi) / n


@dataclasses.dataclass(frozen=True)
class Family:
    """One structure family: the updated model, the true values, the true K and M (dense, on the
    model's dofs), the sensors and the number of modes."""

    name: str
    model: object
    true: np.ndarray
    K: np.ndarray
    M: np.ndarray
    sensors: tuple[str, ...]
    n_modes: int
    model_error: bool = False


def _chain_matrices(k: np.ndarray, m: float, top_spring: float = 0.0):
    n = k.size
    K = np.zeros((n, n))
    for i, ki in enumerate(k):
        K[i, i] += ki
        if i:
            K[i - 1, i - 1] += ki
            K[i - 1, i] -= ki
            K[i, i - 1] -= ki
    K[-1, -1] += top_spring
    return K, m * np.eye(n)


def _frame(name: str, nx: int, ny: int, nz: int, spacing, sensor_dirs) -> Family:
    model = frame_lattice(nx, ny, nz, spacing=spacing).build()
    true = np.array([0.9, 1.1, 0.95]) * model.values
    base = {str(1 + i) for i in range(nx * ny)}
    sensors = tuple(d for d in model.dofs if d.split(":")[1] in sensor_dirs and d.split(":")[0] not in base)
    return Family(name, model, true, model.K(true).toarray(), model.M(true).toarray(), sensors, 6)


def make_family(name: str) -> Family:
    """The family ``name`` (one of :data:`FAMILIES`)."""
    if name in ("chain", "model-error"):
        model = shear_building(8, k=list(CHAIN_K), m=MASS).build()
        true = CHAIN_K * CHAIN_FACTORS
        K, M = _chain_matrices(true, MASS, MISSING_SPRING if name == "model-error" else 0.0)
        return Family(name, model, true, K, M, tuple(model.dofs), 6, name == "model-error")
    if name == "planar":
        return _frame(name, 4, 1, 4, 1.0, ("x", "y", "z"))
    if name == "space":
        return _frame(name, 2, 2, 4, (1.0, 1.4, 1.0), ("x", "y"))
    raise SystemExit(f"unknown family {name!r}: choose from {', '.join(FAMILIES)}")


def _true_modes(fam: Family):
    lam, phi = linalg.eigh(fam.K, fam.M, subset_by_index=[0, fam.n_modes - 1])
    pos = [fam.model.dofs.index(d) for d in fam.sensors]
    return lam, phi[pos]


def make_data(fam: Family, seed: int, stated: bool, modes=None) -> TestData:
    """Noisy measured modes of the true structure (scipy's eigh; noise added here)."""
    lam, phi = modes if modes is not None else _true_modes(fam)
    rng = np.random.default_rng(seed)
    out = []
    for k in range(fam.n_modes):
        f = math.sqrt(lam[k]) / (2 * math.pi) * (1 + FREQ_NOISE * rng.normal())
        shape = phi[:, k] / np.linalg.norm(phi[:, k])
        rms = math.sqrt(float(np.mean(shape**2)))
        shape = shape + SHAPE_NOISE * rms * rng.normal(size=shape.size)
        m = MeasuredMode.from_frequency(f, list(fam.sensors), shape,
                                        **({"std_frequency": FREQ_NOISE} if stated else {}))
        if stated:  # in the units of the unit-scaled shape the residuals compare
            m = dataclasses.replace(m, std_shape=SHAPE_NOISE * rms / float(np.linalg.norm(shape)))
        out.append(m)
    return TestData(modes=tuple(out))


def _summary(z, in68, in95, flagged) -> dict:
    z, in68, in95 = np.asarray(z, float), np.asarray(in68, bool), np.asarray(in95, bool)
    n = int(in68.size)
    b68, b95 = binomial_band(0.6827, n), binomial_band(0.95, n)
    c68, c95 = float(in68.mean()) if n else math.nan, float(in95.mean()) if n else math.nan
    return {"n": n, "seeds": len(flagged), "coverage68": c68, "band68": b68, "pass68": b68[0] <= c68 <= b68[1],
            "coverage95": c95, "band95": b95, "pass95": b95[0] <= c95 <= b95[1],
            "rms_z": math.sqrt(float(np.mean(z**2))) if n else math.nan,
            "flagged": float(np.mean(flagged)) if flagged else math.nan, "flagged_count": int(sum(flagged))}


def run_update(fam: Family, stated: bool, seeds: range) -> dict:
    """``update`` over seeds: errors against its standard deviations and intervals."""
    modes = _true_modes(fam)
    z, in68, in95, flagged, failed = [], [], [], [], 0
    for seed in seeds:
        try:
            res = fu.update(fam.model, make_data(fam, 1000 + seed, stated, modes))
        except Exception:  # noqa: BLE001 - a failed run is counted, never hidden
            failed += 1
            continue
        d = res.diagnostics
        err = np.abs(res.x - fam.true)
        z.extend(err / d.std)
        in68.extend(err <= d.interval(0.6827))
        in95.extend(err <= d.interval(0.95))
        flagged.append(d.model_error["verdict"] == "model error")
    return {**_summary(z, in68, in95, flagged), "failed": failed}


def run_posterior(fam: Family, stated: bool, seeds: range) -> dict:
    """The Laplace ``posterior`` over seeds: its median, standard deviations and 95 % interval."""
    modes = _true_modes(fam)
    z, in68, in95, flagged, failed = [], [], [], [], 0
    for seed in seeds:
        try:
            res = fu.posterior(fam.model, make_data(fam, 2000 + seed, stated, modes), sampler="laplace", starts=1,
                               seed=1)
        except Exception:  # noqa: BLE001
            failed += 1
            continue
        med = np.array([res.median[n] for n in res.names])
        sd = np.array([res.std[n] for n in res.names])
        iv = np.array([res.interval[n] for n in res.names])
        z.extend((med - fam.true) / sd)
        in68.extend(np.abs(med - fam.true) <= Z68 * sd)
        in95.extend((iv[:, 0] <= fam.true) & (fam.true <= iv[:, 1]))
        flagged.append(res.noise["model_error"]["verdict"] == "model error")
    return {**_summary(z, in68, in95, flagged), "failed": failed}


def run_distinct(fam: Family, stated: bool, seeds: range, starts: int) -> dict:
    """``multistart`` over seeds: the count of distinct solutions that fit (the truth: one)."""
    modes = _true_modes(fam)
    counts = []
    for seed in seeds:
        try:
            ms = fu.multistart(fam.model, make_data(fam, 3000 + seed, stated, modes), starts=starts)
            counts.append(len(ms.fitting))
        except Exception:  # noqa: BLE001
            counts.append(-1)
    return {"seeds": len(counts), "starts": starts, "counts": counts, "truth": 1,
            "pass": bool(counts) and all(c == 1 for c in counts)}


# ----------------------------------------------------------------------------- damage
DAMAGE_K = np.array([1000.0, 1200.0, 900.0, 1100.0, 1000.0])
DAMAGE_M = np.array([1.0, 1.1, 0.9, 1.0, 1.2])
DAMAGE_SENSORS = ("1:x", "3:x", "4:x", "5:x")
DAMAGE_NOISE = {"frequency": 0.005, "shape": 0.01}


def _damage_data(model, k: np.ndarray, seed: int) -> TestData:
    """4 modes of the chain with stiffnesses ``k`` (scipy's eigh), shapes scaled to 1 at their
    largest entry, noise added here as noisy_modes does it."""
    K, _ = _chain_matrices(k, 1.0)
    lam, phi = linalg.eigh(K, np.diag(DAMAGE_M), subset_by_index=[0, 3])
    pos = [model.dofs.index(d) for d in DAMAGE_SENSORS]
    rng = np.random.default_rng(seed)
    out = []
    for r in range(4):
        sh = phi[pos, r] / phi[pos, r][np.argmax(np.abs(phi[pos, r]))]
        lr = lam[r] * (1 + DAMAGE_NOISE["frequency"] * rng.standard_normal()) ** 2
        out.append(MeasuredMode(float(lr), list(DAMAGE_SENSORS),
                                sh + DAMAGE_NOISE["shape"] * rng.standard_normal(sh.size), f"mode {r + 1}"))
    return TestData(modes=tuple(out))


def run_damage(stated: bool, seeds: range, bootstrap: int) -> dict:
    """``damage`` on k3 at 60 % (z of the located change) and on healthy data (false positives)."""
    from femupdate.damage import detect_damage
    from femupdate.examples import chain

    model = chain(list(DAMAGE_K), list(DAMAGE_M))
    names = list(model.parameter_names)
    damaged = DAMAGE_K.copy()
    damaged[2] *= 0.6
    noise = DAMAGE_NOISE if stated else None
    z, exact, quoted, hits, failed, not_estimable, bases = [], 0, [], 0, 0, 0, {}
    for seed in seeds:
        try:
            res = detect_damage(model, _damage_data(model, damaged, 200 + seed), noise=noise, bootstrap=bootstrap,
                                baseline_checked=True, seed=seed)
            healthy = detect_damage(model, _damage_data(model, DAMAGE_K, 5000 + seed), noise=noise,
                                    bootstrap=bootstrap, baseline_checked=True, seed=seed)
        except Exception:  # noqa: BLE001
            failed += 1
            continue
        exact += res.located == [names[2]]
        basis = res.confidence["noise"]["basis"]["frequency"]
        bases[basis] = bases.get(basis, 0) + 1
        if "conditional_on" in res.confidence:  # the frequency noise not estimable: its standard errors are conditional
            not_estimable += 1
        elif names[2] in res.located:
            z.append((res.changes[names[2]] + 0.4) / res.confidence["standard_error"][names[2]])
            log_seed = {"seed": seed, "z": z[-1], "frequency": res.confidence["noise"]["frequency"]}
            print(f"damage seed: {json.dumps(log_seed)}", file=sys.stderr, flush=True)
        quoted.append(healthy.confidence["false_positive_rate"]["rate"])
        hits += bool(healthy.located)
    n = len(quoted)
    q = float(np.mean(quoted)) if quoted else math.nan
    band = binomial_band(q, n) if n else (math.nan, math.nan)
    obs = hits / n if n else math.nan
    rms = math.sqrt(float(np.mean(np.square(z)))) if z else math.nan
    return {"seeds": n, "failed": failed, "bootstrap": bootstrap, "located_exact": exact, "z_count": len(z),
            "not_estimable": not_estimable, "frequency_basis": bases,
            "rms_z": rms, "pass_z": rms <= 1.3, "quoted_fp": q, "observed_fp": obs, "fp_band": band,
            "pass_fp": band[0] <= obs <= band[1]}


# ----------------------------------------------------------------------------- table
def _pf(ok: bool) -> str:
    return "pass" if ok else "FAIL"


def _row(family: str, setting: str, what: str, s: dict, model_error: bool) -> str:
    if model_error:
        flag = f"{s['flagged']:.2f} ({_pf(s['flagged'] >= 0.9) if setting == 'stated' else 'info'})"
        cov = "n/a (model error)"
        return (f"| {family} | {setting} | {what} | {s['seeds']} | {cov} | {cov} | {s['rms_z']:.2f} | {flag} |")
    lim = stats.binom.ppf(0.99, max(s["seeds"], 1), 0.01) / max(s["seeds"], 1)
    flag = f"{s['flagged']:.2f} ({_pf(s['flagged'] <= lim)})"
    c68 = f"{s['coverage68']:.3f} [{s['band68'][0]:.3f}, {s['band68'][1]:.3f}] {_pf(s['pass68'])}"
    c95 = f"{s['coverage95']:.3f} [{s['band95'][0]:.3f}, {s['band95'][1]:.3f}] {_pf(s['pass95'])}"
    return f"| {family} | {setting} | {what} | {s['seeds']} | {c68} | {c95} | {s['rms_z']:.2f} | {flag} |"


def markdown(results: dict) -> str:
    """The Markdown tables of a run's results."""
    lines = ["| family | noise | run | seeds | 68 % coverage [99 % band] | 95 % coverage [99 % band] | RMS z "
             "| flagged model error |", "|---|---|---|---|---|---|---|---|"] if results["families"] else []
    for key, r in results["families"].items():
        fam, setting = key.split("/")
        for what in ("update", "posterior"):
            if what in r:
                lines.append(_row(fam, setting, what, r[what], fam == "model-error"))
    dist = [(k, r["distinct"]) for k, r in results["families"].items() if "distinct" in r]
    if dist:
        lines += ["", "| family / noise | seeds x starts | fitting distinct solutions (truth 1) | |", "|---|---|---|---|"]
        lines += [f"| {k} | {d['seeds']} x {d['starts']} | {d['counts']} | {_pf(d['pass'])} |" for k, d in dist]
    if results.get("damage"):
        lines += ["", "| damage, noise | seeds (bootstrap) | exact set | RMS z of located change (<= 1.3) "
                  "| false positives: quoted / observed [99 % band] |", "|---|---|---|---|---|"]
        for setting, d in results["damage"].items():
            ne = f" ({d['not_estimable']} not estimable)" if d.get("not_estimable") else ""
            lines.append(f"| {setting} | {d['seeds']} ({d['bootstrap']}) | {d['located_exact']} / {d['seeds']} | "
                         f"{d['rms_z']:.2f} over {d['z_count']}{ne} {_pf(d['pass_z'])} | {d['quoted_fp']:.3f} / "
                         f"{d['observed_fp']:.3f} [{d['fp_band'][0]:.3f}, {d['fp_band'][1]:.3f}] {_pf(d['pass_fp'])} |")
    return "\n".join(lines)


def run(families, seeds: int, damage_seeds: int, distinct_seeds: int = 3, starts: int = 4, bootstrap: int = 20,
        settings=SETTINGS, log=print, damage_first_seed: int = 0) -> dict:
    """Every family and setting at the sizes given; the results as one JSON-ready dict."""
    out: dict = {"sizes": {"seeds": seeds, "damage_seeds": damage_seeds, "distinct_seeds": distinct_seeds,
                           "starts": starts, "bootstrap": bootstrap}, "families": {}, "damage": {}}
    for name in families:
        fam = make_family(name)
        for setting in settings:
            stated = setting == "stated"
            r = {"update": run_update(fam, stated, range(seeds)),
                 "posterior": run_posterior(fam, stated, range(seeds))}
            if distinct_seeds and not fam.model_error:
                r["distinct"] = run_distinct(fam, stated, range(distinct_seeds), starts)
            out["families"][f"{name}/{setting}"] = r
            log(f"{name}/{setting}: update RMS z {r['update']['rms_z']:.2f}, posterior {r['posterior']['rms_z']:.2f}")
    if damage_seeds:
        for setting in settings:
            out["damage"][setting] = run_damage(setting == "stated", range(damage_first_seed,
                                                                         damage_first_seed + damage_seeds), bootstrap)
            log(f"damage/{setting}: {out['damage'][setting]}")
    return out


def _parse(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seeds", type=int, default=200, help="seeds per family and setting for update and posterior")
    ap.add_argument("--damage-seeds", type=int, default=50, help="seeds per setting for damage (0: none)")
    ap.add_argument("--damage-first-seed", type=int, default=0, help="first damage seed (to split a run over processes)")
    ap.add_argument("--distinct-seeds", type=int, default=5, help="seeds per family and setting for multistart")
    ap.add_argument("--starts", type=int, default=4, help="starts of each multistart")
    ap.add_argument("--bootstrap", type=int, default=20, help="damage's own bootstrap replicates")
    ap.add_argument("--families", nargs="*", default=list(FAMILIES), choices=FAMILIES,
                    help="families of the update and posterior runs (none: damage only)")
    ap.add_argument("--settings", nargs="*", default=list(SETTINGS), choices=SETTINGS,
                    help="noise settings to run (stated, estimated)")
    ap.add_argument("--quick", action="store_true", help="3 seeds, 2 damage seeds, 1 multistart seed")
    ap.add_argument("--output", default=None)
    a = ap.parse_args(argv)
    if a.quick:
        a.seeds, a.damage_seeds, a.distinct_seeds = 3, 2, 1
    return a


def main(argv=None) -> int:
    a = _parse(argv)
    res = run(a.families, a.seeds, a.damage_seeds, a.distinct_seeds, a.starts, a.bootstrap, settings=a.settings,
              damage_first_seed=a.damage_first_seed, log=lambda s: print(s, file=sys.stderr, flush=True))
    res["command"] = "python benchmarks/bench_calibration.py " + " ".join(sys.argv[1:] if argv is None else argv)
    print(markdown(res))
    path = Path(a.output) if a.output else HERE / "results" / "bench_calibration.json"
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(res, indent=1, default=lambda o: o.tolist() if hasattr(o, "tolist") else bool(o)))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
