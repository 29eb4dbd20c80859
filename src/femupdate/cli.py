"""The ``femupdate`` command line (docs/interfaces.md).

Every command prints a readable summary and, with ``--json PATH`` (``-`` = stdout), writes the
machine-readable result atomically.  Exit codes: 0 success, 2 bad input, 1 numerical failure;
errors are one clear message on stderr, never a traceback.
"""

from __future__ import annotations

import logging
import sys
from importlib import resources
from pathlib import Path

import click
import numpy as np
from rich.console import Console
from rich.table import Table

from ._errors import FemupdateError, InputError, NumericalError

log = logging.getLogger("femupdate")


class _Ctx:
    def __init__(self, json_path):
        self.json_path = json_path
        quiet = json_path == "-"
        self.console = Console(file=sys.stderr if quiet else sys.stdout, quiet=quiet, highlight=False, soft_wrap=True,
                               emoji=False)  # dof labels such as "1:x:" are not emoji codes


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
        try:
            out[name.strip()] = float(val)
        except ValueError:
            raise InputError(f"--set: value of {name.strip()!r} is not a number: {val!r}") from None
        if not np.isfinite(out[name.strip()]):
            raise InputError(f"--set: value of {name.strip()!r} is not finite")
    return out


def _values(model, set_text):
    values = parse_set(set_text)
    for name in values:
        model.parameter_index(name)  # names an unknown parameter clearly
    return model.resolve(values) if values else None


def _emit(ctx: _Ctx, payload: dict) -> None:
    if ctx.json_path:
        from .io.results import write_json

        write_json(ctx.json_path, payload)


def _fmt(v: float) -> str:
    return f"{v:.6g}"


json_option = click.option("--json", "json_path", metavar="PATH", default=None,
                           help="Write the machine-readable result to PATH ('-' = stdout).")
set_option = click.option("--set", "set_text", metavar="NAME=VALUE,...", default=None,
                          help="Evaluate the model at other parameter values.")


