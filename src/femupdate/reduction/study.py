"""One reduction of a model to its kept dofs, compared with the full model and with the other
methods: :func:`reduce_model` and its :class:`ReductionResult` (kind ``reduce``, what
``femupdate reduce`` prints and writes)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np

from .._errors import FemupdateError
from ..serialise import RunContext, Serialisable
from .criteria import ReductionCriteria, reduction_criteria
from .projection import Transformation, project, reduced_eigenvalues
from .reducer import METHODS, Reducer
from .selection import mass_fraction


@dataclass(frozen=True, eq=False)
class ReductionResult(Serialisable):
    """A model reduced to its kept dofs (:func:`reduce_model`).

    A result of kind ``reduce`` (:mod:`femupdate.serialise`): ``to_json()`` is what ``femupdate
    reduce --json`` writes; ``to_frame()`` one row per mode (:meth:`records`).

    Attributes
    ----------
    method : str
        The reduction method (``guyan``, ``irs``, ``modal``, ``hybrid`` or ``serep``).
    keep : tuple of str
        The kept dofs, in the order of the reduced matrices.
    n_modes : int or None
        Full-model modes the method used (modal, hybrid, SEREP; None for Guyan and IRS).
    full_frequencies_hz : numpy.ndarray, shape ``(min(n, a),)``
        The lowest natural frequencies of the full model (as many as kept dofs), Hz.
    reduced_frequencies_hz : numpy.ndarray, shape ``(a,)``
        Those of the reduced model, Hz.
    K, M : numpy.ndarray, shape ``(a, a)``
        The reduced stiffness (N/m) and mass (kg) matrices, rows and columns as ``keep``.
    frequency_error : dict of str to numpy.ndarray or str
        Per method (``method`` first, then, compared, every other one): the relative error
        f_reduced / f_full − 1 of each mode (the difference where the full frequency is 0), or
        the message of a method that cannot apply here.
    mass_fraction : float
        The share of the mass the kept dofs carry (:func:`~femupdate.reduction.mass_fraction`).
    criteria : ReductionCriteria or None
        Gordis's and Larsson & Sas's figures of the keep-set (None read back from JSON: its
        ``criteria`` object is kept as read).
    parameters : dict of str to float
        The parameter values the model was reduced at.
    transformation : Transformation or None
        The chosen method's transformation (None read back from JSON).
    context : RunContext, optional
        The model (not serialised: its name goes into the JSON).
    """

    kind: ClassVar[str] = "reduce"

    method: str
    keep: tuple[str, ...]
    n_modes: int | None
    full_frequencies_hz: np.ndarray
    reduced_frequencies_hz: np.ndarray
    K: np.ndarray
    M: np.ndarray
    frequency_error: dict[str, Any]
    mass_fraction: float
    criteria: ReductionCriteria | None
    parameters: dict[str, float]
    transformation: Transformation | None = field(default=None, repr=False)
    context: RunContext | None = field(default=None, compare=False, repr=False)

    @property
    def error(self) -> np.ndarray:
        """The chosen method's relative frequency error per mode."""
        return self.frequency_error[self.method]

    def payload(self) -> dict:
        ctx = self.run_context
        crit = self.criteria
        return {
            "model": ctx.model_name, "method": self.method, "keep": list(self.keep), "n_modes": self.n_modes,
            "frequencies_hz": {"full": self.full_frequencies_hz, "reduced": self.reduced_frequencies_hz},
            "K": self.K, "M": self.M,
            "frequency_error": {k: (v if isinstance(v, str) else list(v)) for k, v in self.frequency_error.items()},
            "mass_fraction": self.mass_fraction,
            "criteria": ctx.get("criteria") if crit is None else {
                "grounded_frequency_hz": crit.grounded_frequency_hz, "gordis_overlap": crit.overlap,
                "omitted_eigenvalues": crit.omitted_eigenvalues, "messages": crit.messages},
            "parameters": self.parameters,
        }

    @classmethod
    def from_payload(cls, obj: Mapping) -> ReductionResult:
        from ..modal_record import floats, rows, stored

        keep = tuple(obj.get("keep") or ())
        freqs = obj.get("frequencies_hz") or {}
        n_modes = obj.get("n_modes")
        return cls(
            method=str(obj.get("method") or ""), keep=keep, n_modes=None if n_modes is None else int(n_modes),
            full_frequencies_hz=floats(freqs.get("full")), reduced_frequencies_hz=floats(freqs.get("reduced")),
            K=rows(obj.get("K"), len(keep)), M=rows(obj.get("M"), len(keep)),
            frequency_error={k: v if isinstance(v, str) else floats(v)
                             for k, v in (obj.get("frequency_error") or {}).items()},
            mass_fraction=float("nan") if obj.get("mass_fraction") is None else float(obj["mass_fraction"]),
            criteria=None, parameters={k: float(v) for k, v in (obj.get("parameters") or {}).items()},
            context=stored(obj, ("model", "criteria")))

    def records(self) -> list[dict]:
        """One record per mode (0-based ``mode``, ``full_hz``, ``reduced_hz``, the chosen method's
        relative ``error``; None where a side has fewer modes): :meth:`to_frame`'s rows."""
        full, red, err = self.full_frequencies_hz, self.reduced_frequencies_hz, self.error
        return [{"mode": i, "full_hz": float(full[i]) if i < full.size else None,
                 "reduced_hz": float(red[i]) if i < red.size else None,
                 "error": float(err[i]) if i < err.size else None}
                for i in range(max(full.size, red.size))]


