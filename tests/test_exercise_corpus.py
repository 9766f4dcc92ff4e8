"""A corpus of plausible student answers to the 29 exercises of chapters 01-06, with the verdict
and the diagnosis each must get: regression tests of the checks (issue 20).

Each row is (exercise, answers, expected status, a fragment of the message). For a wrong answer
the fragment is the diagnosis, and it must stand on the message's first line as the student sees
it (``repr`` of the feedback, at most 76 columns: what ``nbgrader validate`` shows whole), so
the diagnosis comes before the test input and any detail. A row may carry the notebook's
variables (``ns``: a helper the statement asks for, a changed statement) and a time budget.

The answers are written as students write them (numpy, the library, typical slips); the
references they are compared with are the checks' own, computed by the library.
"""

from __future__ import annotations

import functools
import math
import time
from typing import NamedTuple

import numpy as np
import pytest
from scipy import stats
from scipy.special import logsumexp

import bayesfilt as bf
from bayesfilt.checks import CORRECT, INCORRECT, NOT_ATTEMPTED

ch = {n: getattr(bf.checks, f"ch0{n}") for n in range(1, 7)}
F32 = np.float32


class Row(NamedTuple):
    exercise: str                 # "2.1": chapter 02, exercise 1
    answers: tuple                # or a function that makes them (an experiment: run when needed)
    status: str
    fragment: str                 # on the first line of a "Not yet"; in the message otherwise
    ns: dict | None = None        # the notebook's variables the check reads
    limit: float | None = None    # a low time budget (s) for the row


def right(*answers, ns=None):
    return Row("", answers, CORRECT, "", ns)


def code(source: str, **chapter):
    """A function as a notebook defines it (its globals are the notebook's)."""
    space = {"np": np, "bf": bf, "time": time, "math": math, **chapter}
    exec(source, space)
    return space[source.split("def ", 1)[1].split("(", 1)[0]]


# --- chapter 01 -------------------------------------------------------------------------------

def update(prior, likelihood):
    joint = np.asarray(prior, dtype=float) * np.asarray(likelihood, dtype=float)
    return joint / joint.sum()


def door(first_push=True, likelihood=(0.4, 0.8)):
    b, out = 0.5, []
    for _ in range(3):
        b = b + 0.8 * (1 - b) if first_push else b
        b = likelihood[0] * b / (likelihood[0] * b + likelihood[1] * (1 - b))
        out.append(b)
    return np.array(out)


MOVE = bf.bayes.shift_transition(50, [0.05, 0.85, 0.10], offset=1, cyclic=True)
DOORS = np.isin(np.arange(50), (2, 5, 6, 14, 22, 23, 31, 37, 38, 45))
SENSOR = np.array([np.where(DOORS, 0.10, 0.95), np.where(DOORS, 0.90, 0.05)])


def run_01(seed):
    rng, x = np.random.default_rng(seed), np.full(40, 22)
    for t in range(1, 40):
        x[t] = rng.choice(50, p=MOVE[x[t - 1]])
    return x, (rng.random(40) < SENSOR[1, x]).astype(int)


def mass_near(belief, cell, half_width=2):
    return belief[np.mod(cell + np.arange(-half_width, half_width + 1), 50)].sum()


def belief_near_truth(seed, which="posterior"):
    x, y = run_01(seed)
    run = bf.bayes.bayes_filter(np.full(50, 1 / 50), MOVE, SENSOR[y])
    return float(mass_near(run.priors[-1] if which == "prior" else run.posteriors[-1], x[-1]))


SEEDS_01 = [s for s in range(20) if belief_near_truth(s) < 0.5]


def evidences_01(std, start=None):
    x, _ = run_01(3)
    ys = x + 3.0 * np.random.default_rng(5).standard_normal(40)
    liks = [bf.bayes.gaussian_likelihood(np.arange(50.0), y, std) for y in ys]
    start = np.full(50, 1 / 50) if start is None else start
    return bf.bayes.bayes_filter(start, MOVE, liks).log_evidence


EV_01 = np.array([evidences_01(3.0), evidences_01(1.0)])
STEP = np.array([0.05, 0.85, 0.10])
MEAN_01, VAR_01 = 20 * STEP @ np.arange(3), 20 * (STEP @ np.arange(3) ** 2 - (STEP @ np.arange(3)) ** 2)


def float32_update(prior, likelihood):
    joint = np.asarray(prior, dtype=F32) * np.asarray(likelihood, dtype=F32)
    return joint / joint.sum()


def in_place_update(prior, likelihood):
    prior = np.asarray(prior, dtype=float)
    prior *= likelihood
    return prior / prior.sum()


def exits(prior, likelihood):
    import sys
    sys.exit("done")


def stub_update(prior, likelihood):
    """Posterior bel(x_t)."""
    # YOUR CODE HERE


def no_return_update(prior, likelihood):
    joint = prior * likelihood  # noqa: F841


