"""Tests of ``bayesfilt.checks``, the generic feedback of the exercises.

Each comparison must accept the right answer (also within its tolerance),
reject the plausible wrong ones with the diagnosis a tutor would give
(transposed, wrong shape with the expected one, wrong sign, a constant
factor, an unnormalised belief, a non-symmetric covariance, a function that
fails on a named input or forgets ``return``), say "not attempted yet" for
``None`` and ``NotImplementedError``, never raise on garbage, and never give
the reference away: the references below have distinctive digits
(0.123456, 0.654321, ...) that no message may contain.
"""

from __future__ import annotations

import numpy as np
import pytest

import bayesfilt as bf
from bayesfilt.checks import (CORRECT, INCORRECT, NOT_ATTEMPTED, Feedback, compare_array,
                              compare_choice, compare_function, compare_number)

# Distinctive references: their digits must never appear in a message.
E = np.array([[0.123456, 0.654321], [0.222222, 0.987654]])   # not symmetric
WIDE = np.array([[0.123456, 0.654321, 0.345678], [0.222222, 0.987654, 0.456789]])
COV = np.array([[2.123456, 0.345678], [0.345678, 1.654321]])  # symmetric positive definite
BELIEF = np.array([0.123456, 0.345678, 0.530866])               # sums to 1
SECRETS = ("0.1234", "0.6543", "0.2222", "0.9876", "0.3456", "0.4567", "2.1234", "1.6543",
           "0.5308", "0.123", "0.654", "0.988", "0.346", "0.531", "2.12", "1.65")


def assert_no_secret(fb: Feedback) -> None:
    for digits in SECRETS:
        assert digits not in fb.message, f"the message gives the reference away: {fb.message!r}"


def assert_wrong(fb: Feedback, *phrases: str) -> None:
    assert isinstance(fb, Feedback)
    assert fb.status == INCORRECT and not fb.correct, fb
    for phrase in phrases:
        assert phrase in fb.message, f"{phrase!r} not in {fb.message!r}"
    assert_no_secret(fb)


class Garbage:
    """An object numpy cannot even look at."""

    def __array__(self, *args, **kwargs):
        raise RuntimeError("no array here")

    def __float__(self):
        raise RuntimeError("no float here")


GARBAGE = ["abc", {"a": 1}, [[1.0, 2.0], [3.0]], object(), lambda x: x, [None, 1.0], Garbage(),
           np.array([np.nan, 1.0]), np.array([1 + 2j, 1.0]), np.array([True, False]), b"\x00",
           10 ** 400, float("inf"), [], set(), np.array("0.5")]


# --- compare_array -------------------------------------------------------------------------

def test_array_right_answer_is_accepted_within_the_tolerance():
    assert compare_array(E.copy(), E).status == CORRECT
    assert compare_array((E * (1 + 1e-9)).tolist(), E, what="K").status == CORRECT
    assert compare_array(np.array([[1, 2], [3, 4]]), [[1.0, 2.0], [3.0, 4.0]]).correct
    fb = compare_array(E + 1e-3, E, rtol=1e-2)
    assert fb.correct and "matches" in fb.message


def test_array_transposed_is_diagnosed_with_the_expected_shape():
    assert_wrong(compare_array(WIDE.T, WIDE, what="the gain K"),
                 "the gain K", "transposed", "expected shape (2, 3)", "got (3, 2)")
    assert_wrong(compare_array(E.T, E, what="P"), "P is transposed")


def test_array_wrong_shape_names_the_expected_one():
    assert_wrong(compare_array(np.ones(3), E, what="K"), "wrong shape", "expected (2, 2)", "got (3,)")
    assert_wrong(compare_array(0.5, E), "wrong shape", "expected (2, 2)", "got ()")
    assert_wrong(compare_array(E.ravel(), E), "right numbers in the wrong shape",
                 "expected shape (2, 2)", "got (4,)", "reshape")
    assert_wrong(compare_array(BELIEF[:, None], BELIEF), "reshape", "expected shape (3,)")


def test_array_wrong_sign_is_diagnosed():
    assert_wrong(compare_array(-E, E, what="the innovation"), "the innovation", "wrong sign")


def test_array_constant_factor_is_diagnosed():
    assert_wrong(compare_array(2 * E, E), "constant factor")
    assert_wrong(compare_array(E / (2 * np.pi), E), "constant factor")
    assert_wrong(compare_array(0.37 * COV, COV), "constant factor")


def test_one_nonzero_entry_is_not_called_a_constant_factor():
    """With one nonzero reference entry, every wrong value is "a factor" of it: say so only
    for a simple factor."""
    fb = compare_array([0.0, 0.7, 0.0], [0.0, 0.123456, 0.0])
    assert_wrong(fb, "1 of 3 entries differ", "index (1,)")
    assert "factor" not in fb.message
    assert "factor" not in compare_array([0.7], [0.123456]).message
    assert_wrong(compare_array([0.0, 2 * 0.123456, 0.0], [0.0, 0.123456, 0.0]), "constant factor")


def test_array_unnormalised_probability_vector_is_diagnosed():
    assert_wrong(compare_array(3 * BELIEF, BELIEF, what="bel", probability=True),
                 "bel is not normalised", "sum to 3", "normalising constant")
    assert_wrong(compare_array([0.3, 0.3, 0.3], BELIEF, probability=True),
                 "probability vector", "sum to 0.9")
    assert_wrong(compare_array([-0.1, 0.4, 0.7], BELIEF, probability=True), "negative")
    # without probability=True a factor is a factor
    assert_wrong(compare_array(3 * BELIEF, BELIEF), "constant factor")


