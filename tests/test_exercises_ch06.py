"""Tests of bayesfilt.checks.ch06, the checks of chapter 06's exercises.

For every exercise: the right answer, computed here independently of the
check module (a plain loop over the staircase, filterpy's systematic
resampling, closed forms confirmed by simulation, the experiments re-run
with other seeds), is accepted; plausible wrong answers are rejected with
their specific diagnosis (asserted on the message); ``None`` (or a function
that still raises ``NotImplementedError``) is "not attempted yet"; garbage
(text, wrong shapes, odd objects) gives feedback instead of raising; and no
message gives the reference values away.
"""

from __future__ import annotations

import contextlib
import json
import math
from pathlib import Path

import numpy as np
from scipy import stats
import pytest
from filterpy import monte_carlo

import bayesfilt as bf
from bayesfilt.checks import CORRECT, INCORRECT, NOT_ATTEMPTED, Feedback
from exercise_helpers import (  # noqa: F401 - the shared helpers of the exercise tests
    never_raises as _assert_never_raises, wrong as _assert_wrong,
)

ch06 = bf.checks.ch06
NOTEBOOK = Path(__file__).resolve().parents[1] / "notebooks" / "06_resampling.ipynb"

# the numbers of the statements, written out again (not imported from the module under test)
SIX = [0.05, 0.32, 0.08, 0.22, 0.13, 0.20]
W2, M2 = np.array([0.42, 0.28, 0.18, 0.12]), 10
GARBAGE = ["abc", b"x", {"a": 1}, [[1, 2], [3]], object(), 1 + 2j, [True, False], np.eye(4),
           np.full(3, np.nan), [], Ellipsis, 3, -1.5, [None, 1, 2], {1, 2}]


def _not_written(*args):
    raise NotImplementedError("Exercise N: write this function")


# --------------------------------------------------------------------------
# Exercise 1: my_systematic
# --------------------------------------------------------------------------

def loop_systematic(w, u):
    """Systematic resampling by a walk along the staircase (Arulampalam et al., Algorithm 2)."""
    w = [float(x) for x in w]
    total, n = sum(w), len(w)
    ancestors, i, c = [], 0, w[0] / total
    for j in range(n):
        p = (j + u) / n
        while p >= c and i < n - 1:          # move to the first i with p < C_i
            i += 1
            c += w[i] / total
        ancestors.append(i)
    return ancestors                         # a list of Python ints


def searchsorted_systematic(w, u):
    C = np.cumsum(w)
    C = C / C[-1]
    return np.searchsorted(C, (np.arange(len(w)) + u) / len(w), side="right")


def test_ex1_the_right_functions_are_accepted():
    for fun in (loop_systematic, searchsorted_systematic):
        fb = ch06.exercise_1(fun)
        assert fb.status == CORRECT, fb
        assert repr(fb).startswith("Correct")


def test_ex1_the_reference_agrees_with_filterpy_and_a_hand_computation():
    """The check's reference is bf.resampling.from_uniforms: filterpy and the staircase agree."""
    np.testing.assert_array_equal(bf.resampling.from_uniforms(SIX, np.full(6, 0.5)), [1, 1, 2, 3, 4, 5])
    w = np.random.default_rng(61).exponential(size=200)
    W = w / w.sum()
    for seed in range(5):
        saved = np.random.get_state()
        np.random.set_state(np.random.RandomState(seed).get_state())
        try:
            fp = monte_carlo.systematic_resample(W)
        finally:
            np.random.set_state(saved)
        u = np.random.RandomState(seed).random_sample()
        np.testing.assert_array_equal(loop_systematic(W, u), fp)


def test_ex1_counts_instead_of_indices():
    fb = ch06.exercise_1(lambda w, u: np.bincount(searchsorted_systematic(w, u), minlength=len(w)))
    _assert_wrong(fb, "offspring counts", "ancestor indices", "np.repeat")
    fb = ch06.exercise_1(lambda w, u: np.cumsum(np.bincount(searchsorted_systematic(w, u), minlength=len(w))))
    _assert_wrong(fb, "cumulative offspring counts")


