"""The kind ``plan`` (:class:`femupdate.planning.PlanResult`)."""

from __future__ import annotations

from . import ARRAY, INTEGER, NUMBER, OBJECT, STRING, Key, Kind, register
from .modes import opening

register(Kind(
    "plan",
    (*opening("plan"),
     Key("model", "string", "model name", (STRING,)),
     Key("criterion", "string", "`identifiability`, `efi`, `efi-dpr`, `kinetic` or `mac`", (STRING,), True),
     Key("sensor_kind", "string", "`uniaxial` or `triaxial`", (STRING,)),
     Key("sensors", "list of lists", "the chosen sensors, each as the dofs it measures", (ARRAY,), True),
     Key("dofs", "list", "every measured dof, sensor by sensor", (ARRAY,), True),
     Key("fixed", "list of lists", "the sensors the user fixed", (ARRAY,)),
     Key("target", "object", "the target modes: `indices` (0-based), `modes` (1-based), `frequencies_hz`, `method`, "
         "`fractions` (effective-mass or kinetic-energy), `total_fraction`", (OBJECT,), True),
     Key("parameters", "list", "the parameters the plan is to identify", (ARRAY,), True),
     Key("nominal", "`{name: value}`", "their nominal values", (OBJECT,)),
     Key("box", "`{name: [lower, upper]}`", "the box the random points were drawn from", (OBJECT,)),
     Key("noise", "`{eigenvalue, shape}`", "relative std of the eigenvalues, std of the unit-scaled shape entries",
         (OBJECT,)),
     Key("design", "string", "`d` (log det F) or `a` (trace of F⁻¹)", (STRING,)),
     Key("score", "object", "the plan at the nominal point and the random points: `ranks`, `conditions` (null: "
         "infinite), `design`, `min_rank`, `full_rank`, `well_conditioned`, `identifiable`, `max_condition`, `automac_max`, "
         "`max_automac`",
         (OBJECT,), True),
     Key("greedy", "list of lists", "the greedy (or eliminated) set before the exchanges", (ARRAY,)),
     Key("swaps", "integer", "exchanges that improved it", (INTEGER,)),
     Key("predicted_std", "`{name: std}`", "Cramér-Rao standard deviations, parameter units (null: not identifiable)",
         (OBJECT,), True),
     Key("relative_std", "`{name: std}`", "the same divided by the nominal values", (OBJECT,)),
     Key("automac", "list of rows", "auto-MAC of the target modes at the measured dofs", (ARRAY,)),
     Key("automac_max", "number", "its largest off-diagonal term", (NUMBER,)),
     Key("uniqueness", "object", "the expected verdict: `verdict` (`unique`, `locally identifiable`, `not unique`, "
         "`not identifiable`), `explanation`, `criteria` (the counting criteria), `counting_lower_bound` "
         "(`n_min`: the fewest measured dofs with mn >= L, n > 1), `layout_rank_bound` (grounded chains; else null), "
         "`rank`, `ranks`", (OBJECT,), True),
     Key("comparison", "`{criterion: {...}}`", "the other criteria with the same number of sensors: `sensors`, "
         "`identifiable`, `rank`, `condition`, `mean_relative_std`", (OBJECT,)),
     Key("monte_carlo", "object or `null`", "noisy updates with the plan: `runs`, `converged`, `seed`, `mean`, `std`, "
         "`bias`, `predicted_std`, `ratio` (each `{name: value}`), `sampling_error`", (OBJECT,)),
     Key("nodes", "`{node: [x, y, z]}`", "coordinates of the candidate nodes (those the model has)", (OBJECT,)),
     Key("options", "object", "`targets` and `placement` options", (OBJECT,)),
     Key("prior", "`{name: std}` or `null`", "with `--information-gain`: each parameter's prior standard deviation "
         "relative to its nominal value (the design value is then the expected information gain, nats)", (OBJECT,)),
     Key("pretest", "object or `null`", "`tam`: the test-analysis model on the measured dofs (`method`, `dofs`, "
         "`full_frequencies_hz`, `tam_frequencies_hz`, `frequency_error`, `mac`, `paired_targets`, "
         "`self_orthogonality`, `self_max_offdiag`, `cross_orthogonality`, `cross_min_diag`, `cross_max_offdiag`; or "
         "`method` and `error`); `mass_loading`: `sensor_mass`, `total_mass`, `n_sensors`, `frequencies_hz`, "
         "`loaded_frequencies_hz`, `shift_hz`, `relative_shift`, `first_order_relative_shift`, `mac`", (OBJECT,)),
     Key("exciters", "object or `null`", "with `--exciters N`: `dofs`, `greedy`, `excites_all_modes`, `score`, `swaps`, "
         "`noise_floor` (m/N), `std_frf`, `damping_ratio`, `driving_points` (`{dof: {odp, nodp, dpr}}`, best ODP "
         "first), `best_odp`", (OBJECT,)),
     Key("segments", "list of `[node, node]`", "pairs of nodes the stiffness couples (the structure the report draws "
         "the layout on)", (ARRAY,))),
    intro="The result of `femupdate plan` and `femupdate.planning.plan` (`result.to_json()`); `--uff` writes the "
          "sensors as a universal file (datasets 164, 2420, 15, 2411, 82: docs/planning.md); `femupdate report` "
          "draws the layout on the structure."))
