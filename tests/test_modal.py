import numpy as np
import pytest
import scipy.sparse as sp

from femupdate import InputError, NumericalError, model_modes, normalise, solve_modes
from femupdate.examples import chain, two_dof

from conftest import cantilever_beam2d


def test_two_dof_closed_form():
    # det(K - lam M) = 8 lam^2 - 68 lam + 48 (paper eq. 11 with m1=2, m2=4, k1=8, k2=6)
    modes = model_modes(two_dof())
    expected = np.sort(np.roots([8.0, -68.0, 48.0]))
    np.testing.assert_allclose(modes.eigenvalues, expected, rtol=1e-13)
    np.testing.assert_allclose(modes.frequencies_hz, np.sqrt(expected) / (2 * np.pi), rtol=1e-13)


@pytest.mark.parametrize("method", ["dense", "sparse"])
def test_invariants(method):
    model = cantilever_beam2d(n_el=30).build()
    K, M = model.K(), model.M()
    res = model_modes(model, n_modes=6, method=method)
    Phi, lam = res.shapes, res.eigenvalues
    resid = K @ Phi - (M @ Phi) * lam
    eps = np.finfo(float).eps
    normK = sp.linalg.norm(K, 1)
    assert np.max(np.linalg.norm(resid, axis=0) / (normK * np.linalg.norm(Phi, axis=0))) < 1e4 * eps
    np.testing.assert_allclose(Phi.T @ (M @ Phi), np.eye(6), atol=1e-10)


def test_dense_and_sparse_agree():
    model = chain(np.linspace(1e3, 3e3, 2000), np.linspace(1.0, 2.0, 2000))
    dense = model_modes(model, n_modes=5, method="dense")
    sparse = model_modes(model, n_modes=5, method="sparse")
    np.testing.assert_allclose(sparse.eigenvalues, dense.eigenvalues, rtol=1e-9)
    # same shapes up to the (fixed) sign convention
    np.testing.assert_allclose(np.abs(np.sum(sparse.shapes * (model.M() @ dense.shapes), axis=0)), 1.0, atol=1e-8)


def test_auto_method_switches_by_size():
    model = chain(np.full(3000, 1e3), np.ones(3000))
    res = model_modes(model, n_modes=3)  # auto -> sparse shift-invert
    # closed form for a uniform grounded chain with free end: lam_r = 4k/m sin^2((2r-1) pi / (2(2N+1)))
    n = 3000
    r = np.arange(1, 4)
    expected = 4e3 * np.sin((2 * r - 1) * np.pi / (2 * (2 * n + 1))) ** 2
    np.testing.assert_allclose(res.eigenvalues, expected, rtol=1e-8)


@pytest.mark.parametrize("method", ["dense", "sparse"])
def test_free_free_rigid_modes(method):
    s = cantilever_beam2d(n_el=40)
    s.support_nodes.clear()
    res = model_modes(s.build(), n_modes=6, method=method)
    assert res.n_rigid == 3
    np.testing.assert_array_equal(res.eigenvalues[:3], 0.0)
    EI, mA = 2.1e11 * 8.33e-8, 7850 * 1e-3
    beta = (np.sqrt(res.eigenvalues[3:5]) / np.sqrt(EI / mA)) ** 0.5
    np.testing.assert_allclose(beta, [4.730041, 7.853205], rtol=2e-5)


def test_normalisations():
    model = two_dof()
    M = model.M().toarray()
    unit = model_modes(model, normalisation="unit").shapes
    np.testing.assert_allclose(np.linalg.norm(unit, axis=0), 1.0)
    mx = model_modes(model, normalisation="max").shapes
    np.testing.assert_allclose(np.max(np.abs(mx), axis=0), 1.0)
    assert np.all(mx.max(axis=0) == 1.0)  # largest entry is +1
    ref = model_modes(model, normalisation="ref:1:x").shapes
    np.testing.assert_allclose(ref[0], 1.0)
    mass = model_modes(model).shapes
    # all four are the same vectors up to scale
    for other in (unit, mx, ref):
        assert np.allclose(np.abs(np.sum(other * mass, 0)) / (np.linalg.norm(other, axis=0) * np.linalg.norm(mass, axis=0)), 1)
    np.testing.assert_allclose(mass.T @ M @ mass, np.eye(2), atol=1e-12)


def test_reference_at_a_node_is_refused():
    # mode 2 of a symmetric 3-dof chain with free ends has a node at the middle dof
    K = np.array([[1.0, -1, 0], [-1, 2, -1], [0, -1, 1]])
    with pytest.raises(NumericalError, match="node"):
        normalise(solve_modes(K, np.eye(3), normalisation="unit").shapes, "ref:2:x", dofs=("1:x", "2:x", "3:x"))


