r"""The partition of a model into retained and omitted dofs, and the transformation builders.

:class:`Reducer` factorises :math:`K_{oo}` once and computes the model's modes once, and builds
every transformation of :mod:`femupdate.reduction.transforms` from them (Guyan, IRS, Kammer's
modal and hybrid TAMs, SEREP).  A singular :math:`K_{oo}` is refused naming the dofs of the
mechanism (:func:`mechanism_dofs`).
"""

from __future__ import annotations

from collections.abc import Sequence
from functools import cached_property

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from .._docs import shared_docs
from .._errors import InputError, NumericalError
from ..dofs import canonical_all, describe
from ..modal import Modes, NotPositiveDefinite, arpack_options, factorize, model_modes, nearly_singular
from ..model import Model
from .projection import Transformation, project

__all__ = ["METHODS", "DENSE_NULL_LIMIT", "Reducer", "mechanism_dofs"]

METHODS = ("guyan", "irs", "modal", "hybrid", "serep")
DENSE_NULL_LIMIT = 2000  # mechanism search: dense eigen-solution up to this many omitted dofs

# the modal builders' documentation, written once (femupdate._docs)
_N_MODES = r"""Parameters
----------
n_modes : int, optional
    Number m of the full model's lowest modes (default: as many as retained dofs);
    ``1 <= m <= len(keep)``.

Returns
-------
Transformation
    ``T`` of shape ``(n_dofs, len(keep))``, with ``n_modes`` = m."""
_DOCS = {"N_MODES": _N_MODES, "N_MODES_RAISES": _N_MODES + r"""

Raises
------
InputError
    m below 1 or above the number of retained dofs (or of model dofs), or retained dofs
    that do not tell the m modes apart (:math:`\phi_a` rank-deficient).
NumericalError
    The eigen-solution fails."""}


