"""Shared pieces of the eigen-sensitivity routines.

Conventions (every routine): ``modes`` are mass-normalised (φᵀMφ = 1) modes of ``model`` at
parameter values ``values``; ``which`` indexes the modes to differentiate; ``params`` indexes
model parameters (default: the free ones).  With K' = ∂K/∂p_j and M' = ∂M/∂p_j,

    λ' = φᵀ(K' − λM')φ                                  (Fox & Kapoor 1968; paper eq. 21)
    (K − λM) φ' = f,   f = −(K' − λM')φ + λ' M φ
    φᵀ M φ' = −½ φᵀ M' φ                                 (mass normalisation kept)
"""

from __future__ import annotations

import weakref
from collections.abc import Sequence

import numpy as np
import scipy.sparse as sp

from .. import rules
from .._errors import InputError, NumericalError

REPEATED_TOL = rules.REPEATED_TOL  # relative eigenvalue gap below which modes count as repeated


def tangent(model, values=None, modes=None):
    """The model to differentiate: ``model`` itself when affine; for a non-linear one its
    tangent affine model at ``values`` (:meth:`Model.linearised <femupdate.Model.linearised>`),
    exact there to first order, so every route's formulas hold unchanged.  Without ``values`` the
    values ``modes`` were computed at (their context), else the nominal ones."""
    if getattr(model, "is_affine", True):
        return model
    if values is None and modes is not None:
        ctx = getattr(modes, "context", None)
        if ctx is not None and getattr(ctx, "model", None) is model and getattr(ctx, "before", None):
            values = dict(ctx.before)
    return model.linearised(values)


def resolve_params(model, params) -> np.ndarray:
    if params is None:
        return np.asarray(model.free, dtype=np.intp)
    listed = []
    for p in params:
        listed.append(model.parameter_index(p) if isinstance(p, str) else int(p))
    out = np.asarray(listed, dtype=np.intp)
    if out.size and (out.min() < 0 or out.max() >= len(model.parameters)):
        raise InputError(f"parameter index out of range 0..{len(model.parameters) - 1}")
    return out


def resolve_which(modes, which) -> np.ndarray:
    idx = np.arange(modes.n_modes) if which is None else np.atleast_1d(np.asarray(which, dtype=np.intp))
    if idx.size and (idx.min() < 0 or idx.max() >= modes.n_modes):
        raise InputError(f"mode index out of range 0..{modes.n_modes - 1}")
    return idx


def check_distinct(modes, which: Sequence[int], mass_normalised: bool = True, groups=None) -> None:
    """Refuse derivatives of rigid-body or repeated modes (they are not differentiable as such;
    :func:`femupdate.rules.check_distinct`); a mode of one of ``groups`` (:func:`resolve_groups`)
    may repeat the others of its group, not a mode outside it."""
    if mass_normalised and modes.normalisation != "mass":
        raise InputError(f"sensitivities need mass-normalised modes, got {modes.normalisation!r} (use model_modes(..., normalisation='mass'))")
    lam = np.asarray(modes.eigenvalues, float)
    groups = groups or {}
    for i in which:
        i = int(i)
        code, j = rules.check_distinct(lam, lam.size, i)
        if code == rules.E_REPEATED and i in groups:  # repeated inside its group: fine, outside: not
            a, b = groups[i]
            tol = rules.REPEATED_TOL * max(abs(lam[i]), 1e-12 * np.abs(lam).max())
            outside = [j for j in range(lam.size) if not a <= j < b and abs(lam[j] - lam[i]) <= tol]
            code, j = (rules.E_REPEATED, outside[0]) if outside else (rules.OK, i)
        if code != rules.OK:
            raise NumericalError(rules.message(code, i, j, lam[i], lam[j]))


