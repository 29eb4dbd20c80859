"""The parametric reduced model (femupdate.rom): projection, a-posteriori bounds against full
eigen-solutions, greedy enrichment, the full-model check and the reduced update against the
full one (second route: the full model)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import scipy.sparse as sp

from conftest import heavy

import femupdate
from femupdate.coefficients import Power, Term
from femupdate.generators import frame_lattice
from femupdate.model import Parameter, from_matrices
from femupdate.modal import model_modes
from femupdate.rom.basis import full_modes, m_norms, orthonormalise
from femupdate.rom.estimate import residual_bounds, ritz_pairs
from femupdate.rom.greedy import build
from femupdate.rom.update import ROMOptions, basis_for, rom_multistart, rom_update
from femupdate.testdata import MeasuredMode, TestData

SRC = Path(__file__).resolve().parents[1] / "src"
TRUTH = np.array([0.8, 1.1, 0.9, 1.25])


def tower(nx: int, ny: int, nz: int, groups: int = 4):
    """A frame tower (lumped translational mass, massless rotations), ``groups`` storey-stiffness multipliers."""
    base = frame_lattice(nx, ny, nz, spacing=(4.0, 4.8, 3.0), mass="lumped", parameters="storey").build()
    L = len(base.parameters)
    edges = np.linspace(0, L, groups + 1).round().astype(int)
    dK = [sum(base.values[j] * base.dK[j] for j in range(edges[g], edges[g + 1])).tocsr() for g in range(groups)]
    params = [Parameter(f"g{g + 1}", 1.0, bounds=(0.5, 2.0)) for g in range(groups)]
    return from_matrices(base.dofs, base.K0, sp.diags_array(base.M().diagonal()).tocsr(), params, dK, None,
                         name=f"tower {nx}x{ny}x{nz - 1}")


def sensors(nx, ny, nz):
    top = nx * ny * (nz - 1)
    return [f"{n}:{d}" for n in (top + 1, top + nx * ny, top - nx * ny * (nz // 2) + 1) for d in "xy"]


def modal_data(model, dofs, truth=TRUTH, n=4):
    md = model_modes(model, truth, n + 1)
    idx = model.dof_index(dofs)
    return TestData(modes=tuple(MeasuredMode(float(lam), dofs, md.shapes[idx, i])
                                for i, lam in enumerate(md.eigenvalues[:n])))


@pytest.fixture(scope="module")
def small():
    m = tower(4, 4, 21)  # 1,920 dofs
    dofs = sensors(4, 4, 21)
    return m, dofs, modal_data(m, dofs)


def test_orthonormalise_deflates_dependent_vectors():
    rng = np.random.default_rng(1)
    n = 200
    M = sp.diags_array(rng.uniform(1, 3, n)).tocsr()
    A = rng.standard_normal((n, 5))
    W = np.hstack([A, A @ rng.standard_normal((5, 3)) + 1e-13 * rng.standard_normal((n, 3))])
    Q = orthonormalise(W, M)
    assert Q.shape[1] == 5  # the three combinations deflated
    np.testing.assert_allclose(Q.T @ (M @ Q), np.eye(5), atol=1e-12)
    Q2 = orthonormalise(np.hstack([A[:, :2], rng.standard_normal((n, 2))]), M, Q)
    assert Q2.shape[1] == 2  # A's columns already held
    np.testing.assert_allclose(Q.T @ (M @ Q2), 0, atol=1e-12)
    np.testing.assert_allclose(m_norms(Q2, M), 1, rtol=1e-12)


def test_projection_is_exact_with_nonlinear_terms():
    """K_r(p) = V̂ᵀ K(p) V̂ for every p, the model's terms f(p) K_k projected once; V̂ is the
    identity at the data's dofs."""
    rng = np.random.default_rng(2)
    n = 40
    main = np.full(n, 2.0)
    Kb = sp.diags_array([main, -np.ones(n - 1), -np.ones(n - 1)], offsets=[0, 1, -1]).tocsr()
    K1 = sp.diags_array(np.r_[np.ones(n // 2), np.zeros(n - n // 2)]).tocsr()
    M0 = sp.diags_array(rng.uniform(1, 2, n)).tocsr()
    dofs = [f"{i + 1}:x" for i in range(n)]
    params = [Parameter("E", 2.0, (0.5, 4.0)), Parameter("t", 1.0, (0.5, 2.0)), Parameter("k", 1.0, (0.1, 3.0))]
    model = femupdate.Model(dofs=dofs, K0=0 * Kb, M0=M0, parameters=params, dK=[None, None, K1], dM=[None, None, None],
                            terms=(Term(factors=(Power("E", 1), Power("t", 3)), K=Kb),
                                   Term(factors=(Power("t", 1),), M=0.5 * M0)))
    rb = build(model, ["3:x", "17:x"], 4, n_train=3, max_points=2)
    reduced, Vh = rb.reduced()
    np.testing.assert_array_equal(Vh[model.dof_index(["3:x", "17:x"])], np.eye(2, Vh.shape[1]))
    assert reduced.dofs[:2] == ("3:x", "17:x") and len(reduced.terms) == 2
    for _ in range(3):
        p = np.array([rng.uniform(0.5, 4), rng.uniform(0.5, 2), rng.uniform(0.1, 3)])
        Kf, Mf = (Vh.T @ (model.K(p) @ Vh)), (Vh.T @ (model.M(p) @ Vh))
        np.testing.assert_allclose(reduced.K(p).toarray(), Kf, rtol=0, atol=1e-12 * np.abs(Kf).max())
        np.testing.assert_allclose(reduced.M(p).toarray(), Mf, rtol=0, atol=1e-12 * np.abs(Mf).max())
        j = 1  # the chain rule through the projected terms: dK_r/dt = V̂ᵀ dK/dt V̂
        np.testing.assert_allclose(reduced.dK_dp(j, p).toarray(), Vh.T @ (model.dK_dp(j, p) @ Vh),
                                   atol=1e-12 * np.abs(Kf).max())


def test_bounds_hold_and_greedy_reduces_the_estimate(small):
    """At points away from the snapshots the a-posteriori bounds are at least the true frequency
    errors (full eigen-solutions), and every greedy step lowers the largest estimate."""
    m, dofs, _ = small
    rb = build(m, dofs, 4, n_train=8, max_points=3, tol=1e-12)
    largest = [h["largest_estimate"] for h in rb.history]
    assert len(largest) == 3 and all(b < a for a, b in zip(largest, largest[1:]))
    reduced, Vh = rb.reduced()
    rng = np.random.default_rng(5)
    seen = 0.0
    for _ in range(3):
        p = rng.uniform(0.5, 2.0, 4)
        lam, X = ritz_pairs(reduced, Vh, p, 5)
        lf, _, (K, M, lu, s) = full_modes(m, p, 5)
        b = residual_bounds(K, M, lam, X, lu, sigma=s, n_bounded=4)
        true = np.sqrt(lam[:4] / lf[:4]) - 1
        assert np.all(true >= -1e-12)  # Ritz values from above
        assert np.all(b["linear"] >= true) and np.all(b["quadratic"] >= true)
        seen = max(seen, true.max())
    assert seen > 1e-11  # the bounds were tested against errors well above round-off


def test_poor_basis_is_detected_and_enrichment_fixes_it(small):
    m, dofs, data = small
    full = femupdate.update(m, data)
    poor = build(m, dofs, 6, n_train=0, max_points=1, corrections=False)  # 7 modes at the nominal point only
    res = rom_update(m, data, basis=poor, rom=ROMOptions(max_rounds=8))
    checks = res.to_json()["reduced_basis"]["checks"]
    assert not checks[0]["passed"]
    assert max(c["frequency_error"] for c in checks[0]["modes"]) > 1e-6
    assert checks[-1]["passed"] and len(checks) >= 2
    assert all(c["frequency_error"] <= 1e-6 and c["one_minus_mac"] <= 1e-6 for c in checks[-1]["modes"])
    np.testing.assert_allclose(res.x, full.x, rtol=1e-6)


def test_a_start_out_of_rounds_reports_its_failed_check(small):
    m, dofs, data = small
    poor = build(m, dofs, 6, n_train=0, max_points=1, corrections=False)
    res = rom_update(m, data, basis=poor, rom=ROMOptions(max_rounds=1))
    rec = res.to_json()["reduced_basis"]
    assert len(rec["checks"]) == 1 and not rec["passed"]
    assert rec["checks"][0]["parameters"] == res.parameters  # the answer reported is the one checked
    assert any("did not pass its full-model check" in n for n in res.notes)


def _compare_with_full(m, data):
    full = femupdate.update(m, data)
    res = rom_update(m, data)
    rec = res.to_json()["reduced_basis"]
    assert rec["passed"] and rec["size"] < m.n_dofs / 5
    np.testing.assert_allclose(res.x, full.x, rtol=1e-6)
    f_full = model_modes(m, full.parameters, 4).frequencies_hz
    f_rom = model_modes(m, res.parameters, 4).frequencies_hz
    np.testing.assert_allclose(f_rom, f_full, rtol=1e-6)
    return rec


def test_reduced_update_equals_full_update(small):
    m, _, data = small
    rec = _compare_with_full(m, data)
    assert rec["checks"][-1]["modes"][0]["bound_quadratic"] < 1e-6


@heavy
def test_reduced_update_equals_full_update_12k_dofs():
    m = tower(6, 6, 60)  # 12,744 dofs
    dofs = sensors(6, 6, 60)
    _compare_with_full(m, modal_data(m, dofs))


def test_reduced_multistart_checks_every_start(small):
    m, _, data = small
    ms = rom_multistart(m, data, 2, seed=3, batched=False, rom=ROMOptions(n_train=4, max_points=2))
    rec = ms.to_json()["reduced_basis"]
    assert rec["passed"]
    converged = [i + 1 for i, r in enumerate(ms.runs) if not isinstance(r, str) and r.success]
    assert sorted({c["start"] for c in rec["checks"]}) == converged
    np.testing.assert_allclose(ms.best.x, TRUTH, rtol=1e-6)


def _chain_files(tmp_path: Path):
    n = 40
    lines = ['[model]\nname = "chain"\n']
    for g in range(4):
        lines.append(f'[parameters.k{g + 1}]\nvalue = 1000.0\nbounds = [300.0, 3000.0]\n')
    for i in range(n):
        g = i * 4 // n + 1
        dofs = f'["{i + 1}:x"]' if i == 0 else f'["{i}:x", "{i + 1}:x"]'
        lines.append(f'[[element]]\ntype = "spring"\ndofs = {dofs}\nk = "k{g}"\n')
        lines.append(f'[[element]]\ntype = "mass"\ndofs = ["{i + 1}:x"]\nm = {1.0 + 0.01 * i}\n')
    (tmp_path / "chain.toml").write_text("\n".join(lines))
    from femupdate.io.model_file import load_model

    m = load_model(tmp_path / "chain.toml")
    truth = np.array([800.0, 1100.0, 900.0, 1250.0])
    md = model_modes(m, truth, 5)
    dofs = ["10:x", "25:x", "40:x"]
    idx = m.dof_index(dofs)
    modes = [{"eigenvalue": float(md.eigenvalues[i]), "shape": dict(zip(dofs, map(float, md.shapes[idx, i])))}
             for i in range(4)]
    (tmp_path / "data.json").write_text(json.dumps({"modes": modes}))
    return truth


def _cli(args, cwd):
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(SRC), os.environ.get("PYTHONPATH", "")])}
    return subprocess.run([sys.executable, "-m", "femupdate", *args], cwd=cwd, env=env, capture_output=True,
                          text=True, timeout=300)


