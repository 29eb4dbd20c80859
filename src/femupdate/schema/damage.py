"""The kinds ``damage`` (:mod:`femupdate.damage.record`), ``update-multi`` and
``rank-modifications`` (:mod:`femupdate.updating.multiconfig.record`)."""

from __future__ import annotations

from . import ARRAY, BOOLEAN, INTEGER, NUMBER, OBJECT, STRING, Key, Kind, register


def _head(kind: str) -> tuple[Key, Key]:
    return (Key("kind", "string", f"`{kind}`", (STRING,), True),
            Key("schema_version", "integer", "the version of the results' schema (1)", (INTEGER,), True))


DAMAGE_KEYS = (
    *_head("damage"),
    Key("model", "string", "the baseline the unknowns belong to (`NAME (element stiffnesses)` with one unknown per "
        "element)", (STRING,)),
    Key("unknowns", "string", "`parameters` (the model's stiffness parameters as it names them) or `elements` (one "
        "stiffness per element)", (STRING,)),
    Key("descriptions", "`{unknown: text}`", "what each unknown scales, e.g. `element #5 (rod 102-103), model parameter "
        "E`", (OBJECT,)),
    Key("headline", "string", "the verdict in one line: the located changes and the status; a model error first "
        "(`MODEL ERROR: ...`), an unchecked baseline said", (STRING,)),
    Key("status", "string", "`confirmed`, `doubtful`, `not localised` or `unverified` (`--no-refine`); never "
        "`confirmed` with a model error or with a baseline neither checked against `--undamaged` data nor stated checked "
        "(`--baseline-checked`)", (STRING,)),
    Key("doubts", "list", "why a location is doubtful (another set fits as well, the replicates disagree, a model "
        "error, the baseline unchecked, changes that move together as a uniform baseline error would)", (ARRAY,)),
    Key("parameters", "`{unknown: value}`", "identified stiffnesses (the baseline's where unchanged)", (OBJECT,)),
    Key("baseline", "`{unknown: value}`", "", (OBJECT,)),
    Key("changes", "`{unknown: relative change}`", "e.g. −0.4 for a 40 % loss", (OBJECT,)),
    Key("located", "list", "the unknowns judged damaged, largest loss first", (ARRAY,)),
    Key("loss", "`{unknown: loss}`", "for the located ones", (OBJECT,)),
    Key("confidence", "object", "`selection_frequency` (share of the bootstrap replicates — each re-localised, refined "
        "and verified — locating each unknown), `same_set` (share locating exactly `located`), `standard_error` (the "
        "standard deviation of each located change's error: the replicates' spread `bootstrap_spread` times "
        "√(ν/(ν−2) · (B−1)/(B−3)), ν the degrees of freedom of estimated noise levels, B the replicates; `null` "
        "when unbounded), `standard_error_dof` (Satterthwaite, of the spread and the levels together), "
        "`evidence` (rise of the misfit without each located unknown), `separation` (the localisation's smallest "
        "located change over the largest elsewhere; `null` when nothing else changed), `bootstrap`, `noise` "
        "(`frequency`, `shape`, `shape_verify`, per-mode `frequency_modes` and `shape_modes` when the test data state "
        "them, and `basis`: what each level rests on — stated by the caller, stated in the test data, estimated from the "
        "expansion misfit, from the fit of every unknown or, when that fit cannot tell the frequencies' (fewer modes than "
        "unknowns), from the fit of the located unknowns, or assumed; \"not estimable ...\" when neither fit can tell "
        "it), `conditional_on` (present only then: the assumed frequency noise the standard errors and rates rest on; "
        "the location is then not `confirmed`), `false_positive_rate` and `detection_rate` (simulated for this run: the whole "
        "chain on replicates of the healthy baseline and of the located model with this run's sensors, modes and noise; "
        "each `rate`, `count`, `n`, `standard_error` (binomial), `interval` (Clopper-Pearson), `level`, `basis`; `null` "
        "without replicates)", (OBJECT,)),
    Key("verification", "object", "`level`, `noise`, `chi2`, `dof`, `limit` and `fits` of the final set, `n_data`, "
        "`sets` (every set fitted), `alternatives` (other sets that fit as well), `noise_factor`, `model_error` (the "
        "chi-square test of the fit of every unknown against the noise: `chi2`, `dof`, `limit`, `p_value`, `fits`, "
        "`level`; `null` when a smaller set fitted first or the data are too few); empty with `--no-refine`",
        (OBJECT,)),
    Key("localisation", "object", "the sparse localisation step's own answer: `method`, `located`, `changes` (the "
        "candidates the refinement started from)", (OBJECT,)),
    Key("localised", "bool", "`false` when localisation was refused or no set fits", (BOOLEAN,)),
    Key("reason", "string", "why (empty when localised)", (STRING,)),
    Key("detected", "bool", "a frequency changed by more than three times the frequency noise", (BOOLEAN,)),
    Key("method, alpha, alpha_max", "string, number, number", "the localisation's regulariser and its factor "
        "(absolute; `null` when localisation was refused)"),
    Key("tikhonov", "`{changes, alpha, n_above_threshold}`", "the spread-out comparison", (OBJECT,)),
    Key("expansion", "`{method, n_basis, error, n_measured_dofs, n_rigid_modes}`", "", (OBJECT,)),
    Key("pairs", "`[[test, baseline, mac]]`", "test modes against baseline modes, paired by the rule `update` pairs "
        "by (close modes as groups)", (ARRAY,)),
    Key("pairing", "`{rule, used, large_change, flagged}`", "the pairs to doubt: each `test_mode`, `baseline_mode` "
        "(1-based), `mac`, `frequency_change` and `why` (a frequency change beyond `large_change`, a MAC below "
        "`--localise-min-mac`)", (OBJECT,)),
    Key("frequency_change", "list", "relative frequency change of each test mode from its baseline mode", (ARRAY,)),
    Key("baseline_check", "object or `null`", "with `--undamaged`: `ok`, `frequency_error`, `mac`, `pairs`, `reasons`, "
        "`limits`", (OBJECT,)),
    Key("path", "list of `{alpha, alpha_fraction, n_located, rss, bic}`", "the L1 path", (ARRAY,)),
    Key("notes", "list", "first the test data's and the undamaged data's readers', how the unknowns were chosen, then "
        "the run's own", (ARRAY,)),
    Key("units", "object", "the test data's units, when they state them", (OBJECT,)),
    Key("test_points", "object", "with `--test-points`: where each test node was placed on the mesh, as `update`'s", (OBJECT,)),
    Key("parameter_units, bounds", "objects", "of the unknowns (an element's `E` in Pa, a spring's `k` in N/m), as "
        "`direct`", (OBJECT,)),
)

