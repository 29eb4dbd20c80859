"""FRF commands: ``femupdate frf`` (simulate), ``frf-update`` (iterative / multi-start / global
updating from FRFs), ``frf-select`` (choose spectral lines) and ``surface`` (residual surfaces)."""

from __future__ import annotations

from contextlib import nullcontext
from pathlib import Path

import click
import numpy as np
from rich.table import Table

from .._budget import LINE_BYTES, check_count
from .._errors import InputError, NumericalError
from .._limits import MAX_MAGNITUDE
from ..updating.run import DEFAULT_RESIDUAL, FRF_RESIDUALS
from ._common import (SCHEDULER, OUTPUT_DIR, OUTPUT_FIGURE, OUTPUT_FILE, SEED, Ctx, FiniteFloat, check_set, connect_timeout_option, fitting_table, option_dofs,
                      print_starts, starts_payload, emit, print_diagnostics, print_flags, csv_option, write_model_option, write_model_outputs, fmt, json_option, model_values, parse_regularization,
                      parse_set, set_option,
                      update_parameter_table, update_payload, data_fields, report_option, write_report_output)


def parse_omega(text: str, what: str = "--omega") -> np.ndarray:
    """``"0.5,1,1.5"`` or ``"START:STOP:N"`` (N lines, ends included) -> rad/s."""
    text = (text or "").strip()
    if not text:
        raise InputError(f"{what}: no frequencies given")
    if text.count(":") == 2 and "," not in text:
        sa, sb, sn = text.split(":")
        try:
            a, b, n = float(sa), float(sb), int(sn)
        except ValueError:
            raise InputError(f"{what}: {text!r} is not START:STOP:N (numbers, N an integer)") from None
        if n < 1 or not (np.isfinite(a) and np.isfinite(b)):
            raise InputError(f"{what}: {text!r}: need finite ends and N >= 1")
        if max(abs(a), abs(b)) > MAX_MAGNITUDE:
            raise InputError(f"{what}: {text!r}: values must be at most {MAX_MAGNITUDE:g} in magnitude")
        check_count(f"{what} {text}: N", n, LINE_BYTES, "the lines and their responses")
        return np.linspace(a, b, n)
    out = []
    for item in text.split(","):
        item = item.strip()
        try:
            out.append(float(item))
        except ValueError:
            raise InputError(f"{what}: {item!r} is not a number (give a list 0.5,1,1.5 or START:STOP:N)") from None
        if not np.isfinite(out[-1]) or abs(out[-1]) > MAX_MAGNITUDE:
            raise InputError(f"{what}: {item!r} is not a finite number of at most {MAX_MAGNITUDE:g} in magnitude")
    return np.array(out)


def parse_force(text: str, model=None) -> dict:
    """``"2:x"`` (unit force) or ``"2:x=1.5,1:x=-0.5"`` -> {dof: amplitude}; with the ``model``, a
    dof may be ``#N`` (the N-th model dof) and the keys are canonical labels."""
    out = {}
    for item in (text or "").split(","):
        item = item.strip()
        if not item:
            continue
        dof, eq, amp = item.partition("=")
        if dof.strip() in out:
            raise InputError(f"--force: {dof.strip()!r} is given twice")
        try:
            out[dof.strip()] = float(amp) if eq else 1.0
        except ValueError:
            raise InputError(f"--force: amplitude of {dof.strip()!r} is not a number: {amp!r}") from None
        if not np.isfinite(out[dof.strip()]):
            raise InputError(f"--force: amplitude of {dof.strip()!r} is not finite: {amp.strip()!r}")
    if not out:
        raise InputError("--force: give a dof (e.g. 2:x) or dof=amplitude pairs")
    if model is not None:
        out = dict(zip(option_dofs(out, model, "--force"), out.values()))
    return out


