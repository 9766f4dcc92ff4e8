"""Checks of chapter 04's exercises (the EKF; references by bf.models, bf.ekf, bf.kalman,
bf.gaussian). One line per exercise (the notebook variables each reads with ``given``,
in brackets)::

    exercise_1(range_bearing_jacobian): the range-bearing Jacobian H, by hand;
    exercise_2(converted_cov, nees_2): the converted covariance J R J^T, and the NEES of
        a filter started from it;
    exercise_3(iterated_ekf_update, answer_3): the iterated EKF update, and the position
        of its limit [y0_3, m0_3, P0_3];
    exercise_4(turn_jacobian): the Jacobian F of a vehicle turning at the rate omega, by
        hand;
    exercise_5(wrapped_innovation): the innovation with its bearing wrapped into
        (-pi, pi].

"By hand" is checked three ways: a float64 Jacobian must agree with the closed form to
round-off (a finite-difference one agrees to about 1e-10; a float32 one is judged to
float32 round-off instead), and the code must not call bf.ekf.numerical_jacobian,
model.H, nor hold a complex constant (a complex-step derivative).
"""

from __future__ import annotations

import dataclasses
import functools

import numpy as np

from .. import ekf, gaussian, kalman, models
from . import (CORRECT, NOT_ATTEMPTED, Feedback, _as_numbers, _combine, _complex_step, _frozen, _hinted, code_names,
               referenced,
               _low_precision, _matches, _not_attempted, _wrong, compare_array, compare_function, compare_number,
               given, register as _register)

# the statements' numbers; each function's check adds two random cases, drawn with its seed
H_SEED, CONVERT_SEED, TURN_SEED, INNOVATION_SEED, ON_THE_RY_AXIS, EXACTLY_PI = 4041, 4042, 4044, 4045, 4, 5
# ex 1: the true start, m0, two quadrants, the xi_y axis, 0.3 m away
H_STATES = _frozen([[10.0, -5.0, -0.2, 0.2], [5.0, 5.0, 0.0, 0.0], [-6.0, 2.0, 0.3, 0.1], [-3.0, -7.0, 0.0, 1.0],
                    [0.0, 5.0, 0.2, 0.0], [0.3, -0.1, 0.0, 0.0]])
# ex 2: [range (m), bearing (rad)], y_0 first; section 7's batch (a), seed 10, t = 1..10: the average NEES is in the
# band for any seed (4.15 +- 0.25 over 100 seeds; J^T R J gives 7 or more, no rho 70 or more)
Y_CONVERT = _frozen([[11.03, -0.405], [10.0, 0.0], [5.0, 2.5], [8.0, -3.0], [10.0, np.pi]])
NEES_SEED, NEES_RUNS, NEES_STEPS, NEES_BAND = 10, 100, 10, (3.0, 5.5)
# ex 3: Kay's first update (section 1: seed 0, 100 steps), its limit to 0.01 m; a prior, y across the cut; a tight one
SECTION_1_SEED, SECTION_1_STEPS, LIMIT_ITERATIONS, LIMIT_TOL = 0, 100, 50, 0.011
WRAP_PRIOR = (_frozen([-10.0, 0.3, 0.0, 0.0]), _frozen(4.0 * np.eye(4)), _frozen([10.2, -3.12]))
TIGHT_PRIOR = (_frozen([10.0, -5.0, -0.2, 0.2]), _frozen(np.diag([1.0, 1.0, 0.01, 0.01])), _frozen([11.5, -0.5]))
# ex 4: [xi_x, xi_y, xi_x_dot, xi_y_dot, omega]: a slow turn, a quarter turn, a right turn, omega = 0, at rest
TURN_STATES = _frozen([[10.0, -5.0, -0.2, 0.2, 0.05], [0.0, 0.0, 1.0, 0.0, np.pi / 2], [-2.0, 1.0, 0.5, -1.5, -0.4],
                       [1.0, 2.0, 0.3, 0.4, 0.0], [3.0, 4.0, 0.0, 0.0, 0.3]])
# ex 5: (y, y_pred): section 10's first (range change > pi), across the cut both ways, above pi, equal, exactly pi apart
INNOVATION_CASES = tuple((_frozen(y), _frozen(p)) for y, p in [
    ([11.03, -0.405], [7.07, 0.785]), ([9.8, 3.12], [10.0, -3.13]), ([10.0, -3.1], [10.2, 3.05]),
    ([10.0, 3.21], [10.1, -3.1]), ([4.0, 1.0], [8.5, 1.0]), ([5.0, np.pi / 2], [5.0, -np.pi / 2])])
