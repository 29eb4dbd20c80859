"""Gmsh ``.msh`` files (and the other pure mesh formats meshio reads) through meshio, an
optional dependency (``pip install femupdate[mesh]``), imported here only.

Element types: ``quad`` -> mitc4, ``triangle`` -> mitc3, ``hexahedron`` -> hex8, ``tetra`` ->
tet4, ``tetra10`` -> tet10 (meshio gives VTK's node order, femupdate's).  Physical groups become
sets: a group of elements of the mesh's highest dimension is an element set and a node set; a
group of lower dimension (edges, points, or the faces of a solid mesh) a node set only.  Node and
element ids are Gmsh's own tags for ASCII files (format 2.2 and 4.1); otherwise the position in
the file, counted from 1."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .._errors import InputError
from .core import Block, Mesh

TYPES = {"quad": "mitc4", "triangle": "mitc3", "hexahedron": "hex8", "tetra": "tet4", "tetra10": "tet10"}
_DIM = {"vertex": 0, "line": 1, "line3": 1, "triangle": 2, "quad": 2, "triangle6": 2, "quad8": 2, "quad9": 2,
        "tetra": 3, "tetra10": 3, "hexahedron": 3, "hexahedron20": 3, "hexahedron27": 3, "wedge": 3, "pyramid": 3}


def _tags(path: Path, section: str, counts: list[int] | None = None):
    """Node or element tags of an ASCII Gmsh 4.1 or 2.2 file in file order, or None."""
    try:
        with open(path, encoding="utf-8") as fh:
            text = fh.read()
    except (UnicodeDecodeError, OSError):
        return None
    head = text.split("$MeshFormat", 1)[-1].split()
    if len(head) < 2 or head[1] != "0":
        return None  # binary
    body = text.split(f"${section}\n", 1)
    if len(body) != 2:
        return None
    lines = body[1].split(f"$End{section}", 1)[0].splitlines()
    if head[0].startswith("2"):
        if section != "Nodes":
            return None
        return np.array([int(ln.split()[0]) for ln in lines[1:] if ln.strip()], np.int64)
    if not head[0].startswith("4.1"):
        return None
    nblocks, i = int(lines[0].split()[0]), 1
    tags: list = []
    for _ in range(nblocks):
        n = int(lines[i].split()[3])
        if section == "Nodes":
            tags.extend(int(x) for x in lines[i + 1:i + 1 + n])
            i += 1 + 2 * n
        else:
            tags.append(np.array([int(x.split()[0]) for x in lines[i + 1:i + 1 + n]], np.int64))
            i += 1 + n
    return np.array(tags, np.int64) if section == "Nodes" else tags


def read_gmsh(path) -> Mesh:
    """The mesh and physical groups of a Gmsh (or other meshio-readable) file."""
    path = Path(path)
    try:
        import meshio
    except ImportError:
        raise InputError(f"{path}: reading Gmsh and other mesh files needs meshio (pip install meshio, or "
                         "femupdate[mesh])") from None
    if not path.exists():
        raise InputError(f"{path}: no such file")
    try:
        m = meshio.read(path)
    except Exception as exc:  # meshio raises many kinds on a malformed file
        raise InputError(f"{path}: meshio could not read it: {exc}") from None
    ntags = _tags(path, "Nodes") if path.suffix.lower() == ".msh" else None
    if ntags is None or len(ntags) != len(m.points):
        ntags = np.arange(1, len(m.points) + 1, dtype=np.int64)
    etags = _tags(path, "Elements") if path.suffix.lower() == ".msh" else None
    if etags is None or [len(t) for t in etags] != [len(c.data) for c in m.cells]:
        start = np.cumsum([0] + [len(c.data) for c in m.cells])
        etags = [np.arange(a + 1, a + 1 + len(c.data), dtype=np.int64) for a, c in zip(start, m.cells)]
    xyz = np.zeros((len(m.points), 3))
    xyz[:, :m.points.shape[1]] = m.points
    mesh = Mesh(str(path), ntags, xyz)
    top = max((_DIM.get(c.type, -1) for c in m.cells), default=-1)
    names = {(int(v[1]), int(v[0])): k for k, v in (m.field_data or {}).items() if len(v) >= 2}
    phys = m.cell_data.get("gmsh:physical")
    by_type: dict = {}
    for k, c in enumerate(m.cells):
        dim = _DIM.get(c.type)
        conn = ntags[c.data]
        if dim == top:
            if c.type not in TYPES:
                raise InputError(f"{path}: element type {c.type!r} (element {int(etags[k][0])}) is not supported "
                                 f"(femupdate reads {', '.join(TYPES)})")
            by_type.setdefault(c.type, []).append((etags[k], conn))
        if phys is None:
            continue
        for tag in np.unique(phys[k]):
            sel = phys[k] == tag
            name = names.get((-1 if dim is None else dim, int(tag)), str(int(tag)))
            prev = mesh.nsets.get(name, np.empty(0, np.int64))
            mesh.nsets[name] = np.union1d(prev, conn[sel].ravel())
            if dim == top:
                mesh.elsets[name] = np.concatenate([mesh.elsets.get(name, np.empty(0, np.int64)), etags[k][sel]])
    for t, parts in by_type.items():
        mesh.blocks.append(Block(TYPES[t], np.concatenate([p[0] for p in parts]),
                                 np.concatenate([p[1] for p in parts]), t))
    if not mesh.blocks:
        raise InputError(f"{path}: no shell or solid elements (quad, triangle, hexahedron, tetra, tetra10)")
    return mesh.check()


__all__ = ["read_gmsh", "TYPES"]
