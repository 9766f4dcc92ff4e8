"""Tests of bayesfilt.checks.ch04, the checks of the exercises of chapter 04 (the EKF).

For every exercise: the reference answer, computed here independently of the
check (a Jacobian written out by hand or by central differences, filterpy's
EKF update, the MAP by numerical optimisation, the experiment re-run with
other seeds, ``np.angle`` for the wrap), is accepted; plausible wrong answers
are rejected, each with its own diagnosis (asserted on the message); None
and NotImplementedError mean "not attempted yet"; garbage never raises. The
numbers of the notebook's statements are the module's constants.
"""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest
from scipy.optimize import minimize

import bayesfilt as bf
from bayesfilt.checks import CORRECT, INCORRECT, NOT_ATTEMPTED, Feedback
from exercise_helpers import (  # noqa: F401 - the shared helpers of the exercise tests
    solution_names, correct, fails_oddly, hides as _hides, never_raises as _never_raises, not_attempted,
    not_implemented, Odd, wrong,
)


def hides(fb, expected):
    _hides(fb, expected, digits=4, integers=False)

ch04 = bf.checks.ch04
ROOT = Path(__file__).resolve().parents[1]
NOTEBOOK = ROOT / "notebooks" / "04_ekf_linearization.ipynb"

MODEL = bf.models.range_bearing()
R = np.diag([0.1, 0.01])                    # the statement's R, written out again
X_START = np.array([10.0, -5.0, -0.2, 0.2])
inv = np.linalg.inv


GARBAGE = ["text", b"x", [[1.0, 2.0], [3.0]], np.ones(3), np.ones((3, 3)), np.full(2, np.nan),
           {"a": 1}, object(), True, np.array([1j, 0]), [], np.full(2, 1e308), Ellipsis, 3,
           -1.5, [None, 1.0]]
BAD_FUNCTIONS = [3, "f", np.eye(2), lambda *a: "H", lambda *a: {"H": 1},
                 lambda *a: [[1.0], [2.0, 3.0]],
                 lambda *a: np.full((2, 4), np.nan), lambda *a: np.full((5, 5), np.inf),
                 lambda *a: 1 / 0, lambda *a: np.full((2, 2), 1e308), lambda *a: object(),
                 fails_oddly, lambda: None, lambda *a: np.ones((7, 7))]


def never_raises(check, answers):
    _never_raises(check, answers, unpack=True)


# ---------------------------------------------------------------------------
# The statements and the module use the same numbers; the cells follow the pattern
# ---------------------------------------------------------------------------

def _cells():
    nb = json.loads(NOTEBOOK.read_text(encoding="utf-8"))
    return [("".join(c["source"]), c["cell_type"]) for c in nb["cells"]]


def _exercise_cells() -> dict[int, dict[str, str]]:
    out, n = {}, None
    for source, kind in _cells():
        if kind == "markdown" and source.startswith("### Exercise "):
            n = int(source.split()[2])
            out[n] = {"statement": source}
        elif n is not None and kind == "code" and "### BEGIN SOLUTION" in source:
            out[n]["answer"] = source
        elif n is not None and kind == "code" and "bf.checks.ch04" in source:
            out[n]["check"] = source
        elif n is not None and kind == "code":
            # given code in a cell of its own before the answer cell (kept short)
            out[n]["given"] = out[n].get("given", "") + source + "\n"
    return out


def _given(answer_cell: str, namespace: dict) -> dict:
    """Run the lines of an answer cell before its solution block (the given code)."""
    exec(answer_cell.split("### BEGIN SOLUTION")[0], namespace)  # noqa: S102 - the notebook's own
    return namespace


def test_five_exercises_in_the_pattern():
    cells = _exercise_cells()
    assert sorted(cells) == [1, 2, 3, 4, 5]
    for n, parts in cells.items():
        assert set(parts) - {"given"} == {"statement", "answer", "check"}, n


def test_the_notebook_states_the_numbers_of_the_module():
    cells = _exercise_cells()
    text1 = cells[1]["statement"]
    for state in ch04.H_STATES:
        shown = "[" + ", ".join(f"{v:g}" for v in state) + "]"
        assert shown in text1, shown
    assert ch04.H_STATES[ch04.ON_THE_RY_AXIS][0] == 0.0 and "$\\xi_x = 0$" in text1
    text2, answer2 = cells[2]["statement"], cells[2].get("given", "") + cells[2]["answer"]
    assert "0.1\\ \\mathrm{m}^2" in text2 and "0.01\\ \\mathrm{rad}^2" in text2
    np.testing.assert_array_equal(MODEL.R, R)
    assert f"np.random.default_rng({ch04.NEES_SEED})" in answer2 and "T=11" in answer2
    assert ch04.NEES_STEPS == 10 and ch04.NEES_RUNS == 100 and "y_1, \\dots, y_{10}" in text2
    text4 = cells[4]["statement"]
    for state in ch04.TURN_STATES:
        shown = "[" + ", ".join("\\pi/2" if np.isclose(v, np.pi / 2) else f"{v:g}"
                                for v in state) + "]"
        assert shown in text4, shown
    text5 = cells[5]["statement"]
    for y, y_pred in ch04.INNOVATION_CASES[:4]:
        assert f"{y[1]:g}" in text5 and f"{y_pred[1]:g}" in text5
    assert "[11.03, -0.405]" in text5 and "[7.07, 0.785]" in text5
    y, y_pred = ch04.INNOVATION_CASES[ch04.EXACTLY_PI]
    assert y[1] - y_pred[1] == np.pi


