"""The candidates of ``bench_factor.py --candidates``: sparse factorisations that install with pip
alone, against SuperLU and the band route, on solid and plate meshes.

Each (mesh, candidate) runs in a child process of its own (its peak memory is its own): the model
is built, then, under one BLAS thread (``--threads`` to change):

* ``first``    — the candidate's analysis and first factorisation of K(p0);
* ``refactor`` — a factorisation of K(p1) (another parameter point, the same pattern), the
  candidate's analysis reused where it can keep one (best of two);
* ``solve1``   — one right-hand side (median of 5); ``solve20`` — 20 at once (median of 3);
* ``eig``      — shift-invert Lanczos (ARPACK, ``eigsh`` with the refactored K(p1) as OPinv,
  σ = 0, femupdate's ARPACK options) for :data:`N_MODES` modes; ``end_to_end`` = refactor + eig;
* ``peak_mb``  — the process's resident high-water mark above what the built model held.

Every library's threads are limited to ``--threads`` (threadpoolctl, and femupdate's setting, which
PARDISO's calls apply for themselves).

Candidates: ``superlu`` and ``band`` (femupdate's workspace routes; the band's first factorisation,
which chooses the route, is PARDISO's where MKL is installed, else SuperLU's), ``pardiso`` (MKL PARDISO,
phases 11/22/33 through :mod:`femupdate.workspace.pardiso`), ``pardiso12`` (PARDISO as pypardiso's
``factorize`` calls it: analysis and factorisation together at every factorisation),
``pypardiso`` (pypardiso itself, whose ``solve`` checks and compares the matrix at every call),
``cvxopt`` (CHOLMOD 3 bundled in cvxopt's wheel: ``cholmod.symbolic`` once, ``cholmod.numeric``).
"""

from __future__ import annotations

import json
import statistics
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

HERE = Path(__file__).resolve().parent
N_MODES = 15
MESHES = {"solid-20k": ("solid", 18), "solid-86k": ("solid", 30), "plate-20k": ("plate", 57),
          "plate-86k": ("plate", 119), "plate-350k": ("plate", 240), "tower-51k": ("tower", 86),
          "tower-103k": ("tower", 172)}
QUICK_MESHES = {"solid-2k": ("solid", 7), "plate-2k": ("plate", 17)}
CANDIDATES = ("superlu", "band", "pardiso", "pardiso12", "pypardiso", "cvxopt")


def build(kind: str, n: int):
    """A clamped hexahedral block (n × n × n QM6, 1 m, clamped at z = 0) or a clamped square plate
    (n × n MITC4, 1 m × 1 m × 10 mm, clamped along y = 0), steel, two Young's moduli (x below and
    above 0.5) as the parameters."""
    from femupdate.structure import Structure

    if kind == "tower":  # the frame tower of the geometries above (10 x 10 nodes in plan, n levels)
        from femupdate.generators import frame_lattice

        return frame_lattice(10, 10, n, spacing=(4.0, 4.0, 4.0), parameters="storey").build()
    s = Structure(f"{kind}{n}")
    s.parameter("E1", 210e9)
    s.parameter("E2", 210e9)
    x = np.linspace(0.0, 1.0, n + 1)
    if kind == "solid":
        X, Y, Z = np.meshgrid(x, x, x, indexing="ij")
        ids = np.arange((n + 1) ** 3).reshape(n + 1, n + 1, n + 1) + 1
        s.add_nodes(ids.ravel(), np.column_stack([X.ravel(), Y.ravel(), Z.ravel()]))
        i, j, k = np.meshgrid(np.arange(n), np.arange(n), np.arange(n), indexing="ij")
        i, j, k = i.ravel(), j.ravel(), k.ravel()
        conn = np.column_stack([ids[i, j, k], ids[i + 1, j, k], ids[i + 1, j + 1, k], ids[i, j + 1, k],
                                ids[i, j, k + 1], ids[i + 1, j, k + 1], ids[i + 1, j + 1, k + 1], ids[i, j + 1, k + 1]])
        low = i < n // 2
        s.solid(conn[low], E="E1", nu=0.3, rho=7850.0)
        s.solid(conn[~low], E="E2", nu=0.3, rho=7850.0)
        clamped = ids[:, :, 0].ravel()
        s.support([f"{a}:{c}" for a in clamped for c in ("x", "y", "z")])
    else:
        X, Y = np.meshgrid(x, x, indexing="ij")
        ids = np.arange((n + 1) ** 2).reshape(n + 1, n + 1) + 1
        s.add_nodes(ids.ravel(), np.column_stack([X.ravel(), Y.ravel(), np.zeros(X.size)]))
        i, j = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
        i, j = i.ravel(), j.ravel()
        conn = np.column_stack([ids[i, j], ids[i + 1, j], ids[i + 1, j + 1], ids[i, j + 1]])
        low = i < n // 2
        s.shell(conn[low], E="E1", nu=0.3, t=0.01, rho=7850.0)
        s.shell(conn[~low], E="E2", nu=0.3, t=0.01, rho=7850.0)
        clamped = ids[:, 0].ravel()
        s.support([f"{a}:{c}" for a in clamped for c in ("x", "y", "z", "rx", "ry", "rz")])
    return s.build()


