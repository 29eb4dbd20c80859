"""Pairing of test modes with model modes (femupdate.rules.pair_modes): the policies mac, order,
frequency and auto, the same on the local and the compiled route, and what each does for a start
far from the data (issue: pairing that never throws a start away); the one assignment and the one
MAC against SciPy and the closed form, and the entry point femupdate.correlation.pair."""

import dataclasses
import itertools
import json

import numpy as np
import pytest
from scipy.optimize import linear_sum_assignment

from femupdate import InputError, MeasuredMode, NumericalError, Structure, TestData, model_modes, rules
from femupdate.correlation import Pairing, correlate, mac, pair_modes
from femupdate.correlation import pair as pair_entry
from femupdate.generators import shear_building
from femupdate.updating import multistart, update

MAC_, ORDER, FREQ, AUTO = rules.PAIR_MAC, rules.PAIR_ORDER, rules.PAIR_FREQUENCY, rules.PAIR_AUTO


def pair(policy, MAC, lam, lam_e, shaped=None, min_mac=0.5):
    MAC = np.asarray(MAC, float)
    T, nm = MAC.shape
    shaped = np.ones(T, bool) if shaped is None else np.asarray(shaped, bool)
    pairs, bad = np.zeros(T, np.int64), np.zeros(T, bool)
    code, i, used = rules.pair_modes(policy, MAC, shaped, np.asarray(lam, float), np.asarray(lam_e, float), nm,
                                     min_mac, pairs, bad)
    return code, list(pairs), rules.PAIRING_NAMES[used]


# ------------------------------------------------------------------ the rules
def test_order_pairs_by_measured_frequency_whatever_the_listing():
    code, pairs, used = pair(ORDER, np.zeros((3, 5)), [1, 2, 3, 4, 5], [9.0, 1.0, 4.0])
    assert code == rules.OK and pairs == [2, 0, 1] and used == "order"
    code, *_ = pair(ORDER, np.zeros((3, 2)), [1, 2], [1.0, 2.0, 3.0])
    assert code == rules.E_NO_MODE_LEFT


def test_order_skips_rigid_body_modes_of_a_free_structure():
    lam = [0.0, 0.0, 4.0, 9.0, 16.0]
    assert pair(ORDER, np.zeros((2, 5)), lam, [9.5, 4.2])[1] == [3, 2]
    assert pair(AUTO, np.zeros((2, 5)), lam, [9.5, 4.2], shaped=[False, False])[1] == [3, 2]
    assert pair(ORDER, np.zeros((3, 5)), lam, [0.0, 4.2, 9.5])[1] == [0, 2, 3]  # a measured rigid-body mode


def free_chain():
    """Three unit masses joined by springs k1, k2, free at both ends: one rigid-body mode."""
    s = Structure("free chain")
    for i, k in ((1, 1.0), (2, 2.0)):
        s.parameter(f"k{i}", k, (0.1, 10.0))
        s.spring([f"{i}:x", f"{i + 1}:x"], k=f"k{i}")
    for i in (1, 2, 3):
        s.mass([f"{i}:x"], m=1.0)
    return s.build()


@pytest.mark.parametrize("shapes", [True, False])
def test_a_free_structure_updates_by_the_default_pairing(shapes):
    """Its elastic test modes pair with its elastic modes, never with the 0 Hz rigid-body mode."""
    model = free_chain()
    mm = model_modes(model)
    assert mm.n_rigid == 1
    data = TestData(modes=tuple(MeasuredMode(mm.eigenvalues[j], model.dofs, mm.shapes[:, j]) if shapes
                                else MeasuredMode(mm.eigenvalues[j]) for j in (1, 2)))
    res = update(model, data, x0={"k1": 1.6, "k2": 1.3})
    assert res.cost < 1e-20 and [j for _, j, _ in res.pairs] == [1, 2]
    # the shapes tell k1 from k2; the frequencies alone allow the mirror image (k1, k2) = (2, 1) too
    expected = [[1.0, 2.0]] if shapes else [[1.0, 2.0], [2.0, 1.0]]
    assert any(np.allclose(res.x, e, rtol=1e-8) for e in expected)
    if shapes:
        ms = multistart(model, data, starts=6, seed=1, batched=True)
        assert not ms.failures and {rec["pairing"] for rec in ms.records()} == {"order"}


