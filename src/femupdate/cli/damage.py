"""``femupdate damage``, ``update-multi`` and ``rank-modifications`` (``fullfield``: :mod:`.fullfield`).

* ``damage BASELINE DATA``: localise stiffness loss from a validated baseline (the model's stiffness
  parameters or one per element; expansion and L1 regularisation), refine the located set by
  nonlinear updating and verify it against the stated noise, with the baseline checked against
  ``--undamaged`` data;
* ``update-multi MODEL --config DATA[:MODIFICATION] ...``: one set of unknowns updated from several
  test configurations (perturbed boundary conditions), directly when every configuration's data
  are complete, iteratively otherwise;
* ``rank-modifications MODEL CANDIDATES``: pre-test ranking of candidate modifications.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from pathlib import Path

import click
import numpy as np
from rich.table import Table

from .._errors import InputError, NumericalError
from ..options import ModalOptions, PairingOptions, SolverOptions
from ._common import (INPUT_FILE, OUTPUT_FILE, SEED, Ctx, FiniteFloat, check_set, emit, flags, fmt, json_option, load_data,
                      measured_dofs_option, model_values, option_dofs, parse_regularization, parse_set, print_flags,
                      print_identifiability, report_option, set_option, write_model_option, write_model_outputs,
                      write_report_output)
from ._groups import GroupedCommand, option_group
from .outputs import Outputs, outputs_group, phased_progress
from .testpoints import TestPointsSpec, test_points_group

_path = INPUT_FILE


def _load_structure(path: Path):
    """(Structure or None, Model) of a model file; ``[matrices]`` models have no structure."""
    from ..io.model_file import load_model, read_toml
    from ..structure import Structure

    if path.suffix.lower() != ".toml":
        return None, load_model(path)
    raw = read_toml(path)
    if {"matrices", "abaqus", "nastran", "ansys"} & set(raw):
        return None, load_model(path)
    try:
        s = Structure.from_dict(raw, source=str(path))
        return s, s.build()
    except InputError as exc:
        msg = str(exc)
        raise InputError(msg if str(path) in msg else f"{path}: {msg}") from None


def _parameter_table(title, model, values, names, x, stderr) -> Table:
    """Start, identified value and standard error of each unknown."""
    t = Table(title=title)
    for col in ("parameter", "unit", "start", "identified", "std. error"):
        t.add_column(col, justify="left" if col in ("parameter", "unit") else "right")
    p0 = dict(zip(model.parameter_names, model.resolve(values)))
    unit = {p.name: p.unit or "-" for p in model.parameters}
    for n, v, se in zip(names, x, stderr):
        t.add_row(n, unit[n], fmt(p0[n]), fmt(v), "-" if not np.isfinite(se) else fmt(se))
    return t


def _names(text):
    return [p.strip() for p in text.split(",") if p.strip()] if text else None


# ---------------------------------------------------------------------------------- damage
def _pct(v) -> str:
    return "-" if v is None or not np.isfinite(v) else f"{v * 100:.1f} %"


def _rate_lines(conf) -> list[str]:
    """The simulated false-positive and detection rates of this run, with their Monte Carlo error."""
    out = []
    for key, what in (("false_positive_rate", "healthy baseline simulated with this run's sensors, modes and noise: "
                                              "some unknown reported damaged in"),
                      ("detection_rate", "located model simulated likewise: every located unknown found again in")):
        r = conf.get(key)
        if r:
            lo, hi = r["interval"]
            out.append(f"{what} {r['count']} of {r['n']} replicates ({r['rate'] * 100:.0f} % ± "
                       f"{r['standard_error'] * 100:.0f} %, {r['level'] * 100:g} % interval {lo * 100:.0f}-{hi * 100:.0f} %)")
    return out


@dataclasses.dataclass(frozen=True)
class DamageData:
    """The baseline's unknowns and the test data, as the command line gave them (:func:`_data_group`)."""

    undamaged_path: Path | None
    unknowns_kind: str
    elements_text: str | None
    measured_text: str | None


