"""An external code as a black box (issue 29 item 3).

References: OpenSees itself (its assembled matrices at values no probe used, and its own
eigen-solution ``ops.eigen`` at the updated values against the truth's), and spring chains whose
matrices are written down directly."""

from __future__ import annotations

import json
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest
import scipy.linalg as sl

from femupdate import InputError, MeasuredMode, Parameter, TestData, load_model
from femupdate.blackbox import BlackBox, Cache, Command, Function, ProbeOptions, probe_model, update_black_box

from conftest import heavy

HERE = Path(__file__).resolve().parent
DOCS = HERE.parent / "docs" / "blackbox"


@pytest.fixture(scope="module")
def frame():
    """The OpenSees portal frame of docs/blackbox (skipped where OpenSeesPy does not load)."""
    sys.path.insert(0, str(DOCS))
    try:
        import opensees_frame as fr
        try:
            fr.opensees()
        except Exception:  # noqa: BLE001 - not installed, or its libraries do not load
            pytest.skip("OpenSeesPy is not available (pip install openseespy)")
        yield fr
    finally:
        sys.path.remove(str(DOCS))


def opensees_data(fr, truth, n=4):
    lam, shapes = fr.eigen(truth, n)
    return TestData(modes=tuple(MeasuredMode(float(v), tuple(s), np.array(list(s.values()))) for v, s in zip(lam, shapes)))


def frame_matrices(values):
    import opensees_frame as fr

    return fr.matrices(values)


def test_opensees_frame_section_height_and_modulus_updated_to_the_truth(frame):
    """h enters as b h (area, mass) and b h^3 / 12 (bending): not affine; E_cols is.  Noise-free modes by
    OpenSees' eigen-solver at the truth; OpenSees' eigen-solution at the answer gives them back to 1e-6."""
    truth = {"E_cols": 1.9e11, "h": 0.34}
    box = BlackBox(Function(frame_matrices), [Parameter("E_cols", 2.1e11, (1e11, 4e11)), Parameter("h", 0.3, (0.1, 0.6))])
    probed = probe_model(box)
    assert probed.affine == {"E_cols": True, "h": False}
    assert probed.deviation["E_cols"] < 1e-12 and probed.deviation["h"] > 1e-3
    res = update_black_box(box, opensees_data(frame, truth))
    assert len(res.rounds) >= 2  # the first fit (around the nominal values) is not good enough at the answer
    last = res.rounds[-1]
    assert last["matrix_deviation"] <= 1e-6 and last["frequency_deviation"] <= 1e-6
    got = frame.frequencies(res.parameters, 4)
    want = frame.frequencies(truth, 4)
    assert np.max(np.abs(got / want - 1)) < 1e-6, got / want - 1
    for k, v in truth.items():
        assert abs(res.parameters[k] / v - 1) < 1e-5, (k, res.parameters[k])
    assert res.result.start == {"E_cols": 2.1e11, "h": 0.3}
    # every run was cached: a second update runs the code no more
    runs = box.cache.runs
    again = update_black_box(box, opensees_data(frame, truth))
    assert box.cache.runs == runs and again.parameters == res.parameters


def test_affine_modulus_is_exact_against_an_opensees_run_no_probe_used(frame):
    def columns(values):
        return frame.matrices({"E_cols": values["E_cols"], "h": 0.3})

    box = BlackBox(Function(columns), [Parameter("E_cols", 2.1e11, (1e10, 1e12))])
    probed = probe_model(box)
    assert probed.affine == {"E_cols": True} and not probed.model.terms
    K, M, dofs = columns({"E_cols": 3.7e11})
    assert probed.model.dofs == tuple(dofs)
    assert np.abs(probed.model.K({"E_cols": 3.7e11}).toarray() - K).max() <= 1e-12 * np.abs(K).max()
    assert np.abs(probed.model.M({"E_cols": 3.7e11}).toarray() - M).max() <= 1e-12 * np.abs(M).max()
    lam = sl.eigh(K, M, eigvals_only=True)[:3]
    res = update_black_box(box, TestData(modes=tuple(MeasuredMode(float(v)) for v in lam)))
    assert len(res.rounds) == 1 and abs(res.parameters["E_cols"] / 3.7e11 - 1) < 1e-8


