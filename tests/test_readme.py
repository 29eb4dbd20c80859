"""The README's Python examples run as printed (a README that lies fails here)."""

import re
from pathlib import Path

import pytest

README = Path(__file__).resolve().parent.parent / "README.md"
BLOCKS = re.findall(r"```python\n(.*?)```", README.read_text(encoding="utf-8"), flags=re.S) if README.is_file() else []


@pytest.mark.skipif(not BLOCKS, reason="README.md not next to the tests (installed package)")
def test_readme_python_blocks_run_in_order():
    namespace: dict = {}
    for k, block in enumerate(BLOCKS):
        try:
            exec(compile(block, f"README.md python block {k + 1}", "exec"), namespace)
        except Exception as exc:  # pragma: no cover - the failure message is the point
            pytest.fail(f"README python block {k + 1} fails: {type(exc).__name__}: {exc}")
    assert len(namespace["sols"].solutions) == 2  # the last block's exact solution set: (8, 6), (9, 16/3)