def _data_group() -> Callable:
    """``--undamaged``, ``--unknowns``, ``--elements``, ``--measured-dofs`` -> ``given``: :class:`DamageData`."""
    return option_group(
        "Data and unknowns", "given", DamageData,
        click.option("--undamaged", "undamaged_path", type=_path, default=None,
                     help="Test data of the undamaged structure: the baseline must match them first."),
        click.option("--unknowns", "unknowns_kind", type=click.Choice(["auto", "parameters", "elements"]),
                     default="auto", show_default=True,
                     help="The model's stiffness parameters as it names them, or one stiffness per element (auto: the "
                          "parameters, unless the model has fewer than two)."),
        click.option("--elements", "elements_text", default=None, help="Unknowns that may change (default all)."),
        measured_dofs_option,
    )


def _method_group() -> Callable:
    """The method's options -> ``options``: :class:`~femupdate.damage.DamageOptions`."""
    from ..damage import DamageOptions

    return option_group(
        "Damage detection", "options", lambda **kw: DamageOptions(**kw),
        click.option("--method", type=click.Choice(["l1", "tikhonov"]), default="l1", show_default=True,
                     help="Regulariser of the localisation step."),
        click.option("--alpha", type=FiniteFloat(0, 1, min_open=True), default=None,
                     help="L1 factor as a fraction of alpha_max (default: chosen by BIC)."),
        click.option("--expansion", type=click.Choice(["serep", "irs", "guyan"]), default="serep", show_default=True),
        click.option("--n-basis", type=click.IntRange(min=1), default=None,
                     help="SEREP modes (default: twice the highest paired)."),
        click.option("--allow-increase", is_flag=True, help="Let stiffness increase too."),
        click.option("--min-change", type=FiniteFloat(0, 1, min_open=True, max_open=True), default=0.05,
                     show_default=True, help="Smallest relative change reported as damage."),
        click.option("--iterations", type=click.IntRange(min=1), default=3, show_default=True,
                     help="Expansions of the localisation step (later ones with the damaged estimate)."),
        click.option("--refine/--no-refine", default=True, show_default=True,
                     help="Refine the located set by nonlinear updating and verify it against the noise (--no-refine: "
                          "the localisation step's answer alone, unverified)."),
        click.option("--level", type=FiniteFloat(0.5, 1, min_open=True, max_open=True), default=0.99,
                     show_default=True, help="Confidence level of the verification (chi-square test of the misfit)."),
        click.option("--max-located", type=click.IntRange(min=1), default=None,
                     help="Largest set of damaged unknowns tried (default 8)."),
        click.option("--bootstrap", type=click.IntRange(min=0), default=20, show_default=True,
                     help="Replicates for the confidence, each re-localised, refined and verified."),
        click.option("--seed", type=SEED, default=0, show_default=True),
        click.option("--max-frequency-error", type=FiniteFloat(min=0), default=0.02, show_default=True,
                     help="Baseline check: largest frequency error against --undamaged."),
        click.option("--min-mac", type=FiniteFloat(0, 1), default=0.9, show_default=True,
                     help="Baseline check: smallest MAC."),
        click.option("--baseline-checked", is_flag=True,
                     help="The baseline was checked against the undamaged structure (e.g. updated against its data); "
                          "without it or --undamaged a located set is never confirmed."),
        click.option("--localise-min-mac", type=FiniteFloat(0, 1), default=0.8, show_default=True,
                     help="A damaged mode pairing with no baseline mode this well stops the localisation."),
    )


def _noise_group() -> Callable:
    """``--noise-frequency``, ``--noise-shape`` -> ``noise``: the stated noise, as
    :func:`~femupdate.damage.detect_damage` takes it."""
    def build(noise_frequency, noise_shape):
        return ({"frequency": noise_frequency} if noise_frequency is not None else {}) \
            | ({"shape": noise_shape} if noise_shape is not None else {})

    return option_group(
        "Stated noise", "noise", build,
        click.option("--noise-frequency", type=FiniteFloat(min=0, max=1), default=None,
                     help="Relative frequency noise (0: noise-free data; default: the test data's std_frequency, "
                          "else 0.001, said to be assumed)."),
        click.option("--noise-shape", type=FiniteFloat(min=0, max=1), default=None,
                     help="Shape noise relative to each shape's largest value (default: from the expansion misfit)."),
    )


