"""The kinds of report and the builder of each: the sections of a report, built from a command's
JSON result (and, when given, what :mod:`.recompute` recomputed from the model and the data).

The parts several kinds share are in :mod:`femupdate.report.parts` and
:mod:`femupdate.report.sections`; each kind's builder in its module
(:mod:`femupdate.report.update`, :mod:`femupdate.report.damage`,
:mod:`femupdate.report.uniqueness`, :mod:`femupdate.report.paper`,
:mod:`femupdate.report.posterior`, :mod:`femupdate.report.plan`).  A builder is called as ``builder(doc, result, model, data,
rec, segments, kind)`` (with ``images=`` for the kinds that embed figures of their own) and fills
the :class:`~.document.Document`.
"""

from __future__ import annotations

from .damage import build_damage
from .paper import build_paper
from .plan import build_plan
from .posterior import build_posterior
from .uniqueness import build_uniqueness
from .update import build_direct, build_multi, build_update

#: the kinds of result a report is made of, and the command that writes each
KINDS = {
    "direct": "femupdate direct (direct updating from complete data)",
    "update": "femupdate update (iterative updating)",
    "frf-update": "femupdate frf-update (FRF updating)",
    "update-multi": "femupdate update-multi (several test configurations)",
    "damage": "femupdate damage (damage localisation)",
    "uniqueness": "femupdate uniqueness (uniqueness study)",
    "paper": "femupdate paper (the reference paper reproduced)",
    "posterior": "femupdate posterior (Bayesian updating)",
    "plan": "femupdate plan (test planning)",
}

BUILDERS = {"direct": build_direct, "update": build_update, "frf-update": build_update, "update-multi": build_multi,
            "damage": build_damage, "uniqueness": build_uniqueness, "paper": build_paper,
            "posterior": build_posterior, "plan": build_plan}
#: the kinds whose builder takes ``images`` (figures the result carries, or files beside it)
WITH_IMAGES = ("paper", "posterior")

__all__ = ["KINDS", "BUILDERS", "WITH_IMAGES"]
