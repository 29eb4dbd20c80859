"""Issue 28's "done when": a plate (Gmsh), a shell structure (Abaqus) and a solid part (Nastran) go
through ``modes``, ``update`` (thickness and modulus by set), ``damage``, ``posterior`` and
``report`` from the command line (femupdate.mesh.examples writes the files and the noise-free
test data; docs/meshes-end-to-end.md walks the box).

The bracket runs always (and the box on the documentation page); the plate and the box here behind
the heavy switch.  Each check can fail:
the frequencies of ``modes`` against a dense LAPACK solution of the same K and M, the update
against the values the data were simulated at (the start is 5-10 % away), the located set and
its loss against the damage simulated, the Laplace posterior's mode against the truth and its
standard deviations against the update's (stated noise: the same Gauss-Newton covariance by a
second command), the report's shapes drawn on the mesh's element edges (counted from the mesh).
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pytest
import scipy.linalg as la

sys.path.insert(0, str(Path(__file__).resolve().parent))
from conftest import HEAVY, heavy  # noqa: E402

pytest.importorskip("meshio")

from femupdate.io.model_file import load_model  # noqa: E402
from femupdate.mesh.examples import DAMAGE, N_MODES, TRUTH, write_example  # noqa: E402

#: mesh edges of each example, counted by hand: plate 13 x 8 + 12 x 9; box: lid 9 x 6 + 8 x 7 plus one diagonal
#: per lid square (48), walls 28 x 4 vertical + 28 x 4 horizontal (the base ring and three more; the top ring is
#: the lid's edge); bracket: edges of its hexahedra (counted in the test from the connectivity)
EDGES = {"plate": 13 * 8 + 12 * 9, "box": 9 * 6 + 8 * 7 + 48 + 28 * 4 + 28 * 4}


def cli(args, cwd: Path) -> int:
    """``femupdate ARGS`` in this process (PYTHONPATH's femupdate), in ``cwd``; the exit code."""
    import os

    from femupdate.cli import main

    old = os.getcwd()
    os.chdir(cwd)
    try:
        main([str(a) for a in args])
    except SystemExit as exc:
        return int(exc.code or 0)
    finally:
        os.chdir(old)
    return 0


def _bracket_edges() -> int:
    from femupdate.mesh.examples import _bracket_mesh

    _, hexes, _, _ = _bracket_mesh()
    e = {tuple(sorted((h[a], h[b]))) for h in hexes
         for a, b in ((0, 1), (1, 2), (2, 3), (3, 0), (4, 5), (5, 6), (6, 7), (7, 4), (0, 4), (1, 5), (2, 6), (3, 7))}
    return len(e)


def run_example(name: str, folder: Path, capsys) -> None:
    path = write_example(name, folder)
    model = load_model(path)
    truth, n = TRUTH[name], N_MODES[name]
    # modes: the sparse solution of the command against a dense LAPACK one of the same matrices
    assert cli(["modes", path.name, "--n-modes", n, "--json", "m.json"], folder) == 0
    f = np.array(json.loads((folder / "m.json").read_text())["frequencies_hz"])
    K, M = model.K().toarray(), model.M().toarray()
    V = la.eigh(K, M, subset_by_index=[0, n - 1])[1]
    # the Rayleigh quotients of LAPACK's vectors: its eigenvalues themselves carry eps x cond(M) (~1e7 with
    # a shell's rotary inertia), its vectors' quotients are second-order accurate
    lam = np.einsum("ij,ij->j", V, K @ V) / np.einsum("ij,ij->j", V, M @ V)
    assert np.allclose(f, np.sqrt(lam) / (2 * np.pi), rtol=1e-8, atol=0), (f, np.sqrt(lam) / (2 * np.pi))
    # update: thickness and moduli by set, from 5-10 % away, to the values the data were simulated at
    start = model.values
    assert min(abs(start[model.parameter_index(k)] / v - 1) for k, v in truth.items()) > 0.04
    assert cli(["update", path.name, "test.json", "--json", "u.json"], folder) == 0
    u = json.loads((folder / "u.json").read_text())
    for k, v in truth.items():
        assert abs(u["parameters"][k] / v - 1) < 1e-7, (k, u["parameters"][k], v)
    # damage: the baseline at the updated values, the damaged data located and the loss recovered
    values = ",".join(f"{k}={u['parameters'][k]!r}" for k in truth)
    code = cli(["damage", path.name, "damaged.json", "--undamaged", "test.json", "--set", values, "--bootstrap", 0,
                "--json", "d.json"], folder)
    d = json.loads((folder / "d.json").read_text())
    assert code == 0, capsys.readouterr()
    (hit, factor), = DAMAGE[name].items()
    assert d["located"] == [hit], d["located"]
    assert abs(d["changes"][hit] - (factor - 1)) < 1e-4, d["changes"]
    assert all(abs(c) < 1e-4 for k, c in d["changes"].items() if k != hit), d["changes"]
    # posterior: the Laplace mode at the truth; its std (stated noise) as the update's
    assert cli(["posterior", path.name, "test.json", "--method", "laplace", "--starts", 1, "--json", "p.json"], folder) == 0
    p = json.loads((folder / "p.json").read_text())
    sol = p["solutions"][0]
    for k, v in truth.items():
        assert abs(sol["parameters"][k] / v - 1) < 1e-7, (k, sol["parameters"][k])
        assert abs(sol["std"][k] / u["diagnostics"]["std"][k] - 1) < 0.02, (k, sol["std"][k], u["diagnostics"]["std"][k])
    # report: the HTML, its shapes drawn on the mesh's element edges
    assert cli(["report", "u.json", "--model", path.name, "--data", "test.json", "-o", "u.html"], folder) == 0
    html = (folder / "u.html").read_text()
    assert "Mode shapes on the model" in html and "drawn against the dofs in model order" not in html
    from femupdate.cli._common import model_segments
    from femupdate.plot.shapes import shape_geometry

    geom = shape_geometry(model, model_segments(path))
    assert geom is not None and len(geom.segments) == (EDGES[name] if name in EDGES else _bracket_edges())
    capsys.readouterr()


def test_bracket_from_nastran_end_to_end(tmp_path, capsys):
    """The quickest of the three always runs (the box, thickness parameter and all, runs always on
    docs/meshes-end-to-end.md too)."""
    run_example("bracket", tmp_path, capsys)


@heavy
@pytest.mark.parametrize("name", ["plate", "box"])
def test_plate_from_gmsh_and_shell_box_from_abaqus_end_to_end(name, tmp_path, capsys):
    run_example(name, tmp_path, capsys)


def test_thickness_of_a_mesh_set_is_a_parameter(tmp_path):
    """``t = "t_lid"`` in ``[mesh.sets.LID]``: bending ∝ t³, membrane and shear ∝ t, mass ∝ t (the model's
    terms); the frequencies at t and the derivative by central differences agree with dK/dt."""
    path = write_example("box", tmp_path, data=False)
    model = load_model(path)
    assert not model.is_affine
    j = model.parameter_index("t_lid")
    t0 = model.values[j]
    h = 1e-6 * t0
    up, dn = model.values.copy(), model.values.copy()
    up[j] += h
    dn[j] -= h
    fd = (model.K(up) - model.K(dn)) / (2 * h)
    exact = model.dK_dp(j)
    assert abs(fd - exact).max() <= 1e-6 * abs(exact).max()
    assert abs(model.M(up) - model.M(dn)).max() > 0  # the lid's mass goes with its thickness
    bad = path.read_text().replace('t = "t_lid"', 't = "t_nowhere"')
    path.write_text(bad)
    from femupdate._errors import InputError

    with pytest.raises(InputError, match="t_nowhere"):
        load_model(path)


def _figure_faces(name, tmp_path):
    """The shaded polygons of the first mode's figure of example ``name`` (as the report draws it)."""
    import matplotlib.pyplot as plt
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    from femupdate.cli._common import model_segments
    from femupdate.modal import model_modes
    from femupdate.plot.shapes import mode_shape_axes

    path = write_example(name, tmp_path, data=False)
    model = load_model(path)
    ax = mode_shape_axes(model, model_modes(model, n_modes=1).shapes[:, 0], segments=model_segments(path))
    ax.figure.canvas.draw()  # a 3-D collection projects its polygons when drawn
    polys = [c for c in ax.collections if isinstance(c, Poly3DCollection)]
    plt.close(ax.figure)
    assert len(polys) == 1
    return polys[0]


def test_shapes_drawn_as_surfaces_on_the_mesh(tmp_path):
    """The box: one shaded polygon per shell (96 triangles, 112 quadrilaterals); the bracket: its outer
    surface, whose area is the L-section's two faces and its perimeter times the depth."""
    box = _figure_faces("box", tmp_path / "box")
    assert len(box.get_paths()) == 96 + 112
    from femupdate.fullfield import structure_segments
    from femupdate.io.model_file import read_toml
    from femupdate.structure import Structure

    path = write_example("bracket", tmp_path / "bracket", data=False)
    faces = structure_segments(Structure.from_dict(read_toml(path), source=str(path))).faces
    model = load_model(path)
    area = 0.0
    for f in faces:
        x = np.array([model.nodes[n] for n in f])
        area += 0.5 * np.linalg.norm(sum(np.cross(x[i], x[(i + 1) % len(x)]) for i in range(len(x))))
    section = 0.12 * 0.0125 + 0.012 * (0.10 - 0.0125)  # the L: base 120 x 12.5 mm, upright 12 x 87.5 mm
    assert abs(area - (2 * section + 2 * (0.12 + 0.10) * 0.04)) < 1e-12
    assert len(_figure_faces("bracket", tmp_path / "b2").get_paths()) == len(faces)


def test_damage_equations_of_a_thickness_model_are_exact_in_the_moduli(tmp_path):
    """The box (t_lid enters as t and t³): the localisation's equations, formed with the tangent
    stiffness at the baseline, hold exactly for the damaged box's complete noise-free modes with the
    true loss (K is affine in the moduli with the thickness held); the thickness itself, entering M,
    is refused as an unknown by name with what to do."""
    from femupdate._errors import InputError
    from femupdate.damage.examples import noisy_modes
    from femupdate.damage.localise import Equations, measured_shapes

    path = write_example("box", tmp_path, data=False)  # the lid's modulus a parameter too: E_lid t_lid³ a term
    path.write_text(path.read_text().replace('t = "t_lid"', 't = "t_lid"\nE = "E_lid"')
                    + '\n[parameters.E_lid]\nvalue = 200.0e9\n')
    truth = {**TRUTH["box"], "E_lid": 205e9}
    model = load_model(path)  # nominal t_lid 2 mm; the baseline 2.2 mm: the tangent must be taken there
    theta0 = model.resolve(truth)
    assert any("E_lid" in t.parameters and "t_lid" in t.parameters for t in model.terms)
    names = ["E_lid", "E_walls_x", "E_walls_y"]
    for hit in ("E_lid", "E_walls_y"):
        meas = measured_shapes(noisy_modes(model, list(model.dofs), 4, {**truth, hit: truth[hit] * 0.85}))
        eq = Equations(model, names, theta0)
        A, r = eq.build(meas.eigenvalues, meas.shapes)
        assert np.linalg.norm(r) > 1e-3
        delta = np.array([-0.15 if n == hit else 0.0 for n in names])
        assert np.linalg.norm(A @ delta - r) < 1e-8 * np.linalg.norm(r), hit
    with pytest.raises(InputError, match="t_lid enters the mass matrix too .*leave them out of the unknowns"):
        Equations(model, ["t_lid", "E_walls_y"], theta0)


assert HEAVY in (True, False)
