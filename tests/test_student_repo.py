"""The students' repository (``tools/make_student_repo.py``): built, then searched for answers.

The repository is built once, as a git repository (``--git``), into a
temporary folder. Its contents are then checked with a scanner written here,
independent of the tool's own: every line between the solution markers of
every chapter notebook (code and written answers), at least 12 characters
long once its whitespace is removed, must be absent, whitespace ignored,
from every file and from every git object, unless students see that line
anyway (in the chapter outside the solutions, or in the library). The scan
is shown to work on planted leaks (a reformatted solution line in the
README, in a notebook cell, in a later commit; a marker), and a library test
that holds a solution line is left out by the tool. The students' tests are
collected in the built repository, with its own ``bayesfilt``.
"""

from __future__ import annotations

import contextlib
import importlib.util
import io
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import nbformat
import pytest

ROOT = Path(__file__).resolve().parents[1]
TOOL = ROOT / "tools" / "make_student_repo.py"
CHAPTERS = sorted((ROOT / "notebooks").glob("[0-9][0-9]_*.ipynb"))
MIN_CHARS = 12


def _load(path: Path, name: str):
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


msr = _load(TOOL, "_make_student_repo")


# --- an independent scanner ----------------------------------------------------------------

def _flat(text: str) -> str:
    return "".join(text.split())


def _secret_lines() -> dict[str, str]:
    """Squeezed solution line -> where, for lines students do not see anyway."""
    found, public = {}, []
    for path in CHAPTERS:
        for index, cell in enumerate(nbformat.read(path, as_version=4).cells):
            inside = False
            for line in cell.source.splitlines():
                if line.strip() == "### BEGIN SOLUTION":
                    inside = True
                elif line.strip() == "### END SOLUTION":
                    inside = False
                elif inside:
                    # a bare seeding line gives nothing away: statements name their seeds
                    if len(_flat(line)) >= MIN_CHARS and not re.fullmatch(
                            r"\w+=np\.random\.default_rng\(\d+\)", _flat(line)):
                        found.setdefault(_flat(line), f"{path.name} cell {index + 1}: {line.strip()}")
                else:
                    public.append(line)
            if cell.cell_type == "code" and "BEGIN SOLUTION" not in cell.source \
                    and "bf.checks." not in cell.source:
                for out in cell.get("outputs", []):
                    public.append(str(out.get("text", "")))
                    public += [str(v) for k, v in out.get("data", {}).items() if k.startswith("text/")]
    public += [p.read_text(encoding="utf-8") for p in (ROOT / "bayesfilt").rglob("*.py")]
    seen = _flat("\n".join(public))
    return {key: where for key, where in found.items() if key not in seen}


SECRETS = _secret_lines()


def _text(name: str, data: bytes) -> str:
    text = data.decode("utf-8", errors="replace")
    if name.endswith(".ipynb"):
        nb = nbformat.reads(text, as_version=4)
        parts = [c.source for c in nb.cells]
        for c in nb.cells:
            for out in c.get("outputs", []):
                parts.append(str(out.get("text", "")))
                parts += [str(v) for v in out.get("data", {}).values()]
        return "\n".join(parts)
    return text


def _scan(files: dict[str, bytes]) -> list[str]:
    found = []
    for name, data in files.items():
        text = _text(name, data)
        if "BEGIN SOLUTION" in text or "END SOLUTION" in text:
            found.append(f"{name}: a marker")
        flat = _flat(text)
        found += [f"{name}: {where}" for key, where in SECRETS.items() if key in flat]
    return found


def _files(folder: Path) -> dict[str, bytes]:
    return {p.relative_to(folder).as_posix(): p.read_bytes() for p in folder.rglob("*")
            if p.is_file() and ".git" not in p.relative_to(folder).parts}


def _git(folder: Path, *args: str) -> str:
    return subprocess.run(["git", *args], cwd=folder, capture_output=True, text=True,
                          check=True).stdout


