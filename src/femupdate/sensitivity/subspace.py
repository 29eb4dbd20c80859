r"""Eigenvector derivatives from the computed modes and ONE shifted factorisation: the omitted
modes' part summed as a Neumann series on the deflated complement (iterative technique).

With the m computed, mass-normalised modes Φ (n × m), a factorisation S = (K − σM)⁻¹ with
σ below every eigenvalue, and the right-hand side f = −(K' − λ_iM')φ_i + λ_i' Mφ_i
(:mod:`._common`), the derivative of mode i is

.. math::

    \phi_i' = \sum_{r \le m,\, r \ne i} \phi_r \frac{\phi_r^T f}{\lambda_r - \lambda_i}
              - \tfrac12 (\phi_i^T M' \phi_i)\, \phi_i + q, \qquad
    q = \sum_{r > m} \phi_r \frac{\phi_r^T f}{\lambda_r - \lambda_i}
      = \sum_{k \ge 0} (\lambda_i - \sigma)^k y_k,

    y_0 = P S P^T f, \quad y_k = P S M y_{k-1}, \qquad P = I - \Phi\Phi^T M,

because :math:`S M \phi_r = \phi_r / (\lambda_r - \sigma)` and P removes the computed modes.
The first term alone is Wang's (1991) static correction (with shift σ,
:func:`~femupdate.sensitivity.modal_static_correction`); the series converges geometrically
with ratio :math:`(\lambda_i - \sigma) / (\lambda_{m+1} - \sigma)`.  This is the iterative
technique of Rudisill & Chu (1975) and Ting's (1992) accelerated subspace iteration, written as
a Neumann series of the deflated operator P S M: every term costs one forward/backward
substitution with one factorisation for all modes — none per mode as in Nelson's method.

The terms T^k y_0 (T = P S M) do not depend on f's mode when f does not (the adjoint's sensor
columns), and they span a Krylov space in which the Galerkin solution of
(I − (λ_i − σ)T) q = y_0 converges like conjugate gradients — about twice as fast as the
partial sums (``series="krylov"`` of :func:`omitted_modes_series`; in the spirit of Ting's
acceleration).

**Differentiate the lowest m_d of m computed modes**: the ratio for the highest differentiated
mode is :math:`(\lambda_{m_d} - \sigma)/(\lambda_{m+1} - \sigma)`, so compute a buffer of modes
above it (:func:`buffered_modes`, the default: twice as many modes, at least 6 more; with a
spectrum growing like r² that gives a ratio near 0.25, about 17 Neumann terms or 10 Krylov
steps for ``tol = 1e-10``).  The modes must be the lowest m of the model (as
:func:`femupdate.model_modes` returns them): with a lower mode missing the Neumann series
diverges, which is detected and reported (the Krylov form still converges to the right answer,
the missing mode being part of the complement, but slowly).

References
----------
Rudisill, C.S., Chu, Y.-Y. (1975) Numerical methods for evaluating the derivatives of
eigenvalues and eigenvectors. AIAA Journal 13(6), 834–837.
Wang, B.P. (1991) Improved approximate methods for computing eigenvector derivatives in
structural dynamics. AIAA Journal 29(6), 1018–1020.
Ting, T. (1992) Accelerated subspace iteration for eigenvector derivatives. AIAA Journal
30(8), 2114–2118.

The factorisation and the solves with it are in :mod:`.factor`, the series in :mod:`.series`
(both re-exported here); this module is the forward route, :func:`subspace`.
"""

from __future__ import annotations

import numpy as np

from ._common import tangent, resolve_request
from .factor import check_modes, prepare_factor, single_thread_blas, solve
from .modal import group_mode_rhs, modal_part
from .series import DEFAULT_TOL, MAX_TERMS, omitted_modes_series


#: the modes' right-hand sides share one sweep of the series when its sums, (modes × n_dofs ×
#: modes × parameters) numbers, stay below this (40 MB); else one sweep per mode
JOINT_MAX_ENTRIES = 5_000_000


def buffered_modes(n_differentiated: int, n_dofs: int | None = None) -> int:
    """Number of modes to compute to differentiate the lowest ``n_differentiated`` by the
    series routes: ``max(2 m_d, m_d + 6)``, capped at ``n_dofs`` when given.

    Parameters
    ----------
    n_differentiated : int
        Number m_d of modes to differentiate.
    n_dofs : int, optional
        Model size (the cap).

    Returns
    -------
    int
    """
    m = max(2 * int(n_differentiated), int(n_differentiated) + 6)
    return m if n_dofs is None else min(m, int(n_dofs))


