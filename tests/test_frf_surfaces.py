"""Residual surfaces (eqs. 33, 34; Figures 5-7): the vectorised grids against a per-point loop,
8-neighbour local minima on functions with known minima, spikes on resonances, the paper
sections' numbers and figures."""

import numpy as np
import pytest

from femupdate import MeasuredMode, TestData, model_modes
from femupdate.examples import three_dof, two_dof
from femupdate.frf import Damping, frf, simulate
from femupdate.frf.surfaces import (Surface, distinct_minima, frf_residuals, frf_surface, local_minima,
                                    modal_surface)


def loop_frf_r2(model, data, names, x, y, damping=None, residual="linear"):
    """Eq. 34 point by point through the public FRF simulation (the second route)."""
    out = np.empty((x.size, y.size))
    for i, a in enumerate(x):
        for j, b in enumerate(y):
            _, xa = frf(model, data.omega, data.force, data.dofs, {names[0]: a, names[1]: b}, damping)
            if residual == "linear":
                d = xa - data.response
            elif residual == "relative":
                d = (xa - data.response) / np.abs(data.response)
            else:
                d = np.log(np.abs(xa)) - np.log(np.abs(data.response))
            out[i, j] = np.sum(np.abs(d) ** 2)
    return out


def loop_modal_r2(model, data, x, y):
    """Eq. 33 point by point from model_modes (shapes scaled to 1 at dof 1, pairing by order)."""
    lam_e = data.eigenvalues
    out = np.empty((x.size, y.size))
    for i, a in enumerate(x):
        for j, b in enumerate(y):
            mm = model_modes(model, {"k1": a, "k2": b}, normalisation="ref:1:x")
            r = np.sum(((lam_e - mm.eigenvalues) / mm.eigenvalues) ** 2)
            for k, mode in enumerate(data.modes):
                r += np.sum((mode.shape[1:] / mode.shape[0] - mm.shapes[1:, k]) ** 2)
            out[i, j] = r
    return out


@pytest.mark.parametrize("residual", ["linear", "relative", "log"])
def test_frf_surface_equals_the_per_point_loop(residual):
    m = three_dof()
    damping = Damping(eta=0.05)
    w = np.array([15.0, 30.0, 50.0, 70.0])
    data = simulate(m, w, {"3:x": 1.0}, response=["1:x", "3:x"], damping=damping, noise=0.01, seed=1)
    x, y = np.linspace(600, 1400, 7), np.linspace(1500, 2500, 5)
    s = frf_surface(m, data, ["k1", "k2"], x, y, damping=damping, residual=residual)
    np.testing.assert_allclose(s.values, loop_frf_r2(m, data, ["k1", "k2"], x, y, damping, residual), rtol=1e-10)


def test_modal_surface_equals_the_per_point_loop():
    m = two_dof()
    modes = model_modes(m, normalisation="ref:1:x")
    data = TestData(modes=tuple(MeasuredMode(modes.eigenvalues[i], m.dofs, modes.shapes[:, i]) for i in range(2)))
    x, y = np.linspace(3, 13, 6), np.linspace(1, 11, 4)
    s = modal_surface(m, data, ["k1", "k2"], x, y, ref_dof="1:x")
    np.testing.assert_allclose(s.values, loop_modal_r2(m, data, x, y), rtol=1e-9, atol=1e-14)


def test_points_exactly_on_a_resonance_are_inf():
    m = two_dof()
    data = simulate(m, [0.5], {"1:x": 1.0})
    # k1 = 3.5, k2 = 1.5: det(K - 0.25 M) = (3.5 + 1.5 - 0.5)(1.5 - 1) - 1.5^2 = 0 exactly
    s = frf_surface(m, data, ["k1", "k2"], [3.5, 4.0], [1.5, 2.0])
    assert np.isinf(s.values[0, 0]) and np.all(np.isfinite(s.values.ravel()[1:]))
    assert s.summary()["singular_points"] == 1
    assert np.isinf(frf_residuals(m, data, ["k1", "k2"], np.array([[3.5, 1.5]]))).all()


def test_local_minima_of_known_functions():
    x = np.linspace(-1, 1, 81)
    X, Y = np.meshgrid(x, x, indexing="ij")
    # minima of cos(3 pi x) cos(3 pi y) - ... : wells where cos products are -1
    f = np.cos(3 * np.pi * X) * np.cos(3 * np.pi * Y) + 0.01 * (X**2 + Y**2)
    mins = local_minima(f)
    interior = [(i, j) for i, j, e in mins if not e]
    # cos(3 pi x) cos(3 pi y) = -1 at (x, y) with 3x, 3y integers of opposite parity inside (-1, 1)
    expected = {(a, b) for a in (-2, -1, 0, 1, 2) for b in (-2, -1, 0, 1, 2) if (a + b) % 2 == 1}
    found = {(round(3 * x[i]), round(3 * x[j])) for i, j in interior}
    assert found == expected
    flat = np.zeros((5, 5))
    assert local_minima(flat) == []  # a plateau has no strict minimum
    edge = np.add.outer(np.arange(5.0), np.arange(5.0))
    assert local_minima(edge) == [(0, 0, True)]
    nan = edge.copy()
    nan[0, 0] = np.inf
    assert (0, 0, True) not in local_minima(nan)


