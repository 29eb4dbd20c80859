r"""Rigid links exported as penalty springs: detected, and tied exactly or refused by name.

A code that models a rigid link (or a tie, a coupling) by a penalty spring of stiffness P adds
``P (e_a - e_b)(e_a - e_b)ᵀ`` to K.  When P is many orders above the elastic stiffness the
pencil is ill-conditioned: the elastic modes sit at ``1e-10`` of its scale and a first elastic
mode is taken for a rigid-body one; above ``P ≈ k / eps`` the file's own stored entries have lost
the elastic terms (``1e20 + 2000`` is ``1e20`` in double precision).

**Detection** (:func:`find_penalty_links`), on the nominal stiffness K:

1. a pair of dofs (a, b) is a *candidate* when its 2×2 block is singular to
   :data:`PENALTY_RATIO`: ``1 − K_ab² / (K_aa K_bb) ≤ 1 / PENALTY_RATIO``;
2. candidates that share a dof form a *group*; its penalty P is the smallest candidate coupling,
   its elastic scale E the larger of the largest coupling of its dofs to other dofs and the
   largest eigenvalue of its own block that lies far below the penalty (under
   ``P / sqrt(PENALTY_RATIO)``: the spectrum of the penalty against the elastic part);
3. the group is a penalty constraint when ``P ≥ PENALTY_RATIO · E`` (and E > 0: a lone spring
   between two dofs with nothing else is elastic).

**Elimination** (:func:`tie_penalty_links`): a group whose couplings are all negative and whose
diagonals are their couplings' sum (to ``P / PENALTY_RATIO``) is a tie ``u_a = u_b = …``: it is eliminated exactly
as a multipoint constraint, ``K ← Tᵀ K T``, ``M ← Tᵀ M T`` (and every parameter matrix), T the
(n × n − s) matrix that keeps the group's first dof and copies it to the others.  The penalty
cancels exactly in ``Tᵀ K T``; what is left at the tied dofs is the file's elastic stiffness with
the round-off its storage beside P left in it, at most ``2 eps P`` per link (eps = 2.2e-16) of
every stored matrix that holds the penalty and elastic terms together (a matrix that holds the
penalty alone, K0 beside the parameters' matrices, stores it exactly and adds nothing).  The tie is made
when that is at most :data:`PRECISION_TOL` of the tied dof's remaining diagonal; otherwise the
file no longer holds the elastic terms there (to that accuracy) and the model is refused, naming
the dofs.  A group that is not a tie (a penalty with lever arms, ``u_b = u_a + θ × r``, or a
positive coupling) is refused naming its dofs: export such links as multipoint constraints
(Nastran RBE2 / MPC, Abaqus ``*MPC`` / ``*KINEMATIC COUPLING``, ANSYS ``CERIG``), which the
codes eliminate before writing the matrices, or with a penalty below ``PENALTY_RATIO`` times the
elastic stiffness.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from ._errors import InputError
from .dofs import describe

log = logging.getLogger(__name__)

#: a pair of dofs is a penalty link when its coupling exceeds the elastic stiffness at its dofs
#: by this factor (below it the eigensolvers resolve the elastic modes: tests/test_exported_matrices.py)
PENALTY_RATIO = 1e8
#: a tie is made when the round-off the file's storage left at the tied dofs (2 eps P per link)
#: is at most this fraction of their remaining elastic stiffness; else the model is refused
PRECISION_TOL = 1e-6
_EPS = np.finfo(float).eps
_DENSE_GROUP = 1000


@dataclass(frozen=True)
class PenaltyGroup:
    """Dofs joined by penalty couplings.

    Attributes
    ----------
    dofs : tuple of int
        Matrix positions, ascending; the first is kept by a tie.
    penalty : float
        The smallest coupling magnitude of the group.
    elastic : float
        The largest magnitude at its dofs that is not a penalty coupling.
    tie : bool
        Every coupling negative and every diagonal their sum (to ``penalty / PENALTY_RATIO``):
        the dofs move together.
    total : float
        The sum of its coupling magnitudes (the scale of the round-off it leaves).
    """

    dofs: tuple[int, ...]
    penalty: float
    elastic: float
    tie: bool
    total: float


def _candidates(K: sp.csr_array):
    """Off-diagonal pairs (a < b) whose 2×2 block is singular to 1 / PENALTY_RATIO."""
    C = K.tocoo()
    d = K.diagonal()
    off = C.row < C.col
    a, b, v = C.row[off], C.col[off], C.data[off]
    pos = (d[a] > 0) & (d[b] > 0)
    a, b, v = a[pos], b[pos], v[pos]
    with np.errstate(over="ignore", invalid="ignore"):
        gap = 1.0 - (v / d[a]) * (v / d[b])
    keep = gap <= 1.0 / PENALTY_RATIO
    return a[keep], b[keep], v[keep]


def _components(n: int, a, b) -> list[np.ndarray]:
    """Connected components (of size > 1) of the graph with edges (a, b)."""
    G = sp.coo_array((np.ones(a.size), (a, b)), shape=(n, n))
    k, label = sp.csgraph.connected_components(G, directed=False)
    linked = np.zeros(n, bool)
    linked[a] = linked[b] = True
    return [np.flatnonzero(label == c) for c in np.unique(label[linked])]


def _inner_elastic(K: sp.csr_array, dofs: np.ndarray, P: float, R: float) -> float:
    """The elastic part of the group's own block: its eigenvalues far below the penalty (under
    ``P / sqrt(PENALTY_RATIO)``), the largest in magnitude; for a group of more than
    :data:`_DENSE_GROUP` dofs, the largest remainder ``R`` of its diagonals."""
    if len(dofs) > _DENSE_GROUP:
        return R
    lam = np.abs(np.linalg.eigvalsh(K[dofs][:, dofs].toarray()))
    low = lam[lam < P / np.sqrt(PENALTY_RATIO)]
    return float(low.max()) if low.size else 0.0


def find_penalty_links(K) -> list[PenaltyGroup]:
    """The penalty constraints of a stiffness matrix (module docstring).

    Parameters
    ----------
    K : array_like or sparse matrix, shape ``(n, n)``
        Symmetric stiffness.

    Returns
    -------
    list of PenaltyGroup
        One per group of dofs joined by penalty couplings, in order of their first dof.
    """
    K = sp.csr_array(K, dtype=float)
    a, b, v = _candidates(K)
    if not a.size:
        return []
    n = K.shape[0]
    d = K.diagonal()
    partner = sp.coo_array((np.ones(2 * a.size), (np.r_[a, b], np.r_[b, a])), shape=(n, n)).tocsr()
    absK = abs(K).tocsr()
    groups = []
    for dofs in _components(n, a, b):
        inside = np.isin(a, dofs)
        P = float(np.min(np.abs(v[inside])))
        sub = absK[dofs]
        links = partner[dofs]
        coupled = sub.multiply(links)  # the candidate couplings of each dof
        other = sub - coupled
        other = other - sp.csr_array((sub[np.arange(len(dofs)), dofs], (np.arange(len(dofs)), dofs)), shape=sub.shape)
        remainder = d[dofs] - np.asarray(coupled.sum(axis=1)).ravel()
        R = float(np.max(np.abs(remainder)))
        E = max(float(np.abs(other).max()) if other.nnz else 0.0, _inner_elastic(K, dofs, P, R))
        if E == 0.0 or P < PENALTY_RATIO * E:
            continue
        tie = bool(np.all(v[inside] < 0)) and R <= P / PENALTY_RATIO
        groups.append(PenaltyGroup(tuple(int(i) for i in dofs), P, E, tie, float(np.sum(np.abs(v[inside])))))
    return groups


def tie_matrix(n: int, groups) -> tuple[sp.csr_array, np.ndarray]:
    """T (n × m) keeping every dof but the groups' later ones, which copy their group's first.

    Parameters
    ----------
    n : int
        Number of dofs.
    groups : iterable of sequence of int
        Tied dofs; the first of each is kept.

    Returns
    -------
    T : scipy.sparse.csr_array, shape ``(n, m)``
    kept : numpy.ndarray of int
        Positions of the kept dofs (the columns of T, in order).
    """
    master = np.arange(n)
    for g in groups:
        master[list(g)] = g[0]
    kept = np.flatnonzero(master == np.arange(n))
    col = np.searchsorted(kept, master)
    return sp.csr_array((np.ones(n), (np.arange(n), col)), shape=(n, kept.size)), kept


def _stored_loss(parts, T, g: PenaltyGroup, col: int) -> float:
    """The round-off bound of the elastic terms at group ``g``: ``2 eps`` times the penalty-sized
    couplings of every stored matrix that holds elastic terms there too.  A matrix whose group
    block cancels exactly under the tie and that couples the group to nothing else holds the
    penalty alone (exactly), and adds nothing."""
    idx = list(g.dofs)
    loss = 0.0
    for A in parts:
        block = A[idx][:, idx]
        if block.nnz == 0:
            continue
        outside = A[idx].nnz - block.nnz
        reduced = (T.T @ A @ T)[[col]][:, [col]]
        if outside == 0 and (reduced.nnz == 0 or not np.any(reduced.data)):
            continue
        off = sp.triu(abs(block), k=1)
        loss += 2 * _EPS * float(off.sum())
    return loss


def tie_penalty_links(K, dofs, what: str = "K", parts=None) -> tuple[sp.csr_array | None, np.ndarray, list[str]]:
    """The transformation that eliminates the penalty ties of K, or a refusal naming the dofs.

    Parameters
    ----------
    K : array_like or sparse matrix, shape ``(n, n)``
        The nominal stiffness.
    dofs : sequence of str
        Its dof labels.
    what : str, default ``"K"``
        The matrix as messages name it (its file).
    parts : sequence of sparse matrices, optional
        The stored matrices whose sum is K (K0 and ``p_j dK_j``), for the round-off bound: only
        those that hold the penalty and elastic terms together rounded the one beside the
        other.  Default: K alone.

    Returns
    -------
    T : scipy.sparse.csr_array or None
        ``(n, m)`` (module docstring); None when K has no penalty links.
    kept : numpy.ndarray of int
        The dofs that remain (all of them when T is None).
    notes : list of str
        One line per tie made, with its penalty, elastic scale and round-off bound.

    Raises
    ------
    InputError
        A penalty group that is not a tie, or whose elastic terms the file's storage has lost
        beyond :data:`PRECISION_TOL`; the dofs are named.
    """
    K = sp.csr_array(K, dtype=float)
    n = K.shape[0]
    groups = find_penalty_links(K)
    if not groups:
        return None, np.arange(n), []
    for g in groups:
        if not g.tie:
            raise InputError(
                f"{what}: a penalty constraint (coupling {g.penalty:.3g} against an elastic stiffness of {g.elastic:.3g} "
                f"at its dofs) joins {describe([dofs[i] for i in g.dofs])} other than as equal motions (a lever arm "
                "or a positive coupling): femupdate ties only equal dofs; export the link as a multipoint constraint "
                "(Nastran RBE2/MPC, Abaqus *MPC or *KINEMATIC COUPLING, ANSYS CERIG) or with a penalty below "
                f"{PENALTY_RATIO:g} times the elastic stiffness")
    T, kept = tie_matrix(n, [g.dofs for g in groups])
    parts = [sp.csr_array(A) for A in (parts if parts is not None else [K])]
    D = sum((T.T @ A @ T).diagonal() for A in parts)  # each part reduced alone: its penalty cancels exactly
    col = {int(k): c for c, k in enumerate(kept)}
    notes = []
    for g in groups:
        loss = _stored_loss(parts, T, g, col[g.dofs[0]])
        rest = D[col[g.dofs[0]]]
        names = describe([dofs[i] for i in g.dofs])
        if not rest > 0 or loss > PRECISION_TOL * rest:
            held = ("none of the elastic stiffness (lost to round-off beside the penalty)" if not rest > 0 else
                    f"the elastic stiffness only to {loss / rest:.2g} of it ({PRECISION_TOL:g} needed)")
            raise InputError(
                f"{what}: a penalty link (stiffness {g.penalty:.3g}, {g.penalty / g.elastic:.2g} times the elastic "
                f"stiffness there) ties {names}; the file's entries at those dofs hold {held}, so its modes would be "
                "wrong (a first elastic mode taken for a rigid-body mode).  Export the link as a multipoint "
                "constraint (Nastran RBE2/MPC, Abaqus *MPC, ANSYS CERIG), which the code eliminates before writing "
                f"the matrices, or with a penalty below about {PRECISION_TOL * g.elastic / (2 * _EPS):.2g}")
        notes.append(f"{what}: a penalty link (stiffness {g.penalty:.3g}, {g.penalty / g.elastic:.2g} times the elastic "
                     f"stiffness) ties {names}: eliminated exactly as a multipoint constraint ({dofs[g.dofs[0]]} kept; "
                     f"round-off left by the file at most {loss / rest:.1g} of its stiffness)")
    return T, kept, notes





def eliminate_penalty_links(model, what: str | None = None):
    """The model with its penalty ties eliminated exactly (:func:`tie_penalty_links` on its
    nominal stiffness), each tie logged as a warning; the model itself when it has none.

    Parameters
    ----------
    model : femupdate.Model
    what : str, optional
        How messages name the stiffness (its files); default ``model <name>: K``.

    Returns
    -------
    femupdate.Model
        On the kept dofs: ``Tᵀ K0 T``, ``Tᵀ M0 T`` and ``Tᵀ dK_j T``, ``Tᵀ dM_j T``.

    Raises
    ------
    InputError
        As :func:`tie_penalty_links`.
    """
    from .constraints import reduce_model

    what = what or f"model {model.name!r}: K"
    p = model.values
    parts = [model.K0] + [v * A for v, A in zip(p, model.dK) if A is not None and v != 0]
    if model.terms:  # the non-linear terms at the nominal values (femupdate.coefficients)
        parts += [c * t.K for c, t in zip(model._coefficients(p), model.terms) if t.K is not None and c != 0]
    T, kept, notes = tie_penalty_links(model.K(), model.dofs, what, parts)
    if T is None:
        return model
    for note in notes:
        log.warning("%s", note)
    dependent = np.setdiff1d(np.arange(model.n_dofs), kept).tolist()
    return reduce_model(model, T, kept, dependent, ("a penalty tie",) * len(dependent))


__all__ = ["PENALTY_RATIO", "PRECISION_TOL", "PenaltyGroup", "find_penalty_links", "tie_matrix", "tie_penalty_links",
           "eliminate_penalty_links"]
