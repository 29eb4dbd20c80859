"""Exact multipoint constraints (rigid links, equal-dof ties), beam end offsets and point masses:
closed forms, a penalty model converging to the exact one, parameter Jacobians against finite
differences of rebuilt structures, the model-file form against the Python one, recovery of the
dependent dofs, and bad input refused by name (exit 2 from the command line)."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import scipy.linalg as sl

import femupdate as fu
from femupdate._errors import InputError
from femupdate.constraints import expand_shapes
from femupdate.modal import model_modes
from femupdate.sensitivity import eigenvalue_derivatives

ENV = {**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[1] / "src")}


def eig(model, values=None):
    return sl.eigh(model.K(values).toarray(), model.M(values).toarray(), eigvals_only=True)


# ----------------------------------------------------------------------------- closed forms
def arm(route: str, kz=4.0e4, kt=9.0e3, m=12.0, J=0.8, L=0.7):
    """A mass on a rigid arm of length L (along x) from node 1, which sits on a vertical spring kz and a
    rotational spring kt about y: by a rigid link to a point mass at node 2, or by the point mass's offset."""
    s = fu.Structure("arm")
    s.node(1, [0, 0, 0])
    s.spring(["1:z"], k=kz)
    s.spring(["1:ry"], k=kt)
    inertia = np.diag([1.0, J, 1.0])
    if route == "link":
        s.node(2, [L, 0, 0])
        s.point_mass(2, m, inertia=inertia)
        s.rigid_link(1, 2)
    else:
        s.point_mass(1, m, offset=[L, 0, 0], inertia=inertia)
    s.support(["1:x", "1:y", "1:rx", "1:rz"])
    return s.build()


@pytest.mark.parametrize("route", ["link", "offset"])
def test_mass_on_rigid_arm_closed_form(route):
    """w (up) and θ (about y): the mass centre moves w − θ L, so M = [[m, −mL], [−mL, mL² + J]],
    K = diag(kz, kt); λ solves m J λ² − (kz (m L² + J) + kt m) λ + kz kt = 0."""
    kz, kt, m, J, L = 4.0e4, 9.0e3, 12.0, 0.8, 0.7
    model = arm(route, kz, kt, m, J, L)
    assert model.dofs == ("1:z", "1:ry")
    a, b, c = m * J, -(kz * (m * L**2 + J) + kt * m), kz * kt
    exact = np.sort([(-b - np.sqrt(b * b - 4 * a * c)) / (2 * a), (-b + np.sqrt(b * b - 4 * a * c)) / (2 * a)])
    assert np.allclose(eig(model), exact, rtol=1e-12, atol=0)


def test_rigid_bar_on_two_springs_closed_form():
    """A rigid bar (mass m, inertia J about its centre) on springs k1, k2 at its ends ±L/2, its ends
    rigidly linked (z only) to its centre: K = [[k1 + k2, (k1 − k2) L/2], [., (k1 + k2) L²/4]], M = diag(m, J)."""
    m, J, L, k1, k2 = 30.0, 2.5, 1.6, 2.0e4, 5.0e4
    s = fu.Structure("bar")
    for i, x in ((1, -L / 2), (2, L / 2), (3, 0.0)):
        s.node(i, [x, 0, 0])
    s.spring(["1:z"], k=k1)
    s.spring(["2:z"], k=k2)
    s.point_mass(3, m, inertia=np.diag([1.0, J, 1.0]))
    s.rigid_link(3, [1, 2], dofs=["z"])
    s.support(["3:x", "3:y", "3:rx", "3:rz"])
    model = s.build()
    assert model.dofs == ("3:z", "3:ry") and model.constraints.labels == ("1:z", "2:z")
    K = np.array([[k1 + k2, (k1 - k2) * L / 2], [(k1 - k2) * L / 2, (k1 + k2) * L**2 / 4]])
    exact = sl.eigh(K, np.diag([m, J]), eigvals_only=True)
    assert np.allclose(eig(model), exact, rtol=1e-12, atol=0)
    # the dependent dofs recovered: end displacements w ∓ θ... of each mode
    modes = model_modes(model)
    labels, full = expand_shapes(model, modes.shapes)
    w, th = full[0], full[1]
    assert labels[2:] == ("1:z", "2:z")
    assert np.allclose(full[2], w + th * L / 2, rtol=1e-13) and np.allclose(full[3], w - th * L / 2, rtol=1e-13)