def test_solution_blocks_hold_only_defs_and_answer_assignments():
    """What tools/make_student_edition.py can stub: top-level defs and assignments only."""
    answers = {1: {"range_bearing_jacobian"}, 2: {"converted_cov", "nees_2"},
               3: {"iterated_ekf_update", "answer_3"}, 4: {"turn_jacobian"},
               5: {"wrapped_innovation"}}
    for n, parts in _exercise_cells().items():
        source = parts["answer"]
        assert solution_names(source) == answers[n], n


def test_check_cells_are_a_single_call():
    calls = [parts["check"] for _, parts in sorted(_exercise_cells().items())]
    assert calls == ["bf.checks.ch04.exercise_1(range_bearing_jacobian)",
                     "bf.checks.ch04.exercise_2(converted_cov, nees_2)",
                     "bf.checks.ch04.exercise_3(iterated_ekf_update, answer_3)",
                     "bf.checks.ch04.exercise_4(turn_jacobian)",
                     "bf.checks.ch04.exercise_5(wrapped_innovation)"]


def test_the_given_numbers_are_read_only():
    with pytest.raises(ValueError):
        ch04.H_STATES[0, 0] = 5.0
    with pytest.raises(ValueError):
        ch04.INNOVATION_CASES[0][0][1] = 0.0


def test_the_notebooks_f_turn_is_the_modules():
    namespace = _given(_exercise_cells()[4]["answer"], {"np": np})
    for (x,) in ch04._turn_cases():
        np.testing.assert_allclose(namespace["f_turn"](x), ch04.f_turn(x), rtol=0, atol=1e-15)


# ---------------------------------------------------------------------------
# Exercise 1: the range-bearing Jacobian
# ---------------------------------------------------------------------------

def jacobian_by_hand(x):
    rx, ry = x[0], x[1]
    rho2 = rx * rx + ry * ry
    rho = np.sqrt(rho2)
    return np.array([[rx / rho, ry / rho, 0.0, 0.0], [-ry / rho2, rx / rho2, 0.0, 0.0]])


def test_ex1_the_reference_is_model_H_and_central_differences_at_every_state():
    states = [x for (x,) in ch04._jacobian_states()]
    assert len(states) == 8
    for x in states:
        numerical = bf.ekf.numerical_jacobian(MODEL.h, x)
        np.testing.assert_allclose(MODEL.H(x), numerical, rtol=1e-6, atol=1e-8)
        np.testing.assert_allclose(jacobian_by_hand(x), MODEL.H(x), rtol=1e-12, atol=1e-15)
        assert not (x[0] < 0 and abs(x[1]) < 0.5), "a state on the cut of atan2"


def test_ex1_accepts_the_hand_derivation_and_refuses_central_differences():
    correct(ch04.exercise_1(jacobian_by_hand))
    wrong(ch04.exercise_1(lambda x: bf.ekf.numerical_jacobian(MODEL.h, x)),
          "finite-difference", "by hand")
    correct(ch04.exercise_1(lambda x: jacobian_by_hand(x).tolist()))


def _arctan_route(x):
    """The derivation through arctan(xi_y / xi_x), not simplified: NaN where xi_x = 0."""
    rx, ry = x[0], x[1]
    rho = np.hypot(rx, ry)
    u = ry / rx
    return np.array([[rx / rho, ry / rho, 0.0, 0.0],
                     [1 / (1 + u**2) * (-ry / rx**2), 1 / (1 + u**2) / rx, 0.0, 0.0]])


def _arctan_route_floats(x):
    rx, ry = float(x[0]), float(x[1])
    rho = (rx * rx + ry * ry) ** 0.5
    return [[rx / rho, ry / rho, 0.0, 0.0],
            [1 / (1 + (ry / rx) ** 2) * (-ry / rx**2), 1 / (1 + (ry / rx) ** 2) / rx, 0.0, 0.0]]


def _chapter_03_order(x, read=True):
    ry = x[2] if read else x[1]
    H = jacobian_by_hand(np.array([x[0], ry]))
    out = np.zeros((2, 4))
    out[:, [0, 2]] = H[:, :2]
    return out


