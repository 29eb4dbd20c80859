"""The one shifted factorisation of the series routes, and solves with it on one BLAS thread.

:func:`prepare_factor` chooses the shift σ below every computed eigenvalue and factorises
K − σM (or reuses the factorisation the sparse eigensolver left with the modes);
:func:`solve` applies it under :func:`single_thread_blas`.
"""

from __future__ import annotations

import math

import numpy as np

from .._errors import InputError
from .._threads import blas_phase
from .modal import shifted_factor

__all__ = ["single_thread_blas", "solve", "check_modes", "prepare_factor"]


# ---------------------------------------------------------------------------------------------
# solves with one thread of BLAS
# ---------------------------------------------------------------------------------------------
def single_thread_blas():
    """Run the enclosed code in the ``"solve"`` phase of the BLAS policy (one thread unless
    :attr:`femupdate.settings.Settings.blas_threads` says otherwise; :mod:`femupdate._threads`).

    SuperLU's solve with several right-hand sides calls BLAS on every (small) supernode, and
    OpenBLAS's thread hand-off then dominates: on a 35,000-dof frame a 30-column solve takes
    4.1 s with two threads and 0.49 s with one.
    """
    return blas_phase("solve")


def solve(lu, B: np.ndarray) -> np.ndarray:
    """S B with the factorisation ``lu`` (an object with ``.solve``, or a callable).

    Run under :func:`single_thread_blas`.

    Parameters
    ----------
    lu : object with ``.solve`` (e.g. SuperLU), or callable
        The factorisation S = (K − σM)⁻¹ (or any operator applied the same way).
    B : numpy.ndarray, shape ``(n_dofs,)`` or ``(n_dofs, k)``
        Right-hand sides.

    Returns
    -------
    numpy.ndarray, shape of ``B``
        S B.
    """
    with single_thread_blas():
        return lu.solve(B) if hasattr(lu, "solve") else np.asarray(lu(B))


# ---------------------------------------------------------------------------------------------
# the shift and the factorisation
# ---------------------------------------------------------------------------------------------
def check_modes(model, modes) -> None:
    """The modes must live on the model's dofs.

    Parameters
    ----------
    model : Model
        The model.
    modes : Modes
        Its modes.

    Raises
    ------
    InputError
        The modes have another number of dofs or other dof labels than the model.
    """
    if modes.shapes.shape[0] != model.n_dofs or tuple(modes.dofs) != tuple(model.dofs):
        raise InputError(
            f"the modes have {modes.shapes.shape[0]} dofs but model {model.name!r} has {model.n_dofs} "
            "(or they are on other dof labels): compute them with model_modes(model, ...)"
        )


def prepare_factor(K, M, modes, sigma=None, lu=None):
    """The factorisation of K − σM and the shift σ for the series routes.

    σ defaults to 0 when the lowest computed eigenvalue is positive, else (rigid-body modes) a
    small negative shift (:func:`~femupdate.sensitivity.modal.shifted_factor`).  A supplied
    ``lu`` must factorise K − σM for the given ``sigma`` (default 0).  Without ``lu`` and
    ``sigma``, the factorisation the sparse eigensolver left in ``modes.factor`` is reused.

    Parameters
    ----------
    K, M : scipy sparse matrix, shape ``(n_dofs, n_dofs)``
        Stiffness and mass matrices at the modes' parameter values.
    modes : Modes
        The computed modes (their lowest eigenvalue bounds the shift).
    sigma : float, optional
        Shift, rad²/s², below the lowest computed eigenvalue.
    lu : factorisation of K − σM, optional
        Reused as given (with ``sigma``, default 0).

    Returns
    -------
    lu : factorisation
        :class:`femupdate.workspace.Factor` (or the ``lu`` given).
    sigma : float
        The shift, rad²/s².

    Raises
    ------
    InputError
        A shift that is not finite or not below the lowest computed eigenvalue; and as
        :func:`~femupdate.sensitivity.modal.shifted_factor`.
    """
    lam_min = float(np.min(modes.eigenvalues))
    if lu is None and sigma is None and getattr(modes, "factor", None) is not None:
        lu, sigma = modes.factor  # the eigensolver's own factorisation of K − σM
    if sigma is None and (lu is not None or lam_min > 0):
        sigma = 0.0
    if sigma is not None:
        sigma = float(sigma)
        if not math.isfinite(sigma) or sigma >= lam_min:
            raise InputError(
                f"sigma = {sigma:g} must lie below the lowest computed eigenvalue ({lam_min:.6g}); "
                "with rigid-body modes (zero eigenvalues) use a negative shift"
            )
    if lu is None:
        with single_thread_blas():
            lu, sigma = shifted_factor(K, M, sigma)
        if sigma >= lam_min:
            raise InputError(f"the shift {sigma:g} is not below the lowest computed eigenvalue {lam_min:.6g}")
    return lu, float(sigma)
