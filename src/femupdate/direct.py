r"""Direct (linear) updating when every model dof is measured.

Because the model is affine in its parameters, every complete measurement gives equations that
are *linear* in the unknown parameters (the reference paper's eqs. 1-10 and 23-29):

* a measured mode (λ_i, φ_i):  :math:`\sum_j p_j (K_j - \lambda_i M_j)\phi_i = (\lambda_i M_f - K_f)\phi_i`
  (eq. 4: :math:`\Phi_i k = \lambda_i M \phi_i` when only springs are unknown);
* an FRF line (ω, x, f):       :math:`\sum_j p_j (K_j - \omega^2 M_j) x = f - (K_f - \omega^2 M_f) x`
  (eqs. 24-28: :math:`X k = f + M\omega^2 x`);
* a static load case (u, f):    :math:`\sum_j p_j K_j u = f - K_f u` (Lallement et al. 1992);

where :math:`K_f, M_f` collect the known part of the model (``K0`` plus fixed parameters).
The stacked system :math:`A p = b` is solved in the least-squares sense, :math:`p = A^+ b`
(eq. 10, eq. 29), or with bounds by :func:`scipy.optimize.lsq_linear`.  Mass parameters may be
unknown too, as long as something fixes the scale (known masses, a measured force).
"""

from __future__ import annotations

import logging
import math
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from functools import cached_property
from typing import ClassVar

import numpy as np
import scipy.sparse as sp
from scipy.optimize import lsq_linear

from ._checks import flag_arg, params_arg, problem_args, strings_arg
from ._errors import InputError, NumericalError
from .dofs import canonical_all, describe
from .serialise import RunContext, Serialisable
from .testdata import FRFData, MeasuredMode, StaticData, TestData

log = logging.getLogger(__name__)



@dataclass(frozen=True, eq=False)
class LinearSystem:
    """Stacked direct-updating equations ``A p_free = b`` with a label per row block.

    Built by :func:`build_system` (:meth:`EquationBuilder.system`); each parameter is stored as
    the attribute of the same name.

    Parameters
    ----------
    A : numpy.ndarray or scipy.sparse.csr_array, shape ``(n_equations, n_unknowns)``
        Coefficients of the unknown parameters (complex equations split into real and
        imaginary rows).
    b : numpy.ndarray, shape ``(n_equations,)``
        Right-hand side (the known part of the model and the applied forces).
    unknowns : tuple of str
        Names of the unknown parameters, one per column of ``A``.
    blocks : list of (str, int)
        Description and number of rows of each block (a mode, an FRF line, a static case), in
        row order.
    """

    A: np.ndarray | sp.csr_array
    b: np.ndarray
    unknowns: tuple[str, ...]
    blocks: list[tuple[str, int]]  # (description, number of rows)

    @property
    def n_equations(self) -> int:
        """Number of rows of ``A``."""
        return self.b.size


