r"""The parametrised model: a pencil of sparse matrices with dof labels.

.. math::  K(p) = K_0 + \sum_j p_j K_j + \sum_k f_k(p) K_k, \qquad M(p) \text{ likewise}

so that :math:`\partial K / \partial p_j = K_j + \sum_k (\partial f_k / \partial p_j) K_k` exactly;
the terms :math:`f_k(p) K_k` (products of single-parameter functions,
:mod:`femupdate.coefficients`) are absent from an affine model.  A :class:`Model` is a frozen value
object, validated once; transforms (:meth:`Model.with_values`, :meth:`Model.with_fixed`) return
copies.
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from functools import cached_property

import numpy as np
import scipy.sparse as sp

from ._checks import flag_arg, input_errors, largest, shown, str_arg, strings_arg, symmetric_pattern_close
from ._errors import InputError
from ._limits import MAX_MAGNITUDE
from .dofs import canonical_all, describe, index_of
from .coefficients import check_terms, linearise, term_derivative
from .constraints import DependentDofs, check_dependent
from .priors import Prior, parse_prior

_NAME = re.compile(r"^[A-Za-z_][A-Za-z0-9_.\-]*$")


def _shown(v) -> str:
    """A value as the user wrote it in a file: true/false, quoted strings, lists of them."""
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_shown(x) for x in v) + "]"
    if isinstance(v, (bool, np.bool_)):
        return "true" if v else "false"
    return repr(v)


@dataclass(frozen=True)
class Parameter:
    """A physical parameter: nominal (or starting) value, bounds, and whether it is known.

    Parameters
    ----------
    name : str
        Identifier used by elements and in results.
    value : float
        Nominal / starting value.
    bounds : (float, float)
        Lower and upper bound (``-inf``/``inf`` for none); ``value`` must lie within them.
    fixed : bool
        A known parameter, never updated.
    unit : str, default ""
        Unit of the value, for tables and figure axes (e.g. ``"N/m"``); ``""`` when unknown.
        :meth:`Structure.build <femupdate.Structure.build>` sets it from the element properties
        the parameter stands for (SI: :mod:`femupdate.structure.units`); femupdate converts no
        units.
    prior : Prior, str or mapping, optional
        Its prior distribution for Bayesian updating (:mod:`femupdate.priors`: ``"uniform"``,
        ``"normal(MEAN, STD)"``, ``"lognormal(MEDIAN, STD_LOG)"``, or the model file's inline
        table), truncated to ``bounds``; None (default): uniform within finite bounds.
    """

    name: str
    value: float
    bounds: tuple[float, float] = (-math.inf, math.inf)
    fixed: bool = False
    unit: str = ""
    prior: Prior | None = None

    def __post_init__(self):
        if not isinstance(self.name, str) or not _NAME.match(self.name):
            raise InputError(f"parameter name {self.name!r} is not a valid identifier")
        if isinstance(self.value, (str, bytes)):
            raise InputError(f"parameter {self.name!r}: value must be a number, got {shown(self.value)}")
        if not isinstance(self.bounds, (list, tuple, np.ndarray)) or len(self.bounds) != 2:
            raise InputError(f"parameter {self.name!r}: bounds must be a pair (lower, upper), got {shown(self.bounds)}")
        with input_errors():
            flag_arg(self.fixed, "fixed", f"parameter {self.name!r}")
        if isinstance(self.value, (bool, np.bool_)):  # float() would read true as 1
            raise InputError(f"parameter {self.name!r}: value must be a number, got {_shown(self.value)}")
        if isinstance(self.bounds, (list, tuple)) and any(isinstance(b, (bool, np.bool_)) for b in self.bounds):
            raise InputError(f"parameter {self.name!r}: bounds must be numbers, got {_shown(list(self.bounds))}")
        try:
            value = float(self.value)
            lo, hi = (float(b) for b in self.bounds)
        except (TypeError, ValueError):
            raise InputError(f"parameter {self.name!r}: value and bounds must be numbers") from None
        if not math.isfinite(value):
            raise InputError(f"parameter {self.name!r}: value {value!r} is not finite")
        if math.isnan(lo) or math.isnan(hi) or not lo < hi:
            raise InputError(f"parameter {self.name!r}: bounds {list(self.bounds)} must satisfy lower < upper")
        if not lo <= value <= hi:
            raise InputError(f"parameter {self.name!r}: value {value:g} lies outside its bounds [{lo:g}, {hi:g}]")
        object.__setattr__(self, "value", value)
        object.__setattr__(self, "bounds", (lo, hi))
        object.__setattr__(self, "fixed", bool(self.fixed))
        if not isinstance(self.unit, str):
            raise InputError(f"parameter {self.name!r}: unit must be a string, got {self.unit!r}")
        if self.prior is not None:
            prior = parse_prior(self.prior, f"parameter {self.name!r}: prior")
            prior.check(self.name, (lo, hi))
            object.__setattr__(self, "prior", prior)


def _as_csr(A, what: str, n: int | None = None) -> sp.csr_array:
    if A is None:
        return None
    if not sp.issparse(A):
        try:
            A = np.asarray(A, dtype=float)
        except (TypeError, ValueError):
            raise InputError(f"{what} is not a numeric matrix") from None
        if A.ndim != 2:
            raise InputError(f"{what} must be a square matrix, got an array of shape {A.shape}")
    A = sp.csr_array(A, dtype=float)
    if A.ndim != 2 or A.shape[0] != A.shape[1]:
        raise InputError(f"{what} must be square, got shape {A.shape}")
    if n is not None and A.shape[0] != n:
        raise InputError(f"{what} has shape {A.shape}, but the model has {n} dofs")
    if not np.all(np.isfinite(A.data)):
        raise InputError(f"{what} contains NaN or infinite entries")
    scale = largest(A.data)
    if scale > MAX_MAGNITUDE:
        raise InputError(f"{what} has entries above {MAX_MAGNITUDE:g} in magnitude (largest {scale:.3g})")
    A.sum_duplicates()
    A.eliminate_zeros()
    if symmetric_pattern_close(A, 1e-10 * max(scale, 1e-300)):
        return A
    asym = A - A.T
    if asym.nnz and np.max(np.abs(asym.data)) > 1e-10 * max(scale, 1e-300):
        rows, cols = asym.nonzero()
        k = int(np.argmax(np.abs(asym.data)))
        raise InputError(
            f"{what} is not symmetric (largest mismatch {np.max(np.abs(asym.data)):.3g} at "
            f"row {rows[k]}, column {cols[k]}, against entries of size {scale:.3g})"
        )
    return A


def _fields(model: Model) -> None:
    """The types of :class:`Model`'s fields (a :class:`TypeError` naming the first wrong one)."""
    str_arg(model.name, "name", "Model")
    where = f"Model {model.name!r}"
    strings_arg(model.dofs, "dofs", where, optional=False, what="dof label")
    for what, A in (("K0", model.K0), ("M0", model.M0)):
        if A is None or isinstance(A, (str, bytes, Mapping)):
            raise TypeError(f"{where}: {what} must be a matrix (an array or a SciPy sparse matrix), got {shown(A)}")
    for what, seq in (("parameters", model.parameters), ("dK", model.dK), ("dM", model.dM)):
        if isinstance(seq, (str, bytes, Mapping)) or not isinstance(seq, (Sequence, np.ndarray)) or (
                isinstance(seq, np.ndarray) and seq.dtype.kind != "O"):
            raise TypeError(f"{where}: {what} must be a list, got {shown(seq)}")
    bad = [p for p in model.parameters if not isinstance(p, Parameter)]
    if bad:
        raise TypeError(f"{where}: parameters must be Parameter objects, got {shown(bad[0])} (make one with "
                        "Parameter(name, value, bounds))")
    if not isinstance(model.nodes, Mapping):
        raise TypeError(f"{where}: nodes must be a mapping {{node: (x, y, z)}}, got {shown(model.nodes)}")
    if isinstance(model.positive, (str, bytes)):
        raise TypeError(f"{where}: positive must be a collection of parameter names, got {shown(model.positive)}")


