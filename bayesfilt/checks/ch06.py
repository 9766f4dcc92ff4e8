r"""Checks for the exercises of chapter 06 (resampling and the particle filter).

Each function takes what the student defined in the answer cell and returns a
:class:`bayesfilt.checks.Feedback`; the check cell of the notebook calls it as
its last line::

    import bayesfilt as bf
    bf.checks.ch06.exercise_1(my_systematic)   # Correct / Not yet: ... / Not attempted yet

======================  ===========  ==================================================
check                   kind         the student defines
======================  ===========  ==================================================
:func:`exercise_1`      function     ``my_systematic(w, u)``: the ancestor indices of
                                     the comb p_j = (j + u)/N, numpy only
:func:`exercise_2`      derivation   ``answer_2``: E[N_1] and Var(N_1) under the
                                     multinomial, systematic and residual schemes
:func:`exercise_3`      experiment   ``answer_3``: (mean resamplings per record for
                                     the ESS thresholds 0.1, 0.5, 0.9; the threshold
                                     with the largest RMSE)
:func:`exercise_4`      experiment   ``answer_4``: (the smallest roughening constant K
                                     that keeps track, the NEES verdict for it)
======================  ===========  ==================================================

The references are computed here with :mod:`bayesfilt.resampling`,
:mod:`bayesfilt.particle`, :mod:`bayesfilt.kalman` and :mod:`bayesfilt.models`
from the numbers of the statements (the constants below, the same as in the
notebook), never stored and never shown: a message names what differs
(offspring counts instead of ancestor indices, indices shifted by one, a
zero-weight particle chosen, weights not normalised, a variance without its
(1 - W) or its R, a total instead of a mean per record, ...), not the
expected value. A check never raises: an answer it cannot read is feedback
too.
"""

from __future__ import annotations

import contextlib
import functools
import math
import numbers
import re

import numpy as np

from .. import gaussian, kalman, models, particle, resampling
from . import (CORRECT, Feedback, _not_attempted,
               _not_written, _wrong)

__all__ = ["exercise_1", "exercise_2", "exercise_3", "exercise_4"]

# --------------------------------------------------------------------------
# the numbers of the statements (as in the notebook)
# --------------------------------------------------------------------------

#: exercise 1: the six weights of section 2 and the statement's u; the other inputs are the
#: check's own (a degenerate set, a zero weight at u = 0, unnormalised weights, one particle, ...)
SIX_WEIGHTS = (0.05, 0.32, 0.08, 0.22, 0.13, 0.20)
U_STATEMENT = 0.5

#: exercise 2: four weights, M = 10 new particles, questions about particle 1 (numbered from 0)
WEIGHTS_2 = (0.42, 0.28, 0.18, 0.12)
M_2 = 10
PARTICLE_2 = 1
ATOL_HAND = 2e-3                              # three decimals

#: exercise 3: section 3's test bench, its 20 records (seed 15) and filter seed (16)
LG_3 = dict(A=[[0.9]], C=[[1.0]], Q=[[1.0]], R=[[1.0]], m0=[0.0], P0=[[1.0]])
RECORDS_3, T_3, N_3 = 20, 50, 500
SEED_RECORDS_3, SEED_FILTERS_3 = 15, 16
THRESHOLDS_3 = (0.1, 0.5, 0.9)
# Mean resamplings per record: with 200 other pairs of seeds they stayed within 9.1-10.6,
# 23.2-26.0 and 49.95-50 (standard deviations 0.24, 0.41, 0.004); the tolerance, 20 % of the
# reference but at least 1, covers every seed with a margin of more than 4 standard deviations.
RTOL_3, ATOL_3 = 0.2, 1.0

#: exercise 4: the twenty runs of section 6 (seed 25), roughened SIR of section 7 (seed 28)
RUNS_4, T_4, N_4 = 20, 60, 500               # N_4: fewer particles than section 7 (2000): ~2 s
N_BEFORE_4 = 2000                            # the exercise's N before issue 13 (check cells without N)
SEED_RECORDS_4, SEED_FILTERS_4 = 25, 28
K_VALUES_4 = (0.05, 0.1, 0.5, 1.0)
LOST_METRES_4 = 5.0                           # a run is lost when its final error exceeds 5 m
MAX_LOST_4 = 5                                # "keeps track": at most a quarter of the 20 runs lost
T_FROM_4 = 30                                 # the NEES verdict looks at t >= 30
NEES_DOF_4 = 4                                # the state dimension d
VERDICTS_4 = ("overconfident", "conservative")
# With 130 other pairs of seeds: K = 0.1 lost 11-20 runs, K = 0.5 lost 0-3, and K = 0.5's
# median NEES over t >= 30 stayed within 1.17-1.83, so the answer does not depend on the seeds.

TOL_INDEX = 1e-12                             # round-off allowed where a point meets a C_i


# --------------------------------------------------------------------------
# small helpers (feedback that never raises)
# --------------------------------------------------------------------------

# _not_attempted, _not_written and _wrong come from bayesfilt.checks; the engine
# (bayesfilt.checks.exercise) runs every exercise_N.


