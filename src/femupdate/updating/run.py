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

import numpy as np

from .._checks import frf_fit, problem_args
from .._errors import FemupdateError, InputError
from ..frf.residuals import RESIDUALS, check_kind
from ..testdata import TestData
from .combined import DATA_KINDS, STD_KEYS, CombinedProblem, split_std, combined_problem, data_kinds
from ..frf.sensitivity import RESONANCE_TOL
from . import frf as frf_module
from .frf import FRFProblem, FRFUpdateResult, frac, frf_data, modal_report, prepare_problem
from ..options import FRFOptions, ModalOptions, NoiseOptions, PairingOptions, SolverOptions, UpdateOptions, gather
from .results import UpdateResult, attach
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
           values=None, use: Sequence[str] | None = None, modal: ModalOptions | None = None,
           pairing: PairingOptions | str | None = None, noise: NoiseOptions | None = None,
           solver: SolverOptions | None = None, frf: FRFOptions | None = None, options: UpdateOptions | None = None,
           **shorthand) -> UpdateResult:
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
    values : None, mapping of str to float, or array_like of shape ``(n_parameters,)``, optional
        Values of the fixed parameters (default nominal).
    use : sequence of str, default ``("modes", "frf", "static")``
        The kinds of data to use (of those the data hold).
    modal : ModalOptions, optional
        The residuals of measured modes (:class:`~femupdate.options.ModalOptions`: formulation,
        shape scaling, reference dof, shapes used, derivative route, factorisation reuse).
    pairing : PairingOptions or str, optional
        How test modes pair with model modes (:class:`~femupdate.options.PairingOptions`; a
        string is its rule).
    noise : NoiseOptions, optional
        Standard deviations by kind of data and modal weights
        (:class:`~femupdate.options.NoiseOptions`): each block is divided by its stated standard
        deviation, and the covariance is absolute, not scaled by the residual, when every kind
        used has one (modes alone: any stated key; modes with shapes in a mix: both
        ``"eigenvalue"`` and ``"shape"``).
    solver : SolverOptions, optional
        The least-squares solver, its variables and regularisation
        (:class:`~femupdate.options.SolverOptions`).
    frf : FRFOptions, optional
        The FRF residuals (:class:`~femupdate.options.FRFOptions`; ``"auto"`` by default: the
        whole problem solved with ``"log"`` FRF residuals, then with ``"linear"`` ones from that
        solution, :func:`auto_stages`).  ``frf_options`` (a mapping) is accepted as before.
    options : UpdateOptions, optional
        All of the above in one object (what a multi-start study hands to each start); the
        arguments above replace its parts.
    **shorthand
        Fields of the option objects as keywords (``min_mac=0.8``, ``max_nfev=50``,
        ``measurement_std={"eigenvalue": 0.01}``, ...).

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
    TypeError
        A keyword no option object has.
    NumericalError
        The model cannot be evaluated (unpaired modes, a singular stiffness for static data,
        ...) or the solver failed.
    """
    view = damped_doors("update", model, data, params=params, x0=x0, values=values)
    o = UpdateOptions.of("update", shorthand, options=options, use=use, modal=modal, pairing=pairing, noise=noise,
                         solver=solver, frf=frf)
    frf_fit(o.frf, o.noise, data, "update")
    res = update_with(view or model, data, o, params=params, x0=x0, values=values)
    if view is not None:
        return attach(res, view, data, "update")
    return attach(res, model, data, "update", damping=_damping_of(o))


def damped_doors(where: str, model, data, *, params=None, x0=None, values=None, frf: bool = False):
    """The doors of a verb (:func:`~femupdate._checks.problem_args`); for a damped model
    (:class:`~femupdate.damping.DampedModel`) its engine view
    (:class:`~femupdate.damping.view.DampedView`), else None."""
    from ..damping.view import as_view

    view = as_view(model)
    if view is None:
        problem_args(where, model, data, params=params, x0=x0, values=values, frf=frf)
        return None
    from .._checks import data_arg, params_arg, values_arg, x0_arg

    data_arg(data, "data", where, frf=frf)
    params_arg(params, "params", where)
    x0_arg(view, x0, "x0", where)
    values_arg(view, values, "values", where)
    return view


def _damping_of(o: UpdateOptions):
    """The model damping of the FRF options (compared with the data's damping ratios), or None."""
    if o.frf.damping is None:
        return None
    from ..frf.damping import as_damping

    return as_damping(o.frf.damping)


def update_with(model, data: TestData, options: UpdateOptions, *, params: Sequence[str] | None = None,
                x0: Mapping[str, float] | None = None, values=None) -> UpdateResult:
    """:func:`update` with its options in one :class:`~femupdate.options.UpdateOptions` (a damped
    model's view: :func:`~femupdate.updating.damped_run.update_damped`)."""
    from ..damping.view import DampedView

    if isinstance(model, DampedView):
        return _damped_with(model, data, options, params=params, x0=x0, values=values)
    res = _undamped_with(model, data, options, params=params, x0=x0, values=values)
    said = undamped_notes(data, options)
    return replace(res, notes=[*res.notes, *said]) if said else res


def undamped_notes(data, options: UpdateOptions) -> list[str]:
    """What an undamped model does with damped test data: complex shapes compared by their real
    form, damping ratios compared (not updated) — said, with what is used."""
    if not isinstance(data, TestData) or "modes" not in data_kinds(data, options.use):
        return []
    out = []
    if dict(options.noise.std or {}).get("damping_ratio") is not None:
        out.append("measurement_std['damping_ratio'] is not used: the model is undamped (its damping ratios are not "
                   "updated); give the model a [damping] table")
    cplx = [k + 1 for k, m in enumerate(data.modes) if m.has_shape and np.iscomplexobj(m.shape)]
    if cplx and options.modal.use_shapes:
        out.append(f"the test data hold complex shapes (test mode(s) {', '.join(map(str, cplx))}) but the model is "
                   "undamped: their real form is compared (each rotated to its largest entry, the imaginary part "
                   "dropped); give the model a [damping] table to compare them as complex modes")
    zeta = [k + 1 for k, m in enumerate(data.modes) if m.damping_ratio is not None]
    if zeta:
        out.append(f"the test data hold damping ratios (test mode(s) {', '.join(map(str, zeta))}) but the model is "
                   "undamped: the frequencies are used, the damping ratios only compared with the FRF damping "
                   "(--damping); give the model a [damping] table to update damping parameters from them")
    return out


def _damped_with(view, data, o: UpdateOptions, *, params=None, x0=None, values=None) -> UpdateResult:
    """A damped model's update, with the FRF residual ``"auto"`` in its two stages."""
    from .damped_run import update_damped

    kinds = data_kinds(data, o.use)
    if "frf" in kinds and o.frf.residual == "auto":

        def stage(kind, start, first):
            std = {k: v for k, v in dict(o.noise.std or {}).items() if not (first and k == "frf")}
            staged = o.replace(noise=o.noise.replace(std=std or None), frf=o.frf.replace(residual=kind))
            return update_damped(view, data, staged, params=params, x0=start, values=values)

        return auto_stages(stage, x0, o.solver.regularization is not None)
    return update_damped(view, data, o, params=params, x0=x0, values=values)


def _undamped_with(model, data: TestData, options: UpdateOptions, *, params: Sequence[str] | None = None,
                   x0: Mapping[str, float] | None = None, values=None) -> UpdateResult:
    o = options
    kinds = data_kinds(data, o.use)
    if o.modal.formulation != "shapes" and "modes" not in kinds:
        raise InputError(f"formulation {o.modal.formulation!r} (--formulation) applies to measured modes; the data "
                         f"used are: {', '.join(kinds)}")
    unused = sorted({STD_KEYS[k] for k in dict(o.noise.std or {}) if k in STD_KEYS} - set(kinds))
    if unused:
        raise InputError(f"standard deviations given for {', '.join(unused)} data (--std-{unused[0]}), but the data "
                         f"used are: {', '.join(kinds)}")
    if kinds == ("modes",) and not o.frf.changed():
        return update_modal(model, data, params=params, x0=x0, values=values, modal=o.modal, pairing=o.pairing,
                            noise=o.noise, solver=o.solver)
    residual = o.frf.residual if "frf" in kinds else ""
    regularized = o.solver.regularization is not None
    if residual == "auto" and not (kinds == ("frf",) and data.n_frf_sets == 1):  # one set: frf_update's stages

        def stage(kind, start, first):
            std = {k: v for k, v in dict(o.noise.std or {}).items() if not (first and k == "frf")}
            staged = o.replace(noise=o.noise.replace(std=std or None), frf=o.frf.replace(residual=kind))
            return _undamped_with(model, data, staged, params=params, x0=start, values=values)

        return auto_stages(stage, x0, regularized)
    if kinds == ("frf",) and data.n_frf_sets == 1:
        return frf_update_with(model, data, o.frf, o.noise, o.solver, params=params, x0=x0, values=values)
    combined = combined_problem(model, data, params, x0=x0, values=values, options=o.replace(use=kinds),
                                regularized=regularized)
    sol, history, reg = solve(combined, model.bounds, o.solver)
    return combined_result(combined, data, sol.x, sol, history, reg, bounded=o.solver.method != "lm")


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
        formulation, expanded = modal.formulation_used, modal.expanded_shapes(x)
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
               values=None, noise: NoiseOptions | None = None, solver: SolverOptions | None = None,
               frf: FRFOptions | None = None, **shorthand) -> FRFUpdateResult:
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
    values : None, mapping of str to float, or array_like of shape ``(n_parameters,)``, optional
        Values of the fixed parameters (default nominal).
    noise : NoiseOptions, optional
        ``std={"frf": s}``: the standard deviation of the residual entries (scalar or
        broadcastable array); the residuals are divided by it and the covariance is absolute.
        Without it the linear residuals are divided by the RMS of the measured responses (a note
        says so): the cost is dimensionless, and neither it nor the solver's stopping tests
        depend on the data's units.  The shorthand ``measurement_std=s`` is that std.
    solver : SolverOptions, optional
        As :func:`femupdate.update`.
    frf : FRFOptions, optional
        The residual (``"auto"`` by default: a log-magnitude stage from the start, then the
        linear residual from its solution, :func:`auto_stages`), weights, lines, line selection,
        resonances, damping and line solver (:class:`~femupdate.options.FRFOptions`).
    **shorthand
        Fields of those option objects as keywords (``residual="log"``, ``max_nfev=50``, ...;
        ``weights`` are the FRF weights).

    Returns
    -------
    FRFUpdateResult
        ``pairs`` and the frequencies of the pairs only when the test data hold modes too.

    Raises
    ------
    InputError
        As :func:`prepare_problem`, or a start outside the bounds.
    TypeError
        A keyword no option object has.
    NumericalError
        A line on a resonance of the model during the iteration, or the solver failed.
    """
    view = damped_doors("frf_update", model, data, params=params, x0=x0, values=values, frf=True)
    std_given = shorthand.get("measurement_std")
    if std_given is not None and not isinstance(std_given, Mapping):  # the std of the FRF entries
        shorthand = dict(shorthand, measurement_std={"frf": std_given})
    o = gather("frf_update", shorthand, frf=(FRFOptions, frf), noise=(NoiseOptions, noise),
               solver=(SolverOptions, solver))
    frf_fit(o["frf"], o["noise"], data, "frf_update")
    res = frf_update_with(view or model, data, o["frf"], o["noise"], o["solver"], params=params, x0=x0, values=values)
    return attach(res, view or model, data, "frf-update")


def frf_update_with(model, data, frf: FRFOptions, noise: NoiseOptions, solver: SolverOptions, *,
                    params: Sequence[str] | None = None, x0: Mapping[str, float] | None = None,
                    values=None) -> FRFUpdateResult:
    """:func:`frf_update` with its options as objects, without the result's context (what each
    start of a multi-start study runs: its result travels back without the model and data)."""
    from ..damping.view import DampedView

    if isinstance(model, DampedView):  # damping parameters among the unknowns: the damped receptances
        if not isinstance(data, TestData):
            data = TestData(frf=data)
        res = _damped_with(model, data, UpdateOptions(use=("frf",), noise=noise, solver=solver, frf=frf), params=params,
                           x0=x0, values=values)
        assert isinstance(res, FRFUpdateResult)
        return res
    regularized = solver.regularization is not None
    if frf.residual == "auto":

        def stage(kind, start, first):
            return frf_update_with(model, data, frf.replace(residual=kind), noise.replace(std=None) if first else noise,
                                   solver, params=params, x0=start, values=values)

        res = auto_stages(stage, x0, regularized)
        assert isinstance(res, FRFUpdateResult)
        return res
    if isinstance(data, TestData) and data.n_frf_sets > 1:  # a multi-reference test: one block per excitation
        combined = combined_problem(model, data, params, x0=x0, values=values,
                                    options=UpdateOptions(use=("frf",), noise=noise, solver=solver, frf=frf),
                                    regularized=regularized)
        sol, history, reg = solve(combined, model.bounds, solver)
        res = combined_result(combined, data, sol.x, sol, history, reg, bounded=solver.method != "lm")
        assert isinstance(res, FRFUpdateResult)
        return res
    unknown = sorted(set(dict(noise.std or {})) - {"frf"})
    if unknown:
        raise InputError(f"measurement_std: frf_update takes the std of the FRF entries ('frf'), not {unknown[0]!r}")
    measurement_std = dict(noise.std or {}).get("frf")
    prob, sigma, skipped, notes = prepare_problem(model, data, params, x0, frf, solver, measurement_std=measurement_std,
                                                  values=values, regularized=regularized)
    names = prob.names
    frf_set = frf_data(data)
    sol, history, reg = solve(prob, model.bounds, solver)
    p_final = prob.to_p(sol.x)
    r = prob.residuals(sol.x)
    J = prob.jacobian(sol.x)
    diag = diagnostics(prob, sol.x, r, J, sigma, bounds=None if solver.method == "lm" else model.bounds)
    xa = prob.responses(sol.x)
    pairs, f_test, f_model, natural = modal_report(model, data, p_final)
    return FRFUpdateResult(
        parameters=dict(zip(model.parameter_names, map(float, p_final))),
        names=tuple(names), x=p_final[prob.idx], success=bool(sol.success), status=int(sol.status),
        message=str(sol.message), cost=float(0.5 * r @ r), fun=r, jac=J, nfev=int(sol.nfev),
        njev=int(sol.njev or 0), iterations=max(len(history) - 1, int(sol.njev or 0)), history=history,
        pairs=pairs, test_frequencies_hz=f_test, model_frequencies_hz=f_model, swaps=[], diagnostics=diag,
        regularization=reg, start=dict(zip(names, map(float, prob.p_base[prob.idx]))), sensitivity="brandon",
        omega=prob.omega, skipped=skipped, residual=frf.residual, frac=dict(zip(frf_set.dofs, frac(prob.xe, xa))),
        natural_frequencies_hz=natural, notes=notes + diag.notes,
    )


__all__ = ["update", "update_with", "frf_update_with", "combined_result", "frf_update", "auto_stages", "FRF_RESIDUALS",
           "DEFAULT_RESIDUAL"]