@dataclass(frozen=True, eq=False)
class DirectResult(Serialisable):
    """Solution of a direct update (built by :func:`solve_system`).

    Each parameter is stored as the attribute of the same name.  A result of kind ``direct``
    (``demo`` for the demo's, :func:`femupdate.examples.demo`; :mod:`femupdate.serialise`):
    ``to_json()`` is what ``femupdate direct --json`` writes, ``write_report(path)`` its
    ``--report``, ``to_frame()`` one row per parameter.

    Parameters
    ----------
    parameters : dict
        Every parameter's value: identified for the unknowns, given for the fixed ones.
    unknowns : tuple of str
    x : ndarray
        Identified values of the unknowns.
    condition_number : float
        2-norm condition number of ``A`` as stacked (the paper's cond(X), Figure 4).
    condition_number_scaled : float
        Condition number after scaling each column of ``A`` to unit length (unit-independent).
    residual_norm, relative_residual : float
        ``||A x - b||`` and ``||A x - b|| / ||b||``.
    rank : int
    unique : bool
        ``rank == number of unknowns``.
    null_space : ndarray (n_unknowns, n_unknowns - rank)
        Parameter combinations the data cannot determine (empty when unique).
    singular_values : ndarray (n_unknowns,)
        Singular values of ``A`` as stacked (unscaled), descending.
    system : LinearSystem
    standard_error : ndarray
        Standard error of each unknown from the least-squares residual,
        ``sqrt(diag(s^2 (A^T A)^-1))`` with ``s^2 = ||r||^2 / (rows - unknowns)``; NaN when the
        system is square or rank deficient.  It assumes errors in ``b`` only: noise in the
        measured shapes also biases the estimate (errors in variables), so treat it as a
        lower bound on the uncertainty.
    bounded : bool
        Whether the parameters' bounds were enforced (bounded least squares).
    notes : list of str
        Remarks: modes without a shape left out, the undetermined combinations when not unique.
    context : RunContext, optional
        The model, the test data and the starting values (:func:`direct_update`; not
        serialised).  Read back from JSON, ``system``, ``null_space`` and ``singular_values``
        are empty (the JSON does not hold them).
    """

    kind: ClassVar[str] = "direct"
    kinds: ClassVar[tuple[str, ...]] = ("direct", "demo")

    parameters: dict[str, float]
    unknowns: tuple[str, ...]
    x: np.ndarray
    condition_number: float
    condition_number_scaled: float
    residual_norm: float
    relative_residual: float
    rank: int
    unique: bool
    null_space: np.ndarray
    singular_values: np.ndarray
    system: LinearSystem
    standard_error: np.ndarray = field(default_factory=lambda: np.zeros(0))
    bounded: bool = False
    notes: list[str] = field(default_factory=list)
    context: RunContext | None = field(default=None, compare=False, repr=False)

    def payload(self) -> dict:
        from .direct_record import direct_kind

        return direct_kind(self, self.run_context)

    @classmethod
    def from_payload(cls, obj):
        from .direct_record import direct_from

        return direct_from(obj)

    def records(self) -> list[dict]:
        """One record per parameter (``parameter``, ``value``, ``std`` — the standard error of an
        unknown —, ``start``, ``unit``): :meth:`to_frame`'s rows."""
        start = self.run_context.before or {}
        return [{**r, "start": start.get(r["parameter"], r["start"])} for r in super().records()]

    @cached_property
    def identified(self):
        """The identified model's modes and their correlation with the test modes
        (:class:`~femupdate.direct_record.Identified`; None each without the context's test
        modes), computed once, when first asked for (the JSON's ``frequencies_hz`` and ``pairs``)."""
        from .direct_record import identified

        return identified(self, self.run_context)


def _complete(model, dofs: Sequence[str], values: np.ndarray, what: str) -> np.ndarray:
    """Reorder measured values onto the model's dofs; every model dof must be measured."""
    pos = {d: i for i, d in enumerate(canonical_all(dofs, what))}
    extra = [d for d in pos if d not in set(model.dofs)]
    if extra:
        raise InputError(f"{what}: dof(s) not in the model: {describe(extra)}")
    missing = [d for d in model.dofs if d not in pos]
    if missing:
        raise InputError(
            f"{what}: a direct solution needs data at every model dof; missing {len(missing)} of "
            f"{model.n_dofs}: {describe(missing)} (use iterative updating, or reduce the model / expand the data)"
        )
    return values[[pos[d] for d in model.dofs]]


def _force(model, force: dict, what: str) -> np.ndarray:
    f = np.zeros(model.n_dofs, dtype=complex if any(isinstance(v, complex) for v in force.values()) else float)
    idx = {d: i for i, d in enumerate(model.dofs)}
    unknown = [d for d in force if d not in idx]
    if unknown:
        raise InputError(f"{what}: force applied at dof(s) not in the model: {describe(unknown)}")
    for d, v in force.items():
        f[idx[d]] = v
    return f


INFO_TOL = 1e-10  # |(K_j - s M_j) x| below this fraction of |K_j| |x| is round-off, not data


