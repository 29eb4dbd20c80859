"""Parameters that enter through known functions (issue 28 item 2): K(p) = K0 + Σ f_k(p) K_k.

References: central finite differences of the true non-linear model (never its tangent), a
closed form (a thin simply supported plate's bending frequencies go as t: f(t)/f(t0) = t/t0,
Kirchhoff/Leissa), and recovery of simulated parameters from noise-free modes."""

from __future__ import annotations

import numpy as np
import pytest

from femupdate import InputError, MeasuredMode, Structure, TestData, model_modes
from femupdate.coefficients import Exp, Polynomial, Power, Term
from femupdate.model import Model, Parameter
from femupdate.sensitivity import finite_difference, jacobian
from femupdate.sensitivity.eigenvalue import eigenvalue_derivatives
from femupdate.updating import update_modal

from _meshes3d import plate_mesh

NU = 0.3
B = 0.7  # the plate's width (m); its length is 1 m


def plate(n=6, t=0.01, E=70e9, rho=2700.0, t_param="t", E_param=None):
    """A simply supported (hard) aluminium plate 1 m x 0.7 m of MITC4 shells, thickness a parameter
    (rectangular: distinct frequencies)."""
    nodes, conn = plate_mesh(n)
    nodes[:, 1] *= B
    s = Structure("plate")
    s.parameter("t", t, bounds=(1e-4, 0.1))
    if E_param:
        s.parameter(E_param, E, bounds=(1e9, 1e12))
    s.add_nodes(np.arange(1, len(nodes) + 1), nodes)
    s.shell((conn + 1).tolist(), E=E_param or E, nu=NU, t=t_param, rho=rho)
    x, y = nodes[:, 0], nodes[:, 1]
    fixed = []
    for i, (a, b) in enumerate(zip(x, y), start=1):
        fixed += [f"{i}:x", f"{i}:y", f"{i}:rz"]  # in-plane and drilling: decoupled from bending
        ex, ey = np.isclose(a, 0) | np.isclose(a, 1), np.isclose(b, 0) | np.isclose(b, B)
        if ex or ey:
            fixed.append(f"{i}:z")
        if ex:
            fixed.append(f"{i}:rx")
        if ey:
            fixed.append(f"{i}:ry")
    s.support(sorted(set(fixed)))
    return s.build()


def small_model():
    rng = np.random.default_rng(3)
    A, B, C = (X @ X.T + 4 * np.eye(4) for X in rng.standard_normal((3, 4, 4)))
    return Model(dofs=["1:x", "2:x", "3:x", "4:x"], K0=np.eye(4), M0=np.eye(4),
                 parameters=[Parameter("E", 2.0, (0.1, 10)), Parameter("t", 0.5, (0.1, 2)), Parameter("c", 0.3)],
                 dK=[None, None, np.diag([1.0, 0, 0, 2])], dM=[None, np.diag([1.0, 2, 3, 4]), None],
                 terms=[Term([Power("E"), Power("t", 3)], K=A), Term([Exp("c", 0.7)], M=B),
                        Term([Polynomial("t", [1.0, -0.5, 2.0]), Power("c", 2)], K=C)])


def test_matrices_and_chain_rule_derivatives_against_central_differences():
    m = small_model()
    p = np.array([2.0, 0.5, 0.3])
    assert not m.is_affine
    for j in range(3):
        h = 1e-6 * max(1.0, abs(p[j]))
        e = np.zeros(3)
        e[j] = h
        for mat, d in ((m.K, m.dK_dp), (m.M, m.dM_dp)):
            fd = (mat(p + e) - mat(p - e)).toarray() / (2 * h)
            exact = d(j, p).toarray()
            assert np.abs(fd - exact).max() <= 1e-7 * max(1.0, np.abs(exact).max()), (j, mat)
    lin = m.linearised(p)
    assert lin.is_affine and np.abs((lin.K(p) - m.K(p)).toarray()).max() < 1e-12 * np.abs(m.K(p).toarray()).max()


