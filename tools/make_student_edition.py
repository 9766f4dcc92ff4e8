r"""Make the student edition: every chapter notebook with the exercise solutions taken out.

Usage (from the repository root, in the course environment)::

    python tools/make_student_edition.py student/           # a new or empty folder
    python tools/make_student_edition.py student/ --force   # overwrite the notebooks in it
    python tools/make_student_edition.py --table            # print the tables of exercises
    python tools/make_student_edition.py --rubrics          # print the "why?" rubrics
    python tools/make_student_edition.py --update-guide     # rewrite them in INSTRUCTORS.md

Each chapter notebook ``notebooks/NN_*.ipynb`` is written to ``OUTPUT_DIR``
under the same name, changed in three ways only, exactly as nbgrader's
``generate_assignment`` changes it with the course's ``nbgrader_config.py``
(so that the website, this edition and an nbgrader release read alike):

* in every *answer cell* (a code cell with nbgrader's markers) the solution
  between ``### BEGIN SOLUTION`` and ``### END SOLUTION`` (each alone on its
  line), markers included, becomes the one line ``# YOUR CODE HERE`` at the
  markers' indentation (:data:`CODE_STUB`, nbgrader's
  ``ClearSolutions.code_stub``). Everything outside the markers stays: the
  given data, a function's signature and docstring, the line
  ``name = None  # your answer``. A stubbed function therefore returns None and
  a value answer stays None: the checks say "Not attempted yet", and "Run
  All" runs to the end;
* in every *manually graded answer cell* (a markdown cell that nbgrader
  marks as a solution, the "why?" questions) the model answer and the rubric
  between the markers become ``YOUR ANSWER HERE`` (:data:`TEXT_STUB`); the
  question above the markers stays;
* the outputs and execution counts of the answer cells and of the *check
  cells* (code cells that call ``bf.checks.``) are cleared, so that the
  student sees no "Correct" until the answer is written. Nothing else
  changes: the text, figures and outputs of every other cell are kept, and a
  chapter without exercises is copied byte for byte.

Before anything is written, every notebook is checked against the pattern
nbgrader's stub needs (CONTRIBUTING.md, "Exercises"); a notebook that breaks
it stops the tool with an error naming the notebook and the cell:

* markers alone on their line, paired in one cell, not nested, the END at
  the BEGIN's indentation;
* between top-level markers only assignments of answer names, each set to
  None above the markers (``name = None  # your answer``), so that the stub
  leaves every answer defined; a function's signature stays outside them;
* markers inside a function's body only after its docstring, so that the
  stubbed body is not empty (``# YOUR CODE HERE`` alone is no body);
* a markdown answer cell keeps its question above the markers.

The tool never writes into the repository's ``notebooks/`` folder or a
folder inside it (resolved paths are compared, so neither a relative path
nor a symbolic link gets round this, and ``--force`` does not either), and
refuses an existing non-empty folder unless ``--force`` is given. With
``--force`` it overwrites the chapter notebooks it writes and deletes
nothing. The output is deterministic: the same notebooks give byte-identical
files (no timestamps; JSON written by nbformat with sorted keys).

``--table`` prints the exercises of every chapter (number, title, kind,
time, lab or homework, points checked and points graded by hand) and a
summary per chapter, read from the notebooks; ``--rubrics`` prints each
"why?" question with its model answer and rubric. INSTRUCTORS.md holds both
between ``<!-- generated: ... -->`` comments; ``--update-guide`` rewrites
them there, and ``tests/test_student_edition.py`` fails when they differ
from the notebooks.
"""

from __future__ import annotations

import argparse
import ast
import copy
import re
import sys
from pathlib import Path

import nbformat

ROOT = Path(__file__).resolve().parents[1]
NOTEBOOKS = ROOT / "notebooks"
GUIDE = ROOT / "INSTRUCTORS.md"
CHAPTER_GLOB = "[0-9][0-9]_*.ipynb"

