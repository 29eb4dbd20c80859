r"""Test configurations: the known modifications that define them and their models.

Configuration c's model is

.. math:: K_c(p) = K(p) + \Delta K_c, \qquad M_c(p) = M(p) + \Delta M_c

restricted to the dofs left free by its supports (:func:`configure`); :func:`simulate` gives a
configuration's noise-free modes.  The checks shared by the direct, iterative and ranking
solutions (unknowns, configurations against their data) are here too.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace

import numpy as np
import scipy.sparse as sp

from ..._errors import InputError
from ...dofs import canonical_all, describe, node_id, parse_dof
from ...modal import model_modes
from ...model import Model
from ...testdata import MeasuredMode, TestData


# ------------------------------------------------------------------------------ modifications
@dataclass(frozen=True)
class Modification:
    """Known changes that turn the baseline structure into one test configuration.

    Each parameter is stored, validated and with canonical dof labels, as the attribute of the
    same name.

    Parameters
    ----------
    name : str, default ``"baseline"``
        Name of the configuration.
    masses : tuple of (dof, mass)
        Lumped masses added at dofs (kg, or kg m^2 on rotations); negative removes known mass.
    springs : tuple of ((dof,) or (dof_a, dof_b), k)
        Springs added to ground (one dof) or between two dofs (N/m, N m/rad).
    supports : tuple of str
        Dofs fixed in this configuration (removed from its model).
    support_nodes : tuple of int or str
        Nodes (numbers, or names such as ``"A2"``) all of whose dofs are fixed.
    values : mapping {parameter: value}
        Known (fixed) parameters that take other values in this configuration.

    Raises
    ------
    InputError
        Invalid dof labels; a zero or non-finite mass or spring; a spring on neither one nor two
        dofs; a non-numeric or non-finite value.
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
        object.__setattr__(self, "support_nodes", tuple(node_id(n, f"{where} support node") for n in self.support_nodes))
        object.__setattr__(self, "values", vals)

    @property
    def is_baseline(self) -> bool:
        """Whether the modification changes nothing."""
        return not (self.masses or self.springs or self.supports or self.support_nodes or self.values)

    def describe(self) -> str:
        """One line listing the changes (``"unmodified"`` for none)."""
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
    """One tested configuration: its test data and the known modification that defines it.

    Parameters
    ----------
    data : TestData
        The data measured on this configuration (dofs of the configured model).
    modification : Modification, default unmodified
        The known changes from the baseline.
    name : str, default ``""``
        Label (default: the modification's name, see :attr:`label`).
    """

    data: TestData
    modification: Modification = field(default_factory=Modification)
    name: str = ""

    @property
    def label(self) -> str:
        """``name``, or the modification's name when empty."""
        return self.name or self.modification.name


@dataclass(frozen=True, eq=False)
class ConfiguredModel:
    """The model of one configuration and the baseline parameters it does not depend on.

    Parameters
    ----------
    model : Model
        The configured model.
    dropped : tuple of str
        Baseline parameters that no longer enter it.
    removed_dofs : tuple of str
        Baseline dofs supported in this configuration.
    """

    model: Model
    dropped: tuple[str, ...]
    removed_dofs: tuple[str, ...]


