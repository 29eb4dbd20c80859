"""The formulations of the modal residuals (``formulation`` / ``--formulation``): ``shapes`` (the
default), ``mac`` and ``dynamic`` — each with an exact Jacobian (against finite differences),
each recovering the truth from noise-free data, each weighed by the per-mode weights and
standard deviations, and each refusing what it cannot take with one clear message."""

import json
import math
import tomllib

import numpy as np
import pytest

from femupdate import InputError, MeasuredMode, Structure, TestData, model_modes, rules
from femupdate.cli import main
from femupdate.damage import element_parameters
from femupdate.examples import chain, truss_model_toml, two_dof
from femupdate.updating import Problem, multistart, update
from femupdate.updating import dynamic as dynamic_module
from femupdate.updating.batched import BatchRun, unsupported

FORMULATIONS = ("shapes", "mac", "dynamic")
K6 = np.array([1000.0, 1800.0, 1500.0, 1200.0, 900.0, 1600.0])
M6 = np.array([1.0, 1.2, 0.8, 1.1, 0.9, 1.0])
K6_START = K6 * [0.8, 1.2, 0.9, 1.1, 1.05, 0.95]
SIX_DOFS = ("2:x", "4:x", "6:x")


def modes_of(truth, dofs, n, scale=1.0, **per_mode):
    """Noise-free test modes of ``truth``: the lowest ``n`` at ``dofs`` (all dofs: None), each
    shape times ``scale`` (any scaling is the same test)."""
    mm = model_modes(truth, n_modes=min(truth.n_dofs, n + 2))
    dofs = tuple(truth.dofs) if dofs is None else tuple(dofs)
    pos = truth.dof_index(dofs)
    return TestData([MeasuredMode(mm.eigenvalues[r], dofs, scale * (-1) ** r * mm.shapes[pos, r],
                                  **{k: v[r] for k, v in per_mode.items()}) for r in range(n)])


def two_dof_case():
    return two_dof(7.0, 6.5), modes_of(two_dof(), None, 2, 3.0), np.array([8.0, 6.0])


def six_dof_case(**per_mode):
    """A grounded 6-dof chain measured at three of its six dofs, four modes."""
    truth = chain(K6, M6, bounds=(100.0, 5000.0))
    return chain(K6_START, M6, bounds=(100.0, 5000.0)), modes_of(truth, SIX_DOFS, 4, 0.37, **per_mode), K6


TRUSS_UPDATED = ("E.2-3", "E.102-103", "E.3-103")


def truss_case():
    """The 3-bay truss of the examples with one modulus per member: three of them updated (the
    truth has them at 0.7, 1.15 and 0.9 of nominal), the others known; four modes measured at the
    vertical dofs of the six free joints only."""
    base = element_parameters(Structure.from_dict(tomllib.loads(truss_model_toml())))[0].build()
    nominal = {n: base.values[base.parameter_index(n)] for n in TRUSS_UPDATED}
    truth = base.with_values({n: v * f for (n, v), f in zip(nominal.items(), (0.7, 1.15, 0.9))})
    model = base.with_fixed([n for n in base.parameter_names if n not in TRUSS_UPDATED])
    dofs = ("2:y", "3:y", "4:y", "102:y", "103:y", "104:y")
    return model, modes_of(truth, dofs, 4), np.array([truth.values[truth.parameter_index(n)] for n in TRUSS_UPDATED])


CASES = {"two-dof": two_dof_case, "six-dof partial": six_dof_case, "truss partial": truss_case}


def fd_jacobian(prob, x, h=1e-4):
    """Fourth-order central differences of ``prob.residuals`` at x."""
    cols = []
    for e in np.eye(x.size):
        f = [prob.residuals(x + s * h * e) for s in (-2, -1, 1, 2)]
        cols.append((f[0] - 8 * f[1] + 8 * f[2] - f[3]) / (12 * h))
    return np.column_stack(cols)


