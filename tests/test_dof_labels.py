"""Dof labels as commercial FE codes export them: any node name (``A2:x``, ``hinge_3:y``), and
measured dofs given by their position ``#N`` in the model's dof list.

References: the same exported matrices labelled with integer nodes (the established path) — a
model with named nodes must give the same numbers, bit for bit, with its labels; and the same
test data written with labels — ``#N`` must give the same result.
"""

import json
import random

import numpy as np
import pytest

from femupdate import InputError, Structure
from femupdate.cli import main
from femupdate.dofs import canonical, canonical_all, natural_key, parse_dof, resolve_all, resolve_dof, sort_key

# node number of the exported frame -> the name the "commercial" export gives it; chosen so that
# natural order (A2 < A10 < N-5.b < hinge_3) differs from the matrix order (2, 3, 4, 5)
NAMES = {2: "A2", 3: "hinge_3", 4: "A10", 5: "N-5.b"}
TRUTH = {"E1": 2.4e11, "E2": 1.9e11}


def run(args, capsys):
    with pytest.raises(SystemExit) as info:
        main([str(a) for a in args])
    out, err = capsys.readouterr()
    return info.value.code, out, err


def run_json(args, capsys):
    code, out, err = run([*args, "--json", "-"], capsys)
    assert code == 0, err
    return json.loads(out)


def check_refused(code, err, *fragments):
    assert code == 2, err
    assert "Traceback" not in err
    for f in fragments:
        assert f in err, err


def named(label: str) -> str:
    node, direction = label.split(":")
    return f"{NAMES[int(node)]}:{direction}"


def rename(obj):
    """Every integer-node label in the keys and strings of a JSON value, written with its name."""
    if isinstance(obj, dict):
        return {rename(k): rename(v) for k, v in obj.items()}
    if isinstance(obj, list):
        return [rename(v) for v in obj]
    if isinstance(obj, str) and obj.count(":") == 1 and obj.split(":")[0].isdigit() and int(obj.split(":")[0]) in NAMES:
        return named(obj)
    if isinstance(obj, str):  # labels inside a sentence (notes)
        import re

        return re.sub(r"(?<![\w.-])(\d+):(x|y|z|rx|ry|rz)\b",
                      lambda m: named(m.group(0)) if int(m.group(1)) in NAMES else m.group(0), obj)
    return obj


@pytest.fixture(scope="module")
def ex(tmp_path_factory):
    """An exported cantilever frame (4 beams, two modulus groups, clamped at node 1) as .npy
    matrices with two dof files: integer nodes, and the same rows with named nodes."""
    d = tmp_path_factory.mktemp("labels")
    s = Structure("frame")
    x = np.linspace(0.0, 2.0, 5)
    s.add_nodes(range(1, 6), np.c_[x, 0 * x])
    for p in ("E1", "E2"):
        s.parameter(p, 2.1e11, (1e11, 4e11))
    for e in range(4):
        s.beam2d((e + 1, e + 2), E="E1" if e < 2 else "E2", A=1e-3, I=8.33e-8, rho=7850.0)
    s.support_node([1])
    m = s.build()
    K0 = m.K(np.zeros(2)).toarray()
    np.save(d / "K0.npy", K0)
    np.save(d / "M0.npy", m.M(m.values).toarray())
    for j, p in enumerate(m.parameter_names):
        np.save(d / f"d{p}.npy", m.K(np.eye(2)[j]).toarray() - K0)
    (d / "dofs_int.txt").write_text("\n".join(m.dofs) + "\n")
    # as an export may write them: a comment, blank lines, blanks, upper case, NASTRAN components
    written = []
    for lab in m.dofs:
        node, direction = lab.split(":")
        name = NAMES[int(node)]
        written.append({"x": f"{name}:X", "y": f" {name} : 2", "rz": f"{name}:6"}[direction])
    (d / "dofs_named.txt").write_text("# exported by another code\n\n" + "\n".join(written) + "\n")
    for kind in ("int", "named"):
        (d / f"{kind}.toml").write_text(
            f'[model]\nname = "frame"\n[matrices]\ndofs = "dofs_{kind}.txt"\nK0 = "K0.npy"\nM0 = "M0.npy"\n'
            + "".join(f'[parameters.{p}]\nvalue = 2.1e11\nbounds = [1e11, 4e11]\nK = "d{p}.npy"\n' for p in ("E1", "E2")))
    return d


