"""The FRF residual "auto": a log-magnitude stage from the start, then the linear residual (eq. 34)
from its solution.  On analyser-style data (a 0 Hz line, 1 % noise and a noise floor) the linear
residual alone falls into local minima from starts 20-40 % off; auto must reach the linear
residual's own best fit (the one reached from the truth) from there, report the linear
residual's cost, and fall back to the linear residual, saying so, where a log stage cannot run."""

import numpy as np
import pytest

from femupdate import InputError, MeasuredMode, TestData, model_modes
from femupdate.examples import chain
from femupdate.frf import Damping, simulate
from femupdate.testdata import FRFData
from femupdate.updating import frf_multistart, frf_update, update

K4 = np.array([1.0e5, 1.8e5, 1.5e5, 1.2e5])
M4 = np.array([1.0, 1.2, 0.8, 1.1])
DAMPING = Damping(eta=0.02)


@pytest.fixture(scope="module")
def analyser():
    """A 4-dof chain's receptances as an analyser exports them: 101 lines from 0 Hz to 1.2 x the
    highest mode, force at the tip, every dof measured, 1 % complex noise and a floor of 1e-4 of
    the peak."""
    model = chain(K4, M4, bounds=(1e3, 1e7))
    f_hz = np.linspace(0.0, 1.2 * model_modes(model).frequencies_hz[-1], 101)
    clean = simulate(model, 2 * np.pi * f_hz, {"4:x": 1.0}, damping=DAMPING).response
    rng = np.random.default_rng(1)
    cn, fl = ((rng.standard_normal(clean.shape) + 1j * rng.standard_normal(clean.shape)) / np.sqrt(2) for _ in "ab")
    x = clean * (1 + 0.01 * cn) + 1e-4 * np.abs(clean).max() * fl
    data = FRFData(2 * np.pi * f_hz, {"4:x": 1.0}, tuple(model.dofs), x)
    best = frf_update(model, data, x0=dict(zip(model.parameter_names, K4)), residual="linear", damping=DAMPING)
    return model, data, best


def start(model, factors):
    return dict(zip(model.parameter_names, K4 * np.asarray(factors)))


@pytest.mark.parametrize("factors", [[1.2, 1.2, 1.2, 1.2], [0.6, 1.4, 0.7, 1.3]])
def test_auto_reaches_the_linear_best_fit_where_linear_alone_does_not(analyser, factors):
    model, data, best = analyser
    lin = frf_update(model, data, x0=start(model, factors), residual="linear", damping=DAMPING)
    assert np.max(np.abs(lin.x / best.x - 1)) > 0.1  # a local minimum of the linear residual
    res = frf_update(model, data, x0=start(model, factors), residual="auto", damping=DAMPING)
    assert res.success and res.residual == "linear"
    np.testing.assert_allclose(res.x, best.x, rtol=1e-6)
    assert res.cost == pytest.approx(best.cost, rel=1e-8)  # the linear residual's cost (divided by the RMS)
    assert res.start == pytest.approx(start(model, factors))  # the caller's start, not the log stage's solution
    note = res.notes[-1]
    assert note.startswith("residual auto: a log-magnitude stage from the start (") and "then the linear" in note
    log_nfev = int(note.split("(")[1].split(" evaluations")[0])
    linear_nfev = int(note.split("from there (")[1].split(" evaluations")[0])
    assert res.nfev == log_nfev + linear_nfev and log_nfev > 1 and linear_nfev > 1
    # the second stage is exactly the linear residual from the log residual's solution
    first = frf_update(model, data, x0=start(model, factors), residual="log", damping=DAMPING)
    second = frf_update(model, data, x0=dict(zip(first.names, first.x)), residual="linear", damping=DAMPING)
    np.testing.assert_array_equal(res.x, second.x)
    assert res.cost == second.cost and log_nfev == first.nfev


def test_auto_keeps_the_std_for_the_linear_stage(analyser):
    """A stated std (of the linear residual entries) is that of the linear stage: absolute
    covariance, cost half the chi-square there; the log stage does without it."""
    model, data, best = analyser
    sigma = 1e-4 * np.abs(data.response).max()
    res = frf_update(model, data, x0=start(model, [1.2] * 4), residual="auto", damping=DAMPING, measurement_std=sigma)
    lin = frf_update(model, data, x0=dict(zip(best.names, best.x)), residual="linear", damping=DAMPING,
                     measurement_std=sigma)
    np.testing.assert_allclose(res.x, lin.x, rtol=1e-6)
    assert res.diagnostics.absolute and res.cost == pytest.approx(lin.cost, rel=1e-8)
    assert not any("RMS" in n for n in res.notes)


