"""The JSON of direct updating — kinds ``direct`` (:func:`femupdate.direct_update`, ``femupdate
direct``) and ``demo`` (:func:`femupdate.examples.demo`, ``femupdate demo``) — written by
:meth:`DirectResult.to_json <femupdate.serialise.Serialisable.to_json>` and read back by
``from_json`` (docs/file-formats.md); and the identified model's correlation with the test modes
that both report.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from ._errors import InputError
from .modal_record import floats, stored
from .recording import data_fields, flags, parameter_fields

#: keys of a direct result's JSON kept as read, for writing it again (they come from the model and data)
STORED = ("model", "true", "flags", "parameter_units", "bounds", "units", "n_equations", "frequencies_hz", "pairs")


@dataclass(frozen=True)
class Identified:
    """The identified model's modes and their correlation with the test modes
    (:attr:`DirectResult.identified <femupdate.direct.DirectResult.identified>`).

    Attributes
    ----------
    modes : Modes or None
        The identified model's modes (None without test modes, or when they cannot be computed).
    correlation : Correlation or None
        Their correlation with the test modes.
    note : str
        Why there is no correlation, when the identified values are flagged and the model's
        modes cannot be computed at them (e.g. a negative stiffness); empty otherwise.
    """

    modes: Any = None
    correlation: Any = None
    note: str = ""


def identified(res, ctx) -> Identified:
    """The identified model's modes (as many as the test modes and four more, at least 10, for a
    model over 1,500 dofs; else all) and their correlation with the context's test modes.

    Raises
    ------
    InputError
        The modes cannot be computed at the identified values and no value is flagged (with a
        flag, :attr:`Identified.note` says why instead).
    """
    from .correlation import correlate
    from .modal import model_modes

    model, data = ctx.model, ctx.data
    if model is None or data is None or not data.modes:
        return Identified()
    n = model.n_dofs
    try:
        modes = model_modes(model, res.parameters, n_modes=min(n, max(len(data.modes) + 4, 10)) if n > 1500 else None)
        return Identified(modes, correlate(data, modes))
    except InputError as exc:  # a negative stiffness, flagged, can make K indefinite
        if not flags(model, res.parameters, res.unknowns):
            raise
        return Identified(note=f"no correlation of the identified model with the test: {exc}")


def direct_kind(res, ctx) -> dict:
    """The JSON of kind ``direct`` (or ``demo``): the identified values and the system's figures,
    the notes (the test data's first), the flags, units and bounds of the parameters, the data's
    units and the starting values (``direct``) or the true values (``demo``), and with test modes
    the identified model's paired frequencies and pairs."""
    from .examples import FIGURE2_TRUE

    demo = res.result_kind == "demo"
    model, data = ctx.model, ctx.data
    after = res.identified
    out: dict[str, Any] = {"model": ctx.model_name}
    if demo:
        out["true"] = dict(ctx.get("true") or FIGURE2_TRUE)
    notes = list(res.notes)
    if data is not None and not demo:
        notes = [*data.notes, *notes, *([after.note] if after.note else [])]
    out.update({
        "parameters": res.parameters, "unknowns": list(res.unknowns),
        "standard_error": dict(zip(res.unknowns, res.standard_error)),
        "condition_number": res.condition_number, "condition_number_scaled": res.condition_number_scaled,
        "residual_norm": res.residual_norm, "relative_residual": res.relative_residual, "rank": res.rank,
        "unique": res.unique, "n_equations": ctx.get("n_equations", res.system.n_equations), "bounded": res.bounded,
        "notes": notes,
    })
    if model is not None:
        out.update({"flags": flags(model, res.parameters, res.unknowns), **parameter_fields(model)})
    else:
        out.update({k: ctx.get(k) for k in ("flags", "parameter_units", "bounds") if k in ctx.stored})
    if not demo:
        out.update(data_fields(data) if data is not None else {k: ctx.get(k) for k in ("units",) if k in ctx.stored})
        if ctx.before is not None:
            out["start"] = dict(ctx.before)
    corr = after.correlation
    if corr is not None:
        out["frequencies_hz"] = {"test": data.frequencies_hz,
                                 "model": [after.modes.frequencies_hz[j] for _, j, _ in corr.pairs]}
        out["pairs"] = [[i, j, m] for i, j, m in corr.pairs]
    elif model is None:
        out.update({k: ctx.get(k) for k in ("frequencies_hz", "pairs") if k in ctx.stored})
    return out


def _number(v, null: float = math.nan) -> float:
    return null if v is None else float(v)


def direct_from(obj: Mapping):
    """The :class:`~femupdate.direct.DirectResult` of a ``direct`` or ``demo`` JSON; the stacked
    system, its null space and singular values, which the JSON does not hold, are empty."""
    from .direct import DirectResult, LinearSystem

    unknowns = tuple(obj.get("unknowns") or ())
    params = {k: float(v) for k, v in (obj.get("parameters") or {}).items()}
    se = obj.get("standard_error") or {}
    ctx = stored(obj, STORED)
    start = obj.get("start")
    return DirectResult(
        parameters=params, unknowns=unknowns, x=floats([params.get(n) for n in unknowns]),
        condition_number=_number(obj.get("condition_number"), math.inf),
        condition_number_scaled=_number(obj.get("condition_number_scaled"), math.inf),
        residual_norm=_number(obj.get("residual_norm")), relative_residual=_number(obj.get("relative_residual")),
        rank=int(obj.get("rank") or 0), unique=bool(obj.get("unique", False)),
        null_space=np.zeros((len(unknowns), 0)), singular_values=np.zeros(0),
        system=LinearSystem(np.zeros((0, len(unknowns))), np.zeros(0), unknowns, []),
        standard_error=floats([se.get(n) for n in unknowns]), bounded=bool(obj.get("bounded", False)),
        notes=list(obj.get("notes") or []),
        context=ctx.replace(before=dict(start) if isinstance(start, Mapping) else None))


__all__ = ["Identified", "identified", "direct_kind", "direct_from", "STORED"]
