"""Tests of bayesfilt.checks.ch02, the checks of the exercises of chapter 02.

For every exercise: the reference answer, computed here independently of the
check (exact fractions, closed-form numpy, a plain-numpy grid filter, Monte
Carlo regressions), is accepted; plausible wrong answers are rejected, each with
its own diagnosis, and no message shows the reference; None and
NotImplementedError mean "not attempted yet"; garbage never raises; a teacher's
edit of the statement's numbers (the notebook's variables) is honoured. The
inputs of the notebook's statements are the module's constants.
"""

from __future__ import annotations

import json
from fractions import Fraction
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
inv = np.linalg.inv


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
    given_1, given_3, given_4 = _given(cells[1]), _given(cells[3]), _given(cells[4].split("def ")[0])
    assert (given_1["xhat_00_1"], given_1["P_00_1"]) == (ch02.XHAT_00_1, ch02.P_00_1)
    assert (given_1["Q_1"], given_1["R_1"]) == (ch02.Q_1, ch02.R_1)
    np.testing.assert_array_equal(given_1["ys_1"], ch02.YS_1)
    assert (given_1["Q_new_1"], given_1["R_new_1"]) == (ch02.Q_NEW_1, ch02.R_NEW_1)
    np.testing.assert_array_equal(given_3["m_3"], ch02.M_3)
    np.testing.assert_array_equal(given_3["Pi_3"], ch02.PI_3)
    assert given_3["position_3"] == ch02.POSITION_3
    assert given_4["a_4"] == ch02.HALF_WIDTH_4 == np.sqrt(1.5)
    text = "\n".join(source for source, kind in _cells() if kind == "markdown")
    for stated in ["Q = 1\\ \\mathrm{m^2}$ and $R = 2\\ \\mathrm{m^2}", "\\mathcal N(20\\ \\mathrm m,\\ 3\\ \\mathrm{m^2})",
                   "$y_1 = 23$ m and $y_2 = 28.5$ m", "$Q = 1\\ \\mathrm{m^2}$ and $R = 6\\ \\mathrm{m^2}$",
                   "m_8 = [4.76\\ \\mathrm m,\\ 0.43\\ \\mathrm{m/step}]^T",
                   "\\begin{bmatrix}27.35 & 3.96\\\\ 3.96 & 0.87\\end{bmatrix}", "position is exactly 12 m",
                   "P = \\begin{bmatrix}1.2 & 0.45\\\\ 0.45 & 0.34\\end{bmatrix}",
                   "a = \\sqrt{1.5}", "0.9\\,x_{\\mathrm{prev}}", "D = 0.2"]:
        assert stated in text, stated
    assert ch02.D_5[0, 0] == 0.2 and ch02.P_EX[0, 1] == 0.45 and ch02.R_EX[0, 0] == 1.0


def test_the_given_numbers_are_read_only():
    for frozen in (ch02.P_EX, ch02.YS_1, ch02.PI_3, ch02.M_3):
        with pytest.raises(ValueError):
            frozen[0] = 5.0


# ---------------------------------------------------------------------------
# Exercise 1: the scalar filter by hand, then its steady state
# ---------------------------------------------------------------------------

def by_hand(x, P, Q, R, ys, forget_Q=False, K_times_P=False, swap_gain=False, predictions=False):
    """Predict, update, ... in exact fractions (the mistakes as switches)."""
    x, P, Q, R = map(Fraction, (x, P, Q, R))
    means, variances = [], []
    for y in map(Fraction, ys):
        P = P if forget_Q else P + Q
        if predictions:
            means.append(x)
            variances.append(P)
        K = P / (P + R)
        x = x + (1 - K if swap_gain else K) * (y - x)
        P = K * P if K_times_P else (1 - K) * P
        if not predictions:
            means.append(x)
            variances.append(P)
    return np.array(means, dtype=float), np.array(variances, dtype=float)


STATEMENT_1 = (20, 3, 1, 2, [23, Fraction(57, 2)])
MEANS_1, VARS_1 = by_hand(*STATEMENT_1)
# the new Q = 1, R = 6: P = P R / (P + R) + Q, i.e. P^2 - P - 6 = (P - 3)(P + 2) = 0
P_INF_1, K_INF_1 = 3.0, 1.0 / 3.0
RIGHT_1 = (MEANS_1, VARS_1, P_INF_1, K_INF_1)