def _reads_r_y_from_v_x(x):
    return jacobian_by_hand(np.array([x[0], x[2]]))


@pytest.mark.parametrize("fun, phrases", [
    (lambda x: jacobian_by_hand(x)[::-1], ["test input 1", "rows are swapped"]),
    (lambda x: jacobian_by_hand(x).T, ["transposed", "shape (2, 4)"]),
    (lambda x: _chapter_03_order(x, read=False), ["chapter 03's state order", "columns 0 and 1"]),
    (_chapter_03_order, ["chapter 03's order", "xi_y = x[2]"]),
    (_reads_r_y_from_v_x, ["you read xi_y from x[2]"]),
    (lambda x: jacobian_by_hand(x) * np.array([[1.0], [-1.0]]), ["bearing row has the wrong sign"]),
    (lambda x: -jacobian_by_hand(x), ["both rows have the wrong sign"]),
    (lambda x: jacobian_by_hand(x) * np.array([[1.0], [np.hypot(x[0], x[1])]]),
     ["divided by rho; it is divided by rho^2"]),
    (lambda x: jacobian_by_hand(x) * np.array([[np.hypot(x[0], x[1])], [1.0]]),
     ["range row is not divided by rho"]),
    (lambda x: jacobian_by_hand(x) * np.array([[2 * np.hypot(x[0], x[1])], [1.0]]),
     ["derivative of rho^2"]),
    (lambda x: jacobian_by_hand(x)[:, :2], ["velocities do not enter h", "(2, 2)"]),
    (_arctan_route, ["test input 5", "xi_y axis", "NaN or inf", "simplify"]),
    (_arctan_route_floats, ["test input 5", "ZeroDivisionError", "only rho^2"]),
])
def test_ex1_diagnoses(fun, phrases):
    fb = ch04.exercise_1(fun)
    wrong(fb, *phrases)
    hides(fb, jacobian_by_hand(X_START))


def test_ex1_an_unrecognised_mistake_names_the_partial_derivative():
    def off(x):
        H = jacobian_by_hand(x)
        H[1, 0] += 0.01
        return H
    wrong(ch04.exercise_1(off), "d beta / d xi_x", "entry (1, 0)")


def test_ex1_the_check_prints_no_warning(recwarn):
    ch04.exercise_1(_arctan_route)
    assert not [w for w in recwarn if issubclass(w.category, RuntimeWarning)]


def test_ex1_an_input_changed_in_place_is_not_yet():
    def spoils_its_input(x):
        H = jacobian_by_hand(x)
        x[:] = 0.0
        return H
    wrong(ch04.exercise_1(spoils_its_input), "in place", "test input")


def test_ex1_not_attempted_and_garbage():
    not_attempted(ch04.exercise_1(None))
    not_attempted(ch04.exercise_1(not_implemented))
    wrong(ch04.exercise_1(lambda x: len(x) and None), "forget `return`")
    wrong(ch04.exercise_1(lambda x: None), "forget `return`")         # a lambda is never a stub
    wrong(ch04.exercise_1(lambda x: x[7]), "IndexError", "shape (4,)")
    wrong(ch04.exercise_1(fails_oddly), "fails on test input 1", "Odd")
    never_raises(ch04.exercise_1, BAD_FUNCTIONS + GARBAGE)


# ---------------------------------------------------------------------------
# Exercise 2: a prior from the first measurement
# ---------------------------------------------------------------------------

def polar_to_cartesian(y):
    return np.array([y[0] * np.cos(y[1]), y[0] * np.sin(y[1])])


def converted_cov_numerically(y):
    J = bf.ekf.numerical_jacobian(polar_to_cartesian, y)
    return J @ R @ J.T


def converted_cov_by_hand(y):
    rho, beta = y
    J = np.array([[np.cos(beta), -rho * np.sin(beta)], [np.sin(beta), rho * np.cos(beta)]])
    return J @ R @ J.T


def test_ex2_the_closed_form_is_the_linearised_covariance_and_matches_monte_carlo():
    for (y,) in ch04._convert_cases():
        np.testing.assert_allclose(ch04._converted_cov(y), converted_cov_numerically(y),
                                   rtol=1e-6, atol=1e-9)
    # with small noise the converted points have about this covariance (10 m away, R / 100)
    rng = np.random.default_rng(7)
    y = np.array([10.0, 0.7])
    noise = rng.multivariate_normal(np.zeros(2), R / 100, 200_000)
    points = np.array([polar_to_cartesian(y + v) for v in noise[:20_000]])
    np.testing.assert_allclose(np.cov(points.T), converted_cov_by_hand(y) / 100,
                               rtol=0.05, atol=1e-5)


def test_ex2_accepts_the_closed_form_and_central_differences():
    correct(ch04.exercise_2(converted_cov_by_hand, 4.1))
    correct(ch04.exercise_2(converted_cov_numerically, 4.1))