CH01 = [
    right(update), right(float32_update), right(lambda p, l: p * l / np.dot(p, l)),
    Row("1.1", (lambda p, l: p * l,), INCORRECT, "the posterior is not normalised"),
    Row("1.1", (lambda p, l: p * l / np.sum(l),), INCORRECT, "the posterior is not normalised"),
    Row("1.1", (lambda p, l: (p / l) / np.sum(p / l),), INCORRECT, "you divide where Bayes' rule"),
    Row("1.1", (lambda p, l: p / np.sum(p),), INCORRECT, "does not depend on the likelihood"),
    Row("1.1", (lambda p, l: l / np.sum(l),), INCORRECT, "the prior is missing"),
    Row("1.1", (lambda p, l: (p + l) / np.sum(p + l),), INCORRECT, "you add prior and likelihood"),
    Row("1.1", (lambda p, l: (update(p, l), np.dot(p, l)),), INCORRECT, "is a pair: return only the"),
    Row("1.1", (lambda p, l: float(np.dot(p, l)),), INCORRECT, "is a single number"),
    Row("1.1", (in_place_update,), INCORRECT, "changes its argument prior in place"),
    Row("1.1", (lambda p, l: bf.bayes.update(p, l).posterior,), INCORRECT, "uses bf.bayes, which the"),
    Row("1.1", (exits,), INCORRECT, "your function raised SystemExit"),
    Row("1.1", (code("def update_by_hand(prior, likelihood):\n    while True:\n        try:\n"
                     "            time.sleep(1)\n        except:\n            pass"),), INCORRECT,
        "stopped after 0.3 s: update_by_hand did not return", None, 0.3),
    Row("1.1", (stub_update,), NOT_ATTEMPTED, "update_by_hand has no body yet"),
    Row("1.1", (no_return_update,), INCORRECT, "did you forget `return`"),
    Row("1.1", (lambda p, l: p * l / (p * l).sum() * (l / l),), INCORRECT, "NaN or inf where the likelihood"),
    right(door()), right(np.round(door(), 3).tolist()),
    Row("1.2", (1 - door(),), INCORRECT, "gives bel(closed)"),
    Row("1.2", (door(first_push=False),), INCORRECT, "has no push in it"),
    Row("1.2", (bf.bayes.bayes_filter([0.5, 0.5], [[1, 0], [0.8, 0.2]], [[0.4, 0.8]] * 3).posteriors[:, 0],),
        INCORRECT, "starts with a reading, not a push"),
    Row("1.2", (door(likelihood=(0.6, 0.2)),), INCORRECT, "uses the likelihood of 'sense open'"),
    Row("1.2", (np.round(door(), 2),), INCORRECT, "looks rounded to 2 decimals"),
    Row("1.2", (door()[0],), INCORRECT, "is the first value only"),
    Row("1.2", (np.column_stack([door(), 1 - door()]),), INCORRECT, "holds whole beliefs"),
    Row("1.2", ([0.6, 0.7, 0.8],), INCORRECT, "has its first value wrong already"),
    right(EV_01), right(np.round(EV_01, 2)),
    Row("1.3", (EV_01[::-1],), INCORRECT, "has the two values swapped"),
    Row("1.3", (np.exp(EV_01),), INCORRECT, "is an evidence, not a log evidence"),
    Row("1.3", (EV_01 / np.log(10),), INCORRECT, "uses log10"),
    Row("1.3", (EV_01 / 40,), INCORRECT, "is the log evidence per step"),
    Row("1.3", (-EV_01,), INCORRECT, "has the wrong sign"),
    Row("1.3", ([evidences_01(9.0), EV_01[1]],), INCORRECT, "uses the variance 9"),
    Row("1.3", ([EV_01[0], evidences_01(1.0, np.eye(50)[22])],), INCORRECT, "starts the filter at the true cell"),
    Row("1.3", (EV_01[0],), INCORRECT, "must hold two log evidences"),
    right(SEEDS_01, ns={"belief_near_truth": belief_near_truth}),
    Row("1.4", (SEEDS_01,), INCORRECT, "belief_near_truth is not written yet",
        {"belief_near_truth": code('def belief_near_truth(seed):\n    """doc"""\n')}),
    Row("1.4", ([s for s in range(20) if s not in SEEDS_01],), INCORRECT, "lists the seeds where the belief"),
    Row("1.4", ([s for s in range(20) if belief_near_truth(s, "prior") < 0.5],), INCORRECT, "uses the prior at t = 39"),
    Row("1.4", (len(SEEDS_01),), INCORRECT, "is a single number"),
    Row("1.4", ([belief_near_truth(s) < 0.5 for s in range(20)],), INCORRECT, "holds True/False"),
    Row("1.4", (SEEDS_01[1:],), INCORRECT, "is not yet right: 1 seed(s) are missing"),
    Row("1.4", (SEEDS_01,), INCORRECT, "belief_near_truth(0) uses the prior",
        {"belief_near_truth": lambda seed: belief_near_truth(seed, "prior")}),
    Row("1.4", (SEEDS_01,), INCORRECT, "belief_near_truth rebinds the chapter's",
        {"belief_near_truth": code("def belief_near_truth(seed):\n    global x_true\n    x_true = np.zeros(40)\n"
                                   "    return mass(seed)", x_true=np.arange(40), mass=belief_near_truth)}),
    right([MEAN_01, VAR_01]), right(np.round([MEAN_01, VAR_01], 3)),
    Row("1.5", ([VAR_01, MEAN_01],), INCORRECT, "has the two values swapped"),
    Row("1.5", ([20, VAR_01],), INCORRECT, "the mean in answer_5 is the commanded distance"),
    Row("1.5", ([MEAN_01 / 20, VAR_01],), INCORRECT, "the mean in answer_5 is the mean of one step"),
    Row("1.5", ([MEAN_01, VAR_01 / 20],), INCORRECT, "the mean in answer_5 is right; the variance is"),
    Row("1.5", ([MEAN_01, math.sqrt(VAR_01)],), INCORRECT, "the mean in answer_5 is right; the variance is"),
    Row("1.5", ([MEAN_01, 20 * VAR_01],), INCORRECT, "the mean in answer_5 is right; the variance grows"),
    Row("1.5", ([MEAN_01, VAR_01 + MEAN_01 ** 2],), INCORRECT, "the mean in answer_5 is right; the variance is"),
]

# --- chapter 02 -------------------------------------------------------------------------------

P1, C1, R1 = np.array([[1.2, 0.45], [0.45, 0.34]]), np.array([[1.0, 0.0]]), np.array([[1.0]])
inv = np.linalg.inv
# exercise 1: section 2's random walk by hand from 20 m, 3 m^2 with Q = 1, R = 2 and y = 23, 28.5 m, then the
# steady state for Q = 1, R = 6 (P^2 - P - 6 = 0); exercise 3: section 3's cloud given the position 12 m
MEANS_1, VARS_1, P_INF_1, K_INF_1 = np.array([22.0, 25.5]), np.array([4 / 3, 14 / 13]), 3.0, 1 / 3
MEAN_3, SD_3 = 0.43 + 3.96 / 27.35 * (12 - 4.76), math.sqrt(0.87 - 3.96 ** 2 / 27.35)


def gain(P, C, R):
    return np.linalg.solve(C @ P @ C.T + R, C @ P).T


def slow_gain(P, C, R):
    time.sleep(0.12)
    return gain(P, C, R)


def gain_float32(P, C, R):
    P, C, R = (np.asarray(a, dtype=F32) for a in (P, C, R))
    return P @ C.T @ np.linalg.inv(C @ P @ C.T + R)


def correlated_gain(P, C, R, G, D, sign=1.0, cross=2):
    CGD = sign * C @ G @ D
    Syy = C @ P @ C.T + {0: 0.0, 1: CGD, 2: CGD + CGD.T}[cross] + R
    return np.linalg.solve(Syy, (P @ C.T + sign * G @ D).T).T


@functools.lru_cache(maxsize=None)     # a student's function that is slow to run only once
def grid_means(a, variant="right"):
    model = bf.models.LinearGaussian(A=[[0.9]], C=[[0.5]], Q=[[0.5]], R=[[0.4]], m0=[1.0], P0=[[2.0]])
    ys = bf.models.simulate(model, 10, np.random.default_rng(3)).ys
    grid = np.linspace(-15.0, 15.0, 2001)
    A = 1.0 if variant == "no A" else 0.9
    transition = bf.bayes.grid_transition(grid, lambda x1, x0: np.where(np.abs(x1 - A * x0) <= a, 0.5 / a, 0.0))
    norm = lambda x, m, v: np.exp(-0.5 * (x - m) ** 2 / v) / np.sqrt(2 * np.pi * v)  # noqa: E731
    likelihoods = [bf.bayes.grid_likelihood(grid, y, lambda y, x: norm(y, 0.5 * x, 0.4)) for y in ys[:, 0]]
    prior_0 = norm(grid, 1.0, 2.0)
    run = bf.bayes.bayes_filter(prior_0 / prior_0.sum(), transition, likelihoods)
    return (run.priors if variant == "priors" else run.posteriors) @ grid


