"""Checks of chapter 05's exercises (references by bf.particle, bf.models).
One line per exercise (the notebook variables each reads with ``given``, in brackets)::

    exercise_1(my_log_normalize): normalised log-weights and their log sum, without
        under- or overflow [log_w_under_1, log_w_over_1];
    exercise_2(answer_2): three effective sample sizes [weights_a_2, weights_b_2,
        log_weights_c_2];
    exercise_3(log_increment): the log increment log p(y_t | x_(t-1)) of the optimal
        proposal, on seven inputs [lg];
    exercise_4(answer_4): the R of the smallest mean ESS, bootstrap at t = 5 and optimal
        proposal at t = 39, and the function mean_ess(R) the statement asks for, called
        for each R [R_values, mean_ess, N_4, T_4, records_4, t_boot_4, t_opt_4,
        seeds_4];
    exercise_5(answer_5): the models whose optimal proposal is not the transition.
"""

from __future__ import annotations

import functools
import math
import numbers
import re
from typing import NamedTuple

import numpy as np

from .. import models, particle
from . import (CORRECT, INCORRECT, NOT_ATTEMPTED, Feedback, _as_numbers, _combine, _each_case, _is, _not_attempted,
               _tolerance, _wrong, compare_function, compare_number, given, register as _register)

LOG_W = (-1000.0, -1001.0, -1002.0, -np.inf)         # exercise 1's statement; exercise 2 (c)
LOG_W_OVER = (800.0, 799.5)                          # exercise 1's statement: e^l overflows
ESS_GIVEN = ((0.4, 0.3, 0.2, 0.1), (1.0, 1.0, 2.0))   # exercise 2 (a), (b)
A, C, Q, R, S = 0.9, 1.0, 1.0, 0.1, 1.1              # lg of section 4 (exercises 3-5); S = C Q C^T + R
R_VALUES, N_4, T_4, RUNS_4, T_BOOT, T_OPT, SEEDS_4 = (0.01, 0.1, 1.0), 500, 40, 10, 5, 39, (14, 15)  # section 7
TOL, ATOL_HAND = 1e-8, 2e-3     # computed answers; an ESS by hand, to 3 decimals
SAMPLER = "section 15"          # "The optimal proposal: its sampler, and the damped particle"
LSE, NORM, S_ = "m + log sum_j e^(l_j - m)", "log W^(i) = l^(i) - log_sum", "S = C Q C^T + R"
SHIFT = f"Factor out the largest log-weight m first: log sum_j e^(l_j) = {LSE}."
ESS, ASK = "1 / sum_i (W^(i))^2", "Given x_(t-1), does y_t depend on the new process noise?"
# exercise 5: for each model, whether its optimal proposal differs from the transition ("<letter> yes"), as digests
_IN_5 = {"a": "sha256:ch05-ex5:7a3ba04bb4bdd1eed29b", "b": "sha256:ch05-ex5:2f85527d6f509b1960e6",
         "c": "sha256:ch05-ex5:097429d1b0e9be7cb7ae"}


def _first(prefix: str, table) -> Feedback:
    """"Not yet": the prefix, then the message of the first row (hit, message) that hits."""
    return _wrong(prefix + next(m for hit, m in table if hit))


def _close(a, e, rtol: float = TOL, atol: float = TOL) -> bool:
    """Same shape, the same infinities at the same places, finite entries within the tolerances."""
    a, e = np.asarray(a, dtype=float), np.asarray(e, dtype=float)
    if a.shape != e.shape or np.isnan(a).any() or np.isnan(e).any():
        return False
    f = np.isfinite(e)
    return bool(np.array_equal(a[~f], e[~f]) and np.allclose(a[f], e[f], rtol=rtol, atol=atol))


