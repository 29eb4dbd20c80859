"""The damping benchmark's machinery (benchmarks/bench_damping.py, issue 31 item 5) at one seed:
its FRFs (a second route: dense solves) against femupdate's damped receptances, its noise, the
sdypy-EMA identification and the updates from it, and the table's shape."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import numpy as np
import pytest

from conftest import heavy

PATH = Path(__file__).resolve().parents[1] / "benchmarks" / "bench_damping.py"


@pytest.fixture(scope="module")
def bench():
    spec = importlib.util.spec_from_file_location("bench_damping", PATH)
    mod = importlib.util.module_from_spec(spec)
    sys.modules["bench_damping"] = mod
    spec.loader.exec_module(mod)
    return mod


@pytest.fixture(scope="module")
def truss(bench):
    return bench.truss()


def test_simulated_frfs_are_the_damped_receptances_and_the_noise_its_level(bench, truss):
    from femupdate.damping.frf import damped_response

    f = bench.band()[::20]
    H = bench.exact_receptances(truss, f)
    X, _ = damped_response(truss, 2 * np.pi * f, {bench.DRIVE: 1.0}, list(truss.model.dofs))
    np.testing.assert_allclose(H, X, rtol=1e-10, atol=1e-12 * np.abs(X).max())
    H = bench.exact_receptances(truss, bench.band())
    Hn, sigma = bench.noisy(H, 0.05, 3)
    rms = np.sqrt(np.mean(np.abs(H) ** 2, axis=0))
    np.testing.assert_allclose(sigma, 0.05 * rms / np.sqrt(2))
    e = (Hn - H) / sigma
    # real and imaginary parts each of unit variance: 2 x 781 draws per dof, a 5-sigma band
    var = np.concatenate([e.real, e.imag]).var(axis=0)
    assert np.all(np.abs(var - 1) < 5 * np.sqrt(2 / (2 * H.shape[0]))), var


def test_shape_error_is_zero_for_a_complex_multiple_and_not_otherwise(bench):
    rng = np.random.default_rng(0)
    phi = rng.standard_normal(6) + 1j * rng.standard_normal(6)
    assert np.max(np.abs(bench.shape_error(phi * (2 - 3j), phi))) < 1e-14
    assert np.max(np.abs(bench.shape_error(phi.real, phi))) > 1e-3


def test_one_seed_identifies_the_modes_and_the_stated_route_recovers_the_dampers(bench, truss):
    pytest.importorskip("sdypy.EMA", reason="sdypy-EMA is not installed (pip install 'femupdate[ema]')")
    H = bench.exact_receptances(truss, bench.band())
    lv = bench.run_level(truss, H, 0.01, [0], frf=False, log=lambda s: None)
    run = lv["runs"][0]
    f0, z0, _ = bench.true_modes(truss)
    assert np.all(np.abs(run["identified"]["f_rel_error"]) < 5e-3)
    assert np.all(np.abs(np.array(run["identified"]["zeta"]) / z0 - 1) < 0.05)
    est = run["dampers"]["ema+std"]
    assert est["success"], est
    for name, true in bench.TRUTH.items():
        assert est["values"][name] == pytest.approx(true, rel=0.03), name
        assert est["std"][name] is not None and est["std"][name] > 0
    lv["summary"] = bench.summarise(lv)
    s = lv["summary"]["routes"]["dampers/ema+std"]
    assert s["n"] == 1 and s["failed"] == 0 and set(s["parameters"]) == set(bench.TRUTH)
    table = bench.markdown({"levels": [lv]}).splitlines()
    assert len(table) == 2 + bench.N_MODES + 1 + 2 + 2 * len(bench.TRUTH)
    assert all(line.count("|") in (8, 10) for line in table if line)


def test_the_rayleigh_family_is_the_same_structure_with_alpha_a_parameter(bench, truss):
    from femupdate.damping import complex_modes

    fam = bench.family_model(truss, "rayleigh")
    assert fam.parameter_names[-1] == "a" and set(bench.FAMILIES["rayleigh"][0]) <= set(fam.parameter_names)
    base = complex_modes(truss, n_modes=5)
    np.testing.assert_allclose(complex_modes(fam, n_modes=5).eigenvalues, base.eigenvalues, rtol=1e-12)
    # alpha adds alpha M to C: to first order each mode's damping ratio grows by d_alpha / (2 omega)
    up = complex_modes(fam.with_values({"a": 0.6}), n_modes=5)
    np.testing.assert_allclose(up.damping_ratios - base.damping_ratios, 0.1 / (2 * np.abs(base.eigenvalues)), rtol=0.02)


@heavy
def test_one_seed_of_the_frf_route_recovers_the_parameters(bench, truss):
    H = bench.exact_receptances(truss, bench.band())
    Hn, sigma = bench.noisy(H, 0.01, 0)
    est = bench.update_frf(truss, bench.band(), Hn, sigma)
    assert est["success"], est
    for name, true in bench.TRUTH.items():
        assert abs(est["values"][name] - true) < 5 * est["std"][name], name
