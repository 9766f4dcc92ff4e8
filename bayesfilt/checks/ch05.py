r"""Checks for the exercises of chapter 05 (sequential importance sampling and the weights).

Each function takes what the student defined in the answer cell and returns a
:class:`bayesfilt.checks.Feedback`; the check cell of the notebook calls it as
its last line::

    import bayesfilt as bf
    bf.checks.ch05.exercise_1(my_log_normalize)   # Correct / Not yet: ... / Not attempted yet

======================  ===========  ==================================================
check                   kind         the student defines
======================  ===========  ==================================================
:func:`exercise_1`      function     ``my_log_normalize(log_w)``: (log_W, log_sum) by
                                     log-sum-exp, numpy only
:func:`exercise_2`      derivation   ``answer_2``: the ESS of three weight vectors
:func:`exercise_3`      function     ``log_increment(x_prev, y)``: the optimal
                                     proposal's log increment on the 1-D model ``lg``
:func:`exercise_4`      experiment   ``answer_4``: (the R at which the bootstrap's
                                     mean ESS at t = 5 is smallest, the R at which the
                                     optimal proposal's mean ESS at t = 39 is smallest)
:func:`exercise_5`      derivation   ``answer_5``: the models whose optimal proposal
                                     differs from the transition
======================  ===========  ==================================================

The references are computed here with :mod:`bayesfilt.particle` and
:mod:`bayesfilt.models` from the numbers of the statements (the constants
below, the same as in the notebook), never stored and never shown: a message
names what differs (log-sum-exp without the shift, the weights instead of
their logs, S without Q, a variance used as a standard deviation, an
unnormalised ESS, ...), not the expected value. A check never raises: an
answer it cannot read is feedback too.
"""

from __future__ import annotations

import functools
import math
import numbers
import re
from typing import Callable

import numpy as np

from .. import models, particle
from . import (CORRECT, Feedback, _not_attempted,
               _not_written, _wrong)

__all__ = ["exercise_1", "exercise_2", "exercise_3", "exercise_4", "exercise_5"]

# --------------------------------------------------------------------------
# the numbers of the statements (as in the notebook)
# --------------------------------------------------------------------------

#: exercise 1: the log-weights of the statement; the others are the check's own test inputs
LOG_W_STATEMENT = (-1000.0, -1001.0, -1002.0, -np.inf)

#: exercise 2: (a) normalised weights, (b) unnormalised weights, (c) log-weights
ESS_NORMALISED = (0.4, 0.3, 0.2, 0.1)
ESS_UNNORMALISED = (1.0, 1.0, 2.0)
ESS_LOG_WEIGHTS = LOG_W_STATEMENT

#: the 1-D model lg of section 5 (exercises 3 and 4)
LG_A, LG_C, LG_Q, LG_R, LG_M0, LG_P0 = 0.9, 1.0, 1.0, 0.1, 0.0, 1.0

#: exercise 4: the experiment of section 8 for three measurement variances
R_VALUES = (0.01, 0.1, 1.0)
EXPERIMENT_N, EXPERIMENT_T, EXPERIMENT_RUNS = 500, 40, 10
T_BOOTSTRAP, T_OPTIMAL = 5, 39
SEED_RECORDS, SEED_FILTERS = 14, 15           # section 8's seeds; the answer does not depend on them

#: exercise 5: the three models, by letter
MODEL_LETTERS = ("a", "b", "c")

# tolerances: hand-computed answers are rounded; computed ones are not
ATOL_HAND = 2e-3                              # ESS to 3 decimals
TOL_FUNCTION = 1e-8


# --------------------------------------------------------------------------
# small helpers (feedback that never raises)
# --------------------------------------------------------------------------

# _not_attempted, _not_written and _wrong come from bayesfilt.checks; the engine
# (bayesfilt.checks.exercise) runs every exercise_N.


def _real_array(value, what: str, allow_neg_inf: bool = False):
    """(array of floats, None), or (None, Feedback) if ``value`` is not an array of real numbers."""
    if value is None:
        return None, _wrong(f"{what} is None.")
    if isinstance(value, (str, bytes, dict)) or callable(value):
        return None, _wrong(f"{what} must be numbers (a numpy array), got {type(value).__name__}.")
    try:
        a = np.asarray(value)
    except Exception:  # noqa: BLE001 - ragged lists and odd objects
        return None, _wrong(f"{what} must be a rectangular array of numbers, got "
                            f"{type(value).__name__}.")
    if a.dtype.kind not in "iuf":
        return None, _wrong(f"{what} must be made of real numbers, got {type(value).__name__} "
                            f"of dtype {a.dtype}.")
    a = a.astype(float)
    if np.isnan(a).any():
        return None, _wrong(f"{what} contains NaN.")
    if np.isposinf(a).any() or (not allow_neg_inf and np.isneginf(a).any()):
        return None, _wrong(f"{what} contains inf.")
    return a, None