def parse_damping(text: str | None, data=None):
    """``--damping``: ``alpha=A,beta=B,eta=E`` (any of them; default undamped), or ``fit``: the
    Rayleigh damping fitted to the test modes' damping ratios (needs ``data`` with two or more)."""
    from ..frf import Damping
    from ..frf.lines import as_damping

    if not text:
        return Damping()
    if text.strip().lower() == "fit":
        from ._common import fitted_damping

        if data is None:
            raise InputError("--damping fit: fits Rayleigh damping to the test modes' damping ratios, and this command "
                             "reads no test data; give alpha=A,beta=B,eta=E")
        fit, _ = fitted_damping(data)
        if fit is None:
            have = sum(m.damping_ratio is not None for m in data.modes)
            raise InputError(f"--damping fit: fits Rayleigh damping to the test modes' damping ratios and needs two or "
                             f"more; the test data give {have}")
        return fit
    try:
        values = parse_set(text)
    except InputError as exc:
        raise InputError(str(exc).replace("--set", "--damping")) from None
    return as_damping(values)


def _dofs(text: str | None):
    return [d.strip() for d in text.split(",") if d.strip()] if text else None


def _model_dofs(text: str | None, model, option: str = "--dofs"):
    """The dofs of a comma-separated option, ``#N`` resolved against ``model``; None if not given."""
    items = _dofs(text)
    return list(option_dofs(items, model, option)) if items else None


def _pairs(h: np.ndarray) -> list:
    return [[float(np.real(v)), float(np.imag(v))] for v in h]


damping_option = click.option("--damping", "damping_text", default=None, metavar="alpha=A,beta=B,eta=E|fit",
                              help="Rayleigh (C = alpha M + beta K) and structural (eta) damping; default undamped. "
                                   "'fit': Rayleigh damping fitted to the test modes' damping ratios (where the "
                                   "command reads test data).")




def frf_line_options(command):
    """The options of the FRF residuals (``--residual``, ``--lines``, ``--select``, ``--resonance``,
    ``--resonance-tol``, ``--damping``), shared by ``frf-update`` and ``update``."""
    for option in reversed((
        click.option("--residual", type=click.Choice(list(FRF_RESIDUALS)), default=DEFAULT_RESIDUAL,
                     show_default=True, help="FRF residual: linear (eq. 34), relative, log-magnitude, or auto (a "
                                             "log-magnitude stage from the start, then linear from its solution)."),
        click.option("--lines", "lines_text", default=None, help="FRF lines to use, 1-based (e.g. 1,2,5); default all."),
        click.option("--select", type=click.IntRange(min=1), default=None, help="Choose this many FRF lines by conditioning."),
        click.option("--resonance", type=click.Choice(["skip", "error", "keep"]), default="skip", show_default=True,
                     help="FRF lines within --resonance-tol of a resonance of the starting model."),
        click.option("--resonance-tol", type=FiniteFloat(min=0), default=1e-3, show_default=True),
        damping_option,
    )):
        command = option(command)
    return command


reciprocity_option = click.option(
    "--reciprocity", is_flag=True,
    help="Regroup the FRF sets by response dof (H_ij = H_ji): a roving-hammer file (one response, many excitations) "
         "becomes one set of one excitation. Default: one residual block per excitation, as measured.")


def apply_reciprocity(data, asked: bool):
    """The test data with their FRF sets regrouped by reciprocity when ``--reciprocity`` was given."""
    if not asked:
        return data
    from ..testdata import reciprocal

    return reciprocal(data)


def frf_options(residual, lines_text, select, resonance, resonance_tol, damping_text, data=None) -> dict:
    """The FRF options of :func:`femupdate.updating.frf_update` from the command line's."""
    lines = None
    if lines_text:
        try:
            lines = [int(v) - 1 for v in lines_text.split(",") if v.strip()]
        except ValueError:
            raise InputError(f"--lines: {lines_text!r} is not a list of line numbers (1-based)") from None
        if any(not 0 <= v < 2**31 for v in lines):
            raise InputError(f"--lines: line numbers count from 1 and are at most {2**31}")
        twice = sorted({v + 1 for v in lines if lines.count(v) > 1})
        if twice:
            raise InputError(f"--lines: line(s) {', '.join(map(str, twice))} given twice")
    return dict(residual=residual, lines=lines, select=select, resonance=resonance, resonance_tol=resonance_tol,
                damping=parse_damping(damping_text, data))


