"""MKL PARDISO as a factorisation backend (femupdate.workspace.pardiso): its answers against
SuperLU's and dense solves, non-positive-definite matrices refused as by CHOLMOD, its analysis
reused, factors that stay valid, threads, and the installation the environment marker promises."""

from __future__ import annotations

import platform
import sys
import threading

import numpy as np
import pytest
import scipy.sparse as sp

from femupdate import model_modes, settings, workspace
from femupdate.generators import frame_lattice
from femupdate.workspace import SparseWorkspace
from test_workspace import random_pencil

needs_mkl = pytest.mark.skipif(not workspace.pardiso_installed(), reason="the PARDISO backend needs MKL (the mkl package)")


def test_mkl_is_installed_where_the_dependency_marker_brings_it():
    """``pip install femupdate`` brings the mkl package on x86_64 Linux (pyproject's environment
    marker): there the fast factorisation must be found, so that CI runs its path."""
    if not (sys.platform.startswith("linux") and platform.machine().lower() in ("x86_64", "amd64")):
        pytest.skip("the mkl dependency is only declared for x86_64 Linux")
    assert workspace.pardiso_installed()
    with settings.using(factorisation="auto"):
        assert workspace.backend() in ("cholmod", "pardiso")  # CHOLMOD first where scikit-sparse is there


def pencil(n=80, seed=0):
    """A random sparse SPD K (diagonally dominant) and SPD M with a pattern of its own."""
    return random_pencil(n, seed)


@needs_mkl
def test_a_pardiso_factor_solves_as_a_dense_solve_and_refuses_what_is_not_definite():
    K, M = pencil()
    B = np.random.default_rng(1).standard_normal((K.shape[0], 4))
    f = workspace.factorize(K, definite=True, backend="pardiso")
    assert isinstance(f, workspace.PardisoFactor) and f.name == "PARDISO Cholesky" == workspace.factor_name(f)
    X = np.linalg.solve(K.toarray(), B)
    np.testing.assert_allclose(f.solve(B), X, rtol=0, atol=1e-12 * np.max(np.abs(X)))
    np.testing.assert_allclose(f.solve(B[:, 1]), X[:, 1], rtol=0, atol=1e-12 * np.max(np.abs(X)))
    np.testing.assert_allclose(f.solve(B[:, 0] * (1 - 2j)), X[:, 0] * (1 - 2j), rtol=0, atol=1e-11 * np.max(np.abs(X)))
    assert not f.nearly_singular() and f.nnz >= K.shape[0]
    # the pivots it judges are those of LDLᵀ: a diagonal matrix's own entries
    d = workspace.factorize(sp.csc_array(np.diag([1.0, 1e-12, 3.0])), definite=True, backend="pardiso")
    assert d.nearly_singular()
    # indefinite: refused with definite=True, SuperLU's LU otherwise (as with CHOLMOD)
    Z = sp.csc_array((K - 40.0 * M).toarray())
    with pytest.raises(workspace.NotPositiveDefinite):
        workspace.factorize(Z, definite=True, backend="pardiso")
    lu = workspace.factorize(Z, backend="pardiso")
    assert lu.name == "SuperLU"
    np.testing.assert_allclose(lu.solve(B), np.linalg.solve(Z.toarray(), B), rtol=1e-10, atol=0)
    # singular (a free bar): refused, then SuperLU finds it exactly singular
    S = sp.csc_array(np.array([[1.0, -1.0], [-1.0, 1.0]]))
    with pytest.raises(workspace.NotPositiveDefinite):
        workspace.factorize(S, definite=True, backend="pardiso")
    with pytest.raises(RuntimeError):
        workspace.factorize(S, backend="pardiso")


@needs_mkl
def test_the_route_reuses_its_analysis_and_every_factor_stays_valid():
    """The workspace analyses once (one handle per thread); a factor made before a later
    factorisation through the same handle still solves its own matrix."""
    K, M = pencil(n=120, seed=2)
    ws = SparseWorkspace(K, M, prefer="sparse", backend="pardiso")
    B = np.random.default_rng(3).standard_normal(K.shape[0])
    f0 = ws.factor(K, M, 0.0)
    assert ws.route == "pardiso"
    route = ws._route
    handle = route._handle()
    factors = [(0.0, f0)]
    for scale, sigma in ((1.5, 0.2), (0.7, -1.0)):
        K2 = K.copy()
        K2.data = K.data * scale  # new values, the same pattern
        f = ws.factor(K2, M, sigma)
        assert f.handle is handle  # the analysis kept
        factors.append(((K2, sigma), f))
    for key, f in reversed(factors):  # the older ones factorise their own values again
        A = K if key == 0.0 else key[0] - key[1] * M
        np.testing.assert_allclose(f.solve(B), np.linalg.solve(A.toarray(), B), rtol=1e-11)
    np.testing.assert_allclose(f0.solve(B), np.linalg.solve(K.toarray(), B), rtol=1e-11)
    # another thread: a handle (an analysis) of its own, the same answers
    out = {}

    def other():
        g = ws.factor(K, M, 0.3)
        out["handle"], out["x"] = g.handle, g.solve(B)

    t = threading.Thread(target=other)
    t.start()
    t.join()
    assert out["handle"] is not handle
    np.testing.assert_allclose(out["x"], np.linalg.solve((K - 0.3 * M).toarray(), B), rtol=1e-11)
    with pytest.raises(workspace.NotPositiveDefinite):  # a shift above the lowest eigenvalue
        ws.factor(K, M, 1e6)


