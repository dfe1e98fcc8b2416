"""Sphinx configuration of phasemap's documentation site.

Build (offline; warnings are errors)::

    python -m sphinx -W -b html docs docs/_build/html

The API reference is generated from the docstrings (autosummary, numpydoc), the
command-line reference from the argparse parser (``_ext/phasemap_cli.py``) and
the gallery from the scripts in ``examples/`` (sphinx-gallery, run at build time
on warm numba caches).  Nothing is fetched: no intersphinx, MathJax is served
from the site itself (``sphinx-mathjax-offline``).
"""

from __future__ import annotations

import os
import pathlib
import sys

HERE = pathlib.Path(__file__).resolve().parent
ROOT = HERE.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(HERE / "_ext"))
os.environ.setdefault("MPLBACKEND", "Agg")

import phasemap  # noqa: E402

project = "phasemap"
author = "the phasemap authors"
copyright = "the phasemap authors, MIT licence"
release = phasemap.__version__
version = release

extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.mathjax",
    "numpydoc",
    "myst_parser",
    "sphinx_design",
    "sphinx_gallery.gen_gallery",
    "sphinx-mathjax-offline",
    "phasemap_cli",
]

source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
root_doc = "index"
exclude_patterns = ["_build", "examples/*.py", "gallery_output", "**/README.rst",
                    "systems/README.md"]
templates_path = ["_templates"]

# -- MyST: Markdown pages with $...$ maths and definition lists -------------------------------
myst_enable_extensions = ["dollarmath", "amsmath", "deflist", "colon_fence"]
myst_heading_anchors = 3

# -- autosummary and numpydoc -----------------------------------------------------------------
autosummary_generate = True
autosummary_imported_members = True
autodoc_default_options = {"members": False}
autodoc_typehints = "none"
numpydoc_show_class_members = False
numpydoc_class_members_toctree = False
numpydoc_xref_param_type = False
numpydoc_validation_checks = set()

# -- sphinx-gallery: the scripts in examples/, each ending in one figure ----------------------
sphinx_gallery_conf = {
    "examples_dirs": str(ROOT / "examples"),
    "gallery_dirs": "auto_examples",
    "filename_pattern": r"/plot_",
    "download_all_examples": False,
    "remove_config_comments": True,
    "within_subsection_order": "FileNameSortKey",
    "image_scrapers": ("matplotlib",),
    "matplotlib_animations": False,
    "min_reported_time": 1,
    "show_memory": False,
    "reference_url": {},
    "default_thumb_file": None,
}

# -- HTML: the PyData theme ----------------------------------------------------------------
html_theme = "pydata_sphinx_theme"
html_title = f"phasemap {release}"
html_static_path = ["_static"]
html_css_files = ["phasemap.css"]
html_show_sourcelink = False
html_theme_options = {
    "navbar_align": "left",
    "show_toc_level": 2,
    "navigation_with_keys": False,
    "secondary_sidebar_items": ["page-toc"],
    "footer_start": ["copyright"],
    "footer_end": ["sphinx-version"],
    "header_links_before_dropdown": 6,
}
html_sidebars = {"index": []}
html_context = {"default_mode": "light"}

# Offline: nothing is fetched at build time.
intersphinx_mapping: dict = {}
nitpicky = False


# -- the studies' claims tables, made by the build that renders them (docs/claims.py) -----
def _claims_tables(app, docname, source):
    if docname == "guide/studies":
        sys.path.insert(0, str(HERE))
        import claims

        source[0] = claims.filled(source[0])


def setup(app):
    app.connect("source-read", _claims_tables)
