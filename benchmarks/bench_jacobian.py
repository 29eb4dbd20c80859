"""Benchmark: the updating Jacobian of a >= 100,000-dof, >= 1,000-parameter frame, against one bare
SciPy eigensolution and against finite differences.

Usage::

    python benchmarks/bench_jacobian.py            # 10 x 10 x 172 tower: 102,600 dofs, 1,026 parameters
    python benchmarks/bench_jacobian.py --quick    # 5 x 4 x 18 tower: 2,040 dofs, 102 parameters (smoke test)
    python benchmarks/bench_jacobian.py --size NX NY NZ

The model is a frame tower (``frame_lattice`` geometry, built here through the public
:class:`~femupdate.Structure` API) with SIX parameters per storey: Young's modulus and density of
the storey's x-beams, y-beams and columns (``Ex_s, rhox_s, Ey_s, rhoy_s, Ez_s, rhoz_s``), i.e.
stiffness AND mass parameters, ``L = 6 (NZ - 1)``.  The bays are 1.0 m along x and 1.2 m along y
so that the plan is not square (a square plan has pairs of equal frequencies, whose eigenvector
derivatives do not exist).  Sensors: ``N_SENSORS`` = 30 translations (x and y at one corner, y
at the opposite corner) on 10 levels spread over the height.

One run measures, on one model,

(b) the baseline: ONE bare SciPy shift-invert eigensolution,
    ``scipy.sparse.linalg.eigsh(K, k=10, M=M, sigma=0, which="LM")`` (CSC matrices);
(f) femupdate: ``model_modes(model, n_modes=buffered_modes(10))`` (10 modes + a buffer of 10) and
    ``jacobian(model, modes, range(10), sensors, method="adjoint")``: the (relative) eigenvalue
    derivatives and the 30 measured components of the 10 mode-shape derivatives (each mode
    scaled to 1 at its largest measured component), for all L parameters;
(a) finite differences as the open peers do them: one eigensolution (10 modes) per parameter.
    Only ``N_FD`` = 3 perturbed eigensolutions are run and timed; (a) is their mean time
    extrapolated to L parameters (forward differences; central differences would double it);

and reports the ratios (f)/(b) (target <= 3) and (a)/(f) (target >= 100).  Checks (not timed):
the adjoint Jacobian against the forward ``subspace`` route (mass-normalised shape derivatives
at the sensors and eigenvalue derivatives) on ``N_CHECK`` = 3 parameters, and against central
finite differences on one parameter (from two of the three timed perturbed solutions).

Memory per phase is reported as in ``bench_modes.py`` (resident-set high-water mark, reset before
each phase on Linux).  Results go to ``benchmarks/results/bench_jacobian.json``
(``bench_jacobian_quick.json`` with ``--quick``).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))  # the shared probes (_probes.py), also when imported by a test
if (HERE.parent / "src" / "femupdate").is_dir():  # benchmark the checked-out source tree
    sys.path.insert(0, str(HERE.parent / "src"))
from _probes import Phase, write_results  # noqa: E402
from femupdate import Structure, model_modes  # noqa: E402
from femupdate.correlation import mac, pair  # noqa: E402
from femupdate.generators import chs_section  # noqa: E402
from femupdate.sensitivity import buffered_modes, jacobian, scaled_shape  # noqa: E402
from femupdate.sensitivity.factor import prepare_factor  # noqa: E402
from femupdate.sensitivity.subspace import subspace_details  # noqa: E402

FULL_SIZE = (10, 10, 172)
QUICK_SIZE = (5, 4, 18)
N_MODES = 10  # differentiated modes
N_SENSORS = 30
N_FD = 3  # perturbed eigensolutions actually run for (a)
N_CHECK = 3  # parameters checked against the forward route
CHECK_TOL = 1e-8  # adjoint vs forward subspace (relative, per parameter)
FD_TOL = 1e-5  # adjoint vs central differences on one parameter
FD_STEP = 1e-4  # relative step
SPACING = (1.0, 1.2, 1.0)
MB = 1024.0**2


# ------------------------------------------------------------------ the model
def tower(nx: int, ny: int, nz: int, spacing=SPACING, E: float = 210e9, nu: float = 0.3, rho: float = 7850.0) -> Structure:
    """``frame_lattice`` geometry with E and rho of x-beams, y-beams and columns per storey."""
    sx, sy, sz = spacing
    sec = chs_section()
    s = Structure(f"tower {nx}x{ny}x{nz}, 6 parameters per storey")
    ids = 1 + np.arange(nx * ny * nz, dtype=np.int64).reshape(nz, ny, nx)
    k, j, i = np.indices((nz, ny, nx))
    s.add_nodes(ids.ravel(), np.column_stack([i.ravel() * sx, j.ravel() * sy, k.ravel() * sz]))
    for st in range(1, nz):
        for d in "xyz":
            s.parameter(f"E{d}_{st}", E, bounds=(0.5 * E, 2.0 * E))
            s.parameter(f"rho{d}_{st}", rho, bounds=(0.5 * rho, 2.0 * rho))
    G = E / (2.0 * (1.0 + nu))
    levels = np.arange(1, nz)
    families = [("x", ids[1:, :, :-1], ids[1:, :, 1:], (0.0, 0.0, 1.0)),
                ("y", ids[1:, :-1, :], ids[1:, 1:, :], (0.0, 0.0, 1.0)),
                ("z", ids[:-1], ids[1:], (1.0, 0.0, 0.0))]
    for d, a, b, orient in families:
        if a.size == 0:
            continue
        storey = np.broadcast_to(levels[:, None, None], a.shape).ravel()
        s.frame3d(np.column_stack([a.ravel(), b.ravel()]), E=[f"E{d}_{q}" for q in storey], G=G, A=sec["A"],
                  Iy=sec["Iy"], Iz=sec["Iz"], J=sec["J"], rho=[f"rho{d}_{q}" for q in storey], orientation=orient,
                  where=f"tower {d}-members")
    s.support_node(ids[0].ravel().tolist())
    return s


def sensor_labels(nx: int, ny: int, nz: int, n_sensors: int = N_SENSORS) -> list[str]:
    """x and y at corner (0, 0) and y at corner (nx-1, ny-1) on n_sensors / 3 levels."""
    n_levels = n_sensors // 3
    levels = np.unique(np.linspace(1, nz - 1, n_levels).round().astype(int))
    out = []
    for k in levels:
        a = 1 + nx * ny * k
        b = a + nx * ny - 1
        out += [f"{a}:x", f"{a}:y", f"{b}:y"]
    return out[:n_sensors]


def _rel(a, b) -> float:
    """Largest error relative to the largest reference entry, per parameter (last axis)."""
    L = b.shape[-1]
    num = np.abs(a - b).reshape(-1, L).max(axis=0)
    den = np.abs(b).reshape(-1, L).max(axis=0)
    return float(np.max(num / np.where(den > 0, den, 1.0)))


# ------------------------------------------------------------------ the benchmark
def run(size) -> dict:
    phases: dict = {}

    def record(name, ph, **extra):
        phases[name] = {"seconds": ph.seconds, "rss_peak_mb": ph.rss_peak, "rss_delta_mb": ph.rss_delta, **extra}

    with Phase() as ph:
        model = tower(*size).build()
    record("build", ph)
    K, M = model.K(), model.M()  # also builds Model._pattern (cached, shared by every phase)
    n, L = model.n_dofs, len(model.parameters)
    sensors = sensor_labels(*size)
    m = buffered_modes(N_MODES, n)
    which = list(range(N_MODES))

    # (b) one bare SciPy shift-invert eigensolution
    Kc, Mc = sp.csc_array(K), sp.csc_array(M)
    with Phase() as ph:
        lam_b, _phi = spla.eigsh(Kc, k=N_MODES, M=Mc, sigma=0, which="LM")
    del _phi
    record("b_eigsh_baseline", ph)
    del Kc, Mc

    # (f) femupdate: modes with a buffer + the adjoint Jacobian for all parameters
    with Phase() as ph:
        modes = model_modes(model, n_modes=m)
    record("f1_model_modes", ph, n_modes=m)
    # "ref" scaling, each mode to 1 at its largest measured component (a fixed choice: a
    # reference near the base, where the tower hardly moves, would only amplify round-off)
    ref = np.argmax(np.abs(modes.shapes[np.ix_(model.dof_index(sensors), which)]), axis=0).tolist()
    with Phase() as ph:
        res = jacobian(model, modes, which, sensors, method="adjoint", shape_scaling="ref", ref=ref)
    record("f2_jacobian_adjoint", ph, n_terms=res.n_terms)
    f_seconds = phases["f1_model_modes"]["seconds"] + phases["f2_jacobian_adjoint"]["seconds"]

    # (a) finite differences: N_FD perturbed eigensolutions, extrapolated to L parameters
    p0 = model.values
    j_fd = int(np.argmax([nm.startswith("Ex_") for nm in model.parameter_names]))  # the first E_x
    j_fd2 = L // 2
    perturbations = [(j_fd, +1.0), (j_fd, -1.0), (j_fd2, +1.0)][:N_FD]
    solutions, times = [], []
    for j, sgn in perturbations:
        p = p0.copy()
        p[j] += sgn * FD_STEP * abs(p0[j])
        with Phase() as ph:
            pert = model_modes(model, p, n_modes=N_MODES)
        times.append(ph.seconds)
        solutions.append(pert)
    a_seconds = float(np.mean(times)) * L
    phases["a_fd_perturbed_solutions"] = {"seconds_each": times, "n_run": len(times),
                                          "extrapolated_seconds": a_seconds, "n_parameters": L}

    # ---- checks (not timed against the targets)
    base = modes.shapes[:, :N_MODES]
    s = model.dof_index(sensors)
    lam = modes.eigenvalues[:N_MODES]
    check_params = sorted({j_fd, j_fd2, L - 1})[:N_CHECK]
    with Phase() as ph:
        lu, sigma = prepare_factor(K, M, modes)
    record("check_factor", ph)
    with Phase() as ph:
        dl_f, dphi_f, terms_f = subspace_details(model, modes, which, check_params, lu=lu, sigma=sigma)
    record("check_subspace_forward", ph, n_params=len(check_params), n_terms=[int(t) for t in terms_f])
    with Phase() as ph:
        adj = jacobian(model, modes, which, sensors, params=check_params, method="adjoint", shape_scaling="mass",
                       relative_eigenvalues=False, lu=lu, sigma=sigma)
    record("check_adjoint_same_params", ph)
    del lu
    err_lam = _rel(adj.dlam, dl_f)
    err_phi = _rel(adj.dpsi, dphi_f[s])
    # the full-size result (ref-scaled, relative) against the same forward numbers, rescaled
    fwd = _scaled_from_forward(res, dl_f, dphi_f[s], check_params, lam, modes.shapes[np.ix_(s, which)])
    err_full_lam = _rel(res.dlam[:, check_params], fwd[0])
    err_full_psi = _rel(res.dpsi[:, :, check_params], fwd[1])

    # central differences on parameter j_fd from the two timed perturbed solutions
    h = FD_STEP * abs(p0[j_fd])
    sides = []
    for pert in solutions[:2]:
        pairs = {t: q for t, q, _ in pair(mac(base, pert.shapes), rule="mac", min_mac=0.0).pairs}
        lam_p = np.array([pert.eigenvalues[pairs[r]] for r in range(N_MODES)])
        shp = np.column_stack([pert.shapes[:, pairs[r]] for r in range(N_MODES)])
        shp *= np.sign(np.sum(shp * base, axis=0))
        sides.append((lam_p, shp[s]))
    fd_lam = (sides[0][0] - sides[1][0]) / (2 * h)
    fd_phi = (sides[0][1] - sides[1][1]) / (2 * h)
    col = check_params.index(j_fd)
    err_fd_lam = _rel(adj.dlam[:, [col]], fd_lam[:, None])
    err_fd_phi = _rel(adj.dpsi[:, :, [col]], fd_phi[:, :, None])

    rel_b = float(np.max(np.abs(np.sort(lam_b) - lam) / lam))
    b_seconds = phases["b_eigsh_baseline"]["seconds"]
    return {
        "phases": phases,
        "model": {
            "generator": f"tower{tuple(size)} (frame_lattice geometry, spacing {SPACING})", "n_dofs": n,
            "n_parameters": L, "n_sensors": len(sensors), "n_modes_differentiated": N_MODES, "n_modes_computed": m,
            "nnz_K": int(K.nnz), "nnz_M": int(M.nnz), "frequencies_hz": modes.frequencies_hz[:N_MODES].tolist(),
            "buffer_ratio": float(lam[-1] / modes.eigenvalues[-1]),
        },
        "times": {"b_baseline_s": b_seconds, "f_femupdate_s": f_seconds, "a_fd_extrapolated_s": a_seconds},
        "ratio": {"f_over_b": f_seconds / b_seconds, "a_over_f": a_seconds / f_seconds,
                  "targets": {"f_over_b_max": 3.0, "a_over_f_min": 100.0}},
        "checks": {
            "eigenvalues_vs_baseline": {"max_rel_diff": rel_b, "ok": bool(rel_b < 1e-8)},
            "adjoint_vs_subspace": {
                "params": [model.parameter_names[j] for j in check_params], "dlam_rel": err_lam, "dphi_s_rel": err_phi,
                "jacobian_dlam_rel": err_full_lam, "jacobian_dpsi_rel": err_full_psi, "tolerance": CHECK_TOL,
                "ok": bool(max(err_lam, err_phi, err_full_lam, err_full_psi) < CHECK_TOL),
            },
            "adjoint_vs_fd": {
                "param": model.parameter_names[j_fd], "rel_step": FD_STEP, "dlam_rel": err_fd_lam,
                "dphi_s_rel": err_fd_phi, "tolerance": FD_TOL, "ok": bool(max(err_fd_lam, err_fd_phi) < FD_TOL),
            },
        },
    }


def _scaled_from_forward(res, dl, dphi_s, params, lam, phi_s):
    """Relative dlam and ref-scaled shape derivatives from mass-normalised forward results."""
    dlam = dl / lam[:, None]
    dpsi = np.zeros((phi_s.shape[0], phi_s.shape[1], len(params)))
    for r in range(phi_s.shape[1]):
        k = res.ref[r] if res.ref is not None else None
        dpsi[:, r, :] = scaled_shape(phi_s[:, r], dphi_s[:, r, :], res.shape_scaling, k)[1]
    return dlam, dpsi


def table(res: dict) -> str:
    m, ph = res["model"], res["phases"]
    out = [f"model: {m['generator']}: {m['n_dofs']} dofs, {m['n_parameters']} parameters (E and rho), "
           f"{m['n_sensors']} sensors, {m['n_modes_differentiated']} of {m['n_modes_computed']} computed modes "
           f"differentiated (lambda_10 / lambda_{m['n_modes_computed']} = {m['buffer_ratio']:.3f})", ""]
    out.append(f"{'phase':52s} {'time s':>9s} {'RSS peak MB':>12s} {'RSS +MB':>9s}")
    rows = [("build", "Structure.build()"), ("b_eigsh_baseline", "(b) eigsh(K, 10, M, sigma=0)"),
            ("f1_model_modes", f"(f1) model_modes(n_modes={m['n_modes_computed']})"),
            ("f2_jacobian_adjoint", f"(f2) jacobian(adjoint): {ph['f2_jacobian_adjoint']['n_terms']} series terms"),
            ("check_factor", "check: factorisation K - sigma M"),
            ("check_subspace_forward", "check: forward subspace, 3 parameters"),
            ("check_adjoint_same_params", "check: adjoint, 3 parameters (given factor)")]
    for key, label in rows:
        p = ph[key]
        out.append(f"{label:52s} {p['seconds']:9.2f} {p['rss_peak_mb']:12.1f} {p['rss_delta_mb']:9.1f}")
    a = ph["a_fd_perturbed_solutions"]
    out.append(f"{'(a) FD: one eigensolution per parameter':52s} {a['extrapolated_seconds']:9.1f}   "
               f"(EXTRAPOLATED: mean of {a['n_run']} timed perturbed solutions, "
               f"{np.mean(a['seconds_each']):.2f} s, x {a['n_parameters']} parameters)")
    t, r = res["times"], res["ratio"]
    out += ["", f"(f) femupdate total {t['f_femupdate_s']:.2f} s;  (b) baseline {t['b_baseline_s']:.2f} s;  "
            f"(a) FD {t['a_fd_extrapolated_s']:.0f} s (extrapolated)",
            f"ratio f/b = {r['f_over_b']:.2f} (target <= 3: {'met' if r['f_over_b'] <= 3 else 'NOT met'});  "
            f"a/f = {r['a_over_f']:.0f} (target >= 100: {'met' if r['a_over_f'] >= 100 else 'NOT met'})"]
    if m["n_dofs"] < 100_000:
        out.append("note: the targets are for the full-size model (>= 100,000 dofs); on a small one the fixed "
                   "costs dominate and the ratios mean little")
    c = res["checks"]
    e = c["adjoint_vs_subspace"]
    out.append(f"adjoint vs forward subspace on {', '.join(e['params'])}: dlam {e['dlam_rel']:.1e}, dphi_s "
               f"{e['dphi_s_rel']:.1e}, scaled Jacobian {max(e['jacobian_dlam_rel'], e['jacobian_dpsi_rel']):.1e} "
               f"({'OK' if e['ok'] else 'FAIL'}, tolerance {e['tolerance']:g})")
    e = c["adjoint_vs_fd"]
    out.append(f"adjoint vs central differences on {e['param']} (step {e['rel_step']:g}): dlam {e['dlam_rel']:.1e}, "
               f"dphi_s {e['dphi_s_rel']:.1e} ({'OK' if e['ok'] else 'FAIL'}, tolerance {e['tolerance']:g})")
    e = c["eigenvalues_vs_baseline"]
    out.append(f"eigenvalues model_modes vs eigsh: max relative difference {e['max_rel_diff']:.1e} "
               f"({'OK' if e['ok'] else 'FAIL'})")
    return "\n".join(out)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help=f"small tower {QUICK_SIZE} for smoke tests")
    ap.add_argument("--size", type=int, nargs=3, metavar=("NX", "NY", "NZ"), help="tower size (nodes)")
    ap.add_argument("--output", type=Path, help="JSON file (default benchmarks/results/bench_jacobian[_quick].json)")
    args = ap.parse_args(argv)
    size = tuple(args.size) if args.size else (QUICK_SIZE if args.quick else FULL_SIZE)
    res = run(size)
    write_results(res, "bench_jacobian", args.quick, args.output, table, argv)
    c = res["checks"]
    return 0 if all(c[k]["ok"] for k in c) else 1


if __name__ == "__main__":
    sys.exit(main())
