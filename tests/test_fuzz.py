"""Property-based fuzzing of the command line with bad input (issue 16).

Strategies mutate the example model files (TOML), matrix models (.npz/.npy), test data (JSON),
universal files and option strings (dropped and duplicated keys and lines, wrong types,
nan/inf/huge numbers, unknown dofs, empty lists, truncation), run them through the CLI in
process and check that every run ends with exit code 0, 1 or 2, without a traceback and
without any exception other than SystemExit.

Profiles (environment variable FEMUPDATE_FUZZ): ``ci`` (default, a few thousand cases, about a
minute) and ``offline`` (ten times as many per test).  Both are derandomized, so a run is
reproducible.
"""

import contextlib
import copy
import io
import json
import os
import re
import tempfile
import traceback
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from femupdate.cli import main

PROFILE = os.environ.get("FEMUPDATE_FUZZ", "ci")
SCALE = {"ci": 1, "offline": 10}[PROFILE]


def fuzz_settings(ci_examples):
    return settings(max_examples=ci_examples * SCALE, derandomize=True, deadline=None, database=None,
                    suppress_health_check=list(HealthCheck), print_blob=True)


# ---------------------------------------------------------------------------------- running the CLI
def run_cli(args):
    """Run the CLI in process; (exit code, stdout, stderr). Any exception but SystemExit fails."""
    out, err = io.StringIO(), io.StringIO()
    code = None
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            main([str(a) for a in args])
        except SystemExit as exc:
            code = exc.code
        except BaseException:  # noqa: BLE001 - the point of the test
            tb = traceback.format_exc()
            raise AssertionError(f"femupdate {' '.join(map(str, args))} raised instead of exiting:\n{tb}") from None
    return code, out.getvalue(), err.getvalue()


def check(args):
    code, out, err = run_cli(args)
    assert code in (0, 1, 2), f"femupdate {' '.join(map(str, args))}: exit code {code!r}\n{err}"
    assert "Traceback" not in out + err, f"femupdate {' '.join(map(str, args))}:\n{err}"
    assert not re.search(r"np\.\w+\(", err), f"a numpy repr in the message of femupdate {' '.join(map(str, args))}:\n{err}"
    if code != 0:
        assert err.strip(), f"femupdate {' '.join(map(str, args))}: exit {code} without a message"
    return code, out, err


# ---------------------------------------------------------------------------------- the example files
_EX = Path(tempfile.mkdtemp(prefix="femupdate-fuzz-ex-"))
with contextlib.redirect_stdout(io.StringIO()):
    try:
        main(["demo", "--write-files", str(_EX)])
    except SystemExit:
        pass
_UFF_MODES = _EX / "figure2_modes.uff"
_UFF_FRF = _EX / "two_dof_frf.uff"
run_cli(["modes", _EX / "figure2.toml", "--uff", _UFF_MODES])
run_cli(["frf", _EX / "two_dof.toml", "--force", "1:x", "--omega", "0.4:2.8:7", "--uff", _UFF_FRF])

EX = {name: (_EX / name).read_text() for name in
      ("two_dof.toml", "figure2.toml", "truss.toml", "two_dof_frequencies.json", "two_dof_frf.json",
       "figure2_test.json", "truss_damaged.json")}
UFF = {"modes": _UFF_MODES.read_text(), "frf": _UFF_FRF.read_text()}


@pytest.fixture(scope="module")
def work():
    with tempfile.TemporaryDirectory(prefix="femupdate-fuzz-") as d:
        yield Path(d)


# ---------------------------------------------------------------------------------- value strategies
BIG_INT = "9" * 400
HUGE_INT = "9" * 5000
BAD_TOKENS = ["nan", "inf", "-inf", "NaN", "1e308", "-1e308", "1.7976931348623157e308", "1e-320", BIG_INT, "-" + BIG_INT,
              HUGE_INT, "0", "-0.0", "-1", "-1e-9", "1e151", "", "abc", "true", "[]", "[1, 2]", "{}", "\"x\"", "\"k1\"",
              "\"9:x\"", "\"1:q\"", "\"1:x\"", "[\"1:x\", \"1:x\"]", "1:x", "k1=nan", "1,2", "0:1:0", "2:1:3", "1e400",
              "[[1]]", "{a = 1}", "\"\"", "-", "null"]
