r"""The projection of an affine model on a reduction transformation.

:class:`Transformation` holds :math:`x = T x_a` (eq. 36) with its dof labels; :func:`reduce`
projects every affine term of a model, :math:`T^T K_j T` and :math:`T^T M_j T`, with the one
primitive :func:`project`; :func:`reduced_matrices`, :func:`reduced_modes` and
:func:`reduced_eigenvalues` give the reduced pencil and its eigenpairs at the values ``T`` was
built at.  The builders of ``T`` are in :mod:`femupdate.reduction.transforms`.
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from dataclasses import dataclass, field, replace

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp

from .._checks import array_arg, model_arg, str_arg, strings_arg
from .._errors import InputError
from ..dofs import canonical_all, parse_dof
from ..model import Model

__all__ = ["Transformation", "project", "reduce", "reduced_matrices", "reduced_modes", "reduced_eigenvalues"]


@dataclass(frozen=True, eq=False)
class Transformation:
    """A reduction transformation :math:`x = T x_a` (eq. 36) with its dof labels.

    Each parameter is stored as the attribute of the same name.

    Parameters
    ----------
    T : ndarray (n, a)
        Rows follow ``dofs`` (all model dofs), columns follow ``keep``.
    dofs : tuple of str
        The full model's dofs.
    keep : tuple of str
        The retained dofs, in the order of the reduced model.
    method : str
        ``"guyan"``, ``"irs"``, ``"modal"``, ``"hybrid"``, ``"serep"`` or ``"given"``.
    values : ndarray
        Parameter values at which ``T`` was built: the reduced model is exact only there.
    n_modes : int or None
        Number of full-model modes used (modal, hybrid, SEREP).
    """

    T: np.ndarray
    dofs: tuple[str, ...]
    keep: tuple[str, ...]
    method: str
    values: np.ndarray = field(default_factory=lambda: np.zeros(0))
    n_modes: int | None = None

    @property
    def keep_index(self) -> np.ndarray:
        """Positions of the retained dofs among ``dofs``, shape ``(a,)``."""
        pos = {d: i for i, d in enumerate(self.dofs)}
        return np.array([pos[d] for d in self.keep], dtype=np.intp)

    def expand(self, x_a: np.ndarray) -> np.ndarray:
        """Full-dof vectors from retained-dof vectors, ``T @ x_a`` ((a,) or (a, k)).

        Parameters
        ----------
        x_a : numpy.ndarray, shape ``(a,)`` or ``(a, k)``
            Values at the retained dofs, in the order of ``keep``.

        Returns
        -------
        numpy.ndarray, shape ``(n_dofs,)`` or ``(n_dofs, k)``
        """
        return self.T @ x_a


# ---------------------------------------------------------------------------------- projection
def project(A, T: np.ndarray) -> np.ndarray:
    r"""Dense symmetric :math:`T^T A T` for sparse symmetric ``A`` (n, n) and dense ``T`` (n, a).

    Only the rows of ``T`` where ``A`` has entries take part, so a parameter matrix that
    touches a few elements costs O(its size * a^2), not O(n a^2).

    Parameters
    ----------
    A : array_like or sparse matrix, shape ``(n, n)``
        Symmetric matrix.
    T : numpy.ndarray, shape ``(n, a)``
        Transformation.

    Returns
    -------
    numpy.ndarray, shape ``(a, a)``
        Tᵀ A T, symmetrised.
    """
    A = sp.csr_array(A)
    a = T.shape[1]
    if A.nnz == 0:
        return np.zeros((a, a))
    rows = np.unique(A.indices)
    if rows.size < 0.5 * A.shape[0]:
        Tr = T[rows]
        out = Tr.T @ (A[rows][:, rows] @ Tr)
    else:
        out = T.T @ (A @ T)
    return 0.5 * (out + out.T)


def reduce(model: Model, T, keep: Sequence[str] | None = None, name: str | None = None) -> Model:
    r"""Reduced affine model :math:`K_r(p) = T^T K_0 T + \sum_j p_j T^T K_j T` (likewise M).

    Parameters
    ----------
    model : Model
        The full model, on the rows of ``T``.
    T : Transformation or array (n, a)
        The transformation; a plain array needs ``keep`` (labels of its columns).
    keep : sequence of str, optional
        Dof labels of the reduced model (default ``T.keep``).
    name : str, optional
        Name of the reduced model (default ``"<model name> (<method>, <a> dofs)"``).

    Returns
    -------
    Model
        Dofs ``keep``; the same parameters (names, values, bounds, fixed flags).  With a fixed
        ``T`` the reduced model is affine in the parameters; it is the exact reduction only at the
        values ``T`` was built at (Guyan/IRS/modal/hybrid/SEREP build ``T`` from K(p), M(p) or the
        modes).  A parameter whose reduced matrices vanish is dropped with a warning.  A non-linear
        model's terms are projected term by term (:math:`T^T K_k T`, same coefficients f_k(p)).
    """
    model_arg(model, "model", "reduce")
    if not (isinstance(T, Transformation) or sp.issparse(T)):
        array_arg(T, "T", "reduce", ndim=2)
    strings_arg(keep, "keep", "reduce", what="dof label")
    str_arg(name, "name", "reduce", optional=True)
    method = "given"
    if isinstance(T, Transformation):
        if tuple(T.dofs) != tuple(model.dofs):
            raise InputError("reduce: the transformation was built on a model with other dofs")
        method = T.method
        keep = T.keep if keep is None else keep
        Tm = T.T
    else:
        Tm = T.toarray() if sp.issparse(T) else np.asarray(T, dtype=float)
        if keep is None:
            raise InputError("reduce: give the labels of the reduced dofs (keep=...) with a plain matrix T")
    keep = canonical_all(keep, "reduced dofs")
    if Tm.ndim != 2 or Tm.shape != (model.n_dofs, len(keep)):
        raise InputError(f"reduce: T must have shape ({model.n_dofs}, {len(keep)}) (model dofs x kept dofs), got {Tm.shape}")
    if not np.all(np.isfinite(Tm)):
        raise InputError("reduce: T contains NaN or infinite entries")
    K0 = project(model.K0, Tm)
    M0 = project(model.M0, Tm)
    params, dK, dM, dropped = [], [], [], []
    t2 = float(np.max(np.sum(Tm * Tm, axis=1))) if Tm.size else 0.0

    def vanishes(P, A):  # reduced term negligible against the term itself (round-off of a zero)
        return P is None or np.max(np.abs(P), initial=0.0) <= 1e-12 * np.max(np.abs(A.data), initial=0.0) * max(t2, 1.0)

    for j, par in enumerate(model.parameters):
        k = project(model.dK[j], Tm) if model.dK[j] is not None else None
        m = project(model.dM[j], Tm) if model.dM[j] is not None else None
        in_terms = any(par.name in t.parameters for t in model.terms)
        if vanishes(k, model.dK[j]) and vanishes(m, model.dM[j]) and not in_terms:
            dropped.append(par.name)
            continue
        params.append(par)
        dK.append(k)
        dM.append(m)
    if dropped:
        warnings.warn(f"reduce: parameter(s) {', '.join(dropped)} do not enter the reduced model and are dropped",
                      stacklevel=2)
    nodes_kept = {parse_dof(d)[0] for d in keep}
    return Model(
        dofs=tuple(keep), K0=_clean(K0), M0=_clean(M0), parameters=tuple(params),
        dK=tuple(_clean(k) if k is not None else None for k in dK),
        dM=tuple(_clean(m) if m is not None else None for m in dM),
        name=name or f"{model.name} ({method}, {len(keep)} dofs)",
        nodes={k: v for k, v in model.nodes.items() if k in nodes_kept},
        terms=tuple(replace(t, K=None if t.K is None else _clean(project(t.K, Tm)),
                            M=None if t.M is None else _clean(project(t.M, Tm))) for t in model.terms),
    )


def _clean(A: np.ndarray) -> sp.csr_array:
    """Drop round-off entries (below 1e-14 of the largest) so that structural zeros stay zero."""
    scale = np.max(np.abs(A)) if A.size else 0.0
    A = np.where(np.abs(A) > 1e-14 * scale, A, 0.0)
    return sp.csr_array(A)

def reduced_matrices(model: Model, t: Transformation) -> tuple[np.ndarray, np.ndarray]:
    """Dense reduced ``(K_r, M_r)`` at the values ``t`` was built at.

    Parameters
    ----------
    model : Model
        The full model ``t`` was built on.
    t : Transformation
        The transformation (its ``values`` are used).

    Returns
    -------
    K_r, M_r : numpy.ndarray, shape ``(a, a)``
        Tᵀ K(p) T and Tᵀ M(p) T.
    """
    return project(model.K(t.values), t.T), project(model.M(t.values), t.T)


def reduced_modes(K_r: np.ndarray, M_r: np.ndarray, rtol: float = 1e-10) -> tuple[np.ndarray, np.ndarray]:
    r"""Eigenpairs of a (dense) reduced pencil, ascending, mass-normalised.

    A rank-deficient ``M_r`` (SEREP with fewer modes than retained dofs) gives only the
    eigenpairs on the range of ``M_r``: ``rank(M_r)`` of them.

    Parameters
    ----------
    K_r, M_r : numpy.ndarray, shape ``(a, a)``
        Reduced stiffness and mass matrices (symmetrised here).
    rtol : float, default 1e-10
        Eigenvalues of ``M_r`` below ``rtol`` times its largest count as zero (rank test).

    Returns
    -------
    lam : numpy.ndarray, shape ``(r,)``
        Eigenvalues, rad²/s², ascending (those within 1e-12 of the largest magnitude set to 0);
        r = a, or rank(M_r) when M_r is singular.
    V : numpy.ndarray, shape ``(a, r)``
        Mass-normalised eigenvectors on the retained dofs.

    Raises
    ------
    InputError
        The reduced mass matrix is zero.
    """
    K_r = 0.5 * (K_r + K_r.T)
    M_r = 0.5 * (M_r + M_r.T)
    w, U = np.linalg.eigh(M_r)
    if w.size == 0 or w.max() <= 0:
        raise InputError("the reduced mass matrix is zero")
    keep = w > rtol * float(w.max())
    if keep.all():
        lam, V = sla.eigh(K_r, M_r)
    else:
        U = U[:, keep]
        lam, Y = sla.eigh(U.T @ K_r @ U, U.T @ M_r @ U)
        V = U @ Y
    scale = max(float(np.max(np.abs(lam))), 1e-300)
    lam = np.where(np.abs(lam) <= 1e-12 * scale, 0.0, lam)
    return lam, V


def reduced_eigenvalues(K_r: np.ndarray, M_r: np.ndarray, rtol: float = 1e-10) -> np.ndarray:
    """Eigenvalues of a reduced pencil (see :func:`reduced_modes`).

    Parameters
    ----------
    K_r, M_r : numpy.ndarray, shape ``(a, a)``
        Reduced matrices.
    rtol : float, default 1e-10
        Rank tolerance on ``M_r``.

    Returns
    -------
    numpy.ndarray, shape ``(r,)``
        Eigenvalues, rad²/s², ascending.

    Raises
    ------
    InputError
        The reduced mass matrix is zero.
    """
    return reduced_modes(K_r, M_r, rtol)[0]
