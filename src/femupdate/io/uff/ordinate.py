"""What the ordinate of a dataset 58 record holds, from the fields the file writes for it.

A function-type-4 record (an FRF) stores its values as record 7 field 1 says — real (2, 4) or
complex (5, 6; real and imaginary parts) — with the ordinate's specific data type (record 9
field 1: 8 displacement, 11 velocity, 12 acceleration, 0/1 unknown/general), its axis label
(record 9 field 5) and its units label (record 9 field 6), and the denominator's units label
(record 10 field 6).  femupdate reads linear FRFs: receptance, mobility or accelerance.

* A label that says decibels (``dB``: 20 log10|H|), a logarithm (``log``), a phase (``phase``,
  ``deg``, ``°``), a magnitude (``magnitude``, ``mag``, ``abs``, ``amplitude``), or a real or an
  imaginary part alone, is refused by name: those values are not the FRF (a magnitude or a
  logarithm has lost the phase, and a decibel value its reference), and read as one they give a
  wrong answer without a word.
* A units label that names a linear FRF unit — a length (m, mm, cm, µm, in, ft) or ``g``, per
  second or per second squared, per force (N, kN, mN, lbf) — is converted to SI: it states the
  record's units more precisely than dataset 164 (whose factors are then not applied to the
  record's ordinate), and it decides receptance, mobility or accelerance when the specific data
  type is unknown or general (0, 1); a label that contradicts the specific data type is refused.
* Any other label (``NONE``, blank, a name) leaves the record to its specific data type and
  dataset 164, as before; a label that is not ``NONE`` is named in a note.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from ..._errors import InputError

#: standard gravity, m/s² (an accelerance in g/N)
G_N = 9.80665
_LENGTH = {"m": 1.0, "mm": 1e-3, "cm": 1e-2, "um": 1e-6, "µm": 1e-6, "μm": 1e-6, "in": 0.0254, "ft": 0.3048}
_FORCE = {"N": 1.0, "kN": 1e3, "mN": 1e-3, "lbf": 4.4482216152605, "lb": 4.4482216152605}
_KINDS = {8: "displacement", 11: "velocity", 12: "acceleration"}
_FRF = {"displacement": "a receptance", "velocity": "a mobility", "acceleration": "an accelerance"}

# (pattern on the lower-case label, what the values then are)
_NOT_AN_FRF = (
    (re.compile(r"(mag|amp|abs).*(phase|angle|deg)"), "magnitude and phase pairs (universal files store complex "
                                                       "values as real and imaginary parts)"),
    (re.compile(r"(?<![a-z])db(?![a-z])|decibel"), "decibels (20 log10|H|): the phase and the reference are lost"),
    (re.compile(r"(?<![a-z])(log|ln)(?![a-z])|log10|logarithm"), "a logarithm of the magnitude: the phase is lost"),
    (re.compile(r"phase|angle|(?<![a-z])(deg|degrees?|°)(?![a-z])"), "a phase, not an FRF"),
    (re.compile(r"magnitude|(?<![a-z])(mag|abs|amplitude|modulus)(?![a-z])|\|h\|"),
     "a magnitude: the phase is lost"),
    (re.compile(r"imag|(?<![a-z])(im|quad|quadrature)(?![a-z])"), "an imaginary part alone: the real part is not here"),
    (re.compile(r"(?<![a-z])(real|re|co|coincident)(?![a-z])"), "a real part alone: the imaginary part is not here"),
)
_COMPLEX_PAIR = re.compile(r"^(real|re)[-_ /,&]*(and)?[-_ /,&]*(imag(inary)?|im)$|^complex$")
_NUMERATOR = re.compile(r"^(?:(?P<len>m|mm|cm|um|µm|μm|in|ft)(?:/s(?P<sq>\^?2|²|\*\*2)?)?|(?P<g>g))$")
_ROT_ONLY = re.compile(r"^(rad|radians?)$")


@dataclass(frozen=True)
class Ordinate:
    """How to read a record's ordinate: ``kind`` (``"displacement"``, ``"velocity"`` or
    ``"acceleration"``) and, when a units label gave it, ``factor`` (file values -> SI of that
    kind per newton); None: dataset 164's factors apply.  ``file_force``: the label named the
    numerator only, the force is in the file's units (dataset 164's force factor still applies).
    ``note``: what was decided, or None."""

    kind: str
    factor: float | None = None
    note: str | None = None
    file_force: bool = False


def _label(dset: dict, key: str) -> str:
    text = str(dset.get(key, "") or "").strip()
    return "" if text.upper() == "NONE" else text


def _unit(text: str) -> str:
    return re.sub(r"[\s()\[\]]", "", text)


def _ratio(units: str, denominator: str) -> tuple[str, float, bool] | None:
    """(kind, factor to SI, force in the file's units) of a units label such as ``mm/s^2/N``,
    ``g/N``, ``(m/s)/N``, ``m/s`` with ``N`` as the denominator's label (factors per newton), or a
    numerator alone, ``g`` or ``mm/s^2``, over the file's force unit; None when it is not one."""
    text = _unit(units)
    head, sep, force = text.rpartition("/")
    file_force = False
    if sep and force in _FORCE and _NUMERATOR.match(head):
        numerator, f = head, _FORCE[force]
    elif _NUMERATOR.match(text):
        numerator, f = text, _FORCE.get(_unit(denominator), 1.0)
        file_force = _unit(denominator) not in _FORCE
    else:
        return None
    m = _NUMERATOR.match(numerator)
    assert m is not None
    if m.group("g"):
        return "acceleration", G_N / f, file_force
    kind = "displacement" if "/s" not in numerator else ("acceleration" if m.group("sq") else "velocity")
    return kind, _LENGTH[m.group("len")] / f, file_force


def read_ordinate(dset: dict, where: str, complex_values: bool) -> Ordinate:
    """What the ordinate of dataset 58 record ``dset`` holds (see the module's description).

    Parameters
    ----------
    dset : dict
        pyuff's dict of the record.
    where : str
        ``"FILE: dataset 58 record K"``, for the messages.
    complex_values : bool
        The record holds complex values (record 7 field 1 = 5 or 6).

    Returns
    -------
    Ordinate

    Raises
    ------
    InputError
        A label that says the values are not a linear FRF (decibels, a logarithm, a phase, a
        magnitude, a real or imaginary part alone), a units label that contradicts the specific
        data type, or a specific data type that is not a motion — naming the record, the field and
        what it says.
    """
    spec = int(dset.get("ordinate_spec_data_type", 0))
    axis, units, denom = (_label(dset, k) for k in ("ordinate_axis_lab", "ordinate_axis_units_lab",
                                                    "orddenom_axis_units_lab"))
    stored = "complex (real and imaginary parts)" if complex_values else "real"
    for field_name, number, text in (("units label", 6, units), ("axis label", 5, axis)):
        low = text.lower()
        if not low or (complex_values and _COMPLEX_PAIR.match(_unit(low).replace("/", "-"))):
            continue
        angles = number == 6 and _ROT_ONLY.match(_unit(low))
        what = "angles (a phase, not an FRF)" if angles else next(
            (w for pattern, w in _NOT_AN_FRF if pattern.search(low)), None)
        if what is not None:
            raise InputError(
                f"{where}: ordinate {field_name} {text!r} (record 9, field {number}) says the {stored} values are "
                f"{what}; femupdate reads linear FRFs (receptance, mobility or accelerance, complex values as real "
                "and imaginary parts): export the FRF itself, not in decibels, magnitude/phase or parts")
    ratio = _ratio(units, denom) if units else None
    declared = _KINDS.get(spec)
    if spec not in (0, 1) and declared is None:
        raise InputError(f"{where}: ordinate specific data type {spec} (record 9, field 1) is not displacement (8), "
                         "velocity (11) or acceleration (12)")
    if ratio is None:
        note = (f"{where}: ordinate units label {units!r} (record 9, field 6) not recognised as an FRF unit: the values "
                f"are read as {_FRF[declared or 'displacement']} in the file's units (dataset 164, else SI)") if units else None
        return Ordinate(declared or "displacement", None, note)
    kind, factor, file_force = ratio
    if declared is not None and kind != declared:
        raise InputError(f"{where}: ordinate units label {units!r} (record 9, field 6) is {_FRF[kind]}, but the "
                         f"ordinate specific data type (record 9, field 1) is {spec} ({declared}): the record "
                         "contradicts itself; correct one of the two")
    per = "" if "/" in _unit(units) and not file_force else (" per the file's force unit" if file_force else
                                                             f" per {denom}")
    note = None if factor == 1.0 and declared else (
        f"{where}: ordinate in {units}{per} (its units label, record 9, field 6): read as {_FRF[kind]} and "
        "converted to SI" + (f" (x {factor:g})" if factor != 1.0 else ""))
    return Ordinate(kind, factor, note, file_force)


__all__ = ["Ordinate", "read_ordinate", "G_N"]
