"""Sphinx configuration of the sogdd documentation.

Build (offline, from a clean clone): ``pip install '.[docs]' && sphinx-build -W -b html docs docs/_build/html``.
"""

from __future__ import annotations

from dataclasses import fields
from pathlib import Path

import sogdd

HERE = Path(__file__).resolve().parent

project = "sogdd"
author = "the sogdd developers"
copyright = "2026, the sogdd developers"
version = release = sogdd.__version__

extensions = [
    "myst_parser",
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.mathjax",
    "sphinx.ext.viewcode",
    "numpydoc",
    "sphinx_gallery.gen_gallery",
]

source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
templates_path = ["_templates"]  # the class page documents its methods (autosummary/class.rst)
root_doc = "index"
# figures/ holds the cached runs' figures and their notes (read by the pages, not pages themselves);
# pending/ holds pages and examples for code that has not landed yet
exclude_patterns = ["_build", "figures", "pending", "auto_examples/*.ipynb", "auto_examples/*.py",
                    "auto_examples/*.zip", "auto_examples/*.json", "auto_examples/*.md5",
                    "sg_execution_times.rst"]

# Markdown pages (the existing docs/*.md, README-style links between them)
myst_enable_extensions = ["colon_fence", "deflist", "dollarmath"]
myst_heading_anchors = 4

# API reference: autosummary pages generated from the numpydoc docstrings
autosummary_generate = True
autosummary_imported_members = False
autodoc_typehints = "none"  # numpydoc shows the types; the signatures keep their defaults
numpydoc_show_class_members = False
numpydoc_class_members_toctree = False
numpydoc_xref_param_type = False
numpydoc_validation_checks: set[str] = set()  # style is checked in review, not by failing the build

# sphinx-gallery: examples/plot_*.py run at build time on small rendered images
sphinx_gallery_conf = {
    "examples_dirs": str(HERE.parent / "examples"),
    "gallery_dirs": "auto_examples",
    "filename_pattern": r"/plot_",
    "within_subsection_order": "FileNameSortKey",  # plot_1_... first
    "download_all_examples": False,
    "remove_config_comments": True,
    "matplotlib_animations": False,
    "reference_url": {},  # offline: no links to other projects' docs
    "capture_repr": (),
    "show_memory": False,
}

html_theme = "pydata_sphinx_theme"
html_title = f"sogdd {release}"
html_theme_options = {
    "show_toc_level": 2,
    "navigation_with_keys": False,
    "header_links_before_dropdown": 5,
    "footer_start": ["copyright"],
    "footer_end": ["sphinx-version"],
    "secondary_sidebar_items": ["page-toc"],
}
html_static_path = ["_static"]
html_css_files = ["sogdd.css"]
# pages without sub-pages need no section navigation
html_sidebars = {page: [] for page in ("index", "getting-started", "performance", "changelog", "contributing")}
html_show_sourcelink = False
# the gallery's figures and the pages' own figures are enough; no external fonts or analytics
html_context = {"default_mode": "light"}


def _value(v) -> str:
    if isinstance(v, tuple):
        return "(" + ", ".join(_value(x) for x in v) + ")"
    if isinstance(v, float):  # 1.2 and 2.0 as written, 1e9 and the MATLAB grey weights short
        return repr(v) if len(repr(v)) <= 6 else f"{v:.6g}"
    return repr(v)


def write_preset_table(app=None) -> Path:
    """``api/generated/preset_defaults.md``: every parameter's value in each preset, from ``sogdd.PRESETS``."""
    presets = sogdd.PRESETS
    names = list(presets)
    lines = ["| parameter | " + " | ".join(f"`{n}`" for n in names) + " |",
             "|---|" + "---|" * len(names)]
    for f in fields(next(iter(presets.values()))):
        vals = [getattr(presets[n], f.name) for n in names]
        cells = [f"`{_value(v)}`" for v in vals]
        lines.append(f"| `{f.name}` | " + " | ".join(cells) + " |")
    out = HERE / "api" / "generated" / "preset_defaults.md"
    out.parent.mkdir(parents=True, exist_ok=True)
    text = "\n".join(lines) + "\n"
    if not out.is_file() or out.read_text() != text:
        out.write_text(text)
    return out


def setup(app):
    app.connect("builder-inited", write_preset_table)
