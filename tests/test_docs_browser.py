"""The built documentation site in a real browser (``make docs-check``; CI runs it after
``make docs``): every page of ``docs/_build/html`` served on 127.0.0.1 and opened in headless
Chromium loads without console errors, every internal link resolves (to a page and, with a
``#fragment``, to an element of it), and every image has a non-zero size.

Needs Debian's ``chromium`` package (``/usr/bin/chromium``, or ``WHEELGYM_CHROMIUM``) and the
``docs`` extra (Playwright). ``WHEELGYM_DOCS_SHOTS=DIR`` also saves screenshots of the landing
page and of the ThreeWheel robot page into DIR.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from html.parser import HTMLParser
from pathlib import Path
from urllib.parse import unquote, urljoin, urlsplit

import pytest

pytestmark = pytest.mark.browser

ROOT = Path(__file__).resolve().parents[1]
HTML = ROOT / "docs" / "_build" / "html"
CHROMIUM = os.environ.get("WHEELGYM_CHROMIUM", "/usr/bin/chromium")
FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
         "--disable-component-update", "--disable-sync", "--no-first-run"]


class _Ids(HTMLParser):
    def __init__(self) -> None:
        super().__init__()
        self.ids: set[str] = set()

    def handle_starttag(self, tag, attrs):
        for k, v in attrs:
            if k in ("id", "name") and v:
                self.ids.add(v)


def _ids(path: Path, cache: dict[Path, set[str]]) -> set[str]:
    if path not in cache:
        p = _Ids()
        p.feed(path.read_text(encoding="utf-8"))
        cache[path] = p.ids
    return cache[path]


@pytest.fixture(scope="module")
def server():
    if not (HTML / "index.html").is_file():
        pytest.fail(f"{HTML} has no built site: run `make docs` first")
    proc = subprocess.Popen([sys.executable, "-u", "-m", "http.server", "0", "--bind",
                             "127.0.0.1", "--directory", str(HTML)],
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    try:
        line = proc.stdout.readline()
        m = re.search(r"port (\d+)", line)
        assert m, f"http.server did not start: {line!r}"
        yield f"http://127.0.0.1:{m.group(1)}/"
    finally:
        proc.terminate()
        proc.wait(timeout=10)


@pytest.fixture(scope="module")
def browser():
    playwright = pytest.importorskip("playwright.sync_api")  # the docs extra
    if not Path(CHROMIUM).is_file():
        pytest.fail(f"no Chromium at {CHROMIUM}: apt-get install -y chromium chromium-driver")
    with playwright.sync_playwright() as p:
        b = p.chromium.launch(executable_path=CHROMIUM, headless=True, args=FLAGS)
        try:
            yield b
        finally:
            b.close()


def _pages() -> list[str]:
    return sorted(str(p.relative_to(HTML)) for p in HTML.rglob("*.html"))


def test_every_page_loads_links_resolve_images_have_size(server, browser) -> None:
    pages = _pages()
    assert "index.html" in pages and any(p.startswith("robots/") for p in pages)
    problems: list[str] = []
    ids: dict[Path, set[str]] = {}
    context = browser.new_context(viewport={"width": 1280, "height": 900})
    page = context.new_page()
    errors: list[str] = []
    page.on("console", lambda m: errors.append(m.text) if m.type == "error" else None)
    page.on("pageerror", lambda e: errors.append(str(e)))
    checked_links = 0
    for rel in pages:
        errors.clear()
        url = urljoin(server, rel)
        response = page.goto(url, wait_until="load")
        if response is None or response.status != 200:
            problems.append(f"{rel}: HTTP {response and response.status}")
            continue
        problems += [f"{rel}: console error: {e}" for e in errors]
        for src, w, h in page.eval_on_selector_all(
                "img", "els => els.map(e => [e.getAttribute('src'), e.naturalWidth, "
                "e.naturalHeight])"):
            if not (w and h):
                problems.append(f"{rel}: image {src} has size {w}x{h}")
        for href in page.eval_on_selector_all("a[href]", "els => els.map(e => e.href)"):
            parts = urlsplit(href)
            if not href.startswith(server):
                if parts.scheme in ("http", "https") and parts.hostname in ("127.0.0.1",
                                                                            "localhost"):
                    problems.append(f"{rel}: link outside the site {href}")
                continue
            checked_links += 1
            target = HTML / unquote(parts.path[len(urlsplit(server).path):])
            if target.is_dir():
                target = target / "index.html"
            if not target.is_file():
                problems.append(f"{rel}: broken link {href}")
            elif parts.fragment and target.suffix == ".html" and \
                    unquote(parts.fragment) not in _ids(target, ids):
                problems.append(f"{rel}: link {href}: no element #{parts.fragment}")
    context.close()
    assert checked_links > len(pages), "the pages link to almost nothing"
    assert not problems, "\n".join(problems[:50])


def test_screenshots(server, browser) -> None:
    shots = os.environ.get("WHEELGYM_DOCS_SHOTS")
    context = browser.new_context(viewport={"width": 1280, "height": 900})
    page = context.new_page()
    for rel, name in (("index.html", "docs-landing.png"),
                      ("robots/three-wheel.html", "docs-robot-three-wheel.png")):
        page.goto(urljoin(server, rel), wait_until="load")
        png = page.screenshot(full_page=False)
        assert len(png) > 10_000  # a rendered page, not a blank one
        if shots:
            Path(shots).mkdir(parents=True, exist_ok=True)
            (Path(shots) / name).write_bytes(png)
    context.close()
