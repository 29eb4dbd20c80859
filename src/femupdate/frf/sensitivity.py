r"""Receptance sensitivities by Brandon's expression (paper eq. 32).

.. math::  \frac{\partial \alpha(\omega_i)}{\partial p_j}
           = -\,\alpha(\omega_i)\,\frac{\partial Z(\omega_i)}{\partial p_j}\,\alpha(\omega_i),
           \qquad \frac{\partial Z}{\partial p_j} = c_K K_j + c_M M_j
           \quad (= K_j - \omega_i^2 M_j \text{ undamped}),

the exact derivative of :math:`\alpha = Z^{-1}` (differentiate :math:`Z\alpha = I`).  Only the
measured block is needed: rows R (response dofs) and columns E (excitation dofs).  Z is
symmetric, so :math:`\alpha_{R,:} = (\alpha_{:,R})^T` and

.. math::  \partial\alpha_{RE}/\partial p_j = -\,Y_R^T\,(c_K K_j + c_M M_j)\,X_E,
           \qquad Y_R = Z^{-1} I_{:,R},\ X_E = Z^{-1} I_{:,E}:

ONE factorisation per line and ``|R| + |E|`` solves with it serve every parameter; the
parameters then cost only the bilinear forms above, all of them at once from the stored
entries of the :math:`K_j` (:class:`~femupdate.frf.lines.ParameterForms`).  Perturbation
would need two factorisations per parameter and line.

Near a resonance the derivative is still exact, but it describes the receptance only over a
shrinking range of parameter change: a relative change δ moves the nearest eigenvalue by
about :math:`\delta\, s\,\lambda_r` (s: its relative sensitivity), and the first-order
prediction is wrong by about :math:`\delta s / d` relative, d the line's relative distance to
the resonance (He 1993; :meth:`Resonances.first_order_error`).  Central differences suffer the
same way (truncation error :math:`\propto (h s / d)^2`).  The result carries each line's
distance to resonance and these indicators; lines within ``resonance_tol`` are reported.
"""

from __future__ import annotations

import logging
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from .. import modal
from .._docs import FORCE, FRF_LINES, shared_docs
from .._errors import InputError
from ..dofs import canonical_all
from .damping import as_damping
from .lines import LineSystems, ParameterForms, check_omega, factor, force_vector, line_name, lu_apply
from .resonance import Resonances, collect_resonances, nearest_mode, resonances
from .simulate import response_dofs

log = logging.getLogger(__name__)

#: lines closer than this relative eigenvalue distance to a resonance are reported
RESONANCE_TOL = 1e-3


@dataclass(frozen=True, eq=False)
class ReceptanceSensitivity:
    """Receptances of the measured block and their parameter derivatives.

    Attributes
    ----------
    omega : ndarray (n_lines,)
    response, excitation : tuple of str
        Row and column dof labels.
    params : tuple of str
    values : ndarray
        The full parameter vector they were evaluated at.
    alpha : ndarray (n_lines, n_response, n_excitation)
    dalpha : ndarray (n_lines, n_response, n_excitation, L)
    resonances : Resonances or None
        Distance of each line to the nearest resonance, that mode's relative sensitivities
        and the first-order error estimate (None when not checked).
    near_resonance : ndarray of int
        Lines within ``resonance_tol`` of a resonance.
    """

    omega: np.ndarray
    response: tuple[str, ...]
    excitation: tuple[str, ...]
    params: tuple[str, ...]
    values: np.ndarray
    alpha: np.ndarray
    dalpha: np.ndarray
    resonances: Resonances | None
    near_resonance: np.ndarray

    def for_force(self, force: Mapping) -> tuple[np.ndarray, np.ndarray]:
        """Response ``x = α f`` ``(n_lines, n_response)`` and ``∂x/∂p`` ``(n_lines, n_response, L)``
        for a force acting on (some of) the excitation dofs.

        Parameters
        ----------
        force : mapping of str to float or complex
            Force amplitude (N) per loaded dof; excitation dofs not listed carry no force.

        Returns
        -------
        x : numpy.ndarray, shape ``(n_lines, n_response)``
            Response amplitudes, m (rad at rotations).
        dx : numpy.ndarray, shape ``(n_lines, n_response, L)``
            Their derivatives with respect to ``params``.

        Raises
        ------
        InputError
            A malformed or repeated dof label, or a dof that is not an excitation dof.
        """
        labels = canonical_all(force, "force")
        extra = [d for d in labels if d not in self.excitation]
        if extra:
            raise InputError(f"force at dof(s) {', '.join(extra)} that are not among the excitation dofs {list(self.excitation)}")
        f = np.zeros(len(self.excitation), dtype=complex if any(isinstance(v, complex) for v in force.values()) else float)
        for d, v in zip(labels, force.values()):
            f[self.excitation.index(d)] = v
        return self.alpha @ f, np.einsum("lrej,e->lrj", self.dalpha, f)


