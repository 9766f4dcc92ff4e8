"""The classroom workflow with nbgrader 0.9.6, run for real (INSTRUCTORS.md, "Grading with nbgrader").

The commands of the recipe in INSTRUCTORS.md are read from the file and run as
they stand, with the course's ``nbgrader_config.py``, in a temporary folder
that holds a copy of chapter 02: make a course folder, import the roster
(the guide's example, written to ``course/roster.csv``), set a due date,
generate chapter 02's release; then (after the test has put a simulated
class's submissions where the recipe says) autograde, generate the feedback
and export the grades. The roster has four students:

* ``alice`` answers everything with the reference solutions and the model
  answers of the "why?" questions, two days after the due date: 5 of 5
  checked points, her "why?" answers waiting for manual grading, and her
  lateness in the export;
* ``bob`` hands in the released notebook untouched: 0 of 5, his "why?"
  cells scored 0 as "No response" (nbgrader's rule for an unchanged cell);
* ``carol`` has an answer cell that never finishes (stopped by nbgrader's cell
  time limit, and her graded notebook says so), a typical mistake (R left
  out of S), a right answer, a function that never returns (stopped by the
  checks' time limit) and a function that raises, and a wrong "why?" answer:
  1 of 5, each check's diagnosis in her graded notebook and her feedback page;
* ``dave`` hands in nothing: 0 in the export, with no timestamp.

The released notebook is also run top to bottom as a student runs it in
JupyterLab (no ``NBGRADER_EXECUTION``), in parallel with the autograding: no
cell fails and every check says "Not attempted yet". A submission in a
misspelt folder (``alcie``) is refused: the course's configuration grades
only the roster.

Chapter 02 is used because it is the cheapest chapter to execute; the checks'
time limit is set to 1 s (``BAYESFILT_CHECK_TIME_LIMIT``) so that the endless
loop in a function costs one second, and nbgrader's cell time limit to 6 s
(``--Execute.timeout``, added to the autograde command) so that the endless
answer cell costs six, not thirty (every other cell of chapter 02 takes under
2 s). Until the chapter's writer adds its manually graded "why?" cells, the
test adds one to its copy of the chapter (exercise 4's "why that one?", in the pattern of CONTRIBUTING.md).
"""

from __future__ import annotations

import copy
import csv
import json
import os
import re
import subprocess
import sys
import textwrap
from pathlib import Path

import nbformat
import pytest

ROOT = Path(__file__).resolve().parents[1]
CHAPTER = ROOT / "notebooks" / "02_kalman_derivation.ipynb"
CONFIG = ROOT / "nbgrader_config.py"
ASSIGNMENT = "ch02"
INSTRUCTORS = ROOT / "INSTRUCTORS.md"
BIN = Path(sys.executable).parent
CODE_STUB, TEXT_STUB = "# YOUR CODE HERE", "YOUR ANSWER HERE"
CELL_TIMEOUT = 6         # nbgrader's per-cell limit in this test (the course's config says 30 s)

# What the third student writes in place of nbgrader's stubs, per exercise, one entry per stub
# of the answer cell (exercise 4 has two: the function's body, then the two values); None: the
# reference solution.
CAROL = {
    1: ["while True:\n    pass"],                            # an answer cell that never ends
    2: ["return P @ C.T @ np.linalg.inv(C @ P @ C.T)"],      # a typical mistake: R left out of S
    3: [None],                                               # right
    # a function that never returns; its values typed in, so that only the check calls it
    4: ["while True:\n    pass", "agree_4 = 3\nmeaning_4 = \"best linear estimate\""],
    5: ["return P @ C.T * (1 / 0)"],                         # a function that raises
}
CAROL_WHY = "Because the grid is finer."                     # a wrong written answer
EXPECTED = {
    "alice": [1, 1, 1, 1, 1],
    "bob": [0, 0, 0, 0, 0],
    "carol": [0, 0, 1, 0, 0],
}
CAROL_SAYS = {1: "Not attempted yet", 2: "S is computed without R", 3: "Correct",
              4: "did not return within 1 s: an endless loop?", 5: "ZeroDivisionError"}
LATE = {"alice": "2027-03-30 10:00:00 +0900"}    # two days after the recipe's due date

