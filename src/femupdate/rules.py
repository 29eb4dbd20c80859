r"""The rules of the modal updating problem, written once.

Every route that evaluates the modal updating problem — one local solve
(:class:`femupdate.updating.Problem`), the compiled batched route
(:mod:`femupdate.updating.batched`), uniqueness studies, multi-configuration updating — takes
these functions for:

* the map between the optimiser's variables x and the physical parameters p
  (:func:`to_p`, :func:`dp_dx`: ``relative`` x = p / ``|p_start|``, ``log`` x = ln p, ``absolute``);
* the checks of a computed spectrum (:func:`check_spectrum`: no negative eigenvalue, rigid-body
  eigenvalues set to exactly zero) and of a mode to be differentiated (:func:`check_distinct`); the
  group of close modes a mode belongs to (:func:`group_bounds`, in :mod:`femupdate.pairing_rules`);
* the pairing of test modes with model modes (:func:`pair_modes`, by the policy in
  :data:`PAIRINGS`): by MAC over each test mode's measured dofs (:func:`mac_vector`), the
  assignment maximising the total MAC (Hungarian algorithm, :func:`assign`), a test mode below
  ``min_mac`` failing and test modes without a shape taking the lowest free model modes in
  order (:func:`pair_by_mac`); by frequency order (:func:`pair_by_order`); by frequency, MAC
  breaking ties (:func:`pair_by_frequency`); or ``auto``, by order until the shapes show a
  swap — written in :mod:`femupdate.pairing_rules` and handed on here (the entry point outside
  the compiled kernels is :func:`femupdate.correlation.pair`);
* the scaling of a measured shape (:func:`shape_scale`: unit length with the sign of the largest
  entry, 1 at a reference dof, or 1 at the largest entry) and the sign that aligns a unit-length
  model shape with the test shape (:func:`unit_sign`);
* the residuals (:func:`eigenvalue_residual`, :func:`shape_residuals`)

  .. math:: r_\lambda = w_\lambda \frac{\lambda_A - \lambda_E}{\lambda_E}, \qquad
            r_\psi = w_\psi (\psi_A - \psi_E)

  (the normalised sensitivity equation of the reference paper, eq. 19; the reference-dof
  scaling is its eq. 33) and their exact derivatives given ∂λ/∂p and ∂φ/∂p at the measured dofs
  (:func:`eigenvalue_gradient`, :func:`shape_jacobian`): with ψ = φ_s / s(φ_s),
  ψ' = φ_s'/s − ψ s'/s;
* the MAC residuals of the ``"mac"`` formulation (:func:`mac_residuals`, :func:`mac_jacobian`):
  w (I − ê êᵀ) â, whose squared norm is w² (1 − MAC) (not compiled by the batched route, which
  implements the ``"shapes"`` formulation, but written in the same subset).

The functions are plain Python on NumPy arrays and scalars — no objects, no exceptions: a
failure is an error code (:data:`ERRORS`, turned into a message by :func:`message`).  They are
written in the subset of Python that numba compiles, and marked with :func:`rule`; the compiled
backend registers every rule with numba (``numba.extending.register_jitable``) when it is
imported, so that its kernels call these very functions.  Inner products go through
:func:`dot` (and :func:`dot_col`, :func:`sumsq_col` for matrix columns), the primitives with a
compiled implementation of their own (a sequential sum, so
that compiled results do not depend on a BLAS's summation order).  The marker, the primitives
and the error codes live in :mod:`femupdate._rulebase`, the pairing rules in
:mod:`femupdate.pairing_rules`; this module hands all their names on, so that every rule is a
name of :mod:`femupdate.rules` and importing it registers them all.  It does not import numba.
"""

from __future__ import annotations

import math

import numpy as np

from ._rulebase import (E_BAD_JACOBIAN, E_DEGENERATE, E_MASS_CHOL, E_MASS_DIAG, E_NEGATIVE, E_NO_MODE_LEFT,  # noqa: F401
                        E_NO_PAIR, E_NODE, E_NONFINITE, E_REPEATED, E_RIGID, ERRORS, OK, RULES, dot, dot_col, message,
                        rule, sumsq_col)
from .pairing_rules import (AUTO_MARGIN, AUTO_SWAP_MAC, FREQUENCY_WINDOW, PAIR_AUTO, PAIR_FREQUENCY,  # noqa: F401
                            PAIR_MAC, PAIR_ORDER, PAIRING_NAMES, PAIRINGS, assign, assign_rows, group_bounds, mac_value,
                            mac_vector, pair_by_frequency, pair_by_mac, pair_by_order, pair_modes, pairing_rule)

