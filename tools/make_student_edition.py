r"""Make the student edition: every chapter notebook with the exercise solutions taken out.

Usage (from the repository root, in the course environment)::

    python tools/make_student_edition.py student/           # a new or empty folder
    python tools/make_student_edition.py student/ --force   # overwrite the notebooks in it
    python tools/make_student_edition.py --table            # print the table of exercises

Each chapter notebook ``notebooks/NN_*.ipynb`` is written to ``OUTPUT_DIR``
under the same name, changed in three ways only:

* in every *answer cell* the solution between the nbgrader markers
  ``### BEGIN SOLUTION`` and ``### END SOLUTION`` (each alone on its line) is
  replaced by a stub, at the markers' indentation. Markers inside a
  function's body (after its signature and docstring, the layout nbgrader
  needs too) give the body
  ``raise NotImplementedError("Exercise N: write this function")``. Between
  top-level markers, a ``def`` keeps its signature and docstring and gets
  that body, and every other name the solution assigns becomes
  ``name = None  # your answer``, unless the cell already sets it to None
  above the markers.
  The number N comes from a ``# Exercise N`` comment in the cell, else from
  the ``### Exercise N`` heading above it. Code outside the markers stays;
* the outputs and execution counts of the answer cells and of the *check
  cells* (code cells that call ``bf.checks.``) are cleared, so that the
  student sees no "Correct" until the answer is written;
* nothing else: the text, figures and outputs of every other cell are kept
  as they are, and a chapter without exercises is copied unchanged.

A student who runs the whole notebook sees every check say "Not attempted
yet"; once an answer is written, its check says "Correct" or "Not yet" with
a diagnosis (``bayesfilt.checks``).

Between the markers only top-level ``def`` statements and assignments of the
answer names may stand (no imports, prints or intermediate variables); any
other statement, or a malformed pair of markers, stops the tool with an
error naming the notebook and the cell, before anything is written.

The tool never writes into the repository's ``notebooks/`` folder or a
folder inside it (resolved paths are compared, so neither a relative path
nor a symbolic link gets round this, and ``--force`` does not either), and
refuses an existing non-empty folder unless ``--force`` is given. With
``--force`` it overwrites the chapter notebooks it writes and deletes
nothing. The output is deterministic: the same notebooks give byte-identical
files (no timestamps; JSON written by nbformat with sorted keys).

``--table`` prints the exercises of every chapter (number, title, kind,
time, lab or homework), read from the headings, as a markdown table: the
skeleton of the table of exercises in ``INSTRUCTORS.md``.
"""

from __future__ import annotations

import argparse
import ast
import copy
import io
import re
import sys
import tokenize
from pathlib import Path

import nbformat

ROOT = Path(__file__).resolve().parents[1]
NOTEBOOKS = ROOT / "notebooks"
CHAPTER_GLOB = "[0-9][0-9]_*.ipynb"

BEGIN = "### BEGIN SOLUTION"
END = "### END SOLUTION"
# A line that mentions these words but is not exactly a marker is an error: nbgrader, which
# matches whole lines only, would leave it in place, and it is most likely a typo.
MARKER_WORDS = ("BEGIN SOLUTION", "END SOLUTION")
CHECK_CALL = re.compile(r"\bbf\.checks\.")
EXERCISE_COMMENT = re.compile(r"^\s*#\s*Exercise\s+(\d+)\b")
HEADING = re.compile(r"^\s{0,3}(#{1,6})\s+(.*?)\s*#*\s*$")
EXERCISE_HEADING = re.compile(r"^###\s+Exercise\s+(\d+)\b\s*(?:[·:.\-–—]\s*)?(.*?)\s*$")
KIND_LINE = re.compile(r"^\*\s*Kind:\s*(?P<kind>[^·*]+?)\s*·\s*(?P<time>[^·*]+?)\s*·\s*"
                       r"(?P<setting>[^·*]+?)\s*\*\s*$")


class StudentEditionError(ValueError):
    """A notebook the student edition cannot be made from (malformed markers, a bad solution)."""


class RefusedError(ValueError):
    """An output folder the tool will not write into."""