def hides_1(fb):
    _hides(fb, MEANS_1, VARS_1, [P_INF_1, K_INF_1], digits=3, integers=False)


def test_exercise_1_reference_by_hand():
    np.testing.assert_array_equal(MEANS_1, [22.0, 25.5])               # 20 + (2/3) 3, 22 + (7/13) 6.5
    np.testing.assert_allclose(VARS_1, [4 / 3, 14 / 13], rtol=1e-15)   # (1 - 2/3) 4, (6/13) (7/3)
    assert P_INF_1 == P_INF_1 * 6 / (P_INF_1 + 6) + 1 and K_INF_1 == P_INF_1 / (P_INF_1 + 6)
    correct(ch02.exercise_1(*RIGHT_1))
    correct(ch02.exercise_1(list(MEANS_1), tuple(VARS_1), np.float32(P_INF_1), np.array([K_INF_1])))
    correct(ch02.exercise_1(np.round(MEANS_1, 3), np.round(VARS_1, 3), 3, 0.333))   # 3 decimals suffice


@pytest.mark.parametrize("answers, phrases", [
    (by_hand(*STATEMENT_1, forget_Q=True) + (P_INF_1, K_INF_1), ["means_1 and vars_1", "forgets Q"]),
    ((MEANS_1, by_hand(*STATEMENT_1, forget_Q=True)[1], P_INF_1, K_INF_1), ["vars_1:", "forgets Q",
                                                                            "means_1: correct"]),
    (by_hand(*STATEMENT_1, predictions=True) + (P_INF_1, K_INF_1), ["the predictions"]),
    (by_hand(*STATEMENT_1, swap_gain=True) + (P_INF_1, K_INF_1), ["means_1", "not 1 - K_t of the way"]),
    (by_hand(*STATEMENT_1, K_times_P=True) + (P_INF_1, K_INF_1), ["(1 - K_t) P_{t|t-1}"]),
    ((MEANS_1, np.sqrt(VARS_1), P_INF_1, K_INF_1), ["standard deviations"]),
    ((VARS_1, MEANS_1, P_INF_1, K_INF_1), ["swap means_1 and vars_1"]),
    ((MEANS_1, [VARS_1[0], VARS_1[0] * 2 / (VARS_1[0] + 2)], P_INF_1, K_INF_1), ["without adding Q"]),
    ((MEANS_1, [VARS_1[0], 1.5], P_INF_1, K_INF_1), ["step 1 right but not step 2"]),
    ((MEANS_1[:1], VARS_1, P_INF_1, K_INF_1), ["must hold 2 numbers"]),
    ((MEANS_1, np.append(VARS_1, 1.0), P_INF_1, K_INF_1), ["wrong shape"]),
    ((MEANS_1, VARS_1, 2.0, K_INF_1), ["P_inf_1", "after the update", "P_{t|t-1}"]),          # P R / (P + R)
    ((MEANS_1, VARS_1, (6 + np.sqrt(60)) / 2, K_INF_1), ["Q and R are swapped"]),
    ((MEANS_1, VARS_1, 6.0, K_INF_1), ["twice P_inf"]),
    ((MEANS_1, VARS_1, -2.0, K_INF_1), ["negative root"]),
    ((MEANS_1, VARS_1, (2 + np.sqrt(28)) / 2, K_INF_1), ["section 2's numbers"]),
    ((MEANS_1, VARS_1, P_INF_1, 0.25), ["K_inf_1", "not P_{t|t}"]),                          # 2 / (2 + 6)
    ((MEANS_1, VARS_1, P_INF_1, 0.75), ["with R, not Q"]),
    ((MEANS_1, VARS_1, P_INF_1, 2 / 3), ["1 - K_inf"]),
    ((MEANS_1, VARS_1, P_INF_1, 0.5), ["not by R alone"]),
    ((MEANS_1, np.round(VARS_1, 2), P_INF_1, K_INF_1), ["rounded to 2 decimals"]),
    ((MEANS_1, VARS_1, P_INF_1, 0.4), ["K_inf_1 is too large"]),
])
def test_exercise_1_diagnoses(answers, phrases):
    fb = ch02.exercise_1(*answers)
    wrong(fb, *phrases)
    hides_1(fb)


