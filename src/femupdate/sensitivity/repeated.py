r"""Derivatives of repeated and close modes: of their eigenvalues and of the subspace they span.

Symmetric structures (a square plan, a square plate) have repeated eigenvalues; nearly symmetric
ones have close eigenvalues.  Inside such a *group* G of modes (modes ``first .. stop − 1``,
eigenvalues Λ_G, shapes Φ_G with Φ_GᵀMΦ_G = I) the individual eigenvectors are not
differentiable — for a repeated eigenvalue they are not even unique: any rotation Φ_G Q of them is
as good — and for close ones their derivatives carry 1/(λ_g − λ_h) and are worthless beyond a tiny
step.  What is differentiable is the group as a whole: the subspace it spans (its spectral
projector P = Φ_GΦ_GᵀM, as long as the group is separated from the other modes), and the
eigenproblem restricted to it.

**The group's basis with no rotation inside the group.**  Let B(p) be an M-orthonormal basis of
the group's subspace with B(p₀) = Φ_G that does not rotate inside the subspace
(Φ_GᵀM B' symmetric).  Its derivative splits into the part outside the group, which the usual
formulas give mode by mode over the other modes (modal expansion, Nelson's solve — made regular by
the bordered system [[K − λ_g M, MΦ_G], [Φ_GᵀM, 0]] —, the deflated series), and the part inside,
fixed by BᵀMB = I:

.. math::

    B'_g = \sum_{m \notin G} \phi_m \frac{\phi_m^T (K' - \lambda_g M')\phi_g}{\lambda_g - \lambda_m}
           - \tfrac12 \Phi_G \Phi_G^T M' \phi_g .

Every route of :func:`femupdate.sensitivity.jacobian` returns it for the modes of ``groups``
(``groups=``).  A quantity that does not depend on the choice of basis inside the group — the
subspace, the projector P, the best fit of a measured shape by the group's shapes — has its exact
derivative through B'.

**The restricted eigenproblem.**  A(p) = BᵀKB (r × r) has the group's eigenvalues as its
eigenvalues, and

.. math:: A' = \Phi_G^T K' \Phi_G - \tfrac12 (N \Lambda_G + \Lambda_G N), \qquad N = \Phi_G^T M' \Phi_G

(:func:`restricted_derivatives`).  For an exactly repeated eigenvalue λ this is
D = Φ_Gᵀ(K' − λM')Φ_G, the matrix of Mills-Curran (1988) and Dailey (1989): its eigenvalues are
the derivatives of the eigenvalues that split from λ along the parameter (so the sum of the
group's eigenvalues, tr A, is differentiable while each one alone is only directionally so), and
its eigenvectors Y give the *adjacent eigenvectors* X = Φ_G Y, the limits of the eigenvectors as
the parameter moves.  :func:`adjacent_eigenvectors` returns them with their derivatives along one
direction of the parameters by Dailey's method (the in-group part from the second-order
equation; femupdate's models are affine in their parameters, so K'' = M'' = 0).

**Which modes make a group.**  :func:`~femupdate.close_modes.mode_groups` chains neighbouring modes
whose relative eigenvalue gap is below a tolerance (:func:`femupdate.rules.group_bounds`).  Updating groups
modes closer than :data:`femupdate.rules.CLOSE_TOL` (0.01; :class:`femupdate.options.ModalOptions`
``close_modes``): see :mod:`femupdate.updating.groups` for what it compares in a group.

References
----------
Mills-Curran, W.C. (1988) Calculation of eigenvector derivatives for structures with repeated
eigenvalues. AIAA Journal 26(7), 867–871.
Dailey, R.L. (1989) Eigenvector derivatives with repeated eigenvalues. AIAA Journal 27(4),
486–491.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .. import rules
from .._errors import InputError, NumericalError
from ..close_modes import mode_groups
from ..modal import model_modes
from ._common import tangent, param_products, resolve_groups, resolve_params


def restricted_derivatives(model, modes, group, params=None, values=None) -> np.ndarray:
    r"""∂A/∂p_j of the eigenproblem restricted to a group: A = BᵀKB, B the group's M-orthonormal
    basis with no rotation inside the group (module docstring).

    .. math:: A'_{hg} = \phi_h^T K_j \phi_g - \tfrac12 (\lambda_h + \lambda_g)\, \phi_h^T M_j \phi_g

    For an exactly repeated eigenvalue this is Mills-Curran's and Dailey's
    D_j = Φ_Gᵀ(K_j − λM_j)Φ_G, whose eigenvalues are the derivatives of the eigenvalues that
    split from λ along p_j; its diagonal is Fox & Kapoor's λ' of each computed mode, its trace the
    derivative of the sum of the group's eigenvalues.

    Parameters
    ----------
    model : Model
        The model (affine in its parameters).
    modes : Modes
        Mass-normalised modes of ``model`` at ``values``.
    group : (int, int)
        ``(first, stop)``: modes first .. stop − 1 of ``modes``.
    params : sequence of int or str, optional
        Parameters (default the free ones); L = ``len(params)``.
    values : None, mapping of str to float, or array_like, optional
        Parameter values of ``modes`` (default nominal): where the model is linearised when
        parameters enter non-linearly.

    Returns
    -------
    numpy.ndarray, shape ``(r, r, L)``
        Symmetric in its first two axes; rad²/s² per unit of the parameter.

    Raises
    ------
    InputError
        Modes not mass-normalised; a bad group or parameter.
    """
    if modes.normalisation != "mass":
        raise InputError(f"sensitivities need mass-normalised modes, got {modes.normalisation!r}")
    model = tangent(model, values, modes)
    params = resolve_params(model, params)
    a, b = _group(modes, group)
    lam, Phi = modes.eigenvalues[a:b], modes.shapes[:, a:b]
    r = b - a
    dA = np.zeros((r, r, params.size))
    for g in range(r):
        Kp, Mp = param_products(model, params, Phi[:, g])
        dA[:, g, :] = Phi.T @ Kp - 0.5 * (lam[:, None] + lam[g]) * (Phi.T @ Mp)
    return 0.5 * (dA + dA.transpose(1, 0, 2))


@dataclass(frozen=True, eq=False)
class AdjacentEigenvectors:
    """Dailey's (1989) adjacent eigenvectors of a repeated eigenvalue along one direction of the
    parameters (:func:`adjacent_eigenvectors`).

    Attributes
    ----------
    eigenvalue : float
        The repeated eigenvalue λ (the mean of the group's computed ones), rad²/s².
    dlam : numpy.ndarray, shape ``(r,)``
        Derivatives of the eigenvalues that split from λ along the direction, ascending.
    vectors : numpy.ndarray, shape ``(n_dofs, r)``
        The adjacent eigenvectors X = Φ_G Y (mass-normalised; the limits of the eigenvectors on
        each branch), column g the branch of ``dlam[g]``.
    derivatives : numpy.ndarray, shape ``(n_dofs, r)``
        Their derivatives along the direction.
    """

    eigenvalue: float
    dlam: np.ndarray
    vectors: np.ndarray
    derivatives: np.ndarray


def adjacent_eigenvectors(model, modes, group, direction, params=None, values=None) -> AdjacentEigenvectors:
    r"""Derivatives of the eigenvectors of a repeated eigenvalue along a direction of the parameters:
    Mills-Curran's (1988) and Dailey's (1989) method.

    Along p = p₀ + t d the eigenvalues that split from λ and their eigenvectors are analytic in t
    (Rellich).  With K' = Σ_j d_j K_j, M' likewise, D = Φ_Gᵀ(K' − λM')Φ_G = Y diag(μ) Yᵀ:

    * the eigenvalues' derivatives are μ, the adjacent eigenvectors X = Φ_G Y;
    * x_g' = v_g + Σ_h c_hg x_h, v_g the part outside the group (the bordered solve of
      :func:`~femupdate.sensitivity.nelson`), c_gg = −½ x_gᵀM'x_g and, from the second derivative
      of the eigenproblem projected on x_h (K'' = M'' = 0 for an affine model),
      c_hg = (x_hᵀ(K' − λM')v_g − μ_g x_hᵀM'x_g) / (μ_g − μ_h).

    Parameters
    ----------
    model : Model
        The model (affine in its parameters).
    modes : Modes
        Mass-normalised modes of ``model`` at ``values``, the whole group among them.
    group : (int, int)
        ``(first, stop)`` of the repeated modes (e.g. from
        :func:`~femupdate.close_modes.mode_groups`); their eigenvalues must agree to :data:`femupdate.rules.REPEATED_TOL`.
    direction : array_like of float, shape ``(L,)``
        The direction d in the parameters ``params``.
    params : sequence of int or str, optional
        Parameters (default the free ones).
    values : None, mapping of str to float, or array_like, optional
        Parameter values of ``modes`` (default nominal).

    Returns
    -------
    AdjacentEigenvectors

    Raises
    ------
    InputError
        A bad group, direction or parameter; a group whose eigenvalues are not repeated (close
        modes have their own derivatives: :func:`~femupdate.sensitivity.nelson`).
    NumericalError
        The direction does not split the eigenvalue at first order (repeated μ): the adjacent
        eigenvectors are then not determined by D.
    """
    from ..coefficients import route_refusal
    from .nelson import nelson

    # Dailey's derivatives need the second derivatives K'' and M'' along the direction, zero only when
    # the parameters enter linearly (the tangent model has none)
    route_refusal(model, "adjacent_eigenvectors (Dailey's eigenvector derivatives of a repeated eigenvalue, "
                         "which take K'' = M'' = 0)")
    params = resolve_params(model, params)
    d = np.asarray(direction, dtype=float).ravel()
    if d.shape != (params.size,) or not np.all(np.isfinite(d)):
        raise InputError(f"direction: give {params.size} finite numbers, one per parameter, got {direction!r}")
    a, b = _group(modes, group)
    lam_g = modes.eigenvalues[a:b]
    lam = float(np.mean(lam_g))
    if np.ptp(lam_g) > rules.REPEATED_TOL * abs(lam):
        raise InputError(f"modes {a + 1}-{b} are not repeated (relative spread {np.ptp(lam_g) / abs(lam):.3g}): "
                         "Dailey's method is for a repeated eigenvalue; differentiate close modes one by one")
    Phi = modes.shapes[:, a:b]
    D = restricted_derivatives(model, modes, (a, b), params) @ d
    mu, Y = np.linalg.eigh(0.5 * (D + D.T))
    spread = max(float(np.abs(mu).max()), 1e-300)
    if mu.size > 1 and np.min(np.diff(mu)) <= 1e-8 * spread:
        raise NumericalError(f"the direction does not split the repeated eigenvalue of modes {a + 1}-{b} at first "
                             f"order (derivatives {mu}): the adjacent eigenvectors are not determined by it")
    X = Phi @ Y
    _, dB = nelson(model, modes, np.arange(a, b), params, values, groups=[(a, b)])
    KX, MX = _directional_products(model, params, X, d)
    NX = X.T @ MX  # Xᵀ M' X
    V = (dB @ d) @ Y + 0.5 * X @ NX  # the parts outside the group
    KV, MV = _directional_products(model, params, V, d)
    G = X.T @ (KV - lam * MV)  # x_hᵀ (K' − λM') v_g
    r = b - a
    C = np.zeros((r, r))
    for g in range(r):
        for h in range(r):
            C[h, g] = -0.5 * NX[g, g] if h == g else (G[h, g] - mu[g] * NX[h, g]) / (mu[g] - mu[h])
    return AdjacentEigenvectors(lam, mu, X, V + X @ C)


def _group(modes, group) -> tuple[int, int]:
    """``group`` checked as :func:`~._common.resolve_groups` checks it: (first, stop)."""
    resolve_groups(modes, np.zeros(0, np.intp), [group])
    return int(group[0]), int(group[1])


def _directional_products(model, params, V: np.ndarray, d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """K'V and M'V along the direction d (K' = Σ_j d_j K_j), columns of V."""
    KV, MV = np.zeros_like(V), np.zeros_like(V)
    for c in range(V.shape[1]):
        Kp, Mp = param_products(model, params, V[:, c])
        KV[:, c], MV[:, c] = Kp @ d, Mp @ d
    return KV, MV


def group_basis(modes_at, group, Phi0: np.ndarray, M0) -> np.ndarray:
    """The basis of a group's subspace at another point that does not rotate inside the group with
    respect to ``Phi0`` (the group's shapes at the reference point): Φ_G U, U the orthogonal
    polar factor that makes Phi0ᵀ M0 Φ_G U symmetric positive definite.

    Parameters
    ----------
    modes_at : Modes
        Mass-normalised modes at the other point.
    group : (int, int)
        ``(first, stop)``.
    Phi0 : numpy.ndarray, shape ``(n_dofs, r)``
        The group's shapes at the reference point.
    M0 : sparse or dense matrix, shape ``(n_dofs, n_dofs)``
        The mass matrix at the reference point.

    Returns
    -------
    numpy.ndarray, shape ``(n_dofs, r)``
    """
    a, b = group
    P = modes_at.shapes[:, a:b]
    W = np.asarray(Phi0.T @ (M0 @ P))  # Φ0ᵀ M0 Φ_G(p)
    Yl, _, Zt = np.linalg.svd(W)
    return P @ (Zt.T @ Yl.T)


def group_finite_difference(model, group, values=None, params=None, n_modes: int | None = None,
                            rel_step: float = 1e-5, base=None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Central differences of a group's basis with no rotation inside the group
    (:func:`group_basis`), of its restricted stiffness A = BᵀKB and of its sorted eigenvalues:
    the test oracle of the analytical routes (``method="fd"`` of :func:`~femupdate.sensitivity.jacobian`).

    Parameters
    ----------
    model : Model
        The model.
    group : (int, int)
        ``(first, stop)`` of the group among the lowest modes.
    values : None, mapping of str to float, or array_like, optional
        The point (default nominal).
    params : sequence of int or str, optional
        Parameters (default the free ones).
    n_modes : int, optional
        Modes computed per eigen-solution (default: ``stop`` + 6).
    rel_step : float, default 1e-5
        Step relative to ``max(|p_j|, 1e-12)``.
    base : Modes, optional
        The modes at the point whose group shapes the basis starts from (inside a repeated group
        the computed basis is arbitrary, and the derivative follows it); default: computed here.

    Returns
    -------
    dB : numpy.ndarray, shape ``(n_dofs, r, L)``
        The basis' derivatives.
    dA : numpy.ndarray, shape ``(r, r, L)``
        The restricted stiffness' derivatives.
    dlam : numpy.ndarray, shape ``(r, L)``
        Central differences of the group's eigenvalues as a sorted set (meaningful where they
        stay repeated, or as a check of the eigenvalues of ``dA`` where they split).
    """
    a, b = group
    p0 = model.resolve(values)
    params = resolve_params(model, params)
    n_modes = n_modes or min(model.n_dofs, b + 6)
    base = base if base is not None else model_modes(model, p0, n_modes=n_modes)
    Phi0, M0 = base.shapes[:, a:b], model.M(p0)
    r = b - a
    dB = np.zeros((model.n_dofs, r, params.size))
    dA = np.zeros((r, r, params.size))
    dlam = np.zeros((r, params.size))
    for c, j in enumerate(params):
        h = rel_step * max(abs(p0[j]), 1e-12)
        sides = []
        for sgn in (1.0, -1.0):
            p = p0.copy()
            p[j] += sgn * h
            at = model_modes(model, p, n_modes=n_modes)
            B = group_basis(at, group, Phi0, M0)
            sides.append((B, np.asarray(B.T @ (model.K(p) @ B)), at.eigenvalues[a:b]))
        dB[:, :, c] = (sides[0][0] - sides[1][0]) / (2 * h)
        dA[:, :, c] = (sides[0][1] - sides[1][1]) / (2 * h)
        dlam[:, c] = (sides[0][2] - sides[1][2]) / (2 * h)
    return dB, dA, dlam


__all__ = ["mode_groups", "restricted_derivatives", "adjacent_eigenvectors", "AdjacentEigenvectors",
           "group_basis", "group_finite_difference"]
