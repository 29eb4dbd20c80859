"""The JSON fields that several kinds of result share: parameter units and bounds, flags on
identified values, the diagnostics' identifiability keys, the test data's units, and the
comparison of measured and model damping ratios.  The result classes build their JSON from these
(:mod:`femupdate.serialise`); docs/file-formats.md describes every key.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np


def parameter_fields(model, names: Sequence[str] | None = None) -> dict:
    """``parameter_units`` {name: unit or null} (SI, from the element properties they stand for;
    null for matrix models) and ``bounds`` {name: [lower, upper]} (null for an infinite bound).

    Parameters
    ----------
    model : Model
    names : sequence of str, optional
        The parameters to describe (default: all of the model's).
    """
    names = model.parameter_names if names is None else names
    par = {p.name: p for p in model.parameters}
    return {"parameter_units": {n: par[n].unit or None for n in names},
            "bounds": {n: list(par[n].bounds) for n in names}}


def flags(model, parameters: Mapping[str, float], names: Sequence[str] | None) -> list[dict]:
    """Flags on identified values: not > 0 where they must be, outside or on their bounds
    (:func:`femupdate.flags.parameter_flags`); results list them under ``flags``."""
    from .flags import parameter_flags

    return parameter_flags(model, parameters, names)


def diagnostics_fields(names: Sequence[str], d) -> dict:
    """The ``diagnostics`` object of an iterative result (:class:`~femupdate.updating.Diagnostics`)."""
    return {"singular_values": d.singular_values, "condition_number": d.condition_number, "rank": d.rank,
            "poorly_determined": d.poorly_determined, "std": dict(zip(names, d.std)), "covariance": d.covariance,
            "n_residuals": d.n_residuals, "n_parameters": d.n_parameters, **diagnostics_extra(names, d)}


def diagnostics_extra(names: Sequence[str], d) -> dict:
    """The keys of :class:`~femupdate.updating.Diagnostics` for the bounds and the parameters the
    data cannot move: ``absolute``, ``at_bounds`` {name: ``"lower"`` | ``"upper"``},
    ``n_at_bounds``, ``free``, ``poorly_determined_reasons`` {name: reason}, ``relative_std``
    {name: value}; with the noise analysed, ``noise`` (one record per noise component),
    ``std_dof`` {name: effective dof, ``"inf"`` for stated noise only} and ``model_error``."""
    out = {"absolute": d.absolute, "at_bounds": dict(d.at_bounds), "n_at_bounds": d.n_at_bounds,
           "free": list(d.free), "poorly_determined_reasons": dict(d.poorly_determined_reasons),
           "relative_std": dict(zip(names, d.relative_std))}
    if getattr(d, "noise", None):  # what the standard deviations rest on (femupdate.updating.noise)
        dof = np.asarray(d.std_dof, float)
        out["noise"] = list(d.noise)
        out["std_dof"] = {n: "inf" if np.isposinf(v) else None if np.isnan(v) else float(v)
                          for n, v in zip(names, dof)}
        out["model_error"] = dict(d.model_error) or None
    return out


def data_fields(data) -> dict:
    """The keys a result takes from its test data: ``units`` (a universal file's dataset 164, or
    the JSON's ``units``) when the data state them."""
    return {"units": dict(data.units)} if data is not None and data.units else {}


def fitted_damping(data):
    """The Rayleigh damping (α, β ≥ 0) that fits the test modes' damping ratios
    (:meth:`femupdate.frf.Damping.rayleigh_fit`, weighted by their standard deviations when every
    one has one): ``(Damping, {"alpha", "beta", "rms_error", "n_modes"})``, or ``(None, None)``
    when fewer than two modes carry a damping ratio."""
    from .frf import Damping

    use = [m for m in data.modes if m.damping_ratio is not None and m.eigenvalue > 0]
    if len(use) < 2:
        return None, None
    std = [m.std_damping_ratio for m in use]
    fit, resid = Damping.rayleigh_fit([np.sqrt(m.eigenvalue) for m in use], [m.damping_ratio for m in use],
                                      None if any(v is None for v in std) else std)
    return fit, {"alpha": fit.alpha, "beta": fit.beta, "rms_error": float(np.sqrt(np.mean(resid ** 2))),
                 "n_modes": len(use)}


def damping_fields(data, paired_hz: Mapping[int, float], damping=None) -> dict | None:
    """The ``damping_ratio`` object of a correlation or update: per test mode the measured ratio
    (``test``) and its standard deviation (``std``), the model's modal damping ratio at its paired
    mode (``model``: Rayleigh α/2ω + βω/2 plus η/2; null when the model is undamped or the mode
    unpaired), and the Rayleigh damping fitted to the measured ratios (``rayleigh_fit``, with two
    or more); None when neither the data nor the model have damping.

    Parameters
    ----------
    data : TestData
        The test modes.
    paired_hz : mapping of int to float
        Test mode (0-based) -> the frequency (Hz) of the model mode it is paired with.
    damping : Damping, optional
        The model's damping.
    """
    if data is None:
        return None
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


__all__ = ["parameter_fields", "flags", "diagnostics_fields", "diagnostics_extra", "data_fields", "fitted_damping",
           "damping_fields"]
