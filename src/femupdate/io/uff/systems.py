r"""Coordinate systems of universal files (datasets 2420 and 18) and what they do to nodes and data.

A node record (dataset 15 or 2411) names two systems: its *definition* system, in which its
coordinates are given, and its *displacement* system, along whose axes the data measured at the
node (mode shape components in dataset 55, FRF directions in dataset 58) point.  System 0 is the
global one.  femupdate's models live in the global axes, so:

* coordinates in a Cartesian definition system are moved to global ones,
  :math:`p_g = o + R^T p_l`;
* data in a Cartesian displacement system are rotated into the global axes, the translations
  and the rotations alike, :math:`v_g = R^T v_l`;
* a cylindrical or spherical system (type 1 or 2), or a system the file does not define, is
  refused, naming the system and the node.

Dataset 2420 gives each system a 4 x 3 transformation matrix: rows 1-3 are the system's x, y and
z axes as unit vectors in the global axes (the rows of :math:`R`), row 4 its origin :math:`o`.
Dataset 18 gives an origin, a point on the +x axis and a point in the +xz plane, in a reference
system (0: global; another system of the file, resolved in turn).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..._errors import InputError
from ...dofs import DIRECTIONS

__all__ = ["System", "read_2420", "read_18", "resolve_18", "aligned_axis", "unrotatable", "ORTHO_TOL", "ALIGN_TOL"]

#: ``|R Rᵀ − I|`` above this: not a rotation (16-digit matrices meet 1e-12; 6-digit ones about 1e-5)
ORTHO_TOL = 1e-4
#: entries of R below this in magnitude are zero: a direction within 1e-6 of an axis lies along it
ALIGN_TOL = 1e-6
KINDS = {0: "Cartesian", 1: "cylindrical", 2: "spherical"}


@dataclass(frozen=True)
class System:
    """One coordinate system of the file.

    Attributes
    ----------
    label : int
        Its number in the file.
    kind : int
        0 Cartesian, 1 cylindrical, 2 spherical.
    name : str
        Its name in the file (may be empty).
    R : numpy.ndarray, shape ``(3, 3)``
        Rows: the system's x, y, z axes in the global axes (entries below :data:`ALIGN_TOL` in
        magnitude set to zero).
    origin : numpy.ndarray, shape ``(3,)``
        Its origin in global coordinates (file units).
    where : str
        The record that defines it (``"f.uff: dataset 2420 record 1"``).
    """

    label: int
    kind: int
    name: str
    R: np.ndarray
    origin: np.ndarray
    where: str

    def describe(self) -> str:
        """``"coordinate system 3 ('SKEW', dataset 2420 record 1)"`` for messages."""
        named = f"'{self.name}', " if self.name else ""
        return f"coordinate system {self.label} ({named}{self.where.split(': ', 1)[-1]})"

    def cartesian(self, node: int, role: str) -> np.ndarray:
        """R of a Cartesian system; a cylindrical or spherical one is refused, naming the node.

        Parameters
        ----------
        node : int
            The node whose coordinates or data refer to this system.
        role : str
            ``"definition"`` or ``"displacement"``, for the message.

        Returns
        -------
        numpy.ndarray, shape ``(3, 3)``

        Raises
        ------
        InputError
            The system is not Cartesian.
        """
        if self.kind != 0:
            raise InputError(f"node {node}: its {role} system is {self.describe()}, a {KINDS.get(self.kind, str(self.kind))} "
                             "system; femupdate reads Cartesian systems only: export the data in the global system, "
                             "or in Cartesian local systems")
        return self.R


def _rotation(rows, where: str, label: int) -> np.ndarray:
    R = np.asarray(rows, dtype=float).reshape(3, 3)
    if not np.all(np.isfinite(R)):
        raise InputError(f"{where}: coordinate system {label}: NaN or infinite entries in its transformation matrix")
    if np.max(np.abs(R @ R.T - np.eye(3))) > ORTHO_TOL or np.linalg.det(R) < 0:
        raise InputError(f"{where}: coordinate system {label}: rows 1-3 of its transformation matrix are not the "
                         f"unit axes of a right-handed system (R Rᵀ ≠ I or det R < 0): {R.tolist()}")
    return np.where(np.abs(R) < ALIGN_TOL, 0.0, R)


def _add(systems: dict[int, System], s: System) -> None:
    old = systems.get(s.label)
    if old is not None and not (old.kind == s.kind and np.allclose(old.R, s.R, atol=ORTHO_TOL)
                                and np.allclose(old.origin, s.origin, rtol=1e-5, atol=1e-9)):
        raise InputError(f"{s.where}: coordinate system {s.label} is defined twice, differently (first in "
                         f"{old.where.split(': ', 1)[-1]})")
    systems.setdefault(s.label, s)


def read_2420(dset: dict, where: str, systems: dict[int, System]) -> None:
    """Add the systems of one dataset 2420 record to ``systems``.

    Raises
    ------
    InputError
        Missing fields, a matrix that is not 4 x 3, not finite or whose rows 1-3 are not a
        right-handed orthonormal triad; a system defined twice differently; label 0 (the
        global system) redefined other than as the identity.
    """
    try:
        labels = [int(v) for v in dset["CS_sys_labels"]]
        kinds = [int(v) for v in dset["CS_types"]]
        names = [str(v).strip() for v in dset.get("CS_names", [""] * len(labels))]
        mats = [np.asarray(m, dtype=float) for m in dset["CS_matrices"]]
    except (KeyError, TypeError, ValueError) as exc:
        raise InputError(f"{where}: coordinate systems cannot be read ({exc})") from None
    if not (len(labels) == len(kinds) == len(mats)):
        raise InputError(f"{where}: {len(labels)} system labels but {len(mats)} transformation matrices "
                         "(truncated record?)")
    for label, kind, name, m in zip(labels, kinds, names + [""] * len(labels), mats):
        if m.shape != (4, 3):
            raise InputError(f"{where}: coordinate system {label}: transformation matrix of shape {m.shape}, "
                             "expected 4 rows of 3 (truncated record?)")
        if kind not in KINDS:
            raise InputError(f"{where}: coordinate system {label}: type {kind} is not 0 (Cartesian), 1 "
                             "(cylindrical) or 2 (spherical)")
        R = _rotation(m[:3], where, label)
        if not np.all(np.isfinite(m[3])):
            raise InputError(f"{where}: coordinate system {label}: NaN or infinite origin")
        if label == 0:
            if kind != 0 or not np.allclose(R, np.eye(3), atol=ORTHO_TOL) or np.any(m[3] != 0):
                raise InputError(f"{where}: coordinate system 0 is the global system; it cannot be redefined")
            continue
        _add(systems, System(label, kind, name, R, m[3].copy(), where))


def read_18(dset: dict, where: str) -> list[tuple[int, int, int, str, np.ndarray, np.ndarray, np.ndarray, str]]:
    """The raw systems of one dataset 18 record: ``(label, kind, reference system, name, origin,
    point on +x, point in +xz plane, where)``, resolved by :func:`resolve_18` once every
    record is read.

    Raises
    ------
    InputError
        Missing fields, a method of definition other than 1, a type other than 0, 1, 2.
    """
    try:
        labels = [int(v) for v in np.atleast_1d(dset["cs_num"])]
        kinds = [int(v) for v in np.atleast_1d(dset["cs_type"])]
        refs = [int(v) for v in np.atleast_1d(dset["ref_cs_num"])]
        methods = [int(v) for v in np.atleast_1d(dset.get("method", [1] * len(labels)))]
        names = [str(v).strip() for v in dset.get("cs_name", [""] * len(labels))]
        pts = [np.atleast_2d(np.asarray(dset[k], dtype=float)) for k in ("ref_o", "x_point", "xz_point")]
    except (KeyError, TypeError, ValueError) as exc:
        raise InputError(f"{where}: coordinate systems cannot be read ({exc})") from None
    n = len(labels)
    if not (len(kinds) == len(refs) == n and all(p.shape == (n, 3) for p in pts)):
        raise InputError(f"{where}: {n} system labels but not as many definitions (truncated record?)")
    out = []
    for i, label in enumerate(labels):
        if methods[i] != 1:
            raise InputError(f"{where}: coordinate system {label}: method of definition {methods[i]} is not 1 "
                             "(origin, +x axis, +xz plane)")
        if kinds[i] not in KINDS:
            raise InputError(f"{where}: coordinate system {label}: type {kinds[i]} is not 0 (Cartesian), 1 "
                             "(cylindrical) or 2 (spherical)")
        if label == 0:
            raise InputError(f"{where}: coordinate system 0 is the global system; it cannot be redefined")
        out.append((label, kinds[i], refs[i], names[i] if i < len(names) else "", pts[0][i], pts[1][i], pts[2][i],
                    where))
    return out


def resolve_18(raw: list, systems: dict[int, System]) -> None:
    """Add the systems of datasets 18 to ``systems``, each in global axes (its reference system
    resolved first; 0 is the global system).

    Raises
    ------
    InputError
        Points that do not define axes (coincident or collinear), a reference system that is not
        defined or not Cartesian, a cycle of references, non-finite values.
    """
    pending = {r[0]: r for r in raw}
    if len(pending) != len(raw):
        seen: set[int] = set()
        for r in raw:
            if r[0] in seen:
                raise InputError(f"{r[7]}: coordinate system {r[0]} is defined twice in datasets 18")
            seen.add(r[0])

    def build(label: int, chain: tuple[int, ...]) -> System:
        if label in systems:
            return systems[label]
        r = pending.get(label)
        if r is None:
            raise KeyError(label)
        lab, kind, ref, name, o, px, pxz, where = r
        if ref in chain + (lab,):
            raise InputError(f"{where}: coordinate system {lab}: its reference systems form a cycle "
                             f"({' -> '.join(map(str, chain + (lab, ref)))})")
        if not all(np.all(np.isfinite(v)) for v in (o, px, pxz)):
            raise InputError(f"{where}: coordinate system {lab}: NaN or infinite values")
        ex = px - o
        if np.linalg.norm(ex) == 0:
            raise InputError(f"{where}: coordinate system {lab}: its +x point is its origin")
        ex = ex / np.linalg.norm(ex)
        w = pxz - o
        ez = w - (w @ ex) * ex
        if float(np.linalg.norm(ez)) <= 1e-9 * max(float(np.linalg.norm(w)), 1e-300):
            raise InputError(f"{where}: coordinate system {lab}: its +xz-plane point lies on its x axis")
        ez = ez / np.linalg.norm(ez)
        local = np.vstack([ex, np.cross(ez, ex), ez])  # rows: the axes in the reference system
        if ref == 0:
            R, origin = local, o
        else:
            try:
                parent = build(ref, chain + (lab,))
            except KeyError:
                raise InputError(f"{where}: coordinate system {lab}: its reference system {ref} is not defined in "
                                 "the file (datasets 2420, 18)") from None
            if parent.kind != 0:
                raise InputError(f"{where}: coordinate system {lab}: its reference system is {parent.describe()}, "
                                 "not Cartesian")
            R, origin = local @ parent.R, parent.origin + parent.R.T @ o
        s = System(lab, kind, name, np.where(np.abs(R) < ALIGN_TOL, 0.0, R), np.asarray(origin, float), where)
        _add(systems, s)
        return s

    for label in pending:
        build(label, ())


def aligned_axis(v: np.ndarray) -> tuple[int, float] | None:
    """``(axis index, sign)`` when the unit vector v lies along a global axis, else None."""
    big = np.flatnonzero(np.abs(v) >= ALIGN_TOL)
    if big.size != 1:
        return None
    i = int(big[0])
    return i, (1.0 if float(v[i]) > 0 else -1.0)


def unrotatable(measured, disp, systems) -> dict:
    """The nodes in a local Cartesian displacement system with a measured component that enters
    no global component all of whose local components are measured (a single component along a
    skewed axis): ``{node: R}``, R's rows the system's axes in global axes.

    Parameters
    ----------
    measured : collection of (int, str)
        The measured (node, local direction) pairs.
    disp : mapping of int to int
        Each node's displacement system.
    systems : mapping of int to System
    """
    by_node: dict = {}
    for n, d in measured:
        by_node.setdefault(n, set()).add(d)
    out = {}
    for n, ds in by_node.items():
        cs = disp.get(n, 0)
        if cs == 0 or cs not in systems or systems[cs].kind != 0:
            continue  # global, or refused by name where the data are rotated
        R = systems[cs].R
        for group in (DIRECTIONS[:3], DIRECTIONS[3:]):
            known = np.array([d in ds for d in group])
            lost = set(np.flatnonzero(known).tolist())
            for i in range(3):
                needs = np.flatnonzero(R[:, i] != 0)
                if known[needs].all():
                    lost -= set(needs.tolist())
            if lost:
                out[n] = R
    return out
