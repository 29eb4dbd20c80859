r"""Generators of parametrised test structures, from a 2-dof chain to 100,000-dof lattices.

Pure functions that return an editable :class:`~femupdate.Structure` (call ``.build()`` for the
:class:`~femupdate.Model`).  Everything goes through the public :class:`Structure` API, one
vectorised element group per member family: the only Python loops are over storeys and inside
:class:`Structure` itself.

* :func:`frame_lattice` — 3-D space-frame lattice of 12-dof frame members (steel tubes), fixed at
  its base: the large, realistic updating problem (one Young's modulus per storey).
* :func:`truss_lattice` — plane (``dim=2``) X-braced truss of rods, pinned at its base.
* :func:`shear_building` — chain of storey springs and floor masses with a closed-form spectrum.

Node ids are 1-based and run fastest along x, then y, then z; dof labels are ``"<node>:<dir>"``.
Units are SI throughout (m, Pa, kg/m^3, N/m, kg).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping, Sequence

import numpy as np

from ._docs import shared_docs
from ._errors import InputError
from .options._base import Options, gather, number
from .structure import Structure

__all__ = ["chs_section", "FrameMembers", "frame_lattice", "truss_lattice", "shear_building",
           "FRAME_PARAMETERS", "TRUSS_PARAMETERS", "SHEAR_PARAMETERS"]

FRAME_PARAMETERS = ("storey", "storey_mass", "direction", "none")
TRUSS_PARAMETERS = ("storey", "storey_mass", "none")
SHEAR_PARAMETERS = ("storey", "storey_mass", "none")
SUPPORTS = ("base", "none")

# Circular hollow section 114.3 x 6.3 (EN 10210), structural steel S355.
_D, _T = 0.1143, 0.0063
_E, _NU, _RHO = 210e9, 0.3, 7850.0


def chs_section(diameter: float = _D, thickness: float = _T) -> dict[str, float]:
    r"""Section properties of a circular hollow section (tube).

    .. math:: A = \tfrac{\pi}{4}(D^2 - d^2), \quad I_y = I_z = \tfrac{\pi}{64}(D^4 - d^4),
              \quad J = I_y + I_z, \qquad d = D - 2t

    Parameters
    ----------
    diameter : float
        Outside diameter D (m), default 114.3 mm.
    thickness : float
        Wall thickness t (m), ``0 < t <= D/2``, default 6.3 mm.

    Returns
    -------
    dict
        ``A`` (m^2), ``Iy``, ``Iz``, ``J`` (m^4).
    """
    D, t = _positive(diameter, "diameter"), _positive(thickness, "thickness")
    if t > D / 2:
        raise InputError(f"thickness = {t:g} m exceeds half the diameter ({D / 2:g} m)")
    d = D - 2 * t
    A = math.pi / 4 * (D**2 - d**2)
    inertia = math.pi / 64 * (D**4 - d**4)
    return {"A": A, "Iy": inertia, "Iz": inertia, "J": 2 * inertia}


def _lattice_end(members: str, name: str) -> str:
    """The last parameters and the returns of the lattices' documentation (femupdate._docs)."""
    return f"""bounds : (float, float)
    Parameter bounds relative to the nominal value, ``0 <= lower < 1 < upper``.
mass : ``"consistent"`` | ``"lumped"``
    Mass matrix of the {members}.
name : str, optional
    Structure name (default ``"{name}"``).

Returns
-------
Structure"""


