"""Structures: the TOML-dict form, the affine parametrisation, bad input.

References are hand-written matrices, closed forms, or a second route (the same structure
rebuilt with every property a number), never the package's own output.
"""

from __future__ import annotations

import math
import tomllib

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from femupdate import InputError, Structure
from femupdate import elements as el

# The model file of the user-facing contract (docs/file-formats.md), verbatim (comments included).
INTERFACE_TOML = '''
[model]
name = "two-dof chain"

[parameters.k1]          # one table per physical parameter
value = 8.0              # nominal / starting value
bounds = [0.0, 100.0]    # optional
# fixed = true           # optional: known, never updated

[parameters.k2]
value = 6.0

[parameters.E_steel]     # used by the beam below
value = 2.1e11
bounds = [1.5e11, 2.5e11]

[[node]]                 # optional for lumped systems; needed for rods/beams
id = 3
xyz = [0.0, 0.0, 0.0]

[[node]]
id = 4
xyz = [0.5, 0.0, 0.0]

[[element]]
type = "spring"          # one label: spring to ground; two labels: spring between them
dofs = ["1:x"]
k = "k1"                 # every property is a number or a parameter name

[[element]]
type = "spring"
dofs = ["1:x", "2:x"]
k = "k2"

[[element]]
type = "mass"            # lumped mass on one or more dofs
dofs = ["1:x"]
m = 2.0

[[element]]
type = "mass"
dofs = ["2:x"]
m = 4.0

[[element]]
type = "beam2d"          # Euler–Bernoulli beam in the x-y plane; node dofs x, y, rz
nodes = [3, 4]
E = "E_steel"            # numbers or parameter names, as everywhere
A = 1.0e-3
I = 8.33e-8
rho = 7850.0
mass = "consistent"      # "consistent" (default for rod/beam/frame) or "lumped"

[[support]]
dofs = ["3:x", "3:y", "3:rz"]   # fixed dofs (removed from the model): a cantilever
'''


def dense(A):
    return A.toarray() if hasattr(A, "toarray") else np.asarray(A)


def sub(model, A, labels):
    idx = [model.dofs.index(lab) for lab in labels]
    return dense(A)[np.ix_(idx, idx)]


# --------------------------------------------------------------------------------------
# the documented model file
# --------------------------------------------------------------------------------------
def test_interface_example_builds_the_documented_model():
    model = Structure.from_dict(tomllib.loads(INTERFACE_TOML), source="example.toml").build()
    assert model.name == "two-dof chain"
    assert model.parameter_names == ("k1", "k2", "E_steel")
    assert set(model.dofs) == {"1:x", "2:x", "4:x", "4:y", "4:rz"}
    assert model.bounds[0].tolist() == [0.0, -math.inf, 1.5e11]
    # the spring chain: K = [[k1 + k2, -k2], [-k2, k2]], M = diag(2, 4)
    np.testing.assert_array_equal(sub(model, model.K(), ["1:x", "2:x"]), [[14.0, -6.0], [-6.0, 6.0]])
    np.testing.assert_array_equal(sub(model, model.M(), ["1:x", "2:x"]), np.diag([2.0, 4.0]))
    np.testing.assert_array_equal(sub(model, model.dK_dp(0), ["1:x", "2:x"]), [[1.0, 0.0], [0.0, 0.0]])
    np.testing.assert_array_equal(sub(model, model.dK_dp(1), ["1:x", "2:x"]), [[1.0, -1.0], [-1.0, 1.0]])
    # the cantilever tip: (EA/l) for x; [[12EI/l^3, -6EI/l^2], [-6EI/l^2, 4EI/l]] for (y, rz)
    E, A, I, L = 2.1e11, 1e-3, 8.33e-8, 0.5
    tip = [[E * A / L, 0, 0], [0, 12 * E * I / L**3, -6 * E * I / L**2], [0, -6 * E * I / L**2, 4 * E * I / L]]
    np.testing.assert_allclose(sub(model, model.K(), ["4:x", "4:y", "4:rz"]), tip, rtol=1e-14)
    np.testing.assert_allclose(sub(model, model.dK_dp(2), ["4:x", "4:y", "4:rz"]), np.array(tip) / E, rtol=1e-14)
    # consistent tip mass rho A l / 420 * [[140, 0, 0], [0, 156, -22 l], [0, -22 l, 4 l^2]]
    m = 7850.0 * A * L / 420
    np.testing.assert_allclose(sub(model, model.M(), ["4:x", "4:y", "4:rz"]),
                               m * np.array([[140, 0, 0], [0, 156, -22 * L], [0, -22 * L, 4 * L**2]]), rtol=1e-14)
    # no coupling between the chain and the beam
    assert np.all(sub(model, model.K(), ["1:x", "4:y"])[0, 1] == 0)


