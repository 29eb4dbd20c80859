"""Benchmark: assembling a large hexahedral mesh, femupdate against scikit-fem, and reading its decks.

Usage::

    python benchmarks/bench_assembly.py                 # n = 20, 40, 69 elements per side (1,029,000 dofs)
    python benchmarks/bench_assembly.py --n 10 20        # any sizes
    python benchmarks/bench_assembly.py --quick          # n = 8 (2,187 dofs), a smoke run

The mesh is the unit cube cut into n x n x n 8-node hexahedra, ``skfem.MeshHex.init_tensor``'s
nodes for both codes (3 (n + 1)^3 dofs, all free).  Each case runs in a fresh subprocess (one
size, one code) so that its resident-set peak is its own:

* ``skfem``: scikit-fem's ``Basis(mesh, ElementVector(ElementHex1()), intorder=3)`` (the
  2 x 2 x 2 Gauss rule femupdate's hex8 uses) and ``asm`` of its ``linear_elasticity`` form (K)
  and of the vector mass form (M) — the basis is part of the time;
* ``skfem-default``: the same with scikit-fem's default rule for the element (4 x 4 x 4 points),
  up to ``--default-rule-max`` elements per side (20);
* ``femupdate``: ``Structure.add_nodes`` + ``Structure.solid`` (E a parameter, nu = 0.3, rho
  numeric) + ``Structure.build()``: the parameter matrix K_E (K = E K_E) and M of femupdate's
  QM6 hexahedron (incompatible modes condensed, :func:`femupdate.elements_3d.hex8_terms`);
* ``nastran`` / ``abaqus``: a small-field Nastran bulk-data deck (GRID, CHEXA with a continuation,
  PSOLID, MAT1) and an Abaqus deck (``*NODE``, ``*ELEMENT, TYPE=C3D8``, section, material) of the
  same mesh, written before the timing, read by :func:`femupdate.mesh.read_mesh`.

Reported per case: wall seconds, the resident-set peak of the phase above the resident set at
its start (``/proc/self/status`` VmHWM after a reset; ``ru_maxrss`` where that is not possible)
and the bytes of the final sparse matrices (data, indices, indptr of K_E and M), then the ratios
femupdate / scikit-fem of times and peak / matrix bytes.  At the smallest size the run also
checks that femupdate's mass matrix equals scikit-fem's (same element, same rule) to 1e-12.
Results go to ``benchmarks/results/bench_assembly[_quick].json``.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
if (HERE.parent / "src" / "femupdate").is_dir():
    sys.path.insert(0, str(HERE.parent / "src"))

from _probes import MB, _reset_hwm, _status_kb, _maxrss_mb, environment, write_results  # noqa: E402

CODES = ("skfem", "skfem-default", "femupdate", "nastran", "abaqus")


def grid(n: int):
    """Nodes ``(N, 3)`` (scikit-fem's order) and hexahedra ``(n^3, 8)`` in femupdate's node order (0-based)."""
    import numpy as np
    from skfem import MeshHex

    x = np.linspace(0.0, 1.0, n + 1)
    m = MeshHex.init_tensor(x, x, x)
    p, t = m.p.T.copy(), m.t.T
    corner = np.sign(p[t[0]] - p[t[0]].mean(axis=0)).astype(int)  # element 0's nodes as (+-1, +-1, +-1)
    order = [((-1, -1, -1), (1, -1, -1), (1, 1, -1), (-1, 1, -1),
              (-1, -1, 1), (1, -1, 1), (1, 1, 1), (-1, 1, 1))[k] for k in range(8)]
    perm = [next(i for i in range(8) if tuple(corner[i]) == c) for c in order]
    return m, p, np.ascontiguousarray(t[:, perm])


def matrix_bytes(*mats) -> int:
    return int(sum(a.data.nbytes + a.indices.nbytes + a.indptr.nbytes for a in mats if a is not None and a.nnz))


class Probe:
    def __enter__(self):
        import gc

        gc.collect()
        self.reset = _reset_hwm()
        self.rss0 = (_status_kb("VmRSS") or 0) / 1024.0
        self.t0 = time.perf_counter()
        self.c0 = time.process_time()
        return self

    def __exit__(self, *exc):
        self.seconds = time.perf_counter() - self.t0
        self.cpu = time.process_time() - self.c0
        hwm = _status_kb("VmHWM")
        self.peak = (hwm / 1024.0 if hwm is not None and self.reset else _maxrss_mb()) - self.rss0
        return False


def run_skfem(n: int, default_rule: bool) -> dict:
    from skfem import Basis, BilinearForm, ElementHex1, ElementVector, asm
    from skfem.helpers import dot
    from skfem.models.elasticity import lame_parameters, linear_elasticity

    m, _, _ = grid(n)

    @BilinearForm
    def mass(u, v, w):
        return dot(u, v)

    with Probe() as ph:
        e = ElementVector(ElementHex1())
        basis = Basis(m, e) if default_rule else Basis(m, e, intorder=3)
        K = asm(linear_elasticity(*lame_parameters(1.0, 0.3)), basis).tocsr()
        M = asm(mass, basis).tocsr()
    out = {"seconds": ph.seconds, "cpu_seconds": ph.cpu, "peak_mb": ph.peak, "matrix_mb": matrix_bytes(K, M) / MB,
           "quadrature_points": int(basis.X.shape[1]), "dofs": int(K.shape[0])}
    if n <= 10:
        out["M_sum"] = float(M.sum())
    return out


def run_femupdate(n: int) -> dict:
    import numpy as np

    from femupdate.structure import Structure

    _, p, t = grid(n)
    ids = np.arange(1, len(p) + 1)
    with Probe() as ph:
        s = Structure("cube")
        s.parameter("E", 1.0)
        s.add_nodes(ids, p)
        s.solid(t + 1, E="E", nu=0.3, rho=1.0)
        t1 = time.perf_counter()
        model = s.build()
        t_build = time.perf_counter() - t1
    mats = [model.K0, model.M0, *model.dK, *model.dM]
    return {"seconds": ph.seconds, "cpu_seconds": ph.cpu, "build_seconds": t_build, "peak_mb": ph.peak,
            "matrix_mb": matrix_bytes(*mats) / MB, "dofs": len(model.dofs), "nnz_K": int(model.dK[0].nnz)}


def write_decks(n: int, folder: Path) -> tuple[Path, Path]:
    """A small-field Nastran deck and an Abaqus deck of the mesh (ids from 1)."""
    import numpy as np

    _, p, t = grid(n)
    ids = np.arange(1, len(p) + 1)
    conn = t + 1
    eids = np.arange(1, len(t) + 1)
    nas = folder / f"cube{n}.bdf"
    with open(nas, "w") as f:
        f.write("SOL 103\nCEND\nBEGIN BULK\nMAT1    1       2.1+11          0.3     7850.\nPSOLID  1       1\n")
        f.writelines(f"GRID    {i:<8d}        {x:<8.6f}{y:<8.6f}{z:<8.6f}\n" for i, (x, y, z) in zip(ids.tolist(), p.tolist()))
        f.writelines(f"CHEXA   {e:<8d}1       {c[0]:<8d}{c[1]:<8d}{c[2]:<8d}{c[3]:<8d}{c[4]:<8d}{c[5]:<8d}+\n"
                     f"+       {c[6]:<8d}{c[7]:<8d}\n" for e, c in zip(eids.tolist(), conn.tolist()))
        f.write("ENDDATA\n")
    aba = folder / f"cube{n}.inp"
    with open(aba, "w") as f:
        f.write("*HEADING\ncube\n*NODE\n")
        f.writelines(f"{i}, {x!r}, {y!r}, {z!r}\n" for i, (x, y, z) in zip(ids.tolist(), p.tolist()))
        f.write("*ELEMENT, TYPE=C3D8, ELSET=CUBE\n")
        f.writelines(f"{e}, " + ", ".join(map(str, c)) + "\n" for e, c in zip(eids.tolist(), conn.tolist()))
        f.write("*SOLID SECTION, ELSET=CUBE, MATERIAL=STEEL\n*MATERIAL, NAME=STEEL\n*ELASTIC\n2.1e11, 0.3\n"
                "*DENSITY\n7850.\n")
    return nas, aba


def run_deck(n: int, kind: str, folder: Path) -> dict:
    from femupdate.mesh import read_mesh

    path = folder / (f"cube{n}.bdf" if kind == "nastran" else f"cube{n}.inp")
    with Probe() as ph:
        mesh = read_mesh(path, kind)
    n_el = sum(len(b.ids) for b in mesh.blocks)
    return {"seconds": ph.seconds, "cpu_seconds": ph.cpu, "peak_mb": ph.peak, "dofs": 3 * len(mesh.node_ids), "elements": n_el,
            "file_mb": path.stat().st_size / MB}


def child(args) -> None:
    if args.case == "femupdate":
        out = run_femupdate(args.child_n)
    elif args.case in ("skfem", "skfem-default"):
        out = run_skfem(args.child_n, args.case == "skfem-default")
    else:
        out = run_deck(args.child_n, args.case, Path(args.folder))
    print("RESULT " + json.dumps(out))


def spawn(case: str, n: int, folder: Path, timeout: float) -> dict:
    cmd = [sys.executable, __file__, "--case", case, "--child-n", str(n), "--folder", str(folder)]
    try:
        p = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        return {"error": f"timed out after {timeout:.0f} s"}
    line = next((ln for ln in p.stdout.splitlines() if ln.startswith("RESULT ")), None)
    if line is None:
        return {"error": (p.stderr.strip().splitlines() or ["no output"])[-1], "returncode": p.returncode}
    return json.loads(line[7:])


def check_mass(n: int) -> float:
    """Largest difference of femupdate's and scikit-fem's consistent mass matrices, relative to the largest entry."""
    import numpy as np
    from skfem import Basis, BilinearForm, ElementHex1, ElementVector, asm
    from skfem.helpers import dot

    from femupdate.structure import Structure

    m, p, t = grid(n)

    @BilinearForm
    def mass(u, v, w):
        return dot(u, v)

    M_ref = asm(mass, Basis(m, ElementVector(ElementHex1()), intorder=3)).tocsr()
    s = Structure("cube")
    s.add_nodes(np.arange(1, len(p) + 1), p)
    s.solid(t + 1, E=1.0, nu=0.3, rho=1.0)
    M = s.build().M0
    return float(abs(M - M_ref).max() / abs(M_ref).max())


def table(res: dict) -> str:
    out = [f"{'n':>4} {'dofs':>10} {'case':14} {'seconds':>9} {'cpu s':>9} {'peak MB':>9} {'matrix MB':>10} {'peak/matrix':>11}"]
    for row in res["cases"]:
        r = row["result"]
        if "error" in r:
            out.append(f"{row['n']:>4} {'':>10} {row['case']:14} error: {r['error']}")
            continue
        mm = r.get("matrix_mb")
        ratio = f"{r['peak_mb'] / mm:11.2f}" if mm else f"{'':>11}"
        out.append(f"{row['n']:>4} {r['dofs']:>10,} {row['case']:14} {r['seconds']:9.2f} {r['cpu_seconds']:9.2f} {r['peak_mb']:9.0f} "
                   f"{(mm or 0):10.0f} {ratio}")
    for n, rat in res["ratios"].items():
        out.append(f"n = {n}: " + ", ".join(f"{k} {v:.2f}" for k, v in rat.items()))
    if "mass_check" in res:
        out.append(f"femupdate M vs scikit-fem M (n = {res['mass_check']['n']}): {res['mass_check']['rel_diff']:.1e}")
    return "\n".join(out)


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, nargs="+", default=[20, 40, 69], help="elements per side of the cube")
    ap.add_argument("--codes", nargs="+", default=list(CODES), choices=CODES)
    ap.add_argument("--default-rule-max", type=int, default=20,
                    help="run skfem-default (64 points per element, slow) only up to this n")
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--timeout", type=float, default=1800.0)
    ap.add_argument("--output", default=None)
    ap.add_argument("--case", help=argparse.SUPPRESS)
    ap.add_argument("--child-n", type=int, help=argparse.SUPPRESS)
    ap.add_argument("--folder", help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.case:
        return child(args)
    sizes = [8] if args.quick else args.n
    res: dict = {"cases": [], "ratios": {}}
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        for n in sizes:
            if "nastran" in args.codes or "abaqus" in args.codes:
                write_decks(n, folder)
            got = {}
            for case in args.codes:
                if case == "skfem-default" and n > args.default_rule_max:
                    continue
                r = spawn(case, n, folder, args.timeout)
                got[case] = r
                res["cases"].append({"n": n, "case": case, "result": r})
                print(f"n = {n:3d} {case:14s} {r}", flush=True)
            f, s = got.get("femupdate", {}), got.get("skfem", {})
            rat = {}
            if "seconds" in f and "seconds" in s:
                rat["time femupdate / skfem (2x2x2)"] = f["seconds"] / s["seconds"]
                rat["cpu time femupdate / skfem (2x2x2)"] = f["cpu_seconds"] / s["cpu_seconds"]
            if "seconds" in f and "seconds" in got.get("skfem-default", {}):
                rat["time femupdate / skfem (default rule)"] = f["seconds"] / got["skfem-default"]["seconds"]
            if "peak_mb" in f:
                rat["femupdate peak / matrices"] = f["peak_mb"] / f["matrix_mb"]
            if "peak_mb" in s:
                rat["skfem peak / matrices"] = s["peak_mb"] / s["matrix_mb"]
            res["ratios"][str(n)] = rat
            for gone in list(folder.glob(f"cube{n}.*")):
                gone.unlink()
    n0 = min(sizes)
    if n0 <= 20:
        res["mass_check"] = {"n": n0, "rel_diff": check_mass(n0)}
    res["environment"] = environment()
    name = "bench_assembly"
    write_results(res, name, args.quick, args.output, table, argv)


if __name__ == "__main__":
    main()