def test_exercise_1_not_attempted_and_garbage():
    not_attempted(ch02.exercise_1(None, None, None, None))
    fb = ch02.exercise_1(MEANS_1, None, P_INF_1, K_INF_1)
    assert fb.status == NOT_ATTEMPTED and "vars_1 is still None" in fb.message, fb
    for garbage in GARBAGE:
        fb = ch02.exercise_1(garbage, garbage, garbage, garbage)
        assert fb.status == INCORRECT, (garbage, fb)
        assert ch02.exercise_1(MEANS_1, VARS_1, garbage, K_INF_1).status == INCORRECT, garbage


def test_exercise_1_honours_a_teachers_numbers():
    """Section 2's own step (10 m, 4 m^2, Q = 2, R = 3, y_1 = 13 m) and a second reading of 11 m;
    for the steady state Q = 2 and R = 4: P^2 - 2 P - 8 = (P - 4)(P + 2), so P_inf = 4, K_inf = 1/2."""
    edited = {"xhat_00_1": 10.0, "P_00_1": 4.0, "Q_1": 2.0, "R_1": 3.0, "ys_1": np.array([13.0, 11.0]),
              "Q_new_1": 2.0, "R_new_1": 4.0}
    means, variances = by_hand(10, 4, 2, 3, [13, 11])
    assert means[0] == 12.0 and variances[0] == 2.0                   # section 2's numbers
    correct(ch02.exercise_1(means, variances, 4.0, 0.5, namespace=edited))
    assert ch02.exercise_1(*RIGHT_1, namespace=edited).status == INCORRECT
    wrong(ch02.exercise_1(means, variances, 2.0, 0.5, namespace=edited), "after the update")   # 4 * 4 / 8
    correct(ch02.exercise_1(*RIGHT_1))


# ---------------------------------------------------------------------------
# Exercise 2: kalman_gain(P, C, R)
# ---------------------------------------------------------------------------

K_STAR = gain_by_inverse(P, C, R)       # the gain of the statement's first input


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
# Exercise 3: E(velocity | position = 12 m) and its standard deviation in section 3's cloud
# ---------------------------------------------------------------------------

M3, PI3 = np.array([4.76, 0.43]), np.array([[27.35, 3.96], [3.96, 0.87]])


def conditional(m, Pi, position):
    """The line of section 3 and the spread about it: E(v | p) and sd(v | p), closed form."""
    slope = Pi[1, 0] / Pi[0, 0]
    return m[1] + slope * (position - m[0]), float(np.sqrt(Pi[1, 1] - Pi[1, 0] * slope))


MEAN_3, SD_3 = conditional(M3, PI3, 12.0)


def test_exercise_3_reference_by_a_monte_carlo_regression():
    """Regress the velocities of 400 000 draws of N(m_8, Pi_8) on their positions: the line at 12 m
    and the spread of the residuals are the reference (within 5 standard errors)."""
    rng = np.random.default_rng(33)
    draws = rng.multivariate_normal(M3, PI3, 400_000)
    design = np.column_stack([np.ones(len(draws)), draws[:, 0] - 12.0])   # intercept = E(v | p = 12)
    coef, *_ = np.linalg.lstsq(design, draws[:, 1], rcond=None)
    resid_sd = np.std(draws[:, 1] - design @ coef)
    se_mean = resid_sd * np.sqrt(np.linalg.inv(design.T @ design)[0, 0])
    assert abs(coef[0] - MEAN_3) < 5 * se_mean, (coef, MEAN_3, se_mean)
    assert abs(resid_sd - SD_3) < 5 * SD_3 / np.sqrt(2 * len(draws)), (resid_sd, SD_3)
    assert abs(MEAN_3 - 1.478) < 1e-3 and abs(SD_3 - 0.545) < 1e-3      # near section 3's 1.45 ± 0.54
    correct(ch02.exercise_3(MEAN_3, SD_3))
    correct(ch02.exercise_3(np.float32(MEAN_3), np.array([SD_3])))
    correct(ch02.exercise_3(round(MEAN_3, 3), round(SD_3, 3)))
    rho = PI3[0, 1] / np.sqrt(PI3[0, 0] * PI3[1, 1])                     # the same in correlations
    correct(ch02.exercise_3(M3[1] + rho * np.sqrt(PI3[1, 1] / PI3[0, 0]) * (12 - M3[0]),
                            np.sqrt(PI3[1, 1] * (1 - rho**2))))


