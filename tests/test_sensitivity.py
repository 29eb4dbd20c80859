"""Eigen-sensitivities: every route against finite differences and against each other.

Models are chosen so that central differences are accurate (moderate stiffness ratios, a
relative step of 1e-4, where truncation, O(h^2), and round-off, O(eps lambda_max / h), are
both below 1e-6): FD agrees with the analytic routes to better than 5e-7 there, and the
analytic routes agree with one another to ~1e-10.
"""

import dataclasses
import importlib.util
import json
from pathlib import Path

import numpy as np
import pytest

from femupdate import InputError, NumericalError, Structure, model_modes
from femupdate.examples import three_dof, two_dof
from femupdate.generators import frame_lattice, shear_building
from femupdate.sensitivity import (
    JacobianResult, adjoint, buffered_modes, eigenvalue_derivatives, finite_difference, jacobian, modal,
    modal_static_correction, nelson, scaled_shape, subspace,
)
from femupdate.sensitivity._common import param_products, parameter_products
from femupdate.sensitivity.jacobian import choose_method
from femupdate.sensitivity.adjoint import adjoint_details
from femupdate.sensitivity.factor import prepare_factor
from femupdate.sensitivity.series import omitted_modes_series
from femupdate.sensitivity.subspace import subspace_details

FD_TOL = 2e-6  # analytic vs central differences (relative, per parameter)
ROUTE_TOL = 1e-8  # analytic routes against one another


def rel_err(a, b):
    """Largest error relative to the largest reference entry, taken per parameter (last axis)."""
    a, b = np.asarray(a), np.asarray(b)
    L = b.shape[-1]
    num = np.abs(a - b).reshape(-1, L).max(axis=0)
    den = np.abs(b).reshape(-1, L).max(axis=0)
    return float(np.max(num / np.where(den > 0, den, 1.0)))


# ------------------------------------------------------------------------------- models
def cantilever(n_el=12):
    """Steel cantilever (beam2d) with E of the root and tip halves and one density as parameters."""
    s = Structure("cantilever")
    x = np.linspace(0.0, 2.0, n_el + 1)
    s.add_nodes(range(n_el + 1), np.c_[x, 0 * x])
    s.parameter("E_root", 2.1e11, (1e10, 1e12))
    s.parameter("E_tip", 1.8e11, (1e10, 1e12))
    s.parameter("rho", 7850.0, (1e3, 1e4))
    h = n_el // 2
    el = np.c_[np.arange(n_el), np.arange(1, n_el + 1)]
    s.beam2d(el[:h], E="E_root", A=1e-3, I=8e-7, rho="rho")
    s.beam2d(el[h:], E="E_tip", A=1e-3, I=8e-7, rho="rho")
    s.support_node([0])
    return s.build()


def free_beam(n_el=10):
    """Free-free beam2d (three rigid-body modes in the plane)."""
    s = Structure("free-free beam")
    x = np.linspace(0.0, 1.5, n_el + 1)
    s.add_nodes(range(n_el + 1), np.c_[x, 0 * x])
    s.parameter("E_a", 2.1e11, (1e10, 1e12))
    s.parameter("E_b", 2.1e11, (1e10, 1e12))
    s.parameter("rho", 7850.0, (1e3, 1e4))
    el = np.c_[np.arange(n_el), np.arange(1, n_el + 1)]
    s.beam2d(el[:4], E="E_a", A=1e-3, I=8e-7, rho="rho")
    s.beam2d(el[4:], E="E_b", A=1e-3, I=8e-7, rho="rho")
    return s.build()


def frame():
    """Small space frame, asymmetric in plan (no repeated modes), E and rho per storey."""
    return frame_lattice(3, 2, 4, spacing=(1.0, 1.3, 1.0), parameters="storey_mass").build()


def shear():
    return shear_building(4, k=[3e7, 2e7, 2.5e7, 1.5e7], m=[1.2e4, 1e4, 0.9e4, 0.8e4],
                          parameters="storey_mass").build()


