"""Degree-of-freedom labels ``"<node>:<dir>"`` and dof indices ``"#N"``.

A label names a node and a direction, e.g. ``"3:x"``, ``"A2:rz"``, ``"hinge_3:y"``:

* **node**: an integer (``3``, canonical without blanks, sign ``+`` or leading zeros: ``" 03 "`` ->
  ``3``), or any other name as a commercial FE code exports it (``A2``, ``N101``, ``Part-1.12``):
  printable, without whitespace, without ``:``, ``,``, ``;`` or ``=`` (they separate labels, dofs and
  amplitudes on the command line), and not beginning with ``#`` (which marks a dof index).  A
  name is kept exactly as written (case-sensitive; blanks around it are dropped).
* **dir**: one of ``x y z rx ry rz`` in any case, or a NASTRAN component number ``1``-``6``
  (``1`` = x … ``6`` = rz); canonical in lower-case letters.  ``s`` (or NASTRAN's component
  ``0``) is the one dof of a **scalar point** (a NASTRAN SPOINT or EPOINT, the modal coordinate
  of a reduced superelement): ``1995001:s``; it has no direction in space.

``"#N"`` is the N-th dof (1-based) of a model's dof list, as ``femupdate modes --json`` lists it
under ``dofs``.  It is resolved to the model's label where test data or command-line options are
read together with their model (:func:`resolve_dof`, :func:`resolve_all`); everything downstream
sees labels only.

Every array with a dof axis travels with its labels; selection and pairing are by label.
"""

from __future__ import annotations

import re
from collections.abc import Iterable, Sequence

import numpy as np

from ._errors import InputError

DIRECTIONS: tuple[str, ...] = ("x", "y", "z", "rx", "ry", "rz")
#: the direction of a scalar point's one dof (NASTRAN component 0)
SCALAR = "s"
_DIR_INDEX = {**{d: i for i, d in enumerate(DIRECTIONS)}, SCALAR: len(DIRECTIONS)}
_NASTRAN = {"0": SCALAR, **{str(i + 1): d for i, d in enumerate(DIRECTIONS)}}  # NASTRAN components 0..6
_INDEX = re.compile(r"#([0-9]+)")
_SEPARATORS = ",;="  # separate dofs, sets and amplitudes in command-line options

Node = int | str
"""A node: an integer node number, or a node name (a ``str`` that is not an integer)."""


def _is_integer(text: str) -> bool:
    """Whether ``text`` is an integer in ASCII digits, with an optional sign."""
    digits = text[1:] if text[:1] in ("+", "-") else text
    return digits.isascii() and digits.isdigit()


def _node_problem(text: str) -> str | None:
    """Why ``text`` (stripped) cannot be a node name, or None."""
    if not text:
        return "is empty"
    if any(c.isspace() for c in text):
        return "contains a blank"
    if not text.isprintable():
        return "contains a control character"
    bad = sorted({c for c in text if c in _SEPARATORS})
    if bad:
        return (f"contains {' and '.join(repr(c) for c in bad)} (',' ';' and '=' separate dofs and amplitudes "
                "on the command line)")
    if text.startswith("#"):
        return "begins with '#' (which marks a dof index '#N')"
    return None


def node_id(node, what: str = "node") -> Node:
    """The canonical form of a node: an ``int`` for an integer node, else its name.

    Parameters
    ----------
    node : int or str
        An integer (Python or NumPy; a float with an integer value is accepted), or a node name;
        a name that spells an integer (``" 03 "``, ``"+3"``) is that integer.
    what : str, default "node"
        What the node is, for the error message.

    Returns
    -------
    int or str
        The node number, or the name stripped of surrounding blanks (case kept).

    Raises
    ------
    InputError
        A boolean, a non-integer number, or a name that is empty, contains a blank, a control
        character, ``:`` or one of ``, ; =``, or begins with ``#``.
    """
    if isinstance(node, (bool, np.bool_)):
        raise InputError(f"{what}: {node!r} is not a node (an integer or a name such as 'A2')")
    if isinstance(node, (int, np.integer)):
        return int(node)
    if isinstance(node, (float, np.floating)):
        if not float(node).is_integer():
            raise InputError(f"{what}: {float(node)!r} is not a node (an integer or a name such as 'A2')")
        return int(node)
    if not isinstance(node, str):
        raise InputError(f"{what}: {node!r} is not a node (an integer or a name such as 'A2')")
    text = node.strip()
    if _is_integer(text):
        return int(text)
    why = "contains ':'" if ":" in text else _node_problem(text)
    if why:
        raise InputError(f"{what}: node name {node!r} {why}")
    return text


