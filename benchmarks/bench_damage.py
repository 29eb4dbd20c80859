"""Benchmark: element-level damage detection on a lattice truss of thousands of elements.

Usage::

    python benchmarks/bench_damage.py            # 30 x 40-node lattice: 2,340 dofs, 4,563 element stiffnesses
    python benchmarks/bench_damage.py --quick    # 6 x 6 nodes: 60 dofs, 105 elements (smoke test)
    python benchmarks/bench_damage.py --size NX NY

The model: :func:`femupdate.generators.truss_lattice` (plane X-braced steel truss pinned at its
base) turned by :func:`femupdate.damage.element_parameters` into one stiffness parameter per
rod.  The "measured" damaged structure: one diagonal a fifth of the way up the parameter list
loses 40 % of its stiffness; its lowest 8 modes are taken at the x and y dofs of every node with
an even id (about half the dofs), with 0.01 % frequency and shape noise (``--noise`` to change).

One run measures, on one model,

(b) the baseline: ONE eigensolution of the baseline model, ``model_modes(model, n_modes=16)``;
(s) the cost of ONE Gauss-Newton iteration of sensitivity-based updating with every element
    stiffness unknown (what iterative updating would need at each step): the eigenvalue and
    measured-shape sensitivities of the 8 modes for all L parameters,
    ``femupdate.sensitivity.jacobian(..., method="auto")``;
(f) femupdate's detection ``detect_damage(bootstrap=0)``, with one expansion (f1) and with the
    default three (f3): SEREP expansion, projected sparse equations, noise weighting (Monte
    Carlo), the L1 path with BIC, debiasing, and the Tikhonov (GCV) comparison;

and reports the ratios f1/b and s/f1, and checks that the damaged diagonal is located first and
its loss estimated (f3) within 0.05.  The machine is shared: the load average is recorded with
the timings.  Results go to ``benchmarks/results/bench_damage.json`` (``_quick`` with ``--quick``).
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
if (HERE.parent / "src" / "femupdate").is_dir():
    sys.path.insert(0, str(HERE.parent / "src"))
from _probes import Phase, write_results  # noqa: E402
from femupdate.damage import detect_damage, element_parameters  # noqa: E402
from femupdate.generators import truss_lattice  # noqa: E402
from femupdate.modal import model_modes  # noqa: E402
from femupdate.sensitivity import jacobian  # noqa: E402
from femupdate.testdata import MeasuredMode, TestData  # noqa: E402

FULL_SIZE = (30, 40)
QUICK_SIZE = (6, 6)
N_MODES = 8
LOSS = 0.4


def run(size, noise: float) -> dict:
    phases: dict = {}

    def record(name, ph, **extra):
        phases[name] = {"seconds": ph.seconds, "rss_peak_mb": ph.rss_peak, "load_average": os.getloadavg()[0], **extra}

    with Phase() as ph:
        st = truss_lattice(*size, parameters="none")
        model = element_parameters(st)[0].build()
    record("build", ph)
    names = model.parameter_names
    target = [n for n in names if n.count("-") == 1][len(names) // 5]
    # pick a diagonal: the first member at or after that position whose end nodes differ in both x and y
    xy = model.nodes
    for n in names[names.index(target):]:
        a, b = (int(v) for v in n.split(".")[1].split("-"))
        if xy[a][0] != xy[b][0] and xy[a][1] != xy[b][1]:
            target = n
            break
    sensors = [d for d in model.dofs if int(d.split(":")[0]) % 2 == 0]
    dam = model.values.copy()
    dam[model.parameter_index(target)] *= 1 - LOSS
    truth = model_modes(model, dam, n_modes=N_MODES)
    rng = np.random.default_rng(7)
    pos = model.dof_index(sensors)
    data = TestData(modes=tuple(
        MeasuredMode(truth.eigenvalues[r] * (1 + noise * rng.standard_normal()) ** 2, sensors,
                     truth.shapes[pos, r] / np.max(np.abs(truth.shapes[pos, r])) + noise * rng.standard_normal(len(sensors)))
        for r in range(N_MODES)))
    with Phase() as ph:
        modes = model_modes(model, n_modes=2 * N_MODES)
    record("b_eigensolution", ph, n_modes=2 * N_MODES)
    with Phase() as ph:
        sens = jacobian(model, modes, list(range(N_MODES)), sensors, method="auto")
    record("s_one_sensitivity_iteration", ph, method=sens.method, n_parameters=len(names))
    noise_model = {"frequency": max(noise, 1e-6), "shape": max(noise, 1e-6)}
    res = {}
    for it in (1, 3):
        with Phase() as ph:
            res[it] = detect_damage(model, data, bootstrap=0, iterations=it, noise=noise_model)
        record(f"f{it}_detect_{it}_expansion{'s' if it > 1 else ''}", ph)
    r1, r3 = res[1], res[3]
    b = phases["b_eigensolution"]["seconds"]
    s = phases["s_one_sensitivity_iteration"]["seconds"]
    f1 = phases["f1_detect_1_expansion"]["seconds"]
    est = r3.loss.get(target, float("nan"))
    return {
        "model": {"generator": f"truss_lattice{tuple(size)}, one stiffness per rod", "n_dofs": model.n_dofs,
                  "n_elements": len(names), "n_sensors": len(sensors), "n_modes": N_MODES, "damaged": target,
                  "loss": LOSS, "noise": noise},
        "phases": phases,
        "ratio": {"detect_over_eigensolution": f1 / b, "sensitivity_iteration_over_detect": s / f1},
        "result": {"located_1": r1.located[:5], "located_3": r3.located[:5], "estimated_loss_1": r1.loss.get(target),
                   "estimated_loss_3": est, "n_basis": r3.expansion["n_basis"],
                   "tikhonov_n_above_threshold": r3.tikhonov.get("n_above_threshold")},
        "checks": {"located": {"ok": bool(r3.located[:1] == [target] and abs(est - LOSS) < 0.05),
                               "located_first": r3.located[:1], "estimated_loss": est, "tolerance": 0.05}},
    }


def table(res: dict) -> str:
    m, ph = res["model"], res["phases"]
    out = [f"model: {m['generator']}: {m['n_dofs']} dofs, {m['n_elements']} element stiffnesses, {m['n_sensors']} sensors, "
           f"{m['n_modes']} modes; {m['damaged']} loses {m['loss'] * 100:g} %; noise {m['noise']:g}", ""]
    out.append(f"{'phase':52s} {'time s':>9s} {'RSS peak MB':>12s} {'load':>6s}")
    for key, p in ph.items():
        out.append(f"{key:52s} {p['seconds']:9.2f} {p['rss_peak_mb']:12.1f} {p['load_average']:6.2f}")
    r, c = res["ratio"], res["checks"]["located"]
    out += ["", f"detect (1 expansion) / one eigensolution = {r['detect_over_eigensolution']:.1f};  "
                f"one sensitivity iteration / detect = {r['sensitivity_iteration_over_detect']:.2f}",
            f"located first: {c['located_first']}, estimated loss {c['estimated_loss']:.3f} (true {m['loss']}) "
            f"({'OK' if c['ok'] else 'FAIL'}); 1 expansion: {res['result']['located_1']} "
            f"loss {res['result']['estimated_loss_1']}"]
    return "\n".join(out)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help=f"small lattice {QUICK_SIZE} (smoke test)")
    ap.add_argument("--size", type=int, nargs=2, metavar=("NX", "NY"))
    ap.add_argument("--noise", type=float, default=1e-4, help="relative frequency and shape noise")
    ap.add_argument("--output", type=Path, help="JSON file (default benchmarks/results/bench_damage[_quick].json)")
    args = ap.parse_args(argv)
    size = tuple(args.size) if args.size else (QUICK_SIZE if args.quick else FULL_SIZE)
    res = run(size, args.noise)
    write_results(res, "bench_damage", args.quick, args.output, table, argv)
    return 0 if res["checks"]["located"]["ok"] else 1


if __name__ == "__main__":
    sys.exit(main())