def configure(model: Model, modification: Modification) -> ConfiguredModel:
    """The model of the configuration ``modification`` defines (a new :class:`Model`).

    Added masses and springs go into the known parts ``K0``, ``M0``; supported dofs are removed;
    ``values`` become the nominal values of those parameters.  A parameter that no longer enters
    the model (every dof of its elements supported) is dropped from it and listed in ``dropped``.

    Parameters
    ----------
    model : Model
        The baseline model.
    modification : Modification
        The known changes.

    Returns
    -------
    ConfiguredModel

    Raises
    ------
    InputError
        A dof, node or parameter that the model lacks (the message names the modification and the
        culprit), a mass or spring on a dof the same modification supports, every dof supported,
        a value set for a parameter that no longer enters the model.
    """
    from ...coefficients import route_refusal
    route_refusal(model, 'the multi-configuration route')
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

    Parameters
    ----------
    model : Model
        The baseline model.
    modification : Modification, optional
        The configuration (default: the baseline itself).
    measured_dofs : sequence of str, optional
        Dofs of the shapes (default every dof of the configured model).
    n_modes : int, default 3
        Number of elastic (non-zero eigenvalue) modes.
    values : None, mapping of str to float, or array_like, optional
        Baseline parameter values (default nominal); the modification's values override them.

    Returns
    -------
    TestData
        ``n_modes`` measured modes (eigenvalues in rad²/s², mass-normalised shapes).

    Raises
    ------
    InputError
        Fewer elastic modes than asked; measured dofs not in the model; and as :func:`configure`.
    """
    mod = modification or Modification()
    cm = configure(model, mod).model
    p = config_values(model, cm, mod, values)
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


def config_values(model: Model, cm: Model, mod: Modification, values=None) -> np.ndarray:
    """Parameter vector of the configured model: the base model's values (or ``values``) by name,
    with the modification's known values.

    Parameters
    ----------
    model : Model
        The baseline model.
    cm : Model
        The configured model (:func:`configure`).
    mod : Modification
        The configuration's modification.
    values : None, mapping of str to float, or array_like, optional
        Baseline values (default nominal).

    Returns
    -------
    numpy.ndarray, shape ``(len(cm.parameters),)``
    """
    base = dict(zip(model.parameter_names, model.resolve(values)))
    base.update(mod.values)
    return np.array([base[n] for n in cm.parameter_names], dtype=float)


def check_unknowns(model: Model, names) -> list[str]:
    """The unknown parameters, checked.

    Parameters
    ----------
    model : Model
        The baseline model.
    names : sequence of str or None
        Parameter names (``None``: every parameter not ``fixed``).

    Returns
    -------
    list of str

    Raises
    ------
    InputError
        An unknown name; no unknowns; a name listed twice.
    """
    all_names = model.parameter_names
    names = list(names) if names is not None else [all_names[j] for j in model.free]
    for n in names:
        model.parameter_index(n)
    if not names:
        raise InputError("no unknown parameters: every parameter is fixed")
    if len(set(names)) != len(names):
        raise InputError(f"parameter(s) listed twice: {', '.join(sorted({n for n in names if names.count(n) > 1}))}")
    return names


def prepare(model: Model, configurations: Sequence[Configuration], names: Sequence[str]):
    """Configured models, checked against the unknowns and the data.

    Parameters
    ----------
    model : Model
        The baseline model.
    configurations : sequence of Configuration
        The tested configurations (distinct labels).
    names : sequence of str
        The unknown parameters.

    Returns
    -------
    list of ConfiguredModel
        One per configuration, in order.

    Raises
    ------
    InputError
        No configurations; a label used twice; a configuration that sets an unknown parameter;
        data at dofs not in a configured model; an unknown that enters no configuration; and as
        :func:`configure`.
    """
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
    for fs in d.frf_sets:
        used.update(dict.fromkeys(list(fs.dofs) + list(fs.force)))
    for s in d.static:
        used.update(dict.fromkeys(list(s.dofs) + list(s.force)))
    bad = [x for x in used if x not in known]
    if bad:
        sup = [x for x in bad if x in set(cm.removed_dofs)]
        why = f" ({describe(sup)} supported in this configuration)" if sup else ""
        raise InputError(f"configuration {c.label!r}: data at dof(s) not in its model: {describe(bad)}{why}")


def is_complete(c: Configuration, cm: Model) -> bool:
    """Whether the data of a configuration allow the direct solution (shapes at every dof).

    Parameters
    ----------
    c : Configuration
        The configuration and its data.
    cm : Model
        Its configured model.

    Returns
    -------
    bool
        True when there is at least one shape, FRF or static case and each covers as many dofs as
        the model has (the dofs themselves are checked by :func:`prepare`).
    """
    n = cm.n_dofs
    d = c.data
    items = [len(m.dofs) for m in d.modes if m.has_shape]
    items += [len(fs.dofs) for fs in d.frf_sets]
    items += [len(s.dofs) for s in d.static]
    return bool(items) and all(k == n for k in items)
