r"""The modal updating problem: what is updated, against which data, by which rules.

A :class:`Problem` owns everything that defines the problem — the updated parameters and their
parametrisation, the measured eigenvalues and scaled shapes with their weights, the pairing
threshold, the number of model modes to pair among — and evaluates its residuals and exact
Jacobian at one point by the rules of :mod:`femupdate.rules` (paper eqs. 16–21; the residual
vector stacks, per test mode, its relative eigenvalue error and its scaled shape differences —
the default ``"shapes"`` formulation; ``"mac"`` compares the shapes by MAC residuals, and
``"dynamic"`` takes the modal dynamic residual of :mod:`femupdate.updating.dynamic` instead).
The drivers consume it: :func:`~femupdate.updating.solve` (one local solve),
:func:`~femupdate.updating.multistart` and the compiled batched route
(:mod:`femupdate.updating.batched`, which compiles the same rules and reads the same
:class:`Targets`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

import numpy as np

from .._docs import X as X_DOC, shared_docs
from .. import rules
from .._checks import choice_arg, problem_args
from .._errors import InputError, NumericalError
from ..correlation import pair
from ..modal import Modes, model_modes
from ..sensitivity import eigenvalue_derivatives
from ..sensitivity.jacobian import METHODS as SENSITIVITY_METHODS
from ..sensitivity.jacobian import jacobian as sensitivity_jacobian
from ..close_modes import assign_inside, group_columns, mode_groups
from ..testdata import TestData
from . import groups as grouping
from .parametrisation import (PARAMETRISATIONS, Parametrisation, start_error, start_vector, updated_names, x_bounds,
                              x_of_p)
from .dynamic import DynamicResidual
from .targets import TARGETS_PER_MODE, TARGETS_PER_POSITION, Targets, build_targets, modal_weights, mode_uncertainty
from ..options import FORMULATIONS, SHAPE_SCALINGS, ModalOptions, NoiseOptions, PairingOptions, gather
SENSITIVITY_CHOICES = SENSITIVITY_METHODS  #: ``"auto"``, ``"nelson"``, ``"modal"``, ... (the Jacobian's route)
#: the route of the dynamic formulation's Jacobian, as ``sensitivity_used`` and results report it
DYNAMIC_ROUTE = "dynamic residual (exact, no eigen-solution)"


def check_formulation(modal: ModalOptions, noise: NoiseOptions | None = None) -> None:
    """Refuse options the formulation of ``modal`` does not take.

    Parameters
    ----------
    modal : ModalOptions
        The formulation and the other residual options.
    noise : NoiseOptions, optional
        The weights and standard deviations.

    Raises
    ------
    InputError
        ``"mac"`` or ``"dynamic"`` with a shape scaling other than ``"unit"``, a ``ref_dof`` or
        without shapes; ``"dynamic"`` with a sensitivity route other than ``"auto"`` or a shape
        weight or standard deviation.
    """
    formulation, shape_scaling, ref_dof = modal.formulation, modal.shape_scaling, modal.ref_dof
    use_shapes, sensitivity = modal.use_shapes, modal.sensitivity
    weights, measurement_std = (noise.weights, noise.std) if noise is not None else (None, None)
    if formulation == "shapes":
        return
    if not use_shapes:
        raise InputError(f"formulation {formulation!r} compares the measured shapes, but they are ignored "
                         "(--eigenvalues-only, use_shapes=False): use --formulation shapes for frequencies only")
    if shape_scaling != "unit":
        raise InputError(f"shape scaling {shape_scaling!r} (--shape-scaling) applies to formulation 'shapes' only: "
                         f"formulation {formulation!r} does not depend on how the shapes are scaled")
    if ref_dof is not None:
        raise InputError(f"a reference dof (--ref-dof {ref_dof}) applies to formulation 'shapes' with --shape-scaling "
                         f"ref only: formulation {formulation!r} does not depend on how the shapes are scaled")
    if formulation != "dynamic":
        return
    if sensitivity != "auto":
        raise InputError(f"sensitivity {sensitivity!r} (--sensitivity) chooses the route of the eigenvector "
                         "derivatives; formulation 'dynamic' has none (its Jacobian is exact by construction)")
    for name, given, option in (("weights", weights, None), ("measurement_std", measurement_std, "--std-shape")):
        if given is not None and dict(given).get("shape") is not None:
            raise InputError(f"{name}['shape']{f' ({option})' if option else ''}: formulation 'dynamic' holds the "
                             "measured shape entries at the test values, so it has no shape residual to weigh; the "
                             "eigenvalue's weight and std weigh each mode's dynamic residual")


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
    parametrisation : {"relative", "log", "absolute"}, default ``"relative"``
        See :class:`Parametrisation`.
    modal : ModalOptions, optional
        The residuals (:class:`~femupdate.options.ModalOptions`: formulation, shape scaling,
        reference dof, shapes used, derivative route — the compiled route always uses the exact
        complete modal method —, reuse of the factorisation).
    pairing : PairingOptions or str, optional
        How test modes are paired with model modes at each evaluation
        (:class:`~femupdate.options.PairingOptions`; a string is its rule).
    noise : NoiseOptions, optional
        Standard deviations and weights (:class:`~femupdate.options.NoiseOptions`; see
        :func:`modal_weights`), each entry a single value or one per test mode.  The test data's
        per-mode ``std_eigenvalue``, ``std_shape`` and ``weight`` fill the keys not given
        (:func:`mode_uncertainty`).
    **shorthand
        Fields of those option objects as keywords (``min_mac=0.8``, ``formulation="mac"``, ...).

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
        The stated ``measurement_std`` with the data's per-mode values, when every residual is
        divided by a standard deviation (the covariance of the diagnostics is then absolute).
    sensitivity_used : str
        The derivative route of the last Jacobian (``"auto"`` resolved; ``"fox-kapoor"`` when no
        shape is compared).
    swaps : list of dict
        Mode swaps seen while evaluating (``evaluation``, ``test_mode``, ``from_model_mode``,
        ``to_model_mode``; 0-based modes; ``rule``: the pairing rule that made the new pair).
    pairing_used : str
        The rule that made the last evaluation's pairs: ``"mac"``, ``"order"`` or
        ``"frequency"``.
    close_modes : float
        The relative eigenvalue gap below which model modes form a group
        (:mod:`femupdate.updating.groups`).
    group_fits : dict of int to GroupFit
        For the last evaluation, the test modes paired into a group of repeated or close model
        modes and what each is compared with (:class:`~femupdate.updating.groups.GroupFit`);
        empty when no paired model mode has a close neighbour.
    nfev : int
        Residual evaluations so far.
    formulation : str
        The residual formulation.
    notes : list of str
        What the user should know about the formulation (data it does not use).

    Raises
    ------
    InputError
        An unknown ``shape_scaling``, ``sensitivity``, ``parametrisation``, ``pairing`` or
        ``formulation``; ``min_mac`` not a number in [0, 1]; no parameters to update; bad weights,
        standard deviations or data (as :func:`modal_weights`, :func:`build_targets`); options
        the formulation does not take, and for ``"dynamic"`` a test mode without a shape.
    NumericalError
        A test shape whose scaling entry is zero; for ``"dynamic"``, a test shape whose
        unmeasured entries the nominal model's equilibrium does not determine.
    """

    def __init__(self, model, data: TestData, params: Sequence[str] | None = None, *,
                 x0: Mapping[str, float] | None = None, values=None, parametrisation: str = "relative",
                 modal: ModalOptions | None = None, pairing: PairingOptions | str | None = None,
                 noise: NoiseOptions | None = None, **shorthand):
        problem_args("Problem", model, data, params=params, x0=x0, values=values)
        choice_arg(parametrisation, PARAMETRISATIONS, "parametrisation", "Problem")
        o = gather("Problem", shorthand, modal=(ModalOptions, modal), pairing=(PairingOptions, pairing),
                   noise=(NoiseOptions, noise))
        modal, pairing_options, noise = o["modal"], o["pairing"], o["noise"]
        #: the option objects the problem was made with
        self.options = {"modal": modal, "pairing": pairing_options, "noise": noise}
        formulation, shape_scaling, ref_dof = modal.formulation, modal.shape_scaling, modal.ref_dof
        use_shapes, sensitivity, reuse = modal.use_shapes, modal.sensitivity, modal.reuse
        rule, min_mac, n_modes = pairing_options.rule, pairing_options.min_mac, pairing_options.n_modes
        weights, measurement_std = noise.weights, noise.std
        check_formulation(modal, noise)
        self.formulation = formulation
        dynamic = formulation == "dynamic"
        super().__init__(model, updated_names(model, params), parametrisation, start_vector(model, values, x0))
        #: what the user should know about the formulation
        self.notes: list[str] = []
        if dynamic and any(m.std_shape is not None for m in data.modes):
            self.notes.append("the test data's std_shape are not used: the dynamic formulation holds the measured "
                              "shape entries at the test values (the eigenvalue's std weighs each mode's residual)")
        # the dynamic formulation has no shape residual: the data's shape std are not needed
        given_std = {k for k, v in dict(measurement_std or {}).items() if v is not None}
        weights, measurement_std = mode_uncertainty(data, weights, measurement_std, use_shapes and not dynamic)
        w, self.sigma = modal_weights(weights, measurement_std)
        #: the kinds whose residuals are divided by stated deviations, {kind: "given" | "data"}
        #: (given as options, or stated in the test data file; :mod:`femupdate.updating.noise`)
        self.stated_sources = {k: "given" if k in given_std else "data" for k in ("eigenvalue", "shape")
                               if self.sigma is not None and k in self.sigma}
        self.model = model
        self.data = data
        self.scaling = shape_scaling
        self.scaling_code = rules.SCALINGS[shape_scaling]
        self.min_mac = float(min_mac)
        self.pairing = rule
        #: the rule that made the last evaluation's pairs (``mac``, ``order`` or ``frequency``)
        self.pairing_used = ""
        self.close_modes = float(modal.close_modes)
        #: the test modes of the last evaluation paired into a group of close model modes
        self.group_fits: dict[int, grouping.GroupFit] = {}
        self.sensitivity = sensitivity
        self.sensitivity_used = sensitivity
        self.targets = build_targets(model, data, shape_scaling, ref_dof, w.get("eigenvalue", 1.0),
                                     w.get("shape", 1.0), use_shapes, n_modes)
        self.n_modes = self.targets.nm
        tg = self.targets
        self.any_shape = bool(tg.shaped.any())
        ns = np.diff(tg.pptr)
        self.n_residuals = {"shapes": tg.n_residuals, "mac": int(tg.n_test + ns.sum()),
                            "dynamic": int(tg.n_test * model.n_dofs)}[formulation]
        if self.sigma is not None and "eigenvalue" not in self.sigma or (
                self.sigma is not None and self.any_shape and not dynamic and "shape" not in self.sigma):
            # the covariance is absolute only when every residual is divided by its stated std
            self.sigma = None
        self.dynamic: DynamicResidual | None = None
        if dynamic:
            shapeless = [k + 1 for k in np.flatnonzero(~tg.shaped)]
            if shapeless:
                which = f"test mode{'s' if len(shapeless) > 1 else ''} {', '.join(map(str, shapeless))}"
                raise InputError(f"the dynamic formulation needs a shape measured at two dofs or more for every test "
                                 f"mode (its unmeasured entries are the unknowns), and {which} "
                                 f"{'have' if len(shapeless) > 1 else 'has'} none: drop "
                                 f"{'them' if len(shapeless) > 1 else 'it'}, or use --formulation shapes or mac")
            # normalised at the nominal values (the fixed ones as given), not at the start: every start of a
            # multi-start study then solves the same problem
            self.dynamic = DynamicResidual(model, tg, self.idx, start_vector(model, values, None))
        self.sensors = np.unique(tg.pos) if tg.pos.size else np.zeros(0, np.int64)  # where shape derivatives are needed
        # the last two points' evaluations and Jacobians: least squares ends on the point before
        # its last trial step, where the result is then reported (no second eigen-solution)
        self._evaluations: dict[bytes, tuple] = {}
        self._jacobians: dict[bytes, tuple] = {}
        self._pairs_seen: dict[int, int] = {}
        self.swaps: list[dict] = []
        self.nfev = 0
        self.reuse = bool(reuse)
        self._warm: Modes | None = None  # the last modes computed: the next eigen-solution starts from them

    # ------------------------------------------------------------------ evaluation
    @shared_docs(X=X_DOC)
    def evaluate(self, x) -> tuple[np.ndarray, Modes, list[tuple[int, int, float]]]:
        """Parameters, model modes and pairs at x (cached: the last x is not recomputed).

        {{X}}
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
        hit = self._evaluations.get(key)
        if hit is not None:
            self.pairing_used, self.group_fits = hit[3], hit[4]
            return hit[:3]
        p = self.to_p(x)
        if self.reuse:
            # large (sparse) models: the model's factorisation workspace, and the eigensolver
            # started from the previous evaluation's modes (the same modes, found sooner)
            modes = model_modes(self.model, p, n_modes=self.n_modes, start=self._warm)
            self._warm = modes
        else:
            modes = model_modes(self.model, p, n_modes=self.n_modes, reuse=False)
        pairs = self._pair(modes)
        _remember(self._evaluations, key, (p, modes, pairs, self.pairing_used, self.group_fits))
        return p, modes, pairs

    def _pair(self, modes: Modes) -> list[tuple[int, int, float]]:
        tg = self.targets
        T, nm = tg.n_test, min(tg.nm, modes.n_modes)
        shaped = tg.shaped
        MAC = np.zeros((T, nm))
        for k in map(int, np.flatnonzero(shaped)):
            sl = tg.measured(k)
            rules.mac_vector(tg.psi_e[sl], modes.shapes[tg.pos[sl], :nm], MAC[k])
        groups = mode_groups(modes.eigenvalues[:nm], self.close_modes) if self.close_modes > 0 else []
        combos: dict = {}
        if groups:  # a group's columns: the MAC of the best combination of its shapes (femupdate.close_modes)
            measured = {k: (tg.psi_e[tg.measured(k)], modes.shapes[tg.pos[tg.measured(k)], :nm])
                        for k in map(int, np.flatnonzero(shaped))}
            MAC, combos = group_columns(MAC, groups, measured)
        pg = pair(MAC, rule=self.pairing, min_mac=self.min_mac, shaped=shaped, model_eigenvalues=modes.eigenvalues,
                  test_eigenvalues=tg.lam_e, strict=True)
        pairs = assign_inside(pg.pairs, groups, combos) if groups else list(pg.pairs)
        self.group_fits = self._fits(modes, groups, pairs, nm) if groups else {}
        same = {j: g for g in groups for j in range(*g)}  # inside a group a new mode is no swap
        for k, j, _ in pairs:
            old = self._pairs_seen.get(k)
            if old is not None and old != j and not (j in same and same.get(old) == same[j]):
                self.swaps.append({"evaluation": self.nfev, "test_mode": k, "from_model_mode": self._pairs_seen[k],
                                   "to_model_mode": j, "rule": pg.used})
            self._pairs_seen[k] = j
        self.pairing_used = pg.used
        return pairs

    def _fits(self, modes: Modes, groups, pairs, nm: int) -> dict[int, grouping.GroupFit]:
        """What each test mode paired into a group is compared with (:func:`groups.fit`)."""
        tg = self.targets
        out = {}
        for k, j, _ in pairs:
            g = next(((a, b) for a, b in groups if a <= j < b), None)
            if g is None:
                continue
            if g[1] == nm < self.model.n_dofs:
                raise NumericalError(f"test mode {k + 1} pairs into the group of close model modes {g[0] + 1}-{g[1]}, "
                                     f"which reaches the last of the {nm} modes computed: the group may go on above "
                                     "it; compute more modes (--n-modes, n_modes)")
            sl = tg.measured(k)
            shaped = sl.stop > sl.start
            out[k] = grouping.fit(tg.psi_e[sl] if shaped else None,
                                  modes.shapes[tg.pos[sl], g[0]:g[1]] if shaped else None,
                                  modes.eigenvalues[g[0]:g[1]], g, j)
        return out

    def compared(self, modes: Modes, k: int, j: int) -> tuple[float, np.ndarray]:
        """The model eigenvalue and measured shape that test mode k is compared with at the last
        evaluation: model mode j's, or for a test mode paired into a group of close modes the
        best combination's (:attr:`group_fits`)."""
        f = self.group_fits.get(k)
        if f is not None:
            return f.eigenvalue, f.shape
        sl = self.targets.measured(k)
        return modes.eigenvalues[j], modes.shapes[self.targets.pos[sl], j]

    @shared_docs(X=X_DOC)
    def residuals(self, x) -> np.ndarray:
        """The residual vector at x: per test mode its eigenvalue residual
        w (λ_A − λ_E) / λ_E, then its shape residuals w (ψ_A − ψ_E) (paper eq. 19,
        :mod:`femupdate.rules`); with ``formulation="mac"`` its MAC residuals instead of the
        shape differences; with ``"dynamic"`` its dynamic residual at every dof (no eigenvalue
        residual, no eigen-solution).

        {{X}}
        numpy.ndarray, shape ``(m,)``
            Dimensionless residuals (``m = n_residuals``).

        Raises
        ------
        NumericalError
            Unpaired test modes; a model shape whose scaling entry is zero; non-finite residuals.
        """
        self.nfev += 1
        if self.dynamic is not None:
            r = self.dynamic.residuals(self.to_p(np.asarray(x, float)))
            if not np.all(np.isfinite(r)):
                raise NumericalError(rules.message(rules.E_NONFINITE))
            return r
        p, modes, pairs = self.evaluate(x)
        tg = self.targets
        r = np.zeros(self.n_residuals)
        row = 0
        mac = self.formulation == "mac"
        for k, j, _ in pairs:
            lam_a, phi_s = self.compared(modes, k, j)
            r[row] = rules.eigenvalue_residual(lam_a, tg.lam_e[k], tg.w_lam[k])
            row += 1
            sl = tg.measured(k)
            if sl.stop > sl.start:
                n = sl.stop - sl.start if mac else rules.n_shape_residuals(sl.stop - sl.start, tg.ref[k])
                if mac:
                    node = rules.mac_residuals(phi_s, tg.psi_e[sl], tg.w_psi[k], r[row:row + n])
                else:
                    node = rules.shape_residuals(self.scaling_code, phi_s, tg.psi_e[sl],
                                                 tg.ref[k], tg.w_psi[k], r[row:row + n])
                if node >= 0:
                    raise NumericalError(rules.message(rules.E_NODE, node))
                row += n
        if not np.all(np.isfinite(r)):
            raise NumericalError(rules.message(rules.E_NONFINITE))
        return r

    @shared_docs(X=X_DOC)
    def jacobian(self, x) -> np.ndarray:
        """The exact Jacobian ∂r/∂x at x, the derivatives by the route ``sensitivity``
        (eigenvalue derivatives only when no shape is compared).

        {{X}}
        numpy.ndarray, shape ``(m, L)``
            Rows in the order of :meth:`residuals`; sets ``sensitivity_used``.

        Raises
        ------
        NumericalError
            Unpaired test modes (as :meth:`evaluate`).
        """
        if self.dynamic is not None:
            x = np.asarray(x, float)
            self.sensitivity_used = DYNAMIC_ROUTE
            return self.dynamic.jacobian(self.to_p(x), self.dp_dx(x))
        x = np.asarray(x, float)
        key = x.tobytes()
        hit = self._jacobians.get(key)
        if hit is not None:
            self.sensitivity_used = hit[1]
            return hit[0].copy()
        p, modes, pairs = self.evaluate(x)
        tg = self.targets
        which = [j for _, j, _ in pairs]
        # a group's every mode is differentiated (its basis), after the paired modes
        groups = sorted({f.group for f in self.group_fits.values()})
        which += [i for a, b in groups for i in range(a, b) if i not in which]
        col = {j: c for c, j in enumerate(which)}
        if self.any_shape:
            # mass-normalised derivatives at the measured dofs only, by the route asked for
            sens = sensitivity_jacobian(self.model, modes, which, self.sensors, params=self.idx, values=p,
                                        method=self.sensitivity, shape_scaling="mass", relative_eigenvalues=False,
                                        groups=groups or None)
            dlam, dphi = sens.dlam, sens.dpsi
            self.sensitivity_used = sens.method
        else:
            dlam, dphi = eigenvalue_derivatives(self.model, modes, which, self.idx, groups=groups or None,
                                               values=p), None
            self.sensitivity_used = "fox-kapoor"
        dpdx = self.dp_dx(x)
        J = np.zeros((self.n_residuals, self.idx.size))
        row = 0
        mac = self.formulation == "mac"
        for c, (k, j, _) in enumerate(pairs):
            sl = tg.measured(k)
            f = self.group_fits.get(k) if sl.stop > sl.start else None
            at = np.searchsorted(self.sensors, tg.pos[sl])
            dl = dlam[c]  # Fox & Kapoor (of a group's mode: the diagonal of its restricted derivative)
            dv: np.ndarray | None
            if f is not None:  # the best combination of a group's shapes
                a, b = f.group
                assert dphi is not None
                gcols = [col[i] for i in range(a, b)]
                dv = grouping.fit_jacobian(tg.psi_e[sl], modes.shapes[tg.pos[sl], a:b], dphi[at][:, gcols, :])
                phi_s = f.shape
            else:
                phi_s = modes.shapes[tg.pos[sl], j]
                dv = dphi[at, c, :] if dphi is not None else None
            rules.eigenvalue_gradient(dl, tg.lam_e[k], tg.w_lam[k], dpdx, J[row])
            row += 1
            if sl.stop > sl.start:
                n = sl.stop - sl.start if mac else rules.n_shape_residuals(sl.stop - sl.start, tg.ref[k])
                assert dv is not None  # a shape is measured: the derivatives were computed
                if mac:
                    rules.mac_jacobian(phi_s, dv, tg.psi_e[sl], tg.w_psi[k], dpdx, J[row:row + n])
                else:
                    rules.shape_jacobian(self.scaling_code, phi_s, dv, tg.psi_e[sl], tg.ref[k], tg.w_psi[k], dpdx,
                                         J[row:row + n])
                row += n
        _remember(self._jacobians, key, (J.copy(), self.sensitivity_used))
        return J

    @property
    def residual_dof(self) -> int:
        """The number of independent residual equations (for the residual variance of the
        diagnostics): ``n_residuals``, except for the dynamic formulation, whose residual of
        each mode has as many equations as dofs less one per unknown shape entry, that is one per
        measured entry (the unknowns are eliminated at every point)."""
        if self.dynamic is not None:
            return int(np.diff(self.targets.pptr).sum())
        return self.n_residuals

    @property
    def formulation_used(self) -> str:
        """The formulation as results report it: ``"eigenvalues"`` when no mode shape is used
        (frequencies alone), else :attr:`formulation`."""
        return self.formulation if self.any_shape else "eigenvalues"

    def expanded_shapes(self, x) -> np.ndarray | None:
        """The full shapes of the dynamic formulation at x, (n_dofs, T): the measured entries the
        test shape (unit length over them), the others the unknowns solved for; None for the
        other formulations."""
        if self.dynamic is None:
            return None
        return self.dynamic.shapes(self.to_p(np.asarray(x, float)))

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


def _remember(cache: dict, key: bytes, value: tuple, size: int = 2) -> None:
    """Keep ``value`` under ``key`` among the ``size`` most recent entries of ``cache``."""
    cache.pop(key, None)
    cache[key] = value
    while len(cache) > size:
        cache.pop(next(iter(cache)))


# Parametrisation and Targets live in their own modules; they are named here too, where the problem's
# readers have always found them
__all__ = ["Problem", "Parametrisation", "Targets", "x_of_p", "x_bounds", "start_error", "check_determined", "modal_weights",
           "build_targets", "PARAMETRISATIONS", "SHAPE_SCALINGS", "SENSITIVITY_CHOICES", "TARGETS_PER_MODE",
           "TARGETS_PER_POSITION", "FORMULATIONS", "check_formulation", "DYNAMIC_ROUTE"]
