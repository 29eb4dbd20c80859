r"""Repeated and close modes in the modal updating problem: what a test mode is compared with when
its model mode belongs to a group.

Symmetric structures have repeated eigenvalues, nearly symmetric ones close eigenvalues.  Inside
such a group G (neighbouring model modes whose relative eigenvalue gap is at most
``close_modes``, :class:`~femupdate.options.ModalOptions`, default
:data:`femupdate.rules.CLOSE_TOL` = 1e-6; :func:`femupdate.rules.group_bounds`) the model's basis
Φ_G is arbitrary (repeated) or turns abruptly with the parameters (close), so neither a MAC with
one of its modes nor the derivative of one of its modes means anything.  The problem compares a
test mode paired into a group with the group as a whole:

* **Pairing** (:func:`group_mac`): each group's MAC columns are the MAC of the best combination of
  the group's measured shapes — ‖Πψ‖²/‖ψ‖², Π the projector on the span of Φ_G's measured rows —
  the same for every mode of the group, so that the one pairing
  (:func:`femupdate.correlation.pair`) decides which test modes go into the group, and the test
  shapes, not the model's arbitrary basis, decide the combination inside it.
* **Residuals** (:func:`fit`): the model shape of test mode k is the combination
  v_k = Φ_G c_k that fits its measured shape best (least squares over its measured dofs:
  c_k = (Φ_G,s)⁺ ψ_k — a rotation of the group's basis chosen by the test), its eigenvalue the
  Rayleigh quotient λ̃_k = c_kᵀΛ_G c_k / c_kᵀc_k.  Both are independent of the basis, and smooth
  in the parameters as long as the group stays apart from the other modes; on noise-free data
  they equal the test's exactly (the test mode is one combination of the group).  A test mode
  without a shape keeps the model mode it was paired with (c = e_j; its eigenvalue λ_j).
* **Jacobian** (:func:`fit_jacobian`): exact, from the derivative of the group's basis with no
  rotation inside the group and of the restricted eigenproblem
  (:mod:`femupdate.sensitivity.repeated`; every derivative route), through the derivative of the
  pseudo-inverse (Golub & Pereyra 1973).
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
        The Rayleigh quotient of v, rad²/s².
    mac : float
        MAC of ``shape`` with the test shape (NaN without shape).
    visibility : float
        Smallest over largest singular value of the group's measured shapes (1: every combination
        seen alike; 0: one is not seen at all); NaN without shape.
    rank : int
        The combinations the fit uses (the group's size when every one is seen).
    """

    group: tuple[int, int]
    c: np.ndarray
    shape: np.ndarray
    eigenvalue: float
    mac: float
    visibility: float
    rank: int

    @property
    def resolved(self) -> bool:
        """The test shape tells every mode of the group apart (visibility at least :data:`VISIBLE_RTOL`)."""
        return bool(self.visibility >= VISIBLE_RTOL)


def _pinv(Bs: np.ndarray) -> tuple[np.ndarray, float, int]:
    """Pseudo-inverse of the group's measured shapes (rank by :data:`RANK_RTOL`), its visibility and rank."""
    U, S, Vt = np.linalg.svd(Bs, full_matrices=False)
    top = S[0] if S.size else 0.0
    if top <= 0.0:
        return np.zeros(Bs.T.shape), 0.0, 0
    rank = int(np.sum(S > RANK_RTOL * top))
    visibility = float(S[-1] / top) if Bs.shape[0] >= Bs.shape[1] else 0.0
    return (Vt[:rank].T / S[:rank]) @ U[:, :rank].T, visibility, rank


def group_mac(psi: np.ndarray, Bs: np.ndarray) -> float:
    """MAC of the best combination of a group's measured shapes ``Bs`` (n_s, r) with the test shape
    ``psi`` (n_s,): ‖Πψ‖²/‖ψ‖², the largest MAC any combination reaches."""
    pinv, _, _ = _pinv(Bs)
    out = np.zeros(1)
    rules.mac_vector(psi, (Bs @ (pinv @ psi))[:, None], out)
    return float(out[0])


