"""The checks at the door of the public functions: each argument's type and shape, as SciPy does.

Every public entry point calls these first, one line per argument, so that misuse ends in a
:class:`TypeError` (a wrong type) or an :class:`~femupdate.InputError` (a wrong value) that names
the function, the argument and what it got — never in an AttributeError or a NumPy error from
deep inside.  Arguments that look swapped (``update(data, model)``, ``correlate(modes, data)``)
are recognised and said.  A check returns the value it checked, unchanged (or the plain form a
caller reads, such as a tuple of names), so that what runs afterwards is what ran before.
"""

from __future__ import annotations

import functools
import math
import numbers
import os
from collections.abc import Iterator, Mapping, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    import scipy.sparse as sp

from ._errors import InputError

#: how each kind of femupdate object is made, for the messages
_MAKE = {
    "Model": "femupdate.load_model(path), Structure(...).build() or from_matrices(...)",
    "TestData": "femupdate.load_test_data(path), or TestData(modes=[MeasuredMode(...), ...])",
    "Modes": "femupdate.model_modes(model)",
}
#: what to call on a file name given where an object is expected
_LOADER = {"Model": "femupdate.load_model", "TestData": "femupdate.load_test_data", "Modes": None}


def shown(value: Any) -> str:
    """What a value is, for a message: ``the str 'a.json'``, ``a dict``, ``an ndarray of shape (3,)``."""
    if value is None:
        return "None"
    if isinstance(value, (bool, np.bool_)):
        return repr(bool(value))
    name = type(value).__name__
    if isinstance(value, (str, bytes, numbers.Number)):
        text = repr(value)
        return f"the {name} {text if len(text) <= 60 else text[:57] + '...'}"
    if isinstance(value, np.ndarray):
        return f"an ndarray of shape {value.shape} ({value.dtype})"
    if isinstance(value, os.PathLike):
        return f"the path {os.fspath(value)!r}"
    if isinstance(value, (list, tuple, set, frozenset, dict)):
        return f"a {name} of {len(value)} item{'s' if len(value) != 1 else ''}"
    return f"{'an' if name[:1].lower() in 'aeiou' else 'a'} {name}"


def _at(where: str) -> str:
    return f"{where}: " if where else ""


@functools.cache
def _classes() -> tuple[type, ...]:
    """femupdate's object classes (imported once, when a door first needs them)."""
    from .modal import Modes
    from .model import Model
    from .testdata import FRFData, MeasuredMode, StaticData, TestData

    return Model, TestData, Modes, FRFData, MeasuredMode, StaticData


def _kind(value: Any) -> str | None:
    """The femupdate kind of ``value`` ("Model", "TestData", "Modes", ...), or None."""
    return next((cls.__name__ for cls in _classes() if isinstance(value, cls)), None)


def _wrong(where: str, name: str, want: str, value: Any, also: str = "") -> TypeError:
    """The TypeError ``where: name must be a WANT, got VALUE`` with a hint for a file name (``also``:
    the other kinds accepted, ``" or FRFData"``)."""
    hint = ""
    if isinstance(value, (str, os.PathLike)) and want in _LOADER and _LOADER[want]:
        hint = f": load the file with {_LOADER[want]}({os.fspath(value)!r})"
    elif want in _MAKE:
        hint = f" (make one with {_MAKE[want]})"
    return TypeError(f"{_at(where)}{name} must be a {want}{also}, got {shown(value)}{hint}")


def swapped(where: str, *pairs: tuple[str, Any, str]) -> None:
    """Refuse arguments given in the wrong order: each ``(name, value, kind wanted)``; when two of
    them hold each other's kinds the message says so (``update(data, model)``).

    Raises
    ------
    TypeError
        Two arguments whose values are of each other's wanted kind.
    """
    kinds = [(_kind(v), n, want) for n, v, want in pairs]
    if all(got == want for got, _, want in kinds):  # the common case, at once
        return
    for i, (got_i, name_i, want_i) in enumerate(kinds):
        for got_j, name_j, want_j in kinds[i + 1:]:
            if got_i is not None and got_i != want_i and got_i == want_j and got_j == want_i:
                names = ", ".join(p[0] for p in pairs)
                raise TypeError(f"{where}: the arguments look swapped: {name_i} got a {got_i} and {name_j} a {got_j}; "
                                f"call {where}({names})")


