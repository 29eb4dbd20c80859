"""femupdate: finite-element model updating from vibration test data.

The verbs a user reaches for are here, at the top level::

    import femupdate as fu

    model = fu.load_model("structure.toml")        # or fu.Structure(...).build(), fu.from_matrices(...)
    data = fu.load_test_data("test.json")          # JSON or universal file (.uff/.unv)
    modes = fu.model_modes(model)
    print(fu.correlate(data, modes).pairs)
    result = fu.update(model, data)                # iterative, incomplete modal data
    print(result.summary())
    study = fu.multistart(model, data, starts=40)  # random starts, distinct solutions
    post = fu.posterior(model, data, method="tmcmc")  # how far to trust it: samples, solutions, evidence

Names are imported on first use, so ``import femupdate`` stays light (it loads neither SciPy's
solvers nor numba, matplotlib, SymPy or Dask).  Modules whose names start with an underscore are
internal; the sub-packages (:mod:`femupdate.updating`, :mod:`femupdate.sensitivity`,
:mod:`femupdate.reduction`, :mod:`femupdate.frf`, :mod:`femupdate.uniqueness`,
:mod:`femupdate.fullfield`, :mod:`femupdate.damage`, :mod:`femupdate.bayes`, :mod:`femupdate.io`) hold the
rest.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

from ._errors import FemupdateError, InputError, NumericalError
from ._version import __version__

#: public name -> module that defines it
_LAZY = {
    # model
    "Model": "model", "Parameter": "model", "from_matrices": "model", "Structure": "structure",
    # modal solution and correlation
    "Modes": "modal", "model_modes": "modal", "solve_modes": "modal", "normalise": "modal",
    "Correlation": "correlation", "correlate": "correlation", "mac": "correlation", "pair": "correlation",
    "Pairing": "correlation",
    # data
    "FRFData": "testdata", "MeasuredMode": "testdata", "StaticData": "testdata", "TestData": "testdata",
    # files
    "load_model": "io.model_file", "load_test_data": "io.testdata_json", "read_uff": "io.uff",
    "write_json": "io.results", "ClusterError": "dask_cluster",
    # sensitivities
    "jacobian": "sensitivity.jacobian",
    # updating
    "direct_update": "direct", "DirectResult": "direct",
    "Problem": "updating", "update": "updating", "UpdateResult": "updating", "Diagnostics": "updating",
    "multistart": "updating", "MultiStartResult": "updating",
    "frf_update": "updating", "frf_multistart": "updating", "global_search": "updating", "simulate_frf": "frf", "update_configurations": "updating.multiconfig",
    # Bayesian updating
    "posterior": "bayes", "PosteriorResult": "bayes", "Prior": "priors",
    # options and results
    "ModalOptions": "options", "PairingOptions": "options", "NoiseOptions": "options", "SolverOptions": "options",
    "FRFOptions": "options", "StartsOptions": "options", "ExecutionOptions": "options", "SamplerOptions": "options",
    "UpdateOptions": "options", "load_result": "serialise", "write_report": "report",
    # identifiability, reduction, damage
    "counting_criteria": "uniqueness", "exact_solutions": "uniqueness", "define_study": "uniqueness",
    "run_study": "uniqueness", "reduce": "reduction", "expand": "reduction", "detect_damage": "damage",
    "DamageOptions": "damage",
}
_RENAMED = {"load_test_data": "load_testdata", "simulate_frf": "simulate"}

__all__ = ["FemupdateError", "InputError", "NumericalError", "__version__", *_LAZY]


def __getattr__(name: str) -> Any:
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'femupdate' has no attribute {name!r}")
    value = getattr(importlib.import_module(f".{module}", __name__), _RENAMED.get(name, name))
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_LAZY))


if TYPE_CHECKING:  # the names as static type checkers and IDEs see them
    from .correlation import Correlation, Pairing, correlate, mac, pair
    from .dask_cluster import ClusterError
    from .damage import DamageOptions, detect_damage
    from .direct import DirectResult, direct_update
    from .frf import simulate as simulate_frf  # type: ignore[no-redef]  # frf.simulate is also a module
    from .io.model_file import load_model
    from .io.results import write_json
    from .io.testdata_json import load_testdata as load_test_data
    from .io.uff import read_uff
    from .modal import Modes, model_modes, normalise, solve_modes
    from .model import Model, Parameter, from_matrices
    from .reduction import expand, reduce
    from .sensitivity.jacobian import jacobian
    from .structure import Structure
    from .testdata import FRFData, MeasuredMode, StaticData, TestData
    from .uniqueness import counting_criteria, define_study, exact_solutions, run_study
    from .updating import (Diagnostics, MultiStartResult, Problem, UpdateResult, frf_multistart, frf_update,
                           global_search, multistart, update)
    from .updating.multiconfig import update_configurations
    from .bayes import PosteriorResult, posterior
    from .priors import Prior
    from .options import (ExecutionOptions, FRFOptions, ModalOptions, NoiseOptions, PairingOptions, SamplerOptions,
                          SolverOptions, StartsOptions, UpdateOptions)
    from .report import write_report
    from .serialise import load_result