def _param_indices(model, params) -> list[int]:
    if params is None:
        return [int(j) for j in model.free]
    return [model.parameter_index(nm) for nm in params]


@shared_docs(FRF_LINES=FRF_LINES, FORCE=FORCE)
def receptance_sensitivity(model, omega, response: Sequence[str] | None, excitation: Sequence[str],
                           params: Sequence[str] | None = None, values=None, damping=None, method: str = "auto",
                           resonance_check: bool | str = "auto", resonance_tol: float = RESONANCE_TOL) -> ReceptanceSensitivity:
    r"""Brandon's receptance sensitivities (eq. 32) for the block (response × excitation).

    Parameters
    ----------
    {{FRF_LINES}}
    response : sequence of str or None
        Dof labels of the rows (None: every model dof — only sensible for small models).
    excitation : sequence of str
        Dof labels of the columns.
    params : sequence of str, optional
        Parameter names (default every parameter not ``fixed``).
    values : None, mapping of str to float, or array_like, optional
        Parameter values (default nominal).
    damping : Damping or mapping, optional
        :class:`~femupdate.frf.Damping` or ``{alpha, beta, eta}`` (default undamped).
    method : {"auto", "dense", "sparse"}, default "auto"
        Stacked dense solves of all lines for small models (``"auto"``: up to ``DENSE_LIMIT`` dofs);
        one sparse LU per line, reused for every right-hand side and parameter.
    resonance_check : bool or "auto", default "auto"
        Compute each line's distance to resonance (``"auto"``: all but large damped models, which
        would need a second, real, factorisation per line).  Large undamped models reuse the
        line's factor for a k = 1 shift-invert Lanczos search.
    resonance_tol : float, default ``RESONANCE_TOL``
        Lines closer than this (relative eigenvalue distance) are reported in ``near_resonance``
        and logged as a warning.

    Returns
    -------
    ReceptanceSensitivity

    Raises
    ------
    InputError
        Bad frequencies; unknown dofs or parameters, or no parameter to differentiate; bad
        damping; an unknown ``method``.
    NumericalError
        A line lies exactly on a resonance of an undamped model (singular dynamic stiffness).
    """
    w = check_omega(omega)
    damping = as_damping(damping)
    p = model.resolve(values)
    idx = _param_indices(model, params)
    if not idx:
        raise InputError("no parameters to differentiate with respect to")
    L = len(idx)
    r_labels, ir = response_dofs(model, response)
    e_labels, ie = response_dofs(model, excitation, "excitation")
    n = model.n_dofs
    nr, ne = ir.size, ie.size
    # right-hand sides: unit vectors at the excitation dofs, then at the response dofs
    B = np.zeros((n, ne + nr))
    B[ie, np.arange(ne)] = 1.0
    B[ir, ne + np.arange(nr)] = 1.0
    forms = ParameterForms(model, idx, p)
    sys_ = LineSystems(model, p, w, damping, method)
    small = n <= modal.DENSE_LIMIT  # every eigenvalue densely; above, a Lanczos search per line
    check = resonance_check if resonance_check != "auto" else (damping.undamped or small)
    alpha = np.empty((w.size, nr, ne), dtype=complex if sys_.complex else float)
    dalpha = np.empty((w.size, nr, ne, L), dtype=alpha.dtype)

    def block(i, X):
        XE, YR = X[:, :ne], X[:, ne:]
        alpha[i] = XE[ir]
        dalpha[i] = -np.moveaxis(forms(YR, XE, sys_.cK[i], sys_.cM[i]), 0, -1)  # Y_R^T dZ_j X_E, every j

    res = None
    if sys_.dense:
        X = sys_.solve(B)
        for i in range(w.size):
            block(i, X[i])
        if check:
            res = resonances(model, w, p, idx)
    else:
        nearest = np.empty(w.size)
        Phi = np.empty((n, w.size)) if check else None
        for i, lu in sys_.each():
            block(i, lu_apply(lu, B))
            if check and not small:
                if Phi is None:  # allocated whenever check is set
                    raise RuntimeError("internal error: the resonance check's mode array was not allocated")
                where = line_name(i, w[i])
                real_lu = lu if damping.undamped else factor(sp.csc_array(sys_.K - w[i] ** 2 * sys_.M), where)
                nearest[i], Phi[:, i] = nearest_mode(sys_.K, sys_.M, w[i] ** 2, real_lu, where)
        if check:
            res = resonances(model, w, p, idx) if small else collect_resonances(model, p, w, nearest, Phi, np.full(w.size, -1), idx)
    near = res.near(resonance_tol) if res is not None else np.zeros(0, dtype=np.intp)
    if near.size:
        if res is None:  # near is empty without resonances
            raise RuntimeError("internal error: lines near resonance without a resonance check")
        log.warning("receptance sensitivities near resonance (first-order predictions hold only for small changes): %s",
                    res.describe(near))
    return ReceptanceSensitivity(w, r_labels, e_labels, tuple(model.parameter_names[j] for j in idx), p,
                                 alpha, dalpha, res, near)


