"""Static loads a model can carry: a structure with rigid-body modes takes only loads in
equilibrium with them (:func:`check_static_loads`, also named in :mod:`femupdate.modal`)."""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from ._errors import InputError
from .workspace import NotPositiveDefinite, factorize, nearly_singular


def check_static_loads(model, values, loads, need_inverse: bool = False) -> None:
    """Refuse static loads that a model with rigid-body modes cannot carry.

    A free (or partly free) structure can only be loaded by forces in equilibrium: the force must
    have no component along the rigid-body modes (the null space of K).  Otherwise K u = f has
    no solution at any parameter values, and a fit to such data is a least-squares compromise
    that means nothing.  K is factorised once for all the loads (and its modes computed only
    when it is singular).

    Parameters
    ----------
    model : Model
    values : parameter values at which K is judged (None: nominal).
    loads : sequence of (str, numpy.ndarray)
        Each load case's name, as messages give it, and its force vector (n_dofs,), N.
    need_inverse : bool, default False
        The caller computes u = K(p)⁻¹ f (iterative updating): any rigid-body mode is refused,
        a self-equilibrated load too (u is then defined only up to rigid motion).

    Raises
    ------
    InputError
        The model has rigid-body modes and a load is not in equilibrium with respect to them
        (or, with ``need_inverse``, the model has rigid-body modes at all).
    """
    from .modal import DENSE_LIMIT, solve_modes

    loads = list(loads)
    if not loads:
        return
    p = model.resolve(values)
    try:
        if not nearly_singular(factorize(sp.csc_array(model.K(p)), definite=True)):
            return
    except (RuntimeError, NotPositiveDefinite):  # exactly singular
        pass
    n = model.n_dofs
    modes = solve_modes(model.K(p), model.M(p), n_modes=min(n, 12) if n > DENSE_LIMIT else None, dofs=model.dofs,
                        method="dense" if n <= DENSE_LIMIT else "sparse")
    rigid = modes.shapes[:, modes.eigenvalues == 0.0]
    if rigid.shape[1] == 0:
        return
    if need_inverse:
        raise InputError(
            f"{loads[0][0]}: the model has {rigid.shape[1]} rigid-body mode(s): iterative updating computes "
            "u = K(p)^-1 f, which needs a supported model; support it, or use direct updating with displacements "
            "at every dof")
    for what, force in loads:
        f = np.real(np.asarray(force))
        along = np.abs(rigid.T @ f)
        scale = np.linalg.norm(f) * np.linalg.norm(rigid, axis=0)
        if np.any(along > 1e-8 * np.maximum(scale, np.finfo(float).tiny)):
            raise InputError(
                f"{what}: the model has {rigid.shape[1]} rigid-body mode(s) and the load is not in equilibrium with "
                "them (K u = f has no solution at any parameter values): support the model, or give a "
                "self-equilibrated load")
