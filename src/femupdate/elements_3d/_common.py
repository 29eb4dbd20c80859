"""Shared pieces of the shell and solid elements: material matrices, quadrature, mass lumping,
checks of the element geometry."""

from __future__ import annotations

import numpy as np

from .._errors import InputError
from ..elements import MASS_KINDS, _group_error


def check_mass_kind(mass: str) -> None:
    """Refuse a mass kind other than ``"consistent"`` or ``"lumped"``."""
    if mass not in MASS_KINDS:
        raise InputError(f"mass must be one of {', '.join(MASS_KINDS)}, got {mass!r}")


def coords(xyz, n_nodes: tuple[int, ...], what: str) -> np.ndarray:
    """Node coordinates as a float array ``(n_el, n_nodes, 3)``, checked for shape and finiteness."""
    x = np.asarray(xyz, dtype=float)
    if x.ndim != 3 or x.shape[1] not in n_nodes or x.shape[2] != 3:
        raise InputError(f"{what}: node coordinates must have shape (n_el, {' or '.join(map(str, n_nodes))}, 3), "
                         f"got {x.shape}")
    bad = np.flatnonzero(~np.all(np.isfinite(x), axis=(1, 2)))
    if bad.size:
        raise _group_error(f"{what}: element(s) at position(s) {bad[:8].tolist()} have non-finite coordinates", bad)
    return x


def poisson(nu, n_el: int) -> np.ndarray:
    """Poisson's ratio per element, checked to lie in (-1, 0.5)."""
    v = np.broadcast_to(np.asarray(nu, dtype=float), (n_el,)).copy()
    bad = np.flatnonzero(~((v > -1.0) & (v < 0.5)))
    if bad.size:
        raise _group_error(f"Poisson's ratio nu = {v[bad[0]]:g} at position(s) {bad[:8].tolist()} of the group: "
                           "it must lie strictly between -1 and 0.5", bad)
    return v


def isotropic_3d(nu: np.ndarray) -> np.ndarray:
    """Elasticity matrix for E = 1, shape ``(n_el, 6, 6)``; strain order xx, yy, zz, xy, yz, zx
    (engineering shear strains)."""
    n = len(nu)
    lam = nu / ((1 + nu) * (1 - 2 * nu))
    mu = 1.0 / (2 * (1 + nu))
    D = np.zeros((n, 6, 6))
    D[:, :3, :3] = lam[:, None, None]
    for i in range(3):
        D[:, i, i] += 2 * mu
        D[:, 3 + i, 3 + i] = mu
    return D


def plane_stress(nu: np.ndarray) -> np.ndarray:
    """Plane-stress matrix for E = 1, shape ``(n_el, 3, 3)``; order xx, yy, xy (engineering)."""
    c = 1.0 / (1 - nu**2)
    D = np.zeros((len(nu), 3, 3))
    D[:, 0, 0] = D[:, 1, 1] = c
    D[:, 0, 1] = D[:, 1, 0] = c * nu
    D[:, 2, 2] = c * (1 - nu) / 2
    return D


def gauss_1d(n: int) -> tuple[np.ndarray, np.ndarray]:
    """Gauss-Legendre points and weights on [-1, 1]."""
    return np.polynomial.legendre.leggauss(n)


def gauss_hex(n: int) -> tuple[np.ndarray, np.ndarray]:
    """Tensor Gauss rule on the cube [-1, 1]^3: points ``(n^3, 3)``, weights ``(n^3,)``."""
    p, w = gauss_1d(n)
    P = np.array(np.meshgrid(p, p, p, indexing="ij")).reshape(3, -1).T
    W = np.einsum("i,j,k->ijk", w, w, w).ravel()
    return P, W


def gauss_quad(n: int) -> tuple[np.ndarray, np.ndarray]:
    """Tensor Gauss rule on the square [-1, 1]^2."""
    p, w = gauss_1d(n)
    P = np.array(np.meshgrid(p, p, indexing="ij")).reshape(2, -1).T
    return P, np.outer(w, w).ravel()


def duffy_tet(n: int) -> tuple[np.ndarray, np.ndarray]:
    """Collapsed (Duffy / Stroud conical product) rule on the unit tetrahedron.

    Returns volume coordinates ``(L2, L3, L4)`` of the points, shape ``(n^3, 3)``, and weights
    summing to 1/6 (the reference volume).  With ``n`` points per direction the rule is exact for
    polynomials of degree ``2 n - 3`` (the Jacobian of the collapse adds degree 2).
    """
    p, w = gauss_1d(n)
    p, w = (p + 1) / 2, w / 2
    u, v, s = np.meshgrid(p, p, p, indexing="ij")
    wu, wv, ws = np.meshgrid(w, w, w, indexing="ij")
    a = u
    b = v * (1 - u)
    c = s * (1 - u) * (1 - v)
    W = wu * wv * ws * (1 - u) ** 2 * (1 - v)
    return np.stack([a.ravel(), b.ravel(), c.ravel()], axis=1), W.ravel()


