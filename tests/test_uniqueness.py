"""Uniqueness studies: counting criteria, exact solution sets, the batched Monte Carlo study
(against the per-start route), Dask, checkpoints, the command and the paper sections."""

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import sympy as sp
from scipy.linalg import eigh

from femupdate import InputError
from femupdate.cli import main
from femupdate.io.results import to_jsonable
from femupdate.examples import chain, three_dof, two_dof
from femupdate.updating import Problem, cluster
from femupdate.uniqueness import counting_criteria, criteria_verdicts, define_study, exact_solutions, run_study
from femupdate.uniqueness.study import run as study_run
from femupdate.uniqueness.study import units as study_units
from femupdate.uniqueness.problem import study_problem
from femupdate.uniqueness.study import (nested_dof_sets, parse_measured_dofs, parse_modes,
                                        reference_unit, summarise)

ROOT = Path(__file__).resolve().parents[1]
K6 = (1000.0, 1800.0, 1500.0, 1200.0, 900.0, 1600.0)
M6 = (1.0, 1.2, 0.8, 1.1, 0.9, 1.0)


def six_dof():
    return chain(K6, M6, bounds=(100.0, 5000.0))


def first(n):
    return tuple(f"{i}:x" for i in range(1, n + 1))


def same_clusters(a, b, rel_tol=1e-4):
    """Two case results have the same distinct solutions, each with the same count."""
    if len(a.solutions) != len(b.solutions):
        return False
    for s in a.solutions:
        p = np.array(list(s.parameters.values()))
        hit = [t for t in b.solutions if np.all(np.abs(p - np.array(list(t.parameters.values())))
                                                <= rel_tol * np.abs(p))]
        if len(hit) != 1 or hit[0].count != s.count:
            return False
    return True


# ------------------------------------------------------------------------------ criteria
def test_criteria_reproduce_the_papers_worked_counts():
    a = counting_criteria(n=3, m=1, L=3, N=3)  # Figure 1, every dof, one mode
    assert (a["jung_ewins_lin"].count, a["botto_data"].count, a["botto_modes"].count) == (4, 3, 2)  # "4 >= 3", "3", "2"
    assert a["jung_ewins_lin"].satisfied and not a["botto_data"].satisfied and not a["botto_modes"].satisfied
    assert a["data_count"].satisfied and a["paper"].satisfied and not a["botto"].satisfied
    b = criteria_verdicts(n=1, m=2, L=2, N=2)  # Figure 3, one sensor, two modes: not unique
    assert b == {"jung_ewins_lin": True, "botto_data": False, "botto_modes": False, "botto": False,
                 "data_count": True, "paper": False}


def test_criteria_formulas_against_brute_force_counts():
    for N in range(1, 7):
        for n in range(1, N + 1):
            for m in range(1, N + 1):
                c = counting_criteria(n, m, 5, N)
                # eq. 15 counts the free entries of m orthonormal N-vectors: sum_i (N - i)
                assert c["botto_modes"].count == sum(N - i for i in range(1, m + 1))
                assert c["paper"].satisfied == (m * n >= 5 and n > 1)
                assert c["botto"].satisfied == (c["botto_data"].satisfied and c["botto_modes"].satisfied)


@pytest.mark.parametrize("args", [(0, 1, 1, 1), (1, 1, 1.5, 2), (3, 1, 1, 2), (1, 3, 1, 2)])
def test_criteria_bad_input(args):
    with pytest.raises(InputError):
        counting_criteria(*args)


# ------------------------------------------------------------------------------ exact solution sets
def test_exact_two_dof_gives_both_stiffness_pairs_as_rationals():
    ex = exact_solutions(two_dof())  # eqs. 11-12: a1 = 68, a0 = 48
    assert ex.exact_data and ex.zero_dimensional and ex.n_complex == 2 and ex.unique is False
    assert [s.exact for s in ex.solutions] == [{"k1": "8", "k2": "6"}, {"k1": "9", "k2": "16/3"}]
    assert all(s.rational and s.lowest_modes for s in ex.solutions)
    assert sp.Rational(ex.solutions[1].exact["k2"]) == sp.Rational(16, 3)


