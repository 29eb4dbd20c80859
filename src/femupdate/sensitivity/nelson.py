"""Nelson's (1976) exact eigenvector derivatives: one factorisation per mode, sparsity kept."""

from __future__ import annotations

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp

from .._errors import NumericalError
from ..modal import factorize
from ._common import check_distinct, mode_rhs, resolve_params, resolve_which

DENSE_LIMIT = 1500


def nelson(model, modes, which=None, params=None, values=None) -> tuple[np.ndarray, np.ndarray]:
    r"""Eigenvalue and mass-normalised eigenvector derivatives by Nelson's method.

    For mode i, with A = K − λ_i M and the dof k of largest ``|φ_k|``, the singular system
    A v = f is made regular by fixing v_k = 0 (row and column k of A replaced by the unit
    vector); then φ' = v + c φ with c = −½ φᵀM'φ − φᵀ M v restores mass normalisation.
    The modified matrix keeps A's sparsity (banded stays banded) and is factorised once per
    mode, for every parameter (Nelson 1976, AIAA J. 14(9); the paper's "direct method").
    Models of at most ``DENSE_LIMIT`` (1500) dofs are solved dense, larger ones by sparse LU.

    Parameters
    ----------
    model : Model
        The model (affine in its parameters).
    modes : Modes
        Mass-normalised modes of ``model`` at ``values`` (φᵀMφ = 1), e.g. from :func:`femupdate.model_modes`.
    which : int or sequence of int, optional
        Indices into ``modes`` of the modes to differentiate (default all).
    params : sequence of int or str, optional
        Parameters, by index or name (default the free ones); L = ``len(params)``.
    values : array_like, shape ``(n_parameters,)``, optional
        Parameter values of ``modes`` (default nominal).

    Returns
    -------
    dlam : numpy.ndarray, shape ``(len(which), L)``
        Eigenvalue derivatives dλ/dp, rad²/s² per unit of the parameter (paper eq. 21).
    dphi : numpy.ndarray, shape ``(n_dofs, len(which), L)``
        Derivatives of the mass-normalised shapes.

    Raises
    ------
    InputError
        Modes not mass-normalised, or a mode or parameter index out of range (an unknown
        parameter name).
    NumericalError
        A rigid-body or repeated mode among ``which`` (not differentiable as such).
    NumericalError
        The modified matrix of a mode is singular, or a derivative is not finite.
    """
    which = resolve_which(modes, which)
    params = resolve_params(model, params)
    check_distinct(modes, which)
    K, M = model.K(values), model.M(values)
    n = model.n_dofs
    dlam = np.zeros((which.size, params.size))
    dphi = np.zeros((n, which.size, params.size))
    dense = n <= DENSE_LIMIT
    if dense:
        Kd, Md = K.toarray(), M.toarray()
    for r, i in enumerate(which):
        lam, phi = modes.eigenvalues[i], modes.shapes[:, i]
        Mphi = M @ phi
        dl, F, mjj = mode_rhs(model, params, lam, phi, Mphi)
        k = int(np.argmax(np.abs(phi)))
        F[k, :] = 0.0
        if dense:
            A = Kd - lam * Md
            A[k, :] = 0.0
            A[:, k] = 0.0
            A[k, k] = 1.0
            try:
                V = sla.solve(A, F, assume_a="sym")
            except (np.linalg.LinAlgError, sla.LinAlgWarning) as exc:
                raise NumericalError(f"Nelson's method: the modified matrix of mode {i + 1} is singular ({exc})") from None
        else:
            keep = np.ones(n)
            keep[k] = 0.0
            Z = sp.diags_array(keep)
            A = Z @ (K - lam * M) @ Z + sp.coo_array(([1.0], ([k], [k])), shape=(n, n))
            try:
                lu = factorize(A, definite=False)  # K - lam M bordered: indefinite
            except RuntimeError as exc:
                raise NumericalError(f"Nelson's method: the modified matrix of mode {i + 1} is singular ({exc})") from None
            V = lu.solve(F)
        if not np.all(np.isfinite(V)):
            raise NumericalError(f"Nelson's method: non-finite derivative for mode {i + 1} (is the mode repeated?)")
        c = -0.5 * mjj - Mphi @ V
        dlam[r] = dl
        dphi[:, r, :] = V + np.outer(phi, c)
    return dlam, dphi
