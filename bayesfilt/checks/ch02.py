r"""Checks of the exercises of chapter 02, the Kalman filter derived.

One function per exercise of ``notebooks/02_kalman_derivation.ipynb``; each
returns a :class:`bayesfilt.checks.Feedback` and is the last line of the
exercise's check cell::

    import bayesfilt as bf
    bf.checks.ch02.exercise_1(excess_1)            # P+(K) - P+(K*), the Joseph identity
    bf.checks.ch02.exercise_2(kalman_gain)         # K = P C^T S^{-1} as a function
    bf.checks.ch02.exercise_3(info_3)              # the posterior precision matrix
    bf.checks.ch02.exercise_4(agree_4, meaning_4)  # uniform process noise on the grid
    bf.checks.ch02.exercise_5(correlated_gain)     # the gain when cov(w_t, v_{t+1}) = D

The inputs of the statements are the constants of this module (``P_EX``,
``C_EX``, ...), read-only; the references are computed from them by the
library (``bf.kalman.update``, ``bf.gaussian.condition``, ``bf.bayes``) and
never shown. Besides the generic diagnoses of :mod:`bayesfilt.checks` (shape,
sign, transpose, factor), each check recognises the mistakes a student is
likely to make in *this* exercise: the gain computed with S = C P C^T (R
forgotten), a transposed gain, P C^T S without the inverse, ``P - KCP`` used
for a suboptimal gain, a covariance given for a precision, the cross terms of
correlated noises forgotten on one side, ...
"""

from __future__ import annotations

import copy
import functools
import numbers
from typing import Callable, Sequence

import numpy as np

from . import (CORRECT, INCORRECT, NOT_ATTEMPTED, Feedback, _as_numbers, _not_attempted,
               _wrong, compare_array, compare_choice, _frozen, _matches, _combine, _not_written)
from .. import bayes, gaussian, kalman, models

__all__ = ["exercise_1", "exercise_2", "exercise_3", "exercise_4", "exercise_5"]


# ---------------------------------------------------------------------------
# The inputs of the statements (the same numbers are in the notebook)
# ---------------------------------------------------------------------------

#: Exercises 1-3 and 5: a predicted covariance close to P_{11|10} of sections 4-7 (m^2, m^2/step,
#: (m/step)^2), the position sensor C and its noise variance R (m^2) of section 1.
P_EX = _frozen([[1.2, 0.45], [0.45, 0.34]])
C_EX = _frozen([[1.0, 0.0]])
R_EX = _frozen([[1.0]])
#: Exercise 1: the suboptimal gain.
K_1 = _frozen([[0.5], [0.1]])
#: Exercise 3: a better sensor, R = 0.25 m^2.
R_3 = _frozen([[0.25]])
#: Exercise 5: the noise gain of section 1 (the force acts on the velocity) and cov(w_t, v_{t+1}).
G_EX = _frozen([[0.0], [1.0]])
D_5 = _frozen([[0.2]])

#: Exercise 4: section 7's 1-D model, its 10 measurements (seed 3) and grid; the uniform noise
#: on [-a, a] with a = sqrt(1.5) has the variance a^2 / 3 = 0.5 of the Gaussian one.
MODEL_1D = dict(A=[[0.9]], C=[[0.5]], Q=[[0.5]], R=[[0.4]], m0=[1.0], P0=[[2.0]])
SEED_1D, STEPS_1D = 3, 10
GRID_1D = _frozen(np.linspace(-15.0, 15.0, 2001))
HALF_WIDTH_4 = float(np.sqrt(1.5))
AGREE_TOL_4 = 1e-9
OPTIONS_4 = ("conditional mean", "best linear estimate", "neither")


# ---------------------------------------------------------------------------
# Diagnoses shared by the checks
# ---------------------------------------------------------------------------

def _try(fn: Callable, *args):
    """fn(*args) as a float array, or None if it cannot be computed (a singular matrix ...)."""
    try:
        with np.errstate(all="ignore"):
            out = np.asarray(fn(*args), dtype=float)
    except Exception:  # noqa: BLE001 - a mistake that cannot be formed here is simply not it
        return None
    return out if np.all(np.isfinite(out)) else None


