"""The Korean glossary: every term glossed once in the course, and listed.

The course is written in English and gives the source notes' Korean term in
parentheses at its first use in the whole course, e.g. "prediction (예측)"
(CONTRIBUTING.md, "Series conventions"). GLOSSARY.md lists every such term
with the chapter that glosses it; the website shows it as a page. These tests
read the stored notebooks' markdown (the closing "Reading the source notes",
which quotes the sources in Korean, is not glossing) and check that

* each Korean term is glossed once in the course, not once per chapter;
* GLOSSARY.md lists exactly the glossed terms, each with its chapter.
"""

from __future__ import annotations

import json
import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
NOTEBOOKS = sorted((ROOT / "notebooks").glob("[0-9][0-9]_*.ipynb"))
GLOSSARY = ROOT / "GLOSSARY.md"
# a parenthesis holding Hangul; the gloss is its first run of Hangul words
PAREN = re.compile(r"\(([^()]*[\uac00-\ud7a3][^()]*)\)")
HANGUL_RUN = re.compile(r"\d*[\uac00-\ud7a3](?:[\uac00-\ud7a3\d ]*[\uac00-\ud7a3])?")


def course_glosses() -> list[tuple[str, str, int]]:
    """(Korean term, chapter "NN", cell index) for every gloss in the chapters' text."""
    found = []
    for path in NOTEBOOKS:
        cells = json.loads(path.read_text(encoding="utf-8"))["cells"]
        for i, cell in enumerate(cells):
            if cell["cell_type"] != "markdown":
                continue
            text = "".join(cell["source"])
            if text.lstrip().lower().startswith("## reading the source notes"):
                break
            for match in PAREN.finditer(text):
                run = HANGUL_RUN.search(" ".join(match.group(1).split()))
                found.append((run.group(0), path.name[:2], i))
    return found


def glossary_rows() -> dict[str, tuple[str, str]]:
    """Korean term -> (English, chapter) from GLOSSARY.md's table."""
    rows = {}
    for line in GLOSSARY.read_text(encoding="utf-8").splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) == 3 and re.fullmatch(r"\d\d", cells[2]) and HANGUL_RUN.fullmatch(cells[1]):
            assert cells[1] not in rows, f"GLOSSARY.md lists {cells[1]} twice"
            rows[cells[1]] = (cells[0], cells[2])
    return rows


def test_each_korean_term_is_glossed_once_in_the_course():
    seen: dict[str, tuple[str, int]] = {}
    for term, chapter, cell in course_glosses():
        assert term not in seen, (
            f"{term} is glossed twice: chapter {seen[term][0]} cell {seen[term][1]} and chapter "
            f"{chapter} cell {cell}; keep only its first use in the course")
        seen[term] = (chapter, cell)


def test_the_glossary_lists_exactly_the_glossed_terms_with_their_chapter():
    rows = glossary_rows()
    glossed = {term: chapter for term, chapter, _ in course_glosses()}
    assert rows, "GLOSSARY.md has no table rows"
    for term, chapter in glossed.items():
        assert term in rows, f"{term} (chapter {chapter}) is glossed but not in GLOSSARY.md"
        assert rows[term][1] == chapter, (
            f"GLOSSARY.md gives chapter {rows[term][1]} for {term}, but it is glossed in {chapter}")
    for term in rows:
        assert term in glossed, f"GLOSSARY.md lists {term}, which no chapter glosses"
