"""The documentation site: `mkdocs build --strict` (mkdocs.yml) builds docs/ with no warning (a broken link, a
missing anchor or a page left out of the nav fails it), and the built site, served over HTTP and opened in
headless Chromium, has its navigation, its pages and a search that finds what the pages say."""

from __future__ import annotations

import functools
import http.server
import os
import subprocess
import threading
from collections.abc import Iterator
from pathlib import Path

import pytest
from playwright.sync_api import Locator, Page, sync_playwright
from playwright.sync_api import TimeoutError as PlaywrightTimeout

from tests.conftest import ROOT
from tests.test_evidence import CHROMIUM_ARGS

MKDOCS = ROOT / ".venv" / "bin" / "mkdocs"


def build(site: Path, config: Path = ROOT / "mkdocs.yml") -> subprocess.CompletedProcess[str]:
    env = {**os.environ, "NO_MKDOCS_2_WARNING": "1"}
    command = [str(MKDOCS), "build", "--strict", "--config-file", str(config), "--site-dir", str(site)]
    return subprocess.run(command, capture_output=True, text=True, check=False, env=env, cwd=ROOT, timeout=300)


@pytest.fixture(scope="module")
def site(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("site")
    built = build(out)
    assert built.returncode == 0, built.stdout + built.stderr
    assert "WARNING" not in built.stdout + built.stderr
    return out


@pytest.fixture(scope="module")
def served(site: Path) -> Iterator[str]:
    handler = functools.partial(_Quiet, directory=str(site))
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    yield f"http://127.0.0.1:{server.server_address[1]}"
    server.shutdown()


def _search(page: Page, query: str, title: str, log: list[str]) -> Locator:
    """The search result titled `title` for `query`, typed in the header's search box (visible at a desktop
    width). A web worker builds the search index after the page loads, which takes a while on a loaded machine:
    the query's last letter is typed again every two seconds (a new query) until the result shows, a minute at
    most."""
    box = page.locator("input.md-search__input")
    result = page.locator(".md-search-result__item", has_text=title).first
    box.fill(query)
    for _ in range(30):
        try:
            result.wait_for(timeout=2_000)
        except PlaywrightTimeout:
            box.press("Backspace")
            box.press(query[-1])
            continue
        return result
    shown = page.locator(".md-search-result").inner_text()[:300]
    raise AssertionError(f"no search result {title!r} for {query!r}; shown: {shown!r}; console: {log[-5:]}")


class _Quiet(http.server.SimpleHTTPRequestHandler):
    def log_message(self, *args: object) -> None:
        pass


def test_every_page_of_docs_is_built(site: Path) -> None:
    pages = sorted(p.relative_to(ROOT / "docs").with_suffix(".html") for p in (ROOT / "docs").rglob("*.md"))
    built = [Path("index.html") if p == Path("README.html") else p for p in pages]
    assert [p for p in built if not (site / p).is_file()] == []
    assert (site / "reference" / "spec-schema.html").read_text(encoding="utf-8").count("#:schema") >= 1


def test_a_broken_link_fails_the_build(tmp_path: Path) -> None:
    """Strict mode is on: a link to a page that does not exist stops the build, with its name."""
    docs = tmp_path / "docs"
    docs.mkdir()
    (docs / "index.md").write_text("# Home\n\nSee [the guide](guides/nowhere.md).\n", encoding="utf-8")
    config = tmp_path / "mkdocs.yml"
    config.write_text("site_name: t\ndocs_dir: docs\nstrict: true\ntheme:\n  name: material\n  font: false\n")
    built = build(tmp_path / "site", config)
    assert built.returncode != 0 and "guides/nowhere.md" in built.stdout + built.stderr


def test_the_site_navigates_and_searches_in_chromium(served: str) -> None:
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path="/usr/bin/chromium", args=CHROMIUM_ARGS)
        page = browser.new_page()
        errors: list[str] = []
        log: list[str] = []
        page.on("pageerror", lambda e: errors.append(str(e)))
        page.on("console", lambda m: log.append(f"{m.type}: {m.text}"))
        page.goto(f"{served}/index.html")
        nav = page.locator("nav.md-nav--primary").inner_text()
        for title in ("Tutorial", "Property patterns", "Commands", "The spec format as a JSON Schema", "Findings"):
            assert title in nav, nav
        page.locator("nav.md-nav--primary a", has_text="Tutorial").first.click()
        page.wait_for_url("**/tutorial.html")
        assert page.locator("h1").first.inner_text().startswith("Tutorial: a stairwell light")
        result = _search(page, "debounce", "Property patterns", log)
        result.click()
        page.wait_for_url("**/guides/property-patterns.html*")
        assert "debounce" in page.locator("article").inner_text().lower()
        browser.close()
    assert errors == []