# ---------------------------------------------------------------- spring chains written down directly
def chain(k, m):
    """K, M of a grounded chain of springs k[i] and masses m[i]."""
    n = len(k)
    K = np.zeros((n, n))
    for i, ki in enumerate(k):
        K[i, i] += ki
        if i:
            K[i - 1, i - 1] += ki
            K[i - 1, i] -= ki
            K[i, i - 1] -= ki
    return K, np.diag(m), [f"{i + 1}:x" for i in range(n)]


def kink(values):
    """Affine in p near p = 1 (within 2 steps) but not beyond 1.12: only the random checks see it."""
    p = values["p"]
    return chain([1000.0 * p + 5e5 * max(0.0, p - 1.12) ** 2, 800.0, 600.0], [1.0, 1.0, 1.0])


def product(values):
    return chain([1000.0 * values["E"] * values["h"] ** 3, 800.0], [1.0, 1.0])


def test_affinity_check_catches_what_the_axis_probes_miss():
    box = BlackBox(Function(kink), [Parameter("p", 1.0, (0.5, 2.0))], options=ProbeOptions(checks=0))
    assert probe_model(box).affine == {"p": True}  # the axis probes reach 1.1 only
    box = BlackBox(Function(kink), [Parameter("p", 1.0, (0.5, 2.0))], options=ProbeOptions(checks=6))
    probed = probe_model(box)
    assert probed.affine == {"p": False} and probed.deviation["p"] > 1e-6
    # a parameter that is truly affine passes the same check (tolerance 1e-8 of the largest entry)
    box = BlackBox(Function(lambda v: chain([1000.0 * v["p"], 800.0, 600.0], [1.0, 2.0, 1.0])),
                   [Parameter("p", 1.0, (0.5, 2.0))], options=ProbeOptions(checks=6))
    assert probe_model(box).affine == {"p": True}


def test_interacting_parameters_refused_by_name():
    box = BlackBox(Function(product), [Parameter("E", 1.0, (0.1, 10)), Parameter("h", 1.0, (0.1, 10))])
    with pytest.raises(InputError, match=r"black box 'black box': the parameters interact: at E=.*h=.*E\*h\^3"):
        probe_model(box)


SCRIPT = textwrap.dedent("""\
    import sys
    v = dict(a.split("=") for a in sys.argv[1:])
    p, mode = float(v["p"]), v.get("mode", "ok")
    if mode == "fail":
        print("solver: negative pivot in row 2")
        sys.exit(3)
    n = 4 if (mode == "grow" and p > 1.0) else 3
    k = [1000.0 * p ** 3] + [800.0] * (n - 1)
    K = {}
    for i, ki in enumerate(k):
        K[i, i] = K.get((i, i), 0.0) + ki
        if i:
            K[i - 1, i - 1] += ki
            K[i, i - 1] = -ki
    if mode == "nan":
        K[0, 0] = float("nan")
    M = {(i, i): (1.0 + 0.5 * p if i == 0 else 1.0) for i in range(n)}

    def write(name, A):  # Matrix Market, the lower triangle of a symmetric matrix
        with open(name, "w") as fh:
            fh.write(f"%%MatrixMarket matrix coordinate real symmetric\\n{n} {n} {len(A)}\\n")
            fh.writelines(f"{i + 1} {j + 1} {x!r}\\n" for (i, j), x in sorted(A.items()))

    if mode != "nofile":
        write("K.mtx", K)
    write("M.mtx", M)
    open("dofs.txt", "w").write("".join(f"{i + 1}:x\\n" for i in range(n)))
    """)


def spring_truth(p):
    K, M, _ = chain([1000.0 * p**3, 800.0, 800.0], [1.0 + 0.5 * p, 1.0, 1.0])
    return sl.eigh(K, M, eigvals_only=True)


