"""The course website (tools/build_site.py) builds, and shows every chapter, figure and function.

The site is built once for this file (module fixture, into a temporary folder; under
pytest-xdist's ``--dist loadfile`` the whole file runs on one worker). The tests that need
the build are skipped, with a message naming ``requirements-site.txt``, where the site's
dependencies are not installed (a student's course environment); CI installs them.

The references are independent of the build: the stored notebooks (titles, PNG outputs,
solution markers), the README, and the ``bayesfilt`` modules themselves (their public
functions, found by inspection, and their signatures).
"""

from __future__ import annotations

import base64
import hashlib
import importlib
import importlib.util
import inspect
import json
import re
import sys
from html.parser import HTMLParser
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tools"))
import build_site  # noqa: E402

NOTEBOOKS = sorted((ROOT / "notebooks").glob("[0-9][0-9]_*.ipynb"))
SITE_PACKAGES = ("sphinx", "myst_nb", "sphinx_book_theme", "numpydoc", "sphinx-mathjax-offline")
MISSING = [name for name in SITE_PACKAGES if importlib.util.find_spec(name) is None]
SKIP_MESSAGE = (f"the website's dependencies are not installed (missing: {', '.join(MISSING)}); "
                f"pip install -r requirements.txt -r requirements-site.txt to run these tests")


@pytest.fixture(scope="module")
def site(tmp_path_factory):
    """The built site (a folder), or the error of the build; built once for the module.

    The build works from one copy of the notebooks (``_snapshot/`` of its stage), so that a
    notebook saved meanwhile cannot mix two versions; the tests read that copy, which is the
    stored notebooks byte for byte.
    """
    if MISSING:
        pytest.skip(SKIP_MESSAGE)
    tmp = tmp_path_factory.mktemp("site")
    try:
        out = build_site.build(repository="example/bayesfilt", branch="main", quiet=True,
                               out=tmp / "site", stage_dir=tmp / "src",
                               doctrees=tmp / "doctrees", capture=True)
    except build_site.SiteError as exc:
        out = exc
    for path in (tmp / "src" / "_snapshot" / "notebooks").glob("*.ipynb"):
        SNAPSHOT[ROOT / "notebooks" / path.name] = json.loads(path.read_text(encoding="utf-8"))
    return out


SNAPSHOT: dict[Path, dict] = {}


@pytest.fixture(scope="module")
def built(site):
    if isinstance(site, Exception):
        pytest.fail(f"the site did not build: {site}")
    return site


def pages(root: Path) -> list[Path]:
    return sorted(p for p in root.rglob("*.html")
                  if p.relative_to(root).parts[0] not in ("_static", "_sources", "_downloads"))


def notebook(path: Path) -> dict:
    """The stored notebook, as the site was built from it."""
    assert path in SNAPSHOT, f"{path.name} was not part of the site's build"
    return SNAPSHOT[path]


def source(cell: dict) -> str:
    return "".join(cell["source"]) if isinstance(cell["source"], list) else cell["source"]


def title(nb: dict) -> str:
    for cell in nb["cells"]:
        if cell["cell_type"] == "markdown":
            for line in source(cell).splitlines():
                if line.startswith("# "):
                    return line[2:].strip()
    raise AssertionError("notebook without a level-1 heading")


def text_of(html: str) -> str:
    """The visible text of a page, roughly (tags removed, entities kept as they are)."""
    html = re.sub(r"<(script|style)\b.*?</\1>", " ", html, flags=re.S)
    return re.sub(r"\s+", " ", re.sub(r"<[^>]+>", " ", html))


# --- the build ------------------------------------------------------------------------------


def test_the_site_builds_with_warnings_as_errors(site):
    if isinstance(site, Exception):
        pytest.fail(f"python tools/build_site.py failed: {site}")
    assert (site / "index.html").is_file(), "the build wrote no index.html"


def test_every_chapter_has_a_page_with_download_and_binder_links(built):
    assert NOTEBOOKS, "no chapter notebooks in notebooks/"
    for path in NOTEBOOKS:
        page = built / "chapters" / f"{path.stem}.html"
        assert page.is_file(), f"no page for the chapter {path.name} (expected {page.name})"
        html = page.read_text(encoding="utf-8")
        # the title as it renders: the page's text holds the notebook's heading words
        words = [w for w in re.findall(r"\w+", title(notebook(path))) if len(w) > 2]
        assert all(w in html for w in words), f"{page.name} does not show the title of {path.name}"
        downloads = re.findall(r'href="(\.\./_downloads/[^"]+)"', html)
        assert any(d.endswith("/" + path.name) and (page.parent / d).resolve().is_file()
                   for d in downloads), f"{page.name}: no working download link to {path.name}"
        assert (f"https://mybinder.org/v2/gh/example/bayesfilt/main?labpath=notebooks%2F{path.name}"
                in html), f"{page.name}: no Binder launch link for notebooks/{path.name}"
        assert "Run it locally" in html, f"{page.name}: no note on running it locally"


