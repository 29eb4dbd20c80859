r"""Local solution of an updating problem, and :func:`update_modal`, modal updating alone.

:func:`solve` minimises any problem that offers ``residuals(x)``, ``jacobian(x)`` and the maps of
:class:`~femupdate.updating.problem.Parametrisation` (modal, FRF, multi-configuration) with
SciPy's least squares — the Gauss–Newton iteration of the reference paper's eq. 20 made robust
(trust-region reflective by default, dogbox, Levenberg–Marquardt) — with bounds, optional Tikhonov
regularisation and the iteration history.  :func:`diagnostics` gives the identifiability figures
at the solution.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Mapping, Sequence

import numpy as np
from scipy.optimize import least_squares

from .._errors import InputError, NumericalError
from ..options import ModalOptions, NoiseOptions, PairingOptions, SolverOptions, gather
from ..testdata import TestData
from .parametrisation import start_error, x_bounds
from .groups import describe as describe_groups
from .groups import notes as group_notes
from .noise import analyse, basis_records
from .problem import Problem, check_determined
from .results import Diagnostics, UpdateResult

log = logging.getLogger(__name__)


#: singular values of the normalised sensitivity matrix below this fraction of the largest count as
#: zero (the rank), and so does a parameter's column below this fraction of the largest column
RANK_RTOL = 1e-6
#: a parameter whose entry in a right singular vector of the null space is at least this fraction
#: of the vector's largest entry takes part in a combination the data cannot determine
NULL_SHARE = 0.3
#: a free parameter whose standard deviation exceeds this fraction of its value's magnitude (of 1
#: for a value of 0) is poorly determined: within one standard deviation it could be zero or
#: twice its value — the data barely move it
POOR_RELATIVE_STD = 1.0


def _svd(S: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Singular values (descending) and right singular vectors (rows, all of them) of S.

    A tall S (rows >= columns) has all n right singular vectors in the economy SVD, without the
    m x m left factor that the full SVD forms (45 s and gigabytes for the 30 000 FRF residuals of
    12 dofs at 1241 lines; the same values and vectors, bit for bit, by LAPACK's gesdd)."""
    if not S.size:
        return np.zeros(0), np.eye(S.shape[1])
    _, sv, Vt = np.linalg.svd(S, full_matrices=S.shape[0] < S.shape[1])
    return sv, Vt


