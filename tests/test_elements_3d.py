"""Shell (MITC4, MITC3) and solid (hex8 QM6, tet4, tet10) elements: rigid-body modes, patch tests,
convergence to closed forms (Leissa's simply supported plate, Euler-Bernoulli's cantilever) and an
independent code (OpenSeesPy, when installed)."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse.linalg as sla

from femupdate._errors import InputError
from femupdate.elements import combine
from femupdate.elements_3d import hex8_terms, mitc3_terms, mitc4_terms, tet4_terms, tet10_terms
from femupdate.elements_3d.solids import HEX8_CORNERS, TET10_EDGES

from _meshes3d import assemble, box_hex, hex_to_tets, plate_mesh

RNG = np.random.default_rng(7)
ROT = np.linalg.qr(RNG.standard_normal((3, 3)))[0]
QUAD = np.array([[0, 0, 0], [1.1, 0.1, 0], [1.2, 0.9, 0], [-0.1, 1.0, 0]]) @ ROT.T
TET = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1.0]]) + 0.05 * RNG.standard_normal((4, 3))
TET10 = np.vstack([TET, [(TET[i] + TET[j]) / 2 for i, j in TET10_EDGES]]) + 0.02 * RNG.standard_normal((10, 3))
HEX = HEX8_CORNERS * [1.0, 0.7, 0.5] + 0.08 * RNG.standard_normal((8, 3))


def _zero_modes(K):
    ev = np.linalg.eigvalsh(K)
    return int(np.sum(np.abs(ev) < 1e-9 * ev[-1])), ev


@pytest.mark.parametrize("make, X", [
    (lambda X: hex8_terms(X, 0.3), HEX), (lambda X: hex8_terms(X, 0.3, incompatible=False), HEX),
    (lambda X: tet4_terms(X, 0.25), TET), (lambda X: tet10_terms(X, 0.25), TET10),
    (lambda X: mitc4_terms(X, 0.3), QUAD), (lambda X: mitc3_terms(X, 0.3), QUAD[:3])])
def test_a_free_element_has_exactly_six_rigid_body_modes(make, X):
    terms = make(X[None])
    K = combine(terms.K, {"E": 210e9, "t": 0.05})[0]
    zeros, ev = _zero_modes(K)
    assert zeros == 6, ev[:8] / ev[-1]
    M = combine(terms.M, {"rho": 7800.0, "t": 0.05})[0]
    assert np.all(np.linalg.eigvalsh(M) > 0)  # consistent mass positive definite


def test_mass_totals_and_lumping():
    """Total translational mass is rho V (solids) or rho t A (shells), consistent and lumped."""
    vol_tet = abs(np.linalg.det(TET[1:] - TET[0])) / 6
    for mass in ("consistent", "lumped"):
        M = tet4_terms(TET[None], 0.3, mass=mass).M[0][1][0]
        assert M[0::3, 0::3].sum() == pytest.approx(vol_tet, rel=1e-12)
        straight = np.vstack([TET, [(TET[i] + TET[j]) / 2 for i, j in TET10_EDGES]])
        M10 = tet10_terms(straight[None], 0.3, mass=mass).M[0][1][0]
        assert M10[0::3, 0::3].sum() == pytest.approx(vol_tet, rel=1e-12)
        assert np.all(np.diag(M10) > 0)  # HRZ keeps the corner masses positive
        box = HEX8_CORNERS * [1.0, 0.7, 0.5]
        assert hex8_terms(box[None], 0.3, mass=mass).M[0][1][0][0::3, 0::3].sum() == pytest.approx(2.0 * 1.4 * 1.0, rel=1e-12)
        q = np.array([[0, 0, 0], [2.0, 0, 0], [2.0, 1.5, 0], [0, 1.5, 0]])
        Mq = combine(mitc4_terms(q[None], 0.3, mass=mass).M[:1], {"rho": 1.0, "t": 0.1})[0]
        assert Mq[0::6, 0::6].sum() == pytest.approx(0.3, rel=1e-12)


def _patch_solve(K, U, interior):
    inner = np.flatnonzero(interior)
    outer = np.flatnonzero(~interior)
    ui = np.linalg.solve(K[np.ix_(inner, inner)], -K[np.ix_(inner, outer)] @ U[outer])
    return np.abs(ui - U[inner]).max() / np.abs(U).max()


@pytest.mark.parametrize("kind", ["hex8", "hex8_plain", "tet4", "tet10"])
def test_solid_patch_test_reproduces_a_constant_strain_state_exactly(kind):
    nodes, hexes = box_hex(2, 2, 2)
    centre = np.flatnonzero(np.all(np.isclose(nodes, 0.5), axis=1))[0]
    nodes = nodes.copy()
    nodes[centre] += [0.13, -0.08, 0.11]  # a distorted patch: the interior node off centre
    if kind.startswith("hex8"):
        terms, conn = hex8_terms(nodes[hexes], 0.3, incompatible=kind == "hex8"), hexes
    else:
        nodes, conn = hex_to_tets(nodes, hexes, quadratic=kind == "tet10")
        terms = (tet10_terms if kind == "tet10" else tet4_terms)(nodes[conn], 0.3)
    K = assemble(terms, conn, len(nodes), 3, {"E": 1.0, "rho": 1.0})[0].toarray()
    A = np.array([[1.0, 0.4, -0.3], [0.2, -0.7, 0.5], [0.6, 0.1, 0.9]]) * 1e-3
    U = (nodes @ A.T + [1e-3, 2e-3, -1e-3]).ravel()
    interior = np.repeat(np.all((nodes > 1e-9) & (nodes < 1 - 1e-9), axis=1), 3)
    assert interior.sum() >= 3
    assert _patch_solve(K, U, interior) < 1e-10


MH_NODES = np.column_stack([np.array([[0, 0], [0.24, 0], [0.24, 0.12], [0, 0.12], [0.04, 0.02], [0.18, 0.03],
                                      [0.16, 0.08], [0.08, 0.08]]), np.zeros(8)])
MH_QUADS = np.array([[0, 1, 5, 4], [1, 2, 6, 5], [2, 3, 7, 6], [3, 0, 4, 7], [4, 5, 6, 7]])


def _bending_field(x, y):  # constant curvature, zero transverse shear: w = (x^2 + 0.7 y^2 + 0.4 xy) / 2
    wx, wy = x + 0.2 * y, 0.7 * y + 0.2 * x
    return [0, 0, 0.5 * (x * x + 0.7 * y * y + 0.4 * x * y), wy, -wx, 0]


def _membrane_field(x, y):  # constant strain, no in-plane rotation
    return [1e-3 * x - 0.75e-3 * y, 2e-3 * y - 0.75e-3 * x, 0, 0, 0, 0]


@pytest.mark.parametrize("element", ["mitc4", "mitc3"])
@pytest.mark.parametrize("field", [_bending_field, _membrane_field])
def test_shell_patch_test_membrane_and_constant_curvature(element, field):
    """MacNeal-Harder's distorted patch (0.24 x 0.12, interior nodes off-grid), rotated in space."""
    conn = MH_QUADS if element == "mitc4" else np.vstack([MH_QUADS[:, [0, 1, 2]], MH_QUADS[:, [0, 2, 3]]])
    f = mitc4_terms if element == "mitc4" else mitc3_terms
    nodes = MH_NODES @ ROT.T
    K = assemble(f(nodes[conn], 0.3), conn, 8, 6, {"E": 1.0, "t": 0.01, "rho": 1.0})[0].toarray()
    T = np.kron(np.eye(16), ROT)  # local patch fields to global dofs
    U = T @ np.concatenate([field(x, y) for x, y, _ in MH_NODES])
    interior = np.arange(48) >= 24
    assert _patch_solve(K, U, interior) < 1e-8


