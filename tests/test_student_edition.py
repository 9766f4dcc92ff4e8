"""Tests of the exercise pattern and of the student edition (``tools/make_student_edition.py``).

Three groups:

* the pattern, in every chapter notebook: solution markers that pair up in
  one cell (a code cell, or a manually graded markdown answer), every answer
  cell followed by its check cell and, where the exercise asks "why?", by its
  written answer (statement, answer, check, [why]), every ``### Exercise N``
  heading with its kind line and its answer cell, check cells that show
  "Correct" in the repository, at least three exercises per chapter, and
  INSTRUCTORS.md's tables and rubrics equal to the notebooks';
* the edition made from the real chapters: equal to nbgrader's own
  ``ClearSolutions`` with the course's ``nbgrader_config.py``, no solution
  code left, every other cell unchanged, and every student notebook's
  exercises run with each check saying "Not attempted yet";
* the tool itself, on small synthetic cells and notebooks: the stubs, the
  errors on malformed markers and on answer cells nbgrader's stub would
  break, the refusals (a non-empty folder without ``--force``; the course's
  ``notebooks/`` folder, also through a relative path or a symbolic link) and
  byte-identical output from run to run.

The references are independent of the tool where it matters: the stubs are
compared with hand-written expected text and with nbgrader's preprocessor,
and the solution lines are found by a scanner written here, not by the tool's
parser.
"""

from __future__ import annotations

import ast
import contextlib
import importlib.util
import io
import json
import os
import re
import shutil
import subprocess
import sys
import textwrap
from pathlib import Path

import nbformat
import pytest
from nbclient import NotebookClient
from nbclient.exceptions import CellExecutionError

ROOT = Path(__file__).resolve().parents[1]
NOTEBOOKS = ROOT / "notebooks"
TOOL = ROOT / "tools" / "make_student_edition.py"
CHAPTERS = sorted(NOTEBOOKS.glob("[0-9][0-9]_*.ipynb"))

BEGIN, END = "### BEGIN SOLUTION", "### END SOLUTION"
CHECK_CALL = re.compile(r"\bbf\.checks\.")
EXERCISE_HEADING = re.compile(r"^###\s+Exercise\s+(\d+)\b")
KIND_LINE = re.compile(r"^\*Kind:\s*[^·*]+·\s*about\s+\d+(?:\s*-\s*\d+)?\s*min\s*·\s*(lab|homework)\s*\*$")


def _load_tool():
    spec = importlib.util.spec_from_file_location("_make_student_edition", TOOL)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


mse = _load_tool()
_spec = importlib.util.spec_from_file_location("_run_notebooks",
                                               ROOT / "tools" / "run_notebooks.py")
_runner = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(_runner)
_runner.wake_up_in_slices()     # a missed wake-up of nbclient's kernel client costs 0.5 s


def _read(path: Path):
    return nbformat.read(path, as_version=4)


def _chapter(path: Path) -> str:
    return path.name[:2]


def _marker_lines(source: str) -> list[tuple[int, str]]:
    """(line index, stripped line) of every line that mentions a solution marker."""
    return [(k, line.strip()) for k, line in enumerate(source.splitlines())
            if "BEGIN SOLUTION" in line or "END SOLUTION" in line]


def _is_answer_cell(cell) -> bool:
    return cell.cell_type == "code" and any(m == BEGIN for _, m in _marker_lines(cell.source))


def _is_why_cell(cell) -> bool:
    """A manually graded written answer: markdown that nbgrader marks as a solution."""
    return cell.cell_type == "markdown" and bool(cell.metadata.get("nbgrader", {}).get("solution"))


WHY_METADATA = {"grade": True, "solution": True, "locked": False, "schema_version": 3,
                "task": False}


def _solution_blocks(source: str) -> list[list[str]]:
    """The lines between each BEGIN/END pair (a scanner independent of the tool)."""
    blocks, current = [], None
    for line in source.splitlines():
        if line.strip() == BEGIN:
            current = []
        elif line.strip() == END:
            blocks.append(current)
            current = None
        elif current is not None:
            current.append(line)
    return blocks


def _exempt_lines(block: list[str]) -> set[int]:
    """Indices of the lines of a solution block a stub keeps: def signatures and docstrings."""
    code = textwrap.dedent("\n".join(block))
    exempt = set()
    for node in ast.parse(code).body:
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            first = node.decorator_list[0].lineno if node.decorator_list else node.lineno
            body = node.body[0]
            exempt.update(range(first - 1, max(body.lineno - 1, node.lineno)))
            if isinstance(body, ast.Expr) and isinstance(body.value, ast.Constant) \
                    and isinstance(body.value.value, str):
                exempt.update(range(body.lineno - 1, body.end_lineno))
    return exempt


def _outputs_text(cell) -> str:
    parts = []
    for out in cell.get("outputs", []):
        if out.get("output_type") == "stream":
            parts.append(out.get("text", ""))
        elif "data" in out:
            parts.append(out["data"].get("text/plain", ""))
        elif out.get("output_type") == "error":
            parts.append(f"{out.get('ename')}: {out.get('evalue')}")
    return "".join(parts)