_STATE, _TURN = ("xi_x", "xi_y", "xi_x_dot", "xi_y_dot"), ("xi_x", "xi_y", "xi_x_dot", "xi_y_dot", "omega")
_model = functools.cache(models.range_bearing)


def _cases(fixed, seed, draw, keep=lambda *case: True) -> list[tuple]:
    """The fixed cases (tuples of arrays), then two seeded random ones that ``keep`` accepts."""
    rng, drawn = np.random.default_rng(seed), []
    while len(drawn) < 2:
        drawn += [case] if keep(*(case := draw(rng))) else []
    return [tuple(np.array(a) for a in case) for case in fixed] + drawn


def _compare(entry=None, by_hand=False, rules=()):
    """compare_array for compare_function; against the reference (``what`` given) also: rules (predicate(answer,
    reference), message), the first differing entry named by entry(index), and with by_hand finite differences."""
    def compare(out, e, what=None, rtol=1e-6, atol=1e-9):
        fb = compare_array(out, e, what or "the output", rtol=rtol, atol=atol)
        if what is None or fb.status == NOT_ATTEMPTED or " must be " in fb.message:
            return fb                         # a named mistake's comparison, or an answer that is not numbers
        a, e = np.asarray(out, dtype=float), np.asarray(e, dtype=float)
        if fb.correct and by_hand and not _low_precision(out) and (
                err := float(np.max(np.abs(a - e)))) > 1e-12 * max(1.0, np.max(np.abs(e))):
            return _wrong(f"a finite-difference Jacobian, not derivatives by hand? {what} agrees with the closed "
                          f"form only to about {err:.0e}; derivatives by hand agree to round-off (1e-12).")
        hit = None if fb.correct else next((m for rule, m in rules if rule(a, e)), None)
        if hit is not None or fb.correct or entry is None or "entries differ" not in fb.message:
            return _wrong(f"{what}: {hit}") if hit else fb
        first = tuple(int(i) for i in np.argwhere(~np.isclose(a, e, rtol=rtol, atol=atol))[0])
        return _wrong(fb.message.split(" (the first")[0] + f"; the first is {entry(first)} (entry {first}).")
    return compare


def _function(fun, what, cases, reference, variant, table, hints=(), compare=None, forbidden=(),
              **compare_kw) -> Feedback:
    """compare_function (Ellipsis is None); the named mistakes are variant(*args, **kw) for (kw, message) in table; a
    failure gets the text of the first hint (exception types, test(exc, args), text) that fits; with by_hand, a
    right function must not differentiate numerically (module docstring)."""
    hint = lambda exc, args: next((f" Hint: {t}" for kinds, test, t in hints  # noqa: E731
                                   if isinstance(exc, kinds) and test(exc, args)), "")
    fb = compare_function(None if fun is Ellipsis else _hinted(fun, hint), reference, cases, what, mistakes=[
        (lambda *args, kw=kw: variant(*args, **kw), m) for kw, m in table], compare=compare or _compare(**compare_kw),
        forbidden=[*forbidden, *(_NUMERICAL if compare_kw.get("by_hand") else ())])
    if fb.correct and compare_kw.get("by_hand") and _complex_step(fun):
        return _wrong(f"{what} holds a complex number (1j): a complex-step derivative is a numerical one too, "
                      f"exact to round-off but not derived; write each entry of the closed form by hand.")
    return fb


_NUMERICAL = [({"numerical_jacobian"}, "bf.ekf.numerical_jacobian: a finite-difference Jacobian, not derivatives "
                                       "by hand; write each entry of the closed form.")]


# Exercise 1: the range-bearing Jacobian H, in Kay's state order [xi_x, xi_y, xi_x_dot, xi_y_dot] --------------------------------
_jacobian_states = functools.partial(_cases, [(x,) for x in H_STATES], H_SEED, lambda rng: (
    np.round(rng.uniform(-20.0, 20.0, size=4), 3),), lambda x: np.hypot(x[0], x[1]) > 1.0)


