r"""Pre-reduction criteria for a keep-set: Gordis (1992) and Larsson & Sas (1992).

Both rest on the eigenvalues of the *omitted* partition, :math:`\det(K_{oo} - \lambda M_{oo}) = 0`,
i.e. of the structure with every retained dof grounded (the paper: "the omitted eigenvalues are
found from the system :math:`M_{oo}^{-1}K_{oo}`").

* **Gordis**: IRS (and Guyan) are accurate and robust when the eigenvalues of the retained
  (reduced) system do not overlap those of the omitted partition.  IRS is the first term of the
  series :math:`x_o = \sum_k (\lambda K_{oo}^{-1} M_{oo})^k \ldots`, which converges only for
  :math:`\lambda < \lambda_{o,1}`; every reduced eigenvalue at or above :math:`\lambda_{o,1}`
  is an overlap.
* **Larsson & Sas**: the useful frequency range of the reduced model (of measured FRFs used with
  it) ends at the lowest grounded eigenvalue :math:`\lambda_{o,1}`.

Retaining the dofs that carry most of the mass pushes :math:`\lambda_{o,1}` up, which is why both
criteria favour mass-carrying retained sets (and why Guyan failed on Tan's truss).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field

import numpy as np
import scipy.linalg as sla
import scipy.sparse.linalg as spla

from .._errors import NumericalError
from ..modal import arpack_options
from .projection import reduced_eigenvalues
from .reducer import Reducer

DENSE_LIMIT = 300


class ReductionCriteriaWarning(UserWarning):
    """A keep-set violates Gordis's or Larsson & Sas's criterion."""


@dataclass(frozen=True, eq=False)
class ReductionCriteria:
    """Gordis and Larsson & Sas figures of one keep-set (built by :func:`reduction_criteria`).

    Each parameter is stored as the attribute of the same name.

    Parameters
    ----------
    keep : tuple of str
    retained_eigenvalues : ndarray (a,)
        Eigenvalues of the Guyan-reduced model (rad^2/s^2), ascending.
    omitted_eigenvalues : ndarray (k,)
        Lowest eigenvalues of the omitted partition (retained dofs grounded); ``inf`` where the
        omitted dofs carry no mass.
    grounded_frequency_hz : float
        Larsson & Sas's bound :math:`\\sqrt{\\lambda_{o,1}}/2\\pi`.
    overlap : int
        Gordis: number of retained eigenvalues at or above :math:`\\lambda_{o,1}`.
    ratio : float
        :math:`\\lambda_{r,\\max} / \\lambda_{o,1}` over the modes of interest (< 1 is required;
        the smaller the better).
    n_interest : int
        Number of reduced modes of interest the ratio and warnings refer to.
    ok_gordis, ok_larsson_sas : bool
    messages : list of str
        The warnings issued (empty when both criteria hold).
    """

    keep: tuple[str, ...]
    retained_eigenvalues: np.ndarray
    omitted_eigenvalues: np.ndarray
    grounded_frequency_hz: float
    overlap: int
    ratio: float
    n_interest: int
    ok_gordis: bool
    ok_larsson_sas: bool
    messages: list[str] = field(default_factory=list)

    @property
    def retained_frequencies_hz(self) -> np.ndarray:
        """Frequencies of the Guyan-reduced model, Hz, shape ``(a,)``."""
        return np.sqrt(np.clip(self.retained_eigenvalues, 0, None)) / (2 * np.pi)


def omitted_eigenvalues(red: Reducer, k: int = 6) -> np.ndarray:
    """Lowest ``k`` eigenvalues of :math:`(K_{oo}, M_{oo})` reusing the reducer's factor of K_oo.

    Parameters
    ----------
    red : Reducer
        The partition (retained dofs grounded).
    k : int, default 6
        Number of eigenvalues (clipped to 1..number of omitted dofs).

    Returns
    -------
    numpy.ndarray, shape ``(k,)``
        Eigenvalues, rad²/s², ascending; ``inf`` where the omitted dofs carry no mass (dense
        path); ``[inf]`` when nothing is omitted.

    Raises
    ------
    InputError
        A singular omitted partition (named mechanism).
    NumericalError
        The sparse eigensolver failed.
    """
    o = red.io.size
    if o == 0:
        return np.full(1, np.inf)
    lu = red.lu  # also refuses a singular K_oo, naming the mechanism
    k = max(1, min(int(k), o))
    if o <= DENSE_LIMIT or k >= o - 1:
        mu = sla.eigh(red.M_oo.toarray(), red.K_oo.toarray(), eigvals_only=True)  # mu = 1 / lambda
    else:
        op = spla.LinearOperator(red.K_oo.shape, matvec=lu.solve, dtype=float)
        try:
            lam = spla.eigsh(red.K_oo, k=k, M=red.M_oo, sigma=0.0, which="LM", OPinv=op, return_eigenvectors=False,
                             **arpack_options())
        except (spla.ArpackNoConvergence, RuntimeError) as exc:
            raise NumericalError(f"eigenvalues of the omitted partition: the sparse eigensolver failed ({exc})") from None
        return np.sort(lam)
    scale = max(float(np.max(np.abs(mu))), 1e-300)
    with np.errstate(divide="ignore"):
        lam = np.where(mu > 1e-13 * scale, 1.0 / np.where(mu > 0, mu, 1.0), np.inf)
    return np.sort(lam)[:k]


def reduction_criteria(model, keep, values=None, n_interest: int | None = None, f_max_hz: float | None = None,
                       k_omitted: int = 6, warn: bool = True, reducer: Reducer | None = None) -> ReductionCriteria:
    r"""Gordis's overlap and Larsson & Sas's grounded bound for the keep-set ``keep``.

    Parameters
    ----------
    model, keep, values :
        As for :class:`~femupdate.reduction.Reducer` (or pass ``reducer`` to reuse its factor).
    n_interest : int, optional
        Number of reduced modes of interest (default: all ``a``).
    f_max_hz : float, optional
        Upper end of the frequency band of interest; warned about when it exceeds Larsson & Sas's
        bound.
    k_omitted : int
        How many omitted eigenvalues to compute.
    warn : bool
        Issue :class:`ReductionCriteriaWarning` for each violated criterion.
    reducer : Reducer, optional
        Reuse this partition (and its factor) instead of building one from ``model``, ``keep``,
        ``values``.

    Returns
    -------
    ReductionCriteria

    Raises
    ------
    InputError, NumericalError
        As :class:`Reducer` and :func:`omitted_eigenvalues`.
    """
    red = reducer if reducer is not None else Reducer(model, keep, values)
    lam_o = omitted_eigenvalues(red, k_omitted)
    Kg, Mg = red.guyan_matrices
    lam_r = reduced_eigenvalues(Kg, Mg)
    a = lam_r.size
    n_int = a if n_interest is None else max(1, min(int(n_interest), a))
    lo1 = float(lam_o[0])
    overlap = int(np.sum(lam_r[:n_int] >= lo1))
    ratio = float(lam_r[n_int - 1] / lo1) if np.isfinite(lo1) and lo1 > 0 else 0.0
    f_ground = float(np.sqrt(lo1) / (2 * np.pi)) if np.isfinite(lo1) else float("inf")
    msgs = []
    if overlap:
        msgs.append(f"Gordis: {overlap} of the {n_int} reduced eigenvalue(s) of interest lie at or above the lowest "
                    f"eigenvalue of the omitted partition ({lo1:.4g} rad²/s², {f_ground:.4g} Hz): Guyan/IRS will be "
                    "inaccurate there; retain dofs that carry more of the mass")
    f_top = float(f_max_hz) if f_max_hz is not None else float(np.sqrt(max(lam_r[n_int - 1], 0.0)) / (2 * np.pi))
    ok_ls = f_top < f_ground
    if not ok_ls:
        msgs.append(f"Larsson & Sas: the band of interest (to {f_top:.4g} Hz) reaches beyond {f_ground:.4g} Hz, the "
                    "lowest natural frequency with every retained dof grounded")
    if warn:
        for m in msgs:
            warnings.warn(m, ReductionCriteriaWarning, stacklevel=2)
    return ReductionCriteria(red.keep, lam_r, lam_o, f_ground, overlap, ratio, n_int, overlap == 0, ok_ls, msgs)
