"""Checks of chapter 02's exercises (the Kalman filter derived; references by bf.kalman,
bf.gaussian, bf.bayes). One line per exercise (the notebook variables each reads with
``given``, in brackets)::

    exercise_1(means_1, vars_1, P_inf_1, K_inf_1): two steps of the scalar filter by
        hand, then its steady state for new Q and R [xhat_00_1, P_00_1, Q_1, R_1, ys_1,
        Q_new_1, R_new_1];
    exercise_2(kalman_gain): the gain K = P C^T S^{-1}, on five inputs;
    exercise_3(mean_3, sd_3): E(velocity | position) and its standard deviation in
        section 3's cloud [m_3, Pi_3, position_3];
    exercise_4(agree_4, meaning_4, grid_means_uniform): the grid filter under uniform
        noise, and what the KF mean is [a_4];
    exercise_5(correlated_gain): the gain when cov(w_t, v_{t+1}) = D, on four inputs.
"""

from __future__ import annotations

import functools
import numbers

import numpy as np

from . import (CORRECT, INCORRECT, Feedback, _combine, _frozen, _hinted, _is, _named, _normal,
               _not_attempted, _wrong, compare_array, compare_function, compare_number, given,
               register as _register)
from .. import bayes, gaussian, kalman, models

# the statements' numbers. Exercise 1: section 2's random walk x_{t+1} = x_t + w_t, y_t = x_t + v_t, from the
# belief after y_0 (m, m^2), with Q, R (m^2) and y_1, y_2 (m); then the steady state for new Q, R (m^2).
XHAT_00_1, P_00_1, Q_1, R_1, YS_1 = 20.0, 3.0, 1.0, 2.0, _frozen([23.0, 28.5])
Q_NEW_1, R_NEW_1, ATOL_HAND = 1.0, 6.0, 1e-3
# exercise 3: section 3's cloud at t = 8 as printed there (m, m/step; m^2, m^2/step, (m/step)^2), the position
# learnt exactly (m), and the position sensor's R = 1 m^2 of section 1 (the noisy slope is a named mistake)
M_3, PI_3, POSITION_3, R_SECTION_1 = _frozen([4.76, 0.43]), _frozen([[27.35, 3.96], [3.96, 0.87]]), 12.0, 1.0
# exercises 2 and 5: a predicted covariance (m^2, m^2/step, (m/step)^2) close to section 7's P_{11|10}, the
# position sensor and its noise variance (m^2); the noise gain of the damped particle (the kick acts on the
# velocity) and cov(w_t, v_{t+1}) of exercise 5
P_EX, C_EX, R_EX = _frozen([[1.2, 0.45], [0.45, 0.34]]), _frozen([[1.0, 0.0]]), _frozen([[1.0]])
G_EX, D_5 = _frozen([[0.0], [1.0]]), _frozen([[0.2]])
# exercise 4: the 1-D model and grid of "The Kalman filter is the Bayes recursion of chapter 01",
# 10 measurements (seed 3); uniform noise on [-a, a], a = sqrt(1.5), has the variance a^2 / 3 = 0.5
MODEL_1D = dict(A=[[0.9]], C=[[0.5]], Q=[[0.5]], R=[[0.4]], m0=[1.0], P0=[[2.0]])
SEED_1D, STEPS_1D, GRID_1D = 3, 10, _frozen(np.linspace(-15.0, 15.0, 2001))
HALF_WIDTH_4, AGREE_TOL_4 = float(np.sqrt(1.5)), 1e-9
OPTIONS_4 = ("conditional mean", "best linear estimate", "neither")


def _posterior(P, C, R) -> kalman.Update:
    """The library's measurement update of a prediction with covariance P (mean and y zero)."""
    return kalman.update(np.zeros(np.shape(P)[0]), P, np.zeros(np.shape(C)[0]), C, R)


def _gain(P, C, R, S=None):
    """K = P C^T S^{-1}, S = C P C^T + R unless given."""
    return np.linalg.solve(C @ P @ C.T + R if S is None else S, C @ P).T


