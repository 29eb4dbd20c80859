"""Bayesian updating (femupdate.posterior): every method against closed forms and an independent
quadrature, with tolerances from their Monte Carlo errors.

* a linear-Gaussian problem (grounded springs shared between uncoupled masses: every eigenvalue
  is linear in the stiffnesses) whose posterior and evidence are known in closed form;
* Laplace and MCMC on a nearly linear problem (the two-dof system measured at both dofs);
* the paper's two-dof system measured for two frequencies: both solutions, (8, 6) and (9, 16/3),
  in the proportion that quadrature of the posterior on a fine grid gives (eigenvalues by the
  quadratic formula: not femupdate's code);
* the contraction of the posterior with the number of repeated tests (1/sqrt(n)).

Monte Carlo tolerances: a posterior mean is within 4 σ/√n_eff of the truth, a standard deviation
within a relative 4/√(2 n_eff) (Gaussian samples), a proportion within 4 √(f(1−f)/n_eff), with
n_eff the effective sample size the method reports (MCMC: N/τ; TMCMC: the Kish size of its last
reweighting, about N/2, which is conservative: its final population is refreshed by Metropolis
moves).  The TMCMC log-evidence is within 5 times its reported error, a lower bound (independent
samples assumed): across seeds its spread was 1.0–1.6 times the reported error
(``FEMUPDATE_HEAVY=1`` runs that check).
"""

import math

import numpy as np
import pytest

import femupdate as fu
from femupdate import InputError
from femupdate.bayes import Posterior, effective_sample_size, integrated_time, split_rhat
from femupdate.examples import two_dof
from femupdate.priors import Prior

from conftest import HEAVY, heavy  # noqa: E402
pytest.importorskip("emcee")


# ----------------------------------------------------------------------------------- the linear-Gaussian problem
#: grounded springs of each dof: dof i's stiffness is the sum of these parameters (uncoupled dofs)
ROWS = [("a",), ("a", "b"), ("b", "c"), ("a", "c"), ("a", "b", "c"), ("b",)]
TRUE = {"a": 100.0, "b": 200.0, "c": 300.0}
SIGMA = 0.01


def linear_model(n_dofs=4, priors=None):
    """Uncoupled masses on grounded springs; eigenvalue i = (sum of its springs) / m_i, the masses
    chosen so that the eigenvalues at the truth are 100 (i+1)^2: well apart, so that the order
    pairing of frequency-only modes never swaps in the posterior's region."""
    s = fu.Structure("linear")
    for n in "abc":
        s.parameter(n, TRUE[n], (1.0, 1000.0), prior=(priors or {}).get(n))
    A = np.zeros((n_dofs, 3))
    masses = []
    for i, row in enumerate(ROWS[:n_dofs]):
        for n in row:
            s.spring([f"{i + 1}:x"], k=n)
            A[i, "abc".index(n)] = 1.0
        k = sum(TRUE[n] for n in row)
        masses.append(k / (100.0 * (i + 1) ** 2))
        s.mass([f"{i + 1}:x"], m=masses[-1])
    return s.build(), A, np.array(masses)


def linear_data(n_dofs=4, std=SIGMA, seed=7):
    _, A, m = linear_model(n_dofs)
    lam = A @ np.array([TRUE[n] for n in "abc"]) / m
    eps = np.random.default_rng(seed).standard_normal(n_dofs)
    lam_e = lam * (1 + SIGMA * eps)
    order = np.argsort(lam_e)
    assert np.all(order == np.arange(n_dofs))
    modes = tuple(fu.MeasuredMode(v, std_eigenvalue=std) for v in lam_e)
    return fu.TestData(modes=modes), lam_e


PRIOR_MEAN = np.array([110.0, 190.0, 310.0])
PRIOR_STD = np.array([20.0, 30.0, 40.0])


