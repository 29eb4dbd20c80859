r"""The sparse factorisation layer: what the solves of one model share from one evaluation to the next.

Every sparse solve of the package goes through :func:`factorize` (one matrix) or a
:class:`SparseWorkspace` (the same pattern, new values).  Two backends (:func:`backend`):

* **CHOLMOD** (scikit-sparse, the optional extra ``femupdate[cholmod]``): supernodal Cholesky of
  the symmetric positive definite matrices — K, K − σM below the lowest eigenvalue, the omitted
  block K_oo of a reduction — with a fill-reducing ordering (AMD or METIS) and about half of
  SuperLU's fill (a 102,600-dof frame tower: 44 M entries against 73 M);
* **SuperLU** (SciPy) for everything Cholesky cannot take (indefinite or complex symmetric
  matrices: the dynamic stiffness K − ω²M at a frequency line, Nelson's bordered matrix), and for
  everything when scikit-sparse is not installed.

Updating a large model solves :math:`K(p)\phi = \lambda M(p)\phi` at many parameter values p,
start after start and iteration after iteration.  The values change; the sparsity pattern does
not: :class:`~femupdate.Model` assembles K(p) and M(p) onto the union pattern of its matrices
(:attr:`Model._pattern`) whatever p.  A :class:`SparseWorkspace` keeps what depends on that
pattern only, found once per model:

* **the route and the ordering.**  The first factorisation of K − σM is made by the backend
  (CHOLMOD analyses the pattern once — its ordering and symbolic factor — and every later
  factorisation reuses that analysis; SuperLU's fill-reducing ordering is kept and applied to the
  pattern, since SciPy's SuperLU cannot keep a symbolic factorisation but takes a pre-permuted
  matrix in its natural order).  Its fill is then compared with a *band* Cholesky factor in a
  bandwidth-reducing ordering (reverse Cuthill–McKee or the given order, whichever is narrower)
  by their operation counts (:func:`band_wins`): the band factor (LAPACK ``pbtrf``) runs on
  dense blocked kernels, about eight times faster per operation, and wins for slender or
  moderate models — a frame tower of 102,600 dofs factorises in 1.1 s by the band against
  4.0 s by CHOLMOD and 10 s by SuperLU (one BLAS thread).  The choice depends on the pattern
  alone (not on a timing), so runs are reproducible.
* **the scatter maps.**  Where each stored entry of K and of M lands in the factorised storage
  (the band, or the compressed columns): K − σM is one ``zeros`` and two indexed stores.

The band factor *is* the symbolic factorisation of the band route: its structure is fixed by
the ordering, and reused as such.  Its solves with many right-hand sides (the sensitivities'
series: every mode's parameters at once) go by dense blocks of the bandwidth, matrix-matrix
kernels, instead of LAPACK's column-by-column ``pbtrs`` (36 columns on the 2,304-dof building:
about 1.4 times faster).

Safety: a workspace belongs to one model (a weak-keyed cache, :func:`workspace_of`) and is used
only for matrices whose compressed-row pattern is exactly the one it was built for (checked at
every call, :meth:`SparseWorkspace.matches`); anything else is factorised afresh.  The values
cannot change the pattern (assembly is onto the union pattern; a value that makes an entry zero
leaves an explicit zero), so there is no stale reuse.  The factorisations are exact (backward
stable LU or Cholesky): every route gives the same eigenpairs to round-off.
"""

from __future__ import annotations

import functools
import os
import weakref

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from scipy.linalg import blas, lapack
from scipy.sparse.csgraph import reverse_cuthill_mckee

from ._threads import blas_phase

__all__ = ["SparseWorkspace", "BandCholesky", "OrderedLU", "CholmodFactor", "NotPositiveDefinite", "workspace_of",
           "factorize", "backend", "band_wins", "factor_name", "BACKEND_VARIABLE"]

#: environment variable that chooses the sparse factorisation backend: ``auto`` (the default:
#: CHOLMOD where scikit-sparse is installed, else SuperLU), ``cholmod`` or ``superlu``
BACKEND_VARIABLE = "FEMUPDATE_FACTORISATION"
_BACKENDS = ("auto", "cholmod", "superlu")
_CHOLMOD: object = None  # the sksparse.cholmod module once imported, False when it is not installed


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