def _exercise_headings(nb) -> list[tuple[int, int, list[str]]]:
    """(cell index, exercise number, lines after the heading) of every ``### Exercise N``."""
    found = []
    for index, cell in enumerate(nb.cells):
        if cell.cell_type != "markdown":
            continue
        lines = cell.source.splitlines()
        for k, line in enumerate(lines):
            match = EXERCISE_HEADING.match(line.strip())
            if match:
                found.append((index, int(match.group(1)), [x.strip() for x in lines[k + 1:] if x.strip()]))
    return found


def _exercise_of(nb, index: int) -> int | None:
    """The number of the last ``### Exercise N`` heading above cell ``index``."""
    numbers = [n for i, n, _ in _exercise_headings(nb) if i < index]
    return numbers[-1] if numbers else None


# --- the pattern, in every chapter --------------------------------------------------------

@pytest.fixture(params=CHAPTERS, ids=[p.name for p in CHAPTERS])
def chapter(request):
    return request.param


def test_there_are_chapter_notebooks():
    assert len(CHAPTERS) >= 5, f"expected the chapter notebooks in {NOTEBOOKS}, found {CHAPTERS}"


def test_solution_markers_pair_up_in_each_cell(chapter):
    for index, cell in enumerate(_read(chapter).cells):
        markers = _marker_lines(cell.source)
        where = f"{chapter.name} cell {index + 1}"
        if cell.cell_type != "code" and not _is_why_cell(cell):
            assert not markers, (f"{where}: solution markers belong in code cells and in "
                                 f"manually graded markdown answers only")
            continue
        for k, marker in markers:
            assert marker in (BEGIN, END), f"{where} line {k + 1}: marker not alone on its line: {marker!r}"
        kinds = [m for _, m in markers]
        assert kinds == [BEGIN, END] * (len(kinds) // 2) and len(kinds) % 2 == 0, (
            f"{where}: every {BEGIN!r} needs its {END!r} after it, in the same cell, unnested; "
            f"found {kinds}")


def test_every_answer_cell_is_followed_by_its_check_cell(chapter):
    nb = _read(chapter)
    for index, cell in enumerate(nb.cells):
        if not _is_answer_cell(cell):
            continue
        where = f"{chapter.name} cell {index + 1}"
        assert not CHECK_CALL.search(cell.source), f"{where}: the check belongs in the next cell"
        assert index + 1 < len(nb.cells), f"{where}: an answer cell needs a check cell after it"
        check = nb.cells[index + 1]
        assert check.cell_type == "code" and CHECK_CALL.search(check.source), (
            f"{where}: the answer cell must be followed by a check cell calling bf.checks.")
        assert not _marker_lines(check.source), f"{where}: the check cell holds a solution"
        last = check.source.strip().splitlines()[-1]
        number = _exercise_of(nb, index)
        call = re.match(rf"bf\.checks\.ch{_chapter(chapter)}\.exercise_(\d+)\(", last)
        assert call, (f"{where}: the check cell must end with a call "
                      f"bf.checks.ch{_chapter(chapter)}.exercise_N(...), got {last!r}")
        assert number is not None and int(call.group(1)) == number, (
            f"{where}: the check {last!r} does not match the heading ### Exercise {number} above it")


def test_written_answers_follow_their_check_in_the_pattern(chapter):
    """Statement, answer, check, [why]: a "why?" cell comes right after its exercise's check
    cell, with nbgrader's metadata of a manually graded answer, its question above the markers."""
    nb = _read(chapter)
    for index, cell in enumerate(nb.cells):
        if not _is_why_cell(cell):
            continue
        where = f"{chapter.name} cell {index + 1}"
        number = _exercise_of(nb, index)
        before = nb.cells[index - 1]
        assert before.cell_type == "code" and CHECK_CALL.search(before.source), (
            f"{where}: a written answer comes right after its exercise's check cell")
        meta = dict(cell.metadata["nbgrader"])
        assert meta.pop("grade_id", None) == f"ch{_chapter(chapter)}-ex{number}-why", (where, meta)
        points = meta.pop("points", None)
        assert isinstance(points, (int, float)) and points > 0, (where, points)
        assert meta == WHY_METADATA, (where, meta)
        lines = cell.source.splitlines()
        begin = [k for k, line in enumerate(lines) if line.strip() == BEGIN]
        assert len(begin) == 1 and begin[0] > 0 and lines[0].startswith("**Why?**"), (
            f"{where}: the question ('**Why?** ...') above one pair of markers")
        assert re.search(r"\*Rubric\.\*", cell.source), f"{where}: the rubric is missing"


def test_a_written_answer_stays_in_the_exercise_table(chapter):
    """Its points count for its exercise in the table of INSTRUCTORS.md (graded by hand)."""
    nb = _read(chapter)
    whys = [c for c in nb.cells if _is_why_cell(c)]
    found = mse.exercises(nb)
    assert sum(e["manual"] for e in found) == sum(c.metadata.nbgrader.get("points", 0) for c in whys)
    checks = [c for c in nb.cells if c.cell_type == "code" and CHECK_CALL.search(c.source)]
    assert sum(e["points"] for e in found) == sum(c.metadata.get("nbgrader", {}).get("points", 0)
                                                  for c in checks)


