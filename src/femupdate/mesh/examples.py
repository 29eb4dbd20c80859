"""Three small mesh models for the end-to-end examples (docs/meshes-end-to-end.md, tests/test_mesh_e2e.py):

* ``"plate"``: a cantilever aluminium plate 0.6 m x 0.4 m of 12 x 8 MITC4 quadrilaterals, a Gmsh
  ``.msh`` (format 2.2, written by meshio) whose physical groups ``left``, ``middle`` and ``right``
  are strips of the plate and ``clamped`` is its edge at x = 0; parameters the thickness of
  ``left`` and the moduli of ``middle`` and ``right``;
* ``"box"``: an open steel box 0.4 m x 0.3 m x 0.2 m clamped at its base, an Abaqus ``.inp`` with a
  lid of ``S3`` triangles (MITC3, element set ``LID``) and walls of ``S4`` quadrilaterals (MITC4,
  ``WALLS_X`` and ``WALLS_Y``), each with its ``*SHELL SECTION``; parameters the thickness of the
  lid and the moduli of the two pairs of walls;
* ``"bracket"``: a steel L-bracket of 8-node hexahedra, a Nastran bulk deck (``GRID``, ``CHEXA``,
  ``PSOLID`` 1-3, ``MAT1``, ``SPC1``) clamped at the base's end; parameters the moduli of the
  three ``PSOLID`` property sets.

:func:`write_example` writes the mesh file, its model file (a ``[mesh]`` table naming the sets'
parameters) and, with ``data=True``, noise-free test data simulated by the model: ``test.json``
at :data:`TRUTH` and ``damaged.json`` with the stiffness loss :data:`DAMAGE` on top, measured at
the example's sensors (a subset of the translations, ``sensors`` of the file).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from .._errors import InputError

EXAMPLES = ("plate", "box", "bracket")
#: the parameter values the test data are simulated at
TRUTH = {"plate": {"t_left": 3.3e-3, "E_middle": 66e9, "E_right": 74e9},
         "box": {"t_lid": 2.2e-3, "E_walls_x": 190e9, "E_walls_y": 215e9},
         "bracket": {"E_root": 190e9, "E_corner": 212e9, "E_upright": 188e9}}
#: the damaged structure: these moduli times these factors (on top of TRUTH)
DAMAGE = {"plate": {"E_right": 0.85}, "box": {"E_walls_y": 0.85}, "bracket": {"E_upright": 0.85}}
#: the noise the test data state (the values themselves are noise-free): relative frequency std, shape std
STD_FREQUENCY, STD_SHAPE = 0.002, 0.01
N_MODES = {"plate": 6, "box": 6, "bracket": 6}


def _grid(nx: int, ny: int, lx: float, ly: float):
    """Nodes (ids from 1) and counter-clockwise quadrilaterals of a rectangle in the x-y plane."""
    x, y = np.meshgrid(np.linspace(0, lx, nx + 1), np.linspace(0, ly, ny + 1), indexing="ij")
    idx = np.arange((nx + 1) * (ny + 1)).reshape(nx + 1, ny + 1)
    quads = np.array([[idx[i, j], idx[i + 1, j], idx[i + 1, j + 1], idx[i, j + 1]] for i in range(nx) for j in range(ny)])
    return np.column_stack([x.ravel(), y.ravel(), np.zeros(x.size)]), quads, idx


def write_plate(folder: Path) -> Path:
    """``plate.msh`` (Gmsh 2.2 by meshio) and ``plate.toml``; returns the model file."""
    import meshio

    nx, ny = 12, 8
    pts, quads, idx = _grid(nx, ny, 0.6, 0.4)
    strip = np.repeat(np.arange(nx) // 4, ny)  # elements in x-major order: 4 columns per strip
    edge = np.array([[idx[0, j], idx[0, j + 1]] for j in range(ny)])
    tags = {"left": 1, "middle": 2, "right": 3, "clamped": 4}
    mesh = meshio.Mesh(pts, [("line", edge), ("quad", quads)],
                       cell_data={"gmsh:physical": [np.full(len(edge), 4), strip + 1],
                                  "gmsh:geometrical": [np.full(len(edge), 4), strip + 1]},
                       field_data={k: np.array([v, 1 if k == "clamped" else 2]) for k, v in tags.items()})
    meshio.write(folder / "plate.msh", mesh, file_format="gmsh22", binary=False)
    (folder / "plate.toml").write_text('''# A cantilever aluminium plate from a Gmsh mesh: thickness of one strip, moduli of the others
[model]
name = "plate"

[parameters.t_left]
value = 3.0e-3
bounds = [1.0e-3, 6.0e-3]

[parameters.E_middle]
value = 70.0e9
bounds = [35.0e9, 140.0e9]

[parameters.E_right]
value = 70.0e9
bounds = [35.0e9, 140.0e9]

[mesh]
file = "plate.msh"

[mesh.sets.left]
E = 70.0e9
nu = 0.33
rho = 2700.0
t = "t_left"

[mesh.sets.middle]
E = "E_middle"
nu = 0.33
rho = 2700.0
t = 3.0e-3

[mesh.sets.right]
E = "E_right"
nu = 0.33
rho = 2700.0
t = 3.0e-3

[[mesh.support]]
set = "clamped"
''')
    return folder / "plate.toml"


def write_box(folder: Path) -> Path:
    """``box.inp`` (an Abaqus deck: S3 lid, S4 walls, three shell sections) and ``box.toml``."""
    a, b, h, nx, ny, nz = 0.4, 0.3, 0.2, 8, 6, 4
    xs, ys, zs = np.linspace(0, a, nx + 1), np.linspace(0, b, ny + 1), np.linspace(0, h, nz + 1)
    ring = ([(x, 0.0) for x in xs[:-1]] + [(a, y) for y in ys[:-1]] + [(x, b) for x in xs[:0:-1]]
            + [(0.0, y) for y in ys[:0:-1]])  # the base perimeter, counter-clockwise from the origin
    nodes: dict[tuple, int] = {}

    def node(x, y, z) -> int:
        key = (round(x, 9), round(y, 9), round(z, 9))
        return nodes.setdefault(key, len(nodes) + 1)

    walls: dict[str, list] = {"WALLS_X": [], "WALLS_Y": []}
    nr = len(ring)
    for k in range(nr):
        (x0, y0), (x1, y1) = ring[k], ring[(k + 1) % nr]
        name = "WALLS_Y" if abs(y0 - y1) < 1e-12 else "WALLS_X"  # walls along x face y, along y face x
        for m in range(nz):
            walls[name].append([node(x0, y0, zs[m]), node(x1, y1, zs[m]), node(x1, y1, zs[m + 1]), node(x0, y0, zs[m + 1])])
    lid = []
    for i in range(nx):
        for j in range(ny):
            c = [node(xs[i], ys[j], h), node(xs[i + 1], ys[j], h), node(xs[i + 1], ys[j + 1], h), node(xs[i], ys[j + 1], h)]
            lid += [[c[0], c[1], c[2]], [c[0], c[2], c[3]]] if (i + j) % 2 == 0 else [[c[0], c[1], c[3]], [c[1], c[2], c[3]]]
    base = sorted(n for (x, y, z), n in nodes.items() if z == 0.0)
    lines = ["*HEADING", "open steel box clamped at its base (femupdate example)", "*NODE, NSET=ALL"]
    lines += [f"{n}, {x:.9g}, {y:.9g}, {z:.9g}" for (x, y, z), n in nodes.items()]
    eid = 1
    for typ, name, conn in (("S4", "WALLS_X", walls["WALLS_X"]), ("S4", "WALLS_Y", walls["WALLS_Y"]), ("S3", "LID", lid)):
        lines.append(f"*ELEMENT, TYPE={typ}, ELSET={name}")
        for c in conn:
            lines.append(", ".join(map(str, [eid, *c])))
            eid += 1
    lines.append("*NSET, NSET=BASE")
    lines += [", ".join(map(str, base[k:k + 16])) for k in range(0, len(base), 16)]
    lines += ["*MATERIAL, NAME=STEEL", "*ELASTIC", "200.E9, 0.3", "*DENSITY", "7850.",
              "*SHELL SECTION, ELSET=LID, MATERIAL=STEEL", "2.0E-3, 5",
              "*SHELL SECTION, ELSET=WALLS_X, MATERIAL=STEEL", "2.0E-3, 5",
              "*SHELL SECTION, ELSET=WALLS_Y, MATERIAL=STEEL", "2.0E-3, 5",
              "*BOUNDARY", "BASE, ENCASTRE"]
    (folder / "box.inp").write_text("\n".join(lines) + "\n")
    (folder / "box.toml").write_text('''# An open steel box from an Abaqus deck: the deck gives material, sections and the clamped base;
# the model file makes the lid's thickness and the walls' moduli parameters
[model]
name = "box"

[parameters.t_lid]
value = 2.0e-3
bounds = [0.5e-3, 5.0e-3]

[parameters.E_walls_x]
value = 200.0e9
bounds = [100.0e9, 400.0e9]

[parameters.E_walls_y]
value = 200.0e9
bounds = [100.0e9, 400.0e9]

[mesh]
file = "box.inp"

[mesh.sets.LID]
t = "t_lid"

[mesh.sets.WALLS_X]
E = "E_walls_x"

[mesh.sets.WALLS_Y]
E = "E_walls_y"
''')
    return folder / "box.toml"


def _bracket_mesh():
    """Nodes and hexahedra (node ids from 1, element ids from 1) of an L-bracket, and each element's PSOLID."""
    nx, ny, nz, lx, ly, lz = 10, 3, 8, 0.12, 0.04, 0.10
    dx, dz = lx / nx, lz / nz
    keep = [(i, j, k) for i in range(nx) for j in range(ny) for k in range(nz) if k == 0 or i == nx - 1]
    nodes: dict[tuple, int] = {}
    hexes, pid = [], []
    for i, j, k in keep:
        corners = [(i, j, k), (i + 1, j, k), (i + 1, j + 1, k), (i, j + 1, k),
                   (i, j, k + 1), (i + 1, j, k + 1), (i + 1, j + 1, k + 1), (i, j + 1, k + 1)]
        hexes.append([nodes.setdefault(c, len(nodes) + 1) for c in corners])
        pid.append(3 if k > 0 else 1 if i < nx // 2 else 2)
    xyz = {n: (c[0] * dx, c[1] * ly / ny, c[2] * dz) for c, n in nodes.items()}
    clamp = sorted(n for c, n in nodes.items() if c[0] == 0)
    return xyz, hexes, pid, clamp


def write_bracket(folder: Path) -> Path:
    """``bracket.bdf`` (Nastran free-field bulk data) and ``bracket.toml``."""
    xyz, hexes, pid, clamp = _bracket_mesh()
    lines = ["$ steel L-bracket clamped at the end of its base (femupdate example)", "BEGIN BULK"]
    lines += [f"GRID,{n},,{x:.9g},{y:.9g},{z:.9g}" for n, (x, y, z) in xyz.items()]
    for e, (c, p) in enumerate(zip(hexes, pid), start=1):
        lines += [f"CHEXA,{e},{p},{','.join(map(str, c[:6]))},+", f"+,{c[6]},{c[7]}"]
    lines += [f"PSOLID,{p},1" for p in (1, 2, 3)]
    lines += ["MAT1,1,2.0+11,,0.3,7850.0"]
    lines += [f"SPC1,1,123,{','.join(map(str, clamp[k:k + 6]))}" for k in range(0, len(clamp), 6)]
    lines.append("ENDDATA")
    (folder / "bracket.bdf").write_text("\n".join(lines) + "\n")
    (folder / "bracket.toml").write_text('''# A steel L-bracket from a Nastran deck: the modulus of each PSOLID's elements a parameter
[model]
name = "bracket"

[parameters.E_root]
value = 200.0e9
bounds = [100.0e9, 400.0e9]

[parameters.E_corner]
value = 200.0e9
bounds = [100.0e9, 400.0e9]

[parameters.E_upright]
value = 200.0e9
bounds = [100.0e9, 400.0e9]

[mesh]
file = "bracket.bdf"

[mesh.sets."1"]
E = "E_root"

[mesh.sets."2"]
E = "E_corner"

[mesh.sets."3"]
E = "E_upright"
''')
    return folder / "bracket.toml"


def sensors(name: str, model) -> list[str]:
    """The example's measured dofs: translations at every other node of the mesh (x, y and z)."""
    from ..dofs import parse_dof

    ids = sorted({parse_dof(d)[0] for d in model.dofs})
    keep = set(ids[::2])
    return [d for d in model.dofs if parse_dof(d)[0] in keep and parse_dof(d)[1] in ("x", "y", "z")]


def simulate(model, values, dofs, n_modes: int) -> dict:
    """Noise-free test data (JSON object) of ``model`` at ``values``: frequencies, shapes at ``dofs``
    (mass-normalised), each mode stating :data:`STD_FREQUENCY` and :data:`STD_SHAPE`."""
    from ..modal import model_modes

    m = model_modes(model, values, n_modes=n_modes)
    pos = model.dof_index(dofs)
    modes = [{"frequency_hz": float(f), "shape": {d: float(v) for d, v in zip(dofs, m.shapes[pos, i])},
              "std_frequency": STD_FREQUENCY, "std_shape": STD_SHAPE} for i, f in enumerate(m.frequencies_hz)]
    return {"modes": modes, "sensors": list(dofs)}


def write_example(name: str, folder, data: bool = True) -> Path:
    """Write example ``name`` (one of :data:`EXAMPLES`) into ``folder``: the mesh, the model file
    and, with ``data``, ``test.json`` (at :data:`TRUTH`) and ``damaged.json`` (:data:`DAMAGE` on top).

    Returns
    -------
    pathlib.Path
        The model file.
    """
    if name not in EXAMPLES:
        raise InputError(f"example must be one of {', '.join(EXAMPLES)}, got {name!r}")
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    path = {"plate": write_plate, "box": write_box, "bracket": write_bracket}[name](folder)
    if data:
        from ..io.model_file import load_model

        model = load_model(path)
        dofs = sensors(name, model)
        truth = TRUTH[name]
        damaged = {k: v * DAMAGE[name].get(k, 1.0) for k, v in truth.items()}
        for file, values in (("test.json", truth), ("damaged.json", damaged)):
            (folder / file).write_text(json.dumps(simulate(model, values, dofs, N_MODES[name]), indent=1) + "\n")
    return path


__all__ = ["EXAMPLES", "TRUTH", "DAMAGE", "write_example", "simulate", "sensors"]
