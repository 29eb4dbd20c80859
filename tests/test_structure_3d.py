"""Shells and solids in a Structure and in a TOML model file, mixed with frames, springs and masses:
the assembled model equals a direct assembly of the element stacks, parameters by element set,
and bad input is refused with a message naming it."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg as sl
import scipy.sparse.linalg as sla

from femupdate._errors import InputError
from femupdate.elements_3d import hex8_terms, mitc4_terms
from femupdate.io.model_file import load_model
from femupdate.structure import Structure

from _meshes3d import assemble, box_hex, plate_mesh


def _plate_structure(n=4, E="E_plate"):
    nodes, conn = plate_mesh(n, a=0.6)
    s = Structure("plate")
    s.add_nodes(np.arange(1, len(nodes) + 1), nodes)
    s.parameter("E_plate", 70e9, bounds=(1e9, 1e12))
    s.shell(conn + 1, E=E, nu=0.33, t=0.004, rho=2700.0, where="plate")
    return s, nodes, conn


def test_shell_structure_equals_the_direct_assembly_and_is_linear_in_E():
    s, nodes, conn = _plate_structure()
    model = s.build()
    K, M = assemble(mitc4_terms(nodes[conn], 0.33), conn, len(nodes), 6, {"E": 70e9, "t": 0.004, "rho": 2700.0})
    order = [6 * (int(lab.split(":")[0]) - 1) + "x y z rx ry rz".split().index(lab.split(":")[1]) for lab in model.dofs]
    assert np.abs(model.K().toarray() - K.toarray()[np.ix_(order, order)]).max() < 1e-9 * abs(K).max()
    assert np.abs(model.M().toarray() - M.toarray()[np.ix_(order, order)]).max() < 1e-12 * abs(M).max()
    assert abs(model.K0).max() == 0  # every stiffness term is E times a unit matrix: K = E dK/dE
    assert np.abs(70e9 * model.dK_dp(0).toarray() - model.K().toarray()).max() < 1e-9 * abs(K).max()
    assert model.parameters[0].unit == "Pa"


def test_shells_solids_frames_springs_and_masses_mix_in_one_model():
    s, nodes, conn = _plate_structure(n=2)
    # a steel block under the plate's middle corner square (hex8), its top nodes shared with the plate
    bnodes, hexes = box_hex(1, 1, 1, (0.3, 0.3, 0.1))
    bnodes = bnodes - [0, 0, 0.1]
    top = np.isclose(bnodes[:, 2], 0.0)
    ids = np.zeros(len(bnodes), int)
    plate_id = {tuple(np.round(x, 9)): i + 1 for i, x in enumerate(nodes)}
    for k, x in enumerate(bnodes):
        ids[k] = plate_id[tuple(np.round(x, 9))] if top[k] else 100 + k
        if not top[k]:
            s.node(int(ids[k]), x)
    s.parameter("E_block", 200e9)
    s.solid(ids[hexes], E="E_block", nu=0.3, rho=7800.0, where="block")
    s.frame3d([[3, 6], [6, 9]], E=210e9, G=80e9, A=1e-4, Iy=1e-8, Iz=1e-8, J=2e-8, rho=7800.0,
              orientation=[0, 0, 1], where="stiffener")
    s.spring(["9:z"], k=1e5)
    s.mass(["5:x", "5:y", "5:z"], m=0.5)
    s.support_node([1])
    model = s.build()
    solid_only = [int(i) for i in ids[~top]]
    for i in solid_only:  # a solid node has no rotations
        assert f"{i}:x" in model.dofs and f"{i}:rx" not in model.dofs
    assert "5:rz" in model.dofs
    assert len(model.dofs) == 9 * 6 - 6 + 4 * 3
    w2 = sl.eigh(model.K().toarray(), model.M().toarray(), eigvals_only=True)
    assert w2[0] > 0  # supported node 1 plus the block: no mechanism left
    ref = hex8_terms(bnodes[hexes], 0.3).K[0][1][0] * 200e9
    assert model.dK_dp(model.parameter_index("E_block")).toarray().max() == pytest.approx(ref.max() / 200e9, rel=1e-12)


TOML = """
[model]
name = "plate in a file"

[parameters.E_plate]
value = 70e9
bounds = [1e9, 1e12]