@pytest.fixture(scope="module")
def data(ex):
    """Test data simulated on the integer model at TRUTH (three modes at the y dofs), written with
    labels, with named labels, and with indices ``#N``; and the model's dof list."""
    with pytest.raises(SystemExit):
        main(["modes", str(ex / "int.toml"), "--set", ",".join(f"{k}={v}" for k, v in TRUTH.items()),
              "--json", str(ex / "truth.json")])
    truth = json.loads((ex / "truth.json").read_text())
    dofs = truth["dofs"]
    ys = [i for i, lab in enumerate(dofs) if lab.endswith(":y")]
    for kind, key in (("int", lambda i: dofs[i]), ("named", lambda i: named(dofs[i])), ("index", lambda i: f"#{i + 1}")):
        modes = [{"frequency_hz": truth["frequencies_hz"][r], "shape": {key(i): truth["shapes"][r][i] for i in ys},
                  "reference_dof": key(ys[1])} for r in range(3)]
        (ex / f"modes_{kind}.json").write_text(json.dumps({"modes": modes}))
    return dofs


# ---------------------------------------------------------------------------------- labels
@pytest.mark.parametrize("label, expected", [
    (" 03 : X", "3:x"), ("+3:y", "3:y"), ("-2:rz", "-2:rz"), ("101:1", "101:x"), ("101:6", "101:rz"),
    (" A2 : X", "A2:x"), ("a2:x", "a2:x"), ("hinge_3:RY", "hinge_3:ry"), ("N101:3", "N101:z"),
    ("Part-1.12/b:y", "Part-1.12/b:y"), ("A02:x", "A02:x"),
])
def test_canonical_forms(label, expected):
    assert canonical(label) == expected
    assert canonical(expected) == expected


def test_integer_nodes_parse_as_integers_and_names_as_written():
    assert parse_dof(" 03 : X") == (3, "x")
    assert parse_dof("A2:x") == ("A2", "x")
    assert canonical("a2:x") != canonical("A2:x")  # names are case-sensitive
    assert canonical_all(["A2:x", "a2:x", "2:x"]) == ("A2:x", "a2:x", "2:x")


@pytest.mark.parametrize("label, fragment", [
    ("a b:x", "node 'a b' contains a blank"),
    (":x", "node '' is empty"),
    ("A,2:x", "node 'A,2' contains ','"),
    ("A=2:x", "node 'A=2' contains '='"),
    ("#A:x", "node '#A' begins with '#'"),
    ("A:2:x", "is not of the form '<node>:<dir>'"),
    ("A2:q", "direction 'q' is not one of x, y, z, rx, ry, rz (or 1-6)"),
    ("A2:7", "direction '7' is not one of"),
    ("#3", "'#3': '#N' (the N-th dof of a model) is resolved only where"),
])
def test_malformed_labels_are_named(label, fragment):
    with pytest.raises(InputError) as info:
        canonical(label)
    assert fragment in str(info.value)


def test_the_same_dof_written_twice_is_refused_with_both_spellings():
    with pytest.raises(InputError, match=r"dof\(s\) listed twice: A2:x \(written 'A2:x' and ' A2 : 1'\)"):
        canonical_all(["A2:x", " A2 : 1"])


def test_sorting_mixed_labels():
    expected = ["-1:x", "1:x", "1:y", "1:rz", "2:x", "10:x", "A02:x", "A2:x", "A2:z", "A2:rx", "a3:x", "A10:y",
                "B1:x", "hinge_3:x", "hinge_10:x", "N5:x", "n10:x"]
    shuffled = expected[:]
    for seed in range(5):
        random.Random(seed).shuffle(shuffled)
        assert sorted(shuffled, key=sort_key) == expected
    assert natural_key("A10") == ("a", 10, "")


def test_a_structure_sorts_named_spring_dofs_after_numbered_nodes():
    s = Structure("mixed")
    s.spring(["A10:x"], k=1.0)
    s.spring(["A10:x", "A2:x"], k=1.0)
    s.spring(["A2:x", "3:x"], k=1.0)
    s.mass(["A10:x", "A2:x", "3:x"], m=1.0)
    assert s.build().dofs == ("3:x", "A2:x", "A10:x")
    s.support_node(["A10"])
    assert s.build().dofs == ("3:x", "A2:x")