def _real_number(value, what: str, allow_neg_inf: bool = False, allow_inf: bool = False):
    """(float, None), or (None, Feedback) if ``value`` is not one real number."""
    if isinstance(value, (bool, np.bool_)):
        return None, _wrong(f"{what} must be a number, got {value!r}.")
    if isinstance(value, np.ndarray) and value.size == 1 and value.dtype.kind in "iuf":
        value = value.reshape(()).item()
    if not isinstance(value, numbers.Real):
        if isinstance(value, np.ndarray):
            return None, _wrong(f"{what} must be one number, got an array of shape {value.shape}.")
        return None, _wrong(f"{what} must be one number, got {type(value).__name__}.")
    v = float(value)
    if math.isnan(v):
        return None, _wrong(f"{what} is NaN.")
    if not allow_inf and (v == math.inf or (v == -math.inf and not allow_neg_inf)):
        return None, _wrong(f"{what} is {v}.")
    return v, None


def _same(a: np.ndarray, e: np.ndarray, rtol: float = TOL_FUNCTION, atol: float = TOL_FUNCTION) -> bool:
    """Equal shapes, -inf at the same places, the finite entries close."""
    a, e = np.asarray(a, dtype=float), np.asarray(e, dtype=float)
    if a.shape != e.shape or np.isnan(a).any() or np.isnan(e).any():
        return False
    ninf_a, ninf_e = np.isneginf(a), np.isneginf(e)
    if not np.array_equal(ninf_a, ninf_e) or np.isposinf(a).any() != np.isposinf(e).any():
        return False
    fin = np.isfinite(e)
    return bool(np.allclose(a[fin], e[fin], rtol=rtol, atol=atol))


def _show(a) -> str:
    return np.array2string(np.asarray(a, dtype=float), precision=4, separator=", ")


# --------------------------------------------------------------------------
# Exercise 1 - log-sum-exp by hand (a function)
# --------------------------------------------------------------------------

def _exercise_1_cases() -> list[np.ndarray]:
    rng = np.random.default_rng(505)
    around_5000 = rng.normal(-5000.0, 20.0, size=50)
    around_5000[[7, 30]] = -np.inf
    return [
        np.array(LOG_W_STATEMENT),                     # the statement: exp underflows to 0
        np.array([0.0, 0.0, 0.0]),                     # equal weights
        np.array([800.0, 799.5, 795.0]),               # exp overflows to inf
        np.array([3.7]),                               # one particle
        around_5000,                                   # many, with two zero weights
        np.array([-2.0, 0.5, 1e-3, -np.inf, 0.25]),    # moderate, one zero weight
        np.array([0.0, -800.0, -5.0]),                 # a spread of 800: e^(l - m) underflows
    ]


def _diagnose_log_sum(s: float, lw: np.ndarray, ref: float, what: str) -> Feedback | None:
    """A specific message when log_sum is wrong in a recognisable way; None if it is right."""
    if math.isclose(s, ref, rel_tol=TOL_FUNCTION, abs_tol=TOL_FUNCTION):
        return None
    finite = lw[np.isfinite(lw)]
    m, n = float(np.max(lw)), lw.size
    if s in (-math.inf, math.inf):
        return _wrong(f"{what}: log_sum is {s}: exp(l) {'underflowed to 0' if s < 0 else 'overflowed'}"
                      f" before the log. Factor out the largest log-weight m first: "
                      f"log sum_j e^(l_j) = m + log sum_j e^(l_j - m).")
    candidates = [
        (ref - m, "log_sum is the log of the shifted sum, log sum_j e^(l_j - m): add the largest "
                  "log-weight m back (log sum_j e^(l_j) = m + log sum_j e^(l_j - m))."),
        (ref - math.log(n), "log_sum is the log of the mean weight, log((1/N) sum_j e^(l_j)); "
                            "bf.particle.log_normalize returns the log of the sum."),
        (ref - math.log(finite.size) if finite.size != n else math.nan,
         "log_sum is the log of the mean over the nonzero weights; return the log of the sum."),
        (math.exp(ref) if ref < 700 else math.nan,
         "log_sum is the sum of the weights, not its logarithm."),
        (ref / math.log(10), "log_sum uses log10; log-weights are natural logarithms (np.log)."),
        (m, "log_sum is only the largest log-weight m; add log sum_j e^(l_j - m)."),
        (float(np.sum(finite)), "log_sum is the sum of the log-weights, i.e. the log of their "
                                "product; normalising needs the log of their sum."),
    ]
    for value, message in candidates:
        if np.isfinite(value) and math.isclose(s, value, rel_tol=TOL_FUNCTION, abs_tol=TOL_FUNCTION) \
                and not math.isclose(value, ref, rel_tol=TOL_FUNCTION, abs_tol=TOL_FUNCTION):
            return _wrong(f"{what}: {message}")
    if math.isclose(s, -ref, rel_tol=TOL_FUNCTION, abs_tol=TOL_FUNCTION):
        return _wrong(f"{what}: log_sum has the wrong sign.")
    return _wrong(f"{what}: log_sum is too {'large' if s > ref else 'small'} (log sum_j e^(l_j), "
                  f"computed as m + log sum_j e^(l_j - m) with m the largest log-weight).")