def test_exact_from_given_rational_eigenvalues_closed_form():
    # m1 = m2 = 1: trace k1 + 2 k2 = λ1 + λ2 = 7, det k1 k2 = λ1 λ2 = 6  =>  2 k2² - 7 k2 + 6 = 0
    model = chain([3.0, 2.0], [1.0, 1.0], bounds=(0.0, 10.0))
    ex = exact_solutions(model, eigenvalues=["1", "6"])
    assert [s.exact for s in ex.solutions] == [{"k1": "3", "k2": "2"}, {"k1": "4", "k2": "3/2"}]
    # the closed form, independently: the two roots of 2 k2^2 - 7 k2 + 6
    k2 = sorted(np.roots([2, -7, 6]))
    np.testing.assert_allclose(sorted(s.parameters["k2"] for s in ex.solutions), k2, rtol=1e-15)


def test_exact_three_spring_chain_matches_eigensolutions_and_random_starts():
    model = chain([1000.0, 2000.0, 1500.0], [1.0, 1.5, 2.0], bounds=(1.0, 20000.0))
    ex = exact_solutions(model)
    assert ex.n_complex == 6  # 3! complex solutions of the coefficient equations
    assert len(ex.solutions) == 2 and any(s.rational and s.exact == {"k1": "1000", "k2": "2000", "k3": "1500"}
                                          for s in ex.solutions)
    lam = eigh(model.K().toarray(), model.M().toarray(), eigvals_only=True)
    for s in ex.solutions:  # second route: every solution has the measured eigenvalues
        ev = eigh(model.K(s.parameters).toarray(), model.M().toarray(), eigvals_only=True)
        np.testing.assert_allclose(ev, lam, rtol=1e-12)
    # third route: random starts from frequencies alone find the same two solutions, and no other
    st = define_study(model, [(("1:x",), 3)], starts=60, seed=4)
    mc = run_study(st).cases[0]
    assert same_clusters(mc, mc) and len(mc.solutions) == 2
    for s in mc.solutions:
        assert min(np.max(np.abs(np.array(list(s.parameters.values())) - np.array(list(e.parameters.values())))
                          / np.array(list(e.parameters.values()))) for e in ex.solutions) < 1e-8


def test_exact_with_a_mass_parameter_closed_form_and_what_random_starts_miss():
    """Unknowns k1 and m2 (k2 = 6, m1 = 2 known): a0/a2 = 6 gives k1 = 2 m2 and a1/a2 = 8.5 gives
    2 m2² - 11 m2 + 12 = 0, so (k1, m2) = (8, 4) or (3, 3/2)."""
    from femupdate import Structure

    s = Structure("mass parameter")
    s.parameter("k1", 8.0, (0.0, 100.0))
    s.parameter("m2", 4.0, (0.1, 100.0))
    s.spring(["1:x"], k="k1")
    s.spring(["1:x", "2:x"], k=6.0)
    s.mass(["1:x"], m=2.0)
    s.mass(["2:x"], m="m2")
    model = s.build()
    ex = exact_solutions(model)
    assert [x.exact for x in ex.solutions] == [{"k1": "3", "m2": "3/2"}, {"k1": "8", "m2": "4"}]
    # the second solution's basin is a small corner of the box: random starts may miss it, which
    # is why a Monte Carlo "unique" means "one solution found" (the exact set settles it)
    mc = run_study(define_study(model, [(("1:x",), 2)], starts=20, seed=1)).cases[0]
    assert mc.solutions[0].is_truth and len(mc.solutions) <= 2


def test_exact_partial_eigenvalues_and_continuum_and_limits():
    m3 = three_dof()
    part = exact_solutions(m3, n_modes=2, params=["k1", "k2"])  # k3 known, two lowest modes
    assert not part.exact_data and part.notes
    truth = [s for s in part.solutions if abs(s.parameters["k1"] - 1000) < 1e-6 and abs(s.parameters["k2"] - 2000) < 1e-6]
    assert len(truth) == 1
    for s in part.solutions + part.rejected:  # each reproduces the two eigenvalues; the rejected not as the lowest
        ev = eigh(m3.K(s.parameters).toarray(), m3.M().toarray(), eigvals_only=True) if s.physical else None
        if s.valid:
            np.testing.assert_allclose(ev[:2], part.measured_eigenvalues, rtol=1e-9)
    cont = exact_solutions(two_dof(), n_modes=1)  # one eigenvalue, two unknowns
    assert not cont.zero_dimensional and cont.unique is False and cont.n_complex is None
    with pytest.raises(InputError, match="limited to 4 unknown parameters"):
        exact_solutions(six_dof())
    with pytest.raises(InputError, match="ascending"):
        exact_solutions(two_dof(), eigenvalues=[5.0, 1.0])
    with pytest.raises(InputError, match="not a number"):
        exact_solutions(two_dof(), eigenvalues=["one", "2"])


