r"""The classical sensor-placement criteria, about *seeing* the target modes: backward elimination
over the candidate sensors (uniaxial or triaxial), keeping the fixed ones, then an exchange pass.

``"efi"`` — effective independence (Kammer 1991)
    :math:`E = \Phi_s(\Phi_s^T\Phi_s)^{-1}\Phi_s^T`; remove the sensor that contributes least to
    the Fisher information :math:`\det(\Phi_s^T\Phi_s)`.  For a uniaxial sensor that is the
    smallest :math:`E_{ii}` (Kammer's rule, as :func:`femupdate.reduction.effective_independence`);
    for a sensor of several dofs g the exact loss :math:`\det(I - E_{gg})` is used.
``"efi-dpr"`` — effective independence weighted by the driving-point residue
    :math:`E_{ii}\,\mathrm{DPR}_i`, :math:`\mathrm{DPR}_i = \sum_j \phi_{ij}^2/\omega_j`
    (Imamovic 1998): it avoids sensors near the nodes of the modes; exchange objective
    :math:`\log\det(\Phi_s^T D\,\Phi_s)`, D = diag(DPR).
``"kinetic"`` — kinetic energy (Heo et al. 1997)
    :math:`KE_{ij} = \phi_{ij}(M\phi_j)_i`, each mode's share at the dof; the sensors of least
    energy summed over the target modes are removed.
``"mac"`` — MAC-based elimination (Carne & Dohrmann 1995)
    remove the sensor whose removal leaves the smallest largest off-diagonal term of the target
    modes' auto-MAC.

The exchange pass then swaps a chosen sensor for an unchosen one while that improves the
criterion's objective (``log det`` for the two EfI criteria, the energy, or minus the largest
off-diagonal auto-MAC); ``exchange=False`` keeps the elimination's set (the textbook methods).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from .._errors import InputError

CRITERIA = ("efi", "efi-dpr", "kinetic", "mac")


@dataclass(frozen=True, eq=False)
class ClassicalPlacement:
    """A placement by a classical criterion (:func:`classical_placement`).

    Each parameter is stored as the attribute of the same name.

    Parameters
    ----------
    chosen : tuple of int
        Positions of the chosen sensors among the candidates, ascending.
    eliminated : tuple of int
        The set the backward elimination left (before the exchange), ascending.
    removed : tuple of int
        The candidates in the order they were removed.
    objective : float
        The criterion's objective on ``chosen`` (module docstring).
    objective_eliminated : float
        The same on ``eliminated``.
    swaps : int
        Exchanges made.
    criterion : str
    """

    chosen: tuple[int, ...]
    eliminated: tuple[int, ...]
    removed: tuple[int, ...]
    objective: float
    objective_eliminated: float
    swaps: int
    criterion: str


def _logdet(A: np.ndarray) -> float:
    sign, val = np.linalg.slogdet(A)
    return float(val) if sign > 0 else -np.inf


def automac_max(P: np.ndarray) -> float:
    """Largest off-diagonal term of the auto-MAC of the columns of ``P`` (0 for one column)."""
    if P.shape[1] < 2:
        return 0.0
    G = P.T @ P
    d = np.diag(G).copy()
    d[d <= 0] = np.inf
    mac = G ** 2 / np.outer(d, d)
    np.fill_diagonal(mac, 0.0)
    return float(mac.max())


def _objective(criterion: str, phi: np.ndarray, weight: np.ndarray, energy: np.ndarray) -> Callable:
    if criterion == "efi":
        return lambda rows: _logdet(phi[rows].T @ phi[rows])
    if criterion == "efi-dpr":
        return lambda rows: _logdet(phi[rows].T @ (weight[rows, None] * phi[rows]))
    if criterion == "kinetic":
        return lambda rows: float(energy[rows].sum())
    return lambda rows: -automac_max(phi[rows])


def _scores(criterion, phi, weight, energy, groups, active) -> np.ndarray:
    """Per active sensor: how much it is worth keeping (the smallest is removed)."""
    rows = [r for g in active for r in groups[g]]
    if criterion in ("efi", "efi-dpr"):
        P = phi[rows]
        Ainv = np.linalg.inv(P.T @ P)
        out = []
        for g in active:
            Pg = phi[groups[g]]
            Egg = Pg @ Ainv @ Pg.T
            if criterion == "efi":
                loss = np.linalg.det(np.eye(len(groups[g])) - Egg)  # det(A - Pg'Pg) / det(A)
                out.append(-loss)
            else:
                out.append(float(np.diag(Egg) @ weight[groups[g]]))
        return np.array(out, dtype=float)
    if criterion == "kinetic":
        return np.array([energy[groups[g]].sum() for g in active])
    out = []
    for g in active:
        keep = [r for h in active if h != g for r in groups[h]]
        out.append(automac_max(phi[keep]))  # small remaining MAC = removing g does no harm
    return np.array(out)


def classical_placement(shapes: np.ndarray, groups: Sequence[Sequence[int]], n_sensors: int, criterion: str = "efi",
                        *, fixed: Sequence[int] = (), eigenvalues: np.ndarray | None = None,
                        energy: np.ndarray | None = None, exchange: bool = True,
                        max_passes: int = 20) -> ClassicalPlacement:
    """Backward elimination (and exchange) of candidate sensors by a classical criterion.

    Parameters
    ----------
    shapes : ndarray, shape ``(n_rows, m)``
        Target mode shapes at the candidate dofs (rows in sensor order).
    groups : sequence of sequence of int
        Rows of each candidate sensor.
    n_sensors : int
        Sensors to keep (fixed ones included).
    criterion : {"efi", "efi-dpr", "kinetic", "mac"}
    fixed : sequence of int
        Sensors never removed.
    eigenvalues : ndarray, shape ``(m,)``
        ``"efi-dpr"``: the target modes' eigenvalues (rad²/s²).
    energy : ndarray, shape ``(n_rows, m)``
        ``"kinetic"``: each dof's share of each mode's kinetic energy.
    exchange : bool, default True
        Improve the elimination's set by exchanges.
    max_passes : int, default 20

    Returns
    -------
    ClassicalPlacement

    Raises
    ------
    InputError
        An unknown criterion; ``n_sensors`` below the fixed sensors or above the candidates; the
        candidates cannot tell the target modes apart (EfI: singular Fisher information).
    """
    if criterion not in CRITERIA:
        raise InputError(f"unknown placement criterion {criterion!r}: use {', '.join(CRITERIA)}")
    phi = np.asarray(shapes, dtype=float)
    phi = phi / np.where(np.linalg.norm(phi, axis=0) > 0, np.linalg.norm(phi, axis=0), 1.0)
    n_c = len(groups)
    fixed = tuple(sorted(set(int(i) for i in fixed)))
    if not len(fixed) <= n_sensors <= n_c:
        raise InputError(f"sensors: {n_sensors} asked, but there are {n_c} candidate sensors"
                         + (f" and {len(fixed)} fixed ones" if fixed else ""))
    weight = np.zeros(phi.shape[0])
    if criterion == "efi-dpr":
        if eigenvalues is None:
            raise InputError("efi-dpr needs the target modes' eigenvalues")
        weight = np.sum(phi ** 2 / np.sqrt(np.abs(np.asarray(eigenvalues, float)))[None, :], axis=1)
    if criterion == "kinetic":
        if energy is None:
            raise InputError("kinetic energy placement needs the energy of each dof")
        energy = np.asarray(energy, float)
    else:
        energy = np.zeros_like(phi)
    if criterion in ("efi", "efi-dpr"):
        fewest = sum(sorted(len(g) for g in groups)[:n_sensors])
        if fewest < phi.shape[1]:
            raise InputError(f"{criterion}: {n_sensors} sensor(s) may measure fewer dofs than the {phi.shape[1]} target "
                             "modes; effective independence needs at least one measured dof per target mode")
        s = np.linalg.svd(phi.T @ phi, compute_uv=False)
        if s[-1] <= 1e-12 * s[0]:
            raise InputError("the candidate sensors cannot tell the target modes apart (Fisher information "
                             "singular): add candidates or target fewer modes")
    groups = [list(g) for g in groups]
    active = list(range(n_c))
    removed = []
    while len(active) > n_sensors:
        free = [i for i, g in enumerate(active) if g not in fixed]
        sc = _scores(criterion, phi, weight, energy, groups, active)
        k = free[int(np.argmin(sc[free]))]
        removed.append(active.pop(k))
    objective = _objective(criterion, phi, weight, energy)

    def value(sel):
        return objective([r for g in sel for r in groups[g]])

    elim = tuple(sorted(active))
    best, swaps = list(elim), 0
    if exchange:
        best, swaps = exchange_pass(best, n_c, fixed, value, max_passes)
    return ClassicalPlacement(tuple(sorted(best)), elim, tuple(removed), value(best), value(elim), swaps, criterion)


def exchange_pass(chosen: Sequence[int], n_candidates: int, fixed: Sequence[int], value: Callable,
                  max_passes: int = 20) -> tuple[list[int], int]:
    """Swap chosen (not fixed) sensors for unchosen ones while the best swap raises ``value``.

    Parameters
    ----------
    chosen : sequence of int
        The starting set.
    n_candidates : int
    fixed : sequence of int
        Sensors never swapped out.
    value : callable
        ``value(set) -> comparable`` (a float, or a tuple compared lexicographically); larger is better.
    max_passes : int
        The most swaps.

    Returns
    -------
    (list of int, int)
        The improved set and the number of swaps.
    """
    cur = list(chosen)
    best_v = value(cur)
    swaps = 0
    for _ in range(max_passes):
        move = None
        outside = [h for h in range(n_candidates) if h not in cur]
        for i, g in enumerate(cur):
            if g in fixed:
                continue
            for h in outside:
                trial = cur[:i] + [h] + cur[i + 1:]
                v = value(trial)
                if _better(v, best_v):
                    best_v, move = v, trial
        if move is None:
            break
        cur = move
        swaps += 1
    return cur, swaps


def _better(a, b, rtol: float = 1e-10) -> bool:
    if isinstance(a, tuple):
        for x, y in zip(a, b):
            if _better(x, y, rtol):
                return True
            if _better(y, x, rtol):
                return False
        return False
    if b == -np.inf:
        return bool(a > b)
    return bool(a > b + rtol * max(1.0, abs(b)))


__all__ = ["CRITERIA", "ClassicalPlacement", "classical_placement", "exchange_pass", "automac_max"]
