r"""Reduction transformations and the one projection primitive :func:`reduce`.

A reduction keeps the dofs in ``keep`` (the *a*-set, e.g. the measured dofs) and omits the rest
(the *o*-set).  Every method only builds a transformation :math:`x = T x_a` (eq. 36), an
``(n, a)`` matrix whose rows follow the model's dofs and whose columns follow ``keep``; the
reduced matrices are :math:`T^T K T` and :math:`T^T M T` (:func:`reduce`), and expansion of
measured shapes reuses the same ``T`` (:mod:`femupdate.reduction.expansion`).

Builders (reference paper, "Model Reduction Techniques", eqs. 35-44):

* :func:`guyan` — static condensation, eqs. 37-40 (Guyan 1965);
* :func:`irs` — Improved Reduced System, eqs. 41-42 corrected (O'Callahan 1989);
* :func:`kammer_modal` — the modal TAM, eq. 43 (Kammer 1987);
* :func:`kammer_hybrid` — the hybrid TAM, eq. 44 corrected (Kammer 1991);
* :func:`serep` — System Equivalent Reduction Expansion Process (O'Callahan, Avitabile &
  Riemer 1989), :math:`T = \Phi \Phi_a^+`.

The omitted partition :math:`K_{oo}` is factorised once (sparse LU with a symmetric
fill-reducing ordering) and never inverted densely; one :class:`Reducer` shares that factor and
the model's modes between methods.

.. note::
   For Guyan, IRS, modal, hybrid and SEREP, ``T`` depends on the parameters (through K, M or
   the modes).  :func:`reduce` projects each affine term ``K0``, ``dK_j``, ``M0``, ``dM_j`` by the
   *same fixed* ``T``, so the reduced model keeps the parameters and is again affine, but it is
   the exact reduction only at the values ``T`` was built at (:attr:`Transformation.values`).
   Elsewhere it is a Ritz (Rayleigh-Ritz) approximation on a frozen basis.

Layout: the builders are methods of :class:`Reducer` (:mod:`.reducer`), the projection and the
reduced pencil are in :mod:`.projection`; this module gathers them, with one function per method.
"""

from __future__ import annotations

from collections.abc import Sequence

from .._docs import shared_docs
from ..model import Model
from .projection import Transformation, project, reduce, reduced_eigenvalues, reduced_matrices, reduced_modes
from .reducer import DENSE_NULL_LIMIT, METHODS, Reducer, mechanism_dofs

__all__ = [
    "METHODS", "DENSE_NULL_LIMIT", "Transformation", "Reducer", "project", "reduce", "mechanism_dofs",
    "guyan", "irs", "kammer_modal", "kammer_hybrid", "serep", "transformation",
    "reduced_matrices", "reduced_modes", "reduced_eigenvalues",
]


# ---------------------------------------------------------------------------------- functions
# the parameter documentation of the builders, written once (femupdate._docs)
_MODEL_KEEP = """\
model : Model
    The full model.
keep : sequence of str
    Retained dof labels (the a-set), in the order of the reduced model."""
_VALUES = """\
values : None, mapping of str to float, or array_like, optional
    Parameter values T is built at (default nominal)."""
_RETURNS = """\
Returns
-------
Transformation
    T of shape ``(n_dofs, a)``"""
_BAD_KEEP = "As :class:`Reducer` (bad keep-set, singular omitted partition)"
_DOCS = {
    "MODEL_KEEP": _MODEL_KEEP,
    "VALUES": _VALUES,
    # guyan, irs
    "CONDENSATION": "\n".join(["Parameters", "----------", _MODEL_KEEP, _VALUES, "", _RETURNS + "."]),
    # kammer_modal, kammer_hybrid, serep
    "TAM": "\n".join(["Parameters", "----------", _MODEL_KEEP, "n_modes : int, optional",
                       "    Number of full-model modes used (default: as many as retained dofs; at most a).", _VALUES,
                       "", _RETURNS + ", exact for the first ``n_modes`` modes.", "", "Raises", "------", "InputError",
                       f"    {_BAD_KEEP}; ``n_modes`` < 1 or > a;", "    modes the retained dofs cannot tell apart."]),
}


@shared_docs(**_DOCS)
def guyan(model: Model, keep: Sequence[str], values=None) -> Transformation:
    """Guyan / static condensation transformation (eqs. 37-40); see :meth:`Reducer.guyan`.

    {{CONDENSATION}}

    Raises
    ------
    InputError
        As :class:`Reducer` (bad keep-set, singular omitted partition).
    """
    return Reducer(model, keep, values).guyan()


@shared_docs(**_DOCS)
def irs(model: Model, keep: Sequence[str], values=None) -> Transformation:
    """Improved Reduced System transformation (eqs. 41-42, corrected); see :meth:`Reducer.irs`.

    {{CONDENSATION}}

    Raises
    ------
    InputError
        As :func:`guyan`; a Guyan-reduced mass matrix that is not positive definite.
    """
    return Reducer(model, keep, values).irs()


@shared_docs(**_DOCS)
def kammer_modal(model: Model, keep: Sequence[str], n_modes: int | None = None, values=None) -> Transformation:
    """Kammer's modal TAM (eq. 43); see :meth:`Reducer.kammer_modal`.

    {{TAM}}
    """
    return Reducer(model, keep, values).kammer_modal(n_modes)


@shared_docs(**_DOCS)
def kammer_hybrid(model: Model, keep: Sequence[str], n_modes: int | None = None, values=None) -> Transformation:
    """Kammer's hybrid TAM (eq. 44, corrected); see :meth:`Reducer.kammer_hybrid`.

    {{TAM}}
    """
    return Reducer(model, keep, values).kammer_hybrid(n_modes)


@shared_docs(**_DOCS)
def serep(model: Model, keep: Sequence[str], n_modes: int | None = None, values=None) -> Transformation:
    """SEREP transformation :math:`\\Phi\\Phi_a^+`; see :meth:`Reducer.serep`.

    {{TAM}}
    """
    return Reducer(model, keep, values).serep(n_modes)


@shared_docs(**_DOCS)
def transformation(model: Model, keep: Sequence[str], method: str, n_modes: int | None = None, values=None) -> Transformation:
    """Transformation by method name (``guyan``, ``irs``, ``modal``, ``hybrid``, ``serep``).

    Parameters
    ----------
    {{MODEL_KEEP}}
    method : str
        ``"guyan"``, ``"irs"``, ``"modal"``, ``"hybrid"`` or ``"serep"``.
    n_modes : int, optional
        Number of full-model modes used (modal, hybrid, serep; default: as many as retained dofs; at most a).
    {{VALUES}}

    Returns
    -------
    Transformation
        T of shape ``(n_dofs, a)``.

    Raises
    ------
    InputError
        As :class:`Reducer` (bad keep-set, singular omitted partition); an unknown method; and
        as the builder of that method.
    """
    return Reducer(model, keep, values).transformation(method, n_modes)
