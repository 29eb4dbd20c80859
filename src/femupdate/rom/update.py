"""Updating on a parametric reduced model, every answer checked on the full model.

:func:`rom_update` builds the greedy basis (:func:`femupdate.rom.greedy.build`), runs
:func:`femupdate.update` on the reduced model, checks the answer on the full model
(:func:`femupdate.rom.check.check_point`) and, while the check fails, adds the full modes it
computed (and their static corrections) to the basis and resumes the update from that answer.
:func:`rom_multistart` does the same for a multi-start study, checking every converged start.
"""

from __future__ import annotations

import dataclasses
import math
import time
from dataclasses import dataclass

import numpy as np

from .._errors import InputError
from .check import check_line, check_point
from .greedy import ReducedBasis, build
from .project import data_dofs


@dataclass(frozen=True)
class ROMOptions:
    """How the reduced basis is built and its answers checked.

    Parameters
    ----------
    n_modes : int, optional
        Modes per snapshot and modes estimated (default: the test modes plus 4).
    freq_tol : float, default 1e-6
        Largest relative frequency error of a paired mode at the checked answer (full model).
    shape_tol : float, default 1e-6
        Largest 1 − MAC between a paired reduced mode and the full mode at the data's dofs.
    n_train : int, default 12
        Training points of the greedy search.
    max_points : int, default 4
        Most greedy snapshots (the nominal one included).
    max_rounds : int, default 4
        Most check-and-enrich rounds of a start.
    corrections : bool, default True
        Add each mode's static corrections (its derivative's static part) to a snapshot.
    seed : int, default 0
        Of the training points.
    polish : bool, default True
        After a passed check, add the full modes computed there (and their static corrections)
        to the basis once and resume: the reduced model is then exact for those modes at the
        answer, and the answer moves to the full model's to within the solver's tolerance
        rather than the check's; a second check follows.
    """

    n_modes: int | None = None
    freq_tol: float = 1e-6
    shape_tol: float = 1e-6
    n_train: int = 12
    max_points: int = 4
    max_rounds: int = 4
    corrections: bool = True
    seed: int = 0
    polish: bool = True

    def __post_init__(self):
        for name in ("freq_tol", "shape_tol"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not (v > 0 and math.isfinite(v)):
                raise InputError(f"reduced basis: {name} must be a positive number, got {v!r}")
        for name in ("n_train", "max_points", "max_rounds"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, int) or v < (0 if name == "n_train" else 1):
                raise InputError(f"reduced basis: {name} must be a whole number >= "
                                 f"{0 if name == 'n_train' else 1}, got {v!r}")
        if self.n_modes is not None and (isinstance(self.n_modes, bool) or not isinstance(self.n_modes, int)
                                         or self.n_modes < 1):
            raise InputError(f"reduced basis: n_modes must be a whole number >= 1, got {self.n_modes!r}")


def _args(model, data, rom, basis, where: str) -> ROMOptions:
    """The arguments' types (a TypeError naming the first wrong one); the options."""
    from .._checks import data_arg, model_arg

    model_arg(model, "model", where)
    data_arg(data, "data", where)
    if rom is not None and not isinstance(rom, ROMOptions):
        raise TypeError(f"{where}: rom must be a ROMOptions (femupdate.rom.ROMOptions), got {type(rom).__name__}")
    if basis is not None and (not isinstance(basis, ReducedBasis) or basis.model is not model):
        raise TypeError(f"{where}: basis must be a ReducedBasis of this model (femupdate.rom.basis_for(model, data))")
    if not data.modes:
        raise InputError(f"{where}: the reduced route checks measured modes; these data hold none")
    return rom or ROMOptions()


def basis_for(model, data, rom: ROMOptions | None = None, params=None) -> ReducedBasis:
    """The greedy reduced basis of ``model`` for the test data ``data``."""
    rom = _args(model, data, rom, None, "basis_for")
    dofs = data_dofs(data)
    n_modes = rom.n_modes or len(getattr(data, "modes", ())) + 4
    return build(model, dofs, n_modes, names=params, n_train=rom.n_train, max_points=rom.max_points,
                 tol=rom.freq_tol, corrections=rom.corrections, seed=rom.seed)


def _record(rb: ReducedBasis, rom: ROMOptions, checks: list, seconds: dict) -> dict:
    return {"size": rb.size, "n_dofs": rb.model.n_dofs, "n_modes": rb.n_modes, "corrections": rb.corrections,
            "interpolated_dofs": list(rb.dofs), "snapshots": rb.points, "greedy": rb.history,
            "freq_tol": rom.freq_tol, "shape_tol": rom.shape_tol, "checks": checks,
            "passed": bool(checks) and all(c["passed"] for c in checks[-1:]), "seconds": seconds}


def _resolve_start(rb, reduced, data, params, x0, values, options, rom, checks, label=None, res=None,
                   polish: bool | None = None):
    """One start on the reduced model (``res``: its run already made), checked and resumed until its
    check passes (then polished once, unless ``polish`` is False); the final run, the reduced model
    and the full modes of the last check."""
    from ..updating import update

    if res is not None and not hasattr(res, "pairs"):  # a compiled route's light run: resumed from its answer
        x0, res = dict(zip(res.names, map(float, res.x))), None
    polish = rom.polish if polish is None else polish
    polished, modes = False, None
    for rnd in range(rom.max_rounds):
        if res is None:
            res = update(reduced, data, params=params, x0=x0, values=values, options=options)
        p = reduced.resolve(res.parameters)
        rec, modes = check_point(rb, p, [j for _, j, _ in res.pairs], rom.freq_tol, rom.shape_tol,
                                 shape_dofs=_shape_dofs(data) or None)
        rec["round"] = rnd + 1
        if label is not None:
            rec["start"] = label
        checks.append(rec)
        if rec["passed"] and (polished or not polish or rnd + 1 == rom.max_rounds):
            break
        why = "polish: the passed answer's modes" if rec["passed"] else f"check failed at round {rnd + 1}"
        polished = polished or rec["passed"]
        if not rec["passed"] and rnd + 1 == rom.max_rounds:  # no round left: the failed answer is reported
            return res, reduced, None
        rb.add_snapshot(p, why + (f" (start {label})" if label else ""), modes)
        reduced, _ = rb.reduced()
        x0 = dict(zip(res.names, map(float, res.x)))
        res = None
    return res, reduced, modes


def _shape_dofs(data) -> list[str]:
    seen: dict[str, None] = {}
    for m in getattr(data, "modes", ()):
        seen.update(dict.fromkeys(m.dofs))
    return list(seen)


def rom_update(model, data, *, rom: ROMOptions | None = None, basis: ReducedBasis | None = None, params=None,
               x0=None, values=None, options=None):
    """:func:`femupdate.update` on a reduced model, its answer checked on the full model.

    Parameters
    ----------
    model : Model
        The full model.
    data : TestData
        The test data (their dofs are the reduced model's physical dofs).
    rom : ROMOptions, optional
        The basis and the check's tolerances.
    basis : ReducedBasis, optional
        A basis built before (:func:`basis_for`; enriched in place by failed checks).
    params, x0, values, options
        As :func:`femupdate.update`.

    Returns
    -------
    UpdateResult
        The final run on the reduced model, with the full model as its context; its JSON holds
        ``reduced_basis`` (the basis, the greedy history and every check) and its notes a line
        per check.
    """
    rom = _args(model, data, rom, basis, "rom_update")
    t0 = time.perf_counter()
    rb = basis if basis is not None else basis_for(model, data, rom, params)
    t1 = time.perf_counter()
    reduced, _ = rb.reduced()
    checks: list = []
    res, _, _ = _resolve_start(rb, reduced, data, params, x0, values, options, rom, checks)
    seconds = {"basis": t1 - t0 if basis is None else rb.seconds, "update_and_checks": time.perf_counter() - t1}
    return finish(res, model, data, _record(rb, rom, checks, seconds))


def finish(res, model, data, record: dict):
    """``res`` with the full model as context, the record in its JSON and a note per check."""
    from ..updating.results import attach

    notes = list(res.notes) + [f"reduced model ({record['size']} Ritz vectors for {record['n_dofs']} dofs): "
                               + check_line(c) for c in record["checks"]]
    if not record["passed"]:
        notes.append("warning: the reduced answer did not pass its full-model check within the rounds allowed")
    res = dataclasses.replace(res, notes=notes)
    out = attach(res, model, data, "update")
    ctx = out.context.replace(stored={**dict(out.context.stored), "reduced_basis": record})
    return dataclasses.replace(out, context=ctx)


def rom_multistart(model, data, starts=None, *, rom: ROMOptions | None = None, basis: ReducedBasis | None = None,
                   params=None, values=None, options=None, **shorthand):
    """:func:`femupdate.multistart` on a reduced model, every converged start checked on the full
    model; a start whose check fails is resumed (from its answer) on the enriched basis; the best
    start is polished (:class:`ROMOptions`) and checked again.

    Returns
    -------
    MultiStartResult
        As :func:`femupdate.multistart`, its runs those of the last round, its best run's JSON with
        ``reduced_basis``.
    """
    from ..updating import multistart

    rom = _args(model, data, rom, basis, "rom_multistart")
    t0 = time.perf_counter()
    rb = basis if basis is not None else basis_for(model, data, rom, params)
    t1 = time.perf_counter()
    reduced, _ = rb.reduced()
    ms = multistart(reduced, data, starts, params=params, values=values, options=options, **shorthand)
    checks: list = []
    runs = list(ms.runs)
    best_at = _index_of(ms.best, runs)
    final = {}
    for i, run in enumerate(runs):
        if isinstance(run, str) or not run.success:
            continue
        res, reduced, modes = _resolve_start(rb, reduced, data, params, None, values, options, rom, checks,
                                             label=i + 1, res=run, polish=False)
        final[i] = (res, modes if i == best_at else None)  # one factorisation kept, the best start's
        if res is not run:
            runs[i] = res
    if rom.polish and best_at in final and final[best_at][1] is not None:  # the best start polished
        res, modes = final[best_at]
        p = reduced.resolve(res.parameters)
        rb.add_snapshot(p, f"polish: the passed answer's modes (best start {best_at + 1})", modes)
        reduced, _ = rb.reduced()
        res, reduced, _ = _resolve_start(rb, reduced, data, params, dict(zip(res.names, map(float, res.x))), values,
                                         options, rom, checks, label=best_at + 1, polish=False)
        final[best_at] = (res, None)
        runs[best_at] = res
    seconds = {"basis": t1 - t0 if basis is None else rb.seconds, "update_and_checks": time.perf_counter() - t1}
    record = _record(rb, rom, checks, seconds)
    record["passed"] = bool(checks) and all(_last_per_start(checks))
    best = final[best_at][0] if best_at in final else ms.best  # the best start, resumed
    if best is not None:
        best = finish(best, model, data, record)
    out = dataclasses.replace(ms, runs=runs, best=best)
    return out if best is None else dataclasses.replace(out, context=best.context)


def _index_of(best, runs) -> int | None:
    """The start whose run is the study's best (the same answer)."""
    if best is None:
        return None
    for i, run in enumerate(runs):
        if not isinstance(run, str) and np.array_equal(np.asarray(run.x), np.asarray(best.x)):
            return i
    return None


def _last_per_start(checks: list) -> list[bool]:
    last: dict = {}
    for c in checks:
        last[c.get("start")] = c["passed"]
    return list(last.values())


__all__ = ["ROMOptions", "rom_update", "rom_multistart", "basis_for", "finish"]