CH02 = [
    right(MEANS_1, VARS_1, P_INF_1, K_INF_1), right([22, 25.5], [1.333, 1.077], 3, 0.333),
    right(MEANS_1.astype(F32), VARS_1.astype(F32), F32(P_INF_1), F32(K_INF_1)),
    Row("2.1", ([21.8, 24.3125], [1.2, 0.75], P_INF_1, K_INF_1), INCORRECT, "the prediction forgets Q"),
    Row("2.1", ([20.0, 22.0], [4.0, 7 / 3], P_INF_1, K_INF_1), INCORRECT, "these are the predictions"),
    Row("2.1", (MEANS_1, np.sqrt(VARS_1), P_INF_1, K_INF_1), INCORRECT, "these are standard deviations"),
    Row("2.1", (VARS_1, MEANS_1, P_INF_1, K_INF_1), INCORRECT, "holds the variances; swap"),
    Row("2.1", (MEANS_1, VARS_1, 2.0, K_INF_1), INCORRECT, "this is the steady variance after the update"),
    Row("2.1", (MEANS_1, VARS_1, 6.0, K_INF_1), INCORRECT, "this is twice P_inf"),
    Row("2.1", (MEANS_1, VARS_1, P_INF_1, 0.25), INCORRECT, "the gain uses the prediction's variance"),
    Row("2.1", (MEANS_1, VARS_1, P_INF_1, 0.75), INCORRECT, "the gain weighs the prediction against"),
    right(gain), right(lambda P, C, R: P @ C.T @ inv(C @ P @ C.T + R)), right(gain_float32),
    Row("2.2", (lambda P, C, R: gain(P, C, R).T,), INCORRECT, "the gain is transposed"),
    Row("2.2", (lambda P, C, R: P @ C.T @ inv(C @ P @ C.T),), INCORRECT, "S is computed without R"),
    Row("2.2", (lambda P, C, R: P @ C.T @ inv(C @ P @ C.T - R),), INCORRECT, "S is computed as C P C^T - R"),
    Row("2.2", (lambda P, C, R: P @ C.T @ (C @ P @ C.T + R),), INCORRECT, "you multiply P C^T by S"),
    Row("2.2", (lambda P, C, R: P @ C.T @ inv(R),), INCORRECT, "you use R alone as S"),
    Row("2.2", (lambda P, C, R: np.linalg.solve(C @ P @ C.T + R, P @ C.T),), INCORRECT,
        "fails on test input 1: ValueError"),
    Row("2.2", (lambda P, C, R: bf.kalman.update(np.zeros(len(P)), P, np.zeros(len(C)), C, R).gain,),
        INCORRECT, "uses bf.kalman, which the statement"),
    Row("2.2", (slow_gain,), INCORRECT, "stopped after 0.3 s", None, 0.3),
    right(MEAN_3, SD_3), right(round(MEAN_3, 3), round(SD_3, 3)),
    Row("2.3", (0.43, SD_3), INCORRECT, "this is the mean velocity before anything"),
    Row("2.3", (0.43 + 3.96 / 28.35 * (12 - 4.76), SD_3), INCORRECT, "this is the slope for a noisy position"),
    Row("2.3", (0.43 + 3.96 / 0.87 * (12 - 4.76), SD_3), INCORRECT, "the slope is Pi_21 / Pi_11"),
    Row("2.3", (MEAN_3, SD_3 ** 2), INCORRECT, "this is the variance Pi_22 - Pi_21^2 / Pi_11"),
    Row("2.3", (MEAN_3, math.sqrt(0.87)), INCORRECT, "this is the velocity's spread before"),
    Row("2.3", (MEAN_3, math.sqrt(0.87 + 3.96 ** 2 / 27.35)), INCORRECT, "learning the position removes"),
    right(0, "best linear estimate", grid_means), right(0, "BLUE"), right(0, "Best-linear estimate"),
    Row("2.4", (1, "best linear estimate"), INCORRECT, "count the steps from 1"),
    Row("2.4", (0, "conditional mean"), INCORRECT, "meaning_4 is not the right option"),
    Row("2.4", (0, "posterior mean"), INCORRECT, "meaning_4 is not the right option"),
    Row("2.4", (0, "kalman"), INCORRECT, "meaning_4 must be one of"),
    Row("2.4", (0, "best linear estimate", lambda a: grid_means(a, "priors")), INCORRECT,
        "these are the means of the predictions"),
    Row("2.4", (0, "best linear estimate", lambda a: grid_means(a, "no A")), INCORRECT,
        "the state moves first"),
    Row("2.4", (0, "best linear estimate", code('def grid_means_uniform(a):\n    """Means."""\n    # YOUR CODE HERE\n')),
        NOT_ATTEMPTED, "grid_means_uniform has no body yet"),
    right(correlated_gain),
    Row("2.5", (lambda *a: correlated_gain(*a).T,), INCORRECT, "the gain is transposed"),
    Row("2.5", (lambda P, C, R, G, D: gain(P, C, R),), INCORRECT, "this is the usual Kalman gain"),
    Row("2.5", (lambda *a: correlated_gain(*a, cross=0),), INCORRECT, "Sigma_xy accounts for D but"),
    Row("2.5", (lambda *a: correlated_gain(*a, cross=1),), INCORRECT, "Sigma_yy has one cross term only"),
    Row("2.5", (lambda *a: correlated_gain(*a, sign=-1.0),), INCORRECT, "the gain for cov(w_t, v_{t+1}) = -D"),
]

# --- chapter 03 -------------------------------------------------------------------------------

DP = bf.models.damped_particle()
X1, V1, X2, V2 = DP.index_of("x1", "x1_dot", "x2", "x2_dot")


def steady(model):
    ss = bf.kalman.steady_state(model)
    eig = np.linalg.eigvals(model.A @ (np.eye(4) - ss.gain @ model.C))
    return ss, np.abs(eig)


SS1, EIG1 = steady(bf.models.damped_particle(damping=1.0))
SS98, EIG98 = steady(DP)
STD_1, RADIUS_1 = math.sqrt(SS1.cov[X1, X1]), EIG1.max()
YS = bf.models.simulate(DP, 100, np.random.default_rng(2024)).ys
DT_2, SIGMA_A_2 = 0.5, 0.1
A_2 = np.kron(np.eye(2), [[1.0, DT_2], [0.0, 0.98 ** DT_2]])


@functools.cache
def runs_2():
    """The answer cell's runs of 03 ex 2 (200 runs of 200 half steps, seed 22), made when a row runs."""
    rng, xs = np.random.default_rng(22), np.zeros((200, 200, 4))
    xs[:, 0] = rng.normal(size=(200, 4))
    for t in range(1, 200):
        xs[:, t] = xs[:, t - 1] @ A_2.T + np.kron(rng.normal(0.0, SIGMA_A_2, size=(200, 2)), [DT_2 ** 2 / 2, DT_2])
    return xs, xs[..., [0, 2]] + rng.normal(size=(200, 200, 2))