# Exercise 1: the output's form, then log_sum, then log_W, each against its named mistakes ------------------
def exercise_1(my_log_normalize) -> Feedback:
    def _pair_1(out, expected, what: str = "the output") -> Feedback:
        lw, ref_W, ref = expected                             # the input, the library's pair
        if out is None:
            return _not_attempted(what)
        if isinstance(out, np.ndarray) and out.shape == lw.shape:
            return _wrong(f"{what}: one array; return the pair (log_W, log_sum), as bf.particle.log_normalize does.")
        if not isinstance(out, (tuple, list)) or len(out) != 2:
            n = f" of length {len(out)}" if isinstance(out, (tuple, list)) else ""
            return _wrong(f"{what}: my_log_normalize must return a pair (log_W, log_sum), got {type(out).__name__}{n}.")
        if np.ndim(out[0]) == 0 and np.ndim(out[1]) == 1 and np.size(out[1]) == lw.size > 1:
            return _wrong(f"{what}: the pair is in the wrong order: first the array log_W, then the number log_sum.")
        log_W, s = out
        # float32 (either part): its round-off, relative to the largest log-weight the sums went through
        scale = float(np.max(np.abs(lw[np.isfinite(lw)]), initial=1.0))
        rtol, tol = max(_tolerance(log_W, TOL, TOL, scale), _tolerance(s, TOL, TOL, scale))
        close = functools.partial(_close, rtol=rtol, atol=tol)
        s = s.item() if isinstance(s, np.ndarray) and s.size == 1 else s
        if isinstance(s, (bool, np.bool_)) or not isinstance(s, numbers.Real):
            return _wrong(f"{what}: log_sum must be one number, got {type(s).__name__}.")
        if math.isnan(s := float(s)):
            return _wrong(f"{what}: log_sum is NaN: exp(l) overflowed before the log. {SHIFT}")
        try:
            a = np.asarray(log_W, dtype=float)
        except Exception:  # noqa: BLE001 - an answer numpy cannot read is feedback
            return _wrong(f"{what}: log_W must be an array of numbers, got {type(log_W).__name__}.")
        fin, m, zero = lw[np.isfinite(lw)], float(np.max(lw)), np.isneginf(ref_W)
        if not close(s, ref):
            flow = "underflowed to 0" if s < 0 else "overflowed"
            return _first(f"{what}: ", [(math.isinf(s), f"log_sum is {s}: exp(l) {flow} before the log. {SHIFT}")]
                          + [(close(s, v), msg) for v, msg in [
                (ref - m, f"log_sum is log sum_j e^(l_j - m): add the largest log-weight m back ({LSE})."),
                (ref - math.log(lw.size), "log_sum is the log of the mean weight, not of the sum."),
                (ref - math.log(fin.size) if fin.size < lw.size else math.nan,
                 "log_sum is the log of the mean over the nonzero weights, not of the sum."),
                (math.exp(ref) if ref < 700 else math.nan, "log_sum is the sum of the weights, not its log."),
                (ref / math.log(10), "log_sum uses log10; log-weights are natural logarithms (np.log)."),
                (m, "log_sum is only the largest log-weight m; add log sum_j e^(l_j - m)."),
                (np.sum(fin), "log_sum is the sum of the log-weights (the log of their product)."),
                (-ref, "log_sum has the wrong sign.")]]
                          + [(True, f"log_sum is too {'large' if s > ref else 'small'}: {SHIFT}")])
        if close(a, ref_W):
            return Feedback(CORRECT, "")
        if a.shape != ref_W.shape:
            return _wrong(f"{what}: log_W has shape {a.shape}; it must have the shape of log_w, {ref_W.shape}"
                          + (": one normalised log-weight per particle." if a.size == 1 else "."))
        d, bad = a[~zero] - ref_W[~zero], ~np.isclose(a, ref_W, rtol=tol, atol=tol) & ~zero
        live, first = ~np.isneginf(lw), "Subtract the largest log-weight before np.exp."
        return _first(f"{what}: ", [(close(a, v) and not close(v, ref_W), msg) for v, msg in [
            (np.exp(ref_W), f"log_W holds the normalised weights W^(i) themselves; return {NORM}."),
            (lw - m, "log_W is only shifted by m, not normalised: subtract log sum_j e^(l_j), not m."),
            (s - lw, f"log_W has the wrong sign: {NORM}."),
            (lw / s if s else np.nan, f"log_W divides by log_sum; in logs it is a subtraction: {NORM}."),
            (ref_W / math.log(10), "log_W uses log10; use natural logarithms throughout."),
            (np.where(live, -math.log(max(int(live.sum()), 1)), -np.inf),
             "log_W gives every nonzero particle the same share: weigh each by e^(l^(i)).")]] + [
            (np.isnan(a).any(), f"log_W contains NaN: exp(l) underflowed (0/0) or overflowed. {first}"),
            (np.isposinf(a).any(), f"log_W contains +inf: exp(l) overflowed. {first}"),
            (not np.isneginf(a[zero]).all(), "a particle with log-weight -inf (weight 0) must keep log W = -inf; "
                                             f"yours gives it {np.array2string(a[zero][:3])}."),
            (np.isneginf(a[~zero]).any(), "log_W is -inf for a particle whose weight is not zero: exp(l) "
                                          f"underflowed before the log. Stay in logs: {NORM}."),
            (np.allclose(d, d[0], rtol=0, atol=tol), f"log_W is off by the same constant in every entry: not "
                                                      f"normalised ({NORM})."),
            (True, f"log_W differs from the normalised log-weights at {int(bad.sum())} of {a.size} entries "
                   f"(the first at index {int(np.argmax(bad))}).")])
    far = np.random.default_rng(505).normal(-5000.0, 20.0, size=50)   # with two zero weights;
    far[[7, 30]] = -np.inf                                             # last, a spread of 800
    under, over = given("log_w_under_1", LOG_W), given("log_w_over_1", LOG_W_OVER)   # the statement's arrays
    cases = [(np.array(v, dtype=float),) for v in (under, [0.0] * 3, [800.0, 799.5, 795.0], [3.7], far,
                                                   [-2, 0.5, 1e-3, -np.inf, 0.25], [0, -800, -5], over)]
    fb = compare_function(my_log_normalize, lambda lw: (lw, *particle.log_normalize(lw)), cases,
                          what="my_log_normalize", compare=_pair_1, forbidden=[
                              ({name}, f"{name}, which the statement rules out: numpy only, log-sum-exp by hand "
                                       f"({LSE}).") for name in ("logsumexp", "log_normalize")])
    return Feedback(CORRECT, f"{fb.message} They include underflow, overflow, zero weights, one particle, a "
                             f"spread of 800.") if fb.correct else fb