def test_frequency_pairing_lets_mac_decide_inside_the_window_only():
    # test mode at 10 Hz; model modes at 9.8 and 10.3 Hz (inside 10 %) and 30 Hz
    lam = (2 * np.pi * np.array([9.8, 10.3, 30.0])) ** 2
    lam_e = [(2 * np.pi * 10.0) ** 2]
    assert pair(FREQ, [[0.2, 0.9, 0.1]], lam, lam_e)[1] == [1]  # the better shape, not the nearer frequency
    assert pair(FREQ, [[0.9, 0.2, 0.1]], lam, lam_e)[1] == [0]
    # outside the window the nearest frequency wins whatever the MAC; a low MAC never fails
    assert pair(FREQ, [[0.0, 0.0, 1.0]], lam, lam_e)[1:] == ([0], "frequency")


def test_auto_keeps_order_unless_the_shapes_show_a_swap_clearly():
    lam, lam_e = [1.0, 2.0, 3.0], [1.0, 2.0]
    # order correlates: order
    assert pair(AUTO, [[0.95, 0.1, 0.0], [0.1, 0.9, 0.2]], lam, lam_e)[1:] == ([0, 1], "order")
    # a clear swap (each best match >= 0.9 and 0.2 better than any other): by MAC
    assert pair(AUTO, [[0.05, 0.97, 0.0], [0.96, 0.1, 0.2]], lam, lam_e)[1:] == ([1, 0], "mac")
    # the MAC pairing is not clear (0.8 < 0.9, or a second match within 0.2): order, never a failure
    assert pair(AUTO, [[0.05, 0.8, 0.0], [0.96, 0.1, 0.2]], lam, lam_e)[:2] == (rules.OK, [0, 1])
    assert pair(AUTO, [[0.05, 0.97, 0.85], [0.96, 0.1, 0.2]], lam, lam_e)[1:] == ([0, 1], "order")
    # mac fails where auto goes on
    assert pair(MAC_, [[0.05, 0.3, 0.0], [0.2, 0.1, 0.2]], lam, lam_e)[0] == rules.E_NO_PAIR
    assert pair(AUTO, [[0.05, 0.3, 0.0], [0.2, 0.1, 0.2]], lam, lam_e)[:2] == (rules.OK, [0, 1])


def test_pairing_rule_names_what_made_the_pairs():
    assert rules.pairing_rule("auto", [1, 0], [1.0, 2.0]) == "mac"
    assert rules.pairing_rule("auto", [1, 0], [2.0, 1.0]) == "order"
    assert rules.pairing_rule("auto", [7, 6], [2.0, 1.0]) == "order"  # after six rigid-body modes
    assert rules.pairing_rule("frequency", [0, 1], [1.0, 2.0]) == "frequency"


# ------------------------------------------------------------------ the one assignment, against SciPy
def mac_matrices(n=400, seed=7):
    """Random MAC-like matrices, rectangular either way, many with ties: continuous values, values
    from a few levels (exact in binary, so equal totals are equal), repeated columns, zero rows."""
    rng = np.random.default_rng(seed)
    for c in range(n):
        nr, nc = rng.integers(1, 7, size=2)
        kind = c % 4
        if kind == 0:
            M = rng.random((nr, nc))
        elif kind == 1:
            M = rng.choice([0.0, 0.25, 0.5, 0.75, 1.0], size=(nr, nc))
        elif kind == 2:  # repeated columns
            base = rng.random((nr, rng.integers(1, nc + 1)))
            M = base[:, rng.integers(0, base.shape[1], size=nc)]
        else:
            M = rng.choice([0.0, 0.5, 1.0], size=(nr, nc))
            M[rng.integers(0, nr)] = 0.0
        yield np.ascontiguousarray(M, dtype=float)


def optimum(M):
    """Every assignment's total MAC by brute force: the best total, and whether only one assignment
    reaches it (then SciPy's pairs are the pairs)."""
    nr, nc = M.shape
    if nr <= nc:
        totals = np.array([M[np.arange(nr), list(cols)].sum() for cols in itertools.permutations(range(nc), nr)])
    else:
        totals = np.array([M[list(rows), np.arange(nc)].sum() for rows in itertools.permutations(range(nr), nc)])
    best = totals.max()
    return best, int(np.sum(totals >= best - 1e-12)) == 1


