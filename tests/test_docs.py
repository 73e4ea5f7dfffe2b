"""The documentation builds without warnings (user guide, physics, API from docstrings), outside
the source tree, and its pages read as a person sees them offline: tables as tables, math as
MathML (no raw LaTeX, nothing loaded from a CDN), each API object documented once, the side
navigation filled. Where Chromium is installed, a notebook page and the API page are rendered
headless to PNG (CI machines may lack it; the HTML checks always run)."""

import importlib
import re
import shutil
import subprocess
import sys
from html.parser import HTMLParser
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
DOCS = ROOT / "docs"
RAW_TABLE = re.compile(r"\|\s*:?-{3,}:?\s*\|")
RAW_LATEX = re.compile(r"\\(frac|lambda|sigma|int|sum|mathrm|text|left|right|sqrt|pi)\b"
                       r"|\^\{|_\{|\$\$")
#: Elements whose text is code or already-rendered math, not prose.
VERBATIM = {"pre", "code", "math", "script", "style", "kbd", "samp", "tt", "textarea"}


@pytest.fixture(scope="module")
def html(tmp_path_factory):
    """One build for the module (the docs take ~20 s to build)."""
    build = tmp_path_factory.mktemp("docs")
    before = {p for p in DOCS.rglob("*")}
    result = subprocess.run(
        [sys.executable, "-m", "sphinx", "-W", "--keep-going", "-q", "-b", "html", str(DOCS),
         str(build / "html")],
        capture_output=True, text=True,
    )
    assert result.returncode == 0, result.stderr
    created = sorted(str(p.relative_to(DOCS)) for p in set(DOCS.rglob("*")) - before)
    assert not created, f"the build wrote into the source tree: {created[:5]}"
    return build / "html"


class Page(HTMLParser):
    """Prose text (outside code and math), external resources, API entries, the sidebar."""

    def __init__(self):
        super().__init__(convert_charrefs=True)
        self.stack, self.prose, self.resources, self.entries = [], [], [], []
        self.math = 0
        self.nav_links = 0
        self._in_nav = 0

    def handle_starttag(self, tag, attrs):
        attrs = dict(attrs)
        if tag not in ("br", "img", "link", "meta", "input", "hr", "source", "col", "wbr"):
            self.stack.append(tag)
        if tag == "math":
            self.math += 1
        for key in ("src", "href"):
            if tag in ("script", "link", "img", "iframe") and attrs.get(key, "").startswith(
                    ("http:", "https:", "//")):
                self.resources.append(attrs[key])
        if tag == "dt" and "sig-object" in (attrs.get("class") or "") and attrs.get("id"):
            self.entries.append(attrs["id"])
        if tag == "nav" and "bd-docs-nav" in (attrs.get("class") or ""):
            self._in_nav = len(self.stack)
        if self._in_nav and tag == "a":
            self.nav_links += 1

    def handle_endtag(self, tag):
        if tag in self.stack:
            while self.stack and self.stack.pop() != tag:
                pass
        if self._in_nav and len(self.stack) < self._in_nav:
            self._in_nav = 0

    def handle_data(self, data):
        if not VERBATIM.intersection(self.stack):
            self.prose.append(data)


def parse(path) -> Page:
    page = Page()
    page.feed(path.read_text(encoding="utf-8"))
    return page


def pages(html):
    return sorted(p for p in html.rglob("*.html") if "_static" not in p.parts
                  and not p.name.startswith(("genindex", "search")))


def test_sphinx_builds_without_warnings(html):
    assert (html / "api.html").is_file()
    assert (html / "notebooks" / "01_paper_reproduction.html").is_file()


def test_pages_read_offline_tables_and_math_rendered(html):
    """No raw Markdown table rows, no raw LaTeX in prose, nothing fetched from another host."""
    problems = []
    for path in pages(html):
        page = parse(path)
        prose = "".join(page.prose)
        name = path.relative_to(html)
        if RAW_TABLE.search(prose):
            problems.append(f"{name}: raw table {RAW_TABLE.search(prose)[0]!r}")
        latex = RAW_LATEX.search(prose)
        if latex:
            problems.append(f"{name}: raw LaTeX near {prose[latex.start() - 30:latex.end() + 30]!r}")
        problems += [f"{name}: loads {url}" for url in page.resources]
        if not page.nav_links:
            problems.append(f"{name}: empty side navigation")
    assert not problems, "\n".join(problems[:20])
    notebook = (html / "notebooks" / "01_paper_reproduction.html").read_text(encoding="utf-8")
    assert notebook.count("<table") >= 3  # the paper-against-radiosim table and the sweeps'
    assert parse(html / "api.html").math > 10  # the radiometry docstrings' formulas
    assert "<math" in (html / "scene.html").read_text(encoding="utf-8")


def _resolve(name):
    parts = name.split(".")
    for i in range(len(parts), 0, -1):
        try:
            obj = importlib.import_module(".".join(parts[:i]))
        except ImportError:
            continue
        for part in parts[i:]:
            obj = getattr(obj, part, None)
        return obj
    return None


def test_each_api_object_documented_once(html):
    """A class or function re-exported by another module appears once, where it is defined."""
    seen = {}
    duplicates = []
    for entry in parse(html / "api.html").entries:
        if entry.count(".") > 3:  # members follow their class
            continue
        obj = _resolve(entry)
        if not (isinstance(obj, type) or callable(obj)):
            continue
        # keep each object alive: a bound method made for the lookup would free its id
        if id(obj) in seen and seen[id(obj)][0] != entry:
            duplicates.append(f"{entry} is {seen[id(obj)][0]}")
        seen.setdefault(id(obj), (entry, obj))
    assert not duplicates, duplicates


def test_screenshots_in_a_real_browser(html, tmp_path):
    """Chromium renders a notebook page and the API page (skipped where it is not installed):
    the PNGs are written, non-trivial, and kept beside the build for a person to look at."""
    browser = shutil.which("chromium") or shutil.which("chromium-browser")
    if browser is None:
        pytest.skip("chromium is not installed (Debian: apt-get install chromium)")
    for page in ("notebooks/01_paper_reproduction.html", "api.html"):
        png = html.parent / (Path(page).stem + ".png")
        result = subprocess.run(
            [browser, "--headless", "--no-sandbox", "--disable-gpu", "--hide-scrollbars",
             f"--screenshot={png}", "--window-size=1280,2000", (html / page).as_uri()],
            capture_output=True, text=True, timeout=120)
        assert result.returncode == 0 and png.is_file(), result.stderr[-500:]
        assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and png.stat().st_size > 50_000