def test_mitc3_is_isotropic():
    """Lee & Bathe's MITC3 does not depend on the node numbering (a cyclic renumbering)."""
    X = QUAD[:3]
    K = combine(mitc3_terms(X[None], 0.3).K, {"E": 1.0, "t": 0.1})[0]
    perm = [1, 2, 0]
    K2 = combine(mitc3_terms(X[perm][None], 0.3).K, {"E": 1.0, "t": 0.1})[0]
    idx = np.concatenate([np.arange(6) + 6 * p for p in perm])
    assert np.abs(K[np.ix_(idx, idx)] - K2).max() < 1e-12 * np.abs(K).max()


def _ss_plate(n, t, triangles, mass="consistent"):
    """Lowest frequencies of a hard simply supported unit square plate over Leissa's Kirchhoff values."""
    nodes, conn = plate_mesh(n, triangles=triangles)
    f = mitc3_terms if triangles else mitc4_terms
    nu, E, rho = 0.3, 1.0, 1.0
    K, M = assemble(f(nodes[conn], nu, mass=mass), conn, len(nodes), 6, {"E": E, "t": t, "rho": rho})
    x, y = nodes[:, 0], nodes[:, 1]
    edge_x, edge_y = np.isclose(x, 0) | np.isclose(x, 1), np.isclose(y, 0) | np.isclose(y, 1)
    fixed = np.zeros((len(nodes), 6), bool)
    fixed[:, [0, 1, 5]] = True  # membrane and drilling decouple from bending in a flat plate
    fixed[edge_x | edge_y, 2] = True
    fixed[edge_x, 3] = True  # hard support: no rotation about the edge's own direction
    fixed[edge_y, 4] = True
    free = np.flatnonzero(~fixed.ravel())
    w = np.sort(np.sqrt(sla.eigsh(K[free][:, free], k=3, M=M[free][:, free], sigma=0)[0]))
    D = E * t**3 / (12 * (1 - nu**2))
    leissa = np.pi**2 * np.array([2.0, 5.0, 5.0]) * np.sqrt(D / (rho * t))  # (m, n) = (1, 1), (1, 2), (2, 1)
    return w / leissa


