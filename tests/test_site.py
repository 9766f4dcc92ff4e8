"""The course website (tools/build_site.py) builds, and shows every chapter, figure and function.

The site is built once for this file (module fixture, into a temporary folder; under
pytest-xdist's ``--dist loadfile`` the whole file runs on one worker). A second, small site
is built from two notebooks and a glossary written by the tests themselves (no API pages),
to show that the checks catch what they look for: a stray ``$``, a figure without alt text,
a chapter beyond the source notes, a glossary page. The tests that need
the build are skipped, with a message naming ``requirements-site.txt``, where the site's
dependencies are not installed (a student's course environment); CI installs them.

The references are independent of the build: the stored notebooks (titles, PNG outputs,
solution markers), the README, and the ``bayesfilt`` modules themselves (their public
functions, found by inspection, and their signatures).
"""

from __future__ import annotations

import base64
import hashlib
import unicodedata
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
SITE_PACKAGES = ("sphinx", "myst_nb", "sphinx_book_theme", "numpydoc", "sphinx-mathjax-offline",
                 "sphinx_copybutton")
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


# A 1x1 PNG (a figure output for the small site's notebooks).
PNG = ("iVBORw0KGgoAAAANSUhEUgAAAAEAAAABCAYAAAAfFcSJAAAADUlEQVR42mP8z8BQDwAEhQGAhKmMIQAAAABJRU5ErkJggg==")
TOY_ALT = "A single grey pixel: the toy figure of the test."


def _nb(title: str, cells: list[dict], metadata: dict | None = None) -> dict:
    meta = {"kernelspec": {"display_name": "Python 3", "language": "python", "name": "python3"},
            "language_info": {"name": "python"}}
    meta.update(metadata or {})
    return {"cells": [{"cell_type": "markdown", "id": "title", "metadata": {}, "source": f"# {title}\n"}]
            + cells, "metadata": meta, "nbformat": 4, "nbformat_minor": 5}


def _figure_cell(cell_id: str, metadata: dict) -> dict:
    return {"cell_type": "code", "id": cell_id, "metadata": metadata, "execution_count": 1,
            "source": "plt.plot([0, 1])",
            "outputs": [{"output_type": "display_data", "metadata": {},
                         "data": {"image/png": PNG, "text/plain": "<Figure>"}}]}


@pytest.fixture(scope="module")
def toy_site(tmp_path_factory):
    """A small site from the tests' own notebooks and glossary (built once; no API pages).

    Chapter 01 has a display glued to the text above it, a stray ``$``, a figure with alt text
    in its cell metadata and one without; chapter 09 is marked beyond the source notes.
    """
    if MISSING:
        pytest.skip(SKIP_MESSAGE)
    tmp = tmp_path_factory.mktemp("toy")
    notebooks = tmp / "notebooks"
    notebooks.mkdir()
    md = lambda i, text: {"cell_type": "markdown", "id": i, "metadata": {}, "source": text}
    toy = _nb("01 · A toy chapter", [
        md("glued", "The update is\n$$\nK = \\frac{P}{P + R}\n$$\nand nothing else.\n"),
        md("stray", "A stray dollar: it costs 5 $ here.\n"),
        _figure_cell("with-alt", {"mystnb": {"image": {"alt": TOY_ALT}}}),
        _figure_cell("without-alt", {}),
    ])
    beyond = _nb("09 · Further than the notes", [md("text", "Some text, and $x_t$ inline.\n")],
                 {"bayesfilt": {"beyond_sources": True}})
    (notebooks / "01_toy.ipynb").write_text(json.dumps(toy), encoding="utf-8")
    (notebooks / "09_beyond.ipynb").write_text(json.dumps(beyond), encoding="utf-8")
    glossary = tmp / "GLOSSARY.md"
    glossary.write_text("# Glossary\n\n| English | 한국어 | chapter |\n| --- | --- | --- |\n"
                        "| prediction | 예측 | 01 |\n| smoothing | 평활 | 09 |\n", encoding="utf-8")
    try:
        return build_site.build(repository="example/bayesfilt", quiet=True, out=tmp / "site",
                                stage_dir=tmp / "src", doctrees=tmp / "doctrees", capture=True,
                                notebooks_dir=notebooks, glossary=glossary, api=False)
    except build_site.SiteError as exc:
        pytest.fail(f"the small test site did not build: {exc}")


