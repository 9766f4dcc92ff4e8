r"""Build the course website into ``build/site/``: offline, warnings as errors, notebooks not executed.

Usage (from the repository root, with the site's dependencies installed)::

    pip install -r requirements.txt -r requirements-site.txt
    python tools/build_site.py            # or: make site
    python -m http.server -d build/site   # then open http://localhost:8000
                                          # (or open build/site/index.html directly)

What it does:

1. stages ``site/`` (the Sphinx configuration, the landing page, the
   notation page, the CSS and JavaScript, the favicon) into ``build/site-src/``;
2. finds the chapters (every ``notebooks/NN_*.ipynb``, so a new chapter needs
   no change here), writes their **student edition** there with
   ``tools/make_student_edition.py`` (exercise solutions replaced by stubs,
   every other stored output kept as it is), and puts a box under each
   chapter's title with a link to download that notebook, a Binder launch
   link and a note on running it locally. The student notebooks are also
   served as ``notebooks/NN_*.ipynb`` (and all of them as one zip) for the
   header's download menu. A chapter whose notebook metadata holds
   ``{"bayesfilt": {"beyond_sources": true}}`` is marked "beyond the source
   notes", under its title and in the landing page's chapter list;
3. takes the set-up commands from the README's ``## Set-up`` section, the
   instructor's guide from ``INSTRUCTORS.md`` and, if the file exists, the
   glossary page from ``GLOSSARY.md`` (links into the repository are pointed
   at the chapter pages or at GitHub; a bare chapter number ``NN`` in a
   glossary table's "chapter" column becomes a link to that chapter), and
   writes one API page per ``bayesfilt`` module (autodoc + numpydoc, every
   public name);
4. runs Sphinx (myst-nb with execution off, sphinx-book-theme, MathJax 3
   from ``sphinx-mathjax-offline``) with ``-W --keep-going``: any warning,
   e.g. an unresolved reference, fails the build.

The notebooks are rendered with their stored outputs, which strict nbval
keeps current, so nothing is executed and the build needs no kernel.

The Binder and GitHub links name the repository ``owner/name``: taken from
``--repository``, else the ``GITHUB_REPOSITORY`` variable (set by GitHub
Actions), else the ``origin`` remote if it is on GitHub, else the
placeholder ``OWNER/bayesfilt`` (with a note on stderr). A build from a ZIP
or a clone without a GitHub remote should say ``--repository OWNER/NAME``.

The notation page (``site/notation.md``) is written by hand, in maths; it
follows the README's ``## Notation`` tables row for row, which
``tests/test_site.py`` checks.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import shutil
import subprocess
import sys
import time
import zipfile
from pathlib import Path
from urllib.parse import quote

ROOT = Path(__file__).resolve().parents[1]
SITE_SRC = ROOT / "site"
STAGE = ROOT / "build" / "site-src"
OUT = ROOT / "build" / "site"
DOCTREES = ROOT / "build" / "site-doctrees"
CHAPTER_GLOB = "[0-9][0-9]_*.ipynb"
PLACEHOLDER_REPOSITORY = "OWNER/bayesfilt"
NOTEBOOKS = ROOT / "notebooks"
GLOSSARY = ROOT / "GLOSSARY.md"
ZIP_NAME = "bayesfilt-student-notebooks.zip"


class SiteError(RuntimeError):
    """Something the site cannot be built from (a missing README section, a failed step)."""


# --- repository and links ------------------------------------------------------------------


def repository_name(given: str | None = None) -> str:
    """GitHub ``owner/name`` for the Binder and source links (see the module docstring)."""
    if given:
        return given
    if os.environ.get("GITHUB_REPOSITORY"):
        return os.environ["GITHUB_REPOSITORY"]
    try:
        url = subprocess.run(["git", "remote", "get-url", "origin"], cwd=ROOT, capture_output=True,
                             text=True, check=False).stdout.strip()
    except OSError:
        url = ""
    match = re.search(r"github\.com[:/]([^/]+/[^/]+?)(?:\.git)?$", url)
    return match.group(1) if match else PLACEHOLDER_REPOSITORY


def binder_url(repository: str, branch: str, notebook: str) -> str:
    """mybinder.org link that opens ``notebooks/<notebook>`` of the repository in JupyterLab.

    Binder builds its environment from the repository's ``requirements.txt``.
    """
    return (f"https://mybinder.org/v2/gh/{repository}/{branch}"
            f"?labpath={quote('notebooks/' + notebook, safe='')}")


def github_url(repository: str, branch: str, path: str) -> str:
    return f"https://github.com/{repository}/blob/{branch}/{path}"


# --- pieces taken from the README and INSTRUCTORS.md ----------------------------------------


def markdown_section(text: str, title_pattern: str, source: str) -> str:
    """The body of the ``## <title>`` section of a markdown text (up to the next ``## ``).

    ``title_pattern`` is a regular expression matched against the heading text.
    """
    lines = text.splitlines()
    in_fence = False
    start = None
    for k, line in enumerate(lines):
        if line.lstrip().startswith("```"):
            in_fence = not in_fence
        if in_fence:
            continue
        if line.startswith("## "):
            if start is not None:
                return "\n".join(lines[start:k]).strip() + "\n"
            if re.fullmatch(title_pattern, line[3:].strip()):
                start = k + 1
    if start is None:
        raise SiteError(f"{source} has no '## ' section matching {title_pattern!r}; the site "
                        f"takes that section from it (see tools/build_site.py)")
    return "\n".join(lines[start:]).strip() + "\n"


LINK = re.compile(r"(?<!!)\[(?P<text>[^\]]*)\]\((?P<target>[^)\s]+)\)")


def rewrite_links(text: str, docs: dict[str, str], repository: str, branch: str,
                  base: str = "") -> str:
    """Point the relative links of a repository markdown file at the site or at GitHub.

    ``docs`` maps a repository path (e.g. ``notebooks/01_x.ipynb``) to the site
    document that shows it (e.g. ``chapters/01_x.ipynb``); ``base`` is the
    folder of the markdown file in the repository. Other relative links go
    to the file on GitHub; absolute URLs and anchors stay.
    """

    def replace(match: re.Match) -> str:
        target = match.group("target")
        if re.match(r"^[a-z][a-z0-9+.-]*:", target) or target.startswith("#"):
            return match.group(0)
        path, _, anchor = target.partition("#")
        repo_path = os.path.normpath(os.path.join(base, path)).replace(os.sep, "/")
        if repo_path in docs:
            new = docs[repo_path] + (f"#{anchor}" if anchor else "")
        else:
            new = github_url(repository, branch, repo_path) + (f"#{anchor}" if anchor else "")
        return f"[{match.group('text')}]({new})"

    out, in_fence = [], False
    for line in text.splitlines(keepends=True):
        if line.lstrip().startswith("```"):
            in_fence = not in_fence
        out.append(line if in_fence else LINK.sub(replace, line))
    return "".join(out)


# --- the chapters ----------------------------------------------------------------------------


def run_box(name: str, download: str, repository: str, branch: str) -> str:
    """The markdown of the box under a chapter's title: download, Binder, run locally."""
    return "\n".join([
        "```{admonition} Run this chapter",
        ":class: tip run-this-chapter",
        "",
        f'<a class="reference download" href="{download}" download>Download this notebook</a> '
        f"(the student edition shown here: the exercises are stubs for you to fill in) ·",
        f"[Launch it on Binder]({binder_url(repository, branch, name)}) "
        f"(opens the repository's notebook, with the solutions, in JupyterLab) ·",
        f"[see it on GitHub]({github_url(repository, branch, 'notebooks/' + name)})",
        "",
        "**Run it locally:** with Python 3.11 or newer, from a clone of the repository, "
        "`pip install -r requirements.txt && jupyter lab notebooks/` opens the chapters with their "
        "solutions; the downloaded student edition runs in the same environment from any folder "
        "(`jupyter lab` in the folder you saved it to). *Run All*: each exercise's check "
        "says \"Not attempted yet\" until you write an answer.",
        "```",
        "",
    ])


