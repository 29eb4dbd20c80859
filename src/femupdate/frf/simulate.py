r"""Frequency response functions of the model: receptance, mobility, accelerance; noise models.

The receptance matrix (paper eq. 23, the inverse of the dynamic stiffness)

.. math::  \alpha(\omega) = Z(\omega)^{-1}, \qquad Z = K - \omega^2 M \ \ \text{(undamped)},

is never formed: only its columns at the excitation dofs are solved for (one solve per
excitation dof and line), and the rows at the response dofs kept.  Mobility is
:math:`i\omega\alpha` and accelerance :math:`-\omega^2\alpha`.  Damping is optional
(:class:`~femupdate.frf.Damping`: Rayleigh and structural); the paper's models are undamped and
their receptances real.

Noise models (:func:`add_noise`) act on simulated test data:

* ``"relative"``: every value times :math:`(1 + \epsilon)`, :math:`\epsilon \sim N(0, \sigma^2)`
  (complex data: real and imaginary parts each of variance :math:`\sigma^2/2`);
* ``"absolute"``: :math:`+\,\sigma\,\epsilon` in the units of the response (a noise floor);
* ``"coherent"``: one relative error per spectral line, shared by every response channel: the
  error of the force measurement, which scales all the line's FRFs together.
"""

from __future__ import annotations

import dataclasses
import logging
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np

from .._docs import FRF_ARGUMENTS, shared_docs

from .._budget import LINE_BYTES, check_count
from .._checks import array_arg, choice_arg, count_arg, mapping_arg, model_arg, real_arg, strings_arg, values_arg
from .._errors import InputError
from ..dofs import canonical_all, describe
from ..serialise import RunContext, Serialisable
from ..testdata import FRFData
from .damping import Damping, as_damping, nonnegative
from .lines import LineSystems, check_omega, force_vector
from .resonance import resonances

log = logging.getLogger(__name__)

KINDS = ("receptance", "mobility", "accelerance")
NOISE_KINDS = ("relative", "absolute", "coherent")
#: lines closer than this (relative eigenvalue distance) to an undamped resonance are refused
SINGULAR_TOL = 1e-10


def convert(h: np.ndarray, omega: np.ndarray, to: str = "receptance", frm: str = "receptance") -> np.ndarray:
    r"""Convert FRFs between receptance, mobility (:math:`i\omega\alpha`) and accelerance
    (:math:`-\omega^2\alpha`); the first axis of ``h`` runs over the lines ``omega``.

    Parameters
    ----------
    h : array_like, shape ``(n_lines, ...)``
        FRFs of kind ``frm``.
    omega : array_like, shape ``(n_lines,)``
        Spectral lines, rad/s.
    to, frm : str, default ``"receptance"``
        Target and source kinds: ``"receptance"``, ``"mobility"`` or ``"accelerance"``.

    Returns
    -------
    numpy.ndarray, same shape as ``h``
        The converted FRFs (``h`` itself, as an array, when ``to == frm``; complex otherwise).

    Raises
    ------
    InputError
        An unknown kind; converting from mobility or accelerance at a zero frequency.
    """
    for k in (to, frm):
        if k not in KINDS:
            raise InputError(f"unknown FRF kind {k!r}: use {', '.join(KINDS)}")
    if to == frm:
        return np.asarray(h)
    w = np.asarray(omega, float).reshape((-1,) + (1,) * (np.ndim(h) - 1))
    factor = {"receptance": np.ones_like(w, dtype=complex), "mobility": 1j * w, "accelerance": -(w**2) + 0j}
    if frm != "receptance" and np.any(w == 0):
        raise InputError(f"a {frm} cannot be converted at zero frequency")
    return np.asarray(h) * factor[to] / factor[frm]


def response_dofs(model, response: Sequence[str] | None, what: str = "response") -> tuple[tuple[str, ...], np.ndarray]:
    """Labels and model positions of the response dofs (default every model dof).

    Parameters
    ----------
    model : Model
        The model.
    response : sequence of str, optional
        Dof labels ``"node:dir"`` (default: every model dof).
    what : str, default ``"response"``
        What the dofs are, for messages.

    Returns
    -------
    labels : tuple of str
        Canonical labels.
    index : numpy.ndarray of int, shape ``(len(labels),)``
        Their positions in the model matrices.

    Raises
    ------
    InputError
        No dofs given, or a label that is not a model dof.
    """
    labels = model.dofs if response is None else canonical_all(response, what)
    if not labels:
        raise InputError(f"{what}: no dofs given")
    return tuple(labels), model.dof_index(labels, what)


