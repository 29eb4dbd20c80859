r"""The sensitivity (Jacobian) matrix that sensitivity-based updating uses: one entry point.

For the differentiated modes i and the parameters j it returns the eigenvalue derivatives —
relative, :math:`(\partial\lambda_i/\partial p_j)/\lambda_i`, as in the paper's eq. 19 — and the
derivatives of the measured shapes in the scaling in which they are compared with the test
(:func:`~femupdate.sensitivity.scaled_shape`).  Any of the routes can produce it:

==========  ===============================================================================
``nelson``    Nelson (1976), exact; one factorisation per mode (dense below 1,500 dofs)
``modal``     modal superposition over the modes given (exact only with all of them)
``static``    truncated modes + Wang's (1991) static correction
``subspace``  modes + deflated Neumann series with one factorisation (Rudisill & Chu; Ting)
``adjoint``   the same series for the sensors only: cost ∝ sensors × modes, not parameters
``fd``        central finite differences (test oracle; two eigensolutions per parameter)
==========  ===============================================================================

``method="auto"`` takes ``nelson`` for models of up to 1,500 dofs (dense, cheap), and for larger
ones ``adjoint`` when there are fewer sensors than parameters, else ``subspace``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._checks import choice_arg, flag_arg, indices_arg, model_arg, modes_arg, real_arg, swapped, values_arg
from .._errors import InputError, NumericalError
from ..dofs import canonical
from ..options.choices import SENSITIVITY_ROUTES
from ..modal import DENSE_LIMIT  # models up to this size take Nelson's method under "auto"
from ._common import check_distinct, resolve_groups, resolve_params, resolve_which, tangent
from .adjoint import adjoint_details, resolve_sensors
from .factor import check_modes, prepare_factor
from .finite_difference import finite_difference
from .modal import group_mode_rhs, modal_part, modal, modal_static_correction
from .nelson import nelson
from .repeated import group_finite_difference, restricted_derivatives
from .scaling import scaled_shape
from .series import DEFAULT_TOL, omitted_modes_series
from .subspace import subspace_details

METHODS = SENSITIVITY_ROUTES  #: the derivative routes (femupdate.options.SENSITIVITY_ROUTES)
SCALINGS = ("ref", "max", "unit", "mass")


@dataclass(frozen=True, eq=False)
class JacobianResult:
    """Sensitivities of the paired quantities, as sensitivity-based updating consumes them.

    Built by :func:`jacobian`; each parameter is stored as the attribute of the same name.

    Parameters
    ----------
    dlam : ndarray (m_d, L)
        ∂λ_i/∂p_j, divided by λ_i when ``relative_eigenvalues`` (the paper's eq. 19).
    psi : ndarray (n_s, m_d)
        The model's measured shapes, scaled as ``shape_scaling`` says.
    dpsi : ndarray (n_s, m_d, L)
        Their derivatives ∂ψ/∂p_j.
    method : str
        The route used (``"auto"`` resolved).
    n_terms : int
        Series terms (solves) used by ``subspace`` / ``adjoint`` (the largest over the modes),
        0 for the other routes.
    which : ndarray (m_d,)
        Indices of the differentiated modes in the ``Modes`` given.
    eigenvalues : ndarray (m_d,)
        Their eigenvalues λ_i (rad²/s²).
    sensors : tuple of str
        Labels of the measured dofs (rows of ``psi``).
    parameters : tuple of str
        Names of the parameters (last axis).
    shape_scaling : str
    ref : tuple of int, or None
        Position among the sensors of each mode's reference dof (``"ref"`` scaling).
    relative_eigenvalues : bool
    groups : tuple of (int, int)
        The groups of repeated or close modes differentiated as groups (``groups`` of
        :func:`jacobian`, those with a mode in ``which``); for their modes ``dpsi`` is the
        derivative of the group's basis with no rotation inside the group and ``dlam`` the
        diagonal of ``restricted`` (:mod:`femupdate.sensitivity.repeated`).
    restricted : tuple of numpy.ndarray
        Per group, ∂A/∂p (r, r, L) of its restricted eigenproblem
        (:func:`~femupdate.sensitivity.repeated.restricted_derivatives`; not divided by λ).
    """

    dlam: np.ndarray
    psi: np.ndarray
    dpsi: np.ndarray
    method: str
    n_terms: int
    which: np.ndarray
    eigenvalues: np.ndarray
    sensors: tuple[str, ...]
    parameters: tuple[str, ...]
    shape_scaling: str
    ref: tuple[int, ...] | None
    relative_eigenvalues: bool
    groups: tuple[tuple[int, int], ...] = ()
    restricted: tuple[np.ndarray, ...] = ()

    def matrix(self) -> np.ndarray:
        """Stacked Jacobian ``[dlam; dpsi of mode 1; dpsi of mode 2; ...]``, shape
        ``(m_d (1 + n_s), L)``: eigenvalue rows first, then each mode's shape rows.

        Returns
        -------
        numpy.ndarray, shape ``(m_d (1 + n_s), L)``
        """
        return np.vstack([self.dlam] + [self.dpsi[:, r, :] for r in range(self.dlam.shape[0])])


def _resolve_ref(model, s: np.ndarray, ref, how: str, n_modes: int) -> tuple[int, ...] | None:
    """Positions among the sensors of the reference dof of each mode (``"ref"`` scaling)."""
    if how != "ref":
        return None
    if ref is None:
        return (0,) * n_modes  # the first measured dof ("the amplitude of the first freedom being one")
    labels = [model.dofs[i] for i in s]

    def one(r):
        if isinstance(r, str):
            lab = canonical(r)
            if lab not in labels:
                shown = ", ".join(labels[:8]) + (" …" if len(labels) > 8 else "")
                raise InputError(f"ref: reference dof {lab} is not among the sensors ({shown})")
            return labels.index(lab)
        if isinstance(r, (int, np.integer)) and not isinstance(r, bool):
            if not 0 <= int(r) < s.size:
                raise InputError(f"ref: position {r} is out of range 0..{s.size - 1} of the {s.size} sensors")
            return int(r)
        raise InputError(f"ref: give a sensor dof label or its position among the sensors, got {r!r}")

    if isinstance(ref, (str, int, np.integer)):
        return (one(ref),) * n_modes
    refs = list(ref)
    if len(refs) != n_modes:
        raise InputError(f"ref: give one reference dof for all modes or one per mode ({n_modes}), got {len(refs)}")
    return tuple(one(r) for r in refs)


def choose_method(n_dofs: int, n_sensors: int, n_params: int) -> str:
    """The route ``method="auto"`` takes (module docstring).

    Parameters
    ----------
    n_dofs : int
        Model size.
    n_sensors : int
        Number of measured dofs.
    n_params : int
        Number of parameters differentiated.

    Returns
    -------
    str
        ``"nelson"`` up to :data:`femupdate.modal.DENSE_LIMIT` dofs; above, ``"adjoint"`` when
        there are fewer sensors than parameters, else ``"subspace"``.
    """
    if n_dofs <= DENSE_LIMIT:
        return "nelson"
    return "adjoint" if n_sensors < n_params else "subspace"


def jacobian(model, modes, which, sensors, params=None, values=None, method: str = "auto",
             shape_scaling: str = "ref", ref=None, relative_eigenvalues: bool = True, groups=None,
             **factor) -> JacobianResult:
    r"""Eigenvalue and measured-shape sensitivities of the modes ``which``: the updating Jacobian.

    Parameters
    ----------
    model : Model
        The parametrised model.
    modes : Modes
        Mass-normalised modes of ``model`` at ``values`` (:func:`femupdate.model_modes`).  For
        ``subspace`` / ``adjoint`` they must be the lowest m modes, with a buffer above the
        differentiated ones (:func:`~femupdate.sensitivity.subspace.buffered_modes`).
    which : sequence of int
        Modes to differentiate (indices into ``modes``); rigid-body modes, and repeated modes
        outside ``groups``, are refused with :class:`NumericalError`.
    sensors : sequence of str (or of int)
        The measured dofs; unknown labels raise :class:`InputError` naming them.
    params : sequence of int or str, optional
        Parameters (default the free ones).
    values : None, mapping of str to float, or array_like, optional
        Parameter values of ``modes`` (default nominal).
    method : {"auto", "nelson", "modal", "static", "subspace", "adjoint", "fd"}, default "auto"
        See the module docstring (``"auto"``: :func:`choose_method` from the model size, the
        number of sensors and of parameters).
    shape_scaling : {"ref", "max", "unit", "mass"}, default "ref"
        How the measured shapes are scaled (:func:`~femupdate.sensitivity.scaled_shape`):
        1 at the reference sensor (the paper's eq. 33), 1 at the largest measured component,
        unit length over the sensors, or unchanged (mass-normalised).
    ref : str or int, or a sequence of them (one per mode), optional
        A sensor dof label or position.
        Reference dof of ``"ref"`` scaling (default the first sensor).  A mode with a node
        there cannot be scaled to it (:class:`NumericalError`): give a reference per mode.
    relative_eigenvalues : bool, default True
        Divide ∂λ_i/∂p_j by λ_i (paper eq. 19).
    groups : sequence of (int, int), optional
        Groups of repeated or close modes ``(first, stop)`` (modes first .. stop − 1, e.g.
        :func:`~femupdate.close_modes.mode_groups`): a mode of ``which`` in one of them
        gets the derivative of the group's basis with no rotation inside the group, by every
        route (``fd``: central differences of that basis), and ``restricted`` the group's
        ∂A/∂p (:mod:`femupdate.sensitivity.repeated`).
    **factor
        What the routes that solve with K − σM reuse (``subspace``, ``adjoint``, ``static``):
        ``lu`` (a :class:`femupdate.workspace.Factor`, SciPy SuperLU or callable: the
        factorisation of K − σM), ``sigma`` (its shift σ, rad²/s²; default 0, or a small negative
        shift for singular K), ``tol`` (relative tolerance of the omitted modes' series, default
        ``DEFAULT_TOL``) and ``series`` (``"neumann"`` or ``"krylov"``: the series' summation;
        default ``"krylov"`` for ``adjoint``, ``"neumann"`` for ``subspace``; see
        :func:`~femupdate.sensitivity.series.omitted_modes_series`).

    Returns
    -------
    JacobianResult

    Raises
    ------
    InputError
        An unknown ``method`` or ``shape_scaling``; ``which`` not given; modes not on the model's
        dofs or not mass-normalised; unknown sensors, parameters or reference; indices out of
        range.
    NumericalError
        A rigid-body mode, or a repeated mode outside ``groups``, among ``which``; a mode with a
        node at its reference dof; a series that does not converge.
    """
    unknown = sorted(set(factor) - {"lu", "sigma", "tol", "series"})
    if unknown:
        raise TypeError(f"jacobian() got an unexpected keyword argument {unknown[0]!r}")
    lu, sigma, tol, series = factor.get("lu"), factor.get("sigma"), factor.get("tol", DEFAULT_TOL), factor.get("series")
    swapped("jacobian", ("model", model, "Model"), ("modes", modes, "Modes"))
    model_arg(model, "model", "jacobian")
    modes_arg(modes, "modes", "jacobian")
    if which is not None:
        indices_arg(which, "which", "jacobian", size=modes.n_modes, what="mode")
    if sensors is not None:
        indices_arg(sensors, "sensors", "jacobian", size=model.n_dofs, labels=True, what="dof")
    if params is not None:
        indices_arg(params, "params", "jacobian", size=len(model.parameters), labels=True, single=False,
                    what="parameter")
    values_arg(model, values, "values", "jacobian")
    flag_arg(relative_eigenvalues, "relative_eigenvalues", "jacobian")
    real_arg(sigma, "sigma", "jacobian", optional=True)
    real_arg(tol, "tol", "jacobian", low=0.0, low_open=True)
    choice_arg(method, METHODS, "sensitivity method", "jacobian")
    choice_arg(shape_scaling, SCALINGS, "shape scaling", "jacobian")
    check_modes(model, modes)
    if which is None:
        raise InputError("which: give the modes to differentiate (indices into the modes)")
    which = resolve_which(modes, which)
    params = resolve_params(model, params)
    s = resolve_sensors(model, sensors)
    ref_pos = _resolve_ref(model, s, ref, shape_scaling, which.size)
    grouped = resolve_groups(modes, which, groups)
    check_distinct(modes, which, groups=grouped)
    used = tuple(sorted(set(grouped.values())))
    g = list(used) or None  # only the groups with a mode to differentiate
    if method == "auto":
        method = choose_method(model.n_dofs, s.size, params.size)

    fd_model, model = model, tangent(model, values, modes)  # a non-linear model: its tangent at values
    n_terms = 0
    if method == "adjoint":
        dlam, dphi_s, n_terms = adjoint_details(model, modes, which, params, s, values, sigma, tol, lu,
                                                series=series or "krylov", groups=g)
    elif method == "subspace":
        dlam, dphi, terms = subspace_details(model, modes, which, params, values, sigma, tol, lu,
                                             series=series or "neumann", groups=g)
        dphi_s, n_terms = dphi[s], int(np.max(terms, initial=0))
    elif method == "nelson":
        dlam, dphi = nelson(model, modes, which, params, values, groups=g)
        dphi_s = dphi[s]
    elif method == "modal":
        dlam, dphi = modal(model, modes, which, params, values, groups=g)
        dphi_s = dphi[s]
    elif method == "static":
        if lu is not None:
            dlam, dphi = _static_with_factor(model, modes, which, params, values, sigma, lu, grouped)
        else:
            dlam, dphi = modal_static_correction(model, modes, which, params, values, sigma, groups=g)
        dphi_s = dphi[s]
    else:  # "fd"
        dlam, dphi_s = _finite_difference(fd_model, modes, which, params, values, s, grouped)
    restricted = tuple(restricted_derivatives(model, modes, grp, params, values) for grp in used)

    lam = modes.eigenvalues[which]
    if relative_eigenvalues:
        dlam = dlam / lam[:, None]
    phi_s = modes.shapes[np.ix_(s, which)]
    psi = np.zeros_like(phi_s)
    dpsi = np.zeros_like(dphi_s)
    for r in range(which.size):
        k = ref_pos[r] if ref_pos is not None else None
        try:
            psi[:, r], dpsi[:, r, :] = scaled_shape(phi_s[:, r], dphi_s[:, r, :], shape_scaling, k)
        except NumericalError as exc:
            raise NumericalError(f"mode {which[r] + 1}: {exc} ({model.dofs[s[k]] if k is not None else 'largest component'})") from None
    names = model.parameter_names
    return JacobianResult(
        dlam=dlam, psi=psi, dpsi=dpsi, method=method, n_terms=int(n_terms), which=which, eigenvalues=lam,
        sensors=tuple(model.dofs[i] for i in s), parameters=tuple(names[j] for j in params),
        shape_scaling=shape_scaling, ref=ref_pos, relative_eigenvalues=bool(relative_eigenvalues),
        groups=used, restricted=restricted,
    )


def _static_with_factor(model, modes, which, params, values, sigma, lu, grouped):
    """Wang's static correction with a supplied factorisation: the first term of the series."""
    K, M = model.K(values), model.M(values)
    lu, sigma = prepare_factor(K, M, modes, sigma, lu)
    lam, Phi = modes.eigenvalues, modes.shapes
    dlam = np.zeros((which.size, params.size))
    dphi = np.zeros((model.n_dofs, which.size, params.size))
    for r, i in enumerate(which):
        dl, F, mjj, g, Ng = group_mode_rhs(model, modes, params, i, M, grouped)
        Q, _ = omitted_modes_series(lu, M, Phi, F, [lam[i] - sigma], max_terms=1, strict=False)
        dlam[r] = dl
        dphi[:, r, :] = modal_part(modes, i, F, mjj, g, Ng) + Q[0]
    return dlam, dphi


def _finite_difference(model, modes, which, params, values, s, grouped):
    """``fd``: central differences of each mode alone, and of each group's basis (with no
    rotation inside the group) for the modes of ``grouped`` — at the sensors ``s``."""
    dlam, dphi = finite_difference(model, values, which, params, n_modes=modes.n_modes)
    for grp in sorted(set(grouped.values())):
        dB, dA, _ = group_finite_difference(model, grp, values, params, n_modes=modes.n_modes, base=modes)
        for r, i in enumerate(which):
            if grouped.get(int(i)) == grp:
                dphi[:, r, :] = dB[:, int(i) - grp[0], :]
                dlam[r] = dA[int(i) - grp[0], int(i) - grp[0]]
    return dlam, dphi[s]


__all__ = ["jacobian", "JacobianResult", "choose_method", "METHODS", "SCALINGS"]
