"""Tikhonov regularisation and the choice of α (GCV, L-curve).

Every numerical claim is checked against an independent route: the stacked least-squares problem
solved by ``numpy.linalg.lstsq``, explicit influence matrices, finite differences of the L-curve,
and the true error on classic discrete ill-posed problems (Hansen's Shaw problem and a Gaussian
blur) built here.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from femupdate import InputError
from femupdate.regularization import RegularizationChoice, choose_alpha, gcv, l_curve, tikhonov_step

EPS = np.finfo(float).eps


# ----------------------------------------------------------------------------- helpers
def matrix_with_singular_values(rng, m, n, svals):
    U, _ = np.linalg.qr(rng.standard_normal((m, len(svals))))
    V, _ = np.linalg.qr(rng.standard_normal((n, len(svals))))
    return U @ np.diag(svals) @ V.T


def gamma_matrix(kind, n, rng):
    """Γ as passed to the module and as a dense matrix for the independent route."""
    if kind is None:
        return None, np.eye(n)
    if kind == "scalar":
        return 2.5, 2.5 * np.eye(n)
    if kind == "diag":
        d = rng.uniform(0.5, 3.0, n)
        return d, np.diag(d)
    if kind == "diag_with_zero":        # one parameter left unregularised (a semi-norm)
        d = rng.uniform(0.5, 3.0, n)
        d[1] = 0.0
        return d, np.diag(d)
    if kind == "full":
        G = rng.standard_normal((n, n)) + 3 * np.eye(n)
        return G, G
    if kind == "tall":
        G = rng.standard_normal((n + 3, n))
        return G, G
    if kind == "difference":            # first differences, (n-1, n): null space = constants
        G = np.diff(np.eye(n), axis=0)
        return G, G
    raise AssertionError(kind)


def stacked_lstsq(J, r, alpha, G, offset):
    """Independent route: min ||J d + r||^2 + alpha^2 ||G (d + offset)||^2 by numpy.linalg.lstsq."""
    A = np.vstack([J, alpha * G])
    rhs = np.concatenate([-r, -alpha * G @ offset])
    return np.linalg.lstsq(A, rhs, rcond=None)[0]


def shaw(m, n):
    """Hansen's Shaw test problem (1-D image restoration), collocation at m points, n unknowns."""
    ts = -np.pi / 2 + (np.arange(m) + 0.5) * np.pi / m
    tt = -np.pi / 2 + (np.arange(n) + 0.5) * np.pi / n
    c_s, c_t = np.cos(ts)[:, None], np.cos(tt)[None, :]
    A = (np.pi / n) * (c_s + c_t) ** 2 * np.sinc(np.sin(ts)[:, None] + np.sin(tt)[None, :]) ** 2
    x = 2 * np.exp(-6 * (tt - 0.8) ** 2) + np.exp(-2 * (tt + 0.5) ** 2)
    return A, x


def gaussian_blur(n, width):
    """1-D Gaussian blur on [0, 1] (midpoint rule) with a smooth true solution."""
    t = (np.arange(n) + 0.5) / n
    A = np.exp(-((t[:, None] - t[None, :]) ** 2) / (2 * width**2)) / (n * width * np.sqrt(2 * np.pi))
    x = np.sin(np.pi * t) + 0.5 * np.sin(2 * np.pi * t)
    return A, x


def noisy(A, x, level, seed):
    rng = np.random.default_rng(seed)
    b = A @ x
    e = rng.standard_normal(b.size)
    return b + e * (level * np.linalg.norm(b) / np.linalg.norm(e))


# ----------------------------------------------------------------------------- (1) the step
@pytest.mark.parametrize("shape", [(30, 8), (6, 10)])
@pytest.mark.parametrize("kind", [None, "scalar", "diag", "diag_with_zero", "full", "tall", "difference"])
def test_step_equals_stacked_least_squares(shape, kind):
    rng = np.random.default_rng(7)
    m, n = shape
    J = rng.standard_normal((m, n))
    r = rng.standard_normal(m)
    offset = rng.standard_normal(n)
    gamma, G = gamma_matrix(kind, n, rng)
    for alpha in (1e-3, 0.3, 5.0):
        expected = stacked_lstsq(J, r, alpha, G, offset)
        got = tikhonov_step(J, r, alpha, gamma=gamma, offset=offset)
        assert got.shape == (n,)
        np.testing.assert_allclose(got, expected, rtol=0, atol=1e-10 * np.linalg.norm(expected))
    # offset=None means zero offset: the regulariser then only penalises the step
    np.testing.assert_allclose(tikhonov_step(J, r, 0.3, gamma=gamma),
                               stacked_lstsq(J, r, 0.3, G, np.zeros(n)), atol=1e-10)


