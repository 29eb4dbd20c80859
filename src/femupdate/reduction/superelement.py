r"""Connectivity-preserving reduction with super-elements (Lin 1993).

Reducing a whole model to its measured dofs fills the reduced matrices: :math:`\nu \times \nu`
unknown entries for a model of order :math:`\nu`.  Lin argues for reductions that keep the
physical connectivity instead: condense *groups of elements* (super-elements) onto their own
boundary dofs and assemble the condensed super-elements.  The reduced stiffness then couples only
dofs that share a super-element (banded, like the original), and the unknowns stay the physical
parameters of the groups, linear in the model's size.

* :func:`split_structure` — cut a :class:`~femupdate.Structure` into element groups;
* :func:`condense` — one super-element: a group's model reduced to its retained dofs
  (Guyan by default, any method of :mod:`~femupdate.reduction.transforms`);
* :func:`assemble` — sum labelled affine models into one (parameters merged by name);
* :func:`superelement_model` — all three in one call;
* :func:`lin_beam` — the paper's demonstration structure: a 102-dof free-free beam that reduces to
  52 dofs with 25 two-element super-elements.

When each super-element's stiffness is scaled by a single parameter (and its mass is fixed), the
Guyan transformation of that super-element does not depend on the parameter
(:math:`K_{oo}^{-1}K_{oa}` is scale-free), so the assembled reduced model is affine *and* the exact
static condensation at every parameter value — unlike a global Guyan reduction, whose
transformation mixes every parameter.
"""

from __future__ import annotations

from collections.abc import Callable, Hashable, Sequence

import numpy as np
import scipy.sparse as sp

from .._errors import InputError
from ..dofs import canonical_all, describe, parse_dof, sort_key
from ..model import Model, Parameter
from ..structure import Structure
from ..structure.groups import ElementGroup
from .projection import reduce
from .reducer import Reducer


def split_structure(structure: Structure, key: Callable[[list[str], tuple | None], Hashable]) -> dict:
    """Element groups of ``structure``: ``{key: Structure}``.

    ``key(labels, nodes)`` is called for every element with its dof labels and, for line elements,
    its node pair; elements with the same key form one group.  Each group's Structure declares only
    the parameters its elements use, shares the node table, and keeps the supports that touch it.

    Parameters
    ----------
    structure : Structure
        The structure to cut (not modified).
    key : callable ``(labels: list of str, nodes: (int, int) or None) -> hashable``
        Group of each element; ``None`` is refused.

    Returns
    -------
    dict
        ``{key: Structure}``, one structure per group.

    Raises
    ------
    InputError
        ``key`` returned ``None`` for an element.
    """
    parts: dict = {}
    for g in structure.groups:
        for i, labels in enumerate(g.labels):
            nodes = tuple(int(n) for n in g.nodes[i]) if g.nodes is not None else None
            k = key(list(labels), nodes)
            if k is None:
                raise InputError(f"split_structure: element {g.where[i]} belongs to no group (key returned None)")
            parts.setdefault(k, {}).setdefault(id(g), (g, []))[1].append(i)
    out = {}
    for k, by_group in parts.items():
        s = Structure(f"{structure.name} [{k}]")
        s.nodes = dict(structure.nodes)
        used_params: set[str] = set()
        labels_here: set[str] = set()
        for g, sel in by_group.values():
            props = {p: [v[i] for i in sel] for p, v in g.props.items()}
            used_params |= {v for vals in props.values() for v in vals if isinstance(v, str)}
            rows = [g.labels[i] for i in sel]
            labels_here |= {lab for r in rows for lab in r}
            s.groups.append(ElementGroup(
                type=g.type, props=props, labels=rows,
                nodes=None if g.nodes is None else g.nodes[sel], mass=g.mass, dim=g.dim,
                orientation=None if g.orientation is None else g.orientation[sel],
                where=[g.where[i] for i in sel], nu=None if g.nu is None else g.nu[sel], drill=g.drill))
        s.parameters = {n: p for n, p in structure.parameters.items() if n in used_params}
        s.supports = [d for d in structure.supports if d in labels_here]
        nodes_here = {parse_dof(lab)[0] for lab in labels_here}
        s.support_nodes = [n for n in structure.support_nodes if n in nodes_here]
        out[k] = s
    return out


