"""The HTML reports looked at as a person would: each kind of report opened in headless Chromium
loads without console errors, exceptions or requests to anywhere, shows its figures, and the
numbers on the rendered page are the result file's (issue 18).

Skipped, with the reason, where no Chromium is installed (``apt-get install chromium``; or
``FEMUPDATE_CHROMIUM=/path/to/chrome``) or the ``websocket-client`` package is missing.
``FEMUPDATE_SCREENSHOTS=DIR`` keeps a full-page screenshot of each report in DIR.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import pytest

from chromium import Browser, find_chromium
from test_report import KIND_FILES, RECORDED, assert_shown, lookup, verdict_text

from femupdate.cli import main
from femupdate.report import write_report

EXE, WHY = find_chromium()
pytestmark = pytest.mark.skipif(EXE is None, reason=f"no browser to look at the reports with: {WHY}")

#: what the page shows of its numbers: every element tied to the JSON, with its text
CELLS = """Array.from(document.querySelectorAll('[data-key]')).map(e => ({
  key: e.dataset.key, value: e.dataset.value, text: e.textContent.trim(),
  visible: e.getBoundingClientRect().width > 0}))"""
FIGURES = """Array.from(document.querySelectorAll('figure svg, figure img')).map(e => {
  const r = e.getBoundingClientRect(); return [r.width, r.height, e.tagName,
  e.tagName === 'IMG' ? (e.complete && e.naturalWidth > 0) : true]; })"""


@pytest.fixture(scope="module")
def pages(tmp_path_factory, ex):
    """One report of each kind from its recorded result, and an update report with the model and
    the data (mode shapes, MAC before and after), written by the command itself."""
    d = tmp_path_factory.mktemp("reports")
    out = {}
    for kind, name in KIND_FILES.items():
        result = json.loads((RECORDED / name).read_text())
        out[kind] = (write_report(d / f"{kind}.html", result, source=name), result)
    with pytest.raises(SystemExit) as e:
        main(["update", str(ex / "figure2.toml"), str(ex / "figure2_test.json"), "--json", str(d / "u.json"),
              "--report", str(d / "update-full.html")])
    assert e.value.code == 0
    out["update-full"] = (d / "update-full.html", json.loads((d / "u.json").read_text()))
    with pytest.raises(SystemExit) as e:  # the posterior's report (no recorded result: its samples vary by seed only)
        main(["posterior", str(ex / "two_dof.toml"), str(ex / "two_dof_frequencies.json"), "--std-eigenvalue", "0.01",
              "--method", "tmcmc", "--samples", "400", "--starts", "8", "--json", str(d / "p.json"),
              "--report", str(d / "posterior.html")])
    assert e.value.code == 0
    out["posterior"] = (d / "posterior.html", json.loads((d / "p.json").read_text()))
    return out


@pytest.fixture(scope="module")
def browser():
    with Browser(EXE, width=1280, height=900) as b:
        yield b


@pytest.mark.parametrize("kind", [*KIND_FILES, "update-full", "posterior"])
def test_report_renders_without_errors_and_shows_the_results_numbers(kind, pages, browser):
    path, result = pages[kind]
    problems = browser.load(path)
    assert problems == [], problems
    assert browser.evaluate("document.title") and browser.evaluate("document.querySelector('h1').textContent")
    cells = browser.evaluate(CELLS)
    numbers = 0
    for c in cells:
        want = lookup(result, c["key"])
        assert c["visible"], c["key"]
        if isinstance(want, bool) or want is None:  # a section's verdict, or none (the paper prints nothing)
            assert c["text"] == verdict_text(result, c["key"]), c["key"]
            continue
        assert float(c["value"]) == want, c["key"]
        assert_shown(c["text"], want, c["key"])
        numbers += 1
    assert numbers > 0 or kind == "paper"
    figures = browser.evaluate(FIGURES)
    if kind != "paper":
        assert figures, "no figure on the page"
    for w, h, tag, loaded in figures:
        assert w > 50 and h > 50 and loaded, (tag, w, h)
    shots = os.environ.get("FEMUPDATE_SCREENSHOTS")
    if shots:
        Path(shots).mkdir(parents=True, exist_ok=True)
        browser.screenshot(Path(shots) / f"{kind}.png", full_page=True)


def test_update_report_with_model_and_data_shows_shapes_and_both_mac_matrices(pages, browser):
    path, result = pages["update-full"]
    assert browser.load(path) == []
    titles = browser.evaluate("Array.from(document.querySelectorAll('h2')).map(h => h.textContent)")
    assert {"Parameters", "Correlation with the test", "Mode shapes on the model", "Convergence",
            "Identifiability", "Notes and warnings"} <= set(titles)
    captions = browser.evaluate("Array.from(document.querySelectorAll('figcaption')).map(f => f.textContent)")
    assert any("before the update" in c for c in captions) and any("after the update" in c for c in captions)
    assert browser.evaluate("document.querySelectorAll('#shapes figure svg').length") == len(result["pairs"])
    png = browser.screenshot(path.with_suffix(".png"))
    assert png.stat().st_size > 10_000  # a page, not a blank
