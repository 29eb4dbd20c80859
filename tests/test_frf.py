"""FRF simulation, Brandon's receptance sensitivity (eq. 32), resonance handling, conditioning of X
(eq. 28, Figure 4) and frequency selection.  References: closed-form 2-dof receptances, dense
matrix inverses, central finite differences, the direct-updating matrix of femupdate.direct,
exhaustive search."""

import itertools

import numpy as np
import pytest

from femupdate import FRFData, InputError, NumericalError, Structure, TestData, model_modes
from femupdate.direct import build_system
from femupdate.examples import chain, three_dof, two_dof
from femupdate.frf import (Damping, add_noise, convert, first_order_check, frf, from_channels, receptance,
                           receptance_fd, receptance_sensitivity, resonances, simulate)
from femupdate.frf.selection import condition_study, direct_blocks, select_frequencies
from femupdate.frf.simulate import check_data_against_model


def closed_form_2dof(k1, k2, m1, m2, w):
    """alpha = adj(Z)/det(Z), Z = [[k1+k2-m1 w², -k2], [-k2, k2-m2 w²]]."""
    a, b, d = k1 + k2 - m1 * w**2, -k2, k2 - m2 * w**2
    det = a * d - b * b
    return np.array([[d, -b], [-b, a]]) / det


def dense_alpha(model, w, p=None, damping=Damping()):
    K, M = model.K(p).toarray(), model.M(p).toarray()
    cK, cM = damping.coefficients(np.array([w]))
    return np.linalg.inv(cK[0] * K + cM[0] * M)


def with_mass_parameter():
    """Five-dof chain whose second mass is a parameter (dM/dp != 0)."""
    s = Structure("chain with a mass parameter")
    for i, k in enumerate([100.0, 80.0, 120.0, 90.0, 110.0], start=1):
        s.parameter(f"k{i}", k, (1.0, 1e4))
        s.spring([f"{i}:x"] if i == 1 else [f"{i - 1}:x", f"{i}:x"], k=f"k{i}")
    s.parameter("m2", 1.5, (0.1, 10.0))
    for i, m in enumerate([1.0, "m2", 2.0, 1.2, 0.8], start=1):
        s.mass([f"{i}:x"], m=m)
    return s.build()


# ------------------------------------------------------------------------------- simulation
def test_receptance_matches_the_closed_form_of_the_two_dof_system():
    m = two_dof()
    w = np.array([0.3, 0.5, 1.3, 2.0, 3.1])
    A = receptance(m, w, ["1:x", "2:x"])
    ref = np.array([closed_form_2dof(8, 6, 2, 4, wi) for wi in w])
    np.testing.assert_allclose(A, ref, rtol=1e-12)
    np.testing.assert_allclose(A, np.swapaxes(A, 1, 2), rtol=1e-12)  # reciprocity
    dofs, x = frf(m, w, {"2:x": 1.0})
    assert dofs == ("1:x", "2:x")
    np.testing.assert_allclose(x, ref[:, :, 1], rtol=1e-12)
    assert not np.iscomplexobj(x)


@pytest.mark.parametrize("damping", [Damping(), Damping(alpha=0.05, beta=1e-3, eta=0.02)])
def test_dense_and_sparse_paths_agree_with_the_inverse(damping):
    c = chain(np.linspace(100, 200, 30), np.linspace(1, 2, 30))
    w = np.array([0.7, 3.3, 6.1])
    dense = receptance(c, w, ["30:x", "4:x"], ["1:x", "17:x", "30:x"], damping=damping, method="dense")
    sparse = receptance(c, w, ["30:x", "4:x"], ["1:x", "17:x", "30:x"], damping=damping, method="sparse")
    ref = np.array([dense_alpha(c, wi, damping=damping)[np.ix_([0, 16, 29], [29, 3])] for wi in w])
    np.testing.assert_allclose(dense, ref, rtol=1e-10)
    np.testing.assert_allclose(sparse, ref, rtol=1e-10)
    assert np.iscomplexobj(dense) == (not damping.undamped)