def test_every_exercise_heading_has_its_kind_line_and_an_answer_cell(chapter):
    nb = _read(chapter)
    headings = _exercise_headings(nb)
    numbers = [n for _, n, _ in headings]
    assert numbers == list(range(1, len(numbers) + 1)), (
        f"{chapter.name}: exercises must be numbered 1, 2, ... in order, found {numbers}")
    bounds = [i for i, _, _ in headings] + [len(nb.cells)]
    for (index, number, rest), stop in zip(headings, bounds[1:]):
        where = f"{chapter.name} ### Exercise {number}"
        assert rest and KIND_LINE.match(rest[0]), (
            f"{where}: the heading must be followed by the line "
            f"'*Kind: derivation | function | experiment · about 10 min · lab|homework*', "
            f"got {rest[0] if rest else None!r}")
        answers = [c for c in nb.cells[index + 1:stop] if _is_answer_cell(c)]
        assert answers, f"{where}: no answer cell ({BEGIN} ... {END}) before the next exercise"


def test_check_cells_say_correct_in_the_repository(chapter):
    """nbval compares these outputs with a fresh run; here: what they say is "Correct"."""
    for index, cell in enumerate(_read(chapter).cells):
        if cell.cell_type == "code" and CHECK_CALL.search(cell.source):
            text = _outputs_text(cell)
            assert text.startswith("Correct"), (
                f"{chapter.name} cell {index + 1}: the check of the reference solution must say "
                f"'Correct: ...', got {text[:200]!r}")


def test_every_chapter_has_at_least_three_exercises(chapter):
    nb = _read(chapter)
    numbers = [n for _, n, _ in _exercise_headings(nb)]
    answers = sum(1 for c in nb.cells if _is_answer_cell(c))
    assert len(numbers) >= 3 and answers >= 3, (
        f"{chapter.name}: {len(numbers)} '### Exercise N' headings and {answers} answer cells; "
        f"every chapter ends with 3-5 exercises in the pattern of CONTRIBUTING.md")


# --- the edition made from the real chapters -----------------------------------------------

@pytest.fixture(scope="module")
def edition(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("student") / "student"
    written = mse.make_student_edition(out)
    assert sorted(p.name for p in written) == [p.name for p in CHAPTERS]
    return out


def test_student_edition_equals_nbgrader_clear_solutions(edition):
    """nbgrader's own ClearSolutions, configured by the course's nbgrader_config.py, gives every
    cell the source the student edition gives it: one stub for the website, the edition and the
    nbgrader release."""
    from nbgrader.preprocessors import ClearSolutions
    from traitlets.config.loader import PyFileConfigLoader

    config = PyFileConfigLoader("nbgrader_config.py", path=str(ROOT)).load_config()
    assert (mse.CODE_STUB, mse.TEXT_STUB) == (config.ClearSolutions.code_stub["python"],
                                              config.ClearSolutions.text_stub)
    for path in CHAPTERS:
        released, _ = ClearSolutions(config=config).preprocess(_read(path), {})
        student = _read(edition / path.name)
        assert [c.source for c in student.cells] == [c.source for c in released.cells], path.name


def test_the_guide_shows_the_notebooks_tables_and_rubrics():
    """INSTRUCTORS.md's generated regions are what the notebooks give now (make guide)."""
    text = (ROOT / "INSTRUCTORS.md").read_text(encoding="utf-8")
    regions = mse.generated_regions(text)
    assert set(regions) == {"exercises", "rubrics"}, sorted(regions)
    assert regions["exercises"] == mse.exercise_table(), (
        "INSTRUCTORS.md's table of exercises differs from the notebooks: run "
        "python tools/make_student_edition.py --update-guide")
    assert regions["rubrics"] == mse.rubrics(), (
        "INSTRUCTORS.md's rubrics differ from the notebooks: run "
        "python tools/make_student_edition.py --update-guide")
    assert mse.updated_guide(text) == text


def test_student_edition_contains_no_solution_code(edition):
    for path in CHAPTERS:
        source = _read(path)
        student = _read(edition / path.name)
        elsewhere, solution = set(), set()
        for cell in source.cells:
            blocks = _solution_blocks(cell.source) if cell.cell_type == "code" or _is_why_cell(cell) else []
            for block in blocks:
                exempt = _exempt_lines(block) if cell.cell_type == "code" else set()  # prose
                solution.update(line.strip() for k, line in enumerate(block)
                                if k not in exempt and re.search(r"\w", line)
                                and not line.strip().startswith("#"))
            marked = False            # lines outside the markers, by position (a given line
            for line in cell.source.splitlines():   # may repeat one of the solution's)
                if line.strip() in ("### BEGIN SOLUTION", "### END SOLUTION"):
                    marked = line.strip() == "### BEGIN SOLUTION"
                elif not marked or not blocks:
                    elsewhere.add(line.strip())
        # A solution line that also stands outside every solution block (a given matrix, a
        # `return x`) may stay; every other one must be gone from the student notebook.
        secret = solution - elsewhere
        for index, cell in enumerate(student.cells):
            assert not _marker_lines(cell.source), f"{path.name} cell {index + 1}: markers left"
            leaked = secret & {line.strip() for line in cell.source.splitlines()}
            assert not leaked, f"{path.name} cell {index + 1}: solution code left: {sorted(leaked)}"
            if _is_answer_cell(source.cells[index]) or CHECK_CALL.search(cell.source):
                assert cell.outputs == [] and cell.execution_count is None, (
                    f"{path.name} cell {index + 1}: outputs of answer and check cells are cleared")


def test_student_edition_keeps_everything_else(edition):
    for path in CHAPTERS:
        source, student = _read(path), _read(edition / path.name)
        assert student.metadata == source.metadata
        assert len(student.cells) == len(source.cells), path.name
        changed = 0
        for index, (a, b) in enumerate(zip(source.cells, student.cells)):
            if _is_answer_cell(a) or _is_why_cell(a) or (a.cell_type == "code" and CHECK_CALL.search(a.source)):
                changed += 1
                assert (b.cell_type, b.get("id"), b.metadata) == (a.cell_type, a.get("id"), a.metadata)
                if not _is_answer_cell(a) and not _is_why_cell(a):
                    assert b.source == a.source, f"{path.name} cell {index + 1}: a check cell is kept"
                continue
            assert b == a, f"{path.name} cell {index + 1} changed in the student edition"
        if not changed:
            assert (edition / path.name).read_bytes() == path.read_bytes(), (
                f"{path.name} has no exercises and must be copied byte for byte")


def _names(tree: ast.AST) -> tuple[set[str], set[str]]:
    """(names a cell binds at top level, names it reads anywhere, inside functions too)."""
    bound, read = set(), set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Name):
            (bound if isinstance(node.ctx, (ast.Store, ast.Del)) else read).add(node.id)
        elif isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            bound.add(node.name)
        elif isinstance(node, (ast.Import, ast.ImportFrom)):
            bound.update((a.asname or a.name).split(".")[0] for a in node.names)
        elif isinstance(node, (ast.Subscript, ast.Attribute)) and isinstance(node.ctx, ast.Store):
            base = node.value
            while isinstance(base, (ast.Subscript, ast.Attribute)):
                base = base.value
            if isinstance(base, ast.Name):
                bound.add(base.id)        # ys[3] = ..., model.x = ...: the cell changes ys
    return bound, read


