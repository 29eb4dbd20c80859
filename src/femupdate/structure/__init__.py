"""Physical-parameter structures: nodes, elements, supports, parameters -> :class:`Model`.

A :class:`Structure` is the editable description (the TOML model file maps onto it one to one);
:meth:`Structure.build` assembles the affine sparse model.  Every element property is a number,
the name of a declared parameter, or a sequence of those (one per element) for vectorised
groups.  A parameter may appear in any number of elements (grouping).

Example
-------
>>> s = Structure("two-dof chain")
>>> s.parameter("k1", 8.0, bounds=(0, 100)); s.parameter("k2", 6.0)
>>> s.spring(["1:x"], k="k1"); s.spring(["1:x", "2:x"], k="k2")
>>> s.mass(["1:x"], m=2.0); s.mass(["2:x"], m=4.0)
>>> model = s.build()

Layout: :mod:`.builder` (:class:`Structure`: declarations, elements, assembly), :mod:`.groups`
(element types, element groups and their vectorised assembly into triplets) and :mod:`.tables`
(the dict / TOML form, :meth:`Structure.from_dict`).
"""

from .builder import Structure
from .groups import ELEMENT_TYPES, MASS_KINDS

__all__ = ["Structure", "ELEMENT_TYPES", "MASS_KINDS"]