BEGIN = "### BEGIN SOLUTION"
END = "### END SOLUTION"
#: What replaces a code solution: nbgrader_config.py's ClearSolutions.code_stub["python"]. It does
#: not raise, so that Run All goes to the end (tests/test_student_edition.py compares the two).
CODE_STUB = "# YOUR CODE HERE"
#: What replaces a written answer: nbgrader_config.py's ClearSolutions.text_stub.
TEXT_STUB = "YOUR ANSWER HERE"
# A line that mentions these words but is not exactly a marker is an error: nbgrader would
# treat it as a marker anyway (it looks for the words anywhere in a line).
MARKER_WORDS = ("BEGIN SOLUTION", "END SOLUTION")
CHECK_CALL = re.compile(r"\bbf\.checks\.")
HEADING = re.compile(r"^\s{0,3}(#{1,6})\s+(.*?)\s*#*\s*$")
EXERCISE_HEADING = re.compile(r"^###\s+Exercise\s+(\d+)\b\s*(?:[·:.\-–—]\s*)?(.*?)\s*$")
KIND_LINE = re.compile(r"^\*\s*Kind:\s*(?P<kind>[^·*]+?)\s*·\s*(?P<time>[^·*]+?)\s*·\s*"
                       r"(?P<setting>[^·*]+?)\s*\*\s*$")
MINUTES = re.compile(r"(\d+)(?:\s*[-–]\s*(\d+))?\s*min")


class StudentEditionError(ValueError):
    """A notebook the student edition cannot be made from (malformed markers, a bad solution)."""


class RefusedError(ValueError):
    """An output folder the tool will not write into."""


# --- the cells ---------------------------------------------------------------------------


def is_check_cell(cell) -> bool:
    """A code cell whose source calls ``bf.checks.``."""
    return cell.get("cell_type") == "code" and bool(CHECK_CALL.search(cell.get("source", "")))


def is_written_answer_cell(cell) -> bool:
    """A manually graded answer cell: markdown that nbgrader marks as a solution."""
    meta = cell.get("metadata", {}).get("nbgrader", {})
    return cell.get("cell_type") == "markdown" and bool(meta.get("solution"))


def solution_blocks(source: str) -> list[tuple[int, int]]:
    """The ``(begin, end)`` line indices (0-based, the marker lines) of the solution blocks.

    Raises
    ------
    StudentEditionError
        A marker that is not alone on its line, a BEGIN inside an open block
        (nested), an END without a BEGIN, a BEGIN without an END, an END at
        another indentation than its BEGIN.
    """
    blocks, start = [], None
    lines = source.split("\n")
    for k, line in enumerate(lines):
        if not any(word in line for word in MARKER_WORDS):
            continue
        marker = line.strip()
        if marker not in (BEGIN, END):
            raise StudentEditionError(
                f"line {k + 1}: a solution marker must stand alone on its line, exactly "
                f"{BEGIN!r} or {END!r} (indentation allowed), got {line.strip()!r}")
        if marker == BEGIN:
            if start is not None:
                raise StudentEditionError(
                    f"line {k + 1}: {BEGIN!r} inside the block opened at line {start + 1} "
                    f"(solution blocks cannot be nested; close the first with {END!r})")
            start = k
        else:
            if start is None:
                raise StudentEditionError(f"line {k + 1}: {END!r} without a {BEGIN!r} before it")
            if _indent(line) != _indent(lines[start]):
                raise StudentEditionError(
                    f"line {k + 1}: {END!r} is indented differently from the {BEGIN!r} of "
                    f"line {start + 1}")
            blocks.append((start, k))
            start = None
    if start is not None:
        raise StudentEditionError(f"line {start + 1}: {BEGIN!r} has no {END!r} after it "
                                  f"in the same cell")
    return blocks


def _indent(line: str) -> str:
    return line[:len(line) - len(line.lstrip())]


def student_source(source: str, stub: str = CODE_STUB) -> str:
    """``source`` with each solution block, markers included, replaced by ``stub``.

    The stub is indented as the BEGIN marker; every other line is kept. This
    is nbgrader's ``ClearSolutions`` rule (the source is split on newlines
    and joined again, so a final newline is kept or not as it was).
    """
    blocks = solution_blocks(source)
    if not blocks:
        return source
    lines = source.split("\n")
    out, pos = [], 0
    for begin, end in blocks:
        out.extend(lines[pos:begin])
        out.extend(_indent(lines[begin]) + line for line in stub.split("\n"))
        pos = end + 1
    out.extend(lines[pos:])
    return "\n".join(out)


