r"""Variance components of a least-squares fit, one per block of residuals, and the fit's test.

A residual vector r (m,) stacks blocks of different kinds — relative eigenvalue errors, scaled
shape differences, FRF lines, static deflections — each with its own, often unknown, noise.
:func:`variance_components` estimates one variance σ_b² per block from the fit itself, with its
degrees of freedom, by **restricted maximum likelihood (REML)** in the iterative form of
Förstner's variance-component estimation:

.. math::

   \hat\sigma_b^2 = \frac{e_b^\mathsf{T} e_b}{r_b},\qquad
   r_b = n_b - c_b - \operatorname{tr} H_{bb},\qquad
   H = J N^{-1} J^\mathsf{T} W,\quad N = J^\mathsf{T} W J,\quad W = \operatorname{diag}(1/\sigma_b^2),

where e are the residuals of the weighted Gauss–Newton linearisation at the fit (e = r + Jδ with
δ = −N⁻¹JᵀWr: the residuals of the fit re-weighted by the current components), n_b the block's
residuals, c_b the entries its own normalisation takes (a unit-scaled shape loses one) and r_b its
**redundancy** — the block's share of the n − L degrees of freedom, Σ_b tr H_bb = L.  The
components are iterated until they settle; the fixed point is the REML estimate (the REML score
equations of a block-diagonal covariance are exactly e_bᵀe_b/σ_b⁴ = r_b/σ_b²), and for a single
block it is the textbook s² = ‖e‖²/(n − L).

References: W. Förstner, "Ein Verfahren zur Schätzung von Varianz- und Kovarianzkomponenten",
Allgemeine Vermessungs-Nachrichten 86 (1979) 446–453; K.-R. Koch, *Parameter Estimation and
Hypothesis Testing in Linear Models*, 2nd ed., Springer 1999, §3.6 (iterated estimates of variance
components are the REML estimates); H. D. Patterson and R. Thompson, Biometrika 58 (1971) 545–554
(REML); F. E. Satterthwaite, Biometrics Bulletin 2 (1946) 110–114 (effective degrees of freedom).

* **Stated blocks.**  A block whose residuals are already divided by stated standard deviations
  keeps σ_b² = 1 (absolute) and infinite degrees of freedom.
* **Pooling.**  A block whose redundancy is below ``min_dof`` cannot be estimated on its own (a
  single eigenvalue has redundancy below 1): the blocks of its kind are pooled into one component;
  the kinds whose pools are still too small are pooled together, and if that is still too small,
  with every other estimated block; the last estimated
  component is estimated down to ``min_pool_dof`` (1) degrees of freedom, and with less its noise is
  not estimable (NaN).  Each pooling is said in ``notes``.
* **Covariance.**  The parameters are those of the fit as it was weighted (the residuals as
  given); their covariance is that of this estimator under the estimated components, the
  sandwich A (Σ_b σ_b² J_bᵀJ_b) A with A = (JᵀJ)⁻¹ — N⁻¹ itself when the fit's weights already
  are 1/σ_b².  It is linear in the σ_b², C_jj = Σ_b g_jb σ_b², so each standard deviation has a
  Satterthwaite effective number of degrees of freedom ν_j = C_jj² / Σ_b (g_jb σ_b²)² / r_b
  (stated blocks contribute none), and its intervals are Student-t with ν_j.

:func:`fit_test` says whether the fit reproduces the data within the noise: a χ² goodness-of-fit
test on the blocks with stated noise, and a plausibility bound on the estimated ones.
"""

from __future__ import annotations

import math
from typing import Any
from collections.abc import Collection, Mapping
from dataclasses import dataclass, field

import numpy as np

