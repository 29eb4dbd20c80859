"""The method knobs of :func:`~femupdate.damage.detect_damage`, as one checked, frozen object.

``detect_damage(model, data, options=DamageOptions(refine=False, bootstrap=0))`` is the same call as
``detect_damage(model, data, refine=False, bootstrap=0)`` (the fields as shorthand keywords,
:func:`femupdate.options.gather`); the command ``femupdate damage`` builds one from its options.
The data (the undamaged structure's modes, the unknowns that may change, the stated noise, the
descriptions of the unknowns) stay arguments of the function.
"""

from __future__ import annotations

import dataclasses
import numbers

from .._budget import NOISE_DRAW_BYTES, REPLICATE_BYTES, check_count
from .._errors import InputError
from ..options import Options, choice, count, flag, number

#: the regularisers of the localisation step
METHODS = ("l1", "tikhonov")


def _real(value) -> bool:
    return isinstance(value, numbers.Real) and not isinstance(value, bool)


@dataclasses.dataclass(frozen=True, repr=False)
class DamageOptions(Options):
    """How :func:`~femupdate.damage.detect_damage` localises, refines, verifies and bootstraps.

    Attributes
    ----------
    method : {"l1", "tikhonov"}, default ``"l1"``
        The localisation's regulariser: L1 (sparse, α chosen by BIC on a path) or Tikhonov with
        the factor chosen by GCV.
    alpha : float in (0, 1], optional
        L1 factor as a fraction of α_max (default: chosen by BIC on a path).
    expansion : {"serep", "irs", "guyan"}, default ``"serep"``
        Expansion of the measured shapes to every dof (unused when every dof is measured).
    n_basis : int, optional
        SEREP modes (default: the model modes up to the highest one a measured mode pairs with,
        plus as many again, at most the number of measured dofs).  It must lie between 1 and the
        number of measured dofs (checked with the data).
    allow_increase : bool, default False
        Let stiffness increase too (default: loss only, −1 ≤ change ≤ 0; with it, up to +1).
    min_change : float in (0, 1), default 0.05
        A relative change smaller than this is not reported as damage.
    iterations : int ≥ 1, default 3
        Expansions of the localisation step, the first with the baseline, the next ones with the
        damaged estimate (which removes the bias of the baseline expansion: a true 40 % loss in
        one member of an 8 x 8-node lattice truss came out 53 %, 39.4 %, 40.0 % after 1, 2, 4
        expansions).
    n_noise : int ≥ 2, optional
        Replicates estimating the equations' covariance under the stated noise, which weights
        them (default four per equation, 60 to 400).
    refine : bool, default True
        Refine the located set by nonlinear updating and verify it (:mod:`.refine`); False: the
        localisation step's answer alone (``status`` "unverified"; the method before refinement).
    level : float in (0.5, 1), default 0.99
        Confidence level of the verification (chi-square test of the misfit).
    max_located : int ≥ 1, optional
        Largest set the search enlarges to (default ``min(L, 8)`` of the L unknowns).
    bootstrap : int ≥ 0, default 20
        Replicates for the confidence: data simulated from the identified model with the stated
        noise, each re-localised, refined and verified (0: none; none either when the stated
        noise is zero).  Without ``refine``, the measured data are perturbed instead and the
        localisation alone re-run.
    seed : int ≥ 0 or None, default 0
        Seed of the replicates (noise weights and bootstrap; None: unreproducible).
    localise_min_mac : float in [0, 1], default 0.8
        A measured mode pairing with no baseline mode at least this well (0.8 is the usual
        threshold for "the same mode") makes the expansion unreliable: without ``refine`` it
        stops the localisation (``localised`` False, ``reason``); with it, a note says so and the
        refinement, which needs no expansion, chooses the set.
    max_frequency_error : float ≥ 0, default 0.02
        Largest relative frequency error of the baseline against the undamaged structure's data
        (:func:`~femupdate.damage.check_baseline`; unused without them).
    min_mac : float in [0, 1], default 0.9
        Smallest MAC of the baseline against the undamaged structure's data (likewise).
    baseline_checked : bool, default False
        The caller states that the baseline was checked against the undamaged structure (e.g.
        updated against its data) when no ``undamaged`` data are given.  Without either, a located
        set is never "confirmed" (a wrong baseline reports its own errors as damage).
    """

    method: str = "l1"
    alpha: float | None = None
    expansion: str = "serep"
    n_basis: int | None = None
    allow_increase: bool = False
    min_change: float = 0.05
    iterations: int = 3
    n_noise: int | None = None
    refine: bool = True
    level: float = 0.99
    max_located: int | None = None
    bootstrap: int = 20
    seed: int | None = 0
    localise_min_mac: float = 0.8
    max_frequency_error: float = 0.02
    min_mac: float = 0.9
    baseline_checked: bool = False

    def check(self) -> None:
        from ..reduction.expansion import EXPANSION_METHODS

        # the checks (and messages) detect_damage has always made, in its order
        choice(self.method, METHODS, "method")
        if not _real(self.min_change) or not 0 < self.min_change < 1:
            raise InputError(f"min_change must lie in (0, 1), got {self.min_change!r}")
        if self.alpha is not None and (not _real(self.alpha) or not 0 < self.alpha <= 1):
            raise InputError(f"alpha is a fraction of alpha_max in (0, 1], got {self.alpha!r}")
        if self.alpha is not None and self.method != "l1":
            raise InputError(f"alpha={self.alpha} (the L1 factor) applies to method=l1 only, not method={self.method} "
                             "(whose factor is chosen by GCV)")
        for name in ("iterations", "bootstrap", "max_located"):
            v = getattr(self, name)
            if _real(v) and not isinstance(v, numbers.Integral):
                raise InputError(f"{name} must be an integer, got {v!r}")
        if not _real(self.iterations) or not _real(self.bootstrap) or int(self.iterations) < 1 \
                or int(self.bootstrap) < 0:
            raise InputError("iterations must be >= 1 and bootstrap >= 0")
        if not _real(self.level) or not 0.5 < float(self.level) < 1:
            raise InputError(f"level must lie in (0.5, 1), got {self.level!r}")
        if self.max_located is not None and (not _real(self.max_located) or int(self.max_located) < 1):
            raise InputError(f"max_located must be >= 1, got {self.max_located!r}")
        self.set("iterations", int(self.iterations))
        self.set("bootstrap", int(self.bootstrap))
        self.set("level", float(self.level))
        if self.max_located is not None:
            self.set("max_located", int(self.max_located))
        # the others (n_basis is checked against the measured dofs)
        choice(self.expansion, EXPANSION_METHODS, "expansion")
        self.set("allow_increase", flag(self.allow_increase, "allow_increase"))
        self.set("refine", flag(self.refine, "refine"))
        self.set("baseline_checked", flag(self.baseline_checked, "baseline_checked"))
        self.set("n_noise", count(self.n_noise, "n_noise", low=2, allow_none=True))
        check_count("bootstrap", self.bootstrap, REPLICATE_BYTES, "the bootstrap replicates")
        if self.n_noise is not None:
            check_count("n_noise", self.n_noise, NOISE_DRAW_BYTES, "the noise replicates of the weights")
        self.set("seed", count(self.seed, "seed", low=0, allow_none=True))
        self.set("localise_min_mac", number(self.localise_min_mac, "localise_min_mac", low=0.0, high=1.0))
        self.set("max_frequency_error", number(self.max_frequency_error, "max_frequency_error", low=0.0))
        self.set("min_mac", number(self.min_mac, "min_mac", low=0.0, high=1.0))


__all__ = ["DamageOptions", "METHODS"]