# The "why?" cell the test adds to its copy of chapter 02 when the chapter has none yet.
WHY_4 = {
    "source": ("**Why?** *(graded by hand, 1 point)* Why do the grid and Kalman means agree at "
               "that one step and at no later one?\n\n### BEGIN SOLUTION\n*Model answer.* At "
               "t = 0 no prediction has used the process noise yet: both filters update the same "
               "Gaussian prior with the same Gaussian likelihood. From the first prediction on, "
               "the grid carries the uniform noise exactly and its belief is no longer "
               "Gaussian.\n\n*Rubric.* 1 point: no process noise before t = 0's update, "
               "non-Gaussian after; ½ point: only one of the two; 0: the grid's resolution.\n"
               "### END SOLUTION"),
    "metadata": {"nbgrader": {"grade": True, "solution": True, "locked": False, "points": 1,
                              "grade_id": "ch02-ex4-why", "schema_version": 3, "task": False}},
}

# Each block of the recipe runs in one Python process: `cd`, `mkdir -p` and `cp` as the shell
# does them, each `nbgrader ...` line through nbgrader's own application with the same argv
# (as nbgrader's tests do), which saves starting nbgrader once per command. EXTRA holds
# arguments the test adds to a subcommand (the shorter cell time limit).
DRIVER = r"""
import json, os, shlex, shutil, subprocess, sys
from pathlib import Path
extra, may_fail = json.loads(sys.argv[2]), json.loads(sys.argv[3])
for line in sys.argv[1].splitlines():
    line = line.split(" #")[0].strip()
    if not line or line.startswith("#"):
        continue
    args = shlex.split(line)
    if args[0] == "cd":
        os.chdir(args[1])
    elif args[:2] == ["mkdir", "-p"]:
        Path(args[2]).mkdir(parents=True, exist_ok=True)
    elif args[0] == "cp" and len(args) == 3:
        shutil.copy(args[1], args[2])
    elif args[0] == "nbgrader":
        from jupyter_core.application import NoStart
        from nbgrader.apps.nbgraderapp import NbGraderApp
        app = NbGraderApp.instance()
        try:
            app.initialize(args[1:] + extra.get(args[1], []))
            app.start()
            code = 0
        except NoStart:
            code = 0
        except SystemExit as exc:
            code = exc.code or 0
        finally:
            app.reset()
        if line in may_fail:
            print(json.dumps({"command": line, "status": code}), flush=True)
        elif code:
            sys.exit(f"{line}: exit status {code}")
    else:
        subprocess.run(line, shell=True, check=True)
"""

# A student's "Run All" on the released notebook, as in JupyterLab (no NBGRADER_EXECUTION).
RUN_ALL = r"""
import json, sys
import nbformat
from nbclient import NotebookClient
sys.path.insert(0, sys.argv[3])
from run_notebooks import wake_up_in_slices
wake_up_in_slices()   # a missed wake-up of the kernel client costs 0.5 s, not the timeout
nb = nbformat.read(sys.argv[1], as_version=4)
NotebookClient(nb, timeout=600, kernel_name="python3", allow_errors=True,
               resources={"metadata": {"path": sys.argv[2]}}).execute()
nbformat.write(nb, sys.argv[1] + ".ran.ipynb")
"""


def _recipe() -> list[str]:
    """The ```bash blocks of INSTRUCTORS.md's section "Grading with nbgrader", in order."""
    return re.findall(r"```bash\n(.*?)```", _section(), flags=re.S)


def _section() -> str:
    text = INSTRUCTORS.read_text(encoding="utf-8")
    section = text[text.index("## Grading with nbgrader"):]
    return section[:section.index("\n## ", 3)] if "\n## " in section[3:] else section


def _roster() -> str:
    """The guide's example roster (the code block that starts with the roster's header)."""
    blocks = re.findall(r"```text\n(id,first_name,last_name,email\n.*?)```", _section(), flags=re.S)
    assert len(blocks) == 1, "the recipe shows one example roster"
    return blocks[0]


def _grade_id(cell) -> str:
    return cell.metadata.get("nbgrader", {}).get("grade_id", "")


