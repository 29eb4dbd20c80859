"""The documentation site builds offline, with every warning an error (docs/conf.py).

Sphinx builds ``docs/`` into a temporary folder with ``-W --keep-going``: an RST error in a
docstring, a broken cross-reference, a link to a page or heading anchor that does not exist
(MyST's ``myst_heading_anchors``), a missing image or an example of the gallery that fails all
fail the build.  Network connections are refused inside the build, so a site that needs the
network to build fails here too.  Measured: about 70 s on an idle 2-core machine (the gallery's
six examples included), so it runs in the default suite.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
DOCS = ROOT / "docs"

pytest.importorskip("sphinx", reason="Sphinx is not installed (pip install '.[docs]'; the test extra has it)")
for _ext in ("myst_parser", "numpydoc", "pydata_sphinx_theme", "sphinx_click", "sphinx_gallery"):
    pytest.importorskip(_ext, reason=f"{_ext} is not installed (pip install '.[docs]'; the test extra has it)")

# the build in a child process whose Internet sockets cannot connect
_OFFLINE_BUILD = """
import socket, sys
def _refuse(self, address, *a, **k):
    if self.family in (socket.AF_INET, socket.AF_INET6):
        raise OSError(f"the documentation build tried to reach the network: {address}")
    return _connect(self, address, *a, **k)
_connect = socket.socket.connect
socket.socket.connect = _refuse
from sphinx.cmd.build import main
sys.exit(main(sys.argv[1:]))
"""


@pytest.fixture(scope="module")
def site(tmp_path_factory):
    if not (DOCS / "conf.py").is_file():
        pytest.skip("docs/ not next to the tests (installed package)")
    out = tmp_path_factory.mktemp("site")
    env = dict(os.environ, MPLBACKEND="Agg", PYTHONPATH=str(ROOT / "src") + os.pathsep + os.environ.get("PYTHONPATH", ""))
    proc = subprocess.run([sys.executable, "-c", _OFFLINE_BUILD, "-W", "--keep-going", "-q", "-b", "html",
                           "-d", str(out / "doctrees"), str(DOCS), str(out / "html")],
                          capture_output=True, text=True, env=env, cwd=ROOT, timeout=1200)
    return proc, out / "html"


def test_site_builds_offline_without_a_warning(site):
    proc, html = site
    log = proc.stdout + proc.stderr
    problems = [line for line in log.splitlines() if re.search(r"WARNING|ERROR|CRITICAL|Traceback", line)]
    assert proc.returncode == 0 and not problems, f"sphinx exited {proc.returncode}:\n" + "\n".join(problems or [log[-5000:]])
    assert (html / "index.html").is_file()


def test_every_page_and_reference_is_there(site):
    proc, html = site
    assert proc.returncode == 0, "the build failed (see the test above)"
    for page in ("getting-started", "capabilities", "cli", "file-formats", "python-api", "paper", "numerics",
                 "limitations", "benchmarks", "changelog", "reference/commands", "reference/api", "blackbox"):
        assert (html / f"{page}.html").is_file(), page
    commands = (html / "reference" / "commands.html").read_text(encoding="utf-8")
    from femupdate.cli import cli

    for name in cli.commands:  # the command reference is generated from the click group itself
        assert f"femupdate {name}" in commands, name
    api = (html / "reference" / "api.html").read_text(encoding="utf-8")
    import femupdate

    for name in femupdate.__all__:  # every top-level name, linked to its documentation
        if name != "__version__":
            assert f"femupdate.{name}<" in api.replace("</span>", "").replace('<span class="pre">', ""), name


def test_gallery_examples_ran_and_drew_their_figures(site):
    proc, html = site
    assert proc.returncode == 0, "the build failed (see the test above)"
    examples = sorted((ROOT / "examples").glob("plot_*.py"))
    assert len(examples) >= 6
    for ex in examples:
        page = html / "auto_examples" / f"{ex.stem}.html"
        assert page.is_file(), ex.name
        assert re.search(rf"sphx_glr_{ex.stem}_\d+\.png", page.read_text(encoding="utf-8")), f"{ex.name} drew no figure"


def test_pages_load_nothing_from_elsewhere_but_the_math_renderer(site):
    proc, html = site
    assert proc.returncode == 0, "the build failed (see the test above)"
    remote = set()
    for page in html.rglob("*.html"):
        for url in re.findall(r"""<(?:script|link|img)[^>]*?(?:src|href)=["'](https?://[^"']+)""", page.read_text(encoding="utf-8")):
            remote.add(url.split("?")[0])
    assert all("mathjax" in u.lower() for u in remote), sorted(remote)