def _fro(A) -> float:
    return 0.0 if A is None else float(np.sqrt(np.sum(A.data**2)))


class EquationBuilder:
    """Accumulates column blocks ``[(K_j - s M_j) x]_j`` and right-hand sides.

    The known part of the model, ``K_f`` and ``M_f`` (``K0``, ``M0`` and the known
    parameters), goes to the right-hand side.

    Parameters
    ----------
    model : Model
        The parametrised model.
    values : None, mapping of str to float, or array_like, optional
        Parameter values as :meth:`Model.resolve` reads them; those of the known parameters are
        used (default nominal).
    unknowns : sequence of str, optional
        Names of the parameters to identify (default: every parameter not ``fixed``).

    Raises
    ------
    InputError
        No unknown parameter; an unknown parameter name; and as :meth:`Model.resolve`.
    """

    def __init__(self, model, values=None, unknowns: Sequence[str] | None = None):
        from .coefficients import route_refusal
        route_refusal(model, 'the direct update (direct_update: linear equations in the parameters)')
        self.model = model
        self.p = model.resolve(values)
        if unknowns is None:
            self.free = [int(j) for j in model.free]
        else:
            self.free = model.parameter_indices(unknowns, "unknowns (--unknowns)")
        if not self.free:
            raise InputError("no unknown parameters: every parameter is fixed")
        pk = self.p.copy()
        pk[self.free] = 0.0
        self.Kf = model.K(pk)
        self.Mf = model.M(pk)
        self.cols: list[np.ndarray] = []
        self.rhs: list[np.ndarray] = []
        self.blocks: list[tuple[str, int]] = []
        # Frobenius norms of dK/dp_j and dM/dp_j, to tell information from round-off
        self.kn = np.array([_fro(model.dK[j]) for j in self.free])
        self.mn = np.array([_fro(model.dM[j]) for j in self.free])
        self.info = np.zeros(len(self.free))

    def add(self, x: np.ndarray, s: float, f: np.ndarray | None, desc: str) -> None:
        """Equations (K(p) - s M(p)) x = f, linear in the unknown p.

        Adds one block of n_dofs rows (2 n_dofs when complex: real and imaginary parts).

        Parameters
        ----------
        x : numpy.ndarray, shape ``(n_dofs,)``
            A complete vector on the model's dofs (mode shape, response or displacement).
        s : float
            λ (rad²/s²) for a mode, ω² for an FRF line, 0 for a static case.
        f : numpy.ndarray, shape ``(n_dofs,)``, or None
            Applied force (N), or ``None`` (a mode: no force).
        desc : str
            Description of the block.
        """
        m = self.model
        cols = []
        for j in self.free:
            c = m.dK_dp(j) @ x
            if s != 0:
                c = c - s * (m.dM_dp(j) @ x)
            cols.append(c)
        r = -(self.Kf @ x) + s * (self.Mf @ x)
        if f is not None:
            r = r + f
        C = np.column_stack(cols)
        scale = (self.kn + abs(s) * self.mn) * np.linalg.norm(x)
        with np.errstate(invalid="ignore", divide="ignore"):
            self.info = np.maximum(self.info, np.where(scale > 0, np.linalg.norm(C, axis=0) / scale, 0.0))
        if np.iscomplexobj(C) or np.iscomplexobj(r):
            C = np.vstack([C.real, C.imag])
            r = np.concatenate([np.real(r), np.imag(r)])
        self.cols.append(C)
        self.rhs.append(np.asarray(r, float))
        self.blocks.append((desc, C.shape[0]))

    def system(self) -> LinearSystem:
        """The stacked :class:`LinearSystem` of every block added.

        Returns
        -------
        LinearSystem

        Raises
        ------
        InputError
            No block added; an unknown parameter on which the data carry no information (its
            column is round-off compared with ‖K_j‖ ‖x‖).
        """
        if not self.cols:
            raise InputError("no complete data to build direct equations from (need mode shapes, FRFs or static deflections at every model dof)")
        A = np.vstack(self.cols)
        b = np.concatenate(self.rhs)
        names = tuple(self.model.parameter_names[j] for j in self.free)
        blind = [names[i] for i in np.flatnonzero(self.info < INFO_TOL)]
        if blind:
            raise InputError(
                f"direct solve: the data carry no information on parameter(s) {', '.join(blind)} "
                "(the measured motion does not strain their elements, e.g. no axial motion in bending modes); "
                "fix them or add data that excite them"
            )
        return LinearSystem(A, b, names, self.blocks)