def write_model(folder: Path, mode="ok", extra="") -> Path:
    (folder / "springs.py").write_text(SCRIPT)
    (folder / "springs.toml").write_text(textwrap.dedent(f"""\
        [blackbox]
        command = "{{python}} {{base}}/springs.py p={{p}} mode={mode}"
        inputs = ["springs.py"]
        {extra}
        [parameters.p]
        value = 1.0
        bounds = [0.5, 2.0]
        """))
    return folder / "springs.toml"


def femupdate(*args, cwd):
    import os

    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(HERE.parent / "src"), os.environ.get("PYTHONPATH", "")]))
    return subprocess.run([sys.executable, "-m", "femupdate", *map(str, args)], capture_output=True, text=True, cwd=cwd,
                          env=env)


def test_command_route_updates_a_cubic_spring_through_the_command_line(tmp_path):
    """k = 1000 p^3, m = 1 + p/2 (a quadratic fit is not exact): the eigenvalues of the chain at p = 1.3,
    written down directly, give p back; the runs are cached in springs.toml.runs."""
    model = write_model(tmp_path)
    data = {"modes": [{"eigenvalue": float(v)} for v in spring_truth(1.3)]}
    (tmp_path / "test.json").write_text(json.dumps(data))
    out = femupdate("update", model, tmp_path / "test.json", "--json", tmp_path / "out.json", cwd=tmp_path)
    assert out.returncode == 0, out.stderr
    assert "black box:" in out.stdout and "round(s)" in out.stdout
    written = json.loads((tmp_path / "out.json").read_text())
    got = written["parameters"]["p"]
    assert abs(got / 1.3 - 1) < 1e-6, got
    rounds = written["black_box"]["rounds"]
    assert len(rounds) >= 2 and rounds[-1]["matrix_deviation"] <= 1e-6 and rounds[0]["affine"] == {"p": False}
    from femupdate import schema

    schema.check(written, "update")
    assert len(list((tmp_path / "springs.toml.runs").glob("*.npz"))) >= 7
    # the probed model at the nominal value, from the cache: the same K as the script's at p = 1
    m = load_model(model)
    K, _, _ = chain([1000.0, 800.0, 800.0], [1.5, 1.0, 1.0])
    assert np.abs(m.K().toarray() - K).max() <= 1e-12 * 1800


@pytest.mark.parametrize("mode, message", [
    ("fail", r"command `.*springs.py p=1.0 mode=fail` failed with exit status 3; its output:\nsolver: negative pivot in row 2"),
    ("nofile", r"command `.*mode=nofile` ended \(status 0\) but wrote no K.mtx in its folder \(it wrote: M.mtx, dofs.txt\)"),
    ("grow", r"the black-box run at p=1\.05 gave 4 dofs where the run at p=1 gave 3: the code's dofs .* must not change"),
    ("nan", r"the black-box run at p=1 \(command `.*mode=nan`\): its K \(K.mtx\) holds NaN"),
])
def test_bad_runs_named(tmp_path, mode, message):
    with pytest.raises(InputError, match=message):
        load_model(write_model(tmp_path, mode))


def test_a_failing_command_is_exit_2_without_traceback(tmp_path):
    out = femupdate("modes", write_model(tmp_path, "fail"), cwd=tmp_path)
    assert out.returncode == 2, (out.returncode, out.stderr)
    assert "Traceback" not in out.stderr
    assert "failed with exit status 3; its output:\nsolver: negative pivot in row 2" in out.stderr, out.stderr


def test_a_command_past_its_timeout_is_named_with_what_it_printed():
    slow = Command("echo computing; sleep 5", timeout=0.5)
    with pytest.raises(InputError, match=r"command `echo computing; sleep 5` took more than 0.5 s; its output:\ncomputing"):
        slow({"p": 1.0})