def diagnostics(prob, x, r, J, sigma, bounds=None) -> Diagnostics:
    """Identifiability figures (:class:`Diagnostics`) of ``prob`` at x.

    The Jacobian is taken to the parameters (∂r/∂p) and its columns scaled by |p| (1 for a zero
    value): the normalised sensitivity matrix S = ∂r/∂(p/|p|).

    * **Active bounds.**  A parameter whose value sits on one of ``bounds`` (within
      :data:`femupdate.flags.ON_BOUND_RTOL` of the bounds' span, :func:`femupdate.flags.bound_side`)
      is held there by the bound, not by the data: it is listed in ``at_bounds`` and left out of
      the analysis below, which describes the *free* parameters only (its standard deviation is
      NaN).
    * **Singular values** of S restricted to the free columns, descending; its rank (singular
      values above :data:`RANK_RTOL` σ_max) and condition number.
    * **Noise and covariance** of the free parameters (:mod:`femupdate.updating.noise`): the
      residuals are split into blocks (per test mode its eigenvalue and its shape; each FRF set,
      each static case), each block's noise is stated (its residuals divided by standard
      deviations from the data file or the options) or estimated from the fit by REML
      (:func:`femupdate.variance.variance_components`: Förstner's iterative variance components,
      each with its redundancy as degrees of freedom; blocks too small to estimate alone pooled —
      the eigenvalues of all modes into one), and the covariance is that of the fit under these
      components, D A (Σ_b σ_b² S_bᵀS_b) A D with A = (S_freeᵀS_free)⁻¹ and D = diag |p|: the
      absolute (S_freeᵀS_free)⁻¹ in parameter units when every block is stated.  ``noise``
      records each component's basis, ``std_dof`` each standard deviation's Satterthwaite
      degrees of freedom (inf: stated noise only), ``model_error`` the test of the fit
      (:func:`femupdate.variance.fit_test`).  A free parameter the data do not depend on (a
      zero column) is left out of it too (NaN): the others' covariance does not depend on it.
    * **Poorly determined** parameters, each with its reason (``poorly_determined_reasons``):
      a column of S below :data:`RANK_RTOL` times the largest (the data do not depend on the
      parameter; checked for every parameter, on a bound or not); an entry of at least
      :data:`NULL_SHARE` times the largest in a right singular vector of the free parameters'
      null space (the data determine only a combination); a standard deviation above
      :data:`POOR_RELATIVE_STD` times |p| (the data barely move it).

    Parameters
    ----------
    prob : Parametrisation
        The problem (its ``to_p``, ``dp_dx``, ``idx``, ``names`` and ``scale``).
    x : numpy.ndarray, shape ``(L,)``
        The optimiser's variables.
    r : numpy.ndarray, shape ``(m,)``
        The residuals at x.
    J : numpy.ndarray, shape ``(m, L)``
        The Jacobian ∂r/∂x at x.
    sigma : object or None
        Not None when every residual is already divided by the measurement standard deviations
        (for a problem without its own block layout: then stated, else estimated); a modal or
        combined problem says block by block which are stated.
    bounds : tuple of numpy.ndarray, optional
        The model's ``(lo, hi)`` over its full parameter vector, when the solver kept to them;
        None (default, and for Levenberg–Marquardt, which ignores bounds): no bound is active.

    Returns
    -------
    Diagnostics
        Covariance and standard deviations NaN for the parameters on a bound or with a zero
        column, and for all unless S has full column rank over the remaining ones.
    """
    from ..flags import bound_side

    names = list(prob.names)
    p = prob.to_p(x)[prob.idx]
    dxdp = 1.0 / prob.dp_dx(x)
    Jp = J * dxdp[None, :]  # ∂r/∂p
    mag = np.where(p != 0, np.abs(p), 1.0)
    S = Jp * mag[None, :]  # ∂r/∂(p/|p|): normalised sensitivity
    m, L = J.shape
    at: dict[str, str] = {}
    if bounds is not None:
        lo, hi = (np.asarray(b, float)[prob.idx] for b in bounds)
        start = getattr(prob, "scale", np.ones(L))
        for j, n in enumerate(names):
            side = bound_side(float(p[j]), float(lo[j]), float(hi[j]), float(start[j]))
            if side is not None:
                at[n] = side
    free = np.array([j for j, n in enumerate(names) if n not in at], dtype=np.intp)
    reasons: dict[str, str] = {}
    # whether the data depend on a parameter: its sensitivity at its own scale, or at its start's
    # when it has shrunk to ~0 (a damping coefficient on its lower bound 0: |p| ~ 1e-30 would make
    # every column zero, "the data do not depend on it", though they do)
    ref = np.abs(np.asarray(getattr(prob, "scale", np.ones(L)), float))
    ref = np.where(ref > 0, ref, 1.0)
    col = np.sqrt(np.sum((Jp * np.where(np.abs(p) > 1e-9 * ref, mag, ref)[None, :]) ** 2, axis=0)) if m else np.zeros(L)
    largest = float(col.max()) if col.size else 0.0
    unseen = col <= RANK_RTOL * largest  # the data do not depend on these
    for z in np.flatnonzero(unseen):
        reasons[names[int(z)]] = ("the data do not depend on it (zero sensitivity)" if largest > 0
                                  else "the data do not depend on any parameter (zero sensitivity)")
    sv, Vt = _svd(S[:, free])
    nF = free.size
    rank = int(np.sum(sv > RANK_RTOL * sv[0])) if sv.size else 0
    for k in range(rank, nF):  # the null space of the free parameters (with the directions beyond m < L)
        v = np.abs(Vt[k])
        group = [names[free[j]] for j in np.flatnonzero(v >= NULL_SHARE * v.max())]
        for n in group:
            others = [g for g in group if g != n]
            reasons.setdefault(n, f"the data determine only a combination of it with {', '.join(others)}"
                               if others else "the data cannot move it (a null direction of the sensitivity matrix)")
    if nF == 0:
        cond = math.nan
    else:
        cond = float(sv[0] / sv[-1]) if sv.size and sv[-1] > 0 and nF <= m else math.inf
    # the covariance of the free parameters the data depend on: a zero column is a null direction of
    # its own, which leaves the others' covariance defined (the information matrix is block-diagonal)
    cols = free[~unseen[free]]
    nC = cols.size
    svC, VtC = (sv, Vt) if nC == nF else _svd(S[:, cols])
    cov = np.full((L, L), np.nan)
    std_dof = np.full(L, np.nan)
    noise: list[dict] = []
    fit: dict = {}
    noise_notes: list[str] = []
    absolute = sigma is not None
    if nC and m > 0:
        # the noise of each block of residuals: stated, or estimated by REML (femupdate.variance)
        vc, test, lay = analyse(prob, S[:, cols], r, sigma, _basis(prob))
        noise, fit, noise_notes = basis_records(vc, lay.stated), test.record(), list(vc.notes)
        absolute = vc.absolute
        if np.sum(svC > RANK_RTOL * svC[0]) == nC:
            cov[np.ix_(cols, cols)] = mag[cols][:, None] * vc.covariance * mag[cols][None, :]
            std_dof[cols] = vc.dof
    diag = np.diag(cov)
    std = np.where(np.isfinite(diag), np.sqrt(np.clip(np.nan_to_num(diag, nan=0.0), 0, None)), np.nan)
    rel = std / mag
    for j in free:
        if np.isfinite(rel[j]) and rel[j] > POOR_RELATIVE_STD:
            reasons.setdefault(names[j], f"its standard deviation {std[j]:.3g} is {rel[j] * 100:.0f} % of its value "
                                         f"(above {POOR_RELATIVE_STD * 100:.0f} %): the data barely move it")
    poor = sorted(reasons)
    return Diagnostics(sv, cond, rank, poor, cov, std, m, L, absolute, at_bounds=at,
                       free=tuple(names[j] for j in free), poorly_determined_reasons={n: reasons[n] for n in poor},
                       relative_std=rel, noise=noise, std_dof=std_dof, model_error=fit, noise_notes=noise_notes)