def nees_2_of(GQGt, predicted=False):
    xs, ys = runs_2()
    out = bf.kalman.batch_kalman_filter(bf.models.LinearGaussian(A_2, DP.C, GQGt, np.eye(2), np.zeros(4), np.eye(4)), ys)
    means, covs = (out.pred_means, out.pred_covs) if predicted else (out.means, out.covs)
    return float(bf.gaussian.squared_mahalanobis(xs - means, covs).mean())


def g_2(dt):
    return np.array([[dt ** 2 / 2], [dt]])


GQGT_2 = SIGMA_A_2 ** 2 * np.kron(np.eye(2), g_2(DT_2) @ g_2(DT_2).T)      # as a student writes it
OLD_2 = SIGMA_A_2 ** 2 * np.kron(np.eye(2), g_2(1.0) @ g_2(1.0).T)        # section 6's G_pc G_pc^T


def nees(d, P):
    return np.array([di @ np.linalg.solve(Pi, di) for di, Pi in zip(d, P)])


def gap_covs(length, fill=np.nan):
    ys = YS.copy()
    ys[40:40 + length] = fill
    return bf.kalman.kalman_filter(DP, ys).covs


def end_of_gap(length):
    return float(gap_covs(length)[39 + length, X1, X1])


SLOPE = math.log(end_of_gap(20) / end_of_gap(10)) / math.log(2)
YS_LONG = bf.models.simulate(DP, 1000, np.random.default_rng(5)).ys
@functools.cache
def z_5() -> list:
    """z_t of the three mistuned models on ys_long (made when a row runs)."""
    out = []
    for kw in (dict(force_var=0.1), dict(meas_var=0.1), dict(meas_var=10.0)):
        res = bf.kalman.kalman_filter(bf.models.damped_particle(**kw), YS_LONG)
        out.append(bf.gaussian.normalised_innovations(res.innovations, res.innovation_covs))
    return out


def lag1() -> np.ndarray:
    return np.array([bf.gaussian.autocorrelation(z, 1)[0] for z in z_5()])


def notebook_03(ys):
    """The answer cell of 03 ex 4 that writes into section 1's ys, then computes slope_4 (its own calls
    write NaN rows 40-59 into ys before the check runs)."""
    fun = code("def end_of_gap_variance(length):\n    ys[40:40 + length] = np.nan\n"
               "    return float(bf.kalman.kalman_filter(model, ys).covs[39 + length, x1, x1])",
               ys=ys, model=DP, x1=X1)
    slope = math.log(fun(20) / fun(10)) / math.log(2)
    return fun, slope


YS_NB = YS.copy()
CH03 = [
    right("yes", STD_1, RADIUS_1), right(" Yes", float(np.round(STD_1, 5)), float(np.round(RADIUS_1, 5))),
    Row("3.1", ("no", STD_1, RADIUS_1), INCORRECT, "stabilising_1 is not the right option"),
    Row("3.1", ("yes", math.sqrt(SS98.cov[X1, X1]), RADIUS_1), INCORRECT, "std_1: this is section 7's value"),
    Row("3.1", ("yes", SS1.cov[X1, X1], RADIUS_1), INCORRECT, "std_1: this is the variance"),
    Row("3.1", ("yes", math.sqrt(SS1.pred_cov[X1, X1]), RADIUS_1), INCORRECT, "standard deviation of the prediction"),
    Row("3.1", ("yes", STD_1, RADIUS_1 ** 2), INCORRECT, "radius_1: this is |lambda|_max²"),
    Row("3.1", ("yes", STD_1, 1.0), INCORRECT, "radius_1: 1 is the spectral radius of A"),
    Row("3.1", ("yes", STD_1, 0.5), INCORRECT, "radius_1 is too small"),
    Row("3.1", ("yes", STD_1, np.abs(np.linalg.eigvals(np.eye(4) - SS1.gain @ DP.C)).max()), INCORRECT,
        "radius_1: 1 is the spectral radius of A (and, to 4"),
    Row("", lambda: (GQGT_2, nees_2_of(GQGT_2), nees_2_of(OLD_2)), CORRECT, ""),
    Row("", lambda: (GQGT_2.astype(F32), F32(nees_2_of(GQGT_2)), round(nees_2_of(OLD_2), 8)), CORRECT, ""),
    Row("3.2", lambda: (OLD_2, nees_2_of(OLD_2), nees_2_of(OLD_2)), INCORRECT, "section 6's design for Δt = 1"),
    Row("3.2", lambda: (np.kron(np.eye(2), 0.01 * np.array([[DT_2 ** 3 / 3, DT_2 ** 2 / 2], [DT_2 ** 2 / 2, DT_2]])),
                        nees_2_of(GQGT_2), nees_2_of(OLD_2)), INCORRECT, "continuous white-noise model"),
    Row("3.2", lambda: (np.diag([0, 0.0025, 0, 0.0025]), nees_2_of(np.diag([0, 0.0025, 0, 0.0025])),
                        nees_2_of(OLD_2)), INCORRECT, "this puts the push on the velocity only"),
    Row("3.2", lambda: (np.diag(np.diag(GQGT_2)), nees_2_of(GQGT_2), nees_2_of(OLD_2)), INCORRECT,
        "the position-velocity entries"),
    Row("3.2", lambda: (GQGT_2 / SIGMA_A_2, nees_2_of(GQGT_2), nees_2_of(OLD_2)), INCORRECT, "you multiplied by sigma_a"),
    Row("3.2", lambda: (GQGT_2[:2, :2], nees_2_of(GQGT_2), nees_2_of(OLD_2)), INCORRECT, "is the per-axis block"),
    Row("3.2", lambda: (GQGT_2[np.ix_([0, 2, 1, 3], [0, 2, 1, 3])], nees_2_of(GQGT_2), nees_2_of(OLD_2)), INCORRECT,
        "GQGt_2 is in the order"),
    Row("3.2", lambda: (GQGT_2, nees_2_of(OLD_2), nees_2_of(GQGT_2)), INCORRECT, "this is the value of nees_old_2"),
    Row("3.2", lambda: (GQGT_2, nees_2_of(GQGT_2, predicted=True), nees_2_of(OLD_2)), INCORRECT,
        "this uses the predictions"),
    Row("3.2", lambda: (GQGT_2, 200 * 200 * nees_2_of(GQGT_2), nees_2_of(OLD_2)), INCORRECT,
        "this is the sum over all runs"),
    right(nees), right(lambda d, P: np.einsum("ti,ti->t", d, np.linalg.solve(P, d[..., None])[..., 0])),
    Row("3.3", (lambda d, P: np.einsum("ti,tij,tj->t", d, P, d),), INCORRECT, "you multiply by P_t"),
    Row("3.3", (lambda d, P: np.sum(d ** 2 / np.diagonal(P, axis1=1, axis2=2), axis=1),), INCORRECT,
        "you divide by the variances only"),
    Row("3.3", (lambda d, P: np.sqrt(nees(d, P)),), INCORRECT, "you return the square root"),
    Row("3.3", (lambda d, P: nees(d, P) / d.shape[1],), INCORRECT, "you divide by the dimension n"),
    Row("3.3", (lambda d, P: np.sum(d ** 2, axis=1),), INCORRECT, "you return d_t^T d_t"),
    Row("3.3", (lambda d, P: float(np.mean(nees(d, P))),), INCORRECT, "you return a single number"),
    Row("3.3", (lambda d, P: bf.gaussian.squared_mahalanobis(d, P),), INCORRECT, "uses bf.gaussian, which"),
    Row("3.3", (lambda d, P: d @ np.linalg.inv(P[0]) @ d.T,), INCORRECT, "pairs every step with every other"),
    right(end_of_gap, SLOPE), right(end_of_gap, round(SLOPE, 2)),
    Row("3.4", (lambda n: math.sqrt(end_of_gap(n)), SLOPE), INCORRECT, "you return the standard deviation"),
    Row("3.4", (lambda n: float(gap_covs(n)[40 + n, X1, X1]), SLOPE), INCORRECT, "this is t = 40 + length"),
    Row("3.4", (lambda n: float(gap_covs(n, 0.0)[39 + n, X1, X1]), SLOPE), INCORRECT, "the variance did not grow"),
    Row("3.4", (lambda n: float(gap_covs(n)[-1, X1, X1]), SLOPE), INCORRECT, "this is the variance at the last"),
    Row("3.4", (lambda n: gap_covs(n)[39 + n], SLOPE), INCORRECT, "you return the whole covariance"),
    Row("3.4", (end_of_gap, SLOPE / 2), INCORRECT, "slope_4: this is the standard deviation's slope"),
    Row("3.4", (end_of_gap, math.log10(end_of_gap(20) / end_of_gap(10)) / math.log(2)), INCORRECT,
        "slope_4: you mixed two logarithms"),
    Row("3.4", (end_of_gap, end_of_gap(20) / end_of_gap(10)), INCORRECT, "slope_4: this is the ratio v(20) / v(10)"),
    Row("3.4", (end_of_gap, math.log(end_of_gap(20) / end_of_gap(10))), INCORRECT, "slope_4: you did not divide by"),
    Row("3.4", (*notebook_03(YS_NB),), INCORRECT, "changes the chapter's variable ys in place", {"ys": YS_NB}),
    Row("", lambda: (lag1(), "ratio"), CORRECT, ""), Row("", lambda: (np.round(lag1(), 3), "Ratio"), CORRECT, ""),
    Row("3.5", lambda: (np.array([bf.gaussian.autocorrelation(z, 2)[1] for z in z_5()]), "ratio"), INCORRECT,
        "lag1_5 is lag 2"),
    Row("3.5", lambda: (np.array([bf.gaussian.autocorrelation(z, 2)[:, 0] for z in z_5()]), "ratio"), INCORRECT,
        "lag1_5 holds lags 1 and 2 of component 1"),
    Row("3.5", lambda: (lag1()[[2, 1, 0]], "ratio"), INCORRECT, "has its rows in another order"),
    Row("3.5", (np.ones((3, 2)), "ratio"), INCORRECT, "lag1_5 is lag 0"),
    Row("3.5", lambda: (lag1()[:, :1], "ratio"), INCORRECT, "holds one component of r̃_t only"),
    Row("3.5", lambda: (lag1(), "scale"), INCORRECT, "sees_5 is not the right option"),
    Row("3.5", lambda: (lag1(), "the ratio Q/R"), INCORRECT, "sees_5 must be one of"),
]

