"""The factorisations of the sparse layer, the one protocol they share (:class:`Factor`), and the
factorisation of one matrix by the backend (:func:`factorize`)."""

from __future__ import annotations

import functools
from typing import Protocol, runtime_checkable

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from ..settings import FACTORISATIONS

__all__ = ["Factor", "NotPositiveDefinite", "SuperLUFactor", "OrderedLU", "CholmodFactor", "PardisoFactor", "factorize",
           "superlu", "backend", "cholmod_installed", "pardiso_installed", "nearly_singular", "nearly_singular_pivots",
           "PIVOT_THRESHOLD"]

PIVOT_THRESHOLD = 0.1  # SuperLU symmetric mode: off-diagonal pivot only below this fraction

_CHOLMOD: object = None  # the sksparse.cholmod module once imported, False when it is not installed


@runtime_checkable
class Factor(Protocol):
    """What every factorisation of A made by the layer offers its callers.

    Attributes
    ----------
    name : str
        What it is, for reports: ``"band Cholesky"``, ``"PARDISO Cholesky"``, ``"CHOLMOD Cholesky"`` or
        ``"SuperLU"``.
    shape : tuple of int
        ``(n, n)``.
    """

    name: str
    shape: tuple[int, int]

    def solve(self, B) -> np.ndarray:
        """A⁻¹ B for ``B`` of shape ``(n,)`` or ``(n, k)``."""

    def nearly_singular(self) -> bool:
        """Whether the smallest pivot is at most 1e-11 times the largest."""


class NotPositiveDefinite(ArithmeticError):
    """A Cholesky factorisation met a non-positive pivot: the matrix (K − σM, with σ not below the
    lowest eigenvalue) is not positive definite."""


def _cholmod_module():
    global _CHOLMOD
    if _CHOLMOD is None:
        try:
            from sksparse import cholmod
        except ImportError:
            _CHOLMOD = False
        else:
            _CHOLMOD = cholmod
    return _CHOLMOD or None


def cholmod_installed() -> bool:
    """Whether scikit-sparse (CHOLMOD) can be imported."""
    return _cholmod_module() is not None


def pardiso_installed() -> bool:
    """Whether MKL PARDISO can be loaded (the mkl package, x86_64)."""
    from .pardiso import available

    return available()


def backend(choice: str | None = None) -> str:
    """The sparse factorisation backend a choice stands for: ``"cholmod"``, ``"pardiso"`` or
    ``"superlu"``.

    CHOLMOD's supernodal Cholesky (scikit-sparse, the optional extra ``femupdate[cholmod]``)
    factorises the symmetric positive definite matrices of the package — K, K − σM below the
    lowest eigenvalue, the omitted block K_oo of a reduction — with about half the fill of
    SuperLU's LU and dense (BLAS 3) kernels on its supernodes.  SuperLU remains for what
    Cholesky cannot take (indefinite or complex symmetric matrices: dynamic stiffness at a
    frequency line, Nelson's bordered matrix) and whenever neither CHOLMOD nor PARDISO is there.
    MKL PARDISO's supernodal Cholesky (:mod:`.pardiso`; the mkl package, which ``pip install
    femupdate`` brings on x86_64 Linux without any system header) takes the same matrices as
    CHOLMOD, with a nested-dissection ordering and MKL's kernels.

    Parameters
    ----------
    choice : {"auto", "cholmod", "pardiso", "superlu"}, optional
        Default: the process's setting, :attr:`femupdate.settings.Settings.factorisation`
        (``"auto"`` unless configured).  ``"auto"`` is CHOLMOD where scikit-sparse is installed,
        else PARDISO where MKL is, else SuperLU.

    Returns
    -------
    str

    Raises
    ------
    InputError
        An unknown backend, ``"cholmod"`` without scikit-sparse or ``"pardiso"`` without MKL.
    """
    if choice is None:
        from .. import settings

        choice = settings.current().factorisation
    if choice not in FACTORISATIONS:
        from .._errors import InputError

        raise InputError(f"factorisation {choice!r}: not a factorisation backend (give one of "
                         f"{', '.join(FACTORISATIONS)})")
    if choice == "superlu":
        return "superlu"
    if choice == "pardiso":
        if not pardiso_installed():
            raise _no_pardiso()
        return "pardiso"
    if _cholmod_module() is not None:
        return "cholmod"
    if choice == "cholmod":
        raise _no_cholmod()
    return "pardiso" if pardiso_installed() else "superlu"