def model_arg(value: Any, name: str = "model", where: str = ""):
    """``value`` if it is a :class:`~femupdate.Model`, else a :class:`TypeError` naming ``name``."""
    from .model import Model

    if not isinstance(value, Model):
        raise _wrong(where, name, "Model", value)
    return value


def data_arg(value: Any, name: str = "data", where: str = "", *, frf: bool = False, optional: bool = False,
             sets: bool = False):
    """``value`` if it is :class:`~femupdate.TestData` (or, with ``frf``, :class:`~femupdate.FRFData`;
    with ``optional``, None; with ``sets``, a non-empty list or tuple of TestData), else a
    :class:`TypeError` naming ``name`` — a list of :class:`~femupdate.MeasuredMode` or a file
    name is told how to become one."""
    from .testdata import FRFData, MeasuredMode, TestData

    if isinstance(value, TestData) or (frf and isinstance(value, FRFData)) or (optional and value is None):
        return value
    if sets and isinstance(value, (list, tuple)) and value and all(isinstance(d, TestData) for d in value):
        return value
    if isinstance(value, MeasuredMode) or (isinstance(value, (list, tuple)) and value
                                           and all(isinstance(m, MeasuredMode) for m in value)):
        of = " of MeasuredMode" if isinstance(value, (list, tuple)) else ""
        raise TypeError(f"{_at(where)}{name} must be a TestData, got {shown(value)}{of}: wrap the modes as "
                        "TestData(modes=[...])")
    raise _wrong(where, name, "TestData", value, (" or FRFData" if frf else "") + (" or None" if optional else ""))


def modes_arg(value: Any, name: str = "modes", where: str = ""):
    """``value`` if it is :class:`~femupdate.Modes`, else a :class:`TypeError` naming ``name``."""
    from .modal import Modes

    if not isinstance(value, Modes):
        raise _wrong(where, name, "Modes", value)
    return value


def path_arg(value: Any, name: str = "path", where: str = "") -> Path:
    """``value`` as a :class:`~pathlib.Path` if it is a str or path-like (not empty), else a
    :class:`TypeError` (or :class:`InputError` for an empty name) naming ``name``."""
    if isinstance(value, bytes) or not isinstance(value, (str, os.PathLike)):
        kind = _kind(value)
        hint = f" (this function reads a file; a {kind} is already loaded)" if kind else ""
        raise TypeError(f"{_at(where)}{name} must be a file name (str or os.PathLike), got {shown(value)}{hint}")
    text = os.fspath(value)
    if not isinstance(text, str) or not text.strip():
        raise InputError(f"{_at(where)}{name} is an empty file name")
    if "\x00" in text:
        raise InputError(f"{_at(where)}{name} {text!r} contains a NUL character")
    return Path(text)


def flag_arg(value: Any, name: str, where: str = "") -> bool:
    """``value`` as a bool if it is one (NumPy's included), else a :class:`TypeError` naming ``name``."""
    if not isinstance(value, (bool, np.bool_)):
        raise TypeError(f"{_at(where)}{name} must be True or False, got {shown(value)}")
    return bool(value)


def count_arg(value: Any, name: str, where: str = "", *, low: int | None = 1, high: int | None = None,
              optional: bool = False) -> int | None:
    """``value`` as an int in ``[low, high]`` (None with ``optional``): a :class:`TypeError` for
    what is no number (a str, a bool, a list), an :class:`InputError` for a number that is no
    integer (1.5, 2.0, NaN) or out of range (``low`` None: any integer; its range is the
    caller's to check), naming ``name``."""
    if value is None and optional:
        return None
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Real):
        raise TypeError(f"{_at(where)}{name} must be an integer{' or None' if optional else ''}, got {shown(value)}")
    if not isinstance(value, numbers.Integral):
        raise InputError(f"{_at(where)}{name} must be an integer, got {value!r}")
    n = int(value)
    if (low is not None and n < low) or (high is not None and n > high):
        rng = " and ".join(s for s in (f">= {low}" if low is not None else "", f"<= {high}" if high is not None else "")
                           if s)
        raise InputError(f"{_at(where)}{name} must be an integer {rng}, got {n}")
    return n


