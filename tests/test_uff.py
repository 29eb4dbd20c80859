"""Universal-file reading and writing (femupdate.io.uff) through pyuff."""

from __future__ import annotations

import os

import numpy as np
import pytest

pyuff = pytest.importorskip("pyuff")

from femupdate import InputError  # noqa: E402
from femupdate.io.uff import read_uff, write_uff_frf, write_uff_modes  # noqa: E402
from femupdate.modal import Modes  # noqa: E402
from femupdate.testdata import FRFData  # noqa: E402

# UFF stores mode shapes, frequencies and abscissas in E13.5: six significant digits.
RTOL = 1e-5


# ---------------------------------------------------------------------------- helpers
def _write_sets(path, sets):
    pyuff.UFF(str(path)).write_sets(list(sets), mode="overwrite")
    return path


def _nodes_set(ids):
    ids = np.asarray(ids, dtype=int)
    z = np.zeros(ids.size, dtype=int)
    return pyuff.prepare_2411(
        node_nums=ids, def_cs=z, disp_cs=z, color=z,
        x=ids.astype(float), y=np.zeros(ids.size), z=np.zeros(ids.size),
    )


def _mode_set(nodes, r, freq, mode_n=1):
    """A real normal-mode dataset 55; ``r`` is (n_nodes, 3 or 6)."""
    r = np.asarray(r, dtype=float)
    ncomp = r.shape[1]
    return pyuff.prepare_55(
        model_type=1, analysis_type=2, data_ch=2 if ncomp == 3 else 3, spec_data_type=8,
        data_type=2, n_data_per_node=ncomp, node_nums=np.asarray(nodes, dtype=int),
        load_case=1, mode_n=mode_n, freq=float(freq), modal_m=0.0,
        modal_damp_vis=0.0, modal_damp_his=0.0,
        **{f"r{j + 1}": r[:, j].copy() for j in range(ncomp)},
    )


def _frf_set(rsp_node, rsp_dir, ref_node, ref_dir, data, f_hz, ordinate=8, func_type=4):
    return pyuff.prepare_58(
        binary=0, func_type=func_type, rsp_node=rsp_node, rsp_dir=rsp_dir, ref_node=ref_node,
        ref_dir=ref_dir, abscissa_spacing=0, abscissa_spec_data_type=18,
        ordinate_spec_data_type=ordinate, orddenom_spec_data_type=13,
        data=np.asarray(data, dtype=complex), x=np.asarray(f_hz, dtype=float),
    )


def _value(mode, label):
    return mode.shape[mode.dofs.index(label)]


# ---------------------------------------------------------------------------- modes
def test_modes_round_trip_mixed_3_and_6_component_nodes(tmp_path):
    # node 1: x y rz (planar beam node), node 2: all six, node 3: translations only
    dofs = ("1:x", "1:y", "1:rz", "2:x", "2:y", "2:z", "2:rx", "2:ry", "2:rz", "3:x", "3:y", "3:z")
    rng = np.random.default_rng(1)
    phi = rng.normal(size=(len(dofs), 3))
    lam = np.array([40.0, 900.0, 2.5e4])
    modes = Modes(lam, phi, dofs)
    nodes = {1: (0.0, 0.0, 0.0), 2: (0.5, 0.25, 0.0), 3: (1.0, 0.0, -0.125)}
    path = tmp_path / "modes.uff"

    write_uff_modes(path, modes, nodes=nodes)
    td = read_uff(path)

    np.testing.assert_allclose(td.frequencies_hz, modes.frequencies_hz, rtol=RTOL)
    np.testing.assert_allclose(td.eigenvalues, lam, rtol=2 * RTOL)
    assert td.nodes == nodes
    assert td.units["system"] == "SI" and td.units["code"] == 1
    for r, m in enumerate(td.modes):
        # the records carry 6 components at every node; the padding (zero in every mode) is left out
        assert m.dofs == dofs
        np.testing.assert_allclose(m.shape, phi[:, r], rtol=RTOL, atol=RTOL * np.abs(phi[:, r]).max())
    (note,) = [n for n in td.notes if "taken as unmeasured" in n]
    assert "6 component(s)" in note and "1:z, 1:rx, 1:ry, 3:rx, 3:ry, 3:rz" in note