@dataclass(frozen=True, eq=False)
class Model:
    """Affine parametrised model with labelled dofs: K(p) = K0 + Σ_j p_j dK[j], M(p) = M0 + Σ_j p_j dM[j].

    Every argument is validated once, on construction; the stored matrices are CSR arrays with
    duplicates summed and explicit zeros removed.

    Parameters
    ----------
    dofs : sequence of str
        Labels ``"node:dir"`` of the model's (free) dofs, in matrix order (stored canonical, as a
        tuple).
    K0, M0 : array_like or scipy sparse matrix, shape ``(n_dofs, n_dofs)``
        Parameter-independent parts of the stiffness (N/m) and mass (kg) matrices; symmetric,
        finite.
    parameters : sequence of Parameter, default ``()``
        The model parameters p, in declaration order.
    dK, dM : sequence of (array_like, sparse matrix or None), default ``()``
        ``dK[j] = ∂K/∂p_j`` (``None`` where parameter j does not enter K), likewise ``dM``; each
        ``(n_dofs, n_dofs)`` and symmetric.  Empty: no parameter enters that matrix.
    name : str, default ``"model"``
        Name used in messages and results.
    nodes : mapping of int to (float, float, float), optional
        Node id -> coordinates (x, y, z), for geometry-aware output such as UFF.
    positive : collection of str, optional
        Parameters that must stay > 0 (a structure's element properties: a stiffness, mass or
        section value); checked where values come from the user (``--set``) and flagged in
        results.
    terms : sequence of femupdate.coefficients.Term, optional
        Non-linear terms f_k(p) K_k, f_k(p) M_k (a shell's E t³, a product E·I); each factor names a
        declared parameter.  Empty (default): the model is affine.
    constraints : femupdate.constraints.DependentDofs, optional
        The dofs that exact multipoint constraints (rigid links, ties) eliminated, and how they
        follow the model's dofs (:func:`femupdate.constraints.expand_shapes`); None: there are none.

    Attributes
    ----------
    dofs : tuple of str
        Labels of the model's (free) dofs, in matrix order.
    K0, M0 : scipy.sparse.csr_array
        Parameter-independent parts, shape ``(n_dofs, n_dofs)``.
    parameters : tuple of Parameter
    dK, dM : tuple of csr_array or None
        ``dK[j] = dK/dp_j`` (``None`` where parameter j does not enter K); likewise ``dM``.
    name : str
    nodes : dict of int to (x, y, z)
    positive : frozenset of str

    Raises
    ------
    InputError
        No dofs; invalid or duplicate dof labels; a matrix not square, of the wrong size, not
        finite or not symmetric; a parameter declared twice; ``dK``/``dM`` not one entry per
        parameter; a parameter that enters neither K nor M.
    """

    dofs: tuple[str, ...]
    K0: sp.csr_array
    M0: sp.csr_array
    parameters: tuple[Parameter, ...] = ()
    dK: tuple = ()
    dM: tuple = ()
    name: str = "model"
    nodes: Mapping[int, tuple[float, float, float]] = field(default_factory=dict)
    positive: frozenset[str] = frozenset()
    terms: tuple = ()
    constraints: DependentDofs | None = None

    def __post_init__(self):
        with input_errors():
            _fields(self)
        dofs = canonical_all(self.dofs, "model dofs")
        n = len(dofs)
        if n == 0:
            raise InputError(f"model {self.name!r} has no free dofs")
        object.__setattr__(self, "dofs", dofs)
        object.__setattr__(self, "K0", _as_csr(self.K0, "K0", n))
        object.__setattr__(self, "M0", _as_csr(self.M0, "M0", n))
        params = tuple(self.parameters)
        names = [p.name for p in params]
        dup = sorted({x for x in names if names.count(x) > 1})
        if dup:
            raise InputError(f"parameter(s) declared twice: {', '.join(dup)}")
        dK = tuple(self.dK) if self.dK else (None,) * len(params)
        dM = tuple(self.dM) if self.dM else (None,) * len(params)
        if len(dK) != len(params) or len(dM) != len(params):
            raise InputError(f"{len(params)} parameters but {len(dK)} dK and {len(dM)} dM matrices")
        dK = tuple(_as_csr(A, f"dK/d{p.name}", n) for A, p in zip(dK, params))
        dM = tuple(_as_csr(A, f"dM/d{p.name}", n) for A, p in zip(dM, params))
        terms = check_terms(self.terms, names, n)
        in_terms = {x for t in terms for x in t.parameters}
        unused = [p.name for p, a, b in zip(params, dK, dM)
                  if (a is None or a.nnz == 0) and (b is None or b.nnz == 0) and p.name not in in_terms]
        if unused:
            raise InputError(f"parameter(s) declared but used by no element or matrix: {', '.join(unused)}")
        object.__setattr__(self, "parameters", params)
        object.__setattr__(self, "dK", dK)
        object.__setattr__(self, "dM", dM)
        object.__setattr__(self, "terms", terms)
        object.__setattr__(self, "constraints", check_dependent(self.constraints, n, dofs))
        object.__setattr__(self, "nodes", dict(self.nodes))
        object.__setattr__(self, "positive", frozenset(self.positive) & frozenset(names))

    # ------------------------------------------------------------------ basic properties
    @property
    def n_dofs(self) -> int:
        """Number of (free) dofs, the size of every matrix."""
        return len(self.dofs)

    @property
    def parameter_names(self) -> tuple[str, ...]:
        """Parameter names, in declaration order."""
        return tuple(p.name for p in self.parameters)

    @property
    def values(self) -> np.ndarray:
        """Nominal parameter values, in declaration order."""
        return np.array([p.value for p in self.parameters], dtype=float)

    @property
    def free(self) -> np.ndarray:
        """Indices of the parameters that are to be updated (not ``fixed``)."""
        return np.array([j for j, p in enumerate(self.parameters) if not p.fixed], dtype=np.intp)

    @property
    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """Lower and upper bounds of every parameter, two arrays of shape ``(n_parameters,)``."""
        lo = np.array([p.bounds[0] for p in self.parameters])
        hi = np.array([p.bounds[1] for p in self.parameters])
        return lo, hi

    def parameter_indices(self, names: Sequence[str], what: str = "parameters") -> list[int]:
        """Positions of the parameters ``names``, each named once.

        Parameters
        ----------
        names : sequence of str
        what : str
            How the caller names the list (an option such as ``--params``), for messages.

        Returns
        -------
        list of int

        Raises
        ------
        InputError
            A name that is not a parameter, or one listed twice (a duplicate would make two
            unknowns of one parameter: a singular problem reported as something else).
        """
        from collections import Counter

        twice = sorted(n for n, c in Counter(names).items() if c > 1)
        if twice:
            raise InputError(f"{what}: parameter(s) listed twice: {', '.join(twice)}")
        return [self.parameter_index(n) for n in names]

    def parameter_index(self, name: str) -> int:
        """Position of a parameter in declaration order.

        Parameters
        ----------
        name : str
            Parameter name.

        Returns
        -------
        int
            Its index j in :attr:`parameters` (and in ``dK``, ``dM``, :attr:`values`).

        Raises
        ------
        InputError
            ``name`` is not a parameter of the model.
        """
        try:
            return self.parameter_names.index(name)
        except ValueError:
            raise InputError(
                f"parameter {name!r} is not in model {self.name!r} "
                f"(its parameters: {', '.join(self.parameter_names) or 'none'})"
            ) from None

    def dof_index(self, labels: Sequence[str], what: str = "data") -> np.ndarray:
        """Matrix positions of dof labels; one error naming every unknown label.

        Parameters
        ----------
        labels : sequence of str
            Dof labels ``"node:dir"``.
        what : str, default ``"data"``
            What the labels belong to, for the error message.

        Returns
        -------
        numpy.ndarray of int, shape ``(len(labels),)``
            Row/column index of each label in the model matrices.

        Raises
        ------
        InputError
            A label is not a model dof (every unknown label is named).
        """
        dep = self.constraints
        if dep is not None:
            hit = [lab for lab in labels if isinstance(lab, str) and lab in dep.labels]
            if hit:
                k = dep.labels.index(hit[0])
                raise InputError(f"{what}: dof {hit[0]!r} is a dependent dof of {dep.sources[k]}, eliminated from the "
                                 "model (its motion follows the independent node's); pair the test at that node's dofs")
        return index_of(self.dofs, labels, what)

    # ------------------------------------------------------------------ evaluation
    def resolve(self, values=None) -> np.ndarray:
        """Full parameter vector from ``None`` (nominal), a mapping {name: value} or an array.

        Parameters
        ----------
        values : None, mapping of str to float, or array_like of shape ``(n_parameters,)``
            ``None``: the nominal values; a mapping: the nominal values with the named ones
            replaced; an array: every value, in declaration order.

        Returns
        -------
        numpy.ndarray, shape ``(n_parameters,)``
            The parameter values p (a new array).

        Raises
        ------
        InputError
            An unknown parameter name, an array of the wrong shape, or a non-finite value.
        """
        p = self.values
        if values is None:
            return p
        if isinstance(values, Mapping):
            for name, v in values.items():
                p[self.parameter_index(name)] = float(v)
        else:
            v = np.asarray(values, dtype=float)
            if v.shape != p.shape:
                raise InputError(f"expected {p.size} parameter values ({', '.join(self.parameter_names)}), got shape {v.shape}")
            p = v.copy()
        bad = [self.parameter_names[j] for j in np.flatnonzero(~np.isfinite(p))]
        if bad:
            raise InputError(f"parameter value(s) not finite: {', '.join(bad)}")
        return p

    @cached_property
    def _pattern(self):
        """Union sparsity pattern and the map from [1, p] to the matrix data (for fast K(p))."""
        out = {}
        for key, base, derivs in (("K", self.K0, self.dK), ("M", self.M0, self.dM)):
            L = len(derivs)
            tmats = [getattr(t, key) for t in self.terms]
            mats = [base] + [d for d in derivs if d is not None] + [d for d in tmats if d is not None]
            cols = ([0] + [j + 1 for j, d in enumerate(derivs) if d is not None]
                    + [L + 1 + k for k, d in enumerate(tmats) if d is not None])
            n = base.shape[0]
            keys = np.unique(np.concatenate([m.tocoo().row.astype(np.int64) * n + m.tocoo().col for m in mats]))
            union_rows, union_cols = np.divmod(keys, n)
            indptr = np.searchsorted(union_rows, np.arange(n + 1)).astype(np.int64)
            union = sp.csr_array((np.ones(keys.size), union_cols, indptr), shape=(n, n))
            rows, cols_, vals = [], [], []
            for m, c in zip(mats, cols):
                mc = m.tocoo()
                rows.append(np.searchsorted(keys, mc.row.astype(np.int64) * n + mc.col))
                cols_.append(np.full(mc.nnz, c))
                vals.append(mc.data)
            B = sp.csr_array(
                (np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols_))),
                shape=(keys.size, len(derivs) + 1 + len(tmats)),
            )
            out[key] = (union, B)
        return out

    def _assemble(self, key: str, p: np.ndarray) -> sp.csr_array:
        union, B = self._pattern[key]
        coef = np.concatenate(([1.0], p, self._coefficients(p))) if self.terms else np.concatenate(([1.0], p))
        data = B @ coef
        return sp.csr_array((data, union.indices.copy(), union.indptr.copy()), shape=union.shape)

    def K(self, values=None) -> sp.csr_array:
        """Stiffness matrix K(p) = K0 + Σ_j p_j dK[j] (N/m).

        Parameters
        ----------
        values : None, mapping of str to float, or array_like, optional
            Parameter values as :meth:`resolve` reads them (default: nominal).

        Returns
        -------
        scipy.sparse.csr_array, shape ``(n_dofs, n_dofs)``
        """
        return self._assemble("K", self.resolve(values))

    def M(self, values=None) -> sp.csr_array:
        """Mass matrix M(p) = M0 + Σ_j p_j dM[j] (kg), at ``values`` as :meth:`K` takes them."""
        return self._assemble("M", self.resolve(values))

    def dK_dp(self, j: int, values=None) -> sp.csr_array:
        """Exact dK/dp_j at ``values`` (a zero matrix if parameter j does not enter K).

        dK[j] plus, for a non-linear model, the chain rule over its :attr:`terms`:
        Σ_k (∂f_k/∂p_j) K_k.

        Parameters
        ----------
        j : int
            Parameter index (declaration order).
        values : None, mapping or array_like, optional
            Where to differentiate, as :meth:`resolve` reads them (default nominal; an affine
            model's derivative does not depend on it).

        Returns
        -------
        scipy.sparse.csr_array, shape ``(n_dofs, n_dofs)``
        """
        return self._derivative("K", j, values)

    def dM_dp(self, j: int, values=None) -> sp.csr_array:
        """Exact dM/dp_j at ``values`` (a zero matrix if parameter j does not enter M), as :meth:`dK_dp` for K."""
        return self._derivative("M", j, values)

    def _derivative(self, key: str, j: int, values) -> sp.csr_array:
        d = (self.dK if key == "K" else self.dM)[j]
        out = d if d is not None else sp.csr_array((self.n_dofs, self.n_dofs))
        return term_derivative(self, key, j, values, out) if self.terms else out

    # ------------------------------------------------------------------ non-linear parameters
    @property
    def is_affine(self) -> bool:
        """Whether every parameter enters linearly (no :attr:`terms`)."""
        return not self.terms

    def _coefficients(self, p: np.ndarray) -> np.ndarray:
        """f_k(p) of every term."""
        named = dict(zip(self.parameter_names, p.tolist()))
        return np.array([t.value(named) for t in self.terms], dtype=float)

    def linearised(self, values=None) -> Model:
        """The affine model tangent to this one at ``values``: same K(p), M(p) and exact first
        derivatives there (K0 ← K(p) − Σ p_j ∂K/∂p_j, dK[j] ← ∂K/∂p_j(p)).  ``self`` when affine.

        The sensitivity routes differentiate a non-linear model through it; it is exact at
        ``values`` only (never evaluate it elsewhere).
        """
        return linearise(self, values) if self.terms else self

    @cached_property
    def _linearised(self) -> dict:
        return {}

    # ------------------------------------------------------------------ transforms
    def with_values(self, values) -> Model:
        """Copy whose nominal parameter values are ``values`` (mapping or array).

        A parameter's bounds are widened, where needed, to contain its new value.

        Parameters
        ----------
        values : mapping of str to float, or array_like of shape ``(n_parameters,)``
            As :meth:`resolve` reads them (a mapping changes only the named parameters).

        Returns
        -------
        Model

        Raises
        ------
        InputError
            As :meth:`resolve`.
        """
        p = self.resolve(values)
        params = tuple(
            replace(par, value=v, bounds=(min(par.bounds[0], v), max(par.bounds[1], v)))
            for par, v in zip(self.parameters, p)
        )
        return replace(self, parameters=params)

    def with_fixed(self, names: Sequence[str], fixed: bool = True) -> Model:
        """Copy with the named parameters marked known (or unknown with ``fixed=False``).

        Parameters
        ----------
        names : sequence of str
            Parameter names.
        fixed : bool, default True
            The new ``fixed`` flag of those parameters.

        Returns
        -------
        Model

        Raises
        ------
        InputError
            An unknown parameter name.
        """
        idx = {self.parameter_index(n) for n in names}
        params = tuple(replace(p, fixed=fixed) if j in idx else p for j, p in enumerate(self.parameters))
        return replace(self, parameters=params)

    def __repr__(self) -> str:
        return (
            f"Model(name={self.name!r}, n_dofs={self.n_dofs}, "
            f"parameters=[{', '.join(self.parameter_names)}])"
        )

    def describe_dofs(self, limit: int = 8) -> str:
        """Short text listing the model dofs, at most ``limit`` labels (for messages).

        Parameters
        ----------
        limit : int, default 8
            Most labels shown; more are summarised as `` … (<n> in all)``.

        Returns
        -------
        str
        """
        return describe(self.dofs, limit)


from ._from_matrices import from_matrices  # noqa: E402  (public here: femupdate.model.from_matrices)
