"""The JSON of kinds ``update-multi`` (:func:`~femupdate.updating.multiconfig.solve_configurations`,
``femupdate update-multi``) and ``rank-modifications``
(:func:`~femupdate.updating.multiconfig.rank_modifications`, ``femupdate rank-modifications``),
written by the results' ``to_json`` and read back by ``from_json`` (:mod:`femupdate.serialise`;
docs/file-formats.md).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from ...recording import diagnostics_extra, flags, parameter_fields
from ...serialise import RunContext


def attach(result, model, kind: str):
    """``result`` with the :class:`~femupdate.serialise.RunContext` of its model (not serialised:
    the JSON takes its name, parameter units, bounds and flags from it)."""
    return dataclasses.replace(result, context=RunContext(model=model, kind=kind))


def _direct_fields(d) -> dict:
    return {"condition_number": d.condition_number, "condition_number_scaled": d.condition_number_scaled,
            "residual_norm": d.residual_norm, "relative_residual": d.relative_residual, "rank": d.rank,
            "unique": d.unique, "n_equations": d.system.n_equations}


def multi_kind(res, ctx: RunContext) -> dict:
    """The JSON of kind ``update-multi``."""
    d = res.diagnostics
    model = ctx.model
    if model is not None:
        described = {"flags": flags(model, res.parameters, res.names), **parameter_fields(model)}
    else:
        described = {k: ctx.get(k) for k in ("flags", "parameter_units", "bounds") if k in ctx.stored}
    return {
        "model": ctx.model_name, "method": res.method, "parameters": res.parameters, "updated": list(res.names),
        "success": res.success, "message": res.message, "cost": res.cost, "iterations": res.iterations,
        "nfev": res.nfev, "standard_error": dict(zip(res.names, res.standard_error)),
        "configurations": res.configurations, "conditioning": res.conditioning, "history": res.history,
        "regularization": res.regularization, "notes": res.notes, **described,
        "direct": ctx.get("direct") if res.direct is None else _direct_fields(res.direct),
        "diagnostics": None if d is None else {
            "singular_values": d.singular_values, "condition_number": d.condition_number, "rank": d.rank,
            "poorly_determined": d.poorly_determined, "std": dict(zip(res.names, d.std)),
            **diagnostics_extra(res.names, d)},
    }


def _floats(values) -> np.ndarray:
    return np.array([math.nan if v is None else float(v) for v in values], dtype=float)


def multi_from(obj: Mapping) -> Any:
    """The :class:`~femupdate.updating.multiconfig.MultiConfigResult` of an ``update-multi`` JSON
    (its direct solution as the JSON's summary, kept as read)."""
    from ..record import diagnostics_from
    from .results import MultiConfigResult

    names = tuple(obj.get("updated") or ())
    params = {k: float(v) for k, v in (obj.get("parameters") or {}).items()}
    se = obj.get("standard_error") or {}
    stored = {k: obj[k] for k in ("model", "flags", "parameter_units", "bounds", "direct") if k in obj}
    return MultiConfigResult(
        method=str(obj.get("method") or ""), parameters=params, names=names,
        x=_floats([params.get(n) for n in names]), success=bool(obj.get("success", False)),
        message=str(obj.get("message") or ""), configurations=list(obj.get("configurations") or []),
        conditioning=dict(obj.get("conditioning") or {}), standard_error=_floats([se.get(n) for n in names]),
        diagnostics=diagnostics_from(obj.get("diagnostics"), names),
        cost=math.nan if obj.get("cost") is None else float(obj["cost"]), nfev=int(obj.get("nfev") or 0),
        iterations=int(obj.get("iterations") or 0), history=list(obj.get("history") or []),
        notes=list(obj.get("notes") or []), regularization=dict(obj.get("regularization") or {}),
        context=RunContext(kind="update-multi", stored=stored))


def ranking_kind(res, ctx: RunContext) -> dict:
    """The JSON of kind ``rank-modifications``."""
    return {"model": ctx.model_name, "criterion": res.criterion, "unknowns": list(res.unknowns),
            "baseline": res.baseline, "candidates": res.candidates, "selected": res.selected}


def ranking_from(obj: Mapping) -> Any:
    """The :class:`~femupdate.updating.multiconfig.Ranking` of a ``rank-modifications`` JSON."""
    from .ranking import Ranking

    return Ranking(criterion=str(obj.get("criterion") or ""), baseline=dict(obj.get("baseline") or {}),
                   candidates=list(obj.get("candidates") or []), selected=list(obj.get("selected") or []),
                   unknowns=tuple(obj.get("unknowns") or ()),
                   context=RunContext(kind="rank-modifications", stored={k: obj[k] for k in ("model",) if k in obj}))


__all__ = ["attach", "multi_kind", "multi_from", "ranking_kind", "ranking_from"]
