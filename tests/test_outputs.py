"""Outputs: every path a command will write is checked before any computation, and the temporary
files of atomic writes never outlive the process that wrote them."""

import json
import os
import shutil
import socket
import stat
import subprocess
import sys
import textwrap
import threading
from pathlib import Path

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
    ("--json", "{d}/new/", "ends with '/', so names a folder; give a file name"),
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


# ------------------------------------------------------------------------------ what an output path is (issue 34)
def update_args(files, *extra):
    return ["update", str(files / "two_dof.toml"), str(files / "two_dof_frequencies.json"), *map(str, extra)]


@pytest.fixture
def null_device(tmp_path):
    """A private node of the null device (1, 3): a regression must not replace the machine's /dev/null."""
    p = tmp_path / "null"
    try:
        os.mknod(p, 0o666 | stat.S_IFCHR, os.makedev(1, 3))
    except (PermissionError, AttributeError):
        pytest.skip("this process may not create a device node")
    return p


def test_a_device_stays_a_device(files, capsys, null_device):
    code, out = run(update_args(files, "--json", null_device), capsys)
    assert code == 0, out
    assert stat.S_ISCHR(os.stat(null_device).st_mode)  # was replaced by a regular file holding the JSON


def test_json_to_dev_stdout_reaches_standard_output_and_keeps_a_redirected_file(files, tmp_path):
    # /dev/stdout is a link to /proc/self/fd/1; a private one, so that a regression replaces it, not the machine's
    stdout = tmp_path / "stdout"
    stdout.symlink_to("/proc/self/fd/1")
    proc = subprocess.run([sys.executable, "-m", "femupdate", *update_args(files, "--json", stdout)],
                          capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    assert json.loads(proc.stdout[proc.stdout.index("{\n"):])["success"]  # a pipe: the JSON after the tables
    log = tmp_path / "log.txt"
    with open(log, "w") as fh:  # stdout redirected to a file: the same file receives both, nothing is replaced
        inode = os.fstat(fh.fileno()).st_ino
        proc = subprocess.run([sys.executable, "-m", "femupdate", *update_args(files, "--json", stdout)],
                              stdout=fh, stderr=subprocess.PIPE, text=True)
    assert proc.returncode == 0, proc.stderr
    text = log.read_text()
    assert os.stat(log).st_ino == inode and "iterative update" in text and json.loads(text[text.index("{\n"):])


def test_a_fifo_is_written_and_stays_a_fifo(files, capsys, tmp_path):
    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    got = []
    reader = threading.Thread(target=lambda: got.append(fifo.read_text()), daemon=True)
    reader.start()
    code, out = run(update_args(files, "--json", fifo), capsys)
    reader.join(10)
    assert code == 0, out
    assert stat.S_ISFIFO(os.stat(fifo).st_mode) and json.loads(got[0])["success"]


def test_a_symbolic_link_is_followed_and_stays_a_link(files, capsys, tmp_path):
    (tmp_path / "results").mkdir()
    target = tmp_path / "results" / "out.json"
    target.write_text("old")
    link = tmp_path / "link.json"
    link.symlink_to(target)
    code, out = run(update_args(files, "--json", link), capsys)
    assert code == 0, out
    assert link.is_symlink() and os.readlink(link) == str(target)
    assert json.loads(target.read_text())["success"]
    assert f"--json {link}: replaced the existing file" in out
    dangling = tmp_path / "dangling.json"
    dangling.symlink_to(tmp_path / "results" / "new.json")
    code, out = run(update_args(files, "--json", dangling), capsys)
    assert code == 0 and dangling.is_symlink() and json.loads((tmp_path / "results" / "new.json").read_text())


@pytest.mark.parametrize("make, fragment", [
    (lambda p: socket.socket(socket.AF_UNIX).bind(str(p)), "is a socket"),
    (lambda p: os.mknod(p, 0o600 | stat.S_IFBLK, os.makedev(7, 250)), "is a block device"),
    (lambda p: p.mkdir(), "is a folder"),
], ids=["socket", "block device", "folder"])
def test_sockets_block_devices_and_folders_are_refused_by_name(files, capsys, no_computation, tmp_path, make,
                                                               fragment):
    p = tmp_path / "special"
    try:
        make(p)
    except PermissionError:
        pytest.skip("this process may not create the special file")
    for option in ("--json", "--uff"):
        code, out = run(update_args(files, option, p), capsys)
        assert code == 2 and option in out and fragment in out and "Traceback" not in out, out
    link = tmp_path / "link"
    link.symlink_to(p)  # through a link too, with the link's target named
    code, out = run(update_args(files, "--json", link), capsys)
    assert code == 2 and fragment in out and str(p) in out, out


def test_writers_refuse_a_socket_even_without_the_command_line(tmp_path):
    from femupdate import InputError
    from femupdate.io.results import atomic_write_bytes

    p = tmp_path / "s"
    sock = socket.socket(socket.AF_UNIX)
    sock.bind(str(p))
    with pytest.raises(InputError, match="is a socket"):
        atomic_write_bytes(p, b"x")
    assert stat.S_ISSOCK(os.stat(p).st_mode)


def test_an_existing_file_replaced_is_said_on_the_terminal_and_in_the_json(files, capsys, tmp_path):
    out_json, uff = tmp_path / "out.json", tmp_path / "modes.uff"
    code, out = run(update_args(files, "--json", out_json, "--uff", uff), capsys)
    assert code == 0 and "replaced the existing file" not in out  # new files: nothing to say
    code, out = run(update_args(files, "--json", out_json, "--uff", uff), capsys)
    assert code == 0
    assert f"note: --json {out_json}: replaced the existing file" in out
    assert f"note: --uff {uff}: replaced the existing file" in out
    notes = json.loads(out_json.read_text())["notes"]
    assert f"--json {out_json}: replaced the existing file" in notes and f"--uff {uff}: replaced the existing file" in notes


def test_a_replaced_file_keeps_its_owner(files, capsys, tmp_path):
    if os.geteuid() != 0:
        pytest.skip("only root may give a file to another user")
    p = tmp_path / "out.json"
    p.write_text("old")
    os.chown(p, 65534, 65534)
    p.chmod(0o640)
    code, out = run(update_args(files, "--json", p), capsys)
    st = os.stat(p)
    assert code == 0 and (st.st_uid, st.st_gid) == (65534, 65534) and stat.S_IMODE(st.st_mode) == 0o640


# ------------------------------------------------------------------------------ as a user permissions apply to
UNPRIVILEGED = textwrap.dedent("""
    import json, os, stat, sys
    from femupdate.cli import main

    def run(args):
        try:
            main([str(a) for a in args])
        except SystemExit as exc:
            return exc.code
        return None

    d, model, data = sys.argv[1:4]
    run(["modes", model, "--json", os.path.join(d, "warm.json")])  # imports what the command needs, as root
    run(["modes", model, "--json", d])  # and what a refusal needs
    os.setgroups([])
    os.setgid(65534)
    os.setuid(65534)  # nobody, from here on
    out = {}
    for name, path in [("read-only file", os.path.join(d, "readonly.json")), ("locked folder", os.path.join(d, "locked", "x.json")),
                       ("link into a locked folder", os.path.join(d, "link.json")), ("device", "/dev/null"),
                       ("own file", os.path.join(d, "mine.json"))]:
        out[name] = run(["modes", model, "--json", path])
    out["/dev/null"] = stat.S_ISCHR(os.stat("/dev/null").st_mode)
    out["read-only kept"] = open(os.path.join(d, "readonly.json")).read() == "keep"
    out["mine"] = json.load(open(os.path.join(d, "mine.json")))["model"]
    print("RESULT" + json.dumps(out))
""")


@pytest.mark.skipif(os.name != "posix" or os.geteuid() != 0, reason="drops from root to the user nobody")
def test_outputs_as_an_unprivileged_user(files):
    """Root bypasses permission bits: a refusal of what may not be written is only seen by a user
    they apply to (os.setuid in a child process, after the imports that read root's files)."""
    import tempfile

    d = Path(tempfile.mkdtemp(prefix="femupdate-nobody-", dir="/tmp"))
    try:
        d.chmod(0o777)
        for name in ("two_dof.toml", "two_dof_frequencies.json"):
            (d / name).write_text((files / name).read_text())
            (d / name).chmod(0o644)
        (d / "readonly.json").write_text("keep")
        (d / "readonly.json").chmod(0o444)
        (d / "locked").mkdir(mode=0o755)  # root's: nobody may not create files in it
        (d / "locked" / "open.json").write_text("{}")
        (d / "locked" / "open.json").chmod(0o666)  # writable, but not replaceable beside it
        (d / "link.json").symlink_to(d / "locked" / "open.json")
        (d / "mine.json").write_text("old")
        os.chown(d / "mine.json", 65534, 65534)
        proc = subprocess.run([sys.executable, "-c", UNPRIVILEGED, str(d), str(d / "two_dof.toml"),
                               str(d / "two_dof_frequencies.json")], capture_output=True, text=True, timeout=300)
        assert proc.returncode == 0, proc.stderr
        res = json.loads(proc.stdout.split("RESULT", 1)[1])
        assert res["read-only file"] == 2 and "the file is not writable" in proc.stderr
        assert res["locked folder"] == 2 and res["link into a locked folder"] == 2
        assert f"cannot write in {d / 'locked'} (permission denied)" in proc.stderr
        assert res["device"] == 0 and res["/dev/null"]  # used to be refused: 'cannot write in /dev'
        assert res["own file"] == 0 and res["mine"] == "two-dof chain (paper Figure 3)"
        assert res["read-only kept"]
    finally:
        shutil.rmtree(d, ignore_errors=True)


def test_a_result_written_from_python_to_a_folder_name_is_refused(tmp_path):
    """``write_report("out/")`` meant a folder: no file named ``out`` is made."""
    import femupdate as fu
    from femupdate.examples import two_dof

    model = two_dof()
    lam = fu.model_modes(model, {"k1": 8.0, "k2": 6.0}).eigenvalues
    res = fu.update(model, fu.TestData(modes=tuple(fu.MeasuredMode(v) for v in lam)))
    for write in (res.write_report, res.write_json):
        with pytest.raises(fu.InputError, match="ends with '/', so names a folder"):
            write(f"{tmp_path}/out/")
    assert not (tmp_path / "out").exists()