def _array_feedback(answer, expected, what: str, mistakes: Sequence[tuple], rtol: float = 1e-6,
                    atol: float = 1e-9) -> Feedback:
    """compare_array, but a recognised mistake gets its own message.

    ``mistakes`` holds ``(wrong, message)`` pairs, tried in order when the answer is not
    correct: ``wrong`` is the array that mistake produces (None if it cannot be formed),
    or a predicate on the answer (a float array).
    """
    # an answer of huge numbers must not make the generic diagnoses warn (a factor a / e)
    with np.errstate(all="ignore"):
        feedback = compare_array(answer, expected, what, rtol=rtol, atol=atol)
    if feedback.status != INCORRECT:
        return feedback
    a, bad = _as_numbers(answer, what)
    if bad is not None:
        return feedback
    for wrong, message in mistakes:
        hit = wrong(a) if callable(wrong) else _matches(a, wrong, rtol, atol)
        if hit:
            return _wrong(message)
    return feedback


def _describe(names: Sequence[str], args: tuple) -> str:
    """'P = [[1.2, 0.45], [0.45, 0.34]], C = ...' on one line; a large array by its shape."""
    parts = []
    for name, a in zip(names, args):
        if a.size <= 6:
            text = np.array2string(a, precision=3, separator=", ", suppress_small=True)
            parts.append(f"{name} = {' '.join(text.split())}")
        else:
            parts.append(f"{name} of shape {a.shape}")
    return ", ".join(parts)


def _failure(exc: Exception, args: tuple, exception_hint: Callable) -> str:
    """'ValueError: ...' and a hint; even an exception that cannot print itself is reported."""
    try:
        return f"{type(exc).__name__}: {exc}{exception_hint(exc, args)}"
    except Exception:  # noqa: BLE001 - a check never raises
        return type(exc).__name__


def _function_feedback(fun, what: str, names: Sequence[str], cases: Sequence[tuple],
                       reference: Callable, mistakes: Sequence[tuple], exception_hint: Callable,
                       rtol: float = 1e-6, atol: float = 1e-9) -> Feedback:
    """Run a student's function on the cases and diagnose the first one it gets wrong.

    Like :func:`bayesfilt.checks.compare_function` (deep-copied inputs, NotImplementedError
    = not attempted, a failure reported with the input that caused it), with
    ``names`` naming the arguments in the messages, ``mistakes`` = ``(wrong_function,
    message)`` pairs evaluated on the failing case (the message is prefixed by the function's
    name and the test input), and ``exception_hint(exc, args)`` adding a hint to a reported
    failure.
    """
    if fun is None or fun is Ellipsis:
        return _not_attempted(what)
    if not callable(fun):
        return _wrong(f"{what} must be a function (def ...), got {type(fun).__name__}.")
    for k, args in enumerate(cases):
        where = f"test input {k + 1} ({_describe(names, args)})"
        try:
            out = fun(*copy.deepcopy(args))
        except NotImplementedError:
            return Feedback(NOT_ATTEMPTED, f"{what} still raises NotImplementedError; write its "
                                           f"body in the cell above and run it, then run this "
                                           f"check again.")
        except Exception as exc:  # noqa: BLE001 - any failure is feedback, not a crash
            return _wrong(f"{what} fails on {where}: {_failure(exc, args, exception_hint)}")
        if out is None:
            return _wrong(f"{what} returned None on {where}; did you forget `return`?")
        expected = reference(*args)
        found = [(_try(wrong, *args), f"{what}, {where}: {message}") for wrong, message in mistakes]
        feedback = _array_feedback(out, expected, f"the output for {where}", found, rtol, atol)
        if feedback.status != CORRECT:
            return feedback
    return Feedback(CORRECT, f"{what} agrees with the library on all {len(cases)} test inputs.")


def _posterior(P, C, R) -> kalman.Update:
    """The library's measurement update of a prediction with covariance P (mean and y zero)."""
    n, m = np.shape(P)[0], np.shape(C)[0]
    return kalman.update(np.zeros(n), P, np.zeros(m), C, R)


