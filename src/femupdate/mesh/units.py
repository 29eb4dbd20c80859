"""A mesh's declared consistent unit system and the plausibility of its values.

A mesh (the model file's ``[mesh]`` table, :meth:`Structure.from_mesh`) is in one consistent
system: ``"m-kg-s"`` (SI: N, m, kg, s; E in Pa, rho in kg/m³) or ``"mm-t-s"`` (N, mm, tonne, s; E
in MPa, rho in t/mm³).  Both give stiffness over mass in 1/s², so frequencies are in Hz either way;
femupdate converts nothing, the declaration names the parameters' units and lets femupdate refuse
a modulus or density whose magnitude belongs to the other system (docs/file-formats.md, "Units").
"""

from __future__ import annotations

from .._errors import InputError

#: the consistent systems: {name: (factor from SI for E and G, factor from SI for rho, E unit, rho unit)}
SYSTEMS = {"m-kg-s": (1.0, 1.0, "Pa", "kg/m³"), "mm-t-s": (1e-6, 1e-12, "MPa", "t/mm³")}
#: physically possible magnitudes in SI: densities 1e-3 to 1e6 kg/m³, moduli at most 1e13 Pa
RHO_SI = (1e-3, 1e6)
E_MAX_SI = 1e13
_KINDS = {"E": "modulus", "G": "shear modulus", "rho": "density"}


def system_of(units, where: str) -> str:
    """The declared system, refused naming the allowed ones."""
    if units not in SYSTEMS:
        raise InputError(f"{where}: units = {units!r} is not a consistent unit system femupdate knows (allowed: "
                         f"{', '.join(repr(k) for k in SYSTEMS)})")
    return units


def _fits(prop: str, value: float, system: str) -> bool:
    f_e, f_rho = SYSTEMS[system][:2]
    if prop == "rho":
        return RHO_SI[0] * f_rho <= value <= RHO_SI[1] * f_rho
    return value <= E_MAX_SI * f_e


def check_value(prop: str, value, system: str, where: str) -> None:
    """Refuse a number ``value`` of ``prop`` (E, G or rho) that cannot be in ``system``, naming the
    value, the system and what it would be in the declared system if written in the other."""
    if prop not in _KINDS or isinstance(value, (str, bool)) or not isinstance(value, (int, float)) or value <= 0:
        return
    if _fits(prop, float(value), system):
        return
    unit = SYSTEMS[system][3 if prop == "rho" else 2]
    hint = ""
    for other, (f_e, f_rho, e_unit, rho_unit) in SYSTEMS.items():
        if other != system and _fits(prop, float(value), other):
            ratio = (SYSTEMS[system][1] / f_rho) if prop == "rho" else (SYSTEMS[system][0] / f_e)
            other_unit = rho_unit if prop == "rho" else e_unit
            hint = (f"; read as {other_unit} ({other}) it would be {float(value) * ratio:.6g} {unit}: convert it, or "
                    f"declare units = \"{other}\"")
            break
    raise InputError(f"{where}: {prop} = {value:g} is not a plausible {_KINDS[prop]} in {unit} (the declared units "
                     f"{system}){hint}; or set check_units = false")


def check_parameters(s) -> None:
    """At build: refuse a parameter standing for a mesh's E, G or rho whose value contradicts the
    mesh's declared units (``s.unit_checks``: (parameter, property, where) recorded by the mesh)."""
    for name, prop, where in getattr(s, "unit_checks", ()):
        par = s.parameters.get(name)
        if par is not None:
            check_value(prop, par.value, s.units, f"{where}: parameter {name!r} ({prop})")


__all__ = ["SYSTEMS", "check_parameters", "check_value", "system_of"]
