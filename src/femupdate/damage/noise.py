"""The noise levels of :func:`~femupdate.damage.detect_damage` and what each rests on: stated by the
caller, stated in the test data (per mode, as ``update`` reads ``std_frequency`` / ``std_shape``),
estimated from the expansion misfit, or assumed (:func:`stated_noise`, :func:`noise_levels`); and
one draw of that noise on the measured modes (:func:`perturbed`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from .._errors import InputError
from ..testdata import TestData

if TYPE_CHECKING:
    from .localise import Expansion, Measured

DEFAULT_FREQUENCY_NOISE = 0.001  # relative frequency std when none is stated
DEFAULT_SHAPE_NOISE = 0.005      # shape std when none is stated and the expansion misfit cannot tell it


#: the bases a noise level can rest on (the result's ``confidence.noise.basis``)
BASIS_CALLER = "stated by the caller"
BASIS_DATA = "stated in the test data"
BASIS_ASSUMED = "assumed: stated neither in the test data nor by the caller"
BASIS_EXPANSION = "estimated from the expansion misfit: not stated"


@dataclass(frozen=True)
class StatedNoise:
    """The noise levels stated by the caller or the test data: relative frequency std, and the shape
    std relative to each shape's largest value (None: not stated).

    Attributes
    ----------
    frequency, shape : float or None
        One level for every mode (the median of ``*_modes`` when the data state them per mode).
    dof : tuple of (str, float)
        With levels estimated from a fit, the degrees of freedom of each fitted unknown's variance
        under them (the uncertainty of the estimated levels; empty when stated).
    frequency_modes, shape_modes : tuple of float or None
        Per test mode (every mode of the data, in order), when the test data state them.
    basis : dict
        {"frequency": ..., "shape": ...}: what each level rests on (``BASIS_*``; shape None when not
        stated: the expansion's misfit then estimates it).
    """

    frequency: float = DEFAULT_FREQUENCY_NOISE
    shape: float | None = None
    frequency_modes: tuple | None = None
    shape_modes: tuple | None = None
    basis: tuple = (("frequency", BASIS_ASSUMED), ("shape", None))
    #: ((unknown, ν), ...): with levels estimated by REML, the Satterthwaite degrees of freedom of
    #: each fitted unknown's variance under them (:func:`femupdate.variance.weighted_dof`); empty
    #: when every level used is stated
    dof: tuple = ()


def data_noise(data: TestData | None) -> tuple[np.ndarray | None, np.ndarray | None]:
    """The noise the test data state per mode, in damage's terms: relative frequency std
    (``std_eigenvalue`` / 2) of every mode, and the shape std relative to each shape's largest
    value (``std_shape`` — unit-length scaling, as ``update`` reads it — times ‖φ‖ / max|φ|) of
    every shaped mode (1 for a mode without a shape); None for a kind the data do not state.
    A kind stated for some modes but not all is refused as ``update`` refuses it."""
    from ..updating.targets import mode_uncertainty
    from .localise import realised as _realised

    if data is None or not data.modes:
        return None, None
    _, std = mode_uncertainty(data, None, None)
    std = std or {}
    f = None if "eigenvalue" not in std else np.broadcast_to(np.asarray(std["eigenvalue"], float) / 2, len(data.modes)).copy()
    sh = None
    if "shape" in std:
        raw = np.broadcast_to(np.asarray(std["shape"], float), len(data.modes))
        sh = np.array([raw[k] * float(np.linalg.norm(_realised(m)) / np.max(np.abs(_realised(m))))
                       if m.has_shape and len(m.dofs) >= 2 else 1.0 for k, m in enumerate(data.modes)])
    return f, sh


def stated_noise(noise: Mapping | None, data: TestData | None = None) -> StatedNoise:
    """The stated noise: ``{"frequency": ..., "shape": ...}`` of the caller checked (:class:`InputError`
    for an unknown key or a negative level), each kind the caller leaves out taken from the test
    data's per-mode standard deviations when they state them (:func:`data_noise`); the frequency's
    otherwise ``DEFAULT_FREQUENCY_NOISE``, said to be assumed (``basis``)."""
    noise = {k: v for k, v in dict(noise or {}).items() if v is not None}
    unknown_noise = sorted(set(noise) - {"frequency", "shape"})
    if unknown_noise:
        raise InputError(f"noise: unknown key(s) {', '.join(unknown_noise)} (use frequency, shape)")
    if not float(noise.get("frequency", 0.0)) >= 0 or not float(noise.get("shape", 0.0)) >= 0:
        raise InputError("noise levels must be >= 0")
    f_modes, s_modes = data_noise(data) if data is not None else (None, None)
    shaped = [k for k, m in enumerate(data.modes) if m.has_shape and len(m.dofs) >= 2] if data is not None else []
    if "frequency" in noise:
        sig_f, f_modes, b_f = float(noise["frequency"]), None, BASIS_CALLER
    elif f_modes is not None:
        sig_f, b_f = float(np.median(f_modes)), BASIS_DATA
    else:
        sig_f, b_f = DEFAULT_FREQUENCY_NOISE, BASIS_ASSUMED
    if "shape" in noise:
        sig_s, s_modes, b_s = float(noise["shape"]), None, BASIS_CALLER
    elif s_modes is not None and shaped:
        sig_s, b_s = float(np.median(s_modes[shaped])), BASIS_DATA
    else:
        sig_s, s_modes, b_s = None, None, None
    return StatedNoise(sig_f, sig_s, None if f_modes is None else tuple(map(float, f_modes)),
                      None if s_modes is None else tuple(map(float, s_modes)), (("frequency", b_f), ("shape", b_s)))


@dataclass(frozen=True)
class NoiseLevels:
    """The noise levels the steps use.

    Attributes
    ----------
    frequency : float
        Relative frequency std (as stated; the median of the modes' when the data state them).
    shape : float
        Shape std relative to each shape's largest value, weighting the localisation: as stated;
        else the median expansion misfit per mode where the basis is smaller than the sensor set;
        else ``DEFAULT_SHAPE_NOISE``.
    shape_verify : float
        The shape std of the verification and the simulated replicates: as stated; else the
        expansion misfit pooled over the modes, at the upper end of its 99 % confidence interval.
    frequency_modes, shape_modes : tuple of float or None
        The verification's and the replicates' levels per test mode, when the data state them.
    basis : tuple of (kind, str)
        What each level rests on (``BASIS_*``).
    """

    frequency: float
    shape: float
    shape_verify: float
    frequency_modes: tuple | None = None
    shape_modes: tuple | None = None
    basis: tuple = ()

    @property
    def zero(self) -> bool:
        """No noise to verify against or to vary."""
        return not (self.frequency > 0 or self.shape_verify > 0 or any(self.frequency_modes or ())
                    or any(self.shape_modes or ()))

    @property
    def verify_levels(self) -> tuple:
        """(frequency, shape) of the verification and the replicates: per mode where stated so, else one level."""
        return (np.array(self.frequency_modes) if self.frequency_modes is not None else self.frequency,
                np.array(self.shape_modes) if self.shape_modes is not None else self.shape_verify)

    def record(self) -> dict:
        """``frequency``, ``shape`` (localisation), ``shape_verify`` and ``basis`` {kind: what it rests on}."""
        out = {"frequency": self.frequency, "shape": self.shape, "shape_verify": self.shape_verify,
               "basis": {k: v for k, v in self.basis}}
        if self.frequency_modes is not None:
            out["frequency_modes"] = list(self.frequency_modes)
        if self.shape_modes is not None:
            out["shape_modes"] = list(self.shape_modes)
        return out


def noise_levels(stated: StatedNoise, meas: Measured, exp: Expansion) -> tuple[NoiseLevels, list[str]]:
    """The noise levels (:class:`NoiseLevels`) and notes saying what each rests on when not stated."""
    Phi_a, misfit = meas.shapes, exp.error
    n_s, m, n_basis, full = meas.n_sensors, meas.n_modes, exp.n_basis, exp.full
    basis = dict(stated.basis)
    if stated.shape is not None:
        sig_s = stated.shape
    elif not full and n_s > n_basis:
        sig_s = float(np.median(misfit * np.linalg.norm(Phi_a, axis=0) / np.sqrt(n_s - n_basis) / np.max(np.abs(Phi_a), axis=0)))
        basis["shape"] = BASIS_EXPANSION
    else:
        sig_s = DEFAULT_SHAPE_NOISE
        basis["shape"] = BASIS_ASSUMED
    # the verification's shape noise: as stated; else, from the expansion misfit pooled over the modes, at the
    # upper end of its 99 % confidence interval (a level underestimated would refuse the right set)
    sig_s_verify = sig_s
    notes = []
    if basis.get("frequency") == BASIS_ASSUMED:
        notes.append(f"frequency noise stated neither in the test data (std_frequency) nor by the caller: "
                     f"{stated.frequency:g} assumed (--noise-frequency to state it)")
    if stated.shape is None and not full and n_s > n_basis:
        from scipy.special import chdtri

        nu = m * (n_s - n_basis)
        pooled = float(np.sqrt(np.sum((misfit * np.linalg.norm(Phi_a, axis=0) / np.max(np.abs(Phi_a), axis=0)) ** 2) / nu))
        sig_s_verify = pooled * math.sqrt(nu / float(chdtri(nu, 1 - 0.01)))
        notes.append(f"shape noise not stated: the verification takes {sig_s_verify:.3g} (the expansion misfit pooled over "
                     "the modes, upper end of its 99 % confidence interval; --noise-shape to state it)")
    elif stated.shape is None:
        notes.append(f"shape noise stated neither in the test data (std_shape) nor by the caller, and the expansion "
                     f"cannot estimate it: {sig_s:g} assumed (--noise-shape to state it)")
    return NoiseLevels(stated.frequency, sig_s, sig_s_verify, stated.frequency_modes, stated.shape_modes,
                       tuple(basis.items())), notes


def perturbed(meas: Measured, levels: NoiseLevels, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """The measured eigenvalues and shapes with one draw of the noise (``levels.shape`` relative to
    each shape's largest value)."""
    lam, Phi_a = meas.eigenvalues, meas.shapes
    peak = np.max(np.abs(Phi_a), axis=0)
    return (lam * (1.0 + levels.frequency * rng.standard_normal(meas.n_modes)) ** 2,
            Phi_a + levels.shape * peak * rng.standard_normal(Phi_a.shape))


__all__ = ["BASIS_CALLER", "BASIS_DATA", "BASIS_ASSUMED", "BASIS_EXPANSION", "StatedNoise", "data_noise", "stated_noise",
           "NoiseLevels", "noise_levels", "perturbed", "DEFAULT_FREQUENCY_NOISE", "DEFAULT_SHAPE_NOISE"]


#: the basis of a level estimated from the fit of every unknown
BASIS_ESTIMATED = "estimated from the fit of every unknown (REML variance components)"
#: the basis of a level estimated from the fit of the located unknowns (when every unknown's fit cannot tell it)
BASIS_LOCATED = ("estimated from the fit of the located unknowns (REML variance components; conditional on the "
                 "located set)")
#: the basis of a frequency level the located fit shows below the assumed one: the assumed, larger, level is used
BASIS_BELOW_ASSUMED = ("estimated from the fit of the located unknowns below the assumed level: the assumed, larger, "
                       "level is used (conservative)")
#: the basis of a frequency level that neither fit can estimate: the figures resting on it are conditional
BASIS_NOT_ESTIMABLE = ("not estimable from these data (too few modes for the unknowns): assumed, and the standard "
                       "errors and rates resting on it are conditional on it")


def _fit_components(model, names, fitted, data: TestData, start=None, pairing: str | None = None):
    """The REML variance components (:func:`femupdate.variance.variance_components`) of the fit of
    the unknowns ``fitted`` (a subset of ``names``; empty: the baseline's residuals, nothing
    fitted) from ``start`` ({name: value}; default the baseline) with the test and model modes
    paired by ``pairing`` (default the problem's), the fit's test
    (:func:`femupdate.variance.fit_test`) and the data realised; or (None, None, note) when the
    data are too few or the components not available; then the eigenvalue residuals' own sum of
    squares and redundancy at that fit (:func:`_eigen_share`; None without eigenvalues); last, the
    fit's Jacobian (columns: ``fitted``)."""
    import importlib

    try:  # femupdate.variance (issue 27 item 2): by name, for a build without it
        layout = importlib.import_module("femupdate.updating.noise").layout
        variance = importlib.import_module("femupdate.variance")
    except ImportError:  # the variance components are not in this version: the levels stay assumed
        return None, None, None, None, None
    from ..updating import Problem
    from ..updating.solve import solve

    prob = Problem(model, data, list(fitted) if len(fitted) else list(names), shape_scaling="unit",
                   x0=dict(start) if start else None, pairing=pairing)
    L = len(fitted)
    if prob.n_residuals <= L + 1:
        return None, None, (f"the noise cannot be estimated: {prob.n_residuals} residuals for {L} unknowns (state it: "
                            "--noise-frequency, --noise-shape, or std_frequency / std_shape in the test data)"), None, None
    if L:
        sol, _, _ = solve(prob, model.bounds, regularization=None, method="trf", ftol=1e-12, xtol=1e-12, gtol=1e-12,
                          max_nfev=200 + 20 * L)
        x = sol.x
        J = prob.jacobian(x)
    else:  # nothing located: the baseline itself is the fit
        x = prob.x_start
        J = np.zeros((prob.n_residuals, 0))
    r = prob.residuals(x)
    lay = layout(prob, None)
    vc = variance.variance_components(J, r, lay.blocks, kinds=lay.kinds, lost=lay.lost)
    plausible = dict(lay.plausible)
    if plausible:  # a pool across kinds is held to the largest of their bounds
        plausible["all"] = max(plausible.values())
    eig_rows = [np.asarray(rows, np.intp).ravel() for lb, rows in lay.blocks.items() if lay.kinds.get(lb) == "eigenvalue"]
    own = _eigen_share(J, r, vc, np.concatenate(eig_rows)) if eig_rows else None
    return vc, variance.fit_test(vc, plausible=plausible), None, own, J


def _eigen_share(J, r, vc, rows: np.ndarray) -> tuple[float, float]:
    """The eigenvalue residuals' own sum of squares e_bᵀe_b and redundancy r_b = n_b − tr H_bb at
    the fit, weighted by the components ``vc`` estimated (Förstner's step, as
    :func:`femupdate.variance.variance_components` takes it): what the eigenvalues tell of their
    noise on their own, also where their redundancy is too small for a component of their own and
    they were pooled with the shapes."""
    m = r.size
    var = np.ones(m)
    for c in vc.components:
        var[c.rows] = c.variance if math.isfinite(c.variance) else 0.0
    top = float(np.max(var)) if m else 0.0
    var = np.where(var > 0, var, 1e-24 * top) if top > 0 else np.ones(m)
    w = 1.0 / var
    if J.shape[1]:
        Jw = J * w[:, None]
        Ninv = np.linalg.pinv(J.T @ Jw, rcond=1e-12, hermitian=True)
        e = r - J @ (Ninv @ (Jw.T @ r))
        lev = np.einsum("ij,jk,ik->i", J, Ninv, Jw)
    else:
        e, lev = r, np.zeros(m)
    return float(e[rows] @ e[rows]), float(rows.size - lev[rows].sum())


def _upper_frequency(own: tuple[float, float] | None) -> float | None:
    """The upper end of the one-sided 99 % confidence interval of the relative frequency std the
    eigenvalues tell on their own (σ_f = σ_λ / 2, r_b σ̂² / σ² ~ χ²(r_b)); None with less redundancy
    than ``MIN_TEST_DOF`` (none for the frequencies: round-off would decide)."""
    from scipy.special import chdtri

    from ..variance import MIN_TEST_DOF

    if own is None or not own[1] >= MIN_TEST_DOF:
        return None
    return 0.5 * math.sqrt(max(own[0], 0.0) / float(chdtri(own[1], 0.99)))


def estimated_noise(model, names, data: TestData, stated: StatedNoise, fitted=None, *, start=None,
                    pairing: str | None = None) -> tuple[StatedNoise | None, dict | None, list[str]]:
    """The noise the data do not state, estimated from the fit of every unknown (plain updating
    from the baseline, as ``update`` fits them) — or, given ``fitted``, of those unknowns only (the
    located set, the others at the baseline; empty: the baseline's own residuals) — by REML
    variance components per block
    (:func:`femupdate.variance.variance_components` on the blocks of
    :func:`femupdate.updating.noise.layout`: each mode's eigenvalue and shape, pooled where they
    lack the redundancy), and that fit's test (:func:`femupdate.variance.fit_test`: a plausibility
    bound on the estimated levels — a pool across kinds held to the largest of their bounds — a
    model error when they exceed what a vibration test gives).

    Returns
    -------
    noise : StatedNoise or None
        ``stated`` with the kinds it did not state estimated (per mode; ``basis``
        ``BASIS_ESTIMATED``, or ``BASIS_LOCATED`` given ``fitted``); None when nothing is to be
        estimated, the variance components are not available, or the data are too few (a note
        says why).  The frequency level is estimated only where the eigenvalues have redundancy
        of their own; where they are pooled with the shapes (fewer modes than unknowns), it is
        left as stated (:func:`frequency_unknown` then says so).
    model_error : dict or None
        The fit's test (``test``, ``statistic``, ``dof``, ``p_value``, ``alpha``, ``verdict``); when it
        flags the fit, no level is estimated (None, None and a note: a fit from the baseline that
        ended in a local minimum cannot be told from a model error here — the verification's
        chi-square test against the assumed levels then judges).
    notes : list of str
    """
    basis = dict(stated.basis)
    want_f, want_s = basis.get("frequency") == BASIS_ASSUMED, basis.get("shape") is None
    if not (want_f or want_s):
        return None, None, []
    from .._errors import InputError, NumericalError
    from .localise import realised_data

    which = "every unknown" if fitted is None else "the located unknowns"
    data = realised_data(data)
    try:
        fit_names = list(names) if fitted is None else list(fitted)
        vc, test, why, own, J = _fit_components(model, names, fit_names, data, start, pairing)
    except (InputError, NumericalError, ValueError) as exc:
        return None, None, [f"the noise could not be estimated from the fit of {which}: {exc}"]
    if vc is None or test is None:
        return None, None, [why] if why else []
    if test.flagged:  # a model error, or a fit from the baseline that ended in a local minimum: no estimate
        return None, None, list(vc.notes) + [
            f"the noise was not estimated: the fit of {which} from the baseline leaves more than a vibration "
            f"test's noise ({test.headline()}); a model error or a local minimum of that fit — the levels stay "
            "assumed and the verification tests the located set against them"]
    by_label = {mb: c for c in vc.components for mb in c.members}
    T = len(data.modes)
    f_modes, s_modes = list(stated.frequency_modes or [stated.frequency] * T), list(stated.shape_modes or [1.0] * T)
    notes = list(vc.notes)
    eig = [by_label.get(f"eigenvalue mode {k + 1}") for k in range(T)]
    alone = all(c is not None and c.kind == "eigenvalue" and math.isfinite(c.std) for c in eig)
    assumed, up = stated.frequency, _upper_frequency(own)
    # the located fit: the eigenvalues pooled with the shapes (too little redundancy for a component of their own)
    # still tell their noise is below the assumed level when the upper end of its 99 % interval is below it
    shown_below = want_f and fitted is not None and not alone and up is not None and up < assumed
    if want_f and not alone and not shown_below:
        # too few eigenvalues for the unknowns: pooled with the shapes, their level is not the frequencies' own
        want_f = False
        notes.append(f"the frequency noise cannot be estimated on its own from the fit of {which} (too few "
                     "modes for the unknowns: their block is pooled with the shapes" + (
                         f", and they do not show it below the assumed {assumed:g}: 99 % upper bound {up:.3g}"
                         if fitted is not None and up is not None else "") + ")")
    for k, m in enumerate(data.modes):
        if want_f:
            c = eig[k]
            # the residual is the relative eigenvalue error: 2 sigma_f
            if alone and c is not None:
                f_modes[k] = c.std / 2
            else:  # shown below the assumed level: the eigenvalues' own estimate (floored below)
                assert own is not None and own[1] > 0
                f_modes[k] = 0.5 * math.sqrt(max(own[0], 0.0) / own[1])
        if want_s and m.has_shape and len(m.dofs) >= 2:
            c = by_label.get(f"shape mode {k + 1}")
            if c is None or not math.isfinite(c.std):
                return None, None, notes + [f"the shape noise cannot be estimated from the fit of {which}"]
            phi = np.abs(np.asarray(m.shape, float))
            s_modes[k] = c.std * float(np.linalg.norm(phi) / np.max(phi))  # unit-length scaling -> largest value
    shaped = [k for k, m in enumerate(data.modes) if m.has_shape and len(m.dofs) >= 2]
    if not (want_f or want_s):
        return None, None, notes
    label = BASIS_ESTIMATED if fitted is None else BASIS_LOCATED
    label_f = label
    if want_f and fitted is not None:  # a located set's estimate is never taken below the assumed level
        below = [k for k in range(T) if f_modes[k] < assumed]
        if below:
            estimate = float(np.median(f_modes))
            f_modes = [max(f, assumed) for f in f_modes]
            label_f = BASIS_BELOW_ASSUMED if len(below) == T else label
            notes.append(f"the frequency noise estimated from the fit of {which} is below the assumed level "
                         + (f"(median {estimate:.3g}" if len(below) == T else
                            f"in mode(s) {', '.join(str(k + 1) for k in below)} (median {estimate:.3g}")
                         + (f", 99 % upper bound {up:.3g}" if up is not None else "")
                         + f"): the assumed {assumed:g}, larger, is used there — conservative for the verification, "
                         "the standard errors and the rates (--noise-frequency to state it)")
    if want_f:
        basis["frequency"] = label_f
    if want_s:
        basis["shape"] = label
    out = StatedNoise(float(np.median(f_modes)) if want_f else stated.frequency,
                      float(np.median([s_modes[k] for k in shaped])) if want_s and shaped else stated.shape,
                      tuple(map(float, f_modes)) if (want_f or stated.frequency_modes is not None) else None,
                      tuple(map(float, s_modes)) if (want_s or stated.shape_modes is not None) else None,
                      tuple(basis.items()), _estimate_dof(vc, J, fit_names, want_f and label_f != BASIS_BELOW_ASSUMED,
                                                          want_s))
    said = ", ".join(f"{k} {v:.3g}" for k, v in (("frequency", out.frequency), ("shape", out.shape))
                     if v is not None and basis.get(k) in (label, BASIS_BELOW_ASSUMED))
    dof = [c.dof for c in vc.components if c.kind == "eigenvalue" and want_f and alone] or (
        [own[1]] if want_f and own is not None else [])
    notes.append(f"noise not stated: estimated from the fit of {which} (REML variance components per block; "
                 f"median {said}" + (f"; the frequencies' with {dof[0]:.1f} degrees of freedom" if dof else "")
                 + f"); its test: {test.headline()}")
    return out, test.record(), notes


def _estimate_dof(vc, J, fitted, frequency: bool, shape: bool) -> tuple:
    """((unknown, ν), ...) of the ``fitted`` unknowns: the Satterthwaite degrees of freedom of
    each one's variance in the fit weighted by the components ``vc``, counting as estimated the
    components of the kinds estimated here (``frequency``: the eigenvalues, ``shape``: the shapes;
    a pool across kinds when either is); empty when neither is or the fit has no unknowns."""
    from ..variance import weighted_dof

    if not (frequency or shape) or J is None or not J.shape[1]:
        return ()
    est = [(c.kind == "eigenvalue" and frequency) or (c.kind == "shape" and shape)
           or (c.kind not in ("eigenvalue", "shape") and (frequency or shape)) for c in vc.components]
    nu = weighted_dof(J, vc.components, est)
    return tuple((n, float(v)) for n, v in zip(fitted, nu) if not math.isnan(v))


def frequency_unknown(stated: StatedNoise) -> bool:
    """True when the frequency level rests on nothing but the default assumption."""
    return dict(stated.basis).get("frequency") == BASIS_ASSUMED


__all__ += ["BASIS_ESTIMATED", "BASIS_LOCATED", "BASIS_BELOW_ASSUMED", "BASIS_NOT_ESTIMABLE", "estimated_noise", "frequency_unknown"]