#: the phases of damage detection, as its progress shows them
_PHASES = {"refine": "refining and verifying", "bootstrap": "bootstrap replicates",
           "healthy": "replicates of the healthy baseline"}


@click.command(cls=GroupedCommand)
@click.argument("baseline_path", metavar="BASELINE_MODEL", type=_path)
@click.argument("data_path", metavar="DATA", type=_path)
@_data_group()
@_method_group()
@_noise_group()
@test_points_group()
@outputs_group(report=True)
def damage(baseline_path, data_path, given: DamageData, options, noise, test_points: TestPointsSpec, outputs: Outputs):
    """Localise, refine and verify damage in DATA from the validated BASELINE_MODEL."""
    from ..damage import detect_damage

    ctx = Ctx(outputs.json_path)
    structure, du = _damage_model(baseline_path, given.unknowns_kind, outputs.set_text)
    mapped = None
    if test_points.tolerance is None:
        data = load_data(data_path, du.model, given.measured_text)
        undamaged = (load_data(given.undamaged_path, du.model, given.measured_text)
                     if given.undamaged_path is not None else None)
    else:  # test nodes placed on the baseline's mesh; the unknowns' model in the coordinates that hold them
        mapped = test_points.place(structure, du.model, *test_points.read(data_path, given.measured_text), data_path,
                                   baseline_path)
        test_points.announce(ctx, mapped)
        du, data = dataclasses.replace(du, model=mapped.model), mapped.data
        undamaged = None if given.undamaged_path is None else test_points.relabel(
            mapped, test_points.read(given.undamaged_path, given.measured_text), given.undamaged_path)
    with phased_progress(_PHASES, console=ctx.console, quiet=outputs.json_path == "-") as tick:
        res = detect_damage(du, data, undamaged=undamaged, elements=_names(given.elements_text), noise=noise,
                            options=options, progress=tick)
    payload = res.to_json()
    if mapped is not None:
        payload["test_points"] = mapped.to_json()
    ctx.console.print(payload["headline"], markup=False)
    _print_damage(ctx.console, res, du.model, data, du.kind, options.min_change)
    for n in payload["notes"]:
        ctx.console.print(f"note: {n}", markup=False)
    outputs.emit(ctx, payload)
    if outputs.report_path is not None:
        from ..fullfield import structure_segments

        write_report_output(ctx, outputs.report_path, res,
                            segments=structure_segments(structure) if structure is not None else None,
                            test_points=mapped)
    if res.status == "doubtful":
        click.echo("warning: the location is doubtful: " + "; ".join(res.doubts), err=True)
    if not res.localised:
        raise NumericalError(f"damage not localised: {res.reason}")


def _damage_model(path: Path, unknowns_kind: str, set_text):
    """(structure or None, the :class:`~femupdate.damage.DamageUnknowns`) of the baseline file."""
    from ..damage import DamageUnknowns, damage_unknowns

    structure, model = _load_structure(path)
    if structure is not None:
        values = parse_set(set_text)
        check_set(model, values)
        return structure, damage_unknowns(structure, values, unknowns_kind)
    values = model_values(model, set_text)
    model = model.with_values(values) if values is not None else model
    if unknowns_kind == "elements":
        raise InputError(f"{path}: a [matrices] model has no elements; its parameters are the unknowns "
                         "(--unknowns parameters)")
    return None, DamageUnknowns(model, "parameters", [model.parameter_names[j] for j in model.free], {},
                                ["matrix model: its parameters are the unknowns"])


def _located_table(res) -> Table:
    """The located unknowns: change, standard error, evidence and share of the replicates."""
    confirmed = res.status == "confirmed"
    head = {"confirmed": "located and verified", "doubtful": "located, DOUBTFUL",
            "unverified": "located, NOT verified (--no-refine)"}[res.status]
    t = Table(title=f"{head} (localisation {res.method}, alpha {res.alpha:.3g})")
    cols = ["unknown", "what", "change", "std. error", "misfit without it", "selected in replicates"]
    for col in cols:
        t.add_column(col, justify="left" if col in ("unknown", "what") else "right")
    sel = res.confidence.get("selection_frequency", {})
    se = res.confidence.get("standard_error", {})
    ev = res.confidence.get("evidence", {})
    for n in res.located:
        t.add_row(n, res.descriptions.get(n, ""), f"{res.changes[n] * 100:+.1f} %", _pct(se.get(n)),
                  "-" if n not in ev else f"{ev[n]:.3g}",
                  f"{sel[n] * 100:.0f} %" if confirmed and n in sel and np.isfinite(sel[n]) else "-")
    return t