# name: (builder, differentiated modes, modes computed for the series routes, sensors)
CASES = {
    "two_dof": (two_dof, [0], 1, ["1:x", "2:x"]),
    "three_dof": (three_dof, [0, 1], 2, ["1:x", "3:x"]),
    "three_dof_k4": (lambda: three_dof(k4=500.0), [0], 2, ["1:x", "2:x", "3:x"]),
    "shear_storey_mass": (shear, [0, 1], 3, ["2:x", "4:x"]),
    "cantilever": (cantilever, [0, 1, 2], 8, ["3:y", "6:y", "12:y", "12:rz"]),
    "free_free": (free_beam, [3, 4], 10, ["0:y", "5:y", "10:y", "10:x"]),
    "frame": (frame, [0, 1, 2, 3], 12, ["8:x", "10:y", "17:x", "22:y", "24:x", "24:y", "24:z", "20:rx"]),
}
_CACHE = {}


def case(name):
    if name not in _CACHE:
        build, which, m, sensors = CASES[name]
        model = build()
        full = model_modes(model)  # dense: every mode
        trunc = model_modes(model, n_modes=m)
        fd = finite_difference(model, which=which, rel_step=1e-4)
        ref = nelson(model, full, which=which)
        _CACHE[name] = dict(model=model, which=which, full=full, trunc=trunc, sensors=sensors, fd=fd, ref=ref,
                            s=model.dof_index(sensors))
    return _CACHE[name]


# ------------------------------------------------------------------------------- all-parameter products
def test_parameter_products_identical_to_per_parameter_products(rng):
    for model in (frame(), shear(), cantilever()):
        params = rng.permutation(len(model.parameters))
        phi = rng.standard_normal(model.n_dofs)
        Kp, Mp = param_products(model, params, phi)
        for c, j in enumerate(params):
            kref = model.dK[j] @ phi if model.dK[j] is not None else np.zeros(model.n_dofs)
            mref = model.dM[j] @ phi if model.dM[j] is not None else np.zeros(model.n_dofs)
            assert np.array_equal(Kp[:, c], kref) and np.array_equal(Mp[:, c], mref)
        Ks, Ms = parameter_products(model, params).sparse(phi)
        assert Ks.shape == (model.n_dofs, params.size) and np.array_equal(Ks.toarray(), Kp)


# ------------------------------------------------------------------------------- eq. 21
def test_eq21_two_dof_mass_normalised():
    model = two_dof()
    modes = model_modes(model)
    S = eigenvalue_derivatives(model, modes, relative=True)
    np.testing.assert_allclose(S, [[0.0670, 0.0773], [0.0580, 0.0893]], atol=5e-5)
    assert np.linalg.cond(S) == pytest.approx(14.48, abs=0.01)
    res = jacobian(model, modes, [0, 1], ["1:x", "2:x"])
    np.testing.assert_allclose(res.dlam, S, rtol=1e-12)
    fd, _ = finite_difference(model)
    np.testing.assert_allclose(fd / modes.eigenvalues[:, None], S, rtol=1e-8)


def test_eq21_with_unit_length_vectors_gives_the_papers_printed_matrix():
    """The paper's eq. 22 numbers are eq. 21 evaluated with unit-length, not mass-normalised,
    eigenvectors: this documents the normalisation behind the printed matrix."""
    model = two_dof()
    unit = model_modes(model, normalisation="unit")
    S = np.array([[unit.shapes[:, i] @ (model.dK[j] @ unit.shapes[:, i]) / unit.eigenvalues[i] for j in range(2)]
                  for i in range(2)])
    np.testing.assert_allclose(S, [[0.2427, 0.2802], [0.1224, 0.1885]], atol=5e-5)
    assert np.linalg.cond(S) == pytest.approx(16.3, abs=0.05)
    with pytest.raises(InputError, match="mass-normalised"):
        eigenvalue_derivatives(model, unit)