def test_modes_round_trip_translations_only_writes_3_dof_records(tmp_path):
    dofs = ("1:x", "1:y", "1:z", "2:x", "2:y", "2:z")
    phi = np.array([[1.0, 0.5], [0.0, -1.0], [0.25, 0.0], [-0.75, 0.3], [0.1, 0.2], [0.0, 1.0]])
    path = tmp_path / "t.uff"
    write_uff_modes(path, Modes(np.array([1.0, 4.0]), phi, dofs), units=False)

    sets = pyuff.UFF(str(path)).read_sets()
    assert [s["type"] for s in sets] == [55, 55]
    assert all(s["n_data_per_node"] == 3 and s["data_ch"] == 2 for s in sets)
    td = read_uff(path)
    assert td.units == {} and td.nodes == {}
    for r, m in enumerate(td.modes):
        assert m.dofs == dofs
        np.testing.assert_allclose(m.shape, phi[:, r], rtol=RTOL, atol=1e-12)


def test_modes_are_ordered_by_frequency_and_use_the_record_frequency(tmp_path):
    path = _write_sets(tmp_path / "m.uff", [
        _mode_set([1, 2], [[1, 0, 0], [2, 0, 0]], freq=30.0, mode_n=1),
        _mode_set([1, 2], [[1, 0, 0], [-1, 0, 0]], freq=12.5, mode_n=2),
    ])
    td = read_uff(path)
    np.testing.assert_allclose(td.frequencies_hz, [12.5, 30.0], rtol=RTOL)
    assert [m.label for m in td.modes] == ["2", "1"]
    np.testing.assert_allclose(_value(td.modes[0], "2:x"), -1.0)


def test_complex_modes_use_the_modulus_of_the_eigenvalue(tmp_path):
    s = complex(-0.02 * 50.0, 50.0 * np.sqrt(1 - 0.02**2))  # omega_n = 50 rad/s, zeta = 2 %
    r1 = np.array([1.0 + 0.1j, -0.5 + 0.0j])
    ds = pyuff.prepare_55(
        model_type=1, analysis_type=3, data_ch=2, spec_data_type=8, data_type=5,
        n_data_per_node=3, node_nums=np.array([4, 5]), load_case=1, mode_n=1, eig=s,
        modal_a=0j, modal_b=0j, r1=r1, r2=np.zeros(2, complex), r3=np.array([0.0, 0.2j]),
    )
    td = read_uff(_write_sets(tmp_path / "c.uff", [ds]))
    (m,) = td.modes
    np.testing.assert_allclose(m.eigenvalue, 50.0**2, rtol=RTOL)
    assert np.iscomplexobj(m.shape)
    np.testing.assert_allclose(_value(m, "4:x"), 1.0 + 0.1j, rtol=RTOL)
    np.testing.assert_allclose(_value(m, "5:z"), 0.2j, rtol=RTOL)


def test_model_dofs_check_names_the_record_and_the_dofs(tmp_path):
    path = _write_sets(tmp_path / "test.uff", [
        _mode_set([1, 2], [[1, 0, 0], [2, 0, 0]], freq=10.0, mode_n=1),
        _mode_set([1, 9], [[1, 0, 0], [0.5, 0.25, 0]], freq=20.0, mode_n=2),
    ])
    model_dofs = ["1:x", "1:y", "1:z", "2:x", "2:y", "2:z"]
    with pytest.raises(InputError) as err:
        read_uff(path, model_dofs=model_dofs)
    msg = str(err.value)
    assert "test.uff: dataset 55 record 2" in msg
    assert "not in the model" in msg and "9:x" in msg and "9:y" in msg and "1:" not in msg.split("model:")[1]


