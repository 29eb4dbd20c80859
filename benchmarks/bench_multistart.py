"""Benchmark: batched multi-start updating against a plain loop of SciPy least squares.

Usage::

    python benchmarks/bench_multistart.py            # 10-, 18- and 30-storey buildings, 100 starts each
    python benchmarks/bench_multistart.py --quick    # one 6-storey building, 12 starts (CI smoke test)
    python benchmarks/bench_multistart.py --sizes 10 18 --starts 50 --per-start

The problem, for each size N: a shear building (:func:`femupdate.generators.shear_building`)
with one stiffness parameter per storey, true stiffnesses decreasing with height
(``k_r = 2e7 (1 - 0.4 (r - 1)/(N - 1))`` N/m, floor masses 1e4 kg), bounds [0, 2] × the truth
(random starts over the whole range, as published model-updating benchmarks draw them);
noise-free "measured" modes: the lowest ``n_modes`` (4, 4, 6 for N = 10, 18, 30) at sensors on a
subset of the floors (5, 7, 10 floors, evenly spread from the first to the top: for N = 18 floors
1, 4, 7, 10, 12, 15, 18).  The same ``--starts`` random starts
(:func:`femupdate.updating.draw_starts`, one seed) are used by every route:

(f) ``femupdate.multistart(..., batched=True)`` with the default options — all starts advanced at
    once (:mod:`femupdate.updating.batched`), including clustering and the one polishing
    ``update()`` of the best; modes paired by the default ``auto`` policy;
(m) the same with ``pairing="mac"`` (the pairing before the ``auto`` policy: a start whose test
    mode pairs with no model mode at MAC >= 0.5 is abandoned) — outcomes only;
(a) the baseline: a plain Python loop of ``scipy.optimize.least_squares`` (trf, the same bounds,
    tolerances 1e-10, ``max_nfev=200``, ``x_scale="jac"``) with ``jac="2-point"`` on a residual
    function written here with NumPy and ``scipy.linalg.eigh`` — the same residual definition as
    femupdate's default (relative eigenvalue errors; unit-length measured shapes with the sign
    aligned), test and model modes paired by frequency order (the simplest script that keeps
    every start);
(p) optionally (``--per-start``) femupdate's own per-start path, ``multistart(..., batched=False)``.

Before the sizes, one tiny batched run loads femupdate's compiled code (numba's disk cache, or a
build of about 13 s on a fresh install); its time is reported as ``first_call_seconds``.
Reported per size: wall-clock and CPU (process) seconds of each route, the ratios a/f (target
>= 20; on a machine shared with other jobs the CPU-time ratio is the steadier figure), and the
outcome of every start in each route: converged to the truth (max relative parameter error
< 1e-6), converged elsewhere (a local minimum, typically on a bound), not converged, or failed
(target: at least 99 of 100 starts reach the truth in route f); and
whether the routes agree start by start (the same outcome and, for converged starts, the same
solution within 1e-4, multistart's clustering tolerance, with the largest difference recorded).

BLAS threads: the matrices here are 10x10 to 30x30, for which a multi-threaded BLAS only adds
synchronisation; on a loaded machine OpenBLAS' threads can slow small ``eigh`` calls by 10-100x.
The benchmark therefore pins the BLAS to ``--blas-threads`` (default 1) threads *before NumPy is
imported* — the same setting for every route; ``--blas-threads 0`` leaves the environment as
found.  Both the setting and the environment found are recorded.  Results go to
``benchmarks/results/bench_multistart.json`` (``bench_multistart_quick.json`` with ``--quick``).
"""

from __future__ import annotations

import argparse
import os
import sys


def _parse(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help="one 6-storey building, 12 starts (smoke test)")
    ap.add_argument("--sizes", type=int, nargs="+", default=None, help="numbers of storeys (default 10 18 30)")
    ap.add_argument("--starts", type=int, default=None, help="random starts per size (default 100)")
    ap.add_argument("--seed", type=int, default=2024)
    ap.add_argument("--per-start", action="store_true", help="also time femupdate's per-start path")
    ap.add_argument("--blas-threads", type=int, default=1, help="BLAS threads for every route (0: as found)")
    ap.add_argument("--output", default=None, help="JSON file (default benchmarks/results/bench_multistart[_quick].json)")
    return ap.parse_args(argv)