def backend() -> str:
    """The sparse factorisation backend in use: ``"cholmod"`` or ``"superlu"``.

    CHOLMOD's supernodal Cholesky (scikit-sparse, the optional extra ``femupdate[cholmod]``)
    factorises the symmetric positive definite matrices of the package — K, K − σM below the
    lowest eigenvalue, the omitted block K_oo of a reduction — with about half the fill of
    SuperLU's LU and dense (BLAS 3) kernels on its supernodes.  SuperLU remains for what
    Cholesky cannot take (indefinite or complex symmetric matrices: dynamic stiffness at a
    frequency line, Nelson's bordered matrix) and whenever scikit-sparse is missing.  The
    environment variable :data:`BACKEND_VARIABLE` (``FEMUPDATE_FACTORISATION``) forces one.

    Returns
    -------
    str

    Raises
    ------
    InputError
        The variable names an unknown backend, or ``cholmod`` without scikit-sparse.
    """
    choice = os.environ.get(BACKEND_VARIABLE, "auto").strip().lower() or "auto"
    if choice not in _BACKENDS:
        from ._errors import InputError

        raise InputError(f"{BACKEND_VARIABLE}={os.environ.get(BACKEND_VARIABLE)!r}: not a factorisation backend "
                         f"(give one of {', '.join(_BACKENDS)})")
    if choice == "superlu":
        return "superlu"
    if _cholmod_module() is None:
        if choice == "cholmod":
            from ._errors import InputError

            raise InputError(f"{BACKEND_VARIABLE}=cholmod needs scikit-sparse (pip install 'femupdate[cholmod]', "
                             "with SuiteSparse's headers installed)")
        return "superlu"
    return "cholmod"

#: band storage of at most this many entries (800 MB; its blocked solves keep about twice as much
#: again) is considered at all
MAX_BAND_ENTRIES = 100_000_000

#: per floating-point operation, the band Cholesky (LAPACK ``pbtrf``: dense blocked kernels along
#: the band) runs this many times faster than a sparse factorisation (CHOLMOD's supernodes, or
#: SuperLU).  Measured on frame lattices of 1,500 to 102,600 dofs, one BLAS thread: the band took
#: 3.4 ms against CHOLMOD's 14 ms at 2,304 dofs (twice the operations), 145 against 329 ms at
#: 11,400 dofs (four times the operations), 1.13 s against 4.0 s at 102,600 dofs; near a tie
#: (124 against 139 ms) with 10 times the operations on a 12 × 12 × 12 cube
BAND_EFFICIENCY = 8.0


#: a band factorisation of at least this many operations (n b²), or a CHOLMOD one of at least
#: :data:`LARGE_CHOLMOD` dofs, is a "dense" phase of the BLAS policy (femupdate._threads)
LARGE_FACTOR_OPS = 2e9
LARGE_CHOLMOD = 50_000


def band_wins(n: int, b: int, nnz_l: int) -> bool:
    """Whether the band Cholesky of half-bandwidth ``b`` is expected to be faster than a sparse
    Cholesky factor with ``nnz_l`` entries in L.

    Operation counts: the band's is about n b² (``(b + 1) n`` stored entries, each updated ~b
    times); a sparse factor's Σ_j c_j² over its column counts c_j, at least nnz_l²/n (equal
    counts), which is the estimate used.  The band is taken when its count is at most
    :data:`BAND_EFFICIENCY` times the sparse one and its storage at most :data:`MAX_BAND_ENTRIES`.

    Parameters
    ----------
    n : int
        Order of the matrix.
    b : int
        Half-bandwidth in the band ordering.
    nnz_l : int
        Entries of the sparse factor's L (for SuperLU's L + U: about half of its ``nnz`` + n).

    Returns
    -------
    bool
    """
    storage = (b + 1) * n
    return storage <= MAX_BAND_ENTRIES and storage * float(b) <= BAND_EFFICIENCY * float(nnz_l) ** 2 / n


class NotPositiveDefinite(ArithmeticError):
    """The band Cholesky factorisation met a non-positive pivot: K − σM is not positive
    definite (σ is not below the lowest eigenvalue)."""


PIVOT_THRESHOLD = 0.1  # SuperLU symmetric mode: off-diagonal pivot only below this fraction