# ---------------------------------------------------------------------------------- partition
class Reducer:
    r"""The partition of one model into retained (``keep``) and omitted dofs, at fixed values.

    Factorises :math:`K_{oo}` once (sparse LU, symmetric ordering) and computes the model's
    modes once per number of modes; every builder method reuses them.

    Parameters
    ----------
    model : Model
    keep : sequence of str or str
        Retained dofs (labels, or one comma-separated string; their order is the reduced model's).
    values : mapping or array_like, optional
        Parameter values (default nominal).

    Raises
    ------
    InputError
        Unknown or repeated labels, more kept dofs than the model has, an empty keep-set, or
        (when a builder needs it) a singular omitted partition, named by the dofs that form the
        mechanism.
    """

    def __init__(self, model: Model, keep: Sequence[str], values=None):
        if isinstance(keep, str):
            keep = [k for k in keep.split(",") if k.strip()]
        keep = canonical_all(keep, "keep")
        if not keep:
            raise InputError("keep: no dofs to retain")
        if len(keep) > model.n_dofs:
            raise InputError(f"keep: {len(keep)} dofs to retain but the model has only {model.n_dofs}")
        self.model = model
        self.keep = keep
        self.ia = model.dof_index(keep, "keep")
        mask = np.ones(model.n_dofs, dtype=bool)
        mask[self.ia] = False
        self.io = np.flatnonzero(mask)
        self.values = model.resolve(values)
        self._modes: dict[int, Modes] = {}

    # -------------------------------------------------------------- matrices
    @cached_property
    def K(self) -> sp.csr_array:
        """Stiffness matrix at :attr:`values` (N/m), ``(n_dofs, n_dofs)``."""
        return sp.csr_array(self.model.K(self.values))

    @cached_property
    def M(self) -> sp.csr_array:
        """Mass matrix at :attr:`values` (kg), ``(n_dofs, n_dofs)``."""
        return sp.csr_array(self.model.M(self.values))

    @property
    def n_keep(self) -> int:
        """Number a of retained dofs."""
        return self.ia.size

    @property
    def omitted(self) -> tuple[str, ...]:
        """Labels of the omitted dofs, in model order."""
        return tuple(self.model.dofs[i] for i in self.io)

    def _block(self, A, rows, cols) -> sp.csr_array:
        return sp.csr_array(A[rows][:, cols])

    @cached_property
    def K_oo(self) -> sp.csc_array:
        return sp.csc_array(self._block(self.K, self.io, self.io))

    @cached_property
    def M_oo(self) -> sp.csc_array:
        return sp.csc_array(self._block(self.M, self.io, self.io))

    @cached_property
    def lu(self):
        """Sparse LU of K_oo (once); a singular K_oo is refused naming the mechanism's dofs."""
        if self.io.size == 0:
            return None
        try:
            lu = factorize(self.K_oo, definite=True)
            singular = nearly_singular(lu)
        except (RuntimeError, NotPositiveDefinite):  # SuperLU: "Factor is exactly singular"; CHOLMOD: not definite
            singular = True
        if singular:
            raise InputError(self._mechanism_message())
        return lu

    def solve_oo(self, B: np.ndarray) -> np.ndarray:
        """:math:`K_{oo}^{-1} B` with the one factorisation (B dense, (o, k)).

        Parameters
        ----------
        B : numpy.ndarray, shape ``(n_omitted, k)``
            Right-hand sides on the omitted dofs.

        Returns
        -------
        numpy.ndarray, shape ``(n_omitted, k)``

        Raises
        ------
        InputError
            K_oo is singular (the message names the mechanism's dofs).
        """
        return self.lu.solve(np.asfortranarray(B))

    def _mechanism_message(self) -> str:
        names, count = mechanism_dofs(self.K_oo, self.omitted)
        if names:
            return (f"the omitted partition K_oo is singular: once the kept dofs are removed, dof(s) "
                    f"{describe(names, 12)} form a mechanism ({count} zero-energy mode(s)); keep at least one of "
                    "them, or support the structure")
        return "the omitted partition K_oo is numerically singular (ill-conditioned); keep other dofs"

    # -------------------------------------------------------------- modes
    def modes(self, n_modes: int):
        """Lowest ``n_modes`` mass-normalised modes of the full model at :attr:`values` (cached).

        A request for fewer modes than an earlier one slices the cached solution.

        Parameters
        ----------
        n_modes : int
            Number of modes.

        Returns
        -------
        Modes

        Raises
        ------
        NumericalError
            The eigen-solution fails.
        """
        n_modes = int(n_modes)
        if n_modes not in self._modes:
            have = [m for m in self._modes if m >= n_modes]
            if have:
                full = self._modes[min(have)]
                from dataclasses import replace

                self._modes[n_modes] = replace(full, eigenvalues=full.eigenvalues[:n_modes], shapes=full.shapes[:, :n_modes])
            else:
                n = self.model.n_dofs
                method = "sparse" if n > 300 and n_modes < n // 4 else "auto"  # a few modes of a big model
                self._modes[n_modes] = model_modes(self.model, self.values, n_modes=n_modes, method=method)
        return self._modes[n_modes]

    def _n_modes(self, n_modes, method, default=None) -> int:
        a = self.n_keep
        m = (default if default is not None else a) if n_modes is None else int(n_modes)
        if m < 1:
            raise InputError(f"{method}: n_modes must be at least 1, got {m}")
        if m > a:
            raise InputError(
                f"{method}: {m} modes for {a} retained dofs: the retained partition of the mode shapes "
                f"(a x m = {a} x {m}) has no left inverse (eq. 43 needs phi_a^T phi_a invertible); "
                f"use at most {a} modes or retain more dofs")
        if m > self.model.n_dofs:
            raise InputError(f"{method}: {m} modes asked, but the model has {self.model.n_dofs} dofs")
        return m

    def _phi_a_pinv(self, phi_a: np.ndarray, method: str) -> np.ndarray:
        """Left inverse :math:`(\\phi_a^T \\phi_a)^{-1} \\phi_a^T` via the SVD; refuses rank deficiency."""
        U, s, Vt = np.linalg.svd(phi_a, full_matrices=False)
        if s.size == 0 or s[-1] <= 1e-8 * s[0]:
            rank = int(np.sum(s > 1e-8 * s[0])) if s.size else 0
            raise InputError(
                f"{method}: the retained dofs do not distinguish the {phi_a.shape[1]} modes (phi_a has rank {rank}, "
                f"condition {s[0] / max(s[-1], 1e-300):.3g}): retain other dofs or use fewer modes")
        return (Vt.T / s) @ U.T

    # -------------------------------------------------------------- builders
    def _full(self, T_o: np.ndarray | None, T_a: np.ndarray | None = None) -> np.ndarray:
        n, a = self.model.n_dofs, self.n_keep
        T = np.zeros((n, a))
        T[self.ia] = np.eye(a) if T_a is None else T_a
        if T_o is not None and self.io.size:
            T[self.io] = T_o
        return T

    def _make(self, T, method, n_modes=None) -> Transformation:
        return Transformation(T, self.model.dofs, self.keep, method, self.values.copy(), n_modes)

    @cached_property
    def _guyan_T(self) -> np.ndarray:
        if self.io.size == 0:
            return self._full(None)
        K_oa = self._block(self.K, self.io, self.ia).toarray()
        return self._full(-self.solve_oo(K_oa))

    def guyan(self) -> Transformation:
        r"""Guyan (static condensation), eq. 37: :math:`T_G = [I; -K_{oo}^{-1} K_{oa}]`.

        :math:`T_G^T K T_G = K_{aa} - K_{ao} K_{oo}^{-1} K_{oa}` (eq. 38) and :math:`T_G^T M T_G` is
        eq. 40.  Exact when the omitted dofs carry no mass (no inertia forces there).
        """
        return self._make(self._guyan_T, "guyan")

    @cached_property
    def guyan_matrices(self) -> tuple[np.ndarray, np.ndarray]:
        """Guyan-reduced ``(K_G, M_G)`` at :attr:`values` (dense, a x a)."""
        T = self._guyan_T
        return project(self.K, T), project(self.M, T)

    def irs(self) -> Transformation:
        r"""IRS (O'Callahan 1989), eqs. 41-42 as derived:

        .. math:: T_{IRS} = T_G + \begin{bmatrix} 0 \\ K_{oo}^{-1}(M_{oa} + M_{oo} T_{Go}) \end{bmatrix} M_G^{-1} K_G

        with :math:`T_{Go} = -K_{oo}^{-1}K_{oa}` the omitted rows of :math:`T_G` and
        :math:`K_G, M_G` the Guyan-reduced matrices.  (The paper's eq. 42 prints a minus sign,
        :math:`M_{aa}^{-1}K_{aa}` instead of :math:`M_G^{-1}K_G`, the full :math:`T_G` inside
        and no zero block for the retained rows; see the module notes of the paper section.)
        Uses the same factorisation of :math:`K_{oo}` as Guyan (one more solve with a columns).
        """
        Tg = self._guyan_T
        if self.io.size == 0:
            return self._make(Tg.copy(), "irs")
        Kg, Mg = self.guyan_matrices
        G = _solve_reduced_mass(Mg, Kg, "IRS")
        MT_o = (self.M @ Tg)[self.io]  # M_oa + M_oo T_Go
        T = Tg.copy()
        T[self.io] += self.solve_oo(MT_o) @ G
        return self._make(T, "irs")

    @shared_docs(**_DOCS)
    def kammer_modal(self, n_modes: int | None = None) -> Transformation:
        r"""Kammer's modal TAM (1987), eq. 43: :math:`T = [I; \phi_o (\phi_a^T\phi_a)^{-1}\phi_a^T]`.

        The omitted motion is interpolated by the full model's first ``n_modes`` mass-normalised
        modes (default: as many as retained dofs).  Needs ``n_modes <= a`` and modes that the
        retained dofs tell apart (:math:`\phi_a` of full column rank).  The reduced model
        reproduces those modes and their frequencies exactly.

        {{N_MODES_RAISES}}
        """
        m = self._n_modes(n_modes, "modal")
        phi = self.modes(m).shapes
        pinv = self._phi_a_pinv(phi[self.ia], "modal")
        return self._make(self._full(phi[self.io] @ pinv if self.io.size else None), "modal", m)

    @shared_docs(**_DOCS)
    def kammer_hybrid(self, n_modes: int | None = None) -> Transformation:
        r"""Kammer's hybrid TAM (1991), eq. 44 with the retained-dof partition of the modes:

        .. math:: T_H = T_G + (T_{Mod} - T_G)\, \phi_a \phi_a^T\, T_{Mod}^T M T_{Mod}

        :math:`\phi_a \phi_a^T M_{Mod}` is an oblique projector onto the ``n_modes`` target modes
        (mass-normalised): the hybrid reproduces them exactly like the modal TAM and treats the
        rest of the retained space like Guyan.  With ``n_modes = a`` it equals the modal TAM.
        The paper's ``[phi][phi]^T`` with "the full order eigenvector matrix" is dimensionally
        impossible; it is :math:`\phi_a\phi_a^T` (a x a).

        {{N_MODES}}

        Raises
        ------
        InputError
            As :meth:`kammer_modal`, or a singular K_oo (Guyan part; the message names the
            mechanism's dofs).
        NumericalError
            The eigen-solution fails.
        """
        m = self._n_modes(n_modes, "hybrid")
        Tm = self.kammer_modal(m).T
        Tg = self._guyan_T
        phi_a = self.modes(m).shapes[self.ia]
        P = phi_a @ (phi_a.T @ project(self.M, Tm))
        return self._make(Tg + (Tm - Tg) @ P, "hybrid", m)

    @shared_docs(**_DOCS)
    def serep(self, n_modes: int | None = None) -> Transformation:
        r"""SEREP (O'Callahan, Avitabile & Riemer 1989): :math:`T = \Phi\,\Phi_a^+`.

        Reproduces the ``n_modes`` modes exactly.  With ``n_modes = a`` (default) it is Kammer's
        modal TAM; with fewer modes its reduced matrices have rank ``n_modes`` only (fine for
        expansion, where :math:`\Phi_a^+` is a least-squares fit of the measured shape).

        {{N_MODES_RAISES}}
        """
        m = self._n_modes(n_modes, "serep")
        phi = self.modes(m).shapes
        pinv = self._phi_a_pinv(phi[self.ia], "serep")
        return self._make(phi @ pinv, "serep", m)

    def transformation(self, method: str, n_modes: int | None = None) -> Transformation:
        """Builder by name: ``guyan``, ``irs``, ``modal``, ``hybrid`` or ``serep``.

        Parameters
        ----------
        method : str
            Method name, in any case; ``kammer_modal`` and ``kammer_hybrid`` are accepted too.
        n_modes : int, optional
            For ``modal``, ``hybrid`` and ``serep`` (ignored by ``guyan`` and ``irs``).

        Returns
        -------
        Transformation

        Raises
        ------
        InputError
            An unknown method, and as the builder.
        NumericalError
            As the builder.
        """
        method = str(method).lower()
        if method == "guyan":
            return self.guyan()
        if method == "irs":
            return self.irs()
        if method in ("modal", "kammer_modal"):
            return self.kammer_modal(n_modes)
        if method in ("hybrid", "kammer_hybrid"):
            return self.kammer_hybrid(n_modes)
        if method == "serep":
            return self.serep(n_modes)
        raise InputError(f"unknown reduction method {method!r}: use {', '.join(METHODS)}")