ARGS = _parse() if __name__ == "__main__" else None
ENV_FOUND = {k: os.environ.get(k) for k in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")}
if ARGS is not None and ARGS.blas_threads > 0:  # must precede the NumPy import
    for key in ENV_FOUND:
        os.environ[key] = str(ARGS.blas_threads)

import json  # noqa: E402
import platform  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
import scipy  # noqa: E402
import scipy.linalg as sla  # noqa: E402
from scipy.optimize import least_squares  # noqa: E402

HERE = Path(__file__).resolve().parent
if (HERE.parent / "src" / "femupdate").is_dir():  # benchmark the checked-out source tree
    sys.path.insert(0, str(HERE.parent / "src"))
import femupdate  # noqa: E402
from femupdate import MeasuredMode, TestData, model_modes  # noqa: E402
from femupdate.generators import shear_building  # noqa: E402
from femupdate.updating import draw_starts, multistart  # noqa: E402

N_MODES = {6: 3, 10: 4, 18: 4, 30: 6}  # measured modes per size
N_SENSORS = {6: 3, 10: 5, 18: 7, 30: 10}  # floors with a sensor, evenly spread
TRUTH_RTOL = 1e-6  # a start "reaches the truth" when every parameter is within this (relative)
AGREE_RTOL = 1e-4  # two routes reach "the same answer" within this (multistart's clustering tolerance);
# a local minimum with a nonzero residual is located only to ~1e-6 by the finite-difference Jacobian
TOL = 1e-10
MAX_NFEV = 200


# ------------------------------------------------------------------ the problem
def problem(n_storeys: int):
    """Model (nominal = truth, bounds ±50 %), test data, truth, sensor labels."""
    r = np.arange(n_storeys)
    k_true = 2.0e7 * (1.0 - 0.4 * r / max(n_storeys - 1, 1))
    model = shear_building(n_storeys, k=k_true, m=1.0e4, bounds=(0.0, 2.0)).build()
    n_modes = N_MODES.get(n_storeys, min(n_storeys, max(4, n_storeys // 5)))
    n_sensors = N_SENSORS.get(n_storeys, max(n_modes + 1, n_storeys // 3))
    floors = sorted(set(np.linspace(1, n_storeys, n_sensors).round().astype(int)))
    sensors = [f"{i}:x" for i in floors]
    mm = model_modes(model)
    pos = model.dof_index(sensors)
    data = TestData(modes=tuple(MeasuredMode(mm.eigenvalues[j], sensors, mm.shapes[pos, j]) for j in range(n_modes)))
    return model, data, k_true, sensors


class PlainResiduals:
    """The baseline's residual function: NumPy assembly, ``scipy.linalg.eigh``, pairing by order.

    x are the stiffnesses relative to ``p_ref``; residuals (λ_A − λ_E)/λ_E and ψ_A − ψ_E with ψ
    the measured-dof shape scaled to unit length (sign of the largest entry, then aligned with the
    test shape), as femupdate's default.
    """

    def __init__(self, model, data, p_ref):
        self.p_ref = np.asarray(p_ref, float)
        self.K0 = model.K0.toarray()
        self.Kj = np.stack([d.toarray() for d in model.dK])  # (L, n, n)
        self.M = model.M().toarray()
        self.lam_e = data.eigenvalues
        nt = len(data.modes)
        self.n_modes = nt
        self.pos = model.dof_index(data.modes[0].dofs)
        T = np.column_stack([m.shape for m in data.modes])
        T = T / np.linalg.norm(T, axis=0)
        k = np.argmax(np.abs(T), axis=0)
        self.T = T * np.sign(T[k, np.arange(nt)])

    def __call__(self, x):
        K = self.K0 + np.tensordot(x * self.p_ref, self.Kj, axes=1)
        lam, Phi = sla.eigh(K, self.M, subset_by_index=[0, self.n_modes - 1])
        S = Phi[self.pos]
        S = S / np.linalg.norm(S, axis=0)
        psi = S * np.sign(np.sum(S * self.T, axis=0))  # test mode r with model mode r
        return np.concatenate([(lam - self.lam_e) / self.lam_e, (psi - self.T).ravel(order="F")])


def run_baseline(model, data, X0, lo, hi):
    """(a): one scipy least_squares with a 2-point finite-difference Jacobian per start."""
    fun = PlainResiduals(model, data, model.values)
    out = []
    for x0 in X0:
        try:
            sol = least_squares(fun, x0 / fun.p_ref, jac="2-point", bounds=(lo / fun.p_ref, hi / fun.p_ref),
                                method="trf", x_scale="jac", ftol=TOL, xtol=TOL, gtol=TOL, max_nfev=MAX_NFEV)
            out.append({"x": sol.x * fun.p_ref, "success": bool(sol.success), "nfev": int(sol.nfev),
                        "cost": float(sol.cost)})
        except ArithmeticError as exc:
            out.append({"x": None, "success": False, "error": str(exc)})
    return out


def outcomes(runs, truth):
    """Classify each start: truth / other / not-converged / failed, with its solution."""
    cls, sols = [], []
    for r in runs:
        if r.get("x") is None:
            cls.append("failed")
            sols.append(None)
        elif not r["success"]:
            cls.append("not-converged")
            sols.append(r["x"])
        else:
            err = float(np.max(np.abs(r["x"] / truth - 1)))
            cls.append("truth" if err < TRUTH_RTOL else "other")
            sols.append(r["x"])
    return cls, sols


def ms_runs(ms):
    out = []
    for r in ms.runs:
        if isinstance(r, str):
            out.append({"x": None, "success": False, "error": r})
        else:
            out.append({"x": np.asarray(r.x, float), "success": bool(r.success), "nfev": int(r.nfev), "cost": float(r.cost)})
    return out


def agreement(ca, sa, cb, sb):
    """Start by start: the same outcome and, when both converged, the same solution (AGREE_RTOL)."""
    same, differ, max_rel = 0, [], 0.0
    for k, (a, b, xa, xb) in enumerate(zip(ca, cb, sa, sb)):
        ok = a == b and (xa is None) == (xb is None)
        if ok and xa is not None and a in ("truth", "other"):
            rel = float(np.max(np.abs(xa - xb) / np.abs(xb)))
            max_rel = max(max_rel, rel)
            ok = rel <= AGREE_RTOL
        same += ok
        if not ok:
            differ.append({"start": k, "a": a, "b": b})
    return same, differ, max_rel


def count(cls):
    return {c: cls.count(c) for c in ("truth", "other", "not-converged", "failed")}


def bench_size(n_storeys, n_starts, seed, per_start):
    model, data, k_true, sensors = problem(n_storeys)
    names = model.parameter_names
    X0 = draw_starts(model, names, n_starts, seed)
    lo, hi = model.bounds
    res = {"n_storeys": n_storeys, "n_dofs": model.n_dofs, "n_parameters": len(names), "n_test_modes": len(data.modes),
           "sensors": sensors, "starts": n_starts, "seed": seed}

    t, c = time.perf_counter(), time.process_time()
    ms = multistart(model, data, starts=n_starts, seed=seed, batched=True)
    t_f, c_f = time.perf_counter() - t, time.process_time() - c
    np.testing.assert_array_equal(ms.starts, X0)
    runs_f = ms_runs(ms)

    ms_m = multistart(model, data, starts=n_starts, seed=seed, batched=True, pairing="mac")
    cls_m, _ = outcomes(ms_runs(ms_m), k_true)
    res["outcomes_pairing_mac"] = count(cls_m)

    t, c = time.perf_counter(), time.process_time()
    runs_a = run_baseline(model, data, X0, lo, hi)
    t_a, c_a = time.perf_counter() - t, time.process_time() - c

    cls_f, sol_f = outcomes(runs_f, k_true)
    cls_a, sol_a = outcomes(runs_a, k_true)
    same, differ, max_rel = agreement(cls_f, sol_f, cls_a, sol_a)
    conv_f = [k for k, c in enumerate(cls_f) if c in ("truth", "other")]
    conv_a = [k for k, c in enumerate(cls_a) if c in ("truth", "other")]
    res["seconds"] = {"f_batched": t_f, "a_least_squares_2point": t_a}
    res["cpu_seconds"] = {"f_batched": c_f, "a_least_squares_2point": c_a}
    res["ratio_a_over_f"] = t_a / t_f
    res["cpu_ratio_a_over_f"] = c_a / c_f
    res["outcomes"] = {"f_batched": count(cls_f), "a_least_squares_2point": count(cls_a)}
    res["nfev_total"] = {"f_batched": int(sum(r.get("nfev", 0) for r in runs_f)),
                         "a_least_squares_2point": int(sum(r.get("nfev", 0) for r in runs_a))}
    res["agreement_f_a"] = {"same_outcome_and_answer": same, "of": n_starts, "differences": differ,
                            "max_rel_difference_converged": max_rel}
    res["every_converged_start_reaches_truth"] = {
        "f_batched": all(cls_f[k] == "truth" for k in conv_f), "a_least_squares_2point": all(cls_a[k] == "truth" for k in conv_a)}
    res["best"] = {"max_rel_error": float(np.max(np.abs(ms.best.x / k_true - 1))) if ms.best is not None else None,
                   "cost": ms.best.cost if ms.best is not None else None,
                   "condition_number": ms.best.diagnostics.condition_number if ms.best is not None else None}
    res["solutions"] = [{"count": s.count, "cost": s.cost,
                         "max_rel_error": float(np.max(np.abs(np.array(list(s.parameters.values())) / k_true - 1)))}
                        for s in ms.solutions]
    if per_start:
        t, c = time.perf_counter(), time.process_time()
        ms_p = multistart(model, data, starts=n_starts, seed=seed, batched=False)
        t_p, c_p = time.perf_counter() - t, time.process_time() - c
        cls_p, sol_p = outcomes(ms_runs(ms_p), k_true)
        same_p, differ_p, max_rel_p = agreement(cls_f, sol_f, cls_p, sol_p)
        res["seconds"]["p_per_start"] = t_p
        res["cpu_seconds"]["p_per_start"] = c_p
        res["ratio_p_over_f"] = t_p / t_f
        res["outcomes"]["p_per_start"] = count(cls_p)
        res["agreement_f_p"] = {"same_outcome_and_answer": same_p, "of": n_starts, "differences": differ_p,
                                "max_rel_difference_converged": max_rel_p}
    return res


def main(args) -> int:
    sizes = args.sizes or ([6] if args.quick else [10, 18, 30])
    n_starts = args.starts or (12 if args.quick else 100)
    out = Path(args.output) if args.output else HERE / "results" / ("bench_multistart_quick.json" if args.quick else "bench_multistart.json")
    results = {
        "benchmark": "bench_multistart", "quick": bool(args.quick),
        "environment": {
            "python": platform.python_version(), "numpy": np.__version__, "scipy": scipy.__version__,
            "femupdate": femupdate.__version__, "machine": platform.machine(), "cpu_count": os.cpu_count(),
            "load_average": list(os.getloadavg()) if hasattr(os, "getloadavg") else None,
            "blas_threads_set": args.blas_threads or None, "blas_env_found": ENV_FOUND,
        },
        "target_ratio_a_over_f": 20.0,
        "target_starts_reaching_truth": 99,
        "sizes": [],
    }
    # warm-up: the first batched call of a process loads femupdate's compiled code from numba's
    # disk cache (or compiles it, about 13 s, on a fresh install); timed and reported apart
    wm, wd, *_ = problem(4)
    t = time.perf_counter()
    multistart(wm, wd, starts=2, seed=0, batched=True)
    results["first_call_seconds"] = time.perf_counter() - t
    print(f"first batched call in this process (loads or builds the compiled code): {results['first_call_seconds']:.2f} s",
          flush=True)
    for n in sizes:
        r = bench_size(n, n_starts, args.seed, args.per_start)
        results["sizes"].append(r)
        sec = r["seconds"]
        print(f"N={n:3d}: batched {sec['f_batched']:.3f} s, least_squares 2-point {sec['a_least_squares_2point']:.3f} s, "
              f"ratio a/f = {r['ratio_a_over_f']:.1f} (CPU time {r['cpu_ratio_a_over_f']:.1f})"
              + (f", per-start {sec['p_per_start']:.3f} s (p/f = {r['ratio_p_over_f']:.1f})" if "p_per_start" in sec else "")
              + f"; outcomes f {r['outcomes']['f_batched']}, a {r['outcomes']['a_least_squares_2point']}, "
              f"f with pairing=mac {r['outcomes_pairing_mac']}; "
              f"agree {r['agreement_f_a']['same_outcome_and_answer']}/{n_starts}", flush=True)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(results, indent=2, default=float) + "\n")
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main(ARGS))
