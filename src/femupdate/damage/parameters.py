"""The unknowns of damage detection: the model's own stiffness parameters, or one per element.

* :func:`damage_unknowns` — the model and its unknowns as the user asked: ``"parameters"`` (the
  model's stiffness parameters as it names them: a group of elements sharing a parameter is one
  unknown), ``"elements"`` (one stiffness per element, :func:`element_parameters`) or
  ``"auto"`` (the parameters, unless the model has fewer than two stiffness parameters — one
  unknown cannot say where the damage is — then the elements), with a description of each
  unknown that names its elements.
* :func:`element_parameters` turns a :class:`~femupdate.Structure` into one whose every element
  has its own stiffness parameter (the stiffness modulus: ``k`` of a spring, ``E`` of a rod,
  beam or frame), at its validated value.
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from dataclasses import dataclass, field

from .._errors import InputError
from ..dofs import parse_dof
from ..model import Model
from ..structure import Structure

MODULUS = {"spring": "k", "rod": "E", "beam2d": "E", "frame3d": "E",
           **{t: "E" for t in ("mitc4", "mitc3", "hex8", "tet4", "tet10")}}  # every stiffness term of these ∝ E
UNKNOWNS = ("auto", "parameters", "elements")


def _resolve(structure: Structure, v, values: Mapping) -> float:
    if isinstance(v, str):
        return float(values.get(v, structure.parameters[v].value))
    return float(v)


def _element_name(prop: str, g, i: int) -> str:
    if g.nodes is not None:
        return f"{prop}." + "-".join(str(int(x)) for x in g.nodes[i])
    return f"{prop}." + "-".join(lab.replace(":", "") for lab in g.labels[i])


def _connection(g, i: int) -> str:
    """The element's type and what it joins: ``spring 4:x-5:x``, ``rod 102-103``."""
    if g.nodes is not None:
        return f"{g.type} " + "-".join(str(int(x)) for x in g.nodes[i])
    return f"{g.type} " + "-".join(g.labels[i]) + (" (to ground)" if len(g.labels[i]) == 1 and g.type == "spring" else "")


def _plural(kind: str, n: int) -> str:
    return kind if n == 1 else kind + ("es" if kind.endswith("s") else "s")


def parameter_descriptions(structure: Structure, names) -> dict[str, str]:
    """What each named parameter of ``structure`` scales: ``spring 4:x-5:x`` for a parameter of one
    element, ``2 springs: 1:x-2:x, 3:x-4:x`` or ``14 rods`` for a group.

    Parameters
    ----------
    structure : Structure
    names : iterable of str
        Parameter names.

    Returns
    -------
    dict of str to str
        {name: description}; a parameter no element uses is described as ``"no element"``.
    """
    used: dict[str, list[tuple[str, str]]] = {n: [] for n in names}
    for g in structure.groups:
        for prop, vals in g.props.items():
            for i, v in enumerate(vals):
                if isinstance(v, str) and v in used:
                    used[v].append((g.type, _connection(g, i) + ("" if prop in ("k", "E") else f" ({prop})")))
    out = {}
    for n, els in used.items():
        if not els:
            out[n] = "no element"
        elif len(els) == 1:
            out[n] = els[0][1]
        else:
            kinds: dict[str, int] = {}
            for t, _ in els:
                kinds[t] = kinds.get(t, 0) + 1
            head = ", ".join(f"{c} {_plural(t, c)}" for t, c in kinds.items())
            out[n] = head + (": " + ", ".join(c.split(" ", 1)[1] for _, c in els) if len(els) <= 3 else "")
    return out


@dataclass(frozen=True, eq=False)
class DamageUnknowns:
    """The model damage detection works on and its unknowns (:func:`damage_unknowns`).

    Attributes
    ----------
    model : Model
        The baseline model (the structure's own, or one stiffness parameter per element).
    kind : str
        ``"parameters"`` or ``"elements"``.
    names : list of str
        The unknowns: the model's free stiffness parameters (those entering K only).
    descriptions : dict
        {unknown: what it scales, e.g. ``spring 4:x-5:x`` or ``rod 102-103, model parameter E``}.
    notes : list of str
        Why the kind was chosen, parameters left out (those entering M).
    """

    model: Model
    kind: str
    names: list[str]
    descriptions: dict[str, str]
    notes: list[str] = field(default_factory=list)


def enters_mass(model: Model, j: int) -> bool:
    """Whether parameter ``j`` enters the mass matrix: linearly, or through a non-linear term (a shell
    thickness: ρ t)."""
    name = model.parameter_names[j]
    return model.dM[j] is not None or any(t.M is not None and name in t.parameters for t in model.terms)


def mass_refusal(model: Model, names) -> None:
    """Refuse unknowns that enter the mass matrix, naming them and what to do."""
    pos = {n: j for j, n in enumerate(model.parameter_names)}
    bad = [n for n in names if n in pos and enters_mass(model, pos[n])]
    if bad:
        raise InputError(f"damage detection parameters must be stiffness parameters; {', '.join(bad[:5])} "
                         f"enter{'s' if len(bad) == 1 else ''} the mass matrix too (a density, or a shell thickness: "
                         "rho t): leave them out of the unknowns (--elements; they stay known at their baseline "
                         "values), or make the set's modulus E a parameter and locate the loss of stiffness")