# --------------------------------------------------------------------------------------
# affine exactness against numeric rebuilds
# --------------------------------------------------------------------------------------
NAMES = ("E_beam", "k", "m", "rho", "A_rod")


def frame_structure(p: dict, as_parameters: bool, fixed=()) -> Structure:
    """A planar frame (4 beams in one group, one numeric-E beam), a rod, a spring and a mass.

    With ``as_parameters`` the properties in ``p`` are declared parameters; otherwise plain
    numbers (the second route).
    """
    s = Structure("affine")
    ref = (lambda n: n) if as_parameters else (lambda n: p[n])
    if as_parameters:
        for n in NAMES:
            s.parameter(n, p[n], bounds=(0.0, 1e13), fixed=n in fixed)
    s.add_nodes([1, 2, 3, 4, 5], [[0, 0], [1.0, 0.2], [2.1, 0], [1.0, 1.1], [2.0, 1.3]])
    s.beam2d([[1, 2], [2, 3], [2, 4], [4, 5]], E=ref("E_beam"), A=[1e-3, 2e-3, 1e-3, 1.5e-3],
             I=[1e-7, 3e-7, 2e-7, 1e-7], rho=ref("rho"))
    s.beam2d([3, 5], E=7.0e10, A=1e-3, I=1e-7, rho=ref("rho"), mass="lumped")
    s.rod([[1, 4]], E=1.9e11, A=ref("A_rod"), rho=7800.0, dim=2)
    s.spring(["5:y"], k=ref("k"))
    s.mass(["5:x", "5:y"], m=ref("m"))
    s.support(["1:x", "1:y", "1:rz", "3:y"])
    return s


P0 = {"E_beam": 2.0e11, "k": 3.0e5, "m": 4.5, "rho": 7600.0, "A_rod": 2e-4}


def numeric(p):
    model = frame_structure(p, as_parameters=False).build()
    return model, dense(model.K()), dense(model.M())


def test_model_equals_numeric_rebuild_at_any_parameter_values():
    model = frame_structure(P0, as_parameters=True).build()
    rng = np.random.default_rng(0)
    for _ in range(3):
        p = {n: P0[n] * rng.uniform(0.3, 3.0) for n in NAMES}
        ref, Kr, Mr = numeric(p)
        assert ref.dofs == model.dofs
        vec = np.array([p[n] for n in model.parameter_names])
        for values in (p, vec):
            np.testing.assert_allclose(dense(model.K(values)), Kr, rtol=0, atol=1e-12 * np.abs(Kr).max())
            np.testing.assert_allclose(dense(model.M(values)), Mr, rtol=0, atol=1e-12 * np.abs(Mr).max())


def test_derivatives_equal_central_differences_of_rebuilt_models():
    model = frame_structure(P0, as_parameters=True).build()
    for j, name in enumerate(model.parameter_names):
        for rel_step in (1e-3, 0.5):  # exact linearity: even a 50 % step gives the same slope
            h = rel_step * P0[name]
            _, Kp, Mp = numeric(P0 | {name: P0[name] + h})
            _, Km, Mm = numeric(P0 | {name: P0[name] - h})
            fdK, fdM = (Kp - Km) / (2 * h), (Mp - Mm) / (2 * h)
            dK, dM = dense(model.dK_dp(j)), dense(model.dM_dp(j))
            np.testing.assert_allclose(dK, fdK, rtol=0, atol=1e-9 * max(np.abs(dK).max(), 1e-300))
            np.testing.assert_allclose(dM, fdM, rtol=0, atol=1e-9 * max(np.abs(dM).max(), 1e-300))
        # and one-sided over a large step: K(p + Δ) - K(p) = Δ dK/dp exactly
        big = 2.0 * P0[name]
        _, K0, M0 = numeric(P0)
        _, K1, M1 = numeric(P0 | {name: P0[name] + big})
        np.testing.assert_allclose(K1 - K0, big * dense(model.dK_dp(j)), rtol=0, atol=1e-12 * np.abs(K1).max())
        np.testing.assert_allclose(M1 - M0, big * dense(model.dM_dp(j)), rtol=0, atol=1e-12 * np.abs(M1).max())


