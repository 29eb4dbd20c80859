"""Universal files as instruments and modal software write them (issue 15): padded zeros in 3- and
6-value records, sensor lists, local coordinate systems (2420, 18), units (164), records cut
short and multi-reference FRF sets.  Every file is built here with pyuff's writer."""

from __future__ import annotations

import json

import numpy as np
import pytest

pyuff = pytest.importorskip("pyuff")

from femupdate import InputError  # noqa: E402
from femupdate.examples import chain, portal_frame, two_dof  # noqa: E402
from femupdate.frf.simulate import simulate  # noqa: E402
from femupdate.io.testdata_json import load_testdata  # noqa: E402
from femupdate.io.uff import read_uff  # noqa: E402
from femupdate.modal import model_modes  # noqa: E402
from femupdate.updating import frf_update, update  # noqa: E402
from test_cli import run  # noqa: E402

TRUTH = {"E_col": 2.25e11, "E_beam": 1.95e11}  # the nominal frame has 2.1e11 in both


# ---------------------------------------------------------------------------- writers
def _write(path, sets):
    pyuff.UFF(str(path)).write_sets(list(sets), mode="overwrite")
    return path


def _nodes(ids, xyz=None, disp_cs=0, def_cs=0):
    ids = np.asarray(ids, dtype=int)
    xyz = np.zeros((ids.size, 3)) if xyz is None else np.asarray(xyz, dtype=float)
    full = lambda v: np.broadcast_to(np.asarray(v, dtype=int), ids.shape).copy()  # noqa: E731
    return pyuff.prepare_2411(node_nums=ids, def_cs=full(def_cs), disp_cs=full(disp_cs), color=full(1),
                              x=xyz[:, 0].copy(), y=xyz[:, 1].copy(), z=xyz[:, 2].copy())


def _mode(nodes, values, freq, mode_n):
    """A real normal-mode dataset 55; ``values`` is (n_nodes, 3 or 6)."""
    values = np.asarray(values, dtype=float)
    ncomp = values.shape[1]
    return pyuff.prepare_55(model_type=1, analysis_type=2, data_ch=2 if ncomp == 3 else 3, spec_data_type=8,
                            data_type=2, n_data_per_node=ncomp, node_nums=np.asarray(nodes, dtype=int), load_case=1,
                            mode_n=mode_n, freq=float(freq), modal_m=0.0, modal_damp_vis=0.0, modal_damp_his=0.0,
                            **{f"r{j + 1}": values[:, j].copy() for j in range(ncomp)})


def _frf(rsp_node, rsp_dir, ref_node, ref_dir, data, f_hz):
    return pyuff.prepare_58(binary=0, func_type=4, rsp_node=rsp_node, rsp_dir=rsp_dir, ref_node=ref_node,
                            ref_dir=ref_dir, abscissa_spacing=0, abscissa_spec_data_type=18,
                            ordinate_spec_data_type=8, orddenom_spec_data_type=13,
                            data=np.asarray(data, dtype=complex), x=np.asarray(f_hz, dtype=float))


def _units(code, length, force, description):
    return pyuff.prepare_164(units_code=code, units_description=description, temp_mode=1, length=float(length),
                             force=float(force), temp=1.0, temp_offset=273.15)


def _systems_2420(labels, matrices, types=None, names=None):
    n = len(labels)
    return pyuff.prepare_2420(Part_UID=1, Part_Name="test", CS_sys_labels=list(labels),
                              CS_types=list(types or [0] * n), CS_colors=[8] * n,
                              CS_names=list(names or [f"CS{k}" for k in labels]),
                              CS_matrices=[np.asarray(m, dtype=float) for m in matrices])