numbers = st.one_of(st.floats(allow_nan=True, allow_infinity=True), st.integers(-10**6, 10**6),
                    st.sampled_from([1e308, -1e308, 1e151, 1e150, 0.0, -0.0, 5e-324]))
tokens = st.one_of(st.sampled_from(BAD_TOKENS), numbers.map(repr), st.text(max_size=12))


# ---------------------------------------------------------------------------------- text mutations
@st.composite
def mutate_lines(draw, text, n_max=3):
    """Line-level edits: replace a value, delete or duplicate a line, insert junk, truncate."""
    lines = text.splitlines(keepends=True)
    for _ in range(draw(st.integers(1, n_max))):
        if not lines:
            break
        i = draw(st.integers(0, len(lines) - 1))
        op = draw(st.sampled_from(["value", "value", "value", "delete", "duplicate", "insert", "truncate", "swap"]))
        if op == "value" and "=" in lines[i]:
            key = lines[i].split("=", 1)[0]
            lines[i] = f"{key}= {draw(tokens)}\n"
        elif op == "value" and ":" in lines[i]:  # JSON "key": value
            m = re.match(r'(\s*"[^"]*"\s*:\s*)(.*?)(,?)\s*$', lines[i])
            if m:
                lines[i] = f"{m.group(1)}{draw(tokens)}{m.group(3)}\n"
        elif op == "value":  # a universal-file line: replace one number
            parts = lines[i].split()
            if parts:
                j = draw(st.integers(0, len(parts) - 1))
                parts[j] = draw(st.sampled_from(["nan", "inf", "1e308", "-1", "0", "x", BIG_INT, "1.0E+400", "-99"]))
                lines[i] = " ".join(parts) + "\n"
        elif op == "delete":
            del lines[i]
        elif op == "duplicate":
            lines.insert(i, lines[i])
        elif op == "insert":
            lines.insert(i, draw(st.sampled_from(["[model]\n", "[[element]]\n", "x = 1\n", "    -1\n", "  55\n", "}\n",
                                                   "{\n", "\"1:x\": 1.0,\n", "[parameters.k9]\n", "value = 1\n"])))
        elif op == "truncate":
            cut = draw(st.integers(0, len(lines[i])))
            lines = lines[:i] + [lines[i][:cut]]
        elif op == "swap" and len(lines) > 1:
            j = draw(st.integers(0, len(lines) - 1))
            lines[i], lines[j] = lines[j], lines[i]
    return "".join(lines)


# ---------------------------------------------------------------------------------- JSON tree mutations
JSON_VALUES = st.one_of(numbers, st.sampled_from([None, True, "x", "", [], {}, [1, 2], {"1:x": 1.0}, "1:x", [[1, 2]],
                                                  {"99:x": 1.0}, {"1:q": 1.0}, int(BIG_INT), -int(BIG_INT)]))


def _paths(tree, prefix=()):
    yield prefix
    if isinstance(tree, dict):
        for k, v in tree.items():
            yield from _paths(v, prefix + (k,))
    elif isinstance(tree, list):
        for i, v in enumerate(tree):
            yield from _paths(v, prefix + (i,))