#: a block (or a kind's pool) whose redundancy is below this is pooled with others: its variance is
#: not estimated on its own
MIN_DOF = 3.0
#: the pool of every estimated block is estimated down to this redundancy (a residual variance with
#: one degree of freedom, as the textbook s² with m − L = 1; its t-intervals are wide accordingly)
MIN_POOL_DOF = 1.0
#: the least redundancy the fit is tested with (below, the data barely exceed the parameters and
#: a χ² on round-off would decide)
MIN_TEST_DOF = 0.5
#: the method, as results name it
METHOD = "REML (Förstner's iterative variance-component estimation)"
#: default level of the goodness-of-fit test
ALPHA = 0.01


@dataclass(frozen=True, eq=False)
class Component:
    """One variance component.

    Attributes
    ----------
    label : str
        The block's label, or for a pool ``"<kind>"`` / ``"all estimated data"``.
    kind : str
        The kind of data (the pooling group).
    basis : str
        ``"stated"`` (residuals divided by stated standard deviations), ``"estimated"`` (its own
        REML estimate) or ``"pooled"`` (estimated together with the blocks in ``members``);
        ``"not estimable"`` when even the pool of every estimated block has too little redundancy.
    variance : float
        σ_b², in the squared units of the residuals as given (1 for a stated block).
    dof : float
        The redundancy r_b: the degrees of freedom of the estimate (inf for a stated block).
    n : int
        The number of residuals.
    members : tuple of str
        The labels of the blocks it covers.
    rows : numpy.ndarray of int
        Their residual rows.
    redundancy : float
        r_b = n_b − c_b − tr H_bb, the block's share of the fit's degrees of freedom (for a
        stated block too: the χ² test's dof).
    """

    label: str
    kind: str
    basis: str
    variance: float
    dof: float
    n: int
    members: tuple[str, ...]
    rows: np.ndarray = field(repr=False)
    redundancy: float = math.nan

    @property
    def std(self) -> float:
        """σ_b."""
        return math.sqrt(self.variance) if self.variance >= 0 else math.nan

    def record(self) -> dict:
        """The JSON record: ``label``, ``kind``, ``basis``, ``std``, ``dof`` (None when infinite),
        ``n_residuals``, ``members``."""
        return {"label": self.label, "kind": self.kind, "basis": self.basis, "std": _num(self.std),
                "dof": None if not math.isfinite(self.dof) else float(self.dof), "n_residuals": int(self.n),
                "redundancy": _num(self.redundancy), "members": list(self.members)}


@dataclass(frozen=True, eq=False)
class VarianceComponents:
    """What :func:`variance_components` estimates.

    Attributes
    ----------
    components : tuple of Component
    scale : numpy.ndarray, shape ``(m,)``
        σ of each residual's component (NaN where not estimable).
    covariance : numpy.ndarray, shape ``(L, L)``
        The parameters' covariance in the variables of J (module notes).
    std : numpy.ndarray, shape ``(L,)``
    dof : numpy.ndarray, shape ``(L,)``
        Satterthwaite effective degrees of freedom of each standard deviation (inf when it rests
        on stated noise only).
    residuals : numpy.ndarray, shape ``(m,)``
        The residuals as given, divided by their component's σ (NaN where not estimable).
    iterations : int
    converged : bool
    notes : list of str
        Each pooling, and a noise that cannot be estimated.
    method : str
    """

    components: tuple[Component, ...]
    scale: np.ndarray
    covariance: np.ndarray
    std: np.ndarray
    dof: np.ndarray
    residuals: np.ndarray
    iterations: int
    converged: bool
    notes: list[str]
    method: str = METHOD

    @property
    def absolute(self) -> bool:
        """Every component is stated."""
        return all(c.basis == "stated" for c in self.components)

    def half_width(self, level: float = 0.95) -> np.ndarray:
        """Half-widths of the parameters' two-sided intervals at ``level``: Student-t quantiles
        with the effective dof times ``std`` (normal where the dof are infinite)."""
        return t_quantile(0.5 + level / 2, self.dof) * self.std

    def records(self) -> list[dict]:
        """The components' JSON records (:meth:`Component.record`)."""
        return [c.record() for c in self.components]