# --- chapter 04 -------------------------------------------------------------------------------

RB = bf.models.range_bearing()


def jacobian(x, dtype=float):
    x = np.asarray(x, dtype=dtype)
    rho2 = x[0] ** 2 + x[1] ** 2
    rho = np.sqrt(rho2)
    return np.array([[x[0] / rho, x[1] / rho, 0, 0], [-x[1] / rho2, x[0] / rho2, 0, 0]], dtype=dtype)


def complex_step(x):
    x, J = np.asarray(x, dtype=float), np.zeros((2, 4))
    for k in range(2):
        z = x.astype(complex)
        z[k] += 1e-20j
        rho = np.sqrt(z[0] ** 2 + z[1] ** 2)
        J[:, k] = np.imag([rho, 2 * np.arctan(z[1] / (rho + z[0]))]) / 1e-20
    return J


def converted(y, rho_in=True):
    r, b = (y[0] if rho_in else 1.0), y[1]
    J = np.array([[np.cos(b), -r * np.sin(b)], [np.sin(b), r * np.cos(b)]])
    return J @ RB.R @ J.T


def iterated(m0, P0, y, n_iter, mode="right"):
    x = m0
    for _ in range(n_iter + (1 if mode == "plus_one" else 0)):
        H = RB.H(m0 if mode == "fixed_H" else x)
        r = bf.models.range_bearing_residual(y, RB.h(x)) - (0 if mode == "no_term" else H @ (m0 - x))
        x = m0 + P0 @ H.T @ np.linalg.solve(H @ P0 @ H.T + RB.R, r)
    return x


Y0 = bf.models.simulate(RB, 100, np.random.default_rng(0), x0=bf.models.RANGE_BEARING_TRUE_START).ys[0]
LIMIT = iterated(RB.m0, RB.P0, Y0, 50)[:2]
def nees_2(how=np.mean) -> float:
    """The given experiment of the answer cell, seed 10, summarised by how (made when a row runs)."""
    return float(how(bf.checks.ch04._seed_10_nees()))


def turn_jacobian(x, dtype=float, omega_col=1.0, coupling=1.0):
    vx, vy, w = (float(v) for v in x[2:])
    c, s = np.cos(w), np.sin(w)
    return np.array([[1, 0, coupling, 0, 0], [0, 1, 0, coupling, 0], [0, 0, c, -s, omega_col * (-s * vx - c * vy)],
                     [0, 0, s, c, omega_col * (c * vx - s * vy)], [0, 0, 0, 0, 1]], dtype=dtype)


def f_turn(x):
    rx, ry, vx, vy, w = x
    return np.array([rx + vx, ry + vy, np.cos(w) * vx - np.sin(w) * vy, np.sin(w) * vx + np.cos(w) * vy, w])


def turn_complex_step(x):
    x, F = np.asarray(x, dtype=float), np.zeros((5, 5))
    for k in range(5):
        z = x.astype(complex)
        z[k] += 1e-20j
        F[:, k] = np.imag(f_turn(z)) / 1e-20
    return F


def innovation(y, p, wrap=lambda a: np.pi - np.mod(np.pi - a, 2 * np.pi)):
    d = np.asarray(y, dtype=float) - np.asarray(p, dtype=float)
    return np.array([d[0], wrap(d[1])])


