r"""Checks of the exercises of chapter 04, the extended Kalman filter.

One function per exercise of ``notebooks/04_ekf_linearization.ipynb``; each
returns a :class:`bayesfilt.checks.Feedback` and is the last line of the
exercise's check cell::

    import bayesfilt as bf
    bf.checks.ch04.exercise_1(range_bearing_jacobian)          # H(x), shape (2, 4)

======================  ===========  ==================================================
check                   kind         the student defines
======================  ===========  ==================================================
:func:`exercise_1`      function     ``range_bearing_jacobian(x)``: the Jacobian H of
                                     h = [range, bearing] in Kay's state order
:func:`exercise_2`      experiment   ``converted_cov(y)``: J R J^T of a converted
                                     measurement; ``nees_2``: the average NEES of the
                                     EKF started from y_0, t = 1..10, 100 runs
:func:`exercise_3`      function     ``iterated_ekf_update(m0, P0, y, n_iter)``: the
                                     iterated EKF; ``answer_3``: the position of its
                                     limit in the first update of Kay's run
:func:`exercise_4`      derivation   ``turn_jacobian(x)``: the Jacobian F (5, 5) of a
                                     vehicle turning at the rate omega
:func:`exercise_5`      function     ``wrapped_innovation(y, y_pred)``: the
                                     range-bearing innovation, bearing wrapped
======================  ===========  ==================================================

The inputs of the statements are the constants of this module (read-only);
the references are computed from them by the library (``model.H`` of
``bf.models.range_bearing()``, ``bf.ekf.update``, ``bf.kalman.update``,
``bf.models.range_bearing_residual``, ``bf.gaussian``) or, for the two
Jacobians the library does not hold (the polar-to-Cartesian map and the
turning vehicle), by the closed form that the tests compare with
``bf.ekf.numerical_jacobian``. They are never shown. Besides the generic
diagnoses of :mod:`bayesfilt.checks` (shape, sign, transpose, factor), each
check recognises the mistakes a student is likely to make in *this*
exercise: the rows of H swapped, H transposed, its columns in chapter 03's
state order, the bearing row with the wrong sign or divided by rho instead
of rho^2, a NaN on the r_y axis (the r_y / r_x of the arctan derivation),
rho missing from the polar Jacobian, J^T R J, standard deviations used as
variances, the iterated EKF updated from the latest iterate or with the
measurement counted again, an unwrapped bearing, a rate column forgotten or
with the sign of d cos / d omega wrong, a bearing wrapped into [0, 2 pi), a
range wrapped as if it were an angle, ...

A check never raises (an answer it cannot read is feedback too) and never
prints: it returns the Feedback, which the notebook shows.
"""

from __future__ import annotations

import copy
import dataclasses
import functools
import numbers
import warnings
from typing import Callable, Sequence

import numpy as np

from .. import ekf, gaussian, kalman, models
from . import (CORRECT, INCORRECT, Feedback, _as_numbers, _not_attempted,
               _wrong, compare_array, _frozen, _matches, _combine, _not_written)

__all__ = ["exercise_1", "exercise_2", "exercise_3", "exercise_4", "exercise_5"]


# ---------------------------------------------------------------------------
# The inputs of the statements (the same numbers are in the notebook)
# ---------------------------------------------------------------------------

#: Exercise 1: the states [r_x, r_y, v_x, v_y] at which H is checked: the true start, the prior
#: mean m0, the second and third quadrants, the r_y axis (r_x = 0), 0.3 m from the sensor; two
#: seeded random states follow (``_jacobian_states``).
H_STATES = _frozen([[10.0, -5.0, -0.2, 0.2],
                    [5.0, 5.0, 0.0, 0.0],
                    [-6.0, 2.0, 0.3, 0.1],
                    [-3.0, -7.0, 0.0, 1.0],
                    [0.0, 5.0, 0.2, 0.0],
                    [0.3, -0.1, 0.0, 0.0]])
H_SEED = 4041
ON_THE_RY_AXIS = 4                         # the index of the state with r_x = 0

#: Exercise 2: measurements [range (m), bearing (rad)] at which J R J^T is checked (the first is
#: y_0 of section 1, rounded, where the recognised mistakes all differ; then the old exercise's
#: rho = 10 m, beta = 0); two seeded random ones follow.
Y_CONVERT = _frozen([[11.03, -0.405],
                     [10.0, 0.0],
                     [5.0, 2.5],
                     [8.0, -3.0],
                     [10.0, np.pi]])
CONVERT_SEED = 4042
#: Exercise 2: the experiment: batch (a) of section 7 (true start fixed), 100 runs, seed 10,
#: the NEES at t = 1, ..., 10.
NEES_SEED, NEES_RUNS, NEES_STEPS = 10, 100, 10
#: The average NEES a consistent filter gives here lies in this band for every seed (over 100
#: seeds it is 4.15 with a standard deviation of 0.25 across seeds, extremes 3.56 and 4.93;
#: with J^T R J it is 7 or more, without rho in J 70 or more).
NEES_BAND = (3.0, 5.5)

#: Exercise 3: the first update of Kay's run: section 1's simulation (seed 0, 100 steps) and
#: its y_0; the tolerance of "to 0.01 m".
SECTION_1_SEED, SECTION_1_STEPS = 0, 100
LIMIT_ITERATIONS = 50
LIMIT_TOL = 0.011
#: a prior near the negative r_x axis and a measurement across the +-pi cut (the bearing
#: innovation must be wrapped); a tight prior at the true start.
WRAP_PRIOR = (_frozen([-10.0, 0.3, 0.0, 0.0]), _frozen(4.0 * np.eye(4)), _frozen([10.2, -3.12]))
TIGHT_PRIOR = (_frozen([10.0, -5.0, -0.2, 0.2]), _frozen(np.diag([1.0, 1.0, 0.01, 0.01])),
               _frozen([11.5, -0.5]))

#: Exercise 4: the states [r_x, r_y, v_x, v_y, omega]: a slow turn from the true start, a quarter
#: turn per step, a right turn, a straight drive (omega = 0), a vehicle at rest; two seeded
#: random states follow.
TURN_STATES = _frozen([[10.0, -5.0, -0.2, 0.2, 0.05],
                       [0.0, 0.0, 1.0, 0.0, np.pi / 2],
                       [-2.0, 1.0, 0.5, -1.5, -0.4],
                       [1.0, 2.0, 0.3, 0.4, 0.0],
                       [3.0, 4.0, 0.0, 0.0, 0.3]])
TURN_SEED = 4044