def test_the_landing_page_has_the_chapters_and_the_two_setup_commands(built):
    html = (built / "index.html").read_text(encoding="utf-8")
    text = text_of(html).replace("&amp;", "&")
    for command in ("pip install -r requirements.txt && jupyter lab notebooks/",
                    "pip install -r requirements.txt && pytest"):
        assert command in text, f"the landing page lacks the set-up command {command!r}"
    for path in NOTEBOOKS:
        assert f'href="chapters/{path.stem}.html"' in html, f"the landing page lacks {path.stem}"
    for target in ("notation.html", "api/index.html", "instructors.html"):
        assert f'href="{target}"' in html, f"the landing page does not link {target}"


def test_the_site_shows_the_student_edition(built):
    for path in NOTEBOOKS:
        nb = notebook(path)
        if not any("### BEGIN SOLUTION" in source(c) for c in nb["cells"] if c["cell_type"] == "code"):
            continue
        html = (built / "chapters" / f"{path.stem}.html").read_text(encoding="utf-8")
        assert "BEGIN SOLUTION" not in html, f"{path.stem}: the page shows the solution markers"
        assert "NotImplementedError" in html or "your answer" in html, (
            f"{path.stem}: the page shows no exercise stub")


def figures_outside_exercises(nb: dict) -> list[bytes]:
    """PNG outputs of the cells the student edition keeps (not answer or check cells)."""
    found = []
    for cell in nb["cells"]:
        if cell["cell_type"] != "code":
            continue
        if "### BEGIN SOLUTION" in source(cell) or "bf.checks." in source(cell):
            continue
        for output in cell.get("outputs", []):
            data = output.get("data", {}).get("image/png")
            if data:
                found.append(base64.b64decode("".join(data) if isinstance(data, list) else data))
    return found


def test_every_figure_of_the_stored_notebooks_is_an_image_of_its_page(built):
    images = {hashlib.sha256(p.read_bytes()).hexdigest(): p.name for p in (built / "_images").iterdir()}
    total = 0
    for path in NOTEBOOKS:
        html = (built / "chapters" / f"{path.stem}.html").read_text(encoding="utf-8")
        for k, png in enumerate(figures_outside_exercises(notebook(path)), start=1):
            total += 1
            digest = hashlib.sha256(png).hexdigest()
            assert digest in images, f"{path.name}: figure {k} is not an image file of the build"
            assert f'src="../_images/{images[digest]}"' in html, (
                f"{path.name}: figure {k} is in the build but not on the chapter's page")
    assert total > 0, "the stored notebooks hold no figure at all: the test would check nothing"


class _XrefFinder(HTMLParser):
    """Cross-reference markup (class ``xref``) that is not inside a link: an unresolved reference."""

    def __init__(self):
        super().__init__()
        self.links = 0
        self.unresolved: list[str] = []
        self._open: list[str] = []

    def handle_starttag(self, tag, attrs):
        if tag == "a":
            self.links += 1
        classes = (dict(attrs).get("class") or "").split()
        if "xref" in classes and self.links == 0:
            self.unresolved.append(tag)
            self._open.append(tag)

    def handle_endtag(self, tag):
        if tag == "a":
            self.links -= 1

    def handle_data(self, data):
        if self._open:
            self.unresolved[-1] += f" {data.strip()}"
            self._open.clear()


def test_no_page_holds_a_traceback_or_an_unresolved_reference(built):
    for page in pages(built):
        html = page.read_text(encoding="utf-8")
        rel = page.relative_to(built)
        assert "Traceback (most recent call last)" not in html, f"{rel} shows a traceback"
        assert 'class="output traceback' not in html, f"{rel} shows an error output"
        finder = _XrefFinder()
        finder.feed(html)
        assert not finder.unresolved, f"{rel}: unresolved references {finder.unresolved[:5]}"
        leftover = re.findall(r"\{(?:download|doc|ref|numref|py:\w+|func|class|mod|eq)\}`", text_of(html))
        assert not leftover, f"{rel}: MyST roles left unparsed: {leftover[:5]}"


