"""Build and write the HTML report: kind of result, recomputation, sections, template."""

from __future__ import annotations

import base64
import datetime as _dt
import json
import logging
import os
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from .._checks import path_arg, result_arg
from .._errors import FemupdateError, InputError
from .._version import __version__
from .content import BUILDERS, KINDS, WITH_IMAGES
from .document import Document

log = logging.getLogger(__name__)

#: the kinds of result a report is made of: kind -> the command that writes it
REPORT_KINDS = dict(KINDS)

_OBJ, _LIST, _NUM, _STR = "an object", "a list", "a number", "a text"
#: the JSON type of each top-level key the report reads, as the commands write it (null is
#: accepted everywhere: a key that is null or absent leaves its table out)
RESULT_KEYS: dict[str, tuple[str, ...]] = {
    **dict.fromkeys(("start", "standard_error", "baseline", "changes", "bounds", "parameter_units", "frequencies_hz",
                     "diagnostics", "pairing", "verification", "units", "truth", "sections", "confidence",
                     "conditioning", "frac", "descriptions", "criteria_agreement", "baseline_check", "damping_ratio"),
                    (_OBJ,)),
    **dict.fromkeys(("pairs", "updated", "flags", "history", "notes", "omega_rad_s", "located", "cases",
                     "configurations", "natural_frequencies_hz", "frequency_change", "doubts"), (_LIST,)),
    **dict.fromkeys(("condition_number", "cost", "iterations", "nfev", "n_equations"), (_NUM,)),
    **dict.fromkeys(("model", "residual", "message", "formulation", "method", "sensitivity", "kind"), (_STR,)),
    "schema_version": (_NUM,),
    "parameters": (_OBJ, _LIST), "starts": (_OBJ, _NUM), "unknowns": (_LIST, _STR),
}
#: {name: value} objects of parameters: what each value must be
_PER_PARAMETER = {"parameters": (_NUM,), "start": (_NUM,), "standard_error": (_NUM,), "baseline": (_NUM,),
                  "changes": (_NUM,), "parameter_units": (_STR,), "bounds": (_LIST,)}


def _json_type(v) -> str:
    if isinstance(v, Mapping):
        return _OBJ
    if isinstance(v, list):
        return _LIST
    if isinstance(v, (int, float)) and not isinstance(v, bool):
        return _NUM
    if isinstance(v, str):
        return _STR
    return "true/false" if isinstance(v, bool) else type(v).__name__


