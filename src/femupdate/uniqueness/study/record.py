"""The JSON of a uniqueness study — kind ``uniqueness`` (:func:`~femupdate.uniqueness.run_study`,
``femupdate uniqueness``) — written by :meth:`StudyResult.to_json
<femupdate.serialise.Serialisable.to_json>` and read back by ``from_json``
(docs/file-formats.md); and the exact solution sets of its single-sensor cases
(:func:`exact_entries`, ``--exact``).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from ..._errors import InputError

#: the study's own keys, kept as read when a result is read back (the study, which the JSON does
#: not hold, made them)
STORED = ("model", "parameters", "truth", "n_dofs", "starts", "seed", "noise_levels", "max_nfev", "min_mac",
          "units", "study_key", "parameter_units", "bounds")


# ---------------------------------------------------------------------------------- writing
def study_fields(res, ctx) -> dict:
    """The JSON of kind ``uniqueness``: the study (:meth:`StudyResult.to_dict
    <femupdate.uniqueness.study.StudyResult.to_dict>`, or its keys as read back), each counting
    criterion against the verdicts, the unknowns' units and bounds, and the figure with one."""
    from ...recording import parameter_fields

    if res.study is not None:
        out = res.to_dict()
        out["criteria_agreement"] = res.criteria_agreement()
        out.update(parameter_fields(res.study.model, list(res.study.names)))
    else:
        s = ctx.stored
        names = list(s.get("parameters") or [])
        units = dict(s.get("units") or {})
        out = {"model": s.get("model", ""), "parameters": names, "truth": s.get("truth"), "n_dofs": s.get("n_dofs"),
               "starts": s.get("starts"), "seed": s.get("seed"), "noise_levels": s.get("noise_levels"),
               "rel_tol": res.rel_tol, "alpha": res.alpha, "cost_tol": res.cost_tol, "max_nfev": s.get("max_nfev"),
               "min_mac": s.get("min_mac"), "route": res.route,
               "units": {"total": units.get("total"), "computed": res.units_computed, "resumed": res.units_resumed},
               "seconds": res.seconds, "study_key": s.get("study_key"),
               "cases": [c.to_dict(names) for c in res.cases], "criteria_agreement": res.criteria_agreement()}
        out.update({k: s[k] for k in ("parameter_units", "bounds") if k in s})
    if res.figure is not None:
        out["figure"] = res.figure
    return out


def exact_entry(model, names, n_modes: int, truth) -> dict:
    """The ``exact`` object of a single-sensor case: every real parameter set that reproduces the
    truth's lowest ``n_modes`` frequencies (:func:`~femupdate.uniqueness.exact.exact_solutions`),
    or ``{"skipped": why}`` where they cannot be solved exactly."""
    from ..exact import exact_solutions

    try:
        ex = exact_solutions(model, values=truth, n_modes=n_modes, params=list(names))
    except InputError as exc:
        return {"skipped": str(exc)}
    return {"n_solutions": None if not ex.zero_dimensional else len(ex.solutions), "zero_dimensional": ex.zero_dimensional,
            "n_complex": ex.n_complex, "solutions": [{"parameters": s.parameters, "exact": s.exact} for s in ex.solutions],
            "exact_data": ex.exact_data, "notes": ex.notes}


def exact_entries(res) -> list[dict | None]:
    """Per case of a study result, the ``exact`` object of a single-sensor case (frequencies
    only: solved once per number of modes) and None for the others."""
    st = res.study
    if st is None:
        raise InputError("the exact solution sets need the study (its model): a result read back from JSON has none")
    truth = dict(zip(st.model.parameter_names, st.truth))
    solved: dict[int, dict] = {}
    out: list[dict | None] = []
    for case in res.cases:
        if case.case.n_measured != 1:
            out.append(None)
            continue
        m = case.case.n_modes
        if m not in solved:
            solved[m] = exact_entry(st.model, st.names, m, truth)
        out.append(solved[m])
    return out


# ---------------------------------------------------------------------------------- reading
def _float(v, missing: float = math.nan) -> float:
    return missing if v is None else float(v)


def case_from(obj: Mapping) -> Any:
    """The :class:`~femupdate.uniqueness.study.CaseResult` of one entry of ``cases``."""
    from ..criteria import CriterionCount
    from .definition import Case
    from .results import CaseResult, NoiseResult, Solution

    counts = obj.get("criteria_counts") or {}
    satisfied = obj.get("criteria") or {}
    criteria = {k: CriterionCount(k, str(c.get("equation", "")), str(c.get("formula", "")), c.get("count"),
                                  c.get("threshold"), bool(satisfied.get(k)))
                for k, c in counts.items()}
    sols = [Solution(dict(s.get("parameters") or {}), _float(s.get("cost")), int(s.get("count") or 0), [],
                     _float(s.get("max_rel_error")), bool(s.get("is_truth"))) for s in obj.get("solutions") or []]
    noise = [NoiseResult(float(z["level"]), int(z["starts"]), int(z["converged"]),
                         {k: _float(v) for k, v in (z.get("rms_rel_error") or {}).items()},
                         _float(z.get("median_max_rel_error")),
                         {k: _float(v, math.inf) for k, v in (z.get("predicted_std") or {}).items()})
             for z in obj.get("noise") or []]
    return CaseResult(
        case=Case(tuple(obj.get("measured_dofs") or ()), int(obj.get("n_modes") or 0)), criteria=criteria,
        starts=int(obj.get("starts") or 0), converged=int(obj.get("converged") or 0),
        local_minima=int(obj.get("local_minima") or 0), not_converged=int(obj.get("not_converged") or 0),
        failed=int(obj.get("failed") or 0), solutions=sols, condition_number=_float(obj.get("condition_number"), math.inf),
        singular_values=np.array([_float(v) for v in obj.get("singular_values") or []], dtype=float),
        rank=int(obj.get("rank") or 0), n_residuals=int(obj.get("n_residuals") or 0), noise=noise,
        failure_examples=list(obj.get("failure_examples") or []), exact=obj.get("exact"),
        distinct=dict(obj.get("distinct") or {}))


def study_from(obj: Mapping) -> Any:
    """The :class:`~femupdate.uniqueness.study.StudyResult` of a ``uniqueness`` JSON: its cases
    typed, the study's own keys kept as read (``study`` is None: the JSON does not hold the
    model; the raw per-start results are empty)."""
    from ...serialise import RunContext
    from .results import StudyResult

    units = obj.get("units") or {}
    return StudyResult(None, [case_from(c) for c in obj.get("cases") or []], _float(obj.get("seconds")),
                       int(units.get("computed") or 0), int(units.get("resumed") or 0), str(obj.get("route") or ""),
                       _float(obj.get("rel_tol")), _float(obj.get("cost_tol")), figure=obj.get("figure"),
                       alpha=_float(obj.get("alpha"), 0.01),
                       context=RunContext(kind="uniqueness", stored={k: obj[k] for k in STORED if k in obj}))


__all__ = ["STORED", "study_fields", "exact_entry", "exact_entries", "case_from", "study_from"]