def _diagnose_log_w(a: np.ndarray, lw: np.ndarray, ref: np.ndarray, log_sum: float,
                    what: str) -> Feedback | None:
    """A specific message when log_W is wrong in a recognisable way; None if it is right."""
    if _same(a, ref):
        return None
    zero = np.isneginf(ref)
    if a.shape != ref.shape:
        if a.size == 1:
            return _wrong(f"{what}: log_W is a single number; return one normalised log-weight "
                          f"per particle, an array of shape {ref.shape}.")
        return _wrong(f"{what}: log_W has shape {a.shape}; it must have the shape of log_w, "
                      f"{ref.shape}.")
    with np.errstate(all="ignore"):
        W = np.exp(ref)
        shifted = lw - np.max(lw)
        candidates = [
            (W, "log_W holds the normalised weights W_i themselves; return their logarithms, "
                "log W_i = l_i - log_sum."),
            (shifted, "log_W is only shifted by the largest log-weight (l_i - m): the weights "
                      "are not normalised yet. Subtract log sum_j e^(l_j), not m."),
            (log_sum - lw, "log_W has the wrong sign: log W_i = l_i - log_sum, not log_sum - l_i."),
            (lw / log_sum if log_sum != 0 else np.full(lw.shape, np.nan),
             "log_W divides l_i by log_sum; in the log domain a division is a subtraction: "
             "log W_i = l_i - log_sum."),
            (ref / math.log(10), "log_W uses log10; use natural logarithms throughout."),
            (np.where(np.isfinite(lw), -math.log(max(int(np.sum(np.isfinite(lw))), 1)), -np.inf),
             "log_W gives every nonzero particle the same share: weigh each by e^(l_i)."),
        ]
    for value, message in candidates:
        if _same(a, value) and not _same(value, ref):
            return _wrong(f"{what}: {message}")
    if np.isnan(a).any():
        return _wrong(f"{what}: log_W contains NaN: exp(l) underflowed to 0 or overflowed to inf "
                      f"(0/0 or inf/inf). Subtract the largest log-weight before np.exp.")
    if np.isposinf(a).any():
        return _wrong(f"{what}: log_W contains +inf: exp(l) overflowed. Subtract the largest "
                      f"log-weight before np.exp.")
    if zero.any() and not np.all(np.isneginf(a[zero])):
        return _wrong(f"{what}: a particle with log-weight -inf (weight 0) must keep log W = -inf; "
                      f"yours gives it {_show(a[zero][:3])}. Do not replace -inf by a number.")
    if np.isneginf(a[~zero]).any():
        return _wrong(f"{what}: log_W is -inf for a particle whose weight is not zero: exp(l) "
                      f"underflowed before the log. Stay in logs: log W_i = l_i - log_sum.")
    fin = np.isfinite(ref)
    shift = a[fin] - ref[fin]
    if np.array_equal(np.isneginf(a), zero) and np.allclose(shift, shift[0], rtol=0,
                                                             atol=TOL_FUNCTION):
        return _wrong(f"{what}: log_W is off by the same constant in every entry: the "
                      f"weights are not normalised (log W_i = l_i - log_sum makes "
                      f"sum_i e^(log W_i) = 1).")
    wrong = ~np.isclose(a, ref, rtol=TOL_FUNCTION, atol=TOL_FUNCTION) & ~zero
    first = int(np.flatnonzero(wrong)[0]) if wrong.any() else 0
    return _wrong(f"{what}: log_W differs from the normalised log-weights at {int(wrong.sum())} "
                  f"of {a.size} entries (the first at index {first}).")


def exercise_1(my_log_normalize) -> Feedback:
    """Check ``my_log_normalize(log_w) -> (log_W, log_sum)`` against :func:`bf.particle.log_normalize`.

    Test inputs: the statement's (-1000, -1001, -1002, -inf), equal
    log-weights, log-weights near +800 (exp overflows), one particle, 50
    log-weights near -5000 with two -inf, moderate ones with a -inf, and a
    spread of 800 (a weight below floating point whose log is still finite).
    Diagnoses: a single array instead of the pair, the pair swapped;
    log-sum-exp without the shift (-inf, +inf or NaN); the max not added back;
    the log of the mean; the sum of the weights, log10, the sum of the logs;
    normalised weights instead of their logs; logs shifted but not normalised;
    the wrong sign; a division where logs subtract; a zero weight given a
    finite log-weight; log_W computed as the log of the weights (-inf where
    a weight underflows); and the argument changed in place.
    """
    what = "my_log_normalize"
    if my_log_normalize is None or my_log_normalize is Ellipsis:
        return _not_attempted(what)
    if not callable(my_log_normalize):
        return _wrong(f"{what} must be a function (def my_log_normalize(log_w): ...), got "
                      f"{type(my_log_normalize).__name__}.")
    cases = _exercise_1_cases()
    for k, lw in enumerate(cases):
        values = _show(lw) if lw.size <= 6 else f"{lw.size} log-weights near -5000"
        shown = f"test input {k + 1} (log_w = {values})"
        arg = lw.copy()
        try:
            out = my_log_normalize(arg)
        except NotImplementedError:
            return _not_written(what)
        except Exception as exc:  # noqa: BLE001 - the student's error is feedback
            return _wrong(f"{what} fails on {shown}: {type(exc).__name__}: {exc}")
        ref_W, ref_sum = particle.log_normalize(lw)
        if out is None:
            return _wrong(f"{what} returned None on {shown}; did you forget `return`?")
        if isinstance(out, np.ndarray) and out.ndim == 1 and out.shape == lw.shape:
            return _wrong(f"{what} returns one array on {shown}; return the pair "
                          f"(log_W, log_sum), as bf.particle.log_normalize does.")
        if not isinstance(out, (tuple, list)) or len(out) != 2:
            return _wrong(f"{what} must return a pair (log_W, log_sum); on {shown} it returned "
                          f"{type(out).__name__}" + (f" of length {len(out)}"
                                                     if isinstance(out, (tuple, list)) else "") + ".")
        first, second = out
        if np.ndim(first) == 0 and np.ndim(second) == 1 and np.size(second) == lw.size and lw.size > 1:
            return _wrong(f"{what} returns the pair in the wrong order on {shown}: first the "
                          f"array log_W, then the number log_sum.")
        log_sum, bad = _real_number(second, f"{what}, {shown}: log_sum", allow_inf=True)
        if bad is not None:
            if isinstance(second, float) and math.isnan(second):
                return _wrong(f"{what}, {shown}: log_sum is NaN: exp(l) overflowed before the "
                              f"log. Factor out the largest log-weight m first.")
            return bad
        if isinstance(first, (str, bytes, dict)) or callable(first):
            return _wrong(f"{what}, {shown}: log_W must be an array of numbers, got "
                          f"{type(first).__name__}.")
        try:
            log_W = np.asarray(first, dtype=float)
        except Exception:  # noqa: BLE001
            return _wrong(f"{what}, {shown}: log_W must be an array of numbers, got "
                          f"{type(first).__name__}.")
        feedback = _diagnose_log_sum(log_sum, lw, ref_sum, f"{what}, {shown}")
        if feedback is not None:
            return feedback
        feedback = _diagnose_log_w(log_W, lw, ref_W, log_sum, f"{what}, {shown}")
        if feedback is not None:
            return feedback
        # an argument changed in place: the engine's guard (bayesfilt.checks.guard)
    return Feedback(CORRECT, f"{what} agrees with bf.particle.log_normalize on all {len(cases)} "
                             f"test inputs (underflow, overflow, zero weights, one particle, "
                             f"a spread of 800).")


