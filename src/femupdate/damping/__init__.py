"""Damping in the model, complex modes and their sensitivities.

* :class:`DampedModel` — a :class:`~femupdate.Model` with viscous damping C(p) (Rayleigh α M + β K,
  dampers between dofs, C matrices), hysteretic damping D(p) (loss factors: complex stiffness
  K + iD) and modal damping ratios, damping parameters beside the model's (:mod:`.model`);
* :func:`complex_modes` — the quadratic eigenproblem by its state-space form, dense or sparse
  shift-invert, normalised φᵀ(2λM + C)φ = 1 (:mod:`.complex_modes`);
* :func:`modal_phase_collinearity`, :func:`mean_phase_deviation`, :func:`realise` — complexity of
  model and test shapes, and real normal modes from complex ones (:mod:`.complexity`);
* :func:`complex_sensitivities` — exact derivatives of complex eigenvalues and shapes
  (:mod:`.sensitivity`);
* :func:`fit_damping` — parameters from complex eigenvalues by least squares (:mod:`.fit`);
* :func:`load_damped_model` — a model file with a ``[damping]`` table (:mod:`.model_file`).

The FRF damping of :mod:`femupdate.frf` (:class:`femupdate.frf.Damping`: fixed Rayleigh α, β and
a loss factor η for the receptances) is separate and unchanged.
"""

from .complex_modes import ComplexModes, complex_modes
from .complexity import data_complexity, mean_phase_deviation, modal_phase_collinearity, realise
from .fit import DampingFit, fit_damping, target_eigenvalues
from .model import DampedModel, Damper, LossFactor
from .model_file import load_damped_model
from .sensitivity import ComplexSensitivities, complex_sensitivities

__all__ = ["DampedModel", "Damper", "LossFactor", "ComplexModes", "complex_modes", "modal_phase_collinearity",
           "mean_phase_deviation", "realise", "data_complexity", "ComplexSensitivities", "complex_sensitivities", "DampingFit",
           "fit_damping", "target_eigenvalues", "load_damped_model"]