def test_ex1_indices_shifted_by_one():
    def leading_zero(w, u):                  # C_(-1) = 0 kept in the array: one too many
        C = np.concatenate([[0.0], np.cumsum(w) / np.sum(w)])
        return np.searchsorted(C, (np.arange(len(w)) + u) / len(w), side="right")

    _assert_wrong(ch06.exercise_1(leading_zero), "shifted by one", "one more", "test input 1")
    _assert_wrong(ch06.exercise_1(lambda w, u: searchsorted_systematic(w, u) - 1),
                  "shifted by one", "one less")


def test_ex1_unsorted_and_out_of_range_indices():
    _assert_wrong(ch06.exercise_1(lambda w, u: searchsorted_systematic(w, u)[::-1]),
                  "wrong order", "sorted ascending")

    def past_the_end(w, u):                  # a last point that found no piece (C_(N-1) < 1)
        a = searchsorted_systematic(w, u)
        a[-1] = len(w)
        return a

    _assert_wrong(ch06.exercise_1(past_the_end), "index 6", "out of range", "0, ..., 5", "exactly 1")

    def negative(w, u):
        a = searchsorted_systematic(w, u)
        a[0] = -2
        return a

    _assert_wrong(ch06.exercise_1(negative), "index -2", "out of range")


def test_ex1_weights_not_normalised_and_side_left():
    def unnormalised(w, u):
        return np.searchsorted(np.cumsum(w), (np.arange(len(w)) + u) / len(w), side="right")

    _assert_wrong(ch06.exercise_1(unnormalised), "does not normalise", "test input 5", "sum to 3")

    def left(w, u):
        C = np.cumsum(w) / np.sum(w)
        return np.searchsorted(C, (np.arange(len(w)) + u) / len(w), side="left")

    _assert_wrong(ch06.exercise_1(left), "weight 0", "side='right'", "test input 4")


def test_ex1_the_wrong_comb():
    def additive(w, u):
        C = np.cumsum(w) / np.sum(w)
        return np.minimum(np.searchsorted(C, np.arange(len(w)) / len(w) + u, side="right"), len(w) - 1)

    def from_one(w, u):
        C = np.cumsum(w) / np.sum(w)
        return np.searchsorted(C, (np.arange(1, len(w) + 1) + u) / len(w), side="right")

    def no_u(w, u):
        return searchsorted_systematic(w, 0.0)

    _assert_wrong(ch06.exercise_1(from_one), "j = 1, ..., N")
    _assert_wrong(ch06.exercise_1(no_u), "ignores u")
    def additive_unclipped(w, u):
        C = np.cumsum(w) / np.sum(w)
        return np.searchsorted(C, np.arange(len(w)) / len(w) + u, side="right")

    _assert_wrong(ch06.exercise_1(additive_unclipped), "j/N + u", "(j + u)/N")
    fb = ch06.exercise_1(additive)
    assert fb.status == INCORRECT and "test input 1" in fb.message, fb
    _assert_wrong(ch06.exercise_1(lambda w, u: (np.arange(len(w)) + u) / len(w)), "points u_j")


def test_ex1_floats_lengths_and_in_place_changes():
    _assert_wrong(ch06.exercise_1(lambda w, u: searchsorted_systematic(w, u).astype(float)),
                  "floating-point", "integers")
    _assert_wrong(ch06.exercise_1(lambda w, u: np.append(searchsorted_systematic(w, u), len(w) - 1)),
                  "7 indices", "N = 6")
    _assert_wrong(ch06.exercise_1(lambda w, u: np.unique(searchsorted_systematic(w, u))),
                  "One index per point")

    def in_place(w, u):
        w /= w.sum()
        return searchsorted_systematic(w, u)

    _assert_wrong(ch06.exercise_1(in_place), "in place", "w /=")


def test_ex1_random_draws_instead_of_the_given_u():
    rng = np.random.default_rng(63)
    _assert_wrong(ch06.exercise_1(lambda w, u: bf.resampling.systematic(w, rng)), "random numbers",
                  "the given u")
    _assert_wrong(ch06.exercise_1(lambda w, u: np.sort(rng.choice(len(w), len(w), p=w / w.sum()))),
                  "called twice")


