"""Eigenvalue derivatives (Fox & Kapoor 1968; the reference paper's eq. 21)."""

from __future__ import annotations

import numpy as np

from ._common import check_distinct, param_products, resolve_groups, resolve_params, resolve_which, tangent


def eigenvalue_derivatives(model, modes, which=None, params=None, relative: bool = False, groups=None,
                            values=None) -> np.ndarray:
    r"""∂λ_i/∂p_j = φ_iᵀ (∂K/∂p_j − λ_i ∂M/∂p_j) φ_i  (paper eq. 21), mass-normalised φ.

    Parameters
    ----------
    model : Model
    modes : Modes
        Mass-normalised modes of ``model`` at the parameter values of interest.
    which : sequence of int, optional
        Modes to differentiate (default all).
    params : sequence of int or str, optional
        Parameters (default the free ones).
    relative : bool
        Return (∂λ_i/∂p_j)/λ_i, the normalised form of the paper's eq. 19 and eq. 22.
    groups : sequence of (int, int), optional
        Groups of repeated or close modes ``(first, stop)``: their modes are not refused, and get
        the same formula — the diagonal of the group's restricted derivative, the derivative of
        the Rayleigh quotient of the computed mode
        (:func:`~femupdate.sensitivity.repeated.restricted_derivatives`).

    values : None, mapping or array_like, optional
        Parameter values of ``modes``, where a non-linear model is differentiated (default: the
        values the modes were computed at, else nominal); an affine model ignores them.

    Returns
    -------
    ndarray (len(which), len(params))

    Notes
    -----
    Eq. 21 holds for mass-normalised eigenvectors only.  The paper's printed eq. 22 matrix,
    [[0.2427, 0.2802], [0.1224, 0.1885]] with condition number 16.3, is what eq. 21 gives with
    *unit-length* eigenvectors instead; the true normalised derivatives of that system are
    [[0.0670, 0.0773], [0.0580, 0.0893]] (condition number 14.5) — see the paper section
    ``eq22_sensitivity``.
    """
    model = tangent(model, values, modes)
    which = resolve_which(modes, which)
    params = resolve_params(model, params)
    check_distinct(modes, which, groups=resolve_groups(modes, which, groups))
    out = np.zeros((which.size, params.size))
    for r, i in enumerate(which):
        phi = modes.shapes[:, i]
        Kp, Mp = param_products(model, params, phi)
        out[r] = phi @ Kp - modes.eigenvalues[i] * (phi @ Mp)
        if relative:
            out[r] /= modes.eigenvalues[i]
    return out