# ------------------------------------------------------------------------------ the batched problem
def test_study_problem_residuals_and_jacobians_equal_update_problem(rng):
    """Every row of a study (its own case's data set) evaluated by the compiled kernels against
    the local route's Problem of that case and start (Nelson derivatives), row by row."""
    model = six_dof()
    cases = [(first(1), 4), (first(2), 3), (("2:x", "5:x", "6:x"), 2), (first(6), 6), (("4:x", "1:x"), 5)]
    st = define_study(model, cases, starts=3, seed=5)
    pieces = [(c, 0, 0, 3) for c in range(len(cases))]
    rows, X0 = study_units.row_data(st, pieces)
    P = st.truth * rng.uniform(0.85, 1.15, X0.shape)  # near the truth (pairs by MAC), not at the starts
    prob = study_problem(model, st.names, rows, X0, values=st.truth)
    X = P / prob.scale
    ev = prob.evaluate(X)  # the compiled kernels: each row's own residuals first
    assert ev.messages == [None] * X.shape[0]
    for r in range(X.shape[0]):
        c = r // 3
        data = study_units.case_testdata(st, c)
        ref = Problem(model, data, st.names, x0=dict(zip(st.names, X0[r])), values=st.truth)
        f_ref, J_ref = ref.residuals(X[r]), ref.jacobian(X[r])
        # compiled: per mode the eigenvalue, then the shape at the row's dofs in ascending dof order
        pos = model.dof_index(st.cases[c].measured_dofs)
        ns = len(pos) if len(pos) >= 2 else 0
        order = np.concatenate([[k * (1 + ns)] + list(k * (1 + ns) + 1 + np.argsort(pos[:ns]))
                                for k in range(st.cases[c].n_modes)]).astype(int)
        m = f_ref.size
        assert prob.n_residuals[r] == m
        np.testing.assert_allclose(ev.fun[r, :m], f_ref[order], rtol=1e-9, atol=1e-12)
        np.testing.assert_allclose(ev.jac[r, :m], J_ref[order], rtol=1e-6, atol=1e-9 * np.abs(J_ref).max())
        assert np.all(ev.fun[r, m:] == 0) and np.all(ev.jac[r, m:] == 0)


def cluster_solutions(points, costs, rel_tol):
    """The greedy clustering written out point by point (the reference for the vectorised one)."""
    reps, groups = [], []
    for i in np.argsort(costs):
        for g, r in enumerate(reps):
            if np.all(np.abs(points[i] - points[r]) <= rel_tol * np.maximum(np.abs(points[r]), 1e-300)):
                groups[g].append(int(i))
                break
        else:
            reps.append(int(i))
            groups.append([int(i)])
    return groups


def test_fast_clustering_equals_multistart_cluster(rng):
    base = rng.uniform(1, 10, (6, 3))
    pts = np.repeat(base, 7, axis=0) * (1 + 1e-6 * rng.standard_normal((42, 3)))
    pts[::5] *= 1 + 3e-4 * rng.standard_normal((9, 3))  # some straddle the tolerance
    costs = rng.uniform(0, 1, 42)
    assert sorted(map(sorted, cluster_solutions(pts, costs, 1e-4))) == sorted(map(sorted, cluster(pts, costs, 1e-4)))


# ------------------------------------------------------------------------------ the study
@pytest.fixture(scope="module")
def small_study():
    model = six_dof()
    cases = [(first(1), 6), (first(2), 3), (first(2), 4), (first(3), 3), (first(6), 1)]
    return define_study(model, cases, starts=16, seed=7)


@pytest.fixture(scope="module")
def small_result(small_study):
    return run_study(small_study)