def _random_covariance(rng: np.random.Generator, n: int) -> np.ndarray:
    return np.round((M := rng.normal(size=(n, n))) @ M.T / n + 0.2 * np.eye(n), 3)


def _shapes_hint(shapes: str):
    words = ("broadcast", "matmul", "align", "dimension")
    return lambda exc, args: f" Hint: check the shapes: {shapes}." if any(w in str(exc) for w in words) else ""


def _given_arrays(**defaults) -> list[np.ndarray]:
    """The notebook's arrays of these names (float), or the statement's values."""
    return [np.array(given(name, value), dtype=float) for name, value in defaults.items()]


def _number(answer, expected, what, mistakes=(), atol=ATOL_HAND) -> Feedback:
    """compare_number to a hand computation's accuracy; an answer equal to a named wrong value (that is
    not the right one) gets that value's message."""
    fb = compare_number(answer, expected, what, rtol=0.0, atol=atol)
    if fb.status != INCORRECT or " must be " in fb.message or "NaN" in fb.message:
        return fb
    value = float(np.ravel(answer)[0])
    for wrong, message in mistakes:
        if np.isfinite(wrong) and abs(wrong - expected) > atol and abs(value - wrong) <= atol:
            return _wrong(f"{what}: {message}")
    return fb


# Exercise 1: the scalar filter by hand ------------------------------------------------------------------

def _scalar_steps(x, P, Q, R, ys, variant: str = "right") -> tuple[np.ndarray, np.ndarray]:
    """Means and variances after each update from the belief (x, P) after y_0, written out, right or
    with one of the named mistakes (the check's reference is _library_steps)."""
    means, variances = [], []
    for t, y in enumerate(ys):
        P = P + (0.0 if variant == "no Q" or (variant == "no Q at step 2" and t > 0) else Q)
        if variant == "predictions":
            means.append(x)
            variances.append(P)
        K = P / (P + R)
        x = x + ((1 - K) if variant == "gain swapped" else K) * (y - x)
        P = K * P if variant == "K P" else (1 - K) * P
        if variant != "predictions":
            means.append(x)
            variances.append(np.sqrt(P) if variant == "std" else P)
    return np.array(means), np.array(variances)


def _library_steps(x, P, Q, R, ys) -> tuple[np.ndarray, np.ndarray]:
    """The same two steps by bf.kalman.predict and bf.kalman.update (1 x 1 matrices)."""
    mean, cov, means, variances = np.array([x]), np.array([[P]]), [], []
    for y in ys:
        mean, cov = kalman.predict(mean, cov, [[1.0]], [[Q]])
        mean, cov = kalman.update(mean, cov, [y], [[1.0]], [[R]])[:2]
        means.append(mean[0])
        variances.append(cov[0, 0])
    return np.array(means), np.array(variances)


_STEP_MISTAKES = {
    "no Q": "the prediction forgets Q: each prediction adds the drift's variance, P_{t|t-1} = P_{t-1|t-1} + Q, "
            "before the gain is computed.",
    "no Q at step 2": "step 2 starts from P_{1|1} without adding Q: predict again before the second update "
                      "(P_{2|1} = P_{1|1} + Q).",
    "predictions": "these are the predictions x^_{t|t-1}, P_{t|t-1}; give the beliefs after each update.",
    "gain swapped": "the estimate moves K_t of the way from the prediction towards y_t: x^_{t|t-1} + K_t "
                    "(y_t - x^_{t|t-1}), not 1 - K_t of the way.",
    "K P": "after the update the variance is (1 - K_t) P_{t|t-1}, the share the measurement leaves, not "
           "K_t P_{t|t-1}.",
    "std": "these are standard deviations; vars_1 holds the variances P_{1|1}, P_{2|2} (m^2).",
}


