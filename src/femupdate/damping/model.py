r"""The damping part of a model: viscous :math:`C(p)`, hysteretic :math:`D(p)` (the imaginary
stiffness) and modal damping ratios.

.. math::  C(p) = C_0 + \sum_k c_k(p)\, C_k, \qquad D(p) = \sum_k d_k(p)\, D_k,
           \qquad (\lambda^2 M + \lambda C + K + i D)\,\varphi = 0

Every coefficient :math:`c_k(p)` is a constant times a product of parameters (the
:mod:`femupdate.coefficients` factors ``Power(name, 1)``), so :math:`\partial C/\partial p_j` is
exact by the product rule, whichever parameters enter it:

* **Rayleigh** :math:`C = \alpha M(p) + \beta K(p)`.  With
  :math:`K(p) = K_0 + \sum_j p_j K_j + \sum_t f_t(p) K_t`, the term :math:`\beta K(p)` expands into
  :math:`\beta K_0 + \sum_j (\beta p_j) K_j + \sum_t (\beta f_t(p)) K_t`: products of the damping
  parameter β and the stiffness parameters, each exact.  Hence :math:`\partial C/\partial p_j =
  \beta K_j` for a stiffness parameter and :math:`\partial C/\partial\beta = K(p)`.
* **Viscous dampers** between two dofs (or one dof and the ground): :math:`c\,(e_a - e_b)(e_a -
  e_b)^T`, the coefficient ``c`` (N s/m) a number or a damping parameter.
* **Loss factors** (structural, hysteretic damping): :math:`D = \eta K(p)` for the whole
  stiffness, or :math:`D = \eta\, p_j K_j` for the elements of one (affine) stiffness parameter
  :math:`p_j` — an element set or material's complex stiffness :math:`p_j K_j (1 + i\eta)`.
* **Matrices** (models exported from an FE code): a constant ``C0`` and one ``dC`` matrix per
  damping parameter, :math:`C = C_0 + \sum_q q\, C_q`.
* **Modal damping ratios** :math:`\zeta_r` of the first undamped modes act in their real modal
  coordinates (:func:`femupdate.damping.complex_modes`): they form no physical C.  Each is a
  number or a damping parameter (one parameter on several modes: a group sharing one ratio);
  :mod:`femupdate.damping.modal_ratios` differentiates the modes and receptances with respect to
  them and to every other parameter.

Damping parameters are declared beside the model's own (their names distinct), bounded below by
0: a negative damping coefficient is refused.  A :class:`DampedModel` is a frozen value object,
validated once.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace

import numpy as np
import scipy.sparse as sp

from .._errors import InputError
from ..coefficients import Power
from ..model import Model, Parameter, _as_csr


def _coefficient(v, what: str) -> float | str:
    """A coefficient: a parameter name (checked later) or a finite number >= 0."""
    if isinstance(v, str):
        return v
    if isinstance(v, (bool, np.bool_)) or not isinstance(v, (int, float, np.integer, np.floating)):
        raise InputError(f"{what} must be a number >= 0 or the name of a damping parameter, got {v!r}")
    x = float(v)
    if not math.isfinite(x):
        raise InputError(f"{what} = {v!r} is not finite")
    if x < 0:
        raise InputError(f"{what} = {v!r} is negative: a negative damping coefficient feeds energy into the "
                         "structure (damping coefficients must be >= 0)")
    return x


def check_ratio(v, what: str) -> float:
    """A modal damping ratio as a fraction of critical damping in [0, 1); a value > 1 is said to
    look like a percentage."""
    if isinstance(v, (bool, np.bool_)) or not isinstance(v, (int, float, np.integer, np.floating)):
        raise InputError(f"{what} must be a number (a fraction of critical damping), got {v!r}")
    x = float(v)
    if not math.isfinite(x) or x < 0:
        raise InputError(f"{what} = {v!r} must be a finite damping ratio >= 0")
    if x > 1:
        raise InputError(f"{what} = {v!r} is above 1: damping ratios are fractions of critical damping (2 % is "
                         f"0.02); it looks like a percentage, write {x / 100:g}")
    if x == 1:
        raise InputError(f"{what} = 1 is critical damping: the mode does not oscillate (ratios must be < 1)")
    return x


@dataclass(frozen=True)
class Damper:
    """A viscous damper between two dofs, or between one dof and the ground.

    Parameters
    ----------
    dofs : (str, str) or (str,) or str
        Labels ``"node:dir"`` of its ends; one label: grounded.
    c : float or str
        Coefficient (N s/m), >= 0, or the name of a damping parameter.
    """

    dofs: tuple
    c: float | str

    def __post_init__(self):
        d = (self.dofs,) if isinstance(self.dofs, str) else self.dofs
        if not isinstance(d, (list, tuple)) or not 1 <= len(d) <= 2 or not all(isinstance(x, str) for x in d):
            raise InputError(f"damper: dofs must be one or two dof labels such as [\"3:x\", \"5:x\"], got {self.dofs!r}")
        if len(d) == 2 and d[0] == d[1]:
            raise InputError(f"damper between {d[0]} and itself: give two different dofs (or one, for a grounded damper)")
        object.__setattr__(self, "dofs", tuple(d))
        object.__setattr__(self, "c", _coefficient(self.c, f"damper {list(d)} c"))


@dataclass(frozen=True)
class LossFactor:
    """Structural (hysteretic) damping: the imaginary stiffness ``eta * K_on``.

    Parameters
    ----------
    eta : float or str
        Loss factor (dimensionless, >= 0), or the name of a damping parameter.
    on : str, default ``"K"``
        ``"K"``: the whole stiffness K(p); else the name of an affine stiffness parameter
        :math:`p_j`, whose elements' stiffness :math:`p_j K_j` gets the loss factor (an element set
        or material).
    """

    eta: float | str
    on: str = "K"

    def __post_init__(self):
        if not isinstance(self.on, str) or not self.on:
            raise InputError(f"loss factor: on must be \"K\" or a stiffness parameter's name, got {self.on!r}")
        object.__setattr__(self, "eta", _coefficient(self.eta, f"loss factor on {self.on} eta"))


@dataclass(frozen=True, eq=False)
class Piece:
    """One term ``scale * prod(factors) * A`` of C (``kind`` "C") or D (``kind`` "D")."""

    kind: str
    scale: float
    factors: tuple
    A: sp.csr_array
    source: str

    def value(self, named: Mapping[str, float]) -> float:
        return self.scale * math.prod(f.value(named[f.parameter]) for f in self.factors)

    def derivative(self, named: Mapping[str, float], name: str) -> float:
        """∂(coefficient)/∂name by the product rule (0 when ``name`` is not a factor)."""
        vals = [f.value(named[f.parameter]) for f in self.factors]
        out = 0.0
        for i, f in enumerate(self.factors):
            if f.parameter == name:
                out += f.derivative(named[name]) * math.prod(v for k, v in enumerate(vals) if k != i)
        return self.scale * out


def _damping_parameter(p: Parameter, model: Model) -> Parameter:
    if p.name in model.parameter_names:
        raise InputError(f"damping parameter {p.name!r} has the name of a parameter of model {model.name!r}; "
                         "give it another name")
    lo, hi = p.bounds
    if p.value < 0 or lo < 0 and math.isfinite(lo):
        bad = p.value if p.value < 0 else lo
        raise InputError(f"damping parameter {p.name!r} = {bad:g} ({'value' if p.value < 0 else 'lower bound'}) "
                         "is negative: damping coefficients must be >= 0")
    return replace(p, bounds=(max(lo, 0.0), hi))


@dataclass(frozen=True, eq=False)
class DampedModel:
    r"""A :class:`~femupdate.Model` with damping: :math:`(\lambda^2 M + \lambda C + K + iD)\varphi = 0`.

    Parameters
    ----------
    model : Model
        Stiffness, mass and their parameters.
    parameters : sequence of Parameter, default ``()``
        The damping parameters (names distinct from the model's); value and lower bound >= 0
        (a lower bound of ``-inf`` becomes 0).
    alpha, beta : float or str, default 0
        Rayleigh :math:`C = \alpha M(p) + \beta K(p)` (1/s and s): numbers >= 0 or damping
        parameter names.
    dampers : sequence of Damper, default ``()``
    losses : sequence of LossFactor, default ``()``
    C0 : array_like or sparse matrix, optional
        A constant viscous damping matrix (N s/m), symmetric.
    dC : sequence of (matrix or None), optional
        One matrix per damping parameter: :math:`\partial C/\partial q` (matrix models).
    modal : sequence of (float or str), default ``()``
        Modal damping ratios of the first ``len(modal)`` undamped modes: fractions in [0, 1), or
        names of damping parameters (one name on several modes: a group sharing one ratio); a
        ratio parameter's value must be in [0, 1) and its upper bound is taken as at most 1.

    Raises
    ------
    InputError
        A negative coefficient or damping parameter; a name that is no damping parameter; a
        damper dof that is not a model dof; a loss factor on a parameter that does not enter K
        linearly; a damping ratio above 1 (a percentage); a damping parameter that enters nothing.
    """

    model: Model
    parameters: tuple = ()
    alpha: float | str = 0.0
    beta: float | str = 0.0
    dampers: tuple = ()
    losses: tuple = ()
    C0: object = None
    dC: tuple = ()
    modal: tuple = ()
    _pieces: tuple = field(default=(), init=False, repr=False)

    def __post_init__(self):
        if not isinstance(self.model, Model):
            raise InputError(f"DampedModel: model must be a femupdate Model, got {type(self.model).__name__}")
        params = tuple(self.parameters)
        bad = [p for p in params if not isinstance(p, Parameter)]
        if bad:
            raise InputError(f"damping parameters must be Parameter objects, got {bad[0]!r}")
        params = tuple(_damping_parameter(p, self.model) for p in params)
        names = [p.name for p in params]
        twice = sorted({x for x in names if names.count(x) > 1})
        if twice:
            raise InputError(f"damping parameter(s) declared twice: {', '.join(twice)}")
        object.__setattr__(self, "parameters", params)
        for key in ("alpha", "beta"):
            object.__setattr__(self, key, _coefficient(getattr(self, key), f"Rayleigh {key}"))
        for key, cls in (("dampers", Damper), ("losses", LossFactor)):
            items = tuple(getattr(self, key))
            if any(not isinstance(x, cls) for x in items):
                raise InputError(f"{key} must be {cls.__name__} objects")
            object.__setattr__(self, key, items)
        if len(self.modal) > self.model.n_dofs:
            raise InputError(f"{len(self.modal)} modal damping ratios but model {self.model.name!r} has "
                             f"{self.model.n_dofs} dofs (one ratio per mode, from mode 1)")
        modal = tuple(_modal_entry(z, r, names) for r, z in enumerate(self.modal))
        object.__setattr__(self, "modal", modal)
        object.__setattr__(self, "parameters", tuple(_ratio_parameter(p) if p.name in modal else p for p in params))
        pieces = _pieces(self)
        used = {f.parameter for pc in pieces for f in pc.factors} | {z for z in modal if isinstance(z, str)}
        unused = [n for n in names if n not in used]
        if unused:
            raise InputError(f"damping parameter(s) declared but used by no damping: {', '.join(unused)}")
        object.__setattr__(self, "_pieces", pieces)

    # ------------------------------------------------------------------ names and values
    @property
    def name(self) -> str:
        """The model's name."""
        return self.model.name

    @property
    def dofs(self) -> tuple[str, ...]:
        """The model's dof labels."""
        return self.model.dofs

    @property
    def n_dofs(self) -> int:
        """Number of dofs."""
        return self.model.n_dofs

    @property
    def all_parameters(self) -> tuple[Parameter, ...]:
        """The model's parameters, then the damping parameters."""
        return self.model.parameters + self.parameters

    @property
    def parameter_names(self) -> tuple[str, ...]:
        """Names of :attr:`all_parameters`."""
        return tuple(p.name for p in self.all_parameters)

    @property
    def hysteretic(self) -> bool:
        """Whether D (structural damping) is present: K is then complex."""
        return any(pc.kind == "D" for pc in self._pieces)

    def resolve(self, values=None) -> np.ndarray:
        """Every parameter's value (model's, then damping's) from None, a mapping or an array.

        Parameters
        ----------
        values : None, mapping of str to float, or array_like of shape ``(n_all,)``
            As :meth:`femupdate.Model.resolve`, over :attr:`parameter_names`.

        Returns
        -------
        numpy.ndarray
        """
        p = np.array([q.value for q in self.all_parameters], dtype=float)
        if values is None:
            return p
        if isinstance(values, Mapping):
            names = self.parameter_names
            for name, v in values.items():
                if name not in names:
                    raise InputError(f"parameter {name!r} is not in damped model {self.name!r} "
                                     f"(its parameters: {', '.join(names) or 'none'})")
                p[names.index(name)] = float(v)
        else:
            v = np.asarray(values, dtype=float)
            if v.shape != p.shape:
                raise InputError(f"expected {p.size} parameter values ({', '.join(self.parameter_names)}), "
                                 f"got shape {v.shape}")
            p = v.copy()
        if not np.all(np.isfinite(p)):
            raise InputError("parameter value(s) not finite")
        return p

    def _split(self, values):
        p = self.resolve(values)
        m = len(self.model.parameters)
        return p[:m], dict(zip(self.parameter_names, p.tolist()))

    # ------------------------------------------------------------------ matrices
    def K(self, values=None) -> sp.csr_array:
        """The real stiffness K(p) (N/m)."""
        return self.model.K(self._split(values)[0])

    def M(self, values=None) -> sp.csr_array:
        """The mass M(p) (kg)."""
        return self.model.M(self._split(values)[0])

    def _sum(self, kind: str, values) -> sp.csr_array:
        _, named = self._split(values)
        n = self.n_dofs
        out = sp.csr_array((n, n))
        for pc in self._pieces:
            if pc.kind == kind:
                out = out + pc.value(named) * pc.A
        return sp.csr_array(out)

    def C(self, values=None) -> sp.csr_array:
        """The viscous damping matrix C(p) (N s/m); zero without viscous damping."""
        return self._sum("C", values)

    def D(self, values=None) -> sp.csr_array:
        """The hysteretic (imaginary) stiffness D(p) (N/m): the complex stiffness is K + iD."""
        return self._sum("D", values)

    def derivatives(self, name: str, values=None) -> tuple:
        """Exact ``(dK, dM, dC, dD)`` with respect to one parameter (model or damping) at ``values``.

        Parameters
        ----------
        name : str
            A name of :attr:`parameter_names`.
        values : None, mapping or array_like, optional

        Returns
        -------
        tuple of four scipy.sparse.csr_array, shape ``(n_dofs, n_dofs)``
        """
        p_model, named = self._split(values)
        if name not in named:
            raise InputError(f"parameter {name!r} is not in damped model {self.name!r} "
                             f"(its parameters: {', '.join(self.parameter_names)})")
        n = self.n_dofs
        zero = sp.csr_array((n, n))
        if name in self.model.parameter_names:
            j = self.model.parameter_index(name)
            dK, dM = self.model.dK_dp(j, p_model), self.model.dM_dp(j, p_model)
        else:
            dK, dM = zero, zero
        out = {"C": zero, "D": zero}
        for pc in self._pieces:
            if any(f.parameter == name for f in pc.factors):
                out[pc.kind] = out[pc.kind] + pc.derivative(named, name) * pc.A
        return dK, dM, sp.csr_array(out["C"]), sp.csr_array(out["D"])

    def modal_ratios(self, values=None) -> np.ndarray:
        """The modal damping ratios ζ_r of the first ``len(modal)`` undamped modes at ``values``
        (a ratio given by a damping parameter takes its value)."""
        _, named = self._split(values)
        return np.array([named[z] if isinstance(z, str) else z for z in self.modal], dtype=float)

    def ratio_indicator(self, name: str) -> np.ndarray:
        """∂ζ_r/∂name for each modal ratio: 1 for the modes whose ratio is the parameter ``name``, else 0."""
        return np.array([1.0 if z == name else 0.0 for z in self.modal])

    def with_values(self, values) -> DampedModel:
        """Copy whose nominal values (model's and damping's) are ``values`` (mapping or array)."""
        p = self.resolve(values)
        m = len(self.model.parameters)
        params = tuple(replace(q, value=v, bounds=(min(q.bounds[0], v), max(q.bounds[1], v)))
                       for q, v in zip(self.parameters, p[m:]))
        return replace(self, model=self.model.with_values(p[:m]) if m else self.model, parameters=params)

    def __repr__(self) -> str:
        return f"DampedModel(name={self.name!r}, n_dofs={self.n_dofs}, parameters=[{', '.join(self.parameter_names)}])"


def _modal_entry(z, r: int, names: Sequence[str]) -> float | str:
    """One modal damping ratio: a fraction in [0, 1) or the name of a damping parameter."""
    if isinstance(z, str):
        if z not in names:
            raise InputError(f"modal damping ratio of mode {r + 1} = {z!r} is not a damping parameter (declared: "
                             f"{', '.join(names) or 'none'})")
        return z
    return check_ratio(z, f"modal damping ratio of mode {r + 1}")


def _ratio_parameter(p: Parameter) -> Parameter:
    """A damping parameter that is a modal damping ratio: its value a fraction in [0, 1) (a value
    above 1 said to look like a percentage), its upper bound at most 1."""
    check_ratio(p.value, f"damping parameter {p.name!r} (a modal damping ratio)")
    lo, hi = p.bounds
    return replace(p, bounds=(lo, min(hi, 1.0)))


def _factor(coef, names: Sequence[str], what: str) -> tuple[float, tuple]:
    """(scale, factors) of a coefficient: a number, or a damping parameter's name."""
    if isinstance(coef, str):
        if coef not in names:
            raise InputError(f"{what} = {coef!r} is not a damping parameter (declared: {', '.join(names) or 'none'})")
        return 1.0, (Power(coef, 1),)
    return float(coef), ()


def _expand(kind: str, scale: float, factors: tuple, model: Model, key: str, what: str) -> list[Piece]:
    """``coef * K(p)`` (``key`` "K") or ``coef * M(p)`` as pieces, one per matrix of the model."""
    base = model.K0 if key == "K" else model.M0
    derivs = model.dK if key == "K" else model.dM
    out = [Piece(kind, scale, factors, base, what)] if base.nnz else []
    for p, A in zip(model.parameters, derivs):
        if A is not None and A.nnz:
            out.append(Piece(kind, scale, factors + (Power(p.name, 1),), A, what))
    for t in model.terms:
        A = getattr(t, key)
        if A is not None:
            out.append(Piece(kind, scale, factors + tuple(t.factors), A, what))
    return out


def _pieces(dm: DampedModel) -> tuple[Piece, ...]:
    model, n = dm.model, dm.n_dofs
    names = [p.name for p in dm.parameters]
    out: list[Piece] = []
    for key, mat in (("alpha", "M"), ("beta", "K")):
        coef = getattr(dm, key)
        if coef != 0.0:
            s, f = _factor(coef, names, f"Rayleigh {key}")
            out += _expand("C", s, f, model, mat, f"Rayleigh {key}")
    for d in dm.dampers:
        idx = model.dof_index(list(d.dofs), f"damper {list(d.dofs)}")
        e = np.zeros(n)
        e[idx[0]] = 1.0
        if len(idx) == 2:
            e[idx[1]] = -1.0
        s, f = _factor(d.c, names, f"damper {list(d.dofs)} c")
        if s != 0.0:
            out.append(Piece("C", s, f, _outer(e), f"damper {list(d.dofs)}"))
    for lf in dm.losses:
        s, f = _factor(lf.eta, names, f"loss factor on {lf.on} eta")
        if s == 0.0:
            continue
        if lf.on == "K":
            out += _expand("D", s, f, model, "K", "loss factor")
            continue
        j = model.parameter_index(lf.on)
        if model.dK[j] is None or any(lf.on in t.parameters for t in model.terms):
            raise InputError(f"loss factor on {lf.on!r}: the parameter must enter K linearly (p K_j); it "
                             f"{'does not enter K' if model.dK[j] is None else 'enters through a non-linear term'}")
        out.append(Piece("D", s, f + (Power(lf.on, 1),), model.dK[j], f"loss factor on {lf.on}"))
    if dm.C0 is not None:
        out.append(Piece("C", 1.0, (), _semi_definite(_as_csr(dm.C0, "C0", n), "C0", model.dofs), "C0"))
    dC = tuple(dm.dC)
    if dC and len(dC) != len(names):
        raise InputError(f"{len(names)} damping parameters but {len(dC)} dC matrices")
    for q, A in zip(names, dC):
        if A is not None:
            out.append(Piece("C", 1.0, (Power(q, 1),), _semi_definite(_as_csr(A, f"dC/d{q}", n), f"dC/d{q}", model.dofs),
                             f"dC/d{q}"))
    return tuple(pc for pc in out if pc.A.nnz)


def _semi_definite(A: sp.csr_array, what: str, dofs: Sequence[str]) -> sp.csr_array:
    """``A`` if it is positive semi-definite (to round-off), else an :class:`InputError`: a damping
    matrix with a negative direction feeds energy into the structure, as a negative damper does.
    A negative diagonal entry is caught at any size; the smallest eigenvalue up to 3000 dofs."""
    scale = float(np.max(np.abs(A.data))) if A.nnz else 0.0
    tol = 1e-10 * scale * max(A.shape[0], 1)
    d = A.diagonal()
    low, where = (float(d.min()), f"diagonal entry, at {dofs[int(np.argmin(d))]},") if d.size else (0.0, "")
    if low >= -tol and A.shape[0] <= 3000:
        low, where = float(np.linalg.eigvalsh(A.toarray())[0]), "eigenvalue"
    if low < -tol:
        raise InputError(f"{what} is not positive semi-definite (smallest {where} {low:.6g} against entries of size "
                         f"{scale:.3g}): a damping matrix with a negative direction feeds energy into the structure "
                         "(damping matrices must be positive semi-definite)")
    return A


def _outer(e: np.ndarray) -> sp.csr_array:
    i = np.flatnonzero(e)
    rows, cols = np.meshgrid(i, i, indexing="ij")
    return sp.csr_array((np.outer(e[i], e[i]).ravel(), (rows.ravel(), cols.ravel())), shape=(e.size, e.size))


__all__ = ["DampedModel", "Damper", "LossFactor", "check_ratio"]
