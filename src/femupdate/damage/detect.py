r"""Damage detection from a validated baseline: localise (expansion, sparse regularisation), refine
(nonlinear updating of the located set), verify (against the stated noise).

The reference paper ("Damage detection"): for damage detection "the properties of each element
must be treated as being unknown", and because the baseline model has been validated, expanding
the measured shapes with it "should be acceptable".  So:

1. **Unknowns.** The model's stiffness parameters: its own, as it names them (a group of elements
   sharing a parameter is one unknown: :func:`~femupdate.damage.damage_unknowns`), or, when the
   user asks, one per element: :func:`element_parameters` turns a :class:`~femupdate.Structure`
   into one whose every element has its own stiffness parameter (the stiffness modulus: ``k`` of a
   spring, ``E`` of a rod, beam or frame — the whole element stiffness of springs, rods and
   plane beams scales with it; a space frame's torsion, through G, does not), at its validated
   value: :math:`K(\theta) = K_0 + \sum_e \theta_e K_e`, damage :math:`\delta_e = \theta_e/\theta_{e,0} - 1`.
2. **Baseline check** (:func:`check_baseline`): with the undamaged structure's test data, the
   baseline must reproduce them (frequency errors and MAC within limits); otherwise localisation
   is refused with the reasons.
3. **Expansion.** The damaged structure's shapes, measured at a few dofs, are expanded to every
   dof by the model (:func:`femupdate.reduction.expand`: SEREP by default, whose basis holds the
   model modes up to twice the highest one the measured modes pair with); once the damage is
   located, the expansion is repeated with the damaged estimate to re-estimate the loss
   (``iterations``).  Measured modes that pair with no baseline mode
   (MAC below ``localise_min_mac``, 0.8) mean the damage changed the dynamics too much for a
   model-based expansion: the localisation alone cannot place it (the paper's closing remark on
   Doebling et al. 1993) and says so; the refinement (step 6), which needs no expansion, still can.
4. **Equations**, linear in δ, for each measured mode (paper eqs. 4-9 with the element
   stiffnesses as unknowns), projected onto the expanded shapes :math:`w_k` (unit length):

   .. math:: \sum_e \delta_e\,\theta_{e,0}\, w_k^T K_e\phi_i = w_k^T(\lambda_i M - K(\theta_0))\phi_i ,

   each mode's rows divided by :math:`\lambda_i\|M\phi_i\|`: m² rows (energy for k = i,
   orthogonality otherwise).  The pointwise rows at every dof would apply the stiffness to the
   expansion's errors and to the noise (see :mod:`femupdate.fullfield`); measured, they
   located the wrong members even without noise.  The element products are sparse (element e
   touches only its dofs), so the cost grows with the model's non-zeros, not its square.
5. **Sparsity.** Few elements are damaged, so the equations are solved with an L1 penalty,
   :math:`\min_\delta \tfrac12\|A\delta - r\|^2 + \alpha\|\delta\|_1` with
   :math:`-1 \le \delta \le 0` (stiffness is lost, not gained, unless ``allow_increase``), by
   SciPy's L-BFGS-B on the split variables.  α is chosen on a path from
   :math:`\alpha_{max} = \|A^T r\|_\infty` (above which δ = 0) by the Bayesian information
   criterion of the refitted (debiased) support; the loss is then re-estimated by bounded least
   squares on the located elements only.  Tikhonov regularisation (α by GCV,
   :mod:`femupdate.regularization`) is computed alongside for comparison: it spreads the change
   over many elements.
   Steps 2-5 are the **localisation**: its located set (``localisation``) is the candidates of
   the next steps — and, with ``refine=False``, the answer (the method before refinement).
6. **Refine and verify** (:mod:`.refine`).  The candidate set is fitted by nonlinear updating
   (:class:`femupdate.updating.Problem` with ``params`` = the set, the other unknowns at the
   baseline; exact Jacobian; every measured mode at its own dofs, no expansion) and claimed only
   when its misfit, divided by the stated noise, passes a chi-square test at ``level``; else the
   set is enlarged, trimmed and its members exchanged for neighbours, up to ``max_located``
   unknowns, the last enlargement being every unknown at once (plain updating, when the data
   suffice): wherever plain updating identifies the damage exactly, so does this.  Sets of the
   same size that fit as well make the location *doubtful*; when no set fits, the data do not
   localise the damage (``status`` "not localised").
7. **Confidence.** ``bootstrap`` replicates are simulated from the identified model with the
   stated noise (``noise``: relative frequency and shape standard deviations; the shape noise
   defaults to the SEREP misfit) and each is localised, refined and verified anew: the fraction
   of replicates locating each unknown (selection frequency) and exactly the located set
   (``same_set``), and the spread of its estimated change (standard error); the rise of the
   misfit when each member is left out (``evidence``); the localisation's ratio of the smallest
   located change to the largest change elsewhere in the L1 solution (``separation``); and the
   false-positive and detection rates simulated for this run (:mod:`.judge`; not the benchmark's
   families: :mod:`.rates` keeps ``benchmarks/bench_damage.py``'s table for comparable
   noise, sensors and modes, for the benchmark).  With ``refine=False`` the measured data are perturbed instead and
   the localisation alone re-run (its confidence then ignores whether the set fits).

The equations are weighted by the inverse square root of their covariance under that same noise
(Monte Carlo at the baseline), so that rows dominated by shape noise — the orthogonality rows
— weigh less than the energy rows, whose Rayleigh-quotient form makes them insensitive to shape
errors to first order; the BIC then compares residuals in units of their noise.

The steps are units with explicit inputs and outputs, composed by :func:`detect_damage`:
**localise** (:mod:`.localise`: :func:`~.localise.make_localiser`, :func:`~.localise.localise`),
**refine** (:class:`~.verify.Refiner` over :class:`~.refine.SetSearch`), **verify**
(:func:`~.verify.verify`), **bootstrap** (:mod:`.bootstrap`) and **judge** (:func:`judge`); the
method's knobs are one :class:`~.options.DamageOptions`.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np

from .._checks import data_arg, mapping_arg, params_arg, problem_args
from .._errors import InputError
from ..model import Model
from ..options import gather
from ..serialise import RunContext, Serialisable
from ..testdata import TestData
from .baseline import check_baseline
from .bootstrap import Replicates, bootstrap, bootstrap_healthy
from .localise import (Localisation, Localiser, Pairing, indices, localise, make_localiser,
                       measured_shapes, pair_with_baseline, realised_data, stated_noise)
from .judge import Judgement, conditional, error_std, judge
from .noise import BASIS_BELOW_ASSUMED, BASIS_NOT_ESTIMABLE, StatedNoise, estimated_noise, frequency_unknown
from .options import DamageOptions
from .parameters import DamageUnknowns
from .verify import Refined, Refiner, Verification, verify


# ------------------------------------------------------------------------------ detection
STATUSES = ("confirmed", "doubtful", "not localised", "unverified")


@dataclass(frozen=True, eq=False)
class DamageResult(Serialisable):
    """Result of :func:`detect_damage`; it writes the JSON and report of ``femupdate damage``
    (:mod:`femupdate.serialise`: ``to_json``, ``write_json``, ``write_report``; :mod:`femupdate.damage.record`).

    Attributes
    ----------
    parameters : dict
        Identified stiffnesses of the unknowns (the baseline's values where unchanged).
    baseline : dict
        The baseline values.
    changes : dict
        Relative change of every unknown from the baseline (-0.3: 30 % stiffness lost).
    located : list of str
        The unknowns judged damaged, largest loss first (empty when not localised).
    loss : dict
        Estimated stiffness loss (-change) of the located unknowns.
    confidence : dict
        ``selection_frequency`` {unknown: fraction of the bootstrap replicates — each re-localised,
        refined and verified — that locate it}, ``same_set`` (fraction locating exactly
        ``located``), ``standard_error`` {unknown: bootstrap spread of its change},
        ``evidence`` {unknown: rise of the chi-square misfit when it is left out},
        ``separation`` (the localisation step's smallest located ``|change|`` over the largest other
        ``|change|``), ``bootstrap`` (replicates), ``noise`` (levels used), and
        ``false_positive_rate`` and ``detection_rate``: simulated for this run (:mod:`.judge`: the
        whole chain on replicates of the healthy baseline and of the located model, with this run's
        sensors, modes and noise), each ``rate``, ``count``, ``n``, ``standard_error`` (binomial),
        ``interval`` (Clopper-Pearson, ``level``) and ``basis``; None without replicates.
    localised : bool
        False when the damage could not be localised (``reason`` says why).
    reason : str
        Why localisation was refused or failed (empty when ``localised``).
    detected : bool
        Whether the data differ from the baseline beyond the noise (frequency shifts).
    method : str
        The localisation's regulariser, ``"l1"`` or ``"tikhonov"``.
    alpha : float
        Its factor, absolute (NaN when localisation was refused).
    alpha_max : float
        The L1 α_max above which nothing changes (NaN for Tikhonov or when localisation was refused).
    tikhonov : dict
        For comparison: ``changes`` and ``alpha`` of the Tikhonov (GCV) solution, and
        ``n_above_threshold`` (how many unknowns it changes by more than ``min_change``).
    expansion : dict
        ``method``, ``n_basis``, ``error`` (per mode misfit), ``n_measured_dofs`` and
        ``n_rigid_modes``; only ``method`` when localisation was refused.
    pairs : list
        (test mode, baseline mode, MAC) at the measured dofs, paired by the rule ``update`` pairs by
        (:func:`femupdate.correlation.correlate`, ``auto``, close modes as groups).
    frequency_change : ndarray
        Relative frequency change of each measured mode from its baseline mode.
    baseline_check : dict or None
        :func:`check_baseline` against ``undamaged`` as a dict (None without ``undamaged``).
    path : list of dict
        The L1 path (α, located count, RSS, BIC).
    notes : list of str
        Remarks (e.g. no unknown changed by more than ``min_change``).
    status : str
        ``"confirmed"`` (the located set reproduces the data to the noise level, no other set of
        its size found that does, the replicates agree), ``"doubtful"`` (it reproduces the data,
        but so does another set, or most replicates locate another: ``doubts`` says which),
        ``"not localised"`` (no set of up to ``max_located`` unknowns reproduces the data, or
        the localisation was refused) or ``"unverified"`` (``refine=False``: the localisation
        step's answer, not checked against the data).
    doubts : list of str
        Why a location is doubtful.
    verification : dict
        ``level``, ``noise`` (the levels the residuals were divided by), ``chi2`` and ``dof``
        and ``limit`` of the final set, ``fits``, ``n_data`` (independent data), ``sets`` (every
        set fitted: ``members``, ``chi2``, ``limit``, ``fits``), ``alternatives`` (other sets
        that fit as well); empty without ``refine``.
    localisation : dict
        The sparse localisation step's own answer: ``located``, ``changes`` (non-zero ones) —
        the candidates the refinement started from.
    descriptions : dict
        {unknown: what it scales} as given (e.g. by :func:`~femupdate.damage.damage_unknowns`).
    pairing : dict
        ``rule``, ``used`` and ``flagged``: the pairs with the baseline to doubt (a frequency change
        beyond ``large_change`` or a MAC below ``localise_min_mac``), each ``test_mode``,
        ``baseline_mode`` (1-based), ``mac``, ``frequency_change``, ``why``.
    context : DamageContext, optional
        The baseline model, the test data, the kind of unknowns and the run's notes before the
        result's own (:class:`~femupdate.damage.record.DamageContext`): what :meth:`to_json` and
        :meth:`write_report` take from them.
    """

    kind: ClassVar[str] = "damage"

    parameters: dict[str, float]
    baseline: dict[str, float]
    changes: dict[str, float]
    located: list[str]
    loss: dict[str, float]
    confidence: dict
    localised: bool
    reason: str
    detected: bool
    method: str
    alpha: float
    alpha_max: float
    tikhonov: dict
    expansion: dict
    pairs: list
    frequency_change: np.ndarray
    baseline_check: dict | None = None
    path: list = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    status: str = "unverified"
    doubts: list[str] = field(default_factory=list)
    verification: dict = field(default_factory=dict)
    localisation: dict = field(default_factory=dict)
    descriptions: dict = field(default_factory=dict)
    pairing: dict = field(default_factory=dict)
    context: RunContext | None = field(default=None, compare=False, repr=False)

    def payload(self) -> dict:
        from .record import damage_kind

        return damage_kind(self, self.run_context)

    @classmethod
    def from_payload(cls, obj):
        from .record import damage_from

        return damage_from(obj)

    def records(self) -> list[dict]:
        """One record per unknown: its baseline and identified values, change, whether it was
        located, and its bootstrap standard error and selection frequency (:meth:`to_frame`'s rows)."""
        se = self.confidence.get("standard_error") or {}
        sel = self.confidence.get("selection_frequency") or {}
        return [{"unknown": n, "baseline": self.baseline.get(n), "identified": self.parameters.get(n), "change": c,
                 "located": n in self.located, "standard_error": se.get(n), "selection_frequency": sel.get(n),
                 "description": self.descriptions.get(n, "")} for n, c in self.changes.items()]


# ------------------------------------------------------------------------------ detection
def _unknowns(model: Model, elements: Sequence[str] | None) -> list[str]:
    names = list(elements) if elements is not None else [model.parameter_names[j] for j in model.free]
    if not names:
        raise InputError("no unknowns to localise: every parameter is fixed")
    return names


def _common(model: Model, names: Sequence[str], pairing: Pairing, sig_f: float, chk: dict | None,
            descriptions: Mapping[str, str] | None) -> dict[str, Any]:
    """The fields of every result: the baseline values, the pairing and frequency changes, the
    baseline check and the descriptions."""
    return dict(baseline=dict(zip(names, map(float, model.values[indices(model, names)]))),
                detected=bool(np.any(np.abs(pairing.frequency_change) > 3 * sig_f)), pairs=pairing.pairs,
                pairing=pairing.record(),
                frequency_change=pairing.frequency_change, baseline_check=chk,
                descriptions={n: str(descriptions[n]) for n in names if descriptions and n in descriptions})


def _poor_pairing(pairing: Pairing, options: DamageOptions) -> str | None:
    """Which measured modes pair with no baseline mode well enough for the expansion, if any."""
    poor = pairing.poor(options.localise_min_mac)
    if not poor:
        return None
    return ("measured mode(s) " + ", ".join(f"{k + 1} (best MAC {pairing.best[k][1]:.2f})" for k in poor)
            + f" pair with no baseline mode (MAC < {options.localise_min_mac:g})")


def _refused(names: Sequence[str], options: DamageOptions, common: dict, notes: list[str], reason: str) -> DamageResult:
    """The result when the expansion cannot be trusted and there is no refinement to turn to."""
    return DamageResult(parameters=dict(common["baseline"]), changes=dict.fromkeys(names, 0.0), located=[], loss={},
                        confidence={}, localised=False, reason=reason, method=options.method, alpha=math.nan,
                        alpha_max=math.nan, tikhonov={}, expansion={"method": options.expansion}, notes=notes,
                        status="not localised", localisation={"method": options.method, "located": [], "changes": {}},
                        **common)


def _result(names: Sequence[str], localiser: Localiser, loc: Localisation, verdict: Judgement, verification: Verification,
            n_rigid: int, common: dict, notes: list[str]) -> DamageResult:
    theta = localiser.equations.theta(verdict.delta)
    delta, order, fit = verdict.delta, verdict.order, loc.fit
    return DamageResult(
        parameters=dict(zip(names, map(float, theta[localiser.equations.idx]))),
        changes=dict(zip(names, map(float, delta))), located=[names[i] for i in order],
        loss={names[i]: float(-delta[i]) for i in order}, confidence=verdict.confidence,
        localised=verdict.status != "not localised", reason=verdict.reason, method=localiser.method, alpha=fit.alpha,
        alpha_max=fit.alpha_max, tikhonov=loc.tikhonov, expansion=localiser.expansion.as_dict(n_rigid), path=fit.path,
        notes=notes + verdict.notes, status=verdict.status, doubts=verdict.doubts, verification=verification.record,
        localisation=loc.record, **common)


def detect_damage(model: Model | DamageUnknowns, data: TestData, *, undamaged: TestData | None = None,
                  elements: Sequence[str] | None = None, noise: Mapping | None = None,
                  descriptions: Mapping[str, str] | None = None, options: DamageOptions | Mapping | None = None,
                  progress: Callable[[str, int, int], None] | None = None, **shorthand) -> DamageResult:
    """Localise, refine and verify stiffness loss from a validated baseline (module docstring).

    Parameters
    ----------
    model : Model or DamageUnknowns
        The baseline at its validated values; its stiffness parameters are the unknowns — the
        model's own (:func:`~femupdate.damage.damage_unknowns`) or one per element
        (:func:`element_parameters`).  Given the :class:`~femupdate.damage.DamageUnknowns` of
        :func:`~femupdate.damage.damage_unknowns`, its model, with its descriptions (unless
        ``descriptions`` is given), and the result's JSON names the kind of unknowns and carries
        its notes, as ``femupdate damage`` writes them.
    data : TestData
        Modes of the damaged structure.  The localisation uses the shapes at the dofs common to
        every mode; the refinement each mode at its own dofs (and modes without shapes).
    undamaged : TestData, optional
        Modes of the undamaged structure: the baseline is checked against them first
        (``max_frequency_error``, ``min_mac``) and localisation refused if it does not match.
    elements : sequence of str, optional
        The unknowns that may change (default every parameter not fixed).
    noise : mapping, optional
        ``{"frequency": relative std (default 0.001), "shape": std relative to each shape's
        largest measured value (default: from the SEREP misfit, else 0.005)}``: the equations of
        the localisation are weighted by it, the verification tests the misfit against it (zero:
        noise-free data, tested at round-off, ``NOISE_FLOOR``), the replicates carry it.
    descriptions : mapping, optional
        {unknown: what it scales}, carried into the result.
    options : DamageOptions or mapping, optional
        The method's knobs (:class:`~femupdate.damage.DamageOptions`: every field, its default
        and meaning).
    progress : callable ``(phase, done, total)``, optional
        Called as the work advances: phase ``"refine"`` (the search for the set that fits, one
        step), ``"bootstrap"`` (after each replicate) and ``"healthy"`` (after each replicate of the
        healthy baseline, which gives the false-positive rate).
    **shorthand
        Fields of :class:`~femupdate.damage.DamageOptions` as keywords (``bootstrap=0``,
        ``refine=False``, ...), changing ``options``.

    Returns
    -------
    DamageResult
        With its context (:class:`~femupdate.damage.record.DamageContext`): ``to_json()`` and
        ``write_report(path)`` give the JSON and report of ``femupdate damage``.

    Raises
    ------
    InputError
        An option out of range (:class:`~femupdate.damage.DamageOptions`), ``n_basis`` beyond the
        measured dofs, a noise level out of range, or an unknown noise key; no free parameter or
        an unknown name; a parameter entering M; measured modes without shapes at two or more
        common dofs; a baseline that does not match ``undamaged`` (:func:`check_baseline`).
    TypeError
        A keyword that is no field of :class:`~femupdate.damage.DamageOptions`.
    """
    problem_args("detect_damage", model.model if isinstance(model, DamageUnknowns) else model, data)
    data_arg(undamaged, "undamaged", "detect_damage", optional=True)
    params_arg(elements, "elements", "detect_damage")
    mapping_arg(noise, "noise", "detect_damage")
    mapping_arg(descriptions, "descriptions", "detect_damage")
    opts: DamageOptions = gather("detect_damage", shorthand, options=(DamageOptions, options))["options"]
    from .record import attach

    du = model if isinstance(model, DamageUnknowns) else None
    if du is not None:
        model = du.model
        descriptions = du.descriptions if descriptions is None else descriptions
    assert isinstance(model, Model)
    # the unknowns the caller chose (DamageUnknowns: the stiffness parameters; one entering M stays known)
    names = _unknowns(model, du.names if du is not None and elements is None else elements)
    from .parameters import mass_refusal
    mass_refusal(model, names)
    chk = None if undamaged is None else check_baseline(
        model, undamaged, max_frequency_error=opts.max_frequency_error, min_mac=opts.min_mac).as_dict()
    meas = measured_shapes(data)
    stated = stated_noise(noise, data)
    estimated, _, noise_notes = estimated_noise(model, names, data, stated)  # its test is in its note
    stated = estimated or stated
    pairing = pair_with_baseline(model, meas, opts.localise_min_mac)
    common = _common(model, names, pairing, stated.frequency, chk, descriptions)
    notes: list[str] = ([meas.note] if meas.note else []) + noise_notes
    if pairing.flagged:
        notes.append("pairs to doubt (test and baseline modes paired by the rule update pairs by): "
                     + "; ".join(f"test mode {f['test_mode']} with baseline mode {f['baseline_mode']}: {f['why']}"
                                 for f in pairing.flagged)
                     + ": the localisation's expansion leans on them; the refinement pairs each fit anew")
    poor = _poor_pairing(pairing, opts)
    if poor and not opts.refine:
        return attach(_refused(names, opts, common, notes, poor + ": the damage changed the dynamics too much for an expansion "
                        "by the baseline model; damage is detected but cannot be localised without identifying the "
                        "model anew"), model, data, undamaged, du)
    if poor:
        notes.append(poor + ": the damage changed the dynamics too much for an expansion by the baseline model, so the "
                     "sparse localisation is unreliable; the refinement, which compares the measured shapes directly, "
                     "chose the set")
    rng = np.random.default_rng(opts.seed)
    unknown_frequency = silent = frequency_unknown(stated)  # a second pass may follow: the first runs silent
    localiser, levels, more, loc, refiner, refined, realised, verification = _locate(
        model, names, meas, pairing, stated, opts, rng, data, None if silent else progress)
    again_run = False
    if unknown_frequency and refined is not None:  # the fit of every unknown could not tell it: the located set's fit
        again, again_notes = _located_noise(model, names, data, stated_noise(noise, data), refined,
                                            "frequency" if pairing.n_rigid else "auto")
        notes += again_notes
        if again is not None and not frequency_unknown(again):
            if dict(again.basis).get("frequency") == BASIS_BELOW_ASSUMED:
                notes.append("the localisation, refinement and verification were run again with the shape noise "
                             "estimated from the located set's fit and the assumed frequency noise, which that fit "
                             "shows to be larger than the frequencies' own")
            else:
                notes.append("the localisation, refinement and verification were run again with the noise estimated "
                             "from the located set's fit (a first pass had assumed the frequency noise); its frequency "
                             "test is then not independent of the fit, and an estimate from a selected set may be low")
            stated, unknown_frequency, again_run = again, False, True
            localiser, levels, more, loc, refiner, refined, realised, verification = _locate(
                model, names, meas, pairing, stated, opts, rng, data, progress)
    if silent and not again_run and opts.refine:  # the first pass ran silent and no second followed: said now
        _tell(progress, "refine", 0, 1)
        _tell(progress, "refine", 1, 1)
    if unknown_frequency:
        levels = dataclasses.replace(levels, basis=tuple((k, BASIS_NOT_ESTIMABLE if k == "frequency" else v)
                                                         for k, v in levels.basis))
    reps = bootstrap(opts.bootstrap, localiser, meas, levels, opts.alpha, rng, refiner, refined, realised,
                     progress=None if progress is None else lambda done, total: progress("bootstrap", done, total))
    healthy = Replicates.none()
    if refined is not None and reps.sets and not np.any(refined.delta):
        healthy = reps  # nothing located: the located model is the healthy baseline, its replicates the same draws
    elif refiner is not None and refined is not None and realised is not None:
        healthy = bootstrap_healthy(opts.bootstrap, refiner, refined, realised, pairing.pairs, opts.alpha, rng,
                                    progress=None if progress is None else lambda done, total: progress("healthy", done,
                                                                                                        total))
    verdict = judge(names, loc, verification, refined, reps, levels, detected=common["detected"], healthy=healthy,
                    baseline_checked=opts.baseline_checked or bool(chk and chk.get("ok")))
    verdict = error_std(verdict, dict(stated.dof), len(reps.changes))
    if unknown_frequency:
        verdict = conditional(verdict, levels.frequency)
    return attach(_result(names, localiser, loc, verdict, verification, pairing.n_rigid, common, notes + more), model,
                  data, undamaged, du)


def _located_noise(model: Model, names: Sequence[str], data: TestData, stated, refined: Refined, pairing: str):
    """The noise estimated from the fit of the set the refinement ended with, or, when its eigenvalues
    lack the redundancy there, of its members changed by ``min_change`` or more (``support``): the
    noise (None when neither tells the frequencies') and the notes of the fit used.  Each fit starts
    from the refinement's solution and pairs the modes as the refinement did (``pairing``): refitted
    from the baseline, a large change may be paired wrongly, and that fit then reads as a model error."""
    theta0 = dict(zip(model.parameter_names, np.asarray(model.values, float)))
    sets = [tuple(refined.final.members)]
    if refined.support.size and tuple(sorted(refined.support.tolist())) != sets[0]:
        sets.append(tuple(sorted(refined.support.tolist())))
    got: StatedNoise | None = None
    notes: list[str] = []
    for members in sets:
        got, _, notes = estimated_noise(model, names, data, stated, fitted=[names[i] for i in members],
                                        start={names[i]: theta0[names[i]] * (1 + float(refined.delta[i])) for i in members},
                                        pairing=pairing)
        if got is not None and not frequency_unknown(got):
            break
    return got, notes


def _locate(model: Model, names: Sequence[str], meas, pairing: Pairing, stated, opts: DamageOptions,
            rng: np.random.Generator, data: TestData, progress):
    """Localise, refine and verify under the noise ``stated``: (localiser, levels, notes, localisation,
    refiner, refined, realised data, verification); the last four empty without ``opts.refine``."""
    localiser, levels, more = make_localiser(model, names, meas, pairing, stated, opts, rng)
    loc = localise(localiser, names, meas, opts.alpha)
    refiner: Refiner | None = None
    refined: Refined | None = None
    realised: TestData | None = None
    verification = Verification()
    if opts.refine:
        _tell(progress, "refine", 0, 1)
        refiner = Refiner.of(model, names, localiser, levels, opts, pairing.n_rigid)
        realised = realised_data(data)
        refined = refiner.refine(realised, meas.eigenvalues, meas.shapes, loc.fit)
        verification = verify(refined)
        _tell(progress, "refine", 1, 1)
    return localiser, levels, more, loc, refiner, refined, realised, verification


def _tell(progress, phase: str, done: int, total: int) -> None:
    if progress is not None:
        progress(phase, done, total)


__all__ = ["detect_damage", "DamageResult", "STATUSES", "DamageOptions", "judge", "Judgement"]
