r"""Parameters that enter through known functions: the terms of a non-linear :class:`~femupdate.Model`.

.. math::  K(p) = K_0 + \sum_j p_j K_j + \sum_k f_k(p) K_k, \qquad
           f_k(p) = \prod_{i} g_{k,i}(p_{j(k,i)})

Each coefficient :math:`f_k` is a product of single-parameter functions, declared as objects
(never as expression strings): :class:`Power` (:math:`p^a`), :class:`Exp`
(:math:`e^{a p}`) and :class:`Polynomial` (:math:`c_0 + c_1 p + c_2 p^2 + \dots`).  The
derivative is exact by the chain rule,

.. math::  \frac{\partial K}{\partial p_j} = K_j + \sum_k \frac{\partial f_k}{\partial p_j} K_k,
           \qquad \frac{\partial f_k}{\partial p_j} = g'_{k,j}(p_j) \prod_{i \ne j} g_{k,i}.

A plate's bending stiffness :math:`E t^3 K_b` is ``Term(K=Kb, factors=(Power("E", 1), Power("t", 3)))``.
In the model file a factor is a pair ``["t", 3]`` (a power), ``["t", {exp = a}]`` or
``["t", {poly = [c0, c1, ...]}]``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace

import numpy as np

from ._checks import shown
from ._errors import InputError


def _number(v, what: str) -> float:
    if isinstance(v, (bool, np.bool_)) or not isinstance(v, (int, float, np.integer, np.floating)):
        raise InputError(f"{what} must be a number, got {v!r}")
    v = float(v)
    if not math.isfinite(v):
        raise InputError(f"{what} must be finite, got {v!r}")
    return v


def _name(v, what: str) -> str:
    if not isinstance(v, str) or not v:
        raise InputError(f"{what}: the parameter must be named by a string, got {v!r}")
    return v


@dataclass(frozen=True)
class Power:
    """``p ** exponent`` of one parameter (an integer exponent for any p; otherwise p > 0)."""

    parameter: str
    exponent: float = 1.0

    def __post_init__(self):
        object.__setattr__(self, "parameter", _name(self.parameter, "Power"))
        object.__setattr__(self, "exponent", _number(self.exponent, f"Power({self.parameter!r}) exponent"))
        if self.exponent == 0:
            raise InputError(f"Power({self.parameter!r}, 0) is the constant 1: leave the factor out")

    def _check(self, x: float) -> None:
        a = self.exponent
        if (a != round(a) and x <= 0) or (a < 0 and x == 0):
            raise InputError(f"parameter {self.parameter!r} = {x:g}: {self.describe()} is not defined there "
                             "(a fractional power needs a positive value, a negative power a non-zero one)")

    def value(self, x: float) -> float:
        self._check(x)
        return float(x ** self.exponent)

    def derivative(self, x: float) -> float:
        self._check(x)
        a = self.exponent
        return float(a * x ** (a - 1)) if a != 1 else 1.0

    def describe(self) -> str:
        a = self.exponent
        return self.parameter if a == 1 else f"{self.parameter}^{a:g}"


@dataclass(frozen=True)
class Exp:
    """``exp(rate * p)`` of one parameter (``rate = ln 10`` makes p a base-10 exponent)."""

    parameter: str
    rate: float = 1.0

    def __post_init__(self):
        object.__setattr__(self, "parameter", _name(self.parameter, "Exp"))
        object.__setattr__(self, "rate", _number(self.rate, f"Exp({self.parameter!r}) rate"))
        if self.rate == 0:
            raise InputError(f"Exp({self.parameter!r}, rate=0) is the constant 1: leave the factor out")

    def value(self, x: float) -> float:
        return math.exp(self.rate * x)

    def derivative(self, x: float) -> float:
        return self.rate * math.exp(self.rate * x)

    def describe(self) -> str:
        return f"exp({self.rate:g}*{self.parameter})"


@dataclass(frozen=True)
class Polynomial:
    """``c0 + c1 p + c2 p² + …`` of one parameter (``coefficients`` in rising powers)."""

    parameter: str
    coefficients: tuple[float, ...] = (0.0, 1.0)

    def __post_init__(self):
        object.__setattr__(self, "parameter", _name(self.parameter, "Polynomial"))
        c = self.coefficients
        if isinstance(c, (str, bytes, Mapping)) or not isinstance(c, (Sequence, np.ndarray)) or len(c) < 2:
            raise InputError(f"Polynomial({self.parameter!r}): coefficients must be a list [c0, c1, ...] of at "
                             f"least two numbers, got {c!r}")
        c = tuple(_number(v, f"Polynomial({self.parameter!r}) coefficient") for v in c)
        if not any(c[1:]):
            raise InputError(f"Polynomial({self.parameter!r}): every coefficient but c0 is zero; the factor is a "
                             "constant")
        object.__setattr__(self, "coefficients", c)

    def value(self, x: float) -> float:
        return float(np.polynomial.polynomial.polyval(x, self.coefficients))

    def derivative(self, x: float) -> float:
        return float(np.polynomial.polynomial.polyval(x, np.polynomial.polynomial.polyder(self.coefficients)))

    def describe(self) -> str:
        return f"poly{list(self.coefficients)}({self.parameter})"


FACTORS = (Power, Exp, Polynomial)


def factor_from_table(item, where: str):
    """A factor from the model file's pair ``[name, 3]``, ``[name, {exp = a}]`` or ``[name, {poly = [...]}]``."""
    if isinstance(item, FACTORS):
        return item
    if not isinstance(item, (list, tuple)) or len(item) != 2 or not isinstance(item[0], str):
        raise InputError(f"{where}: a factor is a pair [parameter, power] (or [parameter, {{exp = a}}], "
                         f"[parameter, {{poly = [c0, c1, ...]}}]), got {item!r}")
    name, how = item
    if isinstance(how, Mapping):
        keys = set(how)
        if keys == {"exp"}:
            return Exp(name, how["exp"])
        if keys == {"poly"}:
            return Polynomial(name, how["poly"])
        raise InputError(f"{where}: factor {item!r}: the table takes one key, exp or poly; got {sorted(keys)}")
    try:
        return Power(name, how)
    except InputError as exc:
        raise InputError(f"{where}: {exc}") from None


