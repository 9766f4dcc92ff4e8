r"""Write the repository a teacher pushes for students: the course with no answer in it.

Usage (from the repository root, in the course environment)::

    python tools/make_student_repo.py student-repo/          # a new or empty folder
    python tools/make_student_repo.py student-repo/ --git    # ... as a fresh git repository
    make student-repo                                        # the same, with --git

It writes into ``OUTPUT_DIR``:

* ``notebooks/NN_*.ipynb``: the student edition of every chapter
  (``tools/make_student_edition.py``: the solutions replaced by nbgrader's
  stubs, the check outputs cleared);
* ``bayesfilt/``: the library with its checks, as in this repository;
* ``README.md``: a students' README (set-up, how the checks answer, the
  JupyterLab setting the sliders need), and a ``Makefile`` whose ``make lab``
  does the set-up;
* ``requirements.txt``: this repository's pins without nbgrader (the
  instructor's tool: ``requirements-instructor.txt``), ``environment.yml``,
  ``pyproject.toml`` (its pytest settings for the students' tests only),
  ``LICENSE`` and a ``.gitignore``;
* ``tests/``: the library's unit tests (``tests/test_<module>.py`` for each
  module of ``bayesfilt``), which hold no answer.

Left out: the teacher's notebooks, the exercise tests (they show the
answers), INSTRUCTORS.md, ``nbgrader_config.py``, the tools, the website and
the benchmarks.

Nothing in it may give an answer away, and the tool proves it before it
finishes: every file written (and, with ``--git``, every object of the new
repository's history) is scanned for the solution markers and for every
line of every solution and written model answer of the course's notebooks,
except the lines a student sees anyway (in the chapter's text and given
code, or in the library). A library test that contains a solution line is
left out (and named); a leak anywhere else is an error, and the folder is
removed. The comparison ignores whitespace, so a reformatted line is found
too.

With ``--git`` the folder becomes a git repository with a single commit (no
history of this repository, so no solution in it either): push it as a new
repository. The tool refuses a non-empty folder unless ``--force`` is given
(which deletes the folder's contents first) and any folder inside this
repository.
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import re
import shutil
import subprocess
import sys
from pathlib import Path

import nbformat

ROOT = Path(__file__).resolve().parents[1]
NOTEBOOKS = ROOT / "notebooks"
LIBRARY = ROOT / "bayesfilt"
#: Shortest line (whitespace removed) that counts as a solution line in the scan: shorter ones
#: (``return x``, ``pass``) say nothing about an answer and occur everywhere.
MIN_CHARS = 12
#: A solution line that only seeds a generator, ``rng = np.random.default_rng(16)``, gives
#: nothing away (every statement names the seeds its check depends on).
SEEDING = re.compile(r"\w+=np\.random\.default_rng\(\d+\)")
MARKERS = ("BEGIN SOLUTION", "END SOLUTION")
LAB_SETTING = {"@jupyterlab/apputils-extension:kernels-settings": {"commsOverSubshells": "disabled"}}


def _load_edition():
    spec = importlib.util.spec_from_file_location("_make_student_edition",
                                                  ROOT / "tools" / "make_student_edition.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


mse = _load_edition()


class LeakError(RuntimeError):
    """A file of the students' repository holds (a line of) a solution."""


# --- what is secret ------------------------------------------------------------------------


def squeeze(text: str) -> str:
    """``text`` with all whitespace removed (the scan's normal form)."""
    return re.sub(r"\s+", "", text)


def _solution_lines(source: str) -> tuple[list[str], list[str]]:
    """(lines inside the solution blocks, lines outside them) of a cell's source."""
    lines = source.split("\n")
    inside = set()
    for begin, end in mse.solution_blocks(source):
        inside.update(range(begin + 1, end))
    return ([lines[k] for k in sorted(inside)],
            [line for k, line in enumerate(lines) if k not in inside and not any(
                m in line for m in MARKERS)])


def _outputs_text(cell) -> str:
    parts = []
    for out in cell.get("outputs", []):
        if "text" in out:
            parts.append(out["text"])
        for key, value in out.get("data", {}).items():
            if key.startswith("text/"):
                parts.append(value if isinstance(value, str) else "".join(value))
    return "\n".join(parts)


