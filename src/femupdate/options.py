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

import dataclasses
import math
import numbers
from collections.abc import Mapping
from typing import Any, ClassVar, TypeVar

from ._errors import InputError

# ---------------------------------------------------------------------------------- choices
#: how test modes are paired with model modes (:class:`PairingOptions`)
PAIRING_RULES = ("auto", "mac", "order", "frequency")
#: the residuals of measured modes, the default first (:class:`ModalOptions`)
FORMULATIONS = ("shapes", "mac", "dynamic")
#: how compared shapes are scaled (:class:`ModalOptions`)
SHAPE_SCALINGS = ("unit", "ref", "max")
#: routes of the eigenvector derivatives (:func:`femupdate.sensitivity.jacobian`)
SENSITIVITY_ROUTES = ("auto", "nelson", "modal", "static", "subspace", "adjoint", "fd")
#: the variables the solver works in (:class:`SolverOptions`)
PARAMETRISATIONS = ("relative", "log", "absolute")
#: SciPy's least-squares methods (:class:`SolverOptions`)
LSQ_METHODS = ("trf", "dogbox", "lm")
#: the rules that choose a Tikhonov factor (:class:`SolverOptions`)
REGULARIZATION_RULES = ("gcv", "lcurve")
#: FRF residual forms (:class:`FRFOptions`); ``"auto"``: a log-magnitude stage, then linear
FRF_RESIDUALS = ("linear", "relative", "log", "auto")
#: what to do with FRF lines near a resonance (:class:`FRFOptions`)
RESONANCE_POLICIES = ("skip", "error", "keep")
#: solvers of the FRF line systems (:class:`FRFOptions`)
FRF_SOLVERS = ("auto", "dense", "sparse")
#: the kinds of test data, in the order their residual blocks are stacked
DATA_KINDS = ("modes", "frf", "static")
#: the keys of :attr:`NoiseOptions.std`, and the kind of data each belongs to
STD_KEYS = {"eigenvalue": "modes", "shape": "modes", "frf": "frf", "static": "static"}
#: what standard deviations rest on (:class:`NoiseOptions`)
NOISE_BASES = ("auto", "stated", "estimate")

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
        from .io.results import to_jsonable

        return {f.name: (v.to_dict() if isinstance(v := getattr(self, f.name), Options) else to_jsonable(v))
                for f in dataclasses.fields(self)}

    @classmethod
    def from_dict(cls: type[O], data: Mapping[str, Any]) -> O:
        """The object of :meth:`to_dict`'s output (unknown keys refused by name)."""
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
        raise TypeError(f"{where}() got an unexpected keyword argument {key!r} (its options: {known})")
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


# ---------------------------------------------------------------------------------- updating
@dataclasses.dataclass(frozen=True, repr=False)
class PairingOptions(Options):
    """How test modes are paired with model modes (:func:`femupdate.rules.pair_modes`).

    Attributes
    ----------
    rule : {"auto", "mac", "order", "frequency"}, default ``"auto"``
        ``"auto"``: by frequency order until the shapes clearly show a swap, then by MAC (a start
        is never abandoned); ``"mac"``: an optimal assignment by MAC, a test mode below
        ``min_mac`` fails; ``"order"``: by frequency order; ``"frequency"``: the nearest frequency,
        the MAC deciding within 10 %.  Shorthand keyword ``pairing``.
    min_mac : float in [0, 1], default 0.5
        The MAC a pair of shaped modes must reach (``"mac"``), or that confirms a pair (the other
        rules list the pairs below it as unconfirmed).
    n_modes : int, optional
        Model modes computed and paired among (default ``max(2T, T + 6)`` for T test modes).
    """

    rule: str = "auto"
    min_mac: float = 0.5
    n_modes: int | None = None

    aliases: ClassVar[dict[str, str]] = {"pairing": "rule"}
    main: ClassVar[str | None] = "rule"

    def check(self) -> None:
        from .correlation import check_pairing  # the one check of a pairing rule and threshold

        self.set("min_mac", check_pairing(self.rule, self.min_mac))
        self.set("n_modes", count(self.n_modes, "n_modes", allow_none=True))