# ---------------------------------------------------------------------------------------------
# codes
# ---------------------------------------------------------------------------------------------
UNIT, REF, MAX = 0, 1, 2
#: shape scalings by name
SCALINGS = {"unit": UNIT, "ref": REF, "max": MAX}
RELATIVE, LOG, ABSOLUTE = 0, 1, 2
#: parametrisations by name
PARAMETRISATIONS = {"relative": RELATIVE, "log": LOG, "absolute": ABSOLUTE}
#: relative eigenvalue gap below which two modes count as repeated
REPEATED_TOL = 1e-8
#: relative eigenvalue gap below which neighbouring modes are differentiated, paired and compared as one
#: group by updating (:class:`femupdate.options.ModalOptions` ``close_modes``; :func:`group_bounds`)
CLOSE_TOL = 1e-2
#: an eigenvalue within this fraction of the pencil's scale is a rigid-body (zero) eigenvalue
RIGID_TOL = 1e-12
#: a mode whose strain energy ``|φᵀKφ|`` exceeds this fraction of ``|φ|ᵀ|K||φ|`` is elastic, however small
#: its eigenvalue is next to the pencil's largest single-dof quotient (:func:`restore_elastic`)
RIGID_ENERGY_TOL = 1e-11


# ---------------------------------------------------------------------------------------------
# parameters
# ---------------------------------------------------------------------------------------------
@rule
def to_p(code, x, scale):
    """Physical values of the updated parameters at the optimiser's variables ``x`` (L,);
    ``scale`` (L,) the ``|starting values|`` of the relative parametrisation.

    Parameters
    ----------
    code : int
        The parametrisation, a value of :data:`PARAMETRISATIONS`: ``RELATIVE`` (p = x·scale),
        ``LOG`` (p = exp x) or ``ABSOLUTE`` (p = x; any other code acts as ``ABSOLUTE``).
    x : numpy.ndarray of float, shape ``(L,)``
        The optimiser's variables.
    scale : numpy.ndarray of float, shape ``(L,)``
        ``|starting values|`` of the parameters (in their own units, e.g. N/m or kg); read only for
        ``RELATIVE``.

    Returns
    -------
    numpy.ndarray of float, shape ``(L,)``
        The physical parameter values p (a new array).
    """
    p = np.empty(x.size)
    for j in range(x.size):
        p[j] = x[j] * scale[j] if code == RELATIVE else (math.exp(x[j]) if code == LOG else x[j])
    return p


@rule
def dp_dx(code, x, scale):
    """∂p/∂x (L,), the diagonal of the parametrisation's Jacobian.

    Parameters
    ----------
    code : int
        The parametrisation, as in :func:`to_p`.
    x : numpy.ndarray of float, shape ``(L,)``
        The optimiser's variables.
    scale : numpy.ndarray of float, shape ``(L,)``
        ``|starting values|`` of the parameters; read only for ``RELATIVE``.

    Returns
    -------
    numpy.ndarray of float, shape ``(L,)``
        ``scale`` for ``RELATIVE``, exp x (= p) for ``LOG``, ones for ``ABSOLUTE`` (and any
        other code).
    """
    d = np.empty(x.size)
    for j in range(x.size):
        d[j] = scale[j] if code == RELATIVE else (math.exp(x[j]) if code == LOG else 1.0)
    return d


# ---------------------------------------------------------------------------------------------
# the spectrum
# ---------------------------------------------------------------------------------------------
@rule
def check_spectrum(lam, nm, pencil_scale):
    """Checks of the lowest ``nm`` eigenvalues ``lam`` (ascending); rigid-body ones set to 0 in
    place.  ``pencil_scale``: the largest single-dof Rayleigh quotient max ``|K_ii|`` / M_ii.

    Returns ``(code, value)``: ``E_NEGATIVE`` and the lowest eigenvalue when one lies below
    −1e-12 of the scale max(``|λ|``, pencil_scale), else ``OK``.

    Parameters
    ----------
    lam : numpy.ndarray of float, shape ``(≥ nm,)``
        Eigenvalues λ = ω² (rad²/s²), ascending.  When the check passes, every one of the first
        ``nm`` within :data:`RIGID_TOL` of the scale (in magnitude) is set to exactly 0 in place;
        on ``E_NEGATIVE`` ``lam`` is left unchanged.
    nm : int
        How many eigenvalues (the lowest) to check.
    pencil_scale : float
        max_i ``|K_ii|`` / M_ii (rad²/s²); the scale is max(pencil_scale, 1e-300, max ``|λ|``).

    Returns
    -------
    code : int
        ``E_NEGATIVE`` or ``OK``.
    value : float
        The lowest eigenvalue (rad²/s²) for ``E_NEGATIVE``, else 0.0.
    """
    scale = max(pencil_scale, 1e-300)
    low = 0.0
    for i in range(nm):
        scale = max(scale, abs(lam[i]))
        low = min(low, lam[i])
    if low < -RIGID_TOL * scale:
        return E_NEGATIVE, low
    for i in range(nm):
        if abs(lam[i]) <= RIGID_TOL * scale:
            lam[i] = 0.0
    return OK, 0.0