# --------------------------------------------------------------------------
# Exercise 2 - the ESS of three weight vectors (a derivation)
# --------------------------------------------------------------------------

def _exercise_2_reference() -> np.ndarray:
    log_W, _ = particle.log_normalize(ESS_LOG_WEIGHTS)
    return np.array([particle.ess(ESS_NORMALISED), particle.ess(ESS_UNNORMALISED),
                     particle.ess(np.exp(log_W))])


def _ess_variants(w) -> dict[str, float]:
    """The plausible wrong values for one weight vector w (as given: maybe unnormalised)."""
    w = np.asarray(w, dtype=float)
    W = w / w.sum()
    n = w.size
    return {
        "sum of squares": float(np.sum(W ** 2)),
        "unnormalised": float(1 / np.sum(w ** 2)),
        "ddof": float(n / (1 + np.var(n * W, ddof=1))) if n > 1 else math.nan,
        "max": float(1 / W.max()),
        "count": float(np.count_nonzero(w)),
    }


_ESS_MESSAGES = {
    "sum of squares": "is the sum of the squared weights; the ESS is its reciprocal, "
                      "1 / sum_i (W^i)^2.",
    "unnormalised": "is 1 / sum_i (w^i)^2 of the weights as given: normalise them first, "
                    "W^i = w^i / sum_j w^j.",
    "ddof": "uses the sample variance (ddof=1) in N / (1 + var(N W)); the identity of section 7 "
            "takes the variance over the N particles, np.var(N * W) (ddof=0).",
    "max": "is 1 / max_i W^i, another measure of degeneracy; the ESS of section 7 is "
           "1 / sum_i (W^i)^2.",
    "count": "counts the particles with a nonzero weight; the ESS weighs them: 1 / sum_i (W^i)^2.",
}