def insert_after_title(cells: list[dict], box: dict) -> list[dict]:
    """``cells`` with ``box`` right under the first level-1 heading (split out of its cell).

    Without a level-1 heading the box goes first.
    """
    for index, cell in enumerate(cells):
        if cell.get("cell_type") != "markdown":
            continue
        lines = _source(cell).splitlines(keepends=True)
        for k, line in enumerate(lines):
            if line.startswith("# "):
                head = dict(cell, source="".join(lines[:k + 1]))
                rest = "".join(lines[k + 1:])
                tail = [dict(cell, source=rest, id=f"{cell.get('id', index)}-rest")] if rest.strip() else []
                return cells[:index] + [head, box] + tail + cells[index + 1:]
    return [box] + cells


def _source(cell: dict) -> str:
    source = cell.get("source", "")
    return "".join(source) if isinstance(source, list) else source


def chapter_title(nb: dict) -> str:
    """The text of a notebook's first level-1 heading (``# 01 · Title``), or ``""``."""
    for cell in nb.get("cells", []):
        if cell.get("cell_type") == "markdown":
            for line in _source(cell).splitlines():
                if line.startswith("# "):
                    return line[2:].strip()
    return ""


def beyond_sources(nb: dict) -> bool:
    """Whether the notebook's metadata marks it ``{"bayesfilt": {"beyond_sources": true}}``."""
    marks = nb.get("metadata", {}).get("bayesfilt", {})
    return isinstance(marks, dict) and marks.get("beyond_sources") is True


