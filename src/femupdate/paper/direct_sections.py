"""Paper sections of the direct (complete-data) solutions: eqs. 1-12 and 23-29."""

from __future__ import annotations

from typing import Any

import numpy as np

from .._errors import InputError
from ..direct import direct_update
from ..examples import FIGURE1_MASS, FIGURE1_STIFFNESS, FIGURE2_K4, three_dof, two_dof
from ..modal import model_modes
from ..testdata import FRFData, MeasuredMode, TestData

REL_TOL = 1e-9


def _start(model, factor=0.5):
    """Same model at deliberately wrong starting values (the direct solution ignores them)."""
    return model.with_values(model.values * factor)


def paper_phi_matrix(phi: np.ndarray) -> np.ndarray:
    """The paper's eq. (4) matrix Φ_i for the Figure 1 chain, written out by hand."""
    p1, p2, p3 = phi
    return np.array([[p1, p1 - p2, 0.0], [0.0, -p1 + p2, p2 - p3], [0.0, 0.0, -p2 + p3]])


def eq5_direct_three_dof(out_dir, figures=True) -> dict:
    truth = three_dof()
    modes = model_modes(truth, normalisation="ref:1:x")
    k_true = truth.values
    per_mode = []
    ok = True
    for i in range(3):
        phi, lam = modes.shapes[:, i], modes.eigenvalues[i]
        Phi = paper_phi_matrix(phi)
        k5 = lam * np.linalg.solve(Phi, truth.M().toarray() @ phi)  # eq. (5) literally
        res = direct_update(_start(truth), TestData(modes=(MeasuredMode(lam, truth.dofs, phi),)))
        ours = res.system.A * np.linalg.norm(phi)  # our rows K_j phi, shape unit-normalised
        same_matrix = bool(np.allclose(ours, Phi, rtol=1e-12, atol=1e-12 * np.abs(Phi).max()))
        err5 = float(np.max(np.abs(k5 - k_true) / k_true))
        err = float(np.max(np.abs(res.x - k_true) / k_true))
        ok &= same_matrix and err5 < REL_TOL and err < REL_TOL
        per_mode.append({"mode": i + 1, "eigenvalue": lam, "shape": phi, "Phi_i": Phi,
                         "k_eq5": k5, "k_femupdate": res.x, "condition_number": res.condition_number,
                         "rows_equal_eq4": same_matrix, "max_relative_error": max(err, err5)})
    return {
        "equations": "1-5",
        "description": "Figure 1 three-dof chain, every dof measured, ONE mode: k = λ_i Φ_i^-1 M φ_i (eq. 5) "
                       "recovers k1..k3 from any single mode",
        "system": {"k": FIGURE1_STIFFNESS, "m": FIGURE1_MASS,
                   "note": "the paper gives no numbers for Figure 1; these values are femupdate's choice"},
        "modes": per_mode,
        "agrees_with_paper": bool(ok),
        "summary": f"k = {np.round(per_mode[0]['k_femupdate'], 6).tolist()} from mode 1 alone; "
                   f"all 3 modes each recover k (max rel. error {max(m['max_relative_error'] for m in per_mode):.1e})",
    }