def test_array_non_symmetric_covariance_is_diagnosed():
    wrong = COV + np.array([[0.0, 0.1], [0.0, 0.0]])
    assert_wrong(compare_array(wrong, COV, what="P"), "P is not symmetric", "a covariance (or a precision) is",
                 "max |A - A^T| = 0.1")


def test_array_other_differences_name_how_many_and_where():
    wrong = E.copy()
    wrong[1, 0] = 5.0
    assert_wrong(compare_array(wrong, E), "right shape", "1 of 4 entries differ", "index (1, 0)")


def test_array_none_and_ellipsis_are_not_attempted():
    for blank in (None, ...):
        fb = compare_array(blank, E, what="answer_1")
        assert fb.status == NOT_ATTEMPTED and "answer_1" in fb.message and not fb.correct


@pytest.mark.parametrize("garbage", GARBAGE, ids=lambda g: type(g).__name__)
def test_array_garbage_is_feedback_not_an_exception(garbage):
    fb = compare_array(garbage, E, what="K")
    assert fb.status == INCORRECT and "K" in fb.message
    assert_no_secret(fb)


# --- compare_number ------------------------------------------------------------------------

def test_number_right_answer_is_accepted():
    for right in (0.123456, np.float32(0.123456), np.array(0.123456), np.array([0.123456]), 0.1234560001):
        assert compare_number(right, 0.123456, rtol=1e-6).status == CORRECT, right
    assert compare_number(3, 3.0).correct


def test_number_wrong_answers_are_diagnosed():
    assert_wrong(compare_number(-0.123456, 0.123456, what="the evidence"), "the evidence", "wrong sign")
    assert_wrong(compare_number(2 * 0.123456, 0.123456), "simple factor")
    assert_wrong(compare_number(0.123456 / (2 * np.pi), 0.123456), "simple factor")
    assert_wrong(compare_number(0.2, 0.123456), "too large")
    assert_wrong(compare_number(0.1, 0.123456), "too small")
    fb = compare_number(-0.5, 0.123456)
    assert_wrong(fb, "too small")
    assert "factor" not in fb.message


def test_number_none_is_not_attempted():
    assert compare_number(None, 0.123456).status == NOT_ATTEMPTED
    assert compare_number(..., 0.123456).status == NOT_ATTEMPTED


@pytest.mark.parametrize("garbage", GARBAGE + [True, np.bool_(False), [0.5], np.array([0.1, 0.2])],
                         ids=lambda g: type(g).__name__)
def test_number_garbage_is_feedback_not_an_exception(garbage):
    fb = compare_number(garbage, 0.123456, what="x")
    assert fb.status == INCORRECT and "x" in fb.message
    assert_no_secret(fb)


def test_number_that_is_not_one_number_is_named():
    assert_wrong(compare_number("0.5", 0.123456), "single number", "str")
    assert_wrong(compare_number([0.5, 1.0], 0.123456), "single number", "list")
    assert_wrong(compare_number(float("nan"), 0.123456), "NaN")


# --- compare_function ----------------------------------------------------------------------

def reference_gain(P, C, R):
    """K = P C^T (C P C^T + R)^{-1}, the gain of chapter 02."""
    return P @ C.T @ np.linalg.inv(C @ P @ C.T + R)


CASES = [(np.eye(2), np.array([[1.0, 0.0]]), np.array([[1.0]])),
         (np.array([[2.0, 0.5], [0.5, 1.0]]), np.array([[1.0, 1.0]]), np.array([[0.5]])),
         (np.diag([4.0, 9.0]), np.array([[0.0, 1.0]]), np.array([[1e-9]]))]


def test_function_right_answer_is_accepted_on_every_case():
    def gain(P, C, R):
        S = C @ P @ C.T + R
        return np.linalg.solve(S.T, (P @ C.T).T).T

    fb = compare_function(gain, reference_gain, CASES, what="kalman_gain")
    assert fb.status == CORRECT and "all 3 test inputs" in fb.message


def test_function_raising_names_the_input_that_broke_it():
    def gain(P, C, R):
        if R[0, 0] < 1e-6:
            raise ZeroDivisionError("R too small")
        return reference_gain(P, C, R)

    fb = compare_function(gain, reference_gain, CASES, what="kalman_gain")
    assert_wrong(fb, "kalman_gain fails on test input 3", "ZeroDivisionError: R too small",
                 "[[4., 0.]", "[[1.e-09]]")


def test_function_returning_none_is_asked_about_return():
    def gain(P, C, R):
        K = reference_gain(P, C, R)  # noqa: F841 - the forgotten return is the point

    assert_wrong(compare_function(gain, reference_gain, CASES), "returned None on test input 1",
                 "forget `return`")


def test_function_raising_not_implemented_is_not_attempted():
    def gain(P, C, R):
        """The stub of the student edition."""
        raise NotImplementedError("Exercise 2: write this function")

    fb = compare_function(gain, reference_gain, CASES, what="kalman_gain")
    assert fb.status == NOT_ATTEMPTED and "kalman_gain" in fb.message
    assert "NotImplementedError" in fb.message and "None" not in fb.message
    assert compare_function(None, reference_gain, CASES).status == NOT_ATTEMPTED