def _joseph(P, C, R, K):
    IKC = np.eye(P.shape[0]) - K @ C
    # (I - K C) P (I - K C)^T + K R K^T
    return IKC @ P @ IKC.T + K @ R @ K.T


def _gain(P, C, R, S=None):
    # K = P C^T S^{-1}, S = C P C^T + R unless given
    S = C @ P @ C.T + R if S is None else S
    return np.linalg.solve(S, C @ P).T


# ---------------------------------------------------------------------------
# Exercise 1: the excess covariance of a suboptimal gain (the Joseph identity)
# ---------------------------------------------------------------------------

def exercise_1(excess) -> Feedback:
    r"""Check ``excess_1`` = :math:`P^+(K) - P^+(K^*)` for the gain ``K_1`` (shape (2, 2)).

    With ``P_EX``, ``C_EX``, ``R_EX``; :math:`P^+(K)` is the Joseph form and
    :math:`P^+(K^*)` the library's posterior covariance. Recognised mistakes:
    ``P - KCP`` for :math:`P^+(K)`, the Joseph form without :math:`KRK^T`,
    :math:`S` without :math:`R`, :math:`P^+(K)` itself, the opposite
    difference, and a single number (an inner instead of an outer product).
    """
    P, C, R, K = P_EX, C_EX, R_EX, K_1
    what = "excess_1"
    best = _posterior(P, C, R).cov
    expected = _joseph(P, C, R, K) - best
    IKC = np.eye(2) - K @ C
    CPCt = C @ P @ C.T
    mistakes = [
        (lambda a: a.size == 1,
         "excess_1 is a single number, but P+(K) - P+(K*) is a 2 x 2 matrix: K - K* is a "
         "column (2 x 1), so (K - K*) S (K - K*)^T is an outer product (column times row)."),
        (-expected,
         "excess_1 has the wrong sign: the exercise asks for P+(K) - P+(K*), the uncertainty "
         "that the suboptimal gain adds, which is positive semi-definite."),
        (P - K @ C @ P - best,
         "for the gain K you used P - KCP, which is the posterior covariance only at the "
         "optimal gain K*; for any other gain the covariance is the Joseph form (section 8)."),
        (IKC @ P @ IKC.T - best,
         "your Joseph form misses the term K R K^T, the sensor noise that the gain lets into "
         "the estimate."),
        (_joseph(P, C, R, K),
         "this is P+(K) itself; subtract the posterior covariance at the optimal gain, P+(K*)."),
        (_try(lambda: (K - _gain(P, C, R, CPCt)) @ CPCt @ (K - _gain(P, C, R, CPCt)).T),
         "S is C P C^T + R: your result is computed with S = C P C^T, R left out."),
        (_try(lambda: (K - _gain(P, C, R)) @ CPCt @ (K - _gain(P, C, R)).T),
         "the middle factor is S = C P C^T + R: you left R out of it."),
        (_try(lambda: (K - _gain(P, C, R, CPCt)) @ (CPCt + R) @ (K - _gain(P, C, R, CPCt)).T),
         "your K* is computed with S = C P C^T; the optimal gain is K* = P C^T S^{-1} with "
         "S = C P C^T + R."),
    ]
    return _array_feedback(excess, expected, what, mistakes)


# ---------------------------------------------------------------------------
# Exercise 2: the Kalman gain as a function
# ---------------------------------------------------------------------------

def _random_covariance(rng: np.random.Generator, n: int) -> np.ndarray:
    M = rng.normal(size=(n, n))
    return np.round(M @ M.T / n + 0.2 * np.eye(n), 3)


def _gain_cases() -> list[tuple]:
    rng = np.random.default_rng(20202)
    cases = [(P_EX, C_EX, R_EX),                                       # the chapter's example
             (np.array([[4.0]]), np.array([[2.0]]), np.array([[0.5]]))]   # a scalar state
    for n, m in ((2, 2), (3, 2)):                                      # two measurement components
        cases.append((_random_covariance(rng, n), np.round(rng.normal(size=(m, n)), 3),
                      _random_covariance(rng, m)))
    cases.append((np.zeros((2, 2)), C_EX, R_EX))                       # a state known exactly
    return [tuple(np.array(a) for a in case) for case in cases]


