"""The documentation site: built without warnings, examples run, links and
API pages complete, and the pages load in a real headless browser.

The site is built once per session with Sphinx into a temporary folder
(``-W --keep-going``: every warning is an error). Without Sphinx or Chromium
these tests skip, except where ``GEOALPHA_REQUIRE_DOCS`` is set (CI sets it in
``.ci/run``), where a missing tool is a failure.
"""

from __future__ import annotations

import importlib
import importlib.util
import os
import pkgutil
import re
import subprocess
import sys
import zlib
from html.parser import HTMLParser
from pathlib import Path
from urllib.parse import unquote, urlsplit

import pytest

import geoalpha

ROOT = Path(__file__).resolve().parent.parent
DOCS = ROOT / "docs"
REQUIRED = bool(os.environ.get("GEOALPHA_REQUIRE_DOCS"))


def _missing(what: str) -> None:
    if REQUIRED:
        pytest.fail(f"{what} is missing, and GEOALPHA_REQUIRE_DOCS is set (CI)")
    pytest.skip(f"{what} is not installed")


def _sphinx(builder: str, out: Path, doctrees: Path) -> subprocess.CompletedProcess:
    command = [sys.executable, "-m", "sphinx", "-W", "--keep-going", "-q"]
    return subprocess.run(
        [*command, "-b", builder, "-d", str(doctrees), str(DOCS), str(out)],
        capture_output=True,
        text=True,
        timeout=600,
        cwd=ROOT,
        env={**os.environ, "PYTHONPATH": str(ROOT)},
    )


@pytest.fixture(scope="session")
def build(tmp_path_factory):
    """The HTML build: (its folder, the finished sphinx process)."""
    if importlib.util.find_spec("sphinx") is None:
        _missing('Sphinx (pip install -e ".[dask]" --group docs, pip >= 25.1)')
    base = tmp_path_factory.mktemp("docs")
    html = base / "html"
    return html, _sphinx("html", html, base / "doctrees"), base


@pytest.fixture(scope="session")
def site(build):
    html, _, _ = build
    if not (html / "index.html").exists():
        pytest.fail("the docs build wrote no index.html")
    return html


def test_build_has_no_warnings(build):
    _, done, _ = build
    assert done.returncode == 0, done.stdout + done.stderr


def test_examples_of_the_pages_run(build):
    _, _, base = build
    done = _sphinx("doctest", base / "doctest", base / "doctrees")
    report = (base / "doctest" / "output.txt").read_text()
    assert done.returncode == 0, done.stdout + done.stderr + report
    # The guide's examples ran, and none of them failed.
    tested = int(re.search(r"(\d+) tests\n\s+0 failures in tests", report).group(1))
    assert tested >= 30, report


class _Links(HTMLParser):
    """The local href/src targets and the ids of one HTML file."""

    def __init__(self):
        super().__init__()
        self.targets: list[str] = []
        self.ids: set[str] = set()

    def handle_starttag(self, tag, attrs):
        attrs = dict(attrs)
        if attrs.get("id"):
            self.ids.add(attrs["id"])
        if tag == "a" and attrs.get("name"):
            self.ids.add(attrs["name"])
        for key in ("href", "src"):
            value = attrs.get(key)
            if value and not urlsplit(value).scheme and not value.startswith("//"):
                self.targets.append(value)


def _parse(path: Path) -> _Links:
    parser = _Links()
    parser.feed(path.read_text(encoding="utf-8"))
    return parser


def test_every_local_link_resolves(site):
    pages = {
        path: _parse(path)
        for path in site.rglob("*.html")
        if "_static" not in path.relative_to(site).parts  # theme templates
    }
    broken = []
    for page, links in pages.items():
        for target in links.targets:
            parts = urlsplit(target)
            dest = (page.parent / unquote(parts.path)).resolve() if parts.path else page
            if dest.is_dir():
                dest = dest / "index.html"
            if not dest.exists():
                broken.append(f"{page.relative_to(site)}: {target} (no such file)")
            elif parts.fragment and dest.suffix == ".html":
                ids = pages[dest].ids if dest in pages else _parse(dest).ids
                if unquote(parts.fragment) not in ids:
                    broken.append(f"{page.relative_to(site)}: {target} (no anchor)")
    assert len(pages) > 40
    assert not broken, "\n".join(broken)


def _inventory(site: Path) -> dict[str, str]:
    """Python objects documented in the site: full name -> page."""
    data = (site / "objects.inv").read_bytes()
    body = zlib.decompress(data.split(b"\n", 4)[4]).decode()
    found = {}
    for line in body.splitlines():
        match = re.match(r"(\S+) py:(\w+) -?\d+ (\S+)", line)
        if match:
            found[match.group(1)] = match.group(3)
    return found