def closed_form(n_dofs=4):
    """The posterior N(mu, Sigma) and log-evidence of the linear problem: r = B p - c, B = diag(1 /
    (m lam_e sigma)) A, c = 1/sigma; prior N(mu0, S0) truncated to [1, 1000] (log of its mass
    subtracted)."""
    from scipy.stats import norm

    _, A, m = linear_model(n_dofs)
    _, lam_e = linear_data(n_dofs)
    B = A / (m * lam_e * SIGMA)[:, None]
    c = np.full(n_dofs, 1.0 / SIGMA)
    S0 = np.diag(PRIOR_STD ** 2)
    Sigma = np.linalg.inv(B.T @ B + np.linalg.inv(S0))
    mu = Sigma @ (B.T @ c + np.linalg.solve(S0, PRIOR_MEAN))
    C = np.eye(n_dofs) + B @ S0 @ B.T
    d = c - B @ PRIOR_MEAN
    logz = -0.5 * d @ np.linalg.solve(C, d) - 0.5 * np.linalg.slogdet(C)[1] - 0.5 * n_dofs * math.log(2 * math.pi)
    mass = norm.cdf((1000 - PRIOR_MEAN) / PRIOR_STD) - norm.cdf((1 - PRIOR_MEAN) / PRIOR_STD)
    return mu, Sigma, logz - float(np.sum(np.log(mass)))


def linear_priors():
    return {n: Prior("normal", a, b) for n, a, b in zip("abc", PRIOR_MEAN, PRIOR_STD)}


def test_laplace_is_exact_on_the_linear_gaussian_problem():
    model, _, _ = linear_model(priors=linear_priors())
    data, _ = linear_data()
    mu, Sigma, logz = closed_form()
    res = fu.posterior(model, data, method="laplace", starts=4, samples=2000)
    assert res.route == "compiled" and res.noise["kind"] == "stated"
    # random starts also end in local minima elsewhere (where the order pairing swaps): negligible mass
    assert res.modes[0].probability == pytest.approx(1.0, abs=1e-12)
    np.testing.assert_allclose([res.modes[0].parameters[n] for n in "abc"], mu, rtol=1e-9)
    np.testing.assert_allclose(res.modes[0].covariance, Sigma, rtol=1e-7)
    assert res.log_evidence == pytest.approx(logz, abs=1e-7)
    # its draws: the mean within 4 standard errors
    sd = np.sqrt(np.diag(Sigma))
    assert np.all(np.abs(np.array([res.mean[n] for n in "abc"]) - mu) < 4 * sd / math.sqrt(2000))


def _check_moments(res, mu, Sigma, n_eff):
    sd = np.sqrt(np.diag(Sigma))
    mean = np.array([res.mean[n] for n in "abc"])
    std = np.array([res.std[n] for n in "abc"])
    assert np.all(np.abs(mean - mu) < 4 * sd / np.sqrt(n_eff)), (mean - mu) / (sd / np.sqrt(n_eff))
    assert np.all(np.abs(std / sd - 1) < 4 / np.sqrt(2 * n_eff)), (std / sd - 1) * np.sqrt(2 * n_eff)
    corr = Sigma / np.outer(sd, sd)
    # correlations: standard error (1 - rho^2) / sqrt(n_eff)
    assert np.all(np.abs(res.correlation - corr) < 4 * (1 - corr ** 2) / np.sqrt(n_eff) + 1e-12)


def test_tmcmc_matches_the_closed_form_posterior_and_evidence():
    model, _, _ = linear_model(priors=linear_priors())
    data, _ = linear_data()
    mu, Sigma, logz = closed_form()
    res = fu.posterior(model, data, method="tmcmc", samples=1500, tmcmc_steps=10, starts=2, seed=3)
    assert res.success, res.warnings
    _check_moments(res, mu, Sigma, res.diagnostics["ess"])
    assert abs(res.log_evidence - logz) < 5 * res.log_evidence_error, (res.log_evidence, logz, res.log_evidence_error)


def test_mcmc_matches_the_closed_form_posterior():
    model, _, _ = linear_model(priors=linear_priors())
    data, _ = linear_data()
    mu, Sigma, _ = closed_form()
    res = fu.posterior(model, data, method="mcmc", walkers=16, ensembles=2, steps=1200, burn=200, starts=2, seed=5)
    assert res.success, res.warnings
    n_eff = min(res.diagnostics["ess"].values())
    assert n_eff > 400
    _check_moments(res, mu, Sigma, n_eff)
    assert all(r < 1.01 for r in res.diagnostics["rhat"].values())