#: the paper's name for eq. 32
brandon = receptance_sensitivity


@shared_docs(FRF_LINES=FRF_LINES, FORCE=FORCE)
def receptance_fd(model, omega, response: Sequence[str] | None, excitation: Sequence[str],
                  params: Sequence[str] | None = None, values=None, damping=None, rel_step: float = 1e-6,
                  method: str = "auto") -> np.ndarray:
    """Central finite differences of the receptance block (the test oracle of eq. 32):
    ``(n_lines, n_response, n_excitation, L)``, step ``rel_step * max(|p_j|, 1)``.

    Two factorisations per parameter and line: what Brandon's expression avoids.

    Parameters
    ----------
    {{FRF_LINES}}
    response : sequence of str or None
        Response dofs (``None``: every model dof).
    excitation : sequence of str
        Excitation dofs.
    params : sequence of str, optional
        Parameters differentiated (default as :func:`receptance_sensitivity`).
    values : None, mapping of str to float, or array_like, optional
        Parameter values (default nominal).
    damping : Damping or mapping, optional
        Default undamped.
    rel_step : float, default 1e-6
        Relative step.
    method : str, default ``"auto"``
        Line solver: ``"auto"``, ``"dense"`` or ``"sparse"``.

    Returns
    -------
    numpy.ndarray, shape ``(n_lines, n_response, n_excitation, L)``
        ∂α/∂p_j (receptance per unit of p_j).

    Raises
    ------
    InputError
        Unknown dofs or parameters; bad frequencies.
    """
    w = check_omega(omega)
    damping = as_damping(damping)
    p = model.resolve(values)
    idx = _param_indices(model, params)
    _, ir = response_dofs(model, response)
    _, ie = response_dofs(model, excitation, "excitation")
    E = np.zeros((model.n_dofs, ie.size))
    E[ie, np.arange(ie.size)] = 1.0
    out = []
    for j in idx:
        h = rel_step * max(abs(p[j]), 1.0)
        sides = []
        for sgn in (1.0, -1.0):
            q = p.copy()
            q[j] += sgn * h
            sides.append(LineSystems(model, q, w, damping, method).solve(E)[:, ir, :])
        out.append((sides[0] - sides[1]) / (2 * h))
    return np.stack(out, axis=-1)