[[node]]
id = 1
xyz = [0, 0, 0]
[[node]]
id = 2
xyz = [0.5, 0, 0]
[[node]]
id = 3
xyz = [0.5, 0.4, 0]
[[node]]
id = 4
xyz = [0, 0.4, 0]
[[node]]
id = 5
xyz = [1.0, 0, 0]
[[node]]
id = 6
xyz = [1.0, 0.4, 0]
[[node]]
id = 7
xyz = [1.0, 0.4, 0.3]

[[element]]
type = "mitc4"
nodes = [[1, 2, 3, 4]]
E = "E_plate"
nu = 0.33
t = 0.004
rho = 2700

[[element]]
type = "mitc3"
nodes = [[2, 5, 6], [2, 6, 3]]
E = "E_plate"
nu = 0.33
t = 0.004
rho = 2700
mass = "lumped"

[[element]]
type = "tet4"
nodes = [3, 2, 6, 7]
E = 200e9
nu = 0.3
rho = 7800

[[support]]
nodes = [1, 4]
"""


def test_toml_model_file_with_shell_and_solid_sets(tmp_path):
    p = tmp_path / "plate.toml"
    p.write_text(TOML)
    model = load_model(p)
    assert model.parameter_names == ("E_plate",)
    assert "7:x" in model.dofs and "7:rx" not in model.dofs and "5:rz" in model.dofs
    assert len(model.dofs) == 4 * 6 + 3
    for bad, message in [
        ("nu = 0.33\nt = 0.004\nrho = 2700\nmass", "nu = 0.5\nt = 0.004\nrho = 2700\nmass"),
        ("nodes = [[1, 2, 3, 4]]", "nodes = [[1, 2, 3]]"),
        ("nodes = [3, 2, 6, 7]", "nodes = [3, 2, 7, 6]"),
        ("nodes = [3, 2, 6, 7]", "nodes = [3, 2, 6, 6]"),
    ]:
        p.write_text(TOML.replace(bad, message, 1))
        with pytest.raises(InputError) as err:
            load_model(p)
        text = str(err.value)
        assert "element #" in text, text
    # a thickness parameter (issue 28 item 2): K = E t K_m + E t^3 K_b + ..., the model at t equals the numeric one
    p.write_text(TOML.replace("t = 0.004", 't = "t_plate"', 1).replace("[[node]]", "[parameters.t_plate]\nvalue = 0.004\n\n[[node]]", 1))
    nl = load_model(p)
    assert not nl.is_affine and "E_plate*t_plate^3" in {t.describe() for t in nl.terms}
    p.write_text(TOML.replace("t = 0.004", "t = 0.005", 1))
    ref = load_model(p)
    K, K_ref = nl.K({"t_plate": 0.005}).toarray(), ref.K().toarray()
    assert np.abs(K - K_ref).max() <= 1e-12 * np.abs(K_ref).max()
    p.write_text(TOML.replace("nodes = [3, 2, 6, 7]", "nodes = [3, 2, 7, 6]"))
    with pytest.raises(InputError, match=r"element #3 \(tet4\).*inverted or degenerate"):
        load_model(p)
    p.write_text(TOML.replace('nodes = [[1, 2, 3, 4]]', 'nodes = [[1, 2, 3]]'))
    with pytest.raises(InputError, match=r"element #1 \(mitc4\): a mitc4 element has 4 nodes"):
        load_model(p)
    p.write_text(TOML.replace("nu = 0.3\n", 'nu = "E_plate"\n'))
    with pytest.raises(InputError, match="Poisson's ratio enters the element matrices non-linearly"):
        load_model(p)


def test_structure_refuses_bad_shells_and_solids():
    s, _, conn = _plate_structure(n=2)
    with pytest.raises(InputError, match="lists a node twice"):
        s.shell([1, 2, 2, 4], E=1.0, nu=0.3, t=0.01, rho=1.0)
    with pytest.raises(InputError, match="lists 4 \\(mitc4\\) or 3 \\(mitc3\\) node ids"):
        s.shell([1, 2], E=1.0, nu=0.3, t=0.01, rho=1.0)
    with pytest.raises(InputError, match="between -1 and 0.5"):
        s.solid([1, 2, 4, 10], E=1.0, nu=-1.0, rho=1.0)
    with pytest.raises(InputError, match="drill must be a positive number"):
        s.shell([1, 2, 5, 4], E=1.0, nu=0.3, t=0.01, rho=1.0, drill=0)
    s.solid([1, 2, 4, 42], E=1.0, nu=0.3, rho=1.0, where="lonely tet")
    with pytest.raises(InputError, match=r"lonely tet: node\(s\) \[42\] are not defined"):
        s.build()


def test_element_parameters_and_drawing_edges_of_shells_and_solids():
    """Damage detection's one-E-per-element model reproduces the shell model's stiffness (every shell
    term is proportional to E), and the drawing edges are the element edges."""
    from femupdate.damage.parameters import element_parameters
    from femupdate.fullfield import structure_segments

    s, nodes, conn = _plate_structure(n=2)
    s.support_node([1, 2, 3])
    model = s.build()
    per_element, described = element_parameters(s)
    split = per_element.build()
    assert len(split.parameters) == 4
    assert np.abs(split.K().toarray() - model.K().toarray()).max() < 1e-9 * abs(model.K()).max()
    first = split.parameters[0].name
    assert first == "E.1-4-5-2" and "mitc4 1-4-5-2" in described[first]
    segs = structure_segments(s)
    assert len(segs) == 12  # the edges of a 2 x 2 quadrilateral mesh, no diagonals


def test_density_parameter_of_shells_and_solids_is_exact():
    """rho as a parameter: both shell mass terms (rho t, rho t^3) and the solid's go to dM/drho, and a
    finite difference of M(p) agrees with it."""
    s, nodes, conn = _plate_structure(n=2)
    s.parameter("rho_plate", 2700.0)
    s.groups[-1].props["rho"] = ["rho_plate"] * len(conn)
    s.solid([[1, 4, 2, 50]], E=200e9, nu=0.3, rho="rho_plate")
    s.node(50, (0.0, 0.0, 0.3))
    model = s.build()
    j = model.parameter_index("rho_plate")
    assert abs(model.M0).max() == 0
    assert np.abs(2700.0 * model.dM_dp(j).toarray() - model.M().toarray()).max() < 1e-12 * abs(model.M()).max()
    p = model.values.copy()
    h = 1e-3 * p[j]
    p1, p0 = p.copy(), p.copy()
    p1[j] += h
    p0[j] -= h
    fd = (model.M(p1) - model.M(p0)).toarray() / (2 * h)
    assert np.abs(fd - model.dM_dp(j).toarray()).max() < 1e-9 * abs(model.dM_dp(j)).max()


def test_a_shell_strip_stiffened_by_a_frame_bends_as_one_beam():
    """Shell and frame rotations share their global dofs with the same sign convention: a cantilever
    strip of MITC4 shells (nu = 0) with a frame3d of the same EI along its centre line has
    Euler-Bernoulli's first frequency for EI_total = 2 E b t^3 / 12, m = 2 rho b t (a frame whose
    rotation had the opposite sign would fight the shell and stiffen the pair)."""
    length, b, t, nx = 1.0, 0.1, 0.01, 20
    s = Structure("strip")
    ids = {}
    for i in range(nx + 1):
        for j in range(3):
            ids[i, j] = 100 * i + j + 1
            s.node(ids[i, j], (length * i / nx, b * j / 2 - b / 2, 0.0))
    s.shell([[ids[i, j], ids[i + 1, j], ids[i + 1, j + 1], ids[i, j + 1]] for i in range(nx) for j in range(2)],
            E=1.0, nu=0.0, t=t, rho=1.0)
    inertia, area = b * t**3 / 12, b * t
    s.frame3d([[ids[i, 1], ids[i + 1, 1]] for i in range(nx)], E=1.0, G=0.5, A=area, Iy=inertia, Iz=inertia,
              J=2 * inertia, rho=1.0, orientation=[0, 0, 1])
    s.support_node([ids[0, j] for j in range(3)])
    model = s.build()
    w = np.sqrt(sla.eigsh(model.K().tocsc(), k=1, M=model.M().tocsc(), sigma=0)[0][0])
    euler_bernoulli = 1.875104068711961**2 * np.sqrt(2 * inertia / (2 * area * length**4))
    assert w / euler_bernoulli == pytest.approx(1.0, abs=0.002)
