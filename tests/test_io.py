import json
import math

import numpy as np
import pytest
import scipy.io
import scipy.sparse as sp
from hypothesis import given, settings
from hypothesis import strategies as st

from femupdate import InputError, TestData, model_modes
from femupdate.dofs import canonical, parse_dof
from femupdate.examples import three_dof
from femupdate.io import load_model, load_testdata, parse_testdata, write_json

INTERFACES_MODEL = '''
[model]
name = "two-dof chain"

[parameters.k1]
value = 8.0
bounds = [0.0, 100.0]

[parameters.k2]
value = 6.0

[parameters.E_steel]
value = 2.1e11
bounds = [1.5e11, 2.5e11]

[[node]]
id = 3
xyz = [0.0, 0.0, 0.0]

[[node]]
id = 4
xyz = [0.5, 0.0, 0.0]

[[element]]
type = "spring"
dofs = ["1:x"]
k = "k1"

[[element]]
type = "spring"
dofs = ["1:x", "2:x"]
k = "k2"

[[element]]
type = "mass"
dofs = ["1:x"]
m = 2.0

[[element]]
type = "mass"
dofs = ["2:x"]
m = 4.0

[[element]]
type = "beam2d"
nodes = [3, 4]
E = "E_steel"
A = 1.0e-3
I = 8.33e-8
rho = 7850.0
mass = "consistent"

[[support]]
dofs = ["3:x", "3:y", "3:rz"]
'''

INTERFACES_DATA = {
    "modes": [
        {"frequency_hz": 0.1403, "shape": {"1:x": 0.53, "2:x": 1.0}},
        {"eigenvalue": 7.7231},
    ],
    "frf": {
        "omega_rad_s": [1.0, 1.5, 2.0],
        "force": {"2:x": 1.0},
        "response": {"1:x": [0.1, 0.2, 0.3], "2:x": [[0.4, 0.0], [0.5, 0.0], [0.6, 0.0]]},
    },
    "static": {"force": {"3:x": 1.0}, "displacement": {"1:x": 0.1, "2:x": 0.3, "3:x": 0.45}},
}


def test_interfaces_model_example(tmp_path):
    p = tmp_path / "m.toml"
    p.write_text(INTERFACES_MODEL)
    model = load_model(p)
    assert model.dofs == ("1:x", "2:x", "4:x", "4:y", "4:rz")
    K = model.K().toarray()
    np.testing.assert_allclose(K[:2, :2], [[14.0, -6.0], [-6.0, 6.0]])
    # cantilever tip: EA/l axially, 12EI/l^3 transversely
    assert K[2, 2] == pytest.approx(2.1e11 * 1e-3 / 0.5)
    assert K[3, 3] == pytest.approx(12 * 2.1e11 * 8.33e-8 / 0.5**3)
    np.testing.assert_allclose(model.dK_dp(model.parameter_index("E_steel")).toarray()[2:, 2:] * 2.1e11, K[2:, 2:])


def test_interfaces_data_example():
    data = parse_testdata(INTERFACES_DATA)
    assert data.modes[0].frequency_hz == pytest.approx(0.1403)
    assert data.modes[1].eigenvalue == 7.7231 and not data.modes[1].has_shape
    assert data.frf.response.shape == (3, 2) and data.frf.dofs == ("1:x", "2:x")
    np.testing.assert_allclose(data.frf.response[:, 1], [0.4, 0.5, 0.6])
    assert data.static[0].force == {"3:x": 1.0}