def exercise_2(answer) -> Feedback:
    """Check ``answer_2 = np.array([ESS (a), ESS (b), ESS (c)])``, to 3 decimals.

    (a) normalised weights (0.4, 0.3, 0.2, 0.1); (b) unnormalised weights
    (1, 1, 2); (c) log-weights (-1000, -1001, -1002, -inf). Diagnoses per
    entry: the sum of squares instead of its reciprocal; (b) not normalised;
    the sample variance (ddof=1) in N / (1 + var(N W)); 1 / max W; a count
    of particles; (c) NaN from exp(-1000), log-weights used as weights, 10^l
    instead of e^l, the zero weight counted as a particle; entries swapped.
    """
    what = "answer_2"
    if answer is None or answer is Ellipsis:
        return _not_attempted(what)
    labels = ("(a), the weights (0.4, 0.3, 0.2, 0.1)", "(b), the unnormalised weights (1, 1, 2)",
              "(c), the log-weights (-1000, -1001, -1002, -inf)")
    if isinstance(answer, (list, tuple, np.ndarray)) and np.size(answer) == 3:
        try:
            raw = np.asarray(answer, dtype=float).ravel()
        except Exception:  # noqa: BLE001
            raw = None
        if raw is not None and np.isnan(raw[2]) and not np.isnan(raw[:2]).any():
            return _wrong(f"{what}[2], the ESS of {labels[2][5:]}, is NaN: np.exp(-1000) "
                          f"underflows to 0, and 0 / 0 is NaN. Only differences of log-weights "
                          f"matter: subtract the largest one before np.exp (section 6).")
    a, bad = _real_array(answer, what)
    if bad is not None:
        return bad
    ref = _exercise_2_reference()
    if a.shape != (3,):
        if a.size == 3:
            return _wrong(f"{what} has the right count of numbers in shape {a.shape}; give a flat "
                          f"array of three, np.array([ESS_a, ESS_b, ESS_c]).")
        return _wrong(f"{what} must hold three numbers, np.array([ESS_a, ESS_b, ESS_c]); got "
                      f"shape {a.shape}.")
    close = np.isclose(a, ref, rtol=0, atol=ATOL_HAND)
    if close.all():
        return Feedback(CORRECT, f"{what} matches the reference. (c) depends only on the "
                                 f"differences of the log-weights: shift by the largest, then "
                                 f"exponentiate.")
    if sorted(np.round(a, 3)) == sorted(np.round(ref, 3)):
        return _wrong(f"{what} has the right numbers in the wrong order: (a), (b), (c).")
    for k in range(3):
        if close[k]:
            continue
        given = (ESS_NORMALISED, ESS_UNNORMALISED)[k] if k < 2 else None
        label = f"{what}[{k}], the ESS of {labels[k][5:]},"
        if given is not None:
            for key, value in _ess_variants(given).items():
                if np.isfinite(value) and abs(a[k] - value) <= ATOL_HAND and abs(value - ref[k]) > ATOL_HAND:
                    return _wrong(f"{label} {_ESS_MESSAGES[key]}")
        else:
            lw = np.array(ESS_LOG_WEIGHTS)
            finite = lw[np.isfinite(lw)]
            w10 = 10.0 ** (finite - finite.max())
            we = np.exp(finite - finite.max())
            for value, message in [
                (1 / np.sum(finite ** 2), "treats the log-weights as weights; the weights are "
                                          "e^l, normalised."),
                (w10.sum() ** 2 / np.sum(w10 ** 2), "uses 10^l; log-weights are natural "
                                                    "logarithms, the weights are e^l."),
                (1 / np.max(we / we.sum()), _ESS_MESSAGES["max"]),
                (float(np.sum(we ** 2) / we.sum() ** 2), _ESS_MESSAGES["sum of squares"]),
                (3.0, "is the ESS of three equal weights (or of the log-weights used as weights): "
                      "the weights e^-1000, e^-1001 and e^-1002 are not equal; only their ratios "
                      "matter, e^0 : e^-1 : e^-2."),
                (4.0, "counts all four particles as if their weights were equal; the last weight "
                      "is e^-inf = 0, and the others differ."),
            ]:
                if abs(a[k] - value) <= ATOL_HAND:
                    return _wrong(f"{label} {message}")
        if a[k] < 1 - ATOL_HAND:
            return _wrong(f"{label} is below 1; the ESS lies between 1 (one particle holds all "
                          f"the weight) and N (equal weights).")
        return _wrong(f"{label} is too {'large' if a[k] > ref[k] else 'small'} (give at least "
                      f"3 decimals).")
    return _wrong(f"{what} does not match the reference.")


# --------------------------------------------------------------------------
# Exercise 3 - the increment of the optimal proposal on lg (a derivation, as a function)
# --------------------------------------------------------------------------

@functools.lru_cache(maxsize=1)
def _lg():
    return models.LinearGaussian(A=[[LG_A]], C=[[LG_C]], Q=[[LG_Q]], R=[[LG_R]], m0=[LG_M0],
                                 P0=[[LG_P0]])


def _increment_reference(x_prev: float, y: float) -> float:
    """Eq. (13) with the optimal proposal, from the three densities at one draw (bf.particle)."""
    lg = _lg()
    opt = particle.optimal_proposal(lg)
    X_prev, yv = np.array([[x_prev]]), np.array([y])
    X = opt.sample(np.random.default_rng(0), X_prev, yv, 1)
    # log alpha = log p(y | x) + log p(x | x_prev) - log q(x | x_prev, y)
    return float(lg.measurement_logpdf(yv, X)[0] + lg.transition_logpdf(X, X_prev)[0]
                 - opt.logpdf(X, X_prev, yv, 1)[0])


def _log_normal(y: float, mean: float, var: float) -> float:
    return -0.5 * math.log(2 * math.pi * var) - 0.5 * (y - mean) ** 2 / var


def _exercise_3_cases() -> list[tuple[float, float]]:
    rng = np.random.default_rng(303)
    drawn = [(float(x), float(y)) for x, y in rng.normal(0.0, 2.0, size=(3, 2))]
    return [(1.0, 2.0), (0.0, 0.0), (-2.5, 1.0), (4.0, -3.0)] + drawn