def fit(psi: np.ndarray | None, Bs: np.ndarray | None, lam_g: np.ndarray, group: tuple[int, int], j: int) -> GroupFit:
    """The combination of a group's modes that test mode k is compared with (module docstring).

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
        The model mode the pairing gave (used without shape: c = e_j).

    Returns
    -------
    GroupFit
    """
    a, b = group
    r = b - a
    if psi is None or Bs is None:
        c = np.zeros(r)
        c[j - a] = 1.0
        return GroupFit(group, c, np.zeros(0), float(lam_g[j - a]), float("nan"), float("nan"), r)
    pinv, visibility, rank = _pinv(Bs)
    c = pinv @ psi
    v = Bs @ c
    out = np.zeros(1)
    rules.mac_vector(psi, v[:, None], out)
    cc = float(c @ c)
    lam = float(c @ (lam_g * c) / cc) if cc > 0 else float(lam_g[j - a])
    return GroupFit(group, c, v, lam, float(out[0]), visibility, rank)


def fit_jacobian(psi: np.ndarray, Bs: np.ndarray, dBs: np.ndarray, lam_g: np.ndarray, dA: np.ndarray,
                 f: GroupFit) -> tuple[np.ndarray, np.ndarray]:
    r"""Derivatives of a :func:`fit` with a shape: of v at the measured dofs and of its Rayleigh
    quotient, per parameter.

    With A = Φ_G,s (n_s × r), A⁺ its pseudo-inverse at the fit's rank, c = A⁺ψ,

    .. math::

        c' = \bigl(-A^+ A' A^+ + A^+ A^{+T} A'^T (I - A A^+) + (I - A^+ A) A'^T A^{+T} A^+\bigr)\psi,
        \qquad v' = A' c + A c', \qquad
        \tilde\lambda' = \frac{2 c'^T (\Lambda - \tilde\lambda I) c + c^T D c}{c^T c},

    A' the derivative of the group's measured basis (no rotation inside the group) and D that of
    its restricted stiffness (:func:`~femupdate.sensitivity.repeated.restricted_derivatives`).

    Parameters
    ----------
    psi : numpy.ndarray, shape ``(n_s,)``
        The scaled test shape.
    Bs : numpy.ndarray, shape ``(n_s, r)``
        The group's measured shapes.
    dBs : numpy.ndarray, shape ``(n_s, r, L)``
        Their derivatives.
    lam_g : numpy.ndarray, shape ``(r,)``
        The group's eigenvalues.
    dA : numpy.ndarray, shape ``(r, r, L)``
        The restricted stiffness' derivatives.
    f : GroupFit
        The fit at the point.

    Returns
    -------
    dv : numpy.ndarray, shape ``(n_s, L)``
    dlam : numpy.ndarray, shape ``(L,)``
    """
    pinv, _, _ = _pinv(Bs)
    c = f.c
    cc = float(c @ c)
    res = psi - Bs @ c  # (I − A A⁺) ψ
    null = np.eye(Bs.shape[1]) - pinv @ Bs  # I − A⁺A
    L = dBs.shape[2]
    dv = np.zeros((Bs.shape[0], L))
    dlam = np.zeros(L)
    for q in range(L):
        dB = dBs[:, :, q]
        dc = -pinv @ (dB @ c) + pinv @ (pinv.T @ (dB.T @ res)) + null @ (dB.T @ (pinv.T @ c))
        dv[:, q] = dB @ c + Bs @ dc
        dlam[q] = (2.0 * dc @ ((lam_g - f.eigenvalue) * c) + c @ dA[:, :, q] @ c) / cc
    return dv, dlam


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
                   "were compared with the combination of their shapes that fits each measured shape best, and "
                   "with its Rayleigh frequency (the model's own basis there is arbitrary)")
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


__all__ = ["GroupFit", "group_mac", "fit", "fit_jacobian", "describe", "notes", "RANK_RTOL",
           "VISIBLE_RTOL"]
