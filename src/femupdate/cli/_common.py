"""What every ``femupdate`` command shares: the console and JSON output, the common options,
parsing of ``--set`` and ``--regularization``, the tables and payloads of several commands; and,
from the modules beside it, the input and output paths (:mod:`._paths`), the damping fields
(:mod:`._damping`) and the error handling of the entry point (:mod:`._entry`).

Exit codes: 0 success, 2 bad input, 1 numerical failure, 130 Ctrl-C, 143 SIGTERM; errors are one
clear message on stderr, never a traceback.  Keep module-level imports light: heavy libraries
are imported inside the functions that need them.
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import click
import numpy as np
from rich.console import Console
from rich.table import Table

from .._errors import FemupdateError, InputError
from .._limits import MAX_MAGNITUDE
# what the commands import from here, defined beside: output and input paths, damping, the entry point
from ._damping import print_damping  # noqa: F401
from ._entry import run  # noqa: F401
from ._paths import (CHECKPOINT_FILE, INPUT_FILE, OUTPUT_DIR, OUTPUT_FIGURE, OUTPUT_FILE, REPORT_FILE,  # noqa: F401
                     InputPath, OutputPath, with_output_notes)
# the JSON fields several results share (femupdate.recording)
from ..recording import (damping_fields, data_fields, diagnostics_extra, fitted_damping, flags,  # noqa: F401
                         parameter_fields)


class Ctx:
    """Where a command prints (stdout, or stderr and quiet with ``--json -``) and writes its JSON."""

    def __init__(self, json_path):
        self.json_path = json_path
        quiet = json_path == "-"
        self.console = Console(file=sys.stderr if quiet else sys.stdout, quiet=quiet, highlight=False, soft_wrap=True,
                               emoji=False)  # dof labels such as "1:x:" are not emoji codes


class FiniteFloat(click.FloatRange):
    """A float option that must be finite (click's FloatRange lets ``nan`` and ``inf`` through) and
    at most 1e150 in magnitude, optionally within bounds; click's message names the option as typed (e.g. ``--min-mac``)."""

    name = "finite float"

    def convert(self, value, param, ctx):
        rv = super().convert(value, param, ctx)
        if not math.isfinite(rv):
            self.fail(f"{value!r} is not a finite number.", param, ctx)
        if abs(rv) > MAX_MAGNITUDE:  # as in input files (docs/file-formats.md, "Numbers")
            self.fail(f"{value!r} is above {MAX_MAGNITUDE:g} in magnitude.", param, ctx)
        return rv


#: ``--seed``: numpy's generators refuse negative seeds; 2**32 - 1 keeps every generator API usable
SEED = click.IntRange(0, 2**32 - 1)


def parse_set(text: str | None) -> dict[str, float]:
    """``"k1=9,k2=5.33"`` -> {"k1": 9.0, "k2": 5.33}."""
    out: dict[str, float] = {}
    if not text:
        return out
    for item in text.split(","):
        item = item.strip()
        if not item:
            continue
        name, eq, val = item.partition("=")
        if not eq or not name.strip():
            raise InputError(f"--set: {item!r} is not of the form name=value")
        if name.strip() in out:
            raise InputError(f"--set: {name.strip()!r} is given twice")
        try:
            out[name.strip()] = float(val)
        except ValueError:
            raise InputError(f"--set: value of {name.strip()!r} is not a number: {val!r}") from None
        if not np.isfinite(out[name.strip()]):
            raise InputError(f"--set: value of {name.strip()!r} is not finite")
    return out


def check_set(model, values: dict[str, float]) -> None:
    """``--set`` values pass the model file's checks: a known parameter, within its bounds, and
    > 0 where the parameter is an element property (a stiffness, mass or section value)."""
    from ..model import Parameter

    for name, v in values.items():
        par = model.parameters[model.parameter_index(name)]  # names an unknown parameter clearly
        try:
            Parameter(name, v, par.bounds, par.fixed)
        except InputError as exc:
            raise InputError(f"--set: {exc}") from None
        if name in model.positive and not v >= 1 / MAX_MAGNITUDE:
            raise InputError(f"--set: parameter {name!r} = {v:g} is an element property of {model.name!r} and must be > 0 "
                             f"(at least {1 / MAX_MAGNITUDE:g}, as in the model file)")


def model_values(model, set_text):
    """The model's parameter vector with ``--set`` applied, or None without ``--set``."""
    values = parse_set(set_text)
    check_set(model, values)
    return model.resolve(values) if values else None


def option_dofs(items, model, option: str) -> tuple[str, ...]:
    """Dofs given in a command-line option as labels or ``#N`` (the N-th dof of ``model``, 1-based),
    as canonical labels; a message names the option.

    Parameters
    ----------
    items : iterable of str
        The dofs as typed.
    model : Model
        The model whose dof list ``#N`` counts in.
    option : str
        The option, e.g. ``"--keep"``.

    Returns
    -------
    tuple of str

    Raises
    ------
    InputError
        A malformed label or index, an index out of range (the message gives the model's dof
        count), or the same dof twice.
    """
    from ..dofs import resolve_all

    try:
        return resolve_all(items, model.dofs, option)
    except InputError as exc:
        msg = str(exc)
        raise InputError(msg if msg.startswith(option) else f"{option}: {msg}") from None


#: ``--measured-dofs`` of the commands that read test data (:func:`load_data`)
measured_dofs_option = click.option(
    "--measured-dofs", "measured_text", default=None, metavar="DOFS",
    help="The measured dofs of the test modes, comma-separated labels or #N: each mode keeps its shape at these "
         "dofs only, zeros included. Replaces the test data's sensors and a universal file's rule for padded zeros.")


def load_data(path, model, measured_text: str | None = None, numbering=None, option: str = "--measured-dofs"):
    """The test data in ``path`` for ``model`` (:func:`femupdate.io.testdata_json.load_testdata`),
    with ``--measured-dofs`` as its sensor list.

    Raises
    ------
    InputError
        As the reader; ``--measured-dofs`` empty, malformed, out of range or listing a dof twice
        (the message names the option).
    """
    from ..io.testdata_json import load_testdata

    sensors = None
    if measured_text is not None:
        items = [t.strip() for t in str(measured_text).split(",") if t.strip()]
        if not items:
            raise InputError(f"{option}: no dofs given (comma-separated labels such as 3:x, or #N)")
        from ..dofs import resolve_all

        try:
            sensors = resolve_all(items, model.dofs if numbering is None else numbering, option)
        except InputError as exc:
            msg = str(exc)
            raise InputError(msg if msg.startswith(option) else f"{option}: {msg}") from None
    return load_testdata(path, model, numbering=numbering, sensors=sensors)


def print_data_notes(ctx: "Ctx", data) -> None:
    """One ``note:`` line per note of the reader (measured dofs chosen, units converted, systems
    applied)."""
    for n in data.notes:
        ctx.console.print(f"note: {n}", markup=False)


def parse_regularization(text):
    """``--regularization``: None, ``gcv``, ``lcurve`` or a Tikhonov factor."""
    if text is None:
        return None
    if text in ("gcv", "lcurve"):
        return text
    try:
        value = float(text)
    except ValueError:
        raise InputError(f"--regularization must be gcv, lcurve or a number, got {text!r}") from None
    if not (math.isfinite(value) and value >= 0):
        raise InputError(f"--regularization: the Tikhonov factor must be a finite number >= 0, got {text!r}")
    return value


def parse_std(text: str | None, option: str, n_modes: int) -> float | list[float] | None:
    """A standard deviation option that takes one value or one per test mode (``--std-eigenvalue``,
    ``--std-shape``): ``"0.002"`` -> 0.002, ``"0.002,0.004,0.01"`` -> [0.002, 0.004, 0.01].

    Parameters
    ----------
    text : str or None
        The option's text (None: not given).
    option : str
        The option as the user typed it, for the messages.
    n_modes : int
        The number of test modes: a list must have one value per mode.

    Returns
    -------
    float, list of float, or None

    Raises
    ------
    InputError
        An empty item, a value that is not a number, not finite, not > 0 or outside
        [1e-150, 1e150]; a list whose length is neither 1 nor the number of test modes.
    """
    if text is None:
        return None
    values = []
    for item in str(text).split(","):
        item = item.strip()
        if not item:
            raise InputError(f"{option}: empty value in {text!r}; give one number, or one per test mode separated by "
                             "commas")
        try:
            v = float(item)
        except ValueError:
            raise InputError(f"{option}: {item!r} is not a number") from None
        if not math.isfinite(v):
            raise InputError(f"{option}: {item!r} is not a finite number")
        if not v > 0:
            raise InputError(f"{option}: {item} is not > 0 (a standard deviation is positive)")
        if v < 1 / MAX_MAGNITUDE or v > MAX_MAGNITUDE:
            raise InputError(f"{option}: {item} is outside [{1 / MAX_MAGNITUDE:g}, {MAX_MAGNITUDE:g}]")
        values.append(v)
    if len(values) == 1:
        return values[0]
    if len(values) != n_modes:
        held = f"{n_modes} test mode{'s' if n_modes != 1 else ''}" if n_modes else "no test modes"
        raise InputError(f"{option}: {len(values)} values given, but the test data hold {held}: give one value, or "
                         "one per test mode in the order of the file")
    return values


def emit(ctx: Ctx, payload: dict) -> None:
    """Write the machine-readable result if ``--json`` was given."""
    if ctx.json_path:
        from ..io.results import write_json

        write_json(ctx.json_path, with_output_notes(payload))


def percent(x: float, decimals: int = 2) -> str:
    """``x`` (a fraction) in per cent with its sign and ``decimals`` decimals; one that rounds to
    zero is printed without a sign (its sign is rounding noise, which differs between machines)."""
    text = f"{x * 100:+.{decimals}f}"
    return f"{text.lstrip('+-') if float(text) == 0 else text} %"


def fmt(v: float) -> str:
    return f"{v:.6g}"


json_option = click.option("--json", "json_path", metavar="PATH", default=None, type=OutputPath("file", dash=True),
                           help="Write the machine-readable result to PATH ('-' = stdout).")
class SchedulerAddress(click.ParamType):
    """A Dask scheduler's address: not empty (an empty ``--scheduler ''`` used to mean "run
    locally" without a word)."""

    name = "address"

    def convert(self, value, param, ctx):
        text = str(value).strip()
        if not text:
            self.fail("empty; give the scheduler's address (tcp://host:port), or leave the option out to run "
                      "locally", param, ctx)
        return text


SCHEDULER = SchedulerAddress()

connect_timeout_option = click.option(
    "--connect-timeout", type=FiniteFloat(min=0, min_open=True, max=1e6), default=10.0, show_default=True,
    help="Seconds to wait for the Dask scheduler and its first worker (and how long a run may go without workers).")
set_option = click.option("--set", "set_text", metavar="NAME=VALUE,...", default=None,
                          help="Evaluate the model at other parameter values.")
#: ``--write-model FILE`` and ``--csv DIR``: the updated model out (:func:`write_model_outputs`)
write_model_option = click.option("--write-model", "write_model_path", type=OutputPath("file", suffixes=(".toml",), why="a model file"),
                                  default=None, metavar="FILE.toml",
                                  help="Write the updated model file: the same schema with the updated values and "
                                       "a [provenance] table.")
write_back_option = click.option("--write-back", "write_back_dir", type=OUTPUT_DIR, default=None, metavar="DIR",
                                 help="Write the updated values back into the model's deck (Nastran cards, Abaqus "
                                      "keyword lines) or as ANSYS commands, in this folder (as femupdate write-back).")
csv_option = click.option("--csv", "csv_dir", type=OUTPUT_DIR, default=None, metavar="DIR",
                          help="Write parameters.csv (and modes.csv with paired modes) to this folder.")
#: ``--report FILE.html``: the run's HTML report (:func:`write_report_output`)
report_option = click.option("--report", "report_path", type=REPORT_FILE, default=None, metavar="FILE.html",
                             help="Write one self-contained HTML report of the run (tables, figures, mode shapes on "
                                  "the model, notes); it opens offline.")


def model_segments(model_path):
    """Node pairs of every line element of a structure model file, supported ends included (for
    drawing mode shapes), or None for a ``[matrices]`` model or a file that is not a structure."""
    from ..fullfield import structure_segments
    from ..io.model_file import read_toml
    from ..structure import Structure

    path = Path(model_path)
    raw = read_toml(path)
    raw.pop("damping", None)  # a [damping] table does not change the drawing
    if {"matrices", "abaqus", "nastran", "ansys"} & set(raw):
        return None
    segs = structure_segments(Structure.from_dict(raw, source=str(path)))
    return segs if len(segs) else None


def write_report_output(ctx: Ctx, report_path, payload, *, model=None, data=None, model_path=None,
                        before=None, damping=None, kind: str | None = None, segments=None, test_points=None) -> None:
    """Write the run's HTML report (``--report``) from its result object (or its JSON payload,
    with the model and the data for what needs recomputing; :func:`femupdate.report.write_report`),
    and name it.  ``test_points``: the :class:`~femupdate.testpoints.MappedTest` of ``--test-points``
    (shapes drawn on the mesh's own dofs)."""
    if report_path is None:
        return
    from ..report import write_report

    if segments is None and model_path is not None:
        segments = model_segments(model_path)
    write_report(report_path, payload, model=model, data=data, kind=kind, segments=segments, before=before,
                 damping=damping, source=f"run on {model_path}" if model_path else "", test_points=test_points)
    ctx.console.print(f"wrote the report {report_path}")


def write_model_outputs(ctx: Ctx, model_path, data_path, command: str, model, values: dict, names, cost,
                        write_model_path=None, csv_dir=None, res=None, damping: dict | None = None,
                        write_back_dir=None) -> None:
    """The updated model file, the CSV tables and the values written back into the model's deck a
    command was asked for, each named on the terminal (:mod:`femupdate.io.model_write`,
    :mod:`femupdate.io.write_back`)."""
    from ..io.model_write import provenance, write_result_tables, write_updated_model

    if write_back_dir is not None:  # first: a parameter that maps to no card stops the run before any file
        from ..io.write_back import write_back

        for path in write_back(model_path, {n: values[n] for n in names}, write_back_dir):
            ctx.console.print(f"wrote {path}")

    if write_model_path is not None:
        write_updated_model(model_path, write_model_path, {n: values[n] for n in names},
                            provenance(model_path, data_path, command, cost, names))
        ctx.console.print(f"wrote the updated model {write_model_path}")
    if csv_dir is not None and res is not None:
        written = write_result_tables(csv_dir, model, res, damping)
        ctx.console.print("wrote " + ", ".join(str(p) for p in written))


# ---------------------------------------------------------------------------------- tables and payloads
def correlation_table(corr, title):
    """Paired test and model modes: frequencies, error and MAC; unpaired test modes last."""
    t = Table(title=title)
    for col in ("test", "model", "f test [Hz]", "f model [Hz]", "error", "MAC"):
        t.add_column(col, justify="right")
    for (i, j, m), e in zip(corr.pairs, corr.frequency_error):
        t.add_row(str(i + 1), str(j + 1), fmt(corr.test_frequencies_hz[i]), fmt(corr.model_frequencies_hz[j]),
                  percent(e) if np.isfinite(e) else "-", "-" if not np.isfinite(m) else f"{m:.4f}")
    for i in corr.unpaired_test:
        t.add_row(str(i + 1), "-", fmt(corr.test_frequencies_hz[i]), "-", "-", "unpaired")
    if getattr(corr, "unconfirmed", None):
        t.caption = (f"test mode(s) {', '.join(str(i + 1) for i in corr.unconfirmed)}: MAC below the pairing threshold, "
                     "so the shapes do not confirm the pair")
    return t


def print_flags(ctx: Ctx, found: list[dict]) -> None:
    """One ``warning:`` line per flag (printed with the result; the exit code is unchanged)."""
    for f in found:
        ctx.console.print(f"warning: {f['message']}", markup=False)


def unit_suffix(unit: str | None) -> str:
    """``" [N/m]"`` for a unit, ``""`` without one (for column headings and axis labels)."""
    return f" [{unit}]" if unit else ""




def print_diagnostics(console, res) -> None:
    """The diagnostics' lines under an iterative update: convergence, cost and conditioning; the
    count of active bounds (naming them); each poorly determined parameter with its reason."""
    d = res.diagnostics
    what = "free parameters" if d.at_bounds else "parameters"
    console.print(f"{'converged' if res.success else 'NOT converged'}: {res.message}; cost {res.cost:.4g}; "
                  f"condition number of the normalised sensitivity matrix {d.condition_number:.3g} "
                  f"(rank {d.rank}/{d.n_parameters - d.n_at_bounds} {what})", markup=False)
    print_identifiability(console, d)
    print_noise_basis(console, d)


def print_noise_basis(console, d) -> None:
    """What each standard deviation rests on (one line per noise component: stated in the data
    file, given as an option, estimated with its dof, pooled), how blocks were pooled, and the
    fit's test for model error (:mod:`femupdate.updating.noise`)."""
    for line in getattr(d, "basis_lines", []):
        console.print(f"std basis: {line}", markup=False)
    for note in getattr(d, "noise_notes", []):
        console.print(f"std basis: {note}", markup=False)
    line = getattr(d, "model_error_line", "")
    if line:
        console.print(line, markup=False)


def print_identifiability(console, d) -> None:
    """The count of active bounds (naming them) and each poorly determined parameter with its
    reason, from :class:`~femupdate.updating.Diagnostics` ``d``."""
    bounds = f" ({', '.join(f'{n} {side}' for n, side in d.at_bounds.items())})" if d.at_bounds else ""
    console.print(f"active bounds: {d.n_at_bounds} of {d.n_parameters} parameters on a bound{bounds}", markup=False)
    if d.poorly_determined:
        console.print(f"poorly determined (the data cannot move them): {len(d.poorly_determined)} of "
                      f"{d.n_parameters}", markup=False)
        for n, why in d.poorly_determined_reasons.items():
            console.print(f"  {n}: {why}", markup=False)


def fitting_table(ms, what: str = "starts") -> Table:
    """The solutions that fit the data, one column each (parameters, cost, how many starts)."""
    t = Table(title=f"{len(ms.fitting)} distinct solutions fit the data equally well (as well as the best, within "
                    "the fit's statistical spread): the data do not determine the parameters uniquely")
    t.add_column("parameter")
    for i, sol in enumerate(ms.fitting, start=1):
        t.add_column(f"solution {i} ({sol.count} {what})", justify="right")
    for n in ms.names:
        t.add_row(n, *(fmt(sol.parameters[n]) for sol in ms.fitting))
    t.add_row("cost", *(f"{sol.cost:.3g}" for sol in ms.fitting))
    return t


def print_starts(console, ms, what: str = "starts") -> None:
    """The outcome of every start: solutions that fit, local minima, failures by reason."""
    fit, local = ms.fitting, ms.local_minima
    if not ms.converged:
        console.print(f"0/{ms.total} {what} converged")
    else:
        console.print(f"{ms.converged}/{ms.total} {what} converged: {len(fit)} distinct solution(s) fit as well as "
                      f"the best (cost up to {ms.fit_cost:.3g})" + (f", {len(local)} local minima" if local else ""))
    for sol in fit[:10]:
        console.print(f"  {sol.count:4d} x  " + ", ".join(f"{k}={fmt(v)}" for k, v in sol.parameters.items())
                      + f"  (cost {sol.cost:.3g})")
    if local:
        console.print("local minima (converged, but do not fit the data as well):")
        for sol in local[:10]:
            console.print(f"  {sol.count:4d} x  " + ", ".join(f"{k}={fmt(v)}" for k, v in sol.parameters.items())
                          + f"  (cost {sol.cost:.3g})")
        if len(local) > 10:
            console.print(f"  ... and {len(local) - 10} more (see the JSON)")
    for line in distinct_lines(ms):
        console.print(line, markup=False)
    failures = ms.failures
    if failures:
        console.print(f"{sum(failures.values())} {what} without a solution:")
        for reason, count in list(failures.items())[:10]:
            console.print(f"  {count:4d} x  {reason}")


def distinct_lines(ms) -> list[str]:
    """How a multi-start study's solutions were told apart, and ill-conditioning said apart from
    non-uniqueness (``ms.distinct``, :func:`femupdate.updating.clustering.distinct_record`)."""
    from ..distinct import conditioning_line

    rec = getattr(ms, "distinct", None) or {}
    if not rec or not ms.solutions:
        return []
    basis = str(rec.get("basis"))
    how = {"statistic": f"solutions told apart at alpha = {rec['alpha']:g} against their own covariances",
           "mixed": f"solutions told apart at alpha = {rec['alpha']:g} against their covariances where they have one, "
                    "else by the relative tolerance",
           }.get(basis, "solutions told apart by the relative tolerance only: no solution has a covariance (too few "
                        "data for the residual variance and no noise stated)")
    lines = [how]
    fit = ms.fitting
    if len(fit) > 1:
        where = {id(s): i for i, s in enumerate(ms.solutions)}
        why = []
        for s in fit[1:]:
            sep = (rec.get("separations") or [None] * len(ms.solutions))[where[id(s)]]
            if sep and sep.get("basis") == "statistic":
                why.append(f"d2 {sep['statistic']:.3g} > {sep['threshold']:.3g}")
            elif sep and sep.get("basis") == "non-identifiable":
                why.append("along a direction the data do not determine")
            else:
                why.append("beyond the tolerance")
        lines.append(f"non-unique: {len(fit)} separated solutions fit the data equally well ({'; '.join(why)})")
    cond = rec.get("conditioning")
    if cond is not None:
        lines.append(("the best solution: " if len(fit) > 1 else "the solution: ") + conditioning_line(cond))
    return lines


def update_parameter_table(res, title: str, units: dict | None = None) -> Table:
    """Start, updated value, standard deviation (or the bound it sits on) and change of each
    updated parameter, with its unit (``units`` {name: unit}) when known."""
    t = Table(title=title)
    for col in ("parameter", "unit", "start", "updated", "std", "change"):
        t.add_column(col, justify="left" if col in ("parameter", "unit") else "right")
    units = units or {}
    std_p = dict(zip(res.names, res.diagnostics.std))
    at = res.diagnostics.at_bounds
    for n in res.names:
        p0, p1 = res.start[n], res.parameters[n]
        sd = f"{at[n]} bound" if n in at else "-" if not np.isfinite(std_p[n]) else fmt(std_p[n])
        t.add_row(n, units.get(n) or "-", fmt(p0), fmt(p1), sd, percent((p1 - p0) / p0, 1) if p0 else "")
    return t
