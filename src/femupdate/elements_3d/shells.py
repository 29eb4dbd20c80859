r"""Flat shell elements: MITC4 quadrilateral and MITC3 triangle (Reissner-Mindlin).

Each element is a flat plate in its own local frame: plane-stress membrane, Reissner-Mindlin
bending and transverse shear by the Mixed Interpolation of Tensorial Components (assumed
covariant transverse shear strains tied at points), which removes shear locking of thin shells.

* MITC4: K. J. Bathe, E. N. Dvorkin, "A formulation of general shell elements - the use of
  mixed interpolation of tensorial components", *Int. J. Numer. Meth. Engng* 22 (1986) 697-722;
  E. N. Dvorkin, K. J. Bathe, *Engineering Computations* 1 (1984) 77-88.  Bilinear membrane and
  rotations (2 x 2 Gauss); shear strains e_xi tied at (0, +-1), e_eta at (+-1, 0).
* MITC3: P. S. Lee, K. J. Bathe, "Development of MITC isotropic triangular shell finite
  elements", *Computers & Structures* 82 (2004) 945-962.  Linear membrane (constant strain) and
  rotations; the covariant shear strains tied at (1/2, 0), (0, 1/2) and (1/2, 1/2):
  e_rt = e_rt(1) + c s, e_st = e_st(2) - c r, c = e_st(2) - e_rt(1) - e_st(3) + e_rt(3).

Drilling dof: the rotation about the element normal has no stiffness in this theory.  It is
tied to the in-plane rotation of the membrane by a Hughes-Brezzi penalty
(T. J. R. Hughes, F. Brezzi, *Comput. Methods Appl. Mech. Engng* 72 (1989) 105-121),
``K_drill = drill * G t  int (theta_z - omega)^2 dA`` with ``omega = (dv/dx - du/dy)/2``,
integrated with the membrane's rule, with the default factor ``drill = 0.1`` (Hughes & Brezzi and
OpenSees's ShellMITC4 use 1): a free element has exactly 6 zero eigenvalues, and the in-plane
stiffness changes by well under 1 %.  Much smaller factors leave a near-mechanism in shells whose
elements are not coplanar: MacNeal & Harder's twisted beam comes out 25-30 % too flexible with
1e-3, and the error grows under refinement (it is within 1 % with 0.1 or 1).  Its rotary inertia
is that of the other rotations.

Exact decomposition: with G = E / (2 (1 + nu)) and shear correction 5/6, the local stiffness is

    K = E t K_membrane + E t^3 K_bending + E t K_shear + E t K_drill,
    M = rho t M_translation + rho t^3 M_rotation,

returned as separate terms with factors ``("E", "t")``, ``("E", "t", "t", "t")``, ``("E", "t")``,
``("E", "t")`` and ``("rho", "t")``, ``("rho", "t", "t", "t")`` (nu, the shear factor and drill
are folded into the unit matrices: nu is a fixed number of the element).

Dofs: 6 per node in global axes, ``ux, uy, uz, rx, ry, rz``, node by node.  Units: N/m, N, N·m
(rad) with E in Pa, t and coordinates in m; mass in kg and kg·m² with rho in kg/m³.

Local frame: origin at the node centroid, normal e3 along (x3 - x1) x (x4 - x2) for the
quadrilateral, (x2 - x1) x (x3 - x1) for the triangle (node order counter-clockwise about the
normal), e1 along the side 1-2 projected on the plane, e2 = e3 x e1.  A warped quadrilateral is
projected onto the mean plane through its node centroid, and each node is joined to its projection
by a rigid offset (MacNeal's warping correction), so that rigid-body motions of the warped element
stay free of strain; the flat element underneath is not corrected otherwise (keep warping small).
"""

from __future__ import annotations

import numpy as np

from .._errors import InputError
from ..elements import ElementTerms, _group_error
from ._common import btdb, check_mass_kind, coords, expand_scalar, gauss_quad, hrz_lump, plane_stress, poisson

SHEAR_FACTOR = 5.0 / 6.0
DRILL = 0.1
QUAD_CORNERS = np.array([[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]])
# local dof positions within a node
_U, _V, _W, _TX, _TY, _TZ = range(6)


