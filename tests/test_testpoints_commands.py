"""Test points on a mesh beyond ``update`` and ``correlate``: the shapes drawn and written on the
mesh's own dofs (u = T q, so the mesh dofs a test point replaced are not drawn at zero), checked
against the untransformed model's modes; ``--test-points`` on ``damage``, ``posterior``, ``direct``
and ``frf-update`` with the pyuff-written block of tests/test_testpoints.py (FRFs at the test
points computed independently as C (K - ω²M)⁻¹ Cᵀ with SciPy's sparse solver)."""

from __future__ import annotations

import json

import numpy as np
import pytest
import scipy.sparse.linalg as sla

from femupdate.modal import model_modes
from femupdate.testpoints import map_test_data

pyuff = pytest.importorskip("pyuff")
pytest.importorskip("meshio")

from test_testpoints import TEST_POINTS, TRUTH, _block, _block_toml, _rotation, _uff, block_case  # noqa: E402,F401


def _aligned(ref, u):
    return ref * np.sign(ref @ u)


# ------------------------------------------------------------------ shapes on the mesh's own dofs
def test_report_draws_the_shapes_on_every_mesh_dof(block_case, monkeypatch):
    """Fails when the transformed model's shapes are drawn: its dofs lack the masters (drawn at zero)."""
    import femupdate.plot.report as figs
    import femupdate.plot.testpoints as tp_figs
    from femupdate.report import build_report
    from femupdate.updating import update

    s, data, truth, mm, mt = block_case
    res = update(mt.model, mt.data)
    drawn = []
    monkeypatch.setattr(figs, "mode_shape_figure",
                        lambda model, shape, *a, **k: drawn.append((model, np.array(shape))) or {"svg": "<svg></svg>"})
    monkeypatch.setattr(tp_figs, "test_points_figure", lambda *a, **k: {"svg": "<svg></svg>"})  # drawn elsewhere
    html = build_report(res, test_points=mt)
    base = s.build()
    ref = model_modes(base, res.parameters)  # the untransformed model at the same (updated) values
    masters = [d for d in base.dofs if d not in mt.model.dofs]
    assert len(masters) == 21  # 7 test nodes inside elements, 3 directions each
    idx = [base.dofs.index(d) for d in masters]
    assert len(drawn) == len(res.pairs) == 4
    for (model, u), (_, j, _) in zip(drawn, res.pairs):
        assert tuple(model.dofs) == tuple(base.dofs)
        phi = _aligned(ref.shapes[:, j], u)
        tol = 1e-10 * np.abs(phi).max()
        assert np.abs(phi[idx]).max() > 100 * tol  # the masters move: a dent would show
        np.testing.assert_allclose(u[idx], phi[idx], rtol=0, atol=tol)
        np.testing.assert_allclose(u, phi, rtol=0, atol=tol)
    assert "shapes are drawn on every mesh dof (u = T q)" in html
    assert "Test points on the mesh" in html and "T5:y" in html  # the map, though the result object lacks it


def test_shapes_written_on_the_mesh_at_the_truth(block_case):
    s, data, truth, mm, _ = block_case
    tm = map_test_data(s, data, 1e-6, model=truth)
    q = model_modes(tm.model, n_modes=4)
    new = [d for d in tm.model.dofs if d not in truth.dofs]
    assert new and all(d.startswith("T") for d in new)
    for r in range(4):
        shape = dict(zip(tm.model.dofs, q.shapes[:, r]))
        out = tm.mesh_shape_json(shape)
        assert list(out) == [*truth.dofs, *new]
        u = np.array([out[d] for d in truth.dofs])
        phi = _aligned(mm.shapes[:, r], u)
        np.testing.assert_allclose(u, phi, rtol=0, atol=1e-10 * np.abs(phi).max())
        assert [out[d] for d in new] == [shape[d] for d in new]  # the observed combinations C φ
    np.testing.assert_allclose(tm.mesh_shapes(q.shapes)[:, 0], tm.T @ q.shapes[:, 0], rtol=0, atol=0)


