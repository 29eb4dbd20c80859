"""Benchmark: Guyan and IRS reduction of a >= 100,000-dof frame to <= 200 retained dofs.

Usage::

    python benchmarks/bench_reduction.py            # 10 x 10 x 172 frame tower, 102,600 dofs -> 192 dofs
    python benchmarks/bench_reduction.py --quick    # 6 x 6 x 8 lattice, 1,512 dofs (CI smoke test)

One run measures, on one model and one keep-set (x, y, z at the four corner nodes of 16 levels),

(a) the limit, done by hand: extract K_oo, K_oa, factorise K_oo once by the best practice here —
    CHOLMOD's supernodal Cholesky where scikit-sparse is installed, else SuperLU (the symmetric
    ``MMD_AT_PLUS_A`` ordering in symmetric mode; SuperLU's default partial pivoting is 20-50 times
    slower on this matrix), one BLAS thread — and solve for the a right-hand sides of Guyan, then
    the a more of IRS: nothing a reduction can avoid;
(b) ``Reducer(model, keep).guyan()`` plus the reduced ``K_G, M_G``;
(c) ``Reducer(model, keep).irs()`` (a fresh reducer: its own factorisation) plus the reduced matrices;
(d) ``reduce(model, T_G)``: the affine reduced model, every parameter matrix projected;

and reports the ratios (b)/(a_guyan), (c)/(a_irs), and checks that (b) equals the Schur
complement ``K_aa - K_ao K_oo^-1 K_oa`` of (a) (relative difference < 1e-8).  The load average
is recorded with the timings (the machine is shared).  Results go to
``benchmarks/results/bench_reduction[_quick].json``.
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

import numpy as np
import scipy
import scipy.sparse as sp
import scipy.sparse.linalg as spla

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
if (HERE.parent / "src" / "femupdate").is_dir():
    sys.path.insert(0, str(HERE.parent / "src"))
from _probes import Phase, write_results  # noqa: E402
from femupdate.generators import frame_lattice  # noqa: E402
from femupdate.reduction import Reducer, reduce  # noqa: E402

FULL_SIZE = (10, 10, 172)
QUICK_SIZE = (6, 6, 8)
N_LEVELS = 16
RTOL = 1e-8


def keep_set(nx, ny, nz, n_levels=N_LEVELS) -> list[str]:
    """x, y, z at the four plan corners of ``n_levels`` levels spread up the tower (12 per level)."""
    levels = np.unique(np.linspace(1, nz - 1, min(n_levels, nz - 1)).round().astype(int))
    corners = [(0, 0), (nx - 1, 0), (nx - 1, ny - 1), (0, ny - 1)]
    return [f"{1 + i + nx * j + nx * ny * k}:{d}" for k in levels for i, j in corners for d in "xyz"]


def run(size) -> dict:
    res: dict = {"phases": {}, "load_average": {"start": os.getloadavg()}}
    ph_ = res["phases"]

    def rec(name, ph):
        ph_[name] = {"seconds": ph.seconds, "rss_peak_mb": ph.rss_peak, "rss_delta_mb": ph.rss_delta,
                     "load_average_1min": os.getloadavg()[0]}

    with Phase() as ph:
        model = frame_lattice(*size).build()
    rec("build", ph)
    keep = keep_set(*size)
    K = model.K()
    ia = model.dof_index(keep)
    mask = np.ones(model.n_dofs, bool)
    mask[ia] = False
    io = np.flatnonzero(mask)

    # (a) the limit: one factorisation of K_oo and the solves, by the best practice available here:
    # CHOLMOD's supernodal Cholesky where scikit-sparse is installed, else SuperLU; one BLAS thread
    from threadpoolctl import threadpool_limits

    try:
        from sksparse import cholmod
    except ImportError:
        cholmod = None
    res["limit_factorisation"] = "CHOLMOD" if cholmod is not None else "SuperLU"
    with threadpool_limits(1, user_api="blas"):
        with Phase() as ph:
            K_oo = sp.csc_array(K[io][:, io])
            K_oa = K[io][:, ia].toarray()
            if cholmod is not None:
                F = cholmod.cholesky(sp.csc_matrix(K_oo), mode="supernodal")
                solve = F
            else:
                lu = spla.splu(K_oo, permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.1, options={"SymmetricMode": True})
                solve = lu.solve
            X = solve(np.asfortranarray(K_oa))
        rec("limit_guyan", ph)
        with Phase() as ph:
            Y = solve(np.asfortranarray(X))
        rec("limit_irs_second_solve", ph)
    del Y
    K_G_ref = K[ia][:, ia].toarray() - K[ia][:, io] @ X
    del solve, X, K_oo
    ph_["limit_irs"] = {"seconds": ph_["limit_guyan"]["seconds"] + ph_["limit_irs_second_solve"]["seconds"]}

    # (b) Guyan
    with Phase() as ph:
        red = Reducer(model, keep)
        tg = red.guyan()
        K_G, M_G = red.guyan_matrices
    rec("guyan", ph)
    diff = float(np.max(np.abs(K_G - K_G_ref)) / np.max(np.abs(K_G_ref)))
    del red

    # (c) IRS
    with Phase() as ph:
        red2 = Reducer(model, keep)
        ti = red2.irs()
        from femupdate.reduction.projection import project

        K_I, M_I = project(red2.K, ti.T), project(red2.M, ti.T)
    rec("irs", ph)
    del red2

    # (d) the affine reduced model
    with Phase() as ph:
        rm = reduce(model, tg)
    rec("reduce_affine", ph)
    f_g = np.sqrt(np.clip(scipy.linalg.eigh(K_G, M_G, eigvals_only=True)[:5], 0, None)) / (2 * np.pi)
    f_i = np.sqrt(np.clip(scipy.linalg.eigh(K_I, M_I, eigvals_only=True)[:5], 0, None)) / (2 * np.pi)
    res["load_average"]["end"] = os.getloadavg()
    res.update(
        model={"generator": f"frame_lattice{tuple(size)}", "n_dofs": model.n_dofs, "n_keep": len(keep),
               "n_parameters": len(model.parameters), "nnz_K": int(K.nnz), "reduced_parameters": len(rm.parameters)},
        check={"guyan_vs_schur_max_rel_diff": diff, "tolerance": RTOL, "ok": bool(diff < RTOL),
               "guyan_frequencies_hz": f_g.tolist(), "irs_frequencies_hz": f_i.tolist()},
        ratio={"guyan_over_limit": ph_["guyan"]["seconds"] / ph_["limit_guyan"]["seconds"],
               "irs_over_limit": ph_["irs"]["seconds"] / ph_["limit_irs"]["seconds"]},
    )
    return res


def table(res: dict) -> str:
    m = res["model"]
    out = [f"model: {m['generator']}: {m['n_dofs']} dofs -> {m['n_keep']} retained, {m['n_parameters']} parameters, "
           f"nnz(K) = {m['nnz_K']}", ""]
    out.append(f"{'phase':48s} {'time s':>9s} {'RSS peak MB':>12s} {'RSS +MB':>9s} {'load 1min':>10s}")
    labels = {"build": "Structure.build()", "limit_guyan": f"(a) limit ({res.get('limit_factorisation', 'SuperLU')}): factorise K_oo + a solves",
              "limit_irs_second_solve": "    + a more solves (IRS)", "guyan": "(b) Reducer.guyan() + K_G, M_G",
              "irs": "(c) Reducer.irs() + K_IRS, M_IRS", "reduce_affine": "(d) reduce(model, T_G): every parameter"}
    for k, lab in labels.items():
        p = res["phases"][k]
        out.append(f"{lab:48s} {p['seconds']:9.3f} {p['rss_peak_mb']:12.1f} {p['rss_delta_mb']:9.1f} {p['load_average_1min']:10.2f}")
    r, c = res["ratio"], res["check"]
    out += ["", f"ratio guyan / limit {r['guyan_over_limit']:.2f}; irs / limit {r['irs_over_limit']:.2f}",
            f"Guyan K vs Schur complement: max rel. diff {c['guyan_vs_schur_max_rel_diff']:.2e} ({'OK' if c['ok'] else 'FAIL'})",
            "Guyan frequencies (Hz): " + ", ".join(f"{f:.4g}" for f in c["guyan_frequencies_hz"]),
            "IRS frequencies (Hz):   " + ", ".join(f"{f:.4g}" for f in c["irs_frequencies_hz"]),
            f"load average start {res['load_average']['start']}, end {res['load_average']['end']}"]
    return "\n".join(out)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help=f"small model {QUICK_SIZE} for smoke tests")
    ap.add_argument("--size", type=int, nargs=3, metavar=("NX", "NY", "NZ"), help="frame_lattice size")
    ap.add_argument("--output", type=Path, help="JSON file (default benchmarks/results/bench_reduction[_quick].json)")
    args = ap.parse_args(argv)
    size = tuple(args.size) if args.size else (QUICK_SIZE if args.quick else FULL_SIZE)
    res = run(size)
    write_results(res, "bench_reduction", args.quick, args.output, table, argv)
    return 0 if res["check"]["ok"] else 1


if __name__ == "__main__":
    sys.exit(main())
