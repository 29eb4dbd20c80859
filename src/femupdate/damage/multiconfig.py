r"""Perturbed-boundary (multi-configuration) updating and pre-test ranking of modifications.

The structure is tested in several configurations (Barney et al. 1992, Li & Brown 1992,
Lammens et al. 1993; the reference paper's "Improving experimental data"): each differs from the
others by *known* changes — added lumped masses, added springs, changed supports, known
parameters set to other values — while the unknown parameters stay the same.  Configuration c's
model is

.. math:: K_c(p) = K(p) + \Delta K_c, \qquad M_c(p) = M(p) + \Delta M_c

restricted to the dofs left free by its supports.  All configurations are updated jointly:

* **directly** when every configuration's data are complete (eqs. 4-10 of the paper stacked over
  the configurations: each configuration contributes its own rows
  :math:`\sum_j p_j (K_j - \lambda M_j)\phi = (\lambda M_{f,c} - K_{f,c})\phi` to one system
  :math:`A p = b`, solved by the pseudo-inverse, eq. 10);
* **iteratively** otherwise: the residuals and Jacobians of the configurations
  (:class:`femupdate.updating.Problem`, relative eigenvalues and scaled shapes, eq. 19) are
  stacked and minimised by SciPy's least squares (eq. 20).

The conditioning the added configurations buy is reported (each configuration alone, and the
configurations added one by one).  Before testing, :func:`rank_modifications` ranks candidate
modifications by the new, independent information they would bring, from simulated data at the
nominal parameters — "pre-test finite-element analysis would be of the utmost value when
determining optimum structural changes" (the paper).  Its criteria, for the normalised
sensitivity matrices :math:`S_0` (the baseline configuration) and :math:`S_c` (a candidate):

* ``"condition"`` (default): the condition number of :math:`[S_0; S_c]`, the paper's own measure
  of linear independence (its Figure 4 for FRF lines).  It is blind to the size of the rows: a
  candidate whose rows are parallel to the baseline's (a repeat of the baseline test, or a
  modification too small to change the modes) gains nothing — the paper's warning that such
  data "will not give very independent data";
* ``"logdet"`` (D-optimal): :math:`\ln\det(F_0 + F_c) - \ln\det F_0` with the Fisher information
  :math:`F = S^T S` (unit measurement noise): the log-ratio of the volumes of the parameters'
  confidence ellipsoids before and after (a repeat of the test already gains L ln 2);
* ``"min_singular"`` (E-optimal): the smallest singular value of :math:`[S_0; S_c]`, i.e. how
  well the least-determined parameter combination is seen.

A candidate that makes a rank-deficient baseline full-rank ranks first whatever the criterion.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace

import numpy as np
import scipy.sparse as sp

from .._errors import InputError
from ..direct import DirectResult, LinearSystem, EquationBuilder, frf_equations, modal_equations, solve_system, static_equations
from ..correlation import mac
from ..dofs import canonical_all, describe, parse_dof
from ..modal import model_modes
from ..model import Model
from ..testdata import MeasuredMode, TestData
from ..updating import PARAMETRISATIONS, Diagnostics, Parametrisation, Problem, diagnostics, modal_weights, solve

log = logging.getLogger(__name__)

CRITERIA = ("condition", "logdet", "min_singular")


# ------------------------------------------------------------------------------ modifications
@dataclass(frozen=True)
class Modification:
    """Known changes that turn the baseline structure into one test configuration.

    Attributes
    ----------
    name : str
    masses : tuple of (dof, mass)
        Lumped masses added at dofs (kg, or kg m^2 on rotations); negative removes known mass.
    springs : tuple of ((dof,) or (dof_a, dof_b), k)
        Springs added to ground (one dof) or between two dofs (N/m, N m/rad).
    supports : tuple of str
        Dofs fixed in this configuration (removed from its model).
    support_nodes : tuple of int
        Nodes all of whose dofs are fixed.
    values : mapping {parameter: value}
        Known (fixed) parameters that take other values in this configuration.
    """

    name: str = "baseline"
    masses: tuple = ()
    springs: tuple = ()
    supports: tuple = ()
    support_nodes: tuple = ()
    values: Mapping[str, float] = field(default_factory=dict)

    def __post_init__(self):
        where = f"modification {self.name!r}"
        masses = []
        for d, m in self.masses:
            (lab,) = canonical_all([d], f"{where} mass")
            masses.append((lab, _finite_nonzero(m, f"{where}: mass at {lab}")))
        springs = []
        for dofs, k in self.springs:
            dofs = canonical_all([dofs] if isinstance(dofs, str) else dofs, f"{where} spring")
            if len(dofs) not in (1, 2):
                raise InputError(f"{where}: a spring takes one dof (to ground) or two, got {len(dofs)}")
            springs.append((dofs, _finite_nonzero(k, f"{where}: spring at {', '.join(dofs)}")))
        vals = {}
        for name, v in dict(self.values).items():
            vals[str(name)] = _finite(v, f"{where}: value of parameter {name!r}")
        object.__setattr__(self, "masses", tuple(masses))
        object.__setattr__(self, "springs", tuple(springs))
        object.__setattr__(self, "supports", canonical_all(self.supports, f"{where} supports"))
        object.__setattr__(self, "support_nodes", tuple(int(n) for n in self.support_nodes))
        object.__setattr__(self, "values", vals)

    @property
    def is_baseline(self) -> bool:
        return not (self.masses or self.springs or self.supports or self.support_nodes or self.values)

    def describe(self) -> str:
        parts = [f"+{m:g} mass at {d}" for d, m in self.masses]
        parts += [f"+{k:g} spring {'-'.join(d)}" for d, k in self.springs]
        if self.supports or self.support_nodes:
            parts.append("supports " + ", ".join(list(self.supports) + [f"node {n}" for n in self.support_nodes]))
        parts += [f"{n} = {v:g}" for n, v in self.values.items()]
        return "; ".join(parts) or "unmodified"


def _finite(v, what) -> float:
    if isinstance(v, bool):
        raise InputError(f"{what}: expected a number, got {v!r}")
    try:
        x = float(v)
    except (TypeError, ValueError):
        raise InputError(f"{what}: expected a number, got {v!r}") from None
    if not math.isfinite(x):
        raise InputError(f"{what}: not finite ({v!r})")
    return x


def _finite_nonzero(v, what) -> float:
    x = _finite(v, what)
    if x == 0:
        raise InputError(f"{what} is zero")
    return x


@dataclass(frozen=True)
class Configuration:
    """One tested configuration: its test data and the known modification that defines it."""

    data: TestData
    modification: Modification = field(default_factory=Modification)
    name: str = ""

    @property
    def label(self) -> str:
        return self.name or self.modification.name


@dataclass(frozen=True, eq=False)
class ConfiguredModel:
    """The model of one configuration and the baseline parameters it does not depend on."""

    model: Model
    dropped: tuple[str, ...]
    removed_dofs: tuple[str, ...]


def configure(model: Model, modification: Modification) -> ConfiguredModel:
    """The model of the configuration ``modification`` defines (a new :class:`Model`).

    Added masses and springs go into the known parts ``K0``, ``M0``; supported dofs are removed;
    ``values`` become the nominal values of those parameters.  A parameter that no longer enters
    the model (every dof of its elements supported) is dropped from it and listed in ``dropped``.

    Raises
    ------
    InputError
        A dof, node or parameter that the model lacks (the message names the modification and the
        culprit), a mass or spring on a dof the same modification supports.
    """
    mod = modification
    where = f"modification {mod.name!r}"
    index = {d: i for i, d in enumerate(model.dofs)}
    n = model.n_dofs
    used = [d for d, _ in mod.masses] + [d for dofs, _ in mod.springs for d in dofs] + list(mod.supports)
    unknown = [d for d in dict.fromkeys(used) if d not in index]
    if unknown:
        raise InputError(f"{where}: dof(s) not in the model {model.name!r}: {describe(unknown)}")
    nodes_present = {parse_dof(d)[0] for d in model.dofs}
    missing_nodes = [nd for nd in mod.support_nodes if nd not in nodes_present]
    if missing_nodes:
        raise InputError(f"{where}: support node(s) {missing_nodes[:8]} have no dof in the model {model.name!r}")
    for name in mod.values:
        model.parameter_index(name)  # names an unknown parameter
    support_nodes = set(mod.support_nodes)
    fixed = set(mod.supports) | {d for d in model.dofs if parse_dof(d)[0] in support_nodes}
    clash = [d for d in [d for d, _ in mod.masses] + [d for dofs, _ in mod.springs for d in dofs] if d in fixed]
    if clash:
        raise InputError(f"{where}: mass or spring on supported dof(s) {describe(list(dict.fromkeys(clash)))}")
    rows, cols, vals = [], [], []
    for (dofs, k) in mod.springs:
        i = index[dofs[0]]
        if len(dofs) == 1:
            rows.append(i)
            cols.append(i)
            vals.append(k)
        else:
            j = index[dofs[1]]
            rows += [i, j, i, j]
            cols += [i, j, j, i]
            vals += [k, k, -k, -k]
    dK = sp.csr_array((vals, (rows, cols)), shape=(n, n))
    mi = [index[d] for d, _ in mod.masses]
    dM = sp.csr_array(([m for _, m in mod.masses], (mi, mi)), shape=(n, n))
    keep = np.array([i for i, d in enumerate(model.dofs) if d not in fixed], dtype=np.intp)
    if keep.size == 0:
        raise InputError(f"{where}: every dof of the model is supported; nothing is free")

    def cut(A):
        return None if A is None else sp.csr_array(A)[keep][:, keep]

    params, dKs, dMs, dropped = [], [], [], []
    for p, a, b in zip(model.parameters, model.dK, model.dM):
        a, b = cut(a), cut(b)
        if (a is None or a.nnz == 0 or not np.any(a.data)) and (b is None or b.nnz == 0 or not np.any(b.data)):
            dropped.append(p.name)
            continue
        if p.name in mod.values:
            v = mod.values[p.name]
            p = replace(p, value=v, bounds=(min(p.bounds[0], v), max(p.bounds[1], v)))
        params.append(p)
        dKs.append(a)
        dMs.append(b)
    dropped_set = [d for d in dropped if d in mod.values]
    if dropped_set:
        raise InputError(f"{where}: parameter(s) {', '.join(dropped_set)} are set but no longer enter the model (their elements are supported)")
    cfg = Model(
        dofs=tuple(model.dofs[i] for i in keep), K0=cut(model.K0 + dK), M0=cut(model.M0 + dM),
        parameters=tuple(params), dK=tuple(dKs), dM=tuple(dMs),
        name=f"{model.name} [{mod.name}]", nodes=model.nodes,
    )
    kept = set(keep.tolist())
    return ConfiguredModel(cfg, tuple(dropped), tuple(model.dofs[i] for i in range(n) if i not in kept))


def simulate(model: Model, modification: Modification | None = None, measured_dofs: Sequence[str] | None = None,
             n_modes: int = 3, values=None) -> TestData:
    """Noise-free test data of one configuration: its lowest ``n_modes`` elastic modes.

    Shapes are taken at ``measured_dofs`` (default every dof of the configuration; dofs the
    configuration supports are left out).  ``values``: parameter values (default nominal).
    """
    mod = modification or Modification()
    cm = configure(model, mod).model
    p = _config_values(model, cm, mod, values)
    modes = model_modes(cm, p, n_modes=min(cm.n_dofs, n_modes + 6) if cm.n_dofs > 1500 else None)
    elastic = [r for r in range(modes.n_modes) if modes.eigenvalues[r] > 0][:n_modes]
    if len(elastic) < n_modes:
        raise InputError(f"configuration {mod.name!r} has only {len(elastic)} elastic modes, {n_modes} asked for")
    if measured_dofs is None:
        dofs = list(cm.dofs)
    else:
        wanted = canonical_all(measured_dofs, "measured dofs")
        in_model, in_config = set(model.dofs), set(cm.dofs)
        unknown = [d for d in wanted if d not in in_model]
        if unknown:
            raise InputError(f"measured dofs not in the model {model.name!r}: {describe(unknown)}")
        dofs = [d for d in wanted if d in in_config]
    pos = cm.dof_index(dofs)
    return TestData(modes=tuple(MeasuredMode(modes.eigenvalues[r], tuple(dofs), modes.shapes[pos, r], f"mode {k + 1}")
                                for k, r in enumerate(elastic)))


def _config_values(model: Model, cm: Model, mod: Modification, values=None) -> np.ndarray:
    """Parameter vector of the configured model: the base model's values (or ``values``) by name,
    with the modification's known values."""
    base = dict(zip(model.parameter_names, model.resolve(values)))
    base.update(mod.values)
    return np.array([base[n] for n in cm.parameter_names], dtype=float)


