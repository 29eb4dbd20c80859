r"""Where spectral lines lie with respect to the model's undamped resonances, and the
eigen-solutions this needs: the relative eigenvalue distance of every line to its nearest
resonance (all eigenvalues densely for small models, the nearest eigenpair by shift-invert
Lanczos per line for large ones), with the Fox–Kapoor sensitivities of that mode; and the
batched dense eigen-solution of a stack of pencils (the residual surfaces).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from .._errors import NumericalError
from ..modal import arpack_options
from .lines import check_omega, derivative_stack, factor, line_name, lu_apply


@dataclass(frozen=True, eq=False)
class Resonances:
    r"""Where each line lies with respect to the model's undamped resonances.

    Attributes
    ----------
    omega : ndarray (n_lines,)
    distance : ndarray (n_lines,)
        Relative eigenvalue distance to the nearest resonance,
        :math:`d_i = \min_r |\omega_i^2 - \lambda_r| / \max(\lambda_r, \omega_i^2)`
        (0: exactly on a resonance; about twice the relative frequency distance when small).
    nearest : ndarray (n_lines,)
        That resonance's eigenvalue :math:`\lambda_r` (rad²/s²).
    mode : ndarray (n_lines,)
        Its mode number (1-based; -1 when found by a local shift-invert search, whose rank is unknown).
    sensitivity : ndarray (n_lines, L) or None
        Relative eigenvalue sensitivity of that mode, :math:`s_{ij} = p_j\,\partial\lambda_r/\partial p_j / \lambda_r`
        (Fox & Kapoor, eq. 21), when parameters were given.
    """

    omega: np.ndarray
    distance: np.ndarray
    nearest: np.ndarray
    mode: np.ndarray
    sensitivity: np.ndarray | None = None

    def near(self, tol: float) -> np.ndarray:
        """Indices of the lines within ``tol`` (relative eigenvalue distance) of a resonance.

        Parameters
        ----------
        tol : float
            Relative eigenvalue distance (``distance < tol``, strictly).

        Returns
        -------
        numpy.ndarray of int
            0-based line indices, ascending.
        """
        return np.flatnonzero(self.distance < tol)

    def first_order_error(self, delta: float) -> np.ndarray:
        r"""Estimated relative error of a first-order (Brandon) prediction of the receptance for a
        relative parameter change ``delta``: :math:`|\delta\, s_{ij}| / d_i`, ``(n_lines, L)``
        (``(n_lines,)`` with the bound :math:`|s| \le 1` when no sensitivities are known).

        Near resonance, where one mode dominates, :math:`\alpha \approx \phi\phi^T / (\lambda - \omega^2)`
        and the exact change is :math:`-\phi\phi^T\Delta\lambda / ((\lambda-\omega^2)(\lambda+\Delta\lambda-\omega^2))`
        against the first-order :math:`-\phi\phi^T\Delta\lambda/(\lambda-\omega^2)^2`: their relative
        difference is :math:`|\Delta\lambda / (\lambda + \Delta\lambda - \omega^2)| \approx \delta\, s / d`.

        Parameters
        ----------
        delta : float
            Relative parameter change Δp/p.

        Returns
        -------
        numpy.ndarray of float, shape ``(n_lines, L)`` or ``(n_lines,)``
            The estimate; a distance of 0 counts as the smallest normal float (a huge error).
        """
        d = np.maximum(self.distance, np.finfo(float).tiny)
        if self.sensitivity is None:
            return abs(delta) / d
        return np.abs(delta * self.sensitivity) / d[:, None]

    def describe(self, lines) -> str:
        """The lines' distances to their resonances, in words, for messages.

        Parameters
        ----------
        lines : iterable of int
            0-based line indices (e.g. from :meth:`near`).

        Returns
        -------
        str
            One ``"line k (omega = ... rad/s) is d (relative) from mode m at ... rad/s"`` per line,
            joined by ``"; "``.
        """
        return "; ".join(
            f"{line_name(int(i), float(self.omega[i]))} is {self.distance[i]:.2g} (relative) from "
            f"{'mode ' + str(int(self.mode[i])) if self.mode[i] > 0 else 'a mode'} at "
            f"{math.sqrt(max(self.nearest[i], 0.0)):.6g} rad/s" for i in lines)


def _distance(w2: np.ndarray, lam: np.ndarray) -> np.ndarray:
    scale = np.maximum(np.maximum(lam, w2), np.finfo(float).tiny)
    return np.abs(w2 - lam) / scale


def nearest_mode(K, M, s: float, lu, where: str) -> tuple[float, np.ndarray]:
    """The eigenpair of (K, M) nearest ``s`` = ω², by shift-invert Lanczos (k = 1) with the given
    real factor ``lu`` of K − sM; the vector mass-normalised.

    Parameters
    ----------
    K, M : sparse matrix, shape ``(n, n)``
        Stiffness (N/m) and mass (kg).
    s : float
        The shift ω² (rad²/s²).
    lu : femupdate.workspace.SuperLUFactor or scipy.sparse.linalg.SuperLU
        Real factor of K − sM (:func:`factor`).
    where : str
        The line's name in messages.

    Returns
    -------
    lam : float
        The nearest eigenvalue (rad²/s²).
    phi : numpy.ndarray of float, shape ``(n,)``
        Its eigenvector, φᵀMφ = 1.

    Raises
    ------
    NumericalError
        ARPACK does not converge.
    """
    op = spla.LinearOperator(K.shape, matvec=lambda v: lu_apply(lu, v), dtype=float)
    try:
        lam, vec = spla.eigsh(K, k=1, M=M, sigma=s, which="LM", OPinv=op, tol=1e-8, ncv=min(8, K.shape[0] - 1),
                              **arpack_options())
    except spla.ArpackNoConvergence as exc:
        raise NumericalError(f"{where}: the nearest resonance was not found ({len(exc.eigenvalues)} converged)") from None
    v = vec[:, 0]
    return float(lam[0]), v / math.sqrt(float(v @ (M @ v)))


def collect_resonances(model, p, w, nearest, Phi, mode_no, params=None) -> Resonances:
    """:class:`Resonances` from the nearest eigenpair of every line (and Fox–Kapoor sensitivities).

    Parameters
    ----------
    model : Model
        The parametrised model.
    p : numpy.ndarray of float, shape ``(n_parameters,)``
        The full parameter vector.
    w : array_like of float, shape ``(n_lines,)``
        Circular frequencies of the lines (rad/s).
    nearest : numpy.ndarray of float, shape ``(n_lines,)``
        Each line's nearest eigenvalue λ_r (rad²/s²).
    Phi : numpy.ndarray of float, shape ``(n, n_lines)``
        The mass-normalised eigenvectors of those modes.
    mode_no : array_like of int, shape ``(n_lines,)``
        Their 1-based mode numbers (−1: unknown).
    params : sequence of int, optional
        0-based parameter indices: with them, :attr:`Resonances.sensitivity` is
        p_j (∂λ_r/∂p_j) / λ_r with ∂λ_r/∂p_j = φ_rᵀ (K_j − λ_r M_j) φ_r (0 where λ_r <= 0).

    Returns
    -------
    Resonances
    """
    n = model.n_dofs
    sens = None
    if params is not None and len(params):
        Ks, Ms = derivative_stack(model, params, p)
        L = len(params)
        dlam = np.einsum("nl,jnl->lj", Phi, (Ks @ Phi).reshape(L, n, -1))
        if Ms.nnz:
            dlam = dlam - nearest[:, None] * np.einsum("nl,jnl->lj", Phi, (Ms @ Phi).reshape(L, n, -1))
        with np.errstate(divide="ignore", invalid="ignore"):
            sens = np.where(nearest[:, None] > 0, dlam * p[np.asarray(params)][None, :] / nearest[:, None], 0.0)
    return Resonances(np.asarray(w, float), _distance(np.asarray(w, float) ** 2, nearest), nearest, np.asarray(mode_no), sens)


def resonances(model, omega, values=None, params=None) -> Resonances:
    """Distance of every line to the nearest undamped resonance of the model at ``values``.

    Small models (up to :data:`femupdate.modal.DENSE_LIMIT` dofs): every eigenvalue, densely.
    Large ones: the eigenpair nearest each ω² by shift-invert Lanczos, one factorisation of
    K − ω²M per line (:func:`nearest_mode`).  With ``params`` (indices), the relative
    eigenvalue sensitivities of the nearest mode too.

    Parameters
    ----------
    model : Model
        The parametrised model.
    omega : array_like of float
        Circular frequencies of the lines (rad/s), checked by :func:`check_omega`.
    values : None, mapping or array_like, optional
        Parameter values (:meth:`Model.resolve`; None: nominal).
    params : sequence of int, optional
        0-based parameter indices for the sensitivities (:func:`collect_resonances`).

    Returns
    -------
    Resonances

    Raises
    ------
    InputError
        A bad frequency axis or bad ``values``; small models: as :func:`femupdate.modal.solve_modes`
        (e.g. a negative eigenvalue).
    NumericalError
        Small models: as :func:`femupdate.modal.solve_modes`; large models: a line exactly on a
        resonance (K − ω²M singular), or no convergence of the shift-invert search.
    """
    from ..modal import DENSE_LIMIT as MODAL_DENSE
    from ..modal import solve_modes

    w = check_omega(omega)
    p = model.resolve(values)
    K, M = model.K(p), model.M(p)
    if model.n_dofs <= MODAL_DENSE:
        modes = solve_modes(K, M, dofs=model.dofs, method="dense")
        lam = modes.eigenvalues
        r = np.argmin(_distance(w[:, None] ** 2, lam[None, :]), axis=1)
        return collect_resonances(model, p, w, lam[r], modes.shapes[:, r], r + 1, params)
    nearest = np.empty(w.size)
    Phi = np.empty((model.n_dofs, w.size))
    for i, wi in enumerate(w):
        where = line_name(i, wi)
        nearest[i], Phi[:, i] = nearest_mode(K, M, wi**2, factor(sp.csc_array(K - wi**2 * M), where), where)
    return collect_resonances(model, p, w, nearest, Phi, np.full(w.size, -1), params)


def dense_eigen_stack(K: np.ndarray, M: np.ndarray):
    """Eigenvalues (ascending) and M-orthonormal eigenvectors of a stack of symmetric pencils
    ``(G, n, n)`` at once: Cholesky M = L Lᵀ, then ``eigh`` of L⁻¹ K L⁻ᵀ (batched LAPACK).

    Parameters
    ----------
    K : numpy.ndarray of float, shape ``(G, n, n)``
        Symmetric stiffness matrices (N/m); any leading axes (or none).
    M : numpy.ndarray of float, shape ``(G, n, n)``
        Symmetric positive definite mass matrices (kg).

    Returns
    -------
    lam : numpy.ndarray of float, shape ``(G, n)``
        Eigenvalues ω² (rad²/s²), ascending per member.
    Phi : numpy.ndarray of float, shape ``(G, n, n)``
        Eigenvectors as columns, ΦᵀMΦ = I.

    Raises
    ------
    numpy.linalg.LinAlgError
        A mass matrix that is not positive definite (NumPy's error, not a NumericalError).
    """
    Lc = np.linalg.cholesky(M)
    A = np.linalg.solve(Lc, np.swapaxes(np.linalg.solve(Lc, K), -1, -2))
    A = 0.5 * (A + np.swapaxes(A, -1, -2))
    lam, Y = np.linalg.eigh(A)
    Phi = np.linalg.solve(np.swapaxes(Lc, -1, -2), Y)
    return lam, Phi


__all__ = ["Resonances", "resonances", "collect_resonances", "nearest_mode", "dense_eigen_stack"]