def _real_array(value, what: str):
    """(array of floats, None), or (None, Feedback) if ``value`` is not an array of real numbers."""
    if value is None:
        return None, _wrong(f"{what} is None.")
    if isinstance(value, (str, bytes, dict, set)) or callable(value):
        return None, _wrong(f"{what} must be numbers (a numpy array), got {type(value).__name__}.")
    try:
        a = np.asarray(value)
    except Exception:  # noqa: BLE001 - ragged lists and odd objects
        return None, _wrong(f"{what} must be a rectangular array of numbers, got "
                            f"{type(value).__name__}.")
    if a.dtype.kind == "b":
        return None, _wrong(f"{what} must be numbers, got booleans (True/False).")
    if a.dtype.kind not in "iuf":
        return None, _wrong(f"{what} must be made of real numbers, got {type(value).__name__} "
                            f"of dtype {a.dtype}.")
    a = a.astype(float)
    if np.isnan(a).any():
        return None, _wrong(f"{what} contains NaN.")
    if np.isinf(a).any():
        return None, _wrong(f"{what} contains inf.")
    return a, None


def _real_number(value, what: str):
    """(float, None), or (None, Feedback) if ``value`` is not one finite real number."""
    if isinstance(value, (bool, np.bool_)):
        return None, _wrong(f"{what} must be a number, got {value!r}.")
    if isinstance(value, np.ndarray) and value.size == 1 and value.dtype.kind in "iuf":
        value = value.reshape(()).item()
    if isinstance(value, str):
        match = re.fullmatch(r"\s*(?:[A-Za-zθ_ ]*=\s*)?([-+]?\d*\.?\d+(?:[eE][-+]?\d+)?)\s*", value)
        if match:
            value = float(match.group(1))
    if not isinstance(value, numbers.Real):
        if isinstance(value, np.ndarray):
            return None, _wrong(f"{what} must be one number, got an array of shape {value.shape}.")
        return None, _wrong(f"{what} must be one number, got {type(value).__name__}.")
    try:
        v = float(value)
    except (OverflowError, ValueError, TypeError):
        return None, _wrong(f"{what} must be a finite number of ordinary size.")
    if not math.isfinite(v):
        return None, _wrong(f"{what} is {v}.")
    return v, None


def _pair(answer, what: str, first: str, second: str):
    """``answer`` as a pair (first, second), or a Feedback saying what it is instead."""
    if isinstance(answer, np.ndarray) and answer.dtype.kind != "O":
        return None, _wrong(f"{what} must be a pair ({first}, {second}), a tuple of two; got a "
                            f"numpy array of shape {answer.shape}.")
    if not isinstance(answer, (tuple, list)):
        return None, _wrong(f"{what} must be a pair ({first}, {second}), a tuple of two; got "
                            f"{type(answer).__name__}.")
    if len(answer) != 2:
        return None, _wrong(f"{what} must be a pair ({first}, {second}), a tuple of two; got "
                            f"{len(answer)} items.")
    return tuple(answer), None


def _show(a, precision: int = 4) -> str:
    return np.array2string(np.asarray(a, dtype=float), precision=precision, separator=", ")


# --------------------------------------------------------------------------
# Exercise 1 - systematic resampling by hand (a function)
# --------------------------------------------------------------------------

def _exercise_1_cases() -> list[tuple[np.ndarray, float]]:
    rng = np.random.default_rng(606)
    w50 = rng.exponential(size=50)                     # unnormalised: they sum to about 50
    w50[[3, 17, 18]] = 0.0                             # three zero weights, two of them adjacent
    w1000 = rng.exponential(size=1000) ** 3
    return [
        (np.array(SIX_WEIGHTS), U_STATEMENT),          # the statement
        (np.array(SIX_WEIGHTS), 0.0),                  # u = 0: the comb starts at 0
        (np.array([0.0, 0.0, 1.0, 0.0, 0.0]), 0.3),    # degenerate: one particle holds all the weight
        (np.array([0.0, 0.5, 0.5]), 0.0),              # a zero weight first, and p_0 = 0 = C_0
        (3.0 * np.array(SIX_WEIGHTS), 0.4),            # unnormalised, summing to 3
        (np.array([0.3, 0.2, 0.1]), 0.9),              # unnormalised, summing to 0.6
        (np.array([1.0]), 0.7),                        # one particle
        (w50, float(rng.random())),                    # 50 unnormalised weights with zeros
        (w1000 / w1000.sum(), float(rng.random())),    # 1000 normalised, very uneven weights
    ]


def _reference_1(w: np.ndarray, u: float) -> np.ndarray:
    return resampling.from_uniforms(w, np.full(len(w), u))


def _points(n: int, u: float) -> np.ndarray:
    return (np.arange(n) + u) / n


def _valid_1(a: np.ndarray, w: np.ndarray, u: float) -> bool:
    """Is every a_j the first i with p_j < C_i, allowing round-off where p_j meets a C_i?"""
    n = len(w)
    if a.shape != (n,) or np.any(a != np.round(a)) or a.min() < 0 or a.max() > n - 1:
        return False
    idx = a.astype(int)
    if np.any(w[idx] <= 0) or np.any(np.diff(idx) < 0):
        return False
    C = np.cumsum(w) / np.sum(w)
    lower = np.concatenate([[0.0], C])[idx]            # C_(a_j - 1), with C_(-1) = 0
    p = _points(n, u)
    return bool(np.all(p >= lower - TOL_INDEX) and np.all(p < C[idx] + TOL_INDEX))


def _describe_1(w: np.ndarray, u: float) -> str:
    total = float(np.sum(w))
    if w.size <= 6:
        weights = f"w = {_show(w, 3)}"
    else:
        weights = f"{w.size} weights" + (" (normalised)" if math.isclose(total, 1.0) else
                                          f" summing to {total:.4g}")
    return f"{weights}, u = {u:.4g}"


