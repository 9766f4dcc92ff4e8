r"""Checks of the exercises of chapter 03, the damped particle: a Kalman filter at work.

One function per exercise of ``notebooks/03_damped_particle.ipynb``; each
returns a :class:`bayesfilt.checks.Feedback` and is the last line of the
exercise's check cell::

    import bayesfilt as bf
    bf.checks.ch03.exercise_3(normalised_squared)     # Correct / Not yet: ... / Not attempted yet

======================  ===========  ==================================================
check                   kind         the student defines
======================  ===========  ==================================================
:func:`exercise_1`      experiment   ``stabilising_1`` ("yes"/"no"), ``std_1`` and
                                     ``radius_1``: the steady state without damping
:func:`exercise_2`      derivation   ``rank_2``, ``detectable_2`` ("yes"/"no") and
                                     ``var_2``: a sensor that measures x^1 only
:func:`exercise_3`      function     ``normalised_squared(diffs, covs)``: the NEES /
                                     NIS values d_t^T P_t^{-1} d_t, one per step
:func:`exercise_4`      function     ``end_of_gap_variance(length)`` and ``slope_4``:
                                     the variance at the end of a gap, its growth
:func:`exercise_5`      experiment   ``lag1_5`` (3, 2) and ``sees_5``: the whiteness
                                     test on the three other wrong noise models
======================  ===========  ==================================================

The inputs of the statements are the constants of this module; the
references are computed from them by the library (``bf.models.damped_particle``,
``bf.kalman.steady_state``, ``bf.kalman.kalman_filter``,
``bf.gaussian.squared_mahalanobis``, ``bf.gaussian.normalised_innovations``,
``bf.gaussian.autocorrelation``) and never shown. Besides the generic
diagnoses of :mod:`bayesfilt.checks` (shape, sign, transpose, factor), each
check recognises the mistakes a student is likely to make in *this*
exercise: the damped model left in place, a variance for a standard
deviation, the prediction's covariance for the filtered one, a velocity for a
position, :math:`|\lambda|^2` or the real part of a complex eigenvalue for the
spectral radius, :math:`A - KC` for :math:`A(I - KC)`, the rank of C alone, a
measured position's variance for the unmeasured one, the last step off by
one, :math:`P` for :math:`P^{-1}`, the variances alone (correlations
dropped), a square root, a division by n, one covariance for every step, a
gap filled with zeros instead of NaN, the step after the gap, a standard
deviation's slope, mixed logarithms, rows in another order, lag 0 or lag 2,
another record than the statement's, ...

A check never raises (an answer it cannot read is feedback too) and never
prints: it returns the Feedback, which the notebook shows.
"""

from __future__ import annotations

import copy
import functools
import numbers
import warnings
from typing import Callable, Sequence

import numpy as np

from .. import gaussian, kalman, models
from . import (CORRECT, INCORRECT, Feedback, _as_numbers, _not_attempted,
               _wrong, compare_array, compare_choice, compare_number, _frozen, _matches,
               _combine, _not_written)

__all__ = ["exercise_1", "exercise_2", "exercise_3", "exercise_4", "exercise_5"]


# ---------------------------------------------------------------------------
# The inputs of the statements (the same numbers are in the notebook)
# ---------------------------------------------------------------------------

#: Section 1's run: the damped particle of seed 000, T = 100 steps, seed 2024.
SECTION_1_SEED, T = 2024, 100

#: Exercise 1: the particle without damping (the velocity kept entirely); answers to 4 decimals.
DAMPING_1 = 1.0
ATOL_1 = 2e-4
YES_NO = ("yes", "no")

#: Exercise 2: a sensor of x^1 alone, with the chapter's A, G, Q, m0, P0; its variance (m^2).
C_2 = _frozen([[1.0, 0.0, 0.0, 0.0]])
R_2 = _frozen([[1.0]])
STEP_2 = T - 1                          # the last step, t = 99
RTOL_2 = 5e-4                           # 4 significant digits

#: Exercise 3: the correlated covariance and its two errors (a diagonal-only formula fails here),
#: the seed of the random inputs.
CORRELATED_3 = _frozen([[1.0, 0.95], [0.95, 1.0]])
ERRORS_3 = _frozen([[1.0, -1.0], [1.0, 1.0]])
SEED_3 = 3033

#: Exercise 4: the gap starts at t = 40 (section 8); the lengths the check tries (1: a single
#: missing step; 60: the gap reaches t = 99) and the two lengths of the slope (2 decimals). The
#: first length is 10: at length 1 a gap of zeros and the step before the gap give the same
#: (steady-state) variance, so a mistake could not be named there.
GAP_START = 40
GAP_LENGTHS = (10, 20, 1, 2, 5, 33, 60)
SLOPE_LENGTHS = (10, 20)
ATOL_SLOPE = 0.006

