"""Weights of a damped update from identified standard deviations (issue 31, item 4): pyOMA2's
``Xi_std`` (and ``Fn_std``, ``Phi_std``) read by the adapters reach the damped modes block's
weights and the covariance; sdypy-EMA gives none, and ``--std-damping-ratio`` states them.

Reference: a second route — the same deviations given as options (``measurement_std``) rather
than read from the identification: the same weights, the same covariance.
"""

from __future__ import annotations

import json
from types import SimpleNamespace

import numpy as np
import pytest

import femupdate
from femupdate.damping import complex_modes
from femupdate.damping.view import DampedView
from femupdate.io.adapters import from_pyoma2, from_sdypy_ema
from femupdate.options import UpdateOptions
from femupdate.updating.damped_run import damped_problem
from test_damping_update import DOFS, _cli, _start, _truss, _write_case

XI_STD = np.array([1e-4, 2e-4, 3e-4, 4e-4])


@pytest.fixture(scope="module")
def truss():
    return _truss()


def _identified(truss):
    """A pyOMA2-like result of the truss's first four complex modes: shapes scaled to 1 at their
    largest entry, with standard deviations."""
    cm = complex_modes(truss, n_modes=4)
    Phi = cm.shapes[truss.model.dof_index(list(DOFS))]
    Phi = Phi / Phi[np.argmax(np.abs(Phi), axis=0), np.arange(4)]
    f = cm.natural_frequencies_hz
    return SimpleNamespace(Fn=f, Phi=Phi, Xi=cm.damping_ratios, Fn_std=1e-4 * f, Xi_std=XI_STD,
                           Phi_std=np.full(Phi.shape, 1e-3))


def test_pyoma2_deviations_are_the_damped_update_s_weights(truss):
    data = from_pyoma2(_identified(truss), list(DOFS))
    prob = damped_problem(DampedView(truss), data, UpdateOptions()).blocks[0].problem
    np.testing.assert_allclose(prob.w_z, 1 / XI_STD, rtol=1e-14)
    np.testing.assert_allclose(prob.w_f, 1 / 2e-4, rtol=1e-12)  # std_eigenvalue = 2 Fn_std / Fn
    assert prob.stated == {"eigenvalue": "data", "damping_ratio": "data", "shape": "data"}
    res = femupdate.update(_start(truss), data)
    assert res.diagnostics.absolute and res.diagnostics.noise[0]["source"] == "stated in the data file"
    # the second route: the same deviations as options
    plain = femupdate.testdata.TestData(modes=tuple(
        femupdate.testdata.MeasuredMode(m.eigenvalue, m.dofs, m.shape, damping_ratio=m.damping_ratio)
        for m in data.modes))
    given = femupdate.update(_start(truss), plain, measurement_std={
        "eigenvalue": [m.std_eigenvalue for m in data.modes], "damping_ratio": XI_STD.tolist(),
        "shape": [m.std_shape for m in data.modes]})
    assert given.diagnostics.absolute
    np.testing.assert_allclose(res.diagnostics.covariance, given.diagnostics.covariance, rtol=1e-8)
    for n in ("b", "c1", "c2"):
        assert res.damping["std"][n] == pytest.approx(given.damping["std"][n], rel=1e-8)
    # a larger deviation of the damping ratios widens the dampers' deviations
    wide = femupdate.update(_start(truss), plain, measurement_std={
        "eigenvalue": [m.std_eigenvalue for m in data.modes], "damping_ratio": (10 * XI_STD).tolist(),
        "shape": [m.std_shape for m in data.modes]})
    assert wide.damping["std"]["c1"] > 1.5 * res.damping["std"]["c1"]  # the shapes inform c1 too


def test_npz_identification_reaches_the_damped_update_and_std_damping_ratio_states_sdypy_s(tmp_path, capsys, truss):
    ident = _identified(truss)
    np.savez(tmp_path / "oma.npz", channels=np.array(DOFS), **vars(ident))
    model, _ = _write_case(tmp_path, femupdate.testdata.TestData(modes=()))
    code, out, err = _cli(["update", model, tmp_path / "oma.npz", "--json", tmp_path / "r.json"], capsys)
    assert code == 0, out + err
    r = json.loads((tmp_path / "r.json").read_text())
    ref = femupdate.update(_start(truss), from_pyoma2(ident, list(DOFS)))
    for n in ("b", "c1", "c2"):
        assert r["damping"]["std"][n] == pytest.approx(ref.damping["std"][n], rel=1e-6), n
    assert r["diagnostics"]["absolute"] is True
    # sdypy-EMA: no deviations; --std-damping-ratio (with --std-eigenvalue, --std-shape) states them
    ema = SimpleNamespace(nat_freq=ident.Fn, nat_xi=ident.Xi, phi=ident.Phi)
    assert all(m.std_damping_ratio is None for m in from_sdypy_ema(ema, list(DOFS)).modes)
    np.savez(tmp_path / "ema.npz", channels=np.array(DOFS), nat_freq=ident.Fn, nat_xi=ident.Xi, phi=ident.Phi)
    std_shape = ",".join(f"{m.std_shape!r}" for m in from_pyoma2(ident, list(DOFS)).modes)
    code, out, err = _cli(["update", model, tmp_path / "ema.npz", "--std-eigenvalue", "2e-4", "--std-shape", std_shape,
                           "--std-damping-ratio", ",".join(map(repr, XI_STD.tolist())), "--json", tmp_path / "e.json"],
                          capsys)
    assert code == 0, out + err
    e = json.loads((tmp_path / "e.json").read_text())
    assert e["diagnostics"]["absolute"] is True
    for n in ("b", "c1", "c2"):
        assert e["damping"]["std"][n] == pytest.approx(ref.damping["std"][n], rel=1e-6), n
    code, out, err = _cli(["update", model, tmp_path / "ema.npz", "--std-damping-ratio", "1,2"], capsys)
    assert code == 2 and "--std-damping-ratio" in err and err.strip().count("\n") == 0, err