def exercise_1(means, variances, P_inf, K_inf) -> Feedback:
    """means_1 = [x^_{1|1}, x^_{2|2}], vars_1 = [P_{1|1}, P_{2|2}] from x^_{0|0}, P_{0|0} with Q_1, R_1 and
    ys_1 = [y_1, y_2]; P_inf_1 and K_inf_1, the steady P_{t|t-1} and gain for Q_new_1 and R_new_1."""
    x0, P0, Q, R = (float(given(n, v)) for n, v in (("xhat_00_1", XHAT_00_1), ("P_00_1", P_00_1),
                                                      ("Q_1", Q_1), ("R_1", R_1)))
    ys = np.ravel(np.array(given("ys_1", YS_1), dtype=float))
    Qn, Rn = float(given("Q_new_1", Q_NEW_1)), float(given("R_new_1", R_NEW_1))
    ref_means, ref_vars = _library_steps(x0, P0, Q, R, ys)
    variants = {v: _scalar_steps(x0, P0, Q, R, ys, v) for v in _STEP_MISTAKES}
    near = functools.partial(np.allclose, rtol=0.0, atol=ATOL_HAND)
    n = len(ys)

    def step_mistakes(k: int, w: str):
        first = [(lambda a: a.size == 1, f"{w} must hold {n} numbers, one after each of the {n} updates; "
                                         f"got one."),
                 (ref_means if k else ref_vars, f"{w} holds the {'means' if k else 'variances'}; swap "
                                                f"means_1 and vars_1.")]
        named = [(variants[v][k], f"{w}: {m}") for v, m in _STEP_MISTAKES.items() if v != "std" or k == 1]
        last = [(lambda a: a.shape == (n,) and n > 1 and near(a[0], (ref_means, ref_vars)[k][0]),
                 f"{w} has step 1 right but not step 2: step 2 starts from step 1's belief, predicts "
                 f"(adds Q) and updates with y_2.")]
        return first + named + last

    ss = kalman.steady_state(models.LinearGaussian(A=[[1.0]], C=[[1.0]], Q=[[Qn]], R=[[Rn]], m0=[0.0],
                                                   P0=[[1.0]]))
    P_ref, K_ref = float(ss.pred_cov[0, 0]), float(ss.gain[0, 0])
    root = np.sqrt(Qn ** 2 + 4 * Qn * Rn)
    filtered = P_ref * Rn / (P_ref + Rn)
    swapped = (Rn + np.sqrt(Rn ** 2 + 4 * Qn * Rn)) / 2              # Q and R swapped
    notes = "these are section 2's numbers (Q = 2, R = 3 m^2); use Q_new_1 and R_new_1."
    P_2 = (2.0 + np.sqrt(4.0 + 24.0)) / 2                      # section 2's P_inf, Q = 2 and R = 3 m^2
    steps = [_named(means, ref_means, "means_1", step_mistakes(0, "means_1"), rtol=0.0, atol=ATOL_HAND),
             _named(variances, ref_vars, "vars_1", step_mistakes(1, "vars_1"), rtol=0.0, atol=ATOL_HAND)]
    said = [fb.message.split(": ", 1)[-1] for fb in steps]
    if all(fb.status == INCORRECT for fb in steps) and said[0] == said[1]:     # one mistake, said once
        steps = [_wrong(f"means_1 and vars_1: {said[0]}"), Feedback(CORRECT, "")]
    parts = [
        ("means_1", steps[0]), ("vars_1", steps[1]),
        ("P_inf_1", _number(P_inf, P_ref, "P_inf_1", [
            (filtered, "this is the steady variance after the update, P_{t|t} = P_inf R / (P_inf + R); "
                       "P_inf is the prediction's, P_{t|t-1}, the solution of P = P R / (P + R) + Q."),
            (swapped, "Q and R are swapped: P_inf = (Q + sqrt(Q^2 + 4 Q R)) / 2."),
            (Qn + root, "this is twice P_inf: the root of P^2 - Q P - Q R = 0 is (Q + sqrt(Q^2 + 4 Q R)) / 2."),
            ((Qn - root) / 2, "this is the negative root of P^2 - Q P - Q R = 0; a variance is positive."),
            (root / 2, "the root is (Q + sqrt(Q^2 + 4 Q R)) / 2: Q is missing in front of the square root."),
            (P_2, notes)])),
        ("K_inf_1", _number(K_inf, K_ref, "K_inf_1", [
            (filtered / (filtered + Rn), "the gain uses the prediction's variance: K_inf = P_inf / (P_inf + R), "
                                         "with P_inf the steady P_{t|t-1}, not P_{t|t}."),
            (P_ref / (P_ref + Qn), "the gain weighs the prediction against the sensor: K_inf = P_inf / "
                                   "(P_inf + R), with R, not Q."),
            (1 - K_ref, "this is 1 - K_inf, the share kept from the prediction; K_inf = P_inf / (P_inf + R)."),
            (P_ref / Rn, "divide by P_inf + R (the variance of the innovation), not by R alone."),
            (swapped / (swapped + Rn), "Q and R are swapped in your P_inf: P_inf = (Q + sqrt(Q^2 + 4 Q R)) / 2."),
            (P_2 / (P_2 + 3.0), notes)])),
    ]
    if all(fb.correct for _, fb in parts):
        return Feedback(CORRECT, "means_1, vars_1, P_inf_1 and K_inf_1 match the reference.")
    return _combine([part for part in parts if part[1].message])


