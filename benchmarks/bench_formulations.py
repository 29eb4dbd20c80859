"""The formulations of the modal residuals compared (``--formulation``; docs/cli.md, *Formulations*).

1. The MAC term in three forms, on a grounded 6-dof chain (six stiffnesses, truth K6) measured
   at every dof in its three lowest modes, from the same start: the residual femupdate uses
   (``mac``: the vector (I − ê êᵀ) â, squared norm 1 − MAC), the scalar 1 − MAC and the scalar
   √(1 − MAC), each with its eigenvalue residuals and an exact Jacobian (the scalar forms'
   from the vector's: ∂(1 − MAC) = 2 rᵀ∂r, ∂√(1 − MAC) = rᵀ∂r / ‖r‖).
2. ``shapes``, ``mac`` and ``dynamic`` on noisy data (the chain measured at dofs 2, 4, 6 in four
   modes; 0.5 % noise on the frequencies, 1 % on the unit shapes; 50 seeds): the error of the
   updated stiffnesses, evaluations and time.

    python benchmarks/bench_formulations.py
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "src"))

from femupdate import MeasuredMode, TestData, model_modes  # noqa: E402
from femupdate.examples import chain  # noqa: E402
from femupdate.updating import Problem, update  # noqa: E402
from femupdate.updating.solve import solve_problem  # noqa: E402

K6 = np.array([1000.0, 1800.0, 1500.0, 1200.0, 900.0, 1600.0])
M6 = np.array([1.0, 1.2, 0.8, 1.1, 0.9, 1.0])
START = K6 * [0.8, 1.2, 0.9, 1.1, 1.05, 0.95]


def modes(truth, dofs, n, noise_f=0.0, noise_psi=0.0, rng=None):
    mm = model_modes(truth, n_modes=n + 2)
    pos = truth.dof_index(dofs)
    out = []
    for r in range(n):
        psi = mm.shapes[pos, r] / np.linalg.norm(mm.shapes[pos, r])
        lam = mm.eigenvalues[r]
        if rng is not None:
            lam *= (1 + noise_f * rng.standard_normal()) ** 2
            psi = psi + noise_psi * rng.standard_normal(psi.size)
        out.append(MeasuredMode(lam, tuple(dofs), psi))
    return TestData(out)


class ScalarMac:
    """Eigenvalue residuals and one MAC residual per mode: 1 − MAC, or √(1 − MAC) (the rest of a
    ``mac`` :class:`Problem`)."""

    def __init__(self, model, data, root: bool):
        self.mac = Problem(model, data, formulation="mac")
        self.root = root
        ns = np.diff(self.mac.targets.pptr)
        self._split = np.cumsum(1 + ns)[:-1]
        self.n_residuals = 2 * self.mac.targets.n_test

    def __getattr__(self, name):
        return getattr(self.mac, name)

    def residuals(self, x):
        out = []
        for b in np.split(self.mac.residuals(x), self._split):
            q = float(b[1:] @ b[1:])  # 1 − MAC
            out += [b[0], np.sqrt(q) if self.root else q]
        return np.array(out)

    def jacobian(self, x):
        r = np.split(self.mac.residuals(x), self._split)
        J = np.split(self.mac.jacobian(x), self._split)
        rows = []
        for b, Jb in zip(r, J):
            g = 2 * b[1:] @ Jb[1:]
            rows += [Jb[0], g / (2 * np.linalg.norm(b[1:])) if self.root else g]
        return np.array(rows)


def mac_forms(n_modes: int) -> None:
    truth = chain(K6, M6)
    data = modes(truth, [f"{i}:x" for i in range(1, 7)], n_modes)
    model = chain(START, M6)
    print(f"MAC term, 6-dof chain, {n_modes} modes at every dof, 6 stiffnesses")
    print(f"{'form':<14}{'residuals':>10}{'evaluations':>12}{'max error':>12}{'rank':>6}{'condition':>12}")
    for name, prob in (("vector (mac)", Problem(model, data, formulation="mac")),
                       ("1 - MAC", ScalarMac(model, data, root=False)),
                       ("sqrt(1 - MAC)", ScalarMac(model, data, root=True))):
        res = solve_problem(prob, regularization=None if prob.n_residuals >= 6 else 0.0)
        d = res.diagnostics
        print(f"{name:<14}{prob.n_residuals:>10}{res.nfev:>12}{np.abs(res.x / K6 - 1).max():>12.2e}{d.rank:>4}/6"
              f"{d.condition_number:>12.3g}")


def noisy(seeds: int = 50) -> None:
    truth = chain(K6, M6, bounds=(100.0, 5000.0))
    model = chain(START, M6, bounds=(100.0, 5000.0))
    print(f"\nnoisy data, 6-dof chain, 4 modes at dofs 2, 4, 6 (0.5 % on f, 1 % on shapes), {seeds} seeds")
    print(f"{'formulation':<12}{'RMS error':>11}{'max error':>11}{'evaluations':>13}{'ms/solve':>10}")
    for form in ("shapes", "mac", "dynamic"):
        errs, nfev, t = [], [], 0.0
        for seed in range(seeds):
            data = modes(truth, ["2:x", "4:x", "6:x"], 4, 0.005, 0.01, np.random.default_rng(seed))
            t0 = time.perf_counter()
            res = update(model, data, formulation=form)
            t += time.perf_counter() - t0
            errs.append(res.x / K6 - 1)
            nfev.append(res.nfev)
        e = np.array(errs)
        print(f"{form:<12}{np.sqrt(np.mean(e ** 2)):>10.2%}{np.abs(e).max():>10.2%}{np.mean(nfev):>13.1f}"
              f"{1e3 * t / seeds:>10.1f}")


if __name__ == "__main__":
    mac_forms(3)
    mac_forms(2)
    noisy()