def test_model_dofs_drop_zero_padding_of_a_planar_model(tmp_path):
    # a 6-dof record read for a planar beam model (x, y, rz): zero z, rx, ry are padding
    path = _write_sets(tmp_path / "p.uff", [
        _mode_set([1, 2], [[0.1, 1.0, 0, 0, 0, 0.3], [0.2, -1.0, 0, 0, 0, 0.4]], freq=5.0),
    ])
    model_dofs = ["1:x", "1:y", "1:rz", "2:x", "2:y", "2:rz"]
    (m,) = read_uff(path, model_dofs=model_dofs).modes
    assert m.dofs == tuple(model_dofs)
    np.testing.assert_allclose(m.shape, [0.1, 1.0, 0.3, 0.2, -1.0, 0.4], rtol=RTOL)
    # a non-zero value at a dof the model lacks is an error, padding or not
    path2 = _write_sets(tmp_path / "q.uff", [
        _mode_set([1, 2], [[0.1, 1.0, 0.7, 0, 0, 0.3], [0.2, -1.0, 0, 0, 0, 0.4]], freq=5.0),
    ])
    with pytest.raises(InputError, match=r"dataset 55 record 1: dof\(s\) not in the model: 1:z"):
        read_uff(path2, model_dofs=model_dofs)


def test_model_argument_uses_its_dofs(tmp_path):
    class FakeModel:
        dofs = ("1:x", "2:x")

    path = _write_sets(tmp_path / "m.uff", [_mode_set([1, 3], [[1, 0, 0], [2, 0, 0]], freq=3.0)])
    with pytest.raises(InputError, match=r"not in the model: 3:x"):
        read_uff(path, model=FakeModel())


def test_unknown_nodes_in_mode_records(tmp_path):
    path = _write_sets(tmp_path / "n.uff", [
        _nodes_set([1, 2]),
        _mode_set([1, 2, 7], [[1, 0, 0], [2, 0, 0], [3, 0, 0]], freq=4.0),
    ])
    with pytest.raises(InputError, match=r"n\.uff: dataset 55 record 1: unknown node\(s\) 7"):
        read_uff(path)


def test_nodes_from_dataset_15(tmp_path):
    ds15 = pyuff.prepare_15(
        node_nums=[3, 4], def_cs=[0, 0], disp_cs=[0, 0], color=[0, 0],
        x=[0.0, 1.5], y=[0.0, 0.0], z=[0.25, 0.0],
    )
    path = _write_sets(tmp_path / "n15.uff", [ds15, _mode_set([3, 4], [[1, 0, 0], [1, 0, 0]], freq=1.0)])
    assert read_uff(path).nodes == {3: (0.0, 0.0, 0.25), 4: (1.5, 0.0, 0.0)}


# ---------------------------------------------------------------------------- FRFs
def test_frf_round_trip_complex(tmp_path):
    rng = np.random.default_rng(2)
    omega = np.linspace(2.0, 300.0, 41)
    resp = rng.normal(size=(41, 3)) + 1j * rng.normal(size=(41, 3))
    frf = FRFData(omega, {"2:y": 2.5}, ("1:x", "2:rz", "3:z"), resp)
    path = tmp_path / "frf.uff"

    write_uff_frf(path, frf, nodes={1: (0, 0, 0), 2: (1, 0, 0), 3: (2, 0, 0)})
    td = read_uff(path)

    got = td.frf
    assert got.dofs == ("1:x", "2:rz", "3:z")
    assert got.force == {"2:y": 1.0}
    np.testing.assert_allclose(got.omega, omega, rtol=RTOL)
    np.testing.assert_allclose(got.response, resp / 2.5, rtol=1e-10)
    assert td.modes == ()