#: Exercise 5: (y, y_pred) pairs: section 10's first innovation (no wrap, range change > pi),
#: bearings across the cut both ways, a noisy bearing above pi, an equal bearing, a difference
#: of exactly pi; two seeded random pairs follow.
INNOVATION_CASES = (
    (_frozen([11.03, -0.405]), _frozen([7.07, 0.785])),
    (_frozen([9.8, 3.12]), _frozen([10.0, -3.13])),
    (_frozen([10.0, -3.1]), _frozen([10.2, 3.05])),
    (_frozen([10.0, 3.21]), _frozen([10.1, -3.1])),
    (_frozen([4.0, 1.0]), _frozen([8.5, 1.0])),
    (_frozen([5.0, np.pi / 2]), _frozen([5.0, -np.pi / 2])),
)
INNOVATION_SEED = 4045
EXACTLY_PI = 5                             # the index of the pair whose difference is pi


# ---------------------------------------------------------------------------
# Shared machinery
# ---------------------------------------------------------------------------

@functools.lru_cache(maxsize=1)
def _model():
    return models.range_bearing()


def _quiet(fun: Callable, args: tuple):
    """fun(*deep copies of args) with numpy's and Python's warnings silenced (a student's
    division by zero is diagnosed, not printed)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        with np.errstate(all="ignore"):
            return fun(*copy.deepcopy(args))


def _try(fn: Callable, *args):
    """fn(*args) as a finite float array, or None if it cannot be formed."""
    try:
        out = np.asarray(_quiet(fn, args), dtype=float)
    except Exception:  # noqa: BLE001 - a mistake that cannot be formed here is simply not it
        return None
    return out if np.all(np.isfinite(out)) else None


def _array_feedback(answer, expected, what: str, mistakes: Sequence[tuple], rtol: float = 1e-6,
                    atol: float = 1e-9, entry_name: Callable | None = None) -> Feedback:
    """compare_array, but a recognised mistake gets its own message.

    ``mistakes`` holds ``(wrong, message)`` pairs, tried in order when the answer is not
    correct: ``wrong`` is the array that mistake produces (None if it cannot be formed) or a
    predicate on the answer (a float array). ``entry_name(index)`` names an entry (e.g.
    "d beta / d r_x") in the fallback message.
    """
    with np.errstate(all="ignore"):
        feedback = compare_array(answer, expected, what, rtol=rtol, atol=atol)
    if feedback.status != INCORRECT:
        return feedback
    a, bad = _as_numbers(answer, what)
    if bad is not None:
        return feedback
    for wrong, message in mistakes:
        try:
            hit = wrong(a) if callable(wrong) else _matches(a, wrong, rtol, atol)
        except Exception:  # noqa: BLE001 - a predicate that cannot be evaluated does not hit
            hit = False
        if hit:
            return _wrong(message)
    e = np.asarray(expected, dtype=float)
    if entry_name is not None and a.shape == e.shape:
        with np.errstate(all="ignore"):
            differ = ~np.isclose(a, e, rtol=rtol, atol=atol)
        if differ.any():
            first = tuple(int(i) for i in np.argwhere(differ)[0])
            return _wrong(f"{what} has the right shape but {int(differ.sum())} of {a.size} "
                          f"entries differ from the reference; the first is {entry_name(first)} "
                          f"(entry {first}).")
    return feedback


def _describe(names: Sequence[str], args: tuple) -> str:
    """'x = [10, -5, -0.2, 0.2]' on one line; a large array by its shape."""
    parts = []
    for name, a in zip(names, args):
        if isinstance(a, (int, np.integer)):
            parts.append(f"{name} = {int(a)}")
            continue
        a = np.asarray(a)
        if a.size <= 5:
            text = np.array2string(a, separator=", ",
                                   formatter={"float_kind": lambda v: f"{v:.4g}"})
            parts.append(f"{name} = {' '.join(text.split())}")
        else:
            parts.append(f"{name} of shape {a.shape}")
    return ", ".join(parts)


def _failure(exc: Exception) -> str:
    try:
        return f"{type(exc).__name__}: {exc}"
    except Exception:  # noqa: BLE001 - an exception that cannot print itself is still named
        return type(exc).__name__


class _OnAnswer:
    """A mistake recognised by a predicate on the output (a float array), not by the output
    that the mistake would produce from the test input."""

    def __init__(self, predicate: Callable):
        self.predicate = predicate


def _run_case(fun, what: str, where: str, args: tuple,
              exception_hint: Callable = lambda exc: ""):
    """(output, None), or (None, Feedback) when the function is not written, fails or returns
    None."""
    try:
        out = _quiet(fun, args)
    except NotImplementedError:
        return None, _not_written(what)
    except Exception as exc:  # noqa: BLE001 - any failure is feedback, not a crash
        try:
            hint = exception_hint(exc)
        except Exception:  # noqa: BLE001 - a hint that cannot be formed is left out
            hint = ""
        return None, _wrong(f"{what} fails on {where}: {_failure(exc)}{hint}")
    if out is None:
        return None, _wrong(f"{what} returned None on {where}; did you forget `return`?")
    return out, None


def _function_feedback(fun, what: str, names: Sequence[str], cases: Sequence[tuple],
                       reference: Callable, mistakes: Sequence[tuple],
                       exception_hint: Callable = lambda exc, k, args: "",
                       special: Callable = lambda out, k, args: None,
                       rtol: float = 1e-6, atol: float = 1e-9,
                       entry_name: Callable | None = None) -> Feedback:
    """Run a student's function on the cases and diagnose the first one it gets wrong.

    Like :func:`bayesfilt.checks.compare_function` (deep-copied inputs, NotImplementedError
    = not attempted, a failure reported with the input that caused it), with ``names``
    naming the arguments, ``mistakes`` = ``(wrong_function, message)`` pairs evaluated on the
    failing case (or ``(_OnAnswer(predicate), message)``, a predicate on the output),
    ``exception_hint(exc, k, args)`` adding a hint to a failure and
    ``special(out, k, args)`` returning a Feedback for an output that needs its own diagnosis
    before the comparison (e.g. a NaN on the r_y axis), or None.
    """
    if fun is None or fun is Ellipsis:
        return _not_attempted(what)
    if not callable(fun):
        return _wrong(f"{what} must be a function (def ...), got {type(fun).__name__}.")
    for k, args in enumerate(cases):
        where = f"test input {k + 1} ({_describe(names, args)})"
        out, failed = _run_case(fun, what, where, args, lambda exc: exception_hint(exc, k, args))
        if failed is not None:
            return failed
        found = special(out, k, args)
        if found is not None:
            return found
        found = [(wrong.predicate if isinstance(wrong, _OnAnswer) else _try(wrong, *args),
                  f"{what}, {where}: {message}") for wrong, message in mistakes]
        feedback = _array_feedback(out, reference(*args), f"the output for {where}", found,
                                   rtol, atol, entry_name)
        if feedback.status != CORRECT:
            return feedback
    return Feedback(CORRECT, f"{what} agrees with the library on all {len(cases)} test inputs.")


def _number(answer, what: str):
    """(float, None) or (None, Feedback) for an answer that must be one real number."""
    if answer is None or answer is Ellipsis:
        return None, _not_attempted(what)
    if isinstance(answer, np.ndarray) and answer.size == 1:
        answer = answer.item()
    if isinstance(answer, (bool, np.bool_)) or not isinstance(answer, numbers.Real):
        return None, _wrong(f"{what} must be a single number (a float), got "
                            f"{type(answer).__name__}.")
    try:
        value = float(answer)
    except (OverflowError, ValueError, TypeError):
        return None, _wrong(f"{what} must be a finite number of ordinary size.")
    if not np.isfinite(value):
        return None, _wrong(f"{what} is NaN or inf.")
    return value, None


# ---------------------------------------------------------------------------
# Exercise 1: the range-bearing Jacobian H
# ---------------------------------------------------------------------------

_STATE = ("r_x", "r_y", "v_x", "v_y")


def _jacobian_states() -> list[tuple]:
    rng = np.random.default_rng(H_SEED)
    states = [np.array(x) for x in H_STATES]
    while len(states) < len(H_STATES) + 2:
        x = np.round(rng.uniform(-20.0, 20.0, size=4), 3)
        if np.hypot(x[0], x[1]) > 1.0:
            states.append(x)
    return [(x,) for x in states]


def _h_parts(rx, ry):
    rho2 = rx * rx + ry * ry
    return rho2, np.sqrt(rho2)


def _h_kay(cols, range_row, bearing_row):
    """A 2 x 4 matrix with the given rows placed in the columns ``cols``."""
    H = np.zeros((2, 4))
    H[0, list(cols)] = range_row
    H[1, list(cols)] = bearing_row
    return H


def _h_variant(x, read=(0, 1), cols=(0, 1), range_scale="rho", bearing_scale="rho2",
               bearing_sign=1.0):
    rx, ry = float(x[read[0]]), float(x[read[1]])
    rho2, rho = _h_parts(rx, ry)
    range_row = {"rho": np.array([rx, ry]) / rho, "one": np.array([rx, ry]),
                 "square": 2 * np.array([rx, ry])}[range_scale]
    bearing_row = bearing_sign * np.array([-ry, rx]) / {"rho2": rho2, "rho": rho}[bearing_scale]
    return _h_kay(cols, range_row, bearing_row)


_H_MISTAKES = [
    (lambda x: _h_variant(x).T,
     "H is transposed: it has one row per measurement component (range, bearing) and one "
     "column per state component, shape (2, 4)."),
    (lambda x: _h_variant(x)[::-1],
     "the rows are swapped: h = [range, bearing], so row 0 holds the derivatives of the range "
     "and row 1 those of the bearing."),
    (lambda x: _h_variant(x, read=(0, 2), cols=(0, 2)),
     "you read the state in chapter 03's order [r_x, v_x, r_y, v_y] (r_y = x[2]) and placed the "
     "columns there too; here the state is in Kay's order [r_x, r_y, v_x, v_y]: r_y = x[1], "
     "and the columns of r_x, r_y are 0 and 1."),
    (lambda x: _h_variant(x, read=(0, 2)),
     "you read r_y from x[2], its place in chapter 03's order; in Kay's order "
     "[r_x, r_y, v_x, v_y] r_y is x[1] (x[2] is v_x)."),
    (lambda x: _h_variant(x, cols=(0, 2)),
     "the columns are in chapter 03's state order [r_x, v_x, r_y, v_y]; here the state is in "
     "Kay's order [r_x, r_y, v_x, v_y], so the derivatives by r_x and r_y are columns 0 and 1 "
     "(select by name: model.index_of(\"r_x\", \"r_y\"))."),
    (lambda x: _h_variant(x, bearing_sign=-1.0),
     "the bearing row has the wrong sign: the bearing grows anticlockwise, so d beta / d r_y = "
     "r_x / rho^2 is positive where r_x > 0 (differentiate atan2(r_y, r_x), not "
     "atan2(r_x, r_y), and check the sign of d/du arctan(u) times d(r_y/r_x)/d r_x)."),
    (lambda x: -_h_variant(x),
     "both rows have the wrong sign: the range grows as the vehicle moves away from the sensor, "
     "so d rho / d r_x = r_x / rho has the sign of r_x."),
    (lambda x: _h_variant(x, bearing_scale="rho"),
     "the bearing row is divided by rho; it is divided by rho^2 (d beta / d r_x = -r_y / rho^2): "
     "a step across the line of sight of 1 m turns the bearing by 1/rho rad."),
    (lambda x: _h_variant(x, range_scale="one"),
     "the range row is not divided by rho: d rho / d r_x = r_x / rho (a unit vector away from "
     "the sensor), not r_x."),
    (lambda x: _h_variant(x, range_scale="square"),
     "the range row is the derivative of rho^2 = r_x^2 + r_y^2; the range is its square root, so "
     "d rho / d r_x = r_x / rho."),
    (lambda x: _h_variant(x)[:, :2],
     "H has a column for each of the 4 state components; the velocities do not enter h, so "
     "their two columns are zero (shape (2, 4), not (2, 2))."),
]


def _h_entry(index: tuple) -> str:
    i, j = index
    return f"d {('rho', 'beta')[i]} / d {_STATE[j]}"


def _h_special(out, k, args):
    """A NaN or inf exactly where r_x = 0: the r_y / r_x of the arctan derivation."""
    try:
        a = np.asarray(out, dtype=float)
    except Exception:  # noqa: BLE001 - unreadable output: the comparison reports it
        return None
    if k == ON_THE_RY_AXIS and a.size and not np.all(np.isfinite(a)):
        return _wrong(
            f"range_bearing_jacobian, test input {k + 1} ({_describe(('x',), args)}), on the r_y "
            f"axis (r_x = 0): your H contains NaN or inf. The derivation through "
            f"arctan(r_y / r_x) divides by r_x, but H itself is finite wherever rho > 0: "
            f"simplify (1 / (1 + r_y^2 / r_x^2)) (-r_y / r_x^2) until no r_x is left in a "
            f"denominator except through rho.")
    return None


def _h_exception_hint(exc, k, args) -> str:
    if k == ON_THE_RY_AXIS and isinstance(exc, (ZeroDivisionError, FloatingPointError)):
        return (" Hint: r_x = 0 here (the r_y axis): the quotient r_y / r_x of the arctan "
                "derivation is undefined, but H is not; simplify the derivative so that only "
                "rho^2 = r_x^2 + r_y^2 is in a denominator.")
    if isinstance(exc, (IndexError, ValueError)):
        return " Hint: x is a NumPy array of shape (4,), [r_x, r_y, v_x, v_y]; return shape (2, 4)."
    return ""


def exercise_1(range_bearing_jacobian) -> Feedback:
    """Check ``range_bearing_jacobian(x)`` against the model's ``H`` at eight states.

    The states: ``H_STATES`` (the true start, m0, the second and third quadrants, the
    r_y axis, 0.3 m from the sensor) and two seeded random ones; the reference is
    ``bf.models.range_bearing().H`` (the tests confirm it equals
    ``bf.ekf.numerical_jacobian(model.h, x)`` there). Recognised mistakes: H transposed,
    rows swapped, chapter 03's state order (read, columns, or both), the bearing row or
    both rows with the wrong sign, the bearing row over rho instead of rho^2, the range
    row not divided by rho or the derivative of rho^2, the velocity columns left out, and
    a NaN or a division by zero on the r_y axis.
    """
    model = _model()
    return _by_hand(range_bearing_jacobian, "range_bearing_jacobian", _function_feedback(
        range_bearing_jacobian, "range_bearing_jacobian", ("x",), _jacobian_states(), model.H,
        _H_MISTAKES, exception_hint=_h_exception_hint, special=_h_special,
        entry_name=_h_entry), _jacobian_states(), model.H)


def _by_hand(fun, what: str, feedback: Feedback, cases, reference) -> Feedback:
    """A Jacobian that agrees only to ~1e-11 is a finite difference, not derivatives by hand."""
    if feedback.status != CORRECT:
        return feedback
    for k, args in enumerate(cases):
        ref = np.asarray(reference(*args), dtype=float)
        err = float(np.max(np.abs(np.asarray(fun(*copy.deepcopy(args)), dtype=float) - ref)))
        if err > 1e-12 * max(1.0, float(np.max(np.abs(ref)))):
            return _wrong(f"{what} agrees with the closed form only to about {err:.0e} on test "
                          f"input {k + 1}: a finite-difference Jacobian (bf.ekf."
                          f"numerical_jacobian or your own), not derivatives by hand? Derive "
                          f"each entry; a closed form agrees to round-off (1e-12). Use the "
                          f"numerical Jacobian only to check yours.")
    return feedback


# ---------------------------------------------------------------------------
# Exercise 2: a prior from the first measurement
# ---------------------------------------------------------------------------

def _polar_jacobian(y, with_rho: bool = True, from_ry_axis: bool = False) -> np.ndarray:
    """J = d(rho cos beta, rho sin beta) / d(rho, beta); or the mistakes' variants."""
    rho, beta = float(y[0]), float(y[1])
    c, s = np.cos(beta), np.sin(beta)
    r = rho if with_rho else 1.0
    if from_ry_axis:  # (rho sin beta, rho cos beta): the bearing measured from the r_y axis
        return np.array([[s, r * c], [c, -r * s]])
    return np.array([[c, -r * s], [s, r * c]])


