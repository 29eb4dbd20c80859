"""Derivatives of repeated and close modes (femupdate.sensitivity.repeated, the ``groups`` of
every route), against independent references: closed forms, central differences of quantities
that do not depend on the arbitrary basis (the eigenvalues as a sorted set, the projector
P = ΦΦᵀM), central differences along the branches of a split eigenvalue."""

from __future__ import annotations

import math

import numpy as np
import pytest

from femupdate import InputError, NumericalError, model_modes, rules
from femupdate.generators import frame_lattice
from femupdate.model import Parameter, from_matrices
from femupdate.options import ModalOptions
from femupdate.sensitivity import adjoint, eigenvalue_derivatives, jacobian, modal, nelson, subspace
from femupdate.sensitivity.repeated import (adjacent_eigenvectors, group_finite_difference, mode_groups,
                                            restricted_derivatives)


def rel(a, b):
    return float(np.max(np.abs(a - b)) / np.max(np.abs(b)))


def square_frame(parameters="storey_mass"):
    """A 2x2-bay, 2-storey space frame on a square plan: its bending modes come in exact pairs."""
    model = frame_lattice(3, 3, 3, parameters=parameters).build()
    return model, model.values * np.linspace(0.8, 1.2, len(model.parameters))


# ------------------------------------------------------------------------------- groups
def test_group_bounds_chain_neighbours_and_skip_rigid_modes():
    lam = np.array([0.0, 0.0, 1.0, 1.0 + 1e-9, 1.0 + 2e-9, 2.0, 2.001, 5.0])
    assert mode_groups(lam, 1e-8) == [(2, 5)]  # the rigid-body zeros join no group
    assert mode_groups(lam, 1e-3) == [(2, 5), (5, 7)]
    assert mode_groups(lam, 0.0) == []
    assert tuple(map(int, rules.group_bounds(lam, lam.size, 3, 1e-8))) == (2, 5)
    assert tuple(map(int, rules.group_bounds(lam, 5, 4, 1e-8))) == (2, 5)  # only the computed modes
    assert tuple(map(int, rules.group_bounds(lam, lam.size, 0, 1e-2))) == (0, 1)
    with pytest.raises(InputError, match="relative gap"):
        mode_groups(lam, 1.5)


def test_close_modes_option_default_and_check():
    assert ModalOptions().close_modes == rules.CLOSE_TOL == 0.01
    for bad in (-1e-3, 0.1, float("nan"), "0.01"):
        with pytest.raises(InputError, match="close_modes"):
            ModalOptions(close_modes=bad)


# ------------------------------------------------------------------------------- restricted eigenproblem
def test_restricted_derivatives_against_differences_of_the_sorted_eigenvalues():
    """Symmetric parameters keep each pair repeated: the pair's eigenvalues, as a sorted set, are
    then differentiable, and D = λ' I (Mills-Curran, Dailey)."""
    model, p = square_frame()
    modes = model_modes(model, p, n_modes=12)
    groups = mode_groups(modes.eigenvalues, 1e-8)
    assert len(groups) >= 3 and all(b - a == 2 for a, b in groups)
    for g in groups[:3]:
        D = restricted_derivatives(model, modes, g)
        dB, dA, dlam = group_finite_difference(model, g, p, base=modes, rel_step=1e-4)
        assert rel(D, dA) < 1e-6  # the restricted stiffness BᵀKB by differences
        for j in range(D.shape[2]):
            np.testing.assert_allclose(np.linalg.eigvalsh(D[:, :, j]), dlam[:, j], rtol=1e-6,
                                       atol=1e-6 * np.abs(dlam).max())
            assert abs(D[0, 1, j]) < 1e-8 * np.abs(D[:, :, j]).max()  # D = λ' I


