"""The updating verb: :func:`update` solves, from its start, whatever the test data hold —
measured modes (:func:`~femupdate.updating.update_modal`), FRFs
(:func:`~femupdate.updating.frf_update`), static deflections or any mix
(:class:`~femupdate.updating.combined.CombinedProblem`) — and :func:`combined_result` reports a
mix."""

from __future__ import annotations

import logging
from collections.abc import Callable, Mapping, Sequence
from dataclasses import replace
from typing import Any

from .._errors import FemupdateError, InputError
from ..frf.residuals import RESIDUALS, check_kind
from ..testdata import TestData
from .combined import DATA_KINDS, STD_KEYS, CombinedProblem, split_std, combined_problem, data_kinds
from ..frf.sensitivity import RESONANCE_TOL
from . import frf as frf_module
from .frf import FRFProblem, FRFUpdateResult, frac, frf_data, modal_report, prepare_problem
from .problem import check_formulation
from .results import UpdateResult
from .solve import diagnostics, paired_modes, solve, update_modal


#: the FRF residuals the updating drivers take: the forms of :mod:`femupdate.frf.residuals` and
#: ``"auto"`` (a log-magnitude stage from the start, then the linear residual from its solution)
FRF_RESIDUALS = RESIDUALS + ("auto",)
#: the FRF residual of :func:`frf_update`, :func:`update`, multi-start and global search by default:
#: on analyser-style data it reached the linear residual's best fit from 60 of 60 random starts,
#: where log reached its own (biased by the noise floor) from 58 and linear from 15
#: (``benchmarks/bench_frf_residual.py``)
DEFAULT_RESIDUAL = "auto"


def auto_stages(run: Callable[[str, Any, bool], UpdateResult], x0, regularized: bool) -> UpdateResult:
    """The FRF residual ``"auto"``: a log-magnitude stage from the start, then the linear residual
    (eq. 34) from the log stage's solution.

    The log-magnitude residual reaches its best fit from far more starts than the linear one (it
    compresses the peaks, which dominate the linear residual with local minima), but the noise
    floor biases it; the linear residual's minimum is unbiased.  Measured on analyser-style data
    (``benchmarks/bench_frf_residual.py``), the second stage starts inside the linear residual's
    basin from almost every start.

    Parameters
    ----------
    run : callable
        ``run(residual, x0, first)`` -> the result of the driver with that residual from that
        start; ``first`` is True for the log stage (which leaves out the standard deviations of
        the linear residual entries).
    x0 : mapping of str to float or None
        The caller's start.
    regularized : bool
        A Tikhonov term pulls toward the start, which a first stage would move: the linear
        residual alone, from the start.

    Returns
    -------
    UpdateResult
        The linear stage's result (its cost, residuals, standard deviations, history and
        ``residual`` are those of the linear residual), with ``nfev``, ``njev`` and
        ``iterations`` counting both stages, ``start`` the caller's, and a note last in
        ``notes`` saying what the stages did (a warning both stages log, such as the lines
        skipped near resonances, is logged once).  When the log stage cannot run (a zero measured
        value, a line on a resonance): the linear residual from the start, with a note.

    Raises
    ------
    InputError, NumericalError
        As the driver with the linear residual.
    """
    if regularized:
        res = run("linear", x0, False)
        return replace(res, notes=[*res.notes, "residual auto with regularization: the linear residual (eq. 34) "
                                   "alone, from the start (the Tikhonov term pulls toward the start, which a first "
                                   "stage would move)"])
    once = _Once()
    frf_log = logging.getLogger(frf_module.__name__)  # the lines skipped: the same in both stages, said once
    frf_log.addFilter(once)
    try:
        try:
            first = run("log", x0, True)
        except FemupdateError as exc:
            res = run("linear", x0, False)
            return replace(res, notes=[*res.notes, f"residual auto: the log-magnitude stage could not run ({exc}); "
                                       "the linear residual (eq. 34) from the start"])
        reached = dict(zip(first.names, map(float, first.x)))
        res = run("linear", reached, False)
    finally:
        frf_log.removeFilter(once)
    shown = ", ".join(f"{n}={v:.6g}" for n, v in reached.items())
    note = (f"residual auto: a log-magnitude stage from the start ({first.nfev} evaluations, "
            f"{'converged' if first.success else 'not converged: ' + first.message}) reached {shown}; then the "
            f"linear residual (eq. 34) from there ({res.nfev} evaluations), whose cost and standard deviations "
            "are reported")
    return replace(res, nfev=first.nfev + res.nfev, njev=first.njev + res.njev,
                   iterations=first.iterations + res.iterations, start=dict(first.start), notes=[*res.notes, note])


