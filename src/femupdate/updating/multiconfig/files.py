"""Modification and candidate files of multi-configuration updating (TOML or JSON, same schema).

Modification (one configuration's known changes; TOML shown, JSON has the same keys)::

    name = "1.5 kg at the tip"      # optional; default the file name
    [[mass]]                        # known lumped mass added on each listed dof
    dofs = ["2:x"]
    m = 1.5
    [[spring]]                      # known spring: one dof (to ground) or two (between them)
    dofs = ["1:x", "2:x"]
    k = 500.0
    [[support]]                     # dofs (or every dof of nodes) fixed in this configuration
    dofs = ["3:x"]
    nodes = [4]
    [values]                        # known (fixed) parameters that take other values here
    k_mount = 2.0e4

Candidates for pre-test ranking: the same tables under ``[[candidate]]`` (TOML:
``[[candidate]]`` with ``name``, then ``[[candidate.mass]]`` ...; JSON:
``{"candidates": [{"name": ..., "mass": [...]}, ...]}``).
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

from ..._errors import InputError
from ...io.tables import dof_labels, finite_number, list_of_tables, read_table_file
from .configurations import Modification

_MOD_KEYS = {"name", "mass", "spring", "support", "values"}


def modification_from_dict(raw, source: str = "modification", default_name: str = "modified") -> Modification:
    """A :class:`Modification` from the parsed file (schema in the module docstring).

    Parameters
    ----------
    raw : mapping
        The parsed table: ``name``, ``mass`` (``dofs``, ``m`` in kg), ``spring`` (``dofs``, ``k``
        in N/m), ``support`` (``dofs`` and/or ``nodes``) and ``values`` {parameter: value}.
    source : str, default ``"modification"``
        Where it came from, for messages.
    default_name : str, default ``"modified"``
        Name when ``raw`` gives none.

    Returns
    -------
    Modification

    Raises
    ------
    InputError
        Not a table; unknown keys; malformed entries; and as :class:`Modification`.
    """
    if not isinstance(raw, Mapping):
        raise InputError(f"{source}: expected a table / object")
    extra = sorted(set(raw) - _MOD_KEYS)
    if extra:
        raise InputError(f"{source}: unknown key(s) {', '.join(map(str, extra))} (allowed: {', '.join(sorted(_MOD_KEYS))})")
    name = raw.get("name", default_name)
    if not isinstance(name, str) or not name:
        raise InputError(f"{source}: name must be a non-empty string")
    masses, springs, supports, nodes = [], [], [], []
    for i, t in enumerate(list_of_tables(raw, "mass", source), start=1):
        where = f"{source}: mass #{i}"
        if set(t) != {"dofs", "m"}:
            raise InputError(f"{where}: needs exactly 'dofs' and 'm', got {', '.join(map(str, t)) or 'nothing'}")
        m = finite_number(t["m"], f"{where} m")
        masses += [(d, m) for d in dof_labels(t["dofs"], where)]
    for i, t in enumerate(list_of_tables(raw, "spring", source), start=1):
        where = f"{source}: spring #{i}"
        if set(t) != {"dofs", "k"}:
            raise InputError(f"{where}: needs exactly 'dofs' and 'k', got {', '.join(map(str, t)) or 'nothing'}")
        springs.append((tuple(dof_labels(t["dofs"], where)), finite_number(t["k"], f"{where} k")))
    for i, t in enumerate(list_of_tables(raw, "support", source), start=1):
        where = f"{source}: support #{i}"
        if not t or set(t) - {"dofs", "nodes"}:
            raise InputError(f"{where}: expected 'dofs' (labels) and/or 'nodes' (ids)")
        if "dofs" in t:
            supports += dof_labels(t["dofs"], where)
        if "nodes" in t:
            ids = t["nodes"]
            if not isinstance(ids, list) or not all(isinstance(x, (int, str)) and not isinstance(x, bool) for x in ids):
                raise InputError(f"{where}: nodes must be a list of node ids (integers, or names such as \"A2\"), got {ids!r}")
            nodes += ids
    values = raw.get("values", {})
    if not isinstance(values, Mapping):
        raise InputError(f"{source}: [values] must be a table {{parameter = value}}")
    values = {str(k): finite_number(v, f"{source}: values.{k}") for k, v in values.items()}
    try:
        return Modification(name, tuple(masses), tuple(springs), tuple(supports), tuple(nodes), values)
    except InputError as exc:
        raise InputError(f"{source}: {exc}") from None


def load_modification(path) -> Modification:
    """Read one configuration's modification (TOML or JSON).

    Parameters
    ----------
    path : str or os.PathLike
        A ``.toml`` or ``.json`` file; its stem is the default name.

    Returns
    -------
    Modification

    Raises
    ------
    InputError
        As :func:`~femupdate.io.tables.read_table_file` and :func:`modification_from_dict`.
    """
    path = Path(path)
    return modification_from_dict(read_table_file(path), str(path), default_name=path.stem)


def load_candidates(path) -> list[Modification]:
    """Read candidate modifications for :func:`~femupdate.updating.multiconfig.rank_modifications`.

    Parameters
    ----------
    path : str or os.PathLike
        A TOML file of ``[[candidate]]`` tables, or a JSON object ``{"candidates": [...]}``.

    Returns
    -------
    list of Modification
        In file order (default names ``"candidate i"``).

    Raises
    ------
    InputError
        Other top-level keys; no candidates; and as :func:`modification_from_dict`.
    """
    path = Path(path)
    raw = read_table_file(path)
    key = "candidate" if "candidate" in raw else "candidates"
    if not isinstance(raw, Mapping) or key not in raw or set(raw) != {key}:
        raise InputError(f"{path}: expected only [[candidate]] tables (TOML) or {{\"candidates\": [...]}} (JSON)")
    out = [modification_from_dict(t, f"{path}: candidate #{i}", default_name=f"candidate {i}")
           for i, t in enumerate(list_of_tables(raw, key, str(path)), start=1)]
    if not out:
        raise InputError(f"{path}: no candidates")
    return out


def split_config_spec(spec: str) -> tuple[Path, Path | None]:
    """``"DATA"`` or ``"DATA:MODIFICATION.toml"`` (the modification ends in .toml or .json).

    Parameters
    ----------
    spec : str
        The command-line specification of one configuration.

    Returns
    -------
    data : pathlib.Path
        The test-data file.
    modification : pathlib.Path or None
        The modification file, if given.
    """
    head, sep, tail = spec.rpartition(":")
    if sep and Path(tail).suffix.lower() in (".toml", ".json") and head:
        return Path(head), Path(tail)
    return Path(spec), None