class StrayTeX(HTMLParser):
    """Text outside maths, code and scripts that holds a ``$`` or a ``\\command``.

    Before MathJax runs, maths is the text of ``.math`` elements (``\\(x_t\\)``); everything
    else a reader sees as it is. A ``$`` or ``\\Sigma`` there means a formula the site did not
    read as maths (the browser check asserts the same after MathJax has run).
    """

    SKIP_TAGS = {"script", "style", "pre", "code", "kbd", "samp", "textarea", "math"}
    VOID = {"br", "img", "hr", "meta", "link", "input", "source", "wbr", "col", "area", "base",
            "embed", "param", "track"}
    PATTERN = re.compile(r"\$|\\[A-Za-z]+")

    def __init__(self):
        super().__init__(convert_charrefs=True)
        self._stack: list[tuple[str, bool]] = []
        self.found: list[str] = []

    def _skipping(self) -> bool:
        return bool(self._stack) and self._stack[-1][1]

    def handle_starttag(self, tag, attrs):
        if tag in self.VOID:
            return
        classes = (dict(attrs).get("class") or "").split()
        skip = (self._skipping() or tag in self.SKIP_TAGS or "math" in classes
                or "highlight" in classes)
        self._stack.append((tag, skip))

    def handle_endtag(self, tag):
        for k in range(len(self._stack) - 1, -1, -1):
            if self._stack[k][0] == tag:
                del self._stack[k:]
                return

    def handle_data(self, data):
        if self._skipping():
            return
        for match in self.PATTERN.finditer(data):
            self.found.append(data[max(0, match.start() - 40):match.end() + 40].replace("\n", " "))


def stray_tex(html: str) -> list[str]:
    finder = StrayTeX()
    finder.feed(html)
    return finder.found


class FigureImages(HTMLParser):
    """The ``<img>`` of cell outputs: (src, alt, href of the enclosing link or None)."""

    def __init__(self):
        super().__init__(convert_charrefs=True)
        self.images: list[tuple[str, str, str | None]] = []
        self._output = 0      # depth inside a div.cell_output
        self._divs: list[bool] = []
        self._links: list[str | None] = []

    def handle_starttag(self, tag, attrs):
        attrs = dict(attrs)
        if tag == "div":
            is_output = "cell_output" in (attrs.get("class") or "").split()
            self._divs.append(is_output)
            self._output += is_output
        elif tag == "a":
            self._links.append(attrs.get("href"))
        elif tag == "img" and self._output:
            self.images.append((attrs.get("src") or "", attrs.get("alt") or "",
                                self._links[-1] if self._links else None))

    def handle_endtag(self, tag):
        if tag == "div" and self._divs:
            self._output -= self._divs.pop()
        elif tag == "a" and self._links:
            self._links.pop()


def figures(html: str) -> list[tuple[str, str, str | None]]:
    finder = FigureImages()
    finder.feed(html)
    return finder.images


def bad_alt(src: str, alt: str) -> bool:
    """Alt text that describes nothing: empty, the file's path or name (one word with a slash,
    where a sentence may well say "1/2"), or an image file name."""
    alt = alt.strip()
    return (not alt or alt == src or ("/" in alt and " " not in alt) or alt == src.rsplit("/", 1)[-1]
            or bool(re.search(r"\.(png|jpe?g|svg|gif)$", alt, re.I)))