# --- the answer cells --------------------------------------------------------------------


def is_check_cell(cell) -> bool:
    """A code cell whose source calls ``bf.checks.``."""
    return cell.get("cell_type") == "code" and bool(CHECK_CALL.search(cell.get("source", "")))


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
    lines = source.splitlines()
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


def _not_implemented(exercise: int | None) -> str:
    what = f"Exercise {exercise}: write this function" if exercise is not None else "write this function"
    return f'raise NotImplementedError("{what}")'


def _assigned_names(target: ast.expr, line: int) -> list[str]:
    if isinstance(target, ast.Name):
        return [target.id]
    if isinstance(target, (ast.Tuple, ast.List)):
        return [name for elt in target.elts for name in _assigned_names(elt, line)]
    if isinstance(target, ast.Starred):
        return _assigned_names(target.value, line)
    raise StudentEditionError(
        f"line {line} of the solution: only names can be assigned between the markers, "
        f"got {ast.unparse(target)!r}")


def _def_header(code: str, lines: list[str], node: ast.FunctionDef | ast.AsyncFunctionDef) -> str:
    """The decorators and the signature of ``node`` as written, up to and including its colon."""
    first = node.decorator_list[0].lineno if node.decorator_list else node.lineno
    tokens = tokenize.generate_tokens(io.StringIO(code).readline)
    started, depth = False, 0
    for tok in tokens:
        if not started:
            started = tok.type == tokenize.NAME and tok.string == "def" and tok.start[0] >= node.lineno
            continue
        if tok.type == tokenize.OP and tok.string in "([{":
            depth += 1
        elif tok.type == tokenize.OP and tok.string in ")]}":
            depth -= 1
        elif tok.type == tokenize.OP and tok.string == ":" and depth == 0:
            row, col = tok.end
            return "".join(lines[first - 1:row - 1]) + lines[row - 1][:col]
    raise StudentEditionError(f"line {node.lineno} of the solution: cannot read the signature "
                              f"of {node.name}()")  # unreachable for code that parses


def stub(code: str, exercise: int | None = None, skip: set[str] | frozenset = frozenset()) -> str:
    """The student's stub for the (dedented) solution ``code``.

    Each top-level ``def`` keeps its decorators, signature and docstring and
    gets the body ``raise NotImplementedError("Exercise N: write this
    function")``; each other assigned name becomes ``name = None  # your
    answer`` (once, in order of first assignment). A ``return`` (a block
    inside a function body) becomes the ``raise`` line. Comments are dropped.

    Raises
    ------
    StudentEditionError
        Code that does not parse, or a statement other than a ``def``, an
        assignment to names, ``pass`` or ``return``.
    """
    try:
        tree = ast.parse(code)
    except SyntaxError as exc:
        raise StudentEditionError(f"line {exc.lineno} of the solution is not valid Python: "
                                  f"{exc.msg}") from None
    lines = code.splitlines(keepends=True)
    out, seen = [], set(skip)
    for node in tree.body:
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            if node.name in seen:
                continue
            seen.add(node.name)
            header = _def_header(code, lines, node).rstrip()
            def_indent = _indent(lines[node.lineno - 1])
            first = node.body[0]
            header_start = node.decorator_list[0].lineno if node.decorator_list else node.lineno
            prefix = lines[first.lineno - 1][:first.col_offset]
            if first.lineno == header_start + header.count("\n") or prefix.strip():
                body_indent = def_indent + "    "  # the body shares the signature's line
            else:
                body_indent = prefix
            text = header + "\n"
            if (isinstance(first, ast.Expr) and isinstance(first.value, ast.Constant)
                    and isinstance(first.value.value, str)):
                text += body_indent + ast.get_source_segment(code, first) + "\n"
            out.append((True, text + body_indent + _not_implemented(exercise) + "\n"))
        elif isinstance(node, (ast.Assign, ast.AnnAssign, ast.AugAssign)):
            targets = node.targets if isinstance(node, ast.Assign) else [node.target]
            for target in targets:
                for name in _assigned_names(target, node.lineno):
                    if name not in seen:
                        seen.add(name)
                        out.append((False, f"{name} = None  # your answer\n"))
        elif isinstance(node, ast.Return):
            if "return" not in seen:
                seen.add("return")
                out.append((False, _not_implemented(exercise) + "\n"))
        elif isinstance(node, ast.Pass):
            continue
        else:
            kind = type(node).__name__
            raise StudentEditionError(
                f"line {node.lineno} of the solution: only top-level def statements and "
                f"assignments of the answer names may stand between the markers, found "
                f"{kind!r} ({lines[node.lineno - 1].strip()!r}); move it inside a function or "
                f"outside the markers")
    # two blank lines after a function when something follows it, as PEP 8 has it
    return "".join(text + ("\n\n" if is_def and k + 1 < len(out) else "")
                   for k, (is_def, text) in enumerate(out))


