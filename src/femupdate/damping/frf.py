r"""Receptances of a damped model and their exact derivatives with respect to stiffness, mass
and damping parameters.

.. math::  Z(\omega) = K + iD - \omega^2 M + i\omega C, \qquad x(\omega) = Z(\omega)^{-1} f,
           \qquad H(\omega) = Z(\omega)^{-1}

.. math::  \frac{\partial H}{\partial p_j} = -H\,\frac{\partial Z}{\partial p_j}\,H,
           \qquad \frac{\partial Z}{\partial p_j} = \frac{\partial K}{\partial p_j}
           + i\frac{\partial D}{\partial p_j} - \omega^2 \frac{\partial M}{\partial p_j}
           + i\omega \frac{\partial C}{\partial p_j}

For the response to a force f at the measured dofs S (Z is complex symmetric, so
:math:`H^T = H`): :math:`\partial x_S/\partial p_j = -Y_S^T\,\partial Z_j\,x` with
:math:`Y_S = Z^{-1} I_{:,S}` — Brandon's expression (the reference paper's eq. 32) with the
damping terms; one sparse LU of Z per line serves every parameter.  The derivatives of K, M, C
and D are exact (:meth:`~femupdate.damping.DampedModel.derivatives`), so are these; the tests
check them against finite differences.

A model with modal damping ratios (:class:`DampedModel` ``modal``) has its receptances by modal
superposition of its first ``len(modal)`` real modes, where those ratios act
(:func:`femupdate.damping.modal_ratios.modal_response`): the modes above are left out.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from .._errors import InputError, NumericalError
from .model import DampedModel


def force_of(dm: DampedModel, force) -> np.ndarray:
    """The force vector of ``force``: a mapping {dof label: amplitude} or one value per dof."""
    n = dm.n_dofs
    if isinstance(force, Mapping):
        f = np.zeros(n, dtype=complex)
        idx = dm.model.dof_index(list(force), "frf force")
        for i, v in zip(idx, force.values()):
            f[i] = complex(v)
        return f
    f = np.asarray(force, dtype=complex).ravel()
    if f.size != n:
        raise InputError(f"damped receptance: the force vector has {f.size} entries, the model {n} dofs")
    return f


def damped_response(dm: DampedModel, omega, force, dofs: Sequence[str], values=None,
                    parameters: Sequence[str] | None = None) -> tuple[np.ndarray, np.ndarray | None]:
    r"""Responses :math:`x_S(\omega) = [Z(\omega)^{-1} f]_S` of a damped model and, when
    ``parameters`` are given, their exact derivatives.

    Parameters
    ----------
    dm : DampedModel
    omega : array_like of float, shape ``(n_l,)``
        Lines (rad/s).
    force : mapping of str to complex, or array_like of shape ``(n_dofs,)``
        The force (N) at dofs.
    dofs : sequence of str
        The response dofs S.
    values : None, mapping or array_like, optional
        Parameter values (:meth:`DampedModel.resolve`).
    parameters : sequence of str, optional
        Names (model's or damping's) to differentiate with respect to.

    Returns
    -------
    x : numpy.ndarray of complex, shape ``(n_l, n_s)``
        The responses (m for N).
    dx : numpy.ndarray of complex, shape ``(n_l, n_s, n_parameters)``, or None
        :math:`\partial x_S/\partial p_j`.

    Raises
    ------
    NumericalError
        A line where Z is singular (an undamped resonance).
    """
    w = np.asarray(omega, dtype=float).ravel()
    p = dm.resolve(values)
    K, M, C = dm.K(p), dm.M(p), dm.C(p)
    Kc = K + 1j * dm.D(p) if dm.hysteretic else K
    f = force_of(dm, force)
    S = dm.model.dof_index(list(dofs), "frf response")
    n = dm.n_dofs
    B = np.zeros((n, 1 + S.size), dtype=complex)
    B[:, 0] = f
    B[S, 1 + np.arange(S.size)] = 1.0
    if dm.modal:  # modal damping ratios: modal superposition of the first len(modal) modes
        from .modal_ratios import modal_response

        return modal_response(dm, w, f, S, p, None if parameters is None else list(parameters))
    ders = [dm.derivatives(name, p) for name in parameters] if parameters is not None else None
    x = np.zeros((w.size, S.size), dtype=complex)
    dx = np.zeros((w.size, S.size, len(ders)), dtype=complex) if ders is not None else None
    for i, om in enumerate(w):
        Z = sp.csc_array(Kc - om * om * M + 1j * om * C, dtype=complex)
        try:
            X = spla.splu(Z).solve(B)
        except RuntimeError:
            raise NumericalError(f"the dynamic stiffness is singular at {om:.6g} rad/s (an undamped resonance)") from None
        if not np.all(np.isfinite(X)):
            raise NumericalError(f"the dynamic stiffness is singular at {om:.6g} rad/s (an undamped resonance)")
        u, Y = X[:, 0], X[:, 1:]
        x[i] = u[S]
        if dx is not None and ders is not None:
            for j, (dK, dM, dC, dD) in enumerate(ders):
                dZu = dK @ u + 1j * (dD @ u) - om * om * (dM @ u) + 1j * om * (dC @ u)
                dx[i, :, j] = -(Y.T @ dZu)
    return x, dx


__all__ = ["damped_response", "force_of"]
