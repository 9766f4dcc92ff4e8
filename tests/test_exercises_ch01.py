"""Tests of bayesfilt.checks.ch01, the checks of chapter 01's exercises.

For every exercise: the right answer, computed here independently of
``bf.bayes`` and of the check module (closed forms, plain numpy loops,
``scipy.stats.norm``), is accepted; plausible wrong answers are rejected with
their specific diagnosis (asserted on the message); ``None`` (or a function
that still raises ``NotImplementedError``) is "not attempted yet"; and garbage
(text, wrong shapes, odd objects) gives feedback instead of raising.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.stats import norm

import bayesfilt as bf
from bayesfilt.checks import CORRECT, INCORRECT, NOT_ATTEMPTED, Feedback
from exercise_helpers import (  # noqa: F401 - the shared helpers of the exercise tests
    never_raises as _assert_never_raises, wrong as _assert_wrong,
)

ch01 = bf.checks.ch01

# the numbers of the statements, written out again (not imported from the module under test)
N = 50
DOORS = [2, 5, 6, 14, 22, 23, 31, 37, 38, 45]
SLIP = np.array([0.05, 0.85, 0.10])
GARBAGE = ["abc", b"x", {"a": 1}, [[1, 2], [3]], object(), 1 + 2j, [True, False], np.eye(4),
           np.full(3, np.nan), [], lambda x: x, Ellipsis]


def _ring_move() -> np.ndarray:
    """move[i, j]: from cell i to i, i+1, i+2 (mod N) with the slip probabilities."""
    move = np.zeros((N, N))
    for i in range(N):
        for d, p in enumerate(SLIP):
            move[i, (i + d) % N] += p
    return move


def _door_sensor() -> np.ndarray:
    door = np.isin(np.arange(N), DOORS)
    return np.array([np.where(door, 0.10, 0.95), np.where(door, 0.90, 0.05)])


def _filter(initial, likelihoods, move):
    """Plain numpy Bayes recursion: (priors, posteriors, log evidence)."""
    b = np.asarray(initial, dtype=float)
    priors, posts, log_ev = [], [], 0.0
    for t, lik in enumerate(likelihoods):
        if t > 0:
            b = b @ move
        priors.append(b)
        joint = b * lik
        log_ev += math.log(joint.sum())
        b = joint / joint.sum()
        posts.append(b)
    return np.array(priors), np.array(posts), log_ev


def _simulate(seed: int):
    move, sensor = _ring_move(), _door_sensor()
    rng = np.random.default_rng(seed)
    x = np.empty(40, dtype=int)
    x[0] = 22
    for t in range(1, 40):
        x[t] = rng.choice(N, p=move[x[t - 1]])
    y = (rng.random(40) < sensor[1, x]).astype(int)
    return x, y


def _near(belief, cell, half_width=2):
    return belief[np.mod(cell + np.arange(-half_width, half_width + 1), N)].sum()


# --------------------------------------------------------------------------
# Exercise 1: update_by_hand
# --------------------------------------------------------------------------

def right_update(prior, likelihood):
    joint = np.asarray(prior, dtype=float) * np.asarray(likelihood, dtype=float)
    return joint / joint.sum()


def test_ex1_the_right_update_is_accepted():
    fb = ch01.exercise_1(right_update)
    assert fb.status == CORRECT, fb
    assert repr(fb).startswith("Correct")


def test_ex1_a_prior_normalised_first_is_accepted_too():
    def update(prior, likelihood):
        p = prior / np.sum(prior)
        return p * likelihood / np.sum(p * likelihood)
    assert ch01.exercise_1(update).correct


def test_ex1_unnormalised_posterior():
    _assert_wrong(ch01.exercise_1(lambda p, l: p * l), "not normalised", "evidence", "test input 1")
    # normalised by the wrong sum: still a factor off, still "not normalised"
    _assert_wrong(ch01.exercise_1(lambda p, l: p * l / np.sum(l)), "not normalised")


def test_ex1_dividing_instead_of_multiplying():
    def divided(prior, likelihood):
        v = prior / likelihood
        return v / v.sum()
    _assert_wrong(ch01.exercise_1(divided), "divide where Bayes' rule multiplies")
    _assert_wrong(ch01.exercise_1(lambda p, l: p / l), "divide where Bayes' rule multiplies")
    _assert_wrong(ch01.exercise_1(lambda p, l: (l / p) / np.sum(l / p)), "divide")


def test_ex1_division_by_a_zero_likelihood_is_named():
    # a function that only goes wrong where the likelihood is 0 (test input 4)
    def divides_by_zero(prior, likelihood):
        joint = prior * likelihood
        return joint / joint.sum() * (likelihood / likelihood)
    _assert_wrong(ch01.exercise_1(divides_by_zero), "NaN or inf", "you divide by it", "test input 4")


def test_ex1_likelihood_or_prior_ignored_or_added():
    _assert_wrong(ch01.exercise_1(lambda p, l: p / np.sum(p)), "does not depend on the likelihood")
    _assert_wrong(ch01.exercise_1(lambda p, l: l / np.sum(l)), "the prior is missing",
                  "test input 2")
    _assert_wrong(ch01.exercise_1(lambda p, l: (p + l) / np.sum(p + l)), "add prior and")


def test_ex1_returning_the_evidence_too():
    def pair(prior, likelihood):
        joint = prior * likelihood
        return joint / joint.sum(), joint.sum()
    _assert_wrong(ch01.exercise_1(pair), "only the posterior")
    _assert_wrong(ch01.exercise_1(lambda p, l: bf.bayes.update(p, l)), "only the posterior")


def test_ex1_in_place_arithmetic():
    def in_place(prior, likelihood):
        prior *= likelihood
        prior /= prior.sum()
        return prior
    _assert_wrong(ch01.exercise_1(in_place), "in place", "prior")

    def in_place_float_first(prior, likelihood):   # survives the int counts, overwrites likelihood
        likelihood *= prior
        likelihood /= likelihood.sum()
        return likelihood
    _assert_wrong(ch01.exercise_1(in_place_float_first), "in place", "likelihood")

    def in_place_on_counts(prior, likelihood):     # right on floats, fails on the int counts
        if prior.dtype.kind == "f":
            return right_update(prior, likelihood)
        prior *= likelihood
        return prior / prior.sum()
    _assert_wrong(ch01.exercise_1(in_place_on_counts), "integer", "test input 2")


def test_ex1_not_attempted_and_no_return():
    def stub(prior, likelihood):
        """Posterior."""
        raise NotImplementedError("Exercise 1: write this function")
    for answer in (None, stub):
        fb = ch01.exercise_1(answer)
        assert fb.status == NOT_ATTEMPTED, fb
        assert repr(fb).startswith("Not attempted yet")

    def no_return(prior, likelihood):
        prior * likelihood
    _assert_wrong(ch01.exercise_1(no_return), "forget `return`")


def test_ex1_never_raises_on_garbage():
    def raises(prior, likelihood):
        raise KeyError("oops")
    functions = [lambda p, l: "text", lambda p, l: 0.5, lambda p, l: np.ones((2, 2)),
                 lambda p, l: [[1], [2, 3]], lambda p, l: np.full(p.shape, np.nan), raises,
                 lambda p: p, lambda p, l: {"posterior": p}]
    _assert_never_raises(ch01.exercise_1, GARBAGE + functions)
    _assert_wrong(ch01.exercise_1(raises), "fails on test input 1", "KeyError")
    _assert_wrong(ch01.exercise_1("update"), "must be a function")


# --------------------------------------------------------------------------
# Exercise 2: Thrun's door, push then "closed", three times
# --------------------------------------------------------------------------

def _door(prediction=True, p_closed=(0.4, 0.8)):
    """bel(open) after each push + reading, by the closed-form two-state recursion."""
    b, out = 0.5, []
    for _ in range(3):
        if prediction:
            b = b + 0.8 * (1 - b)                  # a push opens a closed door w.p. 0.8
        b = p_closed[0] * b / (p_closed[0] * b + p_closed[1] * (1 - b))
        out.append(b)
    return np.array(out)


def test_ex2_the_right_beliefs_are_accepted():
    ref = _door()
    assert np.isclose(ref[0], 9 / 11)               # 0.4 * 0.9 / (0.4 * 0.9 + 0.8 * 0.1)
    assert ch01.exercise_2(ref).correct
    assert ch01.exercise_2(list(np.round(ref, 3))).correct     # three decimals are enough
    assert ch01.exercise_2(tuple(ref)).correct


def test_ex2_plausible_mistakes_are_named():
    ref = _door()
    _assert_wrong(ch01.exercise_2(1 - ref), "bel(closed)")
    _assert_wrong(ch01.exercise_2(_door(prediction=False)), "no push")
    _assert_wrong(ch01.exercise_2(_door(p_closed=(0.6, 0.2))), "sense open")
    # the update before the push: the value reported is the prior after the push
    b, swapped = 0.5, []
    for _ in range(3):
        b = 0.4 * b / (0.4 * b + 0.8 * (1 - b))
        b = b + 0.8 * (1 - b)
        swapped.append(b)
    _assert_wrong(ch01.exercise_2(swapped), "after the push")
    # no normalisation: p(open) * 0.4 after each push, never divided by the evidence
    b, unnormalised = np.array([0.5, 0.5]), []
    for _ in range(3):
        b = np.array([b[0] + 0.8 * b[1], 0.2 * b[1]]) * [0.4, 0.8]
        unnormalised.append(b[0])
    _assert_wrong(ch01.exercise_2(unnormalised), "not normalised")
    # the push applied down the columns: prior = push @ belief
    b, transposed = np.array([0.5, 0.5]), []
    for _ in range(3):
        b = np.array([[1.0, 0.0], [0.8, 0.2]]) @ b * [0.4, 0.8]
        b = b / b.sum()
        transposed.append(b[0])
    _assert_wrong(ch01.exercise_2(transposed), "transition @ belief")
    _assert_wrong(ch01.exercise_2([ref[0], 0.5, 0.5]), "first value right")


def test_ex2_shapes():
    ref = _door()
    _assert_wrong(ch01.exercise_2(ref[0]), "first value only")
    _assert_wrong(ch01.exercise_2(np.column_stack([ref, 1 - ref])), "whole beliefs")
    _assert_wrong(ch01.exercise_2(ref[:2]), "shape")


def test_ex2_not_attempted_and_garbage():
    assert ch01.exercise_2(None).status == NOT_ATTEMPTED
    _assert_never_raises(ch01.exercise_2, GARBAGE + [np.zeros((3, 2)), -1.0, "0.818"])


# --------------------------------------------------------------------------
# Exercise 3: a position sensor, log evidence with std 3 m and 1 m
# --------------------------------------------------------------------------

def _position_log_evidence(std, density=None, initial=None):
    x, _ = _simulate(3)
    ys = x + 3.0 * np.random.default_rng(5).standard_normal(40)
    cells = np.arange(N)
    density = density or (lambda y, s: norm.pdf(y, loc=cells, scale=s))
    liks = [density(y, std) for y in ys]
    initial = np.full(N, 1 / N) if initial is None else initial
    return _filter(initial, liks, _ring_move())[2]


@pytest.fixture(scope="module")
def ex3_ref():
    return np.array([_position_log_evidence(3.0), _position_log_evidence(1.0)])


def test_ex3_the_right_log_evidences_are_accepted(ex3_ref):
    assert ex3_ref[0] > ex3_ref[1]          # the true noise level wins (by far, for this record)
    assert ch01.exercise_3(ex3_ref).correct
    assert ch01.exercise_3(list(np.round(ex3_ref, 2))).correct


def test_ex3_plausible_mistakes_are_named(ex3_ref):
    _assert_wrong(ch01.exercise_3(ex3_ref[::-1]), "swapped")
    def unnormalised_density(y, s):
        return np.exp(-0.5 * ((y - np.arange(N)) / s) ** 2)
    unnormalised = np.array([_position_log_evidence(s, unnormalised_density) for s in (3.0, 1.0)])
    _assert_wrong(ch01.exercise_3(unnormalised), "lacks the constant", "std 3 m")
    _assert_wrong(ch01.exercise_3([_position_log_evidence(9.0), ex3_ref[1]]), "variance 9")
    _assert_wrong(ch01.exercise_3(np.exp(ex3_ref)), "not a log evidence")
    _assert_wrong(ch01.exercise_3(ex3_ref / np.log(10)), "log10")
    _assert_wrong(ch01.exercise_3(ex3_ref / 40), "per step")
    _assert_wrong(ch01.exercise_3(-ex3_ref), "wrong sign")
    started = _position_log_evidence(1.0, initial=np.eye(N)[22])
    _assert_wrong(ch01.exercise_3([ex3_ref[0], started]), "std 1 m", "true cell 22")
    _assert_wrong(ch01.exercise_3([ex3_ref[0], -np.inf]), "-inf")


def test_ex3_not_attempted_shapes_and_garbage(ex3_ref):
    assert ch01.exercise_3(None).status == NOT_ATTEMPTED
    _assert_wrong(ch01.exercise_3(ex3_ref[0]), "single number")
    _assert_wrong(ch01.exercise_3([ex3_ref[0], ex3_ref[1], 0.0]), "shape")
    _assert_never_raises(ch01.exercise_3, GARBAGE + [[1e308, -1e308], np.zeros((2, 2))])


# --------------------------------------------------------------------------
# Exercise 4: ambiguity over the seeds 0-19
# --------------------------------------------------------------------------

@pytest.fixture(scope="module")
def ex4_masses():
    """For each seed: (mass near x_39 of the posterior, of the prior, posterior at t = 38)."""
    move, sensor = _ring_move(), _door_sensor()
    out = {}
    for seed in range(20):
        x, y = _simulate(seed)
        priors, posts, _ = _filter(np.full(N, 1 / N), sensor[y], move)
        out[seed] = (_near(posts[-1], x[-1]), _near(priors[-1], x[-1]), _near(posts[-2], x[-2]),
                     posts[-1][x[-1]])
    return out


def test_ex4_the_right_seeds_are_accepted(ex4_masses):
    ref = [s for s, m in ex4_masses.items() if m[0] < 0.5]
    assert 0 < len(ref) < 20
    assert ch01.exercise_4(ref).correct
    assert ch01.exercise_4(np.array(ref[::-1])).correct        # any order, any sequence type
    assert ch01.exercise_4(set(ref)).correct


def test_ex4_plausible_mistakes_are_named(ex4_masses):
    ref = [s for s, m in ex4_masses.items() if m[0] < 0.5]
    _assert_wrong(ch01.exercise_4(len(ref)), "not how many")
    _assert_wrong(ch01.exercise_4([s for s in range(20) if s not in ref]), "at least 0.5")
    prior_based = [s for s, m in ex4_masses.items() if m[1] < 0.5]
    assert prior_based != ref
    _assert_wrong(ch01.exercise_4(prior_based), "prior")
    at_38 = [s for s, m in ex4_masses.items() if m[2] < 0.5]
    assert at_38 != ref
    _assert_wrong(ch01.exercise_4(at_38), "t = 38")
    cell_only = [s for s, m in ex4_masses.items() if m[3] < 0.5]
    assert cell_only != ref
    _assert_wrong(ch01.exercise_4(cell_only), "true cell alone")
    _assert_wrong(ch01.exercise_4(ref + [20]), "outside the seeds 0 to 19")
    _assert_wrong(ch01.exercise_4(ref + ref[:1]), "more than once")
    _assert_wrong(ch01.exercise_4(ref[1:]), "missing")
    extra = next(s for s in range(20) if s not in ref)
    _assert_wrong(ch01.exercise_4(ref + [extra]), "should not be there")
    _assert_wrong(ch01.exercise_4([m[0] < 0.5 for m in ex4_masses.values()]), "True/False")


def test_ex4_not_attempted_and_garbage():
    assert ch01.exercise_4(None).status == NOT_ATTEMPTED
    _assert_never_raises(ch01.exercise_4, GARBAGE + [6.0, [0.5], [[0, 4]], np.float64(3), "0, 4"])


# --------------------------------------------------------------------------
# Exercise 5: mean and variance of the distance in 20 steps
# --------------------------------------------------------------------------

def test_ex5_the_closed_form_is_accepted():
    step_mean = 0 * 0.05 + 1 * 0.85 + 2 * 0.10                       # 1.05
    step_var = 0 * 0.05 + 1 * 0.85 + 4 * 0.10 - step_mean ** 2       # 0.1475
    assert ch01.exercise_5(np.array([20 * step_mean, 20 * step_var])).correct
    assert ch01.exercise_5([21, 2.95]).correct


def test_ex5_plausible_mistakes_are_named():
    _assert_wrong(ch01.exercise_5([2.95, 21]), "swapped")
    _assert_wrong(ch01.exercise_5([20, 2.95]), "commanded distance")
    _assert_wrong(ch01.exercise_5([1.05, 0.1475]), "mean of one step")
    _assert_wrong(ch01.exercise_5([21, 0.1475]), "variance of one step")
    _assert_wrong(ch01.exercise_5([21, 400 * 0.1475]), "20^2")
    _assert_wrong(ch01.exercise_5([21, math.sqrt(2.95)]), "standard deviation")
    _assert_wrong(ch01.exercise_5([21, 20 * 1.25]), "second moment")
    _assert_wrong(ch01.exercise_5([21, 2.95 + 21 ** 2]), "second moment")
    _assert_wrong(ch01.exercise_5([21, 20 * (0.05 + 0.10)]), "commanded move")
    _assert_wrong(ch01.exercise_5([21, 5.0]), "too large")
    _assert_wrong(ch01.exercise_5([22, 2.95]), "mean", "too large")


def test_ex5_not_attempted_shapes_and_garbage():
    assert ch01.exercise_5(None).status == NOT_ATTEMPTED
    _assert_wrong(ch01.exercise_5(21), "two numbers")
    _assert_wrong(ch01.exercise_5([[21, 2.95]]), "shape")
    _assert_never_raises(ch01.exercise_5, GARBAGE + [[21, "2.95"], [np.inf, 1.0]])


# --------------------------------------------------------------------------
# every check: its statement's numbers, and no solution in any message
# --------------------------------------------------------------------------

def test_messages_never_show_the_reference(ex3_ref):
    """Wrong answers get messages without the reference numbers (as the check would print them)."""
    wrong = [(ch01.exercise_2, [0.1, 0.2, 0.3], ["0.818", "0.93", "0.972"]),
             (ch01.exercise_3, [1.0, 2.0], [f"{ex3_ref[0]:.1f}", f"{ex3_ref[1]:.1f}"]),
             (ch01.exercise_5, [1.0, 1.0], ["21", "2.95"])]
    for check, answer, secrets in wrong:
        message = check(answer).message
        for secret in secrets:
            assert secret not in message, (secret, message)
