r"""Exact multipoint constraints: dofs eliminated by a transformation, never by penalties.

A constraint makes some dofs *dependent*: each is a fixed linear combination of *independent*
dofs, :math:`u = T\,u_i` with T sparse (identity on the independent dofs).  The model keeps only
the independent dofs, with

.. math::  K_r = T^T K T, \qquad M_r = T^T M T, \qquad \partial K_r/\partial p_j = T^T K_j T

for K0, M0 and **every** parameter matrix and non-linear term, so the parametrisation stays exact
(T depends on geometry only, never on a parameter).  The dependent dofs are recovered from the
independent ones by the rows of T that belong to them (:class:`DependentDofs`), for pairing
with test dofs and for drawing shapes.

Who makes T: :meth:`femupdate.Structure.rigid_link` and :meth:`femupdate.Structure.equal_dofs`
(:mod:`femupdate.structure.links`), the Nastran RBE2 and Abaqus ``*KINEMATIC COUPLING`` / ``*MPC``
cards, and :func:`femupdate.penalty.eliminate_penalty_links` (penalty ties found in exported
matrices); every one reduces the model with :func:`reduce_model`.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
import scipy.sparse as sp

from ._errors import InputError
from .dofs import describe


@dataclass(frozen=True, eq=False)
class DependentDofs:
    """The dofs a model's constraints eliminated and how they follow its dofs.

    Attributes
    ----------
    labels : tuple of str
        The dependent dof labels (not among the model's dofs).
    R : scipy.sparse.csr_array, shape ``(len(labels), n_dofs)``
        ``u_dependent = R @ u`` for any displacement u of the model's dofs.
    sources : tuple of str
        For each dependent dof, the constraint that made it so, as the input names it.
    """

    labels: tuple[str, ...]
    R: sp.csr_array
    sources: tuple[str, ...] = ()

    def expand(self, dofs, shapes) -> tuple[tuple[str, ...], np.ndarray]:
        """The model's dofs followed by the dependent ones, and ``shapes`` (rows: the model's
        dofs) with the dependent rows appended, ``R @ shapes``.

        Parameters
        ----------
        dofs : sequence of str
            The model's dof labels.
        shapes : array_like, shape ``(n_dofs,)`` or ``(n_dofs, k)``

        Returns
        -------
        labels : tuple of str
        full : numpy.ndarray, shape ``(n_dofs + n_dependent, ...)``
        """
        phi = np.asarray(shapes)
        return tuple(dofs) + self.labels, np.concatenate([phi, np.asarray(self.R @ phi)], axis=0)


def expand_shapes(model, shapes) -> tuple[tuple[str, ...], np.ndarray]:
    """A model's dof labels and shapes, with the dofs its constraints eliminated recovered.

    Parameters
    ----------
    model : femupdate.Model
    shapes : array_like, shape ``(n_dofs,)`` or ``(n_dofs, k)``
        Vectors on the model's dofs (mode shapes, static displacements).

    Returns
    -------
    labels : tuple of str
        ``model.dofs`` followed by the dependent dofs (``model.dofs`` alone when there are none).
    full : numpy.ndarray
        ``shapes`` with the dependent rows appended.
    """
    dep = getattr(model, "constraints", None)
    if dep is None:
        return tuple(model.dofs), np.asarray(shapes)
    return dep.expand(model.dofs, shapes)


def dependent_note(model, labels) -> str:
    """A sentence for a message about test dofs that are not model dofs: those among ``labels`` that the
    model's constraints eliminated, and what to do (empty when there are none)."""
    dep = getattr(model, "constraints", None)
    hit = [lab for lab in labels if dep is not None and lab in dep.labels]
    if not hit:
        return ""
    return (f" ({describe(hit)}: dependent dofs of rigid links or ties, eliminated from the model, their motion "
            "follows the independent nodes'; measure at the independent nodes or leave them out, --measured-dofs)")