#: Exercise 5: section 6's long record (1000 steps, seed 5) and the three wrong models, in the
#: order of the rows of lag1_5; answers to 3 decimals. Q x10 and R x0.1 have the same Q/R, the
#: same steady-state gain, hence (after the first steps) the same normalised innovations: their
#: lag-1 values agree to 5e-4 on this record.
LONG_SEED, N_LONG = 5, 1000
MODELS_5 = (("Q ×10", dict(force_var=0.1)), ("R ×0.1", dict(meas_var=0.1)),
            ("R ×10", dict(meas_var=10.0)))
OTHER_MODELS_5 = (("the correct model", {}), ("Q ×0.1 (section 6)", dict(force_var=0.001)))
ATOL_5 = 2e-3
#: A lag-1 autocorrelation of 1000 steps varies between records by about 1 / sqrt(1000) = 0.032;
#: values within 5 such spreads of those of ys_long are "another record", not another mistake.
OTHER_RECORD_5 = 5 / np.sqrt(N_LONG)
OPTIONS_5 = ("ratio", "scale", "neither")


# ---------------------------------------------------------------------------
# Shared machinery
# ---------------------------------------------------------------------------

def _number(answer, what: str):
    """(float, None) or (None, Feedback) for an answer that must be one real number."""
    if answer is None or answer is Ellipsis:
        return None, _not_attempted(what)
    if isinstance(answer, np.ndarray) and answer.size == 1:
        answer = answer.item()
    if isinstance(answer, (bool, np.bool_)) or not isinstance(answer, numbers.Real):
        shape = f" of shape {np.shape(answer)}" if isinstance(answer, np.ndarray) else ""
        return None, _wrong(f"{what} must be a single number (a float), got "
                            f"{type(answer).__name__}{shape}.")
    try:
        value = float(answer)
    except (OverflowError, ValueError, TypeError):
        return None, _wrong(f"{what} must be a finite number of ordinary size.")
    if not np.isfinite(value):
        return None, _wrong(f"{what} is NaN or inf.")
    return value, None


def _number_feedback(answer, expected: float, what: str, mistakes: Sequence[tuple],
                     atol: float = 0.0, rtol: float = 0.0, label: str | None = None) -> Feedback:
    """compare_number, but a recognised mistake (a value and its message) gets its message,
    after ``label`` (default ``what``)."""
    value, bad = _number(answer, what)
    if bad is not None:
        return bad
    if np.isclose(value, expected, rtol=rtol, atol=atol):
        return compare_number(value, expected, what, rtol=rtol, atol=atol)
    for wrong, message in mistakes:
        if wrong is not None and np.isfinite(wrong) and np.isclose(value, wrong, rtol=rtol,
                                                                    atol=atol):
            return _wrong(f"{label or what}: {message}")
    return compare_number(value, expected, what, rtol=rtol, atol=atol)


def _choice(answer, expected: str, what: str, hint: str) -> Feedback:
    return compare_choice(answer, expected, YES_NO if expected in YES_NO else OPTIONS_5, what,
                          hint)


def _failure(exc: Exception) -> str:
    try:
        return f"{type(exc).__name__}: {exc}"
    except Exception:  # noqa: BLE001 - an exception that cannot print itself is still named
        return type(exc).__name__


def _run(fun, what: str, where: str, args: tuple, hint: Callable = lambda exc: ""):
    """(output, None), or (None, Feedback) when the function is not written, fails or returns
    None. The inputs are deep-copied, so a function that changes them spoils nothing."""
    try:
        out = fun(*copy.deepcopy(args))
    except NotImplementedError:
        return None, _not_written(what)
    except Exception as exc:  # noqa: BLE001 - any failure is feedback, not a crash
        try:
            extra = hint(exc)
        except Exception:  # noqa: BLE001 - a hint that cannot be formed is left out
            extra = ""
        return None, _wrong(f"{what} fails on {where}: {_failure(exc)}{extra}")
    if out is None:
        return None, _wrong(f"{what} returned None on {where}; did you forget `return`?")
    return out, None


def _array_feedback(answer, expected, what: str, mistakes: Sequence[tuple], rtol: float = 1e-6,
                    atol: float = 1e-9) -> Feedback:
    """compare_array, but a recognised mistake gets its own message.

    ``mistakes`` holds ``(wrong, message)`` pairs, tried in order when the answer is not
    correct: ``wrong`` is the array that mistake produces (None if it cannot be formed) or a
    predicate on the answer (a float array).
    """
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
    return feedback


def _try(fn: Callable, *args):
    """fn(*args) as a finite float array, or None if this mistake cannot be formed here."""
    try:
        out = np.asarray(fn(*copy.deepcopy(args)), dtype=float)
    except Exception:  # noqa: BLE001 - a mistake that cannot be formed is simply not it
        return None
    return out if np.all(np.isfinite(out)) else None


@functools.lru_cache(maxsize=None)
def _section_1():
    """The model and the run of section 1 (true states, measurements, the filter's result)."""
    model = models.damped_particle()
    sim = models.simulate(model, T, np.random.default_rng(SECTION_1_SEED))
    return model, sim, kalman.kalman_filter(model, sim.ys)


