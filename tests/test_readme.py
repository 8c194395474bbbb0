"""The README's Python blocks run verbatim in a fresh interpreter (what a new user pastes)."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

README = Path(__file__).resolve().parents[1] / "README.md"
BLOCKS = re.findall(r"^```python\n(.*?)^```", README.read_text(encoding="utf-8"),
                    flags=re.MULTILINE | re.DOTALL)
#: A shipped agent's folder named in a block: such a block runs from the repository root.
PRETRAINED = re.compile(r"agents/pretrained/[\w.-]+")


def test_readme_has_python_blocks() -> None:
    assert len(BLOCKS) >= 2


@pytest.mark.parametrize("k", range(len(BLOCKS)))
def test_readme_block_runs_verbatim(k: int, tmp_path: Path) -> None:
    cwd = tmp_path
    agent = PRETRAINED.search(BLOCKS[k])
    if agent is not None:  # the plain-SB3 snippet: paths relative to the repository
        cwd = README.parent
        if not (cwd / agent.group(0)).is_dir():
            pytest.skip(f"{agent.group(0)} is not shipped yet (tests/agents/test_pretrained.py "
                        "runs this block on a freshly trained agent)")
    env = {**os.environ, "SDL_VIDEODRIVER": "dummy", "MPLBACKEND": "Agg"}
    r = subprocess.run([sys.executable, "-c", BLOCKS[k]], cwd=cwd, env=env,
                       capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, f"README block {k} failed:\n{BLOCKS[k]}\n{r.stderr[-3000:]}"


def test_subpackages_are_attributes_in_a_fresh_interpreter() -> None:
    code = ("import wheelgym, sys\n"
            "assert 'wheelgym.control' not in sys.modules\n"  # lazy: nothing heavy at import
            "for name in wheelgym.SUBMODULES:\n"
            "    assert getattr(wheelgym, name).__name__ == 'wheelgym.' + name\n"
            "assert 'control' in dir(wheelgym)\n"
            "try:\n"
            "    wheelgym.no_such_thing\n"
            "except AttributeError as e:\n"
            "    assert 'no_such_thing' in str(e)\n"
            "else:\n"
            "    raise SystemExit('no AttributeError')\n")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                       timeout=300)
    assert r.returncode == 0, r.stderr[-3000:]


def test_readme_is_one_screen_and_a_little_more() -> None:
    lines = README.read_text(encoding="utf-8").splitlines()
    assert len(lines) <= 200, f"README.md has {len(lines)} lines (at most 200: the rest is docs/)"


def test_readme_links_resolve() -> None:
    """Every relative link and picture of the README (into docs/ mostly) names a file of the
    repository."""
    text = README.read_text(encoding="utf-8")
    targets = re.findall(r"\]\(([^)#\s]+)(?:#[^)]*)?\)", text)
    local = [t for t in targets if not re.match(r"[a-z]+://", t)]
    assert len(local) >= 10
    missing = [t for t in local if not (README.parent / t).exists()]
    assert not missing, missing
