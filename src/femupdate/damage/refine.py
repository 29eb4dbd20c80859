r"""Refine and verify located damage: nonlinear updating of a candidate set, a test that it
reproduces the data to the noise level, and a stepwise search that enlarges (or trims) the set.

A **set** S of unknowns is fitted by the updating core (:class:`femupdate.updating.Problem` with
``params`` = S, every other unknown held at the baseline; exact Jacobian; measured shapes at
their own dofs, no expansion), within damage bounds: :math:`(1 - 0.999)\,\theta_0 \le \theta \le
\theta_0` (up to :math:`2\theta_0` with ``allow_increase``).  The residuals are divided by the
stated noise: relative eigenvalue :math:`2\sigma_f` (σ_f relative on frequencies), shape entries
(unit-length scaling) :math:`\sigma_s \max|\phi_k| / \|\phi_k\|` (σ_s relative to each shape's
largest measured value), each at least ``NOISE_FLOOR`` (noise-free data: round-off), so that
:math:`2c = \|r/\sigma\|^2` is a chi-square statistic.

**Verify**: S reproduces the data when :math:`2c_S \le \chi^2_{level}(d - |S|)`, d the independent
data (each mode's eigenvalue and n_s − 1 shape entries).

**Search** (:meth:`SetSearch.run`), from the localisation's set S0:

1. fit S0; **trim**: drop members changed by less than ``min_change`` (refit), then, while S fits,
   drop the member whose removal costs least when the smaller set still fits and its likelihood
   ratio :math:`2(c_{S\setminus e} - c_S)` is below the **addition threshold**
   :math:`\chi^2_{1 - (1 - level)/L'}(1)` (Bonferroni over the L' unknowns outside the set: the
   member was chosen from all of them);
2. **enlarge**: while S does not fit (or fits, but some addition is significant — its likelihood
   ratio above the addition threshold), try the ``n_try`` best-scored unknowns outside S (score:
   the linearised gradient of the misfit, :func:`~femupdate.damage.detect.detect_damage`'s
   projected equations at the current estimate) and the next ones along the L1 path, fit each
   S ∪ {c}, keep the best and trim again; stop at ``max_located`` members or when a set recurs;
3. if no set of up to ``max_located`` fits and every unknown can be fitted at once (enough data,
   at most ``MAX_ALL`` unknowns), fit them all from the baseline — plain updating — and trim:
   wherever plain updating identifies the damage, so does the search;
4. **alternatives**: each member of the final set swapped for each of the best-scored outsiders;
   a swapped set that fits as well (the same verify) makes the location *doubtful*.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

from .._errors import InputError, NumericalError
from ..sensitivity.factor import single_thread_blas
from ..testdata import TestData

MAX_LOSS = 0.999      # the lower bound of a damaged stiffness: 0.1 % of the baseline
NOISE_FLOOR = 1e-8    # smallest noise level the residuals are divided by (noise-free data: round-off)
MAX_ALL = 200         # largest number of unknowns fitted all at once as the last enlargement
TOL = 1e-10           # ftol, xtol and gtol of the least-squares fits
MAX_NEIGHBOURS = 12   # neighbours of a member tried in its exchanges
START_LOSS = 0.95     # a start is kept this far from the lower bound (a fit started on a bound stays there)


@dataclass(frozen=True, eq=False)
class SetFit:
    """One candidate set fitted and tested.

    Attributes
    ----------
    members : tuple of int
        Positions of the set's unknowns (sorted).
    delta : ndarray, shape ``(L,)``
        Relative changes of every unknown (zero outside the set).
    chi2 : float
        :math:`\\|r/\\sigma\\|^2` at the fit.
    dof : int
        Independent data minus the set's size.
    limit : float
        :math:`\\chi^2_{level}(dof)`.
    fits : bool
        ``chi2 <= limit`` (and the fit converged).
    message : str
        The solver's message, or why the set could not be fitted.
    """

    members: tuple[int, ...]
    delta: np.ndarray
    chi2: float
    dof: int
    limit: float
    fits: bool
    message: str = ""
    pairs: list = field(default_factory=list)
    wald: np.ndarray | None = None


class SetSearch:
    """Fit, verify and search sets of unknowns against one data set (module docstring).

    Parameters
    ----------
    model : Model
        The baseline (values = validated baseline).
    names : sequence of str
        The unknowns (stiffness parameters of ``model``).
    data : TestData
        The measured modes.
    sigma : (float or array_like, float or array_like)
        Stated noise ``(sigma_f, sigma_s)``: relative frequency std, shape std relative to each
        shape's largest value; each one level, or one per test mode (shape ``(n_test_modes,)``).
    allow_increase : bool
        Let stiffness increase (upper bound 2 θ0).
    min_change : float
        Smallest relative change reported.
    level : float
        Confidence level of the verification, in (0, 1).
    max_located : int
        Largest set the enlargement goes to.
    n_try : int
        Best-scored outsiders fitted at each enlargement (and in the alternatives).
    score : callable, optional
        ``score(delta) -> (L,)`` how much each unknown would reduce the misfit (larger first).
    path_order : sequence of int, optional
        Unknowns in the order they enter the L1 path.
    pairing : str, default ``"auto"``
        Pairing of test and model modes (:class:`~femupdate.updating.Problem`); ``"frequency"``
        for a model with rigid-body modes (the order pairing would count them).
    """

    def __init__(self, model, names: Sequence[str], data: TestData, sigma: tuple, *,
                 allow_increase: bool, min_change: float, level: float, max_located: int, n_try: int = 4,
                 score: Callable[[np.ndarray], np.ndarray] | None = None, path_order: Sequence[int] = (),
                 pairing: str = "auto"):
        self.names = list(names)
        self.L = len(self.names)
        pos = {n: j for j, n in enumerate(model.parameter_names)}
        self.idx = np.array([pos[n] for n in self.names], dtype=np.intp)
        self.theta0 = model.values
        up = 2.0 if allow_increase else 1.0
        params = list(model.parameters)
        for j in self.idx:
            v = params[j].value
            params[j] = dataclasses.replace(params[j], bounds=(v * (1 - MAX_LOSS), v * up) if v > 0 else params[j].bounds)
        self.model = dataclasses.replace(model, parameters=tuple(params))
        self.data = data
        sigma_f, sigma_s = sigma
        T = len(data.modes)  # one level, or one per test mode (as the test data state them)
        self.sf_modes = np.broadcast_to(np.asarray(sigma_f, float), (T,)).copy()
        self.ss_modes = np.broadcast_to(np.asarray(sigma_s, float), (T,)).copy()
        shaped = [k for k, m in enumerate(data.modes) if m.has_shape and len(m.dofs) >= 2]
        self.sigma_f = float(np.median(self.sf_modes)) if T else float(np.max(sigma_f, initial=0.0))
        self.sigma_s = float(np.median(self.ss_modes[shaped])) if shaped else float(np.max(sigma_s, initial=0.0))
        self.std = self._std(data)
        self.min_change = float(min_change)
        self.level = float(level)
        self.max_located = int(max_located)
        self.n_try = int(n_try)
        self.score = score
        self.path_order = [int(i) for i in path_order]
        self.pairing = pairing
        # the dofs each unknown's stiffness touches, and the unknowns at each dof (neighbours)
        self.touched = [np.unique(model.dK_dp(int(j), self.theta0).indices) for j in self.idx]  # tangent (non-linear models)
        self.by_dof: dict[int, list[int]] = {}
        for i, ds in enumerate(self.touched):
            for d in ds.tolist():
                self.by_dof.setdefault(d, []).append(i)
        self.cache: dict[tuple[int, ...], SetFit] = {}
        self.trail: list[SetFit] = []  # every set fitted, in order
        self.n_data = self._n_independent()
        self.scale = 1.0          # misfits are divided by it (rescale)
        self.noise_factor = 1.0   # the noise taken this many times the stated one
        self.every_fit: SetFit | None = None  # the fit of every unknown, when the search made it
        self._every_scale = 1.0

    # ------------------------------------------------------------------ noise and counts
    def _std(self, data: TestData) -> dict:
        lam = [max(2 * sf, NOISE_FLOOR) for sf in self.sf_modes]
        shape = []
        for m, ss in zip(data.modes, self.ss_modes):
            if m.has_shape and len(m.dofs) >= 2:
                s = np.abs(np.asarray(m.shape))
                shape.append(max(ss, NOISE_FLOOR) * float(np.max(s) / np.linalg.norm(s)))
            else:
                shape.append(1.0)
        return {"eigenvalue": np.array(lam), "shape": np.array(shape)}

    def _problem(self, members: Sequence[int], start: np.ndarray):
        from ..updating import Problem

        names = [self.names[i] for i in members]
        x0 = {self.names[i]: float(self.theta0[self.idx[i]] * (1 + start[i])) for i in members}
        return Problem(self.model, self.data, names or None, x0=x0, values=self.theta0, measurement_std=self.std,
                       shape_scaling="unit", pairing=self.pairing)

    def _n_independent(self) -> int:
        from ..updating.targets import build_targets

        return int(build_targets(self.model, self.data, "unit", None, 1.0, 1.0, True, None).n_independent)

    def threshold_add(self, size: int) -> float:
        """Likelihood ratio an added (or kept) member must exceed: χ² with one degree of freedom at
        1 − (1 − level)/L', L' the unknowns outside a set of ``size`` (Bonferroni)."""
        from scipy.special import chdtri

        outside = max(self.L - size, 1)
        return float(chdtri(1, (1 - self.level) / outside))

    def limit(self, dof: int) -> float:
        """χ²_level(dof): the largest misfit of a set that reproduces the data (0 for dof < 1)."""
        from scipy.special import chdtri

        return float(chdtri(dof, 1 - self.level)) if dof > 0 else 0.0

    # ------------------------------------------------------------------ one set
    def fit(self, members, start: np.ndarray | None = None, want_wald: bool = False, fresh: bool = False) -> SetFit:
        """Fit the set ``members`` (positions) from ``start`` (relative changes; default zero); with
        ``want_wald``, each member's Wald statistic δ²/var(δ) at the fit.  A set fitted before is
        taken from the cache, unless ``fresh``: then it is fitted again from ``start`` and the better
        of the two fits kept (a fit from one start may end in a local minimum another avoids)."""
        key = tuple(sorted(int(i) for i in members))
        old = self.cache.get(key)
        if old is not None and not (fresh or (want_wald and old.wald is None)):
            return old
        with single_thread_blas():  # small dense eigenproblems: OpenBLAS threads only add hand-off time
            out = self._fit(key, start, want_wald)
        if old is not None and not out.chi2 < old.chi2:
            out = old if (old.wald is not None or not want_wald) else dataclasses.replace(old, wald=out.wald)
            self.cache[key] = out
            self.trail = [out if f.members == key else f for f in self.trail]
            return out
        self.cache[key] = out
        self.trail = [f for f in self.trail if f.members != key] + [out]
        return out

    def _fit(self, key: tuple[int, ...], start: np.ndarray | None, want_wald: bool) -> SetFit:
        from ..updating.solve import solve

        start = np.zeros(self.L) if start is None else np.clip(start, -START_LOSS, 1.0)
        dof = self.n_data - len(key)
        delta = np.zeros(self.L)
        wald = None
        try:
            if dof < 1:
                raise InputError(f"{len(key)} unknowns but {self.n_data} independent data")
            if key:
                prob = self._problem(key, start)
                sol, _, _ = solve(prob, self.model.bounds, regularization=None, method="trf", ftol=TOL, xtol=TOL,
                                  gtol=TOL, max_nfev=100 + 20 * len(key))
                p = prob.to_p(sol.x)
                delta[list(key)] = p[self.idx[list(key)]] / self.theta0[self.idx[list(key)]] - 1.0
                r = prob.residuals(sol.x)
                pairs = prob.evaluate(sol.x)[2]
                msg = str(sol.message)
                if want_wald:  # relative parametrisation from the baseline: x = 1 + delta
                    J = prob.jacobian(sol.x)
                    var = np.maximum(np.diag(np.linalg.pinv(J.T @ J)), 1e-300)
                    wald = np.zeros(self.L)
                    wald[list(key)] = delta[list(key)] ** 2 / var
            else:  # the baseline itself
                prob = self._problem([0], np.zeros(self.L))
                x = prob.from_p(prob.p_base[prob.idx])
                r = prob.residuals(x)
                pairs = prob.evaluate(x)[2]
                msg = "the baseline"
            chi2 = float(r @ r) / self.scale
            lim = self.limit(dof)
            out = SetFit(key, delta, chi2, dof, lim, bool(chi2 <= lim), msg, pairs, wald)
        except (NumericalError, InputError) as exc:
            out = SetFit(key, delta, math.inf, dof, self.limit(dof), False, str(exc))
        return out

    def lr(self, small: SetFit, big: SetFit) -> float:
        return small.chi2 - big.chi2

    # ------------------------------------------------------------------ trimming and enlarging
    def trim(self, f: SetFit) -> SetFit:
        """While f fits: leave out the member whose absence costs least, when the smaller set still fits and
        the member is not needed (changed by less than ``min_change``, or its likelihood ratio below the
        addition threshold)."""
        while f.fits and f.members:
            need = self.threshold_add(len(f.members) - 1)
            best = None
            for i in f.members:
                g = self.fit([j for j in f.members if j != i], f.delta)
                if g.fits and (abs(f.delta[i]) < self.min_change or self.lr(g, f) < need) \
                        and (best is None or g.chi2 < best.chi2):
                    best = g
            if best is None:
                break
            f = best
        return f

    def candidates(self, f: SetFit, exclude=()) -> list[int]:
        """The outsiders worth fitting next: the best-scored, then the next along the L1 path."""
        inside = set(f.members) | set(exclude)
        out: list[int] = []
        if self.score is not None:
            s = np.asarray(self.score(f.delta), float)
            s[list(inside)] = -np.inf
            order = [int(i) for i in np.argsort(-s) if np.isfinite(s[i])]
            out += order[:self.n_try]
        out += [i for i in self.path_order if i not in inside and i not in out][:max(2, self.n_try // 2)]
        return out

    def enlarge(self, f: SetFit) -> SetFit | None:
        """The best fit of f's set plus one outsider (None when none can be fitted)."""
        best = None
        for c in self.candidates(f):
            g = self.fit(list(f.members) + [c], f.delta)
            if math.isfinite(g.chi2) and (best is None or g.chi2 < best.chi2):
                best = g
        return best

    def neighbours(self, i: int) -> list[int]:
        """The unknowns whose stiffness shares a dof with unknown i's (the ones it is most easily taken for)."""
        out: set[int] = set()
        for d in self.touched[i]:
            out.update(self.by_dof.get(d, ()))
        out.discard(i)
        return sorted(out)

    def swaps(self, f: SetFit) -> list[tuple[int, int]]:
        """(member, outsider) exchanges worth fitting: each member for its neighbours and the best-scored."""
        scored = self.candidates(f)
        inside = set(f.members)
        out = []
        for i in f.members:
            near = [c for c in self.neighbours(i) if c not in inside][:MAX_NEIGHBOURS]
            out += [(i, c) for c in dict.fromkeys(near + scored) if c not in inside]
        return out

    def exchange(self, f: SetFit) -> SetFit:
        """While f fits: the exchange of one member for an outsider that fits better, trimmed again."""
        seen = {f.members}
        while f.fits and f.members:
            best = None
            for i, c in self.swaps(f):
                g = self.fit([j for j in f.members if j != i] + [c], f.delta)
                if g.fits and g.chi2 < f.chi2 and (best is None or g.chi2 < best.chi2):
                    best = g
            if best is None:
                break
            h = self.trim(best)
            if h.members in seen:
                break
            seen.add(h.members)
            f = h
        return f

    def _stepwise(self, f: SetFit) -> SetFit:
        f = self.trim(f)
        seen = {f.members}
        cap = min(self.max_located, self.L)
        while len(f.members) < cap:
            g = self.enlarge(f)
            if g is None or (f.fits and not self.lr(f, g) > self.threshold_add(len(f.members))):
                break  # nothing to add, or f fits and nothing adds significantly
            h = self.trim(g)
            if h.members in seen:
                break
            seen.add(h.members)
            f = h
        return self.exchange(f)

    def every(self) -> SetFit | None:
        """Every unknown fitted at once (plain updating), when the data allow it: from the baseline
        (as ``update`` starts) and from the best set fitted so far, the better fit kept."""
        if self.L > MAX_ALL or self.n_data <= self.L:
            return None
        e = self.fit(range(self.L), np.zeros(self.L), want_wald=True, fresh=True)
        best = min((f for f in self.trail if math.isfinite(f.chi2)), key=lambda f: f.chi2, default=None)
        if not e.fits and best is not None and best.members != e.members:
            e = self.fit(range(self.L), best.delta, want_wald=True, fresh=True)
        self.every_fit, self._every_scale = e, self.scale
        return e

    def model_error(self) -> dict | None:
        """The chi-square test of the fit of every unknown against the stated noise: ``chi2``, ``dof``,
        ``limit``, ``p_value`` and ``fits`` (None when it was not made: a smaller set fitted first,
        or too few data)."""
        from ..variance import chi2_sf

        e = self.every_fit
        if e is None or not math.isfinite(e.chi2) or e.dof < 1:
            return None
        chi2 = e.chi2 * self._every_scale  # against the stated noise, whatever rescaling followed
        return {"chi2": chi2, "dof": e.dof, "limit": e.limit, "p_value": chi2_sf(chi2, e.dof),
                "fits": bool(chi2 <= e.limit), "level": self.level}

    def _from_every(self, e: SetFit) -> SetFit | None:
        """The smallest set, among the leading ones of e's ranking (Wald statistic), that fits; trimmed."""
        order = [int(i) for i in np.argsort(-e.wald, kind="stable")] if e.wald is not None else []
        for k in range(1, min(self.max_located, self.L) + 1):
            g = self.fit(order[:k], e.delta)
            if not g.fits:  # cached from another start, perhaps a local minimum
                g = self.fit(order[:k], e.delta, fresh=True)
            if g.fits:
                return self.trim(g)
        return None

    def rescale(self, factor: float) -> None:
        """Divide every misfit by ``factor`` (the noise taken ``sqrt(factor)`` times larger than stated)."""
        self.scale *= factor
        for key, f in list(self.cache.items()):
            chi2 = f.chi2 / factor
            self.cache[key] = dataclasses.replace(f, chi2=chi2, fits=bool(chi2 <= f.limit) and math.isfinite(chi2))
        self.trail = [self.cache[f.members] for f in self.trail]

    def run(self, start_members: Sequence[int], start_delta: np.ndarray | None = None) -> SetFit:
        """The stepwise search from ``start_members`` (module docstring); the final set, marked as not
        fitting when it holds more than ``max_located`` unknowns."""
        f = self._search(start_members, start_delta)
        if f.fits and len(f.members) > self.max_located:
            f = dataclasses.replace(f, fits=False, message=f"{len(f.members)} unknowns: more than max_located")
        return f

    def _search(self, start_members: Sequence[int], start_delta: np.ndarray | None) -> SetFit:
        f = self._stepwise(self.fit(start_members, start_delta))
        if f.fits:
            return f
        e = self.every()
        if e is None:
            return f
        g = self._from_every(e)
        if g is not None:
            return g
        if not e.fits and e.dof > 0 and math.isfinite(e.chi2) and e.chi2 > e.dof:
            # even every unknown together misses the data: the noise is larger than stated (or the baseline is
            # wrong); judged again with the noise scaled to the fit of every unknown
            factor = e.chi2 / e.dof
            self.rescale(factor)
            f = self._stepwise(self.cache[f.members])
            if not f.fits:
                f = self._from_every(self.cache[e.members]) or f
            if f.fits and f.chi2 * factor <= f.limit:  # it fits the stated noise after all
                self.rescale(1 / factor)
                f = self.cache[f.members]
            else:
                self.noise_factor = float(np.sqrt(factor))
        return f

    def alternatives(self, f: SetFit) -> list[SetFit]:
        """Sets with one member of f swapped for an outsider that fit the data too."""
        out: list[SetFit] = []
        if not f.fits:
            return out
        for i, c in self.swaps(f):
            g = self.fit([j for j in f.members if j != i] + [c], f.delta)
            if g.fits and all(abs(g.delta[k]) >= self.min_change for k in g.members):
                out.append(g)
        return sorted(out, key=lambda g: g.chi2)

    def evidence(self, f: SetFit) -> dict[int, float]:
        """For each member: the rise of χ² when it is left out (refitted without it)."""
        return {i: float(self.fit([j for j in f.members if j != i], f.delta).chi2 - f.chi2) for i in f.members}


__all__ = ["SetSearch", "SetFit", "MAX_LOSS", "NOISE_FLOOR"]
