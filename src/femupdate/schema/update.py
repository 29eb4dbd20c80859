"""The kinds ``update`` and ``frf-update`` (:mod:`femupdate.updating.record`)."""

from __future__ import annotations

from . import ARRAY, BOOLEAN, INTEGER, NUMBER, OBJECT, STRING, Key, Kind, register

_DIAGNOSTICS = (
    "`singular_values`, `condition_number`, `rank` (of the normalised sensitivity matrix over the free parameters: "
    "those not on a bound), `poorly_determined` (the parameters the data cannot move), `std` `{name: value}` (`null` "
    "on a bound), `covariance`, `n_residuals`, `n_parameters`; `absolute` (the covariance comes from stated standard "
    "deviations), `at_bounds` `{name: \"lower\" \\| \"upper\"}` (parameters held by a bound), `n_at_bounds`, `free` "
    "(the parameters the figures describe), `poorly_determined_reasons` `{name: reason}`, `relative_std` "
    "`{name: std / \\|value\\|}`; `noise` (what the standard deviations rest on, one record per noise component: "
    "`label`, `kind`, `basis` (`stated`, `estimated`, `pooled`, `not estimable`), `source` (`stated in the data file`, "
    "`given as an option`, or the basis), `std` (in the residuals' units), `dof` (`null` for stated), `redundancy`, "
    "`n_residuals`, `members`), `std_dof` `{name: effective dof}` (Satterthwaite; `\"inf\"` when only stated noise "
    "enters), `model_error` (as the top-level key) (docs/cli.md, \"What the diagnostics say\"; docs/numerics.md, "
    "\"Noise and variance components\")")

#: ``distinct`` of a multi-start study (femupdate.updating.clustering.distinct_record) and of a uniqueness case
DISTINCT = ("how the solutions were told apart and how well the best is determined: `alpha` (the significance level), "
            "`basis` (`statistic`: against each solution's covariance, the Mahalanobis distance above the chi-square "
            "quantile; `tolerance`: no covariance, by `rel_tol` alone; `mixed`), `non_unique` (more than one "
            "solution fits the data as well as the best), `separations` (per solution, why it is "
            "distinct from the lowest-cost one: `{basis, statistic, dof, threshold}`, `basis` `statistic`, `non-identifiable` "
            "(differs along a direction the data do not determine) or `tolerance`; `null` for that one), "
            "`conditioning` (ill-conditioning, apart from non-uniqueness: `{condition_number, ill_conditioned, "
            "relative_std {name: value}, weakest {direction {name: component}, relative_std}, basis}`, the "
            "standard deviations relative to the values and what they rest on; `null` without a covariance)")


