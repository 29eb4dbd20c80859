"""The JSON of kind ``posterior`` (:func:`femupdate.posterior`, ``femupdate posterior``), written
by :meth:`PosteriorResult.to_json <femupdate.serialise.Serialisable.to_json>` and read back by
``from_json`` (docs/file-formats.md).  The samples, log likelihoods and chains are not in the
JSON: a result read back has none (``n_samples`` says how many there were).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from ..recording import data_fields
from ..serialise import RunContext


def attach(result, model, data):
    """``result`` with its :class:`~femupdate.serialise.RunContext`: the model and the first test
    data set (their notes and units in the JSON; for the report its measured frequencies)."""
    from ..testdata import TestData

    first = data[0] if isinstance(data, (list, tuple)) and data else data
    return dataclasses.replace(result, context=RunContext(model=model, data=first if isinstance(first, TestData) else None,
                                                          kind="posterior"))


def solution_fields(m, share: float) -> dict:
    """One entry of ``solutions``: a :class:`~femupdate.bayes.Mode` and its share of the samples."""
    return {"parameters": m.parameters, "probability": m.probability, "sample_share": share, "std": m.std,
            "covariance": m.covariance, "log_weight": m.log_weight, "cost": m.cost, "count": m.count,
            "inside_bounds": m.inside, "at_bounds": list(m.at_bounds), "note": m.note or None}


def posterior_kind(res, ctx: RunContext) -> dict:
    """The JSON of kind ``posterior``."""
    data = ctx.data
    out = {
        "model": ctx.model_name,
        "method": res.method,
        "success": res.success,
        "updated": list(res.names),
        "parameters": res.median,
        "mean": res.mean, "median": res.median, "std": res.std, "interval": res.interval, "level": res.level,
        "covariance": res.covariance, "correlation": res.correlation,
        "solutions": [solution_fields(m, f) for m, f in zip(res.modes, res.mode_fractions)],
        "log_evidence": res.log_evidence, "log_evidence_error": res.log_evidence_error,
        "noise": res.noise,
        "model_error": (res.noise or {}).get("model_error"),
        "prior": res.prior,
        "damping": res.damping,
        "predictive": res.predictive,
        "diagnostics": res.diagnostics,
        "n_samples": int(res.samples.shape[0]) if res.samples.size or "n_samples" not in ctx.stored
        else ctx.get("n_samples"),
        "data_sets": res.data_sets,
        "route": res.route, "seed": res.seed, "seconds": res.seconds,
        "warnings": res.warnings, "notes": [*(data.notes if data is not None else ()), *res.notes],
    }
    out.update(data_fields(data) if data is not None else {k: ctx.get(k) for k in ("units",) if k in ctx.stored})
    return out


def _float(v, missing: float = math.nan) -> float:
    return missing if v is None else float(v)


def _matrix(rows, n: int) -> np.ndarray:
    if not rows:
        return np.full((n, n), math.nan)
    return np.array([[math.nan if v is None else float(v) for v in row] for row in rows], dtype=float)


def _mode(s: Mapping, names) -> Any:
    from .laplace import Mode

    return Mode(parameters={k: float(v) for k, v in (s.get("parameters") or {}).items()}, x=np.zeros(0),
                covariance=_matrix(s.get("covariance"), len(names)),
                std={k: _float(v) for k, v in (s.get("std") or {}).items()},
                log_weight=_float(s.get("log_weight"), -math.inf), probability=_float(s.get("probability")),
                cost=_float(s.get("cost")), log_posterior=math.nan, count=int(s.get("count") or 0),
                inside=_float(s.get("inside_bounds"), 1.0), at_bounds=tuple(s.get("at_bounds") or ()),
                note=str(s.get("note") or ""))


#: keys of a posterior JSON kept as read, for writing it again
STORED = ("model", "units", "n_samples")


def posterior_from(obj: Mapping) -> Any:
    """The :class:`~femupdate.bayes.PosteriorResult` of a ``posterior`` JSON, without samples (its
    notes all the result's own)."""
    from .results import PosteriorResult

    names = tuple(obj.get("updated") or ())
    sols = list(obj.get("solutions") or [])

    def per(key):
        return {k: _float(v) for k, v in (obj.get(key) or {}).items()}

    return PosteriorResult(
        method=str(obj.get("method") or ""), names=names, samples=np.zeros((0, len(names))), log_likelihood=np.zeros(0),
        mean=per("mean"), median=per("median"), std=per("std"),
        interval={k: [_float(a), _float(b)] for k, (a, b) in (obj.get("interval") or {}).items()},
        level=_float(obj.get("level")), covariance=_matrix(obj.get("covariance"), len(names)),
        correlation=_matrix(obj.get("correlation"), len(names)), modes=[_mode(s, names) for s in sols],
        mode_fractions=[_float(s.get("sample_share")) for s in sols], log_evidence=_float(obj.get("log_evidence")),
        log_evidence_error=_float(obj.get("log_evidence_error")), noise=dict(obj.get("noise") or {}),
        predictive=obj.get("predictive"), diagnostics=dict(obj.get("diagnostics") or {}),
        success=bool(obj.get("success", False)), warnings=list(obj.get("warnings") or []),
        notes=list(obj.get("notes") or []), route=str(obj.get("route") or ""), seed=obj.get("seed"),
        seconds=_float(obj.get("seconds")), prior=dict(obj.get("prior") or {}), data_sets=int(obj.get("data_sets") or 1),
        damping=obj.get("damping"),
        context=RunContext(kind="posterior", stored={k: obj[k] for k in STORED if k in obj}))


__all__ = ["attach", "posterior_kind", "posterior_from", "solution_fields"]