_H_MISTAKES = [
    ({"then": np.transpose}, "H is transposed: a row per measurement component, a column per state one, shape (2, 4)."),
    ({"then": np.flipud}, "the rows are swapped: h = [range, bearing], so row 0 holds the derivatives of the range."),
    ({"read": (0, 2), "cols": (0, 2)}, "you read the state in chapter 03's order [xi_x, xi_x_dot, xi_y, xi_y_dot] (xi_y = x[2]) "
     "and put its columns there too; in Kay's order [xi_x, xi_y, xi_x_dot, xi_y_dot] xi_y = x[1], in column 1."),
    ({"read": (0, 2)}, "you read xi_y from x[2], its place in chapter 03's order; in Kay's order it is x[1]."),
    ({"cols": (0, 2)}, "the columns are in chapter 03's state order [xi_x, xi_x_dot, xi_y, xi_y_dot]; in Kay's order [xi_x, xi_y, "
     "xi_x_dot, xi_y_dot] the derivatives by xi_x and xi_y are columns 0 and 1 (model.index_of(\"xi_x\", \"xi_y\"))."),
    ({"sign": -1.0}, "the bearing row has the wrong sign: the bearing grows anticlockwise, so d beta / d xi_y = xi_x / "
     "rho^2 (differentiate atan2(xi_y, xi_x), not atan2(xi_x, xi_y))."),
    ({"then": np.negative}, "both rows have the wrong sign: d rho / d xi_x = xi_x / rho has the sign of xi_x."),
    ({"bearing": "rho"}, "the bearing row is divided by rho; it is divided by rho^2 (d beta / d xi_x = -xi_y / rho^2)."),
    ({"rng": "one"}, "the range row is not divided by rho: d rho / d xi_x = xi_x / rho (a unit vector), not xi_x."),
    ({"rng": "square"}, "the range row is the derivative of rho^2, not of rho: d rho / d xi_x = xi_x / rho."),
    ({"then": lambda H: H[:, :2]}, "H must have shape (2, 4), not (2, 2): the velocities do not enter h, but H has "
     "a column for each of the 4 state components.")]


def exercise_1(range_bearing_jacobian) -> Feedback:
    """Check ``range_bearing_jacobian(x)`` against the model's ``H`` at ``H_STATES`` and two seeded states."""
    def _h_variant(x, read=(0, 1), cols=(0, 1), rng="rho", bearing="rho2", sign=1.0, then=lambda H: H):
        rx, ry = float(x[read[0]]), float(x[read[1]])
        rho2, H = rx * rx + ry * ry, np.zeros((2, 4))
        H[0, list(cols)] = np.array([rx, ry]) * {"rho": 1 / np.sqrt(rho2), "one": 1.0, "square": 2.0}[rng]
        H[1, list(cols)] = sign * np.array([-ry, rx]) / {"rho2": rho2, "rho": np.sqrt(rho2)}[bearing]
        return then(H)
    on_axis = (lambda a, e: e.shape == (2, 4) and e[0, 0] == 0 and not np.all(np.isfinite(a)), "on the xi_y axis "
               "(xi_x = 0) your H contains NaN or inf: the derivation through arctan(xi_y / xi_x) divides by xi_x, but H "
               "is finite wherever rho > 0; simplify until only rho^2 is in a denominator.")
    hints = [((ZeroDivisionError, FloatingPointError), lambda exc, args: float(np.ravel(args[0])[0]) == 0.0,
              "xi_x = 0 here (the xi_y axis): simplify so that only rho^2 = xi_x^2 + xi_y^2 is in a denominator."),
             ((IndexError, ValueError), lambda *_: True, "x is a NumPy array of shape (4,); return shape (2, 4).")]
    return _function(range_bearing_jacobian, "range_bearing_jacobian", _jacobian_states(), _model().H, _h_variant,
                     _H_MISTAKES, hints, entry=lambda i: f"d {('rho', 'beta')[i[0]]} / d {_STATE[i[1]]}",
                     by_hand=True, rules=[on_axis], forbidden=[(_uses_model_H, "model.H, which the statement "
                                                                "rules out: derive each entry of H by hand.")])


def _uses_model_H(fun) -> bool:
    """Does fun call the H of a model (an object with h and H) that it reads?"""
    return "H" in code_names(fun) and any(hasattr(o, "H") and hasattr(o, "h") for o in referenced(fun))