@dataclasses.dataclass(frozen=True, repr=False)
class ModalOptions(Options):
    """The residuals of measured modes (:class:`~femupdate.updating.Problem`, paper eqs. 16–21).

    Attributes
    ----------
    formulation : {"shapes", "mac", "dynamic"}, default ``"shapes"``
        ``"shapes"``: relative eigenvalue errors and scaled shape differences; ``"mac"``: relative
        eigenvalue errors and MAC residuals (cost w² (1 − MAC) / 2 per mode); ``"dynamic"``: the
        modal dynamic residual (K − λ_E M) φ of every dof, the unmeasured shape entries solved for
        (no eigen-solution; every test mode needs a shape).
    shape_scaling : {"unit", "ref", "max"}, default ``"unit"``
        How the compared shapes are scaled (``"shapes"`` only): unit norm over the measured dofs,
        1 at a reference dof (eq. 33), or 1 at the largest entry.
    ref_dof : str, optional
        The reference dof of ``"ref"`` scaling (default: each mode's first measured dof).
    use_shapes : bool, default True
        False: the measured shapes are ignored (frequencies only).
    sensitivity : str, default ``"auto"``
        The route of the eigenvector derivatives (:func:`femupdate.sensitivity.jacobian`):
        ``"auto"`` (Nelson up to 1,500 dofs; above, the adjoint or subspace series), ``"nelson"``,
        ``"modal"``, ``"static"``, ``"subspace"``, ``"adjoint"`` or ``"fd"``.
    reuse : bool, default True
        Sparse models: keep the factorisation workspace and the last modes (the eigensolver's
        start) from one evaluation to the next (the same solution to round-off); False factorises
        afresh every time.
    close_modes : float, default 0.01
        The relative eigenvalue gap below which neighbouring model modes are treated as one group
        of repeated or close modes (:mod:`femupdate.updating.groups`): paired by the MAC of the
        best combination of their shapes, each test mode compared with that combination and its
        Rayleigh frequency, differentiated as a subspace.  ``0 <= close_modes < 0.1``; 0 turns
        groups off: every mode is compared alone, and repeated modes (closer than 1e-8) are
        refused, as before this option.
    """

    formulation: str = "shapes"
    shape_scaling: str = "unit"
    ref_dof: str | None = None
    use_shapes: bool = True
    sensitivity: str = "auto"
    reuse: bool = True
    close_modes: float = 1e-2

    def check(self) -> None:
        choice(self.formulation, FORMULATIONS, "formulation")
        choice(self.shape_scaling, SHAPE_SCALINGS, "shape scaling")
        choice(self.sensitivity, SENSITIVITY_ROUTES, "sensitivity method")
        if self.ref_dof is not None and not isinstance(self.ref_dof, str):
            raise InputError(f"ref_dof must be a dof label such as '3:x', got {self.ref_dof!r}")
        self.set("use_shapes", flag(self.use_shapes, "use_shapes"))
        self.set("reuse", flag(self.reuse, "reuse"))
        self.set("close_modes", number(self.close_modes, "close_modes (the relative gap of close modes)", low=0.0,
                                       high=0.1, high_open=True))