def _diagnose_1(a: np.ndarray, w: np.ndarray, u: float, ref: np.ndarray, shown: str) -> Feedback | None:
    """A message for an output ``a`` of the right length that is not the ancestors; None if it is."""
    n = len(w)
    total = float(np.sum(w))
    p = _points(n, u)
    C = np.cumsum(w) / total
    counts = np.bincount(ref, minlength=n)
    if np.array_equal(a, ref) or _valid_1(a, w, u):
        return None
    if np.array_equal(a, counts):
        return _wrong(f"my_systematic returns offspring counts on {shown}: entry i is N_i, the "
                      f"number of copies of particle i. The filter needs the ancestor indices "
                      f"a_j, one per new particle (x_new = x[a]); the counts give them with "
                      f"np.repeat(np.arange(N), counts).")
    if np.array_equal(a, np.cumsum(counts)):
        return _wrong(f"my_systematic returns, on {shown}, the number of points below each "
                      f"cumulative weight C_i (cumulative offspring counts), not the ancestor of "
                      f"each point: a_j is the first i with p_j < C_i.")
    if np.allclose(a, p, rtol=0, atol=1e-9):
        return _wrong(f"my_systematic returns the points p_j = (j + u)/N themselves on {shown}; "
                      f"return, for each point, the index of the piece [C_(i-1), C_i) it falls "
                      f"in.")
    if np.array_equal(a, ref + 1):
        return _wrong(f"my_systematic's indices are shifted by one on {shown}: each is one more "
                      f"than the ancestor. Particles are numbered from 0, and a_j is the first i "
                      f"with p_j < C_i (a cumulative sum with a leading 0, C_(-1) = 0, shifts "
                      f"np.searchsorted's result by one).")
    if np.array_equal(a, ref - 1):
        return _wrong(f"my_systematic's indices are shifted by one on {shown}: each is one less "
                      f"than the ancestor. a_j is the first i with p_j < C_i, i.e. the i with "
                      f"C_(i-1) <= p_j < C_i (particles numbered from 0).")
    if n > 1:
        if not math.isclose(total, 1.0, rel_tol=1e-9):
            unnormalised = np.searchsorted(np.cumsum(w), p, side="right")
            if np.array_equal(a, unnormalised):
                return _wrong(f"my_systematic does not normalise the weights: on {shown} they sum "
                              f"to {total:.4g}, so their cumulative sums do not end at 1 and the "
                              f"comb in [0, 1) covers the wrong part of the staircase. Divide by "
                              f"the sum (or by the last cumulative sum) first.")
        left = np.searchsorted(C, p, side="left")
        if np.array_equal(a, left):
            return _wrong(f"my_systematic picks a particle of weight 0 on {shown}: a point p_j "
                          f"equal to a cumulative weight C_i belongs to the next piece. a_j is "
                          f"the first i with p_j < C_i (strictly): np.searchsorted(C, p, "
                          f"side='right'), not side='left'.")
        shifted_comb = np.searchsorted(C, np.arange(n) / n + u, side="right")
        if np.array_equal(a, shifted_comb):
            return _wrong(f"my_systematic uses the points j/N + u on {shown}; the comb is "
                          f"p_j = (j + u)/N: u shifts every tooth by less than the spacing 1/N, "
                          f"so that the points stay in [0, 1).")
        from_one = np.searchsorted(C, (np.arange(1, n + 1) + u) / n, side="right")
        if np.array_equal(a, from_one):
            return _wrong(f"my_systematic uses p_j = (j + u)/N for j = 1, ..., N on {shown}; "
                          f"j runs from 0 to N - 1.")
        no_u = np.searchsorted(C, np.arange(n) / n, side="right")
        if u > 0 and np.array_equal(a, no_u):
            return _wrong(f"my_systematic ignores u on {shown}: the points are p_j = (j + u)/N, "
                          f"not j/N.")
    if np.any(a != np.round(a)):
        return _wrong(f"my_systematic returns numbers that are not whole on {shown}; ancestor "
                      f"indices are integers 0, ..., N - 1.")
    if np.array_equal(np.sort(a), ref):
        return _wrong(f"my_systematic returns the right ancestors in the wrong order on {shown}: "
                      f"the points p_j increase with j, so their ancestors must be sorted "
                      f"ascending (as bf.resampling returns them).")
    if a.min() < 0 or a.max() > n - 1:
        bad = int(a.max()) if a.max() > n - 1 else int(a.min())
        hint = (" Is the last cumulative weight exactly 1 (normalised weights, or a division by "
                "the last cumulative sum)? Every point p_j < 1 must find a piece."
                if bad >= n else "")
        return _wrong(f"my_systematic returns the index {bad} on {shown}, out of range: with "
                      f"N = {n} particles the ancestors are 0, ..., {n - 1}.{hint}")
    idx = a.astype(int)
    if np.any(w[idx] <= 0):
        i = int(idx[np.flatnonzero(w[idx] <= 0)[0]])
        return _wrong(f"my_systematic picks particle {i} on {shown}, whose weight is 0: its piece "
                      f"[C_(i-1), C_i) is empty, so no point can fall in it. a_j is the first i "
                      f"with p_j < C_i (strictly).")
    if np.any(np.diff(idx) < 0):
        return _wrong(f"my_systematic's indices on {shown} are not sorted ascending; the points "
                      f"p_j increase with j, so their ancestors do too.")
    j = int(np.flatnonzero(a != ref)[0])
    return _wrong(f"my_systematic gives a wrong ancestor on {shown}: the first at j = {j}, for the "
                  f"point p_j = {p[j]:.4f}, which your function puts in particle {int(idx[j])}'s "
                  f"piece [C_(i-1), C_i). Stack the normalised weights (C_i = W^0 + ... + W^i) "
                  f"and take the first i with p_j < C_i.")


