r"""The posterior's noise: stated blocks as stated, one scale per kind of data estimated.

The residuals of every data set are split into blocks as for :func:`femupdate.update`
(:func:`femupdate.updating.noise.layout`: per test mode its eigenvalue and its shape, FRF sets,
static cases).  The blocks with stated standard deviations (from the data file or the options)
form one *stated* pool: their whitened residuals are standard normal.  The others form one pool
per kind of data (``eigenvalue``, ``shape``, ``frf``, ``static``, ...; with ``noise="estimate"``
every block is estimated, a stated one as a factor on its deviations), each with its own noise
scale s_b and Jeffreys' prior p(s_b) ∝ 1/s_b, integrated out:

.. math::  \log L = \sum_{\text{stated}} \bigl(-\tfrac12 Q_b - \tfrac{n_b}2 \log 2\pi\bigr)
           + \sum_{\text{estimated}} \bigl(\log\Gamma(\tfrac{n_b}2) - \log 2
           - \tfrac{n_b}2 \log(\pi Q_b)\bigr),

Q_b = ‖r_b‖², n_b the dimension of the pool's noise (its residuals less one per unit-scaled
shape, whose scaling takes one) — the variance components of :mod:`femupdate.variance`
in their Bayesian form (with one pool, the common scale of earlier versions).  A pool of an
estimated kind with no more residuals than L + 2 could be fitted exactly by the parameters (its
Q_b → 0 makes the likelihood unbounded): the estimated kinds are then pooled together, and said so.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np


@dataclass
class Pool:
    """One noise pool: ``label``, ``basis`` (``"stated"`` or ``"estimated"``), its residual rows in
    each data set's residual vector (``rows[i]``), ``n`` residuals in all, ``members`` (the blocks'
    labels, of the first data set), ``source`` (how a stated pool's deviations came) and, for a
    pool of several kinds, the relative ``weights`` of its rows (:func:`calibrate`)."""

    label: str
    basis: str
    rows: list = field(default_factory=list)
    members: list = field(default_factory=list)
    source: str = ""
    #: per data set, a factor on each of its rows (relative weights of the kinds pooled together)
    weights: list = field(default_factory=list)
    #: the relative weights are to be set from the REML components at the best solution
    weighted: bool = False
    #: degrees of freedom the blocks' own normalisation takes (a unit-scaled shape: one)
    lost: int = 0

    @property
    def dim(self) -> int:
        """The dimension of the pool's noise: its residuals less those its normalisation takes."""
        return max(self.n - self.lost, 1)

    def w(self, i: int) -> np.ndarray:
        return self.weights[i] if self.weights else np.ones(np.size(self.rows[i]))

    @property
    def n(self) -> int:
        return int(sum(np.size(r) for r in self.rows))

    def record(self) -> dict:
        return {"label": self.label, "basis": self.basis, "n_residuals": self.n, "source": self.source,
                "members": list(self.members)}


def noise_pools(problems, basis: str, L: int) -> tuple[list[Pool], list[str]]:
    """The pools of ``problems`` (one per data set) under ``basis`` (``"auto"``, ``"stated"``,
    ``"estimate"``), and notes."""
    from ..updating.noise import SOURCES, layout

    pools: dict[str, Pool] = {}
    n_sets = len(problems)
    for i, prob in enumerate(problems):
        lay = layout(prob, getattr(prob, "sigma", None))
        m = int(prob.n_residuals)
        for label, rows in lay.blocks.items():
            rows = np.arange(m)[rows] if isinstance(rows, slice) else np.asarray(rows, np.intp)
            stated = label in lay.stated and basis != "estimate"
            key = "stated" if stated else str(lay.kinds.get(label, label))
            pool = pools.setdefault(key, Pool(key if not stated else "stated", "stated" if stated else "estimated",
                                              [np.zeros(0, np.intp) for _ in range(n_sets)]))
            pool.rows[i] = np.concatenate([pool.rows[i], rows])
            pool.lost += int(lay.lost.get(label, 0))
            if i == 0:
                pool.members.append(label)
            if stated:
                src = SOURCES[lay.stated[label]]
                pool.source = src if pool.source in ("", src) else "stated in the data file and given as an option"
    out = list(pools.values())
    notes: list[str] = []
    est = [p for p in out if p.basis == "estimated"]
    small = [p for p in est if p.n <= L + 2]
    if small and len(est) > 1:
        merged = Pool("all estimated data", "estimated", [np.concatenate([p.rows[i] for p in est]) for i in range(n_sets)],
                      [mb for p in est for mb in p.members], weighted=True, lost=sum(p.lost for p in est))
        notes.append(f"the noise of {', '.join(p.label for p in small)} cannot be given a scale of its own "
                     f"({', '.join(str(p.n) for p in small)} residuals for {L} parameters: the parameters could fit "
                     f"them exactly): the kinds {', '.join(p.label for p in est)} share one noise scale, their "
                     "residuals weighted by the REML variance components at the best solution "
                     "(femupdate.variance)")
        out = [p for p in out if p.basis == "stated"] + [merged]
    for p in out:
        if p.basis == "estimated":
            p.source = "estimated (Jeffreys' prior, integrated out)"
    return out, notes


def pool_squares(pools: list[Pool], residuals_of_set) -> np.ndarray:
    """Q_b of each pool (P,) from ``residuals_of_set(i)``, the residual vector of data set i."""
    Q = np.zeros(len(pools))
    for i in range(len(pools[0].rows) if pools else 0):
        r = residuals_of_set(i)
        for b, p in enumerate(pools):
            rb = r[p.rows[i]] * p.w(i)
            Q[b] += float(rb @ rb)
    return Q


def log_likelihood(pools: list[Pool], Qp) -> np.ndarray:
    """log L (S,) from the pools' sums of squares Qp (S, P) (module notes); NaN rows: −inf."""
    Qp = np.atleast_2d(np.asarray(Qp, float))
    out = np.zeros(Qp.shape[0])
    with np.errstate(divide="ignore", invalid="ignore"):
        for b, p in enumerate(pools):
            n = p.dim
            if p.basis == "stated":
                out += -0.5 * Qp[:, b] - 0.5 * n * math.log(2 * math.pi)
            else:
                out += math.lgamma(0.5 * n) - math.log(2.0) - 0.5 * n * np.log(math.pi * Qp[:, b])
    return np.where(np.any(np.isnan(Qp), axis=1), -np.inf, out)


def objective_terms(pools: list[Pool], r: np.ndarray, J: np.ndarray, offsets, exact_hessian: bool = False,
                    restricted: np.ndarray | None = None):
    """−log L at the stacked residuals r and Jacobian J (data sets one after another, set i from
    ``offsets[i]``), its gradient and Gauss–Newton Hessian (with ``exact_hessian`` the terms
    −(2 n_b / Q_b²)(J_bᵀr_b)(J_bᵀr_b)ᵀ of the estimated pools); and Q (the total).

    ``restricted`` (the prior's Hessian of −log π, (L, L)): the Gauss–Newton term of each estimated
    pool uses n_b − h_b instead of n_b, h_b = (n_b/Q_b) tr(J_b H⁻¹ J_bᵀ) its share of the
    parameters (H the whole Hessian) — the restricted (REML) noise scale Q_b / (n_b − h_b): the
    Laplace Gaussian of a scale integrated out is otherwise narrower than the posterior, whose
    marginal is a Student-t with n − L degrees of freedom in the linear case."""
    L = J.shape[1]
    f, g, H = 0.0, np.zeros(L), np.zeros((L, L))
    gn: list = []
    for p in pools:
        idx, w = _pool_rows(p, offsets)
        rb, Jb = r[idx] * w, J[idx] * w[:, None]
        Q, n = float(rb @ rb), p.dim
        Jr = Jb.T @ rb
        if p.basis == "stated":
            f += 0.5 * Q + 0.5 * n * math.log(2 * math.pi)
            g += Jr
            H += Jb.T @ Jb
        else:
            if not Q > 0:
                return -math.inf, g, H, float(r @ r)
            f += 0.5 * n * math.log(math.pi * Q) - math.lgamma(0.5 * n) + math.log(2.0)
            g += (n / Q) * Jr
            H += (n / Q) * (Jb.T @ Jb)
            gn.append((n, Q, Jb))
            if exact_hessian:
                H -= (2 * n / Q ** 2) * np.outer(Jr, Jr)
    if restricted is not None and gn:
        for (n, Q, Jb), c in zip(gn, _restricted_factors(gn, H + restricted)):
            H -= (n / Q - c) * (Jb.T @ Jb)
    return f, g, H, float(r @ r)


def _pool_rows(p: Pool, offsets) -> tuple[np.ndarray, np.ndarray]:
    """The pool's rows in the stacked residual vector and their weights."""
    if not p.rows:
        return np.zeros(0, np.intp), np.zeros(0)
    idx = np.concatenate([np.asarray(rows) + off for rows, off in zip(p.rows, offsets)])
    return idx, np.concatenate([p.w(i) for i in range(len(p.rows))])


def _restricted_factors(gn, H) -> list[float]:
    """Each estimated pool's Gauss–Newton factor (n_b − h_b) / Q_b (:func:`objective_terms`), from
    its (n_b, Q_b, J_b) and the whole Hessian H."""
    Hinv = np.linalg.pinv(H, hermitian=True)
    out = []
    for n, Q, Jb in gn:
        h = (n / Q) * float(np.einsum("ij,jk,ik->", Jb, Hinv, Jb))
        out.append((n - min(max(h, 0.0), n - 1.0)) / Q)
    return out


def scale_parts(post, x) -> list[tuple[float, np.ndarray]]:
    r"""The terms of the Laplace Hessian (restricted, :func:`objective_terms`) that rest on an
    estimated noise, one per REML variance component by kind of data at x
    (:func:`femupdate.variance.variance_components`), each with the component's degrees of freedom:
    [(ν_c, H_c)] (empty when every pool is stated or the model cannot be evaluated at x).

    The Gaussian N(x̂, H⁻¹) is the posterior *given* the estimated noise.  Its variance σ_c² rests
    on ν_c degrees of freedom: under Jeffreys' prior its posterior is σ_c² = s_c² ν_c / χ²_{ν_c}.
    Drawing the factors u_c = ν_c / χ²_{ν_c} and the parameters from N(x̂, (H − Σ_c H_c +
    Σ_c H_c / u_c)⁻¹) integrates that uncertainty out (:func:`femupdate.bayes.laplace.mixture_draws`):
    with one estimated component and a linear model the marginal of each parameter is then exactly
    the Student-t with ν = n − L degrees of freedom, as in the textbook regression with unknown
    variance.  Kinds that share one noise scale (:func:`calibrate`) are split again here, each with
    its own ν_c: the eigenvalues' weight, resting on a few degrees of freedom, is then uncertain as
    it is."""
    from .._errors import FemupdateError

    est = [p for p in post.pools if p.basis == "estimated"]
    if not est:
        return []
    got = _components(post, x, by_kind=True)
    if got is None:
        return []
    try:
        r, J = post.residuals_and_jacobian(x)
        hp = post.prior_derivatives(x)[2]
    except FemupdateError:
        return []
    offsets = np.cumsum([0] + [int(p.n_residuals) for p in post.problems])[:-1]
    L = J.shape[1]
    H = np.zeros((L, L))
    gn, rows_of = [], []
    for p in post.pools:
        idx, w = _pool_rows(p, offsets)
        Jb = J[idx] * w[:, None]
        if p.basis == "stated":
            H += Jb.T @ Jb
            continue
        rb = r[idx] * w
        Q, n = float(rb @ rb), p.dim
        if not Q > 0:
            return []
        H += (n / Q) * (Jb.T @ Jb)
        gn.append((n, Q, Jb))
        rows_of.append((idx, w))
    factor = np.zeros(r.size)  # each row's factor in the restricted Gauss–Newton Hessian
    for (idx, w), c in zip(rows_of, _restricted_factors(gn, H - hp)):
        factor[idx] = c * w ** 2
    parts = []
    for comp in got[0].components:
        nu = float(comp.dof)
        if comp.basis not in ("estimated", "pooled") or not (math.isfinite(nu) and nu > 0):
            continue
        rows = np.asarray(comp.rows, np.intp)
        rows = rows[factor[rows] > 0]
        if rows.size:
            parts.append((nu, (J[rows] * factor[rows][:, None]).T @ J[rows]))
    return parts


def scale_draws(pools: list[Pool], Qp, rng: np.random.Generator) -> dict:
    """Draws of each estimated pool's noise scale given the samples' Qp (S, P): s_b² = Q_b / (2 g)
    with g ~ Gamma(n_b/2, 1), its conditional posterior under Jeffreys' prior; {label: draws}."""
    Qp = np.atleast_2d(np.asarray(Qp, float))
    out = {}
    for b, p in enumerate(pools):
        if p.basis == "estimated" and Qp.shape[0]:
            g = rng.gamma(0.5 * p.dim, 1.0, size=Qp.shape[0])
            out[p.label] = np.sqrt(Qp[:, b] / (2.0 * g))
    return out


def _components(post, x, by_kind: bool = False):
    """The REML variance components of every data set's residuals at x
    (:func:`femupdate.variance.variance_components`, the stated pool's blocks stated; ``by_kind``:
    one block per kind of data) with the plausible bounds; None when the model cannot be evaluated
    there."""
    from .._errors import FemupdateError
    from ..updating.noise import layout
    from ..variance import variance_components

    try:
        r, J = post.residuals_and_jacobian(x)
    except FemupdateError:
        return None
    stated_pool = {mb for p in post.pools if p.basis == "stated" for mb in p.members}
    blocks: dict = {}
    kinds: dict = {}
    lost: dict = {}
    stated: set = set()
    plausible: dict = {}
    off = 0
    several = len(post.problems) > 1
    for i, prob in enumerate(post.problems):
        lay = layout(prob, getattr(prob, "sigma", None))
        m = int(prob.n_residuals)
        for lb, rows in lay.blocks.items():
            kind = lay.kinds.get(lb, lb)
            name = (f"stated {kind}" if lb in stated_pool else kind) if by_kind else \
                (f"set {i + 1}: {lb}" if several else lb)
            rows = np.arange(m)[rows] if isinstance(rows, slice) else np.asarray(rows, np.intp)
            blocks[name] = np.concatenate([blocks.get(name, np.zeros(0, np.intp)), rows + off])
            kinds[name] = kind
            lost[name] = lost.get(name, 0) + lay.lost.get(lb, 0)
            if lb in stated_pool:
                stated.add(name)
        for k, v in lay.plausible.items():
            plausible[k] = max(plausible.get(k, 0.0), v)
        off += m
    return variance_components(J, r, blocks, kinds=kinds, stated=stated, lost=lost), plausible


def calibrate(post, x) -> None:
    """Set the relative weights of a pool of several kinds from the REML components of each kind
    at x (the best solution): each row weighted by σ_ref / σ_k of its kind (σ_ref the pool's
    median); the weights are then held fixed (their own uncertainty is not propagated)."""
    pools = [p for p in post.pools if p.weighted]
    if not pools:
        return
    got = _components(post, x, by_kind=True)  # per kind: the per-mode estimates are too uncertain to weigh by
    if got is None:
        return
    scale = got[0].scale
    offsets = np.cumsum([0] + [int(p.n_residuals) for p in post.problems])[:-1]
    for p in pools:
        sig = [scale[np.asarray(rows) + off] for rows, off in zip(p.rows, offsets)]
        allv = np.concatenate(sig) if sig else np.zeros(0)
        good = allv[np.isfinite(allv) & (allv > 0)]
        ref = float(np.median(good)) if good.size else 1.0
        p.weights = [np.where(np.isfinite(sv) & (sv > 0), ref / np.where(sv > 0, sv, 1.0), 1.0) for sv in sig]


def fit_check(post, x, alpha: float | None = None) -> dict:
    """The test of the fit at the posterior's mode x (:func:`femupdate.variance.fit_test`: χ²
    against the stated blocks, the plausibility bound on the REML components of the estimated
    ones): its record (``model_error``); empty when the model cannot be evaluated there."""
    from ..variance import ALPHA, fit_test

    got = _components(post, x)
    if got is None:
        return {}
    return fit_test(got[0], alpha=ALPHA if alpha is None else alpha, plausible=got[1]).record()


def noise_lines(noise: dict, level: float) -> list[str]:
    """Terminal lines of a posterior's ``noise``: what each pool's standard deviations rest on,
    the estimated scales, and the test of the fit."""
    from ..updating.noise import model_error_line

    out = []
    for p in noise.get("pools") or []:
        what = f"std basis: {p['label']} ({p['n_residuals']} residuals): {p.get('source') or p['basis']}"
        s = p.get("scale")
        if s:
            what += (f"; scale median {s['median']:.4g}, {level:.0%} interval [{s['interval'][0]:.4g}, "
                     f"{s['interval'][1]:.4g}]")
        out.append(what)
    line = model_error_line(noise.get("model_error") or {})
    if line:
        out.append(line)
    return out


__all__ = ["scale_parts", "noise_lines", "fit_check", "calibrate", "Pool", "noise_pools", "pool_squares", "log_likelihood", "objective_terms", "scale_draws"]
