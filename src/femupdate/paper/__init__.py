"""Reproduction of the reference paper's numbered results (``femupdate paper``).

Each section is a function ``(out_dir, figures) -> dict`` registered in :data:`SECTIONS`; the
dict holds the computed values, the paper's printed values where there are any, a one-line
``summary``, ``agrees_with_paper`` (True or False, never None) and ``comparison``: ``"agree"``,
``"differ-explained"`` (with the ``explanation``) or ``"not-comparable"`` (with why, in
``explanation``).  Later capabilities add their sections to the same registry.

:func:`run_sections` runs the sections in worker processes (one per core by default), the
longest first, and reports each finished section to a ``progress`` callback.
"""

from __future__ import annotations

import json
from pathlib import Path

from ..io.results import to_jsonable
from ..serialise import RunContext
from .result import PaperResult


def _discover() -> dict:
    """Sections of every ``*_sections`` module of this package, ordered by the modules' ``ORDER``.

    A section module defines ``ORDER`` (an int: its place in ``paper.json``) and ``SECTIONS``
    ({name: function(out_dir, figures) -> dict}).
    """
    import importlib
    import pkgutil

    mods = [importlib.import_module(f"{__name__}.{m.name}") for m in pkgutil.iter_modules(__path__)
            if m.name.endswith("_sections")]
    out: dict = {}
    for mod in sorted(mods, key=lambda m: (getattr(m, "ORDER", 1000), m.__name__)):
        for name, fn in mod.SECTIONS.items():
            if name in out:
                raise RuntimeError(f"paper section {name!r} is defined twice")
            out[name] = fn
    return out


SECTIONS = _discover()


TITLE = "Issues concerning the updating of finite-element models from experimental data"


def _no_constant(name: str):
    raise ValueError(f"{name} is not a number femupdate writes")


def previous_sections(path, notes: list) -> dict:
    """The sections of an existing ``paper.json`` that can be kept: known names, each an object
    with a ``summary`` text and ``agrees_with_paper`` true, false or null.

    A file that is unreadable, malformed or not written by ``femupdate paper`` is ignored, and so
    is every section that is unknown or not as femupdate writes it; each is said in ``notes``.
    """
    path = Path(path)
    if not path.exists():
        return {}
    try:
        doc = json.loads(path.read_text(), parse_constant=_no_constant)
    except RecursionError:
        doc, why = None, "nested too deeply"
    except (OSError, ValueError) as exc:  # malformed JSON, not UTF-8, NaN, an integer too long
        doc, why = None, str(exc)
    else:
        why = "not written by femupdate paper"
    if not isinstance(doc, dict) or doc.get("paper") != TITLE or not isinstance(doc.get("sections"), dict):
        notes.append(f"existing {path} ignored and replaced ({why})")
        return {}
    kept, dropped = {}, []
    for name, sec in doc["sections"].items():
        if (name in SECTIONS and isinstance(sec, dict) and isinstance(sec.get("summary"), str)
                and "agrees_with_paper" in sec and any(sec["agrees_with_paper"] is v for v in (True, False, None))):
            kept[name] = sec
        else:
            dropped.append(name)
    if dropped:
        notes.append(f"existing {path}: section(s) {', '.join(map(repr, dropped))} ignored (unknown, or not as femupdate "
                     "paper writes them)")
    return kept


COMPARISONS = ("agree", "differ-explained", "not-comparable")

#: sections that share a cache and run best in one worker, in this order
GROUPS = (("figure6_frf_surface", "figure7_frf_surface"),)

#: CPU seconds each section took on the reference machine (2 cores, idle), to start the longest first
COST = {"six_dof_uniqueness": 7.0, "damage_cantilever_vs_free": 5.4, "modal_vs_frf_convergence": 5.5,
        "figure7_frf_surface": 2.8, "noise_modal_vs_frf": 3.6, "noise_frf_lines": 3.0, "reduction_truss": 2.9,
        "eigenvector_derivatives": 2.7, "perturbed_boundary": 1.8}