class Cvxopt:
    """CHOLMOD (cvxopt's bundled SuiteSparse): symbolic analysis once, numeric factorisations."""

    def __init__(self, A):
        from cvxopt import cholmod

        self.cholmod = cholmod
        self.symbolic = cholmod.symbolic(self._lower(A))
        self.factor(A)

    @staticmethod
    def _lower(A):
        from cvxopt import matrix, spmatrix

        L = sp.tril(sp.coo_array(A))
        return spmatrix(matrix(L.data.astype(float)), matrix(L.row.astype(np.int64)), matrix(L.col.astype(np.int64)),
                        A.shape)

    def factor(self, A):
        self.cholmod.numeric(self._lower(A), self.symbolic)
        return self

    def solve(self, B):
        from cvxopt import matrix

        X = matrix(np.asfortranarray(B, dtype=float))
        self.cholmod.solve(self.symbolic, X)
        return np.array(X).reshape(np.shape(B))


class PardisoOnce:
    """PARDISO called as pypardiso's ``factorize`` does: analysis and factorisation (phase 12)
    at every factorisation."""

    def __init__(self, A):
        self.factor(A)

    def factor(self, A):
        from femupdate.workspace.pardiso import PardisoHandle, upper_pattern

        indptr, indices, data = upper_pattern(A)
        self.h = PardisoHandle(indptr, indices)
        self.h.factor(data)
        return self

    def solve(self, B):
        return self.h.solve(B)


class PyPardiso:
    """pypardiso's own calls (``factorize``, ``solve``: the matrix checked, compared with the
    factorised one and re-indexed at every solve), type 2 on the upper triangle."""

    def __init__(self, A):
        import pypardiso

        self.solver = pypardiso.PyPardisoSolver(mtype=2)
        self.factor(A)

    def factor(self, A):
        self.A = sp.csr_matrix(sp.triu(A, format="csr"))
        self.solver.factorize(self.A)
        return self

    def solve(self, B):
        return self.solver.solve(self.A, np.asarray(B, dtype=float))


def _median(fn, repeat: int) -> float:
    ts = []
    for _ in range(repeat):
        t = time.perf_counter()
        fn()
        ts.append(time.perf_counter() - t)
    return statistics.median(ts)