def real_arg(value: Any, name: str, where: str = "", *, low: float | None = None, high: float | None = None,
             low_open: bool = False, optional: bool = False) -> float | None:
    """``value`` as a finite float in the range: a :class:`TypeError` for a non-number (bools and
    strings refused), an :class:`InputError` for NaN, infinity or out of range, naming ``name``."""
    if value is None and optional:
        return None
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Real):
        raise TypeError(f"{_at(where)}{name} must be a number{' or None' if optional else ''}, got {shown(value)}")
    v = float(value)
    if not math.isfinite(v) or (low is not None and (v <= low if low_open else v < low)) \
            or (high is not None and v > high):
        lo = "" if low is None else f" {'>' if low_open else '>='} {low:g}"
        hi = "" if high is None else f"{' and' if lo else ''} <= {high:g}"
        raise InputError(f"{_at(where)}{name} must be a finite number{lo}{hi}, got {v!r}")
    return v


def number_arg(value: Any, name: str, where: str = "", *, complex_ok: bool = False) -> None:
    """Refuse what is not a number (a str, a bool, None, a list): a :class:`TypeError` naming
    ``name``; the value's range is the caller's to check."""
    kind = numbers.Number if complex_ok else numbers.Real
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, kind):
        raise TypeError(f"{_at(where)}{name} must be a number, got {shown(value)}")


def str_arg(value: Any, name: str, where: str = "", *, optional: bool = False,
            error: type[Exception] = TypeError) -> str | None:
    """``value`` if it is a str (None with ``optional``), else a :class:`TypeError` (or ``error``)
    naming ``name``."""
    if value is None and optional:
        return None
    if not isinstance(value, str):
        raise error(f"{_at(where)}{name} must be a str{' or None' if optional else ''}, got {shown(value)}")
    return value


def choice_arg(value: Any, allowed: Sequence[str], name: str, where: str = "") -> str:
    """``value`` if it is one of ``allowed``: a :class:`TypeError` for a non-string, an
    :class:`InputError` for an unknown one, naming ``name`` and the choices."""
    if not isinstance(value, str):
        raise TypeError(f"{_at(where)}{name} must be one of {', '.join(allowed)}, got {shown(value)}")
    if value not in allowed:
        raise InputError(f"{_at(where)}unknown {name} {value!r}: use {', '.join(allowed)}")
    return value


def callable_arg(value: Any, name: str, where: str = "", *, optional: bool = True):
    """``value`` if it is callable (or None), else a :class:`TypeError` naming ``name``."""
    if (value is None and optional) or callable(value):
        return value
    raise TypeError(f"{_at(where)}{name} must be a function{' or None' if optional else ''}, got {shown(value)}")


def mapping_arg(value: Any, name: str, where: str = "", *, optional: bool = True) -> Mapping | None:
    """``value`` if it is a mapping with str keys (or None), else a :class:`TypeError` naming ``name``."""
    if value is None and optional:
        return None
    if not isinstance(value, Mapping):
        raise TypeError(f"{_at(where)}{name} must be a mapping (a dict){' or None' if optional else ''}, got "
                        f"{shown(value)}")
    bad = [k for k in value if not isinstance(k, str)]
    if bad:
        raise TypeError(f"{_at(where)}{name}: keys must be str, got {shown(bad[0])}")
    return value


def strings_arg(value: Any, name: str, where: str = "", *, optional: bool = True,
                allowed: Sequence[str] | None = None, what: str = "name") -> tuple[str, ...] | None:
    """``value`` as a tuple of str (None with ``optional``): a lone string, a non-sequence or a
    non-string item is a :class:`TypeError`; an item not in ``allowed`` (when given) an
    :class:`InputError` naming it and the choices."""
    if value is None and optional:
        return None
    if isinstance(value, (str, bytes)):
        raise TypeError(f"{_at(where)}{name} must be a list of {what}s, got {shown(value)} (give [{value!r}])")
    if not isinstance(value, (Sequence, np.ndarray, set, frozenset)) or isinstance(value, Mapping):
        raise TypeError(f"{_at(where)}{name} must be a list of {what}s{' or None' if optional else ''}, got "
                        f"{shown(value)}")
    if isinstance(value, np.ndarray) and value.dtype.kind not in "UO":
        raise TypeError(f"{_at(where)}{name} must be a list of {what}s, got {shown(value)}")
    items = tuple(value.tolist() if isinstance(value, np.ndarray) else value)
    for v in items:
        if not isinstance(v, str):
            raise TypeError(f"{_at(where)}{name} must be a list of {what}s (str), got an item {shown(v)}")
    if allowed is not None:
        unknown = [v for v in items if v not in allowed]
        if unknown:
            raise InputError(f"{_at(where)}{name}: unknown {what} {unknown[0]!r} (known: {', '.join(allowed) or 'none'})")
    return items