def _public_names() -> dict[str, object]:
    """Every name in the ``__all__`` of geoalpha and of its modules."""
    names = {f"geoalpha.{n}": getattr(geoalpha, n) for n in geoalpha.__all__}
    for info in pkgutil.iter_modules(geoalpha.__path__):
        if info.name.startswith("_"):
            continue
        module = importlib.import_module(f"geoalpha.{info.name}")
        for name in getattr(module, "__all__", []):
            names[f"{module.__name__}.{name}"] = getattr(module, name)
    names.pop("geoalpha.__version__")
    return names


def _resolve(full_name: str):
    module, _, name = full_name.rpartition(".")
    try:
        return getattr(importlib.import_module(module), name)
    except (ImportError, AttributeError):
        return None


def test_every_public_name_has_an_api_page(site):
    documented = _inventory(site)
    objects = {id(_resolve(name)) for name in documented}
    undocumented = [
        name
        for name, obj in _public_names().items()
        if name not in documented
        and not (callable(obj) and id(obj) in objects)
        and name != "geoalpha._cli.main"  # the click command: see the next test
    ]
    assert not undocumented, f"add these to docs/api/index.rst: {undocumented}"
    assert documented["geoalpha.hull"].startswith("api/generated/geoalpha.hull.html")


def test_the_command_line_page_is_generated_from_click(site):
    from geoalpha._cli import main

    page = (site / "cli.html").read_text(encoding="utf-8")
    for command in main.commands.values():
        assert f"geoalpha {command.name}" in page
        for param in command.params:
            for opt in param.opts:
                if opt.startswith("-"):
                    assert opt in page, f"{command.name} {opt} missing from cli.html"


def test_front_page_and_readme_agree_on_set_up():
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    ci = (ROOT / ".ci" / "run").read_text(encoding="utf-8")
    start = (DOCS / "getting_started.md").read_text(encoding="utf-8")
    for command in (
        "pip install . && geoalpha demo hulls.gpkg",
        'pip install -e ".[test]" && python -m pytest',
    ):
        assert command in readme and command in start
    assert "\npython -m pytest\n" in ci  # the README's test command, as it is


def test_readme_is_a_front_page_linking_every_docs_page():
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    assert len(readme.splitlines()) <= 150
    links = re.findall(r"\]\(([^)#]+)(?:#[^)]*)?\)", readme)
    local = [link for link in links if not urlsplit(link).scheme]
    missing = [link for link in local if not (ROOT / link).exists()]
    assert not missing, f"README links to files that do not exist: {missing}"
    pages = [
        path.relative_to(ROOT).as_posix()
        for path in sorted(DOCS.glob("*.md")) + sorted(DOCS.glob("user_guide/*.md"))
        if path.name not in ("index.md", "changelog.md", "case_study.md")
    ]
    unlinked = [page for page in pages if page not in local]
    assert not unlinked, f"README does not link these docs pages: {unlinked}"


def _render():
    spec = importlib.util.spec_from_file_location(
        "render_docs", ROOT / "scripts" / "render_docs.py"
    )
    module = importlib.util.module_from_spec(spec)
    sys.modules.setdefault("render_docs", module)  # dataclasses look it up
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="module")
def browser():
    render = _render()
    if render.find_chromium() is None:
        _missing("chromium (apt-get install chromium)")
    return render


CASE_STUDY = (
    "UK road accidents: the seed paper\N{RIGHT SINGLE QUOTATION MARK}s case study, "
    "reproduced with geoalpha"
)


@pytest.mark.parametrize(
    ("page", "title", "headings"),
    [
        ("index.html", "geoalpha", ["geoalpha", "Where to go next"]),
        ("api/generated/geoalpha.hull.html", "geoalpha.hull", ["geoalpha.hull"]),
        ("user_guide/crs.html", "Coordinate reference systems", None),
        (
            "uk_accidents_case_study.html",
            CASE_STUDY,
            [CASE_STUDY, "1. The data", "2. The optimal hulls on a map (paper Fig. 2)"],
        ),
    ],
)
def test_pages_load_in_chromium_without_errors(browser, site, page, title, headings):
    shown = browser.load_page(site / page)
    assert shown.errors == []
    assert shown.title.startswith(f"{title} ")
    assert shown.headings[: len(headings or [title])] == (headings or [title])
    # A real rendering: a PNG of the window, not a blank one.
    assert shown.png.startswith(b"\x89PNG") and len(shown.png) > 20_000


def test_the_browser_check_sees_console_errors(browser, tmp_path):
    page = tmp_path / "broken.html"
    page.write_text(
        "<html><head><title>broken</title></head><body><h1>x</h1>"
        "<script>console.error('boom'); undefinedFunction();</script>"
        "<img src='missing.png'></body></html>"
    )
    shown = browser.load_page(page, screenshot=False)
    text = "\n".join(shown.errors)
    assert "console.error: boom" in text
    assert "undefinedFunction" in text
    assert "missing.png" in text or "ERR_FILE_NOT_FOUND" in text
