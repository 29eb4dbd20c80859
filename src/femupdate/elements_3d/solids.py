r"""Solid elements: 8-node hexahedron with incompatible modes, 4- and 10-node tetrahedra.

Every function takes the node coordinates of a stack of elements, ``xyz`` of shape
``(n_el, n_nodes, 3)`` (a consistent length unit, m in SI), Poisson's ratio ``nu`` (a number or
one per element, -1 < nu < 0.5) and returns :class:`femupdate.elements.ElementTerms` with

* one stiffness term ``("E",)``: the matrix for E = 1 (so K = E K_E exactly; nu enters
  non-linearly and is a fixed number of the element, never a parameter);
* one mass term ``("rho",)``: the matrix for rho = 1 (M = rho M_rho).

Dofs: 3 per node, ``ux, uy, uz`` (global), node by node in the element's node order:
``[ux1, uy1, uz1, ux2, ...]``.  Stiffness in N/m when E is in Pa and lengths in m; mass in kg
when rho is in kg/m³.

Node orders (those of Abaqus C3D8/C3D4/C3D10, Nastran CHEXA/CTETRA, VTK):

* ``hex8``: nodes 1-4 one face, counter-clockwise seen from the opposite face 5-8; node 4+i above
  node i.  Natural coordinates (-1,-1,-1), (1,-1,-1), (1,1,-1), (-1,1,-1), then z = +1.
* ``tet4``: corners 1-4, with node 4 on the side where 1-2-3 turn counter-clockwise.
* ``tet10``: corners 1-4 as ``tet4``, then mid-edge nodes 5 (1-2), 6 (2-3), 7 (3-1), 8 (1-4),
  9 (2-4), 10 (3-4).

Mass matrices: ``"consistent"`` (exactly integrated for straight-sided elements) or ``"lumped"``
(HRZ diagonal scaling, Hinton, Rock & Zienkiewicz 1976, which keeps every diagonal entry
positive for the 10-node tetrahedron, whose row sums are not).

References
----------
E. L. Wilson, R. L. Taylor, W. P. Doherty, J. Ghaboussi, "Incompatible displacement models",
in *Numerical and Computer Methods in Structural Mechanics*, Academic Press 1973.
R. L. Taylor, P. J. Beresford, E. L. Wilson, "A non-conforming element for stress analysis",
*Int. J. Numer. Meth. Engng* 10 (1976) 1211-1219 (the modification that passes the patch test).
"""

from __future__ import annotations

import numpy as np

from ..elements import ElementTerms
from ._common import (bad_jacobian, btdb_isotropic, check_mass_kind, coords, duffy_tet, expand_scalar, gauss_hex,
                      hrz_lump, lame, poisson)

HEX8_CORNERS = np.array([[-1, -1, -1], [1, -1, -1], [1, 1, -1], [-1, 1, -1],
                         [-1, -1, 1], [1, -1, 1], [1, 1, 1], [-1, 1, 1]], dtype=float)
TET10_EDGES = ((0, 1), (1, 2), (2, 0), (0, 3), (1, 3), (2, 3))
# the 4-point rule on the tetrahedron (degree 2), volume coordinates of L2, L3, L4; weights sum to 1/6
_A, _B = 0.5854101966249685, 0.1381966011250105
TET4_POINTS = np.array([[_B, _B, _B], [_A, _B, _B], [_B, _A, _B], [_B, _B, _A]])
TET4_WEIGHTS = np.full(4, 1.0 / 24.0)


