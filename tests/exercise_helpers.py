"""Helpers shared by the exercise tests (tests/test_exercises_chNN.py, test_exercise_checks.py).

Each asserts one of the three answers a check gives, on a ``Feedback``:
``correct``, ``wrong`` (with phrases its message must contain) and
``not_attempted``; ``never_raises`` feeds a check garbage; ``hides`` asserts
that a message does not show the reference. ``not_implemented`` and
``fails_oddly`` are student functions that are unwritten or fail with an
exception that cannot even be printed.
"""

from __future__ import annotations

import numpy as np

from bayesfilt.checks import CORRECT, INCORRECT, NOT_ATTEMPTED, Feedback


def correct(fb) -> None:
    assert isinstance(fb, Feedback), fb
    assert fb.status == CORRECT, fb.message
    assert repr(fb).startswith("Correct"), repr(fb)


def wrong(fb, *phrases: str) -> None:
    assert isinstance(fb, Feedback), fb
    assert fb.status == INCORRECT and not fb.correct, fb
    for phrase in phrases:
        assert phrase in fb.message, (phrase, fb.message)
    assert repr(fb).startswith("Not yet: "), repr(fb)


def not_attempted(fb) -> None:
    assert isinstance(fb, Feedback), fb
    assert fb.status == NOT_ATTEMPTED, fb
    assert repr(fb).startswith("Not attempted yet: "), repr(fb)


def never_raises(check, answers, unpack: bool = False) -> None:
    """Each answer (a tuple of answers with ``unpack``) gives "not yet" or "not attempted"."""
    for answer in answers:
        fb = check(*answer) if unpack and isinstance(answer, tuple) else check(answer)
        assert isinstance(fb, Feedback) and fb.status in (INCORRECT, NOT_ATTEMPTED), (answer, fb)


def hides(fb, *expected, digits: int = 4, min_digits: int = 1, integers: bool = True) -> None:
    """The message does not show the reference: no entry of ``expected`` written to ``digits``
    significant digits, among those with at least ``min_digits`` digits (a short number such as
    4 is found in any text), whole numbers included only with ``integers``."""
    for v in np.concatenate([np.ravel(e) for e in expected]):
        text = f"{v:.{digits}g}"
        if abs(v) > 1e-12 and sum(ch.isdigit() for ch in text) >= min_digits and (integers or v != round(v)):
            assert text not in fb.message, (v, fb.message)


def not_implemented(*args):
    raise NotImplementedError("Exercise: write this function")


class Odd(Exception):
    def __str__(self):
        raise RuntimeError("no text")


def fails_oddly(*args):
    raise Odd()


def solution_names(source: str) -> set[str]:
    """The answer names of an answer cell: the functions whose body stands between nbgrader's
    markers, and the names that top-level markers define (defs and assignments only there).

    Works for both layouts: markers inside a def's body (the signature and docstring outside),
    and a def between top-level markers.
    """
    import ast

    lines = source.splitlines()
    begins = [k + 1 for k, line in enumerate(lines) if line.strip() == "### BEGIN SOLUTION"]
    ends = [k + 1 for k, line in enumerate(lines) if line.strip() == "### END SOLUTION"]
    assert len(begins) == len(ends) >= 1, "markers pair up"
    tree = ast.parse(source)
    names = set()
    for begin, end in zip(begins, ends):
        assert begin < end, "BEGIN before END"
        if lines[begin - 1] != lines[begin - 1].lstrip():          # inside a body
            before = [n for n in tree.body if n.lineno < begin]      # the statement they are in
            assert before and isinstance(before[-1], ast.FunctionDef) and \
                before[-1].end_lineno >= begin, f"indented markers at line {begin} are not in a def"
            names.add(before[-1].name)
            continue
        for node in tree.body:
            if begin < node.lineno < end:
                assert isinstance(node, (ast.FunctionDef, ast.Assign)), ast.dump(node)[:80]
                if isinstance(node, ast.FunctionDef):
                    names.add(node.name)
                else:
                    names.update(t.id for t in node.targets)
    return names
