"""Rigid links, beam end offsets, equal-dof ties and an offset point mass against an independent
code, OpenSeesPy (skipped when it is not installed): the natural frequencies of one space frame
that holds them all, to 1e-8 relative.

OpenSees models the same things its own way: ``rigidLink('beam', ...)`` for the links, beam end
offsets as members between auxiliary nodes rigidly linked to the frame's nodes, ``equalDOF`` for
the tie, and the point mass as a nodal mass on an auxiliary node rigidly linked at the offset;
its constraint handler is the transformation method; consistent member mass (``-cMass``) with
J = Iy + Iz, which is what femupdate's frame3d uses for the torsional inertia.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg as sl

import femupdate as fu
from test_elements_3d_opensees import _opensees

E, G, A, Iy, Iz, rho = 210e9, 81e9, 4e-3, 2e-5, 3e-5, 7850.0
J = Iy + Iz
NODES = {1: (0, 0, 0), 2: (0, 0, 3), 3: (4, 0, 0), 4: (4, 0, 3), 5: (0.3, 0, 3.2), 6: (3.7, 0.1, 3.2),
         7: (2, 2, 0), 8: (2, 2, 3), 9: (2, 2, 3), 10: (2, 3.5, 3)}
OFF = np.array([[0.0, 0.1, 0.2], [0.1, -0.1, 0.2]])  # girder 4-8's end offsets
MASS_AT, MASS_OFF, MASS, INERTIA = 10, np.array([0.0, 0.2, 0.1]), 50.0, (1.0, 2.0, 3.0)
# (nodes, orientation in the local x-y plane)
MEMBERS = [((1, 2), (1, 0, 0)), ((3, 4), (1, 0, 0)), ((7, 8), (1, 0, 0)), ((5, 6), (0, 0, 1)), ((9, 10), (0, 0, 1))]


def femupdate_model():
    s = fu.Structure("linked frame")
    s.parameter("E", E)
    for i, x in NODES.items():
        s.node(i, x)
    for (a, b), v in MEMBERS:
        s.frame3d([a, b], E="E", G=G, A=A, Iy=Iy, Iz=Iz, J=J, rho=rho, orientation=v)
    s.frame3d([4, 8], E="E", G=G, A=A, Iy=Iy, Iz=Iz, J=J, rho=rho, orientation=(0, 0, 1), offsets=OFF)
    s.rigid_link(2, 5)
    s.rigid_link(4, 6)
    s.equal_dofs(8, 9, ["x", "y", "z", "rx", "ry", "rz"])
    s.point_mass(MASS_AT, MASS, offset=MASS_OFF, inertia=np.diag(INERTIA))
    s.support_node([1, 3, 7])
    return s.build()


def opensees_frequencies(ops, n):
    ops.wipe()
    ops.model("basic", "-ndm", 3, "-ndf", 6)
    for i, x in NODES.items():
        ops.node(i, *map(float, x))
    aux = {11: np.add(NODES[4], OFF[0]), 12: np.add(NODES[8], OFF[1]), 13: np.add(NODES[MASS_AT], MASS_OFF)}
    for i, x in aux.items():
        ops.node(i, *map(float, x))
    members = MEMBERS + [((11, 12), (0, 0, 1))]
    for k, ((a, b), v) in enumerate(members, start=1):
        axis = np.subtract(ops.nodeCoord(b), ops.nodeCoord(a))
        ops.geomTransf("Linear", k, *np.cross(axis, v))  # OpenSees's vector lies in the local x-z plane
        ops.element("elasticBeamColumn", k, a, b, A, E, G, J, Iy, Iz, k, "-mass", rho * A, "-cMass")
    for i in (1, 3, 7):
        ops.fix(i, 1, 1, 1, 1, 1, 1)
    ops.rigidLink("beam", 2, 5)
    ops.rigidLink("beam", 4, 6)
    ops.rigidLink("beam", 4, 11)
    ops.rigidLink("beam", 8, 12)
    ops.equalDOF(8, 9, 1, 2, 3, 4, 5, 6)
    ops.rigidLink("beam", MASS_AT, 13)
    ops.mass(13, MASS, MASS, MASS, *INERTIA)
    ops.constraints("Transformation")
    ops.numberer("Plain")
    ops.system("FullGeneral")
    lam = np.array(ops.eigen("-fullGenLapack", n))
    ops.wipe()
    return np.sqrt(lam) / (2 * np.pi)


def test_linked_frame_matches_opensees():
    ops = _opensees()
    model = femupdate_model()
    assert model.constraints is not None and "5:x" in model.constraints.labels and "9:z" in model.constraints.labels
    lam = sl.eigh(model.K().toarray(), model.M().toarray(), eigvals_only=True)
    f = np.sqrt(lam[:10]) / (2 * np.pi)
    f_os = opensees_frequencies(ops, 10)
    rel = np.abs(f - f_os) / f_os
    assert rel.max() < 1e-8, (f, f_os)


def test_rigid_floor_matches_opensees_rigid_diaphragm():
    """One storey: four columns, their tops joined by a rigid floor in its plane (x, y, rz follow a
    master node off the centroid, which carries the floor's mass and rotary inertia): femupdate's
    rigid_link(..., dofs=["x", "y", "rz"]) against OpenSees's rigidDiaphragm(3, ...)."""
    ops = _opensees()
    base = {1: (-2, -1.5, 0), 2: (2, -1.5, 0), 3: (2, 1.5, 0), 4: (-2, 1.5, 0)}
    top = {k + 4: (x, y, 3.0) for k, (x, y, _) in base.items()}
    master, mxy, Izz = 9, 4000.0, 9000.0
    s = fu.Structure("storey")
    for i, x in {**base, **top, master: (0.3, 0.2, 3.0)}.items():
        s.node(i, x)
    for k in base:
        s.frame3d([k, k + 4], E=E, G=G, A=A, Iy=Iy, Iz=Iz, J=J, rho=rho, orientation=(1, 0, 0))
    s.mass([f"{master}:x", f"{master}:y"], m=mxy)
    s.mass([f"{master}:rz"], m=Izz)
    s.rigid_link(master, list(top), dofs=["x", "y", "rz"])
    s.support_node(list(base))
    model = s.build()
    lam = sl.eigh(model.K().toarray(), model.M().toarray(), eigvals_only=True)
    f = np.sqrt(lam[:8]) / (2 * np.pi)

    ops.wipe()
    ops.model("basic", "-ndm", 3, "-ndf", 6)
    for i, x in {**base, **top, master: (0.3, 0.2, 3.0)}.items():
        ops.node(i, *map(float, x))
    for k in base:
        ops.geomTransf("Linear", k, *map(float, np.cross((0, 0, 1), (1, 0, 0))))
        ops.element("elasticBeamColumn", k, k, k + 4, A, E, G, J, Iy, Iz, k, "-mass", rho * A, "-cMass")
        ops.fix(k, 1, 1, 1, 1, 1, 1)
    ops.fix(master, 0, 0, 1, 1, 1, 0)
    ops.mass(master, mxy, mxy, 0.0, 0.0, 0.0, Izz)
    ops.rigidDiaphragm(3, master, *top)
    ops.constraints("Transformation")
    ops.numberer("Plain")
    ops.system("FullGeneral")
    f_os = np.sqrt(np.array(ops.eigen("-fullGenLapack", 8))) / (2 * np.pi)
    ops.wipe()
    assert np.max(np.abs(f - f_os) / f_os) < 1e-8, (f, f_os, np.abs(f - f_os) / f_os)


def test_plane_frame_with_a_rigid_link_matches_opensees():
    """The plane case (beam2d, dofs x, y, rz): a portal whose beam hangs off the column tops on rigid
    links, u_d = u_i − θ r_y, v_d = v_i + θ r_x; OpenSees's 2-D rigidLink('beam', ...)."""
    ops = _opensees()
    nodes = {1: (0.0, 0.0), 2: (0.0, 3.0), 3: (5.0, 0.0), 4: (5.0, 3.0), 5: (0.25, 3.3), 6: (4.8, 3.3)}
    members = [(1, 2), (3, 4), (5, 6)]
    s = fu.Structure("plane portal")
    for i, x in nodes.items():
        s.node(i, x)
    s.beam2d(members, E=E, A=A, I=Iz, rho=rho)
    s.rigid_link(2, 5)
    s.rigid_link(4, 6)
    s.support_node([1, 3])
    model = s.build()
    assert model.constraints.labels == ("5:x", "5:y", "5:rz", "6:x", "6:y", "6:rz")
    lam = sl.eigh(model.K().toarray(), model.M().toarray(), eigvals_only=True)
    f = np.sqrt(lam) / (2 * np.pi)  # all six

    ops.wipe()
    ops.model("basic", "-ndm", 2, "-ndf", 3)
    for i, x in nodes.items():
        ops.node(i, *x)
    ops.geomTransf("Linear", 1)
    for k, (a, b) in enumerate(members, start=1):
        ops.element("elasticBeamColumn", k, a, b, A, E, Iz, 1, "-mass", rho * A, "-cMass")
    ops.fix(1, 1, 1, 1)
    ops.fix(3, 1, 1, 1)
    ops.rigidLink("beam", 2, 5)
    ops.rigidLink("beam", 4, 6)
    ops.constraints("Transformation")
    ops.numberer("Plain")
    ops.system("FullGeneral")
    f_os = np.sqrt(np.array(ops.eigen("-fullGenLapack", 6))) / (2 * np.pi)
    ops.wipe()
    assert np.max(np.abs(f - f_os) / f_os) < 1e-8, (f, f_os, np.abs(f - f_os) / f_os)
