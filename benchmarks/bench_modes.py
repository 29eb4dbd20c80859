"""Benchmark: assembly and lowest modes of a >= 100,000-dof frame against bare SciPy ``eigsh``.

Usage::

    python benchmarks/bench_modes.py            # 10 x 10 x 172 frame tower, 102,600 dofs
    python benchmarks/bench_modes.py --quick    # 8 x 8 x 6 lattice, 1,920 dofs (CI smoke test)
    python benchmarks/bench_modes.py --size 30 30 20   # any frame_lattice (see the note below)

One run measures, on one model,

(a) ``Structure.build()`` (assembly of the affine sparse model), and the first and a repeated
    evaluation of ``K(p), M(p)`` (the first one builds ``Model._pattern``);
(b) ``femupdate.model_modes(model, n_modes=10)`` — femupdate's sparse shift-invert path;
(c) the baseline ``scipy.sparse.linalg.eigsh(K, k=10, M=M, sigma=0, which="LM")`` on the same
    matrices (given as CSC, the format its LU wants);

and reports the ratio (b)/(c) of times and of memory, and checks that (b) and (c) agree on the
eigenvalues (relative difference < 1e-8).

Memory, per phase:

* ``rss_peak_mb``: the process's resident-set high-water mark during the phase (Linux: reset
  before each phase through ``/proc/self/clear_refs``); ``rss_delta_mb`` is that peak minus the
  resident set at the start of the phase, i.e. what the phase itself needed.  This includes
  SuperLU's factors, which are allocated in C and invisible to tracemalloc.
* ``tracemalloc_peak_mb``: peak of Python/NumPy allocations during the phase, from a second,
  traced run of the phase (tracing slows allocation-heavy code, so times come from the untraced
  run).  ``--no-tracemalloc`` skips the traced runs.

Nothing here changes the BLAS set-up: ``OPENBLAS_CORETYPE`` and thread counts are reported as
found.  Results go to ``benchmarks/results/bench_modes.json`` (``bench_modes_quick.json`` with
``--quick``; the directory is git-ignored).

Note on size: a cube-like lattice is the worst case for SciPy's SuperLU (COLAMD ordering): for
``--size 30 30 20`` (102,600 dofs) one ``splu(K)`` alone takes about 10 minutes and 11.6 GB, and
``model_modes`` holds two such factors at once (a singularity check, then eigsh's own), so it
needs more than 23 GB.  The default tower has the same dof count and a factor of ~150 M entries.
"""

from __future__ import annotations

import argparse
import dataclasses
import gc
import sys
import tracemalloc
from pathlib import Path

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))  # the shared probes (_probes.py), also when imported by a test
if (HERE.parent / "src" / "femupdate").is_dir():  # benchmark the checked-out source tree
    sys.path.insert(0, str(HERE.parent / "src"))
from _probes import MB, Phase, write_results  # noqa: E402
from femupdate import model_modes  # noqa: E402
from femupdate.generators import frame_lattice
from femupdate.modal import DENSE_LIMIT

FULL_SIZE = (10, 10, 172)
QUICK_SIZE = (8, 8, 6)
N_MODES = 10
EIG_RTOL = 1e-8


def traced_peak(fn) -> float:
    """Peak of tracemalloc-visible allocations (MB) while running ``fn()``."""
    gc.collect()
    tracemalloc.start()
    try:
        tracemalloc.reset_peak()
        out = fn()
        peak = tracemalloc.get_traced_memory()[1] / MB
    finally:
        tracemalloc.stop()
    del out
    gc.collect()
    return peak