def _python(source: str) -> str:
    """A cell's code with IPython's magics and shell escapes blanked (line numbers kept)."""
    return "\n".join("" if line.lstrip().startswith(("%", "!")) else line
                     for line in source.split("\n"))


def check_answer_cell(source: str) -> None:
    """Raise :class:`StudentEditionError` if nbgrader's stub would break this answer cell.

    See the module docstring: top-level blocks assign only answer names, each
    set to None above the markers; a block inside a function comes after its
    docstring; the stubbed cell is valid Python.
    """
    blocks = solution_blocks(source)
    lines = source.split("\n")
    for begin, end in blocks:
        body = "\n".join(line[len(_indent(lines[begin])):] if line.strip() else ""
                         for line in lines[begin + 1:end])
        if any(line.strip() and not line.startswith(_indent(lines[begin]))
               for line in lines[begin + 1:end]):
            raise StudentEditionError(f"line {begin + 2}: the solution is indented less than "
                                      f"its markers")
        if _indent(lines[begin]):
            continue                       # a function's body: judged by the parse below
        try:
            tree = ast.parse(_python(body))
        except SyntaxError as exc:
            raise StudentEditionError(f"line {begin + 1 + (exc.lineno or 0)} (in the solution "
                                      f"block): not valid Python: {exc.msg}") from None
        above = {m.group(1) for line in lines[:begin]
                 for m in [re.match(r"^(\w+)\s*=\s*None\b", line)] if m}
        for node in tree.body:
            where = f"line {begin + 1 + node.lineno} (in the solution block)"
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                raise StudentEditionError(
                    f"{where}: a function's signature and docstring stand outside the markers "
                    f"(the markers enclose its body), or nbgrader's stub removes {node.name}() "
                    f"altogether")
            if not isinstance(node, (ast.Assign, ast.AnnAssign, ast.AugAssign)):
                raise StudentEditionError(
                    f"{where}: only assignments of the answer names may stand between top-level "
                    f"markers, found {type(node).__name__!r} "
                    f"({lines[begin + node.lineno].strip()!r}); move it inside a function or "
                    f"outside the markers")
            targets = node.targets if isinstance(node, ast.Assign) else [node.target]
            for name in (n for t in targets for n in _assigned_names(t, where)):
                if name not in above:
                    raise StudentEditionError(
                        f"{where}: {name} is assigned between the markers but not set to None "
                        f"above them; add the line '{name} = None  # your answer' before "
                        f"{BEGIN!r}, so that the student's stub leaves {name} defined")
    stubbed = student_source(source)
    try:
        ast.parse(_python(stubbed))
    except SyntaxError as exc:
        raise StudentEditionError(
            f"the cell is not valid Python once its solution is replaced by {CODE_STUB!r} "
            f"(line {exc.lineno}: {exc.msg}); a function whose body is a solution needs its "
            f"docstring above the markers, so that the stubbed body is not empty") from None


def _assigned_names(target: ast.expr, where: str) -> list[str]:
    if isinstance(target, ast.Name):
        return [target.id]
    if isinstance(target, (ast.Tuple, ast.List)):
        return [name for elt in target.elts for name in _assigned_names(elt, where)]
    if isinstance(target, ast.Starred):
        return _assigned_names(target.value, where)
    raise StudentEditionError(f"{where}: only names can be assigned between the markers, "
                              f"got {ast.unparse(target)!r}")


def check_written_answer_cell(source: str) -> None:
    """A manually graded (markdown) answer cell: its question above one pair of markers."""
    blocks = solution_blocks(source)
    if not blocks:
        raise StudentEditionError(
            f"a markdown answer cell (nbgrader solution) needs {BEGIN!r} and {END!r} around the "
            f"model answer and the rubric, or nbgrader replaces the whole cell, question "
            f"included, by {TEXT_STUB!r}")
    lines = source.split("\n")
    if not any(line.strip() for line in lines[:blocks[0][0]]):
        raise StudentEditionError("a markdown answer cell states its question above the markers")


