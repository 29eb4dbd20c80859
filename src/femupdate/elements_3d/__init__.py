"""Shell and solid elements (pure, vectorised NumPy functions returning element stacks).

* :mod:`.solids`: ``hex8_terms`` (QM6 incompatible modes), ``tet4_terms``, ``tet10_terms``.
* :mod:`.shells`: ``mitc4_terms`` (Bathe-Dvorkin 1986), ``mitc3_terms`` (Lee-Bathe 2004).

Each returns :class:`femupdate.elements.ElementTerms`: lists of ``(factors, stack)`` whose sum
of products is the element matrix, the exact decomposition by parameter.
"""

from .shells import mitc3_terms, mitc4_terms
from .solids import hex8_terms, tet4_terms, tet10_terms

__all__ = ["hex8_terms", "tet4_terms", "tet10_terms", "mitc4_terms", "mitc3_terms"]
