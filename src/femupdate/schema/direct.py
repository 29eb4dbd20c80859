"""The kinds ``direct``, ``demo`` and ``fullfield`` (:mod:`femupdate.direct_record`,
:mod:`femupdate.fullfield.result`)."""

from __future__ import annotations

from . import ARRAY, BOOLEAN, INTEGER, NUMBER, OBJECT, STRING, Key, Kind, register
from .modes import opening

_UNITS = ("each parameter's SI unit, from the element property it stands for (`\"N/m\"` for a spring's `k`, `\"Pa\"` "
          "for `E`, `\"m⁴\"` for `I`, `\"N/m\"`, `\"N/rad\"`, `\"N·m/rad\"` for the Appendix terms 12EI/l³ and EA/l, "
          "6EI/l², 2EI/l and GJ/l; a spring on a rotation `\"N·m/rad\"`, a mass `\"kg\"` or `\"kg·m²\"`); `null` for "
          "matrix models and for a parameter used by properties of different units")
_FLAGS = ("identified values that are not > 0 where they must be (`not_positive`), outside their bounds "
          "(`outside_bounds`) or on a bound (`on_bound`); see [cli.md](cli.md#common-behaviour), \"Flags on results\"")

#: the keys of a direct solution that ``direct`` and ``fullfield`` share
SOLUTION = (
    Key("model", "string", "model name", (STRING,)),
    Key("parameters", "`{name: value}`", "every parameter: identified for the unknowns, given for the others",
        (OBJECT,), True),
    Key("unknowns", "list", "the identified parameters", (ARRAY,)),
    Key("standard_error", "`{name: value}`", "from the least-squares residual (`null` when the residual is zero)",
        (OBJECT,)),
    Key("condition_number", "number", "of the stacked system", (NUMBER,), True),
    Key("condition_number_scaled", "number", "with the columns scaled to unit length (independent of units)",
        (NUMBER,)),
    Key("residual_norm", "number", "‖A p − b‖", (NUMBER,), True),
    Key("relative_residual", "number", "residual over ‖b‖", (NUMBER,)),
    Key("rank", "integer", "numerical rank of the system", (INTEGER,)),
    Key("unique", "bool", "rank equals the number of unknowns", (BOOLEAN,)),
)

register(Kind(
    "direct",
    (*opening("direct"), *SOLUTION,
     Key("n_equations", "integer", "rows of the stacked system", (INTEGER,)),
     Key("bounded", "bool", "`--bounded` was used", (BOOLEAN,)),
     Key("notes", "list of strings", "what the reader of the test data decided, then e.g. the undetermined "
         "parameter combination", (ARRAY,)),
     Key("flags", "`[{parameter, value, kind, bounds, message}]`", _FLAGS, (ARRAY,)),
     Key("parameter_units", "`{name: unit}`", _UNITS, (OBJECT,)),
     Key("bounds", "`{name: [lower, upper]}`", "each parameter's bounds (`null` for an infinite one)", (OBJECT,)),
     Key("units", "object", "the test data's units, when they state them", (OBJECT,)),
     Key("start", "`{name: value}`", "the values the model had (with `--set`)", (OBJECT,)),
     Key("frequencies_hz", "`{test, model}`", "when the data hold modes: the test frequencies and the paired "
         "frequencies of the updated model", (OBJECT,)),
     Key("pairs", "`[[test, model, mac]]`", "when the data hold modes", (ARRAY,)),
     Key("test_points", "object", "with `--test-points`: where each test node was placed on the mesh, as `update`'s", (OBJECT,))),
    intro="The result of `femupdate direct` and `femupdate.direct_update` (`result.to_json()`)."))

register(Kind(
    "demo",
    (Key("true", "`{name: value}`", "the true parameter values of the simulated test", (OBJECT,)),),
    intro="The result of `femupdate demo` and `femupdate.examples.demo()`: the keys of `direct` (`kind` `demo`) "
          "without `start` and `units`, plus:",
    extends="direct"))

register(Kind(
    "fullfield",
    (*opening("fullfield"), *SOLUTION,
     Key("form", "string", "`projected` or `pointwise`", (STRING,)),
     Key("mapping", "object", "`method`, `interpolation_error` (relative to the largest value), `max_distance` "
         "(largest distance of a point from the geometry), `tolerance`, `inferred` (rotations from translations), "
         "`zero`, `fields` (per fitted field: `label`, `part`, `direction`, `smoothing`, `cv_error`, `fit_error`), "
         "`node_gap` (nodes far from every scan point), `notes`", (OBJECT,)),
     Key("notes", "list", "of the direct solution", (ARRAY,)),
     Key("flags", "list", "as `direct`", (ARRAY,))),
    intro="The result of `femupdate fullfield` and `femupdate.fullfield.full_field_direct` (`result.to_json()`)."))