def _local_frame(X: np.ndarray, what: str) -> tuple[np.ndarray, np.ndarray]:
    """Rotation rows (e1, e2, e3) ``(n_el, 3, 3)`` and local in-plane coordinates ``(n_el, nn, 2)``."""
    if X.shape[1] == 4:
        d1, d2 = X[:, 2] - X[:, 0], X[:, 3] - X[:, 1]
    else:
        d1, d2 = X[:, 1] - X[:, 0], X[:, 2] - X[:, 0]
    e3 = np.cross(d1, d2)
    n3 = np.linalg.norm(e3, axis=1)
    scale = np.max(np.linalg.norm(X - X[:, :1], axis=2), axis=1) ** 2
    bad = np.flatnonzero(~(n3 > 1e-12 * scale))
    if bad.size:
        raise _group_error(f"{what} element(s) at position(s) {bad[:8].tolist()} of the group are degenerate "
                           "(zero area: repeated or collinear nodes)", bad)
    e3 = e3 / n3[:, None]
    s = X[:, 1] - X[:, 0]
    e1 = s - np.einsum("ni,ni->n", s, e3)[:, None] * e3
    e1 /= np.linalg.norm(e1, axis=1)[:, None]
    e2 = np.cross(e3, e1)
    R = np.stack([e1, e2, e3], axis=1)
    xl = np.einsum("nij,naj->nai", R[:, :2], X - X.mean(axis=1, keepdims=True))
    return R, xl


def _warp_links(X: np.ndarray, R: np.ndarray) -> np.ndarray | None:
    """Rigid offsets from each node to its projection on the element's mean plane, ``(n_el, 6 nn, 6 nn)``
    (global axes: u_projection = u_node + theta x d, d = projection - node), or None when every
    element is flat (the triangles always are)."""
    h = np.einsum("nai,ni->na", X - X.mean(axis=1, keepdims=True), R[:, 2])
    if not np.any(h):
        return None
    n, nn = h.shape
    d = -h[:, :, None] * R[:, None, 2, :]  # (n, nn, 3)
    W = np.zeros((n, nn, 6, nn, 6))
    for a in range(nn):
        W[:, a, :, a, :] = np.eye(6)
        dx, dy, dz = d[:, a, 0], d[:, a, 1], d[:, a, 2]
        # theta x d = (ty dz - tz dy, tz dx - tx dz, tx dy - ty dx)
        W[:, a, 0, a, 4], W[:, a, 0, a, 5] = dz, -dy
        W[:, a, 1, a, 3], W[:, a, 1, a, 5] = -dz, dx
        W[:, a, 2, a, 3], W[:, a, 2, a, 4] = dy, -dx
    return W.reshape(n, 6 * nn, 6 * nn)


def _to_global(K: np.ndarray, R: np.ndarray) -> np.ndarray:
    """T^T K T with T block-diagonal of R, per node translations and rotations."""
    n, ne, _ = K.shape
    nb = ne // 3
    Kr = K.reshape(n, nb, 3, nb, 3)
    return np.einsum("nai,npaqb,nbj->npiqj", R, Kr, R, optimize=True).reshape(n, ne, ne)


def _bmats(N, dNdx, nn):
    """Membrane, bending and drilling strain matrices at points: ``(..., 3|3|1, 6 nn)``."""
    lead = dNdx.shape[:-2]
    dx, dy = dNdx[..., 0], dNdx[..., 1]
    Bm = np.zeros((*lead, 3, nn, 6))
    Bm[..., 0, :, _U] = dx
    Bm[..., 1, :, _V] = dy
    Bm[..., 2, :, _U], Bm[..., 2, :, _V] = dy, dx
    Bb = np.zeros((*lead, 3, nn, 6))  # kappa_xx = d(ty)/dx, kappa_yy = -d(tx)/dy, kappa_xy = d(ty)/dy - d(tx)/dx
    Bb[..., 0, :, _TY] = dx
    Bb[..., 1, :, _TX] = -dy
    Bb[..., 2, :, _TY], Bb[..., 2, :, _TX] = dy, -dx
    Bd = np.zeros((*lead, 1, nn, 6))  # theta_z - (dv/dx - du/dy) / 2
    Bd[..., 0, :, _TZ] = np.broadcast_to(N, dx.shape)
    Bd[..., 0, :, _U], Bd[..., 0, :, _V] = 0.5 * dy, -0.5 * dx
    return tuple(B.reshape(*lead, B.shape[-3], 6 * nn) for B in (Bm, Bb, Bd))


