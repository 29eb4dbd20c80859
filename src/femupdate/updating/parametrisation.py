"""The optimiser's variables x and the model's parameters p: the parametrisation shared by every
updating problem (modal, FRF, static, mixed, multi-configuration) and by the compiled route."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from .._docs import X as X_DOC, shared_docs
from .. import rules
from .._errors import InputError

PARAMETRISATIONS = tuple(rules.PARAMETRISATIONS)  #: ``("relative", "log", "absolute")``


class Parametrisation:
    """The optimiser's variables x and the full parameter vector p.

    Parameters
    ----------
    model : Model
        The model whose parameters are updated (names are looked up in it).
    names : sequence of str
        The updated parameters, in the order of x (L of them).
    kind : {"relative", "log", "absolute"}
        ``"relative"`` (x = p / ``|p_start|``, the default of every driver), ``"log"`` (x = ln p)
        or ``"absolute"`` (x = p).
    p_base : array_like, shape ``(n_parameters,)``
        Full parameter vector: the starting values of ``names`` and the values of every other
        parameter, which stay fixed.

    Attributes
    ----------
    names : tuple of str
        The updated parameters.
    idx : numpy.ndarray of intp, shape ``(L,)``
        Their positions in the model's parameter vector.
    param : str
        The parametrisation ``kind``.
    p_base : numpy.ndarray, shape ``(n_parameters,)``
        The full parameter vector at the start (float copy).
    scale : numpy.ndarray, shape ``(L,)``
        ``|p_start|`` of each updated parameter (1 where the start is 0): the divisor of the
        ``"relative"`` parametrisation.

    Raises
    ------
    InputError
        An unknown ``kind``, or a name that is not a parameter of ``model``.
    """

    def __init__(self, model, names: Sequence[str], kind: str, p_base: np.ndarray):
        if kind not in rules.PARAMETRISATIONS:
            raise InputError(f"unknown parametrisation {kind!r}: use {', '.join(PARAMETRISATIONS)}")
        self.idx = np.array(model.parameter_indices(names, "updated parameters (--params)"), dtype=np.intp)
        self.names = tuple(names)
        self.param = kind
        self.code = rules.PARAMETRISATIONS[kind]
        self.p_base = np.asarray(p_base, float)
        start = self.p_base[self.idx]
        self.scale = np.where(start != 0, np.abs(start), 1.0)

    @shared_docs(X=X_DOC)
    def to_p(self, x: np.ndarray) -> np.ndarray:
        """Full parameter vector at the variables x.

        {{X}}
        numpy.ndarray, shape ``(n_parameters,)``
            ``p_base`` with the updated parameters' values at x (physical units); a new array.
        """
        p = self.p_base.copy()
        p[self.idx] = rules.to_p(self.code, np.asarray(x, float), self.scale)
        return p

    @shared_docs(X=X_DOC)
    def dp_dx(self, x: np.ndarray) -> np.ndarray:
        """∂p/∂x of the updated parameters, the diagonal of the parametrisation's Jacobian.

        {{X}}
        numpy.ndarray, shape ``(L,)``
            ``scale`` (relative), exp(x) = p (log) or 1 (absolute).
        """
        return rules.dp_dx(self.code, np.asarray(x, float), self.scale)

    def from_p(self, p_sel) -> np.ndarray:
        """The variables x of the updated parameters' values ``p_sel``.

        Parameters
        ----------
        p_sel : array_like, shape ``(L,)``
            Values of the updated parameters (physical units), in the order of ``names``.

        Returns
        -------
        numpy.ndarray, shape ``(L,)``

        Raises
        ------
        InputError
            A value that is not positive under the ``"log"`` parametrisation.
        """
        p_sel = np.asarray(p_sel, float)
        if self.param == "log" and np.any(p_sel <= 0):
            raise InputError("log parametrisation needs positive parameter values and bounds")
        return x_of_p(self.param, p_sel, self.scale)

    @property
    def start(self) -> np.ndarray:
        """Starting values of the updated parameters (L,)."""
        return self.p_base[self.idx].copy()

    @property
    def x_start(self) -> np.ndarray:
        """The variables x (L,) at the start."""
        return self.from_p(self.start)

    def bounds_x(self, lo: np.ndarray, hi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Bounds of x from the updated parameters' bounds (:func:`x_bounds`).

        Parameters
        ----------
        lo, hi : array_like, shape ``(L,)``
            Lower and upper bounds of the updated parameters (physical units; may be infinite).

        Returns
        -------
        xl, xh : numpy.ndarray, shape ``(L,)``
            Lower and upper bounds of x.
        """
        return x_bounds(self.param, lo, hi, self.scale)


