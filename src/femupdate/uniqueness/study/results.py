"""Results of a uniqueness study: the raw per-start results of the units clustered into distinct
solutions per case, with the counting criteria, the conditioning at the truth and the scatter
under noise."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from typing import ClassVar

import numpy as np

from ..._errors import InputError
from ...serialise import RunContext, Serialisable
from ...updating.batched import FAILED
from ...distinct import ALPHA, compare, conditioning as conditioning_record, significant
from ...updating.results import Solution as _MultiStartSolution
from ..criteria import counting_criteria
from .definition import Case, Study
from .units import row_data


@dataclass(frozen=True, eq=False)
class Solution(_MultiStartSolution):
    """A distinct solution of a case and its distance from the truth.

    Each parameter is stored as the attribute of the same name; the first four are those of
    :class:`femupdate.updating.Solution`.

    Parameters
    ----------
    parameters : dict of str to float
        The representative's (lowest-cost member's) values of the unknowns.
    cost : float
        Its cost ½‖r‖².
    count : int
        How many starts reached this solution.
    starts : list of int
        Which starts (0-based), ascending.
    max_rel_error : float, default NaN
        Largest ``|p / p_true - 1|`` over the unknowns (``|p - p_true|`` where ``p_true`` is 0).
    is_truth : bool, default False
        Not significantly different from the truth (:func:`femupdate.distinct.compare` against
        the case's covariance at α; within ``rel_tol`` where the case has none).
    """

    max_rel_error: float = math.nan  #: largest ``|p / p_true − 1|`` over the unknowns
    is_truth: bool = False


@dataclass(frozen=True, eq=False)
class NoiseResult:
    """One noise level of a case: scatter of the converged solutions around the truth.

    Built by :func:`summarise`; each parameter is stored as the attribute of the same name.

    Parameters
    ----------
    level : float
        Relative noise level σ.
    starts : int
        Starts with a result at this level.
    converged : int
        Starts with solver success and a cost within twice the noise floor ½ m σ² (m residuals),
        i.e. ``cost <= cost_tol + m σ²``.
    rms_rel_error : dict of str to float
        Per unknown, RMS of ``p / p_true - 1`` over the converged starts (NaN when none).
    median_max_rel_error : float
        Median over the converged starts of the largest relative error (NaN when none).
    predicted_std : dict of str to float
        σ √diag((SᵀS)⁻¹), the linearised scatter of ``p / p_true`` (inf if S is rank-deficient or has
        fewer residuals than unknowns).
    """

    level: float
    starts: int
    converged: int  #: solver success with a cost within twice the noise floor, ½ m σ² (m residuals)
    rms_rel_error: dict[str, float]  #: per unknown, RMS of p / p_true − 1 over the converged starts
    median_max_rel_error: float
    predicted_std: dict[str, float]  #: σ √diag((SᵀS)⁻¹), the linearised scatter (inf if S is singular)


@dataclass(frozen=True, eq=False)
class CaseResult:
    """Outcome of one case (see :mod:`femupdate.uniqueness.study` for the classification of starts).

    Built by :func:`summarise`; each parameter is stored as the attribute of the same name.  The
    counts refer to the noise-free data.

    Parameters
    ----------
    case : Case
        The measurement plan.
    criteria : dict of str to CriterionCount
        The counting criteria (:func:`~femupdate.uniqueness.counting_criteria`) for this plan.
    starts : int
        Starts with a result.
    converged : int
        Starts with solver success and cost <= ``cost_tol``.
    local_minima : int
        Starts with solver success and a larger cost.
    not_converged : int
        Starts stopped by the evaluation limit (status 0).
    failed : int
        Starts whose evaluation failed (status ``FAILED``).
    solutions : list of Solution
        The converged starts grouped (:func:`femupdate.distinct.significant` against the case's
        covariance, :func:`case_covariance`), most frequent first.
    condition_number : float
        Of the normalised sensitivity matrix at the truth (:func:`conditioning`).
    singular_values : ndarray, shape ``(min(m, L),)``
        Its singular values, descending.
    rank : int
        Its numerical rank.
    n_residuals : int
        Its number of rows m.
    noise : list of NoiseResult, default ``[]``
        One per noise level.
    failure_examples : list of str, default ``[]``
        Up to three distinct messages of failed starts.
    exact : dict, optional
        A single-sensor case's exact solution set from the frequencies
        (:meth:`StudyResult.with_exact`), as the JSON's ``exact`` holds it.
    distinct : dict, default ``{}``
        How the solutions were told apart and how well the truth is determined: ``alpha``,
        ``basis``, ``separations`` (per solution, from the lowest-cost one) and
        ``conditioning`` (:func:`femupdate.distinct.conditioning` at the truth: ill-conditioning —
        "k2 known to ±x %" at the study's first noise level, else per 1 % noise on the residuals —
        apart from non-uniqueness).
    """

    case: Case
    criteria: dict
    starts: int
    converged: int
    local_minima: int
    not_converged: int
    failed: int
    solutions: list[Solution]
    condition_number: float
    singular_values: np.ndarray
    rank: int
    n_residuals: int
    noise: list[NoiseResult] = field(default_factory=list)
    failure_examples: list[str] = field(default_factory=list)
    exact: dict | None = None
    distinct: dict = field(default_factory=dict)

    @property
    def truth_found(self) -> bool:
        return any(s.is_truth for s in self.solutions)

    @property
    def unique(self) -> bool | None:
        """True: every converged start reached the truth; False: another solution reproduces the
        data too; None: no start converged."""
        if not self.solutions:
            return None
        return len(self.solutions) == 1 and self.solutions[0].is_truth

    @property
    def verdict(self) -> str:
        return {True: "unique", False: "non-unique", None: "not converging"}[self.unique]

    def to_dict(self, names) -> dict:
        """This case's entry of the JSON result (``cases`` of :meth:`StudyResult.to_dict`).

        Parameters
        ----------
        names : sequence of str
            The study's parameter names (only their number is used, for ``n_parameters``).

        Returns
        -------
        dict
            May hold NumPy arrays and scalars (convert with :func:`~femupdate.io.results.to_jsonable`
            before writing JSON).
        """
        out = {
            "measured_dofs": list(self.case.measured_dofs), "n_measured": self.case.n_measured,
            "n_modes": self.case.n_modes,
            "criteria": {k: c.satisfied for k, c in self.criteria.items()},
            "criteria_counts": {k: {"count": c.count, "threshold": c.threshold, "formula": c.formula,
                                    "equation": c.equation} for k, c in self.criteria.items()},
            "starts": self.starts, "converged": self.converged, "local_minima": self.local_minima,
            "not_converged": self.not_converged, "failed": self.failed,
            "solutions": [{"parameters": s.parameters, "count": s.count, "cost": s.cost,
                           "max_rel_error": s.max_rel_error, "is_truth": s.is_truth} for s in self.solutions],
            "unique": self.unique, "verdict": self.verdict, "truth_found": self.truth_found,
            "condition_number": self.condition_number, "singular_values": self.singular_values,
            "rank": self.rank, "n_parameters": len(names), "n_residuals": self.n_residuals,
            "underdetermined": not self.criteria["data_count"].satisfied,
            "noise": [{"level": z.level, "starts": z.starts, "converged": z.converged,
                       "rms_rel_error": z.rms_rel_error, "median_max_rel_error": z.median_max_rel_error,
                       "predicted_std": z.predicted_std} for z in self.noise],
            "failure_examples": self.failure_examples,
            "distinct": self.distinct,
        }
        if self.exact is not None:
            out["exact"] = self.exact
        return out


@dataclass(frozen=True, eq=False)
class StudyResult(Serialisable):
    """Result of :func:`run_study`: one :class:`CaseResult` per case, in the study's order; a
    result of kind ``uniqueness`` (``femupdate uniqueness``): :meth:`~femupdate.serialise.Serialisable.to_json`
    gives the command's JSON and :meth:`~femupdate.serialise.Serialisable.write_report` its report.

    Each parameter is stored as the attribute of the same name.

    Parameters
    ----------
    study : Study or None
        The study (None for a result read back from JSON, which keeps the study's keys as read).
    cases : list of CaseResult
        One per case.
    seconds : float
        Wall-clock time of the run (s).
    units_computed : int
        Work units computed by this run.
    units_resumed : int
        Work units taken from the checkpoint.
    route : str
        ``"local"``, or ``"dask:<scheduler>"`` / ``"dask:local cluster of <n> workers"``.
    rel_tol : float
        Relative round-off floor of two starts reaching the same solution (the rule where a case
        has no covariance).
    cost_tol : float
        Largest cost of a converged start.
    raw : list of dict, default ``[]``
        Per-start results of every piece (see :func:`~femupdate.uniqueness.study.units.solve_unit`).
    figure : str, optional
        The path of the study's heat map, when one was drawn (:meth:`with_figure`).
    alpha : float, default 0.01
        The significance level at which solutions were told apart.
    context : RunContext, optional
        What a result read back from JSON keeps of the study (:mod:`femupdate.serialise`).
    """

    study: Study | None
    cases: list[CaseResult]
    seconds: float
    units_computed: int
    units_resumed: int
    route: str
    rel_tol: float
    cost_tol: float
    raw: list = field(default_factory=list)  #: per-start results of every piece (see :func:`solve_unit`)
    figure: str | None = None
    alpha: float = ALPHA
    context: RunContext | None = field(default=None, compare=False, repr=False)

    kind: ClassVar[str] = "uniqueness"

    @property
    def run_context(self) -> RunContext:
        """The model of the study (for the report), or the study's keys as read back."""
        if self.context is not None:
            return self.context
        return RunContext(model=None if self.study is None else self.study.model, kind=self.kind)

    def payload(self) -> dict:
        from .record import study_fields

        return study_fields(self, self.run_context)

    @classmethod
    def from_payload(cls, obj):
        from .record import study_from

        return study_from(obj)

    def criteria_agreement(self) -> dict:
        """Per counting criterion, on how many cases with a verdict its prediction matches the
        study's: ``{name: {"agrees", "of", "wrong_cases"}}`` (cases named ``NxM``: measured dofs x
        modes)."""
        out = {}
        judged = [c for c in self.cases if c.unique is not None]
        for name in (judged[0].criteria if judged else {}):
            hits = sum(c.criteria[name].satisfied == c.unique for c in judged)
            wrong = [f"{c.case.n_measured}x{c.case.n_modes}" for c in judged if c.criteria[name].satisfied != c.unique]
            out[name] = {"agrees": hits, "of": len(judged), "wrong_cases": wrong}
        return out

    def with_exact(self) -> StudyResult:
        """A copy whose single-sensor cases carry their exact solution sets from the frequencies
        (:func:`~femupdate.uniqueness.exact.exact_solutions`, SymPy: small models;
        ``femupdate uniqueness --exact``)."""
        from .record import exact_entries

        cases = [c if e is None else replace(c, exact=e) for c, e in zip(self.cases, exact_entries(self))]
        return replace(self, cases=cases)

    def with_figure(self, path) -> StudyResult:
        """A copy that names its heat map (``figure`` in the JSON; ``--plot``)."""
        return replace(self, figure=str(path))

    def records(self) -> list[dict]:
        """One record per case: measured dofs, modes, verdict, distinct solutions, the counts of
        starts and the condition number at the truth."""
        return [{"measured_dofs": ",".join(c.case.measured_dofs), "n_modes": c.case.n_modes, "verdict": c.verdict,
                 "solutions": len(c.solutions), "converged": c.converged, "local_minima": c.local_minima,
                 "not_converged": c.not_converged, "failed": c.failed, "condition_number": c.condition_number}
                for c in self.cases]

    def to_dict(self) -> dict:
        """The study's part of the JSON result of ``femupdate uniqueness`` (:meth:`to_json` adds
        the criteria's agreement, the unknowns' units and bounds and the figure)."""
        st = self.study
        if st is None:
            raise InputError("a study result read back from JSON has no study: use to_json()")
        return {
            "model": st.model.name, "parameters": list(st.names),
            "truth": dict(zip(st.names, st.truth[[st.model.parameter_index(n) for n in st.names]])),
            "n_dofs": st.model.n_dofs, "starts": st.n_starts, "seed": st.seed, "noise_levels": list(st.noise),
            "rel_tol": self.rel_tol, "alpha": self.alpha, "cost_tol": self.cost_tol, "max_nfev": st.max_nfev, "min_mac": st.min_mac,
            "route": self.route, "units": {"total": len(st.units()), "computed": self.units_computed,
                                           "resumed": self.units_resumed},
            "seconds": self.seconds, "study_key": st.key(),
            "cases": [c.to_dict(st.names) for c in self.cases],
        }


def truth_sensitivities(study: Study) -> list[tuple[np.ndarray, int]]:
    """Per case the normalised sensitivity matrix at the truth, noise-free, and its number of residuals.

    Parameters
    ----------
    study : Study
        The study.

    Returns
    -------
    list of (ndarray, int)
        Per case ``S = ∂r/∂(p/p_true)`` of shape ``(m, L)`` (the case's own residual rows only) and m.

    Raises
    ------
    InputError
        A case whose model cannot be differentiated at the truth.
    """
    from ..problem import study_problem

    C = len(study.cases)
    pieces = [(c, 0, 0, 1) for c in range(C)]
    rows, _ = row_data(study, pieces)
    idx = [study.model.parameter_index(n) for n in study.names]
    X0 = np.tile(study.truth[idx], (C, 1))
    prob = study_problem(study.model, study.names, rows, X0, values=study.truth, min_mac=study.min_mac)
    ev = prob.evaluate(prob.x_start)
    m = prob.n_residuals
    out = []
    for c in range(C):
        if ev.messages[c] is not None:
            raise InputError(f"case {c + 1}: the model cannot be differentiated at the truth: {ev.messages[c]}")
        out.append((ev.jac[c, :m[c]], int(m[c])))
    return out


def conditioning(S: np.ndarray, m: int):
    """Condition number, singular values and numerical rank of a sensitivity matrix.

    Parameters
    ----------
    S : ndarray, shape ``(m_rows, L)``
        Sensitivity matrix.
    m : int
        Its number of residuals.

    Returns
    -------
    cond : float
        ``s_max / s_min``; inf when S is numerically rank-deficient, has fewer singular values than
        columns, or ``m < L``.
    singular_values : ndarray, shape ``(min(m_rows, L),)``
        Descending.
    rank : int
        Singular values above ``max(S.shape) * eps * s_max``.
    """
    s = np.linalg.svd(S, compute_uv=False) if S.size else np.zeros(0)
    L = S.shape[1]
    rank = int(np.sum(s > max(S.shape) * np.finfo(float).eps * s[0])) if s.size else 0
    # a numerically rank-deficient matrix has no finite condition number: its smallest singular
    # value is round-off, and so would be any figure computed from it
    cond = float(s[0] / s[-1]) if s.size == L and rank == L and m >= L else math.inf
    return cond, s, rank


def case_covariance(S: np.ndarray, rank: int, scale: np.ndarray, variance: float) -> np.ndarray:
    """``variance`` · D (SᵀS)⁺ D over S's first ``rank`` singular directions (D = diag ``scale``):
    the covariance (physical units) of a solution whose residuals scatter with that variance; the
    directions beyond the rank have none (zero here: :func:`femupdate.distinct.compare` compares
    along them by the tolerance — non-identifiable)."""
    L = S.shape[1]
    if rank == 0 or not S.size:
        return np.full((L, L), np.nan)
    _, sv, Vt = np.linalg.svd(S, full_matrices=False)
    V = Vt[:rank].T * scale[:, None]
    return variance * (V / sv[:rank] ** 2) @ V.T


def _solutions(study, pts, costs, who, p_true, scale, cov, alpha, rel_tol):
    """The converged starts of a case grouped (:func:`~femupdate.distinct.significant`), and the
    record of how (``distinct`` of :class:`CaseResult`, without ``conditioning``)."""
    covs = None if cov is None else [cov] * len(pts)
    grouping = significant(pts, costs, covs, alpha, rel_tol, scale)
    sols = []
    for g, sep in zip(grouping.groups, grouping.separations):
        rep = pts[g[0]]
        err = float(np.max(np.abs(rep - p_true) / scale))
        truth = (compare(p_true, rep, np.zeros_like(cov), cov, alpha, rel_tol, scale) is None if cov is not None
                 else err <= rel_tol)
        sols.append(Solution(dict(zip(study.names, map(float, rep))), float(costs[g[0]]), len(g),
                             sorted(int(who[i]) for i in g), err, truth, separation=sep, basis=grouping.basis))
    sols.sort(key=lambda s: (-s.count, s.cost))
    return sols, {"alpha": alpha, "basis": grouping.basis,
                  "separations": [None if s.separation is None else s.separation.to_dict() for s in sols]}


def summarise(study: Study, raw: Sequence[dict], *, rel_tol: float = 1e-4, cost_tol: float = 1e-12,
              sensitivities=None, alpha: float = ALPHA) -> list[CaseResult]:
    """Case results from raw unit results (any split, any order).

    Parameters
    ----------
    study : Study
        The study.
    raw : sequence of dict
        Raw piece results (:func:`~femupdate.uniqueness.study.units.solve_unit`,
        :func:`~femupdate.uniqueness.study.units.reference_unit`); starts missing from them count as
        absent.
    rel_tol : float, default 1e-4
        Two converged starts within this of each other (relative) are always the same solution.
    cost_tol : float, default 1e-12
        A start with solver success converges when its cost ½‖r‖² is at most this.
    sensitivities : list of (ndarray, int), optional
        :func:`truth_sensitivities` of the study, if at hand.
    alpha : float, default 0.01
        The significance level at which two converged starts are distinct solutions.

    Notes
    -----
    The data are noise-free: what scatters the converged starts of one solution is the fit
    tolerance, ``cost_tol``.  Each start is given the covariance of a fit whose residual vector
    has the largest length a converged start may have, ‖r‖² = 2 ``cost_tol``
    (:func:`case_covariance` with the sensitivity at the truth), so that two starts of one minimum
    — whose residual vectors differ by at most twice that length — are never told apart, while
    separated exact solutions are; directions the data do not determine (beyond the rank at the
    truth) are compared by ``rel_tol`` and a difference along them is non-uniqueness.  A
    solution is the truth when it does not differ significantly from it.

    Returns
    -------
    list of CaseResult
        One per case, in the study's order.

    Raises
    ------
    InputError
        As :func:`truth_sensitivities`.
    """
    C, R, L = len(study.cases), study.n_starts, len(study.names)
    x = np.full((C, len(study.levels), R, L), np.nan)
    cost = np.full((C, len(study.levels), R), np.nan)
    status = np.full((C, len(study.levels), R), FAILED)
    have = np.zeros((C, len(study.levels), R), bool)
    messages: dict = {}
    for piece in raw:
        c, lv = piece["case"], piece["level"]
        ks = piece.get("starts") or list(range(piece["start"], piece["start"] + len(piece["status"])))
        x[c, lv, ks] = np.array(piece["x"], dtype=float).reshape(len(ks), L)
        cost[c, lv, ks] = np.array(piece["cost"], dtype=float)
        status[c, lv, ks] = np.array(piece["status"], dtype=int)
        have[c, lv, ks] = True
        for k, msg in piece.get("messages", {}).items():
            messages.setdefault((c, lv), []).append(msg)
    idx = [study.model.parameter_index(n) for n in study.names]
    p_true = study.truth[idx]
    scale = np.where(p_true != 0, np.abs(p_true), 1.0)
    sens = sensitivities if sensitivities is not None else truth_sensitivities(study)
    out = []
    for c, case in enumerate(study.cases):
        h = have[c, 0]
        st, cs, xs = status[c, 0][h], cost[c, 0][h], x[c, 0][h]
        ks = np.flatnonzero(h)
        conv = (st > 0) & (cs <= cost_tol)
        S, m_own = sens[c]
        cond, sv, rank = conditioning(S, m_own)
        cov = case_covariance(S, rank, scale, 2.0 * cost_tol) if rank else None
        sols: list = []
        distinct: dict = {"alpha": alpha, "basis": "statistic" if rank else "tolerance", "separations": []}
        if conv.any():
            sols, distinct = _solutions(study, xs[conv], cs[conv], ks[conv], p_true, scale, cov, alpha, rel_tol)
        level = study.levels[1] if len(study.levels) > 1 else 0.01
        said = (f"at noise {level:g} on the residuals (the study's first noise level)" if len(study.levels) > 1
                else "per 0.01 noise on the residuals (no noise level given)")
        distinct["conditioning"] = conditioning_record(study.names, p_true, case_covariance(S, rank, scale, level ** 2)
                                                       if rank == L else np.full((L, L), np.nan), cond, said)
        noise = []
        for lv in range(1, len(study.levels)):
            hz = have[c, lv]
            sigma = study.levels[lv]
            # fits the noisy data: success with a cost within twice the expected noise floor ½ m σ²
            ok = hz & (status[c, lv] > 0) & (cost[c, lv] <= cost_tol + m_own * sigma**2)
            rel = (x[c, lv][ok] - p_true) / scale
            if rank == L and m_own >= L:
                pred = sigma * np.sqrt(np.diag(np.linalg.pinv(S.T @ S)))
            else:
                pred = np.full(L, math.inf)
            noise.append(NoiseResult(
                sigma, int(hz.sum()), int(ok.sum()),
                dict(zip(study.names, map(float, np.sqrt(np.mean(rel**2, axis=0)) if ok.any() else [math.nan] * L))),
                float(np.median(np.max(np.abs(rel), axis=1))) if ok.any() else math.nan,
                dict(zip(study.names, map(float, pred)))))
        crit = counting_criteria(case.n_measured, case.n_modes, L, study.model.n_dofs)
        out.append(CaseResult(
            case=case, criteria=crit, starts=int(h.sum()), converged=int(conv.sum()),
            local_minima=int(np.sum((st > 0) & ~(cs <= cost_tol))), not_converged=int(np.sum(st == 0)),
            failed=int(np.sum(st == FAILED)), solutions=sols, condition_number=cond, singular_values=sv, rank=rank,
            n_residuals=m_own, noise=noise, failure_examples=sorted(set(messages.get((c, 0), [])))[:3],
            distinct=distinct))
    return out


__all__ = ["Solution", "NoiseResult", "CaseResult", "StudyResult", "truth_sensitivities", "conditioning", "summarise",
           "case_covariance"]