# ------------------------------------------------------------------------------- every route vs FD
@pytest.mark.parametrize("name", list(CASES))
def test_routes_against_finite_differences(name):
    c = case(name)
    model, which, fd_lam, fd_phi = c["model"], c["which"], *c["fd"]
    dl, dp = c["ref"]
    assert rel_err(dl, fd_lam) < FD_TOL
    assert rel_err(dp, fd_phi) < FD_TOL
    dl2, dp2 = subspace(model, c["trunc"], which=which)
    assert rel_err(dl2, fd_lam) < FD_TOL and rel_err(dp2, fd_phi) < FD_TOL
    dl3, dps = adjoint(model, c["trunc"], which=which, sensors=c["sensors"])
    assert rel_err(dl3, fd_lam) < FD_TOL and rel_err(dps, fd_phi[c["s"]]) < FD_TOL
    dl4, dp4 = modal(model, c["full"], which=which)  # complete modal superposition
    assert rel_err(dp4, fd_phi) < FD_TOL


@pytest.mark.parametrize("name", list(CASES))
def test_routes_against_each_other(name):
    c = case(name)
    model, which, s = c["model"], c["which"], c["s"]
    dl, dp = c["ref"]  # Nelson
    dlm, dpm = modal(model, c["full"], which=which)
    dls, dps, terms = subspace_details(model, c["trunc"], which=which)
    dla, dpa = adjoint(model, c["trunc"], which=which, sensors=c["sensors"])
    for other_l in (dlm, dls, dla):
        assert rel_err(other_l, dl) < 1e-12
    assert rel_err(dpm, dp) < ROUTE_TOL
    assert rel_err(dps, dp) < ROUTE_TOL
    assert rel_err(dpa, dp[s]) < ROUTE_TOL
    assert rel_err(dpa, dps[s]) < ROUTE_TOL  # adjoint == forward at the sensors
    assert np.all(terms >= 2)


def test_stiffness_and_mass_parameters_both_covered():
    model = frame()
    assert any(d is not None for d in model.dM) and any(d is not None for d in model.dK)
    assert any(d is None for d in model.dK)  # rho_s enters M only: zero columns must come out right
    c = case("frame")
    dl, dp = c["ref"]
    rho = [j for j, nm in enumerate(model.parameter_names) if nm.startswith("rho")]
    assert np.all(np.abs(dl[:, rho]) > 0)


# ------------------------------------------------------------------------------- rigid and repeated modes
def test_rigid_modes_refused_flexible_modes_fine():
    c = case("free_free")
    model, trunc = c["model"], c["trunc"]
    assert trunc.n_rigid == 3
    for route in (lambda: nelson(model, trunc, which=[0]), lambda: subspace(model, trunc, which=[1]),
                  lambda: adjoint(model, trunc, which=[2], sensors=["0:y"]),
                  lambda: modal_static_correction(model, trunc, which=[0]),
                  lambda: jacobian(model, trunc, [0, 3], ["0:y"], method="adjoint")):
        with pytest.raises(NumericalError, match="rigid-body"):
            route()
    # the series routes shift below zero for the singular K
    lu, sigma = prepare_factor(model.K(), model.M(), trunc)
    assert sigma < 0


def test_repeated_eigenvalues_raise_never_a_silent_answer():
    model = frame_lattice(3, 3, 3).build()  # square plan: two equal bending frequencies
    modes = model_modes(model, n_modes=8)
    lam = modes.eigenvalues
    assert abs(lam[1] - lam[0]) <= 1e-10 * lam[0]
    for route in (lambda: nelson(model, modes, which=[0]), lambda: subspace(model, modes, which=[1]),
                  lambda: modal(model, modes, which=[0]), lambda: adjoint(model, modes, which=[0], sensors=["10:x"]),
                  lambda: jacobian(model, modes, [0], ["10:x"]), lambda: eigenvalue_derivatives(model, modes, which=[1])):
        with pytest.raises(NumericalError, match="repeated"):
            route()
    # a distinct mode of the same structure is fine
    k = next(i for i in range(2, 8) if np.all(np.abs(np.delete(lam, i) - lam[i]) > 1e-6 * lam[i]))
    dl, dp = nelson(model, modes, which=[k])
    assert np.all(np.isfinite(dp))


