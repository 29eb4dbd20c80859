"""Benchmark: the identifiability plan's parameter errors against effective-independence and
kinetic-energy plans with the same sensor count, by Monte Carlo, on three structure families.

Usage::

    python benchmarks/bench_planning.py            # 400 noisy updates per plan and family
    python benchmarks/bench_planning.py --quick    # 6 per plan (smoke test)

Families (each with its parameters to identify, target modes, sensor count and noise):

* **spring chain** — the six-dof grounded chain of the paper's simulation (k1..k6), 3 target
  modes, 3 uniaxial sensors;
* **planar frame** — a two-bay, one-storey frame of beam2d elements, E of each of its three
  columns and two beams a parameter (5), 4 target modes, 4 uniaxial sensors (x or y);
* **plate** — a cantilever aluminium plate of shells, E in three zones root/middle/tip, 4 target
  modes, 4 uniaxial sensors (z only: the out-of-plane motion);
* **plate, 6 zones** — the same plate (6 × 4 shells), E in six zones (three spanwise bands split
  along the chord), 5 target modes, 5 z sensors: five frequencies cannot determine six
  parameters, so the shapes, hence the placement, matter.

For each, :func:`femupdate.planning.plan` places the sensors by identifiability (D-optimal after
the rank conditions) and, with the same count, by ``efi`` and ``kinetic``; each plan's noisy
tests are the same draws (same seed) of the stated noise, each updated by ``femupdate.update``
from the truth.  The comparison is paired (common random numbers): with the same seed and sensor
count every plan's run k uses the same standard-normal draws.  Reported per plan: its sensors,
rank, rms predicted relative std, the Monte Carlo rms relative parameter error (over parameters
and runs), and for the classical plans the ratio of their rms error to the identifiability
plan's with a paired percentile bootstrap 95 % interval (runs resampled jointly) and the share of
runs where the identifiability plan's error is the smaller; per family also the rms predicted
relative std from the frequencies alone (what no placement changes).  No timing is asserted; the
wall-clock seconds are recorded with the load average (the machine is shared).  Results go to
``benchmarks/results/bench_planning[_quick].json``, and the Markdown table is printed.
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
if (HERE.parent / "src" / "femupdate").is_dir():
    sys.path.insert(0, str(HERE.parent / "src"))
from _probes import write_results  # noqa: E402
import femupdate as fu  # noqa: E402
from femupdate.paper.uniqueness_sections import six_dof_model  # noqa: E402
import numpy as np  # noqa: E402
from femupdate.planning import plan  # noqa: E402
from femupdate.planning.fisher import Noise, SensitivityBank  # noqa: E402
from femupdate.planning.predict import monte_carlo, predicted_std  # noqa: E402


def planar_frame():
    """Two bays (4 m, 5 m), one storey (3.5 m), fixed feet; E of every member a parameter."""
    s = fu.Structure("two-bay planar frame")
    members = {"E_c1": [(0.0, 0.0), (0.0, 3.5)], "E_c2": [(4.0, 0.0), (4.0, 3.5)], "E_c3": [(9.0, 0.0), (9.0, 3.5)],
               "E_b1": [(0.0, 3.5), (4.0, 3.5)], "E_b2": [(4.0, 3.5), (9.0, 3.5)]}
    for name in members:
        s.parameter(name, 2.1e11, (1.0e11, 4.0e11))
    nodes: dict[tuple, int] = {}

    def node(p):
        key = (round(p[0], 9), round(p[1], 9))
        if key not in nodes:
            nodes[key] = len(nodes) + 1
            s.node(nodes[key], (p[0], p[1]))
        return nodes[key]

    n_el = 4
    for name, (a, b) in members.items():
        pts = [(a[0] + (b[0] - a[0]) * i / n_el, a[1] + (b[1] - a[1]) * i / n_el) for i in range(n_el + 1)]
        ids = [node(p) for p in pts]
        s.beam2d([[ids[i], ids[i + 1]] for i in range(n_el)], E=name, A=5e-3, I=2.0e-5 if name[2] == "c" else 3.5e-5,
                 rho=7850.0, where=name)
    s.support_node([nodes[(0.0, 0.0)], nodes[(4.0, 0.0)], nodes[(9.0, 0.0)]])
    return s.build()


def plate(nx=6, ny=3, a=0.6, b=0.35, zones=("E_root", "E_mid", "E_tip"), chord=1):
    """A cantilever aluminium plate of shells, E in ``len(zones)`` zones: ``len(zones) // chord``
    spanwise bands, each split into ``chord`` chordwise strips (nodes slightly skewed: no symmetry)."""
    s = fu.Structure("cantilever plate" if chord == 1 else f"cantilever plate, {len(zones)} zones")
    for name in zones:
        s.parameter(name, 7.0e10, (3.5e10, 1.4e11))
    n_span = len(zones) // chord

    def nid(i, j):
        return 1 + i + (nx + 1) * j

    for j in range(ny + 1):
        for i in range(nx + 1):
            s.node(nid(i, j), (a * i / nx, b * j / ny + 0.02 * (i / nx) ** 2, 0.0))
    for j in range(ny):
        for i in range(nx):
            zone = zones[chord * min(n_span - 1, n_span * i // nx) + min(chord - 1, chord * j // ny)]
            s.shell([nid(i, j), nid(i + 1, j), nid(i + 1, j + 1), nid(i, j + 1)], E=zone, nu=0.33, t=0.003, rho=2700.0)
    s.support_node([nid(0, j) for j in range(ny + 1)])
    return s.build()


def families():
    frame = planar_frame()
    pl = plate()
    pl6 = plate(nx=6, ny=4, zones=("E_r1", "E_r2", "E_m1", "E_m2", "E_t1", "E_t2"), chord=2)
    return [
        ("spring chain", six_dof_model(), dict(n_modes=3, n_sensors=3, candidates=None)),
        ("planar frame", frame, dict(n_modes=4, n_sensors=4,
                                     candidates=[d for d in frame.dofs if d.endswith((":x", ":y"))])),
        ("plate", pl, dict(n_modes=4, n_sensors=4, candidates=[d for d in pl.dofs if d.endswith(":z")])),
        ("plate, 6 zones", pl6, dict(n_modes=5, n_sensors=5, candidates=[d for d in pl6.dofs if d.endswith(":z")])),
    ]


PLANS = ("identifiability", "efi", "kinetic")


def paired(errors: dict, n_boot: int, seed: int) -> dict:
    """Paired comparison of the plans' per-run squared relative errors (the same noise draws, run
    by run): the ratio rms(classical) / rms(identifiability) with a percentile bootstrap 95 %
    interval (the runs resampled jointly for both plans), and the share of runs where the
    identifiability plan's error is the smaller."""
    rng = np.random.default_rng(seed)
    ref = errors["identifiability"]
    out = {}
    for crit in PLANS[1:]:
        if crit not in errors:
            continue
        e = errors[crit]
        idx = rng.integers(0, ref.size, size=(n_boot, ref.size))
        boot = np.sqrt(e[idx].mean(axis=1) / ref[idx].mean(axis=1))
        out[crit] = {"ratio": float(np.sqrt(e.mean() / ref.mean())),
                     "ci95": [float(np.percentile(boot, 2.5)), float(np.percentile(boot, 97.5))],
                     "identifiability_smaller": float(np.mean(ref < e))}
    return out


