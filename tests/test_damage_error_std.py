"""damage's standard errors carry what they rest on (issue 27): the bootstrap spread of B
replicates (B − 1 degrees of freedom) at noise levels estimated with ν degrees of freedom
underestimates the error's standard deviation by E[σ²/s²] = ν/(ν − 2) · (B − 1)/(B − 3)
(femupdate.damage.judge.error_std).  Checked by a second route: a Monte Carlo of that very
situation (a normal error, a noise level from a χ²_ν estimate, a spread of B normal replicates),
whose errors over the standard error must have mean square 1.
"""

import math

import numpy as np
import pytest

from femupdate.damage.judge import Judgement, error_std


def _verdict(se: dict) -> Judgement:
    return Judgement("confirmed", [], "", [], {"standard_error": dict(se)}, np.zeros(1), np.zeros(0, int))


@pytest.mark.parametrize("nu,B", [(4.0, 20), (12.0, 10), (math.inf, 20)])
def test_errors_over_the_standard_error_have_mean_square_one(nu, B):
    rng = np.random.default_rng(1)
    S = 40000
    err = rng.standard_normal(S)  # the change's error, σ = 1
    level = np.sqrt(rng.chisquare(nu, S) / nu) if math.isfinite(nu) else np.ones(S)  # the noise level as estimated
    spread = level * np.std(rng.standard_normal((S, B)), axis=1, ddof=1)  # the bootstrap at that level
    factor = error_std(_verdict({"a": 1.0}), {"a": nu} if math.isfinite(nu) else {}, B).confidence["standard_error"]["a"]
    z = err / (spread * factor)
    assert float(np.mean(z ** 2)) == pytest.approx(1.0, abs=0.04)
    # without the factor the mean square is what the benchmark saw (above 1)
    assert float(np.mean((err / spread) ** 2)) > 1.05


def test_the_record_keeps_the_spread_and_gives_the_degrees_of_freedom():
    v = error_std(_verdict({"a": 0.01, "b": 0.02}), {"a": 8.0}, 20)
    c = v.confidence
    assert c["bootstrap_spread"] == {"a": 0.01, "b": 0.02}
    assert c["standard_error_dof"]["a"] == pytest.approx(1 / (1 / 8 + 1 / 19))
    assert c["standard_error_dof"]["b"] == pytest.approx(c["standard_error_dof"]["a"])  # not covered: the smallest ν
    assert c["standard_error"]["a"] == pytest.approx(0.01 * math.sqrt(8 / 6 * 19 / 17))
    # stated noise: only the bootstrap's own uncertainty; too few replicates: unbounded
    assert error_std(_verdict({"a": 0.01}), {}, 20).confidence["standard_error"]["a"] == pytest.approx(0.01 * math.sqrt(19 / 17))
    assert math.isinf(error_std(_verdict({"a": 0.01}), {}, 3).confidence["standard_error"]["a"])
