"""Damping in the command line's results: the table of the JSON ``damping_ratio`` fields (the
fields themselves and the Rayleigh damping fitted to measured damping ratios are
:mod:`femupdate.recording`'s)."""

from __future__ import annotations

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
    """A damped model's update: the damping parameters updated (± std) or held, and per paired
    mode the measured and model damping ratios and the model mode's MPC."""
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