def _print_located(c, res, min_change: float) -> None:
    """The located set, its verification, bootstrap, doubts and the Tikhonov comparison."""
    if res.located:
        c.print(_located_table(res))
    else:
        c.print("no unknown changed by more than the threshold")
    v = res.verification
    if v:
        c.print(f"verification: chi-square {v['chi2']:.4g} for a limit of {v['limit']:.4g} ({v['dof']} degrees of "
                f"freedom, level {v['level']:g}; noise: frequency {v['noise']['frequency']:g}, shape "
                f"{v['noise']['shape']:g}): the located set reproduces the data"
                + ("" if res.located else " (the baseline does)"))
    if res.status == "confirmed" and res.confidence.get("bootstrap"):
        c.print(f"bootstrap: {res.confidence['bootstrap']} replicates simulated from the identified model, each "
                f"re-localised, refined and verified: {res.confidence['same_set'] * 100:.0f} % locate exactly this set")
    if res.status == "unverified":
        c.print("warning: not verified: the localisation step's answer was not checked against the data "
                "(--no-refine); its bootstrap varies the noise only", markup=False)
    for d in res.doubts:
        c.print(f"warning: doubtful: {d}", markup=False)
    noise = res.confidence.get("noise") or {}
    basis = noise.get("basis") or {}
    if basis:
        c.print(f"noise: frequency {noise.get('frequency', float('nan')):.3g} ({basis.get('frequency')}), shape "
                f"{noise.get('shape_verify', noise.get('shape', float('nan'))):.3g} ({basis.get('shape')})", markup=False)
    if res.tikhonov:
        c.print(f"Tikhonov (GCV) for comparison changes {res.tikhonov['n_above_threshold']} unknown(s) by more than "
                f"{min_change * 100:g} %")


def _print_damage(c, res, model, data, kind: str, min_change: float) -> None:
    """The pairing with the baseline, then the located set (or why there is none) and the benchmark's rate."""
    what = "element stiffnesses" if kind == "elements" else "stiffness parameters"
    t = Table(title=f"{model.name}: {len(res.changes)} {what}, {len(data.modes)} measured modes")
    flagged = {f["test_mode"]: f["why"] for f in (res.pairing or {}).get("flagged", [])}
    for col in ("test mode", "baseline mode", "MAC", "frequency change") + (("pair to doubt",) if flagged else ()):
        t.add_column(col, justify="left" if col == "pair to doubt" else "right")
    for (k, j, m), fc in zip(res.pairs, res.frequency_change):
        t.add_row(str(k + 1), str(j + 1), f"{m:.3f}", f"{fc * 100:+.2f} %", *((flagged.get(k + 1, ""),) if flagged else ()))
    c.print(t)
    if res.localised:
        _print_located(c, res, min_change)
    else:
        c.print(f"[bold]not localised[/bold]: {res.reason}")
    for line in _rate_lines(res.confidence):
        c.print(line, markup=False)


# ---------------------------------------------------------------------------------- update-multi
@dataclasses.dataclass(frozen=True)
class Unknowns:
    """The unknowns and the kind of data used (``--params``, ``--eigenvalues-only``)."""

    params_text: str | None
    eigenvalues_only: bool

    @property
    def names(self) -> list[str] | None:
        return _names(self.params_text)


_PARAMS = click.option("--params", "params_text", default=None, help="Parameters to identify (default: all not fixed).")