def public_functions(module) -> list[str]:
    """Public functions and classes defined in the module itself (by inspection, not ``__all__``)."""
    return [name for name, obj in vars(module).items()
            if not name.startswith("_") and (inspect.isfunction(obj) or inspect.isclass(obj))
            and obj.__module__ == module.__name__]


def test_the_api_reference_lists_every_public_function_with_its_parameters(built):
    """Every public function of every module, by inspection (not from the build's list)."""
    package = ROOT / "bayesfilt"
    modules = [".".join(("bayesfilt",) + p.relative_to(package).with_suffix("").parts)
               for p in package.rglob("*.py") if not p.name.startswith("_")]
    assert {"bayesfilt.kalman", "bayesfilt.checks.ch01"} <= set(modules), "module search is broken"
    index = (built / "api" / "index.html").read_text(encoding="utf-8")
    checked = 0
    for full in modules:
        module = importlib.import_module(full)
        page = built / "api" / f"{full.removeprefix('bayesfilt.')}.html"
        assert page.is_file(), f"no API page for {full}"
        assert f'href="{page.name}"' in index, f"the API index does not link {page.name}"
        html = page.read_text(encoding="utf-8")
        for name in public_functions(module):
            anchor = f'id="{full}.{name}"'
            assert anchor in html, f"{page.name} does not document {full}.{name}"
            obj = getattr(module, name)
            if not inspect.isfunction(obj):
                continue
            # its entry: from its anchor to the next documented object
            entry = html.split(anchor, 1)[1].split('<dt class="sig', 1)[0]
            params = [p for p in inspect.signature(obj).parameters.values()
                      if p.kind not in (p.VAR_POSITIONAL, p.VAR_KEYWORD)]
            # (the signature names them; the docstring's Parameters section, where the library
            # has one, gives their types and shapes)
            for param in params:
                assert re.search(rf"\b{re.escape(param.name)}\b", text_of(entry)), (
                    f"{full}.{name}: the parameter {param.name!r} is not on the API page")
            checked += 1
    assert checked >= 40, f"only {checked} public functions found: the inspection is broken"


def test_chapter_pages_link_the_functions_they_name_to_the_api_reference(built):
    linked = 0
    for path in NOTEBOOKS:
        html = (built / "chapters" / f"{path.stem}.html").read_text(encoding="utf-8")
        named = set()
        for cell in notebook(path)["cells"]:
            if cell["cell_type"] == "markdown":
                named |= set(re.findall(r"`bf\.([a-z_]+)\.([A-Za-z_]\w*)(?:\(\))?`", source(cell)))
        for module_name, name in sorted(named):
            try:
                module = importlib.import_module(f"bayesfilt.{module_name}")
            except ImportError:
                continue
            if not inspect.isfunction(getattr(module, name, None)):
                continue
            href = f'href="../api/{module_name}.html#bayesfilt.{module_name}.{name}"'
            assert href in html, f"{path.stem}: `bf.{module_name}.{name}` is not linked to its API entry"
            linked += 1
    assert linked > 0, "no chapter names a bayesfilt function in its text: the test checks nothing"


def test_maths_is_served_by_the_site_itself(built):
    mathjax = built / "_static" / "mathjax" / "tex-chtml.js"
    assert mathjax.is_file(), "MathJax is not in the build (_static/mathjax/tex-chtml.js)"
    fonts = list((built / "_static" / "mathjax").rglob("*.woff"))
    assert fonts, "MathJax's fonts are not in the build"
    for page in pages(built):
        html = page.read_text(encoding="utf-8")
        rel = page.relative_to(built)
        scripts = re.findall(r'<script[^>]*\bsrc="([^"]+)"', html)
        remote = [s for s in scripts if re.match(r"(https?:)?//", s)]
        assert not remote, f"{rel} loads scripts from the network: {remote}"
        styles = re.findall(r'<link[^>]*rel="stylesheet"[^>]*href="([^"]+)"', html)
        assert not [s for s in styles if re.match(r"(https?:)?//", s)], f"{rel} loads remote CSS"
        if 'class="math' in html:
            assert any(s.endswith("_static/mathjax/tex-chtml.js") for s in scripts), (
                f"{rel} has maths but does not load the local MathJax")


