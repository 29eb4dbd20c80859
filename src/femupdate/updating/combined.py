r"""Updating from whatever the test data hold — modes, FRFs, static deflections or any mix — as
one problem, and :func:`update`, the updating verb.

Each kind of data is a *block* with its own residuals and exact Jacobian, all on one vector of
updated parameters:

* ``"modes"`` — :class:`~femupdate.updating.Problem`: relative eigenvalue errors and scaled
  shape differences of the paired modes (paper eqs. 16–21, 33);
* ``"frf"`` — :class:`~femupdate.updating.frf.FRFProblem`: the responses at the measured dofs,
  line by line (eqs. 30–32, 34);
* ``"static"`` — one :class:`~femupdate.updating.frf.FRFProblem` per load case at ω = 0, where the
  dynamic stiffness is K: :math:`r = w\,(u_S(p) - u_{S,\mathrm{measured}})` with
  :math:`u = K(p)^{-1} f` and :math:`\partial u_S/\partial p_j = -Y_S^T K_j u`,
  :math:`Y_S = K^{-1} I_{:,S}` (Brandon's eq. 32 at zero frequency; mass parameters have no
  effect on it).

The residual vector stacks the blocks, each times a scale:

* a block whose measurement standard deviation is stated (``measurement_std``: ``"eigenvalue"``
  and ``"shape"`` for modes, ``"frf"``, ``"static"``) is divided by it — the blocks then weigh
  by their uncertainty (maximum likelihood for independent Gaussian errors) and, when every
  block's is stated, the covariance of the parameters is absolute;
* without a stated standard deviation, a block of a problem with *one* kind of data keeps its
  own residuals (the result is that of :func:`update_modal` or
  :func:`~femupdate.updating.frf.frf_update`); in a *mix*, a block whose residuals carry units
  (FRF ``"linear"`` residuals, in m/N; static deflections, in m) is divided by the RMS of its
  measured values, so that every block is dimensionless like the modal one, and a note says so:
  such weights are a convention, not a statement about the data.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from .._errors import InputError, NumericalError
from ..frf.lines import UNDAMPED
from ..testdata import FRFData, TestData
from .frf import FRFProblem, FRFUpdateResult, frac, modal_report, prepare_problem
from .problem import Parametrisation, Problem
from .results import UpdateResult
from .solve import diagnostics, result_at, solve, update_modal

#: the kinds of test data, in the order their blocks are stacked
DATA_KINDS = ("modes", "frf", "static")
#: the keys of ``measurement_std``, by kind
STD_KEYS = {"eigenvalue": "modes", "shape": "modes", "frf": "frf", "static": "static"}
#: options of the FRF block (``frf_options``), as :func:`~femupdate.updating.frf.frf_update` takes them
FRF_OPTIONS = ("residual", "weights", "lines", "select", "resonance", "resonance_tol", "damping", "solver")


@dataclass(frozen=True, eq=False)
class Block:
    """One kind of data in a :class:`CombinedProblem`.

    ``kind``: ``"modes"``, ``"frf"`` or ``"static"``; ``label``: how messages name it
    (``"modes"``, ``"frf"``, ``"static case 2"``); ``problem``: its residuals and Jacobian;
    ``scale``: the factor its residuals are multiplied by; ``weighting``: why that factor.
    """

    kind: str
    label: str
    problem: Problem | FRFProblem
    scale: float
    weighting: str


def data_kinds(data: TestData, use: Sequence[str] = DATA_KINDS) -> tuple[str, ...]:
    """The kinds of data in ``data`` that ``use`` asks for, in :data:`DATA_KINDS` order.

    Raises
    ------
    InputError
        An unknown kind in ``use``, or none of the asked-for kinds in the data.
    """
    use = tuple(use)
    unknown = sorted(set(use) - set(DATA_KINDS))
    if unknown:
        raise InputError(f"unknown data kind(s) {', '.join(unknown)}: use {', '.join(DATA_KINDS)}")
    have = {"modes": bool(data.modes), "frf": data.frf is not None, "static": bool(data.static)}
    kinds = tuple(k for k in DATA_KINDS if k in use and have[k])
    if not kinds:
        held = [k for k in DATA_KINDS if have[k]]
        raise InputError(f"the test data hold no {' or '.join(use)} data to update from"
                         + (f" (they hold: {', '.join(held)})" if held else " (they are empty)"))
    return kinds


def _split_std(measurement_std: Mapping | None) -> dict[str, dict]:
    """``measurement_std`` by kind: {"modes": {"eigenvalue": .., "shape": ..}, "frf": .., ...}."""
    out: dict[str, dict] = {}
    for key, value in dict(measurement_std or {}).items():
        if key not in STD_KEYS:
            raise InputError(f"unknown measurement_std key {key!r}: use {', '.join(STD_KEYS)}")
        if value is None:
            continue
        arr = np.asarray(value, float)
        if not (np.all(np.isfinite(arr)) and np.all(arr > 0)):
            raise InputError(f"measurement_std[{key!r}] must be positive and finite")
        out.setdefault(STD_KEYS[key], {})[key] = value
    return out


def _weighting(label: str, stated: bool, relative: bool, measured, what: str, quantity: str, unit: str,
               notes: list[str], key: str = "frf") -> tuple[float, str]:
    """A block's scale and how it was chosen: 1 with a stated std (already in its weights) or when
    its residuals are used as they are; 1 / RMS of the measured values when ``relative`` (a mix,
    residuals with units), with a note."""
    if stated:
        return 1.0, "stated std"
    if not relative:
        return 1.0, "as given"
    v = np.abs(np.asarray(measured))
    rms = float(np.sqrt(np.mean(v ** 2))) if v.size else 0.0
    notes.append(f"{label}: no standard deviation stated; {what} are divided by the RMS measured {quantity} "
                 f"({rms:.4g}{unit}) to weigh them against the other data; state measurement_std['{key}'] to weigh "
                 "by uncertainty")
    return (1.0 / rms if rms > 0 else 1.0), f"divided by the RMS measured {quantity} ({rms:.4g}{unit})"


class CombinedProblem(Parametrisation):
    """Several blocks of data (:class:`Block`), one vector of updated parameters.

    Offers what :func:`~femupdate.updating.solve` and :func:`~femupdate.updating.diagnostics`
    need: the :class:`~femupdate.updating.Parametrisation` maps, ``residuals(x)`` (the blocks'
    residuals times their scales, stacked in block order) and ``jacobian(x)``.

    Attributes
    ----------
    blocks : list of Block
    sigma : True-ish when every block's residuals are divided by stated standard deviations
        (the covariance is then absolute), else None.
    notes : what the user should know about the weighting and the lines used.
    """

    def __init__(self, model, blocks: Sequence[Block], sigma, notes: Sequence[str] = ()):
        first = blocks[0].problem
        super().__init__(model, first.names, first.param, first.p_base)
        self.model = model
        self.blocks = list(blocks)
        self.sigma = sigma
        self.notes = list(notes)
        self.nfev = 0
        self.rows = np.cumsum([0] + [self._n(b) for b in self.blocks])

    @staticmethod
    def _n(block: Block) -> int:
        prob = block.problem
        if isinstance(prob, Problem):
            return prob.n_residuals
        return int(prob.xe.size * (2 if np.iscomplexobj(prob.xe) and prob.kind != "log" else 1))

    @property
    def n_residuals(self) -> int:
        return int(self.rows[-1])

    @property
    def modal(self) -> Problem | None:
        """The modal block's problem (None without modes)."""
        return next((b.problem for b in self.blocks if isinstance(b.problem, Problem)), None)

    def _each(self, x, what: str):
        for b in self.blocks:
            try:
                yield b, getattr(b.problem, what)(x)
            except NumericalError as exc:
                if b.kind == "modes":
                    raise
                raise NumericalError(f"{b.label}: {exc}") from None

    def residuals(self, x) -> np.ndarray:
        """The stacked residuals (m,) at the variables x."""
        self.nfev += 1
        return np.concatenate([b.scale * r for b, r in self._each(x, "residuals")])

    def jacobian(self, x) -> np.ndarray:
        """The stacked exact Jacobian ∂r/∂x (m, L) at x."""
        return np.vstack([b.scale * J for b, J in self._each(x, "jacobian")])

    def block_costs(self, r: np.ndarray) -> list[dict]:
        """Per block {kind, label, n_residuals, scale, weighting, cost} of the residuals r."""
        out = []
        for b, a, z in zip(self.blocks, self.rows[:-1], self.rows[1:]):
            rb = r[a:z]
            out.append({"kind": b.kind, "label": b.label, "n_residuals": int(z - a), "scale": b.scale,
                        "weighting": b.weighting, "cost": float(0.5 * rb @ rb)})
        return out


