"""Shell and solid elements against an independent code, OpenSeesPy (skipped when it is not installed).

OpenSees assembles one element with all dofs free; its matrix is read back with the GimmeMCK
integrator and printA.  Compared exactly: FourNodeTetrahedron (stiffness), stdBrick (stiffness and
mass, against the plain trilinear hex8), ShellMITC4 on a rectangle (stiffness; with the drilling
factor 1, OpenSees's Hughes-Brezzi gamma = G), ASDShellT3's out-of-plane block (MITC3 with a
shear stabilisation factor).  ShellMITC4 on a distorted quadrilateral differs from
femupdate's MITC4 (both pass the patch tests): that comparison is by convergence, in the docs.
"""

from __future__ import annotations

import ctypes
import glob
import os

import numpy as np
import pytest

from femupdate.elements import combine
from femupdate.elements_3d import hex8_terms, mitc3_terms, mitc4_terms, tet4_terms
from femupdate.elements_3d.solids import HEX8_CORNERS


def _opensees():
    """openseespy's module, or skip; its Linux wheel ships BLAS/LAPACK in a lib folder that the
    loader does not search, so those are loaded first."""
    import importlib.util

    try:
        found = importlib.util.find_spec("openseespylinux")
    except (ImportError, ValueError):
        found = None
    if found is not None and found.submodule_search_locations:
        folder = list(found.submodule_search_locations)[0]
        for lib in sorted(glob.glob(os.path.join(folder, "lib", "*.so*"))):
            try:
                ctypes.CDLL(lib, mode=ctypes.RTLD_GLOBAL)
            except OSError:
                pass
    try:
        import openseespy.opensees as ops
    except Exception:  # not installed, or its libraries cannot load
        pytest.skip("openseespy is not available")
    return ops


def _matrix(ops, nodes, make, ndf, mck):
    ops.wipe()
    ops.model("basic", "-ndm", 3, "-ndf", ndf)
    for i, x in enumerate(nodes):
        ops.node(i + 1, *map(float, x))
    make()
    ops.system("FullGeneral")
    ops.numberer("Plain")
    ops.constraints("Plain")
    ops.algorithm("Linear")
    ops.integrator("GimmeMCK", *mck)
    ops.analysis("Transient")
    ops.analyze(1, 0.0)  # the solve fails (free element, singular), the matrix is formed
    A = np.array(ops.printA("-ret"))
    n = int(round(np.sqrt(A.size)))
    return A.reshape(n, n)


def _rel(a, b):
    return np.abs(a - b).max() / np.abs(b).max()


def test_solids_match_opensees():
    ops = _opensees()
    rng = np.random.default_rng(3)
    tet = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1.0]]) + 0.05 * rng.standard_normal((4, 3))

    def tet_el():
        ops.nDMaterial("ElasticIsotropic", 1, 70e9, 0.3, 2700.0)
        ops.element("FourNodeTetrahedron", 1, 1, 2, 3, 4, 1)

    K = _matrix(ops, tet, tet_el, 3, (0.0, 0.0, 1.0))
    assert _rel(K, 70e9 * tet4_terms(tet[None], 0.3).K[0][1][0]) < 1e-12
    brick = HEX8_CORNERS * [1.0, 0.7, 0.4] + 0.05 * rng.standard_normal((8, 3))

    def brick_el():
        ops.nDMaterial("ElasticIsotropic", 1, 70e9, 0.3, 2700.0)
        ops.element("stdBrick", 1, *range(1, 9), 1)

    plain = hex8_terms(brick[None], 0.3, incompatible=False)
    assert _rel(_matrix(ops, brick, brick_el, 3, (0.0, 0.0, 1.0)), 70e9 * plain.K[0][1][0]) < 1e-12
    assert _rel(_matrix(ops, brick, brick_el, 3, (1.0, 0.0, 0.0)), 2700.0 * plain.M[0][1][0]) < 1e-12


def test_mitc4_matches_opensees_shellmitc4_on_a_rectangle():
    ops = _opensees()
    quad = np.array([[0, 0, 0], [1.2, 0, 0], [1.2, 0.8, 0], [0, 0.8, 0.0]])
    E, nu, t = 70e9, 0.3, 0.01

    def shell_el():
        ops.section("ElasticMembranePlateSection", 1, E, nu, t, 2700.0)
        ops.element("ShellMITC4", 1, 1, 2, 3, 4, 1)

    K = _matrix(ops, quad, shell_el, 6, (0.0, 0.0, 1.0))
    ours = combine(mitc4_terms(quad[None], nu, drill=1.0).K, {"E": E, "t": t})[0]
    assert _rel(K, ours) < 1e-10


def test_mitc3_shear_matches_opensees_asdshellt3():
    """OpenSees's ASDShellT3 is the MITC3 triangle with the transverse shear scaled by Lyly, Stenberg &
    Vihinen's stabilisation t^2 / (t^2 + 0.1 h^2) (h the longest edge): its out-of-plane block
    (w, rx, ry) is femupdate's MITC3 bending plus that multiple of its MITC3 shear, so the tied
    shear strains are the same."""
    ops = _opensees()
    tri = np.array([[0, 0, 0], [1.1, 0.1, 0], [0.3, 0.9, 0.0]])
    E, nu, t = 70e9, 0.3, 0.01

    def shell_el():
        ops.section("ElasticMembranePlateSection", 1, E, nu, t, 2700.0)
        ops.element("ASDShellT3", 1, 1, 2, 3, 1)

    K = _matrix(ops, tri, shell_el, 6, (0.0, 0.0, 1.0))
    terms = mitc3_terms(tri[None], nu).K
    h2 = max(np.sum((tri[i] - tri[j]) ** 2) for i, j in ((0, 1), (1, 2), (2, 0)))
    scale = t**2 / (t**2 + 0.1 * h2)
    bending = combine(terms[1:2], {"E": E, "t": t})[0]
    shear = combine(terms[2:3], {"E": E, "t": t})[0]
    out = np.array([6 * a + d for a in range(3) for d in (2, 3, 4)])
    ours = (bending + scale * shear)[np.ix_(out, out)]
    assert _rel(K[np.ix_(out, out)], ours) < 1e-10
