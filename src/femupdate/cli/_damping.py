"""Damping in the command line's results: the Rayleigh damping fitted to measured damping
ratios, the JSON ``damping_ratio`` fields and their table."""

from __future__ import annotations

import numpy as np
from rich.table import Table


def fitted_damping(data):
    """The Rayleigh damping (α, β ≥ 0) that fits the test modes' damping ratios
    (:meth:`femupdate.frf.Damping.rayleigh_fit`, weighted by their standard deviations when every
    one has one): ``(Damping, {"alpha", "beta", "rms_error", "n_modes"})``, or ``(None, None)``
    when fewer than two modes carry a damping ratio."""
    from ..frf import Damping

    use = [m for m in data.modes if m.damping_ratio is not None and m.eigenvalue > 0]
    if len(use) < 2:
        return None, None
    std = [m.std_damping_ratio for m in use]
    fit, resid = Damping.rayleigh_fit([np.sqrt(m.eigenvalue) for m in use], [m.damping_ratio for m in use],
                                      None if any(v is None for v in std) else std)
    return fit, {"alpha": fit.alpha, "beta": fit.beta, "rms_error": float(np.sqrt(np.mean(resid ** 2))),
                 "n_modes": len(use)}


def damping_fields(data, paired_hz: dict[int, float], damping=None) -> dict | None:
    """The JSON ``damping_ratio`` of a correlation or update: per test mode the measured ratio
    (``test``) and its standard deviation (``std``), the model's modal damping ratio at its paired
    mode (``model``: Rayleigh α/2ω + βω/2 plus η/2; null when the model is undamped or the mode
    unpaired), and the Rayleigh damping fitted to the measured ratios (``rayleigh_fit``, with two
    or more); None when neither the data nor the model have damping.

    Parameters
    ----------
    data : TestData
        The test modes.
    paired_hz : dict of int to float
        Test mode (0-based) -> the frequency (Hz) of the model mode it is paired with.
    damping : Damping, optional
        The model's damping (``--damping``).
    """
    zeta = data.damping_ratios
    damped = damping is not None and not damping.undamped
    if not data.modes or (np.all(np.isnan(zeta)) and not damped):
        return None
    model: list[float | None] = [None] * len(data.modes)
    if damped:
        for i, f in paired_hz.items():
            model[i] = float(damping.modal_damping_ratio(2 * np.pi * f))
    _, fit = fitted_damping(data)
    return {"test": [None if np.isnan(z) else float(z) for z in zeta],
            "std": [m.std_damping_ratio for m in data.modes], "model": model,
            "model_damping": damping.as_dict() if damped else None, "rayleigh_fit": fit}


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