def combined_problem(model, data: TestData, params: Sequence[str] | None = None, *,
                     use: Sequence[str] = DATA_KINDS, x0: Mapping[str, float] | None = None, values=None,
                     parametrisation: str = "relative", measurement_std: Mapping | None = None,
                     frf_options: Mapping | None = None, regularized: bool = False, method: str = "trf",
                     **modal_options) -> CombinedProblem:
    """The :class:`CombinedProblem` of every kind of data in ``data`` that ``use`` names.

    Parameters
    ----------
    model : Model
    data : TestData
    params, x0, values, parametrisation : as :func:`update`.
    use : kinds of data to use (:data:`DATA_KINDS`; default all that the data hold).
    measurement_std : {"eigenvalue": relative std of λ, "shape": std of scaled shape entries,
        "frf": std of the FRF residual entries (scalar or broadcastable to the response),
        "static": std of the measured deflections (m; scalar, or one per measured dof of a case
        when there is one case)}; a block with its standard deviation stated is divided by it.
    frf_options : options of the FRF block (:data:`FRF_OPTIONS`).
    regularized : a regularisation will be added (the count of data is not checked).
    method : the least-squares method (``"trf"``, ``"dogbox"``, ``"lm"``).
    **modal_options : options of the modal block (:class:`~femupdate.updating.Problem`:
        ``shape_scaling``, ``ref_dof``, ``weights``, ``min_mac``, ``n_modes``, ``use_shapes``,
        ``sensitivity``).

    Raises
    ------
    InputError
        Unknown kinds, keys or options; data the model cannot be compared with; fewer
        independent data than parameters (unless ``regularized``).
    """
    kinds = data_kinds(data, use)
    std = _split_std(measurement_std)
    frf_options = dict(frf_options or {})
    bad = sorted(set(frf_options) - set(FRF_OPTIONS))
    if bad:
        raise InputError(f"unknown FRF option(s) {', '.join(bad)}: use {', '.join(FRF_OPTIONS)}")
    if frf_options and "frf" not in kinds:
        raise InputError(f"FRF options ({', '.join(sorted(frf_options))}) given, but no FRF data are used")
    mixed = len(kinds) > 1
    names = list(params) if params is not None else [model.parameter_names[j] for j in model.free]
    blocks: list[Block] = []
    notes: list[str] = []
    n_data = 0
    for kind in kinds:
        prob: Problem | FRFProblem
        if kind == "modes":
            given = std.get("modes")
            prob = Problem(model, data, names, x0=x0, values=values, parametrisation=parametrisation,
                           measurement_std=given, **modal_options)
            n_data += prob.targets.n_independent
            weighting = "stated std" if given else "dimensionless (relative eigenvalues, scaled shapes)"
            blocks.append(Block("modes", "modes", prob, 1.0, weighting))
        elif kind == "frf":
            given = std.get("frf", {}).get("frf")
            opts = dict(frf_options)
            fp, _, skipped, frf_notes = prepare_problem(
                model, data, names, x0, opts.get("residual", "linear"), opts.get("weights"), given,
                opts.get("lines"), opts.get("select"), opts.get("resonance", "skip"),
                opts.get("resonance_tol", _resonance_tol()), opts.get("damping"), parametrisation, values,
                opts.get("solver", "auto"), True, method)
            fp.skipped = skipped
            notes.extend(frf_notes)
            n_data += CombinedProblem._n(Block("frf", "frf", fp, 1.0, ""))
            scale, weighting = _weighting("frf", given is not None, mixed and fp.kind == "linear", fp.xe,
                                          "the linear FRF residuals", "response", "", notes)
            blocks.append(Block("frf", "frf", fp, scale, weighting))
        else:
            given = std.get("static", {}).get("static")
            for k, case in enumerate(data.static, start=1):
                label = f"static case {k}"
                frf = FRFData(np.zeros(1), case.force, case.dofs, case.displacement[None, :])
                weights = None
                if given is not None:
                    try:
                        weights = 1.0 / np.broadcast_to(np.asarray(given, float), case.displacement.shape)
                    except ValueError:
                        raise InputError(f"measurement_std['static']: give one value or one per measured dof of "
                                         f"{label} ({case.displacement.size})") from None
                try:
                    prob = FRFProblem(model, frf, names, parametrisation, _p_base(model, values, x0), "linear",
                                      weights, np.zeros(1, int), UNDAMPED, "auto")
                except InputError as exc:
                    raise InputError(f"{label}: {exc}") from None
                n_data += case.displacement.size
                scale, weighting = _weighting(label, given is not None, mixed, case.displacement, "its deflections",
                                              "deflection", " m", notes, key="static")
                blocks.append(Block("static", label, prob, scale, weighting))
    sigma = True if all(b.weighting == "stated std" for b in blocks) else None
    if mixed and "modes" in kinds and blocks[0].weighting == "stated std":
        modal = blocks[0].problem
        if isinstance(modal, Problem) and modal.any_shape and "shape" not in std.get("modes", {}):
            sigma = None
    combined = CombinedProblem(model, blocks, sigma, notes)
    if not regularized and n_data < len(names):
        raise InputError(f"{len(names)} parameters but only {n_data} independent data ({', '.join(kinds)}): the "
                         "problem is underdetermined; add data, fix parameters, or use regularization")
    return combined


