"""Result objects of the updating drivers: short to print, complete to inspect."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np

from ..serialise import RunContext, Serialisable


@dataclass(frozen=True, eq=False)
class Diagnostics:
    """Identifiability at the solution (:func:`~femupdate.updating.diagnostics`).

    A parameter that sits on one of its bounds at the solution is held there by the bound, not by
    the data: it is listed in ``at_bounds`` and the singular values, rank, condition number,
    covariance and standard deviations describe the *free* parameters only (with no bound
    active, all of them).

    Attributes
    ----------
    singular_values : numpy.ndarray, shape ``(min(m, L_free),)``
        Singular values, descending, of the normalised sensitivity matrix S = ∂r/∂(p/``|p|``)
        (columns scaled by the parameter values, so units do not matter) over the free
        parameters' columns.
    condition_number : float
        σ_max / σ_min of that S (inf when σ_min is zero or with fewer data than free parameters;
        merely very large when S is numerically rank-deficient; NaN when no parameter is free).
    rank : int
        Numerical rank of that S (singular values above 1e-6 σ_max), at most ``len(free)``.
    poorly_determined : list of str
        Parameters the data cannot move, sorted by name; why, in ``poorly_determined_reasons``:
        their column of S is (near) zero, they dominate a right singular vector of the free
        parameters' null space (the data determine only a combination), or their standard
        deviation exceeds their value's magnitude
        (:data:`~femupdate.updating.solve.POOR_RELATIVE_STD`).
    covariance : numpy.ndarray, shape ``(L, L)``
        In parameter units (squared), built on the noise of each block of residuals (``noise``:
        stated, or estimated from the fit by REML); NaN when not estimable, and in the rows and
        columns of the parameters on a bound.
    std : numpy.ndarray, shape ``(L,)``
        Standard deviations (parameter units), the square roots of the covariance's diagonal (NaN
        for a parameter on a bound).
    n_residuals : int
        m, the number of residuals.
    n_parameters : int
        L, the number of updated parameters.
    absolute : bool
        Every block's noise is stated (the residuals are divided by stated standard deviations):
        the covariance is absolute; else some of it is estimated from the fit (``noise``).
    at_bounds : dict of str to str
        The parameters sitting on a bound at the solution, {name: ``"lower"`` or ``"upper"``}, in
        the order of the updated parameters (empty when the solver ignored the bounds).
    free : tuple of str
        The updated parameters not on a bound, whose figures the analysis gives.
    poorly_determined_reasons : dict of str to str
        {name: why} for each of ``poorly_determined``.
    relative_std : numpy.ndarray, shape ``(L,)``
        ``std / |value|`` (``std`` itself for a value of 0): the standard deviation in the
        normalised variables of S; NaN where ``std`` is.
    noise : list of dict
        What the standard deviations rest on, one record per noise component
        (:func:`femupdate.updating.noise.basis_records`): ``label``, ``kind``, ``basis``
        (``"stated"``, ``"estimated"``, ``"pooled"``, ``"not estimable"``), ``source`` (``"stated
        in the data file"``, ``"given as an option"``, or the basis), ``std`` (in the residuals'
        units; 1 for stated), ``dof`` (its degrees of freedom, None for stated), ``redundancy``,
        ``n_residuals``, ``members`` (the blocks it covers).
    std_dof : numpy.ndarray, shape ``(L,)``
        Satterthwaite effective degrees of freedom of each standard deviation (inf: it rests on
        stated noise only; NaN where ``std`` is): intervals are Student-t with them
        (:meth:`interval`).
    model_error : dict
        The test of the fit (:meth:`femupdate.variance.FitTest.record`): ``test``,
        ``statistic``, ``dof``, ``p_value``, ``alpha``, ``verdict`` (``"model error"``,
        ``"consistent"``, ``"untested"``), ``detail``; empty when not tested.
    noise_notes : list of str
        How blocks were pooled, and noise that could not be estimated.
    """

    singular_values: np.ndarray
    condition_number: float
    rank: int
    poorly_determined: list[str]
    covariance: np.ndarray
    std: np.ndarray
    n_residuals: int
    n_parameters: int
    absolute: bool = False
    at_bounds: dict[str, str] = field(default_factory=dict)
    free: tuple[str, ...] = ()
    poorly_determined_reasons: dict[str, str] = field(default_factory=dict)
    relative_std: np.ndarray = field(default_factory=lambda: np.zeros(0))
    noise: list[dict] = field(default_factory=list)
    std_dof: np.ndarray = field(default_factory=lambda: np.zeros(0))
    model_error: dict = field(default_factory=dict)
    noise_notes: list[str] = field(default_factory=list)

    def interval(self, level: float = 0.95) -> np.ndarray:
        """Half-widths of each parameter's two-sided interval at ``level`` (parameter units):
        Student-t quantiles with ``std_dof`` times ``std`` (normal where the dof are infinite or
        unknown)."""
        from ..variance import t_quantile

        dof = np.asarray(self.std_dof, float) if np.size(self.std_dof) == np.size(self.std) else \
            np.full(np.size(self.std), np.inf)
        return t_quantile(0.5 + level / 2, dof) * self.std

    @property
    def basis_lines(self) -> list[str]:
        """One line per noise component: what the standard deviations rest on, and the fit's
        test (:mod:`femupdate.updating.noise`)."""
        from ..variance import METHOD
        from .noise import basis_lines

        return basis_lines(self.noise, METHOD)

    @property
    def model_error_line(self) -> str:
        """The fit's test in one line ('' when not tested)."""
        from .noise import model_error_line

        return model_error_line(self.model_error)

    @property
    def n_at_bounds(self) -> int:
        """The number of parameters on a bound (active bounds)."""
        return len(self.at_bounds)

    @property
    def notes(self) -> list[str]:
        """What the user should know about these figures: with active bounds, that the covariance
        and standard deviations describe the free parameters only (empty otherwise)."""
        if not self.at_bounds:
            return []
        k = len(self.at_bounds)
        which = ", ".join(f"{n} {side}" for n, side in self.at_bounds.items())
        return [f"{k} parameter{'s' if k > 1 else ''} on {'their' if k > 1 else 'its'} bound{'s' if k > 1 else ''} "
                f"({which}): held there by the bounds, not by the data; the covariance and std describe the "
                f"{self.n_parameters - k} free parameter{'s' if self.n_parameters - k != 1 else ''} only"]

    def __repr__(self) -> str:
        bound = f", {self.n_at_bounds} on bounds" if self.at_bounds else ""
        poor = f", poorly determined: {', '.join(self.poorly_determined)}" if self.poorly_determined else ""
        free = f"/{self.n_parameters - self.n_at_bounds} free" if self.at_bounds else f"/{self.n_parameters}"
        return (f"Diagnostics(rank {self.rank}{free}, condition {self.condition_number:.3g}, "
                f"{self.n_residuals} residuals{bound}{poor})")


