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
   false-positive rate :mod:`.rates` holds from ``benchmarks/bench_damage.py`` for comparable
   noise, sensors and modes.  With ``refine=False`` the measured data are perturbed instead and
   the localisation alone re-run (its confidence then ignores whether the set fits).

The equations are weighted by the inverse square root of their covariance under that same noise
(Monte Carlo at the baseline), so that rows dominated by shape noise — the orthogonality rows
— weigh less than the energy rows, whose Rayleigh-quotient form makes them insensitive to shape
errors to first order; the BIC then compares residuals in units of their noise.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import scipy.sparse as sp

from .._errors import InputError
from .._limits import MAX_MAGNITUDE
from ..dofs import describe, sort_key
from ..model import Model
from ..sensitivity.factor import single_thread_blas
from ..testdata import MeasuredMode, TestData
from .baseline import check_baseline, paired_modes
from .solvers import L1Fit, debias, l1_path, support_of, tikhonov

log = logging.getLogger(__name__)

METHODS = ("l1", "tikhonov")


# ------------------------------------------------------------------------------ equations
def _indices(model: Model, names: Sequence[str]) -> np.ndarray:
    """Positions of parameter names (one lookup table: models may have thousands of elements)."""
    pos = {n: j for j, n in enumerate(model.parameter_names)}
    unknown = [n for n in names if n not in pos]
    if unknown:
        model.parameter_index(unknown[0])  # the usual message, naming it
    return np.array([pos[n] for n in names], dtype=np.intp)