_GAIN_MISTAKES = [
    (lambda P, C, R: _gain(P, C, R).T, "the gain is transposed: K = P C^T S^{-1} has one row per state "
     "component and one column per measurement component, shape (n, m), not that of S^{-1} C P."),
    (lambda P, C, R: _gain(P, C, R, C @ P @ C.T), "S is computed without R: S = C P C^T + R, the predicted uncertainty "
     "of the measurement plus the sensor noise (without R the filter trusts the sensor as if it were perfect)."),
    (lambda P, C, R: _gain(P, C, R, C @ P @ C.T - R), "S is computed as C P C^T - R: the sensor noise "
     "adds uncertainty, S = C P C^T + R (a minus sign in S, not a constant factor)."),
    (lambda P, C, R: P @ C.T @ (C @ P @ C.T + R), "you multiply P C^T by S instead of by its inverse."),
    (lambda P, C, R: _gain(P, C, R, R), "you use R alone as S; S = C P C^T + R also holds C P C^T."),
    (lambda P, C, R: P @ C.T / (C @ P @ C.T + R), "you divide P C^T by S entry by entry; with m > 1 "
     "measurement components S^{-1} is the inverse of a matrix (np.linalg.inv or np.linalg.solve)."),
    (lambda P, C, R: np.linalg.solve(C @ P @ C.T + R, P @ C.T), "S^{-1} multiplies P C^T from the left; "
     "in K = P C^T S^{-1} it is on the right (the two differ once n = m > 1)."),
]


def exercise_2(kalman_gain) -> Feedback:
    """kalman_gain(P, C, R) against bf.kalman.update(...).gain on five inputs."""
    def hint(exc, args) -> str:
        if "broadcast" in str(exc):
            return " Hint: S is an m x m matrix here; use its inverse (np.linalg.inv or solve), not a division by it."
        if isinstance(exc, np.linalg.LinAlgError) and not np.any(args[0]):
            return " Hint: here P = 0 (a state known exactly), singular; the gain only needs the inverse of S (= R)."
        return _shapes_hint("P (n, n), C (m, n), R (m, m), S (m, m), P C^T (n, m) and the gain (n, m)")(exc, args)
    rng = np.random.default_rng(20202)             # then two measurement components, and P = 0
    cases = [(P_EX, C_EX, R_EX), (np.array([[4.0]]), np.array([[2.0]]), np.array([[0.5]]))] + [
        (_random_covariance(rng, n), np.round(rng.normal(size=(2, n)), 3), _random_covariance(rng, 2))
        for n in (2, 3)] + [(np.zeros((2, 2)), C_EX, R_EX)]
    return compare_function(_hinted(kalman_gain, hint), lambda P, C, R: _posterior(P, C, R).gain,
                            [tuple(map(np.array, case)) for case in cases], what="kalman_gain",
                            mistakes=_GAIN_MISTAKES, forbidden=[({"kalman"}, "bf.kalman, which the statement "
                                                                 "rules out: K = P C^T S^{-1} with np.linalg.solve "
                                                                 "or np.linalg.inv.")])


