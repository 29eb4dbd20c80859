r"""Prior distributions of the model's parameters, for Bayesian updating (:mod:`femupdate.bayes`).

A parameter may carry a :class:`Prior` — declared in the model file (``prior`` in its
``[parameters.NAME]`` table), in Python (:meth:`femupdate.Structure.parameter`), or on the
command line (``femupdate posterior --prior NAME=SPEC``):

* ``uniform`` — constant density within the parameter's bounds (which must be finite);
* ``normal(MEAN, STD)`` — a Gaussian in the parameter's own units;
* ``lognormal(MEDIAN, STD_LOG)`` — ln p Gaussian with mean ln MEDIAN and standard deviation
  STD_LOG (about the coefficient of variation when it is small).

Every prior is **truncated to the parameter's bounds** (the bounds are the model's hard limits:
it is not evaluated outside them), and normalised over them, so that a log-evidence computed with
it is a proper one.  A parameter without a declared prior takes the uniform one within finite
bounds; with an infinite bound it has an improper flat prior, which a sampler that draws from the
prior (TMCMC) refuses.

This module is light (``math`` and NumPy; SciPy's special functions on first use) and sits in the
model layer: :class:`femupdate.model.Parameter` holds a :class:`Prior`.
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from ._errors import InputError
from ._limits import MAX_MAGNITUDE

#: the kinds of prior, as the model file and ``--prior`` name them
PRIOR_KINDS = ("uniform", "normal", "lognormal")
#: the numbers each kind takes, by name (the model file's inline-table keys), in the order of the text form
PRIOR_ARGUMENTS = {"uniform": (), "normal": ("mean", "std"), "lognormal": ("median", "std_log")}

#: log of the smallest prior probability within the bounds that can be drawn from in double precision
_LOG_TINY = math.log(1e-300)
_CALL = re.compile(r"^\s*([A-Za-z_]+)\s*(?:\((.*)\))?\s*$", re.S)


@dataclass(frozen=True)
class Prior:
    """The prior distribution of one parameter (truncated to its bounds).

    Parameters
    ----------
    kind : {"uniform", "normal", "lognormal"}
        The family (:data:`PRIOR_KINDS`).
    a : float, default NaN
        ``normal``: the mean; ``lognormal``: the median (> 0); unused for ``uniform``.
    b : float, default NaN
        ``normal``: the standard deviation; ``lognormal``: the standard deviation of ln p; both
        > 0; unused for ``uniform``.

    Raises
    ------
    InputError
        An unknown kind; a missing, non-finite or non-positive number where one is needed.
    """

    kind: str
    a: float = math.nan
    b: float = math.nan

    def __post_init__(self):
        if self.kind not in PRIOR_KINDS:
            raise InputError(f"unknown prior {self.kind!r}: use {', '.join(PRIOR_KINDS)}")
        names = PRIOR_ARGUMENTS[self.kind]
        if not names:
            object.__setattr__(self, "a", math.nan)
            object.__setattr__(self, "b", math.nan)
            return
        values = []
        for key, v in zip(names, (self.a, self.b)):
            if isinstance(v, (bool, np.bool_)):
                raise InputError(f"prior {self.kind}: {key} must be a number, got {'true' if v else 'false'}")
            try:
                v = float(v)
            except (TypeError, ValueError):
                raise InputError(f"prior {self.kind}: {key} must be a number, got {v!r}") from None
            if not math.isfinite(v) or abs(v) > MAX_MAGNITUDE:
                raise InputError(f"prior {self.kind}: {key} {v!r} is not a finite number of at most {MAX_MAGNITUDE:g}")
            values.append(v)
        if not values[1] > 0:
            raise InputError(f"prior {self.kind}: {names[1]} must be > 0, got {values[1]:g}")
        if self.kind == "lognormal" and not values[0] > 0:
            raise InputError(f"prior lognormal: median must be > 0, got {values[0]:g}")
        object.__setattr__(self, "a", values[0])
        object.__setattr__(self, "b", values[1])

    # ------------------------------------------------------------------ text and tables
    def __str__(self) -> str:
        if self.kind == "uniform":
            return "uniform"
        return f"{self.kind}({self.a:g}, {self.b:g})"

    def to_dict(self) -> dict:
        """The model file's inline table: ``{"type": kind, <argument>: value, ...}``."""
        return {"type": self.kind, **dict(zip(PRIOR_ARGUMENTS[self.kind], (self.a, self.b)))}

    # ------------------------------------------------------------------ support and normalisation
    def support(self, lo: float, hi: float) -> tuple[float, float]:
        """The interval the truncated prior lives on: the bounds (and p > 0 for ``lognormal``)."""
        if self.kind == "lognormal":
            return max(lo, 0.0), hi
        return lo, hi

    def _std_bounds(self, lo: float, hi: float) -> tuple[float, float]:
        """The bounds in the standardised variable z of the normal families."""
        lo, hi = self.support(lo, hi)
        if self.kind == "normal":
            return (lo - self.a) / self.b, (hi - self.a) / self.b
        lo_l = -math.inf if lo <= 0 else math.log(lo)
        return (lo_l - math.log(self.a)) / self.b, (math.log(hi) - math.log(self.a)) / self.b

    def log_mass(self, lo: float, hi: float) -> float:
        """log of the untruncated distribution's probability within the bounds (0 for uniform).

        Raises
        ------
        InputError
            ``uniform`` with an infinite bound; a prior with no mass (to double precision)
            within the bounds.
        """
        if self.kind == "uniform":
            if not (math.isfinite(lo) and math.isfinite(hi)):
                raise InputError("prior uniform needs finite bounds")
            return 0.0
        from scipy.special import log_ndtr

        za, zb = self._std_bounds(lo, hi)
        # log(Φ(zb) − Φ(za)) without cancellation: in the upper tail use the mirrored form
        if za > 0:
            za, zb = -zb, -za
        hi_l, lo_l = float(log_ndtr(zb)), float(log_ndtr(za))
        if not hi_l > lo_l or hi_l < _LOG_TINY:  # none, or too little to draw from in double precision
            raise InputError(f"prior {self}: no probability within the bounds [{lo:g}, {hi:g}]")
        return hi_l + math.log1p(-math.exp(lo_l - hi_l))

    def check(self, name: str, bounds: tuple[float, float]) -> None:
        """Refuse a prior that cannot be used with the parameter's ``bounds`` (:meth:`log_mass`),
        naming the parameter."""
        try:
            self.log_mass(*bounds)
        except InputError as exc:
            raise InputError(f"parameter {name!r}: {exc} (bounds [{bounds[0]:g}, {bounds[1]:g}])") from None

    # ------------------------------------------------------------------ density
    def logpdf(self, p, lo: float, hi: float) -> np.ndarray:
        """log density of the truncated prior at ``p`` (any shape; −inf outside the support).

        Parameters
        ----------
        p : array_like
            Parameter values (physical units).
        lo, hi : float
            The parameter's bounds.

        Returns
        -------
        numpy.ndarray
            The log density (normalised over the bounds), shape of ``p``.
        """
        p = np.asarray(p, float)
        a, b = self.support(lo, hi)
        inside = (p >= a) & (p <= b) & np.isfinite(p)
        out = np.full(p.shape, -np.inf)
        if self.kind == "uniform":
            out[inside] = -math.log(hi - lo)
            return out
        mass = self.log_mass(lo, hi)
        q = p[inside]
        if self.kind == "normal":
            z = (q - self.a) / self.b
            out[inside] = -0.5 * z * z - math.log(self.b) - 0.5 * math.log(2 * math.pi) - mass
        else:
            with np.errstate(divide="ignore"):
                lq = np.log(q)
            z = (lq - math.log(self.a)) / self.b
            out[inside] = -0.5 * z * z - lq - math.log(self.b) - 0.5 * math.log(2 * math.pi) - mass
        return out

    def derivatives(self, p) -> tuple[np.ndarray, np.ndarray]:
        """First and second derivatives of :meth:`logpdf` in p, inside the support.

        Returns
        -------
        d1, d2 : numpy.ndarray
            ∂ log π / ∂p and ∂² log π / ∂p² (zero for ``uniform``), shape of ``p``.
        """
        p = np.asarray(p, float)
        if self.kind == "uniform":
            return np.zeros(p.shape), np.zeros(p.shape)
        if self.kind == "normal":
            return -(p - self.a) / self.b ** 2, np.full(p.shape, -1.0 / self.b ** 2)
        # log π = −(ln p − μ)² / (2σ²) − ln p + const
        u = (np.log(p) - math.log(self.a)) / self.b ** 2
        return (-u - 1.0) / p, (u + 1.0 - 1.0 / self.b ** 2) / p ** 2

    def sample(self, rng: np.random.Generator, n: int, lo: float, hi: float) -> np.ndarray:
        """``n`` draws from the truncated prior (inverse cumulative distribution).

        Parameters
        ----------
        rng : numpy.random.Generator
        n : int
        lo, hi : float
            The parameter's bounds.

        Returns
        -------
        numpy.ndarray, shape ``(n,)``
        """
        self.log_mass(lo, hi)  # refuses what cannot be drawn from
        u = rng.random(n)
        if self.kind == "uniform":
            return lo + u * (hi - lo)
        from scipy.special import ndtr, ndtri

        za, zb = self._std_bounds(lo, hi)
        if za > 0:  # all in the upper tail: draw the mirrored variable, whose distribution keeps its digits there
            fa, fb = ndtr(-zb), ndtr(-za)
            z = -ndtri(fa + u * (fb - fa))
        else:
            fa, fb = ndtr(za), ndtr(zb)
            z = ndtri(fa + u * (fb - fa))
        z = np.clip(z, za, zb)
        x = self.a + self.b * z if self.kind == "normal" else self.a * np.exp(self.b * z)
        a, b = self.support(lo, hi)
        return np.clip(x, a, b)