# --------------------------------------------------------------------------------------
# 3-D space frame
# --------------------------------------------------------------------------------------
@dataclasses.dataclass(frozen=True, repr=False)
class FrameMembers(Options):
    """The members of :func:`frame_lattice`: their material and their tube (:func:`chs_section`).

    Attributes
    ----------
    E : float, default 210e9
        Young's modulus (Pa), > 0; default structural steel.
    nu : float, default 0.3
        Poisson's ratio, in (-1, 0.5); ``G = E / (2 (1 + nu))``.
    rho : float, default 7850
        Density (kg/m^3), > 0.
    diameter : float, default 0.1143
        Tube outside diameter (m), > 0.
    thickness : float, default 0.0063
        Tube wall thickness (m), ``0 < thickness <= diameter / 2``.
    """

    E: float = _E
    nu: float = _NU
    rho: float = _RHO
    diameter: float = _D
    thickness: float = _T

    def check(self) -> None:
        self.set("E", _positive(self.E, "E"))
        self.set("rho", _positive(self.rho, "rho"))
        self.set("nu", number(self.nu, "nu", low=-1.0, high=0.5, low_open=True, high_open=True))
        chs_section(self.diameter, self.thickness)  # checks both
        self.set("diameter", float(self.diameter))
        self.set("thickness", float(self.thickness))


