"""The dict / TOML form of a structure (schema in docs/file-formats.md): parameters, nodes,
elements and supports read into a :class:`~femupdate.structure.Structure`."""

from __future__ import annotations

from collections.abc import Mapping

from .._errors import InputError
from ..model import _shown
from ..priors import Prior, parse_prior
from .groups import BENDING, ELEMENT_TYPES, PROPS, SHELLS, SOLIDS


def structure_from_dict(cls, data: Mapping, source: str = "model"):
    """An instance of ``cls`` (:class:`~femupdate.structure.Structure`) from the parsed TOML model file.

    Parameters
    ----------
    cls : type
        :class:`~femupdate.structure.Structure` or a subclass; called with the model name.
    data : mapping
        The parsed file: top-level keys ``model``, ``parameters``, ``node``, ``element``, ``support``,
        ``mesh`` (docs/file-formats.md).
    source : str, default "model"
        Name of the file, prefixed to error messages; a ``[mesh]`` table's file is relative to its folder.

    Returns
    -------
    Structure
        Not yet built.

    Raises
    ------
    InputError
        An unknown key, a missing or mistyped entry, or anything the Structure methods refuse; the
        message names the table (e.g. ``element #3 (rod)``).
    """
    if not isinstance(data, Mapping):
        raise InputError(f"{source}: expected a table at the top level")
    known = {"model", "parameters", "node", "element", "support", "provenance", "mesh", "constraint"}
    extra = sorted(set(data) - known)
    if extra:
        raise InputError(f"{source}: unknown top-level key(s) {', '.join(extra)} (expected {', '.join(sorted(known))})")
    if not isinstance(data.get("provenance", {}), Mapping):
        raise InputError(f"{source}: [provenance] must be a table (it records where an updated model came from)")
    meta = data.get("model", {})
    s = cls(str(meta.get("name", "model")) if isinstance(meta, Mapping) else "model")
    params = data.get("parameters", {})
    if not isinstance(params, Mapping):
        raise InputError(f"{source}: [parameters] must be a table of tables ([parameters.k1] value = ...)")
    for name, spec in params.items():
        where = f"{source}: [parameters.{name}]"
        if not isinstance(spec, Mapping):
            raise InputError(f"{where} must be a table with at least 'value'")
        unknown = sorted(set(spec) - {"value", "bounds", "fixed", "prior", "card"})
        if unknown:
            raise InputError(f"{where}: unknown key(s) {', '.join(unknown)} (allowed: value, bounds, fixed, prior, card)")
        if "value" not in spec:
            raise InputError(f"{where} has no 'value'")
        prior = _prior(spec, f"{where} prior")  # its message names the file and table already
        try:
            s.parameter(name, spec["value"], spec.get("bounds"), spec.get("fixed", False), prior)
        except InputError as exc:
            raise InputError(f"{source}: {exc}") from None
    for i, nd in enumerate(list_of_tables(data, "node", source), start=1):
        where = f"{source}: node #{i}"
        if "id" not in nd or "xyz" not in nd:
            raise InputError(f"{where} needs 'id' and 'xyz'")
        unknown = sorted(set(nd) - {"id", "xyz"})
        if unknown:
            raise InputError(f"{where}: unknown key(s) {', '.join(map(str, unknown))} (allowed: id, xyz)")
        node_id = nd["id"]
        if isinstance(node_id, bool) or not isinstance(node_id, (int, float)) or not float(node_id).is_integer():
            raise InputError(f"{where}: id must be an integer, got {node_id!r}")
        _no_booleans(nd["xyz"], f"{where}: xyz")
        try:
            s.node(int(node_id), nd["xyz"])
        except InputError as exc:  # before ValueError: InputError is a ValueError
            raise InputError(f"{where}: {exc}") from None
        except (TypeError, ValueError):
            raise InputError(f"{where}: xyz must be 2 or 3 numbers, got {nd['xyz']!r}") from None
    if "mesh" in data:  # a mesh file: its nodes, elements by set and supports (femupdate.mesh.model)
        from ..mesh.model import mesh_from_table

        mesh_from_table(s, data["mesh"], source)
    for i, e in enumerate(list_of_tables(data, "element", source), start=1):
        element_from_dict(s, e, f"{source}: element #{i}")
    for i, c in enumerate(list_of_tables(data, "constraint", source), start=1):
        constraint_from_dict(s, c, f"{source}: constraint #{i}")
    for i, sup in enumerate(list_of_tables(data, "support", source), start=1):
        where = f"{source}: support #{i}"
        unknown = sorted(set(sup) - {"dofs", "nodes"})
        if unknown or not sup:
            raise InputError(f"{where}: expected 'dofs' (labels) and/or 'nodes' (ids)")
        _no_booleans(sup.get("nodes"), f"{where}: nodes")
        try:
            if "dofs" in sup:
                s.support(list(sup["dofs"]))
            if "nodes" in sup:
                s.support_node(list(sup["nodes"]))
        except (TypeError, ValueError, OverflowError) as exc:
            raise InputError(f"{where}: {exc}") from None
    return s


