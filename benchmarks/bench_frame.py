"""Benchmark: multi-start updating of a 2,304-dof 3-D frame building with massless rotations.

The problem.  A 12-storey space frame, 4 x 8 bays in plan (4 m x 4 m, storeys 3 m), of steel
tubes (:func:`femupdate.generators.frame_lattice` (4, 8, 13), ``parameters="storey"``): one
Young's modulus per storey, 12 stiffness groups, 2,304 free dofs.  The mass is lumped on the
translations only: the lumped member masses (ρAl/2 per end) are kept on x, y and z and the
rotary inertia is removed, so the 1,152 rotations are massless, as commercial codes export frame
models (the model is ``frame_lattice(...).build()`` with ``M0`` replaced by that diagonal).  The
sparse eigensolver works on the singular pencil as it is.  The test data are the lowest 3 modes
of the true model (the nominal one: E = 210 GPa in every storey), noise-free, at 40 translational
sensors: x and y of one corner and y of the opposite corner on every floor, and x of that corner
on floors 3, 6, 9 and 12.  The three modes lie within 7 % of each other (0.527, 0.556 and
0.563 Hz: two bending modes and torsion), which is what makes the pairing matter.

The starts.  ``--starts`` (default 100) random starts uniform within the bounds
[0.01, 2] x nominal for every storey modulus — ±99 % / +100 % about the truth
(:func:`femupdate.updating.draw_starts`, one seed).  A start *reaches the truth* when every
parameter is within 1e-6 (relative) of it.

The routes, in the same run, all with femupdate's default options (``pairing="auto"``,
``sensitivity="auto"``, which is the subspace series above 1,500 dofs, relative
parametrisation, trf, tolerances 1e-10):

(f) ``multistart(model, data, starts=N, seed=...)``: the per-start route (one :func:`update` per
    start) with ``reuse=True`` (the default): each model's factorisation workspace
    (:mod:`femupdate.workspace`: band Cholesky in the given order, chosen by its operation count
    against the sparse factor's, :func:`femupdate.workspace.band_wins`) and the eigensolver warm-started from the previous iterate (ARPACK's
    starting vector, shift 0.9 x the previous lowest eigenvalue, which also shortens the
    sensitivities' series); the starts run in local worker processes, one per core
    (:func:`femupdate.updating.starts.local_jobs`: two on this machine), as ``multistart`` does
    by default for models of 300 dofs or more;
(b) the baseline: the same ``multistart`` with ``reuse=False`` — femupdate's per-start route as
    it was before the workspace existed (the backend's factorisation afresh at every evaluation — CHOLMOD where
    scikit-sparse is installed, else SuperLU — shift 0, ARPACK from its fixed random vector; what does not depend on ``reuse``,
    the one series sweep for all modes and the kept Jacobian of the last point, serves both:
    measured apart, the code before any of it took the same time per start) — on the first
    ``--baseline-starts`` (default 10) of the same starts (``draw_starts`` fills row by row, so they are the same
    starting vectors; checked);
(d) optionally (``--dask``) route (f) on a local Dask cluster of two single-threaded workers
    (``dask.distributed.LocalCluster(n_workers=2, threads_per_worker=1)``) through
    femupdate's ``scheduler=`` option.

Reported: wall-clock and CPU seconds, seconds per start, the per-start speed-up b/f (wall and
CPU time; on a machine shared with other jobs the CPU-time ratio is the steadier figure), the
outcome of every start (truth / other / not converged / failed), and whether (f) and (b) agree
start by start on their common starts (the same outcome and solution within 1e-8).  With
``--profile`` (default on, off with ``--no-profile``), one extra start of each route is
profiled and the time split into the eigen-solution (factorisation, ARPACK), the
sensitivities (their series' solves) and the rest.  CPU time is this process's plus what each
local worker process recorded for its starts (for (d), the Dask workers' CPU is not in it: its
wall time is the figure).

BLAS threads are pinned to ``--blas-threads`` (default 1) before NumPy is imported (the
factorisations and solves are single-threaded kernels; a second BLAS thread only competes with
the other jobs of a 2-core machine).  Results go to ``benchmarks/results/bench_frame.json``
(``bench_frame_quick.json`` with ``--quick``: 6 starts, 3 baseline starts, for CI smoke).
"""

from __future__ import annotations

import argparse
import os
import sys