@dataclasses.dataclass(frozen=True, repr=False)
class NoiseOptions(Options):
    """How the data are weighted: their standard deviations (stated, or estimated) or weights.

    Attributes
    ----------
    std : mapping, optional
        Standard deviations by kind of data, ``{"eigenvalue": relative std of λ, "shape": std of
        the scaled shape entries, "frf": std of the FRF residual entries, "static": std of the
        deflections (m)}``; a value is one number or one per test mode (eigenvalue, shape).  The
        residuals are divided by them, and the covariance is absolute when every kind used has
        one.  They replace the test data's own (``std_frequency``, ``std_shape``, ...).
        Shorthand keyword ``measurement_std``.
    weights : mapping, optional
        Modal weights ``{"eigenvalue": w or one per test mode, "shape": w or one per test mode}``.
    basis : {"auto", "stated", "estimate"}, default ``"auto"``
        What the standard deviations of the answer rest on: the stated ones, a noise scale
        estimated from the fit, or ``"auto"`` — stated where every residual has one.
        Shorthand keyword ``noise`` (:func:`femupdate.posterior`).
    """

    std: Mapping | None = None
    weights: Mapping | None = None
    basis: str = "auto"

    aliases: ClassVar[dict[str, str]] = {"measurement_std": "std", "noise": "basis"}
    main: ClassVar[str | None] = "basis"

    def check(self) -> None:
        choice(self.basis, NOISE_BASES, "noise basis")
        for name in ("std", "weights"):
            v = getattr(self, name)
            if v is None:
                continue
            if not isinstance(v, Mapping):
                raise InputError(f"{'measurement_std' if name == 'std' else name} must be a mapping of the kinds of "
                                 f"data ({', '.join(STD_KEYS) if name == 'std' else 'eigenvalue, shape'}) to values, "
                                 f"got {v!r}")
            allowed = STD_KEYS if name == "std" else ("eigenvalue", "shape")
            bad = [k for k in v if k not in allowed]
            if bad:
                raise InputError(f"unknown {'measurement_std' if name == 'std' else name} key {bad[0]!r}: use "
                                 f"{', '.join(allowed)}")
            self.set(name, dict(v))


@dataclasses.dataclass(frozen=True, repr=False)
class SolverOptions(Options):
    """The least-squares solver and the variables it works in
    (:func:`scipy.optimize.least_squares`).

    Attributes
    ----------
    method : {"trf", "dogbox", "lm"}, default ``"trf"``
        Trust-region reflective, dogbox, or Levenberg–Marquardt (which ignores the bounds).
    max_nfev : int, default 200
        The most residual evaluations.
    ftol, xtol, gtol : float, default 1e-10
        The solver's tolerances.
    parametrisation : {"relative", "log", "absolute"}, default ``"relative"``
        The solver's variables: x = p / |p_start|, x = ln p, or x = p.
    regularization : float, {"gcv", "lcurve"} or None, default None
        A Tikhonov factor α ≥ 0, or the rule that chooses it at the start (generalised
        cross-validation, the L-curve's corner); the residual is augmented with α (x − x_start).
    """

    method: str = "trf"
    max_nfev: int = 200
    ftol: float = 1e-10
    xtol: float = 1e-10
    gtol: float = 1e-10
    parametrisation: str = "relative"
    regularization: float | str | None = None

    def check(self) -> None:
        choice(self.method, LSQ_METHODS, "method")
        choice(self.parametrisation, PARAMETRISATIONS, "parametrisation")
        self.set("max_nfev", count(self.max_nfev, "max_nfev"))
        for name in ("ftol", "xtol", "gtol"):
            self.set(name, number(getattr(self, name), name, low=0.0))
        reg = self.regularization
        if isinstance(reg, str):
            choice(reg, REGULARIZATION_RULES, "regularization rule")
        elif reg is not None:
            self.set("regularization", number(reg, "regularization", low=0.0))