def modal_equations(builder: EquationBuilder, modes: Sequence[MeasuredMode], notes: list[str]) -> None:
    """Eqs. (4)-(9): one block of n rows per complete mode (shape normalised to unit length).

    Complex shapes are rotated to the real axis (by the phase of their largest entry) and
    their real part used.

    Parameters
    ----------
    builder : EquationBuilder
        Receives the equations.
    modes : sequence of MeasuredMode
        Measured modes; each with a shape must be measured at every model dof.
    notes : list of str
        Receives a note per mode without a shape (skipped).

    Raises
    ------
    InputError
        A shape missing model dofs or at dofs not in the model.
    """
    for k, mode in enumerate(modes, start=1):
        name = mode.label or f"mode {k}"
        if not mode.has_shape:
            notes.append(f"{name}: eigenvalue only, not usable in a direct solution (no shape)")
            continue
        phi = _complete(builder.model, mode.dofs, mode.shape, f"{name} shape")
        if np.iscomplexobj(phi):
            # real normal mode from a (lightly damped) complex one: rotate to the real axis
            phi = np.real(phi * np.exp(-1j * np.angle(phi[np.argmax(np.abs(phi))])))
        phi = phi / np.linalg.norm(phi)
        builder.add(phi, mode.eigenvalue, None, name)


def frf_equations(builder: EquationBuilder, frf: FRFData) -> None:
    """Eqs. (24)-(28): one block per spectral line; complex data give real and imaginary rows.

    Parameters
    ----------
    builder : EquationBuilder
        Receives the equations (Z(ω) x = f with Z = K − ω²M, ω in rad/s).
    frf : FRFData
        Responses measured at every model dof, with the applied force.

    Raises
    ------
    InputError
        Responses missing model dofs or at dofs not in the model; a force at a dof not in the
        model.
    """
    x = _complete(builder.model, frf.dofs, frf.response.T, "frf response")  # (n, n_freq)
    f = _force(builder.model, dict(frf.force), "frf")
    for i, w in enumerate(frf.omega):
        builder.add(x[:, i], float(w) ** 2, f, f"frf line {i + 1} ({w:g} rad/s)")


def static_equations(builder: EquationBuilder, cases: Sequence[StaticData]) -> None:
    """Static equilibrium K(p) u = f for each load case (Lallement et al. 1992).

    Parameters
    ----------
    builder : EquationBuilder
        Receives the equations.
    cases : sequence of StaticData
        Load cases with displacements at every model dof.

    Raises
    ------
    InputError
        Displacements missing model dofs or at dofs not in the model; a force at a dof not in
        the model; a load not in equilibrium on a model with rigid-body modes
        (:func:`femupdate.modal.check_static_loads`).
    """
    from .modal import check_static_loads

    rows = []
    for k, case in enumerate(cases, start=1):
        u = _complete(builder.model, case.dofs, case.displacement, f"static case {k} displacement")
        rows.append((f"static case {k}", u, _force(builder.model, dict(case.force), f"static case {k}")))
    check_static_loads(builder.model, builder.p, [(what, f) for what, _, f in rows])
    for what, u, f in rows:
        builder.add(u, 0.0, f, what)