def _unknowns(model: Model, names) -> list[str]:
    all_names = model.parameter_names
    names = list(names) if names is not None else [all_names[j] for j in model.free]
    for n in names:
        model.parameter_index(n)
    if not names:
        raise InputError("no unknown parameters: every parameter is fixed")
    if len(set(names)) != len(names):
        raise InputError(f"parameter(s) listed twice: {', '.join(sorted({n for n in names if names.count(n) > 1}))}")
    return names


def _prepare(model: Model, configurations: Sequence[Configuration], names: Sequence[str]):
    """Configured models, checked against the unknowns and the data."""
    if not configurations:
        raise InputError("no configurations given")
    labels = [c.label for c in configurations]
    dup = sorted({x for x in labels if labels.count(x) > 1})
    if dup:
        raise InputError(f"configuration name(s) used twice: {', '.join(dup)} (give each configuration its own name)")
    out = []
    for c in configurations:
        clash = [n for n in c.modification.values if n in names]
        if clash:
            raise InputError(
                f"configuration {c.label!r}: parameter(s) {', '.join(clash)} are unknowns being identified; "
                "a configuration can only set known (fixed) parameters"
            )
        cm = configure(model, c.modification)
        _check_data_dofs(c, cm)
        out.append(cm)
    seen = {n for cm in out for n in cm.model.parameter_names}
    blind = [n for n in names if n not in seen]
    if blind:
        raise InputError(f"parameter(s) {', '.join(blind)} enter no configuration's model (every element supported)")
    return out


