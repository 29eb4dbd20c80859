"""The updating core: one problem, many drivers.

* :class:`Problem` — the modal updating problem (parameters and parametrisation, measured
  modes with their weights, pairing, residuals and exact Jacobian), its rules written once in
  :mod:`femupdate.rules`;
* :func:`update` — one local solve from whatever the test data hold (modes, FRFs, static
  deflections, any mix: :class:`CombinedProblem`); :func:`update_modal` / :func:`solve_problem`
  the modal case; :func:`frf_update` the FRF case (:class:`FRFProblem`, paper eqs. 30–32);
  :func:`solve` (SciPy least squares, paper eq. 20) for any problem with residuals and a
  Jacobian (FRF, multi-configuration);
* :func:`multistart` — random starts, clustered into distinct solutions; locally, on a Dask
  cluster, or all at once in compiled code for small models (:mod:`.batched`);
  :func:`frf_multistart` and :func:`global_search` (differential evolution, basin hopping, dual
  annealing) for FRF data.
"""

from .clustering import cluster, converged_solutions
from .combined import DATA_KINDS, Block, CombinedProblem, combined_problem, data_kinds
from .run import frf_update, update
from .frf import FRFProblem, FRFUpdateResult
from .search import GlobalSearchResult, global_search
from .starts import draw_starts, frf_multistart, multistart, run_starts
from .problem import (PARAMETRISATIONS, SENSITIVITY_CHOICES, SHAPE_SCALINGS, Parametrisation, Problem, Targets,
                      modal_weights)
from .results import Diagnostics, MultiStartResult, RunResult, Solution, UpdateResult
from .solve import diagnostics, result_at, solve, solve_problem, update_modal
from .targets import mode_uncertainty

__all__ = [
    "Problem", "Parametrisation", "Targets", "modal_weights", "mode_uncertainty", "PARAMETRISATIONS", "SHAPE_SCALINGS",
    "SENSITIVITY_CHOICES", "RunResult", "update", "solve", "solve_problem", "result_at", "diagnostics", "UpdateResult",
    "Diagnostics", "multistart", "MultiStartResult", "Solution", "cluster", "converged_solutions", "draw_starts",
    "run_starts", "update_modal", "CombinedProblem", "Block", "combined_problem", "data_kinds", "DATA_KINDS",
    "FRFProblem", "FRFUpdateResult", "frf_update", "frf_multistart", "global_search", "GlobalSearchResult",
]