def test_estimated_noise_gives_the_student_t_posterior():
    """No standard deviation stated, flat prior: the posterior of a linear problem with the noise
    scale integrated out under Jeffreys' prior is a Student t with m - L degrees of freedom, centre
    the least-squares solution and scale² Q_min/(m - L) (BᵀB)⁻¹ (r = B p - c in relative errors)."""
    from scipy.stats import t as student

    n = 6
    model, A, m = linear_model(n)
    data, lam_e = linear_data(n)
    data = fu.TestData(modes=tuple(fu.MeasuredMode(v) for v in lam_e))
    B = A / (m * lam_e)[:, None]
    c = np.ones(n)
    p_hat, *_ = np.linalg.lstsq(B, c, rcond=None)
    q_min = float(np.sum((B @ p_hat - c) ** 2))
    nu = n - 3
    scale = np.sqrt(q_min / nu * np.diag(np.linalg.inv(B.T @ B)))
    res = fu.posterior(model, data, method="mcmc", walkers=16, ensembles=2, steps=2000, burn=400, starts=2, seed=2,
                       level=0.5)
    assert res.noise["kind"] == "estimate" and any("Jeffreys" in n for n in res.notes)
    n_eff = min(res.diagnostics["ess"].values())
    for j, name in enumerate("abc"):
        q75 = student.ppf(0.75, nu)
        lo, hi = res.interval[name]  # the central 50 % interval
        f = student.pdf(q75, nu) / scale[j]  # density at the quartile; s.e. of a quartile sqrt(q(1-q)/n)/f
        tol = 4 * math.sqrt(0.25 * 0.75 / n_eff) / f
        assert abs(lo - (p_hat[j] - q75 * scale[j])) < tol
        assert abs(hi - (p_hat[j] + q75 * scale[j])) < tol
        assert abs(res.median[name] - p_hat[j]) < 4 * math.sqrt(0.25 / n_eff) / (student.pdf(0, nu) / scale[j])
    # the noise scale: s² | d ~ inverse gamma (nu/2, Q_min/2); its median from the predictive draws
    from scipy.stats import invgamma

    s2 = invgamma(nu / 2, scale=q_min / 2)
    med = math.sqrt(s2.median())
    f_s = s2.pdf(med ** 2) * 2 * med  # density of s at its median
    draws = res.noise["draws"]
    assert abs(res.noise["scale"]["median"] - med) < 4 * math.sqrt(0.25 / draws) / f_s


def test_noise_stated_needs_every_std_and_estimation_needs_more_data_than_parameters():
    model, _, _ = linear_model(3)
    data, lam_e = linear_data(3)
    bare = fu.TestData(modes=tuple(fu.MeasuredMode(v) for v in lam_e))
    with pytest.raises(InputError, match="noise 'stated'.*needs a standard deviation for every residual"):
        Posterior(model, bare, noise="stated")
    with pytest.raises(InputError, match="3 residuals for 3 parameters: a noise scale cannot be estimated"):
        Posterior(model, bare)
    assert Posterior(model, data).noise == "stated"
    with pytest.raises(InputError, match="prior given for 'd', which is not an updated parameter"):
        Posterior(model, data, priors={"d": "uniform"})


def test_compiled_and_local_likelihoods_agree(rng):
    model = two_dof()
    modes = fu.model_modes(model)
    data = fu.TestData(modes=tuple(fu.MeasuredMode(lam, ("1:x", "2:x"), modes.shapes[:, k] * (1 + 0.01 * k),
                                                   std_eigenvalue=0.01, std_shape=0.02)
                                   for k, lam in enumerate(modes.eigenvalues)))
    X = 1 + 0.2 * rng.standard_normal((12, 2))
    fast = Posterior(model, data, route="compiled")
    slow = Posterior(model, data, route="local")
    assert (fast.route, slow.route) == ("compiled", "local")
    np.testing.assert_allclose(fast.log_posterior(X), slow.log_posterior(X), rtol=1e-11)
    two = Posterior(model, [data, data], route="compiled")  # repeated tests: the likelihoods multiply
    np.testing.assert_allclose(two.log_likelihood(X) - fast.log_likelihood(X), fast.log_likelihood(X), rtol=1e-11)


# ----------------------------------------------------------------------------------- the paper's two-dof system
M1, M2 = 2.0, 4.0