def frf_fields(res) -> dict:
    """The FRF part of a result's JSON (lines used and skipped, residual, FRAC, natural frequencies)."""
    return {"omega_rad_s": res.omega, "skipped": res.skipped, "residual": res.residual, "frac": res.frac,
            "natural_frequencies_hz": res.natural_frequencies_hz}


# ---------------------------------------------------------------------------------- frf
@click.command("frf")
@click.argument("model_path", metavar="MODEL", type=click.Path(dir_okay=False, path_type=Path))
@click.option("--force", "force_text", required=True, metavar="DOF[=AMP],...",
              help="Excitation (unit force by default); a dof is a label or #N, the N-th model dof.")
@click.option("--omega", "omega_text", default=None, metavar="LIST|START:STOP:N", help="Lines in rad/s.")
@click.option("--frequency-hz", "hz_text", default=None, metavar="LIST|START:STOP:N",
              help="Lines in Hz (instead of --omega).")
@click.option("--dofs", "dofs_text", default=None, help="Response dofs, labels or #N (default every model dof).")
@click.option("--kind", type=click.Choice(["receptance", "mobility", "accelerance"]), default="receptance", show_default=True)
@damping_option
@click.option("--noise", type=FiniteFloat(min=0, max=1e150), default=0.0, show_default=True, help="Noise standard deviation.")
@click.option("--noise-kind", type=click.Choice(["relative", "absolute", "coherent"]), default="relative", show_default=True)
@click.option("--seed", type=SEED, default=0, show_default=True, help="Seed of the noise.")
@click.option("--uff", "uff_path", type=OUTPUT_FILE, default=None,
              help="Also write the receptances as universal file datasets 58.")
@click.option("--test-data", "data_path", type=OUTPUT_FILE, default=None,
              help="Also write them as test-data JSON (the 'frf' object), ready for frf-update.")