def test_mitc4_simply_supported_plate_converges_to_leissa_without_shear_locking():
    for t in (1e-2, 1e-3):  # t/a = 0.01 and 0.001: no shear locking
        r = _ss_plate(16, t, triangles=False)
        assert np.all(np.abs(r - 1) < 0.02), (t, r)
        assert abs(r[0] - 1) < 0.006, (t, r)
    coarse, fine = _ss_plate(8, 1e-3, False), _ss_plate(16, 1e-3, False)
    assert abs(fine[0] - 1) < 0.3 * abs(coarse[0] - 1)  # O(h^2): the error falls about fourfold


def test_mitc3_simply_supported_plate_converges_to_leissa():
    r = _ss_plate(32, 1e-2, triangles=True)
    assert np.all(np.abs(r - 1) < 0.012), r
    # thin: converging (the error falls by more than 4 per halving), though stiffer than MITC4
    e16, e32 = (abs(_ss_plate(n, 1e-3, True)[0] - 1) for n in (16, 32))
    assert e32 < 0.1 and e32 < e16 / 4, (e16, e32)


def _cantilever(kind, nx=20, mass="consistent"):
    L, h = 10.0, 1.0
    nodes, conn = box_hex(nx, 1, 1, (L, h, h))
    if kind.startswith("hex8"):
        terms = hex8_terms(nodes[conn], 0.0, incompatible=kind == "hex8", mass=mass)
    else:
        nodes, conn = hex_to_tets(nodes, conn, quadratic=kind == "tet10")
        terms = (tet10_terms if kind == "tet10" else tet4_terms)(nodes[conn], 0.0, mass=mass)
    K, M = assemble(terms, conn, len(nodes), 3, {"E": 1.0, "rho": 1.0})
    free = np.flatnonzero(np.repeat(nodes[:, 0] > 1e-9, 3))
    w = np.sqrt(sla.eigsh(K[free][:, free], k=2, M=M[free][:, free], sigma=0)[0].min())
    euler_bernoulli = 1.875104068711961**2 * np.sqrt(1.0 / 12 / L**4)  # sqrt(EI / (rho A L^4)), h = b = 1
    return w / euler_bernoulli


def test_solid_cantilever_one_element_through_the_depth():
    """L/h = 10, nu = 0: Timoshenko's shear correction is about -0.5 %; tet4 locks, hex8 (QM6) and
    tet10 do not."""
    qm6, plain, tet4, tet10 = (_cantilever(k) for k in ("hex8", "hex8_plain", "tet4", "tet10"))
    assert 0.985 < qm6 < 1.0, qm6
    assert 0.985 < tet10 < 1.0, tet10
    assert plain > 1.04 and tet4 > 1.3, (plain, tet4)  # shear locking of the plain elements
    assert 0.985 < _cantilever("hex8", nx=10) < 1.0  # QM6 on 1 x 1 x 1 elements: aspect ratio has no effect


def test_bad_geometry_and_material_are_refused():
    inverted = HEX[[4, 5, 6, 7, 0, 1, 2, 3]]
    with pytest.raises(InputError, match="inverted or degenerate"):
        hex8_terms(np.stack([HEX, inverted]), 0.3)
    with pytest.raises(InputError, match="Poisson"):
        tet4_terms(TET[None], 0.5)
    flat = TET.copy()
    flat[3] = flat[0]
    with pytest.raises(InputError, match="inverted or degenerate"):
        tet4_terms(flat[None], 0.3)
    with pytest.raises(InputError, match="degenerate"):
        mitc3_terms(np.array([[[0, 0, 0], [1, 0, 0], [2, 0, 0.0]]]), 0.3)
    with pytest.raises(InputError, match="inverted"):
        mitc4_terms(QUAD[[0, 2, 1, 3]][None], 0.3)  # a bow-tie
    with pytest.raises(InputError, match="mass"):
        mitc4_terms(QUAD[None], 0.3, mass="diagonal")


