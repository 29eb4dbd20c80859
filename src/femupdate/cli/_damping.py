"""Damping in the command line's results: the table of the JSON ``damping_ratio`` fields (the
fields themselves and the Rayleigh damping fitted to measured damping ratios are
:mod:`femupdate.recording`'s)."""

from __future__ import annotations

from pathlib import Path

from rich.table import Table


def print_damping(console, data, fields: dict | None) -> None:
    """The damping table (test ratio ± std, the model's, the difference) and the Rayleigh fit."""
    if not fields:
        return
    from ._common import fmt

    t = Table(title="modal damping ratios")
    for col in ("test", "f test [Hz]", "ζ test", "std", "ζ model", "model - test"):
        t.add_column(col, justify="right")
    f = data.frequencies_hz
    for i, (zt, sd, zm) in enumerate(zip(fields["test"], fields["std"], fields["model"])):
        t.add_row(str(i + 1), fmt(f[i]), "-" if zt is None else f"{zt:.4g}", "-" if sd is None else f"{sd:.2g}",
                  "-" if zm is None else f"{zm:.4g}", "-" if zt is None or zm is None else f"{zm - zt:+.3g}")
    console.print(t)
    fit = fields["rayleigh_fit"]
    if fit:
        console.print(f"Rayleigh damping fitted to the {fit['n_modes']} measured damping ratios: alpha={fit['alpha']:.6g}, "
                      f"beta={fit['beta']:.6g} (rms misfit {fit['rms_error']:.3g}); use it for FRFs with --damping "
                      "fit", markup=False)


def print_damped(console, res) -> None:
    """A damped model's update: the damping parameters updated (± std) or held, per paired mode
    the measured and model damping ratios and the model mode's MPC, and the complexity table."""
    from ._common import fmt

    d = res.damping
    updated = d.get("parameters", [])
    held = [n for n in d.get("values", {}) if n not in updated]
    if updated:
        console.print("damping parameters updated: " + ", ".join(
            f"{n} = {fmt(d['values'][n])}" + ("" if d["std"].get(n) is None else f" ± {d['std'][n]:.3g}")
            for n in updated), markup=False)
    if held:
        console.print("damping parameters held: " + ", ".join(f"{n} = {fmt(d['values'][n])}" for n in held), markup=False)
    ratios = d.get("damping_ratios")
    if not ratios:
        return
    t = Table(title="damping ratios of the paired modes")
    for col in ("test", "model", "ζ test", "ζ model", "model - test", "MPC model"):
        t.add_column(col, justify="right")
    for (k, j, _), zt, zm, mpc in zip(res.pairs, ratios["test"], ratios["model"], d.get("mpc", [])):
        t.add_row(str(k + 1), str(j + 1), "-" if zt is None else f"{zt:.5g}", f"{zm:.5g}",
                  "-" if zt is None else f"{zm - zt:+.3g}", f"{mpc:.4f}")
    console.print(t)
    print_complexity(console, res.pairs, d.get("complexity"))


def print_complexity(console, pairs, cx: dict | None) -> None:
    """Per paired mode the MPC and MPD of the test shape and of the model's at the same dofs."""
    if not cx or not any(v is not None for v in cx["test"]["mpc"]):
        return

    def f(v, spec):
        return "-" if v is None else format(v, spec)

    t = Table(title="complexity of the paired shapes at the measured dofs (MPC 1 and MPD 0° for a real mode)")
    for col in ("test", "model", "MPC test", "MPC model", "MPD test [°]", "MPD model [°]"):
        t.add_column(col, justify="right")
    for i, (k, j, _) in enumerate(pairs):
        t.add_row(str(k + 1), str(j + 1), f(cx["test"]["mpc"][i], ".4f"), f(cx["model"]["mpc"][i], ".4f"),
                  f(cx["test"]["mpd_deg"][i], ".2f"), f(cx["model"]["mpd_deg"][i], ".2f"))
    console.print(t)


def damped_model(model_path):
    """The :class:`~femupdate.damping.DampedModel` of a model file with a ``[damping]`` table, else None."""
    from ..io.model_file import read_toml

    if Path(model_path).suffix.lower() != ".toml" or "damping" not in read_toml(model_path):
        return None
    from ..damping import load_damped_model

    return load_damped_model(model_path)


def view(damped):
    """The engine's view of a damped model (:class:`~femupdate.damping.view.DampedView`)."""
    from ..damping.view import DampedView

    return DampedView(damped)


def model_part(ctx, damped, res, outputs):
    """The result restricted to the model's own parameters for the files written from it (the
    updated model file, the tables, the modes): the damping parameters' values are in the JSON."""
    import dataclasses

    own = set(damped.model.parameter_names)
    if outputs.write_model_path or outputs.csv_dir or outputs.uff_path or outputs.write_back_dir:
        ctx.console.print("the damping parameters' updated values are in the JSON ('damping'), not written into the "
                          "model file, the tables or the deck in this version")
    names = tuple(n for n in res.names if n in own)
    keep = [j for j, n in enumerate(res.names) if n in own]
    d = res.diagnostics
    if d is not None:
        d = dataclasses.replace(d, std=d.std[keep])
    return dataclasses.replace(res, names=names, x=res.x[keep],
                               parameters={n: v for n, v in res.parameters.items() if n in own}, diagnostics=d)


def damped_figures(ctx, damped, data, res, plot_dir) -> None:
    """The figures of a damped model's update: convergence and the MAC of the complex shapes
    (modes), the FRF overlay of the damped receptances at the solution (FRFs: the peaks)."""
    import numpy as np

    names: list[str] = []
    values = {n: v for n, v in res.parameters.items() if n in damped.parameter_names}
    if data.modes and res.pairs:
        from ..damping import complex_modes
        from ..plot.updating import save_update_figures

        cm = complex_modes(damped, values=values, n_modes=min(2 * len(data.modes) + 4, damped.n_dofs) if
                           damped.n_dofs > 400 else None)
        mac = np.zeros((len(data.modes), cm.n_modes))
        for k, m in enumerate(data.modes):
            if m.has_shape and len(m.dofs) >= 2:
                U = cm.shapes[damped.model.dof_index(m.dofs), :]
                v = np.asarray(m.shape, complex)
                mac[k] = np.abs(np.conj(v) @ U) ** 2 / (np.vdot(v, v).real * np.sum(np.abs(U) ** 2, axis=0))
        names += save_update_figures(plot_dir, res.history, mac)
    if hasattr(res, "frac") and data.frf is not None:
        from ..damping.frf import damped_response
        from ..plot.frf import save_frf_update_figures

        frf = data.frf
        used = np.isin(frf.omega, res.omega)
        xa, _ = damped_response(damped, frf.omega[used], dict(frf.force), frf.dofs, values)
        names += [n for n in save_frf_update_figures(plot_dir, res.history, frf.omega[used], frf.dofs,
                                                     frf.response[used], xa) if n not in names]
    ctx.console.print(f"figures: {', '.join(str(plot_dir / n) for n in names)}")
