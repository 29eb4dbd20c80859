"""What the tests of results that serialise themselves share: running the command line, the JSON
a file holds, and results and reports without what differs from run to run (times, stamps)."""

from __future__ import annotations

import json
import re

import pytest

from femupdate.cli import main


def cli(args, capsys):
    """Run ``femupdate ARGS`` in process: (exit code, stdout, stderr)."""
    with pytest.raises(SystemExit) as info:
        main([str(a) for a in args])
    out, err = capsys.readouterr()
    return info.value.code or 0, out, err


def plain(obj):
    """What a JSON file holds (tuples as lists, NaN as null)."""
    return json.loads(json.dumps(obj))


def timeless(obj):
    """``obj`` without wall-clock and CPU times (they differ from run to run)."""
    if isinstance(obj, dict):
        return {k: timeless(v) for k, v in obj.items() if k not in ("seconds", "cpu_seconds")}
    if isinstance(obj, list):
        return [timeless(v) for v in obj]
    return obj


def without_stamp(html: str) -> str:
    """An HTML report without its time stamp."""
    return re.sub(r"\d{4}-\d\d-\d\d \d\d:\d\d UTC", "<stamp>", html)
