"""Model reduction and mode-shape expansion (reference paper, "Model Reduction Techniques").

* :func:`reduce` — the one projection primitive :math:`T^T K T`, :math:`T^T M T` of an affine model;
* transformation builders :func:`guyan`, :func:`irs`, :func:`kammer_modal`, :func:`kammer_hybrid`,
  :func:`serep` (and :class:`Reducer`, which shares one factorisation of K_oo between them);
* :func:`expand` — measured shapes to every model dof with the same transformations;
* :mod:`~femupdate.reduction.metrics` — Tan's (1993) accuracy and robustness measures;
* :mod:`~femupdate.reduction.criteria` — Gordis's and Larsson & Sas's pre-reduction checks;
* :mod:`~femupdate.reduction.selection` — retained-dof mass fraction, effective independence;
* :mod:`~femupdate.reduction.superelement` — connectivity-preserving super-elements (Lin 1993);
* :func:`reduce_model` — one reduction compared with the full model and the other methods
  (:class:`ReductionResult`, what ``femupdate reduce`` writes).
"""

from .criteria import ReductionCriteria, reduction_criteria
from .expansion import EXPANSION_METHODS, ExpandedShapes, ExpansionBiasWarning, expand
from .metrics import TamMetrics, orthogonality, tam_metrics
from .projection import Transformation, project, reduce, reduced_eigenvalues, reduced_matrices
from .reducer import METHODS, Reducer, mechanism_dofs
from .selection import EfiResult, effective_independence, mass_fraction
from .study import ReductionResult, reduce_model
from .superelement import assemble, condense, split_structure, superelement_model
from .transforms import guyan, irs, kammer_hybrid, kammer_modal, serep, transformation

__all__ = [
    "reduce", "project", "Reducer", "Transformation", "METHODS", "transformation",
    "guyan", "irs", "kammer_modal", "kammer_hybrid", "serep", "mechanism_dofs",
    "reduced_matrices", "reduced_eigenvalues",
    "expand", "ExpandedShapes", "ExpansionBiasWarning", "EXPANSION_METHODS",
    "tam_metrics", "TamMetrics", "orthogonality",
    "reduction_criteria", "ReductionCriteria",
    "mass_fraction", "effective_independence", "EfiResult",
    "assemble", "condense", "split_structure", "superelement_model",
    "reduce_model", "ReductionResult",
]