def test_lumped_masses_converge_to_the_same_closed_forms():
    """HRZ-lumped mass: simply supported plate (24 x 24, t/a = 0.01) and the hex8 / tet10 cantilever."""
    assert np.all(np.abs(_ss_plate(24, 1e-2, False, mass="lumped") - 1) < 0.01)
    assert np.all(np.abs(_ss_plate(24, 1e-2, True, mass="lumped") - 1) < 0.015)
    assert 0.98 < _cantilever("hex8", mass="lumped") < 1.0
    assert 0.98 < _cantilever("tet10", mass="lumped") < 1.0


def _square_plate(n, t, support):
    """Lowest three λ = ω a² √(ρ t / D) of a unit square MITC4 plate, clamped all round or along x = 0."""
    nodes, conn = plate_mesh(n)
    K, M = assemble(mitc4_terms(nodes[conn], 0.3), conn, len(nodes), 6, {"E": 1.0, "t": t, "rho": 1.0})
    x, y = nodes[:, 0], nodes[:, 1]
    fixed = np.zeros((len(nodes), 6), bool)
    fixed[:, [0, 1, 5]] = True
    edge = np.isclose(x, 0)
    if support == "clamped":
        edge |= np.isclose(x, 1) | np.isclose(y, 0) | np.isclose(y, 1)
    fixed[edge, 2:5] = True
    free = np.flatnonzero(~fixed.ravel())
    w2 = np.sort(sla.eigsh(K[free][:, free], k=3, M=M[free][:, free], sigma=0)[0])
    D = t**3 / (12 * (1 - 0.3**2))
    return np.sqrt(w2) * np.sqrt(t / D)


def test_mitc4_clamped_and_cantilever_square_plates_against_leissa():
    """Leissa, Vibration of Plates (NASA SP-160, 1969): clamped square 35.99, 73.41 (73.41);
    cantilever square, nu = 0.3: 3.492, 8.525, 21.43 (Ritz values, upper bounds a few per mille high)."""
    clamped = _square_plate(24, 0.01, "clamped")
    assert np.all(np.abs(clamped / [35.99, 73.41, 73.41] - 1) < 0.01), clamped
    cantilever = _square_plate(16, 0.01, "cantilever")
    assert np.all(np.abs(cantilever / [3.492, 8.525, 21.43] - 1) < 0.01), cantilever


