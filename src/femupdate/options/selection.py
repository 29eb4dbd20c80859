"""The options of the choice of spectral lines (:func:`femupdate.frf.select_frequencies`)."""

from __future__ import annotations

import dataclasses
from typing import ClassVar

from ._base import Options, choice, count, flag, number
from .choices import SELECTION_EQUATIONS


@dataclasses.dataclass(frozen=True, repr=False)
class SelectionOptions(Options):
    """How spectral lines are chosen for FRF updating (:func:`femupdate.frf.select_frequencies`;
    He 1993, Ren & Beards 1993).

    Attributes
    ----------
    equations : {"direct", "sensitivity"}, default ``"direct"``
        The equations whose conditioning is judged: those of complete data (eq. 28), or the
        sensitivity equations of data measured at the response dofs (eqs. 31–32).  Shorthand
        keyword ``kind``.
    margin : float, default 0.05
        Candidates whose relative eigenvalue distance to a resonance of the model is below this
        are excluded (0.05 ≈ 2.5 % in frequency); 0 excludes none.
    scaled : bool, default True
        Judge the condition number with the columns scaled to unit length (unit-free).
    max_passes : int, default 20
        Exchange passes per start (greedy + exchange only).
    exhaustive_limit : int, default 200000
        Up to this many subsets, every one is evaluated (the exact optimum); above, greedy +
        exchange from the greedy set and ``restarts`` random sets.
    restarts : int, default 10
        Random starting sets of the exchange.
    seed : int, default 0
        Seed of the random starting sets.
    """

    equations: str = "direct"
    margin: float = 0.05
    scaled: bool = True
    max_passes: int = 20
    exhaustive_limit: int = 200_000
    restarts: int = 10
    seed: int = 0

    aliases: ClassVar[dict[str, str]] = {"kind": "equations"}
    main: ClassVar[str | None] = "equations"

    def check(self) -> None:
        choice(self.equations, SELECTION_EQUATIONS, "selection equations")
        self.set("margin", number(self.margin, "margin", low=0.0))
        self.set("scaled", flag(self.scaled, "scaled"))
        for name in ("max_passes", "exhaustive_limit", "restarts", "seed"):
            self.set(name, count(getattr(self, name), name, low=0))


__all__ = ["SelectionOptions"]
