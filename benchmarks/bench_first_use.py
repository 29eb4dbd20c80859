"""Benchmark: first use of the batched multi-start route — compile (cold cache) against load (warm cache).

Usage::

    python benchmarks/bench_first_use.py            # 3 cold/warm pairs
    python benchmarks/bench_first_use.py --quick    # 1 cold/warm pair (CI smoke test)
    python benchmarks/bench_first_use.py --repeat 5 --storeys 10 --starts 20

femupdate's batched route (:mod:`femupdate.updating.batched`) runs code compiled by numba with
``cache=True``: the first call after installation compiles it (tens of seconds), later processes
load it from numba's disk cache.  This benchmark measures what a user sees, each measurement in a
fresh Python process started with ``sys.executable`` (the same interpreter as the benchmark):

cold
    ``NUMBA_CACHE_DIR`` set to a new, empty temporary directory (numba then caches there and
    nowhere else; the cache beside the package is not used), the script: ``import femupdate``;
    a shear building (:func:`femupdate.generators.shear_building`, ``--storeys`` 6, one
    stiffness parameter per storey, true stiffnesses decreasing with height, bounds ±50 %)
    with noise-free "measured" modes (``--modes`` 4 at ``--sensors`` 3 floors spread over the
    height); ``femupdate.multistart(model, data, starts=8, seed=0)`` (batched by default for such
    a model); then the same call once more in the same process.
warm
    the same command again, with the same — now populated — cache directory.
in-process repeat
    the second ``multistart`` call of the warm process: pure run time, nothing left to load.
import
    ``import femupdate`` alone, in a fresh process (the JSON also has a fresh ``import numba``),
    and whether numba, matplotlib, sympy or dask are in ``sys.modules`` after it (the package
    promises none of them; numpy and scipy are reported too, for information).

Phases of a cold or warm process (monotonic clock, which is system-wide, so the child's stamps
compare with the parent's):

* ``interpreter``: from the parent's launch to the child's first statement;
* ``import_femupdate``: the ``import femupdate`` statement (numba is *not* imported here — it
  would be counted here if it were);
* ``startup`` = interpreter + import_femupdate (+ the few standard-library imports in between);
* ``setup``: the model, its modes and the test data (this first imports NumPy and SciPy);
* ``multistart``: the first call — imports numba, then compiles (cold) or loads (warm) the
  compiled code, then runs; its CPU time too;
* ``total``: the wall time of the process, from launch to exit, *without* the repeated call (which
  is one contiguous block inside the process and is timed on its own); ``process_wall`` includes it.

Repeated ``--repeat`` times (default 3, ``--quick`` 1), each repetition with its own new cache
directory (a cold run, then a warm run on its cache); reported: the median, min and max of every
phase, the ratio cold/warm of the totals, and the compile share: cold − warm, of the total and of
the ``multistart`` call (per pair, then the median).  Also recorded: the numba and llvmlite versions
that ran (from the child process), the CPU count and the cores this process may use, the size of
the cache a cold run leaves, and whether a warm run still had to write to the cache (it should
not: that would mean it compiled something — numba recompiles when ``kernel.py`` or ``trf.py``
changed since the cold run, so each pair also records a hash of femupdate's sources before and
after it, and the load average before it).  The temporary cache directories are deleted
afterwards unless ``--keep-cache``.

BLAS threads: as in ``bench_multistart.py``, the child processes get ``OPENBLAS_NUM_THREADS``,
``OMP_NUM_THREADS`` and ``MKL_NUM_THREADS`` = ``--blas-threads`` (default 1; ``0`` leaves the
environment as found).  Results go to ``benchmarks/results/bench_first_use.json``
(``bench_first_use_quick.json`` with ``--quick``).
"""

from __future__ import annotations

import time

_T_FIRST = time.monotonic()  # a child's first statement: the end of the interpreter's start-up

import argparse  # noqa: E402
import json  # noqa: E402
import os  # noqa: E402
import shutil  # noqa: E402
import statistics  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
from pathlib import Path  # noqa: E402

HERE = Path(__file__).resolve().parent
SRC = HERE.parent / "src"
PROMISED_ABSENT = ("numba", "matplotlib", "sympy", "dask")  # `import femupdate` loads none of these
ALSO_REPORTED = ("numpy", "scipy", "llvmlite")
BLAS_KEYS = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")
RESULT_TAG = "BENCH_FIRST_USE_RESULT "  # the child's result line on stdout