def _draws_at_random(fun, w: np.ndarray, u: float, first: np.ndarray) -> bool:
    """Does ``fun`` give another output on the same input (it draws random numbers)?"""
    try:
        again = np.asarray(fun(w.copy(), u), dtype=float)
    except Exception:  # noqa: BLE001 - a second failure is not evidence of randomness
        return False
    return again.shape != first.shape or not np.array_equal(again, first)


def exercise_1(my_systematic) -> Feedback:
    """Check ``my_systematic(w, u)`` against :func:`bf.resampling.from_uniforms` with ``u`` repeated.

    Test inputs: the six weights of section 2 with u = 0.5 and u = 0; a
    degenerate set (one weight 1, the others 0); a zero weight first with
    u = 0 (p_0 = C_0 = 0); weights summing to 3 and to 0.6; one particle; 50
    unnormalised weights with three zeros; 1000 very uneven normalised
    weights. Diagnoses: offspring counts instead of ancestor indices,
    cumulative counts, the points p_j themselves, indices shifted by one (up
    or down), weights not normalised, ``side='left'`` (a zero-weight particle
    chosen), the comb j/N + u, j from 1 to N, u ignored, non-integer or float
    indices, unsorted indices, an index out of range, a zero-weight particle,
    the wrong number of indices, the weights changed in place, and random
    draws (a different output on the same input).
    """
    what = "my_systematic"
    if my_systematic is None or my_systematic is Ellipsis:
        return _not_attempted(what)
    if not callable(my_systematic):
        return _wrong(f"{what} must be a function (def my_systematic(w, u): ...), got "
                      f"{type(my_systematic).__name__}.")
    cases = _exercise_1_cases()
    float_indices = False
    for k, (w, u) in enumerate(cases):
        shown = f"test input {k + 1} ({_describe_1(w, u)})"
        arg = w.copy()
        try:
            out = my_systematic(arg, u)
        except NotImplementedError:
            return _not_written(what)
        except Exception as exc:  # noqa: BLE001 - the student's error is feedback
            hint = ""
            if isinstance(exc, IndexError):
                hint = (" (an index past the end: is the last cumulative weight exactly 1? "
                        "Normalise the weights, or divide the cumulative sums by the last one.)")
            return _wrong(f"{what} fails on {shown}: {type(exc).__name__}: {exc}{hint}")
        if out is None:
            return _wrong(f"{what} returned None on {shown}; did you forget `return`?")
        a, bad = _real_array(out, f"the output of {what} on {shown}")
        if bad is not None:
            return bad
        ref = _reference_1(w, u)
        n = len(w)
        if a.ndim != 1:
            if a.size == n and np.array_equal(a.ravel(), ref):
                return _wrong(f"{what} returns the right indices in shape {a.shape} on {shown}; "
                              f"return a flat array of N = {n} indices.")
            return _wrong(f"{what} must return a 1-D array of N = {n} ancestor indices on "
                          f"{shown}, got shape {a.shape}.")
        if a.size != n:
            extra = ""
            if a.size == n + 1:
                extra = (" One index per new particle, j = 0, ..., N - 1: did a loop run once "
                         "too often, or did you search the cumulative weights C in the points?")
            elif a.size < n:
                extra = " One index per point p_j, even when several points share an ancestor."
            return _wrong(f"{what} returns {a.size} indices on {shown}; resampling to the same "
                          f"number of particles needs N = {n}.{extra}")
        feedback = _diagnose_1(a, w, u, ref, shown)
        if feedback is not None:
            if _draws_at_random(my_systematic, w, u, a):
                return _wrong(f"{what} gives different ancestors when called twice on {shown}: "
                              f"it draws random numbers. Systematic resampling is a fixed "
                              f"function of the weights and the one uniform u (the comb "
                              f"p_j = (j + u)/N): use the given u, no generator, no "
                              f"bf.resampling.")
            return feedback
        # an argument changed in place: the engine's guard (bayesfilt.checks.guard)
        if np.asarray(out).dtype.kind == "f":
            float_indices = True
    if float_indices:
        return _wrong(f"{what} returns the right ancestors as floating-point numbers; indices "
                      f"must be integers (x[a] fails with a float array): np.searchsorted "
                      f"returns integers, or use .astype(int).")
    return Feedback(CORRECT, f"{what} agrees with bf.resampling.from_uniforms on all {len(cases)} "
                             f"test inputs (u = 0, a degenerate set, zero weights, unnormalised "
                             f"weights, one particle, N = 1000).")


# --------------------------------------------------------------------------
# Exercise 2 - the offspring count of particle 1 (a derivation)
# --------------------------------------------------------------------------

def _systematic_law(W: np.ndarray, M: int, i: int) -> tuple[float, float]:
    """Exact mean and variance of N_i under systematic resampling, from bf.resampling.

    N_i is a step function of the single uniform u; its steps are at the
    fractional parts of M C_k, so evaluating from_uniforms once between
    consecutive steps gives its law exactly.
    """
    MC = M * np.cumsum(W) / np.sum(W)
    cuts = np.unique(np.concatenate([[0.0, 1.0], MC - np.floor(MC)]))
    cuts = cuts[(cuts >= 0.0) & (cuts <= 1.0)]
    lengths = np.diff(cuts)
    mids = (cuts[:-1] + cuts[1:]) / 2
    n_i = np.array([np.sum(resampling.from_uniforms(W, np.full(M, u)) == i) for u in mids])
    mean = float(lengths @ n_i)
    return mean, float(lengths @ (n_i - mean) ** 2)


