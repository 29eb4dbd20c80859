"""The kind ``reduce`` (:class:`femupdate.reduction.ReductionResult`)."""

from __future__ import annotations

from . import ARRAY, INTEGER, NUMBER, OBJECT, STRING, Key, Kind, register
from .modes import opening

register(Kind(
    "reduce",
    (*opening("reduce"),
     Key("model", "string", "model name", (STRING,)),
     Key("method", "string", "the reduction method", (STRING,), True),
     Key("keep", "list", "kept dofs, in the order given", (ARRAY,), True),
     Key("n_modes", "integer or `null`", "modes used by `modal`, `hybrid`, `serep`", (INTEGER,)),
     Key("frequencies_hz", "`{full, reduced}`", "the lowest (number of kept dofs) frequencies of the full model, and "
         "those of the reduced one", (OBJECT,), True),
     Key("K, M", "lists of rows", "reduced matrices, dense, rows and columns ordered as `keep`", (ARRAY,), True),
     Key("frequency_error", "`{method: [relative errors] or message}`", "the chosen method, and every other one with "
         "`--compare`", (OBJECT,)),
     Key("mass_fraction", "number", "share of the mass the kept dofs carry", (NUMBER,)),
     Key("criteria", "object", "`grounded_frequency_hz` (Larsson & Sas), `gordis_overlap`, `omitted_eigenvalues`, "
         "`messages`", (OBJECT,)),
     Key("parameters", "`{name: value}`", "the parameter values the model was reduced at", (OBJECT,))),
    intro="The result of `femupdate reduce` and `femupdate.reduction.reduce_model` (`result.to_json()`)."))