def test_auto_falls_back_to_linear_where_log_cannot_run():
    """A measured zero in a live channel: the log stage is refused; auto runs the linear residual
    from the start and says why.  With regularization: the linear residual alone, said too."""
    model = chain(K4[:2], M4[:2], bounds=(1e3, 1e7))
    w = np.sqrt(model_modes(model).eigenvalues[0]) * np.array([0.5, 0.8, 1.3, 1.6, 2.5])
    data = simulate(model, w, {"2:x": 1.0})
    resp = data.response.copy()
    resp[0, 0] = 0.0
    zero = FRFData(data.omega, dict(data.force), data.dofs, resp)
    x0 = start(model, [1.1, 0.9, 1, 1])
    with pytest.raises(InputError, match="log-magnitude residuals need non-zero measured values"):
        frf_update(model, zero, x0=x0, residual="log")
    res = frf_update(model, zero, x0=x0, residual="auto")
    lin = frf_update(model, zero, x0=x0, residual="linear")
    np.testing.assert_array_equal(res.x, lin.x)
    assert res.notes[-1].startswith("residual auto: the log-magnitude stage could not run (log-magnitude residuals need")
    assert res.nfev == lin.nfev
    reg = frf_update(model, data, x0=x0, residual="auto", regularization=1e-3)
    np.testing.assert_array_equal(reg.x, frf_update(model, data, x0=x0, residual="linear", regularization=1e-3).x)
    assert reg.notes[-1].startswith("residual auto with regularization: the linear residual (eq. 34) alone")


def test_auto_through_update_with_modes_and_several_excitations(analyser):
    """update() with FRFs and modes (a mix), and frf_update with two excitations (blocks): the
    stages run on the whole problem, the result is the linear residual's from the log stage's
    solution."""
    model, data, best = analyser
    modes = model_modes(model)
    both = TestData(modes=(MeasuredMode(modes.eigenvalues[0], tuple(model.dofs), modes.shapes[:, 0]),), frf=data)
    x0 = start(model, [1.2] * 4)
    res = update(model, both, x0=x0, frf_options={"residual": "auto", "damping": DAMPING})
    first = update(model, both, x0=x0, frf_options={"residual": "log", "damping": DAMPING})
    second = update(model, both, x0=dict(zip(first.names, first.x)), frf_options={"residual": "linear",
                                                                                    "damping": DAMPING})
    np.testing.assert_array_equal(res.x, second.x)
    assert [b["kind"] for b in res.blocks] == ["modes", "frf"] and res.nfev == first.nfev + second.nfev
    assert res.notes[-1].startswith("residual auto: a log-magnitude stage")
    sets = TestData(frf_sets=(data, simulate(model, data.omega[1:], {"2:x": 1.0}, damping=DAMPING, noise=0.01, seed=2)))
    two = frf_update(model, sets, x0=x0, residual="auto", damping=DAMPING)
    assert len(two.blocks) == 2 and two.success and two.notes[-1].startswith("residual auto: a log-magnitude stage")
    np.testing.assert_allclose(two.x, best.x, rtol=0.02)


def test_auto_in_a_multistart_study_and_a_bad_residual(analyser):
    _, data, best = analyser
    model = chain(K4, M4, bounds=(5e4, 3e5))  # random starts within [0.28, 3] x the truth
    ms = frf_multistart(model, data, starts=3, seed=5, residual="auto", damping=DAMPING, max_nfev=100)
    assert ms.converged == 3
    for run in ms.runs:
        np.testing.assert_allclose(run.x, best.x, rtol=1e-6)
    with pytest.raises(InputError, match="unknown FRF residual 'cubic': use linear, relative, log, auto"):
        frf_update(model, data, residual="cubic")
    with pytest.raises(InputError, match="unknown FRF residual 'cubic': use linear, relative, log, auto"):
        update(model, TestData(frf=data), frf_options={"residual": "cubic"})



def test_auto_is_the_default_of_the_commands(tmp_path, capsys):
    """frf-update and update run auto unless --residual says otherwise; the JSON names the linear
    residual (whose cost it reports) and a note the stages."""
    import json

    from test_cli import TWO_DOF, run

    model = tmp_path / "two.toml"
    model.write_text(TWO_DOF)
    data = tmp_path / "d.json"
    code, _, err = run(["frf", str(model), "--force", "1:x", "--omega", "0.4:2.8:7", "--damping", "eta=0.02",
                        "--noise", "0.01", "--seed", "1", "--test-data", str(data)], capsys)
    assert code == 0, err
    outs = {}
    for cmd in ("frf-update", "update"):
        for extra in ([], ["--residual", "linear"]):
            code, out, err = run([cmd, str(model), str(data), "--set", "k1=6,k2=8", "--damping", "eta=0.02",
                                  *extra, "--json", "-"], capsys)
            assert code == 0, err
            outs[cmd, bool(extra)] = res = json.loads(out)
            assert res["residual"] == "linear"
            stages = [n for n in res["notes"] if n.startswith("residual auto: a log-magnitude stage")]
            assert len(stages) == (0 if extra else 1)
            assert any(n.startswith("frf: no standard deviation stated; the linear FRF residuals are divided by the "
                                    "RMS measured response") for n in res["notes"])
    assert outs["frf-update", False]["parameters"] == outs["update", False]["parameters"]
    np.testing.assert_allclose([outs["frf-update", False]["parameters"][k] for k in ("k1", "k2")], [8, 6], rtol=0.02)