def eigenvalues_2dof(k1, k2):
    """The two-dof system's eigenvalues by the quadratic formula (independent of femupdate)."""
    a = (k1 + k2) / M1 + k2 / M2
    b = k1 * k2 / (M1 * M2)
    d = np.sqrt(a * a - 4 * b)
    return (a - d) / 2, (a + d) / 2


def quadrature(sigma, k1, k2, log_prior=None, region=None):
    """The posterior on a grid: the share of k1 < 8.5 (or of ``region(K1, K2)``), the means and
    standard deviations, and the log-evidence under the uniform prior on [0, 100]^2 (or
    ``log_prior`` on the grid, normalised)."""
    le = eigenvalues_2dof(8.0, 6.0)
    K1, K2 = np.meshgrid(k1, k2, indexing="ij")
    l1, l2 = eigenvalues_2dof(K1, K2)
    q = ((l1 - le[0]) / (le[0] * sigma)) ** 2 + ((l2 - le[1]) / (le[1] * sigma)) ** 2
    lp = np.full(K1.shape, -math.log(1e4)) if log_prior is None else log_prior(K1, K2)
    w = np.exp(-0.5 * q + lp) / (2 * math.pi)
    da = (k1[1] - k1[0]) * (k2[1] - k2[0])
    z = w.sum() * da
    w = w / w.sum()
    mean = [(w * K).sum() for K in (K1, K2)]
    std = [math.sqrt((w * (K - mu) ** 2).sum()) for K, mu in zip((K1, K2), mean)]
    inside = (K1 < 8.5) if region is None else region(K1, K2)
    return float((w * inside).sum()), mean, std, math.log(z)


def frequencies_only(sigma):
    model = two_dof()
    lam = eigenvalues_2dof(8.0, 6.0)
    return model, fu.TestData(modes=tuple(fu.MeasuredMode(v, std_eigenvalue=sigma) for v in lam))


def test_two_dof_tmcmc_finds_both_solutions_in_the_quadrature_proportion():
    """Frequencies of two modes at 1 % (stated): the two solutions' peaks overlap along the ridge
    between them; TMCMC's share of k1 < 8.5, moments and log-evidence against quadrature."""
    sigma = 0.01
    model, data = frequencies_only(sigma)
    share, mean, std, logz = quadrature(sigma, np.linspace(0.005, 30, 3000), np.linspace(0.005, 20, 2000))
    res = fu.posterior(model, data, method="tmcmc", samples=1500, tmcmc_steps=10, starts=10, seed=1)
    sols = sorted((round(m.parameters["k1"], 6), round(m.parameters["k2"], 6)) for m in res.modes)
    assert sols == [(8.0, 6.0), (9.0, round(16 / 3, 6))]
    n_eff = res.diagnostics["ess"]
    f = float(np.mean(res.samples[:, 0] < 8.5))
    assert abs(f - share) < 4 * math.sqrt(share * (1 - share) / n_eff)
    for j, n in enumerate(("k1", "k2")):
        assert abs(res.mean[n] - mean[j]) < 4 * std[j] / math.sqrt(n_eff)
        assert abs(res.std[n] / std[j] - 1) < 4 / math.sqrt(2 * n_eff) + 0.05  # + the ridge's curvature (not Gaussian)
    assert abs(res.log_evidence - logz) < 5 * res.log_evidence_error