@pytest.mark.parametrize("text, match", [
    ("[model\nname=1", "malformed TOML"),
    ('[[element]]\ntype = "sprong"\ndofs=["1:x"]\nk=1.0', "unknown element type 'sprong'"),
    ('[[element]]\ntype = "spring"\ndofs=["1:x"]\nk="kk"', "parameter 'kk', which is not declared"),
    ('[[element]]\ntype = "mass"\ndofs=["1:x"]\nm=-2.0', "non-positive mass m"),
    ('[[element]]\ntype = "spring"\ndofs=["1:q"]\nk=1.0', "direction 'q'"),
    ('[[element]]\ntype = "spring"\ndofs=["1:x"]\nk=1.0\n[[support]]\ndofs=["2:x"]', "support dof"),
    ('[parameters.k]\nvalue = 5.0\nbounds = [0, 1]', "outside its bounds"),
    ('[[element]]\ntype = "rod"\nnodes=[1, 2]\nE=1.0\nA=1.0\nrho=1.0', "not defined in the node table"),
    ('[[element]]\ntype = "spring"\ndofs=["1:x"]\nk=1.0\nfoo=2', "unknown key"),
])
def test_bad_model_files(tmp_path, text, match):
    p = tmp_path / "bad.toml"
    p.write_text(text)
    with pytest.raises(InputError, match=match) as info:
        load_model(p)
    assert str(p) in str(info.value)


def test_missing_file_and_wrong_suffix(tmp_path):
    with pytest.raises(InputError, match="no such file"):
        load_model(tmp_path / "none.toml")
    (tmp_path / "m.json").write_text("{}")
    with pytest.raises(InputError, match="model files are TOML"):
        load_model(tmp_path / "m.json")


@pytest.mark.parametrize("fmt", ["mtx", "npz", "npy", "mat"])
def test_matrix_model_formats(tmp_path, fmt):
    truth = three_dof(k4=500.0)
    mats = {"K0": truth.K0, "M0": truth.M0}
    mats.update({f"K_{p}": truth.dK[j] for j, p in enumerate(truth.parameter_names)})

    def save(name, A):
        if fmt == "mtx":
            scipy.io.mmwrite(tmp_path / f"{name}.mtx", sp.coo_matrix(A))
            return f"{name}.mtx"
        if fmt == "npz":
            sp.save_npz(tmp_path / f"{name}.npz", sp.csr_matrix(A))
            return f"{name}.npz"
        if fmt == "npy":
            np.save(tmp_path / f"{name}.npy", A.toarray())
            return f"{name}.npy"
        mat = tmp_path / "all.mat"
        old = {k: v for k, v in scipy.io.loadmat(mat).items() if not k.startswith("__")} if mat.exists() else {}
        scipy.io.savemat(mat, {**old, name: A.toarray()})
        return f"all.mat:{name}"

    files = {k: save(k, v) for k, v in mats.items()}
    (tmp_path / "dofs.txt").write_text("# exported dofs\n" + "\n".join(truth.dofs) + "\n")
    lines = ['[model]', 'name = "exported"', '[matrices]', 'dofs = "dofs.txt"', f'K0 = "{files["K0"]}"', f'M0 = "{files["M0"]}"']
    for j, p in enumerate(truth.parameter_names):
        lines += [f"[parameters.{p}]", f"value = {truth.values[j]}", f'K = "{files["K_" + p]}"']
    (tmp_path / "model.toml").write_text("\n".join(lines))
    model = load_model(tmp_path / "model.toml")
    assert model.dofs == truth.dofs
    np.testing.assert_allclose(model.K().toarray(), truth.K().toarray())
    np.testing.assert_allclose(model_modes(model).eigenvalues, model_modes(truth).eigenvalues, rtol=1e-12)


def test_matrix_model_bad_matrices(tmp_path):
    np.save(tmp_path / "K0.npy", np.array([[1.0, 2.0], [0.0, 1.0]]))
    np.save(tmp_path / "M0.npy", np.eye(2))
    np.save(tmp_path / "Knan.npy", np.array([[np.nan, 0.0], [0.0, 1.0]]))
    base = '[matrices]\ndofs = ["1:x", "2:x"]\nM0 = "M0.npy"\n'
    (tmp_path / "a.toml").write_text(base + 'K0 = "K0.npy"\n')
    with pytest.raises(InputError, match="K0 is not symmetric"):
        load_model(tmp_path / "a.toml")
    (tmp_path / "b.toml").write_text(base + 'K0 = "Knan.npy"\n')
    with pytest.raises(InputError, match="NaN"):
        load_model(tmp_path / "b.toml")
    (tmp_path / "c.toml").write_text(base + 'K0 = "missing.mtx"\n')
    with pytest.raises(InputError, match="not found"):
        load_model(tmp_path / "c.toml")
    (tmp_path / "d.toml").write_text('[matrices]\ndofs = ["1:x"]\nM0 = "M0.npy"\nK0 = "M0.npy"\n')
    with pytest.raises(InputError, match="model has 1 dofs"):
        load_model(tmp_path / "d.toml")