@dataclasses.dataclass(frozen=True, repr=False)
class FRFOptions(Options):
    """The FRF residuals (eqs. 30–34; :func:`~femupdate.updating.frf_update`).

    Attributes
    ----------
    residual : {"auto", "linear", "relative", "log"}, default ``"auto"``
        ``"linear"`` (eq. 34), ``"relative"``, ``"log"`` (log-magnitude), or ``"auto"``: a
        log-magnitude stage from the start, then the linear residual from its solution.  Without
        a stated FRF standard deviation the linear residuals are divided by the RMS measured
        response (a note says so).
    weights : array_like, optional
        Broadcastable to the data's (n_lines, n_dofs), multiplying the residuals.
    lines : array_like of int or bool, optional
        Indices (0-based) or a boolean mask of the data's lines to use (default all).
    select : int, optional
        Choose this many of the lines by the conditioning of the sensitivity matrix.
    resonance : {"skip", "error", "keep"}, default ``"skip"``
        What to do with lines within ``resonance_tol`` of a resonance of the nominal model.
    resonance_tol : float, default 1e-3
        Relative eigenvalue distance within which a line is near a resonance.
    damping : Damping or mapping, optional
        The model's damping (:class:`~femupdate.frf.Damping` or ``{alpha, beta, eta}``; default
        undamped).
    solver : {"auto", "dense", "sparse"}, default ``"auto"``
        The solver of the line systems.
    """

    residual: str = "auto"
    weights: Any = None
    lines: Any = None
    select: int | None = None
    resonance: str = "skip"
    resonance_tol: float = 1e-3
    damping: Any = None
    solver: str = "auto"

    def check(self) -> None:
        choice(self.residual, FRF_RESIDUALS, "FRF residual")
        choice(self.resonance, RESONANCE_POLICIES, "resonance policy")
        choice(self.solver, FRF_SOLVERS, "FRF solver")
        self.set("select", count(self.select, "select", allow_none=True))
        self.set("resonance_tol", number(self.resonance_tol, "resonance_tol", low=0.0, high=1.0, low_open=True))

    def given(self) -> dict[str, Any]:
        """The fields that differ from the defaults, as the FRF drivers' keywords."""
        return self.changed()


@dataclasses.dataclass(frozen=True, repr=False)
class StartsOptions(Options):
    """Multi-start: random starts within the bounds, distinct solutions told apart
    (:func:`femupdate.multistart`).

    Attributes
    ----------
    starts : int, default 20
        The number of random starts.
    seed : int or None, default 0
        The seed of the starts (None: unreproducible, the seed drawn is recorded).
    log_uniform : bool, default False
        Draw the starts log-uniformly within the bounds (for parameters spanning decades).
    rel_tol : float, default 1e-4
        Relative distance below which two solutions are the same.
    cost_tol : float, optional
        Converged starts whose cost exceeds this are failures (default: no limit).
    batched : bool, optional
        Force (True) or forbid (False) the compiled batched route of small modal models (default:
        chosen by the problem).
    """

    starts: int = 20
    seed: int | None = 0
    log_uniform: bool = False
    rel_tol: float = 1e-4
    cost_tol: float | None = None
    batched: bool | None = None

    main: ClassVar[str | None] = "starts"

    def check(self) -> None:
        self.set("starts", count(self.starts, "starts"))
        self.set("seed", count(self.seed, "seed", low=0, allow_none=True))
        self.set("log_uniform", flag(self.log_uniform, "log_uniform"))
        self.set("rel_tol", number(self.rel_tol, "rel_tol", low=0.0, low_open=True))
        if self.cost_tol is not None:
            self.set("cost_tol", number(self.cost_tol, "cost_tol", low=0.0))
        if self.batched is not None:
            self.set("batched", flag(self.batched, "batched"))


@dataclasses.dataclass(frozen=True, repr=False)
class ExecutionOptions(Options):
    """Where the work runs: this process, local worker processes, or an existing Dask cluster.

    Attributes
    ----------
    scheduler : str, optional
        The address of an existing Dask scheduler (``tcp://host:port``); local otherwise.
    connect_timeout : float, default 10.0
        Seconds to wait for the scheduler.
    jobs : int, optional
        Local worker processes for per-start work of large models (default: one per usable core
        when a start is worth a process; 1: this process).  Not with ``scheduler``.
    threads : int, optional
        Threads of the compiled routes (default: the usable cores).
    """

    scheduler: str | None = None
    connect_timeout: float = 10.0
    jobs: int | None = None
    threads: int | None = None

    def check(self) -> None:
        if self.scheduler is not None and not isinstance(self.scheduler, str):
            raise InputError(f"scheduler must be an address such as 'tcp://host:8786', got {self.scheduler!r}")
        self.set("connect_timeout", number(self.connect_timeout, "connect_timeout", low=0.0, low_open=True))
        self.set("jobs", count(self.jobs, "jobs", high=256, allow_none=True))
        self.set("threads", count(self.threads, "threads", high=1024, allow_none=True))
        if self.jobs is not None and self.scheduler:
            raise InputError(f"jobs={self.jobs} with a scheduler: the work runs on the cluster's workers; give one of "
                             "the two")