# ---------------------------------------------------------------------------------------------
# the forward route
# ---------------------------------------------------------------------------------------------
def subspace_details(model, modes, which=None, params=None, values=None, sigma=None, tol: float = DEFAULT_TOL,
                     lu=None, max_terms: int = MAX_TERMS, series: str = "neumann", groups=None):
    """:func:`subspace`, also returning the number of series terms used for each mode ``(m_d,)``.

    Parameters
    ----------
    model, modes, which, params, values, sigma, tol, lu, max_terms, series
        As :func:`subspace`.
    groups : sequence of (int, int), optional
        Groups of repeated or close modes ``(first, stop)``: a mode of ``which`` in one gets the
        derivative of the group's basis (the in-group modal coefficients −½ φ_rᵀM'φ_i; the
        omitted modes' series is the same, :mod:`femupdate.sensitivity.repeated`).

    Returns
    -------
    dlam : numpy.ndarray, shape ``(len(which), L)``
        Eigenvalue derivatives (paper eq. 21).
    dphi : numpy.ndarray, shape ``(n_dofs, len(which), L)``
        Derivatives of the mass-normalised shapes.
    n_terms : numpy.ndarray of int, shape ``(len(which),)``
        Series terms used per mode.

    Raises
    ------
    InputError
        Modes not mass-normalised or not on the model's dofs, indices out of range, a bad
        shift.
    NumericalError
        A rigid-body or repeated mode among ``which`` (outside ``groups``), or a series that does
        not converge in ``max_terms``.
    """
    check_modes(model, modes)
    model = tangent(model, values, modes)
    which, params, grouped = resolve_request(model, modes, which, params, groups)
    K, M = model.K(values), model.M(values)
    lu, sigma = prepare_factor(K, M, modes, sigma, lu)
    lam, Phi = modes.eigenvalues, modes.shapes
    n = model.n_dofs
    dlam = np.zeros((which.size, params.size))
    dphi = np.zeros((n, which.size, params.size))
    n_terms = np.zeros(which.size, dtype=int)
    L = params.size
    if 1 < which.size and which.size * n * which.size * L <= JOINT_MAX_ENTRIES:
        # one sweep for all the modes: the terms do not depend on the mode, so the right-hand
        # sides of every mode go through each solve together (fewer, wider solves; each mode
        # takes its own columns at its own shift, and the sweep runs until every mode's converge)
        rhs = [group_mode_rhs(model, modes, params, i, M, grouped) for i in which]
        Q, terms = omitted_modes_series(lu, M, Phi, np.hstack([F for _, F, *_ in rhs]), lam[which] - sigma, tol=tol,
                                        max_terms=max_terms, labels=[str(i + 1) for i in which], series=series)
        for r, (i, (dl, F, mjj, g, Ng)) in enumerate(zip(which, rhs)):
            dlam[r] = dl
            dphi[:, r, :] = modal_part(modes, i, F, mjj, g, Ng) + Q[r][:, r * L:(r + 1) * L]
        n_terms[:] = terms
        return dlam, dphi, n_terms
    for r, i in enumerate(which):
        dl, F, mjj, g, Ng = group_mode_rhs(model, modes, params, i, M, grouped)
        Q, n_terms[r] = omitted_modes_series(lu, M, Phi, F, [lam[i] - sigma], tol=tol, max_terms=max_terms,
                                             labels=[str(i + 1)], series=series)
        dlam[r] = dl
        dphi[:, r, :] = modal_part(modes, i, F, mjj, g, Ng) + Q[0]
    return dlam, dphi, n_terms


def subspace(model, modes, which=None, params=None, values=None, sigma=None, tol: float = DEFAULT_TOL, lu=None,
             max_terms: int = MAX_TERMS, series: str = "neumann", groups=None):
    r"""Eigenvalue and eigenvector derivatives from the computed modes plus the deflated series.

    φ_i' = Σ_{r≤m, r≠i} φ_r (φ_rᵀf)/(λ_r − λ_i) − ½(φ_iᵀM'φ_i)φ_i + Σ_k (λ_i − σ)^k y_k, with
    y_0 = P S Pᵀ f, y_k = P S M y_{k−1}, S = (K − σM)⁻¹, P = I − ΦΦᵀM (see the module
    docstring; Rudisill & Chu 1975, Ting 1992).  Exact to ``tol`` whatever the number of
    computed modes, provided they are the lowest of the model and a buffer lies above the
    differentiated ones.

    Parameters
    ----------
    model : Model
        The parametrised model.
    modes : Modes
        The lowest m modes of ``model`` at ``values``, mass-normalised.
    which : sequence of int, optional
        Modes to differentiate (default all; better the lowest m_d < m, see
        :func:`buffered_modes`).
    params : sequence of int or str, optional
        Parameters (default the free ones).
    values : None, mapping of str to float, or array_like, optional
        Parameter values of ``modes`` (default nominal).
    sigma : float, optional
        Shift of the factorisation, below every computed eigenvalue (default 0, or a small
        negative shift when there are rigid-body modes).
    tol : float, default ``DEFAULT_TOL``
        Relative accuracy of the omitted modes' part (see :func:`omitted_modes_series`).
    lu : object with ``.solve`` (e.g. SuperLU), or callable, optional
        Factorisation of K − σM to reuse; ``sigma`` must then be its shift (default 0).
    max_terms : int, default ``MAX_TERMS``
        Cap on the series; :class:`NumericalError` names the mode when it is not enough.
    series : {"neumann", "krylov"}, default "neumann"
        Partial sums, or the Galerkin (block Lanczos) acceleration of
        :func:`omitted_modes_series`; the latter stores (terms × L) vectors per mode, so use it
        with few parameters.
    groups : sequence of (int, int), optional
        Groups of repeated or close modes (:func:`subspace_details`).

    Returns
    -------
    dlam : ndarray (len(which), L)
    dphi : ndarray (n_dofs, len(which), L)
        Derivatives of the mass-normalised shapes.

    Raises
    ------
    InputError, NumericalError
        As :func:`subspace_details`.
    """
    dlam, dphi, _ = subspace_details(model, modes, which, params, values, sigma, tol, lu, max_terms, series, groups)
    return dlam, dphi


__all__ = ["subspace", "subspace_details", "omitted_modes_series", "buffered_modes", "single_thread_blas",
           "prepare_factor", "solve"]