# ------------------------------------------------------------------------------- truncation, Wang, series
def test_static_correction_beats_truncation_and_series_converges_to_nelson():
    model = cantilever(n_el=16)
    few = model_modes(model, n_modes=5)
    _, exact = nelson(model, few, which=[0, 1])
    _, trunc = modal(model, few, which=[0, 1])
    _, wang = modal_static_correction(model, few, which=[0, 1])
    e_trunc, e_wang = rel_err(trunc, exact), rel_err(wang, exact)
    assert e_trunc > 0.1 and e_wang < 0.01 * e_trunc  # Wang's correction removes most of the truncation error
    K, M = model.K(), model.M()
    lu, sigma = prepare_factor(K, M, few)
    assert sigma == 0.0
    _, first = _series_derivative(model, few, [0, 1], lu, sigma, 1)
    assert rel_err(first, wang) < 1e-12  # k = 0 alone is Wang's static correction
    which = [2, 3]  # slower: ratios (lambda_3, lambda_4) / lambda_6
    _, exact = nelson(model, few, which=which)
    errors = [rel_err(_series_derivative(model, few, which, lu, sigma, n)[1], exact) for n in (1, 2, 4, 8)]
    assert all(b < 0.5 * a for a, b in zip(errors, errors[1:]))  # geometric convergence
    _, converged, terms = subspace_details(model, few, which=which)
    assert rel_err(converged, exact) < 1e-9 and np.all(terms > 8)


def _series_derivative(model, modes, which, lu, sigma, n_terms):
    from femupdate.sensitivity._common import mode_rhs
    from femupdate.sensitivity.modal import modal_part

    M = model.M()
    params = np.arange(len(model.parameters))
    dphi = np.zeros((model.n_dofs, len(which), params.size))
    dlam = np.zeros((len(which), params.size))
    for r, i in enumerate(which):
        dl, F, mjj = mode_rhs(model, params, modes.eigenvalues[i], modes.shapes[:, i], M @ modes.shapes[:, i])
        Q, used = omitted_modes_series(lu, M, modes.shapes, F, [modes.eigenvalues[i] - sigma], tol=0.0, max_terms=n_terms,
                                       strict=False)
        assert used == n_terms
        dlam[r], dphi[:, r, :] = dl, modal_part(modes, i, F, mjj) + Q[0]
    return dlam, dphi


def test_series_without_buffer_or_with_a_missing_mode_raises():
    model = cantilever()
    modes = model_modes(model, n_modes=6)
    with pytest.raises(NumericalError, match="mode\\(s\\) 6.*compute more modes"):
        subspace(model, modes, which=[5], max_terms=5)
    with pytest.raises(NumericalError, match="compute more modes"):
        adjoint(model, modes, which=[0, 5], sensors=["12:y"], max_terms=5)
    # drop the first mode: the deflation misses it and the series diverges
    holed = dataclasses.replace(modes, eigenvalues=modes.eigenvalues[1:], shapes=modes.shapes[:, 1:])
    with pytest.raises(NumericalError, match="diverges"):
        subspace(model, holed, which=[1])


def test_krylov_and_neumann_sums_agree_and_krylov_needs_fewer_solves():
    c = case("frame")
    model, trunc, which, sensors = c["model"], c["trunc"], c["which"], c["sensors"]
    dl_k, dp_k, n_k = adjoint_details(model, trunc, which, sensors=sensors, series="krylov")
    dl_n, dp_n, n_n = adjoint_details(model, trunc, which, sensors=sensors, series="neumann")
    assert rel_err(dp_k, dp_n) < ROUTE_TOL and rel_err(dp_k, c["ref"][1][c["s"]]) < ROUTE_TOL
    assert n_k < n_n
    _, dp_sk = subspace(model, trunc, which=which, series="krylov")
    assert rel_err(dp_sk, c["ref"][1]) < ROUTE_TOL
    with pytest.raises(InputError, match="unknown series"):
        adjoint(model, trunc, which, sensors=sensors, series="chebyshev")