def _check_data_dofs(c: Configuration, cm: ConfiguredModel) -> None:
    known = set(cm.model.dofs)
    used: dict[str, None] = {}
    d = c.data
    for m in d.modes:
        used.update(dict.fromkeys(m.dofs))
    if d.frf is not None:
        used.update(dict.fromkeys(list(d.frf.dofs) + list(d.frf.force)))
    for s in d.static:
        used.update(dict.fromkeys(list(s.dofs) + list(s.force)))
    bad = [x for x in used if x not in known]
    if bad:
        sup = [x for x in bad if x in set(cm.removed_dofs)]
        why = f" ({describe(sup)} supported in this configuration)" if sup else ""
        raise InputError(f"configuration {c.label!r}: data at dof(s) not in its model: {describe(bad)}{why}")


def _complete(c: Configuration, cm: Model) -> bool:
    """Whether the data of a configuration allow the direct solution (shapes at every dof)."""
    n = cm.n_dofs
    d = c.data
    items = [len(m.dofs) for m in d.modes if m.has_shape]
    if d.frf is not None:
        items.append(len(d.frf.dofs))
    items += [len(s.dofs) for s in d.static]
    return bool(items) and all(k == n for k in items)


# ------------------------------------------------------------------------------ results
@dataclass(frozen=True, eq=False)
class MultiConfigResult:
    """Joint update of several configurations.

    Attributes
    ----------
    method : ``"direct"`` | ``"iterative"``
    parameters : dict
        Every parameter of the base model: identified for the unknowns, given for the others.
    names : tuple of str
        The unknowns.
    x : ndarray
        Their identified values.
    success : bool
    message : str
    configurations : list of dict
        Per configuration: ``name``, ``modification`` (text), ``n_data``; direct: ``n_equations``;
        iterative: ``pairs`` [(test, model, mac)], ``frequencies_hz`` {``test``, ``model``}, ``cost``.
    conditioning : dict
        ``each``: per configuration alone, ``cumulative``: the configurations added in order, each
        with ``rank``, ``condition_number`` and ``min_singular`` of the column-scaled direct
        matrix (direct) or the normalised sensitivity matrix (iterative); ``stacked``: all.
    standard_error : ndarray
        Of ``x`` (NaN where not estimable).
    direct : DirectResult or None
    diagnostics : Diagnostics or None
        Of the iterative solution (the stacked normalised sensitivity matrix).
    cost, nfev, iterations, history :
        Of the iterative solution (0 / [] for the direct one).
    notes : list of str
    """

    method: str
    parameters: dict[str, float]
    names: tuple[str, ...]
    x: np.ndarray
    success: bool
    message: str
    configurations: list[dict]
    conditioning: dict
    standard_error: np.ndarray
    direct: DirectResult | None = None
    diagnostics: Diagnostics | None = None
    cost: float = 0.0
    nfev: int = 0
    iterations: int = 0
    history: list[dict] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    regularization: dict = field(default_factory=dict)
    start: dict[str, float] = field(default_factory=dict)