@pytest.fixture(scope="module")
def notebook_experiment():
    """The function the answer cell gives, run with the chapter's variables."""
    namespace = {"np": np, "bf": bf, "dataclasses": dataclasses, "model": MODEL,
                 "x_start": bf.models.RANGE_BEARING_TRUE_START, "pos": MODEL.index_of("xi_x", "xi_y")}
    cells = _exercise_cells()[2]
    return _given(cells.get("given", "") + cells["answer"], namespace)["nees_from_first_measurement"]


def test_ex2_the_notebooks_experiment_is_the_modules(notebook_experiment):
    ours = notebook_experiment(converted_cov_by_hand, np.random.default_rng(3), n_runs=5)
    theirs = ch04._nees_experiment(converted_cov_by_hand, np.random.default_rng(3), n_runs=5)
    np.testing.assert_allclose(ours, theirs, rtol=1e-12)
    assert ours.shape == (5, 10)


@pytest.mark.parametrize("seed", [10, 123, 2024])
def test_ex2_the_band_holds_for_other_seeds(notebook_experiment, seed):
    """The right prior gives an accepted nees_2 whatever the seed (over 100 seeds its average
    is 4.15, standard deviation 0.25, extremes 3.56 and 4.93; the band is 3.0-5.5)."""
    nees = notebook_experiment(converted_cov_by_hand, np.random.default_rng(seed))
    correct(ch04.exercise_2(converted_cov_by_hand, float(nees.mean())))
    correct(ch04.exercise_2(converted_cov_by_hand, nees.mean()))       # a numpy float


def test_ex2_the_mistaken_priors_give_a_rejected_nees(notebook_experiment):
    no_rho = lambda y: converted_cov_by_hand([1.0, y[1]])                # noqa: E731
    nees = notebook_experiment(no_rho, np.random.default_rng(10)).mean()
    wrong(ch04.exercise_2(converted_cov_by_hand, float(nees)), "order of magnitude", "factor rho")

    def transposed(y):
        rho, beta = y
        J = np.array([[np.cos(beta), -rho * np.sin(beta)], [np.sin(beta), rho * np.cos(beta)]])
        return J.T @ R @ J
    nees = notebook_experiment(transposed, np.random.default_rng(10)).mean()
    wrong(ch04.exercise_2(converted_cov_by_hand, float(nees)), "overconfident", "J^T R J")


def _J(y, rho_in=True):
    rho, beta = y
    r = rho if rho_in else 1.0
    return np.array([[np.cos(beta), -r * np.sin(beta)], [np.sin(beta), r * np.cos(beta)]])


@pytest.mark.parametrize("fun, phrases", [
    (lambda y: _J(y, False) @ R @ _J(y, False).T, ["test input 1", "rho is missing from J"]),
    (lambda y: _J(y).T @ R @ _J(y), ["J^T R J"]),
    (lambda y: _J(y) @ np.sqrt(R) @ _J(y).T, ["square roots", "standard deviations"]),
    (lambda y: _J(y) @ R, ["not symmetric"]),
    (lambda y: R, ["R itself"]),
    (lambda y: np.diag(np.diag(_J(y) @ R @ _J(y).T)), ["only the diagonal"]),
    (lambda y: (lambda J: J @ R @ J.T)(np.array([[np.sin(y[1]), y[0] * np.cos(y[1])],
                                                 [np.cos(y[1]), -y[0] * np.sin(y[1])]])),
     ["from the xi_y axis"]),
    (lambda y: inv(_J(y) @ R @ _J(y).T), ["precision"]),
])
def test_ex2_diagnoses_of_converted_cov(fun, phrases):
    fb = ch04.exercise_2(fun, 4.2)
    wrong(fb, *phrases)
    assert "nees_2: correct." in fb.message
    hides(fb, converted_cov_by_hand(np.array([11.03, -0.405])))


@pytest.mark.parametrize("nees, phrases", [
    (80.0, ["order of magnitude", "factor rho"]),
    (9.5, ["overconfident", "J^T R J"]),
    (2.0, ["underconfident", "variances"]),
    (4150.0, ["sum the NEES"]),
    (-1.0, ["negative"]),
    ("4.1", ["single number"]),
    (np.array([4.1, 4.2]), ["single number"]),
    (float("nan"), ["NaN"]),
])
def test_ex2_diagnoses_of_nees_2(nees, phrases):
    fb = ch04.exercise_2(converted_cov_by_hand, nees)
    wrong(fb, *phrases)
    assert "converted_cov: correct." in fb.message
    assert "3.0" not in fb.message and "5.5" not in fb.message