def _converted_cov(y) -> np.ndarray:
    J = _polar_jacobian(y)
    # J R J^T: the measurement noise carried to (r_x, r_y) by the tangent of the conversion
    return J @ _model().R @ J.T


def _convert_cases() -> list[tuple]:
    rng = np.random.default_rng(CONVERT_SEED)
    cases = [np.array(y) for y in Y_CONVERT]
    for _ in range(2):
        cases.append(np.round([rng.uniform(1.0, 30.0), rng.uniform(-np.pi, np.pi)], 3))
    return [(y,) for y in cases]


def _cov_mistakes():
    R = _model().R
    J = _polar_jacobian
    return [
        (lambda y: J(y, with_rho=False) @ R @ J(y, with_rho=False).T,
         "rho is missing from J: a bearing error d beta moves the converted point by "
         "rho d beta across the line of sight, so the bearing column of J is "
         "rho (-sin beta, cos beta)."),
        (lambda y: J(y).T @ R @ J(y),
         "this is J^T R J; the covariance of J v (v the measurement noise) is J R J^T."),
        (lambda y: J(y) @ np.sqrt(R) @ J(y).T,
         "R holds variances (0.1 m^2 for the range, 0.01 rad^2 for the bearing); you used "
         "their square roots, the standard deviations."),
        (lambda y: J(y) @ R,
         "J R is not a covariance (it is not symmetric): the noise is carried by J on both "
         "sides, J R J^T."),
        (lambda y: R,
         "this is R itself, the covariance of (range, bearing); carry it to (r_x, r_y) with the "
         "Jacobian J of the conversion: J R J^T."),
        (lambda y: np.diag(np.diag(J(y) @ R @ J(y).T)),
         "you kept only the diagonal: away from the axes the errors in r_x and r_y are "
         "correlated, so J R J^T has off-diagonal entries."),
        (lambda y: J(y, from_ry_axis=True) @ R @ J(y, from_ry_axis=True).T,
         "your conversion measures the bearing from the r_y axis: the bearing is anticlockwise "
         "from the positive r_x axis, so r_x = rho cos beta and r_y = rho sin beta."),
        (lambda y: np.linalg.inv(J(y) @ R @ J(y).T),
         "this is the inverse of J R J^T, a precision; the exercise asks for the covariance."),
    ]