def check_lines(model, omega, values=None, damping: Damping | None = None, tol: float = SINGULAR_TOL):
    """Refuse undamped lines that lie (numerically) on a resonance of the model, naming them.

    Checked against every eigenvalue for models up to :data:`femupdate.modal.DENSE_LIMIT` dofs;
    larger models rely on the sparse factorisation, which reports an exactly singular line
    (:class:`NumericalError`, naming it).  Damped models are not checked.

    Parameters
    ----------
    model : Model
        The model.
    omega : numpy.ndarray, shape ``(n_lines,)``
        Spectral lines, rad/s.
    values : None, mapping of str to float, or array_like, optional
        Parameter values (default nominal).
    damping : Damping or mapping, optional
        Default undamped.
    tol : float, default :data:`SINGULAR_TOL`
        Relative eigenvalue distance below which a line counts as on a resonance.

    Returns
    -------
    Resonances or None
        The model's resonances relative to the lines (undamped models up to the dense limit),
        else ``None``.

    Raises
    ------
    InputError
        A line on an undamped resonance (named).
    """
    from ..modal import DENSE_LIMIT as MODAL_DENSE

    damping = as_damping(damping)
    if not damping.undamped or model.n_dofs > MODAL_DENSE:
        return None
    res = resonances(model, omega, values)
    bad = res.near(tol)
    if bad.size:
        raise InputError(f"frequencies coincide with undamped model resonances: {res.describe(bad)}; "
                         "move these lines or add damping")
    return res


def receptance(model, omega, excitation: Sequence[str], response: Sequence[str] | None = None, values=None,
               damping=None, method: str = "auto") -> np.ndarray:
    r"""Receptances :math:`\alpha_{ab}(\omega)`, shape ``(n_lines, n_response, n_excitation)``.

    Paper eq. 23: α = Z⁻¹, Z = K − ω²M (undamped), only the columns at ``excitation``.

    Parameters
    ----------
    model : Model
        The parametrised model.
    omega : array_like, shape ``(n_lines,)``
        Frequencies in rad/s.
    excitation : sequence of str
        Dof labels of the columns of α solved for (one solve per dof and line).
    response : sequence of str, optional
        Dof labels of the rows kept (default every model dof).
    values : None, mapping of str to float, or array_like, optional
        Parameter values (default nominal).
    damping : Damping or mapping, optional
        :class:`Damping` or ``{alpha, beta, eta}``; default undamped (real receptances).
    method : {"auto", "dense", "sparse"}, default "auto"
        ``"auto"``: stacked dense solves up to ``DENSE_LIMIT`` dofs, sparse LU above.

    Returns
    -------
    numpy.ndarray, shape ``(n_lines, n_response, n_excitation)``
        Receptances (m/N for SI models); real when undamped, complex otherwise.

    Raises
    ------
    InputError
        Unknown dofs (named), bad frequencies, an undamped line on a resonance (named).
    """
    w = check_omega(omega)
    damping = as_damping(damping)
    p = model.resolve(values)
    exc = canonical_all(excitation, "excitation")
    _, ie = response_dofs(model, exc, "excitation")
    _, ir = response_dofs(model, response)
    check_lines(model, w, p, damping)
    E = np.zeros((model.n_dofs, len(exc)))
    E[ie, np.arange(len(exc))] = 1.0
    X = LineSystems(model, p, w, damping, method).solve(E)
    return X[:, ir, :]


@shared_docs(FRF_ARGUMENTS=FRF_ARGUMENTS)
def frf(model, omega, force: Mapping, response: Sequence[str] | None = None, values=None, damping=None,
        kind: str = "receptance", method: str = "auto") -> tuple[tuple[str, ...], np.ndarray]:
    """Responses to the force vector ``{dof: amplitude}``: ``(dofs, H)`` with ``H`` of shape
    ``(n_lines, n_response)``, as receptance (displacement / force), mobility or accelerance.

    One solve per line whatever the number of loaded dofs.  Real when undamped, real force and
    receptance; complex otherwise.

    Parameters
    ----------
    {{FRF_ARGUMENTS}}
    kind : str, default ``"receptance"``
        ``"receptance"``, ``"mobility"`` or ``"accelerance"``.
    method : str, default ``"auto"``
        ``"auto"``, ``"dense"`` or ``"sparse"``, as :func:`receptance`.

    Returns
    -------
    dofs : tuple of str
        The response dof labels.
    H : numpy.ndarray, shape ``(n_lines, n_response)``
        The responses (receptance: displacement per the given force, m for N).

    Raises
    ------
    InputError
        An unknown kind or method; bad frequencies; a malformed force or a force/response dof
        the model lacks; an undamped line on a resonance; and as :meth:`Model.resolve`.
    """
    if kind not in KINDS:
        raise InputError(f"unknown FRF kind {kind!r}: use {', '.join(KINDS)}")
    w = check_omega(omega)
    damping = as_damping(damping)
    p = model.resolve(values)
    f = force_vector(model, force)
    labels, ir = response_dofs(model, response)
    check_lines(model, w, p, damping)
    X = LineSystems(model, p, w, damping, method).solve(f)[:, ir]
    return labels, (convert(X, w, kind) if kind != "receptance" else X)


