"""Promises of the package as a whole: a light import, the top-level names, the compiled
route's first-use line and its cache check."""

import json
import logging
import subprocess
import sys

import pytest

import femupdate


def test_import_is_light_and_loads_no_heavy_dependency():
    code = ("import sys, time; t = time.perf_counter(); import femupdate; dt = time.perf_counter() - t; "
            "import json; print(json.dumps({'dt': dt, 'mods': sorted(m for m in ('numba', 'matplotlib', 'sympy', "
            "'dask', 'scipy') if m in sys.modules)}))")
    out = json.loads(subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout)
    assert out["mods"] == []  # nothing heavy at import; each is loaded where it is used


def test_every_top_level_name_resolves():
    for name in femupdate.__all__:
        assert getattr(femupdate, name) is not None, name
    with pytest.raises(AttributeError):
        femupdate.no_such_name  # noqa: B018


def test_local_update_does_not_need_the_compiled_route():
    code = ("import sys, femupdate as fu; from femupdate.examples import two_dof; m = two_dof(); "
            "d = fu.TestData(modes=tuple(fu.MeasuredMode(l) for l in fu.model_modes(m).eigenvalues)); "
            "r = fu.update(m, d, x0={'k1': 7.5, 'k2': 6.5}); print('numba' in sys.modules, r.success)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.split()
    assert out == ["False", "True"]


def test_first_use_line_is_said_once(caplog, monkeypatch):
    from femupdate.updating.batched import driver, kernel

    monkeypatch.setattr(driver, "_ANNOUNCED", False)
    monkeypatch.setattr(kernel, "cached", lambda: False)
    with caplog.at_level(logging.INFO, logger="femupdate"):
        driver._announce_first_use()
        driver._announce_first_use()
    said = [r for r in caplog.records if "compiled batched solver" in r.getMessage()]
    assert len(said) == 1 and said[0].levelno == logging.WARNING and "building" in said[0].getMessage()


def test_stale_compiled_code_is_removed_when_a_source_changes(tmp_path):
    from types import SimpleNamespace

    from femupdate.updating.batched import kernel

    stale = [tmp_path / "kernel.solve_rows-1.py311.nbi", tmp_path / "kernel.solve_rows-1.py311.1.nbc"]
    for f in stale:
        f.write_bytes(b"old")
    (tmp_path / "kernel.sources.sha256").write_text("a stamp of other sources")
    fake = SimpleNamespace(_cache=SimpleNamespace(_cache_path=str(tmp_path)))
    kernel._fresh_cache([fake])
    assert not any(f.exists() for f in stale)
    stamp = (tmp_path / "kernel.sources.sha256").read_text()
    assert len(stamp) == 64
    # same sources: the cache is kept
    for f in stale:
        f.write_bytes(b"new")
    kernel._fresh_cache([fake])
    assert all(f.exists() for f in stale)
