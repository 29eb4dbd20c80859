"""The Python API refuses misuse by name (issue 34, item 4).

Every public entry point of the top-level namespace, the constructors of the data and model
objects and the option classes are driven by hypothesis with wrong types and values of each
argument, the others valid.  Each call must end in a :class:`TypeError` or femupdate's
:class:`~femupdate.InputError` whose message names the argument (or the culprit inside it) —
never an AttributeError, IndexError, KeyError, a NumPy ValueError, or a result (a wrong value
that runs is a wrong answer).  The named cases of the issue are tested one by one first.

The examples are derandomized (the same every run: about 4,000 calls in 15 s); while the doors
were written, the same tables ran with 40 random examples per argument, three times over, until
nothing was found.
"""

from __future__ import annotations

import dataclasses
import functools
import math
import types
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import femupdate as fu
from femupdate import InputError
from femupdate import options as fo
from femupdate.damage import DamageOptions
from femupdate.examples import write_example_files
from femupdate.modal import Modes
from femupdate.model import Model
from femupdate.testdata import FRFData, TestData
from femupdate.uniqueness.study.definition import Study
from femupdate.updating.multiconfig import Configuration


DATA_DIR = Path(fu.__file__).parent / "data"


@functools.cache
def world() -> types.SimpleNamespace:
    """The valid objects every call starts from (built once, from the example files)."""
    import tempfile

    d = Path(tempfile.mkdtemp(prefix="femupdate-doors-"))
    write_example_files(d)
    w = types.SimpleNamespace(dir=d)
    w.model = fu.load_model(d / "two_dof.toml")
    w.data = fu.load_test_data(d / "two_dof_frequencies.json")
    w.frf = fu.load_test_data(d / "two_dof_frf.json")
    w.fig = fu.load_model(DATA_DIR / "figure2.toml")
    w.fig_data = fu.load_test_data(DATA_DIR / "figure2_test.json")
    w.truss = fu.load_model(d / "truss.toml")
    w.truss_data = fu.load_test_data(d / "truss_damaged.json")
    w.modes = fu.model_modes(w.model)
    w.study = fu.define_study(w.model, [(["1:x", "2:x"], 2)], starts=2)
    w.result = fu.update(w.model, w.data).to_json()
    w.mode = w.fig_data.modes[0]
    return w


# ------------------------------------------------------------------------------ the issue's cases
def test_the_issues_examples_are_refused_by_name():
    w = world()
    cases = [
        (lambda: fu.update(w.model, {"modes": []}), TypeError, "data must be a TestData, got a dict"),
        (lambda: fu.update(w.model, str(w.dir / "two_dof_frequencies.json")), TypeError, "femupdate.load_test_data"),
        (lambda: fu.update(w.data, w.model), TypeError, "the arguments look swapped"),
        (lambda: fu.correlate(w.modes, w.data), TypeError, "the arguments look swapped"),
        (lambda: fu.TestData(modes=[{"eigenvalue": 1.0}]), InputError, "modes[0] must be a MeasuredMode, got a dict"),
        (lambda: fu.multistart(w.model, w.data, seed=-1), InputError, "seed must be an integer >= 0"),
        (lambda: fu.direct_update(w.fig, np.ones(3)), TypeError, "data must be a TestData, got an ndarray"),
    ]
    for call, exc, words in cases:
        with pytest.raises(exc) as info:
            call()
        assert words in str(info.value)


def test_a_file_name_is_told_which_loader_reads_it():
    w = world()
    with pytest.raises(TypeError, match=r"model must be a Model, got the str 'm.toml': load the file with "
                                        r"femupdate.load_model\('m.toml'\)"):
        fu.model_modes("m.toml")


def test_the_file_functions_name_their_arguments(tmp_path):
    cases = [
        (lambda: fu.write_json(1, {}), "write_json: path must be a file name (str or os.PathLike), got the int 1"),
        (lambda: fu.write_json(tmp_path / "r.json", 3), "write_json: obj must be a result object or a JSON object"),
        (lambda: fu.read_uff(None), "read_uff: path must be a file name (str or os.PathLike), got None"),
    ]
    for call, words in cases:
        with pytest.raises(TypeError) as info:
            call()
        assert words in str(info.value)