# Exercise 2: the first entry off the reference, against the mistakes for its weights ------------------------
def exercise_2(answer) -> Feedback:
    def _ess_mistakes(w) -> list[tuple[float, str]]:
        w = np.asarray(w, dtype=float)
        W, n = w / w.sum(), w.size
        return [(np.sum(W ** 2), f"is the sum of the squared weights; the ESS is its reciprocal, {ESS}."),
                (1 / np.sum(w ** 2), "is 1 / sum_i (w^(i))^2 of the weights as given: normalise them first."),
                (n / (1 + np.var(n * W, ddof=1)), "uses ddof=1 in N / (1 + var(N W)); section 6's identity "
                                                  "takes np.var(N * W) (ddof=0)."),
                (1 / W.max(), f"is 1 / max_i W^(i), another measure of degeneracy; the ESS is {ESS}."),
                (np.count_nonzero(w), f"counts the nonzero weights; the ESS weighs them: {ESS}.")]
    given_w = [np.array(given(name, value), dtype=float) for name, value in (
        ("weights_a_2", ESS_GIVEN[0]), ("weights_b_2", ESS_GIVEN[1]))]
    log_w = np.array(given("log_weights_c_2", LOG_W), dtype=float)
    w, ww = "answer_2", ("the weights (a)", "the unnormalised weights (b)", "the log-weights (c)")
    if answer is None or answer is Ellipsis:
        return _not_attempted(w)
    seq = isinstance(answer, (list, tuple)) or np.ndim(answer) == 1
    if seq and [isinstance(v, float) and math.isnan(v) for v in answer] == [False, False, True]:
        return _wrong(f"{w}[2], the ESS of {ww[2]}, is NaN: np.exp(-1000) underflows to 0 (0 / 0). Only "
                      f"differences of log-weights matter: subtract the largest one before np.exp (section 5).")
    a, bad = _as_numbers(answer, w)
    if bad is not None or a.shape != (3,):
        return bad or _wrong(f"{w} must be a flat array of three numbers, np.array([ESS_a, ESS_b, ESS_c]); "
                             f"got shape {a.shape}.")
    ref = np.array([particle.ess(given_w[0]), particle.ess(given_w[1]),
                    particle.ess(np.exp(particle.log_normalize(log_w)[0]))])
    close = np.isclose(a, ref, rtol=0, atol=ATOL_HAND)
    if close.all():
        return Feedback(CORRECT, f"{w} matches the reference. (c) depends only on the differences of the "
                                 f"log-weights: shift by the largest, then exponentiate.")
    if sorted(np.round(a, 3)) == sorted(np.round(ref, 3)):
        return _wrong(f"{w} has the right numbers in the wrong order: (a), (b), (c).")
    fin, k = log_w[np.isfinite(log_w)], int(np.argmin(close))
    w10 = 10.0 ** (fin - fin.max())
    mistakes = [_ess_mistakes(given_w[0]), _ess_mistakes(given_w[1]), [
        (1 / np.sum(fin ** 2), "treats the log-weights as weights; the weights are e^l."),
        (w10.sum() ** 2 / np.sum(w10 ** 2), "uses 10^l; the weights are e^l (natural logarithms)."),
        (float(fin.size), f"is the ESS of {fin.size} equal weights; but only the ratios e^(l_i - max l) matter."),
        (float(log_w.size), f"counts all {log_w.size} particles as equal; a weight e^-inf is 0.")]
        + _ess_mistakes(np.exp(log_w - fin.max()))]
    return _first(f"{w}[{k}], the ESS of {ww[k]}, ", [(abs(a[k] - v) <= ATOL_HAND, m) for v, m in mistakes[k]]
                  + [(a[k] < 1 - ATOL_HAND, "is below 1; the ESS lies between 1 and N (equal weights)."),
                     (True, f"is too {'large' if a[k] > ref[k] else 'small'} (give at least 3 decimals).")])