def test_plate_jacobian_eigenvalues_and_shapes_against_central_differences():
    m = plate(n=6, E_param="E")
    p = m.values
    modes = model_modes(m, p, n_modes=6)
    sensors = [d for d in m.dofs if d.endswith(":z")]
    which = [0, 1, 3]
    # every mode (the dense eigensolver: its eigenvalues to round-off, so the differences hold ~1e-8)
    dlam_fd, dphi_fd = finite_difference(m, values=p, which=which, rel_step=1e-4)
    s = m.dof_index(sensors)
    shape_scale = np.abs(modes.shapes[np.ix_(s, which)]).max() / p  # a shape's change per unit of p_j
    for method in ("nelson", "adjoint", "subspace", "static"):  # the modal sum is truncated by design
        J = jacobian(m, modes, which, sensors, values=p, method=method, shape_scaling="mass",
                     relative_eigenvalues=False)
        # the differences are good to ~3e-6 here (round-off against the largest eigenvalue, stiff rotations)
        assert np.allclose(J.dlam, dlam_fd, rtol=1e-5, atol=0), (method, J.dlam / dlam_fd - 1)
        err = np.abs(J.dpsi - dphi_fd[s]).max(axis=(0, 1)) / shape_scale
        assert np.all(err < 1e-5), (method, err)
    # closed form: bending eigenvalues go as t^2 (K ~ E t^3, M ~ rho t), so d(lambda)/dt = 2 lambda / t up to the
    # shear and rotary-inertia corrections, O((t/a)^2); and lambda ~ E exactly.  At t = 2 mm, differentiated
    # where the modes were computed (their context: no values given)
    thin = model_modes(m, {"t": 0.002}, n_modes=6)
    lam = eigenvalue_derivatives(m, thin, which)
    dev_thin = 1 - lam[:, 0] * 0.002 / (2 * thin.eigenvalues[which])
    assert np.all(np.abs(dev_thin) < 5e-4), dev_thin
    # the deviation is the O((t/a)^2) correction: 25 times larger at t = 10 mm (within 10 %)
    dev = 1 - eigenvalue_derivatives(m, modes, which)[:, 0] * p[0] / (2 * modes.eigenvalues[which])
    assert np.allclose(dev / dev_thin, 25, rtol=0.1), dev / dev_thin
    assert np.allclose(lam[:, 1], thin.eigenvalues[which] / p[1], rtol=1e-8)


def test_plate_frequency_scales_with_thickness_closed_form():
    m = plate(n=8)
    f0 = model_modes(m, {"t": 0.0005}, n_modes=3).frequencies_hz  # thin: shear and rotary inertia O(1e-5)
    f1 = model_modes(m, {"t": 0.001}, n_modes=3).frequencies_hz
    assert np.allclose(f1 / f0, 2.0, rtol=1e-4), f1 / f0
    D = 70e9 * 0.0005**3 / (12 * (1 - NU**2))
    leissa = np.pi / 2 * (1 + 1 / B**2) * np.sqrt(D / (2700 * 0.0005))  # (1, 1) mode, Hz (Leissa)
    assert abs(f0[0] / leissa - 1) < 0.02


@pytest.mark.parametrize("with_E", [False, True])
def test_update_recovers_plate_thickness_from_noise_free_modes(with_E):
    true = {"t": 0.012, "E": 72e9} if with_E else {"t": 0.012}
    m = plate(n=6, E_param="E" if with_E else None)
    sim = model_modes(m, true, n_modes=6)
    sensors = [i for i, d in enumerate(m.dofs) if d.endswith(":z")]
    data = TestData(modes=tuple(MeasuredMode(float(sim.eigenvalues[i]), tuple(m.dofs[k] for k in sensors),
                                             sim.shapes[sensors, i]) for i in range(5)))
    # with E too: the bending eigenvalues see E t^2 to leading order, so E and t are told apart only by
    # the O((t/a)^2) shear and rotary-inertia terms (and the shapes' scale): identifiable from noise-free
    # data, poorly conditioned with noise
    res = update_modal(m, data, x0={"t": 0.01, **({"E": 65e9} if with_E else {})})
    got = res.parameters
    for k, v in true.items():
        assert abs(got[k] / v - 1) < 1e-6, (k, got[k], v)