def test_two_dof_solution_probabilities_follow_the_prior():
    """0.2 % noise: two separated peaks.  A uniform prior weighs them by |det J|^-1, equal here
    (the characteristic polynomial's Jacobian has the same magnitude 1/16 at both solutions), so
    each has probability 1/2; a normal prior on k2 centred at 6 makes (8, 6) the more probable, in
    the proportion quadrature gives (0.673).  Laplace within 0.01 of it (its error is of the order
    of the noise), TMCMC within its Monte Carlo error."""
    sigma = 0.002
    model, data = frequencies_only(sigma)
    k1, k2 = np.linspace(7.0, 10.0, 1501), np.linspace(4.6, 6.8, 1101)
    uniform = fu.posterior(model, data, method="laplace", starts=10, seed=0)
    share, *_ = quadrature(sigma, k1, k2)
    assert len(uniform.modes) == 2
    probability = {round(m.parameters["k1"]): m.probability for m in uniform.modes}
    assert probability[8] == pytest.approx(0.5, abs=1e-6)
    assert share == pytest.approx(0.5, abs=0.01)
    prior = Prior("normal", 6.0, 0.5)
    share, *_ = quadrature(sigma, k1, k2, lambda K1, K2: prior.logpdf(K2, 0.0, 100.0) - math.log(100.0))
    lap = fu.posterior(model, data, method="laplace", starts=10, seed=0, priors={"k2": prior})
    probability = {round(m.parameters["k1"]): m.probability for m in lap.modes}
    assert share == pytest.approx(0.673, abs=0.002)  # (along the ridge the prior moves the second mode, to 8.94)
    assert probability[8] == pytest.approx(share, abs=0.01)
    res = fu.posterior(model, data, method="tmcmc", samples=1500, tmcmc_steps=5, starts=10, seed=4,
                       priors={"k2": prior})
    n_eff = res.diagnostics["ess"]
    f = float(np.mean(res.samples[:, 0] < 8.5))
    assert abs(f - share) < 4 * math.sqrt(share * (1 - share) / n_eff)
    # the share of the samples femupdate assigns to (8, 6), against quadrature of the same region
    from femupdate.bayes.laplace import assign

    k = [round(m.parameters["k1"]) for m in res.modes].index(8)

    def region(K1, K2):
        pts = res_x(np.column_stack([K1.ravel(), K2.ravel()]))
        return (assign(res.modes, pts) == k).reshape(K1.shape)

    res_x = lambda P: P / np.array([8.0, 6.0])  # noqa: E731  (the relative parametrisation's x: p / start)
    share_k, *_ = quadrature(sigma, k1, k2, lambda K1, K2: prior.logpdf(K2, 0.0, 100.0) - math.log(100.0), region)
    assert abs(res.mode_fractions[k] - share_k) < 4 * math.sqrt(share_k * (1 - share_k) / n_eff)


@heavy
def test_tmcmc_evidence_error_estimate_across_seeds():
    """The spread of the log-evidence over 10 seeds against the reported error (a lower bound):
    within a factor 2, and the mean within 4 standard errors of quadrature."""
    sigma = 0.01
    model, data = frequencies_only(sigma)
    *_, logz = quadrature(sigma, np.linspace(0.005, 30, 3000), np.linspace(0.005, 20, 2000))
    runs = [fu.posterior(model, data, method="tmcmc", samples=1500, tmcmc_steps=10, starts=4, seed=s) for s in range(10)]
    z = np.array([r.log_evidence for r in runs])
    err = np.mean([r.log_evidence_error for r in runs])
    assert z.std(ddof=1) < 2 * err
    assert abs(z.mean() - logz) < 4 * z.std(ddof=1) / math.sqrt(z.size)


# ----------------------------------------------------------------------------------- nearly linear: Laplace = MCMC
def measured_both(model, sigma_lam, sigma_shape, seed, n_sets=1):
    """Data sets of the two-dof system measured at both dofs, noisy, with their stated stds."""
    modes = fu.model_modes(model)
    rng = np.random.default_rng(seed)
    sets = []
    for _ in range(n_sets):
        sets.append(fu.TestData(modes=tuple(
            fu.MeasuredMode(lam * (1 + sigma_lam * rng.standard_normal()), ("1:x", "2:x"),
                            modes.shapes[:, k] / np.linalg.norm(modes.shapes[:, k]) + sigma_shape * rng.standard_normal(2),
                            std_eigenvalue=sigma_lam, std_shape=sigma_shape)
            for k, lam in enumerate(modes.eigenvalues))))
    return sets