def test_a_list_of_measured_modes_is_told_to_become_test_data():
    w = world()
    with pytest.raises(TypeError, match=r"wrap the modes as TestData\(modes=\[...\]\)"):
        fu.update(w.fig, list(w.fig_data.modes))


def test_valid_calls_still_run():
    """The doors refuse only what is wrong: the ordinary calls give their answers."""
    w = world()
    assert fu.update(w.model, w.data, params=("k1", "k2"), x0={"k1": 8.0}).success
    assert fu.correlate(w.data, w.modes).pairs
    assert fu.model_modes(w.model, n_modes=np.int64(1)).eigenvalues.size == 1
    assert fu.counting_criteria(np.int64(3), 1, 3, 3)["paper"].count == 3


# ------------------------------------------------------------------------------ wrong values
_OBJECTS = ("model", "data", "modes", "frf", "study")
_BASE = st.one_of(
    st.none(), st.booleans(), st.integers(-10**6, 10**6), st.floats(allow_nan=True, allow_infinity=True),
    st.text(max_size=6), st.binary(max_size=3), st.lists(st.integers(-3, 3), max_size=3),
    st.lists(st.text(max_size=3), min_size=1, max_size=2), st.dictionaries(st.text(max_size=3), st.integers(), max_size=2),
    st.builds(object), st.sampled_from(_OBJECTS).map(lambda name: getattr(world(), name)),
    st.integers(0, 3).map(lambda n: np.full((n, 2), np.nan)), st.just([[1.0], [1.0, 2.0]]))


def _is_real(v) -> bool:
    return isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(v, (bool, np.bool_))


def _is_int(v) -> bool:
    return isinstance(v, (int, np.integer)) and not isinstance(v, (bool, np.bool_))


def _indices(v, size: int) -> bool:
    """An index into ``size`` items, or a list of them."""
    items = [v] if _is_int(v) else v
    return isinstance(items, list) and all(_is_int(i) and 0 <= i < size for i in items)


@dataclasses.dataclass(frozen=True)
class Kind:
    """An argument's kind: which values are valid (they are filtered out of the wrong ones) and
    the wrong values of the right type worth trying besides (each with what the message must
    name, when not the argument itself)."""

    valid: object  # callable v -> bool
    extra: tuple = ()


def count(low=1, high=None, optional=False, huge=False):
    ok = lambda v: (v is None and optional) or (_is_int(v) and v >= low and (high is None or v <= high))  # noqa: E731
    return Kind(ok, ((low - 1, None), (2.5, None)) + (((10**15, None),) if huge else ()))


def starts_kind():
    """A number of starts, or StartsOptions' fields as a mapping (an empty one is valid)."""
    c = count(optional=True, huge=True)
    return Kind(lambda v: v == {} or c.valid(v), c.extra)


def real(low=-math.inf, high=math.inf, optional=False, low_open=False):
    def ok(v):
        return (v is None and optional) or (_is_real(v) and math.isfinite(v) and
                                            (v > low if low_open else v >= low) and v <= high)
    return Kind(ok)


FLAG = Kind(lambda v: isinstance(v, (bool, np.bool_)))
PATH = Kind(lambda v: isinstance(v, str) and v != "", (("", None),))


def names(optional=True, bad="no_such_name"):
    ok = lambda v: (v is None and optional) or (isinstance(v, (list, tuple)) and all(isinstance(x, str) for x in v))  # noqa: E731
    return Kind(ok, (([bad], bad), ("k1", None)))


def mapping(optional=True):
    return Kind(lambda v: (v is None and optional) or isinstance(v, dict))


def choice(*allowed, optional=False):
    return Kind(lambda v: (v is None and optional) or v in allowed, (("no-such-choice", None),))


def obj(*classes, optional=False):
    return Kind(lambda v: (v is None and optional) or isinstance(v, classes))


CALLABLE = Kind(lambda v: v is None or callable(v))
STR = Kind(lambda v: isinstance(v, str))
OPT_STR = Kind(lambda v: v is None or isinstance(v, str))
MODEL, MODES = obj(Model), obj(Modes)
DATA = Kind(lambda v: isinstance(v, TestData))
FRF = Kind(lambda v: isinstance(v, (TestData, FRFData)), ((None, None),))
def values_kind(names=("k1", "k2")):
    """Parameter values: None, {name: finite number} or one finite number per parameter (values
    of the right form that the model finds unphysical are refused naming the parameter)."""
    def ok(v):
        if v is None:
            return True
        if isinstance(v, dict):
            return set(v) <= set(names) and all(_is_real(x) and math.isfinite(x) for x in v.values())
        if isinstance(v, (list, tuple, np.ndarray)) and len(v) == len(names):
            return all(_is_real(x) and math.isfinite(x) for x in np.ravel(np.asarray(v, dtype=object)))
        return False
    return Kind(ok, (({"no_such_name": 1.0}, "no_such_name"), ([1.0] * (len(names) + 1), None),
                     ({names[0]: "8"}, None), ([np.nan] * len(names), None)))


