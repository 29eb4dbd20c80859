"""Build and write the HTML report: kind of result, recomputation, sections, template."""

from __future__ import annotations

import base64
import datetime as _dt
import json
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from .._errors import InputError
from .._version import __version__
from .content import BUILDERS, KINDS
from .document import Document

#: the kinds of result a report is made of: kind -> the command that writes it
REPORT_KINDS = dict(KINDS)


def detect_kind(result: Mapping) -> str:
    """The command whose JSON result ``result`` is, from its keys (docs/file-formats.md).

    Parameters
    ----------
    result : mapping
        A JSON result as written by ``--json``.

    Returns
    -------
    str
        One of :data:`REPORT_KINDS`.

    Raises
    ------
    InputError
        The keys match no command a report is made of (the message lists them).
    """
    keys = set(result)
    if {"sections", "paper"} <= keys:
        return "paper"
    if "cases" in keys and "criteria_agreement" in keys or "cases" in keys and "study_key" in keys:
        return "uniqueness"
    if {"located", "changes"} <= keys:
        return "damage"
    if {"configurations", "conditioning"} <= keys:
        return "update-multi"
    if "n_equations" in keys and "condition_number" in keys:
        return "direct"
    if "formulation" in keys:
        return "update"
    if "starts" in keys and ({"frac", "residual", "omega_rad_s", "global"} & keys):
        return "frf-update"
    if "starts" in keys and "success" in keys:
        return "update"
    shown = ", ".join(sorted(keys)[:12]) or "none"
    raise InputError(f"not the JSON result of {', '.join(REPORT_KINDS)} (its keys: {shown})")


def paper_images(folder, result: Mapping) -> dict[str, list[dict]]:
    """The figures ``femupdate paper`` wrote beside ``paper.json``, as embedded PNGs per section.

    Parameters
    ----------
    folder : str or os.PathLike
        The ``--out`` folder.
    result : mapping
        The paper's JSON (``{"sections": {name: {...}}}``): each section's ``figure`` or
        ``figure_file`` that names a PNG file, else ``<section>.png``.

    Returns
    -------
    dict
        {section: [{"png": data URI}, ...]} for the files that exist.
    """
    out: dict[str, list[dict]] = {}
    folder = Path(folder)
    for name, sec in (result.get("sections") or {}).items():
        names = [v for k in ("figure", "figure_file") for v in [sec.get(k)] if isinstance(v, str) and v.endswith(".png")]
        names = list(dict.fromkeys(names or [f"{name}.png"]))
        for n in names:
            p = folder / Path(n).name
            if p.is_file():
                out.setdefault(name, []).append(
                    {"png": "data:image/png;base64," + base64.b64encode(p.read_bytes()).decode("ascii")})
    return out


def _jsonable(result) -> dict:
    """The result as its JSON file holds it (NumPy values, NaN and inf converted as ``--json`` does)."""
    from ..io.results import to_jsonable

    if isinstance(result, (str, Path)):
        path = Path(result)
        try:
            text = path.read_text(encoding="utf-8")
        except FileNotFoundError:
            raise InputError(f"{path}: no such file") from None
        except IsADirectoryError:
            raise InputError(f"{path}: is a directory, not a result file") from None
        except UnicodeDecodeError:
            raise InputError(f"{path}: not a text (UTF-8) JSON file") from None
        try:
            result = json.loads(text)
        except json.JSONDecodeError as exc:
            raise InputError(f"{path}: not valid JSON: {exc}") from None
    if not isinstance(result, Mapping):
        raise InputError(f"a result must be a JSON object, got {type(result).__name__}")
    return to_jsonable(dict(result))


def _describe_parameters(res: dict, model) -> None:
    """Units and bounds from the model where the result (written by an older version) lacks them."""
    par = {p.name: p for p in model.parameters}
    given = res.get("parameters")
    names = [n for n in (given if isinstance(given, Mapping) else dict.fromkeys(given or [])) if n in par]
    if "parameter_units" not in res:
        res["parameter_units"] = {n: par[n].unit or None for n in names}
    if "bounds" not in res:
        res["bounds"] = {n: [v if np.isfinite(v) else None for v in par[n].bounds] for n in names}


def _values(model, given) -> dict | None:
    if given is None:
        return None
    return {n: float(v) for n, v in zip(model.parameter_names, model.resolve(dict(given)))}


