r"""Iterative joint updating of several configurations from (incomplete) modal data.

The residuals and Jacobians of the configurations (:class:`femupdate.updating.Problem`, relative
eigenvalues and scaled shapes, eq. 19) are stacked and minimised by SciPy's least squares
(eq. 20) through :func:`femupdate.updating.solve`.  :func:`solve_configurations` chooses the
direct solution when every configuration's data are complete, this one otherwise.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from ..._docs import shared_docs
from ..._checks import data_arg, model_arg, params_arg, shown, values_arg, x0_arg
from ..._errors import InputError
from ...options import ModalOptions, NoiseOptions, PairingOptions, SolverOptions, gather
from ...model import Model
from ...testdata import TestData
from .. import PARAMETRISATIONS, Parametrisation, Problem, diagnostics, solve
from ..parametrisation import start_vector
from .configurations import Configuration, check_unknowns, config_values, is_complete, prepare
from .direct import direct_configurations
from .results import MultiConfigResult, conditioning

#: the argument of the stacked problem's methods, up to their returns (femupdate._docs)
_X = """\
Parameters
----------
x : array_like, shape ``(L,)``
    The common scaled unknowns.

Returns
-------"""


class Stacked(Parametrisation):
    """Residuals and Jacobian of several configurations stacked; one vector of unknowns.

    Each configuration is a :class:`femupdate.updating.Problem` on its own model in absolute
    parameters; this class maps the common scaled unknowns ``x`` (:class:`Parametrisation`) to
    them, and offers what :func:`femupdate.updating.solve` and ``diagnostics`` need.  A
    configuration's problem uses only the unknowns its model has.

    Parameters
    ----------
    model : Model
        The base model.
    configurations : sequence of Configuration
        The configurations and their test data.
    cms : sequence of ConfiguredModel
        Their models (:func:`~femupdate.updating.multiconfig.configurations.prepare`), same order.
    names : sequence of str
        The unknown parameters.
    parametrisation : {"relative", "log", "absolute"}
        Scaling of the unknowns, as :func:`femupdate.updating.update`.
    p_base : ndarray, shape ``(n_parameters,)``
        Parameter values of the base model (the start; the known values of each configuration are
        taken from it and its modification, :func:`~.configurations.config_values`).
    shape_scaling, ref_dof, weights, measurement_std, min_mac, n_modes, use_shapes, sensitivity, pairing
        Options of each configuration's :class:`femupdate.updating.Problem` (defaults ``"unit"``,
        None, None, None, 0.5, None, True, ``"auto"``, ``"auto"``).

    Raises
    ------
    InputError
        An unknown ``parametrisation``; a configuration's problem refused (the message names the
        configuration).
    """

    def __init__(self, model, configurations, cms, names, *, parametrisation, p_base, modal: ModalOptions,
                 pairing: PairingOptions, noise: NoiseOptions):
        if parametrisation not in PARAMETRISATIONS:
            raise InputError(f"unknown parametrisation {parametrisation!r}: use {', '.join(PARAMETRISATIONS)}")
        super().__init__(model, names, parametrisation, p_base)
        self.model = model
        self.subs = []
        for c, cmc in zip(configurations, cms):
            cm = cmc.model
            mine = [n for n in names if n in cm.parameter_names]
            cols = np.array([self.names.index(n) for n in mine], dtype=np.intp)
            pb = config_values(model, cm, c.modification, p_base)
            try:
                prob = Problem(cm, c.data, mine, values=pb, parametrisation="absolute", modal=modal, pairing=pairing,
                               noise=noise)
            except InputError as exc:
                raise InputError(f"configuration {c.label!r}: {exc}") from None
            self.subs.append((c.label, prob, cols))

    @shared_docs(X=_X)
    def residual_blocks(self, x):
        """Per configuration, its residuals r_c at x (each configuration's own unknowns).

        {{X}}
        list of numpy.ndarray, each shape ``(m_c,)``
            In configuration order (relative eigenvalue errors and scaled shape differences).

        Raises
        ------
        NumericalError
            A configuration's modes cannot be paired, or non-finite residuals.
        """
        q = self.to_p(x)[self.idx]
        return [prob.residuals(q[cols]) for _, prob, cols in self.subs]

    @shared_docs(X=_X)
    def jacobian_blocks(self, x):
        """Per configuration, ∂r_c/∂x (rows of configuration c, all unknowns).

        {{X}}
        list of numpy.ndarray, each shape ``(m_c, L)``
            Zero columns for the unknowns a configuration's model lacks.
        """
        q = self.to_p(x)[self.idx]
        d = self.dp_dx(x)
        out = []
        for _, prob, cols in self.subs:
            Jc = prob.jacobian(q[cols])
            full = np.zeros((Jc.shape[0], len(self.names)))
            full[:, cols] = Jc * d[cols][None, :]
            out.append(full)
        return out

    @shared_docs(X=_X)
    def residuals(self, x):
        """The stacked residuals at x.

        {{X}}
        numpy.ndarray, shape ``(m,)``
            :meth:`residual_blocks` concatenated, m = Σ m_c.
        """
        return np.concatenate(self.residual_blocks(x))

    @shared_docs(X=_X)
    def jacobian(self, x):
        """The stacked Jacobian ∂r/∂x at x.

        {{X}}
        numpy.ndarray, shape ``(m, L)``
            :meth:`jacobian_blocks` stacked.
        """
        return np.vstack(self.jacobian_blocks(x))

    def n_data(self) -> int:
        """Independent data over all configurations (eigenvalues and scaled shape entries)."""
        return sum(prob.targets.n_independent for _, prob, _ in self.subs)

    def normalised_blocks(self, x, blocks=None):
        """Per configuration ∂r_c/∂(p/``|p|``): unit-free sensitivity blocks.

        Parameters
        ----------
        x : array_like, shape ``(L,)``
            The common scaled unknowns.
        blocks : list of numpy.ndarray, optional
            The :meth:`jacobian_blocks` at ``x``, if at hand (else computed).

        Returns
        -------
        list of numpy.ndarray, each shape ``(m_c, L)``
            Column j scaled by ``|p_j|`` (1 for a zero value) / (∂p_j/∂x_j).
        """
        p = self.to_p(x)[self.idx]
        d = self.dp_dx(x)
        w = np.where(p != 0, np.abs(p), 1.0) / d
        return [B * w[None, :] for B in (self.jacobian_blocks(x) if blocks is None else blocks)]


def _door(model, configurations, params, x0, values) -> None:
    """:func:`update_configurations`'s arguments by type (:mod:`femupdate._checks`): the model, a
    list of :class:`Configuration` each holding test data, the parameters, start and values."""
    where = "update_configurations"
    model_arg(model, "model", where)
    if isinstance(configurations, (str, bytes)) or not isinstance(configurations, Sequence) \
            or not all(isinstance(c, Configuration) for c in configurations):
        whole = isinstance(configurations, (str, bytes)) or not isinstance(configurations, Sequence)
        bad = configurations if whole else next(c for c in configurations if not isinstance(c, Configuration))
        raise TypeError(f"{where}: configurations must be a list of Configuration(data, modification), got "
                        f"{shown(bad)}" + (" (one configuration's data: femupdate.update(model, data))"
                                           if isinstance(bad, TestData) else ""))
    for k, c in enumerate(configurations):
        data_arg(c.data, f"configurations[{k}].data", where)
    params_arg(params, "params", where)
    x0_arg(model, x0, "x0", where)
    values_arg(model, values, "values", where)


def update_configurations(model: Model, configurations: Sequence[Configuration], *, params: Sequence[str] | None = None,
                          x0: Mapping[str, float] | None = None, values=None, modal: ModalOptions | None = None,
                          pairing: PairingOptions | str | None = None, noise: NoiseOptions | None = None,
                          solver: SolverOptions | None = None, **shorthand) -> MultiConfigResult:
    """Iterative joint updating of several configurations from (incomplete) modal data.

    The residuals of every configuration (relative eigenvalue errors and scaled shape
    differences at its measured dofs, paper eq. 19, as in :func:`femupdate.updating.update`) are
    stacked, with the Jacobian of each configuration's model, and minimised over the one set of
    unknowns by :func:`scipy.optimize.least_squares` (eq. 20).

    Parameters
    ----------
    model : Model
        The base model.
    configurations : sequence of Configuration
        The configurations and their test data (modes; shapes may be partial).
    params : sequence of str, optional
        The unknown parameters (default: every parameter not fixed).
    x0 : mapping of str to float, optional
        Starting values (default: ``values``, else nominal).
    values : None, mapping of str to float, or array_like of shape ``(n_parameters,)``, optional
        Values of the known parameters (default nominal).
    modal, pairing, noise : option objects, optional
        Each configuration's modal residuals, pairing and weighting, as :func:`femupdate.update`
        takes them (:class:`~femupdate.options.ModalOptions` — the ``"shapes"`` formulation —,
        :class:`~femupdate.options.PairingOptions`, :class:`~femupdate.options.NoiseOptions`).
    solver : SolverOptions, optional
        The solver, its variables and regularisation (a Tikhonov term pulls the scaled parameters
        toward the start).
    **shorthand
        Fields of the option objects as keywords.

    Returns
    -------
    MultiConfigResult
        ``conditioning`` holds each configuration's normalised sensitivity matrix alone and the
        configurations stacked one after another, at the solution.

    Raises
    ------
    InputError
        An unknown method or parametrisation, invalid unknowns or configurations, or fewer
        independent data over all configurations than unknowns without ``regularization``.
    NumericalError
        As :func:`femupdate.updating.update`.
    """
    _door(model, configurations, params, x0, values)
    o = gather("update_configurations", shorthand, modal=(ModalOptions, modal), pairing=(PairingOptions, pairing),
               noise=(NoiseOptions, noise), solver=(SolverOptions, solver))
    solver = o["solver"]
    method = solver.method
    if o["modal"].formulation != "shapes":
        raise InputError(f"formulation {o['modal'].formulation!r}: joint updating of configurations takes the "
                         "'shapes' formulation only")
    names = check_unknowns(model, params)
    cms = prepare(model, configurations, names)
    p_base = start_vector(model, values, x0)
    prob = Stacked(model, configurations, cms, names, parametrisation=solver.parametrisation, p_base=p_base,
                   modal=o["modal"], pairing=o["pairing"], noise=o["noise"])
    n_data = prob.n_data()
    if n_data < len(names) and solver.regularization is None:
        raise InputError(f"{len(names)} parameters but only {n_data} independent data over all configurations "
                         "(eigenvalues and scaled shape entries): add configurations or data, fix parameters, "
                         "or use regularization")
    sol, history, reg = solve(prob, model.bounds, solver)
    p_final = prob.to_p(sol.x)
    blocks = prob.residual_blocks(sol.x)
    r = np.concatenate(blocks)
    J_blocks = prob.jacobian_blocks(sol.x)
    # absolute when every configuration's residuals are divided by stated standard deviations
    sigma = True if all(sub.sigma is not None for _, sub, _ in prob.subs) else None
    diag = diagnostics(prob, sol.x, r, np.vstack(J_blocks), sigma, bounds=None if method == "lm" else model.bounds)
    per = []
    for (label, sub, cols), rc, c in zip(prob.subs, blocks, configurations):
        _, modes, pairs = sub.evaluate(p_final[prob.idx][cols])
        per.append({"name": label, "modification": c.modification.describe(),
                    "n_data": sub.targets.n_independent,
                    "pairs": [(k, j, float(m)) for k, j, m in pairs], "cost": float(0.5 * rc @ rc),
                    "frequencies_hz": {"test": c.data.frequencies_hz,
                                       "model": np.array([modes.frequencies_hz[j] for _, j, _ in pairs])},
                    "swaps": list(sub.swaps)})
    cond = conditioning(prob.normalised_blocks(sol.x, J_blocks), names, [c.label for c in configurations])
    from .record import attach

    return attach(MultiConfigResult(
        method="iterative", parameters=dict(zip(model.parameter_names, map(float, p_final))), names=tuple(names),
        x=p_final[prob.idx], success=bool(sol.success), message=str(sol.message), configurations=per,
        conditioning=cond, standard_error=diag.std, diagnostics=diag, cost=float(0.5 * r @ r), nfev=int(sol.nfev),
        iterations=max(len(history) - 1, int(sol.njev or 0)), history=history, regularization=reg,
        start=dict(zip(names, map(float, p_base[prob.idx]))), notes=diag.notes,
    ), model, "update-multi")


def solve_configurations(model: Model, configurations: Sequence[Configuration], method: str = "auto", *,
                         unknowns: Sequence[str] | None = None, values=None, use: Sequence[str] = ("modes", "frf", "static"),
                         bounded: bool = False, **iterative) -> MultiConfigResult:
    """Joint update, direct when every configuration's data are complete, iterative otherwise.

    Parameters
    ----------
    model, configurations
        The base model and the configurations with their test data, as
        :func:`update_configurations`.
    method : {"auto", "direct", "iterative"}, default ``"auto"``
        ``"auto"``: direct when every configuration's data are complete (:func:`~.configurations.is_complete`).
    unknowns : sequence of str, optional
        The unknown parameters (default: every parameter not fixed); both solutions.
    values : None, mapping of str to float, or array_like of shape ``(n_parameters,)``, optional
        Values of the known parameters; both solutions.
    use : sequence of str, default ``("modes", "frf", "static")``
        Direct solution only (:func:`direct_configurations`).
    bounded : bool, default False
        Direct solution only.
    **iterative
        Further keyword arguments of :func:`update_configurations` (iterative solution only).

    Returns
    -------
    MultiConfigResult

    Raises
    ------
    InputError
        An unknown ``method``; otherwise as :func:`direct_configurations` or
        :func:`update_configurations`.
    """
    if method not in ("auto", "direct", "iterative"):
        raise InputError(f"unknown method {method!r}: use auto, direct or iterative")
    if method == "auto":
        cms = prepare(model, configurations, check_unknowns(model, unknowns))
        method = "direct" if all(is_complete(c, cm.model) for c, cm in zip(configurations, cms)) else "iterative"
    if method == "direct":
        return direct_configurations(model, configurations, unknowns=unknowns, values=values, use=use, bounded=bounded)
    return update_configurations(model, configurations, params=unknowns, values=values, **iterative)