def test_step_is_not_from_normal_equations():
    """cond(J) = 1e7: normal equations would square it to 1e14 and lose ~7 more digits."""
    rng = np.random.default_rng(3)
    J = matrix_with_singular_values(rng, 40, 6, np.logspace(0, -7, 6))
    r = rng.standard_normal(40)
    alpha = 1e-9
    expected = stacked_lstsq(J, r, alpha, np.eye(6), np.zeros(6))
    got = tikhonov_step(J, r, alpha)
    assert np.linalg.norm(got - expected) <= 1e-8 * np.linalg.norm(expected)


# ----------------------------------------------------------------------------- (2) α → 0
def test_small_alpha_tends_to_least_squares_solution():
    rng = np.random.default_rng(11)
    J = matrix_with_singular_values(rng, 25, 7, np.logspace(1, -2, 7))   # full column rank, cond 1e3
    r = rng.standard_normal(25)
    x_ls = -np.linalg.pinv(J) @ r
    gamma = rng.uniform(0.5, 2.0, 7)
    offset = rng.standard_normal(7)
    np.testing.assert_allclose(tikhonov_step(J, r, 0.0), x_ls, rtol=1e-10, atol=1e-12)
    errors = [np.linalg.norm(tikhonov_step(J, r, a, gamma=gamma, offset=offset) - x_ls) for a in (1e-4, 1e-5, 1e-6)]
    # the bias of Tikhonov regularisation is O(α²): each decade of α gains two decades
    assert errors[0] / errors[1] == pytest.approx(100, rel=0.05)
    assert errors[1] / errors[2] == pytest.approx(100, rel=0.05)
    assert errors[2] < 1e-7 * np.linalg.norm(x_ls)   # ~ (α / s_min)² = 1e-8


def test_alpha_zero_on_rank_deficient_J_is_the_pseudo_inverse():
    rng = np.random.default_rng(12)
    J = rng.standard_normal((5, 9))                 # underdetermined: more parameters than data
    r = rng.standard_normal(5)
    expected = -np.linalg.pinv(J) @ r
    np.testing.assert_allclose(tikhonov_step(J, r, 0.0), expected, atol=1e-12)
    np.testing.assert_allclose(tikhonov_step(J, r, 1e-7), expected, atol=1e-10)


# ----------------------------------------------------------------------------- (3) ill-posed problems
# GCV is known to undersmooth now and then when its function is flat (Hansen, Discrete Inverse
# Problems, 2010, sec. 5.4): on Shaw (64 x 32, 1 % noise) about one noise draw in six or seven, on
# the blur below about one in a hundred.  The seeds are the first three.
PROBLEMS = {"shaw": (lambda: shaw(64, 32), 0.01), "blur": (lambda: gaussian_blur(100, 0.03), 0.05)}


@pytest.mark.parametrize("seed", [0, 1, 2])
@pytest.mark.parametrize("problem", sorted(PROBLEMS))
def test_gcv_and_lcurve_choose_near_optimal_alpha(problem, seed):
    make, level = PROBLEMS[problem]
    A, x_true = make()
    b = noisy(A, x_true, level, seed)
    r = -b                                          # J Δ ≈ -r from p = 0, p_ref = 0
    # true error on the grid, from an independent SVD of A
    U, s, Vt = np.linalg.svd(A, full_matrices=False)
    beta = U.T @ b

    def x_alpha(a):
        return Vt.T @ (s * beta / (s**2 + a**2))

    x_unreg = np.linalg.lstsq(A, b, rcond=None)[0]
    err_unreg = np.linalg.norm(x_unreg - x_true)
    for choice in (gcv(A, r), l_curve(A, r)):
        grid = choice.alphas
        assert grid.size == 200 and np.all(np.diff(grid) > 0)
        errors = np.array([np.linalg.norm(x_alpha(a) - x_true) for a in grid])
        alpha_opt = grid[np.argmin(errors)]
        assert 0.1 < choice.alpha / alpha_opt < 10, (choice.method, choice.alpha, alpha_opt)
        step = tikhonov_step(A, r, choice.alpha)
        err = np.linalg.norm(step - x_true)
        assert err < 0.25 * np.linalg.norm(x_true)
        assert err < 5 * errors.min()
        assert err < 1e-6 * err_unreg              # unregularised: noise amplified by ~1e10
        assert choice.method in ("gcv", "lcurve")


