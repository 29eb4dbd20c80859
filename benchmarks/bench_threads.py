"""Benchmark: femupdate's phases with one BLAS thread, two, and its policy — on an idle machine and
with the other core kept busy.

Phases (each timed as the best of ``--repeat`` runs, wall and CPU seconds):

* ``dense eigh 408``   — every mode of a 408-dof frame, dense (LAPACK ``eigh``);
* ``dense eigh 1512``  — the 10 lowest modes of a 1,512-dof frame, dense (``gvx``);
* ``sparse modes 20k`` — ``model_modes`` of a 20,304-dof tower, 10 modes, through its workspace;
* ``band factor 100k`` — one band Cholesky factorisation of the 102,600-dof tower (``--large``);
* ``SuperLU solve``    — a 30-column solve with SuperLU's factor of an 11,400-dof frame;
* ``update 2304``      — one ``update`` of the 2,304-dof frame building of ``bench_frame.py``
  (12 storey moduli, 3 modes at 40 sensors, from a start 30 % off);
* ``reduction 10k``    — Guyan reduction of a 10,800-dof frame to 192 retained dofs (the
  192-column solve with K_oo's factor).

Each phase runs under ``Settings(blas_threads=1)``, ``=2`` (what ``FEMUPDATE_BLAS_THREADS=1`` and
``=2`` set for a command) and with the policy (``blas_threads=None``), first with the machine as found, then with a busy-loop process started on every other
core (the default; ``--no-busy`` skips it).  Reported per phase and load: the times,
the ratio of two threads and of the policy to one thread.  The issue's goals: no phase slower
with two cores than with one; with the second core busy, no phase more than 1.5 times slower
under the policy than pinned to one thread.  Results go to ``benchmarks/results/bench_threads.json``.
"""

from __future__ import annotations

import argparse
import multiprocessing as mp
import os
import platform
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
if (HERE.parent / "src" / "femupdate").is_dir():
    sys.path.insert(0, str(HERE.parent / "src"))

import numpy as np  # noqa: E402

import femupdate  # noqa: E402
from femupdate import model_modes  # noqa: E402
from femupdate import settings  # noqa: E402
from femupdate._threads import blas_phase  # noqa: E402
from femupdate.generators import frame_lattice  # noqa: E402

SETTINGS = {"1 thread": 1, "2 threads": 2, "policy": None}


def _spin(stop):
    while not stop.is_set():
        pass


def phases(large: bool) -> dict:
    """name -> (setup() -> state, run(state))."""
    out = {}

    def dense(nz, k):
        m = frame_lattice(2, 2, nz).build()
        K, M = m.K().toarray(), m.M().toarray()
        return lambda: (K, M), lambda st: femupdate.modal.solve_modes(st[0], st[1], n_modes=k, dofs=m.dofs, method="dense")

    out["dense eigh 408"] = dense(18, None)
    out["dense eigh 1512"] = dense(64, 10)

    def sparse_modes():
        m = frame_lattice(6, 6, 95).build()
        model_modes(m, n_modes=10)
        return m

    out["sparse modes 20k"] = (sparse_modes, lambda m: model_modes(m, n_modes=10))

    def superlu_solve():
        m = frame_lattice(10, 10, 20).build()
        lu = femupdate.workspace.superlu(m.K())
        B = np.random.default_rng(0).standard_normal((m.n_dofs, 30))
        return lu, B

    out["SuperLU solve"] = (superlu_solve, lambda st: femupdate.sensitivity.factor.solve(st[0], st[1]))

    def frame_update():
        sys.path.insert(0, str(HERE))
        import bench_frame

        model, data, truth, _, _ = bench_frame.problem()
        x0 = dict(zip(model.parameter_names, truth * np.linspace(0.7, 1.3, truth.size)))
        return model, data, x0

    def run_update(st):
        from femupdate.updating import update

        r = update(st[0], st[1], x0=st[2])
        assert r.success

    out["update 2304"] = (frame_update, run_update)

    def reduction():
        m = frame_lattice(6, 6, 51).build()
        keep = [d for d in m.dofs if d.endswith(":x")][::54][:192]
        return m, keep

    def run_reduction(st):
        from femupdate.reduction import Reducer

        Reducer(st[0], st[1]).guyan()

    out["reduction 10k"] = (reduction, run_reduction)
    if large:
        def band():
            from femupdate.workspace import SparseWorkspace

            m = frame_lattice(10, 10, 172, spacing=(4.0, 4.8, 3.0)).build()
            K, M = m.K(), m.M()
            ws = SparseWorkspace(K, M, prefer="band")
            ws.factor(K, M, 0.0)
            return ws, K, M

        out["band factor 100k"] = (band, lambda st: st[0].factor(st[1], st[2], 0.0))
    return out


def measure(run, state, repeat):
    best_w = best_c = float("inf")
    for _ in range(repeat):
        t, c = time.perf_counter(), time.process_time()
        run(state)
        best_w, best_c = min(best_w, time.perf_counter() - t), min(best_c, time.process_time() - c)
    return best_w, best_c


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--no-busy", action="store_true", help="skip the runs with the other cores busy")
    ap.add_argument("--large", action="store_true", help="also the band factorisation of the 102,600-dof tower")
    ap.add_argument("--output", default=None)
    args = ap.parse_args(argv)
    cores = len(os.sched_getaffinity(0))
    res = {"benchmark": "bench_threads", "environment": {
        "python": platform.python_version(), "numpy": np.__version__, "cores": cores,
        "femupdate": femupdate.__version__, "date": time.strftime("%Y-%m-%dT%H:%M:%S%z")}, "runs": {}}
    table = phases(args.large)
    states = {name: setup() for name, (setup, _) in table.items()}
    loads = ["idle"] + ([] if args.no_busy else ["busy"])
    for load in loads:
        stop, spinners = mp.Event(), []
        if load == "busy":
            spinners = [mp.Process(target=_spin, args=(stop,), daemon=True) for _ in range(max(cores - 1, 1))]
            for p in spinners:
                p.start()
            time.sleep(2.0)
        res["runs"][load] = {"load_average": list(os.getloadavg()), "phases": {}}
        try:
            for name, (_, run) in table.items():
                row = {}
                for label, value in SETTINGS.items():
                    with settings.using(blas_threads=value), blas_phase("solve"):  # as the command line runs every command
                        w, c = measure(run, states[name], args.repeat)
                    row[label] = {"wall": w, "cpu": c}
                row["2 threads / 1"] = row["2 threads"]["wall"] / row["1 thread"]["wall"]
                row["policy / 1"] = row["policy"]["wall"] / row["1 thread"]["wall"]
                res["runs"][load]["phases"][name] = row
                print(f"{load:5s} {name:18s} 1 thread {row['1 thread']['wall']:8.3f} s  2 threads "
                      f"{row['2 threads']['wall']:8.3f} s ({row['2 threads / 1']:5.2f})  policy "
                      f"{row['policy']['wall']:8.3f} s ({row['policy / 1']:5.2f})", flush=True)
        finally:
            stop.set()
            for p in spinners:
                p.join(5)
    sys.path.insert(0, str(HERE))
    from _probes import save_json

    print(f"results written to {save_json(res, Path(args.output) if args.output else HERE / 'results' / 'bench_threads.json')}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