def reduce_model(model, keep: Sequence[str], method: str = "guyan", n_modes: int | None = None, compare: bool = True,
                 values=None) -> ReductionResult:
    """Reduce ``model`` to the dofs ``keep`` by ``method`` and compare the reduced model's
    frequencies with the full model's (and, with ``compare``, every other method's).

    Parameters
    ----------
    model : Model
        The model.
    keep : sequence of str
        The dofs to retain (labels), in the order of the reduced matrices.
    method : {"guyan", "irs", "modal", "hybrid", "serep"}, default ``"guyan"``
        The reduction (:meth:`Reducer.transformation <femupdate.reduction.Reducer.transformation>`).
    n_modes : int, optional
        Modes used by modal, hybrid and SEREP (at most the number of kept dofs; default: that
        number).
    compare : bool, default True
        Also compute every other method's frequency errors (a method that cannot apply here is
        reported by its message, not raised).
    values : None, mapping of str to float, or array_like, optional
        Parameter values to reduce at (default nominal).

    Returns
    -------
    ReductionResult

    Raises
    ------
    InputError, NumericalError
        As :class:`~femupdate.reduction.Reducer` and the chosen method's builder.
    """
    method = str(method).lower()
    red = Reducer(model, keep, values)
    f_full = red.modes(min(model.n_dofs, red.n_keep)).frequencies_hz  # cached: modal, hybrid and SEREP reuse them

    def run(meth):
        t = red.transformation(meth, n_modes)
        K_r, M_r = project(red.K, t.T), project(red.M, t.T)
        f = np.sqrt(np.clip(reduced_eigenvalues(K_r, M_r), 0, None)) / (2 * np.pi)
        k = min(f.size, f_full.size)
        with np.errstate(divide="ignore", invalid="ignore"):
            err = np.where(f_full[:k] > 0, f[:k] / np.where(f_full[:k] > 0, f_full[:k], 1.0) - 1.0, f[:k] - f_full[:k])
        return t, K_r, M_r, f, err

    t, K_r, M_r, f_red, err = run(method)
    errors: dict[str, Any] = {method: err}
    for other in METHODS if compare else ():
        if other != method:
            try:
                errors[other] = run(other)[4]
            except FemupdateError as exc:  # a method that cannot apply here is reported, not fatal
                errors[other] = str(exc)
    return ReductionResult(
        method=method, keep=tuple(red.keep), n_modes=t.n_modes, full_frequencies_hz=f_full,
        reduced_frequencies_hz=f_red, K=K_r, M=M_r, frequency_error=errors,
        mass_fraction=mass_fraction(model, red.keep, red.values),
        criteria=reduction_criteria(model, red.keep, reducer=red, warn=False),
        parameters=dict(zip(model.parameter_names, red.values)), transformation=t, context=RunContext(model=model))


__all__ = ["ReductionResult", "reduce_model"]