def secrets(notebooks: Path = NOTEBOOKS, library: Path = LIBRARY) -> dict[str, str]:
    """The solution lines a student must not find: squeezed line -> where it comes from.

    Every line between the markers of an answer cell or a written answer of
    every chapter, at least :data:`MIN_CHARS` long once squeezed and not a
    bare seeding of a generator (:data:`SEEDING`: the statements give every
    seed a check depends on), unless it also stands (squeezed) in what students see anyway: the notebooks outside
    the solution blocks (text, given code, outputs of the cells that are not
    answers or checks) or a file of the library.
    """
    found, public = {}, []
    for path in mse.chapter_notebooks(notebooks):
        nb = nbformat.read(path, as_version=4)
        for index, cell in enumerate(nb.cells):
            inside, outside = _solution_lines(cell.source)
            public.append("\n".join(outside))
            if cell.cell_type == "code" and not inside and not mse.is_check_cell(cell):
                public.append(_outputs_text(cell))
            for line in inside:
                key = squeeze(line)
                if len(key) >= MIN_CHARS and not SEEDING.fullmatch(key):
                    found.setdefault(key, f"{path.name} cell {index + 1}: {line.strip()}")
    public += [p.read_text(encoding="utf-8") for p in sorted(library.rglob("*.py"))]
    seen = squeeze("\n".join(public))
    return {key: where for key, where in found.items() if key not in seen}


def _strings(value) -> list[str]:
    """Every string inside a JSON value."""
    if isinstance(value, str):
        return [value]
    if isinstance(value, dict):
        return [s for k, v in value.items() for s in [k, *_strings(v)]]
    if isinstance(value, list):
        return [s for v in value for s in _strings(v)]
    return []


def readable(name: str, data: bytes) -> str:
    """The text of a file as the scan reads it: a notebook's strings decoded from their JSON."""
    text = data.decode("utf-8", errors="replace")
    if name.endswith(".ipynb"):
        try:
            return "\n".join(_strings(json.loads(text)))
        except ValueError:
            pass
    return text


def leaks(files: dict[str, bytes], secret: dict[str, str]) -> list[str]:
    """Each (file, what) of ``files`` (name -> bytes) that holds a marker or a secret line."""
    found = []
    for name, data in sorted(files.items()):
        text = readable(name, data)
        found += [f"{name}: the solution marker {m!r}" for m in MARKERS if m in text]
        flat = squeeze(text)
        found += [f"{name}: a line of {where}" for key, where in secret.items() if key in flat]
    return found


def tree_files(folder: Path) -> dict[str, bytes]:
    """Every file under ``folder`` (name relative to it -> bytes), ``.git`` excepted."""
    return {p.relative_to(folder).as_posix(): p.read_bytes() for p in sorted(folder.rglob("*"))
            if p.is_file() and ".git" not in p.relative_to(folder).parts}


def git_objects(folder: Path) -> dict[str, bytes]:
    """Every object of the git repository in ``folder`` (``git:<sha>`` -> its content)."""
    out = subprocess.run(["git", "cat-file", "--batch-all-objects", "--batch"], cwd=folder,
                         capture_output=True, check=True).stdout
    objects, pos = {}, 0
    while pos < len(out):
        header_end = out.index(b"\n", pos)
        sha, _kind, size = out[pos:header_end].decode().split()
        start = header_end + 1
        objects[f"git:{sha}"] = out[start:start + int(size)]
        pos = start + int(size) + 1
    return objects


# --- what is written -----------------------------------------------------------------------


README = """\
# bayesfilt: Bayesian filtering, from the Bayes recursion to the particle filter

Your copy of the course's notebooks, with the exercises for you to do. Each
chapter in `notebooks/` explains one filter, runs it, derives it step by step
and checks every step numerically, then ends with exercises whose checks
answer back.

## Set-up

Python 3.11 or later. In a terminal, in this folder:

```bash
python -m venv .venv
source .venv/bin/activate          # Windows: .venv\\Scripts\\activate
pip install -r requirements.txt
jupyter lab notebooks/
```

(or `make lab`, which does all of it; with conda: `conda env create -f
environment.yml && conda activate bayesfilt`). The first line of every
notebook imports `bayesfilt`, the course's small library, which
`requirements.txt` installs from this folder.

**One JupyterLab setting.** Settings → Settings Editor → Kernels → "Kernel
Comms over subshells": choose *Disabled* (`make lab` sets it for you). With
the default, a slider's figure is drawn in a second thread while "Run All"
draws the next figures, and matplotlib can then show an error
(`ParseException`) instead of a figure.

## The exercises

Every chapter ends with three to five exercises. Each has:

* an **answer cell**: write your answer where it says `# YOUR CODE HERE`. A
  value answer is the line `name = None  # your answer`, given a value below
  it; a function keeps its signature and docstring, and you write its body.
  Run the cell;
* a **check cell** below it, which you run, and which answers in one of
  three ways: **Correct**; **Not yet**, with what differs (a transposed
  matrix, a forgotten noise term, a belief that is not normalised, ...), never
  the answer itself; or **Not attempted yet**, while your answer is still
  `None` or the function's body is still the stub;
* sometimes a **"Why?"** question: write a few sentences in place of
  `YOUR ANSWER HERE` (double-click the cell). Your teacher grades it.

"Run All" runs the whole chapter without an error before you have written
anything: every check then says "Not attempted yet". A check runs your
function on a few inputs and stops it after 10 s (an endless loop?). Run the
chapter's cells in order: the exercises use its variables.

## Tests

`pytest` runs the library's unit tests (a minute or less).

## Licence

See `LICENSE`.
"""

