"""More data and damage: perturbed-boundary (multi-configuration) updating, full-field scans, damage detection.

=======================================  =====================================================
:func:`configure`, :class:`Modification`  one test configuration's model (known masses, springs,
                                          supports, parameter values)
:func:`solve_configurations`              joint update of several configurations: direct when
                                          the data are complete, iterative otherwise
:func:`rank_modifications`                pre-test ranking of candidate modifications by the
                                          new, independent information they bring
:func:`map_scan`, :func:`full_field_direct`  scanning (full-field) data by coordinates onto the
                                          model's dofs, rotations from slopes, direct solution
:func:`element_parameters`                one stiffness parameter per element
:func:`check_baseline`                    the baseline against the undamaged structure's data
:func:`detect_damage`                     damage localisation from a validated baseline
                                          (element stiffnesses, expansion, sparse regularisation)
=======================================  =====================================================
"""

from .detect import BaselineCheck, DamageResult, check_baseline, detect_damage, element_parameters, l1_solve
from .fullfield import (FullFieldMapping, ScanData, ScanFRF, ScanMode, complete_direct, full_field_direct, map_scan,
                        structure_segments)
from .multiconfig import (Configuration, Modification, MultiConfigResult, Ranking, configure, direct_configurations,
                          rank_modifications, simulate, solve_configurations, update_configurations)

__all__ = [
    "Modification", "Configuration", "configure", "simulate", "direct_configurations", "update_configurations",
    "solve_configurations", "rank_modifications", "MultiConfigResult", "Ranking",
    "ScanData", "ScanMode", "ScanFRF", "FullFieldMapping", "map_scan", "full_field_direct", "complete_direct",
    "structure_segments",
    "element_parameters", "check_baseline", "BaselineCheck", "detect_damage", "DamageResult", "l1_solve",
]
