"""Benchmark: FRF residual surfaces and Brandon's receptance sensitivities, each against its
baseline in the same run.

Usage::

    python benchmarks/bench_frf.py            # 200 x 200 surface; 50,000-dof truss, 100 parameters, 20 lines
    python benchmarks/bench_frf.py --quick    # 40 x 40 surface; 400-dof truss, 10 parameters, 6 lines (smoke test)
    python benchmarks/bench_frf.py --model frame   # 54,000-dof space-frame tower 10 x 9 x 101 instead

(1) **Residual surface** (paper eq. 34, Figure 6): the two-dof system, 5 lines 0.5 rad/s apart,
    receptances at both dofs, over a 200 x 200 grid of (k1, k2).  femupdate's
    :func:`~femupdate.frf.surfaces.frf_surface` (every point and line in stacked LAPACK solves)
    against the per-point loop a user would write (``K(p)``, ``M(p)`` and one
    ``numpy.linalg.solve`` per line at every grid point).  Both are timed in full; the values must
    agree.

(2) **Receptance sensitivities** (eq. 32) of a plane X-braced steel truss
    (:func:`~femupdate.generators.truss_lattice` 250 x 101 nodes: 50,000 dofs, one Young's
    modulus per storey: 100 parameters), 20 lines spread from half the first natural frequency to
    just below the tenth, one excitation dof (top corner, x) and 10 measured dofs.  femupdate:
    :func:`~femupdate.frf.receptance_sensitivity` (one sparse LU per line, reused for every
    parameter: 11 solves per line) for all lines and parameters.  Baseline: central finite
    differences, two factorisations per (parameter, line) — ``N_FD`` pairs are actually run and
    timed, and their mean time is extrapolated to 100 parameters x 20 lines (as
    ``bench_jacobian.py`` does).  The FD pairs are also the accuracy check, on the line farthest
    from and the line nearest to a resonance: Brandon's derivative is exact, the FD truncation
    error grows near resonances.  The resonance check (distance of each line to the nearest
    mode, shift-invert Lanczos with the line's own factor) is timed as its own phase.

Load average (1, 5, 15 min) is recorded before and after: the development machine has 2 cores
shared with other work.  Results go to ``benchmarks/results/bench_frf.json``
(``bench_frf_quick.json`` with ``--quick``).
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
if (HERE.parent / "src" / "femupdate").is_dir():  # benchmark the checked-out source tree
    sys.path.insert(0, str(HERE.parent / "src"))
from _probes import Phase, write_results  # noqa: E402
from femupdate import model_modes  # noqa: E402
from femupdate.examples import two_dof  # noqa: E402
from femupdate.frf import receptance_sensitivity, resonances, simulate  # noqa: E402
from femupdate.frf.lines import LineSystems  # noqa: E402
from femupdate.frf.surfaces import frf_surface  # noqa: E402
from femupdate.generators import frame_lattice, truss_lattice  # noqa: E402

FULL = {"grid": 200, "truss": (250, 101), "frame": (10, 9, 101), "lines": 20, "sensors": 10}
QUICK = {"grid": 40, "truss": (20, 11), "frame": (3, 3, 11), "lines": 6, "sensors": 4}
N_FD = 4  # (parameter, line) pairs run by central differences
FD_STEP = 1e-6  # relative
FD_TOL_FAR = 1e-5  # Brandon vs FD on the line farthest from resonance


# ------------------------------------------------------------------ (1) surface
def surface_loop(model, data, x, y) -> np.ndarray:
    """The per-point baseline: assemble and solve at every grid point, one line at a time."""
    f = np.zeros(model.n_dofs)
    for d, v in data.force.items():
        f[model.dofs.index(d)] = v
    S = model.dof_index(data.dofs)
    out = np.empty((x.size, y.size))
    for i, a in enumerate(x):
        for j, b in enumerate(y):
            K = model.K([a, b]).toarray()
            M = model.M([a, b]).toarray()
            r = 0.0
            for k, w in enumerate(data.omega):
                try:
                    xa = np.linalg.solve(K - w**2 * M, f)[S]
                except np.linalg.LinAlgError:
                    r = np.inf
                    break
                r += float(np.sum((xa - data.response[k]) ** 2))
            out[i, j] = r
    return out


def bench_surface(n: int) -> dict:
    model = two_dof()
    data = simulate(model, 0.5 * np.arange(1, 6), {"1:x": 1.0})
    x, y = np.linspace(3, 13, n), np.linspace(1, 11, n)
    frf_surface(model, data, ["k1", "k2"], x[:3], y[:3])  # warm-up (imports, caches)
    times = []
    for _ in range(3):
        with Phase() as ph:
            s = frf_surface(model, data, ["k1", "k2"], x, y)
        times.append(ph.seconds)
    with Phase() as ph_loop:
        ref = surface_loop(model, data, x, y)
    both = np.isfinite(ref) & np.isfinite(s.values)
    rel = float(np.max(np.abs(s.values[both] - ref[both]) / np.maximum(ref[both], 1e-300)))
    same_inf = bool(np.array_equal(np.isinf(ref), np.isinf(s.values)))
    return {"grid": [n, n], "lines": 5, "points": n * n, "vectorised_s": min(times), "vectorised_runs_s": times,
            "loop_s": ph_loop.seconds, "ratio_loop_over_vectorised": ph_loop.seconds / min(times),
            "max_rel_difference": rel, "same_singular_points": same_inf,
            "ok": bool(rel < 1e-8 and same_inf)}


# ------------------------------------------------------------------ (2) sensitivities
def large_model(kind: str, cfg: dict):
    if kind == "truss":
        nx, ny = cfg["truss"]
        s = truss_lattice(nx, ny)
        top = 1 + nx * ny - 1  # top right corner node
        exc = [f"{top}:x"]
        levels = np.unique(np.linspace(1, ny - 1, cfg["sensors"] // 2).round().astype(int))
        sensors = [f"{1 + nx * j + nx - 1}:{d}" for j in levels for d in ("x", "y")]
    else:
        nx, ny, nz = cfg["frame"]
        s = frame_lattice(nx, ny, nz)
        top = nx * ny * nz
        exc = [f"{top}:x"]
        levels = np.unique(np.linspace(1, nz - 1, cfg["sensors"] // 2).round().astype(int))
        sensors = [f"{nx * ny * k + 1}:{d}" for k in levels for d in ("x", "y")]
    return s, exc, sensors[: cfg["sensors"]]


def bench_sensitivity(kind: str, cfg: dict) -> dict:
    phases = {}

    def record(name, ph, **extra):
        phases[name] = {"seconds": ph.seconds, "rss_peak_mb": ph.rss_peak, "rss_delta_mb": ph.rss_delta, **extra}

    s, exc, sensors = large_model(kind, cfg)
    with Phase() as ph:
        model = s.build()
    record("build", ph)
    K = model.K()  # also builds the shared pattern
    n, L = model.n_dofs, len(model.parameters)
    with Phase() as ph:
        modes = model_modes(model, n_modes=10)
    record("modes_for_the_band", ph)
    wn = np.sqrt(modes.eigenvalues)
    omega = np.linspace(0.5 * wn[0], 0.97 * wn[-1], cfg["lines"])
    with Phase() as ph:
        sens = receptance_sensitivity(model, omega, sensors, exc, resonance_check=False, method="sparse")
    record("f_brandon_all", ph, lines=int(omega.size), parameters=L, solves_per_line=len(exc) + len(sensors))
    with Phase() as ph:
        res = resonances(model, omega)  # standalone: its own factorisation per line, then Lanczos
    record("resonance_check", ph)
    d = res.distance
    far, near = int(np.argmax(d)), int(np.argmin(d))
    params = [0, L // 2, L - 1, L // 3][:N_FD]
    pairs = [(params[0], far), (params[1], far), (params[2], near), (params[3], near)][:N_FD]
    fd_times, checks = [], []
    p0 = model.values
    f = np.zeros((n, len(exc)))
    f[model.dof_index(exc), np.arange(len(exc))] = 1.0
    S = model.dof_index(sensors)
    for j, i in pairs:
        h = FD_STEP * abs(p0[j])
        t0 = time.perf_counter()
        sides = []
        for sgn in (1.0, -1.0):
            p = p0.copy()
            p[j] += sgn * h
            sides.append(LineSystems(model, p, omega[i:i + 1], method="sparse").solve(f)[0][S])
        fd = (sides[0] - sides[1]) / (2 * h)
        fd_times.append(time.perf_counter() - t0)
        b = sens.dalpha[i, :, :, j]
        checks.append({"parameter": model.parameter_names[j], "line": i + 1, "omega_rad_s": float(omega[i]),
                       "resonance_distance": float(d[i]),
                       "rel_difference": float(np.max(np.abs(b - fd)) / np.max(np.abs(b)))})
    fd_extrapolated = float(np.mean(fd_times)) * L * omega.size
    f_s = phases["f_brandon_all"]["seconds"]
    far_err = max(c["rel_difference"] for c in checks if c["line"] == far + 1)
    return {
        "model": {"kind": kind, "generator": f"{kind}_lattice{cfg[kind]}", "n_dofs": n, "n_parameters": L,
                  "nnz_K": int(K.nnz), "excitation": exc, "sensors": sensors, "omega_rad_s": omega.tolist(),
                  "natural_frequencies_rad_s": wn.tolist()},
        "phases": phases,
        "fd": {"pairs_run": len(pairs), "seconds_each": fd_times, "extrapolated_s": fd_extrapolated,
               "extrapolated_to": f"{L} parameters x {omega.size} lines, 2 factorisations each"},
        "ratio_fd_over_brandon": fd_extrapolated / f_s,
        "resonance_distance": {"min": float(d.min()), "max": float(d.max())},
        "checks": checks,
        "ok": bool(far_err < FD_TOL_FAR),
    }


def load() -> list[float]:
    try:
        return [round(v, 2) for v in os.getloadavg()]
    except OSError:
        return []


def table(res: dict) -> str:
    s, g = res["surface"], res["sensitivity"]
    m, ph = g["model"], g["phases"]
    out = [f"load average before {res['load_before']}, after {res['load_after']}", "",
           f"(1) eq. 34 surface, two-dof system, {s['grid'][0]} x {s['grid'][1]} grid, 5 lines:",
           f"    femupdate frf_surface {s['vectorised_s']:.3f} s (best of 3)   per-point loop {s['loop_s']:.2f} s   "
           f"ratio {s['ratio_loop_over_vectorised']:.0f}x   max rel. difference {s['max_rel_difference']:.1e} "
           f"({'OK' if s['ok'] else 'FAIL'})", "",
           f"(2) receptance sensitivities: {m['generator']}, {m['n_dofs']} dofs, {m['n_parameters']} parameters, "
           f"{len(m['omega_rad_s'])} lines, {len(m['sensors'])} sensors x {len(m['excitation'])} excitation"]
    out.append(f"    {'phase':44s} {'time s':>9s} {'RSS peak MB':>12s} {'RSS +MB':>9s}")
    for key, label in (("build", "Structure.build()"), ("modes_for_the_band", "model_modes(10) (to place the lines)"),
                       ("f_brandon_all", "receptance_sensitivity (eq. 32), all"),
                       ("resonance_check", "resonance check (Lanczos per line)")):
        p = ph[key]
        out.append(f"    {label:44s} {p['seconds']:9.2f} {p['rss_peak_mb']:12.1f} {p['rss_delta_mb']:9.1f}")
    fd = g["fd"]
    out.append(f"    {'central differences (EXTRAPOLATED)':44s} {fd['extrapolated_s']:9.0f}   (mean of {fd['pairs_run']} "
               f"timed (parameter, line) pairs, {np.mean(fd['seconds_each']):.2f} s, x {fd['extrapolated_to']})")
    out.append(f"    ratio FD / Brandon = {g['ratio_fd_over_brandon']:.0f}x")
    for c in g["checks"]:
        out.append(f"    check {c['parameter']:>6s} line {c['line']:2d} ({c['omega_rad_s']:.4g} rad/s, distance to "
                   f"resonance {c['resonance_distance']:.2g}): Brandon vs FD {c['rel_difference']:.1e}")
    out.append(f"    accuracy check far from resonance: {'OK' if g['ok'] else 'FAIL'} (tolerance {FD_TOL_FAR:g})")
    if m["n_dofs"] < 50_000:
        out.append("    note: the targets are for the full-size model (>= 50,000 dofs); small runs only smoke-test")
    return "\n".join(out)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help="small sizes for a smoke test")
    ap.add_argument("--model", choices=["truss", "frame"], default="truss")
    ap.add_argument("--output", type=Path, help="JSON file (default benchmarks/results/bench_frf[_quick].json)")
    args = ap.parse_args(argv)
    cfg = QUICK if args.quick else FULL
    res = {"load_before": load()}
    res["surface"] = bench_surface(cfg["grid"])
    res["sensitivity"] = bench_sensitivity(args.model, cfg)
    res["load_after"] = load()
    write_results(res, "bench_frf", args.quick, args.output, table, argv)
    return 0 if res["surface"]["ok"] and res["sensitivity"]["ok"] else 1


if __name__ == "__main__":
    sys.exit(main())