def test_mobility_and_accelerance():
    m = two_dof()
    w = np.array([0.5, 1.5])
    _, x = frf(m, w, {"1:x": 1.0})
    _, v = frf(m, w, {"1:x": 1.0}, kind="mobility")
    _, a = frf(m, w, {"1:x": 1.0}, kind="accelerance")
    np.testing.assert_allclose(v, 1j * w[:, None] * x, rtol=1e-14)
    np.testing.assert_allclose(a, -(w[:, None] ** 2) * x, rtol=1e-14)
    np.testing.assert_allclose(convert(a, w, "receptance", "accelerance"), x, rtol=1e-14)
    with pytest.raises(InputError, match="zero frequency"):
        convert(a, np.array([0.0, 1.0]), "receptance", "accelerance")


def test_noise_models():
    m = two_dof()
    w = np.linspace(0.2, 2.4, 400)
    clean = simulate(m, w, {"2:x": 1.0})
    rel = add_noise(clean, 0.02, "relative", seed=1)
    ratio = rel.response / clean.response - 1
    assert not np.iscomplexobj(rel.response)
    assert 0.018 < np.std(ratio) < 0.022  # sigma = 0.02 over 800 samples
    coh = add_noise(clean, 0.02, "coherent", seed=1)
    r = coh.response / clean.response
    np.testing.assert_allclose(r[:, 0], r[:, 1], rtol=1e-12)  # one error per line for every channel
    assert np.std(r[:, 0]) > 0.01
    ab = add_noise(clean, 1e-3, "absolute", seed=2)
    assert 0.0009 < np.std(ab.response - clean.response) < 0.0011
    np.testing.assert_array_equal(add_noise(clean, 0.02, seed=5).response, add_noise(clean, 0.02, seed=5).response)
    cplx = simulate(m, w, {"2:x": 1.0}, damping=Damping(eta=0.01), noise=0.05, seed=3)
    clean_c = simulate(m, w, {"2:x": 1.0}, damping=Damping(eta=0.01))
    e = cplx.response / clean_c.response - 1
    assert 0.045 < np.sqrt(np.mean(np.abs(e) ** 2)) < 0.055  # circular: |e| has rms sigma
    assert abs(np.std(e.real) - np.std(e.imag)) < 0.005
    with pytest.raises(InputError, match="noise kind"):
        add_noise(clean, 0.1, "pink")


def test_channels_must_share_one_frequency_axis():
    w = np.linspace(1, 2, 5)
    data = from_channels({"2:x": 1.0}, {"1:x": (w, np.ones(5)), "2:x": (w.copy(), 2 * np.ones(5))})
    assert data.dofs == ("1:x", "2:x") and data.response.shape == (5, 2)
    w2 = w.copy()
    w2[3] += 1e-3
    with pytest.raises(InputError, match=r"channel 2:x: its frequency axis differs from that of channel 1:x \(line 4"):
        from_channels({"2:x": 1.0}, {"1:x": (w, np.ones(5)), "2:x": (w2, np.ones(5))})
    with pytest.raises(InputError, match="channel 2:x.*6 lines against 5"):
        from_channels({"2:x": 1.0}, {"1:x": (w, np.ones(5)), "2:x": (np.linspace(1, 2, 6), np.ones(6))})