# ---------------------------------------------------------------------------
# Exercise 1: no damping
# ---------------------------------------------------------------------------

@functools.lru_cache(maxsize=None)
def _undamped() -> dict:
    """The steady state with and without damping, and the numbers of the mistakes."""
    out = {}
    for label, damping in (("undamped", DAMPING_1), ("damped", 0.98)):
        model = models.damped_particle(damping=damping)
        ss = kalman.steady_state(model)
        x1, v1 = model.index_of("x1", "x1_dot")
        pos = model.index_of(*model.position_names)
        # Phi = A (I - K C), the error dynamics of the steady-state filter
        eig = np.linalg.eigvals(model.A @ (np.eye(4) - ss.gain @ model.C))
        out[label] = dict(
            std=float(np.sqrt(ss.cov[x1, x1])), var=float(ss.cov[x1, x1]),
            pred_std=float(np.sqrt(ss.pred_cov[x1, x1])), vel_std=float(np.sqrt(ss.cov[v1, v1])),
            both_axes=float(np.sqrt(np.trace(ss.cov[np.ix_(pos, pos)]))),
            radius=float(np.abs(eig).max()), real=float(np.abs(eig.real).max()),
            a_minus_kc=float(np.abs(np.linalg.eigvals(model.A - ss.gain @ model.C)).max()))
    return out


def exercise_1(stabilising, std, radius) -> Feedback:
    r"""Check ``stabilising_1``, ``std_1`` and ``radius_1`` for ``damped_particle(damping=1.0)``.

    ``stabilising_1``: "yes" (the DARE has a stabilising solution: the positions are
    measured and the kicks reach them through the velocities). ``std_1``: the steady-state
    standard deviation of the filtered position :math:`x^1`, ``sqrt(steady_state(model).cov)``
    at (x1, x1). ``radius_1``: the spectral radius of :math:`A(I - K_\infty C)`. Both to
    4 decimals (atol ``ATOL_1``). Recognised: the damped model of section 7, a variance, the
    prediction's standard deviation, the velocity, both axes together, one measurement's 1 m;
    :math:`|\lambda|^2`, the radius of A or of :math:`I - K_\infty C` (1), the largest real
    part, :math:`A - K_\infty C`.
    """
    ref = _undamped()
    u, d = ref["undamped"], ref["damped"]
    damped_hint = ("this is section 7's value, for the damped particle (0.98); build the model "
                   "with bf.models.damped_particle(damping=1.0).")
    std_mistakes = [
        (d["std"], damped_hint),
        (u["var"], "this is the variance (m²); the standard deviation is its square root."),
        (u["pred_std"], "this is the standard deviation of the prediction P_{t|t-1} (the DARE "
                        "solution, steady_state(...).pred_cov); the exercise asks for the "
                        "filtered one, after the measurement update (steady_state(...).cov)."),
        (d["pred_std"], "this is the prediction's standard deviation, and of the damped model: "
                        "use the filtered covariance (.cov) of damped_particle(damping=1.0)."),
        (u["vel_std"], "this is the velocity x1_dot (m/step); the position x1 is the component "
                       "model.index_of('x1')."),
        (u["both_axes"], "this takes both positions together (the trace of the position "
                         "block); give the standard deviation of one coordinate, x^1."),
        (1.0, "1 m is the standard deviation of one measurement; the filter, which averages "
              "many, does better."),
    ]
    radius_mistakes = [
        (d["radius"], damped_hint),
        (u["radius"] ** 2, "this is |lambda|_max², the rate at which P_{t|t-1} approaches P_inf "
                           "(section 12); the spectral radius is |lambda|_max itself."),
        (1.0, "1 is the spectral radius of A (and of I - K_inf C); the filter's error evolves "
              "by Phi = A (I - K_inf C), whose eigenvalues are what matters (section 7)."),
        (u["real"], "this is the largest real part; the eigenvalues of A (I - K_inf C) are "
                    "complex, so take their absolute value (np.abs), not .real."),
        (u["a_minus_kc"], "this is the spectral radius of A - K_inf C; the update comes before "
                          "the prediction, so the error moves by A (I - K_inf C) = A - A K_inf C."),
    ]
    return _combine([
        ("stabilising_1", _choice(stabilising, "yes", "stabilising_1",
                                  "try bf.kalman.steady_state on the undamped model, and read "
                                  "section 7's two conditions again: does either ask for an "
                                  "eigenvalue of A below 1?")),
        ("std_1", _number_feedback(std, u["std"], "std_1", std_mistakes, atol=ATOL_1)),
        ("radius_1", _number_feedback(radius, u["radius"], "radius_1", radius_mistakes,
                                      atol=ATOL_1)),
    ])


# ---------------------------------------------------------------------------
# Exercise 2: measure one axis only
# ---------------------------------------------------------------------------

