r"""Updating from whatever the test data hold — modes, FRFs, static deflections or any mix — as
one problem (:class:`CombinedProblem`); :func:`femupdate.updating.update` (module
:mod:`femupdate.updating.run`) solves it.

Each kind of data is a *block* with its own residuals and exact Jacobian, all on one vector of
updated parameters:

* ``"modes"`` — :class:`~femupdate.updating.Problem`: relative eigenvalue errors and scaled
  shape differences of the paired modes (paper eqs. 16–21, 33);
* ``"frf"`` — :class:`~femupdate.updating.frf.FRFProblem`: the responses at the measured dofs,
  line by line (eqs. 30–32, 34);
* ``"static"`` — one :class:`~femupdate.updating.frf.FRFProblem` per load case at ω = 0, where the
  dynamic stiffness is K: :math:`r = w\,(u_S(p) - u_{S,\mathrm{measured}})` with
  :math:`u = K(p)^{-1} f` and :math:`\partial u_S/\partial p_j = -Y_S^T K_j u`,
  :math:`Y_S = K^{-1} I_{:,S}` (Brandon's eq. 32 at zero frequency; mass parameters have no
  effect on it).

The residual vector stacks the blocks, each times a scale:

* a block whose measurement standard deviation is stated (``measurement_std``: ``"eigenvalue"``
  and ``"shape"`` for modes, ``"frf"``, ``"static"``) is divided by it — the blocks then weigh
  by their uncertainty (maximum likelihood for independent Gaussian errors) and, when every
  block's is stated, the covariance of the parameters is absolute;
* without a stated standard deviation, a block whose residuals carry the data's units (FRF
  ``"linear"`` residuals, in m/N; static deflections, in m) is divided by the RMS of measured
  values, and a note says so (:func:`~femupdate.updating.frf.unit_scale`): in a *mix*, each
  block by its own, so that every block is dimensionless like the modal one (such weights are
  a convention, not a statement about the data); with *one* kind of data, all its blocks by
  one factor, the RMS of all their measured values, so that the cost and the solver's
  stopping tests do not depend on the units while the blocks keep their weights against each
  other (the result is that of :func:`update_modal` or :func:`~femupdate.updating.frf_update`).
  Dimensionless residuals (modes, ``"relative"`` and ``"log"`` FRF residuals) keep their own.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from .._docs import X as X_DOC, shared_docs
from .._errors import InputError, NumericalError
from ..options import DATA_KINDS, STD_KEYS, FRFOptions, UpdateOptions
from ..frf.damping import UNDAMPED
from ..modal import check_static_loads
from ..testdata import FRFData, TestData
from .frf import ALONE, STD_HINT, FRFProblem, prepare_problem, unit_scale
from .parametrisation import Parametrisation, start_vector, updated_names
from .problem import Problem
from .targets import mode_uncertainty

if TYPE_CHECKING:
    from .damped import DampedFRFProblem, DampedModesProblem

#: options of the FRF block (:class:`~femupdate.options.FRFOptions`' fields)
FRF_OPTIONS = FRFOptions.field_names()


@dataclass(frozen=True, eq=False)
class Block:
    """One kind of data in a :class:`CombinedProblem`.

    Attributes
    ----------
    kind : {"modes", "frf", "static", "damped modes"}
        The kind of data (``"damped modes"``: measured modes against the complex modes of a
        damped model, :mod:`femupdate.updating.damped`).
    label : str
        How messages name it (``"modes"``, ``"frf"``, ``"static case 2"``).
    problem : Problem, FRFProblem, DampedModesProblem or DampedFRFProblem
        Its residuals and Jacobian (a static case: an :class:`FRFProblem` at ω = 0).
    scale : float
        The factor its residuals are multiplied by (1, or 1 / RMS of the measured values: its own
        in a mix, those of every block of its kind with one kind of data).
    weighting : str
        Why that factor (``"stated std"``, ``"as given"``, ``"divided by the RMS measured ..."``).
    """

    kind: str
    label: str
    problem: Problem | FRFProblem | DampedModesProblem | DampedFRFProblem
    scale: float
    weighting: str


def data_kinds(data: TestData, use: Sequence[str] = DATA_KINDS) -> tuple[str, ...]:
    """The kinds of data in ``data`` that ``use`` asks for, in :data:`DATA_KINDS` order.

    Parameters
    ----------
    data : TestData
        The test data.
    use : sequence of str, default :data:`DATA_KINDS`
        The kinds asked for (``"modes"``, ``"frf"``, ``"static"``).

    Returns
    -------
    tuple of str
        The kinds both asked for and held (modes, FRFs, static cases), never empty.

    Raises
    ------
    InputError
        An unknown kind in ``use``, or none of the asked-for kinds in the data.
    """
    use = tuple(use)
    unknown = sorted(set(use) - set(DATA_KINDS))
    if unknown:
        raise InputError(f"unknown data kind(s) {', '.join(unknown)}: use {', '.join(DATA_KINDS)}")
    have = {"modes": bool(data.modes), "frf": bool(data.frf_sets), "static": bool(data.static)}
    kinds = tuple(k for k in DATA_KINDS if k in use and have[k])
    if not kinds:
        held = [k for k in DATA_KINDS if have[k]]
        raise InputError(f"the test data hold no {' or '.join(use)} data to update from"
                         + (f" (they hold: {', '.join(held)})" if held else " (they are empty)"))
    return kinds


def frf_label(frf: FRFData) -> str:
    """How a block of one FRF set of a multi-reference test is named: ``"frf excitation 1:z"``
    (a force pattern of several dofs: ``"frf excitation 1:z, 2:x"``)."""
    return "frf excitation " + ", ".join(frf.force)


def split_std(measurement_std: Mapping | None) -> dict[str, dict]:
    """Checked ``measurement_std`` split by kind of data.

    ``measurement_std`` by kind: {"modes": {"eigenvalue": .., "shape": ..}, "frf": .., ...}."""
    out: dict[str, dict] = {}
    for key, value in dict(measurement_std or {}).items():
        if key not in STD_KEYS:
            raise InputError(f"unknown measurement_std key {key!r}: use {', '.join(STD_KEYS)}")
        if value is None:
            continue
        arr = np.asarray(value, float)
        if not (np.all(np.isfinite(arr)) and np.all(arr > 0)):
            raise InputError(f"measurement_std[{key!r}] must be positive and finite")
        out.setdefault(STD_KEYS[key], {})[key] = value
    return out


class CombinedProblem(Parametrisation):
    """Several blocks of data (:class:`Block`), one vector of updated parameters.

    Offers what :func:`~femupdate.updating.solve` and :func:`~femupdate.updating.diagnostics`
    need: the :class:`~femupdate.updating.Parametrisation` maps, ``residuals(x)`` (the blocks'
    residuals times their scales, stacked in block order) and ``jacobian(x)``.

    Parameters
    ----------
    model : Model
        The model updated.
    blocks : sequence of Block
        At least one; the first block's problem gives the updated parameters, parametrisation
        and start (every block's must be the same).
    sigma : True or None
        True when every block's residuals are divided by stated standard deviations (the
        covariance is then absolute), else None.
    notes : sequence of str, default ()
        What the user should know about the weighting and the lines used.

    Attributes
    ----------
    model : Model
    blocks : list of Block
    sigma : True or None
    notes : list of str
    rows : numpy.ndarray of int, shape ``(n_blocks + 1,)``
        Block b's residuals are rows ``rows[b]:rows[b + 1]``.
    nfev : int
        Residual evaluations so far.
    """

    def __init__(self, model, blocks: Sequence[Block], sigma, notes: Sequence[str] = ()):
        first = blocks[0].problem
        for b in blocks[1:]:
            q = b.problem
            if q.names != first.names or q.param != first.param or not np.array_equal(q.p_base, first.p_base):
                raise RuntimeError(f"internal error: block {b.label} has another parametrisation than {blocks[0].label}")
        super().__init__(model, first.names, first.param, first.p_base)
        self.model = model
        self.blocks = list(blocks)
        self.sigma = sigma
        self.notes = list(notes)
        self.nfev = 0
        self.rows = np.cumsum([0] + [self._n(b) for b in self.blocks])

    @staticmethod
    def _n(block: Block) -> int:
        prob = block.problem
        if not isinstance(prob, FRFProblem):  # modal and damped blocks know their count
            return prob.n_residuals
        return int(prob.xe.size * (2 if np.iscomplexobj(prob.xe) and prob.kind != "log" else 1))

    @property
    def n_residuals(self) -> int:
        """m, the length of the stacked residual vector."""
        return int(self.rows[-1])

    @property
    def residual_dof(self) -> int:
        """The number of independent residual equations: ``n_residuals`` less, for a modal block
        of the dynamic formulation, its equations that only determine the unknown shape entries
        (:attr:`Problem.residual_dof`)."""
        modal = self.modal
        return self.n_residuals - (modal.n_residuals - modal.residual_dof if modal is not None else 0)

    @property
    def modal(self) -> Problem | None:
        """The modal block's problem (None without modes)."""
        return next((b.problem for b in self.blocks if isinstance(b.problem, Problem)), None)

    def _each(self, x, what: str):
        for b in self.blocks:
            try:
                yield b, getattr(b.problem, what)(x)
            except NumericalError as exc:
                if b.kind == "modes":
                    raise
                if b.kind == "static":
                    raise NumericalError(f"{b.label}: the stiffness matrix is singular at these parameter values (a "
                                         "mechanism, or rigid-body motion the load excites): K u = f has no solution"
                                         ) from None
                raise NumericalError(f"{b.label}: {exc}") from None

    @shared_docs(X=X_DOC)
    def residuals(self, x) -> np.ndarray:
        """The stacked residuals at the variables x: each block's, times its scale.

        {{X}}
        numpy.ndarray, shape ``(m,)``

        Raises
        ------
        NumericalError
            A block cannot be evaluated (the message names a non-modal block).
        """
        self.nfev += 1
        return np.concatenate([b.scale * r for b, r in self._each(x, "residuals")])

    @shared_docs(X=X_DOC)
    def jacobian(self, x) -> np.ndarray:
        """The stacked exact Jacobian ∂r/∂x at x, each block's rows times its scale.

        {{X}}
        numpy.ndarray, shape ``(m, L)``

        Raises
        ------
        NumericalError
            As :meth:`residuals`.
        """
        return np.vstack([b.scale * J for b, J in self._each(x, "jacobian")])

    def block_costs(self, r: np.ndarray) -> list[dict]:
        """Each block's share of the residuals r.

        Parameters
        ----------
        r : numpy.ndarray, shape ``(m,)``
            Stacked residuals (as :meth:`residuals` returns them).

        Returns
        -------
        list of dict
            Per block, in order: ``kind``, ``label``, ``n_residuals``, ``scale``, ``weighting``
            and ``cost`` (½‖r_b‖² of its scaled residuals).
        """
        out = []
        for b, a, z in zip(self.blocks, self.rows[:-1], self.rows[1:]):
            rb = r[a:z]
            out.append({"kind": b.kind, "label": b.label, "n_residuals": int(z - a), "scale": b.scale,
                        "weighting": b.weighting, "cost": float(0.5 * rb @ rb)})
        return out