def hex8_shape(p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Trilinear shape functions at natural points ``p`` ``(g, 3)``: N ``(g, 8)``, dN/dxi ``(g, 8, 3)``."""
    c = HEX8_CORNERS
    f = 1 + p[:, None, :] * c[None]  # (g, 8, 3)
    N = f.prod(axis=2) / 8
    dN = np.empty(f.shape)
    for k in range(3):
        others = [j for j in range(3) if j != k]
        dN[:, :, k] = c[None, :, k] * f[:, :, others[0]] * f[:, :, others[1]] / 8
    return N, dN


def tet_shape(p: np.ndarray, quadratic: bool) -> tuple[np.ndarray, np.ndarray]:
    """Shape functions of the 4- or 10-node tetrahedron at points ``p`` = (L2, L3, L4), ``(g, 3)``."""
    L = np.column_stack([1 - p.sum(axis=1), p])  # (g, 4)
    G = np.vstack([-np.ones(3), np.eye(3)])  # dL/dxi, (4, 3)
    if not quadratic:
        return L, np.broadcast_to(G, (len(p), 4, 3)).copy()
    g = len(p)
    N = np.empty((g, 10))
    dNdL = np.zeros((g, 10, 4))
    N[:, :4] = L * (2 * L - 1)
    for i in range(4):
        dNdL[:, i, i] = 4 * L[:, i] - 1
    for e, (i, j) in enumerate(TET10_EDGES):
        N[:, 4 + e] = 4 * L[:, i] * L[:, j]
        dNdL[:, 4 + e, i] = 4 * L[:, j]
        dNdL[:, 4 + e, j] = 4 * L[:, i]
    return N, dNdL @ G


def strain_matrix(dNdx: np.ndarray) -> np.ndarray:
    """B ``(..., 6, 3 n)`` from shape-function derivatives ``(..., n, 3)``; strains xx, yy, zz, xy, yz, zx."""
    *lead, n, _ = dNdx.shape
    B = np.zeros((*lead, 6, n, 3))
    dx, dy, dz = dNdx[..., 0], dNdx[..., 1], dNdx[..., 2]
    B[..., 0, :, 0] = dx
    B[..., 1, :, 1] = dy
    B[..., 2, :, 2] = dz
    B[..., 3, :, 0], B[..., 3, :, 1] = dy, dx
    B[..., 4, :, 1], B[..., 4, :, 2] = dz, dy
    B[..., 5, :, 0], B[..., 5, :, 2] = dz, dx
    return B.reshape(*lead, 6, 3 * n)


def _jacobian(X: np.ndarray, dN: np.ndarray, what: str):
    J = np.matmul(dN.transpose(0, 2, 1)[None], X[:, None])  # J[n, g, i, j] = sum_a dN[g, a, i] X[n, a, j]
    detJ = np.linalg.det(J)
    bad_jacobian(detJ, what)
    return J, detJ


def _stiffness(X, dN, W, nu, what):
    """sum_g w det J B^T D B for E = 1 (isotropic D), and the parts needed by the incompatible modes."""
    J, detJ = _jacobian(X, dN, what)
    # the gradients dN_a/dx = J^-1 dN_a/dxi (J[i, j] = dx_j/dxi_i)
    dNt = dN.transpose(0, 2, 1)  # (g, 3, a)
    G = np.linalg.solve(J, np.broadcast_to(dNt[None], (len(X), *dNt.shape)))
    G = G.transpose(0, 1, 3, 2)  # (n, g, a, 3)
    lam, mu = lame(nu)
    K = btdb_isotropic(W[None] * detJ, G, G, lam, mu)
    return K, G, J, detJ


def _scalar_mass(X, N, dN, W, what):
    J, detJ = _jacobian(X, dN, what)
    return np.einsum("ng,ga,gb->nab", W[None] * detJ, N, N)


def _mass_terms(m: np.ndarray, mass: str) -> np.ndarray:
    M = expand_scalar(m, 3, [0, 1, 2])
    if mass == "lumped":
        nn = m.shape[1]
        M = hrz_lump(M, [list(range(c, 3 * nn, 3)) for c in range(3)])
    return M


def hex8_terms(xyz, nu, mass: str = "consistent", incompatible: bool = True) -> ElementTerms:
    """8-node hexahedron; with ``incompatible=True`` (default) the QM6 element: Wilson's three
    incompatible bubble modes ``1 - xi_k^2`` per direction, with Taylor, Beresford & Wilson's
    (1976) modification (their derivatives are taken with the Jacobian at the element centre and
    scaled by det J0 / det J, so the element passes the patch test on any shape), statically
    condensed element by element.  It represents pure bending of a rectangular element exactly
    and does not lock in bending (shear locking of the plain trilinear element).

    Integration: 2 x 2 x 2 Gauss points for stiffness and mass.

    Parameters
    ----------
    xyz : array_like, shape ``(n_el, 8, 3)``
        Node coordinates in the order of the module docstring.
    nu : float or array_like, shape ``(n_el,)``
        Poisson's ratio.
    mass : {"consistent", "lumped"}, default "consistent"
        Mass matrix (the incompatible modes carry no mass).
    incompatible : bool, default True
        False gives the plain trilinear element (which locks in bending; for comparison).

    Returns
    -------
    ElementTerms
        ``K = [(("E",), K_E)]``, ``M = [(("rho",), M_rho)]``, stacks ``(n_el, 24, 24)``.

    Raises
    ------
    InputError
        Wrong shape, non-finite coordinates, nu outside (-1, 0.5), an inverted or degenerate
        element, or an unknown ``mass`` (``positions`` names the elements).
    """
    check_mass_kind(mass)
    X = coords(xyz, (8,), "hex8")
    nu = poisson(nu, len(X))
    P, W = gauss_hex(2)
    N, dN = hex8_shape(P)
    K, G, J, detJ = _stiffness(X, dN, W, nu, "hex8")
    if incompatible:
        _, dN0 = hex8_shape(np.zeros((1, 3)))
        J0 = np.einsum("ai,naj->nij", dN0[0], X)
        det0 = np.linalg.det(J0)
        # dP_k/dxi_i = -2 xi_k delta_ik at each Gauss point: (g, 3 modes, 3 natural directions)
        dPdxi = np.einsum("gk,ki->gki", -2 * P, np.eye(3))
        dPdx = np.einsum("nij,gkj->ngki", np.linalg.inv(J0), dPdxi) * (det0[:, None] / detJ)[:, :, None, None]
        wd = W[None] * detJ
        lam, mu = lame(nu)
        Kua = btdb_isotropic(wd, G, dPdx, lam, mu)
        Kaa = btdb_isotropic(wd, dPdx, dPdx, lam, mu)
        K = K - Kua @ np.linalg.solve(Kaa, Kua.transpose(0, 2, 1))
        K = 0.5 * (K + K.transpose(0, 2, 1))
    m = _scalar_mass(X, N, dN, W, "hex8")
    return ElementTerms(K=[(("E",), K)], M=[(("rho",), _mass_terms(m, mass))])


def tet4_terms(xyz, nu, mass: str = "consistent") -> ElementTerms:
    """4-node (constant-strain) tetrahedron.  Stiffly locking in bending: use it for comparison or
    fine meshes; :func:`tet10_terms` or :func:`hex8_terms` for bending.

    Parameters
    ----------
    xyz : array_like, shape ``(n_el, 4, 3)``
        Corner coordinates (module docstring).
    nu : float or array_like, shape ``(n_el,)``
        Poisson's ratio.
    mass : {"consistent", "lumped"}, default "consistent"
        Consistent ``rho V / 20 (1 + delta_ab)`` per direction, or lumped ``rho V / 4`` per node.

    Returns
    -------
    ElementTerms
        ``K = [(("E",), K_E)]``, ``M = [(("rho",), M_rho)]``, stacks ``(n_el, 12, 12)``.

    Raises
    ------
    InputError
        As :func:`hex8_terms`.
    """
    check_mass_kind(mass)
    X = coords(xyz, (4,), "tet4")
    P, W = np.full((1, 3), 0.25), np.array([1.0 / 6.0])
    N, dN = tet_shape(P, quadratic=False)
    K = _stiffness(X, dN, W, poisson(nu, len(X)), "tet4")[0]
    Pm, Wm = duffy_tet(3)
    Nm, dNm = tet_shape(Pm, quadratic=False)
    m = _scalar_mass(X, Nm, dNm, Wm, "tet4")
    return ElementTerms(K=[(("E",), K)], M=[(("rho",), _mass_terms(m, mass))])


def tet10_terms(xyz, nu, mass: str = "consistent") -> ElementTerms:
    """10-node (quadratic) tetrahedron, isoparametric.

    Integration: the 4-point rule (degree 2, exact for straight-sided elements) for stiffness;
    a 64-point collapsed Gauss rule (degree 5) for mass, exact for straight-sided elements.

    Parameters
    ----------
    xyz : array_like, shape ``(n_el, 10, 3)``
        Node coordinates in the order of the module docstring.
    nu : float or array_like, shape ``(n_el,)``
        Poisson's ratio.
    mass : {"consistent", "lumped"}, default "consistent"
        Mass matrix (lumped: HRZ, each node's share proportional to its consistent diagonal:
        1/36 of the mass on each corner, 4/27 on each mid-edge node of a straight-sided element).

    Returns
    -------
    ElementTerms
        ``K = [(("E",), K_E)]``, ``M = [(("rho",), M_rho)]``, stacks ``(n_el, 30, 30)``.

    Raises
    ------
    InputError
        As :func:`hex8_terms`.
    """
    check_mass_kind(mass)
    X = coords(xyz, (10,), "tet10")
    N, dN = tet_shape(TET4_POINTS, quadratic=True)
    K = _stiffness(X, dN, TET4_WEIGHTS, poisson(nu, len(X)), "tet10")[0]
    Pm, Wm = duffy_tet(4)
    Nm, dNm = tet_shape(Pm, quadratic=True)
    m = _scalar_mass(X, Nm, dNm, Wm, "tet10")
    return ElementTerms(K=[(("E",), K)], M=[(("rho",), _mass_terms(m, mass))])


__all__ = ["hex8_terms", "tet4_terms", "tet10_terms", "hex8_shape", "tet_shape", "strain_matrix", "TET10_EDGES"]