# ----------------------------------------------------------------------------- penalty convergence
def cantilever_with_arm(stiff: float | None):
    """A 2 m cantilever (frame3d) with a 0.5 m arm at its tip carrying a point mass; the arm is a rigid
    link (stiff None), or a frame member whose E is ``stiff`` times the cantilever's (a penalty)."""
    E, G, A, Iy, Iz = 70e9, 26e9, 1e-4, 1e-9, 2e-9
    s = fu.Structure("arm")
    s.parameter("E", E)
    for i, x in ((1, (0, 0, 0)), (2, (2, 0, 0)), (3, (2, 0.5, 0.2))):
        s.node(i, x)
    s.frame3d([1, 2], E="E", G=G, A=A, Iy=Iy, Iz=Iz, J=Iy + Iz, rho=2700.0, orientation=(0, 0, 1))
    s.point_mass(3, 1.5, inertia=np.diag([1e-3, 2e-3, 3e-3]))
    if stiff is None:
        s.rigid_link(2, 3)
    else:
        s.frame3d([2, 3], E=stiff * E, G=stiff * G, A=A, Iy=Iy, Iz=Iz, J=Iy + Iz, rho=1e-9, orientation=(0, 0, 1))
    s.support_node([1])
    return s.build()


def test_penalty_arm_converges_to_the_exact_link():
    exact = np.sqrt(eig(cantilever_with_arm(None))[:4])
    errors = [np.max(np.abs(np.sqrt(eig(cantilever_with_arm(f))[:4]) - exact) / exact) for f in (1e1, 1e2, 1e3, 1e4)]
    ratios = np.array(errors[:-1]) / np.array(errors[1:])
    assert np.all(ratios > 8) and np.all(ratios < 12), errors  # error ∝ 1 / penalty
    assert errors[-1] < 2e-5  # (stiffer, round-off takes over: eps times the stiff arm's eigenvalue ratio)


# ----------------------------------------------------------------------------- Jacobians
def linked_structure(v):
    """Parameters in every place a link touches: E of an offset frame, k of a spring at a dependent
    node, the point mass m on a dependent node."""
    s = fu.Structure("jac")
    s.parameter("E", v["E"])
    s.parameter("k", v["k"])
    s.parameter("m", v["m"])
    nodes = {1: (0, 0, 0), 2: (1.5, 0, 0), 3: (3, 0, 0), 4: (1.5, 0.4, 0.3), 5: (3.2, 0.1, -0.2)}
    for i, x in nodes.items():
        s.node(i, x)
    common = dict(G=27e9, A=2e-4, Iy=3e-9, Iz=5e-9, J=8e-9, rho=2700.0, orientation=(0, 0, 1))
    s.frame3d([1, 2], E="E", **common)
    s.frame3d([2, 3], E="E", offsets=[[0, 0.05, 0.02], [0.03, 0, -0.04]], **common)
    s.rigid_link(2, 4, dofs=["x", "y", "z"])  # node 4 has translations only (a spring, a plain point mass)
    s.rigid_link(3, 5)
    s.spring(["4:z"], k="k")
    s.point_mass(5, "m", offset=[0.1, 0, 0], inertia=np.diag([1e-3, 1e-3, 2e-3]))
    s.point_mass(4, 0.7)
    s.support_node([1])
    return s.build()


def test_jacobian_matches_finite_differences_of_rebuilt_structures():
    v0 = {"E": 70e9, "k": 3e4, "m": 2.0}
    model = linked_structure(v0)
    modes = model_modes(model, n_modes=6)
    dlam = eigenvalue_derivatives(model, modes)
    for j, name in enumerate(v0):
        h = 1e-3 * v0[name]  # central differences: truncation ~ h², far above the eigensolver's round-off
        up = eig(linked_structure({**v0, name: v0[name] + h}))[:6]
        down = eig(linked_structure({**v0, name: v0[name] - h}))[:6]
        fd = (up - down) / (2 * h)
        assert np.allclose(dlam[:, j], fd, rtol=1e-5, atol=1e-7 * np.abs(fd).max()), (name, dlam[:, j], fd)


