"""Reading the small TOML-or-JSON input files (modifications, candidates, scans): shared checks."""

from __future__ import annotations

import math
from pathlib import Path

from .._errors import InputError
from ..structure.tables import list_of_tables
from .model_file import read_toml
from .numbers import load_json_file
from .outputs import note_input


def read_table_file(path) -> dict:
    """The parsed contents of a ``.toml`` or ``.json`` file (an :class:`InputError` naming the file
    when it is missing, unreadable or malformed).

    Parameters
    ----------
    path : str or os.PathLike
        A ``.toml`` or ``.json`` file.

    Returns
    -------
    dict
        The parsed contents (for JSON, whatever the top-level value is).

    Raises
    ------
    InputError
        Another suffix; a missing, unreadable or malformed file.
    """
    path = Path(path)
    if path.suffix.lower() == ".toml":
        return read_toml(path)
    note_input(path, "a JSON file")
    if path.suffix.lower() != ".json":
        raise InputError(f"{path}: expected a .toml or .json file")
    data = load_json_file(path)
    if not isinstance(data, dict):
        raise InputError(f"{path}: expected a JSON object (a table of keys), got a JSON {type(data).__name__}")
    return data


def dof_labels(v, where: str) -> list[str]:
    """A dof label or a non-empty list of them.

    Parameters
    ----------
    v : str or list of str
        The value read from the file.
    where : str
        Location for the message.

    Returns
    -------
    list of str
        The labels as given (not yet canonical).

    Raises
    ------
    InputError
        Not a string or a non-empty list of strings.
    """
    if isinstance(v, str):
        v = [v]
    if not isinstance(v, list) or not v or not all(isinstance(x, str) for x in v):
        raise InputError(f"{where}: dofs must be a list of dof labels such as [\"3:x\"], got {v!r}")
    return v


def finite_number(v, where: str) -> float:
    """A finite int or float (not a bool) as a float.

    Parameters
    ----------
    v : object
        The value read from the file.
    where : str
        Location for the message.

    Returns
    -------
    float

    Raises
    ------
    InputError
        A bool, a non-number, or a non-finite number.
    """
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
        raise InputError(f"{where}: expected a finite number, got {v!r}")
    return float(v)


__all__ = ["read_table_file", "list_of_tables", "dof_labels", "finite_number"]
