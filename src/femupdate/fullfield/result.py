"""The result of :func:`~femupdate.fullfield.full_field_direct`: the direct solution on the scan
mapped onto the model, with the mapping (kind ``fullfield``, what ``femupdate fullfield``
writes)."""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field
from typing import ClassVar

from ..direct import DirectResult
from ..serialise import RunContext, Serialisable
from .mapping import FullFieldMapping


@dataclass(frozen=True, eq=False)
class FullFieldResult(Serialisable):
    """A full-field scan mapped onto the model's dofs and the direct solution on the completed
    data (:func:`~femupdate.fullfield.full_field_direct`).

    A result of kind ``fullfield`` (:mod:`femupdate.serialise`): ``to_json()`` is what ``femupdate
    fullfield --json`` writes; ``to_frame()`` one row per parameter.  It unpacks as
    ``(direct, mapping)``, as :func:`~femupdate.fullfield.full_field_direct` returned before.

    Attributes
    ----------
    direct : DirectResult
        The direct solution on the completed data.
    mapping : FullFieldMapping
        The scan on the model's dofs, with the mapping's error (read back from JSON: its ``data``
        are empty, the JSON does not hold them).
    form : str
        ``"projected"`` or ``"pointwise"``: the direct equations used.
    context : RunContext, optional
        The model (not serialised: its name and the flags on the identified values go into the
        JSON).
    """

    kind: ClassVar[str] = "fullfield"

    direct: DirectResult
    mapping: FullFieldMapping
    form: str = "projected"
    context: RunContext | None = field(default=None, compare=False, repr=False)

    def __iter__(self) -> Iterator:
        return iter((self.direct, self.mapping))

    @property
    def parameters(self) -> dict[str, float]:
        """Every parameter's value (:attr:`DirectResult.parameters <femupdate.direct.DirectResult>`)."""
        return self.direct.parameters

    def payload(self) -> dict:
        from ..recording import flags

        res, mp, ctx = self.direct, self.mapping, self.run_context
        return {
            "model": ctx.model_name, "parameters": res.parameters, "unknowns": list(res.unknowns),
            "standard_error": dict(zip(res.unknowns, res.standard_error)), "condition_number": res.condition_number,
            "condition_number_scaled": res.condition_number_scaled, "residual_norm": res.residual_norm,
            "relative_residual": res.relative_residual, "rank": res.rank, "unique": res.unique, "form": self.form,
            "mapping": {"method": mp.method, "interpolation_error": mp.interpolation_error,
                        "max_distance": mp.max_distance, "tolerance": mp.tolerance, "inferred": mp.inferred,
                        "zero": mp.zero, "fields": mp.fields, "node_gap": mp.node_gap, "notes": mp.notes},
            "notes": res.notes,
            "flags": flags(ctx.model, res.parameters, res.unknowns) if ctx.model is not None else ctx.get("flags"),
        }

    @classmethod
    def from_payload(cls, obj: Mapping) -> FullFieldResult:
        from ..direct_record import direct_from
        from ..modal_record import stored
        from ..testdata import TestData

        mp = obj.get("mapping") or {}

        def number(key: str) -> float:
            return float("nan") if mp.get(key) is None else float(mp[key])

        mapping = FullFieldMapping(
            data=TestData(), method=str(mp.get("method") or ""), fields=list(mp.get("fields") or []),
            interpolation_error=number("interpolation_error"), max_distance=number("max_distance"),
            tolerance=number("tolerance"), inferred=list(mp.get("inferred") or []), zero=list(mp.get("zero") or []),
            node_gap=dict(mp.get("node_gap") or {}), notes=list(mp.get("notes") or []))
        return cls(direct_from(dict(obj, kind="direct")), mapping, str(obj.get("form") or "projected"),
                   context=stored(obj, ("model", "flags")))


__all__ = ["FullFieldResult"]
