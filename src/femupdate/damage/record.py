"""The JSON of kind ``damage`` (:func:`~femupdate.damage.detect_damage`, ``femupdate damage``),
written by :meth:`DamageResult.to_json <femupdate.serialise.Serialisable.to_json>` and read back
by ``from_json`` (docs/file-formats.md).

A result made by :func:`~femupdate.damage.detect_damage` carries a :class:`DamageContext`: the
baseline model and the test data (for the JSON's units, parameter units and bounds, and for the
report), the kind of unknowns and the notes of the run that precede the result's own (the test
data's, the undamaged data's, how the unknowns were chosen).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from ..recording import data_fields, parameter_fields
from ..serialise import RunContext

#: the note of a run without the undamaged structure's data
NO_UNDAMAGED = "no --undamaged data: the baseline was not checked against the undamaged structure"


@dataclasses.dataclass(frozen=True)
class DamageContext(RunContext):
    """The :class:`~femupdate.serialise.RunContext` of a damage result.

    Attributes
    ----------
    undamaged : TestData, optional
        The undamaged structure's test data (not serialised).
    unknowns : str
        ``"parameters"`` or ``"elements"``: what the unknowns are
        (:func:`~femupdate.damage.damage_unknowns`).
    notes : tuple of str
        The run's notes before the result's own: the test data's, the undamaged data's, how the
        unknowns were chosen, and that the baseline was not checked when no undamaged data were
        given.
    """

    undamaged: Any = None
    unknowns: str = "parameters"
    notes: tuple[str, ...] = ()


def attach(result, model, data, undamaged=None, unknowns=None):
    """``result`` with its :class:`DamageContext` (``unknowns``: the
    :class:`~femupdate.damage.DamageUnknowns` the model came from, if any)."""
    from ..testdata import TestData

    notes = [*(data.notes if isinstance(data, TestData) else ()),
             *(undamaged.notes if isinstance(undamaged, TestData) else ()),
             *(unknowns.notes if unknowns is not None else ())]
    if undamaged is None:
        notes.append(NO_UNDAMAGED)
    ctx = DamageContext(model=model, data=data if isinstance(data, TestData) else None, kind="damage",
                        undamaged=undamaged, unknowns=unknowns.kind if unknowns is not None else "parameters",
                        notes=tuple(notes))
    return dataclasses.replace(result, context=ctx)


def model_error_line(res) -> str | None:
    """The model error the verification found (the fit of every unknown misses the data), as one line; None without."""
    me = (res.verification or {}).get("model_error")
    if not me or me.get("fits", True):
        return None
    return (f"MODEL ERROR: even every unknown changing at once leaves a chi-square misfit of {me['chi2']:.4g} for a "
            f"limit of {me['limit']:.4g} ({me['dof']} degrees of freedom, p = {me['p_value']:.2g}): the model cannot "
            "reproduce the data within the noise, so damage is not located with confidence")


def headline(res) -> str:
    """One line: the verdict, the located changes, and a model error or an unchecked baseline first."""
    changes = ", ".join(f"{n} {res.changes[n] * 100:+.1f} %" for n in res.located)
    what = {"confirmed": f"damage located and confirmed: {changes}",
            "doubtful": f"damage located, DOUBTFUL: {changes or 'no unknown changed'}",
            "unverified": f"damage located, not verified (--no-refine): {changes or 'no unknown changed'}",
            "not localised": "damage NOT localised"}.get(res.status, res.status)
    if res.status == "confirmed" and not res.located:
        what = "no damage: the baseline reproduces the data"
    me = model_error_line(res)
    if me:
        return me + "; " + what
    if res.status == "doubtful" and any(d.startswith("the baseline was not checked") for d in res.doubts):
        what += " (the baseline was not checked: undamaged data or a checked baseline are needed to confirm it)"
    return what


def damage_kind(res, ctx: RunContext) -> dict:
    """The JSON of kind ``damage``."""
    model = ctx.model
    if model is not None:
        described = parameter_fields(model, list(res.changes))
    else:
        described = {k: ctx.get(k) for k in ("parameter_units", "bounds") if k in ctx.stored}
    units = data_fields(ctx.data) if ctx.data is not None else {k: ctx.get(k) for k in ("units",) if k in ctx.stored}
    return {
        "model": ctx.model_name, "headline": headline(res), "parameters": res.parameters, "baseline": res.baseline, "changes": res.changes,
        "located": res.located, "loss": res.loss, "confidence": res.confidence, "localised": res.localised,
        "reason": res.reason, "detected": res.detected, "method": res.method, "alpha": res.alpha,
        "alpha_max": res.alpha_max, "tikhonov": res.tikhonov, "expansion": res.expansion,
        "pairs": [list(p) for p in res.pairs], "pairing": res.pairing, "frequency_change": res.frequency_change,
        "baseline_check": res.baseline_check, "path": res.path,
        "notes": [*getattr(ctx, "notes", ()), *res.notes], **units,
        "status": res.status, "doubts": res.doubts, "verification": res.verification,
        "localisation": res.localisation, "unknowns": getattr(ctx, "unknowns", None) or ctx.get("unknowns"),
        "descriptions": res.descriptions, **described,
    }


def _float(v) -> float:
    return math.nan if v is None else float(v)


#: keys of a damage JSON kept as read, for writing it again (they come from the model and data)
STORED = ("model", "units", "parameter_units", "bounds")


def damage_from(obj: Mapping) -> Any:
    """The :class:`~femupdate.damage.DamageResult` of a ``damage`` JSON (its notes all the
    result's own)."""
    from .detect import DamageResult

    ctx = DamageContext(kind="damage", stored={k: obj[k] for k in STORED if k in obj},
                        unknowns=str(obj.get("unknowns") or "parameters"))
    return DamageResult(
        parameters=dict(obj.get("parameters") or {}), baseline=dict(obj.get("baseline") or {}),
        changes=dict(obj.get("changes") or {}), located=list(obj.get("located") or []),
        loss=dict(obj.get("loss") or {}), confidence=dict(obj.get("confidence") or {}),
        localised=bool(obj.get("localised", False)), reason=str(obj.get("reason") or ""),
        detected=bool(obj.get("detected", False)), method=str(obj.get("method") or ""), alpha=_float(obj.get("alpha")),
        alpha_max=_float(obj.get("alpha_max")), tikhonov=dict(obj.get("tikhonov") or {}),
        expansion=dict(obj.get("expansion") or {}), pairs=[tuple(p) for p in obj.get("pairs") or []],
        frequency_change=np.array([_float(v) for v in obj.get("frequency_change") or []], dtype=float),
        baseline_check=obj.get("baseline_check"), path=list(obj.get("path") or []), notes=list(obj.get("notes") or []),
        status=str(obj.get("status") or "unverified"), doubts=list(obj.get("doubts") or []),
        verification=dict(obj.get("verification") or {}), localisation=dict(obj.get("localisation") or {}),
        descriptions=dict(obj.get("descriptions") or {}), pairing=dict(obj.get("pairing") or {}), context=ctx)


__all__ = ["DamageContext", "attach", "damage_kind", "damage_from", "NO_UNDAMAGED", "headline", "model_error_line"]
