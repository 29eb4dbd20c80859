"""Eigen-sensitivities: every route the reference paper reviews, each selectable.

=====================================  ===================================================
:func:`eigenvalue_derivatives`          Fox & Kapoor (1968), paper eq. 21 (and eq. 19's ∂λ/λ)
:func:`nelson`                          Nelson (1976): exact, one sparse factorisation per mode
:func:`modal`                           modal superposition over all modes (Fox & Kapoor)
:func:`modal_static_correction`         truncated modes + Wang's (1991) static correction
:func:`subspace`                        computed modes + deflated Neumann series, ONE
                                        factorisation (Rudisill & Chu 1975; Ting 1992)
:func:`adjoint`                         the same series for the measured dofs only: cost
                                        ∝ sensors × modes, independent of the parameters
:func:`finite_difference`               central differences with MAC tracking (test oracle)
:func:`restricted_derivatives`          repeated / close modes: the restricted eigenproblem's
                                        derivative (Mills-Curran 1988, Dailey 1989); every
                                        route above takes ``groups=`` (:mod:`.repeated`)
:func:`adjacent_eigenvectors`           Dailey's adjacent eigenvectors of a repeated eigenvalue
                                        and their derivatives along a direction
:func:`scaled_shape`                    derivative of a shape scaled as the test data are
:func:`jacobian`                        the updating Jacobian (any route above, "auto")
=====================================  ===================================================
"""

from .adjoint import adjoint
from .eigenvalue import eigenvalue_derivatives
from .finite_difference import finite_difference
from .jacobian import JacobianResult, jacobian
from .modal import modal, modal_static_correction
from .nelson import nelson
from .repeated import adjacent_eigenvectors, restricted_derivatives
from .scaling import scaled_shape
from .subspace import buffered_modes, subspace

__all__ = [
    "eigenvalue_derivatives", "nelson", "modal", "modal_static_correction", "subspace", "adjoint",
    "finite_difference", "scaled_shape", "jacobian", "JacobianResult", "buffered_modes", "restricted_derivatives",
    "adjacent_eigenvectors",
]
