"""Work units of a uniqueness study: the (noisy) test data of a case, the batch solution of one
unit (:func:`solve_unit`) and the per-start reference route (:func:`reference_unit`)."""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from ..._docs import shared_docs
from ..._errors import FemupdateError
from ...updating.batched import FAILED
from .definition import Study

#: the case and noise level of a unit of the study (femupdate._docs)
_CASE = """\
study : Study
    The study.
c : int
    Case index (0-based).
level : int, default 0
    Index into ``study.levels`` (0: noise-free)."""


def _unit(shape):
    """Unit length, sign of the largest entry positive (``scaled_shape(..., "unit")``)."""
    k = np.argmax(np.abs(shape), axis=0)
    s = np.sign(shape[k, np.arange(shape.shape[1])]) * np.linalg.norm(shape, axis=0)
    return shape / s


@shared_docs(CASE=_CASE)
def case_data(study: Study, c: int, level: int = 0, starts=slice(None), modes=None):
    """Test data of case ``c`` for the starts ``starts`` at noise level ``level``.

    The truth's lowest ``n_modes`` eigenvalues and its shapes at the case's measured dofs (unit
    length, largest entry positive).  With noise σ, eigenvalues × (1 + σε) and shapes + σε (ε standard
    normal, drawn per start from the seed ``[study.seed, c, level]``), then rescaled to unit length.

    Parameters
    ----------
    {{CASE}}
    starts : slice or array_like of int, default ``slice(None)``
        Which starts (rows of the result).
    modes : Modes, optional
        The truth's modes, if at hand (default: computed).

    Returns
    -------
    lam : ndarray, shape ``(R', m)``
        Eigenvalues (rad²/s²), R' the number of selected starts.
    psi : ndarray, shape ``(R', n, m)``
        Unit-length shapes at the case's n measured dofs (identical rows when noise-free).
    """
    from ...modal import model_modes

    case = study.cases[c]
    mm = modes if modes is not None else model_modes(study.model, study.truth)
    pos = study.model.dof_index(case.measured_dofs)
    m, n = case.n_modes, case.n_measured
    lam0 = mm.eigenvalues[:m]
    psi0 = _unit(mm.shapes[pos][:, :m])
    idx = np.arange(study.n_starts)[starts]
    if level == 0:
        return np.tile(lam0, (idx.size, 1)), np.tile(psi0, (idx.size, 1, 1))
    sigma = study.levels[level]
    eps = np.random.default_rng([study.seed, c, level]).standard_normal((study.n_starts, m * (1 + n)))[idx]
    lam = lam0 * (1.0 + sigma * eps[:, :m])
    psi = psi0[None] + sigma * eps[:, m:].reshape(idx.size, n, m)
    k = np.argmax(np.abs(psi), axis=1)
    s = np.sign(np.take_along_axis(psi, k[:, None, :], axis=1)) * np.linalg.norm(psi, axis=1, keepdims=True)
    return lam, psi / s


@shared_docs(CASE=_CASE)
def case_testdata(study: Study, c: int, level: int = 0, start: int = 0, modes=None):
    """The :class:`~femupdate.testdata.TestData` of case ``c`` as seen by start ``start``.

    Parameters
    ----------
    {{CASE}}
    start : int, default 0
        The start whose noise realisation is taken.
    modes : Modes, optional
        The truth's modes, if at hand.

    Returns
    -------
    TestData
        The case's modes (:func:`case_data`) at its measured dofs.
    """
    from ...testdata import MeasuredMode, TestData

    lam, psi = case_data(study, c, level, slice(start, start + 1), modes)
    dofs = study.cases[c].measured_dofs
    return TestData(modes=tuple(MeasuredMode(float(lam[0, k]), dofs, psi[0, :, k]) for k in range(lam.shape[1])))


def row_data(study: Study, pieces):
    """Padded test data and starts of the rows of ``pieces``.

    Parameters
    ----------
    study : Study
        The study.
    pieces : sequence of (int, int, int, int)
        (case, level, first start, end start) pieces (:meth:`Study.pieces`), rows in this order.

    Returns
    -------
    rows : RowData
        Sensors: the union of the pieces' measured dofs; shapes only for cases with two or more
        measured dofs.
    starts : ndarray, shape ``(B, L)``
        Start of each row.
    """
    from ...modal import model_modes
    from ..problem import RowData

    model = study.model
    modes = model_modes(model, study.truth)
    sensors = np.unique(np.concatenate([model.dof_index(study.cases[c].measured_dofs) for c, *_ in pieces]))
    u = sensors.size
    T = max(study.cases[c].n_modes for c, *_ in pieces)
    B = sum(b - a for _, _, a, b in pieces)
    lam_e = np.ones((B, T))
    psi_e = np.zeros((B, u, T))
    smask = np.zeros((B, u), bool)
    n_test = np.zeros(B, np.intp)
    X0 = np.zeros((B, len(study.names)))
    r = 0
    for c, lv, a, b in pieces:
        case = study.cases[c]
        k = b - a
        lam, psi = case_data(study, c, lv, slice(a, b), modes)
        at = np.searchsorted(sensors, model.dof_index(case.measured_dofs))
        lam_e[r:r + k, :case.n_modes] = lam
        if case.n_measured >= 2:
            psi_e[r:r + k, at, :case.n_modes] = psi
            smask[r:r + k, at] = True
        n_test[r:r + k] = case.n_modes
        X0[r:r + k] = study.starts[a:b]
        r += k
    return RowData(lam_e, psi_e, smask, n_test, sensors), X0


