"""``from_matrices``: a :class:`~femupdate.model.Model` from plain matrices (exported from an FE code)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence

from ._checks import input_errors, shown, strings_arg
from .model import Model, Parameter


def from_matrices(
    dofs: Sequence[str],
    K0,
    M0,
    parameters: Sequence[Parameter] = (),
    dK: Sequence | None = None,
    dM: Sequence | None = None,
    name: str = "matrices",
    terms: Sequence = (),
) -> Model:
    """Model from plain matrices: ``K = K0 + sum_j p_j dK[j]``, ``M = M0 + sum_j p_j dM[j]``.

    This is how models exported from a commercial FE code come in: ``K0``, ``M0`` and one
    (sparse) matrix per parameter, all on the same dof set.  Rigid links exported as penalty
    springs far above the elastic stiffness are tied exactly (the later dofs of a tie leave the
    model, with a logged warning) or refused by name: :mod:`femupdate.penalty`.

    Parameters
    ----------
    dofs : sequence of str
        Dof labels ``"node:dir"`` in matrix order.
    K0, M0 : array_like or scipy sparse matrix, shape ``(n_dofs, n_dofs)``
        Parameter-independent stiffness (N/m) and mass (kg) matrices.
    parameters : sequence of Parameter, default ``()``
        The parameters p_j.
    dK, dM : sequence of (matrix or None), optional
        One ``(n_dofs, n_dofs)`` matrix (or ``None``) per parameter: ∂K/∂p_j and ∂M/∂p_j.
        Omitted: that matrix depends on no parameter.
    name : str, default ``"matrices"``
        Model name.
    terms : sequence of femupdate.coefficients.Term, optional
        Non-linear terms f_k(p) K_k, f_k(p) M_k (:class:`Model`).

    Returns
    -------
    Model

    Raises
    ------
    InputError
        As :class:`Model` (non-square, asymmetric or non-finite matrices, sizes that do not
        match, unused or duplicate parameters); a penalty link that cannot be tied
        (:func:`femupdate.penalty.tie_penalty_links`).
    """
    with input_errors():  # what tuple() below would not say (a model file's matrices come here too)
        strings_arg(dofs, "dofs", "from_matrices", optional=False, what="dof label")
        for what, seq in (("parameters", parameters), ("dK", dK), ("dM", dM)):
            if seq is not None and (isinstance(seq, (str, bytes, Mapping)) or not isinstance(seq, Sequence)):
                raise TypeError(f"from_matrices: {what} must be a list, got {shown(seq)}")
    from .penalty import eliminate_penalty_links

    return eliminate_penalty_links(Model(dofs=tuple(dofs), K0=K0, M0=M0, parameters=tuple(parameters), name=name,
                                         dK=() if dK is None else tuple(dK), dM=() if dM is None else tuple(dM),
                                         terms=tuple(terms)))
