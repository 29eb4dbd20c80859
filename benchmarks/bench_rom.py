"""Benchmark: one update on the full model against the same update on a parametric reduced model
(``femupdate.rom``), time and peak memory, ratios in one run.

The problem.  The frame tower of ``bench_large.py`` (``frame_lattice(10, 10, 172)``, 102,600 free
dofs, mass lumped on the translations, rotations massless) with ``--groups`` (default 4) storey
stiffness multipliers, nominal 1, bounds [0.3, 2]; the truth ``linspace(0.8, 1.2, G)``; the test
data its lowest 4 modes, noise-free, at about 40 translational sensors.  ``--size nx ny nz``
changes the tower (``--quick``: 10 x 10 x 21, 12,000 dofs).

Measured, each route in its own forked process (so that each has its own peak resident memory,
``VmHWM``; the model, built before the fork, is in both):

(full) ``femupdate.update(model, data)`` from the nominal values, femupdate's defaults;
(basis) the greedy reduced basis (``femupdate.rom.basis_for``), timed apart;
(rom) ``femupdate.rom.rom_update`` on that basis: the update on the reduced model, its full-model
      check, the polish round and its check;
(multi) ``--starts`` (default 4) random starts: ``femupdate.multistart`` on the full model (local
      worker processes, femupdate's default) against ``femupdate.rom.rom_multistart`` on the same
      basis (every converged start checked on the full model, the best polished).

Reported: wall and CPU seconds and peak memory of each, the ratios full / (basis + rom) and
full / rom, the basis size, every check (frequency errors against the full eigen-solution and
the a-posteriori bounds), the largest relative difference of the two answers' parameters and of
the full model's frequencies at them, and the load average before and after (the machine may be
shared).  Results go to ``benchmarks/results/bench_rom.json`` (``bench_rom_quick.json`` with
``--quick``).
"""

from __future__ import annotations

import argparse
import json
import multiprocessing as mp
import os
import platform
import sys
import time
from pathlib import Path

import numpy as np
import scipy
import scipy.sparse as sp

HERE = Path(__file__).resolve().parent
if (HERE.parent / "src" / "femupdate").is_dir():  # benchmark the checked-out source tree
    sys.path.insert(0, str(HERE.parent / "src"))
import femupdate  # noqa: E402
from femupdate import MeasuredMode, Parameter, TestData, model_modes  # noqa: E402
from femupdate.generators import frame_lattice  # noqa: E402
from femupdate.model import from_matrices  # noqa: E402

FULL = (10, 10, 172)
QUICK = (10, 10, 21)
SPACING = (4.0, 4.8, 3.0)
N_TEST_MODES = 4


def tower(size, groups: int):
    """The tower with massless rotations and ``groups`` stiffness multipliers of consecutive storeys."""
    nx, ny, nz = size
    base = frame_lattice(nx, ny, nz, spacing=SPACING, mass="lumped", parameters="storey").build()
    d = base.M(base.values).diagonal().copy()
    d[[lab.split(":")[1].startswith("r") for lab in base.dofs]] = 0.0
    L = len(base.parameters)
    edges = np.linspace(0, L, min(groups, L) + 1).round().astype(int)
    dK = [sum(base.values[j] * base.dK[j] for j in range(edges[g], edges[g + 1])).tocsr() for g in range(len(edges) - 1)]
    params = [Parameter(f"g{g + 1}", 1.0, bounds=(0.3, 2.0)) for g in range(len(dK))]
    return from_matrices(base.dofs, base.K0, sp.diags_array(d).tocsr(), params, dK, None,
                         name=f"frame tower {nx}x{ny}x{nz - 1}, {len(dK)} groups")