def _basis(prob) -> str:
    """The problem's noise basis (:class:`~femupdate.options.NoiseOptions` ``basis``)."""
    options = getattr(prob, "options", None)
    noise = options.get("noise") if isinstance(options, dict) else None
    return getattr(noise, "basis", "auto") or "auto"


def check_start_residuals(r: np.ndarray) -> None:
    """Refuse residuals at the start too large for the least-squares solver (above
    :data:`femupdate._limits.MAX_START_RESIDUAL`: its sums of squares and products would overflow,
    with RuntimeWarnings and a meaningless answer).  They arise when the test data and the model
    differ by tens of orders of magnitude — data in other units, or a standard deviation far too
    small.

    Raises
    ------
    InputError
        Naming the largest residual and what to check.
    """
    from .._limits import MAX_START_RESIDUAL

    with np.errstate(invalid="ignore"):
        largest = float(np.max(np.abs(r))) if np.size(r) else 0.0
    if not largest <= MAX_START_RESIDUAL:
        raise InputError(f"the weighted residuals at the starting values reach {largest:.3g}, too large to compute with "
                         f"(above {MAX_START_RESIDUAL:g}): the test data and the model's responses differ by tens of "
                         "orders of magnitude; check the units of the test data and the standard deviations given")


def solve(prob, bounds, solver: SolverOptions | None = None, **shorthand):
    """Minimise ``prob.residuals`` with SciPy's least squares from ``prob.p_base`` (paper eq. 20).

    Shared by every iterative updating problem (modal, FRF, combined, multi-configuration): the
    parameters' ``bounds`` mapped to the optimiser's variables, Tikhonov augmentation
    α (x − x_start) with α fixed or chosen by ``"gcv"`` / ``"lcurve"`` at the start, and the
    iteration history.

    Parameters
    ----------
    prob : Parametrisation
        Provides ``residuals(x)``, ``jacobian(x)`` and the
        :class:`~femupdate.updating.problem.Parametrisation` maps.
    bounds : tuple of numpy.ndarray, each shape ``(n_parameters,)``
        The model's full ``(lo, hi)`` (physical units); ignored by ``"lm"``.
    solver : SolverOptions, optional
        The method, tolerances, evaluations and regularisation
        (:class:`~femupdate.options.SolverOptions`; a Tikhonov rule chooses α from the residuals
        and Jacobian at the start, :func:`femupdate.regularization.choose_alpha`; the method's
        ``x_scale`` is ``"jac"`` except for ``"lm"``).  Its ``parametrisation`` is the problem's
        own and is not read here.
    **shorthand
        :class:`~femupdate.options.SolverOptions` fields as keywords.

    Returns
    -------
    sol : scipy.optimize.OptimizeResult
        The solver's result, ``sol.x`` in the optimiser's variables (its ``cost`` and ``fun``
        include the regularisation rows).
    history : list of dict
        ``{"iteration", "cost", "parameters": {name: value}}``: the start (iteration 0), then one
        entry per iteration (``"lm"``: the start only).
    regularization : dict
        ``{"rule": "fixed" | "gcv" | "lcurve", "alpha": α}``, or empty without regularisation.

    Raises
    ------
    InputError
        A start outside the bounds (or not positive under ``"log"``); a negative α or an unknown
        rule.
    NumericalError
        The problem cannot be evaluated, or the solver failed.
    """
    solver = gather("solve", shorthand, solver=(SolverOptions, solver))["solver"]
    method, regularization = solver.method, solver.regularization
    names = prob.names
    parametrisation = prob.param
    lo, hi = bounds
    lo, hi = lo[prob.idx], hi[prob.idx]
    p_start = prob.p_base[prob.idx]
    refused = start_error(names, p_start, lo, hi, parametrisation)
    if refused:
        raise InputError(refused)
    x_start = prob.from_p(p_start)
    xl, xh = x_bounds(parametrisation, lo, hi, prob.scale)
    history: list[dict] = []
    check_start_residuals(prob.residuals(x_start))

    # regularisation
    reg: dict = {}
    alpha = 0.0
    if regularization is not None:
        if isinstance(regularization, str):
            from ..regularization import choose_alpha

            J0 = prob.jacobian(x_start)
            r0 = prob.residuals(x_start)
            choice = choose_alpha(J0, r0, rule=regularization)
            alpha = float(choice.alpha)
            reg = {"rule": regularization, "alpha": alpha}
        else:
            alpha = float(regularization)  # checked by SolverOptions: finite and >= 0
            reg = {"rule": "fixed", "alpha": alpha}

    def fun(x):
        r = prob.residuals(x)
        return np.concatenate([r, alpha * (x - x_start)]) if alpha else r

    def jac(x):
        J = prob.jacobian(x)
        return np.vstack([J, alpha * np.eye(x.size)]) if alpha else J

    def callback(intermediate_result):
        xi = intermediate_result.x
        history.append({"iteration": len(history), "cost": float(intermediate_result.cost),
                        "parameters": dict(zip(names, map(float, prob.to_p(xi)[prob.idx])))})

    bounds = (-np.inf, np.inf) if method == "lm" else (xl, xh)
    if method == "lm" and (np.any(np.isfinite(lo)) or np.any(np.isfinite(hi))):
        log.info("Levenberg-Marquardt ignores the parameter bounds")
    history.append({"iteration": 0, "cost": 0.5 * float(np.sum(fun(x_start) ** 2)),
                    "parameters": dict(zip(names, map(float, p_start)))})
    try:
        sol = least_squares(fun, x_start, jac=jac, bounds=bounds, method=method, x_scale="jac" if method != "lm" else 1.0,
                            ftol=solver.ftol, xtol=solver.xtol, gtol=solver.gtol, max_nfev=solver.max_nfev,
                            callback=callback if method != "lm" else None)
    except NumericalError:
        raise
    except (ValueError, np.linalg.LinAlgError) as exc:
        raise NumericalError(f"the least-squares solver failed: {exc}") from None
    return sol, history, reg