def _source_chapter():
    """Chapter 02 as an nbgrader source notebook, with a "why?" cell if it has none yet."""
    nb = nbformat.read(CHAPTER, as_version=4)
    if not any(_grade_id(c) == "ch02-ex2-check" for c in nb.cells):
        pytest.fail("notebooks/02_kalman_derivation.ipynb is not an nbgrader source notebook "
                    "(no cell with grade id ch02-ex2-check)")
    if not any(re.fullmatch(r"ch02-ex\d+-why", _grade_id(c)) for c in nb.cells):
        at = next(k for k, c in enumerate(nb.cells) if _grade_id(c) == "ch02-ex4-check")
        cell = nbformat.v4.new_markdown_cell(WHY_4["source"], id="ch02-ex4-why",
                                             metadata=copy.deepcopy(WHY_4["metadata"]))
        nb.cells.insert(at + 1, cell)
    return nb


def _blocks(source: str) -> list[str]:
    """The solution blocks of a cell (dedented), in order."""
    return [textwrap.dedent(body) for _, body in re.findall(
        r"^([ \t]*)### BEGIN SOLUTION\n(.*?)^[ \t]*### END SOLUTION", source, flags=re.S | re.M)]


def _solutions(source_nb) -> dict[str, list[str]]:
    """The reference solutions of the source notebook, per grade id, one per marker block."""
    return {_grade_id(c): _blocks(c.source) for c in source_nb.cells
            if re.fullmatch(r"ch02-ex\d+-(answer|why)", _grade_id(c))}


def _submit(release: Path, target: Path, answers: dict[str, list[str | None]],
            solutions: dict[str, list[str]]) -> None:
    """Write a student's notebook: each stub replaced by the student's text (None: the solution)."""
    nb = nbformat.read(release, as_version=4)
    for cell in nb.cells:
        gid = _grade_id(cell)
        if gid not in answers:
            continue
        stub = CODE_STUB if cell.cell_type == "code" else TEXT_STUB
        lines, out, k = cell.source.split("\n"), [], 0
        for line in lines:
            if line.strip() == stub:
                indent = line[:len(line) - len(line.lstrip())]
                text = answers[gid][k] if answers[gid][k] is not None else solutions[gid][k]
                out.extend(indent + x if x.strip() else x for x in text.rstrip("\n").split("\n"))
                k += 1
            else:
                out.append(line)
        assert k == len(answers[gid]), f"{gid}: {k} stubs in the released cell, {len(answers[gid])} answers"
        cell.source = "\n".join(out)
    target.parent.mkdir(parents=True, exist_ok=True)
    nbformat.write(nb, target)


@pytest.fixture(scope="module")
def course(tmp_path_factory):
    """Run the recipe: set up, generate, (the class hands in), autograde, feedback, export."""
    source_nb = _source_chapter()
    work = tmp_path_factory.mktemp("classroom")
    (work / "notebooks").mkdir()
    nbformat.write(source_nb, work / "notebooks" / CHAPTER.name)
    (work / CONFIG.name).write_bytes(CONFIG.read_bytes())
    env = dict(os.environ, PATH=f"{BIN}{os.pathsep}{os.environ.get('PATH', '')}",
               BAYESFILT_CHECK_TIME_LIMIT="1")
    env.pop("NBGRADER_EXECUTION", None)
    blocks = _recipe()
    assert len(blocks) == 2, "the recipe has two command blocks: before and after collecting"
    logs = {}

    def run(block: str, name: str, extra: dict | None = None, may_fail: tuple = ()):
        proc = subprocess.run([sys.executable, "-c", DRIVER, block, json.dumps(extra or {}),
                               json.dumps(list(may_fail))],
                              cwd=work, env=env, capture_output=True, text=True, timeout=600)
        logs[name] = proc.stdout + proc.stderr
        assert proc.returncode == 0, f"{block}\n{proc.stdout[-3000:]}\n{proc.stderr[-3000:]}"
        return proc

    (work / "course").mkdir()
    (work / "course" / "roster.csv").write_text(_roster(), encoding="utf-8")
    run(blocks[0], "setup")
    root = work / "course"
    release = root / "release" / ASSIGNMENT / CHAPTER.name
    assert release.exists(), "generate_assignment wrote no student version"
    # a student's Run All on the release, while the class is autograded
    student = work / "student"
    student.mkdir()
    (student / CHAPTER.name).write_bytes(release.read_bytes())
    run_all = subprocess.Popen([sys.executable, "-c", RUN_ALL, str(student / CHAPTER.name),
                                str(student), str(ROOT / "tools")], cwd=student, env=env, stdout=subprocess.PIPE,
                               stderr=subprocess.PIPE, text=True)
    solutions = _solutions(source_nb)
    whys = [g for g in solutions if g.endswith("-why")]
    everything = {gid: [None] * len(blocks_) for gid, blocks_ in solutions.items()}
    carol = {f"ch02-ex{n}-answer": answers for n, answers in CAROL.items()}
    carol.update({gid: [CAROL_WHY] for gid in whys})
    classes = {"alice": everything, "bob": {}, "carol": carol}
    for name, answers in classes.items():
        folder = root / "submitted" / name / ASSIGNMENT
        _submit(release, folder / CHAPTER.name, answers, solutions)
        if name in LATE:
            (folder / "timestamp.txt").write_text(LATE[name])
    # a submission in a folder that is no student of the roster, graded after the recipe
    # (in the same process, to save starting nbgrader again): nbgrader must refuse it
    typo = "nbgrader autograde ch02 --student=alcie"
    second = blocks[1] if blocks[1].startswith("cd course") else "cd course\n" + blocks[1]
    grade = run(second + "\ncp -r submitted/alice submitted/alcie\n" + typo, "grade",
                extra={"autograde": [f"--Execute.timeout={CELL_TIMEOUT}"]}, may_fail=(typo,))
    typo = [json.loads(line) for line in grade.stdout.splitlines() if line.startswith('{"command"')]
    out, err = run_all.communicate(timeout=600)
    assert run_all.returncode == 0, err[-3000:]
    return {"root": root, "work": work, "logs": logs, "typo": typo, "whys": whys,
            "run_all": nbformat.read(str(student / CHAPTER.name) + ".ran.ipynb", as_version=4)}