def _law_2(W: np.ndarray, M: int, i: int) -> np.ndarray:
    """[E N_i, Var N_i multinomial, Var N_i systematic, Var N_i residual]."""
    W = W / W.sum()
    MW = M * W
    floors = np.floor(MW)
    f = MW - floors
    R = M - floors.sum()
    _, var_sys = _systematic_law(W, M, i)
    # residual: floor(M W_i) fixed copies + a Binomial(R, f_i / R) draw
    var_res = R * (f[i] / R) * (1 - f[i] / R) if R > 0 else 0.0
    # multinomial: N_i ~ Binomial(M, W_i)
    return np.array([MW[i], M * W[i] * (1 - W[i]), var_sys, var_res])


_LABELS_2 = ("answer_2[0], the expected count E[N_1],",
             "answer_2[1], the variance of N_1 under multinomial resampling,",
             "answer_2[2], the variance of N_1 under systematic resampling,",
             "answer_2[3], the variance of N_1 under residual resampling,")


def _variants_2() -> list[list[tuple[float, str]]]:
    """For each entry, (plausible wrong value, what it means)."""
    W = np.array(WEIGHTS_2) / np.sum(WEIGHTS_2)
    M, i = M_2, PARTICLE_2
    w, MW = W[i], M * W[i]
    f = MW - math.floor(MW)
    R = M - float(np.sum(np.floor(M * W)))
    other = _law_2(np.array(WEIGHTS_2), M, 0)          # particle 0, for a numbering mix-up
    zero = ("is the value for particle 0 (weight 0.42); particles are numbered from 0, and "
            "particle 1 is the one with weight W^1 = 0.28.")
    std = "is a standard deviation; the question asks for the variance (its square)."
    return [
        [(w, "is the probability W^1 that one draw picks particle 1; over M = 10 draws the "
             "expected number of copies is M W^1."),
         (math.floor(MW), "is a whole number; an expected count need not be one: unbiasedness "
                          "says E[N_i] = M W^i exactly."),
         (math.ceil(MW), "is a whole number; an expected count need not be one: unbiasedness "
                         "says E[N_i] = M W^i exactly."),
         (M / len(W), "is M / N, the expected count of equal weights; particle 1 gets M W^1."),
         (other[0], zero)],
        [(MW, "is M W^1 (a Poisson variance); the multinomial count is binomial, "
              "Var(N_1) = M W^1 (1 - W^1)."),
         (w * (1 - w), "is the variance W^1 (1 - W^1) of one draw's indicator; the M independent "
                       "draws add up: M W^1 (1 - W^1)."),
         (MW * (1 - MW), "puts M W^1 inside the bracket; the formula is M W^1 (1 - W^1), with "
                         "the weight W^1 in (1 - W^1)."),
         (M * M * w * (1 - w), "has M^2; the variance of a sum of M independent indicators is M "
                               "times the variance of one: M W^1 (1 - W^1)."),
         (math.sqrt(M * w * (1 - w)), std),
         (other[1], zero)],
        [(M * w * (1 - w), "is the multinomial variance; the systematic comb puts the teeth 1/M "
                           "apart, so N_1 is always floor(M W^1) or ceil(M W^1): Var = f (1 - f) "
                           "with f = M W^1 - floor(M W^1)."),
         (f, "is f = M W^1 - floor(M W^1), the probability that N_1 takes the larger value; the "
             "variance of floor(M W^1) + Bernoulli(f) is f (1 - f)."),
         (1 - f, "is 1 - f, the probability of the smaller value; the variance of "
                 "floor(M W^1) + Bernoulli(f) is f (1 - f), with f = M W^1 - floor(M W^1)."),
         (0.0, "would mean that N_1 is always the same number, which happens only when M W^1 is "
               "a whole number; here it is not, so N_1 takes two values."),
         (0.25, "is 1/4, the variance of a fair coin; here the larger value has probability "
                "f = M W^1 - floor(M W^1), and Var = f (1 - f)."),
         (math.sqrt(f * (1 - f)), std)],
        [(f * (1 - f), "is f (1 - f), the systematic variance (or the residual one with R = 1). "
                       "The residual scheme draws R = M - sum_i floor(M W^i) points "
                       "multinomially from the residual weights f_i / R: Var = R (f/R)(1 - f/R) "
                       "= f (1 - f/R). Count R again."),
         (M * w * (1 - w), "is the multinomial variance over all M draws; in the residual scheme "
                           "the floor(M W^i) copies are fixed and only R = M - sum_i floor(M W^i) "
                           "draws are random: Var = f (1 - f/R)."),
         (f * (1 - f / M), "divides f by M; the residual weights f_i are normalised by their sum "
                           "R = M - sum_i floor(M W^i), not by M: Var = f (1 - f/R)."),
         (R * f * (1 - f / R), "has an extra factor R: R draws with probability f/R each give "
                               "Var = R (f/R)(1 - f/R) = f (1 - f/R)."),
         (math.sqrt(f * (1 - f / R)), std),
         (other[3], zero)]
        + [(f * (1 - f / r), "uses the wrong number of residual draws R: R = M - sum_i "
                             "floor(M W^i), with the floors of all four particles.")
           for r in range(2, M + 1) if r != R],
    ]


