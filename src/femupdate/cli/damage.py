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

from pathlib import Path

import click
import numpy as np
from rich.table import Table

from .._errors import InputError, NumericalError
from ._common import (INPUT_FILE, OUTPUT_FILE, SEED, Ctx, FiniteFloat, check_set, diagnostics_extra, emit, flags, parameter_fields,
                      print_flags,
                      print_identifiability, fmt, json_option, model_values, option_dofs,
                      parse_regularization, parse_set, set_option, data_fields, load_data, measured_dofs_option,
                      write_model_option, write_model_outputs, report_option, write_report_output)

_path = INPUT_FILE


def _load_structure(path: Path):
    """(Structure or None, Model) of a model file; ``[matrices]`` models have no structure."""
    from ..io.model_file import load_model, read_toml
    from ..structure import Structure

    if path.suffix.lower() != ".toml":
        return None, load_model(path)
    raw = read_toml(path)
    if "matrices" in raw:
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


def _fp_line(rate) -> str:
    """The benchmark's false-positive rate for comparable scenarios, as one line."""
    bins = []
    if rate.get("sensor_fraction"):
        lo, hi = rate["sensor_fraction"]
        bins.append(f"sensors on {lo * 100:.0f}-{min(hi, 1) * 100:.0f} % of the dofs")
    if rate.get("modes"):
        lo, hi = rate["modes"]
        bins.append(f"{lo}-{hi - 1} modes")
    return (f"benchmark: a healthy unknown was reported damaged in {rate['false_positives']} of {rate['scenarios']} "
            f"comparable scenarios ({rate['false_positive_rate'] * 100:.0f} %; every damaged one found in "
            f"{rate['detection_rate'] * 100:.0f} %) at {rate['noise'] * 100:g} % noise"
            + (f", {', '.join(bins)}" if bins else "") + f" (bench_damage.py, {rate['date']})")


@click.command()
@click.argument("baseline_path", metavar="BASELINE_MODEL", type=_path)
@click.argument("data_path", metavar="DATA", type=_path)
@click.option("--undamaged", "undamaged_path", type=_path, default=None,
              help="Test data of the undamaged structure: the baseline must match them first.")
@click.option("--unknowns", "unknowns_kind", type=click.Choice(["auto", "parameters", "elements"]), default="auto",
              show_default=True,
              help="The model's stiffness parameters as it names them, or one stiffness per element (auto: the "
                   "parameters, unless the model has fewer than two).")
@click.option("--elements", "elements_text", default=None, help="Unknowns that may change (default all).")
@click.option("--method", type=click.Choice(["l1", "tikhonov"]), default="l1", show_default=True,
              help="Regulariser of the localisation step.")
@click.option("--alpha", type=FiniteFloat(0, 1, min_open=True), default=None,
              help="L1 factor as a fraction of alpha_max (default: chosen by BIC).")
@click.option("--expansion", type=click.Choice(["serep", "irs", "guyan"]), default="serep", show_default=True)
@click.option("--n-basis", type=click.IntRange(min=1), default=None, help="SEREP modes (default: twice the highest paired).")
@click.option("--allow-increase", is_flag=True, help="Let stiffness increase too.")
@click.option("--min-change", type=FiniteFloat(0, 1, min_open=True, max_open=True), default=0.05, show_default=True,
              help="Smallest relative change reported as damage.")
@click.option("--iterations", type=click.IntRange(min=1), default=3, show_default=True,
              help="Expansions of the localisation step (later ones with the damaged estimate).")
@click.option("--refine/--no-refine", default=True, show_default=True,
              help="Refine the located set by nonlinear updating and verify it against the noise (--no-refine: the "
                   "localisation step's answer alone, unverified).")
@click.option("--level", type=FiniteFloat(0.5, 1, min_open=True, max_open=True), default=0.99, show_default=True,
              help="Confidence level of the verification (chi-square test of the misfit).")
@click.option("--max-located", type=click.IntRange(min=1), default=None,
              help="Largest set of damaged unknowns tried (default 8).")
@click.option("--bootstrap", type=click.IntRange(min=0), default=20, show_default=True,
              help="Replicates for the confidence, each re-localised, refined and verified.")
@click.option("--noise-frequency", type=FiniteFloat(min=0, max=1), default=0.001, show_default=True,
              help="Relative frequency noise (0: noise-free data).")
@click.option("--noise-shape", type=FiniteFloat(min=0, max=1), default=None,
              help="Shape noise relative to each shape's largest value (default: from the expansion misfit).")