# a local system turned 90 degrees about z: its x axis is the global y, its y axis the global -x
ROT_Z90 = np.array([[0.0, 1.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])


def _frame_modes(n=4):
    truth = portal_frame(TRUTH["E_col"], TRUTH["E_beam"])
    mm = model_modes(truth, n_modes=n)
    nodes = sorted({int(d.split(":")[0]) for d in truth.dofs})
    return truth, mm, nodes


def _at(truth, mm, r, label):
    return mm.shapes[truth.dofs.index(label), r]


def _frame_file(path, components, measured=("x",), units=None, scale=1.0, system=None):
    """The frame's lowest four modes, measured at ``measured`` of every free node, written with
    ``components`` (3 or 6) values per node, zeros elsewhere; translations times ``scale`` (a file
    in other units); with ``system`` = (label, R), the nodes' data in that system."""
    truth, mm, nodes = _frame_modes()
    sets = []
    if units is not None:
        sets.append(units)
    if system is not None:
        label, R = system
        sets.append(_systems_2420([label], [np.vstack([R, np.zeros(3)])]))
        sets.append(_nodes(nodes, disp_cs=label))
    for r in range(4):
        vals = np.zeros((len(nodes), components))
        for i, n in enumerate(nodes):
            for j, d in enumerate(("x", "y", "z", "rx", "ry", "rz")[:components]):
                if d in measured:
                    vals[i, j] = _at(truth, mm, r, f"{n}:{d}") * (scale if j < 3 else 1.0)
            if system is not None:  # the global components g seen along the local axes: R g
                vals[i, :3] = R @ vals[i, :3]
                if components == 6:
                    vals[i, 3:] = R @ vals[i, 3:]
        sets.append(_mode(nodes, vals, mm.frequencies_hz[r], r + 1))
    return _write(path, sets)


# ---------------------------------------------------------------------------- padded zeros
@pytest.mark.parametrize("components", [3, 6])
def test_padded_zeros_are_not_measurements(tmp_path, components):
    # accelerometers along x only; the records pad y, z (and the rotations) with zeros
    path = _frame_file(tmp_path / f"pad{components}.uff", components)
    start = portal_frame()
    td = read_uff(path, model=start)
    for m in td.modes:
        assert m.dofs and all(d.endswith(":x") for d in m.dofs)
    (note,) = [n for n in td.notes if "taken as unmeasured" in n]
    assert f"{11 * (components - 1)} component(s)" in note and "2:y" in note
    res = update(start, td)
    assert res.success
    for k, v in TRUTH.items():
        assert res.parameters[k] == pytest.approx(v, rel=1e-4)
    # the same file with the padding taken as measured (every model dof a sensor) misleads the update
    wrong = update(start, read_uff(path, model=start, sensors=start.dofs))
    assert max(abs(wrong.parameters[k] / v - 1) for k, v in TRUTH.items()) > 0.01


def test_a_zero_in_some_modes_is_kept_and_named(tmp_path):
    nodes = [1, 2, 3]
    path = _write(tmp_path / "z.uff", [
        _mode(nodes, [[1.0, 0, 0], [0.0, 0, 0], [-1.0, 0, 0]], 10.0, 1),  # 2:x at a nodal point
        _mode(nodes, [[1.0, 0, 0], [1.5, 0, 0], [1.0, 0, 0]], 20.0, 2),
    ])
    td = read_uff(path)
    assert td.modes[0].dofs == ("1:x", "2:x", "3:x")
    assert td.modes[0].shape[1] == 0.0
    (kept,) = [n for n in td.notes if "zero values kept as measured" in n]
    assert "2:x (mode 1)" in kept
    (dropped,) = [n for n in td.notes if "taken as unmeasured" in n]
    assert "6 component(s)" in dropped


def test_sensor_list_keeps_a_measured_zero(tmp_path):
    # one mode: 2:x is a node of the shape; the zero rule would drop it, the sensor list keeps it
    path = _write(tmp_path / "one.uff", [_mode([1, 2, 3], [[1.0, 0, 0], [0.0, 0, 0], [-1.0, 0, 0]], 10.0, 1)])
    assert read_uff(path).modes[0].dofs == ("1:x", "3:x")
    td = read_uff(path, sensors=["1:x", "2:x", "3:x"])
    assert td.modes[0].dofs == ("1:x", "2:x", "3:x")
    np.testing.assert_array_equal(td.modes[0].shape, [1.0, 0.0, -1.0])
    assert any("measured dofs are the dofs given" in n for n in td.notes)


def test_measured_dofs_option_and_json_sensors(tmp_path, capsys):
    model = two_dof()
    toml = tmp_path / "m.toml"
    from femupdate.examples import two_dof_model_toml

    toml.write_text(two_dof_model_toml())
    mm = model_modes(model)
    uff = _write(tmp_path / "one.uff", [_mode([1, 2], [[mm.shapes[0, 0], 0, 0], [0.0, 0, 0]], mm.frequencies_hz[0], 1)])
    out = tmp_path / "c.json"
    code, _, err = run(["correlate", str(toml), str(uff), "--json", str(out)], capsys)
    assert code == 0, err
    got = json.loads(out.read_text())
    assert got["dofs"] == ["1:x"] and any("taken as unmeasured" in n for n in got["notes"])
    code, _, err = run(["correlate", str(toml), str(uff), "--measured-dofs", "#1,2:x", "--json", str(out)], capsys)
    assert code == 0, err
    got = json.loads(out.read_text())
    assert got["dofs"] == ["1:x", "2:x"]
    assert got["mac"][0][0] < 0.99  # 2:x measured as zero: the shape no longer matches mode 1
    code, _, err = run(["correlate", str(toml), str(uff), "--measured-dofs", "#3"], capsys)
    assert code == 2 and "--measured-dofs" in err and "out of range" in err, err
    # JSON test data: padded zeros at 2:x, the sensors say 1:x only
    js = tmp_path / "t.json"
    js.write_text(json.dumps({"sensors": ["1:x"], "modes": [
        {"frequency_hz": float(mm.frequencies_hz[0]), "shape": {"1:x": 1.0, "2:x": 0.0}},
        {"frequency_hz": float(mm.frequencies_hz[1]), "shape": {"1:x": 1.0, "2:x": 0.0}, "sensors": ["1:x", "2:x"]}]}))
    td = load_testdata(js, model)
    assert td.modes[0].dofs == ("1:x",) and td.modes[1].dofs == ("1:x", "2:x")
    assert any("modes[1]" in n and "left out: 2:x" in n for n in td.notes)
    assert load_testdata(js, model, sensors=["#1", "#2"]).modes[0].dofs == ("1:x", "2:x")
    js.write_text(json.dumps({"sensors": "1:x", "modes": [{"frequency_hz": 1.0}]}))
    with pytest.raises(InputError, match=r"sensors: expected a list of dofs"):
        load_testdata(js, model)


def test_frf_records_give_the_measured_dofs(tmp_path):
    # modes and FRFs in one file: the modes are measured where the FRFs are
    f = np.array([1.0, 2.0])
    path = _write(tmp_path / "both.uff", [
        _mode([1, 2], [[1.0, 0.0, 0.5], [0.0, 0.0, 0.0]], 10.0, 1),
        _frf(1, 1, 1, 1, [1.0, 2.0], f),
        _frf(2, 1, 1, 1, [1.0, 2.0], f),
    ])
    td = read_uff(path)
    assert td.modes[0].dofs == ("1:x", "2:x")  # 1:z is not a response dof; 2:x is, its zero kept
    np.testing.assert_array_equal(td.modes[0].shape, [1.0, 0.0])
    assert any("dofs of the file's FRF records" in n and "1:z" in n for n in td.notes)


# ---------------------------------------------------------------------------- coordinate systems
@pytest.mark.parametrize("components", [3, 6])
def test_local_system_turned_90_degrees_gives_the_global_data(tmp_path, components):
    measured = ("x", "y", "rz") if components == 6 else ("x", "y")
    glob = read_uff(_frame_file(tmp_path / "g.uff", components, measured))
    local = read_uff(_frame_file(tmp_path / "l.uff", components, measured, system=(5, ROT_Z90)))
    for a, b in zip(glob.modes, local.modes):
        assert a.dofs == b.dofs
        np.testing.assert_array_equal(a.shape, b.shape)
    assert any("local displacement coordinate systems (5)" in n for n in local.notes)


def test_dataset_18_system_and_local_coordinates(tmp_path):
    # system 7 of dataset 18: origin (1, 2, 0), +x along the global y, +xz plane the global yz
    cs = pyuff.prepare_18(cs_num=[7], cs_type=[0], ref_cs_num=[0], color=[8], method=[1], cs_name=["turned"],
                          ref_o=[[1.0, 2.0, 0.0]], x_point=[[1.0, 3.0, 0.0]], xz_point=[[1.0, 2.0, 1.0]])
    path = _write(tmp_path / "s18.uff", [
        cs,
        _nodes([1, 2], xyz=[[0.5, 0.25, 0.0], [0.0, 0.0, 2.0]], disp_cs=7, def_cs=7),
        _mode([1, 2], [[1.0, 0.5, 0.0], [-0.25, 2.0, 0.0]], 10.0, 1),
        _frf(2, 1, 1, -2, [1.0, 2.0], [1.0, 2.0]),
    ])
    td = read_uff(path)
    # coordinates: o + Rᵀ p with the local x = global y, local y = global -x
    assert td.nodes[1] == pytest.approx((1.0 - 0.25, 2.0 + 0.5, 0.0))
    assert td.nodes[2] == pytest.approx((1.0, 2.0, 2.0))
    # with the FRF records, the modes are measured at their response dofs: local x of node 2 = global y
    td = read_uff(path, sensors=["1:x", "1:y", "2:x", "2:y"])
    m = td.modes[0]
    assert dict(zip(m.dofs, m.shape)) == {"1:x": -0.5, "1:y": 1.0, "2:x": -2.0, "2:y": -0.25}
    # FRF: response local +x of node 2 = global +y; excitation local -y of node 1 = global +x
    assert td.frf.dofs == ("2:y",) and dict(td.frf.force) == {"1:x": 1.0}
    np.testing.assert_array_equal(td.frf.response[:, 0].real, [1.0, 2.0])


def test_cylindrical_and_undefined_systems_are_refused_by_name(tmp_path):
    cyl = _write(tmp_path / "cyl.uff", [
        _systems_2420([3], [np.vstack([np.eye(3), np.zeros(3)])], types=[1], names=["DRUM"]),
        _nodes([1, 2], disp_cs=[0, 3]),
        _mode([1, 2], [[1.0, 0, 0], [1.0, 0, 0]], 10.0, 1),
    ])
    with pytest.raises(InputError, match=r"cyl\.uff: dataset 55 record 1: node 2: its displacement system is "
                                         r"coordinate system 3 \('DRUM', dataset 2420 record 1\), a cylindrical"):
        read_uff(cyl)
    missing = _write(tmp_path / "missing.uff", [_nodes([1, 2], disp_cs=[0, 4]), _mode([1, 2], [[1.0, 0, 0]] * 2, 10.0, 1)])
    with pytest.raises(InputError, match=r"dataset 2411 record 1: node 2: its displacement coordinate system 4 is not "
                                         r"defined in the file"):
        read_uff(missing)


def test_an_oblique_component_measured_alone_is_refused(tmp_path):
    c = np.sqrt(0.5)
    R = np.array([[c, c, 0.0], [-c, c, 0.0], [0.0, 0.0, 1.0]])  # 45 degrees about z
    path = _write(tmp_path / "ob.uff", [
        _systems_2420([9], [np.vstack([R, np.zeros(3)])]),
        _nodes([1, 2], disp_cs=[0, 9]),
        _mode([1, 2], [[1.0, 0, 0], [0.5, 0, 0]], 10.0, 1),
        _mode([1, 2], [[1.0, 0, 0], [-0.5, 0, 0]], 20.0, 2),
    ])
    with pytest.raises(InputError, match=r"dataset 55 record 1: node 2: the measured component\(s\) x along the axes "
                                         r"of coordinate system 9 .* cannot be rotated into the model's axes"):
        read_uff(path)


# ---------------------------------------------------------------------------- units
def test_millimetre_modes_update_as_the_si_file(tmp_path):
    measured = ("x", "y", "rz")  # translations and rotations: their relative scale depends on the units
    si = _frame_file(tmp_path / "si.uff", 6, measured, units=_units(1, 1.0, 1.0, "SI"))
    mm = _frame_file(tmp_path / "mm.uff", 6, measured, units=_units(9, 1000.0, 1.0, "mm N"), scale=1000.0)
    a, b = read_uff(si), read_uff(mm)
    for x, y in zip(a.modes, b.modes):
        assert x.dofs == y.dofs
        np.testing.assert_allclose(y.shape, x.shape, rtol=1e-12)
    assert b.units["system"] == "US" and b.units["data"] == "SI"
    assert any("lengths divided by 1000" in n for n in b.notes)
    start = portal_frame()
    ra, rb = update(start, a), update(start, b)
    for k, v in TRUTH.items():
        assert rb.parameters[k] == pytest.approx(ra.parameters[k], rel=1e-8)
        assert rb.parameters[k] == pytest.approx(v, rel=1e-4)


@pytest.mark.parametrize("code, length, force", [(9, 1000.0, 1.0), (5, 1000.0, 1000.0), (8, 1000.0, 1 / 9.80665)])
def test_millimetre_frfs_update_as_the_si_file(tmp_path, code, length, force):
    truth, start = two_dof(9.0, 5.0), two_dof()
    f_hz = np.linspace(0.05, 0.6, 12)
    sim = simulate(truth, 2 * np.pi * f_hz, {"1:x": 1.0})
    coords = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]]

    def write(path, units, scale_length, scale_force):  # receptance: length / force
        return _write(path, [units, _nodes([1, 2], xyz=np.asarray(coords) * scale_length),
                             *(_frf(n, 1, 1, 1, sim.response[:, j] * scale_length / scale_force, f_hz)
                               for j, n in enumerate((1, 2)))])

    si = read_uff(write(tmp_path / "si.uff", _units(1, 1.0, 1.0, "SI"), 1.0, 1.0))
    other = read_uff(write(tmp_path / "mm.uff", _units(code, length, force, "mm"), length, force))
    # dataset 58 holds 12 significant digits: a value scaled by 1000 / 9.80665 rounds at 1e-12
    np.testing.assert_allclose(other.frf.response, si.frf.response, rtol=1e-11)
    assert other.nodes[2] == pytest.approx((1.0, 0.0, 0.0))
    ra, rb = frf_update(start, si), frf_update(start, other)
    for k in ("k1", "k2"):
        assert rb.parameters[k] == pytest.approx(ra.parameters[k], rel=1e-8)
    assert rb.parameters["k1"] == pytest.approx(9.0, rel=1e-4)


