"""Checks of chapter 01's exercises (the Bayes recursion on a grid; references from
bf.bayes). One line per exercise (the notebook variables each reads with ``given``, in
brackets)::

    exercise_1(update_by_hand): Bayes' rule, prior x likelihood over the evidence, on
        five inputs;
    exercise_2(answer_2): bel(open) after each push and "closed" reading of Thrun's door
        [door_transitions, door_sensor, start_2];
    exercise_3(answer_3): the log evidences of the 40 position readings under two stds
        [y_pos, stds_3];
    exercise_4(answer_4): the seeds whose belief near the true cell at t = 39 is below
        0.5, and the function belief_near_truth(seed) the statement asks for
        [belief_near_truth, seeds_4];
    exercise_5(answer_5): the mean and variance of the distance moved in 20 steps
        [kernel, steps_5].
"""

from __future__ import annotations

import functools
import math
import numbers

import numpy as np

from .. import bayes
from . import (CORRECT, INCORRECT, NOT_ATTEMPTED, Feedback, _combine, _common_factor, _each_case, _hinted, _named,
               _not_attempted, _wrong, compare_array, compare_function, compare_number, given,
               register as _register)

# the statements' numbers: the ring corridor (50 cells of 1 m, its doors, the slip of a one-cell move)
N_CELLS, DOORS, SLIP = 50, (2, 5, 6, 14, 22, 23, 31, 37, 38, 45), (0.05, 0.85, 0.10)
P_DOOR, START_CELL, T_STEPS, CORRIDOR_SEED = (0.05, 0.90), 22, 40, 3   # p("door" | wall), (| door)
PUSH = np.array([[1.0, 0.0], [0.8, 0.2]])                           # Thrun's door: 0 open, 1 closed
SENSE_OPEN, SENSE_CLOSED, START_2 = np.array([0.6, 0.2]), np.array([0.4, 0.8]), np.array([0.5, 0.5])
POSITION_STD, POSITION_SEED, MODEL_STDS = 3.0, 5, (3.0, 1.0)       # exercise 3
SEEDS_4, NEAR, THRESHOLD, STEPS_5 = tuple(range(20)), 2, 0.5, 20   # exercises 4 and 5
ATOL_HAND, ATOL_LOG_EVIDENCE = 1e-3, 6e-3


def _proportional(a, v) -> bool:
    """Is a = c v for one constant c > 0?"""
    a, v = np.asarray(a, dtype=float), np.asarray(v, dtype=float)
    return a.shape == v.shape and np.all(np.isfinite(v)) and (np.allclose(a, v) or (_common_factor(a, v) or -1) > 0)


@functools.lru_cache(maxsize=1)
def _corridor():
    """(move, sensor) of the ring corridor; sensor[y, j] = p(y | cell j), y = 0 wall, 1 door."""
    door = np.isin(np.arange(N_CELLS), DOORS)
    sensor = np.array([np.where(door, 1 - P_DOOR[1], 1 - P_DOOR[0]), np.where(door, *P_DOOR[::-1])])
    return bayes.shift_transition(N_CELLS, SLIP, offset=1, cyclic=True), sensor


def _simulate(seed: int):
    """The ring corridor's run, draw for draw: the whole true path, then the door readings."""
    (move, sensor), rng, x = _corridor(), np.random.default_rng(seed), np.full(T_STEPS, START_CELL)
    for t in range(1, T_STEPS):
        x[t] = rng.choice(N_CELLS, p=move[x[t - 1]])
    return x, (rng.random(T_STEPS) < sensor[1, x]).astype(int)


_UPDATE_MISTAKES = [(lambda p, l: lambda a: (np.any(p == 0) or np.any(l == 0)) and not np.all(np.isfinite(a)),
                     "NaN or inf where the likelihood (or the prior) is 0: you divide by it. Bayes' rule "
                     "multiplies prior and likelihood, and divides only by the evidence."),
                    (lambda p, l: lambda a: _proportional(a, p * l), "the posterior is not normalised: it is "
                     "proportional to prior x likelihood but does not sum to 1. Divide by the evidence, the sum "
                     "of prior x likelihood over all states (not that of the likelihood)."),
                    (lambda p, l: lambda a: _proportional(a, p / l) or _proportional(a, l / p),
                     "you divide where Bayes' rule multiplies: the posterior is proportional to prior x "
                     "likelihood."),
                    (lambda p, l: lambda a: _proportional(a, p) and not _proportional(p, p * l),
                     "the posterior does not depend on the likelihood: it is the prior (normalised); multiply "
                     "by the likelihood."),
                    (lambda p, l: lambda a: _proportional(a, l) and not _proportional(l, p * l),
                     "the prior is missing: this is the likelihood normalised (only a flat prior gives that)."),
                    (lambda p, l: lambda a: _proportional(a, p + l) or _proportional(a, p / p.sum() + l),
                     "you add prior and likelihood; Bayes' rule multiplies them.")]


