"""Uniqueness and identifiability of model updating from modal data (paper eqs. 11-22, Summary).

* :mod:`.criteria` — the counting criteria of Jung & Ewins / Lin, Botto et al., the data count
  and the paper's mn >= L with n > 1, side by side;
* :mod:`.exact` — every real parameter set that reproduces measured eigenvalues, solved exactly
  (SymPy Gröbner bases) for small systems;
* :mod:`.study` — Monte Carlo studies over measurement plans and random starts, all cases solved
  as one batch (:mod:`.problem`), locally or on a Dask cluster, with checkpoints.
"""

from .criteria import CRITERIA, counting_criteria, criteria_verdicts
from .exact import MAX_DOFS, MAX_PARAMETERS, ExactSolution, ExactSolutionSet, exact_solutions
from .study import (Case, CaseResult, Study, StudyResult, define_study, nested_dof_sets, parse_measured_dofs,
                    parse_modes, reference_unit, run_study)

__all__ = [
    "CRITERIA", "counting_criteria", "criteria_verdicts",
    "MAX_DOFS", "MAX_PARAMETERS", "ExactSolution", "ExactSolutionSet", "exact_solutions",
    "Case", "CaseResult", "Study", "StudyResult", "define_study", "nested_dof_sets", "parse_measured_dofs",
    "parse_modes", "reference_unit", "run_study",
]
