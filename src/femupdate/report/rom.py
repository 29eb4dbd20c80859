"""The report's section of an update on a reduced model (:mod:`femupdate.rom`): the basis and every
full-model check, mode by mode."""

from __future__ import annotations

from collections.abc import Mapping

from .document import Cell, Section, Table, Text, numcell


def reduced_basis_section(rec: Mapping) -> Section:
    """``reduced_basis`` of an update's JSON as a section: a line on the basis, a table of the checks."""
    sec = Section("reduced-basis", "Reduced model and its full-model checks")
    sec.add(Text(f"The update ran on a reduced model of {rec.get('size')} Ritz vectors for {rec.get('n_dofs')} dofs "
                 f"({len(rec.get('snapshots') or [])} snapshots). Each answer was checked on the full model: paired "
                 f"frequencies to {rec.get('freq_tol')} (relative), shapes at the data's dofs to 1 - MAC <= "
                 f"{rec.get('shape_tol')}. " + ("Every start's last check passed." if rec.get("passed")
                                               else "A start's last check FAILED.")))
    t = Table("full-model checks", ["start", "round", "basis", "model mode", "f reduced [Hz]", "f full [Hz]",
                                    "frequency error [–]", "bound (quadratic) [–]", "1 − MAC [–]", "check"])
    for i, c in enumerate(rec.get("checks") or []):
        for j, m in enumerate(c.get("modes") or []):
            where = f"/reduced_basis/checks/{i}/modes/{j}"
            t.rows.append([Cell(str(c.get("start", 1))), Cell(str(c.get("round", ""))), Cell(str(c.get("basis", ""))),
                           Cell(str(m.get("model_mode"))), numcell(m.get("f_reduced_hz"), f"{where}/f_reduced_hz", 9),
                           numcell(m.get("f_full_hz"), f"{where}/f_full_hz", 9),
                           numcell(m.get("frequency_error"), f"{where}/frequency_error", 3),
                           numcell(m.get("bound_quadratic"), f"{where}/bound_quadratic", 3),
                           numcell(m.get("one_minus_mac"), f"{where}/one_minus_mac", 3),
                           Cell("passed" if m.get("passed") else "FAILED", cls="ok" if m.get("passed") else "bad")])
    return sec.add(t)


__all__ = ["reduced_basis_section"]