def check_dependent(dep, n: int, dofs) -> DependentDofs | None:
    """Validate a :class:`Model`'s ``constraints`` field (None, or DependentDofs on its ``n`` dofs)."""
    if dep is None:
        return None
    if not isinstance(dep, DependentDofs):
        raise TypeError(f"constraints must be a DependentDofs (femupdate.constraints) or None, got {type(dep).__name__}")
    R = sp.csr_array(dep.R, dtype=float)
    if R.shape != (len(dep.labels), n):
        raise InputError(f"constraints: R has shape {R.shape}, expected ({len(dep.labels)}, {n})")
    clash = sorted(set(dep.labels) & set(dofs))
    if clash:
        raise InputError(f"constraints: dependent dof(s) {describe(clash)} are also model dofs")
    return replace(dep, labels=tuple(dep.labels), R=R)


def transformation(free, rows) -> tuple[sp.csr_array, list[int], list[int]]:
    """T for dependent dofs given by ``rows``, on the positions ``free``.

    Parameters
    ----------
    free : sequence of str
        All unconstrained-by-support dof labels, in model order.
    rows : mapping of str to list of (str, float)
        Dependent label -> its independent labels and coefficients (labels not in ``free``, that is
        supported dofs, contribute nothing).

    Returns
    -------
    T : scipy.sparse.csr_array, shape ``(len(free), n_independent)``
    kept : list of int
        Positions in ``free`` of the independent dofs (the columns of T, in order).
    dependent : list of int
        Positions in ``free`` of the dependent dofs.
    """
    pos = {lab: i for i, lab in enumerate(free)}
    dep = sorted(pos[d] for d in rows)
    is_dep = np.zeros(len(free), bool)
    is_dep[dep] = True
    kept = [i for i in range(len(free)) if not is_dep[i]]
    col = {i: c for c, i in enumerate(kept)}
    r, c, v = list(kept), [col[i] for i in kept], [1.0] * len(kept)
    for d, terms in rows.items():
        for lab, coef in terms:
            if lab in pos and coef != 0.0:
                r.append(pos[d])
                c.append(col[pos[lab]])
                v.append(coef)
    T = sp.coo_array((v, (r, c)), shape=(len(free), len(kept))).tocsr()
    T.sum_duplicates()
    return T, kept, dep


def reduce_model(model, T, kept, dependent=(), sources=()):
    """The model on its independent dofs: ``Tᵀ A T`` for K0, M0, every dK, dM and term.

    Parameters
    ----------
    model : femupdate.Model
        On the full (unconstrained) dofs.
    T : sparse matrix, shape ``(n_dofs, m)``
    kept : sequence of int
        Positions of the independent dofs (T's columns).
    dependent : sequence of int, optional
        Positions of the dependent dofs, recorded in the result's ``constraints`` (with those the
        model already had, carried through T).
    sources : sequence of str, optional
        The constraint of each dependent dof, for messages.

    Returns
    -------
    femupdate.Model
    """
    T = sp.csr_array(T)

    def reduce(A):
        return None if A is None else sp.csr_array(T.T @ A @ T)

    old = model.constraints
    labels = tuple(model.dofs[i] for i in dependent)
    R = T[list(dependent)] if len(dependent) else sp.csr_array((0, T.shape[1]))
    src = tuple(sources) if sources else ("constraint",) * len(labels)
    if old is not None:
        labels, R = old.labels + labels, sp.vstack([old.R @ T, R]).tocsr()
        src = old.sources + src
    dep = DependentDofs(labels, sp.csr_array(R), src) if labels else None
    return replace(model, dofs=tuple(model.dofs[i] for i in kept), K0=reduce(model.K0), M0=reduce(model.M0),
                   dK=tuple(reduce(A) for A in model.dK), dM=tuple(reduce(A) for A in model.dM),
                   terms=tuple(replace(t, K=reduce(t.K), M=reduce(t.M)) for t in model.terms), constraints=dep)


__all__ = ["DependentDofs", "expand_shapes", "dependent_note", "transformation", "reduce_model", "check_dependent"]