# Exercise 3: eq. (8) with the library's optimal proposal, on 7 (x_prev, y) ---------------------------------
def _lg(r: float = R):
    return models.LinearGaussian(A=[[A]], C=[[C]], Q=[[Q]], R=[[r]], m0=[0.0], P0=[[1.0]])


def _g(var: float, a: float):
    """log N(y; a x_prev, var) as a function of (x_prev, y)."""
    return lambda x, y: -0.5 * math.log(2 * math.pi * var) - 0.5 * (y - a * x) ** 2 / var


def _mistakes_3(A, C, Q, R) -> list:
    """The named mistakes of log_increment for the 1-D model (A, C, Q, R) (G = 1), S = C Q C + R."""
    S = C * Q * C + R
    return [
        (_g(R, C * A), f"uses the variance R alone, the bootstrap's likelihood; y_t = C x_t + v_t with "
                       f"x_t ~ N(A x_(t-1), Q): {S_}."),
        (_g(C * Q * C, C * A), f"uses C Q C^T alone: R is missing from {S_}."),
        (_g(S, C), "centres y on C x_prev; the state moves first: C A x_prev."),
        (_g(R, 1.0), f"is log N(y; x_prev, R); the mean is C A x_prev, {S_}."),
        (_g(C * A * Q * A * C + R, C * A), f"scales the noise by A, added after A: {S_}, without A."),
        (_g(S ** 2, C * A), f"uses {S_} as a standard deviation; it is a variance (scipy.stats.norm takes sqrt(S))."),
        (_g(math.sqrt(S), C * A), "uses sqrt(S) as the variance; S is the variance."),
        (_g((1 - Q * C / S * C) * Q, C * A), f"uses the proposal's variance Sigma = (I - K C) Q; p(y_t | x_(t-1)) "
                                             f"has {S_}."),
        (lambda x, y: math.exp(_g(S, C * A)(x, y)), "returns alpha; the exercise asks for its logarithm."),
        (lambda x, y: -0.5 * (y - C * A * x) ** 2 / S, "misses the constant -1/2 log(2 pi S); log alpha is a "
                                                       "log-density (it estimates the evidence)."),
        (lambda x, y: _g(S, C * A)(x, y) / math.log(10), "uses log10; log-densities are natural logs."),
        (lambda x, y: -_g(S, C * A)(x, y), "has the wrong sign: log alpha = log N(y; C A x_prev, S).")]


MISTAKES_3 = _mistakes_3(A, C, Q, R)