def test_ex2_not_attempted_and_garbage():
    not_attempted(ch04.exercise_2(None, None))
    not_attempted(ch04.exercise_2(not_implemented, None))
    fb = ch04.exercise_2(converted_cov_by_hand, None)
    not_attempted(fb)
    assert "converted_cov: correct." in fb.message
    assert "nees_2: not attempted yet (nees_2 is still None)." in fb.message
    fb = ch04.exercise_2(not_implemented, None)
    assert "converted_cov still raises NotImplementedError and nees_2 is still None" in fb.message
    wrong(ch04.exercise_2(None, 80.0), "converted_cov: not attempted yet", "order of magnitude")
    never_raises(ch04.exercise_2, [(g, g) for g in BAD_FUNCTIONS + GARBAGE])


# ---------------------------------------------------------------------------
# Exercise 3: the iterated EKF
# ---------------------------------------------------------------------------

def iterated(m0, P0, y, n_iter, variant="right"):
    """The statement's recursion, written out with numpy (wrap by np.angle)."""
    x = np.array(m0, dtype=float)
    P = np.array(P0, dtype=float)
    for _ in range(n_iter):
        H = MODEL.H(x)
        d = y - MODEL.h(x)
        d[1] = np.angle(np.exp(1j * d[1]))
        K = P0 @ H.T @ inv(H @ P0 @ H.T + R)
        if variant == "right":
            x = m0 + K @ (d - H @ (m0 - x))
        elif variant == "latest":
            x = x + K @ d
        elif variant == "no_term":
            x = m0 + K @ d
        elif variant == "repeated":
            K = P @ H.T @ inv(H @ P @ H.T + R)
            x, P = x + K @ d, (np.eye(4) - K @ H) @ P
    return x


@pytest.fixture(scope="module")
def y0():
    sim = bf.models.simulate(MODEL, 100, np.random.default_rng(0), x0=X_START)
    return sim.ys[0]


@pytest.fixture(scope="module")
def map_position(y0):
    """The MAP of the first update by numerical optimisation (the limit of Gauss-Newton)."""
    P0_inv = inv(MODEL.P0[:2, :2])

    def negative_log_posterior(p):
        d = y0 - MODEL.h(np.array([p[0], p[1], 0.0, 0.0]))
        d[1] = np.angle(np.exp(1j * d[1]))
        return 0.5 * d @ inv(R) @ d + 0.5 * (p - 5.0) @ P0_inv @ (p - 5.0)
    result = minimize(negative_log_posterior, [12.0, 0.0], method="Nelder-Mead",
                      options={"xatol": 1e-9, "fatol": 1e-14, "maxiter": 5000})
    return result.x


def test_ex3_the_limit_is_the_map_and_one_iteration_is_filterpys_update(y0, map_position):
    from filterpy.kalman import ExtendedKalmanFilter
    np.testing.assert_allclose(iterated(MODEL.m0, MODEL.P0, y0, 50)[:2], map_position, atol=1e-5)
    np.testing.assert_allclose(ch04._limit_positions()["limit"], map_position, atol=1e-5)
    fp = ExtendedKalmanFilter(dim_x=4, dim_z=2)
    fp.x, fp.P, fp.R = MODEL.m0.copy(), MODEL.P0.copy(), R.copy()
    fp.update(y0, HJacobian=MODEL.H, Hx=MODEL.h, residual=bf.models.range_bearing_residual)
    np.testing.assert_allclose(iterated(MODEL.m0, MODEL.P0, y0, 1), fp.x, rtol=1e-10)


def test_ex3_accepts_the_recursion_and_the_map(y0, map_position):
    correct(ch04.exercise_3(iterated, map_position))
    correct(ch04.exercise_3(iterated, np.round(map_position, 2)))
    correct(ch04.exercise_3(iterated, list(map_position)))
    correct(ch04.exercise_3(iterated, iterated(MODEL.m0, MODEL.P0, y0, 20)[:2]))


def test_ex3_the_wrap_case_straddles_the_cut():
    m0, P0, y = ch04.WRAP_PRIOR
    d = y[1] - MODEL.h(m0)[1]
    assert abs(d) > np.pi and abs(np.angle(np.exp(1j * d))) < 0.2


def _iterations(variant=None, shift=0, wrap=True, fixed_H=False, sign=-1.0):
    def fun(m0, P0, y, n_iter):
        x = np.array(m0, dtype=float)
        for _ in range(max(n_iter + shift, 0)):
            H = MODEL.H(m0 if fixed_H else x)
            d = y - MODEL.h(x)
            if wrap:
                d[1] = np.angle(np.exp(1j * d[1]))
            x = m0 + P0 @ H.T @ inv(H @ P0 @ H.T + R) @ (d + sign * H @ (m0 - x))
        return x
    if variant is not None:
        return lambda m0, P0, y, n: iterated(m0, P0, y, n, variant)
    return fun


