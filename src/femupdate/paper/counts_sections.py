"""Paper sections on the number of unknowns and on what data identify them: the parameter counts
(N², N(N+1)/2, 2N − 1, physical), Su & Juang's (1992) sensor/actuator criteria, and
identification from static deflections (Lallement et al. 1992).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .._errors import InputError
from ..direct import direct_update
from ..examples import FIGURE1_MASS, FIGURE1_STIFFNESS, FIGURE2_K4, chain, three_dof
from ..testdata import StaticData, TestData

ORDER = 12
PAPER_COUNTS = {"full": 9, "symmetric": 6, "connectivity": 5, "physical": 3}  # the paper's N = 3 values


def _counts(model) -> dict:
    """Unknowns of a stiffness matrix at each level of structure, counted from the model itself."""
    N = model.n_dofs
    pattern = np.zeros((N, N), dtype=bool)
    for j in range(len(model.parameters)):
        pattern |= model.dK_dp(j).toarray() != 0
    return {"N": N, "full": N * N, "symmetric": N * (N + 1) // 2,
            "connectivity": int(np.count_nonzero(np.triu(pattern))), "physical": len(model.parameters)}


def parameter_counts(out_dir, figures=True) -> dict:
    rows = {"Figure 1 (N = 3)": _counts(three_dof()), "Figure 2 (N = 3, k4 joins 1 and 3)": _counts(three_dof(k4=FIGURE2_K4))}
    for N in (6, 10, 100):
        rows[f"chain N = {N}"] = _counts(chain([1000.0] * N, [1.0] * N))
    f1 = rows["Figure 1 (N = 3)"]
    formula_ok = all(r["connectivity"] == 2 * r["N"] - 1 for k, r in rows.items() if k.startswith(("Figure 1", "chain")))
    agree = bool(all(f1[k] == v for k, v in PAPER_COUNTS.items()) and formula_ok
                 and rows["Figure 2 (N = 3, k4 joins 1 and 3)"]["connectivity"] == 6)
    out = {
        "equations": "text before eq. 1 (Figures 1 and 2)",
        "description": "unknowns of the stiffness matrix: every entry (N²), symmetric (N(N+1)/2), symmetric with the "
                       "connectivity enforced (the non-zeros of the upper triangle: 2N - 1 for a chain) and physical "
                       "(the springs); counted from femupdate's models, not from the formulas",
        "rows": rows,
        "paper": {"N": 3, **PAPER_COUNTS, "figure2": "K(1,3) no longer 0 (one more connectivity entry), 4 springs"},
        "agrees_with_paper": agree, "comparison": "agree" if agree else "differ-explained",
        "explanation": "the counts of the Figure 1 chain are the paper's 9, 6, 5 and 3; Figure 2's direct connection "
                       "adds the K(1,3) entry (6) and a fourth spring; the connectivity count stays 2N - 1 for chains "
                       "of any length, so it grows linearly while N² and N(N+1)/2 grow quadratically (N = 100: "
                       f"{rows['chain N = 100']['full']}, {rows['chain N = 100']['symmetric']}, "
                       f"{rows['chain N = 100']['connectivity']}, {rows['chain N = 100']['physical']})",
        "summary": "N = 3: " + ", ".join(f"{k} {f1[k]}" for k in PAPER_COUNTS) + " (paper 9, 6, 5, 3); N = 100: "
                   + ", ".join(f"{k} {rows['chain N = 100'][k]}" for k in PAPER_COUNTS),
    }
    if figures:
        from ..plot.paper_figures import grouped_bars_figure

        out["figure"] = grouped_bars_figure(out_dir / "parameter_counts.png",
                                            {k: {name: r[k] for name, r in rows.items()} for k in PAPER_COUNTS},
                                            ylabel="unknowns", title="unknowns of the stiffness matrix", log=True)
    return out


# --------------------------------------------------------------------------- Su & Juang
def receptance_rank(K, M, sensors, actuators, symmetric: bool, mass_known: bool, omega) -> tuple[int, int]:
    """Rank of the Jacobian of the measured receptances C (K - w² M)^-1 B with respect to the
    entries of K (all N², or the N(N+1)/2 of a symmetric K) and, when ``mass_known`` is False, the
    N(N+1)/2 entries of a symmetric M; each line's block scaled to unit norm.  Returns (rank, unknowns)."""
    N = K.shape[0]
    C, B = np.eye(N)[list(sensors)], np.eye(N)[:, list(actuators)]
    basis = []
    for i in range(N):
        for j in range(i if symmetric else 0, N):
            E = np.zeros((N, N))
            E[i, j] = 1.0
            if symmetric:
                E[j, i] = 1.0
            basis.append(("K", E))
    if not mass_known:
        for i in range(N):
            for j in range(i, N):
                E = np.zeros((N, N))
                E[i, j] = E[j, i] = 1.0
                basis.append(("M", E))
    blocks = []
    for w in omega:
        G = np.linalg.inv(K - w**2 * M)
        Jw = np.array([(-C @ G @ (E if t == "K" else -(w**2) * E) @ G @ B).ravel() for t, E in basis]).T
        blocks.append(Jw / np.linalg.norm(Jw))
    J = np.vstack(blocks)
    s = np.linalg.svd(J, compute_uv=False)
    return int(np.sum(s > s[0] * max(J.shape) * np.finfo(float).eps)), len(basis)


