"""``femupdate write-back``: an update's values written back into the FE code's own input
(:mod:`femupdate.io.write_back`, docs/file-formats.md)."""

from __future__ import annotations

import click

from ._common import INPUT_FILE, OUTPUT_DIR, Ctx


@click.command("write-back")
@click.argument("model_path", metavar="MODEL", type=INPUT_FILE)
@click.argument("result_path", metavar="RESULT.json", type=INPUT_FILE)
@click.option("--out", "out_dir", required=True, type=OUTPUT_DIR, metavar="DIR",
              help="The folder the updated deck (<deck>_updated.bdf/.inp) or ANSYS commands (<model>_updated.mac) "
                   "go into.")
def write_back_command(model_path, result_path, out_dir):
    """Write the parameters RESULT.json updated (--json of update, frf-update or direct) back into
    MODEL's deck: Nastran MAT1/PSHELL/PBAR/PROD cards, Abaqus *ELASTIC, *DENSITY, *SHELL SECTION and
    *PARAMETER lines, ANSYS MP/RMODIF commands (each parameter's card = ..., or its [mesh.sets] use)."""
    from ..io.write_back import result_values, write_back

    ctx = Ctx(None)
    values = result_values(result_path)
    for path in write_back(model_path, values, out_dir):
        ctx.console.print(f"wrote {path}")