@dataclass(frozen=True, eq=False)
class SimulatedFRF(FRFData, Serialisable):
    """Simulated FRF test data (:func:`simulate`): receptances, as :class:`~femupdate.FRFData`
    (ready for updating), with what they were simulated with; a result of kind ``frf``
    (``femupdate frf``): :meth:`~femupdate.serialise.Serialisable.to_json` gives the command's
    JSON, the responses in :attr:`quantity`.

    Attributes
    ----------
    omega, force, dofs, response
        As :class:`~femupdate.FRFData` (``response``: receptances).
    quantity : {"receptance", "mobility", "accelerance"}, default ``"receptance"``
        What :meth:`responses` and the JSON give (``femupdate frf --kind``); the data stay
        receptances.  :meth:`with_quantity` changes it.
    damping : Damping
        The model's damping.
    noise : dict
        ``{"level", "kind", "seed"}`` of the noise added (level 0: exact data).
    parameters : dict of str to float
        Every model parameter's value the responses were simulated at.
    context : RunContext, optional
        The model (its name goes into the JSON; the note on lines near a resonance is computed
        from it when the JSON is written).
    """

    quantity: str = "receptance"
    damping: Damping = field(default_factory=Damping)
    noise: dict = field(default_factory=lambda: {"level": 0.0, "kind": "relative", "seed": None})
    parameters: dict = field(default_factory=dict)
    context: RunContext | None = field(default=None, compare=False, repr=False)

    kind: ClassVar[str] = "frf"

    def __post_init__(self):
        super().__post_init__()
        if self.quantity not in KINDS:
            raise InputError(f"unknown FRF quantity {self.quantity!r}: use {', '.join(KINDS)}")

    def responses(self) -> np.ndarray:
        """The responses in :attr:`quantity` (:func:`convert` of the receptances), ``(n_lines, n_dofs)``."""
        return convert(self.response, self.omega, self.quantity) if self.quantity != "receptance" else self.response

    def with_quantity(self, quantity: str) -> SimulatedFRF:
        """A copy whose :meth:`responses` and JSON give ``quantity`` (``"receptance"``,
        ``"mobility"`` or ``"accelerance"``)."""
        return dataclasses.replace(self, quantity=quantity)

    def test_data(self) -> dict:
        """The test-data JSON object of the receptances, ``{"frf": {omega_rad_s, force,
        response}}`` (``femupdate frf --test-data``), ready for ``frf-update``."""
        from ..io.results import to_jsonable
        from .record import pairs

        return to_jsonable({"frf": {"omega_rad_s": self.omega, "force": dict(self.force),
                                    "response": {d: pairs(self.response[:, k]) for k, d in enumerate(self.dofs)}}})

    def payload(self) -> dict:
        from .record import simulation_fields

        return simulation_fields(self, self.run_context)

    @classmethod
    def from_payload(cls, obj):
        from .record import simulation_from

        return simulation_from(obj)

    def records(self) -> list[dict]:
        """One record per line and response dof: ``omega_rad_s``, ``dof``, and the response in
        :attr:`quantity` (``real``, ``imag``)."""
        H = self.responses()
        return [{"omega_rad_s": float(w), "dof": d, "real": float(np.real(H[i, k])), "imag": float(np.imag(H[i, k]))}
                for i, w in enumerate(self.omega) for k, d in enumerate(self.dofs)]