@dataclass(frozen=True, eq=False)
class RunResult:
    """What every solve from one start reports (:class:`UpdateResult`, and the lighter
    :class:`~femupdate.updating.batched.BatchRun` of the compiled route).

    Attributes
    ----------
    parameters : dict of str to float
        Every model parameter's value {name: value} at the solution (physical units).
    names : tuple of str
        The updated parameters.
    x : numpy.ndarray, shape ``(L,)``
        Their values at the solution (physical units), in the order of ``names``.
    success : bool
        Whether the solver converged.
    status : int
        As :func:`scipy.optimize.least_squares` reports it (1 gtol, 2 ftol, 3 xtol, 4 ftol and
        xtol, 0 evaluations exhausted).
    message : str
        The solver's message.
    cost : float
        ½‖r‖² at the solution.
    fun : numpy.ndarray, shape ``(m,)``
        The residuals r (modal ones dimensionless: relative eigenvalue errors and scaled shape
        differences, times their weights).
    jac : numpy.ndarray, shape ``(m, L)``
        ∂r/∂x, the Jacobian in the optimiser's variables x — with the default ``"relative"``
        parametrisation x = p / ``|p_start|``, so column j is the change of the residuals per unit
        relative change of parameter j (∂r/∂p_j · ``|p_start,j|``); with ``"log"`` per unit change
        of ln p_j; with ``"absolute"`` per unit of p_j.
    nfev, njev, iterations : int
        Counts of the solver: residual evaluations, Jacobian evaluations, iterations.
    """

    parameters: dict[str, float]
    names: tuple[str, ...]
    x: np.ndarray
    success: bool
    status: int
    message: str
    cost: float
    fun: np.ndarray
    jac: np.ndarray
    nfev: int
    njev: int
    iterations: int