def exercise_1(update_by_hand) -> Feedback:
    """update_by_hand(prior, likelihood) against bf.bayes.update on five inputs."""
    def _posterior_compare(out, expected, what="the output") -> Feedback:
        """compare_array for a posterior; a named mistake is a predicate on the output."""
        if callable(expected):
            return Feedback(CORRECT if expected(np.asarray(out, dtype=float)) else INCORRECT, "")
        if isinstance(out, tuple) and len(out) == 2:
            return _wrong(f"{what} is a pair: return only the posterior, an array of shape "
                          f"{np.shape(expected)}, not (posterior, evidence).")
        if isinstance(out, numbers.Number):
            return _wrong(f"{what} is a single number; return the whole posterior, an array of shape "
                          f"{np.shape(expected)} (one probability per state).")
        return compare_array(out, expected, what, probability=True)
    rng = np.random.default_rng(101)
    cases = [(np.array([0.5, 0.5]), SENSE_OPEN),                       # Thrun's door
             (np.array([2, 6, 2]), np.array([0.9, 0.05, 0.9])),        # integer counts
             (rng.dirichlet(np.ones(N_CELLS)), _corridor()[1][1]),      # a corridor belief, "door"
             (np.array([0.0, 0.25, 0.25, 0.5, 0.0]), np.array([1.0, 0.0, 1.0, 0.0, 1.0])),  # zeros
             (np.array([0.1, 0.2, 0.3, 0.4]), 1e-3 * np.array([4.0, 3.0, 2.0, 1.0]))]       # small
    return compare_function(_hinted(update_by_hand, lambda exc, args: (
        " Hint: the prior is integer counts here, and in-place arithmetic (*=, /=) cannot store fractions in an "
        "integer array: compute a new array instead of changing prior."
        if isinstance(exc, TypeError) and args[0].dtype.kind in "iu" and "cast" in str(exc) else "")),
        lambda prior, likelihood: bayes.update(prior, likelihood).posterior, cases, "update_by_hand",
        _posterior_compare, _UPDATE_MISTAKES,
        forbidden=[({"bayes"}, "bf.bayes, which the statement rules out: write Bayes' rule in numpy, prior "
                               "x likelihood divided by its sum.")])


