"""Priors per parameter (femupdate.priors): normalised over the bounds, exact derivatives, draws of
the truncated distributions, and the model file's ``prior`` key with its refusals."""

import math

import numpy as np
import pytest
from scipy import integrate, stats

import femupdate as fu
from femupdate import InputError
from femupdate.priors import Prior, parse_prior

PRIORS = [Prior("uniform"), Prior("normal", 8.0, 1.5), Prior("lognormal", 6.0, 0.3), Prior("normal", 8.0, 0.5)]
BOUNDS = [(5.0, 9.0), (0.0, 100.0), (3.0, 20.0), (9.0, 11.0)]  # the last: all in the prior's upper tail


@pytest.mark.parametrize("prior", PRIORS, ids=str)
@pytest.mark.parametrize("bounds", BOUNDS)
def test_density_integrates_to_one_over_the_bounds(prior, bounds):
    lo, hi = bounds
    total, err = integrate.quad(lambda v: math.exp(prior.logpdf(np.array([v]), lo, hi)[0]), lo, hi, limit=200,
                                points=[prior.a] if lo < prior.a < hi else None)
    assert total == pytest.approx(1.0, abs=1e-8)
    assert np.all(prior.logpdf(np.array([lo - 1e-9, hi + 1e-9]), lo, hi) == -np.inf)


@pytest.mark.parametrize("prior", PRIORS, ids=str)
def test_derivatives_equal_central_differences(prior):
    p = np.array([5.5, 7.0, 8.5])
    d1, d2 = prior.derivatives(p)
    h = 1e-4
    f = lambda v: prior.logpdf(v, 0.0, 100.0) if prior.kind != "uniform" else prior.logpdf(v, 5.0, 9.0)  # noqa: E731
    np.testing.assert_allclose(d1, (f(p + h) - f(p - h)) / (2 * h), atol=1e-7)
    np.testing.assert_allclose(d2, (f(p + h) - 2 * f(p) + f(p - h)) / h ** 2, atol=2e-5)


@pytest.mark.parametrize("bounds", [(5.0, 9.0), (9.0, 11.0), (-50.0, 50.0)])
def test_truncated_normal_draws_have_scipys_moments(bounds, rng):
    """Draws by the inverse distribution against scipy.stats.truncnorm (an independent route);
    tolerance 4 standard errors of the mean and of the variance."""
    prior = Prior("normal", 8.0, 1.5)
    lo, hi = bounds
    x = prior.sample(rng, 40000, lo, hi)
    ref = stats.truncnorm((lo - 8.0) / 1.5, (hi - 8.0) / 1.5, loc=8.0, scale=1.5)
    assert np.all((x >= lo) & (x <= hi))
    sd = ref.std()
    assert abs(x.mean() - ref.mean()) < 4 * sd / math.sqrt(x.size)
    assert abs(x.var() - ref.var()) < 4 * ref.var() * math.sqrt(2 / x.size) * 1.5  # kurtosis below a normal's x1.5


def test_lognormal_draws_have_the_median_and_log_std(rng):
    x = Prior("lognormal", 6.0, 0.2).sample(rng, 40000, 0.0, 1e6)
    assert abs(np.median(np.log(x)) - math.log(6.0)) < 4 * 0.2 * 1.2533 / math.sqrt(x.size)
    assert abs(np.log(x).std() - 0.2) < 4 * 0.2 / math.sqrt(2 * x.size)


def test_text_and_table_forms():
    assert parse_prior("normal(8, 1.5)", "w") == Prior("normal", 8.0, 1.5)
    assert parse_prior(" LogNormal( 6 ,0.2 ) ", "w") == Prior("lognormal", 6.0, 0.2)
    assert parse_prior({"type": "normal", "mean": 8, "std": 2}, "w") == Prior("normal", 8.0, 2.0)
    assert parse_prior("uniform", "w").kind == "uniform"
    assert str(Prior("lognormal", 6, 0.2)) == "lognormal(6, 0.2)"


@pytest.mark.parametrize("spec, message", [
    ("gauss(8, 1)", "unknown prior 'gauss'"),
    ("normal(8)", "normal takes 2 number"),
    ("normal(8, -1)", "std must be > 0"),
    ("lognormal(-2, 0.1)", "median must be > 0"),
    ("normal(8, x)", r"std of 'normal\(8, x\)' is not a number"),
    ({"type": "normal", "mean": 8}, "missing: std"),
    ({"type": "normal", "mean": 8, "std": 1, "sd": 2}, "unknown key"),
    ({"type": "normal", "mean": True, "std": 1}, "mean must be a number"),
    (3.0, "a prior is a string"),
])
def test_bad_priors_are_refused_by_name(spec, message):
    with pytest.raises(InputError, match=message) as info:
        parse_prior(spec, "model.toml: [parameters.k1] prior")
    assert str(info.value).startswith("model.toml: [parameters.k1] prior")


TOML = """
[parameters.k1]
value = 8.0
bounds = [0.0, 100.0]
prior = {{ type = "normal", mean = 8.0, std = 1.0 }}
[parameters.k2]
value = 6.0
bounds = {bounds}
prior = {prior}
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
dofs = ["1:x", "2:x"]
m = 2.0
"""


def test_model_file_priors(tmp_path):
    p = tmp_path / "m.toml"
    p.write_text(TOML.format(bounds="[1.0, 20.0]", prior='"lognormal(6, 0.1)"'))
    model = fu.load_model(p)
    assert [q.prior for q in model.parameters] == [Prior("normal", 8.0, 1.0), Prior("lognormal", 6.0, 0.1)]
    # the updated model file keeps them (the writer passes the tables through)
    from femupdate.io.model_write import write_updated_model

    out = tmp_path / "out.toml"
    write_updated_model(p, out, {"k1": 8.1}, {"command": "test"})
    assert [q.prior for q in fu.load_model(out).parameters] == [q.prior for q in model.parameters]


@pytest.mark.parametrize("bounds, prior, message", [
    ("[1.0, 20.0]", '"normal(6)"', r"\[parameters.k2\] prior: normal takes 2 number"),
    ("[1.0, 20.0]", "5", r"\[parameters.k2\] prior: a prior is a string"),
    ("[-inf, 20.0]", '"uniform"', "prior uniform needs finite bounds"),
    ("[200.0, 300.0]", '"normal(6, 0.001)"', "no probability within the bounds"),
])
def test_model_file_refuses_bad_priors(tmp_path, bounds, prior, message):
    p = tmp_path / "m.toml"
    p.write_text(TOML.format(bounds=bounds, prior=prior).replace("value = 6.0", "value = 250.0" if "200" in bounds
                                                                  else "value = 6.0"))
    with pytest.raises(InputError, match=message):
        fu.load_model(p)


def test_uniform_prior_needs_finite_bounds():
    s = fu.Structure()
    with pytest.raises(InputError, match="parameter 'k': prior uniform needs finite bounds"):
        s.parameter("k", 1.0, prior="uniform")
