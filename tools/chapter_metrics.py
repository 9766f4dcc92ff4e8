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
* the notebook's size.
"""

from __future__ import annotations

import json
import re
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
BOX = re.compile(r"^>\s*\*\*(Erratum|Clarification|Notation clash)", re.M)
WIDGET = re.compile(r"\b(interact|interactive|FloatSlider|IntSlider|FloatLogSlider|SelectionSlider)\b")


def words(text: str) -> int:
    return len(text.split())


def measure(path: Path) -> dict:
    nb = json.loads(Path(path).read_text())
    core_words = before_fig = boxes = sliders = 0
    longest_code = longest_md = 0
    seen_fig = summary = opt2 = opt3 = False
    source_notes = False
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
            if not summary and not optional:
                longest_code = max(longest_code, len(src.splitlines()))
            for out in cell.get("outputs", []):
                if "image/png" in out.get("data", {}) or "image/svg+xml" in out.get("data", {}):
                    seen_fig = True
    return dict(core_words=core_words, words_before_first_figure=before_fig, core_source_boxes=boxes,
                source_notes_section=source_notes, slider_cells=sliders, longest_core_code_lines=longest_code,
                longest_core_markdown_words=longest_md, kB=round(Path(path).stat().st_size / 1000))


def main(argv: list[str]) -> int:
    paths = [Path(p) for p in argv] or sorted((ROOT / "notebooks").glob("0*.ipynb"))
    for p in paths:
        m = measure(p)
        print(f"{p.name}: " + ", ".join(f"{k}={v}" for k, v in m.items()))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
