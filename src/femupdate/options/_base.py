"""The base of the option objects: :class:`Options`, the checks of their fields, and
:func:`gather`, which routes a call's shorthand keywords to its option objects."""

from __future__ import annotations

import dataclasses
import math
import numbers
from collections.abc import Mapping
from typing import Any, ClassVar, TypeVar

from .._errors import InputError

O = TypeVar("O", bound="Options")


# ---------------------------------------------------------------------------------- checks
def choice(value, allowed: tuple[str, ...], what: str) -> str:
    """``value`` if it is one of ``allowed``; else an :class:`InputError` ``unknown WHAT 'value': use ...``."""
    if not isinstance(value, str) or value not in allowed:
        raise InputError(f"unknown {what} {value!r}: use {', '.join(allowed)}")
    return value


def number(value, what: str, *, low: float | None = None, high: float | None = None, low_open: bool = False,
           high_open: bool = False) -> float:
    """``value`` as a finite float within the stated range; else an :class:`InputError` naming ``what``."""
    ok = isinstance(value, numbers.Real) and not isinstance(value, bool) and math.isfinite(float(value))
    if ok:
        v = float(value)
        ok = ((low is None or (v > low if low_open else v >= low)) and
              (high is None or (v < high if high_open else v <= high)))
    if not ok:
        lo = "" if low is None else f"{'>' if low_open else '>='} {low:g}"
        hi = "" if high is None else f"{'<' if high_open else '<='} {high:g}"
        rng = " and ".join(s for s in (lo, hi) if s)
        raise InputError(f"{what} must be a finite number{' ' + rng if rng else ''}, got {value!r}")
    return float(value)


def count(value, what: str, *, low: int = 1, high: int | None = None, allow_none: bool = False) -> int | None:
    """``value`` as an int within ``[low, high]`` (None allowed with ``allow_none``); else an
    :class:`InputError` naming ``what``."""
    if value is None and allow_none:
        return None
    ok = isinstance(value, numbers.Integral) and not isinstance(value, bool)
    if not ok or value < low or (high is not None and value > high):
        rng = f">= {low}" + (f" and <= {high}" if high is not None else "")
        raise InputError(f"{what} must be an integer {rng}{' (or None)' if allow_none else ''}, got {value!r}")
    return int(value)


def flag(value, what: str) -> bool:
    """``value`` if it is a bool (NumPy's included); else an :class:`InputError` naming ``what``."""
    if not isinstance(value, bool) and type(value).__name__ != "bool_":
        raise InputError(f"{what} must be True or False, got {value!r}")
    return bool(value)