def test_choice_is_independent_of_the_current_parameters():
    """For a linear model the regularised problem depends on p + Δp only, not on where p is."""
    A, x_true = gaussian_blur(60, 0.04)
    b = noisy(A, x_true, 0.02, 4)
    rng = np.random.default_rng(5)
    p_ref = 0.3 + 0.1 * rng.standard_normal(60)      # nominal model
    gamma = rng.uniform(0.5, 2.0, 60)
    results = []
    for p in (p_ref, p_ref + rng.standard_normal(60)):
        r = A @ p - b
        choice = gcv(A, r, gamma=gamma, offset=p - p_ref)
        results.append((choice.alpha, p + tikhonov_step(A, r, choice.alpha, gamma=gamma, offset=p - p_ref)))
    assert results[0][0] == pytest.approx(results[1][0], rel=1e-8)
    np.testing.assert_allclose(results[0][1], results[1][1], atol=1e-8 * np.linalg.norm(results[0][1]))


# ----------------------------------------------------------------------------- (4) GCV by brute force
@pytest.mark.parametrize("kind", [None, "diag", "full", "difference"])
def test_gcv_function_equals_brute_force(kind):
    rng = np.random.default_rng(21)
    m, n = 25, 6
    J = matrix_with_singular_values(rng, m, n, np.logspace(1, -3, n))
    r = rng.standard_normal(m)
    offset = rng.standard_normal(n)
    gamma, G = gamma_matrix(kind, n, rng)
    alphas = np.array([1e-3, 3e-2, 0.5, 4.0])
    choice = gcv(J, r, alphas=alphas, gamma=gamma, offset=offset, refine=False)
    for i, a in enumerate(alphas):
        stacked = np.vstack([J, a * G])
        # explicit influence matrix A(α) = J (JᵀJ + α²ΓᵀΓ)⁻¹ Jᵀ, column by column
        X = np.linalg.lstsq(stacked, np.vstack([np.eye(m), np.zeros((G.shape[0], m))]), rcond=None)[0]
        influence = J @ X
        step = stacked_lstsq(J, r, a, G, offset)
        res2 = np.sum((J @ step + r) ** 2)
        expected = res2 / np.trace(np.eye(m) - influence) ** 2
        assert choice.criterion[i] == pytest.approx(expected, rel=1e-9)
        assert choice.residual_norms[i] == pytest.approx(np.sqrt(res2), rel=1e-9)
        assert choice.solution_norms[i] == pytest.approx(np.linalg.norm(G @ (step + offset)), rel=1e-9)


def test_refined_alpha_improves_on_the_grid():
    A, x_true = gaussian_blur(80, 0.03)
    r = -noisy(A, x_true, 0.05, 0)
    for rule, sign in ((gcv, 1.0), (l_curve, -1.0)):            # minimise G, maximise κ
        coarse = rule(A, r, refine=False)
        fine = rule(A, r)
        i = int(np.argmin(sign * coarse.criterion))
        assert coarse.alpha == coarse.alphas[i]
        assert coarse.alphas[i - 1] < fine.alpha < coarse.alphas[i + 1]
        assert fine.alpha != coarse.alpha
        at_fine = rule(A, r, alphas=[fine.alpha], refine=False).criterion[0]
        assert sign * at_fine < sign * coarse.criterion[i]


def test_default_grid_spans_the_singular_values_of_J_times_inverse_gamma():
    rng = np.random.default_rng(6)
    J = matrix_with_singular_values(rng, 15, 5, np.logspace(0, -4, 5))
    gamma = rng.uniform(0.5, 4.0, 5)
    s = np.linalg.svd(J / gamma, compute_uv=False)             # J Γ⁻¹ for a diagonal Γ
    for rule in (gcv, l_curve):
        grid = rule(J, rng.standard_normal(15), gamma=gamma).alphas
        assert grid.size == 200
        assert grid[0] == pytest.approx(s[-1] / 10, rel=1e-10)
        assert grid[-1] == pytest.approx(s[0] * 10, rel=1e-10)
        np.testing.assert_allclose(np.diff(np.log(grid)), np.log(grid[1] / grid[0]), rtol=1e-8)


