"""The band route's factor: Cholesky in LAPACK's band storage, with blocked multi-column solves,
and the bandwidth-reducing ordering it is made in."""

from __future__ import annotations

import functools

import numpy as np
import scipy.sparse as sp
from scipy.linalg import blas, lapack
from scipy.sparse.csgraph import reverse_cuthill_mckee

from .factors import NotPositiveDefinite, nearly_singular_pivots

__all__ = ["BandCholesky", "band_order", "BLOCKED_MIN_COLUMNS", "BLOCKED_MIN_BANDWIDTH"]


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

    name = "band Cholesky"

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


def _bandwidth(pattern: sp.csr_array, perm: np.ndarray) -> int:
    inv = np.empty_like(perm)
    inv[perm] = np.arange(perm.size)
    coo = pattern.tocoo()
    return int(np.max(np.abs(inv[coo.row] - inv[coo.col]), initial=0))


def band_order(union, n: int) -> tuple[np.ndarray, int]:
    """The narrower of the given order and reverse Cuthill–McKee for the symmetric pattern
    ``union`` (n × n), and its half-bandwidth.

    Returns
    -------
    perm : numpy.ndarray of int
        Row i of the ordered matrix is row ``perm[i]`` of the given one.
    b : int
        Half-bandwidth in that order.
    """
    natural = np.arange(n)
    perm, b = natural, _bandwidth(union, natural)
    rcm = np.asarray(reverse_cuthill_mckee(sp.csr_array(union), symmetric_mode=True), dtype=np.int64)
    b_rcm = _bandwidth(union, rcm)
    if b_rcm < b:
        perm, b = rcm, b_rcm
    return perm, b
