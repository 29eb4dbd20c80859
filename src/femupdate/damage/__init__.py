"""Damage detection from a validated baseline.

==============================================  =====================================================
:func:`damage_unknowns`                         the model and its unknowns: its own stiffness
                                                parameters or one per element (:mod:`.parameters`)
:func:`element_parameters`                      one stiffness parameter per element (:mod:`.parameters`)
:func:`check_baseline`                          the baseline against the undamaged structure's data
                                                (:mod:`.baseline`)
:func:`detect_damage`                           damage from a validated baseline: localise
                                                (expansion, sparse regularisation; :mod:`.localise`),
                                                refine and verify (:mod:`.refine`, :mod:`.verify`),
                                                bootstrap (:mod:`.bootstrap`), judge; :mod:`.detect`
:class:`DamageOptions`                          its method's knobs, checked (:mod:`.options`)
:func:`~.judge.judge`                           the status, doubts and confidence: false-positive and
                                                detection rates simulated for the run (:mod:`.judge`)
:func:`~.noise.stated_noise`                    the noise and what it rests on: the caller's, the test
                                                data's, estimated or assumed (:mod:`.noise`)
:func:`~.rates.comparable_rate`                 the benchmark's rates on its own families (:mod:`.rates`)
:func:`l1_solve`, :func:`~.solvers.tikhonov`    the regularised solvers (:mod:`.solvers`)
==============================================  =====================================================

Multi-configuration (perturbed-boundary) updating is in :mod:`femupdate.updating.multiconfig`,
full-field scans in :mod:`femupdate.fullfield`.
"""

from .baseline import BaselineCheck, check_baseline
from .detect import DamageResult, detect_damage
from .options import DamageOptions
from .parameters import DamageUnknowns, damage_unknowns, element_parameters
from .solvers import l1_solve

__all__ = ["element_parameters", "damage_unknowns", "DamageUnknowns", "check_baseline", "BaselineCheck", "detect_damage",
           "DamageResult", "DamageOptions", "l1_solve"]