def _check_outputs(nb) -> dict[int, str]:
    out = {}
    for cell in nb.cells:
        m = re.fullmatch(r"ch02-ex(\d+)-check", _grade_id(cell))
        if m:
            out[int(m.group(1))] = _text(cell)
    return out


def _text(cell) -> str:
    return "\n".join(o.get("text", "") + o.get("evalue", "") + "\n".join(o.get("traceback", []))
                     + str(o.get("data", {}).get("text/plain", "")) for o in cell.get("outputs", []))


def test_the_released_notebook_keeps_signatures_and_has_no_solution(course):
    nb = nbformat.read(course["root"] / "release" / ASSIGNMENT / CHAPTER.name, as_version=4)
    text = "\n".join(c.source for c in nb.cells)
    assert "BEGIN SOLUTION" not in text and "np.linalg.solve(S, C @ P).T" not in text
    assert "*Model answer.*" not in text and "*Rubric.*" not in text
    assert "def kalman_gain(P, C, R):" in text and "def correlated_gain(P, C, R, G, D):" in text
    code = "\n".join(c.source for c in nb.cells if c.cell_type == "code")
    assert "raise NotImplementedError" not in code, "the course's stub does not raise"
    checks = [c for c in nb.cells if c.cell_type == "code" and c.metadata.get("nbgrader", {}).get("grade")]
    assert [_grade_id(c) for c in checks] == [f"ch02-ex{n}-check" for n in range(1, 6)]
    assert all(c.outputs == [] for c in nb.cells if c.cell_type == "code"), "outputs are cleared"
    for gid in course["whys"]:
        cell = next(c for c in nb.cells if _grade_id(c) == gid)
        assert cell.source.startswith("**Why?**") and TEXT_STUB in cell.source, cell.source


def test_run_all_on_the_release_goes_to_the_end_and_every_check_is_not_attempted(course):
    """The release as a student opens it in JupyterLab: every cell runs, none fails, and each
    check says "Not attempted yet" (a value still None, a function whose body is the stub)."""
    nb = course["run_all"]
    errors = [(k, _text(c)[-300:]) for k, c in enumerate(nb.cells) if c.cell_type == "code"
              and any(o.output_type == "error" for o in c.outputs)]
    assert not errors, errors
    unrun = [k for k, c in enumerate(nb.cells) if c.cell_type == "code" and c.source.strip()
             and c.execution_count is None]
    assert not unrun, f"cells that did not run: {unrun}"
    says = _check_outputs(nb)
    assert sorted(says) == [1, 2, 3, 4, 5]
    for n, text in says.items():
        assert text.startswith("Not attempted yet"), (n, text[:300])