def t_quantile(q: float, dof) -> np.ndarray:
    """Student-t quantiles at probability q with ``dof`` degrees of freedom (normal where they are
    infinite or not positive), by :mod:`scipy.special` (lighter to import than scipy.stats)."""
    from scipy import special

    dof = np.asarray(dof, float)
    fin = np.isfinite(dof) & (dof > 0)
    return np.where(fin, special.stdtrit(np.where(fin, dof, 1.0), q), special.ndtri(q))


def chi2_sf(x: float, dof: float) -> float:
    """P(χ²_dof ≥ x)."""
    from scipy import special

    return float(special.chdtrc(dof, x))


def _num(v: float):
    return float(v) if math.isfinite(v) else None


def _rows(spec, m: int) -> np.ndarray:
    if isinstance(spec, slice):
        return np.arange(m)[spec]
    return np.asarray(spec, dtype=np.intp).ravel()


def _redundancy(J, r, comps, var):
    """One step: the re-weighted linearised residuals e, the leverages and the redundancies."""
    m = r.size
    w = np.zeros(m)
    for c, v in zip(comps, var):
        w[c.rows] = 1.0 / v
    Jw = J * w[:, None]
    N = J.T @ Jw
    Ninv = np.linalg.pinv(N, rcond=1e-12, hermitian=True) if N.size else N
    if not N.size or np.ptp(w) <= 1e-12 * np.max(w):
        e = r.copy()  # equal weights: the re-weighted fit is the fit itself, whose residuals are r
    else:
        e = r - J @ (Ninv @ (Jw.T @ r))
    lev = np.einsum("ij,jk,ik->i", J, Ninv, Jw) if N.size else np.zeros(m)
    return e, lev


def _groups(blocks, kinds, stated, lost, m):
    out = []
    for label, spec in blocks.items():
        rows = _rows(spec, m)
        out.append(Component(str(label), str(kinds.get(label, label)), "stated" if label in stated else "estimated",
                             1.0, math.inf, rows.size, (str(label),), rows))
    return out


def _merge(parts: list[Component], label: str, kind: str, lost: Mapping) -> Component:
    rows = np.concatenate([c.rows for c in parts])
    members = tuple(mb for c in parts for mb in c.members)
    return Component(label, kind, "pooled", 1.0, math.inf, rows.size, members, rows)


def _iterate(J, r, comps, lost, tol, max_iter):
    """Förstner's iteration over the estimated components; returns (variances, dofs, iterations,
    converged)."""
    var = np.array([1.0 if c.basis == "stated" else float(r[c.rows] @ r[c.rows]) / max(c.n, 1) for c in comps])
    est0 = [v for c, v in zip(comps, var) if c.basis != "stated"]
    floor = 1e-24 * max(est0) if est0 and max(est0) > 0 else 1.0
    var = np.where(var > floor, var, floor)
    est = [i for i, c in enumerate(comps) if c.basis != "stated"]
    dof = np.full(len(comps), math.nan)
    converged = not est
    it = 0
    for it in range(1, max_iter + 1):
        e, lev = _redundancy(J, r, comps, var)
        new = var.copy()
        for i, c in enumerate(comps):
            dof[i] = c.n - sum(lost.get(mb, 0) for mb in c.members) - float(lev[c.rows].sum())
        for i in est:
            c = comps[i]
            red = dof[i]
            q = float(e[c.rows] @ e[c.rows])
            new[i] = q / red if red > 0 else math.nan
            if red > 0 and not q > 0:  # an exact fit: no noise to see
                new[i] = 0.0
        if not est:
            converged = True
            break
        top = max((new[i] for i in est if np.isfinite(new[i])), default=0.0)
        if not top > 0:  # an exact fit of every estimated block
            var[est] = 0.0
            converged = True
            break
        for i in est:  # a block fitted exactly keeps a tiny weight-able variance while the others settle
            if np.isfinite(new[i]) and new[i] < 1e-24 * top:
                new[i] = 1e-24 * top
        good = [i for i in est if np.isfinite(new[i]) and new[i] > 0]
        change = max((abs(new[i] / var[i] - 1) for i in good), default=0.0)
        var = np.where(np.isfinite(new) & (new > 0), new, np.where(np.isfinite(new), np.maximum(new, 1e-300), var))
        if any(not np.isfinite(new[i]) for i in est):
            var[[i for i in est if not np.isfinite(new[i])]] = math.nan
            break
        if change < tol:
            converged = True
            break
    for i in est:
        if comps[i].n and not float(r[comps[i].rows] @ r[comps[i].rows]) > 0:
            var[i] = 0.0
    return var, dof, it, converged


