r"""Adjoint eigen-sensitivities: derivatives of the MEASURED shape components only.

Updating compares shapes at n_s sensors, so it needs Eᵀφ_i' (E the n × n_s sensor selector)
for every mode i and parameter j — not the full φ_i'.  With the computed modes Φ (n × m) the
derivative splits into the modal part over Φ and the omitted modes' part
q_ij = G_i f_ij, where

.. math::

    G_i = \sum_{r > m} \frac{\phi_r \phi_r^T}{\lambda_r - \lambda_i}
        = \sum_{k \ge 0} (\lambda_i - \sigma)^k H_{k+1}, \qquad
    H_{k+1} = \sum_{r > m} \frac{\phi_r \phi_r^T}{(\lambda_r - \sigma)^{k+1}}

is symmetric.  Hence :math:`E^T q_{ij} = W_i^T f_{ij}` with :math:`W_i = G_i E`, and the
terms :math:`Y_k = H_{k+1} E` (:math:`Y_0 = P S P^T E`, :math:`Y_k = P S M Y_{k-1}`) do not
depend on the mode: ONE sweep of solves with n_s right-hand sides, with the factorisation
S = (K − σM)⁻¹, gives :math:`W_i = \sum_k (\lambda_i - \sigma)^k Y_k` for every mode — by
default not as the partial sums but as the Galerkin solution of
:math:`(I - (\lambda_i - \sigma) P S M) W_i = Y_0` in the span of the same Y_k (block Lanczos:
about half the solves for the same accuracy; ``series="neumann"`` for the plain sums).  With
:math:`f_{ij} = -(K_j - \lambda_i M_j)\phi_i + \lambda'_{ij} M\phi_i`, all parameters follow
from one sparse–dense product :math:`W_i^T F_i`, the columns K_jφ_i, M_jφ_i of every parameter
being built at once from the model's union sparsity pattern
(:class:`~femupdate.sensitivity._common.ParameterProducts`).

Cost: (number of series terms) × (solves with n_s right-hand sides) + O(nnz) per mode — it
scales with sensors × modes, not with parameters × modes as the forward routes (Nelson: one
factorisation per mode; :func:`~femupdate.sensitivity.subspace`: L right-hand sides per mode
and term) do.  This is the adjoint (transpose) form of the iterative method of Rudisill & Chu
(1975) / Ting (1992); see :mod:`femupdate.sensitivity.subspace`.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from .._errors import InputError
from ._common import tangent, check_distinct, in_group, parameter_products, resolve_groups, resolve_params, resolve_which
from .factor import check_modes, prepare_factor
from .series import DEFAULT_TOL, MAX_TERMS, omitted_modes_series


def resolve_sensors(model, sensors) -> np.ndarray:
    """Matrix positions of the sensors: dof labels (``"12:x"``) or integer dof indices.

    Unknown labels raise :class:`InputError` naming every one of them; indices must lie in
    ``0 .. n_dofs - 1``; a sensor may not be listed twice.

    Parameters
    ----------
    model : Model
        The model.
    sensors : str, sequence of str, or sequence of int
        Dof labels ``"node:dir"`` or integer dof indices (not a mixture).

    Returns
    -------
    numpy.ndarray of int, shape ``(n_s,)``
        Matrix positions of the sensors, in the order given.

    Raises
    ------
    InputError
        ``None`` or empty; unknown labels; indices out of range; a mixture of labels and
        indices; a sensor listed twice.
    """
    if sensors is None:
        raise InputError("sensors: give the measured dofs (labels such as '12:x', or dof indices)")
    if isinstance(sensors, str):
        sensors = [sensors]
    items = list(np.asarray(sensors, dtype=object).ravel()) if not isinstance(sensors, Sequence) else list(sensors)
    if not items:
        raise InputError("sensors: no measured dof given")
    if all(isinstance(s, str) for s in items):
        idx = model.dof_index(items, "sensors")
    elif all(isinstance(s, (int, np.integer)) and not isinstance(s, bool) for s in items):
        idx = np.asarray(items, dtype=np.intp)
        bad = [int(i) for i in idx if not 0 <= i < model.n_dofs]
        if bad:
            raise InputError(f"sensors: dof index(es) {bad[:8]} out of range 0..{model.n_dofs - 1}")
    else:
        raise InputError("sensors: give dof labels (e.g. '12:x') or integer dof indices, not a mixture")
    if np.unique(idx).size != idx.size:
        seen, dup = set(), []
        for i in idx:
            if i in seen:
                dup.append(model.dofs[i])
            seen.add(i)
        raise InputError(f"sensors: dof(s) listed twice: {', '.join(sorted(set(dup)))}")
    return idx


def adjoint_details(model, modes, which=None, params=None, sensors=None, values=None, sigma=None,
                    tol: float = DEFAULT_TOL, lu=None, max_terms: int = MAX_TERMS, series: str = "krylov",
                    groups=None):
    """:func:`adjoint`, also returning the number of series terms (one sweep serves all modes).

    Parameters
    ----------
    model, modes, which, params, sensors, values, sigma, tol, lu, max_terms, series
        As :func:`adjoint`.
    groups : sequence of (int, int), optional
        Groups of repeated or close modes ``(first, stop)``: a mode of ``which`` in one gets the
        derivative of the group's basis (in-group modal coefficients −½ φ_rᵀM'φ_i;
        :mod:`femupdate.sensitivity.repeated`).

    Returns
    -------
    dlam : numpy.ndarray, shape ``(len(which), L)``
        Eigenvalue derivatives ∂λ_i/∂p_j (paper eq. 21), rad²/s² per unit of p_j.
    dphi_s : numpy.ndarray, shape ``(n_s, len(which), L)``
        Derivatives of the mass-normalised shapes at the sensors.
    n_terms : int
        Number of series terms used.

    Raises
    ------
    InputError
        Modes that are not mass-normalised or do not belong to the model, indices out of range,
        bad sensors (:func:`resolve_sensors`).
    NumericalError
        A rigid-body or repeated mode among ``which`` (outside ``groups``); and as
        :func:`~femupdate.sensitivity.series.omitted_modes_series`.
    """
    check_modes(model, modes)
    model = tangent(model, values, modes)
    which = resolve_which(modes, which)
    params = resolve_params(model, params)
    s = resolve_sensors(model, sensors)
    grouped = resolve_groups(modes, which, groups)
    check_distinct(modes, which, groups=grouped)
    K, M = model.K(values), model.M(values)
    lu, sigma = prepare_factor(K, M, modes, sigma, lu)
    lam, Phi = modes.eigenvalues, modes.shapes
    n, ns, L = model.n_dofs, s.size, params.size

    # W_i = G_i E for every differentiated mode, from one sweep with n_s right-hand sides
    E = np.zeros((n, ns))
    E[s, np.arange(ns)] = 1.0
    W, n_terms = omitted_modes_series(lu, M, Phi, E, lam[which] - sigma, tol=tol, max_terms=max_terms,
                                      labels=[str(i + 1) for i in which], series=series)
    products = parameter_products(model, params)
    Phi_s = Phi[s]
    dlam = np.zeros((which.size, L))
    dphi_s = np.zeros((ns, which.size, L))
    for r, i in enumerate(which):
        phi = Phi[:, i]
        Mphi = M @ phi
        Kp, Mp = products.sparse(phi)  # (n, L) sparse
        KpT, MpT = Kp.T, Mp.T
        mjj = MpT @ phi
        dl = KpT @ phi - lam[i] * mjj
        # Φᵀ F_i (m, L) and W_iᵀ F_i (n_s, L), F_i = -(Kp - λ Mp) + Mφ λ'ᵀ, never formed densely
        PhiF = -(KpT @ Phi).T + lam[i] * (MpT @ Phi).T + np.outer(Phi.T @ Mphi, dl)
        WF = -(KpT @ W[r]).T + lam[i] * (MpT @ W[r]).T + np.outer(W[r].T @ Mphi, dl)
        denom = lam - lam[i]
        denom[i] = 1.0
        g = grouped.get(int(i))
        if g is not None:
            denom[g[0]:g[1]] = 1.0
        coef = PhiF / denom[:, None]
        coef[i] = -0.5 * mjj
        if g is not None:  # the group's basis: −½ φ_rᵀ M' φ_i for the group's other modes
            in_group(coef, int(i), g, (MpT @ Phi[:, g[0]:g[1]]).T)
        dlam[r] = dl
        dphi_s[:, r, :] = Phi_s @ coef + WF
    return dlam, dphi_s, n_terms


def adjoint(model, modes, which=None, params=None, sensors=None, values=None, sigma=None,
            tol: float = DEFAULT_TOL, lu=None, max_terms: int = MAX_TERMS, series: str = "krylov", groups=None):
    r"""Eigenvalue derivatives and the derivatives of the measured shape components.

    .. math::

        E^T \phi_i' = \Phi_s\, c_i + W_i^T F_i, \qquad
        (c_i)_r = \frac{\phi_r^T f_{ij}}{\lambda_r - \lambda_i}\ (r \ne i), \quad
        (c_i)_i = -\tfrac12 \phi_i^T M_j \phi_i,

    with :math:`W_i = \sum_{r>m} \phi_r\phi_r^T E/(\lambda_r - \lambda_i)` from one
    mode-independent series of solves with the n_s sensor columns (module docstring).  Equal,
    to ``tol``, to the sensor rows of :func:`~femupdate.sensitivity.subspace` and
    :func:`~femupdate.sensitivity.nelson`.

    Parameters
    ----------
    model : Model
        The parametrised model.
    modes : Modes
        The lowest m modes of ``model`` at ``values``, mass-normalised; differentiate the lowest
        m_d < m of them (a buffer above, see
        :func:`~femupdate.sensitivity.subspace.buffered_modes`).
    which : sequence of int, optional
        Modes to differentiate (default all).
    params : sequence of int or str, optional
        Parameters (default the free ones).
    sensors : sequence of str or of int
        The measured dofs, required (the default None is refused; unknown labels raise
        :class:`InputError` naming them).
    values : None, mapping of str to float, or array_like, optional
        Parameter values of ``modes`` (default nominal).
    sigma, tol, lu, max_terms
        As for :func:`~femupdate.sensitivity.subspace`.
    series : {"krylov", "neumann"}, default "krylov"
        Galerkin (block Lanczos) acceleration of the series over the same mode-independent
        Krylov space, or its plain partial sums (:func:`~femupdate.sensitivity.series.omitted_modes_series`).
        The Krylov basis holds (terms × n_s) vectors; the acceleration about halves the solves.
    groups : sequence of (int, int), optional
        Groups of repeated or close modes (:func:`adjoint_details`).

    Returns
    -------
    dlam : ndarray (len(which), L)
        Eigenvalue derivatives (paper eq. 21).
    dphi_s : ndarray (n_s, len(which), L)
        Derivatives of the mass-normalised shapes at the sensors, in the order given.

    Raises
    ------
    InputError, NumericalError
        As :func:`adjoint_details`.
    """
    dlam, dphi_s, _ = adjoint_details(model, modes, which, params, sensors, values, sigma, tol, lu, max_terms, series,
                                      groups)
    return dlam, dphi_s


__all__ = ["adjoint", "adjoint_details", "resolve_sensors"]