# Exercise 3: conditioning section 3's cloud ----------------------------------------------------------

def exercise_3(mean, sd) -> Feedback:
    """mean_3 = E(velocity | position = position_3) and sd_3, its standard deviation, for the cloud
    N(m_3, Pi_3) of section 3 (position first)."""
    m, Pi = _given_arrays(m_3=M_3, Pi_3=PI_3)
    pos = float(given("position_3", POSITION_3))
    cond = gaussian.condition(mean_x=m[1:], mean_y=m[:1], cov_xx=Pi[1:, 1:], cov_xy=Pi[1:, :1],
                              cov_yy=Pi[:1, :1], y=np.array([pos]))
    ref_mean, ref_sd = float(cond.mean[0]), float(np.sqrt(cond.cov[0, 0]))
    p11, p21, p22, d = Pi[0, 0], Pi[1, 0], Pi[1, 1], pos - m[0]
    noisy = p11 + R_SECTION_1
    rho = p21 / np.sqrt(p11 * p22)
    parts = [
        ("mean_3", _number(mean, ref_mean, "mean_3", [
            (m[1], "this is the mean velocity before anything is learnt, m_2; learning the position moves it "
                   "by the slope times (position - m_1)."),
            (m[1] + p21 / p11 * pos, "measure the position from the cloud's centre: the slope multiplies "
                                     "position - m_1, not the position itself."),
            (m[1] + p21 / p22 * d, "the slope is Pi_21 / Pi_11 (velocity per metre of position); Pi_21 / Pi_22 "
                                   "is the slope of the position on the velocity."),
            (m[1] + p21 / noisy * d, f"this is the slope for a noisy position, Pi_21 / (Pi_11 + R) with R = "
                                     f"{R_SECTION_1:g} m^2 (the filter's gain); here the position is known "
                                     f"exactly: Pi_21 / Pi_11."),
            (m[1] + rho * d, "the correlation is no slope (it has no units): the slope is Pi_21 / Pi_11, "
                             "m/step per metre."),
            (m[0] + p21 / p22 * (pos - m[1]), "this mixes up the two components: the position comes first "
                                              "in m_3 and Pi_3, the velocity second."),
        ])),
        ("sd_3", _number(sd, ref_sd, "sd_3", [
            (ref_sd ** 2, "this is the variance Pi_22 - Pi_21^2 / Pi_11; the standard deviation is its "
                          "square root."),
            (np.sqrt(p22), "this is the velocity's spread before anything is learnt; conditioning on the "
                           "position narrows it: Pi_22 - Pi_21^2 / Pi_11."),
            (np.sqrt(p22 + p21 ** 2 / p11), "learning the position removes variance, it cannot add any: "
                                            "Pi_22 - Pi_21^2 / Pi_11."),
            (np.sqrt(p11 - p21 ** 2 / p22), "this is the spread of the position given the velocity; the "
                                            "velocity's is Pi_22 - Pi_21^2 / Pi_11."),
            (np.sqrt(p22 - p21 ** 2 / noisy), f"this is the spread after a noisy position (R = "
                                              f"{R_SECTION_1:g} m^2); here the position is known exactly."),
            (np.sqrt(p22) * (1 - rho ** 2), "the factor is sqrt(1 - rho^2), not 1 - rho^2: the variance, not "
                                            "the standard deviation, shrinks by 1 - rho^2."),
        ])),
    ]
    if all(fb.correct for _, fb in parts):
        return Feedback(CORRECT, "mean_3 and sd_3 match the reference; compare them with the kept velocities "
                                 "of section 3's figure.")
    return _combine(parts)