def figure2_direct(out_dir, figures=True) -> dict:
    truth = three_dof(k4=FIGURE2_K4)
    modes = model_modes(truth)
    start = _start(truth)
    mm = [MeasuredMode(modes.eigenvalues[i], truth.dofs, modes.shapes[:, i], f"mode {i + 1}") for i in range(3)]
    one: dict[str, bool | str]
    try:
        direct_update(start, TestData(modes=(mm[0],)))
        one = {"solved": True}
    except InputError as exc:
        one = {"solved": False, "message": str(exc)}
    cases: list[dict[str, Any]] = []
    ok = not one["solved"]
    for sel in ((0, 1), (0, 2), (1, 2), (0, 1, 2)):
        res = direct_update(start, TestData(modes=tuple(mm[i] for i in sel)))
        err = float(np.max(np.abs(res.x - truth.values) / truth.values))
        ok &= err < REL_TOL and res.unique
        cases.append({"modes": [i + 1 for i in sel], "k": res.x, "condition_number": res.condition_number,
                      "rank": res.rank, "max_relative_error": err})
    return {
        "equations": "6-10",
        "description": "Figure 2 (k4 joins dofs 1 and 3): 4 unknowns, 3 equations per mode, so one mode is not enough; "
                       "two or more modes stacked and solved with the pseudo-inverse (eq. 10) recover k1..k4",
        "system": {"k": list(FIGURE1_STIFFNESS) + [FIGURE2_K4], "m": FIGURE1_MASS,
                   "K": truth.K().toarray(), "note": "values chosen by femupdate (the paper gives none)"},
        "one_mode": one,
        "stacked": cases,
        "agrees_with_paper": bool(ok),
        "summary": f"one mode: {'refused (3 equations < 4 unknowns)' if not one['solved'] else 'solved?'}; "
                   f"modes 1+2: k = {np.round(cases[0]['k'], 6).tolist()}",
    }


def paper_X_block(x: np.ndarray) -> np.ndarray:
    """Eq. (25): X_i = [[x1, x1 - x2], [0, -x1 + x2]] for the two-dof chain."""
    x1, x2 = x
    return np.array([[x1, x1 - x2], [0.0, -x1 + x2]])


def eq29_frf_direct_two_dof(out_dir, figures=True) -> dict:
    truth = two_dof()
    K, M = truth.K().toarray(), truth.M().toarray()
    f = np.array([0.0, 1.0])
    omega = 0.5 + 0.5 * np.arange(5)
    X = np.array([np.linalg.solve(K - w**2 * M, f) for w in omega])  # (n_freq, 2)
    start = _start(truth)
    # eq. (26): one spectral line
    single = []
    ok = True
    for i, w in enumerate(omega):
        Xi = paper_X_block(X[i])
        cond = float(np.linalg.cond(Xi))
        entry = {"omega_rad_s": w, "X_i": Xi, "condition_number": cond}
        if cond < 1e12:
            k26 = np.linalg.solve(Xi, f + w**2 * M @ X[i])
            ok &= bool(np.allclose(k26, truth.values, rtol=1e-8))
            entry["k"] = k26
        else:
            # X_i is singular when x1 = x2, i.e. at w^2 = k1/m1 (the spring k2 is then unstrained)
            entry["k"] = None
            entry["note"] = "X_i singular: x1 = x2 here (w^2 = k1/m1), so k2 is not seen by this line alone"
            ok &= bool(np.isclose(w**2, 8.0 / 2.0))
        single.append(entry)
    data = TestData(frf=FRFData(omega, {"2:x": 1.0}, truth.dofs, X))
    res = direct_update(start, data)
    Xpaper = np.vstack([paper_X_block(x) for x in X])
    same = bool(np.allclose(res.system.A, Xpaper, rtol=1e-12, atol=1e-15))
    err = float(np.max(np.abs(res.x - truth.values) / truth.values))
    ok &= same and err < REL_TOL
    return {
        "equations": "23-29",
        "description": "two-dof chain (m1=2, m2=4, k1=8, k2=6), unit force at dof 2, receptances at both dofs; "
                       "each line alone solves eq. 26; five lines 0.5 rad/s apart stacked solve eq. 29",
        "force": {"2:x": 1.0},
        "omega_rad_s": omega,
        "single_line": single,
        "stacked": {"X": res.system.A, "rows_equal_eq27": same, "k": res.x,
                    "condition_number": res.condition_number, "residual_norm": res.residual_norm},
        "agrees_with_paper": bool(ok),
        "summary": f"unit force at 2:x: k = {np.round(res.x, 9).tolist()}, cond(X) = {res.condition_number:.3g}",
        "notes": ["eq. 27's last block prints x_{1,2}, x_{2,2}; it is the N-th line x_{1,N}, x_{2,N}"],
    }