def build_report(result, *, model=None, data=None, kind: str | None = None, segments=None, before=None,
                 damping=None, images: Mapping | None = None, source: str = "", title: str | None = None) -> str:
    """The HTML report of a run, as text.

    Parameters
    ----------
    result : mapping, str or os.PathLike
        The run's JSON result (as ``--json`` writes it), or the path of its file.
    model : Model, optional
        The model of the run (for a ``damage`` run: the element-wise model the result names,
        :func:`femupdate.damage.damage_unknowns`).  With ``data``: the correlation before the
        update, MAC matrices, mode shapes, FRF overlays and residual surfaces.
    data : TestData, optional
        The test data of the run.
    kind : str, optional
        One of :data:`REPORT_KINDS` (default: told from the result's keys, :func:`detect_kind`).
    segments : array_like of int, shape ``(s, 2)``, optional
        Node-id pairs of the model's elements for the mode-shape drawings
        (:func:`femupdate.fullfield.structure_segments`; default: from the stiffness couplings).
    before : mapping, optional
        Parameter values of the model before the run (default: the model's own values; a
        ``damage`` run: its ``baseline``).
    damping : mapping, optional
        Damping of an FRF run ({alpha, beta, eta}) for the FRF overlays (default undamped).
    images : mapping, optional
        For ``paper``: {section: [embedded figure]} (:func:`paper_images`).
    source : str, optional
        Where the result came from (shown in the header).
    title : str, optional
        The page title (default from the model and the kind).

    Returns
    -------
    str
        One HTML document; every figure embedded, nothing loaded from elsewhere.

    Raises
    ------
    InputError
        A result that is not a JSON object or not of a known kind; an unknown ``kind``.
    """
    res = _jsonable(result)
    kind = kind or detect_kind(res)
    if kind not in BUILDERS:
        raise InputError(f"unknown report kind {kind!r}; known: {', '.join(REPORT_KINDS)}")
    if model is not None and kind != "paper":
        _describe_parameters(res, model)
    rec = None
    if model is not None and kind not in ("paper", "uniqueness", "update-multi"):
        from .recompute import recompute

        after = res.get("parameters") if isinstance(res.get("parameters"), Mapping) else None
        if kind == "damage":
            start = before if before is not None else res.get("baseline")
        else:
            start = before if before is not None else {p.name: p.value for p in model.parameters}
        known = set(model.parameter_names)
        after = {k: v for k, v in (after or {}).items() if k in known and v is not None} or None
        start = {k: v for k, v in (start or {}).items() if k in known and v is not None} or None
        pairing = (res.get("pairing") or {}).get("policy", "auto") if isinstance(res.get("pairing"), Mapping) else "auto"
        rec = recompute(model, data, _values(model, start), _values(model, after), res, pairing=pairing, damping=damping)
    name = res.get("model") or (model.name if model is not None else "")
    doc = Document(title=title or (f"{name}: {kind}" if name else kind), kind=REPORT_KINDS[kind], source=source)
    if kind == "paper":
        BUILDERS[kind](doc, res, model, data, rec, segments, kind, images=images)  # type: ignore[call-arg]
    else:
        BUILDERS[kind](doc, res, model, data, rec, segments, kind)
    if rec is not None:
        doc.notes.extend(rec.notes)
    from .content import _notes_section

    doc.sections.append(_notes_section(doc))
    return _render(doc, res)


def _render(doc: Document, result: Mapping) -> str:
    import jinja2

    env = jinja2.Environment(loader=jinja2.PackageLoader("femupdate.report", "templates"),
                             autoescape=jinja2.select_autoescape(["html", "j2"]), trim_blocks=True, lstrip_blocks=True,
                             undefined=jinja2.StrictUndefined)
    template = env.get_template("report.html.j2")
    stamp = _dt.datetime.now(_dt.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    return template.render(doc=doc, version=__version__, stamp=stamp, markup=jinja2.utils.markupsafe.Markup)


def write_report(path, result, **kw) -> Path:
    """Write :func:`build_report` to ``path`` atomically (a temporary file renamed over it).

    Parameters
    ----------
    path : str or os.PathLike
        The HTML file.
    result : mapping, str or os.PathLike
        As :func:`build_report`.
    **kw
        As :func:`build_report`.

    Returns
    -------
    pathlib.Path
        ``path``.
    """
    from ..io.results import atomic_write_text

    html = build_report(result, **kw)
    atomic_write_text(path, html)
    return Path(path)