# Exercise 2: a prior from the first measurement: J R J^T, and the NEES of the EKF started from it -----------------
def _converted_cov(y, rho_in=True, from_ry_axis=False, R=None, then=lambda J, R: J @ R @ J.T) -> np.ndarray:
    """J R J^T, J = d(rho cos beta, rho sin beta) / d(rho, beta); or a mistake's variant."""
    r, c, s = float(y[0]) if rho_in else 1.0, np.cos(float(y[1])), np.sin(float(y[1]))
    J = np.array([[s, r * c], [c, -r * s]]) if from_ry_axis else np.array([[c, -r * s], [s, r * c]])
    return then(J, _model().R if R is None else R)


_convert_cases = functools.partial(_cases, [(y,) for y in Y_CONVERT], CONVERT_SEED, lambda rng: (
    np.round([rng.uniform(1.0, 30.0), rng.uniform(-np.pi, np.pi)], 3),))
_COV_MISTAKES = [
    ({"rho_in": False}, "rho is missing from J: a bearing error d beta moves the point by rho d beta."),
    ({"then": lambda J, R: J.T @ R @ J}, "this is J^T R J; the covariance of J v (v the noise) is J R J^T."),
    ({"R": np.sqrt(_model().R)}, "R holds variances; you used their square roots, the standard deviations."),
    ({"then": lambda J, R: J @ R}, "J R is not a covariance (it is not symmetric): J R J^T."),
    ({"then": lambda J, R: R}, "this is R itself, of (range, bearing); carry it to (xi_x, xi_y) with J: J R J^T."),
    ({"then": lambda J, R: np.diag(np.diag(J @ R @ J.T))}, "you kept only the diagonal: away from the axes the errors "
     "in xi_x and xi_y are correlated."),
    ({"from_ry_axis": True}, "your conversion measures the bearing from the xi_y axis; xi_x = rho cos beta."),
    ({"then": lambda J, R: np.linalg.inv(J @ R @ J.T)}, "this is the inverse of J R J^T, a precision.")]


def _nees_experiment(cov_fn, rng, n_runs: int = 100, T: int = 11) -> np.ndarray:
    """The answer cell's experiment, NEES (n_runs, T-1): section 7's batch (a) with the prior of x_0 from y_0 (the
    converted y_0, zero velocity; cov_fn(y_0), unit velocity variances), predicted to t = 1, updated with y_1..."""
    model, nees = _model(), np.empty((n_runs, T - 1))
    pos = model.index_of("xi_x", "xi_y")
    for i in range(n_runs):
        xs, ys = models.simulate(model, T, rng, x0=models.RANGE_BEARING_TRUE_START)
        m, P = np.zeros(4), np.eye(4)
        m[pos], P[np.ix_(pos, pos)] = ys[0, 0] * np.array([np.cos(ys[0, 1]), np.sin(ys[0, 1])]), cov_fn(ys[0])
        prior_1 = ekf.predict(m, P, model.f, model.F, model.Q, model.G)
        run = ekf.extended_kalman_filter(dataclasses.replace(model, m0=prior_1.mean, P0=prior_1.cov), ys[1:])
        nees[i] = gaussian.squared_mahalanobis(xs[1:] - run.means, run.covs)
    return nees


_seed_10_nees = functools.cache(lambda: _nees_experiment(_converted_cov, np.random.default_rng(NEES_SEED)))


def _nees_2(nees, what="nees_2") -> Feedback:
    fb = compare_number(nees, NEES_BAND[0], what)           # for its reading of the answer only
    if fb.status == NOT_ATTEMPTED or f"{what} must" in fb.message or f"{what} is NaN" in fb.message:
        return fb
    v, (low, high) = float(np.ravel(nees)[0]), NEES_BAND
    if not low <= v <= high:
        return _wrong(f"{what} " + next(m for hit, m in [
            (v < 0, "is negative, but a NEES is a squared distance; average nees_from_first_measurement's array."),
            (v > 1000, "is far too large for an average: did you sum the NEES instead of averaging it (np.mean)?"),
            (v > 30, "is an order of magnitude above what a consistent filter gives: does your J carry the factor rho "
                     "in its bearing column?"),
            (v > high, "is above what a consistent filter gives (overconfident): is the covariance J R J^T (not "
                       "J^T R J)?"),
            (True, "is below what a consistent filter gives (underconfident): does your covariance use the variances "
                   "of R (not their square roots)?")] if hit))
    e = _seed_10_nees()
    for other, name in [(e[:, -1].mean(), "the average at the last step t = 10 only"), (e[:, 0].mean(), "the average "
                        "at the first step t = 1 only"), (e[-1].mean(), "the average of the last run only"),
                        (e[0].mean(), "the average of the first run only"), (np.median(e), "the median")]:
        if np.isclose(v, other, rtol=1e-9) and not np.isclose(v, e.mean(), rtol=1e-9):
            return _wrong(f"{what} is {name} of the NEES values; average over all 100 runs and all steps t = 1, ..., "
                          f"10: nees_from_first_measurement(converted_cov, np.random.default_rng({NEES_SEED})).mean().")
    return Feedback(CORRECT, f"{what} is what a consistent filter gives: the chi2_4 average, from the first steps on.")