@pytest.mark.parametrize("answers, phrases", [
    ((M3[1], SD_3), ["mean_3", "before anything is learnt", "sd_3: correct"]),
    ((M3[1] + PI3[1, 0] / PI3[0, 0] * 12.0, SD_3), ["position - m_1"]),
    ((M3[1] + PI3[1, 0] / PI3[1, 1] * (12.0 - M3[0]), SD_3), ["Pi_21 / Pi_11"]),
    ((M3[1] + PI3[1, 0] / (PI3[0, 0] + 1.0) * (12.0 - M3[0]), SD_3), ["noisy position", "known exactly"]),
    ((M3[1] + PI3[0, 1] / np.sqrt(PI3[0, 0] * PI3[1, 1]) * (12.0 - M3[0]), SD_3), ["correlation is no slope"]),
    ((MEAN_3, SD_3 ** 2), ["sd_3", "the variance", "square root"]),
    ((MEAN_3, np.sqrt(PI3[1, 1])), ["before anything is learnt", "narrows"]),
    ((MEAN_3, np.sqrt(PI3[1, 1] + PI3[1, 0] ** 2 / PI3[0, 0])), ["cannot add"]),
    ((MEAN_3, np.sqrt(PI3[0, 0] - PI3[1, 0] ** 2 / PI3[1, 1])), ["position given the velocity"]),
    ((MEAN_3, np.sqrt(PI3[1, 1] - PI3[1, 0] ** 2 / (PI3[0, 0] + 1.0))), ["noisy position"]),
    ((MEAN_3, np.sqrt(PI3[1, 1]) * (1 - PI3[1, 0] ** 2 / (PI3[0, 0] * PI3[1, 1]))), ["sqrt(1 - rho^2)"]),
    ((round(MEAN_3, 2), SD_3), ["rounded to 2 decimals"]),
    ((MEAN_3 + 0.1, SD_3), ["mean_3 is too large"]),
])
def test_exercise_3_diagnoses(answers, phrases):
    fb = ch02.exercise_3(*answers)
    wrong(fb, *phrases)
    _hides(fb, [MEAN_3, SD_3], digits=3)


def test_exercise_3_not_attempted_and_garbage():
    not_attempted(ch02.exercise_3(None, None))
    fb = ch02.exercise_3(MEAN_3, None)
    assert fb.status == NOT_ATTEMPTED and "mean_3: correct" in fb.message, fb
    for garbage in GARBAGE:
        assert ch02.exercise_3(garbage, garbage).status == INCORRECT, garbage
        assert ch02.exercise_3(MEAN_3, garbage).status == INCORRECT, garbage


def test_exercise_3_honours_a_teachers_numbers():
    """The exact m_8 and Pi_8 of the recursion (section 12) in place of the printed cloud's, and a
    position of 10 m."""
    A = np.array([[1.0, 1.0], [0.0, 0.98]])
    m, Pi = np.array([1.0, 0.5]), np.diag([1.0, 0.25])
    for _ in range(8):
        m, Pi = A @ m, A @ Pi @ A.T + np.diag([0.0, 0.1])
    edited = {"m_3": m, "Pi_3": Pi, "position_3": 10.0}
    right = conditional(m, Pi, 10.0)
    correct(ch02.exercise_3(*right, namespace=edited))
    assert ch02.exercise_3(MEAN_3, SD_3, namespace=edited).status == INCORRECT
    wrong(ch02.exercise_3(right[0], right[1] ** 2, namespace=edited), "the variance")
    correct(ch02.exercise_3(MEAN_3, SD_3))


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
    for garbage in GARBAGE:
        ch02.exercise_1(garbage, garbage, garbage, garbage)
        ch02.exercise_3(garbage, garbage)
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