def _python(source: str) -> str:
    """A cell's code without IPython's magics (``%matplotlib inline``)."""
    return "\n".join("" if line.lstrip().startswith(("%", "!")) else line for line in source.splitlines())


def exercise_slice(nb) -> list[int]:
    """The code cells a student edition's exercises need: every answer and check cell, and,
    going backwards, each earlier cell that binds (or changes) a name they, or a cell already
    taken, read. The cells taken run in their order; the chapter's other cells (figures,
    experiments nobody downstream reads) are left out, which is what makes the run cheap."""
    cells = [(k, c) for k, c in enumerate(nb.cells) if c.cell_type == "code"]
    block = [k for k, c in cells if _is_answer_cell(c) or CHECK_CALL.search(c.source)]
    taken, needed = [], set()
    for k, cell in reversed(cells):
        if k > block[-1]:
            continue                      # sections after the exercises
        bound, read = _names(ast.parse(_python(cell.source)))
        if k >= block[0] or bound & needed:
            taken.append(k)
            needed |= read
    return sorted(taken)


RUN_SLICES = r"""
import contextlib, io, json, sys, traceback, warnings
import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt
import ast
report = {}
for name, cells in json.loads(sys.stdin.read()).items():
    from IPython.display import display
    namespace, outputs = {"__name__": "__main__", "display": display}, []
    for index, source in cells:
        tree = ast.parse(source)
        last = tree.body.pop() if tree.body and isinstance(tree.body[-1], ast.Expr) else None
        try:
            with contextlib.redirect_stdout(io.StringIO()), warnings.catch_warnings():
                warnings.simplefilter("ignore")
                exec(compile(tree, f"{name} cell {index + 1}", "exec"), namespace)
                value = eval(compile(ast.Expression(last.value), "<last>", "eval"), namespace) if last else None
        except Exception:
            outputs.append((index, "ERROR " + traceback.format_exc(limit=3)))
            break
        outputs.append((index, repr(value)))
        plt.close("all")
    report[name] = outputs
print(json.dumps(report))
"""


def test_student_edition_runs_and_every_check_says_not_attempted(edition):
    """Every student notebook's exercises, run after the chapter cells they need, in one process.

    The student edition equals the course edition except in its answer and check cells
    (test_student_edition_keeps_everything_else), and the course edition runs top to bottom
    under strict nbval. So what is left to show is that the stubs and the given code of the
    answer cells run, and that every check then says "Not attempted yet", in a namespace made
    by the chapter's own cells: the cells the exercises read from (exercise_slice), not the
    whole chapter, and all six chapters in one Python process rather than six kernels.
    """
    slices = {}
    for path in sorted(edition.glob("*.ipynb")):
        nb = _read(path)
        slices[path.name] = [(k, _python(nb.cells[k].source)) for k in exercise_slice(nb)]
    proc = subprocess.run([sys.executable, "-c", RUN_SLICES], input=json.dumps(slices),
                          capture_output=True, text=True, cwd=edition, timeout=600,
                          env=dict(os.environ, MPLBACKEND="Agg"))
    assert proc.returncode == 0, proc.stderr[-3000:]
    report = json.loads(proc.stdout.strip().splitlines()[-1])
    failures = []
    for name, outputs in report.items():
        nb = _read(edition / name)
        for index, text in outputs:
            if text.startswith("ERROR"):
                failures.append(f"{name} cell {index + 1}: {text}")
            elif CHECK_CALL.search(nb.cells[index].source) and "Not attempted yet" not in text:
                failures.append(f"{name} cell {index + 1}: the check says {text[:200]!r}, "
                                f"not 'Not attempted yet'")
        checks = [k for k, c in enumerate(nb.cells) if c.cell_type == "code" and CHECK_CALL.search(c.source)]
        assert sorted(k for k, _ in outputs if k in checks) == checks or failures, f"{name}: checks not run"
    assert not failures, "the student edition's exercises must run:\n" + "\n".join(failures)


