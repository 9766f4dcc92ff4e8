"""Every chapter follows the course's anatomy (CONTRIBUTING.md, "How a chapter reads").

Measured on the stored notebooks by tools/chapter_metrics.py: the first picture
comes early, the core path fits one lecture and prints at most 8 quiet check
lines, source commentary sits in the closing "Reading the source notes"
section, every chapter has a slider, code lines fit 88 characters, every
display has a blank line before it and every figure its alt text.
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

    def test_a_quiet_core(self, path):
        m = metrics.measure(path)
        assert m["core_check_lines"] <= 8, (
            f"{path.name}: {m['core_check_lines']} check lines printed in the core path (limit 8); group "
            "checks that make one point with bf.verify.together")
        assert m["core_calibration_lines"] == 0, (
            f"{path.name}: {m['core_calibration_lines']} core output lines speak of SE, limits or "
            "tolerances; they belong in 'How the checks were calibrated' (bf.verify.report())")

    def test_code_lines_at_most_88_characters(self, path):
        nb = json.loads(path.read_text(encoding="utf-8"))
        for i, c in enumerate(nb["cells"]):
            if c["cell_type"] == "code":
                for line in "".join(c["source"]).splitlines():
                    assert len(line) <= 88, f"{path.name} cell {i}: a code line of {len(line)} characters"

    def test_a_blank_line_before_every_display(self, path):
        assert metrics.measure(path)["glued_displays"] == 0, (
            f"{path.name}: a $$ display starts right under a line of text (MyST reads it inline)")

    def test_every_figure_has_alt_text(self, path):
        nb = json.loads(path.read_text(encoding="utf-8"))
        for i, c in enumerate(nb["cells"]):
            figure = any("image/png" in out.get("data", {}) for out in c.get("outputs", []))
            alt = c.get("metadata", {}).get("mystnb", {}).get("image", {}).get("alt", "")
            if figure:
                assert len(alt.split()) >= 4 and "/" not in alt.split()[0], (
                    f"{path.name} cell {i}: a figure without alt text (cell metadata "
                    f"mystnb.image.alt: one sentence on what it shows), got {alt!r}")

    def test_chapters_beyond_the_sources_say_so(self, path):
        nb = json.loads(path.read_text(encoding="utf-8"))
        beyond = nb["metadata"].get("bayesfilt", {}).get("beyond_sources", False)
        assert beyond == (int(path.name[:2]) >= 7), (
            f"{path.name}: chapters 07 and later go beyond the source notes (notebook metadata "
            "bayesfilt.beyond_sources), chapters 01-06 follow them")
        if beyond:
            opening = "".join(nb["cells"][0]["source"]).lower()
            assert "beyond the source notes" in opening, f"{path.name}: the opening must say so"

    def test_no_skipped_cells(self, path):
        text = path.read_text(encoding="utf-8")
        assert "NBVAL_SKIP" not in text, f"{path.name}: a skipped cell is not a check; use NBVAL_IGNORE_OUTPUT"
