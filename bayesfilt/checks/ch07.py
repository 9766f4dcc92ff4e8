"""Checks of chapter 07's exercises (smoothing; references by bf.smoothing, bf.kalman,
bf.particle).

One line per exercise::

    exercise_1(gain_1, mean_1, var_1): one scalar backward step: J_t, smoothed mean,
        variance;
    exercise_2(rts_step): one backward step of the RTS smoother as a function, on four
        inputs;
    exercise_3(sd_filter_3, sd_smooth_3): the largest sigma of xi_1 in a 20-step gap;
    exercise_4(distinct_genealogy_4, distinct_ffbsi_4): distinct particles at t = 0.
"""

from __future__ import annotations

import functools
import numbers

import numpy as np

from . import (CORRECT, NOT_ATTEMPTED, Feedback, _combine, _not_attempted, _wrong, compare_array,
               compare_function, compare_number, register as _register)
from .. import kalman, models, particle, smoothing

# exercise 1: x_{t+1} = a x_t + w_t; the filter at t and the smoother at t + 1 (m, m^2)
A_1, Q_1, X_FILT_1, P_FILT_1, X_NEXT_1, P_NEXT_1 = 0.8, 1.0, 2.0, 1.5, 2.5, 0.9
# exercise 3: section 1's damped particle, T = 100, no measurement at steps 40, ..., 59
T_3, GAP_3 = 100, (40, 60)
# exercise 4: the UNGM record, the particle filter and FFBSi (seeds, steps, particles, paths)
SEEDS_4, T_4, N_4, L_4 = (17, 18, 19), 50, 200, 200


def _one_step(A, Q, mean_filt, cov_filt, mean_next, cov_next) -> smoothing.SmootherResult:
    """bf.smoothing.rts_smoother on a two-step filter result whose last step is the smoother's.

    The prediction is the model's own (A x, A P A^T + Q); at t = 1 the smoother is the given
    (mean_next, cov_next), so the result's step 0 is one backward step from them.
    """
    A, Q = np.atleast_2d(A), np.atleast_2d(Q)
    n = A.shape[0]
    mean_filt, mean_next = np.reshape(mean_filt, n), np.reshape(mean_next, n)
    cov_filt, cov_next = np.reshape(cov_filt, (n, n)), np.reshape(cov_next, (n, n))
    model = models.LinearGaussian(A=A, C=np.eye(n), Q=Q, R=np.eye(n), m0=np.zeros(n),
                                  P0=np.eye(n))
    pred_cov = A @ cov_filt @ A.T + Q
    res = kalman.FilterResult(
        means=np.stack([mean_filt, mean_next]), covs=np.stack([cov_filt, cov_next]),
        pred_means=np.stack([np.zeros(n), A @ mean_filt]),
        pred_covs=np.stack([np.eye(n), 0.5 * (pred_cov + pred_cov.T)]),
        innovations=np.zeros((2, n)), innovation_covs=np.stack([np.eye(n)] * 2),
        gains=np.zeros((2, n, n)), step_logliks=np.zeros(2), loglik=0.0,
        observed=np.ones(2, dtype=bool))
    return smoothing.rts_smoother(model, res)


def _number(answer, expected: float, what: str, mistakes) -> Feedback:
    """compare_number; a wrong number that matches a named mistake gets its message."""
    fb = compare_number(answer, expected, what)
    if fb.status in (CORRECT, NOT_ATTEMPTED):
        return fb
    try:
        value = float(answer)
    except (TypeError, ValueError, OverflowError):
        return fb
    for wrong, message in mistakes:
        if wrong is not None and np.isfinite(wrong) and np.isclose(value, wrong, rtol=1e-6,
                                                                   atol=1e-9):
            return _wrong(f"{what}: {message}")
    return fb


