r"""Modal damping ratios: complex modes, receptances and their exact derivatives in the real modal
coordinates of the first m undamped modes.

With :math:`\Phi` (n × m) the first m mass-normalised real modes of (K(p), M(p)) and
:math:`\omega_r` their frequencies, the model in modal coordinates q (:math:`u = \Phi q`) is

.. math::  \tilde M = I, \qquad \tilde K = \operatorname{diag}(\omega_r^2) + i\Phi^T D\Phi,
           \qquad \tilde C = \Phi^T C\Phi + \operatorname{diag}(2\zeta_r\omega_r)

(the modal ratios ζ_r form no physical C).  Complex modes: :math:`(\lambda^2 I + \lambda\tilde C
+ \tilde K) q = 0`, :math:`\varphi = \Phi q`, :math:`q^T(2\lambda I + \tilde C) q = 1`.
Receptances by modal superposition of those m modes:
:math:`x_S = \Phi_S \tilde Z^{-1}\Phi^T f`, :math:`\tilde Z = \tilde K - \omega^2 I + i\omega\tilde C`
(the modes above the m-th are left out: no residual flexibility).

Derivatives, exact for the truncated modal model.  With :math:`\Phi' = \partial\Phi/\partial p_j`
by Nelson's method (:func:`femupdate.sensitivity.nelson`; zero for a damping parameter) and
:math:`\partial(\omega_r^2) = \varphi_r^T(K' - \omega_r^2 M')\varphi_r`, the mass normalisation
keeps :math:`\tilde M = I`, and

.. math::  \partial\tilde K = \operatorname{diag}(\partial\omega_r^2)
           + i(\Phi'^T D\Phi + \Phi^T D'\Phi + \Phi^T D\Phi'), \\
           \partial\tilde C = \Phi'^T C\Phi + \Phi^T C'\Phi + \Phi^T C\Phi'
           + \operatorname{diag}(2\,\partial\zeta_r\,\omega_r + 2\zeta_r\,\partial\omega_r)

(:math:`\partial\zeta_r/\partial z = 1` for the modes whose ratio is the parameter z).  The
complex eigenvalue and q derivatives come from the bordered system of
:mod:`femupdate.damping.sensitivity` in modal coordinates (:math:`\tilde M = I`,
:math:`\partial\tilde M = 0`), :math:`\partial\varphi = \Phi' q + \Phi\,\partial q`; the
receptances' from :math:`\partial x_S = \Phi'_S\tilde x + \Phi_S\tilde Z^{-1}(\Phi'^T f -
\partial\tilde Z\,\tilde x)`, :math:`\partial\tilde Z = \partial\tilde K + i\omega\,\partial\tilde C`.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import scipy.linalg as la

from .._errors import InputError, NumericalError
from .model import DampedModel


def modal_system(dm: DampedModel, p: np.ndarray, names: Sequence[str] | None = None) -> dict:
    """The modal-coordinate matrices of ``dm`` at the full parameter vector ``p``, and with
    ``names`` their derivatives.

    Returns
    -------
    dict
        ``Phi`` (n, m), ``w`` (m,), ``Kt``, ``Ct`` (m, m); with ``names``: ``dPhi`` (n, m, P),
        ``dKt``, ``dCt`` (P, m, m).
    """
    from ..modal import solve_modes

    m = len(dm.modal)
    if m > dm.n_dofs:
        raise InputError(f"damped model {dm.name!r}: {m} modal damping ratios but only {dm.n_dofs} dofs")
    K, M, C = dm.K(p), dm.M(p), dm.C(p)
    D = dm.D(p) if dm.hysteretic else None
    real = solve_modes(K, M, n_modes=m, dofs=dm.dofs)
    Phi = real.shapes
    w = np.sqrt(np.maximum(real.eigenvalues, 0.0))
    zeta = dm.modal_ratios(p)
    Kt = np.diag(w ** 2).astype(complex if D is not None else float)
    if D is not None:
        Kt = Kt + 1j * (Phi.T @ (D @ Phi))
    Ct = Phi.T @ (C @ Phi) + np.diag(2 * zeta * w)
    out = {"Phi": Phi, "w": w, "Kt": Kt, "Ct": Ct, "real": real}
    if names is None:
        return out
    P, n = len(names), dm.n_dofs
    dPhi = np.zeros((n, m, P))
    dlam2 = np.zeros((m, P))
    own = [j for j, nm in enumerate(names) if nm in dm.model.parameter_names]
    if own:
        from ..sensitivity.nelson import nelson

        m_p = len(dm.model.parameters)
        dl, dp = nelson(dm.model, real, params=[names[j] for j in own], values=p[:m_p])
        dlam2[:, own], dPhi[:, :, own] = dl, dp
    dKt = np.zeros((P, m, m), dtype=Kt.dtype)
    dCt = np.zeros((P, m, m))
    for j, name in enumerate(names):
        _, _, dC, dD = dm.derivatives(name, p)
        dw = np.divide(dlam2[:, j], 2 * w, out=np.zeros(m), where=w > 0)
        F = dPhi[:, :, j]
        dKt[j] = np.diag(dlam2[:, j])
        if D is not None:
            dKt[j] = dKt[j] + 1j * (F.T @ (D @ Phi) + Phi.T @ (dD @ Phi) + Phi.T @ (D @ F))
        dCt[j] = (F.T @ (C @ Phi) + Phi.T @ (dC @ Phi) + Phi.T @ (C @ F)
                  + np.diag(2 * dm.ratio_indicator(name) * w + 2 * zeta * dw))
    out.update(dPhi=dPhi, dKt=dKt, dCt=dCt)
    return out


def modal_modes(dm: DampedModel, p: np.ndarray, n_modes, select, normalise):
    """The complex modes of ``dm`` in modal coordinates: ``(lam, Phi @ Q, Q, n_rigid, n_over, m)``
    (``select`` and ``normalise`` those of :mod:`femupdate.damping.complex_modes`)."""
    sysm = modal_system(dm, p)
    m = len(dm.modal)
    w, Kt, Ct = sysm["w"], sysm["Kt"], sysm["Ct"]
    scale = float(np.max(w)) if np.any(w > 0) else 1.0
    A = np.block([[np.zeros((m, m)), scale * np.eye(m)], [-Kt / scale, -Ct]])
    lam, Z = la.eig(A)
    lam, Q, n_rigid, n_over = select(dm, lam, Z[:m], scale, n_modes)
    Q = normalise(Q, lam, np.eye(m), Ct)
    return lam, sysm["Phi"] @ Q, n_rigid, n_over, m


def modal_sensitivities(dm: DampedModel, lam: np.ndarray, Phi_c: np.ndarray, p: np.ndarray, names: Sequence[str],
                        vectors: bool) -> tuple[np.ndarray, np.ndarray | None]:
    """(∂λ (m_c, P), ∂φ (n, m_c, P) or None) of complex modes ``lam``, ``Phi_c`` solved in modal
    coordinates (module docstring)."""
    sysm = modal_system(dm, p, names)
    Phi, Kt, Ct, dPhi, dKt, dCt = (sysm[k] for k in ("Phi", "Kt", "Ct", "dPhi", "dKt", "dCt"))
    m = Phi.shape[1]
    Q = np.linalg.lstsq(Phi, Phi_c, rcond=None)[0]  # Φ is M-orthonormal: q = Φᵀ M φ, here by least squares
    P = len(names)
    dlam = np.zeros((lam.size, P), dtype=complex)
    dphi = np.zeros((dm.n_dofs, lam.size, P), dtype=complex) if vectors else None
    eye = np.eye(m)
    for r, v in enumerate(lam):
        q = Q[:, r]
        dF = [v * dCt[j] + dKt[j] for j in range(P)]
        for j in range(P):
            dlam[r, j] = -(q @ (dF[j] @ q))
        if dphi is None:
            continue
        F = v * v * eye + v * Ct + Kt
        g = 2 * v * q + Ct @ q
        A = np.block([[F, g[:, None]], [2 * g[None, :], np.array([[2 * (q @ q)]])]])
        rhs = np.column_stack([np.concatenate([-(dF[j] @ q), [-(q @ (dCt[j] @ q))]]) for j in range(P)])
        try:
            sol = np.linalg.solve(A, rhs)
        except np.linalg.LinAlgError:
            raise NumericalError(f"complex mode {r + 1} (eigenvalue {v:.6g}): the bordered system is singular "
                                 "(a repeated eigenvalue)") from None
        dphi[:, r, :] = np.einsum("nmj,m->nj", dPhi, q) + Phi @ sol[:-1]
    return dlam, dphi


def modal_response(dm: DampedModel, omega: np.ndarray, f: np.ndarray, S: np.ndarray, p: np.ndarray,
                   names: Sequence[str] | None) -> tuple[np.ndarray, np.ndarray | None]:
    """Receptances x_S (n_l, n_s) by modal superposition of the first ``len(modal)`` modes, and
    with ``names`` their exact derivatives (n_l, n_s, P) (module docstring)."""
    sysm = modal_system(dm, p, names)
    Phi, Kt, Ct = sysm["Phi"], sysm["Kt"], sysm["Ct"]
    m = Phi.shape[1]
    ft = Phi.T @ f
    PhiS = Phi[S]
    x = np.zeros((omega.size, S.size), dtype=complex)
    dx = np.zeros((omega.size, S.size, len(names)), dtype=complex) if names is not None else None
    for i, om in enumerate(omega):
        Z = Kt - om * om * np.eye(m) + 1j * om * Ct
        try:
            lu = la.lu_factor(Z)
        except (ValueError, la.LinAlgError):
            raise NumericalError(f"the modal dynamic stiffness is singular at {om:.6g} rad/s (an undamped resonance)") \
                from None
        xt = la.lu_solve(lu, ft)
        if not np.all(np.isfinite(xt)):
            raise NumericalError(f"the modal dynamic stiffness is singular at {om:.6g} rad/s (an undamped resonance)")
        x[i] = PhiS @ xt
        if dx is None or names is None:
            continue
        for j in range(len(names)):
            F = sysm["dPhi"][:, :, j]
            dZ = sysm["dKt"][j] + 1j * om * sysm["dCt"][j]
            dx[i, :, j] = F[S] @ xt + PhiS @ la.lu_solve(lu, F.T @ f - dZ @ xt)
    return x, dx


__all__ = ["modal_system", "modal_modes", "modal_sensitivities", "modal_response"]
