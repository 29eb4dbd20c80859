"""The options of a test plan (:func:`femupdate.planning.plan`): which modes the test targets,
and how the sensors are placed."""

from __future__ import annotations

import dataclasses
import math
from typing import ClassVar

from .._errors import InputError
from ._base import Options, choice, count, flag, number

#: how target modes are chosen (:class:`TargetOptions`)
TARGET_METHODS = ("lowest", "mass", "energy")
#: placement criteria (:class:`PlacementOptions`): identifiability first, or a classical one
PLACEMENT_CRITERIA = ("identifiability", "efi", "efi-dpr", "kinetic", "mac")
#: the design criterion after identifiability (:class:`PlacementOptions`)
DESIGN_CRITERIA = ("d", "a")
#: the test-analysis model of a plan's pretest correlation
TAM_CHOICES = ("guyan", "irs", "serep", "none")
#: a sensor measures one dof, or the three translations of a node
SENSOR_KINDS = ("uniaxial", "triaxial")


@dataclasses.dataclass(frozen=True, repr=False)
class TargetOptions(Options):
    """The modes a test plan targets (:func:`femupdate.planning.target_modes`).

    Attributes
    ----------
    method : {"lowest", "mass", "energy"}, default ``"lowest"``
        The lowest ``n_modes``; the modes of effective modal mass fraction at least
        ``min_fraction`` along ``direction``; or those whose kinetic energy at the candidate dofs
        is at least ``min_fraction`` of their total.
    n_modes : int, optional
        ``"lowest"``: the number of modes (default 3); otherwise the most kept (largest fractions).
    band_hz : (float, float), optional
        Only modes in this band (Hz), lower < upper.
    direction : str, optional
        ``"mass"``: the direction of the influence vector, x, y or z.
    min_fraction : float, default 0.01
        The smallest effective-mass or kinetic-energy fraction of a target mode, in (0, 1].
    """

    method: str = "lowest"
    n_modes: int | None = None
    band_hz: tuple[float, float] | None = None
    direction: str | None = None
    min_fraction: float = 0.01

    main: ClassVar[str | None] = "method"

    def check(self) -> None:
        choice(self.method, TARGET_METHODS, "target-mode method")
        self.set("n_modes", count(self.n_modes, "n_modes", low=1, allow_none=True))
        if self.band_hz is not None:
            try:
                lo, hi = (float(v) for v in self.band_hz)
            except (TypeError, ValueError):
                raise InputError(f"band_hz must be two frequencies (lower, upper), got {self.band_hz!r}") from None
            if not (math.isfinite(lo) and math.isfinite(hi) and 0 <= lo < hi):
                raise InputError(f"band_hz: the lower frequency {lo:g} must be >= 0 and below the upper {hi:g}")
            self.set("band_hz", (lo, hi))
        if self.method == "mass" and self.direction is None:
            raise InputError("direction must be given (x, y or z) to choose target modes by effective mass")
        if self.direction is not None and self.direction not in ("x", "y", "z"):
            raise InputError(f"direction must be x, y or z, got {self.direction!r}")
        self.set("min_fraction", number(self.min_fraction, "min_fraction", low=0.0, high=1.0, low_open=True))


