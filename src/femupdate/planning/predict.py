r"""What a plan promises before the test: parameter standard deviations, the auto-MAC of the
target modes at the chosen dofs, the expected uniqueness verdict, and a Monte Carlo check.

* **Standard deviations** — :math:`\sqrt{\mathrm{diag}\,F^{-1}}` at the nominal point, F the
  Fisher information of :mod:`.fisher` (physical units): the Cramér-Rao bound, which the
  least-squares update reaches to first order.
* **Expected uniqueness verdict** — the counting criteria of :mod:`femupdate.uniqueness.criteria`
  (n measured dofs, m target modes, L parameters, N model dofs), and where the model is a
  grounded spring chain whose springs are the parameters, the layout rank bound
  (:func:`femupdate.uniqueness.chain.chain_rank_bound`): rank L with n > 1 is then the exact
  condition found by the six-dof study; otherwise full rank at every point of the box is local
  identifiability there, not a proof of uniqueness (``femupdate uniqueness`` answers that).
* **Monte Carlo** — noisy data simulated from the nominal model at the chosen dofs (the noise of
  the plan on the relative eigenvalues and on the unit-scaled shapes), each updated by
  :func:`femupdate.update` from the truth, with the noise stated; the sample standard deviations
  of the estimates against the predicted ones.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
import scipy.sparse as sp

from .._errors import InputError
from .classical import automac_max
from .fisher import Noise, SensitivityBank, rank_and_condition


def chain_positions(model, params: Sequence[str]) -> dict[str, int] | None:
    """If ``model`` is a grounded spring chain whose springs are exactly ``params`` (K = Σ p_j K_j,
    one grounded spring, the others joining the dofs into one path, mass independent of them),
    the position (1 = next to the ground) of each dof along the chain; else None."""
    N = model.n_dofs
    if len(params) != N or not getattr(model, "is_affine", True):
        return None
    idx = model.parameter_indices(list(params))
    p = model.values
    Ksum = sp.csr_matrix((N, N))
    ground: int | None = None
    links: dict[int, list[int]] = {}
    for j in idx:
        if model.dM_dp(j, p).count_nonzero():
            return None
        D = sp.csr_matrix(model.dK_dp(j, p))
        D.eliminate_zeros()
        Ksum = Ksum + p[j] * D
        rows, cols = D.nonzero()
        dofs = sorted(set(rows.tolist()))
        if len(dofs) == 1 and ground is None and D[dofs[0], dofs[0]] > 0:
            ground = dofs[0]
        elif len(dofs) == 2:
            a, b = dofs
            v = D[a, a]
            if not (v > 0 and abs(D[b, b] - v) <= 1e-12 * v and abs(D[a, b] + v) <= 1e-12 * v):
                return None
            links.setdefault(a, []).append(b)
            links.setdefault(b, []).append(a)
        else:
            return None
    if ground is None or abs(model.K(p) - Ksum).max() > 1e-9 * max(abs(Ksum).max(), 1e-300):
        return None
    order, prev, cur = [ground], None, ground
    while True:
        nxt = [d for d in links.get(cur, []) if d != prev]
        if len(nxt) != 1:
            break
        prev, cur = cur, nxt[0]
        if cur in order:
            return None
        order.append(cur)
    if len(order) != N or any(len(v) > 2 for v in links.values()):
        return None
    return {model.dofs[d]: i + 1 for i, d in enumerate(order)}


def predicted_std(bank: SensitivityBank, rows: Sequence[int], noise: Noise) -> np.ndarray:
    """Cramér-Rao standard deviations of the parameters (their units) at the bank's point; inf
    where F is singular."""
    S = bank.matrix(rows, noise)
    r, _, _ = rank_and_condition(S * np.abs(bank.parameter_values)[None, :])
    if r < S.shape[1]:
        return np.full(S.shape[1], math.inf)
    return np.sqrt(np.diag(np.linalg.inv(S.T @ S)))


def automac(bank: SensitivityBank, rows: Sequence[int]) -> tuple[np.ndarray, float]:
    """The target modes' auto-MAC at ``rows`` and its largest off-diagonal term."""
    P = bank.phi[list(rows)]
    G = P.T @ P
    d = np.diag(G)
    mac = G ** 2 / np.outer(d, d)
    return mac, automac_max(P)