def pairing_warnings(res) -> list[str]:
    """Warnings on a result's pairing: test modes whose pair's MAC is below ``min_mac`` (the
    shapes do not confirm the pairing, so the answer is doubtful).

    Parameters
    ----------
    res : UpdateResult
        A result (its ``pairing`` and ``pairs``).

    Returns
    -------
    list of str
        One line per such test mode (empty when every shaped pair correlates).
    """
    pg = getattr(res, "pairing", None) or {}
    macs = {k: (j, m) for k, j, m in res.pairs}
    out = []
    for k in pg.get("low_mac", []):
        j, m = macs[k]
        out.append(f"warning: test mode {k + 1} is paired by {pg.get('used', '?')} with model mode {j + 1} at MAC "
                   f"{m:.3f}, below the pairing threshold {pg.get('min_mac', 0.5):g}: the shapes do not confirm "
                   "this pair, so the updated values are doubtful")
    return out


@dataclass(frozen=True, eq=False)
class UpdateResult(RunResult, Serialisable):
    """Result of :func:`femupdate.update`, in the spirit of :class:`scipy.optimize.OptimizeResult`:
    the fields of :class:`RunResult`, and

    Attributes
    ----------
    parameters, names, x, success, status, message, cost, fun, jac, nfev, njev, iterations
        As :class:`RunResult`.
    history : list of dict
        Per iteration {``iteration``, ``cost``, ``parameters`` {name: value}}, the start first
        (``cost`` includes the regularisation rows).
    pairs : list of (int, int, float)
        ``(test mode, model mode, MAC)`` at the solution (0-based; MAC NaN without shape).
    test_frequencies_hz, model_frequencies_hz : numpy.ndarray, shape ``(T,)``
        Frequencies (Hz) of the test modes and of their paired model modes, in test-mode order.
    swaps : list of dict
        Mode swaps seen during the iteration (``evaluation``, ``test_mode``,
        ``from_model_mode``, ``to_model_mode``, ``rule``).
    diagnostics : Diagnostics or None
        Identifiability at the solution.
    regularization : dict
        {``rule``, ``alpha``} when Tikhonov regularisation was used, else empty.
    start : dict of str to float
        The starting values {name: value}.
    sensitivity : str
        The derivative route used at the solution (``"auto"`` resolved; ``"brandon"`` for FRFs).
    blocks : list of dict
        The data blocks of a problem with more than one kind of data (modes, FRFs, static
        cases): per block {``kind``, ``label``, ``n_residuals``, ``scale`` (the factor applied
        to its residuals), ``weighting`` (how that factor was chosen), ``cost`` (½‖r‖² of its
        residuals at the solution)}; empty for a single kind.
    notes : list of str
        What the run wants the user to know (lines skipped, weighting chosen, ...).
    pairing : dict
        How the modes were paired at the solution (empty without modes): ``policy`` (the rule
        asked for), ``used`` (the rule that made the pairs: ``"mac"``, ``"order"`` or
        ``"frequency"``), ``min_mac`` and ``low_mac`` (0-based test modes whose pair's MAC is
        below ``min_mac``: their pairing is not confirmed by the shapes).
    formulation : str
        The formulation of the modal residuals (``"shapes"``, ``"mac"`` or ``"dynamic"``;
        :class:`~femupdate.updating.Problem`); empty without modes.
    expanded_shapes : numpy.ndarray or None, shape ``(n_dofs, T)``
        With the dynamic formulation, each test mode's full shape at the solution (column k in
        the model's dof order): the measured entries the test shape scaled to unit length over
        them, the unmeasured ones those that minimise the mode's dynamic residual; else None.
    solver : str
        How the model's modes were computed at the solution (:attr:`femupdate.Modes.solver`:
        dense, or sparse with the factorisation used); empty without modes.
    damping : dict
        A damped model's update (:mod:`femupdate.updating.damped_run`): ``parameters`` (the
        damping parameters updated), ``values`` (every damping parameter's value), ``std``
        {name: standard deviation} of those updated, and with measured modes
        ``damping_ratios`` {``test``, ``model``} and ``mpc`` of the paired modes, and
        ``complexity`` {``test``, ``model``: {``mpc``, ``mpd_deg``}} of the paired shapes at the
        measured dofs; empty for an undamped model.
    context : RunContext, optional
        The model and data the result was computed from (:mod:`femupdate.serialise`): what
        :meth:`to_json` and :meth:`write_report` take from them.
    """

    kind: ClassVar[str] = "update"
    kinds: ClassVar[tuple[str, ...]] = ("update", "frf-update")

    history: list[dict]
    pairs: list[tuple[int, int, float]]
    test_frequencies_hz: np.ndarray
    model_frequencies_hz: np.ndarray
    swaps: list[dict]
    diagnostics: Diagnostics | None
    regularization: dict = field(default_factory=dict)
    start: dict[str, float] = field(default_factory=dict)
    sensitivity: str = ""  # the derivative route used at the solution (``"auto"`` resolved)
    blocks: list[dict] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    pairing: dict = field(default_factory=dict)
    formulation: str = ""
    expanded_shapes: np.ndarray | None = None
    solver: str = ""  # how the model's modes were computed at the solution (Modes.solver)
    damping: dict = field(default_factory=dict)
    context: RunContext | None = field(default=None, compare=False, repr=False)

    def payload(self) -> dict:
        from .record import frf_update_kind, update_kind

        ctx = self.run_context
        return frf_update_kind(self, ctx) if self.result_kind == "frf-update" else update_kind(self, ctx)

    @classmethod
    def from_payload(cls, obj):
        from .record import update_from

        return update_from(obj)

    def __repr__(self) -> str:
        values = ", ".join(f"{n}={v:.6g}" for n, v in zip(self.names, self.x))
        state = "converged" if self.success else "NOT converged"
        return (f"{type(self).__name__}({state}, cost {self.cost:.4g}, {self.iterations} iterations, "
                f"{len(self.pairs)} pairs: {values})")

    def summary(self) -> str:
        """A few lines for a terminal or a log: convergence, parameters with their change and
        standard deviation, the paired modes.

        Returns
        -------
        str
            Newline-separated lines: convergence, cost, a table of the parameters (start,
            updated, change in %, standard deviation — or the bound a parameter sits on), a
            table of the pairs (frequencies in Hz, error in %, MAC), the diagnostics, each poorly
            determined parameter with its reason, the notes and the number of mode swaps, if any.
        """
        d = self.diagnostics
        lines = [f"{'converged' if self.success else 'NOT converged'}: {self.message}"
                 + ("; MODEL ERROR: the fit does not reproduce the data within the noise"
                    if d is not None and d.model_error.get("verdict") == "model error" else ""),
                 f"cost {self.cost:.6g} after {self.iterations} iterations ({self.nfev} evaluations)"]
        lines.append(f"{'parameter':<16}{'start':>14}{'updated':>14}{'change':>10}{'std':>12}")
        for j, (n, v) in enumerate(zip(self.names, self.x)):
            s0 = self.start.get(n, math.nan)
            ch = (v / s0 - 1) * 100 if s0 else math.nan
            sd = d.std[j] if d is not None and j < d.std.size else math.nan
            shown = f"{d.at_bounds[n]} bound" if d is not None and n in d.at_bounds else f"{sd:.3g}"
            lines.append(f"{n:<16}{s0:>14.6g}{v:>14.6g}{ch:>9.2f}%{shown:>12}")
        lines.append(f"{'test':>5}{'model':>7}{'f test [Hz]':>14}{'f model [Hz]':>14}{'error':>9}{'MAC':>7}")
        for (k, j, m), ft, fa in zip(self.pairs, self.test_frequencies_hz, self.model_frequencies_hz):
            err = (fa - ft) / ft * 100 if ft else math.nan
            lines.append(f"{k + 1:>5}{j + 1:>7}{ft:>14.6g}{fa:>14.6g}{err:>8.3f}%{m:>7.3f}")
        if d is not None:
            lines.append(repr(d))
            lines.extend(f"poorly determined: {n}: {why}" for n, why in d.poorly_determined_reasons.items())
            lines.extend(d.basis_lines)
            lines.extend(f"note: {n}" for n in d.noise_notes)
            if d.model_error_line:
                lines.append(d.model_error_line)
        lines.extend(f"note: {note}" for note in self.notes)
        if self.swaps:
            lines.append(f"{len(self.swaps)} mode swap(s) during the iteration")
        lines += pairing_warnings(self)
        return "\n".join(lines)


