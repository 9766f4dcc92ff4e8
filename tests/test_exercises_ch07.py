"""Tests of bayesfilt.checks.ch07, the checks of the exercises of chapter 07 (smoothing).

For every exercise: the reference answer, computed here independently of the check (scalar
arithmetic, a covariance recursion written out with inverses, a particle genealogy and a
backward simulation written as plain loops), is accepted; plausible wrong answers are
rejected, each with its own diagnosis; None and NotImplementedError mean "not attempted
yet"; garbage never raises; a message never shows the reference. The inputs of the
notebook's statements are the module's constants.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

import bayesfilt as bf
from bayesfilt.checks import INCORRECT, NOT_ATTEMPTED
from exercise_helpers import (  # noqa: F401 - the shared helpers of the exercise tests
    correct, hides, not_attempted, not_implemented, solution_names, wrong,
)

ch07 = bf.checks.ch07
ROOT = Path(__file__).resolve().parents[1]
NOTEBOOK = ROOT / "notebooks" / "07_smoothing.ipynb"
inv = np.linalg.inv

GARBAGE = ["text", [[1.0, 2.0], [3.0]], np.ones(3), np.full(2, np.nan), {"a": 1}, object(),
           True, 1j, [], 1e308, float("inf"), float("nan")]


# ---------------------------------------------------------------------------
# The statements and the module use the same numbers; the cells follow the pattern
# ---------------------------------------------------------------------------

def _cells():
    nb = json.loads(NOTEBOOK.read_text(encoding="utf-8"))
    return [("".join(c["source"]), c["cell_type"], c["metadata"]) for c in nb["cells"]]


def _answer_cells() -> dict[int, str]:
    out, n = {}, None
    for source, kind, _ in _cells():
        if kind == "markdown" and source.startswith("### Exercise "):
            n = int(source.split()[2])
        elif kind == "code" and "### BEGIN SOLUTION" in source:
            out[n] = source
    return out


def _given(cell_source: str) -> dict:
    """Run the lines of an answer cell before its solution block (the given numbers)."""
    head = cell_source.split("### BEGIN SOLUTION")[0]
    namespace = {"np": np, "bf": bf}
    exec(head, namespace)  # noqa: S102 - the notebook's own given-numbers lines
    return namespace


def test_the_notebook_states_the_numbers_of_the_module():
    cells = _answer_cells()
    assert sorted(cells) == [1, 2, 3, 4]
    g1 = _given(cells[1])
    assert (g1["a_1"], g1["Q_1"], g1["x_filt_1"], g1["P_filt_1"], g1["x_next_1"],
            g1["P_next_1"]) == (ch07.A_1, ch07.Q_1, ch07.X_FILT_1, ch07.P_FILT_1,
                                ch07.X_NEXT_1, ch07.P_NEXT_1)
    g3 = _given(cells[3])
    assert g3["T_3"] == ch07.T_3
    np.testing.assert_array_equal(g3["gap_3"], np.arange(*ch07.GAP_3))
    assert np.isnan(g3["ys_3"][ch07.GAP_3[0]:ch07.GAP_3[1]]).all()
    assert not np.isnan(np.delete(g3["ys_3"], np.arange(*ch07.GAP_3), axis=0)).any()
    g4 = _given(cells[4])
    assert (g4["T_4"], g4["N_4"], g4["L_4"]) == (ch07.T_4, ch07.N_4, ch07.L_4)
    assert "default_rng(17)" in cells[4] and "default_rng(18)" in cells[4]
    text = "\n".join(source for source, kind, _ in _cells() if kind == "markdown")
    for seed in ch07.SEEDS_4:
        assert f"np.random.default_rng({seed})" in text


def test_solution_blocks_hold_only_defs_and_answer_assignments():
    answers = {1: {"gain_1", "mean_1", "var_1"}, 2: {"rts_step"},
               3: {"sd_filter_3", "sd_smooth_3"}, 4: {"distinct_genealogy_4", "distinct_ffbsi_4"}}
    for n, source in _answer_cells().items():
        assert solution_names(source) == answers[n], n


def test_check_cells_are_a_single_call_and_why_cells_are_graded_by_hand():
    cells = _cells()
    calls = [source for source, kind, _ in cells if kind == "code" and "bf.checks.ch07" in source]
    assert calls == ["bf.checks.ch07.exercise_1(gain_1, mean_1, var_1)",
                     "bf.checks.ch07.exercise_2(rts_step)",
                     "bf.checks.ch07.exercise_3(sd_filter_3, sd_smooth_3)",
                     "bf.checks.ch07.exercise_4(distinct_genealogy_4, distinct_ffbsi_4)"]
    why = [(source, meta["nbgrader"]) for source, kind, meta in cells
           if kind == "markdown" and "nbgrader" in meta]
    assert [m["grade_id"] for _, m in why] == ["ch07-ex3-why", "ch07-ex4-why"]
    for source, meta in why:
        assert meta == {"grade": True, "solution": True, "locked": False, "points": 1,
                        "grade_id": meta["grade_id"], "schema_version": 3, "task": False}
        assert source.startswith("**Why?** *(graded by hand, 1 point)*")
        assert "### BEGIN SOLUTION\n*Model answer.*" in source and "*Rubric.* 1 point" in source
        assert source.rstrip().endswith("### END SOLUTION")


def test_the_notebook_is_marked_beyond_the_sources():
    nb = json.loads(NOTEBOOK.read_text(encoding="utf-8"))
    assert nb["metadata"]["bayesfilt"] == {"beyond_sources": True}
    assert "Beyond the source notes" in "".join(nb["cells"][0]["source"])


# ---------------------------------------------------------------------------
# Exercise 1: one scalar backward step
# ---------------------------------------------------------------------------

a, Q, XF, PF, XS, PS = 0.8, 1.0, 2.0, 1.5, 2.5, 0.9
X_PRED, P_PRED = a * XF, a * a * PF + Q
GAIN = PF * a / P_PRED
MEAN = XF + GAIN * (XS - X_PRED)
VAR = PF + GAIN ** 2 * (PS - P_PRED)


def test_exercise_1_accepts_the_reference_in_any_numeric_form():
    assert np.isclose(VAR, PF - GAIN * a * PF + GAIN ** 2 * PS)   # the two forms of P_t|T-1
    correct(ch07.exercise_1(GAIN, MEAN, VAR))
    correct(ch07.exercise_1(np.float64(GAIN), np.array([MEAN]), np.array(VAR)))


@pytest.mark.parametrize("answers, phrases", [
    ((PF / P_PRED, MEAN, VAR), ["gain_1", "misses the transition factor", "mean_1: correct"]),
    ((a * PF / PS, MEAN, VAR), ["divides by the predicted variance"]),
    ((a * PF / (PF + Q), MEAN, VAR), ["scales the variance by a^2"]),
    ((a * a * PF / P_PRED, MEAN, VAR), ["one factor a"]),
    ((GAIN, XF + GAIN * (XS - XF), VAR), ["not with x_t|t"]),
    ((GAIN, XF - GAIN * (XS - X_PRED), VAR), ["sign of the correction"]),
    ((GAIN, X_PRED + GAIN * (XS - X_PRED), VAR), ["added to the filtered x_t|t"]),
    ((0.5, XF + 0.5 * (XS - X_PRED), PF + 0.25 * (PS - P_PRED)),
     ["mean follows from your gain_1", "variance follows from your gain_1"]),
    ((GAIN, MEAN, PF + GAIN * (PS - P_PRED)), ["enters twice"]),
    ((GAIN, MEAN, PF + GAIN ** 2 * (P_PRED - PS)), ["variance shrinks"]),
    ((GAIN, MEAN, PF - GAIN ** 2 * P_PRED), ["residual's variance alone"]),
    ((GAIN, MEAN, GAIN ** 2 * PS), ["only the part due to the smoothed"]),
    ((GAIN, MEAN, PF + GAIN ** 2 * (PS - PF)), ["not with P_t|t"]),
    ((GAIN, MEAN, np.sqrt(VAR)), ["standard deviation"]),
    ((GAIN, MEAN, round(VAR, 2)), ["rounded to 2 decimals"]),
    ((GAIN, MEAN, VAR + 1.0), ["var_1 is too large"]),
])
def test_exercise_1_diagnoses(answers, phrases):
    fb = ch07.exercise_1(*answers)
    wrong(fb, *phrases)
    hides(fb, [GAIN, MEAN, VAR], digits=3)


def test_exercise_1_not_attempted_and_garbage():
    not_attempted(ch07.exercise_1(None, None, None))
    fb = ch07.exercise_1(GAIN, None, None)
    assert fb.status == NOT_ATTEMPTED and "gain_1: correct" in fb.message
    for garbage in GARBAGE:
        assert ch07.exercise_1(garbage, garbage, garbage).status == INCORRECT, garbage


# ---------------------------------------------------------------------------
# Exercise 2: one backward step as a function
# ---------------------------------------------------------------------------

def step_by_inverse(mean_filt, cov_filt, mean_pred, cov_pred, mean_next, cov_next, A):
    J = cov_filt @ A.T @ inv(cov_pred)
    return mean_filt + J @ (mean_next - mean_pred), cov_filt + J @ (cov_next - cov_pred) @ J.T


def test_exercise_2_reference_is_one_step_of_the_joint_gaussian():
    """On exercise 1's scalar numbers, the step equals the conditional of x_t given x_t+1
    averaged over the smoothed x_t+1 (scalar arithmetic)."""
    mean, cov = step_by_inverse(np.array([XF]), np.array([[PF]]), np.array([X_PRED]),
                                np.array([[P_PRED]]), np.array([XS]), np.array([[PS]]),
                                np.array([[a]]))
    np.testing.assert_allclose([mean[0], cov[0, 0]], [MEAN, VAR], rtol=1e-12)
    correct(ch07.exercise_2(step_by_inverse))
    correct(ch07.exercise_2(lambda mf, Pf, mp, Pp, ms, Ps, A: tuple(
        step_by_inverse(mf, Pf, mp, Pp, ms, Ps, A))))
    correct(ch07.exercise_2(lambda *args: list(step_by_inverse(*args))))


def _with_gain(J_of):
    def step(mf, Pf, mp, Pp, ms, Ps, A):
        J = J_of(Pf, Pp, Ps, A)
        return mf + J @ (ms - mp), Pf + J @ (Ps - Pp) @ J.T
    return step


@pytest.mark.parametrize("fun, phrases", [
    (_with_gain(lambda Pf, Pp, Ps, A: np.linalg.solve(Pp, A @ Pf)), ["test input 2", "transposed"]),
    (_with_gain(lambda Pf, Pp, Ps, A: Pf @ A.T @ inv(Ps)), ["test input 1", "smoothed P_t+1|T-1"]),
    (_with_gain(lambda Pf, Pp, Ps, A: Pf @ inv(Pp)), ["test input 1", "misses A^T"]),
    (_with_gain(lambda Pf, Pp, Ps, A: Pf @ A @ inv(Pp)), ["test input 2", "A where A^T belongs"]),
    (lambda mf, Pf, mp, Pp, ms, Ps, A: (
        step_by_inverse(mf, Pf, mp, Pp, ms, Ps, A)[0],
        Pf + Pf @ A.T @ inv(Pp) @ (Pp - Ps) @ inv(Pp) @ A @ Pf), ["wrong sign"]),
    (lambda mf, Pf, mp, Pp, ms, Ps, A: (
        step_by_inverse(mf, Pf, mp, Pp, ms, Ps, A)[0],
        Pf + Pf @ A.T @ inv(Pp) @ (Ps - Pp)), ["J_t on both sides"]),
    (lambda mf, Pf, mp, Pp, ms, Ps, A: (
        mf + Pf @ A.T @ inv(Pp) @ (ms - mf), step_by_inverse(mf, Pf, mp, Pp, ms, Ps, A)[1]),
     ["not with x_t|t"]),
    (lambda *args: step_by_inverse(*args)[::-1], ["test input 1", "wrong order"]),
    (lambda *args: step_by_inverse(*args)[0], ["must return the pair"]),
    (lambda *args: (step_by_inverse(*args)[0], None), ["the pair holds None"]),
])
def test_exercise_2_diagnoses(fun, phrases):
    fb = ch07.exercise_2(fun)
    wrong(fb, *phrases)


def test_exercise_2_an_input_changed_in_place_is_not_yet():
    def spoils(mf, Pf, mp, Pp, ms, Ps, A):
        out = step_by_inverse(mf, Pf, mp, Pp, ms, Ps, A)
        Pf += 1.0
        return out
    wrong(ch07.exercise_2(spoils), "in place")


def test_exercise_2_not_attempted_and_garbage():
    not_attempted(ch07.exercise_2(None))
    fb = ch07.exercise_2(not_implemented)
    not_attempted(fb)
    assert "still raises NotImplementedError" in fb.message
    for garbage in [3, "rts_step", lambda x: x, lambda *a: "mean", lambda *a: None,
                    lambda *a: (np.nan, np.nan), lambda *a: 1 / 0,
                    lambda *a: ([[1.0], [2.0, 3.0]], 0), lambda *a: (1e308, 1e308)]:
        assert ch07.exercise_2(garbage).status == INCORRECT, garbage


# ---------------------------------------------------------------------------
# Exercise 3: the smoothed variance in a gap
# ---------------------------------------------------------------------------

def gap_covariances(first, stop, T=100):
    """The filter's and the RTS smoother's covariances of the damped particle with no
    measurement at steps first, ..., stop - 1: the covariance recursions written out."""
    A = np.array([[1.0, 1.0, 0, 0], [0, 0.98, 0, 0], [0, 0, 1.0, 1.0], [0, 0, 0, 0.98]])
    C = np.array([[1.0, 0, 0, 0], [0, 0, 1.0, 0]])
    GQGt = np.diag([0.0, 0.01, 0.0, 0.01])
    P, filt, pred = np.eye(4), [], []
    for t in range(T):
        if t > 0:
            P = A @ P @ A.T + GQGt
        pred.append(P)
        if not first <= t < stop:
            P = P - P @ C.T @ inv(C @ P @ C.T + np.eye(2)) @ C @ P
        filt.append(P)
    smooth = [filt[-1]]
    for t in range(T - 2, -1, -1):
        J = filt[t] @ A.T @ inv(pred[t + 1])
        smooth.insert(0, filt[t] + J @ (smooth[0] - pred[t + 1]) @ J.T)
    return np.array(filt), np.array(smooth)


FILT_3, SMOOTH_3 = gap_covariances(40, 60)
SD_F = np.sqrt(FILT_3[40:60, 0, 0])
SD_S = np.sqrt(SMOOTH_3[40:60, 0, 0])


def test_exercise_3_accepts_the_reference():
    assert np.argmax(SD_F) == 19 and 5 < np.argmax(SD_S) < 15   # the end; the middle
    correct(ch07.exercise_3(SD_F.max(), SD_S.max()))
    correct(ch07.exercise_3(np.float32(SD_F.max()), SD_S.max()))


LONGER_F, LONGER_S = (np.sqrt(P[40:61, 0, 0]).max() for P in gap_covariances(40, 61))


@pytest.mark.parametrize("answers, phrases", [
    ((SD_F.max() ** 2, SD_S.max() ** 2), ["this is a variance", "sd_smooth_3: this is a var"]),
    ((SD_S.max(), SD_F.max()), ["the smoother's value", "the filter's value"]),
    ((np.sqrt(FILT_3[40:60, 1, 1]).max(), np.sqrt(SMOOTH_3[40:60, 1, 1]).max()),
     ["velocity"]),
    ((LONGER_F, LONGER_S), ["one step too long"]),
    ((SD_F[0], SD_S[-1]), ["gap's first step", "gap's last step"]),
    ((SD_F.max(), np.sqrt(gap_covariances(0, 0)[1][40:60, 0, 0]).max()),
     ["sd_filter_3: correct", "without a gap"]),
    ((SD_F.max(), SD_S.max() * 1.1), ["too large"]),
])
def test_exercise_3_diagnoses(answers, phrases):
    fb = ch07.exercise_3(*answers)
    wrong(fb, *phrases)
    hides(fb, [SD_F.max(), SD_S.max()], digits=3)


def test_exercise_3_not_attempted_and_garbage():
    not_attempted(ch07.exercise_3(None, None))
    for garbage in GARBAGE:
        assert ch07.exercise_3(garbage, garbage).status == INCORRECT, garbage


# ---------------------------------------------------------------------------
# Exercise 4: distinct particles at t = 0
# ---------------------------------------------------------------------------

def distinct_counts():
    """The genealogy and FFBSi written as plain loops over the particle filter's history
    (the same uniform draws as bf.smoothing.ffbsi: one per trajectory and step, by inverse
    CDF); returns the counts at t = 0 and the genealogy's count at t = 1."""
    ungm = bf.models.ungm()
    ys = bf.models.simulate(ungm, 50, np.random.default_rng(17)).ys
    h = bf.particle.particle_filter(ungm, ys, 200, np.random.default_rng(18),
                                    keep_history=True).history
    T, N = h.weights.shape
    line = np.arange(N)
    counts = {}
    for t in range(T - 1, 0, -1):
        line = h.ancestors[t][line]                     # the parents, at t - 1
        counts[t - 1] = len(set(line.tolist()))
    rng = np.random.default_rng(19)
    L = 200
    u = rng.random(L)
    idx = [int(np.searchsorted(np.cumsum(h.weights[-1]), u_l * h.weights[-1].sum(),
                               side="right")) for u_l in u]
    for t in range(T - 2, -1, -1):
        u = rng.random(L)
        new = []
        for l_, i_next in enumerate(idx):
            x_next = h.particles[t + 1, i_next, 0]
            f = ungm.f(h.particles[t, :, 0], t)           # the mean of x_t+1 given x_t
            w = h.weights[t] * np.exp(-0.5 * (x_next - f) ** 2 / 10.0)
            c = np.cumsum(w)
            new.append(min(int(np.searchsorted(c, u[l_] * c[-1], side="right")), N - 1))
        idx = new
    return counts[0], len(set(idx)), counts[1]