def factorize(A, definite: bool | None = None):
    """The factorisation of a sparse symmetric matrix, by the backend in use (:func:`backend`).

    With CHOLMOD, a real matrix not known to be indefinite gets a supernodal Cholesky factor
    (:class:`CholmodFactor`); otherwise, or when its Cholesky meets a non-positive pivot, SuperLU
    (:func:`superlu`).

    Parameters
    ----------
    A : sparse matrix or array_like, shape ``(n, n)``
        Symmetric (real or complex) matrix.
    definite : bool or None
        What the caller knows: None (try Cholesky, LU when it fails), True (A should be positive
        definite: a failed Cholesky raises :class:`NotPositiveDefinite`, which the caller reads
        as "singular or indefinite"), False (A is indefinite: LU directly).

    Returns
    -------
    CholmodFactor or scipy.sparse.linalg.SuperLU
        ``.solve(b)`` solves ``A x = b``; :func:`nearly_singular` judges either.

    Raises
    ------
    NotPositiveDefinite
        ``definite=True`` and CHOLMOD's Cholesky failed.
    RuntimeError
        SuperLU finds A exactly singular.
    """
    A = sp.csc_array(A)
    if definite is not False and not np.iscomplexobj(A.data) and backend() == "cholmod":
        try:
            return CholmodFactor.of(A)
        except NotPositiveDefinite:
            if definite:
                raise
    return superlu(A)


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
        The factorisation; ``.solve(b)`` solves ``A x = b``.

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
    lu : scipy.sparse.linalg.SuperLU, or a factor with a ``nearly_singular`` method
        A factorisation from :func:`factorize` or a workspace.

    Returns
    -------
    bool
        True if ``min |U_ii| <= 1e-11 max |U_ii|`` (the pivots of LDLᵀ for a Cholesky factor).
    """
    if hasattr(lu, "nearly_singular"):
        return bool(lu.nearly_singular())
    U = lu.U
    piv = np.abs(U.diagonal())
    del U
    return bool(piv.min() <= 1e-11 * piv.max())


def nearly_singular_pivots(piv: np.ndarray) -> bool:
    """Whether the smallest pivot magnitude is at most 1e-11 times the largest (as
    :func:`femupdate.modal.nearly_singular`)."""
    piv = np.abs(piv)
    return bool(piv.min() <= 1e-11 * piv.max())


class CholmodFactor:
    """CHOLMOD's supernodal Cholesky factor L Lᵀ = P A Pᵀ (scikit-sparse), P its fill-reducing
    ordering (AMD or METIS, whichever CHOLMOD finds better).

    Parameters
    ----------
    factor : sksparse.cholmod.Factor
        The numeric factorisation.
    """

    backend = "cholmod"

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
        """
        cholmod = _cholmod_module()
        assert cholmod is not None
        A = sp.csc_matrix(A)  # scikit-sparse 0.4 takes the matrix classes
        try:
            if symbolic is None:
                return cls(cholmod.cholesky(A, mode="supernodal"))
            return cls(symbolic.cholesky(A))
        except cholmod.CholmodNotPositiveDefiniteError as exc:
            raise NotPositiveDefinite(str(exc).split(": ")[-1]) from None

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