def test_bad_frf_input_is_named():
    m = two_dof()
    w = np.array([0.5, 1.0])
    with pytest.raises(InputError, match="lacks: 7:x"):
        frf(m, w, {"7:x": 1.0})
    with pytest.raises(InputError, match="complex"):
        frf(m, np.array([1.0 + 1j]), {"1:x": 1.0})
    lam = model_modes(m).eigenvalues
    with pytest.raises(InputError, match=r"line 2 \(omega = 2.77905 rad/s\).*mode 2"):
        frf(m, [0.5, np.sqrt(lam[1])], {"1:x": 1.0})
    real = FRFData(w, {"2:x": 1.0}, ("1:x",), np.ones((2, 1)))
    cplx = FRFData(w, {"2:x": 1.0}, ("1:x",), np.ones((2, 1)) * (1 + 0.3j))
    with pytest.raises(InputError, match=r"complex \(\|Im\|/\|x\| = 0.29 at 1:x, line 1.*undamped"):
        check_data_against_model(m, cplx, Damping(), "linear")
    with pytest.raises(InputError, match="real but the model is damped"):
        check_data_against_model(m, real, Damping(eta=0.01), "linear")
    with pytest.raises(InputError, match="real but the model is driven by a complex force"):
        check_data_against_model(m, FRFData(w, {"2:x": 1j}, ("1:x",), np.ones((2, 1))), Damping(), "linear")
    check_data_against_model(m, cplx, Damping(), "log")  # magnitudes: fine
    with pytest.raises(InputError, match="lacks: 3:x"):
        check_data_against_model(m, FRFData(w, {"3:x": 1.0}, ("1:x",), np.ones((2, 1))), Damping(), "linear")
    with pytest.raises(InputError, match="damping eta"):
        Damping(eta=-1)


# ------------------------------------------------------------------------------- eq. 32
@pytest.mark.parametrize("method", ["dense", "sparse"])
@pytest.mark.parametrize("damping", [Damping(), Damping(alpha=0.02, beta=2e-4, eta=0.03)])
def test_brandon_equals_central_differences(method, damping):
    m = with_mass_parameter()
    w = np.array([2.0, 7.5, 13.0])
    kw = dict(damping=damping, method=method)
    s = receptance_sensitivity(m, w, ["1:x", "3:x", "5:x"], ["5:x", "2:x"], **kw)
    fd = receptance_fd(m, w, ["1:x", "3:x", "5:x"], ["5:x", "2:x"], rel_step=1e-6, **kw)
    assert s.params == m.parameter_names and s.dalpha.shape == (3, 3, 2, 6)
    np.testing.assert_allclose(s.dalpha, fd, rtol=1e-6, atol=1e-7 * np.abs(fd).max())
    np.testing.assert_allclose(s.alpha, receptance(m, w, ["5:x", "2:x"], ["1:x", "3:x", "5:x"], damping=damping),
                               rtol=1e-12)
    # the thinner side is used for the parameter products: both orders give the same answer
    t = receptance_sensitivity(m, w, ["1:x"], ["5:x", "2:x", "3:x"], **kw)
    np.testing.assert_allclose(t.dalpha[:, 0, :2], s.dalpha[:, 0], rtol=1e-10, atol=1e-14)


def test_parameter_forms_equal_dense_products():
    from femupdate.frf.lines import ParameterForms

    m = with_mass_parameter()  # k1..k5 enter K only, m2 enters M only: empty segments on both sides
    rng = np.random.default_rng(0)
    U, V = rng.standard_normal((5, 3)), rng.standard_normal((5, 2)) + 1j * rng.standard_normal((5, 2))
    ref = np.stack([U.T @ (2.0 * m.dK_dp(j).toarray() - 0.5j * m.dM_dp(j).toarray()) @ V for j in range(6)])
    np.testing.assert_allclose(ParameterForms(m, range(6))(U, V, 2.0, -0.5j), ref, rtol=1e-12, atol=1e-14)
    sub = [5, 0, 3]  # any order of parameters
    np.testing.assert_allclose(ParameterForms(m, sub)(U, V, 2.0, -0.5j), ref[sub], rtol=1e-12, atol=1e-14)


def test_brandon_for_a_force_vector():
    m = three_dof()
    w = np.array([10.0, 35.0])
    s = receptance_sensitivity(m, w, ["1:x", "2:x"], ["3:x", "1:x"])
    x, dx = s.for_force({"3:x": 2.0, "1:x": -1.0})
    fd = receptance_fd(m, w, ["1:x", "2:x"], ["3:x", "1:x"])
    np.testing.assert_allclose(dx, np.einsum("lrej,e->lrj", fd, [2.0, -1.0]), rtol=1e-6)
    with pytest.raises(InputError, match="not among the excitation dofs"):
        s.for_force({"2:x": 1.0})