@shared_docs(LATTICE_END=_lattice_end("members", "frame lattice NXxNYxNZ"))
def frame_lattice(
    nx: int,
    ny: int,
    nz: int,
    spacing: float | Sequence[float] = 1.0,
    members: FrameMembers | Mapping | None = None,
    parameters: str = "storey",
    support: str = "base",
    bounds: tuple[float, float] = (0.5, 2.0),
    mass: str = "consistent",
    name: str | None = None,
    **shorthand,
) -> Structure:
    r"""Space-frame lattice of ``nx * ny * nz`` nodes joined by tubular frame members.

    Node ``(i, j, k)`` (``0 <= i < nx`` etc.) sits at ``(i sx, j sy, k sz)`` and has id
    ``1 + i + nx j + nx ny k``.  Members join neighbours along x and y (beams, at every level)
    and along z (columns); each is a 12-dof Euler–Bernoulli ``frame3d`` member with the tube of
    :func:`chs_section`, ``G = E / (2 (1 + nu))``.  Beams are oriented with local y in the
    global z direction's plane (orientation ``(0, 0, 1)``), columns with ``(1, 0, 0)``.

    Storey ``s = 1 .. nz-1`` holds the columns from level ``s-1`` to ``s`` and the beams at level
    ``s`` (the base beams at level 0, present only when ``support="none"``, belong to storey 1).

    Sizes:

    * free dofs: ``6 nx ny (nz - 1)`` with ``support="base"`` (all six dofs of the
      ``nx ny`` nodes at z = 0 are fixed), ``6 nx ny nz`` with ``support="none"`` (free–free,
      six rigid-body modes).  ``frame_lattice(30, 30, 20)`` has 102,600 free dofs.
    * members: ``(nx-1) ny + nx (ny-1)`` beams per level (levels ``1 .. nz-1``, plus level 0
      when unsupported) and ``nx ny (nz-1)`` columns.

    Parameters
    ----------
    nx, ny, nz : int
        Nodes along x, y and z; ``nx, ny >= 1``, ``nz >= 2``, at least two nodes in plan.
    spacing : float or (sx, sy, sz)
        Member lengths (m).
    members : FrameMembers or mapping, optional
        The members' material and tube (default steel tubes 114.3 x 6.3); its fields ``E``,
        ``nu``, ``rho``, ``diameter`` and ``thickness`` are also accepted as keywords
        (``frame_lattice(3, 3, 4, E=70e9)``).
    parameters : ``"storey"`` | ``"storey_mass"`` | ``"direction"`` | ``"none"``
        * ``"storey"``: one Young's modulus ``E_s`` per storey, ``L = nz - 1`` parameters (E
          enters K only: the axial and both bending terms of the storey's members; the shear
          modulus stays numeric so the model is affine).  The usual updating setting: stiffness
          errors localised by storey.
        * ``"storey_mass"``: ``E_s`` and a density ``rho_s`` per storey, ``L = 2 (nz - 1)``,
          in the order ``E_1, rho_1, E_2, rho_2, ...``.
        * ``"direction"``: ``E_x``, ``E_y`` (beams along x, along y) and ``E_z`` (columns),
          ``L = 3`` (``E_x`` or ``E_y`` is left out when ``nx`` or ``ny`` is 1).
        * ``"none"``: all properties numeric, ``L = 0``.
    support : ``"base"`` | ``"none"``
        Fix every dof of the nodes at z = 0, or leave the lattice free–free.
    {{LATTICE_END}}

    Examples
    --------
    >>> s = frame_lattice(3, 3, 4)
    >>> m = s.build()
    >>> m.n_dofs, len(m.parameters)
    (162, 3)
    """
    nx, ny, nz = _count(nx, "nx"), _count(ny, "ny"), _count(nz, "nz", minimum=2)
    if nx * ny < 2:
        raise InputError(f"frame_lattice needs at least two nodes in plan, got nx = {nx}, ny = {ny}")
    sx, sy, sz = _spacing(spacing, 3)
    _choice(parameters, FRAME_PARAMETERS, "parameters")
    _choice(support, SUPPORTS, "support")
    made: FrameMembers = gather("frame_lattice", shorthand, members=(FrameMembers, members))["members"]
    E, nu, rho = made.E, made.nu, made.rho
    sec = chs_section(made.diameter, made.thickness)
    lo, hi = _relative_bounds(bounds)

    s = Structure(name or f"frame lattice {nx}x{ny}x{nz}")
    ids = 1 + np.arange(nx * ny * nz, dtype=np.int64).reshape(nz, ny, nx)  # [k, j, i]
    k, j, i = np.indices((nz, ny, nx))
    s.add_nodes(ids.ravel(), np.column_stack([i.ravel() * sx, j.ravel() * sy, k.ravel() * sz]))

    n_storey = nz - 1
    first = 1 if support == "base" else 0  # base beams are fully clamped: leave them out
    if parameters in ("storey", "storey_mass"):
        for st in range(1, n_storey + 1):
            s.parameter(f"E_{st}", E, bounds=(lo * E, hi * E))
            if parameters == "storey_mass":
                s.parameter(f"rho_{st}", rho, bounds=(lo * rho, hi * rho))
    elif parameters == "direction":
        for d, present in (("x", nx > 1), ("y", ny > 1), ("z", True)):
            if present:
                s.parameter(f"E_{d}", E, bounds=(lo * E, hi * E))

    # member families: (nodes (n, 2), storey of each member, direction letter, orientation)
    families = []
    if nx > 1:
        a, b = ids[first:, :, :-1], ids[first:, :, 1:]
        families.append(("x", a, b, np.broadcast_to(np.arange(first, nz)[:, None, None], a.shape), (0.0, 0.0, 1.0)))
    if ny > 1:
        a, b = ids[first:, :-1, :], ids[first:, 1:, :]
        families.append(("y", a, b, np.broadcast_to(np.arange(first, nz)[:, None, None], a.shape), (0.0, 0.0, 1.0)))
    a, b = ids[:-1], ids[1:]
    families.append(("z", a, b, np.broadcast_to(np.arange(1, nz)[:, None, None], a.shape), (1.0, 0.0, 0.0)))

    G = E / (2.0 * (1.0 + nu))
    for d, a, b, storey, orient in families:
        pairs = np.column_stack([a.ravel(), b.ravel()])
        storey = np.maximum(storey.ravel(), 1)
        E_el, rho_el = _storey_values(parameters, storey, d, E, rho)
        s.frame3d(pairs, E=E_el, G=G, A=sec["A"], Iy=sec["Iy"], Iz=sec["Iz"], J=sec["J"], rho=rho_el,
                  orientation=orient, mass=mass, where=f"frame_lattice {d}-members")
    if support == "base":
        s.support_node(ids[0].ravel().tolist())
    return s