#: the posterior's methods (:class:`SamplerOptions`)
SAMPLER_METHODS = ("laplace", "mcmc", "tmcmc")
#: how likelihoods are evaluated (:class:`SamplerOptions`)
LIKELIHOOD_ROUTES = ("auto", "compiled", "local")


@dataclasses.dataclass(frozen=True, repr=False)
class SamplerOptions(Options):
    """How the posterior is explored (:func:`femupdate.posterior`).

    Attributes
    ----------
    method : {"laplace", "mcmc", "tmcmc"}, default ``"laplace"``
        ``"laplace"``: a mixture of Gaussians at the distinct solutions (samples drawn from it);
        ``"mcmc"``: ``ensembles`` emcee ensembles of ``walkers`` walkers started from it run
        ``steps`` steps; ``"tmcmc"``: ``samples`` samples moved from the prior to the posterior
        (Ching & Chen 2007), with the log-evidence — the one to use when several solutions are
        probable.
    samples : int, default 4000
        Laplace draws, or TMCMC's population.
    walkers : int, optional
        MCMC walkers per ensemble, even (default max(64, 8 L) on the compiled route, whose
        likelihood of a half-ensemble costs little more than of one walker; max(32, 4 L) on the
        local route).
    ensembles : int, default 2
        Independent MCMC ensembles (one Dask task each).
    steps : int, default 2000
        MCMC steps per walker.
    burn : int, optional
        MCMC steps discarded (default a quarter: of ``steps``, or with ``target_ess`` of the
        steps done).
    segment : int, default 250
        MCMC steps between checkpoints (and Dask rounds).
    target_ess : float, optional
        Stop MCMC once every parameter's effective sample size reaches this.
    tmcmc_steps : int, default 5
        Metropolis moves per chain and TMCMC stage.
    target_cov : float, default 1.0
        The coefficient of variation of TMCMC's stage weights.
    chunks : int, default 8
        TMCMC's chains in this many pieces (random streams, Dask tasks).
    level : float, default 0.95
        Probability of the credible intervals.
    predictive : int, default 200
        Posterior draws at which the paired modes are predicted (frequencies, MACs).
    route : {"auto", "compiled", "local"}, default ``"auto"``
        How likelihoods are evaluated: ``"auto"`` compiled when the batched route supports the
        model and options (modal data, at most 200 dofs, formulation ``shapes``), else local.
    """

    method: str = "laplace"
    samples: int = 4000
    walkers: int | None = None
    ensembles: int = 2
    steps: int = 2000
    burn: int | None = None
    segment: int = 250
    target_ess: float | None = None
    tmcmc_steps: int = 5
    target_cov: float = 1.0
    chunks: int = 8
    level: float = 0.95
    predictive: int = 200
    route: str = "auto"

    main: ClassVar[str | None] = "method"

    def check(self) -> None:
        choice(self.method, SAMPLER_METHODS, "method")
        choice(self.route, LIKELIHOOD_ROUTES, "route")
        for name, low in (("samples", 2), ("ensembles", 1), ("steps", 2), ("segment", 1), ("tmcmc_steps", 1),
                          ("chunks", 1), ("predictive", 0)):
            self.set(name, count(getattr(self, name), name, low=low))
        self.set("walkers", count(self.walkers, "walkers", low=2, allow_none=True))
        self.set("burn", count(self.burn, "burn", low=0, allow_none=True))
        self.set("level", number(self.level, "level", low=0.0, high=1.0, low_open=True, high_open=True))
        self.set("target_cov", number(self.target_cov, "target_cov", low=0.0, low_open=True))
        if self.target_ess is not None:
            self.set("target_ess", number(self.target_ess, "target_ess", low=0.0, low_open=True))
        if self.method == "mcmc" and self.burn is not None and self.burn >= self.steps:
            raise InputError(f"burn ({self.burn}) must be smaller than steps ({self.steps})")


