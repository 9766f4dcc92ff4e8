"""Tests of bayesfilt.checks.ch02, the checks of the exercises of chapter 02.

For every exercise: the reference answer, computed here independently of the
check (closed-form numpy, a plain-numpy grid filter, a Monte Carlo regression),
is accepted; plausible wrong answers are rejected, each with its own diagnosis;
None and NotImplementedError mean "not attempted yet"; garbage never raises.
The inputs of the notebook's statements are the module's constants.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

import bayesfilt as bf
from bayesfilt.checks import CORRECT, INCORRECT, NOT_ATTEMPTED, Feedback
from exercise_helpers import (  # noqa: F401 - the shared helpers of the exercise tests
    solution_names, correct, hides as _hides, not_attempted, not_implemented, wrong,
)


def hides(fb, expected):
    _hides(fb, expected, digits=3)

ch02 = bf.checks.ch02
ROOT = Path(__file__).resolve().parents[1]
NOTEBOOK = ROOT / "notebooks" / "02_kalman_derivation.ipynb"

P = np.array([[1.2, 0.45], [0.45, 0.34]])
C = np.array([[1.0, 0.0]])
R = np.array([[1.0]])
K = np.array([[0.5], [0.1]])
inv = np.linalg.inv


def joseph(P, C, R, K):
    IKC = np.eye(P.shape[0]) - K @ C
    return IKC @ P @ IKC.T + K @ R @ K.T


def gain_by_inverse(P, C, R):
    return P @ C.T @ inv(C @ P @ C.T + R)


GARBAGE = ["text", [[1.0, 2.0], [3.0]], np.ones(3), np.ones((3, 3)), np.full((2, 2), np.nan),
           {"a": 1}, object(), True, np.array([[1j, 0], [0, 1]]), [], np.full((2, 2), 1e308)]


# ---------------------------------------------------------------------------
# The statements and the module use the same numbers; the answer cells follow the pattern
# ---------------------------------------------------------------------------

def _cells():
    nb = json.loads(NOTEBOOK.read_text(encoding="utf-8"))
    return [("".join(c["source"]), c["cell_type"]) for c in nb["cells"]]


def _given(cell_source: str) -> dict:
    """Run the lines of an answer cell before its solution block (the given numbers)."""
    head = cell_source.split("### BEGIN SOLUTION")[0]
    namespace = {"np": np}
    exec(head, namespace)  # noqa: S102 - the notebook's own given-numbers lines
    return namespace


def _answer_cells() -> dict[int, str]:
    cells, out, n = _cells(), {}, None
    for source, kind in cells:
        if kind == "markdown" and source.startswith("### Exercise "):
            n = int(source.split()[2])
        elif kind == "code" and "### BEGIN SOLUTION" in source:
            out[n] = source
    return out


def test_the_notebook_states_the_numbers_of_the_module():
    cells = _answer_cells()
    assert sorted(cells) == [1, 2, 3, 4, 5]
    given_1, given_3 = _given(cells[1]), _given(cells[3])
    np.testing.assert_array_equal(given_1["P_1"], ch02.P_EX)
    np.testing.assert_array_equal(given_1["C_1"], ch02.C_EX)
    np.testing.assert_array_equal(given_1["R_1"], ch02.R_EX)
    np.testing.assert_array_equal(given_1["K_1"], ch02.K_1)
    np.testing.assert_array_equal(given_3["P_3"], ch02.P_EX)
    np.testing.assert_array_equal(given_3["C_3"], ch02.C_EX)
    np.testing.assert_array_equal(given_3["R_3"], ch02.R_3)
    text = "\n".join(source for source, kind in _cells() if kind == "markdown")
    assert "a = \\sqrt{1.5}" in text and "0.9\\,x_{\\mathrm{prev}}" in text and "D = 0.2" in text
    assert ch02.HALF_WIDTH_4 == np.sqrt(1.5) and ch02.D_5[0, 0] == 0.2 and ch02.R_3[0, 0] == 0.25


def test_solution_blocks_hold_only_defs_and_answer_assignments():
    """What tools/make_student_edition.py can stub: top-level defs and assignments only."""
    answers = {1: {"excess_1"}, 2: {"kalman_gain"}, 3: {"info_3"},
               4: {"grid_means_uniform", "agree_4", "meaning_4"}, 5: {"correlated_gain"}}
    for n, source in _answer_cells().items():
        assert solution_names(source) == answers[n], n


def test_check_cells_are_a_single_call():
    calls = [source for source, kind in _cells() if kind == "code" and "bf.checks.ch02" in source]
    # exercise 4's check takes grid_means_uniform too once issue 13's notebook changes are in
    ex4 = {"bf.checks.ch02.exercise_4(agree_4, meaning_4)",
           "bf.checks.ch02.exercise_4(agree_4, meaning_4, grid_means_uniform)"}
    assert calls[3] in ex4, calls[3]
    assert calls[:3] + calls[4:] == ["bf.checks.ch02.exercise_1(excess_1)",
                                     "bf.checks.ch02.exercise_2(kalman_gain)",
                                     "bf.checks.ch02.exercise_3(info_3)",
                                     "bf.checks.ch02.exercise_5(correlated_gain)"]


def test_the_given_numbers_are_read_only():
    with pytest.raises(ValueError):
        ch02.P_EX[0, 0] = 5.0


# ---------------------------------------------------------------------------
# Exercise 1: P+(K) - P+(K*)
# ---------------------------------------------------------------------------

K_STAR = gain_by_inverse(P, C, R)
S = C @ P @ C.T + R
EXCESS = joseph(P, C, R, K) - joseph(P, C, R, K_STAR)


def test_exercise_1_accepts_both_sides_of_the_identity():
    np.testing.assert_allclose((K - K_STAR) @ S @ (K - K_STAR).T, EXCESS, atol=1e-14)
    correct(ch02.exercise_1(EXCESS))
    correct(ch02.exercise_1((K - K_STAR) @ S @ (K - K_STAR).T))
    correct(ch02.exercise_1(EXCESS.tolist()))


@pytest.mark.parametrize("answer, phrases", [
    (P - K @ C @ P - joseph(P, C, R, K_STAR), ["P - KCP", "Joseph form"]),
    ((np.eye(2) - K @ C) @ P @ (np.eye(2) - K @ C).T - joseph(P, C, R, K_STAR), ["K R K^T"]),
    ((K - P @ C.T / 1.2) @ (C @ P @ C.T) @ (K - P @ C.T / 1.2).T, ["R left out"]),
    ((K - K_STAR) @ (C @ P @ C.T) @ (K - K_STAR).T, ["left R out"]),
    (float(S[0, 0] * np.sum((K - K_STAR) ** 2)), ["single number", "outer product"]),
    (-EXCESS, ["wrong sign", "positive semi-definite"]),
    (joseph(P, C, R, K), ["P+(K) itself"]),
])
def test_exercise_1_diagnoses(answer, phrases):
    fb = ch02.exercise_1(answer)
    wrong(fb, *phrases)
    hides(fb, EXCESS)


def test_exercise_1_not_attempted_and_garbage():
    not_attempted(ch02.exercise_1(None))
    for garbage in GARBAGE:
        fb = ch02.exercise_1(garbage)
        assert fb.status == INCORRECT, (garbage, fb)
    wrong(ch02.exercise_1(EXCESS.T.reshape(1, 4)), "wrong shape")


# ---------------------------------------------------------------------------
# Exercise 2: kalman_gain(P, C, R)
# ---------------------------------------------------------------------------

def test_exercise_2_accepts_the_gain_by_inverse_and_by_solve():
    correct(ch02.exercise_2(gain_by_inverse))
    correct(ch02.exercise_2(lambda P, C, R: np.linalg.solve(C @ P @ C.T + R, C @ P).T))


def test_exercise_2_an_input_changed_in_place_is_not_yet():
    def spoils_its_input(P, C, R):
        K = gain_by_inverse(P, C, R)
        P[...] = 0.0
        R[...] = -1.0
        return K
    wrong(ch02.exercise_2(spoils_its_input), "in place", "test input")


@pytest.mark.parametrize("fun, phrases", [
    (lambda P, C, R: P @ C.T @ inv(C @ P @ C.T), ["test input 1", "without R"]),
    (lambda P, C, R: gain_by_inverse(P, C, R).T, ["transposed", "shape (n, m)"]),
    (lambda P, C, R: P @ C.T @ (C @ P @ C.T + R), ["instead of by its inverse"]),
    (lambda P, C, R: P @ C.T @ inv(R), ["R alone"]),
    (lambda P, C, R: P @ C.T / (C @ P @ C.T + R), ["test input 3", "entry by entry"]),
    (lambda P, C, R: (inv(C @ P @ C.T + R) @ P @ C.T if C.shape[0] == P.shape[0]
                      else gain_by_inverse(P, C, R)), ["test input 3", "from the left"]),
])
def test_exercise_2_diagnoses(fun, phrases):
    fb = ch02.exercise_2(fun)
    wrong(fb, *phrases)
    hides(fb, K_STAR)


def test_exercise_2_hints_on_failures():
    # the information form inverts P, which fails on P = 0
    info_form = (lambda P, C, R: inv(inv(P) + C.T @ inv(R) @ C) @ C.T @ inv(R))
    wrong(ch02.exercise_2(info_form), "test input 5", "LinAlgError", "P = 0")
    # a division by S that cannot broadcast (n = 3, m = 2)
    wrong(ch02.exercise_2(lambda P, C, R: (P @ C.T) / (C @ P @ C.T + R) if P.shape[0] == 3
                          else gain_by_inverse(P, C, R)),
          "test input 4", "not a division")
    wrong(ch02.exercise_2(lambda P, C, R: P @ C @ inv(C @ P @ C.T + R)), "check the shapes")
    wrong(ch02.exercise_2(lambda P, C, R: inv(C @ P @ C.T + R) @ P @ C.T), "test input 1",
          "check the shapes")
    wrong(ch02.exercise_2(lambda P, C, R: gain_by_inverse(P, C, R)[:, 0]), "reshape")
    def no_return(P, C, R):
        K = gain_by_inverse(P, C, R)  # noqa: F841 - the forgotten return is the point
    wrong(ch02.exercise_2(no_return), "forget `return`")
    wrong(ch02.exercise_2(lambda P, C, R: None), "forget `return`")  # a lambda is never a stub


def test_exercise_2_not_attempted_and_garbage():
    not_attempted(ch02.exercise_2(None))
    fb = ch02.exercise_2(not_implemented)
    not_attempted(fb)
    assert "still raises NotImplementedError" in fb.message
    for garbage in [3, "kalman_gain", np.eye(2), lambda P: P, lambda P, C, R: "K",
                    lambda P, C, R: {"K": 1}, lambda P, C, R: np.full((2, 1), np.nan),
                    lambda P, C, R: 1 / 0, lambda P, C, R: [[1.0], [2.0, 3.0]],
                    lambda P, C, R: np.full((P.shape[0], C.shape[0]), 1e308)]:
        fb = ch02.exercise_2(garbage)
        assert fb.status == INCORRECT, fb


# ---------------------------------------------------------------------------
# Exercise 3: the posterior precision
# ---------------------------------------------------------------------------

R3 = np.array([[0.25]])
INFO = inv(P) + C.T @ inv(R3) @ C


def test_exercise_3_accepts_the_posterior_precision():
    K3 = gain_by_inverse(P, C, R3)
    np.testing.assert_allclose(inv(P - K3 @ C @ P), INFO, rtol=1e-12)  # the two forms agree
    correct(ch02.exercise_3(INFO))
    correct(ch02.exercise_3(inv(P - K3 @ C @ P)))


@pytest.mark.parametrize("answer, phrases", [
    (inv(INFO), ["posterior covariance", "inverse"]),
    (C.T @ inv(R3) @ C, ["measurement's precision", "alone"]),
    (inv(P), ["precision of the prediction", "alone"]),
    (P + C.T @ inv(R3) @ C, ["added the covariance P"]),
    (inv(P) + C.T @ R3 @ C, ["R is not inverted"]),
    (inv(P) - C.T @ inv(R3) @ C, ["cannot remove"]),
])
def test_exercise_3_diagnoses(answer, phrases):
    fb = ch02.exercise_3(answer)
    wrong(fb, *phrases)
    hides(fb, INFO)


def test_exercise_3_not_attempted_and_garbage():
    not_attempted(ch02.exercise_3(None))
    for garbage in GARBAGE:
        assert ch02.exercise_3(garbage).status == INCORRECT, garbage


# ---------------------------------------------------------------------------
# Exercise 4: uniform process noise on the grid
# ---------------------------------------------------------------------------

def test_exercise_4_reference_by_a_plain_numpy_grid_filter():
    """Only the update of x_0 involves no transition: the means agree at t = 0 only."""
    model = bf.models.LinearGaussian(A=[[0.9]], C=[[0.5]], Q=[[0.5]], R=[[0.4]], m0=[1.0],
                                     P0=[[2.0]])
    ys = bf.models.simulate(model, 10, np.random.default_rng(3)).ys[:, 0]
    kf_means = np.empty(10)      # the scalar Kalman filter, written out
    m, v = 1.0, 2.0
    for t, y in enumerate(ys):
        if t > 0:
            m, v = 0.9 * m, 0.81 * v + 0.5
        k = 0.5 * v / (0.25 * v + 0.4)
        m, v = m + k * (y - 0.5 * m), (1 - 0.5 * k) * v
        kf_means[t] = m
    g = np.linspace(-15.0, 15.0, 2001)
    a = np.sqrt(1.5)
    move = (np.abs(g[None, :] - 0.9 * g[:, None]) <= a).astype(float)
    move /= move.sum(axis=1, keepdims=True)
    belief = np.exp(-0.5 * (g - 1.0) ** 2 / 2.0)
    grid_means = np.empty(10)
    for t, y in enumerate(ys):
        if t > 0:
            belief = belief @ move
        belief = belief * np.exp(-0.5 * (y - 0.5 * g) ** 2 / 0.4)
        belief /= belief.sum()
        grid_means[t] = belief @ g
    gaps = np.abs(grid_means - kf_means)
    assert gaps[0] < 1e-9 and np.all(gaps[1:] > 1e-6), gaps
    correct(ch02.exercise_4(0, "best linear estimate"))
    correct(ch02.exercise_4(np.int64(0), "  Best Linear Estimate "))
    correct(ch02.exercise_4(0.0, "best linear estimate"))


@pytest.mark.parametrize("agree, meaning, phrases", [
    (1, "best linear estimate", ["t = 1", "count the steps from 1", "meaning_4: correct."]),
    (5, "best linear estimate", ["t = 5", "far more than", "Print"]),
    (0, "conditional mean", ["agree_4: correct.", "not the right option", "means and covariances alone"]),
    (0, "neither", ["not the right option", "means and covariances alone"]),
    (0, "kalman", ["must be one of"]),
    (12, "best linear estimate", ["not one of the steps"]),
    (0.5, "best linear estimate", ["whole number"]),
    ([0], "best linear estimate", ["single time step"]),
    (3, None, ["t = 3", "meaning_4 is still None"]),
])
def test_exercise_4_diagnoses(agree, meaning, phrases):
    wrong(ch02.exercise_4(agree, meaning), *phrases)


def test_exercise_4_not_attempted_and_garbage():
    not_attempted(ch02.exercise_4(None, None))
    fb = ch02.exercise_4(0, None)
    not_attempted(fb)
    assert "agree_4: correct." in fb.message and "meaning_4 is still None" in fb.message
    not_attempted(ch02.exercise_4(None, "best linear estimate"))
    for garbage in GARBAGE:
        fb = ch02.exercise_4(garbage, garbage)
        assert fb.status == INCORRECT, (garbage, fb)
    assert ch02.exercise_4(float("nan"), 3).status == INCORRECT


# ---------------------------------------------------------------------------
# Exercise 5: the gain with cov(w_t, v_{t+1}) = D
# ---------------------------------------------------------------------------

def gain_with_D(P, C, R, G, D):
    Sxy = P @ C.T + G @ D
    Syy = C @ P @ C.T + C @ G @ D + (C @ G @ D).T + R
    return Sxy @ inv(Syy)


def test_exercise_5_formula_by_monte_carlo():
    """Regress simulated x_{t+1} - x^_{t+1|t} on y_{t+1} - C x^_{t+1|t} with (w_t, v_{t+1})
    correlated: the slope is the derived gain, not the gain of section 7 (model of section 1,
    Q = 0.1, D = 0.2, so P = P_a + G Q G^T with P_a = P - G Q G^T)."""
    rng = np.random.default_rng(11)
    N, G, Q, D = 400_000, np.array([[0.0], [1.0]]), np.array([[0.1]]), np.array([[0.2]])
    a = rng.multivariate_normal(np.zeros(2), P - G @ Q @ G.T, N)    # A x~_{t|t}
    wv = rng.multivariate_normal(np.zeros(2), np.block([[Q, D], [D.T, R]]), N)
    x = a + wv[:, :1] @ G.T
    y = x @ C.T + wv[:, 1:]
    slope = np.linalg.lstsq(y, x, rcond=None)[0].T                    # (2, 1)
    expected = gain_with_D(P, C, R, G, D)
    resid_sd = np.sqrt(np.var(x - y @ slope.T, axis=0))
    se = resid_sd / np.sqrt(N * np.var(y))
    assert np.all(np.abs(slope[:, 0] - expected[:, 0]) < 5 * se), (slope, expected, se)
    assert np.any(np.abs(slope[:, 0] - gain_by_inverse(P, C, R)[:, 0]) > 20 * se)
    correct(ch02.exercise_5(gain_with_D))
    correct(ch02.exercise_5(lambda P, C, R, G, D: np.linalg.solve(
        C @ P @ C.T + C @ G @ D + D.T @ G.T @ C.T + R, (P @ C.T + G @ D).T).T))


def _blocks(P, C, R, G, D, xy=True, cross=2, sign=1.0):
    CGD = sign * C @ G @ D
    extra = {0: 0.0, 1: CGD, 2: CGD + CGD.T, 3: 2 * CGD}[cross]
    return (P @ C.T + (sign * G @ D if xy else 0.0)) @ inv(C @ P @ C.T + extra + R)


@pytest.mark.parametrize("fun, phrases", [
    (lambda P, C, R, G, D: gain_by_inverse(P, C, R), ["test input 1", "as if D were 0"]),
    (lambda P, C, R, G, D: _blocks(P, C, R, G, D, cross=0), ["test input 2", "Sigma_yy does not"]),
    # on test input 1, C G = 0: a gain without G D in Sigma_xy is the gain of section 7 there
    (lambda P, C, R, G, D: _blocks(P, C, R, G, D, xy=False), ["test input 1", "as if D were 0"]),
    (lambda P, C, R, G, D: _blocks(P, C, R, G, D, cross=1), ["one cross term only"]),
    (lambda P, C, R, G, D: np.linalg.solve(C @ P @ C.T + C @ G @ D + R, (P @ C.T + G @ D).T).T,
     ["one cross term only"]),
    (lambda P, C, R, G, D: _blocks(P, C, R, G, D, cross=3), ["twice the same cross term"]),
    (lambda P, C, R, G, D: _blocks(P, C, R, G, D, sign=-1.0), ["= -D"]),
    (lambda P, C, R, G, D: _blocks(P, C, R, G, D.T), ["D^T where D belongs"]),
    (lambda P, C, R, G, D: gain_with_D(P, C, R, G, D).T, ["transposed"]),
])
def test_exercise_5_diagnoses(fun, phrases):
    fb = ch02.exercise_5(fun)
    wrong(fb, *phrases)
    hides(fb, gain_with_D(P, C, R, np.array([[0.0], [1.0]]), np.array([[0.2]])))


def test_exercise_5_not_attempted_and_garbage():
    not_attempted(ch02.exercise_5(None))
    not_attempted(ch02.exercise_5(not_implemented))
    wrong(ch02.exercise_5(lambda P, C, R, G, D: P @ D), "check the shapes")
    for garbage in [0.5, "correlated_gain", gain_by_inverse, lambda *a: "K",
                    lambda P, C, R, G, D: np.full((2, 1), np.inf), lambda P, C, R, G, D: P[0, 0] and None,
                    lambda P, C, R, G, D: G @ D @ G.T]:
        fb = ch02.exercise_5(garbage)
        assert fb.status == INCORRECT, fb


@pytest.mark.filterwarnings("error")
def test_checks_themselves_raise_no_warning_on_garbage():
    for check in (ch02.exercise_1, ch02.exercise_3):
        for garbage in GARBAGE:
            check(garbage)
    ch02.exercise_2(lambda P, C, R: np.full((P.shape[0], C.shape[0]), 1e308))
    ch02.exercise_5(lambda P, C, R, G, D: np.full((P.shape[0], C.shape[0]), -1e308))
    ch02.exercise_4(1e308, "neither")


def test_an_exception_that_cannot_print_itself_is_still_reported():
    class Odd(Exception):
        def __str__(self):
            raise RuntimeError("no text")

    def fails(*args):
        raise Odd()
    wrong(ch02.exercise_2(fails), "fails on test input 1", "Odd")
    wrong(ch02.exercise_5(fails), "fails on test input 1", "Odd")
