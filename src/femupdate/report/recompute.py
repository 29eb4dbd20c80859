"""What the report recomputes when it has the model and the test data: the correlation of the
model before and after the run (modes, MAC matrix, pairs), the FRFs before and after, and a
residual surface of an FRF run.  The JSON results hold the final pairs and frequencies only."""

from __future__ import annotations

import logging
from dataclasses import dataclass, field

import numpy as np

from .._errors import FemupdateError

log = logging.getLogger(__name__)

#: residual surfaces are drawn for models up to this many dofs (the dense stacked evaluation)
SURFACE_MAX_DOFS = 200
#: grid points per axis of the residual surface
SURFACE_POINTS = 41
#: lines of the model's FRF curves drawn between the lowest and highest measured line
FRF_POINTS = 400


@dataclass
class State:
    """The model at one set of parameter values, correlated with the test modes."""

    values: dict
    modes: object = None  # Modes
    correlation: object = None  # Correlation


@dataclass
class Recomputed:
    """Everything recomputed from the model and the data, with notes on what could not be."""

    before: State | None = None
    after: State | None = None
    frf: dict | None = None
    surface: object = None
    notes: list[str] = field(default_factory=list)
    test_points: object = None  # MappedTest: shapes drawn on the structure's dofs, u = T q


def _n_modes(model, data) -> int | None:
    """Model modes to pair among: every mode of a small model, else max(2T + 4, 10) for T test modes."""
    if model.n_dofs <= 200:
        return None
    return min(model.n_dofs - 1, max(2 * len(data.modes) + 4, 10))


def state(model, data, values, what: str, notes: list[str], pairing: str = "auto") -> State | None:
    """The model's modes at ``values`` and their correlation with the test modes (None, with a
    note, when they cannot be computed — e.g. an identified negative stiffness)."""
    from ..correlation import correlate
    from ..modal import model_modes

    try:
        modes = model_modes(model, values, n_modes=_n_modes(model, data))
        corr = correlate(data, modes, pairing=pairing) if data is not None and data.modes else None
    except FemupdateError as exc:
        notes.append(f"the model {what} could not be correlated with the test: {exc}")
        return None
    return State(dict(values), modes, corr)


def recompute(model, data, before: dict | None, after: dict | None, result: dict, pairing: str = "auto",
              damping=None) -> Recomputed:
    """The before/after correlation, FRFs and (FRF runs) residual surface.

    Parameters
    ----------
    model : Model
        The model the run used (the element-wise model for a damage run).
    data : TestData or None
        The test data the run used.
    before, after : dict or None
        Parameter values {name: value} before and after the run.
    result : dict
        The run's JSON result.
    pairing : str
        The pairing policy for the correlation.
    damping : mapping, optional
        The damping of an FRF run ({alpha, beta, eta}); undamped by default.
    """
    from ..damping.view import DampedView

    if isinstance(model, DampedView):  # a damped model's update
        return _damped(model, data, before, after, result, pairing)
    out = Recomputed()
    if before is not None:
        out.before = state(model, data, before, "before", out.notes, pairing)
    if after is not None:
        out.after = state(model, data, after, "after", out.notes, pairing)
    if data is not None and data.frf is not None and after is not None:
        out.frf = _frfs(model, data, before, after, result, damping, out.notes)
        if out.frf is not None and result.get("updated"):
            out.surface = _surface(model, data, after, result, damping, out.notes)
    return out


def _damped(view, data, before, after, result, pairing) -> Recomputed:
    """The report of a damped model's update: the correlation of its undamped modes (the model's
    own parameters) before and after, and its damped FRFs before and after (the peaks)."""
    out = Recomputed(notes=["the correlation figures use the model's undamped modes (its K and M at the "
                            "parameters); the damped update's pairs and damping ratios are in the result"])
    own = set(view.model.parameter_names)
    for key, values in (("before", before), ("after", after)):
        if values is not None:
            setattr(out, key, state(view.model, data, {n: v for n, v in values.items() if n in own}, key, out.notes,
                                    pairing))
    if data is not None and data.frf is not None and after is not None:
        from ..damping.frf import damped_response

        def model_frf(_model, omega, force, dofs, values, _damping):
            return None, damped_response(view.damped, omega, dict(force), dofs, values)[0]

        out.frf = _frfs(view, data, before, after, result, None, out.notes, model_frf)
    return out


def _frfs(model, data, before, after, result, damping, notes, model_frf=None) -> dict | None:
    if model_frf is None:
        from ..frf import frf as model_frf

    frf = data.frf
    used = np.isin(frf.omega, np.asarray(result.get("omega_rad_s") or frf.omega, float))
    if not np.any(used):
        used = np.ones(frf.omega.size, bool)
    lo, hi = float(frf.omega[used].min()), float(frf.omega[used].max())
    dense = np.linspace(lo, hi, FRF_POINTS) if hi > lo else frf.omega[used]
    try:
        _, xa = model_frf(model, dense, frf.force, frf.dofs, after, damping)
        xb = None if before is None else model_frf(model, dense, frf.force, frf.dofs, before, damping)[1]
    except FemupdateError as exc:
        notes.append(f"the model's FRFs could not be computed: {exc}")
        return None
    if data.n_frf_sets > 1:
        notes.append(f"the FRF figures show the first excitation's set ({', '.join(frf.force)})")
    return {"omega": frf.omega[used], "dofs": list(frf.dofs), "measured": frf.response[used], "model_omega": dense,
            "before": xb, "after": xa, "force": dict(frf.force)}


def _surface(model, data, after, result, damping, notes):
    """The FRF residual over the first two updated parameters around the solution (the others at
    their updated values): ±50 % of each value, within its bounds."""
    from ..frf.surfaces import frf_surface

    names = list(result["updated"])[:2]
    if len(names) < 2:
        return None
    if model.n_dofs > SURFACE_MAX_DOFS:
        notes.append(f"no residual surface: the model has {model.n_dofs} dofs (surfaces are drawn up to "
                     f"{SURFACE_MAX_DOFS})")
        return None
    axes = []
    for n in names:
        p = model.parameters[model.parameter_index(n)]
        v = float(after[n])
        lo, hi = (v * 0.5, v * 1.5) if v > 0 else (v * 1.5, v * 0.5) if v < 0 else (-1.0, 1.0)
        lo, hi = max(lo, p.bounds[0]), min(hi, p.bounds[1])
        if n in model.positive:  # an element property stays > 0
            lo = max(lo, 1e-6 * abs(v))
        axes.append(np.linspace(lo, hi, SURFACE_POINTS))
    residual = result.get("residual") or "linear"
    try:
        return frf_surface(model, data.frf, names, axes[0], axes[1], values=after, damping=damping,
                           residual=residual)
    except (FemupdateError, ValueError) as exc:
        notes.append(f"no residual surface: {exc}")
        return None