def _svd_summary(S: np.ndarray) -> dict:
    """Rank, condition number and smallest singular value of ``S`` (columns already scaled)."""
    L = S.shape[1]
    s = np.linalg.svd(S, compute_uv=False) if S.size else np.zeros(0)
    tol = max(S.shape) * np.finfo(float).eps * (s[0] if s.size else 0.0)
    rank = int(np.sum(s > tol))
    full = rank == L and S.shape[0] >= L
    return {"rank": rank, "n_rows": int(S.shape[0]), "min_singular": float(s[-1]) if full else 0.0,
            "condition_number": float(s[0] / s[-1]) if full and s[-1] > 0 else math.inf,
            "singular_values": s}


def conditioning(blocks: Sequence[np.ndarray], names: Sequence[str], labels: Sequence[str]) -> dict:
    """Conditioning of each block alone and of the blocks stacked one after another."""
    each = [{"configuration": lab, **_svd_summary(B)} for lab, B in zip(labels, blocks)]
    cumulative = []
    for k in range(1, len(blocks) + 1):
        cumulative.append({"configurations": list(labels[:k]), **_svd_summary(np.vstack(blocks[:k]))})
    return {"unknowns": list(names), "each": each, "cumulative": cumulative, "stacked": cumulative[-1]}


# ------------------------------------------------------------------------------ direct
def direct_configurations(model: Model, configurations: Sequence[Configuration], *, unknowns: Sequence[str] | None = None,
                          values=None, use: Sequence[str] = ("modes", "frf", "static"), bounded: bool = False) -> MultiConfigResult:
    """Direct (linear) joint identification from complete data of several configurations.

    Each configuration's equations (paper eqs. 4-9 for modes, 24-28 for FRF lines, static
    equilibrium) are built on its own model and stacked into one system whose columns are the
    unknowns; it is solved by the pseudo-inverse (eq. 10) or, with ``bounded``, by bounded least
    squares.  A configuration may see only some of the unknowns (its other columns are zero); a
    parameter no configuration's data strain is refused by name.

    Parameters
    ----------
    model : Model
        The baseline (unmodified) model; its values give the known parameters.
    configurations : sequence of Configuration
        Data at *every* dof of each configuration's model.
    unknowns : names to identify (default every parameter not ``fixed``).
    values : parameter values of the known parameters (default nominal).
    use : kinds of data to stack.
    bounded : honour the parameters' bounds.

    Returns
    -------
    MultiConfigResult
        ``conditioning`` compares each configuration alone with the configurations stacked.
    """
    names = _unknowns(model, unknowns)
    kinds = set(use)
    bad = kinds - {"modes", "frf", "static"}
    if bad:
        raise InputError(f"unknown data kind(s) {sorted(bad)}: use modes, frf, static")
    cms = _prepare(model, configurations, names)
    col = {n: k for k, n in enumerate(names)}
    blocks, rhs, rows_desc, per, notes = [], [], [], [], []
    info = np.zeros(len(names))
    for c, cmc in zip(configurations, cms):
        cm = cmc.model
        mine = [n for n in names if n in cm.parameter_names]
        b = EquationBuilder(cm, _config_values(model, cm, c.modification, values), mine)
        cnotes: list[str] = []
        if "modes" in kinds and c.data.modes:
            modal_equations(b, c.data.modes, cnotes)
        if "frf" in kinds and c.data.frf is not None:
            frf_equations(b, c.data.frf)
        if "static" in kinds and c.data.static:
            static_equations(b, c.data.static)
        notes += [f"{c.label}: {x}" for x in cnotes]
        if not b.cols:
            raise InputError(f"configuration {c.label!r}: no complete data to build direct equations from "
                             "(need mode shapes, FRFs or static deflections at every dof of its model)")
        A_c = np.vstack(b.cols)
        full = np.zeros((A_c.shape[0], len(names)))
        full[:, [col[n] for n in mine]] = A_c
        blocks.append(full)
        rhs.append(np.concatenate(b.rhs))
        rows_desc += [(f"{c.label}: {d}", k) for d, k in b.blocks]
        info[[col[n] for n in mine]] = np.maximum(info[[col[n] for n in mine]], b.info)
        per.append({"name": c.label, "modification": c.modification.describe(), "n_equations": int(A_c.shape[0]),
                    "n_data": int(A_c.shape[0]), "unknowns_seen": mine, "dropped": list(cmc.dropped)})
    from ..direct import INFO_TOL

    blind = [names[i] for i in np.flatnonzero(info < INFO_TOL)]
    if blind:
        raise InputError(
            f"direct solve: no configuration's data carry information on parameter(s) {', '.join(blind)}; "
            "fix them or add data that strain their elements"
        )
    A = np.vstack(blocks)
    system = LinearSystem(A, np.concatenate(rhs), tuple(names), rows_desc)
    res = solve_system(model, system, values, bounded, notes)
    scale = np.linalg.norm(A, axis=0)
    cond = conditioning([B / scale for B in blocks], names, [c.label for c in configurations])
    return MultiConfigResult(
        method="direct", parameters=res.parameters, names=tuple(names), x=res.x, success=bool(res.unique),
        message="unique least-squares solution" if res.unique else (res.notes[-1] if res.notes else "not unique"),
        configurations=per, conditioning=cond, standard_error=res.standard_error, direct=res, notes=res.notes,
    )