def btdb(wd: np.ndarray, B: np.ndarray, D: np.ndarray) -> np.ndarray:
    """sum_g wd[n, g] B[n, g]^T D[n] B[n, g] for stacks: ``wd`` ``(n, g)``, ``B`` ``(n, g, s, m)``,
    ``D`` ``(n, s, s)``; returns ``(n, m, m)`` (batched matrix products, no einsum path search)."""
    n, g, s_, m = B.shape
    DB = np.matmul(D[:, None], B) * wd[:, :, None, None]
    return np.matmul(B.reshape(n, g * s_, m).transpose(0, 2, 1), DB.reshape(n, g * s_, m))


def lame(nu: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Lamé's lambda and mu for E = 1, per element (the entries of :func:`isotropic_3d`)."""
    return nu / ((1 + nu) * (1 - 2 * nu)), 1.0 / (2 * (1 + nu))


def btdb_isotropic(wd: np.ndarray, G1: np.ndarray, G2: np.ndarray, lam: np.ndarray, mu: np.ndarray) -> np.ndarray:
    """:func:`btdb` for the isotropic D of :func:`isotropic_3d` and B the strain matrices of
    gradients ``G1`` ``(n, g, n1, 3)`` and ``G2`` ``(n, g, n2, 3)``: ``(n, 3 n1, 3 n2)``, without
    forming B.  Block (a, b), entry (i, j): sum_g wd (lam G1_ai G2_bj + mu G1_aj G2_bi + mu delta_ij
    G1_a . G2_b) — a product over the g points instead of the 6 g strain components."""
    n, g, n1, _ = G1.shape
    n2 = G2.shape[2]
    P = np.matmul((G1 * wd[:, :, None, None]).reshape(n, g, 3 * n1).transpose(0, 2, 1),
                  G2.reshape(n, g, 3 * n2)).reshape(n, n1, 3, n2, 3)
    muS = mu[:, None, None] * np.einsum("naibi->nab", P)
    K = lam[:, None, None, None, None] * P + mu[:, None, None, None, None] * P.transpose(0, 1, 4, 3, 2)
    for i in range(3):
        K[:, :, i, :, i] += muS
    return K.reshape(n, 3 * n1, 3 * n2)


def hrz_lump(M: np.ndarray, blocks: list[list[int]]) -> np.ndarray:
    """HRZ (Hinton-Rock-Zienkiewicz 1976) diagonal lumping of consistent mass stacks.

    For each set of dofs in ``blocks`` (e.g. all x translations), the diagonal of the consistent
    matrix is scaled so that its sum equals the total of the set's block (the mass moving with a
    unit rigid translation); off-diagonal terms are dropped.  The lumped mass is positive whenever
    the consistent diagonal is, also for quadratic elements (where row sums are not).
    """
    out = np.zeros_like(M)
    n = M.shape[0]
    for idx in blocks:
        sub = M[np.ix_(range(n), idx, idx)]
        total = sub.sum(axis=(1, 2))
        diag = np.einsum("eii->ei", sub)
        scale = total / diag.sum(axis=1)
        d = diag * scale[:, None]
        out[:, idx, idx] = d
    return out


def expand_scalar(m: np.ndarray, ndof: int, comps: list[int]) -> np.ndarray:
    """Scalar (per-node) matrix stacks ``(n_el, n, n)`` placed on components ``comps`` of
    ``ndof`` dofs per node: ``(n_el, n ndof, n ndof)``."""
    n_el, n, _ = m.shape
    out = np.zeros((n_el, n, ndof, n, ndof))
    for c in comps:
        out[:, :, c, :, c] = m
    return out.reshape(n_el, n * ndof, n * ndof)


def bad_jacobian(detJ: np.ndarray, what: str) -> None:
    """Refuse elements whose Jacobian determinant is not positive at some point."""
    ref = np.max(np.abs(detJ), axis=1, keepdims=True)
    bad = np.flatnonzero(np.any(~(detJ > 1e-12 * np.maximum(ref, 1e-300)), axis=1) | np.all(ref == 0, axis=1))
    if bad.size:
        raise _group_error(
            f"{what} element(s) at position(s) {bad[:8].tolist()} of the group are inverted or degenerate "
            "(Jacobian determinant not positive: check the node order and repeated nodes)", bad)