@dataclass(frozen=True, eq=False)
class Term:
    """One non-linear term: ``f(p) * K`` and ``f(p) * M`` with ``f`` the product of ``factors``.

    Parameters
    ----------
    factors : sequence of Power, Exp or Polynomial (or pairs ``(name, exponent)``)
        One factor per parameter (a parameter named twice is refused).
    K, M : array_like or sparse matrix, optional
        The matrices the coefficient multiplies (at least one); checked by :class:`~femupdate.Model`.
    """

    factors: tuple
    K: object = None
    M: object = None

    def __post_init__(self):
        fs = self.factors
        if isinstance(fs, (str, bytes, Mapping)) or not isinstance(fs, (Sequence, np.ndarray)) or not len(fs):
            raise InputError(f"Term: factors must be a non-empty list of Power/Exp/Polynomial, got {fs!r}")
        fs = tuple(factor_from_table(f, "Term") for f in fs)
        names = [f.parameter for f in fs]
        twice = sorted({n for n in names if names.count(n) > 1})
        if twice:
            raise InputError(f"Term {self.describe_of(fs)}: parameter(s) {', '.join(twice)} named in two factors; "
                             "give one factor per parameter (a power, exponential or polynomial)")
        object.__setattr__(self, "factors", fs)
        if self.K is None and self.M is None:
            raise InputError(f"Term {self.describe()}: give K, M or both")

    @staticmethod
    def describe_of(fs) -> str:
        return "*".join(f.describe() if isinstance(f, FACTORS) else repr(f) for f in fs)

    def describe(self) -> str:
        """The coefficient as text, e.g. ``E*t^3``."""
        return self.describe_of(self.factors)

    @property
    def parameters(self) -> tuple[str, ...]:
        return tuple(f.parameter for f in self.factors)

    @property
    def affine(self) -> bool:
        """Whether the coefficient is a single parameter to the first power (f = p)."""
        f = self.factors
        return len(f) == 1 and isinstance(f[0], Power) and f[0].exponent == 1

    def value(self, p: Mapping[str, float]) -> float:
        """f(p)."""
        return math.prod(f.value(p[f.parameter]) for f in self.factors)

    def gradient(self, p: Mapping[str, float]) -> dict[str, float]:
        """``{name: ∂f/∂p_name}`` by the product rule (exact)."""
        vals = [f.value(p[f.parameter]) for f in self.factors]
        out = {}
        for i, f in enumerate(self.factors):
            out[f.parameter] = f.derivative(p[f.parameter]) * math.prod(v for k, v in enumerate(vals) if k != i)
        return out