@click.option("--seed", type=SEED, default=0, show_default=True)
@click.option("--max-frequency-error", type=FiniteFloat(min=0), default=0.02, show_default=True,
              help="Baseline check: largest frequency error against --undamaged.")
@click.option("--min-mac", type=FiniteFloat(0, 1), default=0.9, show_default=True, help="Baseline check: smallest MAC.")
@click.option("--localise-min-mac", type=FiniteFloat(0, 1), default=0.8, show_default=True,
              help="A damaged mode pairing with no baseline mode this well stops the localisation.")
@measured_dofs_option
@report_option
@set_option
@json_option
def damage(baseline_path, data_path, undamaged_path, unknowns_kind, elements_text, method, alpha, expansion, n_basis,
           allow_increase, min_change, iterations, refine, level, max_located, bootstrap, noise_frequency, noise_shape,
           seed, max_frequency_error, min_mac, localise_min_mac, measured_text, report_path, set_text, json_path):
    """Localise, refine and verify damage in DATA from the validated BASELINE_MODEL."""
    from ..damage import DamageOptions, detect_damage

    ctx = Ctx(json_path)
    structure, model, kind, descriptions, notes = _damage_model(baseline_path, unknowns_kind, set_text)
    data = load_data(data_path, model, measured_text)
    undamaged = load_data(undamaged_path, model, measured_text) if undamaged_path is not None else None
    notes = [*data.notes, *(undamaged.notes if undamaged is not None else ()), *notes]
    if undamaged is None:
        notes.append("no --undamaged data: the baseline was not checked against the undamaged structure")
    options = DamageOptions(method=method, alpha=alpha, expansion=expansion, n_basis=n_basis,
                            allow_increase=allow_increase, min_change=min_change, iterations=iterations,
                            bootstrap=bootstrap, seed=seed, localise_min_mac=localise_min_mac,
                            max_frequency_error=max_frequency_error, min_mac=min_mac, refine=refine, level=level,
                            max_located=max_located)
    noise = {"frequency": noise_frequency} | ({"shape": noise_shape} if noise_shape is not None else {})
    res = detect_damage(model, data, undamaged=undamaged, elements=_names(elements_text), noise=noise,
                        descriptions=descriptions, options=options)
    _print_damage(ctx.console, res, model, data, kind, options.min_change)
    for n in notes + res.notes:
        ctx.console.print(f"note: {n}", markup=False)
    payload = _damage_payload(model, data, res, kind, notes)
    emit(ctx, payload)
    if report_path is not None:
        from ..fullfield import structure_segments

        write_report_output(ctx, report_path, payload, model=model, data=data, kind="damage",
                            segments=structure_segments(structure) if structure is not None else None)
    if res.status == "doubtful":
        click.echo("warning: the location is doubtful: " + "; ".join(res.doubts), err=True)
    if not res.localised:
        raise NumericalError(f"damage not localised: {res.reason}")


def _damage_model(path: Path, unknowns_kind: str, set_text):
    """(structure or None, model, kind of unknowns, their descriptions, notes) of the baseline file."""
    from ..damage import damage_unknowns

    structure, model = _load_structure(path)
    if structure is not None:
        values = parse_set(set_text)
        check_set(model, values)
        du = damage_unknowns(structure, values, unknowns_kind)
        return structure, du.model, du.kind, du.descriptions, list(du.notes)
    values = model_values(model, set_text)
    model = model.with_values(values) if values is not None else model
    if unknowns_kind == "elements":
        raise InputError(f"{path}: a [matrices] model has no elements; its parameters are the unknowns "
                         "(--unknowns parameters)")
    return None, model, "parameters", {}, ["matrix model: its parameters are the unknowns"]


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
    if res.tikhonov:
        c.print(f"Tikhonov (GCV) for comparison changes {res.tikhonov['n_above_threshold']} unknown(s) by more than "
                f"{min_change * 100:g} %")


def _print_damage(c, res, model, data, kind: str, min_change: float) -> None:
    """The pairing with the baseline, then the located set (or why there is none) and the benchmark's rate."""
    what = "element stiffnesses" if kind == "elements" else "stiffness parameters"
    t = Table(title=f"{model.name}: {len(res.changes)} {what}, {len(data.modes)} measured modes")
    for col in ("test mode", "baseline mode", "MAC", "frequency change"):
        t.add_column(col, justify="right")
    for (k, j, m), fc in zip(res.pairs, res.frequency_change):
        t.add_row(str(k + 1), str(j + 1), f"{m:.3f}", f"{fc * 100:+.2f} %")
    c.print(t)
    if res.localised:
        _print_located(c, res, min_change)
    else:
        c.print(f"[bold]not localised[/bold]: {res.reason}")
    rate = res.confidence.get("false_positive_rate")
    if rate:
        c.print(_fp_line(rate), markup=False)