MAKEFILE = """\
# make lab: create the virtual environment, install the course, set JupyterLab up, start it.
VENV ?= .venv
PYTHON ?= python3
BIN := $(VENV)/bin
SETTING := $(VENV)/share/jupyter/lab/settings/overrides.d/bayesfilt.json

$(BIN)/.installed: requirements.txt pyproject.toml
\t$(PYTHON) -m venv $(VENV)
\t$(BIN)/python -m pip install --upgrade pip
\t$(BIN)/pip install -r requirements.txt
\tmkdir -p $(dir $(SETTING))
\techo '{setting}' > $(SETTING)
\ttouch $@

.PHONY: lab test
lab: $(BIN)/.installed
\t$(BIN)/jupyter lab notebooks/

test: $(BIN)/.installed
\t$(BIN)/pytest
""".format(setting=json.dumps(LAB_SETTING))

GITIGNORE = ".venv/\n__pycache__/\n*.pyc\n.ipynb_checkpoints/\n*.egg-info/\nbuild/\n"

PYTEST_SETTINGS = """\
[tool.pytest.ini_options]
# `pytest` runs the library's unit tests (the notebooks hold your answers: they are not tested).
testpaths = ["tests"]
addopts = "-p no:cacheprovider"
filterwarnings = ["error::RuntimeWarning:bayesfilt.*"]
"""


def students_requirements(text: str) -> str:
    """``requirements.txt`` without nbgrader (its line and the comment line just above it)."""
    lines = text.splitlines()
    out = []
    for line in lines:
        if re.match(r"^\s*nbgrader\b", line, flags=re.I):
            if out and out[-1].lstrip().startswith("#") and "nbgrader" in out[-1].lower():
                out.pop()
            continue
        out.append(line)
    return "\n".join(out) + "\n"


def students_pyproject(text: str) -> str:
    """``pyproject.toml`` with its pytest settings replaced by the students' (tests/ only)."""
    start = text.find("[tool.pytest.ini_options]")
    if start < 0:
        return text.rstrip("\n") + "\n\n" + PYTEST_SETTINGS
    nxt = re.search(r"^\[", text[start + 1:], flags=re.M)
    end = start + 1 + nxt.start() if nxt else len(text)
    return text[:start] + PYTEST_SETTINGS + ("\n" + text[end:] if nxt else "")


def library_tests(root: Path = ROOT) -> list[Path]:
    """``tests/test_<module>.py`` for each module ``bayesfilt/<module>.py`` (or ``_<module>.py``)."""
    modules = {p.stem.lstrip("_") for p in (root / "bayesfilt").glob("*.py") if p.stem != "__init__"}
    return sorted(p for p in (root / "tests").glob("test_*.py") if p.stem[5:] in modules)


def build(root: Path = ROOT, secret: dict[str, str] | None = None
          ) -> tuple[dict[str, bytes], list[str]]:
    """The students' repository in memory (name -> bytes), and the notes on what was left out.

    ``secret`` is :func:`secrets` of ``root`` (computed if not given).
    """
    files: dict[str, bytes] = {}
    for name, nb in mse.student_notebooks(root / "notebooks"):
        files[f"notebooks/{name}"] = (nbformat.writes(nb) + "\n").encode("utf-8")
    for path in sorted((root / "bayesfilt").rglob("*.py")):
        files[path.relative_to(root).as_posix()] = path.read_bytes()
    files["README.md"] = README.encode("utf-8")
    files["Makefile"] = MAKEFILE.encode("utf-8")
    files[".gitignore"] = GITIGNORE.encode("utf-8")
    files["requirements.txt"] = students_requirements(
        (root / "requirements.txt").read_text(encoding="utf-8")).encode("utf-8")
    files["pyproject.toml"] = students_pyproject(
        (root / "pyproject.toml").read_text(encoding="utf-8")).encode("utf-8")
    for name in ("LICENSE", "environment.yml"):
        if (root / name).exists():
            files[name] = (root / name).read_bytes()
    notes = []
    if secret is None:
        secret = secrets(root / "notebooks", root / "bayesfilt")
    for path in library_tests(root):
        name = path.relative_to(root).as_posix()
        found = leaks({name: path.read_bytes()}, secret)
        if found:
            notes.append(f"left out {name}: it holds {found[0].split(': ', 1)[1]}")
            continue
        files[name] = path.read_bytes()
    return files, notes