def exercise_2(converted_cov, nees) -> Feedback:
    """Check ``converted_cov(y)`` (J R J^T, (2, 2)) at ``Y_CONVERT`` and two seeded y, and ``nees_2`` (a float)."""
    cov = _function(converted_cov, "converted_cov", _convert_cases(), _converted_cov, _converted_cov, _COV_MISTAKES,
                    entry=lambda i: f"cov({_STATE[i[0]]}, {_STATE[i[1]]})")
    return _combine([("converted_cov", cov), ("nees_2", _nees_2(nees))])


# Exercise 3: the iterated EKF, and the position of its limit in Kay's first update --------------------------------
def _iterate(m0, P0, y, n_iter, mode: str = "right") -> np.ndarray:
    """x^(n_iter) by bf.kalman.update of the prior with y linearised at x, y' = r + H x (r = y - h(x) wrapped), so
    that m0 + K (y' - H m0) = m0 + K (r - H (m0 - x)); or a mistake's variant."""
    model, (m0, P0, y) = _model(), (np.asarray(a, dtype=float) for a in (m0, P0, y))
    x, P = m0, P0
    for _ in range(max(int(n_iter) + {"plus_one": 1, "minus_one": -1}.get(mode, 0), 0)):
        H = model.H(m0 if mode == "fixed_H" else x)
        r = y - model.h(x) if mode == "unwrapped" else models.range_bearing_residual(y, model.h(x))
        step = kalman.update(*{"latest": (x, P0, r + H @ x), "no_term": (m0, P0, r + H @ m0),  # x + K r, m0 + K r
                               "repeated": (x, P, r + H @ x), "term_sign": (m0, P0, r + 2 * H @ m0 - H @ x)}.get(
            mode, (m0, P0, r + H @ x)), H, model.R)
        x, P = step.mean, step.cov if mode == "repeated" else P0
    return x


_ITERATION_MISTAKES = [({"mode": mode}, m) for mode, m in [
    ("plus_one", "you return x^(n_iter + 1): x^(0) = m0, and n_iter = 1 is the ordinary EKF update."),
    ("minus_one", "you return x^(n_iter - 1): x^(0) = m0, and n_iter = 1 must give the ordinary EKF update."),
    ("repeated", "you repeat the EKF update, covariance and all: each pass counts y once more. The iterated EKF "
     "updates the prior N(m0, P0) every time and only moves the point of linearisation."),
    ("latest", "you update from the latest iterate, x^(i) + K_i (y - h(x^(i))); start from m0 every time (the term "
     "- H_i (m0 - x^(i)) accounts for linearising at x^(i))."),
    ("no_term", "the term - H_i (m0 - x^(i)) is missing: by the tangent at x^(i), y is predicted at m0 as h(x^(i)) + "
     "H_i (m0 - x^(i))."),
    ("term_sign", "the term H_i (m0 - x^(i)) has the wrong sign: the innovation is y - h(x^(i)) - H_i (m0 - x^(i))."),
    ("unwrapped", "the bearing part of y - h(x^(i)) is not wrapped (bf.models.range_bearing_residual)."),
    ("fixed_H", "you keep the Jacobian of m0 while h is re-evaluated at x^(i): re-linearise, H_i = H(x^(i)).")]]


@functools.cache
def _section_1_y0() -> np.ndarray:
    model = _model()
    return _frozen(models.simulate(model, SECTION_1_STEPS, np.random.default_rng(SECTION_1_SEED),
                                   x0=models.RANGE_BEARING_TRUE_START).ys[0])


def _kay() -> tuple:
    """The prior and measurement of answer_3: the notebook's m0_3, P0_3, y0_3, or Kay's first update."""
    model = _model()
    return tuple(_frozen(given(name, value)) for name, value in (
        ("m0_3", model.m0), ("P0_3", model.P0), ("y0_3", _section_1_y0())))


