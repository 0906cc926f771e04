"""Sphinx configuration of the infoseek documentation.

Build: ``python -m sphinx -W --keep-going -n -b html docs docs/_build/html`` (the ``docs``
extra installs what it needs; CI runs it through ``.ci/docs``).

Why Sphinx with MyST-Parser, autodoc and napoleon (and not MkDocs-Material with mkdocstrings):
the docstrings are Google-style with reST roles and ``.. math::`` blocks, which autodoc and
napoleon render as written (mkdocstrings would show the roles as literal text), the two
environment manuals are Markdown module docstrings that MyST renders as pages (PettingZoo's
arrangement, with Sphinx as PettingZoo uses it), and Sphinx checks every internal reference at
build time, so ``-W -n`` fails on a broken link or cross-reference.
"""

from __future__ import annotations

import importlib.util
import sys
from importlib.metadata import version as _installed_version
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent / "_ext"))

project = "infoseek"
author = "The infoseek developers"
copyright = "2026, the infoseek developers"
release = _installed_version("infoseek")
version = release

extensions = [
    "myst_parser",
    "sphinx.ext.autodoc",
    "sphinx.ext.napoleon",
    "sphinx.ext.mathjax",
    "infoseek_docs",
]
source_suffix = {".md": "markdown"}
root_doc = "index"
exclude_patterns = ["_build", "_ext"]
html_theme = "furo"
html_title = f"infoseek {release}"

# MyST: in-page anchors for headings down to ### (links such as results/fig1.md#...).
myst_heading_anchors = 3
myst_enable_extensions = ["colon_fence"]

# autodoc and napoleon: Google-style docstrings, members in source order, type hints in the
# descriptions (the signatures stay readable).
napoleon_google_docstring = True
napoleon_numpy_docstring = False
napoleon_use_ivar = True  # "Attributes:" as fields: a property listed there is not described twice
autodoc_member_order = "bysource"
autodoc_typehints = "description"
autodoc_class_signature = "separated"

#: Optional dependencies (the ``rl`` and ``distributed`` extras) are mocked where they are not
#: installed, so the docs build without torch; CI installs them, so there nothing is mocked.
autodoc_mock_imports = [
    name
    for name in ("stable_baselines3", "supersuit", "torch", "tensorboard", "ray")
    if importlib.util.find_spec(name) is None
]