@dataclass(frozen=True, eq=False)
class FirstOrderCheck:
    """Brandon's first-order prediction against the exact change, line by line.

    ``exact`` and ``predicted`` ``(n_lines, n_response)`` are the changes of the response to a
    relative parameter change ``delta``; ``error`` their relative difference per line;
    ``estimate`` the a-priori indicator δ|s|/d of :meth:`Resonances.first_order_error`.

    Parameters
    ----------
    omega : numpy.ndarray, shape ``(n_lines,)``
        Spectral lines, rad/s.
    param : str
        The parameter changed.
    delta : float
        Relative change: p → p (1 + delta).
    exact : numpy.ndarray, shape ``(n_lines, n_response)``
        Exact change of the response, m.
    predicted : numpy.ndarray, shape ``(n_lines, n_response)``
        First-order (eq. 32) prediction of that change, m.
    error : numpy.ndarray, shape ``(n_lines,)``
        ‖predicted − exact‖ / ‖exact‖ per line (norms over the response dofs).
    estimate : numpy.ndarray, shape ``(n_lines,)``
        A-priori estimate δ|s|/d of that error.
    distance : numpy.ndarray, shape ``(n_lines,)``
        Relative distance d = ``|ω² − λ|`` / max(λ, ω²) of each line to the nearest resonance.
    """

    omega: np.ndarray
    param: str
    delta: float
    exact: np.ndarray
    predicted: np.ndarray
    error: np.ndarray
    estimate: np.ndarray
    distance: np.ndarray


@shared_docs(FRF_LINES=FRF_LINES, FORCE=FORCE)
def first_order_check(model, omega, force: Mapping, param: str, delta: float, response: Sequence[str] | None = None,
                      values=None, damping=None) -> FirstOrderCheck:
    """How well eq. 32 predicts the response change for a finite relative change ``delta`` of
    ``param``: the loss of accuracy near resonances, measured (He 1993).

    Parameters
    ----------
    {{FRF_LINES}}
    {{FORCE}}
    param : str
        The parameter changed.
    delta : float
        Relative change: p → p (1 + delta).
    response : sequence of str, optional
        Response dofs (default every model dof).
    values : None, mapping of str to float, or array_like, optional
        Parameter values of the reference model (default nominal).
    damping : Damping or mapping, optional
        Default undamped.

    Returns
    -------
    FirstOrderCheck

    Raises
    ------
    InputError
        An unknown parameter or dof; a malformed force; bad frequencies; a damped model above
        ``modal.DENSE_LIMIT`` dofs (the resonance check the estimate needs is not run there).
    """
    p = model.resolve(values)
    j = model.parameter_index(param)
    f = force_vector(model, force)
    sens = receptance_sensitivity(model, omega, response, [model.dofs[k] for k in np.flatnonzero(f)], [param], p, damping,
                                  resonance_tol=0.0)
    x0, dx = sens.for_force({model.dofs[k]: f[k] for k in np.flatnonzero(f)})
    q = p.copy()
    q[j] *= 1 + delta
    _, ir = response_dofs(model, response)
    damping = as_damping(damping)
    x1 = LineSystems(model, q, sens.omega, damping).solve(f)[:, ir]
    exact = x1 - x0
    pred = dx[..., 0] * (q[j] - p[j])
    err = np.linalg.norm(pred - exact, axis=1) / np.maximum(np.linalg.norm(exact, axis=1), np.finfo(float).tiny)
    res = sens.resonances
    if res is None:  # no resonance check (damped model above modal.DENSE_LIMIT dofs)
        raise InputError("first_order_check needs the resonance check, which is not run for damped models above "
                         f"{modal.DENSE_LIMIT} dofs; check the first-order error on an undamped or smaller model")
    est = res.first_order_error(delta)[:, 0]
    return FirstOrderCheck(sens.omega, param, float(delta), exact, pred, err, est, res.distance)
