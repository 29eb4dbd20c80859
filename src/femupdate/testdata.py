"""Measured test data: modes, frequency response functions and static deflections.

Every array with a dof axis travels with its labels.  These are plain value objects; the
readers in :mod:`femupdate.io` build them from JSON and universal files.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

from ._checks import array_arg, input_errors, mapping_arg, number_arg, shown, str_arg, strings_arg
from ._errors import InputError
from ._limits import MAX_MAGNITUDE
from .dofs import canonical_all, describe


def _finite(arr: np.ndarray, what: str, dofs: Sequence[str] | None = None) -> None:
    for bad, kind in ((~np.isfinite(arr), "NaN or infinite value(s)"),
                      (np.abs(arr) > MAX_MAGNITUDE, f"value(s) above {MAX_MAGNITUDE:g} in magnitude")):
        if np.any(bad):
            if dofs is not None and arr.ndim >= 1 and arr.shape[-1] == len(dofs):
                cols = np.flatnonzero(bad.reshape(-1, len(dofs)).any(axis=0))
                raise InputError(f"{what}: {kind} at dof(s) {describe([dofs[int(c)] for c in cols])}")
            raise InputError(f"{what}: {kind}")


def _finite_number(v, what: str) -> float:
    """``v`` as a float if it is a finite real number (booleans and strings refused), else an
    :class:`InputError` naming ``what``."""
    if isinstance(v, (bool, np.bool_, str)) or not isinstance(v, (int, float, np.integer, np.floating)):
        raise InputError(f"{what}: expected a number, got {v!r}")
    x = float(v)
    if not math.isfinite(x):
        raise InputError(f"{what}: NaN or infinite value")
    return x


def positive(v, what: str) -> float:
    """``v`` as a float if it is a number between 1e-150 and 1e150 (a standard deviation or a
    weight: it divides or multiplies residuals), else an :class:`InputError` naming ``what``.

    Parameters
    ----------
    v : object
        The value.
    what : str
        How the message names it (``"mode 2: std_shape"``).

    Returns
    -------
    float

    Raises
    ------
    InputError
        Not a real number (booleans and strings refused), not finite, not > 0, below 1e-150 or
        above 1e150.
    """
    x = _finite_number(v, what)
    if not x > 0:
        raise InputError(f"{what}: {x:g} is not > 0")
    if x < 1.0 / MAX_MAGNITUDE or x > MAX_MAGNITUDE:
        raise InputError(f"{what}: {x:g} is outside [{1.0 / MAX_MAGNITUDE:g}, {MAX_MAGNITUDE:g}]")
    return x


def check_damping_ratio(v, what: str) -> float:
    """``v`` as a float if it is a modal damping ratio: a finite number in [0, 1) (fraction of
    critical damping), else an :class:`InputError` naming ``what``.

    Parameters
    ----------
    v, what
        As :func:`positive` (``what``: ``"modes[2] damping_ratio"``).

    Returns
    -------
    float

    Raises
    ------
    InputError
        Not a real number (booleans and strings refused), not finite, negative, or 1 or more
        (critically or over-damped: no vibration mode).
    """
    x = _finite_number(v, what)
    if not 0 <= x < 1:
        raise InputError(f"{what}: {x:g} is not a damping ratio in [0, 1) (a fraction of critical damping: 0.02 "
                         "is 2 %)")
    return x



def check_std_damping_ratio(v, what: str) -> float:
    """``v`` as a float if it is a standard deviation of a damping ratio: finite, > 0 and below 1
    (a fraction of critical damping, like the ratio), else an :class:`InputError` naming ``what``;
    1 or more is flagged as a percentage."""
    x = positive(v, what)
    if x >= 1:
        raise InputError(f"{what}: {x:g} is not below 1: the standard deviation of a damping ratio is a fraction of "
                         f"critical damping like the ratio (0.5 % is 0.005); it looks like a percentage, write "
                         f"{x / 100:g}")
    return x

@dataclass(frozen=True)
class MeasuredMode:
    """One measured mode: eigenvalue (rad^2/s^2) and an optional partial shape.

    ``shape`` values are in any scaling; real or complex (complex modes from a damped
    structure are accepted and compared through their real-normalised form where needed).

    Parameters
    ----------
    eigenvalue : float
        Measured eigenvalue λ = ω² in rad²/s², finite and ≥ 0 (see :meth:`from_frequency` to give
        a frequency in Hz).
    dofs : sequence of str, default ``()``
        Labels ``"node:dir"`` of the measured shape entries (empty: no shape measured).
    shape : array_like, shape ``(len(dofs),)``
        Shape values at ``dofs``, real or complex, finite, not all zero.
    label : str, default ``""``
        Name of the mode, used in messages.
    reference_dof : str, optional
        The measured dof at which this mode's shape is scaled to 1 when shapes are compared with
        ``"ref"`` scaling (paper eq. 33); default: the updating option's ``ref_dof``, else the
        first measured dof.
    std_eigenvalue : float, optional
        Relative standard deviation of the measured eigenvalue, σ_λ / λ (a relative standard
        deviation of the frequency σ_f / f is 2 σ_f / f here, to first order:
        :meth:`from_frequency` converts it).  Updating divides this mode's eigenvalue residual
        by it, unless ``measurement_std["eigenvalue"]`` (``--std-eigenvalue``) is given.
    std_shape : float, optional
        Standard deviation of this mode's scaled shape entries (absolute, in the units of the
        scaled shape); updating divides its shape residuals by it, unless
        ``measurement_std["shape"]`` (``--std-shape``) is given.
    weight : float, optional
        Factor on this mode's residuals (eigenvalue and shape) in updating, unless the caller's
        ``weights`` give that kind's; default 1.
    damping_ratio : float, optional
        Measured modal damping ratio ζ (viscous, fraction of critical: 0.02 is 2 %), 0 <= ζ < 1.
        Carried and reported; compared with the model's modal damping where the model has
        damping (Rayleigh ζ = α/2ω + βω/2, hysteretic ζ = η/2 at resonance); it does not enter
        the modal residuals.
    std_damping_ratio : float, optional
        Standard deviation of ``damping_ratio`` (absolute, as ζ itself: 0.002 is 0.2 % of
        critical); needs ``damping_ratio``.

    Raises
    ------
    InputError
        Negative or non-finite eigenvalue; invalid dof labels; a shape of the wrong length,
        non-finite, zero at every measured dof, or too small to compute with (every value below
        1e-150 in magnitude); a ``reference_dof`` that is not measured or
        where the shape is zero; a standard deviation or weight that is not a finite number
        between 1e-150 and 1e150; a damping ratio that is not a finite number in [0, 1), or its
        standard deviation without it.
    """

    eigenvalue: float
    dofs: tuple[str, ...] = ()
    shape: np.ndarray = field(default_factory=lambda: np.zeros(0))
    label: str = ""
    reference_dof: str | None = None
    std_eigenvalue: float | None = None
    std_shape: float | None = None
    weight: float | None = None
    damping_ratio: float | None = None
    std_damping_ratio: float | None = None

    def __post_init__(self):
        with input_errors():
            where = f"MeasuredMode {self.label}".rstrip() if isinstance(self.label, str) else "MeasuredMode"
            number_arg(self.eigenvalue, "eigenvalue (rad²/s²)", where)
            strings_arg(self.dofs, "dofs", where, optional=False, what="dof label")
            array_arg(self.shape, "shape", where, complex_ok=True, finite=False)
            str_arg(self.label, "label", "MeasuredMode")
            str_arg(self.reference_dof, "reference_dof", where, optional=True)
        lam = float(self.eigenvalue)
        if not math.isfinite(lam) or lam < 0:
            raise InputError(f"mode {self.label or ''}: eigenvalue {lam!r} must be finite and >= 0".replace("  ", " "))
        dofs = canonical_all(self.dofs, f"mode {self.label} shape")
        shape = np.asarray(self.shape)
        shape = shape.astype(complex if np.iscomplexobj(shape) else float)
        if shape.shape != (len(dofs),):
            raise InputError(f"mode {self.label}: {len(dofs)} dofs but shape has {shape.shape} entries")
        _finite(shape, f"mode {self.label} shape", dofs)
        if len(dofs) and not np.any(shape != 0):
            raise InputError(f"mode {self.label}: the shape is zero at every measured dof")
        if len(dofs) and np.max(np.abs(shape)) < 1.0 / MAX_MAGNITUDE:  # its squares (MAC, norms) would underflow
            raise InputError(f"mode {self.label}: the shape is too small to compute with (largest value "
                             f"{np.max(np.abs(shape)):.3g}, below {1.0 / MAX_MAGNITUDE:g}); scale it: MAC and updating "
                             "do not depend on the scale of a measured shape")
        if self.reference_dof is not None:
            (ref,) = canonical_all([self.reference_dof], f"mode {self.label} reference_dof")
            if ref not in dofs:
                raise InputError(f"mode {self.label}: reference_dof {ref} is not among its measured dofs")
            if shape[dofs.index(ref)] == 0:
                raise InputError(f"mode {self.label}: the shape is zero at its reference_dof {ref}")
            object.__setattr__(self, "reference_dof", ref)
        for name in ("std_eigenvalue", "std_shape", "weight", "std_damping_ratio"):
            v = getattr(self, name)
            if v is not None:
                check = check_std_damping_ratio if name == "std_damping_ratio" else positive
                object.__setattr__(self, name, check(v, f"mode {self.label}: {name}"))
        if self.damping_ratio is not None:
            object.__setattr__(self, "damping_ratio",
                               check_damping_ratio(self.damping_ratio, f"mode {self.label}: damping_ratio"))
        elif self.std_damping_ratio is not None:
            raise InputError(f"mode {self.label}: std_damping_ratio is given without damping_ratio")
        object.__setattr__(self, "eigenvalue", lam)
        object.__setattr__(self, "dofs", dofs)
        object.__setattr__(self, "shape", shape)

    @property
    def frequency_hz(self) -> float:
        """Natural frequency √λ / 2π, Hz."""
        return math.sqrt(self.eigenvalue) / (2 * math.pi)

    @classmethod
    def from_frequency(cls, frequency_hz: float, dofs=(), shape=(), label: str = "", *,
                       reference_dof: str | None = None, std_frequency: float | None = None,
                       std_shape: float | None = None, weight: float | None = None,
                       damping_ratio: float | None = None, std_damping_ratio: float | None = None) -> MeasuredMode:
        """Measured mode from its natural frequency in Hz (λ = (2π f)²).

        Parameters
        ----------
        frequency_hz : float
            Natural frequency, Hz, finite and ≥ 0.
        dofs, shape, label, reference_dof, std_shape, weight, damping_ratio, std_damping_ratio
            As :class:`MeasuredMode`.
        std_frequency : float, optional
            Relative standard deviation of the frequency, σ_f / f; kept as the eigenvalue's
            ``std_eigenvalue`` = 2 σ_f / f (λ ∝ f², to first order in σ_f / f).

        Returns
        -------
        MeasuredMode

        Raises
        ------
        InputError
            A negative or non-finite frequency, and as :class:`MeasuredMode`.
        """
        with input_errors():
            number_arg(frequency_hz, "frequency_hz", "MeasuredMode.from_frequency")
        f = float(frequency_hz)
        if not math.isfinite(f) or f < 0:
            raise InputError(f"mode {label}: frequency_hz {f!r} must be finite and >= 0")
        if f > MAX_MAGNITUDE:
            raise InputError(f"mode {label}: frequency_hz {f:.3g} is above {MAX_MAGNITUDE:g}")
        std_eigenvalue = None
        if std_frequency is not None:
            std_eigenvalue = 2.0 * positive(std_frequency, f"mode {label}: std_frequency")
        return cls((2 * math.pi * f) ** 2, tuple(dofs), np.asarray(shape), label, reference_dof, std_eigenvalue,
                   std_shape, weight, damping_ratio, std_damping_ratio)

    @property
    def has_shape(self) -> bool:
        """Whether a shape was measured (at least one dof)."""
        return len(self.dofs) > 0


@dataclass(frozen=True)
class FRFData:
    """Receptance measurements: response ``x(omega)`` at ``dofs`` for force amplitudes ``force``.

    ``response`` has shape ``(n_freq, n_dofs)`` (complex or real); ``omega`` in rad/s.

    Parameters
    ----------
    omega : array_like, shape ``(n_freq,)``
        Excitation frequencies ω, rad/s, finite and ≥ 0 (flattened; not empty).
    force : mapping of str to float or complex
        Force amplitude (N) at each excited dof ``"node:dir"``; not all zero.
    dofs : sequence of str
        Labels of the measured response dofs.
    response : array_like, shape ``(n_freq, n_dofs)``
        Measured response x(ω) at ``dofs`` (real or complex; m for a force in N).

    Raises
    ------
    InputError
        Empty, negative or non-finite ``omega``; a response of the wrong shape or not finite;
        invalid dof labels; a non-finite, empty or zero force.
    """

    omega: np.ndarray
    force: Mapping[str, float]
    dofs: tuple[str, ...]
    response: np.ndarray

    def __post_init__(self):
        with input_errors():
            array_arg(self.omega, "omega", "FRFData", finite=False)
            mapping_arg(self.force, "force", "FRFData", optional=False)
            strings_arg(self.dofs, "dofs", "FRFData", optional=False, what="dof label")
            array_arg(self.response, "response", "FRFData", complex_ok=True, finite=False)
            for k, v in self.force.items():
                number_arg(v, f"force[{k!r}]", "FRFData", complex_ok=True)
        omega = np.asarray(self.omega, dtype=float).ravel()
        _finite(omega, "frf omega_rad_s")
        if omega.size == 0:
            raise InputError("frf: omega_rad_s is empty")
        if np.any(omega < 0):
            raise InputError("frf: omega_rad_s must be >= 0")
        dofs = canonical_all(self.dofs, "frf response")
        resp = np.asarray(self.response)
        resp = resp.astype(complex if np.iscomplexobj(resp) else float)
        if resp.shape != (omega.size, len(dofs)):
            raise InputError(f"frf: response has shape {resp.shape}, expected ({omega.size} frequencies (omega), "
                             f"{len(dofs)} dofs)")
        _finite(resp, "frf response", dofs)
        force = {}
        for k, v in dict(self.force).items():
            (lab,) = canonical_all([k], "frf force")
            fv = complex(v) if isinstance(v, complex) else float(v)
            if not np.isfinite(fv) or abs(fv) > MAX_MAGNITUDE:
                raise InputError(f"frf force at {lab} is not finite or above {MAX_MAGNITUDE:g} in magnitude")
            force[lab] = fv
        if not force or not any(v != 0 for v in force.values()):
            raise InputError("frf: the force vector is empty or zero")
        object.__setattr__(self, "omega", omega)
        object.__setattr__(self, "dofs", dofs)
        object.__setattr__(self, "response", resp)
        object.__setattr__(self, "force", force)


@dataclass(frozen=True)
class StaticData:
    """A static load case: applied forces and the measured displacements.

    Parameters
    ----------
    force : mapping of str to float
        Applied force (N) at each loaded dof ``"node:dir"``; finite, not all zero.
    dofs : sequence of str
        Labels of the measured displacements.
    displacement : array_like, shape ``(len(dofs),)``
        Measured displacements at ``dofs`` (m for forces in N), finite.

    Raises
    ------
    InputError
        A displacement of the wrong length or not finite; no measured displacement, or all of them
        zero; invalid dof labels; a non-finite, empty or zero force.
    """

    force: Mapping[str, float]
    dofs: tuple[str, ...]
    displacement: np.ndarray

    def __post_init__(self):
        with input_errors():
            mapping_arg(self.force, "force", "StaticData", optional=False)
            strings_arg(self.dofs, "dofs", "StaticData", optional=False, what="dof label")
            array_arg(self.displacement, "displacement", "StaticData", finite=False)
            for k, v in self.force.items():
                number_arg(v, f"force[{k!r}]", "StaticData")
        dofs = canonical_all(self.dofs, "static displacement")
        u = np.asarray(self.displacement, dtype=float).ravel()
        if u.shape != (len(dofs),):
            raise InputError(f"static: {len(dofs)} dofs but {u.size} displacement values")
        if not dofs:
            raise InputError("static: no measured displacement (give at least one {dof: value})")
        _finite(u, "static displacement", dofs)
        if not np.any(u):
            raise InputError("static: every measured displacement is zero (a load that moves nothing measured "
                             "carries no information; check the units and the sign convention)")
        force = {}
        for k, v in dict(self.force).items():
            (lab,) = canonical_all([k], "static force")
            if not np.isfinite(float(v)) or abs(float(v)) > MAX_MAGNITUDE:
                raise InputError(f"static force at {lab} is not finite or above {MAX_MAGNITUDE:g} in magnitude")
            force[lab] = float(v)
        if not any(v != 0 for v in force.values()):
            raise InputError("static: the force vector is empty or zero")
        object.__setattr__(self, "dofs", dofs)
        object.__setattr__(self, "displacement", u)
        object.__setattr__(self, "force", force)


def _fields(data: TestData) -> None:
    """The types of :class:`TestData`'s fields (a :class:`TypeError` naming the first wrong one)."""
    _items(data.modes, "modes", MeasuredMode,
           "MeasuredMode(eigenvalue, dofs, shape) or MeasuredMode.from_frequency(f_hz, ...)")
    if data.frf is not None and not isinstance(data.frf, FRFData):
        raise TypeError(f"TestData: frf must be an FRFData or None, got {shown(data.frf)}")
    _items(data.static, "static", StaticData, "StaticData(force, dofs, displacement)")
    _items(data.frf_sets, "frf_sets", FRFData, "FRFData(omega, force, dofs, response)")
    mapping_arg(data.units, "units", "TestData", optional=False)
    if not isinstance(data.nodes, Mapping):
        raise TypeError(f"TestData: nodes must be a mapping {{node: (x, y, z)}}, got {shown(data.nodes)}")
    if isinstance(data.notes, (str, bytes, np.ndarray)) or not isinstance(data.notes, Sequence):
        raise TypeError(f"TestData: notes must be a list of str, got {shown(data.notes)}")


