import numpy as np

from femupdate import MeasuredMode, TestData, model_modes
from femupdate.correlation import comac, correlate, mac, pair_modes
from femupdate.examples import three_dof


def test_mac_basic(rng):
    A = rng.standard_normal((6, 3))
    np.testing.assert_allclose(np.diag(mac(A, A)), 1.0)
    np.testing.assert_allclose(mac(A, A * [2.0, -3.0, 0.5]), mac(A, A))  # scaling-independent
    Q, _ = np.linalg.qr(A)
    np.testing.assert_allclose(mac(Q, Q), np.eye(3), atol=1e-14)
    # complex: a complex multiple is the same shape
    np.testing.assert_allclose(mac(A[:, :1] * (1 + 2j), A[:, :1]), [[1.0]])


def test_pairing_is_an_assignment_not_greedy():
    m = np.array([[0.9, 0.8], [0.85, 0.1]])
    # greedy would pair (0,0) then (1,1) for a total of 1.0; the optimum is (0,1)+(1,0) = 1.65
    assert pair_modes(m, min_mac=0.0) == [(0, 1, 0.8), (1, 0, 0.85)]
    assert pair_modes(m, min_mac=0.82) == [(1, 0, 0.85)]


def test_correlate_by_label_and_swapped_order():
    model = three_dof()
    mm = model_modes(model)
    # test lists dofs in another order and modes 2 and 1 swapped
    order = [2, 0, 1]
    dofs = [model.dofs[i] for i in order]
    modes = tuple(MeasuredMode(mm.eigenvalues[r], dofs, mm.shapes[order, r] * 5.0) for r in (1, 0))
    corr = correlate(TestData(modes=modes), mm)
    assert [(i, j) for i, j, _ in corr.pairs] == [(0, 1), (1, 0)]
    np.testing.assert_allclose([m for *_, m in corr.pairs], 1.0)
    np.testing.assert_allclose(corr.frequency_error, 0.0, atol=1e-12)
    np.testing.assert_allclose(corr.comac, 1.0)


def test_comac_flags_a_bad_dof(rng):
    A = rng.standard_normal((30, 4))
    B = A.copy()
    B[7] = A[7] * [3.0, 0.1, 1.0, 0.05]  # a sensor whose amplitude does not follow the modes
    c = comac(A, B)
    assert np.argmin(c) == 7 and c[7] < 0.7
    # the bad row also shifts each mode's scale factor a little, so the others stay just below 1
    assert np.all(np.delete(c, 7) > 0.9)
    np.testing.assert_allclose(comac(A, A * [3.0, -1.0, 2.0, 0.5]), 1.0)


def test_low_mac_leaves_test_mode_unpaired():
    model = three_dof()
    mm = model_modes(model)
    bogus = MeasuredMode(10.0, model.dofs, np.array([1.0, 0.0, 0.0]))
    corr = correlate(TestData(modes=(bogus,)), mm, min_mac=0.95, pairing="mac")
    assert corr.pairs == [] and corr.unpaired_test == [0]
    # the default pairs it as update does (by order) and says the shapes do not confirm the pair
    corr = correlate(TestData(modes=(bogus,)), mm, min_mac=0.95)
    assert [p[:2] for p in corr.pairs] == [(0, 0)] and corr.unconfirmed == [0] and corr.unpaired_test == []


def test_correlate_and_update_pair_alike_a_mode_measured_at_fewer_dofs():
    """A test mode measured at fewer dofs than the others was left unpaired by correlate (its MAC
    was taken on the union of the dofs) while update paired it: now both pair it the same way."""
    from femupdate import update

    model = three_dof()
    mm = model_modes(model)
    data = TestData(modes=(MeasuredMode(mm.eigenvalues[0], model.dofs, mm.shapes[:, 0]),
                           MeasuredMode(mm.eigenvalues[1], model.dofs[:2], mm.shapes[:2, 1]),
                           MeasuredMode(mm.eigenvalues[2], model.dofs, mm.shapes[:, 2])))
    corr = correlate(data, mm)
    res = update(model, data, max_nfev=1)
    assert corr.unpaired_test == [] and [p[:2] for p in corr.pairs] == [p[:2] for p in res.pairs]
    np.testing.assert_allclose([p[2] for p in corr.pairs], [p[2] for p in res.pairs], rtol=1e-12)