def two_dof_inverse(a1: float, a0: float, m1: float, m2: float) -> list[tuple[float, float]]:
    """All real (k1, k2) with m2 k1 + (m1 + m2) k2 = a1 and k1 k2 = a0 (eqs. 11-12).

    Eliminating k2 gives m2 k1^2 - a1 k1 + a0 (m1 + m2) = 0, solved in closed form.
    """
    disc = a1**2 - 4.0 * m2 * a0 * (m1 + m2)
    if disc < 0:
        return []
    roots = sorted({(a1 - np.sqrt(disc)) / (2.0 * m2), (a1 + np.sqrt(disc)) / (2.0 * m2)})
    return [(float(k1), float((a1 - m2 * k1) / (m1 + m2))) for k1 in roots]


def characteristic_2x2(K: np.ndarray, M: np.ndarray) -> tuple[float, float, float]:
    """det(K - λM) = a2 λ² - a1 λ + a0 for 2x2 matrices (eq. 11), term by term."""
    a2 = M[0, 0] * M[1, 1] - M[0, 1] * M[1, 0]
    a1 = K[0, 0] * M[1, 1] + K[1, 1] * M[0, 0] - K[0, 1] * M[1, 0] - K[1, 0] * M[0, 1]
    a0 = K[0, 0] * K[1, 1] - K[0, 1] * K[1, 0]
    return float(a2), float(a1), float(a0)


def two_dof_characteristic(out_dir, figures=True) -> dict:
    m1, m2 = 2.0, 4.0
    truth = two_dof()
    K, M = truth.K().toarray(), truth.M().toarray()
    a2, a1, a0 = characteristic_2x2(K, M)
    lam = model_modes(truth).eigenvalues
    # second route: a1 = a2 (λ1 + λ2) and a0 = a2 λ1 λ2 from the eigensolution
    from_eigs = {"a1": float(a2 * lam.sum()), "a0": float(a2 * lam.prod())}
    sols = two_dof_inverse(a1, a0, m1, m2)
    check = []
    for k1, k2 in sols:
        ev = model_modes(truth, {"k1": k1, "k2": k2}).eigenvalues
        check.append({"k1": k1, "k2": k2, "eigenvalues": ev, "same_eigenvalues": bool(np.allclose(ev, lam, rtol=1e-12))})
    paper: dict[str, Any] = {"a2": 8, "a1": 68, "a0": 48, "solutions": [[8, 6], [9, 16 / 3]]}
    ok = (np.allclose([a2, a1, a0], [8, 68, 48], rtol=1e-12) and len(sols) == 2
          and np.allclose([from_eigs["a1"], from_eigs["a0"]], [a1, a0], rtol=1e-12)
          and np.allclose(sols, paper["solutions"], rtol=1e-12) and all(c["same_eigenvalues"] for c in check))
    out = {
        "equations": "11-12",
        "description": "two-dof chain m1=2, m2=4, k1=8, k2=6: characteristic equation λ²a2 - λa1 + a0 = 0; "
                       "two stiffness sets give the same eigenvalues, so frequencies alone do not identify k1, k2",
        "a2": a2, "a1": a1, "a0": a0,
        "from_eigenvalues": from_eigs,
        "eigenvalues": lam,
        "solutions": check,
        "paper": paper,
        "agrees_with_paper": bool(ok),
        "summary": f"a2={a2:.6g}, a1={a1:.6g}, a0={a0:.6g}; (k1, k2) = " + ", ".join(f"({k1:.6g}, {k2:.6g})" for k1, k2 in sols),
    }
    if figures:
        from ..plot.paper_figures import characteristic_curves

        out["figure"] = characteristic_curves(out_dir / "two_dof_characteristic.png", a1, a0, m1, m2, sols)
    return out


ORDER = 10
SECTIONS = {"eq5_direct_three_dof": eq5_direct_three_dof, "figure2_direct": figure2_direct, "eq29_frf_direct_two_dof": eq29_frf_direct_two_dof, "two_dof_characteristic": two_dof_characteristic}