_S = LG_C * LG_Q * LG_C + LG_R
_GAIN = LG_Q * LG_C / _S
_INCREMENT_VARIANTS: list[tuple[Callable[[float, float], float], str]] = [
    (lambda x, y: _log_normal(y, LG_C * LG_A * x, LG_R),
     "uses the variance R alone: that is p(y_t | x_t) at x_t = A x_prev, the bootstrap's "
     "likelihood. Given x_(t-1), y_t = C (A x_(t-1) + w_(t-1)) + v_t, so its variance is "
     "S = C Q C^T + R."),
    (lambda x, y: _log_normal(y, LG_C * LG_A * x, LG_C * LG_Q * LG_C),
     "uses the variance C Q C^T alone: the measurement noise R is missing from S = C Q C^T + R."),
    (lambda x, y: _log_normal(y, LG_C * x, _S),
     "centres y on C x_prev: the state moves before it is measured, so the mean of y_t given "
     "x_(t-1) is C A x_prev."),
    (lambda x, y: _log_normal(y, x, LG_R),
     "is log N(y; x_prev, R): the mean is C A x_prev and the variance S = C Q C^T + R."),
    (lambda x, y: _log_normal(y, LG_C * LG_A * x, LG_C * LG_A * LG_Q * LG_A * LG_C + LG_R),
     "scales the process noise by A: the noise w_(t-1) is added after A (x_t = A x_(t-1) + "
     "w_(t-1)), so S = C Q C^T + R, without A."),
    (lambda x, y: _log_normal(y, LG_C * LG_A * x, _S ** 2),
     "uses S = C Q C^T + R as a standard deviation; S is a variance (scipy.stats.norm takes the "
     "standard deviation sqrt(S))."),
    (lambda x, y: _log_normal(y, LG_C * LG_A * x, math.sqrt(_S)),
     "uses sqrt(S) as the variance; S = C Q C^T + R is already the variance."),
    (lambda x, y: _log_normal(y, LG_C * LG_A * x, (1 - _GAIN * LG_C) * LG_Q),
     "uses the variance Sigma = (I - K C) Q of the proposal q(x_t | x_(t-1), y_t); the increment "
     "is the density of y_t given x_(t-1), whose variance is S = C Q C^T + R."),
    (lambda x, y: math.exp(_log_normal(y, LG_C * LG_A * x, _S)),
     "returns the increment alpha itself; the exercise asks for its logarithm, log alpha."),
    (lambda x, y: -0.5 * (y - LG_C * LG_A * x) ** 2 / _S,
     "misses the constant -1/2 log(2 pi S) of the normal log-density. It cancels when the "
     "weights are normalised, but log alpha is a log-density (and estimates the evidence)."),
    (lambda x, y: _log_normal(y, LG_C * LG_A * x, _S) / math.log(10),
     "uses log10; log-densities are natural logarithms."),
    (lambda x, y: -_log_normal(y, LG_C * LG_A * x, _S),
     "has the wrong sign: log alpha = log N(y; mean, S), not its negative."),
]


def exercise_3(log_increment) -> Feedback:
    """Check ``log_increment(x_prev, y)``, the optimal proposal's log increment on ``lg``.

    Compares with eq. (13) evaluated with ``bf.particle.optimal_proposal(lg)``
    on seven (x_prev, y) pairs. Diagnoses (a mistake must explain every test
    input): the variance R alone (the bootstrap's likelihood), Q alone, the
    mean C x_prev (A forgotten), N(y; x_prev, R), A Q A^T in S, S used as a
    standard deviation, sqrt(S) as the variance, the proposal's variance
    Sigma, alpha instead of log alpha, the normalising constant missing,
    log10, the wrong sign.
    """
    what = "log_increment"
    if log_increment is None or log_increment is Ellipsis:
        return _not_attempted(what)
    if not callable(log_increment):
        return _wrong(f"{what} must be a function (def log_increment(x_prev, y): ...), got "
                      f"{type(log_increment).__name__}.")
    cases = _exercise_3_cases()
    outputs = []
    for k, (x, y) in enumerate(cases):
        shown = f"test input {k + 1} (x_prev = {x:.4g}, y = {y:.4g})"
        try:
            out = log_increment(x, y)
        except NotImplementedError:
            return _not_written(what)
        except Exception as exc:  # noqa: BLE001 - the student's error is feedback
            return _wrong(f"{what} fails on {shown}: {type(exc).__name__}: {exc}")
        if out is None:
            return _wrong(f"{what} returned None on {shown}; did you forget `return`?")
        value, bad = _real_number(out, f"the output of {what} on {shown}", allow_neg_inf=True)
        if bad is not None:
            return bad
        outputs.append(value)
    got = np.array(outputs)
    ref = np.array([_increment_reference(x, y) for x, y in cases])
    if np.allclose(got, ref, rtol=TOL_FUNCTION, atol=TOL_FUNCTION):
        return Feedback(CORRECT, f"{what} agrees with eq. (13) for bf.particle.optimal_proposal "
                                 f"on all {len(cases)} test inputs: the increment does not "
                                 f"depend on the draw x_t.")
    for variant, message in _INCREMENT_VARIANTS:
        values = np.array([variant(x, y) for x, y in cases])
        if np.allclose(got, values, rtol=1e-7, atol=1e-9):
            return _wrong(f"{what} {message}")
    k = int(np.flatnonzero(~np.isclose(got, ref, rtol=TOL_FUNCTION, atol=TOL_FUNCTION))[0])
    x, y = cases[k]
    return _wrong(f"{what} is not yet right: on test input {k + 1} (x_prev = {x:.4g}, y = "
                  f"{y:.4g}) its value is too {'large' if got[k] > ref[k] else 'small'}. "
                  f"log alpha = log p(y_t | x_(t-1)): work out the mean and the variance of "
                  f"y_t = C (A x_(t-1) + w_(t-1)) + v_t given x_(t-1).")


# --------------------------------------------------------------------------
# Exercise 4 - how the degeneracy depends on R (an experiment)
# --------------------------------------------------------------------------

