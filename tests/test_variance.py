"""femupdate.variance: REML variance components against closed forms and a second route."""

import math

import numpy as np
import pytest
from scipy import optimize, stats

from femupdate.variance import fit_test, variance_components, weighted_dof


def _two_groups(rng, n1=12, n2=20, s1=0.1, s2=2.0, shared=True):
    x1, x2 = rng.uniform(0, 1, n1), rng.uniform(0, 1, n2)
    if shared:  # one slope for both groups, an intercept each
        X = np.zeros((n1 + n2, 3))
        X[:n1, 0] = 1
        X[n1:, 1] = 1
        X[:, 2] = np.concatenate([x1, x2])
    else:  # two separate regressions
        X = np.zeros((n1 + n2, 4))
        X[:n1, 0], X[:n1, 1] = 1, x1
        X[n1:, 2], X[n1:, 3] = 1, x2
    beta = rng.normal(size=X.shape[1])
    y = X @ beta + np.concatenate([s1 * rng.normal(size=n1), s2 * rng.normal(size=n2)])
    return X, y, beta, {"a": np.arange(n1), "b": np.arange(n1, n1 + n2)}


def _fit(X, y):
    b = np.linalg.lstsq(X, y, rcond=None)[0]
    return b, X @ b - y  # residual r = model - data, J = X


def test_separate_regressions_are_the_textbook_estimates():
    rng = np.random.default_rng(1)
    X, y, _, blocks = _two_groups(rng, shared=False)
    b, r = _fit(X, y)
    vc = variance_components(X, r, blocks)
    for c, cols in zip(vc.components, ([0, 1], [2, 3])):
        rows = blocks[c.label]
        bb = np.linalg.lstsq(X[np.ix_(rows, cols)], y[rows], rcond=None)[0]
        rss = float(np.sum((X[np.ix_(rows, cols)] @ bb - y[rows]) ** 2))
        assert c.variance == pytest.approx(rss / (rows.size - 2), rel=1e-8)
        assert c.dof == pytest.approx(rows.size - 2, rel=1e-8)
        assert c.basis == "estimated"
    # each group's parameters rest on their own group: the textbook covariance s_b^2 (X_b'X_b)^-1, dof n_b - 2
    for c, cols in zip(vc.components, ([0, 1], [2, 3])):
        Xb = X[np.ix_(blocks[c.label], cols)]
        np.testing.assert_allclose(vc.covariance[np.ix_(cols, cols)], c.variance * np.linalg.inv(Xb.T @ Xb),
                                   rtol=1e-8)
        np.testing.assert_allclose(vc.dof[cols], c.dof, rtol=1e-8)


def test_one_block_is_s_squared():
    rng = np.random.default_rng(2)
    X = np.column_stack([np.ones(15), rng.uniform(size=15), rng.uniform(size=15)])
    y = X @ [1, 2, 3] + 0.3 * rng.normal(size=15)
    b, r = _fit(X, y)
    vc = variance_components(X, r, {"all": np.arange(15)})
    s2 = float(r @ r) / 12
    assert vc.components[0].variance == pytest.approx(s2, rel=1e-10)
    np.testing.assert_allclose(vc.covariance, s2 * np.linalg.inv(X.T @ X), rtol=1e-10)
    np.testing.assert_allclose(vc.dof, 12, rtol=1e-10)


def _reml_nll(logv, X, y, blocks):
    v = np.zeros(y.size)
    for lv, rows in zip(logv, blocks.values()):
        v[rows] = math.exp(lv)
    W = 1 / v
    N = X.T @ (X * W[:, None])
    b = np.linalg.solve(N, X.T @ (W * y))
    e = y - X @ b
    return 0.5 * (np.sum(np.log(v)) + np.linalg.slogdet(N)[1] + float(e @ (W * e)))


def test_shared_parameters_maximise_the_restricted_likelihood():
    """Second route: the REML log-likelihood maximised numerically."""
    rng = np.random.default_rng(3)
    X, y, _, blocks = _two_groups(rng, shared=True)
    b, r = _fit(X, y)  # the unweighted fit: the iteration re-weights it
    vc = variance_components(X, r, blocks)
    best = optimize.minimize(_reml_nll, np.zeros(2), args=(X, y, blocks), method="Nelder-Mead",
                             options={"xatol": 1e-10, "fatol": 1e-14, "maxiter": 4000})
    np.testing.assert_allclose([c.variance for c in vc.components], np.exp(best.x), rtol=1e-5)
    assert vc.converged
    assert sum(c.dof for c in vc.components) == pytest.approx(y.size - 3, rel=1e-10)


def test_sandwich_covariance_and_coverage_of_t_intervals():
    """Over many noise draws the t-intervals with the Satterthwaite dof cover the true value as
    often as they claim, and the RMS z-score is near 1 (variances 100x apart, unweighted fit)."""
    rng = np.random.default_rng(4)
    X, _, beta, blocks = _two_groups(rng, n1=10, n2=25, s1=0.05, s2=0.5, shared=True)
    n, hit68, hit95, z2 = 1500, 0, 0, []
    for _ in range(n):
        y = X @ beta + np.concatenate([0.05 * rng.normal(size=10), 0.5 * rng.normal(size=25)])
        b, r = _fit(X, y)
        vc = variance_components(X, r, blocks)
        err = abs(b[2] - beta[2])
        hit68 += err <= vc.half_width(0.6827)[2]
        hit95 += err <= vc.half_width(0.95)[2]
        z2.append((err / vc.std[2]) ** 2)
    lo68, hi68 = stats.binom.ppf([0.005, 0.995], n, 0.6827) / n
    lo95, hi95 = stats.binom.ppf([0.005, 0.995], n, 0.95) / n
    assert lo68 <= hit68 / n <= hi68
    assert lo95 <= hit95 / n <= hi95
    assert 0.9 < math.sqrt(np.mean(z2)) < 1.15