def assemble(models: Sequence[Model], dofs: Sequence[str] | None = None, name: str = "assembled") -> Model:
    """Sum of labelled affine models: ``K = sum_i P_i^T K_i P_i`` term by term, parameters by name.

    A parameter that appears in several models must be declared identically (value, bounds,
    fixed).  ``dofs`` fixes the order of the result (it must be exactly the union of the models'
    dofs); by default node-then-direction order.

    Parameters
    ----------
    models : sequence of Model
        The parts, each with its own dof labels (shared labels are summed).
    dofs : sequence of str, optional
        Dof order of the result: exactly the union of the parts' dofs.
    name : str, default ``"assembled"``
        Name of the result.

    Returns
    -------
    Model
        The union of the parts' dofs; parameters merged by name; node tables merged.

    Raises
    ------
    InputError
        No models; a ``dofs`` order that is not exactly the union; a parameter declared
        differently in two parts; and as :class:`Model`.
    """
    from ..coefficients import route_refusal
    for m in models:
        route_refusal(m, "the superelement assembly")
    if not models:
        raise InputError("assemble: no models")
    union = sorted({d for m in models for d in m.dofs}, key=sort_key)
    if dofs is not None:
        dofs = canonical_all(dofs, "assembled dofs")
        missing = sorted(set(union) - set(dofs), key=sort_key)
        extra = [d for d in dofs if d not in set(union)]
        if missing or extra:
            raise InputError("assemble: the dof order must list exactly the models' dofs"
                             + (f"; not in any super-element: {describe(extra)}" if extra else "")
                             + (f"; missing from the order: {describe(missing)}" if missing else ""))
        union = list(dofs)
    pos = {d: i for i, d in enumerate(union)}
    n = len(union)
    params: dict[str, Parameter] = {}
    for m in models:
        for p in m.parameters:
            if p.name in params and params[p.name] != p:
                raise InputError(f"assemble: parameter {p.name!r} is declared differently in two parts")
            params.setdefault(p.name, p)
    names = list(params)
    trip: dict[tuple[str, int], list[tuple[np.ndarray, np.ndarray, np.ndarray]]] = {("K", -1): [], ("M", -1): []}
    trip |= {(t, j): [] for t in "KM" for j in range(len(names))}
    for m in models:
        idx = np.array([pos[d] for d in m.dofs], dtype=np.int64)
        terms = [(("K", -1), m.K0), (("M", -1), m.M0)]
        for j, p in enumerate(m.parameters):
            terms += [(("K", names.index(p.name)), m.dK[j]), (("M", names.index(p.name)), m.dM[j])]
        for key, A in terms:
            if A is None or A.nnz == 0:
                continue
            c = sp.coo_array(A)
            trip[key].append((idx[c.row], idx[c.col], c.data))

    def mat(key):
        parts = trip[key]
        if not parts:
            return None
        r, c, v = (np.concatenate([p[i] for p in parts]) for i in range(3))
        return sp.csr_array(sp.coo_array((v, (r, c)), shape=(n, n)))

    zero = sp.csr_array((n, n))
    nodes: dict[int, tuple[float, float, float]] = {}
    for m in models:
        nodes.update(m.nodes)
    return Model(dofs=tuple(union), K0=mat(("K", -1)) if trip[("K", -1)] else zero,
                 M0=mat(("M", -1)) if trip[("M", -1)] else zero, parameters=tuple(params[n_] for n_ in names),
                 dK=tuple(mat(("K", j)) for j in range(len(names))), dM=tuple(mat(("M", j)) for j in range(len(names))),
                 name=name, nodes=nodes)


def condense(model: Model, keep: Sequence[str], method: str = "guyan", values=None, n_modes: int | None = None) -> Model:
    """One super-element: ``model`` reduced onto those of ``keep`` that it has (its boundary).

    Dofs of ``keep`` that the model lacks are ignored; a model with no omitted dof is returned
    unchanged.  See :func:`~femupdate.reduction.transforms.reduce` for what the reduced model is.

    Parameters
    ----------
    model : Model
        The super-element's model.
    keep : sequence of str
        Retained dofs (of the whole structure; only the model's own count).
    method : str, default ``"guyan"``
        ``"guyan"``, ``"irs"``, ``"modal"``, ``"hybrid"`` or ``"serep"``.
    values : None, mapping of str to float, or array_like, optional
        Parameter values the transformation is built at (default nominal).
    n_modes : int, optional
        Modes used by the modal methods.

    Returns
    -------
    Model
        The condensed super-element (or ``model`` itself when nothing is omitted).

    Raises
    ------
    InputError
        None of the model's dofs retained; and as the reduction builders.
    """
    keep_set = set(canonical_all(keep, "keep"))
    boundary = [d for d in model.dofs if d in keep_set]
    if len(boundary) == model.n_dofs:
        return model
    if not boundary:
        raise InputError(f"super-element {model.name!r} has no retained dof: it would be condensed away entirely "
                         "(retain at least one of its dofs, or join it to a neighbouring group)")
    t = Reducer(model, boundary, values).transformation(method, n_modes)
    return reduce(model, t, name=f"{model.name} ({method})")


