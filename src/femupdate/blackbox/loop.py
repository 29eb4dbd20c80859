"""Updating through a black box: probe, fit, update, run the code at the answer, re-probe there.

Each round probes the code around a centre (:func:`~femupdate.blackbox.probe_model`), updates the
fitted model (:func:`femupdate.update`), and runs the code at the updated values.  The round is
accepted when that run reproduces the fitted model there to ``tolerance`` (relative): the largest
entry of K(p) - K_code and of M(p) - M_code against the largest of K_code and M_code, and every
paired mode's frequency.  Otherwise the next round is centred on the answer, with steps no larger
than the last move (the polynomials become local), and starts from it.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

import numpy as np

from .._errors import NumericalError
from .probe import BlackBox, Probed, _rel, probe_model

if TYPE_CHECKING:
    from ..model import Model
    from ..updating.results import UpdateResult


@dataclass(frozen=True, eq=False)
class BlackBoxResult:
    """What :func:`update_black_box` found.

    Attributes
    ----------
    result : UpdateResult
        The last round's update (its parameters are the answer).
    model : Model
        The last round's fitted model.
    parameters : dict of str to float
        The updated values.
    rounds : list of dict
        Per round: ``center``, ``steps``, ``affine`` {name: bool}, ``parameters``,
        ``matrix_deviation`` and ``frequency_deviation`` (relative, fitted model against the
        code's run at the updated values), ``runs`` (the code's runs that round, cache hits not
        counted).
    runs, cache_hits : int
        Runs of the code in all, and runs read back from the cache.
    """

    result: UpdateResult
    model: Model
    parameters: dict
    rounds: list
    runs: int
    cache_hits: int


def _deviation(box: BlackBox, probed: Probed, result) -> tuple[float, float]:
    """(matrices, paired frequencies) relative deviation of the fitted model from a run at the answer."""
    from ..modal import model_modes, solve_modes

    model = probed.model
    p = dict(result.parameters)
    values = np.array([p.get(n, probed.center[n]) for n in box.names])
    (run,) = box.run([values])
    K, M = model.K(values), model.M(values)
    scale_K = float(np.abs(run.K.data).max()) if run.K.nnz else 1.0
    scale_M = float(np.abs(run.M.data).max()) if run.M.nnz else 1.0
    matrices = max(_rel(K, run.K, scale_K), _rel(M, run.M, scale_M))
    paired = sorted({int(m) for _, m, _ in getattr(result, "pairs", ()) if m is not None and m >= 0})
    if not paired:
        return matrices, 0.0
    n = paired[-1] + 1
    fitted = model_modes(model, values, n_modes=n).frequencies_hz[paired]
    code = solve_modes(run.K, run.M, n_modes=n, dofs=run.dofs).frequencies_hz[paired]
    return matrices, float(np.max(np.abs(fitted / code - 1)))


def update_black_box(box: BlackBox, data, **kwargs) -> BlackBoxResult:
    """Update the parameters of an external code so that it matches ``data`` (module docstring).

    Parameters
    ----------
    box : BlackBox
    data : TestData
    **kwargs
        Passed to :func:`femupdate.update` (``params``, ``options``, ...); ``x0`` is the first
        round's start (default: the nominal values).

    Returns
    -------
    BlackBoxResult

    Raises
    ------
    InputError
        What probing refuses (a failing run, named with its command and output; missing files;
        dofs that change; NaN; interacting parameters).
    NumericalError
        The fitted model and the code still disagree after ``rounds`` rounds.
    """
    from ..updating import update

    opt = box.options
    center = None
    steps = None
    rounds: list[dict] = []
    first_start: dict = {}
    for k in range(opt.rounds):
        runs0 = box.cache.runs
        probed = probe_model(box, center, steps)
        res = update(probed.model, data, **kwargs)
        p = {n: float(res.parameters.get(n, probed.center[n])) for n in box.names}
        mat, freq = _deviation(box, probed, res)
        rounds.append({"center": probed.center, "steps": probed.steps, "affine": probed.affine, "parameters": p,
                       "matrix_deviation": mat, "frequency_deviation": freq, "runs": box.cache.runs - runs0})
        if max(mat, freq) <= opt.tolerance:
            if k:  # the start the user gave (or the nominal values), not the last round's
                res = replace(res, start=dict(first_start))
            return BlackBoxResult(res, probed.model, p, rounds, box.cache.runs, box.cache.hits)
        if not k:
            first_start = dict(res.start)
        moved = {n: abs(p[n] - probed.center[n]) for n in box.names}
        steps = {n: min(probed.steps[n] / 2, max(moved[n], 1e-3 * probed.steps[n])) for n in box.names}
        center = {}  # the answer, moved inside its bounds by enough to probe both sides
        for prm in box.parameters:
            lo, hi = prm.bounds
            margin = min(steps[prm.name] * (2 if opt.degree > 2 else 1), (hi - lo) / 4)
            center[prm.name] = min(max(p[prm.name], lo + margin), hi - margin)
        kwargs["x0"] = {n: p[n] for n in res.names}  # the updated ones
    last = rounds[-1]
    raise NumericalError(
        f"black box {box.name!r}: after {opt.rounds} rounds the code run at the updated values "
        f"({', '.join(f'{k}={v:.10g}' for k, v in last['parameters'].items())}) still differs from the fitted model by "
        f"{last['matrix_deviation']:.3g} in the matrices and {last['frequency_deviation']:.3g} in the paired "
        f"frequencies (tolerance {opt.tolerance:g}); raise rounds or degree, or lower step", partial=rounds)


__all__ = ["BlackBoxResult", "update_black_box"]