def test_split_eigenvalues_have_directional_derivatives_the_eigenvalues_of_D():
    """Breaking the square (E_x != E_y) splits each pair: the sorted eigenvalues are only
    directionally differentiable, their one-sided differences along +d and -d are the sorted
    eigenvalues of D·d and of -D·d."""
    model = frame_lattice(3, 3, 3, parameters="direction").build()
    modes = model_modes(model, n_modes=8)
    g = mode_groups(modes.eigenvalues, 1e-8)[0]
    D = restricted_derivatives(model, modes, g)
    d = np.array([1.0, -0.3, 0.5]) * model.values  # E_x, E_y, E_z
    h = 1e-6
    for sgn in (1.0, -1.0):
        lam = model_modes(model, model.values + sgn * h * d, n_modes=8).eigenvalues[g[0]:g[1]]
        one_sided = (lam - modes.eigenvalues[g[0]:g[1]]) / h
        np.testing.assert_allclose(one_sided, np.linalg.eigvalsh(sgn * D @ d), rtol=1e-4)
    mu = np.linalg.eigvalsh(D @ d)
    assert mu[1] - mu[0] > 1e-2 * abs(mu).max()  # the direction does split the pair


# ------------------------------------------------------------------------------- the group's basis, every route
@pytest.mark.parametrize("route", ["nelson", "subspace", "adjoint", "fd"])
def test_group_basis_derivative_every_route(route):
    model, p = square_frame()
    modes = model_modes(model, p, n_modes=16)
    g = mode_groups(modes.eigenvalues, 1e-8)[0]
    which = list(range(*g))
    sensors = ["10:x", "13:y", "18:x", "18:y", "24:x", "26:z"]
    ref_dB, ref_dA, _ = group_finite_difference(model, g, p, base=modes, rel_step=1e-4)
    res = jacobian(model, modes, which, sensors, values=p, method=route, groups=[g], shape_scaling="mass",
                   relative_eigenvalues=False)
    pos = model.dof_index(sensors)
    assert rel(res.dpsi, ref_dB[pos]) < 1e-6
    assert res.groups == (g,) and rel(res.restricted[0], ref_dA) < 1e-6
    diagonal = np.einsum("iij->ij", res.restricted[0])  # Fox-Kapoor's λ' of each computed mode
    assert rel(res.dlam, diagonal) < (1e-6 if route == "fd" else 1e-12)


def test_group_basis_complete_modal_equals_nelson_and_refusal_without_groups():
    model, p = square_frame()
    full = model_modes(model, p, n_modes=model.n_dofs)
    g = mode_groups(full.eigenvalues, 1e-8)[0]
    which = list(range(*g))
    _, exact = nelson(model, full, which, values=p, groups=[g])
    _, complete = modal(model, full, which, values=p, groups=[g])
    assert rel(complete, exact) < 1e-8
    few = model_modes(model, p, n_modes=16)
    _, series = subspace(model, few, which, values=p, groups=[g])
    assert rel(series, nelson(model, few, which, values=p, groups=[g])[1]) < 1e-8  # on the same basis
    for route in (lambda: nelson(model, full, which, values=p), lambda: adjoint(model, full, which, sensors=["10:x"]),
                  lambda: eigenvalue_derivatives(model, full, which)):
        with pytest.raises(NumericalError, match="repeated"):
            route()
    eigenvalue_derivatives(model, full, which, groups=[g])  # fine as a group
    with pytest.raises(InputError, match="groups"):
        nelson(model, full, which, values=p, groups=[(g[0], g[0] + 1)])
    a2 = mode_groups(full.eigenvalues, 1e-8)[1][0]
    with pytest.raises(NumericalError, match=f"modes {a2 + 1} and {a2 + 2} are repeated"):  # a group without its pair
        nelson(model, full, [a2], values=p, groups=[(a2 - 1, a2 + 1)])