@functools.lru_cache(maxsize=1)
def _experiment() -> tuple[tuple[float, ...], tuple[float, ...]]:
    """Mean ESS over the records: (bootstrap at t = 5, optimal at t = 39), one entry per R."""
    boot, opt = [], []
    for R in R_VALUES:
        lg = models.LinearGaussian(A=[[LG_A]], C=[[LG_C]], Q=[[LG_Q]], R=[[R]], m0=[LG_M0],
                                   P0=[[LG_P0]])
        proposals = {"bootstrap": None, "optimal": particle.optimal_proposal(lg)}
        rng_records = np.random.default_rng(SEED_RECORDS)
        rng_filters = {name: np.random.default_rng(SEED_FILTERS) for name in proposals}
        ess = {name: np.empty((EXPERIMENT_RUNS, EXPERIMENT_T)) for name in proposals}
        for r in range(EXPERIMENT_RUNS):
            record = models.simulate(lg, EXPERIMENT_T, rng_records)
            for name, proposal in proposals.items():
                ess[name][r] = particle.particle_filter(lg, record.ys, EXPERIMENT_N,
                                                        rng_filters[name], proposal=proposal,
                                                        ess_threshold=0).ess
        boot.append(float(ess["bootstrap"][:, T_BOOTSTRAP].mean()))
        opt.append(float(ess["optimal"][:, T_OPTIMAL].mean()))
    return tuple(boot), tuple(opt)


def _which_r(value) -> float | None:
    """The value of R_VALUES that ``value`` names, or None."""
    if isinstance(value, (bool, np.bool_)):
        return None
    if isinstance(value, str):
        text = value.strip().lower().replace(" ", "")
        text = text[2:] if text.startswith("r=") else text
        try:
            value = float(text)
        except ValueError:
            return None
    if isinstance(value, np.ndarray) and value.size == 1:
        value = value.reshape(()).item()
    if not isinstance(value, numbers.Real):
        return None
    for R in R_VALUES:
        if math.isclose(float(value), R, rel_tol=1e-9):
            return R
    return None


def exercise_4(answer) -> Feedback:
    """Check ``answer_4 = (R for the bootstrap, R for the optimal proposal)``.

    The first: the R among 0.01, 0.1, 1 at which the bootstrap's mean ESS
    (10 records) at t = 5 is smallest; the second: the R at which the optimal
    proposal's mean ESS at t = 39 is smallest (plain SIS, N = 500, T = 40).
    The reference is the experiment run here with section 8's seeds; with 10
    records the answer is the same for other seeds. Diagnoses: not a pair;
    an ESS given instead of an R; the two swapped; for the bootstrap, the
    belief that a noisier sensor degenerates faster; for the optimal
    proposal, the belief that it behaves like the bootstrap; a neighbour
    value (single record, or another time step).
    """
    what = "answer_4"
    if answer is None or answer is Ellipsis:
        return _not_attempted(what)
    form = (f"{what} must be a pair of values of R, (R at which the bootstrap's mean ESS at "
            f"t = 5 is smallest, R at which the optimal proposal's mean ESS at t = 39 is "
            f"smallest), each one of 0.01, 0.1, 1")
    if not isinstance(answer, (list, tuple, np.ndarray)):
        return _wrong(f"{form}; got {type(answer).__name__}.")
    try:
        items = list(np.asarray(answer, dtype=object).ravel()) if isinstance(answer, np.ndarray) \
            else list(answer)
    except Exception:  # noqa: BLE001
        return _wrong(f"{form}; got {type(answer).__name__}.")
    if len(items) != 2:
        return _wrong(f"{form}; got {len(items)} value(s).")
    chosen = [_which_r(v) for v in items]
    for k, (value, R) in enumerate(zip(items, chosen)):
        if R is None:
            looks_like_ess = isinstance(value, numbers.Real) and not isinstance(value, bool) \
                and float(value) >= 1.0 and float(value) not in R_VALUES
            return _wrong(f"{what}[{k}] is {value!r}, not one of the three values of R (0.01, "
                          f"0.1, 1)" + ("; give the value of R, not the ESS you measured."
                                        if looks_like_ess else "."))
    boot, opt = _experiment()
    expected = (R_VALUES[int(np.argmin(boot))], R_VALUES[int(np.argmin(opt))])
    if tuple(chosen) == expected:
        return Feedback(CORRECT, f"{what} is right: a precise sensor ruins the bootstrap, whose "
                                 f"blind draws rarely land where the narrow likelihood is; the "
                                 f"optimal proposal removes that spread, and what is left comes "
                                 f"from the particles' different pasts.")
    if tuple(chosen) == expected[::-1] and expected[0] != expected[1]:
        return _wrong(f"{what} has the two values swapped: first the bootstrap (t = 5), then the "
                      f"optimal proposal (t = 39).")
    if chosen[0] != expected[0]:
        if chosen[0] == max(R_VALUES):
            return _wrong(f"{what}[0]: a noisier sensor does not make the bootstrap degenerate "
                          f"faster. The bootstrap draws x_t blind to y_t and weights each draw by "
                          f"the likelihood N(y_t; x_t, R): the narrower the likelihood (the "
                          f"smaller R), the fewer draws land where it is large. Look again at the "
                          f"mean ESS at t = 5 (index 5).")
        return _wrong(f"{what}[0] is not the R with the smallest mean ESS of the bootstrap at "
                      f"t = 5. Average over the 10 records (one record can mislead), at index 5 "
                      f"of the ESS, with ess_threshold=0 (no resampling).")
    if chosen[1] == expected[0]:
        return _wrong(f"{what}[0] is right; {what}[1] assumes the optimal proposal ranks the three "
                      f"R like the bootstrap. Look at its mean ESS at t = 39 (index 39 or -1, "
                      f"not 5): its increment p(y_t | x_(t-1)^i) does not depend on the new draw, "
                      f"only on the particle's past, and the spread of the pasts is what decides "
                      f"now.")
    return _wrong(f"{what}[0] is right; {what}[1] is not the R with the smallest mean ESS of the "
                  f"optimal proposal at t = 39 (index 39 or -1). Average over the 10 records, "
                  f"with ess_threshold=0 and proposal=bf.particle.optimal_proposal(model) built "
                  f"for each R.")


