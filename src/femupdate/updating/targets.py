"""The measured modes of a modal updating problem in the flat layout every route reads
(:class:`Targets`), with their weights (:func:`modal_weights`) and scaled test shapes
(:func:`build_targets`)."""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import NamedTuple

import numpy as np

from .. import rules
from .._errors import InputError, NumericalError
from .._limits import MAX_MAGNITUDE
from ..sensitivity.subspace import buffered_modes
from ..dofs import canonical
from ..testdata import TestData


class Targets(NamedTuple):
    """The measured data of a modal updating problem in flat arrays — the one layout that every
    route reads (the compiled kernels too).

    The compiled route hands its kernels the same ``Targets`` (every data set's concatenated,
    field by field: :data:`TARGETS_PER_MODE`, :data:`TARGETS_PER_POSITION`): a new per-mode datum
    is a new field here, filled by :func:`build_targets` and read by the rules.

    Attributes
    ----------
    lam_e : numpy.ndarray, shape ``(T,)``
        Measured eigenvalues λ = ω² (rad²/s²) of the T test modes.
    w_lam : numpy.ndarray, shape ``(T,)``
        Weights of their eigenvalue residuals.
    w_psi : numpy.ndarray, shape ``(T,)``
        Weight of each mode's shape residuals.
    pptr : numpy.ndarray of int64, shape ``(T + 1,)``
        Test mode k's measured dofs are ``pos[pptr[k]:pptr[k + 1]]`` (none: frequency only).
    pos : numpy.ndarray of int64, shape ``(n_positions,)``
        Model dof indices of the measured shape entries, mode after mode.
    psi_e : numpy.ndarray, shape ``(n_positions,)``
        The scaled (real) test shapes at the same positions.
    ref : numpy.ndarray of int64, shape ``(T,)``
        Position of the reference dof within the mode's measured dofs for ``"ref"`` scaling
        (−1: none).
    nm : int
        The number of lowest model modes the test modes are paired among.
    """

    lam_e: np.ndarray
    w_lam: np.ndarray
    w_psi: np.ndarray
    pptr: np.ndarray
    pos: np.ndarray
    psi_e: np.ndarray
    ref: np.ndarray
    nm: int

    @property
    def n_test(self) -> int:
        """T, the number of test modes."""
        return int(self.lam_e.size)

    @property
    def shaped(self) -> np.ndarray:
        """(T,) bool: test modes compared by shape."""
        return np.diff(self.pptr) > 0

    def measured(self, k: int) -> slice:
        """Positions of test mode k's measured dofs in ``pos`` and ``psi_e``.

        Parameters
        ----------
        k : int
            Test mode (0-based).

        Returns
        -------
        slice
            ``slice(pptr[k], pptr[k + 1])`` (empty for a mode without shape).
        """
        return slice(int(self.pptr[k]), int(self.pptr[k + 1]))

    @property
    def n_residuals(self) -> int:
        """m, the length of the residual vector: one eigenvalue residual per test mode plus its
        shape entries, less the reference entry of each shape scaled by ``"ref"``."""
        ns = np.diff(self.pptr)
        return int(self.n_test + np.sum(ns) - np.sum((self.ref >= 0) & (ns > 0)))

    @property
    def n_independent(self) -> int:
        """Independent data: each mode's eigenvalue plus n_s − 1 shape entries (the scaling
        removes one)."""
        ns = np.diff(self.pptr)
        return int(self.n_test + np.sum(np.maximum(ns - 1, 0)))


#: the fields of :class:`Targets` with one entry per test mode, and with one per measured
#: (mode, dof) position
TARGETS_PER_MODE = ("lam_e", "w_lam", "w_psi", "ref")
TARGETS_PER_POSITION = ("pos", "psi_e")