def test_which_matrices_each_parameter_enters():
    model = frame_structure(P0, as_parameters=True).build()
    idx = {n: model.parameter_index(n) for n in NAMES}
    enters = {n: (model.dK[idx[n]] is not None and model.dK[idx[n]].nnz > 0,
                  model.dM[idx[n]] is not None and model.dM[idx[n]].nnz > 0) for n in NAMES}
    assert enters == {"E_beam": (True, False), "k": (True, False), "m": (False, True),
                      "rho": (False, True), "A_rod": (True, True)}
    # the mass parameter: dM/dm = 1 on 5:x and 5:y, nothing else
    dM = dense(model.dM_dp(idx["m"]))
    expect = np.zeros_like(dM)
    for lab in ("5:x", "5:y"):
        expect[model.dofs.index(lab), model.dofs.index(lab)] = 1.0
    np.testing.assert_array_equal(dM, expect)
    # the spring: dK/dk = 1 at 5:y
    dK = dense(model.dK_dp(idx["k"]))
    assert dK[model.dofs.index("5:y"), model.dofs.index("5:y")] == 1.0 and np.count_nonzero(dK) == 1
    # A_rod enters K as (E/l) n n^T and M as (rho l / 6) [2 1; 1 2] at node 4 (node 1 is fixed)
    L = math.hypot(1.0, 1.1)
    n = np.array([1.0, 1.1]) / L
    np.testing.assert_allclose(sub(model, model.dK_dp(idx["A_rod"]), ["4:x", "4:y"]), 1.9e11 / L * np.outer(n, n),
                               rtol=1e-14)
    np.testing.assert_allclose(sub(model, model.dM_dp(idx["A_rod"]), ["4:x", "4:y"]), 7800 * L / 3 * np.eye(2),
                               rtol=1e-14)


def test_grouping_one_parameter_many_elements():
    """dK/dE = sum over the 4 grouped beams of their E = 1 stiffness; the numeric-E beam is in K0."""
    model = frame_structure(P0, as_parameters=True).build()
    j = model.parameter_index("E_beam")
    xyz = {1: (0, 0), 2: (1.0, 0.2), 3: (2.1, 0), 4: (1.0, 1.1), 5: (2.0, 1.3)}
    A, I = [1e-3, 2e-3, 1e-3, 1.5e-3], [1e-7, 3e-7, 2e-7, 1e-7]
    expect = np.zeros((model.n_dofs, model.n_dofs))
    for (a, b), Ae, Ie in zip([(1, 2), (2, 3), (2, 4), (4, 5)], A, I):
        xa, xb = np.array([[*xyz[a], 0.0]]), np.array([[*xyz[b], 0.0]])
        Ke = el.combine(el.beam2d_terms(xa, xb).K, {"E": 1.0, "A": Ae, "I": Ie})[0]
        labels = [f"{a}:x", f"{a}:y", f"{a}:rz", f"{b}:x", f"{b}:y", f"{b}:rz"]
        for r, lr in enumerate(labels):
            for c, lc in enumerate(labels):
                if lr in model.dofs and lc in model.dofs:
                    expect[model.dofs.index(lr), model.dofs.index(lc)] += Ke[r, c]
    np.testing.assert_allclose(dense(model.dK_dp(j)), expect, rtol=0, atol=1e-12 * np.abs(expect).max())
    # K0 holds what no parameter multiplies: the 7e10 beam and the rod is not in K0 (A_rod), the spring neither
    assert dense(model.K0)[model.dofs.index("5:rz"), model.dofs.index("5:rz")] > 0


def test_fixed_parameters_are_known_but_still_differentiable():
    model = frame_structure(P0, as_parameters=True, fixed=("rho", "k")).build()
    names = model.parameter_names
    assert [names[j] for j in model.free] == ["E_beam", "m", "A_rod"]
    assert [p.fixed for p in model.parameters] == [False, True, False, True, False]
    assert model.dK[names.index("k")].nnz == 1
    unfixed = model.with_fixed(["rho"], fixed=False)
    assert [unfixed.parameter_names[j] for j in unfixed.free] == ["E_beam", "m", "rho", "A_rod"]
    assert model.parameters[names.index("rho")].fixed  # the original is unchanged


def test_fixed_parameter_from_dict():
    d = {"parameters": {"k": {"value": 2.0, "fixed": True}, "c": {"value": 1.0}},
         "element": [{"type": "spring", "dofs": ["1:x"], "k": "k"}, {"type": "spring", "dofs": ["1:x", "2:x"], "k": "c"},
                     {"type": "mass", "dofs": ["1:x", "2:x"], "m": 1.0}]}
    model = Structure.from_dict(d).build()
    assert model.free.tolist() == [1]
    np.testing.assert_array_equal(dense(model.K()), [[3.0, -1.0], [-1.0, 1.0]])