def student_source(source: str, exercise: int | None = None) -> str:
    """``source`` with each solution block replaced by its stub (see :func:`stub`).

    The stub keeps the markers' indentation; lines outside the markers are
    kept as they are. A source without markers is returned unchanged.
    """
    blocks = solution_blocks(source)
    if not blocks:
        return source
    lines = source.splitlines(keepends=True)
    out, pos = [], 0
    for begin, end in blocks:
        out.extend(lines[pos:begin])
        indent = _indent(lines[begin])
        body = []
        for k in range(begin + 1, end):
            line = lines[k]
            if not line.strip():
                body.append("\n")
            elif line.startswith(indent):
                body.append(line[len(indent):])
            else:
                raise StudentEditionError(
                    f"line {k + 1}: the solution is indented less than its markers")
        if indent and _inside_def(lines, begin):
            # the markers enclose a function's body: the student writes the body
            code = _not_implemented(exercise) + "\n"
        else:
            try:
                code = stub("".join(body), exercise, skip=_set_to_none(lines[:begin]))
            except StudentEditionError as exc:
                raise StudentEditionError(_shift_line(str(exc), begin + 1)) from None
        if not code and indent:
            code = _not_implemented(exercise) + "\n"  # a function body cannot be empty
        stubbed = [indent + line if line.strip() else line for line in code.splitlines(keepends=True)]
        if end == len(lines) - 1 and not lines[end].endswith("\n") and stubbed:
            stubbed[-1] = stubbed[-1].rstrip("\n")  # the cell ended on the END marker
        out.extend(stubbed)
        pos = end + 1
    out.extend(lines[pos:])
    result = "".join(out)
    # a block that ended the cell and left no stub (its names set to None above): no blank tail
    return result.rstrip("\n") if not source.endswith("\n") else result


def _inside_def(lines: list[str], begin: int) -> bool:
    """Is the (indented) marker at ``lines[begin]`` inside the body of a ``def``?"""
    indent = len(_indent(lines[begin]))
    for line in reversed(lines[:begin]):
        if line.strip() and len(_indent(line)) < indent:
            return bool(re.match(r"\s*(async\s+)?def\s", line))
    return False


def _set_to_none(lines: list[str]) -> set[str]:
    """Names the cell already sets to None (``name = None``) above a solution block."""
    return {m.group(1) for line in lines for m in [re.match(r"^(\w+) = None\b", line)] if m}


def _shift_line(message: str, offset: int) -> str:
    """Turn "line k of the solution" into the line of the cell (the block starts after ``offset``)."""
    return re.sub(r"^line (\d+) of the solution",
                  lambda m: f"line {int(m.group(1)) + offset} (in the solution block)", message)


def exercise_number(cells, index: int) -> int | None:
    """The exercise of the answer cell ``cells[index]``.

    From a ``# Exercise N`` comment in the cell, else from the nearest
    heading above it if that heading is ``### Exercise N``; None otherwise.
    """
    for line in cells[index].get("source", "").splitlines():
        match = EXERCISE_COMMENT.match(line)
        if match:
            return int(match.group(1))
    for cell in reversed(cells[:index]):
        if cell.get("cell_type") != "markdown":
            continue
        headings = [line for line in cell.get("source", "").splitlines() if HEADING.match(line)]
        if headings:
            match = EXERCISE_HEADING.match(headings[-1].strip())
            return int(match.group(1)) if match else None
    return None