# --------------------------------------------------------------------------------------
# plane truss
# --------------------------------------------------------------------------------------
@shared_docs(LATTICE_END=_lattice_end("rods", "truss lattice NXxNY"))
def truss_lattice(
    nx: int,
    ny: int,
    spacing: float | Sequence[float] = 1.0,
    E: float = _E,
    A: float | None = None,
    rho: float = _RHO,
    parameters: str = "storey",
    support: str = "base",
    bounds: tuple[float, float] = (0.5, 2.0),
    mass: str = "consistent",
    name: str | None = None,
) -> Structure:
    r"""Plane X-braced truss of ``nx * ny`` nodes in the x-y plane (2-D rods, dofs ``x, y``).

    Node ``(i, j)`` sits at ``(i sx, j sy, 0)`` with id ``1 + i + nx j``.  Rods join
    horizontal neighbours (chords, at every row), vertical neighbours (posts) and both
    diagonals of every cell, so the truss is stiff in its plane.  Row ``j`` is "storey" ``j``:
    storey ``s = 1 .. ny-1`` holds the posts and diagonals between rows ``s-1`` and ``s`` and
    the chords of row ``s`` (the chords of row 0, present only when ``support="none"``,
    belong to storey 1).

    Sizes:

    * free dofs: ``2 nx (ny - 1)`` with ``support="base"`` (both dofs of the ``nx`` nodes at
      y = 0 are fixed: pinned), ``2 nx ny`` free–free (three rigid-body modes).
    * rods: ``(nx - 1)`` chords per row (rows ``1 .. ny-1``, plus row 0 when unsupported),
      ``nx (ny - 1)`` posts and ``2 (nx - 1)(ny - 1)`` diagonals.

    Parameters
    ----------
    nx, ny : int
        Nodes along x and y, both ``>= 2``.
    spacing : float or (sx, sy)
        Bay width and storey height (m).
    E, rho : float
        Young's modulus (Pa) and density (kg/m^3); default steel.
    A : float, optional
        Rod cross-section (m^2); default the tube of :func:`chs_section`.
    parameters : ``"storey"`` | ``"storey_mass"`` | ``"none"``
        ``"storey"``: one ``E_s`` per storey, ``L = ny - 1``; ``"storey_mass"``: ``E_s`` and
        ``rho_s``, ``L = 2 (ny - 1)`` in the order ``E_1, rho_1, ...``; ``"none"``: ``L = 0``.
    support : ``"base"`` | ``"none"``
        Pin both dofs of the nodes at y = 0, or leave the lattice free–free.
    {{LATTICE_END}}

    Examples
    --------
    >>> m = truss_lattice(4, 3).build()
    >>> m.n_dofs, len(m.parameters)
    (16, 2)
    """
    nx, ny = _count(nx, "nx", minimum=2), _count(ny, "ny", minimum=2)
    sx, sy = _spacing(spacing, 2)
    _choice(parameters, TRUSS_PARAMETERS, "parameters")
    _choice(support, SUPPORTS, "support")
    E, rho = _positive(E, "E"), _positive(rho, "rho")
    A = chs_section()["A"] if A is None else _positive(A, "A")
    lo, hi = _relative_bounds(bounds)

    s = Structure(name or f"truss lattice {nx}x{ny}")
    ids = 1 + np.arange(nx * ny, dtype=np.int64).reshape(ny, nx)  # [j, i]
    j, i = np.indices((ny, nx))
    s.add_nodes(ids.ravel(), np.column_stack([i.ravel() * sx, j.ravel() * sy]))
    if parameters != "none":
        for st in range(1, ny):
            s.parameter(f"E_{st}", E, bounds=(lo * E, hi * E))
            if parameters == "storey_mass":
                s.parameter(f"rho_{st}", rho, bounds=(lo * rho, hi * rho))

    first = 1 if support == "base" else 0
    rows = np.arange(ny)[:, None]
    families = [
        ("chords", ids[first:, :-1], ids[first:, 1:], np.broadcast_to(rows[first:], (ny - first, nx - 1))),
        ("posts", ids[:-1, :], ids[1:, :], np.broadcast_to(rows[1:], (ny - 1, nx))),
        ("diagonals /", ids[:-1, :-1], ids[1:, 1:], np.broadcast_to(rows[1:], (ny - 1, nx - 1))),
        ("diagonals \\", ids[:-1, 1:], ids[1:, :-1], np.broadcast_to(rows[1:], (ny - 1, nx - 1))),
    ]
    for what, a, b, storey in families:
        pairs = np.column_stack([a.ravel(), b.ravel()])
        E_el, rho_el = _storey_values(parameters, np.maximum(storey.ravel(), 1), "", E, rho)
        s.rod(pairs, E=E_el, A=A, rho=rho_el, dim=2, mass=mass, where=f"truss_lattice {what}")
    if support == "base":
        s.support_node(ids[0].tolist())
    return s