@functools.lru_cache(maxsize=None)
def _one_axis() -> dict:
    """The one-axis filter on section 1's first measurement component, and the mistakes."""
    model, sim, res = _section_1()
    one = models.LinearGaussian(A=model.A, C=C_2, Q=model.Q, R=R_2, m0=model.m0, P0=model.P0,
                                G=model.G, state_names=model.state_names)
    out = kalman.kalman_filter(one, sim.ys[:, :1])
    x1, v1, x2, v2 = model.index_of("x1", "x1_dot", "x2", "x2_dot")
    # one more prediction, t = 100: P_{100|99} = A P_{99|99} A^T + G Q G^T
    after = kalman.predict(out.means[-1], out.covs[-1], model.A, model.Q, G=model.G).cov
    obs = np.vstack([C_2 @ np.linalg.matrix_power(model.A, k) for k in range(4)])
    return dict(var=float(out.covs[STEP_2, x2, x2]), std=float(np.sqrt(out.covs[STEP_2, x2, x2])),
                before=float(out.covs[STEP_2 - 1, x2, x2]), after=float(after[x2, x2]),
                measured=float(out.covs[STEP_2, x1, x1]), vel=float(out.covs[STEP_2, v2, v2]),
                vel1=float(out.covs[STEP_2, v1, v1]), prior=float(model.P0[x2, x2]),
                rank=int(np.linalg.matrix_rank(obs)), rank_c=int(np.linalg.matrix_rank(C_2)),
                rank_full=int(np.linalg.matrix_rank(np.vstack(
                    [model.C @ np.linalg.matrix_power(model.A, k) for k in range(4)]))))


def _rank_feedback(answer, ref: dict) -> Feedback:
    what = "rank_2"
    value, bad = _number(answer, what)
    if bad is not None:
        return bad
    if value != round(value):
        return _wrong(f"{what} must be a whole number (a rank counts independent rows), got "
                      f"{value:g}.")
    value = int(round(value))
    if value == ref["rank"]:
        return Feedback(CORRECT, f"{what} is right.")
    if value == ref["rank_full"]:
        return _wrong(f"{what}: full rank would mean that noise-free y_0, ..., y_3 determine "
                      f"the whole state, as with the chapter's two-position sensor. Write out "
                      f"the rows C A^k for C = [1, 0, 0, 0]: which columns stay zero?")
    if value == ref["rank_c"]:
        return _wrong(f"{what}: this is the rank of C alone; stack C, CA, CA², CA³ (section 7) "
                      f"and take the rank of the 4 x 4 result (np.linalg.matrix_rank).")
    if value > 4 or value < 0:
        return _wrong(f"{what}: the observability matrix is 4 x 4 here (C has one row), so its "
                      f"rank lies between 0 and 4.")
    return _wrong(f"{what} is not the rank of [C; CA; CA²; CA³]; compute it with "
                  f"np.linalg.matrix_rank.")


def exercise_2(rank, detectable, variance) -> Feedback:
    r"""Check ``rank_2``, ``detectable_2`` and ``var_2`` for the sensor C = [1, 0, 0, 0], R = 1.

    ``rank_2``: the rank of the observability matrix [C; CA; CA^2; CA^3].
    ``detectable_2``: "no" (the position :math:`x^2`, a mode with :math:`\lambda = 1`, never
    shows in y). ``var_2``: the filter's variance of :math:`x^2` at t = 99 on ``ys[:, :1]``
    of section 1 (rtol ``RTOL_2``); nothing measures :math:`x^2`, so it is the variance of
    section 11's model without measurements. Recognised: the rank of the chapter's sensor or
    of C alone; a standard deviation, t = 98 or t = 100, a measured position's variance, a
    velocity's, the prior's.
    """
    ref = _one_axis()
    var_mistakes = [
        (ref["std"], "this is the standard deviation (m); the variance is its square (m²)."),
        (ref["before"], "this is the variance at t = 98; the run has T = 100 steps, t = 0, ..., "
                        "99, so the last one is t = 99 (covs[-1])."),
        (ref["after"], "this is one prediction beyond the run, t = 100; the last step of the "
                       "run is t = 99 (covs[-1])."),
        (ref["measured"], "this is the variance of a position the sensor measures (x^1 of this "
                          "filter, or x^2 of the chapter's two-position filter); with "
                          "C = [1, 0, 0, 0] nothing measures x^2."),
        (ref["vel"], "this is the velocity x2_dot ((m/step)²); the position x^2 is the "
                     "component model.index_of('x2')."),
        (ref["vel1"], "this is x1_dot: in seed 000's order [x1, x1_dot, x2, x2_dot] column 1 is "
                      "a velocity; select x^2 by name, model.index_of('x2')."),
        (ref["prior"], "this is the prior variance P_0 of x^2; the filter's variance changes "
                       "at every prediction."),
    ]
    return _combine([
        ("rank_2", _rank_feedback(rank, ref)),
        ("detectable_2", _choice(detectable, "no", "detectable_2",
                                 "detectability asks about every mode of A with |lambda| >= 1 "
                                 "(section 7): does each of them show in y = x^1 + v? Try "
                                 "bf.kalman.steady_state on this model.")),
        ("var_2", _number_feedback(variance, ref["var"], "var_2", var_mistakes, rtol=RTOL_2)),
    ])