def checked(name: str, sec: dict) -> dict:
    """A section's result with ``comparison`` set and checked (``agrees_with_paper`` True or False)."""
    agrees = sec.get("agrees_with_paper")
    if agrees is not True and agrees is not False:
        raise RuntimeError(f"paper section {name!r}: agrees_with_paper must be true or false, got {agrees!r}")
    comp = sec.setdefault("comparison", "agree" if agrees else "differ-explained")
    if comp not in COMPARISONS or (comp == "agree") != agrees:
        raise RuntimeError(f"paper section {name!r}: comparison {comp!r} does not fit agrees_with_paper {agrees}")
    if comp != "agree" and not (sec.get("explanation") or sec.get("finding")):
        raise RuntimeError(f"paper section {name!r}: {comp} without an explanation")
    if comp != "agree":
        sec.setdefault("explanation", sec.get("finding"))
    return sec


def _run_group(names, out_dir, figures):
    """Run sections in this process (a worker, or the caller), one BLAS thread: [(name, result, seconds)]."""
    import time

    from ..sensitivity.factor import single_thread_blas

    out = []
    with single_thread_blas():
        for name in names:
            t0 = time.perf_counter()
            sec = checked(name, SECTIONS[name](Path(out_dir), figures))
            out.append((name, to_jsonable(sec), time.perf_counter() - t0))
    return out


def _tasks(names) -> list[tuple[str, ...]]:
    """The sections to run grouped (:data:`GROUPS`) and ordered longest first."""
    left = list(names)
    tasks = []
    for g in GROUPS:
        mine = tuple(n for n in g if n in left)
        if len(mine) > 1:
            tasks.append(mine)
            left = [n for n in left if n not in mine]
    tasks += [(n,) for n in left]
    return sorted(tasks, key=lambda t: -sum(COST.get(n, 1.0) for n in t))


def run_sections(out_dir, names=None, figures: bool = True, notes: list | None = None, jobs: int | None = None,
                 progress=None) -> PaperResult:
    """Run the named sections (default all) and write ``out_dir/paper.json``.

    Sections already in an existing ``paper.json`` and not re-run are kept when they are as
    femupdate writes them (:func:`previous_sections`); what is ignored is appended to ``notes``.

    Parameters
    ----------
    out_dir : str or os.PathLike
        Folder of ``paper.json`` and the figures.
    names : sequence of str, optional
        Sections to run (default all).
    figures : bool, default True
    notes : list, optional
        Receives notes about an existing ``paper.json``.
    jobs : int, optional
        Worker processes (default: the usable cores, at most the number of tasks); 1 runs in this
        process.
    progress : callable, optional
        ``progress(name, seconds, done, total)`` after each section.

    Returns
    -------
    PaperResult
        Every section of ``paper.json`` (those run and those kept); it writes the JSON and the
        report of ``femupdate paper`` (``to_json()``, ``write_report(path)``, the figures of
        ``out_dir`` embedded).
    """
    import os

    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    names = list(SECTIONS) if not names else list(names)
    path = out_dir / "paper.json"
    sections = previous_sections(path, notes if notes is not None else [])
    tasks = _tasks(names)
    if jobs is None:
        jobs = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)
    jobs = max(1, min(int(jobs), len(tasks)))
    done = 0

    def collect(results):
        nonlocal done
        for name, sec, seconds in results:
            sections[name] = sec
            done += 1
            if progress is not None:
                progress(name, seconds, done, len(names))

    if jobs == 1:
        for t in tasks:
            collect(_run_group(t, out_dir, figures))
    else:
        from concurrent.futures import as_completed

        from .._workers import process_pool

        # Not "fork": a process that has already run an OpenMP region (CHOLMOD's libgomp, with
        # scikit-sparse) leaves forked children hanging in their next one.  A fork server is
        # a fresh interpreter forked from before any numerical work; it preloads the package.
        from .. import settings

        # The workers end with this process, however it ends (femupdate._workers), under the caller's settings.
        with process_pool(jobs, ("femupdate.paper",), settings.install, (settings.current(),)) as pool:
            futures = [pool.submit(_run_group, t, str(out_dir), figures) for t in tasks]
            for f in as_completed(futures):
                collect(f.result())
    result = PaperResult(TITLE, {k: sections[k] for k in SECTIONS if k in sections}, folder=out_dir,
                         context=RunContext(kind="paper"))
    result.write_json(path)
    return result
