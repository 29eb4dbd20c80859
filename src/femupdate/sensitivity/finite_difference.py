"""Finite-difference eigen-derivatives: a test oracle, not a production route."""

from __future__ import annotations

import numpy as np

from ..correlation import mac, pair
from ..modal import model_modes
from ._common import resolve_params, resolve_which


def finite_difference(model, values=None, which=None, params=None, n_modes=None, rel_step: float = 1e-5,
                      normalisation: str = "mass") -> tuple[np.ndarray, np.ndarray]:
    """Central differences of eigenvalues and shapes, with mode tracking by MAC.

    Each parameter is perturbed by ±``rel_step``·max(``|p_j|``, 1e-12) and the model re-solved
    (two eigensolutions per parameter: what the paper calls perturbation, and what open
    peers use).  Perturbed modes are paired to the base modes by MAC and their signs aligned.
    The truncation error is O(h²), the round-off error O(ε/h): ``rel_step`` ≈ ε^(1/3).

    Unlike the analytical routes it does not refuse repeated or rigid-body modes: there the
    differences follow whatever the pairing gives.

    Parameters
    ----------
    model : Model
        The model.
    values : array_like, shape ``(n_parameters,)``, optional
        Parameter values to differentiate at (default nominal).
    which : int or sequence of int, optional
        Indices of the base modes to differentiate (default all computed).
    params : sequence of int or str, optional
        Parameters, by index or name (default the free ones); L = ``len(params)``.
    n_modes : int, optional
        Modes computed per eigensolution (default as :func:`femupdate.model_modes`).
    rel_step : float, default 1e-5
        Step relative to max(``|p_j|``, 1e-12).
    normalisation : {"mass", "unit", "max"}, default "mass"
        Normalisation of the shapes whose derivatives are taken.

    Returns
    -------
    dlam : numpy.ndarray, shape ``(len(which), L)``
        Eigenvalue derivatives, rad²/s² per unit of the parameter.
    dphi : numpy.ndarray, shape ``(n_dofs, len(which), L)``
        Shape derivatives in the given normalisation.

    Raises
    ------
    InputError
        Bad ``values``, or a mode or parameter index out of range.
    NumericalError
        An eigensolution fails.
    """
    p0 = model.resolve(values)
    base = model_modes(model, p0, n_modes=n_modes, normalisation=normalisation)
    which = resolve_which(base, which)
    params = resolve_params(model, params)
    dlam = np.zeros((which.size, params.size))
    dphi = np.zeros((model.n_dofs, which.size, params.size))
    for c, j in enumerate(params):
        h = rel_step * max(abs(p0[j]), 1e-12)
        sides = []
        for sgn in (+1.0, -1.0):
            p = p0.copy()
            p[j] += sgn * h
            pert = model_modes(model, p, n_modes=n_modes, normalisation=normalisation)
            pairs = {t: m for t, m, _ in pair(mac(base.shapes[:, which], pert.shapes), rule="mac", min_mac=0.0).pairs}
            lam = np.array([pert.eigenvalues[pairs[r]] for r in range(which.size)])
            shp = np.column_stack([pert.shapes[:, pairs[r]] for r in range(which.size)])
            shp *= np.sign(np.sum(shp * base.shapes[:, which], axis=0))
            sides.append((lam, shp))
        dlam[:, c] = (sides[0][0] - sides[1][0]) / (2 * h)
        dphi[:, :, c] = (sides[0][1] - sides[1][1]) / (2 * h)
    return dlam, dphi
