"""The updating core: one problem, many drivers.

* :class:`Problem` — the modal updating problem (parameters and parametrisation, measured
  modes with their weights, pairing, residuals and exact Jacobian), its rules written once in
  :mod:`femupdate.rules`;
* :func:`update` / :func:`solve_problem` — one local solve (SciPy least squares, paper eq. 20);
  :func:`solve` the same for any problem with residuals and a Jacobian (FRF,
  multi-configuration);
* :func:`multistart` — random starts, clustered into distinct solutions; locally, on a Dask
  cluster, or all at once in compiled code for small models (:mod:`.batched`).
"""

from .clustering import cluster, converged_solutions
from .starts import draw_starts, multistart, run_starts
from .problem import (PARAMETRISATIONS, SENSITIVITY_CHOICES, SHAPE_SCALINGS, Parametrisation, Problem, Targets,
                      modal_weights)
from .results import Diagnostics, MultiStartResult, RunResult, Solution, UpdateResult
from .solve import diagnostics, result_at, solve, solve_problem, update

__all__ = [
    "Problem", "Parametrisation", "Targets", "modal_weights", "PARAMETRISATIONS", "SHAPE_SCALINGS",
    "SENSITIVITY_CHOICES", "RunResult", "update", "solve", "solve_problem", "result_at", "diagnostics", "UpdateResult",
    "Diagnostics", "multistart", "MultiStartResult", "Solution", "cluster", "converged_solutions", "draw_starts",
    "run_starts",
]