def test_ex1_an_unrecognised_mistake_names_the_point():
    def half_wrong(w, u):
        a = searchsorted_systematic(w, u)
        a[2] = a[3]                          # [1, 1, 3, 3, 4, 5] on the statement's input
        return a

    _assert_wrong(ch06.exercise_1(half_wrong), "test input 1", "j = 2", "first i with u_j < Ω^(i)")


def test_ex1_not_attempted_and_never_raises():
    assert ch06.exercise_1(None).status == NOT_ATTEMPTED
    assert ch06.exercise_1(_not_written).status == NOT_ATTEMPTED
    _assert_wrong(ch06.exercise_1(lambda w, u: len(w) and None), "forget `return`")
    _assert_wrong(ch06.exercise_1(lambda w, u: w[len(w)]), "IndexError", "exactly 1")
    funs = [lambda w, u: "x", lambda w, u: [1.0, 2.0], lambda w, u: np.ones((2, 3)), lambda w, u: 1 / 0,
            lambda w, u: np.full(len(w), np.nan), lambda w: 0, lambda w, u: np.ones(len(w), bool),
            lambda w, u: object(), lambda w, u: [[1], [2, 3]]]
    _assert_never_raises(ch06.exercise_1, GARBAGE + funs)
    for fun in funs:
        assert ch06.exercise_1(fun).status == INCORRECT, fun


# --------------------------------------------------------------------------
# Exercise 2: E[O^(2)] and Var(O^(2)) under three schemes
# --------------------------------------------------------------------------

RIGHT_2 = np.array([2.8, 2.016, 0.16, 0.48])   # M W, M W (1 - W), f (1 - f), f (1 - f/R); f = 0.8, R = 2


def test_ex2_the_closed_forms_agree_with_a_simulation():
    """10^5 resamplings of each scheme: means and variances within 5 standard errors."""
    rng = np.random.default_rng(62)
    K = 20_000
    for name, var in [("multinomial", RIGHT_2[1]), ("systematic", RIGHT_2[2]), ("residual", RIGHT_2[3])]:
        scheme = bf.resampling.SCHEMES[name]
        n1 = np.array([np.sum(scheme(W2, rng, M2) == 1) for _ in range(K)])
        assert abs(n1.mean() - RIGHT_2[0]) < 5 * n1.std() / math.sqrt(K), name
        # the standard error of a sample variance: sqrt((mu4 - var^2) / K)
        mu4 = np.mean((n1 - n1.mean()) ** 4)
        assert abs(n1.var(ddof=1) - var) < 5 * math.sqrt((mu4 - var**2) / K) + 1e-12, name
        if name == "systematic":
            assert set(np.unique(n1)) == {2, 3}


def test_ex2_the_right_answer_is_accepted():
    fb = ch06.exercise_2(RIGHT_2)
    assert fb.status == CORRECT, fb
    assert ch06.exercise_2(list(np.round(RIGHT_2, 3))).correct
    assert ch06.exercise_2(tuple(RIGHT_2 + 1e-3)).correct


def test_ex2_the_expected_count():
    _assert_wrong(ch06.exercise_2([0.28, *RIGHT_2[1:]]), "answer_2[0]", "probability W^(2)", "M W^(2)")
    _assert_wrong(ch06.exercise_2([3.0, *RIGHT_2[1:]]), "whole number")


def test_ex2_the_multinomial_variance():
    _assert_wrong(ch06.exercise_2([2.8, 2.8, 0.16, 0.48]), "answer_2[1]", "Poisson", "(1 - W^(2))")
    _assert_wrong(ch06.exercise_2([2.8, 0.28 * 0.72, 0.16, 0.48]), "one draw", "M W^(2) (1 - W^(2))")
    _assert_wrong(ch06.exercise_2([2.8, math.sqrt(2.016), 0.16, 0.48]), "standard deviation")
    _assert_wrong(ch06.exercise_2([2.8, 2.8 * (1 - 2.8), 0.16, 0.48]), "inside the bracket")


def test_ex2_the_systematic_variance():
    _assert_wrong(ch06.exercise_2([2.8, 2.016, 2.016, 0.48]), "answer_2[2]", "multinomial variance",
                  "floor(M W^(2)) or ceil(M W^(2))")
    _assert_wrong(ch06.exercise_2([2.8, 2.016, 0.8, 0.48]), "probability that O^(2) takes the larger")
    _assert_wrong(ch06.exercise_2([2.8, 2.016, 0.0, 0.48]), "always the same number")