VALUES = values_kind()
FIG = ("k1", "k2", "k3", "k4")
X0 = Kind(lambda v: v is None or (isinstance(v, dict) and set(v) <= {"k1", "k2"} and
                                  all(_is_real(x) and math.isfinite(x) and 3 <= x <= 11 for x in v.values())),
          (({"no_such_name": 1.0}, "no_such_name"), ({"k1": math.inf}, None)))


def array(ndim=None, complex_ok=False, low=-math.inf):
    """Numbers of ``ndim`` dimensions (any, by default), finite, not empty, at least ``low``."""
    def ok(v):
        if isinstance(v, (str, bytes, dict)) or v is None or isinstance(v, (bool, np.bool_)):
            return False
        a = np.asarray(v)
        return (a.dtype.kind in "iuf" + ("c" if complex_ok else "") and (ndim is None or a.ndim == ndim)
                and a.size > 0 and bool(np.all(np.isfinite(a))) and bool(np.all(np.real(a) >= low)))
    return Kind(ok, (("1,2", None),))


def options(cls, main=None):
    """An option object, None, a mapping of its fields (an empty one is valid), or its main value."""
    return Kind(lambda v: v is None or isinstance(v, cls) or v == {} or (main is not None and isinstance(v, main)),
                ((fo.SolverOptions() if cls is not fo.SolverOptions else fo.PairingOptions(), None),))