def exercise_2(answer) -> Feedback:
    """answer_2: bel(open) after each of three steps (push, sense "closed") from start_2."""
    transitions = given("door_transitions", {"push": PUSH})
    sensor = given("door_sensor", np.array([SENSE_OPEN, SENSE_CLOSED]))
    push, closed, opened = (np.asarray(a, dtype=float) for a in (transitions["push"], sensor[1], sensor[0]))
    start = np.asarray(given("start_2", START_2), dtype=float)

    def _door_run(likelihood=closed, order="push first", normalise=True, transposed=False):
        """bel(open) after each of the three readings, computed right or in a plausible wrong way."""
        b, out = start, []
        for step in range(3):
            if order == "reading first":                            # bf.bayes.bayes_filter's order
                b = bayes.update(bayes.predict(b, push) if step else b, likelihood).posterior
            elif order == "push after":
                b = bayes.predict(bayes.update(b, likelihood).posterior, push)
            else:
                if order != "no push":
                    b = push @ b if transposed else bayes.predict(b, push) if normalise else b @ push
                b = bayes.update(b, likelihood).posterior if normalise else b * likelihood
            out.append(b[0])
        return np.array(out)
    w, ref = "answer_2", _door_run()
    near = functools.partial(np.allclose, rtol=1e-6, atol=ATOL_HAND)
    mistakes = [
        (lambda a: a.shape == (3, 2) and (near(a[:, 0], ref) or near(a[:, 1], ref)),
         f"{w} holds whole beliefs, two numbers per reading; give bel(open) only, shape (3,)."),
        (lambda a: a.shape == (3, 2), f"{w} must be bel(open) only, shape (3,); got shape (3, 2)."),
        (lambda a: a.size == 1 and near(a.item(), ref[0]), f"{w} is the first value only (and it is "
                                                           f"right); give all 3, an array of shape (3,)."),
        (lambda a: a.size == 1, f"{w} must be 3 numbers, bel(open) after each reading; got one."),
        (1.0 - ref, f"{w} gives bel(closed); the question asks for bel(open), the first entry."),
        (_door_run(order="no push"), f"{w} has no push in it: the belief only follows the readings. Predict "
                                     f"with door_transitions['push'] before each reading."),
        (_door_run(order="reading first"), f"{w} starts with a reading, not a push: bf.bayes.bayes_filter "
         f"updates with its first likelihood at t = 0, before any prediction, so bayes_filter(start, push, "
         f"[door_sensor[1]] * 3) senses, pushes, senses, ... Give it a likelihood of ones at t = 0 "
         f"(no_measurement, no reading yet) and keep posteriors[1:]."),
        (_door_run(order="push after"), f"{w} reports the belief after the push that follows each reading: "
                                        f"push first, then report the posterior after the reading."),
        (_door_run(opened), f"{w} uses the likelihood of 'sense open' (row 0 of door_sensor); the "
                            f"reading is 'closed': row 1."),
        (_door_run(normalise=False), f"{w} is not normalised: divide each product prior x likelihood by "
                                     f"the evidence, so that the belief sums to one."),
        (_door_run(transposed=True), f"{w} applies the push as transition @ belief (down the columns); the "
                                     f"prior is belief @ transition."),
        (lambda a: a.shape == (3,) and abs(a[0] - ref[0]) <= ATOL_HAND, f"{w} has the first value right "
         f"but not the later ones: each push starts from the posterior of the previous reading."),
        (lambda a: a.shape == (3,) and np.all((a >= 0) & (a <= 1)), lambda a: f"{w} has its first value "
         f"wrong already: push first (predict with door_transitions['push']: {start[0]:g} open becomes "
         f"bel-bar(open) = {start[0]:g} + {push[1, 0]:g} x {start[1]:g}), then update with the 'closed' "
         f"likelihood (row 1 of door_sensor) and normalise.")]
    return _named(answer, ref, w, mistakes, atol=ATOL_HAND, rtol=0, note=(
        f"Three 'closed' readings, yet look how bel(open) moves: each push opens a closed door with "
        f"probability {push[1, 0]:g}, while a 'closed' reading favours 'closed' only "
        f"{closed[1] / closed[0]:g} : 1 ({closed[1]:g} / {closed[0]:g})."))


@functools.lru_cache(maxsize=16)
def _position_run(ys: tuple, std: float, variant: str = "right"):
    """(log evidence, evidences) of the ring corridor's filter on exercise 3's position readings."""
    grid, ys = np.arange(N_CELLS, dtype=float), np.array(ys)
    liks = np.array([bayes.gaussian_likelihood(grid, y, std) for y in ys])
    if variant == "wrapped":                                    # the distance round the ring
        d = np.abs(ys[:, None] - grid) % N_CELLS
        liks = np.exp(-0.5 * (np.minimum(d, N_CELLS - d) / std) ** 2) / (math.sqrt(2 * math.pi) * std)
    start = np.eye(N_CELLS)[START_CELL] if variant == "known start" else np.full(N_CELLS, 1 / N_CELLS)
    run = bayes.bayes_filter(start, _corridor()[0], liks)
    return run.log_evidence, run.evidences


def _y_pos() -> tuple:
    """Exercise 3's readings: the notebook's y_pos, or section 2's path read with std 3 m (seed 5)."""
    ys = _simulate(CORRIDOR_SEED)[0] + POSITION_STD * np.random.default_rng(POSITION_SEED).standard_normal(T_STEPS)
    return tuple(np.asarray(given("y_pos", ys), dtype=float).ravel())