CH04 = [
    right(jacobian), right(lambda x: jacobian(x, F32)), right(lambda x: jacobian(x).astype(F32)),
    Row("4.1", (lambda x: jacobian(x).T,), INCORRECT, "H is transposed"),
    Row("4.1", (lambda x: jacobian(x)[::-1],), INCORRECT, "the rows are swapped"),
    Row("4.1", (lambda x: jacobian(x) * [[1], [-1]],), INCORRECT, "the bearing row has the wrong sign"),
    Row("4.1", (lambda x: jacobian(x) * [[1], [np.hypot(x[0], x[1])]],), INCORRECT, "the bearing row is divided by rho"),
    Row("4.1", (lambda x: jacobian(x)[:, :2],), INCORRECT, "not (2, 2)"),
    Row("4.1", (lambda x: bf.ekf.numerical_jacobian(RB.h, x),), INCORRECT, "a finite-difference Jacobian"),
    Row("4.1", (code("def range_bearing_jacobian(x):\n    return model.H(x)", model=RB),), INCORRECT,
        "uses model.H, which the statement rules out"),
    Row("4.1", (complex_step,), INCORRECT, "holds a complex number (1j): a complex-step"),
    Row("4.1", (lambda x: jacobian(x)[:, [0, 2, 1, 3]],), INCORRECT, "columns are in chapter 03's state order"),
    Row("", lambda: (converted, nees_2()), CORRECT, ""), Row("", lambda: (lambda y: converted(y).astype(F32), nees_2()), CORRECT, ""),
    Row("4.2", lambda: (lambda y: converted(y, rho_in=False), nees_2()), INCORRECT, "rho is missing from J"),
    Row("4.2", lambda: (lambda y: np.diag(np.diag(converted(y))), nees_2()), INCORRECT,
        "you kept only the diagonal"),
    Row("4.2", lambda: (lambda y: np.linalg.inv(converted(y)), nees_2()), INCORRECT, "this is the inverse"),
    Row("4.2", lambda: (converted, nees_2(np.sum)), INCORRECT, "did you sum the NEES"),
    Row("4.2", lambda: (converted, nees_2(lambda e: e[:, -1].mean())), INCORRECT, "the average at the last step"),
    Row("4.2", lambda: (converted, nees_2(np.median)), INCORRECT, "nees_2 is the median"),
    right(iterated, LIMIT),
    Row("4.3", (lambda *a: iterated(*a, mode="plus_one"), LIMIT), INCORRECT, "you return x^(n_iter + 1)"),
    Row("4.3", (lambda *a: iterated(*a, mode="no_term"), LIMIT), INCORRECT, "the term - H_i (m0 - x^(i)) is"),
    Row("4.3", (lambda *a: iterated(*a, mode="fixed_H"), LIMIT), INCORRECT, "keep the Jacobian of m0"),
    Row("4.3", (iterated, iterated(RB.m0, RB.P0, Y0, 1)[:2]), INCORRECT, "answer_3 is x^(1), the ordinary"),
    Row("4.3", (iterated, iterated(RB.m0, RB.P0, Y0, 50)), INCORRECT, "answer_3 is a whole state"),
    Row("4.3", (iterated, LIMIT[::-1]), INCORRECT, "answer_3 has xi_x and xi_y swapped"),
    Row("4.3", (lambda *a: iterated(*a)[:2], LIMIT), INCORRECT, "return the whole state x^(n_iter)"),
    right(turn_jacobian), right(lambda x: turn_jacobian(x, F32)),
    Row("4.4", (lambda x: turn_jacobian(x).T,), INCORRECT, "F is transposed"),
    Row("4.4", (lambda x: turn_jacobian(x, omega_col=0.0),), INCORRECT, "the omega column is zero"),
    Row("4.4", (lambda x: turn_jacobian(x, omega_col=-1.0),), INCORRECT, "the omega column has the wrong sign"),
    Row("4.4", (lambda x: turn_jacobian(x, coupling=0.0),), INCORRECT, "the position rows miss the velocities"),
    Row("4.4", (lambda x: bf.ekf.numerical_jacobian(f_turn, x),), INCORRECT, "a finite-difference Jacobian"),
    Row("4.4", (turn_complex_step,), INCORRECT, "a complex-step derivative"),
    right(innovation), right(lambda y, p: innovation(y, p, lambda a: (a + np.pi) % (2 * np.pi) - np.pi)),
    Row("4.5", (lambda y, p: np.subtract(y, p),), INCORRECT, "the bearing difference is not wrapped"),
    Row("4.5", (lambda y, p: innovation(y, p, lambda a: np.mod(a, 2 * np.pi)),), INCORRECT, "wrapped into [0, 2 pi)"),
    Row("4.5", (lambda y, p: -innovation(y, p),), INCORRECT, "the innovation has the wrong sign"),
    Row("4.5", (lambda y, p: bf.models.range_bearing_residual(y, p),), INCORRECT, "uses bf.models.range_bearing_"),
    Row("4.5", (lambda y, p: innovation(y, p)[1],), INCORRECT, "return both components"),
    Row("4.5", (lambda y, p: innovation(y, p, lambda a: np.arctan(np.tan(a))),), INCORRECT, "arctan(tan(d)) folds"),
    Row("4.5", (lambda y, p: innovation(y, p, lambda a: a - 2 * np.pi if a > np.pi else a),), INCORRECT,
        "you wrap a bearing difference above pi but not"),
]

# --- chapter 05 -------------------------------------------------------------------------------


def log_normalize(lw, dtype=float, as_float=True):
    lw = np.asarray(lw, dtype=dtype)
    m = np.max(lw)
    s = m + np.log(np.sum(np.exp(lw - m)))
    return lw - s, float(s) if as_float else s


def no_shift(lw):
    s = np.log(np.sum(np.exp(lw)))
    return lw - s, s


def exp_then_log(lw):
    w = np.exp(lw - np.max(lw))
    return np.log(w / w.sum()), np.max(lw) + np.log(w.sum())


def lse_in_place(lw):
    lw -= np.max(lw)
    return log_normalize(lw)


ESS_A, ESS_B = 1 / np.sum(np.square([0.4, 0.3, 0.2, 0.1])), 1 / np.sum(np.square([0.25, 0.25, 0.5]))
W_C = np.exp([0.0, -1.0, -2.0])
ESS_C = W_C.sum() ** 2 / np.sum(W_C ** 2)


def increment(x, y, var=1.1, mean_factor=0.9):
    return float(stats.norm.logpdf(y, mean_factor * x, math.sqrt(var)))