def _gain_exception_hint(exc: Exception, args: tuple) -> str:
    text = str(exc)
    if "broadcast" in text:
        return (" Hint: with several measurement components S is an m x m matrix; use its "
                "inverse (np.linalg.inv or np.linalg.solve), not a division by it.")
    if isinstance(exc, np.linalg.LinAlgError) and not np.any(args[0]):
        return (" Hint: here P = 0 (a state known exactly), which is singular; the gain only "
                "needs the inverse of S = C P C^T + R, which is R here.")
    if "matmul" in text or "align" in text or "dimension" in text:
        return (" Hint: check the shapes: P (n, n), C (m, n), R (m, m), S (m, m), "
                "P C^T (n, m) and the gain (n, m).")
    return ""


_GAIN_MISTAKES = [
    (lambda P, C, R: _gain(P, C, R).T,
     "the gain is transposed: you return S^{-1} C P, shape (m, n), but K = P C^T S^{-1} has one "
     "row per state component and one column per measurement component, shape (n, m)."),
    (lambda P, C, R: _gain(P, C, R, C @ P @ C.T),
     "S is computed without R: the innovation covariance is S = C P C^T + R, the predicted "
     "uncertainty of the measurement plus the sensor noise (without R the filter trusts the "
     "sensor as if it were perfect)."),
    (lambda P, C, R: _gain(P, C, R, C @ P @ C.T - R),
     "S is computed as C P C^T - R: the sensor noise adds uncertainty to the measurement, "
     "S = C P C^T + R (a minus sign in S, not a constant factor)."),
    (lambda P, C, R: P @ C.T @ (C @ P @ C.T + R),
     "you multiply P C^T by S instead of by its inverse: K = P C^T S^{-1}."),
    (lambda P, C, R: _gain(P, C, R, R),
     "you use R alone as S; the innovation covariance S = C P C^T + R also holds the predicted "
     "uncertainty C P C^T of the measurement."),
    (lambda P, C, R: P @ C.T / (C @ P @ C.T + R),
     "you divide P C^T by S entry by entry; with m > 1 measurement components S^{-1} is the "
     "inverse of a matrix (np.linalg.inv or np.linalg.solve)."),
    (lambda P, C, R: np.linalg.solve(C @ P @ C.T + R, P @ C.T),
     "S^{-1} multiplies P C^T from the left; in K = P C^T S^{-1} it is on the right (the two "
     "differ once n = m > 1)."),
]


def exercise_2(kalman_gain) -> Feedback:
    """Check the function ``kalman_gain(P, C, R)`` against ``bf.kalman.update(...).gain``.

    Five test inputs: the chapter's example, a scalar state, two seeded random
    models with two measurement components (n = 2 and n = 3), and P = 0.
    Recognised mistakes: a transposed gain, S without R, P C^T S (no inverse),
    S = R, an entry-by-entry division by S, S^{-1} on the left; a failure gets a
    hint (a division that does not broadcast, an inverse of P = 0, shapes).
    """
    return _function_feedback(kalman_gain, "kalman_gain", ("P", "C", "R"), _gain_cases(),
                              lambda P, C, R: _posterior(P, C, R).gain,
                              _GAIN_MISTAKES, _gain_exception_hint)


# ---------------------------------------------------------------------------
# Exercise 3: the posterior precision matrix
# ---------------------------------------------------------------------------