class _Once(logging.Filter):
    """Lets each message through once (the warnings that both stages of ``"auto"`` would log)."""

    def __init__(self):
        super().__init__()
        self.seen: set[str] = set()

    def filter(self, record: logging.LogRecord) -> bool:
        message = record.getMessage()
        if message in self.seen:
            return False
        self.seen.add(message)
        return True


def update(model, data: TestData, *, params: Sequence[str] | None = None, x0: Mapping[str, float] | None = None,
           use: Sequence[str] = DATA_KINDS, shape_scaling: str = "unit", ref_dof: str | None = None,
           weights: Mapping | None = None, measurement_std: Mapping | None = None, min_mac: float = 0.5,
           n_modes: int | None = None, parametrisation: str = "relative", method: str = "trf", max_nfev: int = 200,
           ftol: float = 1e-10, xtol: float = 1e-10, gtol: float = 1e-10, use_shapes: bool = True,
           regularization: float | str | None = None, values=None, sensitivity: str = "auto",
           frf_options: Mapping | None = None, pairing: str = "auto", formulation: str = "shapes",
           reuse: bool = True) -> UpdateResult:
    """Update the model's parameters so that it matches the test data: measured modes, FRFs,
    static deflections, or any mix of them, as one least-squares problem.

    Parameters
    ----------
    model : Model
        The model to update.
    data : TestData
        Measured modes (shapes may be partial: any subset of model dofs, any scaling), FRFs at
        any dofs, static load cases with deflections at any dofs.
    params : sequence of str, optional
        Names of the parameters to update (default: every parameter not ``fixed``).
    x0 : mapping of str to float, optional
        Starting values {name: value} (default: the model's nominal values).
    use : sequence of str, default ``("modes", "frf", "static")``
        The kinds of data to use (of those the data hold).
    shape_scaling : {"unit", "ref", "max"}, default ``"unit"``
        Scaling of the compared shapes (:class:`~femupdate.updating.Problem`).
    ref_dof : str, optional
        Reference dof of ``"ref"`` scaling (default: the first measured dof of each mode, the
        paper's eq. 33 convention).
    weights : mapping, optional
        Modal weights {"eigenvalue": w or per-mode array, "shape": w or per-mode array}.
    measurement_std : mapping, optional
        Standard deviations by kind (:func:`combined_problem`): {"eigenvalue": relative std of
        λ, "shape": std of scaled shape entries, "frf": std of the FRF residual entries,
        "static": std of the deflections (m)}; the residuals are divided by them, and the
        covariance is absolute, not scaled by the residual, when every kind used has one (modes
        alone: any stated key; modes with shapes in a mix: both ``"eigenvalue"`` and ``"shape"``).
    min_mac : float, default 0.5
        Pairing threshold of the modes.
    pairing : {"auto", "mac", "order", "frequency"}, default ``"auto"``
        How test modes are paired with model modes (:class:`~femupdate.updating.Problem`):
        ``"auto"`` by frequency order until the shapes show a swap, then by MAC.
    n_modes : int, optional
        Model modes computed and paired among (default ``max(2T, T + 6)`` for T test modes).
    parametrisation : {"relative", "log", "absolute"}, default ``"relative"``
        ``"relative"`` (x = p / ``|p_start|``), ``"log"`` (x = ln p) or ``"absolute"`` (x = p).
    method : {"trf", "dogbox", "lm"}, default ``"trf"``
        ``"lm"``: Levenberg–Marquardt, which ignores the bounds.
    max_nfev : int, default 200
        Largest number of residual evaluations of :func:`scipy.optimize.least_squares`.
    ftol, xtol, gtol : float, default 1e-10
        Tolerances of :func:`scipy.optimize.least_squares`.
    use_shapes : bool, default True
        False: frequencies only.
    regularization : float, {"gcv", "lcurve"} or None, default None
        A Tikhonov factor α, or the rule choosing it at the start; the residual is augmented
        with α (x − x_start).
    values : None, mapping of str to float, or array_like of shape ``(n_parameters,)``, optional
        Values of the fixed parameters (default nominal).
    sensitivity : str, default ``"auto"``
        Derivative route of the modal Jacobian (:func:`femupdate.sensitivity.jacobian`):
        ``"auto"`` (Nelson up to 1,500 dofs; above, the adjoint or subspace series), ``"nelson"``,
        ``"modal"``, ``"static"``, ``"subspace"``, ``"adjoint"`` or ``"fd"``.
    reuse : bool, default True
        Models above 1,500 dofs (sparse eigen-solutions): reuse from one evaluation to the next
        the model's factorisation workspace and the previous modes as the eigensolver's start
        (:class:`~femupdate.updating.Problem`); the same solution to round-off.  False: every
        evaluation factorises afresh (the route before this option existed).
    frf_options : mapping, optional
        Options of the FRF residuals, as :func:`~femupdate.updating.frf_update` takes them:
        ``residual`` (``"auto"``, the default: the whole problem solved with ``"log"`` FRF
        residuals, then with ``"linear"`` ones from that solution, :func:`auto_stages`;
        ``"linear"`` eq. 34, ``"relative"``, ``"log"``), ``weights``, ``lines``, ``select``,
        ``resonance``, ``resonance_tol``, ``damping``, ``solver``.
    formulation : {"shapes", "mac", "dynamic"}, default ``"shapes"``
        The modal residuals (:class:`~femupdate.updating.Problem`): ``"shapes"`` relative
        eigenvalue errors and scaled shape differences; ``"mac"`` relative eigenvalue errors and
        MAC residuals (cost w² (1 − MAC) / 2 per mode); ``"dynamic"`` the modal dynamic residual
        (K − λ_E M) φ of every dof, the unmeasured shape entries solved for (no eigen-solution;
        every test mode needs a shape).  Measured modes only.

    Returns
    -------
    UpdateResult
        Modes only: as :func:`update_modal`.  FRFs only: as
        :func:`~femupdate.updating.frf_update` (an :class:`~femupdate.updating.frf.FRFUpdateResult`).
        A mix, or static cases: an :class:`UpdateResult` (an ``FRFUpdateResult`` when FRFs are
        used) whose ``blocks`` give each block's share of the cost and whose ``notes`` say how
        the blocks were weighted.  ``success``/``status``/``message`` report convergence
        (non-convergence is a status, not an exception).

    Raises
    ------
    InputError
        Bad options or data (named).
    NumericalError
        The model cannot be evaluated (unpaired modes, a singular stiffness for static data,
        ...) or the solver failed.
    """
    call = dict(locals())
    if method not in ("trf", "dogbox", "lm"):
        raise InputError(f"unknown method {method!r}: use trf, dogbox or lm")
    kinds = data_kinds(data, use)
    if formulation != "shapes" and "modes" not in kinds:
        check_formulation(formulation)  # an unknown one is named first
        raise InputError(f"formulation {formulation!r} (--formulation) applies to measured modes; the data used are: "
                         f"{', '.join(kinds)}")
    modal_options: dict[str, Any] = dict(shape_scaling=shape_scaling, ref_dof=ref_dof, weights=weights, min_mac=min_mac,
                         n_modes=n_modes, use_shapes=use_shapes, sensitivity=sensitivity, pairing=pairing,
                         formulation=formulation, reuse=reuse)
    solver_options: dict[str, Any] = dict(method=method, max_nfev=max_nfev, ftol=ftol, xtol=xtol, gtol=gtol)
    unused = sorted({STD_KEYS[k] for k in dict(measurement_std or {}) if k in STD_KEYS} - set(kinds))
    if unused:
        raise InputError(f"standard deviations given for {', '.join(unused)} data (--std-{unused[0]}), but the data "
                         f"used are: {', '.join(kinds)}")
    if kinds == ("modes",) and not frf_options:
        return update_modal(model, data, params=params, x0=x0, values=values, parametrisation=parametrisation,
                            measurement_std=measurement_std, regularization=regularization, **modal_options,
                            **solver_options)
    residual = (check_kind(dict(frf_options or {}).get("residual", DEFAULT_RESIDUAL), FRF_RESIDUALS)
                if "frf" in kinds else "")
    if residual == "auto" and not (kinds == ("frf",) and data.n_frf_sets == 1):  # one set: frf_update's stages

        def stage(kind, start, first):
            std = {k: v for k, v in dict(measurement_std or {}).items() if not (first and k == "frf")}
            return update(**dict(call, x0=start, measurement_std=std or None,
                                 frf_options=dict(frf_options or {}, residual=kind)))

        return auto_stages(stage, x0, regularization is not None)
    if kinds == ("frf",) and data.n_frf_sets == 1:
        std = split_std(measurement_std)
        return frf_update(model, data, params=params, x0=x0, values=values, parametrisation=parametrisation,
                          measurement_std=std.get("frf", {}).get("frf"), regularization=regularization,
                          **dict(frf_options or {}), **solver_options)
    combined = combined_problem(model, data, params, use=kinds, x0=x0, values=values, parametrisation=parametrisation,
                            measurement_std=measurement_std, frf_options=frf_options,
                            regularized=regularization is not None, method=method, **modal_options)
    sol, history, reg = solve(combined, model.bounds, regularization=regularization, **solver_options)
    return combined_result(combined, data, sol.x, sol, history, reg, bounded=method != "lm")


