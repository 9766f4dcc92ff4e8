"""Tests of bayesfilt.checks.ch03, the checks of the exercises of chapter 03.

For every exercise: the reference answer, computed here independently of the
check (the Riccati recursion iterated in plain numpy, the half-step kinematics
written out component by component with a Kalman filter over all runs at once,
a loop with np.linalg.inv, a Kalman filter written out with P - KCP, the
autocorrelation formula), is accepted; plausible wrong
answers are rejected, each with its own diagnosis; None and
NotImplementedError mean "not attempted yet"; garbage never raises; no
message shows the reference; a teacher's edited given values are honoured.
The statements in the notebook use the numbers of the module.
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


def hides(fb, *expected):
    _hides(fb, *expected, digits=3, min_digits=3)

ch03 = bf.checks.ch03
ROOT = Path(__file__).resolve().parents[1]
NOTEBOOK = ROOT / "notebooks" / "03_damped_particle.ipynb"
inv = np.linalg.inv

# Seed 000's damped particle, typed from the seed (not taken from the library).
Q_VAR, R_VAR = 0.01, 1.0
G = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 0.0], [0.0, 1.0]])
C = np.array([[1.0, 0.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0]])
GQG = G @ (Q_VAR * np.eye(2)) @ G.T


def transition(damping):
    return np.array([[1, 1, 0, 0], [0, damping, 0, 0], [0, 0, 1, 1], [0, 0, 0, damping]], float)


A = transition(0.98)


GARBAGE = ["text", [[1.0, 2.0], [3.0]], np.ones(3), np.ones((3, 3)), np.full((2, 2), np.nan),
           {"a": 1}, object(), True, np.array([[1j, 0], [0, 1]]), [], np.full((3, 2), 1e308),
           float("nan"), float("inf"), 1e308]


def plain_filter(A, C, GQG, R, m0, P0, ys):
    """The Kalman filter written out (seed 000's order: update first), P - KCP; a row of NaN
    is a missing measurement. Returns the filtered means, covariances, innovations and S."""
    x, P = np.array(m0, float), np.array(P0, float)
    means, covs, innovations, Ss = [], [], [], []
    for t, y in enumerate(ys):
        if t > 0:
            x, P = A @ x, A @ P @ A.T + GQG
        if not np.all(np.isnan(y)):
            S = C @ P @ C.T + R
            K = P @ C.T @ inv(S)
            r = y - C @ x
            x, P = x + K @ r, P - K @ C @ P
            innovations.append(r)
            Ss.append(S)
        means.append(x)
        covs.append(P)
    return np.array(means), np.array(covs), np.array(innovations), np.array(Ss)


# ---------------------------------------------------------------------------
# The statements and the module use the same numbers; the answer cells follow the pattern
# ---------------------------------------------------------------------------

def _cells():
    nb = json.loads(NOTEBOOK.read_text(encoding="utf-8"))
    return [("".join(c["source"]), c["cell_type"]) for c in nb["cells"]]


def _answer_cells() -> dict[int, str]:
    out, n = {}, None
    for source, kind in _cells():
        if kind == "markdown" and source.startswith("### Exercise "):
            n = int(source.split()[2])
        elif kind == "code" and "### BEGIN SOLUTION" in source:
            out[n] = source
    return out


def _statements() -> dict[int, str]:
    return {int(source.split()[2]): source for source, kind in _cells()
            if kind == "markdown" and source.startswith("### Exercise ")}


def test_the_notebook_states_the_numbers_of_the_module():
    cells, text = _answer_cells(), _statements()
    assert sorted(cells) == [1, 2, 3, 4, 5]
    assert f"damped_particle(damping={ch03.DAMPING_1})" in cells[1]
    assert (f"dt_2, sigma_a_2, M_2, T_2 = {ch03.DT_2}, {ch03.SIGMA_A_2}, {ch03.M_2}, {ch03.T_2}"
            in cells[2]) and f"np.random.default_rng({ch03.SEED_2})" in cells[2]
    assert "damping**dt_2" in cells[2] and ch03.DAMPING == 0.98
    assert "$\\Delta t = 0.5$" in text[2] and "$\\sigma_a = 0.1$" in text[2] and "seed 22" in text[2]
    assert "short_4, long_4 = 10, 20" in cells[4] and ch03.SLOPE_LENGTHS == (10, 20)
    assert 'ys_long = bf.models.simulate(model, N_long, np.random.default_rng(5)).ys' in cells[5]
    assert "0.95" in text[3] and ch03.CORRELATED_3[0, 1] == 0.95
    assert "ys_cut[40:40 + length] = np.nan" in cells[4] and ch03.GAP_START == 40
    assert "10, 20, 1 (the single step $t = 40$), 2, 5, 33 and 60" in text[4]
    assert ch03.GAP_LENGTHS == (10, 20, 1, 2, 5, 33, 60) and ch03.SLOPE_LENGTHS == (10, 20)
    assert 'models_5 = [wrong["Q ×10"], wrong["R ×0.1"], wrong["R ×10"]]' in cells[5]
    assert [label for label, _ in ch03.MODELS_5] == ["Q ×10", "R ×0.1", "R ×10"]
    # section 5 defines wrong[...] with the keyword arguments of the module
    section_5 = next(s for s, kind in _cells() if kind == "code" and s.startswith("wrong = {"))
    for label, kw in ch03.MODELS_5:
        (name, value), = kw.items()
        assert f'"{label}": bf.models.damped_particle({name}={value})' in section_5
    for keyword in ("`force_var=0.1`", "`meas_var=0.1`", "`meas_var=10`"):
        assert keyword in text[5], keyword
    assert "N = 1000" in text[5] and "seed 5" in text[5]
    assert (ch03.LONG_SEED, ch03.N_LONG) == (5, 1000)


def test_solution_blocks_hold_only_defs_and_answer_assignments():
    """What tools/make_student_edition.py can stub: top-level defs and assignments only."""
    answers = {1: {"stabilising_1", "std_1", "radius_1"}, 2: {"GQGt_2", "nees_2", "nees_old_2"},
               3: {"normalised_squared"}, 4: {"end_of_gap_variance", "slope_4"},
               5: {"lag1_5", "sees_5"}}
    for n, source in _answer_cells().items():
        assert solution_names(source) == answers[n], n


def test_check_cells_are_a_single_call():
    calls = [source for source, kind in _cells() if kind == "code" and "bf.checks.ch03" in source]
    assert calls == ["bf.checks.ch03.exercise_1(stabilising_1, std_1, radius_1)",
                     "bf.checks.ch03.exercise_2(GQGt_2, nees_2, nees_old_2)",
                     "bf.checks.ch03.exercise_3(normalised_squared)",
                     "bf.checks.ch03.exercise_4(end_of_gap_variance, slope_4)",
                     "bf.checks.ch03.exercise_5(lag1_5, sees_5)"]


# ---------------------------------------------------------------------------
# Exercise 1: no damping
# ---------------------------------------------------------------------------

def riccati_limit(damping, steps=3000):
    """Iterate the Riccati recursion from P0 = I: (predicted P, gain K, filtered P)."""
    A_d, R = transition(damping), R_VAR * np.eye(2)
    P = np.eye(4)
    for _ in range(steps):
        K = P @ C.T @ inv(C @ P @ C.T + R)
        P = A_d @ (P - K @ C @ P) @ A_d.T + GQG
    K = P @ C.T @ inv(C @ P @ C.T + R)
    return P, K, P - K @ C @ P


P1, K1, F1 = riccati_limit(1.0)
EIG_1 = np.linalg.eigvals(transition(1.0) @ (np.eye(4) - K1 @ C))
STD_1, RADIUS_1 = np.sqrt(F1[0, 0]), np.abs(EIG_1).max()
P98, K98, F98 = riccati_limit(0.98)


def test_exercise_1_accepts_the_riccati_limit_and_rounding():
    assert RADIUS_1 < 1, "the undamped filter must be stable: the DARE has a stabilising solution"
    correct(ch03.exercise_1("yes", STD_1, RADIUS_1))
    correct(ch03.exercise_1(" Yes", np.float64(STD_1), np.array([RADIUS_1])))
    correct(ch03.exercise_1("yes", round(STD_1, 4), round(RADIUS_1, 4)))


@pytest.mark.parametrize("std, phrases", [
    (np.sqrt(F98[0, 0]), ["section 7's value", "use model_1"]),
    (F1[0, 0], ["variance", "square root"]),
    (np.sqrt(P1[0, 0]), ["prediction", "after the measurement update"]),
    (np.sqrt(P98[0, 0]), ["prediction's standard deviation", "damped model"]),
    (np.sqrt(F1[1, 1]), ["velocity x1_dot"]),
    (np.sqrt(F1[0, 0] + F1[2, 2]), ["both positions"]),
    (1.0, ["one measurement"]),
    (0.1, ["too small"]),
])
def test_exercise_1_diagnoses_the_standard_deviation(std, phrases):
    fb = ch03.exercise_1("yes", std, RADIUS_1)
    wrong(fb, "std_1", *phrases)
    assert "stabilising_1: correct." in fb.message and "radius_1: correct." in fb.message
    hides(fb, STD_1, RADIUS_1)


@pytest.mark.parametrize("radius, phrases", [
    (np.abs(np.linalg.eigvals(A @ (np.eye(4) - K98 @ C))).max(), ["section 7's value"]),
    (RADIUS_1 ** 2, ["|lambda|_max²", "itself"]),
    (1.0, ["spectral radius of A", "A (I - K_inf C) (optional section 12)"]),
    (np.abs(EIG_1.real).max(), ["real part", "np.abs"]),
    (np.abs(np.linalg.eigvals(transition(1.0) - K1 @ C)).max(), ["A - K_inf C"]),
])
def test_exercise_1_diagnoses_the_spectral_radius(radius, phrases):
    fb = ch03.exercise_1("yes", STD_1, radius)
    wrong(fb, "radius_1", *phrases)
    hides(fb, STD_1, RADIUS_1)


def test_exercise_1_the_choice():
    wrong(ch03.exercise_1("no", STD_1, RADIUS_1), "stabilising_1 is not the right option",
          "optional section 12's two conditions")
    wrong(ch03.exercise_1(True, STD_1, RADIUS_1), "must be one of ['yes', 'no']")


def test_exercise_1_not_attempted_and_garbage():
    not_attempted(ch03.exercise_1(None, None, None))
    fb = ch03.exercise_1("yes", None, RADIUS_1)
    assert fb.status == NOT_ATTEMPTED and "std_1: not attempted yet" in fb.message
    for garbage in GARBAGE:
        fb = ch03.exercise_1(garbage, garbage, garbage)
        assert fb.status == INCORRECT, (garbage, fb)


# ---------------------------------------------------------------------------
# Exercise 2: design G Q G^T for a half step, and test it with the NEES
# ---------------------------------------------------------------------------

def runs_2(dt=0.5, sigma_a=0.1, seed=22, M=200, T=200):
    """The statement's runs, the kinematics written out component by component: in a half step
    the push a moves the position by v dt + a dt^2/2 and the velocity by a dt (after damping)."""
    rng = np.random.default_rng(seed)
    xs = np.zeros((M, T, 4))
    xs[:, 0] = rng.normal(size=(M, 4))
    keep = 0.98 ** dt
    for t in range(1, T):
        a = rng.normal(0.0, sigma_a, size=(M, 2))
        for axis, (pos, vel) in enumerate(((0, 1), (2, 3))):
            xs[:, t, pos] = xs[:, t - 1, pos] + dt * xs[:, t - 1, vel] + a[:, axis] * dt ** 2 / 2
            xs[:, t, vel] = keep * xs[:, t - 1, vel] + a[:, axis] * dt
    return xs, xs[..., [0, 2]] + rng.normal(size=(M, T, 2))


def half_step(dt):
    return np.array([[1, dt, 0, 0], [0, 0.98 ** dt, 0, 0], [0, 0, 1, dt], [0, 0, 0, 0.98 ** dt]], float)


def design(dt, sigma_a):
    """sigma_a^2 g g^T on each axis, g = [dt^2/2, dt]: entries dt^4/4, dt^3/2, dt^2."""
    block = sigma_a ** 2 * np.array([[dt ** 4 / 4, dt ** 3 / 2], [dt ** 3 / 2, dt ** 2]])
    out = np.zeros((4, 4))
    out[:2, :2] = out[2:, 2:] = block
    return out


def mean_nees(GQGt, xs, ys, dt, predicted=False):
    """The filter (A for dt, C, GQGt, R = I, m0 = 0, P0 = I) on all runs at once, written out."""
    A, (M, T, _) = half_step(dt), xs.shape
    x, P, total = np.zeros((M, 4)), np.eye(4), 0.0
    for t in range(T):
        if t > 0:
            x, P = x @ A.T, A @ P @ A.T + GQGt
        if predicted:
            e = xs[:, t] - x
            total += np.einsum("mi,ij,mj->", e, inv(P), e)
        K = P @ C.T @ inv(C @ P @ C.T + np.eye(2))
        x, P = x + (ys[:, t] - x @ C.T) @ K.T, P - K @ C @ P
        if not predicted:
            e = xs[:, t] - x
            total += np.einsum("mi,ij,mj->", e, inv(P), e)
    return total / (M * T)


XS_2, YS_2 = runs_2()
GQGT_2, OLD_2 = design(0.5, 0.1), design(1.0, 0.1)
NEES_2, NEES_OLD_2 = mean_nees(GQGT_2, XS_2, YS_2, 0.5), mean_nees(OLD_2, XS_2, YS_2, 0.5)
HIDDEN_2 = (GQGT_2[GQGT_2 != 0], NEES_2, NEES_OLD_2)


def test_exercise_2_accepts_the_written_out_reference():
    assert abs(NEES_2 - 4) < 0.1 and NEES_OLD_2 < 3.2      # consistent; over-cautious
    correct(ch03.exercise_2(GQGT_2, NEES_2, NEES_OLD_2))
    correct(ch03.exercise_2(GQGT_2.tolist(), np.float32(NEES_2), np.array([NEES_OLD_2])))
    correct(ch03.exercise_2(GQGT_2.astype(np.float32), NEES_2, NEES_OLD_2))


def continuous(c, dt=0.5):
    out = np.zeros((4, 4))
    out[:2, :2] = out[2:, 2:] = c * np.array([[dt ** 3 / 3, dt ** 2 / 2], [dt ** 2 / 2, dt]])
    return out


ORDER = [0, 2, 1, 3]


@pytest.mark.parametrize("answer, phrases", [
    (OLD_2, ["GQGt_2", "section 6's design for Δt = 1"]),
    (continuous(0.01), ["continuous white-noise model", "sigma_a² g g^T"]),
    (continuous(0.01 * 0.5), ["continuous white-noise model", "same velocity variance"]),
    (np.diag([0, 0.01 * 0.25, 0, 0.01 * 0.25]), ["velocity only", "section 2's G"]),
    (np.diag(np.diag(GQGT_2)), ["position-velocity entries", "correlated"]),
    (GQGT_2 / 0.1, ["multiplied by sigma_a"]),
    (GQGT_2 / 0.01, ["multiplied by the push's variance"]),
    (design(0.5, 0.1) * np.array([[4, 2, 0, 0], [2, 1, 0, 0], [0, 0, 4, 2], [0, 0, 2, 1]]),
     ["the 1/2 is missing"]),
    (GQGT_2[np.ix_(ORDER, ORDER)], ["(ξ_1, ξ_2, ξ̇_1, ξ̇_2)", "order_by_dim"]),
    (GQGT_2[:2, :2], ["per-axis block", "np.kron"]),
    (np.ones((4, 2)), ["shape of G"]),
    (GQGT_2 + 0.001 * np.eye(4), ["4 of 16 entries differ"]),
])
def test_exercise_2_diagnoses_the_design(answer, phrases):
    fb = ch03.exercise_2(answer, NEES_2, NEES_OLD_2)
    wrong(fb, *phrases)
    assert "nees_2: correct." in fb.message and "nees_old_2: correct." in fb.message
    hides(fb, *HIDDEN_2)


@pytest.mark.parametrize("nees, nees_old, phrases", [
    (NEES_OLD_2, NEES_2, ["nees_2: this is the value of nees_old_2",
                          "nees_old_2: this is the value of nees_2"]),
    (NEES_2 * 200 * 200, NEES_OLD_2, ["sum over all runs and steps"]),
    (NEES_2 / 4, NEES_OLD_2 / 4, ["divided by the dimension 4"]),
    (mean_nees(GQGT_2, XS_2, YS_2, 0.5, predicted=True), NEES_OLD_2, ["uses the predictions"]),
    (NEES_2, mean_nees(OLD_2, XS_2, YS_2, 0.5, predicted=True), ["nees_old_2: this uses the pred"]),
    (4.0, NEES_OLD_2, ["4 is what a consistent"]),
    (NEES_2 + 0.05, NEES_OLD_2, ["nees_2 is too large"]),
])
def test_exercise_2_diagnoses_the_nees(nees, nees_old, phrases):
    fb = ch03.exercise_2(GQGT_2, nees, nees_old)
    wrong(fb, *phrases)
    assert fb.message.count("GQGt_2: correct.") == 1
    hides(fb, *HIDDEN_2)


def test_exercise_2_a_wrong_design_and_its_own_nees():
    """A student who designs section 2's G and reports its NEES hears about the design first."""
    sec2 = np.diag([0, 0.0025, 0, 0.0025])
    fb = ch03.exercise_2(sec2, mean_nees(sec2, XS_2, YS_2, 0.5), NEES_OLD_2)
    wrong(fb, "velocity only", "mean NEES of your GQGt_2", "fix GQGt_2 first")
    assert fb.message.index("velocity only") < fb.message.index("fix GQGt_2 first")


def test_exercise_2_a_teacher_changes_the_step_and_the_push():
    """The check reads dt_2, sigma_a_2, A_2, xs_2 and ys_2 from the notebook."""
    dt, sigma_a = 0.25, 0.2
    xs, ys = runs_2(dt, sigma_a, M=40, T=60)
    ns = {"dt_2": dt, "sigma_a_2": sigma_a, "A_2": half_step(dt), "xs_2": xs, "ys_2": ys}
    right = (design(dt, sigma_a), mean_nees(design(dt, sigma_a), xs, ys, dt),
             mean_nees(design(1.0, sigma_a), xs, ys, dt))
    correct(ch03.exercise_2(*right, namespace=ns))
    wrong(ch03.exercise_2(GQGT_2, NEES_2, NEES_OLD_2, namespace=ns), "GQGt_2")
    correct(ch03.exercise_2(GQGT_2, NEES_2, NEES_OLD_2))          # the statement's own numbers


def test_exercise_2_not_attempted_and_garbage():
    not_attempted(ch03.exercise_2(None, None, None))
    fb = ch03.exercise_2(GQGT_2, None, NEES_OLD_2)
    assert fb.status == NOT_ATTEMPTED and "nees_2: not attempted yet" in fb.message
    for garbage in GARBAGE:
        assert ch03.exercise_2(garbage, garbage, garbage).status == INCORRECT, garbage
    # a "design" that is no covariance: the check does not crash filtering it
    fb = ch03.exercise_2(-np.eye(4), NEES_2, NEES_OLD_2)
    wrong(fb, "GQGt_2")


# ---------------------------------------------------------------------------
# Exercise 3: NEES and NIS as a function
# ---------------------------------------------------------------------------

def by_loop(diffs, covs):
    return np.array([d @ inv(P) @ d for d, P in zip(diffs, covs)])


def test_exercise_3_accepts_a_loop_and_a_solve():
    correct(ch03.exercise_3(by_loop))
    correct(ch03.exercise_3(lambda d, P: np.einsum("ti,tij,tj->t", d, inv(P), d)))
    correct(ch03.exercise_3(lambda d, P: [float(x) for x in by_loop(d, P)]))


def test_exercise_3_an_input_changed_in_place_is_not_yet():
    def spoils_its_input(diffs, covs):
        out = by_loop(diffs, covs)
        covs[...] = 0.0
        return out
    wrong(ch03.exercise_3(spoils_its_input), "in place", "test input")


@pytest.mark.parametrize("fun, phrases", [
    (lambda d, P: np.einsum("ti,tij,tj->t", d, P, d), ["test input 1", "multiply by P_t"]),
    (lambda d, P: np.sum(d ** 2 / np.diagonal(P, axis1=1, axis2=2), axis=1),
     ["test input 1", "variances only", "correlations"]),
    (lambda d, P: np.sqrt(by_loop(d, P)), ["square root"]),
    (lambda d, P: by_loop(d, P) / d.shape[1], ["divide by the dimension n"]),
    (lambda d, P: np.sum(d ** 2, axis=1), ["ignores the covariance"]),
    (lambda d, P: np.array([d_t @ inv(P[0]) @ d_t for d_t in d]), ["first covariance"]),
    (lambda d, P: by_loop(d, P).mean(), ["single number", "shape (5,)"]),
    (lambda d, P: d @ inv(P) @ d.T, ["pairs every step with every other"]),
    (lambda d, P: by_loop(d, P)[:-1], ["wrong shape"]),
    (lambda d, P: (by_loop(d, P) if len(d) > 1 else 2 * by_loop(d, P)), ["test input 4"]),
])
def test_exercise_3_diagnoses(fun, phrases):
    fb = ch03.exercise_3(fun)
    wrong(fb, *phrases)
    hides(fb, *[by_loop(d, P) for _, d, P in ch03._nees_cases()])


def test_exercise_3_hints_on_failures():
    wrong(ch03.exercise_3(lambda d, P: d.T @ inv(P)), "fails on test input 1", "Hint",
          "for each t")
    wrong(ch03.exercise_3(lambda d, P: d.sum() and None), "forget `return`")
    wrong(ch03.exercise_3(lambda d, P: 1 / 0), "ZeroDivisionError")


def test_exercise_3_not_attempted_and_garbage():
    not_attempted(ch03.exercise_3(None))
    fb = ch03.exercise_3(not_implemented)
    not_attempted(fb)
    assert "still raises NotImplementedError" in fb.message
    for garbage in [3, "normalised_squared", np.eye(2), lambda d: d, lambda d, P: "eps",
                    lambda d, P: {"e": 1}, lambda d, P: np.full(len(d), np.nan),
                    lambda d, P: [[1.0], [2.0, 3.0]], lambda d, P: np.full(len(d), 1e308),
                    lambda d, P: np.ones(len(d), complex)]:
        fb = ch03.exercise_3(garbage)
        assert fb.status == INCORRECT, fb


# ---------------------------------------------------------------------------
# Exercise 4: the length of a gap
# ---------------------------------------------------------------------------

def gap_covs(length, fill=np.nan, start=40):
    ys = np.zeros((100, 2))
    ys[start:start + length] = fill
    return plain_filter(A, C, GQG, np.eye(2), np.zeros(4), np.eye(4), ys)[1]


def end_of_gap(length):
    return float(gap_covs(length)[39 + length, 0, 0])


SLOPE = np.log(end_of_gap(20) / end_of_gap(10)) / np.log(2)


def test_exercise_4_accepts_the_written_out_filter():
    # the variance grows through the gap, faster than the length
    assert end_of_gap(1) < end_of_gap(10) < end_of_gap(20) and 2 < SLOPE < 3
    assert abs(np.sqrt(end_of_gap(20)) - 5.8) < 0.05            # section 8 prints 5.8 m
    correct(ch03.exercise_4(end_of_gap, SLOPE))
    correct(ch03.exercise_4(lambda L: np.array([end_of_gap(L)]), round(SLOPE, 2)))
    # a gap that starts one step late is (to 1e-6) the same: the filter is at its steady state
    correct(ch03.exercise_4(lambda L: float(gap_covs(L, start=41)[40 + L, 0, 0]) if L < 60
                            else end_of_gap(L), SLOPE))


@pytest.mark.parametrize("fun, phrases", [
    (lambda L: np.sqrt(end_of_gap(L)), ["Test input 1: length = 10", "standard deviation"]),
    (lambda L: float(gap_covs(L)[40 + L, 0, 0]), ["first step after the gap"]),
    (lambda L: float(gap_covs(L)[38 + L, 0, 0]), ["t = 38 + length"]),
    (lambda L: float(gap_covs(L + 1)[40 + L, 0, 0]), ["length + 1"]),
    (lambda L: float(gap_covs(L)[39 + L, 1, 1]), ["velocity x1_dot"]),
    (lambda L: end_of_gap(20), ["Test input 1: length = 10", "section 8's gap of 20 steps"]),
    (lambda L: float(gap_covs(L, fill=0.0)[39 + L, 0, 0]), ["did not grow", "not of zeros"]),
    (lambda L: gap_covs(L)[39 + L], ["whole covariance"]),
    (lambda L: gap_covs(L)[:, 0, 0], ["return one number"]),
])
def test_exercise_4_diagnoses_the_function(fun, phrases):
    fb = ch03.exercise_4(fun, SLOPE)
    wrong(fb, *phrases)
    assert "slope_4: correct." in fb.message
    hides(fb, [end_of_gap(L) for L in ch03.GAP_LENGTHS], SLOPE)


def test_exercise_4_hints_on_failures():
    def indexed_beyond_the_run(L):
        return [end_of_gap(L)][L - 60] if L == 60 else end_of_gap(L)

    def wrong_sensor_missing(L):
        # only the axis-2 sensor drops out (a partly-missing row): the axis-1 position the
        # exercise asks about is still measured, so its variance does not grow
        ys = np.zeros((100, 2))
        ys[40:40 + L, 1] = np.nan
        return bf.kalman.kalman_filter(bf.models.damped_particle(), ys).covs[39 + L, 0, 0]

    def out_of_range(L):
        return float(gap_covs(L)[40 + L, 0, 0]) if L < 60 else gap_covs(L)[100]

    wrong(ch03.exercise_4(wrong_sensor_missing, SLOPE), "test input 1")
    wrong(ch03.exercise_4(out_of_range, SLOPE), "first step after the gap")
    fb = ch03.exercise_4(lambda L: end_of_gap(L) if L < 60 else gap_covs(L)[100], SLOPE)
    wrong(fb, "test input 7", "Test input 7: length = 60", "IndexError", "t = 99 for length = 60")
    correct(ch03.exercise_4(indexed_beyond_the_run, SLOPE))


@pytest.mark.parametrize("slope, phrases", [
    (SLOPE / 2, ["standard deviation"]),
    (np.log(gap_covs(20)[60, 0, 0] / gap_covs(10)[50, 0, 0]) / np.log(2), ["after the gap"]),
    ((end_of_gap(20) - end_of_gap(10)) / 10, ["variance itself"]),
    (np.log(end_of_gap(20) / end_of_gap(10)) / 10, ["not of the length"]),
    (np.log10(end_of_gap(20) / end_of_gap(10)) / np.log(2), ["mixed two logarithms"]),
    (np.log(end_of_gap(20) / end_of_gap(10)) / np.log10(2), ["mixed two logarithms"]),
    (1 / SLOPE, ["other way round"]),
    (3.0, ["too large"]),
])
def test_exercise_4_diagnoses_the_slope(slope, phrases):
    fb = ch03.exercise_4(end_of_gap, slope)
    wrong(fb, "slope_4", *phrases)
    assert "end_of_gap_variance: correct." in fb.message
    hides(fb, SLOPE)


def test_exercise_4_a_teacher_changes_the_slope_lengths():
    slope = np.log(end_of_gap(30) / end_of_gap(5)) / np.log(6)
    ns = {"short_4": 5, "long_4": 30}
    correct(ch03.exercise_4(end_of_gap, slope, namespace=ns))
    wrong(ch03.exercise_4(end_of_gap, SLOPE, namespace=ns), "slope_4")
    fb = ch03.exercise_4(end_of_gap, np.log(end_of_gap(30) / end_of_gap(5)) / 25, namespace=ns)
    wrong(fb, "not of the length", "log 30 - log 5")


def test_exercise_4_not_attempted_and_garbage():
    not_attempted(ch03.exercise_4(None, None))
    fb = ch03.exercise_4(not_implemented, None)
    not_attempted(fb)
    assert "end_of_gap_variance still raises NotImplementedError" in fb.message
    for garbage in GARBAGE + [lambda L: "v", lambda L: None, lambda: 1.0, lambda L: [1.0, 2.0]]:
        assert ch03.exercise_4(garbage, garbage).status == INCORRECT, garbage


# ---------------------------------------------------------------------------
# Exercise 5: whiteness of the other wrong models
# ---------------------------------------------------------------------------

YS_LONG = bf.models.simulate(bf.models.damped_particle(), 1000, np.random.default_rng(5)).ys


def lags(q_var, r_var, ys=YS_LONG, max_lag=2, normalise=True):
    """Lags 1..max_lag of r~_t = L_t^{-1} r_t, by the formula of optional section 13."""
    _, _, r, S = plain_filter(A, C, G @ (q_var * np.eye(2)) @ G.T, r_var * np.eye(2),
                              np.zeros(4), np.eye(4), ys)
    z = np.array([np.linalg.solve(np.linalg.cholesky(S_t), r_t) for r_t, S_t in zip(r, S)]) \
        if normalise else r
    d = z - z.mean(axis=0)
    return np.array([np.sum(d[:-k] * d[k:], axis=0) for k in range(1, max_lag + 1)]) \
        / np.sum(d * d, axis=0)


ROWS = [(0.1, 1.0), (0.01, 0.1), (0.01, 10.0)]          # Q x10, R x0.1, R x10
LAGS = np.array([lags(q, r) for q, r in ROWS])           # (3, 2 lags, 2 components)
LAG1 = LAGS[:, 0]


def test_exercise_5_accepts_the_formula():
    # Q x10 and R x0.1 share Q / R: the same gain, the same r~_t after the first steps
    assert np.abs(LAG1[0] - LAG1[1]).max() < 1e-3
    assert np.all(LAG1[:2] < -0.062) and np.all(LAG1[2] > 0.062)
    correct(ch03.exercise_5(LAG1, "ratio"))
    correct(ch03.exercise_5(np.round(LAG1, 3).tolist(), " Ratio"))
    correct(ch03.exercise_5(LAG1[[1, 0, 2]], "ratio"))      # the first two rows agree


@pytest.mark.parametrize("answer, phrases", [
    (LAG1[[2, 0, 1]], ["another order"]),
    (np.ones((3, 2)), ["lag 0"]),
    (LAGS[:, 1], ["lag 2"]),
    (np.vstack([LAG1[:2], lags(0.001, 1.0)[0]]), ["row 3", "R ×10", "Q ×0.1"]),
    (np.vstack([LAG1[:2], LAG1[0]]), ["row 3", "Q ×10 or R ×0.1", "force_var / meas_var"]),
    (np.vstack([lags(0.01, 1.0)[0], LAG1[1:]]), ["row 1", "the correct model"]),
    (np.array([lags(q, r, ys=bf.models.simulate(bf.models.damped_particle(), 1000,
                                                 np.random.default_rng(6)).ys)[0]
               for q, r in ROWS]), ["another run", "ys_long of the answer cell", "np.corrcoef"]),
    (LAG1.T, ["transposed"]),
    (LAG1[:, 0], ["shape (3, 2)"]),
    (np.zeros((20, 2)), ["lag 1 only"]),
    (-LAG1, ["wrong sign"]),
])
def test_exercise_5_diagnoses_the_autocorrelations(answer, phrases):
    fb = ch03.exercise_5(answer, "ratio")
    wrong(fb, *phrases)
    assert "sees_5: correct." in fb.message
    hides(fb, LAG1)


def test_exercise_5_raw_innovations_are_close_enough():
    """S_t is diagonal here and settles within a few steps, so r_t and r~_t agree to 2e-3."""
    raw = np.array([lags(q, r, normalise=False)[0] for q, r in ROWS])
    assert np.abs(raw - LAG1).max() < ch03.ATOL_5
    correct(ch03.exercise_5(raw, "ratio"))


@pytest.mark.parametrize("sees, phrases", [
    ("scale", ["not the right option", "same Q / R"]),
    ("neither", ["not the right option"]),
    ("gain", ["must be one of ['ratio', 'scale', 'neither']"]),
])
def test_exercise_5_the_choice(sees, phrases):
    wrong(ch03.exercise_5(LAG1, sees), *phrases)


def test_exercise_5_a_teacher_changes_the_long_run():
    ys = bf.models.simulate(bf.models.damped_particle(), 600, np.random.default_rng(55)).ys
    rows = np.array([lags(q, r, ys=ys)[0] for q, r in ROWS])
    correct(ch03.exercise_5(rows, "ratio", namespace={"ys_long": ys, "N_long": 600}))
    assert ch03.exercise_5(LAG1, "ratio", namespace={"ys_long": ys}).status == INCORRECT


def test_exercise_5_not_attempted_and_garbage():
    not_attempted(ch03.exercise_5(None, None))
    fb = ch03.exercise_5(LAG1, None)
    assert fb.status == NOT_ATTEMPTED and "lag1_5: correct." in fb.message
    for garbage in GARBAGE:
        assert ch03.exercise_5(garbage, garbage).status == INCORRECT, garbage