def _cov_entry(index: tuple) -> str:
    return f"cov({('r_x', 'r_y')[index[0]]}, {('r_x', 'r_y')[index[1]]})"


def _nees_experiment(cov_fn: Callable, rng: np.random.Generator, n_runs: int = 100,
                     T: int = 11) -> np.ndarray:
    """The experiment of exercise 2, as the notebook's answer cell gives it (NEES (n_runs, T-1));
    the tests check that the notebook's copy gives the same NEES.

    Batch (a) of section 7 (true start fixed) with the prior of x_0 made from y_0: mean the
    converted y_0 and zero velocity, covariance ``cov_fn(y_0)`` for the positions and 1 for
    each velocity; predicted once to t = 1 and updated with y_1, ..., y_{T-1}.
    """
    model = _model()
    pos = model.index_of("r_x", "r_y")
    nees = np.empty((n_runs, T - 1))
    for i in range(n_runs):
        xs, ys = models.simulate(model, T, rng, x0=models.RANGE_BEARING_TRUE_START)
        rho, beta = ys[0]
        m, P = np.zeros(4), np.eye(4)
        m[pos] = rho * np.cos(beta), rho * np.sin(beta)
        P[np.ix_(pos, pos)] = cov_fn(ys[0])
        prior_1 = ekf.predict(m, P, model.f, model.F, model.Q, model.G)
        run = ekf.extended_kalman_filter(
            dataclasses.replace(model, m0=prior_1.mean, P0=prior_1.cov), ys[1:])
        nees[i] = gaussian.squared_mahalanobis(xs[1:] - run.means, run.covs)
    return nees