def _p_base(model, values, x0) -> np.ndarray:
    p = model.resolve(values)
    for name, v in dict(x0 or {}).items():
        p[model.parameter_index(name)] = float(v)
    return p


def _resonance_tol() -> float:
    from ..frf.sensitivity import RESONANCE_TOL

    return RESONANCE_TOL


def update(model, data: TestData, *, params: Sequence[str] | None = None, x0: Mapping[str, float] | None = None,
           use: Sequence[str] = DATA_KINDS, shape_scaling: str = "unit", ref_dof: str | None = None,
           weights: Mapping | None = None, measurement_std: Mapping | None = None, min_mac: float = 0.5,
           n_modes: int | None = None, parametrisation: str = "relative", method: str = "trf", max_nfev: int = 200,
           ftol: float = 1e-10, xtol: float = 1e-10, gtol: float = 1e-10, use_shapes: bool = True,
           regularization: float | str | None = None, values=None, sensitivity: str = "auto",
           frf_options: Mapping | None = None) -> UpdateResult:
    """Update the model's parameters so that it matches the test data: measured modes, FRFs,
    static deflections, or any mix of them, as one least-squares problem.

    Parameters
    ----------
    model : Model
    data : TestData
        Measured modes (shapes may be partial: any subset of model dofs, any scaling), FRFs at
        any dofs, static load cases with deflections at any dofs.
    params : names of the parameters to update (default: every parameter not ``fixed``).
    x0 : starting values {name: value} (default: the model's nominal values).
    use : the kinds of data to use (default ``("modes", "frf", "static")``: all the data hold).
    shape_scaling : ``"unit"`` | ``"ref"`` | ``"max"``; ``ref_dof`` for ``"ref"`` (default: the
        first measured dof of each mode, the paper's eq. 33 convention).
    weights : modal weights {"eigenvalue": w or per-mode array, "shape": w}.
    measurement_std : standard deviations by kind (:func:`combined_problem`): {"eigenvalue":
        relative std of λ, "shape": std of scaled shape entries, "frf": std of the FRF residual
        entries, "static": std of the deflections (m)}; the residuals are divided by them, and
        when every kind used has one the covariance is absolute, not scaled by the residual.
    min_mac : pairing threshold of the modes.
    n_modes : model modes computed and paired among (default ``max(2T, T + 6)``).
    parametrisation : ``"relative"`` (x = p / p_start, default), ``"log"`` (x = log p) or ``"absolute"``.
    method : ``"trf"`` | ``"dogbox"`` | ``"lm"`` (Levenberg–Marquardt; no bounds).
    max_nfev, ftol, xtol, gtol : limits and tolerances of :func:`scipy.optimize.least_squares`.
    use_shapes : False: frequencies only.
    regularization : None, a Tikhonov factor α, or ``"gcv"`` / ``"lcurve"`` to choose it at the
        start; the residual is augmented with α (x − x_start).
    values : values of the fixed parameters (default nominal).
    sensitivity : derivative route of the modal Jacobian (:func:`femupdate.sensitivity.jacobian`):
        ``"auto"`` (Nelson up to 1,500 dofs; above, the adjoint or subspace series), ``"nelson"``,
        ``"modal"``, ``"static"``, ``"subspace"``, ``"adjoint"`` or ``"fd"``.
    frf_options : options of the FRF residuals, as :func:`~femupdate.updating.frf.frf_update`
        takes them: ``residual`` (``"linear"`` eq. 34, ``"relative"``, ``"log"``), ``weights``,
        ``lines``, ``select``, ``resonance``, ``resonance_tol``, ``damping``, ``solver``.

    Returns
    -------
    UpdateResult
        Modes only: as :func:`update_modal`.  FRFs only: as
        :func:`~femupdate.updating.frf.frf_update` (an :class:`~femupdate.updating.frf.FRFUpdateResult`).
        A mix, or static cases: an :class:`UpdateResult` (an ``FRFUpdateResult`` when FRFs are
        used) whose ``blocks`` give each block's share of the cost and whose ``notes`` say how
        the blocks were weighted.  ``success``/``status``/``message`` report convergence
        (non-convergence is a status, not an exception).

    Raises
    ------
    InputError
        Bad options or data (named); :class:`~femupdate.NumericalError` when the model cannot
        be evaluated (unpaired modes, a singular stiffness for static data, ...).
    """
    if method not in ("trf", "dogbox", "lm"):
        raise InputError(f"unknown method {method!r}: use trf, dogbox or lm")
    kinds = data_kinds(data, use)
    modal_options: dict[str, Any] = dict(shape_scaling=shape_scaling, ref_dof=ref_dof, weights=weights, min_mac=min_mac,
                         n_modes=n_modes, use_shapes=use_shapes, sensitivity=sensitivity)
    solver_options: dict[str, Any] = dict(method=method, max_nfev=max_nfev, ftol=ftol, xtol=xtol, gtol=gtol)
    if kinds == ("modes",) and not frf_options:
        return update_modal(model, data, params=params, x0=x0, values=values, parametrisation=parametrisation,
                            measurement_std=measurement_std, regularization=regularization, **modal_options,
                            **solver_options)
    if kinds == ("frf",):
        from .frf import frf_update

        std = _split_std(measurement_std)
        extra = sorted(set(std) - {"frf"})
        if extra:
            raise InputError(f"measurement_std for {', '.join(extra)} given, but only FRF data are used")
        return frf_update(model, data, params=params, x0=x0, values=values, parametrisation=parametrisation,
                          measurement_std=std.get("frf", {}).get("frf"), regularization=regularization,
                          **dict(frf_options or {}), **solver_options)
    combined = combined_problem(model, data, params, use=kinds, x0=x0, values=values, parametrisation=parametrisation,
                            measurement_std=measurement_std, frf_options=frf_options,
                            regularized=regularization is not None, method=method, **modal_options)
    sol, history, reg = solve(combined, model.bounds, regularization=regularization, **solver_options)
    return combined_result(combined, data, sol.x, sol, history, reg)