BEYOND_BADGE = ('<span class="beyond-sources-badge" title="This chapter is not in the three source '
                'documents the course follows">beyond the source notes</span>')


def beyond_note() -> str:
    """The markdown under the title of a chapter that goes beyond the source notes."""
    return (f"{BEYOND_BADGE} This chapter goes beyond the three source documents that the "
            "course follows: its derivations, checks and examples are the course's own.\n")


def chapter_list(chapters: list[tuple[str, str, bool]]) -> str:
    """Markdown of the landing page's chapter list: a hidden toctree (the sidebar) and a list.

    ``chapters`` holds ``(docname, title, beyond_sources)`` in the course's order.
    """
    toc = "\n".join(doc for doc, _, _ in chapters)
    items = "\n".join(f"- {{doc}}`{title.replace('`', '')} </{doc}>`"
                      + (f" {BEYOND_BADGE}" if beyond else "")
                      for doc, title, beyond in chapters)
    note = ("\nChapters marked *beyond the source notes* go further than the three source documents "
            "the course follows; their derivations and checks are the course's own.\n"
            if any(beyond for _, _, beyond in chapters) else "")
    return ("```{toctree}\n:hidden:\n:maxdepth: 1\n:caption: Chapters\n\n" + toc + "\n```\n\n"
            + items + "\n" + note)


def snapshot_notebooks(stage_dir: Path, notebooks_dir: Path = NOTEBOOKS) -> Path:
    """Copy the chapter notebooks and the student-edition tool into ``stage_dir/_snapshot``.

    The whole site is made from this one copy, so a notebook saved while the site builds
    (by someone re-executing it) cannot mix two versions into one site. A copy caught in the
    middle of a write is not valid JSON: it is taken again. Returns the snapshot's root.
    """
    snap = stage_dir / "_snapshot"
    (snap / "notebooks").mkdir(parents=True)
    (snap / "tools").mkdir()
    shutil.copy2(ROOT / "tools" / "make_student_edition.py", snap / "tools")
    for path in sorted(notebooks_dir.glob(CHAPTER_GLOB)):
        for attempt in range(20):
            data = path.read_bytes()
            try:
                json.loads(data)
                break
            except ValueError:
                if attempt == 19:
                    raise SiteError(f"{path} is not a valid notebook (JSON)") from None
                time.sleep(0.5)
        (snap / "notebooks" / path.name).write_bytes(data)
    return snap


WIDGET_REPR = re.compile(r"^(interactive|[A-Z]\w*(Slider|Box|Dropdown|Button|Checkbox|Text|Select\w*|Output|"
                         r"Tab|Accordion|Play|Picker|Progress\w*))\(")
WIDGET_NOTE = ("*An interactive widget: it runs in the notebook (download it or launch it on Binder, "
               "above), not on this page.*")


def replace_widget_reprs(nb: dict) -> int:
    """Replace the text of stored widget outputs (``interactive(children=(FloatSlider(...``) by a note.

    The notebooks store no widget state, so a widget's output is only its Python repr, which
    means nothing on a web page. Returns how many outputs were replaced.
    """
    count = 0
    for cell in nb["cells"]:
        for k, output in enumerate(cell.get("outputs", [])):
            data = output.get("data", {})
            text = data.get("text/plain", "")
            text = "".join(text) if isinstance(text, list) else text
            if set(data) == {"text/plain"} and WIDGET_REPR.match(text):
                cell["outputs"][k] = {"output_type": "display_data", "metadata": {},
                                      "data": {"text/markdown": WIDGET_NOTE}}
                count += 1
    return count


