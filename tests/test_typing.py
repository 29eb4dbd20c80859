"""The package type-checks: ``mypy src/femupdate`` with the configuration in pyproject.toml
(the public signatures carry type hints and the package ships ``py.typed``)."""

import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def test_mypy_passes_on_the_package():
    pytest.importorskip("mypy")
    proc = subprocess.run([sys.executable, "-m", "mypy", "src/femupdate"], cwd=ROOT, capture_output=True, text=True,
                          timeout=600)
    assert proc.returncode == 0, proc.stdout[-5000:] + proc.stderr[-2000:]


def test_py_typed_marker_is_shipped():
    assert (ROOT / "src" / "femupdate" / "py.typed").exists()
    assert "py.typed" in (ROOT / "pyproject.toml").read_text()