def article(html: str) -> str:
    """The page's article (the text column), without the theme's header and sidebars."""
    match = re.search(r"<article\b.*?</article>", html, flags=re.S)
    assert match, "the page has no <article>"
    return match.group(0)


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
        # the run box's link and the header's download menu: the student edition, served
        assert f'<a class="reference download" href="../notebooks/{path.name}" download>' in html, (
            f"{page.name}: no download link to ../notebooks/{path.name} in the run box")
        header = html.split("article-header-buttons", 1)[-1].split("</article>", 1)[0][:20000]
        assert f'href="../notebooks/{path.name}"' in header, (
            f"{page.name}: the header's download menu does not offer the notebook")
        served = built / "notebooks" / path.name
        assert served.is_file(), f"the site does not serve notebooks/{path.name}"
        student = json.loads(served.read_text(encoding="utf-8"))
        assert len(student["cells"]) == len(notebook(path)["cells"]), (
            f"notebooks/{path.name} of the site is not the chapter's notebook")
        assert not any("### BEGIN SOLUTION" in source(c) for c in student["cells"]), (
            f"notebooks/{path.name} of the site holds the solutions (not the student edition)")
        binder = f"https://mybinder.org/v2/gh/example/bayesfilt/main?labpath=notebooks%2F{path.name}"
        assert html.count(binder) >= 2, (
            f"{page.name}: no Binder launch link for notebooks/{path.name} in the run box and "
            f"the header's launch menu")
        assert "Run it locally" in html, f"{page.name}: no note on running it locally"


def test_the_landing_page_has_the_chapters_and_the_two_setup_commands(built):
    html = (built / "index.html").read_text(encoding="utf-8")
    text = text_of(html).replace("&amp;", "&")
    for command in ("pip install -r requirements.txt && jupyter lab notebooks/",
                    "pip install -r requirements.txt && pytest"):
        assert command in text, f"the landing page lacks the set-up command {command!r}"
    body = article(html)
    for path in NOTEBOOKS:
        assert f'href="chapters/{path.stem}.html"' in body, f"the landing page lacks {path.stem}"
    for target in ("notation.html", "api/index.html", "instructors.html"):
        assert f'href="{target}"' in body, f"the landing page does not link {target}"
    # one "The chapters" heading, and no toctree caption printed a second time under it
    assert len(re.findall(r"<h2>The chapters", body)) == 1, "'The chapters' heading missing or twice"
    assert "caption-text" not in body, "a toctree caption is printed in the landing page's text"
    zip_file = built / "notebooks" / build_site.ZIP_NAME
    assert zip_file.is_file() and f'href="notebooks/{build_site.ZIP_NAME}"' in body, (
        "the landing page does not link the zip of the student notebooks")


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


TEX_LETTERS = {
    "alpha": "α", "beta": "β", "gamma": "γ", "delta": "δ", "epsilon": "ε", "kappa": "κ",
    "mu": "μ", "xi": "ξ", "pi": "π", "rho": "ρ", "sigma": "σ", "phi": "φ", "varphi": "φ",
    "Gamma": "Γ", "Pi": "Π", "Sigma": "Σ", "Omega": "Ω", "ell": "ℓ", "sum": "Σ", "top": "T",
    "Delta": "Δ", "tau": "τ", "theta": "θ", "lambda": "λ", "Lambda": "Λ", "Psi": "Ψ",
    "infty": "∞", "mathcal": " ", "mathrm": " ", "lfloor": " ", "rfloor": " ",
}


def letters(text: str) -> str:
    """The letters and digits of a text, in order, with maths markup reduced to what it shows.

    ``$\\hat x_{t\\vert t}$`` and ``x̂_{t|t}`` both give ``xtt``; ``G^\\top`` and ``Gᵀ`` give
    ``GT``; ``\\Sigma`` and ``Σ`` give ``Σ``. Accents, sub- and superscript marks, markup and
    spaces are dropped.
    """
    text = re.sub(r"\\([A-Za-z]+)", lambda m: TEX_LETTERS.get(m.group(1), " "), text)
    text = unicodedata.normalize("NFKD", text)
    return "".join(ch for ch in text if ch.isalnum() and not unicodedata.combining(ch))


def test_letters_reduces_tex_and_readme_pseudo_tex_to_the_same_letters():
    assert letters(r"$\hat x_{t\vert t}$, $P_{t\vert t}$") == letters("x̂_{t\\|t}, P_{t\\|t}") == "xttPtt"
    assert letters(r"`Q` ($= G Q G^\top$)") == letters("`Q` (= G Q Gᵀ)") == "QGQGT"
    assert letters(r"$K_t = P C^\top S_t^{-1}$") == letters("K_t = P Cᵀ S_t⁻¹")
    assert letters(r"$\dot\xi_1$, $\tilde M$, $\Sigma_{xx}$") == letters("ξ̇_1, M̃, Σ_xx")
    assert letters(r"$x_t$") != letters("y_t"), "a changed letter must show"