def mode_uncertainty(data: TestData, weights: Mapping | None, measurement_std: Mapping | None,
                     use_shapes: bool = True) -> tuple[dict, dict | None]:
    """The caller's modal ``weights`` and ``measurement_std`` completed by the test data's
    per-mode values (:class:`~femupdate.testdata.MeasuredMode` ``std_eigenvalue``, ``std_shape``,
    ``weight``: the test-data file's ``std_frequency`` / ``std_eigenvalue``, ``std_shape``,
    ``weight``).

    Precedence: a key the caller gives (``measurement_std["eigenvalue"]``, ``weights["shape"]``,
    ...; on the command line ``--std-eigenvalue``, ``--std-shape``) replaces the data's per-mode
    values for that key; the data's fill the keys the caller leaves out.  A standard deviation
    from the data must then be stated for every mode it applies to (eigenvalue: every test mode;
    shape: every mode whose shape is compared); a weight from the data multiplies both residuals
    of its mode (1 for a mode without one).  Applying the result again changes nothing.

    Parameters
    ----------
    data : TestData
        The measured modes.
    weights, measurement_std : mapping or None
        As :func:`modal_weights` (a key with the value None counts as not given).
    use_shapes : bool, default True
        False: no shape is compared (the data's ``std_shape`` are not needed).

    Returns
    -------
    weights : dict
        ``{"eigenvalue": ..., "shape": ...}`` as given, per-mode arrays from the data where not.
    measurement_std : dict or None
        Likewise; None when neither the caller nor the data state one.

    Raises
    ------
    InputError
        A value of the caller's neither one number nor one per test mode; standard deviations
        in the data for some modes but not all that need one (naming the modes without).
    """
    modes = data.modes
    T = len(modes)
    w = {k: v for k, v in dict(weights or {}).items() if v is not None}
    std = {k: v for k, v in dict(measurement_std or {}).items() if v is not None}
    for name, given in (("weights", w), ("measurement_std", std)):
        for key in ("eigenvalue", "shape"):
            if key in given:
                shape = np.shape(given[key])
                if not (shape in ((), (1,)) or shape == (T,)):
                    raise InputError(f"{name}[{key!r}]: give one value or one per test mode ({T}), got "
                                     f"{'x'.join(map(str, shape))} values")
    compared = [use_shapes and m.has_shape and len(m.dofs) >= 2 for m in modes]
    for key, needed, option, in_file in (("eigenvalue", [True] * T, "--std-eigenvalue", "std_frequency or std_eigenvalue"),
                                         ("shape", compared, "--std-shape", "std_shape")):
        values = [getattr(m, f"std_{key}") for m in modes]
        if key in std or not any(v is not None for v, n in zip(values, needed) if n):
            continue
        missing = [k + 1 for k, (v, n) in enumerate(zip(values, needed)) if n and v is None]
        if missing:
            stated = [k + 1 for k, (v, n) in enumerate(zip(values, needed)) if n and v is not None]
            which = "test mode" + ("s" if len(missing) > 1 else "")
            raise InputError(f"the test data state {in_file} for {_modes(stated)} but not for {which} "
                             f"{', '.join(map(str, missing))}: state it for every mode"
                             f"{' whose shape is compared' if key == 'shape' else ''}, or give one value for all "
                             f"({option}, or measurement_std[{key!r}] in Python)")
        std[key] = np.array([1.0 if v is None else v for v in values], float)
    factors = [m.weight for m in modes]
    if any(v is not None for v in factors):
        arr = np.array([1.0 if v is None else v for v in factors], float)
        for key in ("eigenvalue", "shape"):
            w.setdefault(key, arr)
    return w, (std or None)


def _modes(numbers: list[int]) -> str:
    return f"test mode{'s' if len(numbers) > 1 else ''} {', '.join(map(str, numbers))}"


def modal_weights(weights: Mapping | None, measurement_std: Mapping | None):
    """User weights of the modal residuals divided by the measurement standard deviations where
    given: ``(weights, sigma)`` with ``sigma`` the checked ``measurement_std`` (or None).

    Parameters
    ----------
    weights : mapping or None
        ``{"eigenvalue": w, "shape": w}``, each a scalar or one value per test mode (a missing
        key: 1).
    measurement_std : mapping or None
        ``{"eigenvalue": std, "shape": std}``, each a scalar or one value per test mode; the
        eigenvalue's standard deviation is relative (of λ), the shape's absolute (of the
        scaled shape entries).  Other keys are kept in ``sigma`` but not applied.

    Returns
    -------
    weights : dict
        The weights, with each key that has a standard deviation divided by it (w / std).
    sigma : dict or None
        ``measurement_std`` as a dict, or None when it is empty or None.

    Raises
    ------
    InputError
        An unknown key in ``weights``; a standard deviation that is not positive.
    """
    w = dict(weights or {})
    unknown = sorted(set(w) - {"eigenvalue", "shape"})
    if unknown:
        raise InputError(f"unknown weight(s) {', '.join(unknown)}: use eigenvalue, shape")
    sigma = None
    if measurement_std:
        sigma = dict(measurement_std)
        for key in ("eigenvalue", "shape"):
            if key in sigma:
                if not np.all(np.asarray(sigma[key], float) > 0):
                    raise InputError(f"measurement_std[{key!r}] must be positive")
                w[key] = np.asarray(w.get(key, 1.0), float) / np.asarray(sigma[key], float)
    return w, sigma