def _parse(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help="6 starts, 3 baseline starts (smoke test)")
    ap.add_argument("--starts", type=int, default=None, help="random starts (default 100)")
    ap.add_argument("--baseline-starts", type=int, default=None, help="starts of the reuse=False baseline (default 10)")
    ap.add_argument("--seed", type=int, default=2024)
    ap.add_argument("--dask", action="store_true", help="also run the starts on a local two-worker Dask cluster")
    ap.add_argument("--no-profile", action="store_true", help="skip the profile of one start per route")
    ap.add_argument("--blas-threads", type=int, default=1, help="BLAS threads (0: as found)")
    ap.add_argument("--output", default=None, help="JSON file (default benchmarks/results/bench_frame[_quick].json)")
    return ap.parse_args(argv)


ARGS = _parse() if __name__ == "__main__" else None
ENV_FOUND = {k: os.environ.get(k) for k in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")}
if ARGS is not None and ARGS.blas_threads > 0:  # must precede the NumPy import
    for key in ENV_FOUND:
        os.environ[key] = str(ARGS.blas_threads)

import cProfile  # noqa: E402
import dataclasses  # noqa: E402
import platform  # noqa: E402
import pstats  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
import scipy  # noqa: E402
import scipy.sparse as sp  # noqa: E402

HERE = Path(__file__).resolve().parent
if (HERE.parent / "src" / "femupdate").is_dir():  # benchmark the checked-out source tree
    sys.path.insert(0, str(HERE.parent / "src"))
    os.environ["PYTHONPATH"] = os.pathsep.join([str(HERE.parent / "src")] + [p for p in [os.environ.get("PYTHONPATH")] if p])
import femupdate  # noqa: E402
from femupdate import MeasuredMode, TestData, model_modes  # noqa: E402
from femupdate.generators import frame_lattice  # noqa: E402
from femupdate.updating import draw_starts, multistart, update  # noqa: E402

sys.path.insert(0, str(HERE))  # the shared probes
from _probes import count, multistart_cpu, outcomes, save_json  # noqa: E402

NX, NY, NZ = 4, 8, 13  # nodes in plan and levels: 12 storeys, 2,304 free dofs
SPACING = (4.0, 4.0, 3.0)
BOUNDS = (0.01, 2.0)  # relative to nominal (= truth)
N_MODES = 3
TRUTH_RTOL = 1e-6
AGREE_RTOL = 1e-8


# ------------------------------------------------------------------ the problem
def building():
    """The frame building with massless rotations (nominal = truth)."""
    m = frame_lattice(NX, NY, NZ, spacing=SPACING, mass="lumped", parameters="storey", bounds=BOUNDS).build()
    d = m.M(m.values).diagonal().copy()
    d[[lab.split(":")[1].startswith("r") for lab in m.dofs]] = 0.0  # no rotary inertia
    assert all(a is None or a.nnz == 0 for a in m.dM)  # storey moduli enter K only
    return dataclasses.replace(m, M0=sp.diags_array(d).tocsr(), name="frame building 4x8x12")


def sensors():
    """40 translational sensors: corner A (x, y) and the opposite corner C (y) on every floor,
    C (x) on floors 3, 6, 9, 12."""
    out = []
    for k in range(1, NZ):
        a = 1 + NX * NY * k
        c = a + (NX - 1) + NX * (NY - 1)
        out += [f"{a}:x", f"{a}:y", f"{c}:y"] + ([f"{c}:x"] if k % 3 == 0 else [])
    return out


def problem():
    model = building()
    s = sensors()
    mm = model_modes(model, n_modes=N_MODES + 3, reuse=False)
    pos = model.dof_index(s)
    data = TestData(modes=tuple(MeasuredMode(mm.eigenvalues[j], s, mm.shapes[pos, j]) for j in range(N_MODES)))
    return model, data, model.values.copy(), s, mm.frequencies_hz[:N_MODES + 3]


# ------------------------------------------------------------------ outcomes
def agreement(ca, sa, cb, sb):
    same, differ, max_rel = 0, [], 0.0
    for k, (a, b, xa, xb) in enumerate(zip(ca, cb, sa, sb)):
        ok = a == b and (xa is None) == (xb is None)
        if ok and xa is not None:
            rel = float(np.max(np.abs(xa - xb) / np.abs(xb)))
            max_rel = max(max_rel, rel)
            ok = rel <= AGREE_RTOL or a not in ("truth", "other")
        same += ok
        if not ok:
            differ.append({"start": k, "f": a, "b": b})
    return same, differ, max_rel


def timed(fn):
    t, c = time.perf_counter(), time.process_time()
    out = fn()
    return out, time.perf_counter() - t, time.process_time() - c


# ------------------------------------------------------------------ profile of one start
PROFILE_GROUPS = {
    # (file suffix, function name) -> group; cumulative times, outermost first
    "eigen-solution": [("modal.py", "solve_modes")],
    "  factorisation": [("workspace.py", "factor"), ("workspace.py", "factorize"), ("modal.py", "factorize")],
    "  ARPACK (with its solves)": [("arpack.py", "eigsh")],
    "sensitivities": [("jacobian.py", "jacobian")],
    "  series solves": [("factor.py", "solve")],
}


def profile_start(model, data, x0, reuse):
    names = model.parameter_names
    pr = cProfile.Profile()
    pr.enable()
    t = time.perf_counter()
    r = update(model, data, x0=dict(zip(names, x0)), reuse=reuse)
    total = time.perf_counter() - t
    pr.disable()
    st = pstats.Stats(pr).stats  # {(file, line, name): (cc, nc, tt, ct, callers)}
    out = {"total_seconds": total, "nfev": int(r.nfev), "njev": int(r.njev)}
    for group, keys in PROFILE_GROUPS.items():
        ct = 0.0
        for (fname, _, func), v in st.items():
            if any(fname.endswith(suf) and func == name for suf, name in keys):
                ct += v[3]
        out[group.strip()] = ct
    out["rest"] = total - out["eigen-solution"] - out["sensitivities"]
    return out


# ------------------------------------------------------------------ main
def main(args) -> int:
    n_starts = args.starts or (6 if args.quick else 100)
    n_base = min(args.baseline_starts or (3 if args.quick else 10), n_starts)
    out = Path(args.output) if args.output else HERE / "results" / ("bench_frame_quick.json" if args.quick else "bench_frame.json")
    model, data, truth, s, freqs = problem()
    names = model.parameter_names
    X0 = draw_starts(model, names, n_starts, args.seed)
    res = {
        "benchmark": "bench_frame", "quick": bool(args.quick),
        "environment": {
            "python": platform.python_version(), "numpy": np.__version__, "scipy": scipy.__version__,
            "femupdate": femupdate.__version__, "machine": platform.machine(), "cpu_count": os.cpu_count(),
            "load_average_before": list(os.getloadavg()) if hasattr(os, "getloadavg") else None,
            "blas_threads_set": args.blas_threads or None, "blas_env_found": ENV_FOUND,
        },
        "problem": {"n_dofs": model.n_dofs, "massless_dofs": int(np.sum(model.M().diagonal() == 0)),
                    "n_parameters": len(names), "n_test_modes": N_MODES, "n_sensors": len(s), "sensors": s,
                    "frequencies_hz": [float(f) for f in freqs], "bounds_relative": list(BOUNDS),
                    "starts": n_starts, "baseline_starts": n_base, "seed": args.seed,
                    "options": "femupdate defaults (pairing auto, sensitivity auto, trf, tolerances 1e-10)"},
        "target": {"truth_of_100": 97, "wall_seconds": 120.0},
    }

    ms_f, t_f, c_f = timed(lambda: multistart(model, data, starts=n_starts, seed=args.seed))
    np.testing.assert_array_equal(ms_f.starts, X0)
    ms_b, t_b, c_b = timed(lambda: multistart(model, data, starts=n_base, seed=args.seed, reuse=False))
    np.testing.assert_array_equal(ms_b.starts, X0[:n_base])
    c_f, jobs_f = multistart_cpu(ms_f, c_f, model)  # the local worker processes' CPU included
    c_b, jobs_b = multistart_cpu(ms_b, c_b, model)
    cls_f, sol_f = outcomes(ms_f, truth, TRUTH_RTOL)
    cls_b, sol_b = outcomes(ms_b, truth, TRUTH_RTOL)
    same, differ, max_rel = agreement(cls_f[:n_base], sol_f[:n_base], cls_b, sol_b)
    res["seconds"] = {"f_reuse": t_f, "b_per_start_no_reuse": t_b}
    res["cpu_seconds"] = {"f_reuse": c_f, "b_per_start_no_reuse": c_b}
    res["local_processes"] = {"f_reuse": jobs_f, "b_per_start_no_reuse": jobs_b}
    res["seconds_per_start"] = {"f_reuse": t_f / n_starts, "b_per_start_no_reuse": t_b / n_base}
    res["cpu_seconds_per_start"] = {"f_reuse": c_f / n_starts, "b_per_start_no_reuse": c_b / n_base}
    res["speedup_per_start_b_over_f"] = (t_b / n_base) / (t_f / n_starts)
    res["cpu_speedup_per_start_b_over_f"] = (c_b / n_base) / (c_f / n_starts)
    res["outcomes"] = {"f_reuse": count(cls_f), "b_per_start_no_reuse": count(cls_b)}
    res["nfev_per_start"] = {
        "f_reuse": float(np.mean([r.nfev for r in ms_f.runs if not isinstance(r, str)] or [0])),
        "b_per_start_no_reuse": float(np.mean([r.nfev for r in ms_b.runs if not isinstance(r, str)] or [0]))}
    res["agreement_f_b"] = {"same_outcome_and_answer": same, "of": n_base, "differences": differ,
                            "max_rel_difference": max_rel}
    res["f_solutions"] = [{"count": sol.count, "cost": sol.cost,
                           "max_rel_error": float(np.max(np.abs(np.array(list(sol.parameters.values())) / truth - 1)))}
                          for sol in ms_f.solutions]
    res["target_met_locally"] = bool(count(cls_f)["truth"] >= 0.97 * n_starts and t_f <= 120.0 * n_starts / 100)
    print(f"{model.n_dofs} dofs, {len(names)} parameters, {len(s)} sensors, {N_MODES} modes; {n_starts} starts", flush=True)
    print(f"(f) reuse:    {t_f:7.1f} s wall, {c_f:7.1f} s CPU, {t_f / n_starts:.3f} s/start ({jobs_f} processes); "
          f"outcomes {count(cls_f)}",
          flush=True)
    print(f"(b) no reuse: {t_b:7.1f} s wall, {c_b:7.1f} s CPU, {t_b / n_base:.3f} s/start over {n_base} starts "
          f"({jobs_b} processes); "
          f"outcomes {count(cls_b)}", flush=True)
    print(f"per-start speed-up b/f: {res['speedup_per_start_b_over_f']:.2f} wall, "
          f"{res['cpu_speedup_per_start_b_over_f']:.2f} CPU; agree on {same}/{n_base} common starts "
          f"(largest relative difference {max_rel:.1e})", flush=True)

    if not args.no_profile:
        x_extra = draw_starts(model, names, n_starts + 1, args.seed)[-1]  # a start of neither route
        res["profile_one_start"] = {"start": [float(v) for v in x_extra / truth],
                                    "f_reuse": profile_start(model, data, x_extra, True),
                                    "b_per_start_no_reuse": profile_start(model, data, x_extra, False)}
        for k in ("f_reuse", "b_per_start_no_reuse"):
            p = res["profile_one_start"][k]
            print(f"profile {k}: " + ", ".join(f"{g} {v:.3f}" if isinstance(v, float) else f"{g} {v}" for g, v in p.items()),
                  flush=True)

    if args.dask:
        from dask.distributed import LocalCluster

        with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
            ms_d, t_d, c_d = timed(lambda: multistart(model, data, starts=n_starts, seed=args.seed,
                                                      scheduler=cluster.scheduler_address))
        cls_d, sol_d = outcomes(ms_d, truth, TRUTH_RTOL)
        same_d, differ_d, max_rel_d = agreement(cls_f, sol_f, cls_d, sol_d)
        res["seconds"]["d_dask_2_workers"] = t_d
        res["cpu_seconds"]["d_dask_2_workers_client_only"] = c_d
        res["seconds_per_start"]["d_dask_2_workers"] = t_d / n_starts
        res["outcomes"]["d_dask_2_workers"] = count(cls_d)
        res["agreement_f_d"] = {"same_outcome_and_answer": same_d, "of": n_starts, "differences": differ_d,
                                "max_rel_difference": max_rel_d}
        res["target_met_dask"] = bool(count(cls_d)["truth"] >= 0.97 * n_starts and t_d <= 120.0 * n_starts / 100)
        print(f"(d) dask, 2 workers: {t_d:7.1f} s wall, {t_d / n_starts:.3f} s/start; outcomes {count(cls_d)}; "
              f"agree with (f) on {same_d}/{n_starts}", flush=True)

    res["environment"]["load_average_after"] = list(os.getloadavg()) if hasattr(os, "getloadavg") else None
    print(f"wrote {save_json(res, out)}")
    return 0


if __name__ == "__main__":
    sys.exit(main(ARGS))