def exercise_3(log_increment) -> Feedback:
    """log_increment(x_prev, y) against eq. (8) with bf.particle.optimal_proposal of lg, on seven inputs."""
    lg = given("lg", None)
    lg = _lg() if lg is None else lg
    num = lambda M: float(np.ravel(M)[0])  # noqa: E731
    G = 1.0 if lg.G is None else num(lg.G)
    mistakes = _mistakes_3(num(lg.A), num(lg.C), G * num(lg.Q) * G, num(lg.R))

    def _increment(x_prev: float, y: float) -> tuple[float, float, float]:
        """(log alpha from the three densities at one draw, x_prev, y): messages name the input."""
        X_prev, Y = np.array([[x_prev]]), np.array([y])
        opt = particle.optimal_proposal(lg)
        X = opt.sample(np.random.default_rng(0), X_prev, Y, 1)
        return float(lg.measurement_logpdf(Y, X)[0] + lg.transition_logpdf(X, X_prev)[0]
                     - opt.logpdf(X, X_prev, Y, 1)[0]), x_prev, y
    def _number_3(out, expected, what: str = "the output") -> Feedback:   # a wrong number: where, a hint
        fb = compare_number(out, expected[0], what=what, rtol=TOL, atol=TOL)
        v = out.item() if isinstance(out, np.ndarray) and out.size == 1 else out
        hint = isinstance(v, numbers.Real) and not isinstance(v, bool) and math.isfinite(v)
        return _wrong(f"{fb.message[:-1]}: work out the mean and variance of y_t = C x_t + v_t, with x_t ~ "
                      f"N(A x_(t-1), Q), given x_(t-1).") if fb.status == INCORRECT and hint else fb
    drawn = np.random.default_rng(303).normal(0.0, 2.0, size=(3, 2)).tolist()
    cases = [(1.0, 2.0), (0.0, 0.0), (-2.5, 1.0), (4.0, -3.0)] + [tuple(c) for c in drawn]
    fb = compare_function(log_increment, _increment, cases, what="log_increment", compare=_number_3,
                          mistakes=[(lambda x, y, f=f: (f(x, y), x, y), m) for f, m in mistakes])
    return Feedback(CORRECT, f"{fb.message} It is eq. (8) for bf.particle.optimal_proposal, whatever the draw "
                             f"x_t.") if fb.correct else fb


# Exercise 4: section 7's experiment for each R, then a table of verdicts ------------------------------------
class _Setup4(NamedTuple):
    """Section 7's experiment as the statement gives it (the answer cell's variables)."""
    n: int                  # N_4, particles
    T: int                  # T_4, steps per record
    runs: int               # records_4, records per R
    t_boot: int             # t_boot_4, the bootstrap's step
    t_opt: int              # t_opt_4, the optimal proposal's step
    seeds: tuple            # seeds_4, (records, filters)


SETUP_4 = _Setup4(N_4, T_4, RUNS_4, T_BOOT, T_OPT, SEEDS_4)


def _setup_4() -> _Setup4:
    """The statement's numbers, from the notebook where it has them."""
    return _Setup4(int(given("N_4", N_4)), int(given("T_4", T_4)), int(given("records_4", RUNS_4)),
                   int(given("t_boot_4", T_BOOT)), int(given("t_opt_4", T_OPT)),
                   tuple(int(v) for v in given("seeds_4", SEEDS_4)))


@functools.lru_cache(maxsize=8)
def _ess_runs(r: float, setup: _Setup4 = SETUP_4) -> tuple[np.ndarray, np.ndarray]:
    """The ESS (records, T) of the bootstrap and of the optimal proposal in section 7's experiment with R = r,
    the statement's seeds: one generator for the records, one per filter, each afresh for each R."""
    lg, records = _lg(r), np.random.default_rng(setup.seeds[0])
    runs = [(p, np.random.default_rng(setup.seeds[1]), []) for p in (None, particle.optimal_proposal(lg))]
    for _ in range(setup.runs):
        ys = models.simulate(lg, setup.T, records).ys
        for p, rng, ess in runs:
            ess.append(particle.particle_filter(lg, ys, setup.n, rng, proposal=p, ess_threshold=0).ess)
    return np.array(runs[0][2]), np.array(runs[1][2])


def _experiment(r_values=R_VALUES, setup: _Setup4 = SETUP_4) -> tuple[float, float]:
    """(R of the smallest mean bootstrap ESS at t_boot, R of the smallest optimal ESS at t_opt)."""
    means = [[boot[:, setup.t_boot].mean(), opt[:, setup.t_opt].mean()]
             for boot, opt in (_ess_runs(r, setup) for r in r_values)]
    return tuple(r_values[int(i)] for i in np.argmin(means, axis=0))