def exercise_2(answer) -> Feedback:
    """Check ``answer_2 = np.array([E N_1, Var multinomial, Var systematic, Var residual])``.

    Weights (0.42, 0.28, 0.18, 0.12), M = 10, particle 1; to 3 decimals. The
    systematic variance is computed exactly with ``bf.resampling.from_uniforms``
    (the count is a step function of u). Diagnoses per entry: W^1 for M W^1, a
    whole number for a mean, M/N; M W (Poisson), W (1 - W) without M, M W inside
    the bracket, M^2, a standard deviation; the multinomial variance for the
    systematic or residual one, f or 1 - f for f (1 - f), zero, 1/4; f (1 - f)
    for the residual (R forgotten or R = 1), f/M, an extra R, a wrong R;
    particle 0's values; the right numbers in the wrong order; a value close
    to the reference but not exact (a simulation's estimate).
    """
    what = "answer_2"
    if answer is None or answer is Ellipsis:
        return _not_attempted(what)
    a, bad = _real_array(answer, what)
    if bad is not None:
        return bad
    ref = _law_2(np.array(WEIGHTS_2), M_2, PARTICLE_2)
    if a.shape != (4,):
        if a.size == 4:
            return _wrong(f"{what} has four numbers in shape {a.shape}; give a flat array, "
                          f"np.array([E_N1, var_multinomial, var_systematic, var_residual]).")
        return _wrong(f"{what} must hold four numbers, np.array([E_N1, var_multinomial, "
                      f"var_systematic, var_residual]); got shape {a.shape}.")
    close = np.isclose(a, ref, rtol=0, atol=ATOL_HAND)
    if close.all():
        return Feedback(CORRECT, f"{what} matches the reference: all four schemes are unbiased "
                                 f"(the same E[N_1]), and systematic resampling, whose count "
                                 f"takes only the two whole numbers next to M W^1, adds the "
                                 f"least noise here.")
    if sorted(np.round(a, 3)) == sorted(np.round(ref, 3)):
        return _wrong(f"{what} has the right numbers in the wrong order: E[N_1], then the "
                      f"variances under multinomial, systematic and residual resampling.")
    variants = _variants_2()
    for k in range(4):
        if close[k]:
            continue
        for value, message in variants[k]:
            if abs(a[k] - value) <= ATOL_HAND and abs(value - ref[k]) > ATOL_HAND:
                return _wrong(f"{_LABELS_2[k]} {message}")
        if k > 0 and a[k] < -ATOL_HAND:
            return _wrong(f"{_LABELS_2[k]} is negative; a variance never is.")
        if abs(a[k] - ref[k]) <= 0.05 * abs(ref[k]) + 0.01:
            return _wrong(f"{_LABELS_2[k]} is close but not exact (a simulation's estimate, or "
                          f"rounded too early?): work it out with the formulas of section 2.1, "
                          f"to at least 3 decimals.")
        return _wrong(f"{_LABELS_2[k]} is too {'large' if a[k] > ref[k] else 'small'} (give at "
                      f"least 3 decimals).")
    return _wrong(f"{what} does not match the reference.")


# --------------------------------------------------------------------------
# Exercise 3 - the ESS threshold (an experiment)
# --------------------------------------------------------------------------

@functools.lru_cache(maxsize=1)
def _experiment_3() -> tuple[tuple[float, ...], tuple[float, ...]]:
    """(mean resamplings per record, RMSE in posterior sds), one entry per threshold."""
    lg = models.LinearGaussian(**LG_3)
    records = models.simulate_many(lg, RECORDS_3, T_3, np.random.default_rng(SEED_RECORDS_3))
    kfs = [kalman.kalman_filter(lg, ys) for ys in records.ys]
    counts, rmse = [], []
    for theta in THRESHOLDS_3:
        rng = np.random.default_rng(SEED_FILTERS_3)
        n, sq = 0, []
        for ys, kf in zip(records.ys, kfs):
            res = particle.particle_filter(lg, ys, N_3, rng, ess_threshold=theta)
            n += int(res.resampled.sum())
            sq.append(np.mean((res.means[:, 0] - kf.means[:, 0]) ** 2 / kf.covs[:, 0, 0]))
        counts.append(n / RECORDS_3)
        rmse.append(float(np.sqrt(np.mean(sq))))
    return tuple(counts), tuple(rmse)


def _within_3(a: np.ndarray, ref: np.ndarray) -> np.ndarray:
    return np.abs(a - ref) <= np.maximum(ATOL_3, RTOL_3 * np.abs(ref))


def _which_theta(value) -> float | None:
    """The threshold of THRESHOLDS_3 that ``value`` names, or None."""
    v, bad = _real_number(value, "theta")
    if bad is not None:
        return None
    for theta in THRESHOLDS_3:
        if math.isclose(v, theta, abs_tol=1e-9):
            return theta
    return None