def update_modal(model, data: TestData, *, params: Sequence[str] | None = None, x0: Mapping[str, float] | None = None,
                 values=None, modal: ModalOptions | None = None, pairing: PairingOptions | str | None = None,
                 noise: NoiseOptions | None = None, solver: SolverOptions | None = None,
                 **shorthand) -> UpdateResult:
    """Update the model's parameters so that its modes match the measured ones (the modal case of
    :func:`femupdate.update`, which takes FRFs and static deflections too).

    Parameters
    ----------
    model : Model
        The model to update.
    data : TestData
        Measured modes; shapes may be partial (any subset of model dofs, any scaling).
    params, x0, values
        The parameters updated, their starting values and the fixed ones' values, as
        :func:`femupdate.update` takes them.
    modal : ModalOptions, optional
        The residuals of the modes (:class:`~femupdate.options.ModalOptions`).
    pairing : PairingOptions or str, optional
        How test modes pair with model modes (:class:`~femupdate.options.PairingOptions`).
    noise : NoiseOptions, optional
        Standard deviations and weights (:class:`~femupdate.options.NoiseOptions`): with standard
        deviations the residuals are divided by them and the covariance is absolute, not scaled
        by the residual.
    solver : SolverOptions, optional
        The least-squares solver, its variables and regularisation
        (:class:`~femupdate.options.SolverOptions`).
    **shorthand
        Fields of those option objects as keywords (``min_mac=0.8``, ``max_nfev=50``, ...).

    Returns
    -------
    UpdateResult
        ``success``/``status``/``message`` report convergence (non-convergence is a status,
        not an exception); ``diagnostics`` holds the identifiability figures; ``formulation``
        the formulation, ``expanded_shapes`` the full shapes of the dynamic one.

    Raises
    ------
    InputError
        An unknown option value, bad weights or data (as :class:`~femupdate.updating.Problem`),
        a start outside the bounds, or fewer independent data than parameters without a
        regularisation.
    TypeError
        A keyword that no option object has.
    NumericalError
        The model cannot be evaluated (unpaired modes, non-finite residuals) or the solver failed.
    """
    o = gather("update_modal", shorthand, modal=(ModalOptions, modal), pairing=(PairingOptions, pairing),
               noise=(NoiseOptions, noise), solver=(SolverOptions, solver))
    prob = Problem(model, data, params, x0=x0, values=values, parametrisation=o["solver"].parametrisation,
                   modal=o["modal"], pairing=o["pairing"], noise=o["noise"])
    return solve_problem(prob, o["solver"])