# ------------------------------------------------------------------------------ iterative
class _Stacked(Parametrisation):
    """Residuals and Jacobian of several configurations stacked; one vector of unknowns.

    Each configuration is a :class:`femupdate.updating.Problem` on its own model in absolute
    parameters; this class maps the common scaled unknowns ``x`` (:class:`Parametrisation`) to
    them, and offers what :func:`femupdate.updating.solve` and ``diagnostics`` need.
    """

    def __init__(self, model, configurations, cms, names, *, parametrisation, p_base, shape_scaling="unit",
                 ref_dof=None, weights=None, measurement_std=None, min_mac=0.5, n_modes=None, use_shapes=True,
                 sensitivity="auto"):
        if parametrisation not in PARAMETRISATIONS:
            raise InputError(f"unknown parametrisation {parametrisation!r}: use {', '.join(PARAMETRISATIONS)}")
        super().__init__(model, names, parametrisation, p_base)
        self.model = model
        self.subs = []
        for c, cmc in zip(configurations, cms):
            cm = cmc.model
            mine = [n for n in names if n in cm.parameter_names]
            cols = np.array([self.names.index(n) for n in mine], dtype=np.intp)
            pb = _config_values(model, cm, c.modification, p_base)
            try:
                prob = Problem(cm, c.data, mine, values=pb, shape_scaling=shape_scaling, ref_dof=ref_dof,
                               weights=weights, measurement_std=measurement_std, min_mac=min_mac, n_modes=n_modes,
                               parametrisation="absolute", use_shapes=use_shapes, sensitivity=sensitivity)
            except InputError as exc:
                raise InputError(f"configuration {c.label!r}: {exc}") from None
            self.subs.append((c.label, prob, cols))

    def residual_blocks(self, x):
        q = self.to_p(x)[self.idx]
        return [prob.residuals(q[cols]) for _, prob, cols in self.subs]

    def jacobian_blocks(self, x):
        """Per configuration, ∂r_c/∂x (rows of configuration c, all unknowns)."""
        q = self.to_p(x)[self.idx]
        d = self.dp_dx(x)
        out = []
        for _, prob, cols in self.subs:
            Jc = prob.jacobian(q[cols])
            full = np.zeros((Jc.shape[0], len(self.names)))
            full[:, cols] = Jc * d[cols][None, :]
            out.append(full)
        return out

    def residuals(self, x):
        return np.concatenate(self.residual_blocks(x))

    def jacobian(self, x):
        return np.vstack(self.jacobian_blocks(x))

    def n_data(self) -> int:
        return sum(prob.targets.n_independent for _, prob, _ in self.subs)

    def normalised_blocks(self, x, blocks=None):
        """Per configuration ∂r_c/∂(p/|p|): unit-free sensitivity blocks (``blocks``: the
        :meth:`jacobian_blocks` at ``x``, if at hand)."""
        p = self.to_p(x)[self.idx]
        d = self.dp_dx(x)
        w = np.where(p != 0, np.abs(p), 1.0) / d
        return [B * w[None, :] for B in (self.jacobian_blocks(x) if blocks is None else blocks)]


