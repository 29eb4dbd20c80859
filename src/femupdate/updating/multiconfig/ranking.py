r"""Pre-test ranking of candidate modifications by the new information they would bring.

Before testing, :func:`rank_modifications` ranks candidate modifications by the new, independent
information they would bring, from simulated data at the nominal parameters — "pre-test
finite-element analysis would be of the utmost value when determining optimum structural
changes" (the paper).  Its criteria, for the normalised
sensitivity matrices :math:`S_0` (the baseline configuration) and :math:`S_c` (a candidate):

* ``"condition"`` (default): the condition number of :math:`[S_0; S_c]`, the paper's own measure
  of linear independence (its Figure 4 for FRF lines).  It is blind to the size of the rows: a
  candidate whose rows are parallel to the baseline's (a repeat of the baseline test, or a
  modification too small to change the modes) gains nothing — the paper's warning that such
  data "will not give very independent data";
* ``"logdet"`` (D-optimal): :math:`\ln\det(F_0 + F_c) - \ln\det F_0` with the Fisher information
  :math:`F = S^T S` (unit measurement noise): the log-ratio of the volumes of the parameters'
  confidence ellipsoids before and after (a repeat of the test already gains L ln 2);
* ``"min_singular"`` (E-optimal): the smallest singular value of :math:`[S_0; S_c]`, i.e. how
  well the least-determined parameter combination is seen.

A candidate that makes a rank-deficient baseline full-rank ranks first whatever the criterion.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np

from ..._errors import InputError
from ...correlation import mac
from ...options import ModalOptions, NoiseOptions, PairingOptions
from ...model import Model
from ...serialise import RunContext, Serialisable
from .configurations import Configuration, Modification, check_unknowns, prepare, simulate
from .iterative import Stacked
from .results import svd_summary

CRITERIA = ("condition", "logdet", "min_singular")


@dataclass(frozen=True, eq=False)
class Ranking(Serialisable):
    """Candidate modifications ranked by the information they add to the baseline test; it writes
    the JSON of ``femupdate rank-modifications`` (:mod:`femupdate.serialise`; :mod:`femupdate.updating.multiconfig.record`).

    Attributes
    ----------
    criterion : str
        The criterion of the ranking (:data:`CRITERIA`).
    baseline : dict
        ``rank``, ``condition_number``, ``min_singular``, ``logdet`` of the baseline alone.
    candidates : list of dict
        Best first: ``name``, ``modification`` (text), ``gain`` (in the criterion: log-det gain,
        increase of the smallest singular value, or the factor by which the condition number
        falls), ``rank``, ``condition_number``, ``min_singular``, ``logdet`` of baseline +
        candidate, ``frequency_shift`` (largest relative change of the simulated frequencies
        from the baseline's) and ``min_mac`` (lowest MAC of a candidate mode with the baseline
        mode of the same order, over the dofs both measure).
    selected : list of str
        With ``select=k``: the k candidates chosen greedily, each the best given the ones before.
    unknowns : tuple of str
        The unknown parameters.
    context : RunContext, optional
        The model (:mod:`femupdate.serialise`): the JSON's model name.
    """

    kind: ClassVar[str] = "rank-modifications"

    criterion: str
    baseline: dict
    candidates: list[dict]
    selected: list[str]
    unknowns: tuple[str, ...]
    context: RunContext | None = field(default=None, compare=False, repr=False)

    def payload(self) -> dict:
        from .record import ranking_kind

        return ranking_kind(self, self.run_context)

    @classmethod
    def from_payload(cls, obj):
        from .record import ranking_from

        return ranking_from(obj)

    def records(self) -> list[dict]:
        """One record per candidate, best first (:meth:`to_frame`'s rows)."""
        return [dict(c) for c in self.candidates]


def _information(S: np.ndarray) -> dict:
    s = svd_summary(S)
    F = S.T @ S
    sign, logdet = np.linalg.slogdet(F) if S.size else (0.0, -math.inf)
    s["logdet"] = float(logdet) if sign > 0 and s["rank"] == S.shape[1] else -math.inf
    return s


def _score(info: dict, criterion: str) -> tuple:
    """Sort key, larger is better: rank first, then the criterion."""
    if criterion == "logdet":
        v = info["logdet"]
    elif criterion == "min_singular":
        v = info["min_singular"]
    else:
        v = -info["condition_number"]
    return (info["rank"], v)


def _gain(info: dict, base: dict, criterion: str) -> float:
    if criterion == "logdet":
        a, b = info["logdet"], base["logdet"]
        return math.inf if b == -math.inf and a > -math.inf else (a - b if a > -math.inf else 0.0)
    if criterion == "min_singular":
        return info["min_singular"] - base["min_singular"]
    a, b = info["condition_number"], base["condition_number"]
    return math.inf if math.isinf(b) and not math.isinf(a) else (b / a if math.isfinite(a) else 1.0)


def rank_modifications(model: Model, candidates: Sequence[Modification], measured_dofs: Sequence[str], n_modes: int, *,
                       baseline: Modification | None = None, params: Sequence[str] | None = None, values=None,
                       criterion: str = "condition", select: int | None = None, shape_scaling: str = "unit",
                       use_shapes: bool = True, sensitivity: str = "auto") -> Ranking:
    """Rank candidate modifications by the new, independent information they would bring.

    For the baseline configuration and each candidate, the test is simulated at the nominal
    parameters (``values``; the lowest ``n_modes`` elastic modes at ``measured_dofs``; dofs a candidate
    supports are left out) and its normalised sensitivity matrix ``S = ∂r/∂(p/|p|)`` is computed
    with the residuals of :func:`update_configurations`.  Each candidate is scored by the
    baseline and the candidate stacked, under ``criterion`` (module docstring).

    Parameters
    ----------
    model : Model
        The baseline model.
    candidates : sequence of Modification
        The candidate modifications (distinct names, none named as the baseline).
    measured_dofs : sequence of str
        The planned sensors.
    n_modes : int
        The modes to be measured in every configuration.
    baseline : Modification, optional
        The configuration that will be tested in any case (default the unmodified structure).
    params : sequence of str, optional
        The unknowns (default every parameter not fixed).
    values : None, mapping of str to float, or array_like of shape ``(n_parameters,)``, optional
        Nominal values (default the model's).
    criterion : {"condition", "logdet", "min_singular"}, default ``"condition"``
        The score (module docstring).
    select : int, optional
        Choose this many candidates greedily (sequential design), 1 .. ``len(candidates)``.
    shape_scaling : {"unit", "ref", "max"}, default ``"unit"``
        Scaling of the shape residuals (:class:`femupdate.updating.Problem`).
    use_shapes : bool, default True
        False: frequencies only.
    sensitivity : str, default ``"auto"``
        Derivative route of the sensitivities (:func:`femupdate.sensitivity.jacobian`).

    Returns
    -------
    Ranking
        Candidates best first (full rank first, then the criterion).

    Raises
    ------
    InputError
        An unknown criterion; no candidates; a name used twice; ``select`` out of range; and as
        :func:`~.configurations.check_unknowns`, :func:`~.configurations.simulate` and
        :func:`~.configurations.prepare`.
    """
    if criterion not in CRITERIA:
        raise InputError(f"unknown criterion {criterion!r}: use {', '.join(CRITERIA)}")
    if not candidates:
        raise InputError("no candidate modifications to rank")
    names = check_unknowns(model, params)
    base_mod = baseline or Modification(name="baseline")
    mods = [base_mod] + list(candidates)
    labels = [m.name for m in mods]
    dup = sorted({x for x in labels if labels.count(x) > 1})
    if dup:
        raise InputError(f"candidate name(s) used twice: {', '.join(dup)}")
    if select is not None and not 1 <= int(select) <= len(candidates):
        raise InputError(f"select must be between 1 and the number of candidates ({len(candidates)}), got {select}")
    configs = [Configuration(simulate(model, m, measured_dofs, n_modes, values), m) for m in mods]
    cms = prepare(model, configs, names)
    p = model.resolve(values)
    prob = Stacked(model, configs, cms, names, parametrisation="relative", p_base=p,
                   modal=ModalOptions(shape_scaling=shape_scaling, use_shapes=use_shapes, sensitivity=sensitivity),
                   pairing=PairingOptions(), noise=NoiseOptions())
    x = prob.from_p(p[prob.idx])
    S = prob.normalised_blocks(x)
    base = _information(S[0])
    ref_modes = configs[0].data
    rows = []
    for k, m in enumerate(candidates, start=1):
        info = _information(np.vstack([S[0], S[k]]))
        data = configs[k].data
        shift = float(np.max(np.abs(np.sqrt(data.eigenvalues / ref_modes.eigenvalues) - 1.0)))
        measured = set(data.modes[0].dofs)
        common = [d for d in ref_modes.modes[0].dofs if d in measured]
        A = ref_modes.shape_matrix(common)[1]
        B = data.shape_matrix(common)[1]
        rows.append({"name": m.name, "modification": m.describe(), "gain": _gain(info, base, criterion),
                     "frequency_shift": shift, "min_mac": float(np.min(np.diag(mac(A, B)))) if common else math.nan,
                     **{k2: info[k2] for k2 in ("rank", "condition_number", "min_singular", "logdet")}})
    order = sorted(range(len(rows)), key=lambda i: _score(rows[i], criterion), reverse=True)
    selected: list[str] = []
    if select:
        chosen: list[int] = []
        for _ in range(int(select)):
            best = max((i for i in range(len(candidates)) if i not in chosen),
                       key=lambda i: _score(_information(np.vstack([S[0]] + [S[j + 1] for j in chosen + [i]])), criterion))
            chosen.append(best)
        selected = [candidates[i].name for i in chosen]
    from .record import attach

    return attach(Ranking(criterion, {k2: base[k2] for k2 in ("rank", "condition_number", "min_singular", "logdet")},
                          [rows[i] for i in order], selected, tuple(names)), model, "rank-modifications")
