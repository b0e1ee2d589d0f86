"""Sphinx configuration of the ltvmodels documentation.

Build (warnings are errors)::

    python -m sphinx -W --keep-going -b html docs docs/_build/html

The gallery runs every script in ``examples/`` in its quick mode (see
``gallery_hooks.py``); ``-D sphinx_gallery_conf.plot_gallery=0`` skips running them.
"""

from __future__ import annotations

import os
import re
import sys
from pathlib import Path

import ltvmodels

DOCS = Path(__file__).resolve().parent
sys.path.insert(0, str(DOCS))  # gallery_hooks

os.environ.setdefault("MPLBACKEND", "Agg")

project = "ltvmodels"
author = "ltvmodels developers"
copyright = "2026, ltvmodels developers"
release = ltvmodels.__version__
version = ".".join(release.split(".")[:2])

templates_path = ["_templates"]

extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.mathjax",
    "sphinx-mathjax-offline",  # MathJax 3 copied into _static/: formulas render offline
    "numpydoc",
    "myst_parser",
    "sphinx_gallery.gen_gallery",
]

source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
exclude_patterns = ["_build", "**.ipynb_checkpoints", "auto_examples/*.py", "auto_examples/*.ipynb"]
myst_enable_extensions = ["dollarmath", "colon_fence"]
myst_heading_anchors = 3

# API reference: one page per public name, written by autosummary from the docstrings.
autosummary_generate = True
autosummary_imported_members = True
autodoc_typehints = "none"  # numpydoc's Parameters section says the types
numpydoc_show_class_members = False
numpydoc_class_members_toctree = False
numpydoc_xref_param_type = False

sphinx_gallery_conf = {
    "examples_dirs": str(DOCS.parent / "examples"),
    "gallery_dirs": "auto_examples",
    "filename_pattern": r".*\.py$",  # every example runs, not only plot_*.py
    "reset_argv": "gallery_hooks.example_argv",
    "image_scrapers": ("gallery_hooks.written_figures",),
    "within_subsection_order": "gallery_hooks.ExampleOrder",
    "download_all_examples": False,
    "remove_config_comments": True,
    "abort_on_example_error": True,
    "show_memory": False,
    "min_reported_time": 1,
    # The execution-times page loads jQuery and DataTables from a CDN: not written.
    "write_computation_times": False,
}

html_theme = "pydata_sphinx_theme"
html_title = f"ltvmodels {release}"
html_theme_options = {
    "navigation_with_keys": False,
    "show_toc_level": 2,
    "footer_start": ["copyright"],
}
# Unset, the theme logs "invalid theme mode" to the console on every page.
html_context = {"default_mode": "auto"}
html_static_path = ["_static"]
html_css_files = ["custom.css"]


# Docstrings write formulas in plain text, readable in help(): k_{t+1}, x^r_{t+1},
# σ_{e,i}². On the site each subscripted or superscripted token is typeset by
# MathJax as an inline :math: role; code, doctests and literal or math blocks
# are left as they are. (The objectives of the estimators are ``.. math::`` blocks.)
_LETTERS = r"A-Za-zÀ-ɏα-ωΑ-Ωℓ\u0300-\u036f"
_SCRIPT = r"[_^](?:\{[^{}`]*\}|[\w−]+)"
_TEX_TOKEN = re.compile(
    rf"(?<![\w\\`$:])(?:[{_LETTERS}][{_LETTERS}0-9]*|\([^()\s`]*\))"
    rf"(?:{_SCRIPT})*[_^]\{{[^{{}}`]*\}}(?:{_SCRIPT})*[²³¹⁻ᵀ]*"
)
_CODE_OR_ROLE = re.compile(r"(``.*?``|:\w+(?::\w+)*:`[^`]*`|`[^`]*`_?)")


def _typeset_line(line: str) -> str:
    parts = _CODE_OR_ROLE.split(line)
    for i in range(0, len(parts), 2):  # the even parts are outside code and roles
        parts[i] = _TEX_TOKEN.sub(lambda m: f":math:`{m.group(0)}`", parts[i])
    return "".join(parts)


def typeset_docstring_math(app, what, name, obj, options, lines: list[str]) -> None:
    """Typeset the plain-text formulas of a docstring (after numpydoc's rewrite)."""
    block_indent = None  # the indentation of the directive or ``::`` opening a block
    for i, line in enumerate(lines):
        stripped = line.lstrip()
        indent = len(line) - len(stripped)
        if block_indent is not None:
            if not stripped or indent > block_indent:
                continue
            block_indent = None
        if stripped.startswith((">>>", "...")):
            continue
        if stripped.rstrip().endswith("::") or stripped.startswith(".. "):
            block_indent = indent
            if stripped.startswith(".. "):
                continue
        lines[i] = _typeset_line(line)


def setup(app) -> None:
    app.connect("autodoc-process-docstring", typeset_docstring_math)
