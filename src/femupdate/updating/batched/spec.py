"""The arrays the compiled kernels read, named (no numba here: building them compiles nothing)."""

from __future__ import annotations

from collections.abc import Sequence
from typing import NamedTuple

import numpy as np

from ... import rules
from ..targets import TARGETS_PER_MODE, TARGETS_PER_POSITION, Targets


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
    pscale: np.ndarray  #: (R, L) ``|start|`` of each row, for the relative parametrisation


class DataSets(NamedTuple):
    """The data sets of a batch: per data set its first test mode ``t0`` in the concatenated
    :class:`~femupdate.updating.problem.Targets`, its numbers of test modes ``T``, of model modes
    paired among ``nm`` and of residuals ``m``; ``row_ds`` (R,) each row's data set."""

    t0: np.ndarray
    T: np.ndarray
    nm: np.ndarray
    m: np.ndarray
    row_ds: np.ndarray


class Spec(NamedTuple):
    """Everything a row's evaluation reads.  ``targets`` are the problem's own
    :class:`~femupdate.updating.problem.Targets` — every data set's, concatenated — so the
    kernels read the measured data in the very layout (and under the very field names) that the
    local route reads: a new field of ``Targets`` is in the kernels' hands without a change here."""

    model: ModelArrays
    sets: DataSets
    targets: Targets
    scaling: int  #: :data:`femupdate.rules.SCALINGS`
    min_mac: float
    pairing: int  #: :data:`femupdate.rules.PAIRINGS`
    close_tol: float  #: relative gap of a group of close modes, which the local route takes (0: none)


def concatenate(targets: Sequence[Targets], row_dataset) -> tuple[DataSets, Targets]:
    """The data sets ``targets`` as one :class:`DataSets` and one concatenated ``Targets``;
    ``row_dataset`` (R,) each row's data set."""
    i64 = (lambda a: np.asarray(a, np.int64))
    p0 = np.cumsum([0] + [t.pos.size for t in targets])[:-1]
    sets = DataSets(i64(np.cumsum([0] + [t.n_test for t in targets])[:-1]), i64([t.n_test for t in targets]),
                    i64([t.nm for t in targets]), i64([t.n_residuals for t in targets]), i64(row_dataset))
    fields: dict = {"pptr": i64(np.concatenate([[0]] + [t.pptr[1:] + a for t, a in zip(targets, p0)])),
                    "nm": int(max((t.nm for t in targets), default=0))}
    for name in TARGETS_PER_MODE + TARGETS_PER_POSITION:
        dtype = np.asarray(getattr(targets[0], name)).dtype if targets else np.dtype(float)
        fields[name] = (np.concatenate([np.asarray(getattr(t, name), dtype) for t in targets]) if targets
                        else np.zeros(0, dtype))
    return sets, Targets(**fields)


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

__all__ = ["ModelArrays", "DataSets", "Spec", "concatenate", "Report", "new_report", "error_message"]