def solve_problem(prob: Problem, solver: SolverOptions | None = None, **shorthand) -> UpdateResult:
    """Solve the modal updating problem ``prob`` from its starting point (:func:`update_modal` on a
    :class:`Problem` already built).

    Parameters
    ----------
    prob : Problem
        The modal problem (its start, bounds from ``prob.model.bounds``).
    solver : SolverOptions, optional
        The solver (:class:`~femupdate.options.SolverOptions`; its ``parametrisation`` is the
        problem's own and is not read here); without a regularisation the problem must be
        determined.
    **shorthand
        :class:`~femupdate.options.SolverOptions` fields as keywords.

    Returns
    -------
    UpdateResult
        As :func:`result_at` at the solution.

    Raises
    ------
    InputError
        Fewer independent data than parameters without a regularisation; and as :func:`solve`.
    NumericalError
        As :func:`solve`.
    """
    solver = gather("solve_problem", shorthand, solver=(SolverOptions, solver))["solver"]
    model = prob.model
    if solver.regularization is None:
        check_determined(prob)
    sol, history, reg = solve(prob, model.bounds, solver)
    return result_at(prob, sol.x, sol, history, reg, bounded=solver.method != "lm")


def paired_modes(prob: Problem, modes, pairs) -> dict:
    """The correlation part of a result: ``pairs`` (test mode, model mode, MAC — the MAC computed
    for a mode compared by frequency only), ``test_frequencies_hz``, ``model_frequencies_hz``
    and ``pairing`` (``policy``: the rule asked for, ``used``: the rule that made these pairs,
    ``low_mac``: 0-based test modes with a shape whose pair's MAC is below ``min_mac``; and
    ``groups`` when test modes were paired into groups of repeated or close model modes,
    :func:`femupdate.updating.groups.describe`: their MAC is then that of the best combination of
    the group's shapes).

    Parameters
    ----------
    prob : Problem
    modes : Modes
        The model's modes at the point (``prob.evaluate(x)``).
    pairs : list of (int, int, float)
        The pairs there.

    Returns
    -------
    dict
    """
    fits = prob.group_fits
    record = pairing_record(prob, [m for _, _, m in pairs], prob.pairing_used)
    if fits:  # test modes paired into groups of repeated or close model modes (absent otherwise)
        record["groups"] = describe_groups(fits, pairs)
    return dict(pairs=[(k, j, m if np.isfinite(m) else prob.mac_of_pair(modes, k, j)) for k, j, m in pairs],
                test_frequencies_hz=prob.data.frequencies_hz,
                model_frequencies_hz=np.array([modes.frequencies_hz[j] for _, j, _ in pairs]),
                pairing=record)