def parse_dof(label: str) -> tuple[Node, str]:
    """Split ``"12:rz"`` into ``(12, "rz")`` and ``"A2:x"`` into ``("A2", "x")``; raise
    :class:`InputError` if malformed.

    Parameters
    ----------
    label : str
        ``"<node>:<dir>"`` (module docstring); blanks around either part are ignored, the direction
        may be in any case or a NASTRAN component number ``1``-``6``.

    Returns
    -------
    node : int or str
        The node number (``int``) for an integer node, else the node name (``str``, as written).
    direction : str
        One of ``x y z rx ry rz`` (lower case).

    Raises
    ------
    InputError
        ``label`` is not a string with exactly one ``:``; its node is not an integer nor a valid
        name; its direction is unknown; it is a dof index ``"#N"`` (which only
        :func:`resolve_dof` resolves, against a model's dof list).
    """
    if not isinstance(label, str) or label.count(":") != 1:
        if is_index(label):
            raise InputError(f"dof {label!r}: '#N' (the N-th dof of a model) is resolved only where test data or "
                             "command-line options are read with their model; give a label '<node>:<dir>' here")
        raise InputError(f"dof label {label!r} is not of the form '<node>:<dir>' (e.g. '3:x' or 'A2:x')")
    node_txt, direction = label.split(":")
    node_txt, direction = node_txt.strip(), direction.strip().lower()
    node: Node
    if _is_integer(node_txt):
        node = int(node_txt)
    else:
        why = _node_problem(node_txt)
        if why:
            raise InputError(f"dof label {label!r}: node {node_txt!r} {why}")
        node = node_txt
    direction = _NASTRAN.get(direction, direction)
    if direction not in _DIR_INDEX:
        raise InputError(
            f"dof label {label!r}: direction {direction!r} is not one of {', '.join(DIRECTIONS)} (or 1-6), or s for a "
            "scalar point"
        )
    return node, direction


def dof(node: Node, direction: str) -> str:
    """Canonical label of ``direction`` at ``node``.

    Parameters
    ----------
    node : int or str
        Node number or name (canonicalised by :func:`node_id`).
    direction : str
        Direction, written as given (not checked; pass one of ``x y z rx ry rz``).

    Returns
    -------
    str
        ``"<node>:<direction>"``.

    Raises
    ------
    InputError
        ``node`` is neither an integer nor a valid node name.
    """
    return f"{node_id(node)}:{direction}"


def canonical(label: str) -> str:
    """The canonical spelling of a label (``" 3 : X"`` -> ``"3:x"``, ``" A2 : 1"`` -> ``"A2:x"``).

    Parameters
    ----------
    label : str
        A dof label, as :func:`parse_dof` accepts it.

    Returns
    -------
    str
        The label without blanks: an integer node as a plain number, a named node as written,
        the direction as ``x y z rx ry rz``.

    Raises
    ------
    InputError
        The label is malformed.
    """
    node, direction = parse_dof(label)
    return f"{node}:{direction}"


def _listed_twice(out: Sequence[str], written: Sequence[object], what: str) -> None:
    if len(set(out)) == len(out):
        return
    seen: dict[str, list[object]] = {}
    for lab, w in zip(out, written):
        seen.setdefault(lab, []).append(w)
    parts = []
    for lab in sorted((lab for lab, ws in seen.items() if len(ws) > 1), key=sort_key):
        ws = seen[lab]
        shown = [w for w in ws if w != lab]
        parts.append(lab + (f" (written {' and '.join(repr(w) for w in ws)})" if shown else ""))
    raise InputError(f"{what}: dof(s) listed twice: {', '.join(parts)}")


def canonical_all(labels: Iterable[str], what: str = "dofs") -> tuple[str, ...]:
    """Canonical labels, refusing duplicates.

    Parameters
    ----------
    labels : iterable of str
        Dof labels.
    what : str, default "dofs"
        What the labels are, for the error message.

    Returns
    -------
    tuple of str
        The canonical labels, in the given order.

    Raises
    ------
    InputError
        A label is malformed, or two labels are the same dof once canonical.
    """
    labels = list(labels)
    if _all_canonical_integer(labels):  # a million-dof mesh's labels: checked at once, already canonical
        out = tuple(labels)
    else:
        out = tuple(canonical(lab) for lab in labels)
    _listed_twice(out, labels, what)
    return out


_CANONICAL_INTEGER = re.compile(r"(?:(?:0|-?[1-9][0-9]*):(?:x|y|z|rx|ry|rz|s)\n)*+")  # possessive: one linear pass


def _all_canonical_integer(labels: list) -> bool:
    """Whether every label is a str already in canonical form with an integer node (one regex pass)."""
    if not all(isinstance(lab, str) for lab in labels):
        return False
    text = "\n".join(labels) + "\n"
    return len(text) > 1 and _CANONICAL_INTEGER.fullmatch(text) is not None and text.count("\n") == len(labels)


def is_index(text) -> bool:
    """Whether ``text`` is meant as a dof index: a string beginning with ``#`` and without ``:``.

    Parameters
    ----------
    text : object
        What the user wrote.

    Returns
    -------
    bool
    """
    return isinstance(text, str) and text.strip().startswith("#") and ":" not in text


