"""The documentation's sources: the code its pages show runs, the generated robot pages are
current, and the code's citations of the docs point at pages that exist.

The built site itself is checked in a browser by ``tests/test_docs_browser.py``
(``make docs-check``).
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
PAGES = sorted(p for p in DOCS.rglob("*.md") if "_build" not in p.parts)
FENCE = re.compile(r"^```python\n(.*?)^```", flags=re.MULTILINE | re.DOTALL)
#: The pages whose code this test runs: docs/topics/ pages are each branch's own and show code
#: that their own tests run (some blocks read what a shell command on the page wrote).
BLOCKS = [(p.relative_to(ROOT).as_posix(), k, b) for p in PAGES if "topics" not in p.parts
          for k, b in enumerate(FENCE.findall(p.read_text(encoding="utf-8")))]
#: Paths of the repository a block may name; it then runs where they resolve (a scratch
#: folder holding links to them, so that what it writes stays out of the checkout).
REPO_PATHS = ("configs", "agents", "benchmarks", "examples")
#: A block that trains (seconds to minutes of CPU) is a slow test.
SLOW = re.compile(r"\btrain\(|\.learn\(|wheelgym\.agents\.(train|tune|benchmark)\b")


def test_pages_show_python() -> None:
    assert len(BLOCKS) >= 8
    shown = {name for name, _, _ in BLOCKS}
    assert {"docs/index.md", "docs/getting-started.md", "docs/tasks.md"} <= shown


@pytest.mark.parametrize(
    "name,k,block",
    [pytest.param(n, k, b, id=f"{n}:{k}", marks=[pytest.mark.slow] if SLOW.search(b) else [])
     for n, k, b in BLOCKS])
def test_page_block_runs_verbatim(name: str, k: int, block: str, tmp_path: Path) -> None:
    import importlib.util

    for mod in re.findall(r"^(?:from|import) ([A-Za-z_]\w*)", block, flags=re.MULTILINE):
        if importlib.util.find_spec(mod) is None:  # a block of an extra that is not installed
            pytest.skip(f"{name} block {k} needs {mod!r}, not installed here")
    for d in REPO_PATHS:
        if re.search(rf"(?<![\w/.-]){d}/", block):
            (tmp_path / d).symlink_to(ROOT / d, target_is_directory=True)
    if "agents/pretrained/" in block:
        agent = re.search(r"agents/pretrained/[\w.-]+", block).group(0)
        if not (ROOT / agent).is_dir():
            pytest.skip(f"{agent} is not shipped in this checkout")
    env = {**os.environ, "SDL_VIDEODRIVER": "dummy", "MPLBACKEND": "Agg",
           "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")])}
    r = subprocess.run([sys.executable, "-c", block], cwd=tmp_path, env=env,
                       capture_output=True, text=True, timeout=600)
    missing = re.search(r"ModuleNotFoundError: No module named '([\w.]+)'", r.stderr)
    if r.returncode and missing and not missing.group(1).startswith("wheelgym") and \
            importlib.util.find_spec(missing.group(1).split(".")[0]) is None:
        pytest.skip(f"{name} block {k} needs {missing.group(1)!r}, not installed here")
    assert r.returncode == 0, f"{name} block {k} failed:\n{block}\n{r.stderr[-3000:]}"


def test_generated_robot_pages_are_current() -> None:
    env = {**os.environ, "SDL_VIDEODRIVER": "dummy",
           "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")])}
    r = subprocess.run([sys.executable, str(DOCS / "gen_robot_pages.py"), "--check"],
                       cwd=ROOT, env=env, capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stdout + r.stderr[-3000:]


def test_robot_gifs_are_small() -> None:
    gifs = sorted((DOCS / "robots" / "img").glob("*.gif"))
    assert len(gifs) == 21  # 7 robots x 3 tasks
    for g in gifs:
        assert 1_000 < g.stat().st_size < 300_000, g.name


#: Where the code may cite the documentation.
SOURCES = [p for d in ("wheelgym", "tests", "benchmarks", "examples")
           for p in (ROOT / d).rglob("*.py") if p != Path(__file__).resolve()]
SOURCES += [ROOT / "Makefile", ROOT / "ARCHITECTURE.md"]
CITE = re.compile(r"docs/[\w./-]+\.md")


def test_code_cites_pages_that_exist() -> None:
    cited = {}
    for path in SOURCES:
        for m in CITE.finditer(path.read_text(encoding="utf-8")):
            cited.setdefault(m.group(0), path.relative_to(ROOT).as_posix())
    assert cited, "no code cites a docs page"
    missing = {c: where for c, where in cited.items()
               if not (ROOT / c).is_file() and not c.startswith("docs/topics/")}
    assert not missing, f"cited pages that do not exist: {missing}"


def test_code_cites_nothing_outside_the_repository() -> None:
    bad = []
    for path in SOURCES:
        for n, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
            if "../shared" in line or re.search(r"(?<![\w/-])physics\.md", line):
                bad.append(f"{path.relative_to(ROOT)}:{n}: {line.strip()}")
    assert not bad, "\n".join(bad[:40])


def test_ci_builds_the_docs_strictly_and_opens_them_in_a_browser() -> None:
    make = (ROOT / "Makefile").read_text(encoding="utf-8")
    ci = (ROOT / ".ci" / "run").read_text(encoding="utf-8").splitlines()
    docs = make[make.index("\ndocs:") + 1:].splitlines()[1]
    assert "sphinx" in docs and "-W" in docs.split() and "--keep-going" in docs.split()
    assert "tests/test_docs_browser.py" in make and "-m browser" in make
    assert ci.index("make docs") < ci.index("make docs-check")
    assert any("apt-get install" in ln and "chromium" in ln for ln in ci)


@pytest.mark.slow
def test_validation_page_shows_the_current_report() -> None:
    """docs/physics/validation.md holds what ``python -m wheelgym.validate`` prints now."""
    from wheelgym.validate import format_table, run_checks

    page = (DOCS / "physics" / "validation.md").read_text(encoding="utf-8")
    assert format_table(run_checks()).strip() in page


@pytest.mark.slow
def test_a_new_topic_page_is_listed_by_the_index_in_a_strict_build(tmp_path: Path) -> None:
    """The index's glob toctree takes every page of docs/topics/: a page added there builds
    strictly (``make docs``'s flags) and is linked from the index beside the others."""
    pytest.importorskip("sphinx")
    import shutil

    src = tmp_path / "docs"
    shutil.copytree(DOCS, src, ignore=shutil.ignore_patterns("_build"))
    (tmp_path / "benchmarks").symlink_to(ROOT / "benchmarks")  # the pages' figures
    (src / "topics" / "zz-new-topic.md").write_text("# A new topic\n\nA [link](../index.md).\n")
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT),
                                                        os.environ.get("PYTHONPATH", "")])}
    r = subprocess.run([sys.executable, "-m", "sphinx", "-W", "--keep-going", "-q", "-b", "html",
                        str(src), str(tmp_path / "html")], env=env, capture_output=True,
                       text=True, timeout=900)
    assert r.returncode == 0, r.stderr[-3000:]
    index = (tmp_path / "html" / "index.html").read_text(encoding="utf-8")
    for page in sorted((src / "topics").glob("*.md")):
        assert f'href="topics/{page.stem}.html"' in index, page.name
