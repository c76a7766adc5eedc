"""Sphinx configuration of the diskpack_cl site.

Build: ``.venv/bin/python -m sphinx -W -b html docs docs/_build/html`` (the
``docs`` extra installs what it needs). The API pages, the CLI reference, the
option tables, the results tables and the gallery are made from the code and
the stored benchmark rows at build time, so they cannot drift from them.
"""

from __future__ import annotations

import pkgutil
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE / "_ext"))

import diskpack_cl  # noqa: E402

project = "diskpack_cl"
author = "diskpack_cl contributors"
copyright = "2026, diskpack_cl contributors"
release = version = diskpack_cl.__version__

extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.mathjax",
    "numpydoc",
    "myst_parser",
    "sphinx_gallery.gen_gallery",
    "diskpack_docs",
]

# Option names such as --pen-mm appear in plain text (help strings in the
# generated tables): smart quotes would turn their "--" into dashes.
smartquotes = False

source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
exclude_patterns = ["_build", "auto_examples/*.ipynb", "auto_examples/*.py",
                    "auto_examples/*.zip", "auto_examples/*.md5", "auto_examples/*.json"]
# The stored Markdown pages (results.md, stipple_quality.md, ...) start at
# level-1 headings and link to repository files; these are the only warnings
# we accept from them, everything else fails the -W build.
myst_heading_anchors = 4
myst_enable_extensions = ["dollarmath"]
suppress_warnings = ["myst.header"]

autosummary_generate = True
autodoc_default_options = {"members": True, "member-order": "bysource"}
autodoc_typehints = "none"
numpydoc_show_class_members = False
numpydoc_validation_checks: set = set()
numpydoc_xref_param_type = False

html_theme = "pydata_sphinx_theme"
html_title = "diskpack_cl"
html_theme_options = {"navigation_depth": 2, "show_toc_level": 2}
html_static_path: list = []

# PoCL on a shared CPU: one example at a time, small inputs (examples/README.txt).
sphinx_gallery_conf = {
    "examples_dirs": str(HERE.parent / "examples"),
    "gallery_dirs": "auto_examples",
    "filename_pattern": r"/plot_",
    # the paper's figure script is a command-line tool with its own test, not a gallery page
    "ignore_pattern": r"paper_figures\.py",
    "download_all_examples": False,
    "remove_config_comments": True,
    "matplotlib_animations": False,
    "image_scrapers": ("matplotlib",),
    "within_subsection_order": "FileNameSortKey",
    "reset_modules": ("matplotlib",),
    "show_memory": False,
}


def public_modules():
    """The package's public modules and subpackages (no part with a leading underscore), sorted."""
    names = [m.name for m in pkgutil.walk_packages(diskpack_cl.__path__, "diskpack_cl.")]
    return sorted(n for n in names if not any(part.startswith("_") for part in n.split("."))
                  and not n.startswith("diskpack_cl.cli."))   # the CLI's page is its reference


def write_module_pages(app):
    """One ``reference/modules/<module>.rst`` per public module, so that a new module gets a page."""
    out = HERE / "reference" / "modules"
    out.mkdir(parents=True, exist_ok=True)
    names = public_modules()
    for page in out.glob("*.rst"):   # a module that moved or went leaves no page behind
        if page.stem not in names:
            page.unlink()
    for name in names:
        title = f"``{name}``"
        text = [title, "=" * len(title), "", f".. automodule:: {name}", "   :members:", ""]
        page = out / f"{name}.rst"
        content = "\n".join(text)
        if not page.exists() or page.read_text() != content:  # unchanged pages keep Sphinx's cache
            page.write_text(content)


def setup(app):
    app.connect("builder-inited", write_module_pages)