@needs_mkl
@pytest.mark.parametrize("prefer", [None, "sparse"])
def test_modes_by_pardiso_equal_those_by_superlu(prefer):
    """A clamped frame block (the sparse route wins over the band on it) and a free frame (six
    rigid-body modes: Cholesky refused at shift 0, the shift goes below zero): the modes through
    PARDISO equal SuperLU's to 1e-10 in eigenvalue and 1e-7 in shape."""
    for model in (frame_lattice(6, 6, 6, parameters="direction").build(),
                  frame_lattice(2, 2, 40, parameters="direction", support="none").build()):
        p = model.values * np.linspace(0.7, 1.4, len(model.parameters))
        with settings.using(factorisation="superlu"):
            ref = model_modes(model, p, n_modes=12, reuse=False)
            ref1 = model_modes(model, p * 1.01, n_modes=12, reuse=False)
        with settings.using(factorisation="pardiso"):
            workspace._WORKSPACES[model] = SparseWorkspace(model.K(p), model.M(p), prefer=prefer)
            model_modes(model, p, n_modes=12)
            got = model_modes(model, p * 1.01, n_modes=12)  # a refactorisation at another point
            got0 = model_modes(model, p, n_modes=12)
        assert workspace._WORKSPACES[model].route == ("pardiso" if prefer else workspace._WORKSPACES[model].route)
        assert "PARDISO" in got.solver or "band" in got.solver
        nr = ref.n_rigid
        assert got0.n_rigid == nr
        np.testing.assert_allclose(got0.eigenvalues[nr:], ref.eigenvalues[nr:], rtol=1e-10)
        np.testing.assert_allclose(got.eigenvalues[nr:], ref1.eigenvalues[nr:], rtol=1e-10)
        if nr == 0:
            scale = np.max(np.abs(ref.shapes), axis=0)
            signs = np.sign(np.sum(ref.shapes * got0.shapes, axis=0))
            assert np.max(np.abs(ref.shapes - got0.shapes * signs) / scale) < 1e-7


@needs_mkl
def test_pardiso_runs_on_the_threads_of_the_blas_phase():
    """MKL is one of the BLAS libraries the thread policy limits: inside a phase it gets the
    phase's threads."""
    from threadpoolctl import threadpool_info

    from femupdate._threads import blas_phase

    K, _ = pencil()
    workspace.factorize(K, definite=True, backend="pardiso")  # MKL loaded
    with settings.using(blas_threads=1), blas_phase("solve"):
        mkl = [d for d in threadpool_info() if d["internal_api"] == "mkl"]
        assert mkl and all(d["num_threads"] == 1 for d in mkl)


def test_pardiso_without_mkl_is_refused_by_name(monkeypatch):
    from femupdate import InputError
    from femupdate.workspace import pardiso

    monkeypatch.setattr(pardiso, "_LIB", False)
    with pytest.raises(InputError, match="'pardiso' needs MKL"):
        workspace.backend("pardiso")
    with settings.using(factorisation="auto"):
        assert workspace.backend() in ("cholmod", "superlu")


@needs_mkl
def test_pardiso_calls_take_the_threads_of_the_phase_even_where_its_limit_missed_mkl(monkeypatch):
    """MKL loaded inside a phase is not reached by the phase's limit (threadpoolctl saw the
    libraries at its start): each PARDISO call sets the phase's threads for itself (MKL's
    thread-local setting) and restores MKL's own afterwards."""
    import ctypes

    from femupdate._threads import blas_phase, phase_threads
    from femupdate.workspace import pardiso

    lib = pardiso.load()
    lib.MKL_Get_Max_Threads.restype = ctypes.c_int
    K, _ = pencil()
    f = workspace.factorize(K, definite=True, backend="pardiso")
    seen = []
    real = f.handle._pardiso

    def spy(*args):
        seen.append(lib.MKL_Get_Max_Threads())
        return real(*args)

    monkeypatch.setattr(f.handle, "_pardiso", spy)
    assert phase_threads() is None
    b = np.ones(K.shape[0])
    with settings.using(blas_threads=1), blas_phase("solve"):
        assert phase_threads() == 1
        lib.MKL_Set_Num_Threads_Local(2)  # as if MKL had been loaded after the phase began (threadpoolctl's setting)
        x = f.solve(b)
        assert lib.MKL_Get_Max_Threads() == 2  # MKL's own setting is back after the call
    assert seen == [1]
    np.testing.assert_allclose(K @ x, b, rtol=0, atol=1e-12)


@needs_mkl
def test_the_candidates_benchmark_runs_quick(tmp_path):
    """benchmarks/bench_factor.py --candidates on its smallest solid: SuperLU, the band and PARDISO
    measured in child processes, their eigenvalues equal to 1e-8."""
    import json
    import subprocess
    from pathlib import Path

    out = tmp_path / "cand.json"
    script = Path(__file__).resolve().parents[1] / "benchmarks" / "bench_factor.py"
    proc = subprocess.run([sys.executable, str(script), "--candidates", "--quick", "--mesh", "solid-2k", "--candidate",
                           "superlu", "--candidate", "band", "--candidate", "pardiso", "--output", str(out)],
                          capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-2000:]
    rows = json.loads(out.read_text())["rows"]
    assert [r["candidate"] for r in rows] == ["superlu", "band", "pardiso"]
    assert [r["route"] for r in rows] == ["superlu", "band", "pardiso"]
    assert all(r["max_rel_eigenvalue_difference"] < 1e-8 and r["residual"] < 1e-10 for r in rows)