def _mean_ess(fun, r_values, setup: _Setup4 = SETUP_4) -> Feedback:
    """mean_ess(R), the statement's helper, against section 7's experiment for each R."""
    tb, to, runs = setup.t_boot, setup.t_opt, setup.runs

    def judge(out, where, args) -> Feedback:
        (r,), what = args, f"mean_ess({args[0]:g})"
        boot, opt = _ess_runs(r, setup)
        ref = np.array([boot[:, tb].mean(), opt[:, to].mean()])
        a, bad = _as_numbers(out, what)
        if bad is not None or a.shape != (2,):
            return bad or _wrong(f"{what} must return a pair of numbers (the bootstrap's mean ESS at t = {tb}, "
                                 f"the optimal proposal's at t = {to}); got shape {a.shape}.")
        if np.allclose(a, ref, rtol=1e-6):
            return Feedback(CORRECT, "")
        variants = [(ref[::-1], "returns the pair in the wrong order: first the bootstrap's ESS, then the "
                                "optimal's.")]
        variants += [([boot[:, k].mean(), ref[1]], f"reads the bootstrap's ESS at t = {k}: index {tb}.")
                     for k in (tb - 1, tb + 1) if 0 <= k < setup.T]
        variants += [([ref[0], opt[:, k].mean()], f"reads the optimal proposal's ESS at t = {k}: index {to}"
                                                  + (" (or -1)." if to == setup.T - 1 else "."))
                     for k in (to - 1,) if k >= 0]
        variants += [
            ([boot[-1, tb], opt[-1, to]], f"returns the ESS of the last record only; average over the {runs} "
                                          f"records."),
            ([np.median(boot[:, tb]), np.median(opt[:, to])], "returns medians; average over the records "
                                                              "(np.mean)."),
            ([boot[:, tb].sum(), opt[:, to].sum()], f"returns sums over the records; average them (divide by "
                                                    f"{runs}).")]
        for value, message in variants:
            if np.allclose(a, value, rtol=1e-6):
                return _wrong(f"{what} {message}")
        return _wrong(f"{what} does not reproduce section 7's experiment with the statement's seeds: one "
                      f"generator np.random.default_rng({setup.seeds[0]}) for the {runs} records of each R, and "
                      f"for each filter its own np.random.default_rng({setup.seeds[1]}), made afresh for each R "
                      f"(N = {setup.n}, ess_threshold=0).")
    return _each_case(fun, "mean_ess", [(r,) for r in r_values], ["" for _ in r_values], judge)


def _answer_4(answer, r_values, setup: _Setup4 = SETUP_4) -> Feedback:
    def _which_r(v) -> float | None:
        if isinstance(v, (bool, np.bool_)) or not isinstance(v, (str, numbers.Real, np.ndarray)):
            return None
        try:
            v = float(v.strip().lower().replace(" ", "").removeprefix("r=") if isinstance(v, str) else v)
        except (TypeError, ValueError):
            return None
        return next((r for r in r_values if math.isclose(v, r, rel_tol=1e-9)), None)
    w, listed, tb, to = "answer_4", ", ".join(f"{r:g}" for r in r_values), setup.t_boot, setup.t_opt
    if answer is None or answer is Ellipsis:
        return _not_attempted(w)
    items = list(np.asarray(answer, dtype=object).ravel()) if isinstance(answer, np.ndarray) else answer
    if not isinstance(items, (list, tuple)) or len(items) != 2:
        got = f"{len(items)} value(s)" if isinstance(items, (list, tuple)) else type(answer).__name__
        return _wrong(f"{w} must be a pair of values of R, (R of the bootstrap's smallest mean ESS at t = {tb}, R "
                      f"of the optimal proposal's smallest mean ESS at t = {to}), each one of {listed}; got {got}.")
    if None in (chosen := tuple(_which_r(v) for v in items)):
        k = chosen.index(None)
        ess = isinstance(items[k], numbers.Real) and not isinstance(items[k], bool) and float(items[k]) >= 1.0
        return _wrong(f"{w}[{k}] is {items[k]!r}, not one of the values of R ({listed})"
                      + ("; give the value of R, not the ESS you measured." if ess else "."))
    boot, opt = expected = _experiment(r_values, setup)
    if chosen == expected:
        return Feedback(CORRECT, f"{w} is right: a precise sensor ruins the bootstrap's blind draws; the "
                                 f"optimal proposal removes that spread, and what is left comes from the "
                                 f"particles' different pasts.")
    average = f"Average over the {setup.runs} records (one can mislead), with ess_threshold=0"
    last = " or -1" if to == setup.T - 1 else ""
    return _first(w, [
        (chosen == (opt, boot) and boot != opt, f" has the two values swapped: first the bootstrap (t = {tb}), "
                                                f"then the optimal proposal (t = {to})."),
        (chosen[0] != boot, f"[0] is not the R of the bootstrap's smallest mean ESS at t = {tb} (index {tb}). For "
         f"each R, how many of the blind draws land where N(y_t; x_t, R) is large? {average}."),
        (chosen[1] == boot, f"[1] ranks the R like the bootstrap ({w}[0] is right). At t = {to} (index {to}{last}, "
         f"not {tb}) the increment p(y_t | x_(t-1)^(i)) does not depend on the new draw, only on the particle's "
         f"past."),
        (True, f"[1] is not the R of the optimal proposal's smallest mean ESS at t = {to} (index {to}{last}; {w}[0] "
               f"is right). {average} and its own optimal_proposal for each R.")])