def build_system(model, data: TestData, use: Sequence[str] = ("modes", "frf", "static"),
                 values=None, unknowns=None, notes: list[str] | None = None) -> LinearSystem:
    """Stack the direct equations of the chosen kinds of data.

    Parameters
    ----------
    model : Model
        The parametrised model.
    data : TestData
        Complete test data (every model dof measured).
    use : sequence of str, default ``("modes", "frf", "static")``
        Kinds of data to use, among those present.
    values : None, mapping of str to float, or array_like, optional
        Values of the known parameters (default nominal).
    unknowns : sequence of str, optional
        Parameters to identify (default: every parameter not ``fixed``).
    notes : list of str, optional
        Receives remarks (modes without a shape).

    Returns
    -------
    LinearSystem

    Raises
    ------
    InputError
        An unknown data kind, and as :class:`EquationBuilder`, :func:`modal_equations`,
        :func:`frf_equations`, :func:`static_equations`.
    """
    notes = [] if notes is None else notes
    b = EquationBuilder(model, values, unknowns)
    unknown_kinds = set(use) - {"modes", "frf", "static"}
    if unknown_kinds:
        raise InputError(f"unknown data kind(s) {sorted(unknown_kinds)}: use modes, frf, static")
    if "modes" in use and data.modes:
        modal_equations(b, data.modes, notes)
    if "frf" in use:
        for fs in data.frf_sets:  # one set per excitation (several in a multi-reference test)
            frf_equations(b, fs)
    if "static" in use and data.static:
        static_equations(b, data.static)
    return b.system()


def solve_system(model, system: LinearSystem, values=None, bounded: bool = False,
                 notes: list[str] | None = None) -> DirectResult:
    """Least-squares solution of ``A p = b`` (eq. 10 / eq. 29) with diagnostics.

    The columns of ``A`` are scaled to unit length; without bounds the solution is the
    minimum-norm pseudo-inverse one (singular values below ``max(A.shape) · eps · s_max`` of the
    scaled matrix dropped), with bounds SciPy's ``lsq_linear`` (BVLS).

    Parameters
    ----------
    model : Model
        The model the system was built from.
    system : LinearSystem
        The stacked equations.
    values : None, mapping of str to float, or array_like, optional
        Values of the known parameters, reported in ``parameters`` (default nominal).
    bounded : bool, default False
        Enforce the unknown parameters' bounds.
    notes : list of str, optional
        Remarks so far; a note on the undetermined combinations is appended when not unique.

    Returns
    -------
    DirectResult

    Raises
    ------
    InputError
        Fewer equations than unknowns; a homogeneous system (b = 0: the scale is undetermined).
    NumericalError
        The bounded solve failed.
    """
    notes = [] if notes is None else notes
    A, b = system.A, system.b
    L = A.shape[1]
    if system.n_equations < L:
        per = max(n for _, n in system.blocks) if system.blocks else 1
        raise InputError(
            f"direct solve: {L} unknown parameters but only {system.n_equations} equations; "
            f"at least {L} are needed (each complete mode or spectral line gives {per} here, so at least "
            f"{math.ceil(L / per)} are needed; fix some parameters or add data)"
        )
    if not np.any(b):
        raise InputError(
            "direct solve: the equations are homogeneous (every stiffness and mass term is unknown), so the "
            "scale of the parameters is undetermined: fix at least one mass or stiffness parameter, or use FRF/static data with a known force"
        )
    colnorm = np.linalg.norm(A, axis=0)
    As = A / colnorm
    U, s, Vt = np.linalg.svd(As, full_matrices=False)
    tol = max(As.shape) * np.finfo(float).eps * s[0]
    rank = int(np.sum(s > tol))
    s_raw = np.linalg.svd(A, compute_uv=False)
    cond = float(s_raw[0] / s_raw[-1]) if s_raw[-1] > 0 else math.inf
    cond_s = float(s[0] / s[-1]) if s[-1] > 0 else math.inf
    null = (Vt[rank:].T / colnorm[:, None]) if rank < L else np.zeros((L, 0))
    if rank < L:
        null = null / np.linalg.norm(null, axis=0)
    lo, hi = model.bounds
    free_idx = [model.parameter_index(n) for n in system.unknowns]
    if bounded:
        res = lsq_linear(As, b, bounds=(lo[free_idx] * colnorm, hi[free_idx] * colnorm), lsmr_tol="auto", method="bvls")
        if not res.success:
            raise NumericalError(f"bounded direct solve failed: {res.message}")
        x = res.x / colnorm
    else:
        # minimum-norm least squares in scaled coordinates (eq. 10: p = A^+ b)
        keep = s > tol
        x = (Vt[keep].T @ ((U[:, keep].T @ b) / s[keep])) / colnorm
    r = A @ x - b
    rn = float(np.linalg.norm(r))
    p = model.resolve(values)
    p[free_idx] = x
    dof_resid = system.n_equations - L
    if rank == L and dof_resid > 0:
        cov_scaled = (Vt.T / s**2) @ Vt * (rn**2 / dof_resid)
        stderr = np.sqrt(np.diag(cov_scaled)) / colnorm
    else:
        stderr = np.full(L, np.nan)
    if rank < L:
        combos = []
        for k in range(null.shape[1]):
            v = null[:, k]
            big = np.argsort(-np.abs(v))[:3]
            combos.append(" + ".join(f"{v[i]:.3g}*{system.unknowns[i]}" for i in big if abs(v[i]) > 1e-3))
        notes.append(
            f"not unique: rank {rank} < {L} unknowns; undetermined combination(s): " + "; ".join(combos)
        )
    return DirectResult(
        parameters=dict(zip(model.parameter_names, map(float, p))),
        unknowns=system.unknowns, x=x, condition_number=cond, condition_number_scaled=cond_s,
        residual_norm=rn, relative_residual=rn / float(np.linalg.norm(b)), rank=rank, unique=rank == L,
        null_space=null, singular_values=s_raw, system=system, standard_error=stderr,
        bounded=bounded, notes=notes,
    )