def solve_unit(study: Study, unit: int, progress: Callable[[int, int], None] | None = None) -> list[dict]:
    """Solve work unit ``unit`` of ``study`` as one batch: a pure function of its arguments.

    Parameters
    ----------
    study : Study
        The study.
    unit : int
        Index into ``study.units()``.
    progress : callable, optional
        Passed to the batch solver: ``progress(rows_done, rows_total)`` within the unit.

    Returns
    -------
    list of dict
        One per piece: ``case``, ``level``, ``start`` (first start), and per start ``x`` (final
        values of the unknowns), ``cost``, ``status`` (SciPy's codes, or -3 failed), ``nfev``, and
        ``messages`` {start: message} of the failed ones.
    """
    from ..problem import study_problem

    pieces = study.units()[unit]
    rows, X0 = row_data(study, pieces)
    prob = study_problem(study.model, study.names, rows, X0, values=study.truth, min_mac=study.min_mac,
                         max_nfev=study.max_nfev, ftol=study.tol, xtol=study.tol, gtol=study.tol)
    res = prob.solve(progress=progress, history=False)
    X = prob.to_p(res.x, np.arange(X0.shape[0]))
    out, r = [], 0
    for c, lv, a, b in pieces:
        sl = slice(r, r + b - a)
        failed = {str(a + k): res.message[r + k] for k in range(b - a) if res.status[r + k] == FAILED}
        out.append({"case": c, "level": lv, "start": a, "x": X[sl].tolist(), "cost": res.cost[sl].tolist(),
                    "status": res.status[sl].tolist(), "nfev": res.nfev[sl].tolist(), "messages": failed})
        r += b - a
    return out


@shared_docs(CASE=_CASE)
def reference_unit(study: Study, c: int, level: int = 0, starts: Sequence[int] | None = None) -> dict:
    """The per-start route: one :func:`femupdate.updating.update` per start of case ``c``.

    SciPy least squares with the exact Nelson Jacobian, in the raw format of :func:`solve_unit`
    (plus ``starts``).  A case with fewer independent data than unknowns is solved with
    ``regularization=0`` (the same unregularised problem; ``update`` otherwise refuses it as
    underdetermined).  A start whose update raises a femupdate error is recorded as failed (NaN
    values, status -3) with its message.

    Parameters
    ----------
    {{CASE}}
    starts : sequence of int, optional
        Which starts (default all).

    Returns
    -------
    dict
        ``case``, ``level``, ``start`` (the first), ``starts``, and per start ``x``, ``cost``,
        ``status``, ``nfev``; ``messages`` {start: message} of the failed ones.
    """
    from ...modal import model_modes
    from ...updating import update

    idx = list(range(study.n_starts)) if starts is None else [int(k) for k in starts]
    case = study.cases[c]
    L = len(study.names)
    n_data = case.n_modes * (case.n_measured if case.n_measured >= 2 else 1)
    out: dict[str, Any] = {"case": c, "level": level, "start": idx[0] if idx else 0, "x": [], "cost": [], "status": [],
                           "nfev": [], "messages": {}, "starts": idx}
    truth_modes = model_modes(study.model, study.truth)  # the data of every start derive from them
    for k in idx:
        data = case_testdata(study, c, level, k, truth_modes)
        try:
            res = update(study.model, data, params=list(study.names), x0=dict(zip(study.names, study.starts[k])),
                         values=study.truth, min_mac=study.min_mac, max_nfev=study.max_nfev, ftol=study.tol,
                         xtol=study.tol, gtol=study.tol, regularization=0.0 if n_data < L else None)
            out["x"].append(list(map(float, res.x)))
            out["cost"].append(float(res.cost))
            out["status"].append(int(res.status))
            out["nfev"].append(int(res.nfev))
        except FemupdateError as exc:
            out["x"].append([math.nan] * L)
            out["cost"].append(math.nan)
            out["status"].append(FAILED)
            out["nfev"].append(0)
            out["messages"][str(k)] = f"{type(exc).__name__}: {exc}"
    return out


__all__ = ["case_data", "case_testdata", "row_data", "solve_unit", "reference_unit"]