def scipy_pairs(M):
    rows, cols = linear_sum_assignment(M, maximize=True)
    return sorted((int(r), int(c)) for r, c in zip(rows, cols))


def _assign_py(C, nr, nc, out):
    rules.assign(C, nr, nc, out)


def _compiled_assign():
    import numba

    import femupdate.updating.batched.kernel  # noqa: F401  (registers the rules with numba)

    @numba.njit(error_model="numpy")
    def assign_c(C, nr, nc, out):
        rules.assign(C, nr, nc, out)

    return assign_c


@pytest.mark.parametrize("route", ["python", "compiled"])
def test_the_assignment_kernel_agrees_with_scipy(route):
    """rules.assign on -MAC, both routes, rectangular either way, with ties: every row of the
    smaller side assigned, distinct, at SciPy's (and the brute-force) total; SciPy's very pairs
    wherever the optimum is unique."""
    assign = _assign_py if route == "python" else _compiled_assign()
    unique = 0
    for M in mac_matrices():
        nr, nc = M.shape
        out = np.full(nr, -7, np.int64)
        assign(np.ascontiguousarray(-M), nr, nc, out)
        got = sorted((r, int(c)) for r, c in enumerate(out) if c >= 0)
        assert len(got) == min(nr, nc) and np.all((out >= -1) & (out < nc))
        assert len({c for _, c in got}) == len(got)
        ref = scipy_pairs(M)
        best, only = optimum(M)
        total = sum(M[r, c] for r, c in got)
        assert total == pytest.approx(best, abs=1e-12) and sum(M[r, c] for r, c in ref) == pytest.approx(best, abs=1e-12)
        if only:
            unique += 1
            assert got == ref, M
    assert unique > 100  # the comparison of pairs is not vacuous


def test_the_entry_point_pairs_by_mac_as_scipy_does():
    """pair(rule="mac", min_mac=0) — the policy rule (its shortcut when each best match is clear,
    else the assignment), and the assignment of those there are when test modes outnumber model
    modes — gives SciPy's total, and SciPy's pairs wherever the optimum is unique; the old
    pair_modes is its alias."""
    for M in mac_matrices(seed=11):
        got = pair_entry(M, rule="mac", min_mac=0.0)
        best, only = optimum(M)
        assert len(got.pairs) == min(M.shape) and got.used == "mac" and not got.unconfirmed
        assert sum(m for _, _, m in got.pairs) == pytest.approx(best, abs=1e-12)
        assert [k for k, _, _ in got.pairs] == sorted(k for k, _, _ in got.pairs)
        assert set(got.unpaired) == set(range(M.shape[0])) - {k for k, _, _ in got.pairs}
        if only:
            assert [(k, j) for k, j, _ in got.pairs] == scipy_pairs(M)
        assert pair_modes(M, 0.3) == [p for p in got.pairs if p[2] >= 0.3]


# ------------------------------------------------------------------ the one MAC
def test_mac_matrix_and_the_compiled_rule_share_one_formula(rng):
    A, B = rng.standard_normal((7, 3)), rng.standard_normal((7, 5))
    B[:, 2] = 0.0  # a zero shape: MAC 0, not NaN
    closed = np.array([[(a @ b) ** 2 / ((a @ a) * (b @ b)) if b @ b > 0 else 0.0 for b in B.T] for a in A.T])
    np.testing.assert_allclose(mac(A, B), closed, rtol=1e-13, atol=0)
    for r in range(3):
        out = np.full(5, -1.0)
        rules.mac_vector(A[:, r], B, out)
        np.testing.assert_allclose(out, closed[r], rtol=1e-13, atol=0)
    Z = A + 1j * rng.standard_normal((7, 3))  # complex: |aᴴb|² / (aᴴa bᴴb)
    want = np.array([[abs(np.vdot(a, b)) ** 2 / (np.vdot(a, a).real * (b @ b)) if b @ b > 0 else 0.0 for b in B.T]
                     for a in Z.T])
    np.testing.assert_allclose(mac(Z, B), want, rtol=1e-13, atol=0)
    assert rules.mac_value(4.0, 2.0, 2.0) == 1.0 and rules.mac_value(4.0 + 1e-12, 2.0, 2.0) == 1.0  # clipped
    assert rules.mac_value(0.0, 0.0, 1.0) == 0.0


