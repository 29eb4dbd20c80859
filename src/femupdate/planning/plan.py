"""One entry point: :func:`plan`, a sensor plan for a model and the parameters to update."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

import numpy as np

from .._errors import InputError
from ..dofs import parse_dof
from ..modal import model_modes
from ..options import PlacementOptions, TargetOptions, gather
from .candidates import Candidates, candidates as make_candidates
from .classical import classical_placement
from .fisher import Design, Noise, SensitivityBank, parameter_points, prior_variances, rank_and_condition
from .placement import identifiability_placement, score_set
from .predict import automac, chain_positions, monte_carlo, predicted_std, uniqueness_verdict
from .result import PlanResult
from .targets import target_modes

COMPARED = ("identifiability", "efi", "kinetic")


def plan(model, *, params: Sequence[str] | None = None, candidates: Sequence[str] | None = None,
         fixed: Sequence[str] = (), box: Mapping[str, tuple[float, float]] | None = None,
         targets: TargetOptions | None = None, placement: PlacementOptions | None = None, values=None,
         compare: bool = True, **shorthand) -> PlanResult:
    """A test plan: target modes, sensors, and what they promise for the parameters.

    Parameters
    ----------
    model : Model
    params : sequence of str, optional
        The parameters the test is to identify (default: every parameter not fixed).
    candidates : sequence of str, optional
        Candidate dofs (uniaxial) or nodes (triaxial); default every translational dof (node).
    fixed : sequence of str
        Sensors always in the plan (dofs or nodes, as ``candidates``).
    box : mapping of str to (float, float), optional
        The parameter box of the random points (default the model's bounds, else ±50 %).
    targets : TargetOptions, optional
        The target modes (:class:`~femupdate.options.TargetOptions`; default the lowest 3).
    placement : PlacementOptions, optional
        The criterion, number and kind of sensors, noise, points, Monte Carlo
        (:class:`~femupdate.options.PlacementOptions`).
    values : optional
        Parameter values of the nominal model (default the model's).
    compare : bool, default True
        Also place the same number of sensors by the other criteria of :data:`COMPARED` and score them.
    **shorthand
        Fields of the option objects as keywords (``n_sensors=4``, ``criterion="efi"``, ``n_modes=3``).

    Returns
    -------
    PlanResult

    Raises
    ------
    InputError
        Unknown parameters or candidate dofs (named); more sensors asked than candidates; a
        parameter box with lower >= upper; zero noise; bad options.
    NumericalError
        An eigen-solution or sensitivity fails at a point of the box.
    """
    o = gather("plan", shorthand, targets=(TargetOptions, targets), placement=(PlacementOptions, placement))
    t_opt: TargetOptions = o["targets"]
    p_opt: PlacementOptions = o["placement"]
    if values is not None:
        model = model.with_values(values)
    names = list(params) if params is not None else [p.name for p in model.parameters if not p.fixed]
    model.parameter_indices(names, "params")
    if not names:
        raise InputError("params: no parameter to identify (every parameter is fixed)")
    cand = make_candidates(model, candidates, p_opt.kind, fixed)
    n_req = p_opt.n_sensors
    if n_req is not None and n_req > len(cand.sensors):
        raise InputError(f"sensors: {n_req} asked, but there are only {len(cand.sensors)} candidate "
                         f"{p_opt.kind} sensors")
    if n_req is not None and n_req < len(cand.fixed):
        raise InputError(f"sensors: {n_req} asked, fewer than the {len(cand.fixed)} fixed sensors")
    if p_opt.n_exciters > len(cand.dofs):
        raise InputError(f"exciters: {p_opt.n_exciters} asked, but there are {len(cand.dofs)} candidate driving points")
    n_lowest = t_opt.n_modes if t_opt.n_modes is not None else (3 if t_opt.method == "lowest" and t_opt.band_hz is None
                                                                else None)
    n_solve = min(model.n_dofs, max(20, 2 * (n_lowest or 10)))
    modes = model_modes(model, n_modes=n_solve)
    if t_opt.method == "lowest" and n_lowest is None:  # a band without a count: every mode in it
        n_lowest = int(np.sum((modes.frequencies_hz >= t_opt.band_hz[0]) & (modes.frequencies_hz <= t_opt.band_hz[1])))  # type: ignore[index]
    target = target_modes(model, modes, method=t_opt.method, n_modes=n_lowest, band_hz=t_opt.band_hz,
                          direction=t_opt.direction, min_fraction=t_opt.min_fraction, candidate_dofs=cand.dofs)
    noise = Noise(p_opt.std_eigenvalue, p_opt.std_shape)
    points, the_box = parameter_points(model, names, p_opt.points, box, p_opt.seed)
    banks = [SensitivityBank(model, cand.dofs, target.indices, names, points[0])]
    banks += [SensitivityBank(model, cand.dofs, target.indices, names, p, reference=banks[0].shapes_full)
              for p in points[1:]]
    groups = [cand.rows([i]) for i in range(len(cand.sensors))]
    prior_var = prior_variances(model, names) if p_opt.information_gain else None
    design = Design(p_opt.design, prior_var) if prior_var is not None else p_opt.design
    if p_opt.criterion == "identifiability":
        _rank_bound_met(model, names, cand.dofs, len(target.indices))
        _identifiable_at_all(banks[0], names, len(cand.dofs), len(target.indices))
    chosen, greedy, swaps = _place(p_opt.criterion, p_opt, model, cand, banks, groups, noise, n_req, design)
    rows = cand.rows(chosen)
    dofs = [cand.dofs[r] for r in rows]
    score = score_set(banks, rows, noise, design, p_opt.max_condition, p_opt.max_automac)
    std = predicted_std(banks[0], rows, noise)
    mac, mac_max = automac(banks[0], rows)
    nominal = dict(zip(names, banks[0].parameter_values.tolist()))
    comparison = {}
    if compare:
        for crit in COMPARED:
            if crit != p_opt.criterion:
                comparison[crit] = _compared(crit, p_opt, model, cand, banks, groups, noise, len(chosen), design)
    mc = None
    if p_opt.monte_carlo >= 2 and score.ranks[0] == len(names):
        mc = monte_carlo(model, names, dofs, banks[0], noise, p_opt.monte_carlo, p_opt.seed)
    nodes = {str(parse_dof(s[0])[0]): _xyz(model, parse_dof(s[0])[0]) for s in cand.sensors}
    return PlanResult(
        model=model.name, criterion=p_opt.criterion, sensor_kind=p_opt.kind,
        sensors=[list(cand.sensors[i]) for i in chosen], dofs=dofs, fixed=[list(cand.sensors[i]) for i in cand.fixed],
        target=target.to_dict(), parameters=names, nominal=nominal, box={k: list(v) for k, v in the_box.items()},
        noise={"eigenvalue": noise.eigenvalue, "shape": noise.shape}, design=p_opt.design, score=score.to_dict(),
        greedy=[list(cand.sensors[i]) for i in greedy], swaps=swaps,
        predicted_std=dict(zip(names, std.tolist())),
        relative_std={n: s / abs(v) if v else s for (n, v), s in zip(nominal.items(), std.tolist())},
        automac=mac, automac_max=mac_max, uniqueness=uniqueness_verdict(model, names, dofs, len(target.indices), score),
        comparison=comparison, monte_carlo=mc, nodes={k: v for k, v in nodes.items() if v is not None},
        options={"targets": t_opt.to_dict(), "placement": p_opt.to_dict()},
        prior=None if prior_var is None else dict(zip(names, np.sqrt(prior_var).tolist())),
        pretest=_pretest(model, p_opt, banks[0], [list(cand.sensors[i]) for i in chosen], dofs, target.indices),
        exciters=_exciters(p_opt, cand, banks, rows, design), segments=coupled_nodes(model))


def _place(criterion, p_opt, model, cand: Candidates, banks, groups, noise, n_req, design):
    """(chosen, greedy or eliminated set, swaps) of one criterion."""
    if criterion == "identifiability":
        ident = identifiability_placement(banks, groups, n_req, noise, fixed=cand.fixed, design=design,
                                          max_condition=p_opt.max_condition, restarts=p_opt.restarts, seed=p_opt.seed,
                                          max_passes=50 if p_opt.exchange else 0, max_automac=p_opt.max_automac,
                                          exhaustive_limit=p_opt.exhaustive_limit)
        return ident.chosen, ident.greedy, ident.swaps
    b = banks[0]
    m = b.phi.shape[1]
    n = n_req if n_req is not None else max(m, len(cand.fixed))
    if n > len(groups):
        raise InputError(f"sensors: {n} needed for {m} target modes, but there are only {len(groups)} candidate "
                         "sensors")
    rows = model.dof_index(list(cand.dofs), "candidates")
    energy = b.phi * (model.M(b.values) @ b.shapes_full)[rows]
    res = classical_placement(b.phi, groups, n, criterion, fixed=cand.fixed, eigenvalues=b.eigenvalues,
                              energy=energy, exchange=p_opt.exchange)
    return res.chosen, res.eliminated, res.swaps


def _rank_bound_met(model, names, dofs: Sequence[str], n_modes: int) -> None:
    """Refuse candidates too few for the rank bound, said with the bound: the m eigenvalues and the
    unit-scaled shapes at n dofs give at most m n independent rows (the counting criterion
    mn >= L), and on a grounded chain whose springs are the parameters the layout rank bound
    with every candidate measured (:func:`femupdate.uniqueness.chain.chain_rank_bound`) is exact."""
    from ..uniqueness.chain import chain_rank_bound

    n, m, L = len(dofs), n_modes, len(names)
    shown = ", ".join(dofs) if n <= 8 else ", ".join(dofs[:8]) + ", ..."
    if m * n < L:
        raise InputError(f"candidates: {n} candidate dof(s) ({shown}) with {m} target mode(s) bound the rank by "
                         f"mn = {m * n} < {L} parameters; the rank bound mn >= L needs at least {math.ceil(L / m)} "
                         "candidate dofs: add candidates or target modes, or fix some parameters")
    pos = chain_positions(model, names)
    if pos is not None:
        bound = chain_rank_bound(model.n_dofs, [pos[d] for d in dofs], m)
        if bound < L:
            raise InputError(f"candidates: with every candidate ({shown}) measured, the layout rank bound of this "
                             f"grounded chain is {bound} < {L} parameters from {m} target mode(s): add candidate "
                             "dofs (spread along the chain) or target modes, or fix some parameters")


def _identifiable_at_all(bank, names, n_rows: int, n_modes: int) -> None:
    """Refuse a problem no sensor set solves: with every candidate measured, S is still
    rank-deficient at the nominal point; the parameters of its null space are named."""
    S = bank.matrix(range(n_rows), normalised=True)
    rank, _, _ = rank_and_condition(S)
    if rank == len(names):
        return
    _, s, Vt = np.linalg.svd(S)
    null = Vt[rank:]
    weight = np.sqrt(np.sum(null ** 2, axis=0))
    involved = [n for n, w in zip(names, weight) if w > 1e-3]
    raise InputError(f"params: no sensor set identifies {', '.join(involved)} from these {n_modes} target mode(s): "
                     f"with every candidate measured the data determine only {rank} of the {len(names)} parameters' "
                     "combinations; add target modes or candidates, or fix some of them")


def _compared(crit, p_opt, model, cand, banks, groups, noise, n, design) -> dict:
    try:
        chosen, _, _ = _place(crit, p_opt, model, cand, banks, groups, noise, n, design)
    except InputError as exc:
        return {"error": str(exc)}
    rows = cand.rows(chosen)
    sc = score_set(banks, rows, noise, design, p_opt.max_condition, p_opt.max_automac)
    std = predicted_std(banks[0], rows, noise)
    rel = std / np.abs(banks[0].parameter_values)
    out = {"sensors": [list(cand.sensors[i]) for i in chosen], "identifiable": sc.identifiable,
           "rank": sc.ranks[0], "condition": sc.conditions[0], "mean_relative_std": float(np.mean(rel))}
    if p_opt.monte_carlo >= 2 and sc.ranks[0] == len(banks[0].parameter_values):  # the same noisy tests, this plan
        mc = monte_carlo(model, list(banks[0].parameter_names), [cand.dofs[r] for r in rows], banks[0], noise,
                         p_opt.monte_carlo, p_opt.seed)
        out["monte_carlo"] = {"runs": mc["runs"], "converged": mc["converged"],
                              "rms_relative_error": mc["rms_relative_error"]}
    return out


def _pretest(model, p_opt, bank, sensors, dofs, target) -> dict | None:
    """The TAM on the measured dofs and the mass loading of the sensors (:mod:`.pretest`); a TAM
    the dofs do not allow is reported, not raised."""
    from .pretest import mass_loading, tam

    if p_opt.tam == "none" and p_opt.sensor_mass == 0:
        return None
    out: dict = {}
    if p_opt.tam != "none":
        try:
            out["tam"] = tam(model, dofs, bank.shapes_full, bank.eigenvalues, p_opt.tam, bank.values)
        except InputError as exc:
            out["tam"] = {"method": p_opt.tam, "error": str(exc)}
    if p_opt.sensor_mass > 0:
        out["mass_loading"] = mass_loading(model, sensors, p_opt.sensor_mass, target, bank.values)
    return out


def _exciters(p_opt, cand: Candidates, banks, rows, design) -> dict | None:
    """The exciters of an FRF test for the chosen sensors (:mod:`.exciters`)."""
    if p_opt.n_exciters == 0:
        return None
    from .exciters import driving_point_criteria, exciter_placement

    ex = exciter_placement(banks, rows, p_opt.n_exciters, std_frf=p_opt.std_frf, damping_ratio=p_opt.damping_ratio,
                           design=design, max_condition=p_opt.max_condition)
    crit = driving_point_criteria(banks[0])
    order = np.argsort(-crit["odp"], kind="stable")
    return {"dofs": [cand.dofs[r] for r in ex.chosen], "greedy": [cand.dofs[r] for r in ex.greedy],
            "excites_all_modes": ex.excites_all, "score": ex.score.to_dict(), "swaps": ex.swaps,
            "noise_floor": ex.noise_floor, "std_frf": p_opt.std_frf, "damping_ratio": p_opt.damping_ratio,
            "driving_points": {cand.dofs[r]: {"odp": float(crit["odp"][r]), "nodp": float(crit["nodp"][r]),
                                              "dpr": float(crit["dpr"][r])} for r in order},
            "best_odp": cand.dofs[int(order[0])]}


def coupled_nodes(model) -> list[list[str]]:
    """Pairs of distinct nodes the stiffness matrices couple (the elements' edges, to draw the
    layout on the structure), as node ids."""
    import scipy.sparse as sp

    node_of = [str(parse_dof(d)[0]) for d in model.dofs]
    pattern = abs(sp.coo_array(model.K0))
    for A in (*model.dK, *(t.K for t in getattr(model, "terms", ()))):  # non-linear terms too
        if A is not None:
            pattern = pattern + abs(sp.coo_array(A))
    coo = sp.coo_array(pattern)
    pairs = {tuple(sorted((node_of[r], node_of[c]), key=_node_key)) for r, c in zip(coo.row, coo.col)
             if node_of[r] != node_of[c]}
    return [list(p) for p in sorted(pairs, key=lambda p: (_node_key(p[0]), _node_key(p[1])))]


def _node_key(n: str):
    return (0, int(n), "") if n.lstrip("-").isdigit() else (1, 0, n)


def _xyz(model, node):
    for key in (node, str(node)):
        if key in model.nodes:
            return [float(v) for v in model.nodes[key]]
    return None


__all__ = ["plan", "COMPARED"]