@functools.lru_cache(maxsize=1)
def _model_1d():
    model = models.LinearGaussian(**MODEL_1D)
    return model, models.simulate(model, STEPS_1D, np.random.default_rng(SEED_1D)).ys


@functools.lru_cache(maxsize=16)
def _uniform_grid_means(a: float, variant: str = "right") -> np.ndarray:
    """The grid filter's 10 posterior means on the 1-D model with w_t uniform on [-a, a]; or a mistake's."""
    (model, ys), g = _model_1d(), GRID_1D
    A, C, R = model.A[0, 0], model.C[0, 0], model.R[0, 0]
    A = 1.0 if variant == "no A" else A

    def pdf(x, mean, var):
        return np.exp(-0.5 * (x - mean) ** 2 / var) / np.sqrt(2 * np.pi * var)
    transition = bayes.grid_transition(g, lambda x1, x0: pdf(x1, A * x0, model.Q[0, 0]) if variant == "gaussian"
                                       else np.where(np.abs(x1 - A * x0) <= a, 0.5 / a, 0.0))
    likelihoods = [bayes.grid_likelihood(g, y, lambda y, x: pdf(y, C * x, R)) for y in ys[:, 0]]
    prior_0 = pdf(g, model.m0[0], model.P0[0, 0])
    run = bayes.bayes_filter(prior_0 / prior_0.sum(), transition, likelihoods)
    return _frozen((run.priors if variant == "priors" else run.posteriors) @ g)


_MEANS_MISTAKES = [
    ("priors", "these are the means of the predictions (run.priors); the exercise asks for the posteriors."),
    ("no A", "the state moves first: the uniform noise is centred on 0.9 x_prev, |x_next - 0.9 x_prev| <= a "
             "(yours on x_prev)."),
    ("gaussian", "these are the means under section 10's Gaussian noise; replace its density by the "
                 "uniform one, 1/(2a) where |x_next - 0.9 x_prev| <= a.")]
# meaning_4: the right option and its synonyms, and the wrong options' synonyms, as digests (not in clear)
_RIGHT_4 = {"sha256:ch02-ex4:d61ae77aa5a6a4f9a59b", "sha256:ch02-ex4:c784ca6c0707b71c1b9f",
            "sha256:ch02-ex4:a432cf4660ae6481b96f", "sha256:ch02-ex4:da4f5e1ea8bf81f33320",
            "sha256:ch02-ex4:23903348447feef6a07c", "sha256:ch02-ex4:9717b81326f663d3a8da",
            "sha256:ch02-ex4:50df3bf6f14aa6b851a6", "sha256:ch02-ex4:b56145ec74520d9202ce",
            "sha256:ch02-ex4:94dc0677eacb1b12f855"}
_OTHERS_4 = {"sha256:ch02-ex4:4517247fd43ed478dc21", "sha256:ch02-ex4:7fa85c1202383c205f13",
             "sha256:ch02-ex4:0f4636d7a1befd627481", "sha256:ch02-ex4:6677554519605f62c658",
             "sha256:ch02-ex4:417034b4a194d25e1bf5", "sha256:ch02-ex4:883c46e49a7d0a63a068"}


def _meaning_4(meaning) -> Feedback:
    w = "meaning_4"
    if meaning is None or meaning is Ellipsis:
        return _not_attempted(w)
    if isinstance(meaning, str) and any(_is(meaning, d) for d in _RIGHT_4):
        return Feedback(CORRECT, f"{w} is right.")
    if isinstance(meaning, str) and (any(_is(meaning, d) for d in _OTHERS_4)
                                     or _normal(meaning) in map(_normal, OPTIONS_4)):
        return _wrong(f"{w} is not the right option. Under the uniform noise the grid computes E(x_t | "
                      f"y_0, ..., y_t), and you have just seen it differ from the Kalman mean, which uses "
                      f"only means and covariances: which estimator does section 8 define by means and "
                      f"covariances alone, whatever the distributions?")
    shown = repr(meaning)[:60] if isinstance(meaning, str) else type(meaning).__name__
    return _wrong(f"{w} must be one of {list(OPTIONS_4)}, got {shown}.")