def test_the_exercise_slice_takes_what_the_answers_read():
    nb = _notebook([("code", "import numpy as np"), ("code", "ys = np.zeros(3)"),
                    ("code", "big = np.ones(9)  # an experiment nobody reads"),
                    ("code", "ys[1] = 2.0"), ("md", "### Exercise 1 · T\n*Kind: function · about 5 min · lab*"),
                    ("code", "### BEGIN SOLUTION\nanswer_1 = ys.sum()\n### END SOLUTION"),
                    ("code", "bf.checks.ch01.exercise_1(answer_1)"), ("code", "later = ys + 1")])
    assert exercise_slice(nb) == [0, 1, 3, 5, 6]


# --- the tool on synthetic cells ----------------------------------------------------------

def test_a_function_body_becomes_the_stub_and_keeps_its_signature_and_docstring():
    source = textwrap.dedent("""\
        # Exercise 2: your answer
        def kalman_gain(P, C,
                        R):  # K = P C^T S^-1
            \"\"\"The Kalman gain.

            K = P C^T (C P C^T + R)^{-1}
            \"\"\"
            ### BEGIN SOLUTION
            S = C @ P @ C.T + R
            return P @ C.T @ np.linalg.inv(S)
            ### END SOLUTION""")
    expected = textwrap.dedent("""\
        # Exercise 2: your answer
        def kalman_gain(P, C,
                        R):  # K = P C^T S^-1
            \"\"\"The Kalman gain.

            K = P C^T (C P C^T + R)^{-1}
            \"\"\"
            # YOUR CODE HERE""")
    mse.check_answer_cell(source)
    assert mse.student_source(source) == expected
    namespace = {}
    exec(compile(expected, "<stub>", "exec"), namespace)
    assert namespace["kalman_gain"](1, 2, 3) is None, "the stub returns None, it does not raise"


def test_value_answers_keep_their_none_line_and_get_the_stub():
    source = ("rng = np.random.default_rng(7)\nA = np.eye(2)\nanswer_3 = None  # your answer\n"
              "### BEGIN SOLUTION\nanswer_3 = A @ A\n### END SOLUTION\nprint(A)")
    mse.check_answer_cell(source)
    assert mse.student_source(source) == ("rng = np.random.default_rng(7)\nA = np.eye(2)\n"
                                          "answer_3 = None  # your answer\n# YOUR CODE HERE\nprint(A)")


def test_a_final_newline_is_kept_or_not_as_nbgrader_keeps_it():
    assert mse.student_source("x = None\n### BEGIN SOLUTION\nx = 1\n### END SOLUTION\n") == \
        "x = None\n# YOUR CODE HERE\n"
    assert mse.student_source("x = None\n### BEGIN SOLUTION\nx = 1\n### END SOLUTION") == \
        "x = None\n# YOUR CODE HERE"


def test_a_written_answer_keeps_its_question():
    source = ("**Why?** *(graded by hand, 1 point)* Why one?\n\n### BEGIN SOLUTION\n"
              "*Model answer.* Because.\n\n*Rubric.* 1 point: because.\n### END SOLUTION")
    mse.check_written_answer_cell(source)
    assert mse.student_source(source, mse.TEXT_STUB) == (
        "**Why?** *(graded by hand, 1 point)* Why one?\n\nYOUR ANSWER HERE")


def test_a_cell_without_markers_is_unchanged():
    source = "x = 1  # no exercise here\nprint(x)"
    assert mse.student_source(source) == source


@pytest.mark.parametrize("source, message", [
    ("### BEGIN SOLUTION\nx = 1\n", r"line 1: '### BEGIN SOLUTION' has no '### END SOLUTION'"),
    ("x = 1\n### END SOLUTION\n", r"line 2: '### END SOLUTION' without a '### BEGIN SOLUTION'"),
    ("### BEGIN SOLUTION\n### BEGIN SOLUTION\nx = 1\n### END SOLUTION\n### END SOLUTION\n",
     r"line 2: .* cannot be nested"),
    ("x = 1  ### BEGIN SOLUTION\ny = 2\n### END SOLUTION\n", r"line 1: .*alone on its line"),
    ("### BEGIN SOLUTION  # the answer\nx = 1\n### END SOLUTION\n", r"line 1: .*alone on its line"),
    ("    ### BEGIN SOLUTION\n    x = 1\n### END SOLUTION\n", r"line 3: .*indented differently"),
    ("x = None\n### BEGIN SOLUTION\nimport numpy as np\nx = np.eye(2)\n### END SOLUTION\n",
     r"line 3 .*only assignments of the answer names"),
    ("x = None\n### BEGIN SOLUTION\nx = 1\nprint(x)\n### END SOLUTION\n", r"line 4 .*only assignments"),
    ("x = None\n### BEGIN SOLUTION\nx[0] = 1\n### END SOLUTION\n", r"only names can be assigned"),
    ("x = None\n### BEGIN SOLUTION\nx = (1,\n### END SOLUTION\n", r"not valid Python"),
    ("### BEGIN SOLUTION\nx = 1\n### END SOLUTION\n", r"x is assigned between the markers but not "
                                                      r"set to None above them"),
    ("### BEGIN SOLUTION\ndef f(x):\n    return x\n### END SOLUTION\n",
     r"signature and docstring stand outside the markers"),
    ("def f(x):\n    ### BEGIN SOLUTION\n    return x\n    ### END SOLUTION\n",
     r"not valid Python once its solution is replaced .* needs its docstring above the markers"),
])
def test_malformed_markers_and_answer_cells_the_stub_would_break_are_errors(source, message):
    with pytest.raises(mse.StudentEditionError, match=message):
        mse.check_answer_cell(source)