# --------------------------------------------------------------------------------------
# shear building
# --------------------------------------------------------------------------------------
def shear_building(
    n_storeys: int,
    k: float | Sequence[float] = 1.0e7,
    m: float | Sequence[float] = 1.0e4,
    parameters: str = "storey",
    height: float = 3.0,
    bounds: tuple[float, float] = (0.5, 2.0),
    name: str | None = None,
) -> Structure:
    r"""Shear building: floor masses on a chain of storey springs, fixed at the ground.

    Floor ``r = 1 .. n`` is node ``r`` at ``(0, 0, r h)`` with the single dof ``"r:x"``; storey
    ``r`` is the spring ``k_r`` between floor ``r - 1`` (the ground for ``r = 1``) and floor
    ``r``, and ``m_r`` the floor's lumped mass:

    .. math:: K = \begin{bmatrix} k_1 + k_2 & -k_2 \\ -k_2 & k_2 + k_3 & \ddots \\
              & \ddots & k_n \end{bmatrix}, \qquad M = \operatorname{diag}(m_r)

    With uniform ``k`` and ``m`` the eigenvalues are
    :math:`\lambda_r = 4 (k/m) \sin^2\!\big((2r - 1)\pi / (2 (2n + 1))\big)`.

    Sizes:

    ``n`` dofs; ``L = n`` parameters ``k_1 .. k_n`` (``"storey"``), ``2n`` parameters
    ``k_1, m_1, k_2, m_2, ...`` (``"storey_mass"``) or none (``"none"``).

    Parameters
    ----------
    n_storeys : int
        Number of storeys n >= 1.
    k : float or sequence of n floats
        Storey stiffnesses (N/m), nominal parameter values.
    m : float or sequence of n floats
        Floor masses (kg).
    parameters : ``"storey"`` | ``"storey_mass"`` | ``"none"``
        Which of k and m become parameters (see Sizes above).
    height : float
        Storey height (m), for node coordinates only.
    bounds : (float, float)
        Parameter bounds relative to the nominal value.
    name : str, optional
        Structure name (default ``"shear building, N storeys"``).

    Returns
    -------
    Structure

    Examples
    --------
    >>> m = shear_building(3).build()
    >>> m.parameter_names
    ('k_1', 'k_2', 'k_3')
    """
    n = _count(n_storeys, "n_storeys")
    _choice(parameters, SHEAR_PARAMETERS, "parameters")
    kv = _per_storey(k, n, "k")
    mv = _per_storey(m, n, "m")
    h = _positive(height, "height")
    lo, hi = _relative_bounds(bounds)

    s = Structure(name or f"shear building, {n} storeys")
    floors = np.arange(1, n + 1)
    s.add_nodes(floors, np.column_stack([np.zeros(n), np.zeros(n), floors * h]))
    if parameters != "none":
        for r in floors:
            s.parameter(f"k_{r}", kv[r - 1], bounds=(lo * kv[r - 1], hi * kv[r - 1]))
            if parameters == "storey_mass":
                s.parameter(f"m_{r}", mv[r - 1], bounds=(lo * mv[r - 1], hi * mv[r - 1]))
    k_el = [f"k_{r}" for r in floors] if parameters != "none" else kv.tolist()
    m_el = [f"m_{r}" for r in floors] if parameters == "storey_mass" else mv.tolist()
    s.spring(["1:x"], k=k_el[0], where="shear_building storey 1")
    if n > 1:
        s.springs([[f"{r - 1}:x", f"{r}:x"] for r in floors[1:]], k=k_el[1:], where="shear_building storeys")
    for r in floors:  # Structure has no vectorised lumped-mass call; one group per floor
        s.mass([f"{r}:x"], m=m_el[r - 1], where=f"shear_building floor {r}")
    return s


