"""The judge step of :func:`~femupdate.damage.detect_damage` (its module docstring, step 7): the
status, doubts, notes and confidence figures of the answer.

* **Rates for this structure.**  The false-positive rate is simulated for this run: replicates
  of the *healthy* baseline (its model, the measured modes at their sensors, the noise the run
  uses) each pass through the whole chain (localise, refine, verify); the share that reports any
  unknown damaged is the rate.  The detection rate is the share of the replicates simulated from
  the *located* model that locate every located unknown again.  Each rate comes with its Monte
  Carlo error: the binomial standard error and the Clopper-Pearson 95 % interval of k in n.
* **Baseline unchecked.**  Without the undamaged structure's data (or a baseline stated as checked,
  ``baseline_checked``) a located set is never "confirmed": a baseline that is wrong reports its own
  errors as damage.  Located changes that move together (one sign, spread within
  ``UNIFORM_SPREAD`` of their mean) are called out: a uniform error of the baseline would give them.
* **Model error.**  When even the fit of every unknown cannot reproduce the data within the noise
  (chi-square test at ``level``), the location is not claimed with confidence (``doubtful``) and
  the verification's ``model_error`` says by how much.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from .bootstrap import Replicates
from .localise import Localisation, NoiseLevels
from .verify import Refined, Verification

#: located changes whose spread (std / ``|mean|``) is below this move together: a uniform baseline error explains them
UNIFORM_SPREAD = 0.25
#: the doubt of a located set whose baseline was not checked
UNCHECKED = ("the baseline was not checked against the undamaged structure: a baseline that is wrong reports its own "
             "errors as damage; give the undamaged structure's data (--undamaged, undamaged=...) or state that the "
             "baseline was checked, e.g. updated against them (--baseline-checked, baseline_checked=True)")


def binomial_rate(k: int, n: int, level: float = 0.95) -> dict:
    """The rate k/n with its Monte Carlo error: the binomial standard error sqrt(p(1-p)/n) and the
    Clopper-Pearson interval at ``level`` (exact: it holds for every n)."""
    from scipy.stats import beta

    if n <= 0:
        return {"rate": math.nan, "count": int(k), "n": int(n), "standard_error": math.nan,
                "interval": [math.nan, math.nan], "level": level}
    p = k / n
    a = (1 - level) / 2
    lo = 0.0 if k == 0 else float(beta.ppf(a, k, n - k + 1))
    hi = 1.0 if k == n else float(beta.ppf(1 - a, k + 1, n - k))
    return {"rate": p, "count": int(k), "n": int(n), "standard_error": math.sqrt(p * (1 - p) / n),
            "interval": [lo, hi], "level": level}


def simulated_rates(healthy: Replicates, located_reps: Replicates, located: Sequence[int]) -> dict:
    """``false_positive_rate`` (share of the healthy replicates reporting any unknown damaged) and
    ``detection_rate`` (share of the located model's replicates locating every located unknown),
    each :func:`binomial_rate`, or None where there were no replicates (or nothing was located)."""
    fp = (binomial_rate(sum(1 for s in healthy.sets if s), len(healthy.sets)) | {"basis": "simulated: the healthy "
          "baseline with this run's sensors, modes and noise, each replicate localised, refined and verified"}
          if healthy.sets else None)
    want = set(int(i) for i in located)
    det = (binomial_rate(sum(1 for s in located_reps.sets if want <= s), len(located_reps.sets)) | {"basis": "simulated: "
           "the located model with this run's sensors, modes and noise, each replicate localised, refined and verified"}
           if located_reps.sets and want else None)
    return {"false_positive_rate": fp, "detection_rate": det}


@dataclass(frozen=True, eq=False)
class Judgement:
    """The final judgement of :func:`judge`.

    Attributes
    ----------
    status : str
        One of ``STATUSES``.
    doubts : list of str
        Why the location is doubtful.
    reason : str
        Why it is not localised (empty otherwise).
    notes : list of str
        Remarks of the verification, the bootstrap and the judgement, in that order.
    confidence : dict
        The result's ``confidence``.
    delta : ndarray, shape ``(L,)``
        The change of every unknown.
    order : ndarray of int
        The located unknowns, largest change first.
    """

    status: str
    doubts: list[str]
    reason: str
    notes: list[str]
    confidence: dict
    delta: np.ndarray
    order: np.ndarray


def uniform_change(names: Sequence[str], delta: np.ndarray, order: np.ndarray, n_unknowns: int) -> str | None:
    """The note on located changes that move together — at least two, and half the unknowns, within
    ``UNIFORM_SPREAD`` of their median, one sign — which a uniform error of the baseline would give;
    the other located changes are told relative to theirs.  None when they do not."""
    if order.size < 2:
        return None
    d = delta[order]
    med = float(np.median(d))
    together = order[np.abs(d - med) <= UNIFORM_SPREAD * abs(med)] if med != 0 else order[:0]
    if together.size < max(2, n_unknowns / 2):
        return None
    mean = float(np.mean(delta[together]))
    others = [i for i in order if i not in set(together.tolist())]
    rel = "; ".join(f"{names[i]} {((1 + delta[i]) / (1 + mean) - 1) * 100:+.1f} % relative to them" for i in others)
    return (f"{together.size} of the {n_unknowns} unknowns changed together ({mean * 100:+.1f} % on average, spread "
            f"{float(np.std(delta[together])) * 100:.1f} %): a uniform error of the unchecked baseline (its stiffness "
            f"{(1 / (1 + mean) - 1) * 100:+.1f} % off) would explain them as well as damage" + (f"; {rel}" if rel else ""))


def judge(names: Sequence[str], localisation: Localisation, verification: Verification, refined: Refined | None,
          replicates: Replicates, levels: NoiseLevels, *, detected: bool, healthy: Replicates | None = None,
          baseline_checked: bool = False) -> Judgement:
    """The status, doubts, confidence figures and notes of the answer: the refined set (or, without
    ``refined``, the localisation's), its bootstrap replicates (the whole chain re-run on data simulated
    from the located model), the ``healthy`` replicates (the same from the baseline) and whether the
    baseline was checked (``baseline_checked``: against the undamaged data, or stated so)."""
    if refined is not None:
        delta, S, evidence = refined.delta, refined.support, refined.evidence
    else:
        delta, S, evidence = localisation.fit.debiased, localisation.support, {}
    order = S[np.argsort(-np.abs(delta[S]))]
    sel, se, same = replicates.summary(len(names), order.tolist())
    confidence = {
        "selection_frequency": {names[i]: float(sel[i]) for i in range(len(names)) if sel[i] > 0 or i in S},
        "standard_error": {names[i]: float(se[i]) for i in S},
        "separation": localisation.separation, "bootstrap": replicates.n,
        "noise": levels.record(),
        "same_set": same, "evidence": {names[i]: float(v) for i, v in evidence.items() if i in set(S.tolist())},
    }
    status, doubts = verification.status, list(verification.doubts)
    if refined is not None and status == "confirmed" and replicates.sets and same < 0.5:
        status = "doubtful"
        doubts.append(f"only {same * 100:.0f} % of the {len(replicates.sets)} bootstrap replicates locate this set")
    confidence.update(simulated_rates(healthy or Replicates.none(), replicates, order.tolist()))
    notes = verification.notes + ([replicates.note] if replicates.note else [])
    if not baseline_checked and order.size:
        said = [UNCHECKED] + [u for u in [uniform_change(names, delta, order, len(names))] if u]
        if status in ("confirmed", "doubtful"):
            status = "doubtful"
            doubts += said
        else:  # unverified: not claimed anyway
            notes += said
    if not order.size and status != "not localised":
        notes.append("no unknown changed by more than min_change" + (" although the frequencies changed" if detected else ""))
    return Judgement(status, doubts, verification.reason, notes, confidence, delta, order)


def error_std(verdict: Judgement, noise_dof: Mapping, replicates: int) -> Judgement:
    """The standard errors as the standard deviations of the changes' errors, the uncertainty of
    what they rest on included.  The bootstrap spread s of B = ``replicates`` replicates estimates
    the error's variance σ² with B − 1 degrees of freedom, at noise levels estimated with ν_noise
    (``noise_dof`` {unknown: ν}, :attr:`femupdate.damage.noise.StatedNoise.dof`; none when stated):
    s² = σ² (χ²_ν/ν) (χ²_{B−1}/(B − 1)), the two independent, so E[σ²/s²] = ν/(ν − 2) ·
    (B − 1)/(B − 3) and the standard error s √(ν/(ν − 2)) √((B − 1)/(B − 3)) gives errors whose
    ratio to it has mean square 1 (infinite for ν ≤ 2 or B ≤ 3: the spread says too little).  Their
    Satterthwaite degrees of freedom ν_eff = 1 / (1/ν_noise + 1/(B − 1)) (the error over s about
    Student-t with them) go to ``standard_error_dof``, s itself to ``bootstrap_spread``.  A
    located unknown the noise's fit did not cover takes the smallest ν_noise of those it did."""
    import dataclasses

    se = verdict.confidence.get("standard_error") or {}
    if not se:
        return verdict
    fallback = min(noise_dof.values()) if noise_dof else math.inf
    out, dofs = {}, {}
    for n, s in se.items():
        nu_noise = float(noise_dof.get(n, fallback))
        nu_boot = float(replicates - 1)
        dofs[n] = 1.0 / ((1.0 / nu_noise if nu_noise > 0 else math.inf) + (1.0 / nu_boot if nu_boot > 0 else math.inf))
        if not math.isfinite(s):
            out[n] = s
        elif nu_noise > 2 and nu_boot > 2:
            out[n] = s * math.sqrt((1.0 if math.isinf(nu_noise) else nu_noise / (nu_noise - 2)) * nu_boot / (nu_boot - 2))
        else:
            out[n] = math.inf
    confidence = dict(verdict.confidence, standard_error=out, standard_error_dof=dofs, bootstrap_spread=dict(se))
    return dataclasses.replace(verdict, confidence=confidence)


def conditional(verdict: Judgement, frequency: float) -> Judgement:
    """The judgement when the frequency noise could be estimated from neither the fit of every
    unknown nor that of the located set: its standard errors and simulated rates rest on an assumed
    level, so they are marked conditional (``confidence["conditional_on"]``) and the location is
    not confirmed (``confirmed`` becomes ``doubtful``, with the reason)."""
    import dataclasses

    why = (f"not confirmed: the frequency noise is not estimable from these data (too few modes for the unknowns); the "
           f"standard errors and rates assume {frequency:g} — state it (--noise-frequency, or std_frequency in the "
           "test data)")
    confidence = dict(verdict.confidence, conditional_on=f"an assumed relative frequency noise of {frequency:g} "
                      "(not estimable from these data)")
    status, doubts = verdict.status, list(verdict.doubts)
    if status == "confirmed":
        status = "doubtful"
    if status in ("confirmed", "doubtful"):
        doubts.append(why)
    return dataclasses.replace(verdict, status=status, doubts=doubts, confidence=confidence,
                               notes=verdict.notes + ([] if why in doubts else [why]))


__all__ = ["error_std", "conditional", "judge", "Judgement", "binomial_rate", "simulated_rates", "uniform_change", "UNCHECKED", "UNIFORM_SPREAD"]