def _agree_4(agree, a: float) -> Feedback:
    w = "agree_4"
    if agree is None or agree is Ellipsis:
        return _not_attempted(w)
    agree = agree.item() if isinstance(agree, np.ndarray) and agree.size == 1 else agree
    if isinstance(agree, (bool, np.bool_)) or not isinstance(agree, numbers.Real):
        return _wrong(f"{w} must be a single time step, an int such as 3 (got {type(agree).__name__}).")
    if not np.isfinite(agree) or agree != round(agree):
        return _wrong(f"{w} must be a whole number, a time step t = 0, ..., {STEPS_1D - 1}.")
    if not 0 <= (t := int(round(agree))) < STEPS_1D:
        return _wrong(f"{w} = {t} is not one of the steps t = 0, ..., {STEPS_1D - 1}.")
    gaps = np.abs(_uniform_grid_means(a) - kalman.kalman_filter(*_model_1d()).means[:, 0])
    agreeing = list(np.flatnonzero(gaps < AGREE_TOL_4))
    if agreeing == [t]:
        return Feedback(CORRECT, f"{w} is right.")
    gap = f"at t = {t} the grid and Kalman posterior means differ by {gaps[t]:.1e} m, far more than " \
          f"{AGREE_TOL_4:.0e}"
    if agreeing and t == agreeing[0] + 1:
        return _wrong(f"{w}: did you count the steps from 1? {gap[0].upper()}{gap[1:]}. Steps are numbered from "
                      f"t = 0, y_0 measuring x_0; or did you compare the predictions (priors) rather than the "
                      f"posteriors?")
    return _wrong(f"{w}: {gap}. Print |grid mean - Kalman mean| for each of the 10 steps.")


def exercise_4(agree, meaning, grid_means_uniform=None) -> Feedback:
    """agree_4 (the step where grid and Kalman posterior means agree), meaning_4 and, when given,
    grid_means_uniform(a) against the library's grid filter at a = a_4 (sqrt(1.5)) and a = 1."""
    a = float(given("a_4", HALF_WIDTH_4))
    parts = [("agree_4", _agree_4(agree, a)), ("meaning_4", _meaning_4(meaning))]
    if grid_means_uniform is not None:
        means = compare_function(grid_means_uniform, lambda a: _uniform_grid_means(a), [(a,), (1.0,)],
                                 what="grid_means_uniform", mistakes=[
                                     (lambda a, v=v: _uniform_grid_means(a, v), m) for v, m in _MEANS_MISTAKES])
        if means.status == INCORRECT and "entries differ" in means.message:
            means = _wrong(means.message.replace("(Test input", "Return the 10 posterior means, posteriors @ grid, "
                                                 "of bayes_filter(prior_0 / prior_0.sum(), transition, likelihoods) "
                                                 "with the density 1/(2a) on |x_next - 0.9 x_prev| <= a. (Test input"))
        parts.insert(0, ("grid_means_uniform", means))
    statuses = {fb.status for _, fb in parts[-2:]}
    if statuses == {CORRECT} and len(parts) == 2:
        return Feedback(CORRECT, "agree_4 and meaning_4 are right.")
    if statuses == {CORRECT}:
        return _combine([parts[0], ("agree_4 and meaning_4", Feedback(CORRECT, "agree_4 and meaning_4 are right."))])
    return _combine(parts)


def _correlated(P, C, R, G, D, sign=1.0, cross_terms=2, solved=False):
    """Sigma_xy Sigma_yy^{-1} when cov(w_t, v_{t+1}) = sign * D: Sigma_xy = P C^T + G D (x_{t+1} and
    v_{t+1} correlate through G w_t) and Sigma_yy = C P C^T + C G D + (C G D)^T + R; cross_terms 0, 1
    or "double" and solved (Sigma_yy^{-T}, as np.linalg.solve(Syy, Sxy^T)^T gives it) are mistakes."""
    CGD = sign * C @ G @ D
    Syy = C @ P @ C.T + {0: 0.0, 1: CGD, 2: CGD + CGD.T, "double": 2 * CGD}[cross_terms] + R
    return np.linalg.solve(Syy if solved else Syy.T, (P @ C.T + sign * G @ D).T).T