def run(runs: int, n_boot: int = 4000) -> dict:
    out: dict = {"runs": runs, "noise": {"eigenvalue": 0.002, "shape": 0.01}, "families": {}, "bootstrap": n_boot,
                 "load_average": {"start": os.getloadavg()}}
    noise = Noise(0.002, 0.01)
    for name, model, kw in families():
        t0 = time.perf_counter()
        res = plan(model, n_modes=kw["n_modes"], n_sensors=kw["n_sensors"], candidates=kw["candidates"], points=4,
                   monte_carlo=0, std_eigenvalue=0.002, std_shape=0.01, seed=1, tam="none")
        bank = SensitivityBank(model, model.dofs, res.target["indices"], res.parameters, res.nominal)
        # frequencies only: the information no placement changes (shape noise made huge)
        freq_only = predicted_std(bank, [], Noise(0.002, 1e6)) / np.abs(bank.parameter_values)
        plans = {"identifiability": {"sensors": res.sensors, "dofs": res.dofs, "rank": res.score["ranks"][0],
                                     "identifiable": res.score["identifiable"]}}
        for crit in PLANS[1:]:
            v = res.comparison.get(crit, {})
            plans[crit] = {"sensors": v.get("sensors"), "dofs": [d for s in v.get("sensors") or [] for d in s],
                           "rank": v.get("rank"), "identifiable": v.get("identifiable"), "error": v.get("error")}
        errors = {}
        for crit, r in plans.items():
            rows = [model.dofs.index(d) for d in r["dofs"]]
            std = predicted_std(bank, rows, noise) / np.abs(bank.parameter_values) if rows else None
            r["mean_relative_std"] = None if std is None else float(np.mean(std))
            r["rms_predicted_relative_std"] = None if std is None else float(np.sqrt(np.mean(std ** 2)))
            if r["rank"] != len(res.parameters):
                continue
            # the same seed and sensor count: the same standard-normal draws for every plan, run by run
            mc = monte_carlo(model, res.parameters, r["dofs"], bank, noise, runs, seed=1)
            rel = (mc["estimates"] - bank.parameter_values) / np.abs(bank.parameter_values)
            errors[crit] = np.mean(rel ** 2, axis=1)
            r["rms_relative_error"] = mc["rms_relative_error"]
            r["converged"] = mc["converged"]
        out["families"][name] = {"model": model.name, "n_dofs": model.n_dofs, "parameters": res.parameters,
                                 "target_hz": list(res.target["frequencies_hz"]), "n_sensors": kw["n_sensors"],
                                 "frequency_only_rms_relative_std": float(np.sqrt(np.mean(freq_only ** 2))),
                                 "plans": plans, "paired": paired(errors, n_boot, 7) if "identifiability" in errors else {},
                                 "seconds": time.perf_counter() - t0}
    out["load_average"]["end"] = os.getloadavg()
    return out