# ----------------------------------------------------------------------------- the model file
TOML = """
[model]
name = "linked"
[parameters.k]
value = 3.0e4
[[node]]
id = 1
xyz = [0, 0, 0]
[[node]]
id = 2
xyz = [1.5, 0, 0]
[[node]]
id = 3
xyz = [1.5, 0.4, 0.3]
[[node]]
id = 4
xyz = [1.5, 0.4, 0.3]
[[element]]
type = "frame3d"
nodes = [1, 2]
E = 70e9
G = 27e9
A = 2e-4
Iy = 3e-9
Iz = 5e-9
J = 8e-9
rho = 2700
orientation = [0, 0, 1]
offsets = [[0, 0, 0], [0.02, 0.01, 0]]
[[element]]
type = "spring"
dofs = ["3:z"]
k = "k"
[[element]]
type = "point_mass"
node = 4
m = 1.5
offset = [0.1, 0, 0]
inertia = [1e-3, 0, 1e-3, 0, 0, 2e-3]
[[constraint]]
type = "rigid"
independent = 2
dependent = [3]
[[constraint]]
type = "equal"
independent = 2
dependent = 4
dofs = ["x", "y", "z", "rx", "ry", "rz"]
[[support]]
nodes = [1]
"""


def python_twin():
    s = fu.Structure("linked")
    s.parameter("k", 3.0e4)
    for i, x in ((1, (0, 0, 0)), (2, (1.5, 0, 0)), (3, (1.5, 0.4, 0.3)), (4, (1.5, 0.4, 0.3))):
        s.node(i, x)
    s.frame3d([1, 2], E=70e9, G=27e9, A=2e-4, Iy=3e-9, Iz=5e-9, J=8e-9, rho=2700.0, orientation=(0, 0, 1),
              offsets=[[0, 0, 0], [0.02, 0.01, 0]])
    s.spring(["3:z"], k="k")
    s.point_mass(4, 1.5, offset=[0.1, 0, 0], inertia=np.diag([1e-3, 1e-3, 2e-3]))
    s.rigid_link(2, 3)
    s.equal_dofs(2, 4, ["x", "y", "z", "rx", "ry", "rz"])
    s.support_node([1])
    return s.build()


def test_model_file_matches_python():
    import tomllib

    a = fu.Structure.from_dict(tomllib.loads(TOML), "linked.toml").build()
    b = python_twin()
    assert a.dofs == b.dofs == tuple(f"2:{d}" for d in ("x", "y", "z", "rx", "ry", "rz"))
    for A, B in ((a.K0, b.K0), (a.M0, b.M0), (a.dK[0], b.dK[0])):
        assert abs(A - B).max() == 0
    assert a.constraints.sources[0].startswith("linked.toml: constraint #1 (rigid)")


def test_model_file_runs_modes_and_refuses_a_chain(tmp_path):
    """The file runs ``modes``; tying node 4 to node 3 instead (3 is dependent on 2: a chain) is refused
    by name, exit 2."""
    (tmp_path / "ok.toml").write_text(TOML)
    r = subprocess.run([sys.executable, "-m", "femupdate", "modes", "ok.toml"], cwd=tmp_path, capture_output=True,
                       text=True, env=ENV)
    assert r.returncode == 0, r.stderr
    (tmp_path / "m.toml").write_text(TOML.replace("independent = 2\ndependent = 4", "independent = 3\ndependent = 4"))
    r = subprocess.run([sys.executable, "-m", "femupdate", "modes", "m.toml"], cwd=tmp_path, capture_output=True,
                       text=True, env=ENV)
    assert r.returncode == 2 and "constraints chained" in r.stderr and "constraint #2 (equal)" in r.stderr, r.stderr
    assert "Traceback" not in r.stderr


# ----------------------------------------------------------------------------- bad input
def base():
    s = fu.Structure("bad")
    for i in range(1, 6):
        s.node(i, [i, 0, 0])
    s.frame3d([[1, 2], [2, 3], [3, 4], [4, 5]], E=1e9, G=4e8, A=1e-3, Iy=1e-7, Iz=1e-7, J=2e-7, rho=1e3,
              orientation=(0, 0, 1))
    s.support_node([1])
    return s


@pytest.mark.parametrize("make, message", [
    (lambda s: (s.rigid_link(2, 4), s.rigid_link(3, 4, where="link B")), "dof 4:x is dependent twice: in rigid link and in link B"),
    (lambda s: (s.rigid_link(2, 3, where="A"), s.rigid_link(3, 4, where="B")), "constraints chained: dof 3:"),
    (lambda s: (s.rigid_link(2, 3, where="A"), s.rigid_link(3, 2, where="B")), "constraints chained"),
    (lambda s: (s.rigid_link(2, 1, where="to the support")), "dof 1:x is supported but is a dependent dof of to the support"),
    (lambda s: s.rigid_link(3, 3), "node 3 is both the independent node and a dependent one"),
    (lambda s: s.rigid_link(2, 9), "dependent node 9 has none of the dofs"),
    (lambda s: s.rigid_link(2, [4, 4]), "dependent node 4 listed twice"),
    (lambda s: s.rigid_link(2, 4, dofs=["q"]), "direction 'q' is not one of"),
    (lambda s: (s.node(9, [9, 0, 0]), s.spring(["9:z"], k=1.0), s.equal_dofs(2, 9, ["x"], where="tie")),
     "tie: dependent node 9 has no dof x"),
    (lambda s: s.point_mass(3, 1.0, inertia=[[1, 2, 0], [0, 1, 0], [0, 0, 1]]), "inertia must be a symmetric"),
    (lambda s: s.frame3d([2, 4], E=1e9, G=4e8, A=1e-3, Iy=1e-7, Iz=1e-7, J=2e-7, rho=1e3, orientation=(0, 0, 1),
                         offsets=[0, 0, 1]), "offsets must be"),
])
def test_bad_constraints_refused_by_name(make, message):
    s = base()
    with pytest.raises(InputError) as exc:
        make(s)
        s.build()
    assert message in str(exc.value), str(exc.value)