def combined_result(prob: CombinedProblem, data: TestData, x, sol=None, history=None, reg=None) -> UpdateResult:
    """The result of ``prob`` at the variables x (:func:`~femupdate.updating.result_at` for a
    :class:`CombinedProblem`)."""
    model = prob.model
    r = prob.residuals(x)
    J = prob.jacobian(x)
    p_final = prob.to_p(x)
    modal = prob.modal
    if modal is not None:
        base = result_at(modal, x, sol, history, reg)
        pairs, f_test, f_model, swaps = base.pairs, base.test_frequencies_hz, base.model_frequencies_hz, base.swaps
        routes = [base.sensitivity]
    else:
        pairs, f_test, f_model, _ = modal_report(model, data, p_final)
        swaps, routes = [], []
    frf_blocks = [b for b in prob.blocks if b.kind == "frf"]
    routes += ["brandon"] if frf_blocks else []
    routes += ["static (brandon at ω = 0)"] if any(b.kind == "static" for b in prob.blocks) else []
    history = history if history is not None else []
    common = dict(
        parameters=dict(zip(model.parameter_names, map(float, p_final))), names=tuple(prob.names), x=p_final[prob.idx],
        success=bool(sol.success) if sol is not None else False, status=int(sol.status) if sol is not None else 0,
        message=str(sol.message) if sol is not None else "evaluated, not solved", cost=float(0.5 * r @ r), fun=r,
        jac=J, nfev=int(sol.nfev) if sol is not None else 1, njev=int(sol.njev or 0) if sol is not None else 0,
        iterations=max(len(history) - 1, int(sol.njev or 0) if sol is not None else 0), history=history,
        pairs=pairs, test_frequencies_hz=f_test, model_frequencies_hz=f_model, swaps=swaps,
        diagnostics=diagnostics(prob, x, r, J, prob.sigma), regularization=reg or {},
        start=dict(zip(prob.names, map(float, prob.p_base[prob.idx]))), sensitivity=" + ".join(routes),
        blocks=prob.block_costs(r), notes=list(prob.notes))
    if not frf_blocks:
        return UpdateResult(**common)
    fp = frf_blocks[0].problem
    assert isinstance(fp, FRFProblem)
    frf = data.frf
    assert frf is not None
    _, _, _, natural = modal_report(model, TestData(), p_final)
    return FRFUpdateResult(**common, omega=fp.omega, skipped=list(getattr(fp, "skipped", [])), residual=fp.kind,
                           frac=dict(zip(frf.dofs, frac(fp.xe, fp.responses(x)))), natural_frequencies_hz=natural)


__all__ = ["update", "combined_problem", "combined_result", "CombinedProblem", "Block", "data_kinds", "DATA_KINDS",
           "STD_KEYS", "FRF_OPTIONS"]