def resolve_request(model, modes, which, params, groups) -> tuple[np.ndarray, np.ndarray, dict[int, tuple[int, int]]]:
    """The modes and parameters of a derivative request and the groups of those modes, checked:
    :func:`resolve_which`, :func:`resolve_params`, :func:`resolve_groups` and
    :func:`check_distinct`, in that order (the routes' shared door)."""
    which = resolve_which(modes, which)
    params = resolve_params(model, params)
    grouped = resolve_groups(modes, which, groups)
    check_distinct(modes, which, groups=grouped)
    return which, params, grouped


def resolve_groups(modes, which: np.ndarray, groups) -> dict[int, tuple[int, int]]:
    """The group of each mode of ``which`` that belongs to one of ``groups`` (modes alone are left out).

    Parameters
    ----------
    modes : Modes
        The computed modes.
    which : numpy.ndarray of int
        The modes to differentiate.
    groups : sequence of (int, int), or None
        Groups of close or repeated modes as ``(first, stop)``: modes ``first .. stop - 1`` of
        ``modes``, at least two, groups not overlapping (e.g. :func:`~femupdate.close_modes.mode_groups`).

    Returns
    -------
    dict of int to (int, int)
        ``{mode: (first, stop)}`` for every mode of ``which`` in a group.

    Raises
    ------
    InputError
        A group that is not a pair of indices ``0 <= first < stop <= n_modes`` with
        ``stop - first >= 2``, or groups that overlap.
    """
    out: dict[int, tuple[int, int]] = {}
    if groups is None:
        return out
    taken = np.zeros(modes.n_modes, bool)
    for g in groups:
        try:
            a, b = (int(v) for v in g)
        except (TypeError, ValueError):
            raise InputError(f"groups: give each group as (first, stop) mode indices, got {g!r}") from None
        if not (0 <= a and b <= modes.n_modes and b - a >= 2):
            raise InputError(f"groups: ({a}, {b}) is not a group of at least two of the {modes.n_modes} modes "
                             "(first, stop: modes first .. stop - 1)")
        if taken[a:b].any():
            raise InputError(f"groups: ({a}, {b}) overlaps another group")
        taken[a:b] = True
        for i in which:
            if a <= int(i) < b:
                out[int(i)] = (a, b)
    return out


