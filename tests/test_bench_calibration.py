"""The calibration benchmark's machinery (benchmarks/bench_calibration.py, issue 27 item 7) on 2
seeds of the smallest family: the table's shape, and its binomial band against scipy.stats.binom's
own distribution function (a second route: the band's ends hold at least 0.5 % each side)."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import numpy as np
import pytest
from scipy import stats

PATH = Path(__file__).resolve().parents[1] / "benchmarks" / "bench_calibration.py"


@pytest.fixture(scope="module")
def bench():
    spec = importlib.util.spec_from_file_location("bench_calibration", PATH)
    mod = importlib.util.module_from_spec(spec)
    sys.modules["bench_calibration"] = mod
    spec.loader.exec_module(mod)
    return mod


@pytest.mark.parametrize("p, n", [(0.6827, 16), (0.95, 16), (0.6827, 1600), (0.95, 400), (0.1, 7)])
def test_binomial_band_is_the_central_99_percent(bench, p, n):
    lo, hi = bench.binomial_band(p, n)
    klo, khi = round(lo * n), round(hi * n)
    cdf = stats.binom.cdf
    # the smallest count with P(X <= k) >= 0.005, the smallest with P(X <= k) >= 0.995
    assert cdf(klo, n, p) >= 0.005 and (klo == 0 or cdf(klo - 1, n, p) < 0.005)
    assert cdf(khi, n, p) >= 0.995 and (khi == 0 or cdf(khi - 1, n, p) < 0.995)
    assert stats.binom.pmf(np.arange(klo, khi + 1), n, p).sum() >= 0.99


def test_data_are_the_true_structures_modes(bench):
    fam = bench.make_family("chain")
    data = bench.make_data(fam, 0, True)
    lam, _ = bench._true_modes(fam)
    got = np.array([m.eigenvalue for m in data.modes])
    assert np.all(np.abs(np.sqrt(got / lam) - 1) < 5 * bench.FREQ_NOISE)
    err = bench.make_family("model-error")
    assert np.all(bench._true_modes(err)[0] > lam)  # the missing spring stiffens every mode


def test_table_shape_on_two_seeds_of_the_chain(bench):
    res = bench.run(["chain"], seeds=2, damage_seeds=0, distinct_seeds=0, settings=("stated",), log=lambda s: None)
    r = res["families"]["chain/stated"]
    for what in ("update", "posterior"):
        s = r[what]
        assert s["seeds"] == 2 and s["n"] == 16 and s["failed"] == 0
        assert 0 <= s["coverage68"] <= s["coverage95"] <= 1 and s["rms_z"] > 0
        assert s["band95"] == bench.binomial_band(0.95, 16)
    table = bench.markdown(res).splitlines()
    assert len(table) == 4 and all(line.count("|") == 9 for line in table)