W = world
#: function -> (valid arguments, {argument: kind}); the call is ``fn(**valid)`` with one argument replaced
CALLS = {
    "load_model": (lambda: {"path": str(W().dir / "two_dof.toml")}, {"path": PATH}),
    "load_test_data": (lambda: {"path": str(W().dir / "two_dof_frequencies.json")},
                       {"path": PATH, "model": obj(Model, optional=True), "numbering": names(bad=None),
                        "sensors": names(bad=None)}),
    "model_modes": (lambda: {"model": W().model},
                    {"model": MODEL, "values": VALUES, "n_modes": count(optional=True, high=2, huge=True),
                     "normalisation": STR, "reuse": FLAG}),
    "correlate": (lambda: {"test": W().data, "model_modes": W().modes},
                  {"test": DATA, "model_modes": MODES, "min_mac": real(0, 1), "pairing": choice("auto", "mac", "order",
                                                                                                "frequency")}),
    "pair": (lambda: {"mac_matrix": np.eye(2), "model_eigenvalues": [1.0, 4.0], "test_eigenvalues": [1.0, 4.0]},
             {"mac_matrix": array(2), "rule": choice("auto", "mac", "order", "frequency"), "min_mac": real(0, 1),
              "shaped": Kind(lambda v: v is None), "model_eigenvalues": array(1), "test_eigenvalues": array(1),
              "strict": FLAG, "max_change": real(0)}),
    "mac": (lambda: {"A": np.ones((2, 1)), "B": np.eye(2)},
            {"A": array(complex_ok=True), "B": array(complex_ok=True)}),
    "solve_modes": (lambda: {"K": np.diag([2.0, 3.0]), "M": np.eye(2)},
                    {"K": array(2), "M": array(2), "n_modes": count(optional=True, high=2)}),
    "normalise": (lambda: {"Phi": np.eye(2), "how": "unit"}, {"Phi": array(2), "how": choice("unit", "max")}),
    "Problem": (lambda: {"model": W().model, "data": W().data},
                {"model": MODEL, "data": DATA, "params": names(), "x0": X0, "values": VALUES,
                 "parametrisation": choice("relative", "log", "absolute")}),
    "from_matrices": (lambda: {"dofs": ("1:x",), "K0": np.eye(1), "M0": np.eye(1)},
                      {"dofs": names(optional=False, bad="1:q"), "K0": array(2), "M0": array(2), "name": STR}),
    "direct_update": (lambda: {"model": W().fig, "data": W().fig_data},
                      {"model": MODEL, "data": DATA, "use": names(optional=False), "values": values_kind(FIG),
                       "unknowns": names(), "bounded": FLAG}),
    "update": (lambda: {"model": W().model, "data": W().data},
               {"model": MODEL, "data": DATA, "params": names(), "x0": X0, "values": VALUES,
                "modal": options(fo.ModalOptions), "pairing": options(fo.PairingOptions, str),
                "noise": options(fo.NoiseOptions, str), "solver": options(fo.SolverOptions),
                "frf": options(fo.FRFOptions), "options": options(fo.UpdateOptions),
                "max_nfev": count(), "min_mac": real(0, 1), "no_such_keyword": Kind(lambda v: False)}),
    "multistart": (lambda: {"model": W().model, "data": W().data, "starts": 2},
                   {"model": MODEL, "data": DATA, "starts": starts_kind(), "params": names(),
                    "values": VALUES,
                    "execution": options(fo.ExecutionOptions), "progress": CALLABLE,
                    "options": options(fo.UpdateOptions), "seed": count(low=0, optional=True)}),
    "frf_update": (lambda: {"model": W().model, "data": W().frf, "max_nfev": 3},
                   {"model": MODEL, "data": FRF, "params": names(), "x0": X0, "values": VALUES,
                    "noise": options(fo.NoiseOptions, str), "solver": options(fo.SolverOptions),
                    "frf": options(fo.FRFOptions)}),
    "frf_multistart": (lambda: {"model": W().model, "data": W().frf, "starts": 2, "max_nfev": 3},
                       {"model": MODEL, "data": FRF, "starts": starts_kind(), "params": names(),
                        "values": VALUES,
                        "progress": CALLABLE}),
    "global_search": (lambda: {"model": W().model, "data": W().frf, "method_options": {"popsize": 3, "maxiter": 2},
                               "max_nfev": 3},
                      {"model": MODEL, "data": FRF, "method": choice("differential_evolution", "basinhopping",
                                                                     "dual_annealing"),
                       "method_options": mapping(), "global_residual": choice("log", "linear", "relative",
                                                                              optional=True),
                       "params": names(), "values": VALUES, "progress": CALLABLE}),
    "posterior": (lambda: {"model": W().model, "data": W().data, "starts": 1, "samples": 50, "predictive": 0,
                           "measurement_std": {"eigenvalue": 0.01}},
                  {"model": MODEL, "data": DATA, "params": names(), "values": VALUES, "x0": X0, "priors": mapping(),
                   "sampler": options(fo.SamplerOptions, str), "progress": CALLABLE,
                   "checkpoint": Kind(lambda v: v is None or isinstance(v, str)), "samples": count(low=2, huge=True),
                   "chunks": count()}),
    "detect_damage": (lambda: {"model": W().truss, "data": W().truss_data, "bootstrap": 0, "refine": False},
                      {"model": MODEL, "data": DATA, "undamaged": obj(TestData, optional=True),
                       "elements": names(), "noise": mapping(), "descriptions": mapping(),
                       "options": options(DamageOptions), "bootstrap": count(low=0, huge=True)}),
    "reduce": (lambda: {"model": W().model, "T": np.array([[1.0], [0.0]]), "keep": ["1:x"]},
               {"model": MODEL, "T": array(2), "keep": names(bad="1:q"), "name": OPT_STR}),
    "expand": (lambda: {"model": W().model, "measured_dofs": ["1:x"], "shapes": np.ones((1, 1)),
                        "warn_validation": False},
               {"model": MODEL, "measured_dofs": Kind(lambda v: v == "1:x" or v == ["1:x"], ((["9:x"], "9:x"),)),
                "shapes": array(complex_ok=True),
                "method": choice("serep", "guyan", "irs"), "values": VALUES, "n_modes": count(optional=True, high=1),
                "warn_validation": FLAG}),
    "jacobian": (lambda: {"model": W().model, "modes": W().modes, "which": [0], "sensors": ["1:x"]},
                 {"model": MODEL, "modes": MODES,
                  "which": Kind(lambda v: _indices(v, 2), ((5, None),)),
                  "sensors": Kind(lambda v: v in ("1:x", "2:x") or (_is_int(v) and 0 <= v < 2) or v in ([0], [1])),
                  "params": Kind(lambda v: v is None or (_indices(v, 2) and not _is_int(v)),
                                 ((["no_such_name"], "no_such_name"),)),
                  "values": VALUES,
                  "relative_eigenvalues": FLAG, "sigma": real(optional=True), "tol": real(0, low_open=True),
                  "method": choice("auto", "nelson", "modal", "static", "subspace", "adjoint", "fd")}),
    "define_study": (lambda: {"model": W().model, "cases": [(["1:x", "2:x"], 2)], "starts": 2},
                     {"model": MODEL, "cases": Kind(lambda v: False), "starts": count(huge=True),
                      "seed": count(low=0), "values": VALUES, "params": names(),
                      "noise": Kind(lambda v: all(real(0, low_open=True).valid(x) for x in v), (([-1.0], None),)),
                      "min_mac": real(0, 1), "max_nfev": count(), "tol": real(0, low_open=True), "unit_rows": count(),
                      "log_uniform": FLAG}),
    "run_study": (lambda: {"study": W().study},
                  {"study": obj(Study), "scheduler": OPT_STR,
                   "workers": count(optional=True, high=256, huge=True), "checkpoint": OPT_STR, "progress": CALLABLE,
                   "rel_tol": real(0, 1, low_open=True), "cost_tol": real(0), "connect_timeout": real(0, low_open=True)}),
    "exact_solutions": (lambda: {"model": W().model},
                        {"model": MODEL, "values": VALUES, "n_modes": count(optional=True, high=2),
                         "params": names(), "bounds": FLAG}),
    "counting_criteria": (lambda: {"n": 2, "m": 1, "L": 2, "N": 2},
                          {"n": count(high=2), "m": count(high=2), "L": count(), "N": count()}),
    "simulate_frf": (lambda: {"model": W().model, "omega": [0.5, 1.0], "force": {"1:x": 1.0}},
                     {"model": MODEL, "omega": array(low=0), "force": Kind(lambda v: False, (({}, "force"),)),
                      "response": names(bad="9:x"), "values": VALUES, "noise": real(0),
                      "noise_kind": choice("relative", "absolute", "coherent"), "seed": count(low=0, optional=True),
                      "method": choice("auto", "dense", "sparse")}),
    "update_configurations": (lambda: {"model": W().model, "configurations": [Configuration(W().data)]},
                              {"model": MODEL, "configurations": Kind(lambda v: False), "params": names(), "x0": X0,
                               "values": VALUES}),
    "write_report": (lambda: {"path": str(W().dir / "report.html"), "result": W().result},
                     {"path": PATH, "result": Kind(lambda v: isinstance(v, (dict, str)))}),
    "load_result": (lambda: {"path_or_obj": W().result}, {"path_or_obj": Kind(lambda v: isinstance(v, (dict, str)))}),
    "TestData": (lambda: {"modes": W().fig_data.modes},
                 {"modes": Kind(lambda v: isinstance(v, (list, tuple)) and not v), "frf": obj(FRFData, optional=True),
                  "static": Kind(lambda v: isinstance(v, (list, tuple)) and not v), "units": mapping(optional=False),
                  "nodes": Kind(lambda v: isinstance(v, dict)),
                  "frf_sets": Kind(lambda v: isinstance(v, (list, tuple)) and not v),
                  "notes": Kind(lambda v: isinstance(v, (list, tuple)))}),
    "MeasuredMode": (lambda: {"eigenvalue": 1.0, "dofs": ("1:x",), "shape": np.ones(1)},
                     {"eigenvalue": real(0), "dofs": names(optional=False, bad="1:q"), "shape": array(1),
                      "label": STR, "reference_dof": Kind(lambda v: v is None or v == "1:x"),
                      "std_eigenvalue": real(1e-150, 1e150, optional=True), "weight": real(1e-150, 1e150, optional=True),
                      "damping_ratio": Kind(lambda v: v is None or (_is_real(v) and 0 <= v < 1))}),
    "FRFData": (lambda: {"omega": [1.0], "force": {"1:x": 1.0}, "dofs": ("1:x",), "response": np.ones((1, 1))},
                {"omega": Kind(lambda v: array(low=0).valid(v) and np.size(v) == 1), "force": Kind(lambda v: False, (({}, "force"),)),
                 "dofs": names(optional=False, bad="1:q"), "response": array(2)}),
    "StaticData": (lambda: {"force": {"1:x": 1.0}, "dofs": ("1:x",), "displacement": np.ones(1)},
                   {"force": Kind(lambda v: False, (({}, "force"),)), "dofs": names(optional=False, bad="1:q"),
                    "displacement": Kind(lambda v: array().valid(v) and np.size(v) == 1 and np.all(np.asarray(v) != 0))}),
    "Structure": (lambda: {"name": "s"}, {"name": STR}),
    "Model": (lambda: {"dofs": ("1:x",), "K0": np.eye(1), "M0": np.eye(1)},
              {"dofs": names(optional=False, bad="1:q"), "K0": array(2), "M0": array(2),
               "parameters": Kind(lambda v: isinstance(v, (list, tuple)) and not v), "name": STR,
               "nodes": Kind(lambda v: isinstance(v, dict))}),
    "Parameter": (lambda: {"name": "k", "value": 1.0},
                  {"name": Kind(lambda v: isinstance(v, str) and v.isidentifier()), "value": real(-1e300, 1e300),
                   "bounds": Kind(lambda v: isinstance(v, (list, tuple)) and len(v) == 2 and all(_is_real(b) for b in v)
                                  and v[0] <= 1.0 <= v[1] and v[0] < v[1]),
                   "fixed": FLAG, "unit": STR}),
}
#: what each function's wrong arguments may be told by, besides their own name
ALSO = {("posterior", "sampler"): "method", ("correlate", "pairing"): "pairing", ("pair", "rule"): "pairing", ("update", "pairing"): "pairing",
        ("Parameter", "name"): "parameter name", ("jacobian", "method"): "sensitivity method",
        ("global_search", "method"): "global method", ("direct_update", "use"): "data kind",
        ("simulate_frf", "noise_kind"): "noise kind", ("simulate_frf", "method"): "method",
        ("Model", "K0"): "K0", ("Model", "M0"): "M0"}