def _nees_feedback(nees) -> Feedback:
    what = "nees_2"
    value, bad = _number(nees, what)
    if bad is not None:
        return bad
    low, high = NEES_BAND
    if low <= value <= high:
        return Feedback(CORRECT, f"{what} is what a consistent filter gives: the chi2_4 "
                                 f"average, from the first steps on.")
    if value < 0:
        return _wrong(f"{what} is negative, but a NEES is a squared distance; average the "
                      f"array that nees_from_first_measurement returns.")
    if value > 1000:
        return _wrong(f"{what} is far too large for an average: did you sum the NEES instead of "
                      f"averaging it over the runs and the steps (np.mean)?")
    if value > 30:
        return _wrong(f"{what} is an order of magnitude above what a consistent filter gives: "
                      f"the prior is far too sure across the line of sight. Does your J carry "
                      f"the factor rho in its bearing column (a bearing error d beta moves the "
                      f"point by rho d beta)?")
    if value > high:
        return _wrong(f"{what} is above what a consistent filter gives (overconfident): your "
                      f"position covariance is too small in some direction. Is it J R J^T "
                      f"(not J^T R J)?")
    return _wrong(f"{what} is below what a consistent filter gives (underconfident): your "
                  f"position covariance is too large. Does it use the variances of R (not "
                  f"their square roots)?")


def exercise_2(converted_cov, nees) -> Feedback:
    """Check ``converted_cov(y)`` (J R J^T, shape (2, 2)) and ``nees_2`` (a float).

    ``converted_cov`` is compared with the closed form J R J^T (R of
    ``bf.models.range_bearing()``) at ``Y_CONVERT`` and two seeded random measurements.
    Recognised mistakes: rho missing from J, J^T R J, standard deviations for
    variances, J R, R itself, the diagonal only, the bearing from the r_y axis, the
    inverse. ``nees_2`` is accepted in ``NEES_BAND``, which holds for any seed;
    outside it the message says overconfident (too small a covariance: J^T R J, rho
    missing) or underconfident, or a sum instead of an average.
    """
    cov = _function_feedback(converted_cov, "converted_cov", ("y",), _convert_cases(),
                             _converted_cov, _cov_mistakes(), entry_name=_cov_entry)
    nees_fb = _nees_feedback(nees)
    if nees_fb.status == CORRECT:
        nees_fb = _nees_summary(float(np.asarray(nees, dtype=float)))
    return _combine([("converted_cov", cov), ("nees_2", nees_fb)])


@functools.lru_cache(maxsize=1)
def _seed_10_nees() -> np.ndarray:
    return _nees_experiment(_converted_cov, np.random.default_rng(NEES_SEED))


def _nees_summary(value: float) -> Feedback:
    """nees_2 in the band: is it another summary of the seed's NEES array than its average?"""
    e = _seed_10_nees()
    if np.isclose(value, e.mean(), rtol=1e-9):
        return _nees_feedback(value)
    summaries = [(e[:, -1].mean(), "the average at the last step t = 10 only"),
                 (e[:, 0].mean(), "the average at the first step t = 1 only"),
                 (e[-1].mean(), "the average of the last run only"),
                 (e[0].mean(), "the average of the first run only"),
                 (float(np.median(e)), "the median")]
    for other, name in summaries:
        if np.isclose(value, other, rtol=1e-9):
            return _wrong(f"nees_2 is {name} of the array of NEES values; the exercise asks for "
                          f"the average over all 100 runs and all steps t = 1, ..., 10, "
                          f"nees_from_first_measurement(converted_cov, "
                          f"np.random.default_rng({NEES_SEED})).mean().")
    return _nees_feedback(value)


# ---------------------------------------------------------------------------
# Exercise 3: the iterated EKF
# ---------------------------------------------------------------------------

@functools.lru_cache(maxsize=1)
def _section_1_y0() -> np.ndarray:
    model = _model()
    sim = models.simulate(model, SECTION_1_STEPS, np.random.default_rng(SECTION_1_SEED),
                          x0=models.RANGE_BEARING_TRUE_START)
    return _frozen(sim.ys[0])


def _iterate(m0, P0, y, n_iter, mode: str = "right") -> np.ndarray:
    """x^(n_iter) of the iterated EKF by bf.kalman.update, or a mistake's variant.

    Each step is the Kalman update of the prior (m0, P0) with the measurement linearised at
    the iterate x: y' = r + H x, where r is the wrapped y - h(x), so that
    m0 + K (y' - H m0) = m0 + K (r - H (m0 - x)).
    """
    model = _model()
    m0, P0, y = np.asarray(m0, float), np.asarray(P0, float), np.asarray(y, float)
    n = int(n_iter) + {"plus_one": 1, "minus_one": -1}.get(mode, 0)
    x, P = m0.copy(), P0.copy()
    H0 = model.H(m0)
    for _ in range(max(n, 0)):
        H = H0 if mode == "fixed_H" else model.H(x)
        y_pred = model.h(x)
        r = y - y_pred if mode == "unwrapped" else models.range_bearing_residual(y, y_pred)
        if mode == "latest":           # x + K r, from the latest iterate
            x = kalman.update(x, P0, r + H @ x, H, model.R).mean
        elif mode == "no_term":        # m0 + K r
            x = kalman.update(m0, P0, r + H @ m0, H, model.R).mean
        elif mode == "term_sign":      # m0 + K (r + H (m0 - x))
            x = kalman.update(m0, P0, r + 2 * H @ m0 - H @ x, H, model.R).mean
        elif mode == "repeated":       # the EKF update repeated, covariance and all
            step = kalman.update(x, P, r + H @ x, H, model.R)
            x, P = step.mean, step.cov
        else:                          # m0 + K (r - H (m0 - x))
            x = kalman.update(m0, P0, r + H @ x, H, model.R).mean
    return x


def _iterated_reference(m0, P0, y, n_iter) -> np.ndarray:
    if int(n_iter) == 1:  # the ordinary EKF update, by the library's EKF
        model = _model()
        return ekf.update(m0, P0, y, model.h, model.H, model.R, models.range_bearing_residual).mean
    return _iterate(m0, P0, y, n_iter)


def _iteration_cases() -> list[tuple]:
    model = _model()
    y0 = _section_1_y0()
    kay = (np.array(model.m0), np.array(model.P0), np.array(y0))
    return [kay + (1,), kay + (2,), kay + (0,), kay + (10,),
            tuple(np.array(a) for a in WRAP_PRIOR) + (3,),
            tuple(np.array(a) for a in TIGHT_PRIOR) + (4,)]