def make_student_repo(output: Path, force: bool = False, git: bool = False,
                      root: Path = ROOT) -> list[str]:
    """Write the students' repository into ``output``; returns notes (tests left out).

    Raises
    ------
    mse.RefusedError
        ``output`` is inside this repository, or not empty without ``force``.
    LeakError
        A file (or git object) of the result holds a solution; ``output`` is removed.
    """
    out = Path(output).expanduser().resolve()
    if out == root.resolve() or root.resolve() in out.parents:
        raise mse.RefusedError(f"refusing to write the students' repository into {str(output)!r}, "
                               f"inside the course's repository: choose a folder outside it")
    if out.exists() and (not out.is_dir() or (any(out.iterdir()) and not force)):
        raise mse.RefusedError(f"{str(output)!r} exists and is not an empty folder; choose a new "
                               f"folder, or give --force to replace its contents")
    secret = secrets(root / "notebooks", root / "bayesfilt")
    files, notes = build(root, secret)
    found = leaks(files, secret)
    if found:
        raise LeakError("the students' repository would give answers away:\n  " + "\n  ".join(found))
    if out.exists():
        shutil.rmtree(out)
    out.mkdir(parents=True)
    for name, data in files.items():
        target = out / name
        target.parent.mkdir(parents=True, exist_ok=True)
        target.write_bytes(data)
    try:
        if git:
            _git(out)
        written = tree_files(out) | (git_objects(out) if git else {})
        found = leaks(written, secret)
        if found:
            raise LeakError("the students' repository gives answers away:\n  " + "\n  ".join(found))
    except BaseException:
        shutil.rmtree(out, ignore_errors=True)
        raise
    return notes


def _git(folder: Path) -> None:
    """A fresh repository in ``folder`` with one commit of everything in it."""
    env = {"GIT_AUTHOR_NAME": "bayesfilt course", "GIT_AUTHOR_EMAIL": "course@example.invalid",
           "GIT_COMMITTER_NAME": "bayesfilt course", "GIT_COMMITTER_EMAIL": "course@example.invalid"}
    import os

    env = dict(os.environ, **env)
    for args in (["init", "--quiet", "--initial-branch=main"], ["add", "--all"],
                 ["-c", "commit.gpgsign=false", "commit", "--quiet", "--message",
                  "The bayesfilt course, student edition"]):
        subprocess.run(["git", *args], cwd=folder, env=env, check=True, capture_output=True)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(
        prog="make_student_repo.py",
        description="Write the repository to push for students: the student edition of every "
                    "chapter, the library with its checks, a students' README, requirements "
                    "without nbgrader, and the library's tests; scanned for any solution.",
        epilog="Example: python tools/make_student_repo.py student-repo/ --git")
    parser.add_argument("output", type=Path, metavar="OUTPUT_DIR", help="a new or empty folder")
    parser.add_argument("--git", action="store_true",
                        help="make it a git repository with a single commit")
    parser.add_argument("--force", action="store_true",
                        help="replace the contents of a non-empty folder")
    args = parser.parse_args(argv)
    try:
        notes = make_student_repo(args.output, force=args.force, git=args.git)
    except mse.RefusedError as exc:
        print(f"make_student_repo.py: error: {exc}", file=sys.stderr)
        return 2
    except (mse.StudentEditionError, LeakError) as exc:
        print(f"make_student_repo.py: error: {exc}", file=sys.stderr)
        return 1
    for note in notes:
        print(f"note: {note}")
    files = tree_files(Path(args.output))
    print(f"the students' repository is in {args.output}: {len(files)} files, "
          f"{sum(1 for n in files if n.startswith('notebooks/'))} chapters"
          + (", one commit" if args.git else "") + "; no solution found in it")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
