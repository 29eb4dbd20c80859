"""Results that serialise themselves: one JSON form per kind of result, written and read back
by the result classes, so that Python and the command line write the same files.

Every result class that a command writes mixes in :class:`Serialisable`:

* ``result.to_json()`` — the JSON object of the result (the keys docs/file-formats.md lists
  for its kind, with ``kind`` and ``schema_version``), as ``femupdate <command> --json`` writes it;
* ``Result.from_json(obj)`` — the typed result back from that object (arrays the JSON does not
  hold, such as the residual vector, come back empty);
* ``result.write_json(path)`` and ``result.write_report(path)`` — the JSON file and the HTML
  report of the command line, from Python;
* ``result.to_frame()`` — its main table as a :class:`pandas.DataFrame` (pandas is not a
  dependency: installed, it is used).

A result made by a library verb (:func:`femupdate.update`, :func:`femupdate.multistart`, ...)
carries its :class:`RunContext`: the model and test data it was made from (for the report's
recomputed figures and for the JSON's parameter units, bounds and flags), not written; a result
read back from JSON carries the JSON's own copies of those keys instead.

:func:`load_result` reads any result file into its typed result.
"""

from __future__ import annotations

import dataclasses
import json
import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any, ClassVar

from ._checks import result_arg
from ._errors import InputError

#: the version of the JSON results' schema, written as ``schema_version`` with every result; it
#: changes when a key changes meaning or goes (adding keys does not change it)
SCHEMA_VERSION = 1

#: kind -> the result class that writes and reads it (filled as the classes are defined)
REGISTRY: dict[str, type] = {}


@dataclasses.dataclass(frozen=True)
class RunContext:
    """What a result knows of the run that made it, beyond its own numbers.

    Attributes
    ----------
    model : Model, optional
        The model the result was computed on (not serialised): its name, parameter units and
        bounds, and the flags of the identified values, and for the report its geometry.
    data : TestData, optional
        The test data (not serialised): their notes and units in the JSON, and for the report the
        recomputed correlation.
    damping : Damping, optional
        The model's damping compared with the data's damping ratios.
    before : mapping of str to float, optional
        The parameter values the run started the model at (``--set``), for the report.
    kind : str
        The kind of result the run made, where the class alone does not say it (an
        :class:`~femupdate.updating.frf.FRFUpdateResult` of :func:`femupdate.update` is an
        ``"update"``, of :func:`femupdate.updating.frf_update` an ``"frf-update"``).
    stored : mapping
        Keys of a result read back from JSON (``model``, ``parameter_units``, ``bounds``,
        ``flags``, ``units``, ...), used where ``model`` and ``data`` are absent.
    """

    model: Any = None
    data: Any = None
    damping: Any = None
    before: Mapping[str, float] | None = None
    kind: str = ""
    stored: Mapping[str, Any] = dataclasses.field(default_factory=dict)

    def replace(self, **changes) -> RunContext:
        return dataclasses.replace(self, **changes)

    def get(self, key: str, default=None):
        """A key of the result's JSON read back (:attr:`stored`)."""
        return self.stored.get(key, default)

    @property
    def model_name(self) -> str:
        return self.model.name if self.model is not None else self.stored.get("model", "")


class Serialisable:
    """Mixin of the results the commands write (module docstring).

    A subclass sets :attr:`kind` and implements :meth:`payload` (the JSON object without
    ``kind`` and ``schema_version``) and :meth:`from_payload`.
    """

    #: the kind of result (the command that writes it)
    kind: ClassVar[str] = ""
    #: the kinds :meth:`from_json` reads (default: :attr:`kind`)
    kinds: ClassVar[tuple[str, ...]] = ()

    def __init_subclass__(cls, **kw) -> None:
        super().__init_subclass__(**kw)
        for k in cls.__dict__.get("kinds") or ((cls.__dict__["kind"],) if cls.__dict__.get("kind") else ()):
            REGISTRY.setdefault(k, cls)

    # ------------------------------------------------------------------ to implement
    def payload(self) -> dict:
        """The result's JSON object, without ``kind`` and ``schema_version``."""
        raise NotImplementedError

    @classmethod
    def from_payload(cls, obj: Mapping[str, Any]):
        """The typed result of a JSON object of this kind."""
        raise NotImplementedError

    # ------------------------------------------------------------------ the API
    @property
    def run_context(self) -> RunContext:
        """The :class:`RunContext` (empty when the result was made without one)."""
        return getattr(self, "context", None) or RunContext()

    def with_context(self, **changes):
        """A copy with the context's fields changed (``model=``, ``data=``, ``damping=``, ...)."""
        return dataclasses.replace(self, context=self.run_context.replace(**changes))

    @property
    def result_kind(self) -> str:
        """The kind of this result: its context's where set (:attr:`RunContext.kind`), else the class's."""
        return self.run_context.kind or self.kind

    def to_json(self) -> dict:
        """The JSON object of the result, as ``femupdate <command> --json`` writes it: ``kind``,
        ``schema_version``, then the keys of its kind (docs/file-formats.md).  NumPy values are
        converted, NaN and infinities become null."""
        from .io.results import to_jsonable

        return {"kind": self.result_kind, "schema_version": SCHEMA_VERSION, **to_jsonable(self.payload())}

    @classmethod
    def from_json(cls, obj: Mapping[str, Any] | str | Path):
        """The typed result of a JSON object (or of a JSON file's path) written by :meth:`to_json`.

        Raises
        ------
        InputError
            Not a JSON object, another kind of result, a newer schema, or keys that do not hold
            what the kind writes (named).
        """
        obj = _read(obj)
        kind = obj.get("kind")
        if kind is None:
            from .report.build import detect_kind

            kind = detect_kind(obj)
        accepted = cls.kinds or (cls.kind,)
        if kind not in accepted:
            raise InputError(f"a {kind!r} result, not {' or '.join(map(repr, accepted))}")
        return cls.from_payload(_checked(obj, kind))

    def write_json(self, path) -> Path | None:
        """Write :meth:`to_json` to ``path`` (``"-"``: standard output), atomically."""
        from .io.outputs import check_output
        from .io.results import write_json

        check_output(path, "write_json:")
        write_json(path, self.to_json())
        return None if str(path) == "-" else Path(path)

    def write_report(self, path, **kw) -> Path:
        """Write the HTML report of the result to ``path`` (:func:`femupdate.report.write_report`)."""
        from .io.outputs import check_output
        from .report import write_report

        check_output(path, "write_report:")
        return write_report(path, self, **kw)

    def to_frame(self):
        """The result's main table as a :class:`pandas.DataFrame` (:meth:`records`).

        Raises
        ------
        ImportError
            pandas is not installed.
        """
        import pandas as pd

        return pd.DataFrame.from_records(self.records())

    def records(self) -> list[dict]:
        """The result's main table as records (one dict per row): per parameter by default."""
        obj = self.to_json()
        params = obj.get("parameters")
        if not isinstance(params, Mapping):
            return []
        std = ((obj.get("diagnostics") or {}).get("std") or obj.get("standard_error") or obj.get("std") or {})
        units = obj.get("parameter_units") or {}
        start = obj.get("start") or {}
        return [{"parameter": n, "value": v, "std": std.get(n), "start": start.get(n), "unit": units.get(n)}
                for n, v in params.items()]