def test_batched_study_equals_per_start_route(small_study, small_result):
    """Cluster for cluster and start for start against one update() (SciPy least squares) per start."""
    st = small_study
    raw = [reference_unit(st, c) for c in range(len(st.cases))]
    ref = summarise(st, raw)
    for a, b, ra in zip(small_result.cases, ref, raw):
        piece = next(p for p in small_result.raw if p["case"] == ra["case"])
        fb = np.array(piece["status"]) > 0
        fa = np.array(ra["status"]) > 0
        near_limit = (np.array(piece["nfev"]) > 0.9 * st.max_nfev) | (np.array(ra["nfev"]) > 0.9 * st.max_nfev)
        assert np.array_equal(fa[~near_limit], fb[~near_limit]), a.case
        if not near_limit.any():
            assert (a.converged, a.local_minima, a.not_converged, a.failed) == \
                   (b.converged, b.local_minima, b.not_converged, b.failed)
            assert same_clusters(a, b), a.case
        assert a.verdict == b.verdict
    verdicts = {(c.case.n_measured, c.case.n_modes): c.verdict for c in small_result.cases}
    assert verdicts[(2, 4)] == verdicts[(3, 3)] == verdicts[(6, 1)] == "unique"
    assert verdicts[(1, 6)] == verdicts[(2, 3)] == "non-unique"


def test_study_result_content(small_study, small_result):
    by = {(c.case.n_measured, c.case.n_modes): c for c in small_result.cases}
    assert by[(2, 4)].solutions[0].is_truth and by[(2, 4)].solutions[0].max_rel_error < 1e-8
    assert not np.isfinite(by[(1, 6)].condition_number) or by[(1, 6)].condition_number < 1e3
    assert by[(2, 3)].condition_number > 1e14 and by[(2, 3)].rank == 5  # singular: a continuum
    assert by[(6, 1)].condition_number < 100
    d = small_result.to_dict()
    for c in d["cases"]:
        for key in ("measured_dofs", "n_modes", "criteria", "starts", "converged", "solutions", "unique",
                    "condition_number"):
            assert key in c
        assert all(set(s) >= {"parameters", "count"} for s in c["solutions"])
    json.dumps(to_jsonable(d), allow_nan=False)  # inf condition numbers become null


def test_noise_scatter_follows_conditioning():
    st = define_study(six_dof(), [(first(6), 2)], starts=40, seed=3, noise=[1e-3])
    z = run_study(st).cases[0].noise[0]
    assert z.converged >= 30
    rms, pred = np.array(list(z.rms_rel_error.values())), np.array(list(z.predicted_std.values()))
    assert np.all(np.isfinite(pred))
    ratio = rms / pred
    assert np.all((ratio > 0.5) & (ratio < 2.0)), ratio  # 40 draws: the RMS is within ±50 % of σ


def test_split_into_units_does_not_change_the_answer(small_study, small_result):
    split = define_study(small_study.model, small_study.cases, starts=16, seed=7, unit_rows=20)
    assert len(split.units()) > 3 and split.key() != small_study.key()
    res = run_study(split)
    for a, b in zip(small_result.cases, res.cases):
        assert same_clusters(a, b) and a.verdict == b.verdict


def test_checkpoint_resume_after_interruption(small_study, small_result, tmp_path, monkeypatch):
    st = define_study(small_study.model, small_study.cases, starts=16, seed=7, unit_rows=32)
    n_units = len(st.units())
    ck = tmp_path / "study.checkpoint.json"
    calls = []
    real = study_run.solve_unit

    def interrupted(study, unit, progress=None):
        if len(calls) == 2:
            raise KeyboardInterrupt
        calls.append(unit)
        return real(study, unit, progress)

    monkeypatch.setattr(study_run, "solve_unit", interrupted)
    with pytest.raises(KeyboardInterrupt):
        run_study(st, checkpoint=ck)
    saved = json.loads(ck.read_text())
    assert sorted(saved["units"]) == ["0", "1"]  # the finished units, written atomically
    monkeypatch.setattr(study_run, "solve_unit", lambda study, unit, progress=None: (calls.append(unit), real(study, unit, progress))[1])
    res = run_study(st, checkpoint=ck)
    assert calls == [0, 1] + list(range(2, n_units))  # nothing recomputed
    assert (res.units_resumed, res.units_computed) == (2, n_units - 2)
    again = run_study(st, checkpoint=ck)
    assert again.units_computed == 0
    fresh = run_study(st)
    assert json.dumps(again.to_dict()["cases"], default=str) == \
        json.dumps(fresh.to_dict()["cases"], default=str)  # bit-identical after a resume
    other = define_study(small_study.model, small_study.cases, starts=16, seed=8, unit_rows=32)
    with pytest.raises(InputError, match="different study"):
        run_study(other, checkpoint=ck)
    ck.write_text("{not json")
    with pytest.raises(InputError, match="not a readable"):
        run_study(st, checkpoint=ck)


