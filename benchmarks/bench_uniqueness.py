"""Benchmark: the paper's full 6-dof uniqueness study, batched across cases, against a per-start loop.

Usage::

    python benchmarks/bench_uniqueness.py                 # 6 x 6 cases, 100 starts each (3,600 updates)
    python benchmarks/bench_uniqueness.py --quick         # 3 x 3 cases, 12 starts (CI smoke test)
    python benchmarks/bench_uniqueness.py --dask-workers 2

The study (``femupdate.uniqueness``): the six-spring chain of the paper section
``six_dof_uniqueness`` (k = 1000, 1800, 1500, 1200, 900, 1600 N/m; m = 1.0, 1.2, 0.8, 1.1, 0.9,
1.0 kg; bounds [100, 5000] N/m), every case "dofs 1..n measured × the lowest m modes" for
n, m = 1..6, ``--starts`` random starts per case (one seeded draw, the same for every case),
noise-free data.  Routes, on the same starts:

(f) ``run_study`` in this process: every case and start in ONE batch
    (:func:`femupdate.uniqueness.problem.study_problem`, every row run in compiled code),
    clustering and the condition numbers at the truth included;
(d) optionally (``--dask-workers W``) the same study split into W work units on a local Dask
    cluster of W worker processes, timed once the cluster is up (its start-up time is reported
    separately);
(a) the baseline: a plain Python loop of ``femupdate.update`` — one
    ``scipy.optimize.least_squares`` (trf, exact Nelson Jacobian, tolerances 1e-10,
    ``max_nfev=200``) per start and case — summarised by the same clustering.

Reported: wall-clock and CPU seconds of each route, the ratio a/f (and a/d), the 1 s target,
the load average before and after (the machine is shared), and the agreement: per case the same
verdict and the same distinct solutions (within the clustering tolerance 1e-4) — and per start
the same outcome (converged / local minimum / out of evaluations / failed), with every start that
differs listed with its evaluation counts (a start that needs close to ``max_nfev`` evaluations
can end on either side of the limit: the two routes agree to round-off, not bit for bit).

BLAS threads are pinned to ``--blas-threads`` (default 1) before NumPy is imported, for every
route (6×6 matrices gain nothing from threads).  Results go to
``benchmarks/results/bench_uniqueness.json`` (``bench_uniqueness_quick.json`` with ``--quick``).
"""

from __future__ import annotations

import argparse
import os
import sys


def _parse(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help="3 x 3 cases, 12 starts (smoke test)")
    ap.add_argument("--starts", type=int, default=None, help="random starts per case (default 100)")
    ap.add_argument("--seed", type=int, default=1994)
    ap.add_argument("--repeat", type=int, default=3, help="runs of the batched route (the best is reported)")
    ap.add_argument("--dask-workers", type=int, default=0, help="also run on a local Dask cluster of W processes")
    ap.add_argument("--no-baseline", action="store_true", help="skip the per-start loop")
    ap.add_argument("--blas-threads", type=int, default=1, help="BLAS threads for every route (0: as found)")
    ap.add_argument("--output", default=None, help="JSON file (default benchmarks/results/bench_uniqueness[_quick].json)")
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

HERE = Path(__file__).resolve().parent
if (HERE.parent / "src" / "femupdate").is_dir():  # benchmark the checked-out source tree
    sys.path.insert(0, str(HERE.parent / "src"))
import femupdate  # noqa: E402
from femupdate.updating.batched import FAILED  # noqa: E402
from femupdate.paper.uniqueness_sections import six_dof_model  # noqa: E402
from femupdate.uniqueness.study import (define_study, nested_dof_sets, reference_unit, run_study,  # noqa: E402
                                        summarise)

REL_TOL = 1e-4
COST_TOL = 1e-12


def _load():
    return list(os.getloadavg()) if hasattr(os, "getloadavg") else None


def _timed(fn):
    t, c = time.perf_counter(), time.process_time()
    out = fn()
    return out, time.perf_counter() - t, time.process_time() - c


def _outcome(status, cost):
    if status == FAILED:
        return "failed"
    if status == 0:
        return "not-converged"
    return "converged" if cost <= COST_TOL else "local-minimum"


def compare(study, raw_a, raw_b, cases_a, cases_b):
    """Per case: same verdict and distinct solutions; per start: same outcome (differences listed)."""
    per_case, differing_starts = [], []
    for c, (ca, cb) in enumerate(zip(cases_a, cases_b)):
        ra = next(p for p in raw_a if p["case"] == c and p["level"] == 0)
        rb = next(p for p in raw_b if p["case"] == c and p["level"] == 0)
        for k in range(study.n_starts):
            oa, ob = _outcome(ra["status"][k], ra["cost"][k]), _outcome(rb["status"][k], rb["cost"][k])
            if oa != ob:
                differing_starts.append({"case": f"{ca.case.n_measured}x{ca.case.n_modes}", "start": k, "batched": oa,
                                         "per_start": ob, "nfev_batched": ra["nfev"][k], "nfev_per_start": rb["nfev"][k]})
        pa = np.array([list(s.parameters.values()) for s in ca.solutions]).reshape(-1, len(study.names))
        pb = np.array([list(s.parameters.values()) for s in cb.solutions]).reshape(-1, len(study.names))
        matched = sum(any(np.all(np.abs(p - q) <= REL_TOL * np.abs(q)) for q in pb) for p in pa)
        per_case.append({"case": f"{ca.case.n_measured}x{ca.case.n_modes}", "verdict": [ca.verdict, cb.verdict],
                         "solutions": [len(ca.solutions), len(cb.solutions)], "matched_solutions": matched,
                         "same": ca.verdict == cb.verdict and len(ca.solutions) == len(cb.solutions) == matched})
    return per_case, differing_starts