def exercise_3(answer) -> Feedback:
    """answer_3 = [log evidence with stds_3[0], with stds_3[1]] of the 40 position readings y_pos."""
    def _near_log(x, v) -> bool:
        """x within the tolerance of v (relatively for an evidence v near 0)."""
        return bool(np.isclose(x, v, rtol=1e-3, atol=0) if 0 < v < 1e-3 else abs(x - v) <= ATOL_LOG_EVIDENCE)
    w, ys, stds = "answer_3", _y_pos(), tuple(float(s) for s in given("stds_3", MODEL_STDS))
    ref = np.array([_position_run(ys, s)[0] for s in stds])
    if isinstance(answer, (list, tuple, np.ndarray)) and -np.inf in np.asarray(answer, dtype=object):
        return _wrong(f"{w} contains -inf: a log of an evidence that underflowed to 0? Use "
                      f"run.log_evidence, a sum of logarithms.")
    mistakes = [(lambda a: a.size == 1, f"{w} must hold two log evidences, np.array([with std {stds[0]:g} m, "
                                        f"with std {stds[1]:g} m]); got a single number."),
                (ref[::-1], f"{w} has the two values swapped: first std {stds[0]:g} m, then std {stds[1]:g} m.")]
    for k, s in enumerate(stds):
        log_ev, evidences = _position_run(ys, s)
        label = f"{w}[{k}] (std {s:g} m)"
        off = lambda a, k=k: a.shape == (2,) and not _near_log(a[k], ref[k])  # noqa: E731
        mistakes += [(lambda a, v=v, off=off, k=k: off(a) and _near_log(a[k], v), f"{label} {m}") for v, m in [
            (log_ev + T_STEPS * math.log(math.sqrt(2 * math.pi) * s), "lacks the constant 1/(sqrt(2 pi) std) of "
             "the normal density: it cancels in every posterior, not in the evidence, and differs between "
             "the two stds."),
            (_position_run(ys, s * s)[0] if s != 1.0 else np.nan, f"uses the variance {s * s:g} where the "
                                                                  f"standard deviation {s:g} is expected."),
            (math.exp(log_ev), "is an evidence, not a log evidence: take the natural logarithm."),
            (log_ev / math.log(10), "uses log10; the log evidence is a natural logarithm."),
            (math.log(evidences[-1]), "is the evidence of the last reading only, not the product over the 40 steps."),
            (log_ev / T_STEPS, "is the log evidence per step; give the sum over all 40 steps."),
            (-log_ev, "has the wrong sign: the log evidence is log p(y_0:39), not its negative."),
            (_position_run(ys, s, "wrapped")[0], "measures the distance round the ring; use "
             "bf.bayes.gaussian_likelihood(grid, y_pos[t], std) as it is (no wrap-around)."),
            (_position_run(ys, s, "known start")[0], "starts the filter at the true cell 22, which the "
             "filter does not know: start from the uniform belief.")]]
        mistakes.append((off, lambda a, k=k, label=label: (
            f"{label} is too {'large' if a[k] > ref[k] else 'small'}. Use y_pos as given, the uniform "
            f"initial belief, move, and the rows bf.bayes.gaussian_likelihood(grid, y_pos[t], std) "
            f"for t = 0..39; give at least 2 decimals.")))
    return _named(answer, ref, w, mistakes, atol=ATOL_LOG_EVIDENCE, rtol=0, note=(
        "A difference d between two log evidences is a factor e^d between the densities the two "
        "models gave to the same 40 readings."))


@functools.lru_cache(maxsize=None)
def _mass(seed: int) -> dict:
    """The mass near the truth at t = 39 of section 2's run with this seed, computed right and in
    the wrong ways of _MASS_MISTAKES."""
    def near(belief, cell, half_width=NEAR):
        return float(belief[np.mod(cell + np.arange(-half_width, half_width + 1), N_CELLS)].sum())
    (x, y), (move, sensor) = _simulate(seed), _corridor()
    run = bayes.bayes_filter(np.full(N_CELLS, 1 / N_CELLS), move, sensor[y])
    post = run.posteriors
    return dict(zip(("right", "prior", "t = 38", "cell only", "start cell"), (
        near(post[-1], x[-1]), near(run.priors[-1], x[-1]), near(post[-2], x[-2]), near(post[-1], x[-1], 0),
        near(post[-1], x[0]))))


_MASS_MISTAKES = [
    ("prior", "uses the prior at t = 39 (run.priors); the belief is run.posteriors[39]."),
    ("t = 38", "uses the belief at t = 38; the question is about t = 39 (index 39, or -1)."),
    ("cell only", "uses the probability of the true cell alone; the question asks for that within "
                  "2 m of it, cells x - 2 .. x + 2 on the ring (mass_near)."),
    ("start cell", "measures the belief near the start cell 22; compare with the true cell at "
                   "t = 39, x_true[39].")]