def _tamper(doc, unit, edit, redigest):
    from femupdate.uniqueness.checkpoint import digest

    edit(doc["units"][unit])
    if redigest:  # an edit that also fixes the digest: only the layout check can catch it
        doc["digests"][unit] = digest(doc["units"][unit])
    return doc


@pytest.mark.parametrize("edit, redigest, match", [
    (lambda u: u[0]["cost"].__setitem__(0, 123.0), False, "does not match its digest"),
    (lambda u: u[0].pop("status"), True, "lacks status"),
    (lambda u: u[0].__setitem__("nfev", ["7"] * len(u[0]["nfev"])), True, "must be integers"),
    (lambda u: u[0]["x"].__setitem__(0, [1.0]), True, "numbers per start"),
    (lambda u: u[0].__setitem__("case", 99), True, "the study's is case"),
    (lambda u: u[0]["cost"].pop(), True, "one per start"),
    (lambda u: u.clear(), True, "pieces recorded"),
])
def test_checkpoint_units_are_checked_one_by_one(small_study, tmp_path, edit, redigest, match):
    st = define_study(small_study.model, small_study.cases, starts=16, seed=7, unit_rows=32)
    ck = tmp_path / "study.checkpoint.json"
    run_study(st, checkpoint=ck)
    doc = json.loads(ck.read_text())
    assert doc["version"] == 2 and sorted(doc["digests"]) == sorted(doc["units"])
    ck.write_text(json.dumps(_tamper(doc, "0", edit, redigest)))
    with pytest.raises(InputError, match=f"unit 0: .*{match}"):
        run_study(st, checkpoint=ck)


def test_checkpoint_unknown_unit_and_version_1_files(small_study, small_result, tmp_path):
    st = define_study(small_study.model, small_study.cases, starts=16, seed=7, unit_rows=32)
    ck = tmp_path / "study.checkpoint.json"
    reference = run_study(st, checkpoint=ck)
    doc = json.loads(ck.read_text())
    extra = dict(doc, units=dict(doc["units"], **{"999": doc["units"]["0"]}),
                 digests=dict(doc["digests"], **{"999": doc["digests"]["0"]}))
    ck.write_text(json.dumps(extra))
    with pytest.raises(InputError, match="unit 999: the study has"):
        run_study(st, checkpoint=ck)
    v1 = {k: v for k, v in doc.items() if k != "digests"} | {"version": 1}  # written by the previous version
    ck.write_text(json.dumps(v1))
    resumed = run_study(st, checkpoint=ck)
    assert resumed.units_computed == 0
    assert json.dumps(resumed.to_dict()["cases"], default=str) == json.dumps(reference.to_dict()["cases"], default=str)
    ck.write_text(json.dumps(dict(doc, version=3)))
    with pytest.raises(InputError, match="format version 3"):
        run_study(st, checkpoint=ck)


@pytest.mark.parametrize("kwargs, match", [
    (dict(cases=[(("9:x",), 1)]), "9:x"),
    (dict(cases=[(first(2), 7)]), "7 modes"),
    (dict(cases=[(first(2), 2), (first(2), 2)]), "twice"),
    (dict(cases=[(first(2), 2)], starts=0), "at least 1"),
    (dict(cases=[(first(2), 2)], noise=[-0.1]), "noise"),
    (dict(cases=[]), "no cases"),
    (dict(cases=[(first(2), 2)], values={"k1": 99.0}), "outside the bounds"),
])
def test_study_bad_input(kwargs, match):
    with pytest.raises(InputError, match=match):
        define_study(six_dof(), **kwargs)


def test_study_needs_finite_bounds_and_flexible_modes():
    with pytest.raises(InputError, match="finite bounds"):
        define_study(chain(K6, M6), [(first(2), 2)])  # bounds (0, inf)
    from femupdate import Structure

    s = Structure("free-free")
    s.parameter("k", 10.0, (1.0, 100.0))
    s.spring(["1:x", "2:x"], k="k")
    s.mass(["1:x"], m=1.0)
    s.mass(["2:x"], m=1.0)
    with pytest.raises(InputError, match="rigid-body"):
        define_study(s.build(), [(("1:x", "2:x"), 2)])


def test_parsers():
    assert parse_measured_dofs("1:x, 2:X;1:x") == [("1:x", "2:x"), ("1:x",)]
    assert parse_modes("1-3,6") == [1, 2, 3, 6]
    with pytest.raises(InputError):
        parse_measured_dofs("1:x;;2:x")
    with pytest.raises(InputError):
        parse_modes("3-1")
    assert nested_dof_sets(six_dof(), 2) == [("1:x",), ("1:x", "2:x")]


