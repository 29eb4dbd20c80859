"""The BLAS threading policy (femupdate._threads): one thread for solves and parallel work, the
free cores for large dense kernels, the user's override, and the limits really applied."""

from __future__ import annotations

import os

import numpy as np
import pytest
from threadpoolctl import threadpool_info

from femupdate import InputError, _threads, settings
from femupdate.cli._entry import THREADS_VARIABLE, settings_from


def blas_threads() -> set[int]:
    return {lib["num_threads"] for lib in threadpool_info() if lib["user_api"] == "blas"}


def test_solves_get_one_thread_and_the_limit_is_applied():
    with settings.using(settings.Settings()):
        assert _threads.threads_for("solve") == 1
        with _threads.blas_phase("solve"):
            assert blas_threads() == {1}
            with _threads.blas_phase("solve"):  # nested: kept
                assert blas_threads() == {1}


def test_a_dense_kernel_takes_the_free_cores_judged_by_the_load(monkeypatch):
    monkeypatch.setattr(settings, "_current", settings.Settings())
    monkeypatch.setattr(_threads, "_cores", lambda: 4)
    monkeypatch.setattr(os, "getloadavg", lambda: (1.0, 1.0, 1.0))  # this process alone
    assert _threads.threads_for("dense") == 4
    monkeypatch.setattr(os, "getloadavg", lambda: (3.0, 3.0, 3.0))  # two other processes busy
    assert _threads.threads_for("dense") == 2
    monkeypatch.setattr(os, "getloadavg", lambda: (9.0, 9.0, 9.0))  # a busy machine
    assert _threads.threads_for("dense") == 1
    monkeypatch.setattr(os, "getloadavg", lambda: (0.0, 0.0, 0.0))
    with _threads.parallel_work():  # one of several tasks: never more than one thread
        assert _threads.threads_for("dense") == 1
    assert _threads.threads_for("dense") == 4


def test_a_dense_phase_inside_a_solve_phase_sets_its_own_limit_and_restores(monkeypatch):
    with settings.using(blas_threads=1), _threads.blas_phase("solve"):
        monkeypatch.setattr(_threads, "threads_for", lambda phase: 2 if phase == "dense" else 1)
        with _threads.blas_phase("dense"):
            assert blas_threads() == {2}
        assert blas_threads() == {1}


@pytest.mark.parametrize("text, expected", [("3", 3), (" 2 ", 2), ("keep", None), ("KEEP", None)])
def test_the_user_overrides_the_policy(text, expected):
    """The command line's variable, read into the settings, overrides the policy in every phase."""
    with settings.using(settings_from({THREADS_VARIABLE: text})):
        assert _threads.threads_for("solve") == expected
        assert _threads.threads_for("dense") == expected


@pytest.mark.parametrize("text", ["0", "-1", "two", "1.5", "²"])
def test_a_bad_thread_count_is_refused_by_name(text):
    with pytest.raises(InputError, match=f"FEMUPDATE_BLAS_THREADS={text!r}"):
        settings_from({THREADS_VARIABLE: text})


@pytest.mark.parametrize("value", [0, -1, "two", 1.5, True])
def test_a_bad_thread_count_is_refused_by_the_library(value):
    with pytest.raises(InputError, match=f"blas_threads={value!r}"):
        settings.Settings(blas_threads=value)


# the command line's exit 2 on a bad FEMUPDATE_BLAS_THREADS: tests/test_settings.py


def test_a_dask_task_runs_as_parallel_work():
    from femupdate.dask_cluster import task

    assert not _threads.in_parallel_work()
    assert task(_threads.in_parallel_work) is True
    assert task(lambda: blas_threads()) == {1}
    assert not _threads.in_parallel_work()


def test_results_do_not_depend_on_the_thread_count():
    """A dense eigen-solution large enough for the dense phase, with one and with two threads:
    the same eigenvalues to round-off."""
    from femupdate.generators import frame_lattice
    from femupdate.modal import solve_modes

    m = frame_lattice(2, 2, 36).build()
    assert m.n_dofs >= _threads.LARGE_DENSE
    out = []
    for n in (1, 2):
        with settings.using(blas_threads=n):
            out.append(solve_modes(m.K(), m.M(), n_modes=6, dofs=m.dofs, method="dense").eigenvalues)
    # the lowest modes of a slender frame carry a relative error of about eps times the pencil's
    # scale over the eigenvalue (max K_ii/M_ii / lambda_1 ~ 1e6 here): 1e-10, not 1e-15
    scale = max(m.K().diagonal() / m.M().diagonal()) / out[0][0]
    assert 1e4 < scale < 1e8
    np.testing.assert_allclose(out[0], out[1], rtol=100 * scale * np.finfo(float).eps)
