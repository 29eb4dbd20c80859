"""Test planning: where to put the sensors so that the update is unique and well determined
(issue 32; docs/planning.md).

* :mod:`.targets` — target modes by effective modal mass or kinetic energy in a band;
* :mod:`.candidates` — candidate sensors, uniaxial or triaxial, from the model or a file;
* :mod:`.classical` — effective independence, EfI-DPR, kinetic energy, MAC-based elimination;
* :mod:`.fisher` — the Fisher information of a sensor set for the physical parameters;
* :mod:`.placement` — identifiability-first greedy selection with exchange, then D/A-optimal;
* :mod:`.predict` — predicted standard deviations, auto-MAC, expected uniqueness verdict,
  Monte Carlo check;
* :mod:`.pretest` — the test-analysis model on the chosen dofs, its orthogonality checks, and
  the mass loading of the accelerometers;
* :mod:`.exciters` — exciter placement for FRF tests (driving-point criteria, FRF Fisher
  information);
* :func:`plan` — all of it (:class:`PlanResult`, what ``femupdate plan`` writes);
  the universal files for the test lab are written by :func:`femupdate.io.plan_uff.write_plan_uff`.
"""

from .candidates import Candidates, candidates, read_candidates
from .classical import CRITERIA, ClassicalPlacement, classical_placement
from .exciters import ExciterPlacement, driving_point_criteria, exciter_placement
from .fisher import Design, Noise, SensitivityBank, parameter_points, prior_variances
from .placement import IdentifiabilityPlacement, SetScore, identifiability_placement, score_set
from .plan import plan
from .predict import chain_positions, monte_carlo, predicted_std, uniqueness_verdict
from .pretest import mass_loading, tam
from .result import PlanResult
from .targets import TargetModes, effective_mass_fractions, influence_vector, target_modes

__all__ = [
    "plan", "PlanResult", "Candidates", "candidates", "read_candidates", "CRITERIA", "ClassicalPlacement",
    "classical_placement", "Noise", "SensitivityBank", "parameter_points", "IdentifiabilityPlacement", "SetScore",
    "identifiability_placement", "score_set", "chain_positions", "monte_carlo", "predicted_std",
    "uniqueness_verdict", "TargetModes", "target_modes", "effective_mass_fractions", "influence_vector",
    "tam", "mass_loading", "ExciterPlacement", "exciter_placement", "driving_point_criteria", "Design",
    "prior_variances",
]
