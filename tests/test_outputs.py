"""Outputs: every path a command will write is checked before any computation, and the temporary
files of atomic writes never outlive the process that wrote them."""

import json
import os
import subprocess
import sys
import textwrap

import pytest

from femupdate.cli import main
from femupdate.examples import example_files
from femupdate.io.results import remove_stale_temporaries, write_json


def run(args, capsys):
    with pytest.raises(SystemExit) as info:
        main(args)
    out, err = capsys.readouterr()
    return info.value.code, out + err


@pytest.fixture
def files(tmp_path):
    for name in ("two_dof.toml", "two_dof_frequencies.json"):
        (tmp_path / name).write_text(example_files()[name])
    return tmp_path


@pytest.fixture
def no_computation(monkeypatch):
    """Any update started fails the test: the refusal must come first."""
    import femupdate.updating.run as run

    def forbidden(*a, **k):
        raise AssertionError("the computation started before the output path was checked")

    monkeypatch.setattr(run, "update_modal", forbidden)


@pytest.mark.parametrize("option, target, message", [
    ("--json", "{d}", "is a folder; give a file name"),
    ("--json", "{d}/two_dof.toml/out.json", "two_dof.toml is a file, not a folder"),
    ("--plot", "{d}/two_dof.toml", "is a file; give a folder"),
])
def test_bad_output_paths_are_refused_before_computing(files, capsys, no_computation, option, target, message):
    code, out = run(["update", str(files / "two_dof.toml"), str(files / "two_dof_frequencies.json"), option,
                     target.format(d=files)], capsys)
    assert code == 2 and f"Invalid value for '{option}'" in out and message in out and "Traceback" not in out


def test_checkpoint_and_uff_paths_are_checked_too(files, capsys):
    code, out = run(["uniqueness", str(files / "two_dof.toml"), "--starts", "2", "--checkpoint", str(files)], capsys)
    assert code == 2 and "'--checkpoint'" in out and "is a folder" in out
    code, out = run(["modes", str(files / "two_dof.toml"), "--uff", str(files)], capsys)
    assert code == 2 and "'--uff'" in out


@pytest.mark.skipif(os.name != "posix" or os.geteuid() == 0, reason="needs a user that permissions apply to")
def test_an_unwritable_folder_is_refused_by_name(files, capsys, no_computation):
    locked = files / "locked"
    locked.mkdir()
    locked.chmod(0o500)
    try:
        code, out = run(["update", str(files / "two_dof.toml"), str(files / "two_dof_frequencies.json"), "--json",
                         str(locked / "out.json")], capsys)
    finally:
        locked.chmod(0o700)
    assert code == 2 and "permission denied" in out


def test_a_write_killed_before_the_rename_leaves_a_temporary_that_the_next_write_removes(tmp_path):
    target = tmp_path / "result.json"
    script = textwrap.dedent(f"""
        import os, signal
        from femupdate.io import results
        os.replace = lambda *a: os.kill(os.getpid(), signal.SIGKILL)  # killed between write and rename
        results.write_json({str(target)!r}, {{"a": 1}})
    """)
    proc = subprocess.run([sys.executable, "-c", script], capture_output=True)
    assert proc.returncode == -9
    left = [p for p in tmp_path.iterdir() if p.name.endswith(".tmp")]
    assert len(left) == 1 and not target.exists()  # the old behaviour stopped here: the file stayed for good
    write_json(target, {"a": 2})
    assert json.loads(target.read_text()) == {"a": 2}
    assert [p for p in tmp_path.iterdir() if p.name.endswith(".tmp")] == []


def test_the_temporary_file_of_a_live_writer_is_left_alone(tmp_path):
    target = tmp_path / "result.json"
    sleeper = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(30)"])
    try:
        live = tmp_path / f".result.json.femupdate-{sleeper.pid}.x1.tmp"
        live.write_text("partial")
        other = tmp_path / ".other.json.femupdate-1.x2.tmp"  # another file's temporary: not ours to judge
        other.write_text("partial")
        assert remove_stale_temporaries(target) == []
        assert live.exists() and other.exists()
    finally:
        sleeper.kill()
        sleeper.wait()
    assert remove_stale_temporaries(target) == [live]