@pytest.mark.parametrize("data, match", [
    ({"modes": [{"frequency_hz": float("nan")}]}, r"^modes\[1\] frequency_hz: NaN"),  # the place named once
    ({"modes": [{"frequency_hz": 1.0, "shape": {"1:x": float("nan")}}]}, "NaN"),
    ({"modes": [{"frequency_hz": 1.0, "eigenvalue": 2.0}]}, "exactly one"),
    ({"modes": [{"frequency_hz": -1.0}]}, ">= 0"),
    ({"frf": {"omega_rad_s": [1.0, 2.0], "force": {"1:x": 1.0}, "response": {"1:x": [0.1]}}}, "expected 2 values"),
    ({"frf": {"omega_rad_s": [1.0], "force": {"1:x": 1.0}, "response": {"1:x": [[1.0, 2.0, 3.0]]}}}, r"pair \[re, im\]"),
    ({"nodes": []}, "unknown key"),
    ({}, "no test data"),
    ([1, 2], "JSON object"),
])
def test_bad_test_data(data, match):
    with pytest.raises(InputError, match=match):
        parse_testdata(data)


def test_test_data_dofs_checked_against_model(tmp_path):
    p = tmp_path / "d.json"
    p.write_text(json.dumps({"modes": [{"frequency_hz": 1.0, "shape": {"1:x": 1.0, "9:z": 0.5}}]}))
    with pytest.raises(InputError, match=r"not in the model .*9:z"):
        load_testdata(p, three_dof())
    p.write_text("{not json")
    with pytest.raises(InputError, match="malformed JSON"):
        load_testdata(p)


def test_write_json_atomic_and_nan(tmp_path):
    out = tmp_path / "sub" / "r.json"
    write_json(out, {"a": np.array([1.0, np.nan]), "b": np.float64(np.inf), "c": (1, 2), "d": 1 + 2j})
    assert json.loads(out.read_text()) == {"a": [1.0, None], "b": None, "c": [1, 2], "d": [1.0, 2.0]}
    assert [p.name for p in out.parent.iterdir()] == ["r.json"]  # no temporary left behind


@given(st.integers(min_value=0, max_value=10**6), st.sampled_from(["x", "y", "z", "rx", "ry", "rz"]))
def test_dof_label_round_trip(node, direction):
    label = f" {node} : {direction.upper()} "
    assert parse_dof(canonical(label)) == (node, direction)


json_values = st.recursive(
    st.none() | st.booleans() | st.floats(allow_nan=True) | st.text(max_size=5),
    lambda children: st.lists(children, max_size=3) | st.dictionaries(st.sampled_from(
        ["modes", "frf", "static", "shape", "frequency_hz", "eigenvalue", "1:x", "force", "response",
         "omega_rad_s", "displacement"]), children, max_size=4),
    max_leaves=12,
)


@settings(max_examples=300, deadline=None)
@given(json_values)
def test_test_data_parser_only_raises_input_error(value):
    try:
        data = parse_testdata(value)
    except InputError:
        return
    assert isinstance(data, TestData)
    for m in data.modes:
        assert math.isfinite(m.eigenvalue)


def test_written_files_get_ordinary_permissions(tmp_path):
    """Atomic writes go through a private temporary file; the result must not stay private (0600)."""
    import os

    from femupdate.io.results import atomic_write_text

    umask = os.umask(0o022)
    try:
        atomic_write_text(tmp_path / "new.json", "{}")
        assert (tmp_path / "new.json").stat().st_mode & 0o777 == 0o644
        (tmp_path / "old.json").write_text("{}")
        os.chmod(tmp_path / "old.json", 0o640)
        atomic_write_text(tmp_path / "old.json", "[]")  # a replaced file keeps its permissions
        assert (tmp_path / "old.json").stat().st_mode & 0o777 == 0o640
    finally:
        os.umask(umask)