# ---------------------------------------------------------------------------
# Exercise 3: NEES and NIS as a function
# ---------------------------------------------------------------------------

def _random_covariances(rng: np.random.Generator, T: int, n: int) -> np.ndarray:
    M = rng.normal(size=(T, n, n))
    return np.round(M @ np.swapaxes(M, 1, 2) / n + 0.3 * np.eye(n), 3)


@functools.lru_cache(maxsize=None)
def _nees_cases() -> tuple:
    """(label, diffs, covs) of the test inputs."""
    model, sim, res = _section_1()
    rng = np.random.default_rng(SEED_3)
    cov_3 = _random_covariances(rng, 1, 3)
    cov_6 = _random_covariances(rng, 6, 3)
    cases = (
        ("section 1's errors x_t - x_t|t and covariances P_t|t, t = 0, ..., 4",
         sim.xs[:5] - res.means[:5], res.covs[:5]),
        ("section 1's innovations r_t and covariances S_t, t = 0, ..., 4",
         res.innovations[:5], res.innovation_covs[:5]),
        ("two errors, [1, -1] and [1, 1], with the covariance [[1, 0.95], [0.95, 1]]",
         ERRORS_3, np.stack([CORRELATED_3, CORRELATED_3])),
        ("a single step, T = 1, n = 3", np.round(rng.normal(size=(1, 3)), 3), cov_3),
        ("a scalar state, n = 1: errors [2, -1, 0], variances [4, 0.25, 1]",
         np.array([[2.0], [-1.0], [0.0]]), np.array([[[4.0]], [[0.25]], [[1.0]]])),
        ("six random steps, n = 3", np.round(rng.normal(size=(6, 3)), 3), cov_6),
    )
    return tuple((label, np.array(d, dtype=float), np.array(P, dtype=float))
                 for label, d, P in cases)


def _solve_each(d, P):
    # u_t = P_t^{-1} d_t, one step at a time
    return np.linalg.solve(P, d[..., None])[..., 0]


_NEES_MISTAKES = [
    (lambda d, P: np.einsum("ti,tij,tj->t", d, P, d),
     "you multiply by P_t; the statistic uses its inverse, d_t^T P_t^{-1} d_t: an error counts "
     "for less where the filter says it is uncertain."),
    (lambda d, P: np.sum(d ** 2 / np.diagonal(P, axis1=1, axis2=2), axis=1),
     "you divide by the variances only (the diagonal of P_t) and so drop the correlations "
     "between the components; use the whole matrix, d_t^T P_t^{-1} d_t."),
    (lambda d, P: np.sqrt(np.einsum("ti,ti->t", d, _solve_each(d, P))),
     "you return the square root of d_t^T P_t^{-1} d_t; NEES and NIS are the quadratic form "
     "itself, chi-square with n degrees of freedom and mean n."),
    (lambda d, P: np.einsum("ti,ti->t", d, _solve_each(d, P)) / d.shape[1],
     "you divide by the dimension n; the statistic itself is chi-square with n degrees of "
     "freedom, mean n (section 4 compares the average NEES with 4, not with 1)."),
    (lambda d, P: np.sum(d ** 2, axis=1),
     "you return the squared length d_t^T d_t, which ignores the covariance P_t; normalise "
     "by it: d_t^T P_t^{-1} d_t."),
    (lambda d, P: np.einsum("ti,ij,tj->t", d, np.linalg.inv(P[0]), d),
     "you use the first covariance for every step; each step has its own P_t: "
     "d_t^T P_t^{-1} d_t."),
    (lambda d, P: np.einsum("ti,ij,tj->t", d, np.linalg.inv(P[-1]), d),
     "you use the last covariance for every step; each step has its own P_t: "
     "d_t^T P_t^{-1} d_t."),
]


def _nees_shape_mistakes(T: int) -> list:
    return [
        (lambda a: a.size == 1 and T > 1,
         f"you return a single number for {T} steps; the function returns one value per "
         f"step, shape ({T},) (averaging them is the next step of the test, not this one)."),
        (lambda a: a.ndim >= 2 and a.shape[0] == T and a.shape[1] == T,
         f"you return an array of shape {{}} that pairs every step with every other (a matrix "
         f"product over the time axis); the statistic pairs d_t with its own P_t only: one "
         f"value per step, shape ({T},)."),
    ]


def _nees_hint(exc: Exception) -> str:
    if isinstance(exc, np.linalg.LinAlgError):
        return (" Hint: np.linalg.inv and np.linalg.solve take a stack of matrices (T, n, n) "
                "directly; for the vectors use d[..., None], shape (T, n, 1).")
    text = str(exc)
    if "matmul" in text or "align" in text or "broadcast" in text or "dimension" in text:
        return (" Hint: diffs has shape (T, n) and covs (T, n, n); compute d_t^T P_t^{-1} d_t "
                "for each t (a loop over t, or np.einsum / np.linalg.solve on the stack).")
    return ""