def test_cli_reduced_basis(tmp_path):
    truth = _chain_files(tmp_path)
    r = _cli(["update", "chain.toml", "data.json", "--reduced-basis", "--rom-points", "2", "--json", "out.json",
              "--report", "out.html"], tmp_path)
    assert r.returncode == 0, r.stderr
    out = json.loads((tmp_path / "out.json").read_text())
    from femupdate import schema

    schema.check(out, "update")  # the keys and types the schema states
    rec = out["reduced_basis"]
    assert rec["passed"] and rec["checks"] and rec["freq_tol"] == 1e-6
    assert all(set(c) >= {"parameters", "modes", "passed", "basis"} for c in rec["checks"])
    assert "full-model check" in "\n".join(out["notes"])
    html = (tmp_path / "out.html").read_text()
    assert "Reduced model and its full-model checks" in html and html.count(">passed<") >= 4
    np.testing.assert_allclose([out["parameters"][f"k{g + 1}"] for g in range(4)], truth, rtol=1e-6)
    bad = _cli(["update", "chain.toml", "data.json", "--rom", "--rom-freq-tol", "-1"], tmp_path)
    assert bad.returncode == 2 and "--rom-freq-tol" in bad.stderr and "Traceback" not in bad.stderr


def test_arguments_refused_by_name(small):
    m, _, data = small
    with pytest.raises(TypeError, match="rom_update: model"):
        rom_update("tower.toml", data)
    with pytest.raises(TypeError, match="rom must be a ROMOptions"):
        rom_update(m, data, rom={"freq_tol": 1e-6})
    with pytest.raises(femupdate.InputError, match="hold none"):
        rom_update(m, TestData(static=(femupdate.testdata.StaticData(force={"321:x": 1.0}, dofs=("321:x",),
                                                                             displacement=np.ones(1)),)))


