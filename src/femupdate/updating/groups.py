r"""Repeated and close modes in the modal updating problem: what a test mode is compared with when
its model mode belongs to a group.

Symmetric structures have repeated eigenvalues, nearly symmetric ones close eigenvalues.  Inside
such a group G (neighbouring model modes whose relative eigenvalue gap is at most
``close_modes``, :class:`~femupdate.options.ModalOptions`, default
:data:`femupdate.rules.CLOSE_TOL` = 0.01; :func:`femupdate.rules.group_bounds`) the model's basis
Φ_G is arbitrary (repeated) or turns abruptly with the parameters (close), so neither a MAC with
one of its modes nor the derivative of one of its modes means anything.  The problem compares a
test mode paired into a group with the group as a whole:

* **Pairing** (:func:`group_mac`): each group's MAC columns are the MAC of the best combination of
  the group's measured shapes — ‖Πψ‖²/‖ψ‖², Π the projector on the span of Φ_G's measured rows —
  the same for every mode of the group, so that the one pairing
  (:func:`femupdate.correlation.pair`) decides which test modes go into the group, and the test
  shapes, not the model's arbitrary basis, decide the combination inside it.
* **Residuals** (:func:`fit`, :func:`assign_inside`): the model shape of test mode k is the
  combination v_k = Φ_G c_k that fits its measured shape best (least squares over its measured
  dofs: c_k = (Φ_G,s)⁺ ψ_k — a rotation of the group's basis chosen by the test, independent of
  the model's arbitrary basis and smooth in the parameters as long as the group stays apart from
  the other modes).  Its eigenvalue is the group's eigenvalue whose mode c_k lies most along
  (the assignment of largest Σ c_j²/‖c‖² over the model modes the pairing gave the group): the
  eigenvalues are compared as a set, and where the modes are close but distinct the measured
  shapes say which frequency is whose.  On noise-free data both equal the test's exactly.  A
  test mode without a shape keeps the model mode the pairing gave it.
* **Jacobian** (:func:`fit_jacobian`): exact, from the derivative of the group's basis with no
  rotation inside the group (:mod:`femupdate.sensitivity.repeated`; every derivative route),
  through the derivative of the pseudo-inverse (Golub & Pereyra 1973); the eigenvalue's is Fox &
  Kapoor's, the diagonal of the restricted eigenproblem's derivative — for a repeated eigenvalue
  one of its directional derivatives (the eigenvalues of a repeated group are not differentiable,
  their set is only directionally: a cone, which Gauss–Newton steps cross).
* **Test shapes that cannot tell the group's modes apart** (sensors on a symmetry line, fewer
  measured dofs than modes in the group): the combination the measured dofs do not see (singular
  values of Φ_G,s below :data:`RANK_RTOL` of the largest) is left out (the minimum-norm fit) and
  the result says so; a group whose least visible combination is below :data:`VISIBLE_RTOL` of
  the most visible is reported as not resolved by the test shapes.

Modes alone (every mode of a model without repeated or close modes) are compared exactly as
before: nothing here runs.

References
----------
Golub, G.H., Pereyra, V. (1973) The differentiation of pseudo-inverses and nonlinear least squares
problems whose variables separate. SIAM J. Numer. Anal. 10(2), 413–432.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .. import rules

#: singular values of a group's measured shapes below this fraction of the largest are left out of
#: the fit (the measured dofs do not see that combination of the group's modes)
RANK_RTOL = 1e-8
#: a group whose least visible combination at a test mode's measured dofs is below this fraction of
#: the most visible one is reported as not resolved by the test shapes (their pairing inside the
#: group rests on little)
VISIBLE_RTOL = 1e-2


@dataclass(frozen=True, eq=False)
class GroupFit:
    """What test mode k is compared with when its model mode belongs to a group (:func:`fit`).

    Attributes
    ----------
    group : (int, int)
        ``(first, stop)``: model modes first .. stop − 1 (0-based).
    c : numpy.ndarray, shape ``(r,)``
        The combination of the group's shapes, v = Φ_G c.
    shape : numpy.ndarray, shape ``(n_s,)``
        v at the test mode's measured dofs (the best fit of its shape); empty without shape.
    eigenvalue : float
        The eigenvalue of the group's model mode ``mode``, rad²/s².
    mac : float
        MAC of ``shape`` with the test shape (NaN without shape).
    visibility : float
        Smallest over largest singular value of the group's measured shapes (1: every combination
        seen alike; 0: one is not seen at all); NaN without shape.
    rank : int
        The combinations the fit uses (the group's size when every one is seen).
    mode : int
        The model mode of the group whose eigenvalue the test mode is compared with
        (:func:`assign_inside`; 0-based).
    """

    group: tuple[int, int]
    c: np.ndarray
    shape: np.ndarray
    eigenvalue: float
    mac: float
    visibility: float
    rank: int
    mode: int

    @property
    def resolved(self) -> bool:
        """The test shape tells every mode of the group apart (visibility at least :data:`VISIBLE_RTOL`)."""
        return bool(self.visibility >= VISIBLE_RTOL)


def _pinv(W: np.ndarray) -> tuple[np.ndarray, int]:
    """Pseudo-inverse of ``W`` at its numerical rank (singular values above :data:`RANK_RTOL` of the largest)."""
    U, S, Vt = np.linalg.svd(W, full_matrices=False)
    top = S[0] if S.size else 0.0
    if top <= 0.0:
        return np.zeros(W.T.shape), 0
    rank = int(np.sum(S > RANK_RTOL * top))
    return (Vt[:rank].T / S[:rank]) @ U[:, :rank].T, rank


def visibility(Bs: np.ndarray) -> float:
    """Smallest over largest singular value of a group's measured shapes ``Bs`` (n_s, r): how well
    the measured dofs see every combination of the group's modes (0: one is not seen at all)."""
    if Bs.shape[0] < Bs.shape[1]:
        return 0.0
    S = np.linalg.svd(Bs, compute_uv=False)
    return float(S[-1] / S[0]) if S.size and S[0] > 0 else 0.0


def group_mac(psi: np.ndarray, Bs: np.ndarray) -> float:
    """MAC of the best combination of a group's measured shapes ``Bs`` (n_s, r) with the test shape
    ``psi`` (n_s,): ‖Πψ‖²/‖ψ‖², the largest MAC any combination reaches."""
    pinv, _ = _pinv(Bs)
    out = np.zeros(1)
    rules.mac_vector(psi, (Bs @ (pinv @ psi))[:, None], out)
    return float(out[0])


def fit(psi: np.ndarray | None, Bs: np.ndarray | None, lam_g: np.ndarray, group: tuple[int, int],
        j: int) -> GroupFit:
    """The combination of a group's modes that test mode k is compared with (module docstring):
    c = (Φ_G,s)⁺ψ, the least-squares fit of the measured shape by the group's measured shapes
    (minimum norm where they do not see every combination); without a shape c = e_j.

    Parameters
    ----------
    psi : numpy.ndarray, shape ``(n_s,)``, or None
        The scaled test shape at its measured dofs; None for a test mode without shape.
    Bs : numpy.ndarray, shape ``(n_s, r)``, or None
        The group's mass-normalised shapes at those dofs.
    lam_g : numpy.ndarray, shape ``(r,)``
        The group's eigenvalues (rad²/s²).
    group : (int, int)
        ``(first, stop)``.
    j : int
        The model mode of the group whose eigenvalue the test mode is compared with
        (:func:`assign_inside`).

    Returns
    -------
    GroupFit
    """
    a, b = group
    r = b - a
    if psi is None or Bs is None:
        c = np.zeros(r)
        c[j - a] = 1.0
        return GroupFit(group, c, np.zeros(0), float(lam_g[j - a]), float("nan"), float("nan"), r, j)
    pinv, rank = _pinv(Bs)
    c = pinv @ psi
    v = Bs @ c
    out = np.zeros(1)
    rules.mac_vector(psi, v[:, None], out)
    return GroupFit(group, c, v, float(lam_g[j - a]), float(out[0]), visibility(Bs), rank, j)


def assign_inside(fits: dict, pairs, eigenvalues: np.ndarray) -> list[tuple[int, int, float]]:
    """The pairs with each group's model modes given to its test modes by the fits: the test mode
    whose best combination lies most along a model mode of the group takes that mode's eigenvalue
    (the assignment of largest total c_j²/‖c‖², :func:`femupdate.pairing_rules.assign`, over the
    model modes the pairing gave the group).  For a repeated group any assignment gives the same
    eigenvalues; for close modes it is the measured shapes that say which frequency is whose.

    Parameters
    ----------
    fits : dict of int to GroupFit
        The fits of the test modes paired into groups (their ``j`` is replaced).
    pairs : sequence of (int, int, float)
        The pairing's pairs.
    eigenvalues : numpy.ndarray
        The model's eigenvalues (rad²/s²).

    Returns
    -------
    list of (int, int, float)
        The pairs, each test mode in a group with its model mode so assigned and the MAC of its
        best combination.
    """
    by_group: dict[tuple[int, int], list[int]] = {}
    for k, _, _ in pairs:
        if k in fits:
            by_group.setdefault(fits[k].group, []).append(k)
    col = {k: j for k, j, _ in pairs}
    for (a, b), ks in by_group.items():
        cols = sorted(col[k] for k in ks)
        C = np.zeros((len(ks), len(cols)))
        for i, k in enumerate(ks):
            f = fits[k]
            cc = float(f.c @ f.c)
            if f.shape.size and cc > 0:
                C[i] = [-(f.c[j - a] ** 2) / cc for j in cols]
        out = np.zeros(len(ks), np.int64)
        rules.assign(C, len(ks), len(cols), out)
        for i, k in enumerate(ks):
            f = fits[k]
            j = cols[int(out[i])]
            fits[k] = GroupFit(f.group, f.c, f.shape, float(eigenvalues[j]), f.mac, f.visibility, f.rank, j)
            col[k] = j
    return [(k, col[k], fits[k].mac if k in fits and fits[k].shape.size else m) for k, _, m in pairs]


def fit_jacobian(psi: np.ndarray, Bs: np.ndarray, dBs: np.ndarray) -> np.ndarray:
    r"""Derivative of a :func:`fit` with a shape at the measured dofs, per parameter.

    With B = Φ_G,s (n_s × r), B⁺ its pseudo-inverse at the fit's rank and c = B⁺ψ
    (Golub & Pereyra 1973),

    .. math::

        c' = \bigl(-B^+ B' B^+ + B^+ B^{+T} B'^T (I - B B^+) + (I - B^+ B) B'^T B^{+T} B^+\bigr) \psi,
        \qquad v' = B' c + B c',

    B' the derivative of the group's measured basis with no rotation inside the group
    (:mod:`femupdate.sensitivity.repeated`; v does not depend on the basis chosen).

    Parameters
    ----------
    psi : numpy.ndarray, shape ``(n_s,)``
        The scaled test shape.
    Bs : numpy.ndarray, shape ``(n_s, r)``
        The group's measured shapes.
    dBs : numpy.ndarray, shape ``(n_s, r, L)``
        Their derivatives.

    Returns
    -------
    numpy.ndarray, shape ``(n_s, L)``
    """
    pinv, _ = _pinv(Bs)
    c = pinv @ psi
    res = psi - Bs @ c  # (I − B B⁺) ψ
    null = np.eye(Bs.shape[1]) - pinv @ Bs  # I − B⁺B
    dv = np.zeros((Bs.shape[0], dBs.shape[2]))
    for q in range(dBs.shape[2]):
        dB = dBs[:, :, q]
        dc = -pinv @ (dB @ c) + pinv @ (pinv.T @ (dB.T @ res)) + null @ (dB.T @ (pinv.T @ c))
        dv[:, q] = dB @ c + Bs @ dc
    return dv


def describe(fits: dict, pairs) -> list[dict]:
    """The ``groups`` record of a result's pairing: per group of model modes that test modes were
    paired into, ``model_modes`` and ``test_modes`` (0-based), per test mode its ``visibility``
    and whether the test shapes ``resolved`` the group."""
    by_group: dict[tuple[int, int], list[int]] = {}
    for k, _, _ in pairs:
        if k in fits:
            by_group.setdefault(fits[k].group, []).append(k)
    out = []
    for (a, b), ks in sorted(by_group.items()):
        shaped = [k for k in ks if np.isfinite(fits[k].visibility)]
        out.append({"model_modes": list(range(a, b)), "test_modes": ks,
                    "visibility": {k: fits[k].visibility for k in shaped},
                    "resolved": all(fits[k].resolved for k in shaped) if shaped else False})
    return out


def notes(groups: list[dict], tol: float) -> list[str]:
    """What a result says about its groups of repeated or close modes (:func:`describe`)."""
    out = []
    for g in groups:
        a, b = g["model_modes"][0] + 1, g["model_modes"][-1] + 1
        tests = ", ".join(str(k + 1) for k in g["test_modes"])
        out.append(f"model modes {a}-{b} are repeated or close (relative gap below {tol:g}): test mode(s) {tests} "
                   "were compared with the combination of their shapes that fits each measured shape best (the "
                   "model's own basis there is arbitrary), and with their frequencies as a set")
        unresolved = [k for k, v in g["visibility"].items() if not v >= VISIBLE_RTOL]
        if unresolved:
            out.append(f"the measured dofs of test mode(s) {', '.join(str(k + 1) for k in unresolved)} cannot tell "
                       f"model modes {a}-{b} apart (the least visible combination is seen at "
                       f"{min(g['visibility'][k] for k in unresolved):.2g} of the most visible): their pairing inside "
                       "the group is not confirmed by the shapes; measure dofs off the symmetry lines")
        elif not g["visibility"]:
            out.append(f"test mode(s) {tests} have no shape: their pairing inside model modes {a}-{b} is by "
                       "frequency order only")
    return out


__all__ = ["GroupFit", "group_mac", "visibility", "fit", "assign_inside", "fit_jacobian", "describe", "notes", "RANK_RTOL",
           "VISIBLE_RTOL"]
