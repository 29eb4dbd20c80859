r"""The damping of the FRF model: proportional viscous (Rayleigh, :math:`C = \alpha M + \beta K`)
and structural (hysteretic, :math:`i\eta K`) damping, the coefficients of the dynamic stiffness
:math:`Z(\omega) = c_K K + c_M M` they give, their modal damping ratios, and the Rayleigh
damping fitted to measured ratios.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from .._errors import InputError


def nonnegative(value, what: str) -> float:
    """``value`` as a finite float >= 0, or an :class:`InputError` naming ``what``.

    Parameters
    ----------
    value : object
        Anything :class:`float` converts (a number, a numeric string, a size-1 array).
    what : str
        Its name in messages.

    Returns
    -------
    float
        ``float(value)``.

    Raises
    ------
    InputError
        ``value`` is not a number, or is negative, NaN or infinite.
    """
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise InputError(f"{what} must be a number, got {value!r}") from None
    if not (math.isfinite(v) and v >= 0):
        raise InputError(f"{what} = {v!r} must be finite and >= 0")
    return v


@dataclass(frozen=True)
class Damping:
    r"""Proportional viscous and structural damping of the FRF model.

    Attributes
    ----------
    alpha, beta : float
        Rayleigh coefficients of :math:`C = \alpha M + \beta K` (1/s and s), >= 0.
    eta : float
        Structural (hysteretic) loss factor: stiffness :math:`K(1 + i\eta)`, >= 0.

    The default is undamped (the paper's assumption): receptances are then real.
    """

    alpha: float = 0.0
    beta: float = 0.0
    eta: float = 0.0

    def __post_init__(self):
        for name in ("alpha", "beta", "eta"):
            object.__setattr__(self, name, nonnegative(getattr(self, name), f"damping {name}"))

    @property
    def undamped(self) -> bool:
        """True when alpha, beta and eta are all 0 (receptances are then real)."""
        return self.alpha == 0 and self.beta == 0 and self.eta == 0

    def coefficients(self, omega) -> tuple[np.ndarray, np.ndarray]:
        r"""``(c_K, c_M)`` per line: :math:`Z = c_K K + c_M M` (real when undamped).

        Parameters
        ----------
        omega : float or array_like of float, shape ``(n_lines,)``
            Circular frequencies ω (rad/s).

        Returns
        -------
        c_K : numpy.ndarray, shape of ``omega``
            :math:`1 + i\eta + i\omega\beta` (dimensionless); ones (float) when undamped.
        c_M : numpy.ndarray, shape of ``omega``
            :math:`i\omega\alpha - \omega^2` (rad²/s²); :math:`-\omega^2` (float) when undamped.
        """
        w = np.asarray(omega, float)
        if self.undamped:
            return np.ones_like(w), -(w**2)
        return 1.0 + 1j * self.eta + 1j * w * self.beta, 1j * w * self.alpha - w**2

    def as_dict(self) -> dict:
        """``{"alpha": ..., "beta": ..., "eta": ...}`` (the keys :func:`as_damping` takes)."""
        return {"alpha": self.alpha, "beta": self.beta, "eta": self.eta}

    def modal_damping_ratio(self, omega) -> np.ndarray:
        r"""The modal damping ratio of an undamped mode of circular frequency ω:
        :math:`\zeta = \alpha/(2\omega) + \beta\omega/2 + \eta/2` (Rayleigh damping is
        diagonal in the real modes; a loss factor η is the viscous ratio η/2 at resonance).

        Parameters
        ----------
        omega : float or array_like of float
            The modes' circular frequencies ω = √λ (rad/s), > 0 where ``alpha`` > 0.

        Returns
        -------
        numpy.ndarray
            ζ per mode (infinite at ω = 0 when ``alpha`` > 0).
        """
        w = np.asarray(omega, float)
        with np.errstate(divide="ignore"):
            mass_term = np.where(w > 0, self.alpha / (2 * np.where(w > 0, w, 1.0)), np.inf if self.alpha else 0.0)
        return mass_term + self.beta * w / 2 + self.eta / 2

    @classmethod
    def rayleigh_fit(cls, omega, zeta, std=None) -> tuple[Damping, np.ndarray]:
        r"""The Rayleigh damping that best fits measured modal damping ratios: α, β ≥ 0
        minimising :math:`\sum_r ((\alpha/(2\omega_r) + \beta\omega_r/2 - \zeta_r)/\sigma_r)^2`
        (non-negative least squares).

        Parameters
        ----------
        omega : array_like of float, shape ``(n,)``
            Circular frequencies of the measured modes (rad/s), > 0.
        zeta : array_like of float, shape ``(n,)``
            Their measured damping ratios.
        std : array_like of float, shape ``(n,)``, optional
            Standard deviations of the ratios (default: equal weights).

        Returns
        -------
        damping : Damping
            α and β (η = 0).
        residual : numpy.ndarray, shape ``(n,)``
            The fitted ratio minus the measured one, per mode.

        Raises
        ------
        InputError
            Fewer than one mode, a frequency that is not > 0, or sizes that differ.
        """
        from scipy.optimize import nnls

        w = np.asarray(omega, float).ravel()
        z = np.asarray(zeta, float).ravel()
        if w.size == 0 or w.shape != z.shape or not np.all(w > 0) or not np.all(np.isfinite(z)):
            raise InputError("Rayleigh fit: needs at least one mode with a frequency > 0 and a finite damping ratio")
        s = np.ones_like(z) if std is None else np.asarray(std, float).ravel()
        A = np.column_stack([1 / (2 * w), w / 2]) / s[:, None]
        x, _ = nnls(A, z / s)
        fit = cls(alpha=float(x[0]), beta=float(x[1]))
        return fit, fit.modal_damping_ratio(w) - z


UNDAMPED = Damping()


def as_damping(damping) -> Damping:
    """``None`` (undamped), a :class:`Damping`, or a mapping {alpha, beta, eta}.

    Parameters
    ----------
    damping : None, Damping or mapping of str to float
        A mapping may give any of ``alpha`` (1/s), ``beta`` (s) and ``eta``; the others are 0.

    Returns
    -------
    Damping
        :data:`UNDAMPED` for None, ``damping`` itself for a :class:`Damping`.

    Raises
    ------
    InputError
        An unknown key; a value that is not a finite number >= 0; any other type.
    """
    if damping is None:
        return UNDAMPED
    if isinstance(damping, Damping):
        return damping
    if isinstance(damping, Mapping):
        unknown = sorted(set(damping) - {"alpha", "beta", "eta"})
        if unknown:
            raise InputError(f"damping: unknown key(s) {', '.join(unknown)} (use alpha, beta, eta)")
        return Damping(**damping)
    raise InputError(f"damping must be a Damping or a mapping {{alpha, beta, eta}}, got {damping!r}")


__all__ = ["Damping", "UNDAMPED", "as_damping", "nonnegative"]