REF_G, REF_F, AT_1 = distinct_counts()


def test_exercise_4_accepts_the_reference():
    assert 1 <= REF_G < 20 and REF_F > 3 * REF_G      # degenerate genealogy, FFBSi is not
    correct(ch07.exercise_4(REF_G, REF_F))
    correct(ch07.exercise_4(np.int64(REF_G), float(REF_F)))


@pytest.mark.parametrize("answers, phrases", [
    ((200, REF_F), ["count at the last step", "ancestors[0]"]),
    ((REF_G, 200), ["number of trajectories"]),
    ((REF_G, REF_G), ["the genealogy's count"]),
    ((REF_G + 7, REF_F), ["too large", "seeds"]),
    ((REF_G, REF_F - 5), ["too small"]),
    ((2.5, REF_F), ["whole number"]),
])
def test_exercise_4_diagnoses(answers, phrases):
    fb = ch07.exercise_4(*answers)
    wrong(fb, *phrases)
    hides(fb, [REF_F], min_digits=2)


def test_exercise_4_not_attempted_and_garbage():
    not_attempted(ch07.exercise_4(None, None))
    for garbage in GARBAGE:
        assert ch07.exercise_4(garbage, garbage).status == INCORRECT, garbage


@pytest.mark.filterwarnings("error")
def test_checks_themselves_raise_no_warning_on_garbage():
    for garbage in GARBAGE:
        ch07.exercise_1(garbage, garbage, garbage)
        ch07.exercise_3(garbage, garbage)
        ch07.exercise_4(garbage, garbage)
    ch07.exercise_2(lambda *a: (np.full(len(a[0]), 1e308), np.full((len(a[0]),) * 2, 1e308)))
