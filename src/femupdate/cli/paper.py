"""``femupdate paper``: the reference paper's numbered results reproduced."""

from __future__ import annotations


import click
from rich.table import Table

from .._errors import InputError
from ._common import OUTPUT_DIR, Ctx, emit, json_option


@click.command()
@click.option("--out", "out_dir", required=True, type=OUTPUT_DIR,
              help="Folder for paper.json and the figures.")
@click.option("--section", "sections", multiple=True, help="Only these sections (repeatable).")
@click.option("--no-figures", is_flag=True, help="Skip the figures.")
@json_option
def paper(out_dir, sections, no_figures, json_path):
    """Reproduce the reference paper's numbered results into OUT/paper.json and figures."""
    from ..paper import SECTIONS, run_sections

    ctx = Ctx(json_path)
    unknown = [s for s in sections if s not in SECTIONS]
    if unknown:
        raise InputError(f"unknown section(s) {', '.join(unknown)}; known: {', '.join(SECTIONS)}")
    result = run_sections(out_dir, list(sections) or list(SECTIONS), figures=not no_figures)
    t = Table(title=f"reference paper reproduced in {out_dir}")
    t.add_column("section")
    t.add_column("result")
    t.add_column("check", justify="center")
    for name, sec in result["sections"].items():
        t.add_row(name, sec.get("summary", ""), {True: "ok", False: "DIFFERS", None: "-"}[sec.get("agrees_with_paper")])
    ctx.console.print(t)
    ctx.console.print(f"written {out_dir / 'paper.json'}")
    emit(ctx, result)