def _correlated_reference(P, C, R, G, D):
    """The gain by bf.gaussian.condition: column j is the shift of E(x | y) when y_j moves by one."""
    Sxy, CGD, n, m = P @ C.T + G @ D, C @ G @ D, len(P), len(C)
    return np.column_stack([gaussian.condition(np.zeros(n), np.zeros(m), P, Sxy, C @ P @ C.T + CGD + CGD.T + R,
                                               e).mean for e in np.eye(m)])


_CORRELATED_MISTAKES = [
    (lambda *args: _correlated_reference(*args).T, "the gain is transposed: one row per state component."),
    (lambda P, C, R, G, D: _gain(P, C, R), "this is the usual Kalman gain, as if D were 0: with D != 0, "
     "v_{t+1} is correlated with x_{t+1} (through w_t), so the cross terms with v_{t+1} that vanished "
     "in the joint Gaussian of the state and its measurement do not all vanish."),
    (lambda *args: _correlated(*args, cross_terms=0), "Sigma_xy accounts for D but Sigma_yy does not: "
     "y_{t+1} = C x_{t+1} + v_{t+1}, a sum of two correlated terms, has cross terms too."),
    *[(lambda *args, s=solved, c=cross: _correlated(*args, cross_terms=c, solved=s), message)
      for cross, message in [(1, "Sigma_yy has one cross term only: the covariance of a sum a + b holds "
                                 "both cov(a, b) and cov(b, a) = cov(a, b)^T."),
                             ("double", "Sigma_yy holds twice the same cross term: cov(a, b) and cov(b, a) "
                                        "are transposes, equal only when symmetric (one measurement).")]
      for solved in (False, True)],
    (lambda *args: _correlated(*args, sign=-1.0), "this is the gain for cov(w_t, v_{t+1}) = -D: check the "
                                                  "sign of the cross terms."),
    (lambda P, C, R, G, D: _correlated(P, C, R, G, D.T), "you use D^T where D belongs: D = cov(w_t, v_{t+1}) "
                                                         "has shape (q, m), one row per component of w_t."),
]


def exercise_5(correlated_gain) -> Feedback:
    """correlated_gain(P, C, R, G, D) against bf.gaussian.condition on four inputs (D = 0.2 with
    C G = 0, a random (n, q, m) = (3, 2, 2), D = 0, a random (4, 1, 3))."""
    def _correlated_case(rng: np.random.Generator, n: int, q: int, m: int) -> tuple:
        """P = P_a + G Q G^T and a joint covariance [[Q, D], [D^T, R]] of (w_t, v_{t+1}): a valid model."""
        joint = _random_covariance(rng, q + m)
        G = np.round(rng.normal(size=(n, q)), 3)
        P = _random_covariance(rng, n) + G @ joint[:q, :q] @ G.T
        return np.round(P, 3), np.round(rng.normal(size=(m, n)), 3), joint[q:, q:], G, joint[:q, q:]
    rng = np.random.default_rng(50505)
    cases = [(P_EX, C_EX, R_EX, G_EX, D_5), _correlated_case(rng, 3, 2, 2),
             (P_EX, C_EX, R_EX, G_EX, np.zeros((1, 1))), _correlated_case(rng, 4, 1, 3)]
    hint = _shapes_hint("P (n, n), C (m, n), R (m, m), G (n, q), D (q, m); Sigma_xy is (n, m) and Sigma_yy is (m, m)")
    return compare_function(_hinted(correlated_gain, hint), _correlated_reference,
                            [tuple(map(np.array, case)) for case in cases], what="correlated_gain",
                            mistakes=_CORRELATED_MISTAKES)


_register(globals())