def _items(value, name: str, cls: type, make: str) -> None:
    """Refuse a field of :class:`TestData` that is not a sequence of ``cls`` objects (a
    :class:`TypeError` naming the field, the item and how to make one)."""
    if isinstance(value, (str, bytes, Mapping, cls)) or not isinstance(value, (Sequence, np.ndarray)) or (
            isinstance(value, np.ndarray) and value.dtype.kind != "O"):
        raise TypeError(f"TestData: {name} must be a list of {cls.__name__}, got {shown(value)}"
                        + (f" (give [{name}])" if isinstance(value, cls) else ""))
    for k, item in enumerate(value):
        if not isinstance(item, cls):
            raise TypeError(f"TestData: {name}[{k}] must be a {cls.__name__}, got {shown(item)} (make one with {make})")


@dataclass(frozen=True)
class TestData:
    """All test data of one configuration: measured modes, FRFs and static load cases.

    Parameters
    ----------
    modes : tuple of MeasuredMode, default ``()``
        The measured modes (their order is the test-mode numbering used in pairs).
    frf : FRFData, optional
        Measured receptances.
    static : tuple of StaticData, default ``()``
        Static load cases.
    units : mapping, optional
        Unit information carried from the file (e.g. a universal file's dataset 164).
    nodes : mapping of int to (float, float, float), optional
        Node id -> coordinates (x, y, z), when the file gives them.
    frf_sets : tuple of FRFData, default ``()``
        Every FRF set, one per excitation (reference): a roving-hammer or multi-reference test
        holds several.  Given ``frf`` alone, ``frf_sets`` is ``(frf,)``; given ``frf_sets``
        alone, ``frf`` is its first set.  Code that compares one set only must check
        :attr:`n_frf_sets` (the updating commands use every set, one residual block each).
    notes : tuple of str, default ``()``
        What the reader decided about the data (components taken as unmeasured, units
        converted, coordinate systems applied), for the results' notes.

    Raises
    ------
    InputError
        ``frf`` given together with ``frf_sets`` whose first set it is not.
    """

    __test__ = False  # not a pytest test class

    modes: tuple[MeasuredMode, ...] = ()
    frf: FRFData | None = None
    static: tuple[StaticData, ...] = ()
    units: Mapping[str, object] = field(default_factory=dict)
    nodes: Mapping[int, tuple[float, float, float]] = field(default_factory=dict)
    frf_sets: tuple[FRFData, ...] = ()
    notes: tuple[str, ...] = ()

    def __post_init__(self):
        with input_errors():
            _fields(self)
        sets = tuple(self.frf_sets)
        if not sets and self.frf is not None:
            sets = (self.frf,)
        elif sets and self.frf is None:
            object.__setattr__(self, "frf", sets[0])
        elif sets and self.frf is not sets[0]:
            raise InputError("TestData: frf must be the first of frf_sets (give frf_sets alone)")
        object.__setattr__(self, "frf_sets", sets)
        object.__setattr__(self, "notes", tuple(str(n) for n in self.notes))

    @property
    def n_frf_sets(self) -> int:
        """The number of FRF sets (excitations): 0, 1, or more for a multi-reference test."""
        return len(self.frf_sets)

    @property
    def eigenvalues(self) -> np.ndarray:
        """Measured eigenvalues λ (rad²/s²), shape ``(n_modes,)``."""
        return np.array([m.eigenvalue for m in self.modes])

    @property
    def frequencies_hz(self) -> np.ndarray:
        """Measured natural frequencies (Hz), shape ``(n_modes,)``."""
        return np.sqrt(self.eigenvalues) / (2 * np.pi)

    @property
    def damping_ratios(self) -> np.ndarray:
        """Measured modal damping ratios ζ, shape ``(n_modes,)``; NaN for a mode without one."""
        return np.array([np.nan if m.damping_ratio is None else m.damping_ratio for m in self.modes], float)

    def shape_matrix(self, dofs: Sequence[str] | None = None) -> tuple[tuple[str, ...], np.ndarray]:
        """Measured shapes on a common dof set: ``(dofs, Phi)`` with ``Phi`` (n_dofs, n_modes).

        ``dofs`` defaults to the union of every mode's measured dofs; a mode not measured at a
        dof has NaN there.

        Parameters
        ----------
        dofs : sequence of str, optional
            Dof labels of the rows (default: the union of the measured dofs, in first-seen
            order).  Measured entries at other dofs are left out.

        Returns
        -------
        dofs : tuple of str
            The row labels.
        Phi : numpy.ndarray, shape ``(n_dofs, n_modes)``
            Shapes (complex if any mode is complex), NaN where a mode was not measured.
        """
        if dofs is None:
            seen: dict[str, None] = {}
            for m in self.modes:
                for d in m.dofs:
                    seen.setdefault(d, None)
            dofs = tuple(seen)
        else:
            dofs = canonical_all(dofs)
        cplx = any(np.iscomplexobj(m.shape) for m in self.modes)
        Phi = np.full((len(dofs), len(self.modes)), np.nan, dtype=complex if cplx else float)
        pos = {d: i for i, d in enumerate(dofs)}
        for j, m in enumerate(self.modes):
            for d, v in zip(m.dofs, m.shape):
                if d in pos:
                    Phi[pos[d], j] = v
        return tuple(dofs), Phi