def su_juang_criteria(out_dir, figures=True, N: int = 4, seed: int = 1992) -> dict:
    rng = np.random.default_rng(seed)
    A = rng.standard_normal((N, N))
    K = A @ A.T + N * np.eye(N)  # a generic symmetric positive definite stiffness (every entry unknown)
    M = np.diag(rng.uniform(1.0, 2.0, N))
    import scipy.linalg as sl

    lam = sl.eigh(K, M, eigvals_only=True)
    omega = np.sqrt(np.linspace(0.05, 0.95, 3 * N) * lam.min())  # every mode is in every line's receptance
    variants = {"general K, M known": (False, True), "symmetric K, M known": (True, True),
                "symmetric K and M": (True, False)}
    placements = {"collocated (sensors 1..s, actuators 1..a)": lambda s, a: (range(s), range(a)),
                  "opposite ends (sensors 1..s, actuators N-a+1..N)": lambda s, a: (range(s), range(N - a, N))}
    tables: dict = {}
    for vname, (sym, known) in variants.items():
        tables[vname] = {}
        for pname, place in placements.items():
            grid = {}
            for s in range(1, N + 1):
                for a in range(1, N + 1):
                    r, L = receptance_rank(K, M, *place(s, a), sym, known, omega)
                    grid[f"{s}x{a}"] = {"sensors": s, "actuators": a, "rank": r, "unknowns": L, "identifiable": r == L}
            tables[vname][pname] = grid

    def matches(grid, rule):
        return all(v["identifiable"] == rule(v["sensors"], v["actuators"]) for v in grid.values())

    general = all(matches(g, lambda s, a: s >= N or a >= N) for g in tables["general K, M known"].values())
    sym_rule = {v: {p: matches(g, lambda s, a: s + a >= N) for p, g in tables[v].items()}
                for v in ("symmetric K, M known", "symmetric K and M")}
    # as a necessary condition (every identifiable plan has s + a >= N) and as a sufficient one
    sym_nec = {v: {p: all(c["sensors"] + c["actuators"] >= N for c in g.values() if c["identifiable"])
                   for p, g in tables[v].items()} for v in sym_rule}
    sym_suf = {v: {p: all(c["identifiable"] for c in g.values() if c["sensors"] + c["actuators"] >= N)
                   for p, g in tables[v].items()} for v in sym_rule}
    agree = bool(general and all(all(d.values()) for d in sym_rule.values()))
    explanation = (
        f"Local identifiability of every stiffness entry from FRFs (which carry all N = {N} modes, Su & Juang's "
        "assumption), as the rank of the receptance Jacobian. General K: identifiable exactly when sensors or "
        f"actuators number N ({'reproduced' if general else 'NOT reproduced'} in every placement). Symmetric K: the "
        "rule sensors + actuators >= N is "
        + "; ".join(f"{v}, {p.split(' (')[0]}: " + ("exact" if sym_rule[v][p] else
                                                    "necessary but not sufficient" if sym_nec[v][p] else
                                                    "sufficient but not necessary" if sym_suf[v][p] else "neither")
                    for v in sym_rule for p in sym_rule[v])
        + ". Where it is not exact, the count depends on where the actuators sit relative to the sensors (collocated pairs "
        "give a symmetric block, so fewer independent data) and on whether M is known: with M known and the "
        "actuators away from the sensors fewer than N transducers in all suffice; with M unknown and collocated "
        "transducers N sensors or N actuators are needed. The paper quotes the criteria without these conditions.")
    out = {
        "description": f"generic symmetric positive definite K and diagonal M (N = {N}, seed {seed}); receptances at "
                       f"{len(omega)} lines below the first resonance (each contains every mode); unknowns: every entry "
                       "of K (N²), or of a symmetric K (N(N+1)/2), plus a symmetric M when M is unknown",
        "tables": tables,
        "general_criterion_reproduced": general,
        "symmetric_criterion_reproduced": sym_rule,
        "symmetric_criterion_necessary": sym_nec,
        "symmetric_criterion_sufficient": sym_suf,
        "paper": {"general": "sensors >= N or actuators >= N", "symmetric": "sensors + actuators >= N",
                  "assumption": "number of measured modes = N"},
        "agrees_with_paper": agree, "comparison": "agree" if agree else "differ-explained", "explanation": explanation,
        "summary": f"general K: sensors or actuators >= N {'reproduced' if general else 'not reproduced'}; symmetric "
                   "K, sum >= N: " + "; ".join(f"{v}: " + "/".join("exact" if sym_rule[v][p] else "necessary" if sym_nec[v][p]
                                                                else "sufficient" if sym_suf[v][p] else "neither"
                                                                for p in sym_rule[v])
                                              for v in sym_rule) + " (collocated/opposite)",
    }
    if figures:
        from ..plot.paper_figures import identifiability_grids_figure

        out["figure"] = identifiability_grids_figure(out_dir / "su_juang_criteria.png", tables, N)
    return out