def exercise_4(answer) -> Feedback:
    """answer_4 = (R_boot, R_opt) among R_values; the statement's mean_ess(R) is called for each R."""
    r_values = tuple(float(r) for r in given("R_values", R_VALUES))
    setup = _setup_4()
    value, fun = _answer_4(answer, r_values, setup), given("mean_ess", None)
    if fun is None:                       # no notebook (a unit test): the pair alone
        return value
    helper = _mean_ess(fun, r_values, setup)
    if helper.status == NOT_ATTEMPTED and value.status != NOT_ATTEMPTED:
        return _wrong("mean_ess is not written yet: the statement asks for the experiment as a function of R, "
                      "and the check calls it for each R.")
    return value if helper.correct else _combine([("answer_4", value), ("mean_ess", helper)])


# Exercise 5: the letters, against the models whose y_t sees the new process noise given x_(t-1) ------------
def exercise_5(answer) -> Feedback:
    def _letters(answer) -> set[str] | None:
        """The set of letters an answer names, or None when it is not a list of a, b, c."""
        if isinstance(answer, str):
            tokens = [t for t in re.findall(r"[a-z]+", answer.lower()) if t != "and"]
            items = [c for t in tokens for c in t] if all(set(t) <= set("abc") for t in tokens) else ["?"]
        elif isinstance(answer, (list, tuple, set, frozenset, np.ndarray)):
            items = [i.strip().strip("()").lower() if isinstance(i, str) else "?" for i in answer]
        else:
            return None
        return set(items) if set(items) <= set("abc") else None
    w = "answer_5"
    if answer is None or answer is Ellipsis:
        return _not_attempted(w)
    expected = {k for k in "abc" if _is(f"{k} yes", _IN_5[k])}
    if (chosen := _letters(answer)) is None:
        shown = repr(answer)[:80] if isinstance(answer, (str, list, tuple, set)) else type(answer).__name__
        return _wrong(f"{w} must be a list of the letters of the models, e.g. [\"a\"] or [] for none; got {shown}.")
    if chosen == expected:
        return Feedback(CORRECT, f"{w} is right: the optimal proposal differs from the transition exactly "
                                 f"when y_t depends on the new process noise given x_(t-1).")
    hints = {"a": "the damped particle (a): which components of x_t does its new process noise move, and "
                  f"which does C measure? {ASK} ({SAMPLER})",
             "b": f"dp_pushed (b): with G = I, which components does its noise move, and which does C measure? {ASK}",
             "c": f"lg (c): write y_t = C x_t + v_t with x_t ~ N(A x_(t-1), Q). {ASK}"}
    extra, missing = sorted(chosen - expected) or "a", sorted(expected - chosen) or "a"
    return _first(w, [
        (not chosen, " is empty: for at least one model y_t depends on the new process noise given x_(t-1). "
                     "Write y_t in terms of x_(t-1), the new process noise and v_t."),
        (chosen - expected, f" includes {hints[extra[0]]} If not, the optimal proposal is the transition."),
        (True, f" leaves out {hints[missing[0]]} If so, the optimal proposal differs from the transition.")])


_register(globals())