def exercise_3(info) -> Feedback:
    r"""Check ``info_3``, the posterior precision :math:`P_{t+1|t+1}^{-1}` (shape (2, 2)).

    For ``P_EX``, ``C_EX`` and ``R_3``; the reference is the inverse of the
    library's posterior covariance. Recognised mistakes: the covariance instead
    of the precision, the measurement's precision :math:`C^TR^{-1}C` or the
    prior's :math:`P^{-1}` alone, :math:`P` added instead of :math:`P^{-1}`,
    :math:`R` not inverted, a precision subtracted.
    """
    P, C, R = P_EX, C_EX, R_3
    post_cov = _posterior(P, C, R).cov
    expected = np.linalg.inv(post_cov)
    P_inv, R_inv = np.linalg.inv(P), np.linalg.inv(R)
    meas = C.T @ R_inv @ C
    mistakes = [
        (post_cov,
         "this is the posterior covariance P_{t+1|t+1}; the exercise asks for its inverse, the "
         "posterior precision matrix."),
        (meas,
         "this is the measurement's precision C^T R^{-1} C alone (a singular matrix: one position "
         "measurement says nothing about the velocity); add the precision of the prediction."),
        (P_inv,
         "this is the precision of the prediction, P^{-1}, alone; the measurement adds to it."),
        (P + meas,
         "you added the covariance P; precisions add, so use the prediction's precision P^{-1}."),
        (P_inv + C.T @ R @ C,
         "R is not inverted: the measurement contributes C^T R^{-1} C (a precise sensor, small R, "
         "adds much precision)."),
        (P_inv - meas,
         "a measurement adds precision, it cannot remove it: check the sign of C^T R^{-1} C."),
    ]
    return _array_feedback(info, expected, "info_3", mistakes)


# ---------------------------------------------------------------------------
# Exercise 4: a uniform process noise on section 7's grid
# ---------------------------------------------------------------------------

@functools.lru_cache(maxsize=1)
def _uniform_noise_gaps() -> tuple[float, ...]:
    """|grid posterior mean - Kalman mean| at each of the 10 steps, w_t uniform on [-a, a]."""
    model = models.LinearGaussian(**MODEL_1D)
    ys = models.simulate(model, STEPS_1D, np.random.default_rng(SEED_1D)).ys
    kf = kalman.kalman_filter(model, ys)
    return tuple(float(g) for g in np.abs(_uniform_grid_means(HALF_WIDTH_4) - kf.means[:, 0]))


@functools.lru_cache(maxsize=4)
def _uniform_grid_means(a: float) -> np.ndarray:
    """Section 7's grid filter with w_t uniform on [-a, a]: the 10 posterior means."""
    model = models.LinearGaussian(**MODEL_1D)
    ys = models.simulate(model, STEPS_1D, np.random.default_rng(SEED_1D)).ys
    A, C, R = model.A[0, 0], model.C[0, 0], model.R[0, 0]
    grid = GRID_1D

    def normal_pdf(x, mean, var):
        return np.exp(-0.5 * (x - mean) ** 2 / var) / np.sqrt(2 * np.pi * var)

    # p(x_next | x_prev) = 1/(2a) on |x_next - A x_prev| <= a: the uniform noise
    transition = bayes.grid_transition(
        grid, lambda x_next, x_prev: np.where(np.abs(x_next - A * x_prev) <= a, 0.5 / a, 0.0))
    likelihoods = np.array([bayes.grid_likelihood(grid, y, lambda y, x: normal_pdf(y, C * x, R))
                            for y in ys[:, 0]])
    prior_0 = normal_pdf(grid, model.m0[0], model.P0[0, 0])
    result = bayes.bayes_filter(prior_0 / prior_0.sum(), transition, likelihoods)
    return _frozen(result.posteriors @ grid)


def _grid_means_feedback(fun) -> Feedback:
    what = "grid_means_uniform"
    if fun is None or fun is Ellipsis:
        return _not_attempted(what)
    if not callable(fun):
        return _wrong(f"{what} must be a function (def ...), got {type(fun).__name__}.")
    for k, a in enumerate((HALF_WIDTH_4, 1.0)):
        try:
            out = fun(a)
        except NotImplementedError:
            return _not_written(what)
        except Exception as exc:  # noqa: BLE001 - feedback, not a crash
            return _wrong(f"{what} fails on test input {k + 1} (a = {a:.4g}): "
                          f"{type(exc).__name__}: {exc}")
        if out is None:
            return _wrong(f"{what} returned None on test input {k + 1} (a = {a:.4g}); did you "
                          f"forget `return`?")
        fb = compare_array(out, _uniform_grid_means(a), f"the output for a = {a:.4g}",
                           rtol=1e-6, atol=1e-9)
        if fb.status != CORRECT:
            return _wrong(f"{what}: {fb.message} (the 10 posterior means, m, posteriors @ grid, of "
                          f"bayes_filter(prior_0 / prior_0.sum(), transition, likelihoods) with "
                          f"the density 1/(2a) on |x_next - 0.9 x_prev| <= a.)")
    return Feedback(CORRECT, f"{what} is right.")