@rule
def restore_elastic(K, Phi, lam, computed, nm):
    """Undo :func:`check_spectrum`'s zero for each mode whose strain energy says it is elastic:
    the pencil's scale, max K_ii / M_ii, can be dominated by one penalty stiffness (a rigid link
    exported as a 1e10 spring) next to which a genuine first mode looks like round-off.  A
    rigid-body mode's strain energy φᵀKφ is round-off of its terms, ``|φ|ᵀ|K||φ|`` times about
    1e-16; an elastic mode's is far above :data:`RIGID_ENERGY_TOL` of it.

    Parameters
    ----------
    K : numpy.ndarray of float, shape ``(n, n)``
        The stiffness matrix (dense).
    Phi : numpy.ndarray of float, shape ``(n, ≥ nm)``
        The mode shapes, column by column.
    lam : numpy.ndarray of float, shape ``(≥ nm,)``
        The eigenvalues after :func:`check_spectrum`; an elastic one set to 0 gets its computed
        value back, in place.
    computed : numpy.ndarray of float, shape ``(≥ nm,)``
        The eigenvalues as computed (before :func:`check_spectrum`).
    nm : int
        How many (the lowest) to check.

    Returns
    -------
    None
    """
    n = K.shape[0]
    for i in range(nm):
        if lam[i] == 0.0 and computed[i] != 0.0:
            energy = 0.0
            total = 0.0
            for a in range(n):
                pa = Phi[a, i]
                if pa == 0.0:
                    continue
                for b in range(n):
                    kab = K[a, b]
                    if kab != 0.0:
                        energy += pa * kab * Phi[b, i]
                        total += abs(pa) * abs(kab) * abs(Phi[b, i])
            if total > 0.0 and abs(energy) > RIGID_ENERGY_TOL * total:
                lam[i] = computed[i]


@rule
def check_distinct(lam, nm, t):
    """Can mode ``t`` be differentiated?  ``lam`` the eigenvalues, the lowest ``nm`` computed.

    Returns ``(code, other)``: ``E_RIGID`` for a rigid-body mode, ``E_REPEATED`` and the first
    mode whose eigenvalue lies within :data:`REPEATED_TOL` (relative) of mode t's, else ``OK``.

    Parameters
    ----------
    lam : numpy.ndarray of float, shape ``(≥ nm,)``
        Eigenvalues (rad²/s²), rigid-body ones already exactly 0 (:func:`check_spectrum`).
    nm : int
        The number of computed eigenvalues: modes ``0 .. nm-1`` are compared with mode ``t``.
    t : int
        The 0-based mode to differentiate.

    Returns
    -------
    code : int
        ``E_RIGID`` when ``lam[t] == 0`` exactly; ``E_REPEATED`` when another of the ``nm``
        eigenvalues lies within ``REPEATED_TOL · max(|λ_t|, 1e-12 · max |λ|)`` of λ_t; else ``OK``.
    other : int
        The first such mode for ``E_REPEATED``, else ``t``.
    """
    scale = 1e-300
    for i in range(nm):
        scale = max(scale, abs(lam[i]))
    li = lam[t]
    if li == 0.0:
        return E_RIGID, t
    tol = REPEATED_TOL * max(abs(li), 1e-12 * scale)
    for j in range(nm):
        if j != t and abs(lam[j] - li) <= tol:
            return E_REPEATED, j
    return OK, t