# ------------------------------------------------------------------------------------ exact Jacobians
@pytest.mark.parametrize("formulation", FORMULATIONS)
@pytest.mark.parametrize("case", CASES)
@pytest.mark.parametrize("parametrisation", ["relative", "log"])
def test_jacobian_is_exact(case, formulation, parametrisation):
    model, data, _ = CASES[case]()
    weights = {"eigenvalue": np.linspace(0.5, 2.0, len(data.modes))}
    if formulation != "dynamic":
        weights["shape"] = np.linspace(1.5, 0.7, len(data.modes))
    prob = Problem(model, data, formulation=formulation, parametrisation=parametrisation, weights=weights)
    x0 = prob.x_start
    rng = np.random.default_rng(7)
    for _ in range(4):
        x = x0 + (np.abs(x0) if parametrisation == "relative" else 1.0) * rng.uniform(-0.1, 0.1, x0.size)
        J = prob.jacobian(x)
        assert J.shape == (prob.n_residuals, x0.size)
        err = np.abs(J - fd_jacobian(prob, x)).max() / np.abs(J).max()
        assert err < 1e-8, (case, formulation, err)


def test_mac_residuals_have_the_squared_norm_1_minus_mac_and_ignore_scaling():
    rng = np.random.default_rng(3)
    for _ in range(20):
        phi, psi = rng.standard_normal(5), rng.standard_normal(5)
        mac = np.zeros(1)
        rules.mac_vector(psi, phi[:, None], mac)
        out = np.zeros(5)
        assert rules.mac_residuals(phi, psi, 2.5, out) == -1
        assert out @ out == pytest.approx(2.5 ** 2 * (1 - mac[0]), rel=1e-12, abs=1e-15)
        again = np.zeros(5)
        rules.mac_residuals(-7.0 * phi, 0.01 * psi, 2.5, again)
        np.testing.assert_allclose(again, out, rtol=1e-12, atol=1e-15)
    assert rules.mac_residuals(np.zeros(3), np.ones(3), 1.0, np.zeros(3)) == 0


# ------------------------------------------------------------------------------------ noise-free data
@pytest.mark.parametrize("formulation", FORMULATIONS)
@pytest.mark.parametrize("case", CASES)
def test_noise_free_data_give_the_truth(case, formulation):
    model, data, truth = CASES[case]()
    res = update(model, data, formulation=formulation)
    assert res.success and res.formulation == formulation
    np.testing.assert_allclose(res.x, truth, rtol=1e-8)
    assert res.cost < 1e-18


@pytest.mark.parametrize("case", CASES)
def test_mac_and_shapes_give_the_same_answer_on_noise_free_data(case):
    model, data, _ = CASES[case]()
    a, b = update(model, data, formulation="shapes"), update(model, data, formulation="mac")
    np.testing.assert_allclose(b.x, a.x, rtol=1e-9)
    assert [j for _, j, _ in a.pairs] == [j for _, j, _ in b.pairs]


@pytest.mark.parametrize("case", CASES)
def test_dynamic_residual_is_zero_at_the_truth_with_the_true_full_shapes(case):
    model, data, truth = CASES[case]()
    at = model.with_values(dict(zip(Problem(model, data).names, truth)))
    full = model_modes(at, n_modes=len(data.modes))
    prob = Problem(at, data, formulation="dynamic")
    x = prob.x_start
    assert np.abs(prob.residuals(x)).max() < 1e-12
    # the unknown entries solved for are the true mode's, scaled as the test shape
    S = prob.expanded_shapes(x)
    for k, m in enumerate(data.modes):
        true = full.shapes[:, k]
        pos = at.dof_index(m.dofs)
        scaled = true / np.linalg.norm(true[pos]) * np.sign(true[pos] @ S[pos, k])
        np.testing.assert_allclose(S[:, k], scaled, atol=1e-12)
        # the equilibrium of every dof with the true shape, as the residual defines it
        lam = m.eigenvalue
        assert np.abs((at.K() - lam * at.M()) @ true).max() < 1e-9 * lam * np.abs(at.M() @ true).max()