@dataclass(frozen=True, eq=False)
class Solution:
    """One distinct solution of a multi-start study or global search: a cluster of converged runs
    (:func:`~femupdate.updating.converged_solutions`).

    Attributes
    ----------
    parameters : dict of str to float
        The updated parameters' values {name: value} (physical units) of the cluster's
        lowest-cost run.
    cost : float
        ½‖r‖² of that run.
    count : int
        The number of runs in the cluster.
    starts : list of int
        Their indices in the study's ``runs``, in increasing cost.
    fits : bool
        The solution fits the data as well as the best one: its cost exceeds the best by less
        than the statistical fluctuation of the fit allows (:func:`~femupdate.updating.clustering.fit_threshold`).
        Solutions that do not are local minima.
    separation : Separation or None
        Why it is distinct from the lowest-cost solution (:func:`femupdate.distinct.compare`:
        ``"statistic"``, ``"non-identifiable"`` or ``"tolerance"``); None for that one.
    basis : str
        How the runs were grouped: ``"statistic"`` (every run had a covariance), ``"tolerance"``
        (none had: the relative tolerance alone) or ``"mixed"``.
    """

    parameters: dict[str, float]
    cost: float
    count: int
    starts: list[int]
    fits: bool = field(default=False, kw_only=True)
    separation: object = field(default=None, kw_only=True)
    basis: str = field(default="tolerance", kw_only=True)


