r"""Repeated and close modes in the modal updating problem: what a test mode is compared with when
its model mode belongs to a group.

Symmetric structures have repeated eigenvalues, nearly symmetric ones close eigenvalues.  Inside
such a group G (neighbouring model modes whose relative eigenvalue gap is at most
``close_modes``, :class:`~femupdate.options.ModalOptions`, default
:data:`femupdate.rules.CLOSE_TOL` = 0.01) the model's basis Φ_G is arbitrary (repeated) or turns
abruptly with the parameters (close), so neither a MAC with one of its modes nor the derivative of
one of its modes means anything.  The problem compares a test mode paired into a group with the
group as a whole:

* **Pairing** (:mod:`femupdate.close_modes`): the one pairing is given the MAC of the best
  combination of each group's shapes in the group's columns, and the test modes it puts in a group
  get the group's modes by their best combinations (``correlate`` pairs alike).
* **Residuals** (:func:`fit`): the model shape of test mode k is the combination v_k = Φ_G c_k
  that fits its measured shape best (least squares over its measured dofs: c_k = (Φ_G,s)⁺ ψ_k — a
  rotation of the group's basis chosen by the test, independent of the model's arbitrary basis
  and smooth in the parameters as long as the group stays apart from the other modes); its
  eigenvalue is that of the group's mode the pairing inside the group gave it: the eigenvalues
  are compared as a set, and where the modes are close but distinct the measured shapes say which
  frequency is whose.  On noise-free data both equal the test's exactly.  A test mode without a
  shape keeps the model mode the pairing gave it.
* **Jacobian** (:func:`fit_jacobian`): exact, from the derivative of the group's basis with no
  rotation inside the group (:mod:`femupdate.sensitivity.repeated`; every derivative route),
  through the derivative of the pseudo-inverse (Golub & Pereyra 1973); the eigenvalue's is Fox &
  Kapoor's, the diagonal of the restricted eigenproblem's derivative — for a repeated eigenvalue
  one of its directional derivatives (the eigenvalues of a repeated group are not differentiable,
  their set is only directionally: a cone, which Gauss–Newton steps cross).
* **Test shapes that cannot tell the group's modes apart** (sensors on a symmetry line, fewer
  measured dofs than modes in the group): the combination the measured dofs do not see is left
  out (the minimum-norm fit), and the result says that the group is not resolved
  (:data:`femupdate.close_modes.VISIBLE_RTOL`).

Modes alone (every mode of a model without repeated or close modes) are compared exactly as
before: nothing here runs.

**The threshold.**  Updating switches a pair from mode-by-mode to group comparison where its
relative gap crosses ``close_modes``; the residuals jump there (the best combination is not the
model's own mode), so the switch had better happen far from the solution.  Measured on two masses
in the plane whose pairs turn with the parameters (``tests/test_repeated_update.py``,
:func:`planar_masses`; 20 random starts, noise-free data, starts reaching the truth to 1e-6):

=================  =======  =======  =======  =======  =======  =======
gap at the truth   0 (off)     1e-6     1e-4     1e-3     1e-2     5e-2
=================  =======  =======  =======  =======  =======  =======
5e-2 (eps 0.1)          20       20       20       20       20       20
5e-3                    20       20       20       19       19       20
5e-4                    20       20       13       16       19       20
5e-5                    20       20        9       15       19       20
5e-6                    20       13        9       15       19       20
5e-7                    10        7        9       15       19       20
0 (repeated)             0        8       12       12       18       20
=================  =======  =======  =======  =======  =======  =======

and on square space frames (every pair repeated whatever the storey moduli, 20 starts): 0 of 20
with grouping off (every start abandoned as "repeated"), 19 and 20 of 20 at 0.01.  Mode by mode
(off) is as good as long as the gap at the truth stays above about 1e-5; below, and for repeated
modes, only a threshold well above the gaps near the truth works.  The default 0.01 groups modes
closer than 1 %, the usual meaning of "closely spaced"; 0.05 did better still on these problems
but groups modes that are well apart for a test.

References
----------
Golub, G.H., Pereyra, V. (1973) The differentiation of pseudo-inverses and nonlinear least squares
problems whose variables separate. SIAM J. Numer. Anal. 10(2), 413–432.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..close_modes import VISIBLE_RTOL, combination, pinv, visibility

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
    c, mac = combination(psi, Bs)
    return GroupFit(group, c, Bs @ c, float(lam_g[j - a]), mac, visibility(Bs), pinv(Bs)[1], j)


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
    P, _ = pinv(Bs)
    c = P @ psi
    res = psi - Bs @ c  # (I − B B⁺) ψ
    null = np.eye(Bs.shape[1]) - P @ Bs  # I − B⁺B
    dv = np.zeros((Bs.shape[0], dBs.shape[2]))
    for q in range(dBs.shape[2]):
        dB = dBs[:, :, q]
        dc = -P @ (dB @ c) + P @ (P.T @ (dB.T @ res)) + null @ (dB.T @ (P.T @ c))
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


__all__ = ["GroupFit", "fit", "fit_jacobian", "describe", "notes"]
