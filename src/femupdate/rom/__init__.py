"""Parametric reduced-order models for updating, every answer checked on the full model.

:func:`rom_update` (and :func:`rom_multistart`) build a greedy Ritz basis of the full model
(:mod:`femupdate.rom.greedy`: modes and their static corrections at a few parameter points,
M-orthonormalised with deflation), project every parameter matrix on it once
(:mod:`femupdate.rom.project`: a :class:`~femupdate.Model` that interpolates at the data's dofs,
on which every route runs unchanged), update on it, and check each answer on the full model
(:mod:`femupdate.rom.check`, with the a-posteriori bounds of :mod:`femupdate.rom.estimate`),
enriching the basis where a check fails.  ``femupdate update --reduced-basis`` on the command line;
docs/reduced-models.md explains the error control.
"""

from .greedy import ReducedBasis, build
from .project import data_dofs, reduced_model
from .update import ROMOptions, basis_for, rom_multistart, rom_update

__all__ = ["ROMOptions", "rom_update", "rom_multistart", "basis_for", "build", "ReducedBasis", "reduced_model",
           "data_dofs"]
