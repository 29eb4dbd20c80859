"""The kind ``uniqueness`` (:mod:`femupdate.uniqueness.study.record`)."""

from __future__ import annotations

from . import ARRAY, BOOLEAN, INTEGER, NUMBER, OBJECT, STRING, Key, Kind, register

#: what differs from ``starts.distinct`` of ``update``
DISTINCT_CASE = ("without `non_unique`; each start's covariance is that of a fit whose residuals have the length "
                 "`cost_tol` allows, from the sensitivity at the truth; `conditioning` at the truth, its "
                 "`relative_std` at the first noise level, else per 0.01 noise on the residuals")

CASE_KEYS = (
    Key("measured_dofs", "list", "", (ARRAY,), True),
    Key("n_measured", "integer", "", (INTEGER,)),
    Key("n_modes", "integer", "the lowest `n_modes` modes are measured", (INTEGER,), True),
    Key("criteria", "`{name: bool}`", "`jung_ewins_lin`, `botto_data`, `botto_modes`, `botto`, `data_count`, `paper`",
        (OBJECT,), True),
    Key("criteria_counts", "`{name: {count, threshold, formula, equation}}`", "", (OBJECT,)),
    Key("starts, converged", "integers", "", (INTEGER,), True),
    Key("local_minima, not_converged, failed", "integers",
        "starts that ended at a local minimum, ran out of evaluations, failed", (INTEGER,)),
    Key("solutions", "list of `{parameters, count, cost, max_rel_error, is_truth}`",
        "distinct solutions that reproduce the data (told apart by statistics: `distinct`); `is_truth`: not "
        "significantly different from the truth", (ARRAY,), True),
    Key("unique", "bool or `null`", "`true`: every converged start reached the truth; `false`: another solution "
        "reproduces the data too; `null`: no start converged", (BOOLEAN,), True),
    Key("verdict", "string", "`unique`, `non-unique` or `not converging`", (STRING,)),
    Key("truth_found", "bool", "", (BOOLEAN,)),
    Key("condition_number", "number or `null`", "of the normalised sensitivity matrix at the truth (`null`: singular)",
        (NUMBER,), True),
    Key("singular_values, rank, n_parameters, n_residuals", "", "of the same matrix"),
    Key("underdetermined", "bool", "fewer data than unknowns (mn < L)", (BOOLEAN,)),
    Key("noise", "list of `{level, starts, converged, rms_rel_error, median_max_rel_error, predicted_std}`",
        "with `--noise`", (ARRAY,)),
    Key("failure_examples", "list of strings", "", (ARRAY,)),
    Key("distinct", "object", "as `starts.distinct` of `update` (" + DISTINCT_CASE + ")", (OBJECT,)),
    Key("exact", "object", "with `--exact` (`result.with_exact()`), single-sensor cases: `n_solutions`, "
        "`zero_dimensional`, `n_complex`, `solutions` `[{parameters, exact}]` (exact values as strings such as "
        "`\"13/2\"`), `exact_data`, `notes`; or `{skipped: reason}`", (OBJECT,)),
)

register(Kind(
    "uniqueness",
    (Key("kind", "string", "`uniqueness` (the command that wrote it)", (STRING,), True),
     Key("schema_version", "integer", "the version of the results' schema (1)", (INTEGER,), True),
     Key("model", "string", "", (STRING,)),
     Key("parameters", "list", "the unknowns", (ARRAY,)),
     Key("truth", "`{name: value}`", "the values the test data were simulated from", (OBJECT,)),
     Key("n_dofs, starts, seed", "integers", "", (INTEGER,)),
     Key("noise_levels", "list", "relative noise levels studied besides the noise-free data", (ARRAY,)),
     Key("rel_tol, cost_tol, max_nfev, min_mac", "numbers", "options used", (NUMBER,)),
     Key("alpha", "number", "the significance level at which solutions were told apart", (NUMBER,)),
     Key("route", "string", "`local`, or the Dask cluster used", (STRING,)),
     Key("units", "`{total, computed, resumed}`", "work units (not physical units)", (OBJECT,)),
     Key("seconds", "number", "", (NUMBER,)),
     Key("study_key", "string", "SHA-256 of everything that determines the results", (STRING,)),
     Key("cases", "list", "one object per (measured dof set, number of modes)", (ARRAY,), True),
     Key("criteria_agreement", "`{criterion: {agrees, of, wrong_cases}}`",
         "each counting criterion against the study's verdicts", (OBJECT,)),
     Key("parameter_units, bounds", "objects", "of the unknowns, as `direct`", (OBJECT,)),
     Key("figure", "string", "with `--plot` (`result.with_figure(path)`)", (STRING,))),
    intro="The result of `femupdate uniqueness` and `femupdate.run_study` (a `StudyResult`, `result.to_json()`).  "
          "Top level:",
    tables=(("Each case:", CASE_KEYS),)))
