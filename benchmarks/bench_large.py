"""Benchmark: multi-start updating of a 102,600-dof frame tower, against one bare sparse eigen-solution.

The problem.  A 171-storey space frame, 9 x 9 bays in plan (4 m x 4.8 m, so that no two modes
are repeated; storeys 3 m), of steel tubes (:func:`femupdate.generators.frame_lattice`
(10, 10, 172)), 102,600 free dofs.  The mass is lumped on the translations only (the rotations
massless, as commercial codes export frame models).  The 171 storey moduli are grouped into
``--groups`` (default 10) stiffness groups of consecutive storeys: the model is rebuilt from its
matrices (:func:`femupdate.model.from_matrices`) with one multiplier per group (nominal 1, bounds
[0.3, 2]).  The truth is the multipliers ``linspace(0.8, 1.2, G)``; the test data are its lowest
4 modes, noise-free, at about 40 translational sensors (x and y of one corner and y of the
opposite corner on every 13th floor).

The starts.  ``--starts`` (default 20) random starts uniform within the bounds
(:func:`femupdate.updating.draw_starts`, one seed).  A start *reaches the truth* when every
multiplier is within 1e-6 (relative) of it.

Measured in one run:

(e) the baseline: one bare sparse eigen-solution of the true model with SciPy's defaults,
    ``eigsh(K, k, M, sigma=0)`` (SuperLU), k the modes an update computes (max(2T, T + 6) = 10);
    its time is the unit of the per-start figures;
(c) where scikit-sparse is installed, the best practice for that one solution: CHOLMOD's
    analysed factor of K behind ARPACK (``OPinv``), one BLAS thread;
(f) ``multistart(model, data, starts=N, seed=...)`` locally, with femupdate's default options
    (the starts in local worker processes, one per core: two here);
(d) optionally (``--dask``) route (f) on a local Dask cluster of two single-threaded workers,
    through femupdate's ``scheduler=`` option.

Reported: wall-clock and CPU seconds of each (with the local worker processes' CPU), seconds
per start (the run's wall time over its starts, and each start's own duration) and their ratio to (e), the
outcome of every start (truth / other / not converged / failed), whether (f) and (d) agree start
by start, the eigen-solver the starts report (``solver``; ``route`` and ``bandwidth`` are
null when the starts ran in worker processes, whose workspaces this process does not see), and the load average before and after
(the machine may be shared: the figures say what it was doing).  Results go to
``benchmarks/results/bench_large.json`` (``bench_large_quick.json`` with ``--quick``: a 5,400-dof
tower (10 x 10 x 10), 3 starts, for a smoke test).  A start of 10 groups takes about 5 minutes
on the 2-core machine (12-16 evaluations of about 20 s), two at a time, so the default run takes
about an hour locally and the Dask run as long again; ``--starts`` and ``--dask-starts`` trade
time for precision.  With 16 groups a start needs 70 evaluations or more.
"""

from __future__ import annotations

import argparse
import os
import platform
import sys
import time
from pathlib import Path

import numpy as np
import scipy
import scipy.sparse as sp
import scipy.sparse.linalg as spla

HERE = Path(__file__).resolve().parent
if (HERE.parent / "src" / "femupdate").is_dir():  # benchmark the checked-out source tree
    sys.path.insert(0, str(HERE.parent / "src"))
    os.environ["PYTHONPATH"] = os.pathsep.join([str(HERE.parent / "src")] + [p for p in [os.environ.get("PYTHONPATH")] if p])
import femupdate  # noqa: E402
from femupdate import MeasuredMode, Parameter, TestData, model_modes  # noqa: E402
from femupdate.generators import frame_lattice  # noqa: E402
from femupdate.model import from_matrices  # noqa: E402
from femupdate.updating import draw_starts, multistart  # noqa: E402

sys.path.insert(0, str(HERE))  # the shared probes
from _probes import count, multistart_cpu, outcomes, save_json  # noqa: E402

FULL = (10, 10, 172)
QUICK = (10, 10, 10)
SPACING = (4.0, 4.8, 3.0)
N_TEST_MODES = 4
TRUTH_RTOL = 1e-6
AGREE_RTOL = 1e-8