def test_function_wrong_output_gets_the_array_diagnosis_and_the_input():
    fb = compare_function(lambda P, C, R: -reference_gain(P, C, R), reference_gain, CASES)
    assert_wrong(fb, "test input 1", "wrong sign")
    fb = compare_function(lambda P, C, R: reference_gain(P, C, R).T, reference_gain, CASES)
    assert_wrong(fb, "test input 1", "transposed", "expected shape (2, 1)")
    # R forgotten: correct on no input
    fb = compare_function(lambda P, C, R: P @ C.T @ np.linalg.inv(C @ P @ C.T), reference_gain, CASES)
    assert_wrong(fb, "test input 1")


def test_function_inputs_are_copied_for_every_call():
    def scaled(x):
        y = 0.123456 * x
        x[:] = 0.0  # spoils its input
        return y

    cases = [(np.array([1.0, 2.0]),), (np.array([3.0, 4.0]),)]
    fb = compare_function(scaled, lambda x: 0.123456 * x, cases)
    assert fb.correct, fb
    assert np.array_equal(cases[0][0], [1.0, 2.0]), "the cases themselves must not change"


def test_function_with_number_comparison_and_a_model_input():
    model = bf.models.damped_particle()
    cases = [(model, np.array([1.0, 0.0, 2.0, 0.0])), (model, np.arange(4.0))]

    def energy(model, x):
        return float(x @ model.A.T @ model.A @ x) * 0.123456

    assert compare_function(energy, energy, cases, compare=compare_number, rtol=1e-9).correct
    fb = compare_function(lambda m, x: 2 * energy(m, x), energy, cases, compare=compare_number)
    assert_wrong(fb, "test input 1", "LinearGaussian", "simple factor")
    fb = compare_function(lambda m, x: m.nope, energy, cases)
    assert_wrong(fb, "fails on test input 1", "AttributeError")


@pytest.mark.parametrize("garbage", [3, "def f(x): return x", np.eye(2), [reference_gain]],
                         ids=lambda g: type(g).__name__)
def test_function_that_is_not_a_function_is_named(garbage):
    assert_wrong(compare_function(garbage, reference_gain, CASES), "must be a function")


def test_function_returning_garbage_is_feedback_not_an_exception():
    for out in ("K", {"K": 1}, Garbage(), [[1.0], [2.0, 3.0]], object()):
        fb = compare_function(lambda P, C, R, out=out: out, reference_gain, CASES)
        assert fb.status == INCORRECT and "test input 1" in fb.message
        assert_no_secret(fb)


# --- compare_choice ------------------------------------------------------------------------

OPTIONS = ("multinomial", "stratified", "systematic", "residual")


def test_choice_right_option_is_accepted_whatever_the_case_and_spaces():
    assert compare_choice(" Systematic ", "systematic", OPTIONS).correct
    assert compare_choice("SYSTEMATIC", "Systematic", OPTIONS).status == CORRECT


def test_choice_wrong_option_does_not_name_the_right_one():
    fb = compare_choice("multinomial", "systematic", OPTIONS, what="the scheme",
                        hint="which scheme draws one uniform only?")
    assert_wrong(fb, "the scheme is not the right option", "Hint: which scheme draws one uniform")
    assert "systematic" not in fb.message


def test_choice_outside_the_options_lists_them():
    assert_wrong(compare_choice("bootstrap", "systematic", OPTIONS), "must be one of", "'bootstrap'")


@pytest.mark.parametrize("garbage", [None, ..., 3, ["systematic"], Garbage(), b"systematic"],
                         ids=lambda g: type(g).__name__)
def test_choice_garbage_or_none_never_raises(garbage):
    fb = compare_choice(garbage, "systematic", OPTIONS)
    expected = NOT_ATTEMPTED if garbage is None or garbage is ... else INCORRECT
    assert fb.status == expected


# --- Feedback and the package --------------------------------------------------------------

def test_feedback_shows_its_message_as_a_cell_would():
    from IPython.lib.pretty import pretty

    fb = compare_array(None, E, what="K")
    assert repr(fb).startswith("Not attempted yet: K is still None")
    assert pretty(fb) == repr(fb) == str(fb)
    assert repr(compare_array(E, E, what="K")) == "Correct: K matches the reference."
    assert repr(compare_array(-E, E, what="K")).startswith("Not yet: K has the wrong sign")
    assert repr(Feedback(CORRECT, "")) == "Correct"


def test_chapter_modules_load_lazily_and_a_missing_one_is_an_attribute_error():
    import pkgutil

    assert not hasattr(bf.checks, "ch42")
    with pytest.raises(AttributeError, match="ch42"):
        bf.checks.ch42  # noqa: B018 - the attribute access is the test
    with pytest.raises(AttributeError, match="nonsense"):
        bf.checks.nonsense  # noqa: B018
    for info in pkgutil.iter_modules(bf.checks.__path__):
        if info.name.startswith("ch"):
            assert getattr(bf.checks, info.name).__name__ == f"bayesfilt.checks.{info.name}"
            assert info.name in dir(bf.checks)
    assert {"Feedback", "compare_array", "compare_number", "compare_function",
            "compare_choice"} <= set(dir(bf.checks))


