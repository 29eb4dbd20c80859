"""Matrices as commercial FE codes export them: massless (rotational) dofs, and rigid links
modelled as penalty springs.

References: SciPy's QZ generalised eigenvalues of the full singular pencil (an independent route
that never condenses), central finite differences of the update Jacobian, and closed-form
frequencies of a spring-mass system.
"""

import numpy as np
import pytest
import scipy.linalg as sla

from femupdate import InputError, MeasuredMode, Parameter, Structure, TestData, model_modes, rules, solve_modes, update
from femupdate.model import from_matrices
from femupdate.updating import Problem, multistart

E = (2.1e11, 1.8e11, 2.4e11)


def frame_without_rotational_mass():
    """A 12-element cantilever in three modulus groups whose exported mass matrix has no
    rotational inertia (the rows of the rz dofs are zero), as from_matrices receives it."""
    s = Structure("cantilever")
    n_el = 12
    x = np.linspace(0.0, 2.4, n_el + 1)
    s.add_nodes(range(n_el + 1), np.c_[x, 0 * x])
    for g, value in enumerate(E):
        s.parameter(f"E{g + 1}", value, (0.3 * value, 3 * value))
    for e in range(n_el):
        s.beam2d((e, e + 1), E=f"E{e // 4 + 1}", A=1e-3, I=8.33e-8, rho=7850.0, mass="lumped")
    s.support_node([0])
    m = s.build()
    L = len(m.parameter_names)
    K0 = m.K(np.zeros(L)).toarray()
    dK = [m.K(np.eye(L)[j]).toarray() - K0 for j in range(L)]
    M = m.M(m.values).toarray()
    rot = np.array([d.endswith("rz") for d in m.dofs])
    M[rot, :] = 0.0
    M[:, rot] = 0.0
    params = [Parameter(n, v, (0.3 * v, 3 * v)) for n, v in zip(m.parameter_names, m.values)]
    return from_matrices(m.dofs, K0, M, params, dK=dK, name="exported cantilever"), rot


def qz_frequencies(K, M, n):
    w = sla.eig(K, M, right=False)
    w = np.sort(w.real[np.isfinite(w) & (np.abs(w) < 1e30)])
    return w[:n]


def test_massless_dofs_give_the_finite_eigenvalues_of_the_singular_pencil():
    model, rot = frame_without_rotational_mass()
    modes = model_modes(model)
    assert modes.n_modes == int((~rot).sum())  # one finite mode per dof with mass
    K, M = model.K(model.values).toarray(), model.M(model.values).toarray()
    np.testing.assert_allclose(modes.eigenvalues[:6], qz_frequencies(K, M, 6), rtol=1e-9)
    # mass-normalised on the full dofs, and satisfying the full pencil's equation
    Phi = modes.shapes
    np.testing.assert_allclose(Phi.T @ M @ Phi, np.eye(Phi.shape[1]), atol=1e-9)
    np.testing.assert_allclose(K @ Phi[:, :6], M @ Phi[:, :6] * modes.eigenvalues[:6], atol=1e-6 * np.abs(K).max())
    sparse = solve_modes(model.K(model.values), model.M(model.values), n_modes=6, dofs=model.dofs, method="sparse")
    np.testing.assert_allclose(sparse.eigenvalues, modes.eigenvalues[:6], rtol=1e-9)


def test_a_model_with_massless_dofs_updates_without_hand_made_changes():
    model, rot = frame_without_rotational_mass()
    truth = np.array(E) * np.array([1.15, 0.9, 1.05])
    tm = model_modes(model, truth)
    sensors = [i for i, d in enumerate(model.dofs) if d.endswith(":y")][1::2]
    data = TestData(modes=tuple(MeasuredMode(tm.eigenvalues[j], tuple(model.dofs[i] for i in sensors),
                                             tm.shapes[sensors, j]) for j in range(4)))
    prob = Problem(model, data)
    x = prob.x_start
    J = prob.jacobian(x)
    # the beam's spectrum spans 4e6: eigenvalue round-off makes central differences noisy below
    # h = 1e-4 (their error grows as 1/h), so h = 1e-3, where truncation (h²) leaves about 2e-7
    h = 1e-3
    fd = np.column_stack([(prob.residuals(x + h * e) - prob.residuals(x - h * e)) / (2 * h) for e in np.eye(x.size)])
    assert np.abs(J - fd).max() <= 1e-5 * np.abs(J).max()
    res = update(model, data)
    assert res.success
    np.testing.assert_allclose(res.x, truth, rtol=1e-7)
    ms = multistart(model, data, starts=4, seed=0)  # the compiled route needs a definite M: per start
    assert ms.converged == 4 and type(ms.runs[0]).__name__ == "UpdateResult"
    np.testing.assert_allclose(ms.best.x, truth, rtol=1e-7)


