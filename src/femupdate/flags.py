"""Flags on identified parameter values: outside their bounds, on a bound, or physically
impossible (a stiffness, mass or section value that is not > 0).

One helper for every result type (``direct``, ``update``, ``frf-update``, ``update-multi``,
``fullfield``, ``surface``): the commands print each flag as a ``warning:`` line and list them
in the JSON under ``flags``.  They are warnings, not errors: the exit code stays 0 (docs/cli.md,
"Flags on results").
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

#: a value within this fraction of the bounds' span (when the other bound is infinite: of the
#: larger of the bound's and the parameter's nominal magnitude) counts as sitting on the bound
#: (:func:`bound_side`; the updating diagnostics' ``at_bounds`` use the same test)
ON_BOUND_RTOL = 1e-6


def _on(v: float, b: float, lo: float, hi: float, scale: float = 0.0) -> bool:
    span = hi - lo if math.isfinite(hi - lo) else max(abs(b), abs(scale), 1e-300)
    return math.isfinite(b) and abs(v - b) <= ON_BOUND_RTOL * span


def bound_side(v: float, lo: float, hi: float, scale: float = 0.0) -> str | None:
    """Which bound the value v sits on: ``"lower"``, ``"upper"`` or None.

    v sits on a bound when it lies within :data:`ON_BOUND_RTOL` times the bounds' span of it, or
    beyond it; when the other bound is infinite the span is replaced by the larger of the bound's
    magnitude and ``scale`` (the parameter's typical size: a bound of 0 has no size of its own).
    An infinite bound is never sat on.

    Parameters
    ----------
    v : float
        The value.
    lo, hi : float
        Its bounds (``-inf`` / ``inf`` for none).
    scale : float, default 0
        The parameter's typical magnitude (its nominal or starting value).

    Returns
    -------
    str or None
    """
    if not math.isfinite(v):
        return None
    if math.isfinite(lo) and (v <= lo or _on(v, lo, lo, hi, scale)):
        return "lower"
    if math.isfinite(hi) and (v >= hi or _on(v, hi, lo, hi, scale)):
        return "upper"
    return None


def parameter_flags(model, parameters: Mapping[str, float], names: Sequence[str] | None = None) -> list[dict]:
    """Flags for the values of ``names`` (default every parameter) in ``parameters``.

    Parameters
    ----------
    model : Model
        Its bounds, and :attr:`Model.positive` (parameters that must be > 0).
    parameters : mapping of str to float
        The result's parameter values.
    names : sequence of str, optional
        The parameters that were identified (fixed ones are not flagged).

    Returns
    -------
    list of dict
        ``{"parameter", "value", "kind", "bounds", "message"}`` with ``kind`` one of
        ``"not_positive"``, ``"outside_bounds"``, ``"on_bound"``.
    """
    out = []
    for n in (names if names is not None else model.parameter_names):
        par = model.parameters[model.parameter_index(n)]
        v, (lo, hi) = float(parameters[n]), par.bounds
        bounds = [lo, hi]
        shown = f"[{lo:g}, {hi:g}]"
        if not math.isfinite(v):
            continue
        if n in model.positive and not v > 0:
            out.append({"parameter": n, "value": v, "kind": "not_positive", "bounds": bounds,
                        "message": f"{n} = {v:.6g} is not > 0: physically impossible for an element property "
                                   f"(stiffness, mass or section); bounds {shown}"})
        elif v < lo or v > hi:
            out.append({"parameter": n, "value": v, "kind": "outside_bounds", "bounds": bounds,
                        "message": f"{n} = {v:.6g} lies outside its bounds {shown}"})
        elif bound_side(v, lo, hi, par.value) is not None:
            which = bound_side(v, lo, hi, par.value)
            out.append({"parameter": n, "value": v, "kind": "on_bound", "bounds": bounds,
                        "message": f"{n} = {v:.6g} sits on its {which} bound {shown}: the best fit may lie beyond it"})
    return out


def suspect_values(model, p) -> str:
    """``"k2 = -1.5 (bounds [1, 11])"`` for the values in ``p`` (full vector) that are negative, not
    > 0 where they must be, or outside their bounds; ``""`` if none."""
    bad = []
    for par, v in zip(model.parameters, p):
        lo, hi = par.bounds
        if v < 0 or v < lo or v > hi or (par.name in model.positive and not v > 0):
            bad.append(f"{par.name} = {float(v):.6g} (bounds [{lo:g}, {hi:g}])")
    return ", ".join(bad)


__all__ = ["parameter_flags", "suspect_values", "bound_side", "ON_BOUND_RTOL"]
