r"""The modal updating problem: what is updated, against which data, by which rules.

A :class:`Problem` owns everything that defines the problem — the updated parameters and their
parametrisation, the measured eigenvalues and scaled shapes with their weights, the pairing
threshold, the number of model modes to pair among — and evaluates its residuals and exact
Jacobian at one point by the rules of :mod:`femupdate.rules` (paper eqs. 16–21; the residual
vector stacks, per test mode, its relative eigenvalue error and its scaled shape differences).
The drivers consume it: :func:`~femupdate.updating.solve` (one local solve),
:func:`~femupdate.updating.multistart` and the compiled batched route
(:mod:`femupdate.updating.batched`, which compiles the same rules and reads the same
:class:`Targets`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import NamedTuple

import numpy as np

from .. import rules
from .._errors import InputError, NumericalError
from .._limits import MAX_MAGNITUDE
from ..modal import Modes, model_modes
from ..sensitivity import eigenvalue_derivatives
from ..sensitivity.jacobian import METHODS as SENSITIVITY_METHODS
from ..sensitivity.jacobian import jacobian as sensitivity_jacobian
from ..sensitivity.subspace import buffered_modes
from ..testdata import TestData

PARAMETRISATIONS = tuple(rules.PARAMETRISATIONS)  #: ``("relative", "log", "absolute")``
SHAPE_SCALINGS = tuple(rules.SCALINGS)  #: ``("unit", "ref", "max")``
SENSITIVITY_CHOICES = SENSITIVITY_METHODS  #: ``"auto"``, ``"nelson"``, ``"modal"``, ... (the Jacobian's route)


class Parametrisation:
    """The optimiser's variables x and the full parameter vector p.

    Parameters
    ----------
    model : Model
        The model whose parameters are updated (names are looked up in it).
    names : sequence of str
        The updated parameters, in the order of x (L of them).
    kind : {"relative", "log", "absolute"}
        ``"relative"`` (x = p / |p_start|, the default of every driver), ``"log"`` (x = ln p)
        or ``"absolute"`` (x = p).
    p_base : array_like, shape ``(n_parameters,)``
        Full parameter vector: the starting values of ``names`` and the values of every other
        parameter, which stay fixed.

    Attributes
    ----------
    names : tuple of str
        The updated parameters.
    idx : numpy.ndarray of intp, shape ``(L,)``
        Their positions in the model's parameter vector.
    param : str
        The parametrisation ``kind``.
    p_base : numpy.ndarray, shape ``(n_parameters,)``
        The full parameter vector at the start (float copy).
    scale : numpy.ndarray, shape ``(L,)``
        |p_start| of each updated parameter (1 where the start is 0): the divisor of the
        ``"relative"`` parametrisation.

    Raises
    ------
    InputError
        An unknown ``kind``, or a name that is not a parameter of ``model``.
    """

    def __init__(self, model, names: Sequence[str], kind: str, p_base: np.ndarray):
        if kind not in rules.PARAMETRISATIONS:
            raise InputError(f"unknown parametrisation {kind!r}: use {', '.join(PARAMETRISATIONS)}")
        self.idx = np.array(model.parameter_indices(names, "updated parameters (--params)"), dtype=np.intp)
        self.names = tuple(names)
        self.param = kind
        self.code = rules.PARAMETRISATIONS[kind]
        self.p_base = np.asarray(p_base, float)
        start = self.p_base[self.idx]
        self.scale = np.where(start != 0, np.abs(start), 1.0)

    def to_p(self, x: np.ndarray) -> np.ndarray:
        """Full parameter vector at the variables x.

        Parameters
        ----------
        x : array_like, shape ``(L,)``
            The optimiser's variables.

        Returns
        -------
        numpy.ndarray, shape ``(n_parameters,)``
            ``p_base`` with the updated parameters' values at x (physical units); a new array.
        """
        p = self.p_base.copy()
        p[self.idx] = rules.to_p(self.code, np.asarray(x, float), self.scale)
        return p

    def dp_dx(self, x: np.ndarray) -> np.ndarray:
        """∂p/∂x of the updated parameters, the diagonal of the parametrisation's Jacobian.

        Parameters
        ----------
        x : array_like, shape ``(L,)``
            The optimiser's variables.

        Returns
        -------
        numpy.ndarray, shape ``(L,)``
            ``scale`` (relative), exp(x) = p (log) or 1 (absolute).
        """
        return rules.dp_dx(self.code, np.asarray(x, float), self.scale)

    def from_p(self, p_sel) -> np.ndarray:
        """The variables x of the updated parameters' values ``p_sel``.

        Parameters
        ----------
        p_sel : array_like, shape ``(L,)``
            Values of the updated parameters (physical units), in the order of ``names``.

        Returns
        -------
        numpy.ndarray, shape ``(L,)``

        Raises
        ------
        InputError
            A value that is not positive under the ``"log"`` parametrisation.
        """
        p_sel = np.asarray(p_sel, float)
        if self.param == "log" and np.any(p_sel <= 0):
            raise InputError("log parametrisation needs positive parameter values and bounds")
        return x_of_p(self.param, p_sel, self.scale)

    @property
    def start(self) -> np.ndarray:
        """Starting values of the updated parameters (L,)."""
        return self.p_base[self.idx].copy()

    @property
    def x_start(self) -> np.ndarray:
        """The variables x (L,) at the start."""
        return self.from_p(self.start)

    def bounds_x(self, lo: np.ndarray, hi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Bounds of x from the updated parameters' bounds (:func:`x_bounds`).

        Parameters
        ----------
        lo, hi : array_like, shape ``(L,)``
            Lower and upper bounds of the updated parameters (physical units; may be infinite).

        Returns
        -------
        xl, xh : numpy.ndarray, shape ``(L,)``
            Lower and upper bounds of x.
        """
        return x_bounds(self.param, lo, hi, self.scale)