def test_ex2_the_residual_variance():
    _assert_wrong(ch06.exercise_2([2.8, 2.016, 0.16, 0.16]), "answer_2[3]", "Count M̃ again")
    _assert_wrong(ch06.exercise_2([2.8, 2.016, 0.16, 2.016]), "only M̃ = M - sum_i floor(M W^(i))")
    _assert_wrong(ch06.exercise_2([2.8, 2.016, 0.16, 0.8 * (1 - 0.8 / 10)]), "divides φ by M")
    _assert_wrong(ch06.exercise_2([2.8, 2.016, 0.16, 0.8 * (1 - 0.8 / 3)]), "wrong number of residual draws")


def test_ex2_particle_0_order_and_shape():
    particle_0 = [4.2, 10 * 0.42 * 0.58, 0.16, 0.2 * (1 - 0.2 / 2)]
    _assert_wrong(ch06.exercise_2(particle_0), "particle 1 (weight 0.42)", "numbered from 0")
    _assert_wrong(ch06.exercise_2(RIGHT_2[[0, 1, 3, 2]]), "wrong order")
    _assert_wrong(ch06.exercise_2(RIGHT_2.reshape(2, 2)), "flat array")
    _assert_wrong(ch06.exercise_2(RIGHT_2[:3]), "four numbers")
    _assert_wrong(ch06.exercise_2([2.8, 2.016, 0.16, -0.3]), "negative")
    _assert_wrong(ch06.exercise_2([2.8, 2.03, 0.16, 0.48]), "answer_2[1]", "close but not exact")
    _assert_wrong(ch06.exercise_2([2.8, 2.016, 0.16, 0.7]), "answer_2[3]", "too large")


def test_ex2_messages_never_give_the_values_away():
    wrongs = [[0.28, *RIGHT_2[1:]], [2.8, 2.8, 0.16, 0.48], [2.8, 2.016, 2.016, 0.48],
              [2.8, 2.016, 0.16, 0.16], [2.8, 2.016, 0.16, 0.9], [1.0, 1.0, 1.0, 1.0]]
    for wrong in wrongs:
        message = ch06.exercise_2(wrong).message
        for secret in ("2.016", "0.48", "0.16 ", "= 0.8", "2.8,", "2.8 "):
            assert secret not in message, (secret, message)


def test_ex2_not_attempted_and_never_raises():
    assert ch06.exercise_2(None).status == NOT_ATTEMPTED
    _assert_never_raises(ch06.exercise_2, GARBAGE + [np.ones(4) * np.inf, ["2.8", 1, 1, 1]])


# --------------------------------------------------------------------------
# Exercise 3: the ESS threshold
# --------------------------------------------------------------------------

def _threshold_experiment(seed_records, seed_filters):
    """Section 3's twenty records with thresholds 0.1, 0.5, 0.9, with other seeds than the check's."""
    lg = bf.models.LinearGaussian(A=[[0.9]], C=[[1.0]], Q=[[1.0]], R=[[1.0]], m0=[0.0], P0=[[1.0]])
    batch = bf.models.simulate_many(lg, 20, 50, np.random.default_rng(seed_records))
    counts, rmse = [], []
    for theta in (0.1, 0.5, 0.9):
        rng = np.random.default_rng(seed_filters)
        n, sq = 0, []
        for ys in batch.ys:
            kf = bf.kalman.kalman_filter(lg, ys)
            res = bf.particle.particle_filter(lg, ys, 500, rng, ess_threshold=theta)
            n += res.resampled.sum()
            sq.append(np.mean((res.means[:, 0] - kf.means[:, 0]) ** 2 / kf.covs[:, 0, 0]))
        counts.append(n / 20)
        rmse.append(math.sqrt(np.mean(sq)))
    return np.array(counts), (0.1, 0.5, 0.9)[int(np.argmax(rmse))]


@pytest.fixture(scope="module")
def right_3():
    return _threshold_experiment(seed_records=301, seed_filters=302)