# ------------------------------------------------------------------ child processes
def _loaded(names) -> dict:
    return {n: any(m == n or m.startswith(n + ".") for m in sys.modules) for n in names}


def _emit(out: dict) -> None:
    print(RESULT_TAG + json.dumps(out), flush=True)


def child_import() -> None:
    """``import femupdate`` alone; which heavy modules it brought in."""
    n0 = len(sys.modules)
    t = time.perf_counter()
    import femupdate  # noqa: F401

    dt = time.perf_counter() - t
    _emit({"t_first": _T_FIRST, "import_femupdate": dt, "modules_added": len(sys.modules) - n0,
           "loaded": _loaded(PROMISED_ABSENT + ALSO_REPORTED)})


def child_numba() -> None:
    """``import numba`` alone (part of every first multistart call of a process)."""
    t = time.perf_counter()
    import numba  # noqa: F401

    _emit({"t_first": _T_FIRST, "import_numba": time.perf_counter() - t})


def child_run(n_storeys: int, n_modes: int, n_sensors: int, n_starts: int, seed: int) -> None:
    """The timed user script: import, problem, multistart, multistart again."""
    t = time.perf_counter()
    import femupdate

    t_import = time.perf_counter() - t
    loaded_after_import = _loaded(PROMISED_ABSENT)

    t = time.perf_counter()
    import numpy as np

    from femupdate.generators import shear_building

    k_true = 2.0e7 * (1.0 - 0.4 * np.arange(n_storeys) / max(n_storeys - 1, 1))
    model = shear_building(n_storeys, k=k_true, m=1.0e4, bounds=(0.5, 1.5)).build()
    floors = np.unique(np.round(np.linspace(n_storeys / n_sensors, n_storeys, n_sensors)).astype(int))
    sensors = [f"{int(f)}:x" for f in floors]  # 6 storeys, 3 sensors: floors 2, 4, 6
    mm = femupdate.model_modes(model)
    pos = model.dof_index(sensors)
    data = femupdate.TestData(modes=tuple(femupdate.MeasuredMode(mm.eigenvalues[j], sensors, mm.shapes[pos, j])
                                          for j in range(n_modes)))
    t_setup = time.perf_counter() - t

    t_before = time.monotonic()
    t, c = time.perf_counter(), time.process_time()
    ms = femupdate.multistart(model, data, starts=n_starts, seed=seed)
    t_call, c_call = time.perf_counter() - t, time.process_time() - c
    batched = "femupdate.updating.batched.kernel" in sys.modules

    t, c = time.perf_counter(), time.process_time()
    ms2 = femupdate.multistart(model, data, starts=n_starts, seed=seed)
    t_again, c_again = time.perf_counter() - t, time.process_time() - c

    import llvmlite
    import numba

    err = float(np.max(np.abs(ms.best.x / k_true - 1))) if ms.best is not None else None
    same = ms.best is not None and ms2.best is not None and bool(np.array_equal(ms.best.x, ms2.best.x))
    _emit({"t_first": _T_FIRST, "t_before_call": t_before, "import_femupdate": t_import,
           "loaded_after_import": loaded_after_import, "setup": t_setup,
           "multistart": t_call, "multistart_cpu": c_call, "repeat_call": t_again, "repeat_call_cpu": c_again,
           "batched_route": batched, "numba": numba.__version__, "llvmlite": llvmlite.__version__,
           "numba_cache_dir": numba.config.CACHE_DIR, "problem": {
               "n_storeys": n_storeys, "n_dofs": model.n_dofs, "n_parameters": len(model.parameter_names),
               "n_test_modes": n_modes, "sensors": sensors, "starts": n_starts, "seed": seed},
           "converged": ms.converged, "solutions": len(ms.solutions), "best_max_rel_error": err,
           "repeat_same_best": same})


# ------------------------------------------------------------------ the parent
def _child_env(args, cache_dir: str | None) -> dict:
    env = dict(os.environ)
    if (SRC / "femupdate").is_dir():  # benchmark the checked-out source tree
        env["PYTHONPATH"] = os.pathsep.join([str(SRC)] + ([env["PYTHONPATH"]] if env.get("PYTHONPATH") else []))
    if args.blas_threads > 0:
        for key in BLAS_KEYS:
            env[key] = str(args.blas_threads)
    if cache_dir is None:
        env.pop("NUMBA_CACHE_DIR", None)
    else:
        env["NUMBA_CACHE_DIR"] = cache_dir
    return env