def test_resonance_distances_dense_and_lanczos_routes_agree(monkeypatch):
    c = chain(np.linspace(100, 200, 40), np.linspace(1, 2, 40))
    w = np.array([0.9, 3.0, 5.5])
    dense = resonances(c, w, params=[0, 10, 39])
    import femupdate.modal

    monkeypatch.setattr(femupdate.modal, "DENSE_LIMIT", 10)  # force the shift-invert search
    lanczos = resonances(c, w, params=[0, 10, 39])
    np.testing.assert_allclose(lanczos.nearest, dense.nearest, rtol=1e-10)
    np.testing.assert_allclose(lanczos.distance, dense.distance, rtol=1e-8)
    np.testing.assert_allclose(lanczos.sensitivity, dense.sensitivity, rtol=1e-7, atol=1e-12)
    s = receptance_sensitivity(c, w, ["40:x"], ["1:x"], params=["k1", "k11", "k40"], method="sparse")
    np.testing.assert_allclose(s.resonances.distance, dense.distance, rtol=1e-8)


def test_relative_eigenvalue_sensitivities_sum_to_one_for_the_two_dof_system():
    r = resonances(two_dof(), [0.5, 2.5], params=[0, 1])
    np.testing.assert_allclose(r.sensitivity.sum(axis=1), 1.0, rtol=1e-12)  # K = k1 K1 + k2 K2, Euler


def test_first_order_error_grows_near_resonance_as_estimated():
    m = two_dof()
    lam2 = model_modes(m).eigenvalues[1]
    d = np.array([0.3, 0.1, 0.03, 0.01])  # relative eigenvalue distance below the second resonance
    w = np.sqrt(lam2 * (1 - d))
    chk = first_order_check(m, w, {"2:x": 1.0}, "k1", delta=1e-3)
    assert np.all(np.diff(chk.error) > 0)  # worse and worse towards the resonance
    np.testing.assert_allclose(chk.distance, d, rtol=1e-10)
    ratio = chk.error[-2:] / chk.estimate[-2:]
    assert np.all((ratio > 0.8) & (ratio < 1.25)), ratio  # delta*s/d predicts it where one mode dominates
    # the derivative itself is exact: central differences with a step well below d agree
    s = receptance_sensitivity(m, w[-1:], None, ["2:x"], resonance_tol=0)
    fd = receptance_fd(m, w[-1:], None, ["2:x"], rel_step=1e-7)
    np.testing.assert_allclose(s.dalpha, fd, rtol=1e-5)


def test_lines_near_resonance_are_reported(caplog):
    m = two_dof()
    lam = model_modes(m).eigenvalues
    w = np.array([0.5, np.sqrt(lam[0]) * (1 + 1e-5)])
    s = receptance_sensitivity(m, w, None, ["1:x"])
    assert s.near_resonance.tolist() == [1]
    assert "line 2" in caplog.text and "mode 1" in caplog.text


# ------------------------------------------------------------------------------- Figure 4 / selection
def test_condition_study_equals_the_direct_updating_matrix():
    m = two_dof()
    st = condition_study(m, {"1:x": 1.0}, [0.3, 0.5], starts=[0.2, 1.0], n_lines=5)
    for i, start in enumerate([0.2, 1.0]):
        for j, dw in enumerate([0.3, 0.5]):
            w = start + dw * np.arange(5)
            data = TestData(frf=simulate(m, w, {"1:x": 1.0}))
            A = build_system(m.with_values([3.0, 2.0]), data).A  # the direct method's X (eq. 28)
            assert st.condition[i, j] == pytest.approx(np.linalg.cond(A), rel=1e-10)
    blocks = direct_blocks(m, [0.7], {"1:x": 1.0})
    x = simulate(m, [0.7], {"1:x": 1.0}).response[0]
    np.testing.assert_allclose(blocks[0], [[x[0], x[0] - x[1]], [0.0, -x[0] + x[1]]], rtol=1e-12)  # eq. 25