def test_each_student_gets_the_right_score_per_exercise(course):
    from nbgrader.api import Gradebook

    with Gradebook(f"sqlite:///{course['root'] / 'gradebook.db'}") as gb:
        for student, expected in EXPECTED.items():
            scores = [gb.find_grade(f"ch02-ex{n}-check", CHAPTER.stem, ASSIGNMENT, student).score
                      for n in range(1, 6)]
            assert scores == expected, f"{student}: {scores} != {expected}"
    with open(course["root"] / "grades.csv", newline="") as fh:
        rows = {row["student_id"]: row for row in csv.DictReader(fh)}
    totals = {s: float(row["score"]) for s, row in rows.items()}
    assert totals == {**{s: float(sum(e)) for s, e in EXPECTED.items()}, "dave": 0.0}, totals
    # the maximum counts the points graded by hand too
    assert {float(row["max_score"]) for row in rows.values()} == {5.0 + len(course["whys"])}


def test_the_why_answers_wait_for_manual_grading(course):
    from nbgrader.api import Gradebook

    assert course["whys"], "chapter 02 has a manually graded cell (or the test added one)"
    with Gradebook(f"sqlite:///{course['root'] / 'gradebook.db'}") as gb:
        for gid in course["whys"]:
            for student in ("alice", "carol"):          # answered: a grader must read it
                grade = gb.find_grade(gid, CHAPTER.stem, ASSIGNMENT, student)
                assert grade.needs_manual_grade and grade.auto_score is None, (student, gid)
            blank = gb.find_grade(gid, CHAPTER.stem, ASSIGNMENT, "bob")
            assert not blank.needs_manual_grade and blank.auto_score == 0, "no response: 0"
            assert gb.find_comment(gid, CHAPTER.stem, ASSIGNMENT, "bob").auto_comment == "No response."
        submission = gb.find_submission_notebook(CHAPTER.stem, ASSIGNMENT, "alice")
        assert submission.needs_manual_grade


def test_the_export_shows_names_due_date_and_lateness(course):
    with open(course["root"] / "grades.csv", newline="") as fh:
        rows = {row["student_id"]: row for row in csv.DictReader(fh)}
    roster = list(csv.DictReader(_roster().splitlines()))
    assert set(rows) == {r["id"] for r in roster}, "one line per student of the roster"
    for r in roster:
        assert (rows[r["id"]]["first_name"], rows[r["id"]]["last_name"]) == (r["first_name"],
                                                                              r["last_name"])
    from dateutil.parser import parse

    due = parse(rows["alice"]["duedate"])
    assert rows["alice"]["timestamp"] and parse(rows["alice"]["timestamp"]) > due, "alice is late"
    for on_time in ("bob", "carol"):
        assert rows[on_time]["timestamp"] == "", "no timestamp.txt: not late"
    assert rows["dave"]["timestamp"] == "" and float(rows["dave"]["raw_score"]) == 0.0
    assert float(rows["alice"]["late_submission_penalty"] or 0) == 0.0, "no automatic penalty"
    assert "seconds late" in course["logs"]["grade"], "autograde reports the late submission"


def test_a_misspelt_submission_folder_is_refused(course):
    assert len(course["typo"]) == 1 and course["typo"][0]["status"] != 0, (
        "a folder that is no student id must not become a student")
    assert "No student with ID 'alcie' exists" in course["logs"]["grade"]
    from nbgrader.api import Gradebook

    with Gradebook(f"sqlite:///{course['root'] / 'gradebook.db'}") as gb:
        assert sorted(s.id for s in gb.students) == ["alice", "bob", "carol", "dave"]


def test_the_diagnoses_reach_the_graded_notebooks_and_the_feedback(course):
    root = course["root"]
    graded = {s: nbformat.read(root / "autograded" / s / ASSIGNMENT / CHAPTER.name, as_version=4)
              for s in EXPECTED}
    checks = {s: _check_outputs(nb) for s, nb in graded.items()}
    assert all(text.startswith("Correct") for text in checks["alice"].values()), checks["alice"]
    assert all("Not attempted yet" in text for text in checks["bob"].values()), checks["bob"]
    for n, phrase in CAROL_SAYS.items():        # the checks wrap their messages at 76 columns
        assert phrase in " ".join(checks["carol"][n].split()), (n, checks["carol"][n])
    feedback = (root / "feedback" / "carol" / ASSIGNMENT / f"{CHAPTER.stem}.html").read_text()
    assert "S is computed without R" in feedback
    assert "an endless loop?" in feedback and "ZeroDivisionError" in feedback