def _limit_positions() -> dict:
    return _limit_positions_of(*(tuple(np.ravel(a)) for a in _kay()))


@functools.lru_cache(maxsize=4)
def _limit_positions_of(m0: tuple, P0: tuple, y0: tuple) -> dict:
    """Kay's first update, its limit, section 8's grid posterior mean, the positions of wrong answers (messages)."""
    model, g, n = _model(), np.arange(-25.0, 35.0 + 0.1, 0.2), LIMIT_ITERATIONS
    kay = (_frozen(m0), _frozen(np.reshape(P0, (4, 4))), _frozen(y0))
    pos, grid = model.index_of("xi_x", "xi_y"), np.zeros((g.size**2, 4))
    grid[:, pos] = np.stack(np.meshgrid(g, g), axis=-1).reshape(-1, 2)
    log_post = model.measurement_logpdf(kay[2], grid) + gaussian.logpdf(grid[:, pos], kay[0][pos], kay[1][pos][:, pos])
    post = np.exp(log_post - log_post.max())
    with np.errstate(all="ignore"):
        at = lambda n, mode="right": _iterate(*kay, n, mode)[pos]  # noqa: E731
        return {"kay": kay, "limit": at(n), "grid": post @ grid[:, pos] / post.sum(), "table": [
            (at(1), " is x^(1), the ordinary EKF update of section 8; iterate until x^(i) no longer moves."),
            *[(at(k), f" is x^({k}), still on its way: iterate until x^(i) no longer moves.") for k in range(2, 6)],
            (kay[0][pos], " is the prior mean m0, x^(0); the limit is where the iterations go."),
            (models.RANGE_BEARING_TRUE_START[pos], " is the true start, which the filter does not know."),
            (None, " is (close to) the mean of the exact posterior of section 8; the iterated EKF converges to the "
                   "MAP, the point of largest posterior density."),
            (at(n, "latest"), ": this is where the iteration from the latest iterate goes; update m0 every time."),
            (at(n, "no_term"), ": this is where the iteration without the term - H_i (m0 - x^(i)) goes; keep it."),
            (at(n, "repeated"), ": this is where repeated EKF updates with the same y_0 go; update the prior each "
                                "time."),
            (at(n)[::-1], " has xi_x and xi_y swapped: give [xi_x, xi_y]."),
            (..., " is not the limit for y0_3 (y_0 = sim.ys[0] of section 1) to 0.01 m: iterate your "
                  "iterated_ekf_update from m0 until x^(i) no longer moves, and give its position.")]}


def _answer_3(answer, what="answer_3") -> Feedback:
    a, bad = _as_numbers(answer, what) if answer is not None and answer is not Ellipsis else (0, _not_attempted(what))
    ref = _limit_positions()
    close = lambda p: np.shape(a) in ((2,), (4,)) and np.allclose(a[:2], p, rtol=0.0, atol=LIMIT_TOL)  # noqa: E731
    if bad is not None or a.shape != (2,):
        return bad or _wrong(f"{what} is a whole state; give the position [xi_x, xi_y] only, shape (2,) (x[pos])." if
                             close(ref["limit"]) else f"{what} must be the position [xi_x, xi_y], a NumPy array of shape "
                             f"(2,)" + (", not a whole state." if a.shape == (4,) else f"; got shape {a.shape}."))
    grid = close(ref["grid"]) or np.linalg.norm(a - ref["grid"]) < 0.5 * np.linalg.norm(ref["limit"] - ref["grid"])
    return Feedback(CORRECT, f"{what} is the limit of the iterated EKF, to 0.01 m.") if close(ref["limit"]) else _wrong(
        what + next(m for p, m in ref["table"] if p is ... or (grid if p is None else close(p))))