_resolve = backend  # the function, under a name that factorize's parameter does not hide


def _no_cholmod():
    from .._errors import InputError

    return InputError("the factorisation backend 'cholmod' needs scikit-sparse (pip install 'femupdate[cholmod]', "
                      "with SuiteSparse's headers installed)")


def _no_pardiso():
    from .._errors import InputError

    return InputError("the factorisation backend 'pardiso' needs MKL (pip install mkl, on x86_64; "
                      "pip install femupdate brings it there)")


def factorize(A, definite: bool | None = None, backend: str | None = None) -> Factor:
    """The factorisation of a sparse symmetric matrix, by the backend (:func:`backend`).

    With CHOLMOD (PARDISO), a real matrix not known to be indefinite gets a supernodal Cholesky
    factor (:class:`CholmodFactor`, :class:`PardisoFactor`); otherwise, or when its Cholesky
    meets a non-positive pivot, SuperLU (:class:`SuperLUFactor`).

    Parameters
    ----------
    A : sparse matrix or array_like, shape ``(n, n)``
        Symmetric (real or complex) matrix.
    definite : bool or None
        What the caller knows: None (try Cholesky, LU when it fails), True (A should be positive
        definite: a failed Cholesky raises :class:`NotPositiveDefinite`, which the caller reads
        as "singular or indefinite"), False (A is indefinite: LU directly).
    backend : {"auto", "cholmod", "pardiso", "superlu"}, optional
        As :func:`backend` takes it (default: the process's setting).

    Returns
    -------
    Factor
        ``.solve(b)`` solves ``A x = b``; ``.nearly_singular()`` judges it.

    Raises
    ------
    NotPositiveDefinite
        ``definite=True`` and CHOLMOD's (PARDISO's) Cholesky failed.
    RuntimeError
        SuperLU finds A exactly singular.
    """
    A = sp.csc_array(A)
    chosen = _resolve(backend)
    if definite is not False and not np.iscomplexobj(A.data) and chosen != "superlu":
        try:
            return CholmodFactor.of(A) if chosen == "cholmod" else PardisoFactor.of(A)
        except NotPositiveDefinite:
            if definite:
                raise
    return SuperLUFactor(superlu(A))


def superlu(A):
    """Sparse LU of a symmetric matrix with a symmetric fill-reducing ordering.

    ``MMD_AT_PLUS_A`` orders on the pattern of A + A^T, which for FE matrices gives far less
    fill than SuperLU's default COLAMD (meant for unsymmetric A^T A): on a 100,000-dof frame
    it halves the factorisation time and memory.  SuperLU's *symmetric mode* (diagonal pivots
    preferred, an off-diagonal one only when the diagonal is below 0.1 of its column) keeps that
    ordering intact: with the default partial pivoting the omitted partition K_oo of a 23,400-dof
    frame took 37-120 s instead of 2 s for the same fill.  The threshold keeps indefinite
    (K - omega^2 M) and complex matrices as accurate as partial pivoting (residuals 1e-13).

    Parameters
    ----------
    A : sparse matrix or array_like, shape ``(n, n)``
        Symmetric (real or complex) matrix; converted to CSC.

    Returns
    -------
    scipy.sparse.linalg.SuperLU
        SciPy's factorisation (:class:`SuperLUFactor` wraps it for the layer's callers).

    Raises
    ------
    RuntimeError
        SuperLU finds A exactly singular (SciPy's own error, not a NumericalError).
    """
    return spla.splu(sp.csc_array(A), permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=PIVOT_THRESHOLD,
                     options={"SymmetricMode": True})