# ---------------------------------------------------------------------------------- base
@dataclasses.dataclass(frozen=True)
class Options:
    """Base of the option objects: frozen, checked when made, with a changed copy by
    :meth:`replace`, a JSON form by :meth:`to_dict` and :meth:`from_dict`, and a short ``repr``
    that shows the fields that differ from their defaults."""

    #: shorthand keyword -> field (for the keywords functions have always taken)
    aliases: ClassVar[dict[str, str]] = {}
    #: the field a plain (non-mapping) value stands for, if any (``pairing="mac"``)
    main: ClassVar[str | None] = None

    def __new__(cls, *args, **kwargs):
        # a keyword that is no field, named with the closest field (the dataclass's own message names neither)
        names = cls.field_names()
        for key in kwargs:
            if key not in names:
                import difflib

                if key in cls.aliases:
                    hint = f"; it is the functions' shorthand of the field {cls.aliases[key]!r}"
                else:
                    close = difflib.get_close_matches(key, names, n=1)
                    hint = f"; did you mean {close[0]!r}?" if close else ""
                raise TypeError(f"{cls.__name__}() got an unexpected keyword argument {key!r}{hint} (its options: "
                                f"{', '.join(names)})")
        return super().__new__(cls)

    def __post_init__(self) -> None:
        self.check()

    def check(self) -> None:
        """Check the fields (subclasses); raise :class:`InputError` naming the bad one."""

    def set(self, name: str, value) -> None:
        """Store a checked (normalised) value of field ``name`` in :meth:`check`."""
        object.__setattr__(self, name, value)

    def replace(self: O, **changes) -> O:
        """A copy with ``changes`` (fields or aliases), checked like a new object."""
        return dataclasses.replace(self, **self.fields_of(changes, type(self).__name__ + ".replace"))

    @classmethod
    def field_names(cls) -> tuple[str, ...]:
        return tuple(f.name for f in dataclasses.fields(cls))

    @classmethod
    def fields_of(cls, given: Mapping[str, Any], where: str) -> dict[str, Any]:
        """``given`` with aliases resolved to field names; an unknown key raises :class:`TypeError`."""
        names = set(cls.field_names())
        out: dict[str, Any] = {}
        for key, value in given.items():
            name = cls.aliases.get(key, key)
            if name not in names:
                raise TypeError(f"{where}: {cls.__name__} has no option {key!r} (its options: "
                                f"{', '.join(cls.field_names())})")
            if name in out:
                raise TypeError(f"{where}: option {name!r} given twice (as {name!r} and an alias)")
            out[name] = value
        return out

    @classmethod
    def coerce(cls: type[O], value, where: str) -> O:
        """``value`` as an object of this class: the object itself, None (the defaults), a mapping
        of fields, or a plain value of the :attr:`main` field."""
        if isinstance(value, cls):
            return value
        if value is None:
            return cls()
        if isinstance(value, Options):
            raise TypeError(f"{where}: expected {cls.__name__}, got {type(value).__name__}")
        if isinstance(value, Mapping):
            return cls(**cls.fields_of(value, where))
        if cls.main is not None:
            return cls(**{cls.main: value})
        raise TypeError(f"{where}: expected {cls.__name__} (or a mapping of its fields), got {value!r}")

    def to_dict(self) -> dict[str, Any]:
        """The fields as JSON values (nested options as objects, tuples as lists)."""
        from ..io.results import to_jsonable

        return {f.name: (v.to_dict() if isinstance(v := getattr(self, f.name), Options) else to_jsonable(v))
                for f in dataclasses.fields(self)}

    @classmethod
    def from_dict(cls: type[O], data: Mapping[str, Any]) -> O:
        """The object of :meth:`to_dict`'s output (unknown keys refused by name)."""
        if not isinstance(data, Mapping):
            from .._checks import shown

            raise TypeError(f"{cls.__name__}.from_dict: expected a mapping of {cls.__name__}' fields, got {shown(data)}")
        return cls.coerce(dict(data), f"{cls.__name__}.from_dict")

    def changed(self) -> dict[str, Any]:
        """The fields whose values differ from the defaults."""
        out = {}
        for f in dataclasses.fields(self):
            default = f.default if f.default is not dataclasses.MISSING else (
                f.default_factory() if f.default_factory is not dataclasses.MISSING else dataclasses.MISSING)
            v = getattr(self, f.name)
            try:
                same = bool(v == default)
            except (TypeError, ValueError):  # arrays
                same = False
            if not same:
                out[f.name] = v
        return out

    def __repr__(self) -> str:
        return f"{type(self).__name__}({', '.join(f'{k}={v!r}' for k, v in self.changed().items())})"


def gather(where: str, shorthand: Mapping[str, Any], **slots: tuple[type[Options], Any]) -> dict[str, Any]:
    """The option objects of a call: each slot's given value coerced to its class, then changed by
    the shorthand keywords that belong to it.

    Parameters
    ----------
    where : str
        The function's name, for messages.
    shorthand : mapping
        The call's extra keywords; each goes to the first slot whose class has that field or alias.
    **slots : (class, given)
        ``name=(OptionsClass, value given or None)``, in the order keywords are matched.

    Returns
    -------
    dict
        ``{name: options object}``.

    Raises
    ------
    TypeError
        A keyword no slot has, or a slot given a value of the wrong type.
    InputError
        A field's value is out of range (named).
    """
    objs, rest = gather_some(where, shorthand, **slots)
    if rest:
        key = next(iter(rest))
        known = ", ".join(f"{cls.__name__} ({name}=)" for name, (cls, _) in slots.items())
        import difflib

        fields = [f for cls, _ in slots.values() for f in (*cls.field_names(), *cls.aliases)]
        close = difflib.get_close_matches(key, fields, n=1)
        hint = f"; did you mean {close[0]!r}?" if close else ""
        raise TypeError(f"{where}() got an unexpected keyword argument {key!r}{hint} (its options: {known})")
    return objs


def gather_some(where: str, shorthand: Mapping[str, Any], **slots: tuple[type[Options], Any]
                ) -> tuple[dict[str, Any], dict[str, Any]]:
    """:func:`gather` for the slots given, and the keywords none of them has (for a function that
    passes them on: ``multistart`` passes the update's options to :func:`femupdate.update`).

    Returns
    -------
    (dict, dict)
        ``{name: options object}`` and the keywords left over, in their order.
    """
    objs = {name: cls.coerce(given, f"{where}({name}=...)") for name, (cls, given) in slots.items()}
    routed: dict[str, dict[str, Any]] = {name: {} for name in slots}
    rest: dict[str, Any] = {}
    for key, value in shorthand.items():
        for name, (cls, _) in slots.items():
            if key in cls.aliases or key in cls.field_names():
                routed[name][key] = value
                break
        else:
            rest[key] = value
    return {name: (objs[name].replace(**routed[name]) if routed[name] else objs[name]) for name in slots}, rest


__all__ = ["Options", "gather", "gather_some", "choice", "number", "count", "flag"]