def exercise_3(iterated_ekf_update, answer) -> Feedback:
    """Check ``iterated_ekf_update(m0, P0, y, n_iter)`` on six inputs, and ``answer_3``, the limit, to 0.011 m."""
    model = _model()
    kay = (np.array(model.m0), np.array(model.P0), np.array(_section_1_y0()))      # the test inputs stay Kay's
    cases = [kay + (n,) for n in (1, 2, 0, 10)] + [tuple(map(np.array, WRAP_PRIOR)) + (3,),
                                                  tuple(map(np.array, TIGHT_PRIOR)) + (4,)]
    hints = [(NameError, lambda exc, args: "model" in str(exc), "use the chapter's model (bf.models.range_bearing())."),
             ((ValueError, IndexError), lambda exc, args: any(w in str(exc) for w in ("shape", "align", "dimension")),
              "m0 (4,), P0 (4, 4), y (2,), H_i (2, 4), R (2, 2), K (4, 2); return the state x^(n_iter), shape (4,).")]
    fun = _function(iterated_ekf_update, "iterated_ekf_update", cases, lambda m0, P0, y, n: ekf.update(
        m0, P0, y, model.h, model.H, model.R, models.range_bearing_residual).mean if n == 1 else _iterate(m0, P0, y, n),
        _iterate, _ITERATION_MISTAKES, hints, entry=lambda i: f"the {_STATE[i[0]]} component", rules=[(
            lambda a, e: a.shape == (2,), "return the whole state x^(n_iter), shape (4,) (answer_3 then selects it).")])
    return _combine([("iterated_ekf_update", fun), ("answer_3", _answer_3(answer))])


# Exercise 4: the Jacobian F (5, 5) of a vehicle turning at the rate omega --------------------------------------------
def f_turn(x) -> np.ndarray:
    """The turning vehicle of exercise 4: the position moves by the velocity, which turns by omega."""
    rx, ry, vx, vy, omega = (float(v) for v in x)
    c, s = np.cos(omega), np.sin(omega)
    return np.array([rx + vx, ry + vy, c * vx - s * vy, s * vx + c * vy, omega])


def _turn_jacobian(x, transposed_turn=False, omega_column=1.0, cos_sign=1.0, coupling=1.0, turned_position=False,
                   last=1.0, then=lambda F: F) -> np.ndarray:
    """F(x) in closed form (the tests compare it with bf.ekf.numerical_jacobian(f_turn, x)), or a mistake's."""
    vx, vy, c, s = float(x[2]), float(x[3]), np.cos(float(x[4])), np.sin(float(x[4]))
    F, turn = np.eye(5), np.array([[c, -s], [s, c]])
    d_omega = np.array([-cos_sign * s * vx - c * vy, c * vx - cos_sign * s * vy])   # d cos = -sin, d sin = cos
    F[2:4, 2:4], F[2:4, 4], F[4, 4] = turn.T if transposed_turn else turn, omega_column * d_omega, last
    F[0, 2] = F[1, 3] = coupling                                                    # r_{t+1} = r_t + v_t
    if turned_position:                                                             # r_t + (turned v_t)
        F[0:2, 2:4], F[0:2, 4] = turn, d_omega
    return then(F)


_turn_cases = functools.partial(_cases, [(x,) for x in TURN_STATES], TURN_SEED, lambda rng: (np.round(np.concatenate([
    rng.uniform(-20, 20, 2), rng.uniform(-2, 2, 2), rng.uniform(-np.pi, np.pi, 1)]), 3),))
_TURN_MISTAKES = [
    ({"then": np.transpose}, "F is transposed: row i holds the derivatives of the i-th component of f(x)."),
    ({"omega_column": 0.0}, "the omega column is zero: the turned velocity depends on omega, a state component."),
    ({"omega_column": -1.0}, "the omega column has the wrong sign: d/d omega of cos(omega) xi_x_dot - sin(omega) xi_y_dot is "
     "-sin(omega) xi_x_dot - cos(omega) xi_y_dot."),
    ({"cos_sign": -1.0}, "the derivative of cos has the wrong sign in the omega column: d cos(omega) / d omega = "
     "-sin(omega)."),
    ({"transposed_turn": True}, "the velocity block is the transposed rotation, a clockwise turn: d xi_x_dot(t+1) / d xi_y_dot "
     "= -sin(omega)."),
    ({"coupling": 0.0}, "the position rows miss the velocities: xi_x(t+1) = xi_x + xi_x_dot, so d xi_x(t+1) / d xi_x_dot = 1."),
    ({"turned_position": True}, "you move the position by the turned velocity; it moves by v_t: xi_x(t+1) = xi_x + xi_x_dot."),
    ({"last": 0.0}, "the last row is zero: omega(t+1) = omega(t), so d omega(t+1) / d omega = 1."),
    ({"then": lambda F: F[:4, :4]}, "F must be 5 x 5: the state has five components [xi_x, xi_y, xi_x_dot, xi_y_dot, omega].")]