def nearly_singular(lu) -> bool:
    """Whether a factorisation's smallest pivot is at most 1e-11 times its largest.

    Parameters
    ----------
    lu : Factor or scipy.sparse.linalg.SuperLU
        A factorisation from :func:`factorize` or a workspace, or SciPy's own.

    Returns
    -------
    bool
        True if ``min |U_ii| <= 1e-11 max |U_ii|`` (the pivots of LDLᵀ for a Cholesky factor).
    """
    if hasattr(lu, "nearly_singular"):
        return bool(lu.nearly_singular())
    return _superlu_nearly_singular(lu)


def _superlu_nearly_singular(lu) -> bool:
    U = lu.U
    piv = U.diagonal()
    del U
    return nearly_singular_pivots(piv)


def nearly_singular_pivots(piv: np.ndarray) -> bool:
    """Whether the smallest pivot magnitude is at most 1e-11 times the largest (as
    :func:`femupdate.modal.nearly_singular`)."""
    piv = np.abs(piv)
    return bool(piv.min() <= 1e-11 * piv.max())


class SuperLUFactor:
    """SuperLU's factorisation of A (SciPy's, ordered by SuperLU: :func:`superlu`).

    Parameters
    ----------
    lu : scipy.sparse.linalg.SuperLU
    """

    name = "SuperLU"

    def __init__(self, lu):
        self.lu = lu
        self.shape = lu.shape
        self.nnz = lu.nnz

    def solve(self, B) -> np.ndarray:
        """A⁻¹ B for ``B`` of shape ``(n,)`` or ``(n, k)`` (SciPy's solve: complex B needs a
        complex factor)."""
        return self.lu.solve(B)

    def nearly_singular(self) -> bool:
        """``min |U_ii| <= 1e-11 max |U_ii|``."""
        return _superlu_nearly_singular(self.lu)


class OrderedLU:
    """SuperLU factorisation of P A Pᵀ in its natural order, P the workspace's fill-reducing
    ordering; :meth:`solve` works in A's own order.

    Parameters
    ----------
    Ap : scipy.sparse.csc_array
        P A Pᵀ.
    perm : numpy.ndarray of int
        Row i of P A Pᵀ is row ``perm[i]`` of A.
    """

    name = "SuperLU"

    def __init__(self, Ap, perm: np.ndarray):
        self.lu = spla.splu(Ap, permc_spec="NATURAL", diag_pivot_thresh=PIVOT_THRESHOLD,
                            options={"SymmetricMode": True})
        self.perm = perm
        self.shape = Ap.shape
        self.nnz = self.lu.nnz

    def solve(self, B) -> np.ndarray:
        """A⁻¹ B for ``B`` of shape ``(n,)`` or ``(n, k)``."""
        B = np.asarray(B, dtype=float)
        X = self.lu.solve(np.ascontiguousarray(B[self.perm]))
        out = np.empty_like(X)
        out[self.perm] = X
        return out

    def nearly_singular(self) -> bool:
        """``min |U_ii| <= 1e-11 max |U_ii|``."""
        return _superlu_nearly_singular(self.lu)