def pairing_record(prob: Problem, macs, used: str) -> dict:
    """The ``pairing`` record of a result (:attr:`UpdateResult.pairing`): the policy, the rule
    ``used`` for the final pairs, ``min_mac`` and the test modes whose pair's MAC (``macs``, in
    test-mode order, NaN without shape) is below it.

    Parameters
    ----------
    prob : Problem
    macs : sequence of float
    used : str

    Returns
    -------
    dict
    """
    low = [k for k, m in enumerate(macs) if np.isfinite(m) and not m >= prob.min_mac]
    return {"policy": prob.pairing, "used": used, "min_mac": prob.min_mac, "low_mac": low}


def result_at(prob: Problem, x, sol=None, history=None, reg=None, bounded: bool = True) -> UpdateResult:
    """The :class:`UpdateResult` of ``prob`` at the variables x: residuals, Jacobian, pairs and
    diagnostics there; ``sol`` (a SciPy ``OptimizeResult`` or an object with its fields) gives
    the convergence figures (none: a plain evaluation, 0 iterations).

    Parameters
    ----------
    prob : Problem
        The modal problem.
    x : array_like, shape ``(L,)``
        The optimiser's variables.
    sol : scipy.optimize.OptimizeResult, optional
        Gives ``success``, ``status``, ``message``, ``nfev``, ``njev``; None: ``success`` False,
        status 0, message ``"evaluated, not solved"``, one evaluation.
    history : list of dict, optional
        The iteration history (:func:`solve`; default empty).
    reg : dict, optional
        The regularisation used (:func:`solve`; default empty).
    bounded : bool, default True
        The solver kept to the model's bounds (False for Levenberg–Marquardt): parameters on a
        bound are reported as held by it (:func:`diagnostics`).

    Returns
    -------
    UpdateResult
        ``cost`` ½‖r‖² of the problem's own residuals (without regularisation rows),
        ``iterations`` the larger of the history's iterations and ``njev``, ``sensitivity`` the
        route of the Jacobian at x, ``formulation`` the problem's, ``expanded_shapes`` the full
        shapes of the dynamic formulation there (the pairs of the dynamic formulation, which
        pairs nothing while it solves, are those of the model's modes at x, for the report).

    Raises
    ------
    NumericalError
        The problem cannot be evaluated at x.
    """
    p_final = prob.to_p(x)
    _, modes, pairs = prob.evaluate(x)
    r = prob.residuals(x)
    J = prob.jacobian(x)
    history = history if history is not None else []
    status = int(sol.status) if sol is not None else 0
    njev = int(sol.njev or 0) if sol is not None else 0
    diag = diagnostics(prob, x, r, J, prob.sigma, bounds=prob.model.bounds if bounded else None)
    paired = paired_modes(prob, modes, pairs)
    return UpdateResult(
        parameters=dict(zip(prob.model.parameter_names, map(float, p_final))),
        names=tuple(prob.names), x=p_final[prob.idx], success=bool(sol.success) if sol is not None else False,
        status=status, message=str(sol.message) if sol is not None else "evaluated, not solved",
        cost=float(0.5 * r @ r), fun=r, jac=J, nfev=int(sol.nfev) if sol is not None else 1, njev=njev,
        iterations=max(len(history) - 1, njev), history=history,
        **paired,
        swaps=list(prob.swaps), diagnostics=diag, regularization=reg or {},
        start=dict(zip(prob.names, map(float, prob.start))), sensitivity=prob.sensitivity_used,
        notes=list(prob.notes) + group_notes(paired["pairing"].get("groups", []), prob.close_modes) + diag.notes, formulation=prob.formulation_used, expanded_shapes=prob.expanded_shapes(x),
        solver=getattr(modes, "solver", ""),
    )


__all__ = ["update_modal", "solve", "solve_problem", "result_at", "paired_modes", "pairing_record", "diagnostics", "RANK_RTOL", "NULL_SHARE",
           "POOR_RELATIVE_STD"]