def stage_chapters(stage_dir: Path, repository: str, branch: str, docs: dict[str, str],
                   notebooks_dir: Path = NOTEBOOKS) -> list[tuple[str, str, bool]]:
    """Write the student edition into the stage, one page per chapter (with the run box).

    The student edition is made by ``tools/make_student_edition.py OUTPUT_DIR``, run from the
    snapshot, whose ``notebooks/`` folder is then the one it reads. The student notebooks and
    their zip go to ``_extra/notebooks/`` (served as ``notebooks/`` of the site). Returns the
    chapters as ``(docname, title, beyond_sources)``, in order.
    """
    snap = snapshot_notebooks(stage_dir, notebooks_dir)
    student = stage_dir / "student-notebooks"
    result = subprocess.run([sys.executable, str(snap / "tools" / "make_student_edition.py"),
                             str(student)], cwd=snap, capture_output=True, text=True, check=False)
    if result.returncode != 0:
        raise SiteError("tools/make_student_edition.py failed:\n" + result.stdout + result.stderr)
    notebooks = sorted(student.glob(CHAPTER_GLOB))
    if not notebooks:
        raise SiteError(f"no chapter notebooks {CHAPTER_GLOB} in notebooks/")
    chapters = stage_dir / "chapters"
    chapters.mkdir()
    served = stage_dir / "_extra" / "notebooks"
    served.mkdir(parents=True)
    found = []
    for path in notebooks:
        shutil.copy2(path, served / path.name)
        nb = json.loads(path.read_text(encoding="utf-8"))
        replace_widget_reprs(nb)
        for cell in nb["cells"]:
            if cell.get("cell_type") == "markdown":
                cell["source"] = rewrite_links(_source(cell), docs, repository, branch, "notebooks")
        box = {"cell_type": "markdown", "metadata": {}, "id": "site-run-this-chapter",
               "source": run_box(path.name, f"../notebooks/{path.name}", repository, branch)}
        beyond = beyond_sources(nb)
        if beyond:
            box["source"] = beyond_note() + "\n" + box["source"]
        nb["cells"] = insert_after_title(nb["cells"], box)
        (chapters / path.name).write_text(json.dumps(nb, indent=1, ensure_ascii=False) + "\n",
                                          encoding="utf-8")
        found.append((f"chapters/{path.stem}", chapter_title(nb) or path.stem, beyond))
    with zipfile.ZipFile(served / ZIP_NAME, "w", zipfile.ZIP_DEFLATED) as archive:
        for path in notebooks:
            archive.write(path, f"bayesfilt-student-notebooks/{path.name}")
    return found


# --- the API pages ---------------------------------------------------------------------------


def public_names(module) -> list[str]:
    """The public names of a module: its ``__all__``, then any other public function defined in it."""
    import inspect

    names = list(getattr(module, "__all__", []))
    for name, obj in vars(module).items():
        if (not name.startswith("_") and name not in names and inspect.isfunction(obj)
                and obj.__module__ == module.__name__):
            names.append(name)
    return names


def api_page(module_name: str) -> str:
    """reStructuredText of one module's reference page: its docstring and every public name."""
    import importlib
    import inspect

    full = f"bayesfilt.{module_name}"
    module = importlib.import_module(full)
    title = f"``bf.{module_name}``"
    lines = [title, "=" * len(title), "", f".. automodule:: {full}", "   :no-members:", ""]
    for name in public_names(module):
        obj = getattr(module, name)
        if inspect.isclass(obj):
            # members inherited from the library's own (private) base classes are shown, tuple's are not
            lines += [f".. autoclass:: {full}.{name}", "   :members:", "   :undoc-members:",
                      "   :inherited-members: tuple, object, dict", ""]
        elif callable(obj):
            lines += [f".. autofunction:: {full}.{name}", ""]
        else:
            lines += [f".. autodata:: {full}.{name}", "   :no-value:", ""]
    return "\n".join(lines)


def api_modules() -> list[str]:
    """The public modules of bayesfilt, as ``kalman``, ``checks.ch02``, ...

    The order of ``bayesfilt._MODULES`` (the course's order) first, then every other public
    module or submodule found in the package, alphabetically.
    """
    import importlib
    import pkgutil

    sys.path.insert(0, str(ROOT))
    package = importlib.import_module("bayesfilt")
    found = [info.name.removeprefix("bayesfilt.")
             for info in pkgutil.walk_packages(package.__path__, "bayesfilt.")
             if not any(part.startswith("_") for part in info.name.split("."))]
    ordered = [m for m in getattr(package, "_MODULES", ()) if m in found]
    return ordered + sorted(m for m in found if m not in ordered)


