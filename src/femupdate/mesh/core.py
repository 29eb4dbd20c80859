"""The neutral mesh every reader fills: nodes (file ids, coordinates), element blocks by
femupdate element type (file ids, connectivity in file node ids), named element and node sets,
and what a solver deck says of materials and sections."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .._errors import InputError

#: node count of each femupdate element type a mesh may hold
NODE_COUNT = {"mitc4": 4, "mitc3": 3, "hex8": 8, "tet4": 4, "tet10": 10, "frame3d": 2}


@dataclass
class Block:
    """Elements of one femupdate type: ``ids`` (n,), ``conn`` (n, k) file node ids, and the
    element type as the file names it (``"S4R"``, ``"CQUAD4"``, ``"quad"``)."""

    type: str
    ids: np.ndarray
    conn: np.ndarray
    source_type: str
    orientation: np.ndarray | None = None  # frame3d: (n, 3) vectors in each member's local x-y plane
    offsets: np.ndarray | None = None  # frame3d: (n, 2, 3) rigid end offsets (global), or None


@dataclass
class Material:
    """An isotropic material of a deck: E, nu, rho (None where the deck does not give one)."""

    name: str
    E: float | None = None
    nu: float | None = None
    rho: float | None = None


@dataclass
class Section:
    """A deck's section: the element set it covers, its material's name and (shells) thickness."""

    elset: str
    material: str
    thickness: float | None = None
    where: str = ""
    beam: dict | None = None  # a beam section: A, Iy, Iz, J (femupdate's frame3d names)


@dataclass
class Mesh:
    """A mesh as read from a file (:func:`femupdate.mesh.read_mesh`).

    Attributes
    ----------
    source : str
        The file, for messages.
    node_ids : numpy.ndarray, shape ``(n,)``
        Node ids as the file writes them.
    xyz : numpy.ndarray, shape ``(n, 3)``
        Coordinates.
    blocks : list of Block
        Elements by type (file element ids and node ids).
    elsets, nsets : dict of str to numpy.ndarray
        Named element sets (element ids) and node sets (node ids); Gmsh physical groups, Abaqus
        ``*ELSET``/``*NSET``, Nastran property ids (element sets named by the id, ``"1"``).
    materials : dict of str to Material
        Deck materials by name (Abaqus) or id (Nastran, ``"1"``).
    sections : list of Section
        Deck sections: which element set has which material and thickness.
    ignored : list of str
        What the reader skipped on purpose (solution control), named with its line.
    supports : list of dict
        The deck's own fixed dofs (Abaqus ``*BOUNDARY``, Nastran ``SPC1``), each
        ``{"nodes": [ids], "dofs": [directions], "where": text}``.
    springs : list of dict
        Springs (Nastran CELAS1/CELAS2): ``{"dofs": [labels], "k": value, "where": text}``.
    masses : list of dict
        Point masses (Nastran CONM2): ``{"node", "m", "offset", "inertia", "where"}``.
    links : list of dict
        Exact multipoint constraints (Nastran RBE2, Abaqus ``*KINEMATIC COUPLING`` and ``*MPC``):
        ``{"kind": "rigid" | "equal", "independent", "dependent": [ids], "dofs": [directions] or
        None, "where"}``.
    """

    source: str
    node_ids: np.ndarray
    xyz: np.ndarray
    blocks: list[Block] = field(default_factory=list)
    elsets: dict[str, np.ndarray] = field(default_factory=dict)
    nsets: dict[str, np.ndarray] = field(default_factory=dict)
    materials: dict[str, Material] = field(default_factory=dict)
    sections: list[Section] = field(default_factory=list)
    ignored: list[str] = field(default_factory=list)
    supports: list[dict] = field(default_factory=list)
    springs: list[dict] = field(default_factory=list)
    masses: list[dict] = field(default_factory=list)
    links: list[dict] = field(default_factory=list)

    def check(self) -> Mesh:
        """Refuse duplicate node or element ids, elements that list a node twice and elements on
        undefined nodes (named by id)."""
        ids, counts = np.unique(self.node_ids, return_counts=True)
        if np.any(counts > 1):
            raise InputError(f"{self.source}: node {int(ids[counts > 1][0])} defined twice")
        all_el = np.concatenate([b.ids for b in self.blocks]) if self.blocks else np.empty(0, np.int64)
        eids, ecounts = np.unique(all_el, return_counts=True)
        if np.any(ecounts > 1):
            raise InputError(f"{self.source}: element {int(eids[ecounts > 1][0])} defined twice")
        for b in self.blocks:
            srt = np.sort(b.conn, axis=1)
            rep = np.flatnonzero(np.any(srt[:, 1:] == srt[:, :-1], axis=1))
            if rep.size:
                raise InputError(f"{self.source}: element {int(b.ids[rep[0]])} ({b.source_type}) lists a node twice "
                                 f"({', '.join(map(str, b.conn[rep[0]].tolist()))}): degenerate")
            missing = ~np.isin(b.conn, self.node_ids)
            if missing.any():
                r = int(np.flatnonzero(missing.any(axis=1))[0])
                raise InputError(f"{self.source}: element {int(b.ids[r])} ({b.source_type}) uses node "
                                 f"{int(b.conn[r][missing[r]][0])}, which the file does not define")
        known = set(self.node_ids.tolist())
        from ..dofs import parse_dof

        used = [(parse_dof(lab)[0], x["where"]) for x in self.springs for lab in x["dofs"]]
        used += [(x["node"], x["where"]) for x in self.masses]
        used += [(n, x["where"]) for x in self.links for n in [x["independent"], *x["dependent"]]]
        bad = next(((n, w) for n, w in used if n not in known), None)
        if bad is not None:
            raise InputError(f"{bad[1]}: node {bad[0]} is not defined in {Path(self.source).name}")
        return self

    def set_of(self, name: str, kind: str) -> tuple[str, np.ndarray]:
        """The named element (``kind="element"``) or node set, matched as written, else ignoring
        case (Abaqus set names are case-insensitive); refused naming the sets the file has."""
        sets = self.elsets if kind == "element" else self.nsets
        if name in sets:
            return name, sets[name]
        folded = [k for k in sets if k.casefold() == str(name).casefold()]
        if not folded and "." in str(name):  # an Abaqus assembly's "Instance.Set"
            folded = [k for k in sets if k.casefold() == str(name).split(".", 1)[1].casefold()]
        if len(folded) == 1:
            return folded[0], sets[folded[0]]
        have = ", ".join(sorted(sets)) or "none"
        raise InputError(f"no {kind} set {name!r} in {Path(self.source).name} (its {kind} sets: {have})")


def int_id(text: str, what: str) -> int:
    """An id field as an int, refused naming the field as written."""
    try:
        return int(text)  # the common case, first
    except ValueError:
        pass
    try:
        v = float(text) if "." in text or "e" in text.lower() else int(text)
    except ValueError:
        raise InputError(f"{what}: {text!r} is not an id") from None
    if not float(v).is_integer():
        raise InputError(f"{what}: {text!r} is not an integer id")
    return int(v)


#: direction of each dof number of Abaqus and Nastran (1-6)
DIRS = {"1": "x", "2": "y", "3": "z", "4": "rx", "5": "ry", "6": "rz"}


__all__ = ["DIRS", "Mesh", "Block", "Material", "Section", "NODE_COUNT", "int_id"]