@st.composite
def mutate_json(draw, text):
    tree = json.loads(text)
    for _ in range(draw(st.integers(1, 3))):
        paths = [p for p in _paths(tree) if p]
        if not paths:
            break
        path = draw(st.sampled_from(paths))
        parent = tree
        for k in path[:-1]:
            parent = parent[k]
        key = path[-1]
        op = draw(st.sampled_from(["replace", "replace", "delete", "unknown_key", "empty", "rename"]))
        if op == "replace":  # a copy: the strategy's lists and dicts must not be mutated in place
            parent[key] = copy.deepcopy(draw(JSON_VALUES))
        elif op == "delete":
            del parent[key]
        elif op == "unknown_key" and isinstance(parent, dict):
            parent[draw(st.sampled_from(["99:x", "1:q", "bogus", "1:x", "label", "#1", "#0", "#x", "A2:x"]))] = \
                copy.deepcopy(draw(JSON_VALUES))
        elif op == "empty":
            parent[key] = [] if isinstance(parent[key], list) else {} if isinstance(parent[key], dict) else None
        elif op == "rename" and isinstance(parent, dict):
            parent[draw(st.sampled_from(["99:x", "2:x", "1:z", "eigenvalue", "frequency_hz", "#2", "#99", "#1.5"]))] = \
                parent.pop(key)
    out = json.dumps(tree, indent=1)  # NaN and Infinity as JSON's extensions
    if draw(st.booleans()):
        out = draw(mutate_lines(out, n_max=1))  # duplicate keys, truncation, junk
    return out


# ---------------------------------------------------------------------------------- the tests
TOML_COMMANDS = {
    "two_dof.toml": [["modes", "{m}"], ["correlate", "{m}", "{two_dof_frequencies.json}"],
                     ["update", "{m}", "{two_dof_frequencies.json}", "--max-nfev", "5"],
                     ["frf-update", "{m}", "{two_dof_frf.json}", "--max-nfev", "3"],
                     ["frf", "{m}", "--force", "1:x", "--omega", "1,2"]],
    "figure2.toml": [["direct", "{m}", "{figure2_test.json}"], ["modes", "{m}", "--n-modes", "2"]],
    "truss.toml": [["modes", "{m}"], ["damage", "{m}", "{truss_damaged.json}", "--bootstrap", "0", "--iterations", "1"]],
}


def _fill(args, work, **extra):
    files = {k: work / "ex" / k for k in EX}
    files.update(extra)
    out = []
    for a in map(str, args):
        for k, v in files.items():
            a = a.replace("{" + k + "}", str(v))
        out.append(a)
    return out


@pytest.fixture(scope="module")
def ex_dir(work):
    d = work / "ex"
    d.mkdir()
    for k, v in EX.items():
        (d / k).write_text(v)
    return d


@pytest.mark.parametrize("name", list(TOML_COMMANDS))
@fuzz_settings(250)
@given(data=st.data())
def test_fuzz_model_toml(work, ex_dir, name, data):
    text = data.draw(mutate_lines(EX[name]))
    p = work / "m.toml"
    p.write_text(text)
    args = data.draw(st.sampled_from(TOML_COMMANDS[name]))
    check(_fill(args, work, m=p))


JSON_COMMANDS = {
    "two_dof_frequencies.json": [["correlate", "{two_dof.toml}", "{d}"], ["update", "{two_dof.toml}", "{d}", "--max-nfev", "5"]],
    "two_dof_frf.json": [["frf-update", "{two_dof.toml}", "{d}", "--max-nfev", "3"], ["update", "{two_dof.toml}", "{d}", "--max-nfev", "3"],
                         ["surface", "{two_dof.toml}", "{d}", "--params", "k1,k2", "--x", "3:13:3", "--y", "1:11:3"]],
    "figure2_test.json": [["direct", "{figure2.toml}", "{d}"], ["correlate", "{figure2.toml}", "{d}"]],
    "truss_damaged.json": [["damage", "{truss.toml}", "{d}", "--bootstrap", "0", "--iterations", "1"]],
}


@pytest.mark.parametrize("name", list(JSON_COMMANDS))
@fuzz_settings(200)
@given(data=st.data())
def test_fuzz_test_data_json(work, ex_dir, name, data):
    text = data.draw(mutate_json(EX[name]))
    p = work / "d.json"
    p.write_text(text)
    args = data.draw(st.sampled_from(JSON_COMMANDS[name]))
    check(_fill(args, work, d=p))


UFF_COMMANDS = {
    "modes": [["correlate", "{figure2.toml}", "{u}"], ["update", "{figure2.toml}", "{u}", "--max-nfev", "5"]],
    "frf": [["frf-update", "{two_dof.toml}", "{u}", "--max-nfev", "3"]],
}