# ---------------------------------------------------------------------------- records cut short
def test_a_record_cut_short_is_refused_by_number(tmp_path):
    f = np.linspace(1.0, 2.0, 4)
    sets = [_mode([1, 2], [[1.0, 0, 0], [2.0, 0, 0]], 10.0, 1), _frf(1, 1, 1, 1, f, f), _frf(2, 1, 1, 1, f, f)]
    path = _write(tmp_path / "cut.uff", sets)
    text = path.read_text()
    path.write_text(text[: text.rindex("    -1") - 30])  # the file ends inside the second FRF record
    with pytest.raises(InputError, match=r"cut\.uff: dataset 58 record 2 \(block 3 of the file\) is truncated"):
        read_uff(path)


# ---------------------------------------------------------------------------- several references
def _roving_hammer(tmp_path, refs=(1, 2, 3), response=3):
    truth, start = chain([900.0, 700.0, 500.0], [1.0, 1.5, 2.0]), chain([600.0, 600.0, 600.0], [1.0, 1.5, 2.0])
    f_hz = np.linspace(0.5, 6.0, 23)  # uneven: one line moved
    f_hz[5] += 0.07
    sets = [_nodes([1, 2, 3])]
    for ref in refs:
        sim = simulate(truth, 2 * np.pi * f_hz, {f"{ref}:x": 1.0}, response=[f"{response}:x"])
        sets.append(_frf(response, 1, ref, 1, sim.response[:, 0], f_hz))
    return _write(tmp_path / "rove.uff", sets), truth, start