# ----------------------------------------------------------------------------- L-curve curvature
def test_lcurve_curvature_equals_finite_differences():
    A, x_true = shaw(40, 20)
    r = -noisy(A, x_true, 1e-3, 1)
    alphas = np.geomspace(1e-6, 1e-1, 6001)
    choice = l_curve(A, r, alphas=alphas)
    t = np.log(alphas)
    x, y = np.log(choice.residual_norms), np.log(choice.solution_norms)
    dx, dy = np.gradient(x, t), np.gradient(y, t)
    ddx, ddy = np.gradient(dx, t), np.gradient(dy, t)
    kappa_fd = (dx * ddy - dy * ddx) / (dx**2 + dy**2) ** 1.5
    inner = slice(10, -10)
    scale = np.max(np.abs(kappa_fd[inner]))
    np.testing.assert_allclose(choice.criterion[inner], kappa_fd[inner], rtol=0, atol=1e-4 * scale)
    # the corner is the maximum of the curvature, and it is a real corner (positive, sharp)
    i = int(np.argmax(kappa_fd[inner])) + 10
    assert choice.alpha == pytest.approx(alphas[i], rel=0.01)
    assert choice.criterion[i] > 10


# ----------------------------------------------------------------------------- degenerate cases
@pytest.mark.filterwarnings("error")
def test_lcurve_well_conditioned_has_no_corner():
    rng = np.random.default_rng(2)
    J = matrix_with_singular_values(rng, 30, 6, [2.0, 1.8, 1.5, 1.3, 1.1, 1.0])
    r = -(J @ rng.standard_normal(6) + 0.01 * rng.standard_normal(30))
    choice = l_curve(J, r)
    assert choice.alpha == choice.alphas[0]
    assert choice.method.startswith("lcurve (no corner")
    assert "smallest alpha" in choice.method
    assert gcv(J, r).alpha == gcv(J, r).alphas[0]


@pytest.mark.filterwarnings("error")
@pytest.mark.parametrize("svals", [[2.0, 1.5, 1.0], [100.0, 10.0, 0.3], [1e3, 1.0, 1e-3]])
def test_lcurve_consistent_data_returns_smallest_alpha(svals):
    rng = np.random.default_rng(8)
    J = matrix_with_singular_values(rng, 20, 3, svals)
    r = -J @ rng.standard_normal(3)                 # r in the range of J: zero residual
    choice = l_curve(J, r)
    assert choice.alpha == choice.alphas[0]
    assert "range of J" in choice.method
    assert gcv(J, r).alpha == choice.alphas[0]


@pytest.mark.filterwarnings("error")
def test_zero_right_hand_side_does_not_crash():
    rng = np.random.default_rng(9)
    J = rng.standard_normal((10, 4))
    r = np.zeros(10)
    for rule in ("gcv", "lcurve"):
        choice = choose_alpha(J, r, rule)
        assert choice.alpha == choice.alphas[0]
        assert "smallest alpha" in choice.method
    np.testing.assert_array_equal(tikhonov_step(J, r, 0.5), np.zeros(4))


@pytest.mark.filterwarnings("error")
def test_square_well_conditioned_does_not_crash():
    rng = np.random.default_rng(10)
    J = rng.standard_normal((6, 6)) + 5 * np.eye(6)
    r = rng.standard_normal(6)
    for rule in ("gcv", "lcurve"):
        choice = choose_alpha(J, r, rule)
        assert np.isfinite(choice.alpha) and choice.alpha > 0


def test_lcurve_maximum_at_the_end_of_a_narrow_grid():
    A, x_true = shaw(40, 20)
    r = -noisy(A, x_true, 1e-2, 0)
    corner = l_curve(A, r).alpha
    narrow = np.geomspace(corner / 100, corner / 10, 20)
    choice = l_curve(A, r, alphas=narrow)
    assert choice.alpha == narrow[-1]
    assert "largest alpha" in choice.method


# ----------------------------------------------------------------------------- dispatch and result
def test_choose_alpha_dispatch():
    A, x_true = gaussian_blur(50, 0.05)
    r = -noisy(A, x_true, 0.02, 3)
    assert choose_alpha(A, r, "gcv").alpha == gcv(A, r).alpha
    assert choose_alpha(A, r).alpha == gcv(A, r).alpha
    for name in ("lcurve", "L-curve", "l_curve"):
        assert choose_alpha(A, r, name).alpha == l_curve(A, r).alpha
    fixed = choose_alpha(A, r, 0.02)
    assert fixed.alpha == 0.02 and fixed.method == "fixed"
    step = tikhonov_step(A, r, 0.02)
    assert fixed.residual_norms[0] == pytest.approx(np.linalg.norm(A @ step + r), rel=1e-10)
    assert fixed.solution_norms[0] == pytest.approx(np.linalg.norm(step), rel=1e-10)


def test_choice_is_a_frozen_value_object():
    rng = np.random.default_rng(1)
    choice = gcv(rng.standard_normal((12, 4)), rng.standard_normal(12))
    assert isinstance(choice, RegularizationChoice)
    with pytest.raises(dataclasses.FrozenInstanceError):
        choice.alpha = 1.0
    with pytest.raises(ValueError):
        choice.alphas[0] = 1.0
    assert choice.alphas.shape == choice.residual_norms.shape == choice.solution_norms.shape == choice.criterion.shape


