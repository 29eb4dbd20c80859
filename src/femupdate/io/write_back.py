"""Updated parameter values written back in the FE code's own language (docs/file-formats.md,
"Updated values back into the deck").

Each parameter maps to one field of one card, keyword or command:

* **explicitly**, by a ``card`` key in its ``[parameters.NAME]`` table:

  - Nastran ``"MAT1 3 E"`` (card, id, field): ``MAT1`` ``E G NU RHO``, ``PSHELL`` ``T NSM``,
    ``PBAR`` ``A I1 I2 J NSM``, ``PROD`` ``A J``, ``PELAS`` ``K GE`` (its first property); the
    card is re-written in large-field format (16 columns: eleven significant digits) in a copy
    of the deck; a ``MAT1`` with both G and NU gets G = E / 2(1 + NU) with a new E;
  - ANSYS ``"MP,EX,3"`` (a material property: ``EX``, ``DENS``, ``NUXY``, ...) or ``"R,2,1"``
    (real constant set 2, its first value): commands ``MP,EX,3,<value>`` and
    ``RMODIF,2,1,<value>`` in a macro, to run after the model is read (``/INPUT``);
  - Abaqus ``"ELASTIC STEEL"`` (E of ``*MATERIAL, NAME=STEEL``), ``"DENSITY STEEL"``, ``"SHELL
    SECTION PLATE"`` (the thickness of ``*SHELL SECTION, ELSET=PLATE``) or ``"PARAMETER E_steel"``
    (the line ``E_steel = ...`` under ``*PARAMETER``): the data line edited in a copy of the deck;

* **implicitly**, for a ``[mesh]`` model read from a Nastran or Abaqus deck: a parameter a set
  uses as ``E`` or ``rho`` goes to the set's material (``MAT1`` E or RHO of the ``PSHELL``/
  ``PSOLID``'s MID; ``*ELASTIC`` or ``*DENSITY`` of the section's material).

The deck is the ``[mesh]`` ``file`` or the ``deck`` of an ``[abaqus]``, ``[nastran]`` table; the
copy is written as ``<deck stem>_updated<suffix>`` in the folder asked for, the ANSYS commands as
``<model stem>_updated.mac``.  A parameter that maps to no card is refused by name.
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .._errors import InputError
from .model_file import read_toml
from .outputs import note_input
from .results import atomic_write_text

#: the fields of the Nastran cards a value can be written into (their positions after the id)
NASTRAN_FIELDS = {"MAT1": {"E": 1, "G": 2, "NU": 3, "RHO": 4}, "PSHELL": {"T": 2, "NSM": 7},
                  "PBAR": {"A": 2, "I1": 3, "I2": 4, "J": 5, "NSM": 6}, "PROD": {"A": 2, "J": 3},
                  "PELAS": {"K": 1, "GE": 2}}
ABAQUS_KEYWORDS = ("ELASTIC", "DENSITY", "SHELL SECTION", "PARAMETER")
_NASTRAN_SUFFIXES = {".bdf", ".dat", ".nas", ".blk", ".bulk"}


@dataclass(frozen=True)
class Edit:
    """One value to write: ``code`` (``nastran``, ``ansys``, ``abaqus``), the card or keyword,
    its id (or name), the field, the value and the parameter it comes from."""

    code: str
    card: str
    ident: str
    field: str
    value: float
    parameter: str


def _parse_card(text, pname: str, where: str) -> tuple[str, str, str, str]:
    """(code, card, id, field) of a ``card`` key."""
    if not isinstance(text, str) or not text.strip():
        raise InputError(f"{where}: card must be a string such as \"MAT1 3 E\", \"MP,EX,3\" or \"ELASTIC STEEL\"")
    s = text.strip()
    up = s.upper()
    if up.startswith(("MP,", "R,")):
        parts = [p.strip() for p in s.split(",")]
        if up.startswith("MP,") and len(parts) == 3 and parts[1] and parts[2].isdigit():
            return "ansys", "MP", parts[2], parts[1].upper()
        if up.startswith("R,") and len(parts) == 3 and parts[1].isdigit() and parts[2].isdigit() and int(parts[2]) >= 1:
            return "ansys", "R", parts[1], parts[2]
        raise InputError(f"{where}: card {text!r}: ANSYS cards are \"MP,<property>,<material id>\" or "
                         "\"R,<real constant set>,<position from 1>\"")
    for kw in ABAQUS_KEYWORDS:
        if up.startswith(kw + " ") and s[len(kw):].strip():
            return "abaqus", kw, s[len(kw):].strip(), "value"
    parts = up.split()
    if len(parts) == 3 and parts[0] in NASTRAN_FIELDS:
        if parts[2] not in NASTRAN_FIELDS[parts[0]] or not parts[1].isdigit():
            raise InputError(f"{where}: card {text!r}: {parts[0]} takes an id and one of "
                             f"{', '.join(NASTRAN_FIELDS[parts[0]])}")
        return "nastran", parts[0], parts[1], parts[2]
    raise InputError(f"{where}: card {text!r} is not one femupdate writes: Nastran \"MAT1 3 E\" (MAT1, PSHELL, PBAR, "
                     "PROD, PELAS), ANSYS \"MP,EX,3\" or \"R,2,1\", Abaqus \"ELASTIC STEEL\", \"DENSITY STEEL\", "
                     "\"SHELL SECTION PLATE\" or \"PARAMETER name\"")


def _deck(raw: Mapping, path: Path) -> tuple[Path | None, str | None]:
    """The deck of the model file and its code (``nastran``/``abaqus``), or (None, None)."""
    for table, key in (("mesh", "file"), ("abaqus", "deck"), ("nastran", "deck")):
        t = raw.get(table)
        if isinstance(t, Mapping) and isinstance(t.get(key), str):
            deck = path.parent / t[key]
            fmt = str(t.get("format", "")).lower() if table == "mesh" else table
            if not fmt:
                fmt = "abaqus" if deck.suffix.lower() == ".inp" else ("nastran" if deck.suffix.lower() in
                                                                       _NASTRAN_SUFFIXES else "")
            return deck, fmt or None
    return None, None


def _mesh_edits(raw: Mapping, deck: Path, fmt: str, values: Mapping[str, float]) -> dict[str, list[Edit]]:
    """The cards of the parameters a ``[mesh]`` set uses as E or rho (the set's deck material)."""
    from ..mesh import read_mesh

    sets = raw.get("mesh", {}).get("sets", {})
    wanted = {name: spec for name, spec in sets.items() if isinstance(spec, Mapping)
              and any(isinstance(spec.get(k), str) and spec[k] in values for k in ("E", "rho"))}
    if not wanted:
        return {}
    mesh = read_mesh(deck)
    material_of = {s.elset.upper(): s.material for s in mesh.sections}
    out: dict[str, list[Edit]] = {}
    for name, spec in wanted.items():
        mat = material_of.get(str(name).upper())
        for key, field in (("E", "E"), ("rho", "RHO")):
            pname = spec.get(key)
            if not isinstance(pname, str) or pname not in values:
                continue
            if mat is None:
                raise InputError(f"write-back: parameter {pname} ([mesh.sets.{name}] {key}) maps to no card: set "
                                 f"{name!r} has no section in {deck.name} (give the parameter a card = ...)")
            if fmt == "nastran":
                edit = Edit("nastran", "MAT1", mat, field, float(values[pname]), pname)
            else:
                edit = Edit("abaqus", "ELASTIC" if key == "E" else "DENSITY", mat, "value", float(values[pname]), pname)
            out.setdefault(pname, []).append(edit)
    return out


def plan(model_path, values: Mapping[str, float]) -> tuple[list[Edit], Path | None]:
    """The edits that write ``values`` back, and the deck they go into.

    Raises
    ------
    InputError
        A parameter of ``values`` that maps to no card (named); a ``card`` that cannot be read; a
        Nastran or Abaqus card without a deck to edit; two parameters on one field.
    """
    path = Path(model_path)
    raw = read_toml(path)
    params = raw.get("parameters", {})
    deck, fmt = _deck(raw, path)
    implicit = _mesh_edits(raw, deck, fmt, values) if "mesh" in raw and deck is not None and fmt else {}
    edits: list[Edit] = []
    missing = []
    for pname, value in values.items():
        spec = params.get(pname) if isinstance(params, Mapping) else None
        where = f"{path}: [parameters.{pname}]"
        if isinstance(spec, Mapping) and "card" in spec:
            code, card, ident, field = _parse_card(spec["card"], pname, where)
            if code != "ansys" and deck is None:
                raise InputError(f"{where}: card {spec['card']!r} is edited in the deck, but the model file names none "
                                 "(deck = \"...\" in its [nastran] or [abaqus] table, or a [mesh] file)")
            if code != "ansys" and fmt != code:
                raise InputError(f"{where}: card {spec['card']!r} is a {code.capitalize()} card, but the deck "
                                 f"{deck.name if deck else ''} is {fmt or 'of no known format'}")
            edits.append(Edit(code, card, ident, field, float(value), pname))
        elif pname in implicit:
            edits.extend(implicit[pname])
        else:
            missing.append(pname)
    if missing:
        raise InputError(f"write-back: parameter(s) {', '.join(missing)} of {path} map to no card: give each a card = "
                         "\"MAT1 3 E\" (Nastran), \"MP,EX,3\" (ANSYS) or \"ELASTIC STEEL\" (Abaqus), or use it as E or "
                         "rho of a [mesh.sets] set of a deck")
    seen: dict = {}
    for e in edits:
        key = (e.code, e.card, e.ident.upper(), e.field)
        if key in seen and seen[key].parameter != e.parameter:
            raise InputError(f"write-back: parameters {seen[key].parameter} and {e.parameter} both write "
                             f"{e.card} {e.ident} {e.field}")
        seen[key] = e
    return edits, deck


# ---------------------------------------------------------------------------------- Nastran
def _large(v: float) -> str:
    """A real in 16 columns, eleven significant digits (ten when negative)."""
    text = f"{v:.10E}" if v >= 0 else f"{v:.9E}"
    if len(text) > 16:  # a three-digit exponent
        text = f"{v:.9E}" if v >= 0 else f"{v:.8E}"
    return text


def _card_lines(lines: list[str]) -> list[tuple[int, int]]:
    """(first line, end line) of each bulk card of a deck's own lines (continuations joined)."""
    spans: list[list[int]] = []
    for i, raw in enumerate(lines):
        line = raw.split("$", 1)[0].rstrip()
        if not line.strip():
            continue
        head = line.split(",", 1)[0].strip() if "," in line else line[:8].strip()
        if head[:1] in ("+", "*") or (head == "" and spans):
            if spans:
                spans[-1][1] = i + 1
            continue
        spans.append([i, i + 1])
    return [(a, b) for a, b in spans]


def _nastran_deck(deck: Path, edits: list[Edit]) -> str:
    from ..mesh.nastran import _fields

    lines = deck.read_text(encoding="utf-8").splitlines()
    todo: dict[tuple[str, int], list[Edit]] = {(e.card, int(e.ident)): [] for e in edits}
    for e in edits:
        todo[(e.card, int(e.ident))].append(e)
    out_spans: dict[int, tuple[int, list[str]]] = {}
    found = set()
    for a, b in _card_lines(lines):
        head, data, _ = _fields(lines[a].split("$", 1)[0].rstrip().expandtabs(8))
        name = head.rstrip("*").upper()
        if name not in NASTRAN_FIELDS or not data or not data[0].strip().isdigit():
            continue
        key = (name, int(data[0]))
        if key not in todo:
            continue
        for k in range(a + 1, b):
            data = data + _fields(lines[k].split("$", 1)[0].rstrip().expandtabs(8))[1]
        while data and data[-1] == "":
            data.pop()
        for e in todo[key]:
            pos = NASTRAN_FIELDS[name][e.field]
            data += [""] * (pos + 1 - len(data))
            data[pos] = _large(e.value)
            if name == "MAT1" and e.field == "E" and len(data) > 3 and data[2] and data[3]:
                from ..mesh.nastran import real

                data[2] = _large(e.value / (2 * (1 + real(data[3], f"{deck.name}: MAT1 {key[1]} NU"))))  # G = E/2(1+ν)
        found.add(key)
        out_spans[a] = (b, _large_card(name, data))
    lost = [f"{c} {i}" for c, i in todo if (c, i) not in found]
    if lost:
        raise InputError(f"write-back: {deck} has no card {', '.join(lost)} (in the deck's own lines; cards of an "
                         "INCLUDE file are not edited)")
    text, i = [], 0
    while i < len(lines):
        if i in out_spans:
            end, new = out_spans[i]
            span = f"line {i + 1}" if end == i + 1 else f"lines {i + 1}-{end}"
            text += [f"$ femupdate: updated {lines[i].split(',')[0].split()[0].rstrip('*').upper()} (was {span})"] + new
            i = end
        else:
            text.append(lines[i])
            i += 1
    return "\n".join(text) + "\n"


def _large_card(name: str, data: list[str]) -> list[str]:
    """A card in large-field format: ``NAME*`` and four 16-column fields a line, ``*`` continuations."""
    rows = [data[i:i + 4] for i in range(0, max(len(data), 1), 4)]
    out = []
    for k, row in enumerate(rows):
        first = f"{name}*" if k == 0 else "*"
        long = [v.strip() for v in row if len(v.strip()) > 16]
        if long:
            raise InputError(f"write-back: {name} field {long[0]!r} is longer than the 16 columns of a large field")
        out.append(f"{first:<8s}" + "".join(f"{v.strip():<16s}" for v in row).rstrip())
    return out


# ---------------------------------------------------------------------------------- Abaqus
def _abaqus_deck(deck: Path, edits: list[Edit]) -> str:
    lines = deck.read_text(encoding="utf-8").splitlines()
    pending = {(e.card, e.ident.upper()): e for e in edits}
    done: set[tuple[str, str]] = set()
    material = None
    for i, raw in enumerate(lines):
        s = raw.strip()
        if not s.startswith("*") or s.startswith("**"):
            continue
        parts = [p.strip() for p in s[1:].split(",")]
        kw = " ".join(parts[0].upper().split())
        opts = {" ".join(k.upper().split()): v.strip() for k, _, v in (p.partition("=") for p in parts[1:] if p)}
        if kw == "MATERIAL":
            material = opts.get("NAME", "").upper()
        if kw in ("ELASTIC", "DENSITY") and material is not None:
            target = (kw, material)
        elif kw == "SHELL SECTION":
            target = (kw, opts.get("ELSET", "").upper())
        elif kw == "PARAMETER":
            _parameters(lines, i, pending, done)
            continue
        else:
            continue
        if target in pending:
            j = _data_line(lines, i, deck)
            fields = lines[j].split(",")
            fields[0] = repr(pending[target].value)
            lines[j] = ", ".join(f.strip() for f in fields).rstrip()
            done.add(target)
    lost = [f"*{k} {n}" for k, n in pending if (k, n) not in done]
    if lost:
        raise InputError(f"write-back: {deck} has no {', '.join(lost)} to edit")
    return "\n".join(lines) + "\n"


def _data_line(lines: list[str], i: int, deck: Path) -> int:
    for j in range(i + 1, len(lines)):
        s = lines[j].strip()
        if s and not s.startswith("**"):
            if s.startswith("*"):
                break
            return j
    raise InputError(f"write-back: {deck}: line {i + 1} ({lines[i].strip()[:40]}) has no data line to edit")


def _parameters(lines: list[str], i: int, pending: dict, done: set) -> None:
    """The ``name = value`` lines of a ``*PARAMETER`` block."""
    for j in range(i + 1, len(lines)):
        s = lines[j].strip()
        if s.startswith("*") and not s.startswith("**"):
            return
        m = re.match(r"\s*([A-Za-z_]\w*)\s*=", lines[j])
        if m and ("PARAMETER", m.group(1).upper()) in pending:
            lines[j] = f"{m.group(1)} = {pending[('PARAMETER', m.group(1).upper())].value!r}"
            done.add(("PARAMETER", m.group(1).upper()))


# ---------------------------------------------------------------------------------- ANSYS
def _ansys_commands(model_path: Path, edits: list[Edit]) -> str:
    out = [f"! femupdate: updated values of {model_path.name}; run after the model is read (/INPUT,<this file>)",
           "/PREP7"]
    for e in edits:
        if e.card == "MP":
            out.append(f"MP,{e.field},{e.ident},{e.value!r}   ! {e.parameter}")
        else:
            out.append(f"RMODIF,{e.ident},{e.field},{e.value!r}   ! {e.parameter}")
    return "\n".join(out) + "\n"


def write_back(model_path, values: Mapping[str, float], out_dir) -> list[Path]:
    """Write ``values`` (updated parameters) back into the FE code's input (module docstring).

    Parameters
    ----------
    model_path : str or os.PathLike
        femupdate's model file (TOML) the update used.
    values : mapping of str to float
        The parameters to write and their values (an update's ``parameters`` of its ``updated``).
    out_dir : str or os.PathLike
        The folder the files go into (made if missing).

    Returns
    -------
    list of pathlib.Path
        The files written.

    Raises
    ------
    InputError
        As :func:`plan`; a value that is not finite; a card the deck does not have.
    """
    model_path, out_dir = Path(model_path), Path(out_dir)
    for k, v in values.items():
        if not np.isfinite(float(v)):
            raise InputError(f"write-back: {k} = {v} is not a finite number")
    edits, deck = plan(model_path, values)
    out_dir.mkdir(parents=True, exist_ok=True)
    written = []
    deck_edits = [e for e in edits if e.code != "ansys"]
    if deck_edits and deck is not None:
        note_input(deck, "the deck")  # a link named like the output must not lead back to it
        target = out_dir / f"{deck.stem}_updated{deck.suffix}"
        text = _nastran_deck(deck, deck_edits) if deck_edits[0].code == "nastran" else _abaqus_deck(deck, deck_edits)
        atomic_write_text(target, text)
        written.append(target)
    ansys = [e for e in edits if e.code == "ansys"]
    if ansys:
        target = out_dir / f"{model_path.stem}_updated.mac"
        atomic_write_text(target, _ansys_commands(model_path, ansys))
        written.append(target)
    return written




def result_values(result) -> dict[str, float]:
    """The values an update result identified: its ``parameters`` of its ``updated`` (``update``,
    ``frf-update``; ``unknowns`` of ``direct``), from a result object, a JSON result (dict) or the
    path of one (``--json``).

    Raises
    ------
    InputError
        Not a result with ``parameters``; a run that did not succeed.
    """
    from ..serialise import _read, check_version

    obj = result.to_json() if hasattr(result, "to_json") else _read(result)
    check_version(obj)
    where = str(result) if isinstance(result, (str, Path)) else "the result"
    params = obj.get("parameters")
    if not isinstance(params, Mapping) or not params:
        raise InputError(f"{where}: no parameters (write-back reads the JSON of update, frf-update or direct)")
    if obj.get("success") is False:
        raise InputError(f"{where}: the run did not succeed: nothing to write back")
    names = obj.get("updated") or obj.get("unknowns") or list(params)
    if not isinstance(names, list) or not all(isinstance(n, str) and n in params for n in names):
        raise InputError(f"{where}: its updated parameters {names!r} are not all in its parameters")
    return {n: float(params[n]) for n in names}


__all__ = ["Edit", "plan", "write_back", "result_values", "NASTRAN_FIELDS", "ABAQUS_KEYWORDS"]
