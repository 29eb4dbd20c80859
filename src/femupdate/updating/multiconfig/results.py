"""The result of a joint update of several configurations and its conditioning report."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np

from ...direct import DirectResult
from ...serialise import RunContext, Serialisable
from .. import Diagnostics


@dataclass(frozen=True, eq=False)
class MultiConfigResult(Serialisable):
    """Joint update of several configurations; it writes the JSON and report of ``femupdate
    update-multi`` (:mod:`femupdate.serialise`; :mod:`femupdate.updating.multiconfig.record`).

    Attributes
    ----------
    method : {"direct", "iterative"}
        The solution used.
    parameters : dict
        Every parameter of the base model: identified for the unknowns, given for the others.
    names : tuple of str
        The unknowns.
    x : ndarray, shape ``(L,)``
        Their identified values (physical units).
    success : bool
        Direct: the least-squares solution is unique; iterative: the solver converged.
    message : str
        The solver's message (direct: uniqueness, or why not).
    configurations : list of dict
        Per configuration: ``name``, ``modification`` (text), ``n_data``; direct:
        ``n_equations``, ``unknowns_seen``, ``dropped`` (parameters its model lost); iterative:
        ``pairs`` [(test, model, mac)], ``frequencies_hz`` {``test``, ``model``}, ``cost``,
        ``swaps``.
    conditioning : dict
        ``each``: per configuration alone, ``cumulative``: the configurations added in order, each
        with ``rank``, ``condition_number`` and ``min_singular`` of the column-scaled direct
        matrix (direct) or the normalised sensitivity matrix (iterative); ``stacked``: all.
    standard_error : ndarray
        Of ``x`` (NaN where not estimable; iterative: NaN for a parameter on a bound, see
        ``diagnostics.at_bounds``).
    direct : DirectResult or None
        The direct solution (None for the iterative one).
    diagnostics : Diagnostics or None
        Of the iterative solution (the stacked normalised sensitivity matrix).
    cost, nfev, iterations, history
        Of the iterative solution: ½‖r‖², residual evaluations, iterations, per iteration
        {``iteration``, ``cost``, ``parameters``} (0 / [] for the direct one).
    notes : list of str
        Notes of the direct solution; of the iterative one, the parameters on their bounds
        (:attr:`~femupdate.updating.Diagnostics.notes`).
    regularization : dict
        {``rule``, ``alpha``} when the iterative solution was regularised, else empty.
    start : dict of str to float
        The unknowns' starting values of the iterative solution (empty for the direct one).
    context : RunContext, optional
        The base model (:mod:`femupdate.serialise`): the JSON's model name, parameter units,
        bounds and flags, and the report's.
    """

    kind: ClassVar[str] = "update-multi"

    method: str
    parameters: dict[str, float]
    names: tuple[str, ...]
    x: np.ndarray
    success: bool
    message: str
    configurations: list[dict]
    conditioning: dict
    standard_error: np.ndarray
    direct: DirectResult | None = None
    diagnostics: Diagnostics | None = None
    cost: float = 0.0
    nfev: int = 0
    iterations: int = 0
    history: list[dict] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    regularization: dict = field(default_factory=dict)
    start: dict[str, float] = field(default_factory=dict)
    context: RunContext | None = field(default=None, compare=False, repr=False)

    def payload(self) -> dict:
        from .record import multi_kind

        return multi_kind(self, self.run_context)

    @classmethod
    def from_payload(cls, obj):
        from .record import multi_from

        return multi_from(obj)

    def records(self) -> list[dict]:
        """One record per unknown: its identified value and standard error (:meth:`to_frame`'s rows)."""
        return [{"parameter": n, "value": float(v), "standard_error": float(s)}
                for n, v, s in zip(self.names, self.x, self.standard_error)]


def svd_summary(S: np.ndarray) -> dict:
    """Rank, condition number and smallest singular value of ``S`` (columns already scaled).

    Parameters
    ----------
    S : ndarray, shape ``(n_rows, L)``
        Column-scaled matrix.

    Returns
    -------
    dict
        ``rank`` (singular values above ``max(S.shape) * eps * s_max``), ``n_rows``,
        ``min_singular`` (0 unless full column rank with ``n_rows >= L``), ``condition_number``
        (inf in that case), ``singular_values`` (ndarray, descending).
    """
    L = S.shape[1]
    s = np.linalg.svd(S, compute_uv=False) if S.size else np.zeros(0)
    tol = max(S.shape) * np.finfo(float).eps * (s[0] if s.size else 0.0)
    rank = int(np.sum(s > tol))
    full = rank == L and S.shape[0] >= L
    return {"rank": rank, "n_rows": int(S.shape[0]), "min_singular": float(s[-1]) if full else 0.0,
            "condition_number": float(s[0] / s[-1]) if full and s[-1] > 0 else math.inf,
            "singular_values": s}


def conditioning(blocks: Sequence[np.ndarray], names: Sequence[str], labels: Sequence[str]) -> dict:
    """Conditioning of each block alone and of the blocks stacked one after another.

    Parameters
    ----------
    blocks : sequence of ndarray, shape ``(n_rows_c, L)``
        One column-scaled matrix per configuration, same columns.
    names : sequence of str
        The unknowns (the L columns).
    labels : sequence of str
        Configuration names, one per block.

    Returns
    -------
    dict
        ``unknowns``; ``each``: per block ``{"configuration": label, **svd_summary}``;
        ``cumulative``: the first k blocks stacked, k = 1 .. n, ``{"configurations": [...], **svd_summary}``;
        ``stacked``: the last of ``cumulative`` (all blocks).
    """
    each = [{"configuration": lab, **svd_summary(B)} for lab, B in zip(labels, blocks)]
    cumulative = []
    for k in range(1, len(blocks) + 1):
        cumulative.append({"configurations": list(labels[:k]), **svd_summary(np.vstack(blocks[:k]))})
    return {"unknowns": list(names), "each": each, "cumulative": cumulative, "stacked": cumulative[-1]}
