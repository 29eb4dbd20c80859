"""Damping in the model and complex modes (issue 31, first slice).

References: the characteristic polynomial det(λ²M + λC + K) = 0 of a 2-dof system with
non-proportional damping (numpy.roots), SciPy's dense state-space eigen-solution as a second
route, the closed form λ = -ζω ± iω√(1-ζ²) of proportional damping, central finite differences
for the sensitivities, and the recovery of damping parameters from noise-free complex eigenvalues.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import scipy.linalg as la

from femupdate import Model
from femupdate._errors import InputError
from femupdate.damping import (DampedModel, Damper, LossFactor, complex_modes, complex_sensitivities, fit_damping,
                               load_damped_model, mean_phase_deviation, modal_phase_collinearity, realise,
                               target_eigenvalues)
from femupdate.examples import TRUSS_DAMPING, truss_damped_model_toml, truss_model_toml
from femupdate.model import Parameter

DOFS = ["1:x", "2:x"]


def two_dof(c=3.0, beta=2e-3, alpha=0.0, grounded=True):
    """Masses 1 and 2 kg, springs k1 (ground-1) and k2 (1-2), a damper c at dof 1 (non-proportional)."""
    k1 = np.array([[1.0, 0.0], [0.0, 0.0]])
    k2 = np.array([[1.0, -1.0], [-1.0, 1.0]])
    m = Model(DOFS, np.zeros((2, 2)), np.diag([1.0, 2.0]), (Parameter("k1", 1000.0), Parameter("k2", 500.0)),
              (k1, k2), (None, None))
    params = [Parameter("c", c), Parameter("b", beta)]
    return DampedModel(m, params, alpha=alpha, beta="b", dampers=(Damper(("1:x",) if grounded else DOFS, "c"),))


def characteristic_roots(M, C, K):
    """Roots of det(λ²M + λC + K) for 2 x 2 matrices, upper half-plane, ascending |λ|."""
    P = [[np.array([M[i, j], C[i, j], K[i, j]]) for j in range(2)] for i in range(2)]
    poly = np.polysub(np.polymul(P[0][0], P[1][1]), np.polymul(P[0][1], P[1][0]))
    r = np.roots(poly)
    r = r[r.imag > 0]
    return r[np.argsort(np.abs(r))]


def test_two_dof_eigenvalues_match_the_characteristic_polynomial_and_scipy():
    dm = two_dof()
    res = complex_modes(dm)
    K, M, C = (A.toarray() for A in (dm.K(), dm.M(), dm.C()))
    ref = characteristic_roots(M, C, K)
    assert res.n_modes == 2
    np.testing.assert_allclose(res.eigenvalues, ref, rtol=1e-10)
    # the damper makes the damping non-proportional: the modes are complex (MPC < 1)
    assert np.all(res.mpc < 1 - 1e-5) and np.all(res.mpd > 0.01)
    # second route: SciPy's quadratic problem via the other companion form (λ M φ = ..., B = [[C, M],[M, 0]])
    A2 = np.block([[-K, np.zeros((2, 2))], [np.zeros((2, 2)), M]])
    B2 = np.block([[C, M], [M, np.zeros((2, 2))]])
    w = la.eigvals(A2, B2)
    w = w[w.imag > 0]
    np.testing.assert_allclose(np.sort_complex(w[np.argsort(np.abs(w))]), np.sort_complex(ref), rtol=1e-10)
    # each pair satisfies the quadratic problem and the normalisation
    for lam, phi in zip(res.eigenvalues, res.shapes.T):
        F = lam ** 2 * M + lam * C + K
        assert np.linalg.norm(F @ phi) <= 1e-10 * np.linalg.norm(F) * np.linalg.norm(phi)
        assert abs(phi @ ((2 * lam * M + C) @ phi) - 1) < 1e-12


def test_sparse_shift_invert_agrees_with_dense():
    dm = two_dof(grounded=False)
    dense = complex_modes(dm)
    sparse = complex_modes(dm, n_modes=1, method="sparse")
    np.testing.assert_allclose(sparse.eigenvalues, dense.eigenvalues[:1], rtol=1e-10)
    np.testing.assert_allclose(np.abs(sparse.shapes), np.abs(dense.shapes[:, :1]), rtol=1e-8)


def test_proportional_damping_gives_real_modes_with_the_closed_form_eigenvalues():
    s = _truss(alpha=0.7, beta=3e-5, dampers=False)
    res = complex_modes(s)
    K, M = s.K().toarray(), s.M().toarray()
    w2, Phi = la.eigh(K, M)
    w = np.sqrt(w2)
    zeta = 0.7 / (2 * w) + 3e-5 * w / 2
    lam = -zeta * w + 1j * w * np.sqrt(1 - zeta ** 2)
    np.testing.assert_allclose(res.eigenvalues, lam, rtol=1e-12)  # 1e-9 without the pencil's balancing
    np.testing.assert_allclose(res.damping_ratios, zeta, rtol=1e-10)
    np.testing.assert_allclose(res.mpc, 1.0, atol=1e-10)
    np.testing.assert_allclose(res.mpd, 0.0, atol=1e-5)
    # realised shapes are the undamped modes (up to scale)
    R = realise(res.shapes)
    for r in range(res.n_modes):
        a, b = R[:, r], Phi[:, r]
        assert abs(a @ b) / (np.linalg.norm(a) * np.linalg.norm(b)) > 1 - 1e-10


def test_modal_damping_ratios_act_in_modal_coordinates():
    m = two_dof().model
    dm = DampedModel(m, modal=(0.02, 0.05))
    res = complex_modes(dm)
    w = np.sqrt(la.eigh(m.K().toarray(), m.M().toarray(), eigvals_only=True))
    np.testing.assert_allclose(res.damping_ratios, [0.02, 0.05], rtol=1e-10)
    np.testing.assert_allclose(np.abs(res.eigenvalues), w, rtol=1e-10)
    np.testing.assert_allclose(res.mpc, 1.0, atol=1e-10)
    # differentiated in modal coordinates since modal ratios became parameters (tests/test_damping_modal.py)
    assert complex_sensitivities(dm, res).d_eigenvalues.shape == (2, 2)


def test_hysteretic_loss_factor_on_the_whole_stiffness():
    m = two_dof().model
    dm = DampedModel(m, losses=(LossFactor(0.04),))
    res = complex_modes(dm)
    w = np.sqrt(la.eigh(m.K().toarray(), m.M().toarray(), eigvals_only=True))
    np.testing.assert_allclose(res.eigenvalues, 1j * w * np.sqrt(1 + 0.04j), rtol=1e-10)  # λ² = -ω²(1 + iη)


def test_complexity_indicators_on_known_shapes():
    real = np.array([1.0, -2.0, 0.5]) * np.exp(0.7j)
    assert modal_phase_collinearity(real) == pytest.approx(1.0, abs=1e-14)
    assert mean_phase_deviation(real) == pytest.approx(0.0, abs=1e-6)
    circle = np.array([1.0, 1j, -1.0, -1j])
    assert modal_phase_collinearity(circle) == pytest.approx(0.0, abs=1e-14)
    assert mean_phase_deviation(circle) == pytest.approx(45.0, abs=1e-9)
    np.testing.assert_allclose(realise(real), [-1.0, 2.0, -0.5], atol=1e-14)  # largest entry positive
    two = np.array([1.0, 1.0 + 1.0j])  # one entry 45° off the best line: MPC from the 2 x 2 eigenvalues
    x, y = two.real, two.imag
    s = np.linalg.eigvalsh([[x @ x, x @ y], [x @ y, y @ y]])
    assert modal_phase_collinearity(two) == pytest.approx(((s[1] - s[0]) / (s[1] + s[0])) ** 2, rel=1e-12)


@pytest.mark.parametrize("hysteretic", [False, True])
def test_sensitivities_match_central_differences(hysteretic):
    dm = two_dof(alpha=0.0)
    if hysteretic:
        dm = DampedModel(dm.model, dm.parameters + (Parameter("eta", 0.03),), beta="b", dampers=dm.dampers,
                         losses=(LossFactor("eta", on="k2"),))
    res = complex_modes(dm)
    S = complex_sensitivities(dm, res, vectors=True)
    p0 = dm.resolve()
    for j, name in enumerate(dm.parameter_names):
        h = 1e-5 * max(abs(p0[j]), 1e-3)
        up, down = p0.copy(), p0.copy()
        up[j] += h
        down[j] -= h
        a, b = complex_modes(dm, values=up), complex_modes(dm, values=down)
        fd = (a.eigenvalues - b.eigenvalues) / (2 * h)
        np.testing.assert_allclose(S.d_eigenvalues[:, j], fd, rtol=1e-6, atol=1e-9 * np.abs(fd).max(), err_msg=name)
        fdv = (a.shapes - b.shapes) / (2 * h)
        assert np.abs(S.d_shapes[:, :, j] - fdv).max() <= 1e-5 * np.abs(fdv).max(), name
    # derived: natural frequency and damping ratio derivatives against differences of those
    j = dm.parameter_names.index("c")
    up = p0.copy()
    up[j] += 1e-6
    dz = (complex_modes(dm, values=up).damping_ratios - res.damping_ratios) / 1e-6
    np.testing.assert_allclose(S.d_damping_ratios[:, j], dz, rtol=1e-4)


def test_rayleigh_beta_times_a_stiffness_parameter_is_exact():
    dm = two_dof(alpha=0.0)
    dK, dM, dC, dD = dm.derivatives("k2")
    np.testing.assert_allclose(dC.toarray(), 2e-3 * np.array([[1.0, -1.0], [-1.0, 1.0]]))
    _, _, dCb, _ = dm.derivatives("b")
    np.testing.assert_allclose(dCb.toarray(), dm.K().toarray())


def _truss(alpha=0.5, beta="b", dampers=True, c=(40.0, 25.0)):
    from femupdate.io.model_file import build_model
    import tomllib

    model = build_model(tomllib.loads(truss_model_toml()), Path("truss.toml"))
    params = [Parameter("b", 2e-5)] if beta == "b" else []
    ds = ()
    if dampers:
        params += [Parameter("c1", c[0]), Parameter("c2", c[1])]
        ds = (Damper(("4:x", "104:y"), "c1"), Damper(("103:y",), "c2"))
    return DampedModel(model, params, alpha=alpha, beta=beta, dampers=ds)


def test_dampers_and_rayleigh_recovered_from_noise_free_complex_eigenvalues():
    truth = _truss()
    target = complex_modes(truth, n_modes=6).eigenvalues
    start = _truss(alpha=0.2, c=(10.0, 60.0)).with_values({"b": 5e-5})
    dm = DampedModel(start.model, start.parameters + (Parameter("a", 0.2),), alpha="a", beta="b",
                     dampers=start.dampers)
    fit = fit_damping(dm, target, ["a", "b", "c1", "c2"])
    assert fit.success
    for name, true in (("a", 0.5), ("b", 2e-5), ("c1", 40.0), ("c2", 25.0)):
        assert fit.values[name] == pytest.approx(true, rel=1e-6), name
    # the same from frequencies and damping ratios
    tr = complex_modes(truth, n_modes=6)
    lam = target_eigenvalues(tr.natural_frequencies_hz, tr.damping_ratios)
    np.testing.assert_allclose(lam, target, rtol=1e-12)


def test_model_file_damping_table(tmp_path, capsys):
    (tmp_path / "truss.toml").write_text(truss_damped_model_toml())
    dm = load_damped_model(tmp_path / "truss.toml")
    ref = _truss(c=(TRUSS_DAMPING["c1"], TRUSS_DAMPING["c2"]))
    np.testing.assert_allclose(dm.C().toarray(), ref.C().toarray(), rtol=1e-14)
    code, out, err = _cli([tmp_path / "truss.toml", "--n-modes", "3", "--json", tmp_path / "cm.json"], capsys)
    assert code == 0, err
    assert "MPC" in out and "3 complex modes" in out
    obj = json.loads((tmp_path / "cm.json").read_text())
    lam = complex_modes(ref, n_modes=3).eigenvalues
    np.testing.assert_allclose([complex(*v) for v in obj["eigenvalues"]], lam, rtol=1e-12)
    assert obj["parameters"]["c1"] == TRUSS_DAMPING["c1"]


def _cli(args, capsys):
    from femupdate.cli import main

    with pytest.raises(SystemExit) as info:
        main(["complex-modes", *map(str, args)])
    out, err = capsys.readouterr()
    return info.value.code, out, err


BAD = {
    "negative damper": ('[[damping.damper]]\ndofs = ["4:x"]\nc = -3.0\n', "[damping]: damper ['4:x'] c = -3.0 is negative"),
    "negative parameter": ('[damping]\nalpha = "a"\n[damping.parameters.a]\nvalue = -0.1\n',
                           "damping parameter 'a' = -0.1 (value) is negative"),
    "indefinite C0": ('[damping]\nC0 = "C0.npy"\n', "C0 is not positive semi-definite (smallest diagonal entry, at 2:x, "
                      "-50 against entries of size 50)"),
    "percent": ("[damping]\nmodal = [2.0, 3.0]\n", "mode 1 = 2.0 is above 1: damping ratios are fractions of critical "
                "damping (2 % is 0.02); it looks like a percentage, write 0.02"),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_bad_damping_input_one_message_exit_2(tmp_path, capsys, case):
    extra, message = BAD[case]
    if case == "indefinite C0":  # a C with a negative entry at a dof: a damper that feeds energy in
        n = _truss().n_dofs
        C = np.zeros((n, n))
        C[0, 0] = -50.0
        np.save(tmp_path / "C0.npy", C)
    (tmp_path / "m.toml").write_text(truss_model_toml() + "\n" + extra)
    code, out, err = _cli([tmp_path / "m.toml"], capsys)
    assert code == 2, out + err
    assert message in err and "Traceback" not in err
    assert str(tmp_path / "m.toml") in err  # the file named
    assert err.strip().count("\n") == 0, err  # one message


def test_unstable_model_refused():
    # a stiffness that is not positive semi-definite (k1 < 0): a real eigenvalue > 0, refused by name
    k1 = np.array([[1.0, 0.0], [0.0, 0.0]])
    k2 = np.array([[1.0, -1.0], [-1.0, 1.0]])
    m = Model(DOFS, np.zeros((2, 2)), np.diag([1.0, 2.0]), (Parameter("k1", -300.0), Parameter("k2", 500.0)),
              (k1, k2), (None, None))
    dm = DampedModel(m, [Parameter("c", 3.0)], dampers=(Damper(("1:x",), "c"),))
    with pytest.raises(InputError, match=r"damped model 'model' is unstable: eigenvalue 10.6\d*\+0i"):
        complex_modes(dm, n_modes=1)


def test_indefinite_damping_matrix_refused_though_the_model_is_stable():
    # a 2x2 block [[1, 3], [3, 1]] at 2:x, 2:y (eigenvalues 4 and -2; its diagonal >= 0): small against the
    # truss's damping, but a C that feeds energy in along (1, -1), as a negative damper does, was taken
    m = _truss()
    C = np.zeros((m.n_dofs, m.n_dofs))
    C[0, 0], C[1, 1], C[0, 1], C[1, 0] = 1.0, 1.0, 3.0, 3.0  # diagonal >= 0, eigenvalues 4 and -2
    with pytest.raises(InputError, match=r"C0 is not positive semi-definite \(smallest eigenvalue -2 against"):
        DampedModel(m.model, m.parameters, m.alpha, m.beta, m.dampers, C0=C)


def test_negative_damping_parameter_and_unknown_names_refused():
    m = two_dof().model
    with pytest.raises(InputError, match="'c' = -1 .*negative"):
        DampedModel(m, (Parameter("c", -1.0),), dampers=(Damper(("1:x",), "c"),))
    with pytest.raises(InputError, match="not a damping parameter"):
        DampedModel(m, (), dampers=(Damper(("1:x",), "k1"),))
    with pytest.raises(InputError, match="used by no damping"):
        DampedModel(m, (Parameter("c", 1.0),))
    with pytest.raises(InputError, match="percentage"):
        target_eigenvalues([10.0], [5.0])
    with pytest.raises(InputError, match="'k1' has the name of a parameter of model"):
        DampedModel(m, (Parameter("k1", 1.0),), alpha="k1")
    with pytest.raises(InputError, match="between 1:x and itself"):
        Damper(["1:x", "1:x"], 1.0)
    with pytest.raises(InputError, match="damper \\['9:x'\\]"):
        DampedModel(m, dampers=(Damper(["9:x"], 1.0),))
    with pytest.raises(InputError, match="parameter 'E' is not in model"):
        DampedModel(m, losses=(LossFactor(0.01, on="E"),))
    with pytest.raises(InputError, match="modal damping ratio of mode 2 = 1 is critical"):
        DampedModel(m, modal=(0.02, 1.0))


@pytest.mark.parametrize("hysteretic", [False, True])
def test_sparse_shift_invert_on_the_truss(hysteretic):
    t = _truss()
    if hysteretic:  # K + iD complex: the pencil is complex
        t = DampedModel(t.model, (Parameter("eta", 0.03),), losses=(LossFactor("eta"),), dampers=(Damper(["4:x"], 30.0),))
    dense = complex_modes(t)
    sparse = complex_modes(t, n_modes=3, method="sparse")
    np.testing.assert_allclose(sparse.eigenvalues, dense.eigenvalues[:3], rtol=1e-12)
    for r in range(3):  # the same normalised shapes, up to sign
        a, b = sparse.shapes[:, r], dense.shapes[:, r]
        assert min(np.abs(a - b).max(), np.abs(a + b).max()) <= 1e-9 * np.abs(b).max()


def test_sparse_solver_on_a_free_free_chain_shifts_left_of_zero():
    dofs, ks = ["1:x", "2:x", "3:x", "4:x"], []
    for i in range(3):  # springs between neighbours only: free-free
        e = np.zeros(4)
        e[i], e[i + 1] = 1.0, -1.0
        ks.append(np.outer(e, e))
    m = Model(dofs, np.zeros((4, 4)), np.diag([1.0, 2.0, 1.5, 1.0]),
              [Parameter("k1", 400.0), Parameter("k2", 300.0), Parameter("k3", 200.0)], ks, [None] * 3)
    dm = DampedModel(m, alpha=0.2, dampers=(Damper(["2:x", "4:x"], 2.0),))
    dense = complex_modes(dm)
    sparse = complex_modes(dm, method="sparse", n_modes=2)
    assert dense.n_rigid == 1 and dense.n_overdamped == 1  # α M damps the rigid motion: 0 and -α
    np.testing.assert_allclose(sparse.eigenvalues, dense.eigenvalues[:2], rtol=1e-10)
    assert sparse.solver.startswith("sparse (sigma=-")


def test_free_free_and_overdamped_motions_are_counted_and_left_out():
    k2 = np.array([[1.0, -1.0], [-1.0, 1.0]])
    m = Model(DOFS, np.zeros((2, 2)), np.diag([1.0, 2.0]), (Parameter("k", 500.0),), (k2,), (None,))
    free = DampedModel(m, dampers=(Damper(DOFS, 3.0),))  # rigid-body motion undamped: a double zero
    res = complex_modes(free)
    # relative motion: m_r = 2/3 kg, k = 500, c = 3: λ = -c/2m_r + i√(k/m_r - (c/2m_r)²)
    mr = 2.0 / 3.0
    np.testing.assert_allclose(res.eigenvalues, [-3 / (2 * mr) + 1j * np.sqrt(500 / mr - (3 / (2 * mr)) ** 2)],
                               rtol=1e-12)
    assert (res.n_rigid, res.n_overdamped) == (2, 0)
    with pytest.raises(InputError, match="found 0 underdamped mode.*use method='dense'"):  # 2 dofs: ARPACK's 2 nearest are 0
        complex_modes(free, method="sparse", n_modes=1)
    grounded = DampedModel(m, dampers=(Damper(["1:x"], 300.0),))  # the rigid motion creeps: one 0, one real root
    assert (complex_modes(grounded).n_rigid, complex_modes(grounded).n_overdamped) == (1, 1)


def test_rayleigh_on_a_model_with_nonlinear_terms_differentiates_the_products():
    from femupdate.coefficients import Power, Term

    Kb, Km = np.diag([2.0, 1.0]), np.array([[1.0, -0.5], [-0.5, 1.0]])
    shell = Model(DOFS, np.diag([5.0, 5.0]), np.diag([1.0, 2.0]), [Parameter("E", 70.0), Parameter("t", 0.4)],
                  [None, None], [None, np.diag([0.1, 0.1])], terms=[Term([Power("E"), Power("t", 3)], K=Kb),
                                                                    Term([Power("E"), Power("t")], K=Km)])
    dm = DampedModel(shell, [Parameter("a", 0.3), Parameter("b", 1e-3)], alpha="a", beta="b")
    p0 = dm.resolve()
    for name in dm.parameter_names:  # dC/dp against central differences of C(p)
        j = dm.parameter_names.index(name)
        h = 1e-6 * abs(p0[j])
        up, down = p0.copy(), p0.copy()
        up[j] += h
        down[j] -= h
        fd = (dm.C(up) - dm.C(down)).toarray() / (2 * h)
        np.testing.assert_allclose(dm.derivatives(name)[2].toarray(), fd, rtol=1e-7, atol=1e-9 * np.abs(fd).max(),
                                   err_msg=name)
    np.testing.assert_allclose(dm.C().toarray(), 0.3 * dm.M().toarray() + 1e-3 * dm.K().toarray(), rtol=1e-14)


def test_stiffness_and_damping_recovered_together():
    truth = _truss()
    target = complex_modes(truth, n_modes=6).eigenvalues
    start = _truss(c=(10.0, 60.0)).with_values({"b": 5e-5, "E": 6.0e10})
    fit = fit_damping(start, target, ["E", "b", "c1", "c2"])
    assert fit.success
    for name, true in (("E", 7.0e10), ("b", 2e-5), ("c1", 40.0), ("c2", 25.0)):
        assert fit.values[name] == pytest.approx(true, rel=1e-6), name


def test_a_damping_table_read_as_an_undamped_model_is_said(tmp_path, caplog):
    from femupdate import load_model

    (tmp_path / "t.toml").write_text(truss_damped_model_toml())
    with caplog.at_level("WARNING"):
        model = load_model(tmp_path / "t.toml")
    assert "the [damping] table is read by complex modes" in caplog.text and "undamped K and M are used" in caplog.text
    np.testing.assert_allclose(model.K().toarray(), _truss().K().toarray())


def test_complexity_of_test_data_equals_that_of_the_model_shapes_at_the_measured_dofs():
    from femupdate import MeasuredMode, TestData
    from femupdate.damping import data_complexity

    dm = load_damped_model_text(truss_damped_model_toml())
    res = complex_modes(dm, n_modes=3)
    at = ["4:x", "4:y", "104:y", "103:y"]
    idx = dm.model.dof_index(at)
    data = TestData(modes=(*(MeasuredMode(abs(v) ** 2, at, 2.5j * res.shapes[idx, r]) for r, v in
                             enumerate(res.eigenvalues)), MeasuredMode(1.0e6)))
    table = data_complexity(data)
    for r in range(3):
        assert table[r]["mpc"] == pytest.approx(float(modal_phase_collinearity(res.shapes[idx, r])), rel=1e-12)
        assert table[r]["mpd_deg"] == pytest.approx(float(mean_phase_deviation(res.shapes[idx, r])), rel=1e-9)
        assert table[r]["mpc"] < 1 - 1e-6
    assert table[3] == {"mode": 4, "mpc": None, "mpd_deg": None}


def load_damped_model_text(text):
    import tempfile

    with tempfile.TemporaryDirectory() as d:
        (Path(d) / "m.toml").write_text(text)
        return load_damped_model(Path(d) / "m.toml")


def test_matrix_model_with_damping_matrices(tmp_path):
    K = np.array([[3.0, -1.0], [-1.0, 1.0]]) * 1e3
    Cc = np.array([[1.0, -1.0], [-1.0, 1.0]])
    for name, A in (("K0", K), ("M0", np.diag([1.0, 2.0])), ("C0", np.diag([0.5, 0.0])), ("Cc", Cc)):
        np.save(tmp_path / f"{name}.npy", A)
    (tmp_path / "m.toml").write_text('[matrices]\ndofs = ["1:x", "2:x"]\nK0 = "K0.npy"\nM0 = "M0.npy"\n\n'
                                     '[damping]\nC0 = "C0.npy"\n\n[damping.parameters.c]\nvalue = 4.0\nC = "Cc.npy"\n')
    dm = load_damped_model(tmp_path / "m.toml")
    np.testing.assert_allclose(dm.C().toarray(), np.diag([0.5, 0.0]) + 4.0 * Cc)
    np.testing.assert_allclose(dm.derivatives("c")[2].toarray(), Cc)
    ref = characteristic_roots(np.diag([1.0, 2.0]), dm.C().toarray(), K)
    np.testing.assert_allclose(complex_modes(dm).eigenvalues, ref, rtol=1e-10)


def test_fit_with_standard_deviations_gives_the_covariance_of_the_parameters():
    truth = _truss()
    tr = complex_modes(truth, n_modes=6)
    s_zeta, s_f = np.full(6, 0.002), np.full(6, 0.001)
    fit = fit_damping(_truss(c=(10.0, 60.0)), tr.eigenvalues, ["b", "c1", "c2"], std_damping_ratio=s_zeta,
                      std_frequency=s_f)
    assert fit.values["c1"] == pytest.approx(40.0, rel=1e-6)
    # second route: the covariance from central differences of the damping ratios and frequencies
    names, p0 = ["b", "c1", "c2"], truth.resolve()
    J = np.zeros((12, 3))
    for k, name in enumerate(names):
        j = truth.parameter_names.index(name)
        h = 1e-4 * p0[j]  # central differences: truncation O(h²) ~ 1e-8, round-off small against h
        up, down = p0.copy(), p0.copy()
        up[j] += h
        down[j] -= h
        a, b = complex_modes(truth, n_modes=6, values=up), complex_modes(truth, n_modes=6, values=down)
        J[:6, k] = -(a.eigenvalues.real - b.eigenvalues.real) / np.abs(tr.eigenvalues) / (2 * h) / s_zeta
        J[6:, k] = (a.eigenvalues.imag - b.eigenvalues.imag) / np.abs(tr.eigenvalues) / (2 * h) / s_f
    ref = np.linalg.inv(J.T @ J)
    sd, sd_ref = np.sqrt(np.diag(fit.covariance)), np.sqrt(np.diag(ref))
    np.testing.assert_allclose(sd, sd_ref, rtol=1e-6)  # standard deviations
    np.testing.assert_allclose(fit.covariance / np.outer(sd, sd), ref / np.outer(sd_ref, sd_ref), atol=1e-6)  # correlations
    assert set(fit.std) == set(names)
    with pytest.raises(InputError, match="together"):
        fit_damping(truth, tr.eigenvalues, ["c1"], std_frequency=0.01)