def update_configurations(model: Model, configurations: Sequence[Configuration], *, params: Sequence[str] | None = None,
                          x0: Mapping[str, float] | None = None, shape_scaling: str = "unit", ref_dof: str | None = None,
                          weights: Mapping | None = None, measurement_std: Mapping | None = None, min_mac: float = 0.5,
                          n_modes: int | None = None, parametrisation: str = "relative", method: str = "trf",
                          max_nfev: int = 200, ftol: float = 1e-10, xtol: float = 1e-10, gtol: float = 1e-10,
                          use_shapes: bool = True, values=None, sensitivity: str = "auto",
                          regularization: float | str | None = None) -> MultiConfigResult:
    """Iterative joint updating of several configurations from (incomplete) modal data.

    The residuals of every configuration (relative eigenvalue errors and scaled shape
    differences at its measured dofs, as in :func:`femupdate.updating.update`) are stacked,
    with the Jacobian of each configuration's model, and minimised over the one set of unknowns
    by :func:`scipy.optimize.least_squares`.  The options mean what they mean in
    :func:`~femupdate.updating.update` (``regularization``: a Tikhonov factor, or ``"gcv"`` /
    ``"lcurve"``, pulling the scaled parameters toward the start).

    Returns
    -------
    MultiConfigResult
        ``conditioning`` holds each configuration's normalised sensitivity matrix alone and the
        configurations stacked one after another, at the solution.
    """
    names = _unknowns(model, params)
    if method not in ("trf", "dogbox", "lm"):
        raise InputError(f"unknown method {method!r}: use trf, dogbox or lm")
    cms = _prepare(model, configurations, names)
    p_base = model.resolve(values)
    for name, v in dict(x0 or {}).items():
        p_base[model.parameter_index(name)] = float(v)
    _, sigma = modal_weights(weights, measurement_std)
    prob = _Stacked(model, configurations, cms, names, parametrisation=parametrisation, p_base=p_base,
                    shape_scaling=shape_scaling, ref_dof=ref_dof, weights=weights,
                    measurement_std=measurement_std, min_mac=min_mac, n_modes=n_modes,
                    use_shapes=use_shapes, sensitivity=sensitivity)
    n_data = prob.n_data()
    if n_data < len(names) and regularization is None:
        raise InputError(f"{len(names)} parameters but only {n_data} independent data over all configurations "
                         "(eigenvalues and scaled shape entries): add configurations or data, fix parameters, "
                         "or use regularization")
    sol, history, reg = solve(prob, model.bounds, regularization=regularization, method=method, ftol=ftol, xtol=xtol,
                               gtol=gtol, max_nfev=max_nfev)
    p_final = prob.to_p(sol.x)
    blocks = prob.residual_blocks(sol.x)
    r = np.concatenate(blocks)
    J_blocks = prob.jacobian_blocks(sol.x)
    diag = diagnostics(prob, sol.x, r, np.vstack(J_blocks), sigma)
    per = []
    for (label, sub, cols), rc, c in zip(prob.subs, blocks, configurations):
        _, modes, pairs = sub.evaluate(p_final[prob.idx][cols])
        per.append({"name": label, "modification": c.modification.describe(),
                    "n_data": sub.targets.n_independent,
                    "pairs": [(k, j, float(m)) for k, j, m in pairs], "cost": float(0.5 * rc @ rc),
                    "frequencies_hz": {"test": c.data.frequencies_hz,
                                       "model": np.array([modes.frequencies_hz[j] for _, j, _ in pairs])},
                    "swaps": list(sub.swaps)})
    cond = conditioning(prob.normalised_blocks(sol.x, J_blocks), names, [c.label for c in configurations])
    return MultiConfigResult(
        method="iterative", parameters=dict(zip(model.parameter_names, map(float, p_final))), names=tuple(names),
        x=p_final[prob.idx], success=bool(sol.success), message=str(sol.message), configurations=per,
        conditioning=cond, standard_error=diag.std, diagnostics=diag, cost=float(0.5 * r @ r), nfev=int(sol.nfev),
        iterations=max(len(history) - 1, int(sol.njev or 0)), history=history, regularization=reg,
        start=dict(zip(names, map(float, p_base[prob.idx]))),
    )


