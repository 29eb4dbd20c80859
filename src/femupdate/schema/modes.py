"""The kinds ``modes`` and ``correlate`` (:mod:`femupdate.modal_record`)."""

from __future__ import annotations

from . import ARRAY, INTEGER, OBJECT, STRING, Key, Kind, register


def opening(kind: str) -> tuple[Key, Key]:
    """The rows of ``kind`` and ``schema_version`` in a kind's table."""
    return (Key("kind", "string", f"`{kind}`", (STRING,), True),
            Key("schema_version", "integer", "the version of the results' schema (1)", (INTEGER,), True))


register(Kind(
    "modes",
    (*opening("modes"),
     Key("model", "string", "model name (empty for modes not computed from a model: `femupdate.solve_modes`)",
         (STRING,)),
     Key("eigenvalues", "list of numbers", "λ, rad²/s², ascending", (ARRAY,), True),
     Key("frequencies_hz", "list", "√λ / 2π", (ARRAY,), True),
     Key("dofs", "list of labels", "the model's free dofs", (ARRAY,), True),
     Key("shapes", "list of lists", "one list per mode, ordered as `dofs`", (ARRAY,), True),
     Key("normalisation", "string", "`mass`, `unit`, `max` or `ref:<dof>`", (STRING,)),
     Key("n_rigid", "integer", "rigid-body modes (eigenvalue set to exactly 0)", (INTEGER,)),
     Key("parameters", "`{name: value}`", "the parameter values used", (OBJECT,)),
     Key("solver", "string", "how the modes were computed: `dense (LAPACK)`, or `sparse (ARPACK, ...)` with the "
         "factorisation of K − σM used ([cli.md](cli.md#modes))", (STRING,))),
    intro="The result of `femupdate modes` and `femupdate.model_modes` (`modes.to_json()`)."))

register(Kind(
    "correlate",
    (*opening("correlate"),
     Key("dofs", "list", "the dofs of the COMAC: those every paired test shape was measured at", (ARRAY,)),
     Key("mac", "list of lists", "MAC, test modes × model modes, each row over that test mode's measured dofs",
         (ARRAY,)),
     Key("pairs", "`[[test, model, mac]]`", "the pairs, by the rule `update` uses (`pairing`)", (ARRAY,)),
     Key("frequencies_hz", "`{test, model}`", "all test and all model frequencies", (OBJECT,)),
     Key("frequency_error", "list", "(f_model − f_test) / f_test per pair", (ARRAY,)),
     Key("comac", "`{dof: value}`", "coordinate MAC over the pairs", (OBJECT,)),
     Key("unpaired_test", "list", "test modes without a partner", (ARRAY,)),
     Key("unconfirmed", "list", "test modes whose pair's MAC is below `--min-mac`", (ARRAY,)),
     Key("pairing", "string", "the pairing policy asked for (`auto`, `mac`, `order` or `frequency`)", (STRING,)),
     Key("notes", "list", "what the reader of the test data decided; present only when there are any", (ARRAY,)),
     Key("units", "object", "the test data's units, when they state them", (OBJECT,)),
     Key("test_points", "object", "with `--test-points`: where each test node was placed on the mesh, as `update`'s",
         (OBJECT,)),
     Key("damping_ratio", "object", "with damping: see below", (OBJECT,))),
    intro="The result of `femupdate correlate` and `femupdate.correlate` (`correlation.to_json()`; the model's "
          "damping of `--damping` is `correlation.with_context(damping=...)`).",
    outro="With damping (measured ratios or `--damping`), `correlate` and `update` add `damping_ratio`: `{test, std, "
          "model}` one value per test mode (`null` where not known: the model's is its modal damping ratio at the "
          "paired mode), `model_damping` (`{alpha, beta, eta}` or `null`) and `rayleigh_fit` (`{alpha, beta, "
          "rms_error, n_modes}` or `null`)."))

register(Kind(
    "complex-modes",
    (*opening("complex-modes"),
     Key("model", "string", "model name", (STRING,)),
     Key("eigenvalues", "list of `[re, im]`", "λ = −ζω + iω√(1 − ζ²), rad/s, Im λ > 0, ascending |λ|", (ARRAY,), True),
     Key("natural_frequencies_hz", "list", "|λ| / 2π", (ARRAY,), True),
     Key("damped_frequencies_hz", "list", "Im λ / 2π", (ARRAY,)),
     Key("damping_ratios", "list", "ζ = −Re λ / |λ| (fractions of critical damping)", (ARRAY,), True),
     Key("mpc", "list", "modal phase collinearity per mode, 0 to 1 (1: a real mode)", (ARRAY,)),
     Key("mpd_deg", "list", "mean phase deviation per mode, degrees (0: a real mode)", (ARRAY,)),
     Key("dofs", "list of labels", "the model's free dofs", (ARRAY,), True),
     Key("shapes", "list of lists of `[re, im]`", "one list per mode, ordered as `dofs`", (ARRAY,), True),
     Key("normalisation", "string", "`phi^T (2 lambda M + C) phi = 1`, or `modal coordinates` with modal damping "
         "ratios", (STRING,)),
     Key("solver", "string", "`dense`, `sparse (sigma=...)` or `modal coordinates (N modes)`", (STRING,)),
     Key("n_rigid", "integer", "zero eigenvalues (rigid-body motion) left out", (INTEGER,)),
     Key("n_overdamped", "integer", "real eigenvalues (overdamped motion) left out", (INTEGER,)),
     Key("parameters", "`{name: value}`", "the parameter values used (model's and damping's)", (OBJECT,))),
    intro="The result of `femupdate complex-modes` and `femupdate.damping.complex_modes` (`modes.to_json(model, "
          "parameters)`): the complex modes of a model with a `[damping]` table ([Damping](#damping-damping))."))