def test_massless_dofs_without_stiffness_are_refused_by_name():
    K = np.diag([2.0, 1.0, 0.0])
    M = np.diag([1.0, 1.0, 0.0])
    with pytest.raises(InputError, match="massless dof.*3:x.*not held"):
        solve_modes(K, M, dofs=("1:x", "2:x", "3:x"))
    with pytest.raises(InputError, match="no positive mass at dof.*2:x"):
        solve_modes(np.eye(2), np.array([[1.0, 0.5], [0.5, 0.0]]), dofs=("1:x", "2:x"))


@pytest.mark.parametrize("penalty", [1e8, 1e10])
def test_a_penalty_link_does_not_turn_the_first_mode_into_a_rigid_body_mode(penalty):
    """Ground spring k, mass m1, linked rigidly (penalty) to a nearly massless point m2: the first
    mode is sqrt(k / (m1 + m2)), not 0 Hz."""
    k, m1, m2 = 1e4, 10.0, 1e-8
    K = np.array([[k + penalty, -penalty], [-penalty, penalty]])
    M = np.diag([m1, m2])
    modes = solve_modes(K, M, dofs=("1:x", "2:x"))
    assert modes.n_rigid == 0
    assert modes.eigenvalues[0] == pytest.approx(k / (m1 + m2), rel=1e-5)
    free = np.array([[penalty, -penalty], [-penalty, penalty]])  # no ground spring: truly rigid
    rigid = solve_modes(free, M, dofs=("1:x", "2:x"))
    assert rigid.n_rigid == 1 and rigid.eigenvalues[0] == 0.0


@pytest.mark.parametrize("penalty", [1e8, 1e10])
def test_the_compiled_route_tells_a_penalty_linked_mode_from_a_rigid_body_mode(penalty):
    """A chain k1 - m1 = (penalty link) = m2 - k2 - m3 with a nearly massless m2, updated by
    multi-start on the compiled route: its first mode is elastic.  The pencil-scale test (max
    K_ii / M_ii = penalty / m2) called it a rigid-body mode, and every start failed ("mode 1 is a
    rigid-body mode").  Now both routes compute the same eigenvalues and every start runs."""
    from femupdate.updating.batched import BatchedProblem

    k1, k2, m = 1e4, 2e4, (10.0, 1e-8, 5.0)
    dofs = ("1:x", "2:x", "3:x")
    link = np.zeros((3, 3))
    link[np.ix_([0, 1], [0, 1])] = [[penalty, -penalty], [-penalty, penalty]]
    dK1 = np.zeros((3, 3))
    dK1[0, 0] = 1.0
    dK2 = np.zeros((3, 3))
    dK2[np.ix_([1, 2], [1, 2])] = [[1.0, -1.0], [-1.0, 1.0]]
    model = from_matrices(dofs, link, np.diag(m), [Parameter("k1", k1, (1e3, 1e5)), Parameter("k2", k2, (1e3, 1e5))],
                          dK=[dK1, dK2])
    mm = model_modes(model)
    assert mm.n_rigid == 0 and mm.eigenvalues[0] > 0
    assert max(abs(np.diag(link + k1 * dK1 + k2 * dK2)) / m) * rules.RIGID_TOL > mm.eigenvalues[0]  # the old test's trap
    data = TestData(modes=tuple(MeasuredMode(mm.eigenvalues[j], ["1:x", "3:x"], mm.shapes[[0, 2], j]) for j in range(2)))
    starts = np.array([[2e4, 1e4], [5e3, 4e4], [1.2e4, 2.2e4]])
    bp = BatchedProblem.from_problem(Problem(model, data), starts)
    ev = bp.evaluate(bp.x_start, np.arange(3))
    for r in range(3):
        local = model_modes(model, dict(zip(model.parameter_names, starts[r])))
        assert ev.messages[r] is None
        assert ev.eigenvalues[r, 0] > 0
        # the same pencil reduced the same way (Cholesky of the diagonal M): the same eigenvalues
        np.testing.assert_allclose(ev.eigenvalues[r, :2], local.eigenvalues[:2], rtol=1e-9)
    a = multistart(model, data, starts=6, seed=2, batched=True)
    assert a.converged == 6 and not a.failures