# ---------------------------------------------------------------------------
# The engine every exercise runs through (bayesfilt.checks.exercise): the time budget of a
# check, in-place changes, any BaseException, stubs, nbgrader, the notebook's given values.
# ---------------------------------------------------------------------------

import os  # noqa: E402
import re  # noqa: E402
import signal  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

from bayesfilt.checks import WIDTH, Check, digest  # noqa: E402
from exercise_helpers import correct, not_attempted, wrong  # noqa: E402

ch01, ch02, ch03, ch04 = bf.checks.ch01, bf.checks.ch02, bf.checks.ch03, bf.checks.ch04
ch05, ch06 = bf.checks.ch05, bf.checks.ch06
ROOT = Path(__file__).resolve().parents[1]


def _in_chapter(code: str, source: bool = False, **chapter):
    """Define a student's function in a namespace holding the chapter's variables; with source,
    its source is where inspect finds it, as IPython keeps a cell's."""
    import linecache
    namespace, name = {"np": np, "bf": bf, **chapter}, f"<cell {abs(hash(code))}>"
    if source:
        linecache.cache[name] = (len(code), None, code.splitlines(True), name)
    exec(compile(code, name, "exec"), namespace)
    return namespace


def _right_update(prior, likelihood):
    joint = np.asarray(prior, dtype=float) * np.asarray(likelihood, dtype=float)
    return joint / joint.sum()


def _untouched():
    """The process's alarm handler, timer, trace function and interrupt handler, as they are."""
    return (signal.getsignal(signal.SIGALRM), signal.getitimer(signal.ITIMER_REAL)[0],
            sys.gettrace(), signal.getsignal(signal.SIGINT))


LOOPS = {   # functions that never return; the last four catch the check's alarm
    "while True": "    while True:\n        pass",
    "sleep": "    time.sleep(60)",
    "bare except": "    while True:\n        try:\n            time.sleep(1)\n        except:\n            pass",
    "one-line bare except": "    while True:\n        try: pass\n        except: pass",
    "BaseException, nested": "    while True:\n        try:\n            x = 1\n        except BaseException:\n"
                             "            try:\n                time.sleep(1)\n            except:\n"
                             "                continue",
    "except in a helper": "    def safe():\n        try:\n            time.sleep(1)\n        except:\n"
                          "            return\n    while True:\n        safe()",
}


@pytest.mark.parametrize("body", LOOPS.values(), ids=LOOPS.keys())
def test_a_function_that_never_returns_is_stopped_and_the_kernel_stays_usable(monkeypatch, body):
    """Even a loop that catches everything (bare except) ends within the budget and a fraction of
    a second; afterwards the alarm, the timer, the trace function and Jupyter's interrupt
    (SIGINT) are as before, and the next check runs as usual."""
    monkeypatch.setattr(bf.checks, "TIME_LIMIT", 0.2)
    fun = _in_chapter(f"import time\ndef update_by_hand(prior, likelihood):\n{body}")["update_by_hand"]
    before = _untouched()
    start = time.perf_counter()
    fb = ch01.exercise_1(fun)
    assert time.perf_counter() - start < 2.5
    wrong(fb, "update_by_hand did not return within 0.2 s: an endless loop?", "test input")
    assert repr(fb).startswith("Not yet: stopped after 0.2 s: update_by_hand did not return")
    assert _untouched() == before
    correct(ch01.exercise_1(_right_update))           # the next check runs as usual
    with pytest.raises(KeyboardInterrupt):            # and the interrupt still interrupts
        os.kill(os.getpid(), signal.SIGINT)
        time.sleep(5)


def test_one_budget_for_the_whole_check_not_one_per_input(monkeypatch):
    """A right answer that takes 0.15 s a call, on five inputs, with a budget of 0.4 s: stopped
    after the budget, not after 5 x 0.4 s; the message says it was too slow in all."""
    monkeypatch.setattr(bf.checks, "TIME_LIMIT", 0.4)

    def update_by_hand(prior, likelihood):
        time.sleep(0.15)
        return _right_update(prior, likelihood)
    start = time.perf_counter()
    fb = ch01.exercise_1(update_by_hand)
    assert time.perf_counter() - start < 1.5
    wrong(fb, "stopped after 0.4 s", "took more than 0.4 s in all over the test inputs", "too slow")


def test_the_time_limit_is_ten_seconds_unless_the_environment_says_otherwise():
    """(The variable's effect is shown by the nbgrader test below, which sets it to 0.3.)"""
    expected = float(os.environ.get("BAYESFILT_CHECK_TIME_LIMIT", "10"))
    assert bf.checks.TIME_LIMIT == expected


class _Custom(BaseException):
    pass


@pytest.mark.parametrize("exc, name", [(SystemExit(3), "SystemExit"), (GeneratorExit(), "GeneratorExit"),
                                       (_Custom("x"), "_Custom")])
def test_every_base_exception_but_the_interrupt_is_a_not_yet(exc, name):
    def update_by_hand(prior, likelihood):
        raise exc
    fb = ch01.exercise_1(update_by_hand)
    wrong(fb, f"your function raised {name}", "update_by_hand")
    assert fb.message.startswith(f"your function raised {name}")
    if name == "SystemExit":
        assert "return the result instead" in fb.message

    def interrupted(prior, likelihood):
        raise KeyboardInterrupt
    with pytest.raises(KeyboardInterrupt):
        ch01.exercise_1(interrupted)