def _read(obj) -> dict:
    if isinstance(obj, (str, Path)):
        path = Path(obj)
        try:
            obj = json.loads(path.read_text(encoding="utf-8"))
        except FileNotFoundError:
            raise InputError(f"{path}: file not found") from None
        except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
            raise InputError(f"{path}: not a JSON result ({exc})") from None
    if not isinstance(obj, Mapping):
        raise InputError(f"a result must be a JSON object, got {type(obj).__name__}")
    return dict(obj)


def check_version(obj: Mapping) -> None:
    """Refuse a JSON result of a newer schema than :data:`SCHEMA_VERSION` (or whose
    ``schema_version`` is no integer); one without the key is taken as this schema's."""
    version = obj.get("schema_version", SCHEMA_VERSION)
    if not isinstance(version, int) or isinstance(version, bool):
        raise InputError(f"/schema_version: expected an integer, got {version!r}")
    if version > SCHEMA_VERSION:
        raise InputError(f"schema_version {version!r}: this femupdate reads results of schema {SCHEMA_VERSION} and "
                         "older; a newer femupdate wrote it")


def _checked(obj: dict, kind: str) -> dict:
    check_version(obj)
    from .report.build import REPORT_KINDS, check_result
    from .schema import check

    if kind in REPORT_KINDS:  # the keys a report reads (the other kinds use some of the names otherwise)
        check_result(obj)
    check(obj, kind)
    return obj


def load_result(path_or_obj):
    """The typed result of a JSON result file (or object) of any kind
    (:meth:`Serialisable.from_json` of the class its ``kind`` names).

    Raises
    ------
    InputError
        Not a result femupdate wrote, or a kind without a typed result.
    """
    result_arg(path_or_obj, "path_or_obj", "load_result", objects=False)
    obj = _read(path_or_obj if not isinstance(path_or_obj, os.PathLike) else Path(path_or_obj))
    kind = obj.get("kind")
    if kind is None:
        from .report.build import detect_kind

        kind = detect_kind(obj)
    _import_result_modules(kind)
    cls = REGISTRY.get(kind)
    if cls is None:
        raise InputError(f"results of kind {kind!r} have no typed form (known: {', '.join(sorted(REGISTRY))})")
    return cls.from_json(dict(obj, kind=kind))


def _import_result_modules(kind: str | None = None) -> None:
    """Import the modules that define result classes (they register themselves), in order, until
    ``kind`` is registered (all of them without ``kind``)."""
    import importlib

    for name in RESULT_MODULES:
        if kind is not None and kind in REGISTRY:
            return
        importlib.import_module(name)


#: the modules whose result classes :data:`REGISTRY` holds
RESULT_MODULES: tuple[str, ...] = ("femupdate.updating.results",)
RESULT_MODULES += ("femupdate.frf.simulate", "femupdate.frf.selection", "femupdate.frf.surfaces",
                   "femupdate.uniqueness.study.results")
RESULT_MODULES += ("femupdate.modal", "femupdate.correlation", "femupdate.direct", "femupdate.reduction.study",
                   "femupdate.fullfield.result")
RESULT_MODULES += ("femupdate.damage.detect", "femupdate.updating.multiconfig", "femupdate.bayes.results",
                   "femupdate.paper.result")


__all__ = ["SCHEMA_VERSION", "RunContext", "Serialisable", "load_result", "REGISTRY"]