def student_notebook(nb, name: str = "notebook"):
    """A student copy of ``nb`` (the input is not changed); ``name`` is used in errors."""
    nb = copy.deepcopy(nb)
    for index, cell in enumerate(nb.cells):
        kind = cell.get("cell_type")
        try:
            if kind == "code":
                blocks = solution_blocks(cell.source)
                if blocks:
                    check_answer_cell(cell.source)
                    cell.source = student_source(cell.source, CODE_STUB)
                if blocks or is_check_cell(cell):
                    cell.outputs = []
                    cell.execution_count = None
            elif is_written_answer_cell(cell):
                check_written_answer_cell(cell.source)
                cell.source = student_source(cell.source, TEXT_STUB)
            elif kind == "markdown" and any(line.strip() in (BEGIN, END)
                                            for line in cell.source.split("\n")):
                raise StudentEditionError(
                    "solution markers in a markdown cell that nbgrader does not mark as a "
                    "solution (metadata nbgrader.solution): they would be shown to students")
        except StudentEditionError as exc:
            cell_id = f", id {cell['id']}" if "id" in cell else ""
            raise StudentEditionError(f"{name}, cell {index + 1}{cell_id}: {exc}") from None
    return nb


# --- the edition ---------------------------------------------------------------------------


def chapter_notebooks(source: Path = NOTEBOOKS) -> list[Path]:
    """The chapter notebooks ``NN_*.ipynb`` of ``source``, in order."""
    return sorted(Path(source).glob(CHAPTER_GLOB))


def check_output_dir(output: Path, force: bool = False, source: Path = NOTEBOOKS) -> Path:
    """The resolved output folder, or :class:`RefusedError` saying why it cannot be used."""
    out = Path(output).expanduser().resolve()
    for protected in {NOTEBOOKS.resolve(), Path(source).resolve()}:
        if out == protected or protected in out.parents:
            raise RefusedError(
                f"refusing to write the student edition into {str(output)!r}, which is (inside) "
                f"the course's notebooks folder {str(protected)!r}: it would overwrite the "
                f"solutions. Choose another folder, e.g. student/")
    if out.exists() and not out.is_dir():
        raise RefusedError(f"{str(output)!r} exists and is not a folder")
    if out.is_dir() and any(out.iterdir()) and not force:
        raise RefusedError(f"the folder {str(output)!r} is not empty; choose a new folder, or "
                           f"give --force to overwrite the notebooks in it")
    return out


def student_notebooks(source: Path = NOTEBOOKS) -> list[tuple[str, nbformat.NotebookNode]]:
    """(file name, student notebook) of every chapter, all converted before any is returned."""
    paths = chapter_notebooks(source)
    if not paths:
        raise StudentEditionError(f"no chapter notebooks {CHAPTER_GLOB} in {str(source)!r}")
    return [(path.name, student_notebook(nbformat.read(path, as_version=4), path.name))
            for path in paths]


def make_student_edition(output: Path, force: bool = False, source: Path = NOTEBOOKS) -> list[Path]:
    """Write the student edition of the chapter notebooks of ``source`` into ``output``.

    Every notebook is converted in memory before the first file is written,
    so an error leaves nothing half-made. Returns the written paths.
    """
    out = check_output_dir(output, force, source)
    made = student_notebooks(source)
    out.mkdir(parents=True, exist_ok=True)
    written = []
    for name, nb in made:
        target = out / name
        with open(target, "w", encoding="utf-8", newline="\n") as f:
            nbformat.write(nb, f)
        written.append(target)
    return written


# --- the tables of exercises and the rubrics -----------------------------------------------


