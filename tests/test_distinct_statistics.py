"""Distinct solutions by statistics (issue 27 item 4): two solutions are distinct only when they
differ significantly against their own covariances; an ill-conditioned but unique case is one
solution with a ± statement, separated exact solutions stay separate, and one minimum is split in
about α of noisy repetitions, no more than the binomial 99 % band allows."""

import tempfile
from pathlib import Path

import numpy as np
import pytest
from scipy.stats import binom, chi2

from femupdate import MeasuredMode, TestData, model_modes, update
from femupdate.distinct import cluster, compare, conditioning, significant
from femupdate.examples import two_dof
from femupdate.io.model_file import load_model
from femupdate.updating import multistart

from conftest import HEAVY, heavy  # noqa: E402

SERIES = """
[model]
name = "two springs in series"
[parameters.k1]
value = 100.0
bounds = [20.0, 500.0]
[parameters.k2]
value = 100.0
bounds = [20.0, 500.0]
[[element]]
type = "spring"
dofs = ["1:x"]
k = "k1"
[[element]]
type = "spring"
dofs = ["1:x", "2:x"]
k = "k2"
[[element]]
type = "mass"
dofs = ["1:x"]
m = 0.01
[[element]]
type = "mass"
dofs = ["2:x"]
m = 1.0
"""
#: the frequency is known to 1e-5 (relative eigenvalue), the shape weakly (0.01 on unit-length entries):
#: the first mode of two springs in series (a light middle mass) gives their series stiffness from
#: the frequency and their ratio from the shape only -- condition number about 2.5e3
SE, SS = 1e-5, 0.01


@pytest.fixture(scope="module")
def series():
    path = Path(tempfile.mkdtemp()) / "series.toml"
    path.write_text(SERIES)
    model = load_model(path)
    modes = model_modes(model)
    phi = modes.shapes[:, 0] / np.linalg.norm(modes.shapes[:, 0])
    return model, modes.eigenvalues[0], phi


def noisy(series, seed):
    _, lam, phi = series
    rng = np.random.default_rng(seed)
    return TestData(modes=(MeasuredMode(lam * (1 + SE * rng.standard_normal()), ("1:x", "2:x"),
                                        phi + SS * rng.standard_normal(2)),))


STD = {"eigenvalue": SE, "shape": SS}


def test_an_ill_conditioned_spread_is_one_solution_where_the_tolerance_made_six():
    # a solution known to ±0.1 % along k1 + k2 and ±3 % along k1 - k2 (condition number ~30 in std,
    # ~1e3 in the normalised information): points scattered along the weak direction within its std
    u = np.array([1.0, -1.0]) / np.sqrt(2)
    v = np.array([1.0, 1.0]) / np.sqrt(2)
    p0 = np.array([100.0, 100.0])
    C = 100.0 ** 2 * (0.03 ** 2 * np.outer(u, u) + 0.001 ** 2 * np.outer(v, v))
    steps = np.array([0.0, 0.1, -0.2, 0.3, -0.4, 0.5])  # in std of the weak direction: 0.3 % to 1.5 % apart
    pts = p0 + np.outer(steps * 3.0, u)
    costs = np.arange(6.0)
    assert len(cluster(pts, costs, 1e-4)) == 6  # the old rule: six "distinct solutions"
    g = significant(pts, costs, [C] * 6, alpha=0.01)
    assert g.groups == [[0, 1, 2, 3, 4, 5]] and g.basis == "statistic"
    # the same spread across the well-determined direction is significant: split
    far = np.array([p0, p0 + 1.0 * v])  # 1.0 / sqrt(2 * 0.1**2) = 7 std of the difference
    sep = compare(far[0], far[1], C, C, alpha=0.01)
    assert sep is not None and sep.basis == "statistic" and sep.dof == 2
    assert sep.statistic == pytest.approx(1.0 ** 2 / (2 * 0.1 ** 2), rel=1e-9)
    assert sep.threshold == pytest.approx(chi2.ppf(0.99, 2))


def test_without_a_covariance_the_tolerance_decides_and_a_non_identifiable_direction_is_said():
    p = np.array([[1.0, 2.0], [1.0, 2.5]])
    assert compare(p[0], p[1], None, None).basis == "tolerance"
    C = np.array([[1e-4, np.nan], [np.nan, np.nan]])  # k2 has no covariance (on a bound, unseen, a null direction)
    assert compare(p[0], p[1], C, C).basis == "non-identifiable"
    assert compare(p[0], p[0] * (1 + 1e-6), C, C) is None  # within the round-off floor
    # three parameters, the second without a covariance: the other two compared by the statistic
    C3 = np.full((3, 3), np.nan)
    C3[np.ix_([0, 2], [0, 2])] = np.diag([1e-2, 1e-2])
    a = np.array([1.0, 5.0, 2.0])
    assert compare(a, a + [0.05, 0.0, 0.05], C3, C3) is None  # d2 = 0.25: the same
    sep = compare(a, a + [1.0, 0.0, 0.0], C3, C3)
    assert sep.basis == "statistic" and sep.dof == 2 and sep.statistic == pytest.approx(1.0 / 2e-2)
    assert compare(a, a + [0.05, 1.0, 0.05], C3, C3).basis == "non-identifiable"