def test_krylov_form_is_right_even_with_a_lower_mode_missing():
    """The Galerkin form solves (I - c T) W = Y_0 on the whole complement, so a lower mode left
    out of the modes given is summed with it (where the Neumann series diverges)."""
    model = cantilever()
    modes = model_modes(model, n_modes=10)
    holed = dataclasses.replace(modes, eigenvalues=modes.eigenvalues[1:], shapes=modes.shapes[:, 1:])
    sensors = ["3:y", "6:y", "12:y", "12:rz"]
    _, dps = adjoint(model, holed, which=[1], sensors=sensors)  # the model's mode 3
    _, ref = nelson(model, modes, which=[2])
    assert rel_err(dps, ref[model.dof_index(sensors)]) < ROUTE_TOL


def test_supplied_factor_and_shift():
    c = case("cantilever")
    model, trunc, which = c["model"], c["trunc"], c["which"]
    K, M = model.K(), model.M()
    sigma = -0.5 * trunc.eigenvalues[0]
    lu, _ = prepare_factor(K, M, trunc, sigma=sigma)
    dl, dp = subspace(model, trunc, which=which, lu=lu, sigma=sigma)
    assert rel_err(dp, c["ref"][1]) < ROUTE_TOL
    with pytest.raises(InputError, match="sigma"):
        subspace(model, trunc, which=which, sigma=2 * trunc.eigenvalues[0])
    static = jacobian(model, trunc, which, c["sensors"], method="static", lu=lu, sigma=sigma, shape_scaling="mass")
    _, wang = modal_static_correction(model, trunc, which=which, sigma=sigma)
    np.testing.assert_allclose(static.dpsi, wang[c["s"]], rtol=1e-10, atol=1e-12 * np.abs(wang).max())


def test_buffered_modes():
    assert buffered_modes(10) == 20 and buffered_modes(2) == 8 and buffered_modes(5, n_dofs=9) == 9


# ------------------------------------------------------------------------------- jacobian and scaling
# reference sensor of each differentiated mode for "ref" scaling (none at a node of its mode)
REFS = {"cantilever": ["12:y", "12:y", "12:y"], "frame": ["24:y", "24:x", "24:x", "24:y"]}


@pytest.mark.parametrize("how", ["ref", "max", "unit"])
@pytest.mark.parametrize("name", ["cantilever", "frame"])
def test_scaled_shape_derivatives_against_fd_of_scaled_shapes(name, how):
    c = case(name)
    model, which = c["model"], c["which"]
    # no two sensors mirror each other: "max" and "unit" take the sign and the scale from the
    # largest component, which a tie between symmetric dofs makes ambiguous
    sensors = [d for d in c["sensors"] if d != "22:y"]
    s = model.dof_index(sensors)
    p0 = model.values
    base = c["full"]
    ref = REFS[name] if how == "ref" else None
    results = [jacobian(model, base, which, sensors, method="nelson", shape_scaling=how, ref=ref),
               jacobian(model, c["trunc"], which, sensors, method="adjoint", shape_scaling=how, ref=ref)]
    pos = results[0].ref
    fd = np.zeros_like(results[0].dpsi)
    M = model.M()
    for j in range(p0.size):
        h = 1e-3 * abs(p0[j])  # scaled shapes of these models carry O(1e-9) noise: a larger step
        psi = []
        for sgn in (1, -1):
            p = p0.copy()
            p[j] += sgn * h
            pert = model_modes(model, p)
            cols = []
            for r, i in enumerate(which):  # pair with the base mode (no scaling depends on the sign)
                k = int(np.argmax(np.abs(pert.shapes.T @ (M @ base.shapes[:, i]))))
                cols.append(scaled_shape(pert.shapes[s, k], None, how, pos[r] if pos else None)[0])
            psi.append(np.column_stack(cols))
        fd[:, :, j] = (psi[0] - psi[1]) / (2 * h)
    # compare d psi / d ln p: a uniform density leaves the scaled shapes unchanged (exact zero)
    for res in results:
        err = np.max(np.abs((res.dpsi - fd) * p0)) / np.max(np.abs(fd * p0))
        assert err < FD_TOL
        np.testing.assert_allclose(res.psi, results[0].psi, rtol=0, atol=1e-9 * np.abs(res.psi).max())
    if how != "unit":
        assert np.all(np.abs(results[0].psi).max(axis=0) >= 1.0 - 1e-12)