# ---------------------------------------------------------------------------------------------
# shapes and residuals
# ---------------------------------------------------------------------------------------------
@rule
def shape_scale(scaling, phs, ref):
    """The scale s of a measured shape ``phs`` (n_s,) and the position k of its scaling entry:
    ``UNIT`` s = ±‖φ_s‖ with the sign of the largest entry (k the largest entry); ``REF``
    s = φ_s[ref]; ``MAX`` s = the largest-magnitude entry.  Returns ``(s, k, node)``, ``node``
    True when ``REF``/``MAX`` meets an entry not above 1e-12 of the largest (a node of the mode),
    or when the shape is zero at every measured dof (any scaling).

    The reference-dof scaling is the reference paper's eq. 33.

    Parameters
    ----------
    scaling : int
        ``UNIT``, ``REF`` or ``MAX`` (:data:`SCALINGS`); any other code acts as ``MAX``.
    phs : numpy.ndarray of float, shape ``(n_s,)``
        The shape at its measured dofs.
    ref : int
        0-based position of the reference dof within ``phs``; read only for ``REF``.

    Returns
    -------
    s : float
        The scale (divide the shape by it); 0.0 for a zero shape under ``UNIT``.
    k : int
        0-based position of the scaling entry: ``ref`` for ``REF``, else the first entry of
        largest magnitude.
    node : bool
        True when the shape cannot be scaled (see above).
    """
    amax = 0.0
    kmax = 0
    for i in range(phs.size):
        if abs(phs[i]) > amax:
            amax = abs(phs[i])
            kmax = i
    if scaling == UNIT:
        nrm = math.sqrt(dot(phs, phs))
        s = nrm if phs[kmax] > 0 else (-nrm if phs[kmax] < 0 else 0.0)
        return s, kmax, not nrm > 0  # a shape that is zero at every measured dof cannot be scaled
    k = ref if scaling == REF else kmax
    s = phs[k]
    return s, k, not (abs(s) > 1e-12 * amax)


@rule
def unit_sign(scaling, phs, s, psi_e):
    """−1 when the unit-length model shape φ_s/s points against the test shape ψ_E, else 1
    (always 1 for the other scalings, whose scale fixes the sign).

    Parameters
    ----------
    scaling : int
        ``UNIT``, ``REF`` or ``MAX`` (:data:`SCALINGS`).
    phs : numpy.ndarray of float, shape ``(n_s,)``
        The model shape at the measured dofs.
    s : float
        Its scale from :func:`shape_scale` (non-zero).
    psi_e : numpy.ndarray of float, shape ``(n_s,)``
        The scaled test shape.

    Returns
    -------
    float
        −1.0 when ``scaling == UNIT`` and φ_sᵀψ_E / s < 0, else 1.0.
    """
    if scaling != UNIT:
        return 1.0
    return -1.0 if dot(phs, psi_e) / s < 0 else 1.0


@rule
def n_shape_residuals(ns, ref):
    """Residuals of a shape measured at ``ns`` dofs: the reference entry (``ref`` >= 0) is 1 by
    construction and dropped.

    Parameters
    ----------
    ns : int
        The number of measured dofs of the shape.
    ref : int
        0-based position of the reference dof (``"ref"`` scaling), or −1 (other scalings).

    Returns
    -------
    int
        ``ns - 1`` when ``ref >= 0``, else ``ns``.
    """
    return ns - 1 if ref >= 0 else ns


@rule
def eigenvalue_residual(lam, lam_e, w):
    """w (λ_A − λ_E) / λ_E (paper eq. 19, normalised by the measured eigenvalue).

    Parameters
    ----------
    lam : float
        The model eigenvalue λ_A (rad²/s²).
    lam_e : float
        The measured eigenvalue λ_E (rad²/s²), non-zero.
    w : float
        The weight w_λ.

    Returns
    -------
    float
        The residual r_λ (dimensionless).
    """
    return w * (lam - lam_e) / lam_e


@rule
def eigenvalue_gradient(dlam, lam_e, w, dpdx, out):
    """∂r_λ/∂x (L,) from ∂λ/∂p ``dlam`` (L,) into ``out``.

    Parameters
    ----------
    dlam : numpy.ndarray of float, shape ``(L,)``
        ∂λ_A/∂p_j (rad²/s² per unit of each parameter).
    lam_e : float
        The measured eigenvalue λ_E (rad²/s²).
    w : float
        The weight w_λ.
    dpdx : numpy.ndarray of float, shape ``(L,)``
        ∂p/∂x (:func:`dp_dx`).
    out : numpy.ndarray of float, shape ``(L,)``
        Receives ``w · dlam[j] / lam_e · dpdx[j]``.

    Returns
    -------
    None
    """
    for j in range(dlam.size):
        out[j] = w * dlam[j] / lam_e * dpdx[j]