def test_a_parameter_in_two_factors_of_different_terms_is_affine():
    """E in K (E A, E I) and rho in M: K(2E) = 2 K(E), M(2 rho) = 2 M(rho), K0 = M0 = 0."""
    s = Structure()
    s.parameter("E", 1.0)
    s.parameter("rho", 1.0)
    s.add_nodes([1, 2, 3], [[0, 0], [1, 0], [1, 1]])
    s.beam2d([[1, 2], [2, 3]], E="E", A=2.0, I=0.5, rho="rho")
    s.support_node([1])
    m = s.build()
    assert m.K0.nnz == 0 and m.M0.nnz == 0
    np.testing.assert_allclose(dense(m.K({"E": 2.0})), 2 * dense(m.K()), rtol=1e-15)
    np.testing.assert_allclose(dense(m.M({"rho": 3.0})), 3 * dense(m.M()), rtol=1e-15)
    assert not np.any([lab.startswith("1:") for lab in m.dofs])


# --------------------------------------------------------------------------------------
# the Appendix terms as parameters, through the dict form
# --------------------------------------------------------------------------------------
def _frame_dict(kind, terms=None, orientation=(0.0, 0.0, 1.0), per_plane=False, parameters=None):
    nodes = [{"id": i, "xyz": list(np.array([1.0, 2.0, 2.0]) / 3 * 0.4 * i)} for i in range(4)]
    elems = []
    for i in range(3):
        if kind == "frame3d":
            e = {"type": "frame3d", "E": 2.1e11, "G": 8e10, "A": 3e-3, "Iy": 4e-7, "Iz": 4e-7, "J": 6e-7}
        else:
            e = {"type": "frame3d_terms", "EA_l": terms["EA_l"], "GJ_l": terms["GJ_l"], "A": 3e-3, "Ip": 8e-7}
            for k in ("k12", "k6", "k2"):
                if per_plane:
                    e[k + "_y"] = terms[k + "_y"]
                    e[k + "_z"] = terms[k + "_z"]
                else:
                    e[k] = terms[k + "_z"]
        e |= {"nodes": [i, i + 1], "rho": 7850.0, "orientation": list(orientation)}
        elems.append(e)
    d = {"node": nodes, "element": elems, "support": [{"nodes": [0]}]}
    if parameters:
        d["parameters"] = parameters
    return d


def test_frame3d_terms_from_section_properties_equal_frame3d():
    pt = {k: float(v) for k, v in el.physical_terms_of_frame(2.1e11, 8e10, 3e-3, 4e-7, 4e-7, 6e-7, 0.4).items()}
    ref = Structure.from_dict(_frame_dict("frame3d")).build()
    for per_plane in (False, True):
        phy = Structure.from_dict(_frame_dict("frame3d_terms", pt, per_plane=per_plane)).build()
        assert phy.dofs == ref.dofs
        np.testing.assert_allclose(dense(phy.K()), dense(ref.K()), rtol=0, atol=1e-12 * np.abs(dense(ref.K())).max())
        np.testing.assert_allclose(dense(phy.M()), dense(ref.M()), rtol=1e-14, atol=1e-14 * np.abs(dense(ref.M())).max())


def test_frame3d_terms_shared_parameters_are_the_five_appendix_unknowns():
    """k12, k6, k2 shared by both planes: 5 parameters and dK/dk = sum of both plane units."""
    pt = {k: float(v) for k, v in el.physical_terms_of_frame(2.1e11, 8e10, 3e-3, 4e-7, 4e-7, 6e-7, 0.4).items()}
    names = {"EA_l": "EA_l", "GJ_l": "GJ_l", "k12_z": "k12", "k6_z": "k6", "k2_z": "k2"}
    params = {v: {"value": pt[k]} for k, v in names.items()}
    d = _frame_dict("frame3d_terms", {k: names.get(k, None) for k in pt}, parameters=params)
    model = Structure.from_dict(d).build()
    assert model.parameter_names == ("EA_l", "GJ_l", "k12", "k6", "k2")
    assert model.K0.nnz == 0  # every stiffness term is a parameter
    ref = Structure.from_dict(_frame_dict("frame3d")).build()
    np.testing.assert_allclose(dense(model.K()), dense(ref.K()), rtol=0, atol=1e-12 * np.abs(dense(ref.K())).max())
    # per-plane parameters with equal values give the same K, and their derivatives add up
    pp = {f"{b}_{s}": {"value": pt[f"{b}_z"]} for b in ("k12", "k6", "k2") for s in ("y", "z")}
    d2 = _frame_dict("frame3d_terms", {k: k for k in pt}, per_plane=True,
                     parameters={"EA_l": {"value": pt["EA_l"]}, "GJ_l": {"value": pt["GJ_l"]}} | pp)
    m2 = Structure.from_dict(d2).build()
    np.testing.assert_allclose(dense(m2.K()), dense(model.K()), rtol=0, atol=1e-12 * np.abs(dense(ref.K())).max())
    for b in ("k12", "k6", "k2"):
        both = dense(m2.dK_dp(m2.parameter_index(b + "_y"))) + dense(m2.dK_dp(m2.parameter_index(b + "_z")))
        np.testing.assert_allclose(dense(model.dK_dp(model.parameter_index(b))), both, rtol=0, atol=1e-12 * np.abs(both).max())
    # K is exactly linear in the five terms: K(p) = sum p_j dK_j
    p = model.values * np.array([1.3, 0.7, 2.0, 1.1, 0.9])
    np.testing.assert_allclose(dense(model.K(p)), sum(pj * dense(model.dK_dp(j)) for j, pj in enumerate(p)),
                               rtol=0, atol=1e-12 * np.abs(dense(model.K(p))).max())