def sensors(size):
    nx, ny, nz = size
    step = max(1, (nz - 1) // 13)
    out = []
    for k in range(step, nz, step):
        a = 1 + nx * ny * k
        c = a + (nx - 1) + nx * (ny - 1)
        out += [f"{a}:x", f"{a}:y", f"{c}:y"]
    return out


def peak_mb() -> float:
    """This process's peak resident memory (VmHWM), MB."""
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith("VmHWM:"):
            return int(line.split()[1]) / 1024
    return float("nan")


def workers_peak_mb() -> float:
    """The largest peak resident memory of this process's finished child processes (the local
    workers of a multi-start study), MB; 0 when there were none."""
    import resource

    return resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024


def _in_child(fn, q):
    t, c = time.perf_counter(), time.process_time()
    try:
        out = fn()
    except BaseException as exc:  # the parent waits for a record: give it the failure
        out = {"error": f"{type(exc).__name__}: {exc}"}
    q.put({"wall_seconds": time.perf_counter() - t, "cpu_seconds": time.process_time() - c, "peak_mb": peak_mb(),
           **out})


def forked(fn) -> dict:
    """``fn()`` (a dict) in a forked process, with its wall and CPU seconds and peak memory."""
    ctx = mp.get_context("fork")
    q = ctx.Queue()
    p = ctx.Process(target=_in_child, args=(fn, q))
    p.start()
    out = q.get()
    p.join()
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help="12,000-dof tower (smoke test)")
    ap.add_argument("--size", type=int, nargs=3, default=None, metavar=("NX", "NY", "NZ"))
    ap.add_argument("--groups", type=int, default=4)
    ap.add_argument("--starts", type=int, default=4, help="random starts of the multi-start comparison (0: none)")
    ap.add_argument("--seed", type=int, default=2026)
    ap.add_argument("--output", default=None)
    args = ap.parse_args(argv)
    size = tuple(args.size) if args.size else QUICK if args.quick else FULL
    out = Path(args.output) if args.output else HERE / "results" / ("bench_rom_quick.json" if args.quick else "bench_rom.json")
    res: dict = {"benchmark": "bench_rom", "environment": {
        "python": platform.python_version(), "numpy": np.__version__, "scipy": scipy.__version__,
        "femupdate": femupdate.__version__, "cpu_count": os.cpu_count(), "load_average_before": list(os.getloadavg()),
        "factorisation_backend": femupdate.workspace.backend(), "date": time.strftime("%Y-%m-%dT%H:%M:%S%z")}}
    model = tower(size, args.groups)
    truth = np.linspace(0.8, 1.2, len(model.parameters))
    s = sensors(size)
    mm = model_modes(model, truth, n_modes=N_TEST_MODES + 2, reuse=False)
    pos = model.dof_index(s)
    data = TestData(modes=tuple(MeasuredMode(mm.eigenvalues[j], s, mm.shapes[pos, j]) for j in range(N_TEST_MODES)))
    res["problem"] = {"n_dofs": model.n_dofs, "n_parameters": len(model.parameters), "n_sensors": len(s),
                      "n_test_modes": N_TEST_MODES, "baseline_mb": peak_mb()}
    print(f"{model.name}: {model.n_dofs} dofs, {len(model.parameters)} parameters, {len(s)} sensors", flush=True)

    def full():
        t, c = time.perf_counter(), time.process_time()
        r = femupdate.update(model, data)
        out = {"x": r.x.tolist(), "nfev": int(r.nfev), "success": bool(r.success),
               "update_seconds": time.perf_counter() - t, "update_cpu_seconds": time.process_time() - c,
               "update_peak_mb": peak_mb()}
        if args.starts:
            t, c = time.perf_counter(), time.process_time()
            ms = femupdate.multistart(model, data, starts=args.starts, seed=args.seed, batched=False)
            workers = ms.cpu_seconds is not None and len(ms.cpu_seconds) and time.process_time() - c < sum(ms.cpu_seconds)
            out["multistart"] = {"wall_seconds": time.perf_counter() - t, "best_x": ms.best.x.tolist(),
                                 "cpu_seconds": time.process_time() - c + (sum(ms.cpu_seconds) if workers else 0.0),
                                 "converged": int(ms.converged), "workers_peak_mb": workers_peak_mb()}
        return out

    def reduced():
        from femupdate.rom import basis_for, rom_update

        t, c = time.perf_counter(), time.process_time()
        rb = basis_for(model, data)
        t_basis, c_basis, peak_basis = time.perf_counter() - t, time.process_time() - c, peak_mb()
        t, c = time.perf_counter(), time.process_time()
        r = rom_update(model, data, basis=rb)
        t_update, c_update, peak_update = time.perf_counter() - t, time.process_time() - c, peak_mb()
        rec = r.to_json()["reduced_basis"]
        out = {"x": r.x.tolist(), "nfev": int(r.nfev), "basis_seconds": t_basis, "basis_peak_mb": peak_basis,
               "basis_cpu_seconds": c_basis, "update_seconds": t_update, "update_cpu_seconds": c_update,
               "update_peak_mb": peak_update, "size": rec["size"], "checks": rec["checks"], "passed": rec["passed"],
               "greedy": rec["greedy"]}
        if args.starts:
            from femupdate.rom import rom_multistart

            t, c = time.perf_counter(), time.process_time()
            ms = rom_multistart(model, data, args.starts, basis=rb, seed=args.seed, batched=False)
            rec = ms.to_json()["reduced_basis"]
            out["multistart"] = {"wall_seconds": time.perf_counter() - t, "cpu_seconds": time.process_time() - c,
                                 "best_x": ms.best.x.tolist(),
                                 "converged": int(ms.converged), "checks": len(rec["checks"]),
                                 "passed": rec["passed"], "size": rec["size"]}
        return out

    res["full"] = f = forked(full)
    print(f"(full) update {f['update_seconds']:.1f} s, peak {f['update_peak_mb']:.0f} MB, {f['nfev']} evaluations",
          flush=True)
    res["rom"] = r = forked(reduced)
    if "error" in f or "error" in r:
        print(f.get("error"), r.get("error"))
        return 1
    t_upd = r["update_seconds"]
    print(f"(rom) basis {r['basis_seconds']:.1f} s ({r['size']} vectors), update and checks {t_upd:.1f} s, "
          f"peak {r['peak_mb']:.0f} MB, checks passed: {r['passed']}", flush=True)
    x_f, x_r = np.array(f["x"]), np.array(r["x"])
    f_full = model_modes(model, x_f, N_TEST_MODES).frequencies_hz
    f_rom = model_modes(model, x_r, N_TEST_MODES).frequencies_hz
    res["comparison"] = {
        "parameters_max_rel_diff": float(np.max(np.abs(x_r / x_f - 1))),
        "frequencies_max_rel_diff": float(np.max(np.abs(f_rom / f_full - 1))),
        "time_ratio_full_over_rom_update_with_basis": f["update_seconds"] / (t_upd + r["basis_seconds"]),
        "time_ratio_full_over_rom_update": f["update_seconds"] / t_upd,
        "cpu_ratio_full_over_rom_update": f["update_cpu_seconds"] / r["update_cpu_seconds"],
        "cpu_ratio_full_over_rom_update_with_basis": f["update_cpu_seconds"]
        / (r["update_cpu_seconds"] + r["basis_cpu_seconds"]),
        "memory_ratio_full_update_over_rom_update": f["update_peak_mb"] / r["update_peak_mb"],
        **({"multistart_time_ratio_full_over_rom": f["multistart"]["wall_seconds"] / r["multistart"]["wall_seconds"],
            "multistart_time_ratio_full_over_rom_with_basis": f["multistart"]["wall_seconds"]
            / (r["multistart"]["wall_seconds"] + r["basis_seconds"]),
            "multistart_cpu_ratio_full_over_rom": f["multistart"]["cpu_seconds"] / r["multistart"]["cpu_seconds"],
            "multistart_cpu_ratio_full_over_rom_with_basis": f["multistart"]["cpu_seconds"]
            / (r["multistart"]["cpu_seconds"] + r["basis_cpu_seconds"]),
            "multistart_best_max_rel_diff": float(np.max(np.abs(np.array(r["multistart"]["best_x"])
                                                                / np.array(f["multistart"]["best_x"]) - 1)))}
           if args.starts else {}),
        "load_average_after": list(os.getloadavg())}
    print(json.dumps(res["comparison"], indent=1), flush=True)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(res, indent=1))
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