def test_update_dynamic_expanded_shapes_on_the_mesh(tmp_path, capsys):
    from femupdate import schema
    from test_cli import run

    path, truth, mm = _uff(tmp_path, n_modes=3)
    model = _block_toml(tmp_path)
    code, out, err = run(["update", str(model), str(path), "--test-points", "1e-6", "--formulation", "dynamic",
                          "--json", str(tmp_path / "u.json")], capsys)
    assert code == 0, out + err
    res = json.loads((tmp_path / "u.json").read_text())
    schema.check(res, "update")
    for k, (t, j, _) in enumerate(res["pairs"]):
        sh = res["expanded_shapes"][k]
        assert [d for d in sh if not d.startswith("T")] == list(truth.dofs)  # every mesh dof, masters included
        u = np.array([sh[d] for d in truth.dofs])
        phi = mm.shapes[:, j]
        u = u * (phi @ u) / (u @ u)  # the expansion's own scale
        # the universal file holds 6 significant digits
        np.testing.assert_allclose(u, phi, rtol=0, atol=1e-4 * np.abs(phi).max())


# ------------------------------------------------------------------ the other commands
def test_damage_with_test_points(tmp_path, capsys):
    from femupdate import schema
    from test_cli import run

    path, truth, mm = _uff(tmp_path)
    model = _block_toml(tmp_path)
    base = ["damage", str(model), str(path), "--test-points", "1e-6", "--set", "E_root=1.25,E_tip=1.0",
            "--unknowns", "parameters", "--bootstrap", "0", "--baseline-checked"]
    code, out, err = run([*base, "--json", str(tmp_path / "d.json")], capsys)
    assert code == 0, out + err
    assert "test points: 8 placed on the mesh" in out
    res = json.loads((tmp_path / "d.json").read_text())
    schema.check(res, "damage")
    assert res["located"] == ["E_tip"]
    assert res["changes"]["E_tip"] == pytest.approx(0.85 - 1.0, abs=1e-3)
    assert res["test_points"]["points"][4]["dofs"]["y"] == "T5:y"
    # undamaged data measured where the damaged data are not: refused by name
    for k, (points, why) in enumerate([
            (np.vstack([TEST_POINTS, [0.2, 0.1, 0.05]]), "test dof(s) 9:x, 9:y, 9:z are not measured in the first"),
            (np.vstack([TEST_POINTS[:1], [0.2, 0.1, 0.05], TEST_POINTS[2:]]),
             "test node 2 lies 0.111 from where the first test file puts it")]):
        (tmp_path / str(k)).mkdir()
        other, *_ = _uff(tmp_path / str(k), points=points)
        code, out, err = run([*base, "--undamaged", str(other)], capsys)
        assert code == 2 and why in out + err and "Traceback" not in err


def test_posterior_with_test_points(tmp_path, capsys):
    from femupdate import schema
    from test_cli import run

    path, truth, mm = _uff(tmp_path)
    model = _block_toml(tmp_path)
    code, out, err = run(["posterior", str(model), str(path), str(path), "--test-points", "1e-6", "--starts", "1",
                          "--json", str(tmp_path / "p.json")], capsys)
    assert code == 0, out + err
    res = json.loads((tmp_path / "p.json").read_text())
    schema.check(res, "posterior")
    for k, v in TRUTH.items():
        assert res["parameters"][k] == pytest.approx(v, rel=2e-5)  # 6-digit universal file
    assert res["data_sets"] == 2 and len(res["test_points"]["points"]) == 8


def test_direct_with_test_points(tmp_path, capsys):
    """Every mesh node measured but one, whose motion a point inside one of its elements gives."""
    from femupdate import schema
    from test_cli import run

    s, axes, idx = _block(tmp_path)
    free = np.array([s.nodes[i + 1] for i in idx[1:].ravel()])
    gone = idx[3, 1, 1] + 1  # an interior node
    points = np.vstack([[x for x in free if not np.allclose(x, s.nodes[gone])], [[0.27, 0.13, 0.06]]])
    path, truth, mm = _uff(tmp_path, n_modes=4, points=points)
    model = _block_toml(tmp_path)
    code, out, err = run(["direct", str(model), str(path), "--test-points", "1e-6", "--json", str(tmp_path / "d.json"),
                          "--uff", str(tmp_path / "m.uff")], capsys)
    assert code == 0, out + err
    assert "1 inside elements" in out
    res = json.loads((tmp_path / "d.json").read_text())
    schema.check(res, "direct")
    for k, v in TRUTH.items():
        assert res["parameters"][k] == pytest.approx(v, rel=1e-4)  # 6-digit universal file
    assert res["test_points"]["points"][-1]["dofs"]["x"] == f"T{len(points)}:x"
    from femupdate.io.uff import read_uff

    written = read_uff(tmp_path / "m.uff")  # the identified modes on the mesh's own nodes, u = T q
    for r in range(4):
        w = written.modes[r]
        assert {f"{gone}:x", f"{gone}:y", f"{gone}:z"} <= set(w.dofs)
        phi = mm.shapes[[truth.dofs.index(d) for d in w.dofs], r]
        w_scaled = w.shape * (phi @ w.shape) / (w.shape @ w.shape)
        # the identified values (to 1e-4) and 6 digits of the file: the truth's shape, the replaced node too
        np.testing.assert_allclose(w_scaled, phi, rtol=0, atol=1e-3 * np.abs(phi).max())