def test_the_notation_page_is_the_readmes_table(built):
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    section = readme.split("\n## Notation", 1)[1].split("\n## ", 1)[0]
    rows = [line.split("|")[1].strip() for line in section.splitlines()
            if line.startswith("| ") and not line.startswith("| ---")]
    assert len(rows) > 5, "the README's notation table was not found"
    text = text_of((built / "notation.html").read_text(encoding="utf-8"))
    for row in rows:
        assert row in text, f"the notation page lacks the README's row {row!r}"


def test_the_css_has_a_cjk_fallback_font(built):
    css = (built / "_static" / "course.css").read_text(encoding="utf-8")
    assert "Noto Sans CJK KR" in css and "Malgun Gothic" in css, "no CJK fallback font in course.css"
    html = (built / "index.html").read_text(encoding="utf-8")
    assert "_static/course.css" in html, "the pages do not load course.css"


# --- the pieces of the build that need no Sphinx ----------------------------------------------


def test_markdown_section_stops_at_the_next_section_and_names_a_missing_one():
    text = "# T\n\n## A\n\none\n```\n## not a heading\n```\n## B\n\ntwo\n"
    assert build_site.markdown_section(text, "A", "X.md") == "one\n```\n## not a heading\n```\n"
    assert build_site.markdown_section(text, "B", "X.md") == "two\n"
    with pytest.raises(build_site.SiteError, match="X.md has no '## ' section matching 'C'"):
        build_site.markdown_section(text, "C", "X.md")


def test_links_to_the_repository_point_at_the_site_or_github():
    docs = {"notebooks/01_x.ipynb": "chapters/01_x.ipynb"}
    text = ("[ch](notebooks/01_x.ipynb#ex-1) [c](CONTRIBUTING.md) [w](https://a.b/c) [s](#top) "
            "![img](pic.png)\n```\n[code](notebooks/01_x.ipynb)\n```\n")
    out = build_site.rewrite_links(text, docs, "o/r", "main")
    assert "[ch](chapters/01_x.ipynb#ex-1)" in out
    assert "[c](https://github.com/o/r/blob/main/CONTRIBUTING.md)" in out
    assert "[w](https://a.b/c)" in out and "[s](#top)" in out and "![img](pic.png)" in out
    assert "[code](notebooks/01_x.ipynb)" in out, "a link inside a code fence was changed"
    assert build_site.rewrite_links("[n](01_x.ipynb)", docs, "o/r", "main", base="notebooks") == \
        "[n](chapters/01_x.ipynb)"


def test_the_run_box_goes_right_under_the_title():
    box = {"cell_type": "markdown", "source": "BOX"}
    cells = [{"cell_type": "code", "source": "x"},
             {"cell_type": "markdown", "source": "intro\n# Title\nmore\n", "id": "a"},
             {"cell_type": "markdown", "source": "## next"}]
    out = build_site.insert_after_title(cells, box)
    assert [c["source"] for c in out] == ["x", "intro\n# Title\n", "BOX", "more\n", "## next"]
    assert build_site.insert_after_title([{"cell_type": "markdown", "source": "# T"}], box)[1] is box
    assert build_site.insert_after_title([{"cell_type": "code", "source": "# c"}], box)[0] is box


def test_binder_link_opens_the_notebook_in_jupyterlab():
    assert build_site.binder_url("o/r", "main", "01_x.ipynb") == \
        "https://mybinder.org/v2/gh/o/r/main?labpath=notebooks%2F01_x.ipynb"


def test_a_stored_widget_repr_becomes_a_note():
    nb = {"cells": [{"cell_type": "code", "source": "interact(f, a=1)", "outputs": [
        {"output_type": "display_data", "metadata": {},
         "data": {"text/plain": ["interactive(children=(FloatSlider(value=0.05), Output()), ...)"]}},
        {"output_type": "execute_result", "metadata": {}, "data": {"text/plain": "Text(0.5, 1.0, 't')"}},
        {"output_type": "stream", "name": "stdout", "text": "FloatSlider(value=1)"}]}]}
    assert build_site.replace_widget_reprs(nb) == 1
    outputs = nb["cells"][0]["outputs"]
    assert outputs[0]["data"] == {"text/markdown": build_site.WIDGET_NOTE}
    assert outputs[1]["data"] == {"text/plain": "Text(0.5, 1.0, 't')"}, "a non-widget repr was replaced"
    assert outputs[2]["text"] == "FloatSlider(value=1)", "printed text was replaced"
