r"""Monte Carlo uniqueness studies (the paper's 6-dof simulation, for any small model).

For every case — a set of measured dofs and a number of measured (lowest) modes — the model at
its parameter values (the truth) gives noise-free test data; :func:`femupdate.updating.update`'s
problem is then solved from R random starts drawn uniformly within the parameters' bounds (one
seeded draw, the same starts for every case).  The converged solutions are clustered: one
distinct solution, the truth, is a **unique** case; several are **non-unique**; none is **not
converging**.  Each case also carries the counting criteria (:mod:`~femupdate.uniqueness.criteria`) and the
condition number of the normalised sensitivity matrix :math:`\partial r/\partial(p/p_{true})` at
the truth.  Optional noise levels re-solve every case from the same starts with noisy data (one
noise realisation per start), showing how conditioning turns into scatter.

How it runs.  All rows (case × noise level × start) of a study are split, in a fixed order, into
work units of at most ``unit_rows`` rows; each unit is solved as ONE batch
(:func:`~femupdate.uniqueness.problem.study_problem`: all its cases together, every row run to the end in compiled
code, the rows spread over the process's CPU cores).  A unit's result is a pure function of (study, unit number), so units run
in process by default or as tasks of a Dask cluster (``scheduler`` address, or ``workers`` for a
local cluster) with identical results; a task lost with its worker is simply recomputed.  With a
checkpoint path every finished unit is written to disk (:mod:`~femupdate.uniqueness.checkpoint`) and a re-run of the
same study skips it.

A start **converges** when the solver reports success with a cost ½‖r‖² at most ``cost_tol``
(the data are reproduced); success with a larger cost is a **local minimum**; running out of
evaluations is **not converged**; an evaluation failure (a test mode that pairs with no model
mode, repeated or rigid modes, K indefinite) is **failed**.  With a single sensor the measured
shapes carry no information (a one-entry shape scaled to unit length is ±1), so those cases use
the frequencies only, as :func:`~femupdate.updating.update` does.  Cases with fewer independent
data than parameters (mn < L) are solved too — their converged starts spread over a continuum
of solutions, which the clustering shows.

"Unique" means that every converged start reached the truth: it is the verdict of R samples, as
in the paper's simulation, not a proof — another solution with a small basin of attraction can
be missed (a two-dof chain with an unknown mass has a second solution in a corner of the box
that 20 starts miss).  For small models, :func:`femupdate.uniqueness.exact.exact_solutions`
gives the complete set from the frequencies.

Layout: :mod:`.definition` (cases, :class:`Study`, :func:`define_study`), :mod:`.units` (the data
of a case and the solution of one work unit), :mod:`.results` (clustering the raw results into
:class:`CaseResult` objects) and :mod:`.run` (:func:`run_study`: in process or on Dask, with
checkpoints).
"""

from .definition import (ALGORITHM, DEFAULT_UNIT_ROWS, Case, Study, define_study, nested_dof_sets, parse_measured_dofs,
                         parse_modes)
from .results import CaseResult, NoiseResult, Solution, StudyResult, conditioning, summarise, truth_sensitivities
from .run import run_study
from .units import case_data, case_testdata, reference_unit, solve_unit

__all__ = [
    "Case", "CaseResult", "NoiseResult", "Solution", "Study", "StudyResult", "case_data", "case_testdata",
    "define_study", "nested_dof_sets", "parse_measured_dofs", "parse_modes", "reference_unit",
    "run_study", "solve_unit", "summarise", "truth_sensitivities", "conditioning",
]