def main(args) -> int:
    n_starts = args.starts or (12 if args.quick else 100)
    N = 3 if args.quick else 6
    model = six_dof_model()
    cases = [(d, m) for d in nested_dof_sets(model, N) for m in range(1, N + 1)]
    study = define_study(model, cases, starts=n_starts, seed=args.seed)
    out = Path(args.output) if args.output else HERE / "results" / ("bench_uniqueness_quick.json" if args.quick else "bench_uniqueness.json")
    res = {
        "benchmark": "bench_uniqueness", "quick": bool(args.quick),
        "environment": {
            "python": platform.python_version(), "numpy": np.__version__, "scipy": scipy.__version__,
            "femupdate": femupdate.__version__, "machine": platform.machine(), "cpu_count": os.cpu_count(),
            "blas_threads_set": args.blas_threads or None, "blas_env_found": ENV_FOUND, "load_average_before": _load(),
        },
        "study": {"cases": len(cases), "starts_per_case": n_starts, "updates": study.n_rows, "seed": args.seed,
                  "n_dofs": model.n_dofs, "unknowns": list(study.names)},
        "target_seconds_f": 1.0,
    }
    run_study(define_study(model, cases[:2], starts=2, seed=0))  # warm-up (imports, first calls)
    times = []
    for _ in range(max(1, args.repeat)):
        result, t, c = _timed(lambda: run_study(study))
        times.append((t, c))
    t_f, c_f = min(times)
    raw_f = result.raw
    res["seconds"] = {"f_batched": t_f, "f_batched_all_runs": [t for t, _ in times]}
    res["cpu_seconds"] = {"f_batched": c_f}
    res["verdicts"] = {f"{c.case.n_measured}x{c.case.n_modes}": [c.verdict, len(c.solutions)] for c in result.cases}
    print(f"(f) batched, in process: {t_f:.3f} s (CPU {c_f:.3f} s; runs {', '.join(f'{t:.3f}' for t, _ in times)}) "
          f"for {study.n_rows} updates; target 1 s", flush=True)
    if args.dask_workers:
        from dask.distributed import Client, LocalCluster

        split = define_study(model, cases, starts=n_starts, seed=args.seed,
                             unit_rows=-(-study.n_rows // args.dask_workers))
        t0 = time.perf_counter()
        with LocalCluster(n_workers=args.dask_workers, threads_per_worker=1, processes=True, host="127.0.0.1",
                          dashboard_address=None) as cluster, Client(cluster) as client:
            t_up = time.perf_counter() - t0
            client.run(lambda: __import__("femupdate.uniqueness.study"))
            dres, t_d, _ = _timed(lambda: run_study(split, scheduler=cluster.scheduler_address))
        same_d = [a.verdict == b.verdict and len(a.solutions) == len(b.solutions) for a, b in zip(result.cases, dres.cases)]
        res["seconds"]["d_dask"] = t_d
        res["seconds"]["d_dask_cluster_start"] = t_up
        res["dask"] = {"workers": args.dask_workers, "units": len(split.units()), "cases_same_as_f": int(sum(same_d))}
        print(f"(d) Dask, {args.dask_workers} workers: {t_d:.3f} s (+ {t_up:.2f} s cluster start); "
              f"{sum(same_d)}/{len(same_d)} cases as (f)", flush=True)
    if not args.no_baseline:
        raw_a, t_a, c_a = _timed(lambda: [reference_unit(study, c) for c in range(len(cases))])
        cases_a = summarise(study, raw_a, rel_tol=REL_TOL, cost_tol=COST_TOL)
        per_case, differing = compare(study, raw_f, raw_a, result.cases, cases_a)
        res["seconds"]["a_per_start_least_squares"] = t_a
        res["cpu_seconds"]["a_per_start_least_squares"] = c_a
        res["ratio_a_over_f"] = t_a / t_f
        res["cpu_ratio_a_over_f"] = c_a / c_f
        if "d_dask" in res["seconds"]:
            res["ratio_a_over_d"] = t_a / res["seconds"]["d_dask"]
        res["agreement"] = {"cases_same": int(sum(p["same"] for p in per_case)), "of": len(per_case),
                            "per_case": per_case, "starts_with_different_outcome": differing,
                            "starts_compared": study.n_rows}
        print(f"(a) per-start least_squares loop: {t_a:.2f} s (CPU {c_a:.2f} s); ratio a/f = {t_a / t_f:.1f} "
              f"(CPU {c_a / c_f:.1f}); cases identical {res['agreement']['cases_same']}/{len(per_case)}; "
              f"{len(differing)}/{study.n_rows} starts end differently: "
              + "; ".join(f"{d['case']} start {d['start']}: {d['batched']} ({d['nfev_batched']} ev.) vs "
                          f"{d['per_start']} ({d['nfev_per_start']} ev.)" for d in differing[:6]), flush=True)
    res["environment"]["load_average_after"] = _load()
    print(f"load average before {res['environment']['load_average_before']}, after {res['environment']['load_average_after']}")
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(res, indent=2, default=float) + "\n")
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main(ARGS))