def _no_booleans(v, where: str) -> None:
    """Refuse TOML booleans in a numeric field (Python reads true as 1, false as 0)."""
    if isinstance(v, bool) or (isinstance(v, list) and any(isinstance(x, bool) or (isinstance(x, list) and any(
            isinstance(y, bool) for y in x)) for x in v)):
        raise InputError(f"{where} must be {'numbers' if isinstance(v, list) else 'a number'}, got {_shown(v)}")


def list_of_tables(data, key, source):
    """The array of tables ``data[key]`` (a single table counts as an array of one).

    Parameters
    ----------
    data : mapping
        The parsed file.
    key : str
        Key of the array of tables (``"node"``, ``"element"``, ``"support"``).
    source : str
        Name of the file, for the error message.

    Returns
    -------
    list of mapping
        Empty when ``key`` is absent.

    Raises
    ------
    InputError
        ``data[key]`` is neither a table nor a list of tables.
    """
    items = data.get(key, [])
    if isinstance(items, Mapping):
        items = [items]
    if not isinstance(items, list) or not all(isinstance(x, Mapping) for x in items):
        raise InputError(f"{source}: '{key}' must be an array of tables ([[{key}]])")
    return items


ELEMENT_KEYS = {"type", "dofs", "nodes", "mass", "dim", "orientation", "nu", "drill", "offsets", "node", "offset", "inertia"}
TYPE_KEYS = {  # non-property keys that apply to each line-element type
    "rod": {"nodes", "mass", "dim"},
    "beam2d": {"nodes", "mass"},
    "beam2d_terms": {"nodes", "mass"},
    "frame3d": {"nodes", "mass", "orientation", "offsets"},
    "frame3d_terms": {"nodes", "mass", "orientation", "offsets"},
    "point_mass": {"node", "offset", "inertia"},
    **{t: {"nodes", "mass", "nu", "drill"} for t in SHELLS},
    **{t: {"nodes", "mass", "nu"} for t in SOLIDS},
}


def element_from_dict(s, e: Mapping, where: str) -> None:
    """Add one [[element]] table to the structure ``s``.

    Parameters
    ----------
    s : Structure
        Structure to add to.
    e : mapping
        The table: ``type`` and the keys of that type (docs/file-formats.md).
    where : str
        The table's position, prefixed to error messages.

    Raises
    ------
    InputError
        An unknown type or key, a property that is neither a number nor a name, a missing
        required key, or anything the Structure method refuses.
    """
    t = e.get("type")
    if not isinstance(t, str) or t not in PROPS:
        raise InputError(f"{where}: unknown element type {t!r} (known: {', '.join(ELEMENT_TYPES)})")
    where = f"{where} ({t})"
    if t in ("spring", "mass"):
        allowed = {"type", "dofs", PROPS[t][0][0]}
    else:
        allowed = {"type"} | TYPE_KEYS[t] | set(PROPS[t][0]) | set(PROPS[t][1])
        if t == "frame3d_terms":
            allowed |= {b + s_ for b in BENDING for s_ in ("", "_y", "_z")}
    unknown = sorted(set(e) - allowed)
    if unknown:
        raise InputError(f"{where}: unknown key(s) {', '.join(unknown)} (allowed: {', '.join(sorted(allowed))})")
    props = {k: v for k, v in e.items() if k not in ELEMENT_KEYS}
    for k, v in props.items():
        if isinstance(v, bool) or not isinstance(v, (int, float, str)):
            raise InputError(f"{where}: {k} must be a number or a parameter name, got {_shown(v)}")
    for k in ("nodes", "orientation", "dim", "nu", "drill", "offsets", "node", "offset", "inertia"):
        _no_booleans(e.get(k), f"{where}: {k}")
    try:
        if t == "spring":
            if "dofs" not in e or "k" not in e:
                raise InputError("spring needs 'dofs' and 'k'")
            s.spring(list(e["dofs"]), k=e["k"], where=where)
        elif t == "mass":
            if "dofs" not in e or "m" not in e:
                raise InputError("mass needs 'dofs' and 'm'")
            s.mass(list(e["dofs"]), m=e["m"], where=where)
        elif t == "point_mass":
            if "node" not in e or "m" not in e:
                raise InputError("point_mass needs 'node' and 'm'")
            s.point_mass(e["node"], m=e["m"], offset=e.get("offset"), inertia=e.get("inertia"), where=where)
        elif t in SHELLS or t in SOLIDS:
            _continuum_from_dict(s, t, e, props, where)
        else:
            if "nodes" not in e:
                raise InputError(f"{t} needs 'nodes' = [a, b]")
            kw = dict(mass=e.get("mass", "consistent"), where=where)
            if t == "rod":
                s.rod(e["nodes"], dim=e.get("dim", 3), **props, **kw)
            elif t == "beam2d":
                s.beam2d(e["nodes"], **props, **kw)
            elif t == "beam2d_terms":
                s.beam2d_terms(e["nodes"], **props, **kw)
            elif t == "frame3d":
                s.frame3d(e["nodes"], orientation=e.get("orientation"), offsets=e.get("offsets"), **props, **kw)
            else:
                s.frame3d_terms(e["nodes"], orientation=e.get("orientation"), offsets=e.get("offsets"), **props, **kw)
    except TypeError as exc:  # missing required keyword arguments
        raise InputError(f"{where}: {exc}".replace("() missing", " is missing")) from None
    except InputError as exc:
        msg = str(exc)
        raise InputError(msg if msg.startswith(where) else f"{where}: {msg}") from None