FIELD_ALSO = {(fo.PairingOptions, "rule"): "pairing"}
FIELDS = {
    fo.PairingOptions: {"rule": choice("auto", "mac", "order", "frequency"), "min_mac": real(0, 1),
                        "n_modes": count(optional=True)},
    fo.ModalOptions: {"formulation": choice("shapes", "mac", "dynamic"), "shape_scaling": choice("unit", "ref", "max"),
                      "ref_dof": OPT_STR, "use_shapes": FLAG, "sensitivity": choice("auto", "nelson", "modal", "static",
                                                                                     "subspace", "adjoint", "fd"),
                      "reuse": FLAG},
    fo.NoiseOptions: {"std": Kind(lambda v: v is None or v == {}), "weights": Kind(lambda v: v is None or v == {}),
                      "basis": choice("auto", "stated", "estimate")},
    fo.SolverOptions: {"method": choice("trf", "dogbox", "lm"), "max_nfev": count(), "ftol": real(0), "xtol": real(0),
                       "gtol": real(0), "parametrisation": choice("relative", "log", "absolute"),
                       "regularization": Kind(lambda v: v is None or v in ("gcv", "lcurve") or
                                              (_is_real(v) and math.isfinite(v) and v >= 0))},
    fo.FRFOptions: {"residual": choice("linear", "relative", "log", "auto"),
                    "weights": Kind(lambda v: v is None or array(low=0).valid(v)),
                    "lines": Kind(lambda v: v is None or (isinstance(v, list) and v and (
                        all(_is_int(i) and i >= 0 for i in v) or all(isinstance(i, bool) for i in v)))), "select": count(optional=True),
                    "resonance": choice("skip", "error", "keep"), "resonance_tol": real(0, 1, low_open=True),
                    "damping": Kind(lambda v: v is None or v == {}), "solver": choice("auto", "dense", "sparse")},
    fo.StartsOptions: {"starts": count(huge=True), "seed": count(low=0, optional=True), "log_uniform": FLAG,
                       "rel_tol": real(0, low_open=True), "cost_tol": real(0, optional=True),
                       "batched": Kind(lambda v: v is None or isinstance(v, bool))},
    fo.ExecutionOptions: {"scheduler": OPT_STR, "connect_timeout": real(0, low_open=True),
                          "jobs": count(optional=True, high=256), "threads": count(optional=True, high=1024)},
    fo.SamplerOptions: {"method": choice("laplace", "mcmc", "tmcmc"), "samples": count(low=2, huge=True),
                        "walkers": count(low=2, optional=True), "ensembles": count(), "steps": count(low=2),
                        "segment": count(), "tmcmc_steps": count(), "chunks": count(), "predictive": count(low=0, huge=True),
                        "level": real(0, 1, low_open=True), "target_cov": real(0, low_open=True),
                        "route": choice("auto", "compiled", "local")},
    fo.UpdateOptions: {"use": Kind(lambda v: v in ("modes", "frf", "static") or
                                   (isinstance(v, (list, tuple)) and set(v) <= {"modes", "frf", "static"})),
                       "modal": options(fo.ModalOptions), "solver": options(fo.SolverOptions)},
    DamageOptions: {"method": choice("l1", "tikhonov"), "iterations": count(), "bootstrap": count(low=0, huge=True),
                    "n_noise": count(low=2, optional=True, huge=True), "seed": count(low=0, optional=True),
                    "level": real(0.5, 1, low_open=True), "refine": FLAG, "max_located": count(optional=True)},
}