UPDATE_KEYS = (
    Key("kind", "string", "`update` (the command that wrote it; `frf-update` for `frf-update`)", (STRING,), True),
    Key("schema_version", "integer", "the version of the results' schema (1)", (INTEGER,), True),
    Key("model", "string", "", (STRING,)),
    Key("parameters", "`{name: value}`", "every parameter after the (best) update", (OBJECT,), True),
    Key("updated", "list", "the parameters updated", (ARRAY,)),
    Key("start", "`{name: value}`", "the starting point of the run reported", (OBJECT,)),
    Key("success", "bool", "the optimiser converged", (BOOLEAN,), True),
    Key("status, message", "integer, string", "SciPy's termination status and message"),
    Key("cost", "number", "½ Σ r² at the end", (NUMBER,), True),
    Key("iterations", "integer", "", (NUMBER,), True),
    Key("nfev", "integer", "residual evaluations", (NUMBER,)),
    Key("pairs", "`[[test, model, mac]]`", "final pairing; `mac` is `null` for frequency-only modes", (ARRAY,), True),
    Key("frequencies_hz", "`{test, model}`", "per pair", (OBJECT,), True),
    Key("swaps", "list of `{evaluation, test_mode, from_model_mode, to_model_mode}`",
        "mode swaps met during the iteration", (ARRAY,)),
    Key("pairing", "object", "how the modes were paired at the solution: `policy` (asked for), `used` (the rule that "
        "made the pairs), `min_mac`, `low_mac` (test modes whose pair's MAC is below it)", (OBJECT,)),
    Key("history", "list of `{iteration, cost, parameters}`", "", (ARRAY,)),
    Key("regularization", "`{rule, alpha}` or `{}`", "Tikhonov factor used", (OBJECT,)),
    Key("sensitivity", "string", "the derivative route used (e.g. `fox-kapoor`, `nelson`; `dynamic residual (exact, no "
        "eigen-solution)` for `--formulation dynamic`)", (STRING,)),
    Key("formulation", "string or `null`", "the residuals of the measured modes: `shapes` (default), `mac` or "
        "`dynamic`; `damped` (complex modes of a model with a `[damping]` table); `eigenvalues` when no mode shape is used; `null` without modes (`update` only, not `frf-update`)", (STRING,)),
    Key("solver", "string or `null`", "how the model's modes were computed at the solution (dense LAPACK, or ARPACK "
        "with the factorisation used); `null` without modes (`update` only)", (STRING,)),
    Key("reduced_basis", "object", "with `--reduced-basis`: the reduced model and its control — `size` (Ritz "
        "vectors), `n_dofs`, `n_modes`, `corrections`, `interpolated_dofs`, `snapshots` `[{parameters, why, added, "
        "deflated}]`, `greedy` `[{basis, snapshots, largest_estimate, at}]`, `freq_tol`, `shape_tol`, `checks` (one "
        "per full-model check: `parameters`, `basis`, `round`, `start`, `passed`, `modes` `[{model_mode, "
        "f_reduced_hz, f_full_hz, frequency_error, bound_linear, bound_quadratic, one_minus_mac, passed}]`), "
        "`passed` (every start's last check), `seconds` `{basis, update_and_checks}` (docs/reduced-models.md)",
        (OBJECT,)),
    Key("expanded_shapes", "list of `{dof: value}`", "with `--formulation dynamic`: the full shape of each test mode "
        "at the solution, its measured entries the test shape scaled to unit length over them (with `--test-points`: "
        "at every mesh dof, u = T q, then at the test points' own dofs `T<test node>:<direction>`)", (ARRAY,)),
    Key("notes", "list", "what the user should know: first what the reader of the test data decided, then the run's "
        "own notes", (ARRAY,)),
    Key("flags", "list", "as `direct`: updated values on or outside their bounds, or not > 0 where they must be",
        (ARRAY,)),
    Key("parameter_units, bounds", "objects", "as `direct`", (OBJECT,)),
    Key("black_box", "object", "a `[blackbox]` model (`update` only, one start): `rounds` (per round of probing: "
        "`center`, `steps`, `affine` `{name: bool}`, `parameters` (the round's answer), `matrix_deviation` and "
        "`frequency_deviation` (the code's own run at the answer against the fitted model, relative), `runs`), "
        "`runs` and `cache_hits` (the code's runs in all, and those read back from the cache) (docs/blackbox.md)",
        (OBJECT,)),
    Key("diagnostics", "object", _DIAGNOSTICS, (OBJECT,)),
    Key("model_error", "object", "whether the best fit reproduces the data within the noise: `test` (`chi-square` "
        "against stated noise, `plausibility` of estimated noise, `none`), `statistic`, `dof`, `p_value`, `alpha`, "
        "`verdict` (`model error`, `consistent`, `untested`), `detail` (each test made, Bonferroni-adjusted p-values) "
        "(docs/numerics.md, \"Model error\")", (OBJECT,)),
    Key("blocks", "list", "with more than one kind of data: per block `{kind, label, n_residuals, scale, weighting, "
        "cost}`", (ARRAY,)),
    Key("damping", "object", "a model with a `[damping]` table: `parameters` (the damping parameters updated), "
        "`values` `{name: value}` (every damping parameter), `std` `{name: value}` (of those updated; `null` on a "
        "bound), with modes `damping_ratios` `{test, model}`, `mpc` (of the paired model modes) and `complexity` "
        "`{test, model}` (each `{mpc, mpd_deg}` per paired mode, the model's shape at the test's measured dofs; "
        "`null` for a mode without a shape) "
        "(docs/file-formats.md, \"Damping\")", (OBJECT,)),
    Key("damping_ratio", "object", "with damping (measured ratios or `--damping`): as `correlate`", (OBJECT,)),
    Key("units", "object", "the test data's units, when they state them", (OBJECT,)),
    Key("test_points", "object", "with `--test-points`: where each test node was placed on the mesh: `method` "
        "(`interpolate` or `nearest`), `tolerance`, `largest_distance`, `points` (per test node `test_node`, `xyz`, "
        "`kind` (`element`: inside an element; `node`: on one mesh node), `mesh_nodes`, `weights` (the shape "
        "functions' values), `element`, `natural` (natural coordinates), `distance`, `dofs` `{direction: label}` "
        "(the label its measured dofs carry in the run: a mesh dof, or `T<test node>:<direction>`), and for a test "
        "node measured along its own axes `axes` (their rows in global axes; its directions are along them))",
        (OBJECT,)),
    Key("starts", "object", "**`total`**, **`converged`**, **`solutions`** `[{parameters, cost, count, fits}]` "
        "(distinct solutions: those that fit the data as well as the best first); with `--starts R > 1` or "
        "`--scheduler` also `seed`, `fitting`, `fit_cost`, `distinct` (" + DISTINCT + "), `failed` (messages of "
        "failed starts), `failures` "
        "`{reason: count}`, `runs` (one record per start: `start`, `outcome`, `cost`, `iterations`, `nfev`, "
        "`solution`, `message`, `seconds`, `cpu_seconds`, `pairing`) and `seconds`", (OBJECT,), True),
)

register(Kind(
    "update", UPDATE_KEYS,
    intro="The result of `femupdate update`, `femupdate.update` and `femupdate.multistart` "
          "(`result.to_json()`).",
    outro="When no start converges the file holds only `kind`, `schema_version`, `model`, `success` (`false`) and "
          "`starts`.  With FRF data the keys of `frf-update` below are added.",
    may_add="frf-update"))

register(Kind(
    "frf-update",
    (Key("omega_rad_s", "list", "the lines used", (ARRAY,)),
     Key("skipped", "list of `{line, omega_rad_s, reason}`", "lines left out (e.g. at a resonance)", (ARRAY,)),
     Key("residual", "string", "`linear`, `relative` or `log`", (STRING,)),
     Key("frac", "`{dof: value}`", "frequency response assurance criterion per response dof", (OBJECT,)),
     Key("natural_frequencies_hz", "list", "of the updated model", (ARRAY,)),
     Key("global", "`{method, runs, residual, optimizer}`", "with `--global`", (OBJECT,))),
    intro="The result of `femupdate frf-update`, `femupdate.updating.frf_update`, `frf_multistart` and "
          "`global_search`: the keys of `update` (except "
          "`formulation`, `solver` and `expanded_shapes`; `kind` is `frf-update`), plus:",
    outro="`pairs` and `frequencies_hz` are empty lists for FRF updating unless the test data hold modes too.",
    extends="update"))
