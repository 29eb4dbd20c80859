r"""Choosing the retained (measured) dofs.

* :func:`mass_fraction` — the share of the structure's mass that the retained dofs carry.  Guyan
  reduction assumes no inertia at the omitted dofs, so it is only as good as this fraction is
  large; on Tan's (1993) truss the retained dofs carried about 5 % of the mass and Guyan failed.
* :func:`effective_independence` — Kammer's (1991) effective-independence sensor placement: from
  a candidate set, remove one at a time the dof that contributes least to the linear independence
  of the target modes (smallest diagonal of the projector
  :math:`E = \Phi_s (\Phi_s^T \Phi_s)^{-1} \Phi_s^T`), which keeps the Fisher information
  :math:`\det(\Phi_s^T \Phi_s)` as large as possible.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from .._errors import InputError, NumericalError
from ..dofs import canonical_all, parse_dof

TRANSLATIONS = ("x", "y", "z")


def _translational(labels: Sequence[str]) -> np.ndarray:
    return np.array([parse_dof(d)[1] in TRANSLATIONS for d in labels], dtype=bool)


def mass_fraction(model, keep: Sequence[str], values=None) -> float:
    r"""Fraction of the translational mass carried by the retained dofs.

    :math:`\sum_{i \in a} m_{ii} / \sum_i m_{ii}` over translational dofs (x, y, z); rotational
    inertias have other units and are left out (if the model has no translational dof, all dofs
    count).  With a lumped mass matrix this is exactly the retained share of the mass; with a
    consistent one it is the share of its diagonal.

    Parameters
    ----------
    model : Model
        The model.
    keep : sequence of str
        Retained dof labels.
    values : None, mapping of str to float, or array_like, optional
        Parameter values of M (default nominal).

    Returns
    -------
    float
        The fraction, in [0, 1] for a mass matrix with a non-negative diagonal.

    Raises
    ------
    InputError
        Unknown dof labels, or no mass on the counted dofs.
    """
    keep = canonical_all(keep, "keep")
    ia = model.dof_index(keep, "keep")
    d = model.M(values).diagonal()
    trans = _translational(model.dofs)
    if not trans.any():
        trans[:] = True
    sel = np.zeros(model.n_dofs, dtype=bool)
    sel[ia] = True
    total = float(d[trans].sum())
    if total <= 0:
        raise InputError("mass_fraction: the model has no mass on its translational dofs")
    return float(d[sel & trans].sum() / total)


@dataclass(frozen=True, eq=False)
class EfiResult:
    """Result of :func:`effective_independence`.

    ``selected`` the chosen dofs (in candidate order); ``removed`` the dofs in the order they were
    dropped (least informative first); ``determinant`` the Fisher determinant
    :math:`\\det(\\Phi_s^T\\Phi_s)` after each removal (relative to the full candidate set);
    ``efi`` the final effective-independence value of each selected dof.

    Parameters
    ----------
    selected : tuple of str
        The ``n_sensors`` chosen dofs, in candidate order.
    removed : tuple of str
        The dropped dofs, least informative first.
    determinant : numpy.ndarray, shape ``(len(removed),)``
        det(Φ_sᵀΦ_s) after each removal, relative to the full candidate set.
    efi : numpy.ndarray, shape ``(n_sensors,)``
        Effective independence E_i of each selected dof (in [0, 1]).
    n_modes : int
        Number of target modes.
    """

    selected: tuple[str, ...]
    removed: tuple[str, ...]
    determinant: np.ndarray
    efi: np.ndarray
    n_modes: int


def effective_independence(model, n_sensors: int, n_modes: int, candidates: Sequence[str] | None = None,
                           values=None, shapes: np.ndarray | None = None) -> EfiResult:
    r"""Kammer's effective-independence sensor placement.

    Parameters
    ----------
    model : Model
    n_sensors : int
        Dofs to select, ``n_modes <= n_sensors <= len(candidates)``.
    n_modes : int
        Target modes (the model's lowest, or the columns of ``shapes``).
    candidates : sequence of str, optional
        Candidate dofs (default: every translational dof of the model).
    values : None, mapping of str to float, or array_like, optional
        Parameter values (default nominal).
    shapes : ndarray (len(candidates), n_modes), optional
        Target mode shapes at the candidates (default: the model's lowest ``n_modes`` modes).

    Returns
    -------
    EfiResult

    Raises
    ------
    InputError
        Unknown or repeated candidates, ``n_modes < 1``, ``n_sensors`` outside
        ``[n_modes, len(candidates)]``, ``shapes`` of the wrong shape, or a singular Fisher
        information (the candidates cannot tell the modes apart).
    NumericalError
        Every remaining candidate is essential (E = 1) before ``n_sensors`` is reached.
    """
    from ..modal import model_modes

    if candidates is None:
        candidates = [d for d, t in zip(model.dofs, _translational(model.dofs)) if t] or list(model.dofs)
    cand = canonical_all(candidates, "candidates")
    idx = model.dof_index(cand, "candidates")
    n_modes, n_sensors = int(n_modes), int(n_sensors)
    if n_modes < 1:
        raise InputError(f"effective_independence: n_modes must be at least 1, got {n_modes}")
    if not n_modes <= n_sensors <= len(cand):
        raise InputError(f"effective_independence: n_sensors must lie between n_modes ({n_modes}) and the "
                         f"{len(cand)} candidates, got {n_sensors}")
    if shapes is None:
        phi = model_modes(model, values, n_modes=min(model.n_dofs, n_modes)).shapes[idx, :n_modes]
    else:
        phi = np.asarray(shapes, dtype=float)
        if phi.shape != (len(cand), n_modes):
            raise InputError(f"effective_independence: shapes must have shape ({len(cand)}, {n_modes}), got {phi.shape}")
    phi = phi / np.linalg.norm(phi, axis=0)
    active = np.ones(len(cand), dtype=bool)
    A = phi.T @ phi
    s = np.linalg.svd(A, compute_uv=False)
    if s[-1] <= 1e-12 * s[0]:
        raise InputError("effective_independence: the candidate dofs cannot tell the target modes apart "
                         "(Fisher information singular); add candidates or use fewer modes")
    det0 = np.linalg.slogdet(A)[1]
    Ainv = np.linalg.inv(A)
    removed, dets = [], []
    for _ in range(len(cand) - n_sensors):
        P = phi[active]
        E = np.einsum("ij,jk,ik->i", P, Ainv, P)
        k_local = int(np.argmin(E))
        k = np.flatnonzero(active)[k_local]
        if E[k_local] >= 1.0 - 1e-12:
            raise NumericalError("effective_independence: every remaining candidate is essential (E = 1)")
        v = Ainv @ phi[k]
        Ainv = Ainv + np.outer(v, v) / (1.0 - phi[k] @ v)  # Sherman-Morrison: remove row k
        active[k] = False
        removed.append(cand[k])
        A = phi[active].T @ phi[active]
        dets.append(np.exp(np.linalg.slogdet(A)[1] - det0))
    P = phi[active]
    E = np.einsum("ij,jk,ik->i", P, Ainv, P)
    return EfiResult(tuple(c for c, a in zip(cand, active) if a), tuple(removed), np.array(dets), E, n_modes)
