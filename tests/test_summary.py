"""``femupdate summary`` (femupdate.summary): total mass against the closed forms ρ·a·b·t of a plate
and ρ·a·b·c of a block, the rigid-body mass rᵀ M r against the sum over element types, the shares of
the stiffness adding up to 1 and the strain-energy share equal to the relative eigenvalue
sensitivity by finite differences; the command line's text and JSON; bad input exits 2."""

from __future__ import annotations

import json

import numpy as np
import pytest

from femupdate import schema
from femupdate.io.model_file import load_model
from femupdate.modal import model_modes
from femupdate.structure import Structure
from femupdate.summary import model_summary, stiffness_shares
from test_cli import run

meshio = pytest.importorskip("meshio")

A, B, T, RHO = 1.2, 0.8, 0.02, 7.5


def _plate_file(tmp_path, support=""):
    """A free a x b plate of 6 x 4 quadrilaterals in two sets (left, right), written by meshio as Gmsh."""
    x, y = np.meshgrid(np.linspace(0, A, 7), np.linspace(0, B, 5), indexing="ij")
    pts = np.column_stack([x.ravel(), y.ravel(), np.zeros(x.size)])
    idx = np.arange(x.size).reshape(x.shape)
    quads = np.array([[idx[i, j], idx[i + 1, j], idx[i + 1, j + 1], idx[i, j + 1]] for i in range(6) for j in range(4)])
    left = quads[:12]  # i < 3
    right = quads[12:]
    m = meshio.Mesh(pts, [("quad", left), ("quad", right)],
                    cell_data={"gmsh:physical": [np.full(12, 1), np.full(12, 2)],
                               "gmsh:geometrical": [np.ones(12, int), np.ones(12, int)]},
                    field_data={"left": np.array([1, 2]), "right": np.array([2, 2])})
    meshio.write(tmp_path / "plate.msh", m, file_format="gmsh22", binary=False)
    sets = "".join(f'[mesh.sets.{k}]\nE = "E_{k}"\nnu = 0.3\nrho = {RHO}\nt = {T}\n\n' for k in ("left", "right"))
    (tmp_path / "plate.toml").write_text('[parameters.E_left]\nvalue = 2.0\n\n[parameters.E_right]\nvalue = 1.5\n\n'
                                         f'[mesh]\nfile = "plate.msh"\n\n{sets}{support}')
    return tmp_path / "plate.toml"


def test_command_line_text_json_and_bad_input(tmp_path, capsys):
    path = _plate_file(tmp_path)
    code, out, err = run(["summary", str(path), "--set", "E_right=3", "--json", str(tmp_path / "s.json")], capsys)
    assert code == 0, err
    assert "210 free dofs" in out and "24 mitc4" in out and "left (12 elements)" in out and "E_right" in out
    js = json.loads((tmp_path / "s.json").read_text())
    schema.check(js, "summary")  # the keys and types docs/file-formats.md describes
    assert js["parameters"][1] == {"name": "E_right", "value": 3.0, "unit": "Pa", "bounds": [None, None],
                                   "fixed": False, "enters": ["K"]}
    assert js["mass"]["total"]["z"] == pytest.approx(RHO * A * B * T, rel=1e-12)
    assert len(js["stiffness_shares"]["modes"]) == 3 and js["stiffness_shares"]["modes"][0] == 7  # 6 rigid modes first
    code, out, err = run(["summary", str(tmp_path / "none.toml")], capsys)
    assert code == 2 and "none.toml" in out + err and "Traceback" not in err
    code, out, err = run(["summary", str(path), "--set", "E_top=1"], capsys)
    assert code == 2 and "E_top" in out + err
    code, out, err = run(["summary", str(path), "--n-modes", "0"], capsys)
    assert code == 2 and "--n-modes" in out + err


def _structure(path):
    from femupdate.cli.summary import _structure_of

    return _structure_of(path)


def test_plate_mass_against_closed_form(tmp_path):
    path = _plate_file(tmp_path)
    model = load_model(path)
    s = model_summary(model, _structure(path))
    for d in "xyz":
        assert s["mass"]["free"][d] == pytest.approx(RHO * A * B * T, rel=1e-12)
        assert s["mass"]["total"][d] == pytest.approx(RHO * A * B * T, rel=1e-12)
    assert s["elements"] == {"mitc4": 24} and s["sets"] == {"left": 12, "right": 12}
    assert s["dofs_by_direction"] == dict.fromkeys(("x", "y", "z", "rx", "ry", "rz"), 35)


def _block():
    x = np.stack(np.meshgrid(np.linspace(0, 0.6, 4), np.linspace(0, 0.2, 3), np.linspace(0, 0.1, 2), indexing="ij"), -1)
    idx = np.arange(x[..., 0].size).reshape(x.shape[:3])
    hexes = np.array([[idx[i, j, k], idx[i + 1, j, k], idx[i + 1, j + 1, k], idx[i, j + 1, k], idx[i, j, k + 1],
                       idx[i + 1, j, k + 1], idx[i + 1, j + 1, k + 1], idx[i, j + 1, k + 1]]
                      for i in range(3) for j in range(2) for k in range(1)])
    s = Structure("block")
    s.parameter("E_a", 1.0)
    s.parameter("E_b", 2.0)
    s.add_nodes(range(1, idx.size + 1), x.reshape(-1, 3))
    s.solid(hexes[:2] + 1, E="E_a", nu=0.3, rho=RHO)
    s.solid(hexes[2:] + 1, E="E_b", nu=0.3, rho=RHO)
    s.mass([f"{idx[-1, 0, 0] + 1}:x"], 0.5)  # a lumped mass along x only
    s.support_node((idx[0].ravel() + 1).tolist())
    return s, idx


def test_block_mass_free_total_and_by_type():
    s, idx = _block()
    model = s.build()
    out = model_summary(model, s)
    solid = RHO * 0.6 * 0.2 * 0.1
    m = out["mass"]
    assert m["total"]["x"] == pytest.approx(solid + 0.5, rel=1e-12)
    assert m["total"]["y"] == pytest.approx(solid, rel=1e-12) and m["total"]["z"] == pytest.approx(solid, rel=1e-12)
    assert m["by_type"]["hex8"]["y"] == pytest.approx(solid, rel=1e-12) and m["by_type"]["mass"] == {"x": 0.5}
    assert m["free"]["y"] < solid  # the clamped face's share of the mass does not move
    assert out["elements"] == {"hex8": 6, "mass": 1}


def test_shares_add_up_and_energy_share_is_the_relative_eigenvalue_sensitivity():
    s, _ = _block()
    model = s.build()
    sh = stiffness_shares(model, n_modes=3)
    assert sum(sh["trace"].values()) == pytest.approx(1.0, rel=1e-12)
    for r in range(3):
        assert sum(e[r] for e in sh["energy"].values()) == pytest.approx(1.0, rel=1e-10)
    p = model.values
    lam = model_modes(model, n_modes=3).eigenvalues
    for j, name in enumerate(model.parameter_names):
        h = 1e-4 * p[j]  # central differences: truncation ~h², round-off ~1e-12/h
        up, dn = p.copy(), p.copy()
        up[j] += h
        dn[j] -= h
        dlam = (model_modes(model, up, n_modes=3).eigenvalues - model_modes(model, dn, n_modes=3).eigenvalues) / (2 * h)
        np.testing.assert_allclose(sh["energy"][name], p[j] * dlam / lam, rtol=1e-7)
