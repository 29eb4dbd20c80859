"""Full-field (scanning) test data: points by coordinates, measured translation components.

:class:`ScanData` holds the points and, per mode (:class:`ScanMode`) or FRF line
(:class:`ScanFRF`), the measured components at every point; :mod:`.mapping` maps them onto a
model's dofs, :mod:`femupdate.fullfield.files` reads them from JSON.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .._errors import InputError
from ..dofs import DIRECTIONS

AXES = {"x": np.array([1.0, 0.0, 0.0]), "y": np.array([0.0, 1.0, 0.0]), "z": np.array([0.0, 0.0, 1.0])}


@dataclass(frozen=True)
class ScanMode:
    """One mode measured by scanning.

    Each parameter is stored as the attribute of the same name; checked by :class:`ScanData`.

    Parameters
    ----------
    eigenvalue : float
        λ = ω² (rad²/s²).
    values : dict of str to array_like, shape ``(n_points,)``
        Measured values per translation direction (``"x"``, ``"y"``, ``"z"``), real or complex, one
        per scan point.
    label : str, default ``""``
        Name of the mode (``"mode k"`` is used where empty).
    """

    eigenvalue: float
    values: dict
    label: str = ""


@dataclass(frozen=True)
class ScanFRF:
    """Operating deflection shapes at known forcing.

    Each parameter is stored as the attribute of the same name; checked by :class:`ScanData`.

    Parameters
    ----------
    omega : ndarray, shape ``(n_freq,)``
        Excitation frequencies (rad/s).
    force : dict of str to float
        Applied force per dof label ``"node:dir"``.
    values : dict of str to array_like, shape ``(n_freq, n_points)``
        Measured response per translation direction (``"x"``, ``"y"``, ``"z"``), one row per frequency,
        real or complex.
    """

    omega: np.ndarray
    force: dict
    values: dict


def _same_mode(a: ScanMode, b: ScanMode) -> bool:
    """Whether two scanned modes are one mode given twice: equal eigenvalues, proportional values."""
    if not math.isclose(float(a.eigenvalue), float(b.eigenvalue), rel_tol=1e-9) or sorted(a.values) != sorted(b.values):
        return False
    u = np.concatenate([np.ravel(a.values[d]) for d in sorted(a.values)]).astype(complex)
    v = np.concatenate([np.ravel(b.values[d]) for d in sorted(b.values)]).astype(complex)
    uu, vv = np.vdot(u, u).real, np.vdot(v, v).real
    return uu > 0 and vv > 0 and abs(np.vdot(u, v)) ** 2 >= (1 - 1e-9) * uu * vv


@dataclass(frozen=True)
class ScanData:
    """A full-field scan: points by coordinates and the measured components at every point.

    Each parameter is stored as the attribute of the same name (points as a float array with
    shape ``(n, 3)``, ``zero`` as a tuple).

    Parameters
    ----------
    points : array_like, shape ``(n, 3)`` or ``(n, 2)``
        Coordinates of the scan points (same frame and units as the model's nodes; a missing z
        is 0).
    modes : tuple of ScanMode, default ``()``
        Scanned modes, each with values of shape ``(n,)``.
    frf : ScanFRF or None, default None
        Scanned FRF lines, values of shape ``(n_freq, n)``.
    zero : tuple of str, default ``()``
        Directions (``x`` ... ``rz``) known to be zero at every node (e.g. the axial motion and
        the torsion of a beam's bending modes); they complete the data.
    max_distance : float or None, default None
        Largest allowed distance of a point from the model's geometry (default
        ``TOLERANCE_FACTOR`` times the longest element).

    Raises
    ------
    InputError
        Points of the wrong shape or not finite, or all at one place; no modes and no frf; a mode
        with an eigenvalue that is not positive and finite, or given twice (the same frequency and
        shape); values of the wrong shape, not finite, or in a direction other than x, y, z; modes and frf measuring different
        directions; an unknown ``zero`` direction or one also measured; ``max_distance`` <= 0.
    """

    points: np.ndarray
    modes: tuple = ()
    frf: ScanFRF | None = None
    zero: tuple = ()
    max_distance: float | None = None

    def __post_init__(self):
        pts = np.asarray(self.points, dtype=float)
        if pts.ndim != 2 or pts.shape[1] not in (2, 3) or pts.shape[0] == 0:
            raise InputError(f"scan points must have shape (n, 3), got {pts.shape}")
        if pts.shape[1] == 2:
            pts = np.column_stack([pts, np.zeros(len(pts))])
        if not np.all(np.isfinite(pts)):
            raise InputError("scan points contain NaN or infinite coordinates")
        n = len(pts)
        if np.all(pts == pts[0]):
            raise InputError(f"{'all ' + str(n) + ' scan points are' if n > 1 else 'the only scan point is'} at one place "
                             f"({', '.join(f'{c:.4g}' for c in pts[0])}): a scan must spread over the structure")
        comps = None
        for k, m in enumerate(self.modes, start=1):
            what = m.label or f"mode {k}"
            comps = self._check(m.values, n, (n,), comps, what)
            lam = float(m.eigenvalue)
            if not (math.isfinite(lam) and lam > 0):
                raise InputError(f"scan {what}: eigenvalue {lam!r} must be finite and > 0" if lam != 0 else
                                 f"scan {what}: zero frequency: a rigid-body mode carries no stiffness information "
                                 "and cannot be a target of the identification; leave it out")
        for k, m in enumerate(self.modes):
            for j, o in enumerate(self.modes[:k]):
                if _same_mode(o, m):
                    raise InputError(f"scan {m.label or f'mode {k + 1}'} repeats {o.label or f'mode {j + 1}'} "
                                     "(the same frequency and shape): give each mode once")
        if self.frf is not None:
            comps = self._check(self.frf.values, n, (np.asarray(self.frf.omega).size, n), comps, "frf")
        if comps is None:
            raise InputError("the scan holds no modes and no frf")
        bad = [z for z in self.zero if z not in DIRECTIONS]
        if bad:
            raise InputError(f"zero: unknown direction(s) {', '.join(bad)} (use {', '.join(DIRECTIONS)})")
        both = sorted(set(self.zero) & set(comps))
        if both:
            raise InputError(f"direction(s) {', '.join(both)} are both measured and declared zero")
        if self.max_distance is not None and not self.max_distance > 0:
            raise InputError(f"max_distance must be positive, got {self.max_distance!r}")
        object.__setattr__(self, "points", pts)
        object.__setattr__(self, "zero", tuple(self.zero))

    @staticmethod
    def _check(values, n, shape, comps, what):
        if not values:
            raise InputError(f"scan {what}: no values")
        for d, v in values.items():
            if d not in AXES:
                raise InputError(f"scan {what}: direction {d!r} must be x, y or z")
            a = np.asarray(v)
            if a.shape != shape:
                raise InputError(f"scan {what} values.{d}: shape {a.shape}, expected {shape} ({n} scan points)")
            if not np.all(np.isfinite(a)):
                raise InputError(f"scan {what} values.{d}: NaN or infinite values")
        c = tuple(sorted(values))
        if comps is not None and c != comps:
            raise InputError(f"scan {what}: measured directions {', '.join(c)} differ from the others' ({', '.join(comps)})")
        return c

    @property
    def components(self) -> tuple[str, ...]:
        if self.modes:
            src = self.modes[0].values
        elif self.frf is not None:
            src = self.frf.values
        else:  # refused by __post_init__
            raise RuntimeError("internal error: a scan with neither modes nor FRFs")
        return tuple(sorted(src))