def superelement_model(structure: Structure, key: Callable[[list[str], tuple | None], Hashable], keep: Sequence[str],
                       method: str = "guyan", name: str | None = None) -> tuple[Model, dict]:
    """Reduce ``structure`` onto ``keep`` super-element by super-element and assemble.

    Parameters
    ----------
    structure : Structure
    key : callable
        Element -> group (see :func:`split_structure`).
    keep : sequence of str
        Retained dofs; the reduced model's dofs in this order.  Every dof shared by two groups must
        be retained (a super-element may only condense dofs interior to it).
    method : str, default "guyan"
        Reduction of each super-element (a method of :meth:`Reducer.transformation`).
    name : str, optional
        Name of the assembled model (default ``"<structure name> (<n> super-elements, <method>)"``).

    Returns
    -------
    (Model, dict)
        The assembled reduced model, and ``{group key: (n_dofs, n_retained)}`` of the super-elements.
    """
    keep = canonical_all(keep, "keep")
    keep_set = set(keep)
    parts = {k: s.build() for k, s in split_structure(structure, key).items()}
    owner: dict[str, list] = {}
    for k, m in parts.items():
        for d in m.dofs:
            owner.setdefault(d, []).append(k)
    shared = sorted((d for d, ks in owner.items() if len(ks) > 1 and d not in keep_set), key=sort_key)
    if shared:
        raise InputError(f"dof(s) {describe(shared)} are omitted but shared by several super-elements "
                         f"(e.g. {shared[0]} by groups {owner[shared[0]][:3]}): retain them, a super-element may "
                         "condense only dofs interior to it")
    unknown = [d for d in keep if d not in owner]
    if unknown:
        raise InputError(f"keep: dof(s) not in the model: {describe(unknown)}")
    reduced = [condense(m, keep, method) for m in parts.values()]
    info = {k: (m.n_dofs, r.n_dofs) for (k, m), r in zip(parts.items(), reduced)}
    return assemble(reduced, dofs=keep, name=name or f"{structure.name} ({len(parts)} super-elements, {method})"), info


# ---------------------------------------------------------------------------------- Lin's beam
def lin_beam(n_elements: int = 50, length: float = 2.0, E: float = 70e9, width: float = 0.05, height: float = 0.01,
             rho: float = 2700.0, per_group: int = 2, support: str = "free") -> tuple[Structure, Callable, list[str]]:
    r"""The paper's super-element demonstration: a uniform beam in bending, one parameter per group.

    ``n_elements`` Euler-Bernoulli elements (``beam2d``, consistent mass) along x with the axial
    dofs removed, so each of the ``n_elements + 1`` nodes has two dofs (``y``, ``rz``): with the
    defaults a 2 m free-free aluminium bar of 50 × 10 mm section, 51 nodes, **102 dofs**.
    Consecutive runs of ``per_group`` elements form a group with its own Young's modulus
    ``E_k`` (``k = 1 ..``, bounds 0.5-2 × nominal); with the defaults 25 groups and 25 parameters.
    The retained dofs are the nodes at group ends: 26 nodes, **52 dofs**, so each super-element
    condenses its interior node.

    Parameters
    ----------
    n_elements : int, default 50
        Number of beam elements (a positive multiple of ``per_group``).
    length : float, default 2.0
        Beam length, m.
    E : float, default 70e9
        Nominal Young's modulus of every group, Pa.
    width, height : float, default 0.05 and 0.01
        Rectangular section, m (bending about the 0.05 m side: I = width · height³ / 12).
    rho : float, default 2700.0
        Density, kg/m³.
    per_group : int, default 2
        Elements per group (super-element).
    support : {"free", "cantilever"}, default "free"
        Free-free, or clamped at node 1 (its ``y`` and ``rz`` supported and left out of ``keep``).

    Returns
    -------
    (Structure, key, keep)
        The structure, the element -> group function for :func:`superelement_model`, and the
        retained dof labels.

    Raises
    ------
    InputError
        ``n_elements`` or ``per_group`` below 1, ``n_elements`` not a multiple of ``per_group``, or
        an unknown ``support``.
    """
    if n_elements < 1 or per_group < 1 or n_elements % per_group:
        raise InputError(f"lin_beam: n_elements ({n_elements}) must be a positive multiple of per_group ({per_group})")
    if support not in ("free", "cantilever"):
        raise InputError(f"lin_beam: support must be 'free' or 'cantilever', got {support!r}")
    n_groups = n_elements // per_group
    s = Structure(f"Lin beam {n_elements + 1} nodes")
    ids = np.arange(1, n_elements + 2)
    x = np.linspace(0.0, length, n_elements + 1)
    s.add_nodes(ids, np.column_stack([x, np.zeros_like(x)]))
    for k in range(1, n_groups + 1):
        s.parameter(f"E_{k}", E, bounds=(0.5 * E, 2.0 * E))
    group = np.repeat(np.arange(1, n_groups + 1), per_group)
    A, I = width * height, width * height**3 / 12.0
    s.beam2d(np.column_stack([ids[:-1], ids[1:]]), E=[f"E_{g}" for g in group], A=A, I=I, rho=rho)
    s.support([f"{i}:x" for i in ids])
    if support == "cantilever":
        s.support(["1:y", "1:rz"])
    first = {int(ids[i]): int(group[i]) for i in range(n_elements)}

    def key(labels, nodes):
        return first[min(nodes)]

    kept_nodes = ids[::per_group]
    keep = [f"{i}:{d}" for i in kept_nodes for d in ("y", "rz") if not (support == "cantilever" and i == 1)]
    return s, key, keep
