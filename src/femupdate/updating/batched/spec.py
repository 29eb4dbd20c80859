"""The arrays the compiled kernels read, named (no numba here: building them compiles nothing)."""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from ... import rules


class ModelArrays(NamedTuple):
    """A small model in the form the kernels read: dense constant matrices, the updated
    parameters' matrices as COO triplets, the fixed mass factor and the parametrisation."""

    K_const: np.ndarray  #: (n, n) K0 plus the fixed parameters' terms
    kp: np.ndarray  #: (L + 1,) pointers into the COO triplets of the K_j
    ki: np.ndarray
    kj: np.ndarray
    kv: np.ndarray
    M_varies: bool  #: an updated parameter enters M
    M_const: np.ndarray  #: (n, n)
    mp: np.ndarray  #: (L + 1,) pointers into the COO triplets of the M_j
    mi: np.ndarray
    mj: np.ndarray
    mv: np.ndarray
    Cinv: np.ndarray  #: (n, n) inverse Cholesky factor of a fixed M (identity when M varies)
    sptr: np.ndarray  #: (L + 1,) pointers into ``sidx``
    sidx: np.ndarray  #: rows where K_j or M_j is nonzero
    pcode: int  #: parametrisation (:data:`femupdate.rules.PARAMETRISATIONS`)
    pscale: np.ndarray  #: (R, L) |start| of each row, for the relative parametrisation


class DataArrays(NamedTuple):
    """The data sets of a batch: the :class:`~femupdate.updating.problem.Targets` of each,
    concatenated, with per data set its first test mode ``t0``, its number of test modes ``T``,
    of modes to pair among ``nm`` and of residuals ``m``; ``row_ds`` (R,) each row's data set."""

    t0: np.ndarray
    T: np.ndarray
    nm: np.ndarray
    m: np.ndarray
    row_ds: np.ndarray
    lam_e: np.ndarray
    w_lam: np.ndarray
    pptr: np.ndarray
    pos: np.ndarray
    psi_e: np.ndarray
    ref: np.ndarray


class Spec(NamedTuple):
    """Everything a row's evaluation reads: the fields of :class:`ModelArrays`, then those of
    :class:`DataArrays`, then the rules' settings (one flat tuple: numba's parallel loops take
    no nested tuples)."""

    K_const: np.ndarray
    kp: np.ndarray
    ki: np.ndarray
    kj: np.ndarray
    kv: np.ndarray
    M_varies: bool
    M_const: np.ndarray
    mp: np.ndarray
    mi: np.ndarray
    mj: np.ndarray
    mv: np.ndarray
    Cinv: np.ndarray
    sptr: np.ndarray
    sidx: np.ndarray
    pcode: int
    pscale: np.ndarray
    t0: np.ndarray
    T: np.ndarray
    nm: np.ndarray
    m: np.ndarray
    row_ds: np.ndarray
    lam_e: np.ndarray
    w_lam: np.ndarray
    pptr: np.ndarray
    pos: np.ndarray
    psi_e: np.ndarray
    ref: np.ndarray
    scaling: int  #: :data:`femupdate.rules.SCALINGS`
    w_shape: float
    min_mac: float

    @classmethod
    def of(cls, model: ModelArrays, data: DataArrays, scaling: int, w_shape: float, min_mac: float) -> Spec:
        return cls(*model, *data, int(scaling), float(w_shape), float(min_mac))


class Report(NamedTuple):
    """Per row: the error code and the numbers of its message, and the pairs at the row's
    current point (its last accepted evaluation)."""

    code: np.ndarray  #: (R,) int64, 0 = none
    ints: np.ndarray  #: (R, 2) int64
    floats: np.ndarray  #: (R, 2)
    modes: np.ndarray  #: (R, T) bool: test modes concerned
    pairs: np.ndarray  #: (R, T) int64: the model mode of each test mode
    macs: np.ndarray  #: (R, T) the MAC of each pair (NaN without shape)
    eigenvalues: np.ndarray  #: (R, T) the eigenvalue of each pair's model mode


def new_report(R: int, T: int) -> Report:
    T = max(T, 1)
    return Report(np.zeros(R, np.int64), np.zeros((R, 2), np.int64), np.zeros((R, 2)), np.zeros((R, T), np.bool_),
                  np.zeros((R, T), np.int64), np.full((R, T), np.nan), np.full((R, T), np.nan))


def error_message(err: Report, r: int, min_mac: float) -> str:
    """The message of row r's error, as the local route words it."""
    c = int(err.code[r])
    text = rules.message(c, err.ints[r, 0], err.ints[r, 1], err.floats[r, 0], err.floats[r, 1],
                         np.flatnonzero(err.modes[r]), min_mac)
    return f"NumericalError: {text}"

__all__ = ["ModelArrays", "DataArrays", "Spec", "Report", "new_report", "error_message"]