def _spawn(args, child: list[str], cache_dir: str | None) -> dict:
    """Run this file as a child; its result plus launch-to-exit wall time and interpreter start-up."""
    cmd = [sys.executable, str(Path(__file__).resolve()), "--child", *child]
    t_launch = time.monotonic()
    p = subprocess.run(cmd, env=_child_env(args, cache_dir), capture_output=True, text=True, timeout=args.timeout)
    t_exit = time.monotonic()
    lines = [ln for ln in p.stdout.splitlines() if ln.startswith(RESULT_TAG)]
    if p.returncode != 0 or not lines:
        raise RuntimeError(f"child {' '.join(child)} failed (exit {p.returncode}):\n{p.stdout}\n{p.stderr}")
    out = json.loads(lines[-1][len(RESULT_TAG):])
    out["process_wall"] = t_exit - t_launch
    out["interpreter"] = out.pop("t_first") - t_launch
    if "t_before_call" in out:
        out["startup"] = out.pop("t_before_call") - t_launch - out["setup"]
        out["total"] = out["process_wall"] - out["repeat_call"]
        out["after_call"] = out["total"] - out["startup"] - out["setup"] - out["multistart"]  # exit etc.
    return out


def _source_state() -> dict | None:
    """Commit of the checked-out tree and whether its src/ differs from it (None outside git)."""
    try:
        run_git = lambda *a: subprocess.run(["git", *a], cwd=HERE.parent, capture_output=True, text=True,  # noqa: E731
                                            timeout=30, check=True).stdout.strip()
        return {"commit": run_git("rev-parse", "HEAD"), "src_modified": bool(run_git("status", "--porcelain", "--", "src"))}
    except (OSError, subprocess.SubprocessError):
        return None


def _package_stamp() -> str | None:
    """SHA-256 of the femupdate sources the children import (a warm run recompiles when they
    change between the cold and the warm run, e.g. on a tree that is being edited)."""
    import hashlib
    import importlib.util

    spec = importlib.util.find_spec("femupdate")  # locates the package without importing it
    if spec is None or not spec.submodule_search_locations:
        return None
    root = Path(list(spec.submodule_search_locations)[0])
    h = hashlib.sha256()
    for f in sorted(root.rglob("*.py")):
        h.update(str(f.relative_to(root)).encode() + b"\0" + f.read_bytes())
    return h.hexdigest()


def _cache_state(cache_dir: str) -> dict:
    files = [p for p in Path(cache_dir).rglob("*") if p.is_file()]
    return {"files": len(files), "bytes": sum(p.stat().st_size for p in files),
            "latest_mtime_ns": max((p.stat().st_mtime_ns for p in files), default=0)}


def _stats(values) -> dict:
    v = [float(x) for x in values]
    return {"median": statistics.median(v), "min": min(v), "max": max(v), "values": v}


RUN_PHASES = ("interpreter", "import_femupdate", "startup", "setup", "multistart", "multistart_cpu",
              "after_call", "total", "process_wall", "repeat_call", "repeat_call_cpu")


