"""The JSON of the modal results — kinds ``modes`` (:class:`~femupdate.modal.Modes`, ``femupdate
modes``) and ``correlate`` (:class:`~femupdate.correlation.Correlation`, ``femupdate correlate``) —
written by their ``to_json()`` and read back by ``from_json()`` (docs/file-formats.md), and the
conversions of JSON values back into arrays that the other readers share.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from .recording import damping_fields, data_fields
from .serialise import RunContext


# ---------------------------------------------------------------------------------- JSON values
def floats(values: Sequence | None) -> np.ndarray:
    """A JSON list of numbers as a float array (``null`` -> NaN)."""
    return np.array([math.nan if v is None else float(v) for v in (values or [])], dtype=float)


def rows(values: Sequence | None, n_columns: int = 0) -> np.ndarray:
    """A JSON list of rows of numbers as a 2-D float array (``null`` -> NaN); no rows: shape
    ``(0, n_columns)``."""
    if not values:
        return np.zeros((0, n_columns))
    return np.array([[math.nan if v is None else float(v) for v in row] for row in values], dtype=float)


def stored(obj: Mapping, keys: Sequence[str]) -> RunContext:
    """The context of a result read back from ``obj``: its kind, and the keys ``keys`` it holds
    (those the result takes from its model and data when it is made) kept as read."""
    return RunContext(kind=str(obj.get("kind") or ""), stored={k: obj[k] for k in keys if k in obj})


# ---------------------------------------------------------------------------------- modes
def modes_kind(modes, ctx: RunContext) -> dict:
    """The JSON of kind ``modes``: eigenvalues, frequencies, shapes (one list per mode), the
    normalisation, the rigid-body count, the eigen-solver and the model's name and parameter
    values (from the context's model and values, or as read back)."""
    model = ctx.model
    if model is not None:
        parameters: Any = dict(zip(model.parameter_names, model.resolve(ctx.before)))
    else:
        parameters = ctx.get("parameters")
    return {
        "model": ctx.model_name, "eigenvalues": modes.eigenvalues, "frequencies_hz": modes.frequencies_hz,
        "dofs": list(modes.dofs), "shapes": modes.shapes.T, "normalisation": modes.normalisation,
        "n_rigid": modes.n_rigid, "parameters": parameters,
        "solver": ctx.get("solver") or modes.solver,  # read back: the solver that made them, not "dense"
    }


def modes_from(obj: Mapping):
    """The :class:`~femupdate.modal.Modes` of a ``modes`` JSON (without the sparse path's
    factorisation; the model's name, parameter values and the eigen-solver kept as read)."""
    from .modal import Modes

    dofs = tuple(obj.get("dofs") or ())
    return Modes(floats(obj.get("eigenvalues")), rows(obj.get("shapes"), len(dofs)).T, dofs,
                 str(obj.get("normalisation") or "mass"), int(obj.get("n_rigid") or 0),
                 context=stored(obj, ("model", "parameters", "solver")))


# ---------------------------------------------------------------------------------- correlate
def correlate_kind(corr, ctx: RunContext) -> dict:
    """The JSON of kind ``correlate``: the MAC matrix, the pairs, the frequencies and their errors,
    COMAC, the unpaired and unconfirmed test modes, the pairing policy; and from the test data
    their notes (when there are any), units, and the damping ratios compared with the context's
    model damping."""
    out: dict[str, Any] = {
        "dofs": list(corr.dofs), "mac": corr.mac, "pairs": [[i, j, m] for i, j, m in corr.pairs],
        "frequencies_hz": {"test": corr.test_frequencies_hz, "model": corr.model_frequencies_hz},
        "frequency_error": corr.frequency_error, "comac": dict(zip(corr.dofs, corr.comac)),
        "unpaired_test": list(corr.unpaired_test), "unconfirmed": list(corr.unconfirmed),
        "pairing": corr.pairing.rule if corr.pairing is not None else ctx.get("pairing"),
    }
    data = ctx.data
    if data is None:
        out.update({k: ctx.get(k) for k in ("notes", "units", "damping_ratio") if k in ctx.stored})
        return out
    if data.notes:
        out["notes"] = list(data.notes)
    out.update(data_fields(data))
    damping = damping_fields(data, {i: float(corr.model_frequencies_hz[j]) for i, j, _ in corr.pairs}, ctx.damping)
    if damping is not None:
        out["damping_ratio"] = damping
    return out


def correlate_from(obj: Mapping):
    """The :class:`~femupdate.correlation.Correlation` of a ``correlate`` JSON (its
    :class:`~femupdate.correlation.Pairing` None; the policy, notes, units and damping ratios
    kept as read)."""
    from .correlation import Correlation

    dofs = tuple(obj.get("dofs") or ())
    comac = obj.get("comac") or {}
    freqs = obj.get("frequencies_hz") or {}
    test, model = floats(freqs.get("test")), floats(freqs.get("model"))
    return Correlation(
        dofs, rows(obj.get("mac"), model.size), [(int(i), int(j), math.nan if m is None else float(m))
                                                  for i, j, m in obj.get("pairs") or []],
        test, model, floats(obj.get("frequency_error")), floats([comac.get(d) for d in dofs]),
        [int(i) for i in obj.get("unpaired_test") or []], [int(i) for i in obj.get("unconfirmed") or []], None,
        context=stored(obj, ("pairing", "notes", "units", "damping_ratio")))


__all__ = ["floats", "rows", "stored", "modes_kind", "modes_from", "correlate_kind", "correlate_from"]