@dataclasses.dataclass(frozen=True, repr=False)
class PlacementOptions(Options):
    """How the sensors of a test plan are placed (:func:`femupdate.planning.plan`).

    Attributes
    ----------
    criterion : {"identifiability", "efi", "efi-dpr", "kinetic", "mac"}, default ``"identifiability"``
        Identifiability of the parameters first, then ``design``; or a classical criterion about
        seeing the target modes (:mod:`femupdate.planning.classical`).
    n_sensors : int, optional
        Sensors in the plan, fixed ones included.  Default: the smallest identifiable plan
        (``"identifiability"``), the number of target modes (classical criteria).
    kind : {"uniaxial", "triaxial"}, default ``"uniaxial"``
        A sensor measures one dof, or the translations of a node.
    design : {"d", "a"}, default ``"d"``
        After identifiability: D-optimal (log det F) or A-optimal (trace of F⁻¹, relative parameters).
    points : int, default 10
        Random points of the parameter box at which identifiability is checked (besides the
        nominal point).
    max_condition : float, default 1e6
        The largest condition number of the value-scaled sensitivity matrix counted as well
        conditioned.
    max_automac : float, default 1.0
        The largest off-diagonal auto-MAC of the target modes at the sensors of an identifiable
        plan (modes that look alike at the sensors cannot be paired by MAC); 1: no requirement.
    std_eigenvalue : float, default 0.002
        Relative standard deviation of the measured eigenvalues (>= 1e-100; twice the frequencies').
    std_shape : float, default 0.01
        Standard deviation of the unit-scaled shape entries (>= 1e-100).
    monte_carlo : int, default 0
        Noisy updates that check the predicted standard deviations (0: none; else at least 2).
    exchange : bool, default True
        Improve the greedy (or eliminated) set by exchanges.
    restarts : int, default 0
        Random starting sets of the exchange besides the greedy one.
    seed : int, default 0
        Seed of the box's points, the restarts and the Monte Carlo noise.
    exhaustive_limit : int, default 0
        ``"identifiability"`` with ``n_sensors``: up to this many candidate sets, score every one
        (the exact optimum) instead of greedy selection and exchange.
    information_gain : bool, default False
        Judge sets (after identifiability) by the expected information gain with the parameters'
        priors (Laplace: ½ log det(I + Σ_prior F) for ``design="d"``); a parameter without a
        normal or lognormal prior takes the uniform one within its (finite) bounds.
    n_exciters : int, default 0
        Exciters of an FRF test placed for the chosen sensors (0: none).
    std_frf : float, default 0.01
        Noise floor of the simulated receptances, relative to the largest (> 0).
    damping_ratio : float, default 0.01
        Modal damping ratio of the simulated receptances (> 0).
    tam : {"guyan", "irs", "serep", "none"}, default ``"guyan"``
        The test-analysis model of the pretest correlation.
    sensor_mass : float, default 0.0
        Mass of one accelerometer (kg): the frequency shifts it causes (0: not computed).
    """

    criterion: str = "identifiability"
    n_sensors: int | None = None
    kind: str = "uniaxial"
    design: str = "d"
    points: int = 10
    max_condition: float = 1e6
    max_automac: float = 1.0
    std_eigenvalue: float = 0.002
    std_shape: float = 0.01
    monte_carlo: int = 0
    exchange: bool = True
    restarts: int = 0
    seed: int = 0
    exhaustive_limit: int = 0
    information_gain: bool = False
    n_exciters: int = 0
    std_frf: float = 0.01
    damping_ratio: float = 0.01
    tam: str = "guyan"
    sensor_mass: float = 0.0

    main: ClassVar[str | None] = "criterion"

    def check(self) -> None:
        choice(self.criterion, PLACEMENT_CRITERIA, "placement criterion")
        choice(self.kind, SENSOR_KINDS, "sensor kind")
        choice(self.design, DESIGN_CRITERIA, "design criterion")
        self.set("n_sensors", count(self.n_sensors, "n_sensors", low=1, allow_none=True))
        self.set("points", count(self.points, "points", low=0))
        self.set("max_condition", number(self.max_condition, "max_condition", low=1.0))
        self.set("max_automac", number(self.max_automac, "max_automac", low=0.0, high=1.0, low_open=True))
        for name in ("std_eigenvalue", "std_shape"):
            v = getattr(self, name)
            if isinstance(v, (int, float)) and not isinstance(v, bool) and v == 0:
                raise InputError(f"{name} must be > 0: with zero noise the information is infinite and nothing "
                                 "tells plans apart")
            self.set(name, number(v, name, low=1e-100))  # 1/std² stays finite
        mc = count(self.monte_carlo, "monte_carlo", low=0)
        if mc == 1:
            raise InputError("monte_carlo must be 0 or at least 2 (a standard deviation needs two runs), got 1")
        self.set("monte_carlo", mc)
        self.set("exchange", flag(self.exchange, "exchange"))
        self.set("restarts", count(self.restarts, "restarts", low=0))
        self.set("seed", count(self.seed, "seed", low=0))
        self.set("exhaustive_limit", count(self.exhaustive_limit, "exhaustive_limit", low=0))
        self.set("information_gain", flag(self.information_gain, "information_gain"))
        self.set("n_exciters", count(self.n_exciters, "n_exciters", low=0))
        for name in ("std_frf", "damping_ratio"):
            v = getattr(self, name)
            if isinstance(v, (int, float)) and not isinstance(v, bool) and v == 0:
                raise InputError(f"{name} must be > 0")
            self.set(name, number(v, name, low=1e-100))
        choice(self.tam, TAM_CHOICES, "TAM method")
        self.set("sensor_mass", number(self.sensor_mass, "sensor_mass", low=0.0))


__all__ = ["TargetOptions", "PlacementOptions", "TARGET_METHODS", "PLACEMENT_CRITERIA", "DESIGN_CRITERIA",
           "SENSOR_KINDS"]