def test_jacobian_result_and_options():
    c = case("frame")
    model, trunc, which, sensors = c["model"], c["trunc"], c["which"], c["sensors"]
    res = jacobian(model, trunc, which, sensors, method="adjoint", shape_scaling="ref", ref=REFS["frame"])
    assert isinstance(res, JacobianResult) and res.method == "adjoint" and res.n_terms >= 2
    L, ns, md = len(model.parameters), len(sensors), len(which)
    assert res.dlam.shape == (md, L) and res.psi.shape == (ns, md) and res.dpsi.shape == (ns, md, L)
    assert res.sensors == tuple(sensors) and res.parameters == model.parameter_names and res.ref == (5, 4, 4, 5)
    for r, k in enumerate(res.ref):
        assert res.psi[k, r] == pytest.approx(1.0)
        np.testing.assert_allclose(res.dpsi[k, r], 0.0, atol=1e-12 * np.abs(res.dpsi).max())
    with pytest.raises(NumericalError, match="mode 1: cannot scale.*8:x"):
        jacobian(model, trunc, which, sensors, method="adjoint", shape_scaling="ref")  # 8:x is a node of mode 1
    assert res.matrix().shape == (md * (1 + ns), L)
    with pytest.raises(dataclasses.FrozenInstanceError):
        res.method = "fd"
    absolute = jacobian(model, trunc, which, sensors, method="subspace", relative_eigenvalues=False, shape_scaling="mass")
    np.testing.assert_allclose(absolute.dlam, eigenvalue_derivatives(model, trunc, which=which), rtol=1e-12)
    np.testing.assert_allclose(absolute.dlam / trunc.eigenvalues[which, None], res.dlam, rtol=1e-12)
    np.testing.assert_allclose(absolute.dpsi, c["ref"][1][c["s"]], rtol=0, atol=ROUTE_TOL * np.abs(c["ref"][1]).max())
    fd = jacobian(model, c["full"], which, sensors, method="fd", params=[0, 1], ref=REFS["frame"])
    assert fd.method == "fd" and rel_err(fd.dpsi, res.dpsi[:, :, :2]) < FD_TOL
    assert jacobian(model, c["full"], which, sensors, ref=REFS["frame"]).method == "nelson"  # small: auto -> nelson


def test_auto_choice():
    assert choose_method(1500, 30, 1000) == "nelson"
    assert choose_method(1501, 30, 1000) == "adjoint"
    assert choose_method(1501, 30, 30) == "subspace"


def test_auto_on_a_large_sparse_model_uses_the_adjoint():
    model = frame_lattice(4, 3, 23, spacing=(1.0, 1.2, 1.0)).build()  # 1,584 dofs, 22 parameters
    assert model.n_dofs > 1500
    modes = model_modes(model, n_modes=buffered_modes(3))
    sensors = ["40:x", "100:y", "200:x", "270:z"]
    res = jacobian(model, modes, [0, 1, 2], sensors, shape_scaling="unit")
    assert res.method == "adjoint"
    params = [0, 10, 21]
    dl, dp = nelson(model, modes, which=[0, 1, 2], params=params)
    s = model.dof_index(sensors)
    mass = jacobian(model, modes, [0, 1, 2], sensors, shape_scaling="mass", relative_eigenvalues=False)
    assert rel_err(mass.dpsi[:, :, params], dp[s]) < ROUTE_TOL  # Nelson's sparse path (n > 1500)
    ref = jacobian(model, modes, [0, 1, 2], sensors, params=params, method="nelson", shape_scaling="unit")
    assert ref.method == "nelson"
    assert rel_err(res.dpsi[:, :, params], ref.dpsi) < ROUTE_TOL
    assert rel_err(res.dlam[:, params], dl / modes.eigenvalues[:3, None]) < 1e-12
    sub = jacobian(model, modes, [0, 1, 2], sensors, params=params, shape_scaling="unit")  # sensors >= parameters
    assert sub.method == "subspace" and rel_err(sub.dpsi, ref.dpsi) < ROUTE_TOL


