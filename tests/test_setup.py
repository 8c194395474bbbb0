"""The setup takes the CPU build of torch by version alone (README: no package-index URL)."""

from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def test_makefile_names_no_package_index() -> None:
    text = (ROOT / "Makefile").read_text(encoding="utf-8")
    assert not re.search(r"--(extra-)?index-url|https?://", text)
    assert '"torch==2.13.0"' in text  # the pinned CPU build, installed first


def test_ci_runs_the_readme_test_command() -> None:
    ci = (ROOT / ".ci" / "run").read_text(encoding="utf-8")
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    assert "make test" in ci and "make test" in readme
