r"""Exciter placement for FRF tests: driving points that excite every target mode and make the
FRF-based Fisher information of the parameters full rank and well conditioned.

**Driving-point criteria** (Imamovic 1998, after the optimum driving point of Larson, Zimmerman &
Marek 1994), from the mass-normalised target modes φ_r at a candidate driving dof d:

* ODP — optimum driving point, :math:`\mathrm{ODP}_d = \prod_r |\phi_{dr}|`: zero at a node of
  any target mode (a force there does not excite that mode);
* NODP — non-optimum driving point, :math:`\mathrm{NODP}_d = \min_r |\phi_{dr}|`;
* DPR — driving-point residue, :math:`\mathrm{DPR}_d = \sum_r \phi_{dr}^2/\omega_r`.

A candidate excites mode r when :math:`|\phi_{dr}|` is at least ``min_residue`` times the
largest :math:`|\phi_{cr}|` over the candidates (default 0.05); a set of exciters excites
every target mode when, for each mode, one of its exciters does.

**FRF-based Fisher information** — the receptance at the plan's sensors s and an exciter e, by
modal superposition of the target modes with structural damping η = 2ζ (ζ the modal damping
ratio, held fixed),

.. math:: H_{se}(\omega) = \sum_r \frac{\phi_{sr}\phi_{er}}{\lambda_r(1 + i\eta) - \omega^2},

sampled at three lines per target mode (:math:`\omega^2 = \lambda_r(1-\eta), \lambda_r,
\lambda_r(1+\eta)`: the half-power points and the resonance), its real and imaginary parts with
an absolute noise floor σ_H times the largest :math:`|H|` of any candidate exciter at the
sensors (one floor for every exciter set, so that an exciter near a node gives less
information).  The derivatives come from the :class:`~.fisher.SensitivityBank` (exact
eigenvalue and mass-normalised shape derivatives, no new eigen-solution):

.. math:: \frac{\partial H_{se}}{\partial p} = \sum_r \frac{\partial_p(\phi_{sr}\phi_{er})}{D_r}
          - \frac{\phi_{sr}\phi_{er}(1+i\eta)\,\partial_p\lambda_r}{D_r^2},
          \quad D_r = \lambda_r(1+i\eta) - \omega^2.

The modes outside the target set are left out of H (their residual contribution carries
information as well; the plan's figures are for the target modes).

**Placement** reuses the identifiability-first logic of :mod:`.placement`: sets are compared
by, in this order, exciting every target mode, the smallest rank of the value-scaled FRF
sensitivity over the nominal point and the random points of the box, being well conditioned
at every point, and the design criterion (D or A, or the expected information gain with a
prior) at the nominal point; greedy selection from the fixed exciters, then exchange.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from .._errors import InputError
from .classical import _better, exchange_pass
from .fisher import SensitivityBank, design_value, rank_and_condition
from .placement import SetScore


def driving_point_criteria(bank: SensitivityBank) -> dict[str, np.ndarray]:
    """ODP, NODP and DPR of every candidate dof of ``bank`` (module docstring), and the
    normalised amplitude ``|φ_dr| / max_c |φ_cr|`` (n_c × m) that says which modes it excites."""
    phi = np.abs(bank.phi)
    omega = np.sqrt(np.abs(bank.eigenvalues))
    peak = phi.max(axis=0)
    return {"odp": np.prod(phi, axis=1), "nodp": phi.min(axis=1), "dpr": np.sum(phi ** 2 / omega[None, :], axis=1),
            "amplitude": phi / np.where(peak > 0, peak, 1.0)[None, :]}


def frf_lines(eigenvalues: np.ndarray, eta: float) -> np.ndarray:
    """ω² of the lines: three per target mode, λ(1 − η), λ, λ(1 + η)."""
    lam = np.asarray(eigenvalues, float)
    return np.sort(np.concatenate([lam * (1 - eta), lam, lam * (1 + eta)]))


def frf_sensitivity(bank: SensitivityBank, sensors: Sequence[int], exciter: int, eta: float,
                    w2: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """The receptances H (real and imaginary parts stacked, lines × sensors) at the bank's
    point for one exciter row, and their derivatives (rows × parameters, parameter units).
    ``w2``: the lines' ω² (default :func:`frf_lines` of the bank's own eigenvalues; a test
    fixes them from the nominal model)."""
    s = list(sensors)
    lam = bank.eigenvalues
    dlam = bank.dlam * lam[:, None]  # (m, L) absolute
    w2 = frf_lines(bank.eigenvalues, eta) if w2 is None else np.asarray(w2, float)
    D = lam[None, :] * (1 + 1j * eta) - w2[:, None]  # (k, m)
    num = bank.phi[s] * bank.phi[exciter][None, :]  # (ns, m)
    dnum = bank.dphi[s] * bank.phi[exciter][None, :, None] + bank.phi[s][:, :, None] * bank.dphi[exciter][None, :, :]
    H = np.einsum("sm,km->ks", num, 1 / D)
    dH = (np.einsum("sml,km->ksl", dnum, 1 / D)
          - np.einsum("sm,km,ml->ksl", num, (1 + 1j * eta) / D ** 2, dlam))
    L = dlam.shape[1]
    return (np.concatenate([H.real.ravel(), H.imag.ravel()]),
            np.vstack([dH.real.reshape(-1, L), dH.imag.reshape(-1, L)]))


@dataclass(frozen=True, eq=False)
class ExciterPlacement:
    """An exciter placement (:func:`exciter_placement`).

    Each parameter is stored as the attribute of the same name.

    Parameters
    ----------
    chosen : tuple of int
        The exciters (rows of the bank's candidate dofs), ascending.
    greedy : tuple of int
        The greedy set before the exchanges.
    score : SetScore
        The FRF Fisher information's ranks, conditions and design value.
    excites_all : bool
        Every target mode excited by one of the exciters.
    swaps : int
    noise_floor : float
        The absolute noise std of the receptances (m/N).
    """

    chosen: tuple[int, ...]
    greedy: tuple[int, ...]
    score: SetScore
    excites_all: bool
    swaps: int
    noise_floor: float


def exciter_placement(banks: Sequence[SensitivityBank], sensors: Sequence[int], n_exciters: int, *,
                      candidates: Sequence[int] | None = None, fixed: Sequence[int] = (), std_frf: float = 0.01,
                      damping_ratio: float = 0.01, design="d", max_condition: float = 1e6,
                      min_residue: float = 0.05, max_passes: int = 20) -> ExciterPlacement:
    """Choose ``n_exciters`` driving dofs for an FRF test with the plan's ``sensors`` (module docstring).

    Parameters
    ----------
    banks : sequence of SensitivityBank
        Nominal point first, then the random points of the box.
    sensors : sequence of int
        The response dofs (rows of the banks).
    n_exciters : int
        Exciters in the plan (fixed ones included).
    candidates : sequence of int, optional
        Rows where an exciter may go (default every candidate dof).
    fixed : sequence of int
        Exciters always in the plan (rows).
    std_frf : float, default 0.01
        Noise floor of the receptances, relative to the largest one.
    damping_ratio : float, default 0.01
        Modal damping ratio ζ of the simulated FRFs (η = 2ζ).
    design : str or Design
        As :func:`~.fisher.design_value`.
    max_condition : float
    min_residue : float, default 0.05
        The normalised amplitude at which a driving point counts as exciting a mode.
    max_passes : int

    Returns
    -------
    ExciterPlacement

    Raises
    ------
    InputError
        ``n_exciters`` outside 1..candidates, or below the fixed ones; a noise or damping not > 0.
    """
    rows = list(range(len(banks[0].dof_labels))) if candidates is None else [int(c) for c in candidates]
    fixed = [int(f) for f in fixed]
    for f in fixed:
        if f not in rows:
            rows.append(f)
    if not (1 <= n_exciters <= len(rows)) or n_exciters < len(fixed):
        raise InputError(f"exciters: {n_exciters} asked, but there are {len(rows)} candidate driving points"
                         + (f" and {len(fixed)} fixed ones" if fixed else ""))
    for name, v in (("std_frf", std_frf), ("damping_ratio", damping_ratio)):
        if not (math.isfinite(v) and v > 0):
            raise InputError(f"exciters: {name} must be a finite number > 0, got {v!r}")
    eta = 2.0 * damping_ratio
    crit = driving_point_criteria(banks[0])
    excites = crit["amplitude"] >= min_residue  # (n_c, m)
    w2 = frf_lines(banks[0].eigenvalues, eta)
    H0 = {e: frf_sensitivity(banks[0], sensors, e, eta, w2) for e in rows}
    floor = std_frf * max(float(np.max(np.abs(h[0]))) for h in H0.values())
    L = banks[0].dlam.shape[1]
    pv = [np.abs(b.parameter_values) for b in banks]

    def score(sel: list[int]) -> tuple[SetScore, bool]:
        ranks, conds, value = [], [], -math.inf
        for k, b in enumerate(banks):
            S = np.vstack([(H0[e][1] if k == 0 else frf_sensitivity(b, sensors, e, eta, w2)[1]) for e in sel])
            S = S / floor * pv[k][None, :]
            r, c, sv = rank_and_condition(S)
            ranks.append(r)
            conds.append(c)
            if k == 0:
                value = design_value(S.T @ S, design) if r == L else float(np.sum(np.log(sv[:r] ** 2))) if r else -math.inf
        all_modes = bool(np.all(np.any(excites[sel], axis=0)))
        return SetScore(tuple(ranks), tuple(conds), value, L, max_condition, 2), all_modes

    cache: dict[tuple, tuple] = {}

    def key(sel_pos: list[int]) -> tuple:
        sel = tuple(sorted(rows[i] for i in sel_pos))
        if sel not in cache:
            sc, ok = score(list(sel))
            cache[sel] = (int(ok),) + sc.key()
        return cache[sel]

    fixed_pos = [rows.index(f) for f in fixed]
    cur = list(fixed_pos)
    while len(cur) < n_exciters:
        best, best_k = None, None
        for h in range(len(rows)):
            if h in cur:
                continue
            k = key(cur + [h])
            if best_k is None or _better(k, best_k):
                best, best_k = h, k
        cur.append(int(best))  # type: ignore[arg-type]
    greedy = tuple(sorted(rows[i] for i in cur))
    best_set, swaps = exchange_pass(cur, len(rows), fixed_pos, key, max_passes)
    chosen = tuple(sorted(rows[i] for i in best_set))
    sc, ok = score(list(chosen))
    return ExciterPlacement(chosen, greedy, sc, ok, swaps, floor)


__all__ = ["driving_point_criteria", "frf_lines", "frf_sensitivity", "ExciterPlacement", "exciter_placement"]