def tower(size, groups: int):
    """The tower with massless rotations and ``groups`` stiffness multipliers of consecutive storeys."""
    nx, ny, nz = size
    base = frame_lattice(nx, ny, nz, spacing=SPACING, mass="lumped", parameters="storey").build()
    d = base.M(base.values).diagonal().copy()
    d[[lab.split(":")[1].startswith("r") for lab in base.dofs]] = 0.0
    L = len(base.parameters)
    groups = min(groups, L)
    edges = np.linspace(0, L, groups + 1).round().astype(int)
    dK = [sum(base.values[j] * base.dK[j] for j in range(edges[g], edges[g + 1])).tocsr() for g in range(groups)]
    params = [Parameter(f"g{g + 1}", 1.0, bounds=(0.3, 2.0)) for g in range(groups)]
    model = from_matrices(base.dofs, base.K0, sp.diags_array(d).tocsr(), params, dK, None,
                          name=f"frame tower {nx}x{ny}x{nz - 1}, {groups} groups")
    return model, [(int(edges[g]) + 1, int(edges[g + 1])) for g in range(groups)]


def sensors(size):
    nx, ny, nz = size
    step = max(1, (nz - 1) // 13)
    out = []
    for k in range(step, nz, step):
        a = 1 + nx * ny * k
        c = a + (nx - 1) + nx * (ny - 1)
        out += [f"{a}:x", f"{a}:y", f"{c}:y"]
    return out


def timed(fn):
    t, c = time.perf_counter(), time.process_time()
    out = fn()
    return out, time.perf_counter() - t, time.process_time() - c


def cholmod_limit(K, M, k):
    """One eigen-solution by the best practice here: CHOLMOD's factor of K behind ARPACK."""
    try:
        from sksparse import cholmod
    except ImportError:
        return None
    from threadpoolctl import threadpool_limits

    def go():
        F = cholmod.cholesky(sp.csc_matrix(K), mode="supernodal")
        op = spla.LinearOperator(K.shape, matvec=F, dtype=float)
        return spla.eigsh(K, k=k, M=M, sigma=0.0, which="LM", OPinv=op)[0]

    with threadpool_limits(1, user_api="blas"):
        return timed(go)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help="5,400-dof tower, 3 starts (smoke test)")
    ap.add_argument("--starts", type=int, default=None, help="random starts (default 20)")
    ap.add_argument("--groups", type=int, default=10, help="stiffness groups (parameters), default 10")
    ap.add_argument("--seed", type=int, default=2026)
    ap.add_argument("--dask", action="store_true", help="also run the starts on a local two-worker Dask cluster")
    ap.add_argument("--dask-starts", type=int, default=None, help="starts of the Dask run (default: all)")
    ap.add_argument("--output", default=None)
    args = ap.parse_args(argv)
    size = QUICK if args.quick else FULL
    n_starts = args.starts or (3 if args.quick else 20)
    out = Path(args.output) if args.output else HERE / "results" / ("bench_large_quick.json" if args.quick else "bench_large.json")
    sys.path.insert(0, str(HERE))
    from _probes import settings_from_environment

    settings_from_environment()  # FEMUPDATE_FACTORISATION, FEMUPDATE_BLAS_THREADS as the command line reads them
    res: dict = {"benchmark": "bench_large", "quick": bool(args.quick), "environment": {
        "python": platform.python_version(), "numpy": np.__version__, "scipy": scipy.__version__,
        "femupdate": femupdate.__version__, "cpu_count": os.cpu_count(), "load_average_before": list(os.getloadavg()),
        "factorisation_backend": femupdate.workspace.backend(),
        "blas_env": {k: os.environ.get(k) for k in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "FEMUPDATE_BLAS_THREADS")},
        "date": time.strftime("%Y-%m-%dT%H:%M:%S%z")}}

    (model, groups), t_build, _ = timed(lambda: tower(size, args.groups))
    truth = np.linspace(0.8, 1.2, len(model.parameters))
    s = sensors(size)
    k_update = max(2 * N_TEST_MODES, N_TEST_MODES + 6)
    K, M = sp.csc_array(model.K(truth)), sp.csc_array(model.M(truth))
    mm = model_modes(model, truth, n_modes=k_update, reuse=False)
    pos = model.dof_index(s)
    data = TestData(modes=tuple(MeasuredMode(mm.eigenvalues[j], s, mm.shapes[pos, j]) for j in range(N_TEST_MODES)))
    res["problem"] = {"n_dofs": model.n_dofs, "massless_dofs": int(np.sum(model.M().diagonal() == 0)),
                      "n_parameters": len(model.parameters), "storeys_per_group": groups, "n_sensors": len(s),
                      "n_test_modes": N_TEST_MODES, "modes_computed_per_evaluation": k_update,
                      "frequencies_hz": [float(f) for f in mm.frequencies_hz[:N_TEST_MODES]],
                      "starts": n_starts, "seed": args.seed, "build_seconds": t_build}
    print(f"{model.name}: {model.n_dofs} dofs, {len(model.parameters)} parameters, {len(s)} sensors", flush=True)

    # (e) one bare sparse eigen-solution, SciPy's defaults
    (lam_e), t_e, c_e = timed(lambda: np.sort(spla.eigsh(K, k=k_update, M=M, sigma=0.0, which="LM")[0]))
    np.testing.assert_allclose(lam_e, mm.eigenvalues, rtol=1e-8)
    res["bare_eigensolution"] = {"wall_seconds": t_e, "cpu_seconds": c_e, "how": f"scipy eigsh(K, k={k_update}, M, sigma=0)"}
    print(f"(e) bare eigsh: {t_e:.2f} s wall, {c_e:.2f} s CPU", flush=True)
    lim = cholmod_limit(K, M, k_update)
    if lim is not None:
        lam_c, t_c, c_c = lim
        np.testing.assert_allclose(np.sort(lam_c), mm.eigenvalues, rtol=1e-8)
        res["cholmod_eigensolution"] = {"wall_seconds": t_c, "cpu_seconds": c_c}
        print(f"(c) CHOLMOD + ARPACK: {t_c:.2f} s wall, {c_c:.2f} s CPU", flush=True)
    K = M = None  # the matrices are not needed any more

    t_start = time.perf_counter()

    def progress(done, total):
        print(f"    {done}/{total} starts done ({time.perf_counter() - t_start:.0f} s)", flush=True)

    ms_f, t_f, c_f = timed(lambda: multistart(model, data, starts=n_starts, seed=args.seed, progress=progress))
    X0 = draw_starts(model, model.parameter_names, n_starts, args.seed)
    np.testing.assert_array_equal(ms_f.starts, X0)
    cls_f, sol_f = outcomes(ms_f, truth, TRUTH_RTOL)
    c_f, jobs_f = multistart_cpu(ms_f, c_f, model)
    ws = femupdate.workspace._WORKSPACES.get(model)
    mean_start = float(np.mean(ms_f.seconds)) if ms_f.seconds else float("nan")
    res["local"] = {"wall_seconds": t_f, "cpu_seconds": c_f, "processes": jobs_f, "per_start_wall": t_f / n_starts,
                    "per_start_over_bare": t_f / n_starts / t_e, "outcomes": count(cls_f), "per_start": cls_f,
                    "mean_start_seconds": mean_start, "mean_start_over_bare": mean_start / t_e,
                    "start_seconds": list(ms_f.seconds or []), "start_cpu_seconds": list(ms_f.cpu_seconds or []),
                    "route": getattr(ws, "route", None), "bandwidth": getattr(ws, "bandwidth", None),
                    "solver": next((r.solver for r in ms_f.runs if not isinstance(r, str)), None),
                    "sensitivity": next((r.sensitivity for r in ms_f.runs if not isinstance(r, str)), None),
                    "evaluations": [int(r.nfev) for r in ms_f.runs if not isinstance(r, str)]}
    print(f"(f) local, {jobs_f} processes: {t_f:.1f} s wall, {c_f:.1f} s CPU ({t_f / n_starts:.1f} s per start = "
          f"{t_f / n_starts / t_e:.1f} bare eigen-solutions; each start {mean_start:.1f} s on average = "
          f"{mean_start / t_e:.1f}), {count(cls_f)}", flush=True)

    if args.dask:
        import distributed

        nd = min(args.dask_starts or n_starts, n_starts)
        with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                                      dashboard_address=None) as cluster:
            t0 = time.perf_counter()
            ms_d, t_d, c_d = timed(lambda: multistart(model, data, starts=nd, seed=args.seed,
                                                      scheduler=cluster.scheduler_address))
            cls_d, sol_d = outcomes(ms_d, truth, TRUTH_RTOL)
        same = sum(a == b and (xa is None or xb is None or np.max(np.abs(xa - xb) / np.abs(xb)) <= AGREE_RTOL)
                   for a, b, xa, xb in zip(cls_f[:nd], cls_d, sol_f[:nd], sol_d))
        res["dask"] = {"wall_seconds": t_d, "starts": nd, "per_start_wall": t_d / nd,
                       "per_start_over_bare": t_d / nd / t_e, "outcomes": count(cls_d),
                       "same_as_local": int(same), "with_cluster_start_seconds": time.perf_counter() - t0}
        print(f"(d) Dask, 2 workers: {t_d:.1f} s wall for {nd} starts ({t_d / nd:.1f} s per start = "
              f"{t_d / nd / t_e:.1f} bare eigen-solutions), {count(cls_d)}, {same}/{nd} the same as locally", flush=True)
    res["environment"]["load_average_after"] = list(os.getloadavg())
    print(f"results written to {save_json(res, out)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