def check_result(result: Mapping) -> None:
    """Check that the keys a report reads hold what the commands write (docs/file-formats.md):
    each top-level key's JSON type, the values of the per-parameter objects, the entries of
    ``pairs``, ``notes``, ``flags`` and ``updated``, and the lists of ``frequencies_hz``.

    Raises
    ------
    InputError
        Naming the key (a JSON pointer such as ``/pairs/2``) and what it holds instead.
    """
    def bad(where: str, want: str, v) -> InputError:
        shown = json.dumps(v)[:60] if not isinstance(v, float) or np.isfinite(v) else repr(v)
        return InputError(f"{where}: expected {want}, got {_json_type(v)} ({shown}); the report reads the keys as "
                          "femupdate writes them (docs/file-formats.md)")

    for key, want in RESULT_KEYS.items():
        v = result.get(key)
        if v is not None and _json_type(v) not in want:
            raise bad(f"/{key}", " or ".join(want), v)
    for key, want in _PER_PARAMETER.items():
        obj = result.get(key)
        if isinstance(obj, Mapping):
            for name, v in obj.items():
                if v is not None and _json_type(v) not in want:
                    raise bad(f"/{key}/{name}", " or ".join(want), v)
                if key == "bounds" and v is not None and (len(v) != 2 or any(
                        b is not None and _json_type(b) != _NUM for b in v)):
                    raise bad(f"/bounds/{name}", "[lower, upper] (numbers or null)", v)
    for i, p in enumerate(result.get("pairs") or []):
        if not (isinstance(p, list) and len(p) == 3 and all(_json_type(x) == _NUM and float(x).is_integer() and x >= 0
                                                            for x in p[:2])
                and (p[2] is None or _json_type(p[2]) == _NUM)):
            raise bad(f"/pairs/{i}", "[test mode, model mode, MAC] (indices from 0, MAC a number or null)", p)
    for key, kind in (("notes", _STR), ("updated", _STR), ("flags", _OBJ)):
        for i, v in enumerate(result.get(key) or []):
            if _json_type(v) != kind:
                raise bad(f"/{key}/{i}", kind, v)
    for side, v in (result.get("frequencies_hz") or {}).items():
        if side in ("test", "model") and v is not None:
            if _json_type(v) != _LIST:
                raise bad(f"/frequencies_hz/{side}", "a list", v)
            for i, f in enumerate(v):
                if f is not None and _json_type(f) != _NUM:
                    raise bad(f"/frequencies_hz/{side}/{i}", "a number or null", f)


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
    if result.get("kind") in REPORT_KINDS:  # written by femupdate with its kind
        return str(result["kind"])
    if {"sections", "paper"} <= keys:
        return "paper"
    if "cases" in keys and "criteria_agreement" in keys or "cases" in keys and "study_key" in keys:
        return "uniqueness"
    if {"located", "changes"} <= keys:
        return "damage"
    if {"solutions", "interval", "median"} <= keys:
        return "posterior"
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