# ------------------------------------------------------------------ the benchmark
def run(size, trace: bool = True) -> dict:
    results: dict = {"phases": {}}
    phases = results["phases"]

    def record(name, ph, fn=None):
        phases[name] = {"seconds": ph.seconds, "rss_peak_mb": ph.rss_peak, "rss_delta_mb": ph.rss_delta}
        if trace and fn is not None:
            phases[name]["tracemalloc_peak_mb"] = traced_peak(fn)

    with Phase() as ph:
        structure = frame_lattice(*size)
    record("generate", ph, lambda: frame_lattice(*size))

    with Phase() as ph:
        model = structure.build()
    record("build", ph, structure.build)

    with Phase() as ph:
        K, M = model.K(), model.M()
    record("K_M_first", ph)
    if trace:  # a copy of the model has no cached pattern yet
        fresh = dataclasses.replace(model)
        phases["K_M_first"]["tracemalloc_peak_mb"] = traced_peak(lambda: (fresh.K(), fresh.M()))
        del fresh

    with Phase() as ph:
        K2, M2 = model.K(), model.M()
    record("K_M_again", ph, lambda: (model.K(), model.M()))
    del K2, M2

    n = model.n_dofs
    path = "dense" if n <= DENSE_LIMIT else "sparse"
    with Phase() as ph:
        modes = model_modes(model, n_modes=N_MODES)
    record("model_modes", ph, lambda: model_modes(model, n_modes=N_MODES))

    Kc, Mc = sp.csc_array(K), sp.csc_array(M)
    del K, M
    with Phase() as ph:
        lam_ref, _phi = spla.eigsh(Kc, k=N_MODES, M=Mc, sigma=0, which="LM")
    del _phi
    record("eigsh_baseline", ph, lambda: spla.eigsh(Kc, k=N_MODES, M=Mc, sigma=0, which="LM"))

    lam_ref = np.sort(lam_ref)
    lam = modes.eigenvalues
    rel = float(np.max(np.abs(lam - lam_ref) / np.abs(lam_ref)))
    b, c = phases["model_modes"], phases["eigsh_baseline"]
    results.update(
        model={
            "generator": f"frame_lattice{tuple(size)}", "n_dofs": n, "n_parameters": len(model.parameters),
            "nnz_K": int(Kc.nnz), "nnz_M": int(Mc.nnz), "modes_path": path, "n_modes": N_MODES,
        },
        eigen_check={
            "max_rel_diff": rel, "tolerance": EIG_RTOL, "ok": bool(rel < EIG_RTOL),
            "frequencies_hz": modes.frequencies_hz.tolist(),
        },
        ratio={
            "time_modes_over_baseline": b["seconds"] / c["seconds"],
            "rss_delta_modes_over_baseline": b["rss_delta_mb"] / c["rss_delta_mb"] if c["rss_delta_mb"] > 0 else None,
        },
    )
    return results


def table(res: dict) -> str:
    rows = [
        ("generate", "frame_lattice(...) -> Structure"),
        ("build", "(a) Structure.build()"),
        ("K_M_first", "(a') first K(p), M(p) (+ pattern)"),
        ("K_M_again", "     repeated K(p), M(p)"),
        ("model_modes", "(b) model_modes(n_modes=10)"),
        ("eigsh_baseline", "(c) eigsh(K, 10, M, sigma=0)"),
    ]
    m = res["model"]
    out = [f"model: {m['generator']}: {m['n_dofs']} dofs, {m['n_parameters']} parameters, "
           f"nnz(K) = {m['nnz_K']}, modes path: {m['modes_path']}", ""]
    out.append(f"{'phase':38s} {'time s':>9s} {'RSS peak MB':>12s} {'RSS +MB':>9s} {'tracemalloc MB':>15s}")
    for key, label in rows:
        p = res["phases"][key]
        tm = p.get("tracemalloc_peak_mb")
        out.append(f"{label:38s} {p['seconds']:9.3f} {p['rss_peak_mb']:12.1f} {p['rss_delta_mb']:9.1f} "
                   f"{(f'{tm:.1f}' if tm is not None else '-'):>15s}")
    r = res["ratio"]
    mem = r["rss_delta_modes_over_baseline"]
    mem_txt = f", RSS increase {mem:.2f}" if mem is not None else ""
    out += ["", f"ratio (b)/(c): time {r['time_modes_over_baseline']:.2f}{mem_txt}"]
    e = res["eigen_check"]
    out.append(f"eigenvalues (b) vs (c): max relative difference {e['max_rel_diff']:.2e} "
               f"({'OK' if e['ok'] else 'FAIL'}, tolerance {e['tolerance']:g})")
    out.append("frequencies (Hz): " + ", ".join(f"{f:.4g}" for f in e["frequencies_hz"]))
    if not res["environment"]["rss_hwm_reset"]:
        out.append("note: could not reset the RSS high-water mark; RSS peaks are process-wide maxima")
    return "\n".join(out)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help=f"small model {QUICK_SIZE} for smoke tests")
    ap.add_argument("--size", type=int, nargs=3, metavar=("NX", "NY", "NZ"), help="frame_lattice size")
    ap.add_argument("--no-tracemalloc", action="store_true", help="skip the traced (memory) re-runs")
    ap.add_argument("--output", type=Path, help="JSON file (default benchmarks/results/bench_modes[_quick].json)")
    args = ap.parse_args(argv)
    size = tuple(args.size) if args.size else (QUICK_SIZE if args.quick else FULL_SIZE)
    res = run(size, trace=not args.no_tracemalloc)
    write_results(res, "bench_modes", args.quick, args.output, table, argv)
    return 0 if res["eigen_check"]["ok"] else 1


if __name__ == "__main__":
    sys.exit(main())