# --------------------------------------------------------------------------
# Exercise 5 - which models need more than the bootstrap (a derivation, as a choice)
# --------------------------------------------------------------------------

def _statement_models() -> dict[str, object]:
    dp = models.damped_particle()
    dp_pushed = models.LinearGaussian(A=dp.A, C=dp.C, Q=np.diag([1e-4, 0.01, 1e-4, 0.01]),
                                      R=dp.R, m0=dp.m0, P0=dp.P0)
    return {"a": dp, "b": dp_pushed, "c": _lg()}


def _optimal_differs(model) -> bool:
    """p(x_t | x_(t-1), y_t) differs from p(x_t | x_(t-1)) iff y_t sees w_(t-1): C G Q != 0."""
    G = model.G if model.G is not None else np.eye(model.state_dim)
    return not np.allclose(model.C @ G @ model.Q, 0.0)


_MODEL_HINTS = {
    "a": "the damped particle (a): its sensor measures positions, and its noise G w_(t-1) moves "
         "only the velocities at step t. Given x_(t-1), does y_t depend on w_(t-1)? "
         "(section 8.1)",
    "b": "dp_pushed (b): with G = I its noise also pushes the positions, which y_t measures. "
         "Given x_(t-1), does y_t depend on w_(t-1)?",
    "c": "lg (c): y_t = C (A x_(t-1) + w_(t-1)) + v_t. Given x_(t-1), does y_t depend on "
         "w_(t-1)?",
}


def _letters(answer):
    """(set of letters, None) or (None, Feedback)."""
    what = "answer_5"
    usage = (f"{what} must be a list of the letters of the models, e.g. [\"a\"] or [] for none; "
             f"got {{}}.")
    if isinstance(answer, str):
        tokens = [t for t in re.findall(r"[a-z]+", answer.lower()) if t != "and"]
        if not all(set(t) <= set(MODEL_LETTERS) for t in tokens):
            return None, _wrong(usage.format(repr(answer)[:80]))
        return {ch for t in tokens for ch in t}, None
    if isinstance(answer, (bytes, dict)) or callable(answer) or isinstance(answer, numbers.Number):
        return None, _wrong(usage.format(type(answer).__name__))
    try:
        items = list(answer)
    except Exception:  # noqa: BLE001
        return None, _wrong(usage.format(type(answer).__name__))
    out = set()
    for item in items:
        if not isinstance(item, str) or item.strip().strip("()").lower() not in MODEL_LETTERS:
            return None, _wrong(usage.format(f"an entry {item!r}"[:80]))
        out.add(item.strip().strip("()").lower())
    return out, None


def exercise_5(answer) -> Feedback:
    """Check ``answer_5``: the letters of the models whose optimal proposal is not the transition.

    (a) ``bf.models.damped_particle()``, (b) ``dp_pushed`` of section 8,
    (c) the 1-D model ``lg``. The reference asks each model whether y_t sees
    the new noise w_(t-1) (C G Q != 0). Diagnoses: the wrong form; none
    chosen; the first model put on the wrong side, with a question that
    leads to the reason (without naming the answer for the others).
    """
    what = "answer_5"
    if answer is None or answer is Ellipsis:
        return _not_attempted(what)
    chosen, bad = _letters(answer)
    if bad is not None:
        return bad
    expected = {k for k, m in _statement_models().items() if _optimal_differs(m)}
    if chosen == expected:
        return Feedback(CORRECT, f"{what} is right: the optimal proposal differs from the "
                                 f"transition exactly when y_t depends on the new noise w_(t-1) "
                                 f"given x_(t-1), here when C G != 0.")
    if not chosen:
        return _wrong(f"{what} is empty: for at least one model y_t does depend on the new noise "
                      f"w_(t-1) given x_(t-1). Write y_t in terms of x_(t-1), w_(t-1) and v_t "
                      f"for each.")
    extra, missing = sorted(chosen - expected), sorted(expected - chosen)
    if extra:
        return _wrong(f"{what} includes {_MODEL_HINTS[extra[0]]} If not, y_t carries no "
                      f"information about the new noise and the optimal proposal is the "
                      f"transition.")
    return _wrong(f"{what} leaves out {_MODEL_HINTS[missing[0]]} If it does, y_t tells "
                  f"something about the new noise and the optimal proposal differs from the "
                  f"transition.")


from . import register as _register  # noqa: E402

_register(globals())