def test_the_notation_page_follows_the_readmes_notation_section():
    """site/notation.md (maths) says what README's ``## Notation`` says (plain text), row by row."""
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    section = build_site.markdown_section(readme, r"Notation", "README.md")
    page = (ROOT / "site" / "notation.md").read_text(encoding="utf-8")
    page = re.sub(r"<!--.*?-->", "", page, flags=re.S).split("\n", 1)[1]   # without the title
    page = re.sub(r"^```.*$", "", page, flags=re.M)                          # the container fence
    rows = lambda text: [line for line in text.splitlines() if line.startswith("| ")]
    assert len(rows(page)) == len(rows(section)), (
        f"site/notation.md has {len(rows(page))} table rows, README's Notation section "
        f"{len(rows(section))}: update site/notation.md to follow the README")
    for ours, theirs in zip(rows(page), rows(section)):
        assert letters(ours) == letters(theirs), (
            f"site/notation.md's row\n  {ours}\ndoes not say what README's row says\n  {theirs}\n"
            f"(compared: letters and digits, maths markup aside): update site/notation.md")
    assert letters(page) == letters(section), (
        "site/notation.md's text between the tables differs from README's Notation section: "
        "update site/notation.md")


def test_the_notation_page_is_typeset_as_maths(built):
    html = article((built / "notation.html").read_text(encoding="utf-8"))
    assert html.count('class="math') >= 100, "the notation page has (almost) no maths"
    text = text_of(re.sub(r'<span class="math[^"]*">.*?</span>', " ", html, flags=re.S))
    leftover = re.findall(r"\w_\{|[ᵀ⁻¹]|x̂", text)
    assert not leftover, f"pseudo-TeX outside maths on the notation page: {leftover[:5]}"


def test_the_css_has_a_cjk_fallback_font(built):
    css = (built / "_static" / "course.css").read_text(encoding="utf-8")
    assert "Noto Sans CJK KR" in css and "Malgun Gothic" in css, "no CJK fallback font in course.css"
    html = (built / "index.html").read_text(encoding="utf-8")
    assert "_static/course.css" in html, "the pages do not load course.css"


# --- maths, figures and the page's furniture ---------------------------------------------


def test_the_stray_tex_finder_catches_a_stray_dollar_and_a_raw_command_and_nothing_else():
    html = ('<p>fine <span class="math notranslate">\\(x_t \\Sigma\\)</span> and '
            '<code>cost = "$5"</code><pre>\\alpha</pre><script>var a = "$";</script></p>'
            '<div class="math">\\[\\hat x\\]</div><div class="highlight"><pre>$ pip</pre></div>')
    assert stray_tex(html) == []
    assert len(stray_tex(html + "<p>it costs 5 $ here</p>")) == 1
    assert len(stray_tex(html + "<p>the blocks <em>\\Sigma</em> of</p>")) == 1
    assert len(stray_tex("<li>$\\mathbf x$ is</li>")) == 3


def test_no_page_shows_a_stray_dollar_or_a_raw_tex_command(built):
    """Outside maths and code, no page's text holds `$` or `\\command` (a formula not read as maths)."""
    found = {}
    for page in pages(built):
        stray = stray_tex(page.read_text(encoding="utf-8"))
        if stray:
            found[str(page.relative_to(built))] = stray[:5]
    assert not found, ("stray TeX in the text (a `$` display glued to the line above it? "
                       f"a `$` left alone?): {found}")


SPLIT = re.compile(r"\\begin\{split\}(.*?)\\end\{split\}", re.S)


