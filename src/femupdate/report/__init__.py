"""One self-contained HTML report of a run — what a test engineer hands over.

:func:`build_report` turns the result (object or JSON) of ``direct``, ``update``,
``frf-update``, ``update-multi``, ``damage``, ``uniqueness``, ``paper`` or ``posterior`` into one
HTML page: model and data, parameters (start, updated, change, bounds, standard deviation, flags),
the paired modes and MAC matrices before and after, frequency comparison, mode shapes on the
model's geometry, convergence, identifiability, the distinct multi-start solutions, FRF overlays
and residual surfaces, located damage with its confidence, the posterior's intervals, solutions,
diagnostics and predictions, and every note and warning.  Figures are embedded
(inline SVG or base64 PNG) and the page loads nothing from anywhere: it opens offline.

The JSON alone gives what it holds; with the model and the test data the report also computes
what needs them (the correlation *before* the update, MAC matrices, mode shapes, FRFs, residual
surface).  Jinja2 (the templating library) and matplotlib are imported on first use.

Layering: this package sits on top, beside :mod:`femupdate.plot` and :mod:`femupdate.cli`; the
numerical packages never import it.

Example
-------
>>> import json, femupdate as fu
>>> from femupdate.report import write_report
>>> result = json.load(open("result.json"))                          # doctest: +SKIP
>>> write_report("report.html", result, model=fu.load_model("model.toml"),
...              data=fu.load_test_data("test.json", model))        # doctest: +SKIP
"""

from __future__ import annotations

from .build import REPORT_KINDS, build_report, detect_kind, paper_images, write_report

__all__ = ["build_report", "write_report", "detect_kind", "paper_images", "REPORT_KINDS"]
