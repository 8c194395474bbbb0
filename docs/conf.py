"""Sphinx configuration of the wheelgym documentation (``make docs``: warnings are errors)."""

from __future__ import annotations

import os
import re
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
    """The package's version: ``wheelgym.__version__`` where it has one, else its metadata,
    else what pyproject.toml names."""
    try:
        import wheelgym

        if getattr(wheelgym, "__version__", None):
            return str(wheelgym.__version__)
        from importlib.metadata import version

        return version("wheelgym")
    except Exception:  # an unbuilt checkout
        import tomllib

        project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
        return str(project.get("version", ""))


release = version = _version()

extensions = [
    "myst_parser",
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.napoleon",
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
html_logo = None
html_theme_options = {"navigation_with_keys": True}

autodoc_default_options = {"members": True, "undoc-members": False, "show-inheritance": True}
autodoc_typehints = "description"
autodoc_member_order = "bysource"
autodoc_inherit_docstrings = False  # Gymnasium's own docstrings are not this site's to check
autosummary_generate = False
napoleon_use_ivar = True  # "Attributes:" as fields: autodoc documents the members themselves

suppress_warnings = [
    # heading levels that skip one (# then ###) are a page's style, not a broken site
    "myst.header",
]

_MARKDOWN = re.compile(r"^\s*(#{1,6} |\|.*\|\s*$)")


def _docstring_as_literal(app, what, name, obj, options, lines):
    """Docstrings in Gymnasium's layout (``## Section`` headers, pipe tables) are Markdown,
    which reST would read as broken markup: their first paragraph stays text and the rest is
    shown as it is written, as a literal block. The others (Google style: ``Args:``,
    ``Returns:``) go on to napoleon."""
    if not lines or not any(_MARKDOWN.match(ln) for ln in lines):
        return
    # the summary: up to the first blank line, header or table row
    cut = next((k for k, ln in enumerate(lines)
                if not ln.strip() or ln.lstrip().startswith(("#", "|"))), len(lines))
    rest = lines[cut:]
    if not any(ln.strip() for ln in rest):
        return
    head = " ".join(ln.strip() for ln in lines[:cut])
    lines[:] = [head, "", "::", "", *(("    " + ln) if ln else "" for ln in rest), ""]


_IGNORED = ("Unknown interpreted text role", "No role entry", "Unknown directive type",
            "No directive entry", "Unknown target name", "Undefined substitution")


_ROLE = re.compile(r":[\w.-]+(?::[\w.-]+)*:`")


def _rst_problems(lines) -> list[str]:
    """What docutils says about ``lines`` as reST. Sphinx's roles (``:class:`x```) are read
    as plain interpreted text here: they need a build environment that a bare docutils parse
    has not."""
    import io

    from docutils import nodes
    from docutils.core import publish_doctree

    text = _ROLE.sub("`", "\n".join(lines))
    doc = publish_doctree(text, settings_overrides={
        "report_level": 2, "halt_level": 5, "warning_stream": io.StringIO(),
        "file_insertion_enabled": False, "raw_enabled": False})

    return [m.astext() for m in doc.findall(nodes.system_message)
            if m["level"] >= 2 and not m.astext().startswith(_IGNORED)]


def _broken_rst_as_literal(app, what, name, obj, options, lines):
    """A docstring that is not valid reST (after napoleon) is shown as written, as a literal
    block, instead of failing the strict build: the site's checks are about its pages; the
    docstrings' own markup is each module's."""
    if lines and _rst_problems(lines):
        lines[:] = ["::", "", *(("    " + ln) if ln else "" for ln in lines), ""]


def setup(app):
    app.connect("autodoc-process-docstring", _docstring_as_literal, priority=400)
    app.connect("autodoc-process-docstring", _broken_rst_as_literal, priority=600)