def combined_problem(model, data: TestData, params: Sequence[str] | None = None, *,
                     x0: Mapping[str, float] | None = None, values=None, options: UpdateOptions | None = None,
                     regularized: bool = False, **shorthand) -> CombinedProblem:
    """The :class:`CombinedProblem` of every kind of data in ``data`` that the options' ``use`` names.

    Parameters
    ----------
    model : Model
        The model to update.
    data : TestData
        The test data.
    params : sequence of str, optional
        Names of the parameters to update (default: every parameter not ``fixed``).
    x0 : mapping of str to float, optional
        Starting values {name: value} (default: nominal, or ``values``).
    values : None, mapping of str to float, or array_like of shape ``(n_parameters,)``, optional
        Values of the fixed parameters (default nominal).
    options : UpdateOptions, optional
        The kinds of data used (those the data hold; :func:`data_kinds`), the modal block's
        options, the standard deviations by kind (``noise.std``: {"eigenvalue", "shape",
        "frf": std of the FRF residual entries, scalar or broadcastable to the response,
        "static": std of the measured deflections (m; scalar, or broadcastable to each case's
        measured dofs)}; a block with its standard deviation stated is divided by it), the
        FRF block's options (its residual ``"auto"`` is the linear one here: a problem has one
        residual; :func:`~femupdate.updating.update` runs the log stage first), the
        parametrisation and the method (checked with the FRF block) of its ``solver``.
    regularized : bool, default False
        A regularisation will be added (the count of data is not checked).
    **shorthand
        Fields of the option objects as keywords (as :func:`femupdate.update`).

    Returns
    -------
    CombinedProblem
        Blocks in :data:`DATA_KINDS` order (one per static case).  A block without a stated
        standard deviation whose residuals carry units (linear FRF residuals, static
        deflections) is divided by the RMS of measured values, with a note: its own in a mix of
        kinds, that of all blocks of the kind with one kind of data.  ``sigma``
        is True when every block's standard deviation is stated (for modes with shapes: both
        ``"eigenvalue"`` and ``"shape"`` in a mix).

    Raises
    ------
    InputError
        Unknown kinds, keys or options; FRF options without FRF data; data the model cannot be
        compared with; fewer independent data than parameters (unless ``regularized``).
    NumericalError
        As :class:`~femupdate.updating.Problem` (a test shape with a zero scaling entry).
    """
    o = UpdateOptions.of("combined_problem", shorthand, options=options)
    kinds = data_kinds(data, o.use)
    std = split_std(o.noise.std)
    parametrisation = o.solver.parametrisation
    frf_options = o.frf.changed()
    residual = "linear" if o.frf.residual == "auto" else o.frf.residual
    if frf_options and "frf" not in kinds:
        raise InputError(f"FRF options ({', '.join(sorted(frf_options))}) given, but no FRF data are used")
    mixed = len(kinds) > 1
    names = updated_names(model, params)
    blocks: list[Block] = []
    notes: list[str] = []
    n_data = 0
    for kind in kinds:
        prob: Problem | FRFProblem
        if kind == "modes":
            # the caller's standard deviations, completed by the data's per-mode ones
            _, given = mode_uncertainty(data, o.noise.weights, std.get("modes"),
                                        o.modal.use_shapes and o.modal.formulation != "dynamic")
            prob = Problem(model, data, names, x0=x0, values=values, parametrisation=parametrisation, modal=o.modal,
                           pairing=o.pairing, noise=o.noise.replace(std=given))
            mine = {k for k, v in dict(std.get("modes") or {}).items() if v is not None}  # the caller's own
            prob.stated_sources = {k: "given" if k in mine else "data" for k in prob.stated_sources}
            n_data += prob.targets.n_independent
            weighting = "stated std" if given else "dimensionless (relative eigenvalues, scaled shapes)"
            blocks.append(Block("modes", "modes", prob, 1.0, weighting))
        elif kind == "frf":
            given = std.get("frf", {}).get("frf")
            f = o.frf
            several = data.n_frf_sets > 1  # a multi-reference test: one block per excitation
            sets = []
            for fs in data.frf_sets:
                label = frf_label(fs) if several else "frf"
                try:
                    fp, _, skipped, frf_notes = prepare_problem(
                        model, fs, names, x0, f.replace(residual=residual), o.solver, measurement_std=given,
                        values=values, regularized=True, scale_units=False)
                except InputError as exc:
                    raise InputError(f"{label}: {exc}" if several else str(exc)) from None
                fp.skipped = [dict(s, excitation=label) for s in skipped] if several else skipped
                notes.extend(f"{label}: {n}" if several else n for n in frf_notes)
                n_data += CombinedProblem._n(Block("frf", label, fp, 1.0, ""))
                sets.append((label, fp))
            # residuals in the data's units (linear): divided by the RMS of the measured responses, each
            # set's own in a mix, all sets' together alone (their weights against each other unchanged)
            pooled = None if mixed else _unit_scale_alone("frf", given is not None, sets[0][1].kind == "linear",
                                                          [fp.xe for _, fp in sets], "the linear FRF residuals",
                                                          "response", "", notes, "frf", STD_HINT)
            for label, fp in sets:
                scale, weighting = pooled or unit_scale(label, given is not None, fp.kind == "linear", fp.xe,
                                                        "the linear FRF residuals", "response", "", notes)
                blocks.append(Block("frf", label, fp, scale, weighting))
        else:
            given = std.get("static", {}).get("static")
            pooled = None if mixed else _unit_scale_alone("static cases", given is not None, True,
                                                          [c.displacement for c in data.static], "their deflections",
                                                          "deflection", " m", notes, "static")
            for k, case in enumerate(data.static, start=1):
                label = f"static case {k}"
                frf = FRFData(np.zeros(1), case.force, case.dofs, case.displacement[None, :])
                weights = None
                if given is not None:
                    try:
                        weights = 1.0 / np.broadcast_to(np.asarray(given, float), case.displacement.shape)
                    except ValueError:
                        raise InputError(f"measurement_std['static']: give one value or one per measured dof of "
                                         f"{label} ({case.displacement.size})") from None
                try:
                    prob = FRFProblem(model, frf, names, parametrisation, start_vector(model, values, x0), "linear",
                                      weights, np.zeros(1, int), UNDAMPED, "auto")
                except InputError as exc:
                    raise InputError(f"{label}: {exc}") from None
                n_data += case.displacement.size
                scale, weighting = pooled or unit_scale(label, given is not None, True, case.displacement,
                                                        "its deflections", "deflection", " m", notes, key="static")
                blocks.append(Block("static", label, prob, scale, weighting))
            check_static_loads(model, values, [(b.label, b.problem.f) for b in blocks
                                               if isinstance(b.problem, FRFProblem) and b.kind == "static"],
                               need_inverse=True)
    sigma = True if all(b.weighting == "stated std" for b in blocks) else None
    if mixed and "modes" in kinds and blocks[0].weighting == "stated std":
        modal = blocks[0].problem
        if isinstance(modal, Problem) and modal.any_shape and modal.sigma is None:
            sigma = None
    combined = CombinedProblem(model, blocks, sigma, notes)
    if not regularized and n_data < len(names):
        raise InputError(f"{len(names)} parameters but only {n_data} independent data ({', '.join(kinds)}): the "
                         "problem is underdetermined; add data, fix parameters, or use regularization")
    return combined



def _unit_scale_alone(label, stated, has_units, measured, what, quantity, unit, notes, key, how=None):
    """:func:`~femupdate.updating.frf.unit_scale` of the blocks of one kind of data used alone: one
    factor for all of them, from the RMS of all their measured values, and one note."""
    pooled = np.concatenate([np.abs(np.asarray(m)).ravel() for m in measured])
    return unit_scale(label, stated, has_units, pooled, what, quantity, unit, notes, key=key, why=ALONE, how=how)


__all__ = ["combined_problem", "split_std", "frf_label", "CombinedProblem", "Block", "data_kinds", "DATA_KINDS",
           "STD_KEYS", "FRF_OPTIONS"]
