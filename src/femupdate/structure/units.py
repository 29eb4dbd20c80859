"""Units of a structure's parameters, from the element properties they stand for.

femupdate converts no units in model files: the recommended set is SI (N, m, kg, s;
docs/file-formats.md, "Units").  A parameter's unit is therefore the unit of the property that
uses it in the structure's consistent unit system — SI by default (a spring's ``k`` N/m, a rod's
``E`` Pa, a beam's ``I`` m⁴), or the system a mesh declares (``units = "mm-t-s"``: N, mm, t, s, so
``E`` MPa, ``rho`` t/mm³, ``t`` mm) — and is stated in results so that tables and figure axes carry
it.  A parameter used by properties of different units, and the parameters of matrix models, have
no unit (``""``).
"""

from __future__ import annotations

from collections.abc import Iterable

from ..dofs import parse_dof

#: SI unit of each element property (springs and masses depend on their dofs: :func:`property_unit`)
PROPERTY_UNITS: dict[str, str] = {
    "E": "Pa", "G": "Pa", "A": "m²", "I": "m⁴", "Iy": "m⁴", "Iz": "m⁴", "J": "m⁴", "Ip": "m⁴",
    "rho": "kg/m³", "t": "m",
    "EA_l": "N/m", "GJ_l": "N·m/rad",
    "k12": "N/m", "k12_y": "N/m", "k12_z": "N/m",
    "k6": "N/rad", "k6_y": "N/rad", "k6_z": "N/rad",
    "k2": "N·m/rad", "k2_y": "N·m/rad", "k2_z": "N·m/rad",
}

#: the same in the consistent mm-t-s system (N, mm, tonne, s)
MM_T_S_UNITS: dict[str, str] = {
    "E": "MPa", "G": "MPa", "A": "mm²", "I": "mm⁴", "Iy": "mm⁴", "Iz": "mm⁴", "J": "mm⁴", "Ip": "mm⁴",
    "rho": "t/mm³", "t": "mm",
    "EA_l": "N/mm", "GJ_l": "N·mm/rad",
    "k12": "N/mm", "k12_y": "N/mm", "k12_z": "N/mm",
    "k6": "N/rad", "k6_y": "N/rad", "k6_z": "N/rad",
    "k2": "N·mm/rad", "k2_y": "N·mm/rad", "k2_z": "N·mm/rad",
}

#: each consistent unit system: its property units, spring and mass units (translation, rotation)
SYSTEMS: dict[str, tuple[dict[str, str], tuple[str, str], tuple[str, str]]] = {
    "m-kg-s": (PROPERTY_UNITS, ("N/m", "N·m/rad"), ("kg", "kg·m²")),
    "mm-t-s": (MM_T_S_UNITS, ("N/mm", "N·mm/rad"), ("t", "t·mm²")),
}

_ROTATIONS = frozenset({"rx", "ry", "rz"})


def property_unit(element_type: str, prop: str, labels: Iterable[str] = (), system: str = "m-kg-s") -> str:
    """The unit of one element property (SI unless ``system`` says otherwise).

    Parameters
    ----------
    element_type : str
        ``"spring"``, ``"mass"``, ``"rod"``, ``"beam2d"``, ... (:data:`~femupdate.structure.ELEMENT_TYPES`).
    prop : str
        The property, e.g. ``"k"``, ``"E"``, ``"k6_y"``.
    labels : iterable of str
        The element's dof labels: a spring's ``k`` is N/m on translations and N·m/rad on
        rotations, a mass's ``m`` kg or kg·m²; mixed, no unit.
    system : {"m-kg-s", "mm-t-s"}
        The structure's consistent unit system (:data:`SYSTEMS`).

    Returns
    -------
    str
        The unit, or ``""`` when it cannot be told.
    """
    table, spring, mass = SYSTEMS[system]
    if element_type in ("spring", "mass"):
        rot = {parse_dof(lab)[1] in _ROTATIONS for lab in labels}
        if len(rot) != 1:
            return ""
        return (spring if element_type == "spring" else mass)[int(rot.pop())]
    if element_type == "point_mass":
        return mass[0]
    return table.get(prop, "")


def parameter_units(groups, names: Iterable[str], system: str = "m-kg-s") -> dict[str, str]:
    """Each parameter's unit, from every element property that names it.

    Parameters
    ----------
    groups : sequence of ElementGroup
        The structure's element groups (:attr:`Structure.groups`).
    names : iterable of str
        The declared parameters.
    system : {"m-kg-s", "mm-t-s"}
        The structure's consistent unit system.

    Returns
    -------
    dict of str to str
        {name: unit}; ``""`` for a parameter whose properties disagree on their unit (e.g. a
        spring on a translation and on a rotation) or whose unit is unknown.
    """
    seen: dict[str, set[str]] = {n: set() for n in names}
    for g in groups:
        for prop, values in g.props.items():
            if g.type not in ("spring", "mass"):  # the unit does not depend on the element's dofs
                for v in set(values):
                    if isinstance(v, str) and v in seen:
                        seen[v].add(property_unit(g.type, prop, system=system))
                continue
            for i, v in enumerate(values):
                if isinstance(v, str) and v in seen:
                    seen[v].add(property_unit(g.type, prop, g.labels[i], system))
    return {n: (next(iter(u)) if len(u) == 1 else "") for n, u in seen.items()}