def run(args) -> dict:
    n_rep = args.repeat or (1 if args.quick else 3)
    problem = [str(args.storeys), str(args.modes), str(args.sensors), str(args.starts), str(args.seed)]
    res = {"benchmark": "bench_first_use", "quick": bool(args.quick), "repeat": n_rep,
           "python_executable": sys.executable,
           "machine": {"cpu_count": os.cpu_count(),
                       "usable_cores": len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else None},
           "source": _source_state(), "blas_threads_set": args.blas_threads or None,
           "environment_found": {k: v for k, v in os.environ.items() if k.startswith("NUMBA_") or k in BLAS_KEYS}}

    # the import of femupdate alone, and of numba alone (cache untouched: nothing is compiled)
    imports = [_spawn(args, ["import"], None) for _ in range(n_rep)]
    numba_imports = [_spawn(args, ["numba"], None) for _ in range(n_rep)]
    loaded = {k: any(r["loaded"][k] for r in imports) for k in imports[0]["loaded"]}
    res["import"] = {"import_femupdate": _stats(r["import_femupdate"] for r in imports),
                     "interpreter": _stats(r["interpreter"] for r in imports),
                     "process_wall": _stats(r["process_wall"] for r in imports),
                     "modules_added": imports[0]["modules_added"], "loaded_after_import_femupdate": loaded,
                     "promise_kept": not any(loaded[k] for k in PROMISED_ABSENT),
                     "import_numba": _stats(r["import_numba"] for r in numba_imports)}

    cold, warm, caches = [], [], []
    root = args.cache_root or None
    for i in range(n_rep):
        cache_dir = tempfile.mkdtemp(prefix="femupdate-numba-cache-", dir=root)
        stamp, load = _package_stamp(), os.getloadavg() if hasattr(os, "getloadavg") else None
        try:
            print(f"[{i + 1}/{n_rep}] cold (NUMBA_CACHE_DIR={cache_dir}) ...", end=" ", flush=True)
            c = _spawn(args, ["run", *problem], cache_dir)
            after_cold = _cache_state(cache_dir)
            print(f"{c['total']:.2f} s; warm ...", end=" ", flush=True)
            w = _spawn(args, ["run", *problem], cache_dir)
            after_warm = _cache_state(cache_dir)
            print(f"{w['total']:.2f} s", flush=True)
        finally:
            if not args.keep_cache:
                shutil.rmtree(cache_dir, ignore_errors=True)
        cold.append(c)
        warm.append(w)
        caches.append({"dir": cache_dir, "kept": bool(args.keep_cache), "after_cold": after_cold,
                       "warm_wrote_to_cache": after_warm != after_cold, "load_average_before": load,
                       "source_sha256": stamp, "source_changed_during_pair": _package_stamp() != stamp})

    res["problem"] = cold[0]["problem"]
    res["compiled_code"] = {"numba": cold[0]["numba"], "llvmlite": cold[0]["llvmlite"],
                            "batched_route": all(r["batched_route"] for r in cold + warm),
                            "numba_cache_dir_seen_by_child": [r["numba_cache_dir"] for r in cold]}
    res["cold"] = {k: _stats(r[k] for r in cold) for k in RUN_PHASES}
    res["warm"] = {k: _stats(r[k] for r in warm) for k in RUN_PHASES}
    res["in_process_repeat"] = {"seconds": _stats(r["repeat_call"] for r in warm),
                                "cpu_seconds": _stats(r["repeat_call_cpu"] for r in warm)}
    res["ratio_cold_over_warm"] = {"total": _stats(c["total"] / w["total"] for c, w in zip(cold, warm)),
                                   "multistart": _stats(c["multistart"] / w["multistart"] for c, w in zip(cold, warm))}
    share = [c["total"] - w["total"] for c, w in zip(cold, warm)]
    res["compile_share"] = {"total_seconds": _stats(share),
                            "multistart_seconds": _stats(c["multistart"] - w["multistart"] for c, w in zip(cold, warm)),
                            "fraction_of_cold_total": _stats(s / c["total"] for s, c in zip(share, cold))}
    res["warm_load"] = {"seconds": _stats(w["multistart"] - w["repeat_call"] for w in warm),
                        "note": "warm first call - in-process repeat: numba import + loading the cached code"}
    res["cache"] = caches
    res["checks"] = {
        "batched_route": res["compiled_code"]["batched_route"],
        "numba_not_loaded_by_import_in_runs": not any(r["loaded_after_import"]["numba"] for r in cold + warm),
        "every_run_reaches_truth": all(r["best_max_rel_error"] is not None and r["best_max_rel_error"] < 1e-6
                                       for r in cold + warm),
        "repeat_same_best": all(r["repeat_same_best"] for r in cold + warm),
        "warm_runs_did_not_compile": not any(c["warm_wrote_to_cache"] for c in caches),
        "source_unchanged_during_pairs": not any(c["source_changed_during_pair"] for c in caches),
        "import_promise_kept": res["import"]["promise_kept"],
    }
    res["runs"] = {"cold": cold, "warm": warm}
    return res


def _fmt(s: dict) -> str:
    return f"{s['median']:9.4f} {s['min']:9.4f} {s['max']:9.4f}"