class _Equations:
    """Projected damage equations A δ = r of expanded modes (module docstring, step 4)."""

    def __init__(self, model: Model, names: Sequence[str], theta0: np.ndarray):
        self.model = model
        self.idx = _indices(model, names)
        if any(model.dM[j] is not None for j in self.idx):
            bad = [names[c] for c, j in enumerate(self.idx) if model.dM[j] is not None]
            raise InputError(f"damage detection parameters must be stiffness parameters; {', '.join(bad[:5])} enter M")
        self.theta0 = theta0
        rows, cols, vals, owner = [], [], [], []
        for c, j in enumerate(self.idx):
            d = model.dK_dp(j).tocoo()
            rows.append(d.row)
            cols.append(d.col)
            vals.append(d.data * theta0[j])
            owner.append(np.full(d.nnz, c))
        self.rows, self.cols = np.concatenate(rows), np.concatenate(cols)
        self.vals, own = np.concatenate(vals), np.concatenate(owner)
        self.n, self.L = model.n_dofs, len(self.idx)
        self.G = sp.csr_array((np.ones(own.size), (np.arange(own.size), own)), shape=(own.size, self.L)).T.tocsr()
        self.K0 = model.K(theta0)
        self.M = model.M(theta0)

    def build(self, lam: np.ndarray, Phi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Rows w_k^T (θ0,e K_e φ_i) δ = w_k^T (λ_i M - K(θ0)) φ_i / (λ_i ||M φ_i||), w = unit shapes."""
        W = Phi / np.linalg.norm(Phi, axis=0)
        Wr = W[self.rows]  # (nnz, m): the test vectors at each stiffness entry's row
        A_rows, r_rows = [], []
        for i in range(Phi.shape[1]):
            phi = Phi[:, i]
            Mphi = self.M @ phi
            s = 1.0 / (lam[i] * np.linalg.norm(Mphi))
            # sum over element e's entries (r, c): w_k[r] θ0_e K_e[r, c] φ_i[c]
            A_rows.append(np.asarray(self.G @ (Wr * (self.vals * phi[self.cols] * s)[:, None])).T)
            r_rows.append(W.T @ ((lam[i] * Mphi - self.K0 @ phi) * s))
        return np.vstack(A_rows), np.concatenate(r_rows)


WHITEN_RANGE = 1e-6  # noise variances below this fraction of the largest are treated as this floor (weights within 1e3)


def _whitener(R: np.ndarray) -> np.ndarray:
    """C^{-1/2} of the sample covariance of the rows of R (replicates x equations), its spectrum
    floored at ``WHITEN_RANGE`` of the largest variance (else the L1 problem turns stiff)."""
    C = np.cov(R, rowvar=False)
    w, V = np.linalg.eigh(np.atleast_2d(C))
    w = np.maximum(w, max(w.max(), 1e-300) * WHITEN_RANGE)
    keep = np.ones(w.size, dtype=bool)
    return (V[:, keep] / np.sqrt(w[keep])).T


# ------------------------------------------------------------------------------ detection
STATUSES = ("confirmed", "doubtful", "not localised", "unverified")


@dataclass(frozen=True, eq=False)
class DamageResult:
    """Result of :func:`detect_damage`.

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
        ``false_positive_rate``: the benchmark's measured rate for comparable noise, sensors and
        modes (:func:`femupdate.damage.rates.comparable_rate`; None without a comparable row).
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
        (test mode, baseline mode, MAC) at the measured dofs.
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
    """

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


def _realised(m: MeasuredMode) -> np.ndarray:
    """A measured shape as real numbers (a complex one rotated to its largest entry's phase)."""
    if np.iscomplexobj(m.shape):
        return np.real(m.shape * np.exp(-1j * np.angle(m.shape[np.argmax(np.abs(m.shape))])))
    return np.asarray(m.shape, float)


def _measured(data: TestData):
    modes = [m for m in data.modes if m.has_shape and len(m.dofs) >= 2]
    if not modes:
        raise InputError("damage detection needs measured mode shapes (at two or more dofs)")
    if len(modes) < len(data.modes):
        log.info("modes without shapes are ignored by the localisation")
    rigid = [m.label or f"mode {k + 1}" for k, m in enumerate(modes) if not m.eigenvalue >= 1 / MAX_MAGNITUDE]
    if rigid:
        raise InputError(f"{', '.join(rigid)}: zero frequency; damage detection needs elastic (non-rigid-body) modes")
    others = [set(m.dofs) for m in modes[1:]]
    common = [d for d in modes[0].dofs if all(d in o for o in others)]
    if len(common) < 2:
        raise InputError("the measured modes share fewer than two dofs; damage detection needs one sensor set")
    shapes = [_realised(m) for m in modes]
    rows = [[list(m.dofs).index(d) for d in common] for m in modes]
    Phi = np.column_stack([shapes[k][rows[k]] for k in range(len(modes))])
    dropped = {d for m in modes for d in m.dofs} - set(common)
    note = None
    if dropped:
        missing = "; ".join(f"{m.label or f'mode {k + 1}'} lacks {describe(sorted(dropped - set(m.dofs), key=sort_key))}"
                            for k, m in enumerate(modes) if dropped - set(m.dofs))
        note = (f"the modes were measured at different dofs ({missing}): the localisation uses only the {len(common)} "
                f"dofs measured in every mode, {describe(sorted(dropped, key=sort_key))} dropped")
    return tuple(common), Phi, np.array([m.eigenvalue for m in modes]), note


def _expansion_matrix(model, theta, dofs, method, n_basis) -> np.ndarray:
    """T (n_dofs, n_measured) with expanded shapes = T φ_a (every expansion method is linear)."""
    if len(dofs) == model.n_dofs:
        T = np.zeros((model.n_dofs, len(dofs)))
        T[model.dof_index(dofs), np.arange(len(dofs))] = 1.0
        return T
    from ..reduction import expand

    ex = expand(model, dofs, np.eye(len(dofs)), method=method, values=theta, n_modes=n_basis, warn_validation=False)
    return np.real(ex.shapes)


def _simulated(model, theta, data: TestData, pairs, sig_f: float, sig_s: float, rng) -> TestData:
    """Replicate test data from the model at ``theta``: each test mode's paired model mode at its
    dofs, scaled to 1 at its largest entry with the measured sign, plus the stated noise."""
    from ..modal import model_modes

    T = len(data.modes)
    modes = model_modes(model, theta, n_modes=min(model.n_dofs, max(2 * T, T + 6)))
    by_test = {k: j for k, j, _ in pairs}
    out = []
    for k, m in enumerate(data.modes):
        j = by_test.get(k, k)
        lam = modes.eigenvalues[j] * (1 + sig_f * rng.standard_normal()) ** 2
        if m.has_shape and len(m.dofs) >= 2:
            sh = modes.shapes[model.dof_index(m.dofs), j]
            sh = sh / sh[np.argmax(np.abs(sh))]
            if sh @ _realised(m) < 0:
                sh = -sh
            out.append(MeasuredMode(lam, m.dofs, sh + sig_s * rng.standard_normal(sh.size), m.label))
        else:
            out.append(MeasuredMode(lam, label=m.label))
    return TestData(modes=tuple(out))


def detect_damage(model: Model, data: TestData, *, undamaged: TestData | None = None, elements: Sequence[str] | None = None,
                  method: str = "l1", alpha: float | None = None, expansion: str = "serep", n_basis: int | None = None,
                  allow_increase: bool = False, min_change: float = 0.05, iterations: int = 3, bootstrap: int = 20,
                  noise: Mapping | None = None, seed: int = 0, localise_min_mac: float = 0.8,
                  max_frequency_error: float = 0.02, min_mac: float = 0.9, n_noise: int | None = None,
                  refine: bool = True, level: float = 0.99, max_located: int | None = None,
                  descriptions: Mapping[str, str] | None = None) -> DamageResult:
    """Localise, refine and verify stiffness loss from a validated baseline (module docstring).

    Parameters
    ----------
    model : Model
        The baseline at its validated values; its stiffness parameters are the unknowns — the
        model's own (:func:`~femupdate.damage.damage_unknowns`) or one per element
        (:func:`element_parameters`).
    data : TestData
        Modes of the damaged structure.  The localisation uses the shapes at the dofs common to
        every mode; the refinement each mode at its own dofs (and modes without shapes).
    undamaged : TestData, optional
        Modes of the undamaged structure: the baseline is checked against them first
        (``max_frequency_error``, ``min_mac``) and localisation refused if it does not match.
    elements : sequence of str, optional
        The unknowns that may change (default every parameter not fixed).
    method : {"l1", "tikhonov"}, default "l1"
        Localisation by L1 (sparse) or Tikhonov with the factor chosen by GCV.
    alpha : float, optional
        L1 factor as a fraction of α_max, in (0, 1] (default: chosen by BIC on a path).
    expansion : {"serep", "irs", "guyan"}, default "serep"
        Expansion of the measured shapes to every dof (unused when every dof is measured).
    n_basis : int, optional
        SEREP modes (default: the model modes up to the highest one a measured mode pairs
        with, plus as many again, at most the number of measured dofs).
    allow_increase : bool, default False
        Let stiffness increase too (default: loss only, -1 <= change <= 0; with it, up to +1).
    min_change : float, default 0.05
        A relative change smaller than this is not reported as damage; in (0, 1).
    iterations : int, default 3
        Expansions of the localisation step, the first with the baseline, the next ones with the
        damaged estimate (which removes the bias of the baseline expansion: a true 40 % loss in
        one member of an 8 x 8-node lattice truss came out 53 %, 39.4 %, 40.0 % after 1, 2, 4
        expansions).
    bootstrap : int, default 20
        Replicates for the confidence: data simulated from the identified model with the stated
        noise, each re-localised, refined and verified (0: none; none either when the stated
        noise is zero).
    noise : mapping, optional
        ``{"frequency": relative std (default 0.001), "shape": std relative to each shape's
        largest measured value (default: from the SEREP misfit, else 0.005)}``: the equations of
        the localisation are weighted by it, the verification tests the misfit against it (zero:
        noise-free data, tested at round-off, ``NOISE_FLOOR``), the replicates carry it.
    seed : int, default 0
        Seed of the replicates (noise weights and bootstrap).
    localise_min_mac : float, default 0.8
        A measured mode pairing with no baseline mode at least this well (0.8 is the usual
        threshold for "the same mode") makes the expansion unreliable: without ``refine`` it
        stops the localisation (``localised`` False, ``reason``); with it, a note says so and the
        refinement, which needs no expansion, chooses the set.
    max_frequency_error : float, default 0.02
        Largest relative frequency error of the baseline against ``undamaged``
        (:func:`check_baseline`; unused without ``undamaged``).
    min_mac : float, default 0.9
        Smallest MAC of the baseline against ``undamaged`` (likewise).
    n_noise : int, optional
        Replicates estimating the equations' covariance (default four per equation, 60 to 400).
    refine : bool, default True
        Refine the located set by nonlinear updating and verify it (:mod:`.refine`); False: the
        localisation step's answer alone (``status`` "unverified"; the method before refinement).
    level : float, default 0.99
        Confidence level of the verification (chi-square test of the misfit), in (0.5, 1).
    max_located : int, optional
        Largest set the search enlarges to (default ``min(L, 8)``).
    descriptions : mapping, optional
        {unknown: what it scales}, carried into the result.

    Returns
    -------
    DamageResult

    Raises
    ------
    InputError
        An unknown ``method``; ``min_change``, ``alpha``, ``iterations``, ``bootstrap``, ``n_basis``,
        ``level``, ``max_located`` or a noise level out of range, or an unknown noise key; no free
        parameter or an unknown name; a parameter entering M; measured modes without shapes at two
        or more common dofs; a baseline that does not match ``undamaged`` (:func:`check_baseline`).
    """
    from .refine import SetSearch

    if method not in METHODS:
        raise InputError(f"unknown method {method!r}: use {', '.join(METHODS)}")
    if not 0 < min_change < 1:
        raise InputError(f"min_change must lie in (0, 1), got {min_change!r}")
    if alpha is not None and not 0 < alpha <= 1:
        raise InputError(f"alpha is a fraction of alpha_max in (0, 1], got {alpha!r}")
    if int(iterations) < 1 or int(bootstrap) < 0:
        raise InputError("iterations must be >= 1 and bootstrap >= 0")
    if not 0.5 < float(level) < 1:
        raise InputError(f"level must lie in (0.5, 1), got {level!r}")
    if max_located is not None and int(max_located) < 1:
        raise InputError(f"max_located must be >= 1, got {max_located!r}")
    all_names = model.parameter_names
    names = list(elements) if elements is not None else [all_names[j] for j in model.free]
    if not names:
        raise InputError("no unknowns to localise: every parameter is fixed")
    theta0 = model.values
    chk = None
    if undamaged is not None:
        chk = check_baseline(model, undamaged, max_frequency_error=max_frequency_error, min_mac=min_mac).as_dict()
    dofs, Phi_a, lam, dropped_note = _measured(data)
    n_s, m = Phi_a.shape
    noise = dict(noise or {})
    unknown_noise = sorted(set(noise) - {"frequency", "shape"})
    if unknown_noise:
        raise InputError(f"noise: unknown key(s) {', '.join(unknown_noise)} (use frequency, shape)")
    sig_f = float(noise.get("frequency", 0.001))
    if not sig_f >= 0 or not float(noise.get("shape", 0.0)) >= 0:
        raise InputError("noise levels must be >= 0")
    lower, upper = -1.0 + 1e-9, (1.0 if allow_increase else 0.0)
    # pairing with the baseline and the frequency changes
    measured = TestData(modes=tuple(MeasuredMode(lam[k], dofs, Phi_a[:, k]) for k in range(m)))
    base_modes, _, pairs = paired_modes(model, measured, None, 0.0)
    best = {k: (j, mm) for k, j, mm in pairs}
    fchange = np.array([math.sqrt(lam[k] / base_modes.eigenvalues[best[k][0]]) - 1.0 for k in range(m)])
    detected = bool(np.any(np.abs(fchange) > 3 * sig_f))
    notes: list[str] = [dropped_note] if dropped_note else []
    n_rigid = int(np.sum(base_modes.eigenvalues <= 0))
    idx = _indices(model, names)
    desc = {n: str(descriptions[n]) for n in names if descriptions and n in descriptions}
    common: dict[str, Any] = dict(baseline=dict(zip(names, map(float, theta0[idx]))), detected=detected,
                                  pairs=[(k, j, float(mm)) for k, (j, mm) in sorted(best.items())],
                                  frequency_change=fchange, baseline_check=chk, descriptions=desc)
    poor = [k for k in range(m) if best[k][1] < localise_min_mac]
    poor_text = ("measured mode(s) " + ", ".join(f"{k + 1} (best MAC {best[k][1]:.2f})" for k in poor)
                 + f" pair with no baseline mode (MAC < {localise_min_mac:g})")
    if poor and refine:
        notes.append(poor_text + ": the damage changed the dynamics too much for an expansion by the baseline model, "
                     "so the sparse localisation is unreliable; the refinement, which compares the measured shapes "
                     "directly, chose the set")
    elif poor:
        reason = (poor_text + ": the damage changed the dynamics too much for an expansion by the baseline model; damage "
                  "is detected but cannot be localised without identifying the model anew")
        return DamageResult(parameters=dict(common["baseline"]), changes=dict.fromkeys(names, 0.0), located=[], loss={},
                            confidence={}, localised=False, reason=reason, method=method, alpha=math.nan,
                            alpha_max=math.nan, tikhonov={}, expansion={"method": expansion}, notes=notes,
                            status="not localised", localisation={"method": method, "located": [], "changes": {}}, **common)
    full = len(dofs) == model.n_dofs
    chosen = n_basis is None
    if n_basis is None:
        n_basis = min(n_s, 2 * (max(j for j, _ in best.values()) + 1))
    n_basis = int(n_basis)
    if not (full or 1 <= n_basis <= n_s):
        raise InputError(f"n_basis must lie between 1 and the number of measured dofs ({n_s}), got {n_basis}")
    eq = _Equations(model, names, theta0)
    while True:
        try:
            T0 = _expansion_matrix(model, theta0, dofs, expansion, n_basis)
            break
        except InputError as exc:
            # the default basis: fewer modes when the sensors cannot tell that many apart
            if not chosen or full or n_basis <= 1 or expansion != "serep":
                raise
            log.info("%s; trying %d modes", exc, n_basis - 1)
            n_basis -= 1
    if chosen and not full and n_basis < min(n_s, 2 * (max(j for j, _ in best.values()) + 1)):
        notes.append(f"the sensors do not tell apart as many model modes as the default SEREP basis holds: "
                     f"{n_basis} modes used" + (f", fewer than the {m} measured: the expansion, and so the "
                                               "localisation, is approximate" if n_basis < m else ""))

    def expansion_at(theta, fallback):
        """The expansion with the damaged estimate (the previous one where the sensors cannot tell its modes apart)."""
        try:
            return _expansion_matrix(model, theta, dofs, expansion, n_basis)
        except InputError:
            return fallback
    pos = model.dof_index(dofs)
    misfit = np.linalg.norm(T0[pos] @ Phi_a - Phi_a, axis=0) / np.linalg.norm(Phi_a, axis=0)
    # noise: the shape level from the expansion misfit where the basis is smaller than the sensor set
    if "shape" in noise:
        sig_s = float(noise["shape"])
    elif not full and n_s > n_basis:
        sig_s = float(np.median(misfit * np.linalg.norm(Phi_a, axis=0) / np.sqrt(n_s - n_basis) / np.max(np.abs(Phi_a), axis=0)))
    else:
        sig_s = 0.005
    # the verification's shape noise: as stated; else, from the expansion misfit pooled over the modes, at the
    # upper end of its 99 % confidence interval (a level underestimated would refuse the right set)
    sig_s_verify = sig_s
    if "shape" not in noise and not full and n_s > n_basis:
        from scipy.special import chdtri

        nu = m * (n_s - n_basis)
        pooled = float(np.sqrt(np.sum((misfit * np.linalg.norm(Phi_a, axis=0) / np.max(np.abs(Phi_a), axis=0)) ** 2) / nu))
        sig_s_verify = pooled * math.sqrt(nu / float(chdtri(nu, 1 - 0.01)))
        notes.append(f"shape noise not stated: the verification takes {sig_s_verify:.3g} (the expansion misfit pooled over "
                     "the modes, upper end of its 99 % confidence interval; --noise-shape to state it)")
    rng = np.random.default_rng(seed)
    peak = np.max(np.abs(Phi_a), axis=0)

    def perturbed() -> tuple[np.ndarray, np.ndarray]:
        return (lam * (1.0 + sig_f * rng.standard_normal(m)) ** 2,
                Phi_a + sig_s * peak * rng.standard_normal(Phi_a.shape))

    # weights: the equations' covariance under the measurement noise, at the baseline
    n_rows = m * m
    n_rep = int(n_noise) if n_noise is not None else int(min(400, max(60, 4 * n_rows)))
    R = np.array([eq.build(lb, T0 @ pb)[1] for lb, pb in (perturbed() for _ in range(n_rep))])
    Wt = _whitener(R) if sig_f > 0 or sig_s > 0 else np.eye(n_rows)

    def solve_once(lam_k, Phi_k, fixed_alpha=None):
        theta, T, fit = theta0.copy(), T0, None
        for it in range(int(iterations)):
            if it:
                T = expansion_at(theta, T)
            A, r = eq.build(lam_k, T @ Phi_k)
            A, r = Wt @ A, Wt @ r
            with single_thread_blas():  # small dense problems: OpenBLAS threads only add hand-off time
                if method == "l1" and it:
                    # later expansions re-estimate the located elements' loss; the location stays
                    S = support_of(fit.debiased, min_change)
                    fit = L1Fit(fit.l1, debias(A, r, S, lower, upper), fit.alpha, fit.alpha_max, fit.path, fit.order)
                elif method == "l1":
                    fit = l1_path(A, r, lower, upper, min_change, fixed_alpha)
                else:
                    d_t, a_t = tikhonov(A, r)
                    d_t = np.clip(d_t, lower, upper)
                    fit = L1Fit(d_t, d_t, a_t, math.nan, [], np.argsort(-np.abs(d_t), kind="stable"))
            theta = theta0.copy()
            theta[eq.idx] = theta0[eq.idx] * (1.0 + fit.debiased)
        return fit, A, r

    def scorer(lam_k, Phi_k):
        """The linearised gradient of the misfit at a damaged estimate: the projected equations,
        the shapes expanded with that estimate, correlated with their residual (per unit column)."""
        memo: dict[bytes, np.ndarray] = {}

        def score(delta: np.ndarray) -> np.ndarray:
            key = np.asarray(delta, float).tobytes()
            if key not in memo:
                theta = theta0.copy()
                theta[eq.idx] = theta0[eq.idx] * (1.0 + delta)
                A, r = eq.build(lam_k, expansion_at(theta, T0) @ Phi_k)
                A, r = Wt @ A, Wt @ r
                g = A.T @ (r - A @ delta)
                norm = np.maximum(np.linalg.norm(A, axis=0), 1e-300)
                memo[key] = (np.abs(g) if allow_increase else np.maximum(-g, 0.0)) / norm
            return memo[key]

        return score

    n_max = min(len(names), int(max_located) if max_located is not None else 8)

    def search_for(data_k: TestData, lam_k, Phi_k, fit_k):
        srch = SetSearch(model, names, data_k, sig_f, sig_s_verify, allow_increase=allow_increase, min_change=min_change,
                         level=level, max_located=n_max, score=scorer(lam_k, Phi_k),
                         path_order=() if fit_k.order is None else fit_k.order,
                         pairing="frequency" if n_rigid else "auto")
        S0 = support_of(fit_k.debiased, min_change)
        return srch, srch.run(S0.tolist(), fit_k.debiased)

    fit, A, r = solve_once(lam, Phi_a, alpha)
    tk = {}
    if method == "l1":
        with single_thread_blas():
            d_t, a_t = tikhonov(A, r)
        tk = {"changes": dict(zip(names, map(float, d_t))), "alpha": a_t,
              "n_above_threshold": int(np.sum(np.abs(d_t) >= min_change))}
    S_loc = support_of(fit.debiased, min_change)
    localisation = {"method": method, "located": [names[i] for i in S_loc[np.argsort(-np.abs(fit.debiased[S_loc]))]],
                    "changes": {names[i]: float(fit.debiased[i]) for i in S_loc}}
    others = np.setdiff1d(np.arange(len(names)), S_loc)
    big_other = float(np.max(np.abs(fit.l1[others]))) if others.size else 0.0
    sep = (float(np.min(np.abs(fit.debiased[S_loc]))) / big_other if big_other > 0 else math.inf) if S_loc.size else math.nan
    noise_used = {"frequency": sig_f, "shape": sig_s}
    status, doubts, reason, verification = "unverified", [], "", {}
    final = None
    if refine:
        realised = TestData(modes=tuple(MeasuredMode(mo.eigenvalue, mo.dofs, _realised(mo), mo.label) if mo.has_shape
                                        else MeasuredMode(mo.eigenvalue, label=mo.label) for mo in data.modes))
        with single_thread_blas():
            srch, final = search_for(realised, lam, Phi_a, fit)
            alts = srch.alternatives(final) if final.fits else []
            evidence = srch.evidence(final) if final.fits else {}
        delta = final.delta if final.fits else np.zeros(len(names))
        S = np.array([i for i in final.members if abs(delta[i]) >= min_change], dtype=np.intp) if final.fits else np.zeros(0, np.intp)
        from .refine import NOISE_FLOOR

        verification = {
            "level": float(level), "noise": {"frequency": max(sig_f, NOISE_FLOOR) * srch.noise_factor,
                                             "shape": max(sig_s_verify, NOISE_FLOOR) * srch.noise_factor},
            "noise_factor": srch.noise_factor,
            "n_data": srch.n_data, "chi2": final.chi2, "dof": final.dof, "limit": final.limit, "fits": final.fits,
            "members": [names[i] for i in final.members],
            "sets": [{"members": [names[i] for i in f.members], "chi2": f.chi2, "limit": f.limit, "fits": f.fits}
                     for f in srch.trail],
            "alternatives": [{"members": [names[i] for i in g.members], "chi2": g.chi2, "limit": g.limit,
                              "changes": {names[i]: float(g.delta[i]) for i in g.members}} for g in alts],
        }
        if final.fits:
            status = "confirmed"
            if srch.noise_factor > 1:
                status = "doubtful"
                doubts.append(f"not even every unknown changing at once reproduces the data to the stated noise: the "
                              f"noise is larger than stated, or the baseline model is wrong; the location was judged "
                              f"with the noise taken {srch.noise_factor:.3g} times the stated one")
            small = [names[i] for i in final.members if abs(final.delta[i]) < min_change]
            if small:
                notes.append(f"{', '.join(small)} changed by less than min_change but are needed to reproduce the data "
                             "(not reported as damage; their changes are in `changes`)")
            if alts:
                status = "doubtful"
                doubts.append(f"{len(alts)} other set(s) of the same size fit the data as well, e.g. "
                              + " + ".join(names[i] for i in alts[0].members)
                              + f" (chi-square {alts[0].chi2:.3g}, limit {alts[0].limit:.3g})")
        else:
            status = "not localised"
            best_f = min(srch.trail, key=lambda f: f.chi2)
            small_fit = [f for f in srch.trail if f.fits]
            reason = (f"the smallest set found that reproduces the data, "
                      f"{' + '.join(names[i] for i in min(small_fit, key=lambda f: len(f.members)).members)}, has more "
                      f"than {n_max} unknown(s) (max_located): the data do not localise the damage to that few unknowns"
                      if small_fit else
                      f"no set of up to {n_max} unknown(s) reproduces the data to the stated noise (frequency "
                      f"{sig_f:g}, shape {sig_s_verify:.3g}; chi-square test at {level:g}): the best, "
                      f"{' + '.join(names[i] for i in best_f.members) or 'the baseline'}, leaves a misfit of "
                      f"{best_f.chi2:.4g} for a limit of {best_f.limit:.4g}; the data do not localise the damage "
                      "(more modes or sensors, another choice of unknowns, or a larger --max-located)")
    else:
        delta = fit.debiased
        S = S_loc
        evidence = {}
    order = S[np.argsort(-np.abs(delta[S]))]
    located = [names[i] for i in order]
    # bootstrap: replicates simulated from the identified model, each localised, refined and verified anew
    n_boot = int(bootstrap)
    reps: list[tuple[set, np.ndarray]] = []
    if n_boot and refine and final is not None and final.fits and (sig_f > 0 or sig_s_verify > 0):
        theta_hat = theta0.copy()
        theta_hat[eq.idx] = theta0[eq.idx] * (1.0 + delta)
        for _ in range(n_boot):
            data_k = _simulated(model, theta_hat, realised, final.pairs, sig_f, sig_s_verify, rng)
            _, Phi_k, lam_k, _ = _measured(data_k)
            fit_k, _, _ = solve_once(lam_k, Phi_k, alpha)
            with single_thread_blas():
                _, f_k = search_for(data_k, lam_k, Phi_k, fit_k)
            d_k = f_k.delta if f_k.fits else np.zeros(len(names))
            reps.append(({i for i in f_k.members if abs(d_k[i]) >= min_change} if f_k.fits else set(), d_k))
    elif n_boot and not refine:
        for _ in range(n_boot):
            d_k = solve_once(*perturbed(), alpha)[0].debiased
            reps.append((set(support_of(d_k, min_change).tolist()), d_k))
    elif n_boot and refine and final is not None and final.fits:
        notes.append("no noise stated (zero): the bootstrap has nothing to vary and was skipped")
        n_boot = 0
    elif n_boot and refine:
        n_boot = 0
    if reps:
        D = np.array([d for _, d in reps])
        sel = np.array([[i in s for i in range(len(names))] for s, _ in reps]).mean(axis=0)
        se = D.std(axis=0, ddof=1) if len(reps) > 1 else np.full(len(names), math.nan)
        same = float(np.mean([s == set(order.tolist()) for s, _ in reps]))
    else:
        sel, se, same = np.full(len(names), math.nan), np.full(len(names), math.nan), math.nan
    confidence = {
        "selection_frequency": {names[i]: float(sel[i]) for i in range(len(names)) if sel[i] > 0 or i in S},
        "standard_error": {names[i]: float(se[i]) for i in S},
        "separation": sep, "bootstrap": n_boot, "noise": noise_used,
        "same_set": same, "evidence": {names[i]: float(v) for i, v in evidence.items() if i in set(S.tolist())},
    }
    if refine and status == "confirmed" and reps and same < 0.5:
        status = "doubtful"
        doubts.append(f"only {same * 100:.0f} % of the {len(reps)} bootstrap replicates locate this set")
    from .rates import comparable_rate

    confidence["false_positive_rate"] = comparable_rate(max(sig_f, sig_s_verify), n_s / model.n_dofs, len(data.modes))
    theta = theta0.copy()
    theta[eq.idx] = theta0[eq.idx] * (1.0 + delta)
    if not located and status != "not localised":
        notes.append("no unknown changed by more than min_change" + (" although the frequencies changed" if detected else ""))
    return DamageResult(
        parameters=dict(zip(names, map(float, theta[idx]))),
        changes=dict(zip(names, map(float, delta))), located=located, loss={names[i]: float(-delta[i]) for i in order},
        confidence=confidence, localised=status != "not localised", reason=reason, method=method, alpha=fit.alpha,
        alpha_max=fit.alpha_max, tikhonov=tk,
        expansion={"method": "none (every dof measured)" if full else expansion, "n_basis": None if full else n_basis,
                   "error": misfit, "n_measured_dofs": n_s, "n_rigid_modes": n_rigid},
        path=fit.path, notes=notes, status=status, doubts=doubts, verification=verification, localisation=localisation,
        **common,
    )


__all__ = ["detect_damage", "DamageResult", "STATUSES"]
