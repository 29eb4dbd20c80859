"""``femupdate paper``: the reference paper's numbered results reproduced."""

from __future__ import annotations


import click
from rich.table import Table

from .._errors import InputError
from ._common import OUTPUT_DIR, Ctx, emit, json_option, report_option


@click.command()
@click.option("--out", "out_dir", required=True, type=OUTPUT_DIR,
              help="Folder for paper.json and the figures.")
@click.option("--section", "sections", multiple=True, help="Only these sections (repeatable).")
@click.option("--no-figures", is_flag=True, help="Skip the figures.")
@click.option("--jobs", type=click.IntRange(1, 64), default=None,
              help="Worker processes (default: one per usable core; 1 runs in this process).")
@report_option
@json_option
def paper(out_dir, sections, no_figures, jobs, report_path, json_path):
    """Reproduce the reference paper's numbered results into OUT/paper.json and figures."""
    import time

    from ..paper import SECTIONS, run_sections

    ctx = Ctx(json_path)
    unknown = [s for s in sections if s not in SECTIONS]
    if unknown:
        raise InputError(f"unknown section(s) {', '.join(unknown)}; known: {', '.join(SECTIONS)}")
    notes: list[str] = []
    run = list(dict.fromkeys(sections)) or list(SECTIONS)
    t0 = time.perf_counter()

    def progress(name, seconds, done, total):
        ctx.console.print(f"[{done}/{total}] {name} ({seconds:.1f} s)")

    result = run_sections(out_dir, run, figures=not no_figures, notes=notes, jobs=jobs, progress=progress)
    ctx.console.print(f"{len(run)} section(s) in {time.perf_counter() - t0:.1f} s")
    for n in notes:
        ctx.console.print(f"note: {n}")
    t = Table(title=f"reference paper reproduced in {out_dir}")
    t.add_column("section")
    t.add_column("result")
    t.add_column("check", justify="center")
    for name, sec in result.sections.items():
        check = {"agree": "ok", "differ-explained": "differs (explained)", "not-comparable": "not comparable"}.get(
            sec.get("comparison"), {True: "ok", False: "DIFFERS", None: "-"}[sec.get("agrees_with_paper")])
        t.add_row(name, sec.get("summary", ""), check if name in run else f"{check} (earlier run)")
    ctx.console.print(t)
    ctx.console.print(f"written {out_dir / 'paper.json'}")
    emit(ctx, result.to_json())
    if report_path is not None:
        result.write_report(report_path, source=str(out_dir))  # the figures of out_dir embedded
        ctx.console.print(f"wrote the report {report_path}")