def check_terms(terms, names, n: int) -> tuple:
    """The model's non-linear terms, each factor naming a declared parameter, matrices checked."""
    from .model import _as_csr

    if isinstance(terms, (str, bytes, Mapping)) or not isinstance(terms, (Sequence, np.ndarray)):
        raise InputError(f"terms must be a list of Term objects, got {shown(terms)}")
    out = []
    for t in terms:
        if not isinstance(t, Term):
            raise InputError(f"terms must be Term objects (femupdate.coefficients.Term), got {shown(t)}")
        missing = [x for x in t.parameters if x not in names]
        if missing:
            raise InputError(f"term {t.describe()} names parameter(s) {', '.join(missing)}, not declared "
                             f"(declared: {', '.join(names) or 'none'})")
        K = _as_csr(t.K, f"the K matrix of term {t.describe()}", n)
        M = _as_csr(t.M, f"the M matrix of term {t.describe()}", n)
        out.append(replace(t, K=K, M=M) if (K is not t.K or M is not t.M) else t)
    return tuple(out)


def term_derivative(model, key: str, j: int, values, affine_part):
    """∂K/∂p_j (``key`` "K") or ∂M/∂p_j at ``values``: the affine part plus Σ_k (∂f_k/∂p_j) K_k."""
    import scipy.sparse as sp

    p = model.resolve(values)
    named = dict(zip(model.parameter_names, p.tolist()))
    name = model.parameter_names[j]
    out = affine_part
    for t in model.terms:
        A = getattr(t, key)
        if A is not None and name in t.parameters:
            out = out + t.gradient(named)[name] * A
    return sp.csr_array(out)


def linearise(model, values=None):
    """:meth:`Model.linearised <femupdate.Model.linearised>` of a non-linear model (a few points cached)."""
    import scipy.sparse as sp

    from .model import Model

    p = model.resolve(values)
    cache = model._linearised
    key = p.tobytes()
    if key in cache:
        return cache[key]
    dK = tuple(model.dK_dp(j, p) for j in range(p.size))
    dM = tuple(model.dM_dp(j, p) for j in range(p.size))
    K0 = sp.csr_array(model.K(p) - sum((v * A for v, A in zip(p, dK)), sp.csr_array(model.K0.shape)))
    M0 = sp.csr_array(model.M(p) - sum((v * A for v, A in zip(p, dM)), sp.csr_array(model.M0.shape)))
    out = object.__new__(Model)  # validated already: the same dofs, parameters and sizes
    for f, v in (("dofs", model.dofs), ("K0", K0), ("M0", M0), ("parameters", model.parameters),
                 ("dK", tuple(A if A.nnz else None for A in dK)), ("dM", tuple(A if A.nnz else None for A in dM)),
                 ("name", model.name), ("nodes", model.nodes), ("positive", model.positive), ("terms", ())):
        object.__setattr__(out, f, v)
    if len(cache) >= 4:
        cache.pop(next(iter(cache)))
    cache[key] = out
    return out


def route_refusal(model, route: str) -> None:
    """Refuse a non-linear model on a route that assumes K(p) affine in p (one clear message)."""
    terms = getattr(model, "terms", ())
    if not terms:
        return
    t = terms[0]
    raise InputError(
        f"{route} assumes the parameters enter linearly (K = K0 + sum p_j K_j), but in model {model.name!r} "
        f"parameter {t.parameters[0]!r} enters through {t.describe()}; the local modal update, the "
        "sensitivities and the posterior take non-linear parameters")


__all__ = ["Power", "Exp", "Polynomial", "Term", "factor_from_table", "route_refusal", "check_terms", "linearise",
           "term_derivative"]