class ParameterProducts:
    r"""All-parameter products K_j φ and M_j φ as sparse (n, L) matrices, for one parameter set.

    From the model's union pattern (:attr:`Model._pattern`: ``K.data = B @ [1, p]``, one row of
    ``B`` per stored entry e of K), column j of K_j φ is

    .. math:: (K_j \phi)_r = \sum_{e \in \mathrm{row}\ r} B_{e, j} \, \phi_{\mathrm{col}(e)},

    i.e. ``R @ (diag(φ[col]) @ B)`` with R the row-incidence matrix of the pattern.  The
    pattern of the product does not depend on φ, so it is found once here; each call is then a
    single ``bincount`` over the nonzeros of ``B`` (no Python loop over parameters).  The terms
    of each entry are summed in the same order as ``dK[j] @ φ``, so the results are identical
    to the per-parameter products.
    """

    def __init__(self, model, params: np.ndarray):
        self.n = model.n_dofs
        self.params = np.asarray(params, dtype=np.intp)
        self._maps = {key: self._build(model, key) for key in ("K", "M")}

    def _build(self, model, key: str):
        n, L = self.n, self.params.size
        union, B = model._pattern[key]
        Bsel = sp.csr_array(sp.csc_array(B)[:, self.params + 1])  # (nnz_union, L), rows by entry
        Bsel.sort_indices()
        entry = np.repeat(np.arange(Bsel.shape[0], dtype=np.int64), np.diff(Bsel.indptr))
        urow = np.repeat(np.arange(n, dtype=np.int64), np.diff(union.indptr))
        rows, cols = urow[entry], Bsel.indices.astype(np.int64)
        keys = rows * max(L, 1) + cols
        # bincount adds the terms of each (row, parameter) slot in the order of B's entries,
        # i.e. in column order within the row: the order of dK[j] @ phi (identical results)
        uniq, target = np.unique(keys, return_inverse=True)
        indptr = np.searchsorted(uniq // max(L, 1), np.arange(n + 1)).astype(np.int64)
        return {
            "phi_index": union.indices[entry].astype(np.intp), "weights": Bsel.data,
            "target": target.ravel(), "indices": (uniq % max(L, 1)).astype(np.int64), "indptr": indptr,
        }

    def sparse(self, phi: np.ndarray) -> tuple[sp.csr_array, sp.csr_array]:
        """``(K_j φ)_j`` and ``(M_j φ)_j`` as sparse (n, L) matrices (column c is parameter params[c])."""
        return tuple(self._product(self._maps[key], phi) for key in ("K", "M"))

    def dense(self, phi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The same as dense (n, L) arrays."""
        return tuple(A.toarray() for A in self.sparse(phi))

    def _product(self, mp, phi):
        data = np.bincount(mp["target"], weights=mp["weights"] * phi[mp["phi_index"]], minlength=mp["indices"].size)
        return sp.csr_array((data, mp["indices"], mp["indptr"]), shape=(self.n, self.params.size))


_PRODUCTS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def parameter_products(model, params) -> ParameterProducts:
    """The (cached) :class:`ParameterProducts` of ``model`` for the parameter indices ``params``."""
    params = np.asarray(params, dtype=np.intp)
    cache = _PRODUCTS.setdefault(model, {})
    key = params.tobytes()
    if key not in cache:
        if len(cache) >= 8:  # a few parameter sets per model are plenty
            cache.pop(next(iter(cache)))
        cache[key] = ParameterProducts(model, params)
    return cache[key]


def param_products(model, params: np.ndarray, phi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Columns K_j φ and M_j φ for the given parameters, shape (n, L) each (dense).

    Built for all parameters at once by :class:`ParameterProducts`; identical to
    ``dK[j] @ φ`` column by column (zero where parameter j does not enter the matrix).
    """
    return parameter_products(model, params).dense(np.asarray(phi, dtype=float))


def mode_rhs(model, params, lam: float, phi: np.ndarray, Mphi: np.ndarray):
    """Eigenvalue derivatives (L,), right-hand sides f (n, L) and φᵀM'φ (L,) of one mode."""
    Kp, Mp = param_products(model, params, phi)
    mjj = phi @ Mp
    dlam = phi @ Kp - lam * mjj
    F = -(Kp - lam * Mp) + np.outer(Mphi, dlam)
    return dlam, F, mjj


def group_rhs(model, params, lam: float, phi: np.ndarray, Mphi: np.ndarray, Phi_g: np.ndarray):
    """:func:`mode_rhs` of a mode of a group, with the products N = Φ_gᵀ M_j φ (r, L) of the group's
    modes ``Phi_g`` (n, r) that set the in-group part of the derivative of the group's basis
    (:mod:`femupdate.sensitivity.repeated`)."""
    Kp, Mp = param_products(model, params, phi)
    mjj = phi @ Mp
    dlam = phi @ Kp - lam * mjj
    F = -(Kp - lam * Mp) + np.outer(Mphi, dlam)
    return dlam, F, mjj, Phi_g.T @ Mp


def in_group(coef: np.ndarray, i: int, group: tuple[int, int] | None, Ng: np.ndarray | None) -> np.ndarray:
    """Set the in-group modal coefficients of mode i's derivative (rows of ``coef``, (m, L)) to
    those of the group's basis with no rotation inside the group, −½ φ_rᵀ M_j φ_i for every other
    mode r of the group (:mod:`femupdate.sensitivity.repeated`); unchanged for a mode alone."""
    if group is not None and Ng is not None:
        a, b = group
        for r in range(a, b):
            if r != i:
                coef[r] = -0.5 * Ng[r - a]
    return coef


def as_dense(A):
    return A.toarray() if sp.issparse(A) else np.asarray(A)