def _covariant_shear(N, dNdxi_k, xk, nn):
    """Row of the covariant transverse shear strain e_k = dw/dxi_k + ty dx/dxi_k - tx dy/dxi_k.

    ``N`` ``(nn,)`` and ``dNdxi_k`` ``(nn,)`` at one tying point, ``xk`` = d(x, y)/dxi_k ``(n_el, 2)``.
    Returns ``(n_el, 6 nn)``.
    """
    n = len(xk)
    row = np.zeros((n, nn, 6))
    row[:, :, _W] = dNdxi_k
    row[:, :, _TY] = N[None] * xk[:, 0:1]
    row[:, :, _TX] = -N[None] * xk[:, 1:2]
    return row.reshape(n, 6 * nn)


def _quad_shape(p):
    c = QUAD_CORNERS
    N = (1 + p[:, None, 0] * c[None, :, 0]) * (1 + p[:, None, 1] * c[None, :, 1]) / 4
    dN = np.stack([c[None, :, 0] * (1 + p[:, None, 1] * c[None, :, 1]),
                   c[None, :, 1] * (1 + p[:, None, 0] * c[None, :, 0])], axis=2) / 4
    return N, dN  # (g, 4), (g, 4, 2)


def _tri_shape(p):
    N = np.column_stack([1 - p[:, 0] - p[:, 1], p[:, 0], p[:, 1]])
    dN = np.broadcast_to(np.array([[-1.0, -1.0], [1.0, 0.0], [0.0, 1.0]]), (len(p), 3, 2))
    return N, dN


def _shear_mitc4(xl):
    """Assumed shear strain matrices at the 2 x 2 Gauss points: ``(n_el, 4, 2, 24)`` (natural comps)."""
    tie = {"A": (0.0, 1.0), "C": (0.0, -1.0), "B": (1.0, 0.0), "D": (-1.0, 0.0)}
    e = {}
    for name, pt in tie.items():
        N, dN = _quad_shape(np.array([pt]))
        k = 0 if name in "AC" else 1
        xk = np.einsum("a,nai->ni", dN[0, :, k], xl)
        e[name] = _covariant_shear(N[0], dN[0, :, k], xk, 4)
    P, _ = gauss_quad(2)
    rows = []
    for xi, eta in P:
        exi = 0.5 * (1 + eta) * e["A"] + 0.5 * (1 - eta) * e["C"]
        eeta = 0.5 * (1 + xi) * e["B"] + 0.5 * (1 - xi) * e["D"]
        rows.append(np.stack([exi, eeta], axis=1))
    return np.stack(rows, axis=1)


def _shear_mitc3(xl, P):
    """Assumed shear strain matrices of MITC3 at points ``P`` (r, s): ``(n_el, g, 2, 18)``."""
    def cov(pt, k):
        N, dN = _tri_shape(np.array([pt]))
        xk = np.einsum("a,nai->ni", dN[0, :, k], xl)
        return _covariant_shear(N[0], dN[0, :, k], xk, 3)

    e1r, e2s = cov((0.5, 0.0), 0), cov((0.0, 0.5), 1)
    e3r, e3s = cov((0.5, 0.5), 0), cov((0.5, 0.5), 1)
    c = e2s - e1r - e3s + e3r
    rows = [np.stack([e1r + c * s, e2s - c * r], axis=1) for r, s in P]
    return np.stack(rows, axis=1)