_ITERATION_MISTAKES = [
    (lambda m0, P0, y, n: _iterate(m0, P0, y, n, "plus_one"),
     "you return x^(n_iter + 1): x^(0) = m0, and n_iter = 1 is the ordinary EKF update "
     "(one pass through the loop)."),
    (lambda m0, P0, y, n: _iterate(m0, P0, y, n, "minus_one"),
     "you return x^(n_iter - 1): x^(0) = m0, and n_iter = 1 must give the ordinary EKF update."),
    (lambda m0, P0, y, n: _iterate(m0, P0, y, n, "repeated"),
     "you repeat the EKF update, covariance and all, with the same y: each pass counts y once "
     "more. The iterated EKF always updates the prior N(m0, P0) and only moves the point of "
     "linearisation."),
    (lambda m0, P0, y, n: _iterate(m0, P0, y, n, "latest"),
     "you update from the latest iterate, x^(i) + K_i (y - h(x^(i))); the iterated EKF always "
     "starts from the prior mean m0, and the term - H_i (m0 - x^(i)) accounts for linearising "
     "at x^(i) instead."),
    (lambda m0, P0, y, n: _iterate(m0, P0, y, n, "no_term"),
     "the term - H_i (m0 - x^(i)) is missing: updating m0 with a tangent taken at x^(i), the "
     "prediction of y at m0 is h(x^(i)) + H_i (m0 - x^(i)), not h(x^(i))."),
    (lambda m0, P0, y, n: _iterate(m0, P0, y, n, "term_sign"),
     "the term H_i (m0 - x^(i)) has the wrong sign: the innovation is y - h(x^(i)) - "
     "H_i (m0 - x^(i)), the measurement minus its prediction at m0 by the tangent at x^(i)."),
    (lambda m0, P0, y, n: _iterate(m0, P0, y, n, "unwrapped"),
     "the bearing part of y - h(x^(i)) is not wrapped: the measured and predicted bearings lie "
     "on both sides of the +-pi cut here; wrap the difference into (-pi, pi] "
     "(bf.models.range_bearing_residual)."),
    (lambda m0, P0, y, n: _iterate(m0, P0, y, n, "fixed_H"),
     "you re-evaluate h at x^(i) but keep the Jacobian of m0: re-linearise, H_i = H(x^(i)) and "
     "K_i with it."),
    (_OnAnswer(lambda a: a.shape == (2,)),
     "return the whole state x^(n_iter), shape (4,) (answer_3 then selects its position)."),
]


def _iteration_hint(exc, k, args) -> str:
    if "model" in str(exc) and isinstance(exc, NameError):
        return " Hint: use the chapter's model (model = bf.models.range_bearing(), section 1)."
    if isinstance(exc, (ValueError, IndexError)) and ("shape" in str(exc) or "align" in str(exc)
                                                     or "dimension" in str(exc)):
        return (" Hint: m0 (4,), P0 (4, 4), y (2,), H_i (2, 4), R (2, 2), S (2, 2), K (4, 2); "
                "return the state x^(n_iter), shape (4,).")
    return ""


@functools.lru_cache(maxsize=1)
def _limit_positions() -> dict:
    """The limit and the positions a mistaken answer_3 is likely to hold."""
    model = _model()
    y0 = _section_1_y0()
    pos = model.index_of("r_x", "r_y")
    kay = (model.m0, model.P0, y0)
    out = {"limit": _iterate(*kay, LIMIT_ITERATIONS)[pos],
           "early": [_iterate(*kay, n)[pos] for n in range(1, 6)],
           "prior": np.array(model.m0)[pos],
           "truth": np.array(models.RANGE_BEARING_TRUE_START)[pos],
           "grid": _grid_posterior_mean(y0)}
    out["mistakes"] = [(_try(lambda: _iterate(*kay, LIMIT_ITERATIONS, mode)), message)
                       for mode, message in (
                           ("latest", "this is where the iteration from the latest iterate "
                                      "goes; the iterated EKF always updates the prior mean m0."),
                           ("no_term", "this is where the iteration without the term "
                                       "- H_i (m0 - x^(i)) goes; keep it."),
                           ("repeated", "this is where repeated EKF updates with the same y_0 "
                                        "go (y_0 counted again and again); the iterated EKF "
                                        "updates the prior every time."))]
    return out


def _grid_posterior_mean(y0) -> np.ndarray:
    """The exact posterior mean of the position after y0, on section 8's grid (spacing 0.2)."""
    model = _model()
    pos = model.index_of("r_x", "r_y")
    g = np.arange(-25.0, 35.0 + 0.1, 0.2)
    gx, gy = np.meshgrid(g, g)
    states = np.zeros((gx.size, 4))
    states[:, pos[0]], states[:, pos[1]] = gx.ravel(), gy.ravel()
    log_post = (model.measurement_logpdf(y0, states)
                + gaussian.logpdf(states[:, pos], model.m0[pos], model.P0[np.ix_(pos, pos)]))
    post = np.exp(log_post - log_post.max())
    post /= post.sum()
    return np.array([post @ gx.ravel(), post @ gy.ravel()])


def _limit_feedback(answer) -> Feedback:
    with np.errstate(all="ignore"):  # an answer of huge numbers is feedback, not a warning
        return _limit_diagnosis(answer)


