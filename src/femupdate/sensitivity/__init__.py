"""Eigen-sensitivities: every route the reference paper reviews, each selectable.

=====================================  ===================================================
:func:`eigenvalue_derivatives`          Fox & Kapoor (1968), paper eq. 21 (and eq. 19's ∂λ/λ)
:func:`nelson`                          Nelson (1976): exact, one sparse factorisation per mode
:func:`modal`                           modal superposition over all modes (Fox & Kapoor)
:func:`modal_static_correction`         truncated modes + Wang's (1991) static correction
:func:`finite_difference`               central differences with MAC tracking (test oracle)
:func:`scaled_shape`                    derivative of a shape scaled as the test data are
=====================================  ===================================================
"""

from .eigenvalue import eigenvalue_derivatives
from .finite_difference import finite_difference
from .modal import modal, modal_static_correction
from .nelson import nelson
from .scaling import scaled_shape

__all__ = [
    "eigenvalue_derivatives", "nelson", "modal", "modal_static_correction",
    "finite_difference", "scaled_shape",
]