def _belief_near_truth(fun, seeds) -> Feedback:
    """belief_near_truth(seed), the statement's helper, against section 2's run for each seed."""
    what = "belief_near_truth"

    def judge(out, where, args) -> Feedback:
        (seed,), table = args, _mass(args[0])
        ref = table["right"]
        fb = compare_number(out, ref, f"belief_near_truth({seed})", rtol=1e-9, atol=1e-12)
        if fb.status != INCORRECT or " must be " in fb.message or "NaN" in fb.message:
            return fb
        for kind, message in _MASS_MISTAKES:
            if np.isclose(float(np.ravel(out)[0]), table[kind], rtol=1e-9) and table[kind] != ref:
                return _wrong(f"{what}({seed}) {message}")
        return _wrong(f"{what}({seed}) is not section 2's belief for this seed: re-run section 2's code "
                      f"exactly, only the seed changed (rng = np.random.default_rng(seed); the whole path "
                      f"first, then the readings), and return mass_near(posteriors[39], x[39]).")
    return _each_case(fun, what, [(s,) for s in seeds], ["" for _ in seeds], judge)


def _seeds_answer(answer, seeds) -> Feedback:
    """answer_4 against the seeds whose mass near the truth is below 0.5."""
    w = "answer_4"
    if answer is None or answer is Ellipsis:
        return _not_attempted(w)
    if isinstance(answer, (numbers.Integral, np.ndarray)) and not isinstance(answer, bool) and np.ndim(answer) == 0:
        return _wrong(f"{w} is a single number: give the seeds themselves (e.g. [1, 7]), not how many.")
    if isinstance(answer, (dict, str, bytes, bool, np.bool_)) or not hasattr(answer, "__iter__"):
        return _wrong(f"{w} must be a list of seeds (integers from {min(seeds)} to {max(seeds)}), got "
                      f"{type(answer).__name__}.")
    items = list(answer)
    if items and all(isinstance(s, (bool, np.bool_)) for s in items):
        return _wrong(f"{w} holds True/False, one per seed: give the list of the seeds themselves whose "
                      f"belief is below {THRESHOLD:g}, e.g. [s for s in range(20) if belief_near_truth(s) < 0.5].")
    bad = [s for s in items if isinstance(s, (bool, np.bool_)) or not isinstance(s, numbers.Real)
           or not float(s).is_integer()]
    if bad:
        return _wrong(f"{w} must hold seeds, whole numbers from {min(seeds)} to {max(seeds)}; it holds "
                      f"{bad[0]!r}. (The list of seeds, not of beliefs or of True/False per seed.)")
    got = {int(s) for s in items}
    below = lambda kind: {s for s in seeds if _mass(s)[kind] < THRESHOLD}  # noqa: E731
    ref, outside = below("right"), sorted(got - set(seeds))
    if outside:
        return _wrong(f"{w} holds {', '.join(map(str, outside))}, outside the seeds {min(seeds)} to "
                      f"{max(seeds)} of the statement.")
    if len(got) != len(items):
        return _wrong(f"{w} lists a seed more than once; give each seed once.")
    if got == ref:
        return Feedback(CORRECT, f"{w} is right. Now plot the belief of one of these seeds (bf.plotting.belief_image) "
                                 f"with the door map in mind: were the readings ambiguous, or is the filter wrong?")
    if got == set(seeds) - ref and got != ref:
        return _wrong(f"{w} lists the seeds where the belief within 2 m of the true cell is at least "
                      f"{THRESHOLD:g} (the robot was found); the question asks for those below {THRESHOLD:g}.")
    for kind, message in _MASS_MISTAKES:
        if below(kind) != ref and got == below(kind):
            return _wrong(f"{w} {message}")
    parts = ([f"{len(got - ref)} of your seeds should not be there"] if got - ref else []) + \
            ([f"{len(ref - got)} seed(s) are missing"] if ref - got else [])
    return _wrong(f"{w} is not yet right: {' and '.join(parts)}. Re-run the ring corridor's code "
                  f"exactly, only the seed changed (the whole path first, then the readings), and "
                  f"use the posterior at t = 39 and mass_near with the true cell at t = 39.")