def student_notebook(nb, name: str = "notebook"):
    """A student copy of ``nb`` (the input is not changed); ``name`` is used in errors."""
    nb = copy.deepcopy(nb)
    for index, cell in enumerate(nb.cells):
        if cell.get("cell_type") != "code":
            continue
        try:
            blocks = solution_blocks(cell.source)
            if blocks:
                cell.source = student_source(cell.source, exercise_number(nb.cells, index))
        except StudentEditionError as exc:
            cell_id = f", id {cell['id']}" if "id" in cell else ""
            raise StudentEditionError(f"{name}, cell {index + 1}{cell_id}: {exc}") from None
        if blocks or is_check_cell(cell):
            cell.outputs = []
            cell.execution_count = None
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


def make_student_edition(output: Path, force: bool = False, source: Path = NOTEBOOKS) -> list[Path]:
    """Write the student edition of the chapter notebooks of ``source`` into ``output``.

    Every notebook is converted in memory before the first file is written,
    so an error leaves nothing half-made. Returns the written paths.
    """
    out = check_output_dir(output, force, source)
    paths = chapter_notebooks(source)
    if not paths:
        raise StudentEditionError(f"no chapter notebooks {CHAPTER_GLOB} in {str(source)!r}")
    made = [(path.name, student_notebook(nbformat.read(path, as_version=4), path.name))
            for path in paths]
    out.mkdir(parents=True, exist_ok=True)
    written = []
    for name, nb in made:
        target = out / name
        with open(target, "w", encoding="utf-8", newline="\n") as f:
            nbformat.write(nb, f)
        written.append(target)
    return written


# --- the table of exercises ----------------------------------------------------------------


def exercises(nb) -> list[dict]:
    """The exercises of a notebook, from its ``### Exercise N · Title`` headings.

    Each is a dict with ``number``, ``title``, ``kind``, ``time``,
    ``setting`` (lab or homework; the last three from the italic line
    ``*Kind: ... · about 10 min · lab*`` under the heading, None if missing)
    and ``cell`` (the index of the heading's cell).
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
                    "kind": None, "time": None, "setting": None}
            rest = [line.strip() for line in lines[k + 1:] if line.strip()]
            kind = KIND_LINE.match(rest[0]) if rest else None
            if kind:
                info.update(kind=kind.group("kind"), time=kind.group("time"),
                            setting=kind.group("setting"))
            found.append(info)
    return found


def exercise_table(source: Path = NOTEBOOKS) -> str:
    """The exercises of every chapter as a markdown table."""
    rows = ["| chapter | exercise | kind | time | setting |", "| --- | --- | --- | --- | --- |"]
    for path in chapter_notebooks(source):
        found = exercises(nbformat.read(path, as_version=4))
        if not found:
            rows.append(f"| {path.stem} | (no exercises in the pattern yet) | | | |")
        for ex in found:
            rows.append(f"| {path.stem} | {ex['number']} · {ex['title']} | {ex['kind'] or '?'} "
                        f"| {ex['time'] or '?'} | {ex['setting'] or '?'} |")
    return "\n".join(rows)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(
        prog="make_student_edition.py",
        description="Write the student edition of the course: every chapter notebook with the "
                    "exercise solutions replaced by stubs and the check outputs cleared.",
        epilog="Example: python tools/make_student_edition.py student/  (then hand out student/). "
               "The folder must be new or empty unless --force is given; the course's "
               "notebooks/ folder is always refused.")
    parser.add_argument("output", nargs="?", type=Path, metavar="OUTPUT_DIR",
                        help="the folder to write the student notebooks into")
    parser.add_argument("--force", action="store_true",
                        help="write into a non-empty folder, overwriting the notebooks of the "
                             "same name (nothing is deleted)")
    parser.add_argument("--table", action="store_true",
                        help="print the exercises of every chapter as a markdown table and exit")
    args = parser.parse_args(argv)
    if args.table:
        print(exercise_table())
        return 0
    if args.output is None:
        parser.error("OUTPUT_DIR is required (e.g. student/)")
    try:
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