def test_an_answer_that_raises_a_base_exception_itself_never_escapes():
    class Weird:
        def __array__(self, *args, **kwargs):
            raise SystemExit("no")

        def __float__(self):
            raise SystemExit("no")
    for check in (ch01.exercise_2, ch02.exercise_1, ch03.exercise_2):
        args = (Weird(),) * (3 if check is ch03.exercise_2 else 1)
        assert check(*args).status == INCORRECT


STUBS = {
    "docstring": 'def kalman_gain(P, C, R):\n    """The gain."""\n',
    "nbgrader's stub": 'def kalman_gain(P, C, R):\n    """The gain."""\n    # YOUR CODE HERE\n',
    "pass": 'def kalman_gain(P, C, R):\n    """The gain."""\n    # YOUR CODE HERE\n    pass\n',
    "ellipsis": "def kalman_gain(P, C, R):\n    ...\n",
}


@pytest.mark.parametrize("with_source", [True, False], ids=["source", "code object"])
@pytest.mark.parametrize("source", STUBS.values(), ids=STUBS.keys())
def test_a_function_whose_body_is_still_the_stub_is_not_attempted(source, with_source):
    """nbgrader's code_stub that does not raise leaves a docstring and a comment: the function
    returns None, which is "not attempted yet", not "did you forget return?"; recognised from
    its source (a notebook's cell) or, without it, from its code object."""
    fb = ch02.exercise_2(_in_chapter(source, with_source)["kalman_gain"])
    not_attempted(fb)
    assert "kalman_gain has no body yet" in fb.message
    fb = ch02.exercise_4(0, "best linear estimate", _in_chapter(source.replace("kalman_gain(P, C, R)",
                                                                        "grid_means_uniform(a)"), with_source)["grid_means_uniform"])
    assert fb.status == NOT_ATTEMPTED and "grid_means_uniform has no body yet" in fb.message
    # a body that computes but forgets `return` is a mistake, not a stub; so is `return None`
    forgot = _in_chapter("def kalman_gain(P, C, R):\n    K = P @ C.T @ np.linalg.inv(C @ P @ C.T + R)\n")
    wrong(ch02.exercise_2(forgot["kalman_gain"]), "forget `return`")
    wrong(ch02.exercise_2(lambda P, C, R: None), "forget `return`")

    returns_none = _in_chapter("def kalman_gain(P, C, R):\n    return None\n", source=True)["kalman_gain"]
    wrong(ch02.exercise_2(returns_none), "forget `return`")


def test_an_argument_changed_in_place_is_not_yet_whatever_the_output():
    def spoils(prior, likelihood):
        prior = np.asarray(prior, dtype=float)
        prior *= likelihood                            # changes the caller's float array
        return prior / prior.sum()
    wrong(ch01.exercise_1(spoils), "spoils changes its argument prior in place", "test input")


def test_03_ex4_the_chapters_ys_is_really_put_back():
    """The answer cell's own call end_of_gap_variance(20) wrote NaN into section 1's ys before the
    check ran (issue 20): the check says so and puts section 1's values back."""
    model = bf.models.damped_particle()
    ys = bf.models.simulate(model, 100, np.random.default_rng(2024)).ys
    kept = ys.copy()
    ns = _in_chapter(
        "def end_of_gap_variance(length):\n"
        "    ys[40:40 + length] = np.nan\n"
        "    return float(bf.kalman.kalman_filter(model, ys).covs[39 + length, x1, x1])\n"
        "slope_4 = float(np.log(end_of_gap_variance(20) / end_of_gap_variance(10)) / np.log(2))",
        ys=ys, model=model, x1=model.index_of("x1")[0], __name__="__main__")
    assert np.isnan(ys).sum() == 40                      # rows 40-59, written by the answer cell
    exec("fb = bf.checks.ch03.exercise_4(end_of_gap_variance, slope_4)", ns)
    wrong(ns["fb"], "changes the chapter's variable ys in place", "ys.copy()", "had NaN in 20 rows",
          "put section 1's values back")
    np.testing.assert_array_equal(ys, kept)
    assert ns["ys"] is ys
    # a ys that is not section 1's (a teacher's other seed) is left alone
    other = bf.models.simulate(model, 100, np.random.default_rng(7)).ys
    other[40:50] = np.nan
    fb = ch03.exercise_4(lambda n: 1.0, 1.5, namespace={"ys": other})
    assert np.isnan(other).sum() == 20 and "put section 1's values back" not in fb.message


def test_a_chapter_array_changed_in_place_by_the_check_call_is_put_back():
    model = bf.models.damped_particle()
    ys = bf.models.simulate(model, 100, np.random.default_rng(1)).ys
    kept = ys.copy()
    ns = _in_chapter(
        "def end_of_gap_variance(length):\n"
        "    ys[40:40 + length] = np.nan\n"
        "    return float(bf.kalman.kalman_filter(model, ys).covs[39 + length, x1, x1])\n"
        "slope_4 = 1.5", ys=ys, model=model, x1=model.index_of("x1")[0])
    fb = ch03.exercise_4(ns["end_of_gap_variance"], ns["slope_4"])
    wrong(fb, "changes the chapter's variable ys in place", "ys.copy()", "put ys back")
    np.testing.assert_array_equal(ys, kept)