def variance_components(J, r, blocks: Mapping, *, kinds: Mapping | None = None, stated: Collection = (),
                        lost: Mapping | None = None, min_dof: float = MIN_DOF, min_pool_dof: float = MIN_POOL_DOF,
                        tol: float = 1e-8, max_iter: int = 200) -> VarianceComponents:
    """Estimate one variance component per block of residuals from a least-squares fit by REML
    (Förstner's iterative variance-component estimation; module notes for the method and the
    references).

    Parameters
    ----------
    J : array_like, shape ``(m, L)``
        The Jacobian of the residuals at the fit, in any variables (the covariance is in the
        same); columns of parameters held on a bound left out by the caller.
    r : array_like, shape ``(m,)``
        The residuals at the fit, as the fit weighted them.
    blocks : mapping of str to index array or slice
        {label: rows}: every residual in exactly one block (e.g. ``"eigenvalue"``,
        ``"shape mode 3"``).
    kinds : mapping of str to str, optional
        {label: kind}: the blocks of one kind are pooled together when one of them has too little
        redundancy (default: each label its own kind).
    stated : collection of str
        Labels whose residuals are already divided by stated standard deviations (σ_b = 1,
        not estimated).
    lost : mapping of str to int, optional
        {label: c_b}: degrees of freedom a block's own normalisation takes (a unit-scaled shape:
        1; default 0).
    min_dof : float, default :data:`MIN_DOF`
        The least redundancy a block or a kind's pool is estimated with.
    min_pool_dof : float, default :data:`MIN_POOL_DOF`
        The least redundancy of the last resort, the pool of every estimated block (with less its
        noise is not estimable).
    tol : float, default 1e-8
        Relative change of every component at which the iteration stops.
    max_iter : int, default 200

    Returns
    -------
    VarianceComponents

    Raises
    ------
    ValueError
        Blocks that do not cover every row exactly once, or shapes that do not agree.
    """
    J = np.asarray(J, float)
    r = np.asarray(r, float).ravel()
    m = r.size
    if J.ndim != 2 or J.shape[0] != m:
        raise ValueError(f"variance_components: J must be (m, L) with m = len(r) = {m}, got shape {J.shape}")
    kinds = dict(kinds or {})
    lost = dict(lost or {})
    stated = set(stated)
    comps = _groups(blocks, kinds, stated, lost, m)
    seen = np.concatenate([c.rows for c in comps]) if comps else np.zeros(0, np.intp)
    if seen.size != m or np.unique(seen).size != m or (m and (seen.min() < 0 or seen.max() >= m)):
        raise ValueError("variance_components: the blocks must cover every residual row exactly once")
    notes: list[str] = []
    # pool until every estimated component has enough redundancy
    for stage in ("kind", "small", "all"):
        while True:
            var, dof, it, conv = _iterate(J, r, comps, lost, tol, max_iter)
            small = [c for c, d in zip(comps, dof) if c.basis != "stated" and not d >= min_dof]
            if not small:
                break
            if stage == "kind":
                todo = [k for k in dict.fromkeys(c.kind for c in small)
                        if sum(1 for c in comps if c.basis != "stated" and c.kind == k) > 1]
                if not todo:
                    break
                k = todo[0]
                parts = [c for c in comps if c.basis != "stated" and c.kind == k]
                notes.append(f"{', '.join(mb for c in parts for mb in c.members)}: too little redundancy to estimate "
                             f"each on its own (below {min_dof:g}): pooled as one component '{k}'")
                comps = [c for c in comps if c not in parts] + [_merge(parts, k, k, lost)]
            elif stage == "small":  # the kinds too small on their own, together
                if len(small) < 2:
                    break
                label = " + ".join(c.label for c in small)
                notes.append(f"{', '.join(c.label for c in small)}: too little redundancy to estimate each kind on its "
                             f"own (below {min_dof:g}): pooled as one component '{label}'")
                comps = [c for c in comps if c not in small] + [_merge(small, label, "mixed", lost)]
            else:
                parts = [c for c in comps if c.basis != "stated"]
                if len(parts) < 2:
                    break
                notes.append(f"{', '.join(c.label for c in parts)}: too little redundancy to estimate each kind on "
                             f"its own (below {min_dof:g}): pooled as one component 'all estimated data'")
                comps = [c for c in comps if c.basis == "stated"] + [_merge(parts, "all estimated data", "all", lost)]
    final = []
    n_est = sum(1 for c in comps if c.basis != "stated")
    for c, v, d in zip(comps, var, dof):
        if abs(d) < 1e-9 * max(c.n, 1):  # a redundancy of zero (as many data as parameters) computed as round-off
            d = 0.0
        least = min_pool_dof if n_est == 1 else min_dof  # the last estimated component: the last resort
        if c.basis != "stated" and not d >= least:
            notes.append(f"{c.label}: redundancy {d:.3g} below {least:g}: its noise cannot be estimated from the fit "
                         "(state its standard deviation)")
            final.append(Component(c.label, c.kind, "not estimable", math.nan, d, c.n, c.members, c.rows, float(d)))
        else:
            final.append(Component(c.label, c.kind, c.basis, float(v), math.inf if c.basis == "stated" else float(d),
                                   c.n, c.members, c.rows, float(d)))
    order = {str(lb): i for i, lb in enumerate(blocks)}
    final.sort(key=lambda c: min(order[mb] for mb in c.members))
    return _finish(J, r, final, it, conv, notes)


