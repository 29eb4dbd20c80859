"""femupdate: finite-element model updating from vibration test data.

The public namespace; modules whose names start with an underscore are internal.
"""

from ._errors import FemupdateError, InputError, NumericalError
from .model import Model, Parameter, from_matrices
from .modal import Modes, model_modes, normalise, solve_modes
from .structure import Structure
from .testdata import FRFData, MeasuredMode, StaticData, TestData

__version__ = "0.1.0"

__all__ = [
    "FemupdateError", "InputError", "NumericalError",
    "Model", "Parameter", "from_matrices", "Structure",
    "Modes", "model_modes", "solve_modes", "normalise",
    "FRFData", "MeasuredMode", "StaticData", "TestData",
]