def test_distinct_minima_merge_grid_artefacts():
    m = two_dof()
    data = simulate(m, 0.4 * np.arange(1, 8), {"1:x": 1.0})
    s = frf_surface(m, data, ["k1", "k2"], np.linspace(3, 13, 101), np.linspace(1, 11, 101), truth=(8, 6))
    grid = s.summary()
    found = distinct_minima(s, lambda P: frf_residuals(m, data, ["k1", "k2"], P))
    assert found[0]["k1"] == pytest.approx(8.0, rel=1e-8) and found[0]["value"] < 1e-20
    assert grid["local_minima"] > sum(not d["on_boundary"] for d in found)  # grid minima along the valley merge


def test_surface_validation():
    m = two_dof()
    data = simulate(m, [0.5, 1.0], {"1:x": 1.0})
    from femupdate import InputError

    with pytest.raises(InputError, match="exactly two parameters"):
        frf_surface(m, data, ["k1"], [1, 2], [1, 2])
    with pytest.raises(InputError, match="must differ"):
        frf_surface(m, data, ["k1", "k1"], [1, 2], [1, 2])
    with pytest.raises(InputError, match="not in model"):
        frf_surface(m, data, ["k1", "k9"], [1, 2], [1, 2])
    with pytest.raises(InputError, match="at least two finite values"):
        frf_surface(m, data, ["k1", "k2"], [1], [1, 2])


# ------------------------------------------------------------------------------- paper sections
def test_figure4_and_eq32_sections(tmp_path):
    from femupdate.paper.frf_sections import eq32_receptance_sensitivity, figure4_frf_condition

    f4 = figure4_frf_condition(tmp_path, figures=True)
    assert f4["agrees_with_paper"] and f4["reproduces_description"] == {"1:x": True, "2:x": False}
    assert f4["selection"]["condition_number"] < f4["selection"]["paper_lines_condition"]
    assert (tmp_path / f4["figure_file"]).stat().st_size > 10_000
    e = eq32_receptance_sensitivity(tmp_path, figures=False)
    assert e["agrees_with_paper"] and e["fd_vs_brandon"]["max_far_from_resonance"] < 1e-8


def test_surface_sections_count_minima(tmp_path):
    from femupdate.paper.frf_sections import figure5_modal_surface, figure6_frf_surface, figure7_frf_surface

    f5 = figure5_modal_surface(tmp_path, figures=False)
    f6 = figure6_frf_surface(tmp_path, figures=False)
    f7 = figure7_frf_surface(tmp_path, figures=False)
    assert f5["minimum"] == {"k1": 8.0, "k2": 6.0, "value": 0.0} and f5["n_distinct_interior"] == 1
    n6 = f6["by_force"]["1:x"]["n_distinct_interior"]
    n7 = f7["by_force"]["1:x"]["n_distinct_interior"]
    assert 1 < n6 <= n7
    assert f6["by_force"]["1:x"]["singular_points"] > 0  # the paper's "large spikes"
    assert all(s["agrees_with_paper"] for s in (f5, f6, f7))


def test_convergence_section_with_few_starts(tmp_path):
    from femupdate.paper.frf_sections import modal_vs_frf_convergence

    out = modal_vs_frf_convergence(tmp_path, figures=True, starts=20, seed=3)
    assert out["same_starts"]
    c = out["cases"]
    assert c["modal, both dofs"]["reached_truth"] == 20
    assert c["frf 7 lines x 0.4 rad/s, both dofs"]["reached_truth"] < 10
    assert out["global_search"]["reached_truth"] == 5
    assert (tmp_path / out["figure_file"]).exists()


def test_plots_take_and_return_axes():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from femupdate.plot.frf import contour_axes, frf_axes, starts_axes, surface_axes

    s = Surface(("a", "b"), np.arange(3.0), np.arange(4.0), np.arange(12.0).reshape(3, 4) + 1, "test", (1.0, 2.0))
    fig = plt.figure()
    ax3 = fig.add_subplot(1, 3, 1, projection="3d")
    assert surface_axes(s, ax3) is ax3
    ax = fig.add_subplot(1, 3, 2)
    assert contour_axes(s, ax) is ax
    ax2 = fig.add_subplot(1, 3, 3)
    assert starts_axes(np.ones((3, 2)), [True, False, True], "t", ax=ax2) is ax2
    _, ax4 = plt.subplots()
    assert frf_axes(np.arange(3.0) + 1, ["1:x"], np.ones((3, 1)), np.ones((3, 1)), ax4) is ax4
    plt.close("all")