@rule
def shape_residuals(scaling, phs, psi_e, ref, w, out):
    """w (ψ_A − ψ_E) of a measured model shape ``phs`` against the scaled test shape ``psi_e``
    into ``out`` (:func:`n_shape_residuals` entries).  Returns the position of the scaling entry
    when it is a node of the mode (the residual is then undefined), else −1.

    With ψ_A = ±φ_s/s (:func:`shape_scale`, sign from :func:`unit_sign`): paper eq. 19, with the
    reference-dof scaling of eq. 33.

    Parameters
    ----------
    scaling : int
        ``UNIT``, ``REF`` or ``MAX`` (:data:`SCALINGS`).
    phs : numpy.ndarray of float, shape ``(n_s,)``
        The model shape at the test mode's measured dofs.
    psi_e : numpy.ndarray of float, shape ``(n_s,)``
        The scaled test shape ψ_E.
    ref : int
        0-based position of the reference dof (``REF``; its entry is dropped), or −1.
    w : float
        The weight w_ψ.
    out : numpy.ndarray of float, shape ``(≥ n_shape_residuals(n_s, ref),)``
        Receives ``w (ψ_A[i] − ψ_E[i])`` for every ``i != ref``, in order; untouched on a node.

    Returns
    -------
    int
        The 0-based position of the scaling entry when :func:`shape_scale` reports a node (or a
        zero shape), else −1.
    """
    s, k, node = shape_scale(scaling, phs, ref)
    if node:
        return k
    sign = unit_sign(scaling, phs, s, psi_e)
    o = 0
    for i in range(phs.size):
        if i != ref:
            out[o] = w * (sign * phs[i] / s - psi_e[i])
            o += 1
    return -1


@rule
def shape_jacobian(scaling, phs, dphs, psi_e, ref, w, dpdx, out):
    """∂r_ψ/∂x into ``out`` (n_shape_residuals, L) from the derivatives ``dphs`` (n_s, L) of the
    mass-normalised measured shape: ψ' = φ_s'/s − ψ s'/s, s' = φ_sᵀφ_s'/s for unit length and
    φ_k' for the reference and largest-entry scalings.

    The shape must have passed :func:`shape_residuals` (no node at the scaling entry): no check
    is made here.

    Parameters
    ----------
    scaling : int
        ``UNIT``, ``REF`` or ``MAX`` (:data:`SCALINGS`).
    phs : numpy.ndarray of float, shape ``(n_s,)``
        The mass-normalised model shape at the measured dofs.
    dphs : numpy.ndarray of float, shape ``(n_s, L)``
        ∂φ_s/∂p_j, one column per parameter.
    psi_e : numpy.ndarray of float, shape ``(n_s,)``
        The scaled test shape (for the sign of :func:`unit_sign`).
    ref : int
        0-based position of the reference dof (``REF``; its row is dropped), or −1.
    w : float
        The weight w_ψ.
    dpdx : numpy.ndarray of float, shape ``(L,)``
        ∂p/∂x (:func:`dp_dx`).
    out : numpy.ndarray of float, shape ``(≥ n_shape_residuals(n_s, ref), ≥ L)``
        Receives ∂r_ψ/∂x_j in column j, rows in the order of :func:`shape_residuals`.

    Returns
    -------
    None
    """
    s, k, node = shape_scale(scaling, phs, ref)
    sign = unit_sign(scaling, phs, s, psi_e)
    fct = w * sign / s
    for j in range(dphs.shape[1]):
        ds = dot_col(phs, dphs, j) / s if scaling == UNIT else dphs[k, j]
        o = 0
        for i in range(phs.size):
            if i != ref:
                out[o, j] = fct * (dphs[i, j] - phs[i] / s * ds) * dpdx[j]
                o += 1