def test_bad_factors_refused():
    with pytest.raises(InputError, match="named in two factors"):
        Term([Power("t", 1), Power("t", 2)], K=np.eye(2))
    with pytest.raises(InputError, match="not declared"):
        Model(dofs=["1:x"], K0=[[1.0]], M0=[[1.0]], parameters=[Parameter("E", 1.0)], dK=[[[1.0]]], dM=[None],
              terms=[Term([Power("t", 3)], K=[[1.0]])])
    m = small_model()
    with pytest.raises(InputError, match="not defined"):
        Model(dofs=["1:x"], K0=[[1.0]], M0=[[1.0]], parameters=[Parameter("t", 1.0)],
              terms=[Term([Power("t", 0.5)], K=[[1.0]])]).K({"t": -1.0})
    assert m.K().shape == (4, 4)


def test_posterior_laplace_uses_the_chain_rule():
    """The Laplace posterior of t from three eigenvalues (1 % stated): its standard deviation against
    one from central differences of the true model's eigenvalues, 1/sqrt(sum (dlam_i/dt / (lam_i s))^2)."""
    import femupdate

    m = plate(n=4)
    lam = model_modes(m, {"t": 0.012}, n_modes=4).eigenvalues[:3]
    data = TestData(modes=tuple(MeasuredMode(float(v), std_eigenvalue=0.01) for v in lam))
    res = femupdate.posterior(m, data, sampler="laplace", noise="stated", seed=1, samples=2000, starts=2)
    h = 1e-6 * 0.012
    d = (model_modes(m, {"t": 0.012 + h}, n_modes=4).eigenvalues[:3]
         - model_modes(m, {"t": 0.012 - h}, n_modes=4).eigenvalues[:3]) / (2 * h)
    std_fd = 1 / np.sqrt(np.sum((d / (lam * 0.01)) ** 2))
    mode = res.modes[0]
    assert abs(mode.x[0] * 0.01 / 0.012 - 1) < 1e-6  # x = t / t_start (the relative parametrisation)
    std = float(np.sqrt(np.linalg.inv(mode.hessian))[0, 0]) * 0.01
    assert abs(std / std_fd - 1) < 1e-4, (std, std_fd)
    assert res.route == "local"  # the automatic choice: the compiled route assumes linear parameters
    with pytest.raises(InputError, match=r"route 'compiled': parameter 't' enters model 'plate' through t\^3"):
        femupdate.posterior(m, data, sampler="laplace", noise="stated", seed=1, samples=200, starts=1,
                            route="compiled")


def test_routes_that_assume_linear_parameters_refuse_a_thickness():
    import femupdate
    from femupdate.updating.batched import unsupported
    from femupdate.updating.batched.driver import BatchedProblem

    m = plate(n=2)
    sim = model_modes(m, {"t": 0.012}, n_modes=2)
    data = TestData(modes=(MeasuredMode(float(sim.eigenvalues[0])),))
    assert "parameter 't' enters model 'plate' through " in unsupported(m, {}, explicit=True)
    with pytest.raises(InputError, match=r"the compiled batched route assumes the parameters enter linearly.*'t'"):
        BatchedProblem(m, ["t"], np.array([[1.0]]), data)
    with pytest.raises(InputError, match=r"exact-solution algebra .*parameter 't' enters through .*t\^3"):
        femupdate.exact_solutions(m, sim.eigenvalues[:1])
    with pytest.raises(InputError, match=r"the direct update .*parameter 't'"):
        femupdate.direct_update(m, data)
    from femupdate.reduction.superelement import assemble
    with pytest.raises(InputError, match=r"the superelement assembly .*parameter 't'"):
        assemble([m, m])
    # the automatic choices fall back to the local routes: a multi-start study runs
    ms = femupdate.updating.multistart(m, data, 2, seed=1)
    assert abs(ms.best.parameters["t"] / 0.012 - 1) < 1e-6