def test_no_display_puts_a_tag_inside_split(built):
    """MathJax refuses \\tag inside the split environment that Sphinx wraps around a display
    with a line break; such a display must reach the page unwrapped (site/conf.py)."""
    found = {}
    for page in pages(built):
        tagged = [m.group(1)[:60] for m in SPLIT.finditer(page.read_text(encoding="utf-8"))
                  if "\\tag" in m.group(1)]
        if tagged:
            found[str(page.relative_to(built))] = tagged[:3]
    assert not found, f"a \\tag inside \\begin{{split}} (a TeX error in the browser): {found}"
    tagged_05 = (built / "chapters" / "05_sis_weights.html").read_text(encoding="utf-8")
    assert "\\tag{4}" in tagged_05, "chapter 05's numbered two-line display (4) is missing"


def test_a_display_glued_to_text_is_a_display_and_a_stray_dollar_is_caught(toy_site):
    html = article((toy_site / "chapters" / "01_toy.html").read_text(encoding="utf-8"))
    displays = re.findall(r'<div class="math[^"]*">(.*?)</div>', html, flags=re.S)
    assert any("K = \\frac{P}{P + R}" in d for d in displays), (
        "a $$ display on the line right after text is not a display (myst_dmath_double_inline?)")
    stray = stray_tex(html)
    assert len(stray) == 1 and "costs 5 $ here" in stray[0], (
        f"the planted stray `$` (and only it) should be found: {stray}")


def test_figures_have_alt_text_from_the_cell_metadata_and_the_test_sees_a_missing_one(toy_site):
    images = figures((toy_site / "chapters" / "01_toy.html").read_text(encoding="utf-8"))
    assert len(images) == 2, f"the toy chapter's two figures: {images}"
    (src1, alt1, _), (src2, alt2, _) = images
    assert alt1 == TOY_ALT and not bad_alt(src1, alt1), (
        f"the alt text from the cell's mystnb.image.alt metadata is not on the image: {alt1!r}")
    assert bad_alt(src2, alt2), f"a figure without alt metadata should be caught: alt={alt2!r}"


def test_every_figure_of_a_chapter_has_alt_text(built):
    """Alt text from the cell metadata ``{"mystnb": {"image": {"alt": "..."}}}`` (CONTRIBUTING).

    Without it the image's alt is its file path, which a screen reader reads out.
    """
    missing = {}
    for path in NOTEBOOKS:
        html = (built / "chapters" / f"{path.stem}.html").read_text(encoding="utf-8")
        bad = [src.rsplit("/", 1)[-1][:16] for src, alt, _ in figures(html) if bad_alt(src, alt)]
        if bad:
            missing[path.name] = f"{len(bad)} of {len(figures(html))} figures"
    assert not missing, ("figures without alt text (give the figure's code cell the metadata "
                         f'{{"mystnb": {{"image": {{"alt": "<what it shows>"}}}}}}): {missing}')


def test_every_figure_of_a_chapter_links_to_its_full_size_image(built):
    checked = 0
    for path in NOTEBOOKS:
        page = built / "chapters" / f"{path.stem}.html"
        for src, _, href in figures(page.read_text(encoding="utf-8")):
            assert href == src, f"{page.name}: the figure {src} is not a link to itself ({href})"
            assert (page.parent / href).resolve().is_file(), f"{page.name}: {href} is missing"
            checked += 1
    assert checked > 0, "no figure found on the chapter pages"


def test_every_page_has_the_favicon_copy_button_and_a_valid_colour_mode(built):
    assert (built / "_static" / "favicon.svg").is_file(), "no favicon in the build"
    copybutton = (built / "_static" / "copybutton.js").read_text(encoding="utf-8")
    assert "div[class*=\"highlight-\"]:not(.output)" in copybutton, (
        "the copy button is not limited to code (it would go on outputs too)")
    for page in pages(built):
        html = page.read_text(encoding="utf-8")
        rel = page.relative_to(built)
        assert re.search(r'<link rel="icon" href="(\.\./)*_static/favicon\.svg"', html), (
            f"{rel}: no favicon link (the browser asks for /favicon.ico: a 404)")
        assert "_static/copybutton.js" in html, f"{rel}: no copy button script"
        # pydata-sphinx-theme logs "Got invalid theme mode" when this default is empty
        assert re.search(r'localStorage\.getItem\("mode"\) \|\| "(auto|light|dark)"', html), (
            f"{rel}: the theme's default colour mode is not auto/light/dark")