def test_beam2d_terms_parameters():
    d = {"parameters": {"k12": {"value": 12.0}, "k6": {"value": 6.0}, "k2": {"value": 2.0}},
         "node": [{"id": 1, "xyz": [0, 0]}, {"id": 2, "xyz": [1, 0]}],
         "element": [{"type": "beam2d_terms", "nodes": [1, 2], "EA_l": 5.0, "k12": "k12", "k6": "k6", "k2": "k2",
                      "rho": 1.0, "A": 1.0}],
         "support": [{"dofs": ["1:x", "1:y", "1:rz"]}]}
    model = Structure.from_dict(d).build()
    assert model.dofs == ("2:x", "2:y", "2:rz")
    # free end of one element: F = k12 w - k6 t, M = -k6 w + 2 k2 t (paper's rows for node 2)
    np.testing.assert_array_equal(dense(model.dK_dp(0)), [[0, 0, 0], [0, 1, 0], [0, 0, 0]])
    np.testing.assert_array_equal(dense(model.dK_dp(1)), [[0, 0, 0], [0, 0, -1], [0, -1, 0]])
    np.testing.assert_array_equal(dense(model.dK_dp(2)), [[0, 0, 0], [0, 0, 0], [0, 0, 2]])
    np.testing.assert_array_equal(dense(model.K0), [[5, 0, 0], [0, 0, 0], [0, 0, 0]])
    # E I = 1, l = 1 beam: the textbook tip stiffness [[12, -6], [-6, 4]]
    np.testing.assert_array_equal(dense(model.K())[1:, 1:], [[12, -6], [-6, 4]])


# --------------------------------------------------------------------------------------
# bad input through the dict (TOML) form: InputError naming the culprit
# --------------------------------------------------------------------------------------
def base_dict():
    return {
        "model": {"name": "bad"},
        "parameters": {"E": {"value": 2e11, "bounds": [1e11, 3e11]}, "k": {"value": 5.0}, "m": {"value": 2.0}},
        "node": [{"id": 1, "xyz": [0, 0, 0]}, {"id": 2, "xyz": [1, 0, 0]}, {"id": 3, "xyz": [2, 0, 0]},
                 {"id": 4, "xyz": [2, 1, 0]}],
        "element": [
            {"type": "beam2d", "nodes": [1, 2], "E": "E", "A": 1e-3, "I": 1e-6, "rho": 7800.0},
            {"type": "beam2d", "nodes": [2, 3], "E": "E", "A": 1e-3, "I": 1e-6, "rho": 7800.0},
            {"type": "spring", "dofs": ["3:y"], "k": "k"},
            {"type": "mass", "dofs": ["3:y"], "m": "m"},
        ],
        "support": [{"dofs": ["1:x", "1:y", "1:rz"]}],
    }


def _frame_elements(d, second_orientation):
    d["element"][:2] = [
        {"type": "frame3d", "nodes": [1, 2], "E": "E", "G": 8e10, "A": 1e-3, "Iy": 1e-7, "Iz": 2e-7, "J": 1e-7,
         "rho": 7800.0, "orientation": [0, 1, 0]},
        {"type": "frame3d", "nodes": [2, 3], "E": "E", "G": 8e10, "A": 1e-3, "Iy": 1e-7, "Iz": 2e-7, "J": 1e-7,
         "rho": 7800.0, "orientation": second_orientation},
    ]
    d["support"][0]["dofs"] = ["1:x", "1:y", "1:z", "1:rx", "1:ry", "1:rz"]


def test_base_dict_is_valid():
    model = Structure.from_dict(base_dict()).build()
    assert model.parameter_names == ("E", "k", "m")