@pytest.mark.parametrize("source, message", [
    ("*Model answer.* Because.", r"needs '### BEGIN SOLUTION' and '### END SOLUTION'"),
    ("### BEGIN SOLUTION\nBecause.\n### END SOLUTION", r"states its question above the markers"),
])
def test_a_written_answer_without_its_question_or_markers_is_an_error(source, message):
    with pytest.raises(mse.StudentEditionError, match=message):
        mse.check_written_answer_cell(source)


def _notebook(cells) -> nbformat.NotebookNode:
    nb = nbformat.v4.new_notebook(metadata={"kernelspec": {
        "name": "python3", "display_name": "Python 3 (ipykernel)", "language": "python"}})
    for k, (kind, source) in enumerate(cells):
        if kind == "why":
            nb.cells.append(nbformat.v4.new_markdown_cell(source, id=f"cell-{k}", metadata={
                "nbgrader": {**WHY_METADATA, "points": 1, "grade_id": "ch09-ex2-why"}}))
            continue
        new = nbformat.v4.new_markdown_cell if kind == "md" else nbformat.v4.new_code_cell
        nb.cells.append(new(source, id=f"cell-{k}"))
    return nb


SYNTHETIC = [
    ("code", "import numpy as np\nimport bayesfilt as bf"),
    ("md", "## Exercises\n\n### Exercise 1 · A number\n*Kind: derivation · about 5 min · lab*\n\n"
           "Define `answer_1`, a float."),
    ("code", "# Exercise 1: your answer\nanswer_1 = None  # your answer\n### BEGIN SOLUTION\n"
             "answer_1 = 0.25 * 8\n### END SOLUTION"),
    ("code", "bf.checks.compare_number(answer_1, 2.0, what='answer_1')"),
    ("md", "### Exercise 2 · A function\n*Kind: function · about 15 min · homework*\n\n"
           "Write `double(x)`."),
    ("code", "x_given = np.arange(3.0)\n\n\ndef double(x):\n    \"\"\"Twice x.\"\"\"\n"
             "    ### BEGIN SOLUTION\n    return x + x\n    ### END SOLUTION"),
    ("code", "bf.checks.compare_function(double, lambda x: 2 * x, [(x_given,)], what='double')"),
    ("why", "**Why?** *(graded by hand, 1 point)* Why twice?\n\n### BEGIN SOLUTION\n"
            "*Model answer.* Doubling.\n\n*Rubric.* 1 point: doubling.\n### END SOLUTION"),
    ("md", "## 9. More *(optional)*"),
]


def test_student_notebook_clears_answer_and_check_outputs_only():
    nb = _notebook(SYNTHETIC)
    for k, cell in enumerate(nb.cells):
        if cell.cell_type == "code":
            cell.execution_count = k
            cell.outputs = [nbformat.v4.new_output("stream", name="stdout", text=f"out {k}\n")]
    student = mse.student_notebook(nb, "synthetic.ipynb")
    assert nb.cells[2].source.count("BEGIN") == 1, "the input notebook must not be changed"
    assert student.cells[0] == nb.cells[0]
    for k in (2, 3, 5, 6):
        assert student.cells[k].outputs == [] and student.cells[k].execution_count is None
    assert student.cells[2].source == ("# Exercise 1: your answer\nanswer_1 = None  # your answer\n"
                                       "# YOUR CODE HERE")
    assert student.cells[3].source == nb.cells[3].source
    assert student.cells[5].source == ('x_given = np.arange(3.0)\n\n\ndef double(x):\n'
                                       '    """Twice x."""\n    # YOUR CODE HERE')
    assert student.cells[7].source == "**Why?** *(graded by hand, 1 point)* Why twice?\n\nYOUR ANSWER HERE"
    assert student.cells[7].metadata == nb.cells[7].metadata


def test_an_error_names_the_notebook_and_the_cell():
    nb = _notebook(SYNTHETIC + [("code", "### BEGIN SOLUTION\ny = 1")])
    with pytest.raises(mse.StudentEditionError,
                       match=r"^bad\.ipynb, cell 10, id cell-9: line 1: '### BEGIN SOLUTION' has no"):
        mse.student_notebook(nb, "bad.ipynb")
    nb = _notebook(SYNTHETIC + [("md", "Text\n### BEGIN SOLUTION\nsecret\n### END SOLUTION")])
    with pytest.raises(mse.StudentEditionError, match=r"cell 10, .*markdown cell that nbgrader "
                                                      r"does not mark as a solution"):
        mse.student_notebook(nb, "bad.ipynb")