@shared_docs(FRF_ARGUMENTS=FRF_ARGUMENTS)
def simulate(model, omega, force: Mapping, response: Sequence[str] | None = None, values=None, damping=None,
             noise: float = 0.0, noise_kind: str = "relative", seed: int | None = None,
             method: str = "auto") -> SimulatedFRF:
    """Simulated FRF test data (receptances, :class:`~femupdate.FRFData`), optionally noisy.

    :func:`frf` (paper eq. 23) at the given lines, then :func:`add_noise` when ``noise`` is
    non-zero.

    Parameters
    ----------
    {{FRF_ARGUMENTS}}
    noise : float, default 0.0
        Noise standard deviation (relative for ``"relative"``/``"coherent"``, in the response's
        units for ``"absolute"``); 0: exact data.
    noise_kind : str, default ``"relative"``
        ``"relative"``, ``"absolute"`` or ``"coherent"`` (see the module notes).
    seed : int, optional
        Seed of the noise generator.
    method : str, default ``"auto"``
        ``"auto"``, ``"dense"`` or ``"sparse"``, as :func:`receptance`.

    Returns
    -------
    SimulatedFRF
        An :class:`~femupdate.FRFData`: ``omega``, ``force``, the response dofs and receptances
        ``(n_lines, n_response)``; with the damping, noise and parameter values used, and
        ``to_json()``, the JSON of ``femupdate frf`` (``with_quantity("mobility")`` for
        mobilities, as ``--kind mobility``).

    Raises
    ------
    InputError
        As :func:`frf` and :func:`add_noise`.
    """
    where = "simulate_frf"
    model_arg(model, "model", where)
    lines = np.asarray(array_arg(omega, "omega", where, finite=False))
    mapping_arg(force, "force", where, optional=False)
    strings_arg(response, "response", where, what="dof label")
    values_arg(model, values, "values", where)
    real_arg(noise, "noise", where, low=0.0)
    choice_arg(noise_kind, NOISE_KINDS, "noise_kind", where)
    count_arg(seed, "seed", where, low=0, optional=True)
    choice_arg(method, ("auto", "dense", "sparse"), "method", where)
    n_response = model.n_dofs if response is None else len(response)
    check_count("omega", lines.size, LINE_BYTES * max(n_response, 1), "the responses at the lines")
    labels, X = frf(model, omega, force, response, values, damping, method=method)
    data = FRFData(check_omega(omega), dict(force), labels, X)
    if noise:
        data = add_noise(data, noise, noise_kind, seed)
    return SimulatedFRF(data.omega, data.force, data.dofs, data.response, damping=as_damping(damping),
                        noise={"level": float(noise), "kind": noise_kind, "seed": seed},
                        parameters=dict(zip(model.parameter_names, map(float, model.resolve(values)))),
                        context=RunContext(model=model))


def add_noise(data: FRFData, level: float, kind: str = "relative", seed: int | None = None) -> FRFData:
    """Copy of ``data`` with measurement noise of standard deviation ``level`` (see module doc).

    Real data stay real (real noise); complex data get circular complex noise.

    Parameters
    ----------
    data : FRFData
        The data to perturb (not modified).
    level : float
        Standard deviation σ ≥ 0: relative for ``"relative"`` and ``"coherent"``, in the
        response's units for ``"absolute"``.
    kind : str, default ``"relative"``
        ``"relative"`` (each value times 1 + σε), ``"absolute"`` (+ σε) or ``"coherent"`` (one
        relative error per spectral line, shared by every channel).
    seed : int, optional
        Seed of :func:`numpy.random.default_rng`.

    Returns
    -------
    FRFData

    Raises
    ------
    InputError
        An unknown kind, or a negative or non-finite level.
    """
    if kind not in NOISE_KINDS:
        raise InputError(f"unknown noise kind {kind!r}: use {', '.join(NOISE_KINDS)}")
    level = nonnegative(level, "noise level")
    rng = np.random.default_rng(seed)
    X = data.response
    cplx = np.iscomplexobj(X)

    def draw(shape):
        if cplx:
            return (rng.standard_normal(shape) + 1j * rng.standard_normal(shape)) * np.sqrt(0.5)
        return rng.standard_normal(shape)

    if kind == "relative":
        Y = X * (1 + level * draw(X.shape))
    elif kind == "absolute":
        Y = X + level * draw(X.shape)
    else:
        Y = X * (1 + level * draw((X.shape[0], 1)))
    return FRFData(data.omega, dict(data.force), data.dofs, Y)