@pytest.mark.parametrize("fun, phrases", [
    (_iterations(shift=1), ["test input 1", "x^(n_iter + 1)"]),
    (_iterations(shift=-1), ["test input 1", "x^(n_iter - 1)"]),
    (_iterations("repeated"), ["test input 2", "counts y once more"]),
    (_iterations("latest"), ["test input 2", "from the latest iterate"]),
    (_iterations("no_term"), ["test input 2", "H_i (m0 - x^(i)) is missing"]),
    (_iterations(sign=1.0), ["test input 2", "wrong sign"]),
    (_iterations(wrap=False), ["test input 5", "not wrapped"]),
    (_iterations(fixed_H=True), ["test input 2", "keep the Jacobian of m0"]),
    (lambda m0, P0, y, n: iterated(m0, P0, y, n)[:2], ["test input 1", "whole state", "(4,)"]),
])
def test_ex3_diagnoses_of_the_function(fun, phrases, map_position):
    fb = ch04.exercise_3(fun, map_position)
    wrong(fb, *phrases)
    assert "answer_3: correct." in fb.message


def test_ex3_diagnoses_of_answer_3(y0, map_position):
    def check(answer, *phrases):
        fb = ch04.exercise_3(iterated, answer)
        wrong(fb, *phrases)
        assert "iterated_ekf_update: correct." in fb.message
        assert f"{map_position[0]:.2f}" not in fb.message
        assert f"{map_position[1]:.2f}" not in fb.message
    check(iterated(MODEL.m0, MODEL.P0, y0, 1)[:2], "x^(1), the ordinary EKF update")
    check(iterated(MODEL.m0, MODEL.P0, y0, 2)[:2], "x^(2), still on its way")
    check(iterated(MODEL.m0, MODEL.P0, y0, 20), "whole state", "shape (2,)")
    check(X_START[:2], "true start")
    check(np.array([5.0, 5.0]), "prior mean m0")
    check(map_position[::-1], "swapped")
    check(map_position + 0.3, "not the limit", "no longer moves")
    check(np.ones((2, 2)), "shape (2,)")


def test_ex3_answer_3_at_the_grid_mean_is_told_mean_and_map_differ(y0, map_position):
    """The exact posterior mean (section 8's grid, in plain numpy here) is not the MAP."""
    g = np.arange(-25.0, 35.0 + 0.1, 0.2)
    gx, gy = np.meshgrid(g, g)
    rho, beta = np.hypot(gx, gy), np.arctan2(gy, gx)
    d_beta = np.angle(np.exp(1j * (y0[1] - beta)))
    log_post = (-0.5 * (y0[0] - rho) ** 2 / 0.1 - 0.5 * d_beta**2 / 0.01
                - 0.5 * ((gx - 5) ** 2 + (gy - 5) ** 2) / 100)
    post = np.exp(log_post - log_post.max())
    post /= post.sum()
    mean = np.array([np.sum(post * gx), np.sum(post * gy)])
    assert 0.02 < np.linalg.norm(mean - map_position) < 0.2
    wrong(ch04.exercise_3(iterated, mean), "mean of the exact posterior", "MAP")
    wrong(ch04.exercise_3(iterated, np.round(mean, 2)), "mean of the exact posterior")


def test_ex3_limits_of_mistaken_iterations_are_recognised(y0):
    latest = iterated(MODEL.m0, MODEL.P0, y0, 50, "latest")[:2]
    repeated = iterated(MODEL.m0, MODEL.P0, y0, 50, "repeated")[:2]
    for answer, phrase in [(latest, "from the latest iterate"), (repeated, "repeated EKF updates")]:
        assert np.linalg.norm(answer - iterated(MODEL.m0, MODEL.P0, y0, 50)[:2]) > 0.05
        wrong(ch04.exercise_3(iterated, answer), phrase)


def test_ex3_not_attempted_and_garbage(map_position):
    not_attempted(ch04.exercise_3(None, None))
    not_attempted(ch04.exercise_3(not_implemented, None))
    fb = ch04.exercise_3(not_implemented, map_position)
    not_attempted(fb)
    assert "answer_3: correct." in fb.message
    wrong(ch04.exercise_3(lambda m0, P0, y, n: m0 @ P0 @ np.ones(3), None), "ValueError",
          "(4, 4)")
    wrong(ch04.exercise_3(lambda m0, P0, y, n: undefined_name, None), "NameError")  # noqa: F821
    never_raises(ch04.exercise_3, [(g, g) for g in BAD_FUNCTIONS + GARBAGE])


# ---------------------------------------------------------------------------
# Exercise 4: the Jacobian of the turning vehicle
# ---------------------------------------------------------------------------

def f_turn(x):
    rx, ry, vx, vy, w = x
    return np.array([rx + vx, ry + vy, np.cos(w) * vx - np.sin(w) * vy,
                     np.sin(w) * vx + np.cos(w) * vy, w])