# ------------------------------------------------------------------ the entry point
def hz2lam(f):
    return (2 * np.pi * np.asarray(f, float)) ** 2


def test_pairing_says_what_it_did():
    f_model, f_test = [5.0, 9.8, 10.3, 30.0], [10.0, 5.2, 24.0]
    M = np.array([[0.1, 0.2, 0.95, 0.0],   # test 1 (10 Hz): model 3 (10.3 Hz) by shape
                  [0.97, 0.1, 0.0, 0.0],   # test 2 (5.2 Hz): model 1
                  [0.0, 0.1, 0.0, 0.3]])   # test 3 (24 Hz): nearest is model 4 (30 Hz), a low MAC
    kw = dict(model_eigenvalues=hz2lam(f_model), test_eigenvalues=hz2lam(f_test))
    pg = pair_entry(M, rule="frequency", min_mac=0.5, **kw)
    assert isinstance(pg, Pairing) and (pg.rule, pg.used) == ("frequency", "frequency")
    assert [(k, j) for k, j, _ in pg.pairs] == [(0, 2), (1, 0), (2, 3)] and [m for *_, m in pg.pairs] == [0.95, 0.97, 0.3]
    expected = [(10.3 - 10.0) / 10.0, (5.0 - 5.2) / 5.2, (30.0 - 24.0) / 24.0]
    np.testing.assert_allclose(pg.frequency_error, expected, rtol=1e-12)
    assert pg.unconfirmed == (2,) and pg.large_change == (2,) and pg.unpaired == ()
    # order pairs 5.2 Hz with 5 Hz, 10 Hz with 9.8 Hz, 24 Hz with 10.3 Hz: the shapes confirm only one pair
    order = pair_entry(M, rule="order", min_mac=0.5, **kw)
    assert [(k, j) for k, j, _ in order.pairs] == [(0, 1), (1, 0), (2, 2)] and order.unconfirmed == (0, 2)
    assert order.large_change == (2,)
    # auto: the shapes show no clear swap for every mode (test 3's best is 0.3): order
    assert pair_entry(M, rule="auto", min_mac=0.5, **kw).used == "order"
    # by MAC, leniently (as correlate): test 3 is left unpaired; strictly (as update): a failure naming it
    lenient = pair_entry(M, rule="mac", min_mac=0.5)
    assert [(k, j) for k, j, _ in lenient.pairs] == [(0, 2), (1, 0)] and lenient.unpaired == (2,)
    assert np.isnan(lenient.frequency_error).all() and lenient.large_change == ()
    with pytest.raises(NumericalError, match=r"test mode\(s\) \[3\] pair with no model mode"):
        pair_entry(M, rule="mac", min_mac=0.5, strict=True)
    with pytest.raises(dataclasses.FrozenInstanceError):
        pg.used = "mac"  # type: ignore[misc]


def test_more_test_modes_than_model_modes():
    M = np.array([[0.9, 0.1], [0.2, 0.8], [0.95, 0.3]])
    kw = dict(model_eigenvalues=[1.0, 4.0], test_eigenvalues=[1.0, 4.0, 1.1])
    pg = pair_entry(M, rule="order", **kw)  # order runs out of model modes: the best MAC assignment of those there are
    assert [(k, j) for k, j, _ in pg.pairs] == [(1, 1), (2, 0)] and pg.unpaired == (0,) and pg.used == "mac"
    with pytest.raises(NumericalError, match="no model mode left"):
        pair_entry(M, rule="order", strict=True, **kw)
    assert pair_entry(np.zeros((2, 0)), rule="mac").unpaired == (0, 1)


def test_pair_refuses_bad_input_naming_it():
    M = np.eye(2)
    with pytest.raises(InputError, match="unknown pairing 'nearest'"):
        pair_entry(M, rule="nearest")
    with pytest.raises(InputError, match="min_mac must be a number between 0 and 1, got 1.5"):
        pair_entry(M, rule="mac", min_mac=1.5)
    with pytest.raises(InputError, match="pairing 'auto' needs the eigenvalues"):
        pair_entry(M)
    with pytest.raises(InputError, match="2-D"):
        pair_entry(np.ones(3), rule="mac")
    with pytest.raises(InputError, match="shaped has 3 entries for 2 test modes"):
        pair_entry(M, rule="mac", shaped=[True, True, False])
    with pytest.raises(InputError, match="1 model and 2 test eigenvalues"):
        pair_entry(M, rule="order", model_eigenvalues=[1.0], test_eigenvalues=[1.0, 2.0])
    with pytest.raises(NumericalError, match=r"non-finite MAC of test mode\(s\) \[2\]"):
        pair_entry([[1.0, 0.0], [np.nan, 0.5]], rule="mac")
    assert pair_entry([[1.0, 0.0], [np.nan, 0.5]], rule="mac", shaped=[True, False]).pairs[0] == (0, 0, 1.0)