def test_the_search_page_loads_the_course_script_before_sphinx_search(built):
    """course.js turns off snippet fetching on file:// and takes snippets from the article."""
    html = (built / "search.html").read_text(encoding="utf-8")
    course, search = html.find("_static/course.js"), html.find("_static/searchtools.js")
    assert 0 <= course < search, "course.js must load before searchtools.js on search.html"
    script = (built / "_static" / "course.js").read_text(encoding="utf-8")
    assert "SHOW_SEARCH_SUMMARY = false" in script and "article.bd-article" in script


def test_the_print_stylesheet_wraps_code_and_hides_the_chrome(built):
    css = (built / "_static" / "course.css").read_text(encoding="utf-8")
    print_css = css.split("@media print", 1)[1]
    assert re.search(r"pre[^{]*\{[^}]*white-space:\s*pre-wrap", print_css), "code does not wrap in print"
    assert "break-inside: avoid" in print_css, "cells may break across pages"
    assert re.search(r"\.bd-sidebar-primary[^{]*\{[^}]*display:\s*none", print_css), (
        "the sidebars are printed")


def test_a_chapter_beyond_the_source_notes_is_marked_and_found_by_itself(toy_site):
    index = article((toy_site / "index.html").read_text(encoding="utf-8"))
    items = re.findall(r"<li>.*?</li>", index, flags=re.S)
    toy = [i for i in items if "chapters/01_toy.html" in i]
    beyond = [i for i in items if "chapters/09_beyond.html" in i]
    assert toy and beyond, "the chapter list does not list both chapters (found automatically)"
    assert "beyond-sources-badge" in beyond[0] and "beyond-sources-badge" not in toy[0], (
        "only the chapter marked {'bayesfilt': {'beyond_sources': true}} gets the badge")
    page = article((toy_site / "chapters" / "09_beyond.html").read_text(encoding="utf-8"))
    assert "beyond-sources-badge" in page, "the chapter's page does not show the badge"
    assert "beyond-sources-badge" not in article(
        (toy_site / "chapters" / "01_toy.html").read_text(encoding="utf-8"))


def test_the_glossary_page_comes_from_glossary_md_with_its_chapters_linked(toy_site, built):
    page = toy_site / "glossary.html"
    assert page.is_file(), "GLOSSARY.md exists but the site has no glossary page"
    html = article(page.read_text(encoding="utf-8"))
    assert "예측" in html and "smoothing" in html, "the glossary's rows are not on its page"
    assert re.search(r'href="chapters/01_toy\.html"[^>]*>.*?01', html, flags=re.S), (
        "a glossary row's chapter number is not a link to that chapter")
    assert 'href="glossary.html"' in article((toy_site / "index.html").read_text(encoding="utf-8"))
    # the course's own site: a glossary page exactly when the repository has GLOSSARY.md
    assert (built / "glossary.html").is_file() == (ROOT / "GLOSSARY.md").is_file()


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


def test_beyond_sources_reads_the_notebook_metadata_key():
    assert build_site.beyond_sources({"metadata": {"bayesfilt": {"beyond_sources": True}}})
    assert not build_site.beyond_sources({"metadata": {"bayesfilt": {"beyond_sources": "yes"}}})
    assert not build_site.beyond_sources({"metadata": {}})


def test_glossary_chapter_numbers_become_links_only_in_the_chapter_column():
    text = ("| term | 한국어 | chapter |\n| --- | --- | --- |\n| gain | 이득 | 02, 03 |\n"
            "| odd | 01 | 99 |\n\n| a | chapter |\n| --- | --- |\n| 01 | x |\n")
    out = build_site.link_glossary_chapters(text, {"01": "chapters/01_a", "02": "chapters/02_b",
                                                   "03": "chapters/03_c"})
    assert "| gain | 이득 | [02](/chapters/02_b), [03](/chapters/03_c) |" in out
    assert "| odd | 01 | 99 |" in out, "an unknown chapter or another column was changed"
    assert "| 01 | x |" in out, "a number outside the chapter column was changed"
