"""MKL PARDISO's sparse Cholesky, called through ctypes on the ``mkl`` wheel's runtime library.

PARDISO (Intel oneMKL) factorises a real symmetric positive definite matrix (its matrix type 2)
from the upper triangle in compressed rows, with a nested-dissection ordering (METIS) and dense
supernodal kernels (MKL's BLAS).  It is called in its three phases, so that the analysis of a
pattern (ordering, symbolic factor: phase 11) is made once and every later factorisation with new
values is a numeric one (phase 22), as with CHOLMOD; solves are phase 33.  The ``mkl`` wheel
installs with pip alone (no system headers) on x86_64, where ``pip install femupdate`` brings it
(an environment marker); :func:`available` says whether the runtime library can be loaded.

A handle (:class:`PardisoHandle`) owns PARDISO's internal memory for one pattern; it is released
when the handle is collected.  Threads: PARDISO runs on MKL's OpenMP threads, as many as the BLAS
phase of :mod:`femupdate._threads` that the calling thread is in gives (set thread-locally for
each call, so a phase entered before MKL was loaded holds too); outside a phase, MKL's own
setting (threadpoolctl controls MKL as a BLAS).
"""

from __future__ import annotations

import ctypes
import glob
import os
import site
import sys
import threading

import numpy as np
import scipy.sparse as sp

__all__ = ["available", "PardisoHandle", "PardisoError", "load"]

_LIB: object = None  # the loaded mkl_rt (ctypes.CDLL), False when it cannot be loaded
_LOCK = threading.Lock()

#: PARDISO's matrix type of a real symmetric positive definite matrix
SPD = 2


class PardisoError(RuntimeError):
    """PARDISO returned an error code other than a non-positive pivot."""

    def __init__(self, phase: int, code: int):
        self.phase, self.code = phase, code
        super().__init__(f"PARDISO failed in phase {phase} with error {code}")


def _candidates() -> list[str]:
    """Where the ``mkl`` wheel puts its runtime library: ``lib/`` of the environment's prefix or
    of the user's site."""
    found = []
    for prefix in (sys.prefix, sys.base_prefix, site.getuserbase()):
        found += sorted(glob.glob(os.path.join(prefix, "lib", "libmkl_rt.so*")), key=len)
    return found


def load():
    """The MKL runtime library (``libmkl_rt``), or None when it is not installed or not loadable
    (not x86_64 Linux, or the ``mkl`` wheel missing)."""
    global _LIB
    if _LIB is None:
        with _LOCK:
            if _LIB is None:
                lib = None
                for path in _candidates():
                    try:
                        lib = ctypes.CDLL(path)
                        lib.pardiso  # noqa: B018 - the symbol must be there
                    except (OSError, AttributeError):
                        lib = None
                        continue
                    break
                if lib is not None:
                    _declare(lib)
                    from .. import _threads

                    _threads.forget_libraries()  # threadpoolctl must see MKL from now on
                _LIB = lib if lib is not None else False
    return _LIB or None


def available() -> bool:
    """Whether MKL PARDISO can be loaded."""
    return load() is not None


def _declare(lib) -> None:
    i32p = ctypes.POINTER(ctypes.c_int32)
    lib.pardiso.argtypes = [ctypes.c_void_p, i32p, i32p, i32p, i32p, i32p, ctypes.c_void_p, ctypes.c_void_p,
                            ctypes.c_void_p, ctypes.c_void_p, i32p, ctypes.c_void_p, i32p, ctypes.c_void_p,
                            ctypes.c_void_p, i32p]
    lib.pardiso.restype = None
    lib.pardiso_getdiag.argtypes = [ctypes.c_void_p, ctypes.c_void_p, ctypes.c_void_p, i32p, i32p]
    lib.pardiso_getdiag.restype = None
    lib.MKL_Set_Num_Threads_Local.argtypes = [ctypes.c_int]
    lib.MKL_Set_Num_Threads_Local.restype = ctypes.c_int


def _iparm() -> np.ndarray:
    """PARDISO's control parameters (0-based indices of the manual's iparm(1..64))."""
    iparm = np.zeros(64, dtype=np.int32)
    iparm[0] = 1    # these values, not the defaults
    iparm[1] = 2    # nested dissection (METIS)
    iparm[7] = 0    # iterative refinement: none unless pivots were perturbed (never for type 2)
    iparm[9] = 13   # pivot perturbation 1e-13 (only for indefinite types)
    iparm[10] = 0   # no scaling (symmetric matrices)
    iparm[12] = 0   # no weighted matching
    iparm[17] = -1  # report the entries of the factor
    iparm[20] = 1   # Bunch-Kaufman pivoting (indefinite types only)
    iparm[23] = 0   # classic factorisation
    iparm[26] = 0   # no matrix checker (the layer hands sorted, upper-triangular rows)
    iparm[27] = 0   # double precision
    iparm[34] = 1   # zero-based indices
    iparm[55] = 1   # keep the factor's diagonal for pardiso_getdiag
    return iparm