def _solve_reduced_mass(Mg: np.ndarray, B: np.ndarray, what: str) -> np.ndarray:
    """:math:`M_G^{-1} B` by Cholesky; a singular Guyan mass (massless retained set) is refused."""
    try:
        c = sla.cho_factor(Mg)
    except np.linalg.LinAlgError:
        raise InputError(f"{what}: the Guyan-reduced mass matrix is not positive definite "
                         "(the retained dofs carry no inertia); retain dofs with mass") from None
    return sla.cho_solve(c, B)


def mechanism_dofs(K_oo, labels: Sequence[str], tol: float = 1e-9) -> tuple[list[str], int]:
    r"""Dofs that move in the zero-energy modes of a singular (or nearly singular) ``K_oo``.

    Works on the diagonally scaled :math:`D^{-1/2} K_{oo} D^{-1/2}` (unit diagonal, so the
    threshold is scale-free): dense eigen-solution up to :data:`DENSE_NULL_LIMIT` dofs, sparse
    shift-invert Lanczos above.  Dofs with no stiffness at all are named directly.
    Returns ``(labels, number of zero-energy modes)``.

    Parameters
    ----------
    K_oo : sparse matrix or array_like, shape ``(o, o)``
        The omitted partition of the stiffness matrix.
    labels : sequence of str
        Labels of its rows.
    tol : float, default 1e-9
        Eigenvalue of the scaled matrix below which a mode counts as zero-energy.

    Returns
    -------
    labels : list of str
        Dofs whose amplitude in a zero-energy mode is at least 0.1 of that mode's largest (or, if
        some dofs have a zero diagonal, exactly those dofs).
    count : int
        Number of zero-energy modes found (the number of zero-diagonal dofs in the second case;
        at most 8 are searched by the sparse route).

    Raises
    ------
    NumericalError
        The sparse search for the null space fails.
    """
    K = sp.csc_array(K_oo)
    d = np.abs(K.diagonal())
    zero = np.flatnonzero(d <= 1e-300)
    if zero.size:
        return [labels[int(i)] for i in zero], int(zero.size)
    s = 1.0 / np.sqrt(d)
    S = sp.csc_array(sp.diags_array(s) @ K @ sp.diags_array(s))
    n = S.shape[0]
    if n <= DENSE_NULL_LIMIT:
        lam, V = np.linalg.eigh(S.toarray())
    else:
        k = min(8, n - 2)
        try:
            lam, V = spla.eigsh(S, k=k, sigma=-1e-3, which="LM", **arpack_options())
        except (RuntimeError, spla.ArpackNoConvergence) as exc:
            raise NumericalError(f"K_oo is singular and its null space could not be found: {exc}") from None
    null = lam < tol
    if not np.any(null):
        return [], 0
    Vn = V[:, null]
    amp = np.max(np.abs(Vn) / np.max(np.abs(Vn), axis=0), axis=1)
    idx = np.flatnonzero(amp >= 0.1)
    return [labels[int(i)] for i in idx], int(null.sum())

