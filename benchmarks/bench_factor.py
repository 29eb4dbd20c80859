"""Benchmark: the lowest modes of large frames by femupdate against the best practice here, on three geometries.

For every model, in the same run:

(f1) ``model_modes(model, n_modes=10)`` on a fresh model: the factorisation layer's first call
     (the backend's factor; the route chosen for later calls);
(f2) the same call again: the route the workspace chose (band Cholesky, CHOLMOD or SuperLU);
(L)  the limit: CHOLMOD's supernodal Cholesky of K (analysed and factorised once) behind
     ARPACK (``eigsh(K, 10, M, sigma=0, OPinv=...)``), one BLAS thread — the best practice
     available here (needs scikit-sparse);
(e)  optionally (``--eigsh``) bare ``scipy.sparse.linalg.eigsh(K, 10, M, sigma=0)`` (SuperLU
     with SciPy's defaults), which is slow on cube-like models.

Geometries (:func:`femupdate.generators.frame_lattice`, steel tubes): ``tower`` (10 × 10 nodes in
plan, 4 m spacing, nz levels), ``tower-uneven`` (the same with spacing (4, 4.8, 4) m: the same
pattern, other values, no repeated modes) and ``cube`` (n × n × n nodes).  Reported: wall and
CPU seconds of each phase, the ratios f1/L and f2/L, the route, and per geometry the exponent of
time against dofs (least squares on log t = a + p log n).  The issue's goal: femupdate within 1.3
times the limit on every geometry.  The eigenvalues of every phase are checked against each other
(relative difference < 1e-8).

``--quick``: one small model per geometry (CI smoke run).  Results go to
``benchmarks/results/bench_factor[_quick].json``.

``--candidates``: the factorisations that install with pip alone against SuperLU and the band
route, on clamped solid and plate meshes (first factorisation, refactorisation at a new parameter
point, solves, a 15-mode shift-invert Lanczos, peak memory; each in a child process:
``_factor_candidates.py``); ``--mesh`` and ``--candidate`` to choose, ``--threads`` for BLAS
threads, ``--repeat`` to run each twice or more.  Results go to
``benchmarks/results/bench_factor_candidates[_quick].json``.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import platform
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
if (HERE.parent / "src" / "femupdate").is_dir():
    sys.path.insert(0, str(HERE.parent / "src"))

import numpy as np  # noqa: E402
import scipy  # noqa: E402
import scipy.sparse as sp  # noqa: E402
import scipy.sparse.linalg as spla  # noqa: E402
from threadpoolctl import threadpool_limits  # noqa: E402

import femupdate  # noqa: E402
from femupdate import model_modes  # noqa: E402
from femupdate.generators import frame_lattice  # noqa: E402

N_MODES = 10
SIZES = {"tower": [(10, 10, 20), (10, 10, 43), (10, 10, 86), (10, 10, 172)],
         "tower-uneven": [(10, 10, 20), (10, 10, 43), (10, 10, 86), (10, 10, 172)],
         "cube": [(12, 12, 12), (16, 16, 16), (20, 20, 20), (24, 24, 24)]}
QUICK = {"tower": [(6, 6, 12)], "tower-uneven": [(6, 6, 12)], "cube": [(8, 8, 8)]}
SPACING = {"tower": (4.0, 4.0, 4.0), "tower-uneven": (4.0, 4.8, 4.0), "cube": (4.0, 4.0, 4.0)}


def timed(fn):
    t, c = time.perf_counter(), time.process_time()
    out = fn()
    return out, time.perf_counter() - t, time.process_time() - c


def limit(K, M):
    from sksparse import cholmod

    def go():
        F = cholmod.cholesky(sp.csc_matrix(K), mode="supernodal")
        op = spla.LinearOperator(K.shape, matvec=F, dtype=float)
        return np.sort(spla.eigsh(K, k=N_MODES, M=M, sigma=0.0, which="LM", OPinv=op)[0])

    with threadpool_limits(1, user_api="blas"):
        return timed(go)


def run_model(geometry, size, eigsh: bool) -> dict:
    model = frame_lattice(*size, spacing=SPACING[geometry], parameters="storey").build()
    K, M = model.K(), model.M()  # the pattern, built once (as an update's first evaluation does)
    row = {"geometry": geometry, "size": list(size), "n_dofs": model.n_dofs, "nnz_K": int(K.nnz)}
    fresh = dataclasses.replace(model)
    fresh.K(), fresh.M()
    m1, row["f1_wall"], row["f1_cpu"] = timed(lambda: model_modes(fresh, n_modes=N_MODES))
    m2, row["f2_wall"], row["f2_cpu"] = timed(lambda: model_modes(fresh, n_modes=N_MODES))
    ws = femupdate.workspace._WORKSPACES.get(fresh)
    row.update(route=getattr(ws, "route", None), bandwidth=getattr(ws, "bandwidth", None), solver=m2.solver)
    Kc, Mc = sp.csc_array(K), sp.csc_array(M)
    try:
        lam_l, row["limit_wall"], row["limit_cpu"] = limit(Kc, Mc)
    except ImportError:
        lam_l = None
    ref = m2.eigenvalues
    diffs = [float(np.max(np.abs(m1.eigenvalues / ref - 1)))]
    if lam_l is not None:
        diffs.append(float(np.max(np.abs(lam_l / ref - 1))))
        row["f1_over_limit"] = row["f1_wall"] / row["limit_wall"]
        row["f2_over_limit"] = row["f2_wall"] / row["limit_wall"]
    if eigsh:
        lam_e, row["eigsh_wall"], row["eigsh_cpu"] = timed(
            lambda: np.sort(spla.eigsh(Kc, k=N_MODES, M=Mc, sigma=0.0, which="LM")[0]))
        diffs.append(float(np.max(np.abs(lam_e / ref - 1))))
    row["max_rel_eigenvalue_difference"] = max(diffs)
    return row


def exponent(rows, key):
    pts = [(r["n_dofs"], r[key]) for r in rows if r.get(key)]
    if len(pts) < 2:
        return None
    n, t = np.log([p[0] for p in pts]), np.log([p[1] for p in pts])
    return float(np.polyfit(n, t, 1)[0])


def candidates(args) -> int:
    """``--candidates``: every (mesh, candidate) in a child process, one after the other."""
    sys.path.insert(0, str(HERE))
    import _factor_candidates as fc

    meshes = args.mesh or list(fc.QUICK_MESHES if args.quick else fc.MESHES)
    res = {"benchmark": "bench_factor --candidates", "environment": {
        "python": platform.python_version(), "numpy": np.__version__, "scipy": scipy.__version__,
        "load_average_before": list(os.getloadavg()), "date": time.strftime("%Y-%m-%dT%H:%M:%S%z")}, "rows": []}
    ok = True
    for mesh in meshes:
        ref = None
        for cand in args.candidate or list(fc.CANDIDATES):
            for _ in range(args.repeat):
                row = fc.spawn(mesh, cand, args.threads)
                res["rows"].append(row)
                if "eigenvalues" in row:
                    lam = np.array(row["eigenvalues"])
                    ref = lam if ref is None else ref
                    row["max_rel_eigenvalue_difference"] = float(np.max(np.abs(lam / ref - 1)))
                    ok &= row["max_rel_eigenvalue_difference"] < 1e-8
                    print(f"{mesh:10s} {row['n_dofs']:7d} {cand:9s} first {row['first']:7.2f} s, refactor "
                          f"{row['refactor']:7.2f} s, solve {row['solve1'] * 1e3:7.1f} ms, 20 rhs {row['solve20']:6.2f} s, "
                          f"eig {row['eig']:7.2f} s, end to end {row['end_to_end']:7.2f} s, peak {row['peak_mb']:7.0f} MB, "
                          f"eigenvalues to {row['max_rel_eigenvalue_difference']:.1e}", flush=True)
                else:
                    print(f"{mesh:10s} {cand:9s} {row.get('skipped') or row.get('error')}", flush=True)
                    break
    res["environment"]["load_average_after"] = list(os.getloadavg())
    out = Path(args.output) if args.output else HERE / "results" / (
        "bench_factor_candidates_quick.json" if args.quick else "bench_factor_candidates.json")
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(res, indent=2) + "\n")
    print(f"results written to {out}")
    return 0 if ok else 1


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    if argv[:1] == ["--child"]:  # one (mesh, candidate) of --candidates, in this process
        sys.path.insert(0, str(HERE))
        import _factor_candidates as fc

        print(json.dumps(fc.measure(argv[1], argv[2], int(argv[3]))))
        return 0
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--geometry", choices=list(SIZES), action="append", help="only these geometries")
    ap.add_argument("--eigsh", action="store_true", help="also bare scipy eigsh (slow on cubes)")
    ap.add_argument("--output", default=None)
    ap.add_argument("--candidates", action="store_true", help="pip-installable factorisations against SuperLU")
    ap.add_argument("--mesh", action="append", help="--candidates: only these meshes")
    ap.add_argument("--candidate", action="append", help="--candidates: only these candidates")
    ap.add_argument("--threads", type=int, default=1, help="--candidates: BLAS threads")
    ap.add_argument("--repeat", type=int, default=1, help="--candidates: runs of each")
    args = ap.parse_args(argv)
    if args.candidates:
        return candidates(args)
    sizes = QUICK if args.quick else SIZES
    sys.path.insert(0, str(HERE))
    from _probes import settings_from_environment

    chosen = settings_from_environment()  # FEMUPDATE_FACTORISATION, FEMUPDATE_BLAS_THREADS as the command line reads them
    res = {"benchmark": "bench_factor", "environment": {
        "python": platform.python_version(), "numpy": np.__version__, "scipy": scipy.__version__,
        "femupdate": femupdate.__version__, "backend": femupdate.workspace.backend(),
        "load_average_before": list(os.getloadavg()), "date": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
        "FEMUPDATE_BLAS_THREADS": os.environ.get("FEMUPDATE_BLAS_THREADS"), "settings": dataclasses.asdict(chosen)},
        "rows": [], "exponents": {}}
    for geometry in args.geometry or list(sizes):
        rows = []
        for size in sizes[geometry]:
            row = run_model(geometry, size, args.eigsh)
            rows.append(row)
            res["rows"].append(row)
            lim = f"limit {row['limit_wall']:7.2f} s, f1/L {row['f1_over_limit']:4.2f}, f2/L {row['f2_over_limit']:4.2f}" \
                if "limit_wall" in row else "limit -"
            print(f"{geometry:12s} {str(tuple(size)):14s} {row['n_dofs']:7d} dofs: f1 {row['f1_wall']:7.2f} s, "
                  f"f2 {row['f2_wall']:7.2f} s ({row['route']}), {lim}"
                  + (f", eigsh {row['eigsh_wall']:.2f} s" if "eigsh_wall" in row else "")
                  + f"; eigenvalues agree to {row['max_rel_eigenvalue_difference']:.1e}", flush=True)
        res["exponents"][geometry] = {k: exponent(rows, k) for k in ("f1_wall", "f2_wall", "limit_wall", "eigsh_wall")}
        print(f"{geometry}: time ~ n^p, p = " + ", ".join(f"{k} {v:.2f}" for k, v in res["exponents"][geometry].items()
                                                      if v is not None), flush=True)
    res["environment"]["load_average_after"] = list(os.getloadavg())
    out = Path(args.output) if args.output else HERE / "results" / ("bench_factor_quick.json" if args.quick else "bench_factor.json")
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(res, indent=2) + "\n")
    print(f"results written to {out}")
    ok = all(r["max_rel_eigenvalue_difference"] < 1e-8 for r in res["rows"])
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
