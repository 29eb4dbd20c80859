"""Updating a damped model (:class:`~femupdate.damping.DampedModel`): stiffness, mass and damping
parameters together, from measured modes (frequencies, damping ratios, complex or real shapes)
and FRFs, through the engine every update uses (:class:`~femupdate.updating.combined.CombinedProblem`
with the damped blocks of :mod:`femupdate.updating.damped`, :func:`~femupdate.updating.solve`,
:func:`~femupdate.updating.diagnostics`).

:func:`femupdate.update`, :func:`~femupdate.updating.frf_update` and
:func:`~femupdate.multistart` come here when given a damped model; ``femupdate update`` and
``femupdate frf-update`` when the model file has a ``[damping]`` table.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

import numpy as np

from .._errors import InputError
from ..damping.model import check_ratio
from ..damping.view import DampedView
from ..frf.residuals import zero_channels
from ..options import UpdateOptions
from ..testdata import TestData
from .combined import Block, CombinedProblem, data_kinds, frf_label, split_std
from .damped import DampedFRFProblem, DampedModesProblem
from .frf import ALONE, STD_HINT, FRFUpdateResult, frac, unit_scale
from .parametrisation import start_vector, updated_names
from .results import UpdateResult
from .solve import diagnostics, solve


def damping_information(data: TestData, kinds: Sequence[str]) -> bool:
    """Whether the data used can move damping parameters: measured damping ratios, complex
    shapes, or FRFs."""
    if "frf" in kinds:
        return True
    if "modes" not in kinds:
        return False
    return any(m.damping_ratio is not None or (m.has_shape and np.iscomplexobj(m.shape)) for m in data.modes)


def damped_problem(view: DampedView, data: TestData, options: UpdateOptions, params: Sequence[str] | None = None, *,
                   x0: Mapping[str, float] | None = None, values=None) -> CombinedProblem:
    """The :class:`CombinedProblem` of a damped model: a ``"damped modes"`` block for measured
    modes, one damped ``"frf"`` block per FRF set.

    Parameters
    ----------
    view : DampedView
    data : TestData
    options : UpdateOptions
        ``use``, the pairing rule and ``min_mac``, ``use_shapes``, the standard deviations
        (``noise.std``: ``eigenvalue``, ``shape``, ``damping_ratio``, ``frf``), the FRF residual
        (``"auto"``: linear here) and the parametrisation.
    params, x0, values
        As :func:`femupdate.update`; without ``params``, the damping parameters are left out
        (with a note) when the data hold no damping ratio, complex shape or FRF.

    Raises
    ------
    InputError
        Static data (not taken with damping in this version); options of the undamped modal
        residual other than its defaults (formulation, shape scaling, reference dof); more
        parameters than data.
    """
    o = options
    kinds = data_kinds(data, o.use)
    if "static" in kinds:
        raise InputError("static deflections with a damped model ([damping] table): not taken in this version; "
                         "update from the static data with the undamped model (damping does not act at 0 Hz), or "
                         "leave them out (--use modes,frf)")
    m = o.modal
    if m.formulation != "shapes" or m.shape_scaling != "unit" or m.ref_dof is not None:
        raise InputError("a damped model ([damping] table) compares complex shapes phase-aligned and scaled to unit "
                         "length: --formulation, --shape-scaling and --ref-dof do not apply")
    notes: list[str] = []
    names = updated_names(view, params)
    if params is None and not damping_information(data, kinds):
        dropped = [n for n in names if view.is_damping(n)]
        names = [n for n in names if not view.is_damping(n)]
        if dropped:
            notes.append(f"the damping parameters {', '.join(dropped)} are not updated: the data hold no damping "
                         "ratios, complex shapes or FRFs (their values stay as given)")
        if not names:
            raise InputError("no parameters to update: the model's are fixed and the data hold nothing that moves "
                             "the damping parameters (damping ratios, complex shapes, FRFs)")
    p_base = start_vector(view, values, x0)
    _start_ratios(view, p_base)
    std = split_std({k: v for k, v in dict(o.noise.std or {}).items() if k != "damping_ratio"})
    mode_std = dict(std.get("modes") or {})
    if dict(o.noise.std or {}).get("damping_ratio") is not None:
        mode_std["damping_ratio"] = dict(o.noise.std or {})["damping_ratio"]
    blocks: list[Block] = []
    n_data = 0
    param = o.solver.parametrisation
    if "modes" in kinds:
        prob = DampedModesProblem(view, data, names, p_base, param, o.pairing.rule, o.pairing.min_mac, mode_std,
                                  m.use_shapes, o.pairing.n_modes)
        notes += prob.notes
        n_data += prob.n_independent
        blocks.append(Block("damped modes", "damped modes", prob, 1.0,
                            "stated std" if prob.sigma else "dimensionless (relative eigenvalues, damping ratios, "
                            "unit shapes)"))
    if "frf" in kinds:
        notes += _truncation_note(view, data, p_base)
        given = std.get("frf", {}).get("frf")
        residual = "linear" if o.frf.residual == "auto" else o.frf.residual
        several = data.n_frf_sets > 1
        for fs in data.frf_sets:
            label = frf_label(fs) if several else "frf"
            dead = zero_channels(fs.response)
            if dead.all():
                raise InputError(f"{label}: every FRF channel is zero at every line: no response to update with")
            if dead.any():
                notes.append(f"{label}: FRF response(s) at {', '.join(d for d, z in zip(fs.dofs, dead) if z)} zero at "
                             "every line (a dead channel?): left out of the residual")
            w = None if given is None else 1.0 / np.broadcast_to(np.asarray(given, float), fs.response.shape)
            fp = DampedFRFProblem(view, fs, names, p_base, param, residual, w)
            scale, weighting = unit_scale(label, given is not None, fp.kind == "linear", fp.xe,
                                          "the linear FRF residuals", "response", "", notes, how=STD_HINT,
                                          **({"why": ALONE} if len(kinds) == 1 else {}))
            fp.weighting = weighting
            n_data += fp.n_residuals
            blocks.append(Block("frf", label, fp, scale, weighting))
    if n_data < len(names) and o.solver.regularization is None:
        raise InputError(f"{len(names)} parameters but only {n_data} independent data ({', '.join(kinds)}): the "
                         "problem is underdetermined; add data, fix parameters, or use regularization")
    sigma = True if all(b.weighting == "stated std" for b in blocks) else None
    return CombinedProblem(view, blocks, sigma, notes)


def _start_ratios(view: DampedView, p_base) -> None:
    """Refuse, by the parameter's name, a start (``--set``, ``values``, ``x0``) at which a modal damping
    ratio is 1 or more: its mode would not oscillate, and the update could not pair it."""
    dm = view.damped
    for name, z in zip(dm.modal, dm.modal_ratios(p_base)):
        if isinstance(name, str) and z >= 1:
            check_ratio(float(z), f"the start value of damping parameter {name!r} (a modal damping ratio)")


def _truncation_note(view: DampedView, data: TestData, p_base) -> list[str]:
    """With modal damping ratios the receptances are the modal superposition of their N modes:
    said when the FRF lines reach above the N-th mode's frequency."""
    dm = view.damped
    if not dm.modal or len(dm.modal) >= view.n_dofs:  # every mode has a ratio: none is left out
        return []
    from ..modal import solve_modes

    p = dm.resolve(p_base)
    top = math.sqrt(max(float(solve_modes(dm.K(p), dm.M(p), n_modes=len(dm.modal)).eigenvalues[-1]), 0.0))
    high = max(float(np.max(fs.omega)) for fs in data.frf_sets)
    if high <= top:
        return []
    return [f"the FRF lines reach {high / (2 * math.pi):.4g} Hz, above the highest of the {len(dm.modal)} modes with "
            f"modal damping ratios ({top / (2 * math.pi):.4g} Hz at the start): the model's receptances are the modal "
            "superposition of those modes, the modes above left out; give ratios for the modes of the band"]


