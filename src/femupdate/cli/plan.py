"""``femupdate plan``: where to put the sensors so that the update is unique and well determined
(docs/planning.md); the result writes its own JSON (kind ``plan``) and, with ``--uff``, the
universal file the test lab imports."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import click
import numpy as np
from rich.table import Table

from .._errors import InputError
from ..options import (DESIGN_CRITERIA, PLACEMENT_CRITERIA, TARGET_METHODS, PlacementOptions, TargetOptions)
from ..options.planning import TAM_CHOICES
from ._common import INPUT_FILE, SEED, Ctx, FiniteFloat, fmt, model_values
from ._groups import GroupedCommand, option_group
from .outputs import Outputs, outputs_group


@dataclasses.dataclass(frozen=True)
class SensorSpec:
    """The candidates, fixed sensors, parameters and box as typed (:func:`sensors_group`)."""

    candidates_text: str | None
    candidates_file: str | None
    fixed_text: str | None
    params_text: str | None
    box_text: str | None

    def candidates(self) -> list[str] | None:
        """The candidate dofs or nodes (``--candidates`` or ``--candidates-file``; None: the model's)."""
        from ..planning import read_candidates

        if self.candidates_text and self.candidates_file:
            raise InputError("--candidates and --candidates-file: give one of the two")
        if self.candidates_file:
            return read_candidates(self.candidates_file)
        return _items(self.candidates_text) or None

    def fixed(self) -> list[str]:
        return _items(self.fixed_text)

    def params(self) -> list[str] | None:
        return _items(self.params_text) or None

    def box(self) -> dict[str, tuple[float, float]]:
        """``--box k1=100:5000,k2=...`` as {name: (lower, upper)}, lower < upper."""
        out = {}
        for item in _items(self.box_text):
            name, _, rng = item.partition("=")
            lo, sep, hi = rng.partition(":")
            try:
                a, b = float(lo), float(hi)
            except ValueError:
                a = b = math.nan
            if not sep or not (math.isfinite(a) and math.isfinite(b)):
                raise InputError(f"--box: {item!r} is not name=lower:upper (e.g. k1=100:5000)")
            if not a < b:
                raise InputError(f"--box: parameter {name.strip()} has lower {a:g} >= upper {b:g}; give lower < upper")
            out[name.strip()] = (a, b)
        return out


def _items(text: str | None) -> list[str]:
    return [t.strip() for t in (text or "").replace(";", ",").split(",") if t.strip()]


def sensors_group():
    """``--candidates``, ``--candidates-file``, ``--fixed``, ``--params``, ``--box`` -> ``sensors``: :class:`SensorSpec`."""
    return option_group(
        "Sensors and parameters", "sensors", SensorSpec,
        click.option("--candidates", "candidates_text", default=None, metavar="LIST",
                     help="Candidate dofs (uniaxial, e.g. 2:x,3:y) or nodes (--triaxial, e.g. 2,3). Default: every "
                          "translational dof (node) of the model."),
        click.option("--candidates-file", type=INPUT_FILE, default=None,
                     help="Candidates from a file: a JSON list, or one label per line (# comments)."),
        click.option("--fixed", "fixed_text", default=None, metavar="LIST",
                     help="Sensors that are always in the plan, spelled as the candidates."),
        click.option("--params", "params_text", default=None, metavar="LIST",
                     help="The parameters the test is to identify (default: every parameter not fixed)."),
        click.option("--box", "box_text", default=None, metavar="LIST",
                     help="Parameter box of the random points, name=lower:upper,... (default: the model's bounds, "
                          "else +-50 %)."),
    )


def targets_group():
    """``--target``, ``--modes``, ``--band``, ``--direction``, ``--min-fraction`` -> ``targets``: TargetOptions."""
    def build(method, n_modes, band, direction, min_fraction):
        band_hz = None
        if band:
            lo, sep, hi = band.partition(":")
            try:
                band_hz = (float(lo), float(hi))
            except ValueError:
                sep = ""
            if not sep:
                raise InputError(f"--band: {band!r} is not lower:upper in Hz (e.g. 5:200)")
            if not band_hz[0] < band_hz[1]:
                raise InputError(f"--band: the lower frequency {band_hz[0]:g} Hz must be below the upper "
                                 f"{band_hz[1]:g} Hz")
        if method == "lowest" and n_modes is None and band_hz is None:
            n_modes = 3
        return TargetOptions(method=method, n_modes=n_modes, band_hz=band_hz, direction=direction,
                             min_fraction=min_fraction)

    return option_group(
        "Target modes", "targets", build,
        click.option("--target", "method", type=click.Choice(list(TARGET_METHODS)), default="lowest",
                     show_default=True,
                     help="lowest: the lowest --modes; mass: effective modal mass along --direction; energy: kinetic "
                          "energy at the candidates."),
        click.option("--modes", "n_modes", type=click.IntRange(min=1), default=None,
                     help="Number of target modes (lowest; default 3), or the most kept (mass, energy)."),
        click.option("--band", default=None, metavar="LO:HI", help="Only modes in this band, Hz."),
        click.option("--direction", type=click.Choice(["x", "y", "z"]), default=None,
                     help="Direction of the influence vector (--target mass)."),
        click.option("--min-fraction", type=FiniteFloat(0, 1, min_open=True), default=0.01, show_default=True,
                     help="Smallest effective-mass or kinetic-energy fraction of a target mode."),
    )


def placement_group():
    """The placement options -> ``placement``: :class:`~femupdate.options.PlacementOptions`."""
    def build(criterion, n_sensors, triaxial, design, points, max_condition, max_automac, std_eigenvalue, std_shape,
              monte_carlo, exchange, restarts, seed, exhaustive_limit):
        return PlacementOptions(criterion=criterion, n_sensors=n_sensors, kind="triaxial" if triaxial else "uniaxial",
                                design=design, points=points, max_condition=max_condition, max_automac=max_automac,
                                std_eigenvalue=std_eigenvalue, std_shape=std_shape, monte_carlo=monte_carlo,
                                exchange=exchange, restarts=restarts, seed=seed, exhaustive_limit=exhaustive_limit)

    return option_group(
        "Placement", "placement", build,
        click.option("--criterion", type=click.Choice(list(PLACEMENT_CRITERIA)), default="identifiability",
                     show_default=True,
                     help="identifiability of the parameters first (then --design), or a classical criterion: "
                          "effective independence, EfI-DPR, kinetic energy, MAC."),
        click.option("--sensors", "n_sensors", type=click.IntRange(min=1), default=None,
                     help="Sensors in the plan, fixed ones included (default: the smallest identifiable plan; "
                          "classical criteria: the number of target modes)."),
        click.option("--triaxial", is_flag=True, help="A sensor measures the three translations of a node."),
        click.option("--design", type=click.Choice(list(DESIGN_CRITERIA)), default="d", show_default=True,
                     help="After identifiability: d (log det F) or a (trace of F^-1)."),
        click.option("--points", type=click.IntRange(min=0), default=10, show_default=True,
                     help="Random points of the parameter box checked besides the nominal one."),
        click.option("--max-condition", type=FiniteFloat(min=1), default=1e6, show_default=True,
                     help="Largest condition number of the value-scaled sensitivity matrix counted as well "
                          "conditioned."),
        click.option("--max-automac", type=FiniteFloat(0, 1, min_open=True), default=1.0, show_default=True,
                     help="Largest off-diagonal auto-MAC of the target modes at the sensors of an identifiable plan "
                          "(1: no requirement)."),
        click.option("--std-eigenvalue", type=FiniteFloat(min=0), default=0.002, show_default=True,
                     help="Relative standard deviation of the measured eigenvalues (twice the frequencies')."),
        click.option("--std-shape", type=FiniteFloat(min=0), default=0.01, show_default=True,
                     help="Standard deviation of the unit-scaled shape entries."),
        click.option("--monte-carlo", type=click.IntRange(min=0), default=0, show_default=True,
                     help="Noisy updates that check the predicted standard deviations (0: none)."),
        click.option("--exchange/--no-exchange", default=True, show_default=True,
                     help="Improve the greedy (or eliminated) set by exchanges."),
        click.option("--restarts", type=click.IntRange(min=0), default=0, show_default=True,
                     help="Random starting sets of the exchange."),
        click.option("--seed", type=SEED, default=0, show_default=True,
                     help="Seed of the box's points, the restarts and the Monte Carlo noise."),
        click.option("--exhaustive-limit", type=click.IntRange(min=0), default=0, show_default=True,
                     help="With --sensors: score every candidate set when there are at most this many (the exact "
                          "optimum) instead of greedy selection and exchange."),
    )


def pretest_group():
    """``--information-gain``, ``--exciters``, ``--std-frf``, ``--damping-ratio``, ``--tam``,
    ``--sensor-mass`` -> ``pretest``: a dict of :class:`~femupdate.options.PlacementOptions` fields."""
    def build(information_gain, n_exciters, std_frf, damping_ratio, tam, sensor_mass):
        return {"information_gain": information_gain, "n_exciters": n_exciters, "std_frf": std_frf,
                "damping_ratio": damping_ratio, "tam": tam, "sensor_mass": sensor_mass}

    return option_group(
        "Prior, exciters and pretest", "pretest", build,
        click.option("--information-gain", is_flag=True,
                     help="Judge sensor sets by the expected information gain with the parameters' priors (Laplace: "
                          "1/2 log det(I + S_prior F)); uniform within the bounds where no prior is declared."),
        click.option("--exciters", "n_exciters", type=click.IntRange(min=0), default=0, show_default=True,
                     help="Exciters of an FRF test to place for the chosen sensors (driving points that excite every "
                          "target mode, FRF Fisher information full rank)."),
        click.option("--std-frf", type=FiniteFloat(min=0, min_open=True), default=0.01, show_default=True,
                     help="Noise floor of the receptances, relative to the largest (exciter placement)."),
        click.option("--damping-ratio", type=FiniteFloat(min=0, min_open=True), default=0.01, show_default=True,
                     help="Modal damping ratio of the simulated receptances (exciter placement)."),
        click.option("--tam", type=click.Choice(list(TAM_CHOICES)), default="guyan", show_default=True,
                     help="Test-analysis model on the measured dofs for the pretest orthogonality checks."),
        click.option("--sensor-mass", type=FiniteFloat(min=0), default=0.0, show_default=True,
                     help="Mass of one accelerometer, kg: the frequency shifts the sensors cause (0: not computed)."),
    )


@click.command(cls=GroupedCommand)
@click.argument("model_path", metavar="MODEL", type=INPUT_FILE)
@targets_group()
@sensors_group()
@placement_group()
@pretest_group()
@outputs_group(uff="Write the sensor layout as a universal file the test lab imports (datasets 164, 2420, 15, 2411, "
                   "82).")
def plan(model_path, targets: TargetOptions, sensors: SensorSpec, placement: PlacementOptions, pretest: dict,
         outputs: Outputs):
    """Plan the test: sensors that identify MODEL's parameters, with their predicted uncertainty.

    Chooses target modes, places the sensors (identifiability of the parameters first, or a
    classical criterion), and predicts the parameters' standard deviations, the auto-MAC and the
    uniqueness verdict; --monte-carlo checks them with noisy updates.
    """
    from ..io.model_file import load_model
    from ..planning import candidates as make_candidates, plan as make_plan

    ctx = Ctx(outputs.json_path)
    placement = dataclasses.replace(placement, **pretest)
    model = load_model(model_path)
    values = model_values(model, outputs.set_text)
    cand, fixed = sensors.candidates(), sensors.fixed()
    if values is not None:
        model = model.with_values(values)
    make_candidates(model, cand, placement.kind, fixed, what="--candidates-file" if sensors.candidates_file
                    else "--candidates")  # the candidates named as the command line gave them
    try:
        res = make_plan(model, params=sensors.params(), candidates=cand, fixed=fixed, box=sensors.box() or None,
                        targets=targets, placement=placement)
    except InputError as exc:
        msg = str(exc)
        for field, opt in (("sensors:", "--sensors:"), ("box:", "--box:"), ("params:", "--params:"),
                           ("exciters:", "--exciters:"), ("prior:", "--information-gain:"),
                           ("candidates:", ("--candidates-file:" if sensors.candidates_file else "--candidates:")
                            if cand is not None else "candidates:")):
            if msg.startswith(field):
                msg = opt + msg[len(field):]
        raise InputError(msg) from None
    from ._common import model_segments

    segs = model_segments(model_path) if Path(model_path).suffix.lower() == ".toml" else None  # supports too
    if segs is not None:
        res = dataclasses.replace(res, segments=[[str(a), str(b)] for a, b in np.asarray(segs).tolist()])
    _print(ctx.console, model, res)
    _print_extras(ctx.console, res)
    if outputs.uff_path is not None:
        from ..io.plan_uff import write_plan_uff

        info = write_plan_uff(outputs.uff_path, res)
        ctx.console.print(f"universal file: {outputs.uff_path} ({len(info['nodes'])} node(s); datasets "
                          f"{', '.join(map(str, info['datasets']))})"
                          + ("; nodes placed on the x axis (the model has no coordinates)" if info["placed"] else ""))
    payload = res.to_json()
    if outputs.report_path is not None:
        from ._common import write_report_output

        write_report_output(ctx, outputs.report_path, payload, model=model, model_path=model_path)
    outputs.emit(ctx, payload)


def _print(c, model, res) -> None:
    """The target modes, the sensors, the figures at the points, the predictions and the comparison."""
    t = res.target
    c.print(f"{model.name}: {len(res.parameters)} parameter(s) to identify ({', '.join(res.parameters)}); target modes "
            + ", ".join(f"{i} ({fmt(f)} Hz)" for i, f in zip(t["modes"], t["frequencies_hz"])))
    c.print(f"{len(res.sensors)} {res.sensor_kind} sensor(s) by {res.criterion}: "
            + "; ".join(",".join(s) for s in res.sensors)
            + (f" (greedy set improved by {res.swaps} exchange(s))" if res.swaps else ""))
    sc = res.score
    conds = [v for v in sc["conditions"] if v is not None]
    worst = "inf" if len(conds) < len(sc["conditions"]) else f"{max(conds):.3g}"
    c.print(f"rank {sc['ranks'][0]} of {len(res.parameters)} at the nominal point, smallest rank {sc['min_rank']} over "
            f"{len(sc['ranks'])} point(s) of the box, worst condition {worst}")
    tab = Table(title=f"predicted standard deviations (noise: eigenvalue {res.noise['eigenvalue']:g} relative, shape "
                      f"{res.noise['shape']:g})")
    for col in ("parameter", "nominal", "std", "relative"):
        tab.add_column(col, justify="left" if col == "parameter" else "right")
    mc = res.monte_carlo
    if mc:
        tab.add_column(f"Monte Carlo std ({mc['runs']} runs)", justify="right")
    for k, name in enumerate(res.parameters):
        s, r = res.predicted_std[name], res.relative_std[name]
        row = [name, fmt(res.nominal[name]), "inf" if s is None or not math.isfinite(s) else fmt(s),
               "-" if r is None or not math.isfinite(r) else f"{r:.3%}"]
        if mc:
            row.append(fmt(float(mc["std"][k])))
        tab.add_row(*row)
    c.print(tab)
    if mc:
        c.print(f"Monte Carlo: {mc['converged']}/{mc['runs']} updates converged; std / predicted within "
                f"{min(mc['ratio']):.3f}..{max(mc['ratio']):.3f} (sampling error of a std: {mc['sampling_error']:.3f}); "
                f"rms relative parameter error {mc['rms_relative_error']:.3%}")
    u = res.uniqueness
    c.print(f"largest off-diagonal auto-MAC {res.automac_max:.3f}")
    c.print(f"expected verdict: {u['verdict']} - {u['explanation']}")
    lb = u["counting_lower_bound"]["n_min"]
    c.print(f"counting lower bound (mn >= L, n > 1): {lb if lb is not None else 'none'} measured dof(s); this plan "
            f"measures {len(res.dofs)}" + (f"; layout rank bound {u['layout_rank_bound']}"
                                           if u["layout_rank_bound"] is not None else ""))
    if res.comparison:
        ct = Table(title=f"other criteria with {len(res.sensors)} sensor(s)")
        with_mc = any("monte_carlo" in v for v in res.comparison.values())
        for col in ("criterion", "sensors", "identifiable", "rank", "mean relative std") + (
                ("Monte Carlo rms error",) if with_mc else ()):
            ct.add_column(col)
        for crit, v in res.comparison.items():
            if "error" in v:
                ct.add_row(crit, v["error"][:60], *(["-"] * (4 if with_mc else 3)))
                continue
            m = v["mean_relative_std"]
            row = [crit, "; ".join(",".join(s) for s in v["sensors"]), "yes" if v["identifiable"] else "no",
                   str(v["rank"]), "inf" if m is None or not math.isfinite(m) else f"{m:.3%}"]
            if with_mc:
                row.append(f"{v['monte_carlo']['rms_relative_error']:.3%}" if "monte_carlo" in v else "not run")
            ct.add_row(*row)
        c.print(ct)


def _print_extras(c, res) -> None:
    """The prior, the exciters and the pretest correlation, where the plan has them."""
    if res.prior:
        c.print("expected information gain (Laplace) with prior relative std "
                + ", ".join(f"{k} {v:.3g}" for k, v in res.prior.items()) + f": {res.score['design']:.4g} nats")
    ex = res.exciters
    if ex:
        sc = ex["score"]
        c.print(f"{len(ex['dofs'])} exciter(s): {', '.join(ex['dofs'])} (every target mode excited: "
                f"{'yes' if ex['excites_all_modes'] else 'no'}; FRF Fisher rank {sc['ranks'][0]} of "
                f"{len(res.parameters)}, smallest {sc['min_rank']} over the points, worst condition "
                f"{_worst(sc['conditions'])}); best optimum driving point (ODP) {ex['best_odp']}")
    pre = res.pretest or {}
    t = pre.get("tam")
    if t and "error" in t:
        c.print(f"TAM ({t['method']}): not built - {t['error']}")
    elif t:
        tab = Table(title=f"pretest: {t['method']} TAM on the {len(t['dofs'])} measured dof(s)")
        for col in ("mode", "full Hz", "TAM Hz", "error", "cross-orthogonality"):
            tab.add_column(col, justify="right")
        paired = t["paired_targets"]
        for k, j in enumerate(res.target["modes"]):
            f_t = t["tam_frequencies_hz"][k]
            pos = paired.index(k) if k in paired else None
            tab.add_row(str(j), fmt(t["full_frequencies_hz"][k]), "-" if f_t is None or f_t != f_t else fmt(f_t),
                        "-" if pos is None else f"{t['frequency_error'][k]:+.3%}",
                        "-" if pos is None else f"{t['cross_orthogonality'][pos][pos]:.3f}")
        c.print(tab)
        c.print(f"self-orthogonality of the target modes with the TAM mass: largest off-diagonal "
                f"{t['self_max_offdiag']:.3f} (held to 0.1 in practice); cross-orthogonality TAM vs full modes: smallest "
                f"diagonal {t['cross_min_diag']:.3f}, largest off-diagonal {t['cross_max_offdiag']:.3f}")
    ml = pre.get("mass_loading")
    if ml:
        c.print(f"mass loading ({ml['n_sensors']} sensor(s) of {ml['sensor_mass']:g} kg, {ml['total_mass']:g} kg on the "
                "translations): " + "; ".join(
                    f"mode {j} {fmt(f0)} -> {fmt(f1)} Hz ({r:+.3%}, first order {r1:+.3%})" for j, f0, f1, r, r1 in
                    zip(res.target["modes"], ml["frequencies_hz"], ml["loaded_frequencies_hz"], ml["relative_shift"],
                        ml["first_order_relative_shift"])))


def _worst(conds) -> str:
    finite = [v for v in conds if v is not None and v != float("inf")]
    return "inf" if len(finite) < len(conds) else f"{max(finite):.3g}"


__all__ = ["plan", "SensorSpec", "sensors_group", "targets_group", "placement_group"]