def exercise_3(answer) -> Feedback:
    """Check ``answer_3 = (resamplings, theta_worst)`` for the ESS thresholds 0.1, 0.5, 0.9.

    ``resamplings``: the mean number of resamplings per record over the 20
    records of section 3, for each threshold, within 20 % (at least 1) of the
    reference, which covers any seeds. ``theta_worst``: the threshold with the
    largest RMSE (0.1 for every seed tried). Diagnoses: a total over the
    records, a fraction or a percentage of the 50 steps, the steps without
    resampling, the thresholds in reverse order, counts that fall as the
    threshold rises; for ``theta_worst``: an RMSE instead of a threshold, the
    smallest RMSE instead of the largest, a value that is not a threshold.
    """
    what = "answer_3"
    if answer is None or answer is Ellipsis:
        return _not_attempted(what)
    pair, bad = _pair(answer, what, "resamplings", "theta_worst")
    if bad is not None:
        if isinstance(answer, (np.ndarray, list, tuple)) and np.size(answer) == 3:
            return _wrong(f"{what} must be a pair (resamplings, theta_worst): the array of three "
                          f"mean counts, then the threshold with the largest RMSE.")
        return bad
    first, second = pair
    if np.ndim(first) == 0 and np.size(second) == 3:
        return _wrong(f"{what} is in the wrong order: first the array of three mean counts, then "
                      f"theta_worst.")
    counts, rmse = _experiment_3()
    ref = np.array(counts)
    a, bad = _real_array(first, f"{what}[0], the mean resamplings per record,")
    if bad is not None:
        return bad
    label = f"{what}[0], the mean number of resamplings per record,"
    if a.shape != (3,):
        return _wrong(f"{label} must hold three numbers, one for each threshold 0.1, 0.5, 0.9; "
                      f"got shape {a.shape}.")
    ok = _within_3(a, ref)
    if not ok.all():
        steps = float(T_3)
        for value, message in [
            (ref * RECORDS_3, f"is a total over the {RECORDS_3} records; divide by "
                              f"{RECORDS_3} for the mean per record."),
            (ref / steps, f"is a fraction of the {T_3} steps; give the number of resamplings "
                          f"per record (res.resampled.sum())."),
            (100 * ref / steps, f"is a percentage of the {T_3} steps; give the number of "
                                f"resamplings per record (res.resampled.sum())."),
            (steps - ref, "counts the steps without resampling; count those with "
                          "(res.resampled is True where the filter resampled)."),
            (ref[::-1], "lists the thresholds in reverse order; give them for 0.1, 0.5, 0.9."),
        ]:
            if _within_3(a, value).all() and not _within_3(value, ref).all():
                return _wrong(f"{label} {message}")
        if np.any(np.diff(a) < 0):
            return _wrong(f"{label} falls as the threshold rises; a higher threshold theta N is "
                          f"reached sooner, so the filter resamples more often. Check which "
                          f"ess_threshold each run used.")
        k = int(np.flatnonzero(~ok)[0])
        return _wrong(f"{label} is too {'large' if a[k] > ref[k] else 'small'} for theta = "
                      f"{THRESHOLDS_3[k]} (beyond Monte Carlo noise). Run the 20 records of "
                      f"section 3 (batch_lg, N = {N_3}) with ess_threshold={THRESHOLDS_3[k]} and "
                      f"average res.resampled.sum() over them.")
    worst = THRESHOLDS_3[int(np.argmax(rmse))]
    best = THRESHOLDS_3[int(np.argmin(rmse))]
    theta = _which_theta(second)
    if theta is None:
        v, bad = _real_number(second, f"{what}[1], theta_worst,")
        if bad is not None:
            return bad
        if 0.0 < v < 0.5 and v not in THRESHOLDS_3:
            return _wrong(f"{what}[1], theta_worst, is not one of the thresholds "
                          f"{list(THRESHOLDS_3)}; give the threshold whose RMSE is largest, not "
                          f"the RMSE itself.")
        return _wrong(f"{what}[1], theta_worst, must be one of the thresholds "
                      f"{list(THRESHOLDS_3)}.")
    if theta != worst:
        smallest = " (did you take the smallest RMSE, np.argmin, instead of the largest?)" \
            if theta == best else ""
        return _wrong(f"{what}[1], theta_worst = {theta}, is not the threshold with the largest "
                      f"RMSE{smallest}. Resampling adds noise, but waiting too long lets the "
                      f"weights degenerate between resamplings: compare the RMSE of the three "
                      f"thresholds, each the square root of the mean over the records of "
                      f"rmse_in_sd(res, kf) ** 2.")
    return Feedback(CORRECT, f"{what} is right: a low threshold resamples rarely and lets the ESS "
                             f"fall far between resamplings, which costs accuracy; the two higher "
                             f"thresholds differ by less than the Monte Carlo noise (rerun with "
                             f"another seed: their order can flip), and 0.5 gets there with about "
                             f"half the resamplings of 0.9.")


# --------------------------------------------------------------------------
# Exercise 4 - tuning roughening (an experiment)
# --------------------------------------------------------------------------

def _roughened_sir(model, ys, N: int, rng, K: float):
    """Section 7's SIR filter with roughening: weighted means and covariances per step."""
    res = particle.particle_filter(model, ys, N, rng, ess_threshold=1.0, roughening=K)
    return res.means, res.covs


def _nees(errors: np.ndarray, covs: np.ndarray) -> np.ndarray:
    out = np.full(len(errors), np.inf)
    for t in range(len(errors)):
        with contextlib.suppress(ValueError):
            out[t] = gaussian.squared_mahalanobis(errors[t], covs[t])
    return out