def test_stated_blocks_are_absolute_and_small_blocks_pooled():
    rng = np.random.default_rng(5)
    X, y, _, blocks = _two_groups(rng, n1=12, n2=20, s1=1.0, shared=True)
    b, r = _fit(X, y)
    vc = variance_components(X, r, blocks, stated={"a"})
    a = vc.components[0]
    assert a.basis == "stated" and a.variance == 1.0 and math.isinf(a.dof)
    # one block per residual of group b: none estimable alone, pooled by kind with the same estimate
    fine = {"a": blocks["a"], **{f"b{i}": [int(k)] for i, k in enumerate(blocks["b"])}}
    vc2 = variance_components(X, r, fine, stated={"a"}, kinds={f"b{i}": "b" for i in range(20)})
    assert [c.basis for c in vc2.components] == ["stated", "pooled"]
    assert vc2.components[1].variance == pytest.approx(vc.components[1].variance, rel=1e-10)
    assert "pooled" in vc2.notes[0]
    with pytest.raises(ValueError, match="exactly once"):
        variance_components(X, r, {"a": blocks["a"]})


def test_not_estimable_when_no_redundancy():
    X = np.eye(3)
    vc = variance_components(X, np.array([0.1, -0.2, 0.3]), {"x": [0, 1, 2]})
    assert vc.components[0].basis == "not estimable"
    assert np.all(np.isnan(vc.std))


def test_fit_test_chi_square_level_and_power():
    rng = np.random.default_rng(6)
    X = np.column_stack([np.ones(30), np.linspace(0, 1, 30)])
    flags, flagged_bias = 0, 0
    n = 1000
    for _ in range(n):
        e = rng.normal(size=30)
        _, r = _fit(X, X @ [1, 2] + e)
        flags += fit_test(variance_components(X, r, {"d": np.arange(30)}, stated={"d"}), alpha=0.05).flagged
        _, r = _fit(X, X @ [1, 2] + e + 20 * np.linspace(0, 1, 30) ** 2)  # a curvature the model lacks
        flagged_bias += fit_test(variance_components(X, r, {"d": np.arange(30)}, stated={"d"})).flagged
    lo, hi = stats.binom.ppf([0.005, 0.995], n, 0.05)
    assert lo <= flags <= hi
    assert flagged_bias >= 0.9 * n
    t = fit_test(variance_components(X, r, {"d": np.arange(30)}, stated={"d"}))
    assert t.dof == pytest.approx(28) and t.record()["verdict"] == "model error"


def test_fit_test_plausibility_bound():
    rng = np.random.default_rng(7)
    X = np.column_stack([np.ones(40), np.linspace(0, 1, 40)])
    _, r = _fit(X, X @ [1, 2] + 0.01 * rng.normal(size=40))
    ok = fit_test(variance_components(X, r, {"d": np.arange(40)}, kinds={"d": "eigenvalue"}),
                  plausible={"eigenvalue": 0.02})
    assert ok.test == "plausibility" and ok.verdict == "consistent"
    _, r = _fit(X, X @ [1, 2] + 0.05 * rng.normal(size=40))
    bad = fit_test(variance_components(X, r, {"d": np.arange(40)}, kinds={"d": "eigenvalue"}),
                   plausible={"eigenvalue": 0.02})
    assert bad.flagged and bad.statistic > 2


def test_weighted_dof_closed_forms():
    rng = np.random.default_rng(4)
    # one estimated component, linear: every standard deviation rests on n − L degrees of freedom
    J = rng.standard_normal((12, 3))
    vc = variance_components(J, rng.standard_normal(12), {"all": slice(None)})
    assert weighted_dof(J, vc.components) == pytest.approx([9.0] * 3)
    # two blocks, each the only data of its own parameters: each parameter has its block's n_b − L_b
    J = np.zeros((17, 3))
    J[:10, :2] = rng.standard_normal((10, 2))
    J[10:, 2] = rng.standard_normal(7)
    r = rng.standard_normal(17)
    vc = variance_components(J, r, {"a": np.arange(10), "b": np.arange(10, 17)})
    assert [c.dof for c in vc.components] == pytest.approx([8.0, 6.0])
    assert weighted_dof(J, vc.components) == pytest.approx([8.0, 8.0, 6.0])
    # block b counted as known: its parameter's standard deviation rests on nothing estimated
    assert weighted_dof(J, vc.components, [True, False]) == pytest.approx([8.0, 8.0, math.inf])
    # shared parameters: Satterthwaite's ν between the two blocks' and above the smaller
    J = rng.standard_normal((17, 2))
    vc = variance_components(J, r, {"a": np.arange(10), "b": np.arange(10, 17)})
    nu = weighted_dof(J, vc.components)
    assert np.all(nu >= min(c.dof for c in vc.components) - 1e-9) and np.all(nu <= sum(c.dof for c in vc.components))