BAD = {
    # name: (mutation, fragments the message must contain)
    "unknown element type": (lambda d: d["element"][1].update(type="beam3"), ["element #2", "'beam3'"]),
    "undeclared parameter": (lambda d: d["element"][1].update(E="E_alu"), ["element #2", "'E_alu'", "E"]),
    "unknown node": (lambda d: d["element"][1].update(nodes=[2, 9]), ["element #2", "9"]),
    "element joining a node to itself": (lambda d: d["element"][1].update(nodes=[2, 2]), ["element #2", "node 2"]),
    "zero length, alone in its group": (
        lambda d: d["node"].append({"id": 5, "xyz": [2, 1, 0]})
        or d["element"].append({"type": "rod", "nodes": [4, 5], "E": 1.0, "A": 1.0, "rho": 1.0}),
        ["element #5", "zero"]),
    "negative mass": (lambda d: d["element"][3].update(m=-1.0), ["element #4", "m", "-1"]),
    "zero mass": (lambda d: d["element"][3].update(m=0.0), ["element #4", "mass", "m"]),
    "zero density": (lambda d: d["element"][1].update(rho=0.0), ["element #2", "rho"]),
    "negative density": (lambda d: d["element"][0].update(rho=-7800.0), ["element #1", "rho"]),
    "mass parameter with zero value": (lambda d: d["parameters"]["m"].update(value=0.0), ["element #4", "'m'"]),
    "mass parameter with negative value": (lambda d: d["parameters"]["m"].update(value=-2.0), ["element #4", "'m'"]),
    # E and I (or A and rho) both parameters: a product E*I, a non-linear term of the model since
    # issue 28 item 2 (tests/test_nonlinear_parameters.py), no longer refused
    "unknown element key": (lambda d: d["element"][1].update(colour="red"), ["element #2", "colour"]),
    "unknown top-level key": (lambda d: d.update(elements=[]), ["elements"]),
    "unknown parameter key": (lambda d: d["parameters"]["E"].update(bound=[1, 2]), ["parameters.E", "bound"]),
    "parameter value outside bounds": (lambda d: d["parameters"]["E"].update(value=5e11), ["'E'", "bounds"]),
    "bounds reversed": (lambda d: d["parameters"]["E"].update(bounds=[3e11, 1e11]), ["'E'", "bounds"]),
    "parameter without value": (lambda d: d["parameters"]["k"].pop("value"), ["parameters.k", "value"]),
    "orientation parallel, alone in its group": (
        lambda d: _frame_elements(d, [0, 1, 0]) or d["element"][0].update(orientation=[-3, 0, 0]),
        ["element #1", "parallel"]),
    "frame without orientation": (lambda d: _frame_elements(d, None) or d["element"][1].pop("orientation"),
                                  ["element #2", "orientation"]),
    "support dof not in any element": (lambda d: d["support"][0].update(dofs=["1:x", "7:y"]), ["7:y"]),
    "support dof in a direction no element has": (lambda d: d["support"][0].update(dofs=["1:x", "1:z"]), ["1:z"]),
    "support node not in any element": (lambda d: d["support"].append({"nodes": [42]}), ["42"]),
    "malformed support label": (lambda d: d["support"][0].update(dofs=["1:q"]), ["support #1", "'1:q'"]),
    "declared but unused parameter": (lambda d: d["parameters"].update(G_unused={"value": 1.0}), ["G_unused"]),
    "missing property": (lambda d: d["element"][1].pop("I"), ["element #2", "I"]),
    "property of the wrong type": (lambda d: d["element"][1].update(A=[1e-3]), ["element #2", "A"]),
    "boolean property": (lambda d: d["element"][1].update(A=True), ["element #2", "A"]),
    "unknown mass kind": (lambda d: d["element"][1].update(mass="lumpy"), ["element #2", "'lumpy'"]),
    "bad dof direction": (lambda d: d["element"][2].update(dofs=["3:q"]), ["element #3", "'3:q'"]),
    "spring with three dofs": (lambda d: d["element"][2].update(dofs=["3:y", "2:y", "1:y"]), ["element #3", "3"]),
    "zero stiffness": (lambda d: d["element"][2].update(k=0.0), ["element #3", "k"]),
    "infinite property": (lambda d: d["element"][2].update(k=math.inf), ["element #3", "k"]),
    "beam2d out of plane": (lambda d: d["node"][0].update(xyz=[0, 0, 0.5]), ["element #1", "plane"]),
    "rod of dimension 4": (
        lambda d: d["element"].append({"type": "rod", "nodes": [3, 4], "E": 1.0, "A": 1.0, "rho": 1.0, "dim": 4}),
        ["element #5", "dim"]),
    "element list not a list of tables": (lambda d: d.update(element={"type": 3} and 5), ["element"]),
    "nothing free": (lambda d: d["support"].append({"nodes": [2, 3]}), ["nothing is free"]),
    "parameter name not an identifier": (lambda d: d["parameters"].update({"2k": {"value": 1.0}}), ["'2k'"]),
}