def test_frf_round_trip_single_frequency(tmp_path):
    frf = FRFData([7.0], {"1:x": 1.0}, ("1:x", "2:x"), [[1.0 - 2.0j, 0.5j]])
    path = tmp_path / "one.uff"
    write_uff_frf(path, frf, units=False)
    got = read_uff(path).frf
    np.testing.assert_allclose(got.omega, [7.0], rtol=RTOL)
    np.testing.assert_allclose(got.response, [[1.0 - 2.0j, 0.5j]], rtol=1e-10)


def test_negative_direction_codes_negate_the_data(tmp_path):
    f = np.array([1.0, 2.0, 4.0])
    h = np.array([1.0 + 1.0j, 2.0 - 0.5j, -3.0 + 0.0j])
    path = _write_sets(tmp_path / "neg.uff", [
        _frf_set(1, +1, 5, -3, h, f),  # force applied in -z: data negated
        _frf_set(2, -2, 5, -3, h, f),  # sensor in -y and force in -z: sign unchanged
        _frf_set(3, -4, 5, -3, 2 * h, f),  # sensor in -rx, force in -z
    ])
    got = read_uff(path).frf
    assert got.dofs == ("1:x", "2:y", "3:rx")
    assert got.force == {"5:z": 1.0}
    np.testing.assert_allclose(got.response[:, 0], -h, rtol=1e-10)
    np.testing.assert_allclose(got.response[:, 1], h, rtol=1e-10)
    np.testing.assert_allclose(got.response[:, 2], 2 * h, rtol=1e-10)
    np.testing.assert_allclose(got.omega, 2 * np.pi * f, rtol=RTOL)


def test_accelerance_and_mobility_are_converted_to_receptance(tmp_path):
    f = np.array([1.0, 2.0, 5.0])
    w = 2 * np.pi * f
    x = np.array([1.0 + 0.5j, -2.0j, 0.25 + 0.0j])  # the receptance
    path = _write_sets(tmp_path / "acc.uff", [
        _frf_set(1, 1, 1, 1, -(w**2) * x, f, ordinate=12),
        _frf_set(2, 1, 1, 1, 1j * w * x, f, ordinate=11),
        _frf_set(3, 1, 1, 1, x, f, ordinate=8),
    ])
    got = read_uff(path).frf
    for j in range(3):
        np.testing.assert_allclose(got.response[:, j], x, rtol=1e-9)


def test_several_excitation_dofs_give_one_set_each(tmp_path):
    # a roving-hammer file: one response, the hammer at two dofs (it used to be refused)
    f = np.array([1.0, 2.0])
    path = _write_sets(tmp_path / "exc.uff", [
        _frf_set(1, 1, 5, 3, [1, 2], f),
        _frf_set(1, 1, 6, 3, [3, 4], f),
    ])
    td = read_uff(path)
    assert td.n_frf_sets == 2 and td.frf is td.frf_sets[0]
    assert [dict(s.force) for s in td.frf_sets] == [{"5:z": 1.0}, {"6:z": 1.0}]
    assert [s.dofs for s in td.frf_sets] == [("1:x",), ("1:x",)]
    np.testing.assert_allclose(td.frf_sets[1].response[:, 0], [3, 4])
    assert any("2 excitation dofs" in n for n in td.notes)


def test_mismatched_frequency_axis(tmp_path):
    path = _write_sets(tmp_path / "ax.uff", [
        _frf_set(1, 1, 5, 3, [1, 2], [1.0, 2.0]),
        _frf_set(2, 1, 5, 3, [1, 2], [1.0, 2.5]),
    ])
    with pytest.raises(InputError, match=r"dataset 58 record 2: frequency axis"):
        read_uff(path)