register(Kind(
    "damage", DAMAGE_KEYS,
    intro="The result of `femupdate damage` and `femupdate.damage.detect_damage` (`result.to_json()`).",
    outro="Element names: `E.A-B` for the rod, beam or frame between nodes A and B, `k.1x-2x` for a spring between "
          "`1:x` and `2:x`; `.2`, `.3` separate elements between the same nodes."))

register(Kind(
    "update-multi",
    (*_head("update-multi"),
     Key("model", "string", "", (STRING,)),
     Key("method", "string", "`direct` or `iterative`", (STRING,)),
     Key("parameters", "`{name: value}`", "every parameter of the base model", (OBJECT,)),
     Key("updated", "list", "the unknowns", (ARRAY,)),
     Key("success", "bool", "direct: the least-squares solution is unique; iterative: the solver converged",
         (BOOLEAN,)),
     Key("message", "string", "", (STRING,)),
     Key("cost, iterations, nfev", "number, integer, integer", "of the iterative solution (0 for the direct one)",
         (NUMBER,)),
     Key("standard_error", "`{name: value}`", "", (OBJECT,)),
     Key("configurations", "list", "per configuration: `name`, `modification` (a description), `n_data`; iterative: "
         "`pairs`, `cost`, `frequencies_hz`, `swaps`; direct: `n_equations`, `unknowns_seen`, `dropped`", (ARRAY,)),
     Key("conditioning", "object", "`unknowns`; `each` and `cumulative` lists and `stacked`, each with `rank`, "
         "`n_rows`, `min_singular`, `condition_number`, `singular_values`", (OBJECT,)),
     Key("history", "list of `{iteration, cost, parameters}`", "", (ARRAY,)),
     Key("regularization", "`{rule, alpha}` or `{}`", "", (OBJECT,)),
     Key("notes", "list", "", (ARRAY,)),
     Key("flags", "list", "as `direct`", (ARRAY,)),
     Key("parameter_units, bounds", "objects", "as `direct`", (OBJECT,)),
     Key("direct", "object or `null`", "for the direct method: `condition_number`, `condition_number_scaled`, "
         "`residual_norm`, `relative_residual`, `rank`, `unique`, `n_equations`", (OBJECT,)),
     Key("diagnostics", "object or `null`", "iterative: `singular_values`, `condition_number`, `rank`, "
         "`poorly_determined`, `std`, `absolute`, `at_bounds`, `n_at_bounds`, `free`, `poorly_determined_reasons`, "
         "`relative_std`, as for `update`", (OBJECT,))),
    intro="The result of `femupdate update-multi` and `femupdate.updating.multiconfig.solve_configurations` "
          "(`update_configurations`, `direct_configurations`)."))

register(Kind(
    "rank-modifications",
    (*_head("rank-modifications"),
     Key("model", "string", "", (STRING,)),
     Key("criterion", "string", "`condition`, `logdet` or `min_singular`", (STRING,)),
     Key("unknowns", "list", "", (ARRAY,)),
     Key("baseline", "`{rank, condition_number, min_singular, logdet}`", "the baseline test alone", (OBJECT,)),
     Key("candidates", "list", "best first: `name`, `modification`, `gain`, `frequency_shift` (largest relative "
         "shift), `min_mac`, `rank`, `condition_number`, `min_singular`, `logdet`", (ARRAY,)),
     Key("selected", "list", "the greedy choice with `--select`, else empty", (ARRAY,))),
    intro="The result of `femupdate rank-modifications` and `femupdate.updating.multiconfig.rank_modifications`."))
