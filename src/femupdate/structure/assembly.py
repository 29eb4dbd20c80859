"""The assembly of a :class:`~femupdate.structure.Structure` into the sparse
:class:`~femupdate.model.Model` (:meth:`Structure.build <femupdate.structure.Structure.build>`):
element terms per group, properties resolved to numbers or parameters, triplets summed into one
sparse matrix per parameter and one per product of parameter powers (E·t³: a non-linear term
of the model, :mod:`femupdate.coefficients`); no dense global matrix."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import scipy.sparse as sp

from .. import elements as el
from .. import elements_3d as e3
from .._errors import InputError
from .._limits import MAX_MAGNITUDE
from ..dofs import describe
from ..coefficients import Power, Term
from ..model import Model
from ..constraints import reduce_model, transformation
from .groups import SHELLS, SOLIDS, ElementGroup, NodeDofs, merge_groups, triplets
from .node_assembly import DIR_CODE, DofTable, assemble_node_group
from .links import constraint_rows, offset_terms, point_mass_terms, supported_rows
from ..mesh.units import check_parameters
from .units import parameter_units


def _free_dofs(self, groups):
    """The dof table, the constraint rows (and their sources), the free codes and named labels."""
    table = DofTable(groups)
    rows: dict = {}
    source: dict = {}
    if self.constraints:  # rigid links and ties: the independent dofs no element uses join the model
        rows, source, extra = constraint_rows(self, set(table.labels()))
        table = DofTable(groups, extra)
    unknown_sup = [d for d in self.supports if not table.contains(d)]
    if unknown_sup:
        raise InputError(f"support dof(s) not used by any element: {describe(unknown_sup)}")
    used_nodes = table.nodes()
    missing_nodes = [n for n in self.support_nodes if n not in used_nodes]
    if missing_nodes:
        raise InputError(f"support node(s) not used by any element: {missing_nodes[:8]}")
    fixed_codes, fixed_named = table.fixed(self.supports, self.support_nodes)
    if rows:
        fixed = set(table.labels_of(table.codes[fixed_codes])) | fixed_named
        supported_rows(rows, source, fixed)
    codes = table.codes[~fixed_codes]
    named = [lab for lab in table.named if lab not in fixed_named]
    if not len(codes) and not named:
        raise InputError(f"structure {self.name!r}: every dof is supported; nothing is free")
    return table, rows, source, codes, named, used_nodes


def assemble(structure) -> Model:
    """:meth:`Structure.build <femupdate.structure.Structure.build>`: the affine sparse model of ``structure``."""
    self = structure

    if not self.groups:
        raise InputError(f"structure {self.name!r} has no elements")
    groups = merge_groups(self.groups)
    table, rows, source, codes, named, used_nodes = _free_dofs(self, groups)
    dofs = table.labels_of(codes) + named
    named_index = {lab: len(codes) + i for i, lab in enumerate(named)}
    pnames = list(self.parameters)
    pindex = {n: j for j, n in enumerate(pnames)}
    L, n = len(pnames), len(dofs)
    trip: dict[tuple[str, int], list[tuple[np.ndarray, np.ndarray, np.ndarray]]] = {
        (target, t): [] for target in ("K", "M") for t in range(-1, L)}  # every K key, then every M key
    blocks: dict[tuple[str, int], list] = {}  # CSR parts of the shell and solid groups
    signatures: dict[tuple, int] = {}  # a product of parameter powers -> its owner id (L, L + 1, ...)
    nodes = node_table(self)

    def D_of(U, dirs):  # model dof index of each (node, direction) of a shell or solid group, -1: supported
        c = U[:, None] * 8 + np.array([DIR_CODE[d] for d in dirs])[None]
        if not len(codes):
            return np.full(c.shape, -1, np.int64)
        pos = np.minimum(np.searchsorted(codes, c), len(codes) - 1)
        return np.where(codes[pos] == c, pos, -1)

    for g in groups:
        resolved = {k: resolve_property(self, g, k, pindex) for k in g.props}
        if isinstance(g.labels, NodeDofs):
            assemble_node_group(g, lambda h: element_terms(self, h, nodes=nodes),
                                lambda f, g=g, r=resolved: combine_factors(self, g, f, r, signatures, L), D_of, n, blocks)
            continue
        terms = element_terms(self, g, nodes=nodes)
        idx = table.index_rows(g.labels, codes, named_index)
        for target, tlist in (("K", terms.K), ("M", terms.M)):
            for factors, unit in tlist:
                coef, pid = combine_factors(self, g, factors, resolved, signatures, L)
                triplets(trip, target, unit, idx, coef, pid)
    mats: dict[tuple[str, int], sp.csr_array | None] = {}
    for target in ("K", "M"):
        for t in range(L, L + len(signatures)):
            trip.setdefault((target, t), [])
    for key, parts in trip.items():
        mats[key] = _sum(parts, blocks.pop(key, []), n)
    zero = sp.csr_array((n, n))
    K0 = mats[("K", -1)] if mats[("K", -1)] is not None else zero
    M0 = mats[("M", -1)] if mats[("M", -1)] is not None else zero
    check_parameters(self)  # a mesh's E, G and rho parameters against its declared units
    units = parameter_units(groups, pnames, self.units)
    model = Model(
        dofs=tuple(dofs), K0=K0, M0=M0,
        parameters=tuple(par if par.unit else replace(par, unit=units[par.name])
                         for par in (self.parameters[p] for p in pnames)),
        dK=tuple(mats[("K", j)] for j in range(L)), dM=tuple(mats[("M", j)] for j in range(L)),
        name=self.name, nodes={k: v for k, v in self.nodes.items() if k in used_nodes},
        terms=tuple(Term(factors=tuple(Power(pnames[j], a) for j, a in sig), K=mats[("K", t)], M=mats[("M", t)])
                    for sig, t in signatures.items()),
        positive=frozenset(v for g in groups for vals in g.props.values() for v in set(vals) if isinstance(v, str)),
    )
    if not rows:
        return model
    if len(rows) == len(dofs):
        raise InputError(f"structure {self.name!r}: every free dof is a dependent dof of a constraint; nothing is free")
    T, kept, dep = transformation(dofs, rows)
    return reduce_model(model, T, kept, dep, [source[dofs[i]] for i in dep])


def _sum(parts, csr_parts, n):
    """One CSR matrix of COO triplet parts and CSR parts (None when both are empty)."""
    A = None
    if parts:
        r = np.concatenate([p[0] for p in parts])
        c = np.concatenate([p[1] for p in parts])
        v = np.concatenate([p[2] for p in parts])
        A = sp.coo_array((v, (r, c)), shape=(n, n)).tocsr()
        A.sum_duplicates()
    for B in csr_parts:
        A = B if A is None else A + B
    return A


def node_table(self) -> tuple[np.ndarray, np.ndarray]:
    """Node ids (sorted) and their coordinates ``(n, 3)``."""
    ids = np.fromiter(self.nodes.keys(), np.int64, len(self.nodes))
    xyz = np.array(list(self.nodes.values()), dtype=float).reshape(-1, 3)
    o = np.argsort(ids)
    return ids[o], xyz[o]


def _coords(self, g: ElementGroup, nodes=None) -> np.ndarray:
    """Node coordinates of a group's elements, ``(n_el, n_nodes, 3)``; ``nodes``: :func:`node_table`."""
    if g.nodes is None:  # spring and mass groups have no end nodes; _terms does not ask for theirs
        raise TypeError(f"{g.where[0]}: a {g.type} group has no end nodes")
    if nodes is not None and len(nodes[0]):
        pos = np.minimum(np.searchsorted(nodes[0], g.nodes), len(nodes[0]) - 1)
        if np.all(nodes[0][pos] == g.nodes):
            return nodes[1][pos]
    ids = np.unique(g.nodes)
    missing = [int(i) for i in ids if int(i) not in self.nodes]
    if missing:
        k = next(i for i, row in enumerate(g.nodes) if any(int(a) in missing for a in row))
        raise InputError(f"{g.where[k]}: node(s) {missing[:8]} are not defined in the node table")
    return np.array([self.nodes[int(a)] for a in g.nodes.ravel()]).reshape(*g.nodes.shape, 3)