def solve_configurations(model: Model, configurations: Sequence[Configuration], method: str = "auto", *,
                         unknowns: Sequence[str] | None = None, values=None, use: Sequence[str] = ("modes", "frf", "static"),
                         bounded: bool = False, **iterative) -> MultiConfigResult:
    """Joint update, direct when every configuration's data are complete, iterative otherwise.

    ``method``: ``"auto"`` | ``"direct"`` | ``"iterative"``.  ``unknowns`` and ``values`` serve
    both; ``use`` and ``bounded`` the direct solution (:func:`direct_configurations`); the other
    keyword arguments the iterative one (:func:`update_configurations`).
    """
    if method not in ("auto", "direct", "iterative"):
        raise InputError(f"unknown method {method!r}: use auto, direct or iterative")
    if method == "auto":
        cms = _prepare(model, configurations, _unknowns(model, unknowns))
        method = "direct" if all(_complete(c, cm.model) for c, cm in zip(configurations, cms)) else "iterative"
    if method == "direct":
        return direct_configurations(model, configurations, unknowns=unknowns, values=values, use=use, bounded=bounded)
    return update_configurations(model, configurations, params=unknowns, values=values, **iterative)


# ------------------------------------------------------------------------------ pre-test ranking
@dataclass(frozen=True, eq=False)
class Ranking:
    """Candidate modifications ranked by the information they add to the baseline test.

    Attributes
    ----------
    criterion : str
    baseline : dict
        ``rank``, ``condition_number``, ``min_singular``, ``logdet`` of the baseline alone.
    candidates : list of dict
        Best first: ``name``, ``modification`` (text), ``gain`` (in the criterion: log-det gain,
        increase of the smallest singular value, or the factor by which the condition number
        falls), ``rank``, ``condition_number``, ``min_singular``, ``logdet`` of baseline +
        candidate, ``frequency_shift`` (largest relative change of the simulated frequencies
        from the baseline's) and ``min_mac`` (lowest MAC of a candidate mode with its baseline mode).
    selected : list of str
        With ``select=k``: the k candidates chosen greedily, each the best given the ones before.
    unknowns : tuple of str
    """

    criterion: str
    baseline: dict
    candidates: list[dict]
    selected: list[str]
    unknowns: tuple[str, ...]


def _information(S: np.ndarray) -> dict:
    s = _svd_summary(S)
    F = S.T @ S
    sign, logdet = np.linalg.slogdet(F) if S.size else (0.0, -math.inf)
    s["logdet"] = float(logdet) if sign > 0 and s["rank"] == S.shape[1] else -math.inf
    return s


def _score(info: dict, criterion: str) -> tuple:
    """Sort key, larger is better: rank first, then the criterion."""
    if criterion == "logdet":
        v = info["logdet"]
    elif criterion == "min_singular":
        v = info["min_singular"]
    else:
        v = -info["condition_number"]
    return (info["rank"], v)