def test_a_global_rebinding_is_not_yet_and_undone():
    """01 ex 4 with `global x_true, run`: the chapter's variables would change; the check undoes it."""
    x_true, run = np.arange(40), bf.bayes.bayes_filter(np.full(3, 1 / 3), np.eye(3), np.ones((2, 3)))
    seeds = [s for s in range(20) if ch01._mass(s)["right"] < 0.5]
    ns = _in_chapter(
        "def belief_near_truth(seed):\n"
        "    global x_true, run\n"
        "    x_true = np.zeros(40, dtype=int)\n"
        "    run = None\n"
        "    return mass[seed]\n", x_true=x_true, run=run, mass={s: ch01._mass(s)["right"] for s in range(20)})
    fb = ch01.exercise_4(seeds, namespace=ns)
    wrong(fb, "belief_near_truth rebinds the chapter's variable", "global")
    assert ns["x_true"] is x_true and ns["run"] is run


def test_under_nbgrader_a_check_prints_or_raises_its_message(monkeypatch, capsys):
    """nbgrader reads a check cell's value as a score: a correct check prints and returns None;
    one that is not correct raises Check, an AssertionError, with its message in lines that
    nbgrader validate shows whole, the diagnosis on the first."""
    monkeypatch.setenv("NBGRADER_EXECUTION", "autograde")
    assert ch01.exercise_1(_right_update) is None
    assert capsys.readouterr().out.startswith("Correct: update_by_hand agrees with the library")
    with pytest.raises(Check, match="Not yet: answer_2") as info:
        ch01.exercise_2(np.array([0.1, 0.2, 0.3]))
    assert isinstance(info.value, AssertionError)
    lines = str(info.value).splitlines()
    assert all(len(line) <= WIDTH for line in lines) and len(lines) > 1
    with pytest.raises(Check) as info:
        ch02.exercise_2(lambda P, C, R: np.linalg.solve(C @ P @ C.T + R, C @ P))
    assert "the gain is transposed" in str(info.value).splitlines()[0]
    with pytest.raises(Check, match="Not attempted yet"):
        ch01.exercise_2(None)
    monkeypatch.delenv("NBGRADER_EXECUTION")
    wrong(ch01.exercise_2(np.array([0.1, 0.2, 0.3])))  # in JupyterLab it never raises


def _cell(source: str, namespace: dict, number: int) -> str:
    """Run a notebook cell and show its failure as a kernel does, by IPython's own formatter."""
    import linecache

    from IPython.core.ultratb import AutoFormattedTB
    name = f"<ipython-input-{number}>"
    linecache.cache[name] = (len(source), None, source.splitlines(True), name)
    try:
        exec(compile(source, name, "exec"), namespace)
    except Exception:  # noqa: BLE001 - the formatted failure is what is tested
        etype, value, tb = sys.exc_info()
        return AutoFormattedTB(mode="Context", theme_name="nocolor").text(etype, value, tb.tb_next)
    return ""


def test_the_feedback_under_nbgrader_shows_the_diagnosis_and_no_library_frame(monkeypatch, capsys):
    """IPython's own formatter, as a kernel under nbgrader shows the failed check: the check cell,
    no frame of bayesfilt's files and no absolute path, then the diagnosis; a timed-out answer
    says so; each line fits nbgrader validate's 90 columns (4 of indent, cut at 87)."""
    monkeypatch.setenv("NBGRADER_EXECUTION", "validate")
    monkeypatch.setattr(bf.checks, "TIME_LIMIT", 0.3)
    ns = {"np": np, "bf": bf, "__name__": "__main__"}
    exec("def kalman_gain(P, C, R):\n    return np.linalg.solve(C @ P @ C.T + R, C @ P)", ns)
    transposed = _cell("bf.checks.ch02.exercise_2(kalman_gain)", ns, 1)
    exec("def kalman_gain(P, C, R):\n    while True:\n        try:\n            pass\n        except:\n"
         "            pass", ns)
    looped = _cell("bf.checks.ch02.exercise_2(kalman_gain)", ns, 2)
    for shown in (transposed, looped):
        assert "Traceback" in shown and "----> 1 bf.checks.ch02.exercise_2(kalman_gain)" in shown, shown
        assert str(ROOT) not in shown and "site-packages" not in shown and "__init__.py" not in shown
        assert "bayesfilt/checks" not in shown, shown
        assert all(len(line) + 4 <= 87 for line in shown.splitlines() if not line.startswith("---")), shown
    assert "Check: Not yet: kalman_gain, test input 1: the gain is transposed" in transposed
    assert "Check: Not yet: stopped after 0.3 s: kalman_gain did not return" in looped
    capsys.readouterr()
    right = "bf.checks.ch02.exercise_3(0.43 + 3.96 / 27.35 * 7.24, (0.87 - 3.96 ** 2 / 27.35) ** 0.5)"
    assert _cell(right, ns, 3) == "" and capsys.readouterr().out == (
        "Correct: mean_3 and sd_3 match the reference; compare them with the kept velocities of section 3's "
        "figure.\n")




# --- the statement's numbers, read from the notebook: one exercise per chapter ---------------

