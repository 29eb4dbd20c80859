"""The JSON of the FRF results — kinds ``frf`` (:func:`femupdate.simulate_frf`, ``femupdate
frf``), ``frf-select`` (:func:`~femupdate.frf.select_frequencies`, ``femupdate frf-select``) and
``surface`` (:func:`~femupdate.frf.frf_surface`, :func:`~femupdate.frf.modal_surface`,
``femupdate surface``) — written by the results' ``to_json`` and read back by ``from_json``
(docs/file-formats.md).  Each kind names its own variant under a key of its own (``quantity``,
``equations``, ``residual``): ``kind`` is the kind of result.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np

#: lines within this relative eigenvalue distance of a resonance are noted in an ``frf`` result
NEAR_RESONANCE = 1e-3


# ---------------------------------------------------------------------------------- shared
def _floats(values) -> np.ndarray:
    return np.array([math.nan if v is None else float(v) for v in (values or [])], dtype=float)


def _number(v, missing: float = math.nan) -> float:
    return missing if v is None else float(v)


def _context(obj: Mapping, *keys: str):
    from ..serialise import RunContext

    return RunContext(kind=str(obj.get("kind") or ""), stored={k: obj[k] for k in ("model", *keys) if k in obj})


# ---------------------------------------------------------------------------------- frf
def pairs(h) -> list:
    """One response channel as ``[re, im]`` pairs (real values with a zero imaginary part)."""
    return [[float(np.real(v)), float(np.imag(v))] for v in np.asarray(h)]


def resonance_notes(model, omega, values) -> list[str]:
    """The note of an ``frf`` result on lines within :data:`NEAR_RESONANCE` of a resonance of
    ``model`` at ``values`` (large, sensitive values); models above the dense eigen-solution's
    limit are not checked (no note)."""
    from ..modal import DENSE_LIMIT
    from .resonance import resonances

    if model.n_dofs > DENSE_LIMIT:
        return []
    res = resonances(model, omega, values)
    near = res.near(NEAR_RESONANCE)
    return [f"lines within 1e-3 of a resonance (large, sensitive values): {res.describe(near)}"] if near.size else []


def simulation_fields(sim, ctx) -> dict:
    """The JSON of kind ``frf``: the responses in ``sim.quantity`` per dof as ``[re, im]`` pairs,
    with the force, damping, noise and parameter values they were simulated with, and the note
    on lines near a resonance (from the model, or as read back)."""
    stored = ctx.stored
    if "response" in stored and stored.get("quantity") == sim.quantity:
        response = stored["response"]  # as read: the quantity's values, not converted twice
    else:
        H = sim.responses()
        response = {d: pairs(H[:, k]) for k, d in enumerate(sim.dofs)}
    if ctx.model is not None:
        notes = resonance_notes(ctx.model, sim.omega, sim.parameters)
    else:
        notes = list(stored.get("notes") or [])
    return {"model": ctx.model_name, "omega_rad_s": sim.omega, "dofs": list(sim.dofs), "quantity": sim.quantity,
            "response": response, "force": dict(sim.force), "damping": sim.damping.as_dict(),
            "noise": dict(sim.noise), "parameters": dict(sim.parameters), "notes": notes}


def simulation_from(obj: Mapping) -> Any:
    """The :class:`~femupdate.frf.simulate.SimulatedFRF` of an ``frf`` JSON: its responses back
    as receptances (converted from ``quantity``).

    Raises
    ------
    InputError
        A response that is not ``[re, im]`` pairs per line, or a mobility or accelerance at a
        0 rad/s line (no receptance can be recovered there).
    """
    from .._errors import InputError
    from .damping import Damping
    from .simulate import SimulatedFRF, convert

    omega = _floats(obj.get("omega_rad_s"))
    dofs = tuple(obj.get("dofs") or ())
    quantity = str(obj.get("quantity") or "receptance")
    resp = obj.get("response") or {}
    try:
        H = np.array([[complex(*p) for p in resp[d]] for d in dofs], dtype=complex).T.reshape(omega.size, len(dofs))
    except (KeyError, TypeError, ValueError):
        raise InputError("/response: expected [re, im] pairs per line for every dof of /dofs") from None
    try:
        X = convert(H, omega, "receptance", quantity)
    except InputError as exc:
        raise InputError(f"an frf result in {quantity}: {exc}; its receptances cannot be recovered") from None
    if not np.any(np.imag(X)):
        X = np.real(X)
    damping = Damping(**(obj.get("damping") or {}))
    return SimulatedFRF(omega, dict(obj.get("force") or {}), dofs, X, quantity=quantity, damping=damping,
                        noise=dict(obj.get("noise") or {}), parameters=dict(obj.get("parameters") or {}),
                        context=_context(obj, "response", "quantity", "notes"))


# ---------------------------------------------------------------------------------- frf-select
def selection_fields(sel, ctx) -> dict:
    """The JSON of kind ``frf-select``: the chosen lines (rad/s, and 1-based among the
    candidates), their condition number, the evenly spread lines' for comparison, the
    candidates excluded and the search's history."""
    return {"model": ctx.model_name, "equations": sel.equations, "omega_rad_s": sel.omega,
            "lines": (np.asarray(sel.index, dtype=int) + 1).tolist(), "condition_number": sel.condition_number,
            "uniform": sel.uniform, "excluded": sel.excluded, "history": sel.history}


def selection_from(obj: Mapping) -> Any:
    """The :class:`~femupdate.frf.selection.Selection` of an ``frf-select`` JSON (the candidates
    and the search method, which the JSON does not hold, empty)."""
    from .selection import Selection

    uniform = dict(obj.get("uniform") or {})
    if "condition_number" in uniform:
        uniform["condition_number"] = _number(uniform["condition_number"], math.inf)
    return Selection(_floats(obj.get("omega_rad_s")), np.array([int(v) - 1 for v in obj.get("lines") or []], dtype=int),
                     _number(obj.get("condition_number"), math.inf), str(obj.get("equations") or "direct"),
                     np.zeros(0), list(obj.get("excluded") or []), uniform, list(obj.get("history") or []),
                     context=_context(obj))


# ---------------------------------------------------------------------------------- surface
#: the keys of :meth:`Surface.summary <femupdate.frf.surfaces.Surface.summary>` a surface's JSON holds
SUMMARY_KEYS = ("minimum", "local_minima", "edge_minima", "minima", "singular_points")


def surface_fields(surf, ctx) -> dict:
    """The JSON of kind ``surface``: the residual's name, the two parameters and their grids,
    the values (null where the model is singular) and the grid's minima."""
    summ = surf.summary()
    return {"model": ctx.model_name, "residual": surf.residual, "params": list(surf.names), "x": surf.x, "y": surf.y,
            "values": surf.values, **{k: summ[k] for k in SUMMARY_KEYS}}


def surface_from(obj: Mapping) -> Any:
    """The :class:`~femupdate.frf.surfaces.Surface` of a ``surface`` JSON (null values back as
    inf: the model is singular there)."""
    from .surfaces import Surface

    x, y = _floats(obj.get("x")), _floats(obj.get("y"))
    values = np.array([[math.inf if v is None else float(v) for v in row] for row in obj.get("values") or []],
                      dtype=float).reshape(x.size, y.size)
    names = tuple(obj.get("params") or ("", ""))
    return Surface(names, x, y, values, str(obj.get("residual") or ""), context=_context(obj))


__all__ = ["NEAR_RESONANCE", "pairs", "resonance_notes", "simulation_fields", "simulation_from", "selection_fields",
           "selection_from", "SUMMARY_KEYS", "surface_fields", "surface_from"]