def exercise_3(normalised_squared) -> Feedback:
    r"""Check ``normalised_squared(diffs, covs)`` against ``bf.gaussian.squared_mahalanobis``.

    Six test inputs: section 1's first five errors with :math:`P_{t|t}` (n = 4, correlated
    position and velocity), its first five innovations with :math:`S_t` (n = 2), two errors
    with the strongly correlated ``CORRELATED_3``, one step (T = 1), a scalar state with a zero
    error, six random steps (n = 3). Recognised mistakes: P instead of its inverse, the
    variances alone, a square root, a division by n, :math:`d^Td`, one covariance for every
    step, a single number, a (T, T) array of all pairs; a failure gets a hint on the shapes.
    """
    what = "normalised_squared"
    fun = normalised_squared
    if fun is None or fun is Ellipsis:
        return _not_attempted(what)
    if not callable(fun):
        return _wrong(f"{what} must be a function (def ...), got {type(fun).__name__}.")
    cases = _nees_cases()
    for k, (label, d, P) in enumerate(cases):
        where = f"test input {k + 1} ({label})"
        out, failed = _run(fun, what, where, (d, P), _nees_hint)
        if failed is not None:
            return failed
        expected = gaussian.squared_mahalanobis(d, P)
        found = [(_try(wrong, d, P), f"{what}, {where}: {message}")
                 for wrong, message in _NEES_MISTAKES]
        a, bad = _as_numbers(out, "the output")
        shape = a.shape if bad is None else None
        found += [(predicate, f"{what}, {where}: {message.format(shape)}")
                  for predicate, message in _nees_shape_mistakes(len(d))]
        feedback = _array_feedback(out, expected, f"the output for {where}", found, rtol=1e-6,
                                   atol=1e-9)
        if feedback.status != CORRECT:
            return feedback
    return Feedback(CORRECT, f"{what} agrees with the library on all {len(cases)} test inputs.")


# ---------------------------------------------------------------------------
# Exercise 4: the length of a gap
# ---------------------------------------------------------------------------

@functools.lru_cache(maxsize=None)
def _gap_covs(length: int, start: int = GAP_START) -> np.ndarray:
    """The filtered covariances P_t|t (T, 4, 4) with the measurements at start ... start +
    length - 1 missing. They do not depend on the measured values, so zeros stand in for ys."""
    model = models.damped_particle()
    ys = np.zeros((T, 2))
    ys[start:start + length] = np.nan
    return kalman.kalman_filter(model, ys).covs


def _gap_variance(length: int, offset: int = 0, component: int = 0) -> float | None:
    """The filter's variance of one component at t = start + length - 1 + offset, or None."""
    t = GAP_START + length - 1 + offset
    if not 0 <= t < T:
        return None
    return float(_gap_covs(length)[t, component, component])


def _gap_feedback(out, length: int, what: str, where: str) -> Feedback:
    model = models.damped_particle()
    x1, v1 = model.index_of("x1", "x1_dot")
    expected = _gap_variance(length)
    a, bad = _as_numbers(out, "the output")
    if bad is None and a.shape == (4, 4) and np.isclose(a[x1, x1], expected, rtol=1e-6):
        return _wrong(f"{what}, {where}: you return the whole covariance P_t|t (4 x 4); return "
                      f"its (x1, x1) entry, a float.")
    if bad is None and a.size > 1:
        return _wrong(f"{what}, {where}: return one number, the variance of x^1 at the last "
                      f"step of the gap, not an array of shape {a.shape}.")
    steady = float(_gap_covs(0)[GAP_START + length - 1, x1, x1])
    mistakes = [
        (np.sqrt(expected), "you return the standard deviation (m); the variance is its square "
                            "(m²)."),
        (_gap_variance(length, offset=1), "this is t = 40 + length, the first step after the "
                                          "gap, whose measurement has already pulled the "
                                          "variance down; the gap's last step is "
                                          "t = 39 + length."),
        (_gap_variance(length, offset=-1), "this is t = 38 + length, one step before the end "
                                           "of the gap; its last step is t = 39 + length."),
        (_gap_variance(length + 1) if GAP_START + length < T else None,
         "this is the variance one step after the end of the gap, before its measurement: you "
         "deleted length + 1 measurements, or read pred_covs[40 + length]."),
        (_gap_variance(length, component=v1), "this is the velocity x1_dot ((m/step)²); the "
                                              "position x^1 is model.index_of('x1')."),
        (float(_gap_covs(20)[GAP_START + 19, x1, x1]) if length != 20 else None,
         "this is the value of section 8's gap of 20 steps whatever the length; delete "
         "`length` measurements, ys_cut[40:40 + length] = np.nan, and filter again."),
        (float(_gap_covs(length)[T - 1, x1, x1]) if GAP_START + length < T
         and not where.endswith(" ") else None,
         "this is the variance at the last step of the whole run, t = 99 (covs[-1]); the gap "
         "ends at t = 39 + length: read covs[39 + length, x1, x1]." + _STEADY),
        (steady if length > 0 else None,
         "the variance did not grow: the filter still updated at the steps of the gap. A "
         "missing measurement is a row of NaN (np.nan), not of zeros."),
    ]
    where = where.strip()
    return _number_feedback(out, expected, f"the output for {where}", [
        (value, message) for value, message in mistakes if value is not None], rtol=1e-6,
        label=f"{what}, {where}")