def from_channels(force: Mapping, channels: Mapping[str, tuple], rtol: float = 1e-9) -> FRFData:
    """FRF data from separately recorded channels ``{dof: (omega, values)}``.

    Every channel must share one frequency axis: a channel whose axis differs (length or
    values, beyond ``rtol``) is refused with a message naming it and the first channel.

    Parameters
    ----------
    force : mapping of str to float or complex
        Force amplitude (N) at each excited dof.
    channels : mapping of str to (array_like, array_like)
        Per response dof, its frequency axis ω (rad/s, shape ``(n_lines,)``) and its values
        (same shape).
    rtol : float, default 1e-9
        Relative tolerance of the comparison of the frequency axes.

    Returns
    -------
    FRFData
        Responses ``(n_lines, n_channels)`` in the order of ``channels`` (complex if any channel
        is).

    Raises
    ------
    InputError
        No channels; a channel that is not a pair, has bad frequencies, a length mismatch, or
        an axis different from the first channel's; and as :class:`FRFData`.
    """
    if not channels:
        raise InputError("frf channels: none given")
    first = None
    dofs, cols = [], []
    for d, item in channels.items():
        try:
            w, v = item
        except (TypeError, ValueError):
            raise InputError(f"frf channel {d}: expected a pair (omega, values)") from None
        w = check_omega(w, f"frf channel {d} omega")
        v = np.asarray(v)
        if v.shape != w.shape:
            raise InputError(f"frf channel {d}: {v.size} values for {w.size} frequencies")
        if first is None:
            first = (d, w)
        else:
            d0, w0 = first
            if w.shape != w0.shape or not np.allclose(w, w0, rtol=rtol, atol=0):
                k = int(np.argmax(~np.isclose(w, w0, rtol=rtol, atol=0))) if w.shape == w0.shape else None
                detail = (f"{w.size} lines against {w0.size}" if k is None
                          else f"line {k + 1}: {w[k]:.9g} against {w0[k]:.9g} rad/s")
                raise InputError(f"frf channel {d}: its frequency axis differs from that of channel {d0} ({detail}); "
                                 "every channel of one excitation must share one axis (resample first)")
        dofs.append(d)
        cols.append(v)
    kinds = {np.iscomplexobj(c) for c in cols}
    resp = np.column_stack([c.astype(complex) if True in kinds else c for c in cols])
    if first is None:  # set by the first of the (non-empty) channels
        raise RuntimeError("internal error: channels without a first channel")
    return FRFData(first[1], dict(force), tuple(dofs), resp)


def check_data_against_model(model, data: FRFData, damping: Damping, residual: str, imag_tol: float = 1e-6) -> None:
    """Refuse data the model cannot be compared with, naming the culprit.

    * a response or force dof the model lacks;
    * complex data with a significant imaginary part where the model's responses are real
      (undamped, real force) — unless the residual compares magnitudes (``"log"``);
    * real data where the model's responses are complex (damping, or a complex force): the
      phase is missing — unless ``"log"``.

    Parameters
    ----------
    model : Model
        The model.
    data : FRFData
        Measured FRFs.
    damping : Damping
        The model's damping.
    residual : str
        The FRF residual in use; ``"log"`` skips the real/complex checks.
    imag_tol : float, default 1e-6
        Largest |Im x| / |x| accepted as real.

    Raises
    ------
    InputError
        In the cases listed above (and a malformed force, as :func:`force_vector`).
    """
    f = force_vector(model, data.force, "frf force")
    missing = [d for d in data.dofs if d not in set(model.dofs)]
    if missing:
        raise InputError(f"frf response at dof(s) the model {model.name!r} lacks: {describe(missing)}")
    if residual == "log":
        return
    real_model = damping.undamped and not np.iscomplexobj(f)
    X = data.response
    if real_model and np.iscomplexobj(X):
        mag = np.abs(X)
        ratio = np.abs(X.imag) / np.maximum(mag, np.finfo(float).tiny)
        k = np.unravel_index(np.argmax(np.where(mag > 1e-12 * mag.max(), ratio, 0)), X.shape)
        if ratio[k] > imag_tol:
            raise InputError(
                f"frf response is complex (|Im|/|x| = {ratio[k]:.2g} at {data.dofs[k[1]]}, line {k[0] + 1}, "
                f"{data.omega[k[0]]:g} rad/s) but the model's responses are real (undamped, real force): give "
                "damping, or compare magnitudes (residual 'log')")
    if not real_model and not np.iscomplexobj(X):
        why = "damped" if not damping.undamped else "driven by a complex force"
        raise InputError(f"frf response is real but the model is {why} (complex responses): give the data as "
                         "[re, im] pairs, or compare magnitudes (residual 'log')")