def test_dynamic_result_reports_the_full_shapes():
    model, data, truth = six_dof_case()
    res = update(model, data, formulation="dynamic")
    at = model.with_values(dict(zip(res.names, truth)))
    true = model_modes(at, n_modes=4).shapes
    assert res.expanded_shapes.shape == (6, 4)
    pos = model.dof_index(SIX_DOFS)
    for k in range(4):
        mac = (res.expanded_shapes[:, k] @ true[:, k]) ** 2 / (
            (res.expanded_shapes[:, k] @ res.expanded_shapes[:, k]) * (true[:, k] @ true[:, k]))
        assert mac > 1 - 1e-14
        assert np.linalg.norm(res.expanded_shapes[pos, k]) == pytest.approx(1.0, rel=1e-14)
    assert res.sensitivity.startswith("dynamic residual")
    assert update(model, data).expanded_shapes is None


def test_dynamic_sparse_expansion_is_the_dense_one(monkeypatch):
    model, data, _ = truss_case()
    dense = Problem(model, data, formulation="dynamic")
    monkeypatch.setattr(dynamic_module, "DENSE_DYNAMIC", 0)
    sparse = Problem(model, data, formulation="dynamic")
    assert not sparse.dynamic.dense and dense.dynamic.dense
    x = dense.x_start * 1.05
    np.testing.assert_allclose(sparse.residuals(x), dense.residuals(x), rtol=1e-9, atol=1e-12)
    J = dense.jacobian(x)
    np.testing.assert_allclose(sparse.jacobian(x), J, rtol=1e-8, atol=1e-10 * np.abs(J).max())
    np.testing.assert_allclose(sparse.expanded_shapes(x), dense.expanded_shapes(x), atol=1e-10)


def test_dynamic_takes_massless_dofs():
    """A chain whose dofs 2 and 4 carry no mass (measured, so that the springs on either side of
    them are told apart; dof 5 is not): no eigen-solution is needed to update it."""
    def build(k):
        s = Structure("chain with massless dofs")
        for i, v in enumerate(k, start=1):
            s.parameter(f"k{i}", v, (10.0, 1e4))
            s.spring([f"{i}:x"] if i == 1 else [f"{i - 1}:x", f"{i}:x"], k=f"k{i}")
        for i in (1, 3, 5):
            s.mass([f"{i}:x"], m=1.0 + 0.1 * i)
        return s.build()

    truth_k = np.array([1000.0, 1400.0, 900.0, 1200.0, 800.0])
    data = modes_of(build(truth_k), ("1:x", "2:x", "3:x", "4:x"), 3)
    model = build(truth_k * [1.1, 0.9, 1.05, 0.95, 1.1])
    prob = Problem(model, data, formulation="dynamic")
    x = prob.x_start * 1.02
    J = prob.jacobian(x)
    assert np.abs(J - fd_jacobian(prob, x)).max() < 1e-8 * np.abs(J).max()
    res = update(model, data, formulation="dynamic")
    np.testing.assert_allclose(res.x, truth_k, rtol=1e-8)
    # the unmeasured dof 5 of the expanded shapes is the true modes'
    true = model_modes(build(truth_k)).shapes
    S = res.expanded_shapes
    np.testing.assert_allclose(S[4], true[4] * S[0] / true[0], rtol=1e-9)


# ------------------------------------------------------------------------------------ weights and stds
STD_E, STD_S, WEIGHT = [0.01, 0.02, 0.005, 0.03], [0.02, 0.01, 0.04, 0.02], [1.0, 2.0, 0.5, 1.5]


def blocks(prob, r):
    """The residuals r split per test mode."""
    tg = prob.targets
    if prob.formulation == "dynamic":
        return np.split(r, tg.n_test)
    ns = np.diff(tg.pptr)
    return np.split(r, np.cumsum(1 + ns)[:-1])