def params_arg(value: Any, name: str = "params", where: str = "") -> tuple[str, ...] | None:
    """``value`` (None, or a sequence of parameter names) as a tuple of names, else a
    :class:`TypeError` naming ``name``; the names themselves are checked against the model where
    they are used (an unknown or repeated one is named there)."""
    return strings_arg(value, name, where, what="parameter name")


def modes_count(model, value: Any, name: str = "n_modes", where: str = "") -> int | None:
    """``value`` (None, or a number of modes from 1 to the model's dofs) checked, and the memory
    of that many shapes and the eigensolver's basis (three vectors of the model's size each)
    against the available memory (:func:`femupdate._budget.check_memory`)."""
    from ._budget import check_memory

    n = count_arg(value, name, where, optional=True)
    if n is not None and n > model.n_dofs:
        raise InputError(f"{name} must be between 1 and the number of dofs ({model.n_dofs}), got {n}")  # as before
    if n is not None:
        check_memory(f"{name}={n}", 24.0 * n * model.n_dofs, "the mode shapes and the eigensolver's basis")
    return n


def problem_args(where: str, model: Any, data: Any, *, params: Any = None, x0: Any = None, values: Any = None,
                 frf: bool = False, sets: bool = False, data_name: str = "data") -> None:
    """The door of a verb that takes a model and test data (:func:`femupdate.update` and its
    kin): the two in their order (:func:`swapped`), then :func:`model_arg`, :func:`data_arg`,
    :func:`params_arg`, :func:`x0_arg` and :func:`values_arg`.

    Raises
    ------
    TypeError, InputError
        The first argument of a wrong type or value, named.
    """
    swapped(where, ("model", model, "Model"), (data_name, data, "TestData"))
    model_arg(model, "model", where)
    data_arg(data, data_name, where, frf=frf, sets=sets)
    params_arg(params, "params", where)
    x0_arg(model, x0, "x0", where)
    values_arg(model, values, "values", where)


def x0_arg(model, value: Any, name: str = "x0", where: str = "") -> Mapping | None:
    """``value`` if None or a mapping {parameter of ``model``: finite number}, else a
    :class:`TypeError` / :class:`InputError` naming ``name`` and the entry."""
    mapping_arg(value, name, where)
    for key, v in (value or {}).items():
        if key not in model.parameter_names:
            raise InputError(f"{_at(where)}{name}: {key!r} is not a parameter of model {model.name!r} (its parameters: "
                             f"{', '.join(model.parameter_names) or 'none'})")
        real_arg(v, f"{name}[{key!r}]", where)
    return value


def values_arg(model, value: Any, name: str = "values", where: str = ""):
    """``value`` if it is what :meth:`Model.resolve` reads — None, a mapping {parameter: number}
    or one finite number per parameter — else a :class:`TypeError` / :class:`InputError` naming
    ``name``.  Returned unchanged."""
    if value is None:
        return value
    if isinstance(value, Mapping):
        return x0_arg(model, value, name, where)
    if isinstance(value, (str, bytes)) or not isinstance(value, (Sequence, np.ndarray)):
        raise TypeError(f"{_at(where)}{name} must be None, a mapping {{parameter: value}} or one value per parameter "
                        f"({', '.join(model.parameter_names)}), got {shown(value)}")
    shape = np.asarray(array_arg(value, name, where, ndim=1)).shape
    if shape != (len(model.parameters),):
        raise InputError(f"{_at(where)}{name} must hold {len(model.parameters)} values "
                         f"({', '.join(model.parameter_names)}), got shape {shape}")
    return value


