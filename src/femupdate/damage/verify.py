"""The refine and verify steps of :func:`~femupdate.damage.detect_damage` (its module docstring,
step 6): the localisation's candidates searched by nonlinear updating (:class:`Refiner`, over
:class:`~femupdate.damage.refine.SetSearch`), and the final set judged against the stated noise
(:func:`verify`: the verification record, the status it supports, the doubts and the reason).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from ..model import Model
from ..sensitivity.factor import single_thread_blas
from ..testdata import TestData
from .localise import Localiser, NoiseLevels
from .options import DamageOptions
from .refine import NOISE_FLOOR, SetFit, SetSearch
from .solvers import L1Fit, support_of

#: the largest set the search enlarges to, unless ``max_located`` says
DEFAULT_MAX_LOCATED = 8


@dataclass(frozen=True, eq=False)
class Refined:
    """The refinement's answer.

    Attributes
    ----------
    final : SetFit
        The set the search ended with (``fits``: it reproduces the data to the noise).
    alternatives : list of SetFit
        Sets of the same size, one member exchanged, that fit as well (empty unless ``final.fits``).
    evidence : dict
        {member: rise of the chi-square misfit when it is left out} (empty unless ``final.fits``).
    search : SetSearch
        The search (its ``trail`` of every set fitted, ``noise_factor``, ``n_data``).
    delta : ndarray, shape ``(L,)``
        The change of every unknown (zero when the final set does not fit).
    support : ndarray of int
        The members changed by ``min_change`` or more (empty when the final set does not fit).
    """

    final: SetFit
    alternatives: list[SetFit]
    evidence: dict[int, float]
    search: SetSearch
    delta: np.ndarray
    support: np.ndarray


@dataclass(frozen=True, eq=False)
class Refiner:
    """The refinement of one baseline's candidate sets against a data set (:class:`SetSearch`).

    Attributes
    ----------
    model : Model
        The baseline.
    names : tuple of str
        The unknowns.
    localiser : Localiser
        Scores the candidates (:meth:`Localiser.scorer`).
    levels : NoiseLevels
        The noise the misfit is divided by (``frequency``, ``shape_verify``).
    min_change, level : float
        The smallest change reported; the verification's confidence level.
    max_located : int
        The largest set tried.
    allow_increase : bool
        Stiffness may increase.
    pairing : str
        Pairing of test and model modes (``"frequency"`` for a model with rigid-body modes).
    """

    model: Model
    names: tuple[str, ...]
    localiser: Localiser
    levels: NoiseLevels
    min_change: float
    level: float
    max_located: int
    allow_increase: bool = False
    pairing: str = "auto"

    @classmethod
    def of(cls, model: Model, names: Sequence[str], localiser: Localiser, levels: NoiseLevels,
           options: DamageOptions, n_rigid: int) -> Refiner:
        """The refiner :func:`~femupdate.damage.detect_damage` uses, from its :class:`DamageOptions`."""
        n_max = min(len(names), int(options.max_located) if options.max_located is not None else DEFAULT_MAX_LOCATED)
        return cls(model, tuple(names), localiser, levels, options.min_change, options.level, n_max,
                   options.allow_increase, "frequency" if n_rigid else "auto")

    def search(self, data: TestData, lam: np.ndarray, Phi: np.ndarray, fit: L1Fit) -> tuple[SetSearch, SetFit]:
        """The stepwise search from the localisation ``fit`` of ``data`` (whose common-dof shapes and
        eigenvalues are ``Phi`` and ``lam``, scoring the candidates)."""
        srch = SetSearch(self.model, self.names, data, self.levels.verify_levels,
                         allow_increase=self.allow_increase, min_change=self.min_change, level=self.level,
                         max_located=self.max_located, score=self.localiser.scorer(lam, Phi),
                         path_order=() if fit.order is None else fit.order.tolist(), pairing=self.pairing)
        S0 = support_of(fit.debiased, self.min_change)
        return srch, srch.run(S0.tolist(), fit.debiased)

    def refine(self, data: TestData, lam: np.ndarray, Phi: np.ndarray, fit: L1Fit) -> Refined:
        """The search, and the alternatives and evidence of a final set that fits."""
        with single_thread_blas():
            srch, final = self.search(data, lam, Phi, fit)
            alts = srch.alternatives(final) if final.fits else []
            evidence = srch.evidence(final) if final.fits else {}
        delta = final.delta if final.fits else np.zeros(len(self.names))
        S = np.array([i for i in final.members if abs(delta[i]) >= self.min_change], dtype=np.intp) if final.fits \
            else np.zeros(0, np.intp)
        return Refined(final, alts, evidence, srch, delta, S)


@dataclass(frozen=True)
class Verification:
    """The verification of the refined set against the stated noise.

    Attributes
    ----------
    status : str
        ``"confirmed"``, ``"doubtful"``, ``"not localised"`` or ``"unverified"`` (no refinement).
    doubts : list of str
        Why a location is doubtful.
    reason : str
        Why it is not localised (empty otherwise).
    notes : list of str
        Remarks (members needed to fit the data but changed by less than ``min_change``).
    record : dict
        The result's ``verification`` (empty when unverified).
    """

    status: str = "unverified"
    doubts: list[str] = field(default_factory=list)
    reason: str = ""
    notes: list[str] = field(default_factory=list)
    record: dict = field(default_factory=dict)


def _record(refined: Refined) -> dict:
    """The result's ``verification``: the test of the final set and of every set fitted."""
    srch, final, names = refined.search, refined.final, refined.search.names
    return {
        "level": srch.level, "noise": {"frequency": max(srch.sigma_f, NOISE_FLOOR) * srch.noise_factor,
                                       "shape": max(srch.sigma_s, NOISE_FLOOR) * srch.noise_factor},
        "noise_factor": srch.noise_factor, "model_error": srch.model_error(),
        "n_data": srch.n_data, "chi2": final.chi2, "dof": final.dof, "limit": final.limit, "fits": final.fits,
        "members": [names[i] for i in final.members],
        "sets": [{"members": [names[i] for i in f.members], "chi2": f.chi2, "limit": f.limit, "fits": f.fits}
                 for f in srch.trail],
        "alternatives": [{"members": [names[i] for i in g.members], "chi2": g.chi2, "limit": g.limit,
                          "changes": {names[i]: float(g.delta[i]) for i in g.members}} for g in refined.alternatives],
    }