@functools.lru_cache(maxsize=None)
def mean_ess(R):
    model = bf.models.LinearGaussian(A=[[0.9]], C=[[1.0]], Q=[[1.0]], R=[[R]], m0=[0.0], P0=[[1.0]])
    proposals = {"bootstrap": None, "optimal": bf.particle.optimal_proposal(model)}
    records, rngs = np.random.default_rng(14), {k: np.random.default_rng(15) for k in proposals}
    ess = {k: np.empty((10, 40)) for k in proposals}
    for r in range(10):
        ys = bf.models.simulate(model, 40, records).ys
        for k, p in proposals.items():
            ess[k][r] = bf.particle.particle_filter(model, ys, 500, rngs[k], proposal=p, ess_threshold=0).ess
    return ess["bootstrap"][:, 5].mean(), ess["optimal"][:, 39].mean()


def answer_5_4() -> tuple:
    """(R_boot, R_opt) from the student's experiment (made when a row runs)."""
    return tuple((0.01, 0.1, 1.0)[int(np.argmin(col))] for col in np.array([mean_ess(R) for R in (0.01, 0.1, 1.0)]).T)

CH05 = [
    right(log_normalize), right(lambda lw: log_normalize(lw, F32)), right(lambda lw: log_normalize(lw, F32, False)),
    Row("5.1", (no_shift,), INCORRECT, "log_sum is -inf: exp(l) underflowed"),
    Row("5.1", (lambda lw: (lw - np.max(lw), np.max(lw)),), INCORRECT, "log_sum is only the largest"),
    Row("5.1", (lambda lw: (log_normalize(lw)[0], log_normalize(lw)[1] - np.log(lw.size)),), INCORRECT,
        "log_sum is the log of the mean weight"),
    Row("5.1", (lambda lw: (lw - np.max(lw), log_normalize(lw)[1]),), INCORRECT, "log_W is only shifted by m"),
    Row("5.1", (lambda lw: (np.exp(log_normalize(lw)[0]), log_normalize(lw)[1]),), INCORRECT,
        "log_W holds the normalised weights"),
    Row("5.1", (lambda lw: (log_normalize(lw)[1] - lw, log_normalize(lw)[1]),), INCORRECT, "log_W has the wrong sign"),
    Row("5.1", (exp_then_log,), INCORRECT, "log_W is -inf for a particle"),
    Row("5.1", (lambda lw: log_normalize(lw)[0],), INCORRECT, "one array; return the pair"),
    Row("5.1", (lambda lw: (lw - logsumexp(lw), logsumexp(lw)),), INCORRECT, "uses logsumexp"),
    Row("5.1", (lse_in_place,), INCORRECT, "changes its argument lw in place"),
    right([ESS_A, ESS_B, ESS_C]), right(np.round([ESS_A, ESS_B, ESS_C], 3)),
    Row("5.2", ([1 / ESS_A, ESS_B, ESS_C],), INCORRECT, "answer_2[0], the ESS of the weights (a), is the sum"),
    Row("5.2", ([ESS_A, 1 / 6, ESS_C],), INCORRECT, "is 1 / sum_i (w^(i))^2 of the weights as given"),
    Row("5.2", ([ESS_A, ESS_B, float("nan")],), INCORRECT, "answer_2[2], the ESS of the log-weights (c), is NaN"),
    Row("5.2", ([ESS_C, ESS_B, ESS_A],), INCORRECT, "right numbers in the wrong order"),
    Row("5.2", ([ESS_A, ESS_B, 4.0],), INCORRECT, "counts all 4 particles as equal"),
    Row("5.2", ([1 / 0.4, ESS_B, ESS_C],), INCORRECT, "is 1 / max_i W^(i)"),
    right(increment), right(lambda x, y: F32(increment(x, y))),
    Row("5.3", (lambda x, y: increment(x, y, var=0.1),), INCORRECT, "uses the variance R alone"),
    Row("5.3", (lambda x, y: increment(x, y, var=1.0),), INCORRECT, "uses C Q C^T alone"),
    Row("5.3", (lambda x, y: increment(x, y, mean_factor=1.0),), INCORRECT, "centres y on C x_prev"),
    Row("5.3", (lambda x, y: increment(x, y, var=1.21),), INCORRECT, "as a standard deviation"),
    Row("5.3", (lambda x, y: math.exp(increment(x, y)),), INCORRECT, "returns alpha"),
    Row("5.3", (lambda x, y: -0.5 * (y - 0.9 * x) ** 2 / 1.1,), INCORRECT, "misses the constant"),
    Row("5.3", (lambda x, y: -increment(x, y),), INCORRECT, "has the wrong sign"),
    Row("5.3", (lambda x, y: increment(x, y, mean_factor=0.8),), INCORRECT, "the output for test input 1 is too"),
    Row("", lambda: (answer_5_4(),), CORRECT, "", {"mean_ess": mean_ess}),
    Row("", lambda: (list(answer_5_4()),), CORRECT, ""),
    Row("5.4", lambda: (answer_5_4()[::-1],), INCORRECT, "has the two values swapped"),
    Row("5.4", ((1.1, 30.0),), INCORRECT, "give the value of R, not the ESS"),
    Row("5.4", lambda: (answer_5_4(),), INCORRECT, "mean_ess is not written yet",
        {"mean_ess": code('def mean_ess(R):\n    """(ESS, ESS)."""\n    # YOUR CODE HERE\n')}),
    Row("5.4", lambda: (answer_5_4(),), INCORRECT, "mean_ess(0.01) returns the pair in the wrong order",
        {"mean_ess": lambda R: mean_ess(R)[::-1]}),
    right(["b", "c"]), right("b and c"), right(("C", "B")),
    Row("5.5", (["a", "b", "c"],), INCORRECT, "includes the damped particle (a)"),
    Row("5.5", (["c"],), INCORRECT, "leaves out dp_pushed (b)"),
    Row("5.5", ([],), INCORRECT, "is empty"),
    Row("5.5", ([1, 2],), INCORRECT, "must be a list of the letters"),
]

# --- chapter 06 -------------------------------------------------------------------------------


def systematic(w, u):
    C = np.cumsum(w)
    return np.searchsorted(C / C[-1], (np.arange(len(w)) + u) / len(w), side="right")


SIX, RNG = np.array([0.05, 0.32, 0.08, 0.22, 0.13, 0.20]), np.random.default_rng(0)
W2, M2 = np.array([0.42, 0.28, 0.18, 0.12]), 10
PHI = M2 * W2[1] % 1
ANSWER_6_2 = np.array([M2 * W2[1], M2 * W2[1] * (1 - W2[1]), PHI * (1 - PHI), PHI * (1 - PHI / 2)])
LG_6 = bf.models.LinearGaussian(A=[[0.9]], C=[[1.0]], Q=[[1.0]], R=[[1.0]], m0=[0.0], P0=[[1.0]])
BATCH = bf.models.simulate_many(LG_6, 20, 50, np.random.default_rng(15))


def threshold_experiment(thresholds, worst=np.argmax):
    counts, rmse = _threshold_runs(tuple(thresholds))
    return counts, thresholds[int(worst(rmse))]


