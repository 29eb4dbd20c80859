"""The kind ``summary`` (:mod:`femupdate.summary`)."""

from __future__ import annotations

from . import ARRAY, INTEGER, OBJECT, STRING, Key, Kind, register
from .modes import opening

register(Kind(
    "summary",
    (*opening("summary"),
     Key("name", "string", "the model's name", (STRING,), True),
     Key("n_dofs", "integer", "free dofs", (INTEGER,), True),
     Key("dofs_by_direction", "`{direction: count}`", "free dofs per direction (`x` … `rz`, `s`)", (OBJECT,)),
     Key("n_nodes", "integer", "nodes with a free dof", (INTEGER,)),
     Key("elements", "`{type: count}`", "elements by type (`mitc4`, `hex8`, `frame3d`, `mass`, ...); `{}` for a "
         "matrices model", (OBJECT,), True),
     Key("sets", "`{set: count}`", "elements per mesh set (element set, physical group, property id)", (OBJECT,)),
     Key("parameters", "list of `{name, value, unit, bounds, fixed, enters}`", "`bounds` `[lower, upper]` (`null`: "
         "unbounded); `enters`: `K`, `M` and the non-linear terms the parameter is a factor of (`E*t^3`)",
         (ARRAY,), True),
     Key("mass", "`{free, total, by_type}`", "rigid-body translation mass rᵀ M r along `x`, `y`, `z` (kg): `free` "
         "over the free dofs, `total` the structure's with its supports removed, `by_type` the same per element "
         "type (`null` for a matrices model)", (OBJECT,), True),
     Key("stiffness_shares", "`{trace, energy, modes, frequencies_hz}`", "each stiffness term's share (`K0`, each "
         "parameter, each non-linear term; the shares add up to 1): `trace` f tr(K_j) / tr(K), `energy` the modal "
         "strain energy fraction f φᵀ K_j φ / λ in each of the flexible `modes` (numbers from 1) at "
         "`frequencies_hz`", (OBJECT,), True)),
    intro="The output of `femupdate summary` and `femupdate.summary.model_summary` (what a model holds)."))