def test_products_of_parameters_in_a_model_file_match_the_numeric_model():
    """E and I both parameters of a beam (K ~ E I for bending, E A axial), A and rho of the mass: the
    model evaluated at values equals the same structure with those values as numbers (a second route),
    and its derivatives the chain rule's."""
    import tomllib

    def build(E, I, A, rho):
        params = {n: {"value": v, "bounds": [v / 10, v * 10]} for n, v in (("E", 2e11), ("I", 1e-6), ("A", 1e-3),
                                                                           ("rho", 7800.0))}
        d = {"model": {"name": "beam"}, "parameters": params,
             "node": [{"id": i, "xyz": [float(i), 0, 0]} for i in (1, 2, 3)],
             "element": [{"type": "beam2d", "nodes": [1, 2], "E": E, "A": A, "I": I, "rho": rho},
                         {"type": "beam2d", "nodes": [2, 3], "E": E, "A": A, "I": I, "rho": rho}],
             "support": [{"dofs": ["1:x", "1:y", "1:rz"]}]}
        if not isinstance(E, str):
            d["parameters"] = {"k0": {"value": 1.0}}
            d["element"].append({"type": "spring", "dofs": ["3:y"], "k": "k0"})
        else:
            d["element"].append({"type": "spring", "dofs": ["3:y"], "k": 1.0})
        return Structure.from_dict(tomllib.loads("") | d).build()

    m = build("E", "I", "A", "rho")
    assert not m.is_affine and {t.describe() for t in m.terms} >= {"E*I", "A*rho"}
    v = {"E": 2.2e11, "I": 1.3e-6, "A": 1.1e-3, "rho": 7000.0}
    ref = build(*v.values())
    for a, b in ((m.K(v), ref.K()), (m.M(v), ref.M())):
        assert np.abs((a - b).toarray()).max() <= 1e-12 * np.abs(b.toarray()).max()
    p = m.resolve(v)
    j = m.parameter_index("I")
    h = 1e-6 * p[j]
    e = np.zeros(p.size)
    e[j] = h
    fd = (m.K(p + e) - m.K(p - e)).toarray() / (2 * h)
    assert np.abs(fd - m.dK_dp(j, p).toarray()).max() <= 1e-7 * np.abs(fd).max()