def test_laplace_and_mcmc_agree_on_a_nearly_linear_problem():
    """0.2 % eigenvalue and 0.002 shape noise: the parameters' relative std is a few 0.1 %, so the
    posterior's departure from the Laplace Gaussian (of relative order std², below 1e-4 of the
    values) is far below the Monte Carlo tolerance."""
    model = two_dof()
    (data,) = measured_both(model, 0.002, 0.002, seed=3)
    lap = fu.posterior(model, data, method="laplace", starts=4)
    mc = fu.posterior(model, data, method="mcmc", walkers=16, steps=1000, burn=200, starts=4, seed=8)
    assert len(lap.modes) == 1 and mc.success, mc.warnings
    mode = lap.modes[0]
    for n in ("k1", "k2"):
        n_eff = mc.diagnostics["ess"][n]
        sd = mode.std[n]
        assert abs(mc.mean[n] - mode.parameters[n]) < 4 * sd / math.sqrt(n_eff) + (sd / mode.parameters[n]) ** 2 * 8
        assert abs(mc.std[n] / sd - 1) < 4 / math.sqrt(2 * n_eff) + 2 * sd / mode.parameters[n]
    c_lap = mode.covariance[0, 1] / (mode.std["k1"] * mode.std["k2"])
    assert abs(mc.correlation[0, 1] - c_lap) < 4 * (1 - c_lap ** 2) / math.sqrt(min(mc.diagnostics["ess"].values()))


def test_posterior_contracts_as_one_over_sqrt_n():
    """n repeated tests (independent noise): the posterior standard deviations fall as 1/sqrt(n)
    (Bernstein-von Mises).  MCMC at n = 1 and 16: ratio 4 within its Monte Carlo error (plus 3 %
    for the departure from Gaussian at n = 1, 1 % noise); Laplace over n = 1, 4, 16, 64: slope -1/2
    of log std against log n within 0.02."""
    model = two_dof()
    sets = measured_both(model, 0.01, 0.01, seed=11, n_sets=64)
    stds = []
    for n in (1, 4, 16, 64):
        res = fu.posterior(model, sets[:n], method="laplace", starts=1)
        stds.append([res.modes[0].std[k] for k in ("k1", "k2")])
    slope = np.polyfit(np.log([1, 4, 16, 64]), np.log(np.array(stds)), 1)[0]
    np.testing.assert_allclose(slope, -0.5, atol=0.02)
    one = fu.posterior(model, sets[:1], method="mcmc", walkers=16, steps=800, burn=200, starts=1, seed=1)
    many = fu.posterior(model, sets[:16], method="mcmc", walkers=16, steps=800, burn=200, starts=1, seed=1)
    for k in ("k1", "k2"):
        e1, e16 = one.diagnostics["ess"][k], many.diagnostics["ess"][k]
        ratio = one.std[k] / many.std[k]
        assert abs(ratio / 4 - 1) < 4 * math.sqrt(1 / (2 * e1) + 1 / (2 * e16)) + 0.03, ratio


# ----------------------------------------------------------------------------------- diagnostics
def test_split_rhat_and_integrated_time(rng):
    iid = rng.standard_normal((4000, 8))
    assert split_rhat(iid) < 1.01
    shifted = iid + np.repeat([0.0, 1.0], 4)[None, :]  # R-hat about sqrt(1 + 1/4)
    assert split_rhat(shifted) > 1.1
    # AR(1) with rho = 0.9: tau = (1 + rho) / (1 - rho) = 19
    rho, n, W = 0.9, 40000, 8
    x = np.zeros((n, W))
    e = rng.standard_normal((n, W)) * math.sqrt(1 - rho ** 2)
    for t in range(1, n):
        x[t] = rho * x[t - 1] + e[t]
    tau, reliable = integrated_time(x)
    assert tau == pytest.approx(19.0, rel=0.15) and reliable
    ess, tau2, ok = effective_sample_size(x[None, :, :, None])
    assert ess[0] == pytest.approx(n * W / tau, rel=1e-12) and ok[0]


def test_mcmc_warns_when_the_chains_are_too_short():
    model, _, _ = linear_model(priors=linear_priors())
    data, _ = linear_data()
    res = fu.posterior(model, data, method="mcmc", walkers=8, ensembles=1, steps=40, burn=10, segment=20, starts=1)
    assert not res.success
    assert any("effective sample size below 400" in w for w in res.warnings)


def test_ensemble_sampler_is_told_apart_from_several_solutions():
    model, data = frequencies_only(0.002)
    res = fu.posterior(model, data, method="mcmc", walkers=8, ensembles=1, steps=60, burn=20, starts=6)
    assert any("2 solutions are probable: the ensemble sampler does not move between" in w for w in res.warnings)