def as_array(value: Any) -> np.ndarray | None:
    """``value`` as an ndarray, or None for what is no array (a str, bytes, a mapping, None, a
    ragged nesting)."""
    if isinstance(value, (str, bytes, Mapping)) or value is None:
        return None
    try:
        return np.asarray(value)
    except (TypeError, ValueError):  # ragged nesting
        return None


def array_arg(value: Any, name: str, where: str = "", *, ndim: int | None = None, complex_ok: bool = False,
              finite: bool = True, optional: bool = False, empty: bool = True) -> np.ndarray | None:
    """``value`` as a float (or complex) ndarray of ``ndim`` dimensions with finite entries: a
    :class:`TypeError` for what is not numeric (strings, objects, booleans), an
    :class:`InputError` for a wrong number of dimensions, NaN or infinity (or, without ``empty``,
    no entry), naming ``name``."""
    if value is None and optional:
        return None
    arr = as_array(value)
    if arr is None:
        raise TypeError(f"{_at(where)}{name} must be an array of numbers, got {shown(value)}"
                        + (" that is not rectangular" if isinstance(value, (list, tuple)) else ""))
    if arr.dtype.kind not in "iuf" + ("c" if complex_ok else "") or arr.dtype.kind == "b":
        what = "an array of real numbers" if not complex_ok else "an array of numbers"
        raise TypeError(f"{_at(where)}{name} must be {what}, got {shown(value)}"
                        + (f" of {arr.dtype}" if isinstance(value, (list, tuple)) else ""))
    if ndim is not None and arr.ndim != ndim:
        raise InputError(f"{_at(where)}{name} must be {ndim}-D, got shape {arr.shape}")
    if not empty and arr.size == 0:
        raise InputError(f"{_at(where)}{name} is empty (shape {arr.shape})")
    if finite and arr.size and not np.all(np.isfinite(arr)):
        raise InputError(f"{_at(where)}{name} holds NaN or infinite values")
    return arr


def indices_arg(value: Any, name: str, where: str = "", *, size: int, labels: bool = False,
                single: bool = True, what: str = "") -> None:
    """``value`` as indices into ``size`` items: an int or a sequence of ints (with ``labels``,
    of str instead; a lone int or str only with ``single``) — a :class:`TypeError` for another
    type (a float, a bool, a mixture), an :class:`InputError` for an index out of
    ``0 .. size - 1``, naming ``name``."""
    if isinstance(value, (str, numbers.Integral)) and not isinstance(value, bool) and not single:
        raise TypeError(f"{_at(where)}{name} must be a list of {'labels or ' if labels else ''}indices, got "
                        f"{shown(value)} (give [{value!r}])")
    items = [value] if isinstance(value, (numbers.Integral, str)) else value
    if isinstance(items, np.ndarray):
        if items.ndim > 1 or items.dtype.kind not in "iu" + ("UO" if labels else ""):
            raise TypeError(f"{_at(where)}{name} must be {'labels or ' if labels else ''}indices (int), got "
                            f"{shown(items)}")
        if items.dtype.kind in "iu" and (not items.size or (items.min() >= 0 and items.max() < size)):
            return  # indices in range, at once (the updating's Jacobian passes them at every evaluation)
        items = items.tolist()
    if not isinstance(items, Sequence) or isinstance(items, (str, bytes)):
        raise TypeError(f"{_at(where)}{name} must be {'labels or ' if labels else ''}indices (int), got {shown(value)}")
    ints = [v for v in items if isinstance(v, numbers.Integral) and not isinstance(v, (bool, np.bool_))]
    strs = [v for v in items if isinstance(v, str)] if labels else []
    if len(items) and not (len(ints) == len(items) or len(strs) == len(items)):
        bad = next(v for v in items if v not in ints and v not in strs)
        raise TypeError(f"{_at(where)}{name} must be {'labels (str) or ' if labels else ''}indices (int), got an item "
                        f"{shown(bad)}")
    out = [int(v) for v in ints if not 0 <= int(v) < size]
    if out:
        raise InputError(f"{_at(where)}{name}: {what + ' ' if what else ''}index out of range 0..{size - 1} (got "
                         f"{out[0]})")