def exercise_4(answer) -> Feedback:
    """answer_4: the seeds of seeds_4 whose belief within 2 m of the true cell at t = 39 is below 0.5;
    the statement's belief_near_truth(seed), which must give that belief, is called for each seed."""
    seeds = tuple(int(s) for s in given("seeds_4", SEEDS_4))
    if not set(seeds) <= set(range(100)):
        return _wrong("the check knows the seeds 0 to 99 only (seeds_4 of the answer cell).")
    value = _seeds_answer(answer, seeds)
    fun = given("belief_near_truth", None)
    if fun is None:                       # no notebook (a unit test): the list alone
        return value
    helper = _belief_near_truth(fun, seeds)
    if helper.status == NOT_ATTEMPTED and value.status != NOT_ATTEMPTED:
        return _wrong(f"belief_near_truth is not written yet: the statement asks for the run as a "
                      f"function of the seed (so that section 2's variables stay as they are), and the "
                      f"check calls it. {value.message if value.correct else ''}".strip())
    return value if helper.correct else _combine([("answer_4", value), ("belief_near_truth", helper)])


def exercise_5(answer) -> Feedback:
    """answer_5 = [mean, variance] of the distance in steps_5 steps (the belief of bf.bayes.predict)."""
    kernel = np.asarray(given("kernel", SLIP), dtype=float)
    w, m, n = "answer_5", int(given("steps_5", STEPS_5)), max(N_CELLS, 2 * len(kernel) * int(given("steps_5", STEPS_5)))
    move, cells, belief = bayes.shift_transition(n, kernel, offset=1, cyclic=True), np.arange(n), np.eye(n)[0]
    for _ in range(m):                                   # a ring large enough never to wrap round
        belief = bayes.predict(belief, move)
    mean, d, p = float(belief @ cells), np.arange(len(kernel)), kernel
    var = float(belief @ (cells - mean) ** 2)
    step_var = float(p @ d ** 2) - float(p @ d) ** 2
    near = functools.partial(np.allclose, rtol=1e-4, atol=ATOL_HAND)
    mean_off = lambda a: a.shape == (2,) and not near(a[0], mean)  # noqa: E731
    mistakes = [(lambda a: a.size == 1, f"{w} must be two numbers, np.array([mean, variance]); got one."),
                (np.array([var, mean]), f"{w} has the two values swapped: first the mean, then the variance.")]
    mistakes += [(lambda a, v=v: mean_off(a) and near(a[0], v), f"the mean in {w} {msg}") for v, msg in [
        (m, f"is the commanded distance, {m} x 1 cell; the slip is not symmetric: one step's mean is the "
            f"sum of d p(d) over d = 0, 1, 2."),
        (float(p @ d), f"is the mean of one step; the distance is the sum of {m} independent steps.")]]
    mistakes.append((mean_off, lambda a: f"the mean in {w} is too {'large' if a[0] > mean else 'small'}: "
                                         f"one step moves d = 0, 1, 2 cells with the slip's probabilities; "
                                         f"the means of the {m} independent steps add."))
    mistakes += [(lambda a, v=v: a.shape == (2,) and near(a[1], v), f"the mean in {w} is right; the "
                  f"variance {msg}") for v, msg in [
        (step_var, f"is the variance of one step; for {m} independent steps the variances add."),
        (m * m * step_var, f"grows like {m}^2: that is the variance of {m} times one step's distance "
                           f"(the same slip repeated). Independent steps add variances."),
        (math.sqrt(var), "is a standard deviation; the question asks for the variance."),
        (m * float(p @ d ** 2), "is a second moment: the variance is E[d^2] - E[d]^2."),
        (var + mean ** 2, "is the second moment E[D^2]; the variance subtracts the squared mean."),
        (m * float(p @ (d - 1.0) ** 2), "is the spread about the commanded move of 1 cell, not about the mean step.")]]
    mistakes.append((lambda a: a.shape == (2,), lambda a: f"the mean in {w} is right; " + compare_number(
        float(a[1]), var, what=f"the variance in {w}", rtol=1e-4, atol=ATOL_HAND).message))
    return _named(answer, np.array([mean, var]), w, mistakes, atol=ATOL_HAND, rtol=1e-4, note=(
        f"The belief after {m} predictions from cell 0 has this mean and variance: prediction alone "
        f"only blurs the belief."))


_register(globals())