def test_bad_input():
    K = np.array([[2.0, -1], [-1, 1]])
    # a massless dof is condensed (it used to be refused): K~ = 2 - 1 = 1 with m = 1, φ = (1, 1)
    massless = solve_modes(K, np.diag([1.0, 0.0]), dofs=("1:x", "2:x"))
    np.testing.assert_allclose(massless.eigenvalues, [1.0], rtol=1e-14)
    np.testing.assert_allclose(np.abs(massless.shapes[:, 0]), [1.0, 1.0], rtol=1e-14)
    with pytest.raises(InputError, match="no positive mass at dof"):
        solve_modes(K, np.array([[1.0, 0.2], [0.2, 0.0]]), dofs=("1:x", "2:x"))
    with pytest.raises(InputError, match=r"negative mass at dof\(s\) 2:x \(diagonal -4\)"):
        solve_modes(K, np.diag([2.0, -4.0]), dofs=("1:x", "2:x"))
    with pytest.raises(InputError, match="not positive semi-definite"):
        solve_modes(-K, np.eye(2))
    with pytest.raises(InputError, match="n_modes"):
        solve_modes(K, np.eye(2), n_modes=3)
    with pytest.raises(InputError, match="unknown normalisation"):
        solve_modes(K, np.eye(2), normalisation="foo")
    with pytest.raises(InputError, match="not in the model"):
        solve_modes(K, np.eye(2), dofs=("1:x", "2:x"), normalisation="ref:3:x")


def test_modes_at_labels():
    res = model_modes(two_dof())
    np.testing.assert_array_equal(res.at(["2:x", "1:x"]), res.shapes[::-1])
    with pytest.raises(InputError, match="9:x"):
        res.at(["9:x"])


def test_sparse_factor_pivots_off_the_diagonal_when_it_must():
    """Symmetric mode prefers diagonal pivots; indefinite matrices with tiny or zero diagonal
    entries (K - w^2 M between resonances, Nelson's bordered matrix) must still solve accurately."""
    from femupdate.modal import factorize

    rng = np.random.default_rng(3)
    for A in (np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 2.0], [0.0, 2.0, 1e-14]]),
              np.array([[1e-13, 1.0, 0.0], [1.0, 1.0, 2.0], [0.0, 2.0, 3.0]])):  # a tiny pivot ruins accuracy
        b = np.array([1.0, 2.0, 3.0])
        assert np.allclose(factorize(sp.csc_array(A)).solve(b), np.linalg.solve(A, b), rtol=1e-12, atol=0)
    n = 60  # a chain K - w^2 M with w^2 between the 10th and 11th eigenvalue: indefinite
    K = sp.diags_array([2.0 * np.ones(n), -np.ones(n - 1), -np.ones(n - 1)], offsets=[0, 1, -1]).toarray()
    lam = np.linalg.eigvalsh(K)
    Z = K - 0.5 * (lam[9] + lam[10]) * np.eye(n)
    b = rng.standard_normal(n)
    x = factorize(sp.csc_array(Z)).solve(b)
    assert np.linalg.norm(Z @ x - b) <= 1e-12 * np.linalg.norm(b) * np.linalg.cond(Z)


def test_sign_convention_is_stable_for_antisymmetric_shapes():
    """Entries of equal magnitude and opposite sign, perturbed by round-off either way, must not
    flip the sign chosen (the eigensolvers' round-off differs)."""
    from femupdate.modal import _sign_fix

    a = np.array([[0.5], [1.0 + 1e-13], [-1.0], [0.2]])
    b = np.array([[0.5], [1.0], [-1.0 - 1e-13], [0.2]])
    np.testing.assert_array_equal(_sign_fix(a) > 0, _sign_fix(b) > 0)
    np.testing.assert_array_equal(_sign_fix(-b), _sign_fix(b))


def test_the_eigensolver_path_follows_the_cost_rule():
    """modal.eigensolver_for: every mode (or the default number) dense up to DENSE_LIMIT; a few
    modes of a model from SPARSE_FROM dofs sparse; the dense and sparse paths agree."""
    from femupdate.generators import frame_lattice
    from femupdate.modal import DENSE_LIMIT, SPARSE_FROM, eigensolver_for

    assert eigensolver_for(DENSE_LIMIT, None) == "dense" and eigensolver_for(DENSE_LIMIT + 1, None) == "sparse"
    assert eigensolver_for(SPARSE_FROM - 1, 10) == "dense" and eigensolver_for(SPARSE_FROM, 10) == "sparse"
    assert eigensolver_for(1000, 201) == "dense" and eigensolver_for(1000, 200) == "sparse"  # a fifth of the modes
    assert eigensolver_for(5000, 4999) == "dense"  # n - 1 modes: only the dense solver gives them
    m = frame_lattice(2, 2, 20).build()  # 456 dofs
    sparse = model_modes(m, n_modes=8)
    assert sparse.factor is not None and sparse.solver.startswith("sparse")
    dense = model_modes(m, n_modes=8, method="dense")
    assert dense.factor is None and dense.solver == "dense (LAPACK)"
    np.testing.assert_allclose(sparse.eigenvalues, dense.eigenvalues, rtol=1e-10)