def test_ill_conditioned_but_unique_is_one_solution_with_a_plus_minus_that_holds(series):
    model = series[0]
    ms = multistart(model, noisy(series, 0), starts=8, seed=1, measurement_std=STD)
    assert len(ms.fitting) == 1 and ms.distinct["basis"] == "statistic" and not ms.distinct["non_unique"]
    cond = ms.distinct["conditioning"]
    assert cond["ill_conditioned"] and 1e3 < cond["condition_number"] < 1e4
    w = cond["weakest"]["direction"]
    assert abs(abs(w["k1"]) - abs(w["k2"])) < 0.1 and w["k1"] * w["k2"] < 0  # the ratio k1/k2 is the weak combination
    # the ± statement against a second route: the scatter of independent noisy repetitions
    fits = [update(model, noisy(series, 100 + s), measurement_std=STD, x0={"k1": 100.0, "k2": 100.0}) for s in range(24)]
    X = np.array([r.x for r in fits if r.success])
    n = len(X)
    assert n >= 20
    emp = X.std(axis=0, ddof=1) / 100.0
    lo, hi = np.sqrt(chi2.ppf([0.005, 0.995], n - 1) / (n - 1))
    for j, name in enumerate(("k1", "k2")):
        assert lo <= emp[j] / cond["relative_std"][name] <= hi, (name, emp[j], cond["relative_std"][name])


def test_two_minima_separated_far_beyond_their_std_are_two():
    model = two_dof()  # k1 = 8, k2 = 6; its two frequencies also come from (9, 16/3) (paper, Figure 3)
    modes = model_modes(model)
    data = TestData(modes=tuple(MeasuredMode(modes.eigenvalues[j]) for j in range(2)))
    ms = multistart(model, data, starts=30, seed=4, measurement_std={"eigenvalue": 1e-4})
    assert len(ms.fitting) == 2 and ms.distinct["non_unique"] and ms.distinct["basis"] == "statistic"
    got = sorted(tuple(round(v, 6) for v in s.parameters.values()) for s in ms.fitting)
    assert got == [(8.0, 6.0), (9.0, round(16 / 3, 6))]
    sep = [s for s in ms.distinct["separations"] if s][0]
    assert sep["basis"] == "statistic" and sep["statistic"] > 100 * sep["threshold"]


def test_the_paper_s_non_unique_single_sensor_case_keeps_every_exact_solution():
    from femupdate.uniqueness.exact import exact_solutions
    from femupdate.uniqueness.study import define_study, run_study

    model = two_dof()
    exact = exact_solutions(model, n_modes=2)  # a second route: the Groebner basis of the frequency equations
    real = sorted(tuple(round(s.parameters[n], 6) for n in ("k1", "k2")) for s in exact.solutions if s.valid)
    res = run_study(define_study(model, [(("1:x",), 2)], starts=30, seed=0))
    case = res.cases[0]
    got = sorted(tuple(round(s.parameters[n], 6) for n in ("k1", "k2")) for s in case.solutions)
    assert case.verdict == "non-unique" and got == real and len(got) >= 2
    assert case.distinct["basis"] == "statistic"
    assert all(s["basis"] == "statistic" for s in case.distinct["separations"] if s)


def _split_rate(n_pairs, seed, J, sigma):
    """Pairs of independent estimates of one linear-Gaussian minimum with their covariances; the
    number split at alpha = 0.01."""
    rng = np.random.default_rng(seed)
    p = np.array([100.0, 100.0])
    C = sigma ** 2 * np.linalg.inv(J.T @ J)
    G = np.linalg.solve(J.T @ J, J.T)
    split = 0
    for _ in range(n_pairs):
        a = p + G @ (sigma * rng.standard_normal(J.shape[0]))
        b = p + G @ (sigma * rng.standard_normal(J.shape[0]))
        split += compare(a, b, C, C, alpha=0.01) is not None
    return split


def test_one_minimum_is_split_in_about_alpha_of_repetitions_linear_gaussian():
    # an ill-conditioned linear model (condition number ~2.5e3), where the statistic is exactly chi-square
    J = np.array([[1.0, 1.0], [1.0, 1.0008], [0.5, 0.5004]]) / 100.0
    n = 3000
    split = _split_rate(n, 7, J, 1e-5)
    hi = binom.ppf(0.995, n, 0.01)
    lo = binom.ppf(0.005, n, 0.01)
    assert lo <= split <= hi, (split, lo, hi)


def test_one_minimum_is_split_at_most_as_often_as_alpha_allows_in_noisy_updates(series):
    # the nonlinear model: pairs of independent noisy data sets, each updated, compared at alpha = 0.01
    model = series[0]
    n = 60 if HEAVY else 15
    fits = [update(model, noisy(series, 1000 + s), measurement_std=STD, x0={"k1": 100.0, "k2": 100.0})
            for s in range(2 * n)]
    pairs = [(a, b) for a, b in zip(fits[::2], fits[1::2]) if a.success and b.success]
    split = sum(compare(a.x, b.x, a.diagnostics.covariance, b.diagnostics.covariance, alpha=0.01) is not None
                for a, b in pairs)
    assert split <= binom.ppf(0.99, len(pairs), 0.01), (split, len(pairs))


def test_conditioning_statement_of_a_known_covariance():
    C = np.diag([0.01 ** 2 * 4.0, 0.03 ** 2 * 9.0])  # k1 = 2 ± 1 %, k2 = 3 ± 3 %
    st = conditioning(["k1", "k2"], [2.0, 3.0], C, 2.4e3, "stated")
    assert st["ill_conditioned"] and st["relative_std"] == pytest.approx({"k1": 0.01, "k2": 0.03})
    assert st["weakest"]["direction"] == pytest.approx({"k1": 0.0, "k2": 1.0}) and st["weakest"]["relative_std"] == pytest.approx(0.03)