def test_ex3_the_right_answer_is_accepted_with_other_seeds(right_3):
    fb = ch06.exercise_3(right_3)
    assert fb.status == CORRECT, fb
    assert ch06.exercise_3([list(right_3[0]), right_3[1]]).correct
    assert ch06.exercise_3((right_3[0], f"theta = {right_3[1]}")).correct
    assert ch06.exercise_3(_threshold_experiment(seed_records=15, seed_filters=16)).correct


def test_ex3_the_answer_is_the_one_the_chapter_explains(right_3):
    """A low threshold lets the weights degenerate; 0.9 resamples at (almost) every step."""
    counts, worst = right_3
    assert worst == 0.1
    assert counts[0] < counts[1] < counts[2] and counts[2] > 49


def test_ex3_counts_as_a_total_a_fraction_or_the_complement(right_3):
    counts, worst = right_3
    _assert_wrong(ch06.exercise_3((20 * counts, worst)), "total over the 20 records")
    _assert_wrong(ch06.exercise_3((counts / 50, worst)), "fraction of the 50 steps")
    _assert_wrong(ch06.exercise_3((2 * counts, worst)), "percentage")
    _assert_wrong(ch06.exercise_3((50 - counts, worst)), "steps without resampling")
    _assert_wrong(ch06.exercise_3((counts[::-1], worst)), "reverse order")
    _assert_wrong(ch06.exercise_3((np.array([counts[0], counts[2], 2.0]), worst)),
                  "falls as the threshold rises")
    _assert_wrong(ch06.exercise_3((counts + [0, 8, 0], worst)), "too large for theta = 0.5")


def test_ex3_the_worst_threshold(right_3):
    counts, _ = right_3
    _assert_wrong(ch06.exercise_3((counts, 0.9)), "not the threshold with the largest RMSE")
    fb_05, fb_09 = ch06.exercise_3((counts, 0.5)), ch06.exercise_3((counts, 0.9))
    assert any("np.argmin" in fb.message for fb in (fb_05, fb_09))
    _assert_wrong(ch06.exercise_3((counts, 0.11)), "not the RMSE itself")
    _assert_wrong(ch06.exercise_3((counts, 2.0)), "must be one of the thresholds")


def test_ex3_the_pair_and_the_messages(right_3):
    counts, worst = right_3
    _assert_wrong(ch06.exercise_3(counts), "pair (resamplings, theta_worst)")
    _assert_wrong(ch06.exercise_3((worst, counts)), "wrong order")
    _assert_wrong(ch06.exercise_3((counts[:2], worst)), "three numbers")
    for wrong in [(20 * counts, worst), (counts, 0.9), (counts + [3, 0, 0], worst)]:
        message = ch06.exercise_3(wrong).message
        assert "9.4" not in message and "23.5" not in message and "0.103" not in message, message


def test_ex3_not_attempted_and_never_raises():
    assert ch06.exercise_3(None).status == NOT_ATTEMPTED
    _assert_never_raises(ch06.exercise_3, GARBAGE + [(None, None), ("a", "b"), ([1, 2, 3], None),
                                                     ([1, 2, 3], "x"), (np.ones(3), [0.1]),
                                                     ([1, 2, 3], 0.1, 0.5), (lambda: 0, 0.1)])


# --------------------------------------------------------------------------
# Exercise 4: tuning roughening
# --------------------------------------------------------------------------

def _roughened_lost_and_nees(model, sims, kappa, seed):
    """(lost runs, median NEES over t >= 30) of SIR with roughening, written out here."""
    rng = np.random.default_rng(seed)
    position = model.index_of("xi_x", "xi_y")
    d, N = 4, 500
    lost, nees = 0, []
    for xs, ys in zip(sims.xs, sims.ys):
        X = model.sample_initial(rng, N)
        errors, covs = [], []
        for t, y in enumerate(ys):
            if t > 0:
                X = model.sample_transition(rng, X, t=t - 1)
            log_w = model.measurement_logpdf(y, X)
            W = np.exp(log_w - log_w.max())
            W /= W.sum()
            mean = W @ X
            errors.append(xs[t] - mean)
            covs.append((X - mean).T @ (W[:, None] * (X - mean)))
            X = X[bf.resampling.systematic(W, rng)]
            X = X + kappa * (X.max(axis=0) - X.min(axis=0)) * N ** (-1 / d) * rng.standard_normal(X.shape)
        run_nees = []
        for e, c in zip(errors, covs):
            with contextlib.suppress(np.linalg.LinAlgError):
                run_nees.append(float(e @ np.linalg.solve(c, e)))
                continue
            run_nees.append(np.inf)
        nees.append(run_nees)
        lost += np.hypot(*errors[-1][position]) > 5
    return int(lost), float(np.median(np.array(nees)[:, 30:]))