def test_frf_unknown_nodes_and_model_dofs(tmp_path):
    f = np.array([1.0, 2.0])
    path = _write_sets(tmp_path / "fn.uff", [_nodes_set([1, 5]), _frf_set(1, 1, 5, 3, [1, 2], f),
                                             _frf_set(8, 2, 5, 3, [1, 2], f)])
    with pytest.raises(InputError, match=r"dataset 58 record 2: unknown node\(s\) 8"):
        read_uff(path)
    path2 = _write_sets(tmp_path / "fm.uff", [_frf_set(1, 1, 5, 3, [1, 2], f)])
    with pytest.raises(InputError, match=r"dataset 58 record 1: dof\(s\) not in the model: 5:z"):
        read_uff(path2, model_dofs=["1:x", "5:x"])


def test_non_frf_functions_are_skipped(tmp_path):
    f = np.array([1.0, 2.0])
    path = _write_sets(tmp_path / "coh.uff", [
        _frf_set(1, 1, 5, 3, [1 + 1j, 2], f),
        pyuff.prepare_58(binary=0, func_type=6, rsp_node=1, rsp_dir=1, ref_node=5, ref_dir=3,
                         abscissa_spacing=0, orddenom_spec_data_type=0,  # pyuff needs it
                         data=np.array([0.9, 0.95]), x=f),
    ])
    assert read_uff(path).frf.dofs == ("1:x",)


def test_binary_58b_records(tmp_path):
    f = np.array([1.0, 2.0, 3.0])
    ds = pyuff.prepare_58(binary=1, func_type=4, rsp_node=1, rsp_dir=1, ref_node=1, ref_dir=-1,
                          abscissa_spacing=1, orddenom_spec_data_type=13,
                          data=np.array([1 + 1j, 2.0, 3j]), x=f)
    path = tmp_path / "bin.uff"
    pyuff.UFF(str(path)).write_sets([ds], mode="add")  # pyuff loses 58b data in 'overwrite' mode
    got = read_uff(path).frf
    np.testing.assert_allclose(got.omega, 2 * np.pi * f, rtol=1e-12)
    np.testing.assert_allclose(got.response[:, 0], [-1 - 1j, -2.0, -3j], rtol=1e-12)


@pytest.mark.parametrize("code", [0, 7, -9])
def test_bad_direction_code(tmp_path, code):
    f = np.array([1.0, 2.0])
    ds = _frf_set(4, 1, 5, 3, [1, 2], f)
    ds["rsp_dir"] = code  # prepare_58 refuses such codes; files can still hold them
    path = _write_sets(tmp_path / "dir.uff", [ds])
    with pytest.raises(InputError, match=rf"dataset 58 record 1: response: node 4: direction code {code}"):
        read_uff(path)


# ---------------------------------------------------------------------------- units
def test_units_dataset_164(tmp_path):
    units = pyuff.prepare_164(units_code=5, units_description="mm (milli newton)", temp_mode=1,
                              length=1000.0, force=1000.0, temp=1.0, temp_offset=273.15)
    path = _write_sets(tmp_path / "u.uff", [units, _mode_set([1], [[1, 0, 0]], freq=2.0)])
    u = read_uff(path).units
    assert u["code"] == 5 and u["system"] == "MM"
    assert u["description"] == "mm (milli newton)"
    assert u["length"] == 1000.0 and u["force"] == 1000.0 and u["temperature"] == 1.0
    assert u["temperature_offset"] == pytest.approx(273.15)


# ---------------------------------------------------------------------------- bad files
def test_not_a_uff_file(tmp_path):
    p = tmp_path / "notes.txt"
    p.write_text("this is not a universal file\n1 2 3\n")
    with pytest.raises(InputError, match=r"notes\.txt: not a universal file"):
        read_uff(p)


def test_missing_empty_and_directory(tmp_path):
    with pytest.raises(InputError, match="file not found"):
        read_uff(tmp_path / "nope.uff")
    (tmp_path / "empty.uff").write_bytes(b"")
    with pytest.raises(InputError, match=r"empty\.uff"):
        read_uff(tmp_path / "empty.uff")
    with pytest.raises(InputError, match="directory"):
        read_uff(tmp_path)