def test_nan_in_a_callable_run_and_unknown_placeholders_refused():
    def nan(values):
        K, M, d = chain([1000.0, 800.0], [1.0, 1.0])
        K[1, 1] = np.nan
        return K, M, d

    box = BlackBox(Function(nan), [Parameter("p", 1.0, (0.5, 2.0))])
    with pytest.raises(InputError, match=r"the black-box run at p=1 \(.*\.nan\(\)\): its K holds NaN"):
        probe_model(box)
    idle = BlackBox(Function(cubic), [Parameter("p", 1.0, (0.5, 2.0)), Parameter("q", 1.0)])
    with pytest.raises(InputError, match=r"the code's matrices do not change with parameter\(s\) q$"):
        probe_model(idle)
    with pytest.raises(InputError, match=r"placeholder\(s\) \{t\} name no parameter \(parameters: p;"):
        BlackBox(Command("run {p} {t}"), [Parameter("p", 1.0)])


def test_cache_folder_and_local_processes_give_the_same_model(tmp_path):
    params = [Parameter("p", 1.0, (0.5, 2.0))]
    serial = probe_model(BlackBox(Function(kink), params, options=ProbeOptions(checks=2)))
    cache = Cache(tmp_path / "runs")
    parallel = probe_model(BlackBox(Function(kink), params, cache=cache, jobs=2, options=ProbeOptions(checks=2)))
    assert np.array_equal(serial.model.K({"p": 1.3}).toarray(), parallel.model.K({"p": 1.3}).toarray())
    reread = BlackBox(Function(kink), params, cache=Cache(tmp_path / "runs"), options=ProbeOptions(checks=2))
    probe_model(reread)
    assert reread.cache.runs == 0 and reread.cache.hits == parallel.runs
    (tmp_path / "file").write_text("")
    with pytest.raises(InputError, match=r"cannot write the cache folder .*file/runs .*name another with cache ="):
        probe_model(BlackBox(Function(kink), params, cache=Cache(tmp_path / "file" / "runs")))
    with pytest.raises(InputError, match="need a picklable runner"):
        probe_model(BlackBox(Function(lambda v: kink(v)), params, jobs=2))


def test_runs_on_a_dask_cluster_give_the_same_model():
    distributed = pytest.importorskip("distributed")
    params = [Parameter("p", 1.0, (0.5, 2.0))]
    here = probe_model(BlackBox(Function(kink), params, options=ProbeOptions(checks=2)))
    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=False, protocol="tcp",
                                  host="127.0.0.1", dashboard_address=None) as cl:
        box = BlackBox(Function(kink), params, scheduler=cl.scheduler_address, options=ProbeOptions(checks=2))
        there = probe_model(box)
    assert box.cache.runs == here.runs
    assert np.array_equal(here.model.K({"p": 1.3}).toarray(), there.model.K({"p": 1.3}).toarray())


@heavy
def test_opensees_frame_as_a_command_through_the_command_line(frame, tmp_path):
    """The page's model file and script, run as printed: OpenSees as a subprocess, two processes."""
    import shutil

    shutil.copy(DOCS / "opensees_frame.py", tmp_path)
    page = (HERE.parent / "docs" / "blackbox.md").read_text()
    toml = page.split("## The model file: `[blackbox]`", 1)[1].split("```toml\n", 1)[1].split("```", 1)[0]
    (tmp_path / "frame.toml").write_text(toml)
    truth = {"E_cols": 1.9e11, "h": 0.34}
    lam, shapes = frame.eigen(truth, 4)
    modes = [{"eigenvalue": float(v), "shape": s} for v, s in zip(lam, shapes)]
    (tmp_path / "test.json").write_text(json.dumps({"modes": modes}))
    out = femupdate("update", "frame.toml", "test.json", "--json", "out.json", cwd=tmp_path)
    assert out.returncode == 0, out.stderr
    got = json.loads((tmp_path / "out.json").read_text())["parameters"]
    assert np.max(np.abs(frame.frequencies(got, 4) / frame.frequencies(truth, 4) - 1)) < 1e-6


def cubic(values):
    p = values["p"]
    return chain([1000.0 * p**3, 800.0, 800.0], [1.0 + 0.5 * p, 1.0, 1.0])