@pytest.mark.parametrize("formulation", FORMULATIONS)
def test_per_mode_weights_and_stds_from_the_data_weigh_each_formulation(formulation):
    model, plain, _ = six_dof_case()
    stated = dict(std_eigenvalue=STD_E, weight=WEIGHT)
    if formulation != "dynamic":
        stated["std_shape"] = STD_S
    model, rich, _ = six_dof_case(**stated)
    a, b = Problem(model, plain, formulation=formulation), Problem(model, rich, formulation=formulation)
    x = a.x_start * 1.03
    for k, (ra, rb) in enumerate(zip(blocks(a, a.residuals(x)), blocks(b, b.residuals(x)))):
        if formulation == "dynamic":  # one residual per mode: the eigenvalue's weight and std
            np.testing.assert_allclose(rb, ra * WEIGHT[k] / STD_E[k], rtol=1e-12)
        else:
            assert rb[0] == pytest.approx(ra[0] * WEIGHT[k] / STD_E[k], rel=1e-12)
            np.testing.assert_allclose(rb[1:], ra[1:] * WEIGHT[k] / STD_S[k], rtol=1e-12)
    assert b.sigma is not None  # every residual divided by its std: the covariance is absolute
    res = update(model, rich, formulation=formulation)
    assert res.diagnostics.absolute
    # the same problem with the stds and weights given in Python
    w = {"eigenvalue": WEIGHT} if formulation == "dynamic" else {"eigenvalue": WEIGHT, "shape": WEIGHT}
    std = {"eigenvalue": STD_E} if formulation == "dynamic" else {"eigenvalue": STD_E, "shape": STD_S}
    c = Problem(model, plain, formulation=formulation, weights=w, measurement_std=std)
    np.testing.assert_array_equal(c.residuals(x), b.residuals(x))


def test_dynamic_does_not_use_the_data_shape_std_and_says_so():
    model, data, _ = six_dof_case(std_eigenvalue=STD_E, std_shape=STD_S)
    res = update(model, data, formulation="dynamic")
    assert res.diagnostics.absolute
    assert any("std_shape are not used" in n for n in res.notes)
    assert not any("std_shape" in n for n in update(model, data).notes)


def test_dynamic_residual_variance_counts_the_measured_entries():
    """Without stated stds the covariance is scaled by ‖r‖² / (data − parameters), the data
    being one equation per measured entry (the others determine the unknown entries)."""
    model, data, _ = six_dof_case()
    rng = np.random.default_rng(5)
    noisy = TestData([MeasuredMode(m.eigenvalue * (1 + 0.01 * rng.standard_normal()), m.dofs,
                                   m.shape + 0.01 * rng.standard_normal(m.shape.size)) for m in data.modes])
    res = update(model, noisy, formulation="dynamic")
    d = res.diagnostics
    assert d.n_residuals == 24 and res.jac.shape == (24, 6)  # 4 modes x 6 dofs; 4 x 3 measured entries
    Jp = res.jac / np.abs([res.start[n] for n in res.names])[None, :]  # ∂r/∂p (x = p / |p_start|)
    expected = np.linalg.inv(Jp.T @ Jp) * float(res.fun @ res.fun) / (12 - 6)
    np.testing.assert_allclose(d.covariance, expected, rtol=1e-8)


