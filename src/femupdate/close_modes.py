r"""Groups of repeated or close model modes, and the pairing inside a group by the measured shapes.

Symmetric structures have repeated eigenvalues, nearly symmetric ones close eigenvalues.  Inside
such a group G of model modes (neighbours whose relative eigenvalue gap is at most a tolerance,
:func:`mode_groups`, :func:`femupdate.rules.group_bounds`) the model's basis Φ_G is arbitrary
(repeated) or turns abruptly with the parameters (close): the MAC of a test mode with one of the
group's modes says nothing.  The one pairing (:func:`femupdate.correlation.pair`) is therefore
given, in every column of a group, the MAC of the *best combination* of the group's shapes
(:func:`group_mac`: ‖Πψ‖²/‖ψ‖², Π the projector on the span of Φ_G's measured rows; the largest
MAC any combination reaches) — so it decides which test modes go into the group — and the test
modes it puts there are then given the group's modes by their best combinations
(:func:`assign_inside`: the test mode whose combination lies most along a model mode takes it; for
a repeated group any assignment is as good, for close modes the measured shapes say which
frequency is whose).  ``correlate`` and ``update`` pair this way alike.

Where the measured dofs do not see every combination of a group (sensors on a symmetry line, fewer
dofs than modes), the combination they do not see is left out of the fit (singular values of the
group's measured shapes below :data:`RANK_RTOL` of the largest: the minimum-norm fit), and a
group whose least visible combination is seen at less than :data:`VISIBLE_RTOL` of the most
visible (:func:`visibility`) is not resolved by the test shapes: the results say so.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from ._errors import InputError
from .pairing_rules import assign, group_bounds, mac_vector

#: singular values of a group's measured shapes below this fraction of the largest are left out of
#: the fit (the measured dofs do not see that combination of the group's modes)
RANK_RTOL = 1e-8
#: a group whose least visible combination at a test mode's measured dofs is below this fraction of
#: the most visible one is not resolved by the test shapes (their pairing inside it rests on little)
VISIBLE_RTOL = 1e-2


def mode_groups(eigenvalues, tol: float) -> list[tuple[int, int]]:
    """The groups of repeated or close modes among ``eigenvalues``: runs of neighbours whose
    relative gap is at most ``tol`` (:func:`femupdate.rules.group_bounds`).

    Parameters
    ----------
    eigenvalues : array_like of float, shape ``(m,)``
        Eigenvalues (rad²/s²), ascending; rigid-body ones (exactly 0) join no group.
    tol : float
        The relative gap, ``0 <= tol < 1`` (updating's default :data:`femupdate.rules.CLOSE_TOL`).

    Returns
    -------
    list of (int, int)
        ``(first, stop)`` of every group of at least two modes, ascending.

    Raises
    ------
    InputError
        ``tol`` not a number in [0, 1).
    """
    if not isinstance(tol, (int, float, np.floating)) or not 0.0 <= float(tol) < 1.0:
        raise InputError(f"the relative gap of close modes must be a number in [0, 1), got {tol!r}")
    lam = np.array(eigenvalues, dtype=float)
    out, t = [], 0
    while t < lam.size:
        a, b = group_bounds(lam, lam.size, t, float(tol))
        if b - a > 1:
            out.append((int(a), int(b)))
        t = max(int(b), t + 1)
    return out


def pinv(B: np.ndarray) -> tuple[np.ndarray, int]:
    """The pseudo-inverse of a group's measured shapes ``B`` (n_s, r) at its numerical rank
    (singular values above :data:`RANK_RTOL` of the largest), and that rank."""
    U, S, Vt = np.linalg.svd(B, full_matrices=False)
    top = S[0] if S.size else 0.0
    if top <= 0.0:
        return np.zeros(B.T.shape), 0
    rank = int(np.sum(S > RANK_RTOL * top))
    return (Vt[:rank].T / S[:rank]) @ U[:, :rank].T, rank


def visibility(B: np.ndarray) -> float:
    """Smallest over largest singular value of a group's measured shapes ``B`` (n_s, r): how well the
    measured dofs see every combination of the group's modes (1: alike; 0: one is not seen)."""
    if B.shape[0] < B.shape[1]:
        return 0.0
    S = np.linalg.svd(B, compute_uv=False)
    return float(S[-1] / S[0]) if S.size and S[0] > 0 else 0.0


def combination(psi: np.ndarray, B: np.ndarray) -> tuple[np.ndarray, float]:
    """The best combination c = B⁺ψ of a group's measured shapes ``B`` (n_s, r) for the test shape
    ``psi`` (n_s,) — the least-squares fit, minimum norm where ``B`` does not see every
    combination — and the MAC of Bc with ψ (:func:`group_mac`)."""
    c = pinv(B)[0] @ psi
    out = np.zeros(1)
    mac_vector(psi, (B @ c)[:, None], out)
    return c, float(out[0])


def group_mac(psi: np.ndarray, B: np.ndarray) -> float:
    """MAC of the best combination of a group's measured shapes ``B`` (n_s, r) with the test shape
    ``psi`` (n_s,): ‖Πψ‖²/‖ψ‖², the largest MAC any combination reaches."""
    return combination(psi, B)[1]


def group_columns(mac_matrix: np.ndarray, groups: Sequence[tuple[int, int]],
                  measured: Mapping[int, tuple[np.ndarray, np.ndarray]]) -> tuple[np.ndarray, dict]:
    """The MAC matrix the one pairing is given where model modes form groups: each group's columns
    the MAC of the best combination of its shapes (module docstring).

    Parameters
    ----------
    mac_matrix : numpy.ndarray, shape ``(n_test, n_model)``
        The MAC of each test mode with each model mode.
    groups : sequence of (int, int)
        The groups (:func:`mode_groups`), within the columns.
    measured : mapping of int to (numpy.ndarray, numpy.ndarray)
        Per test mode with a shape, its shape ψ (n_s,) and the model's shapes at the same dofs
        (n_s, n_model).

    Returns
    -------
    mac : numpy.ndarray, shape ``(n_test, n_model)``
        A copy with the groups' columns replaced.
    combinations : dict of (int, (int, int)) to numpy.ndarray
        ``{(test mode, group): c}``, the best combination of each test mode in each group.
    """
    out = np.array(mac_matrix, dtype=float)
    combos = {}
    for a, b in groups:
        for k, (psi, B) in measured.items():
            c, m = combination(psi, B[:, a:b])
            out[k, a:b] = m
            combos[(k, (a, b))] = c
    return out, combos


def assign_inside(pairs, groups: Sequence[tuple[int, int]], combos: Mapping) -> list[tuple[int, int, float]]:
    """The pairs with each group's model modes given to the test modes the pairing put in it by
    their best combinations: the assignment of largest total c_j²/‖c‖²
    (:func:`femupdate.pairing_rules.assign`) over the model modes the pairing gave the group; a
    test mode without a shape keeps its model mode where the others leave it.

    Parameters
    ----------
    pairs : sequence of (int, int, float)
        The pairing's ``(test mode, model mode, MAC)``.
    groups : sequence of (int, int)
        The groups.
    combos : mapping
        ``{(test mode, group): c}`` (:func:`group_columns`).

    Returns
    -------
    list of (int, int, float)
        The pairs, in the same order, with the model modes inside each group reassigned (the MACs,
        those of the best combinations, unchanged).
    """
    col = {k: j for k, j, _ in pairs}
    for a, b in groups:
        ks = [k for k, j, _ in pairs if a <= j < b]
        if len(ks) < 2:
            continue
        cols = sorted(col[k] for k in ks)
        C = np.zeros((len(ks), len(cols)))
        for i, k in enumerate(ks):
            c = combos.get((k, (a, b)))
            cc = float(c @ c) if c is not None else 0.0
            if c is not None and cc > 0:
                C[i] = [-(c[j - a] ** 2) / cc for j in cols]
            else:  # no shape: its own column first
                C[i] = [0.0 if j == col[k] else 1e-9 for j in cols]
        out = np.zeros(len(ks), np.int64)
        assign(C, len(ks), len(cols), out)
        for i, k in enumerate(ks):
            col[k] = cols[int(out[i])]
    return [(k, col[k], m) for k, _, m in pairs]


__all__ = ["mode_groups", "pinv", "visibility", "combination", "group_mac", "group_columns", "assign_inside",
           "RANK_RTOL", "VISIBLE_RTOL"]