# ------------------------------------------------------------------------------ Dask
def test_study_on_a_dask_cluster_matches_local(small_study, small_result):
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=False, protocol="tcp",
                                  host="127.0.0.1", dashboard_address=None) as cl:
        remote = run_study(small_study, scheduler=cl.scheduler_address)
    assert remote.route.startswith("dask:tcp://127.0.0.1")
    assert json.dumps(remote.to_dict()["cases"], default=str) == json.dumps(small_result.to_dict()["cases"], default=str)


def test_a_worker_lost_mid_study_does_not_change_the_result(small_study, small_result):
    """A worker process killed (SIGKILL) while units are in flight: its tasks are recomputed."""
    import signal

    distributed = pytest.importorskip("distributed")
    st = define_study(small_study.model, small_study.cases, starts=16, seed=7, unit_rows=8)
    local = run_study(st)
    killed = []
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                                  dashboard_address=None) as cl:
        pid = next(iter(cl.workers.values())).process.process.pid

        def progress(done, total):
            if done and not killed:  # the first unit is back; the others are queued or running
                os.kill(pid, signal.SIGKILL)
                killed.append((done, total))

        remote = run_study(st, scheduler=cl.scheduler_address, progress=progress)
    assert killed and killed[0][0] < killed[0][1]
    assert json.dumps(remote.to_dict()["cases"], default=str) == json.dumps(local.to_dict()["cases"], default=str)


def test_unreachable_scheduler_is_input_error(small_study):
    pytest.importorskip("distributed")
    with pytest.raises(InputError, match="cannot reach the Dask scheduler"):
        run_study(small_study, scheduler="tcp://127.0.0.1:9", connect_timeout=1.0)


# ------------------------------------------------------------------------------ command line
SIX_TOML = "\n".join(
    ['[model]', 'name = "six-dof chain"']
    + sum(([f"[parameters.k{i}]", f"value = {k}", "bounds = [100.0, 5000.0]"] for i, k in enumerate(K6, 1)), [])
    + sum((["[[element]]", 'type = "spring"', f'dofs = ["{i}:x"]' if i == 1 else f'dofs = ["{i - 1}:x", "{i}:x"]',
            f'k = "k{i}"'] for i in range(1, 7)), [])
    + sum((["[[element]]", 'type = "mass"', f'dofs = ["{i}:x"]', f"m = {m}"] for i, m in enumerate(M6, 1)), []))


def run(args, capsys):
    with pytest.raises(SystemExit) as info:
        main(args)
    out, err = capsys.readouterr()
    return info.value.code, out, err


def test_cli_json_keys_plot_and_resume(tmp_path, capsys):
    model = tmp_path / "six.toml"
    model.write_text(SIX_TOML)
    code, out, err = run(["uniqueness", str(model), "--measured-dofs", "1:x,2:x,3:x;1:x", "--modes", "1,3",
                          "--starts", "8", "--seed", "2", "--json", "-"], capsys)
    assert code == 0, err
    res = json.loads(out)  # nothing but JSON on stdout
    assert len(res["cases"]) == 4 and res["starts"] == 8
    for c in res["cases"]:
        assert set(c) >= {"measured_dofs", "n_modes", "criteria", "starts", "converged", "solutions", "unique",
                          "condition_number"}
    assert res["cases"][1]["measured_dofs"] == ["1:x", "2:x", "3:x"] and res["cases"][1]["n_modes"] == 3
    assert res["cases"][1]["unique"] is True
    assert set(res["criteria_agreement"]) == {"jung_ewins_lin", "botto_data", "botto_modes", "botto", "data_count", "paper"}
    out_json = tmp_path / "r.json"
    args = ["uniqueness", str(model), "--measured-dofs", "1:x", "--modes", "2", "--starts", "6", "--json",
            str(out_json), "--plot", str(tmp_path / "fig"), "--exact", "--params", "k1,k2",
            "--set", "k3=1500,k4=1200,k5=900,k6=1600"]
    code, out, err = run(args, capsys)
    assert code == 0, err
    assert "uniqueness study" in out and (tmp_path / "fig" / "uniqueness.png").stat().st_size > 1000
    r1 = json.loads(out_json.read_text())
    assert r1["units"]["computed"] == 1 and (tmp_path / "r.checkpoint.json").exists()
    assert r1["cases"][0]["exact"]["n_solutions"] >= 1
    code, out, err = run(args, capsys)
    r2 = json.loads(out_json.read_text())
    assert code == 0 and r2["units"] == {"total": 1, "computed": 0, "resumed": 1}
    assert r2["cases"] == r1["cases"]


