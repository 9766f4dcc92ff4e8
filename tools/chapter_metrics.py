"""Measure a chapter against the course's anatomy (CONTRIBUTING.md, "How a chapter reads").

Usage (from the repository root)::

    python tools/chapter_metrics.py                       # every chapter
    python tools/chapter_metrics.py notebooks/02_*.ipynb  # some

For each stored notebook it prints:

* core words: words of markdown in the core path, i.e. in the sections that are
  not marked *(optional)* (a ``##`` heading containing "optional", and every
  ``###`` under it; a ``###`` marked optional inside a core section still
  counts, since optional material belongs after the exercises), before ``## Summary``;
* words before the first figure: markdown words, the title cell included,
  before the first cell whose output is an image;
* labelled source boxes in the core: blockquotes starting with **Erratum**,
  **Clarification** or **Notation clash** in the core path;
* whether a "Reading the source notes" section exists;
* sliders: code cells that build an ipywidgets control;
* the longest code cell (lines) and the longest markdown cell (words) in the core;
* check lines in the core: printed lines that report a passed check, i.e. that
  start with ``✓`` (``bf.verify``'s quiet line) or carry a tolerance or a
  standard error;
* calibration lines in the core: printed lines that speak of standard errors,
  limits or tolerances (``SE``, ``limit``, ``max |...|``, ``< 1e-12``); they
  belong in the optional "How the checks were calibrated";
* the longest code line (characters), over every code cell of the notebook;
* display equations glued to text: a ``$$`` that opens a display on the line
  right after a line of text (MyST reads it as inline maths, so the website
  breaks it; a blank line before the ``$$`` fixes it);
* the notebook's size.
"""

from __future__ import annotations

import json
import re
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
BOX = re.compile(r"^>\s*\*\*(Erratum|Clarification|Notation clash)", re.M)
CALIBRATION = re.compile(r"\bSE\b|\blimit\b|max \||standard error|<\s*1e-?\d+|<\s*10\^")
WIDGET = re.compile(r"\b(interact|interactive|FloatSlider|IntSlider|FloatLogSlider|SelectionSlider)\b")


def words(text: str) -> int:
    return len(text.split())


def _printed_lines(cell: dict) -> list[str]:
    """The text a code cell printed (stdout), line by line."""
    lines = []
    for out in cell.get("outputs", []):
        if out.get("output_type") == "stream" and out.get("name") == "stdout":
            text = out["text"]
            lines += ("".join(text) if isinstance(text, list) else text).splitlines()
    return lines


def glued_displays(src: str) -> int:
    """How many ``$$`` displays open on the line right after a line of text."""
    count, previous, inside = 0, "", False
    for line in src.splitlines():
        bare = line.lstrip().lstrip(">").strip()
        if bare.startswith("$$") or (inside and bare.endswith("$$")):
            if not inside and previous:
                count += 1                 # an opening $$ right under text
            closes_itself = len(bare) > 2 and bare.endswith("$$") and bare != "$$"
            inside = not inside and not closes_itself
        previous = bare
    return count


def measure(path: Path) -> dict:
    nb = json.loads(Path(path).read_text())
    core_words = before_fig = boxes = sliders = 0
    longest_code = longest_md = 0
    seen_fig = summary = opt2 = opt3 = False
    source_notes = False
    check_lines = calibration_lines = longest_line = glued = 0
    for cell in nb["cells"]:
        src = "".join(cell["source"])
        if cell["cell_type"] == "markdown":
            for line in src.splitlines():
                if line.startswith("## "):
                    opt2, opt3 = "optional" in line.lower(), False
                    if line.lower().startswith("## summary"):
                        summary = True
                    if "reading the source notes" in line.lower():
                        source_notes = True
            optional = opt2 or opt3
            n = words(src)
            glued += glued_displays(src)
            if not seen_fig:
                before_fig += n
            if not summary and not optional:
                core_words += n
                boxes += len(BOX.findall(src))
                longest_md = max(longest_md, n)
        else:
            optional = opt2 or opt3
            if WIDGET.search(src):
                sliders += 1
            longest_line = max([longest_line] + [len(line) for line in src.splitlines()])
            if not summary and not optional:
                longest_code = max(longest_code, len(src.splitlines()))
                for line in _printed_lines(cell):
                    calibration = bool(CALIBRATION.search(line))
                    check_lines += line.lstrip().startswith("\u2713") or calibration
                    calibration_lines += calibration
            for out in cell.get("outputs", []):
                if "image/png" in out.get("data", {}) or "image/svg+xml" in out.get("data", {}):
                    seen_fig = True
    return dict(core_words=core_words, words_before_first_figure=before_fig, core_source_boxes=boxes,
                source_notes_section=source_notes, slider_cells=sliders, longest_core_code_lines=longest_code,
                longest_core_markdown_words=longest_md, core_check_lines=check_lines,
                core_calibration_lines=calibration_lines, longest_code_line=longest_line,
                glued_displays=glued, kB=round(Path(path).stat().st_size / 1000))


def main(argv: list[str]) -> int:
    paths = [Path(p) for p in argv] or sorted((ROOT / "notebooks").glob("[0-9][0-9]_*.ipynb"))
    for p in paths:
        m = measure(p)
        print(f"{p.name}: " + ", ".join(f"{k}={v}" for k, v in m.items()))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