def _limit_diagnosis(answer) -> Feedback:
    what = "answer_3"
    if answer is None or answer is Ellipsis:
        return _not_attempted(what)
    a, bad = _as_numbers(answer, what)
    if bad is not None:
        return bad
    ref = _limit_positions()
    close = functools.partial(np.allclose, rtol=0.0, atol=LIMIT_TOL)
    if a.shape == (4,):
        if close(a[:2], ref["limit"]):
            return _wrong(f"{what} is a whole state; give the position [r_x, r_y] only, shape "
                          f"(2,) (x[pos] selects it by name).")
        return _wrong(f"{what} must be the position [r_x, r_y], shape (2,), not a whole state.")
    if a.shape != (2,):
        return _wrong(f"{what} must be the position [r_x, r_y], a NumPy array of shape (2,); "
                      f"got shape {a.shape}.")
    if close(a, ref["limit"]):
        return Feedback(CORRECT, f"{what} is the limit of the iterated EKF, to 0.01 m.")
    if close(a, ref["early"][0]):
        return _wrong(f"{what} is x^(1), the ordinary EKF update of section 8; iterate until "
                      f"x^(i) no longer moves.")
    for n, early in enumerate(ref["early"][1:], start=2):
        if close(a, early):
            return _wrong(f"{what} is x^({n}), still on its way: iterate until x^(i) no longer "
                          f"moves (print |x^(i+1) - x^(i)|).")
    if close(a, ref["prior"]):
        return _wrong(f"{what} is the prior mean m0, x^(0); the limit is where the iterations "
                      f"go.")
    if close(a, ref["truth"]):
        return _wrong(f"{what} is the true start of the vehicle, which the filter does not know; "
                      f"report the limit of the iterations.")
    if close(a, ref["grid"]) or (np.linalg.norm(a - ref["grid"]) < 0.5 * np.linalg.norm(
            ref["limit"] - ref["grid"])):
        return _wrong(f"{what} is (close to) the mean of the exact posterior of section 8. The "
                      f"iterated EKF converges to the MAP, the point of largest posterior "
                      f"density, which need not be the mean: report the limit of the "
                      f"iterations.")
    for wrong, message in ref["mistakes"]:
        if wrong is not None and close(a, wrong[:2]):
            return _wrong(f"{what}: {message}")
    if close(a[::-1], ref["limit"]):
        return _wrong(f"{what} has r_x and r_y swapped: give [r_x, r_y].")
    return _wrong(f"{what} is not the limit of the iterations for y_0 = sim.ys[0] of section 1 "
                  f"(with m0 and P0 of model) to 0.01 m: iterate your iterated_ekf_update from "
                  f"m0 until x^(i) no longer moves, and give its position.")


def exercise_3(iterated_ekf_update, answer) -> Feedback:
    """Check ``iterated_ekf_update(m0, P0, y, n_iter)`` and ``answer_3`` (the limit's position).

    The function is compared on six inputs (Kay's first update with n_iter = 1, 2, 0, 10; a
    prior and a measurement across the +-pi cut; a tight prior) with the library: n_iter = 1
    is ``bf.ekf.update``, more iterations are Kalman updates of the prior by
    ``bf.kalman.update`` with the re-linearised measurement. Recognised mistakes: one
    iteration too many or too few, repeated EKF updates, updates from the latest iterate,
    the term - H_i (m0 - x^(i)) missing or with the wrong sign, an unwrapped bearing, a
    Jacobian kept at m0. ``answer_3`` is compared to 0.011 m with the limit for y_0 of
    section 1; recognised: x^(1) (the EKF), an early iterate, m0, the truth, the grid
    posterior mean, the limits of the mistaken iterations, a whole state, swapped axes.
    """
    fun = _function_feedback(iterated_ekf_update, "iterated_ekf_update",
                             ("m0", "P0", "y", "n_iter"), _iteration_cases(),
                             _iterated_reference, _ITERATION_MISTAKES,
                             exception_hint=_iteration_hint, rtol=1e-6, atol=1e-7,
                             entry_name=lambda i: f"the {_STATE[i[0]]} component")
    return _combine([("iterated_ekf_update", fun), ("answer_3", _limit_feedback(answer))])


# ---------------------------------------------------------------------------
# Exercise 4: the Jacobian of a turning vehicle
# ---------------------------------------------------------------------------

_TURN = ("r_x", "r_y", "v_x", "v_y", "omega")


def f_turn(x) -> np.ndarray:
    """The turning vehicle of exercise 4: the position moves by the velocity, which turns by
    omega."""
    rx, ry, vx, vy, omega = (float(v) for v in x)
    c, s = np.cos(omega), np.sin(omega)
    return np.array([rx + vx, ry + vy, c * vx - s * vy, s * vx + c * vy, omega])


def _turn_jacobian(x, *, transposed_turn=False, omega_column=1.0, cos_sign=1.0,
                   coupling=True, turned_position=False, last=1.0) -> np.ndarray:
    """F(x) in closed form (the tests compare it with bf.ekf.numerical_jacobian(f_turn, x)),
    or a mistake's variant."""
    vx, vy, omega = float(x[2]), float(x[3]), float(x[4])
    c, s = np.cos(omega), np.sin(omega)
    F = np.eye(5)
    turn = np.array([[c, -s], [s, c]])
    # d(turned velocity) / d omega: d cos = -sin, d sin = cos
    d_omega = np.array([-cos_sign * s * vx - c * vy, c * vx - cos_sign * s * vy])
    F[2:4, 2:4] = turn.T if transposed_turn else turn
    F[2:4, 4] = omega_column * d_omega
    if coupling:
        F[0, 2] = F[1, 3] = 1.0            # r_{t+1} = r_t + v_t
    if turned_position:                    # r_{t+1} = r_t + (turned v_t): another model
        F[0:2, 2:4] = turn
        F[0:2, 4] = d_omega
    F[4, 4] = last                         # omega_{t+1} = omega_t
    return F


def _turn_cases() -> list[tuple]:
    rng = np.random.default_rng(TURN_SEED)
    states = [np.array(x) for x in TURN_STATES]
    for _ in range(2):
        states.append(np.round(np.concatenate([rng.uniform(-20, 20, 2), rng.uniform(-2, 2, 2),
                                               rng.uniform(-np.pi, np.pi, 1)]), 3))
    return [(x,) for x in states]


_TURN_MISTAKES = [
    (lambda x: _turn_jacobian(x).T,
     "F is transposed: row i holds the derivatives of the i-th component of f(x) (the next "
     "state), column j the derivatives by the j-th component of x."),
    (lambda x: _turn_jacobian(x, omega_column=0.0),
     "the omega column is zero: omega is a state component, and the turned velocity depends on "
     "it (differentiate cos(omega) v_x - sin(omega) v_y by omega)."),
    (lambda x: _turn_jacobian(x, omega_column=-1.0),
     "the omega column has the wrong sign: d/d omega of cos(omega) v_x - sin(omega) v_y is "
     "-sin(omega) v_x - cos(omega) v_y."),
    (lambda x: _turn_jacobian(x, cos_sign=-1.0),
     "the derivative of cos has the wrong sign in the omega column: d cos(omega) / d omega = "
     "-sin(omega) (and d sin(omega) / d omega = +cos(omega))."),
    (lambda x: _turn_jacobian(x, transposed_turn=True),
     "the velocity block is the transposed rotation, a clockwise turn: v_x(t+1) = "
     "cos(omega) v_x - sin(omega) v_y, so d v_x(t+1) / d v_y = -sin(omega)."),
    (lambda x: _turn_jacobian(x, coupling=False),
     "the position rows miss the velocities: r_x(t+1) = r_x + v_x, so d r_x(t+1) / d v_x = 1."),
    (lambda x: _turn_jacobian(x, turned_position=True),
     "you move the position by the turned velocity; in this model the position moves by v_t, "
     "before the turn: r_x(t+1) = r_x + v_x."),
    (lambda x: _turn_jacobian(x, last=0.0),
     "the last row is zero: omega(t+1) = omega(t), so d omega(t+1) / d omega = 1."),
    (lambda x: _turn_jacobian(x)[:4, :4],
     "F must be 5 x 5: the state has five components [r_x, r_y, v_x, v_y, omega], and f has "
     "five outputs."),
]