def test_line_elements_refuse_a_named_node(tmp_path, capsys):
    p = tmp_path / "rod.toml"
    p.write_text('[[element]]\ntype = "rod"\nnodes = ["A2", "A3"]\nE = 1.0\nA = 1.0\nrho = 1.0\n')
    code, _, err = run(["modes", p], capsys)
    check_refused(code, err, "element #1 (rod): node 'A2' is not an integer; line elements join [[node]] ids")


# ---------------------------------------------------------------------------------- named nodes end to end
def test_the_dofs_file_keeps_named_nodes_in_file_order(ex, data, capsys):
    out = run_json(["modes", ex / "named.toml", "--n-modes", "2"], capsys)
    assert out["dofs"] == [named(d) for d in data]


def test_named_nodes_give_the_same_modes(ex, capsys):
    a = run_json(["modes", ex / "int.toml"], capsys)
    b = run_json(["modes", ex / "named.toml"], capsys)
    assert b["dofs"] == [named(d) for d in a["dofs"]]
    assert b["eigenvalues"] == a["eigenvalues"]
    assert b["shapes"] == a["shapes"]


def test_named_nodes_give_the_same_update(ex, data, capsys):
    a = run_json(["update", ex / "int.toml", ex / "modes_int.json"], capsys)
    b = run_json(["update", ex / "named.toml", ex / "modes_named.json"], capsys)
    assert a["success"] and b["success"]
    np.testing.assert_allclose([a["parameters"][k] for k in TRUTH], list(TRUTH.values()), rtol=1e-6)
    assert b == rename(a)


def test_named_nodes_give_the_same_correlation(ex, data, capsys):
    a = run_json(["correlate", ex / "int.toml", ex / "modes_int.json"], capsys)
    b = run_json(["correlate", ex / "named.toml", ex / "modes_named.json"], capsys)
    assert b == rename(a)
    assert set(b["comac"]) == {named(d) for d in data if d.endswith(":y")}


def test_named_nodes_give_the_same_frf(ex, data, capsys):
    args = ["--omega", "5:300:7", "--damping", "eta=0.02"]
    a = run_json(["frf", ex / "int.toml", "--force", "5:y=2", "--dofs", "3:y,5:rz", *args], capsys)
    b = run_json(["frf", ex / "named.toml", "--force", "N-5.b:y=2", "--dofs", "hinge_3:y,N-5.b:rz", *args], capsys)
    assert b == rename(a)


def test_frf_update_on_named_nodes(ex, data, capsys):
    sets = ",".join(f"{k}={v}" for k, v in TRUTH.items())
    for kind, model, force in (("int", "int.toml", "5:y"), ("named", "named.toml", "N-5.b:y")):
        with pytest.raises(SystemExit):
            main(["frf", str(ex / model), "--force", force, "--omega", "10:200:6", "--set", sets,
                  "--test-data", str(ex / f"frf_{kind}.json")])
    capsys.readouterr()
    a = run_json(["frf-update", ex / "int.toml", ex / "frf_int.json"], capsys)
    b = run_json(["frf-update", ex / "named.toml", ex / "frf_named.json"], capsys)
    assert a["success"] and b == rename(a)


# ---------------------------------------------------------------------------------- #N
def test_indices_in_test_data_give_the_same_update_as_labels(ex, data, capsys):
    for model, labels in (("int.toml", "modes_int.json"), ("named.toml", "modes_named.json")):
        for scaling in ("unit", "ref"):
            a = run_json(["update", ex / model, ex / labels, "--shape-scaling", scaling], capsys)
            b = run_json(["update", ex / model, ex / "modes_index.json", "--shape-scaling", scaling], capsys)
            assert a["success"] and b == a