def test_exercises_are_listed_with_kind_time_setting_and_points():
    nb = _notebook(SYNTHETIC)
    nb.cells[3].metadata["nbgrader"] = {"grade": True, "points": 1}
    nb.cells[6].metadata["nbgrader"] = {"grade": True, "points": 2}
    found = mse.exercises(nb)
    assert [(e["number"], e["title"], e["kind"], e["time"], e["setting"], e["points"], e["manual"])
            for e in found] == [(1, "A number", "derivation", "about 5 min", "lab", 1, 0),
                                (2, "A function", "function", "about 15 min", "homework", 2, 1)]


def test_the_table_and_the_rubrics_from_a_synthetic_chapter(tmp_path):
    nb = _notebook(SYNTHETIC)
    nb.cells[3].metadata["nbgrader"] = {"grade": True, "points": 1}
    nb.cells[6].metadata["nbgrader"] = {"grade": True, "points": 1}
    nbformat.write(nb, tmp_path / "09_synthetic.ipynb")
    table = mse.exercise_table(tmp_path)
    assert "| [09](notebooks/09_synthetic.ipynb) | 2 · A function | function | about 15 min | " \
           "homework | 1 + 1 by hand |" in table
    assert "| [09_synthetic](notebooks/09_synthetic.ipynb) | 2 | 1, about 5 min | 1, about 15 min " \
           "| 2 + 1 by hand |" in table
    rubric = mse.rubrics(tmp_path)
    assert rubric.startswith("**09 · exercise 2** (`ch09-ex2-why`, 1 point). **Why?**")
    assert "> *Model answer.* Doubling." in rubric and "> *Rubric.* 1 point: doubling." in rubric
    guide = ("a\n<!-- generated: exercises (x) -->\nold\n<!-- end generated: exercises -->\nb\n"
             "<!-- generated: rubrics (x) -->\n<!-- end generated: rubrics -->\n")
    new = mse.updated_guide(guide, tmp_path)
    assert mse.generated_regions(new) == {"exercises": table, "rubrics": rubric}
    assert mse.updated_guide(new, tmp_path) == new


def test_a_synthetic_student_notebook_runs_and_says_not_attempted(tmp_path):
    """The course notebook, then its student copy, in one real kernel (as "Run All" twice)."""
    nb = _notebook(SYNTHETIC)
    student = mse.student_notebook(nb)
    both = _notebook(SYNTHETIC)
    both.cells = nb.cells + [nbformat.from_dict({**c, "id": f"student-{k}"}) for k, c in enumerate(student.cells)]
    NotebookClient(both, timeout=120, kernel_name="python3",
                   resources={"metadata": {"path": str(tmp_path)}}).execute()
    for offset, expected in ((0, "Correct"), (len(nb.cells), "Not attempted yet")):
        for k in (3, 6):
            text = _outputs_text(both.cells[offset + k])
            assert text.startswith(expected), text


# --- the command line: refusals and determinism -------------------------------------------

@pytest.fixture
def fake_repo(tmp_path) -> Path:
    """A copy of the repository's layout: the tool, and notebooks/ with a synthetic chapter.

    The command-line tests write here, so that a broken refusal could never
    overwrite the real notebooks.
    """
    repo = tmp_path / "repo"
    (repo / "tools").mkdir(parents=True)
    (repo / "notebooks").mkdir()
    shutil.copy(TOOL, repo / "tools" / TOOL.name)
    shutil.copy(ROOT / "INSTRUCTORS.md", repo / "INSTRUCTORS.md")
    nbformat.write(_notebook(SYNTHETIC), repo / "notebooks" / "01_synthetic.ipynb")
    shutil.copy(min(CHAPTERS, key=lambda p: p.stat().st_size), repo / "notebooks")
    return repo


class _Run:
    def __init__(self, returncode: int, stdout: str, stderr: str):
        self.returncode, self.stdout, self.stderr = returncode, stdout, stderr


def _cli(repo: Path, *args: str, cwd: Path | None = None, hashseed: str | None = None):
    """Run the fake repository's copy of the tool on ``args`` from ``cwd``.

    In-process (the copy loaded as a module, so that its notebooks/ is the fake one; the
    working directory changed for the call), which is what the command line does minus the
    start of a Python process; with ``hashseed``, as a real process with that
    PYTHONHASHSEED (determinism across processes needs two processes).
    """
    tool = repo / "tools" / TOOL.name
    if hashseed is not None:
        env = dict(os.environ, PYTHONHASHSEED=hashseed)
        return subprocess.run([sys.executable, str(tool), *args], cwd=cwd or repo, env=env,
                              capture_output=True, text=True, timeout=120)
    spec = importlib.util.spec_from_file_location(f"_tool_{abs(hash(str(repo)))}", tool)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    out, err, here = io.StringIO(), io.StringIO(), os.getcwd()
    try:
        os.chdir(cwd or repo)
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            try:
                code = module.main(list(args))
            except SystemExit as exc:
                code = exc.code or 0
    finally:
        os.chdir(here)
    return _Run(code, out.getvalue(), err.getvalue())


