"""The JSON of the updating results — kinds ``update`` (:func:`femupdate.update`, ``femupdate
update``) and ``frf-update`` (:func:`~femupdate.updating.frf_update`, ``femupdate frf-update``) —
written by :meth:`UpdateResult.to_json <femupdate.serialise.Serialisable.to_json>` and
:meth:`MultiStartResult.to_json`, and read back by ``from_json`` (docs/file-formats.md).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from .._errors import InputError
from ..recording import damping_fields, data_fields, diagnostics_fields, flags, parameter_fields


# ---------------------------------------------------------------------------------- writing
def _model_fields(res, ctx) -> dict:
    """``model``, ``flags``, ``parameter_units`` and ``bounds``: from the model, or as read back."""
    if ctx.model is not None:
        return {"flags": flags(ctx.model, res.parameters, res.names), **parameter_fields(ctx.model)}
    return {k: ctx.get(k) for k in ("flags", "parameter_units", "bounds") if k in ctx.stored}


def update_fields(res, ctx, starts: dict | None = None) -> dict:
    """The keys every iterative update writes (``update`` and ``frf-update``), the starts' record
    ``starts`` (default: one start from the result's own start)."""
    d = res.diagnostics
    data = ctx.data
    out: dict[str, Any] = {
        "model": ctx.model_name,
        "parameters": res.parameters,
        "updated": list(res.names),
        "start": res.start,
        "success": res.success,
        "status": res.status,
        "message": res.message,
        "cost": res.cost,
        "iterations": res.iterations,
        "nfev": res.nfev,
        "pairs": [[k, j, m] for k, j, m in res.pairs],
        "frequencies_hz": {"test": res.test_frequencies_hz, "model": res.model_frequencies_hz},
        "swaps": res.swaps,
        "pairing": getattr(res, "pairing", {}) or None,
        "history": res.history,
        "regularization": res.regularization,
        "sensitivity": res.sensitivity,
        "notes": [*(data.notes if data is not None else []), *res.notes],
        **_model_fields(res, ctx),
        "diagnostics": None if d is None else diagnostics_fields(res.names, d),
    }
    if d is not None and getattr(d, "model_error", None):  # the fit's test, also at the top (femupdate.variance)
        out["model_error"] = d.model_error
    if res.blocks:
        out["blocks"] = res.blocks
    if getattr(res, "damping", None):  # a damped model's update: its damping parameters
        out["damping"] = res.damping
    if starts is None:
        starts = ctx.get("starts") or single_start(res)
    out["starts"] = starts
    out.update(data_fields(data) if data is not None else {k: ctx.get(k) for k in ("units",) if k in ctx.stored})
    return out


def frf_fields(res) -> dict:
    """The FRF part of a result's JSON (lines used and skipped, residual, FRAC, natural frequencies)."""
    return {"omega_rad_s": res.omega, "skipped": res.skipped, "residual": res.residual, "frac": res.frac,
            "natural_frequencies_hz": res.natural_frequencies_hz}


def update_kind(res, ctx, starts: dict | None = None) -> dict:
    """The JSON of kind ``update``: :func:`update_fields`, the formulation, the eigen-solver, the
    damping ratios compared, the dynamic formulation's expanded shapes and the FRF fields."""
    out = update_fields(res, ctx, starts)
    out["formulation"] = res.formulation or None
    out["solver"] = getattr(res, "solver", "") or None
    damping = _damping(res, ctx) if not getattr(res, "damping", None) else None  # a damped model: its own record
    if damping is not None:
        out["damping_ratio"] = damping
    if res.expanded_shapes is not None and ctx.model is not None:  # per test mode {dof: value}
        out["expanded_shapes"] = [dict(zip(ctx.model.dofs, map(float, col))) for col in res.expanded_shapes.T]
    elif "expanded_shapes" in ctx.stored:
        out["expanded_shapes"] = ctx.get("expanded_shapes")
    if hasattr(res, "frac"):
        out.update(frf_fields(res))
    if ctx.get("reduced_basis") is not None:  # femupdate.rom: the basis and its full-model checks
        out["reduced_basis"] = ctx.get("reduced_basis")
    return out


def frf_update_kind(res, ctx, starts: dict | None = None, search: dict | None = None) -> dict:
    """The JSON of kind ``frf-update``: :func:`update_fields`, the FRF fields and, for a global
    search, ``global``."""
    out = update_fields(res, ctx, starts)
    out.update(frf_fields(res))
    search = search if search is not None else ctx.get("global")
    if search is not None:
        out["global"] = search
    return out


def _damping(res, ctx):
    if ctx.data is None:
        return ctx.get("damping_ratio")
    paired = {k: float(fm) for (k, _, _), fm in zip(res.pairs, res.model_frequencies_hz)}
    return damping_fields(ctx.data, paired, ctx.damping)


def single_start(res) -> dict:
    """``starts`` of a run from one start."""
    return {"total": 1, "converged": int(res.success),
            "solutions": [{"parameters": {n: res.parameters[n] for n in res.names}, "cost": res.cost, "count": 1}]
            if res.success else []}


def starts_fields(ms) -> dict:
    """``starts`` of a multi-start study: counts, distinct solutions (marked ``fits``: they fit the
    data as well as the best one), failures by reason and one record per start."""
    return {
        "total": ms.total, "converged": ms.converged, "seed": ms.seed,
        "solutions": [{"parameters": s.parameters, "cost": s.cost, "count": s.count, "fits": s.fits}
                      for s in ms.solutions],
        "fitting": len(ms.fitting), "fit_cost": ms.fit_cost, "distinct": ms.distinct or None,
        "failed": [r for r in ms.runs if isinstance(r, str)],
        "failures": ms.failures,
        "runs": ms.records(),
        "seconds": {"compiled_batch": ms.batch_seconds,
                    "per_start_total": None if ms.seconds is None else float(sum(ms.seconds)),
                    "per_start_cpu_total": None if ms.cpu_seconds is None else float(sum(ms.cpu_seconds))},
    }


def search_fields(ms) -> dict | None:
    """``global`` of a global search (method, runs, residual of the global stage, per-run
    optimiser records); None for a multi-start study."""
    if not getattr(ms, "method", ""):
        return None
    return {"method": ms.method, "runs": ms.total, "residual": ms.global_residual, "optimizer": ms.optimizer}


def multistart_kind(ms, ctx) -> dict:
    """The JSON of a multi-start study or global search: its best run's, with ``starts`` the
    study's; without a converged run ``model``, ``success`` false and ``starts``."""
    starts = starts_fields(ms)
    search = search_fields(ms)
    kind = ctx.kind or ms.kind
    if ms.best is None:
        out = {"model": ctx.model_name, "success": False, "starts": starts}
        if search is not None:
            out["global"] = search
        return out
    if kind == "frf-update":
        return frf_update_kind(ms.best, ctx, starts, search)
    return update_kind(ms.best, ctx, starts)


# ---------------------------------------------------------------------------------- reading
def _floats(values) -> np.ndarray:
    return np.array([math.nan if v is None else float(v) for v in (values or [])], dtype=float)


def _matrix(rows, n: int) -> np.ndarray:
    if not rows:
        return np.full((n, n), math.nan)
    return np.array([[math.nan if v is None else float(v) for v in row] for row in rows], dtype=float)


def diagnostics_from(obj: Mapping | None, names) -> Any:
    """The :class:`~femupdate.updating.Diagnostics` of a result's ``diagnostics`` object."""
    from .results import Diagnostics

    if obj is None:
        return None
    std = obj.get("std") or {}
    rel = obj.get("relative_std") or {}
    cond = obj.get("condition_number")
    return Diagnostics(
        singular_values=_floats(obj.get("singular_values")),
        condition_number=math.inf if cond is None else float(cond), rank=int(obj.get("rank", 0)),
        poorly_determined=list(obj.get("poorly_determined") or []),
        covariance=_matrix(obj.get("covariance"), len(names)),
        std=_floats([std.get(n) for n in names]), n_residuals=int(obj.get("n_residuals", 0)),
        n_parameters=int(obj.get("n_parameters", len(names))), absolute=bool(obj.get("absolute", False)),
        at_bounds=dict(obj.get("at_bounds") or {}), free=tuple(obj.get("free") or ()),
        poorly_determined_reasons=dict(obj.get("poorly_determined_reasons") or {}),
        relative_std=_floats([rel.get(n) for n in names]), noise=list(obj.get("noise") or []),
        std_dof=np.array([_dof((obj.get("std_dof") or {}).get(n, math.nan)) for n in names], dtype=float),
        model_error=dict(obj.get("model_error") or {}))


def _dof(v) -> float:
    """A ``std_dof`` entry as read: a number, ``"inf"`` (stated noise only) or None (NaN)."""
    if v is None:
        return math.nan
    return math.inf if v == "inf" else float(v)


#: keys of an update's JSON kept as read, for writing it again (they come from the model and data)
STORED = ("model", "flags", "parameter_units", "bounds", "units", "starts", "damping_ratio", "expanded_shapes",
          "global")


def update_from(obj: Mapping) -> Any:
    """The :class:`~femupdate.updating.UpdateResult` (an
    :class:`~femupdate.updating.frf.FRFUpdateResult` when it holds FRF fields) of an ``update`` or
    ``frf-update`` JSON; the residuals and Jacobian, which the JSON does not hold, are empty."""
    from ..serialise import RunContext
    from .frf import FRFUpdateResult
    from .results import UpdateResult

    names = tuple(obj.get("updated") or ())
    params = {k: math.nan if v is None else float(v) for k, v in (obj.get("parameters") or {}).items()}
    missing = [n for n in names if n not in params]
    if missing:
        raise InputError(f"/parameters: no value of the updated parameter {missing[0]!r} (named in /updated); the "
                         "update result is not as femupdate writes it")
    freqs = obj.get("frequencies_hz") or {}
    common = dict(
        parameters=params, names=names, x=np.array([params.get(n, math.nan) for n in names], dtype=float),
        success=bool(obj.get("success", False)), status=int(obj.get("status") or 0), message=str(obj.get("message", "")),
        cost=math.nan if obj.get("cost") is None else float(obj["cost"]), fun=np.zeros(0),
        jac=np.zeros((0, len(names))), nfev=int(obj.get("nfev") or 0), njev=0, iterations=int(obj.get("iterations") or 0),
        history=list(obj.get("history") or []),
        pairs=[(int(k), int(j), math.nan if m is None else float(m)) for k, j, m in obj.get("pairs") or []],
        test_frequencies_hz=_floats(freqs.get("test")), model_frequencies_hz=_floats(freqs.get("model")),
        swaps=list(obj.get("swaps") or []), diagnostics=diagnostics_from(obj.get("diagnostics"), names),
        regularization=dict(obj.get("regularization") or {}), start=dict(obj.get("start") or {}),
        sensitivity=str(obj.get("sensitivity") or ""), blocks=list(obj.get("blocks") or []),
        notes=list(obj.get("notes") or []), pairing=dict(obj.get("pairing") or {}),
        formulation=str(obj.get("formulation") or ""), solver=str(obj.get("solver") or ""),
        damping=dict(obj.get("damping") or {}),
        context=RunContext(kind=str(obj.get("kind") or ""), stored={k: obj[k] for k in STORED if k in obj}))
    if "frac" in obj or "omega_rad_s" in obj:
        return FRFUpdateResult(**common, omega=_floats(obj.get("omega_rad_s")), skipped=list(obj.get("skipped") or []),
                               residual=str(obj.get("residual") or "linear"), frac=dict(obj.get("frac") or {}),
                               natural_frequencies_hz=_floats(obj.get("natural_frequencies_hz")))
    return UpdateResult(**common)


__all__ = ["update_fields", "update_kind", "frf_update_kind", "frf_fields", "single_start", "starts_fields",
           "search_fields", "multistart_kind", "update_from", "diagnostics_from"]