def test_supported_dependent_with_supported_independent_is_consistent():
    """A dependent dof fixed, its independent dofs fixed too: both sides zero, the row is dropped."""
    s = base()
    s.node(6, [0, 0.5, 0])
    s.point_mass(6, 2.0)
    s.rigid_link(1, 6)  # node 1 is fully supported
    s.support(["6:x"])
    m = s.build()
    assert not any(d.startswith("6:") for d in m.dofs)
    assert m.constraints.labels == ("6:y", "6:z")


def test_dependent_dof_in_test_data_is_named():
    s = base()
    s.rigid_link(2, 3)
    m = s.build()
    with pytest.raises(InputError, match="dof '3:z' is a dependent dof of rigid link"):
        m.dof_index(["2:z", "3:z"], "test mode 1 shape")


def test_damage_element_parameters_keep_links_offsets_and_point_masses():
    """Damage detection rebuilds the structure with one parameter per element: its model at the nominal
    values is the original one (links, offsets, torsion mass and point masses carried over)."""
    from femupdate.damage.parameters import element_parameters

    s = fu.Structure("jac")
    s.parameter("E", 70e9)
    for i, x in {1: (0, 0, 0), 2: (1.5, 0, 0), 3: (3, 0, 0), 4: (1.5, 0.4, 0.3)}.items():
        s.node(i, x)
    common = dict(G=27e9, A=2e-4, Iy=3e-9, Iz=5e-9, J=8e-9, rho=2700.0, orientation=(0, 0, 1))
    s.frame3d([1, 2], E="E", torsion_mass=False, **common)
    s.frame3d([2, 3], E="E", offsets=[[0, 0.05, 0.02], [0.03, 0, -0.04]], **common)
    s.rigid_link(2, 4)
    s.point_mass(4, 0.7, offset=[0.1, 0, 0], inertia=np.diag([1e-3, 1e-3, 2e-3]))
    s.support_node([1])
    a = s.build()
    out, _ = element_parameters(s)
    b = out.build()
    assert a.dofs == b.dofs and a.constraints.labels == b.constraints.labels
    assert abs(a.K() - b.K()).max() <= 1e-12 * abs(a.K()).max() and abs(a.M() - b.M()).max() <= 1e-12 * abs(a.M()).max()


def test_solid_with_a_rigid_spider_keeps_exactly_six_rigid_body_modes():
    """A free hexahedral block whose end face is joined by a rigid spider (a rigid link on the face's
    translations) to a reference node off the block carrying an offset point mass: rigid motions of the
    whole are admissible, so exactly 6 zero modes (a wrong lever arm that varies over the face would lose
    rotations; one the same for every face node, here r_x, is absorbed by the reference node's motion)."""
    from _meshes3d import box_hex

    nodes, conn = box_hex(4, 1, 1, size=(2.0, 0.5, 0.5))

    def block():
        s = fu.Structure("block")
        s.add_nodes(np.arange(1, len(nodes) + 1), nodes)
        s.solid(conn + 1, E=7e10, nu=0.3, rho=2700.0)
        s.node(1000, [2.3, 0.25, 0.25])
        face = [int(i) + 1 for i in np.flatnonzero(np.isclose(nodes[:, 0], 2.0))]
        s.point_mass(1000, 5.0, offset=[0.1, 0.05, 0.0], inertia=np.diag([0.1, 0.2, 0.3]))
        s.rigid_link(1000, face)
        return s.build()

    lam = eig(block())
    scale = lam.max()
    assert np.sum(np.abs(lam) < 1e-10 * scale) == 6 and lam[6] > 1e-6 * scale, lam[:8]
