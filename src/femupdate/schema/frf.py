"""The kinds ``frf``, ``frf-select`` and ``surface`` (:mod:`femupdate.frf.record`)."""

from __future__ import annotations

from . import ARRAY, INTEGER, NUMBER, OBJECT, STRING, Key, Kind, register


def _kind(name: str) -> tuple[Key, Key]:
    return (Key("kind", "string", f"`{name}` (the command that wrote it)", (STRING,), True),
            Key("schema_version", "integer", "the version of the results' schema (1)", (INTEGER,), True))


register(Kind(
    "frf",
    (*_kind("frf"),
     Key("model", "string", "", (STRING,)),
     Key("omega_rad_s", "list", "the lines, rad/s", (ARRAY,), True),
     Key("dofs", "list", "response dofs", (ARRAY,), True),
     Key("quantity", "string", "`receptance`, `mobility` or `accelerance` (`--kind`)", (STRING,)),
     Key("response", "`{dof: [[re, im], ...]}`", "one pair per line, in the unit of `quantity`", (OBJECT,), True),
     Key("force", "`{dof: amplitude}`", "", (OBJECT,)),
     Key("damping", "`{alpha, beta, eta}`", "", (OBJECT,)),
     Key("noise", "`{level, kind, seed}`", "", (OBJECT,)),
     Key("parameters", "`{name: value}`", "", (OBJECT,)),
     Key("notes", "list", "e.g. lines within 1e-3 of a resonance", (ARRAY,))),
    intro="The result of `femupdate frf` and `femupdate.simulate_frf` (`femupdate.frf.simulate`: simulated test "
          "data, `result.with_quantity(\"mobility\").to_json()` for `--kind mobility`).  The test data written by "
          "`--test-data` are the receptances, whatever `quantity` says ([below](#test-data-written-by-commands))."))

register(Kind(
    "frf-select",
    (*_kind("frf-select"),
     Key("model", "string", "", (STRING,)),
     Key("equations", "string", "the equations judged: `direct` (complete data, eq. 28) or `sensitivity` (data at "
         "`--dofs`, eqs. 31–32) (`--kind`)", (STRING,)),
     Key("omega_rad_s", "list", "the chosen lines, rad/s", (ARRAY,)),
     Key("lines", "list", "their 1-based positions among the candidates", (ARRAY,)),
     Key("condition_number", "number", "of the chosen lines' equations", (NUMBER,)),
     Key("uniform", "`{omega_rad_s, condition_number}`", "the same number of evenly spread lines, for comparison",
         (OBJECT,)),
     Key("excluded", "list of `{line, omega_rad_s, reason}`", "candidates near resonances", (ARRAY,)),
     Key("history", "list", "the optimum of an exhaustive search, or per start the condition number after each "
         "exchange pass", (ARRAY,))),
    intro="The result of `femupdate frf-select` and `femupdate.frf.select_frequencies` (a `Selection`)."))

register(Kind(
    "surface",
    (*_kind("surface"),
     Key("model", "string", "", (STRING,)),
     Key("residual", "string", "the residual mapped, e.g. `\"frf (eq. 34, linear)\"` or `\"modal (eq. 33)\"`",
         (STRING,)),
     Key("params", "list", "the two parameters", (ARRAY,)),
     Key("x, y", "lists", "the grid values of the first and second parameter", (ARRAY,)),
     Key("values", "list of rows", "the residual, `values[i][j]` at `x[i]`, `y[j]`; `null` where the model is "
         "singular", (ARRAY,)),
     Key("minimum", "`{P1, P2, value}`", "the lowest grid point", (OBJECT,)),
     Key("local_minima", "integer", "interior local minima (8 neighbours)", (INTEGER,)),
     Key("edge_minima", "integer", "local minima on the grid's border", (INTEGER,)),
     Key("minima", "list of `{P1, P2, value, edge}`", "up to 20 local minima, lowest first", (ARRAY,)),
     Key("singular_points", "integer", "grid points exactly on a resonance", (INTEGER,))),
    intro="The result of `femupdate surface`, `femupdate.frf.frf_surface` and `femupdate.frf.modal_surface` (a "
          "`Surface`)."))