def test_figure4_rise_comes_from_the_lowest_line():
    m = two_dof()
    diag = condition_study(m, {"1:x": 1.0}, [0.01, 0.02]).condition[0]
    assert diag[0] / diag[1] == pytest.approx(4.0, rel=0.02)  # k2's column ~ omega^2: cond ~ 1/spacing^2
    fixed = condition_study(m, {"1:x": 1.0}, [0.001, 0.01], starts=[1.0]).condition[0]
    assert fixed.max() < 10  # at a lowest line of 1 rad/s, near-identical lines do no harm
    other = condition_study(m, {"2:x": 1.0}, [0.01]).condition[0, 0]
    assert other < 4  # force at dof 2: k2 is strained statically


def test_selection_finds_the_exhaustive_optimum():
    m = two_dof()
    cand = np.round(np.arange(0.1, 3.01, 0.1), 10)
    sel = select_frequencies(m, cand, 3, {"1:x": 1.0}, margin=0.05, scaled=False)
    blocks = direct_blocks(m, cand, {"1:x": 1.0})
    allowed = [i for i in range(cand.size) if cand[i] not in [e["omega_rad_s"] for e in sel.excluded]]
    best = min(np.linalg.cond(blocks[list(c)].reshape(-1, 2)) for c in itertools.combinations(allowed, 3))
    assert sel.condition_number == pytest.approx(best, rel=1e-9) and sel.method == "exhaustive"
    heuristic = select_frequencies(m, cand, 3, {"1:x": 1.0}, margin=0.05, scaled=False, exhaustive_limit=0)
    assert heuristic.method.startswith("greedy") and heuristic.condition_number == pytest.approx(best, rel=1e-9)
    lam = model_modes(m).eigenvalues
    assert np.all(np.min(np.abs(sel.omega[:, None] ** 2 - lam) / lam, axis=1) >= 0.05)
    assert sel.condition_number <= sel.uniform["condition_number"]
    assert {e["line"] for e in sel.excluded} == {9, 28}  # 0.9 and 2.8 rad/s sit on the resonances


def test_sensitivity_selection_for_incomplete_data():
    m = three_dof()
    lam = model_modes(m).eigenvalues
    cand = np.linspace(5, 1.2 * np.sqrt(lam[-1]), 40)
    sel = select_frequencies(m, cand, 4, {"3:x": 1.0}, kind="sensitivity", response=["3:x"], margin=0.02)
    assert sel.omega.size == 4 and np.isfinite(sel.condition_number)
    assert sel.condition_number <= sel.uniform["condition_number"] * (1 + 1e-12)
    with pytest.raises(InputError, match="equations for 3 unknowns"):
        select_frequencies(m, cand, 2, {"3:x": 1.0}, kind="sensitivity", response=["3:x"])
    with pytest.raises(InputError, match="only 0 of 1 candidate"):
        select_frequencies(m, [np.sqrt(lam[0])], 1, {"3:x": 1.0})


def test_singular_line_gives_inf_blocks_not_an_exception():
    m = two_dof()
    lam = model_modes(m).eigenvalues
    K, M = m.K().toarray(), m.M().toarray()
    w = np.sqrt(lam[0])
    if np.linalg.det(K - w**2 * M) != 0:  # rounding: make it exact with a model whose resonance is exactly 1
        s = Structure("unit")
        s.parameter("k", 1.0, (0.1, 10))
        s.spring(["1:x"], k="k")
        s.mass(["1:x"], m=1.0)
        m, w = s.build(), 1.0
    assert np.all(np.isinf(direct_blocks(m, [w], {"1:x": 1.0})))
    with pytest.raises((NumericalError, InputError)):
        receptance(m, [w], ["1:x"])
