"""The layout criterion of a grounded spring chain (femupdate.uniqueness.chain)."""

import itertools

import numpy as np
import pytest

from femupdate.uniqueness.chain import chain_rank_bound, chain_segments, chain_sensitivity

K6 = (1000.0, 1800.0, 1500.0, 1200.0, 900.0, 1600.0)
M6 = (1.0, 1.2, 0.8, 1.1, 0.9, 1.0)


def _rank(S):
    s = np.linalg.svd(S, compute_uv=False)
    return int(np.sum(s > max(S.shape) * np.finfo(float).eps * s[0]))


def test_closed_forms_of_the_consecutive_layouts():
    N = 6
    for n in range(1, N + 1):
        for m in range(1, N + 1):
            assert chain_rank_bound(N, range(1, n + 1), m) == min(m * n, n + min(m, N - n))  # from the ground
            assert chain_rank_bound(N, range(N - n + 1, N + 1), m) == min(m * n, n - 1 + min(m, N - n + 1))  # free end


def test_bound_equals_the_numerical_rank_for_every_layout():
    for n in range(1, 7):
        for dofs in itertools.combinations(range(1, 7), n):
            for m in range(1, 7):
                S = chain_sensitivity(K6, M6, dofs, m)
                assert _rank(S) == min(chain_rank_bound(6, dofs, m), m * n), (dofs, m)


def test_analytic_sensitivity_equals_central_differences():
    for dofs, m in (((1, 3, 6), 2), ((2, 5), 4), ((1, 2, 3, 4, 5, 6), 3)):
        for shapes in ("scaled", "mass"):
            for eigen in ("relative", "absolute"):
                a = chain_sensitivity(K6, M6, dofs, m, shapes=shapes, eigen=eigen)
                f = chain_sensitivity(K6, M6, dofs, m, shapes=shapes, eigen=eigen, derivative="central")
                np.testing.assert_allclose(a, f, atol=1e-6 * np.abs(a).max())


def test_segments_and_bad_input():
    assert chain_segments(6, [2, 5]) == [(2, (2,)), (3, (2, 5)), (1, (5,))]
    with pytest.raises(ValueError, match="1..6"):
        chain_segments(6, [0, 3])
    with pytest.raises(ValueError, match="unknown option"):
        chain_sensitivity(K6, M6, (1, 2), 2, shapes="unit")