def uniqueness_verdict(model, params: Sequence[str], dofs: Sequence[str], n_modes: int, score) -> dict:
    """The expected uniqueness verdict of a plan: counting criteria, the chain's layout rank bound
    where it applies, and the verdict from the plan's ranks (:class:`~.placement.SetScore`)."""
    from ..uniqueness.chain import chain_rank_bound
    from ..uniqueness.criteria import counting_criteria

    n, L, N = len(dofs), len(params), model.n_dofs
    counts = counting_criteria(min(n, N), min(n_modes, N), L, N)
    crit = {k: {"formula": c.formula, "count": c.count, "satisfied": c.satisfied} for k, c in counts.items()}
    lower = next((n_ for n_ in range(2, N + 1) if n_modes * n_ >= L), None)
    pos = chain_positions(model, params)
    bound = None
    if pos is not None:
        bound = min(chain_rank_bound(N, [pos[d] for d in dofs], n_modes), n_modes * n if n > 1 else n_modes)
    r = score.ranks[0]
    if r < L:
        verdict, text = "not identifiable", f"rank {r} of {L} at the nominal point: the data determine only {r} " \
                                            "combinations of the parameters"
    elif n < 2:
        verdict, text = "not unique", "one measured dof gives frequencies only: full rank, but several solutions can " \
                                      "reproduce them (the paper's two-dof example)"
    elif bound is not None:
        verdict, text = ("unique", "the layout rank bound is met with n > 1: the exact condition of the grounded "
                                   "chain (six-dof study)") if bound == L else ("not identifiable", f"layout rank bound {bound} < {L}")
    elif score.full_rank:
        verdict, text = "locally identifiable", (f"full rank at all {len(score.ranks)} points of the box; uniqueness "
                                                 "itself is not proved (femupdate uniqueness answers it)")
    else:
        verdict, text = "not identifiable", f"rank {score.min_rank} of {L} at a point of the box"
    if verdict in ("unique", "locally identifiable") and not score.well_conditioned:
        worst = max(score.conditions)
        text += f"; ill-conditioned (condition {worst:.3g} > {score.max_condition:.3g})"
    if not score.distinct_modes:
        text += (f"; the target modes look alike at the sensors (auto-MAC up to {score.automac_max:.3f} > "
                 f"{score.max_automac:g})")
    return {"verdict": verdict, "explanation": text, "criteria": crit,
            "counting_lower_bound": {"formula": "mn >= L and n > 1", "n_min": lower},
            "layout_rank_bound": bound, "rank": r, "ranks": list(score.ranks)}


def monte_carlo(model, params: Sequence[str], dofs: Sequence[str], bank: SensitivityBank, noise: Noise, runs: int,
                seed: int = 0, max_nfev: int = 100) -> dict:
    """Noisy updates with the plan (module docstring).

    Returns
    -------
    dict
        ``runs``, ``converged``, ``mean`` and ``std`` of the estimates (parameter units), ``bias``
        (mean − truth), ``predicted_std``, ``ratio`` (std / predicted) and ``sampling_error``
        (the relative standard error of a sample std, ``1/sqrt(2 (runs − 1))``).

    Raises
    ------
    InputError
        ``runs`` < 2.
    """
    from .. import update
    from ..options import NoiseOptions
    from ..testdata import MeasuredMode, TestData

    if runs < 2:
        raise InputError(f"monte carlo: at least 2 runs, got {runs}")
    rng = np.random.default_rng(seed)
    truth = bank.parameter_values
    full_rows = [list(bank.dof_labels).index(d) for d in dofs]
    psi = bank.shapes(full_rows)
    est, converged = [], 0
    for _ in range(int(runs)):
        modes = []
        for i, lam in enumerate(bank.eigenvalues):
            lam_e = lam * (1 + noise.eigenvalue * rng.standard_normal())
            if len(dofs) >= 2:
                modes.append(MeasuredMode(lam_e, tuple(dofs), psi[:, i] + noise.shape * rng.standard_normal(len(dofs))))
            else:
                modes.append(MeasuredMode(lam_e))
        res = update(model, TestData(modes=tuple(modes)), params=list(params), values=bank.values,
                     noise=NoiseOptions(std={"eigenvalue": noise.eigenvalue, "shape": noise.shape}), max_nfev=max_nfev)
        converged += bool(res.success)
        est.append([res.parameters[p] for p in params])
    X = np.array(est)
    pred = predicted_std(bank, full_rows, noise)
    std = X.std(axis=0, ddof=1)
    rel = (X - truth) / np.abs(truth)
    return {"runs": int(runs), "converged": converged, "seed": seed, "mean": X.mean(axis=0), "std": std,
            "bias": X.mean(axis=0) - truth, "predicted_std": pred, "ratio": std / pred,
            "sampling_error": 1.0 / math.sqrt(2 * (runs - 1)),
            "rms_relative_error": float(np.sqrt(np.mean(rel ** 2))),
            "predicted_rms_relative_error": float(np.sqrt(np.mean((pred / np.abs(truth)) ** 2))), "estimates": X}


__all__ = ["chain_positions", "predicted_std", "automac", "uniqueness_verdict", "monte_carlo"]