def stiffness_unknowns(model: Model) -> tuple[list[str], list[str]]:
    """(free parameters entering K only, free parameters entering M) of ``model``."""
    k_only: list[str] = []
    in_m: list[str] = []
    for j in model.free:
        name = model.parameter_names[j]
        (in_m if enters_mass(model, int(j)) else k_only).append(name)
    return k_only, in_m


def damage_unknowns(structure: Structure, values: Mapping | None = None, unknowns: str = "auto") -> DamageUnknowns:
    """The baseline model and the unknowns of damage detection, as the user asked for them.

    Parameters
    ----------
    structure : Structure
        The validated baseline.
    values : mapping of str to float, optional
        ``{parameter: value}`` overriding the structure's parameter values (e.g. updated ones).
    unknowns : {"auto", "parameters", "elements"}, default ``"auto"``
        ``"parameters"``: the structure's free stiffness parameters as it names them (elements
        sharing a parameter change together: one unknown; elements with a numeric stiffness and
        parameters entering the mass matrix stay known).  ``"elements"``: one stiffness per
        element (:func:`element_parameters`).  ``"auto"``: the parameters, unless fewer than two
        of them enter the stiffness matrix (one unknown cannot locate anything), then the
        elements; a note says which.

    Returns
    -------
    DamageUnknowns

    Raises
    ------
    InputError
        An unknown ``unknowns``; as :func:`element_parameters` and :meth:`Structure.build`;
        ``"parameters"`` with no free stiffness parameter.
    """
    if unknowns not in UNKNOWNS:
        raise InputError(f"unknowns must be one of {', '.join(UNKNOWNS)}, got {unknowns!r}")
    values = dict(values or {})
    notes: list[str] = []
    if unknowns in ("auto", "parameters"):
        model = structure.build()
        if values:
            model = model.with_values(values)
        k_only, in_m = stiffness_unknowns(model)
        if in_m:
            notes.append(f"parameter(s) entering the mass matrix stay known: {', '.join(in_m)}")
        if unknowns == "parameters" or len(k_only) >= 2:
            if not k_only:
                raise InputError(f"structure {structure.name!r} has no free stiffness parameter to take as a damage "
                                 "unknown; use unknowns='elements' (--unknowns elements) for one stiffness per element")
            desc = parameter_descriptions(structure, k_only)
            return DamageUnknowns(model, "parameters", k_only, desc, notes)
        if k_only:
            notes = [f"the model has one stiffness parameter ({k_only[0]}): one unknown cannot say where damage is, so "
                     "each element's stiffness is an unknown (--unknowns parameters to keep the model's parameter)"]
        else:
            notes = ["the model has no free stiffness parameter: each element's stiffness is an unknown"]
    es, described = element_parameters(structure, values)
    model = es.build()
    names = [n for n in stiffness_unknowns(model)[0] if n in described]
    return DamageUnknowns(model, "elements", names, {n: described[n] for n in names}, notes)


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
        if g.type == "point_mass":
            for i in range(n_el):
                assert g.data is not None
                out.point_mass(parse_dof(g.labels[i][0])[0], props["m"][i], offset=g.data[i, :3].tolist(),
                               inertia=g.data[i, 3:].reshape(3, 3), where=g.where[i])
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
            orig = g.props[prop][i]
            where = g.where[i]
            where = where[:-len(f" ({g.type})")] if where.endswith(f" ({g.type})") else where
            numbered = re.search(r"element #\d+$", where)  # a model file's element: its number, not the file's name
            where = numbered.group(0) if numbered else where
            described[nm] = f"{where} ({_connection(g, i)})" + (f", model parameter {orig}" if isinstance(orig, str) else "")
            names.append(nm)
        props[prop] = names
        if g.type == "spring":
            for i in range(n_el):
                out.spring(g.labels[i], k=names[i], where=g.where[i])
        elif g.type == "rod":
            out.rod(g.nodes, dim=g.dim, mass=g.mass, where=g.where[0], **props)
        elif g.type == "beam2d":
            out.beam2d(g.nodes, mass=g.mass, where=g.where[0], **props)
        elif g.type in ("mitc4", "mitc3"):
            out.shell(g.nodes, nu=g.nu, drill=g.drill, mass=g.mass, where=g.where[0], **props)
        elif g.type in ("hex8", "tet4", "tet10"):
            out.solid(g.nodes, nu=g.nu, mass=g.mass, where=g.where[0], **props)
        else:
            out.frame3d(g.nodes, orientation=g.orientation, mass=g.mass, where=g.where[0], torsion_mass=g.torsion_mass,
                        offsets=None if g.data is None else g.data.reshape(-1, 2, 3), **props)
    out.constraints = list(structure.constraints)  # rigid links and ties, as they were
    out.supports = list(structure.supports)
    out.support_nodes = list(structure.support_nodes)
    return out, described