def measure(mesh: str, candidate: str, threads: int) -> dict:
    """The figures of one candidate on one mesh (in this process)."""
    sys.path.insert(0, str(HERE))
    from _probes import _reset_hwm, _status_kb
    from threadpoolctl import threadpool_info, threadpool_limits

    import femupdate
    from femupdate.modal_sparse import arpack_options

    kind, n = {**MESHES, **QUICK_MESHES}[mesh]
    model = build(kind, n)
    p0 = model.values
    p1 = p0 * np.linspace(1.3, 0.8, p0.size)
    K0, K1, M = model.K(p0), model.K(p1), model.M(p0)
    row = {"mesh": mesh, "candidate": candidate, "n_dofs": int(K0.shape[0]), "nnz_K": int(K0.nnz), "threads": threads}
    from femupdate._threads import blas_phase
    from femupdate.workspace import pardiso

    if candidate.startswith(("pardiso", "pypardiso")) or (candidate == "band" and pardiso.available()):
        pardiso.load()  # MKL loaded before the limits, which then reach it
    _reset_hwm()
    base = (_status_kb("VmRSS") or 0) / 1024.0
    with threadpool_limits(threads), femupdate.settings.using(blas_threads=threads), blas_phase("solve"):
        t = time.perf_counter()
        if candidate in ("superlu", "band", "pardiso"):
            first_by = "superlu" if candidate == "superlu" or not femupdate.workspace.pardiso_installed() else "pardiso"
            ws = femupdate.workspace.SparseWorkspace(K0, M, prefer="band" if candidate == "band" else "sparse",
                                                     backend=first_by)
            if candidate == "band" and not _band_fits(ws, K0, M):
                return {**row, "skipped": "band storage beyond MAX_BAND_ENTRIES"}
            F = ws.factor(K0, M, 0.0)

            def refactor():
                return ws.factor(K1, M, 0.0)
        else:
            cls = {"cvxopt": Cvxopt, "pypardiso": PyPardiso}.get(candidate, PardisoOnce)
            F = cls(sp.csc_array(K0))

            def refactor():
                return F.factor(sp.csc_array(K1))
        row["first"] = time.perf_counter() - t
        times = []
        for _ in range(2):
            t = time.perf_counter()
            F1 = refactor()
            times.append(time.perf_counter() - t)
        row["refactor"], row["refactor_runs"] = min(times), times
        row["route"] = getattr(ws, "route", None) if candidate in ("superlu", "band", "pardiso") else candidate
        rng = np.random.default_rng(0)
        b1, b20 = rng.standard_normal(K1.shape[0]), rng.standard_normal((K1.shape[0], 20))
        row["solve1"] = _median(lambda: F1.solve(b1), 5)
        row["solve20"] = _median(lambda: F1.solve(b20), 3)
        row["residual"] = float(np.linalg.norm(K1 @ F1.solve(b1) - b1) / np.linalg.norm(b1))
        op = spla.LinearOperator(K1.shape, matvec=F1.solve, dtype=float)
        t = time.perf_counter()
        lam = spla.eigsh(K1, k=N_MODES, M=M, sigma=0.0, which="LM", OPinv=op, **arpack_options())[0]
        row["eig"] = time.perf_counter() - t
        row["end_to_end"] = row["refactor"] + row["eig"]
        row["eigenvalues"] = np.sort(lam).tolist()
        row["libraries"] = [(d["internal_api"], Path(d["filepath"]).name, d["num_threads"]) for d in threadpool_info()]
    hwm = _status_kb("VmHWM")
    row["peak_mb"] = (hwm or 0) / 1024.0 - base
    return row


def _band_fits(ws, K, M) -> bool:
    from femupdate.workspace import MAX_BAND_ENTRIES
    from femupdate.workspace.band import band_order

    _, b = band_order(sp.csc_array(ws.pattern.union()), ws.n)
    return (b + 1) * ws.n <= MAX_BAND_ENTRIES


def spawn(mesh: str, candidate: str, threads: int, timeout: float = 3600.0) -> dict:
    """:func:`measure` in a child process (``nice -n 5``)."""
    cmd = ["nice", "-n", "5", sys.executable, str(HERE / "bench_factor.py"), "--child", mesh, candidate, str(threads)]
    out = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout)
    if out.returncode:
        return {"mesh": mesh, "candidate": candidate, "threads": threads,
                "error": (out.stderr.strip().splitlines() or ["?"])[-1][:300]}
    return json.loads(out.stdout.strip().splitlines()[-1])