def test_matrices_model_file_terms(tmp_path):
    """A [matrices] model with [[term]] tables: K = K0 + E t^3 Kb + E t Km, M = M0 + rho t Mt (a plate's
    split, as exported), against the same model built in Python; bad tables refused by name."""
    from femupdate import load_model

    m = small_model()
    for name, A in (("K0", np.eye(4)), ("M0", np.eye(4)), ("A", m.terms[0].K.toarray()),
                    ("B", m.terms[1].M.toarray()), ("C", m.terms[2].K.toarray()), ("Kc", np.diag([1.0, 0, 0, 2])),
                    ("Mt", np.diag([1.0, 2, 3, 4]))):
        np.save(tmp_path / f"{name}.npy", A)
    text = """[model]
name = "terms"
[matrices]
dofs = ["1:x", "2:x", "3:x", "4:x"]
K0 = "K0.npy"
M0 = "M0.npy"
[parameters.E]
value = 2.0
bounds = [0.1, 10]
[parameters.t]
value = 0.5
bounds = [0.1, 2]
M = "Mt.npy"
[parameters.c]
value = 0.3
K = "Kc.npy"
[[term]]
factors = [["E", 1], ["t", 3]]
K = "A.npy"
[[term]]
factors = [["c", {exp = 0.7}]]
M = "B.npy"
[[term]]
factors = [["t", {poly = [1.0, -0.5, 2.0]}], ["c", 2]]
K = "C.npy"
"""
    (tmp_path / "m.toml").write_text(text)
    f = load_model(tmp_path / "m.toml")
    p = np.array([1.7, 0.8, -0.2])
    for a, b in ((f.K(p), m.K(p)), (f.M(p), m.M(p)), (f.dK_dp(1, p), m.dK_dp(1, p)), (f.dM_dp(2, p), m.dM_dp(2, p))):
        assert np.abs((a - b).toarray()).max() <= 1e-14 * max(1.0, np.abs(b.toarray()).max())
    for bad, match in (('factors = [["E", 1], ["t", 3]]', 'factors = [["E", 1], ["s", 3]]'),
                       ('factors = [["E", 1], ["t", 3]]', 'factors = "E*t^3"'),
                       ('factors = [["c", {exp = 0.7}]]', 'factors = [["c", {log = 0.7}]]')):
        (tmp_path / "bad.toml").write_text(text.replace(bad, match, 1))
        with pytest.raises(InputError, match=r"\[\[term\]\] #[12]|names parameter\(s\) s"):
            load_model(tmp_path / "bad.toml")


def test_drawings_see_the_members_of_a_frame_whose_stiffness_is_all_in_terms():
    from femupdate.plot.shapes import shape_geometry

    s = Structure("beams")
    for name, v in (("E", 2e11), ("A", 1e-3), ("I", 1e-6)):
        s.parameter(name, v, bounds=(v / 10, v * 10))
    for i in (1, 2, 3):
        s.node(i, (float(i), 0.0, 0.0))
    s.beam2d([(1, 2), (2, 3)], E="E", A="A", I="I", rho=7800.0)  # E A and E I: both products, no affine part
    s.support(["1:x", "1:y", "1:rz"])
    m = s.build()
    assert m.K0.nnz == 0 and m.dK[m.parameter_index("E")] is None
    geo = shape_geometry(m)
    assert geo is not None and len(geo.segments) == 1  # 2-3 (node 1 is fully supported: no free dof draws 1-2)


def test_frf_and_static_updating_of_a_plate_thickness():
    """FRFs (off resonance) and a static deflection simulated at t = 12 mm: the combined problem's
    Jacobian against central differences of its residuals, and the update recovers t to 1e-6."""
    from femupdate import StaticData, update
    from femupdate.frf import simulate
    from femupdate.updating import combined_problem

    m = plate(n=4)
    centre = [d for d in m.dofs if d.endswith(":z")]
    sensors = tuple(centre[::2])
    true = m.with_values({"t": 0.012})
    f0 = model_modes(true, n_modes=2).frequencies_hz[0]
    frf = simulate(true, 2 * np.pi * f0 * np.array([0.5, 0.8, 1.3]), {centre[4]: 1.0}, response=sensors)
    K = true.K().toarray()
    u = np.linalg.solve(K, np.eye(m.n_dofs)[:, m.dof_index([centre[4]])[0]] * 100.0)
    static = StaticData({centre[4]: 100.0}, sensors, u[m.dof_index(sensors)])
    data = TestData(frf=frf, static=(static,))
    prob = combined_problem(m, data, x0={"t": 0.011})
    x = np.array([1.05])
    J = prob.jacobian(x)
    h = 1e-6
    fd = (prob.residuals(x + h) - prob.residuals(x - h)) / (2 * h)
    assert np.abs(J[:, 0] - fd).max() <= 1e-6 * np.abs(fd).max(), np.abs(J[:, 0] - fd).max() / np.abs(fd).max()
    res = update(m, data, x0={"t": 0.01})
    assert abs(res.parameters["t"] / 0.012 - 1) < 1e-6, res.parameters