@dataclass(frozen=True, eq=False)
class MultiStartResult(Serialisable):
    """The result of a multi-start study (:func:`~femupdate.updating.multistart`).

    Attributes
    ----------
    best : UpdateResult or None
        The lowest-cost converged run (within ``cost_tol`` when given); None when none converged.
    solutions : list of Solution
        The converged runs clustered, most frequent first (ties: lowest cost first).
    runs : list
        Every start's result, in start order — an :class:`UpdateResult` (or a
        :class:`~femupdate.updating.batched.BatchRun` on the compiled route) — or, for a start
        that failed, the message ``"ErrorType: message"``.
    starts : numpy.ndarray, shape ``(n_starts, L)``
        The drawn starting values (physical units), in the order of ``names``.
    names : tuple of str
        The updated parameters.
    total : int
        The number of starts.
    converged : int
        The number of runs that converged (and fit within ``cost_tol``).
    seed : int or None
        The seed of the random starts.
    fit_cost : float
        The largest cost of a solution that fits the data as well as the best
        (:func:`~femupdate.updating.clustering.fit_threshold`); NaN when none converged.
    seconds : list of float or None
        Wall-clock seconds of each start on the per-start route (locally or on a Dask worker);
        None on the compiled route, where the starts advance together (``batch_seconds`` then).
    cpu_seconds : list of float or None
        CPU seconds of each start on the per-start route (of the process that ran it, BLAS
        threads included); None on the compiled route.
    batch_seconds : float or None
        The compiled route's wall-clock seconds for all the starts together (None per start).
    distinct : dict
        How the solutions were told apart and how well the best one is determined
        (:func:`~femupdate.updating.clustering.distinct_record`): ``alpha``, ``basis``,
        ``non_unique``, ``separations``, ``conditioning`` (ill-conditioning — "k2 known to ±x %",
        the condition number, the weakest direction — apart from non-uniqueness).

    The solutions are ordered: those that fit the data first (most frequent first), then the
    local minima (lowest cost first).
    """

    best: UpdateResult | None
    solutions: list[Solution]
    runs: list
    starts: np.ndarray
    names: tuple[str, ...]
    total: int
    converged: int
    seed: int | None
    fit_cost: float = field(default=math.nan, kw_only=True)
    seconds: list | None = field(default=None, kw_only=True)
    cpu_seconds: list | None = field(default=None, kw_only=True)
    batch_seconds: float | None = field(default=None, kw_only=True)
    distinct: dict = field(default_factory=dict, kw_only=True)
    context: RunContext | None = field(default=None, kw_only=True, compare=False, repr=False)

    kind: ClassVar[str] = "update"
    kinds: ClassVar[tuple[str, ...]] = ()  # read back as the best run's result (UpdateResult.from_json)

    def payload(self) -> dict:
        from .record import multistart_kind

        return multistart_kind(self, self.run_context)

    @classmethod
    def from_payload(cls, obj):
        """The best run's result (an :class:`UpdateResult`; the study's ``starts`` kept as read)."""
        return UpdateResult.from_payload(obj)

    def solution_records(self) -> list[dict]:
        """One record per distinct solution: its parameters, cost, the starts that reached it and
        whether it fits the data as well as the best (:meth:`to_frame`'s rows)."""
        return [{**s.parameters, "cost": s.cost, "count": s.count, "fits": s.fits} for s in self.solutions]

    def to_frame(self):
        """The distinct solutions as a :class:`pandas.DataFrame` (:meth:`solution_records`)."""
        import pandas as pd

        return pd.DataFrame.from_records(self.solution_records())

    @property
    def fitting(self) -> list[Solution]:
        """The distinct solutions that fit the data as well as the best one (more than one: the
        data do not determine the parameters uniquely)."""
        return [s for s in self.solutions if s.fits]

    @property
    def local_minima(self) -> list[Solution]:
        """The distinct solutions that converged without fitting the data."""
        return [s for s in self.solutions if not s.fits]

    @property
    def failures(self) -> dict[str, int]:
        """Starts that did not converge, counted by reason (numbers in the messages replaced by #)."""
        out: dict[str, int] = {}
        for run in self.runs:
            if isinstance(run, str):
                reason = failure_reason(run)
            elif not getattr(run, "success", True):
                reason = f"did not converge: {failure_reason(str(getattr(run, 'message', '')))}"
            else:
                continue
            out[reason] = out.get(reason, 0) + 1
        return dict(sorted(out.items(), key=lambda kv: -kv[1]))

    def records(self) -> list[dict]:
        """One record per start, in start order: ``start`` {name: value}, ``outcome``
        (``"fits"``, ``"local minimum"``, ``"not converged"``, ``"failed"``, or ``"rejected"``
        when above ``cost_tol``), ``cost``, ``iterations``, ``nfev``, ``solution`` (index into
        ``solutions``, or None), ``message``, ``seconds`` (wall-clock seconds of the start on the
        per-start route, None on the compiled route), ``cpu_seconds`` (its CPU seconds, likewise) and ``pairing`` (the rule that made the final pairs:
        ``"mac"``, ``"order"`` or ``"frequency"``; None for a failed start)."""
        where = {k: i for i, s in enumerate(self.solutions) for k in s.starts}
        out = []
        for k, run in enumerate(self.runs):
            rec: dict = {"start": dict(zip(self.names, map(float, self.starts[k]))), "solution": where.get(k),
                         "seconds": None if self.seconds is None else self.seconds[k],
                         "cpu_seconds": None if self.cpu_seconds is None else self.cpu_seconds[k]}
            if isinstance(run, str):
                rec.update(outcome="failed", cost=None, iterations=None, nfev=None, message=run, pairing=None)
            else:
                i = where.get(k)
                outcome = ("not converged" if not run.success else "rejected" if i is None
                           else "fits" if self.solutions[i].fits else "local minimum")
                rec.update(outcome=outcome, cost=float(run.cost), iterations=int(run.iterations), nfev=int(run.nfev),
                           message=str(run.message), pairing=(getattr(run, "pairing", None) or {}).get("used"))
            out.append(rec)
        return out