# Bad input that structure.py once reported against the wrong element or let escape as a
# non-InputError (fixed); the third entry says what used to go wrong.
BAD_FIXED = {
    "zero length, second of its group": (
        lambda d: d["node"][2].update(xyz=[1, 0, 0]), ["element #2", "zero"],
        "structure._terms names the group's first element (#1), not the zero-length one"),
    "orientation parallel, second of its group": (
        lambda d: _frame_elements(d, [2, 0, 0]), ["element #2", "parallel"],
        "structure._terms names the group's first element (#1), not the culprit"),
    "beam2d out of plane, second of its group": (
        lambda d: d["node"][2].update(xyz=[2, 0, 0.5]), ["element #2", "plane"],
        "structure._terms names the group's first element (#1), not the culprit"),
    "non-integer node id in an element": (
        lambda d: d["element"][1].update(nodes=[2.5, 3]), ["element #2", "2.5"],
        "_node_pairs truncates 2.5 to node 2 (astype(int64)) and builds a different structure"),
    "NaN node id in an element": (
        lambda d: d["element"][1].update(nodes=[math.nan, 3]), ["element #2"],
        "_node_pairs casts NaN to an integer (RuntimeWarning, an error under this pytest config)"),
    "infinite node id": (
        lambda d: d["node"][1].update(id=math.inf), ["node #2"],
        "int(inf) raises OverflowError, which from_dict does not catch"),
    "bounds not a pair": (
        lambda d: d["parameters"]["E"].update(bounds=2.5e11), ["'E'", "bounds"],
        "Structure.parameter calls tuple(bounds): TypeError escapes"),
    "element type not a string": (
        lambda d: d["element"][1].update(type=["beam2d"]), ["element #2", "type"],
        "`t not in _PROPS` with an unhashable t raises TypeError"),
    "element nodes ragged": (
        lambda d: d["element"][1].update(nodes=[[2], 3]), ["element #2", "nodes"],
        "np.asarray on a ragged list raises ValueError before the check"),
    "NaN coordinates": (
        lambda d: d["node"][1].update(xyz=[math.nan, 0, 0]), ["node #2", "NaN"],
        "from_dict catches InputError as ValueError: the NaN message becomes 'id must be an integer...'"),
    "node defined twice": (
        lambda d: d["node"][1].update(id=1), ["node #2", "defined twice"],
        "from_dict catches InputError as ValueError and replaces the message"),
    "key that does not apply to the type": (
        lambda d: d["element"][1].update(orientation=[0, 0, 1]), ["element #2", "orientation"],
        "beam2d silently accepts 'orientation', 'dofs' and 'dim'"),
    "unknown node key": (
        lambda d: d["node"][1].update(xzy=[1, 0, 0]), ["node #2", "xzy"],
        "[[node]] tables are not checked for unknown keys"),
    "fixed given as a string": (
        lambda d: d["parameters"]["k"].update(fixed="no"), ["'k'", "fixed"],
        "'fixed' is passed through bool(), so 'no' means fixed = true"),
}


def _check_bad(mutate, fragments):
    d = base_dict()
    mutate(d)
    with pytest.raises(InputError) as ei:
        Structure.from_dict(d, source="bad.toml").build()
    msg = str(ei.value)
    for frag in fragments:
        assert frag in msg, f"{frag!r} not in message: {msg}"
    return msg


@pytest.mark.parametrize("case", list(BAD))
def test_bad_input_names_the_culprit(case):
    mutate, fragments = BAD[case]
    msg = _check_bad(mutate, fragments)
    assert "\n" not in msg


@pytest.mark.parametrize("case", list(BAD_FIXED))
def test_bad_input_names_the_culprit_formerly_buggy(case):
    mutate, fragments, _ = BAD_FIXED[case]
    _check_bad(mutate, fragments)


def test_bad_input_messages_name_the_source_file():
    d = base_dict()
    d["element"][1]["type"] = "beam3"
    with pytest.raises(InputError, match=r"^bad\.toml: element #2"):
        Structure.from_dict(d, source="bad.toml")


def test_structure_without_elements():
    with pytest.raises(InputError, match="no elements"):
        Structure("empty").build()
    with pytest.raises(InputError, match="top level"):
        Structure.from_dict([1, 2])