@pytest.fixture(scope="module")
def right_4():
    vehicle = bf.models.range_bearing()
    sims = bf.models.simulate_many(vehicle, 20, 60, np.random.default_rng(401),
                                   x0=bf.models.RANGE_BEARING_TRUE_START)
    results = {k: _roughened_lost_and_nees(vehicle, sims, k, seed=402) for k in (0.1, 0.2, 2.0)}
    kappa_min = min(k for k, (lost, _) in results.items() if lost <= 5)
    return kappa_min, "overconfident" if results[kappa_min][1] > stats.chi2.median(4) else "conservative", results


def _exercise_4_500(*answers):
    return ch06.exercise_4(*answers, n_particles=500)


def test_ex4_the_right_answer_is_accepted_with_other_seeds(right_4):
    kappa_min, verdict, results = right_4
    assert (kappa_min, verdict) == (2.0, "conservative"), results
    assert results[0.1][0] > 5 and results[0.2][0] > 5, results
    fb = _exercise_4_500((kappa_min, verdict))
    assert fb.status == CORRECT, fb
    assert _exercise_4_500([np.float64(kappa_min), " Conservative "]).correct
    assert _exercise_4_500((kappa_min, "below")).correct
    # "below 4" compares with the mean, which the statement warns against
    _assert_wrong(_exercise_4_500((kappa_min, "below 4")), "must be one of the words")


def test_ex4_a_k_too_small_or_larger_than_needed():
    _assert_wrong(_exercise_4_500((0.1, "conservative")), "too small to separate the copies",
                  "more than 5 of the 20 runs")
    _assert_wrong(_exercise_4_500((0.2, "overconfident")), "too small")
    # 0.5 and 1.0 (the statement's values before issue 14) are no longer offered
    _assert_wrong(_exercise_4_500((1.0, "conservative")), "one of the roughening constants")


def test_ex4_the_verdict_read_the_wrong_way_round():
    _assert_wrong(_exercise_4_500((2.0, "overconfident")), "answer_4[1]", "median NEES", "mean d = 4")
    _assert_wrong(_exercise_4_500((2.0, "consistent")), "must be one of", "'consistent'")
    _assert_wrong(_exercise_4_500((2.0, 1.4)), "must be one of the words")


def test_ex4_not_a_k_and_the_pair_swapped():
    _assert_wrong(_exercise_4_500((0, "conservative")), "one of the roughening constants", "lost runs")
    _assert_wrong(_exercise_4_500((0.3, "conservative")), "one of the roughening constants")
    _assert_wrong(_exercise_4_500(("conservative", 2.0)), "wrong order")
    _assert_wrong(_exercise_4_500(0.5), "pair (kappa_min, verdict)")


def test_ex4_not_attempted_and_never_raises():
    assert _exercise_4_500(None).status == NOT_ATTEMPTED
    _assert_never_raises(_exercise_4_500, GARBAGE + [(None, None), ("a", "b"), (0.5,), (0.5, None),
                                                     (np.array([0.5, 1.0]), "below"), (np.nan, "below"),
                                                     (0.5, "conservative", 1), (lambda: 0, "x")])


# --------------------------------------------------------------------------
# a teacher's edited statement is honoured (the checks read the answer cells' variables)
# --------------------------------------------------------------------------

def test_ex1_the_statement_s_try_out_is_the_first_input():
    edited = {"W_1": np.array([0.5, 0.25, 0.25]), "u_1": 0.25}
    def fails_on_the_edit(w, u):
        if len(w) == 3 and u == 0.25 and w[0] == 0.5:
            return np.array([0, 1, 2])
        return searchsorted_systematic(w, u)
    assert ch06.exercise_1(fails_on_the_edit).correct
    _assert_wrong(ch06.exercise_1(fails_on_the_edit, namespace=edited), "test input 1")