def _finish(J, r, comps, it, conv, notes) -> VarianceComponents:
    m, L = J.shape
    scale = np.full(m, math.nan)
    for c in comps:
        scale[c.rows] = c.std
    A = np.linalg.pinv(J.T @ J, rcond=1e-12, hermitian=True) if L else np.zeros((0, 0))
    cov = np.zeros((L, L))
    contrib = np.zeros((len(comps), L))
    for i, c in enumerate(comps):
        Jb = J[c.rows]
        G = A @ (Jb.T @ Jb) @ A
        cov += c.variance * G
        contrib[i] = c.variance * np.diag(G)
    d = np.diag(cov).copy()
    std = np.sqrt(np.where(np.isfinite(d) & (d >= 0), d, np.nan))
    dof = _satterthwaite(d, [(contrib[i], c.dof) for i, c in enumerate(comps) if c.basis in ("estimated", "pooled")])
    dof = np.where(np.isfinite(d), dof, math.nan)
    with np.errstate(divide="ignore", invalid="ignore"):
        z = r / scale
    return VarianceComponents(tuple(comps), scale, cov, std, dof, z, it, conv, notes)


def weighted_dof(J, components, estimated=None) -> np.ndarray:
    """Satterthwaite effective degrees of freedom (L,) of the standard deviations of the fit
    weighted by the ``components`` themselves (each row by 1/σ_b², covariance N⁻¹ =
    Σ_b N⁻¹ J_bᵀJ_b N⁻¹ / σ_b², N = Σ_b J_bᵀJ_b / σ_b²): ν_j = C_jj² / Σ_b c_jb² / ν_b over the
    components counted as ``estimated`` (a sequence of bool, default: those not stated), the
    others taken as known; inf where none contributes, NaN where a component is not estimable."""
    J = np.asarray(J, float)
    comps = list(components)
    est = [c.basis != "stated" for c in comps] if estimated is None else [bool(e) for e in estimated]
    L = J.shape[1]
    if any(not (c.variance > 0 and math.isfinite(c.variance)) for c in comps):
        return np.full(L, math.nan)
    N = sum((J[c.rows].T @ J[c.rows]) / c.variance for c in comps) if comps else np.zeros((L, L))
    Ninv = np.linalg.pinv(np.asarray(N, float), rcond=1e-12, hermitian=True)
    contrib = [np.einsum("ij,jk,ki->i", Ninv, J[c.rows].T @ J[c.rows], Ninv) / c.variance for c in comps]
    d = np.sum(contrib, axis=0) if contrib else np.zeros(L)
    return _satterthwaite(d, [(cb, c.dof) for c, e, cb in zip(comps, est, contrib) if e])


