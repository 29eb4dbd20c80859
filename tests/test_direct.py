import numpy as np
import pytest

from femupdate import FRFData, InputError, MeasuredMode, StaticData, Structure, TestData, from_matrices, model_modes
from femupdate.direct import direct_update
from femupdate.examples import three_dof, two_dof
from femupdate.paper.direct_sections import paper_phi_matrix

from conftest import spring_chain


def _modes(model, which, values=None, scale=1.0):
    mm = model_modes(model, values)
    return tuple(MeasuredMode(mm.eigenvalues[r], model.dofs, mm.shapes[:, r] * scale) for r in which)


def test_one_mode_recovers_three_springs_eq5():
    truth = three_dof()
    start = truth.with_values([1.0, 1.0, 1.0])
    for r in range(3):
        res = direct_update(start, TestData(modes=_modes(truth, [r], scale=-7.3)))
        np.testing.assert_allclose(res.x, truth.values, rtol=1e-10)
        assert res.unique and res.rank == 3
        # the stacked rows are the paper's eq. (4) matrix Phi_i for the unit-length shape
        phi = model_modes(truth).shapes[:, r]
        phi = -phi / np.linalg.norm(phi)
        np.testing.assert_allclose(res.system.A, paper_phi_matrix(phi), atol=1e-12)


def test_figure2_needs_two_modes():
    truth = three_dof(k4=500.0)
    start = truth.with_values(np.ones(4))
    with pytest.raises(InputError, match=r"4 unknown parameters but only 3 equations.*at least 2"):
        direct_update(start, TestData(modes=_modes(truth, [0])))
    res = direct_update(start, TestData(modes=_modes(truth, [0, 2])))
    np.testing.assert_allclose(res.x, truth.values, rtol=1e-10)
    assert res.residual_norm < 1e-10 * np.linalg.norm(res.system.b)


def test_frf_direct_eq29():
    truth = two_dof()
    K, M = truth.K().toarray(), truth.M().toarray()
    omega = np.array([0.3, 0.9, 1.4, 2.2, 3.1])
    f = np.array([0.0, 1.0])
    X = np.array([np.linalg.solve(K - w**2 * M, f) for w in omega])
    res = direct_update(truth.with_values([1.0, 1.0]), TestData(frf=FRFData(omega, {"2:x": 1.0}, truth.dofs, X)))
    np.testing.assert_allclose(res.x, [8.0, 6.0], rtol=1e-10)
    # complex data (e.g. phase-rotated by the acquisition) give real and imaginary equations
    Xc = X * np.exp(0.3j)
    res = direct_update(truth.with_values([1.0, 1.0]),
                        TestData(frf=FRFData(omega, {"2:x": np.exp(0.3j)}, truth.dofs, Xc)))
    np.testing.assert_allclose(res.x, [8.0, 6.0], rtol=1e-10)
    assert res.system.n_equations == 2 * 2 * len(omega)


def test_static_direct_lallement():
    truth = three_dof()
    u = np.linalg.solve(truth.K().toarray(), [0.0, 0.0, 5.0])
    res = direct_update(truth.with_values(np.ones(3)), TestData(static=(StaticData({"3:x": 5.0}, truth.dofs, u),)))
    np.testing.assert_allclose(res.x, truth.values, rtol=1e-12)


def test_all_kinds_stacked_and_mass_parameter():
    s = spring_chain([100.0, 200.0], [1.0, 2.0])
    s.parameter("m2", 2.0, (0.1, 10.0))
    s.mass(["2:x"], m="m2")  # the parameter adds to the 2.0 kg already there
    truth = s.build()
    start = truth.with_values([50.0, 50.0, 1.0])
    res = direct_update(start, TestData(modes=_modes(truth, [0, 1])))
    np.testing.assert_allclose(res.x, truth.values, rtol=1e-10)


def test_noisy_closed_loop_and_standard_error(rng):
    k = np.array([1000.0, 1800.0, 1500.0, 1200.0, 900.0, 1600.0])
    truth = spring_chain(k, [1.0, 1.2, 0.8, 1.1, 0.9, 1.0]).build()
    mm = model_modes(truth, normalisation="max")
    errors, ses = [], []
    for trial in range(40):
        modes = tuple(MeasuredMode(mm.eigenvalues[r], truth.dofs, mm.shapes[:, r] + 0.002 * rng.standard_normal(6))
                      for r in range(6))
        res = direct_update(truth.with_values(np.ones(6)), TestData(modes=modes))
        errors.append(res.x - k)
        ses.append(res.standard_error)
    errors, ses = np.array(errors), np.array(ses)
    assert np.max(np.abs(errors) / k) < 0.05  # 0.2 % shape noise -> a few per cent at worst
    # the standard error is the right order of magnitude (noise in the shapes is errors-in-variables)
    ratio = np.std(errors, axis=0) / np.mean(ses, axis=0)
    assert np.all((ratio > 0.3) & (ratio < 3.0))


def test_bounds_are_honoured():
    truth = three_dof()
    s = Structure("bounded")
    for i, v in enumerate(truth.values, start=1):
        s.parameter(f"k{i}", 1.0, (0.0, 900.0) if i == 1 else (0.0, 1e5))
    s.spring(["1:x"], k="k1"); s.spring(["1:x", "2:x"], k="k2"); s.spring(["2:x", "3:x"], k="k3")
    for i, m in enumerate((1.0, 1.5, 2.0), start=1):
        s.mass([f"{i}:x"], m=m)
    res = direct_update(s.build(), TestData(modes=_modes(truth, [0, 1, 2])), bounded=True)
    assert res.x[0] == pytest.approx(900.0)
    assert res.bounded and np.all(res.x >= 0)


