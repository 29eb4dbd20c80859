"""Element matrices: closed forms, invariants and analytic vibration references.

Every reference here comes from a closed form written out in this file (textbook element
matrices, the reference paper's Appendix, Euler-Bernoulli / rod / shaft eigenvalues, the exact
eigenvalues of the discretised uniform rod) or from a second independent route (a rotated copy
of the same structure, a hand-written transformation, a hand-written assembly), never from the
package's own output.
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg as sla
from scipy.spatial.transform import Rotation

from femupdate import InputError, Structure, model_modes
from femupdate import elements as el
from femupdate.paper.element_sections import appendix_matrix

# βL of the Euler-Bernoulli beam (roots of cos βL cosh βL = ∓1), to 12+ digits.
CANTILEVER_BL = np.array([1.875104068711961, 4.694091132974175, 7.854757438237613, 10.995540734875467])
FREE_FREE_BL = np.array([4.730040744862704, 7.853204624095838, 10.995607838001671])

EPS = np.finfo(float).eps


# --------------------------------------------------------------------------------------
# independent helpers (written from the textbook / the documented conventions)
# --------------------------------------------------------------------------------------
def local_axes(xa, xb, v):
    """Rows: local x (a -> b), y, z with z = x × v / |x × v|, y = z × x (documented convention)."""
    ex = (np.asarray(xb, float) - np.asarray(xa, float))
    ex = ex / np.linalg.norm(ex)
    ez = np.cross(ex, v)
    ez = ez / np.linalg.norm(ez)
    ey = np.cross(ez, ex)
    return np.array([ex, ey, ez])


def frame_T(xa, xb, v):
    return np.kron(np.eye(4), local_axes(xa, xb, v))


def beam2d_T(xa, xb):
    d = np.asarray(xb, float)[:2] - np.asarray(xa, float)[:2]
    c, s = d / np.linalg.norm(d)
    R = np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])
    return np.kron(np.eye(2), R)


def textbook_beam2d(E, A, I, rho, L):
    """Local (u1 v1 θ1 u2 v2 θ2) stiffness and consistent mass of the plane Euler-Bernoulli beam."""
    a, b, c, d, e = E * A / L, 12 * E * I / L**3, 6 * E * I / L**2, 4 * E * I / L, 2 * E * I / L
    K = np.array([
        [a, 0, 0, -a, 0, 0],
        [0, b, c, 0, -b, c],
        [0, c, d, 0, -c, e],
        [-a, 0, 0, a, 0, 0],
        [0, -b, -c, 0, b, -c],
        [0, c, e, 0, -c, d],
    ])
    m = rho * A * L / 420.0
    M = m * np.array([
        [140, 0, 0, 70, 0, 0],
        [0, 156, 22 * L, 0, 54, -13 * L],
        [0, 22 * L, 4 * L**2, 0, 13 * L, -3 * L**2],
        [70, 0, 0, 140, 0, 0],
        [0, 54, 13 * L, 0, 156, -22 * L],
        [0, -13 * L, -3 * L**2, 0, -22 * L, 4 * L**2],
    ])
    return K, M


def _sym(upper: dict, n: int) -> np.ndarray:
    A = np.zeros((n, n))
    for (i, j), v in upper.items():
        A[i, j] = v
        A[j, i] = v
    return A


def textbook_frame3d(E, G, A, Iy, Iz, J, rho, L):
    """Local 12-dof space-frame stiffness and consistent mass (Przemieniecki / McGuire form).

    dof order u1 v1 w1 θx1 θy1 θz1 u2 v2 w2 θx2 θy2 θz2; Iz bends in the local x-y plane.
    """
    ea, gj = E * A / L, G * J / L
    z12, z6, z4, z2 = 12 * E * Iz / L**3, 6 * E * Iz / L**2, 4 * E * Iz / L, 2 * E * Iz / L
    y12, y6, y4, y2 = 12 * E * Iy / L**3, 6 * E * Iy / L**2, 4 * E * Iy / L, 2 * E * Iy / L
    K = _sym({
        (0, 0): ea, (0, 6): -ea, (6, 6): ea,
        (3, 3): gj, (3, 9): -gj, (9, 9): gj,
        (1, 1): z12, (1, 5): z6, (1, 7): -z12, (1, 11): z6,
        (5, 5): z4, (5, 7): -z6, (5, 11): z2, (7, 7): z12, (7, 11): -z6, (11, 11): z4,
        (2, 2): y12, (2, 4): -y6, (2, 8): -y12, (2, 10): -y6,
        (4, 4): y4, (4, 8): y6, (4, 10): y2, (8, 8): y12, (8, 10): y6, (10, 10): y4,
    }, 12)
    ip = (Iy + Iz) / A
    m = rho * A * L / 420.0
    M = m * _sym({
        (0, 0): 140, (0, 6): 70, (6, 6): 140,
        (3, 3): 140 * ip, (3, 9): 70 * ip, (9, 9): 140 * ip,
        (1, 1): 156, (1, 5): 22 * L, (1, 7): 54, (1, 11): -13 * L,
        (5, 5): 4 * L**2, (5, 7): 13 * L, (5, 11): -3 * L**2, (7, 7): 156, (7, 11): -22 * L, (11, 11): 4 * L**2,
        (2, 2): 156, (2, 4): -22 * L, (2, 8): 54, (2, 10): 13 * L,
        (4, 4): 4 * L**2, (4, 8): -13 * L, (4, 10): -3 * L**2, (8, 8): 156, (8, 10): 22 * L, (10, 10): 4 * L**2,
    }, 12)
    return K, M


def rigid_modes_3d(xyz: np.ndarray, rotations: bool) -> np.ndarray:
    """Columns: 3 translations and 3 infinitesimal rotations of a set of nodes.

    Per node dofs x y z (+ rx ry rz when ``rotations``): u = t + θ × r, rotation dofs = θ.
    """
    cols = []
    nd = 6 if rotations else 3
    for k in range(6):
        u = np.zeros((len(xyz), nd))
        if k < 3:
            u[:, k] = 1.0
        else:
            th = np.eye(3)[k - 3]
            u[:, :3] = np.cross(th, xyz)
            if rotations:
                u[:, 3:] = th
        cols.append(u.ravel())
    return np.array(cols).T


def rigid_modes_2d(xy: np.ndarray, rotation_dof: bool) -> np.ndarray:
    """Columns: x, y translations and the in-plane rotation of nodes (dofs x y [rz])."""
    nd = 3 if rotation_dof else 2
    cols = []
    for k in range(3):
        u = np.zeros((len(xy), nd))
        if k < 2:
            u[:, k] = 1.0
        else:
            u[:, 0], u[:, 1] = -xy[:, 1], xy[:, 0]
            if rotation_dof:
                u[:, 2] = 1.0
        cols.append(u.ravel())
    return np.array(cols).T


def random_elements(rng, n, planar=False, min_length=0.2):
    xa = rng.normal(size=(n, 3))
    d = rng.normal(size=(n, 3))
    if planar:
        xa[:, 2] = 0.0
        d[:, 2] = 0.0
    d *= (min_length + rng.random(n))[:, None] / np.linalg.norm(d, axis=1)[:, None]
    return xa, xa + d


def random_orientations(rng, xa, xb):
    """Orientation vectors well away from the element axes."""
    ex = (xb - xa) / np.linalg.norm(xb - xa, axis=1)[:, None]
    v = rng.normal(size=xa.shape)
    v -= 0.5 * np.einsum("ei,ei->e", v, ex)[:, None] * ex  # keep a generic, non-orthogonal angle
    return v


def total(terms, props):
    return el.combine(terms, props)


# --------------------------------------------------------------------------------------
# element stacks: closed forms
# --------------------------------------------------------------------------------------
def test_beam2d_matches_textbook_matrices_in_any_in_plane_direction():
    rng = np.random.default_rng(1)
    xa, xb = random_elements(rng, 5, planar=True)
    E, A, I, rho = 2.1e11, rng.uniform(1e-3, 5e-3, 5), rng.uniform(1e-7, 1e-6, 5), 7850.0
    t = el.beam2d_terms(xa, xb)
    K = total(t.K, {"E": E, "A": A, "I": I})
    M = total(t.M, {"rho": rho, "A": A})
    for e in range(5):
        L = np.linalg.norm(xb[e] - xa[e])
        Kl, Ml = textbook_beam2d(E, A[e], I[e], rho, L)
        T = beam2d_T(xa[e], xb[e])
        np.testing.assert_allclose(K[e], T.T @ Kl @ T, rtol=0, atol=1e-12 * np.abs(Kl).max())
        np.testing.assert_allclose(M[e], T.T @ Ml @ T, rtol=0, atol=1e-12 * np.abs(Ml).max())


def test_frame3d_matches_textbook_matrices_in_any_orientation():
    rng = np.random.default_rng(2)
    n = 6
    xa, xb = random_elements(rng, n)
    v = random_orientations(rng, xa, xb)
    E, G, rho = 2.1e11, 8.1e10, 7850.0
    A, Iy, Iz, J = (rng.uniform(1, 5, n) * s for s in (1e-3, 1e-7, 1e-7, 1e-7))
    t = el.frame3d_terms(xa, xb, v)
    K = total(t.K, {"E": E, "G": G, "A": A, "Iy": Iy, "Iz": Iz, "J": J})
    M = total(t.M, {"rho": rho, "A": A, "Iy": Iy, "Iz": Iz})
    for e in range(n):
        L = np.linalg.norm(xb[e] - xa[e])
        Kl, Ml = textbook_frame3d(E, G, A[e], Iy[e], Iz[e], J[e], rho, L)
        T = frame_T(xa[e], xb[e], v[e])
        np.testing.assert_allclose(K[e], T.T @ Kl @ T, rtol=0, atol=1e-12 * np.abs(Kl).max())
        np.testing.assert_allclose(M[e], T.T @ Ml @ T, rtol=0, atol=1e-12 * np.abs(Ml).max())


def test_lumped_mass_matrices_closed_form():
    """Lumped: rho A l/2 on each translation, rho A (l/2)^3/3 = rho A l^3/24 on each bending
    rotation (half the member about its end node), rho Ip l/2 on the twist (frame)."""
    rng = np.random.default_rng(21)
    xa, xb = random_elements(rng, 3, planar=True)
    L = np.linalg.norm(xb - xa, axis=1)
    M = total(el.beam2d_terms(xa, xb, mass="lumped").M, {"rho": 2.0, "A": 3.0})
    for e in range(3):
        # translations: isotropic, so the same in any in-plane direction
        np.testing.assert_allclose(M[e], 6.0 * np.diag(np.tile([L[e] / 2, L[e] / 2, L[e] ** 3 / 24], 2)), rtol=1e-14,
                                   atol=1e-15)
    xa, xb = random_elements(rng, 3)
    v = random_orientations(rng, xa, xb)
    L = np.linalg.norm(xb - xa, axis=1)
    Iy, Iz = 0.2, 0.5
    M = total(el.frame3d_terms(xa, xb, v, mass="lumped").M, {"rho": 2.0, "A": 3.0, "Iy": Iy, "Iz": Iz})
    for e in range(3):
        node = np.diag(np.concatenate([np.full(3, 6.0 * L[e] / 2), [2.0 * (Iy + Iz) * L[e] / 2],
                                       np.full(2, 6.0 * L[e] ** 3 / 24)]))
        T = frame_T(xa[e], xb[e], v[e])
        np.testing.assert_allclose(M[e], T.T @ np.kron(np.eye(2), node) @ T, rtol=0, atol=1e-14 * node.max())


def test_frame3d_along_x_is_the_local_matrix():
    """Member along global x with v = global y: global = local, no transformation at all."""
    xa, xb = np.zeros((1, 3)), np.array([[2.0, 0, 0]])
    t = el.frame3d_terms(xa, xb, [0.0, 1.0, 0.0])
    props = dict(E=3.0, G=1.3, A=0.7, Iy=0.11, Iz=0.29, J=0.17, rho=5.0)
    Kl, Ml = textbook_frame3d(*(props[k] for k in ("E", "G", "A", "Iy", "Iz", "J", "rho")), 2.0)
    np.testing.assert_allclose(total(t.K, props)[0], Kl, atol=1e-13)
    np.testing.assert_allclose(total(t.M, props)[0], Ml, atol=1e-13)


def test_rod_matches_closed_form():
    rng = np.random.default_rng(3)
    for dim in (2, 3):
        xa, xb = random_elements(rng, 4, planar=dim == 2)
        t = el.rod_terms(xa, xb, dim=dim)
        tl = el.rod_terms(xa, xb, dim=dim, mass="lumped")
        K = total(t.K, {"E": 7.0, "A": 0.3})
        M = total(t.M, {"rho": 2.0, "A": 0.3})
        Mlump = total(tl.M, {"rho": 2.0, "A": 0.3})
        for e in range(4):
            d = (xb[e] - xa[e])[:dim]
            L = np.linalg.norm(d)
            n = d / L
            B = np.concatenate([-n, n])  # strain-displacement row: elongation = B u
            np.testing.assert_allclose(K[e], 7.0 * 0.3 / L * np.outer(B, B), atol=1e-13)
            np.testing.assert_allclose(M[e], 2.0 * 0.3 * L / 6 * np.kron([[2, 1], [1, 2]], np.eye(dim)), atol=1e-13)
            np.testing.assert_allclose(Mlump[e], 2.0 * 0.3 * L / 2 * np.eye(2 * dim), atol=1e-13)


def test_spring_and_mass_units():
    t = el.spring_terms(3, grounded=False)
    assert t.M == [] and t.K[0][0] == ("k",)
    np.testing.assert_array_equal(t.K[0][1], np.broadcast_to([[1, -1], [-1, 1]], (3, 2, 2)))
    g = el.spring_terms(2, grounded=True)
    np.testing.assert_array_equal(g.K[0][1], np.ones((2, 1, 1)))
    m = el.mass_terms(2, 3)
    assert m.K == [] and m.M[0][0] == ("m",)
    np.testing.assert_array_equal(m.M[0][1], np.broadcast_to(np.eye(3), (2, 3, 3)))


# --------------------------------------------------------------------------------------
# the Appendix: physical terms as the element's unknowns
# --------------------------------------------------------------------------------------
def test_beam2d_physical_terms_reproduce_beam2d():
    rng = np.random.default_rng(4)
    n = 7
    xa, xb = random_elements(rng, n, planar=True)
    L = np.linalg.norm(xb - xa, axis=1)
    E, A, I = rng.uniform(1, 3, n) * 1e11, rng.uniform(1, 3, n) * 1e-3, rng.uniform(1, 3, n) * 1e-7
    pt = el.physical_terms_of_frame(E, 1.0, A, I, I, 1.0, L)
    for mass in ("consistent", "lumped"):
        ref = el.beam2d_terms(xa, xb, mass=mass)
        phy = el.beam2d_physical_terms(xa, xb, mass=mass)
        Kref = total(ref.K, {"E": E, "A": A, "I": I})
        Kphy = total(phy.K, {"EA_l": pt["EA_l"], "k12": pt["k12_z"], "k6": pt["k6_z"], "k2": pt["k2_z"]})
        np.testing.assert_allclose(Kphy, Kref, rtol=1e-13, atol=1e-13 * np.abs(Kref).max())
        np.testing.assert_allclose(total(phy.M, {"rho": 3.0, "A": A}), total(ref.M, {"rho": 3.0, "A": A}), rtol=1e-14)


def test_frame3d_physical_terms_reproduce_frame3d():
    rng = np.random.default_rng(5)
    n = 7
    xa, xb = random_elements(rng, n)
    v = random_orientations(rng, xa, xb)
    L = np.linalg.norm(xb - xa, axis=1)
    E, G = rng.uniform(1, 3, n) * 1e11, rng.uniform(0.5, 1, n) * 1e11
    A, Iy, Iz, J = (rng.uniform(1, 5, n) * s for s in (1e-3, 1e-7, 1e-7, 1e-7))
    pt = el.physical_terms_of_frame(E, G, A, Iy, Iz, J, L)
    for mass in ("consistent", "lumped"):
        ref = el.frame3d_terms(xa, xb, v, mass=mass)
        phy = el.frame3d_physical_terms(xa, xb, v, mass=mass)
        Kref = total(ref.K, {"E": E, "G": G, "A": A, "Iy": Iy, "Iz": Iz, "J": J})
        Kphy = total(phy.K, pt)
        np.testing.assert_allclose(Kphy, Kref, rtol=1e-12, atol=1e-13 * np.abs(Kref).max())
        Mref = total(ref.M, {"rho": 7.0, "A": A, "Iy": Iy, "Iz": Iz})
        Mphy = total(phy.M, {"rho": 7.0, "A": A, "Ip": Iy + Iz})
        np.testing.assert_allclose(Mphy, Mref, rtol=1e-13, atol=1e-14 * np.abs(Mref).max())


def test_physical_terms_of_frame_closed_form():
    pt = el.physical_terms_of_frame(E=2.0, G=3.0, A=5.0, Iy=7.0, Iz=11.0, J=13.0, length=0.5)
    expected = {"EA_l": 20.0, "GJ_l": 78.0, "k12_z": 12 * 22 / 0.125, "k6_z": 6 * 22 / 0.25, "k2_z": 88.0,
                "k12_y": 12 * 14 / 0.125, "k6_y": 6 * 14 / 0.25, "k2_y": 56.0}
    assert set(pt) == set(el.FRAME3D_PHYSICAL) == set(expected)
    for k, v in expected.items():
        assert pt[k] == pytest.approx(v, rel=1e-15)


@pytest.mark.parametrize("rotated", [False, True])
def test_frame3d_matches_the_appendix_matrix_of_displacements(rotated):
    """K_local u = A(u) @ (EA/l, 12EI/l^3, 6EI/l^2, GJ/l, 2EI/l) for Iy = Iz (paper, Appendix 1)."""
    rng = np.random.default_rng(6)
    E, G, A, I, J, L = 2.0e11, 7.9e10, 3e-3, 4e-7, 6e-7, 0.8
    if rotated:
        xa = rng.normal(size=(1, 3))
        xb = xa + L * np.array([[1.0, 2.0, 2.0]]) / 3.0
        v = np.array([0.3, -1.0, 0.4])
    else:
        xa, xb, v = np.zeros((1, 3)), np.array([[L, 0, 0]]), np.array([0.0, 1.0, 0.0])
    T = frame_T(xa[0], xb[0], v)
    terms = np.array([E * A / L, 12 * E * I / L**3, 6 * E * I / L**2, G * J / L, 2 * E * I / L])
    Kg = total(el.frame3d_terms(xa, xb, v).K, {"E": E, "G": G, "A": A, "Iy": I, "Iz": I, "J": J})[0]
    shared = {"EA_l": terms[0], "GJ_l": terms[3]}
    for k in ("_y", "_z"):
        shared |= {"k12" + k: terms[1], "k6" + k: terms[2], "k2" + k: terms[4]}
    Kp = total(el.frame3d_physical_terms(xa, xb, v).K, shared)[0]
    for _ in range(5):
        u_global = rng.normal(size=12)
        u_local = T @ u_global
        f_local = appendix_matrix(u_local) @ terms
        scale = np.abs(f_local).max()
        np.testing.assert_allclose(T @ (Kg @ u_global), f_local, rtol=0, atol=1e-12 * scale)
        np.testing.assert_allclose(T @ (Kp @ u_global), f_local, rtol=0, atol=1e-12 * scale)


def test_appendix_matrix_row7_typo_matters():
    """The printed row 7 (-x1 - x2) would break equilibrium; the corrected one does not."""
    u = np.zeros(12)
    u[0] = u[6] = 1.0  # rigid axial translation: no force anywhere
    terms = np.ones(5)
    np.testing.assert_array_equal(appendix_matrix(u) @ terms, np.zeros(12))
    xa, xb = np.zeros((1, 3)), np.array([[1.0, 0, 0]])
    K = total(el.frame3d_physical_terms(xa, xb, [0, 1, 0]).K, dict.fromkeys(el.FRAME3D_PHYSICAL, 1.0))[0]
    np.testing.assert_allclose(K @ u, 0, atol=1e-15)


def test_shared_bending_terms_equal_per_plane_terms():
    """Iy = Iz: giving k12, k6, k2 once for both planes == equal _y and _z values."""
    rng = np.random.default_rng(7)
    xa, xb = random_elements(rng, 4)
    v = random_orientations(rng, xa, xb)
    phy = el.frame3d_physical_terms(xa, xb, v)
    k12, k6, k2 = 3.0, 5.0, 7.0
    per_plane = total(phy.K, {"EA_l": 1.0, "GJ_l": 2.0, "k12_y": k12, "k12_z": k12, "k6_y": k6,
                              "k6_z": k6, "k2_y": k2, "k2_z": k2})
    # the shared form: each shared term's matrix is the sum of its two plane matrices
    units = dict((f[0], u) for f, u in phy.K)
    shared = (1.0 * units["EA_l"] + 2.0 * units["GJ_l"] + k12 * (units["k12_y"] + units["k12_z"])
              + k6 * (units["k6_y"] + units["k6_z"]) + k2 * (units["k2_y"] + units["k2_z"]))
    np.testing.assert_allclose(shared, per_plane, rtol=1e-14, atol=1e-14)


# --------------------------------------------------------------------------------------
# symmetry, definiteness, rigid-body null spaces
# --------------------------------------------------------------------------------------
def _element_cases(rng):
    n = 5
    xa3, xb3 = random_elements(rng, n)
    xa2, xb2 = random_elements(rng, n, planar=True)
    v = random_orientations(rng, xa3, xb3)
    L3 = np.linalg.norm(xb3 - xa3, axis=1)
    L2 = np.linalg.norm(xb2 - xa2, axis=1)
    fr = dict(E=2.0, G=0.8, A=rng.uniform(1, 2, n), Iy=rng.uniform(0.1, 0.3, n), Iz=rng.uniform(0.1, 0.3, n),
              J=rng.uniform(0.1, 0.3, n), rho=3.0)
    pt3 = el.physical_terms_of_frame(fr["E"], fr["G"], fr["A"], fr["Iy"], fr["Iz"], fr["J"], L3)
    pt2 = el.physical_terms_of_frame(2.0, 1.0, 1.5, 0.2, 0.2, 1.0, L2)
    for mass in ("consistent", "lumped"):
        yield f"rod2d-{mass}", el.rod_terms(xa2, xb2, dim=2, mass=mass), dict(E=2.0, A=1.5, rho=3.0), (xa2, xb2), 2
        yield f"rod3d-{mass}", el.rod_terms(xa3, xb3, dim=3, mass=mass), dict(E=2.0, A=1.5, rho=3.0), (xa3, xb3), 3
        yield f"beam2d-{mass}", el.beam2d_terms(xa2, xb2, mass=mass), dict(E=2.0, A=1.5, I=0.2, rho=3.0), (xa2, xb2), "beam"
        yield (f"beam2d_terms-{mass}", el.beam2d_physical_terms(xa2, xb2, mass=mass),
               dict(EA_l=pt2["EA_l"], k12=pt2["k12_z"], k6=pt2["k6_z"], k2=pt2["k2_z"], rho=3.0, A=1.5), (xa2, xb2), "beam")
        yield f"frame3d-{mass}", el.frame3d_terms(xa3, xb3, v, mass=mass), fr, (xa3, xb3), "frame"
        yield (f"frame3d_terms-{mass}", el.frame3d_physical_terms(xa3, xb3, v, mass=mass),
               pt3 | dict(rho=3.0, A=fr["A"], Ip=fr["Iy"] + fr["Iz"]), (xa3, xb3), "frame")


CASES = list(_element_cases(np.random.default_rng(8)))


@pytest.mark.parametrize("name,terms,props,geom,kind", CASES, ids=[c[0] for c in CASES])
def test_stacks_symmetric_and_semidefinite(name, terms, props, geom, kind):
    for target in (terms.K, terms.M):
        for factors, unit in target:
            scale = np.abs(unit).max(axis=(1, 2))
            np.testing.assert_allclose(unit, unit.transpose(0, 2, 1), rtol=0, atol=1e-14 * scale.max())
            lam = np.linalg.eigvalsh(unit)
            if factors[0].startswith("k6"):
                # the 6EI/l^2 coupling unit alone is indefinite (eigenvalues ±2, 0): only the
                # sum with 12EI/l^3 and 2EI/l terms in the physical ratio is semi-definite
                np.testing.assert_allclose(lam[:, [0, -1]], [[-2.0, 2.0]] * len(lam), rtol=1e-12)
            else:
                assert np.all(lam >= -1e-12 * scale[:, None]), (name, factors, lam.min())
    K = total(terms.K, props)
    M = total(terms.M, props)
    assert np.all(np.linalg.eigvalsh(K) >= -1e-12 * np.abs(K).max(axis=(1, 2))[:, None])
    # every element mass matrix is positive definite (every dof carries inertia)
    assert np.all(np.linalg.eigvalsh(M) > 0), name


@pytest.mark.parametrize("name,terms,props,geom,kind", CASES, ids=[c[0] for c in CASES])
def test_rigid_body_null_space(name, terms, props, geom, kind):
    xa, xb = geom
    K = total(terms.K, props)
    for e in range(K.shape[0]):
        xyz = np.array([xa[e], xb[e]])
        if kind == 2:
            R, rank = rigid_modes_2d(xyz[:, :2], rotation_dof=False), 1
        elif kind == 3:
            R, rank = rigid_modes_3d(xyz, rotations=False), 1
        elif kind == "beam":
            R, rank = rigid_modes_2d(xyz[:, :2], rotation_dof=True), 3
        else:
            R, rank = rigid_modes_3d(xyz, rotations=True), 6
        scale = np.abs(K[e]).max() * np.abs(R).max()
        np.testing.assert_allclose(K[e] @ R, 0, atol=1e-12 * scale)
        lam = np.linalg.eigvalsh(K[e])
        # exactly the rigid (and, for a rod, the trivial transverse) motions are stress-free
        assert np.sum(lam > 1e-10 * lam.max()) == rank


@pytest.mark.parametrize("name,terms,props,geom,kind", CASES, ids=[c[0] for c in CASES])
def test_element_mass_of_a_rigid_translation(name, terms, props, geom, kind):
    """u^T M u = rho A l for a unit rigid translation in any direction, consistent or lumped."""
    xa, xb = geom
    rng = np.random.default_rng(9)
    M = total(terms.M, props)
    L = np.linalg.norm(xb - xa, axis=1)
    A = np.broadcast_to(props["A"], L.shape)
    for e in range(M.shape[0]):
        d = rng.normal(size=3)
        if kind in (2, "beam"):
            d[2] = 0.0
        d /= np.linalg.norm(d)
        if kind == 2:
            u = np.tile(d[:2], 2)
        elif kind == 3:
            u = np.tile(d, 2)
        elif kind == "beam":
            u = np.tile([d[0], d[1], 0.0], 2)
        else:
            u = np.tile(np.concatenate([d, np.zeros(3)]), 2)
        assert u @ M[e] @ u == pytest.approx(props["rho"] * A[e] * L[e], rel=1e-13)


def test_frame_twist_inertia_uses_polar_moment():
    """Rigid twist about the member axis: u^T M u = rho (Iy + Iz) l, consistent and lumped."""
    rng = np.random.default_rng(10)
    xa, xb = random_elements(rng, 3)
    v = random_orientations(rng, xa, xb)
    L = np.linalg.norm(xb - xa, axis=1)
    Iy, Iz = np.array([1.0, 2.0, 3.0]), np.array([0.5, 0.25, 4.0])
    for mass in ("consistent", "lumped"):
        M = total(el.frame3d_terms(xa, xb, v, mass=mass).M, dict(rho=2.0, A=9.0, Iy=Iy, Iz=Iz))
        for e in range(3):
            ex = (xb[e] - xa[e]) / L[e]
            # rotation θ = ex about an axis through node a: node a does not move; node b moves θ × (xb - xa) = 0
            u = np.concatenate([np.zeros(3), ex, np.zeros(3), ex])
            assert u @ M[e] @ u == pytest.approx(2.0 * (Iy[e] + Iz[e]) * L[e], rel=1e-13)


def test_consistent_beam_mass_integrates_rigid_rotation_exactly():
    """Rigid rotation about node a, v = θ s: u^T M u = rho A l^3 / 3 (exact for cubic Hermite)."""
    rng = np.random.default_rng(11)
    xa, xb = random_elements(rng, 4, planar=True)
    L = np.linalg.norm(xb - xa, axis=1)
    M = total(el.beam2d_terms(xa, xb).M, {"rho": 2.0, "A": 3.0})
    for e in range(4):
        r = xb[e] - xa[e]
        u = np.array([0.0, 0.0, 1.0, -r[1], r[0], 1.0])
        assert u @ M[e] @ u == pytest.approx(2.0 * 3.0 * L[e] ** 3 / 3, rel=1e-13)


# --------------------------------------------------------------------------------------
# bad input to the element functions
# --------------------------------------------------------------------------------------
def test_zero_length_reports_positions():
    xa = np.array([[0.0, 0, 0], [1, 1, 0], [2, 0, 0]])
    xb = np.array([[1.0, 0, 0], [1, 1, 0], [2, 0, 0]])
    for fn in (lambda: el.rod_terms(xa, xb), lambda: el.beam2d_terms(xa, xb),
               lambda: el.beam2d_physical_terms(xa, xb), lambda: el.frame3d_terms(xa, xb, [0, 0, 1]),
               lambda: el.frame3d_physical_terms(xa, xb, [0, 0, 1])):
        with pytest.raises(InputError, match="zero") as ei:
            fn()
        assert ei.value.positions == [1, 2]


def test_orientation_parallel_to_axis():
    xa = np.zeros((2, 3))
    xb = np.array([[1.0, 0, 0], [1.0, 2.0, 2.0]])
    with pytest.raises(InputError, match="parallel") as ei:
        el.frame3d_terms(xa, xb, np.array([[0.0, 1.0, 0.0], [-2.0, -4.0, -4.0]]))
    assert ei.value.positions == [1]
    with pytest.raises(InputError, match="parallel"):
        el.frame3d_physical_terms(xa, xb, [0.0, 0.0, 0.0])


def test_planar_elements_out_of_plane():
    xa = np.zeros((2, 3))
    xb = np.array([[1.0, 0, 0], [1.0, 0, 0.5]])
    with pytest.raises(InputError, match="x-y plane") as ei:
        el.beam2d_terms(xa, xb)
    assert ei.value.positions == [1]
    with pytest.raises(InputError, match="x-y plane"):
        el.rod_terms(xa, xb, dim=2)
    with pytest.raises(InputError, match="dim"):
        el.rod_terms(xa, xb, dim=4)


@pytest.mark.parametrize("fn", [
    lambda m: el.rod_terms(np.zeros((1, 3)), np.ones((1, 3)), mass=m),
    lambda m: el.beam2d_terms(np.zeros((1, 3)), np.array([[1.0, 1, 0]]), mass=m),
    lambda m: el.beam2d_physical_terms(np.zeros((1, 3)), np.array([[1.0, 1, 0]]), mass=m),
    lambda m: el.frame3d_terms(np.zeros((1, 3)), np.ones((1, 3)), [0, 0, 1], mass=m),
    lambda m: el.frame3d_physical_terms(np.zeros((1, 3)), np.ones((1, 3)), [0, 0, 1], mass=m),
])
def test_unknown_mass_kind_is_refused(fn):
    with pytest.raises(InputError, match="'lumpd'"):
        fn("lumpd")


# --------------------------------------------------------------------------------------
# vibration of assembled members against closed forms
# --------------------------------------------------------------------------------------
E, RHO = 2.1e11, 7850.0


def _line_nodes(s, n, L, direction, origin=(0.0, 0.0, 0.0)):
    direction = np.asarray(direction, float)
    direction = direction / np.linalg.norm(direction)
    s.add_nodes(list(range(n + 1)), np.asarray(origin) + np.outer(np.linspace(0, L, n + 1), direction))
    return np.column_stack([np.arange(n), np.arange(1, n + 1)])


def _beta_l(lam, EI, rhoA, L):
    return (lam * rhoA / EI) ** 0.25 * L


def beam2d_line(n, L=1.3, direction=(1.0, 0.0, 0.0), mass="consistent", clamp=True, A=2e-3, I=3e-7):
    s = Structure("beam")
    pairs = _line_nodes(s, n, L, direction)
    s.beam2d(pairs, E=E, A=A, I=I, rho=RHO, mass=mass)
    if clamp:
        s.support(["0:x", "0:y", "0:rz"])
    return s.build()


def bending_beta_l(model, n_bend, L=1.3, A=2e-3, I=3e-7, skip=0):
    """βL of the lowest bending modes (axial modes of these slender beams lie far above)."""
    modes = model_modes(model)
    lam = modes.eigenvalues[modes.n_rigid:]
    return _beta_l(lam[skip: skip + n_bend], E * I, RHO * A, L), modes


@pytest.mark.parametrize("direction", [(1.0, 0.0, 0.0), (0.6, -0.8, 0.0)])
def test_cantilever_beam2d_converges_to_euler_bernoulli(direction):
    bl40, modes = bending_beta_l(beam2d_line(40, direction=direction), 4)
    bl20, _ = bending_beta_l(beam2d_line(20, direction=direction), 4)
    assert modes.n_rigid == 0
    err40 = (bl40 - CANTILEVER_BL) / CANTILEVER_BL
    err20 = (bl20 - CANTILEVER_BL) / CANTILEVER_BL
    # consistent mass is a Rayleigh-Ritz bound: from above (up to eigen-solver round-off ~1e-9)
    assert np.all(err40 > -1e-8) and np.all(err20 > -1e-8)
    assert np.all(np.abs(err40[:3]) < 1e-5), err40
    assert abs(err40[3]) < 1e-5, err40
    # mesh convergence of the cubic-Hermite beam: frequency error O(h^4), so halving h divides
    # the error by ~16 (modes 2-4, whose error is well above round-off)
    ratio = err20[1:] / err40[1:]
    assert np.all((ratio > 12) & (ratio < 20)), ratio


def test_free_free_beam2d_rigid_modes_and_frequencies():
    model = beam2d_line(40, direction=(0.28, 0.96, 0.0), clamp=False)
    bl, modes = bending_beta_l(model, 3)
    assert modes.n_rigid == 3  # x, y translation and in-plane rotation
    np.testing.assert_array_equal(modes.eigenvalues[:3], 0.0)
    np.testing.assert_allclose(bl, FREE_FREE_BL, rtol=1e-5)


def test_lumped_mass_converges_from_below_and_slower():
    bl = {}
    for n in (20, 40):
        bl[n], _ = bending_beta_l(beam2d_line(n, mass="lumped"), 4)
    err = {n: (b - CANTILEVER_BL) / CANTILEVER_BL for n, b in bl.items()}
    assert np.all(err[40] < 0) and np.all(err[20] < err[40])  # from below, improving
    assert np.all(np.abs(err[40]) < 5e-3), err[40]
    ratio = err[20] / err[40]
    assert np.all((ratio > 3.5) & (ratio < 4.5)), ratio  # O(h^2)


@pytest.mark.parametrize("mass", ["consistent", "lumped"])
def test_total_mass_of_assembled_structures_is_exact(mass):
    """1^T M 1 in any translation direction = rho A L (sum over members), rod/beam/frame."""
    rng = np.random.default_rng(12)
    model = beam2d_line(9, L=2.0, direction=(0.6, 0.8, 0.0), mass=mass, clamp=False)
    for d in ([1.0, 0.0], [0.0, 1.0]):
        u = np.array([d[0] if lab.endswith(":x") else d[1] if lab.endswith(":y") else 0.0 for lab in model.dofs])
        assert u @ (model.M() @ u) == pytest.approx(RHO * 2e-3 * 2.0, rel=1e-13)
    s = Structure("frame")
    xyz = rng.normal(size=(4, 3))
    s.add_nodes([1, 2, 3, 4], xyz)
    pairs = np.array([[1, 2], [2, 3], [3, 4], [4, 1], [1, 3]])
    Ls = np.linalg.norm(xyz[pairs[:, 1] - 1] - xyz[pairs[:, 0] - 1], axis=1)
    As = rng.uniform(1, 2, 5) * 1e-3
    s.frame3d(pairs, E=E, G=8e10, A=As, Iy=1e-7, Iz=2e-7, J=1e-7, rho=RHO,
              orientation=random_orientations(rng, xyz[pairs[:, 0] - 1], xyz[pairs[:, 1] - 1]), mass=mass)
    s.rod([[2, 4]], E=E, A=5e-4, rho=RHO, mass=mass)
    m = s.build()
    total_mass = RHO * (As @ Ls + 5e-4 * np.linalg.norm(xyz[3] - xyz[1]))
    d = rng.normal(size=3)
    d /= np.linalg.norm(d)
    u = np.array([d["xyz".index(lab[-1])] if lab[-2] == ":" else 0.0 for lab in m.dofs])
    assert u @ (m.M() @ u) == pytest.approx(total_mass, rel=1e-13)


def _discrete_rod_eigenvalues(c2, h, n, k, mass):
    """Exact eigenvalues of the uniform fixed-free chain of n linear elements.

    The modes are sin(κ x_i) with κ L = (2k - 1) π / 2 (the free end is satisfied exactly),
    θ = κ h; consistent mass: λ = 6 c²/h² (1 - cos θ)/(2 + cos θ); lumped: 4 c²/h² sin²(θ/2).
    """
    th = (2 * np.asarray(k) - 1) * np.pi / (2 * n)
    if mass == "consistent":
        return 6 * c2 / h**2 * (1 - np.cos(th)) / (2 + np.cos(th))
    return 4 * c2 / h**2 * np.sin(th / 2) ** 2


@pytest.mark.parametrize("mass", ["consistent", "lumped"])
def test_axial_rod_fixed_free(mass):
    """3-D rod chain along (1,2,2)/3: transverse dofs are mechanisms, axial modes exact."""
    n, L, A = 30, 2.5, 1e-4
    s = Structure("rod")
    pairs = _line_nodes(s, n, L, (1.0, 2.0, 2.0), origin=(0.5, -1.0, 2.0))
    s.rod(pairs, E=E, A=A, rho=RHO, mass=mass)
    s.support(["0:x", "0:y", "0:z"])
    modes = model_modes(s.build())
    assert modes.n_rigid == 2 * n  # a straight pin-jointed chain cannot resist transverse motion
    lam = modes.eigenvalues[modes.n_rigid:]
    k = np.arange(1, n + 1)
    np.testing.assert_allclose(lam, _discrete_rod_eigenvalues(E / RHO, L / n, n, k, mass), rtol=1e-9)
    # and towards the continuum: ω_k = (2k-1) π/2 sqrt(E/rho)/L, from above (consistent) or below (lumped)
    omega = (2 * k[:3] - 1) * np.pi / 2 * np.sqrt(E / RHO) / L
    rel = np.sqrt(lam[:3]) / omega - 1
    assert np.all(rel > 0) if mass == "consistent" else np.all(rel < 0)
    # leading error term ±(θ²/24) of the two discretisations, θ = κ h
    th = (2 * k[:3] - 1) * np.pi / (2 * n)
    np.testing.assert_allclose(np.abs(rel), th**2 / 24, rtol=0.05)


def test_rod2d_truss_axial_modes_along_x():
    n, L, A = 20, 1.0, 1e-4
    s = Structure("rod2d")
    pairs = _line_nodes(s, n, L, (1.0, 0.0, 0.0))
    s.rod(pairs, E=E, A=A, rho=RHO, dim=2)
    s.support(["0:x"] + [f"{i}:y" for i in range(n + 1)])
    modes = model_modes(s.build())
    assert modes.n_rigid == 0 and modes.n_modes == n
    k = np.arange(1, n + 1)
    np.testing.assert_allclose(modes.eigenvalues, _discrete_rod_eigenvalues(E / RHO, L / n, n, k, "consistent"), rtol=1e-9)


FRAME = dict(G=8.0e10, A=4e-3, Iy=2e-6, Iz=5.4e-6, J=3e-6)


def frame_cantilever(n, L, axis, v, mass="consistent", clamp=True, origin=(0.3, -0.2, 0.1)):
    s = Structure("frame")
    pairs = _line_nodes(s, n, L, axis, origin)
    s.frame3d(pairs, E=E, rho=RHO, orientation=v, mass=mass, **FRAME)
    if clamp:
        s.support_node([0])
    return s.build()


@pytest.mark.parametrize("axis,v", [((1.0, 0.0, 0.0), (0.0, 1.0, 0.0)),
                                    ((1.0, 2.0, 2.0), (0.0, 0.0, 1.0)),
                                    ((1.0, 2.0, 2.0), (-1.0, 3.0, 0.5))])
def test_frame3d_cantilever_spectrum(axis, v):
    """Both bending planes (E Iy, E Iz), axial (E A) and torsion (G J, rho Ip), one spectrum.

    Bending: Euler-Bernoulli βL; axial and torsion: the exact eigenvalues of the linear-element
    chain (as for the rod), c² = E/rho and G J/(rho Ip) with Ip = Iy + Iz.
    """
    n, L = 40, 1.5
    model = frame_cantilever(n, L, axis, v)
    # LAPACK directly: model_modes misclassifies the lowest mode of this model as rigid (see
    # test_model_modes_keeps_low_flexible_modes_of_fine_meshes)
    lam_all, shapes = sla.eigh(model.K().toarray(), model.M().toarray())
    A, Iy, Iz = FRAME["A"], FRAME["Iy"], FRAME["Iz"]
    bz = CANTILEVER_BL**4 * E * Iz / (RHO * A * L**4)
    by = CANTILEVER_BL**4 * E * Iy / (RHO * A * L**4)
    k = np.arange(1, 4)
    axial = _discrete_rod_eigenvalues(E / RHO, L / n, n, k, "consistent")
    torsion = _discrete_rod_eigenvalues(FRAME["G"] * FRAME["J"] / (RHO * (Iy + Iz)), L / n, n, k, "consistent")
    expected = np.concatenate([bz, by, axial, torsion])
    # relative tolerance per family: bending βL within 1e-5 (λ ∝ (βL)^4), chains exact
    tol = np.concatenate([np.full(8, 4e-5), np.full(6, 1e-9)])
    order = np.argsort(expected)
    expected, tol = expected[order], tol[order]
    n_check = np.searchsorted(expected, bz[3] * 1.0001)  # everything up to the 4th Iz bending mode
    lam = lam_all[:n_check]
    np.testing.assert_array_less(np.abs(lam - expected[:n_check]) / expected[:n_check], tol[:n_check])
    # the lowest mode bends in the stiffer-free plane: about local y (Iy < Iz), i.e. it moves along
    # local z = x × v; the second moves along local y.  Checks the orientation convention.
    R = local_axes([0, 0, 0], axis, np.asarray(v, float))
    tip = [model.dofs.index(f"{n}:{d}") for d in ("x", "y", "z")]
    for mode, axis_row in ((0, 2), (1, 1)):
        t_local = R @ shapes[tip, mode]
        off = np.delete(np.abs(t_local), axis_row)
        assert off.max() < 1e-6 * abs(t_local[axis_row]), (mode, t_local)


def test_frame3d_free_free_six_rigid_modes():
    n, L = 30, 1.5
    model = frame_cantilever(n, L, (1.0, 2.0, 2.0), (0.0, 0.0, 1.0), clamp=False)
    modes = model_modes(model, n_modes=12)
    assert modes.n_rigid == 6
    np.testing.assert_array_equal(modes.eigenvalues[:6], 0.0)
    A, Iy, Iz = FRAME["A"], FRAME["Iy"], FRAME["Iz"]
    by = FREE_FREE_BL**4 * E * Iy / (RHO * A * L**4)
    bz = FREE_FREE_BL**4 * E * Iz / (RHO * A * L**4)
    # free-free chains (modes cos κx, κL = kπ) are also exact in closed form: θ = kπ/n
    k = np.arange(1, 3)
    th = k * np.pi / n
    chain = 6 * (n / L) ** 2 * (1 - np.cos(th)) / (2 + np.cos(th))
    axial, torsion = chain * E / RHO, chain * FRAME["G"] * FRAME["J"] / (RHO * (Iy + Iz))
    expected = np.concatenate([by, bz, axial, torsion])
    tol = np.concatenate([np.full(6, 4e-5), np.full(4, 1e-9)])
    order = np.argsort(expected)
    np.testing.assert_array_less(np.abs(modes.eigenvalues[6:12] - expected[order][:6]) / expected[order][:6],
                                 tol[order][:6])
    # the six zero modes span the rigid-body motions (u = t + θ × r, rotations θ)
    xyz = np.array([model.nodes[i] for i in range(n + 1)])
    Rb = rigid_modes_3d(xyz, rotations=True)
    Q = sla.orth(modes.shapes[:, :6])
    resid = Rb - Q @ (Q.T @ Rb)
    assert np.linalg.norm(resid) < 1e-8 * np.linalg.norm(Rb)


def test_frame3d_torsion_uses_gj_and_polar_moment():
    """Fixed-free shaft: ω_k = (2k-1)π/2 sqrt(GJ/(rho Ip))/L with Ip = Iy + Iz (not J)."""
    n, L = 40, 2.0
    s = Structure("shaft")
    pairs = _line_nodes(s, n, L, (0.0, 0.6, 0.8))
    Iy, Iz, J = 1e-6, 3e-6, 2.5e-6
    s.frame3d(pairs, E=E, G=8e10, A=1e-2, Iy=Iy, Iz=Iz, J=J, rho=RHO, orientation=[1.0, 0.0, 0.0])
    s.support_node([0])
    modes = model_modes(s.build())
    c2 = 8e10 * J / (RHO * (Iy + Iz))
    k = np.arange(1, 4)
    exact = ((2 * k - 1) * np.pi / 2) ** 2 * c2 / L**2
    # pick the twist-dominated modes: largest rotational component about the axis
    axis = np.array([0.0, 0.6, 0.8])
    twist = np.zeros(modes.n_modes)
    for i in range(1, n + 1):
        idx = [modes.dofs.index(f"{i}:{d}") for d in ("rx", "ry", "rz")]
        twist += (axis @ modes.shapes[idx]) ** 2
    twist /= np.sum(modes.shapes**2, axis=0)  # fraction of the shape that is twist about the axis
    lam_t = np.sort(modes.eigenvalues[twist > 0.999])[:3]
    np.testing.assert_allclose(lam_t, _discrete_rod_eigenvalues(c2, L / n, n, k, "consistent"), rtol=1e-9)
    np.testing.assert_allclose(np.sqrt(lam_t), np.sqrt(exact), rtol=2e-3)


# --------------------------------------------------------------------------------------
# rotational invariance
# --------------------------------------------------------------------------------------
def _space_frame(xyz, orient, lumped=False):
    s = Structure("space frame")
    s.add_nodes(list(range(1, len(xyz) + 1)), xyz)
    pairs = np.array([[1, 2], [2, 3], [3, 4], [4, 1], [1, 3], [2, 5], [5, 3], [4, 5]])
    s.frame3d(pairs, E=E, G=8e10, A=[1e-3, 2e-3, 1.5e-3, 1e-3, 3e-3, 2e-3, 1e-3, 1.2e-3],
              Iy=2e-7, Iz=[3e-7, 5e-7, 2e-7, 4e-7, 6e-7, 1e-7, 2e-7, 3e-7], J=4e-7, rho=RHO,
              orientation=orient, mass="lumped" if lumped else "consistent")
    s.support_node([1])
    return s.build()


@pytest.mark.parametrize("lumped", [False, True])
def test_space_frame_eigenvalues_invariant_under_rotation(lumped):
    rng = np.random.default_rng(13)
    xyz = rng.normal(size=(5, 3))
    orient = rng.normal(size=(8, 3))
    R = Rotation.random(random_state=14).as_matrix()
    base = _space_frame(xyz, orient, lumped)
    lam0 = sla.eigh(base.K().toarray(), base.M().toarray(), eigvals_only=True)
    rotated = _space_frame(xyz @ R.T + [3.0, -1.0, 2.0], orient @ R.T, lumped)
    lam1 = sla.eigh(rotated.K().toarray(), rotated.M().toarray(), eigvals_only=True)
    np.testing.assert_allclose(lam1, lam0, rtol=1e-8)
    # a different orientation of the same members does change the spectrum (Iy != Iz): the test can fail
    other = _space_frame(xyz, rng.normal(size=(8, 3)), lumped)
    lam2 = sla.eigh(other.K().toarray(), other.M().toarray(), eigvals_only=True)
    assert not np.allclose(lam2, lam0, rtol=1e-6)


def test_planar_truss_and_frame_invariant_under_in_plane_rotation():
    rng = np.random.default_rng(15)
    xy = np.array([[0.0, 0.0], [1.0, 0.0], [2.0, 0.0], [0.5, 0.8], [1.5, 0.9]]) + rng.normal(0, 0.05, (5, 2))
    bars = [[1, 2], [2, 3], [1, 4], [2, 4], [2, 5], [3, 5], [4, 5]]

    def build(pts, kind):
        s = Structure(kind)
        s.add_nodes([1, 2, 3, 4, 5], pts)
        if kind == "truss":
            s.rod(bars, E=E, A=np.linspace(1e-4, 3e-4, 7), rho=RHO, dim=2)
            s.support(["1:x", "1:y", "3:x", "3:y"])
        else:
            s.beam2d(bars, E=E, A=1e-3, I=np.linspace(1e-7, 4e-7, 7), rho=RHO)
            s.support(["1:x", "1:y", "1:rz"])
        m = s.build()
        return sla.eigh(m.K().toarray(), m.M().toarray(), eigvals_only=True)

    a = 2.1
    R = np.array([[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]])
    for kind in ("truss", "frame"):
        np.testing.assert_allclose(build(xy @ R.T + [4.0, -2.0], kind), build(xy, kind), rtol=1e-9)


def test_assembly_equals_hand_assembly_of_element_stacks():
    """Second route for assembly: scatter the element matrices by hand into a dense matrix."""
    rng = np.random.default_rng(16)
    xyz = rng.normal(size=(4, 3))
    xyz[:, 2] = 0.0
    s = Structure("hand")
    s.add_nodes([1, 2, 3, 4], xyz)
    pairs = [[1, 2], [2, 3], [3, 4], [1, 3]]
    s.beam2d(pairs, E=E, A=1e-3, I=2e-7, rho=RHO)
    s.spring(["4:y"], k=1e6)
    s.mass(["4:x", "4:y"], m=3.0)
    s.support(["1:x", "1:y"])
    model = s.build()
    dofs = list(model.dofs)
    n = len(dofs)
    Kh, Mh = np.zeros((n, n)), np.zeros((n, n))
    for a, b in pairs:
        Kl, Ml = textbook_beam2d(E, 1e-3, 2e-7, RHO, np.linalg.norm(xyz[b - 1] - xyz[a - 1]))
        T = beam2d_T(xyz[a - 1], xyz[b - 1])
        labels = [f"{a}:x", f"{a}:y", f"{a}:rz", f"{b}:x", f"{b}:y", f"{b}:rz"]
        for i, li in enumerate(labels):
            for j, lj in enumerate(labels):
                if li in dofs and lj in dofs:
                    Kh[dofs.index(li), dofs.index(lj)] += (T.T @ Kl @ T)[i, j]
                    Mh[dofs.index(li), dofs.index(lj)] += (T.T @ Ml @ T)[i, j]
    Kh[dofs.index("4:y"), dofs.index("4:y")] += 1e6
    Mh[dofs.index("4:x"), dofs.index("4:x")] += 3.0
    Mh[dofs.index("4:y"), dofs.index("4:y")] += 3.0
    assert "1:x" not in dofs and "1:rz" in dofs
    np.testing.assert_allclose(model.K().toarray(), Kh, rtol=0, atol=1e-12 * np.abs(Kh).max())
    np.testing.assert_allclose(model.M().toarray(), Mh, rtol=0, atol=1e-12 * np.abs(Mh).max())


# --------------------------------------------------------------------------------------
# the modal solver on these element models (modal.py is not this file's subject, but its
# rigid-body classification decides what the tests above can use)
# --------------------------------------------------------------------------------------
def test_model_modes_keeps_low_flexible_modes_of_fine_meshes():
    model = frame_cantilever(40, 1.5, (1.0, 2.0, 2.0), (0.0, 0.0, 1.0))
    modes = model_modes(model)
    assert modes.n_rigid == 0
    by1 = CANTILEVER_BL[0] ** 4 * E * FRAME["Iy"] / (RHO * FRAME["A"] * 1.5**4)
    assert modes.eigenvalues[0] == pytest.approx(by1, rel=1e-6)


@pytest.mark.parametrize("method", ["dense", "sparse"])
def test_model_modes_rigid_modes_alone(method):
    model = beam2d_line(40, clamp=False)
    modes = model_modes(model, n_modes=3, method=method)
    assert modes.n_rigid == 3


def test_vanishing_element_length_is_input_error():
    """An element so short that its bending terms (1/l^3) overflow is refused by name, not turned
    into NaN (found by the random corruption test: a node at 2e-105)."""
    from femupdate import InputError, Structure

    s = Structure("vanishing beam")
    s.parameter("E", 2.0e11)
    s.node(1, [0.0, 0.0, 0.0])
    s.node(2, [2e-105, 0.0, 0.0])
    s.beam2d([1, 2], E="E", A=1e-3, I=1e-8, rho=7850.0)
    with pytest.raises(InputError, match="vanishing"):
        s.build()
