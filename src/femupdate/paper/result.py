"""The result of ``femupdate paper`` (:func:`femupdate.paper.run_sections`): a light typed form of
``paper.json`` that writes its JSON and report like the other results (:mod:`femupdate.serialise`)."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, ClassVar

from ..serialise import RunContext, Serialisable


@dataclass(frozen=True, eq=False)
class PaperResult(Serialisable):
    """The reference paper reproduced: one dict of computed values per section.

    Attributes
    ----------
    title : str
        The paper's title (``paper`` in the JSON).
    sections : dict
        {section: its values, ``summary``, ``agrees_with_paper``, ``comparison`` and, unless it
        agrees, ``explanation``} (docs/file-formats.md, ``paper``).
    folder : pathlib.Path, optional
        Where ``paper.json`` and the figures were written (the report embeds the figures); None
        for a result read back from JSON.
    context : RunContext, optional
        As every result (:mod:`femupdate.serialise`); a paper has no model or data.

    ``result["sections"]`` and ``result["paper"]`` read the JSON's keys, as the dict
    :func:`~femupdate.paper.run_sections` returned before this type.
    """

    kind: ClassVar[str] = "paper"

    title: str
    sections: dict
    folder: Path | None = None
    context: RunContext | None = field(default=None, compare=False, repr=False)

    def payload(self) -> dict:
        return {"paper": self.title, "sections": self.sections}

    @classmethod
    def from_payload(cls, obj):
        return cls(title=str(obj.get("paper") or ""), sections=dict(obj.get("sections") or {}))

    def __getitem__(self, key: str) -> Any:
        return self.payload()[key]

    def records(self) -> list[dict]:
        """One record per section: its name, one-line summary and comparison with the paper."""
        return [{"section": n, "summary": s.get("summary"), "comparison": s.get("comparison"),
                 "agrees_with_paper": s.get("agrees_with_paper")} for n, s in self.sections.items()]

    def report_images(self) -> dict:
        """The figures written beside ``paper.json`` (:func:`femupdate.report.paper_images`), as the
        report embeds them; none without :attr:`folder`."""
        if self.folder is None:
            return {}
        from ..report import paper_images

        return paper_images(self.folder, self.to_json())

    def __repr__(self) -> str:
        agree = sum(1 for s in self.sections.values() if s.get("agrees_with_paper") is True)
        return f"PaperResult({len(self.sections)} sections, {agree} agree with the paper)"


__all__ = ["PaperResult"]