def exercises(nb) -> list[dict]:
    """The exercises of a notebook, from its ``### Exercise N · Title`` headings.

    Each is a dict with ``number``, ``title``, ``kind``, ``time``,
    ``setting`` (lab or homework; the last three from the italic line
    ``*Kind: ... · about 10 min · lab*`` under the heading, None if missing),
    ``cell`` (the index of the heading's cell), ``points`` (of the check
    cells, graded automatically) and ``manual`` (of the markdown answer cells,
    graded by hand), both summed over the cells up to the next exercise or
    ``##`` section, and ``why``: the manually graded cells' indices.
    """
    found = []
    for index, cell in enumerate(nb.cells):
        if cell.get("cell_type") != "markdown":
            continue
        lines = cell.get("source", "").splitlines()
        for k, line in enumerate(lines):
            match = EXERCISE_HEADING.match(line.strip())
            if not match:
                continue
            info = {"number": int(match.group(1)), "title": match.group(2), "cell": index,
                    "kind": None, "time": None, "setting": None, "points": 0.0, "manual": 0.0,
                    "why": []}
            rest = [line.strip() for line in lines[k + 1:] if line.strip()]
            kind = KIND_LINE.match(rest[0]) if rest else None
            if kind:
                info.update(kind=kind.group("kind"), time=kind.group("time"),
                            setting=kind.group("setting"))
            found.append(info)
    for ex, nxt in zip(found, found[1:] + [None]):
        stop = nxt["cell"] if nxt else len(nb.cells)
        for index in range(ex["cell"] + 1, stop):
            cell = nb.cells[index]
            if cell.get("cell_type") == "markdown" and not is_written_answer_cell(cell) and any(
                    re.match(r"^##\s", line) for line in cell.get("source", "").splitlines()):
                break                                        # the next section
            meta = cell.get("metadata", {}).get("nbgrader", {})
            if meta.get("grade"):
                points = float(meta.get("points", 0))
                if is_written_answer_cell(cell):
                    ex["manual"] += points
                    ex["why"].append(index)
                else:
                    ex["points"] += points
    return found


def _points(value: float) -> str:
    return f"{value:g}"


def _minutes(times: list[str]) -> str:
    low = high = 0
    for time in times:
        match = MINUTES.search(time or "")
        if match:
            low += int(match.group(1))
            high += int(match.group(2) or match.group(1))
    return f"about {low} min" if low == high else f"about {low}-{high} min"


def exercise_table(source: Path = NOTEBOOKS) -> str:
    """The exercises of every chapter as a markdown table, then a summary per chapter."""
    rows = ["| chapter | exercise | kind | time | setting | points |",
            "| --- | --- | --- | --- | --- | --- |"]
    summary = ["| chapter | exercises | lab | homework | points |",
               "| --- | --- | --- | --- | --- |"]
    for path in chapter_notebooks(source):
        found = exercises(nbformat.read(path, as_version=4))
        link = f"[{path.name[:2]}](notebooks/{path.name})"
        if not found:
            rows.append(f"| {link} | (no exercises yet) | | | | |")
            summary.append(f"| {link} | 0 | | | |")
            continue
        for ex in found:
            title = ex["title"].replace("|", "\\|")
            points = _points(ex["points"]) + (f" + {_points(ex['manual'])} by hand"
                                              if ex["manual"] else "")
            rows.append(f"| {link} | {ex['number']} · {title} | {ex['kind'] or '?'} "
                        f"| {ex['time'] or '?'} | {ex['setting'] or '?'} | {points} |")
        parts = []
        for setting in ("lab", "homework"):
            these = [ex for ex in found if ex["setting"] == setting]
            parts.append(f"{len(these)}, {_minutes([ex['time'] for ex in these])}" if these else "0")
        auto = sum(ex["points"] for ex in found)
        manual = sum(ex["manual"] for ex in found)
        total = _points(auto) + (f" + {_points(manual)} by hand" if manual else "")
        summary.append(f"| [{path.stem}](notebooks/{path.name}) | {len(found)} | {parts[0]} "
                       f"| {parts[1]} | {total} |")
    return "\n".join(rows) + "\n\nPer chapter:\n\n" + "\n".join(summary)