def _objects(folder: Path) -> dict[str, bytes]:
    """Every object in the repository's object store, reachable or not."""
    shas = _git(folder, "cat-file", "--batch-all-objects", "--batch-check=%(objectname)").split()
    return {f"git:{sha}": subprocess.run(["git", "cat-file", "-p", sha], cwd=folder,
                                         capture_output=True, check=True).stdout for sha in shas}


# --- the repository ------------------------------------------------------------------------

@pytest.fixture(scope="module")
def repo(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("students") / "bayesfilt-students"
    notes = msr.make_student_repo(out, git=True)
    assert notes == [], notes
    return out


def test_there_is_something_to_find():
    """The scan is only as good as its list: every chapter's solutions are in it."""
    for path in CHAPTERS:
        assert any(where.startswith(path.name) for where in SECRETS.values()), path.name
    assert len(SECRETS) > 50, len(SECRETS)


def test_the_repository_holds_what_students_need(repo):
    files = _files(repo)
    for path in CHAPTERS:
        assert f"notebooks/{path.name}" in files
        assert f"bayesfilt/checks/ch{path.name[:2]}.py" in files
    for name in ("README.md", "requirements.txt", "pyproject.toml", "LICENSE", "Makefile",
                 "bayesfilt/__init__.py", "bayesfilt/checks/__init__.py", "tests/test_kalman.py"):
        assert name in files, name
    assert not [n for n in files if n.startswith(("tools/", "site/", "benchmarks/"))]
    for absent in ("INSTRUCTORS.md", "nbgrader_config.py", "requirements-instructor.txt",
                   "tests/exercise_helpers.py", "tests/test_nbgrader.py"):
        assert absent not in files, absent
    assert not [n for n in files if re.match(r"tests/test_exercise", n)], "exercise tests show answers"


def test_requirements_are_the_course_pins_without_nbgrader(repo):
    students = (repo / "requirements.txt").read_text().splitlines()
    course = (ROOT / "requirements.txt").read_text().splitlines()
    assert not [line for line in students if "nbgrader" in line.lower()]
    pins = [line for line in course if line and not line.startswith("#")
            and not line.lower().startswith("nbgrader")]
    assert [line for line in students if line and not line.startswith("#")] == pins


def test_the_notebooks_are_the_student_edition(repo, tmp_path):
    mse = _load(ROOT / "tools" / "make_student_edition.py", "_mse_for_repo")
    mse.make_student_edition(tmp_path / "edition")
    for path in CHAPTERS:
        assert (repo / "notebooks" / path.name).read_bytes() == \
            (tmp_path / "edition" / path.name).read_bytes(), path.name


def test_no_file_gives_an_answer_away(repo):
    assert _scan(_files(repo)) == []


def test_the_history_is_one_commit_with_no_answer(repo):
    assert _git(repo, "rev-list", "--all").split() == [_git(repo, "rev-parse", "HEAD").strip()]
    assert _git(repo, "status", "--porcelain") == "", "everything is committed"
    objects = _objects(repo)
    assert len(objects) > len(_files(repo)), "blobs, trees and the commit"
    assert _scan(objects) == []


def test_the_scan_finds_a_planted_leak(repo, tmp_path):
    """A reformatted solution line in the README, one in a notebook's cell, a marker, and a
    leak committed and then removed again: each is found, by this scanner and by the tool's."""
    key, where = sorted(SECRETS.items())[0]
    line = where.split(": ", 1)[1]
    spaced = "  ".join(line.split(" ")) + "   # copied"
    copy = tmp_path / "copy"
    shutil.copytree(repo, copy)
    (copy / "README.md").write_text((copy / "README.md").read_text() + "\n" + spaced + "\n")
    nb_path = copy / "notebooks" / CHAPTERS[-1].name
    nb = nbformat.read(nb_path, as_version=4)
    nb.cells[-1].source += "\n" + line
    nbformat.write(nb, nb_path)
    (copy / "tests" / "notes.txt").write_text("### BEGIN SOLUTION\n")
    found = _scan(_files(copy))
    assert any(f.startswith("README.md") for f in found), found
    assert any(f.startswith(f"notebooks/{CHAPTERS[-1].name}") for f in found), found
    assert any(f == "tests/notes.txt: a marker" for f in found), found
    tool = msr.leaks(msr.tree_files(copy), msr.secrets())
    assert {f.split(":")[0] for f in tool} >= {"README.md", f"notebooks/{CHAPTERS[-1].name}",
                                               "tests/notes.txt"}, tool
    # committed, then deleted: the tree is clean again, the history is not
    env = dict(os.environ, GIT_AUTHOR_NAME="x", GIT_AUTHOR_EMAIL="x@x", GIT_COMMITTER_NAME="x",
               GIT_COMMITTER_EMAIL="x@x")
    for args in (["add", "-A"], ["commit", "-qm", "leak"]):
        subprocess.run(["git", *args], cwd=copy, env=env, check=True, capture_output=True)
    shutil.rmtree(copy / "tests")
    (copy / "README.md").write_text((repo / "README.md").read_text())
    nb_path.write_bytes((repo / "notebooks" / CHAPTERS[-1].name).read_bytes())
    assert not _scan(_files(copy)), "the working tree is clean again"
    assert _scan(_objects(copy)), "the leak is still in the history"
    assert msr.leaks(msr.git_objects(copy), msr.secrets()), "the tool reads the history too"


def test_a_library_test_with_a_solution_line_is_left_out(tmp_path):
    """The tool's gate on the shipped tests: a copy of the course whose test_kalman.py holds a
    solution line gets a repository without that file, and a note naming it."""
    fake = tmp_path / "course"
    for name in ("notebooks", "bayesfilt"):
        shutil.copytree(ROOT / name, fake / name, ignore=shutil.ignore_patterns("__pycache__"))
    for name in ("requirements.txt", "pyproject.toml", "LICENSE"):
        shutil.copy(ROOT / name, fake / name)
    (fake / "tests").mkdir()
    line = sorted(SECRETS.values())[0].split(": ", 1)[1]
    (fake / "tests" / "test_kalman.py").write_text(f"def test_x():\n    pass  # {line}\n")
    (fake / "tests" / "test_bayes.py").write_text("def test_y():\n    assert True\n")
    files, notes = msr.build(fake)
    assert "tests/test_kalman.py" not in files and "tests/test_bayes.py" in files
    assert len(notes) == 1 and "tests/test_kalman.py" in notes[0], notes


def test_the_students_tests_run_in_the_repository(repo):
    """Collected in the built repository with its own bayesfilt (nothing of this one)."""
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "NBGRADER_EXECUTION")}
    env.update(PYTHONPATH=str(repo), PYTEST_DISABLE_PLUGIN_AUTOLOAD="1")
    proc = subprocess.run([sys.executable, "-m", "pytest", "--collect-only", "-q"],
                          cwd=repo, env=env, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-2000:]
    assert re.search(r"(\d+) tests? collected", proc.stdout), proc.stdout[-500:]
    where = subprocess.run([sys.executable, "-c", "import bayesfilt.checks.ch02 as m; print(m.__file__)"],
                           cwd=repo, env=env, capture_output=True, text=True, check=True).stdout
    assert Path(where.strip()).resolve().is_relative_to(repo.resolve()), where


def test_refusals(tmp_path):
    with pytest.raises(msr.mse.RefusedError, match="inside the course's repository"):
        msr.make_student_repo(ROOT / "build" / "students")
    full = tmp_path / "full"
    full.mkdir()
    (full / "mine.txt").write_text("x")
    with pytest.raises(msr.mse.RefusedError, match="--force"):
        msr.make_student_repo(full)
    assert (full / "mine.txt").read_text() == "x"


def test_the_command_line_and_the_make_target(tmp_path):
    text = (ROOT / "Makefile").read_text()
    assert re.search(r"^student-repo:", text, flags=re.M) and "make_student_repo.py" in text
    assert "python tools/make_student_repo.py student-repo/ --git" in (ROOT / "INSTRUCTORS.md").read_text()
    out = io.StringIO()
    with contextlib.redirect_stdout(out), pytest.raises(SystemExit) as exit_:
        msr.main(["--help"])
    assert exit_.value.code == 0 and "OUTPUT_DIR" in out.getvalue() and "--git" in out.getvalue()