class BandCholesky:
    """Cholesky factor L Lᵀ = P A Pᵀ of a symmetric positive definite matrix in band storage.

    Parameters
    ----------
    ab : numpy.ndarray, shape ``((b + 1) n,)``
        The lower band of P A Pᵀ, Fortran order of the ``(b + 1, n)`` LAPACK layout
        (``ab[d + (b + 1) j] = A[j + d, j]``); overwritten.
    b : int
        Half-bandwidth.
    perm : numpy.ndarray of int, shape ``(n,)``
        The ordering: row i of P A Pᵀ is row ``perm[i]`` of A.

    Raises
    ------
    NotPositiveDefinite
        A pivot is not positive.
    """

    def __init__(self, ab: np.ndarray, b: int, perm: np.ndarray):
        n = perm.size
        c, info = lapack.dpbtrf(ab.reshape((b + 1, n), order="F"), lower=1, overwrite_ab=1)
        if info > 0:
            raise NotPositiveDefinite(f"leading minor {info} is not positive definite")
        if info < 0:  # pragma: no cover - a wrong argument is a bug here
            raise ValueError(f"dpbtrf: illegal argument {-info}")
        self.c = c
        self.perm = perm
        self.shape = (n, n)
        self._blk: tuple | None = None

    def solve(self, B) -> np.ndarray:
        """A⁻¹ B for ``B`` of shape ``(n,)`` or ``(n, k)``.

        LAPACK's ``pbtrs`` solves one column at a time (matrix-vector kernels); from
        :data:`BLOCKED_MIN_COLUMNS` columns on, and for bands of at least
        :data:`BLOCKED_MIN_BANDWIDTH`, the triangular solves run by blocks of the bandwidth
        instead (:meth:`_blocked`: matrix-matrix kernels, the same operations in another order).
        """
        B = np.asarray(B, dtype=float)
        one = B.ndim == 1
        n = self.shape[0]
        B2 = B.reshape(n, -1)
        b = self.c.shape[0] - 1
        if B2.shape[1] >= BLOCKED_MIN_COLUMNS and b >= BLOCKED_MIN_BANDWIDTH and n > 2 * b:
            X = self._blocked(B2[self.perm])
        else:
            X, info = lapack.dpbtrs(self.c, np.asfortranarray(B2[self.perm]), lower=1, overwrite_b=1)
            if info != 0:  # pragma: no cover
                raise ValueError(f"dpbtrs: illegal argument {-info}")
        out = np.empty_like(X)
        out[self.perm] = X
        return out[:, 0] if one else out

    def _blocks(self):
        """L as block-bidiagonal dense blocks of the bandwidth's size: ``D[i]`` (lower
        triangular) on the diagonal and ``S[i]`` below it (rows of block i + 1); padded to whole
        blocks with an identity."""
        if self._blk is None:
            b = self.c.shape[0] - 1
            n = self.shape[0]
            nb = b  # = the bandwidth: the blocks below the diagonal are then upper triangular (trmm)
            idx, nblk = _block_index(n, b, nb)
            cpad = np.zeros((b + 1) * nblk * nb + 1)
            cpad[:(b + 1) * n] = self.c.ravel(order="F")
            cpad[(b + 1) * np.arange(n, nblk * nb)] = 1.0  # identity on the padding
            W = cpad[idx]  # (nblk, 2 nb, nb); idx -1 reads the trailing zero
            self._blk = (nb, nblk, W)
        return self._blk

    def _blocked(self, Bp: np.ndarray) -> np.ndarray:
        nb, nblk, W = self._blocks()
        n, k = Bp.shape
        X = np.zeros((nblk * nb, k))
        X[:n] = Bp
        trsm, trmm = blas.dtrsm, blas.dtrmm
        for i in range(nblk):  # L Y = B
            r = slice(i * nb, (i + 1) * nb)
            if i:  # S_{i-1} is upper triangular (the band ends on its diagonal): trmm, half gemm's work
                X[r] -= trmm(1.0, W[i - 1, nb:].T, X[(i - 1) * nb:i * nb], lower=1, trans_a=1)
            # D_i (C order) is the upper triangle D_iᵀ in Fortran order: solve (D_iᵀ)ᵀ y = x
            X[r] = trsm(1.0, W[i, :nb].T, X[r], lower=0, trans_a=1)
        for i in range(nblk - 1, -1, -1):  # Lᵀ X = Y
            r = slice(i * nb, (i + 1) * nb)
            if i < nblk - 1:
                X[r] -= trmm(1.0, W[i, nb:].T, X[(i + 1) * nb:(i + 2) * nb], lower=1, trans_a=0)
            X[r] = trsm(1.0, W[i, :nb].T, X[r], lower=0, trans_a=0)
        return X[:n]

    def nearly_singular(self) -> bool:
        """Pivots of the LDLᵀ form (the squared diagonal of L) spread beyond 1e11."""
        return nearly_singular_pivots(self.c[0] ** 2)


#: multi-column solves from this many columns on go by blocks (matrix-matrix kernels) ...
BLOCKED_MIN_COLUMNS = 16
#: ... when the band is at least this wide (narrower blocks are all Python overhead)
BLOCKED_MIN_BANDWIDTH = 64