def stage_api(stage_dir: Path) -> None:
    api = stage_dir / "api"
    api.mkdir()
    modules = api_modules()
    for module_name in modules:
        (api / f"{module_name}.rst").write_text(api_page(module_name), encoding="utf-8")
    toc = "\n".join(f"   {m}" for m in modules)
    (api / "index.rst").write_text(
        "The ``bayesfilt`` reference\n===========================\n\n"
        ".. automodule:: bayesfilt\n   :no-members:\n\n"
        "One page per module. Every public function and class is listed with its parameters "
        "and their shapes, from the numpydoc docstrings of the library (version "
        f"|release|).\n\n.. toctree::\n   :maxdepth: 1\n\n{toc}\n", encoding="utf-8")


# --- the build -------------------------------------------------------------------------------


GLOSSARY_CHAPTER = re.compile(r"^\s*\d{2}(\s*[,;]\s*\d{2})*\s*$")


def link_glossary_chapters(text: str, chapters: dict[str, str]) -> str:
    """In a markdown table whose header has a "chapter" column, link bare chapter numbers.

    ``chapters`` maps ``"01"`` to the chapter's docname (``chapters/01_bayes_recursion``).
    A cell such as ``01`` or ``02, 04`` becomes ``[01](/chapters/01_...)``; any other cell,
    and every other table, stays as it is.
    """
    out, column = [], None
    for line in text.splitlines(keepends=True):
        stripped = line.strip()
        if not stripped.startswith("|"):
            column = None
            out.append(line)
            continue
        cells = stripped.strip("|").split("|")
        if column is None:
            heads = [c.strip().lower() for c in cells]
            column = next((k for k, h in enumerate(heads) if h.startswith("chapter")), -1)
            out.append(line)
            continue
        if 0 <= column < len(cells) and GLOSSARY_CHAPTER.match(cells[column]):
            numbers = re.findall(r"\d{2}", cells[column])
            if all(n in chapters for n in numbers):
                cells[column] = " " + ", ".join(f"[{n}](/{chapters[n]})" for n in numbers) + " "
                line = "|" + "|".join(cells) + "|" + ("\n" if line.endswith("\n") else "")
        out.append(line)
    return "".join(out)


def stage(stage_dir: Path, repository: str, branch: str, notebooks_dir: Path = NOTEBOOKS,
          glossary: Path | None = GLOSSARY, api: bool = True) -> None:
    """Write the Sphinx source of the site into ``stage_dir`` (emptied first).

    ``api=False`` leaves the API reference out (a quick build, for tests of the build itself).
    """
    if stage_dir.exists():
        shutil.rmtree(stage_dir)
    shutil.copytree(SITE_SRC, stage_dir)
    (stage_dir / "_generated").mkdir(exist_ok=True)
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    notebooks = sorted(notebooks_dir.glob(CHAPTER_GLOB))
    docs = {f"notebooks/{p.name}": f"chapters/{p.name}" for p in notebooks}
    docs.update({"INSTRUCTORS.md": "instructors.md", "README.md": "index.md"})
    has_glossary = glossary is not None and glossary.is_file()
    if has_glossary:
        docs["GLOSSARY.md"] = "glossary.md"
    # Files in _generated/ are included from pages one level up: links relative to the stage.
    (stage_dir / "_generated" / "setup.md").write_text(
        rewrite_links(markdown_section(readme, r"Set-up.*", "README.md"), docs, repository, branch),
        encoding="utf-8")
    instructors = (ROOT / "INSTRUCTORS.md").read_text(encoding="utf-8")
    (stage_dir / "instructors.md").write_text(rewrite_links(instructors, docs, repository, branch),
                                          encoding="utf-8")
    chapters = stage_chapters(stage_dir, repository, branch, docs, notebooks_dir)
    (stage_dir / "_generated" / "chapters.md").write_text(chapter_list(chapters), encoding="utf-8")
    if has_glossary:
        numbers = {doc.split("/")[1][:2]: doc for doc, _, _ in chapters}
        text = rewrite_links(glossary.read_text(encoding="utf-8"), docs, repository, branch)
        if not re.search(r"^# ", text, flags=re.M):
            text = "# Glossary\n\n" + text   # the page's title in the sidebar and the search
        (stage_dir / "glossary.md").write_text(link_glossary_chapters(text, numbers),
                                               encoding="utf-8")
    reference = [("notation", "the notation")]
    reference += [("glossary", "the glossary (English, 한국어)")] if has_glossary else []
    reference += [("api/index", "the bayesfilt reference")] if api else []
    links = ", ".join(f"{{doc}}`{text} </{doc}>`" for doc, text in reference)
    (stage_dir / "_generated" / "reference.md").write_text(
        "```{toctree}\n:hidden:\n:maxdepth: 1\n:caption: Reference\n\n"
        + "\n".join(doc for doc, _ in reference) + "\n```\n\n"
        f"**Reference:** {links}; and, for teachers, {{doc}}`the instructor's guide </instructors>`.\n",
        encoding="utf-8")
    if api:
        stage_api(stage_dir)