def test_indices_in_frf_and_static_data_are_the_model_labels(ex, data):
    from femupdate.io.testdata_json import load_testdata
    from femupdate.io.model_file import load_model

    model = load_model(ex / "named.toml")
    by_label = {"frf": {"omega_rad_s": [10.0, 20.0], "force": {"A10:y": 1.0},
                        "response": {"A2:y": [1e-5, 2e-5], "N-5.b:rz": [[1e-6, 1e-7], [2e-6, 0.0]]}},
                "static": [{"force": {"N-5.b:y": 100.0}, "displacement": {"hinge_3:y": 1e-4, "A10:y": 3e-4}}]}
    pos = {lab: f"#{i + 1}" for i, lab in enumerate(model.dofs)}
    by_index = {"frf": {**by_label["frf"], "force": {pos["A10:y"]: 1.0},
                        "response": {pos[k]: v for k, v in by_label["frf"]["response"].items()}},
                "static": [{"force": {pos["N-5.b:y"]: 100.0},
                            "displacement": {pos[k]: v for k, v in by_label["static"][0]["displacement"].items()}}]}
    (ex / "fs_label.json").write_text(json.dumps(by_label))
    (ex / "fs_index.json").write_text(json.dumps(by_index))
    a, b = load_testdata(ex / "fs_label.json", model), load_testdata(ex / "fs_index.json", model)
    assert b.frf.dofs == a.frf.dofs == ("A2:y", "N-5.b:rz")
    assert b.frf.force == a.frf.force == {"A10:y": 1.0}
    np.testing.assert_array_equal(b.frf.response, a.frf.response)
    assert b.static[0].dofs == a.static[0].dofs == ("hinge_3:y", "A10:y")
    assert b.static[0].force == a.static[0].force
    np.testing.assert_array_equal(b.static[0].displacement, a.static[0].displacement)


def test_indices_in_command_line_options_are_the_model_labels(ex, data, capsys):
    pos = {named(d): f"#{i + 1}" for i, d in enumerate(data)}
    m = ex / "named.toml"
    a = run_json(["update", m, ex / "modes_named.json", "--shape-scaling", "ref", "--ref-dof", "A10:y"], capsys)
    b = run_json(["update", m, ex / "modes_named.json", "--shape-scaling", "ref", "--ref-dof", pos["A10:y"]], capsys)
    assert b == a
    args = ["--omega", "5,50", "--damping", "eta=0.02"]
    a = run_json(["frf", m, "--force", "N-5.b:y=2,A2:x", "--dofs", "hinge_3:y,N-5.b:rz", *args], capsys)
    b = run_json(["frf", m, "--force", f"{pos['N-5.b:y']}=2,{pos['A2:x']}", "--dofs",
                  f"{pos['hinge_3:y']},{pos['N-5.b:rz']}", *args], capsys)
    assert b == a
    a = run_json(["reduce", m, "--keep", "A2:y,A10:y,N-5.b:y", "--no-compare"], capsys)
    b = run_json(["reduce", m, "--keep", f"{pos['A2:y']},{pos['A10:y']},{pos['N-5.b:y']}", "--no-compare"], capsys)
    assert b == a and a["keep"] == ["A2:y", "A10:y", "N-5.b:y"]
    a = run_json(["modes", m, "--n-modes", "4", "--normalise", "ref:N-5.b:y"], capsys)
    b = run_json(["modes", m, "--n-modes", "4", "--normalise", f"ref:{pos['N-5.b:y']}"], capsys)
    assert b == a


def test_measured_dof_sets_by_index():
    from femupdate.uniqueness.study import parse_measured_dofs

    dofs = ("1:x", "A2:y", "A10:y")
    assert parse_measured_dofs("#2,#3;#1", dofs) == parse_measured_dofs("A2:y,A10:y;1:x", dofs) == \
        [("A2:y", "A10:y"), ("1:x",)]
    with pytest.raises(InputError, match=r"--measured-dofs set 1: dof\(s\) listed twice: A2:y \(written '#2' and 'A2:y'\)"):
        parse_measured_dofs("#2,A2:y", dofs)


