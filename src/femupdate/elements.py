r"""Element matrices as pure, vectorised functions.

Every element type is described by *terms*: an element's stiffness (or mass) matrix is a sum

.. math::  K_e = \sum_t \Big(\prod_{f \in F_t} q_f\Big)\, \hat K_{e,t}

of unit matrices :math:`\hat K_{e,t}` (which depend on geometry only) times products of element
properties :math:`q_f` (E, A, I, rho, ... or the Appendix's physical terms EA/l, 12EI/l^3, ...).
The model assembled from them is affine in its parameters as long as each product contains at
most one parameter, and the unit matrices, times the numeric factors, are then the exact
derivatives dK/dp.

All functions take node coordinates ``xa, xb`` of shape ``(n_el, 3)`` (metres) and return
stacks of shape ``(n_el, n_e, n_e)`` in *global* coordinates, element dof order as given by
``node_directions``.  Units are whatever consistent set the properties use (SI recommended).

Element dof orders
------------------
* ``spring``: the two (or one, grounded) dof labels given.
* ``mass``: the dof labels given.
* ``rod`` (truss): ``x, y`` (``dim=2``) or ``x, y, z`` (``dim=3``) at node a, then node b.
* ``beam2d``, ``beam2d_terms``: ``x, y, rz`` at node a, then node b (bending in the x-y plane).
* ``frame3d``, ``frame3d_terms``: ``x, y, z, rx, ry, rz`` at node a, then node b.

Local frame of ``frame3d``: local x runs from node a to node b; the ``orientation`` vector v
lies in the local x-y plane: local z = x × v / ``|x × v|``, local y = z × x.  ``Iz`` is the second
moment for bending in the local x-y plane (about local z), ``Iy`` for the local x-z plane.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import cast

import numpy as np

from ._errors import InputError

Terms = list[tuple[tuple[str, ...], np.ndarray]]

MASS_KINDS = ("consistent", "lumped")


@dataclass(frozen=True)
class ElementTerms:
    """Unit matrices of one element group: ``K`` and ``M`` lists of ``(factors, stack)``.

    Parameters
    ----------
    K : list of (tuple of str, numpy.ndarray)
        Stiffness terms: the names of the properties whose product multiplies the term, and the
        unit matrices, shape ``(n_el, n_e, n_e)``, in global coordinates.
    M : list of (tuple of str, numpy.ndarray)
        Mass terms, likewise (empty for a spring).
    """

    K: Terms
    M: Terms


# --------------------------------------------------------------------------------------
# geometry helpers
# --------------------------------------------------------------------------------------
def _group_error(message: str, bad: np.ndarray) -> InputError:
    """InputError whose ``positions`` attribute lists the offending elements of the group.

    Callers that know the elements by name (e.g. :class:`femupdate.Structure`) use
    ``positions`` to name the culprit instead of the position in the stack.
    """
    exc = InputError(message)
    exc.positions = [int(i) for i in bad]
    return exc


def _check_mass_kind(mass: str) -> None:
    if mass not in MASS_KINDS:
        raise InputError(f"mass must be one of {', '.join(MASS_KINDS)}, got {mass!r}")


def _lengths(xa: np.ndarray, xb: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    d = np.asarray(xb, float) - np.asarray(xa, float)
    length = np.linalg.norm(d, axis=1)
    with np.errstate(over="ignore", divide="ignore", under="ignore"):
        vanishing = ~np.isfinite(12.0 / length**3)  # bending terms go as 1/l^3: they must stay finite
    bad = np.flatnonzero(~(length > 0) | vanishing)
    if bad.size:
        raise _group_error(
            f"element(s) of zero, vanishing or undefined length at position(s) {bad[:8].tolist()} of the group: "
            "both end nodes at (nearly) the same point, or a coordinate that is not finite", bad)
    return d, length


def _frame_rotation(xa, xb, orientation) -> tuple[np.ndarray, np.ndarray]:
    """Rows of R (n_el, 3, 3) are the local x, y, z axes in global coordinates."""
    d, length = _lengths(xa, xb)
    ex = d / length[:, None]
    v = np.broadcast_to(np.asarray(orientation, float), ex.shape)
    ez = np.cross(ex, v)
    nz = np.linalg.norm(ez, axis=1)
    vnorm = np.linalg.norm(v, axis=1)
    bad = np.flatnonzero(~(nz > 1e-8 * np.maximum(vnorm, 1e-300)))
    if bad.size:
        raise _group_error(
            "frame3d orientation vector is parallel to the element axis (or zero) for element(s) "
            f"at position(s) {bad[:8].tolist()} of the group: give an orientation not along the axis",
            bad,
        )
    ez /= nz[:, None]
    ey = np.cross(ez, ex)
    return np.stack([ex, ey, ez], axis=1), length


def _to_global(stack_local: np.ndarray, T: np.ndarray) -> np.ndarray:
    """T^T K T for stacks."""
    return np.matmul(np.matmul(T.transpose(0, 2, 1), stack_local), T)


def _place(n_el: int, ne: int, blocks: list[tuple[list[int], np.ndarray]]) -> np.ndarray:
    """Stack of (n_el, ne, ne) with per-element sub-blocks placed at the given dof positions."""
    out = np.zeros((n_el, ne, ne))
    for idx, blk in blocks:
        ix = np.ix_(range(n_el), idx, idx)
        out[ix] += np.broadcast_to(blk, (n_el, len(idx), len(idx)))
    return out


# --------------------------------------------------------------------------------------
# unit matrices of the bending terms (Appendix 1 of the reference paper)
# --------------------------------------------------------------------------------------
# dof order (w1, theta1, w2, theta2) for bending in the local x-y plane (w = v, theta = rz):
#   F1 = k12 (w1 - w2) + k6 (t1 + t2),  M1 = k6 (w1 - w2) + k2 (2 t1 + t2), ...
_B12 = np.array([[1.0, 0, -1, 0], [0, 0, 0, 0], [-1, 0, 1, 0], [0, 0, 0, 0]])
_B6 = np.array([[0.0, 1, 0, 1], [1, 0, -1, 0], [0, -1, 0, -1], [1, 0, -1, 0]])
_B2 = np.array([[0.0, 0, 0, 0], [0, 2, 0, 1], [0, 0, 0, 0], [0, 1, 0, 2]])
# in the local x-z plane the rotation ry = -dw/dx, which flips the sign of the k6 coupling
_FLIP = np.diag([1.0, -1.0, 1.0, -1.0])
_AX = np.array([[1.0, -1.0], [-1.0, 1.0]])
_AXM = np.array([[2.0, 1.0], [1.0, 2.0]]) / 6.0


def _bending_mass(length: np.ndarray) -> np.ndarray:
    """Consistent bending mass per unit (rho A), dof order (w1, t1, w2, t2), x-y plane."""
    L = length[:, None, None]
    c = np.array([[156.0, 0, 54, 0], [0, 0, 0, 0], [54, 0, 156, 0], [0, 0, 0, 0]])
    l1 = np.array([[0.0, 22, 0, -13], [22, 0, 13, 0], [0, 13, 0, -22], [-13, 0, -22, 0]])
    l2 = np.array([[0.0, 0, 0, 0], [0, 4, 0, -3], [0, 0, 0, 0], [0, -3, 0, 4]])
    return (L / 420.0) * (c + L * l1 + L * L * l2)


def _bending_stiffness_unit(length: np.ndarray) -> np.ndarray:
    """EI = 1 bending stiffness, x-y plane: (12/l^3) B12 + (6/l^2) B6 + (2/l) B2."""
    L = length[:, None, None]
    return 12.0 / L**3 * _B12 + 6.0 / L**2 * _B6 + 2.0 / L * _B2


# --------------------------------------------------------------------------------------
# element types
# --------------------------------------------------------------------------------------
def spring_terms(n_el: int, grounded: bool) -> ElementTerms:
    """Spring k between two dofs (``[[1, -1], [-1, 1]]``) or from one dof to ground (``[[1]]``).

    Parameters
    ----------
    n_el : int
        Number of springs.
    grounded : bool
        True for springs from one dof to ground.

    Returns
    -------
    ElementTerms
        One stiffness term with factor ``("k",)`` (k in N/m, or N·m/rad on a rotation), stack of shape
        ``(n_el, 1, 1)`` or ``(n_el, 2, 2)``; no mass terms.
    """
    unit = np.ones((1, 1)) if grounded else _AX
    return ElementTerms(K=[(("k",), np.broadcast_to(unit, (n_el, *unit.shape)).copy())], M=[])


def mass_terms(n_el: int, n_dofs: int) -> ElementTerms:
    """Lumped mass m on each of ``n_dofs`` dofs.

    Parameters
    ----------
    n_el : int
        Number of mass elements.
    n_dofs : int
        Dofs each mass acts on (the same m on each).

    Returns
    -------
    ElementTerms
        One mass term with factor ``("m",)`` (kg), identity stack of shape ``(n_el, n_dofs, n_dofs)``; no
        stiffness terms.
    """
    return ElementTerms(K=[], M=[(("m",), np.broadcast_to(np.eye(n_dofs), (n_el, n_dofs, n_dofs)).copy())])


def rod_terms(xa, xb, dim: int = 3, mass: str = "consistent") -> ElementTerms:
    """Truss member: K = (E A / l) [n n^T, -n n^T; -n n^T, n n^T].

    Mass: consistent ``rho A l / 6 [2I, I; I, 2I]`` or lumped ``rho A l / 2 I`` (all
    translations, as is usual for trusses).  ``dim=2`` uses the x-y components only.

    Parameters
    ----------
    xa, xb : array_like, shape ``(n_el, 3)``
        Coordinates of each element's end nodes a and b, m.
    dim : {2, 3}, default 3
        Plane truss (dofs ``x, y`` per node; every element must have the same z at both ends) or
        space truss (``x, y, z`` per node).
    mass : {"consistent", "lumped"}, default "consistent"
        Mass matrix.

    Returns
    -------
    ElementTerms
        Stiffness term ``("E", "A")`` and mass term ``("rho", "A")``, stacks of shape
        ``(n_el, 2 dim, 2 dim)``.

    Raises
    ------
    InputError
        ``mass`` or ``dim`` unknown, an element of zero (or non-finite) length, or, with ``dim=2``,
        an element whose ends differ in z (``positions`` names the elements).
    """
    _check_mass_kind(mass)
    xa, xb = np.asarray(xa, float), np.asarray(xb, float)
    if dim == 2:
        dz = np.abs(xb[:, 2] - xa[:, 2])
        bad = np.flatnonzero(dz > 0)
        if bad.size:
            raise _group_error(f"2-D rod element(s) at position(s) {bad[:8].tolist()} leave the x-y plane (z differs)", bad)
    elif dim != 3:
        raise InputError(f"rod: dim must be 2 or 3, not {dim!r}")
    d, length = _lengths(xa[:, :dim], xb[:, :dim])
    n = d / length[:, None]
    nn = np.einsum("ei,ej->eij", n, n)
    K = np.einsum("ab,eij->eaibj", _AX, nn).reshape(-1, 2 * dim, 2 * dim) / length[:, None, None]
    eye = np.eye(dim)
    mm = _AXM if mass == "consistent" else np.eye(2) / 2.0
    M = np.kron(mm, eye)[None] * length[:, None, None]
    return ElementTerms(K=[(("E", "A"), K)], M=[(("rho", "A"), M)])


def _beam2d_T(xa, xb) -> tuple[np.ndarray, np.ndarray]:
    xa, xb = np.asarray(xa, float), np.asarray(xb, float)
    dz = np.abs(xb[:, 2] - xa[:, 2])
    bad = np.flatnonzero(dz > 0)
    if bad.size:
        raise _group_error(f"beam2d element(s) at position(s) {bad[:8].tolist()} leave the x-y plane (z differs)", bad)
    d, length = _lengths(xa[:, :2], xb[:, :2])
    c, s = d[:, 0] / length, d[:, 1] / length
    R = np.zeros((len(length), 3, 3))
    R[:, 0, 0], R[:, 0, 1], R[:, 1, 0], R[:, 1, 1], R[:, 2, 2] = c, s, -s, c, 1.0
    T = np.zeros((len(length), 6, 6))
    T[:, :3, :3] = R
    T[:, 3:, 3:] = R
    return T, length


def _beam2d_mass(T, length, mass: str) -> list[tuple[tuple[str, ...], np.ndarray]]:
    _check_mass_kind(mass)
    n = len(length)
    if mass == "consistent":
        local = _place(n, 6, [([0, 3], _AXM)])
        local *= length[:, None, None]
        local[np.ix_(range(n), [1, 2, 4, 5], [1, 2, 4, 5])] += _bending_mass(length)
    else:
        diag = np.stack([length / 2, length / 2, length**3 / 24] * 2, axis=1)
        local = np.einsum("ei,ij->eij", diag, np.eye(6))
    return [(("rho", "A"), _to_global(local, T))]


def beam2d_terms(xa, xb, mass: str = "consistent") -> ElementTerms:
    """Euler-Bernoulli beam in the x-y plane with axial stiffness (6 dofs: x, y, rz per node).

    K = (E A) K_axial + (E I) K_bending; M = (rho A) M (consistent: the usual cubic-Hermite
    matrix, no rotary inertia; lumped: rho A l / 2 on translations and rho A l^3 / 24 on the
    rotation, the inertia of half the member about its end node).

    Parameters
    ----------
    xa, xb : array_like, shape ``(n_el, 3)``
        Coordinates of each element's end nodes a and b, m.
    mass : {"consistent", "lumped"}, default "consistent"
        Mass matrix.

    Returns
    -------
    ElementTerms
        Stiffness terms ``("E", "A")`` and ``("E", "I")``, mass term ``("rho", "A")``; stacks of
        shape ``(n_el, 6, 6)``.

    Raises
    ------
    InputError
        An element leaves the x-y plane (its ends differ in z) or has zero length (``positions``
        names the elements), or ``mass`` is unknown.
    """
    T, length = _beam2d_T(xa, xb)
    n = len(length)
    ax = _place(n, 6, [([0, 3], _AX)]) / length[:, None, None]
    bend = np.zeros((n, 6, 6))
    bend[np.ix_(range(n), [1, 2, 4, 5], [1, 2, 4, 5])] = _bending_stiffness_unit(length)
    K: Terms = [(("E", "A"), _to_global(ax, T)), (("E", "I"), _to_global(bend, T))]
    return ElementTerms(K=K, M=_beam2d_mass(T, length, mass))


def beam2d_physical_terms(xa, xb, mass: str = "consistent") -> ElementTerms:
    """Beam2d whose independent stiffness terms are the properties (Appendix 1).

    Properties: ``EA_l`` (EA/l), ``k12`` (12EI/l^3), ``k6`` (6EI/l^2), ``k2`` (2EI/l); mass from
    ``rho`` and ``A`` as for :func:`beam2d_terms`.

    Parameters
    ----------
    xa, xb, mass
        As :func:`beam2d_terms`.

    Returns
    -------
    ElementTerms
        Stiffness terms ``("EA_l",)`` (N/m), ``("k12",)`` (N/m), ``("k6",)`` (N), ``("k2",)`` (N·m),
        mass term ``("rho", "A")``; stacks of shape ``(n_el, 6, 6)``.

    Raises
    ------
    InputError
        As for :func:`beam2d_terms`.
    """
    T, length = _beam2d_T(xa, xb)
    n = len(length)
    idx = [1, 2, 4, 5]
    K: Terms = [(("EA_l",), _to_global(_place(n, 6, [([0, 3], _AX)]), T))]
    for name, unit in (("k12", _B12), ("k6", _B6), ("k2", _B2)):
        K.append(((name,), _to_global(_place(n, 6, [(idx, unit)]), T)))
    return ElementTerms(K=K, M=_beam2d_mass(T, length, mass))


def _frame_T(xa, xb, orientation):
    R, length = _frame_rotation(xa, xb, orientation)
    T = np.zeros((len(length), 12, 12))
    for b in range(4):
        T[:, 3 * b : 3 * b + 3, 3 * b : 3 * b + 3] = R
    return T, length


# local dof positions in the 12-dof frame: u1 v1 w1 tx1 ty1 tz1 u2 v2 w2 tx2 ty2 tz2
_AXIAL, _TORSION = [0, 6], [3, 9]
_PLANE_XY, _PLANE_XZ = [1, 5, 7, 11], [2, 4, 8, 10]


def _frame_mass(T, length, mass: str, torsion_factors: list[tuple[str, ...]]):
    _check_mass_kind(mass)
    n = len(length)
    L = length[:, None, None]
    if mass == "consistent":
        trans = _place(n, 12, [(_AXIAL, _AXM)]) * L
        bm = _bending_mass(length)
        i1 = np.ix_(range(n), _PLANE_XY, _PLANE_XY)
        trans[i1] += bm
        i2 = np.ix_(range(n), _PLANE_XZ, _PLANE_XZ)
        trans[i2] += _FLIP @ bm @ _FLIP
        tors = _place(n, 12, [(_TORSION, _AXM)]) * L
    else:
        d = np.zeros((n, 12))
        for k in (0, 1, 2, 6, 7, 8):
            d[:, k] = length / 2
        for k in (4, 5, 10, 11):
            d[:, k] = length**3 / 24
        trans = np.einsum("ei,ij->eij", d, np.eye(12))
        tors = _place(n, 12, [(_TORSION, np.eye(2) / 2)]) * L
    tg = _to_global(tors, T)
    return [(("rho", "A"), _to_global(trans, T))] + [(f, tg) for f in torsion_factors]


def frame3d_terms(xa, xb, orientation, mass: str = "consistent") -> ElementTerms:
    """12-dof Euler-Bernoulli space frame.

    K = (E A) K_axial + (G J) K_torsion + (E Iz) K_xy + (E Iy) K_xz.
    M = (rho A) M_translation + rho (Iy + Iz) M_torsion: the torsional inertia uses the polar
    moment Ip = Iy + Iz.  Lumped mass as in :func:`beam2d_terms`, with rho Ip l / 2 on twist.

    Parameters
    ----------
    xa, xb : array_like, shape ``(n_el, 3)``
        Coordinates of each element's end nodes a and b, m.
    orientation : array_like, shape ``(3,)`` or ``(n_el, 3)``
        A vector in each element's local x-y plane, not along its axis (see the module docstring).
    mass : {"consistent", "lumped"}, default "consistent"
        Mass matrix.

    Returns
    -------
    ElementTerms
        Stiffness terms ``("E", "A")``, ``("G", "J")``, ``("E", "Iz")``, ``("E", "Iy")``; mass
        terms ``("rho", "A")``, ``("rho", "Iy")``, ``("rho", "Iz")``; stacks of shape
        ``(n_el, 12, 12)``.

    Raises
    ------
    InputError
        An element of zero length, an orientation parallel to an element's axis or zero
        (``positions`` names the elements), or ``mass`` unknown.
    """
    T, length = _frame_T(xa, xb, orientation)
    n = len(length)
    L = length[:, None, None]
    ax = _place(n, 12, [(_AXIAL, _AX)]) / L
    tor = _place(n, 12, [(_TORSION, _AX)]) / L
    bz = np.zeros((n, 12, 12))
    bz[np.ix_(range(n), _PLANE_XY, _PLANE_XY)] = _bending_stiffness_unit(length)
    by = np.zeros((n, 12, 12))
    by[np.ix_(range(n), _PLANE_XZ, _PLANE_XZ)] = _FLIP @ _bending_stiffness_unit(length) @ _FLIP
    K: Terms = [
        (("E", "A"), _to_global(ax, T)),
        (("G", "J"), _to_global(tor, T)),
        (("E", "Iz"), _to_global(bz, T)),
        (("E", "Iy"), _to_global(by, T)),
    ]
    return ElementTerms(K=K, M=_frame_mass(T, length, mass, [("rho", "Iy"), ("rho", "Iz")]))


FRAME3D_PHYSICAL = ("EA_l", "GJ_l", "k12_z", "k6_z", "k2_z", "k12_y", "k6_y", "k2_y")


def frame3d_physical_terms(xa, xb, orientation, mass: str = "consistent") -> ElementTerms:
    """Space frame whose independent stiffness terms are the properties (Appendix 1).

    Properties ``EA_l`` (EA/l), ``GJ_l`` (GJ/l), and per bending plane ``k12_z``
    (12 E Iz / l^3), ``k6_z`` (6 E Iz / l^2), ``k2_z`` (2 E Iz / l) and likewise ``_y``.  When
    Iy = Iz the element may give ``k12``, ``k6``, ``k2`` instead, shared by both planes: the
    Appendix's reduced set of five unknowns.  Mass from ``rho``, ``A`` and ``Ip`` (polar
    moment for the torsional inertia).

    The shared names are resolved by the builder
    (:meth:`femupdate.structure.Structure.frame3d_terms`); the terms returned here always carry the
    per-plane names.

    Parameters
    ----------
    xa, xb : array_like, shape ``(n_el, 3)``
        Coordinates of each element's end nodes a and b, m.
    orientation : array_like, shape ``(3,)`` or ``(n_el, 3)``
        A vector in each element's local x-y plane, not along its axis.
    mass : {"consistent", "lumped"}, default "consistent"
        Mass matrix.

    Returns
    -------
    ElementTerms
        Stiffness terms ``("EA_l",)``, ``("GJ_l",)``, then ``("k12_z",)``, ``("k12_y",)``,
        ``("k6_z",)``, ``("k6_y",)``, ``("k2_z",)``, ``("k2_y",)``; mass terms ``("rho", "A")`` and
        ``("rho", "Ip")``; stacks of shape ``(n_el, 12, 12)``.

    Raises
    ------
    InputError
        As for :func:`frame3d_terms`.
    """
    T, length = _frame_T(xa, xb, orientation)
    n = len(length)
    K: Terms = [
        (("EA_l",), _to_global(_place(n, 12, [(_AXIAL, _AX)]), T)),
        (("GJ_l",), _to_global(_place(n, 12, [(_TORSION, _AX)]), T)),
    ]
    for name, unit in (("k12", _B12), ("k6", _B6), ("k2", _B2)):
        K.append(((name + "_z",), _to_global(_place(n, 12, [(_PLANE_XY, unit)]), T)))
        K.append(((name + "_y",), _to_global(_place(n, 12, [(_PLANE_XZ, _FLIP @ unit @ _FLIP)]), T)))
    return ElementTerms(K=K, M=_frame_mass(T, length, mass, [("rho", "Ip")]))


def combine(terms: Terms, props: dict[str, np.ndarray]) -> np.ndarray:
    """Numeric stack ``sum_t prod_f props[f] * unit_t`` for numeric properties (one per element).

    Parameters
    ----------
    terms : list of (tuple of str, numpy.ndarray)
        Terms as in :class:`ElementTerms`, stacks of shape ``(n_el, n_e, n_e)``.
    props : dict of str to array_like
        Value of each property named by a factor: a scalar or one value per element, shape ``(n_el,)``.

    Returns
    -------
    numpy.ndarray, shape ``(n_el, n_e, n_e)``
        The element matrices (``None`` if ``terms`` is empty).

    Raises
    ------
    KeyError
        A factor has no entry in ``props``.
    """
    out = None
    for factors, unit in terms:
        coef = np.ones(unit.shape[0])
        for f in factors:
            coef = coef * np.broadcast_to(np.asarray(props[f], float), coef.shape)
        part = coef[:, None, None] * unit
        out = part if out is None else out + part
    return cast(np.ndarray, out)  # None for an empty ``terms``, as before


def physical_terms_of_frame(E, G, A, Iy, Iz, J, length) -> dict[str, np.ndarray]:
    """The Appendix's physical terms of a frame member from its section properties.

    Parameters
    ----------
    E, G : array_like
        Young's and shear moduli, Pa.
    A : array_like
        Cross-section area, m².
    Iy, Iz : array_like
        Second moments of area for bending in the local x-z and x-y planes, m⁴.
    J : array_like
        Torsion constant, m⁴.
    length : array_like
        Member length, m.

    Returns
    -------
    dict of str to numpy.ndarray
        ``EA_l``, ``GJ_l`` (N/m and N·m), and per plane ``k12_z``/``k12_y`` (12EI/l³, N/m), ``k6_z``/``k6_y``
        (6EI/l², N) and ``k2_z``/``k2_y`` (2EI/l, N·m), broadcast over the inputs.
    """
    E, G, A, Iy, Iz, J, length = (np.asarray(v, float) for v in (E, G, A, Iy, Iz, J, length))
    return {
        "EA_l": E * A / length,
        "GJ_l": G * J / length,
        "k12_z": 12 * E * Iz / length**3,
        "k6_z": 6 * E * Iz / length**2,
        "k2_z": 2 * E * Iz / length,
        "k12_y": 12 * E * Iy / length**3,
        "k6_y": 6 * E * Iy / length**2,
        "k2_y": 2 * E * Iy / length,
    }
