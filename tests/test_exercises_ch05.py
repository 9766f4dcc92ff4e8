"""Tests of bayesfilt.checks.ch05, the checks of chapter 05's exercises.

For every exercise: the right answer, computed here independently of the
check module (closed forms with numpy and ``scipy.stats.norm``, the
experiment re-run with other seeds, the models' matrices read by hand), is
accepted; plausible wrong answers are rejected with their specific diagnosis
(asserted on the message); ``None`` (or a function that still raises
``NotImplementedError``) is "not attempted yet"; and garbage (text, wrong
shapes, odd objects) gives feedback instead of raising.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from scipy.special import logsumexp
from scipy.stats import norm

import bayesfilt as bf
from bayesfilt.checks import CORRECT, INCORRECT, NOT_ATTEMPTED, Feedback
from exercise_helpers import (  # noqa: F401 - the shared helpers of the exercise tests
    never_raises as _assert_never_raises, wrong as _assert_wrong,
)

ch05 = bf.checks.ch05
NOTEBOOK = Path(__file__).resolve().parents[1] / "notebooks" / "05_sis_weights.ipynb"

# the numbers of the statements, written out again (not imported from the module under test)
A, Q, C, R = 0.9, 1.0, 1.0, 0.1
GARBAGE = ["abc", b"x", {"a": 1}, [[1, 2], [3]], object(), 1 + 2j, [True, False], np.eye(4),
           np.full(3, np.nan), [], Ellipsis, 3, -1.5, [None, 1, 2]]


def _not_written(*args):
    raise NotImplementedError("Exercise N: write this function")


# --------------------------------------------------------------------------
# Exercise 1: my_log_normalize
# --------------------------------------------------------------------------

def right_log_normalize(log_w):
    m = np.max(log_w)
    log_sum = m + np.log(np.sum(np.exp(log_w - m)))
    return log_w - log_sum, float(log_sum)


def test_ex1_the_right_function_is_accepted():
    fb = ch05.exercise_1(right_log_normalize)
    assert fb.status == CORRECT, fb
    assert repr(fb).startswith("Correct")


def test_ex1_a_list_result_is_accepted_and_scipy_refused():
    _assert_wrong(ch05.exercise_1(lambda lw: (lw - logsumexp(lw), logsumexp(lw))),
                  "uses logsumexp, which the statement rules out")
    assert ch05.exercise_1(lambda lw: [list(right_log_normalize(lw)[0]),
                                       np.float64(right_log_normalize(lw)[1])]).correct


def test_ex1_the_reference_agrees_with_a_hand_computation():
    """The statement's case by hand: e^0, e^-1, e^-2, 0 (the check's reference is the library)."""
    log_W, log_sum = bf.particle.log_normalize([-1000.0, -1001.0, -1002.0, -np.inf])
    s = 1 + math.exp(-1) + math.exp(-2)
    assert math.isclose(log_sum, -1000 + math.log(s), rel_tol=1e-14)
    np.testing.assert_allclose(log_W[:3], [-math.log(s), -1 - math.log(s), -2 - math.log(s)])
    assert log_W[3] == -np.inf


def test_ex1_no_shift():
    def no_shift(lw):
        s = np.log(np.sum(np.exp(lw)))
        return lw - s, s
    _assert_wrong(ch05.exercise_1(no_shift), "underflowed", "largest log-weight", "test input 1")


def test_ex1_overflow_without_the_shift():
    """Shifting by the smallest finite log-weight survives underflow but not overflow."""
    def shift_by_min(lw):
        m = np.min(lw[np.isfinite(lw)])
        s = m + np.log(np.sum(np.exp(lw - m)))
        return lw - s, s
    fb = ch05.exercise_1(shift_by_min)
    _assert_wrong(fb)
    assert "overflowed" in fb.message or "largest log-weight" in fb.message, fb


def test_ex1_log_of_the_weights_underflows_where_the_spread_is_wide():
    def log_of_weights(lw):
        m = np.max(lw)
        s = m + np.log(np.sum(np.exp(lw - m)))
        with np.errstate(divide="ignore"):
            return np.log(np.exp(lw - s)), s
    _assert_wrong(ch05.exercise_1(log_of_weights), "not zero", "Stay in logs", "test input 7")


def test_ex1_max_not_added_back():
    def forgot_m(lw):
        m = np.max(lw)
        s = np.log(np.sum(np.exp(lw - m)))
        return lw - m - s, s
    _assert_wrong(ch05.exercise_1(forgot_m), "add the largest log-weight m back")


def test_ex1_log_of_the_mean():
    def log_mean(lw):
        m = np.max(lw)
        s = m + np.log(np.sum(np.exp(lw - m)))
        return lw - s, s - np.log(lw.size)
    _assert_wrong(ch05.exercise_1(log_mean), "log of the mean")


def test_ex1_weights_instead_of_log_weights():
    _assert_wrong(ch05.exercise_1(lambda lw: (np.exp(right_log_normalize(lw)[0]),
                                              right_log_normalize(lw)[1])),
                  "normalised weights W^(i) themselves")


def test_ex1_shifted_but_not_normalised():
    _assert_wrong(ch05.exercise_1(lambda lw: (lw - np.max(lw), right_log_normalize(lw)[1])),
                  "only shifted")


def test_ex1_wrong_sign_and_division():
    _assert_wrong(ch05.exercise_1(lambda lw: (right_log_normalize(lw)[1] - lw,
                                              right_log_normalize(lw)[1])), "wrong sign")
    _assert_wrong(ch05.exercise_1(lambda lw: (lw / right_log_normalize(lw)[1],
                                              right_log_normalize(lw)[1])), "subtraction")


def test_ex1_a_zero_weight_must_stay_minus_infinity():
    def finite_floor(lw):
        log_W, s = right_log_normalize(lw)
        return np.maximum(log_W, -1e300), s
    _assert_wrong(ch05.exercise_1(finite_floor), "must keep log W = -inf")


def test_ex1_changes_its_argument_in_place():
    def in_place(lw):
        m = np.max(lw)
        lw -= m
        s = np.log(np.sum(np.exp(lw)))
        return lw - s, m + s
    _assert_wrong(ch05.exercise_1(in_place), "in place")


def test_ex1_the_shape_of_the_result():
    _assert_wrong(ch05.exercise_1(lambda lw: right_log_normalize(lw)[0]), "return the pair")
    _assert_wrong(ch05.exercise_1(lambda lw: right_log_normalize(lw)[::-1]), "wrong order")
    _assert_wrong(ch05.exercise_1(lambda lw: (right_log_normalize(lw)[0], right_log_normalize(lw)[1], 0)),
                  "pair")


def test_ex1_not_attempted():
    assert ch05.exercise_1(None).status == NOT_ATTEMPTED
    assert ch05.exercise_1(_not_written).status == NOT_ATTEMPTED


def test_ex1_never_raises():
    funs = [lambda lw: len(lw) and None, lambda lw: "x", lambda lw: (None, None), lambda lw: (lw, "s"),
            lambda lw: (np.full(lw.shape, np.nan), np.nan), lambda lw: 1 / 0,
            lambda lw: ([[1, 2], [3]], 0.0), lambda lw: (lw, [1.0, 2.0]), lambda: 0]
    _assert_never_raises(ch05.exercise_1, GARBAGE + funs)
    for fun in funs:
        assert ch05.exercise_1(fun).status == INCORRECT, fun


# --------------------------------------------------------------------------
# Exercise 2: the ESS of three weight vectors
# --------------------------------------------------------------------------

def _ess(w):
    w = np.asarray(w, dtype=float)
    W = w / w.sum()
    return 1 / np.sum(W ** 2)


RIGHT_2 = np.array([_ess([0.4, 0.3, 0.2, 0.1]), _ess([1, 1, 2]),
                    _ess([1, math.exp(-1), math.exp(-2), 0])])


def test_ex2_the_right_answer_is_accepted_also_rounded():
    np.testing.assert_allclose(RIGHT_2[:2], [10 / 3, 8 / 3])
    assert ch05.exercise_2(RIGHT_2).correct
    assert ch05.exercise_2(list(np.round(RIGHT_2, 3))).correct
    assert ch05.exercise_2(tuple(RIGHT_2)).correct


def test_ex2_sum_of_squares_instead_of_its_reciprocal():
    _assert_wrong(ch05.exercise_2(1 / RIGHT_2), "reciprocal", "answer_2[0]")


def test_ex2_unnormalised_weights():
    _assert_wrong(ch05.exercise_2([RIGHT_2[0], 1 / 6, RIGHT_2[2]]), "normalise them first",
                  "answer_2[1]")


def test_ex2_exp_underflow_gives_nan():
    _assert_wrong(ch05.exercise_2([RIGHT_2[0], RIGHT_2[1], np.nan]), "underflows",
                  "subtract the largest")


def test_ex2_equal_weights_or_log_weights_as_weights():
    lw = np.array([-1000.0, -1001.0, -1002.0])
    _assert_wrong(ch05.exercise_2([RIGHT_2[0], RIGHT_2[1], lw.sum() ** 2 / np.sum(lw ** 2)]),
                  "3 equal weights")
    _assert_wrong(ch05.exercise_2([RIGHT_2[0], RIGHT_2[1], 4.0]), "all 4 particles")


def test_ex2_base_10():
    _assert_wrong(ch05.exercise_2([RIGHT_2[0], RIGHT_2[1], _ess([1, 0.1, 0.01])]), "10^l")


def test_ex2_sample_variance_and_max_weight():
    NW = 4 * np.array([0.4, 0.3, 0.2, 0.1])
    _assert_wrong(ch05.exercise_2([4 / (1 + np.var(NW, ddof=1)), RIGHT_2[1], RIGHT_2[2]]), "ddof=1")
    _assert_wrong(ch05.exercise_2([1 / 0.4, RIGHT_2[1], RIGHT_2[2]]), "1 / max_i W^(i)")


def test_ex2_order_and_shape():
    _assert_wrong(ch05.exercise_2(RIGHT_2[[1, 0, 2]]), "wrong order")
    _assert_wrong(ch05.exercise_2(RIGHT_2[None, :]), "flat array")
    _assert_wrong(ch05.exercise_2(RIGHT_2[:2]), "three numbers")
    _assert_wrong(ch05.exercise_2([RIGHT_2[0], RIGHT_2[1], 0.5]), "below 1")


def test_ex2_the_messages_do_not_show_the_answer():
    for wrong in ([0.3, 0.375, 0.51], [1.0, 1.0, 1.0], [5.0, 5.0, 5.0], [3.3, 2.6, 1.9]):
        message = ch05.exercise_2(wrong).message
        for value in RIGHT_2:
            assert f"{value:.3f}" not in message and f"{value:.2f}" not in message, message


def test_ex2_not_attempted_and_never_raises():
    assert ch05.exercise_2(None).status == NOT_ATTEMPTED
    _assert_never_raises(ch05.exercise_2, GARBAGE + [lambda: 0, [np.inf, 1, 1], [1, 2, "3"]])


# --------------------------------------------------------------------------
# Exercise 3: log_increment
# --------------------------------------------------------------------------

def right_increment(x_prev, y):
    # y_t | x_t-1 ~ N(C A x_prev, C Q C^T + R)
    return norm.logpdf(y, C * A * x_prev, math.sqrt(C * Q * C + R))


def _with(mean_factor=C * A, var=C * Q * C + R):
    return lambda x, y: norm.logpdf(y, mean_factor * x, math.sqrt(var))


def test_ex3_the_right_function_is_accepted():
    assert math.isclose(right_increment(1.0, 2.0), -1.5165936231068353, rel_tol=1e-12)
    fb = ch05.exercise_3(right_increment)
    assert fb.status == CORRECT, fb
    assert ch05.exercise_3(lambda x, y: np.array([right_increment(x, y)])).correct


def test_ex3_the_reference_is_eq_13_with_the_library_proposal():
    """Independent of the closed form: eq. (13) at a few draws of bf.particle.optimal_proposal."""
    lg = bf.models.LinearGaussian(A=[[A]], C=[[C]], Q=[[Q]], R=[[R]], m0=[0.0], P0=[[1.0]])
    opt = bf.particle.optimal_proposal(lg)
    X_prev, Y = np.array([[1.0]] * 5), np.array([2.0])
    X = opt.sample(np.random.default_rng(7), X_prev, Y, 1)
    log_alpha = lg.measurement_logpdf(Y, X) + lg.transition_logpdf(X, X_prev) - opt.logpdf(X, X_prev, Y, 1)
    np.testing.assert_allclose(log_alpha, right_increment(1.0, 2.0), rtol=1e-10)


def test_ex3_variance_without_q_or_without_r():
    _assert_wrong(ch05.exercise_3(_with(var=R)), "variance R alone", "bootstrap")
    _assert_wrong(ch05.exercise_3(_with(var=C * Q * C)), "R is missing")


def test_ex3_mean_without_a_and_noise_scaled_by_a():
    _assert_wrong(ch05.exercise_3(_with(mean_factor=C)), "C A x_prev")
    _assert_wrong(ch05.exercise_3(_with(var=A * Q * A + R)), "without A")


def test_ex3_variance_and_standard_deviation_confused():
    S = C * Q * C + R
    _assert_wrong(ch05.exercise_3(lambda x, y: norm.logpdf(y, A * x, S)), "standard deviation")
    _assert_wrong(ch05.exercise_3(lambda x, y: norm.logpdf(y, A * x, S ** 0.25)), "sqrt(S) as the variance")


def test_ex3_the_proposal_variance():
    K = Q * C / (C * Q * C + R)
    _assert_wrong(ch05.exercise_3(_with(var=(1 - K * C) * Q)), "proposal")


def test_ex3_density_constant_sign_and_base():
    _assert_wrong(ch05.exercise_3(lambda x, y: math.exp(right_increment(x, y))), "logarithm")
    _assert_wrong(ch05.exercise_3(lambda x, y: -(y - A * x) ** 2 / (2 * (Q + R))), "constant")
    _assert_wrong(ch05.exercise_3(lambda x, y: -right_increment(x, y)), "wrong sign")
    _assert_wrong(ch05.exercise_3(lambda x, y: right_increment(x, y) / math.log(10)), "log10")


def test_ex3_an_unrecognised_mistake_names_the_input():
    _assert_wrong(ch05.exercise_3(_with(mean_factor=0.8)), "test input 1", "x_prev = 1")


def test_ex3_not_attempted_and_never_raises():
    assert ch05.exercise_3(None).status == NOT_ATTEMPTED
    assert ch05.exercise_3(_not_written).status == NOT_ATTEMPTED
    _assert_wrong(ch05.exercise_3(lambda x, y: float(x) and None), "forget `return`")
    funs = [lambda x, y: "x", lambda x, y: [1.0, 2.0], lambda x, y: np.ones(3), lambda x, y: 1 / 0,
            lambda x, y: np.nan, lambda x, y: math.inf, lambda x: 0, lambda x, y: True]
    _assert_never_raises(ch05.exercise_3, GARBAGE + funs)
    for fun in funs:
        assert ch05.exercise_3(fun).status == INCORRECT, fun


# --------------------------------------------------------------------------
# Exercise 4: how the degeneracy depends on R
# --------------------------------------------------------------------------

def _experiment(seed_records, seed_filters, R_values=(0.01, 0.1, 1.0)):
    """Section 8's experiment for each R, with other seeds than the check's."""
    boot, opt = [], []
    for Rv in R_values:
        lg = bf.models.LinearGaussian(A=[[A]], C=[[C]], Q=[[Q]], R=[[Rv]], m0=[0.0], P0=[[1.0]])
        rng_records = np.random.default_rng(seed_records)
        rngs = {"b": np.random.default_rng(seed_filters), "o": np.random.default_rng(seed_filters)}
        eb, eo = [], []
        for _ in range(10):
            ys = bf.models.simulate(lg, 40, rng_records).ys
            eb.append(bf.particle.particle_filter(lg, ys, 500, rngs["b"], ess_threshold=0).ess[5])
            eo.append(bf.particle.particle_filter(lg, ys, 500, rngs["o"], ess_threshold=0,
                                                  proposal=bf.particle.optimal_proposal(lg)).ess[39])
        boot.append(np.mean(eb))
        opt.append(np.mean(eo))
    return R_values[int(np.argmin(boot))], R_values[int(np.argmin(opt))]


@pytest.fixture(scope="module")
def right_4():
    return _experiment(seed_records=101, seed_filters=202)


def test_ex4_the_right_answer_is_accepted_in_several_forms(right_4):
    fb = ch05.exercise_4(right_4)
    assert fb.status == CORRECT, fb
    assert ch05.exercise_4(list(right_4)).correct
    assert ch05.exercise_4(np.array(right_4)).correct
    assert ch05.exercise_4(tuple(f"R = {v:g}" for v in right_4)).correct


def test_ex4_the_answer_is_the_one_section_8_explains(right_4):
    """A precise sensor ruins the bootstrap; the optimal proposal suffers most from wide pasts."""
    assert right_4 == (0.01, 1.0)


def test_ex4_swapped(right_4):
    _assert_wrong(ch05.exercise_4(right_4[::-1]), "swapped")


def test_ex4_a_noisier_sensor_is_not_worse_for_the_bootstrap(right_4):
    _assert_wrong(ch05.exercise_4((1.0, 1.0)), "is not the R of the bootstrap", "blind draws")


def test_ex4_the_optimal_proposal_does_not_rank_like_the_bootstrap(right_4):
    _assert_wrong(ch05.exercise_4((right_4[0], right_4[0])), "like the bootstrap", "t = 39")
    _assert_wrong(ch05.exercise_4((right_4[0], 0.1)), "answer_4[1]", "t = 39")
    _assert_wrong(ch05.exercise_4((0.1, right_4[1])), "Average over the 10 records")


def test_ex4_an_ess_instead_of_an_r():
    _assert_wrong(ch05.exercise_4((1.1, 30.2)), "not the ESS")
    _assert_wrong(ch05.exercise_4((0.01, 0.5)), "not one of the values of R (0.01, 0.1, 1)")


def test_ex4_not_attempted_and_never_raises():
    assert ch05.exercise_4(None).status == NOT_ATTEMPTED
    _assert_never_raises(ch05.exercise_4, GARBAGE + [(0.01,), (0.01, 1.0, 0.1), [[0.01, 1.0]],
                                                      ("a", "b"), (None, None), lambda: 0])


# --------------------------------------------------------------------------
# Exercise 5: which models need more than the bootstrap
# --------------------------------------------------------------------------

def _sees_new_noise(C_, G_) -> bool:
    """Given x_t-1, y_t = C A x_t-1 + C G w_t-1 + v_t depends on w_t-1 iff C G != 0."""
    return bool(np.any(np.abs(np.asarray(C_) @ np.asarray(G_)) > 0))


def right_5():
    dp = bf.models.damped_particle()
    position_rows = np.array([[1.0, 0, 0, 0], [0, 0, 1.0, 0]])     # dp measures the two positions
    np.testing.assert_array_equal(dp.C, position_rows)
    models = {"a": (dp.C, dp.G), "b": (dp.C, np.eye(4)), "c": ([[C]], [[1.0]])}
    return sorted(k for k, (C_, G_) in models.items() if _sees_new_noise(C_, G_))


def test_ex5_the_right_answer_is_accepted_in_several_forms():
    letters = right_5()
    assert letters == ["b", "c"]
    assert ch05.exercise_5(letters).correct
    assert ch05.exercise_5(tuple(reversed(letters))).correct
    assert ch05.exercise_5(set(letters)).correct
    assert ch05.exercise_5(", ".join(letters)).correct
    assert ch05.exercise_5(" and ".join(f"({x.upper()})" for x in letters)).correct


def test_ex5_the_damped_particle_included():
    _assert_wrong(ch05.exercise_5(["a", "b", "c"]), "damped particle (a)", "section 15")
    _assert_wrong(ch05.exercise_5(["a"]), "damped particle (a)")


def test_ex5_a_model_left_out():
    _assert_wrong(ch05.exercise_5(["b"]), "leaves out lg (c)")
    _assert_wrong(ch05.exercise_5(["c"]), "leaves out dp_pushed (b)")
    _assert_wrong(ch05.exercise_5([]), "empty")


def test_ex5_a_wrong_message_never_lists_the_answer():
    for wrong in (["a"], ["a", "b", "c"], ["b"], ["c"], [], ["a", "c"]):
        message = ch05.exercise_5(wrong).message
        assert "['b', 'c']" not in message and "b and c" not in message, message


def test_ex5_not_attempted_and_never_raises():
    assert ch05.exercise_5(None).status == NOT_ATTEMPTED
    _assert_wrong(ch05.exercise_5(["b", "d"]), "list of the letters")
    _assert_never_raises(ch05.exercise_5, GARBAGE + ["xyz", [1, 2], ["b", None], lambda: 0])


# --------------------------------------------------------------------------
# a teacher's edited statement is honoured (the checks read the answer cells' variables)
# --------------------------------------------------------------------------

def test_ex1_the_statement_s_arrays_are_tested():
    """An edited log_w_under_1 is the first test input: a function that fails only there is caught."""
    edited = np.array([-3000.0, -3000.5, -np.inf])
    def fails_on_the_edit(lw):
        if lw.size == 3 and np.isneginf(lw[-1]) and lw[0] == -3000.0:
            return lw, 0.0
        return right_log_normalize(lw)
    assert ch05.exercise_1(fails_on_the_edit).correct                 # the statement's own arrays
    _assert_wrong(ch05.exercise_1(fails_on_the_edit, namespace={"log_w_under_1": edited}), "test input 1")
    assert ch05.exercise_1(right_log_normalize, namespace={"log_w_under_1": edited,
                                                           "log_w_over_1": np.array([900.0, 1.0])}).correct


def test_ex2_an_edited_statement_is_honoured():
    ns = {"weights_a_2": np.array([0.7, 0.1, 0.1, 0.1])}
    right = [_ess([0.7, 0.1, 0.1, 0.1]), RIGHT_2[1], RIGHT_2[2]]
    assert ch05.exercise_2(right, namespace=ns).correct
    _assert_wrong(ch05.exercise_2(RIGHT_2, namespace=ns), "answer_2[0], the ESS of the weights (a)")


def test_ex4_an_edited_step_is_honoured():
    """With t_boot_4 = 6 the helper must read the bootstrap's ESS at t = 6, not at the statement's 5."""
    def mean_ess_at(t_boot):
        def mean_ess(R):
            lg = bf.models.LinearGaussian(A=[[A]], C=[[C]], Q=[[Q]], R=[[R]], m0=[0.0], P0=[[1.0]])
            rec, rngs = np.random.default_rng(14), [np.random.default_rng(15) for _ in range(2)]
            b, o = [], []
            for _ in range(10):
                ys = bf.models.simulate(lg, 40, rec).ys
                b.append(bf.particle.particle_filter(lg, ys, 500, rngs[0], ess_threshold=0).ess[t_boot])
                o.append(bf.particle.particle_filter(lg, ys, 500, rngs[1], ess_threshold=0,
                                                     proposal=bf.particle.optimal_proposal(lg)).ess[39])
            return np.mean(b), np.mean(o)
        return mean_ess
    ns = {"mean_ess": mean_ess_at(6), "t_boot_4": 6}
    assert ch05.exercise_4((0.01, 1.0), namespace=ns).correct
    fb = ch05.exercise_4((0.01, 1.0), namespace={"mean_ess": mean_ess_at(5), "t_boot_4": 6})
    _assert_wrong(fb, "mean_ess(0.01) reads the bootstrap's ESS at t = 5: index 6")


def test_the_messages_use_the_chapter_s_words():
    """eq. (8), not the source's eq. (13); the process noise is never w (a weight in chapters 05-06)."""
    assert "eq. (8)" in ch05.exercise_3(right_increment).message
    fb = ch05.exercise_3(_with(var=R))
    _assert_wrong(fb, "y_t = C x_t + v_t with x_t ~ N(A x_(t-1), Q)")
    for wrong in (["a", "b", "c"], ["b"], []):
        message = ch05.exercise_5(wrong).message
        assert "w_(t-1)" not in message and "new process noise" in message, message
    assert "new process noise" in ch05.exercise_5(["b", "c"]).message


# --------------------------------------------------------------------------
# the statements in the notebook give the numbers the checks use
# --------------------------------------------------------------------------

def test_the_notebook_states_the_numbers_of_the_checks():
    cells = json.loads(NOTEBOOK.read_text(encoding="utf-8"))["cells"]
    text = "\n".join("".join(c["source"]) for c in cells)
    exercises = text[text.index("## Exercises"):]
    for fragment in ["np.array([-1000.0, -1001.0, -1002.0, -np.inf])", "np.array([800.0, 799.5])",
                     "(0.4, 0.3, 0.2, 0.1)", "(1, 1, 2)", "(-1000, -1001, -1002, -\\infty)",
                     "$A = 0.9$, $G = 1$, $C = 1$", "R = 0.1", "R_values = (0.01, 0.1, 1.0)",
                     "$N = 500$, $T = 40$, 10", "$t = 5$", "$t = 39$", "`dp_pushed`"]:
        assert fragment in exercises, fragment
    for k in range(1, 6):
        assert f"bf.checks.ch05.exercise_{k}(" in exercises