def test_roving_hammer_set_updates_with_one_block_per_excitation(tmp_path):
    path, truth, start = _roving_hammer(tmp_path)
    td = read_uff(path, model=start)
    assert td.n_frf_sets == 3 and [tuple(s.force) for s in td.frf_sets] == [("1:x",), ("2:x",), ("3:x",)]
    res = frf_update(start, td)
    assert res.success and len(res.blocks) == 3
    assert [b["label"] for b in res.blocks] == ["frf excitation 1:x", "frf excitation 2:x", "frf excitation 3:x"]
    assert set(res.frac) == {"3:x (excitation 1:x)", "3:x (excitation 2:x)", "3:x (excitation 3:x)"}
    for name, v in zip(start.parameter_names, truth.resolve(None)):
        assert res.parameters[name] == pytest.approx(v, rel=1e-4)
    same = update(start, td)
    assert same.parameters == pytest.approx(res.parameters, rel=1e-10)


CHAIN_TOML = "\n".join(
    ['[model]', 'name = "chain"']
    + [f"[parameters.k{i}]\nvalue = 600.0\nbounds = [100.0, 2000.0]" for i in (1, 2, 3)]
    + ['[[element]]\ntype = "spring"\ndofs = ["1:x"]\nk = "k1"',
       '[[element]]\ntype = "spring"\ndofs = ["1:x", "2:x"]\nk = "k2"',
       '[[element]]\ntype = "spring"\ndofs = ["2:x", "3:x"]\nk = "k3"']
    + [f'[[element]]\ntype = "mass"\ndofs = ["{i}:x"]\nm = {m}' for i, m in ((1, 1.0), (2, 1.5), (3, 2.0))])


