"""Candidate sensor positions: uniaxial sensors (one dof each) or triaxial ones (the translations
of a node), from the model or a file, with the sensors the user fixes.

A *sensor* is a tuple of dof labels measured together: ``("3:y",)`` for a uniaxial sensor, or
``("3:x", "3:y", "3:z")`` for a triaxial one (the translations of node 3 that the model has;
those removed by a support are left out).  The placement algorithms choose among sensors, and
every measured dof of a sensor is a row of the data.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from .._errors import InputError
from ..dofs import canonical, parse_dof

TRANSLATIONS = ("x", "y", "z")
KINDS = ("uniaxial", "triaxial")


@dataclass(frozen=True)
class Candidates:
    """The sensors a plan chooses from.

    Each parameter is stored as the attribute of the same name.

    Parameters
    ----------
    sensors : tuple of tuple of str
        Every candidate sensor, as the dof labels it measures.
    kind : {"uniaxial", "triaxial"}
        One dof per sensor, or the translations of a node.
    fixed : tuple of int
        Positions in ``sensors`` of the sensors the user fixes (always in the plan).
    """

    sensors: tuple[tuple[str, ...], ...]
    kind: str
    fixed: tuple[int, ...] = ()

    @property
    def dofs(self) -> tuple[str, ...]:
        """Every candidate dof, sensor by sensor."""
        return tuple(d for s in self.sensors for d in s)

    def rows(self, chosen: Sequence[int]) -> list[int]:
        """Positions in :attr:`dofs` of the dofs of the sensors ``chosen``."""
        starts, pos = [], 0
        for s in self.sensors:
            starts.append(pos)
            pos += len(s)
        return [starts[i] + k for i in chosen for k in range(len(self.sensors[i]))]

    def label(self, i: int) -> str:
        """A sensor as the user reads it: its dof (uniaxial) or its node (triaxial, ``node 3``)."""
        s = self.sensors[i]
        return s[0] if self.kind == "uniaxial" else f"node {parse_dof(s[0])[0]}"


def _node_sensors(model, nodes: Sequence[str] | None, what: str) -> list[tuple[str, ...]]:
    by_node: dict[str, list[str]] = {}
    for d in model.dofs:
        node, direction = parse_dof(d)
        if direction in TRANSLATIONS:
            by_node.setdefault(str(node), []).append(d)
    if nodes is None:
        return [tuple(v) for v in by_node.values()]
    unknown = [n for n in nodes if str(n).strip() not in by_node]
    if unknown:
        raise InputError(f"{what}: unknown candidate node(s) {', '.join(map(str, unknown))} (no translational dof of "
                         f"the model {model.name!r} there)")
    return [tuple(by_node[str(n).strip()]) for n in nodes]


def candidates(model, given: Sequence[str] | None = None, kind: str = "uniaxial", fixed: Sequence[str] = (),
               what: str = "candidates") -> Candidates:
    """The candidate sensors of a plan.

    Parameters
    ----------
    model : Model
    given : sequence of str, optional
        Uniaxial: dof labels; triaxial: node ids (or dof labels, whose nodes are taken).  Default:
        every translational dof (node) of the model.
    kind : {"uniaxial", "triaxial"}, default "uniaxial"
    fixed : sequence of str
        Sensors always in the plan, spelled as ``given`` (added to the candidates when missing).
    what : str
        The name of ``given`` in messages (``--candidates`` on the command line).

    Returns
    -------
    Candidates

    Raises
    ------
    InputError
        An unknown kind; unknown candidate dofs or nodes (every one named, as written); a repeated
        candidate; no candidate.
    """
    if kind not in KINDS:
        raise InputError(f"unknown sensor kind {kind!r}: use {', '.join(KINDS)}")
    trans = [d for d in model.dofs if parse_dof(d)[1] in TRANSLATIONS] or list(model.dofs)

    def spell(items, where):
        if kind == "uniaxial":
            out = []
            bad = []
            for raw in items:
                try:
                    lab = canonical(str(raw))
                except InputError:
                    bad.append(str(raw).strip())
                    continue
                if lab in model.dofs:
                    out.append(lab)
                else:
                    bad.append(str(raw).strip())
            if bad:
                raise InputError(f"{where}: unknown candidate dof(s) {', '.join(bad)} (not dofs of the model "
                                 f"{model.name!r}: {model.describe_dofs()})")
            return [(d,) for d in out]
        nodes = [str(parse_dof(str(r))[0]) if ":" in str(r) else str(r).strip() for r in items]
        return _node_sensors(model, nodes, where)

    sensors = spell(given, what) if given is not None else (
        [(d,) for d in trans] if kind == "uniaxial" else _node_sensors(model, None, what))
    seen: set[tuple[str, ...]] = set()
    for s in sensors:
        if s in seen:
            raise InputError(f"{what}: candidate {s[0] if kind == 'uniaxial' else 'node ' + str(parse_dof(s[0])[0])} "
                             "given twice")
        seen.add(s)
    fixed_sensors = spell(list(fixed), "fixed sensors") if fixed else []
    for s in fixed_sensors:
        if s not in seen:
            sensors.append(s)
            seen.add(s)
    if not sensors:
        raise InputError(f"{what}: no candidate sensor")
    pos = {s: i for i, s in enumerate(sensors)}
    return Candidates(tuple(sensors), kind, tuple(dict.fromkeys(pos[s] for s in fixed_sensors)))


def read_candidates(path) -> list[str]:
    """Candidate dofs (or nodes) from a file: a JSON list of labels, or text with one label per
    line (or separated by commas; ``#`` starts a comment).

    Raises
    ------
    InputError
        The file is missing, unreadable or holds no label.
    """
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise InputError(f"{p}: candidate file not found") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"{p}: cannot read the candidate file ({exc})") from None
    if text.lstrip().startswith("["):
        try:
            items = json.loads(text)
        except json.JSONDecodeError as exc:
            raise InputError(f"{p}: not a JSON list of labels ({exc})") from None
        if not isinstance(items, list) or not all(isinstance(i, (str, int)) for i in items):
            raise InputError(f"{p}: expected a JSON list of dof labels or node ids")
        labels = [str(i) for i in items]
    else:
        labels = [tok.strip() for line in text.splitlines() for tok in line.split("#")[0].split(",") if tok.strip()]
    if not labels:
        raise InputError(f"{p}: no candidate in the file")
    return labels


__all__ = ["Candidates", "candidates", "read_candidates", "KINDS"]