def element_terms(self, g: ElementGroup, xa=None, xb=None, nodes=None) -> el.ElementTerms:
    """The element terms of a group (its element type's stacks); ``xa``, ``xb``: a line group's
    end points when they are not its nodes (offset ends); ``nodes``: :func:`node_table`, to look
    the coordinates up in."""
    n_el = len(g.labels)
    if g.type == "spring":
        return el.spring_terms(n_el, grounded=len(g.labels[0]) == 1)
    if g.type == "mass":
        return el.mass_terms(n_el, len(g.labels[0]))
    if g.type == "point_mass":
        assert g.data is not None  # the offset and inertia of each point mass
        return point_mass_terms(g.data, len(g.labels[0]))
    if xa is None:
        xyz = _coords(self, g, nodes)
        xa, xb = xyz[:, 0], xyz[:, -1]
    if g.data is not None and g.type in ("frame3d", "frame3d_terms"):  # rigid end offsets
        oa, ob = g.data[:, :3], g.data[:, 3:]
        return offset_terms(element_terms(self, replace(g, data=None), xa + oa, xb + ob), oa, ob)
    try:
        if g.type in SHELLS:
            return (e3.mitc4_terms if g.type == "mitc4" else e3.mitc3_terms)(xyz, g.nu, mass=g.mass, drill=g.drill)
        if g.type in SOLIDS:
            return {"hex8": e3.hex8_terms, "tet4": e3.tet4_terms, "tet10": e3.tet10_terms}[g.type](xyz, g.nu, mass=g.mass)
        if g.type == "rod":
            return el.rod_terms(xa, xb, dim=g.dim, mass=g.mass)
        if g.type == "beam2d":
            return el.beam2d_terms(xa, xb, mass=g.mass)
        if g.type == "beam2d_terms":
            return el.beam2d_physical_terms(xa, xb, mass=g.mass)
        if g.type == "frame3d":
            t = el.frame3d_terms(xa, xb, g.orientation, mass=g.mass)
            return t if g.torsion_mass else el.ElementTerms(K=t.K, M=[x for x in t.M if x[0] == ("rho", "A")])
        if g.type == "frame3d_terms":
            return el.frame3d_physical_terms(xa, xb, g.orientation, mass=g.mass)
    except InputError as exc:
        pos = getattr(exc, "positions", None) or [0]
        who = ", ".join(g.where[i] for i in pos[:8]) + (f" and {len(pos) - 8} more" if len(pos) > 8 else "")
        raise InputError(f"{who}: {exc}") from None
    raise InputError(f"{g.where[0]}: unknown element type {g.type!r}")