def x_of_p(kind: str, p, scale) -> np.ndarray:
    """The optimiser's variables of the values ``p`` of the updated parameters, for any shape
    that broadcasts with ``scale`` (|start| of each parameter; one row per start if 2-D).

    Parameters
    ----------
    kind : {"relative", "log", "absolute"}
        The parametrisation.
    p : array_like, shape ``(L,)`` or ``(n_starts, L)``
        Parameter values (physical units).
    scale : array_like, shape ``(L,)``
        |p_start| of each parameter (used by ``"relative"`` only).

    Returns
    -------
    numpy.ndarray, shape of ``p``
        p / scale (relative), ln p (log; −inf or NaN for p <= 0, without a warning) or a copy
        of p (absolute).
    """
    if kind == "relative":
        return np.asarray(p, float) / scale
    if kind == "log":
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.log(np.asarray(p, float))
    return np.array(p, float)


def x_bounds(kind: str, lo, hi, scale) -> tuple[np.ndarray, np.ndarray]:
    """Bounds of the optimiser's variables from the parameters' bounds ``lo``, ``hi``.

    Parameters
    ----------
    kind : {"relative", "log", "absolute"}
        The parametrisation.
    lo, hi : array_like, shape ``(L,)``
        Lower and upper bounds of the parameters (physical units; may be infinite).
    scale : array_like, shape ``(L,)``
        |p_start| of each parameter (used by ``"relative"`` only).

    Returns
    -------
    xl, xh : numpy.ndarray, shape ``(L,)``
        Lower and upper bounds of the variables: ln(max(lo, 0)) and ln(hi) for ``"log"`` (−inf
        for a lower bound of 0); otherwise the mapped bounds, ordered element-wise (a negative
        start flips the relative ones).
    """
    if kind == "log":
        with np.errstate(divide="ignore"):
            return np.log(np.maximum(lo, 0)), np.log(hi)
    xl, xh = x_of_p(kind, lo, scale), x_of_p(kind, hi, scale)
    return np.minimum(xl, xh), np.maximum(xl, xh)  # a negative start flips the relative ones


def start_error(names: Sequence[str], start, lo, hi, kind: str) -> str | None:
    """Why the start ``start`` of ``names`` cannot be solved from (None when it can).

    Parameters
    ----------
    names : sequence of str
        The updated parameters.
    start : array_like, shape ``(L,)``
        Their starting values (physical units).
    lo, hi : array_like, shape ``(L,)``
        Their bounds.
    kind : {"relative", "log", "absolute"}
        The parametrisation.

    Returns
    -------
    str or None
        The reason — starting values outside the bounds (named), or, for ``"log"``, a
        starting value <= 0 or a negative lower bound — or None.
    """
    outside = [n for n, v, a, b in zip(names, start, lo, hi) if not a <= v <= b]
    if outside:
        return f"starting value(s) outside the bounds for: {', '.join(outside)}"
    if kind == "log" and (np.any(np.asarray(start) <= 0) or np.any(np.asarray(lo) < 0)):
        return "log parametrisation needs positive starting values and non-negative lower bounds"
    return None


