"""Options as frozen, self-validating objects, each documented once on its class.

A function that takes options takes them as objects — ``update(model, data,
solver=SolverOptions(max_nfev=50), pairing=PairingOptions(rule="mac", min_mac=0.8))`` — instead of
the same twenty keywords repeated down a call chain.  An option object is checked once, when it is
made (an unknown choice or a number out of range raises :class:`~femupdate.InputError` naming the
field and what it got), is immutable, and makes a changed copy with :meth:`Options.replace`.

For quick use the fields are also accepted as keywords of the function (*shorthand*):
``update(model, data, max_nfev=50, min_mac=0.8)`` is the same call as the one above.  Each keyword
goes to the first of the function's option objects that has a field (or an alias, such as
``measurement_std`` for :attr:`NoiseOptions.std`) of that name; a keyword no option object has is
a :class:`TypeError` naming it, as Python's own.  Some options also take a plain value for their
main field: ``pairing="mac"`` is ``PairingOptions(rule="mac")``, ``noise="estimate"`` is
``NoiseOptions(basis="estimate")``, a mapping is the object's fields.

The command line builds one object per option group (``femupdate update --help`` groups them),
so a command and a Python call with the same options run the same problem.  :meth:`Options.to_dict`
gives the fields as JSON, as results record them.
"""

from __future__ import annotations

from ._base import Options, choice, count, flag, gather, gather_some, number
from .choices import (DATA_KINDS, FORMULATIONS, FRF_RESIDUALS, FRF_SOLVERS, LIKELIHOOD_ROUTES, LSQ_METHODS, NOISE_BASES,
                      PAIRING_RULES, PARAMETRISATIONS, REGULARIZATION_RULES, RESONANCE_POLICIES, SAMPLER_METHODS,
                      SELECTION_EQUATIONS, SENSITIVITY_ROUTES, SHAPE_SCALINGS, STD_KEYS)
from .runs import ExecutionOptions, SamplerOptions, StartsOptions
from .selection import SelectionOptions
from .updating import FRFOptions, ModalOptions, NoiseOptions, PairingOptions, SolverOptions, UpdateOptions

__all__ = ["Options", "UpdateOptions", "PairingOptions", "ModalOptions", "NoiseOptions", "SolverOptions", "FRFOptions",
           "StartsOptions", "ExecutionOptions", "SamplerOptions", "gather", "gather_some", "choice", "number", "count",
           "flag", "PAIRING_RULES", "FORMULATIONS", "SHAPE_SCALINGS", "SENSITIVITY_ROUTES", "PARAMETRISATIONS",
           "LSQ_METHODS", "REGULARIZATION_RULES", "FRF_RESIDUALS", "RESONANCE_POLICIES", "FRF_SOLVERS", "DATA_KINDS",
           "STD_KEYS", "NOISE_BASES", "SAMPLER_METHODS", "LIKELIHOOD_ROUTES"]
__all__ += ["SelectionOptions", "SELECTION_EQUATIONS"]
from .planning import (DESIGN_CRITERIA, PLACEMENT_CRITERIA, SENSOR_KINDS, TARGET_METHODS, PlacementOptions,
                       TargetOptions)

__all__ += ["TargetOptions", "PlacementOptions", "TARGET_METHODS", "PLACEMENT_CRITERIA", "DESIGN_CRITERIA",
            "SENSOR_KINDS"]