def resolve_property(self, g: ElementGroup, prop: str, pindex: dict) -> tuple[np.ndarray, np.ndarray]:
    """Per-element (numeric factor, parameter index or -1) of one property."""
    vals = g.props[prop]
    num = np.ones(len(vals))
    pid = np.full(len(vals), -1, dtype=np.int64)
    for i, v in enumerate(vals):
        if isinstance(v, str):
            if v not in pindex:
                declared = ", ".join(pindex) or "none"
                raise InputError(f"{g.where[i]}: property {prop} names parameter {v!r}, which is not declared in [parameters] (declared: {declared})")
            pid[i] = pindex[v]
            value = self.parameters[v].value
        else:
            try:
                value = float(v)
            except (TypeError, ValueError):
                raise InputError(f"{g.where[i]}: property {prop} must be a number or a parameter name, got {v!r}") from None
            num[i] = value
        if not math.isfinite(value):
            raise InputError(f"{g.where[i]}: property {prop} is not finite ({value!r})")
        if not value > 0:
            kind = "mass" if prop in ("m", "rho") else "property"
            raise InputError(f"{g.where[i]}: non-positive {kind} {prop} = {value:g}" + (f" (parameter {v!r})" if isinstance(v, str) else ""))
        if value < 1 / MAX_MAGNITUDE:
            raise InputError(f"{g.where[i]}: property {prop} = {value:g} is below {1 / MAX_MAGNITUDE:g}, too small to "
                             "compute with" + (f" (parameter {v!r})" if isinstance(v, str) else ""))
    return num, pid

def combine_factors(self, g: ElementGroup, factors, resolved, signatures: dict, L: int) -> tuple[np.ndarray, np.ndarray]:
    """Per element, the numeric coefficient of a term and its owner: -1 (no parameter, K0), j
    (parameter j to the first power, the affine dK[j]) or an id from ``signatures`` (a product
    of parameter powers such as E·t³, a non-linear :class:`~femupdate.coefficients.Term`;
    ``signatures`` is updated in place)."""
    n_el = len(g.labels)
    coef = np.ones(n_el)
    P = np.full((n_el, max(len(factors), 1)), -1, dtype=np.int64)
    for c, f in enumerate(factors):
        num, p = resolved[f]
        coef = coef * num
        P[:, c] = p
    P.sort(axis=1)
    rows, inverse = np.unique(P, axis=0, return_inverse=True)
    owner_of_row = np.empty(len(rows), dtype=np.int64)
    for r, row in enumerate(rows):
        ids, counts = np.unique(row[row >= 0], return_counts=True)
        sig = tuple((int(a), int(b)) for a, b in zip(ids, counts))
        if not sig:
            owner_of_row[r] = -1
        elif len(sig) == 1 and sig[0][1] == 1:
            owner_of_row[r] = sig[0][0]
        else:
            owner_of_row[r] = signatures.setdefault(sig, L + len(signatures))
    return coef, owner_of_row[np.asarray(inverse).ravel()]


__all__ = ["assemble", "element_terms", "resolve_property", "combine_factors"]