def rubrics(source: Path = NOTEBOOKS) -> str:
    """Every manually graded "why?" question with its model answer and rubric, as markdown."""
    parts = []
    for path in chapter_notebooks(source):
        nb = nbformat.read(path, as_version=4)
        for ex in exercises(nb):
            for index in ex["why"]:
                cell = nb.cells[index]
                lines = cell.source.split("\n")
                blocks = solution_blocks(cell.source)
                if not blocks:
                    continue
                begin, end = blocks[0]
                question = " ".join(line.strip() for line in lines[:begin] if line.strip())
                answer = "\n".join(lines[begin + 1:end]).strip()
                gid = cell.metadata.get("nbgrader", {}).get("grade_id", "?")
                points = _points(float(cell.metadata.get("nbgrader", {}).get("points", 0)))
                parts.append(f"**{path.name[:2]} · exercise {ex['number']}** (`{gid}`, "
                             f"{points} point{'s' * (points != '1')}). {question}\n\n"
                             + "\n".join("> " + line if line.strip() else ">"
                                         for line in answer.split("\n")))
    return "\n\n".join(parts) if parts else "(No manually graded question in the notebooks yet.)"


GENERATED = {"exercises": exercise_table, "rubrics": rubrics}


def _region(name: str) -> re.Pattern:
    return re.compile(rf"(<!-- generated: {name} [^>]*-->\n)(.*?)(<!-- end generated: {name} -->)",
                      re.S)


def generated_regions(text: str) -> dict[str, str]:
    """The generated regions of INSTRUCTORS.md's text, by name (missing ones left out)."""
    found = {}
    for name in GENERATED:
        match = _region(name).search(text)
        if match:
            found[name] = match.group(2).removesuffix("\n")
    return found


def updated_guide(text: str, source: Path = NOTEBOOKS) -> str:
    """INSTRUCTORS.md's text with every generated region made again from the notebooks."""
    for name, make in GENERATED.items():
        pattern = _region(name)
        if not pattern.search(text):
            raise StudentEditionError(f"INSTRUCTORS.md has no region '<!-- generated: {name} ... "
                                      f"-->' ... '<!-- end generated: {name} -->'")
        content = make(source)
        text = pattern.sub(lambda m: m.group(1) + content + "\n" + m.group(3), text, count=1)
    return text


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(
        prog="make_student_edition.py",
        description="Write the student edition of the course: every chapter notebook with the "
                    "exercise solutions replaced by nbgrader's stubs and the check outputs cleared.",
        epilog="Example: python tools/make_student_edition.py student/  (then hand out student/). "
               "The folder must be new or empty unless --force is given; the course's "
               "notebooks/ folder is always refused.")
    parser.add_argument("output", nargs="?", type=Path, metavar="OUTPUT_DIR",
                        help="the folder to write the student notebooks into")
    parser.add_argument("--force", action="store_true",
                        help="write into a non-empty folder, overwriting the notebooks of the "
                             "same name (nothing is deleted)")
    parser.add_argument("--table", action="store_true",
                        help="print the exercises of every chapter as markdown tables and exit")
    parser.add_argument("--rubrics", action="store_true",
                        help="print the manually graded questions with their rubrics and exit")
    parser.add_argument("--update-guide", action="store_true",
                        help="rewrite the generated tables and rubrics of INSTRUCTORS.md and exit")
    args = parser.parse_args(argv)
    try:
        if args.table or args.rubrics:
            print("\n\n".join(make() for name, make in GENERATED.items()
                              if getattr(args, {"exercises": "table"}.get(name, name))))
            return 0
        if args.update_guide:
            text = GUIDE.read_text(encoding="utf-8")
            new = updated_guide(text)
            if new != text:
                GUIDE.write_text(new, encoding="utf-8")
            print(f"{GUIDE.name}: {'updated' if new != text else 'already up to date'}")
            return 0
        if args.output is None:
            parser.error("OUTPUT_DIR is required (e.g. student/)")
        written = make_student_edition(args.output, force=args.force)
    except RefusedError as exc:
        print(f"make_student_edition.py: error: {exc}", file=sys.stderr)
        return 2
    except StudentEditionError as exc:
        print(f"make_student_edition.py: error: {exc}", file=sys.stderr)
        return 1
    for path in written:
        count = len(exercises(nbformat.read(path, as_version=4)))
        print(f"{path.name}: {count} exercise{'s' * (count != 1)}"
              + (" (copied unchanged)" if not count else ""))
    print(f"student edition written to {args.output}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