def build_targets(model, data: TestData, shape_scaling: str, ref_dof: str | None, w_eigenvalue, w_shape,
                  use_shapes: bool, n_modes: int | None) -> Targets:
    """The :class:`Targets` of ``data`` for ``model``: test shapes scaled as the residuals
    compare them (complex shapes rotated to their largest entry and made real).

    Parameters
    ----------
    model : Model
        The model; the measured dofs are looked up in it.
    data : TestData
        The measured modes.
    shape_scaling : {"unit", "ref", "max"}
        Scaling of the shapes (:data:`SHAPE_SCALINGS`).
    ref_dof : str or None
        Reference dof of ``"ref"`` scaling (default: each mode's first measured dof).
    w_eigenvalue, w_shape : float or array_like, shape ``(T,)``
        Weights of the eigenvalue and of the shape residuals, one value or one per test mode.
    use_shapes : bool
        False: frequencies only (every mode's shape is ignored).
    n_modes : int or None
        Model modes to pair among (default ``max(2T, T + 6)``); capped at the model's dofs.

    Returns
    -------
    Targets
        Only shapes measured at two dofs or more are compared.

    Raises
    ------
    InputError
        No measured modes; a mode with zero (or negative) eigenvalue; weights neither one value
        nor one per test mode, negative or not finite; a measured dof not in the model; a
        reference dof the mode does not measure.
    NumericalError
        A test shape whose scaling entry is zero (a node of the mode).
    """
    if not data.modes:
        raise InputError("iterative modal updating needs measured modes (frequencies and optionally shapes)")
    lam_e = np.asarray(data.eigenvalues, float)
    if np.any(lam_e < 1 / MAX_MAGNITUDE):  # the relative residual (λ - λ_E) / λ_E would overflow
        bad = ", ".join(str(k + 1) for k in np.flatnonzero(lam_e < 1 / MAX_MAGNITUDE))
        raise InputError(f"test mode(s) {bad} have zero frequency (eigenvalue below {1 / MAX_MAGNITUDE:g}): rigid-body "
                         "modes cannot be used as updating targets")
    try:
        w_lam = np.broadcast_to(np.asarray(w_eigenvalue, float), lam_e.shape).copy()
        w_psi = np.broadcast_to(np.asarray(w_shape, float), lam_e.shape).copy()
    except ValueError:
        raise InputError(f"weights: give one value or one per test mode ({lam_e.size})") from None
    if not (np.all(np.isfinite(w_lam)) and np.all(w_lam >= 0) and np.all(np.isfinite(w_psi)) and np.all(w_psi >= 0)):
        raise InputError("weights must be finite and non-negative")
    code = rules.SCALINGS[shape_scaling]
    if ref_dof is not None:  # as the user may type it (" 1 : X"), checked once for every mode
        try:
            ref_dof = canonical(ref_dof)
        except InputError as exc:
            raise InputError(f"reference dof (--ref-dof): {exc}") from None
    pptr: list[int] = [0]
    pos: list[int] = []
    psi: list[float] = []
    ref: list[int] = []
    for k, m in enumerate(data.modes):
        r = -1
        if use_shapes and m.has_shape and len(m.dofs) >= 2:
            at = model.dof_index(m.dofs, f"test mode {k + 1} shape")
            phi = m.shape
            if np.iscomplexobj(phi):
                phi = np.real(phi * np.exp(-1j * np.angle(phi[np.argmax(np.abs(phi))])))
            phi = np.asarray(phi, float)
            if shape_scaling == "ref":
                label = m.reference_dof or ref_dof or m.dofs[0]
                if label not in m.dofs:
                    raise InputError(f"test mode {k + 1}: reference dof {label} is not measured")
                r = list(m.dofs).index(label)
            s, kk, node = rules.shape_scale(code, phi, r)
            if node:
                raise NumericalError(rules.message(rules.E_NODE, kk))
            pos.extend(int(i) for i in at)
            psi.extend(map(float, phi / s))
        ref.append(r)
        pptr.append(len(pos))
    plain = [k for k in range(lam_e.size) if pptr[k + 1] == pptr[k]]  # compared by frequency only
    for a, b in zip(plain, plain[1:]):
        if lam_e[b] < lam_e[a]:
            fa, fb = (math.sqrt(lam_e[i]) / (2 * math.pi) for i in (a, b))
            raise InputError(f"test modes without a shape are paired with the model's modes in order of frequency: list "
                             f"them by increasing frequency (test mode {b + 1} at {fb:.6g} Hz comes after test mode "
                             f"{a + 1} at {fa:.6g} Hz)")
    nm = min(model.n_dofs, n_modes or buffered_modes(lam_e.size))
    return Targets(lam_e, w_lam, w_psi, np.array(pptr, np.int64), np.array(pos, np.int64), np.array(psi, float),
                   np.array(ref, np.int64), int(nm))


__all__ = ["Targets", "TARGETS_PER_MODE", "TARGETS_PER_POSITION", "mode_uncertainty", "modal_weights", "build_targets"]