# ----------------------------------------------------------------------------- (5) bad input
@pytest.fixture
def Jr():
    rng = np.random.default_rng(0)
    return rng.standard_normal((5, 3)), rng.standard_normal(5)


@pytest.mark.parametrize("fn", [gcv, l_curve, choose_alpha, lambda J, r, **kw: tikhonov_step(J, r, 0.1, **kw)])
def test_nan_and_inf_are_refused(Jr, fn):
    J, r = Jr
    Jbad = J.copy()
    Jbad[2, 1] = np.nan
    with pytest.raises(InputError, match=r"sensitivity matrix contains NaN.*J\[2, 1\]"):
        fn(Jbad, r)
    rbad = r.copy()
    rbad[4] = np.inf
    with pytest.raises(InputError, match=r"residual vector contains NaN or inf.*r\[4\]"):
        fn(J, rbad)
    with pytest.raises(InputError, match="offset"):
        fn(J, r, offset=[0.0, np.nan, 0.0])
    with pytest.raises(InputError, match="gamma"):
        fn(J, r, gamma=[1.0, np.inf, 1.0])


@pytest.mark.parametrize("fn", [gcv, l_curve, choose_alpha, lambda J, r, **kw: tikhonov_step(J, r, 0.1, **kw)])
def test_inconsistent_shapes_are_refused(Jr, fn):
    J, r = Jr
    with pytest.raises(InputError, match=r"\(5, 3\).*\(4,\)"):
        fn(J, r[:4])
    with pytest.raises(InputError, match=r"2-D.*\(15,\)"):
        fn(J.ravel(), r)
    with pytest.raises(InputError, match=r"\(5, 1\)"):
        fn(J, r[:, None])
    with pytest.raises(InputError, match=r"gamma.*length 4.*\(5, 3\)"):
        fn(J, r, gamma=np.ones(4))
    with pytest.raises(InputError, match=r"gamma has shape \(3, 4\).*\(5, 3\)"):
        fn(J, r, gamma=np.ones((3, 4)))
    with pytest.raises(InputError, match=r"offset.*\(2,\).*\(5, 3\)"):
        fn(J, r, offset=np.ones(2))
    with pytest.raises(InputError, match="empty"):
        fn(np.zeros((0, 3)), np.zeros(0))


def test_invalid_rules_and_factors(Jr):
    J, r = Jr
    with pytest.raises(InputError, match="'foo'"):
        choose_alpha(J, r, rule="foo")
    with pytest.raises(InputError, match="None"):
        choose_alpha(J, r, rule=None)
    with pytest.raises(InputError, match="True"):
        choose_alpha(J, r, rule=True)
    with pytest.raises(InputError, match=">= 0"):
        choose_alpha(J, r, rule=-1.0)
    with pytest.raises(InputError, match=">= 0"):
        tikhonov_step(J, r, -0.1)
    with pytest.raises(InputError, match=">= 0"):
        tikhonov_step(J, r, np.nan)
    with pytest.raises(InputError, match="positive"):
        gcv(J, r, alphas=[0.0, 1.0])
    with pytest.raises(InputError, match="non-empty"):
        l_curve(J, r, alphas=[])
    with pytest.raises(InputError, match="real"):
        gcv(J + 1j, r)


def test_unidentifiable_combinations_are_refused():
    rng = np.random.default_rng(4)
    J = rng.standard_normal((8, 3))
    J[:, 2] = 0.0                                    # parameter 3 not measured ...
    r = rng.standard_normal(8)
    with pytest.raises(InputError, match="common null space"):
        tikhonov_step(J, r, 0.1, gamma=[1.0, 1.0, 0.0])   # ... and not regularised
    # regularised, it is fine: it stays at the reference
    step = tikhonov_step(J, r, 0.1, gamma=[1.0, 1.0, 1.0], offset=[0.0, 0.0, 0.7])
    assert step[2] == pytest.approx(-0.7)
    with pytest.raises(InputError, match="zero"):
        gcv(np.zeros((4, 2)), np.ones(4))
    with pytest.raises(InputError, match="gamma is zero"):
        tikhonov_step(J, r, 0.1, gamma=np.zeros((2, 3)))


def test_errors_are_value_errors(Jr):
    J, r = Jr
    with pytest.raises(ValueError):
        choose_alpha(J, r, rule="maximum-likelihood")