def check_kind(result: Mapping, kind: str | None, where: str = "") -> str:
    """The kind of ``result``: ``kind`` where given and not contradicted by the keys (a result
    of another command is refused: its report would be empty or wrong), else told from the keys.

    Raises
    ------
    InputError
        ``kind`` None and the keys match no kind; ``kind`` given and the keys are another
        command's (``update`` and ``frf-update`` are reported alike and taken for each other).
    """
    stated = result.get("kind")
    if stated in REPORT_KINDS:  # the file's own kind: its keys must not be another command's
        try:
            by_keys = detect_kind({k: v for k, v in result.items() if k != "kind"})
        except InputError:
            by_keys = None
        if by_keys is not None and BUILDERS[by_keys] is not BUILDERS[stated]:
            raise InputError(f"{where}/kind: {stated!r}, but the keys are those of the result of {by_keys}: the report "
                             f"would be empty or wrong; was the file edited?")
    try:
        told = detect_kind(result)
    except InputError as exc:
        if kind is None:
            raise InputError(f"{where}{exc}") from None
        return kind  # keys of no known kind: the caller says which it is
    if kind is not None and BUILDERS[kind] is not BUILDERS[told]:
        raise InputError(f"{where}the result of {told}, not of {kind} (told from its keys); leave the kind out")
    return kind or told


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

    where = ""
    if isinstance(result, (str, Path)):
        path = Path(result)
        where = f"{path}: "
        from ..io.outputs import note_input

        note_input(path, "the result file")
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
        except RecursionError:
            raise InputError(f"{path}: JSON nested too deeply") from None
    if not isinstance(result, Mapping):
        raise InputError(f"{where}a result must be a JSON object, got {_json_type(result)}")
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
                 damping=None, images: Mapping | None = None, source: str = "", title: str | None = None,
                 test_points=None) -> str:
    """The HTML report of a run, as text.

    Parameters
    ----------
    result : result object, mapping, str or os.PathLike
        The run's result: a result object (:mod:`femupdate.serialise`: its JSON, and by default
        the model, data, starting values and damping it carries), its JSON (as ``--json`` writes
        it), or the path of its file.
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
        For ``paper``: {section: [embedded figure]} (:func:`paper_images`); for ``posterior``:
        the figures of its samples (:func:`femupdate.report.posterior.sample_figures`).  Default:
        a result object's own (``report_images()``: a paper's figures beside its file, a
        posterior's samples).
    source : str, optional
        Where the result came from (shown in the header).
    title : str, optional
        The page title (default from the model and the kind).
    test_points : MappedTest, optional
        When ``model`` is a model test points were placed on (``map_test_data(...).model``,
        :func:`femupdate.testpoints.map_test_data`): its map, so that the mode shapes are drawn on
        the structure's own dofs, ``u = T q`` (without it the mesh dofs the test points replaced
        would be drawn at zero).

    Returns
    -------
    str
        One HTML document; every figure embedded, nothing loaded from elsewhere.

    Raises
    ------
    InputError
        A result that is not a JSON object or not of a known kind; an unknown ``kind``, or one
        its keys contradict; a key that does not hold what the commands write
        (:func:`check_result`, or the builders failing on it); a model without the result's
        parameters or test data without its paired test modes (:func:`check_model_and_data`).
    """
    from ..serialise import Serialisable, check_version

    _model_and_data_args(model, data, "build_report")
    if isinstance(result, Serialisable):  # a typed result: its JSON, and the model and data it carries
        ctx = result.run_context
        model = model if model is not None else ctx.model
        data = data if data is not None else ctx.data
        before = before if before is not None else ctx.before
        damping = damping if damping is not None else ctx.damping
        if images is None and hasattr(result, "report_images"):  # figures of what the JSON does not hold
            images = result.report_images()
        result = result.to_json()
        if kind is None and result["kind"] not in REPORT_KINDS:
            kind = _report_kind(result)
    res = _jsonable(result)
    where = f"{source}: " if source else ""
    if kind is not None and kind not in BUILDERS:
        raise InputError(f"unknown report kind {kind!r}; known: {', '.join(REPORT_KINDS)}")
    try:
        check_version(res)
    except InputError as exc:
        raise InputError(f"{where}{exc}") from None
    kind = check_kind(res, kind, where)
    try:
        check_result(res)
    except InputError as exc:
        raise InputError(f"{where}{exc}") from None
    check_model_and_data(res, kind, model, data)
    try:
        return _build(res, kind, model, data, segments, before, damping, images, source, title, test_points)
    except FemupdateError:
        raise
    except (KeyError, IndexError, TypeError, ValueError, AttributeError, ArithmeticError) as exc:  # not checked above
        log.debug("the report failed on the result", exc_info=True)
        raise InputError(f"{where}the {kind} result is not as femupdate writes it ({type(exc).__name__}: {exc}); was "
                         "the file edited, or written by another program?") from None


def _report_kind(result: Mapping) -> str:
    """The report kind of a typed result whose own kind has no report of its name (a ``demo``
    result is a ``direct`` one); refused, naming its kind, when there is none."""
    try:
        return detect_kind({k: v for k, v in result.items() if k != "kind"})
    except InputError:
        raise InputError(f"results of kind {result['kind']!r} have no report (reports are made of the results of "
                         f"{', '.join(REPORT_KINDS)})") from None