def test_a_timed_out_answer_says_so(course):
    """Carol's first answer cell never ends: nbgrader stops it, and the course's message says
    so under the cell, in the graded notebook and the feedback page."""
    root = course["root"]
    nb = nbformat.read(root / "autograded" / "carol" / ASSIGNMENT / CHAPTER.name, as_version=4)
    cell = next(c for c in nb.cells if _grade_id(c) == "ch02-ex1-answer")
    assert "did not finish within nbgrader's" in _text(cell), _text(cell)[-500:]
    feedback = (root / "feedback" / "carol" / ASSIGNMENT / f"{CHAPTER.stem}.html").read_text()
    assert "did not finish within nbgrader" in feedback


def test_no_warning_for_a_correct_answer(course):
    """nbgrader warned once per correct check ("Cell output is Correct: ... cannot be converted to
    a float"): a check cell under nbgrader must leave no execute_result."""
    log = " ".join(course["logs"]["grade"].split())      # nbgrader's message spans lines
    warned = re.findall(r"Cell output is .{0,120}?cannot be converted to a float", log)
    assert not warned, f"{len(warned)} warnings, e.g. {warned[:2]}"
    graded = nbformat.read(course["root"] / "autograded" / "alice" / ASSIGNMENT / CHAPTER.name,
                           as_version=4)
    results = [_grade_id(c) for c in graded.cells if c.cell_type == "code"
               and any(o.output_type == "execute_result" for o in c.outputs) and _grade_id(c)]
    assert not results, f"check cells with an execute_result under nbgrader: {results}"


def test_feedback_has_no_absolute_path(course):
    for page in (course["root"] / "feedback").rglob("*.html"):
        html = page.read_text(encoding="utf-8")
        for path in {str(ROOT), str(course["work"]), sys.prefix, str(Path.home())}:
            assert path not in html, f"{page.name}: the feedback shows the path {path}"
        assert "site-packages" not in html, f"{page.name}: a library frame in the feedback"


def test_the_recipe_commands_are_the_ones_this_test_runs():
    blocks = _recipe()
    commands = [line.split(" #")[0].strip() for block in blocks for line in block.splitlines()
                if line.strip() and not line.strip().startswith("#")]
    for expected in ("cp nbgrader_config.py course/", "nbgrader db student import roster.csv",
                     "nbgrader db assignment add ch02 --duedate=", "nbgrader generate_assignment ch02",
                     "nbgrader autograde ch02", "nbgrader generate_feedback ch02", "nbgrader export"):
        assert any(c.startswith(expected) for c in commands), (expected, commands)
    text = INSTRUCTORS.read_text(encoding="utf-8")
    # the quickstart's header cells, the platforms without a time limit and the manual grading
    assert "quickstart" in text and "IncludeHeaderFooter" in text
    assert "SIGALRM" in text and "Windows" in text
    assert "formgrader" in text.lower() and "Manual Grading" in text
    # the feedback pages load MathJax from a CDN (nbconvert's default): the guide says so
    assert "MathJax from a CDN" in _section()


def test_the_course_config_sets_what_the_guide_says():
    """nbgrader_config.py read as nbgrader reads it: the course id, the stubs that the student
    edition uses too, the roster-only grading and the lateness setting."""
    from traitlets.config.loader import PyFileConfigLoader

    config = PyFileConfigLoader(CONFIG.name, path=str(ROOT)).load_config()
    assert config.CourseDirectory.course_id == "bayesfilt"
    assert config.ClearSolutions.code_stub == {"python": CODE_STUB}
    assert config.ClearSolutions.text_stub == TEXT_STUB
    assert config.Autograde.create_student is False
    assert config.LateSubmissionPlugin.penalty_method == "none"
    assert config.Execute.timeout == 30
    import importlib.util

    spec = importlib.util.spec_from_file_location("_mse", ROOT / "tools" / "make_student_edition.py")
    mse = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mse)
    assert (mse.CODE_STUB, mse.TEXT_STUB) == (CODE_STUB, TEXT_STUB), "one stub for every edition"
    for n in range(1, 9):                                   # a due date for every chapter
        assert f"nbgrader db assignment add ch{n:02d} --duedate=" in CONFIG.read_text()
    assert "nbgrader db student import" in CONFIG.read_text()
