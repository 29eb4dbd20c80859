"""Full-field (scanning) data given by coordinates, mapped onto the model's dofs, and the direct
solution on the completed data.

================  ===============================================================================
:mod:`.scan`      :class:`ScanData`, :class:`ScanMode`, :class:`ScanFRF`: points and measured components
:mod:`.geometry`  the model's geometry, distances of points to it, rotations from translations
:mod:`.mapping`   :func:`map_scan` (element shape functions, smoothing spline, local fit),
                  :class:`FullFieldMapping` with the mapping error
:mod:`.direct`    :func:`full_field_direct`, :func:`complete_direct`, :func:`project_system`
:mod:`.result`    :class:`FullFieldResult`: the direct solution with the mapping (kind ``fullfield``)
:mod:`.files`     :func:`~.files.load_scan`: the JSON scan file
:mod:`.examples`  :func:`~.examples.segmented_cantilever`, :func:`~.examples.scan_beam`
================  ===============================================================================
"""

from .direct import FORMS, complete_direct, full_field_direct, measured_vectors, project_system
from .geometry import (Geometry, distance_to_geometry, inferable_rotations, model_geometry, rotation_operators,
                       structure_segments)
from .mapping import METHODS, FullFieldMapping, element_design, map_scan
from .result import FullFieldResult
from .scan import ScanData, ScanFRF, ScanMode

__all__ = ["ScanData", "ScanMode", "ScanFRF", "Geometry", "FullFieldMapping", "model_geometry", "structure_segments",
           "distance_to_geometry", "element_design", "rotation_operators", "inferable_rotations", "map_scan",
           "project_system", "measured_vectors", "complete_direct", "full_field_direct", "METHODS", "FORMS",
           "FullFieldResult"]