@functools.lru_cache(maxsize=2)
def _experiment_4(n_particles: int = N_4) -> tuple[float, str, tuple[int, ...]]:
    """(smallest K of K_VALUES_4 that keeps track, its NEES verdict, lost runs of the Ks tried).

    The K are tried in increasing order and the search stops at the first one
    that loses at most MAX_LOST_4 runs, so every smaller K lost more.
    """
    vehicle = models.range_bearing()
    sims = models.simulate_many(vehicle, RUNS_4, T_4, np.random.default_rng(SEED_RECORDS_4),
                                x0=models.RANGE_BEARING_TRUE_START)
    lost_counts = []
    for K in K_VALUES_4:
        rng = np.random.default_rng(SEED_FILTERS_4)
        nees, lost = np.empty((RUNS_4, T_4)), 0
        for r, (xs, ys) in enumerate(zip(sims.xs, sims.ys)):
            m, c = _roughened_sir(vehicle, ys, n_particles, rng, K)
            nees[r] = _nees(xs - m, c)
            lost += int(np.linalg.norm(models.positions(vehicle, xs - m)[-1]) > LOST_METRES_4)
        lost_counts.append(lost)
        if lost <= MAX_LOST_4:
            verdict = VERDICTS_4[0] if np.median(nees[:, T_FROM_4:]) > NEES_DOF_4 else VERDICTS_4[1]
            return K, verdict, tuple(lost_counts)
    return math.nan, "", tuple(lost_counts)


def _which_k(value) -> float | None:
    v, bad = _real_number(value, "K")
    if bad is not None:
        return None
    for K in K_VALUES_4:
        if math.isclose(v, K, abs_tol=1e-9):
            return K
    return None


_VERDICT_WORDS = {
    "overconfident": "overconfident", "above": "overconfident", "above 4": "overconfident",
    "conservative": "conservative", "below": "conservative", "below 4": "conservative",
}


def exercise_4(answer, n_particles: int = N_BEFORE_4) -> Feedback:
    """Check ``answer_4 = (K_min, verdict)`` for roughened SIR on the twenty runs of section 6.

    ``n_particles``: the N of the answer cell's experiment, ``N_4`` (500; the check cell passes
    it) or, for a check cell written before issue 13 that passes nothing, 2000.

    ``K_min``: the smallest K of (0.05, 0.1, 0.5, 1.0) that loses at most 5 of
    the 20 runs (final position error above 5 m); ``verdict``: for that K,
    "overconfident" if the median NEES over the runs and the steps t >= 30 is
    above 4, else "conservative". Both hold for every seed tried. Diagnoses: a
    K that loses too many runs, a larger K than needed, a number that is not
    one of the four K (a count of lost runs), the pair swapped, a verdict that
    reads the NEES the wrong way round or is not one of the two words.
    """
    what = "answer_4"
    if n_particles not in (N_4, N_BEFORE_4):
        return _wrong(f"the check knows the experiment with N_4 = {N_4} particles (the answer cell "
                      f"gives it); got n_particles = {n_particles!r}.")
    if answer is None or answer is Ellipsis:
        return _not_attempted(what)
    pair, bad = _pair(answer, what, "K_min", "verdict")
    if bad is not None:
        return bad
    first, second = pair
    if isinstance(first, str) and not isinstance(second, str) and first.strip().lower() in _VERDICT_WORDS:
        return _wrong(f"{what} is in the wrong order: first K_min, then the verdict.")
    K = _which_k(first)
    if K is None:
        v, bad = _real_number(first, f"{what}[0], K_min,")
        if bad is not None:
            return bad
        hint = (" (a number of lost runs? give the roughening constant K itself)"
                if float(v).is_integer() and v not in K_VALUES_4 else "")
        return _wrong(f"{what}[0], K_min, must be one of the roughening constants "
                      f"{list(K_VALUES_4)}{hint}.")
    K_ref, verdict_ref, lost = _experiment_4(n_particles)
    if K < K_ref:
        return _wrong(f"{what}[0]: with K = {K} the jitter is too small to separate the copies: "
                      f"the filter loses more than {MAX_LOST_4} of the {RUNS_4} runs (final "
                      f"position error above {LOST_METRES_4:g} m). Did you count the runs kept "
                      f"instead of those lost, or the error at the first step instead of the "
                      f"last?")
    if K > K_ref:
        return _wrong(f"{what}[0]: K = {K} keeps track, but a smaller K of the list also loses at "
                      f"most {MAX_LOST_4} runs; the question asks for the smallest.")
    if not isinstance(second, str):
        return _wrong(f"{what}[1], the verdict, must be one of the words {list(VERDICTS_4)}, got "
                      f"{type(second).__name__}.")
    verdict = _VERDICT_WORDS.get(second.strip().lower())
    if verdict is None:
        return _wrong(f"{what}[1], the verdict, must be one of {list(VERDICTS_4)}, got "
                      f"{second!r}.")
    if verdict != verdict_ref:
        return _wrong(f"{what}[1]: look again at the median NEES of K = {K} over all runs and the "
                      f"steps t >= {T_FROM_4} (np.median(nees[:, {T_FROM_4}:])). The NEES is the "
                      f"squared error in the filter's own standard deviations, with mean d = "
                      f"{NEES_DOF_4} for a consistent filter: above {NEES_DOF_4}, the errors are "
                      f"larger than the covariance claims (overconfident); below, the covariance "
                      f"is larger than the errors (conservative).")
    return Feedback(CORRECT, f"{what} is right: too little jitter leaves the copies together and "
                             f"the cloud loses the vehicle; enough jitter keeps track, at the "
                             f"price of a covariance larger than the errors (roughening is "
                             f"artificial process noise).")


from . import register as _register  # noqa: E402

_register(globals())