def test_correlate_keeps_the_pairing_it_made():
    model = free_chain()
    mm = model_modes(model)
    data = TestData(modes=tuple(MeasuredMode(mm.eigenvalues[j], model.dofs, mm.shapes[:, j]) for j in (2, 1)))
    corr = correlate(data, mm)
    assert corr.pairing is not None and corr.pairing.rule == "auto" and corr.pairing.used == "order"
    assert corr.pairs == list(corr.pairing.pairs) and [(k, j) for k, j, _ in corr.pairs] == [(0, 2), (1, 1)]
    np.testing.assert_allclose(corr.pairing.frequency_error, 0.0, atol=1e-12)


# ------------------------------------------------------------------ updating
def two_oscillators():
    """Two uncoupled unit masses on springs k1, k2: their modes cross when k1 passes k2."""
    s = Structure("two oscillators")
    for i, k in ((1, 1.0), (2, 4.0)):
        s.parameter(f"k{i}", k, (0.1, 10.0))
        s.spring([f"{i}:x"], k=f"k{i}")
        s.mass([f"{i}:x"], m=1.0)
    return s.build()


def test_auto_follows_a_mode_swap_that_order_pairing_gets_wrong():
    model = two_oscillators()
    mm = model_modes(model)
    data = TestData(modes=tuple(MeasuredMode(mm.eigenvalues[j], ["1:x", "2:x"], mm.shapes[:, j]) for j in range(2)))
    start = {"k1": 6.0, "k2": 2.0}  # the model's lower mode is the test's upper one
    res = update(model, data, x0=start)
    np.testing.assert_allclose(res.x, [1.0, 4.0], rtol=1e-8)
    # paired by MAC while the model's modes are in the other order, then (once they have crossed) by order
    assert res.pairing == {"policy": "auto", "used": "order", "min_mac": 0.5, "low_mac": []}
    assert res.swaps and {sw["test_mode"] for sw in res.swaps} == {0, 1}
    bad = update(model, data, x0=start, pairing="order")  # order pairs the wrong modes: no exact fit
    assert bad.cost > 1e-3 and bad.pairing["low_mac"] and "do not confirm" in bad.summary()
    assert update(model, data, x0=start, pairing="mac").cost < 1e-20


def sparse_building(n=10, n_modes=4, n_sensors=5):
    k = 2.0e7 * (1.0 - 0.4 * np.arange(n) / (n - 1))
    model = shear_building(n, k=k, m=1.0e4, bounds=(0.0, 2.0)).build()
    floors = sorted(set(np.linspace(1, n, n_sensors).round().astype(int)))
    sensors = [f"{i}:x" for i in floors]
    mm = model_modes(model)
    pos = model.dof_index(sensors)
    data = TestData(modes=tuple(MeasuredMode(mm.eigenvalues[j], sensors, mm.shapes[pos, j]) for j in range(n_modes)))
    return model, data, k


def reached(ms, k):
    return sum(1 for r in ms.runs if not isinstance(r, str) and r.success and np.max(np.abs(r.x / k - 1)) < 1e-6)


def test_auto_keeps_every_start_of_a_sparse_building_alive():
    """Sensors on 5 of 10 floors, 4 modes, 40 starts over [0, 2] x nominal: by MAC a third of the starts
    are abandoned at their first evaluation; the default keeps them and every one reaches the truth."""
    model, data, k = sparse_building()
    by_mac = multistart(model, data, starts=40, seed=1, pairing="mac")
    assert sum(isinstance(r, str) for r in by_mac.runs) >= 5
    assert any("pair with no model mode" in reason for reason in by_mac.failures)
    ms = multistart(model, data, starts=40, seed=1)
    assert reached(ms, k) == 40 and not ms.failures
    assert {rec["pairing"] for rec in ms.records()} == {"order"}


