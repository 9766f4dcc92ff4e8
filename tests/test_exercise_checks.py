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
    assert_wrong(compare_array(wrong, COV, what="P"), "P should be a covariance", "symmetric",
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
# The engine every exercise runs through (bayesfilt.checks.exercise): time limit,
# in-place changes, nbgrader, rounded answers; and the answers of a class (issue 13)
# that used to be accepted or misdiagnosed.
# ---------------------------------------------------------------------------

import signal  # noqa: E402
import time  # noqa: E402

from exercise_helpers import correct, wrong  # noqa: E402

ch01, ch02, ch03, ch04 = bf.checks.ch01, bf.checks.ch02, bf.checks.ch03, bf.checks.ch04


def _in_chapter(code: str, **chapter):
    """Define a student's function in a namespace holding the chapter's variables."""
    namespace = {"np": np, "bf": bf, **chapter}
    exec(code, namespace)
    return namespace


def _right_update(prior, likelihood):
    joint = np.asarray(prior, dtype=float) * np.asarray(likelihood, dtype=float)
    return joint / joint.sum()


@pytest.mark.parametrize("body", ["while True:\n        pass", "time.sleep(60)"])
def test_a_function_that_never_returns_is_stopped_and_the_kernel_stays_usable(monkeypatch, body):
    monkeypatch.setattr(bf.checks, "TIME_LIMIT", 0.3)
    fun = _in_chapter(f"import time\ndef update_by_hand(prior, likelihood):\n    {body}")["update_by_hand"]
    handler = signal.getsignal(signal.SIGALRM)
    start = time.perf_counter()
    fb = ch01.exercise_1(fun)
    assert time.perf_counter() - start < 5
    wrong(fb, "your function update_by_hand did not return within 0.3 s: an endless loop?",
          "test input")
    assert signal.getsignal(signal.SIGALRM) is handler and signal.getitimer(signal.ITIMER_REAL)[0] == 0
    correct(ch01.exercise_1(_right_update))           # and the next check runs as usual


def test_the_time_limit_is_ten_seconds_unless_the_environment_says_otherwise():
    import os
    expected = float(os.environ.get("BAYESFILT_CHECK_TIME_LIMIT", "10"))
    assert bf.checks.TIME_LIMIT == expected


def test_an_argument_changed_in_place_is_not_yet_whatever_the_output():
    def spoils(prior, likelihood):
        prior = np.asarray(prior, dtype=float)
        prior *= likelihood                            # changes the caller's float array
        return prior / prior.sum()
    wrong(ch01.exercise_1(spoils), "spoils changes its argument prior in place", "test input")


def test_a_chapter_array_changed_in_place_is_not_yet_and_put_back():
    """03 ex 4: the gap written into the chapter's own ys instead of a copy."""
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


def test_under_nbgrader_a_check_that_is_not_correct_raises_its_message(monkeypatch):
    monkeypatch.setenv("NBGRADER_EXECUTION", "autograde")
    with pytest.raises(AssertionError, match="Not yet: answer_2"):
        ch01.exercise_2(np.array([0.1, 0.2, 0.3]))
    with pytest.raises(AssertionError, match="Not attempted yet"):
        ch01.exercise_2(None)
    correct(ch01.exercise_1(_right_update))            # a correct answer passes, once
    monkeypatch.delenv("NBGRADER_EXECUTION")
    wrong(ch01.exercise_2(np.array([0.1, 0.2, 0.3])))  # in JupyterLab it never raises


def test_a_rounded_answer_is_asked_for_more_decimals():
    ref = np.array([0.818181818, 0.929824561, 0.972318339])
    wrong(ch01.exercise_2(np.round(ref, 2)), "rounded to 2 decimals", "give more decimals")
    wrong(compare_number(0.12, 0.123456), "rounded to 2 decimals")
    wrong(compare_array(np.round(E, 3), E), "rounded to 3 decimals")
    assert "decimals" not in compare_number(0.1, 0.123456).message     # 0.1 is just too small


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
