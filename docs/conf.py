"""Sphinx configuration of the femupdate documentation.

Build (offline; nothing is fetched at build time)::

    python -m pip install ".[docs]"
    python -m sphinx -W --keep-going -b html docs docs/_build/html

``tests/test_docs_build.py`` runs that build into a temporary folder and fails on any warning.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

DOCS = Path(__file__).resolve().parent
ROOT = DOCS.parent
if (ROOT / "src" / "femupdate").is_dir():  # a checkout: document this tree, not an installed copy
    sys.path.insert(0, str(ROOT / "src"))

os.environ.setdefault("MPLBACKEND", "Agg")

import femupdate  # noqa: E402

project = "femupdate"
author = "the femupdate developers"
copyright = "the femupdate developers"  # noqa: A001
release = femupdate.__version__
version = release

extensions = [
    "myst_parser",
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.mathjax",
    "numpydoc",
    "sphinx_click",
    "sphinx_gallery.gen_gallery",
]

source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
root_doc = "index"
exclude_patterns = ["_build", "**/sg_execution_times.rst", "Thumbs.db", ".DS_Store"]
templates_path: list[str] = []

# -- Markdown (MyST) --------------------------------------------------------------------------
myst_enable_extensions = ["colon_fence", "deflist"]
myst_heading_anchors = 4  # GitHub-style anchors (#model-file-toml) for links between pages

# -- API reference ------------------------------------------------------------------------------
autosummary_generate = True
autosummary_imported_members = False
autodoc_default_options = {"members": True, "ignore-module-all": True}
autodoc_typehints = "none"  # the numpydoc sections state the types
numpydoc_show_class_members = False
numpydoc_class_members_toctree = False
numpydoc_xref_param_type = False
numpydoc_validation_checks: set[str] = set()

# -- Examples gallery (executed at build time) --------------------------------------------------
sphinx_gallery_conf = {
    "examples_dirs": str(ROOT / "examples"),
    "gallery_dirs": "auto_examples",
    "filename_pattern": r"/plot_",
    "download_all_examples": False,
    "remove_config_comments": True,
    "within_subsection_order": "FileNameSortKey",
    "matplotlib_animations": False,
    "image_scrapers": ("matplotlib",),
    "reset_modules": ("matplotlib",),
    "capture_repr": (),
    "show_memory": False,
    "show_signature": False,
    "copyfile_regex": "",
    "write_computation_times": False,
}

# -- HTML (PyData theme; no remote assets) ------------------------------------------------------
html_theme = "pydata_sphinx_theme"
html_title = f"femupdate {release}"
html_static_path: list[str] = []
html_theme_options = {
    "navigation_with_keys": False,
    "show_toc_level": 2,
    "icon_links": [],
    "use_edit_page_button": False,
    "header_links_before_dropdown": 6,
    "footer_start": ["copyright"],
    "footer_end": ["sphinx-version"],
}
html_show_sourcelink = False
html_copy_source = False


# -- The top-level names of femupdate, from its own list (femupdate._LAZY) ----------------------
def _toplevel_table() -> str:
    """RST of a table: each top-level name, linked to where it is defined, and its summary line."""
    import inspect

    rows = []
    for name in femupdate.__all__:
        if name == "__version__":
            continue
        obj = getattr(femupdate, name)
        target = f"{obj.__module__}.{obj.__qualname__}"
        role = "class" if inspect.isclass(obj) else "func"
        doc = inspect.getdoc(obj) or ""
        summary = doc.split("\n\n")[0].replace("\n", " ").strip()
        rows.append((f":{role}:`femupdate.{name} <{target}>`", summary or "—"))
    out = [".. list-table::", "   :header-rows: 1", "   :widths: 30 70", "",
           "   * - name", "     - what it is"]
    for ref, summary in rows:
        out += [f"   * - {ref}", f"     - {summary}"]
    return "\n".join(out)


def _skip_foreign(app, what, name, obj, skip, options):
    """Leave out what a module imported from elsewhere (scipy's cKDTree, ...): not femupdate's API."""
    module = getattr(obj, "__module__", None)
    if what == "module" and isinstance(module, str) and not module.startswith("femupdate"):
        return True
    return None


def setup(app):
    app.connect("autodoc-skip-member", _skip_foreign)
    from docutils import nodes
    from docutils.statemachine import StringList
    from sphinx.util.docutils import SphinxDirective

    class TopLevel(SphinxDirective):
        has_content = False

        def run(self):
            node = nodes.section()
            node.document = self.state.document
            self.state.nested_parse(StringList(_toplevel_table().split("\n"), source="femupdate._LAZY"),
                                    self.content_offset, node)
            return node.children

    app.add_directive("femupdate-toplevel", TopLevel)
    return {"parallel_read_safe": True}