@functools.lru_cache(maxsize=None)
def _threshold_runs(thresholds):
    counts, rmse = [], []
    for theta in thresholds:
        rng = np.random.default_rng(16)
        runs = [(bf.particle.particle_filter(LG_6, ys, 500, rng, ess_threshold=theta), bf.kalman.kalman_filter(LG_6, ys))
                for ys in BATCH.ys]
        counts.append(np.mean([r.resampled.sum() for r, _ in runs]))
        rmse.append(np.sqrt(np.mean([np.mean((r.means[:, 0] - k.means[:, 0]) ** 2 / k.covs[:, 0, 0])
                                     for r, k in runs])))
    return np.array(counts), rmse


def answer_6_3() -> tuple:
    return threshold_experiment((0.1, 0.5, 0.9))

CH06 = [
    right(systematic), right(lambda w, u: systematic(w, u).astype(np.int32)),
    Row("6.1", (lambda w, u: np.bincount(systematic(w, u), minlength=len(w)),), INCORRECT, "returns offspring counts"),
    Row("6.1", (lambda w, u: (np.arange(len(w)) + u) / len(w),), INCORRECT, "returns the points u_j"),
    Row("6.1", (lambda w, u: systematic(w, u) + 1,), INCORRECT, "'s indices are shifted by one"),
    Row("6.1", (lambda w, u: np.searchsorted(np.cumsum(w), (np.arange(len(w)) + u) / len(w), side="right"),),
        INCORRECT, "does not normalise the weights"),
    Row("6.1", (lambda w, u: np.searchsorted(np.cumsum(w) / np.sum(w), (np.arange(len(w)) + u) / len(w)),),
        INCORRECT, "picks a particle of weight 0"),
    Row("6.1", (lambda w, u: systematic(w, 0.0),), INCORRECT, "ignores u"),
    Row("6.1", (lambda w, u: systematic(w, u).astype(float),), INCORRECT, "as floating-point numbers"),
    Row("6.1", (lambda w, u: np.sort(bf.resampling.systematic(w, RNG, len(w))),), INCORRECT,
        "gives different ancestors when called twice"),
    Row("6.1", (lambda w, u: bf.resampling.from_uniforms(w, np.full(len(w), u)),), INCORRECT,
        "uses bf.resampling, which the statement"),
    right(ANSWER_6_2), right(np.round(ANSWER_6_2, 3)),
    Row("6.2", ([W2[1], *ANSWER_6_2[1:]],), INCORRECT, "is the probability W^(2)"),
    Row("6.2", ([ANSWER_6_2[0], M2 * W2[1], *ANSWER_6_2[2:]],), INCORRECT, "is M W^(2) (a Poisson variance)"),
    Row("6.2", ([*ANSWER_6_2[:2], ANSWER_6_2[1], ANSWER_6_2[3]],), INCORRECT, "is the multinomial variance"),
    Row("6.2", ([*ANSWER_6_2[:3], PHI * (1 - PHI / 3)],), INCORRECT, "uses the wrong number of residual draws"),
    Row("6.2", ([*ANSWER_6_2[:3], PHI * (1 - PHI) / 2],), INCORRECT, "divides the whole variance φ (1 - φ) by M̃"),
    Row("6.2", ([M2 * W2[0], *ANSWER_6_2[1:]],), INCORRECT, "is the value for particle 1"),
    Row("6.2", ([*ANSWER_6_2[:2], math.sqrt(PHI * (1 - PHI)), ANSWER_6_2[3]],), INCORRECT, "is a standard deviation"),
    Row("", lambda: (answer_6_3(),), CORRECT, "", {"threshold_experiment": threshold_experiment,
                                                  "thresholds": (0.1, 0.5, 0.9)}),
    Row("6.3", lambda: ((answer_6_3()[0] * 20, answer_6_3()[1]),), INCORRECT, "is a total over the 20 records"),
    Row("6.3", lambda: ((answer_6_3()[0][::-1], answer_6_3()[1]),), INCORRECT, "lists the thresholds in reverse order"),
    Row("6.3", lambda: (threshold_experiment((0.1, 0.5, 0.9), np.argmin),), INCORRECT, "is not the threshold with the"),
    Row("6.3", lambda: ((answer_6_3()[1], answer_6_3()[0]),), INCORRECT, "is in the wrong order"),
    Row("6.3", lambda: (answer_6_3(),), INCORRECT, "threshold_experiment is not written yet",
        {"threshold_experiment": code('def threshold_experiment(thresholds):\n    """(counts, theta)."""\n')}),
    right((2.0, "conservative"), 500), right((2, "Conservative"), 500),
    Row("6.4", ((0.1, "conservative"), 500), INCORRECT, "the jitter is too small"),
    Row("6.4", ((2.0, "overconfident"), 500), INCORRECT, "the verdict, is not what the median NEES"),
    Row("6.4", (("conservative", 2.0), 500), INCORRECT, "is in the wrong order"),
    Row("6.4", ((3, "conservative"), 500), INCORRECT, "must be one of the roughening constants"),
]


# --- the rows, named by chapter -------------------------------------------------------------

def _named(rows):
    """The rows, each right answer (written without its exercise) given the exercise of the row after."""
    out, exercise = list(rows), None
    for k in range(len(out) - 1, -1, -1):
        exercise = out[k].exercise or exercise
        out[k] = out[k]._replace(exercise=exercise)
    return out


CORPUS = _named(CH01 + CH02 + CH03 + CH04 + CH05 + CH06)


def _id(row: Row) -> str:
    return f"{row.exercise}-{row.status.replace(' ', '')}-{row.fragment[:30]}"


def judge(row: Row, monkeypatch=None):
    chapter, number = row.exercise.split(".")
    check = getattr(ch[int(chapter)], f"exercise_{number}")
    if row.limit is not None and monkeypatch is not None:
        monkeypatch.setattr(bf.checks, "TIME_LIMIT", row.limit)
    answers = row.answers() if callable(row.answers) else row.answers
    return check(*answers, namespace=row.ns) if row.ns is not None else check(*answers)


@pytest.mark.parametrize("row", CORPUS, ids=[_id(r) for r in CORPUS])
def test_the_corpus(row, monkeypatch):
    fb = judge(row, monkeypatch)
    assert fb.status == row.status, (row.exercise, fb)
    assert row.fragment in fb.message, (row.fragment, fb.message)
    if row.status == INCORRECT:                       # the diagnosis starts on the first line
        text, first = " ".join(repr(fb).split()), repr(fb).splitlines()[0]
        assert text.index(" ".join(row.fragment.split())) < len(first), (row.fragment, repr(fb))


def test_the_corpus_covers_every_exercise_with_right_and_wrong_answers():
    expected = {f"{c}.{e}" for c, n in ((1, 5), (2, 5), (3, 5), (4, 5), (5, 5), (6, 4)) for e in range(1, n + 1)}
    wrong = {r.exercise for r in CORPUS if r.status == INCORRECT}
    right_ = {r.exercise for r in CORPUS if r.status == CORRECT}
    assert wrong == expected and right_ == expected
    assert sum(r.status == INCORRECT for r in CORPUS) >= 150