def test_update_multi_counts_indices_in_the_baseline_dofs(tmp_path, capsys):
    """A configuration that supports dof #1 has one dof left; '#2' still means the baseline's 2:x."""
    from femupdate.examples import two_dof_model_toml

    model = tmp_path / "two_dof.toml"
    model.write_text(two_dof_model_toml())
    (tmp_path / "clamped.toml").write_text('name = "1:x clamped"\n[[support]]\ndofs = ["1:x"]\n')
    lam = 6.5 / 4.0  # k2 / m2 with 1:x held
    for kind, key in (("label", "2:x"), ("index", "#2")):
        (tmp_path / f"clamped_{kind}.json").write_text(json.dumps({"modes": [{"eigenvalue": lam, "shape": {key: 1.0}}]}))
    (tmp_path / "free.json").write_text(json.dumps({"modes": [{"eigenvalue": 0.7768890026375489},
                                                               {"eigenvalue": 7.723110997362449}]}))
    outs = [run_json(["update-multi", model, "--config", tmp_path / "free.json",
                      "--config", f"{tmp_path / f'clamped_{kind}.json'}:{tmp_path / 'clamped.toml'}"], capsys)
            for kind in ("label", "index")]
    assert outs[1] == outs[0]


@pytest.mark.parametrize("written, fragment", [
    ("#0", "dof index '#0' is out of range: the model has 12 dofs (#1 to #12)"),
    ("#13", "dof index '#13' is out of range: the model has 12 dofs (#1 to #12)"),
    ("#x", "dof index '#x' is not '#' and a whole number from 1 to 12 (the model has 12 dofs)"),
    ("#3.5", "dof index '#3.5' is not '#' and a whole number from 1 to 12 (the model has 12 dofs)"),
    ("#-1", "dof index '#-1' is not '#' and a whole number"),
])
def test_bad_indices_in_test_data(ex, data, tmp_path, capsys, written, fragment):
    raw = json.loads((ex / "modes_index.json").read_text())
    shape = raw["modes"][1]["shape"]
    raw["modes"][1]["shape"] = {(written if k == "#2" else k): v for k, v in shape.items()}
    p = tmp_path / "bad.json"
    p.write_text(json.dumps(raw))
    for cmd in ("update", "correlate"):
        code, _, err = run([cmd, ex / "named.toml", p], capsys)
        check_refused(code, err, str(p), "modes[2]: shape:", fragment)


@pytest.mark.parametrize("where, edit, fragment", [
    ("reference_dof", lambda raw: raw["modes"][0].update(reference_dof="#0"), "modes[1]: reference_dof: dof index '#0'"),
    ("the same dof twice", lambda raw: raw["modes"][0]["shape"].update({"A2:y": 1.0}),
     "modes[1]: shape: dof(s) listed twice: A2:y (written '#2' and 'A2:y')"),
    ("static", lambda raw: raw.update(static={"force": {"#11": 1.0}, "displacement": {"#12.0": 1e-3}}),
     "static[1]: displacement: dof index '#12.0' is not '#' and a whole number"),
    ("frf force", lambda raw: raw.update(frf={"omega_rad_s": [1.0], "force": {"#99": 1.0}, "response": {"#2": [1.0]}}),
     "frf force: dof index '#99' is out of range: the model has 12 dofs"),
    ("frf response", lambda raw: raw.update(frf={"omega_rad_s": [1.0], "force": {"#1": 1.0}, "response": {"#": [1.0]}}),
     "frf response: dof index '#' is not '#' and a whole number"),
])
def test_bad_indices_elsewhere_in_test_data(ex, data, tmp_path, capsys, where, edit, fragment):
    raw = json.loads((ex / "modes_index.json").read_text())
    edit(raw)
    p = tmp_path / "bad.json"
    p.write_text(json.dumps(raw))
    code, _, err = run(["update", ex / "named.toml", p], capsys)
    check_refused(code, err, str(p), fragment)


