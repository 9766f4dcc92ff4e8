"""Hygiene of the stored notebooks (their outputs are checked by nbval separately).

The stored notebooks are what a reader sees on the repository, so they must
be the product of one clean, top-to-bottom run with the course's own code.
"""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
NOTEBOOKS = sorted((ROOT / "notebooks").glob("[0-9][0-9]_*.ipynb"))
MAX_BYTES = 1_000_000

# Absolute paths of any machine: POSIX home/work/temp folders and Windows drives.
ABSOLUTE_PATH = re.compile(r"(/home/|/Users/|/root/|/work/|/tmp/|/private/var/|\b[A-Za-z]:\\\\(Users|Documents|Windows|Program Files)\b)")
LEGACY_RANDOM = re.compile(r"np\.random\.(seed|rand|randn|randint|normal|uniform|choice|random|"
                           r"multivariate_normal|shuffle|permutation)\(|default_rng\(\s*\)")
# nbval honours a marker only when it is alone on its comment line, so the
# reason goes on the next comment line.
NBVAL_MARKERS = {"NBVAL_IGNORE_OUTPUT", "NBVAL_SKIP", "NBVAL_RAISES_EXCEPTION", "NBVAL_CHECK_OUTPUT"}


def _load(path: Path) -> dict:
    return json.loads(path.read_text(encoding="utf-8"))


def _code_cells(nb: dict) -> list[dict]:
    return [c for c in nb["cells"] if c["cell_type"] == "code"]


def _text(value) -> str:
    return "".join(value) if isinstance(value, list) else str(value)


def test_there_are_notebooks():
    assert NOTEBOOKS, "no notebooks found in notebooks/"


def test_notebooks_are_numbered_consecutively():
    numbers = [int(p.name[:2]) for p in NOTEBOOKS]
    assert numbers == list(range(1, len(numbers) + 1)), numbers


@pytest.mark.parametrize("path", NOTEBOOKS, ids=lambda p: p.name)
class TestNotebookHygiene:
    def test_executed_in_order(self, path):
        counts = [c.get("execution_count") for c in _code_cells(_load(path))]
        assert counts == list(range(1, len(counts) + 1)), (
            f"{path.name}: execution counts {counts}; re-run with tools/run_notebooks.py")

    def test_no_errors_or_stderr(self, path):
        for i, cell in enumerate(_code_cells(_load(path))):
            for out in cell.get("outputs", []):
                assert out["output_type"] != "error", f"{path.name} code cell {i}: error output"
                if out["output_type"] == "stream":
                    assert out["name"] != "stderr", (
                        f"{path.name} code cell {i} wrote to stderr: {_text(out['text'])[:200]}")

    def test_no_absolute_paths(self, path):
        text = path.read_text(encoding="utf-8")
        match = ABSOLUTE_PATH.search(text)
        assert match is None, f"{path.name} contains an absolute path near {text[match.start():match.start() + 60]!r}"
        assert "shared/seeds" not in text, f"{path.name} refers to the seed folder, which learners do not have"

    def test_python3_kernel(self, path):
        assert _load(path)["metadata"]["kernelspec"]["name"] == "python3"

    def test_imports_bayesfilt_and_filterpy(self, path):
        source = "\n".join(_text(c["source"]) for c in _code_cells(_load(path)))
        assert re.search(r"^import bayesfilt as bf", source, re.M), f"{path.name} does not import bayesfilt"
        assert "filterpy" in source, f"{path.name} has no filterpy cross-check"

    def test_size(self, path):
        size = path.stat().st_size
        assert size < MAX_BYTES, f"{path.name} is {size} bytes (limit {MAX_BYTES})"

    def test_seeded_randomness_only(self, path):
        for i, cell in enumerate(_code_cells(_load(path))):
            match = LEGACY_RANDOM.search(_text(cell["source"]))
            assert match is None, (f"{path.name} code cell {i} uses {match.group(0)!r}; draw from "
                                   "np.random.default_rng(<seed>) instead")

    def test_nbval_markers_work_and_give_a_reason(self, path):
        for i, cell in enumerate(_code_cells(_load(path))):
            lines = [line.strip() for line in _text(cell["source"]).splitlines()]
            tags = [t for t in cell.get("metadata", {}).get("tags", []) if t.startswith("nbval")]
            for k, line in enumerate(lines):
                comment = line.lstrip("#").strip()
                if not (line.startswith("#") and comment.startswith("NBVAL")):
                    continue
                assert comment in NBVAL_MARKERS, (
                    f"{path.name} code cell {i}: {line!r} is not a marker nbval recognises "
                    "(it must be alone on its line; put the reason on the next comment line)")
                following = lines[k + 1] if k + 1 < len(lines) else ""
                assert following.startswith("#") and len(following.lstrip("#").strip()) >= 10, (
                    f"{path.name} code cell {i}: {comment} must be followed by a comment line "
                    "that says why the output cannot be compared")
            if tags:
                reasons = [line for line in lines if line.startswith("#") and len(line) > 12]
                assert reasons, f"{path.name} code cell {i}: tags {tags} need a comment saying why"

    def test_has_objectives_summary_and_exercises(self, path):
        headings = [line.strip().lstrip("#").strip().lower()
                    for c in _load(path)["cells"] if c["cell_type"] == "markdown"
                    for line in _text(c["source"]).splitlines() if line.startswith("#")]
        assert any("objective" in h for h in headings), f"{path.name}: no learning objectives"
        assert any("summary" in h for h in headings), f"{path.name}: no summary"
        assert any("exercise" in h for h in headings), f"{path.name}: no exercises section"