class PardisoHandle:
    """PARDISO's analysis of one pattern (real symmetric positive definite, upper triangle in
    compressed rows), its current numeric factor and its solves.

    Parameters
    ----------
    indptr, indices : numpy.ndarray of int
        The upper triangle's compressed rows (sorted column indices, the diagonal stored).

    Raises
    ------
    PardisoError
        The analysis failed (out of memory, or a pattern PARDISO refuses).
    """

    def __init__(self, indptr: np.ndarray, indices: np.ndarray):
        lib = load()
        if lib is None:
            raise ImportError("MKL PARDISO is not available (the mkl package)")
        self._lib = lib
        self.n = int(indptr.size - 1)
        self.indptr = np.ascontiguousarray(indptr, dtype=np.int32)
        self.indices = np.ascontiguousarray(indices, dtype=np.int32)
        self.pt = np.zeros(64, dtype=np.int64)
        self.iparm = _iparm()
        self.perm = np.zeros(1, dtype=np.int32)
        self.data = np.zeros(self.indices.size)
        self._factored = False
        self.lock = threading.Lock()
        self.owner: object = None  # which factor's values the handle holds (femupdate.workspace.factors)
        code = self._call(11, self.data, None, 0)
        if code:
            raise PardisoError(11, code)

    @property
    def nnz_factor(self) -> int:
        """Entries of the factor L (from the analysis)."""
        return int(self.iparm[17])

    def _call(self, phase: int, data: np.ndarray, b, nrhs: int, x=None) -> int:
        """One PARDISO call, on the threads of the BLAS phase the calling thread is in (MKL's
        thread-local setting, for the call only: MKL may have been loaded inside the phase)."""
        from .._threads import phase_threads

        threads = phase_threads()
        if threads is None:
            return self._pardiso(phase, data, b, nrhs, x)
        before = self._lib.MKL_Set_Num_Threads_Local(int(threads))
        try:
            return self._pardiso(phase, data, b, nrhs, x)
        finally:
            self._lib.MKL_Set_Num_Threads_Local(before)

    def _pardiso(self, phase: int, data: np.ndarray, b, nrhs: int, x) -> int:
        err = ctypes.c_int32(0)
        one = ctypes.c_int32(1)
        dummy = np.zeros(1)
        self._lib.pardiso(self.pt.ctypes.data, ctypes.byref(one), ctypes.byref(one), ctypes.byref(ctypes.c_int32(SPD)),
                          ctypes.byref(ctypes.c_int32(phase)), ctypes.byref(ctypes.c_int32(self.n)), data.ctypes.data,
                          self.indptr.ctypes.data, self.indices.ctypes.data, self.perm.ctypes.data,
                          ctypes.byref(ctypes.c_int32(max(nrhs, 1))), self.iparm.ctypes.data, ctypes.byref(ctypes.c_int32(0)),
                          (dummy if b is None else b).ctypes.data, (dummy if x is None else x).ctypes.data,
                          ctypes.byref(err))
        return int(err.value)

    def factor(self, data: np.ndarray) -> None:
        """Numeric factorisation (phase 22) of the matrix with these values on the pattern.

        Raises
        ------
        ArithmeticError
            A pivot is not positive (the matrix is not positive definite); PARDISO's code -4.
        PardisoError
            Any other failure.
        """
        self.data = np.ascontiguousarray(data, dtype=float)
        self._factored = False
        code = self._call(22, self.data, None, 0)
        if code == -4:
            raise ArithmeticError(f"not positive definite (non-positive pivot at equation {int(self.iparm[29])})")
        if code:
            raise PardisoError(22, code)
        self._factored = True

    def solve(self, B: np.ndarray) -> np.ndarray:
        """A⁻¹ B for real ``B`` of shape ``(n,)`` or ``(n, k)`` (phase 33)."""
        if not self._factored:
            raise RuntimeError("PARDISO: solve before a successful factorisation")
        B = np.asarray(B, dtype=float)
        nrhs = 1 if B.ndim == 1 else B.shape[1]
        b = np.asfortranarray(B)
        x = np.empty_like(b, order="F")
        code = self._call(33, self.data, b, nrhs, x)
        if code:
            raise PardisoError(33, code)
        return np.ascontiguousarray(x)

    def diagonal(self) -> np.ndarray:
        """The diagonal of the factorised matrix as PARDISO keeps it (the pivots)."""
        df, da = np.zeros(self.n), np.zeros(self.n)
        err = ctypes.c_int32(0)
        self._lib.pardiso_getdiag(self.pt.ctypes.data, df.ctypes.data, da.ctypes.data, ctypes.byref(ctypes.c_int32(1)),
                                  ctypes.byref(err))
        if err.value:
            raise PardisoError(-1, int(err.value))
        return df

    def __del__(self):
        try:
            if getattr(self, "pt", None) is not None and self.pt.any():
                self._call(-1, self.data, None, 0)
        except Exception:  # pragma: no cover - interpreter shutdown
            pass


def upper_pattern(A) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The upper triangle of A (sparse, symmetric) in compressed rows: ``(indptr, indices, data)``,
    every diagonal entry stored (an explicit zero where A has none)."""
    A = sp.coo_array(A)
    n = A.shape[0]
    up = A.row <= A.col
    rows = np.concatenate([A.row[up], np.arange(n)]).astype(np.int64)
    cols = np.concatenate([A.col[up], np.arange(n)]).astype(np.int64)
    vals = np.concatenate([A.data[up], np.zeros(n)])
    key = rows * n + cols
    order = np.argsort(key, kind="stable")
    key, vals = key[order], vals[order]
    first = np.concatenate([[True], key[1:] != key[:-1]])
    data = np.add.reduceat(vals, np.flatnonzero(first))  # duplicates summed
    r, c = np.divmod(key[first], n)
    indptr = np.searchsorted(r, np.arange(n + 1)).astype(np.int32)
    return indptr, c.astype(np.int32), data