def _gain(info: dict, base: dict, criterion: str) -> float:
    if criterion == "logdet":
        a, b = info["logdet"], base["logdet"]
        return math.inf if b == -math.inf and a > -math.inf else (a - b if a > -math.inf else 0.0)
    if criterion == "min_singular":
        return info["min_singular"] - base["min_singular"]
    a, b = info["condition_number"], base["condition_number"]
    return math.inf if math.isinf(b) and not math.isinf(a) else (b / a if math.isfinite(a) else 1.0)


def rank_modifications(model: Model, candidates: Sequence[Modification], measured_dofs: Sequence[str], n_modes: int, *,
                       baseline: Modification | None = None, params: Sequence[str] | None = None, values=None,
                       criterion: str = "condition", select: int | None = None, shape_scaling: str = "unit",
                       use_shapes: bool = True, sensitivity: str = "auto") -> Ranking:
    """Rank candidate modifications by the new, independent information they would bring.

    For the baseline configuration and each candidate, the test is simulated at the nominal
    parameters (the lowest ``n_modes`` elastic modes at ``measured_dofs``; dofs a candidate
    supports are left out) and its normalised sensitivity matrix ``S = ∂r/∂(p/|p|)`` is computed
    with the residuals of :func:`update_configurations`.  Each candidate is scored by the
    baseline and the candidate stacked, under ``criterion`` (module docstring).

    Parameters
    ----------
    model : Model
    candidates : sequence of Modification
    measured_dofs : the planned sensors; n_modes : the modes to be measured in every configuration.
    baseline : the configuration that will be tested in any case (default the unmodified structure).
    params : the unknowns (default every parameter not fixed); values : nominal values.
    criterion : ``"condition"`` | ``"logdet"`` | ``"min_singular"``.
    select : choose this many candidates greedily (sequential design).

    Returns
    -------
    Ranking
    """
    if criterion not in CRITERIA:
        raise InputError(f"unknown criterion {criterion!r}: use {', '.join(CRITERIA)}")
    if not candidates:
        raise InputError("no candidate modifications to rank")
    names = _unknowns(model, params)
    base_mod = baseline or Modification(name="baseline")
    mods = [base_mod] + list(candidates)
    labels = [m.name for m in mods]
    dup = sorted({x for x in labels if labels.count(x) > 1})
    if dup:
        raise InputError(f"candidate name(s) used twice: {', '.join(dup)}")
    if select is not None and not 1 <= int(select) <= len(candidates):
        raise InputError(f"select must be between 1 and the number of candidates ({len(candidates)}), got {select}")
    configs = [Configuration(simulate(model, m, measured_dofs, n_modes, values), m) for m in mods]
    cms = _prepare(model, configs, names)
    p = model.resolve(values)
    prob = _Stacked(model, configs, cms, names, parametrisation="relative", p_base=p, shape_scaling=shape_scaling,
                    use_shapes=use_shapes, sensitivity=sensitivity)
    x = prob.from_p(p[prob.idx])
    S = prob.normalised_blocks(x)
    base = _information(S[0])
    ref_modes = configs[0].data
    rows = []
    for k, m in enumerate(candidates, start=1):
        info = _information(np.vstack([S[0], S[k]]))
        data = configs[k].data
        shift = float(np.max(np.abs(np.sqrt(data.eigenvalues / ref_modes.eigenvalues) - 1.0)))
        measured = set(data.modes[0].dofs)
        common = [d for d in ref_modes.modes[0].dofs if d in measured]
        A = ref_modes.shape_matrix(common)[1]
        B = data.shape_matrix(common)[1]
        rows.append({"name": m.name, "modification": m.describe(), "gain": _gain(info, base, criterion),
                     "frequency_shift": shift, "min_mac": float(np.min(np.diag(mac(A, B)))) if common else math.nan,
                     **{k2: info[k2] for k2 in ("rank", "condition_number", "min_singular", "logdet")}})
    order = sorted(range(len(rows)), key=lambda i: _score(rows[i], criterion), reverse=True)
    selected: list[str] = []
    if select:
        chosen: list[int] = []
        for _ in range(int(select)):
            best = max((i for i in range(len(candidates)) if i not in chosen),
                       key=lambda i: _score(_information(np.vstack([S[0]] + [S[j + 1] for j in chosen + [i]])), criterion))
            chosen.append(best)
        selected = [candidates[i].name for i in chosen]
    return Ranking(criterion, {k2: base[k2] for k2 in ("rank", "condition_number", "min_singular", "logdet")},
                   [rows[i] for i in order], selected, tuple(names))