# ------------------------------------------------------------------------------------ refusals
def test_refusals_name_the_culprit():
    model, data, _ = six_dof_case()
    shapeless = TestData(list(data.modes[:2]) + [MeasuredMode(data.modes[2].eigenvalue)] + list(data.modes[3:]))
    with pytest.raises(InputError, match=r"unknown formulation 'foo': use shapes, mac, dynamic"):
        Problem(model, data, formulation="foo")
    with pytest.raises(InputError, match=r"dynamic formulation needs a shape .* test mode 3 has none"):
        Problem(model, shapeless, formulation="dynamic")
    with pytest.raises(InputError, match=r"shape scaling 'ref' \(--shape-scaling\) applies to formulation 'shapes'"):
        Problem(model, data, formulation="mac", shape_scaling="ref")
    with pytest.raises(InputError, match=r"reference dof \(--ref-dof 2:x\)"):
        Problem(model, data, formulation="dynamic", ref_dof="2:x")
    with pytest.raises(InputError, match=r"formulation 'mac' compares the measured shapes.*--eigenvalues-only"):
        Problem(model, data, formulation="mac", use_shapes=False)
    with pytest.raises(InputError, match=r"measurement_std\['shape'\] \(--std-shape\): formulation 'dynamic'"):
        Problem(model, data, formulation="dynamic", measurement_std={"shape": 0.01})
    with pytest.raises(InputError, match=r"weights\['shape'\]: formulation 'dynamic'"):
        Problem(model, data, formulation="dynamic", weights={"shape": 2.0})
    with pytest.raises(InputError, match=r"sensitivity 'nelson' \(--sensitivity\)"):
        Problem(model, data, formulation="dynamic", sensitivity="nelson")
    Problem(model, shapeless, formulation="mac")  # a mode without shape enters by its eigenvalue
    # the per-start route would refuse every start alike: refused once
    with pytest.raises(InputError, match=r"test mode 3 has none"):
        multistart(model, shapeless, starts=3, formulation="dynamic")


def cli(args, capsys):
    with pytest.raises(SystemExit) as info:
        main(args)
    out, err = capsys.readouterr()
    return info.value.code or 0, out, err


@pytest.fixture()
def files(tmp_path):
    model, data, _ = six_dof_case()
    lines = ['[model]', 'name = "six-dof chain"', ""]
    for i, k in enumerate(K6_START, start=1):
        lines += [f"[parameters.k{i}]", f"value = {float(k)!r}", "bounds = [100.0, 5000.0]", ""]
    for i in range(1, 7):
        lines += ["[[element]]", 'type = "spring"', f'dofs = ["{i}:x"]' if i == 1 else f'dofs = ["{i - 1}:x", "{i}:x"]',
                  f'k = "k{i}"', "", "[[element]]", 'type = "mass"', f'dofs = ["{i}:x"]', f"m = {float(M6[i - 1])!r}", ""]
    (tmp_path / "chain.toml").write_text("\n".join(lines))
    modes = [{"eigenvalue": m.eigenvalue, "shape": dict(zip(m.dofs, map(float, m.shape)))} for m in data.modes]
    (tmp_path / "test.json").write_text(json.dumps({"modes": modes}))
    modes[2] = {"eigenvalue": modes[2]["eigenvalue"]}
    (tmp_path / "shapeless.json").write_text(json.dumps({"modes": modes}))
    return tmp_path


@pytest.mark.parametrize("formulation", FORMULATIONS)
def test_cli_formulation_in_the_json(files, capsys, formulation):
    out = files / f"{formulation}.json"
    code, text, _ = cli(["update", str(files / "chain.toml"), str(files / "test.json"), "--formulation", formulation,
                         "--json", str(out)], capsys)
    assert code == 0
    d = json.loads(out.read_text())
    assert d["formulation"] == formulation and f"formulation: {formulation}" in text
    np.testing.assert_allclose([d["parameters"][f"k{i}"] for i in range(1, 7)], K6, rtol=1e-8)
    if formulation == "dynamic":
        assert len(d["expanded_shapes"]) == 4 and set(d["expanded_shapes"][0]) == {f"{i}:x" for i in range(1, 7)}
    else:
        assert "expanded_shapes" not in d


def test_cli_default_formulation_is_shapes(files, capsys):
    out = files / "default.json"
    assert cli(["update", str(files / "chain.toml"), str(files / "test.json"), "--json", str(out)], capsys)[0] == 0
    assert json.loads(out.read_text())["formulation"] == "shapes"