@pytest.mark.parametrize("extra, match", [
    (["--measured-dofs", "1:x,7:x"], "7:x"),
    (["--modes", "0"], "positive"),
    (["--noise", "abc"], "--noise"),
    (["--scheduler", "tcp://127.0.0.1:9", "--connect-timeout", "1"], "cannot reach the Dask scheduler"),
])
def test_cli_bad_input_exit_2(tmp_path, capsys, extra, match):
    model = tmp_path / "six.toml"
    model.write_text(SIX_TOML)
    code, out, err = run(["uniqueness", str(model), "--starts", "2", "--modes", "1", "--json", "-"] + extra, capsys)
    assert code == 2 and match in err and "Traceback" not in err


# ------------------------------------------------------------------------------ paper sections, benchmark
def test_paper_section_criteria_examples(tmp_path):
    from femupdate.paper.uniqueness_sections import criteria_examples

    sec = criteria_examples(tmp_path, figures=False)
    assert sec["agrees_with_paper"] is True
    assert sec["criterion_right_on_A_and_B"]["paper"] == [True, True]
    assert sec["criterion_right_on_A_and_B"]["jung_ewins_lin"] == [True, False]
    b = sec["case_B_two_dof_one_dof_two_modes"]["true_answer"]
    assert b["exact_solutions"] == [{"k1": "8", "k2": "6"}, {"k1": "9", "k2": "16/3"}]


def test_paper_section_six_dof(tmp_path):
    from femupdate.paper.uniqueness_sections import six_dof_uniqueness

    sec = six_dof_uniqueness(tmp_path, figures=True)
    t = sec["table"]
    assert len(t) == 36 and (tmp_path / sec["figure"]).stat().st_size > 1000
    for key, c in t.items():
        n, m = c["n"], c["m"]
        if n * m < 6 or n == 1:  # too few data, or frequencies only: never unique
            assert c["verdict"] == "non-unique", key
        elif m + n >= 6 and m * (n - 1) >= n:  # the chain's own count (see the section's finding)
            assert c["verdict"] == "unique", key
    assert sec["paper_criterion_mismatches"] == ["2x3", "3x2"]
    assert t["2x3"]["condition_number"] > 1e14 and t["3x2"]["condition_number"] > 1e14
    assert "1:x,3:x,5:x" not in sec["sensor_placements"]["3x2"]["singular"]


def test_bench_uniqueness_quick_runs(tmp_path):
    out = tmp_path / "b.json"
    proc = subprocess.run([sys.executable, str(ROOT / "benchmarks" / "bench_uniqueness.py"), "--quick", "--repeat", "1",
                           "--output", str(out)], capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    res = json.loads(out.read_text())
    assert res["agreement"]["cases_same"] == res["agreement"]["of"] == 9
    assert res["ratio_a_over_f"] > 1


@pytest.mark.parametrize("text, fragment", [
    ('{"format": "femupdate-uniqueness-checkpoint", "version": 2, "study": "k", "units": {"0": [NaN]}}', "NaN"),
    ('{"format": "femupdate-uniqueness-checkpoint", "version": 2, "study": "k", "units": {"0": [' + "1" * 5000 + ']}}',
     "digits"),
    ("[" * 100_000 + "]" * 100_000, "nested too deeply"),
    ('{"format": "femupdate-uniqueness-checkpoint", "version": 2, "study": "k", "units": {"0": [Infinity]}}',
     "Infinity"),
], ids=["nan", "5000-digit integer", "deep nesting", "infinity"])
def test_checkpoint_with_nan_huge_integer_or_deep_nesting_is_refused(tmp_path, text, fragment):
    from femupdate._errors import InputError
    from femupdate.uniqueness.checkpoint import Checkpoint

    ck = tmp_path / "bad.checkpoint.json"
    ck.write_text(text)
    with pytest.raises(InputError, match="not a readable femupdate checkpoint") as info:
        Checkpoint(ck, key="k", description={})
    assert str(ck) in str(info.value) and fragment in str(info.value)
