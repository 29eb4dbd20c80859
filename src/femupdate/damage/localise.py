r"""The localisation step of :func:`~femupdate.damage.detect_damage` (its module docstring, steps
3-5): the measured shapes at their common dofs (:func:`measured_shapes`), paired with the baseline
(:func:`pair_with_baseline`), expanded to every dof (:func:`expansion`), the noise levels they
carry (:func:`noise_levels`), the projected equations weighted by their covariance under that
noise (:class:`Equations`, :func:`noise_weights`), and their L1 (or Tikhonov) solution
(:class:`Localiser`, :func:`localise`).

Each step takes what it needs and returns a small frozen object: the bootstrap re-runs
:meth:`Localiser.solve` on every replicate, the refinement scores its candidates with
:meth:`Localiser.scorer`.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from .._errors import InputError
from .._limits import MAX_MAGNITUDE
from ..dofs import describe, sort_key
from ..model import Model
from ..sensitivity.factor import single_thread_blas
from ..testdata import MeasuredMode, TestData
from .baseline import paired_modes
from .noise import (BASIS_ASSUMED, BASIS_CALLER, BASIS_DATA, BASIS_EXPANSION, DEFAULT_FREQUENCY_NOISE,  # noqa: F401
                    DEFAULT_SHAPE_NOISE, NoiseLevels, StatedNoise, data_noise, noise_levels, perturbed, stated_noise)
from .options import DamageOptions
from .solvers import L1Fit, debias, l1_path, support_of, tikhonov

log = logging.getLogger(__name__)

WHITEN_RANGE = 1e-6  # noise variances below this fraction of the largest are treated as this floor (weights within 1e3)


# ------------------------------------------------------------------------------ the data
def indices(model: Model, names: Sequence[str]) -> np.ndarray:
    """Positions of parameter names (one lookup table: models may have thousands of elements)."""
    pos = {n: j for j, n in enumerate(model.parameter_names)}
    unknown = [n for n in names if n not in pos]
    if unknown:
        model.parameter_index(unknown[0])  # the usual message, naming it
    return np.array([pos[n] for n in names], dtype=np.intp)


def realised(m: MeasuredMode) -> np.ndarray:
    """A measured shape as real numbers (a complex one rotated to its largest entry's phase)."""
    if np.iscomplexobj(m.shape):
        return np.real(m.shape * np.exp(-1j * np.angle(m.shape[np.argmax(np.abs(m.shape))])))
    return np.asarray(m.shape, float)


def realised_data(data: TestData) -> TestData:
    """The test data with every shape real (:func:`realised`), as the refinement fits them."""
    return TestData(modes=tuple(MeasuredMode(mo.eigenvalue, mo.dofs, realised(mo), mo.label) if mo.has_shape
                                else MeasuredMode(mo.eigenvalue, label=mo.label) for mo in data.modes))


@dataclass(frozen=True, eq=False)
class Measured:
    """The damaged structure's modes as the localisation sees them: real shapes at the dofs every
    mode was measured at.

    Attributes
    ----------
    dofs : tuple of str
        The common dofs (n_s of them).
    shapes : ndarray, shape ``(n_s, m)``
        One measured shape per column.
    eigenvalues : ndarray, shape ``(m,)``
        The measured eigenvalues.
    note : str or None
        Which dofs were dropped because not every mode was measured there.
    """

    dofs: tuple[str, ...]
    shapes: np.ndarray
    eigenvalues: np.ndarray
    note: str | None = None

    @property
    def n_sensors(self) -> int:
        return int(self.shapes.shape[0])

    @property
    def n_modes(self) -> int:
        return int(self.shapes.shape[1])


def measured_shapes(data: TestData) -> Measured:
    """The shaped modes of ``data`` at their common dofs; :class:`InputError` when there are none,
    a mode has zero frequency, or the modes share fewer than two dofs."""
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
    shapes = [realised(m) for m in modes]
    rows = [[list(m.dofs).index(d) for d in common] for m in modes]
    Phi = np.column_stack([shapes[k][rows[k]] for k in range(len(modes))])
    dropped = {d for m in modes for d in m.dofs} - set(common)
    note = None
    if dropped:
        missing = "; ".join(f"{m.label or f'mode {k + 1}'} lacks {describe(sorted(dropped - set(m.dofs), key=sort_key))}"
                            for k, m in enumerate(modes) if dropped - set(m.dofs))
        note = (f"the modes were measured at different dofs ({missing}): the localisation uses only the {len(common)} "
                f"dofs measured in every mode, {describe(sorted(dropped, key=sort_key))} dropped")
    return Measured(tuple(common), Phi, np.array([m.eigenvalue for m in modes]), note)


@dataclass(frozen=True, eq=False)
class Pairing:
    """The measured modes paired with the baseline's (at the measured dofs) by the one rule
    (:func:`~femupdate.damage.baseline.paired_modes`: ``update``'s).

    Attributes
    ----------
    best : dict
        {test mode: (baseline mode, MAC)}.
    frequency_change : ndarray, shape ``(m,)``
        Relative frequency change of each measured mode from its baseline mode.
    n_rigid : int
        Rigid-body modes of the baseline (among those computed).
    flagged : list of dict
        The pairs to doubt: ``test_mode``, ``baseline_mode`` (1-based), ``mac``, ``frequency_change``
        and ``why`` (a frequency change beyond ``LARGE_CHANGE``, a MAC below ``min_mac``).
    used : str
        The rule that made the pairs (``order``, ``frequency`` or ``mac``).
    """

    best: dict[int, tuple[int, float]]
    frequency_change: np.ndarray
    n_rigid: int
    flagged: tuple = ()
    used: str = "order"

    @property
    def pairs(self) -> list[tuple[int, int, float]]:
        """(test mode, baseline mode, MAC), by test mode."""
        return [(k, j, float(mm)) for k, (j, mm) in sorted(self.best.items())]

    @property
    def highest(self) -> int:
        """The highest baseline mode a measured mode pairs with (0-based)."""
        return max(j for j, _ in self.best.values())

    def poor(self, min_mac: float) -> list[int]:
        """The measured modes that pair with no baseline mode at least ``min_mac`` well."""
        return [k for k in range(len(self.frequency_change)) if self.best[k][1] < min_mac]

    def record(self) -> dict:
        """The result's ``pairing``: the rule and the flagged pairs."""
        return {"rule": "auto (as update pairs: by frequency order unless the shapes show a swap, close modes as "
                        "groups)", "used": self.used, "large_change": LARGE_CHANGE,
                "flagged": [dict(f) for f in self.flagged]}


#: a relative frequency change of a pair beyond this is flagged (the pairing rule's own window)
LARGE_CHANGE = 0.1


def pair_with_baseline(model: Model, meas: Measured, min_mac: float = 0.8) -> Pairing:
    """Pair the measured modes with the baseline's by the one rule (``update``'s, at the measured
    dofs); pairs that cross a frequency change beyond ``LARGE_CHANGE`` or whose MAC is below
    ``min_mac`` are flagged."""
    lam, Phi_a = meas.eigenvalues, meas.shapes
    measured = TestData(modes=tuple(MeasuredMode(lam[k], meas.dofs, Phi_a[:, k]) for k in range(meas.n_modes)))
    base_modes, corr = paired_modes(model, measured, None)
    best = {k: (j, mm) for k, j, mm in corr.pairs}
    missing = [k for k in range(meas.n_modes) if k not in best]
    if missing:
        raise InputError(f"measured mode(s) {', '.join(str(k + 1) for k in missing)} pair with no baseline mode "
                         f"(fewer baseline modes computed than measured)")
    fchange = np.array([math.sqrt(lam[k] / base_modes.eigenvalues[best[k][0]]) - 1.0 for k in range(meas.n_modes)])
    flagged = []
    for k in range(meas.n_modes):
        j, mm = best[k]
        why = ([f"frequency change {fchange[k] * 100:+.1f} % (beyond {LARGE_CHANGE * 100:g} %)"]
               if abs(fchange[k]) > LARGE_CHANGE else []) + ([f"MAC {mm:.2f} (below {min_mac:g})"] if mm < min_mac else [])
        if why:
            flagged.append({"test_mode": k + 1, "baseline_mode": j + 1, "mac": float(mm),
                            "frequency_change": float(fchange[k]), "why": "; ".join(why)})
    used = corr.pairing.used if corr.pairing is not None else "order"
    return Pairing(best, fchange, int(np.sum(base_modes.eigenvalues <= 0)), tuple(flagged), used)


# ------------------------------------------------------------------------------ expansion
def expansion_matrix(model, theta, dofs, method, n_basis) -> np.ndarray:
    """T (n_dofs, n_measured) with expanded shapes = T φ_a (every expansion method is linear)."""
    if len(dofs) == model.n_dofs:
        T = np.zeros((model.n_dofs, len(dofs)))
        T[model.dof_index(dofs), np.arange(len(dofs))] = 1.0
        return T
    from ..reduction import expand

    ex = expand(model, dofs, np.eye(len(dofs)), method=method, values=theta, n_modes=n_basis, warn_validation=False)
    return np.real(ex.shapes)


@dataclass(frozen=True, eq=False)
class Expansion:
    """The expansion of the measured shapes to every dof (module docstring of :mod:`.detect`, step 3).

    Attributes
    ----------
    model : Model
        The baseline.
    dofs : tuple of str
        The measured dofs.
    method : str
        ``"serep"``, ``"irs"`` or ``"guyan"``.
    n_basis : int
        SEREP modes.
    T0 : ndarray, shape ``(n_dofs, n_s)``
        The expansion by the baseline.
    error : ndarray, shape ``(m,)``
        Each measured shape's relative misfit by the expansion at the measured dofs.
    """

    model: Model
    dofs: tuple[str, ...]
    method: str
    n_basis: int
    T0: np.ndarray
    error: np.ndarray

    @property
    def full(self) -> bool:
        """Every dof is measured (no expansion)."""
        return len(self.dofs) == self.model.n_dofs

    def at(self, theta: np.ndarray, fallback: np.ndarray) -> np.ndarray:
        """The expansion with the damaged estimate (``fallback`` where the sensors cannot tell its modes apart)."""
        try:
            return expansion_matrix(self.model, theta, self.dofs, self.method, self.n_basis)
        except InputError:
            return fallback

    def as_dict(self, n_rigid: int) -> dict:
        """The result's ``expansion`` record."""
        return {"method": "none (every dof measured)" if self.full else self.method,
                "n_basis": None if self.full else self.n_basis, "error": self.error,
                "n_measured_dofs": len(self.dofs), "n_rigid_modes": n_rigid}


def basis_size(meas: Measured, pairing: Pairing, n_dofs: int, n_basis: int | None) -> int:
    """The SEREP basis asked for (default: twice the highest paired mode, at most the sensors); an
    :class:`InputError` when it is not between 1 and the number of measured dofs."""
    n_s = meas.n_sensors
    if n_basis is None:
        n_basis = min(n_s, 2 * (pairing.highest + 1))
    n_basis = int(n_basis)
    if not (n_s == n_dofs or 1 <= n_basis <= n_s):
        raise InputError(f"n_basis must lie between 1 and the number of measured dofs ({n_s}), got {n_basis}")
    return n_basis


def expansion(model: Model, theta0: np.ndarray, meas: Measured, pairing: Pairing, method: str, n_basis: int,
              chosen: bool) -> tuple[Expansion, list[str]]:
    """The expansion by the baseline, with ``n_basis`` modes; when the basis was ``chosen`` by
    default, fewer where the sensors cannot tell that many apart (a note says so)."""
    dofs, n_s, m = meas.dofs, meas.n_sensors, meas.n_modes
    full = n_s == model.n_dofs
    while True:
        try:
            T0 = expansion_matrix(model, theta0, dofs, method, n_basis)
            break
        except InputError as exc:
            # the default basis: fewer modes when the sensors cannot tell that many apart
            if not chosen or full or n_basis <= 1 or method != "serep":
                raise
            log.info("%s; trying %d modes", exc, n_basis - 1)
            n_basis -= 1
    notes = []
    if chosen and not full and n_basis < min(n_s, 2 * (pairing.highest + 1)):
        notes.append(f"the sensors do not tell apart as many model modes as the default SEREP basis holds: "
                     f"{n_basis} modes used" + (f", fewer than the {m} measured: the expansion, and so the "
                                               "localisation, is approximate" if n_basis < m else ""))
    Phi_a = meas.shapes
    pos = model.dof_index(dofs)
    misfit = np.linalg.norm(T0[pos] @ Phi_a - Phi_a, axis=0) / np.linalg.norm(Phi_a, axis=0)
    return Expansion(model, dofs, method, n_basis, T0, misfit), notes


# ------------------------------------------------------------------------------ equations
class Equations:
    """Projected damage equations A δ = r of expanded modes (module docstring of :mod:`.detect`, step 4)."""

    def __init__(self, model: Model, names: Sequence[str], theta0: np.ndarray):
        from .parameters import mass_refusal

        self.model = model
        self.idx = indices(model, names)
        mass_refusal(model, names)
        self.theta0 = theta0
        rows, cols, vals, owner = [], [], [], []
        for c, j in enumerate(self.idx):
            # the tangent stiffness of each unknown at the baseline: K(θ0 (1 + δ)) = K(θ0) + Σ θ0_j ∂K/∂p_j δ_j
            # to first order in δ, exactly where K is affine in the unknowns (a modulus, other parameters held,
            # as a shell thickness is); the refinement fits the true non-linear model
            d = model.dK_dp(j, theta0).tocoo()
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

    def theta(self, delta: np.ndarray) -> np.ndarray:
        """Every parameter's value with the unknowns changed by ``delta`` (relative)."""
        theta = self.theta0.copy()
        theta[self.idx] = self.theta0[self.idx] * (1.0 + delta)
        return theta


def whitener(R: np.ndarray) -> np.ndarray:
    """C^{-1/2} of the sample covariance of the rows of R (replicates x equations), its spectrum
    floored at ``WHITEN_RANGE`` of the largest variance (else the L1 problem turns stiff)."""
    C = np.cov(R, rowvar=False)
    w, V = np.linalg.eigh(np.atleast_2d(C))
    w = np.maximum(w, max(w.max(), 1e-300) * WHITEN_RANGE)
    keep = np.ones(w.size, dtype=bool)
    return (V[:, keep] / np.sqrt(w[keep])).T


def noise_weights(eq: Equations, exp: Expansion, meas: Measured, levels: NoiseLevels, n_noise: int | None,
                  rng: np.random.Generator) -> np.ndarray:
    """The equations' weights: the inverse square root of their covariance under the noise, at the
    baseline (Monte Carlo, ``n_noise`` draws from ``rng``; the identity without noise)."""
    n_rows = meas.n_modes ** 2
    n_rep = int(n_noise) if n_noise is not None else int(min(400, max(60, 4 * n_rows)))
    R = np.array([eq.build(lb, exp.T0 @ pb)[1] for lb, pb in (perturbed(meas, levels, rng) for _ in range(n_rep))])
    return whitener(R) if levels.frequency > 0 or levels.shape > 0 else np.eye(n_rows)


# ------------------------------------------------------------------------------ solution
@dataclass(frozen=True, eq=False)
class Localiser:
    """The weighted projected equations of one baseline and sensor set, and their solution.

    Attributes
    ----------
    equations : Equations
        The projected equations.
    expansion : Expansion
        The expansion by the baseline (repeated with the damaged estimate).
    weights : ndarray, shape ``(m², m²)``
        The rows' whitening (:func:`noise_weights`).
    method : {"l1", "tikhonov"}
        The regulariser.
    iterations : int
        Expansions per solution.
    min_change : float
        The smallest change located.
    allow_increase : bool
        Changes up to +1 (else ≤ 0).
    """

    equations: Equations
    expansion: Expansion
    weights: np.ndarray
    method: str = "l1"
    iterations: int = 3
    min_change: float = 0.05
    allow_increase: bool = False

    @property
    def bounds(self) -> tuple[float, float]:
        """The bounds of every δ."""
        return -1.0 + 1e-9, (1.0 if self.allow_increase else 0.0)

    def weighted(self, lam: np.ndarray, Phi: np.ndarray, T: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The whitened equations of the shapes ``Phi`` expanded by ``T``."""
        A, r = self.equations.build(lam, T @ Phi)
        return self.weights @ A, self.weights @ r

    def solve(self, lam: np.ndarray, Phi: np.ndarray, alpha: float | None = None) -> tuple[L1Fit, np.ndarray, np.ndarray]:
        """The localisation of measured eigenvalues ``lam`` and shapes ``Phi`` (at the expansion's
        dofs): the fit and the last (whitened) equations A, r.  ``alpha``: the L1 factor as a
        fraction of α_max (default by BIC)."""
        lower, upper = self.bounds
        T = self.expansion.T0
        theta = self.equations.theta0.copy()
        fit: L1Fit | None = None
        for it in range(int(self.iterations)):
            if it:
                T = self.expansion.at(theta, T)
            A, r = self.weighted(lam, Phi, T)
            with single_thread_blas():  # small dense problems: OpenBLAS threads only add hand-off time
                if self.method == "l1" and fit is not None:
                    # later expansions re-estimate the located elements' loss; the location stays
                    S = support_of(fit.debiased, self.min_change)
                    fit = L1Fit(fit.l1, debias(A, r, S, lower, upper), fit.alpha, fit.alpha_max, fit.path, fit.order)
                elif self.method == "l1":
                    fit = l1_path(A, r, lower, upper, self.min_change, alpha)
                else:
                    d_t, a_t = tikhonov(A, r)
                    d_t = np.clip(d_t, lower, upper)
                    fit = L1Fit(d_t, d_t, a_t, math.nan, [], np.argsort(-np.abs(d_t), kind="stable"))
            theta = self.equations.theta(fit.debiased)
        assert fit is not None  # iterations >= 1
        return fit, A, r

    def scorer(self, lam: np.ndarray, Phi: np.ndarray) -> Callable[[np.ndarray], np.ndarray]:
        """The linearised gradient of the misfit at a damaged estimate: the projected equations,
        the shapes expanded with that estimate, correlated with their residual (per unit column)."""
        memo: dict[bytes, np.ndarray] = {}
        T0 = self.expansion.T0

        def score(delta: np.ndarray) -> np.ndarray:
            key = np.asarray(delta, float).tobytes()
            if key not in memo:
                A, r = self.weighted(lam, Phi, self.expansion.at(self.equations.theta(delta), T0))
                g = A.T @ (r - A @ delta)
                norm = np.maximum(np.linalg.norm(A, axis=0), 1e-300)
                memo[key] = (np.abs(g) if self.allow_increase else np.maximum(-g, 0.0)) / norm
            return memo[key]

        return score


def make_localiser(model: Model, names: Sequence[str], meas: Measured, pairing: Pairing, stated: StatedNoise,
                   options: DamageOptions, rng: np.random.Generator) -> tuple[Localiser, NoiseLevels, list[str]]:
    """The localiser of ``meas`` (basis, equations, expansion, noise levels, weights) and the notes
    its choices leave; the weights draw ``options.n_noise`` replicates from ``rng``."""
    theta0 = model.values
    n_basis = basis_size(meas, pairing, model.n_dofs, options.n_basis)
    eq = Equations(model, names, theta0)
    exp, notes = expansion(model, theta0, meas, pairing, options.expansion, n_basis, options.n_basis is None)
    levels, noise_notes = noise_levels(stated, meas, exp)
    weights = noise_weights(eq, exp, meas, levels, options.n_noise, rng)
    loc = Localiser(eq, exp, weights, options.method, options.iterations, options.min_change, options.allow_increase)
    return loc, levels, notes + noise_notes


@dataclass(frozen=True, eq=False)
class Localisation:
    """The localisation step's answer (module docstring of :mod:`.detect`, step 5).

    Attributes
    ----------
    fit : L1Fit
        The L1 (or Tikhonov) solution, debiased.
    support : ndarray of int
        The unknowns it changes by ``min_change`` or more.
    tikhonov : dict
        For comparison (L1 only): ``changes``, ``alpha``, ``n_above_threshold``.
    separation : float
        The smallest located ``|change|`` over the largest other ``|change|`` of the L1 solution (NaN
        when nothing is located, inf when nothing else changes).
    record : dict
        ``method``, ``located`` (largest first), ``changes`` (of the located).
    """

    fit: L1Fit
    support: np.ndarray
    tikhonov: dict
    separation: float
    record: dict


def localise(localiser: Localiser, names: Sequence[str], meas: Measured, alpha: float | None = None) -> Localisation:
    """Localise the measured modes' change (with the Tikhonov solution alongside for L1)."""
    fit, A, r = localiser.solve(meas.eigenvalues, meas.shapes, alpha)
    min_change = localiser.min_change
    tk = {}
    if localiser.method == "l1":
        with single_thread_blas():
            d_t, a_t = tikhonov(A, r)
        tk = {"changes": dict(zip(names, map(float, d_t))), "alpha": a_t,
              "n_above_threshold": int(np.sum(np.abs(d_t) >= min_change))}
    S_loc = support_of(fit.debiased, min_change)
    record = {"method": localiser.method, "located": [names[i] for i in S_loc[np.argsort(-np.abs(fit.debiased[S_loc]))]],
              "changes": {names[i]: float(fit.debiased[i]) for i in S_loc}}
    others = np.setdiff1d(np.arange(len(names)), S_loc)
    big_other = float(np.max(np.abs(fit.l1[others]))) if others.size else 0.0
    sep = (float(np.min(np.abs(fit.debiased[S_loc]))) / big_other if big_other > 0 else math.inf) if S_loc.size else math.nan
    return Localisation(fit, S_loc, tk, sep, record)


__all__ = ["Measured", "measured_shapes", "StatedNoise", "stated_noise", "Pairing", "pair_with_baseline", "Expansion",
           "expansion", "basis_size", "expansion_matrix", "NoiseLevels", "noise_levels", "data_noise", "perturbed", "Equations",
           "whitener", "noise_weights", "Localiser", "make_localiser", "Localisation", "localise", "indices", "realised",
           "realised_data"]