def exercise_1(gain, mean, var) -> Feedback:
    """gain_1, mean_1, var_1: J_t, x_t|T-1 and P_t|T-1 of one scalar step (floats)."""
    a, Q, x, P, x_s, P_s = A_1, Q_1, X_FILT_1, P_FILT_1, X_NEXT_1, P_NEXT_1
    ref = _one_step([[a]], [[Q]], [x], [[P]], [x_s], [[P_s]])
    J, m_ref, v_ref = ref.gains[0, 0, 0], ref.means[0, 0], ref.covs[0, 0, 0]
    x_pred, P_pred = a * x, a * a * P + Q
    gain_fb = _number(gain, J, "gain_1", [
        (P / P_pred, "the gain misses the transition factor: J_t = P_t|t A^T P_t+1|t^{-1}, "
                     "here a P_t|t / P_t+1|t."),
        (a * P / P_s, "J_t divides by the predicted variance P_t+1|t = a^2 P_t|t + Q, not by "
                      "the smoothed P_t+1|T-1."),
        (a * P / (P + Q), "the predicted variance is P_t+1|t = a^2 P_t|t + Q: the transition "
                          "scales the variance by a^2."),
        (a * P / (a * P + Q), "the predicted variance is P_t+1|t = a^2 P_t|t + Q (a squared)."),
        (a * a * P / P_pred, "J_t = a P_t|t / P_t+1|t has one factor a, not a^2 (that is "
                             "A P A^T, the prediction)."),
        (P_pred / (P_pred + Q), "this is not the smoother gain: J_t = P_t|t A^T P_t+1|t^{-1}, "
                                "the regression slope of x_t on x_t+1."),
    ])
    own = float(gain) if isinstance(gain, numbers.Real) and not isinstance(gain, bool) else None
    mean_fb = _number(mean, m_ref, "mean_1", [
        (x + J * (x_s - x), "the correction compares the smoothed x_t+1|T-1 with the "
                            "filter's prediction x_t+1|t = a x_t|t, not with x_t|t."),
        (x - J * (x_s - x_pred), "the sign of the correction: x_t|T-1 = x_t|t + J_t "
                                 "(x_t+1|T-1 - x_t+1|t)."),
        (x_pred + J * (x_s - x_pred), "the correction is added to the filtered x_t|t, not to "
                                      "the prediction x_t+1|t."),
        (None if own is None or np.isclose(own, J) else x + own * (x_s - x_pred),
         "your mean follows from your gain_1, which is not right yet: fix the gain first."),
    ])
    var_fb = _number(var, v_ref, "var_1", [
        (P + J * (P_s - P_pred), "the gain enters twice, J_t (...) J_t^T: for a scalar J_t^2."),
        (P + J * J * (P_pred - P_s), "the sign of the correction: P_t|T-1 = P_t|t + J_t^2 "
                                     "(P_t+1|T-1 - P_t+1|t), and the smoother knows more than "
                                     "the filter, so the variance shrinks."),
        (P - J * J * P_pred, "this is var(x_t | x_t+1, y_0:t), the residual's variance alone; "
                             "add J_t^2 P_t+1|T-1, the uncertainty of the smoothed x_t+1."),
        (J * J * P_s, "this is only the part due to the smoothed x_t+1; add the residual's "
                      "variance P_t|t - J_t^2 P_t+1|t."),
        (P + J * J * (P_s - P), "the correction compares P_t+1|T-1 with the prediction's "
                                "variance P_t+1|t = a^2 P_t|t + Q, not with P_t|t."),
        (np.sqrt(max(v_ref, 0.0)), "this is a standard deviation; the exercise asks for the "
                                   "variance P_t|T-1 (m^2)."),
        (None if own is None or np.isclose(own, J) else P + own ** 2 * (P_s - P_pred),
         "your variance follows from your gain_1, which is not right yet: fix the gain first."),
    ])
    return _combine([("gain_1", gain_fb), ("mean_1", mean_fb), ("var_1", var_fb)])


# --- exercise 2 ----------------------------------------------------------------------------------

def _reference_2(mean_filt, cov_filt, mean_pred, cov_pred, mean_next, cov_next, A):
    """The library's backward step (the prediction's Q recovered from cov_pred)."""
    step = _one_step(A, cov_pred - A @ cov_filt @ A.T, mean_filt, cov_filt, mean_next, cov_next)
    return step.means[0], step.covs[0]