@functools.lru_cache(maxsize=8)
def _block_index(n: int, b: int, nb: int) -> tuple[np.ndarray, int]:
    """Gather indices of the block-bidiagonal form of a band factor (:meth:`BandCholesky._blocks`):
    ``W[i, r, c] = L[i nb + r, i nb + c]`` for r < 2 nb, c < nb, read from the column-major band
    storage ``c[d + (b + 1) j] = L[j + d, j]`` padded to whole blocks; -1 where L is zero."""
    nblk = -(-n // nb)
    N = nblk * nb
    r = np.arange(2 * nb)[:, None]
    c = np.arange(nb)[None, :]
    d = r - c
    i = np.arange(nblk)[:, None, None]
    col = i * nb + c
    idx = d + (b + 1) * col
    ok = (d >= 0) & (d <= b) & (i * nb + r < N)
    idx = np.where(ok, idx, -1)
    idx.setflags(write=False)
    return idx, nblk


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
        U = self.lu.U
        piv = U.diagonal()
        del U
        return nearly_singular_pivots(piv)


def _bandwidth(pattern: sp.csr_array, perm: np.ndarray) -> int:
    inv = np.empty_like(perm)
    inv[perm] = np.arange(perm.size)
    coo = pattern.tocoo()
    return int(np.max(np.abs(inv[coo.row] - inv[coo.col]), initial=0))


class SparseWorkspace:
    """The reusable part of the factorisations of K − σM for one sparsity pattern.

    Parameters
    ----------
    K, M : scipy.sparse.csr_array, shape ``(n, n)``
        Matrices with the pattern of every later call (their values are not kept).
    prefer : {None, "band", "sparse"}
        The route: chosen by :func:`band_wins` (None), or imposed — the band (if its storage is
        within :data:`MAX_BAND_ENTRIES`) or the backend's sparse factor — for comparisons.

    Attributes
    ----------
    route : str or None
        ``"band"``, ``"cholmod"`` or ``"superlu"`` once the first factorisation has chosen (None
        before).
    bandwidth : int or None
        Half-bandwidth of the band ordering (once computed).
    n_factorisations : int
        Factorisations made through the workspace.
    """

    def __init__(self, K, M, prefer: str | None = None):
        if prefer not in (None, "band", "sparse"):
            raise ValueError(f"prefer={prefer!r}: give None, 'band' or 'sparse'")
        self.prefer = prefer
        K, M = sp.csr_array(K), sp.csr_array(M)
        self.n = K.shape[0]
        self._kpat = (K.indptr.copy(), K.indices.copy())
        self._mpat = (M.indptr.copy(), M.indices.copy())
        self.route: str | None = None
        self.bandwidth: int | None = None
        self.n_factorisations = 0
        self._perm: np.ndarray | None = None
        self._size = 0
        self._kpos: np.ndarray | None = None
        self._mpos: np.ndarray | None = None
        self._csc: tuple[np.ndarray, np.ndarray] | None = None  # (indptr, indices) of P A P^T (A: CHOLMOD)
        self._cpos: tuple[np.ndarray, np.ndarray] | None = None  # CHOLMOD: slots of K's and M's entries in A
        self._symbolic = None  # CHOLMOD: the analysed pattern

    # ------------------------------------------------------------------ pattern
    def matches(self, K, M) -> bool:
        """True when K and M are CSR arrays with exactly the workspace's patterns."""
        for A, (indptr, indices) in ((K, self._kpat), (M, self._mpat)):
            if not (sp.issparse(A) and A.format == "csr" and A.shape == (self.n, self.n)
                    and A.indptr.size == indptr.size and A.indices.size == indices.size
                    and np.array_equal(A.indptr, indptr) and np.array_equal(A.indices, indices)):
                return False
        return True

    def _coo(self, pat):
        indptr, indices = pat
        rows = np.repeat(np.arange(self.n, dtype=np.int64), np.diff(indptr))
        return rows, indices.astype(np.int64)

    def _union(self) -> sp.csr_array:
        (kr, kc), (mr, mc) = self._coo(self._kpat), self._coo(self._mpat)
        ones = np.ones(kr.size + mr.size)
        A = sp.csr_array((ones, (np.concatenate([kr, mr]), np.concatenate([kc, mc]))), shape=(self.n, self.n))
        A.sum_duplicates()
        return A

    # ------------------------------------------------------------------ the route
    def _band_chosen(self, n: int, b: int, nnz_l) -> bool:
        if self.prefer == "sparse":
            return False
        if (b + 1) * n > MAX_BAND_ENTRIES:
            return False
        return self.prefer == "band" or band_wins(n, b, nnz_l())

    def _band_order(self, union) -> tuple[np.ndarray, int]:
        """The narrower of the given order and reverse Cuthill–McKee, and its half-bandwidth."""
        natural = np.arange(self.n)
        perm, b = natural, _bandwidth(union, natural)
        rcm = np.asarray(reverse_cuthill_mckee(sp.csr_array(union), symmetric_mode=True), dtype=np.int64)
        b_rcm = _bandwidth(union, rcm)
        if b_rcm < b:
            perm, b = rcm, b_rcm
        return perm, b

    def _choose_cholmod(self, K, M, sigma: float):
        """CHOLMOD backend: analyse the union pattern once and factorise; the band route instead
        when :func:`band_wins` against the factor's fill."""
        cholmod = _cholmod_module()
        assert cholmod is not None
        union = sp.csc_array(self._union())
        n = self.n
        perm, b = self._band_order(union)
        A = self._assemble_cholmod(union, K, M, sigma)
        symbolic = cholmod.analyze(sp.csc_matrix(A), mode="supernodal")
        first = CholmodFactor.of(A, symbolic)  # NotPositiveDefinite: no route chosen yet
        if self._band_chosen(n, b, lambda: first.nnz):
            self._band_route(perm, b)
        else:
            self.route, self.bandwidth, self._symbolic = "cholmod", b, symbolic
        return first

    def _assemble_cholmod(self, union, K, M, sigma: float):
        """K − σM on the union pattern in compressed columns (each entry's slot found once)."""
        if self._cpos is None:
            union = sp.csc_array(union)
            union.sort_indices()
            cols = np.repeat(np.arange(self.n, dtype=np.int64), np.diff(union.indptr))
            keys = cols * self.n + union.indices.astype(np.int64)  # sorted: column-major order
            self._csc = (union.indptr.astype(np.int32), union.indices.astype(np.int32))

            def positions(pat):
                r, c = self._coo(pat)
                return np.searchsorted(keys, c * self.n + r).astype(np.int64)

            self._cpos = (positions(self._kpat), positions(self._mpat))
        assert self._csc is not None
        kpos, mpos = self._cpos
        data = np.zeros(self._csc[1].size)
        data[kpos] = K.data
        if sigma:
            data[mpos] -= sigma * M.data
        indptr, indices = self._csc
        return sp.csc_array((data, indices, indptr), shape=(self.n, self.n))

    def _band_route(self, perm: np.ndarray, b: int) -> None:
        """Take the band route in ordering ``perm`` of half-bandwidth ``b``: each stored entry's
        slot in the band (−1 above the diagonal)."""
        n = self.n
        self.route, self.bandwidth = "band", b
        inv = np.empty_like(perm)
        inv[perm] = np.arange(n)

        def positions(pat):
            r, c = self._coo(pat)
            i, j = inv[r], inv[c]
            lower = i >= j
            pos = np.full(r.size, -1, dtype=np.int64)
            pos[lower] = (i - j)[lower] + (b + 1) * j[lower]
            return pos

        self._perm, self._size = perm.astype(np.intp), (b + 1) * n
        self._kpos, self._mpos = positions(self._kpat), positions(self._mpat)

    def _choose(self, fill: int, perm_c: np.ndarray) -> None:
        """Band if :func:`band_wins` against SuperLU's fill ``fill`` (L + U); else SuperLU in
        ``perm_c``."""
        union = self._union()
        n = self.n
        perm, b = self._band_order(union)
        if self._band_chosen(n, b, lambda: (fill + n) // 2):
            self._band_route(perm, b)
        else:
            self.route, self.bandwidth = "superlu", b
            perm = np.asarray(perm_c, dtype=np.int64)
            order = np.empty_like(perm)
            order[perm] = np.arange(n)  # row i of P A P^T is row order[i] of A (SuperLU's perm_c inverted)
            inv = perm
            # the permuted pattern in compressed columns, entries sorted; each matrix entry's slot
            ui, uj = union.tocoo().row.astype(np.int64), union.tocoo().col.astype(np.int64)
            key = np.sort(inv[uj] * n + inv[ui])  # column-major keys of P A P^T
            pcol, prow = np.divmod(key, n)
            indptr = np.searchsorted(pcol, np.arange(n + 1)).astype(np.int32)
            self._csc = (indptr, prow.astype(np.int32))

            def positions(pat):
                r, c = self._coo(pat)
                return np.searchsorted(key, inv[c] * n + inv[r]).astype(np.int64)

            self._perm, self._size = order.astype(np.intp), key.size
            self._kpos, self._mpos = positions(self._kpat), positions(self._mpat)

    # ------------------------------------------------------------------ factorisation
    def factor(self, K, M, sigma: float = 0.0):
        """A factorisation of K − σM with ``.solve`` and ``.nearly_singular()``.

        Parameters
        ----------
        K, M : scipy.sparse.csr_array
            With the workspace's patterns (:meth:`matches`).
        sigma : float
            The shift.

        Returns
        -------
        BandCholesky, CholmodFactor, OrderedLU or scipy.sparse.linalg.SuperLU
            With the SuperLU backend the first call returns SuperLU's own factorisation (and
            chooses the route); with CHOLMOD, a factor through the analysed pattern.

        Raises
        ------
        NotPositiveDefinite
            Band or CHOLMOD route: K − σM is not positive definite.
        RuntimeError
            SuperLU finds the matrix exactly singular.
        """

        with blas_phase(self._phase()):
            return self._factor(K, M, sigma)

    def _phase(self) -> str:
        """The BLAS phase of a factorisation (:mod:`femupdate._threads`): a large band or
        CHOLMOD factor is a dense kernel (every free core); the rest one thread."""
        if self.route == "band" and self.bandwidth is not None and self.n * float(self.bandwidth) ** 2 >= LARGE_FACTOR_OPS:
            return "dense"
        if self.route == "cholmod" and self.n >= LARGE_CHOLMOD:
            return "dense"
        return "solve"

    def _factor(self, K, M, sigma: float):
        self.n_factorisations += 1
        if self.route is None:
            if backend() == "cholmod":
                return self._choose_cholmod(K, M, sigma)
            lu = superlu(K - sigma * M if sigma else K)
            self._choose(int(lu.nnz), lu.perm_c)
            return lu
        if self.route == "cholmod":
            return CholmodFactor.of(self._assemble_cholmod(None, K, M, sigma), self._symbolic)
        assert self._kpos is not None and self._mpos is not None and self._perm is not None
        data = np.zeros(self._size)
        if self.route == "band":
            low = self._kpos >= 0
            data[self._kpos[low]] = K.data[low]
            if sigma:
                lowm = self._mpos >= 0
                data[self._mpos[lowm]] -= sigma * M.data[lowm]
            assert self.bandwidth is not None
            return BandCholesky(data, self.bandwidth, self._perm)
        data[self._kpos] = K.data
        if sigma:
            data[self._mpos] -= sigma * M.data
        assert self._csc is not None
        indptr, indices = self._csc
        return OrderedLU(sp.csc_array((data, indices, indptr), shape=(self.n, self.n)), self._perm)


def factor_name(factor) -> str:
    """What a factorisation is, for reports: ``"band Cholesky"``, ``"CHOLMOD Cholesky"`` or
    ``"SuperLU"``.

    Parameters
    ----------
    factor : object
        A factorisation from :func:`factorize` or :meth:`SparseWorkspace.factor`.

    Returns
    -------
    str
    """
    if isinstance(factor, BandCholesky):
        return "band Cholesky"
    if isinstance(factor, CholmodFactor):
        return "CHOLMOD Cholesky"
    return "SuperLU"


_WORKSPACES: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def workspace_of(model, K, M) -> SparseWorkspace | None:
    """The (cached) workspace of ``model`` for K and M, or None when they do not have the
    pattern the model assembles onto (then nothing is reused).

    Parameters
    ----------
    model : Model
        The key of the cache (weakly held: the workspace goes with the model).
    K, M : scipy.sparse.csr_array
        The model's matrices at some parameter values.

    Returns
    -------
    SparseWorkspace or None
    """
    ws = _WORKSPACES.get(model)
    if ws is None:
        if not (sp.issparse(K) and K.format == "csr" and sp.issparse(M) and M.format == "csr"):
            return None
        ws = SparseWorkspace(K, M)
        _WORKSPACES[model] = ws
    return ws if ws.matches(K, M) else None
