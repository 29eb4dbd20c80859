"""Degree-of-freedom labels ``"<node>:<dir>"`` (``dir`` one of x y z rx ry rz).

Every array with a dof axis travels with its labels; selection and pairing are by label.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence

import numpy as np

from ._errors import InputError

DIRECTIONS: tuple[str, ...] = ("x", "y", "z", "rx", "ry", "rz")
_DIR_INDEX = {d: i for i, d in enumerate(DIRECTIONS)}


def parse_dof(label: str) -> tuple[int, str]:
    """Split ``"12:rz"`` into ``(12, "rz")``; raise :class:`InputError` if malformed.

    Parameters
    ----------
    label : str
        ``"<node>:<dir>"``; blanks around either part are ignored and the direction may be in any case.

    Returns
    -------
    node : int
        The node number.
    direction : str
        One of ``x y z rx ry rz`` (lower case).

    Raises
    ------
    InputError
        ``label`` is not a string with exactly one ``:``, its node is not an integer, or its direction is unknown.
    """
    if not isinstance(label, str) or label.count(":") != 1:
        raise InputError(f"dof label {label!r} is not of the form '<node>:<dir>' (e.g. '3:x')")
    node_txt, direction = label.split(":")
    node_txt, direction = node_txt.strip(), direction.strip().lower()
    try:
        node = int(node_txt)
    except ValueError:
        raise InputError(f"dof label {label!r}: node {node_txt!r} is not an integer") from None
    if direction not in _DIR_INDEX:
        raise InputError(
            f"dof label {label!r}: direction {direction!r} is not one of {', '.join(DIRECTIONS)}"
        )
    return node, direction


def dof(node: int, direction: str) -> str:
    """Canonical label of ``direction`` at ``node``.

    Parameters
    ----------
    node : int
        Node number (converted with ``int``).
    direction : str
        Direction, written as given (not checked; pass one of ``x y z rx ry rz``).

    Returns
    -------
    str
        ``"<node>:<direction>"``.
    """
    return f"{int(node)}:{direction}"


def canonical(label: str) -> str:
    """The canonical spelling of a label (``" 3 : X"`` -> ``"3:x"``).

    Parameters
    ----------
    label : str
        A dof label, as :func:`parse_dof` accepts it.

    Returns
    -------
    str
        The label without blanks, direction in lower case.

    Raises
    ------
    InputError
        The label is malformed.
    """
    return dof(*parse_dof(label))


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
    out = tuple(canonical(lab) for lab in labels)
    if len(set(out)) != len(out):
        seen, dup = set(), []
        for lab in out:
            if lab in seen:
                dup.append(lab)
            seen.add(lab)
        raise InputError(f"{what}: dof(s) listed twice: {', '.join(sorted(set(dup)))}")
    return out


def sort_key(label: str) -> tuple[int, int]:
    """Key ordering labels by node, then by direction in the order ``x y z rx ry rz``.

    Parameters
    ----------
    label : str
        A dof label.

    Returns
    -------
    tuple of (int, int)
        ``(node, index of the direction in DIRECTIONS)``.

    Raises
    ------
    InputError
        The label is malformed.
    """
    node, direction = parse_dof(label)
    return node, _DIR_INDEX[direction]


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