def _step_with(J, mean_filt, cov_filt, mean_pred, cov_pred, mean_next, cov_next):
    return mean_filt + J @ (mean_next - mean_pred), cov_filt + J @ (cov_next - cov_pred) @ J.T


def _gain(cov_filt, cov_pred, A):
    return np.linalg.solve(cov_pred, A @ cov_filt).T


_MISTAKES_2 = [
    (lambda mf, Pf, mp, Pp, ms, Ps, A: _step_with(np.linalg.solve(Pp, A @ Pf), mf, Pf, mp, Pp,
                                                  ms, Ps),
     "the gain is transposed: np.linalg.solve(P_t+1|t, A P_t|t) is J_t^T; J_t = P_t|t A^T "
     "P_t+1|t^{-1} is its transpose."),
    (lambda mf, Pf, mp, Pp, ms, Ps, A: _step_with(_gain(Pf, Ps, A), mf, Pf, mp, Pp, ms, Ps),
     "the gain divides by the smoothed P_t+1|T-1; J_t = P_t|t A^T P_t+1|t^{-1} uses the "
     "filter's prediction P_t+1|t."),
    (lambda mf, Pf, mp, Pp, ms, Ps, A: _step_with(np.linalg.solve(Pp, Pf).T, mf, Pf, mp, Pp,
                                                  ms, Ps),
     "the gain misses A^T: J_t = P_t|t A^T P_t+1|t^{-1}."),
    (lambda mf, Pf, mp, Pp, ms, Ps, A: _step_with(np.linalg.solve(Pp, A.T @ Pf).T, mf, Pf, mp,
                                                  Pp, ms, Ps),
     "the gain uses A where A^T belongs: J_t = P_t|t A^T P_t+1|t^{-1} (A^T multiplies "
     "P_t|t from the right)."),
    (lambda mf, Pf, mp, Pp, ms, Ps, A: _step_with(_gain(Pf, Pp, A), mf, Pf, mp, Ps, ms, Pp),
     "the covariance correction has the wrong sign: P_t|T-1 = P_t|t + J_t (P_t+1|T-1 - "
     "P_t+1|t) J_t^T."),
    (lambda mf, Pf, mp, Pp, ms, Ps, A: (
        mf + _gain(Pf, Pp, A) @ (ms - mp), Pf + _gain(Pf, Pp, A) @ (Ps - Pp)),
     "the covariance correction needs J_t on both sides: J_t (P_t+1|T-1 - P_t+1|t) J_t^T."),
    (lambda mf, Pf, mp, Pp, ms, Ps, A: (
        mf + _gain(Pf, Pp, A) @ (ms - mf), _step_with(_gain(Pf, Pp, A), mf, Pf, mp, Pp, ms,
                                                      Ps)[1]),
     "the mean's correction compares the smoothed x_t+1|T-1 with the prediction x_t+1|t, not "
     "with x_t|t."),
]


def _pair_compare(out, expected, what: str = "the output") -> Feedback:
    """rts_step's output: the pair (mean (n,), cov (n, n)), each compared with the reference."""
    if not isinstance(out, (tuple, list)) or len(out) != 2:
        return _wrong(f"{what}: rts_step must return the pair (mean, cov), got "
                      f"{type(out).__name__}" + (f" of length {len(out)}"
                                                 if isinstance(out, (tuple, list)) else "") + ".")
    mean, cov = out
    if mean is None or cov is None:
        return _wrong(f"{what}: the pair holds None; return both the mean and the covariance.")
    n = np.shape(expected[0])[0]
    if np.shape(mean) == (n, n) and np.shape(cov) == (n,):
        return _wrong(f"{what}: the pair is in the wrong order; return (mean, cov).")
    fb_mean = compare_array(mean, expected[0], f"{what}: the mean")
    fb_cov = compare_array(cov, expected[1], f"{what}: the covariance")
    if fb_mean.correct and fb_cov.correct:
        return Feedback(CORRECT, f"{what} matches the reference.")
    return fb_mean if not fb_mean.correct else fb_cov


