"""The options of one update: pairing, modal residuals, noise, solver, FRF residuals, and
:class:`UpdateOptions`, which holds them all."""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from typing import Any, ClassVar

import numpy as np

from .._checks import as_array
from .._errors import InputError
from ._base import Options, choice, count, flag, gather, number
from .choices import (DATA_KINDS, FORMULATIONS, FRF_RESIDUALS, FRF_SOLVERS, LSQ_METHODS, NOISE_BASES, PARAMETRISATIONS,
                      REGULARIZATION_RULES, RESONANCE_POLICIES, SENSITIVITY_ROUTES, SHAPE_SCALINGS, STD_KEYS)


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
        from ..correlation import check_pairing  # the one check of a pairing rule and threshold

        self.set("min_mac", check_pairing(self.rule, self.min_mac))
        self.set("n_modes", count(self.n_modes, "n_modes", allow_none=True))


@dataclasses.dataclass(frozen=True, repr=False)
class ModalOptions(Options):
    """The residuals of measured modes (:class:`~femupdate.updating.Problem`, paper eqs. 16–21).

    Attributes
    ----------
    formulation : {"shapes", "mac", "dynamic"}, default ``"shapes"``
        The residuals of each test mode:

        * ``"shapes"``: w_λ (λ_A − λ_E)/λ_E and the scaled shape differences w_ψ (ψ_A − ψ_E) at
          the measured dofs (:func:`femupdate.rules.shape_residuals`);
        * ``"mac"``: w_λ (λ_A − λ_E)/λ_E and the MAC residuals w_ψ (I − ê êᵀ) â
          (:func:`femupdate.rules.mac_residuals`), whose squared norm is w_ψ² (1 − MAC): the MAC
          term of the literature in a form smooth at MAC = 1, independent of the shapes' scaling;
        * ``"dynamic"``: the modal dynamic residual w_λ (K − λ_E M) φ / c of every dof, the
          measured entries of φ the test shape and the unmeasured ones unknowns solved for at each
          point (:mod:`femupdate.updating.dynamic`); no eigen-solution, every test mode needs a
          shape, the eigenvalue's weight and standard deviation weigh the mode's residual and the
          shape's have nothing to weigh (the measured entries are held).

        ``"mac"`` and ``"dynamic"`` do not depend on how the shapes are scaled: they take
        ``shape_scaling="unit"`` and no ``ref_dof``, and need the shapes (``use_shapes``);
        ``"dynamic"`` takes ``sensitivity="auto"``
        (:func:`femupdate.updating.problem.check_formulation`).
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
        Models solved by the sparse eigensolver (:func:`femupdate.modal.eigensolver_for`): reuse
        from one evaluation to the next what does not change — the model's factorisation
        workspace (ordering and factorisation route, :mod:`femupdate.workspace`) — and start the
        eigensolver from the previous evaluation's modes (ARPACK's starting vector, and a shift
        below their lowest eigenvalue, which also shortens the sensitivities' series).  The same
        modes and derivatives to round-off.  False: every evaluation as a first one (the backend's
        factorisation afresh, shift 0).
    close_modes : float, default 0.01
        The relative eigenvalue gap below which neighbouring model modes are treated as one group
        of repeated or close modes (:mod:`femupdate.updating.groups`): paired by the MAC of the
        best combination of their shapes, each test mode compared with the combination of the
        group's shapes that fits it best and with the eigenvalue of the model mode it is assigned
        inside the group, differentiated as a subspace (Mills-Curran 1988, Dailey 1989:
        :mod:`femupdate.sensitivity.repeated`).  ``0 <= close_modes < 0.1``; 0 turns groups off:
        every mode is compared alone, and repeated modes (closer than 1e-8) are refused.
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
        What the standard deviations of the answer rest on (:mod:`femupdate.updating.noise`):
        ``"auto"`` — each block of residuals with stated standard deviations as stated, the
        others estimated from the fit (REML variance components; in the posterior a scale per
        kind of data); ``"estimate"`` — every block estimated, a stated one as a factor on its
        deviations; ``"stated"`` — every block stated (:func:`femupdate.posterior` refuses data
        without; an update estimates the blocks without and says so).  Shorthand keyword
        ``noise`` (:func:`femupdate.posterior`).
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
            for key, value in v.items():
                _check_values(name, key, value)
            self.set(name, dict(v))


def _check_values(name: str, key: str, value) -> None:
    """A standard deviation (finite, > 0) or a weight (finite, >= 0) of ``NoiseOptions``: one
    number or an array of them; None (a kind without one) passes for standard deviations."""
    if value is None and name == "std":
        return
    arr = as_array(value)
    ok = arr is not None and arr.size > 0 and arr.dtype.kind in "iuf"
    if ok and arr is not None:
        arr = arr.astype(float)
        ok = bool(np.all(np.isfinite(arr)) and (np.all(arr > 0) if name == "std" else np.all(arr >= 0)))
    if not ok:
        label = "measurement_std" if name == "std" else "weights"
        rule = "positive and finite" if name == "std" else "finite and non-negative"
        each = "one number or one per test mode" if key in ("eigenvalue", "shape") else "a number or an array of numbers"
        raise InputError(f"{label}[{key!r}] must be {rule} ({each}), got {value!r}")


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
        The solver's variables: x = p / ``|p_start|``, x = ln p, or x = p.
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
        for name, kinds in (("lines", "iub"), ("weights", "iuf")):
            v = getattr(self, name)
            if v is None:
                continue
            arr = as_array(v)
            if arr is None or arr.dtype.kind not in kinds or arr.size == 0 or (name == "lines" and arr.ndim != 1) \
                    or (name == "lines" and arr.dtype.kind == "i" and np.any(arr < 0)):
                what = ("indices (int, from 0) or a mask (bool) of the lines" if name == "lines"
                        else "an array of numbers")
                raise InputError(f"{name} must be {what}, got {v!r}")
            if name == "weights" and not np.all(np.isfinite(arr) & (arr >= 0)):
                raise InputError("weights must be finite numbers >= 0")
        if self.damping is not None:
            from ..frf.lines import as_damping

            as_damping(self.damping)

    def given(self) -> dict[str, Any]:
        """The fields that differ from the defaults, as the FRF drivers' keywords."""
        return self.changed()


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
            if isinstance(use, (bytes, Mapping)):
                raise TypeError
            use = tuple(use)
        except TypeError:
            use = ()
        if not use:
            raise InputError(f"use must be a sequence of the kinds of data ({', '.join(DATA_KINDS)}), got "
                             f"{self.use!r}")
        unknown = [u for u in use if not isinstance(u, str) or u not in DATA_KINDS]
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
        is) or among the shorthand keywords by the same names (an option object, or for ``modal``
        and ``frf`` a mapping of its fields: ``multistart(..., solver=SolverOptions(...))``), then
        changed by the other shorthand keywords (fields of the parts; ``frf_options``, a
        mapping of FRF fields, is the older spelling of ``frf``).

        Raises
        ------
        TypeError
            A keyword no part has (named).
        """
        base = cls.coerce(options, f"{where}(options=...)")
        shorthand = dict(shorthand)
        if "frf_options" in shorthand:
            if parts.get("frf") is not None:
                raise TypeError(f"{where}(): give frf or frf_options, not both")
            parts["frf"] = shorthand.pop("frf_options")
        if "use" in shorthand:
            use = shorthand.pop("use")
        fields = {f for pcls in cls.PARTS.values() for f in (*pcls.field_names(), *pcls.aliases)}
        for name in cls.PARTS:  # a part by its keyword (multistart(solver=SolverOptions(...))), as update takes it
            if name in shorthand and (isinstance(shorthand[name], Options) or name not in fields):
                if parts.get(name) is not None:
                    raise TypeError(f"{where}(): {name} given twice")
                parts[name] = shorthand.pop(name)
        slots = {name: (pcls, getattr(base, name) if parts.get(name) is None else parts[name])
                 for name, pcls in cls.PARTS.items()}
        objs = gather(where, shorthand, **slots)
        return cls(use=base.use if use is None else use, **objs)

    def keywords(self) -> dict[str, Any]:
        """The parts as :func:`femupdate.update` takes them (``use=``, ``modal=``, ...)."""
        return {"use": self.use, **{name: getattr(self, name) for name in self.PARTS}}


__all__ = ["PairingOptions", "ModalOptions", "NoiseOptions", "SolverOptions", "FRFOptions", "UpdateOptions"]