def parse_prior(spec, where: str) -> Prior:
    """A :class:`Prior` from the model file's or the command line's form.

    Parameters
    ----------
    spec : str or mapping
        ``"uniform"``, ``"normal(MEAN, STD)"``, ``"lognormal(MEDIAN, STD_LOG)"``, or an inline
        table ``{type = "normal", mean = ..., std = ...}`` /
        ``{type = "lognormal", median = ..., std_log = ...}`` / ``{type = "uniform"}``.
    where : str
        How messages name the place it was given (``"model.toml: [parameters.k1] prior"``).

    Returns
    -------
    Prior

    Raises
    ------
    InputError
        Anything else, naming ``where`` and what was given.
    """
    if isinstance(spec, Prior):
        return spec
    forms = "uniform, normal(MEAN, STD) or lognormal(MEDIAN, STD_LOG)"
    if isinstance(spec, Mapping):
        kind = spec.get("type")
        if not isinstance(kind, str):
            raise InputError(f"{where}: an inline table needs type = \"uniform\", \"normal\" or \"lognormal\"")
        kind = kind.strip().lower()
        if kind not in PRIOR_KINDS:
            raise InputError(f"{where}: unknown prior {kind!r}: use {', '.join(PRIOR_KINDS)}")
        names = PRIOR_ARGUMENTS[kind]
        unknown = sorted(set(spec) - {"type", *names})
        if unknown:
            raise InputError(f"{where}: unknown key(s) {', '.join(unknown)} for a {kind} prior (allowed: type"
                             f"{''.join(', ' + n for n in names)})")
        missing = [n for n in names if n not in spec]
        if missing:
            raise InputError(f"{where}: a {kind} prior needs {', '.join(names)} (missing: {', '.join(missing)})")
        args = [spec[n] for n in names]
    elif isinstance(spec, str):
        m = _CALL.match(spec)
        if not m:
            raise InputError(f"{where}: {spec!r} is not a prior; write {forms}")
        kind = m.group(1).lower()
        if kind not in PRIOR_KINDS:
            raise InputError(f"{where}: unknown prior {m.group(1)!r}: write {forms}")
        names = PRIOR_ARGUMENTS[kind]
        text = (m.group(2) or "").strip()
        items = [t.strip() for t in text.split(",")] if text else []
        if len(items) != len(names):
            raise InputError(f"{where}: {kind} takes {len(names)} number(s) ({', '.join(names) or 'none'}), "
                             f"got {spec!r}; write {forms}")
        args = []
        for n, t in zip(names, items):
            try:
                args.append(float(t))
            except ValueError:
                raise InputError(f"{where}: {n} of {spec!r} is not a number: {t!r}") from None
    else:
        raise InputError(f"{where}: a prior is a string ({forms}) or an inline table, got {spec!r}")
    try:
        return Prior(kind, *args)
    except InputError as exc:
        raise InputError(f"{where}: {exc}") from None


__all__ = ["Prior", "parse_prior", "PRIOR_KINDS", "PRIOR_ARGUMENTS"]
