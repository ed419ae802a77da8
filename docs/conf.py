"""Sphinx configuration of the geoalpha documentation.

Build (warnings are errors, as in CI), from the repository root::

    python -m sphinx -W --keep-going -b html -d docs/_build/dt docs docs/_build/html
    python -m sphinx -W --keep-going -b doctest -d docs/_build/dt docs docs/_build/dt
"""

from __future__ import annotations

import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))  # document the source tree next to this file

import geoalpha  # noqa: E402

project = "geoalpha"
author = "geoalpha developers"
copyright = "2026, geoalpha developers"
release = geoalpha.__version__
version = release

extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.doctest",
    "numpydoc",
    "sphinx_click",
    "myst_nb",
]

exclude_patterns = ["_build", "**.ipynb_checkpoints", "README.md"]
templates_path = ["_templates"]
source_suffix = {".rst": "restructuredtext", ".md": "myst-nb", ".ipynb": "myst-nb"}
root_doc = "index"
nitpicky = False

# -- API reference ----------------------------------------------------------
autosummary_generate = True
autosummary_ignore_module_all = False
autodoc_typehints = "none"  # numpydoc's Parameters sections say the types
autodoc_default_options = {"member-order": "bysource"}
numpydoc_show_class_members = False
numpydoc_class_members_toctree = False
numpydoc_xref_param_type = False

# -- Notebooks and Markdown ------------------------------------------------
nb_execution_mode = "off"  # rendered with the outputs stored in the notebook
myst_enable_extensions = ["colon_fence", "deflist"]
myst_heading_anchors = 3
suppress_warnings = ["myst.header"]

# -- Doctests of the guide pages --------------------------------------------
# Only the explicit ``doctest`` blocks of the pages run here; the docstrings'
# examples are run by pytest (--doctest-modules).
doctest_test_doctest_blocks = ""
doctest_global_setup = """
import warnings
import numpy as np
import shapely
import geoalpha
"""

# -- HTML ---------------------------------------------------------------------
html_theme = "pydata_sphinx_theme"
html_title = f"geoalpha {release}"
html_static_path: list[str] = []
html_theme_options = {
    "navigation_with_keys": False,
    "navbar_align": "left",
    "header_links_before_dropdown": 5,
    "show_toc_level": 2,
    "footer_start": ["copyright"],
    "footer_end": ["sphinx-version"],
}
# Pages without sub-pages get no (empty) section navigation.
html_sidebars = {
    page: []
    for page in (
        "index",
        "getting_started",
        "cli",
        "dask",
        "benchmarks",
        "postgis",
        "development",
        "changelog",
    )
}
html_show_sourcelink = False
html_context = {"default_mode": "light"}


def _skip_namedtuple_fields(app, what, name, obj, skip, options):
    """Leave out NamedTuple fields: the class's Attributes section has them."""
    if (getattr(obj, "__doc__", None) or "").startswith("Alias for field number"):
        return True
    return None


def setup(app):
    """Connect the hooks above."""
    app.connect("autodoc-skip-member", _skip_namedtuple_fields)
