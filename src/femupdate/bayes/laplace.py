r"""The Laplace approximation at each distinct solution, with each solution's probability.

Every distinct solution of a multi-start study (:func:`femupdate.multistart`: the least-squares
minima, which are the likelihood's modes) is refined to the posterior's mode — the maximum of
likelihood times prior — by a damped Gauss–Newton iteration on :math:`f(x) = -\log p(x \mid d)`
with the exact Jacobian of the updating core, within the bounds.  There the posterior is
approximated by the Gaussian :math:`\mathcal N(\hat x_k, H_k^{-1})`, H_k the Gauss–Newton Hessian
of f (JᵀJ over the squared noise, plus the prior's curvature; with estimated noise each
estimated pool's term over its restricted scale Q_b / (n_b − h_b), h_b its share of the
parameters, :func:`femupdate.bayes.noise.objective_terms`), and the posterior mass near the
solution by

.. math::  Z_k = p(d \mid \hat x_k)\,\pi(\hat x_k)\,(2\pi)^{L/2}\,|H_k|^{-1/2}\;c_k ,

c_k the fraction of that Gaussian within the bounds (estimated from its draws).  The solutions'
relative probabilities are Z_k / Σ Z, and log Σ Z approximates the log-evidence.  Two solutions
that fit the data equally well (equal likelihood) and sit under a flat prior weigh as
``|H_k|^{-1/2}``: the less sensitive solution, whose neighbourhood fits as well over a larger volume,
is the more probable one.

The approximation is made in the sampler's variables x (the parametrisation: relative, log or
absolute), which is where its Gaussian is assumed.

With estimated noise that Gaussian is the posterior *given* the noise variances at their
estimates.  Each variance rests on few degrees of freedom (six eigenvalues for eight parameters
leave about five): the draws integrate that uncertainty out — per draw, each REML variance
component's factor u_c = ν_c / χ²_{ν_c} scales its term of the Hessian
(:func:`femupdate.bayes.noise.scale_parts`, :func:`scale_mixture`) — so the posterior's marginals
have the Student-t tails of the textbook regression with unknown variance (exactly so for a
linear model with one estimated component).  The modes' ``covariance`` and ``std`` stay the
Gaussian's; the result's standard deviations and intervals come from the draws.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass, field

import numpy as np

from .._errors import FemupdateError, InputError, NumericalError
from .likelihood import Posterior

log = logging.getLogger(__name__)


@dataclass(frozen=True, eq=False)
class Mode:
    """One solution of the posterior: its mode and Laplace approximation.

    Attributes
    ----------
    parameters : dict
        The updated parameters' values at the posterior's mode {name: value}.
    x : numpy.ndarray, shape ``(L,)``
        The mode in the sampler's variables.
    covariance : numpy.ndarray, shape ``(L, L)``
        The Laplace covariance in parameter units (NaN when the Hessian is not positive definite).
    std : dict
        Its standard deviations {name: value}.
    log_weight : float
        log Z_k (module docstring), −inf for a mode without a positive definite Hessian.
    probability : float
        Z_k / Σ Z over the modes.
    cost : float
        ½‖r‖² at the mode (all data sets).
    log_posterior : float
        The log posterior density there (in x).
    count : int
        How many multi-start runs reached this solution.
    inside : float
        The fraction of its Gaussian within the bounds (c_k).
    at_bounds : tuple of str
        Parameters that sit on a bound at the mode (the Gaussian is then a poor description).
    hessian : numpy.ndarray, shape ``(L, L)``
        H_k in the variables x (the Gaussian's; with estimated noise the restricted one, while
        ``log_weight`` takes the determinant of the density's own Hessian).
    note : str
        Why the mode was left out of the mixture, or ``""``.
    scale_parts : tuple of (float, numpy.ndarray)
        With estimated noise, the terms of ``hessian`` that rest on it, one per REML variance
        component with its degrees of freedom (:func:`femupdate.bayes.noise.scale_parts`): the
        draws (:func:`mixture_draws`) integrate the components' uncertainty out, so the posterior
        is this Gaussian's scale mixture (Student-t like), not the Gaussian itself.
    """

    parameters: dict
    x: np.ndarray
    covariance: np.ndarray
    std: dict
    log_weight: float
    probability: float
    cost: float
    log_posterior: float
    count: int
    inside: float = 1.0
    at_bounds: tuple = ()
    hessian: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))
    note: str = ""
    scale_parts: tuple = ()

    @property
    def x_covariance(self) -> np.ndarray:
        """H_k⁻¹, the covariance in the variables x."""
        return np.linalg.inv(self.hessian)


#: the mode search's significance level: every separate minimum is a candidate mode (a difference
#: beyond the relative tolerance is kept), even two within each other's noise — they are two peaks
#: of the posterior, and merging them would lose one (the two-dof chain's (8, 6) and (9, 16/3) at
#: 1 % noise on its frequencies)
EVERY_MINIMUM = 1.0 - 1e-12


def candidates(post: Posterior, starts: int, seed: int | None, progress=None, scheduler=None,
               connect_timeout: float = 10.0) -> tuple[list[tuple[np.ndarray, int]], list[str]]:
    """Starting points of the mode search: the separate minima of a multi-start study on the
    first data set (each with its count of starts; :data:`EVERY_MINIMUM`), or one update from the
    nominal values when ``starts`` is 1 or a parameter has no finite bounds; and notes.

    Raises
    ------
    NumericalError
        No start converged.
    """
    from ..updating import multistart, update

    model, data = post.model, post.sets[0]
    opts = {"values": post.options["values"], "options": post.options["options"]}
    notes: list[str] = []
    if len(post.sets) > 1:
        notes.append(f"the solutions are searched on the first of the {len(post.sets)} data sets, then refined to the "
                     "posterior's modes with all of them")
    finite = bool(np.all(np.isfinite(post.lo)) and np.all(np.isfinite(post.hi)))
    if starts > 1 and not finite:
        notes.append("some parameters have no finite bounds: one update from the nominal values instead of random "
                     "starts (a second solution, if any, is not looked for)")
    if starts > 1 and finite:
        ms = multistart(model, data, starts=starts, seed=seed, params=list(post.names), progress=progress,
                        scheduler=scheduler, connect_timeout=connect_timeout, alpha=EVERY_MINIMUM, **opts)
        if not ms.solutions:
            raise NumericalError(f"none of the {starts} starts of the mode search converged"
                                 + (f" ({next(iter(ms.failures))})" if ms.failures else ""))
        pts = [(post.from_p(np.array([s.parameters[n] for n in post.names])[None, :])[0], s.count)
               for s in ms.solutions]
        return pts, notes
    x0 = post.options.get("x0")
    res = update(model, data, params=list(post.names), x0=x0, **opts)
    if not res.success:
        raise NumericalError(f"the update from the nominal values did not converge: {res.message}")
    return [(post.from_p(np.asarray(res.x, float)[None, :])[0], 1)], notes


def refine(post: Posterior, x0: np.ndarray, max_iter: int = 100) -> tuple[np.ndarray, int, bool]:
    """The posterior's mode near x0: damped Gauss–Newton (Levenberg–Marquardt) on −log posterior,
    each step projected into the bounds.

    Returns
    -------
    x : numpy.ndarray, shape ``(L,)``
    iterations : int
    converged : bool

    Raises
    ------
    NumericalError
        The model cannot be evaluated at x0.
    """
    xl, xh = post.bounds_x()
    x = np.clip(np.asarray(x0, float), xl, xh)
    f, g, H, _ = post.objective(x)
    if not math.isfinite(f):
        raise NumericalError("the posterior density is zero at the solution (outside the prior's support)")
    mu = 1e-6
    for it in range(1, max_iter + 1):
        d = np.sqrt(np.maximum(np.diag(H), 1e-300))
        A = H / np.outer(d, d) + mu * np.eye(post.L)
        try:
            step = -np.linalg.solve(A, g / d) / d
        except np.linalg.LinAlgError:
            mu *= 10
            continue
        x_new = np.clip(x + step, xl, xh)
        try:
            f_new, g_new, H_new, _ = post.objective(x_new)
        except FemupdateError:
            f_new = math.inf
        if math.isfinite(f_new) and f_new <= f:
            small = f - f_new <= 1e-13 * (1 + abs(f)) or np.all(np.abs(x_new - x) <= 1e-12 * (1 + np.abs(x)))
            x, f, g, H = x_new, f_new, g_new, H_new
            mu = max(mu / 4, 1e-12)
            if small:
                return x, it, True
        else:
            mu *= 8
            if mu > 1e12:
                return x, it, True  # no step downhill: at the (bounded) minimum to working precision
    return x, max_iter, False


def laplace_modes(post: Posterior, points: list[tuple[np.ndarray, int]], rng: np.random.Generator,
                  rel_tol: float = 1e-4, n_inside: int = 4000) -> tuple[list[Mode], list[str]]:
    """Refine ``points`` to the posterior's modes, merge those that coincide, and give each its
    Laplace approximation and probability (most probable first); and notes.

    Raises
    ------
    NumericalError
        No mode has a positive definite Hessian.
    """
    from ..distinct import cluster
    from ..flags import bound_side
    from .noise import scale_parts

    notes: list[str] = []
    refined = []
    for x0, count in points:
        try:
            x, _, ok = refine(post, x0)
        except FemupdateError as exc:
            notes.append(f"a solution could not be refined to a posterior mode: {exc}")
            continue
        if not ok:
            notes.append("a posterior mode search stopped at its iteration limit")
        f, _, H, Q = post.objective(x, exact_hessian=True)
        # the Gaussian's covariance with the restricted (REML) noise scales of the estimated pools;
        # the evidence keeps the Hessian of the density itself
        Hr = post.objective(x, exact_hessian=True, restricted=True)[2] if post.noise == "estimate" else H
        refined.append((x, count, f, H, Q, Hr))
    if not refined:
        raise NumericalError("no solution could be refined to a posterior mode")
    P = post.to_p(np.array([r[0] for r in refined]))
    scale = np.maximum(np.abs(post.to_p(post.param.x_start[None, :])[0]), 1e-300)
    groups = cluster(P, np.array([r[2] for r in refined]), rel_tol, scale)
    xl, xh = post.bounds_x()
    modes = []
    for g in groups:
        x, _, f, H, Q, Hr = refined[g[0]]
        count = sum(refined[i][1] for i in g)
        p = post.to_p(x[None, :])[0]
        dpdx = post.param.dp_dx(x)
        at = tuple(n for j, n in enumerate(post.names)
                   if bound_side(float(p[j]), float(post.lo[j]), float(post.hi[j]), float(post.param.scale[j])))
        note = ""
        cov = np.full((post.L, post.L), np.nan)
        log_weight = -math.inf
        inside = math.nan
        C: np.ndarray | None
        Cr: np.ndarray | None
        try:
            C, Cr = np.linalg.cholesky(H), np.linalg.cholesky(Hr)
        except np.linalg.LinAlgError:
            C = Cr = None
        if C is None or Cr is None or not np.all(np.isfinite(H)) or not np.all(np.isfinite(Hr)):
            note = "the posterior's Hessian there is not positive definite: the data and prior do not confine it"
        else:
            Hinv = np.linalg.inv(Hr)
            cov = dpdx[:, None] * Hinv * dpdx[None, :]
            logdet = 2.0 * float(np.sum(np.log(np.diag(C))))
            z = rng.standard_normal((n_inside, post.L))
            draws = x + np.linalg.solve(Cr.T, z.T).T
            inside = float(np.mean(np.all((draws >= xl) & (draws <= xh), axis=1) & np.isfinite(post.log_prior(draws))))
            log_weight = -f + 0.5 * post.L * math.log(2 * math.pi) - 0.5 * logdet + (math.log(inside) if inside > 0
                                                                                      else -math.inf)
            if at:
                note = (f"{', '.join(at)} on a bound: the Gaussian is cut there ({inside:.0%} of it inside), and the "
                        "approximation is rough")
        parts = tuple(scale_parts(post, x)) if post.noise == "estimate" and math.isfinite(log_weight) else ()
        modes.append(Mode(dict(zip(post.names, map(float, p))), x, cov, dict(zip(post.names, np.sqrt(np.diag(cov)))),
                          float(log_weight), 0.0, 0.5 * Q, float(-f), count, inside, at, Hr, note, parts))
    lw = np.array([m.log_weight for m in modes])
    if not np.any(np.isfinite(lw)):
        raise NumericalError("no posterior mode has a positive definite Hessian: the data and priors do not determine "
                             "the parameters (state informative priors, or add data)")
    prob = np.exp(lw - np.max(lw))
    prob /= prob.sum()
    modes = [_with(m, probability=float(w)) for m, w in zip(modes, prob)]
    modes.sort(key=lambda m: -m.probability)
    for m in modes:
        if m.note and (m is modes[0] or m.probability >= 1e-4):  # the negligible local minima go unremarked
            notes.append(f"solution at {_where(m)}: {m.note}")
    return modes, notes


def _with(mode: Mode, **changes) -> Mode:
    import dataclasses

    return dataclasses.replace(mode, **changes)


def _where(mode: Mode) -> str:
    return "(" + ", ".join(f"{n}={v:.6g}" for n, v in mode.parameters.items()) + ")"


def log_evidence(modes: list[Mode]) -> float:
    """log Σ Z_k over the modes (the Laplace log-evidence)."""
    lw = np.array([m.log_weight for m in modes])
    top = float(np.max(lw))
    return top + math.log(float(np.sum(np.exp(lw - top))))


def mixture_draws(post: Posterior, modes: list[Mode], n: int, rng: np.random.Generator,
                  max_rounds: int = 50) -> tuple[np.ndarray, np.ndarray]:
    """``n`` draws of the variables x from the mixture of the modes' Gaussians, weighted by their
    probabilities and cut to the prior's support; and each draw's mode (index).

    Raises
    ------
    NumericalError
        Fewer than ``n`` draws inside the support after ``max_rounds`` rounds.
    """
    usable = [k for k, m in enumerate(modes) if math.isfinite(m.log_weight) and m.probability > 0]
    w = np.array([modes[k].probability for k in usable])
    w /= w.sum()
    chol = {k: np.linalg.cholesky(modes[k].hessian) for k in usable}
    out_x: list[np.ndarray] = []
    out_k: list[np.ndarray] = []
    have = 0
    for _ in range(max_rounds):
        which = rng.choice(len(usable), size=n, p=w)
        z = rng.standard_normal((n, post.L))
        X = np.empty((n, post.L))
        for i, k in enumerate(usable):
            sel = which == i
            if modes[k].scale_parts:
                X[sel] = modes[k].x + scale_mixture(modes[k], z[sel], rng)
            else:
                X[sel] = modes[k].x + np.linalg.solve(chol[k].T, z[sel].T).T
        ok = np.isfinite(post.log_prior(X))
        out_x.append(X[ok])
        out_k.append(np.array(usable)[which[ok]])
        have += int(ok.sum())
        if have >= n:
            break
    if have < n:
        raise NumericalError(f"the Laplace approximation puts too little of its mass within the bounds ({have} of "
                             f"{n * max_rounds} draws)")
    return np.concatenate(out_x)[:n], np.concatenate(out_k)[:n]


def scale_mixture(mode: Mode, z: np.ndarray, rng: np.random.Generator, chunk: int = 512) -> np.ndarray:
    """Offsets from the mode (S, L) of its Gaussian's scale mixture, from standard normal ``z``
    (S, L): per draw, each estimated noise component's factor u_c = ν_c / χ²_{ν_c} (the posterior
    of its variance over its estimate under Jeffreys' prior) and N(0, H(u)⁻¹) with
    H(u) = H − Σ_c H_c + Σ_c H_c / u_c (``mode.scale_parts``).  A draw whose H(u) is not positive
    definite (possible only where the exact Hessian's terms make the rest indefinite) takes u = 1."""
    S, L = z.shape
    fixed = mode.hessian - sum(Hc for _, Hc in mode.scale_parts)
    nus = np.array([nu for nu, _ in mode.scale_parts])
    parts = np.stack([Hc for _, Hc in mode.scale_parts])
    u = nus[None, :] / rng.chisquare(np.broadcast_to(nus, (S, nus.size)))
    out = np.empty((S, L))
    for a in range(0, S, chunk):
        b = min(a + chunk, S)
        Hs = fixed[None] + np.einsum("sc,cij->sij", 1.0 / u[a:b], parts)
        try:
            C = np.linalg.cholesky(Hs)
        except np.linalg.LinAlgError:
            Hs[~np.array([_is_pd(h) for h in Hs])] = mode.hessian
            C = np.linalg.cholesky(Hs)
        out[a:b] = np.linalg.solve(np.swapaxes(C, 1, 2), z[a:b, :, None])[:, :, 0]
    return out


def _is_pd(h: np.ndarray) -> bool:
    try:
        np.linalg.cholesky(h)
    except np.linalg.LinAlgError:
        return False
    return bool(np.all(np.isfinite(h)))


def assign(modes: list[Mode], X: np.ndarray) -> np.ndarray:
    """The solution each sample belongs to (S,): the mode whose Laplace Gaussian (in x, equal
    weights) has the highest density there, −½ (x − x_k)ᵀ H_k (x − x_k) + ½ log ``|H_k|`` (−1 when no
    mode has a Gaussian)."""
    usable = [k for k, m in enumerate(modes) if math.isfinite(m.log_weight)]
    if not usable:
        return np.full(X.shape[0], -1)
    score = np.empty((X.shape[0], len(usable)))
    for i, k in enumerate(usable):
        C = np.linalg.cholesky(modes[k].hessian)
        score[:, i] = -0.5 * np.sum(((X - modes[k].x) @ C) ** 2, axis=1) + float(np.sum(np.log(np.diag(C))))
    return np.array(usable)[np.argmax(score, axis=1)]


__all__ = ["Mode", "candidates", "refine", "laplace_modes", "log_evidence", "mixture_draws", "scale_mixture", "assign"]
