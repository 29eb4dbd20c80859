"""Nelson's (1976) exact eigenvector derivatives: one factorisation per mode, sparsity kept."""

from __future__ import annotations

import numpy as np

from .._docs import DERIVATIVE_DOCS, shared_docs
import scipy.linalg as sla
import scipy.sparse as sp

from .._errors import NumericalError
from ..modal import factorize
from ._common import tangent, group_rhs, mode_rhs, resolve_request

DENSE_LIMIT = 1500


@shared_docs(**DERIVATIVE_DOCS)
def nelson(model, modes, which=None, params=None, values=None, groups=None) -> tuple[np.ndarray, np.ndarray]:
    r"""Eigenvalue and mass-normalised eigenvector derivatives by Nelson's method.

    For mode i, with A = K − λ_i M and the dof k of largest ``|φ_k|``, the singular system
    A v = f is made regular by fixing v_k = 0 (row and column k of A replaced by the unit
    vector); then φ' = v + c φ with c = −½ φᵀM'φ − φᵀ M v restores mass normalisation.
    The modified matrix keeps A's sparsity (banded stays banded) and is factorised once per
    mode, for every parameter (Nelson 1976, AIAA J. 14(9); the paper's "direct method").
    Models of at most ``DENSE_LIMIT`` (1500) dofs are solved dense, larger ones by sparse LU.

    A mode of one of ``groups`` (repeated or close modes Φ_g) gets the derivative of the group's
    basis (:mod:`femupdate.sensitivity.repeated`): the part outside the group from the bordered
    system [[K − λ_i M, MΦ_g], [Φ_gᵀM, 0]] (regular however close the group's eigenvalues are;
    the generalisation of Nelson's regularisation to a group), the part inside −½ Φ_gᵀ M' φ_i.

    Parameters
    ----------
    {{DERIVATIVE_ARGUMENTS}}
    groups : sequence of (int, int), optional
        Groups of repeated or close modes ``(first, stop)`` (modes first .. stop − 1).

    {{DERIVATIVES}}

    {{DERIVATIVE_RAISES}}
    NumericalError
        The modified matrix of a mode is singular, or a derivative is not finite.
    """
    model = tangent(model, values, modes)
    which, params, grouped = resolve_request(model, modes, which, params, groups)
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
        if int(i) in grouped:
            dlam[r], dphi[:, r, :] = _group_member(model, params, (Kd, Md) if dense else (K, M), M, modes, int(i),
                                                   grouped[int(i)])
            continue
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


def _group_member(model, params, KM, M, modes, i: int, group: tuple[int, int]):
    """λ' and the derivative of the group's basis vector i (the bordered system of :func:`nelson`);
    ``KM`` (K, M) dense or sparse, ``M`` sparse."""
    a, b = group
    lam, phi, Phi_g = modes.eigenvalues[i], modes.shapes[:, i], modes.shapes[:, a:b]
    n, r = model.n_dofs, b - a
    MPg = np.asarray(M @ Phi_g)
    dl, F, mjj, Ng = group_rhs(model, params, lam, phi, M @ phi, Phi_g)
    rhs = np.vstack([F - MPg @ (Phi_g.T @ F), np.zeros((r, F.shape[1]))])  # F with the group's part removed
    try:
        K_, M_ = KM
        if isinstance(K_, np.ndarray):
            A = np.block([[K_ - lam * M_, MPg], [MPg.T, np.zeros((r, r))]])
            V = sla.solve(A, rhs, assume_a="sym")
        else:
            A = sp.bmat([[K_ - lam * M_, sp.csr_array(MPg)], [sp.csr_array(MPg.T), None]], format="csc")
            V = factorize(A, definite=False).solve(rhs)
    except (np.linalg.LinAlgError, sla.LinAlgWarning, RuntimeError) as exc:
        raise NumericalError(f"Nelson's method: the bordered matrix of mode {i + 1} (group of modes {a + 1}-{b}) "
                             f"is singular ({exc})") from None
    if not np.all(np.isfinite(V)):
        raise NumericalError(f"Nelson's method: non-finite derivative for mode {i + 1} (group of modes {a + 1}-{b})")
    return dl, V[:n] - 0.5 * Phi_g @ Ng