def _satterthwaite(d, parts) -> np.ndarray:
    """Satterthwaite's effective degrees of freedom of variances d (L,) that are sums of parts
    [(c_b (L,), ν_b)] estimated with ν_b degrees of freedom (the parts taken as known left out):
    d² / Σ_b (c_b² / ν_b), written with the shares c_b / d so that the squares cannot overflow (data
    of 1e149: their variances and contributions are ~1e298); inf where no part contributes."""
    den = np.zeros(np.shape(d))
    with np.errstate(divide="ignore", invalid="ignore"):
        for c, nu in parts:
            den += (c / d) ** 2 / nu
        return np.where(den > 0, 1.0 / den, math.inf)


# ---------------------------------------------------------------------------------------------
# goodness of fit
# ---------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class FitTest:
    """Whether the fit reproduces the data within the noise (:func:`fit_test`).

    Attributes
    ----------
    test : str
        The test that decides (smallest adjusted p-value): ``"chi-square"`` (stated noise: χ² = Σ
        over the stated blocks of their whitened residuals' squares, against χ² with their
        redundancy), ``"plausibility"`` (an estimated component against its plausible bound), or
        ``"none"`` (nothing to test).
    statistic : float
        χ², or the largest ratio σ̂_b / bound of the plausibility test.
    dof : float
        Degrees of freedom of the χ² (of the plausibility test: those of the component tested).
    p_value : float
        Of the statistic (the smallest Bonferroni-adjusted one when several tests are made).
    alpha : float
    verdict : str
        ``"model error"`` when p < α, else ``"consistent"`` (``"untested"`` for ``"none"``).
    detail : list of dict
        One record per test made: ``{test, blocks, statistic, dof, p_value}``.
    """

    test: str
    statistic: float
    dof: float
    p_value: float
    alpha: float
    verdict: str
    detail: list

    @property
    def flagged(self) -> bool:
        return self.verdict == "model error"

    def record(self) -> dict:
        """The JSON ``model_error`` entry."""
        return {"test": self.test, "statistic": _num(self.statistic), "dof": _num(self.dof),
                "p_value": _num(self.p_value), "alpha": self.alpha, "verdict": self.verdict,
                "detail": [{k: (_num(v) if isinstance(v, float) else v) for k, v in d.items()} for d in self.detail]}

    def headline(self) -> str:
        """One line for a terminal."""
        if self.test == "none":
            return ("model error: untested (no stated noise to test the fit against, and no estimated noise of a "
                    "kind with a plausibility bound)")
        if self.test == "chi-square":
            what = (f"chi-square {self.statistic:.4g} on {self.dof:.4g} dof against the stated noise, "
                    f"p = {self.p_value:.3g}")
        else:
            what = (f"estimated noise up to {self.statistic:.3g} x its plausible bound ({self.dof:.3g} dof), "
                    f"p = {self.p_value:.3g}")
        if len(self.detail) > 1:
            what += f"; worst of {len(self.detail)} tests, Bonferroni-adjusted"
        if self.flagged:
            return (f"MODEL ERROR: the best fit does not reproduce the data within the noise ({what} < "
                    f"alpha {self.alpha:g}): the model lacks something the structure has (or the noise is "
                    "understated); its standard deviations describe the noise only, not the model's error")
        return f"fit consistent with the noise ({what})"