def x_of_p(kind: str, p, scale) -> np.ndarray:
    """The optimiser's variables of the values ``p`` of the updated parameters, for any shape
    that broadcasts with ``scale`` (``|start|`` of each parameter; one row per start if 2-D).

    Parameters
    ----------
    kind : {"relative", "log", "absolute"}
        The parametrisation.
    p : array_like, shape ``(L,)`` or ``(n_starts, L)``
        Parameter values (physical units).
    scale : array_like, shape ``(L,)``
        ``|p_start|`` of each parameter (used by ``"relative"`` only).

    Returns
    -------
    numpy.ndarray, shape of ``p``
        p / scale (relative), ln p (log; −inf or NaN for p <= 0, without a warning) or a copy
        of p (absolute).
    """
    if kind == "relative":
        return np.asarray(p, float) / scale
    if kind == "log":
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.log(np.asarray(p, float))
    return np.array(p, float)


def x_bounds(kind: str, lo, hi, scale) -> tuple[np.ndarray, np.ndarray]:
    """Bounds of the optimiser's variables from the parameters' bounds ``lo``, ``hi``.

    Parameters
    ----------
    kind : {"relative", "log", "absolute"}
        The parametrisation.
    lo, hi : array_like, shape ``(L,)``
        Lower and upper bounds of the parameters (physical units; may be infinite).
    scale : array_like, shape ``(L,)``
        ``|p_start|`` of each parameter (used by ``"relative"`` only).

    Returns
    -------
    xl, xh : numpy.ndarray, shape ``(L,)``
        Lower and upper bounds of the variables: ln(max(lo, 0)) and ln(hi) for ``"log"`` (−inf
        for a lower bound of 0); otherwise the mapped bounds, ordered element-wise (a negative
        start flips the relative ones).
    """
    if kind == "log":
        with np.errstate(divide="ignore"):
            return np.log(np.maximum(lo, 0)), np.log(hi)
    xl, xh = x_of_p(kind, lo, scale), x_of_p(kind, hi, scale)
    return np.minimum(xl, xh), np.maximum(xl, xh)  # a negative start flips the relative ones


def start_error(names: Sequence[str], start, lo, hi, kind: str) -> str | None:
    """Why the start ``start`` of ``names`` cannot be solved from (None when it can).

    Parameters
    ----------
    names : sequence of str
        The updated parameters.
    start : array_like, shape ``(L,)``
        Their starting values (physical units).
    lo, hi : array_like, shape ``(L,)``
        Their bounds.
    kind : {"relative", "log", "absolute"}
        The parametrisation.

    Returns
    -------
    str or None
        The reason — starting values outside the bounds (named), or, for ``"log"``, a
        starting value <= 0 or a negative lower bound — or None.
    """
    outside = [n for n, v, a, b in zip(names, start, lo, hi) if not a <= v <= b]
    if outside:
        return f"starting value(s) outside the bounds for: {', '.join(outside)}"
    if kind == "log" and (np.any(np.asarray(start) <= 0) or np.any(np.asarray(lo) < 0)):
        return "log parametrisation needs positive starting values and non-negative lower bounds"
    return None


def updated_names(model, params: Sequence[str] | None) -> list[str]:
    """The parameters to update: ``params``, or every parameter not ``fixed``.

    Raises
    ------
    InputError
        Nothing to update (every parameter fixed, or an empty ``params``).
    """
    names = list(params) if params is not None else [model.parameter_names[j] for j in model.free]
    if not names:
        raise InputError("no parameters to update: every parameter is fixed")
    return names


def start_vector(model, values, x0) -> np.ndarray:
    """The full parameter vector at the start: ``values`` (default nominal) with the updated
    parameters' starting values ``x0`` {name: value} put in."""
    p = model.resolve(values)
    for name, v in dict(x0 or {}).items():
        p[model.parameter_index(name)] = float(v)
    return p


__all__ = ["Parametrisation", "x_of_p", "x_bounds", "start_error", "PARAMETRISATIONS", "updated_names", "start_vector"]