def table(res: dict) -> str:
    p, cc, imp = res["problem"], res["compiled_code"], res["import"]
    out = [f"problem: shear building, {p['n_storeys']} storeys ({p['n_parameters']} parameters), {p['n_test_modes']} modes "
           f"at {p['sensors']}, multistart(starts={p['starts']}, seed={p['seed']}); batched route: {cc['batched_route']}",
           f"numba {cc['numba']}, llvmlite {cc['llvmlite']}; cpus {res['machine']['cpu_count']} "
           f"(usable {res['machine']['usable_cores']}); {res['repeat']} cold/warm pair(s), each in a fresh process", "",
           f"{'seconds (median, min, max)':50s} {'median':>9s} {'min':>9s} {'max':>9s}"]
    rows = [("cold: startup (interpreter + import femupdate)", res["cold"]["startup"]),
            ("cold: multistart (numba import + compile + run)", res["cold"]["multistart"]),
            ("cold: total (process wall)", res["cold"]["total"]),
            ("warm: startup", res["warm"]["startup"]),
            ("warm: multistart (numba import + load + run)", res["warm"]["multistart"]),
            ("warm: total (process wall)", res["warm"]["total"]),
            ("in-process repeat: multistart", res["in_process_repeat"]["seconds"]),
            ("compile share: cold - warm, total", res["compile_share"]["total_seconds"]),
            ("compile share: cold - warm, multistart", res["compile_share"]["multistart_seconds"]),
            ("ratio cold / warm, total", res["ratio_cold_over_warm"]["total"]),
            ("import femupdate alone", imp["import_femupdate"]),
            ("import numba alone", imp["import_numba"])]
    out += [f"{name:50s} {_fmt(s)}" for name, s in rows]
    loaded = imp["loaded_after_import_femupdate"]
    out += ["", "after `import femupdate`: " + ", ".join(f"{k} {'LOADED' if v else 'not loaded'}" for k, v in loaded.items()),
            f"cache left by a cold run: {res['cache'][0]['after_cold']['files']} files, "
            f"{res['cache'][0]['after_cold']['bytes'] / 1024**2:.1f} MB",
            "checks: " + ", ".join(f"{k} {'ok' if v else 'FAILED'}" for k, v in res["checks"].items())]
    return "\n".join(out)


def _parse(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help="one cold/warm pair (smoke test)")
    ap.add_argument("--repeat", type=int, default=None, help="cold/warm pairs (default 3; --quick: 1)")
    ap.add_argument("--storeys", type=int, default=6)
    ap.add_argument("--modes", type=int, default=4, help="measured modes")
    ap.add_argument("--sensors", type=int, default=3, help="sensor floors, spread over the height")
    ap.add_argument("--starts", type=int, default=8)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--blas-threads", type=int, default=1, help="BLAS threads of the children (0: as found)")
    ap.add_argument("--cache-root", default=None, help="where the temporary cache directories go (default: the system's)")
    ap.add_argument("--keep-cache", action="store_true", help="keep the temporary cache directories")
    ap.add_argument("--timeout", type=float, default=900.0, help="seconds allowed to one child process")
    ap.add_argument("--output", default=None, help="JSON file (default benchmarks/results/bench_first_use[_quick].json)")
    ap.add_argument("--child", nargs="+", help=argparse.SUPPRESS)  # internal: run as a measured child
    args = ap.parse_args(argv)
    if args.repeat is not None and args.repeat < 1:
        ap.error("--repeat must be at least 1")
    if not 1 <= args.modes <= args.storeys or not 1 <= args.sensors <= args.storeys:
        ap.error("--modes and --sensors must be between 1 and --storeys")
    return args


def main(argv=None) -> int:
    args = _parse(argv)
    if args.child:
        kind, *rest = args.child
        if kind == "import":
            child_import()
        elif kind == "numba":
            child_numba()
        else:
            child_run(*(int(x) for x in rest))
        return 0
    sys.path.insert(0, str(HERE))  # the shared probes (_probes.py)
    if (SRC / "femupdate").is_dir():
        sys.path.insert(0, str(SRC))
    from _probes import write_results

    res = run(args)
    write_results(res, "bench_first_use", args.quick, args.output, table, argv)
    return 0 if all(res["checks"].values()) else 1


if __name__ == "__main__":
    sys.exit(main())