def test_projector_derivative_against_differences_of_the_projector():
    """P = Φ_G Φ_Gᵀ M does not depend on the arbitrary basis: its differences are an independent
    reference for P' = B'BᵀM + BB'ᵀM + BBᵀM' (mass parameters included)."""
    model, p = square_frame()
    modes = model_modes(model, p, n_modes=16)
    for g in mode_groups(modes.eigenvalues, 1e-8)[:2]:
        B = modes.shapes[:, g[0]:g[1]]
        _, dB = nelson(model, modes, list(range(*g)), values=p, groups=[g])
        M = model.M(p).toarray()
        for j in range(len(p)):
            h = 1e-5 * p[j]
            Ps = []
            for s in (1.0, -1.0):
                q = p.copy()
                q[j] += s * h
                Phi = model_modes(model, q, n_modes=16).shapes[:, g[0]:g[1]]
                Ps.append(Phi @ Phi.T @ model.M(q).toarray())
            dP = dB[:, :, j] @ B.T @ M + B @ dB[:, :, j].T @ M + B @ B.T @ _dM(model, j)
            assert rel(dP, (Ps[0] - Ps[1]) / (2 * h)) < 1e-6


def _dM(model, j):
    """∂M/∂p_j (dense), by the model's own affine pattern."""
    v = model.values.copy()
    v[j] += 1.0
    return (model.M(v) - model.M(model.values)).toarray()


# ------------------------------------------------------------------------------- Dailey's adjacent eigenvectors
def two_identical_blocks():
    """Two uncoupled, identical 2-dof blocks [[3, -1], [-1, 2]] (M = I): every eigenvalue twice.
    Parameter k adds k - 1 to the first block's (0, 0) entry."""
    B0 = np.array([[3.0, -1.0], [-1.0, 2.0]])
    E = np.zeros((4, 4))
    E[0, 0] = 1.0
    K0 = np.zeros((4, 4))
    K0[:2, :2] = B0 - E[:2, :2]
    K0[2:, 2:] = B0
    return from_matrices(["1:x", "2:x", "3:x", "4:x"], K0, np.eye(4), [Parameter("k", 1.0)], dK=[E])


def test_dailey_against_the_closed_form_of_two_identical_blocks():
    model = two_identical_blocks()
    modes = model_modes(model, n_modes=4)
    groups = mode_groups(modes.eigenvalues, 1e-8)
    assert groups == [(0, 2), (2, 4)]
    a, b, c = 3.0, -1.0, 2.0
    theta = 0.5 * math.atan2(2 * b, a - c)
    dtheta = -b / ((a - c) ** 2 + 4 * b ** 2)
    v_plus, v_minus = np.array([math.cos(theta), math.sin(theta)]), np.array([-math.sin(theta), math.cos(theta)])
    dv_plus = np.array([-math.sin(theta), math.cos(theta)]) * dtheta
    dv_minus = np.array([-math.cos(theta), -math.sin(theta)]) * dtheta
    for g, v, dv, mu in (((2, 4), v_plus, dv_plus, math.cos(theta) ** 2), ((0, 2), v_minus, dv_minus,
                                                                          math.sin(theta) ** 2)):
        ad = adjacent_eigenvectors(model, modes, g, [1.0])
        np.testing.assert_allclose(ad.dlam, [0.0, mu], atol=1e-12)  # block 2 does not move, block 1 by mu
        x_still, x_moving = ad.vectors[:, 0], ad.vectors[:, 1]
        s1 = np.sign(x_moving[:2] @ v)
        np.testing.assert_allclose(x_moving, s1 * np.r_[v, 0, 0], atol=1e-12)
        np.testing.assert_allclose(np.abs(x_still @ np.r_[0, 0, v]), 1.0, atol=1e-12)
        np.testing.assert_allclose(ad.derivatives[:, 1], s1 * np.r_[dv, 0, 0], atol=1e-12)
        np.testing.assert_allclose(ad.derivatives[:, 0], 0.0, atol=1e-12)