def test_frf_update_with_test_points(tmp_path, capsys):
    """Receptances at test points inside elements along a skewed axis (the z of the test's rotated system,
    kept along it: refused by every other reading), the force at one of them: C (K - ω²M)⁻¹ Cᵀ."""
    from femupdate import schema
    from test_cli import run

    s, *_ = _block(tmp_path, TRUTH)
    truth = s.build()
    pts = np.array([[0.41, 0.0, 0.033], [0.55, 0.031, 0.1], [0.48, 0.13, 0.1]])
    R = _rotation(0.4, -0.3, 0.7).T
    origin = np.array([0.1, -0.2, 0.05])
    mt = map_test_data(s, _pointdata(pts), 1e-6, model=truth)
    C = np.zeros((len(pts), truth.n_dofs))  # along the system's z (R[2]) at each point, by the shape functions
    for k, lk in enumerate(mt.map.links):
        for n, w in zip(lk.mesh_nodes, lk.weights):
            for g, c in zip("xyz", R[2]):
                if f"{n}:{g}" in truth.dofs:
                    C[k, truth.dofs.index(f"{n}:{g}")] += c * w
    f_hz = np.sqrt(model_modes(truth, n_modes=3).eigenvalues) / (2 * np.pi)
    lines = np.concatenate([np.linspace(0.3, 0.8, 3) * f_hz[0], [0.5 * (f_hz[0] + f_hz[1])]])
    K, M = truth.K(), truth.M()
    H = np.array([C @ sla.spsolve((K - (2 * np.pi * f) ** 2 * M).tocsc(), C[1]) for f in lines])
    ids = np.arange(1, len(pts) + 1)
    loc = (pts - origin) @ R.T
    sets = [pyuff.prepare_2420(Part_UID=1, Part_Name="test", CS_sys_labels=[5], CS_types=[0], CS_colors=[8],
                               CS_names=["SKEW"], CS_matrices=[np.vstack([R, origin])]),
            pyuff.prepare_2411(node_nums=ids, def_cs=np.full(len(ids), 5), disp_cs=np.full(len(ids), 5),
                               color=np.ones(len(ids), int), x=loc[:, 0].copy(), y=loc[:, 1].copy(), z=loc[:, 2].copy())]
    for k in range(len(pts)):
        sets.append(pyuff.prepare_58(binary=0, func_type=4, rsp_node=k + 1, rsp_dir=3, ref_node=2, ref_dir=3,
                                     abscissa_spacing=0, abscissa_spec_data_type=18, ordinate_spec_data_type=8,
                                     orddenom_spec_data_type=13, data=H[:, k].astype(complex), x=lines))
    path = tmp_path / "frf.uff"
    pyuff.UFF(str(path)).write_sets(sets, mode="overwrite")
    from femupdate._errors import InputError
    from femupdate.io.uff import read_uff

    with pytest.raises(InputError, match="direction z of coordinate system 5 .* does not lie along one of the model"):
        read_uff(path)
    model = _block_toml(tmp_path)
    code, out, err = run(["frf-update", str(model), str(path), "--test-points", "1e-6", "--json",
                          str(tmp_path / "f.json")], capsys)
    assert code == 0, out + err
    res = json.loads((tmp_path / "f.json").read_text())
    schema.check(res, "frf-update")
    for k, v in TRUTH.items():
        assert res["parameters"][k] == pytest.approx(v, rel=1e-4)  # 6-digit universal file
    points = res["test_points"]["points"]
    assert [p["dofs"] for p in points] == [{"z": "T1:z"}, {"z": "T2:z"}, {"z": "T3:z"}]
    assert all(np.allclose(p["axes"], R, atol=1e-9) for p in points)


def _pointdata(pts):
    from femupdate.testdata import MeasuredMode, TestData

    labels = [f"{k + 1}:z" for k in range(len(pts))]
    return TestData(modes=(MeasuredMode(1.0, labels, np.ones(len(labels))),),
                    nodes={k + 1: tuple(p) for k, p in enumerate(pts)})