def test_several_references_on_the_command_line(tmp_path, capsys):
    path, truth, start = _roving_hammer(tmp_path, refs=(1, 3))
    toml = tmp_path / "chain.toml"
    toml.write_text(CHAIN_TOML)
    out = tmp_path / "r.json"
    code, _, err = run(["frf-update", str(toml), str(path), "--json", str(out)], capsys)
    assert code == 0, err
    got = json.loads(out.read_text())
    assert len(got["blocks"]) == 2 and any("2 excitation dofs" in n for n in got["notes"])
    for name, v in zip(start.parameter_names, truth.resolve(None)):
        assert got["parameters"][name] == pytest.approx(v, rel=1e-4)
    code, _, err = run(["frf-update", str(toml), str(path), "--global", "dual_annealing"], capsys)
    assert code == 2 and "2 FRF sets" in err and "split the file" in err, err
    # reciprocity, when asked for: the roving-hammer set becomes one set excited at the response dof
    code, _, err = run(["update", str(toml), str(path), "--reciprocity", "--json", str(out)], capsys)
    assert code == 0, err
    rec = json.loads(out.read_text())
    assert "blocks" not in rec and set(rec["frac"]) == {"1:x", "3:x"}
    assert any(n.startswith("reciprocity: 2 FRF set(s)") for n in rec["notes"])
    assert rec["parameters"] == pytest.approx(got["parameters"], rel=1e-6)


def test_reciprocity_regroups_by_response_dof(tmp_path):
    from femupdate.testdata import reciprocal

    path, truth, start = _roving_hammer(tmp_path)
    td = reciprocal(read_uff(path, model=start))
    assert td.n_frf_sets == 1 and dict(td.frf.force) == {"3:x": 1.0} and td.frf.dofs == ("1:x", "2:x", "3:x")
    direct = simulate(truth, td.frf.omega, {"3:x": 1.0})  # the responses to a force at 3:x
    np.testing.assert_allclose(td.frf.response.real, direct.response, rtol=1e-9)
    res = frf_update(start, td)
    for name, v in zip(start.parameter_names, truth.resolve(None)):
        assert res.parameters[name] == pytest.approx(v, rel=1e-4)
    with pytest.raises(InputError, match=r"reciprocity: the test data hold no FRFs"):
        reciprocal(read_uff(_write(tmp_path / "m.uff", [_mode([1], [[1.0, 0, 0]], 1.0, 1)])))
