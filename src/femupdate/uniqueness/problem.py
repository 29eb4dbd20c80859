r"""Many updating problems of one model solved as one batch: every (case, start) pair a row.

A uniqueness study updates one model from many measurement plans (cases: measured dofs × number
of modes), noise realisations and random starts.  :func:`study_problem` gives every row its own
data set — the :class:`~femupdate.updating.problem.Targets` of its case and noise realisation, in
the concatenated form the compiled kernels read — on one shared model, as a
:class:`~femupdate.updating.batched.BatchedProblem`; its ``solve`` runs every row to the end in
compiled code by the updating core's own rules, so each row's decisions are those of
:func:`femupdate.update` for that case from that start.

Per row: shapes scaled to unit length over the row's measured dofs (the default of
:func:`~femupdate.update`); shapes at fewer than two dofs carry no information once scaled and
are dropped (frequencies only); pairing among the ``min(N, max(2T, T + 6))`` lowest modes; all
weights 1; the relative parametrisation.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..sensitivity.subspace import buffered_modes
from ..updating.batched import BatchedProblem
from ..updating.batched.spec import DataSets
from ..updating.targets import Targets


@dataclass(frozen=True, eq=False)
class RowData:
    """Per-row test data of a study's rows, padded to common sizes.

    Built by :func:`femupdate.uniqueness.study.units.row_data`; each parameter is stored as the
    attribute of the same name.  B rows, T the largest number of test modes, u sensors.

    Parameters
    ----------
    lam_e : ndarray, shape ``(B, T)``
        Measured eigenvalues (rad²/s²), 1 where padded.
    psi_e : ndarray, shape ``(B, u, T)``
        Unit-length test shapes on the sensor union, 0 where not measured.
    smask : ndarray of bool, shape ``(B, u)``
        The row's measured dofs among the sensors.
    n_test : ndarray of int, shape ``(B,)``
        The row's number of test modes.
    sensors : ndarray of int, shape ``(u,)``
        Model dof indices of the sensors, ascending.
    """

    lam_e: np.ndarray
    psi_e: np.ndarray
    smask: np.ndarray
    n_test: np.ndarray
    sensors: np.ndarray


def study_data(rows: RowData, n_dofs: int) -> tuple[DataSets, Targets]:
    """Each row's own data set, concatenated (one data set per row), built without a loop over rows.

    Unit-length test shapes at the row's measured dofs in ascending dof order, none for rows with
    fewer than two sensors (frequencies only), weights 1, no reference dof; each row pairs among its
    ``min(n_dofs, buffered_modes(T_row))`` lowest modes.

    Parameters
    ----------
    rows : RowData
        The rows' padded test data.
    n_dofs : int
        Number of model dofs.

    Returns
    -------
    sets : DataSets
        Per row: first test mode, number of test modes, model modes, residual count ``T (1 + n_s)``.
    targets : Targets
        The concatenated test modes of every row.
    """
    B, T = rows.lam_e.shape
    U = np.asarray(rows.sensors, dtype=np.int64)
    nt = np.asarray(rows.n_test, dtype=np.int64)
    smask = rows.smask & (rows.smask.sum(axis=1) >= 2)[:, None]
    ns = smask.sum(axis=1).astype(np.int64)
    real = np.arange(T)[None, :] < nt[:, None]  # (B, T)
    lam_e = rows.lam_e[real]
    q_ns = np.broadcast_to(ns[:, None], (B, T))[real]  # measured dofs of each test mode
    pptr = np.concatenate([[0], np.cumsum(q_ns)]).astype(np.int64)
    sel = real[:, None, :] & smask[:, :, None]  # (B, u, T): measured (dof, mode) pairs
    order = np.transpose(sel, (0, 2, 1))  # (B, T, u): per mode its dofs, ascending
    pos = np.broadcast_to(U[None, None, :], order.shape)[order].astype(np.int64)
    psi_e = np.transpose(rows.psi_e, (0, 2, 1))[order]
    nm = np.array([min(n_dofs, buffered_modes(int(t))) for t in nt], dtype=np.int64)
    t0 = np.concatenate([[0], np.cumsum(nt)[:-1]]).astype(np.int64)
    sets = DataSets(t0=t0, T=nt, nm=nm, m=nt * (1 + ns), row_ds=np.arange(B, dtype=np.int64))
    return sets, Targets(lam_e=lam_e.astype(float), w_lam=np.ones(lam_e.size), w_psi=np.ones(lam_e.size), pptr=pptr,
                         pos=pos, psi_e=psi_e.astype(float), ref=np.full(lam_e.size, -1, np.int64),
                         nm=int(nm.max(initial=0)))


def study_problem(model, names, rows: RowData, starts, *, values=None, min_mac: float = 0.5, max_nfev: int = 200,
                  ftol: float = 1e-10, xtol: float = 1e-10, gtol: float = 1e-10) -> BatchedProblem:
    """The rows of a study as one :class:`~femupdate.updating.batched.BatchedProblem`.

    Row b starts from ``starts[b]`` on its own data set (:func:`study_data`).

    Parameters
    ----------
    model : Model
        The shared model.
    names : sequence of str
        The unknown parameters.
    rows : RowData
        The rows' test data.
    starts : ndarray, shape ``(B, L)``
        Start of each row: physical values of ``names``.
    values : None, mapping of str to float, or array_like of shape ``(n_parameters,)``, optional
        Values of the other (known) parameters.
    min_mac : float, default 0.5
        Smallest MAC of a mode pair.
    max_nfev : int, default 200
        Most residual evaluations per row.
    ftol, xtol, gtol : float, default 1e-10
        Stopping tolerances of the least-squares solver.

    Returns
    -------
    BatchedProblem
    """
    return BatchedProblem(model, names, starts, study_data(rows, model.n_dofs), values=values, min_mac=min_mac,
                          max_nfev=max_nfev, ftol=ftol, xtol=xtol, gtol=gtol)


__all__ = ["RowData", "study_data", "study_problem"]