def combined_result(prob: CombinedProblem, data: TestData, x, sol=None, history=None, reg=None,
                    bounded: bool = True) -> UpdateResult:
    """The result of ``prob`` at the variables x (:func:`~femupdate.updating.result_at` for a
    :class:`CombinedProblem`).

    Parameters
    ----------
    prob : CombinedProblem
        The problem.
    data : TestData
        Its test data (the FRF data for ``frac``; the modes for the pairing when there is no
        modal block).
    x : array_like, shape ``(L,)``
        The optimiser's variables.
    sol : scipy.optimize.OptimizeResult, optional
        Convergence figures; None: a plain evaluation (``success`` False, one evaluation).
    history : list of dict, optional
        The iteration history (:func:`~femupdate.updating.solve`).
    reg : dict, optional
        The regularisation used.
    bounded : bool, default True
        The solver kept to the model's bounds (False for Levenberg–Marquardt).

    Returns
    -------
    UpdateResult
        An :class:`~femupdate.updating.frf.FRFUpdateResult` when an FRF block is used (its FRF
        fields from that block); ``blocks`` and ``notes`` filled; ``sensitivity`` the routes of
        the blocks joined by ``" + "``.

    Raises
    ------
    NumericalError
        A block cannot be evaluated at x.
    """
    model = prob.model
    r = prob.residuals(x)
    J = prob.jacobian(x)
    p_final = prob.to_p(x)
    modal = prob.modal
    if modal is not None:  # its modes at x, cached by the evaluation above: no second eigen-solution
        _, modes, mpairs = modal.evaluate(x)
        paired = paired_modes(modal, modes, mpairs)
        swaps, routes = list(modal.swaps), [modal.sensitivity_used]
        natural = modes.frequencies_hz[:10]
        formulation, expanded = modal.formulation, modal.expanded_shapes(x)
    else:
        mp, f_test, f_model, natural = modal_report(model, data, p_final)
        paired = dict(pairs=mp, test_frequencies_hz=f_test, model_frequencies_hz=f_model)
        swaps, routes = [], []
        formulation, expanded = "", None
    frf_blocks = [b for b in prob.blocks if b.kind == "frf"]
    routes += ["brandon"] if frf_blocks else []
    routes += ["static (brandon at ω = 0)"] if any(b.kind == "static" for b in prob.blocks) else []
    history = history if history is not None else []
    diag = diagnostics(prob, x, r, J, prob.sigma, bounds=model.bounds if bounded else None)
    common = dict(
        parameters=dict(zip(model.parameter_names, map(float, p_final))), names=tuple(prob.names), x=p_final[prob.idx],
        success=bool(sol.success) if sol is not None else False, status=int(sol.status) if sol is not None else 0,
        message=str(sol.message) if sol is not None else "evaluated, not solved", cost=float(0.5 * r @ r), fun=r,
        jac=J, nfev=int(sol.nfev) if sol is not None else 1, njev=int(sol.njev or 0) if sol is not None else 0,
        iterations=max(len(history) - 1, int(sol.njev or 0) if sol is not None else 0), history=history,
        **paired, swaps=swaps,
        diagnostics=diag, regularization=reg or {},
        start=dict(zip(prob.names, map(float, prob.p_base[prob.idx]))), sensitivity=" + ".join(routes),
        blocks=prob.block_costs(r), notes=list(prob.notes) + (list(modal.notes) if modal is not None else []) + diag.notes,
        formulation=formulation, expanded_shapes=expanded)
    if not frf_blocks:
        return UpdateResult(**common)
    fp = frf_blocks[0].problem
    assert isinstance(fp, FRFProblem)
    several = len(frf_blocks) > 1  # a multi-reference test: FRAC per response and excitation
    fracs: dict[str, float] = {}
    skipped: list[dict] = []
    for b, fs in zip(frf_blocks, data.frf_sets):
        q = b.problem
        assert isinstance(q, FRFProblem)
        exc = ", ".join(fs.force)
        fracs.update((f"{d} (excitation {exc})" if several else d, float(v))
                     for d, v in zip(fs.dofs, frac(q.xe, q.responses(x))))
        skipped += list(getattr(q, "skipped", []))
    return FRFUpdateResult(**common, omega=fp.omega, skipped=skipped, residual=fp.kind, frac=fracs,
                           natural_frequencies_hz=natural)