def test_rank_deficiency_is_reported():
    # two springs between the same dofs cannot be told apart: k2a + k2b is all the data see
    s = spring_chain([100.0], [1.0])
    s.parameter("k2a", 50.0, (0, 1e3)); s.parameter("k2b", 70.0, (0, 1e3))
    s.spring(["1:x", "2:x"], k="k2a"); s.spring(["1:x", "2:x"], k="k2b"); s.mass(["2:x"], m=1.0)
    truth = s.build()
    res = direct_update(truth.with_values([1.0, 1.0, 1.0]), TestData(modes=_modes(truth, [0, 1])))
    assert not res.unique and res.rank == 2
    v = res.null_space[:, 0]
    np.testing.assert_allclose(np.abs(v), [0.0, 1 / np.sqrt(2), 1 / np.sqrt(2)], atol=1e-8)
    assert res.x[1] + res.x[2] == pytest.approx(120.0)
    assert "not unique" in res.notes[-1] and "k2a" in res.notes[-1]


def test_missing_and_unknown_dofs_named():
    truth = three_dof()
    mm = model_modes(truth)
    with pytest.raises(InputError, match=r"missing 1 of 3: 2:x"):
        direct_update(truth, TestData(modes=(MeasuredMode(mm.eigenvalues[0], ["1:x", "3:x"], mm.shapes[[0, 2], 0]),)))
    with pytest.raises(InputError, match=r"not in the model: 7:x"):
        direct_update(truth, TestData(modes=(MeasuredMode(mm.eigenvalues[0], ["1:x", "2:x", "3:x", "7:x"], [1, 2, 3, 4.0]),)))
    with pytest.raises(InputError, match=r"force applied at dof\(s\) not in the model: 4:y"):
        direct_update(truth, TestData(static=(StaticData({"4:y": 1.0}, truth.dofs, [1.0, 2.0, 3.0]),)))


def test_homogeneous_system_refused():
    s = Structure("all unknown")
    for name in ("k1", "k2", "m1", "m2"):
        s.parameter(name, 1.0, (0.1, 1e3))
    s.spring(["1:x"], k="k1"); s.spring(["1:x", "2:x"], k="k2")
    s.mass(["1:x"], m="m1"); s.mass(["2:x"], m="m2")
    model = s.build()
    with pytest.raises(InputError, match="homogeneous"):
        direct_update(model, TestData(modes=_modes(model, [0, 1])))


def test_beam_physical_terms_from_complete_modes():
    """Appendix 1: the independent terms EA/l, 12EI/l^3, 6EI/l^2, 2EI/l of each member."""
    from femupdate.elements import physical_terms_of_frame

    n_el, L = 3, 1.2
    E, A, I, rho = 7.0e10, 2e-4, 3e-9, 2700.0
    le = L / n_el
    terms = physical_terms_of_frame(E, 1.0, A, I, I, 1.0, le)
    s = Structure("physical beam")
    x = np.linspace(0, L, n_el + 1)
    s.add_nodes(range(n_el + 1), np.c_[x, 0 * x])
    for e in range(n_el):
        names = {}
        for key, tk in (("EA_l", "EA_l"), ("k12", "k12_z"), ("k6", "k6_z"), ("k2", "k2_z")):
            # true values differ member by member (a 'damaged' middle member)
            s.parameter(f"{key}_{e}", float(terms[tk]) * (0.7 if e == 1 else 1.0), (0, np.inf))
            names[key] = f"{key}_{e}"
        s.beam2d_terms([e, e + 1], rho=rho, A=A, **names)
    s.support_node([0])
    truth = s.build()
    start = truth.with_values(truth.values * 1.3)
    # the lowest modes are pure bending: they carry no information on the axial terms
    with pytest.raises(InputError, match=r"no information on parameter\(s\) EA_l_0, EA_l_1, EA_l_2"):
        direct_update(start, TestData(modes=_modes(truth, [0, 1, 2])))
    bending = start.with_fixed([f"EA_l_{e}" for e in range(n_el)])
    one = direct_update(bending, TestData(modes=_modes(truth, [0])))
    assert not one.unique  # 9 equations, but the 3 axial rows are empty: rank 6 < 9
    res = direct_update(bending, TestData(modes=_modes(truth, [0, 1, 2])))
    assert res.unique
    np.testing.assert_allclose(res.x, truth.values[[j for j, n in enumerate(truth.parameter_names) if not n.startswith("EA")]], rtol=1e-7)


def test_frame3d_grouped_modulus_from_matrices_model():
    s = Structure("frame")
    s.parameter("E", 2.1e11, (1e10, 1e12))
    pts = np.array([[0, 0, 0], [0, 0, 1.0], [1.0, 0, 1.0], [1.0, 0.5, 1.0]])
    s.add_nodes(range(4), pts)
    s.frame3d([[0, 1], [1, 2], [2, 3]], E="E", G=8e10, A=1e-3, Iy=2e-7, Iz=3e-7, J=4e-7, rho=7850.0,
              orientation=[0.3, 1.0, 0.2])
    s.support_node([0])
    truth = s.build()
    # the same model as plain matrices: K0, M0 and dK/dE (how exported models come in)
    mat = from_matrices(truth.dofs, truth.K0, truth.M0, truth.parameters, truth.dK, truth.dM)
    res = direct_update(mat.with_values([1e11]), TestData(modes=_modes(truth, [0])))
    assert res.x[0] == pytest.approx(2.1e11, rel=1e-9)