# ------------------------------------------------------------------ a single component along a skewed axis
def _skewed_uff(tmp_path, single=4):
    """As tests/test_testpoints.py's file, test node ``single + 1`` measuring only its local y (a
    skewed axis: x and z written as zeros in every mode, the padding the reader drops)."""
    from test_testpoints import _truth_at_points

    truth, mm, values = _truth_at_points(tmp_path)
    R = _rotation(0.4, -0.3, 0.7).T
    origin = np.array([0.1, -0.2, 0.05])
    ids = np.arange(1, len(TEST_POINTS) + 1)
    loc_xyz = (TEST_POINTS - origin) @ R.T
    sets = [pyuff.prepare_2420(Part_UID=1, Part_Name="test", CS_sys_labels=[5], CS_types=[0], CS_colors=[8],
                               CS_names=["SKEW"], CS_matrices=[np.vstack([R, origin])]),
            pyuff.prepare_2411(node_nums=ids, def_cs=np.full(len(ids), 5), disp_cs=np.full(len(ids), 5),
                               color=np.ones(len(ids), int), x=loc_xyz[:, 0].copy(), y=loc_xyz[:, 1].copy(),
                               z=loc_xyz[:, 2].copy())]
    for r, g in enumerate(values):
        loc = g @ R.T
        loc[single, [0, 2]] = 0.0
        sets.append(pyuff.prepare_55(model_type=1, analysis_type=2, data_ch=2, spec_data_type=8, data_type=2,
                                     n_data_per_node=3, node_nums=ids, load_case=1, mode_n=r + 1,
                                     freq=float(mm.frequencies_hz[r]), modal_m=0.0, modal_damp_vis=0.0,
                                     modal_damp_his=0.0, r1=loc[:, 0].copy(), r2=loc[:, 1].copy(), r3=loc[:, 2].copy()))
    path = tmp_path / "skew.uff"
    pyuff.UFF(str(path)).write_sets(sets, mode="overwrite")
    return path, truth, mm, R, values


def test_single_component_along_a_skewed_axis(tmp_path, capsys):
    from femupdate import schema
    from femupdate._errors import InputError
    from femupdate.io.uff import read_uff
    from test_cli import run

    path, truth, mm, R, values = _skewed_uff(tmp_path)
    with pytest.raises(InputError, match=r"node 5: the measured component\(s\) y along the axes of coordinate system 5"):
        read_uff(path)  # into the global axes, as every other command reads it
    axes: dict = {}
    data = read_uff(path, keep_local=axes)
    assert list(axes) == [5] and np.allclose(axes[5], R, atol=1e-9)
    assert [d for d in data.modes[0].dofs if d.startswith("5:")] == ["5:y"]  # along the system's y
    assert any("node(s) 5: measured components kept along" in n for n in data.notes)
    s, *_ = _block(tmp_path)
    mt = map_test_data(s, data, 1e-6, model=truth, axes=axes)
    assert mt.rename["5:y"] == "T5:y"
    q = model_modes(mt.model, n_modes=4)
    k = mt.model.dofs.index("T5:y")
    u = mt.mesh_shapes(q.shapes)
    for r in range(4):  # the new dof: the truth's motion at the point (SciPy's trilinear) along the skewed y, R[1]·u(p)
        sign = np.sign(u[:, r] @ mm.shapes[:, r])
        np.testing.assert_allclose(sign * q.shapes[k, r], R[1] @ values[r][4], rtol=0,
                                   atol=1e-10 * np.abs(values[r]).max())
    for r, m in enumerate(mt.data.modes):
        sh = q.shapes[[mt.model.dofs.index(d) for d in m.dofs], r]
        assert abs(sh @ m.shape) / (np.linalg.norm(sh) * np.linalg.norm(m.shape)) == pytest.approx(1.0, abs=1e-9)
    model = _block_toml(tmp_path)
    code, out, err = run(["update", str(model), str(path), "--test-points", "1e-6", "--json", str(tmp_path / "u.json")],
                         capsys)
    assert code == 0, out + err
    res = json.loads((tmp_path / "u.json").read_text())
    schema.check(res, "update")
    for name, v in TRUTH.items():
        assert res["parameters"][name] == pytest.approx(v, rel=2e-5)  # 6-digit universal file
    point = res["test_points"]["points"][4]
    assert point["dofs"] == {"y": "T5:y"} and np.allclose(point["axes"], R, atol=1e-9)