def update_damped(view: DampedView, data: TestData, options: UpdateOptions, *, params: Sequence[str] | None = None,
                  x0: Mapping[str, float] | None = None, values=None) -> UpdateResult:
    """:func:`femupdate.update` of a damped model (its options in one
    :class:`~femupdate.options.UpdateOptions`), without the result's context.

    Returns
    -------
    UpdateResult
        An :class:`~femupdate.updating.frf.FRFUpdateResult` with FRF data; ``damping`` says which
        damping parameters were updated, their standard deviations, and per paired mode the
        measured and model damping ratios and the model mode's MPC.
    """
    prob = damped_problem(view, data, options, params, x0=x0, values=values)
    sol, history, reg = solve(prob, view.bounds, options.solver)
    return damped_result(prob, data, sol.x, sol, history, reg, bounded=options.solver.method != "lm")


def damped_result(prob: CombinedProblem, data: TestData, x, sol=None, history=None, reg=None,
                  bounded: bool = True) -> UpdateResult:
    """The result of a damped problem at the variables x (as
    :func:`~femupdate.updating.run.combined_result`)."""
    view = prob.model
    assert isinstance(view, DampedView)
    r = prob.residuals(x)
    J = prob.jacobian(x)
    p = prob.to_p(x)
    diag = diagnostics(prob, x, r, J, prob.sigma, bounds=view.bounds if bounded else None)
    modal = next((b.problem for b in prob.blocks if isinstance(b.problem, DampedModesProblem)), None)
    extra: dict = {}
    if modal is not None:
        paired = modal.paired(x)
        extra = {"damping_ratios": {"test": [None if math.isnan(z) else float(z) for z in modal.zeta_e[[k for k, _, _ in paired["pairs"]]]],
                                    "model": paired.pop("model_damping_ratios")},
                 "mpc": paired.pop("model_mpc"), "complexity": paired.pop("complexity")}
        _, modes, _ = modal.evaluate(x)
        natural = modes.natural_frequencies_hz[:10]
        solver_used = modes.solver
    else:
        from ..damping.complex_modes import complex_modes

        paired = dict(pairs=[], test_frequencies_hz=np.zeros(0), model_frequencies_hz=np.zeros(0))
        natural = complex_modes(view.damped, values=p, n_modes=None if view.n_dofs <= 400 else 6).natural_frequencies_hz[:10]
        solver_used = ""
    updated = [n for n in prob.names if view.is_damping(n)]
    std = dict(zip(prob.names, map(float, diag.std)))
    damping = {"parameters": updated, "values": {n: float(p[view.parameter_index(n)]) for n in view.damping_names},
               "std": {n: (None if not np.isfinite(std[n]) else std[n]) for n in updated}, **extra}
    has_frf = any(b.kind == "frf" for b in prob.blocks)
    common = dict(
        parameters=dict(zip(view.parameter_names, map(float, p))), names=tuple(prob.names), x=p[prob.idx],
        success=bool(sol.success) if sol is not None else False, status=int(sol.status) if sol is not None else 0,
        message=str(sol.message) if sol is not None else "evaluated, not solved", cost=float(0.5 * r @ r), fun=r,
        jac=J, nfev=int(sol.nfev) if sol is not None else 1, njev=int(sol.njev or 0) if sol is not None else 0,
        iterations=max(len(history or []) - 1, int(sol.njev or 0) if sol is not None else 0), history=history or [],
        **paired, swaps=[], diagnostics=diag, regularization=reg or {},
        start=dict(zip(prob.names, map(float, prob.p_base[prob.idx]))),
        sensitivity=" + ".join((["complex modes (exact, state-space)"] if modal is not None else [])
                               + (["damped receptances (exact)"] if has_frf else [])),
        blocks=prob.block_costs(r) if len(prob.blocks) > 1 else [], notes=list(prob.notes) + diag.notes,
        formulation="damped" if modal is not None else "", solver=solver_used, damping=damping)
    if not has_frf:
        return UpdateResult(**common)
    fblocks = [b for b in prob.blocks if b.kind == "frf"]
    fp = fblocks[0].problem
    assert isinstance(fp, DampedFRFProblem)
    several = len(fblocks) > 1
    fracs: dict[str, float] = {}
    for b, fs in zip(fblocks, data.frf_sets):
        q = b.problem
        assert isinstance(q, DampedFRFProblem)
        exc = ", ".join(fs.force)
        fracs.update((f"{d} (excitation {exc})" if several else d, float(v))
                     for d, v in zip(fs.dofs, frac(q.xe, q.responses(x))))
    return FRFUpdateResult(**common, omega=fp.omega, skipped=[], residual=fp.kind, frac=fracs,
                           natural_frequencies_hz=natural)


__all__ = ["update_damped", "damped_problem", "damped_result", "damping_information"]
