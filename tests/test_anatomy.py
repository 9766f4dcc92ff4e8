"""Every chapter follows the course's anatomy (CONTRIBUTING.md, "How a chapter reads").

Measured on the stored notebooks by tools/chapter_metrics.py: the first picture
comes early, the core path fits one lecture, source commentary sits in the
closing "Reading the source notes" section, and every chapter has a slider.
"""

from __future__ import annotations

import importlib.util
import json
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
NOTEBOOKS = sorted((ROOT / "notebooks").glob("[0-9][0-9]_*.ipynb"))

_spec = importlib.util.spec_from_file_location("chapter_metrics", ROOT / "tools" / "chapter_metrics.py")
metrics = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(metrics)


def _headings(path):
    nb = json.loads(path.read_text(encoding="utf-8"))
    return [line.strip() for c in nb["cells"] if c["cell_type"] == "markdown"
            for line in "".join(c["source"]).splitlines() if line.startswith("## ")]


@pytest.mark.parametrize("path", NOTEBOOKS, ids=lambda p: p.name)
class TestAnatomy:
    def test_a_picture_before_300_words(self, path):
        m = metrics.measure(path)
        assert m["words_before_first_figure"] < 300, (
            f"{path.name}: {m['words_before_first_figure']} words of markdown before the first figure (limit 300)")

    def test_core_path_at_most_3000_words(self, path):
        m = metrics.measure(path)
        assert m["core_words"] <= 3000, f"{path.name}: {m['core_words']} core words (limit 3,000)"

    def test_no_labelled_source_box_in_the_core(self, path):
        m = metrics.measure(path)
        assert m["core_source_boxes"] == 0, (
            f"{path.name}: {m['core_source_boxes']} Erratum/Clarification/Notation-clash boxes in the core path; "
            "they belong in 'Reading the source notes'")

    def test_reading_the_source_notes_closes_the_chapter(self, path):
        headings = _headings(path)
        assert headings and "reading the source notes" in headings[-1].lower(), (
            f"{path.name}: the last section is {headings[-1]!r}, not 'Reading the source notes'")

    def test_order_summary_exercises_optional(self, path):
        headings = [h.lower() for h in _headings(path)]
        summary = next(i for i, h in enumerate(headings) if h.startswith("## summary"))
        assert headings[summary + 1].startswith("## exercises"), f"{path.name}: Exercises must follow the Summary"
        for h in headings[summary + 2:-1]:
            assert "optional" in h, f"{path.name}: {h!r} comes after the exercises but is not marked optional"
        for h in headings[:summary]:
            assert "optional" not in h, f"{path.name}: optional section {h!r} sits before the Summary"

    def test_at_least_one_slider(self, path):
        assert metrics.measure(path)["slider_cells"] >= 1, f"{path.name}: no slider (ipywidgets) cell"

    def test_code_cells_at_most_25_lines(self, path):
        nb = json.loads(path.read_text(encoding="utf-8"))
        for i, c in enumerate(nb["cells"]):
            if c["cell_type"] == "code":
                n = len("".join(c["source"]).splitlines())
                assert n <= 25, f"{path.name} cell {i}: {n} lines of code (limit 25)"

    def test_no_skipped_cells(self, path):
        text = path.read_text(encoding="utf-8")
        assert "NBVAL_SKIP" not in text, f"{path.name}: a skipped cell is not a check; use NBVAL_IGNORE_OUTPUT"