def build(repository: str | None = None, branch: str = "main", quiet: bool = False,
          out: Path = OUT, stage_dir: Path = STAGE, doctrees: Path = DOCTREES,
          capture: bool = False, notebooks_dir: Path = NOTEBOOKS,
          glossary: Path | None = GLOSSARY, api: bool = True) -> Path:
    """Stage and build the site into ``out`` (default ``build/site``); returns ``out``.

    ``notebooks_dir``, ``glossary`` and ``api`` are for tests of the build: the chapters' folder,
    the glossary file (its page is built only if it exists) and whether to build the API pages.
    Raises SiteError if a step or Sphinx fails (Sphinx's warnings are printed).
    """
    repository = repository_name(repository)
    if repository == PLACEHOLDER_REPOSITORY:
        print(f"note: no GitHub repository known (no --repository, GITHUB_REPOSITORY or GitHub "
              f"origin remote): the Binder and GitHub links use {PLACEHOLDER_REPOSITORY}",
              file=sys.stderr)
    stage(stage_dir, repository, branch, notebooks_dir, glossary, api)
    if out.exists():
        shutil.rmtree(out)
    env = dict(os.environ, SITE_REPOSITORY=repository, SITE_BRANCH=branch,
               BAYESFILT_ROOT=str(ROOT), MPLBACKEND="Agg")
    command = [sys.executable, "-m", "sphinx", "-b", "html", "-W", "--keep-going", "-n",
               "-E", "-d", str(doctrees), str(stage_dir), str(out)]
    if quiet:
        command.insert(3, "-q")
    result = subprocess.run(command, cwd=ROOT, env=env, check=False, capture_output=capture, text=True)
    if result.returncode != 0:
        details = (result.stdout or "") + (result.stderr or "") if capture else "see the warnings above"
        raise SiteError(f"sphinx-build failed (exit {result.returncode}): {details}")
    (out / ".nojekyll").write_text("", encoding="utf-8")  # GitHub Pages: serve _static/ etc. as is
    return out


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(
        prog="build_site.py",
        description="Build the course website into build/site/ (offline; warnings are errors; "
                    "the stored notebooks are rendered without being executed).",
        epilog="Needs: pip install -r requirements.txt -r requirements-site.txt. "
               "View: open build/site/index.html, or python -m http.server -d build/site.")
    parser.add_argument("--repository", metavar="OWNER/NAME",
                        help="GitHub repository for the Binder and source links (default: "
                             "$GITHUB_REPOSITORY, else the origin remote)")
    parser.add_argument("--branch", default="main", help="branch for those links (default: main)")
    parser.add_argument("-q", "--quiet", action="store_true", help="only warnings and errors")
    args = parser.parse_args(argv)
    try:
        import myst_nb  # noqa: F401
        import sphinx  # noqa: F401
    except ImportError as exc:
        print(f"error: the site's dependencies are missing ({exc}); install them with\n"
              f"  pip install -r requirements.txt -r requirements-site.txt", file=sys.stderr)
        return 2
    start = time.perf_counter()
    try:
        out = build(args.repository, args.branch, args.quiet)
    except SiteError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 1
    print(f"built the site in {time.perf_counter() - start:.0f} s: {out.relative_to(ROOT)}/index.html")
    return 0


if __name__ == "__main__":
    sys.exit(main())