@click.group(context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(package_name="femupdate")
@click.option("-v", "--verbose", count=True, help="Log progress (-v info, -vv debug).")
def cli(verbose: int) -> None:
    """femupdate: update finite-element models so that they match vibration test data."""
    logging.basicConfig(level=logging.WARNING - 10 * min(verbose, 2), format="%(levelname)s %(name)s: %(message)s")


# ---------------------------------------------------------------------------------- modes
@cli.command()
@click.argument("model_path", metavar="MODEL", type=click.Path(dir_okay=False, path_type=Path))
@click.option("--n-modes", type=click.IntRange(min=1), default=None, help="Number of modes (default all for small models, 10 for large).")
@click.option("--normalise", "--normalize", "normalisation", default="mass", show_default=True,
              help="mass | unit | max | ref:<dof>")
@click.option("--method", type=click.Choice(["auto", "dense", "sparse"]), default="auto", show_default=True)
@click.option("--uff", "uff_path", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="Also write the modes as universal file datasets 55 (with nodes 2411).")
@set_option
@json_option
def modes(model_path, n_modes, normalisation, method, uff_path, set_text, json_path):
    """Natural frequencies and mode shapes of MODEL."""
    from .io.model_file import load_model
    from .modal import model_modes

    ctx = _Ctx(json_path)
    model = load_model(model_path)
    values = _values(model, set_text)
    if n_modes is not None and n_modes > model.n_dofs:
        raise InputError(f"--n-modes {n_modes}: the model has only {model.n_dofs} dofs")
    res = model_modes(model, values, n_modes=n_modes, normalisation=normalisation, method=method)
    t = Table(title=f"{model.name}: {model.n_dofs} dofs, {res.n_modes} modes")
    t.add_column("mode", justify="right")
    t.add_column("frequency [Hz]", justify="right")
    t.add_column("eigenvalue [rad²/s²]", justify="right")
    for r in range(res.n_modes):
        t.add_row(str(r + 1), _fmt(res.frequencies_hz[r]), _fmt(res.eigenvalues[r]))
    ctx.console.print(t)
    if res.n_rigid:
        ctx.console.print(f"{res.n_rigid} rigid-body mode(s)")
    if uff_path is not None:
        from .io.uff import write_uff_modes

        write_uff_modes(uff_path, res, nodes=model.nodes, model_name=model.name)
        ctx.console.print(f"modes written to {uff_path}")
    _emit(ctx, {
        "model": model.name, "eigenvalues": res.eigenvalues, "frequencies_hz": res.frequencies_hz,
        "dofs": list(res.dofs), "shapes": res.shapes.T, "normalisation": res.normalisation,
        "n_rigid": res.n_rigid,
        "parameters": dict(zip(model.parameter_names, model.resolve(values))),
    })


# ---------------------------------------------------------------------------------- direct
def _direct_payload(model, res, data, corr_before=None):
    return {
        "model": model.name,
        "parameters": res.parameters,
        "unknowns": list(res.unknowns),
        "standard_error": dict(zip(res.unknowns, res.standard_error)),
        "condition_number": res.condition_number,
        "condition_number_scaled": res.condition_number_scaled,
        "residual_norm": res.residual_norm,
        "relative_residual": res.relative_residual,
        "rank": res.rank,
        "unique": res.unique,
        "n_equations": res.system.n_equations,
        "bounded": res.bounded,
        "notes": res.notes,
    }


def _correlation_rows(data, model, values):
    from .correlation import correlate
    from .modal import model_modes

    if not data.modes:
        return None, None
    mm = model_modes(model, values, n_modes=min(model.n_dofs, max(len(data.modes) + 4, 10)) if model.n_dofs > 1500 else None)
    return mm, correlate(data, mm)


@cli.command()
@click.argument("model_path", metavar="MODEL", type=click.Path(dir_okay=False, path_type=Path))
@click.argument("data_path", metavar="DATA", type=click.Path(dir_okay=False, path_type=Path))
@click.option("--use", default="modes,frf,static", show_default=True, help="Kinds of data to use.")
@click.option("--unknowns", default=None, help="Parameters to identify (default: all not fixed).")
@click.option("--bounded", is_flag=True, help="Honour parameter bounds (bounded least squares).")
@click.option("--uff", "uff_path", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="Write the updated model's modes as universal file datasets 55.")
@set_option
@json_option
def direct(model_path, data_path, use, unknowns, bounded, uff_path, set_text, json_path):
    """Identify MODEL's parameters directly from DATA measured at every model dof."""
    from .direct import direct_update
    from .io.model_file import load_model
    from .io.testdata_json import load_testdata

    ctx = _Ctx(json_path)
    model = load_model(model_path)
    values = _values(model, set_text)
    data = load_testdata(data_path, model)
    kinds = [u.strip() for u in use.split(",") if u.strip()]
    names = [u.strip() for u in unknowns.split(",")] if unknowns else None
    res = direct_update(model, data, use=kinds, values=values, unknowns=names, bounded=bounded)
    payload = _direct_payload(model, res, data)
    table = Table(title=f"{model.name}: direct update from {res.system.n_equations} equations")
    for col in ("parameter", "start", "identified", "std. error", "change"):
        table.add_column(col, justify="right" if col != "parameter" else "left")
    p0 = model.resolve(values)
    for j, name in enumerate(model.parameter_names):
        new = res.parameters[name]
        if name in res.unknowns:
            se = res.standard_error[res.unknowns.index(name)]
            table.add_row(name, _fmt(p0[j]), _fmt(new), "-" if not np.isfinite(se) else _fmt(se),
                          f"{(new - p0[j]) / p0[j] * 100:+.1f} %" if p0[j] else "")
        else:
            table.add_row(name, _fmt(p0[j]), "(fixed)", "", "")
    ctx.console.print(table)
    ctx.console.print(f"condition number {res.condition_number:.4g} (columns scaled: {res.condition_number_scaled:.4g}), "
                      f"residual {res.residual_norm:.4g} (relative {res.relative_residual:.3g}), rank {res.rank}/{len(res.unknowns)}")
    if data.modes:
        mm, corr = _correlation_rows(data, model, res.parameters)
        payload["frequencies_hz"] = {"test": data.frequencies_hz, "model": [mm.frequencies_hz[j] for _, j, _ in corr.pairs]}
        payload["pairs"] = [[i, j, m] for i, j, m in corr.pairs]
        ctx.console.print(_corr_table(corr, "updated model vs test"))
        if uff_path is not None:
            from .io.uff import write_uff_modes

            write_uff_modes(uff_path, mm, nodes=model.nodes, model_name=model.name)
    for note in res.notes:
        ctx.console.print(f"note: {note}")
    _emit(ctx, payload)
    if not res.unique:
        raise NumericalError(f"the data do not determine every parameter uniquely: {res.notes[-1]}")


def _corr_table(corr, title):
    t = Table(title=title)
    for col in ("test", "model", "f test [Hz]", "f model [Hz]", "error", "MAC"):
        t.add_column(col, justify="right")
    for (i, j, m), e in zip(corr.pairs, corr.frequency_error):
        t.add_row(str(i + 1), str(j + 1), _fmt(corr.test_frequencies_hz[i]), _fmt(corr.model_frequencies_hz[j]),
                  f"{e * 100:+.2f} %", "-" if not np.isfinite(m) else f"{m:.4f}")
    for i in corr.unpaired_test:
        t.add_row(str(i + 1), "-", _fmt(corr.test_frequencies_hz[i]), "-", "-", "unpaired")
    return t


# ---------------------------------------------------------------------------------- update
def _parse_regularization(text):
    if text is None:
        return None
    if text in ("gcv", "lcurve"):
        return text
    try:
        return float(text)
    except ValueError:
        raise InputError(f"--regularization must be gcv, lcurve or a number, got {text!r}") from None


def _update_payload(model, data, res, ms=None):
    d = res.diagnostics
    out = {
        "model": model.name,
        "parameters": res.parameters,
        "updated": list(res.names),
        "start": res.start,
        "success": res.success,
        "status": res.status,
        "message": res.message,
        "cost": res.cost,
        "iterations": res.iterations,
        "nfev": res.nfev,
        "pairs": [[k, j, m] for k, j, m in res.pairs],
        "frequencies_hz": {"test": res.test_frequencies_hz, "model": res.model_frequencies_hz},
        "swaps": res.swaps,
        "history": res.history,
        "regularization": res.regularization,
        "sensitivity": res.sensitivity,
        "diagnostics": None if d is None else {
            "singular_values": d.singular_values, "condition_number": d.condition_number, "rank": d.rank,
            "poorly_determined": d.poorly_determined, "std": dict(zip(res.names, d.std)),
            "covariance": d.covariance, "n_residuals": d.n_residuals, "n_parameters": d.n_parameters,
        },
    }
    if ms is not None:
        out["starts"] = {
            "total": ms.total, "converged": ms.converged, "seed": ms.seed,
            "solutions": [{"parameters": s.parameters, "cost": s.cost, "count": s.count} for s in ms.solutions],
            "failed": [r for r in ms.runs if isinstance(r, str)],
        }
    else:
        out["starts"] = {"total": 1, "converged": int(res.success),
                         "solutions": [{"parameters": {n: res.parameters[n] for n in res.names}, "cost": res.cost, "count": 1}] if res.success else []}
    return out


def _parameter_table(res, title: str) -> Table:
    """Start, updated value, standard deviation and change of each updated parameter."""
    t = Table(title=title)
    for col in ("parameter", "start", "updated", "std", "change"):
        t.add_column(col, justify="left" if col == "parameter" else "right")
    std_p = dict(zip(res.names, res.diagnostics.std))
    for n in res.names:
        p0, p1 = res.start[n], res.parameters[n]
        t.add_row(n, _fmt(p0), _fmt(p1), "-" if not np.isfinite(std_p[n]) else _fmt(std_p[n]),
                  f"{(p1 - p0) / p0 * 100:+.1f} %" if p0 else "")
    return t


@cli.command()
@click.argument("model_path", metavar="MODEL", type=click.Path(dir_okay=False, path_type=Path))
@click.argument("data_path", metavar="DATA", type=click.Path(dir_okay=False, path_type=Path))
@click.option("--starts", type=click.IntRange(min=1), default=1, show_default=True,
              help="1: start from the model's values; R > 1: R random starts within the bounds.")
@click.option("--seed", type=int, default=0, show_default=True, help="Seed of the random starts.")
@click.option("--scheduler", default=None, metavar="ADDR", help="Run the starts on an existing Dask cluster (tcp://host:port).")
@click.option("--params", "params_text", default=None, help="Parameters to update (default: all not fixed).")
@click.option("--shape-scaling", type=click.Choice(["unit", "ref", "max"]), default="unit", show_default=True)
@click.option("--ref-dof", default=None, help="Reference dof for --shape-scaling ref (default: first measured dof).")
@click.option("--parametrisation", type=click.Choice(["relative", "log", "absolute"]), default="relative", show_default=True)
@click.option("--method", type=click.Choice(["trf", "dogbox", "lm"]), default="trf", show_default=True)
@click.option("--regularization", "reg_text", default=None, help="Tikhonov factor, or gcv / lcurve to choose it.")
@click.option("--min-mac", type=click.FloatRange(0, 1), default=0.5, show_default=True)
@click.option("--max-nfev", type=click.IntRange(min=1), default=200, show_default=True)
@click.option("--eigenvalues-only", is_flag=True, help="Ignore the measured shapes (frequencies only).")
@click.option("--sensitivity", type=click.Choice(["auto", "nelson", "modal", "static", "subspace", "adjoint", "fd"]),
              default="auto", show_default=True,
              help="Route of the eigenvector derivatives (auto: Nelson up to 1,500 dofs, adjoint/subspace above).")
@click.option("--std-eigenvalue", type=float, default=None, help="Relative std of measured eigenvalues (for the covariance).")
@click.option("--std-shape", type=float, default=None, help="Std of scaled shape entries (for the covariance).")
@click.option("--plot", "plot_dir", type=click.Path(file_okay=False, path_type=Path), default=None,
              help="Write convergence and MAC figures to this folder.")
@set_option
@json_option
def update(model_path, data_path, starts, seed, scheduler, params_text, shape_scaling, ref_dof, parametrisation,
           method, reg_text, min_mac, max_nfev, eigenvalues_only, sensitivity, std_eigenvalue, std_shape, plot_dir,
           set_text, json_path):
    """Update MODEL's parameters iteratively from measured modes in DATA (any measured dofs)."""
    from .io.model_file import load_model
    from .io.testdata_json import load_testdata
    from .updating import multistart
    from .updating import update as _update

    ctx = _Ctx(json_path)
    model = load_model(model_path)
    values = _values(model, set_text)
    data = load_testdata(data_path, model)
    params = [p.strip() for p in params_text.split(",") if p.strip()] if params_text else None
    std = {k: v for k, v in (("eigenvalue", std_eigenvalue), ("shape", std_shape)) if v is not None} or None
    kw = dict(shape_scaling=shape_scaling, ref_dof=ref_dof, parametrisation=parametrisation, method=method,
              regularization=_parse_regularization(reg_text), min_mac=min_mac, max_nfev=max_nfev,
              use_shapes=not eigenvalues_only, measurement_std=std, values=values, sensitivity=sensitivity)
    ms = None
    if starts == 1 and not scheduler:
        res = _update(model, data, params=params, **kw)
    else:
        from rich.progress import Progress

        with Progress(console=ctx.console, transient=True, disable=json_path == "-" or not ctx.console.is_terminal) as bar:
            task = bar.add_task("starts", total=starts)
            ms = multistart(model, data, starts=starts, seed=seed, params=params, scheduler=scheduler,
                            progress=lambda done, total: bar.update(task, completed=done), **kw)
        if ms.best is None:
            _emit(ctx, {"model": model.name, "success": False, "starts": {"total": ms.total, "converged": 0, "solutions": [],
                        "failed": [r for r in ms.runs if isinstance(r, str)]}})
            raise NumericalError(f"none of the {starts} starts converged")
        res = ms.best
    c = ctx.console
    c.print(_parameter_table(res, f"{model.name}: iterative update ({res.iterations} iterations, {res.nfev} evaluations)"))
    t2 = Table(title="paired modes")
    for col in ("test", "model", "f test [Hz]", "f model [Hz]", "error", "MAC"):
        t2.add_column(col, justify="right")
    for (k, j, m), ft, fm in zip(res.pairs, res.test_frequencies_hz, res.model_frequencies_hz):
        t2.add_row(str(k + 1), str(j + 1), _fmt(ft), _fmt(fm), f"{(fm - ft) / ft * 100:+.3f} %", "-" if not np.isfinite(m) else f"{m:.4f}")
    c.print(t2)
    d = res.diagnostics
    c.print(f"{'converged' if res.success else 'NOT converged'}: {res.message}; cost {res.cost:.4g}; "
            f"condition number of the normalised sensitivity matrix {d.condition_number:.3g} (rank {d.rank}/{d.n_parameters})")
    if d.poorly_determined:
        c.print(f"poorly determined: {', '.join(d.poorly_determined)}")
    for sw in res.swaps:
        c.print(f"mode swap: test mode {sw['test_mode'] + 1} moved from model mode {sw['from_model_mode'] + 1} to {sw['to_model_mode'] + 1}")
    if ms is not None:
        c.print(f"{ms.converged}/{ms.total} starts converged to {len(ms.solutions)} distinct solution(s):")
        for s in ms.solutions[:10]:
            c.print(f"  {s.count:4d} x  " + ", ".join(f"{k}={_fmt(v)}" for k, v in s.parameters.items()) + f"  (cost {s.cost:.3g})")
    if plot_dir is not None:
        from .correlation import correlate as _correlate
        from .modal import model_modes
        from .plot.updating import save_update_figures

        corr = _correlate(data, model_modes(model, res.parameters, n_modes=min(model.n_dofs, 2 * len(data.modes) + 4)))
        names = save_update_figures(plot_dir, res.history, corr.mac)
        c.print(f"figures: {', '.join(str(plot_dir / n) for n in names)}")
    _emit(ctx, _update_payload(model, data, res, ms))
    if not res.success:
        raise NumericalError(f"the update did not converge: {res.message}")


# ---------------------------------------------------------------------------------- correlate
@cli.command()
@click.argument("model_path", metavar="MODEL", type=click.Path(dir_okay=False, path_type=Path))
@click.argument("data_path", metavar="DATA", type=click.Path(dir_okay=False, path_type=Path))
@click.option("--min-mac", type=click.FloatRange(0, 1), default=0.5, show_default=True)
@set_option
@json_option
def correlate(model_path, data_path, min_mac, set_text, json_path):
    """Pair test and model modes by MAC; frequency errors and COMAC."""
    from .correlation import correlate as _correlate
    from .io.model_file import load_model
    from .io.testdata_json import load_testdata
    from .modal import model_modes

    ctx = _Ctx(json_path)
    model = load_model(model_path)
    values = _values(model, set_text)
    data = load_testdata(data_path, model)
    if not data.modes:
        raise InputError(f"{data_path}: no modes to correlate")
    mm = model_modes(model, values, n_modes=None if model.n_dofs <= 1500 else max(len(data.modes) + 4, 10))
    corr = _correlate(data, mm, min_mac=min_mac)
    ctx.console.print(_corr_table(corr, f"{model.name} vs {Path(data_path).name}"))
    _emit(ctx, {
        "dofs": list(corr.dofs), "mac": corr.mac, "pairs": [[i, j, m] for i, j, m in corr.pairs],
        "frequencies_hz": {"test": corr.test_frequencies_hz, "model": corr.model_frequencies_hz},
        "frequency_error": corr.frequency_error, "comac": dict(zip(corr.dofs, corr.comac)),
        "unpaired_test": corr.unpaired_test,
    })


# ---------------------------------------------------------------------------------- paper
@cli.command()
@click.option("--out", "out_dir", required=True, type=click.Path(file_okay=False, path_type=Path),
              help="Folder for paper.json and the figures.")
@click.option("--section", "sections", multiple=True, help="Only these sections (repeatable).")
@click.option("--no-figures", is_flag=True, help="Skip the figures.")
@json_option
def paper(out_dir, sections, no_figures, json_path):
    """Reproduce the reference paper's numbered results into OUT/paper.json and figures."""
    from .paper import SECTIONS, run_sections

    ctx = _Ctx(json_path)
    unknown = [s for s in sections if s not in SECTIONS]
    if unknown:
        raise InputError(f"unknown section(s) {', '.join(unknown)}; known: {', '.join(SECTIONS)}")
    result = run_sections(out_dir, list(sections) or list(SECTIONS), figures=not no_figures)
    t = Table(title=f"reference paper reproduced in {out_dir}")
    t.add_column("section")
    t.add_column("result")
    t.add_column("check", justify="center")
    for name, sec in result["sections"].items():
        t.add_row(name, sec.get("summary", ""), {True: "ok", False: "DIFFERS", None: "-"}[sec.get("agrees_with_paper")])
    ctx.console.print(t)
    ctx.console.print(f"written {out_dir / 'paper.json'}")
    _emit(ctx, result)


# ---------------------------------------------------------------------------------- demo
@cli.command()
@click.option("--write-files", "write_dir", type=click.Path(file_okay=False, path_type=Path), default=None,
              help="Also write the example models and test data of every command to this folder (see README).")
@json_option
def demo(write_dir, json_path):
    """Identify the paper's Figure 2 system from its built-in (simulated, noisy) test data."""
    from .correlation import correlate as _correlate
    from .direct import direct_update
    from .examples import FIGURE2_TRUE
    from .io.model_file import load_model
    from .io.testdata_json import load_testdata
    from .modal import model_modes

    ctx = _Ctx(json_path)
    data_dir = resources.files("femupdate") / "data"
    with resources.as_file(data_dir / "figure2.toml") as mpath, resources.as_file(data_dir / "figure2_test.json") as dpath:
        model = load_model(mpath)
        data = load_testdata(dpath, model)
        if write_dir is not None:
            from .io.results import atomic_write_text

            atomic_write_text(write_dir / "figure2.toml", Path(mpath).read_text())
            atomic_write_text(write_dir / "figure2_test.json", Path(dpath).read_text())
            from .examples import write_example_files

            write_example_files(write_dir)  # the examples of the other commands
    c = ctx.console
    c.print(f"[bold]femupdate demo[/bold]: {model.name}; {model.n_dofs} dofs, unknowns {', '.join(model.parameter_names)}")
    c.print(f"test data: {len(data.modes)} modes measured at every dof (simulated at the true values, 1 % noise on the shapes)")
    before = _correlate(data, model_modes(model))
    c.print(_corr_table(before, "starting model vs test"))
    res = direct_update(model, data)
    one = None
    try:
        one = direct_update(model, type(data)(modes=data.modes[:1]))
    except InputError as exc:
        one_msg = str(exc)
    after = _correlate(data, model_modes(model, res.parameters))
    t = Table(title="direct identification (paper eq. 10, all modes stacked)")
    for col in ("parameter", "start", "identified", "std. error", "true", "error"):
        t.add_column(col, justify="right" if col != "parameter" else "left")
    for j, name in enumerate(model.parameter_names):
        v = res.parameters[name]
        t.add_row(name, _fmt(model.values[j]), _fmt(v), _fmt(res.standard_error[j]), _fmt(FIGURE2_TRUE[name]),
                  f"{(v - FIGURE2_TRUE[name]) / FIGURE2_TRUE[name] * 100:+.2f} %")
    c.print(t)
    c.print(f"condition number {res.condition_number:.4g}, relative residual {res.relative_residual:.3g}, rank {res.rank}/{len(res.unknowns)}")
    c.print(_corr_table(after, "updated model vs test"))
    if one is None:
        c.print(f"with one mode only: {one_msg}")
    _emit(ctx, {
        "model": model.name, "true": FIGURE2_TRUE,
        **_direct_payload(model, res, data),
        "frequencies_hz": {"test": data.frequencies_hz, "model": [after.model_frequencies_hz[j] for _, j, _ in after.pairs]},
        "pairs": [[i, j, m] for i, j, m in after.pairs],
    })


def _load_command_modules() -> None:
    """Import every module of :mod:`femupdate.commands`: each adds its commands to :func:`cli`."""
    import importlib
    import pkgutil

    from . import commands

    for info in sorted(pkgutil.iter_modules(commands.__path__), key=lambda m: m.name):
        importlib.import_module(f"{commands.__name__}.{info.name}")


_load_command_modules()


def main(argv=None) -> None:
    """Entry point: run the CLI, turning femupdate errors into one message and an exit code."""
    try:
        rv = cli.main(args=argv, prog_name="femupdate", standalone_mode=False)
    except click.exceptions.Abort:
        click.echo("femupdate: interrupted", err=True)
        sys.exit(130)
    except click.ClickException as exc:
        exc.show()
        sys.exit(exc.exit_code)
    except FemupdateError as exc:
        click.echo(f"femupdate: error: {exc}", err=True)
        sys.exit(exc.exit_code)
    except KeyboardInterrupt:
        click.echo("femupdate: interrupted", err=True)
        sys.exit(130)
    except OSError as exc:  # e.g. an output folder that cannot be created or written
        where = f"{exc.filename}: " if getattr(exc, "filename", None) else ""
        click.echo(f"femupdate: error: {where}{exc.strerror or exc}", err=True)
        sys.exit(2)
    except MemoryError:
        click.echo("femupdate: error: out of memory (try fewer modes or a smaller model)", err=True)
        sys.exit(1)
    sys.exit(rv if isinstance(rv, int) else 0)


if __name__ == "__main__":  # pragma: no cover
    main()
