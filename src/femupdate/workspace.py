r"""What the sparse eigen-solutions of one model share from one evaluation to the next.

Updating a large model solves :math:`K(p)\phi = \lambda M(p)\phi` at many parameter values p,
start after start and iteration after iteration.  The values change; the sparsity pattern does
not: :class:`~femupdate.Model` assembles K(p) and M(p) onto the union pattern of its matrices
(:attr:`Model._pattern`) whatever p.  A :class:`SparseWorkspace` keeps what depends on that
pattern only, found once per model:

* **the route and the ordering.**  At its first factorisation the workspace factorises K − σM
  with SuperLU (:func:`femupdate.modal.factorize`, a minimum-degree ordering of A + Aᵀ) and
  compares the fill with the storage of a *band* Cholesky factor in a bandwidth-reducing ordering
  (reverse Cuthill–McKee or the given order, whichever is narrower).  A frame building, slender
  in plan, has a narrow band: its band factor (LAPACK ``pbtrf``) stores no more than SuperLU's
  L + U, runs on dense kernels, and is about seven times faster (2,304 dofs: 4.5 ms against
  32 ms).  When the band holds at most SuperLU's fill the workspace takes the band route; else it
  keeps SuperLU with its fill-reducing ordering, applied once to the pattern (SciPy's SuperLU
  cannot keep a symbolic factorisation, but it takes a pre-permuted matrix in its natural order,
  which skips the ordering).  The choice depends on the pattern alone (not on a timing), so runs
  are reproducible.
* **the scatter maps.**  Where each stored entry of K and of M lands in the factorised storage
  (the band, or the permuted compressed columns): K − σM is one ``zeros`` and two indexed stores.

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
stable LU or Cholesky): the band route and SuperLU give the same eigenpairs to round-off.
"""

from __future__ import annotations

import functools
import weakref

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from scipy.linalg import blas, lapack
from scipy.sparse.csgraph import reverse_cuthill_mckee

__all__ = ["SparseWorkspace", "BandCholesky", "OrderedLU", "NotPositiveDefinite", "workspace_of"]

#: band storage of at most this many entries (80 MB) is considered at all
MAX_BAND_ENTRIES = 10_000_000


class NotPositiveDefinite(ArithmeticError):
    """The band Cholesky factorisation met a non-positive pivot: K − σM is not positive
    definite (σ is not below the lowest eigenvalue)."""


PIVOT_THRESHOLD = 0.1  # SuperLU symmetric mode: off-diagonal pivot only below this fraction


def factorize(A):
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
    lu : scipy.sparse.linalg.SuperLU
        A factorisation from :func:`factorize`.

    Returns
    -------
    bool
        True if ``min |U_ii| <= 1e-11 max |U_ii|``.
    """
    U = lu.U
    piv = np.abs(U.diagonal())
    del U
    return bool(piv.min() <= 1e-11 * piv.max())


def nearly_singular_pivots(piv: np.ndarray) -> bool:
    """Whether the smallest pivot magnitude is at most 1e-11 times the largest (as
    :func:`femupdate.modal.nearly_singular`)."""
    piv = np.abs(piv)
    return bool(piv.min() <= 1e-11 * piv.max())


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

    Attributes
    ----------
    route : str or None
        ``"band"`` or ``"superlu"`` once the first factorisation has chosen (None before).
    bandwidth : int or None
        Half-bandwidth of the band ordering (once computed).
    n_factorisations : int
        Factorisations made through the workspace.
    """

    def __init__(self, K, M):
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
        self._csc: tuple[np.ndarray, np.ndarray] | None = None  # (indptr, indices) of P A P^T

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
    def _choose(self, fill: int, perm_c: np.ndarray) -> None:
        """Band if its storage is at most SuperLU's fill ``fill``; else SuperLU in ``perm_c``."""
        union = self._union()
        n = self.n
        natural = np.arange(n)
        b_nat = _bandwidth(union, natural)
        perm, b = natural, b_nat
        if (b + 1) * n > fill:  # the given order is too wide: try reverse Cuthill-McKee
            rcm = np.asarray(reverse_cuthill_mckee(union, symmetric_mode=True), dtype=np.int64)
            b_rcm = _bandwidth(union, rcm)
            if b_rcm < b:
                perm, b = rcm, b_rcm
        if (b + 1) * n <= min(fill, MAX_BAND_ENTRIES):
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
        BandCholesky, OrderedLU or scipy.sparse.linalg.SuperLU
            The first call returns SuperLU's own factorisation (and chooses the route).

        Raises
        ------
        NotPositiveDefinite
            Band route: K − σM is not positive definite.
        RuntimeError
            SuperLU finds the matrix exactly singular.
        """

        self.n_factorisations += 1
        if self.route is None:
            lu = factorize(K - sigma * M if sigma else K)
            self._choose(int(lu.nnz), lu.perm_c)
            return lu
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
