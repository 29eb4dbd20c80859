"""False-positive and detection rates of damage detection measured by ``benchmarks/bench_damage.py``.

The benchmark (random scenarios on a spring chain, a planar truss and a space frame; one or two
damaged members; noise on frequencies and shapes; sensors on a subset of the dofs) writes the
rates of :func:`~femupdate.damage.detect_damage` per noise level, sensor share and number of
modes into the package file ``femupdate/data/damage_benchmark.json``, with its date and
command.  :func:`comparable_rate` reads the row nearest to a detection's own setting.
"""

from __future__ import annotations

import json
import math
from functools import lru_cache
from importlib import resources

TABLE = "damage_benchmark.json"
MIN_SCENARIOS = 10  # fewer comparable scenarios than this: the bins are widened


@lru_cache(maxsize=1)
def table() -> dict | None:
    """The benchmark's table (None when the package holds none)."""
    try:
        text = (resources.files("femupdate") / "data" / TABLE).read_text(encoding="utf-8")
    except (FileNotFoundError, OSError):
        return None
    return json.loads(text)


def comparable_rate(noise: float, sensor_fraction: float, n_modes: int) -> dict | None:
    """The benchmark's rates for scenarios comparable with a detection.

    Comparable: the benchmark's noise level nearest to ``noise`` (relative, the larger of the
    frequency and shape levels), the same sensor-share bin and the same bin of the number of
    modes; when that holds fewer than ``MIN_SCENARIOS`` scenarios, the modes bin and then the
    sensor bin are dropped.

    Parameters
    ----------
    noise : float
        Stated noise level (relative).
    sensor_fraction : float
        Measured dofs over the model's dofs.
    n_modes : int
        Measured modes.

    Returns
    -------
    dict or None
        ``false_positive_rate`` (share of scenarios in which a healthy unknown was reported
        damaged), ``detection_rate`` (share in which every damaged one was found), ``scenarios``,
        ``false_positives``, ``noise`` (the benchmark level), ``sensor_fraction`` and ``modes``
        (the bins used, None when dropped), ``date``, ``command``; None without a table.
    """
    tab = table()
    if not tab or not tab.get("rows"):
        return None
    rows = tab["rows"]
    levels = sorted({r["noise"] for r in rows})
    level = min(levels, key=lambda v: (abs(v - noise), v))

    def inside(value, bounds) -> bool:
        return bounds[0] <= value < bounds[1]

    sel = [r for r in rows if r["noise"] == level]
    keys = ("sensor_fraction", "modes")
    chosen: dict = {}
    for drop in (0, 1, 2):
        use = keys[:2 - drop]
        pick = [r for r in sel if all(inside(sensor_fraction if k == "sensor_fraction" else n_modes, r[k]) for k in use)]
        if sum(r["scenarios"] for r in pick) >= MIN_SCENARIOS or drop == 2:
            chosen = {k: (pick[0][k] if pick and k in use else None) for k in keys}
            break
    n = sum(r["scenarios"] for r in pick)
    fp = sum(r["false_positives"] for r in pick)
    det = sum(r["detected"] for r in pick)
    return {"false_positive_rate": fp / n if n else math.nan, "detection_rate": det / n if n else math.nan,
            "scenarios": n, "false_positives": fp, "noise": level, **chosen,
            "date": tab.get("date"), "command": tab.get("command")}


__all__ = ["comparable_rate", "table"]