def resolve_dof(text: str, dofs: Sequence[str] | None, what: str = "dof") -> str:
    """A dof as the user wrote it: ``"#N"`` is ``dofs[N - 1]``, anything else a label.

    Parameters
    ----------
    text : str
        ``"#N"`` (N from 1 to ``len(dofs)``; blanks around it are ignored) or a dof label.
    dofs : sequence of str or None
        The model's dof list that ``#N`` counts in; ``None`` where no model is known (then
        ``#N`` is refused).
    what : str, default "dof"
        What the dof is (e.g. ``"--ref-dof"``), for the message.

    Returns
    -------
    str
        The canonical label.  A label is not checked against ``dofs`` here.

    Raises
    ------
    InputError
        ``#`` not followed by a whole number; N out of range (the message gives the dof count);
        ``#N`` without ``dofs``; a malformed label.
    """
    if not is_index(text):
        return canonical(text)
    if dofs is None:
        raise InputError(f"{what}: dof {text!r}: '#N' (the N-th dof of the model) needs the model, which is "
                         "not known here; give a label '<node>:<dir>'")
    n = len(dofs)
    has = f"the model has {n} dof{'' if n == 1 else 's'}"
    m = _INDEX.fullmatch(text.strip())
    if m is None:
        raise InputError(f"{what}: dof index {text!r} is not '#' and a whole number from 1 to {n} ({has})")
    k = int(m.group(1))
    if not 1 <= k <= n:
        raise InputError(f"{what}: dof index {text!r} is out of range: {has} (#1 to #{n})")
    return canonical(dofs[k - 1])


def resolve_all(texts: Iterable[str], dofs: Sequence[str] | None, what: str = "dofs") -> tuple[str, ...]:
    """:func:`resolve_dof` of each text, refusing the same dof given twice (e.g. as ``"1:x"`` and ``"#1"``).

    Parameters
    ----------
    texts : iterable of str
        Dof labels and/or indices ``"#N"``.
    dofs : sequence of str or None
        The model's dof list (``None``: no model; ``#N`` is refused).
    what : str, default "dofs"
        What the dofs are, for the message.

    Returns
    -------
    tuple of str
        Canonical labels, in the given order.

    Raises
    ------
    InputError
        As :func:`resolve_dof`; a dof given twice (the message shows how each was written).
    """
    texts = list(texts)
    out = tuple(resolve_dof(t, dofs, what) for t in texts)
    _listed_twice(out, texts, what)
    return out


def sort_key(label: str) -> tuple:
    """Key ordering labels by node, then by direction in the order ``x y z rx ry rz``.

    Integer nodes come first, by number; then named nodes in natural order: runs of digits
    compare as numbers and letters without regard to case (``A2 < a3 < A10 < B1``), names that
    still tie by their exact spelling (``A02 < A2``).  The order is total, so sorting is stable
    and reproducible.

    Parameters
    ----------
    label : str
        A dof label.

    Returns
    -------
    tuple
        ``(0, node, direction index)`` for an integer node, ``(1, natural key, name,
        direction index)`` for a named node.

    Raises
    ------
    InputError
        The label is malformed.
    """
    node, direction = parse_dof(label)
    if isinstance(node, int):
        return 0, node, _DIR_INDEX[direction]
    return 1, natural_key(node), node, _DIR_INDEX[direction]


def natural_key(name: str) -> tuple:
    """Natural-order key of a name: digit runs as numbers, the rest case-folded (``"A10"`` ->
    ``("a", 10, "")``).

    Parameters
    ----------
    name : str
        Any text.

    Returns
    -------
    tuple
        Alternately text (case-folded) and integers, beginning and ending with text, so that any
        two keys compare.
    """
    parts = re.split(r"([0-9]+)", name)
    return tuple(int(p) if i % 2 else p.casefold() for i, p in enumerate(parts))


def _names(labels: Sequence[str], limit: int = 8) -> str:
    labels = list(labels)
    shown = ", ".join(labels[:limit])
    return shown + (f" … ({len(labels)} in all)" if len(labels) > limit else "")


def index_of(dofs: Sequence[str], wanted: Iterable[str], what: str = "data") -> np.ndarray:
    """Positions of ``wanted`` labels in ``dofs``; one error naming every unknown label.

    Parameters
    ----------
    dofs : sequence of str
        Canonical labels of an array's dof axis.
    wanted : iterable of str
        Labels to find (canonicalised first).
    what : str, default "data"
        What asks, for the error message.

    Returns
    -------
    numpy.ndarray of intp, shape ``(len(wanted),)``
        Index in ``dofs`` of each wanted label, in the order of ``wanted``.

    Raises
    ------
    InputError
        A wanted label is malformed or not in ``dofs``.
    """
    lookup = {lab: i for i, lab in enumerate(dofs)}
    wanted = [canonical(w) for w in wanted]
    missing = [w for w in wanted if w not in lookup]
    if missing:
        raise InputError(f"{what}: dof(s) not in the model: {_names(missing)}")
    return np.fromiter((lookup[w] for w in wanted), dtype=np.intp, count=len(wanted))


def describe(labels: Sequence[str], limit: int = 8) -> str:
    """Short human-readable list of labels for messages.

    Parameters
    ----------
    labels : sequence of str
        Labels to list.
    limit : int, default 8
        Most labels shown; beyond it the text ends with `` … (<n> in all)``.

    Returns
    -------
    str
        The labels joined by ``", "``.
    """
    return _names(labels, limit)