def _wrong(kind: Kind):
    """Wrong values of a kind: the base pool without the valid ones, and its extra wrong values,
    each with the text the message must hold (None: the argument's name)."""
    pool = _BASE.filter(lambda v: not _safe(kind.valid, v)).map(lambda v: (v, None))
    return st.one_of(pool, st.sampled_from(kind.extra)) if kind.extra else pool


def _safe(pred, v) -> bool:
    try:
        return bool(pred(v))
    except Exception:
        return False


def _culprits(value) -> list[str]:
    """How a message may name what the argument held: a string as written (repr), a mapping's keys,
    a sequence's string items."""
    if isinstance(value, str):
        return [repr(value)]
    if isinstance(value, dict):
        return [repr(k) for k in value if isinstance(k, str)]
    if isinstance(value, (list, tuple)):
        return [repr(v) for v in value if isinstance(v, str)]
    return []


#: arguments whose wrong values may also be a NumericalError naming them: pair's non-finite MAC
#: of a shaped test mode (the error it raises when the MAC comes from a failed computation)
NUMERICAL = {"mac_matrix"}


def _check(call, name: str, must: str | None, alias: str | None, value=None) -> None:
    try:
        out = call()
    except (TypeError, InputError) + ((fu.NumericalError,) if name in NUMERICAL else ()) as exc:
        text = str(exc)
        wanted = [w for w in (must, name, alias) if w] + _culprits(value)
        assert any(w in text for w in wanted), f"{name}: the message names none of {wanted}: {text}"
        return
    raise AssertionError(f"{name}: a wrong value was accepted and gave {type(out).__name__}")


