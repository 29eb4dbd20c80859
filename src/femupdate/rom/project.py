r"""The reduced :class:`~femupdate.Model`: every parameter matrix projected once on the Ritz basis.

With the basis :math:`V` (n × r, :math:`V^T M V = I`) and the dofs the test data name (sensors,
excitation and load points: ``s`` of them, rows ``S`` of V), the coordinates are changed by
:math:`T = [A^+ \; N]`, :math:`A = V_S`, :math:`N` an orthonormal basis of its null space, so
that the basis :math:`\hat V = V T` is the identity at the data's dofs and zero there
elsewhere: the reduced model's first ``s`` coordinates *are* the displacements at those dofs,
under their own labels, and the others are generalised coordinates (scalar points
``ritz<i>:s``).  Every route then reads a reduced mode at the sensors, and applies a point force
at a named dof, exactly as on the full model, unchanged: the projection of a point force is
:math:`\hat V^T e_d = e_d`.

The matrices are projected once, term by term, so that the reduced model has the full model's
parameter structure,

.. math::  K_r(p) = \hat V^T K_0 \hat V + \sum_j p_j \hat V^T K_j \hat V + \sum_k f_k(p)\, \hat V^T K_k \hat V,

:math:`M_r(p)` likewise, with the same parameters, bounds, priors and coefficient functions:
:math:`K_r(p) = \hat V^T K(p) \hat V` for every p.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import scipy.sparse as sp

from .._errors import NumericalError


def data_dofs(data) -> list[str]:
    """The dofs the test data name, in first-seen order: measured shape entries, FRF responses and
    excitations, static deflections and loads."""
    seen: dict[str, None] = {}
    for m in getattr(data, "modes", ()):
        seen.update(dict.fromkeys(m.dofs))
    for f in getattr(data, "frf_sets", ()) or ():
        seen.update(dict.fromkeys(f.dofs))
        seen.update(dict.fromkeys(f.force))
    for s in getattr(data, "static", ()) or ():
        seen.update(dict.fromkeys(s.dofs))
        seen.update(dict.fromkeys(s.force))
    return list(seen)


def interpolating(V: np.ndarray, rows: np.ndarray) -> np.ndarray:
    """``T`` (r × r) such that ``(V T)[rows] = [I 0]``.

    Raises
    ------
    NumericalError
        The basis cannot move the data's dofs independently (fewer vectors than dofs, or
        dependent rows): the dofs are named.
    """
    A = V[rows, :]
    s, r = A.shape
    U, S, Wt = np.linalg.svd(A, full_matrices=True)
    if s > r or (s and S[-1] <= 1e-10 * S[0]):
        raise NumericalError(f"the reduced basis ({r} vectors) cannot move the {s} data dofs independently; "
                             "give more modes or parameter points")
    W = Wt.T
    return np.hstack([W[:, :s] @ (U.T / S[:, None]), W[:, s:]])


def _matrices(model) -> list:
    """Every parameter matrix of the model, in a fixed order (None where absent)."""
    return ([model.K0, model.M0] + list(model.dK) + list(model.dM)
            + [t.K for t in model.terms] + [t.M for t in model.terms])


def extend(proj: list | None, model, V: np.ndarray, Q: np.ndarray) -> list:
    """The projections ``V_new^T A V_new`` of every parameter matrix, ``V_new = [V Q]``, from those
    on ``V`` (``proj``): only the new blocks are computed (``A Q``: one sparse product per matrix)."""
    out: list = []
    for k, A in enumerate(_matrices(model)):
        if A is None:
            out.append(None)
            continue
        AQ = A @ Q
        old = proj[k] if proj is not None else np.zeros((0, 0))
        C = V.T @ AQ if V.shape[1] else np.zeros((0, Q.shape[1]))
        D = Q.T @ AQ
        out.append(np.block([[old, C], [C.T, 0.5 * (D + D.T)]]))
    return out


def _transformed(P, T: np.ndarray) -> sp.csr_array | None:
    if P is None:
        return None
    R = T.T @ P @ T
    R = 0.5 * (R + R.T)
    R[np.abs(R) < 1e-15 * max(float(np.abs(R).max(initial=0.0)), 1e-300)] = 0.0
    return sp.csr_array(R)


def generalised_labels(model, count: int) -> list[str]:
    """``ritz1:s`` … for the generalised coordinates, with a node name the model does not use."""
    nodes = {d.rsplit(":", 1)[0] for d in model.dofs}
    stem = "ritz"
    while any(n.startswith(stem) for n in nodes):
        stem = "_" + stem
    return [f"{stem}{i + 1}:s" for i in range(count)]


def reduced_model(model, V: np.ndarray, dofs, proj: list | None = None) -> tuple:
    """The reduced model on the basis ``V`` interpolating at ``dofs``, and its basis ``V T``.

    Parameters
    ----------
    model : Model
        The full model.
    V : numpy.ndarray, shape ``(n, r)``
        The Ritz basis (any full-rank basis; M-orthonormal keeps the projection well conditioned).
    dofs : sequence of str
        The dofs the data name (labels of ``model``).
    proj : list, optional
        The projections on ``V`` of every parameter matrix (:func:`extend`), kept by the caller as
        the basis grows; default computed here.

    Returns
    -------
    (Model, numpy.ndarray)
        The reduced model (dofs: ``dofs`` then the generalised coordinates) and ``V T``
        (n × r), whose column i is the full-model shape of reduced coordinate i.
    """
    from ..model import Model

    rows = model.dof_index(list(dofs), "data")
    T = interpolating(V, rows)
    Vh = V @ T
    Vh[rows, :] = np.eye(len(rows), Vh.shape[1])  # exactly, not to round-off
    if proj is None:
        proj = extend(None, model, np.zeros((V.shape[0], 0)), V)
    P = [_transformed(A, T) for A in proj]
    L, nt = len(model.parameters), len(model.terms)
    labels = [model.dofs[i] for i in rows] + generalised_labels(model, Vh.shape[1] - len(rows))
    terms = tuple(replace(t, K=P[2 + 2 * L + k], M=P[2 + 2 * L + nt + k]) for k, t in enumerate(model.terms))
    names = {d.rsplit(":", 1)[0] for d in labels}
    nodes = {k: v for k, v in model.nodes.items() if f"{k}" in names}
    reduced = Model(dofs=tuple(labels), K0=P[0], M0=P[1], parameters=model.parameters, dK=tuple(P[2:2 + L]),
                    dM=tuple(P[2 + L:2 + 2 * L]), name=f"{model.name} (reduced, {Vh.shape[1]} Ritz vectors)",
                    nodes=nodes, positive=model.positive, terms=terms)
    return reduced, Vh


__all__ = ["reduced_model", "extend", "data_dofs", "interpolating", "generalised_labels"]