def test_the_check_reads_the_notebooks_variables_only_from_a_notebook():
    """The caller's globals count when they are a notebook's (__main__), not a module's."""
    m, Pi = np.array([4.76, 0.43]), np.array([[27.35, 3.96], [3.96, 0.87]])
    mean, sd = m[1] + Pi[1, 0] / Pi[0, 0] * (10.0 - m[0]), (Pi[1, 1] - Pi[1, 0] ** 2 / Pi[0, 0]) ** 0.5
    ns = {"bf": bf, "np": np, "m_3": m, "Pi_3": Pi, "position_3": 10.0, "mean_3": mean, "sd_3": sd,
          "__name__": "__main__"}
    exec("fb = bf.checks.ch02.exercise_3(mean_3, sd_3)", ns)
    correct(ns["fb"])
    ns["__name__"] = "some_module"                            # a module's globals are not read
    exec("fb = bf.checks.ch02.exercise_3(mean_3, sd_3)", ns)
    wrong(ns["fb"])


def _edited(check, answer_right, answer_old, namespace):
    correct(check(*answer_right, namespace=namespace))
    assert check(*answer_old, namespace=namespace).status == INCORRECT
    assert check(*answer_old).correct                           # the statement's own numbers


def test_01_a_teacher_changes_the_number_of_steps():
    step_mean, step_var = 1.05, 0.1475
    _edited(ch01.exercise_5, ([10 * step_mean, 10 * step_var],), ([20 * step_mean, 20 * step_var],),
            {"steps_5": 10})


def test_02_a_teacher_changes_the_measured_position():
    m, Pi = np.array([4.76, 0.43]), np.array([[27.35, 3.96], [3.96, 0.87]])
    sd = (Pi[1, 1] - Pi[1, 0] ** 2 / Pi[0, 0]) ** 0.5
    at = lambda position: (m[1] + Pi[1, 0] / Pi[0, 0] * (position - m[0]), sd)  # noqa: E731
    _edited(ch02.exercise_3, at(10.0), at(12.0), {"position_3": 10.0})


def test_03_a_teacher_changes_the_kick_variance():
    dp = bf.models.damped_particle()
    ys = bf.models.simulate(dp, 100, np.random.default_rng(2024)).ys[:, :1]

    def answers(kick_variance):          # the unmeasured xi_2 depends on Q, not on R
        model = bf.models.LinearGaussian(A=dp.A, C=[[1.0, 0.0, 0.0, 0.0]], Q=kick_variance * np.eye(2),
                                         R=[[1.0]], m0=dp.m0, P0=dp.P0, G=dp.G, state_names=dp.state_names)
        return model, (2, "no", float(bf.kalman.kalman_filter(model, ys).covs[-1, 2, 2]))
    (model, right), (_, old) = answers(0.02), answers(0.01)
    _edited(ch03.exercise_2, right, old, {"model_2": model})


def test_04_a_teacher_changes_the_measurement_of_the_iterated_update():
    model = bf.models.range_bearing()

    def limit(y):
        x = model.m0
        for _ in range(50):
            H = model.H(x)
            r = bf.models.range_bearing_residual(y, model.h(x)) - H @ (model.m0 - x)
            x = model.m0 + model.P0 @ H.T @ np.linalg.solve(H @ model.P0 @ H.T + model.R, r)
        return x[:2]
    y0 = bf.models.simulate(model, 100, np.random.default_rng(0), x0=bf.models.RANGE_BEARING_TRUE_START).ys[0]
    y_new = np.array([9.0, -0.3])
    right_fun = ch04._iterate
    _edited(ch04.exercise_3, (right_fun, limit(y_new)), (right_fun, limit(y0)), {"y0_3": y_new})


def test_05_a_teacher_changes_the_weights():
    ess = lambda w: np.sum(w) ** 2 / np.sum(np.square(w))  # noqa: E731
    lw = np.array([-1000.0, -1001.0, -1002.0])
    c = ess(np.exp(lw - lw.max()))
    new = (0.7, 0.1, 0.1, 0.1)
    _edited(ch05.exercise_2, ([ess(new), ess([1, 1, 2]), c],), ([ess([0.4, 0.3, 0.2, 0.1]), ess([1, 1, 2]), c],),
            {"weights_a_2": new})


def test_06_a_teacher_changes_the_weights_and_the_number_of_draws():
    W, M = np.array([0.5, 0.25, 0.15, 0.1]), 12
    f = M * W[1] % 1
    leftover = M - np.floor(M * W).sum()
    new = [M * W[1], M * W[1] * (1 - W[1]), f * (1 - f), f * (1 - f / leftover)]
    w, f0 = 0.28, 0.8
    old = [10 * w, 10 * w * (1 - w), f0 * (1 - f0), f0 * (1 - f0 / 2)]
    _edited(ch06.exercise_2, (np.array(new),), (np.array(old),), {"W_2": W, "M_2": M})


# --- choice answers are not in the modules in clear ------------------------------------------

def test_choice_answers_are_stored_as_salted_hashes():
    src = {n: (ROOT / "bayesfilt" / "checks" / f"{n}.py").read_text(encoding="utf-8")
           for n in ("ch02", "ch03", "ch05")}
    # each right option appears once, in the statement's list of options, and nowhere else
    assert src["ch02"].count('"best linear estimate"') == 1 and "OPTIONS_4 = (" in src["ch02"]
    assert src["ch03"].count('"ratio"') == 1 and "OPTIONS_5 = " in src["ch03"]
    assert not re.search(r"""\[?["']b["'],\s*["']c["']\]?""", src["ch05"])
    assert ch03.SEES_5 == digest("ratio", "ch03-ex5") and digest(" Ratio ", "ch03-ex5") == ch03.SEES_5
    assert compare_choice("RATIO", ch03.SEES_5, ("ratio", "scale", "neither")).correct
    assert not compare_choice("scale", ch03.SEES_5, ("ratio", "scale", "neither")).correct