PAIRS = [(fn, arg) for fn, (_, kinds) in CALLS.items() for arg in kinds]


@pytest.mark.parametrize("fn,arg", PAIRS, ids=[f"{f}-{a}" for f, a in PAIRS])
@settings(max_examples=12, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.filter_too_much, HealthCheck.too_slow])
@given(data=st.data())
def test_every_public_function_refuses_a_wrong_argument_by_name(fn, arg, data):
    valid, kinds = CALLS[fn]
    value, must = data.draw(_wrong(kinds[arg]), label=arg)
    kwargs = dict(valid(), **{arg: value})
    target = getattr(fu, fn)
    _check(lambda: target(**kwargs), arg, must, ALSO.get((fn, arg)), value)


FIELD_PAIRS = [(cls, name) for cls, kinds in FIELDS.items() for name in kinds]


@pytest.mark.parametrize("cls,name", FIELD_PAIRS, ids=[f"{c.__name__}-{n}" for c, n in FIELD_PAIRS])
@settings(max_examples=15, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.filter_too_much, HealthCheck.too_slow])
@given(data=st.data())
def test_every_option_field_refuses_a_wrong_value_by_name(cls, name, data):
    value, must = data.draw(_wrong(FIELDS[cls][name]), label=name)
    extra = {"method": "mcmc"} if cls is fo.SamplerOptions and name in ("walkers", "ensembles", "steps") else {}
    _check(lambda: cls(**{name: value, **extra}), name, must, FIELD_ALSO.get((cls, name), name.replace("_", " ")),
           value)