def _turn_entry(index: tuple) -> str:
    i, j = index
    return f"d {_TURN[i]}(t+1) / d {_TURN[j]}"


def _turn_hint(exc, k, args) -> str:
    if isinstance(exc, (IndexError, ValueError)):
        return (" Hint: x is a NumPy array of shape (5,), [r_x, r_y, v_x, v_y, omega]; return "
                "shape (5, 5).")
    return ""


def exercise_4(turn_jacobian) -> Feedback:
    """Check ``turn_jacobian(x)``, the Jacobian (5, 5) of :func:`f_turn`, at seven states.

    The states: ``TURN_STATES`` (a slow turn, a quarter turn, a right turn, omega = 0, a
    vehicle at rest) and two seeded random ones; the reference is the closed form (tested
    against ``bf.ekf.numerical_jacobian(f_turn, x)``). Recognised mistakes: F transposed,
    the omega column zero or negated, the sign of d cos / d omega, the transposed rotation,
    the position rows without the velocities or moved by the turned velocity, the last row
    zero, a 4 x 4 matrix.
    """
    return _by_hand(turn_jacobian, "turn_jacobian", _function_feedback(
        turn_jacobian, "turn_jacobian", ("x",), _turn_cases(), _turn_jacobian, _TURN_MISTAKES,
        exception_hint=_turn_hint, rtol=1e-6, atol=1e-9, entry_name=_turn_entry),
        _turn_cases(), _turn_jacobian)


# ---------------------------------------------------------------------------
# Exercise 5: the wrapped innovation (filterpy's residual)
# ---------------------------------------------------------------------------

def _innovation_cases() -> list[tuple]:
    rng = np.random.default_rng(INNOVATION_SEED)
    cases = [(np.array(y), np.array(p)) for y, p in INNOVATION_CASES]
    for _ in range(2):
        cases.append((np.round([rng.uniform(1, 20), rng.uniform(-np.pi, np.pi)], 3),
                      np.round([rng.uniform(1, 20), rng.uniform(-np.pi, np.pi)], 3)))
    return cases


def _plain(y, p):
    return np.asarray(y, float) - np.asarray(p, float)


def _with_bearing(d, bearing):
    d = np.array(d, dtype=float)
    d[1] = bearing
    return d


_INNOVATION_MISTAKES = [
    (lambda y, p: models.range_bearing_residual(p, y),
     "the innovation has the wrong sign: it is the measurement minus its prediction, "
     "y - y_pred."),
    (lambda y, p: _plain(y, p),
     "the bearing difference is not wrapped: the two bearings lie on both sides of the +-pi "
     "cut, so their plain difference is almost 2 pi; add the multiple of 2 pi that brings it "
     "into (-pi, pi]."),
    (lambda y, p: _with_bearing(_plain(y, p), np.mod(_plain(y, p)[1], 2 * np.pi)),
     "the bearing difference is wrapped into [0, 2 pi); a turn to the right must stay "
     "negative: wrap into (-pi, pi]."),
    (lambda y, p: models.wrap_angle(_plain(y, p)),
     "you wrapped the range difference too; only the bearing is an angle (a range difference "
     "of 4 m is 4 m)."),
    (lambda y, p: models.wrap_angle(_plain(y, p))[1],
     "return both components, [range difference, wrapped bearing difference], shape (2,)."),
    (lambda y, p: _plain(y, p)[1],
     "return both components, [range difference, wrapped bearing difference], shape (2,)."),
]


def exercise_5(wrapped_innovation) -> Feedback:
    """Check ``wrapped_innovation(y, y_pred)`` against ``bf.models.range_bearing_residual``.

    Eight (y, y_pred) pairs: ``INNOVATION_CASES`` (no wrap and a range change above pi,
    bearings across the cut both ways, a noisy bearing above pi, equal bearings, a
    difference of exactly pi) and two seeded random ones. Recognised mistakes: the wrong
    sign, no wrap, a wrap on one side of the cut only, a wrap into [0, 2 pi), the range
    wrapped too, the bearing alone. At a difference of exactly pi, -pi is accepted with a
    remark (the same direction; the chapter's interval (-pi, pi] writes it pi).
    """
    what = "wrapped_innovation"
    if wrapped_innovation is None or wrapped_innovation is Ellipsis:
        return _not_attempted(what)
    if not callable(wrapped_innovation):
        return _wrong(f"{what} must be a function (def ...), got "
                      f"{type(wrapped_innovation).__name__}.")
    cases = _innovation_cases()
    wrapped = {"above": False, "below": False}   # the sides of the cut already wrapped right
    remark = ""
    for k, args in enumerate(cases):
        where = f"test input {k + 1} ({_describe(('y', 'y_pred'), args)})"
        out, failed = _run_case(wrapped_innovation, what, where, args)
        if failed is not None:
            return failed
        ref = models.range_bearing_residual(*args)
        d = _plain(*args)
        a, bad = _as_numbers(out, "the output")
        if bad is None and a.shape == (2,):
            if k == EXACTLY_PI and np.allclose(a, [ref[0], -np.pi]):
                remark = (f" (On test input {k + 1}, a difference of exactly pi, you return -pi: "
                          f"the same direction, though the chapter's interval (-pi, pi] writes "
                          f"it pi.)")
                continue
            side, other = ("above", "below") if d[1] > np.pi else ("below", "above")
            if abs(d[1]) > np.pi and np.allclose(a, d) and wrapped[other]:
                return _wrong(f"{what}, {where}: you wrap a bearing difference {other} "
                              f"{'-pi' if other == 'below' else 'pi'} but not this one, {side} "
                              f"{'pi' if side == 'above' else '-pi'}; wrap both ways.")
        found = [(_try(wrong, *args), f"{what}, {where}: {message}")
                 for wrong, message in _INNOVATION_MISTAKES]
        feedback = _array_feedback(out, ref, f"the output for {where}", found,
                                   entry_name=lambda i: ("the range difference",
                                                         "the bearing difference")[i[-1]])
        if feedback.status != CORRECT:
            return feedback
        if abs(d[1]) > np.pi:
            wrapped["above" if d[1] > np.pi else "below"] = True
    return Feedback(CORRECT, f"{what} agrees with the library on all {len(cases)} test inputs."
                             f"{remark}")


from . import register as _register  # noqa: E402

_register(globals())