def attach(result, model, data, kind: str = "", **context):
    """``result`` with its :class:`~femupdate.serialise.RunContext`: the model, the test data
    (:class:`~femupdate.TestData` only) and the kind of result the verb makes; a multi-start
    result's best run gets the same context.

    Parameters
    ----------
    result : UpdateResult or MultiStartResult
    model : Model
    data : TestData or other data
    kind : str, optional
        ``"update"`` or ``"frf-update"`` (default: the class's).
    **context
        Further :class:`~femupdate.serialise.RunContext` fields (``damping=``, ``before=``).
    """
    import dataclasses

    from ..testdata import TestData

    ctx = RunContext(model=model, data=data if isinstance(data, TestData) else None, kind=kind, **context)
    if isinstance(result, MultiStartResult) and result.best is not None:
        result = dataclasses.replace(result, best=dataclasses.replace(result.best, context=ctx))
    return dataclasses.replace(result, context=ctx)


def failure_reason(message: str) -> str:
    """The head of a failure message with its numbers as ``#``, so that starts failing alike count
    together: ``"NumericalError: test mode(s) [3] pair with no model mode (MAC below 0.5 ...): check
    ..."`` → ``"test mode(s) [#] pair with no model mode (MAC below # ...)"``."""
    import re

    text = re.sub(r"^\w+Error: ", "", message.strip())
    parts = text.split(": ")
    head = parts[0]
    if len(parts) > 1 and len(head.split()) <= 3:  # a subject ("test mode 2") and what befell it
        head = f"{head}: {parts[1]}"
    return re.sub(r"[-+]?\d+(\.\d+)?([eE][-+]?\d+)?", "#", head)[:200]


__all__ = ["Diagnostics", "RunResult", "UpdateResult", "Solution", "MultiStartResult", "failure_reason", "pairing_warnings",
           "attach"]