def check_determined(problem: Problem) -> None:
    """Refuse a problem with fewer independent data than updated parameters.

    Parameters
    ----------
    problem : Problem
        The modal problem; its ``targets.n_independent`` is compared with ``len(problem.names)``.

    Raises
    ------
    InputError
        Fewer independent data (eigenvalues and scaled shape entries) than parameters.
    """
    n_data = problem.targets.n_independent
    if n_data < len(problem.names):
        raise InputError(
            f"{len(problem.names)} parameters but only {n_data} independent data (eigenvalues and scaled shape "
            "entries): the problem is underdetermined; add data, fix parameters, or use regularization "
            "(e.g. --regularization gcv)"
        )


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


class Problem(Parametrisation):
    """The modal updating problem of ``model`` against the measured modes of ``data``.

    The residual vector stacks, per test mode, its relative eigenvalue error and its scaled
    shape differences (paper eqs. 16–21, :mod:`femupdate.rules`).

    Parameters
    ----------
    model : Model
        The model to update.
    data : TestData
        Measured modes; a shape may be partial (any subset of the model's dofs, any scaling).
    params : sequence of str, optional
        Names of the parameters to update (default: every parameter not ``fixed``).
    x0 : mapping of str to float, optional
        Starting values ``{name: value}`` (default: the model's nominal values, or ``values``).
    values : None, mapping of str to float, or array_like of shape ``(n_parameters,)``, optional
        Values of the parameters that are not updated (default: nominal).
    shape_scaling : {"unit", "ref", "max"}, default ``"unit"``
        ``"unit"`` (unit length over the measured dofs), ``"ref"`` (1 at ``ref_dof``: the
        paper's eq. 33) or ``"max"`` (1 at the largest entry).
    ref_dof : str, optional
        Reference dof of ``"ref"`` scaling (default: the first measured dof of each mode).
    weights, measurement_std : mapping, optional
        See :func:`modal_weights`; each entry a single value or one per test mode.
    min_mac : float, default 0.5
        Pairing threshold in [0, 1]; a test mode with a shape must reach it with its model mode.
    n_modes : int, optional
        Model modes computed and paired among (default ``max(2T, T + 6)`` for T test modes,
        capped at the model's dofs).
    parametrisation : {"relative", "log", "absolute"}, default ``"relative"``
        See :class:`Parametrisation`.
    use_shapes : bool, default True
        False: frequencies only.
    sensitivity : str, default ``"auto"``
        The derivative route of the local Jacobian (:data:`SENSITIVITY_CHOICES`,
        :func:`femupdate.sensitivity.jacobian`; the compiled route always uses the exact
        complete modal method).

    Attributes
    ----------
    model : Model
    data : TestData
    targets : Targets
        The measured data in flat arrays (:func:`build_targets`).
    n_residuals : int
        m, the length of the residual vector.
    n_modes : int
        Model modes computed and paired among.
    sigma : dict or None
        The stated ``measurement_std`` (the covariance of the diagnostics is then absolute).
    sensitivity_used : str
        The derivative route of the last Jacobian (``"auto"`` resolved; ``"fox-kapoor"`` when no
        shape is compared).
    swaps : list of dict
        Mode swaps seen while evaluating (``evaluation``, ``test_mode``, ``from_model_mode``,
        ``to_model_mode``; 0-based modes).
    nfev : int
        Residual evaluations so far.

    Raises
    ------
    InputError
        An unknown ``shape_scaling``, ``sensitivity`` or ``parametrisation``; ``min_mac`` not a
        number in [0, 1]; no parameters to update; bad weights, standard deviations or data (as
        :func:`modal_weights`, :func:`build_targets`).
    NumericalError
        A test shape whose scaling entry is zero.
    """

    def __init__(self, model, data: TestData, params: Sequence[str] | None = None, *,
                 x0: Mapping[str, float] | None = None, values=None, shape_scaling: str = "unit",
                 ref_dof: str | None = None, weights: Mapping | None = None, measurement_std: Mapping | None = None,
                 min_mac: float = 0.5, n_modes: int | None = None, parametrisation: str = "relative",
                 use_shapes: bool = True, sensitivity: str = "auto"):
        if shape_scaling not in rules.SCALINGS:
            raise InputError(f"unknown shape scaling {shape_scaling!r}: use {', '.join(SHAPE_SCALINGS)}")
        if sensitivity not in SENSITIVITY_CHOICES:
            raise InputError(f"unknown sensitivity method {sensitivity!r}: use {', '.join(SENSITIVITY_CHOICES)}")
        try:
            min_mac = float(min_mac)
        except (TypeError, ValueError):
            raise InputError(f"min_mac must be a number between 0 and 1, got {min_mac!r}") from None
        if not 0.0 <= min_mac <= 1.0:
            raise InputError(f"min_mac must be a number between 0 and 1, got {min_mac!r}")
        names = list(params) if params is not None else [model.parameter_names[j] for j in model.free]
        if not names:
            raise InputError("no parameters to update: every parameter is fixed")
        p_base = model.resolve(values)
        for name, v in dict(x0 or {}).items():
            p_base[model.parameter_index(name)] = float(v)
        super().__init__(model, names, parametrisation, p_base)
        w, self.sigma = modal_weights(weights, measurement_std)
        self.model = model
        self.data = data
        self.scaling = shape_scaling
        self.scaling_code = rules.SCALINGS[shape_scaling]
        self.min_mac = float(min_mac)
        self.sensitivity = sensitivity
        self.sensitivity_used = sensitivity
        self.targets = build_targets(model, data, shape_scaling, ref_dof, w.get("eigenvalue", 1.0),
                                     w.get("shape", 1.0), use_shapes, n_modes)
        self.n_modes = self.targets.nm
        self.n_residuals = self.targets.n_residuals
        tg = self.targets
        self.any_shape = bool(tg.shaped.any())
        if self.sigma is not None and "eigenvalue" not in self.sigma or (
                self.sigma is not None and self.any_shape and "shape" not in self.sigma):
            # the covariance is absolute only when every residual is divided by its stated std
            self.sigma = None
        self.sensors = np.unique(tg.pos) if tg.pos.size else np.zeros(0, np.int64)  # where shape derivatives are needed
        self._cache_key: bytes | None = None
        self._cache: tuple = ()
        self._pairs_seen: dict[int, int] = {}
        self.swaps: list[dict] = []
        self.nfev = 0

    # ------------------------------------------------------------------ evaluation
    def evaluate(self, x) -> tuple[np.ndarray, Modes, list[tuple[int, int, float]]]:
        """Parameters, model modes and pairs at x (cached: the last x is not recomputed).

        Parameters
        ----------
        x : array_like, shape ``(L,)``
            The optimiser's variables.

        Returns
        -------
        p : numpy.ndarray, shape ``(n_parameters,)``
            The full parameter vector.
        modes : Modes
            The lowest ``n_modes`` model modes (eigenvalues in rad²/s², mass-normalised shapes).
        pairs : list of (int, int, float)
            ``(test mode, model mode, MAC)`` per test mode, 0-based; MAC NaN without shape.

        Raises
        ------
        NumericalError
            A test mode cannot be paired (MAC below ``min_mac``, or no model mode left).
        """
        x = np.asarray(x, float)
        key = x.tobytes()
        if key == self._cache_key:
            return self._cache
        p = self.to_p(x)
        modes = model_modes(self.model, p, n_modes=self.n_modes)
        pairs = self._pair(modes)
        self._cache_key, self._cache = key, (p, modes, pairs)
        return self._cache

    def _pair(self, modes: Modes) -> list[tuple[int, int, float]]:
        tg = self.targets
        T, nm = tg.n_test, min(tg.nm, modes.n_modes)
        shaped = tg.shaped
        MAC = np.zeros((T, max(nm, 1)))
        for k in map(int, np.flatnonzero(shaped)):
            sl = tg.measured(k)
            rules.mac_vector(tg.psi_e[sl], modes.shapes[tg.pos[sl], :nm], MAC[k, :nm])
        pairs = np.zeros(T, np.int64)
        bad = np.zeros(T, np.bool_)
        code, i = rules.pair_by_mac(MAC, shaped, nm, self.min_mac, pairs, bad)
        if code != rules.OK:
            raise NumericalError(rules.message(code, i, modes=np.flatnonzero(bad), min_mac=self.min_mac))
        out = [(k, int(pairs[k]), float(MAC[k, pairs[k]]) if shaped[k] else math.nan) for k in range(T)]
        for k, j, _ in out:
            if k in self._pairs_seen and self._pairs_seen[k] != j:
                self.swaps.append({"evaluation": self.nfev, "test_mode": k, "from_model_mode": self._pairs_seen[k],
                                   "to_model_mode": j})
            self._pairs_seen[k] = j
        return out

    def residuals(self, x) -> np.ndarray:
        """The residual vector at x: per test mode its eigenvalue residual
        w (λ_A − λ_E) / λ_E, then its shape residuals w (ψ_A − ψ_E) (paper eq. 19,
        :mod:`femupdate.rules`).

        Parameters
        ----------
        x : array_like, shape ``(L,)``
            The optimiser's variables.

        Returns
        -------
        numpy.ndarray, shape ``(m,)``
            Dimensionless residuals (``m = n_residuals``).

        Raises
        ------
        NumericalError
            Unpaired test modes; a model shape whose scaling entry is zero; non-finite residuals.
        """
        self.nfev += 1
        p, modes, pairs = self.evaluate(x)
        tg = self.targets
        r = np.zeros(self.n_residuals)
        row = 0
        for k, j, _ in pairs:
            r[row] = rules.eigenvalue_residual(modes.eigenvalues[j], tg.lam_e[k], tg.w_lam[k])
            row += 1
            sl = tg.measured(k)
            if sl.stop > sl.start:
                n = rules.n_shape_residuals(sl.stop - sl.start, tg.ref[k])
                node = rules.shape_residuals(self.scaling_code, modes.shapes[tg.pos[sl], j], tg.psi_e[sl], tg.ref[k],
                                             tg.w_psi[k], r[row:row + n])
                if node >= 0:
                    raise NumericalError(rules.message(rules.E_NODE, node))
                row += n
        if not np.all(np.isfinite(r)):
            raise NumericalError(rules.message(rules.E_NONFINITE))
        return r

    def jacobian(self, x) -> np.ndarray:
        """The exact Jacobian ∂r/∂x at x, the derivatives by the route ``sensitivity``
        (eigenvalue derivatives only when no shape is compared).

        Parameters
        ----------
        x : array_like, shape ``(L,)``
            The optimiser's variables.

        Returns
        -------
        numpy.ndarray, shape ``(m, L)``
            Rows in the order of :meth:`residuals`; sets ``sensitivity_used``.

        Raises
        ------
        NumericalError
            Unpaired test modes (as :meth:`evaluate`).
        """
        p, modes, pairs = self.evaluate(x)
        tg = self.targets
        which = [j for _, j, _ in pairs]
        if self.any_shape:
            # mass-normalised derivatives at the measured dofs only, by the route asked for
            sens = sensitivity_jacobian(self.model, modes, which, self.sensors, params=self.idx, values=p,
                                        method=self.sensitivity, shape_scaling="mass", relative_eigenvalues=False)
            dlam, dphi = sens.dlam, sens.dpsi
            self.sensitivity_used = sens.method
        else:
            dlam, dphi = eigenvalue_derivatives(self.model, modes, which, self.idx), None
            self.sensitivity_used = "fox-kapoor"
        dpdx = self.dp_dx(x)
        J = np.zeros((self.n_residuals, self.idx.size))
        row = 0
        for c, (k, j, _) in enumerate(pairs):
            rules.eigenvalue_gradient(dlam[c], tg.lam_e[k], tg.w_lam[k], dpdx, J[row])
            row += 1
            sl = tg.measured(k)
            if sl.stop > sl.start:
                n = rules.n_shape_residuals(sl.stop - sl.start, tg.ref[k])
                at = np.searchsorted(self.sensors, tg.pos[sl])
                assert dphi is not None  # a shape is measured: the derivatives were computed
                rules.shape_jacobian(self.scaling_code, modes.shapes[tg.pos[sl], j], dphi[at, c, :], tg.psi_e[sl],
                                     tg.ref[k], tg.w_psi[k], dpdx, J[row:row + n])
                row += n
        return J

    def mac_of_pair(self, modes: Modes, k: int, j: int) -> float:
        """MAC of test mode k with model mode j (NaN for a test mode without shape).

        Parameters
        ----------
        modes : Modes
            Model modes (as :meth:`evaluate` returns them).
        k : int
            Test mode (0-based).
        j : int
            Model mode (0-based column of ``modes.shapes``).

        Returns
        -------
        float
            MAC in [0, 1] over the test mode's measured dofs.
        """
        tg = self.targets
        sl = tg.measured(k)
        if sl.stop == sl.start:
            return math.nan
        out = np.zeros(1)
        rules.mac_vector(tg.psi_e[sl], modes.shapes[tg.pos[sl], j:j + 1], out)
        return float(out[0])


__all__ = ["Problem", "Parametrisation", "Targets", "x_of_p", "x_bounds", "start_error", "check_determined", "modal_weights", "build_targets", "PARAMETRISATIONS",
           "SHAPE_SCALINGS", "SENSITIVITY_CHOICES"]
