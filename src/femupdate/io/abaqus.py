"""Abaqus matrix files: assembled ``*MATRIX GENERATE`` output and ``*ELEMENT MATRIX OUTPUT``.

Two text files that Abaqus/Standard writes with the suffix ``.mtx``:

* **Assembled matrices**, from a ``*MATRIX GENERATE, STIFFNESS, MASS`` step with
  ``*MATRIX OUTPUT, STIFFNESS, MASS, FORMAT=MATRIX INPUT`` (the default format): files
  ``<job>_STIF<step>.mtx`` and ``<job>_MASS<step>.mtx``, one nonzero term a line in the
  *matrix input* format that ``*MATRIX INPUT`` reads back::

      row node, row dof, column node, column dof, value

  one triangle of the symmetric matrix (the format also allows the square; both triangles, if
  given, must agree and are then not counted twice).  Comment lines begin with ``**``.
* **Element matrices**, from ``*ELEMENT MATRIX OUTPUT, ELSET=<set>, STIFFNESS=YES, MASS=YES,
  OUTPUT FILE=USER DEFINED, FILE NAME=<name>``: ``<name>.mtx`` holds, for each element of the
  set, a header comment ``** ELEMENT NUMBER <n> ...``, the element's nodes after a comment
  ``** ELEMENT NODES``, and the matrices in the format of ``*USER ELEMENT, LINEAR``: the keyword
  ``*USER ELEMENT, NODES=<k>, LINEAR``, a line of the active dofs at the first node (and lines
  ``<node position>, <dofs>`` where they change), then ``*MATRIX, TYPE=STIFFNESS`` and
  ``*MATRIX, TYPE=MASS`` each followed by the symmetric matrix's upper triangle stored by
  columns -- (1,1), (1,2), (2,2), (1,3), ... -- four values a line (the order of the results
  file's records 1011 and 1021).  Variables are ordered node by node, the element's first node
  first.

Dofs become labels ``node:dir`` from Abaqus's node numbers (or ``instance.node`` names) and
dof numbers 1-6 (x, y, z, rx, ry, rz); other dof numbers (warping, pore pressure,
temperature...) and negative or zero node numbers (Abaqus's internal nodes, Lagrange
multipliers) are refused by name.

A parameter's matrix is the sum of its element set's matrices divided by its nominal value:
exact for a parameter that scales the set's stiffness (a modulus) or mass (a density).
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import scipy.sparse as sp

from .._errors import InputError
from ..dofs import DIRECTIONS, node_id

#: Abaqus dof numbers read as femupdate directions
ABAQUS_DOFS = {i + 1: d for i, d in enumerate(DIRECTIONS)}
_ELEMENT = re.compile(r"ELEMENT\s+NUMBER\s+(\S+)", re.IGNORECASE)


def _text(p: Path, what: str) -> list[str]:
    if not p.exists():
        raise InputError(f"{what}: Abaqus matrix file {p} not found")
    if p.is_dir():
        raise InputError(f"{what}: {p} is a folder, not an Abaqus .mtx file")
    try:
        return p.read_bytes().decode("utf-8", errors="strict").splitlines()
    except UnicodeDecodeError:
        raise InputError(f"{what}: {p} is not a text file (an Abaqus .mtx file is text)") from None


def _dof(node_text: str, dof_text: str, where: str) -> tuple:
    """(node, direction) of an Abaqus node and dof number, refused by name when not structural."""
    node_text, dof_text = node_text.strip(), dof_text.strip()
    try:
        dof = int(dof_text)
    except ValueError:
        raise InputError(f"{where}: dof number {dof_text!r} is not an integer") from None
    node = node_id(node_text, where)
    if isinstance(node, int) and node <= 0:
        raise InputError(f"{where}: node {node} is an Abaqus internal node (a Lagrange multiplier or an element's "
                         "internal variable): condense it before exporting, or export the matrices without it")
    if dof not in ABAQUS_DOFS:
        raise InputError(f"{where}: dof {dof} at node {node} is not a displacement or rotation (Abaqus dofs 1-6 are "
                         "x, y, z, rx, ry, rz): femupdate reads structural dofs only")
    return node, ABAQUS_DOFS[dof]


def _label(key: tuple) -> str:
    return f"{key[0]}:{key[1]}"


def _order(keys) -> list[tuple]:
    """Dofs node by node (numbered nodes first, ascending; then names), x y z rx ry rz."""
    return sorted(keys, key=lambda k: (isinstance(k[0], str), k[0] if isinstance(k[0], int) else 0, str(k[0]),
                                       DIRECTIONS.index(k[1])))


def read_assembled(path, what: str = "matrix") -> dict[tuple[tuple, tuple], float]:
    """The terms of an assembled ``.mtx`` in matrix input format (module docstring).

    Parameters
    ----------
    path : str or os.PathLike
    what : str
        How messages name the file's role.

    Returns
    -------
    dict
        ``{((node, dir), (node, dir)): value}`` with both triangles filled (a term given in both
        triangles is counted once).

    Raises
    ------
    InputError
        A line that is not ``node, dof, node, dof, value`` (a file written with ``FORMAT=LABELS``
        or ``FORMAT=COORDINATE`` is named as such); a dof that is not structural or an internal
        node; a term given twice, or in both triangles with different values; no terms.
    """
    p = Path(path)
    terms: dict = {}
    for k, line in enumerate(_text(p, what), start=1):
        text = line.strip()
        if not text or text.startswith("**"):
            continue
        where = f"{what}: {p}: line {k}"
        fields = [f for f in text.split(",")]
        if len(fields) != 5:
            fmt = " (FORMAT=COORDINATE writes 'row, column, value': write FORMAT=MATRIX INPUT)" if len(fields) == 3 else ""
            raise InputError(f"{where}: expected 'node, dof, node, dof, value' (the matrix input format of *MATRIX "
                             f"GENERATE), got {text[:60]!r}{fmt}")
        a, b = _dof(fields[0], fields[1], where), _dof(fields[2], fields[3], where)
        try:
            value = float(fields[4])
        except ValueError:
            raise InputError(f"{where}: {fields[4].strip()!r} is not a number") from None
        if not np.isfinite(value):
            raise InputError(f"{where}: the value {fields[4].strip()} is not finite")
        if (a, b) in terms:
            raise InputError(f"{where}: the term ({_label(a)}, {_label(b)}) is given twice")
        terms[(a, b)] = value
    if not terms:
        raise InputError(f"{what}: {p} holds no matrix terms")
    full = dict(terms)
    for (a, b), value in terms.items():
        if a == b:
            continue
        if (b, a) in terms and terms[(b, a)] != value:
            raise InputError(f"{what}: {p}: the terms ({_label(a)}, {_label(b)}) = {value:.17g} and "
                             f"({_label(b)}, {_label(a)}) = {terms[(b, a)]:.17g} differ: not a symmetric matrix")
        full[(b, a)] = value
    return full


@dataclass(frozen=True)
class ElementMatrix:
    """One element's matrix from an ``*ELEMENT MATRIX OUTPUT`` file.

    Attributes
    ----------
    element : str
        The element number as the header gives it.
    dofs : tuple of (node, dir)
        The matrix's dofs, in the element's order.
    matrix : numpy.ndarray
        The symmetric matrix.
    """

    element: str
    dofs: tuple
    matrix: np.ndarray


def _element_dofs(nodes: list[str], dof_lines: list[str], where: str) -> list[tuple]:
    """The element's dofs: the first node's active dofs, changed at the node positions given."""
    active: dict[int, list[int]] = {}
    for j, line in enumerate(dof_lines):
        vals = [v.strip() for v in line.split(",") if v.strip()]
        try:
            ints = [int(v) for v in vals]
        except ValueError:
            raise InputError(f"{where}: the *USER ELEMENT dof line {line.strip()!r} is not integers") from None
        if j == 0:
            active[1] = ints
        else:
            active[ints[0]] = ints[1:]
    dofs, current = [], active.get(1, [])
    for pos, node in enumerate(nodes, start=1):
        current = active.get(pos, current)
        dofs += [_dof(node, str(d), where) for d in current]
    return dofs


def _symmetric(values: list[float], n: int, where: str) -> np.ndarray:
    """The symmetric n × n matrix from its upper triangle stored by columns."""
    if len(values) != n * (n + 1) // 2:
        raise InputError(f"{where}: {len(values)} matrix values for {n} dofs (a symmetric matrix stored by its "
                         f"triangle has {n * (n + 1) // 2})")
    A = np.zeros((n, n))
    rows, cols = np.triu_indices(n)
    order = np.lexsort((rows, cols))  # by columns, from the first row to the diagonal
    A[rows[order], cols[order]] = values
    return A + np.triu(A, 1).T


def read_element_matrices(path, kind: str = "STIFFNESS", what: str = "elements") -> list[ElementMatrix]:
    """The element matrices of one type in an ``*ELEMENT MATRIX OUTPUT`` file (module docstring).

    Parameters
    ----------
    path : str or os.PathLike
    kind : str, default ``"STIFFNESS"``
        ``"STIFFNESS"`` or ``"MASS"``: which ``*MATRIX, TYPE=`` records to read.
    what : str
        How messages name the file's role.

    Returns
    -------
    list of ElementMatrix
        In the file's order.

    Raises
    ------
    InputError
        An element without nodes, dofs or the matrix asked for; a count of values that does not
        fill the triangle; a dof that is not structural; an element given twice; no elements.
    """
    p = Path(path)
    lines = _text(p, what)
    blocks: list[tuple[str, int, list[str]]] = []
    for k, line in enumerate(lines, start=1):
        m = _ELEMENT.search(line) if line.lstrip().startswith("**") else None
        if m:
            blocks.append((m.group(1).rstrip(","), k, []))
        elif blocks:
            blocks[-1][2].append(line)
    if not blocks:
        raise InputError(f"{what}: {p} has no element header ('** ELEMENT NUMBER ...'): not an *ELEMENT MATRIX OUTPUT "
                         "file (an assembled *MATRIX GENERATE file goes under 'stiffness' and 'mass')")
    out, seen = [], set()
    for element, k, body in blocks:
        where = f"{what}: {p}: element {element} (line {k})"
        if element in seen:
            raise InputError(f"{where}: the element is given twice")
        seen.add(element)
        nodes: list[str] = []
        dof_lines: list[str] = []
        values: list[float] | None = None
        section: str | None = None
        for line in body:
            text = line.strip()
            upper = text.upper().replace(" ", "")
            if upper.startswith("**ELEMENTNODES"):
                section = "nodes"
            elif upper.startswith("*USERELEMENT"):
                section = "dofs"
            elif upper.startswith("*MATRIX"):
                section = "matrix" if f"TYPE={kind}" in upper else "other"
                if section == "matrix":
                    values = []
            elif text.startswith("**") and section == "nodes" and not nodes:
                nodes = [v.strip() for v in text[2:].split(",") if v.strip()]
            elif text.startswith("*"):
                section = None
            elif text and section == "nodes" and not nodes:
                nodes = [v.strip() for v in text.split(",") if v.strip()]
            elif text and section == "dofs":
                dof_lines.append(text)
            elif text and section == "matrix" and values is not None:
                try:
                    values += [float(v) for v in text.split(",") if v.strip()]
                except ValueError:
                    raise InputError(f"{where}: a matrix line {text[:60]!r} is not numbers") from None
        if not nodes or not dof_lines:
            raise InputError(f"{where}: no {'nodes (** ELEMENT NODES)' if not nodes else 'dofs (*USER ELEMENT)'}")
        if values is None:
            raise InputError(f"{where}: no *MATRIX, TYPE={kind} (request {kind}=YES in *ELEMENT MATRIX OUTPUT)")
        dofs = _element_dofs(nodes, dof_lines, where)
        out.append(ElementMatrix(element, tuple(dofs), _symmetric(values, len(dofs), where)))
    return out


def element_set_sum(elements: list[ElementMatrix], index: dict, n: int, where: str) -> sp.csr_array:
    """The sum of element matrices on the model's dofs ``index`` ({(node, dir): position});
    terms at dofs not in ``index`` are dropped only when the caller removed those dofs (held)."""
    rows, cols, vals = [], [], []
    for e in elements:
        missing = [_label(d) for d in e.dofs if d not in index]
        if missing:
            raise InputError(f"{where}: element {e.element} has dof(s) {', '.join(missing[:6])} that the assembled "
                             "matrices do not have")
        pos = np.array([index[d] for d in e.dofs])
        r, c = np.meshgrid(pos, pos, indexing="ij")
        rows.append(r.ravel())
        cols.append(c.ravel())
        vals.append(e.matrix.ravel())
    A = sp.coo_array((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(n, n)).tocsr()
    A.sum_duplicates()
    return A


def assembled_matrices(stiffness, mass, what: str = "abaqus") -> tuple[list[str], sp.csr_array, sp.csr_array, dict]:
    """K and M from ``*MATRIX GENERATE`` files on their common dofs.

    Parameters
    ----------
    stiffness, mass : str or os.PathLike
        The ``_STIF`` and ``_MASS`` files.
    what : str
        How messages name the table.

    Returns
    -------
    dofs : list of str
        Labels, node by node (:func:`_order`).
    K, M : scipy.sparse.csr_array
    index : dict
        ``{(node, dir): position}``.
    """
    Kt = read_assembled(stiffness, f"{what} stiffness")
    Mt = read_assembled(mass, f"{what} mass")
    keys = _order({a for a, _ in Kt} | {a for a, _ in Mt})
    index = {k: i for i, k in enumerate(keys)}
    n = len(keys)

    def build(terms):
        r = np.array([index[a] for a, _ in terms])
        c = np.array([index[b] for _, b in terms])
        return sp.coo_array((np.array(list(terms.values())), (r, c)), shape=(n, n)).tocsr()

    return [_label(k) for k in keys], build(Kt), build(Mt), index


def read_nodes(path, what: str = "deck") -> dict:
    """Node coordinates from the ``*NODE`` blocks of an Abaqus input file (``id, x, y[, z]``)."""
    p = Path(path)
    nodes, inside = {}, False
    for k, line in enumerate(_text(p, what), start=1):
        text = line.strip()
        if not text or text.startswith("**"):
            continue
        if text.startswith("*"):
            inside = text.upper().replace(" ", "").split(",")[0] == "*NODE"
            continue
        if inside:
            fields = [f.strip() for f in text.split(",") if f.strip()]
            try:
                xyz = [float(v) for v in fields[1:4]] + [0.0] * (4 - len(fields))
                node = node_id(fields[0], f"{what}: {p}: line {k}")
            except (ValueError, IndexError):
                raise InputError(f"{what}: {p}: line {k}: expected 'node, x, y[, z]', got {text[:60]!r}") from None
            if node in nodes:
                raise InputError(f"{what}: {p}: line {k}: node {node} is defined twice")
            nodes[node] = tuple(xyz[:3])
    return nodes


def _held(spec, dofs: list[str], where: str) -> np.ndarray:
    """Positions of the held dofs: entries ``"node"`` (every dof of the node) or ``"node:dir"``."""
    from ..dofs import canonical

    if not isinstance(spec, list) or not all(isinstance(h, (str, int)) for h in spec):
        raise InputError(f"{where}: held must be a list of nodes or dofs such as [1, \"4:x\"], got {spec!r}")
    held = np.zeros(len(dofs), bool)
    for h in spec:
        text = str(h).strip()
        if ":" in text:
            lab = canonical(text)
            hit = np.array([d == lab for d in dofs])
        else:
            node = str(node_id(text, where))
            hit = np.array([d.split(":")[0] == node for d in dofs])
        if not hit.any():
            raise InputError(f"{where}: held {h!r} is no dof of the assembled matrices")
        held |= hit
    return held


def abaqus_model(table, parameters, path: Path, name: str):
    """A :class:`~femupdate.Model` from a model file's ``[abaqus]`` table and its parameters
    (docs/file-formats.md): K and M from ``*MATRIX GENERATE``, each parameter's matrices from
    the ``*ELEMENT MATRIX OUTPUT`` file of its element set (``K_elements``, ``M_elements``) divided
    by the value it was written at (``exported_at``, default ``value``), ``K0 = K − Σ`` (the sets'
    sums) and likewise ``M0``; the ``held`` dofs removed; node
    coordinates from ``deck`` (``*NODE``) when given."""
    from ..model import Model, Parameter
    from ..priors import parse_prior

    src = f"{path}: [abaqus]"
    base = path.parent
    unknown = sorted(set(table) - {"stiffness", "mass", "held", "deck"})
    if unknown:
        raise InputError(f"{src}: unknown key(s) {', '.join(unknown)} (allowed: stiffness, mass, held, deck)")
    for key in ("stiffness", "mass"):
        if not isinstance(table.get(key), str):
            raise InputError(f"{src}: '{key}' must name the *MATRIX GENERATE file (…_{key[:4].upper()}<step>.mtx)")
    dofs, K, M, index = assembled_matrices(base / table["stiffness"], base / table["mass"], src)
    n = len(dofs)
    params: list = []
    dK: list = []
    dM: list = []
    sums_K: list = []
    sums_M: list = []
    for pname, spec in parameters.items():
        where = f"{path}: [parameters.{pname}]"
        if not isinstance(spec, dict) or "value" not in spec:
            raise InputError(f"{where} must be a table with at least 'value'")
        allowed = {"value", "bounds", "fixed", "prior", "K_elements", "M_elements", "exported_at", "card"}
        if set(spec) - allowed or not ({"K_elements", "M_elements"} & set(spec)):
            raise InputError(f"{where}: an Abaqus parameter takes {', '.join(sorted(allowed))}, with K_elements and/or "
                             f"M_elements (the *ELEMENT MATRIX OUTPUT file of its element set); got {', '.join(spec)}")
        try:
            par = Parameter(pname, spec["value"], tuple(spec.get("bounds", (-np.inf, np.inf))), spec.get("fixed", False),
                            prior=parse_prior(spec["prior"], f"{where} prior") if "prior" in spec else None)
        except InputError as exc:
            raise InputError(f"{where}: {exc}") from None
        at = spec.get("exported_at", par.value)
        if isinstance(at, bool) or not isinstance(at, (int, float)) or not np.isfinite(at) or at == 0:
            raise InputError(f"{where}: exported_at (the value the element matrices were written at) must be a nonzero "
                             f"number, got {at!r}")
        params.append(par)
        for key, kind, out in (("K_elements", "STIFFNESS", dK), ("M_elements", "MASS", dM)):
            if key in spec:
                els = read_element_matrices(base / str(spec[key]), kind, f"{where} {key}")
                S = element_set_sum(els, index, n, f"{where} {key} ({spec[key]})")
                out.append(S / at)
                (sums_K if kind == "STIFFNESS" else sums_M).append(S)
            else:
                out.append(None)
    K0 = K - sum(sums_K, sp.csr_array((n, n)))  # the files' matrices less what the parameters make of them
    M0 = M - sum(sums_M, sp.csr_array((n, n)))
    keep = ~_held(table.get("held", []), dofs, src)
    idx = np.flatnonzero(keep)

    def cut(A):
        return None if A is None else sp.csr_array(A)[idx][:, idx]

    nodes = read_nodes(base / table["deck"], f"{src} deck") if "deck" in table else {}
    used = {d.split(":")[0] for d in dofs}
    nodes = {k: v for k, v in nodes.items() if str(k) in used}
    try:
        return Model(tuple(dofs[i] for i in idx), cut(K0), cut(M0), tuple(params), tuple(cut(A) for A in dK),
                     tuple(cut(A) for A in dM), name=name, nodes=nodes)
    except InputError as exc:
        raise InputError(f"{path}: {exc}") from None


__all__ = ["ABAQUS_DOFS", "ElementMatrix", "read_assembled", "read_element_matrices", "element_set_sum",
           "assembled_matrices", "read_nodes", "abaqus_model"]