@pytest.mark.parametrize("kind", list(UFF_COMMANDS))
@fuzz_settings(200)
@given(data=st.data())
def test_fuzz_universal_file(work, ex_dir, kind, data):
    text = UFF[kind]
    if data.draw(st.booleans()):
        text = text[:data.draw(st.integers(0, len(text)))]  # cut anywhere
    else:
        text = data.draw(mutate_lines(text))
    p = work / "t.uff"
    p.write_text(text)
    args = data.draw(st.sampled_from(UFF_COMMANDS[kind]))
    check(_fill(args, work, u=p))


def _matrix(draw, n):
    kind = draw(st.sampled_from(["spd", "spd", "random", "asym", "nan", "inf", "huge", "shape", "3d", "empty", "zero"]))
    if kind == "spd":
        return np.diag(draw(st.lists(st.floats(0.1, 10), min_size=n, max_size=n)))
    if kind == "random":
        a = np.array(draw(st.lists(numbers.map(float), min_size=n * n, max_size=n * n))).reshape(n, n)
        with np.errstate(over="ignore"):  # huge draws may overflow to inf: bad input on purpose
            return a + a.T
    if kind == "asym":
        return np.triu(np.ones((n, n)))
    if kind in ("nan", "inf", "huge"):
        a = np.eye(n)
        a[0, 0] = {"nan": np.nan, "inf": np.inf, "huge": 1e300}[kind]
        return a
    if kind == "shape":
        return np.eye(n + draw(st.integers(-1, 2)))[:, :n + draw(st.integers(0, 1))]
    if kind == "3d":
        return np.zeros((n, n, 2))
    if kind == "empty":
        return np.zeros((0, 0))
    return np.zeros((n, n))


@fuzz_settings(300)
@given(data=st.data())
def test_fuzz_matrix_model(work, ex_dir, data):
    d = work / "mm"
    d.mkdir(exist_ok=True)
    n = data.draw(st.integers(1, 3))
    for name in ("K0", "M0", "dK"):
        fmt = data.draw(st.sampled_from(["npy", "npz"]))
        arr = _matrix(data.draw, n)
        for old in d.glob(f"{name}.*"):
            old.unlink()
        if fmt == "npy":
            np.save(d / f"{name}.npy", arr)
        else:
            np.savez(d / f"{name}.npz", arr, *([arr] if data.draw(st.integers(0, 5)) == 0 else []))
    dofs = data.draw(st.one_of(
        st.just([f"{i + 1}:x" for i in range(n)]),
        st.lists(st.sampled_from(["1:x", "2:x", "3:x", "1:q", "x", "", "1:x:y", "0:x", "-1:x", "A2:x", "a b:x", "#1", "N1:6"]),
                 max_size=4),
        st.sampled_from(["5", "true", "{a = 1}", "\"dofs.txt\"", "\"nofile.txt\"", "[1, 2]"])))
    (d / "dofs.txt").write_bytes(data.draw(st.sampled_from([b"1:x\n2:x\n3:x\n"[:4 * n], b"\xff\xfe1:x\n", b"", b"# c\n1:x\n"])))
    names = {k: next(iter(d.glob(f"{k}.*"))).name for k in ("K0", "M0", "dK")}
    value = data.draw(st.sampled_from(["1.0", "0.5", "-1.0", "0", "nan", "1e300", "\"x\""]))
    bounds = data.draw(st.sampled_from(["", "bounds = [0.0, 10.0]", "bounds = [2.0, 1.0]", "bounds = [0.0, inf]", "bounds = 3"]))
    text = (f'[matrices]\ndofs = {json.dumps(dofs) if isinstance(dofs, list) else dofs}\nK0 = "{names["K0"]}"\n'
            f'M0 = "{names["M0"]}"\n[parameters.k1]\nvalue = {value}\n{bounds}\nK = "{names["dK"]}"\n')
    p = d / "m.toml"
    p.write_text(text)
    args = data.draw(st.sampled_from([["modes", p], ["modes", p, "--set", "k1=2"], ["correlate", p, ex_dir / "two_dof_frequencies.json"]]))
    check(args)