def _step_feedback(agree) -> Feedback:
    what = "agree_4"
    if agree is None or agree is Ellipsis:
        return _not_attempted(what)
    if isinstance(agree, np.ndarray) and agree.size == 1:
        agree = agree.item()
    if isinstance(agree, (bool, np.bool_)) or not isinstance(agree, numbers.Real):
        return _wrong(f"{what} must be a single time step, an int such as 3 (got "
                      f"{type(agree).__name__}).")
    if not np.isfinite(agree) or agree != round(agree):
        return _wrong(f"{what} must be a whole number, a time step t = 0, ..., {STEPS_1D - 1}.")
    t = int(round(agree))
    if not 0 <= t < STEPS_1D:
        return _wrong(f"{what} = {t} is not one of the steps t = 0, ..., {STEPS_1D - 1}.")
    gaps = _uniform_noise_gaps()
    agreeing = [k for k, g in enumerate(gaps) if g < AGREE_TOL_4]
    if len(agreeing) == 1 and t == agreeing[0]:
        return Feedback(CORRECT, f"{what} is right.")
    message = (f"at t = {t} the grid posterior mean differs from the Kalman filter's by "
               f"{gaps[t]:.1e} m, far more than {AGREE_TOL_4:.0e}.")
    if t == 1:
        message += (" Did you compare the predictions (grid_res.priors) rather than the "
                    "posteriors, or count the steps from 1? Steps are numbered from t = 0, "
                    "y_0 measuring x_0.")
    else:
        message += " Print |grid mean - Kalman mean| for each of the 10 steps and look again."
    return _wrong(f"{what}: {message}")


_MEANING_SYNONYMS = {
    "best linear estimator": "best linear estimate", "best linear": "best linear estimate",
    "the best linear estimate": "best linear estimate", "blue": "best linear estimate",
    "best linear unbiased estimate": "best linear estimate",
    "best linear unbiased estimator": "best linear estimate",
    "linear mmse": "best linear estimate", "lmmse": "best linear estimate",
    "conditional mean estimate": "conditional mean", "the conditional mean": "conditional mean",
    "posterior mean": "conditional mean", "mmse": "conditional mean",
}


def _meaning_feedback(meaning) -> Feedback:
    what = "meaning_4"
    if isinstance(meaning, str):
        said = " ".join(meaning.strip().lower().replace("-", " ").split())
        meaning = _MEANING_SYNONYMS.get(said, meaning)
    feedback = compare_choice(meaning, "best linear estimate", OPTIONS_4, what)
    if feedback.status != INCORRECT or not isinstance(meaning, str):
        return feedback
    chosen = meaning.strip().lower()
    if chosen == "conditional mean":
        return _wrong("meaning_4: not the conditional mean. Under the uniform noise, "
                      "E(x_t | y_0, ..., y_t) is what the grid computes, and you have just seen the "
                      "two differ. Section 6: which estimator depends only on means and "
                      "covariances, all that the Kalman filter uses?")
    if chosen == "neither":
        return _wrong("meaning_4: section 6 names an estimator that depends only on means and "
                      "covariances, which is all that the Kalman filter uses; with the same means "
                      "and covariances, is its mean not that estimator?")
    return feedback