CONSTRAINT_KEYS = {"type", "independent", "dependent", "dofs"}
CONSTRAINT_TYPES = ("rigid", "equal")


def constraint_from_dict(s, c: Mapping, where: str) -> None:
    """Add one [[constraint]] table (a rigid link or an equal-dof tie) to the structure ``s``.

    Parameters
    ----------
    s : Structure
        Structure to add to.
    c : mapping
        The table: ``type`` (``"rigid"`` or ``"equal"``), ``independent`` (a node), ``dependent``
        (a node or a list of nodes) and ``dofs`` (directions; default every dof of the dependent node).
    where : str
        The table's position, prefixed to error messages.

    Raises
    ------
    InputError
        An unknown type or key, a missing key, or anything :meth:`Structure.rigid_link` refuses.
    """
    t = c.get("type")
    if t not in CONSTRAINT_TYPES:
        raise InputError(f"{where}: type must be one of {', '.join(map(repr, CONSTRAINT_TYPES))}, got {_shown(t)}")
    where = f"{where} ({t})"
    unknown = sorted(set(c) - CONSTRAINT_KEYS)
    if unknown:
        raise InputError(f"{where}: unknown key(s) {', '.join(unknown)} (allowed: {', '.join(sorted(CONSTRAINT_KEYS))})")
    for k in ("independent", "dependent"):
        if k not in c:
            raise InputError(f"{where}: needs '{k}' (a node{', or a list of nodes' if k == 'dependent' else ''})")
        _no_booleans(c[k], f"{where}: {k}")
    dofs = c.get("dofs")
    if dofs is not None and (isinstance(dofs, str) or not isinstance(dofs, list)):
        raise InputError(f"{where}: dofs must be a list of directions such as [\"x\", \"rz\"], got {_shown(dofs)}")
    try:
        if t == "rigid":
            s.rigid_link(c["independent"], c["dependent"], dofs, where=where)
        else:
            s.equal_dofs(c["independent"], c["dependent"], dofs, where=where)
    except InputError as exc:
        msg = str(exc)
        raise InputError(msg if msg.startswith(where) else f"{where}: {msg}") from None


def _continuum_from_dict(s, t: str, e: Mapping, props: dict, where: str) -> None:
    """A shell or solid [[element]] table: ``nodes`` one list of node ids or a list of them (an element set)."""
    count = SHELLS.get(t) or SOLIDS[t]
    nodes = e.get("nodes")
    if nodes is None:
        raise InputError(f"{t} needs 'nodes' = [{count} node ids] or a list of such lists (a set of elements)")
    rows = nodes if nodes and isinstance(nodes[0], list) else [nodes]
    bad = next((r for r in rows if not isinstance(r, list) or len(r) != count), None)
    if bad is not None:
        raise InputError(f"a {t} element has {count} nodes; got {bad!r}")
    if "nu" not in e:
        raise InputError(f"{t} needs Poisson's ratio 'nu'")
    kw = dict(mass=e.get("mass", "consistent"), where=where)
    if t in SHELLS:
        s.shell(rows, nu=e["nu"], drill=e.get("drill", 0.1), **props, **kw)
    else:
        s.solid(rows, nu=e["nu"], **props, **kw)


__all__ = ["structure_from_dict", "list_of_tables", "element_from_dict", "constraint_from_dict", "ELEMENT_KEYS",
           "TYPE_KEYS", "CONSTRAINT_KEYS"]


def _prior(spec: Mapping, where: str) -> Prior | None:
    """The ``prior`` of a ``[parameters.NAME]`` table (:func:`femupdate.priors.parse_prior`), or None."""
    return parse_prior(spec["prior"], where) if "prior" in spec else None
