"""FRF commands: ``femupdate frf`` (simulate), ``frf-select`` (choose spectral lines) and
``surface`` (residual surfaces), each built from option groups; and the parsers and options of
FRFs that ``frf-update`` (:mod:`.frf_update`) and ``update`` share."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import click
import numpy as np
from rich.table import Table

from .._budget import LINE_BYTES, check_count
from .._errors import InputError, NumericalError
from .._limits import MAX_MAGNITUDE
from ..updating.run import DEFAULT_RESIDUAL, FRF_RESIDUALS
from ._common import (INPUT_FILE, OUTPUT_FIGURE, OUTPUT_FILE, SEED, Ctx, FiniteFloat, check_set, fmt, model_values, option_dofs,
                      parse_set)
from ._groups import GroupedCommand, option_group
from .outputs import Outputs, outputs_group


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
    from ..frf.damping import as_damping

    if not text:
        return Damping()
    if text.strip().lower() == "fit":
        from ..recording import fitted_damping

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


# ---------------------------------------------------------------------------------- frf
@dataclasses.dataclass(frozen=True)
class Excitation:
    """``--force``, ``--omega`` / ``--frequency-hz`` and ``--dofs`` as typed (:func:`excitation_group`)."""

    force_text: str
    omega_text: str | None
    hz_text: str | None
    dofs_text: str | None

    def resolve(self, model) -> tuple[np.ndarray, dict, list | None]:
        """The lines (rad/s), the force {dof: amplitude} and the response dofs (None: every dof).

        Raises
        ------
        InputError
            Neither or both of ``--omega`` and ``--frequency-hz``; lines, a force or dofs that do
            not parse or that the model lacks (the option named).
        """
        if (self.omega_text is None) == (self.hz_text is None):
            raise InputError("give the frequency lines with exactly one of --omega (rad/s) or --frequency-hz (Hz)")
        omega = (parse_omega(self.omega_text or "") if self.hz_text is None
                 else 2 * np.pi * parse_omega(self.hz_text, "--frequency-hz"))
        return omega, parse_force(self.force_text, model), _model_dofs(self.dofs_text, model)


def excitation_group():
    """``--force``, ``--omega``, ``--frequency-hz``, ``--dofs`` -> ``excitation``: :class:`Excitation`."""
    return option_group(
        "Excitation and lines", "excitation", Excitation,
        click.option("--force", "force_text", required=True, metavar="DOF[=AMP],...",
                     help="Excitation (unit force by default); a dof is a label or #N, the N-th model dof."),
        click.option("--omega", "omega_text", default=None, metavar="LIST|START:STOP:N", help="Lines in rad/s."),
        click.option("--frequency-hz", "hz_text", default=None, metavar="LIST|START:STOP:N",
                     help="Lines in Hz (instead of --omega)."),
        click.option("--dofs", "dofs_text", default=None, help="Response dofs, labels or #N (default every model dof)."),
    )


@dataclasses.dataclass(frozen=True)
class Simulation:
    """What is simulated besides the lines: the quantity shown (``--kind``), the model's damping
    (``--damping``, as typed) and the noise (``--noise``, ``--noise-kind``, ``--seed``)."""

    quantity: str
    damping_text: str | None
    noise: float
    noise_kind: str
    seed: int


def simulation_group():
    """``--kind``, ``--damping``, ``--noise``, ``--noise-kind``, ``--seed`` -> ``simulation``: :class:`Simulation`."""
    return option_group(
        "Response and noise", "simulation", Simulation,
        click.option("--kind", "quantity", type=click.Choice(["receptance", "mobility", "accelerance"]),
                     default="receptance", show_default=True),
        damping_option,
        click.option("--noise", type=FiniteFloat(min=0, max=1e150), default=0.0, show_default=True,
                     help="Noise standard deviation."),
        click.option("--noise-kind", type=click.Choice(["relative", "absolute", "coherent"]), default="relative",
                     show_default=True),
        click.option("--seed", type=SEED, default=0, show_default=True, help="Seed of the noise."),
    )


@dataclasses.dataclass(frozen=True)
class FRFFiles:
    """The files ``frf`` writes besides its JSON: ``--uff`` and ``--test-data``."""

    uff_path: Path | None
    data_path: Path | None


def _frf_files_group():
    return option_group(
        "Model values and outputs", "files", FRFFiles,
        click.option("--uff", "uff_path", type=OUTPUT_FILE, default=None,
                     help="Also write the receptances as universal file datasets 58."),
        click.option("--test-data", "data_path", type=OUTPUT_FILE, default=None,
                     help="Also write them as test-data JSON (the 'frf' object), ready for frf-update."),
    )


@click.command("frf", cls=GroupedCommand)
@click.argument("model_path", metavar="MODEL", type=INPUT_FILE)
@excitation_group()
@simulation_group()
@_frf_files_group()
@outputs_group(report=False)
def frf_command(model_path, excitation: Excitation, simulation: Simulation, files: FRFFiles, outputs: Outputs):
    """Frequency response functions of MODEL to a force (receptance, mobility or accelerance)."""
    from ..frf import simulate
    from ..io.model_file import load_model

    ctx = Ctx(outputs.json_path)
    model = load_model(model_path)
    values = model_values(model, outputs.set_text)
    omega, force, response = excitation.resolve(model)
    if files.uff_path is not None:
        from ..io.uff.write import uff_dofs

        uff_dofs(list(force) + list(response or model.dofs), "frf --uff")
    damping = parse_damping(simulation.damping_text)
    sim = simulate(model, omega, force, response, values, damping, simulation.noise, simulation.noise_kind,
                   simulation.seed).with_quantity(simulation.quantity)
    payload = sim.to_json()
    _print_frf(ctx, model.name, sim, payload["notes"])
    if files.uff_path is not None:
        from ..io.uff import write_uff_frf

        write_uff_frf(files.uff_path, sim, nodes=model.nodes, model_name=model.name)
        ctx.console.print(f"receptances written to {files.uff_path} (datasets 58)")
    if files.data_path is not None:
        from ..io.results import write_json

        write_json(files.data_path, sim.test_data())
        ctx.console.print(f"test data written to {files.data_path}")
    outputs.emit(ctx, payload)


def _print_frf(ctx: Ctx, name: str, sim, notes) -> None:
    """|response| per line (about 20 lines, the first 6 dofs) and the notes."""
    H, omega = sim.responses(), sim.omega
    t = Table(title=f"{name}: {sim.quantity}, force {', '.join(f'{d}={fmt(v)}' for d, v in sim.force.items())}")
    t.add_column("omega (rad/s)", justify="right")
    shown = list(sim.dofs[:6])
    for d in shown:
        t.add_column(f"|{d}|", justify="right")
    step = max(1, omega.size // 20)
    for i in range(0, omega.size, step):
        t.add_row(fmt(omega[i]), *(fmt(abs(H[i, k])) for k in range(len(shown))))
    ctx.console.print(t)
    if len(sim.dofs) > len(shown) or step > 1:
        ctx.console.print(f"({omega.size} lines x {len(sim.dofs)} dofs; the table shows a sample)")
    for n in notes:
        ctx.console.print(f"note: {n}")


# ---------------------------------------------------------------------------------- frf-select
@dataclasses.dataclass(frozen=True)
class LineChoice:
    """What ``frf-select`` chooses among, as typed: the force, the candidate lines, how many,
    the measured dofs, the unknowns and the damping."""

    force_text: str
    cand_text: str
    n_lines: int
    dofs_text: str | None
    unknowns: str | None
    damping_text: str | None

    def resolve(self, model) -> dict:
        """The arguments of :func:`~femupdate.frf.select_frequencies` besides the model and its
        options: ``candidates`` (rad/s), ``n_lines``, ``force``, ``response``, ``unknowns``,
        ``damping``.

        Raises
        ------
        InputError
            Candidates, a force, dofs or damping that do not parse or that the model lacks.
        """
        return {"candidates": parse_omega(self.cand_text, "--candidates"), "n_lines": self.n_lines,
                "force": parse_force(self.force_text, model), "response": _model_dofs(self.dofs_text, model),
                "unknowns": _dofs(self.unknowns), "damping": parse_damping(self.damping_text)}


def _line_choice_group():
    return option_group(
        "Lines to choose", "choice", LineChoice,
        click.option("--force", "force_text", required=True, metavar="DOF[=AMP],..."),
        click.option("--candidates", "cand_text", required=True, metavar="LIST|START:STOP:N",
                     help="Candidate lines, rad/s."),
        click.option("--lines", "n_lines", type=click.IntRange(min=1), required=True, help="How many lines to choose."),
        click.option("--dofs", "dofs_text", default=None,
                     help="Measured dofs, labels or #N (kind sensitivity; default all)."),
        click.option("--unknowns", default=None, help="Parameters to identify (default: all not fixed)."),
        damping_option,
    )


def _selection_group():
    from ..options import SelectionOptions

    return option_group(
        "Selection", "selection", lambda kind, margin: SelectionOptions(equations=kind, margin=margin),
        click.option("--kind", type=click.Choice(["direct", "sensitivity"]), default="direct", show_default=True,
                     help="direct: complete data (eq. 28); sensitivity: measured at --dofs (eqs. 31-32)."),
        click.option("--margin", type=FiniteFloat(min=0), default=0.05, show_default=True,
                     help="Keep this relative eigenvalue distance from resonances."),
    )


@click.command("frf-select", cls=GroupedCommand)
@click.argument("model_path", metavar="MODEL", type=INPUT_FILE)
@_line_choice_group()
@_selection_group()
@outputs_group(report=False)
def frf_select_command(model_path, choice: LineChoice, selection, outputs: Outputs):
    """Choose spectral lines that make the FRF updating equations best conditioned (He 1993; Ren & Beards 1993)."""
    from ..frf.selection import select_frequencies
    from ..io.model_file import load_model

    ctx = Ctx(outputs.json_path)
    model = load_model(model_path)
    values = model_values(model, outputs.set_text)
    args = choice.resolve(model)
    sel = select_frequencies(model, args.pop("candidates"), args.pop("n_lines"), args.pop("force"), selection,
                             values=values, **args)
    c = ctx.console
    c.print(f"chosen lines (rad/s): {', '.join(fmt(w) for w in sel.omega)}  (condition number {sel.condition_number:.4g})")
    c.print(f"evenly spread lines {', '.join(fmt(w) for w in sel.uniform['omega_rad_s'])}: condition number "
            f"{sel.uniform['condition_number']:.4g}")
    if sel.excluded:
        c.print(f"{len(sel.excluded)} candidate(s) excluded near resonances")
    outputs.emit(ctx, sel.to_json())


# ---------------------------------------------------------------------------------- surface
def _range(text: str, what: str) -> np.ndarray:
    g = parse_omega(text, what)
    if g.size < 2:
        raise InputError(f"{what}: a grid needs at least two values")
    return g


@dataclasses.dataclass(frozen=True)
class Grid:
    """The grid of ``surface`` as typed: the two parameters, their values and the truth."""

    params_text: str
    x_text: str
    y_text: str
    truth_text: str | None

    def resolve(self, model) -> tuple[list[str], np.ndarray, np.ndarray, tuple[float, float] | None]:
        """The two names, their grids (each end a value the model file would accept) and the truth.

        Raises
        ------
        InputError
            A grid of fewer than two values, outside a parameter's bounds, or a truth without
            a value for each parameter (the option named).
        """
        names = [p.strip() for p in self.params_text.split(",") if p.strip()]
        x, y = _range(self.x_text, "--x"), _range(self.y_text, "--y")
        if len(names) == 2:
            for opt, grid, name in (("--x", x, names[0]), ("--y", y, names[1])):
                for v in (float(np.min(grid)), float(np.max(grid))):
                    try:
                        check_set(model, {name: v})
                    except InputError as exc:
                        raise InputError(str(exc).replace("--set:", f"{opt}: the grid of", 1)) from None
        truth = None
        if self.truth_text:
            t = parse_set(self.truth_text)
            missing = [n for n in names if n not in t]
            if missing:
                raise InputError(f"--truth: give a value for {', '.join(missing)}")
            truth = (t[names[0]], t[names[1]])
        return names, x, y, truth


def _grid_group():
    return option_group(
        "Grid", "grid", Grid,
        click.option("--params", "params_text", required=True, metavar="P1,P2", help="The two parameters of the grid."),
        click.option("--x", "x_text", required=True, metavar="START:STOP:N", help="Grid of the first parameter."),
        click.option("--y", "y_text", required=True, metavar="START:STOP:N", help="Grid of the second parameter."),
        click.option("--truth", "truth_text", default=None, metavar="P1=V1,P2=V2", help="Mark the true solution."),
    )


@dataclasses.dataclass(frozen=True)
class SurfaceResidual:
    """Which residual ``surface`` maps, as typed: ``--kind``, ``--residual``, ``--ref-dof``, ``--damping``."""

    kind: str
    residual: str
    ref_dof: str | None
    damping_text: str | None

    def surface(self, model, data, data_path, names, x, y, values, truth):
        """The :class:`~femupdate.frf.surfaces.Surface` of the data over the grid.

        Raises
        ------
        InputError
            FRFs or modes missing from the data; a bad ``--ref-dof`` or ``--damping``.
        """
        from ..frf.surfaces import frf_surface, modal_surface
        from ..updating.frf import frf_data

        if self.kind == "frf":
            return frf_surface(model, frf_data(data), names, x, y, values, parse_damping(self.damping_text, data),
                               self.residual, truth=truth)
        if not data.modes:
            raise InputError(f"{data_path}: no modes for a modal surface")
        (ref,) = option_dofs([self.ref_dof], model, "--ref-dof") if self.ref_dof else (None,)
        return modal_surface(model, data, names, x, y, values, ref, truth=truth)


def _surface_residual_group():
    return option_group(
        "Residual", "residual", SurfaceResidual,
        click.option("--kind", type=click.Choice(["frf", "modal"]), default="frf", show_default=True,
                     help="frf: eq. 34 from the data's FRFs; modal: eq. 33 from its modes."),
        click.option("--residual", type=click.Choice(["linear", "relative", "log"]), default="linear", show_default=True),
        click.option("--ref-dof", default=None,
                     help="Modal: scale shapes to 1 here, a label or #N (default first measured dof)."),
        damping_option,
    )


def _figure_group():
    return option_group(
        "Model values and outputs", "plot_path", lambda plot_path: plot_path,
        click.option("--plot", "plot_path", type=OUTPUT_FIGURE, default=None,
                     help="Write the surface and contour figure (PNG)."),
    )


@click.command("surface", cls=GroupedCommand)
@click.argument("model_path", metavar="MODEL", type=INPUT_FILE)
@click.argument("data_path", metavar="DATA", type=INPUT_FILE)
@_grid_group()
@_surface_residual_group()
@_figure_group()
@outputs_group(report=False)
def surface_command(model_path, data_path, grid: Grid, residual: SurfaceResidual, plot_path, outputs: Outputs):
    """Residual surface over two parameters (paper Figures 5-7): grid minimum and local minima."""
    from ..io.model_file import load_model
    from ..io.testdata_json import load_testdata

    ctx = Ctx(outputs.json_path)
    model = load_model(model_path)
    values = model_values(model, outputs.set_text)
    data = load_testdata(data_path, model)
    names, x, y, truth = grid.resolve(model)
    surf = residual.surface(model, data, data_path, names, x, y, values, truth)
    summ = surf.summary()
    m = summ["minimum"]
    ctx.console.print(f"{surf.residual} over {names[0]} x {names[1]} ({x.size} x {y.size}): minimum {m['value']:.4g} at "
                      f"{names[0]}={fmt(m[names[0]])}, {names[1]}={fmt(m[names[1]])}; {summ['local_minima']} interior "
                      f"local minima (8 neighbours), {summ['edge_minima']} on the border, {summ['singular_points']} "
                      "points exactly on a resonance")
    if plot_path is not None:
        from ..plot.frf import save_surface_figure

        save_surface_figure(plot_path, surf, f"log10 r, {surf.residual}")
        ctx.console.print(f"figure written to {plot_path}")
    outputs.emit(ctx, surf.to_json())


__all__ = ["parse_omega", "parse_force", "parse_damping", "damping_option", "frf_line_options", "reciprocity_option",
           "apply_reciprocity", "frf_options", "frf_command", "frf_select_command", "surface_command", "Excitation",
           "Simulation", "LineChoice", "Grid", "SurfaceResidual"]