@rule
def mac_residuals(phs, psi_e, w, out):
    """The MAC residuals of a measured model shape ``phs`` against the test shape ``psi_e`` into
    ``out`` (n_s entries): w (I − ê êᵀ) â, the part of the unit model shape â = ±φ_s/‖φ_s‖ (its
    sign toward the test shape) orthogonal to the unit test shape ê = ψ_E/‖ψ_E‖.  Their squared
    norm is exactly w² (1 − MAC): the cost ½‖r‖² adds w² (1 − MAC) / 2 per mode, a smooth
    function of the shapes whose Gauss–Newton curvature at a fit is that of the shape differences
    (the scalar residual w (1 − MAC) would add w² (1 − MAC)² / 2, flat to fourth order there).
    Independent of how either shape is scaled.  Returns 0 when the model shape is zero at every
    measured dof (the residual is then undefined), else −1.

    Parameters
    ----------
    phs : numpy.ndarray of float, shape ``(n_s,)``
        The model shape at the test mode's measured dofs.
    psi_e : numpy.ndarray of float, shape ``(n_s,)``
        The test shape (any scaling, not zero).
    w : float
        The weight w_ψ.
    out : numpy.ndarray of float, shape ``(≥ n_s,)``
        Receives ``w · sign · (φ_s[i]/‖φ_s‖ − c ψ_E[i]/‖ψ_E‖)``, c = φ_sᵀψ_E / (‖φ_s‖‖ψ_E‖) and
        sign = −1 when c < 0 else 1; untouched when the model shape is zero.

    Returns
    -------
    int
        0 when ‖φ_s‖ = 0, else −1.
    """
    nrm = math.sqrt(dot(phs, phs))
    if not nrm > 0:
        return 0
    ee = math.sqrt(dot(psi_e, psi_e))
    c = dot(phs, psi_e) / (nrm * ee)
    sign = -1.0 if c < 0 else 1.0
    for i in range(phs.size):
        out[i] = w * sign * (phs[i] / nrm - c * psi_e[i] / ee)
    return -1


@rule
def mac_jacobian(phs, dphs, psi_e, w, dpdx, out):
    """∂r/∂x of :func:`mac_residuals` into ``out`` (n_s, L) from the derivatives ``dphs``
    (n_s, L) of the model shape at the measured dofs: with u = φ_s/‖φ_s‖,
    ∂u/∂p_j = (φ_s' − u uᵀφ_s') / ‖φ_s‖, and r' = w · sign · (I − ê êᵀ) u'.

    The shape must have passed :func:`mac_residuals` (not zero): no check is made here.

    Parameters
    ----------
    phs : numpy.ndarray of float, shape ``(n_s,)``
        The model shape at the measured dofs (any scaling whose derivatives ``dphs`` are).
    dphs : numpy.ndarray of float, shape ``(n_s, L)``
        ∂φ_s/∂p_j, one column per parameter.
    psi_e : numpy.ndarray of float, shape ``(n_s,)``
        The test shape.
    w : float
        The weight w_ψ.
    dpdx : numpy.ndarray of float, shape ``(L,)``
        ∂p/∂x (:func:`dp_dx`).
    out : numpy.ndarray of float, shape ``(≥ n_s, ≥ L)``
        Receives ∂r/∂x_j in column j, rows in the order of :func:`mac_residuals`.

    Returns
    -------
    None
    """
    n = phs.size
    nrm = math.sqrt(dot(phs, phs))
    ee = math.sqrt(dot(psi_e, psi_e))
    sign = -1.0 if dot(phs, psi_e) < 0 else 1.0
    v = np.empty(n)
    for j in range(dphs.shape[1]):
        t = dot_col(phs, dphs, j) / nrm  # uᵀφ_s'
        s = 0.0
        for i in range(n):
            v[i] = (dphs[i, j] - phs[i] / nrm * t) / nrm
            s += psi_e[i] / ee * v[i]
        for i in range(n):
            out[i, j] = w * sign * (v[i] - psi_e[i] / ee * s) * dpdx[j]


__all__ = [
    "RULES", "rule", "dot", "dot_col", "sumsq_col", "SCALINGS", "PARAMETRISATIONS", "REPEATED_TOL", "CLOSE_TOL", "RIGID_TOL",
    "RIGID_ENERGY_TOL", "ERRORS", "message", "PAIRINGS", "PAIRING_NAMES", "to_p", "dp_dx", "check_spectrum",
    "restore_elastic", "check_distinct", "group_bounds", "mac_value", "mac_vector", "assign", "pair_by_mac", "pair_by_order",
    "pair_by_frequency", "pair_modes", "pairing_rule", "shape_scale", "unit_sign", "n_shape_residuals",
    "eigenvalue_residual", "eigenvalue_gradient", "shape_residuals", "shape_jacobian", "mac_residuals", "mac_jacobian",
]