@functools.lru_cache(maxsize=1)
def _cases_2() -> tuple:
    """Four consistent inputs: n = 1 (exercise 1's numbers), 2, 3 (random) and 4 (the damped
    particle's filter and smoother at step 50 of a record with a gap)."""
    def case(A, Q, mean_filt, cov_filt, mean_next, cov_next):
        A = np.atleast_2d(A)
        return (np.array(mean_filt, float), np.array(cov_filt, float),
                A @ mean_filt, A @ cov_filt @ A.T + Q, np.array(mean_next, float),
                np.array(cov_next, float), A)
    rng = np.random.default_rng(70707)

    def spd(k):
        M = rng.normal(size=(k, k))
        return np.round(M @ M.T / k + 0.3 * np.eye(k), 3)
    cases = [case([[A_1]], [[Q_1]], [X_FILT_1], [[P_FILT_1]], [X_NEXT_1], [[P_NEXT_1]])]
    for k in (2, 3):
        cases.append(case(np.round(rng.normal(size=(k, k)) / np.sqrt(k), 3), spd(k),
                          np.round(rng.normal(size=k), 3), spd(k),
                          np.round(rng.normal(size=k), 3), spd(k)))
    model = models.damped_particle()
    ys = models.simulate(model, 60, np.random.default_rng(70708)).ys
    ys[45:55] = np.nan
    filt = kalman.kalman_filter(model, ys)
    smooth = smoothing.rts_smoother(model, filt)
    cases.append((filt.means[50], filt.covs[50], filt.pred_means[51], filt.pred_covs[51],
                  smooth.means[51], smooth.covs[51], model.A.copy()))
    for c in cases:
        for a in c:
            a.setflags(write=False)
    return tuple(cases)


def exercise_2(rts_step) -> Feedback:
    """rts_step(mean_filt, cov_filt, mean_pred, cov_pred, mean_next, cov_next, A) against
    bf.smoothing.rts_smoother on four inputs (n = 1, 2, 3, 4)."""
    cases = [tuple(np.array(a) for a in c) for c in _cases_2()]
    return compare_function(rts_step, _reference_2, cases, what="rts_step",
                            compare=_pair_compare, mistakes=_MISTAKES_2)


# --- exercise 3 ----------------------------------------------------------------------------------

@functools.lru_cache(maxsize=1)
def _gap_variances_3() -> dict:
    """Variances of xi_1 and its velocity over the gap (and at t = 60) by the library."""
    model = models.damped_particle()
    out = {}
    for name, last in (("right", GAP_3[1]), ("one more", GAP_3[1] + 1)):
        ys = np.zeros((T_3, 2))
        ys[GAP_3[0]:last] = np.nan
        filt = kalman.kalman_filter(model, ys)
        smooth = smoothing.rts_smoother(model, filt)
        out[name] = (filt.covs[GAP_3[0]:last], smooth.covs[GAP_3[0]:last])
    filt_none = kalman.kalman_filter(model, np.zeros((T_3, 2)))
    out["no gap"] = smoothing.rts_smoother(model, filt_none).covs[GAP_3[0]:GAP_3[1]]
    return out


def exercise_3(sd_filter, sd_smooth) -> Feedback:
    """sd_filter_3, sd_smooth_3: the largest sigma of xi_1 over the gap, filter, smoother (m)."""
    v = _gap_variances_3()
    P_f, P_s = v["right"]
    sd_f, sd_s = np.sqrt(P_f[:, 0, 0]), np.sqrt(P_s[:, 0, 0])
    ref_f, ref_s = float(sd_f.max()), float(sd_s.max())
    velocity = [np.sqrt(P[:, 1, 1]).max() for P in (P_f, P_s)]
    longer = [np.sqrt(P[:, 0, 0]).max() for P in v["one more"]]
    filter_fb = _number(sd_filter, ref_f, "sd_filter_3", [
        (ref_f ** 2, "this is a variance; take the square root for the standard deviation (m)."),
        (ref_s, "this is the smoother's value; sd_filter_3 is the filter's (its covs)."),
        (velocity[0], "this is the velocity's sigma; the position xi_1 is state component 0."),
        (longer[0], "the gap is one step too long: y_60 is measured, the missing rows are "
                    "40, ..., 59 (np.arange(40, 60))."),
        (float(sd_f[0]), "this is the sigma at the gap's first step; the exercise asks for the "
                         "largest over the gap."),
    ])
    smooth_fb = _number(sd_smooth, ref_s, "sd_smooth_3", [
        (ref_s ** 2, "this is a variance; take the square root for the standard deviation (m)."),
        (ref_f, "this is the filter's value: run bf.smoothing.rts_smoother on the filter's "
                "result and use its covs."),
        (velocity[1], "this is the velocity's sigma; the position xi_1 is state component 0."),
        (longer[1], "the gap is one step too long: y_60 is measured, the missing rows are "
                    "40, ..., 59 (np.arange(40, 60))."),
        (float(sd_s[-1]), "this is the sigma at the gap's last step; the smoother's sigma is "
                          "largest elsewhere in the gap."),
        (float(np.sqrt(v["no gap"][:, 0, 0]).max()), "this is the smoother without a gap: the "
                                                     "rows 40, ..., 59 must be NaN."),
    ])
    return _combine([("sd_filter_3", filter_fb), ("sd_smooth_3", smooth_fb)])


