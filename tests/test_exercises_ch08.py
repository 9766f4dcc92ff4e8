"""Tests of bayesfilt.checks.ch08, the checks of the exercises of chapter 08 (the UKF).

For every exercise: the reference answer, computed here independently of the
check (the Cholesky factor and the weights written out by hand, the moments of
a Gaussian in closed form, the UT's variance of x^T x summed point by point,
the UKF update with plain loops and the direct gain), is accepted; plausible wrong
answers are rejected, each with its own diagnosis (asserted on the message);
None and NotImplementedError mean "not attempted yet"; garbage never raises.
The numbers of the notebook's statements are the module's constants.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from scipy import linalg as sla

import bayesfilt as bf
from exercise_helpers import (  # noqa: F401 - the shared helpers of the exercise tests
    correct, fails_oddly, hides, never_raises as _never_raises, not_attempted, not_implemented,
    solution_names, wrong,
)

ch08 = bf.checks.ch08
ROOT = Path(__file__).resolve().parents[1]
NOTEBOOK = ROOT / "notebooks" / "08_unscented.ipynb"

GARBAGE = ["text", b"x", [[1.0, 2.0], [3.0]], np.ones(3), np.ones((3, 3)), np.full(2, np.nan),
           {"a": 1}, object(), True, np.array([1j, 0]), [], np.full(2, 1e308), Ellipsis, 3,
           -1.5, [None, 1.0], float("nan"), 1e308]
BAD_FUNCTIONS = [3, "f", np.eye(2), lambda *a: "H", lambda *a: {"H": 1}, lambda *a: [1.0, 2.0],
                 lambda *a: np.nan, lambda *a: np.inf, lambda *a: 1 / 0, lambda *a: 1e308,
                 lambda *a: object(), fails_oddly, lambda: None, lambda *a: np.ones((7, 7)),
                 lambda *a: True]


def never_raises(check, answers):
    _never_raises(check, answers, unpack=True)


# ---------------------------------------------------------------------------
# The statements and the module use the same numbers; the cells follow the pattern
# ---------------------------------------------------------------------------

def _cells():
    nb = json.loads(NOTEBOOK.read_text(encoding="utf-8"))
    return [("".join(c["source"]), c["cell_type"], c.get("metadata", {})) for c in nb["cells"]]


def _exercise_cells() -> dict[int, dict[str, str]]:
    out, n = {}, None
    for source, kind, meta in _cells():
        if kind == "markdown" and source.startswith("### Exercise "):
            n = int(source.split()[2])
            out[n] = {"statement": source}
        elif n is not None and kind == "code" and "### BEGIN SOLUTION" in source:
            out[n]["answer"] = source
        elif n is not None and kind == "code" and "bf.checks.ch08" in source:
            out[n]["check"] = source
        elif n is not None and kind == "markdown" and source.startswith("**Why?**"):
            out[n]["why"] = meta["nbgrader"]["grade_id"]
    return out


def test_four_exercises_in_the_pattern():
    cells = _exercise_cells()
    assert sorted(cells) == [1, 2, 3, 4]
    for n, parts in cells.items():
        assert {"statement", "answer", "check"} <= set(parts), n
        assert parts["check"].strip().startswith(f"bf.checks.ch08.exercise_{n}(")
        assert len(parts["check"].strip().splitlines()) == 1
    assert cells[2]["why"] == "ch08-ex2-why" and cells[3]["why"] == "ch08-ex3-why"


def test_the_notebook_states_the_numbers_of_the_module():
    cells = _exercise_cells()
    given = {}
    for n in (1, 2, 3):
        exec(cells[n]["answer"].split("### BEGIN SOLUTION")[0].split("\ndef ")[0],  # noqa: S102
             {"np": np}, given)
    np.testing.assert_array_equal(given["m_1"], ch08.M_1)
    np.testing.assert_array_equal(given["P_1"], ch08.P_1)
    assert (given["alpha_1"], given["beta_1"], given["kappa_1"]) == ch08.PARAMS_1
    assert (given["m_2"], given["var_2"]) == (ch08.M_2, ch08.VAR_2)
    assert given["n_3"] == ch08.N_3
    text1, text2, text3 = (cells[n]["statement"] for n in (1, 2, 3))
    assert "m_1 = [1, 2]^T" in text1 and "4 & 2 \\\\ 2 & 2" in text1 and "(0.5, 2, 6)" in text1
    assert "$m = 1$" in text2 and "\\sigma^2 = 0.5" in text2
    for key, setting in ch08.SETTINGS_3.items():
        shown = "(" + ", ".join(f"{v:g}" for v in setting) + ")"
        assert f'`"{key}"` ${shown}$' in text3, shown


def test_solution_blocks_hold_only_defs_and_answer_assignments():
    answers = {1: {"points_1", "mean_weights_1", "cov_weights_1"},
               2: {"ut_mean_2", "ut_var_2", "exact_var_2", "beta_2"},
               3: {"ut_variance", "negative_3"}, 4: {"ukf_update"}}
    for n, parts in _exercise_cells().items():
        assert solution_names(parts["answer"]) == answers[n], n


def test_the_notebooks_own_answers_are_correct():
    namespace = {"np": np, "bf": bf}
    for n, parts in sorted(_exercise_cells().items()):
        exec(parts["answer"], namespace)  # noqa: S102 - the notebook's own solution
        correct(eval(parts["check"].strip(), namespace))  # noqa: S307


# ---------------------------------------------------------------------------
# Exercise 1: sigma points and weights by hand
# ---------------------------------------------------------------------------

def _by_hand():
    """The statement worked by hand: lambda = 0.25 (2 + 6) - 2 = 0, L = [[2, 0], [1, 1]]."""
    m = np.array([1.0, 2.0])
    L = np.array([[2.0, 0.0], [1.0, 1.0]])             # L L^T = [[4, 2], [2, 2]]
    c = np.sqrt(2.0)                                    # sqrt(n + lambda)
    points = np.array([m, m + c * L[:, 0], m + c * L[:, 1], m - c * L[:, 0], m - c * L[:, 1]])
    return points, np.array([0.0, 0.25, 0.25, 0.25, 0.25]), np.array([2.75] + [0.25] * 4)


def test_ex1_accepts_the_hand_derivation():
    points, wm, wc = _by_hand()
    np.testing.assert_allclose(np.linalg.cholesky(ch08.P_1), [[2.0, 0.0], [1.0, 1.0]])
    correct(ch08.exercise_1(points, wm, wc))
    correct(ch08.exercise_1(points.tolist(), list(wm), tuple(wc)))


@pytest.mark.parametrize("change, phrases", [
    (lambda p, m: np.vstack([m, m + np.sqrt(2) * np.array([[2.0, 0.0], [1.0, 1.0]]),   # U's columns
                             m - np.sqrt(2) * np.array([[2.0, 0.0], [1.0, 1.0]])]),
     ["rows of L", "columns of the lower factor"]),
    (lambda p, m: np.vstack([m, m + np.sqrt(2) * sla.sqrtm(ch08.P_1).real.T,
                             m - np.sqrt(2) * sla.sqrtm(ch08.P_1).real.T]), ["symmetric square root"]),
    (lambda p, m: m + (p - m) / np.sqrt(2.0), ["lack the factor sqrt(n + lambda~)"]),
    (lambda p, m: m + (p - m) * np.sqrt(2.0), ["scaled by n + lambda~", "square root"]),
    (lambda p, m: m + (p - m) * 2.0, ["sqrt(n + kappa~)"]),
    (lambda p, m: np.vstack([m, m + np.sqrt(2) * ch08.P_1.T, m - np.sqrt(2) * ch08.P_1.T]),
     ["columns of P_1 itself"]),
    (lambda p, m: p[[0, 1, 3, 2, 4]], ["another order", "+ points, then the two - points"]),
    (lambda p, m: p[[0, 2, 1, 3, 4]], ["another order"]),
    (lambda p, m: p.T, ["transposed"]),
])
def test_ex1_diagnoses_points(change, phrases):
    points, wm, wc = _by_hand()
    fb = ch08.exercise_1(change(points, np.array([1.0, 2.0])), wm, wc)
    wrong(fb, *phrases)
    assert "mean_weights_1: correct." in fb.message and "cov_weights_1: correct." in fb.message
    hides(fb, points, integers=False)


@pytest.mark.parametrize("wm, wc, phrases", [
    ([2.75, 0.25, 0.25, 0.25, 0.25], None, ["mean_weights_1", "covariance weights W^c"]),
    ([0.75] + [1 / 16] * 4, None, ["kappa~ in place of lambda~"]),
    ([0.1, 0.25, 0.25, 0.25, 0.25], None, ["sum to 1"]),
    (None, [0.0, 0.25, 0.25, 0.25, 0.25], ["these are the mean weights"]),
    (None, [2.0, 0.25, 0.25, 0.25, 0.25], ["lacks the 1 - alpha~^2"]),
    (None, [3.0, 0.25, 0.25, 0.25, 0.25], ["lacks the - alpha~^2"]),
    (None, [2.5, 0.25, 0.25, 0.25, 0.25], ["alpha~ squared"]),
    (None, [0.75, 0.25, 0.25, 0.25, 0.25], ["lacks beta~"]),
])
def test_ex1_diagnoses_weights(wm, wc, phrases):
    points, wm_ref, wc_ref = _by_hand()
    fb = ch08.exercise_1(points, wm_ref if wm is None else np.array(wm),
                         wc_ref if wc is None else np.array(wc))
    wrong(fb, *phrases)
    assert "points_1: correct." in fb.message


def test_ex1_not_attempted_and_garbage():
    points, wm, wc = _by_hand()
    not_attempted(ch08.exercise_1(None, None, None))
    fb = ch08.exercise_1(points, None, None)
    not_attempted(fb)
    assert "points_1: correct." in fb.message
    never_raises(ch08.exercise_1, [(g, g, g) for g in GARBAGE] + [(points, g, wc) for g in GARBAGE])


# ---------------------------------------------------------------------------
# Exercise 2: the UT of x^2
# ---------------------------------------------------------------------------

M, V = 1.0, 0.5
S = np.sqrt(V)
REF_2 = (M**2 + V, 4 * M**2 * V, 4 * M**2 * V + 2 * V**2, 2.0)    # 1.5, 2.0, 2.5, 2.0


def test_ex2_reference_against_monte_carlo_and_accepted():
    """The exact variance by simulation (500 000 draws; 5 standard errors), the UT's by its
    three points written out."""
    draws = (M + S * np.random.default_rng(7).standard_normal(500_000)) ** 2
    var, se = draws.var(), np.sqrt(np.mean((draws - draws.mean()) ** 4) - draws.var() ** 2) / np.sqrt(draws.size)
    assert abs(var - REF_2[2]) < 5 * se
    pts, w = np.array([M, M + S, M - S]), np.array([0.0, 0.5, 0.5])
    mean = w @ pts**2
    assert np.isclose(mean, REF_2[0]) and np.isclose(w @ (pts**2 - mean) ** 2, REF_2[1])
    correct(ch08.exercise_2(*REF_2))
    correct(ch08.exercise_2(np.float32(1.5), np.array([2.0]), 2.5, 2))


@pytest.mark.parametrize("index, value, phrases", [
    (0, 1.0, ["ut_mean_2", "tangent's (EKF's) mean"]),
    (0, 1.25, ["ut_mean_2", "not at m +- 0.5"]),
    (0, (M + S) ** 2, ["ut_mean_2", "one outer point"]),
    (1, 0.5 * ((M + S) ** 4 + (M - S) ** 4), ["ut_var_2", "weighted mean of g^2"]),
    (1, 2.5, ["ut_var_2", "exact variance"]),
    (1, 1.0, ["ut_var_2", "not at m +- 0.5"]),
    (2, 2.0, ["exact_var_2", "2 sigma^4", "missing"]),
    (2, 2.75, ["exact_var_2", "not 3 sigma^4"]),
    (2, 4.75, ["exact_var_2", "E[x^4]"]),
    (2, 2.25, ["exact_var_2", "E[e^4] = 3 sigma^4"]),
    (3, 0.0, ["beta_2", "misses 2 sigma^4"]),
    (3, 3.0, ["beta_2", "beta~ sigma^4"]),
    (3, 1.0, ["beta_2", "simple factor"]),
    (3, 1.5, ["beta_2", "too small"]),
])
def test_ex2_diagnoses(index, value, phrases):
    answers = list(REF_2)
    answers[index] = value
    fb = ch08.exercise_2(*answers)
    wrong(fb, *phrases)
    hides(fb, [v for k, v in enumerate(REF_2) if k != index], min_digits=2)


def test_ex2_variance_with_beta_two_is_named():
    fb = ch08.exercise_2(REF_2[0], REF_2[2] + 0.0, REF_2[2], REF_2[3])
    wrong(fb, "exact variance")
    # beta = 2's UT variance equals the exact one here, so the message for it is the exact one's


def test_ex2_not_attempted_and_garbage():
    not_attempted(ch08.exercise_2(None, None, None, None))
    fb = ch08.exercise_2(REF_2[0], None, None, None)
    not_attempted(fb)
    assert "ut_mean_2: correct." in fb.message
    never_raises(ch08.exercise_2, [(g, g, g, g) for g in GARBAGE + BAD_FUNCTIONS])


# ---------------------------------------------------------------------------
# Exercise 3: the UT's variance of x^T x; a negative weight
# ---------------------------------------------------------------------------

def ut_variance_by_points(alpha, beta, kappa, n=4):
    """Sum over the 2n + 1 points written out: images 0 and n + lambda, weights by formula."""
    lam = alpha**2 * (n + kappa) - n
    images = [0.0] + [n + lam] * (2 * n)
    wm = [lam / (n + lam)] + [1 / (2 * (n + lam))] * (2 * n)
    wc = [wm[0] + 1 - alpha**2 + beta] + wm[1:]
    mean = sum(w * y for w, y in zip(wm, images))
    return sum(w * (y - mean) ** 2 for w, y in zip(wc, images))


def test_ex3_reference_and_the_negative_setting():
    for a, b, k in ch08.CASES_3:
        sp = bf.ukf.sigma_points(np.zeros(4), np.eye(4), a, b, k)
        images = (sp.points**2).sum(axis=1)
        assert np.isclose(images[0], 0.0) and np.allclose(images[1:], a**2 * (4 + k))
    values = {key: ut_variance_by_points(*s) for key, s in ch08.SETTINGS_3.items()}
    assert values["B"] < 0 < min(values["A"], values["C"])
    np.testing.assert_allclose(values["B"], -4.0)
    correct(ch08.exercise_3(ut_variance_by_points, "B"))
    correct(ch08.exercise_3(lambda a, b, k: np.float64(ut_variance_by_points(a, b, k)), " b "))


def _mean_weight_variant(a, b, k, n=4):
    lam = a**2 * (n + k) - n
    return lam / (n + lam) * n**2 + n * lam**2 / (n + lam)


@pytest.mark.parametrize("fun, phrases", [
    (_mean_weight_variant, ["test input 1", "mean weight W^m_0"]),
    (lambda a, b, k: ut_variance_by_points(a, b, k) - 4 * (a**2 * (4 + k) - 4) ** 2 / (a**2 * (4 + k)),
     ["outer points' term", "missing"]),
    (lambda a, b, k: 4 * a**2 * (4 + k), ["about 0", "centre the images"]),
    (lambda a, b, k: -ut_variance_by_points(a, b, k), ["wrong sign"]),
    (lambda a, b, k: ut_variance_by_points(a, b, k) + 1.0, ["test input 1"]),
])
def test_ex3_diagnoses_the_function(fun, phrases):
    fb = ch08.exercise_3(fun, "B")
    wrong(fb, *phrases)
    assert "negative_3: correct." in fb.message
    hides(fb, [ut_variance_by_points(*c) for c in ch08.CASES_3], min_digits=2)


def test_ex3_diagnoses_the_choice():
    wrong(ch08.exercise_3(ut_variance_by_points, "A"), "negative_3", "not the right option",
          "negative centre weight")
    wrong(ch08.exercise_3(ut_variance_by_points, "D"), "must be one of")


def test_ex3_not_attempted_and_garbage():
    not_attempted(ch08.exercise_3(None, None))
    not_attempted(ch08.exercise_3(not_implemented, None))
    fb = ch08.exercise_3(not_implemented, "B")
    not_attempted(fb)
    assert "negative_3: correct." in fb.message
    never_raises(ch08.exercise_3, [(g, g) for g in BAD_FUNCTIONS + GARBAGE])


# ---------------------------------------------------------------------------
# Exercise 4: the UKF's measurement update
# ---------------------------------------------------------------------------

def ukf_update_by_loops(x, P, y, h, R, alpha, beta, kappa):
    """Särkkä (2013), Algorithm 5.14's update with plain loops: the points and weights written
    out (not bf.ukf.sigma_points), the direct gain K = Sigma_xy S^{-1}."""
    x, P, y, R = (np.asarray(a, float) for a in (x, P, y, R))
    n = x.size
    lam = alpha**2 * (n + kappa) - n
    L = np.linalg.cholesky(P)
    points = [x] + [x + np.sqrt(n + lam) * L[:, j] for j in range(n)] \
        + [x - np.sqrt(n + lam) * L[:, j] for j in range(n)]
    wm = [lam / (n + lam)] + [1 / (2 * (n + lam))] * (2 * n)
    wc = [wm[0] + 1 - alpha**2 + beta] + wm[1:]
    images = [np.asarray(h(p[None, :]), float)[0] for p in points]      # one point at a time
    y_hat = sum(w * z for w, z in zip(wm, images))
    S = R + sum(w * np.outer(z - y_hat, z - y_hat) for w, z in zip(wc, images))
    Sxy = sum(w * np.outer(p - x, z - y_hat) for w, p, z in zip(wc, points, images))
    K = Sxy @ np.linalg.inv(S)
    return x + K @ (y - y_hat), P - K @ S @ K.T


def test_ex4_cases_cover_the_settings_and_a_linear_h():
    cases = ch08.CASES_4
    params = [c[5:] for c in cases]
    assert (1.0, 0.0, 2.0) in params and (1.0, 2.0, 0.0) in params      # section 1's, the defaults
    centre_weights = [bf.ukf.sigma_points(c[0], c[1], *c[5:]).cov_weights[0] for c in cases]
    assert min(centre_weights) < 0                                       # a negative W^c_0
    linear = next(c for c in cases if c[3] is ch08._linear)
    # a linear h: the UKF's update is the Kalman update (chapter 02), by an independent formula
    x, P, y, _, R = linear[:5]
    C = np.asarray(ch08._C_4)
    K = P @ C.T @ np.linalg.inv(C @ P @ C.T + R)
    mean, cov = ukf_update_by_loops(*linear)
    np.testing.assert_allclose(mean, x + K @ (y - C @ x), atol=1e-12)
    np.testing.assert_allclose(cov, P - K @ C @ P, atol=1e-12)


def test_ex4_reference_is_the_direct_update_and_accepted():
    for case in ch08.CASES_4:
        ref, mine = ch08._update_4(*case), ukf_update_by_loops(*case)
        np.testing.assert_allclose(ref[0], mine[0], atol=1e-12)
        np.testing.assert_allclose(ref[1], mine[1], atol=1e-12)
        assert np.linalg.eigvalsh(mine[1]).min() > 0
    correct(ch08.exercise_4(ukf_update_by_loops))
    correct(ch08.exercise_4(lambda *a: list(ukf_update_by_loops(*a))))
    correct(ch08.exercise_4(lambda *a: tuple(v.tolist() for v in ukf_update_by_loops(*a))))


def _mistake(**kw):
    return lambda *args: ch08._variant_4(*args, **kw)


@pytest.mark.parametrize("fun, phrases", [
    (_mistake(weights="mean"), ["test input 2", "covariance weights W^c"]),
    (_mistake(noise=False), ["test input 1", "R is missing"]),
    (_mistake(centre="tangent"), ["test input 1", "not h at the mean"]),
    (_mistake(cross="raw"), ["test input 2", "X_j - x_hat"]),
    (_mistake(sign=1.0), ["test input 1", "lowers the covariance"]),
    (lambda *a: (ukf_update_by_loops(*a)[0] + 0.01, ukf_update_by_loops(*a)[1]),
     ["test input 1", "mean"]),
    (lambda *a: ukf_update_by_loops(*a)[0], ["a pair (mean, cov)", "ndarray"]),
    (lambda *a: (ukf_update_by_loops(*a)[1], ukf_update_by_loops(*a)[0]),
     ["the mean in the output for test input 1", "wrong shape"]),
])
def test_ex4_diagnoses(fun, phrases):
    fb = ch08.exercise_4(fun)
    wrong(fb, *phrases)
    hides(fb, *[v for c in ch08.CASES_4 for v in ch08._update_4(*c)], min_digits=3,
          integers=False)


def test_ex4_not_attempted_and_garbage():
    not_attempted(ch08.exercise_4(None))
    not_attempted(ch08.exercise_4(not_implemented))
    wrong(ch08.exercise_4(lambda *a: None), "forget `return`")
    wrong(ch08.exercise_4(fails_oddly), "fails on test input 1")
    never_raises(ch08.exercise_4, [(g,) for g in BAD_FUNCTIONS + GARBAGE])


@pytest.mark.filterwarnings("error")
def test_checks_themselves_raise_no_warning_on_garbage():
    for g in GARBAGE:
        ch08.exercise_1(g, g, g)
        ch08.exercise_2(g, g, g, g)
        ch08.exercise_3(lambda a, b, k: g, g)
        ch08.exercise_4(lambda *a: g)