def exercise_4(agree, meaning, grid_means_uniform=None) -> Feedback:
    """Check ``agree_4`` (the step at which grid and Kalman posterior means agree) and ``meaning_4``.

    The reference step is computed by running section 7's grid filter with the
    uniform noise (``bf.bayes``) against ``bf.kalman.kalman_filter``; it does not
    depend on the seed (only x_0's update involves no transition). A wrong step
    is told the size of the disagreement there (t = 1 gets a hint: predictions
    compared, or steps counted from 1); the choice among ``OPTIONS_4`` gets a hint
    specific to the option chosen. ``grid_means_uniform(a)``, when given, is compared
    with the grid filter's 10 posterior means at a = sqrt(1.5) and a = 1.
    """
    if grid_means_uniform is not None:
        return _combine([("grid_means_uniform", _grid_means_feedback(grid_means_uniform)),
                         ("agree_4 and meaning_4", exercise_4.__wrapped__(agree, meaning))])
    step, choice = _step_feedback(agree), _meaning_feedback(meaning)
    parts = (("agree_4", step), ("meaning_4", choice))
    if step.status == CORRECT and choice.status == CORRECT:
        return Feedback(CORRECT, "agree_4 and meaning_4 are right.")
    if step.status == NOT_ATTEMPTED and choice.status == NOT_ATTEMPTED:
        return Feedback(NOT_ATTEMPTED, "agree_4 and meaning_4 are still None; write your answers "
                                       "in the cell above and run it, then run this check again.")
    lines = []
    for name, feedback in parts:
        if feedback.status == CORRECT:
            lines.append(f"{name} is right.")
        elif feedback.status == NOT_ATTEMPTED:
            lines.append(f"{name} is still None.")
        else:
            lines.append(feedback.message)
    status = INCORRECT if INCORRECT in (step.status, choice.status) else NOT_ATTEMPTED
    return Feedback(status, " ".join(lines))


# ---------------------------------------------------------------------------
# Exercise 5: the gain when the process and measurement noises are correlated
# ---------------------------------------------------------------------------

def _correlated_blocks(P, C, R, G, D, sign=1.0, cross_terms=2):
    """Sigma_xy and Sigma_yy given y_0..y_t when cov(w_t, v_{t+1}) = sign * D.

    ``cross_terms`` 0, 1 or "double" (instead of both) form mistakes of the check.
    """
    CGD = sign * C @ G @ D
    # Sigma_xy = P C^T + G D  (x_{t+1} and v_{t+1} are correlated through G w_t)
    Sxy = P @ C.T + sign * G @ D
    # Sigma_yy = C P C^T + C G D + (C G D)^T + R  (y = C x + v, both terms correlated)
    extra = {0: 0.0, 1: CGD, 2: CGD + CGD.T, "double": 2 * CGD}[cross_terms]
    return Sxy, C @ P @ C.T + extra + R


def _correlated_reference(P, C, R, G, D):
    """The gain Sigma_xy Sigma_yy^{-1}: column j is the shift of E(x | y) by bf.gaussian.condition
    when y moves one unit along its component j."""
    Sxy, Syy = _correlated_blocks(P, C, R, G, D)
    n, m = P.shape[0], C.shape[0]
    return np.column_stack([
        gaussian.condition(mean_x=np.zeros(n), mean_y=np.zeros(m), cov_xx=P, cov_xy=Sxy,
                           cov_yy=Syy, y=np.eye(m)[j]).mean for j in range(m)])


def _slope(blocks, solved=False):
    """Sigma_xy Sigma_yy^{-1} (or, solved=True, Sigma_xy Sigma_yy^{-T}, as solve(Syy, Sxy^T)^T
    gives it: the same for a symmetric Sigma_yy, not for the mistakes that break symmetry)."""
    Sxy, Syy = blocks
    return np.linalg.solve(Syy if solved else Syy.T, Sxy.T).T


def _correlated_case(rng: np.random.Generator, n: int, q: int, m: int) -> tuple:
    """P = P_a + G Q G^T and a joint covariance [[Q, D], [D^T, R]] of (w_t, v_{t+1}): a valid model."""
    joint = _random_covariance(rng, q + m)
    G = np.round(rng.normal(size=(n, q)), 3)
    P = _random_covariance(rng, n) + G @ joint[:q, :q] @ G.T
    return (np.round(P, 3), np.round(rng.normal(size=(m, n)), 3), joint[q:, q:], G,
            joint[:q, q:])