@pytest.mark.parametrize("args, message", [
    (["--formulation", "foo"], "Invalid value for '--formulation': 'foo' is not one of 'shapes', 'mac', 'dynamic'"),
    (["--formulation", "dynamic", "--data", "shapeless.json"], "test mode 3 has none"),
    (["--formulation", "dynamic", "--data", "shapeless.json", "--starts", "3"], "test mode 3 has none"),
    (["--formulation", "mac", "--shape-scaling", "ref"], "shape scaling 'ref' (--shape-scaling)"),
    (["--formulation", "dynamic", "--std-shape", "0.01"], "measurement_std['shape'] (--std-shape)"),
    (["--formulation", "mac", "--eigenvalues-only"], "--eigenvalues-only"),
])
def test_cli_bad_formulation_options_exit_2_with_one_message(files, capsys, args, message):
    data = "test.json"
    if "--data" in args:
        i = args.index("--data")
        data, args = args[i + 1], args[:i] + args[i + 2:]
    code, out, err = cli(["update", str(files / "chain.toml"), str(files / data), *args], capsys)
    assert code == 2
    assert message in " ".join(err.split())
    assert "Traceback" not in err


def test_cli_formulation_of_frf_data_is_refused(tmp_path, capsys):
    main_dir = tmp_path / "ex"
    with pytest.raises(SystemExit):
        main(["demo", "--write-files", str(main_dir)])
    capsys.readouterr()
    code, _, err = cli(["update", str(main_dir / "two_dof.toml"), str(main_dir / "two_dof_frf.json"), "--formulation",
                        "mac"], capsys)
    assert code == 2 and "formulation 'mac' (--formulation) applies to measured modes" in " ".join(err.split())


# ------------------------------------------------------------------------------------ multistart
@pytest.mark.parametrize("formulation", ["mac", "dynamic"])
def test_multistart_takes_the_per_start_route_for_other_formulations(formulation):
    model, data, truth = six_dof_case()
    reason = unsupported(model, {"formulation": formulation})
    assert reason and f"formulation={formulation!r}" in reason and unsupported(model, {"formulation": "shapes"}) is None
    ms = multistart(model, data, starts=3, seed=1, formulation=formulation)
    assert all(not isinstance(r, BatchRun) and r.formulation == formulation for r in ms.runs if not isinstance(r, str))
    assert ms.best is not None and ms.best.formulation == formulation
    np.testing.assert_allclose(ms.best.x, truth, rtol=1e-8)
    with pytest.raises(InputError, match=rf"batched=True: formulation={formulation!r}.*use batched=False"):
        multistart(model, data, starts=2, formulation=formulation, batched=True)
    shapes = multistart(model, data, starts=2, seed=1)
    assert all(isinstance(r, BatchRun) for r in shapes.runs) and shapes.best.formulation == "shapes"


# ------------------------------------------------------------------------------------ mixed data
@pytest.mark.parametrize("formulation", FORMULATIONS)
def test_modes_with_static_data_in_each_formulation(formulation):
    from femupdate.testdata import StaticData

    model, data, truth = six_dof_case()
    at = model.with_values(dict(zip(Problem(model, data).names, truth)))
    f = np.zeros(6)
    f[5] = 100.0
    u = np.linalg.solve(at.K().toarray(), f)
    mixed = TestData(list(data.modes), static=(StaticData({"6:x": 100.0}, ("3:x", "6:x"), u[[2, 5]]),))
    res = update(model, mixed, formulation=formulation)
    assert res.formulation == formulation and [b["kind"] for b in res.blocks] == ["modes", "static"]
    np.testing.assert_allclose(res.x, truth, rtol=1e-8)
    assert (res.expanded_shapes is not None) == (formulation == "dynamic")
    assert not math.isnan(res.diagnostics.condition_number)


def test_a_frequency_only_update_does_not_claim_the_shape_formulation(files, capsys):
    """With no mode shape used (--eigenvalues-only) the result says "eigenvalues", not "shapes"."""
    out = files / "freq.json"
    code, text = cli(["update", str(files / "chain.toml"), str(files / "test.json"), "--eigenvalues-only",
                      "--params", "k1,k2", "--json", str(out)], capsys)[:2]
    assert code == 0 and json.loads(out.read_text())["formulation"] == "eigenvalues"
    assert "formulation: eigenvalues" in text and "formulation: shapes" not in text