# --------------------------------------------------------------------------- static deflections
def static_deflections(out_dir, figures=True, noise: float = 0.01, reps: int = 200, seed: int = 1992) -> dict:
    t1 = three_dof()
    K = t1.K().toarray()
    f = np.array([0.0, 0.0, 1000.0])  # N at dof 3, the paper's example
    u = np.linalg.solve(K, f)
    # equilibrium by hand (the paper's argument): spring i carries the load beyond it
    by_hand = [f.sum() / u[0], f[1:].sum() / (u[1] - u[0]), f[2] / (u[2] - u[1])]
    case = StaticData({"3:x": 1000.0}, t1.dofs, u)
    res = direct_update(t1.with_values(t1.values * 0.5), TestData(static=(case,)))
    err = float(np.max(np.abs(res.x / t1.values - 1)))
    rng = np.random.default_rng(seed)
    noisy = []
    for _ in range(reps):
        un = u * (1 + noise * rng.standard_normal(3))
        r = direct_update(t1, TestData(static=(StaticData({"3:x": 1000.0}, t1.dofs, un),)))
        noisy.append(np.abs(r.x / t1.values - 1))
    noisy_arr = np.array(noisy)
    # Figure 2 (4 springs): one load case gives 3 equations, two recover k1..k4
    t2 = three_dof(k4=FIGURE2_K4)
    K2 = t2.K().toarray()
    cases = [StaticData({d: 1000.0}, t2.dofs, np.linalg.solve(K2, 1000.0 * np.eye(3)[i]))
             for i, d in ((2, "3:x"), (1, "2:x"), (0, "1:x"))]
    try:
        direct_update(t2, TestData(static=tuple(cases[:1])))
        one: dict[str, Any] = {"solved": True}
    except InputError as exc:
        one = {"solved": False, "message": str(exc)}
    r2 = direct_update(t2.with_values(t2.values * 0.5), TestData(static=tuple(cases[:2])))
    err2 = float(np.max(np.abs(r2.x / t2.values - 1)))
    r13 = direct_update(t2.with_values(t2.values * 0.5), TestData(static=(cases[0], cases[2])))
    agree = bool(err < 1e-12 and np.allclose(by_hand, FIGURE1_STIFFNESS, rtol=1e-12) and not one["solved"] and err2 < 1e-12)
    # with loads at dofs 3 and 1 only, dof 2 is unloaded in both cases and the equations are rank 3
    loop = r13.rank < 4
    out = {
        "equations": "text after eq. 5 (Lallement et al. 1992)",
        "description": "Figure 1 chain (k = (1000, 2000, 1500) N/m) under 1000 N at dof 3, displacements at every dof: "
                       "the springs from equilibrium by hand and from femupdate's direct solution with static data; "
                       f"{noise:.0%} displacement noise ({reps} seeded repetitions); Figure 2 (k4 = 500 N/m) from one "
                       "and from two load cases (dof 3, dof 1)",
        "force": {"3:x": 1000.0},
        "displacements_m": u, "by_hand": by_hand, "direct": res.x, "max_relative_error": err,
        "noise": {"level": noise, "rms_relative_error": np.sqrt(np.mean(noisy_arr**2, axis=0)),
                  "condition_number": res.condition_number},
        "figure2": {"one_load_case": one,
                    "loads_at_3_and_2": {"k": r2.x, "max_relative_error": err2, "rank": r2.rank,
                                         "condition_number": r2.condition_number},
                    "loads_at_3_and_1": {"k": r13.x, "rank": r13.rank, "unique": r13.unique,
                                         "condition_number": r13.condition_number}},
        "system": {"k": FIGURE1_STIFFNESS, "m": FIGURE1_MASS},
        "paper": {"claim": "if the system is statically deformed by a known force at the third degree of freedom, "
                           "knowledge of the displacements at each degree-of-freedom is sufficient to determine each "
                           "spring stiffness"},
        "agrees_with_paper": agree, "comparison": "agree" if agree else "differ-explained",
        "explanation": "one static load case with every dof measured fixes the three springs of Figure 1 exactly, by "
                       "equilibrium and by the direct solution; like one mode for Figure 2 (figure2_direct), one load "
                       "case gives 3 equations for 4 springs and is refused; a second load case at dof 2 recovers all "
                       "four" + (f", but one at dof 1 does not (rank {r13.rank}): dof 2 is then unloaded in both cases, and "
                                 "its equilibrium equation is the same ratio k2 : k3 twice, so the equations lose rank - "
                                 "the paper's 'sufficient' holds per load case count, not "
                                 "for any choice of loads" if loop else ""),
        "summary": f"force 1000 N at 3:x: k = {np.round(res.x, 6).tolist()} (error {err:.0e}); {noise:.0%} noise -> RMS "
                   f"error {', '.join(f'{v:.1%}' for v in np.sqrt(np.mean(noisy_arr**2, axis=0)))}; Figure 2: one load "
                   f"case {'refused' if not one['solved'] else 'solved?'}, loads at 3 and 2 recover k1..k4 ({err2:.0e}), at 3 and 1 "
                   f"rank {r13.rank}",
    }
    return out


SECTIONS = {"parameter_counts": parameter_counts, "su_juang_criteria": su_juang_criteria,
            "static_deflections": static_deflections}
