r"""Exact sensitivities of complex eigenvalues and eigenvectors to stiffness, mass and damping
parameters.

With :math:`F(\lambda) = \lambda^2 M + \lambda C + K + iD` symmetric, the left eigenvector of a
mode is :math:`\varphi` itself (:math:`\psi^T F = 0` with :math:`\psi = \varphi`), and under the
normalisation :math:`\varphi^T(2\lambda M + C)\varphi = 1` of
:func:`~femupdate.damping.complex_modes`

.. math::  \frac{\partial\lambda}{\partial p_j} =
           -\varphi^T \Big(\lambda^2 \frac{\partial M}{\partial p_j}
           + \lambda \frac{\partial C}{\partial p_j} + \frac{\partial K}{\partial p_j}
           + i\frac{\partial D}{\partial p_j}\Big)\varphi

(the general form :math:`-\psi^T \partial F\, \varphi / \psi^T(2\lambda M + C)\varphi`).  The
eigenvector derivative solves the bordered system of the differentiated eigen-equation and
normalisation (the algebraic method of Lee, Kim & Jung, "Natural frequency and mode shape
sensitivities of damped systems: part I, distinct natural frequencies", J. Sound Vib. 223(3),
1999), non-singular for a distinct eigenvalue:

.. math::  \begin{bmatrix} F(\lambda) & (2\lambda M + C)\varphi \\
           2\varphi^T(2\lambda M + C) & 2\varphi^T M\varphi \end{bmatrix}
           \begin{bmatrix} \partial\varphi \\ \partial\lambda \end{bmatrix} =
           -\begin{bmatrix} \partial F\,\varphi \\
           \varphi^T(2\lambda\,\partial M + \partial C)\varphi \end{bmatrix}

One sparse LU per mode serves every parameter.  The bordered solve's :math:`\partial\lambda`
equals the adjoint formula's (a check in the tests).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from .._errors import InputError
from .complex_modes import ComplexModes
from .model import DampedModel


@dataclass(frozen=True, eq=False)
class ComplexSensitivities:
    r"""Derivatives of complex modes with respect to parameters.

    Attributes
    ----------
    parameters : tuple of str
    eigenvalues : numpy.ndarray of complex, shape ``(n_modes,)``
        The modes' λ (rad/s).
    d_eigenvalues : numpy.ndarray of complex, shape ``(n_modes, n_parameters)``
        :math:`\partial\lambda_r/\partial p_j`.
    d_shapes : numpy.ndarray of complex, shape ``(n_dofs, n_modes, n_parameters)`` or None
        :math:`\partial\varphi_r/\partial p_j` (normalisation kept), when asked for.
    """

    parameters: tuple
    eigenvalues: np.ndarray
    d_eigenvalues: np.ndarray
    d_shapes: np.ndarray | None = None

    @property
    def d_natural_frequencies(self) -> np.ndarray:
        r""":math:`\partial|\lambda_r|/\partial p_j` (rad/s per unit of p), ``(n_modes, n_parameters)``."""
        lam = self.eigenvalues[:, None]
        return (np.conj(lam) * self.d_eigenvalues).real / np.abs(lam)

    @property
    def d_damping_ratios(self) -> np.ndarray:
        r""":math:`\partial\zeta_r/\partial p_j` with :math:`\zeta = -\operatorname{Re}\lambda/|\lambda|`."""
        lam = self.eigenvalues[:, None]
        w = np.abs(lam)
        return -self.d_eigenvalues.real / w + lam.real * self.d_natural_frequencies / w ** 2


def complex_sensitivities(dm: DampedModel, modes: ComplexModes, values=None, parameters: Sequence[str] | None = None,
                          vectors: bool = False) -> ComplexSensitivities:
    """Exact derivatives of the complex eigenvalues (and shapes) of ``modes``.

    Parameters
    ----------
    dm : DampedModel
    modes : ComplexModes
        From :func:`~femupdate.damping.complex_modes` of ``dm`` at ``values`` (normalised there).
    values : None, mapping or array_like, optional
        The parameter values the modes were computed at (default nominal).
    parameters : sequence of str, optional
        Which (default: every parameter of ``dm``, model's then damping's).
    vectors : bool, default False
        Also the shape derivatives (one sparse LU of the bordered matrix per mode).

    Returns
    -------
    ComplexSensitivities

    Raises
    ------
    InputError
        An unknown parameter; modes of another model (sizes differ).

    Notes
    -----
    Modes solved in modal coordinates (modal damping ratios) are differentiated there
    (:func:`femupdate.damping.modal_ratios.modal_sensitivities`, exact for the truncated modal
    model, the real modes' derivatives by Nelson's method).
    """
    if modes.shapes.shape[0] != dm.n_dofs:
        raise InputError(f"complex sensitivities: the modes have {modes.shapes.shape[0]} dofs, the model {dm.n_dofs}")
    names = tuple(dm.parameter_names if parameters is None else parameters)
    p = dm.resolve(values)
    unknown = [nm for nm in names if nm not in dm.parameter_names]
    if unknown:
        raise InputError(f"parameter {unknown[0]!r} is not in damped model {dm.name!r} "
                         f"(its parameters: {', '.join(dm.parameter_names)})")
    if modes.modal:  # modal damping ratios: in the real modal coordinates (femupdate.damping.modal_ratios)
        from .modal_ratios import modal_sensitivities

        dl, dp = modal_sensitivities(dm, modes.eigenvalues, modes.shapes, p, names, vectors)
        return ComplexSensitivities(names, modes.eigenvalues.copy(), dl, dp)
    K, M, C = dm.K(p), dm.M(p), dm.C(p)
    Kc = (K + 1j * dm.D(p)) if dm.hysteretic else K
    ders = [dm.derivatives(name, p) for name in names]
    lam, Phi = modes.eigenvalues, modes.shapes
    m, P, n = lam.size, len(names), dm.n_dofs
    dlam = np.zeros((m, P), dtype=complex)
    dphi = np.zeros((n, m, P), dtype=complex)
    for r in range(m):
        v, phi = lam[r], Phi[:, r]
        dF = [v * v * dM + v * dC + dK + 1j * dD for dK, dM, dC, dD in ders]
        for j, A in enumerate(dF):
            dlam[r, j] = -(phi @ (A @ phi))
        if vectors:
            dphi[:, r, :], _ = _bordered(Kc, M, C, v, phi, dF, ders)
    return ComplexSensitivities(names, lam.copy(), dlam, dphi if vectors else None)


def _bordered(Kc, M, C, v, phi, dF, ders):
    """(∂φ, ∂λ) of one mode for every parameter from the bordered system."""
    F = sp.csc_array(v * v * M + v * C + Kc, dtype=complex)
    g = (2 * v * (M @ phi) + C @ phi)
    top = sp.hstack([F, sp.csc_array(g[:, None])])
    bottom = sp.hstack([sp.csc_array(2 * g[None, :]), sp.csc_array(np.array([[2 * (phi @ (M @ phi))]]))])
    lu = spla.splu(sp.csc_array(sp.vstack([top, bottom]), dtype=complex))
    rhs = np.column_stack([np.concatenate([-(A @ phi), [-(phi @ (2 * v * (dM @ phi) + dC @ phi))]])
                           for A, (_, dM, dC, _) in zip(dF, ders)])
    sol = lu.solve(rhs)
    return sol[:-1], sol[-1]


__all__ = ["ComplexSensitivities", "complex_sensitivities"]