def test_options_refused_by_name():
    with pytest.raises(femupdate.InputError, match="freq_tol"):
        ROMOptions(freq_tol=0.0)
    with pytest.raises(femupdate.InputError, match="n_modes"):
        ROMOptions(n_modes=0)


def test_basis_for_takes_the_data_dofs(small):
    m, dofs, data = small
    rb = basis_for(m, data, ROMOptions(n_train=0, max_points=1))
    assert rb.dofs == dofs and rb.n_modes == 8
    few = basis_for(m, data, ROMOptions(n_modes=2, corrections=False, n_train=0, max_points=1))
    assert [p["why"].split(":")[0] for p in few.points] == ["nominal", "attachment"]  # 3 modes for 6 dofs
    reduced, Vh = few.reduced()
    assert reduced.dofs[:6] == tuple(dofs)
    np.testing.assert_allclose(Vh[m.dof_index(dofs)], np.eye(6, Vh.shape[1]), atol=0)


@heavy
def test_benchmark_runs_quick(tmp_path):
    """benchmarks/bench_rom.py --quick: the two routes agree, every check passed."""
    out = tmp_path / "bench.json"
    script = Path(__file__).resolve().parents[1] / "benchmarks" / "bench_rom.py"
    proc = subprocess.run([sys.executable, str(script), "--quick", "--starts", "0", "--output", str(out)],
                          capture_output=True, text=True, timeout=1800)
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-2000:]
    res = json.loads(out.read_text())
    assert res["rom"]["passed"] and res["comparison"]["frequencies_max_rel_diff"] < 1e-6
    assert res["comparison"]["parameters_max_rel_diff"] < 1e-6
