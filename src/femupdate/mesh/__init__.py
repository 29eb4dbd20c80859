"""Meshes in: a neutral :class:`Mesh` and readers into it (:func:`read_mesh`).

* :mod:`.gmsh`: Gmsh ``.msh`` (and other pure mesh formats) through meshio (optional);
* :mod:`.nastran`: Nastran bulk data (``.bdf``, ``.dat``, ``.nas``, ``.blk``), read by femupdate
  (beams, springs, masses and RBE2 in :mod:`.nastran_cards`);
* :mod:`.abaqus`: Abaqus input files (``.inp``), read by femupdate (couplings and MPCs in
  :mod:`.abaqus_links`);
* :mod:`.model`: a :class:`~femupdate.structure.Structure` from a mesh and a model file's
  ``[mesh]`` table (:meth:`Structure.from_mesh`).
"""

from __future__ import annotations

from pathlib import Path

from .._errors import InputError
from .core import Block, Material, Mesh, Section

NASTRAN_SUFFIXES = (".bdf", ".dat", ".nas", ".blk", ".bulk")
FORMATS = ("gmsh", "nastran", "abaqus")


def read_mesh(path, format: str | None = None) -> Mesh:
    """Read a mesh file into a :class:`Mesh`.

    Parameters
    ----------
    path : str or os.PathLike
        The file.
    format : {"gmsh", "nastran", "abaqus"}, optional
        Default by suffix: ``.inp`` Abaqus, ``.bdf .dat .nas .blk .bulk`` Nastran, anything else
        through meshio (``.msh`` Gmsh).

    Raises
    ------
    InputError
        An unreadable file, unsupported cards or element types, duplicate ids, elements on
        undefined nodes (named as the file writes them).
    """
    from ..io.outputs import note_input

    path = Path(path)
    note_input(path, "the mesh file")  # no output of the run may be written over it
    if format is None:
        suffix = path.suffix.lower()
        format = "abaqus" if suffix == ".inp" else "nastran" if suffix in NASTRAN_SUFFIXES else "gmsh"
    if format == "abaqus":
        from .abaqus import read_abaqus
        return read_abaqus(path)
    if format == "nastran":
        from .nastran import read_nastran
        return read_nastran(path)
    if format == "gmsh":
        from .gmsh import read_gmsh
        return read_gmsh(path)
    raise InputError(f"{path}: format must be one of {', '.join(FORMATS)}, got {format!r}")


__all__ = ["Mesh", "Block", "Material", "Section", "read_mesh", "FORMATS"]