def test_bad_inputs_are_named():
    c = case("cantilever")
    model, trunc = c["model"], c["trunc"]
    with pytest.raises(InputError, match="99:y.*98:x|98:x.*99:y"):
        jacobian(model, trunc, [0], ["3:y", "99:y", "98:x"])
    with pytest.raises(InputError, match="listed twice"):
        adjoint(model, trunc, which=[0], sensors=["3:y", "3:y"])
    with pytest.raises(InputError, match="out of range"):
        adjoint(model, trunc, which=[0], sensors=[0, 10_000])
    with pytest.raises(InputError, match="not a mixture"):
        adjoint(model, trunc, which=[0], sensors=["3:y", 4])
    with pytest.raises(InputError, match="reference dof 6:x is not among the sensors"):
        jacobian(model, trunc, [0], ["3:y", "6:y"], ref="6:x")
    with pytest.raises(InputError, match="unknown sensitivity method"):
        jacobian(model, trunc, [0], ["3:y"], method="magic")
    with pytest.raises(InputError, match="unknown shape scaling"):
        jacobian(model, trunc, [0], ["3:y"], shape_scaling="peak")
    with pytest.raises(InputError, match="dofs"):
        subspace(two_dof(), trunc, which=[0])
    with pytest.raises(InputError, match="mode index out of range"):
        jacobian(model, trunc, [99], ["3:y"])
    # sensors given as dof indices work the same as labels
    by_index = adjoint(model, trunc, which=[0], sensors=list(c["s"]))
    by_label = adjoint(model, trunc, which=[0], sensors=c["sensors"])
    np.testing.assert_array_equal(by_index[1], by_label[1])


# ------------------------------------------------------------------------------- benchmark smoke run
def test_benchmark_quick(tmp_path):
    path = Path(__file__).resolve().parents[1] / "benchmarks" / "bench_jacobian.py"
    spec = importlib.util.spec_from_file_location("bench_jacobian", path)
    bench = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(bench)
    out = tmp_path / "bench.json"
    assert bench.main(["--quick", "--output", str(out)]) == 0
    res = json.loads(out.read_text())
    assert res["checks"]["adjoint_vs_subspace"]["ok"] and res["checks"]["adjoint_vs_fd"]["ok"]
    assert res["model"]["n_parameters"] > res["model"]["n_sensors"]


# ------------------------------------------------------------------------------- the eigensolver's factor
@pytest.mark.parametrize("name", ["cantilever", "free_free"])
def test_series_routes_reuse_the_eigensolvers_factor(name, monkeypatch):
    factor = importlib.import_module("femupdate.sensitivity.factor")  # where prepare_factor looks shifted_factor up

    c = case(name)
    model = c["model"]
    sparse_modes = model_modes(model, n_modes=c["trunc"].n_modes, method="sparse")
    assert sparse_modes.factor is not None and c["full"].factor is None  # dense path: no factor
    lu, sigma = sparse_modes.factor
    assert sigma < np.min(sparse_modes.eigenvalues) and (sigma < 0) == (sparse_modes.n_rigid > 0)
    kw = dict(shape_scaling="mass")  # (scaled shapes do not depend on a uniform density: round-off only)
    own = jacobian(model, sparse_modes, c["which"], c["sensors"], method="adjoint", **kw)

    def no_factorising(*a, **k):
        raise AssertionError("factorised again although the modes carry their factor")

    monkeypatch.setattr(factor, "shifted_factor", no_factorising)
    for method in ("adjoint", "subspace"):
        reused = jacobian(model, sparse_modes, c["which"], c["sensors"], method=method, **kw)
        # against Nelson on every mode (dense), not merely against itself
        ref = jacobian(model, c["full"], c["which"], c["sensors"], method="nelson", **kw)
        assert rel_err(reused.dlam, ref.dlam) < ROUTE_TOL and rel_err(reused.dpsi, ref.dpsi) < ROUTE_TOL
    assert rel_err(own.dpsi, ref.dpsi) < ROUTE_TOL