# --------------------------------------------------------------------------------------
# helpers
# --------------------------------------------------------------------------------------
def _storey_values(parameters, storey, direction, E, rho):
    """Per-member E and rho: numbers, or parameter names by storey / direction."""
    if parameters in ("storey", "storey_mass"):
        names = np.array([f"E_{st}" for st in range(storey.max() + 1)], dtype=object)
        E_el = names[storey].tolist()
    elif parameters == "direction":
        E_el = f"E_{direction}"
    else:
        E_el = E
    if parameters == "storey_mass":
        rho_el = np.array([f"rho_{st}" for st in range(storey.max() + 1)], dtype=object)[storey].tolist()
    else:
        rho_el = rho
    return E_el, rho_el


def _count(value, what: str, minimum: int = 1) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < minimum:
        raise InputError(f"{what} must be an integer >= {minimum}, got {value!r}")
    return int(value)


def _positive(value, what: str) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise InputError(f"{what} must be a positive number, got {value!r}") from None
    if not (math.isfinite(v) and v > 0):
        raise InputError(f"{what} must be a positive finite number, got {value!r}")
    return v


def _spacing(spacing, dim: int) -> tuple[float, ...]:
    try:
        arr = np.atleast_1d(np.asarray(spacing, dtype=float))
    except (TypeError, ValueError):
        raise InputError(f"spacing must be a positive number or {dim} positive numbers, got {spacing!r}") from None
    if arr.shape == (1,):
        arr = np.repeat(arr, dim)
    if arr.shape != (dim,) or not np.all(np.isfinite(arr) & (arr > 0)):
        raise InputError(f"spacing must be a positive number or {dim} positive numbers, got {spacing!r}")
    return tuple(float(x) for x in arr)


def _choice(value, options, what: str) -> None:
    if value not in options:
        raise InputError(f"{what} must be one of {', '.join(map(repr, options))}, got {value!r}")


def _relative_bounds(bounds) -> tuple[float, float]:
    try:
        lo, hi = (float(b) for b in bounds)
    except (TypeError, ValueError):
        raise InputError(f"bounds must be two numbers (lower, upper) relative to nominal, got {bounds!r}") from None
    if not (0.0 <= lo < 1.0 < hi):
        raise InputError(f"bounds {bounds!r} are relative to the nominal value: need 0 <= lower < 1 < upper")
    return lo, hi


def _per_storey(value, n: int, what: str) -> np.ndarray:
    try:
        arr = np.atleast_1d(np.asarray(value, dtype=float))
    except (TypeError, ValueError):
        raise InputError(f"{what}: expected one number or {n} numbers (one per storey), got {value!r}") from None
    if arr.shape == (1,):
        arr = np.repeat(arr, n)
    if arr.shape != (n,):
        raise InputError(f"{what}: expected one number or {n} (one per storey), got shape {arr.shape}")
    bad = np.flatnonzero(~(np.isfinite(arr) & (arr > 0)))
    if bad.size:
        raise InputError(f"{what}: storey {bad[0] + 1} has non-positive or non-finite value {arr[bad[0]]!r}")
    return arr