# --- exercise 4 ----------------------------------------------------------------------------------

@functools.lru_cache(maxsize=1)
def _distinct_4() -> tuple[int, int, int]:
    """(genealogy at t = 0, FFBSi at t = 0, genealogy at t = 1) by the library."""
    ungm = models.ungm()
    ys = models.simulate(ungm, T_4, np.random.default_rng(SEEDS_4[0])).ys
    pf = particle.particle_filter(ungm, ys, N_4, np.random.default_rng(SEEDS_4[1]),
                                  keep_history=True)
    tree = smoothing.genealogy(pf.history)
    paths = smoothing.ffbsi(ungm, pf.history, L_4, np.random.default_rng(SEEDS_4[2]))
    return int(tree.n_distinct[0]), int(np.unique(paths.indices[:, 0]).size), int(
        tree.n_distinct[1])


def _count(answer, expected: int, what: str, mistakes) -> Feedback:
    if answer is None or answer is Ellipsis:
        return _not_attempted(what)
    if isinstance(answer, np.ndarray) and answer.size == 1:
        answer = answer.item()
    if (isinstance(answer, (bool, np.bool_)) or not isinstance(answer, numbers.Real)
            or not np.isfinite(answer) or answer != round(answer)):
        return _wrong(f"{what} must be a whole number (a count of particles), got {answer!r}.")
    if int(answer) == expected:
        return Feedback(CORRECT, f"{what} is right.")
    for wrong, message in mistakes:
        if int(answer) == wrong and wrong != expected:
            return _wrong(f"{what}: {message}")
    return _wrong(f"{what} is too {'large' if answer > expected else 'small'}. Check the seeds "
                  f"(17, 18, 19, in that order), N = {N_4}, L = {L_4}, and that you count at "
                  f"t = 0.")


def exercise_4(distinct_genealogy, distinct_ffbsi) -> Feedback:
    """distinct_genealogy_4, distinct_ffbsi_4: distinct particles at t = 0 (ints)."""
    ref_g, ref_f, at_1 = _distinct_4()
    genealogy_fb = _count(distinct_genealogy, ref_g, "distinct_genealogy_4", [
        (N_4, f"{N_4} is the count at the last step (every final particle is its own path), or "
              "of history.ancestors[0], which is arange(N); follow the ancestors back to t = 0 "
              "(bf.smoothing.genealogy(...).n_distinct[0])."),
        (at_1, "this is the count at t = 1; the exercise asks for t = 0."),
    ])
    ffbsi_fb = _count(distinct_ffbsi, ref_f, "distinct_ffbsi_4", [
        (L_4, f"{L_4} is the number of trajectories; count the distinct particle indices at "
              "t = 0, np.unique(paths.indices[:, 0])."),
        (ref_g, "this is the genealogy's count; distinct_ffbsi_4 counts the FFBSi trajectories' "
                "particles at t = 0."),
    ])
    return _combine([("distinct_genealogy_4", genealogy_fb), ("distinct_ffbsi_4", ffbsi_fb)])


_register(globals())
