"""Meshes in (femupdate.mesh): one plate read from Gmsh (meshed by Gmsh itself), Abaqus and
Nastran (the decks' nodes, elements and sets written by meshio in its three Nastran formats, the
cards meshio does not write added here) gives the same K and M; the simply supported plate
against Leissa; a solid block from the three formats; bad input refused naming the culprit."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import scipy.sparse.linalg as sla

import femupdate
from femupdate._errors import InputError
from femupdate.io.model_file import load_model
from femupdate.mesh import read_mesh
from femupdate.mesh.nastran import cards, real
from femupdate.structure import Structure

meshio = pytest.importorskip("meshio")

E, NU, RHO, T = 1.0, 0.3, 1.0, 0.01
SUPPORT_NAMES = ("plate", "edges_x", "edges_y")


def _initialize(gmsh) -> None:
    """``gmsh.initialize()``, then SIGPIPE ignored again: the SDK resets it to the default action, and a
    later write to a closed pipe (a process pool's worker that ended) would kill the whole test run."""
    import signal

    gmsh.initialize()
    signal.signal(signal.SIGPIPE, signal.SIG_IGN)


def _gmsh_plate(path, n):
    """A unit square plate of n x n quadrilaterals meshed by Gmsh; physical groups plate, edges_x, edges_y."""
    gmsh = pytest.importorskip("gmsh")
    _initialize(gmsh)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.model.add("plate")
        s = gmsh.model.occ.addRectangle(0, 0, 0, 1, 1)
        gmsh.model.occ.synchronize()
        ex, ey = [], []
        for _, c in gmsh.model.getEntities(1):
            gmsh.model.mesh.setTransfiniteCurve(c, n + 1)
            x0, _, _, x1, _, _ = gmsh.model.getBoundingBox(1, c)
            (ex if abs(x1 - x0) < 1e-3 else ey).append(c)
        gmsh.model.mesh.setTransfiniteSurface(s)
        gmsh.model.mesh.setRecombine(2, s)
        gmsh.model.addPhysicalGroup(2, [s], name="plate")
        gmsh.model.addPhysicalGroup(1, ex, name="edges_x")
        gmsh.model.addPhysicalGroup(1, ey, name="edges_y")
        gmsh.model.mesh.generate(2)
        gmsh.write(str(path))
    finally:
        gmsh.finalize()


def _support(mesh, by_set=True):
    """Hard simple support: membrane and drilling fixed everywhere, z and the rotation about the edge on the edges."""
    dirs = {"plate": ["x", "y", "rz"], "edges_x": ["z", "rx"], "edges_y": ["z", "ry"]}
    if by_set:
        return [{"set": k, "dofs": v} for k, v in dirs.items()]
    return [{"nodes": mesh.nsets[k].tolist(), "dofs": v} for k, v in dirs.items()]


NASTRAN_CARDS = {  # PSHELL 1 (t = 0.01) and MAT1 1 in each format
    "free": "PSHELL,1,1,0.01,1,,1\nMAT1,1,1.0,,0.3,1.0\nENDDATA\n",
    "fixed-small": "PSHELL  1       1       .01     1               1\nMAT1    1       1.0             .3      1.0\nENDDATA\n",
    "fixed-large": ("PSHELL* 1               1               1.-2            1               *\n"
                    "*                       1\n"
                    "MAT1*   1               1.0                             0.3\n*       1.0\nENDDATA\n"),
}


def _decks(tmp_path, msh):
    """The Gmsh plate as an Abaqus deck and three Nastran decks, nodes and elements written by meshio."""
    m = meshio.read(msh)
    quads = [c for c in m.cells if c.type == "quad"]
    plate = meshio.Mesh(m.points, quads, cell_data={"nastran:ref": [np.ones(len(c.data), int) for c in quads]})
    mesh = read_mesh(msh)
    out = {}
    for fmt in NASTRAN_CARDS:
        p = tmp_path / f"plate_{fmt}.bdf"
        meshio.nastran.write(p, plate, point_format=fmt, cell_format="fixed-large" if fmt == "free" else fmt)  # meshio 5.3 fails on free-field elements
        text = p.read_text().replace("ENDDATA\n", "")
        p.write_text(text + NASTRAN_CARDS[fmt])
        out[fmt] = p
    inp = tmp_path / "plate.inp"
    pm = meshio.Mesh(m.points, quads, cell_sets={"PLATE": [np.arange(len(c.data)) for c in quads]},
                     point_sets={k: mesh.nsets[k] - 1 for k in SUPPORT_NAMES})
    meshio.abaqus.write(inp, pm)
    text = inp.read_text().replace("TYPE=CAX4P", "TYPE=S4R")
    inp.write_text(text + "*MATERIAL, NAME=alu\n*ELASTIC\n1.0, 0.3\n*DENSITY\n1.0\n"
                          "*SHELL SECTION, ELSET=plate, MATERIAL=ALU\n0.01, 5\n")
    out["abaqus"] = inp
    return out


@pytest.fixture(scope="module")
def plate16(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("plate")
    msh = tmp / "plate.msh"
    _gmsh_plate(msh, 16)
    return msh, _decks(tmp, msh)


def _model(path, mesh=None, **kw):
    sets = {"plate": {"E": E, "nu": NU, "rho": RHO, "t": T}} if path.suffix == ".msh" else None
    mesh = mesh or read_mesh(path)
    return Structure.from_mesh(path, sets, _support(mesh, by_set=path.suffix != ".bdf"), **kw).build()


def test_simply_supported_plate_from_gmsh_against_leissa(plate16):
    """Gmsh's own mesh (16 x 16 MITC4, t/a = 0.01): within MITC4's 16 x 16 error of Leissa's Kirchhoff values."""
    model = _model(plate16[0])
    w = np.sort(np.sqrt(sla.eigsh(model.K(), k=3, M=model.M(), sigma=0)[0]))
    D = E * T**3 / (12 * (1 - NU**2))
    r = w / (np.pi**2 * np.array([2.0, 5.0, 5.0]) * np.sqrt(D / (RHO * T)))
    assert np.all(np.abs(r - 1) < 0.02) and abs(r[0] - 1) < 0.006, r
    assert len(model.nodes) == 17 * 17 and all(len(x) == 3 for x in model.nodes.values())


def test_same_plate_from_three_formats_same_matrices(plate16):
    msh, decks = plate16
    ref = _model(msh)
    mesh = read_mesh(msh)
    Kr, Mr = ref.K(), ref.M()
    for name, path in decks.items():
        m = _model(path, mesh)
        assert m.dofs == ref.dofs, name
        assert abs(m.K() - Kr).max() <= 1e-12 * abs(Kr).max(), name
        assert abs(m.M() - Mr).max() <= 1e-12 * abs(Mr).max(), name
        assert m.nodes == ref.nodes, name


def test_nastran_fields():
    assert real("1.-3", "f") == 1e-3 and real("-2.5+2", "f") == -250.0 and real("1.5D3", "f") == 1500.0
    with pytest.raises(InputError, match="'abc' is not a number"):
        real("abc", "f")


def _block_mesh():
    """A 2 x 1 x 1 block of 4 x 2 x 2 hexahedra (numpy), nodes 1-based."""
    g = np.stack(np.meshgrid(np.linspace(0, 2, 5), np.linspace(0, 1, 3), np.linspace(0, 1, 3), indexing="ij"), -1)
    idx = np.arange(g[..., 0].size).reshape(g.shape[:3])
    hexes = [[idx[i, j, k], idx[i + 1, j, k], idx[i + 1, j + 1, k], idx[i, j + 1, k],
              idx[i, j, k + 1], idx[i + 1, j, k + 1], idx[i + 1, j + 1, k + 1], idx[i, j + 1, k + 1]]
             for i in range(4) for j in range(2) for k in range(2)]
    return g.reshape(-1, 3), np.array(hexes)


def _tet10(pts, tets):
    """Quadratic tetrahedra from linear ones: mid-edge nodes 5 (1-2), 6 (2-3), 7 (3-1), 8 (1-4), 9 (2-4), 10 (3-4)."""
    edges = np.sort(tets[:, [[0, 1], [1, 2], [2, 0], [0, 3], [1, 3], [2, 3]]], axis=2).reshape(-1, 2)
    uniq, inv = np.unique(edges, axis=0, return_inverse=True)
    mids = 0.5 * (pts[uniq[:, 0]] + pts[uniq[:, 1]])
    return np.vstack([pts, mids]), np.hstack([tets, len(pts) + inv.reshape(-1, 6)])


@pytest.mark.parametrize("kind", ["hex", "tetra", "tetra10"])
def test_solid_block_three_formats(tmp_path, kind):
    """A clamped block (meshio writes Gmsh 2.2 and the Nastran nodes and elements): same K and M,
    equal to the Structure built from the same arrays by hand."""
    pts, hexes = _block_mesh()
    if kind.startswith("tetra"):  # each hexahedron into six tetrahedra around its 1-7 diagonal, positive volume
        tets = [[0, 1, 2, 6], [0, 2, 3, 6], [0, 3, 7, 6], [0, 7, 4, 6], [0, 4, 5, 6], [0, 5, 1, 6]]
        cells = hexes[:, tets].reshape(-1, 4)
        ctype, abq = "tetra", "C3D4"
        if kind == "tetra10":
            pts, cells = _tet10(pts, cells)
            ctype, abq = "tetra10", "C3D10"
    else:
        cells, ctype, abq = hexes, "hexahedron", "C3D8I"
    clamp = np.flatnonzero(pts[:, 0] == 0)
    m = meshio.Mesh(pts, [(ctype, cells)], cell_data={"gmsh:physical": [np.full(len(cells), 7)],
                                                      "gmsh:geometrical": [np.ones(len(cells), int)]},
                    field_data={"block": np.array([7, 3])})
    files = {}
    for fmt in ("gmsh22",):  # (4.1 as Gmsh writes it: the plate)
        files[fmt] = tmp_path / f"b_{fmt}.msh"
        meshio.write(files[fmt], m, file_format=fmt, binary=False)
    files["bdf"] = tmp_path / "b.bdf"
    meshio.nastran.write(files["bdf"], meshio.Mesh(pts, [(ctype, cells)], cell_data={"nastran:ref": [np.full(len(cells), 3)]}))
    bulk = files["bdf"].read_text().replace("ENDDATA\n", "").replace("CTETRA_", "CTETRA ")  # meshio's name for CTETRA with 10
    spc = "".join(f"SPC1,1,123,{','.join(str(c + 1) for c in clamp[k:k + 6])}\n" for k in range(0, len(clamp), 6))
    files["bdf"].write_text(bulk + "PSOLID,3,9\nMAT1,9,2.0,,0.25,3.0\n" + spc)
    inp = tmp_path / "b.inp"
    lines = [f"{i + 1}, {x:.17g}, {y:.17g}, {z:.17g}" for i, (x, y, z) in enumerate(pts)]
    els = [", ".join(map(str, [e + 1, *(c + 1)])) for e, c in enumerate(cells)]
    inp.write_text("*NODE, NSET=ALL\n" + "\n".join(lines) + f"\n*ELEMENT, TYPE={abq}, ELSET=Block\n" + "\n".join(els)
                   + "\n*NSET, NSET=clamp\n" + ",\n".join(str(c + 1) for c in clamp) + ","  # a trailing comma
                   + "\n*MATERIAL, NAME=steel\n*ELASTIC\n2.0, 0.25\n*DENSITY\n3.0\n"
                     "*SOLID SECTION, ELSET=BLOCK, MATERIAL=steel\n,\n*BOUNDARY\nclamp, ENCASTRE\n*STEP\n*FREQUENCY\n5\n*END STEP\n")
    files["inp"] = inp
    hand = Structure("hand")
    hand.add_nodes(range(1, len(pts) + 1), pts)
    hand.solid(cells + 1, E=2.0, nu=0.25, rho=3.0)
    hand.support_node((clamp + 1).tolist())
    ref = hand.build()
    for name, f in files.items():
        sets = {"block": {"E": 2.0, "nu": 0.25, "rho": 3.0}} if f.suffix == ".msh" else None
        own = f.suffix in (".inp", ".bdf")  # *BOUNDARY, SPC1: the deck's own supports
        model = Structure.from_mesh(f, sets, None if own else [{"nodes": (clamp + 1).tolist()}]).build()
        assert model.dofs == ref.dofs, name
        assert abs(model.K() - ref.K()).max() <= 1e-12 * abs(ref.K()).max(), name
        assert abs(model.M() - ref.M()).max() <= 1e-12 * abs(ref.M()).max(), name


def test_abaqus_part_and_instance_flattened(tmp_path):
    """A deck as Abaqus/CAE writes it (a part, its instance translated by (1, 2, 3), assembly sets with
    instance=, *Boundary on an assembly set): the same K and M as the plain deck, nodes moved."""
    pts, hexes = _block_mesh()
    nodes = "".join(f"{i + 1}, {x:.17g}, {y:.17g}, {z:.17g}\n" for i, (x, y, z) in enumerate(pts))
    els = "".join(", ".join(map(str, [e + 1, *(c + 1)])) + "\n" for e, c in enumerate(hexes))
    clamp = ", ".join(str(c + 1) for c in np.flatnonzero(pts[:, 0] == 0))
    mat = "*Material, name=Steel\n*Elastic\n2.0, 0.25\n*Density\n3.0\n"
    plain = tmp_path / "plain.inp"
    plain.write_text(f"*Node\n{nodes}*Element, type=C3D8I, elset=Solid\n{els}*Nset, nset=Fix\n{clamp}\n"
                     f"*Solid Section, elset=Solid, material=Steel\n,\n{mat}*Boundary\nFix, ENCASTRE\n")
    cae = tmp_path / "cae.inp"
    cae.write_text(f"*Heading\n*Part, name=Block\n*Node\n{nodes}*Element, type=C3D8I\n{els}"
                   f"*Elset, elset=Solid, generate\n1, {len(hexes)}, 1\n*Solid Section, elset=Solid, material=Steel\n,\n"
                   "*End Part\n*Assembly, name=Assembly\n*Instance, name=Block-1, part=Block\n1., 2., 3.\n*End Instance\n"
                   f"*Nset, nset=Fix, instance=Block-1\n{clamp}\n*End Assembly\n{mat}"
                   "*Boundary\nFix, ENCASTRE\n*Step, name=modes\n*Frequency\n4\n*End Step\n")
    a, b = Structure.from_mesh(plain).build(), Structure.from_mesh(cae).build()
    assert a.dofs == b.dofs and len(a.dofs) == 3 * 36
    assert abs(a.K() - b.K()).max() <= 1e-12 * abs(a.K()).max() and abs(a.M() - b.M()).max() <= 1e-12 * abs(a.M()).max()
    assert all(np.allclose(np.subtract(b.nodes[k], a.nodes[k]), [1, 2, 3]) for k in a.nodes)


def _refused(tmp_path, name, text, match, **kw):
    p = tmp_path / name
    p.write_text(text)
    with pytest.raises(InputError, match=match):
        Structure.from_mesh(p, **kw).build()


GRIDS = "".join(f"GRID,{i},,{x},{y},0.\n" for i, (x, y) in enumerate([(0, 0), (1, 0), (1, 1), (0, 1)], start=11))
PROPS = "PSHELL,5,1,0.01,1,,1\nMAT1,1,1.0,,0.3,1.0\n"


def test_bad_decks_refused_by_name(tmp_path):
    _refused(tmp_path, "a.bdf", GRIDS + "CQUAD8,1,5,11,12,13,14\n" + PROPS, r"CQUAD8 \(a.bdf:5\)")
    _refused(tmp_path, "b.bdf", GRIDS + "GRID,12,,3.,0.,0.\nCQUAD4,1,5,11,12,13,14\n" + PROPS, "node 12 defined twice")
    _refused(tmp_path, "c.bdf", GRIDS + "CQUAD4,1,5,11,13,12,14\n" + PROPS, r"element 1 \(CQUAD4, set '5'\).*degenerate")
    _refused(tmp_path, "d.bdf", GRIDS + "CQUAD4,1,6,11,12,13,14\n" + PROPS, r"PSHELL 5\): no element set '5' in d.bdf")
    _refused(tmp_path, "h.bdf", GRIDS + "CQUAD4,8,5,11,12,13,11\n" + PROPS, r"element 8 \(CQUAD4\) lists a node twice")
    _refused(tmp_path, "e.bdf", GRIDS + "CQUAD4,1,5,11,12,13,99\n" + PROPS, "element 1 .CQUAD4. uses node 99")
    _refused(tmp_path, "f.bdf", GRIDS + "CQUAD4,1,5,11,12,13,14\nPSHELL,5,1,-0.01,1,,1\nMAT1,1,1.0,,0.3,1.0\n",
             "non-positive property t")
    _refused(tmp_path, "g.bdf", GRIDS + "CQUAD4,1,5,11,12,13,14\nPSHELL,5,1,0.01,1,,1\nMAT1,1,1.0,,0.5,1.0\n",
             "Poisson's ratio")
    inp = "*NODE\n1,0,0,0\n2,1,0,0\n3,1,1,0\n4,0,1,0\n*ELEMENT, TYPE={t}, ELSET=P\n7, 1, 2, 3, 4\n"
    _refused(tmp_path, "a.inp", inp.format(t="CPS4"), "element type 'CPS4' is not supported")
    _refused(tmp_path, "b.inp", inp.format(t="S4") + "*CLOAD\n1, 1, 6\n", r"\*CLOAD \(line 8\)")
    _refused(tmp_path, "i.inp", inp.format(t="S4") + "*BOUNDARY\n1, 1, 6, 0.1\n", r"line 9: \*BOUNDARY reads")
    _refused(tmp_path, "i.bdf", GRIDS + "CQUAD4,1,5,11,12,13,14\nSPC1,1,123,11\nSPC1,2,3,12\n" + PROPS,
             "SPC1 sets 1 and 2")
    _refused(tmp_path, "c.inp", inp.format(t="S4"), "no element set 'Q'", sets={"Q": {"E": 1.0}})
    part = "*PART, NAME=x\n" + inp.format(t="S4") + "*END PART\n*ASSEMBLY, NAME=A\n"
    _refused(tmp_path, "d.inp", part + "*INSTANCE, NAME=i, PART=x\n*END INSTANCE\n*INSTANCE, NAME=j, PART=x\n",
             "part 'x' instanced twice")
    _refused(tmp_path, "d2.inp", part + "*INSTANCE, NAME=i, PART=x\n1., 0., 0.\n0., 0., 0., 0., 0., 1., 90.\n",
             "instance 'i' is rotated")
    _refused(tmp_path, "e.inp", inp.format(t="S4"), r"set 'P': its S4 elements need t",
             sets={"P": {"E": 1.0, "nu": 0.3, "rho": 1.0}})
    _refused(tmp_path, "f.inp", inp.format(t="S4"), "no node set 'edge'",
             sets={"P": {"E": 1.0, "nu": 0.3, "rho": 1.0, "t": 0.1}}, support=[{"set": "edge"}])
    ok = {"E": 1.0, "nu": 0.3, "rho": 1.0, "t": 0.1}
    _refused(tmp_path, "j.inp", inp.format(t="S4"), "E must be a number or a parameter name, got True",
             sets={"P": {**ok, "E": True}})
    _refused(tmp_path, "k.inp", inp.format(t="S4"), r"dofs must be a list of directions \(x, y, z, rx, ry, rz\), got \['w'\]",
             sets={"P": ok}, support=[{"nodes": [1], "dofs": ["w"]}])
    hexa = ("*NODE\n" + "".join(f"{i + 1},{x},{y},{z}\n" for i, (x, y, z) in enumerate(
        [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0), (0, 0, 1), (1, 0, 1), (1, 1, 1), (0, 1, 1)]))
        + "*ELEMENT, TYPE=C3D8, ELSET=B\n40, 5, 6, 7, 8, 1, 2, 3, 4\n")
    _refused(tmp_path, "g.inp", hexa, r"element 40 \(C3D8, set 'B'\).*inverted", sets={"B": {"E": 1.0, "nu": 0.3, "rho": 1.0}})


def test_nastran_continuations_and_include(tmp_path):
    (tmp_path / "grids.bdf").write_text(GRIDS)
    p = tmp_path / "m.bdf"
    p.write_text("SOL 103\nCEND\nBEGIN BULK\nINCLUDE 'grids.bdf'\n$ a comment\nCQUAD4  1       5       11      12      "
                 "13      14      +\n+       0.0\n" + PROPS + "PARAM,POST,-1\nENDDATA\n")
    mesh = read_mesh(p)
    assert mesh.node_ids.tolist() == [11, 12, 13, 14] and {k: v.tolist() for k, v in mesh.elsets.items()} == {"5": [1]} and mesh.ignored == ["PARAM (m.bdf:10)"]
    assert [c[0] for c in cards(p)] == ["GRID"] * 4 + ["CQUAD4", "PSHELL", "MAT1", "PARAM"]


ENV = {**os.environ, "PYTHONPATH": str(Path(femupdate.__file__).parents[1])}


def test_model_file_mesh_table_cli(plate16, tmp_path):
    """The [mesh] table through the command line: modes, and a bad set exits 2 naming it."""
    msh = plate16[0]
    (tmp_path / "plate.msh").write_bytes(msh.read_bytes())
    sup = "".join(f'[[mesh.support]]\nset = "{k}"\ndofs = {v}\n' for k, v in
                  (("plate", '["x", "y", "rz"]'), ("edges_x", '["z", "rx"]'), ("edges_y", '["z", "ry"]')))
    toml = ('[parameters.E_plate]\nvalue = 1.0\n\n[mesh]\nfile = "plate.msh"\n\n[mesh.sets.plate]\nE = "E_plate"\n'
            f'nu = 0.3\nrho = 1.0\nt = 0.01\n\n{sup}')
    (tmp_path / "plate.toml").write_text(toml)
    r = subprocess.run([sys.executable, "-m", "femupdate", "modes", "plate.toml", "--n-modes", "3", "--json", "-"],
                       cwd=tmp_path, capture_output=True, text=True, env=ENV)
    assert r.returncode == 0, r.stderr
    run = [sys.executable, "-m", "femupdate"]
    r = subprocess.run(run + ["modes", "plate.toml", "--n-modes", "4", "--set", "E_plate=1.3", "--uff", "test.uff"],
                       cwd=tmp_path, capture_output=True, text=True, env=ENV)
    assert r.returncode == 0, r.stderr
    (tmp_path / "out").mkdir()
    r = subprocess.run(run + ["update", "plate.toml", "test.uff", "--json", "u.json", "--write-model", "out/updated.toml"],
                       cwd=tmp_path, capture_output=True, text=True, env=ENV)
    assert r.returncode == 0, r.stderr
    res = json.loads((tmp_path / "u.json").read_text())
    assert abs(res["parameters"]["E_plate"] / 1.3 - 1) < 1e-6, res["parameters"]
    updated = load_model(tmp_path / "out" / "updated.toml")  # its [mesh] file relative to the new folder
    assert updated.dofs == load_model(tmp_path / "plate.toml").dofs and abs(updated.parameters[0].value / 1.3 - 1) < 1e-6
    (tmp_path / "bad.toml").write_text(toml.replace("mesh.sets.plate", "mesh.sets.plates"))
    r = subprocess.run([sys.executable, "-m", "femupdate", "modes", "bad.toml"], cwd=tmp_path, capture_output=True, text=True, env=ENV)
    assert r.returncode == 2 and "no element set 'plates'" in r.stderr + r.stdout and "Traceback" not in r.stderr


def test_gmsh_tet10_cantilever_against_beam_theory(tmp_path):
    """A 10 x 1 x 1 box meshed by Gmsh (unstructured second-order tetrahedra, size 0.5), clamped on its
    physical face "root": first bending frequency over Euler-Bernoulli's.  Timoshenko's shear and rotary
    inertia lower it to about 0.995 (Rayleigh estimate, kappa = 5/6, nu = 0); tet10 is stiff, so the ratio
    lies a little under that and near the structured tet10 mesh of test_elements_3d (0.992)."""
    gmsh = pytest.importorskip("gmsh")
    path, L = tmp_path / "cantilever.msh", 10.0
    _initialize(gmsh)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        v = gmsh.model.occ.addBox(0, 0, 0, L, 1, 1)
        gmsh.model.occ.synchronize()
        gmsh.model.addPhysicalGroup(3, [v], name="beam")
        root = [t for _, t in gmsh.model.getEntities(2) if gmsh.model.getBoundingBox(2, t)[3] < 1e-3]
        gmsh.model.addPhysicalGroup(2, root, name="root")
        gmsh.option.setNumber("Mesh.MeshSizeMax", 0.5)
        gmsh.model.mesh.generate(3)
        gmsh.model.mesh.setOrder(2)
        gmsh.write(str(path))
    finally:
        gmsh.finalize()
    mesh = read_mesh(path)
    assert [b.type for b in mesh.blocks] == ["tet10"] and set(mesh.nsets) == {"beam", "root"}
    model = Structure.from_mesh(path, {"beam": {"E": 1.0, "nu": 0.0, "rho": 1.0}}, [{"set": "root"}]).build()
    w = np.sqrt(sla.eigsh(model.K(), k=2, M=model.M(), sigma=0)[0])
    r = w / (1.875104068711961**2 * np.sqrt(1 / 12 / L**4))
    assert np.all((0.985 < r) & (r < 0.997)), r


def test_gmsh_element_named_by_its_tag(plate16, tmp_path):
    """A bow-tie made in Gmsh's own file (two nodes of its first quadrangle swapped) is refused by the
    element's Gmsh tag."""
    lines = plate16[0].read_text().splitlines()
    start = lines.index("$Elements")
    i = next(k for k in range(start + 2, len(lines))  # the header of a block of dimension 2, type 3 (quadrangles)
             if len(lines[k].split()) == 4 and lines[k].split()[0] == "2" and lines[k].split()[2] == "3")
    row = lines[i + 1].split()
    tag, row[2], row[3] = row[0], row[3], row[2]
    lines[i + 1] = " ".join(row)
    bad = tmp_path / "bowtie.msh"
    bad.write_text("\n".join(lines) + "\n")
    with pytest.raises(InputError, match=rf"bowtie.msh: element {tag} \(quad, set 'plate'\).*degenerate"):
        _model(bad)


def test_nastran_grid_positions_in_cord2_systems(tmp_path):
    """GRID CP in CORD2R, CORD2C and CORD2S (one defined in another, RID) against positions worked by hand."""
    p = tmp_path / "c.bdf"
    p.write_text("CORD2R,1,0,1.,2.,3.,1.,2.,4.,+\n+,2.,2.,3.\n"       # origin (1,2,3), z = basic z, x = basic x
                 "CORD2R,2,1,0.,0.,0.,1.,0.,0.,+\n+,0.,1.,0.\n"       # in system 1: z along 1's x, x along 1's y
                 "CORD2C,3,0,0.,0.,0.,0.,0.,1.,+\n+,1.,0.,0.\n"
                 "CORD2S,4,0,0.,0.,0.,0.,0.,1.,+\n+,1.,0.,0.\n"
                 "GRID,1,1,1.,1.,1.\nGRID,2,2,1.,1.,1.\nGRID,3,3,2.,90.,5.\nGRID,4,4,2.,90.,90.\n"
                 "CTETRA,1,1,1,2,3,4\nPSOLID,1,1\nMAT1,1,1.,,0.3,1.\n")
    xyz = read_mesh(p).xyz
    # system 2: origin (1,2,3); z = basic x, x = basic y, y = z x x = basic z
    assert np.allclose(xyz, [[2, 3, 4], [2, 3, 4], [0, 2, 5], [0, 2, 0]]), xyz
    p.write_text(p.read_text().replace("CORD2R,1,0,", "CORD2R,1,2,"))
    with pytest.raises(InputError, match="coordinate systems 1 -> 2 -> 1 refer to each other"):
        read_mesh(p)
