"""Derivatives of mode shapes in the scaling in which they are compared with test data.

Test shapes carry no absolute scale.  The residuals of the paper's eq. 33 compare shapes scaled
to 1 at a reference dof ("the amplitude of the first freedom being one"); others use unit length
or unit largest entry over the measured dofs.  Given the components φ_s of a mass-normalised
mode at the measured dofs and their derivatives φ_s', these functions return the scaled shape
ψ = φ_s / s(φ_s) and its derivative ψ' = φ_s'/s − ψ s'/s.
"""

from __future__ import annotations

import numpy as np

from .._errors import InputError, NumericalError


def scaled_shape(phi_s: np.ndarray, dphi_s: np.ndarray | None, how: str, ref: int | None = None):
    """Scaled measured shape and its derivative.

    Parameters
    ----------
    phi_s : array_like, shape ``(n_s,)``
        Mass-normalised mode at the measured dofs.
    dphi_s : array_like, shape ``(n_s, L)``, or None
        Its derivatives with respect to the L parameters.
    how : {"ref", "max", "unit", "mass"}
        ``"ref"`` (1 at position ``ref`` of the measured dofs), ``"max"`` (1 at the
        largest-magnitude measured component), ``"unit"`` (unit length, sign so that the
        largest component is positive) or ``"mass"`` (unchanged).
    ref : int, optional
        0-based position among the measured dofs of the reference (needed by ``"ref"``).

    Returns
    -------
    psi : numpy.ndarray, shape ``(n_s,)``
        The scaled shape.
    dpsi : numpy.ndarray, shape ``(n_s, L)``, or None
        Its derivatives (None when ``dphi_s`` is None).

    Raises
    ------
    InputError
        An unknown ``how``, or ``"ref"`` without ``ref``.
    NumericalError
        The shape is (nearly) zero at the reference (a node of the mode).
    """
    phi_s = np.asarray(phi_s, float)
    if how == "mass":
        return phi_s.copy(), None if dphi_s is None else np.array(dphi_s, float)
    if how in ("ref", "max"):
        k = int(np.argmax(np.abs(phi_s))) if how == "max" else ref
        if k is None:
            raise InputError("reference scaling needs the reference dof")
        s = phi_s[k]
        if abs(s) <= 1e-12 * np.max(np.abs(phi_s)):
            raise NumericalError(f"cannot scale the shape to 1 at measured dof #{k + 1}: the mode has a node there")
        psi = phi_s / s
        if dphi_s is None:
            return psi, None
        return psi, dphi_s / s - np.outer(psi, dphi_s[k] / s)
    if how == "unit":
        k = int(np.argmax(np.abs(phi_s)))
        s = np.sign(phi_s[k]) * np.linalg.norm(phi_s)
        psi = phi_s / s
        if dphi_s is None:
            return psi, None
        ds = (phi_s @ dphi_s) / s  # d|φ|/dp with the sign of s
        return psi, dphi_s / s - np.outer(psi, ds / s)
    raise InputError(f"unknown shape scaling {how!r}: use ref, max, unit or mass")