@dataclasses.dataclass(frozen=True, repr=False)
class UpdateOptions(Options):
    """Everything that defines one update besides the model, the data and the start: the kinds
    of data used and the option objects of :func:`femupdate.update`.  What a multi-start study, a
    posterior or a uniqueness study hands to every update it runs.

    Attributes
    ----------
    use : tuple of str, default ``("modes", "frf", "static")``
        The kinds of data to use, of those the data hold.
    modal : ModalOptions
    pairing : PairingOptions
    noise : NoiseOptions
    solver : SolverOptions
    frf : FRFOptions
    """

    use: tuple[str, ...] = DATA_KINDS
    modal: ModalOptions = dataclasses.field(default_factory=ModalOptions)
    pairing: PairingOptions = dataclasses.field(default_factory=PairingOptions)
    noise: NoiseOptions = dataclasses.field(default_factory=NoiseOptions)
    solver: SolverOptions = dataclasses.field(default_factory=SolverOptions)
    frf: FRFOptions = dataclasses.field(default_factory=FRFOptions)

    #: the option objects, in the order shorthand keywords are matched
    PARTS: ClassVar[dict[str, type[Options]]] = {"modal": ModalOptions, "pairing": PairingOptions,
                                                 "noise": NoiseOptions, "solver": SolverOptions, "frf": FRFOptions}

    def check(self) -> None:
        use = (self.use,) if isinstance(self.use, str) else self.use
        try:
            use = tuple(use)
        except TypeError:
            raise InputError(f"use must be a sequence of the kinds of data ({', '.join(DATA_KINDS)}), got "
                             f"{self.use!r}") from None
        unknown = [u for u in use if u not in DATA_KINDS]
        if unknown:
            raise InputError(f"unknown data kind(s) {', '.join(map(str, unknown))}: use {', '.join(DATA_KINDS)}")
        self.set("use", use)
        for name, cls in self.PARTS.items():
            self.set(name, cls.coerce(getattr(self, name), f"UpdateOptions({name}=...)"))

    @classmethod
    def of(cls, where: str, shorthand: Mapping[str, Any], *, options: UpdateOptions | None = None,
           use=None, **parts) -> UpdateOptions:
        """The update's options from a call: ``options`` (or the defaults), its parts replaced by
        the objects given in ``parts`` (``modal=``, ``pairing=``, ...; None leaves a part as it
        is), then changed by the shorthand keywords (fields of the parts; ``frf_options``, a
        mapping of FRF fields, is the older spelling of ``frf``).

        Raises
        ------
        TypeError
            A keyword no part has (named).
        """
        base = options if options is not None else cls()
        shorthand = dict(shorthand)
        if "frf_options" in shorthand:
            if parts.get("frf") is not None:
                raise TypeError(f"{where}(): give frf or frf_options, not both")
            parts["frf"] = shorthand.pop("frf_options")
        if "use" in shorthand:
            use = shorthand.pop("use")
        slots = {name: (pcls, getattr(base, name) if parts.get(name) is None else parts[name])
                 for name, pcls in cls.PARTS.items()}
        objs = gather(where, shorthand, **slots)
        return cls(use=base.use if use is None else use, **objs)

    def keywords(self) -> dict[str, Any]:
        """The parts as :func:`femupdate.update` takes them (``use=``, ``modal=``, ...)."""
        return {"use": self.use, **{name: getattr(self, name) for name in self.PARTS}}


__all__ = ["Options", "UpdateOptions", "SamplerOptions", "gather_some", "SAMPLER_METHODS", "LIKELIHOOD_ROUTES", "PairingOptions", "ModalOptions", "NoiseOptions", "SolverOptions", "FRFOptions",
           "StartsOptions", "ExecutionOptions", "gather", "choice", "number", "count", "flag",
           "PAIRING_RULES", "FORMULATIONS", "SHAPE_SCALINGS", "SENSITIVITY_ROUTES", "PARAMETRISATIONS",
           "LSQ_METHODS", "REGULARIZATION_RULES", "FRF_RESIDUALS", "RESONANCE_POLICIES", "FRF_SOLVERS",
           "DATA_KINDS", "STD_KEYS", "NOISE_BASES"]
