"""Damage detection from a validated baseline.

=======================================  =====================================================
:func:`element_parameters`                one stiffness parameter per element (:mod:`.parameters`)
:func:`check_baseline`                    the baseline against the undamaged structure's data
                                          (:mod:`.baseline`)
:func:`detect_damage`                     damage localisation from a validated baseline
                                          (element stiffnesses, expansion, sparse
                                          regularisation, bootstrap; :mod:`.detect`)
:func:`l1_solve`, :func:`~.solvers.tikhonov`  the regularised solvers (:mod:`.solvers`)
=======================================  =====================================================

Multi-configuration (perturbed-boundary) updating is in :mod:`femupdate.updating.multiconfig`,
full-field scans in :mod:`femupdate.fullfield`.
"""

from .baseline import BaselineCheck, check_baseline
from .detect import DamageResult, detect_damage
from .parameters import element_parameters
from .solvers import l1_solve

__all__ = ["element_parameters", "check_baseline", "BaselineCheck", "detect_damage", "DamageResult", "l1_solve"]