# --------------------------------------------------------------------------------------
# property tests
# --------------------------------------------------------------------------------------
positive = st.floats(min_value=1e-3, max_value=1e3, allow_nan=False, allow_infinity=False)


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(k=st.lists(positive, min_size=1, max_size=8), m=st.data(), scale=st.floats(0.1, 10.0))
def test_spring_chain_is_symmetric_and_linear_in_its_parameters(k, m, scale):
    """Grounded chain 1-2-...-n: K is the closed-form tridiagonal matrix and K(p) is linear."""
    n = len(k)
    masses = m.draw(st.lists(positive, min_size=n, max_size=n))
    d = {"parameters": {f"k{i}": {"value": v} for i, v in enumerate(k)},
         "element": [{"type": "spring", "dofs": [f"{i}:x"] if i == 0 else [f"{i - 1}:x", f"{i}:x"], "k": f"k{i}"}
                     for i in range(n)]
         + [{"type": "mass", "dofs": [f"{i}:x"], "m": mi} for i, mi in enumerate(masses)]}
    model = Structure.from_dict(d).build()
    assert model.dofs == tuple(f"{i}:x" for i in range(n))
    K = dense(model.K())
    np.testing.assert_array_equal(K, K.T)
    expect = np.zeros((n, n))
    for i, ki in enumerate(k):
        expect[i, i] += ki
        if i > 0:
            expect[i - 1, i - 1] += ki
            expect[i - 1, i] -= ki
            expect[i, i - 1] -= ki
    np.testing.assert_allclose(K, expect, rtol=1e-14)
    np.testing.assert_array_equal(dense(model.M()), np.diag(masses))
    assert model.K0.nnz == 0
    # linear (no constant part): K(a p + b q) = a K(p) + b K(q)
    p, q = np.array(k), np.array(k)[::-1] * scale
    a, b = 0.75, 1.5
    np.testing.assert_allclose(dense(model.K(a * p + b * q)), a * dense(model.K(p)) + b * dense(model.K(q)),
                               rtol=1e-12, atol=1e-12 * np.abs(K).max())
    # positive definite: a grounded chain with positive springs
    assert np.linalg.eigvalsh(K).min() > 0


JUNK_VALUES = [None, -1, 0, 3, 2.5, math.nan, math.inf, -math.inf, "", "x", "1", True, [], [1], [1, 2, 3],
               [[1, 2]], [1, "a"], {}, {"a": 1}]
# floats of physical magnitude plus the non-finite ones (1e300-metre members overflow l^3: not a parser matter)
JUNK = st.one_of(st.none(), st.integers(-3, 3), st.floats(-1e6, 1e6),
                 st.sampled_from([math.nan, math.inf, -math.inf]),
                 st.text(max_size=4), st.booleans(), st.lists(st.integers(-1, 5), max_size=4),
                 st.lists(st.one_of(st.integers(0, 3), st.text(max_size=2)), max_size=3),
                 st.dictionaries(st.text(max_size=3), st.integers(), max_size=2))


def _paths(obj, prefix=()):
    if isinstance(obj, dict):
        for k, v in obj.items():
            yield prefix + (k,)
            yield from _paths(v, prefix + (k,))
    elif isinstance(obj, list):
        for i, v in enumerate(obj):
            yield prefix + (i,)
            yield from _paths(v, prefix + (i,))


BASE_PATHS = list(_paths(base_dict()))


def _corrupt(path, junk):
    d = base_dict()
    target = d
    for key in path[:-1]:
        target = target[key]
    target[path[-1]] = junk
    return d


def _escapes(cases):
    out = []
    for path, junk in cases:
        try:
            Structure.from_dict(_corrupt(path, junk)).build()
        except InputError as exc:
            assert str(exc)
        except Exception as exc:  # noqa: BLE001 - that is what the test looks for
            out.append((path, junk, type(exc).__name__))
    return out


def test_every_corrupted_value_gives_input_error_or_a_model():
    assert _escapes([(p, j) for p in BASE_PATHS for j in JUNK_VALUES]) == []


@settings(max_examples=150, deadline=None)
@given(path=st.sampled_from(BASE_PATHS), junk=JUNK)
def test_random_corruption_gives_input_error_or_a_model(path, junk):
    assert _escapes([(path, junk)]) == []


def test_a_node_id_beyond_64_bits_is_refused_by_name():
    """Node ids are tabled as 64-bit integers (the node-block assembly): one beyond is refused when
    the node is added, not met as an OverflowError while building (found by tests/test_fuzz.py)."""
    from femupdate import InputError, Structure

    s = Structure("big ids")
    s.node(2**63 - 1, [0.0, 0.0])  # the largest that fits
    with pytest.raises(InputError, match=r"node id 9223372036854775808: out of range"):
        s.node(2**63, [1.0, 0.0])