def frf_update(model, data, *, params: Sequence[str] | None = None, x0: Mapping[str, float] | None = None,
               residual: str = DEFAULT_RESIDUAL, weights=None, measurement_std=None, lines=None, select: int | None = None,
               resonance: str = "skip", resonance_tol: float = RESONANCE_TOL, damping=None,
               parametrisation: str = "relative", method: str = "trf", max_nfev: int = 200, ftol: float = 1e-10,
               xtol: float = 1e-10, gtol: float = 1e-10, regularization: float | str | None = None, values=None,
               solver: str = "auto") -> FRFUpdateResult:
    """Update the model's parameters so that its FRFs match measured ones (eqs. 30-32).

    Parameters
    ----------
    model : Model
        The model to update.
    data : TestData or FRFData
        Test data with ``frf``, or FRF data: responses at any subset of dofs to one force vector.
        Test data with several FRF sets (a roving-hammer or multi-reference test, ``frf_sets``)
        are compared set by set, one residual block per excitation
        (:func:`~femupdate.updating.combined.combined_problem`; ``blocks`` in the result).
    params : sequence of str, optional
        Names of the parameters to update (default: every parameter not ``fixed``).
    x0 : mapping of str to float, optional
        Starting values {name: value} (default: the model's values, or ``values``).
    residual : {"auto", "linear", "relative", "log"}, default ``"auto"``
        ``"linear"`` (eq. 34), ``"relative"``, ``"log"`` (log-magnitude), or ``"auto"``: a
        log-magnitude stage from the start, then the linear residual from its solution
        (:func:`auto_stages`).  Without ``measurement_std`` the linear residuals are divided by
        the RMS of the measured responses (a note says so): the cost is dimensionless, and
        neither it nor the solver's stopping tests depend on the data's units.
    weights : array_like, optional
        Broadcastable to the data's (n_lines, n_dofs), multiplying the residuals.
    measurement_std : float or array_like, optional
        Standard deviation of the residual entries (scalar or broadcastable array); the
        residuals are divided by it and the covariance is absolute.
    lines : array_like of int or bool, optional
        Indices (0-based) or a boolean mask of the data's lines to use (default all).
    select : int, optional
        Choose this many of the lines by conditioning of the sensitivity matrix.
    resonance : {"skip", "error", "keep"}, default ``"skip"``
        What to do with lines within ``resonance_tol`` of a resonance of the model at ``values``
        (the nominal model: the same lines for every start of a multi-start study).
    resonance_tol : float, default 1e-3
        Relative eigenvalue distance within which a line is near a resonance.
    damping : Damping or mapping, optional
        :class:`~femupdate.frf.Damping` of the model, or ``{alpha, beta, eta}`` (default
        undamped: real responses).
    parametrisation, method, max_nfev, ftol, xtol, gtol, regularization, values
        As in :func:`femupdate.updating.update`.
    solver : {"auto", "dense", "sparse"}, default ``"auto"``
        Solver of the line systems.

    Returns
    -------
    FRFUpdateResult
        ``pairs`` and the frequencies of the pairs only when the test data hold modes too.

    Raises
    ------
    InputError
        As :func:`prepare_problem`, or a start outside the bounds.
    NumericalError
        A line on a resonance of the model during the iteration, or the solver failed.
    """
    if check_kind(residual, FRF_RESIDUALS) == "auto":
        call = dict(locals())

        def stage(kind, start, first):
            return frf_update(**dict(call, x0=start, residual=kind, measurement_std=None if first else measurement_std))

        res = auto_stages(stage, x0, regularization is not None)
        assert isinstance(res, FRFUpdateResult)
        return res
    if isinstance(data, TestData) and data.n_frf_sets > 1:  # a multi-reference test: one block per excitation

        opts = dict(residual=residual, weights=weights, lines=lines, select=select, resonance=resonance,
                    resonance_tol=resonance_tol, damping=damping, solver=solver)
        combined = combined_problem(model, data, params, use=("frf",), x0=x0, values=values,
                                    parametrisation=parametrisation,
                                    measurement_std=None if measurement_std is None else {"frf": measurement_std},
                                    frf_options=opts, regularized=regularization is not None, method=method)
        sol, history, reg = solve(combined, model.bounds, regularization=regularization, method=method, ftol=ftol,
                                  xtol=xtol, gtol=gtol, max_nfev=max_nfev)
        res = combined_result(combined, data, sol.x, sol, history, reg, bounded=method != "lm")
        assert isinstance(res, FRFUpdateResult)
        return res
    prob, sigma, skipped, notes = prepare_problem(model, data, params, x0, residual, weights, measurement_std, lines, select,
                                           resonance, resonance_tol, damping, parametrisation, values, solver,
                                           regularization is not None, method)
    names = prob.names
    frf = frf_data(data)
    sol, history, reg = solve(prob, model.bounds, regularization=regularization, method=method, ftol=ftol,
                               xtol=xtol, gtol=gtol, max_nfev=max_nfev)
    p_final = prob.to_p(sol.x)
    r = prob.residuals(sol.x)
    J = prob.jacobian(sol.x)
    diag = diagnostics(prob, sol.x, r, J, sigma, bounds=None if method == "lm" else model.bounds)
    xa = prob.responses(sol.x)
    pairs, f_test, f_model, natural = modal_report(model, data, p_final)
    return FRFUpdateResult(
        parameters=dict(zip(model.parameter_names, map(float, p_final))),
        names=tuple(names), x=p_final[prob.idx], success=bool(sol.success), status=int(sol.status),
        message=str(sol.message), cost=float(0.5 * r @ r), fun=r, jac=J, nfev=int(sol.nfev),
        njev=int(sol.njev or 0), iterations=max(len(history) - 1, int(sol.njev or 0)), history=history,
        pairs=pairs, test_frequencies_hz=f_test, model_frequencies_hz=f_model, swaps=[], diagnostics=diag,
        regularization=reg, start=dict(zip(names, map(float, prob.p_base[prob.idx]))), sensitivity="brandon",
        omega=prob.omega, skipped=skipped, residual=residual, frac=dict(zip(frf.dofs, frac(prob.xe, xa))),
        natural_frequencies_hz=natural, notes=notes + diag.notes,
    )


__all__ = ["update", "combined_result", "frf_update", "auto_stages", "FRF_RESIDUALS",
           "DEFAULT_RESIDUAL"]
