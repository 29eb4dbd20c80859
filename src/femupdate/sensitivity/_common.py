"""Shared pieces of the eigen-sensitivity routines.

Conventions (every routine): ``modes`` are mass-normalised (φᵀMφ = 1) modes of ``model`` at
parameter values ``values``; ``which`` indexes the modes to differentiate; ``params`` indexes
model parameters (default: the free ones).  With K' = ∂K/∂p_j and M' = ∂M/∂p_j,

    λ' = φᵀ(K' − λM')φ                                  (Fox & Kapoor 1968; paper eq. 21)
    (K − λM) φ' = f,   f = −(K' − λM')φ + λ' M φ
    φᵀ M φ' = −½ φᵀ M' φ                                 (mass normalisation kept)
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import scipy.sparse as sp

from .._errors import InputError, NumericalError

REPEATED_TOL = 1e-8  # relative eigenvalue gap below which modes count as repeated


def resolve_params(model, params) -> np.ndarray:
    if params is None:
        return np.asarray(model.free, dtype=np.intp)
    out = []
    for p in params:
        out.append(model.parameter_index(p) if isinstance(p, str) else int(p))
    out = np.asarray(out, dtype=np.intp)
    if out.size and (out.min() < 0 or out.max() >= len(model.parameters)):
        raise InputError(f"parameter index out of range 0..{len(model.parameters) - 1}")
    return out


def resolve_which(modes, which) -> np.ndarray:
    idx = np.arange(modes.n_modes) if which is None else np.atleast_1d(np.asarray(which, dtype=np.intp))
    if idx.size and (idx.min() < 0 or idx.max() >= modes.n_modes):
        raise InputError(f"mode index out of range 0..{modes.n_modes - 1}")
    return idx


def check_distinct(modes, which: Sequence[int], mass_normalised: bool = True) -> None:
    """Refuse derivatives of rigid-body or repeated modes (they are not differentiable as such)."""
    if mass_normalised and modes.normalisation != "mass":
        raise InputError(f"sensitivities need mass-normalised modes, got {modes.normalisation!r} (use model_modes(..., normalisation='mass'))")
    lam = modes.eigenvalues
    scale = max(float(np.max(np.abs(lam))), 1e-300)
    for i in which:
        if lam[i] == 0.0:
            raise NumericalError(f"mode {i + 1} is a rigid-body mode (zero frequency): its derivatives are not defined; differentiate the flexible modes only")
        gap = np.abs(lam - lam[i]) <= REPEATED_TOL * max(abs(lam[i]), 1e-12 * scale)
        gap[i] = False
        if np.any(gap):
            j = int(np.flatnonzero(gap)[0])
            raise NumericalError(
                f"modes {i + 1} and {j + 1} are repeated (eigenvalues {lam[i]:.10g} and {lam[j]:.10g}): "
                "eigenvector derivatives of repeated modes are not unique; femupdate refuses rather than "
                "return a wrong derivative (pair modes by subspace, or perturb the model to split them)"
            )


def param_products(model, params: np.ndarray, phi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Columns K_j φ and M_j φ for the given parameters, shape (n, L) each."""
    n = model.n_dofs
    Kp = np.zeros((n, params.size))
    Mp = np.zeros((n, params.size))
    for c, j in enumerate(params):
        if model.dK[j] is not None:
            Kp[:, c] = model.dK[j] @ phi
        if model.dM[j] is not None:
            Mp[:, c] = model.dM[j] @ phi
    return Kp, Mp


def mode_rhs(model, params, lam: float, phi: np.ndarray, Mphi: np.ndarray):
    """Eigenvalue derivatives (L,), right-hand sides f (n, L) and φᵀM'φ (L,) of one mode."""
    Kp, Mp = param_products(model, params, phi)
    mjj = phi @ Mp
    dlam = phi @ Kp - lam * mjj
    F = -(Kp - lam * Mp) + np.outer(Mphi, dlam)
    return dlam, F, mjj


def as_dense(A):
    return A.toarray() if sp.issparse(A) else np.asarray(A)
