"""The result of a test plan (:func:`femupdate.planning.plan`), kind ``plan``: what
``femupdate plan --json`` writes, read back by :meth:`PlanResult.from_json`."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np

from ..serialise import RunContext, Serialisable


@dataclass(frozen=True, eq=False)
class PlanResult(Serialisable):
    """A test plan: the sensors, why, and what they promise.

    Each parameter is stored as the attribute of the same name; the JSON keys are the same
    (docs/file-formats.md, kind ``plan``).

    Parameters
    ----------
    model : str
        Model name.
    criterion : str
        The placement criterion (:data:`femupdate.options.PLACEMENT_CRITERIA`).
    sensor_kind : str
        ``"uniaxial"`` or ``"triaxial"``.
    sensors : list of list of str
        The chosen sensors, each as the dofs it measures.
    dofs : list of str
        Every measured dof, sensor by sensor.
    fixed : list of list of str
        The sensors the user fixed.
    target : dict
        The target modes (:meth:`~femupdate.planning.targets.TargetModes.to_dict`).
    parameters : list of str
        The parameters the plan is to identify.
    nominal : dict of str to float
        Their nominal values.
    box : dict of str to list of float
        The parameter box the random points were drawn from.
    noise : dict
        ``eigenvalue`` (relative std) and ``shape`` (std of unit-scaled entries).
    design : str
        ``"d"`` or ``"a"``.
    score : dict
        The plan at every point: ``ranks``, ``conditions``, ``design``, ``identifiable``, ...
    greedy : list of list of str
        The greedy (or eliminated) set before the exchanges.
    swaps : int
        Exchanges that improved it.
    predicted_std : dict of str to float
        Cramér-Rao standard deviations (parameter units; null when not identifiable).
    relative_std : dict of str to float
        The same divided by the nominal values.
    automac : list of list of float
        The target modes' auto-MAC at the measured dofs.
    automac_max : float
        Its largest off-diagonal term.
    uniqueness : dict
        The expected verdict (:func:`~femupdate.planning.predict.uniqueness_verdict`).
    comparison : dict
        Per other criterion (the classical ones, or identifiability), its plan with the same
        number of sensors: ``sensors``, ``identifiable``, ``rank``, ``condition``,
        ``mean_relative_std``.
    monte_carlo : dict, optional
        The noisy updates' check (:func:`~femupdate.planning.predict.monte_carlo`), None when not run.
    nodes : dict of str to list of float
        Coordinates of the sensors' nodes (for the universal files).
    options : dict
        The target and placement options.
    prior : dict, optional
        With the expected information gain: each parameter's prior standard deviation relative
        to its nominal value; None otherwise.
    pretest : dict, optional
        ``tam`` (:func:`~femupdate.planning.pretest.tam`) and ``mass_loading``
        (:func:`~femupdate.planning.pretest.mass_loading`), each where asked.
    exciters : dict, optional
        The exciters of an FRF test (:mod:`femupdate.planning.exciters`): ``dofs``, ``greedy``,
        ``excites_all_modes``, ``score``, ``swaps``, ``noise_floor``, ``std_frf``,
        ``damping_ratio``, ``driving_points`` ({dof: {odp, nodp, dpr}}, best ODP first), ``best_odp``.
    segments : list of list of str
        Pairs of nodes the model's stiffness couples (the structure the report draws the layout on;
        ``femupdate plan`` stores the model file's elements instead, supported ends included).
    """

    model: str
    criterion: str
    sensor_kind: str
    sensors: list
    dofs: list
    fixed: list
    target: dict
    parameters: list
    nominal: dict
    box: dict
    noise: dict
    design: str
    score: dict
    greedy: list
    swaps: int
    predicted_std: dict
    relative_std: dict
    automac: Any
    automac_max: float
    uniqueness: dict
    comparison: dict = field(default_factory=dict)
    monte_carlo: dict | None = None
    nodes: dict = field(default_factory=dict)
    options: dict = field(default_factory=dict)
    prior: dict | None = None
    pretest: dict | None = None
    exciters: dict | None = None
    segments: list = field(default_factory=list)
    context: RunContext | None = field(default=None, repr=False, compare=False)

    kind: ClassVar[str] = "plan"

    def payload(self) -> dict:
        out = {k: getattr(self, k) for k in KEYS}
        mc = self.monte_carlo
        if mc is not None:
            names = self.parameters
            out["monte_carlo"] = {**{k: v for k, v in mc.items() if k != "estimates"},
                                  **{k: dict(zip(names, np.asarray(mc[k], float).tolist()))
                                     for k in ("mean", "std", "bias", "predicted_std", "ratio") if k in mc}}
        return out

    @classmethod
    def from_payload(cls, obj: Mapping[str, Any]):
        kw: dict[str, Any] = {k: obj.get(k) for k in KEYS}
        for k in ("comparison", "nodes", "options"):
            kw[k] = kw[k] or {}
        kw["segments"] = kw["segments"] or []
        return cls(**kw)

    @property
    def verdict(self) -> str:
        """The expected uniqueness verdict (``"unique"``, ``"locally identifiable"``, ...)."""
        return str(self.uniqueness.get("verdict", ""))

    def records(self) -> list[dict]:
        """One row per chosen sensor: its dofs and node coordinates."""
        from ..dofs import parse_dof

        return [{"sensor": i + 1, "dofs": ",".join(s), "node": str(parse_dof(s[0])[0]),
                 "xyz": self.nodes.get(str(parse_dof(s[0])[0]))} for i, s in enumerate(self.sensors)]

    def summary(self) -> str:
        stds = ", ".join(f"{k} ±{v:.3g}" if v is not None else f"{k} -" for k, v in self.predicted_std.items())
        return (f"{len(self.sensors)} {self.sensor_kind} sensor(s) by {self.criterion}: "
                f"{', '.join(','.join(s) for s in self.sensors)}; {self.verdict}; predicted std {stds}")

    def __repr__(self) -> str:
        return f"PlanResult({self.summary()})"


KEYS = ("model", "criterion", "sensor_kind", "sensors", "dofs", "fixed", "target", "parameters", "nominal", "box",
        "noise", "design", "score", "greedy", "swaps", "predicted_std", "relative_std", "automac", "automac_max",
        "uniqueness", "comparison", "monte_carlo", "nodes", "options", "prior", "pretest", "exciters",
        "segments")

__all__ = ["PlanResult"]