def bools_arg(value: Any, name: str, where: str = "", *, optional: bool = True) -> np.ndarray | None:
    """``value`` as a 1-D bool array (True/False or 0/1 entries; None with ``optional``), else a
    :class:`TypeError` / :class:`InputError` naming ``name``."""
    if value is None and optional:
        return None
    arr = as_array(value)
    if arr is None or arr.dtype.kind not in "biu" or (arr.dtype.kind != "b" and not np.isin(arr, (0, 1)).all()):
        raise TypeError(f"{_at(where)}{name} must be an array of True/False, got {shown(value)}")
    if arr.ndim != 1:
        raise InputError(f"{_at(where)}{name} must be 1-D, got shape {arr.shape}")
    return arr.astype(bool)


def result_arg(value: Any, name: str = "result", where: str = "", *, objects: bool = True):
    """``value`` if it is a result's JSON object (a mapping), a JSON file name (str or path-like)
    or, with ``objects``, a result object (one with ``to_json``), else a :class:`TypeError`
    naming ``name``."""
    if isinstance(value, (Mapping, str, os.PathLike)) or (objects and callable(getattr(value, "to_json", None))):
        return value
    hint = " (already a result: use it as it is)" if callable(getattr(value, "to_json", None)) else ""
    raise TypeError(f"{_at(where)}{name} must be {'a result object, ' if objects else ''}a result's JSON object (a dict) "
                    f"or the name of its JSON file, got {shown(value)}{hint}")


def frf_fit(frf_options, noise_options, data, where: str = "") -> None:
    """The FRF weights and the stated FRF standard deviation (``measurement_std["frf"]``) of the
    option objects against every FRF set of ``data``: each must broadcast to the set's response,
    (lines, response dofs); else an :class:`InputError` naming it and the shapes."""
    sets = getattr(data, "frf_sets", None) or ((data,) if hasattr(data, "response") else ())
    given = (("weights", frf_options.weights),
             ("measurement_std['frf']", dict(noise_options.std or {}).get("frf")))
    for name, value in given:
        if value is None or isinstance(value, Mapping):
            continue
        arr = np.asarray(array_arg(value, name, where))
        for s in sets:
            try:
                np.broadcast_shapes(arr.shape, s.response.shape)
            except ValueError:
                raise InputError(f"{_at(where)}{name} of shape {arr.shape} does not fit the FRF data's response "
                                 f"(lines x response dofs: {s.response.shape})") from None


@contextmanager
def input_errors() -> Iterator[None]:
    """The checks of a value object's fields (:class:`~femupdate.TestData`, :class:`~femupdate.Model`,
    ...), which the file readers build too: a wrong type there is bad input — an
    :class:`InputError` with the same message (exit 2 on the command line) — not a TypeError."""
    try:
        yield
    except TypeError as exc:
        raise InputError(str(exc)) from None


def options_arg(value: Any, cls: type, name: str, where: str = ""):
    """``value`` if None, an object of ``cls`` or a mapping of its fields, else a :class:`TypeError`
    naming ``name``."""
    if value is None or isinstance(value, (cls, Mapping)):
        return value
    raise TypeError(f"{_at(where)}{name} must be a {cls.__name__} (or a mapping of its fields), got {shown(value)}")


__all__ = ["largest", "symmetric_pattern_close", "shown", "swapped", "model_arg", "data_arg", "modes_arg", "path_arg", "flag_arg", "count_arg", "real_arg",
           "number_arg", "str_arg", "choice_arg", "callable_arg", "mapping_arg", "strings_arg", "params_arg", "x0_arg", "values_arg",
           "as_array", "array_arg", "indices_arg", "bools_arg", "result_arg", "frf_fit", "input_errors", "options_arg", "problem_args", "modes_count"]


def largest(x: np.ndarray) -> float:
    """Largest magnitude of ``x`` (0 when empty), without a copy of its absolute values."""
    return float(max(x.max(), -x.min())) if x.size else 0.0


def symmetric_pattern_close(A: sp.csr_array, tol: float) -> bool:
    """Whether canonical ``A`` has a symmetric pattern and ``|A - A^T| <= tol`` entry by entry:
    one transposed copy of the arrays and no difference matrix (False: check the long way)."""
    T = A.T.tocsr()  # canonical: sorted indices
    if not (np.array_equal(T.indptr, A.indptr) and np.array_equal(T.indices, A.indices)):
        return False
    step = 1 << 22
    return all(largest(A.data[i:i + step] - T.data[i:i + step]) <= tol for i in range(0, A.nnz, step))