def exercise_4(turn_jacobian) -> Feedback:
    """Check ``turn_jacobian(x)``, the Jacobian (5, 5) of :func:`f_turn`, at ``TURN_STATES`` and two seeded states."""
    return _function(turn_jacobian, "turn_jacobian", _turn_cases(), _turn_jacobian, _turn_jacobian, _TURN_MISTAKES,
                     [((IndexError, ValueError), lambda *_: True, "x is a NumPy array of shape (5,); return shape "
                       "(5, 5).")], entry=lambda i: f"d {_TURN[i[0]]}(t+1) / d {_TURN[i[1]]}", by_hand=True)


# Exercise 5: the wrapped innovation (filterpy's residual) ------------------------------------------------------------
_innovation_cases = functools.partial(_cases, INNOVATION_CASES, INNOVATION_SEED, lambda rng: tuple(
    np.round([rng.uniform(1, 20), rng.uniform(-np.pi, np.pi)], 3) for _ in range(2)))


def exercise_5(wrapped_innovation) -> Feedback:
    """Check ``wrapped_innovation(y, y_pred)`` against ``bf.models.range_bearing_residual`` on eight pairs."""
    def _plain(y, p, wrap=lambda d: d, side=0, cases=()):
        """wrap(y - p); with side +-1: y - p on a case across the cut that way after one across the other, else None."""
        d = wrap(np.asarray(y, dtype=float) - np.asarray(p, dtype=float))
        k = next((i for i, (a, b) in enumerate(cases) if np.array_equal(a, y) and np.array_equal(b, p)), 0)
        before = [np.sign(a[1] - b[1]) for a, b in cases[:k] if abs(a[1] - b[1]) > np.pi]
        return d if not side or side * d[1] > np.pi and -side in before else None
    cases, remark, both = _innovation_cases(), [], "return both components, [range, wrapped bearing], shape (2,)."
    mistakes = [({"side": s, "cases": cases}, f"you wrap a bearing difference {o} but not this one, {t}; wrap both "
                 f"ways.") for s, o, t in [(-1, "above pi", "below -pi"), (1, "below -pi", "above pi")]] + [
        ({"wrap": lambda d: np.array([-d[0], models.wrap_angle(-d[1])])}, "the innovation has the wrong sign: y - "
         "y_pred, the measurement minus its prediction."),
        ({}, "the bearing difference is not wrapped: across the +-pi cut the plain difference is almost 2 pi; wrap "
             "it into (-pi, pi]."),
        ({"wrap": lambda d: np.array([d[0], np.arctan(np.tan(d[1]))])}, "arctan(tan(d)) folds the bearing difference "
         "into (-pi/2, pi/2): beyond pi/2 it comes back shifted by pi; wrap by 2 pi into (-pi, pi]."),
        ({"wrap": lambda d: np.array([d[0], np.mod(d[1], 2 * np.pi)])}, "the bearing difference is wrapped into [0, 2 "
         "pi); a turn to the right must stay negative: (-pi, pi]."),
        ({"wrap": models.wrap_angle}, "you wrapped the range difference too; only the bearing is an angle."),
        ({"wrap": lambda d: models.wrap_angle(d)[1]}, both), ({"wrap": lambda d: d[1]}, both)]
    named = _compare(entry=lambda i: ("the range difference", "the bearing difference")[i[-1]])

    def compare(out, e, what=None, **tol):          # -pi for exactly pi: the same direction, accepted with a remark
        a = _as_numbers(out, "")[0]
        if what and e[1] == np.pi and a is not None and _matches(a, [e[0], -np.pi], 1e-6, 1e-9):
            out = remark.append(f" (On test input {EXACTLY_PI + 1}, exactly pi, you return -pi: the same direction, "
                                f"though the chapter's interval (-pi, pi] writes it pi.)") or e
        return named(out, e, what, **tol)
    fb = _function(wrapped_innovation, "wrapped_innovation", cases, models.range_bearing_residual, _plain, mistakes,
                   compare=compare, forbidden=[({name}, f"bf.models.{name}, which the statement rules out: wrap with "
                                                        f"NumPy (np.mod, or a while loop).")
                                               for name in ("wrap_angle", "range_bearing_residual")])
    return Feedback(CORRECT, fb.message + "".join(remark)) if fb.correct else fb


_register(globals())