def _correlated_cases() -> list[tuple]:
    rng = np.random.default_rng(50505)
    cases = [(P_EX, C_EX, R_EX, G_EX, D_5),                   # the chapter's model, Q = 0.1
             _correlated_case(rng, 3, 2, 2),
             (P_EX, C_EX, R_EX, G_EX, np.zeros((1, 1))),      # D = 0: the gain of section 7
             _correlated_case(rng, 4, 1, 3)]
    return [tuple(np.array(a) for a in case) for case in cases]


def _correlated_exception_hint(exc: Exception, args: tuple) -> str:
    text = str(exc)
    if "broadcast" in text or "matmul" in text or "align" in text or "dimension" in text:
        return (" Hint: check the shapes: P (n, n), C (m, n), R (m, m), G (n, q), D (q, m); "
                "Sigma_xy is (n, m) and Sigma_yy is (m, m).")
    return ""


_CORRELATED_MISTAKES = [
    (lambda P, C, R, G, D: _correlated_reference(P, C, R, G, D).T,
     "the gain is transposed: it has one row per state component, shape (n, m)."),
    (lambda P, C, R, G, D: _gain(P, C, R),
     "this is the gain of section 7, as if D were 0: with D != 0 the sensor error v_{t+1} is "
     "correlated with x_{t+1} (through w_t), so the cross terms with v_{t+1} that vanished in "
     "section 5 do not all vanish."),
    (lambda P, C, R, G, D: _slope(_correlated_blocks(P, C, R, G, D, cross_terms=0)),
     "Sigma_xy accounts for D but Sigma_yy does not: y_{t+1} = C x_{t+1} + v_{t+1} is a sum of "
     "two correlated terms, so its covariance has cross terms too."),
    *[(lambda P, C, R, G, D, s=solved: _slope(_correlated_blocks(P, C, R, G, D, cross_terms=1), s),
       "Sigma_yy has one cross term only: the covariance of a sum a + b holds both cov(a, b) and "
       "cov(b, a) = cov(a, b)^T.") for solved in (False, True)],
    *[(lambda P, C, R, G, D, s=solved: _slope(_correlated_blocks(P, C, R, G, D,
                                                                 cross_terms="double"), s),
       "Sigma_yy holds twice the same cross term: cov(a, b) and cov(b, a) are transposes of "
       "each other, equal only when they are symmetric (e.g. for one measurement component).")
      for solved in (False, True)],
    (lambda P, C, R, G, D: _slope(_correlated_blocks(P, C, R, G, D, sign=-1.0)),
     "this is the gain for cov(w_t, v_{t+1}) = -D: check the sign of the cross terms."),
    (lambda P, C, R, G, D: _slope(_correlated_blocks(P, C, R, G, D.T)),
     "you use D^T where D belongs: D = cov(w_t, v_{t+1}) has shape (q, m), one row per "
     "component of w_t."),
]


def exercise_5(correlated_gain) -> Feedback:
    """Check ``correlated_gain(P, C, R, G, D)``, the gain when cov(w_t, v_{t+1}) = D.

    The reference conditions the corrected joint Gaussian with
    ``bf.gaussian.condition``. Four test inputs: the chapter's model with
    D = 0.2 (there C G = 0), a seeded random model (n, q, m) = (3, 2, 2), D = 0
    (the gain of section 7), and a seeded random (4, 1, 3). Recognised mistakes:
    D ignored (or, on the first input, where C G = 0, forgotten in Sigma_xy), no,
    one or twice the same cross term in Sigma_yy, the opposite sign, D^T for D,
    a transposed gain.
    """
    return _function_feedback(correlated_gain, "correlated_gain", ("P", "C", "R", "G", "D"),
                              _correlated_cases(),
                              _correlated_reference, _CORRELATED_MISTAKES,
                              _correlated_exception_hint)


from . import register as _register  # noqa: E402

_register(globals())