@pytest.mark.parametrize("pairing", ["auto", "order", "frequency", "mac"])
def test_compiled_and_local_routes_pair_alike(pairing):
    model, data, k = sparse_building(8, 3, 4)
    a = multistart(model, data, starts=8, seed=5, pairing=pairing, batched=True)
    b = multistart(model, data, starts=8, seed=5, pairing=pairing, batched=False)
    for ra, rb in zip(a.runs, b.runs):
        assert isinstance(ra, str) == isinstance(rb, str), (ra, rb)
        if isinstance(ra, str):
            assert ra == rb
            continue
        assert ra.success == rb.success
        if ra.success:
            np.testing.assert_allclose(ra.x, rb.x, rtol=1e-6, atol=1e-9 * k.max())  # a value on its bound 0
            assert [j for _, j, _ in ra.pairs] == [j for _, j, _ in rb.pairs]
            assert ra.pairing["used"] == rb.pairing["used"]


# ------------------------------------------------------------------ command line
def test_cli_pairing_option_and_warning(tmp_path, capsys):
    from femupdate.cli import main

    toml = ['[model]', 'name = "oscillators"']
    for i, kv in ((1, 1.0), (2, 4.0)):
        toml += [f"[parameters.k{i}]", f"value = {kv}", "bounds = [0.1, 10.0]",
                 "[[element]]", 'type = "spring"', f'dofs = ["{i}:x"]', f'k = "k{i}"',
                 "[[element]]", 'type = "mass"', f'dofs = ["{i}:x"]', "m = 1.0"]
    (tmp_path / "m.toml").write_text("\n".join(toml) + "\n")
    mm = model_modes(two_oscillators())
    modes = [{"eigenvalue": float(mm.eigenvalues[j]), "shape": {"1:x": float(mm.shapes[0, j]),
                                                                 "2:x": float(mm.shapes[1, j])}} for j in range(2)]
    modes[1]["shape"] = {"1:x": 1.0, "2:x": 1.0}  # a shape no model mode matches at MAC 0.9
    (tmp_path / "d.json").write_text(json.dumps({"modes": modes}))
    args = ["update", str(tmp_path / "m.toml"), str(tmp_path / "d.json"), "--set", "k1=6,k2=2", "--min-mac", "0.9"]
    with pytest.raises(SystemExit) as info:
        main(args + ["--pairing", "mac"])
    assert info.value.code == 1 and "pair with no model mode" in capsys.readouterr().err
    with pytest.raises(SystemExit) as info:
        main(args + ["--json", str(tmp_path / "r.json")])
    out = capsys.readouterr().out
    assert info.value.code in (0, None)
    assert "pairing: auto" in out and "do not confirm" in out.replace("\n", " ")
    got = json.loads((tmp_path / "r.json").read_text())
    assert got["pairing"]["policy"] == "auto" and got["pairing"]["low_mac"]
    with pytest.raises(SystemExit) as info:
        main(args + ["--pairing", "nearest"])
    assert info.value.code == 2


def test_unknown_pairing_is_refused():
    model = two_oscillators()
    data = TestData(modes=(MeasuredMode(1.0),))
    with pytest.raises(Exception, match="unknown pairing 'nearest'"):
        update(model, data, params=["k1"], pairing="nearest")
    with pytest.raises(NumericalError):
        update(model, TestData(modes=(MeasuredMode(1.0, ["1:x", "2:x"], [1.0, 1.0]),)), params=["k1"],
               min_mac=0.99, pairing="mac")


def test_each_start_records_its_time_on_the_per_start_route():
    model, data, k = sparse_building(6, 3, 3)
    local = multistart(model, data, starts=4, seed=3, batched=False)
    assert local.batch_seconds is None and len(local.seconds) == 4 and all(s > 0 for s in local.seconds)
    assert [rec["seconds"] for rec in local.records()] == local.seconds
    assert len(local.cpu_seconds) == 4 and all(c > 0 for c in local.cpu_seconds)
    assert [rec["cpu_seconds"] for rec in local.records()] == local.cpu_seconds
    compiled = multistart(model, data, starts=4, seed=3, batched=True)
    assert compiled.seconds is None and compiled.batch_seconds > 0
    assert all(rec["seconds"] is None and rec["cpu_seconds"] is None for rec in compiled.records())