def reciprocal(data: TestData) -> TestData:
    """The test data with their FRF sets regrouped by response dof through reciprocity
    (H_ij = H_ji for a linear structure with symmetric matrices): the response at dof i to a unit
    force at dof j is read as the response at j to a unit force at i.  A roving-hammer test (one
    response dof, the hammer at many dofs: one set per excitation) becomes one set of one
    excitation, compared with one factorisation per line instead of one per set.

    Parameters
    ----------
    data : TestData
        Test data whose FRF sets each have a unit force at one dof and share one frequency axis.

    Returns
    -------
    TestData
        The same modes, static cases, units and nodes; one FRF set per response dof of the
        given sets (in first-seen order), its responses at the given sets' excitation dofs;
        a note says what was regrouped.

    Raises
    ------
    InputError
        No FRF data; a set whose force is not a unit force at one dof; sets on different
        frequency axes.
    """
    sets = data.frf_sets
    if not sets:
        raise InputError("reciprocity: the test data hold no FRFs")
    omega = sets[0].omega
    cols: dict[str, dict[str, np.ndarray]] = {}
    for k, s in enumerate(sets, start=1):
        if len(s.force) != 1 or next(iter(s.force.values())) != 1:
            raise InputError(f"reciprocity: FRF set {k} has the force {dict(s.force)}; reciprocity regroups sets of "
                             "a unit force at one dof (receptances)")
        if s.omega.shape != omega.shape or not np.array_equal(s.omega, omega):
            raise InputError(f"reciprocity: FRF set {k} ({', '.join(s.force)}) has another frequency axis than set 1: "
                             "the sets can only be regrouped on one axis")
        (exc,) = s.force
        for j, d in enumerate(s.dofs):
            cols.setdefault(d, {})[exc] = s.response[:, j]
    out = []
    for d, by in cols.items():
        resp = np.column_stack(list(by.values()))
        out.append(FRFData(omega, {d: 1.0}, tuple(by), resp))
    note = (f"reciprocity: {len(sets)} FRF set(s) (one per excitation) regrouped by response dof into {len(out)} "
            f"set(s) (excitation {', '.join(cols)}), reading H(i <- j) as H(j <- i)")
    return TestData(data.modes, None, data.static, data.units, data.nodes, tuple(out), (*data.notes, note))
