"""The numerics' settings (femupdate.settings): values checked once, installed explicitly, carried to
worker processes and Dask tasks; the library reads no environment variable, the command line reads
FEMUPDATE_FACTORISATION and FEMUPDATE_BLAS_THREADS once per command and refuses bad values by name."""

from __future__ import annotations

import pickle
import re
import subprocess
import sys
from pathlib import Path

import click
import numpy as np
import pytest
import scipy.sparse as sp

import femupdate
from femupdate import InputError, _threads, settings, workspace
from femupdate.cli import main
from femupdate.cli._entry import FACTORISATION_VARIABLE, THREADS_VARIABLE, run, settings_from
from femupdate.generators import frame_lattice

SRC = Path(femupdate.__file__).resolve().parent


@pytest.fixture
def garbage(monkeypatch):
    """Both variables set to values the command line refuses."""
    monkeypatch.setenv(FACTORISATION_VARIABLE, "mumps")
    monkeypatch.setenv(THREADS_VARIABLE, "many")


def test_library_calls_ignore_the_environment(garbage):
    assert settings.current() == settings.Settings()
    auto = "cholmod" if workspace.cholmod_installed() else "pardiso" if workspace.pardiso_installed() else "superlu"
    assert workspace.backend() == auto
    assert _threads.threads_for("solve") == 1
    A = sp.csc_array(np.array([[4.0, 1.0], [1.0, 3.0]]))
    np.testing.assert_allclose(A @ workspace.factorize(A).solve(np.array([1.0, 2.0])), [1.0, 2.0], rtol=1e-14)
    model = frame_lattice(2, 2, 30, parameters="direction").build()
    assert model.n_dofs >= femupdate.modal.SPARSE_FROM
    modes = femupdate.model_modes(model, n_modes=4)
    assert modes.solver.startswith("sparse")
    assert workspace.workspace_of(model, model.K(), model.M()).backend == auto


@pytest.mark.parametrize("variable, value, message", [
    (FACTORISATION_VARIABLE, "mumps", "FEMUPDATE_FACTORISATION='mumps': not a factorisation backend"),
    (THREADS_VARIABLE, "many", "FEMUPDATE_BLAS_THREADS='many': give a positive number of threads")])
def test_the_command_line_refuses_a_bad_variable_by_name_with_exit_2(monkeypatch, capsys, variable, value, message):
    monkeypatch.setenv(variable, value)
    with pytest.raises(SystemExit) as info:
        main(["demo"])
    assert info.value.code == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err
    assert settings.current() == settings.Settings()  # nothing left installed


def test_cholmod_without_scikit_sparse_is_refused_by_name(monkeypatch):
    monkeypatch.setattr(workspace.factors, "_CHOLMOD", False)  # as if scikit-sparse were missing
    with pytest.raises(InputError, match="FEMUPDATE_FACTORISATION=cholmod needs scikit-sparse"):
        settings_from({FACTORISATION_VARIABLE: "cholmod"})
    with pytest.raises(InputError, match="'cholmod' needs scikit-sparse"):
        workspace.backend("cholmod")
    assert workspace.backend("auto") == ("pardiso" if workspace.pardiso_installed() else "superlu")


def test_pardiso_without_mkl_is_refused_by_name_and_auto_falls_back_to_superlu(monkeypatch):
    monkeypatch.setattr(workspace.factors, "_CHOLMOD", False)
    from femupdate.workspace import pardiso

    monkeypatch.setattr(pardiso, "_LIB", False)  # as if the mkl package were missing
    with pytest.raises(InputError, match="FEMUPDATE_FACTORISATION=pardiso needs MKL"):
        settings_from({FACTORISATION_VARIABLE: "pardiso"})
    with pytest.raises(InputError, match="'pardiso' needs MKL"):
        workspace.backend("pardiso")
    assert workspace.backend("auto") == "superlu"
    assert settings_from({FACTORISATION_VARIABLE: "superlu"}).factorisation == "superlu"


def test_a_command_runs_under_the_settings_of_its_environment_and_restores_them(monkeypatch):
    seen = []

    @click.group()
    def probe():
        pass

    @probe.command()
    def show():
        seen.append((settings.current(), workspace.backend()))

    monkeypatch.setenv(FACTORISATION_VARIABLE, " SuperLU ")
    monkeypatch.setenv(THREADS_VARIABLE, "2")
    with pytest.raises(SystemExit) as info:
        run(probe, ["show"])
    assert info.value.code == 0
    assert seen == [(settings.Settings(factorisation="superlu", blas_threads=2), "superlu")]
    assert settings.current() == settings.Settings()


def test_a_subprocess_command_refuses_the_variable_by_name(tmp_path):
    env = {k: v for k, v in __import__("os").environ.items() if not k.startswith("FEMUPDATE_")}
    env.update({FACTORISATION_VARIABLE: "mumps", "PYTHONPATH": str(SRC.parent)})
    out = subprocess.run([sys.executable, "-m", "femupdate", "--version"], env=env, capture_output=True, text=True,
                         cwd=tmp_path, timeout=120)
    assert out.returncode == 2
    assert "FEMUPDATE_FACTORISATION='mumps'" in out.stderr and "Traceback" not in out.stderr


def test_settings_are_values_installed_and_restored():
    base = settings.current()
    with settings.using(factorisation="superlu", blas_threads="keep") as s:
        assert settings.current() is s and s == settings.Settings("superlu", "keep")
        assert _threads.threads_for("dense") is None
        with settings.using(blas_threads=3):
            assert settings.current() == settings.Settings("superlu", 3)
        assert settings.current() is s
    assert settings.current() is base
    before = settings.configure(factorisation="superlu")
    try:
        assert settings.current().factorisation == "superlu" and before is base
    finally:
        settings.install(before)
    with pytest.raises(TypeError):
        settings.install("superlu")


def test_a_dask_task_carries_the_settings_it_was_made_under():
    from femupdate.dask_cluster import Task

    with settings.using(factorisation="superlu", blas_threads=2):
        t = pickle.loads(pickle.dumps(Task(settings.current)))  # as a task travels to a worker
        quiet = Task(_threads.in_parallel_work, parallel=False)
    before = settings.current()
    try:
        assert t() == settings.Settings("superlu", 2)  # installed where it runs
        assert quiet() is False
    finally:
        settings.install(before)


def report_settings(model, data, names, x, kwargs):
    """A start's runner that reports the settings of the process it runs in."""
    return settings.current()


def test_local_worker_processes_run_under_the_callers_settings():
    from femupdate.updating.starts import _run_processes

    with settings.using(factorisation="superlu", blas_threads=1) as s:
        pairs = _run_processes(2, None, None, [], [np.zeros(1), np.ones(1)], {}, None, report_settings)
    assert [p[0] for p in pairs] == [s, s]


def test_no_library_module_reads_the_environment():
    """Only the command line (femupdate/cli) reads environment variables; the library takes its
    settings as values."""
    reads = re.compile(r"os\.environ\.get|os\.environ\[|getenv\(|environ\.setdefault")
    found = [str(p.relative_to(SRC)) for p in SRC.rglob("*.py")
             if "cli" not in p.relative_to(SRC).parts and reads.search(p.read_text(encoding="utf-8"))]
    assert found == []
