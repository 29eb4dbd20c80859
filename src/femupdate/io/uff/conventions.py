"""Universal-file conventions shared by reading and writing: dataset numbers, direction codes,
unit systems and the specific data types of dataset 58."""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping

from ..._errors import InputError
from ...dofs import DIRECTIONS

NODE_SETS = (15, 2411)
SYSTEM_SETS = (18, 2420)
READ_SETS = frozenset((15, 18, 55, 58, 164, 2411, 2420))

#: Dataset 164 unit-system codes.
UNIT_SYSTEMS = {
    1: "SI",  # meter, newton
    2: "BG",  # foot, pound force
    3: "MG",  # meter, kilogram force
    4: "BA",  # foot, poundal
    5: "MM",  # millimeter, millinewton
    6: "CM",  # centimeter, centinewton
    7: "IN",  # inch, pound force
    8: "GM",  # millimeter, kilogram force
    9: "US",  # user defined
}

# Dataset 58 specific data types (records 8 to 10).
ABSCISSA_FREQUENCY = frozenset((0, 1, 18))  # unknown, general, frequency
ORD_DISPLACEMENT = frozenset((0, 1, 8))  # unknown, general, displacement -> receptance
ORD_VELOCITY = 11  # mobility
ORD_ACCELERATION = 12  # accelerance
DENOM_FORCE = frozenset((0, 1, 9, 13))  # unknown, general, reaction force, excitation force

AXIS_RTOL = 1e-5  # UFF abscissas are single precision (E13.5): equal axes agree to ~5e-6


def node_id(value, where: str) -> int:
    """``value`` as a node number (an integer of at most 10 digits); ``where`` names the record."""
    try:
        v = float(value)
    except (TypeError, ValueError, OverflowError):
        raise InputError(f"{where}: node number {str(value)[:20]!r} is not a number of at most 10 digits") from None
    if not math.isfinite(v) or v != int(v) or abs(v) > 2**31:
        raise InputError(f"{where}: node number {value!r} is not an integer (of at most 10 digits)")
    return int(v)


def check_nodes(used: Iterable[int], nodes: Mapping[int, object], where: str) -> None:
    """Every node of ``used`` is among ``nodes`` (the file's node datasets), when the file has any."""
    if not nodes:
        return
    unknown = sorted({int(n) for n in used} - set(nodes))
    if unknown:
        shown = ", ".join(str(n) for n in unknown[:8]) + (f" … ({len(unknown)} in all)" if len(unknown) > 8 else "")
        raise InputError(f"{where}: unknown node(s) {shown}: not in the file's node datasets (15/2411)")


def direction_of_code(code, where: str, node) -> tuple[str, float]:
    """UFF direction code -> (direction name, sign of the transducer).

    Parameters
    ----------
    code : int or str
        Direction code ±1..±6 (x, y, z, rx, ry, rz; negative: transducer reversed).
    where : str
        Location (file, dataset) for the message.
    node : int
        Node number, for the message.

    Returns
    -------
    direction : str
        ``"x"``, ``"y"``, ``"z"``, ``"rx"``, ``"ry"`` or ``"rz"``.
    sign : float
        +1.0 or −1.0.

    Raises
    ------
    InputError
        Code 0 (scalar), a code beyond ±6, or not an integer.
    """
    try:
        c = int(code)
    except (TypeError, ValueError):
        c = 0
    if c == 0 or abs(c) > 6:
        raise InputError(
            f"{where}: node {node}: direction code {code!r} is not one of ±1..±6 "
            "(x, y, z, rx, ry, rz); scalar (0) and other codes are not supported"
        )
    return DIRECTIONS[abs(c) - 1], (1.0 if c > 0 else -1.0)


def code_of_direction(direction: str) -> int:
    """Direction name (x .. rz) -> UFF direction code 1..6.

    Parameters
    ----------
    direction : str
        ``"x"``, ``"y"``, ``"z"``, ``"rx"``, ``"ry"`` or ``"rz"``.

    Returns
    -------
    int

    Raises
    ------
    ValueError
        Another name (from :meth:`tuple.index`).
    """
    return DIRECTIONS.index(direction) + 1


__all__ = ["node_id", "check_nodes", "NODE_SETS", "SYSTEM_SETS", "READ_SETS", "UNIT_SYSTEMS", "ABSCISSA_FREQUENCY", "ORD_DISPLACEMENT", "ORD_VELOCITY",
           "ORD_ACCELERATION", "DENOM_FORCE", "AXIS_RTOL", "direction_of_code", "code_of_direction"]