def test_01_ex2_the_natural_call_of_bayes_filter_is_explained():
    push = np.array([[1.0, 0.0], [0.8, 0.2]])
    closed = np.array([0.4, 0.8])
    natural = bf.bayes.bayes_filter([0.5, 0.5], push, [closed] * 3).posteriors[:, 0]
    wrong(ch01.exercise_2(natural), "first likelihood at t = 0", "no_measurement", "posteriors[1:]")


def test_02_ex2_a_minus_r_is_not_called_a_constant_factor():
    fb = ch02.exercise_2(lambda P, C, R: P @ C.T @ np.linalg.inv(C @ P @ C.T - R))
    wrong(fb, "C P C^T - R", "S = C P C^T + R")
    assert "constant factor" not in fb.message.replace("not a constant factor", "")


def test_02_ex4_the_function_is_checked_and_synonyms_accepted():
    right = ch02._uniform_grid_means
    correct(ch02.exercise_4(0, "best linear estimator", lambda a: right(a)))
    correct(ch02.exercise_4(0, "Best linear estimate"))
    wrong(ch02.exercise_4(0, "best linear estimate", lambda a: right(np.sqrt(1.5))),
          "grid_means_uniform", "a = 1")


def test_03_ex4_the_variance_at_t_99_is_named_and_not_nan_rows_kept_for_zeros():
    model = bf.models.damped_particle()
    x1 = model.index_of("x1")[0]

    def covs(length, fill):
        ys = np.zeros((100, 2))
        ys[40:40 + length] = fill
        return bf.kalman.kalman_filter(model, ys).covs
    wrong(ch03.exercise_4(lambda n: float(covs(n, np.nan)[99, x1, x1]), 1.5), "t = 99", "covs[39 + length")
    wrong(ch03.exercise_4(lambda n: float(covs(n, 0.0)[39 + n, x1, x1]), 1.5), "row of NaN")


def test_03_ex5_a_wrong_lag_is_named():
    ys_long = bf.models.simulate(bf.models.damped_particle(), 1000, np.random.default_rng(5)).ys
    rows = []
    for kw in (dict(force_var=0.1), dict(meas_var=0.1), dict(meas_var=10)):
        res = bf.kalman.kalman_filter(bf.models.damped_particle(**kw), ys_long)
        z = bf.gaussian.normalised_innovations(res.innovations, res.innovation_covs)
        rows.append(bf.gaussian.autocorrelation(z, 3)[2])
    fb = ch03.exercise_5(np.array(rows), "ratio")
    wrong(fb, "is lag 3")
    assert "filter ys_long" not in fb.message


def test_04_the_false_positives_of_the_class_are_not_yet():
    model = bf.models.range_bearing()
    # ex 5: y -= y_pred changes the caller's array
    def in_place(y, y_pred):
        y -= y_pred
        y[1] = np.pi - np.mod(np.pi - y[1], 2 * np.pi)
        return y
    wrong(ch04.exercise_5(in_place), "changes its argument y in place")

    # ex 3: x = m0; x += step moves m0
    def aliasing(m0, P0, y, n_iter):
        x = m0
        for _ in range(n_iter):
            H = model.H(x)
            r = bf.models.range_bearing_residual(y, model.h(x)) - H @ (m0 - x)
            x += m0 + P0 @ H.T @ np.linalg.solve(H @ P0 @ H.T + model.R, r) - x
        return x
    wrong(ch04.exercise_3(aliasing, np.zeros(2)), "changes its argument m0 in place")

    # ex 2: the NEES at the last step only (seed 10 as the statement says)
    nees = ch04._nees_experiment(ch04._converted_cov, np.random.default_rng(10))
    wrong(ch04.exercise_2(ch04._converted_cov, float(nees[:, -1].mean())), "last step t = 10 only")
    wrong(ch04.exercise_2(ch04._converted_cov, float(np.median(nees))), "the median")
    correct(ch04.exercise_2(ch04._converted_cov, float(nees.mean())))


def test_the_example_of_contributing_md_is_a_working_check():
    """CONTRIBUTING.md's example check, run in chapter 02's module namespace."""
    import re
    from pathlib import Path
    text = (Path(__file__).resolve().parents[1] / "CONTRIBUTING.md").read_text(encoding="utf-8")
    section = text[text.index("## Exercises (every chapter)"):]
    code = next(b for b in re.findall(r"```python\n(.*?)```", section, flags=re.S)
                if b.startswith("def exercise_2"))
    namespace = {**vars(bf.checks), **vars(ch02)}   # the module's names and the engine's
    exec(code, namespace)
    check = bf.checks.exercise(namespace["exercise_2"])
    def gain(P, C, R):
        return P @ C.T @ np.linalg.inv(C @ P @ C.T + R)
    right = gain(ch02.P_EX, ch02.C_EX, ch02.R_EX)
    correct(check(gain, right))
    wrong(check(lambda P, C, R: P @ C.T @ np.linalg.inv(C @ P @ C.T), right), "without R")
    wrong(check(gain, 2 * right), "gain_2")
