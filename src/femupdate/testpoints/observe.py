r"""Measured dofs that are combinations of model dofs: the observation matrix and the model in
coordinates that hold them.

femupdate compares test and model at *dofs*: every measured value is one entry of the model's
shape (pairing, MAC, residuals, sensitivities, FRFs all select model dofs by label).  A test point
inside an element sees :math:`y = c^T u` — one row of an observation matrix :math:`C` — rather
than one dof.  Instead of teaching every route a general :math:`C`, the model is written in new
coordinates that contain :math:`y` (an exact change of basis, no approximation):

* for each row, one *master* dof of the row is chosen (column-pivoted QR of C, so that
  :math:`C_m`, the columns of the masters, is invertible and well conditioned);
* :math:`u = T q`, where q is u with each master replaced by its row's value y:
  :math:`u_m = C_m^{-1}(y - C_r u_r)`, the other dofs unchanged, so :math:`C T q = y`;
* :math:`K' = T^T K T`, :math:`M' = T^T M T` and every parameter matrix likewise (each term
  of a non-linear model too): the eigenvalues are those of the model, the eigenvectors are
  :math:`q = T^{-1}\phi` — whose entries at the new dofs are exactly :math:`C\phi` — mass
  normalisation and orthogonality hold, and because T does not depend on the parameters,
  :math:`\partial K'/\partial p = T^T (\partial K/\partial p) T`: sensitivities are exact.  A
  force at a new dof is the force :math:`C^T F` spread by the shape functions (reciprocal FRFs).

A row that is one model dof with weight 1 (a point mapped to a node, along a global axis) needs
no new coordinate: the test label is renamed to that model dof.  The new dofs are labelled
``"<prefix><test node>:<dir>"`` (``"T101:z"``); the master dofs they replace are no longer listed
among the model's dofs.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import replace

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp

from .._errors import InputError
from ..dofs import DIRECTIONS, describe, dof, parse_dof

#: columns of C whose pivot falls below this fraction of the largest: rows that are (nearly) combinations
#: of each other (two test points observing the same motion)
RANK_TOL = 1e-8


def _congruence(A, T):
    if A is None:
        return None
    B = (T.T @ sp.csr_array(A) @ T).tocsr()
    return ((B + B.T) * 0.5).tocsr()


def _dependent(C: np.ndarray, labels: list[str]) -> list[str]:
    """The rows of C that are (nearly) combinations of the others: those a row-pivoted QR takes last."""
    if C.shape[1] == 0:
        return labels
    _, R, piv = sla.qr(C.T, mode="economic", pivoting=True)
    d = np.abs(np.diag(R))
    rank = int(np.sum(d > RANK_TOL * max(d[0], 1e-300))) if len(d) else 0
    return [labels[i] for i in piv[rank:]] or labels


def observed_model(model, rows: Mapping[str, Mapping[int, float]], fixed: Sequence[int] = ()):
    """The model in coordinates that hold the observed combinations as dofs (module docstring).

    Parameters
    ----------
    model : Model
        The model.
    rows : mapping of str to mapping of int to float
        New dof label -> {model dof index: weight}: the rows of C.
    fixed : sequence of int, optional
        Model dof indices that must stay dofs (measured directly): never chosen as masters.

    Returns
    -------
    model : Model
        With the masters' labels replaced by the new labels (same positions), and
        ``K' = T^T K T`` etc.
    T : scipy.sparse.csr_array, shape ``(n, n)``
        ``u = T q``.

    Raises
    ------
    InputError
        A new label that is already a model dof; rows that are (nearly) combinations of each
        other or of the directly measured dofs (named).
    """
    labels = list(rows)
    if not labels:
        return model, sp.identity(model.n_dofs, format="csr")
    clash = [lab for lab in labels if lab in set(model.dofs)]
    if clash:
        raise InputError(f"test points: label(s) {describe(clash)} are already dofs of model {model.name!r}")
    cols = sorted({j for r in rows.values() for j in r})
    colpos = {j: k for k, j in enumerate(cols)}
    Cd = np.zeros((len(labels), len(cols)))
    for i, lab in enumerate(labels):
        for j, w in rows[lab].items():
            Cd[i, colpos[j]] = w
    direct = set(fixed)
    usable = np.flatnonzero([j not in direct for j in cols])
    m = len(labels)
    diag = np.zeros(0)
    if len(usable) >= m:
        _, R, piv = sla.qr(Cd[:, usable], mode="economic", pivoting=True)
        diag = np.abs(np.diag(R))
    if len(diag) < m or diag[m - 1] <= RANK_TOL * max(diag[0], 1e-300):
        raise InputError(f"test points: the measured dofs {describe(_dependent(Cd[:, usable], labels))} are "
                         "combinations of the other measured dofs (two test points on the same spot and direction, "
                         "or a point that sees only what other measured dofs see); drop them")
    masters = [cols[k] for k in usable[piv[:m]]]
    n = model.n_dofs
    C = sp.csr_array((Cd.ravel(), (np.repeat(np.arange(m), len(cols)), np.tile(cols, m))), shape=(m, n))
    Cm = C[:, masters].toarray()
    rest = sp.csr_array(C.copy())
    rest = rest @ sp.diags_array(np.where(np.isin(np.arange(n), masters), 0.0, 1.0))
    Ey = sp.csr_array((np.ones(m), (np.arange(m), masters)), shape=(m, n))
    A = np.linalg.inv(Cm)
    master_rows = sp.csr_array(A) @ (Ey - rest)  # u_m = A (y - C_r u_r), y at the masters' positions
    keep = np.ones(n, bool)
    keep[masters] = False
    Ikeep = sp.diags_array(keep.astype(float))
    P = sp.csr_array((np.ones(m), (masters, np.arange(m))), shape=(n, m))
    T = (Ikeep + P @ master_rows).tocsr()
    T.eliminate_zeros()
    dofs = list(model.dofs)
    for lab, j in zip(labels, masters):
        dofs[j] = lab
    terms = tuple(replace(t, K=_congruence(t.K, T), M=_congruence(t.M, T)) for t in model.terms)
    new = type(model)(dofs, _congruence(model.K0, T), _congruence(model.M0, T), model.parameters,
                      tuple(_congruence(a, T) for a in model.dK), tuple(_congruence(a, T) for a in model.dM),
                      model.name, model.nodes, model.positive, terms)
    return new, T


def observation_rows(pmap, labels: Sequence[str], model, structure_dofs: set[str] | frozenset[str],
                     prefix: str = "T", axes: Mapping | None = None) -> tuple[dict[str, str], dict[str, dict[int, float]]]:
    """Rows of C for measured labels ``"<test node>:<dir>"`` (global directions).

    Parameters
    ----------
    pmap : PointMap
        Where each test node lies (:func:`~femupdate.testpoints.locate_points`).
    labels : sequence of str
        The measured dofs, test node ids and global directions.
    model : Model
        Its dofs are the columns.
    structure_dofs : set of str
        Every dof label of the structure's elements, supported ones included (a weight on a
        supported dof is dropped: it does not move).
    prefix : str, default "T"
        Prefix of the new dofs' node names.
    axes : mapping of node to array_like (3, 3), optional
        Test nodes whose labels' directions are along their own axes (rows: those axes in global
        axes; a universal file's ``keep_local``): the row of ``"<node>:<dir>"`` is the direction
        cosines' combination of the global rows, the new dof keeps the local direction's name.

    Returns
    -------
    rename : dict of str to str
        Test label -> the label the data carry from now on (a model dof, or a new one).
    rows : dict of str to dict of int to float
        New label -> {model dof index: weight}, for :func:`observed_model`.

    Raises
    ------
    InputError
        A test node without coordinates; a direction the mesh's nodes lack (a rotation at a
        solid's node); a measured dof that only sees supported dofs; two test dofs that become
        the same model dof.
    """
    index = {d: i for i, d in enumerate(model.dofs)}
    rename: dict[str, str] = {}
    rows: dict[str, dict[int, float]] = {}
    for lab in dict.fromkeys(labels):
        node, d = parse_dof(lab)
        lk = pmap.link(node)
        row: dict[int, float] = {}
        for g, c in _components(d, None if axes is None else axes.get(node)):
            for mn, w in zip(lk.mesh_nodes, lk.weights):
                md = dof(mn, g)
                if md in index:
                    row[index[md]] = row.get(index[md], 0.0) + c * w
                elif md not in structure_dofs:
                    raise InputError(f"test dof {lab}: mesh node {mn} (where test node {node} lies"
                                     f"{', in ' + lk.element if lk.element else ''}) has no '{g}' dof")
        if not row:
            raise InputError(f"test dof {lab}: test node {node} lies where the model's {d} motion is supported "
                             f"(mesh node(s) {', '.join(map(str, lk.mesh_nodes))}): it cannot move; leave it out")
        single = next(iter(row.items())) if len(row) == 1 else None
        if single is not None and abs(single[1] - 1.0) < 1e-12:
            rename[lab] = model.dofs[single[0]]
        else:
            new = dof(f"{prefix}{node}", d)
            rename[lab] = new
            rows[new] = row
    seen: dict[str, str] = {}
    for lab, new in rename.items():
        if new in seen:
            raise InputError(f"test dofs {seen[new]} and {lab} both become model dof {new} (their test nodes map to "
                             "the same mesh node); keep one, or interpolate with a smaller tolerance")
        seen[new] = lab
    return rename, rows


def _components(d: str, R) -> list[tuple[str, float]]:
    """[(global direction, cosine)] of direction ``d``: itself, or along row ``d`` of R (local axes)."""
    if R is None:
        return [(d, 1.0)]
    j = DIRECTIONS.index(d)
    row = np.asarray(R, float)[j % 3]
    return [(DIRECTIONS[3 * (j // 3) + i], float(row[i])) for i in range(3) if row[i] != 0.0]


def relabel(data, rename: Mapping[str, str]):
    """The test data with every dof label renamed by ``rename`` (labels it lacks kept)."""
    def f(lab):
        return rename.get(lab, lab)

    modes = tuple(replace(m, dofs=tuple(map(f, m.dofs)),
                          reference_dof=None if m.reference_dof is None else f(m.reference_dof)) for m in data.modes)
    frf_sets = tuple(replace(s, dofs=tuple(map(f, s.dofs)), force={f(k): v for k, v in s.force.items()})
                     for s in data.frf_sets)
    static = tuple(replace(s, dofs=tuple(map(f, s.dofs)), force={f(k): v for k, v in s.force.items()})
                   for s in data.static)
    return replace(data, modes=modes, frf=frf_sets[0] if frf_sets else None, frf_sets=frf_sets, static=static)


def measured_labels(data) -> list[str]:
    """Every dof label the test data use (modes, FRF responses and forces, static cases), in order."""
    out: dict[str, None] = {}
    for m in data.modes:
        out.update(dict.fromkeys(m.dofs))
    for s in (*data.frf_sets, *data.static):
        out.update(dict.fromkeys(s.dofs))
        out.update(dict.fromkeys(s.force))
    return list(out)


__all__ = ["observed_model", "observation_rows", "relabel", "measured_labels"]