def test_ex2_an_edited_statement_is_honoured():
    """W = (0.1, 0.45, 0.25, 0.2), M = 8: M W^(2) = 3.6, phi = 0.6, floors 0, 3, 2, 1, so M~ = 2."""
    ns = {"W_2": np.array([0.1, 0.45, 0.25, 0.2]), "M_2": 8}
    right = [3.6, 8 * 0.45 * 0.55, 0.6 * 0.4, 0.6 * (1 - 0.6 / 2)]
    assert ch06.exercise_2(right, namespace=ns).correct
    _assert_wrong(ch06.exercise_2(RIGHT_2, namespace=ns), "answer_2[0]")
    _assert_wrong(ch06.exercise_2(right, namespace={}), "answer_2[0]")


def test_ex3_the_notebook_s_records_and_seed_are_used(right_3):
    """With the notebook's batch_lg and seed_filters_3 = 302 (the test's own seeds), the check's
    reference is that experiment: the right answer for those seeds is accepted."""
    lg = bf.models.LinearGaussian(A=[[0.9]], C=[[1.0]], Q=[[1.0]], R=[[1.0]], m0=[0.0], P0=[[1.0]])
    ns = {"batch_lg": bf.models.simulate_many(lg, 20, 50, np.random.default_rng(301)), "lg_bench": lg,
          "seed_filters_3": 302, "N_3": 500}
    counts, worst = right_3
    assert ch06.exercise_3((counts, worst), namespace=ns).correct
    _assert_wrong(ch06.exercise_3((counts * 2, worst), namespace=ns), "answer_3[0]")


def test_ex4_kappa_values_are_read_from_the_notebook():
    ns = {"kappa_values": (2.0, 4.0)}
    assert ch06.exercise_4((2.0, "conservative"), 500, namespace=ns).correct
    _assert_wrong(ch06.exercise_4((0.1, "conservative"), 500, namespace=ns),
                  "must be one of the roughening constants [2.0, 4.0]")


# --------------------------------------------------------------------------
# the statements in the notebook give the numbers the checks use
# --------------------------------------------------------------------------

def test_the_notebook_states_the_numbers_of_the_checks():
    cells = json.loads(NOTEBOOK.read_text(encoding="utf-8"))["cells"]
    text = "\n".join("".join(c["source"]) for c in cells)
    exercises = text[text.index("## Exercises"):]
    for fragment in ["(0.05, 0.32, 0.08, 0.22, 0.13, 0.20)", "$u = 0.5$", "$u_j = (j + u)/N$",
                     "$W = (0.42, 0.28, 0.18, 0.12)$", "$M = 10$", "particle 1",
                     "$\\theta = 0.1$, $0.5$ and $0.9$", "$N = 500$", "`np.random.default_rng(16)`",
                     "$(0.1, 0.2, 2.0)$", "`np.random.default_rng(28)`", "above 5 m",
                     "at most 5 of the 20 runs", "$t \\ge 30$", "`stats.chi2.median(4)`"]:
        assert fragment in exercises, fragment
    for k in range(1, 5):
        assert f"bf.checks.ch06.exercise_{k}(" in exercises
    # the constants of the module are those of the statements
    assert ch06.SIX_WEIGHTS == tuple(SIX) and ch06.U_STATEMENT == 0.5
    assert ch06.WEIGHTS_2 == tuple(W2) and ch06.M_2 == M2 and ch06.PARTICLE_2 == 1
    assert ch06.THRESHOLDS_3 == (0.1, 0.5, 0.9) and ch06.N_3 == 500 and ch06.SEED_FILTERS_3 == 16
    assert ch06.KAPPA_VALUES_4 == (0.1, 0.2, 2.0) and ch06.SEED_FILTERS_4 == 28
    assert ch06.N_4 == 500
    wrong_n = ch06.exercise_4((2.0, "conservative"), "500")
    assert wrong_n.status == INCORRECT and "passes N_4" in wrong_n.message
    assert (ch06.MAX_LOST_4, ch06.LOST_METRES_4, ch06.T_FROM_4) == (5, 5.0, 30)