@pytest.mark.parametrize("args, fragment", [
    (["update", "{m}", "{d}", "--shape-scaling", "ref", "--ref-dof", "#0"], "--ref-dof: dof index '#0' is out of range"),
    (["frf", "{m}", "--force", "#13=2", "--omega", "1,2"], "--force: dof index '#13' is out of range: the model has 12 dofs"),
    (["frf", "{m}", "--force", "#1", "--omega", "1,2", "--dofs", "#3.5"], "--dofs: dof index '#3.5' is not '#' and a whole number"),
    (["frf", "{m}", "--force", "#11,N-5.b:y", "--omega", "1,2"], "--force: dof(s) listed twice: N-5.b:y (written '#11' and 'N-5.b:y')"),
    (["frf-select", "{m}", "--force", "#x", "--candidates", "1:3:5", "--lines", "2"], "--force: dof index '#x'"),
    (["reduce", "{m}", "--keep", "#2,#0"], "--keep: dof index '#0' is out of range"),
    (["modes", "{m}", "--normalise", "ref:#13"], "--normalise: dof index '#13' is out of range"),
    (["uniqueness", "{m}", "--measured-dofs", "#2;#x", "--modes", "1"], "--measured-dofs set 2: dof index '#x'"),
    (["surface", "{m}", "{d}", "--kind", "modal", "--params", "E1,E2", "--x", "2e11:3e11:3", "--y", "2e11:3e11:3", "--ref-dof", "#0"],
     "--ref-dof: dof index '#0' is out of range"),
])
def test_bad_indices_in_options(ex, data, capsys, args, fragment):
    code, _, err = run([a.format(m=ex / "named.toml", d=ex / "modes_named.json") for a in args], capsys)
    check_refused(code, err, fragment)


def test_rank_modifications_sensors_by_index(ex, tmp_path, capsys):
    cands = tmp_path / "cands.toml"
    cands.write_text('[[candidate]]\nname = "tip mass"\n[[candidate.mass]]\ndofs = ["N-5.b:y"]\nm = 2.0\n')
    args = ["rank-modifications", ex / "named.toml", cands, "--modes", "2", "--eigenvalues-only"]
    a = run_json([*args, "--measured-dofs", "A10:y,N-5.b:y"], capsys)
    b = run_json([*args, "--measured-dofs", "#8,#11"], capsys)
    assert b == a
    code, _, err = run([*args, "--measured-dofs", "#8,#0"], capsys)
    check_refused(code, err, "--measured-dofs: dof index '#0' is out of range: the model has 12 dofs")


def test_indices_need_a_model():
    from femupdate.io.testdata_json import parse_testdata
    from femupdate.updating.multiconfig.files import modification_from_dict

    raw = {"modes": [{"eigenvalue": 1.0, "shape": {"#1": 1.0}}]}
    with pytest.raises(InputError, match=r"modes\[1\]: shape: dof '#1': '#N' \(the N-th dof of the model\) needs the model"):
        parse_testdata(raw)
    assert parse_testdata(raw, ("A2:x",)).modes[0].dofs == ("A2:x",)
    with pytest.raises(InputError, match=r"mod.toml: dof '#1': '#N' \(the N-th dof of a model\) is resolved only where"):
        modification_from_dict({"mass": [{"dofs": ["#1"], "m": 1.0}]}, "mod.toml")
    assert resolve_dof(" #2 ", ("1:x", "A2:x")) == "A2:x"
    assert resolve_all(["#1", "A2:X"], ("1:x", "A2:x")) == ("1:x", "A2:x")


# ---------------------------------------------------------------------------------- universal files
def test_universal_files_refuse_named_nodes(ex, tmp_path, capsys):
    out = tmp_path / "modes.uff"
    code, _, err = run(["modes", ex / "named.toml", "--uff", out], capsys)
    check_refused(code, err, "modes --uff: node 'A2' of dof 'A2:x' is not an integer; universal files number nodes "
                             "with integers")
    assert not out.exists()
    code, _, err = run(["frf", ex / "named.toml", "--force", "A10:y", "--omega", "1,2", "--uff", out], capsys)
    check_refused(code, err, "frf --uff: node 'A10' of dof 'A10:y' is not an integer")
    assert not out.exists()
    code, _, _ = run(["modes", ex / "int.toml", "--uff", out], capsys)  # the same matrices, numbered: written
    assert code == 0 and out.exists()


def test_write_uff_refuses_named_nodes(ex, tmp_path):
    from femupdate.io.model_file import load_model
    from femupdate.io.uff import write_uff_modes
    from femupdate.modal import model_modes

    target = tmp_path / "m.uff"
    with pytest.raises(InputError, match=f"{target}: node 'A2' of dof 'A2:x' is not an integer"):
        write_uff_modes(target, model_modes(load_model(ex / "named.toml"), n_modes=2))
    assert not target.exists()