def check_model_and_data(res: Mapping, kind: str, model, data, model_what: str = "", data_what: str = "") -> None:
    """Refuse a model without the result's parameters and test data without the result's test
    modes (the report would show another model's correlation, or fail on a missing mode).

    Parameters
    ----------
    res : mapping
        The JSON result.
    kind : str
        Its kind (:data:`REPORT_KINDS`).
    model : Model or None
    data : TestData or None
    model_what, data_what : str
        How the messages name the model and the data (e.g. ``"--model m.toml: "``).

    Raises
    ------
    InputError
        A result parameter the model lacks, or a model parameter an update or direct result
        lacks (it holds every parameter of its model); a paired test mode the data lack.
    """
    if model is not None and kind in ("direct", "update", "frf-update", "damage"):
        given = res.get("changes") if kind == "damage" else res.get("parameters")
        names = list(given) if isinstance(given, (Mapping, list)) else []
        missing = [str(n) for n in names if n not in model.parameter_names]
        if missing:
            raise InputError(f"{model_what}the model {model.name!r} has no parameter(s) {', '.join(missing[:6])} of the result "
                             f"(its parameters: {', '.join(model.parameter_names[:6])}): is it the model of this run?")
        extra = [n for n in model.parameter_names if n not in names] if kind != "damage" and names else []
        if extra:  # an update or direct result holds every parameter of its model
            raise InputError(f"{model_what}the model {model.name!r} has parameter(s) {', '.join(extra[:6])} the result "
                             f"does not have (its parameters: {', '.join(map(str, names[:6]))}): is it the model of this "
                             "run?")
    if data is not None and kind in ("direct", "update", "frf-update", "damage"):
        tested = [int(p[0]) for p in res.get("pairs") or []]
        if tested and max(tested) >= len(data.modes):
            raise InputError(f"{data_what}the result pairs test mode {max(tested) + 1}, but the test data hold {len(data.modes)} "
                             f"mode(s): are they the test data of this run?")


def _build(res: dict, kind: str, model, data, segments, before, damping, images, source, title,
           test_points=None) -> str:
    """:func:`build_report` once the result is checked."""
    if model is not None and kind != "paper":
        _describe_parameters(res, model)
    rec = None
    if model is not None and kind not in ("paper", "uniqueness", "update-multi", "posterior", "plan"):
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
        rec.test_points = test_points
    name = res.get("model") or (model.name if model is not None else "")
    doc = Document(title=title or (f"{name}: {kind}" if name else kind), kind=REPORT_KINDS[kind], source=source)
    if kind in WITH_IMAGES:
        BUILDERS[kind](doc, res, model, data, rec, segments, kind, images=images)  # type: ignore[call-arg]
    else:
        BUILDERS[kind](doc, res, model, data, rec, segments, kind)
    if test_points is not None and not any(sec.id == "test-points" for sec in doc.sections):
        from .testpoints import test_points_section  # every kind's report shows where the test points went

        tp = test_points_section({"test_points": res.get("test_points") or test_points.to_json()}, model, segments)
        if tp is not None:
            doc.sections.append(tp)
    if rec is not None:
        doc.notes.extend(rec.notes)
    if isinstance(res.get("reduced_basis"), Mapping):  # an update on a reduced model (femupdate.rom)
        from .rom import reduced_basis_section

        doc.sections.append(reduced_basis_section(res["reduced_basis"]))
    from .parts import notes_section

    doc.sections.append(notes_section(doc))
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

    path_arg(path, "path", "write_report")
    result_arg(result, "result", "write_report")
    _model_and_data_args(kw.get("model"), kw.get("data"), "write_report")
    if isinstance(result, (str, os.PathLike)):
        _not_over_the_result(path, result)
    html = build_report(result, **kw)
    atomic_write_text(path, html)
    return Path(path)


def _model_and_data_args(model, data, where: str) -> None:
    """A :class:`TypeError` naming ``model`` or ``data`` when given and not a Model, TestData or
    FRFData (a file name is told its loader)."""
    from .._checks import data_arg, model_arg

    if model is not None:
        model_arg(model, "model", where)
    data_arg(data, "data", where, frf=True, optional=True)


def _not_over_the_result(path, result) -> None:
    """Refuse a report path that is the result file it reads (by any name: :func:`os.path.samefile`),
    and a report's name given for the result with a JSON file's for the report (swapped)."""
    try:
        same = os.path.samefile(path, result)
    except (OSError, ValueError):
        same = False
    if same:
        raise InputError(f"write_report: path {path} is the result file {result} it reads: writing there would destroy "
                         "it; give the report another name")
    if Path(result).suffix.lower() in (".html", ".htm") and Path(path).suffix.lower() == ".json":
        raise InputError(f"write_report: the arguments look swapped: path {path} is a JSON file and result {result} "
                         "an HTML file's name; call write_report(report_path, result)")