def turn_by_hand(x):
    vx, vy, w = x[2], x[3], x[4]
    c, s = np.cos(w), np.sin(w)
    return np.array([[1, 0, 1, 0, 0], [0, 1, 0, 1, 0], [0, 0, c, -s, -s * vx - c * vy],
                     [0, 0, s, c, c * vx - s * vy], [0, 0, 0, 0, 1.0]])


def test_ex4_the_reference_is_central_differences_at_every_state():
    states = [x for (x,) in ch04._turn_cases()]
    assert len(states) == 7
    for x in states:
        numerical = bf.ekf.numerical_jacobian(f_turn, x)
        np.testing.assert_allclose(ch04._turn_jacobian(x), numerical, rtol=1e-6, atol=1e-8)
        np.testing.assert_allclose(turn_by_hand(x), ch04._turn_jacobian(x), atol=1e-15)


def test_ex4_accepts_the_hand_derivation_and_refuses_central_differences():
    correct(ch04.exercise_4(turn_by_hand))
    wrong(ch04.exercise_4(lambda x: bf.ekf.numerical_jacobian(f_turn, x)),
          "finite-difference", "by hand")


def _turn_variant(change):
    def fun(x):
        F = turn_by_hand(x)
        change(F, x)
        return F
    return fun


def _cos_sign(F, x):
    vx, vy, w = x[2], x[3], x[4]
    F[2, 4] = np.sin(w) * vx - np.cos(w) * vy
    F[3, 4] = np.cos(w) * vx + np.sin(w) * vy


def _turned_position(F, x):
    F[0:2, 2:5] = F[2:4, 2:5]


@pytest.mark.parametrize("fun, phrases", [
    (lambda x: turn_by_hand(x).T, ["test input 1", "transposed"]),
    (_turn_variant(lambda F, x: F.__setitem__((slice(2, 4), 4), 0.0)), ["omega column is zero"]),
    (_turn_variant(lambda F, x: F.__setitem__((slice(2, 4), 4), -F[2:4, 4])),
     ["omega column has the wrong sign"]),
    (_turn_variant(_cos_sign), ["derivative of cos has the wrong sign"]),
    (_turn_variant(lambda F, x: F.__setitem__((slice(2, 4), slice(2, 4)), F[2:4, 2:4].T.copy())),
     ["transposed rotation", "clockwise"]),
    (_turn_variant(lambda F, x: F.__setitem__((slice(0, 2), slice(2, 4)), 0.0)),
     ["position rows miss the velocities"]),
    (_turn_variant(_turned_position), ["turned velocity"]),
    (_turn_variant(lambda F, x: F.__setitem__((4, 4), 0.0)), ["last row is zero"]),
    (lambda x: turn_by_hand(x)[:4, :4], ["5 x 5", "five components"]),
])
def test_ex4_diagnoses(fun, phrases):
    fb = ch04.exercise_4(fun)
    wrong(fb, *phrases)
    hides(fb, turn_by_hand(ch04.TURN_STATES[0]))


def test_ex4_the_straight_drive_hides_the_rate_column_until_a_turn():
    """omega = 0 and v = 0 are edge cases: a forgotten rate column passes them, not the others."""
    zero_column = _turn_variant(lambda F, x: F.__setitem__((slice(2, 4), 4), 0.0))
    at_rest = ch04.TURN_STATES[4]
    np.testing.assert_allclose(zero_column(at_rest), turn_by_hand(at_rest))
    wrong(ch04.exercise_4(zero_column), "test input 1")


def test_ex4_an_unrecognised_mistake_names_the_partial_derivative():
    def off(x):
        F = turn_by_hand(x)
        F[3, 4] += 0.5
        return F
    wrong(ch04.exercise_4(off), "d xi_y_dot(t+1) / d omega", "entry (3, 4)")


def test_ex4_not_attempted_and_garbage():
    not_attempted(ch04.exercise_4(None))
    not_attempted(ch04.exercise_4(not_implemented))
    wrong(ch04.exercise_4(lambda x: x[9]), "IndexError", "shape (5,)")
    never_raises(ch04.exercise_4, BAD_FUNCTIONS + GARBAGE)


# ---------------------------------------------------------------------------
# Exercise 5: the wrapped innovation
# ---------------------------------------------------------------------------

def innovation_by_angle(y, y_pred):
    d = np.asarray(y, float) - np.asarray(y_pred, float)
    return np.array([d[0], np.angle(np.exp(1j * d[1]))])


def innovation_by_modulo(y, y_pred):
    d = np.asarray(y, float) - np.asarray(y_pred, float)
    return np.array([d[0], (d[1] + np.pi) % (2 * np.pi) - np.pi])   # -pi at exactly pi


def innovation_by_arctan2(y, y_pred):
    d = np.asarray(y, float) - np.asarray(y_pred, float)
    return [d[0], float(np.arctan2(np.sin(d[1]), np.cos(d[1])))]