def test_an_answer_on_a_bound_is_re_probed_from_inside():
    """The truth p = 1.3 lies beyond the upper bound 1.2: the update ends on the bound, where the code's
    run agrees with the last fit (centred inside the bounds) to 1e-6."""
    data = TestData(modes=tuple(MeasuredMode(float(v)) for v in spring_truth(1.3)))
    box = BlackBox(Function(cubic), [Parameter("p", 1.0, (0.5, 1.2))])
    res = update_black_box(box, data)
    assert 1.2 - 1e-9 < res.parameters["p"] <= 1.2  # on the bound, as the bounded solver ends there
    assert all(r["center"]["p"] < 1.2 for r in res.rounds)
    assert res.rounds[-1]["matrix_deviation"] <= 1e-6


ABAQUS_SCRIPT = textwrap.dedent("""\
    import sys
    p = float(sys.argv[1])
    k1, k2 = 1000.0 * p, 800.0
    with open("job_STIF1.mtx", "w") as fh:  # *MATRIX GENERATE, matrix input format, one triangle
        fh.write("** assembled stiffness\\n")
        fh.write(f"10,1, 10,1, {k1 + k2!r}\\n20,1, 10,1, {-k2!r}\\n20,1, 20,1, {k2!r}\\n")
    with open("job_MASS1.mtx", "w") as fh:
        fh.write("10,1, 10,1, 1.0\\n20,1, 20,1, 2.0\\n")
    """)


def test_command_writing_abaqus_matrix_files(tmp_path):
    """The dof labels come from the Abaqus files themselves (nodes 10 and 20); k1 = 1000 p is affine."""
    (tmp_path / "abq.py").write_text(ABAQUS_SCRIPT)
    runner = Command("{python} {base}/abq.py {p}", K="job_STIF1.mtx", M="job_MASS1.mtx", dofs=None, format="abaqus",
                     base=str(tmp_path))
    probed = probe_model(BlackBox(runner, [Parameter("p", 1.0, (0.5, 2.0))], options=ProbeOptions(checks=1)))
    assert probed.model.dofs == ("10:x", "20:x") and probed.affine == {"p": True}
    assert np.allclose(probed.model.K({"p": 1.7}).toarray(), [[2500.0, -800.0], [-800.0, 800.0]], rtol=1e-12)


@heavy  # the representative that always runs: test_runs_on_a_dask_cluster_give_the_same_model
def test_update_scheduler_option_sends_the_runs_to_dask(tmp_path):
    """`femupdate update --scheduler`: the command's runs go to the cluster (its worker runs the script);
    the answer is the local one's."""
    distributed = pytest.importorskip("distributed")
    model = write_model(tmp_path)
    (tmp_path / "test.json").write_text(json.dumps({"modes": [{"eigenvalue": float(v)} for v in spring_truth(1.3)]}))
    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=False, protocol="tcp",
                                  host="127.0.0.1", dashboard_address=None) as cl:
        out = femupdate("update", model, "test.json", "--scheduler", cl.scheduler_address, "--json", "out.json",
                        cwd=tmp_path)
        with distributed.Client(cl.scheduler_address) as client:
            ran = client.run_on_scheduler(lambda dask_scheduler: len(dask_scheduler.task_prefixes))
    assert out.returncode == 0, out.stderr
    assert ran > 0  # tasks reached the scheduler
    assert abs(json.loads((tmp_path / "out.json").read_text())["parameters"]["p"] / 1.3 - 1) < 1e-6


def test_a_fixed_parameter_stays_at_its_value_through_the_rounds(frame):
    """E_cols fixed at a value that is not the truth's: h alone is updated, in several rounds."""
    truth = {"E_cols": 2.1e11, "h": 0.34}
    box = BlackBox(Function(frame_matrices), [Parameter("E_cols", 2.1e11, (1e11, 4e11), fixed=True),
                                              Parameter("h", 0.3, (0.1, 0.6))])
    res = update_black_box(box, opensees_data(frame, truth))
    assert tuple(res.result.names) == ("h",) and res.parameters["E_cols"] == 2.1e11
    assert abs(res.parameters["h"] / 0.34 - 1) < 1e-5 and len(res.rounds) >= 2