@set_option
@json_option
def frf_command(model_path, force_text, omega_text, hz_text, dofs_text, kind, damping_text, noise, noise_kind, seed, uff_path,
                data_path, set_text, json_path):
    """Frequency response functions of MODEL to a force (receptance, mobility or accelerance)."""
    from ..frf import convert, resonances, simulate
    from ..io.model_file import load_model

    ctx = Ctx(json_path)
    model = load_model(model_path)
    values = model_values(model, set_text)
    if (omega_text is None) == (hz_text is None):
        raise InputError("give the frequency lines with exactly one of --omega (rad/s) or --frequency-hz (Hz)")
    omega = parse_omega(omega_text) if hz_text is None else 2 * np.pi * parse_omega(hz_text, "--frequency-hz")
    force = parse_force(force_text, model)
    response = _model_dofs(dofs_text, model)
    if uff_path is not None:
        from ..io.uff.write import uff_dofs

        uff_dofs(list(force) + list(response or model.dofs), "frf --uff")
    damping = parse_damping(damping_text)
    data = simulate(model, omega, force, response, values, damping, noise, noise_kind, seed)
    H = convert(data.response, omega, kind) if kind != "receptance" else data.response
    notes = []
    from ..modal import DENSE_LIMIT

    if model.n_dofs <= DENSE_LIMIT:
        res = resonances(model, omega, values)
        near = res.near(1e-3)
        if near.size:
            notes.append(f"lines within 1e-3 of a resonance (large, sensitive values): {res.describe(near)}")
    t = Table(title=f"{model.name}: {kind}, force {', '.join(f'{d}={fmt(v)}' for d, v in data.force.items())}")
    t.add_column("omega (rad/s)", justify="right")
    shown = list(data.dofs[:6])
    for d in shown:
        t.add_column(f"|{d}|", justify="right")
    step = max(1, omega.size // 20)
    for i in range(0, omega.size, step):
        t.add_row(fmt(omega[i]), *(fmt(abs(H[i, k])) for k in range(len(shown))))
    ctx.console.print(t)
    if len(data.dofs) > len(shown) or step > 1:
        ctx.console.print(f"({omega.size} lines x {len(data.dofs)} dofs; the table shows a sample)")
    for n in notes:
        ctx.console.print(f"note: {n}")
    if uff_path is not None:
        from ..io.uff import write_uff_frf

        write_uff_frf(uff_path, data, nodes=model.nodes, model_name=model.name)
        ctx.console.print(f"receptances written to {uff_path} (datasets 58)")
    frf_obj = {"omega_rad_s": omega, "force": dict(data.force),
               "response": {d: _pairs(data.response[:, k]) for k, d in enumerate(data.dofs)}}
    if data_path is not None:
        from ..io.results import write_json

        write_json(data_path, {"frf": frf_obj})
        ctx.console.print(f"test data written to {data_path}")
    emit(ctx, {
        "model": model.name, "omega_rad_s": omega, "dofs": list(data.dofs), "kind": kind,
        "response": {d: _pairs(H[:, k]) for k, d in enumerate(data.dofs)},
        "force": dict(data.force), "damping": damping.as_dict(), "noise": {"level": noise, "kind": noise_kind, "seed": seed},
        "parameters": dict(zip(model.parameter_names, model.resolve(values))), "notes": notes,
    })


# ---------------------------------------------------------------------------------- frf-update
def _frf_payload(model, data, res, ms, extra=None):
    out = update_payload(model, data, res, ms)
    out.update(frf_fields(res))
    out.update(extra or {})
    return out


@click.command("frf-update")
@click.argument("model_path", metavar="MODEL", type=click.Path(dir_okay=False, path_type=Path))
@click.argument("data_path", metavar="DATA", type=click.Path(dir_okay=False, path_type=Path))
@click.option("--params", "params_text", default=None, help="Parameters to update (default: all not fixed).")
@click.option("--starts", type=click.IntRange(min=1), default=1, show_default=True,
              help="1: start from the model's values; R > 1: R random starts within the bounds.")
@click.option("--seed", type=SEED, default=0, show_default=True)
@click.option("--scheduler", type=SCHEDULER, default=None, metavar="ADDR", help="Run the starts / runs on an existing Dask cluster.")
@connect_timeout_option
@click.option("--global", "global_method", type=click.Choice(["differential_evolution", "basinhopping", "dual_annealing"]),
              default=None, help="Global search within the bounds, then a local polish.")
@click.option("--runs", type=click.IntRange(min=1), default=1, show_default=True, help="Independent global runs.")
@click.option("--global-residual", type=click.Choice(["linear", "relative", "log"]), default="log", show_default=True,
              help="Residual of the global stage (the polish uses --residual).")
@frf_line_options
@click.option("--parametrisation", type=click.Choice(["relative", "log", "absolute"]), default="relative", show_default=True)
@click.option("--method", type=click.Choice(["trf", "dogbox", "lm"]), default="trf", show_default=True)
@click.option("--regularization", "reg_text", default=None, help="Tikhonov factor, or gcv / lcurve.")
@click.option("--max-nfev", type=click.IntRange(min=1), default=200, show_default=True)
@click.option("--std", type=FiniteFloat(min=1 / MAX_MAGNITUDE), default=None, help="Std of the residual entries (covariance).")
@reciprocity_option
@write_model_option
@csv_option
@click.option("--plot", "plot_dir", type=OUTPUT_DIR, default=None,
              help="Write the FRF overlay and convergence figures to this folder.")
@report_option
@set_option
@json_option
def frf_update_command(model_path, data_path, params_text, starts, seed, scheduler, connect_timeout, global_method, runs, global_residual,
                       residual, lines_text, select, resonance, resonance_tol, damping_text, parametrisation, method,
                       reg_text, max_nfev, std, reciprocity, write_model_path, csv_dir, plot_dir, report_path, set_text,
                       json_path):
    """Update MODEL's parameters from FRFs in DATA measured at any dofs (eqs. 30-32)."""
    from ..updating import frf_multistart, frf_update
    from ..updating.frf import frf_data
    from ..io.model_file import load_model
    from ..io.testdata_json import load_testdata

    ctx = Ctx(json_path)
    model = load_model(model_path)
    values = model_values(model, set_text)
    data = apply_reciprocity(load_testdata(data_path, model), reciprocity)
    if global_method or data.n_frf_sets <= 1:
        frf_data(data)  # no FRF data, or several sets for the global search: refused by name
    frf = data.frf
    assert frf is not None
    params = [p.strip() for p in params_text.split(",") if p.strip()] if params_text else None
    kw = dict(**frf_options(residual, lines_text, select, resonance, resonance_tol, damping_text, data),
              parametrisation=parametrisation, method=method, regularization=parse_regularization(reg_text),
              max_nfev=max_nfev, values=values, measurement_std=std)
    ms, extra = None, {}
    if global_method:
        from ..updating import global_search

        # every local option reaches the polish except --method (global_search's method is the global one)
        glob = {k: v for k, v in kw.items() if k != "method"}
        with ctx.console.status("global search", spinner="dots") if ctx.console.is_terminal else nullcontext():
            ms = global_search(model, data, method=global_method, params=params, runs=runs, seed=seed,
                               scheduler=scheduler, connect_timeout=connect_timeout, global_residual=global_residual, **glob)
        extra["global"] = {"method": global_method, "runs": runs, "residual": global_residual, "optimizer": ms.optimizer}
    elif starts > 1 or scheduler:
        from rich.progress import Progress

        with Progress(console=ctx.console, transient=True, disable=json_path == "-" or not ctx.console.is_terminal) as bar:
            task = bar.add_task("starts", total=starts)
            ms = frf_multistart(model, data, starts=starts, seed=seed, params=params, scheduler=scheduler,
                                connect_timeout=connect_timeout,
                                progress=lambda done, total: bar.update(task, completed=done), **kw)
    if ms is not None and ms.best is None:
        failed = {"model": model.name, "success": False, "starts": starts_payload(ms), **extra}
        emit(ctx, failed)
        print_starts(ctx.console, ms, f"{global_method} runs" if global_method else "starts")
        write_report_output(ctx, report_path, failed, model=model, model_path=model_path, kind="frf-update")
        raise NumericalError(f"none of the {ms.total} {'runs' if global_method else 'starts'} converged")
    res = ms.best if ms is not None else frf_update(model, data, params=params, **kw)
    c = ctx.console
    what = f"{global_method} runs" if global_method else "starts"
    sets = (f"{res.omega.size} lines x {len(frf.dofs)} dofs" if data.n_frf_sets == 1
            else f"{data.n_frf_sets} excitations, {sum(len(s.dofs) for s in data.frf_sets)} responses")
    title = (f"{model.name}: FRF update ({res.iterations} iterations, {res.nfev} evaluations, "
             f"{sets}, {res.residual} residual)")
    if ms is not None and len(ms.fitting) > 1:
        c.print(fitting_table(ms, what))
        title = f"the lowest-cost solution in detail — {title}"
    c.print(update_parameter_table(res, title, {p.name: p.unit for p in model.parameters}))
    c.print("FRAC per dof: " + ", ".join(f"{d} {v:.4f}" for d, v in res.frac.items()))
    print_diagnostics(c, res)
    for s in res.skipped:
        c.print(f"skipped line {s['line']} ({fmt(s['omega_rad_s'])} rad/s): {s['reason']}")
    for note in [*data.notes, *res.notes]:
        c.print(f"note: {note}", markup=False)
    payload = _frf_payload(model, data, res, ms, extra)
    payload["notes"] = [*data.notes, *payload["notes"]]
    payload.update(data_fields(data))
    print_flags(ctx, payload["flags"])
    if ms is not None:
        print_starts(c, ms, what)
    if plot_dir is not None:
        from ..frf import frf as model_frf
        from ..plot.frf import save_frf_update_figures

        use = np.isin(frf.omega, res.omega)
        _, xa = model_frf(model, frf.omega[use], frf.force, frf.dofs, res.parameters, kw["damping"])
        names = save_frf_update_figures(plot_dir, res.history, frf.omega[use], frf.dofs, frf.response[use], xa)
        c.print(f"figures: {', '.join(str(plot_dir / n) for n in names)}"
                + (f" (the FRF overlay shows the first excitation's set, {', '.join(frf.force)})"
                   if data.n_frf_sets > 1 else ""))
    emit(ctx, payload)
    write_report_output(ctx, report_path, payload, model=model, data=data, model_path=model_path, kind="frf-update",
                        before=None if values is None else dict(zip(model.parameter_names, values)),
                        damping=kw["damping"])
    if not res.success:
        if write_model_path or csv_dir:
            c.print("not written: the updated model and tables (the update did not converge)")
        raise NumericalError(f"the FRF update did not converge: {res.message}")
    write_model_outputs(ctx, model_path, data_path, "frf-update", model, res.parameters, res.names, res.cost,
                        write_model_path, csv_dir, res)


# ---------------------------------------------------------------------------------- frf-select
@click.command("frf-select")
@click.argument("model_path", metavar="MODEL", type=click.Path(dir_okay=False, path_type=Path))
@click.option("--force", "force_text", required=True, metavar="DOF[=AMP],...")
@click.option("--candidates", "cand_text", required=True, metavar="LIST|START:STOP:N", help="Candidate lines, rad/s.")
@click.option("--lines", "n_lines", type=click.IntRange(min=1), required=True, help="How many lines to choose.")
@click.option("--kind", type=click.Choice(["direct", "sensitivity"]), default="direct", show_default=True,
              help="direct: complete data (eq. 28); sensitivity: measured at --dofs (eqs. 31-32).")
@click.option("--dofs", "dofs_text", default=None, help="Measured dofs, labels or #N (kind sensitivity; default all).")
@click.option("--unknowns", default=None, help="Parameters to identify (default: all not fixed).")
@click.option("--margin", type=FiniteFloat(min=0), default=0.05, show_default=True,
              help="Keep this relative eigenvalue distance from resonances.")
@damping_option
@set_option
@json_option
def frf_select_command(model_path, force_text, cand_text, n_lines, kind, dofs_text, unknowns, margin, damping_text,
                       set_text, json_path):
    """Choose spectral lines that make the FRF updating equations best conditioned (He 1993; Ren & Beards 1993)."""
    from ..frf.selection import select_frequencies
    from ..io.model_file import load_model

    ctx = Ctx(json_path)
    model = load_model(model_path)
    values = model_values(model, set_text)
    sel = select_frequencies(model, parse_omega(cand_text, "--candidates"), n_lines, parse_force(force_text, model),
                             kind=kind, response=_model_dofs(dofs_text, model), unknowns=_dofs(unknowns), values=values,
                             damping=parse_damping(damping_text), margin=margin)
    c = ctx.console
    c.print(f"chosen lines (rad/s): {', '.join(fmt(w) for w in sel.omega)}  (condition number {sel.condition_number:.4g})")
    c.print(f"evenly spread lines {', '.join(fmt(w) for w in sel.uniform['omega_rad_s'])}: condition number "
            f"{sel.uniform['condition_number']:.4g}")
    if sel.excluded:
        c.print(f"{len(sel.excluded)} candidate(s) excluded near resonances")
    emit(ctx, {"model": model.name, "kind": kind, "omega_rad_s": sel.omega, "lines": (sel.index + 1).tolist(),
                "condition_number": sel.condition_number, "uniform": sel.uniform, "excluded": sel.excluded,
                "history": sel.history})


# ---------------------------------------------------------------------------------- surface
def _range(text: str, what: str) -> np.ndarray:
    g = parse_omega(text, what)
    if g.size < 2:
        raise InputError(f"{what}: a grid needs at least two values")
    return g


@click.command("surface")
@click.argument("model_path", metavar="MODEL", type=click.Path(dir_okay=False, path_type=Path))
@click.argument("data_path", metavar="DATA", type=click.Path(dir_okay=False, path_type=Path))
@click.option("--params", "params_text", required=True, metavar="P1,P2", help="The two parameters of the grid.")
@click.option("--x", "x_text", required=True, metavar="START:STOP:N", help="Grid of the first parameter.")
@click.option("--y", "y_text", required=True, metavar="START:STOP:N", help="Grid of the second parameter.")
@click.option("--kind", type=click.Choice(["frf", "modal"]), default="frf", show_default=True,
              help="frf: eq. 34 from the data's FRFs; modal: eq. 33 from its modes.")
@click.option("--residual", type=click.Choice(["linear", "relative", "log"]), default="linear", show_default=True)
@click.option("--ref-dof", default=None, help="Modal: scale shapes to 1 here, a label or #N (default first measured dof).")
@damping_option
@click.option("--truth", "truth_text", default=None, metavar="P1=V1,P2=V2", help="Mark the true solution.")
@click.option("--plot", "plot_path", type=OUTPUT_FIGURE, default=None,
              help="Write the surface and contour figure (PNG).")
@set_option
@json_option
def surface_command(model_path, data_path, params_text, x_text, y_text, kind, residual, ref_dof, damping_text,
                    truth_text, plot_path, set_text, json_path):
    """Residual surface over two parameters (paper Figures 5-7): grid minimum and local minima."""
    from ..frf.surfaces import frf_surface, modal_surface
    from ..updating.frf import frf_data
    from ..io.model_file import load_model
    from ..io.testdata_json import load_testdata

    ctx = Ctx(json_path)
    model = load_model(model_path)
    values = model_values(model, set_text)
    data = load_testdata(data_path, model)
    names = [p.strip() for p in params_text.split(",") if p.strip()]
    x, y = _range(x_text, "--x"), _range(y_text, "--y")
    if len(names) == 2:
        for opt, grid, name in (("--x", x, names[0]), ("--y", y, names[1])):
            for v in (float(np.min(grid)), float(np.max(grid))):
                try:
                    check_set(model, {name: v})
                except InputError as exc:
                    raise InputError(str(exc).replace("--set:", f"{opt}: the grid of", 1)) from None
    truth = None
    if truth_text:
        t = parse_set(truth_text)
        missing = [n for n in names if n not in t]
        if missing:
            raise InputError(f"--truth: give a value for {', '.join(missing)}")
        truth = (t[names[0]], t[names[1]])
    if kind == "frf":
        surf = frf_surface(model, frf_data(data), names, x, y, values, parse_damping(damping_text, data), residual,
                           truth=truth)
    else:
        if not data.modes:
            raise InputError(f"{data_path}: no modes for a modal surface")
        (ref,) = option_dofs([ref_dof], model, "--ref-dof") if ref_dof else (None,)
        surf = modal_surface(model, data, names, x, y, values, ref, truth=truth)
    summ = surf.summary()
    m = summ["minimum"]
    ctx.console.print(f"{surf.kind} over {names[0]} x {names[1]} ({x.size} x {y.size}): minimum {m['value']:.4g} at "
                      f"{names[0]}={fmt(m[names[0]])}, {names[1]}={fmt(m[names[1]])}; {summ['local_minima']} interior "
                      f"local minima (8 neighbours), {summ['edge_minima']} on the border, {summ['singular_points']} "
                      "points exactly on a resonance")
    if plot_path is not None:
        from ..plot.frf import save_surface_figure

        save_surface_figure(plot_path, surf, f"log10 r, {surf.kind}")
        ctx.console.print(f"figure written to {plot_path}")
    emit(ctx, {"model": model.name, "kind": surf.kind, "params": names, "x": x, "y": y, "values": surf.values,
                **{k: summ[k] for k in ("minimum", "local_minima", "edge_minima", "minima", "singular_points")}})
