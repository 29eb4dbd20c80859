r"""Iterative updating from incomplete FRF measurements (paper eqs. 30-31, with eq. 32).

The residual stacks, for every used line :math:`\omega_l` and measured dof s, the difference of
the model's and the measured response to the test's force (:mod:`femupdate.frf.residuals`:
``"linear"`` = eq. 34, ``"relative"``, or ``"log"``-magnitude), optionally weighted.  Its
Jacobian is eq. 31's sensitivity matrix, built from Brandon's expression (eq. 32) for the
force vector: per line ONE factorisation of Z and the solves

.. math::  x = Z^{-1} f, \qquad Y_S = Z^{-1} I_{:,S}, \qquad
           \partial x_S / \partial p_j = -\,Y_S^T\,(c_K K_j + c_M M_j)\,x,

all lines at once in one stacked dense solve for small models.  The iteration of eq. 30
(:math:`D_{j+1} = D_j + S^+\Delta`) is made robust by SciPy's least squares (trust-region
reflective with bounds, dogbox, Levenberg–Marquardt) — the same driver, parametrisations,
regularisation and :class:`~femupdate.updating.UpdateResult` / diagnostics as modal updating.

Lines are chosen with ``lines`` (indices) or ``select`` (the best-conditioned N lines,
:func:`femupdate.frf.selection.select_frequencies`); lines within ``resonance_tol`` of a
resonance of the nominal model (at ``values``, not ``x0``: the same lines for every start) are
skipped (``resonance="skip"``, named in ``notes``), refused (``"error"``) or kept (``"keep"``).
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass, field

import numpy as np

from .._docs import X as X_DOC, shared_docs
from .._errors import InputError, NumericalError
from ..frf import residuals as R
from ..frf.damping import as_damping
from ..frf.lines import LineSystems, ParameterForms, force_vector
from ..frf.resonance import resonances
from ..frf.simulate import check_data_against_model
from ..options import FRFOptions, SolverOptions
from ..testdata import FRFData, TestData
from .parametrisation import PARAMETRISATIONS, Parametrisation, start_vector, updated_names
from .results import UpdateResult

log = logging.getLogger(__name__)

RESONANCE_POLICIES = ("skip", "error", "keep")
#: how a standard deviation of the FRF residual entries is stated, on each route
STD_HINT = "--std of frf-update, --std-frf of update, or measurement_std in Python"
# RESONANCE_TOL (from .sensitivity): lines within this relative eigenvalue distance of a resonance
# of the starting model are skipped (or refused) by default


@dataclass(frozen=True, eq=False)
class FRFUpdateResult(UpdateResult):
    """:class:`~femupdate.updating.UpdateResult` of an FRF update, plus the FRF fields.

    Attributes
    ----------
    parameters, names, x, success, status, message, cost, fun, jac, nfev, njev, iterations
        As :class:`~femupdate.updating.RunResult` (``fun`` in the layout of :meth:`FRFProblem.residuals`).
    history, pairs, test_frequencies_hz, model_frequencies_hz, swaps, diagnostics, regularization
        As :class:`~femupdate.updating.UpdateResult` (``swaps`` empty from :func:`frf_update`).
    start, sensitivity, blocks, notes
        As :class:`~femupdate.updating.UpdateResult` (``sensitivity`` ``"brandon"`` from
        :func:`frf_update`; ``notes``: lines skipped or selected).
    omega : numpy.ndarray, shape ``(n_lines_used,)``
        The lines used (rad/s).
    skipped : list of dict
        Lines left out near a resonance: ``{"line" (1-based), "omega_rad_s", "reason"}``.
    residual : str
        The residual's form (``"linear"``, ``"relative"``, ``"log"``).
    frac : dict of str to float
        {dof: FRAC of the test vs the updated model's responses over the lines used}, in [0, 1]
        (NaN where a response is zero).
    natural_frequencies_hz : numpy.ndarray, shape ``(<= 10,)``
        The lowest natural frequencies of the updated model (Hz), at most ten.
    """

    omega: np.ndarray = field(default_factory=lambda: np.zeros(0))
    skipped: list = field(default_factory=list)
    residual: str = "linear"
    frac: dict = field(default_factory=dict)
    natural_frequencies_hz: np.ndarray = field(default_factory=lambda: np.zeros(0))


def frf_data(data) -> FRFData:
    """The FRF data of ``data``.

    Parameters
    ----------
    data : FRFData or TestData
        FRF data, or test data holding them.

    Returns
    -------
    FRFData

    Raises
    ------
    InputError
        No FRF data, or several sets (a multi-reference test: :func:`femupdate.updating.update`
        compares them all).
    """
    if isinstance(data, FRFData):
        return data
    if isinstance(data, TestData) and data.n_frf_sets > 1:
        refs = "; ".join(", ".join(s.force) for s in data.frf_sets)
        raise InputError(f"the test data hold {data.n_frf_sets} FRF sets, one per excitation ({refs}): this route "
                         "compares one set; update from all of them with femupdate update (or frf-update without "
                         "--global), one residual block per excitation, or split the file into one file per "
                         "excitation dof")
    if isinstance(data, TestData) and data.frf is not None:
        return data.frf
    raise InputError("FRF updating needs FRF test data (omega_rad_s, force, response)")


def frac(xe: np.ndarray, xa: np.ndarray) -> np.ndarray:
    """Frequency response assurance criterion per dof (columns): ``|x_Eᴴ x_A|² / (|x_E|² |x_A|²)``.

    Parameters
    ----------
    xe, xa : numpy.ndarray, shape ``(n_lines, n_dofs)``
        Measured and model responses, column by column on the same dofs and lines.

    Returns
    -------
    numpy.ndarray, shape ``(n_dofs,)``
        FRAC per dof in [0, 1]; NaN where either response is zero.
    """
    # FRAC does not depend on the scale of either column: each is divided by its largest value
    # first, so that data of extreme magnitude neither overflow nor underflow the sums of squares
    se, sa = np.max(np.abs(xe), axis=0), np.max(np.abs(xa), axis=0)
    xe = xe / np.where(se > 0, se, 1.0)
    xa = xa / np.where(sa > 0, sa, 1.0)
    num = np.abs(np.sum(np.conj(xe) * xa, axis=0)) ** 2
    den = np.sum(np.abs(xe) ** 2, axis=0) * np.sum(np.abs(xa) ** 2, axis=0)
    return np.where(den > 0, num / np.where(den > 0, den, 1.0), np.nan)


class FRFProblem(Parametrisation):
    """Residuals and Jacobian of one FRF updating problem (cached per parameter vector).

    The residuals compare the model's responses at the measured dofs ``frf.dofs`` to the force
    ``frf.force`` with the measured ones, line by line (``lines``: indices into ``frf.omega``), in
    the form ``residual`` (``"linear"`` eq. 34, ``"relative"``, ``"log"``), times ``weights``
    (broadcastable to ``frf.response``); the Jacobian is eq. 31's sensitivity matrix from
    Brandon's eq. 32.  A static load case is the same problem at ω = 0 (undamped: Z = K).
    Built by :func:`prepare_problem` (FRF data, with the checks and the choice of lines) or
    directly (static cases, :mod:`femupdate.updating.combined`).

    Parameters
    ----------
    model : Model
        The model updated.
    frf : FRFData
        Measured responses ``response`` (n_lines, n_dofs) at ``dofs`` to the force vector
        ``force`` {dof: amplitude} at the lines ``omega`` (rad/s).
    names : sequence of str
        The updated parameters.
    parametrisation : {"relative", "log", "absolute"}
        See :class:`~femupdate.updating.Parametrisation`.
    p_base : array_like, shape ``(n_parameters,)``
        The full parameter vector at the start.
    residual : {"linear", "relative", "log"}
        Form of the residuals (:mod:`femupdate.frf.residuals`).
    weights : None or array_like
        Broadcastable to ``frf.response`` (all its lines); None: 1.
    lines : array_like of int
        Indices into ``frf.omega`` of the lines used.
    damping : Damping
        Damping of the model (undamped with a real force: real responses and residuals).
    solver : {"auto", "dense", "sparse"}
        Solver of the line systems.

    Attributes
    ----------
    kind : str
        The residual form.
    omega : numpy.ndarray, shape ``(n_l,)``
        The lines used (rad/s).
    S : numpy.ndarray of int, shape ``(n_s,)``
        Model indices of the measured dofs.
    f : numpy.ndarray, shape ``(n_dofs,)``
        The force vector.
    xe : numpy.ndarray, shape ``(n_l, n_s)``
        The measured responses at the lines used (real parts when the model's are real).
    skipped : list of dict
        Lines left out (set by the caller that chose them).
    unit_factor : float
        The factor folded into the weights ``w`` by :func:`prepare_problem`: 1, or 1 / RMS of
        the measured responses for linear residuals without a stated standard deviation.
    weighting : str
        How ``unit_factor`` was chosen (:func:`unit_scale`).
    nfev : int
        Residual evaluations so far.

    Raises
    ------
    InputError
        An unknown residual form or parametrisation; force or response dofs the model lacks.
    """

    def __init__(self, model, frf: FRFData, names, parametrisation, p_base, residual, weights, lines, damping, solver):
        super().__init__(model, names, parametrisation, p_base)
        self.model = model
        self.damping = damping
        self.solver = solver
        self.kind = R.check_kind(residual)
        self.f = force_vector(model, frf.force, "frf force")
        self.S = model.dof_index(frf.dofs, "frf response")
        self.omega = frf.omega[lines]
        xe = frf.response[lines]
        w = np.broadcast_to(np.asarray(1.0 if weights is None else weights, float), frf.response.shape)[lines]
        real = damping.undamped and not np.iscomplexobj(self.f)
        self.w, self.target = R.prepare(xe, self.kind, w, real)
        self.xe = xe.real if real and np.iscomplexobj(xe) else xe
        # a non-linear model's forms depend on p: made at each Jacobian (its tangent there)
        self.forms = ParameterForms(model, self.idx) if model.is_affine else None
        n = model.n_dofs
        self.B = np.zeros((n, 1 + self.S.size), dtype=self.f.dtype)
        self.B[:, 0] = self.f
        self.B[self.S, 1 + np.arange(self.S.size)] = 1.0
        self.cache_key = None
        self.nfev = 0
        self.skipped: list[dict] = []  # lines left out (set by the caller that chose them)
        self.unit_factor = 1.0  # folded into w by prepare_problem (1 / RMS of xe for unit-bearing residuals)
        self.weighting = "as given"

    def _evaluate(self, x):
        key = x.tobytes()
        if key != self.cache_key:
            p = self.to_p(x)
            sys_ = LineSystems(self.model, p, self.omega, self.damping, self.solver)
            X = sys_.solve(self.B)  # (n_l, n, 1 + n_s)
            self.cache_key, self.cache = key, (p, sys_, X)
        return self.cache

    @shared_docs(X=X_DOC)
    def responses(self, x) -> np.ndarray:
        """The model's responses to the force at the measured dofs, x = Z(ω)⁻¹ f (paper eq. 32).

        {{X}}
        numpy.ndarray, shape ``(n_l, n_s)``
            Real when undamped with a real force, else complex; the units of the measured
            responses.

        Raises
        ------
        NumericalError
            A line at which the dynamic stiffness is singular.
        """
        _, _, X = self._evaluate(x)
        return X[:, self.S, 0]

    @shared_docs(X=X_DOC)
    def residuals(self, x):
        """The residuals at x (``"linear"`` eq. 34, ``"relative"`` or ``"log"``), times the weights.

        {{X}}
        numpy.ndarray, shape ``(m,)``
            Line-major over (line, dof): m = n_l n_s when real (and always for ``"log"``); for
            complex responses m = 2 n_l n_s, the real parts of every line first, then the
            imaginary parts.

        Raises
        ------
        NumericalError
            Non-finite residuals (a line on a resonance of the model at x), or a singular
            dynamic stiffness.
        """
        self.nfev += 1
        r = R.values(self.responses(x), self.target, self.w, self.kind).ravel()
        if not np.all(np.isfinite(r)):
            raise NumericalError("non-finite FRF residuals (a line lies on a resonance of the model at these parameter values)")
        return r

    @shared_docs(X=X_DOC)
    def jacobian(self, x):
        """The exact Jacobian ∂r/∂x at x: eq. 31's sensitivity matrix from Brandon's eq. 32,
        ∂x_S/∂p_j = −Y_Sᵀ (c_K K_j + c_M M_j) x for every parameter at once.

        {{X}}
        numpy.ndarray, shape ``(m, L)``
            Rows in the order of :meth:`residuals`.

        Raises
        ------
        NumericalError
            A singular dynamic stiffness at a line.
        """
        p, sys_, X = self._evaluate(x)
        forms = self.forms if self.forms is not None else ParameterForms(self.model, self.idx, p)
        L = self.idx.size
        # eq. 32 for the force vector: dx_S/dp_j = -Y_S^T (c_K K_j + c_M M_j) x, every j at once
        dx = np.stack([-forms(X[i, :, 1:], X[i, :, :1], sys_.cK[i], sys_.cM[i])[:, :, 0].T
                       for i in range(self.omega.size)])  # (n_l, n_s, L)
        J = R.jacobian(X[:, self.S, 0], dx, self.w, self.kind)
        return J.reshape(-1, L) * self.dp_dx(x)[None, :]


def _select_lines(model, frf: FRFData, p, lines, select, resonance, resonance_tol, names, damping, notes):
    n_all = frf.omega.size
    if lines is None:
        use = np.arange(n_all)
    else:
        use = np.asarray(lines)
        if use.dtype == bool:
            if use.shape != (n_all,):
                raise InputError(f"lines: a mask needs {n_all} entries (one per line), got {use.shape}")
            use = np.flatnonzero(use)
        use = use.astype(int)
        bad = use[(use < 0) | (use >= n_all)]
        if bad.size:
            raise InputError(f"lines: line(s) {', '.join(str(int(b) + 1) for b in bad)} (counted from 1; index(es) "
                             f"{', '.join(str(int(b)) for b in bad)} from 0) outside the data's {n_all} lines")
        use = np.unique(use)
    skipped = []
    dc = use[frf.omega[use] == 0]
    if dc.size:  # an analyser's DC bin: not a measurement of the dynamic response
        for i in dc:
            skipped.append({"line": int(i) + 1, "omega_rad_s": 0.0,
                            "reason": "a 0 Hz line (an analyser's DC bin); give static deflections as 'static' data"})
        notes.append(f"skipped the 0 Hz line(s) {', '.join(str(int(i) + 1) for i in dc)}: an analyser's DC bin is not a "
                     "measurement of the dynamic response (static deflections go in 'static')")
        use = use[frf.omega[use] != 0]
        if use.size == 0:
            raise InputError("no FRF lines left to update with: every line given is at 0 Hz")
    if resonance not in RESONANCE_POLICIES:
        raise InputError(f"unknown resonance policy {resonance!r}: use {', '.join(RESONANCE_POLICIES)}")
    if resonance != "keep":
        res = resonances(model, frf.omega[use], p)
        near = res.near(resonance_tol)
        if near.size:
            where = "; ".join(f"line {use[i] + 1} ({frf.omega[use[i]]:.6g} rad/s, {res.distance[i]:.2g} from the "
                              f"resonance at {math.sqrt(max(res.nearest[i], 0)):.6g} rad/s)" for i in near)
            if resonance == "error":
                raise InputError(f"FRF data at frequencies that coincide with resonances of the model: {where}; "
                                 "drop these lines, or use resonance='skip'")
            log.warning("FRF lines skipped, within %g of a model resonance: %s", resonance_tol, where)
            for i in near:
                skipped.append({"line": int(use[i]) + 1, "omega_rad_s": float(frf.omega[use[i]]),
                                "reason": f"within {resonance_tol:g} (relative eigenvalue distance) of the model "
                                          f"resonance at {math.sqrt(max(res.nearest[i], 0)):.6g} rad/s"})
            notes.append(f"skipped near resonance: {where}")
            use = np.delete(use, near)
    if select is not None:
        from ..frf.selection import select_frequencies

        sel = select_frequencies(model, frf.omega[use], int(select), dict(frf.force), kind="sensitivity",
                                 response=frf.dofs, unknowns=names, values=p, damping=damping, margin=0.0)
        use = use[sel.index]
        notes.append(f"selected {use.size} lines by conditioning (cond {sel.condition_number:.3g}, evenly spread "
                     f"{sel.uniform['condition_number']:.3g}): {np.round(frf.omega[use], 6).tolist()} rad/s")
    if use.size == 0:
        raise InputError("no FRF lines left to update with")
    return use, skipped


def unit_scale(label: str, stated: bool, has_units: bool, measured, what: str, quantity: str, unit: str,
               notes: list[str], key: str = "frf", why: str = "to weigh them against the other data",
               how: str | None = None) -> tuple[float, str]:
    """The factor of residuals that may carry the data's units, and how it was chosen.

    Residuals in the data's units (linear FRF residuals in m/N, static deflections in m) have a
    size that depends on those units; SciPy's least squares tests its gradient against an
    absolute ``gtol``, so receptances of 1e-5 m/N make it stop near the start.  Without a stated
    standard deviation such residuals are divided by the RMS of their measured values, which
    makes them dimensionless whatever the units (and weighs them against other kinds of data in
    a mix), and a note says so.

    Parameters
    ----------
    label : str
        How the note names the residuals (``"frf"``, ``"static case 2"``).
    stated : bool
        A standard deviation is stated (already folded into the weights): factor 1.
    has_units : bool
        The residuals carry the data's units (False: dimensionless, factor 1).
    measured : array_like
        The measured values whose RMS (of the magnitudes) is taken.
    what, quantity, unit : str
        The note's words: what is divided (``"the linear FRF residuals"``), the measured
        quantity (``"response"``) and its unit (``" m"``, or ``""``).
    notes : list of str
        The note is appended here.
    key : str, default ``"frf"``
        The ``measurement_std`` key (and ``--std-KEY`` option) that states the deviation.
    why : str, default ``"to weigh them against the other data"``
        Why the residuals are divided (the note's words).
    how : str, optional
        How to state the deviation (the note's words); default ``--std-KEY, or
        measurement_std['KEY'] in Python``.

    Returns
    -------
    scale : float
        1 with a stated deviation or dimensionless residuals; else 1 / RMS (1 when the RMS is 0).
    weighting : str
        ``"stated std"``, ``"as given"`` or ``"divided by the RMS measured QUANTITY (VALUE UNIT)"``.
    """
    if stated:
        return 1.0, "stated std"
    if not has_units:
        return 1.0, "as given"
    v = np.abs(np.asarray(measured))
    rms = float(np.sqrt(np.mean(v ** 2))) if v.size else 0.0
    how = how or f"--std-{key}, or measurement_std['{key}'] in Python"
    notes.append(f"{label}: no standard deviation stated; {what} are divided by the RMS measured {quantity} "
                 f"({rms:.4g}{unit}) {why}; state it ({how}) to weigh by uncertainty")
    return (1.0 / rms if rms > 0 else 1.0), f"divided by the RMS measured {quantity} ({rms:.4g}{unit})"


#: why a problem with one kind of data divides its residuals by the RMS of the measured values
ALONE = "so that the cost is dimensionless and the solver's stopping tests do not depend on the data's units"


def prepare_problem(model, data, params, x0, frf: FRFOptions, solver: SolverOptions, *, measurement_std=None,
                    values=None, regularized: bool = False, scale_units: bool = True):
    """Checks, line choice and the :class:`FRFProblem` (shared by local and global FRF updating).

    Parameters
    ----------
    model : Model
        The model to update.
    data : TestData or FRFData
        The FRF data (:func:`frf_data`).
    params : sequence of str or None
        The updated parameters (None: every parameter not ``fixed``).
    x0 : mapping of str to float or None
        Starting values.
    frf : FRFOptions
        The residual (one form: ``"linear"``, ``"relative"`` or ``"log"``, not ``"auto"``),
        weights, lines, line selection, resonance policy and tolerance, damping and line solver
        (:class:`~femupdate.options.FRFOptions`).
    solver : SolverOptions
        Its ``parametrisation`` is the problem's; its ``method`` is only checked.
    measurement_std : float or array_like, optional
        The standard deviation of the residual entries (the weights are divided by it).
    values : None, mapping of str to float, or array_like, optional
        Values of the fixed parameters; the nominal model for the resonance check and ``select``.
    regularized : bool, default False
        A regularisation will be added: fewer residuals than parameters are allowed.
    scale_units : bool, default True
        Without ``measurement_std``, divide the ``"linear"`` residuals by the RMS of the
        measured responses on the lines used (:func:`unit_scale`, with a note), so that neither
        the cost nor the solver's stopping tests depend on the data's units.  False: leave them
        in the data's units (:func:`~femupdate.updating.combined.combined_problem` scales its
        blocks itself).

    Returns
    -------
    prob : FRFProblem
        The problem on the chosen lines.
    sigma : numpy.ndarray or None
        ``measurement_std`` as an array (the weights are divided by it), or None.
    skipped : list of dict
        Lines left out near a resonance (``line`` 1-based, ``omega_rad_s``, ``reason``).
    notes : list of str
        Lines skipped or selected.

    Raises
    ------
    InputError
        No FRF data; an unknown parametrisation, method, residual form, damping or resonance
        policy; data the model cannot be compared with; no parameters; a standard deviation
        not positive and finite; bad ``lines``; a line on a resonance with ``"error"``; no line
        left; fewer residuals than parameters unless ``regularized``.
    """
    frf_set = frf_data(data)
    residual, parametrisation, method = frf.residual, solver.parametrisation, solver.method
    if parametrisation not in PARAMETRISATIONS:
        raise InputError(f"unknown parametrisation {parametrisation!r}: use {', '.join(PARAMETRISATIONS)}")
    if method not in ("trf", "dogbox", "lm"):
        raise InputError(f"unknown method {method!r}: use trf, dogbox or lm")
    R.check_kind(residual)
    damping = as_damping(frf.damping)
    check_data_against_model(model, frf_set, damping, residual)
    names = updated_names(model, params)
    p_nominal = model.resolve(values)
    p_base = start_vector(model, values, x0)
    w = frf.weights
    sigma = None
    if measurement_std is not None:
        sigma = np.asarray(measurement_std, float)
        if not np.all(sigma > 0) or not np.all(np.isfinite(sigma)):
            raise InputError("measurement_std must be positive and finite")
        w = np.asarray(1.0 if frf.weights is None else frf.weights, float) / sigma
    notes: list[str] = []
    dead = R.zero_channels(frf_set.response)
    if dead.all():
        raise InputError("every FRF channel is zero at every line: no response to update with")
    if dead.any():
        notes.append(f"FRF response(s) at {', '.join(d for d, z in zip(frf_set.dofs, dead) if z)} zero at every line (a "
                     "dead channel?): left out of the residual")
    use, skipped = _select_lines(model, frf_set, p_nominal, frf.lines, frf.select, frf.resonance, frf.resonance_tol,
                                 names, damping, notes)
    prob = FRFProblem(model, frf_set, names, parametrisation, p_base, residual, w, use, damping, frf.solver)
    if scale_units:
        prob.unit_factor, prob.weighting = unit_scale("frf", sigma is not None, prob.kind == "linear", prob.xe,
                                                "the linear FRF residuals", "response", "", notes, why=ALONE,
                                                how=STD_HINT)
        prob.w = prob.w * prob.unit_factor
    n_res = prob.xe.size * (2 if np.iscomplexobj(prob.xe) and residual != "log" else 1)
    if n_res < len(names) and not regularized:
        raise InputError(f"{len(names)} parameters but only {n_res} residuals from {use.size} line(s) at "
                         f"{prob.S.size} dof(s): add lines or dofs, fix parameters, or use regularization")
    return prob, sigma, skipped, notes


def modal_report(model, data, p):
    """Natural frequencies of the model at the parameters p, and its MAC pairing with the measured
    modes if the test data hold modes (the pairing of :func:`femupdate.correlate`).

    Parameters
    ----------
    model : Model
        The model.
    data : TestData or FRFData
        The test data (pairing only for a TestData with modes).
    p : array_like, shape ``(n_parameters,)``
        The full parameter vector.

    Returns
    -------
    pairs : list of (int, int, float)
        ``(test mode, model mode, MAC)``, 0-based; empty without measured modes.
    test_frequencies_hz : numpy.ndarray
        The measured modes' frequencies (Hz); empty without modes.
    model_frequencies_hz : numpy.ndarray
        The paired model modes' frequencies (Hz), in the order of ``pairs``.
    natural_frequencies_hz : numpy.ndarray, shape ``(<= 10,)``
        The model's lowest natural frequencies (Hz), at most ten.
    """
    from ..modal import DENSE_LIMIT, model_modes

    n_modes = None if model.n_dofs <= DENSE_LIMIT else min(10, model.n_dofs - 2)
    modes = model_modes(model, p, n_modes=n_modes)
    natural = modes.frequencies_hz[:10]
    if isinstance(data, TestData) and data.modes:
        from ..correlation import correlate

        corr = correlate(data, modes)
        pairs = [(int(i), int(j), float(m)) for i, j, m in corr.pairs]
        return pairs, data.frequencies_hz, np.array([modes.frequencies_hz[j] for _, j, _ in corr.pairs]), natural
    return [], np.zeros(0), np.zeros(0), natural