def _scordelis_lo(n, triangles=False):
    """Scordelis-Lo roof (MacNeal & Harder's benchmark, 1985): cylinder R = 25, L = 50, 80 degrees,
    t = 0.25, E = 4.32e8, nu = 0, self-weight 90 per unit area, ends on diaphragms; the full roof on
    n x n elements.  Returns the vertical deflection at the middle of a free edge over 0.3024."""
    length, radius, t, q = 50.0, 25.0, 0.25, 90.0
    X, T = np.meshgrid(np.linspace(0, length, n + 1), np.radians(np.linspace(-40, 40, n + 1)), indexing="ij")
    nodes = np.column_stack([X.ravel(), radius * np.sin(T.ravel()), radius * np.cos(T.ravel())])
    nid = np.arange(len(nodes)).reshape(n + 1, n + 1)
    quads = np.array([[nid[i, j], nid[i + 1, j], nid[i + 1, j + 1], nid[i, j + 1]] for i in range(n) for j in range(n)])
    conn = np.vstack([quads[:, [0, 1, 2]], quads[:, [0, 2, 3]]]) if triangles else quads
    f = mitc3_terms if triangles else mitc4_terms
    K = assemble(f(nodes[conn], 0.0), conn, len(nodes), 6, {"E": 4.32e8, "t": t, "rho": 1.0})[0]
    area = assemble(f(nodes[conn], 0.0, mass="lumped"), conn, len(nodes), 6, {"E": 1.0, "t": 1.0, "rho": 1.0})[1]
    g = np.zeros(6 * len(nodes))
    g[2::6] = -q
    F = area @ g  # the weight lumped at the nodes (HRZ areas)
    fixed = np.zeros((len(nodes), 6), bool)
    ends = np.isclose(nodes[:, 0], 0) | np.isclose(nodes[:, 0], length)
    fixed[ends, 1] = fixed[ends, 2] = True  # rigid diaphragms
    fixed[np.isclose(nodes[:, 0], length / 2), 0] = True  # symmetry: no axial motion at mid-span
    free = np.flatnonzero(~fixed.ravel())
    u = np.zeros(6 * len(nodes))
    u[free] = sla.spsolve(K[free][:, free].tocsc(), F[free])
    return -u[6 * nid[n // 2, 0] + 2] / 0.3024


def test_scordelis_lo_roof_curved_shell_of_flat_elements():
    """Membrane-bending coupling of a curved shell: MITC4 16 x 16 and 32 x 32 (quarter-model 8 x 8,
    16 x 16) within 3 % and 1.5 % of the reference 0.3024, converging; MITC3 converges more slowly."""
    r16, r32 = _scordelis_lo(16), _scordelis_lo(32)
    assert abs(r16 - 1) < 0.03 and abs(r32 - 1) < 0.015 and abs(r32 - 1) < abs(r16 - 1), (r16, r32)
    assert 0.9 < _scordelis_lo(32, triangles=True) < 1.0


def test_a_warped_quadrilateral_moves_rigidly_without_strain():
    """MacNeal's rigid offsets: rigid rotations of a warped MITC4 about any axis give no strain energy
    (without them the flat projection would strain: energy of order warp^2)."""
    X = (np.array([[0, 0, 0], [1, 0, 0.05], [1, 1, 0], [0, 1, 0.05]]) + [2.0, 3.0, 1.0]) @ ROT.T
    K = combine(mitc4_terms(X[None], 0.3).K, {"E": 1.0, "t": 0.01})[0]
    assert _zero_modes(K)[0] == 6
    for axis in np.eye(3):
        U = np.concatenate([np.r_[np.cross(axis, x), axis] for x in X])
        assert abs(U @ K @ U) < 1e-12 * np.abs(K).max()


def _twisted_beam(nx, ny, triangles=False):
    """MacNeal & Harder's twisted beam (1985): 12 x 1.1, t = 0.32, twisted 90 degrees, E = 29e6,
    nu = 0.22, clamped; tip deflections under unit tip loads along y and z over 1.754e-3 and 5.424e-3."""
    length, width = 12.0, 1.1
    X, Y = np.meshgrid(np.linspace(0, length, nx + 1), np.linspace(-width / 2, width / 2, ny + 1), indexing="ij")
    beta = np.pi / 2 * X / length
    nodes = np.column_stack([X.ravel(), (Y * np.cos(beta)).ravel(), (Y * np.sin(beta)).ravel()])
    nid = np.arange(len(nodes)).reshape(nx + 1, ny + 1)
    quads = np.array([[nid[i, j], nid[i + 1, j], nid[i + 1, j + 1], nid[i, j + 1]]
                      for i in range(nx) for j in range(ny)])
    conn = np.vstack([quads[:, [0, 1, 2]], quads[:, [0, 2, 3]]]) if triangles else quads
    f = mitc3_terms if triangles else mitc4_terms
    K = assemble(f(nodes[conn], 0.22), conn, len(nodes), 6, {"E": 29e6, "t": 0.32, "rho": 1.0})[0]
    free = np.flatnonzero(~np.repeat(np.isclose(nodes[:, 0], 0), 6))
    Kf = sla.splu(K[free][:, free].tocsc())
    tip = nid[nx]
    out = []
    for d in (1, 2):
        F = np.zeros(6 * len(nodes))
        F[6 * tip + d] = 1.0 / len(tip)
        u = np.zeros(6 * len(nodes))
        u[free] = Kf.solve(F[free])
        out.append(u[6 * tip + d].mean())
    return np.array(out) / [1.754e-3, 5.424e-3]


def test_twisted_beam_warped_elements():
    """Warped elements (7.5 degrees of twist per element on the 12 x 2 mesh): MITC4 within 7 % on
    MacNeal & Harder's 12 x 2 mesh and 1 % on 48 x 8; MITC3 within 3 % on 96 x 16."""
    coarse, fine = _twisted_beam(12, 2), _twisted_beam(48, 8)
    assert np.all(np.abs(coarse - 1) < 0.07) and np.all(np.abs(fine - 1) < 0.01), (coarse, fine)
    assert np.all(np.abs(_twisted_beam(96, 16, triangles=True) - 1) < 0.03)
