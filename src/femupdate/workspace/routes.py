"""The routes of a workspace: band Cholesky, CHOLMOD and ordered SuperLU, each owning what it keeps
from one factorisation of K − σM to the next, and the chooser that takes one (:func:`choose_route`).

Every route is made once per sparsity pattern (:class:`Pattern`) and then factorises K − σM for
new values and shifts by scattering K's and M's stored entries into its own storage (each entry's
slot found once):

* :class:`BandRoute` — LAPACK's band storage in a bandwidth-reducing ordering (its factor:
  :class:`~femupdate.workspace.band.BandCholesky`);
* :class:`CholmodRoute` — the compressed columns of K − σM and CHOLMOD's symbolic analysis of
  them, refactorised with the new values (:class:`~femupdate.workspace.factors.CholmodFactor`);
* :class:`PardisoRoute` — the upper triangle of K − σM in compressed rows and MKL PARDISO's
  analysis of it, made once per thread, refactorised with the new values
  (:class:`~femupdate.workspace.factors.PardisoFactor`);
* :class:`SuperLURoute` — the compressed columns of P(K − σM)Pᵀ in SuperLU's fill-reducing
  ordering P, factorised in that natural order
  (:class:`~femupdate.workspace.factors.OrderedLU`).
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from typing import Protocol

import numpy as np
import scipy.sparse as sp

from .band import BandCholesky, band_order
from .factors import CholmodFactor, Factor, OrderedLU, PardisoFactor, SuperLUFactor, superlu

__all__ = ["Route", "Pattern", "BandRoute", "CholmodRoute", "PardisoRoute", "SuperLURoute", "choose_route", "band_wins",
           "MAX_BAND_ENTRIES", "BAND_EFFICIENCY", "PARDISO_BAND_EFFICIENCY", "LARGE_FACTOR_OPS", "LARGE_CHOLMOD"]

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

#: the same for MKL PARDISO's Cholesky, whose kernels run near the processor's peak like the band's.
#: Measured (benchmarks/bench_factor.py --candidates, one thread), the band and PARDISO break even
#: where n b² is 1.4 (solid), 1.7 (frame tower) and 3-4 (MITC4 plates) times nnz(L)²/n; 1 errs
#: towards PARDISO, which also holds a fifth of the band's memory
PARDISO_BAND_EFFICIENCY = 1.0

#: a band factorisation of at least this many operations (n b²), or a CHOLMOD one of at least
#: :data:`LARGE_CHOLMOD` dofs, is a "dense" phase of the BLAS policy (femupdate._threads)
LARGE_FACTOR_OPS = 2e9
LARGE_CHOLMOD = 50_000


def band_wins(n: int, b: int, nnz_l: int, efficiency: float = BAND_EFFICIENCY) -> bool:
    """Whether the band Cholesky of half-bandwidth ``b`` is expected to be faster than a sparse
    Cholesky factor with ``nnz_l`` entries in L.

    Operation counts: the band's is about n b² (``(b + 1) n`` stored entries, each updated ~b
    times); a sparse factor's Σ_j c_j² over its column counts c_j, at least nnz_l²/n (equal
    counts), which is the estimate used.  The band is taken when its count is at most
    ``efficiency`` times the sparse one and its storage at most :data:`MAX_BAND_ENTRIES`.

    Parameters
    ----------
    n : int
        Order of the matrix.
    b : int
        Half-bandwidth in the band ordering.
    nnz_l : int
        Entries of the sparse factor's L (for SuperLU's L + U: about half of its ``nnz`` + n).
    efficiency : float
        How many times faster the band runs per operation: :data:`BAND_EFFICIENCY` against CHOLMOD
        or SuperLU (the default), :data:`PARDISO_BAND_EFFICIENCY` against PARDISO.

    Returns
    -------
    bool
    """
    storage = (b + 1) * n
    return storage <= MAX_BAND_ENTRIES and storage * float(b) <= efficiency * float(nnz_l) ** 2 / n


class Route(Protocol):
    """What a workspace asks of its route.

    Attributes
    ----------
    name : str
        ``"band"``, ``"cholmod"`` or ``"superlu"``.
    bandwidth : int
        Half-bandwidth of the band ordering (computed for every route, reported).
    """

    name: str
    bandwidth: int

    def factor(self, K, M, sigma: float) -> Factor:
        """The factorisation of K − σM (K, M with the route's pattern)."""

    def phase(self) -> str:
        """The BLAS phase of a factorisation (:mod:`femupdate._threads`)."""


class Pattern:
    """The compressed-row patterns of K and M that a workspace serves (their values are not kept).

    Parameters
    ----------
    K, M : scipy sparse matrix, shape ``(n, n)``
    """

    def __init__(self, K, M):
        K, M = sp.csr_array(K), sp.csr_array(M)
        self.n = K.shape[0]
        self.k = (K.indptr.copy(), K.indices.copy())
        self.m = (M.indptr.copy(), M.indices.copy())

    def matches(self, K, M) -> bool:
        """True when K and M are CSR arrays with exactly these patterns."""
        for A, (indptr, indices) in ((K, self.k), (M, self.m)):
            if not (sp.issparse(A) and A.format == "csr" and A.shape == (self.n, self.n)
                    and A.indptr.size == indptr.size and A.indices.size == indices.size
                    and np.array_equal(A.indptr, indptr) and np.array_equal(A.indices, indices)):
                return False
        return True

    def coo(self, pat) -> tuple[np.ndarray, np.ndarray]:
        """Rows and columns of the stored entries of ``pat`` (:attr:`k` or :attr:`m`)."""
        indptr, indices = pat
        rows = np.repeat(np.arange(self.n, dtype=np.int64), np.diff(indptr))
        return rows, indices.astype(np.int64)

    def union(self) -> sp.csr_array:
        """The union of the two patterns (ones), duplicates summed."""
        (kr, kc), (mr, mc) = self.coo(self.k), self.coo(self.m)
        ones = np.ones(kr.size + mr.size)
        A = sp.csr_array((ones, (np.concatenate([kr, mr]), np.concatenate([kc, mc]))), shape=(self.n, self.n))
        A.sum_duplicates()
        return A


class BandRoute:
    """Band Cholesky in ordering ``perm`` of half-bandwidth ``b``: each stored entry's slot in the
    lower band (entries above the diagonal are left out).

    Parameters
    ----------
    pattern : Pattern
    perm : numpy.ndarray of int
        Row i of the ordered matrix is row ``perm[i]`` of K.
    b : int
        Half-bandwidth in that ordering.
    """

    name = "band"

    def __init__(self, pattern: Pattern, perm: np.ndarray, b: int):
        n = pattern.n
        inv = np.empty_like(perm)
        inv[perm] = np.arange(n)

        def slots(pat):
            r, c = pattern.coo(pat)
            i, j = inv[r], inv[c]
            lower = i >= j
            return lower, (i - j)[lower] + (b + 1) * j[lower]

        self.n, self.bandwidth = n, b
        self.perm = perm.astype(np.intp)
        self.size = (b + 1) * n
        self.k_lower, self.k_slots = slots(pattern.k)
        self.m_lower, self.m_slots = slots(pattern.m)

    def factor(self, K, M, sigma: float) -> BandCholesky:
        data = np.zeros(self.size)
        data[self.k_slots] = K.data[self.k_lower]
        if sigma:
            data[self.m_slots] -= sigma * M.data[self.m_lower]
        return BandCholesky(data, self.bandwidth, self.perm)

    def phase(self) -> str:
        """A large band factor (at least :data:`LARGE_FACTOR_OPS` operations) is a dense kernel."""
        return "dense" if self.n * float(self.bandwidth) ** 2 >= LARGE_FACTOR_OPS else "solve"


class _Columns:
    """K − σM in compressed columns of a fixed pattern, P(K − σM)Pᵀ for an ordering P: the
    pattern's sorted column-major keys and each stored entry's slot, found once.

    Parameters
    ----------
    pattern : Pattern
    union : scipy sparse matrix
        The union of the patterns (:meth:`Pattern.union`).
    inv : numpy.ndarray of int
        Row i of K goes to row ``inv[i]`` (the identity: K − σM itself).
    """

    def __init__(self, pattern: Pattern, union, inv: np.ndarray):
        n = self.n = pattern.n
        coo = union.tocoo()
        key = np.sort(inv[coo.col.astype(np.int64)] * n + inv[coo.row.astype(np.int64)])
        pcol, prow = np.divmod(key, n)
        self.indptr = np.searchsorted(pcol, np.arange(n + 1)).astype(np.int32)
        self.indices = prow.astype(np.int32)

        def slots(pat):
            r, c = pattern.coo(pat)
            return np.searchsorted(key, inv[c] * n + inv[r]).astype(np.int64)

        self.k_slots, self.m_slots = slots(pattern.k), slots(pattern.m)

    def assemble(self, K, M, sigma: float) -> sp.csc_array:
        data = np.zeros(self.indices.size)
        data[self.k_slots] = K.data
        if sigma:
            data[self.m_slots] -= sigma * M.data
        return sp.csc_array((data, self.indices, self.indptr), shape=(self.n, self.n))


class CholmodRoute:
    """CHOLMOD's supernodal Cholesky, its analysis of the pattern (ordering, supernodes) made once
    and every factorisation a numeric one with the new values.

    Made by :meth:`analyse` with the first factorisation.
    """

    name = "cholmod"

    def __init__(self, columns: _Columns, symbolic, bandwidth: int):
        self.columns, self.symbolic, self.bandwidth = columns, symbolic, bandwidth

    @classmethod
    def analyse(cls, pattern: Pattern, bandwidth: int, K, M, sigma: float) -> tuple[CholmodRoute, CholmodFactor]:
        """The route for ``pattern`` and its first factorisation, of K − σM.

        Raises
        ------
        NotPositiveDefinite
            K − σM is not positive definite.
        """
        columns = _Columns(pattern, pattern.union(), np.arange(pattern.n, dtype=np.int64))
        A = columns.assemble(K, M, sigma)
        symbolic = CholmodFactor.analyse(A)
        first = CholmodFactor.of(A, symbolic)
        return cls(columns, symbolic, bandwidth), first

    def factor(self, K, M, sigma: float) -> CholmodFactor:
        return CholmodFactor.of(self.columns.assemble(K, M, sigma), self.symbolic)

    def phase(self) -> str:
        """A factor of at least :data:`LARGE_CHOLMOD` dofs is a dense kernel."""
        return "dense" if self.columns.n >= LARGE_CHOLMOD else "solve"


class _Upper:
    """K − σM's upper triangle in compressed rows of a fixed pattern (every diagonal entry stored),
    and the slot of each stored entry of K and M on or above the diagonal, found once."""

    def __init__(self, pattern: Pattern, union):
        from .pardiso import upper_pattern

        n = self.n = pattern.n
        self.indptr, self.indices, _ = upper_pattern(union)
        key = np.repeat(np.arange(n, dtype=np.int64) * n, np.diff(self.indptr)) + self.indices

        def slots(pat):
            pr, pc = pattern.coo(pat)
            keep = pr <= pc
            return keep, np.searchsorted(key, pr[keep] * n + pc[keep])

        self.k_keep, self.k_slots = slots(pattern.k)
        self.m_keep, self.m_slots = slots(pattern.m)

    def assemble(self, K, M, sigma: float) -> np.ndarray:
        data = np.zeros(self.indices.size)
        data[self.k_slots] = K.data[self.k_keep]
        if sigma:
            data[self.m_slots] -= sigma * M.data[self.m_keep]
        return data


class PardisoRoute:
    """MKL PARDISO's supernodal Cholesky: its analysis of the pattern (nested-dissection ordering,
    symbolic factor) made once per thread, every factorisation a numeric one with the new values.

    Made by :meth:`analyse` with the first factorisation.
    """

    name = "pardiso"

    def __init__(self, upper: _Upper, handle, bandwidth: int):
        self.upper, self.bandwidth = upper, bandwidth
        self._local = threading.local()
        self._local.handle = handle

    def _handle(self):
        handle = getattr(self._local, "handle", None)
        if handle is None:  # a thread of its own: an analysis of its own
            from .pardiso import PardisoHandle

            handle = self._local.handle = PardisoHandle(self.upper.indptr, self.upper.indices)
        return handle

    @classmethod
    def analyse(cls, pattern: Pattern, bandwidth: int, K, M, sigma: float,
                union=None) -> tuple[PardisoRoute, PardisoFactor]:
        """The route for ``pattern`` and its first factorisation, of K − σM (``union``: the
        pattern's union, when made already).

        Raises
        ------
        NotPositiveDefinite
            K − σM is not positive definite.
        """
        from .pardiso import PardisoHandle

        upper = _Upper(pattern, pattern.union() if union is None else union)
        handle = PardisoHandle(upper.indptr, upper.indices)
        first = PardisoFactor(handle, upper.assemble(K, M, sigma))
        return cls(upper, handle, bandwidth), first

    def factor(self, K, M, sigma: float) -> PardisoFactor:
        return PardisoFactor(self._handle(), self.upper.assemble(K, M, sigma))

    def phase(self) -> str:
        """A factor of at least :data:`LARGE_CHOLMOD` dofs is a dense kernel."""
        return "dense" if self.upper.n >= LARGE_CHOLMOD else "solve"


class SuperLURoute:
    """SuperLU in a fill-reducing ordering found once (SuperLU's own for the first factorisation):
    SciPy's SuperLU cannot keep a symbolic factorisation, but takes the permuted matrix in its
    natural order.

    Parameters
    ----------
    pattern : Pattern
    union : scipy sparse matrix
        The union of the patterns.
    perm_c : numpy.ndarray of int
        SuperLU's column ordering (``SuperLU.perm_c``) of the first factorisation.
    bandwidth : int
        Half-bandwidth of the band ordering (reported).
    """

    name = "superlu"

    def __init__(self, pattern: Pattern, union, perm_c: np.ndarray, bandwidth: int):
        inv = np.asarray(perm_c, dtype=np.int64)
        order = np.empty_like(inv)
        order[inv] = np.arange(pattern.n)  # row i of P A P^T is row order[i] of A (SuperLU's perm_c inverted)
        self.columns = _Columns(pattern, union, inv)
        self.perm = order.astype(np.intp)
        self.bandwidth = bandwidth

    def factor(self, K, M, sigma: float) -> OrderedLU:
        return OrderedLU(self.columns.assemble(K, M, sigma), self.perm)

    def phase(self) -> str:
        return "solve"


def _band_chosen(prefer: str | None, n: int, b: int, nnz_l: Callable[[], int],
                 efficiency: float = BAND_EFFICIENCY) -> bool:
    if prefer == "sparse" or (b + 1) * n > MAX_BAND_ENTRIES:
        return False
    return prefer == "band" or band_wins(n, b, nnz_l(), efficiency)


def choose_route(pattern: Pattern, K, M, sigma: float, backend: str, prefer: str | None) -> tuple[Route, Factor]:
    """The route for ``pattern``, and the first factorisation of K − σM, which chose it.

    The backend's sparse factor is made first (CHOLMOD, PARDISO: the pattern analysed; SuperLU: its
    fill-reducing ordering found); its fill is then compared with a band Cholesky factor in the
    narrower of the given and the reverse Cuthill–McKee orderings by their operation counts
    (:func:`band_wins`, with the band's efficiency against that backend).

    Parameters
    ----------
    pattern : Pattern
    K, M : scipy.sparse.csr_array
        With ``pattern``.
    sigma : float
        The shift of the first factorisation.
    backend : {"cholmod", "pardiso", "superlu"}
        The sparse backend (:func:`femupdate.workspace.backend`).
    prefer : {None, "band", "sparse"}
        None: by :func:`band_wins`; else that route imposed (the band only within
        :data:`MAX_BAND_ENTRIES`).

    Returns
    -------
    route : Route
    first : Factor
        The backend's factorisation of K − σM.

    Raises
    ------
    NotPositiveDefinite
        CHOLMOD or PARDISO backend: K − σM is not positive definite (no route chosen).
    RuntimeError
        SuperLU finds K − σM exactly singular (no route chosen).
    """
    n = pattern.n
    if backend in ("cholmod", "pardiso"):
        union = pattern.union()
        perm, b = band_order(sp.csc_array(union), n)
        sparse_route: Route
        first: Factor
        if backend == "cholmod":
            sparse_route, first = CholmodRoute.analyse(pattern, b, K, M, sigma)
        else:
            sparse_route, first = PardisoRoute.analyse(pattern, b, K, M, sigma, union)
        efficiency = BAND_EFFICIENCY if backend == "cholmod" else PARDISO_BAND_EFFICIENCY
        if _band_chosen(prefer, n, b, lambda: first.nnz, efficiency):
            return BandRoute(pattern, perm, b), first
        return sparse_route, first
    lu = superlu(K - sigma * M if sigma else K)
    union = pattern.union()
    perm, b = band_order(union, n)
    if _band_chosen(prefer, n, b, lambda: (int(lu.nnz) + n) // 2):
        return BandRoute(pattern, perm, b), SuperLUFactor(lu)
    return SuperLURoute(pattern, union, lu.perm_c, b), SuperLUFactor(lu)
