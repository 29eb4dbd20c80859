"""The arrays the compiled kernels read, named (no numba here: building them compiles nothing)."""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from ... import rules
from ..problem import Targets


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


#: per data set: its first test mode, its numbers of test modes, of modes paired among and of
#: residuals; per row: its data set
_DATASET_FIELDS = [("t0", np.ndarray), ("T", np.ndarray), ("nm", np.ndarray), ("m", np.ndarray),
                   ("row_ds", np.ndarray)]

#: The data sets of a batch: the per-data-set fields above, then every array field of
#: :class:`~femupdate.updating.problem.Targets` (its per-mode and per-position fields, and
#: ``pptr``), concatenated over the data sets — built from ``Targets``' own field names, so a new
#: field of the problem's data reaches the kernels as ``spec.<name>`` without another change here.
DataArrays = NamedTuple("DataArrays", _DATASET_FIELDS + [(f, np.ndarray) for f in Targets._fields if f != "nm"])

#: Everything a row's evaluation reads: the fields of :class:`ModelArrays`, then those of
#: :data:`DataArrays`, then the rules' settings — one flat tuple (numba's parallel loops and its
#: caching handle flat tuples best).
Spec = NamedTuple("Spec", [(f, ModelArrays.__annotations__[f]) for f in ModelArrays._fields]
                  + list(zip(DataArrays._fields, [np.ndarray] * len(DataArrays._fields)))
                  + [("scaling", int), ("min_mac", float)])


def make_spec(model: ModelArrays, data, scaling: int, min_mac: float):
    """The :data:`Spec` of a batch (``scaling`` as :data:`femupdate.rules.SCALINGS`)."""
    return Spec(*model, *data, int(scaling), float(min_mac))


def data_arrays(targets, row_dataset):
    """The data sets ``targets`` (a sequence of :class:`~femupdate.updating.problem.Targets`)
    concatenated as the kernels read them; ``row_dataset`` (R,) each row's data set."""
    i64 = (lambda a: np.asarray(a, np.int64))
    p0 = np.cumsum([0] + [t.pos.size for t in targets])[:-1]
    fields = {
        "t0": i64(np.cumsum([0] + [t.n_test for t in targets])[:-1]), "T": i64([t.n_test for t in targets]),
        "nm": i64([t.nm for t in targets]), "m": i64([t.n_residuals for t in targets]), "row_ds": i64(row_dataset),
        "pptr": i64(np.concatenate([[0]] + [t.pptr[1:] + a for t, a in zip(targets, p0)])),
    }
    for name in Targets.PER_MODE + Targets.PER_POSITION:
        dtype = np.asarray(getattr(targets[0], name)).dtype if targets else float
        fields[name] = np.concatenate([np.asarray(getattr(t, name), dtype) for t in targets]) if targets \
            else np.zeros(0, dtype)
    return DataArrays(**fields)


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

__all__ = ["ModelArrays", "DataArrays", "Spec", "make_spec", "data_arrays", "Report", "new_report", "error_message"]