def test_no_usable_datasets(tmp_path):
    path = _write_sets(tmp_path / "geo.uff", [_nodes_set([1, 2])])
    with pytest.raises(InputError, match=r"geo\.uff: no usable data"):
        read_uff(path)


def test_malformed_record_is_wrapped(tmp_path):
    path = _write_sets(tmp_path / "bad.uff", [_mode_set([1, 2], [[1, 0, 0], [2, 0, 0]], freq=2.0),
                                              _mode_set([1, 2], [[1, 0, 0], [3, 0, 0]], freq=3.0)])
    lines = path.read_text().splitlines(keepends=True)
    # garble the frequency line of the second record
    idx = [i for i, line in enumerate(lines) if "3.00000e+00" in line][0]
    lines[idx] = lines[idx].replace("3.00000e+00", "3.0000#e+00")
    path.write_text("".join(lines))
    with pytest.raises(InputError, match=r"bad\.uff: dataset 55 record 2 .*malformed"):
        read_uff(path)


def test_truncated_record(tmp_path):
    path = _write_sets(tmp_path / "trunc.uff", [_mode_set([1, 2], [[1, 0, 0], [2, 0, 0]], freq=2.0)])
    lines = path.read_text().splitlines(keepends=True)
    del lines[-2]  # the values of the last node
    path.write_text("".join(lines))
    with pytest.raises(InputError, match=r"dataset 55 record 1: 2 nodes but 1 values"):
        read_uff(path)


def test_nan_values(tmp_path):
    ds = _frf_set(1, 1, 1, 1, [1.0, 2.0], [1.0, 2.0])
    path = _write_sets(tmp_path / "nan.uff", [ds])
    text = path.read_text()
    # pyuff's writer turns NaN into 0, so put one in by hand (E20.11 field)
    first = [line for line in text.splitlines() if line.strip().startswith("1.00000e+00")][0]
    path.write_text(text.replace(first, first[:13] + f"{'nan':>20s}" + first[33:]))
    with pytest.raises(InputError, match=r"nan\.uff: dataset 58 record 1: NaN"):
        read_uff(path)


# ---------------------------------------------------------------------------- writing
def test_write_is_atomic(tmp_path, monkeypatch):
    path = tmp_path / "keep.uff"
    path.write_text("old content\n")
    frf = FRFData([1.0, 2.0], {"1:x": 1.0}, ("1:x", "2:x", "3:x"), np.ones((2, 3)))
    calls = {"n": 0}
    real = pyuff.UFF.write_sets

    def failing(self, dsets, mode="add", force_double=True):
        calls["n"] += 1
        if calls["n"] == 3:
            raise Exception("disk full")
        return real(self, dsets, mode=mode, force_double=force_double)

    monkeypatch.setattr(pyuff.UFF, "write_sets", failing)
    with pytest.raises(InputError, match=r"keep\.uff: pyuff could not write dataset 58"):
        write_uff_frf(path, frf)
    assert path.read_text() == "old content\n"
    assert os.listdir(tmp_path) == ["keep.uff"]


def test_write_refuses_what_uff_cannot_hold(tmp_path):
    frf = FRFData([1.0, 2.0], {"1:x": 1.0, "2:x": 1.0}, ("1:x",), np.ones((2, 1)))
    with pytest.raises(InputError, match="one excitation dof"):
        write_uff_frf(tmp_path / "two.uff", frf)
    modes = Modes(np.array([1.0]), np.array([[1.0], [2.0]]), ("1:x", "2:x"))
    with pytest.raises(InputError, match=r"node\(s\) without coordinates in `nodes`: 2"):
        write_uff_modes(tmp_path / "m.uff", modes, nodes={1: (0, 0, 0)})
    with pytest.raises(InputError, match="directory"):
        write_uff_modes(tmp_path / "no" / "such" / "m.uff", modes)
    assert os.listdir(tmp_path) == []