OPTION_COMMANDS = [
    (["modes", "{two_dof.toml}"], ["--n-modes", "--normalise", "--set"]),
    (["correlate", "{two_dof.toml}", "{two_dof_frequencies.json}"], ["--min-mac", "--set"]),
    (["update", "{two_dof.toml}", "{two_dof_frequencies.json}", "--max-nfev", "5"],
     ["--min-mac", "--std-eigenvalue", "--std-shape", "--regularization", "--params", "--set", "--ref-dof",
      "--shape-scaling", "--use", "--seed", "--parametrisation"]),
    (["posterior", "{two_dof.toml}", "{two_dof_frequencies.json}", "--starts", "2", "--samples", "20",
      "--std-eigenvalue", "0.01"],
     ["--prior", "--noise", "--level", "--params", "--set", "--seed", "--std-eigenvalue", "--std-shape", "--use"]),
    (["frf", "{two_dof.toml}"], ["--force", "--omega", "--dofs", "--damping", "--noise", "--seed", "--set", "--kind"]),
    (["frf-update", "{two_dof.toml}", "{two_dof_frf.json}", "--max-nfev", "3"],
     ["--lines", "--select", "--resonance-tol", "--damping", "--std", "--params", "--set", "--regularization"]),
    (["frf-select", "{two_dof.toml}"], ["--force", "--candidates", "--lines", "--margin", "--dofs", "--unknowns"]),
    (["surface", "{two_dof.toml}", "{two_dof_frf.json}", "--params", "k1,k2"], ["--x", "--y", "--truth", "--damping", "--set"]),
    (["direct", "{figure2.toml}", "{figure2_test.json}"], ["--use", "--unknowns", "--set"]),
    (["uniqueness", "{two_dof.toml}", "--starts", "2"],
     ["--measured-dofs", "--modes", "--rel-tol", "--cost-tol", "--min-mac", "--noise", "--params", "--seed", "--set"]),
    (["reduce", "{figure2.toml}"], ["--keep", "--method", "--n-modes", "--set"]),
    (["damage", "{truss.toml}", "{truss_damaged.json}", "--bootstrap", "0", "--iterations", "1"],
     ["--alpha", "--min-change", "--noise-frequency", "--min-mac", "--elements", "--n-basis", "--seed", "--set"]),
]
OPTION_VALUES = st.one_of(tokens, st.sampled_from([
    "1:x", "2:x", "1:x,2:x", "1:x=2", "9:x", "k1", "k1,k2", "k1=9", "k1=0", "k1=-1", "k9=1", "k1=1e400", "k1=9,k1=3",
    "alpha=nan", "eta=-1", "beta=1e300", "0:3:5", "1:2:0", "1,2,2", "0", "1", "2", "3", "-1", "1-3", "3-1",
    "1:x;2:x", ";", ",", "modes", "frf,static", "ref", "max", "gcv", "lcurve", "1e-300", "4294967296",
    "#1", "#2", "#0", "#x", "#1.5", "#1,1:x", "#1=2", "#2;#1", "A2:x", "ref:#1", "ref:#9"]))


@fuzz_settings(500)
@given(data=st.data())
def test_fuzz_options(work, ex_dir, data):
    base, options = data.draw(st.sampled_from(OPTION_COMMANDS))
    args = _fill(base, work)
    if base[0] in ("frf", "frf-select"):
        args += ["--force", "1:x"]
        args += ["--omega", "1,2"] if base[0] == "frf" else ["--candidates", "1:3:5", "--lines", "2"]
    if base[0] == "surface":
        args += ["--x", "3:13:3", "--y", "1:11:3"]
    if base[0] == "reduce":
        args += ["--keep", "1:x"]
    for _ in range(data.draw(st.integers(1, 3))):
        args += [data.draw(st.sampled_from(options)), data.draw(OPTION_VALUES)]
    check(args)
