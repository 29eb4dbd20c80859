r"""Target modes of a test plan: the modes the test must see.

* ``"mass"`` — by effective modal mass along an influence vector r (a base excitation direction):
  with mass-normalised modes the participation factor is :math:`\Gamma_i = \phi_i^T M r`, the
  effective mass :math:`m_i = \Gamma_i^2`, and its fraction :math:`m_i / r^T M r` (the fractions
  of all modes add up to 1).  The modes in the band whose fraction reaches ``min_fraction``.
* ``"energy"`` — by kinetic energy: the modes in the band whose kinetic energy at the candidate
  dofs, :math:`\sum_{c} \phi_{ci} (M\phi_i)_c` (a fraction of :math:`\phi_i^T M \phi_i = 1`),
  reaches ``min_fraction`` — a mode that moves only where no sensor can go cannot be measured.
* ``"lowest"`` — the lowest ``n_modes`` modes (in the band).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from .._errors import InputError
from ..dofs import parse_dof

METHODS = ("lowest", "mass", "energy")


@dataclass(frozen=True, eq=False)
class TargetModes:
    """The chosen target modes (:func:`target_modes`).

    Each parameter is stored as the attribute of the same name.

    Parameters
    ----------
    indices : tuple of int
        0-based indices of the target modes among the model's modes, ascending.
    frequencies_hz : numpy.ndarray
        Their natural frequencies.
    method : str
        How they were chosen (:data:`METHODS`).
    fractions : numpy.ndarray
        Per target mode its effective-mass fraction (``"mass"``) or kinetic-energy fraction at the
        candidates (``"energy"``); empty for ``"lowest"``.
    total_fraction : float
        ``"mass"``: the effective-mass fraction the target modes carry together; NaN otherwise.
    """

    indices: tuple[int, ...]
    frequencies_hz: np.ndarray
    method: str
    fractions: np.ndarray
    total_fraction: float = float("nan")

    def to_dict(self) -> dict:
        return {"indices": list(self.indices), "modes": [i + 1 for i in self.indices],
                "frequencies_hz": self.frequencies_hz, "method": self.method, "fractions": self.fractions,
                "total_fraction": self.total_fraction}


def influence_vector(model, direction: str | Sequence[float]) -> np.ndarray:
    """The influence vector r of a rigid translation: 1 at every dof of ``direction`` (``"x"``,
    ``"y"`` or ``"z"``), or an array given over the model's dofs."""
    if isinstance(direction, str):
        d = direction.strip().lower()
        if d not in ("x", "y", "z"):
            raise InputError(f"direction must be x, y or z (or a vector over the dofs), got {direction!r}")
        r = np.array([1.0 if parse_dof(lab)[1] == d else 0.0 for lab in model.dofs])
        if not r.any():
            raise InputError(f"direction {d}: the model {model.name!r} has no dof in {d}")
        return r
    r = np.asarray(direction, dtype=float)
    if r.shape != (model.n_dofs,) or not np.all(np.isfinite(r)) or not r.any():
        raise InputError(f"direction: an influence vector needs {model.n_dofs} finite values, not all zero")
    return r


def effective_mass_fractions(model, modes, r: np.ndarray, values=None) -> np.ndarray:
    r"""Effective modal mass fractions :math:`(\phi_i^T M r)^2 / r^T M r` of mass-normalised modes."""
    M = model.M(values)
    Mr = M @ r
    return (modes.shapes.T @ Mr) ** 2 / float(r @ Mr)


def target_modes(model, modes, *, method: str = "lowest", n_modes: int | None = None,
                 band_hz: tuple[float, float] | None = None, direction=None, min_fraction: float = 0.01,
                 candidate_dofs: Sequence[str] | None = None, values=None) -> TargetModes:
    """Choose the target modes among ``modes`` (mass-normalised modes of ``model``).

    Parameters
    ----------
    model : Model
    modes : Modes
        Mass-normalised modes at ``values``.
    method : {"lowest", "mass", "energy"}, default "lowest"
        Module docstring.
    n_modes : int, optional
        ``"lowest"``: how many (required); ``"mass"``/``"energy"``: at most this many, the largest
        fractions kept.
    band_hz : (float, float), optional
        Only modes with ``lo <= f <= hi`` (default all computed).
    direction : str or array_like, optional
        ``"mass"``: the influence vector (:func:`influence_vector`; required).
    min_fraction : float, default 0.01
        ``"mass"``/``"energy"``: the smallest fraction of a target mode.
    candidate_dofs : sequence of str, optional
        ``"energy"``: the dofs where sensors may go (default every dof).
    values : optional
        Parameter values of ``modes``.

    Returns
    -------
    TargetModes

    Raises
    ------
    InputError
        An unknown method; a band with ``lo >= hi``; ``"lowest"`` without ``n_modes``; ``"mass"``
        without ``direction``; no mode qualifies (said with the largest fraction found).
    """
    if method not in METHODS:
        raise InputError(f"unknown target-mode method {method!r}: use {', '.join(METHODS)}")
    f = modes.frequencies_hz
    inband = np.ones(f.size, dtype=bool)
    if band_hz is not None:
        lo, hi = (float(v) for v in band_hz)
        if not lo < hi:
            raise InputError(f"band: the lower frequency {lo:g} Hz must be below the upper {hi:g} Hz")
        inband = (f >= lo) & (f <= hi)
        if not inband.any():
            raise InputError(f"band {lo:g}-{hi:g} Hz: no mode of the model there (computed: "
                             f"{', '.join(f'{v:.4g}' for v in f[:8])} Hz)")
    idx = np.flatnonzero(inband)
    if method == "lowest":
        if n_modes is None:
            raise InputError("target modes: give the number of modes (n_modes), a band, or a method by mass or energy")
        if n_modes > idx.size:
            raise InputError(f"target modes: {n_modes} asked, {idx.size} computed in the band")
        chosen = idx[:n_modes]
        return TargetModes(tuple(int(i) for i in chosen), f[chosen], method, np.zeros(0))
    if method == "mass":
        if direction is None:
            raise InputError("target modes by effective mass need a direction (influence vector), e.g. x")
        frac = effective_mass_fractions(model, modes, influence_vector(model, direction), values)
    else:
        dofs = list(candidate_dofs) if candidate_dofs is not None else list(model.dofs)
        rows = model.dof_index(dofs, "candidates")
        MPhi = model.M(values) @ modes.shapes
        frac = np.sum(modes.shapes[rows] * MPhi[rows], axis=0)
    ok = idx[frac[idx] >= min_fraction]
    if ok.size == 0:
        best = int(idx[np.argmax(frac[idx])])
        raise InputError(f"target modes by {method}: no mode in the band reaches the fraction {min_fraction:g} "
                         f"(largest: mode {best + 1}, {frac[best]:.3g})")
    if n_modes is not None and ok.size > n_modes:
        ok = np.sort(ok[np.argsort(-frac[ok], kind="stable")[:n_modes]])
    total = float(frac[ok].sum()) if method == "mass" else float("nan")
    return TargetModes(tuple(int(i) for i in ok), f[ok], method, frac[ok], total)


__all__ = ["TargetModes", "target_modes", "influence_vector", "effective_mass_fractions", "METHODS"]