def _not_localised(srch: SetSearch) -> str:
    """Why no set was claimed: the smallest that fits is too large, or none fits."""
    names, n_max = srch.names, srch.max_located
    best_f = min(srch.trail, key=lambda f: f.chi2)
    small_fit = [f for f in srch.trail if f.fits]
    if small_fit:
        smallest = min(small_fit, key=lambda f: len(f.members))
        return (f"the smallest set found that reproduces the data, {' + '.join(names[i] for i in smallest.members)}, "
                f"has more than {n_max} unknown(s) (max_located): the data do not localise the damage to that few "
                "unknowns")
    return (f"no set of up to {n_max} unknown(s) reproduces the data to the stated noise (frequency "
            f"{srch.sigma_f:g}, shape {srch.sigma_s:.3g}; chi-square test at {srch.level:g}): the best, "
            f"{' + '.join(names[i] for i in best_f.members) or 'the baseline'}, leaves a misfit of "
            f"{best_f.chi2:.4g} for a limit of {best_f.limit:.4g}; the data do not localise the damage "
            "(more modes or sensors, another choice of unknowns, or a larger --max-located)")


def verify(refined: Refined) -> Verification:
    """Judge the refined set against the stated noise: confirmed when it fits, doubtful when it
    fits only a noise larger than stated or another set of its size fits as well, not localised
    when no set of up to ``max_located`` unknowns fits."""
    srch, final = refined.search, refined.final
    names = srch.names
    if not final.fits:
        return Verification("not localised", reason=_not_localised(srch), record=_record(refined))
    status, doubts, notes = "confirmed", [], []
    if srch.noise_factor > 1:
        status = "doubtful"
        doubts.append(f"model error: not even every unknown changing at once reproduces the data to the noise "
                      f"(chi-square test at {srch.level:g}): the model lacks something the structure has, or the noise "
                      f"is larger than stated; the location was judged with the noise taken {srch.noise_factor:.3g} "
                      "times the stated one and is not claimed with confidence")
    small = [names[i] for i in final.members if abs(final.delta[i]) < srch.min_change]
    if small:
        notes.append(f"{', '.join(small)} changed by less than min_change but are needed to reproduce the data "
                     "(not reported as damage; their changes are in `changes`)")
    alts = refined.alternatives
    if alts:
        status = "doubtful"
        doubts.append(f"{len(alts)} other set(s) of the same size fit the data as well, e.g. "
                      + " + ".join(names[i] for i in alts[0].members)
                      + f" (chi-square {alts[0].chi2:.3g}, limit {alts[0].limit:.3g})")
    return Verification(status, doubts, "", notes, _record(refined))


__all__ = ["Refiner", "Refined", "Verification", "verify", "DEFAULT_MAX_LOCATED"]
