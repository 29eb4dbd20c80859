"""One stiffness parameter per element: the unknowns of damage detection.

:func:`element_parameters` turns a :class:`~femupdate.Structure` into one whose every element
has its own stiffness parameter (the stiffness modulus: ``k`` of a spring, ``E`` of a rod, beam
or frame), at its validated value.
"""

from __future__ import annotations

from collections.abc import Mapping

from .._errors import InputError
from ..dofs import parse_dof
from ..structure import Structure

MODULUS = {"spring": "k", "rod": "E", "beam2d": "E", "frame3d": "E"}


def _resolve(structure: Structure, v, values: Mapping) -> float:
    if isinstance(v, str):
        return float(values.get(v, structure.parameters[v].value))
    return float(v)


def _element_name(prop: str, g, i: int) -> str:
    if g.nodes is not None:
        a, b = (int(x) for x in g.nodes[i])
        return f"{prop}.{a}-{b}"
    return f"{prop}." + "-".join(lab.replace(":", "") for lab in g.labels[i])


def element_parameters(structure: Structure, values: Mapping | None = None, bounds: tuple[float, float] = (0.0, 2.0),
                       name: str | None = None) -> tuple[Structure, dict[str, str]]:
    """A copy of ``structure`` with one stiffness parameter per element, at its validated value.

    Every property is resolved to its value (``values`` overrides the structure's parameters, e.g.
    with updated ones); then each spring's ``k`` and each rod's, beam's or frame's ``E`` becomes
    a parameter of its own, named after the element (``E.4-5`` for the element between nodes 4
    and 5, ``k.1x-2x`` for a spring between 1:x and 2:x; a suffix ``.2``, ``.3`` separates
    elements between the same nodes).  Masses stay known.

    Parameters
    ----------
    structure : Structure
        The validated baseline (not modified).
    values : mapping of str to float, optional
        ``{parameter: value}`` overriding the structure's parameter values.
    bounds : (float, float), default (0.0, 2.0)
        The new parameters' bounds relative to their values, ``0 <= lower < 1 < upper``.
    name : str, optional
        Name of the new structure (default ``"<name> (element stiffnesses)"``).

    Returns
    -------
    (Structure, dict)
        The new structure and {parameter: description of its element}.

    Raises
    ------
    InputError
        Physical-term elements (``beam2d_terms``, ``frame3d_terms``): they have several stiffness
        terms, so one parameter cannot scale the element; an unknown parameter in ``values``;
        ``bounds`` outside ``0 <= lower < 1 < upper``.
    """
    values = dict(values or {})
    for k in values:
        if k not in structure.parameters:
            raise InputError(f"values: parameter {k!r} is not in the structure (its parameters: {', '.join(structure.parameters) or 'none'})")
    lo, hi = bounds
    if not 0 <= lo < 1 < hi:
        raise InputError(f"bounds {bounds!r} must satisfy 0 <= lower < 1 < upper (relative to the element's value)")
    out = Structure(name or f"{structure.name} (element stiffnesses)")
    ids = list(structure.nodes)
    if ids:
        out.add_nodes(ids, [structure.nodes[i] for i in ids])
    used: dict[str, int] = {}
    described: dict[str, str] = {}
    sup_nodes = set(structure.support_nodes)
    fixed = set(structure.supports)

    def supported(labels) -> bool:  # an element with no free dof carries no information
        return all(lab in fixed or parse_dof(lab)[0] in sup_nodes for lab in labels)

    for g in structure.groups:
        n_el = len(g.labels)
        props: dict[str, list] = {k: [_resolve(structure, v, values) for v in vs] for k, vs in g.props.items()}
        if g.type == "mass":
            for i in range(n_el):
                out.mass(g.labels[i], m=props["m"][i], where=g.where[i])
            continue
        if g.type not in MODULUS:
            raise InputError(f"{g.where[0]}: damage detection gives each element one stiffness parameter (k or E); "
                             f"a {g.type} element has several stiffness terms: build the baseline with "
                             f"{'beam2d' if g.type.startswith('beam') else 'frame3d'} elements")
        prop = MODULUS[g.type]
        names: list[float | str] = []
        for i in range(n_el):
            if supported(g.labels[i]):
                names.append(props[prop][i])
                continue
            base = _element_name(prop, g, i)
            k = used.get(base, 0) + 1
            used[base] = k
            nm = base if k == 1 else f"{base}.{k}"
            v = props[prop][i]
            out.parameter(nm, v, bounds=(lo * v, hi * v))
            described[nm] = g.where[i]
            names.append(nm)
        props[prop] = names
        if g.type == "spring":
            for i in range(n_el):
                out.spring(g.labels[i], k=names[i], where=g.where[i])
        elif g.type == "rod":
            out.rod(g.nodes, dim=g.dim, mass=g.mass, where=g.where[0], **props)
        elif g.type == "beam2d":
            out.beam2d(g.nodes, mass=g.mass, where=g.where[0], **props)
        else:
            out.frame3d(g.nodes, orientation=g.orientation, mass=g.mass, where=g.where[0], **props)
    out.supports = list(structure.supports)
    out.support_nodes = list(structure.support_nodes)
    return out, described