def table(out: dict) -> str:
    lines = ["| family (parameters, modes, sensors) | plan | sensors | rank | rms predicted relative std | "
             "Monte Carlo rms relative error | ratio to identifiability (95 % CI), runs where identifiability smaller |",
             "|---|---|---|---|---|---|---|"]
    for name, fam in out["families"].items():
        head = f"{name} ({len(fam['parameters'])}, {len(fam['target_hz'])}, {fam['n_sensors']})"
        for crit, r in fam["plans"].items():
            sens = "; ".join(",".join(s) for s in r["sensors"] or []) or (r.get("error") or "–")[:40]
            m = r["rms_predicted_relative_std"]
            mstd = "∞" if m is None or not math.isfinite(m) else f"{100 * m:.3g} %"
            mc = r.get("rms_relative_error")
            pr = fam["paired"].get(crit)
            ratio = "–" if pr is None else (f"{pr['ratio']:.3f} ({pr['ci95'][0]:.3f}–{pr['ci95'][1]:.3f}), "
                                            f"{100 * pr['identifiability_smaller']:.0f} %")
            lines.append(f"| {head} | {crit} | {sens} | {r['rank'] if r['rank'] is not None else '–'} | {mstd} | "
                         + (f"{100 * mc:.3g} % ({r['converged']}/{out['runs']} converged)" if mc is not None
                            else "refused" if r.get("error") else "not run (rank-deficient)") + f" | {ratio} |")
            head = ""
        f = fam["frequency_only_rms_relative_std"]
        lines.append("| | frequencies only (no placement) | – | – | "
                     + (f"{100 * f:.3g} %" if math.isfinite(f) else "∞ (rank-deficient)") + " | – | – |")
    return "\n".join(lines)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="6 noisy updates per plan (smoke test)")
    ap.add_argument("--runs", type=int, default=None, help="noisy updates per plan (default 400; 6 with --quick)")
    args = ap.parse_args()
    runs = args.runs or (6 if args.quick else 400)
    write_results(run(runs), "bench_planning", args.quick, None, table, None)


if __name__ == "__main__":
    main()
