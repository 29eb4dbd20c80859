"""The kinds ``posterior`` (:mod:`femupdate.bayes.record`) and ``paper`` (:mod:`femupdate.paper.result`)."""

from __future__ import annotations

from . import ARRAY, BOOLEAN, INTEGER, NUMBER, OBJECT, STRING, Key, Kind, register

register(Kind(
    "posterior",
    (Key("kind", "string", "`posterior`", (STRING,), True),
     Key("schema_version", "integer", "the version of the results' schema (1)", (INTEGER,), True),
     Key("model", "string", "", (STRING,)),
     Key("method", "string", "`laplace`, `mcmc` or `tmcmc`", (STRING,), True),
     Key("success", "bool", "the method's checks passed (MCMC: effective sample size ≥ 400 and split R-hat ≤ 1.01 for "
         "every parameter; TMCMC: the last stage's acceptance ≥ 5 %); `false` exits 1", (BOOLEAN,), True),
     Key("updated", "list", "the parameters of the posterior", (ARRAY,)),
     Key("parameters", "`{name: value}`", "the posterior medians (as `median`)", (OBJECT,), True),
     Key("mean, median, std", "`{name: value}`", "of the samples", (OBJECT,), True),
     Key("interval", "`{name: [lower, upper]}`", "equal-tailed credible interval of probability `level`", (OBJECT,),
         True),
     Key("level", "number", "0.95 unless `--level`", (NUMBER,)),
     Key("covariance", "list of lists", "of the samples, in the order of `updated`", (ARRAY,)),
     Key("correlation", "list of lists", "of the samples, in the order of `updated`", (ARRAY,), True),
     Key("solutions", "list", "the distinct solutions, most probable first: `parameters` (the posterior's mode), "
         "`probability` (Laplace), `sample_share` (share of the samples nearest it; the probability itself for "
         "`laplace`), `std` and `covariance` of its Laplace Gaussian, `log_weight` (log Z_k), `cost` (½‖r‖² there), "
         "`count` (multi-start runs that reached it), `inside_bounds` (share of its Gaussian within the bounds), "
         "`at_bounds`, `note`", (ARRAY,), True),
     Key("log_evidence, log_evidence_error", "number or `null`", "log p(data): TMCMC's estimate and its Monte Carlo "
         "error (a lower bound), or the Laplace approximation (no error); `null` for `mcmc`. It is the log density "
         "of the residuals as weighted: compare it between models of the same data and standard deviations",
         (NUMBER,)),
     Key("noise", "object", "`kind` (`stated` when every block's noise is stated, else `estimate`), `n_residuals`, "
         "`pools` (what the standard deviations rest on: [{`label`, `basis` (`stated` or `estimated`), `n_residuals`, "
         "`source` (`stated in the data file`, `given as an option`, or `estimated (Jeffreys' prior, integrated out)`), "
         "`members` (the blocks), `scale` {`median`, `interval`} when estimated}]: the stated blocks, and one scale per "
         "kind of data estimated); when the eigenvalues' noise is estimated, `scale` {`median`, `interval`} (its "
         "scale) and `draws`; `model_error` (as the top-level key)", (OBJECT,), True),
     Key("model_error", "object or `null`", "the test of the fit at the most probable solution, as `update`'s: "
         "`test`, `statistic`, `dof`, `p_value`, `alpha`, `verdict` (`model error`, `consistent`, `untested`), "
         "`detail`", (OBJECT,)),
     Key("prior", "`{name: text}`", "the prior used, e.g. `\"normal(6, 0.5) on [1, 11]\"`, `\"uniform on [3, 13]\"`",
         (OBJECT,)),
     Key("predictive", "object or `null`", "with measured modes: `modes` [{`test_mode` (0-based), `frequency_hz` "
         "{`mean`, `std`, `interval`}, `measured_frequency_hz` {`interval`} (a new measurement: the model's frequency "
         "with the measurement noise), `mac` {`mean`, `interval`} or `null`, and for a damped model `damping_ratio` "
         "{`mean`, `std`, `interval`} or `null` (the paired complex mode's)}], `draws` (posterior samples predicted)",
         (OBJECT,)),
     Key("damping", "object or `null`", "a model with a `[damping]` table: `parameters` (the damping parameters among "
         "the updated ones), `held` {name: value} (those held at their values); `null` otherwise", (OBJECT,)),
     Key("diagnostics", "object", "all: `evaluations`, `failures` {message: count}; MCMC: `ess`, `tau` (integrated "
         "autocorrelation time, steps), `tau_reliable`, `rhat` (each `{name: value}`), `acceptance`, `walkers`, "
         "`ensembles`, `steps`, `burn`, `kept_steps`, `stopped` (`steps` or `target_ess`), `resumed_steps`, "
         "`limits`, `mcmc_seconds`; TMCMC: `stages` [{`stage`, `beta`, `cov`, `log_S`, `acceptance`, `scale`, "
         "`ess`, `distinct`, `mean`, `std`}], `n_stages`, `acceptance`, `ess` (Kish size of the last reweighting), "
         "`distinct`, `samples`, `resumed_stages`, `tmcmc_seconds`", (OBJECT,)),
     Key("n_samples, data_sets", "integer", "samples summarised; test-data files (repeated tests)", (INTEGER,)),
     Key("route, seed, seconds", "string, integer, number", "`compiled` or `local` likelihood evaluations; the seed of "
         "every random stream; wall-clock time"),
     Key("warnings, notes", "list of strings", "what makes the answer doubtful; what the user should know (first what "
         "the reader of the test data decided, then the noise treatment, improper priors, failed evaluations, "
         "solutions on a bound)", (ARRAY,)),
     Key("units", "object", "the (first) test data's units, when they state them", (OBJECT,)),
     Key("test_points", "object", "with `--test-points`: where each test node was placed on the mesh, as `update`'s", (OBJECT,))),
    intro="The result of `femupdate posterior` and `femupdate.posterior` (`result.to_json()`; the samples are not in "
          "it: `--samples-out`, `result.samples`)."))

register(Kind(
    "paper",
    (Key("kind", "string", "`paper`", (STRING,), True),
     Key("schema_version", "integer", "the version of the results' schema (1)", (INTEGER,), True),
     Key("paper", "string", "the paper's title", (STRING,)),
     Key("sections", "`{NAME: {...}}`", "per section the computed values, the paper's printed values or claims, "
         "`summary` (one line), `agrees_with_paper` (`true` or `false`; files written before this version may hold "
         "`null`), `comparison` (`\"agree\"`, `\"differ-explained\"` or `\"not-comparable\"`) and, unless it agrees, "
         "`explanation` (how and why the result differs, or why it cannot be compared). Sections of FRF data carry "
         "`force` (where the unit force acts)", (OBJECT,))),
    intro="The result of `femupdate paper` and `femupdate.paper.run_sections` (a `PaperResult`), written as "
          "`OUT/paper.json`; `--json` writes the same object."))
