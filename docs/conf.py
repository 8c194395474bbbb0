"""Sphinx configuration of the wheelgym documentation (``make docs``: warnings are errors)."""

from __future__ import annotations

import os
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))  # autodoc imports this checkout's wheelgym
os.environ.setdefault("SDL_VIDEODRIVER", "dummy")
os.environ.setdefault("MPLBACKEND", "Agg")

project = "wheelgym"
author = "the wheelgym developers"
copyright = "2026, the wheelgym developers"  # noqa: A001  (Sphinx's name)


def _version() -> str:
    try:
        from importlib.metadata import version

        return version("wheelgym")
    except Exception:  # an unbuilt checkout: the version pyproject.toml names
        import tomllib

        return tomllib.loads((ROOT / "pyproject.toml").read_text())["project"].get(
            "version", "")


release = version = _version()

extensions = [
    "myst_parser",
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.viewcode",
]
source_suffix = {".md": "markdown", ".rst": "restructuredtext"}
exclude_patterns = ["_build", "Thumbs.db", ".DS_Store", "**/README.md"]
root_doc = "index"

# no math extension: MathJax would load from a CDN (the site must work offline)
myst_enable_extensions = ["colon_fence", "deflist", "attrs_inline"]
myst_heading_anchors = 3  # [text](page.md#a-heading) links to headings up to level 3

html_theme = "furo"
html_title = f"wheelgym {release}"
html_static_path = ["_static"]
html_logo = None
html_theme_options = {"navigation_with_keys": True}

autodoc_default_options = {"members": True, "undoc-members": False, "show-inheritance": True}
autodoc_typehints = "description"
autodoc_member_order = "bysource"
autosummary_generate = False

#: The index's glob toctree of docs/topics/ (pages written by several branches): dropped
#: from the index when no page is there, since Sphinx warns on an empty glob.
TOPICS_TOCTREE = "```{toctree}\n:maxdepth: 1\n:caption: Topics\n:glob:\n\ntopics/*\n```\n"


def _drop_empty_topics(app, docname, source):
    if docname == "index" and not any((Path(app.srcdir) / "topics").glob("*.md")):
        if TOPICS_TOCTREE not in source[0]:
            raise RuntimeError("docs/index.md: the topics toctree is not conf.TOPICS_TOCTREE")
        source[0] = source[0].replace(TOPICS_TOCTREE, "")


def _docstring_as_literal(app, what, name, obj, options, lines):
    """The package's docstrings are Markdown-like (Gymnasium's layout: ``## Section`` headers,
    pipe tables): reST would read their tables and headers as broken markup. The first
    paragraph stays text; the rest is shown as it is written, as a literal block."""
    if not lines:
        return
    # the summary: up to the first blank line, header or table row
    cut = next((k for k, ln in enumerate(lines)
                if not ln.strip() or ln.lstrip().startswith(("#", "|"))), len(lines))
    rest = lines[cut:]
    if not any(ln.strip() for ln in rest):
        return
    head = " ".join(ln.strip() for ln in lines[:cut])
    lines[:] = [head, "", "::", "", *(("    " + ln) if ln else "" for ln in rest), ""]


def setup(app):
    app.connect("autodoc-process-docstring", _docstring_as_literal)
    app.connect("source-read", _drop_empty_topics)