def _damage_payload(model, data, res, kind: str, notes: list[str]) -> dict:
    return {
        "model": model.name, "parameters": res.parameters, "baseline": res.baseline, "changes": res.changes,
        "located": res.located, "loss": res.loss, "confidence": res.confidence, "localised": res.localised,
        "reason": res.reason, "detected": res.detected, "method": res.method, "alpha": res.alpha,
        "alpha_max": res.alpha_max, "tikhonov": res.tikhonov, "expansion": res.expansion,
        "pairs": [list(p) for p in res.pairs], "frequency_change": res.frequency_change,
        "baseline_check": res.baseline_check, "path": res.path, "notes": notes + res.notes, **data_fields(data),
        "status": res.status, "doubts": res.doubts, "verification": res.verification,
        "localisation": res.localisation, "unknowns": kind, "descriptions": res.descriptions,
        **parameter_fields(model, list(res.changes)),
    }


# ---------------------------------------------------------------------------------- update-multi
def _multi_payload(model, res) -> dict:
    d = res.diagnostics
    return {
        "model": model.name, "method": res.method, "parameters": res.parameters, "updated": list(res.names),
        "success": res.success, "message": res.message, "cost": res.cost, "iterations": res.iterations,
        "nfev": res.nfev, "standard_error": dict(zip(res.names, res.standard_error)),
        "configurations": res.configurations, "conditioning": res.conditioning, "history": res.history,
        "regularization": res.regularization, "notes": res.notes,
        "flags": flags(model, res.parameters, res.names),
        **parameter_fields(model),
        "direct": None if res.direct is None else {
            "condition_number": res.direct.condition_number, "condition_number_scaled": res.direct.condition_number_scaled,
            "residual_norm": res.direct.residual_norm, "relative_residual": res.direct.relative_residual,
            "rank": res.direct.rank, "unique": res.direct.unique, "n_equations": res.direct.system.n_equations},
        "diagnostics": None if d is None else {
            "singular_values": d.singular_values, "condition_number": d.condition_number, "rank": d.rank,
            "poorly_determined": d.poorly_determined, "std": dict(zip(res.names, d.std)),
            **diagnostics_extra(res.names, d)},
    }


@click.command("update-multi")
@click.argument("model_path", metavar="MODEL", type=_path)
@click.option("--config", "configs", multiple=True, required=True, metavar="DATA[:MODIFICATION]",
              help="One test configuration: its data, and the file of its known modification (TOML/JSON; none: the "
                   "unmodified structure). Repeat for each configuration.")
@click.option("--method", type=click.Choice(["auto", "direct", "iterative"]), default="auto", show_default=True,
              help="auto: direct when every configuration's data are complete.")
@click.option("--params", "params_text", default=None, help="Parameters to identify (default: all not fixed).")
@click.option("--shape-scaling", type=click.Choice(["unit", "ref", "max"]), default="unit", show_default=True)
@click.option("--min-mac", type=FiniteFloat(0, 1), default=0.5, show_default=True)
@click.option("--pairing", type=click.Choice(["auto", "mac", "order", "frequency"]), default="auto", show_default=True,
              help="How test modes pair with model modes (iterative), as in update.")