_STEADY = " "  # marks the two mistakes that give the same numbers until the gap reaches t = 99


def _gap_hint(exc: Exception) -> str:
    if isinstance(exc, IndexError):
        return (" Hint: the run has T = 100 steps, t = 0, ..., 99; the last step of the gap is "
                "t = 39 + length (t = 99 for length = 60).")
    if "partly NaN" in str(exc):
        return (" Hint: delete whole measurements: set both components to NaN, "
                "ys_cut[40:40 + length] = np.nan.")
    return ""


def _gap_function_feedback(fun) -> Feedback:
    what = "end_of_gap_variance"
    if fun is None or fun is Ellipsis:
        return _not_attempted(what)
    if not callable(fun):
        return _wrong(f"{what} must be a function (def ...), got {type(fun).__name__}.")
    for k, length in enumerate(GAP_LENGTHS):
        where = f"test input {k + 1} (length = {length})"
        out, failed = _run(fun, what, where, (length,), _gap_hint)
        if failed is not None:
            return failed
        feedback = _gap_feedback(out, length, what, where)
        if feedback.status != CORRECT:
            if feedback.message.endswith(_STEADY):
                # t = 99 and "zeros for NaN" agree until the gap reaches t = 99: ask length 60
                last, _ = _run(fun, what, where, (T - GAP_START,), _gap_hint)
                a, _ = _as_numbers(last, "") if last is not None else (None, None)
                reads_99 = (a is not None and a.size == 1 and np.isclose(
                    float(a.ravel()[0]), _gap_variance(T - GAP_START), rtol=1e-6))
                if not reads_99:
                    return _gap_feedback(out, length, what, where + " ")
            return _wrong(feedback.message.strip())
    return Feedback(CORRECT, f"{what} agrees with the library on all {len(GAP_LENGTHS)} "
                             f"lengths.")


def _slope_feedback(answer) -> Feedback:
    lo, hi = SLOPE_LENGTHS
    v_lo, v_hi = _gap_variance(lo), _gap_variance(hi)
    after_lo, after_hi = _gap_variance(lo, offset=1), _gap_variance(hi, offset=1)
    d_log_v, d_log_l = np.log(v_hi / v_lo), np.log(hi / lo)
    expected = d_log_v / d_log_l
    mistakes = [
        (expected / 2, "this is the slope of the standard deviation; the variance's slope is "
                       "twice it (log of a square)."),
        (np.log(after_hi / after_lo) / d_log_l,
         "this uses the variances at t = 40 + length, after the gap, already updated; use those "
         "at its last step, t = 39 + length (your end_of_gap_variance)."),
        ((v_hi - v_lo) / (hi - lo), "this is the slope of the variance itself; take the "
                                    "logarithm of both the variance and the length."),
        (d_log_v / (hi - lo), "you took the logarithm of the variance but not of the length: "
                              "divide by log 20 - log 10."),
        (np.log10(v_hi / v_lo) / d_log_l, "you mixed two logarithms (log10 and ln); use the "
                                          "same one for the variance and the length."),
        (d_log_v / np.log10(hi / lo), "you mixed two logarithms (ln and log10); use the same "
                                      "one for the variance and the length."),
        (1 / expected, "you divided the other way round; the slope is the change of "
                       "log(variance) per change of log(length)."),
    ]
    return _number_feedback(answer, expected, "slope_4", mistakes, atol=ATOL_SLOPE)


def exercise_4(end_of_gap_variance, slope) -> Feedback:
    """Check ``end_of_gap_variance(length)`` and ``slope_4``.

    The function must return the filter's variance of x^1 at t = 39 + length when the
    measurements at t = 40, ..., 39 + length of section 1's run are missing; it is compared
    with ``bf.kalman.kalman_filter`` for the lengths ``GAP_LENGTHS`` (1: a single missing
    step; 60: the gap reaches t = 99). ``slope_4`` is (log v(20) - log v(10)) / (log 20 -
    log 10), to 2 decimals. Recognised: a standard deviation, the step after the gap or one
    before its end, one measurement too many deleted, the velocity, section 8's fixed gap, a
    gap of zeros instead of NaN, the whole covariance; for the slope, the standard
    deviation's, the variances after the gap, no logarithm or only one, mixed bases, the
    inverse ratio.
    """
    return _combine([("end_of_gap_variance", _gap_function_feedback(end_of_gap_variance)),
                     ("slope_4", _slope_feedback(slope))])


# ---------------------------------------------------------------------------
# Exercise 5: whiteness of the other wrong models
# ---------------------------------------------------------------------------