def _snapshot(folder: Path) -> dict:
    return {p.relative_to(folder): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


def test_help_documents_the_usage(fake_repo):
    proc = _cli(fake_repo, "--help")
    assert proc.returncode == 0
    assert "OUTPUT_DIR" in proc.stdout and "--force" in proc.stdout
    assert "python tools/make_student_edition.py student/" in mse.__doc__


def test_writes_into_a_new_folder_and_refuses_a_non_empty_one_without_force(fake_repo, tmp_path):
    out = tmp_path / "student"
    first = _cli(fake_repo, str(out))
    assert first.returncode == 0, first.stderr
    assert sorted(p.name for p in out.iterdir()) == sorted(p.name for p in (fake_repo / "notebooks").glob("*.ipynb"))
    (out / "notes.txt").write_text("mine")
    before = _snapshot(out)
    again = _cli(fake_repo, str(out))
    assert again.returncode != 0
    assert "not empty" in again.stderr and "--force" in again.stderr
    assert _snapshot(out) == before, "a refused run must not touch the folder"
    forced = _cli(fake_repo, str(out), "--force")
    assert forced.returncode == 0, forced.stderr
    assert (out / "notes.txt").read_text() == "mine", "--force deletes nothing"


@pytest.mark.parametrize("how", ["absolute", "relative", "dot", "dotdot", "inside", "symlink",
                                 "symlink-inside"])
def test_refuses_the_notebooks_folder_even_with_force(fake_repo, tmp_path, how):
    notebooks = fake_repo / "notebooks"
    cwd = fake_repo
    if how == "absolute":
        target = str(notebooks)
    elif how == "relative":
        target = "notebooks"
    elif how == "dot":
        target, cwd = ".", notebooks
    elif how == "dotdot":
        target = "tools/../notebooks/"
    elif how == "inside":
        target = "notebooks/student"
    else:
        link = tmp_path / "link"
        link.symlink_to(notebooks, target_is_directory=True)
        target = str(link) if how == "symlink" else str(link / "student")
    before = _snapshot(notebooks)
    proc = _cli(fake_repo, target, "--force", cwd=cwd)
    assert proc.returncode != 0
    assert "refusing" in proc.stderr and "notebooks" in proc.stderr, proc.stderr
    assert _snapshot(notebooks) == before and not (notebooks / "student").exists()


@pytest.mark.parametrize("target", ["notebooks", "notebooks/student", "notebooks/../notebooks"])
def test_refuses_the_real_notebooks_folder_before_reading_anything(monkeypatch, target):
    """The real folder, in-process, with reading and writing disabled: nothing can be hurt."""
    def forbidden(*args, **kwargs):
        raise AssertionError("the tool touched a notebook before refusing")

    monkeypatch.setattr(mse.nbformat, "read", forbidden)
    monkeypatch.setattr(mse.nbformat, "write", forbidden)
    monkeypatch.chdir(ROOT)
    assert mse.main([target, "--force"]) == 2
    assert mse.main([str(ROOT / target), "--force"]) == 2
    assert not (NOTEBOOKS / "student").exists()


def test_malformed_markers_stop_the_tool_before_writing(fake_repo, tmp_path):
    nbformat.write(_notebook(SYNTHETIC + [("code", "x = 1\n### END SOLUTION")]),
                   fake_repo / "notebooks" / "09_broken.ipynb")
    out = tmp_path / "student"
    proc = _cli(fake_repo, str(out))
    assert proc.returncode == 1
    assert "09_broken.ipynb, cell 10" in proc.stderr and "without a '### BEGIN SOLUTION'" in proc.stderr
    assert not out.exists() or not any(out.iterdir())


def test_output_is_byte_identical_from_run_to_run(fake_repo, tmp_path):
    """Two processes with different hash seeds (set and dict orders differ): this one, in-process,
    and a fresh one started with another PYTHONHASHSEED."""
    one, two = tmp_path / "one", tmp_path / "two"
    other = "2" if os.environ.get("PYTHONHASHSEED") == "1" else "1"
    assert _cli(fake_repo, str(one)).returncode == 0
    assert _cli(fake_repo, str(two), hashseed=other).returncode == 0
    assert _snapshot(one) == _snapshot(two)
    assert "# YOUR CODE HERE" in (one / "01_synthetic.ipynb").read_text()



def test_the_commands_of_instructors_md_run(fake_repo, tmp_path):
    """Every `python tools/make_student_edition.py ...` of INSTRUCTORS.md, run as written (from a
    copy of the repository's layout, so that the real notebooks are never the target)."""
    text = (ROOT / "INSTRUCTORS.md").read_text(encoding="utf-8")
    commands = set(re.findall(r"python tools/make_student_edition\.py(?:[ \n]+(?:--[\w-]+|[\w./-]+/))*",
                              text))
    assert any(c.endswith("student/") for c in commands) and any(c.endswith("--table") for c in commands), commands
    for command in sorted(commands):
        args = command.split()[2:]
        proc = _cli(fake_repo, *args)
        assert proc.returncode == 0, (command, proc.stderr)
        if "--table" in args:
            assert proc.stdout.startswith("| chapter | exercise | kind | time | setting | points |"), proc.stdout
    assert (fake_repo / "student" / "01_synthetic.ipynb").exists()