@click.option("--max-nfev", type=click.IntRange(min=1), default=200, show_default=True)
@click.option("--regularization", "reg_text", default=None, help="Tikhonov factor, or gcv / lcurve (iterative).")
@click.option("--eigenvalues-only", is_flag=True, help="Ignore the measured shapes (iterative).")
@click.option("--bounded", is_flag=True, help="Honour parameter bounds (direct).")
@write_model_option
@report_option
@set_option
@json_option
def update_multi(model_path, configs, method, params_text, shape_scaling, min_mac, pairing, max_nfev, reg_text, eigenvalues_only,
                 bounded, write_model_path, report_path, set_text, json_path):
    """Update MODEL from several test configurations with known modifications (perturbed boundaries)."""
    from ..updating.multiconfig import Configuration, Modification, configure, solve_configurations
    from ..updating.multiconfig.files import load_modification, split_config_spec
    from ..io.model_file import load_model
    from ..io.testdata_json import load_testdata

    ctx = Ctx(json_path)
    model = load_model(model_path)
    values = model_values(model, set_text)
    cfgs = []
    for spec in configs:
        dpath, mpath = split_config_spec(spec)
        mod = load_modification(mpath) if mpath is not None else Modification(name=dpath.stem)
        cm = configure(model, mod).model
        data = load_testdata(dpath, cm, numbering=model.dofs)  # "#N" counts in the baseline model's dofs
        cfgs.append(Configuration(data, mod, name=mod.name if mpath is not None else dpath.stem))
    res = solve_configurations(model, cfgs, method, unknowns=_names(params_text), values=values, bounded=bounded,
                               shape_scaling=shape_scaling, min_mac=min_mac, pairing=pairing, max_nfev=max_nfev,
                               regularization=parse_regularization(reg_text), use_shapes=not eigenvalues_only)
    c = ctx.console
    c.print(_parameter_table(f"{model.name}: {res.method} update from {len(cfgs)} configurations", model, values,
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
    payload = _multi_payload(model, res)
    print_flags(ctx, payload["flags"])
    emit(ctx, payload)
    write_report_output(ctx, report_path, payload, model=model, model_path=model_path, kind="update-multi")
    if not res.success:
        if write_model_path:
            c.print("not written: the updated model (the multi-configuration update did not succeed)")
        raise NumericalError(f"the multi-configuration update did not succeed: {res.message}")
    write_model_outputs(ctx, model_path, ",".join(configs), "update-multi", model, res.parameters, list(res.names),
                        res.cost if res.method == "iterative" else None, write_model_path)


# ---------------------------------------------------------------------------------- rank-modifications
@click.command("rank-modifications")
@click.argument("model_path", metavar="MODEL", type=_path)
@click.argument("candidates_path", metavar="CANDIDATES", type=_path)
@click.option("--measured-dofs", "dofs_text", required=True,
              help="The planned sensors, labels or #N (the N-th model dof), e.g. \"1:x,2:x\".")
@click.option("--modes", "n_modes", type=click.IntRange(min=1), required=True, help="Modes measured in each configuration.")
@click.option("--criterion", type=click.Choice(["condition", "logdet", "min_singular"]), default="condition", show_default=True)
@click.option("--select", type=click.IntRange(min=1), default=None, help="Choose this many candidates greedily.")
@click.option("--params", "params_text", default=None, help="The unknowns (default: all not fixed).")
@click.option("--eigenvalues-only", is_flag=True, help="Plan for frequencies only.")
@set_option
@json_option
def rank_modifications(model_path, candidates_path, dofs_text, n_modes, criterion, select, params_text, eigenvalues_only,
                       set_text, json_path):
    """Rank CANDIDATES (modifications) by the new, independent information each adds to MODEL's test."""
    from ..updating.multiconfig import rank_modifications as _rank
    from ..updating.multiconfig.files import load_candidates
    from ..io.model_file import load_model

    ctx = Ctx(json_path)
    model = load_model(model_path)
    values = model_values(model, set_text)
    cands = load_candidates(candidates_path)
    sensors = list(option_dofs(_names(dofs_text) or [], model, "--measured-dofs"))
    res = _rank(model, cands, sensors, n_modes, params=_names(params_text), values=values,
                criterion=criterion, select=select, use_shapes=not eigenvalues_only)
    t = Table(title=f"{model.name}: candidates ranked by {criterion} (baseline: condition {res.baseline['condition_number']:.4g}, "
                    f"rank {res.baseline['rank']}/{len(res.unknowns)})")
    for col in ("rank", "candidate", "gain", "condition number", "smallest s.v.", "largest freq. shift"):
        t.add_column(col, justify="left" if col == "candidate" else "right")
    for k, row in enumerate(res.candidates, start=1):
        t.add_row(str(k), row["name"], f"{row['gain']:.4g}", f"{row['condition_number']:.4g}", f"{row['min_singular']:.4g}",
                  f"{row['frequency_shift'] * 100:.1f} %")
    ctx.console.print(t)
    if res.selected:
        ctx.console.print("greedy selection: " + " -> ".join(res.selected))
    emit(ctx, {"model": model.name, "criterion": res.criterion, "unknowns": list(res.unknowns), "baseline": res.baseline,
                "candidates": res.candidates, "selected": res.selected})