def test_dynamic_formulation_differentiates_a_thickness_at_each_iterate():
    """The dynamic (expanded-residual) formulation: its Jacobian against central differences of its
    residuals away from the nominal values, and t recovered from noise-free partial shapes to 1e-6."""
    from femupdate import update
    from femupdate.updating import Problem

    m = plate(n=4)
    sim = model_modes(m, {"t": 0.012}, n_modes=4)
    sensors = [i for i, d in enumerate(m.dofs) if d.endswith(":z")]
    data = TestData(modes=tuple(MeasuredMode(float(sim.eigenvalues[i]), tuple(m.dofs[k] for k in sensors),
                                             sim.shapes[sensors, i]) for i in range(2)))
    prob = Problem(m, data, x0={"t": 0.01}, formulation="dynamic")
    x = np.array([1.1])
    h = 1e-4  # the differences' error: 1.5e-8 here (truncation above, round-off of the expansions below)
    fd = (prob.residuals(x + h) - prob.residuals(x - h)) / (2 * h)
    J = prob.jacobian(x)
    assert np.abs(J[:, 0] - fd).max() <= 1e-6 * np.abs(fd).max(), np.abs(J[:, 0] - fd).max() / np.abs(fd).max()
    res = update(m, data, x0={"t": 0.01}, formulation="dynamic")
    assert abs(res.parameters["t"] / 0.012 - 1) < 1e-6, res.parameters


def test_reduction_projects_the_terms():
    """A Guyan reduction of the plate onto its transverse dofs, T built at t = 10 mm: the reduced model
    at t = 14 mm equals T^T K(p) T and T^T M(p) T of the full model there (a fixed T is linear)."""
    from femupdate.reduction import Reducer, reduce

    m = plate(n=4)
    keep = [d for d in m.dofs if d.endswith(":z")]
    t = Reducer(m, keep).transformation("guyan")
    r = reduce(m, t)
    assert not r.is_affine
    T = t.T.toarray() if hasattr(t.T, "toarray") else np.asarray(t.T)
    for full, red in ((m.K({"t": 0.014}), r.K({"t": 0.014})), (m.M({"t": 0.014}), r.M({"t": 0.014}))):
        ref = T.T @ full.toarray() @ T
        assert np.abs(red.toarray() - ref).max() <= 1e-12 * np.abs(ref).max()


def test_adjacent_eigenvectors_refuse_a_non_linear_model():
    from femupdate.sensitivity import adjacent_eigenvectors

    m = plate(n=2)
    modes = model_modes(m, n_modes=3)
    with pytest.raises(InputError, match=r"adjacent_eigenvectors .*K'' = M'' = 0.*parameter 't'"):
        adjacent_eigenvectors(m, modes, (0, 2), [1.0])


def test_a_penalty_tie_reduces_the_terms_too():
    """A penalty link on a chain whose springs enter as t^3 (a term): tied exactly, and the tied model at
    t equals the tied affine model with k = t^3 (a second route) at every t."""
    from femupdate import from_matrices
    from test_exported_matrices import chain_K

    elastic = chain_K(k=1.0, link=(2, 3), penalty=0.0)
    dofs = [f"{i}:x" for i in range(1, 7)]
    nl = from_matrices(dofs, chain_K(k=0.0, link=(2, 3), penalty=1e10), np.eye(6), [Parameter("t", 2.0, (1, 4))],
                       dK=[None], dM=[None], terms=[Term([Power("t", 3)], K=elastic)])
    af = from_matrices(dofs, chain_K(k=0.0, link=(2, 3), penalty=1e10), np.eye(6), [Parameter("k", 8.0, (1, 64))],
                       dK=[elastic], dM=[None])
    assert nl.dofs == af.dofs and len(nl.dofs) == 5
    for t in (1.5, 2.0, 3.0):
        a, b = nl.K({"t": t}).toarray(), af.K({"k": t**3}).toarray()
        assert np.abs(a - b).max() <= 1e-12 * np.abs(b).max()