def _shell(xyz, nu, mass, drill, nn, what) -> ElementTerms:
    check_mass_kind(mass)
    X = coords(xyz, (nn,), what)
    nu = poisson(nu, len(X))
    if not (np.isfinite(drill) and drill > 0):
        raise InputError(f"{what}: drill must be a positive number, got {drill!r}")
    R, xl = _local_frame(X, what)
    if nn == 4:
        P, W = gauss_quad(2)
        N, dN = _quad_shape(P)
    else:
        P = np.array([[1 / 6, 1 / 6], [2 / 3, 1 / 6], [1 / 6, 2 / 3]])
        W = np.full(3, 1 / 6)
        N, dN = _tri_shape(P)
    J = np.einsum("gai,naj->ngij", dN, xl)  # J_ij = dx_j / dxi_i
    detJ = np.linalg.det(J)
    bad = np.flatnonzero(np.any(~(detJ > 0), axis=1))
    if bad.size:
        raise _group_error(f"{what} element(s) at position(s) {bad[:8].tolist()} of the group are inverted or "
                           "degenerate (Jacobian not positive: a re-entrant corner, or nodes out of order)", bad)
    Jinv = np.linalg.inv(J)
    dNdx = np.einsum("ngij,gaj->ngai", Jinv, dN)
    Bm, Bb, Bd = _bmats(N[None], dNdx, nn)
    Bs = np.einsum("ngij,ngjk->ngik", Jinv, _shear_mitc4(xl) if nn == 4 else _shear_mitc3(xl, P))
    wd = W[None] * detJ
    Dp = plane_stress(nu)
    G = 1.0 / (2 * (1 + nu))

    def integrate(B, D):
        return btdb(wd, B, D)

    eye2 = np.broadcast_to(np.eye(2), (len(X), 2, 2))
    Kl = [integrate(Bm, Dp), integrate(Bb, Dp / 12), integrate(Bs, SHEAR_FACTOR * G[:, None, None] * eye2),
          integrate(Bd, drill * G[:, None, None] * np.ones((len(X), 1, 1)))]
    m = np.einsum("ng,ga,gb->nab", wd, N, N)
    Mt, Mr = expand_scalar(m, 6, [_U, _V, _W]), expand_scalar(m, 6, [_TX, _TY, _TZ]) / 12
    if mass == "lumped":
        Mt = hrz_lump(Mt, [list(range(c, 6 * nn, 6)) for c in (_U, _V, _W)])
        Mr = hrz_lump(Mr, [list(range(c, 6 * nn, 6)) for c in (_TX, _TY, _TZ)])
    K = [_to_global(k, R) for k in Kl]
    Mt, Mr = _to_global(Mt, R), _to_global(Mr, R)
    links = _warp_links(X, R)
    if links is not None:  # a warped quadrilateral: its nodes joined to their projections by rigid offsets
        LT = links.transpose(0, 2, 1)
        K = [LT @ k @ links for k in K]
        Mt, Mr = LT @ Mt @ links, LT @ Mr @ links
    Et, Et3, rt, rt3 = ("E", "t"), ("E", "t", "t", "t"), ("rho", "t"), ("rho", "t", "t", "t")
    return ElementTerms(K=[(Et, K[0]), (Et3, K[1]), (Et, K[2]), (Et, K[3])],
                        M=[(rt, Mt), (rt3, Mr)])


def mitc4_terms(xyz, nu, mass: str = "consistent", drill: float = DRILL) -> ElementTerms:
    """MITC4 flat shell quadrilateral (Bathe & Dvorkin 1986; module docstring).

    Parameters
    ----------
    xyz : array_like, shape ``(n_el, 4, 3)``
        Corner coordinates, counter-clockwise about the element normal.
    nu : float or array_like, shape ``(n_el,)``
        Poisson's ratio, -1 < nu < 0.5.
    mass : {"consistent", "lumped"}, default "consistent"
        Consistent (bilinear, 2 x 2 Gauss) or HRZ-lumped mass.
    drill : float, default 0.1
        Drilling penalty factor: ``drill * G t`` multiplies ``int (theta_z - omega)^2 dA``.

    Returns
    -------
    ElementTerms
        Stiffness terms, in this order, membrane ``("E", "t")``, bending ``("E", "t", "t", "t")``,
        transverse shear ``("E", "t")``, drilling ``("E", "t")``; mass terms translation
        ``("rho", "t")``, rotation ``("rho", "t", "t", "t")``; stacks ``(n_el, 24, 24)``, global axes.

    Raises
    ------
    InputError
        Wrong shape, non-finite coordinates, nu outside (-1, 0.5), a degenerate or inverted
        element, an unknown ``mass`` (``positions`` names the elements).
    """
    return _shell(xyz, nu, mass, drill, 4, "mitc4")


def mitc3_terms(xyz, nu, mass: str = "consistent", drill: float = DRILL) -> ElementTerms:
    """MITC3 flat shell triangle (Lee & Bathe 2004; module docstring).

    Parameters
    ----------
    xyz : array_like, shape ``(n_el, 3, 3)``
        Corner coordinates.
    nu : float or array_like, shape ``(n_el,)``
        Poisson's ratio, -1 < nu < 0.5.
    mass : {"consistent", "lumped"}, default "consistent"
        Consistent (linear, exact) or lumped (a third of the mass on each node).
    drill : float, default 0.1
        Drilling penalty factor, as :func:`mitc4_terms`.

    Returns
    -------
    ElementTerms
        As :func:`mitc4_terms`, stacks ``(n_el, 18, 18)``.

    Raises
    ------
    InputError
        As :func:`mitc4_terms`.
    """
    return _shell(xyz, nu, mass, drill, 3, "mitc3")


__all__ = ["mitc4_terms", "mitc3_terms", "SHEAR_FACTOR", "DRILL"]