def _iterative_group() -> Callable:
    """The iterative solution's options -> ``iterative``: {``modal``, ``pairing``, ``solver``} option
    objects (:func:`~femupdate.updating.multiconfig.update_configurations`)."""
    def build(shape_scaling, min_mac, pairing, max_nfev, reg_text):
        return {"modal": ModalOptions(shape_scaling=shape_scaling), "pairing": PairingOptions(rule=pairing, min_mac=min_mac),
                "solver": SolverOptions(max_nfev=max_nfev, regularization=parse_regularization(reg_text))}

    return option_group(
        "Iterative solution", "iterative", build,
        click.option("--shape-scaling", type=click.Choice(["unit", "ref", "max"]), default="unit", show_default=True),
        click.option("--min-mac", type=FiniteFloat(0, 1), default=0.5, show_default=True),
        click.option("--pairing", type=click.Choice(["auto", "mac", "order", "frequency"]), default="auto",
                     show_default=True, help="How test modes pair with model modes (iterative), as in update."),
        click.option("--max-nfev", type=click.IntRange(min=1), default=200, show_default=True),
        click.option("--regularization", "reg_text", default=None, help="Tikhonov factor, or gcv / lcurve (iterative)."),
    )


@click.command("update-multi", cls=GroupedCommand)
@click.argument("model_path", metavar="MODEL", type=_path)
@option_group(
    "Configurations and unknowns", "configs", lambda configs: configs,
    click.option("--config", "configs", multiple=True, required=True, metavar="DATA[:MODIFICATION]",
                 help="One test configuration: its data, and the file of its known modification (TOML/JSON; none: "
                      "the unmodified structure). Repeat for each configuration."))
@option_group(
    "Configurations and unknowns", "unknowns", Unknowns, _PARAMS,
    click.option("--eigenvalues-only", is_flag=True, help="Ignore the measured shapes (iterative)."))
@option_group(
    "Solution", "solution", lambda method, bounded: (method, bounded),
    click.option("--method", type=click.Choice(["auto", "direct", "iterative"]), default="auto", show_default=True,
                 help="auto: direct when every configuration's data are complete."),
    click.option("--bounded", is_flag=True, help="Honour parameter bounds (direct)."))
@_iterative_group()
@option_group("Model values and outputs", "outputs", lambda **kw: Outputs(**kw), write_model_option, report_option,
              set_option, json_option)
def update_multi(model_path, configs, unknowns: Unknowns, solution, iterative, outputs: Outputs):
    """Update MODEL from several test configurations with known modifications (perturbed boundaries)."""
    from ..updating.multiconfig import solve_configurations
    from ..io.model_file import load_model

    ctx = Ctx(outputs.json_path)
    model = load_model(model_path)
    values = model_values(model, outputs.set_text)
    cfgs = _configurations(model, configs)
    method, bounded = solution
    modal = iterative["modal"].replace(use_shapes=not unknowns.eigenvalues_only)
    res = solve_configurations(model, cfgs, method, unknowns=unknowns.names, values=values, bounded=bounded,
                               **{**iterative, "modal": modal})
    payload = res.to_json()
    _print_multi(ctx, model, values, res, len(cfgs))
    print_flags(ctx, payload["flags"])
    outputs.emit(ctx, payload)
    write_report_output(ctx, outputs.report_path, res, model_path=model_path)
    if not res.success:
        if outputs.write_model_path:
            ctx.console.print("not written: the updated model (the multi-configuration update did not succeed)")
        raise NumericalError(f"the multi-configuration update did not succeed: {res.message}")
    write_model_outputs(ctx, model_path, ",".join(configs), "update-multi", model, res.parameters, list(res.names),
                        res.cost if res.method == "iterative" else None, outputs.write_model_path)


def _configurations(model, configs) -> list:
    """The configurations of ``--config DATA[:MODIFICATION]``: each modification applied to the
    model, its data read for the modified model (``#N`` counting the baseline model's dofs)."""
    from ..io.testdata_json import load_testdata
    from ..updating.multiconfig import Configuration, Modification, configure
    from ..updating.multiconfig.files import load_modification, split_config_spec

    cfgs = []
    for spec in configs:
        dpath, mpath = split_config_spec(spec)
        mod = load_modification(mpath) if mpath is not None else Modification(name=dpath.stem)
        cm = configure(model, mod).model
        data = load_testdata(dpath, cm, numbering=model.dofs)  # "#N" counts in the baseline model's dofs
        cfgs.append(Configuration(data, mod, name=mod.name if mpath is not None else dpath.stem))
    return cfgs


