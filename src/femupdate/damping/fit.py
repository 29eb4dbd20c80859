r"""Damping (and other) parameters from measured complex eigenvalues: a small least-squares update.

The residual of mode r is the relative misfit of its complex eigenvalue, split into real and
imaginary parts,

.. math::  r_r = \frac{\lambda_r(p) - \lambda_r^{test}}{|\lambda_r^{test}|}
           \quad\Rightarrow\quad
           \operatorname{Re} r_r \approx \zeta_r^{test} - \zeta_r(p), \quad
           \operatorname{Im} r_r \approx \omega_{d,r}(p)/|\lambda^{test}_r| - \sqrt{1 - \zeta_r^2}

so it weighs the damping ratio and the frequency of each mode alike.  Model mode r is paired
with test mode r (the lowest modes, in order of :math:`|\lambda|`).  The Jacobian is exact
(:func:`~femupdate.damping.complex_sensitivities`); the solver is SciPy's bounded trust-region
least squares (:func:`scipy.optimize.least_squares`, ``method="trf"``) within each parameter's
bounds (damping parameters >= 0).

This is a self-contained route for this first slice: the general updating engine
(:mod:`femupdate.updating`) works on a :class:`~femupdate.Model`, whose parameters do not yet
include damping.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from .._errors import InputError, NumericalError
from .complex_modes import complex_modes
from .model import DampedModel, check_ratio
from .sensitivity import complex_sensitivities


def target_eigenvalues(frequencies_hz, damping_ratios) -> np.ndarray:
    r"""Complex eigenvalues :math:`\lambda = -\zeta\omega + i\omega\sqrt{1 - \zeta^2}` of
    measured modes, ω the undamped natural frequency (rad/s).

    Parameters
    ----------
    frequencies_hz : array_like of float, shape ``(n,)``
        Undamped natural frequencies :math:`\omega/2\pi` (Hz), > 0.
    damping_ratios : array_like of float, shape ``(n,)``
        Fractions of critical damping in [0, 1) (a value above 1 is refused as a percentage).

    Returns
    -------
    numpy.ndarray of complex, shape ``(n,)``
    """
    f = np.asarray(frequencies_hz, dtype=float).ravel()
    z = np.asarray(damping_ratios, dtype=float).ravel()
    if f.shape != z.shape or f.size == 0:
        raise InputError(f"target eigenvalues: {f.size} frequencies but {z.size} damping ratios")
    if not np.all(np.isfinite(f) & (f > 0)):
        raise InputError("target eigenvalues: frequencies must be finite and > 0 Hz")
    zs = np.array([check_ratio(float(v), f"damping ratio of test mode {r + 1}") for r, v in enumerate(z)])
    w = 2 * np.pi * f
    return -zs * w + 1j * w * np.sqrt(1 - zs ** 2)


@dataclass(frozen=True, eq=False)
class DampingFit:
    """The result of :func:`fit_damping`.

    Attributes
    ----------
    parameters : tuple of str
        The updated parameters.
    values : dict of str to float
        Their values at the solution.
    model : DampedModel
        The damped model with those values.
    eigenvalues : numpy.ndarray of complex
        The model's eigenvalues at the solution (paired with the targets in order).
    residual : numpy.ndarray of float, shape ``(2 n_modes,)``
        Real and imaginary parts of the relative eigenvalue misfits.
    cost : float
        Half the sum of squared residuals.
    nfev : int
    success : bool
    message : str
    covariance : numpy.ndarray or None
        With standard deviations given: :math:`(J^T J)^{-1}` of the standardised residuals at the
        solution, in the parameters' units, shape ``(n_parameters, n_parameters)``; else None.
    """

    parameters: tuple
    values: dict
    model: DampedModel
    eigenvalues: np.ndarray
    residual: np.ndarray
    cost: float
    nfev: int
    success: bool
    message: str
    covariance: np.ndarray | None = None

    @property
    def std(self) -> dict | None:
        """Standard deviations of the parameters (from :attr:`covariance`), or None."""
        if self.covariance is None:
            return None
        return dict(zip(self.parameters, np.sqrt(np.diag(self.covariance)).tolist()))


def _std(std, n: int, what: str) -> np.ndarray:
    s = np.broadcast_to(np.asarray(std, dtype=float), (n,)) if np.ndim(std) == 0 else np.asarray(std, float).ravel()
    if s.shape != (n,) or not np.all(np.isfinite(s) & (s > 0)):
        raise InputError(f"fit_damping: {what} must be one positive number or one per target mode ({n}), got {std!r}")
    return s


def fit_damping(dm: DampedModel, target, parameters: Sequence[str], x0=None, xtol: float = 1e-12,
                std_damping_ratio=None, std_frequency=None) -> DampingFit:
    """Update ``parameters`` of ``dm`` so that its lowest complex eigenvalues match ``target``.

    Parameters
    ----------
    dm : DampedModel
        The starting model (its nominal values; the others stay fixed).
    target : array_like of complex, shape ``(n_modes,)``
        Measured eigenvalues with Im > 0 (:func:`target_eigenvalues` builds them from
        frequencies and damping ratios), in ascending :math:`|\\lambda|`.
    parameters : sequence of str
        Names of the updated parameters (model's or damping's), at most ``2 n_modes``.
    x0 : array_like of float, optional
        Starting values of ``parameters`` (default: their nominal values).
    xtol : float, default 1e-12
        Step tolerance of the least-squares solver.
    std_damping_ratio, std_frequency : float or array_like of shape ``(n_modes,)``, optional
        Standard deviations of the measured damping ratios (absolute) and frequencies (relative,
        σ_f/f), both or neither: the real and imaginary parts of each residual are divided by
        them (to first order they are the damping-ratio error and the relative frequency error),
        and the result carries the parameters' covariance.

    Returns
    -------
    DampingFit

    Raises
    ------
    InputError
        Unknown parameters; more unknowns than data; a target with Im <= 0 or not finite; one
        standard deviation given without the other, or not positive.
    NumericalError
        With standard deviations: a Jacobian singular at the solution (no covariance).
    """
    lam_t = np.asarray(target, dtype=complex).ravel()
    if lam_t.size == 0 or not np.all(np.isfinite(lam_t)) or np.any(lam_t.imag <= 0):
        raise InputError("fit_damping: target eigenvalues must be finite with a positive imaginary part "
                         "(one per underdamped mode)")
    names = tuple(parameters)
    all_names = dm.parameter_names
    unknown = [x for x in names if x not in all_names]
    if unknown or not names or len(set(names)) != len(names):
        raise InputError(f"fit_damping: parameters {list(names)} must be distinct names of "
                         f"{', '.join(all_names)}")
    if len(names) > 2 * lam_t.size:
        raise InputError(f"fit_damping: {len(names)} unknowns from {lam_t.size} complex eigenvalues "
                         f"({2 * lam_t.size} real data): the problem is underdetermined")
    idx = [all_names.index(x) for x in names]
    p0 = dm.resolve(None)
    if x0 is not None:
        p0[idx] = np.asarray(x0, dtype=float)
    lo = np.array([dm.all_parameters[j].bounds[0] for j in idx])
    hi = np.array([dm.all_parameters[j].bounds[1] for j in idx])
    scale = np.abs(lam_t)
    if (std_damping_ratio is None) != (std_frequency is None):
        raise InputError("fit_damping: give std_damping_ratio and std_frequency together (or neither)")
    if std_damping_ratio is None:
        w_re = w_im = np.ones(lam_t.size)
    else:
        w_re = 1 / _std(std_damping_ratio, lam_t.size, "std_damping_ratio")
        w_im = 1 / _std(std_frequency, lam_t.size, "std_frequency")
    cache: dict = {}

    def evaluate(x):
        key = x.tobytes()
        if key not in cache:
            p = p0.copy()
            p[idx] = x
            modes = complex_modes(dm, n_modes=lam_t.size, values=p)
            cache.clear()
            cache[key] = (p, modes)
        return cache[key]

    def fun(x):
        _, modes = evaluate(x)
        r = (modes.eigenvalues - lam_t) / scale
        return np.concatenate([w_re * r.real, w_im * r.imag])

    def jac(x):
        p, modes = evaluate(x)
        S = complex_sensitivities(dm, modes, p, names).d_eigenvalues / scale[:, None]
        return np.vstack([w_re[:, None] * S.real, w_im[:, None] * S.imag])

    from scipy.optimize import least_squares

    x_start = np.clip(p0[idx], lo, hi)
    sol = least_squares(fun, x_start, jac=jac, bounds=(lo, hi), method="trf", xtol=xtol, ftol=1e-15, gtol=1e-15,
                        x_scale=np.where(x_start != 0, np.abs(x_start), 1.0))
    p = p0.copy()
    p[idx] = sol.x
    final = complex_modes(dm, n_modes=lam_t.size, values=p)
    cov = None
    if std_damping_ratio is not None:
        J = jac(sol.x)
        d = np.linalg.norm(J, axis=0)  # column scaling: the parameters' units differ by decades
        d[d == 0] = 1.0
        _, sv, vt = np.linalg.svd(J / d, full_matrices=False)
        if sv[-1] <= 1e-12 * sv[0]:
            raise NumericalError(f"fit_damping: the parameters {', '.join(names)} are not identifiable from these "
                                 f"{lam_t.size} modes (singular Jacobian at the solution): no covariance")
        cov = (vt.T / sv ** 2) @ vt / np.outer(d, d)
    return DampingFit(names, dict(zip(names, sol.x.tolist())), dm.with_values(p), final.eigenvalues, sol.fun,
                      float(sol.cost), int(sol.nfev), bool(sol.success), str(sol.message), cov)


__all__ = ["DampingFit", "fit_damping", "target_eigenvalues"]