def innovation_by_loops(y, y_pred):
    d = [y[0] - y_pred[0], y[1] - y_pred[1]]
    while d[1] > np.pi:
        d[1] -= 2 * np.pi
    while d[1] <= -np.pi:
        d[1] += 2 * np.pi
    return d


def test_ex5_the_cases_include_both_crossings_and_the_boundary():
    diffs = [y[1] - p[1] for y, p in ch04._innovation_cases()]
    assert any(d > np.pi for d in diffs) and any(d < -np.pi for d in diffs)
    assert diffs[ch04.EXACTLY_PI] == np.pi
    assert any(abs(y[0] - p[0]) > np.pi for y, p in ch04._innovation_cases())
    assert any(y[1] > np.pi for y, _ in ch04._innovation_cases())


def test_ex5_accepts_every_way_of_wrapping():
    for fun in (innovation_by_angle, innovation_by_arctan2, innovation_by_loops):
        correct(ch04.exercise_5(fun))
    fb = ch04.exercise_5(innovation_by_modulo)
    correct(fb)
    assert "exactly pi, you return -pi" in fb.message
    assert "exactly pi" not in ch04.exercise_5(innovation_by_angle).message


def test_ex5_used_as_filterpys_residual_it_tracks_the_second_target():
    """The statement's follow-up: filterpy with the wrapped innovation is bf.ekf, with
    np.subtract it is not."""
    from filterpy.kalman import ExtendedKalmanFilter
    cross_model = bf.models.range_bearing(m0=(-10.0, 5.0, 0.0, 0.0), prior_var=4.0)
    cross = bf.models.simulate(cross_model, 60, np.random.default_rng(5),
                               x0=np.array([-10.0, 5.0, 0.0, -0.2]))

    def run(residual):
        fp = ExtendedKalmanFilter(dim_x=4, dim_z=2)
        fp.x, fp.P, fp.R = cross_model.m0.copy(), cross_model.P0.copy(), cross_model.R.copy()
        fp.F, fp.Q = cross_model.F(cross_model.m0), cross_model.G @ cross_model.Q @ cross_model.G.T
        means = []
        for k, y in enumerate(cross.ys):
            if k > 0:
                fp.predict()
            fp.update(y, HJacobian=cross_model.H, Hx=cross_model.h, residual=residual)
            means.append(fp.x.copy())
        return np.array(means)
    ours = bf.ekf.extended_kalman_filter(cross_model, cross.ys).means
    assert np.abs(run(innovation_by_angle) - ours).max() < 1e-9
    assert np.abs(run(np.subtract) - ours).max() > 5.0


def _one_sided(y, y_pred):
    d = np.asarray(y, float) - np.asarray(y_pred, float)
    if d[1] > np.pi:
        d[1] -= 2 * np.pi
    return d


@pytest.mark.parametrize("fun, phrases", [
    (lambda y, p: innovation_by_angle(p, y), ["test input 1", "wrong sign", "y - y_pred"]),
    (lambda y, p: np.asarray(y, float) - p, ["test input 2", "not wrapped", "almost 2 pi"]),
    (_one_sided, ["test input 3", "above pi but not this one, below -pi", "both ways"]),
    (lambda y, p: np.array([y[0] - p[0], np.mod(y[1] - p[1], 2 * np.pi)]),
     ["test input 1", "[0, 2 pi)"]),
    (lambda y, p: np.angle(np.exp(1j * (np.asarray(y, float) - p))),
     ["test input 1", "wrapped the range difference too"]),
    (lambda y, p: innovation_by_angle(y, p)[1], ["return both components", "shape (2,)"]),
    (lambda y, p: innovation_by_angle(y, p)[::-1], ["test input 1"]),
])
def test_ex5_diagnoses(fun, phrases):
    fb = ch04.exercise_5(fun)
    wrong(fb, *phrases)
    hides(fb, innovation_by_angle(*ch04.INNOVATION_CASES[1]))


def test_ex5_not_attempted_and_garbage():
    not_attempted(ch04.exercise_5(None))
    not_attempted(ch04.exercise_5(not_implemented))
    wrong(ch04.exercise_5(lambda y, p: len(y) and None), "forget `return`")
    wrong(ch04.exercise_5(fails_oddly), "fails on test input 1", "Odd")
    never_raises(ch04.exercise_5, BAD_FUNCTIONS + GARBAGE)


@pytest.mark.filterwarnings("error")
def test_checks_themselves_raise_no_warning_on_garbage():
    for g in GARBAGE:
        ch04.exercise_2(converted_cov_by_hand, g)
        ch04.exercise_3(iterated, g)
    ch04.exercise_1(lambda x: np.full((2, 4), 1e308))
    ch04.exercise_4(lambda x: np.full((5, 5), -1e308))
    ch04.exercise_5(lambda y, p: np.full(2, 1e308))
    ch04.exercise_2(converted_cov_by_hand, 1e308)