def fit_test(vc: VarianceComponents, *, alpha: float = ALPHA, plausible: Mapping | None = None,
             n_parameters: int | None = None) -> FitTest:
    """Test whether a fit reproduces the data within the noise.

    * **Stated noise.**  χ² = Σ_b e_bᵀe_b over the stated blocks (their whitened residuals, from
      ``vc.residuals``) against the χ² distribution with Σ_b r_b degrees of freedom, their
      redundancies (n − L when every block is stated): p = P(χ² ≥ observed).
    * **Estimated noise** (the plausibility bound).  A component estimated from the fit absorbs
      any model error; it is compared with the largest standard deviation a vibration test gives
      that kind of data (``plausible`` {kind: bound, in the residuals' units}): ``(r_b σ̂_b² /
      bound²)`` against χ² with r_b dof, one-sided.
    * The tests together are at level α by Bonferroni: each p-value is multiplied by the number of
      tests; the verdict is ``"model error"`` when the smallest adjusted one is below α.

    Parameters
    ----------
    vc : VarianceComponents
    alpha : float, default :data:`ALPHA`
    plausible : mapping of str to float, optional
        Bounds on the estimated components' σ by kind (a component pooled across kinds takes the
        largest bound of its members' kinds, passed under their labels' kinds by the caller as
        ``"all"``); components without one are not tested.
    n_parameters : int, optional
        Unused (kept for callers that pass L; the redundancies already account for it).

    Returns
    -------
    FitTest
    """
    plausible = dict(plausible or {})
    tests: list[dict[str, Any]] = []
    st = [c for c in vc.components if c.basis == "stated"]
    if st:
        rows = np.concatenate([c.rows for c in st])
        # the stated blocks' redundancies: their share of n - L under the components
        red = float(sum(c.redundancy for c in st))
        chi2 = float(np.nansum(vc.residuals[rows] ** 2))
        if red >= MIN_TEST_DOF:  # no redundancy (as many data as parameters): nothing to test
            tests.append({"test": "chi-square", "blocks": [c.label for c in st], "statistic": chi2, "dof": red,
                          "p_value": chi2_sf(chi2, red)})
    for c in vc.components:
        bound = plausible.get(c.kind)
        if c.basis in ("estimated", "pooled") and bound and math.isfinite(c.variance) and c.dof >= MIN_TEST_DOF:
            q = c.dof * c.variance / bound ** 2
            tests.append({"test": "plausibility", "blocks": [c.label], "statistic": c.std / bound, "dof": c.dof,
                          "p_value": chi2_sf(q, c.dof)})
    if not tests:
        return FitTest("none", math.nan, math.nan, math.nan, alpha, "untested", [])
    k = len(tests)
    for t in tests:
        t["p_value"] = min(1.0, t["p_value"] * k)
    worst = min(tests, key=lambda t: t["p_value"])
    return FitTest(worst["test"], float(worst["statistic"]), float(worst["dof"]), float(worst["p_value"]),
                   float(alpha), "model error" if worst["p_value"] < alpha else "consistent", tests)


__all__ = ["t_quantile", "chi2_sf", "variance_components", "weighted_dof", "VarianceComponents", "Component", "fit_test", "FitTest", "MIN_DOF", "METHOD", "ALPHA"]