def _print_multi(ctx: Ctx, model, values, res, n_configs: int) -> None:
    """The unknowns, the conditioning as configurations are added, convergence and notes."""
    c = ctx.console
    c.print(_parameter_table(f"{model.name}: {res.method} update from {n_configs} configurations", model, values,
                             res.names, res.x, res.standard_error))
    t = Table(title="conditioning (column-scaled / normalised)")
    for col in ("configurations", "rank", "condition number", "smallest singular value"):
        t.add_column(col, justify="left" if col == "configurations" else "right")
    for row in res.conditioning["cumulative"]:
        t.add_row(" + ".join(row["configurations"]), f"{row['rank']}/{len(res.names)}", f"{row['condition_number']:.4g}",
                  f"{row['min_singular']:.4g}")
    c.print(t)
    c.print(f"{'converged' if res.success else 'NOT converged'}: {res.message}")
    if res.diagnostics is not None:
        print_identifiability(c, res.diagnostics)
    for note in res.notes:
        c.print(f"note: {note}", markup=False)


# ---------------------------------------------------------------------------------- rank-modifications
@click.command("rank-modifications", cls=GroupedCommand)
@click.argument("model_path", metavar="MODEL", type=_path)
@click.argument("candidates_path", metavar="CANDIDATES", type=_path)
@option_group(
    "The planned test", "plan", lambda dofs_text, n_modes: (dofs_text, n_modes),
    click.option("--measured-dofs", "dofs_text", required=True,
                 help="The planned sensors, labels or #N (the N-th model dof), e.g. \"1:x,2:x\"."),
    click.option("--modes", "n_modes", type=click.IntRange(min=1), required=True,
                 help="Modes measured in each configuration."))
@option_group(
    "Ranking", "ranking", lambda criterion, select: {"criterion": criterion, "select": select},
    click.option("--criterion", type=click.Choice(["condition", "logdet", "min_singular"]), default="condition",
                 show_default=True),
    click.option("--select", type=click.IntRange(min=1), default=None, help="Choose this many candidates greedily."))
@option_group(
    "The planned test", "unknowns", Unknowns, click.option("--params", "params_text", default=None,
                                                            help="The unknowns (default: all not fixed)."),
    click.option("--eigenvalues-only", is_flag=True, help="Plan for frequencies only."))
@option_group("Model values and outputs", "outputs", lambda **kw: Outputs(**kw), set_option, json_option)
def rank_modifications(model_path, candidates_path, plan, ranking, unknowns: Unknowns, outputs: Outputs):
    """Rank CANDIDATES (modifications) by the new, independent information each adds to MODEL's test."""
    from ..updating.multiconfig import rank_modifications as _rank
    from ..updating.multiconfig.files import load_candidates
    from ..io.model_file import load_model

    ctx = Ctx(outputs.json_path)
    model = load_model(model_path)
    values = model_values(model, outputs.set_text)
    cands = load_candidates(candidates_path)
    dofs_text, n_modes = plan
    sensors = list(option_dofs(_names(dofs_text) or [], model, "--measured-dofs"))
    res = _rank(model, cands, sensors, n_modes, params=unknowns.names, values=values,
                use_shapes=not unknowns.eigenvalues_only, **ranking)
    t = Table(title=f"{model.name}: candidates ranked by {res.criterion} (baseline: condition "
                    f"{res.baseline['condition_number']:.4g}, rank {res.baseline['rank']}/{len(res.unknowns)})")
    for col in ("rank", "candidate", "gain", "condition number", "smallest s.v.", "largest freq. shift"):
        t.add_column(col, justify="left" if col == "candidate" else "right")
    for k, row in enumerate(res.candidates, start=1):
        t.add_row(str(k), row["name"], f"{row['gain']:.4g}", f"{row['condition_number']:.4g}", f"{row['min_singular']:.4g}",
                  f"{row['frequency_shift'] * 100:.1f} %")
    ctx.console.print(t)
    if res.selected:
        ctx.console.print("greedy selection: " + " -> ".join(res.selected))
    outputs.emit(ctx, res.to_json())