@functools.lru_cache(maxsize=None)
def _lag_values() -> dict:
    """Lags 1 and 2 of the normalised innovations on ys_long, for every model of the exercise."""
    ys_long = models.simulate(models.damped_particle(), N_LONG,
                              np.random.default_rng(LONG_SEED)).ys
    out = {}
    for label, kw in MODELS_5 + OTHER_MODELS_5:
        res = kalman.kalman_filter(models.damped_particle(**kw), ys_long)
        z = gaussian.normalised_innovations(res.innovations, res.innovation_covs)
        out[label] = gaussian.autocorrelation(z, 5)          # (5, 2): lags 1, ..., 5
        out["raw " + label] = gaussian.autocorrelation(res.innovations, 1)[0]
    return out


def _lag_feedback(answer) -> Feedback:
    what = "lag1_5"
    values = _lag_values()
    labels = [label for label, _ in MODELS_5]
    expected = np.array([values[label][0] for label in labels])
    feedback = compare_array(answer, expected, what, rtol=0.0, atol=ATOL_5)
    if feedback.status != INCORRECT:
        return feedback
    a, bad = _as_numbers(answer, what)
    if bad is not None:
        return feedback
    if a.shape == (20, 2) or (a.ndim == 3 and a.shape[0] == 3):
        return _wrong(f"{what} must hold lag 1 only, shape (3, 2): autocorrelation(z, max_lag)"
                      f"[0] is lag 1 (row k - 1 holds lag k).")
    if a.shape == (2,) or a.shape == (3,):
        return _wrong(f"{what} must have shape (3, 2): one row per model (Q ×10, R ×0.1, "
                      f"R ×10), one column per component of z_t; got shape {a.shape}.")
    if a.shape != (3, 2):
        return feedback
    close = functools.partial(np.allclose, rtol=0.0, atol=ATOL_5)
    if close(a, 1.0):
        return _wrong(f"{what} is lag 0 (every sequence correlates perfectly with itself); "
                      f"lag 1 is the correlation of z_t with z_{{t+1}}.")
    for lag in range(2, 6):
        if close(a, np.array([values[label][lag - 1] for label in labels])):
            return _wrong(f"{what} is lag {lag}; autocorrelation(z, max_lag)[0] is lag 1 (row "
                          f"k - 1 holds lag k).")
    if close(a, np.array([values["raw " + label] for label in labels])):
        return _wrong(f"{what} is the autocorrelation of the raw innovations r_t; the test "
                      f"reads the normalised ones, z_t = bf.gaussian.normalised_innovations("
                      f"res.innovations, res.innovation_covs).")
    for order in ((0, 2, 1), (1, 0, 2), (1, 2, 0), (2, 0, 1), (2, 1, 0)):
        if close(a, expected[list(order)]):
            return _wrong(f"{what} has its rows in another order; the order is Q ×10, R ×0.1, "
                          f"R ×10 (models_5).")
    for row, label in enumerate(labels):
        if close(a[row], expected[row]):
            continue
        for other, _ in OTHER_MODELS_5 + MODELS_5:
            if other != label and close(a[row], values[other][0]):
                same_gain = {"Q ×10", "R ×0.1"} if other in ("Q ×10", "R ×0.1") else {other}
                return _wrong(f"{what}: row {row + 1} should be the filter with {label}, but "
                              f"it holds the values of {' or '.join(sorted(same_gain))}; "
                              f"check which model you filtered with (force_var / meas_var).")
    if np.all(np.abs(a - expected) < OTHER_RECORD_5) and np.all(np.sign(a) == np.sign(expected)):
        return _wrong(f"{what} is close to the right values but not equal to 3 decimals: the "
                      f"right models on another record, or another estimate of the "
                      f"correlation (np.corrcoef, your own formula)? Filter ys_long of section 6 "
                      f"(1000 steps, seed 5) and use bf.gaussian.autocorrelation(z, 1)[0].")
    return feedback


def exercise_5(lag1, sees) -> Feedback:
    """Check ``lag1_5`` (3, 2) and ``sees_5``.

    ``lag1_5``: the lag-1 autocorrelation of both components of the normalised innovations
    z_t of the filters Q ×10, R ×0.1, R ×10 on ys_long (section 6), to 3 decimals.
    ``sees_5``: "ratio": Q ×10 and R ×0.1 have the same ratio Q/R, the same steady-state gain
    and the same z_t, so the whiteness test responds to the ratio (the NIS of section 5 to
    the scale too). Recognised: lag 0, lag 2, all 20 lags, rows in another order, a row of
    another model (the correct one, Q ×0.1, or a mix-up of the three), another record.
    """
    return _combine([
        ("lag1_5", _lag_feedback(lag1)),
        ("sees_5", compare_choice(sees, "ratio", OPTIONS_5, "sees_5",
                                  "compare the rows of Q ×10 and R ×0.1, two models with the "
                                  "same Q / R, and then their NIS in section 5's table.")),
    ])


from . import register as _register  # noqa: E402

_register(globals())