def random_repeated(n=6, seed=3):
    """K, M with a double eigenvalue 2 at p = (1, 1, 1); random stiffness and mass parameters."""
    rng = np.random.default_rng(seed)
    Q, _ = np.linalg.qr(rng.normal(size=(n, n)))
    Kt = Q @ np.diag([1.0, 2.0, 2.0, 3.0, 5.0, 7.0]) @ Q.T
    sym = [0.5 * (A + A.T) for A in rng.normal(size=(3, n, n))]
    dK1, dK2, dM1 = 0.6 * sym[0], 0.4 * sym[1], 0.1 * sym[2]
    return from_matrices([f"{i + 1}:x" for i in range(n)], Kt - dK1 - dK2, np.eye(n) - dM1,
                         [Parameter("a", 1.0), Parameter("b", 1.0), Parameter("c", 1.0)],
                         dK=[dK1, dK2, None], dM=[None, None, dM1])


def test_dailey_against_differences_along_the_branches():
    """A stiffness-and-mass direction that splits the pair: along p0 + t d the branches are
    analytic; their central differences (eigenvectors matched to the adjacent ones) are the
    reference, and the in-group part of the derivative is large here (not a trivial check)."""
    model = random_repeated()
    modes = model_modes(model, n_modes=6)
    (g,) = mode_groups(modes.eigenvalues, 1e-8)
    d = np.array([0.7, -0.4, 0.5])
    ad = adjacent_eigenvectors(model, modes, g, d)
    h = 1e-4
    sides = []
    for s in (1.0, -1.0):
        at = model_modes(model, model.values + s * h * d, n_modes=6)
        S = at.shapes[:, g[0]:g[1]]
        ov = ad.vectors.T @ model.M(model.values) @ S  # branch by overlap, sign aligned
        k = np.argmax(np.abs(ov), axis=1)
        sides.append((at.eigenvalues[g[0] + k], S[:, k] * np.sign(ov[np.arange(k.size), k])))
    np.testing.assert_allclose(ad.dlam, (sides[0][0] - sides[1][0]) / (2 * h), rtol=1e-6)
    assert rel(ad.derivatives, (sides[0][1] - sides[1][1]) / (2 * h)) < 1e-6
    inside = ad.vectors.T @ model.M(model.values) @ ad.derivatives
    assert abs(inside[0, 1]) > 0.1  # Dailey's in-group coefficients matter


def test_dailey_refusals():
    model = random_repeated()
    modes = model_modes(model, n_modes=6)
    with pytest.raises(InputError, match="not repeated"):
        adjacent_eigenvectors(model, modes, (2, 4), [1.0, 0.0, 0.0])
    with pytest.raises(InputError, match="direction"):
        adjacent_eigenvectors(model, modes, (1, 3), [1.0, 0.0])
    sym, p = square_frame("storey")
    sm = model_modes(sym, p, n_modes=6)
    g = mode_groups(sm.eigenvalues, 1e-8)[0]
    with pytest.raises(NumericalError, match="does not split"):  # symmetric parameters keep the pair
        adjacent_eigenvectors(sym, sm, g, np.ones(len(p)))


def test_group_basis_inside_the_group_with_an_unsymmetric_mass_parameter():
    """A mass parameter that couples the pair (φ_1ᵀM'φ_2 != 0) sets the part of the basis'
    derivative inside the group, −½ Φ_Gᵀ M' φ: checked against the differences of the basis."""
    model = random_repeated()
    modes = model_modes(model, n_modes=6)
    (g,) = mode_groups(modes.eigenvalues, 1e-8)
    Phi = modes.shapes[:, g[0]:g[1]]
    assert abs(Phi[:, 0] @ _dM(model, 2) @ Phi[:, 1]) > 1e-3
    ref, _, _ = group_finite_difference(model, g, base=modes, rel_step=1e-5)
    for route in ("nelson", "modal", "fd"):
        res = jacobian(model, modes, list(range(*g)), list(model.dofs), method=route, groups=[g], shape_scaling="mass",
                       relative_eigenvalues=False)
        assert rel(res.dpsi, ref) < 1e-6, route