def direct_update(model, data: TestData, use: Sequence[str] = ("modes", "frf", "static"),
                  values=None, unknowns: Sequence[str] | None = None, bounded: bool = False) -> DirectResult:
    """Identify the unknown parameters directly from complete test data.

    Parameters
    ----------
    model : Model
        The parametrised model.
    data : TestData
        Modes with shapes, FRFs and/or static deflections at *every* model dof.
    use : sequence of str, default ``("modes", "frf", "static")``
        Kinds of data to stack, among those present in ``data``.
    values : None, mapping of str to float, or array_like, optional
        Parameter values for the known (fixed) parameters (default nominal).
    unknowns : sequence of str, optional
        Names of the parameters to identify (default: every parameter not ``fixed``).
    bounded : bool, default False
        Honour the parameters' bounds (e.g. non-negative stiffness) with a bounded
        least-squares solve instead of the pseudo-inverse.

    Returns
    -------
    DirectResult
        With its context: the model, the test data and the starting values (``to_json()`` and
        ``write_report()`` take the units, bounds, flags, notes and the identified model's
        correlation with the test from them).

    Raises
    ------
    InputError
        Data missing at model dofs (the message names them), fewer equations than unknowns
        (it says how many are needed), NaN, unknown dofs, an unknown data kind in ``use``, a
        homogeneous system (the scale is undetermined).
    NumericalError
        The bounded solve failed.
    """
    problem_args("direct_update", model, data, values=values)
    params_arg(unknowns, "unknowns", "direct_update")
    strings_arg(use, "use", "direct_update", optional=False, what="data kind")
    flag_arg(bounded, "bounded", "direct_update")
    notes: list[str] = []
    system = build_system(model, data, use, values, unknowns, notes)
    res = solve_system(model, system, values, bounded, notes)
    start = dict(zip(model.parameter_names, map(float, model.resolve(values))))
    return replace(res, context=RunContext(model=model, data=data if isinstance(data, TestData) else None, before=start))