class CholmodFactor:
    """CHOLMOD's supernodal Cholesky factor L Lᵀ = P A Pᵀ (scikit-sparse), P its fill-reducing
    ordering (AMD or METIS, whichever CHOLMOD finds better).

    Parameters
    ----------
    factor : sksparse.cholmod.Factor
        The numeric factorisation.
    """

    name = "CHOLMOD Cholesky"

    def __init__(self, factor):
        self.factor = factor
        n = factor.P().size
        self.shape = (n, n)

    @classmethod
    def of(cls, A, symbolic=None) -> CholmodFactor:
        """Factorise A (CSC, real symmetric), through ``symbolic`` (an analysed factor of A's
        pattern) when given.

        Raises
        ------
        NotPositiveDefinite
            A pivot is not positive (A singular or indefinite).
        InputError
            scikit-sparse is not installed.
        """
        cholmod = _cholmod_module()
        if cholmod is None:
            raise _no_cholmod()
        A = sp.csc_matrix(A)  # scikit-sparse 0.4 takes the matrix classes
        try:
            if symbolic is None:
                return cls(cholmod.cholesky(A, mode="supernodal"))
            return cls(symbolic.cholesky(A))
        except cholmod.CholmodNotPositiveDefiniteError as exc:
            raise NotPositiveDefinite(str(exc).split(": ")[-1]) from None

    @staticmethod
    def analyse(A):
        """CHOLMOD's symbolic analysis of A's pattern (its ordering and supernodes), for
        :meth:`of`."""
        cholmod = _cholmod_module()
        if cholmod is None:
            raise _no_cholmod()
        return cholmod.analyze(sp.csc_matrix(A), mode="supernodal")

    def solve(self, B) -> np.ndarray:
        """A⁻¹ B for ``B`` of shape ``(n,)`` or ``(n, k)``, real or complex."""
        B = np.asarray(B)
        if np.iscomplexobj(B):
            return self.solve(B.real) + 1j * self.solve(B.imag)
        return self.factor(np.asarray(B, dtype=float))

    def nearly_singular(self) -> bool:
        """Pivots of the LDLᵀ form spread beyond 1e11."""
        return nearly_singular_pivots(self.factor.D())

    @functools.cached_property
    def nnz(self) -> int:
        """Entries of L."""
        return int(self.factor.L().nnz)


class PardisoFactor:
    """MKL PARDISO's supernodal Cholesky factor of A (:mod:`.pardiso`): the numeric factor held in
    a PARDISO handle (the analysis of A's pattern), which later factorisations of the same pattern
    reuse.

    A handle holds one numeric factor at a time: a factor whose values are no longer the handle's
    (a later factorisation through the same handle) factorises its own values again before its
    next solve, so every factor stays valid for as long as it is kept.  Calls on one handle are
    serialised (a lock).

    Parameters
    ----------
    handle : femupdate.workspace.pardiso.PardisoHandle
    data : numpy.ndarray
        The values of A on the handle's pattern (upper triangle, compressed rows).

    Raises
    ------
    NotPositiveDefinite
        A pivot is not positive (A singular or indefinite).
    """

    name = "PARDISO Cholesky"

    def __init__(self, handle, data: np.ndarray):
        self.handle = handle
        self.data = data
        self.shape = (handle.n, handle.n)
        self._token = object()
        with handle.lock:
            self._load()

    def _load(self) -> None:
        try:
            self.handle.factor(self.data)
        except ArithmeticError as exc:
            self.handle.owner = None
            raise NotPositiveDefinite(str(exc)) from None
        self.handle.owner = self._token

    def _current(self) -> None:
        """The handle holds this factor's values (factorised again when a later one replaced them);
        called under the handle's lock."""
        if self.handle.owner is not self._token:
            self._load()

    @classmethod
    def of(cls, A) -> PardisoFactor:
        """Analyse and factorise A (real symmetric) in a handle of its own.

        Raises
        ------
        NotPositiveDefinite
            A pivot is not positive.
        InputError
            MKL is not installed.
        """
        from .pardiso import PardisoHandle, available, upper_pattern

        if not available():
            raise _no_pardiso()
        indptr, indices, data = upper_pattern(A)
        return cls(PardisoHandle(indptr, indices), data)

    def solve(self, B) -> np.ndarray:
        """A⁻¹ B for ``B`` of shape ``(n,)`` or ``(n, k)``, real or complex."""
        B = np.asarray(B)
        if np.iscomplexobj(B):
            return self.solve(B.real) + 1j * self.solve(B.imag)
        with self.handle.lock:
            self._current()
            return self.handle.solve(B)

    def nearly_singular(self) -> bool:
        """Pivots of the LDLᵀ form spread beyond 1e11."""
        with self.handle.lock:
            self._current()
            return nearly_singular_pivots(self.handle.diagonal())

    @property
    def nnz(self) -> int:
        """Entries of L (PARDISO's count from the analysis)."""
        return self.handle.nnz_factor
