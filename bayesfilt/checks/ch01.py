r"""Checks for the exercises of chapter 01 (the Bayes recursion on a grid).

Each function takes what the student defined in the answer cell and returns a
:class:`bayesfilt.checks.Feedback`; the check cell of the notebook calls it as
its last line::

    import bayesfilt as bf
    bf.checks.ch01.exercise_1(update_by_hand)   # Correct / Not yet: ... / Not attempted yet

======================  ===========  ==================================================
check                   kind         the student defines
======================  ===========  ==================================================
:func:`exercise_1`      function     ``update_by_hand(prior, likelihood)``: the posterior
:func:`exercise_2`      derivation   ``answer_2``: bel(open) after push + "closed", 3 times
:func:`exercise_3`      experiment   ``answer_3``: log evidences of a position sensor,
                                     std 3 m and 1 m
:func:`exercise_4`      experiment   ``answer_4``: the seeds 0-19 whose belief is within
                                     2 m of the true cell with probability < 0.5 at t = 39
:func:`exercise_5`      derivation   ``answer_5``: mean and variance of the distance in
                                     20 steps
======================  ===========  ==================================================

The references are computed here with :mod:`bayesfilt.bayes` from the numbers
of the statements (the constants below, the same as in the notebook), never
stored, and never shown: a message names what differs (an unnormalised
posterior, a division where Bayes' rule multiplies, a skipped prediction, the
variance of one step, ...), not the expected value. A check never raises:
an answer it cannot read is feedback too.
"""

from __future__ import annotations

import functools
import math
import numbers

import numpy as np

from .. import bayes
from . import (CORRECT, Feedback, compare_array, compare_number,
               _not_attempted, _not_written, _wrong)

__all__ = ["exercise_1", "exercise_2", "exercise_3", "exercise_4", "exercise_5"]

# --------------------------------------------------------------------------
# the numbers of the statements (as in the notebook)
# --------------------------------------------------------------------------

#: section 1: a ring of 50 cells (1 m each), doors, slip of a "move one cell" command
N_CELLS = 50
DOORS = (2, 5, 6, 14, 22, 23, 31, 37, 38, 45)
SLIP = (0.05, 0.85, 0.10)                 # moves 0, 1, 2 cells
P_DOOR = (0.05, 0.90)                     # p(reading "door" | wall), p(reading "door" | door)
START_CELL = 22
T_STEPS = 40
SECTION_1_SEED = 3

#: section 6: Thrun's door, 0 = open, 1 = closed
DOOR_PUSH = ((1.0, 0.0),                  # an open door stays open
             (0.8, 0.2))                  # a closed door opens with probability 0.8
DOOR_SENSOR = ((0.6, 0.2),                # p(sense open | open), p(sense open | closed)
               (0.4, 0.8))                # p(sense closed | open), p(sense closed | closed)
DOOR_START = (0.5, 0.5)
DOOR_PUSHES = 3

#: exercise 3: readings y_t = x_t + v_t, v_t ~ N(0, 3^2), with this seed; filters with these std
POSITION_STD = 3.0
POSITION_SEED = 5
POSITION_MODEL_STDS = (3.0, 1.0)

#: exercise 4
AMBIGUITY_SEEDS = tuple(range(20))
NEAR = 2                                  # "within 2 m"
THRESHOLD = 0.5

#: exercise 5
PREDICTION_STEPS = 20

# tolerances: hand-computed answers are rounded; computed ones are not
ATOL_HAND = 1e-3
ATOL_LOG_EVIDENCE = 6e-3                  # two decimals are enough


# --------------------------------------------------------------------------
# small helpers (feedback that never raises)
# --------------------------------------------------------------------------

# _not_attempted, _not_written and _wrong come from bayesfilt.checks; the engine
# (bayesfilt.checks.exercise) runs every exercise_N.


def _as_float_array(answer, what: str):
    """(array, None), or (None, Feedback) if the answer is not an array of real numbers."""
    if isinstance(answer, (str, bytes, dict)) or callable(answer):
        return None, _wrong(f"{what} must be numbers (a numpy array), got {type(answer).__name__}.")
    try:
        a = np.asarray(answer)
    except Exception:  # noqa: BLE001 - ragged lists and odd objects
        return None, _wrong(f"{what} must be a rectangular array of numbers, got "
                            f"{type(answer).__name__}.")
    if a.dtype.kind not in "iuf":
        return None, _wrong(f"{what} must be made of real numbers, got {type(answer).__name__} "
                            f"of dtype {a.dtype}.")
    a = a.astype(float)
    if not np.all(np.isfinite(a)):
        return None, _wrong(f"{what} contains NaN or inf.")
    return a, None


def _close(a, b, atol: float, rtol: float = 1e-6) -> bool:
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    return a.shape == b.shape and bool(np.all(np.isfinite(b))) and bool(
        np.allclose(a, b, rtol=rtol, atol=atol))


def _proportional(a: np.ndarray, v: np.ndarray) -> bool:
    """Is a = c v for one constant c > 0 (zeros of v zeros of a)?"""
    if a.shape != v.shape or not np.all(np.isfinite(v)) or not np.any(v != 0):
        return False
    nz = np.abs(v) > 1e-12 * np.max(np.abs(v))
    if np.any(np.abs(a[~nz]) > 1e-12 * max(np.max(np.abs(a)), 1e-300)):
        return False
    c = a[nz] / v[nz]
    return bool(c[0] > 0 and np.allclose(c, c[0], rtol=1e-6))


@functools.lru_cache(maxsize=1)
def _corridor():
    """Section 1's model: (move, sensor); sensor[y, j] = p(y | cell j), y = 0 wall, 1 door."""
    grid = np.arange(N_CELLS)
    is_door = np.isin(grid, DOORS)
    move = bayes.shift_transition(N_CELLS, SLIP, offset=1, cyclic=True)
    sensor = np.array([np.where(is_door, 1 - P_DOOR[1], 1 - P_DOOR[0]),
                       np.where(is_door, P_DOOR[1], P_DOOR[0])])
    return move, sensor


def _simulate(seed: int):
    """Section 1's simulation, draw for draw: the true path, then the door readings."""
    move, sensor = _corridor()
    rng = np.random.default_rng(seed)
    x_true = np.empty(T_STEPS, dtype=int)
    x_true[0] = START_CELL
    for t in range(1, T_STEPS):
        x_true[t] = rng.choice(N_CELLS, p=move[x_true[t - 1]])
    y_door = (rng.random(T_STEPS) < sensor[1, x_true]).astype(int)
    return x_true, y_door


def _mass_near(belief, cell, half_width=NEAR) -> float:
    return float(belief[np.mod(cell + np.arange(-half_width, half_width + 1), N_CELLS)].sum())


def _listing(seeds) -> str:
    return "seed " + str(seeds[0]) if len(seeds) == 1 else "seeds " + ", ".join(map(str, seeds))


# --------------------------------------------------------------------------
# Exercise 1 - the measurement update by hand (a function)
# --------------------------------------------------------------------------

def _exercise_1_cases() -> list[tuple[np.ndarray, np.ndarray]]:
    _, sensor = _corridor()
    rng = np.random.default_rng(101)
    return [
        (np.array([0.5, 0.5]), np.array([0.6, 0.2])),               # Thrun's door, section 6
        (np.array([2, 6, 2]), np.array([0.9, 0.05, 0.9])),          # counts (ints), unnormalised
        (rng.dirichlet(np.ones(N_CELLS)), sensor[1].copy()),         # a corridor belief, "door"
        (np.array([0.0, 0.25, 0.25, 0.5, 0.0]),                      # a perfect detector: zeros
         np.array([1.0, 0.0, 1.0, 0.0, 1.0])),                      # in prior and likelihood
        (np.array([0.1, 0.2, 0.3, 0.4]), 1e-3 * np.array([4.0, 3.0, 2.0, 1.0])),   # small scale
    ]


def _diagnose_update(out, prior, likelihood, shown: str) -> Feedback:
    what = f"the output for test input {shown}"
    if out is None:
        return _wrong(f"update_by_hand returned None on test input {shown}; did you forget "
                      f"`return`?")
    if isinstance(out, tuple) and len(out) == 2:
        return _wrong(f"update_by_hand returns a pair on test input {shown}: return only the "
                      f"posterior, an array of shape {np.shape(prior)}, not (posterior, evidence).")
    a, bad = _as_float_array(out, what)
    if bad is not None:
        if _has_nonfinite(out) and (np.any(likelihood == 0) or np.any(prior == 0)):
            return _wrong(f"{what} contains NaN or inf: your function divides by zero where the "
                          f"likelihood (or the prior) is 0. Bayes' rule multiplies the prior by "
                          f"the likelihood, and divides only by the evidence.")
        return bad
    p = np.asarray(prior, dtype=float)
    lik = np.asarray(likelihood, dtype=float)
    joint = p * lik
    posterior = bayes.update(p, lik).posterior
    if a.shape != posterior.shape:
        if a.ndim == 0:
            return _wrong(f"{what} is a single number; return the whole posterior, an array of "
                          f"shape {posterior.shape} (one probability per state).")
        return compare_array(a, posterior, what=what, probability=True)
    if _close(a, posterior, atol=1e-9):
        return Feedback(CORRECT, "")
    if _proportional(a, joint):
        return _wrong(f"{what} is not normalised: it is proportional to prior x likelihood, but "
                      f"its entries sum to {a.sum():.4g}, not 1. Divide by the evidence, the sum "
                      f"of prior x likelihood over all states (not the sum of the likelihood, "
                      f"nor of the prior).")
    if any(_proportional(a, v) for v in (p / lik, lik / p)):
        return _wrong(f"{what} divides where Bayes' rule multiplies: the posterior is "
                      f"proportional to prior x likelihood, not to prior / likelihood.")
    if _proportional(a, p) and not _proportional(p, joint):
        return _wrong(f"{what} does not depend on the likelihood: it is the prior (normalised). "
                      f"A reading changes the belief: multiply by the likelihood.")
    if _proportional(a, lik) and not _proportional(lik, joint):
        return _wrong(f"{what} is the likelihood normalised: the prior is missing. Only a flat "
                      f"prior makes the posterior the normalised likelihood.")
    if _proportional(a, p + lik) or _proportional(a, p / p.sum() + lik):
        return _wrong(f"{what} adds prior and likelihood; Bayes' rule multiplies them.")
    return compare_array(a, posterior, what=what, probability=True)


def exercise_1(update_by_hand) -> Feedback:
    """Check ``update_by_hand(prior, likelihood)``: the normalised posterior of section 4.

    Runs it on Thrun's door, integer counts as a prior, a 50-cell corridor
    belief with the "door" likelihood, a prior and a likelihood with zeros,
    and a likelihood of small scale; compares each output with
    :func:`bayesfilt.bayes.update`. Diagnoses: a pair returned, an
    unnormalised posterior, a division instead of a product, the likelihood
    or the prior ignored, a sum instead of a product, NaN from a division by
    zero, and arguments modified in place (or in-place arithmetic on the
    integer counts).
    """
    what = "update_by_hand"
    if update_by_hand is None:
        return _not_attempted(what)
    if not callable(update_by_hand):
        return _wrong(f"{what} must be a function (def update_by_hand(prior, likelihood): ...), "
                      f"got {type(update_by_hand).__name__}.")
    cases = _exercise_1_cases()
    for k, (prior, likelihood) in enumerate(cases):
        shown = f"{k + 1} (prior {_short(prior)}, likelihood {_short(likelihood)})"
        prior_in, lik_in = prior.copy(), likelihood.copy()
        try:
            out = update_by_hand(prior_in, lik_in)
        except NotImplementedError:
            return _not_written(what)
        except TypeError as exc:
            if prior.dtype.kind in "iu" and ("cast" in str(exc) or "ufunc" in str(exc).lower()):
                return _wrong(f"{what} fails on test input {shown}, a prior of integer counts: "
                              f"in-place arithmetic (*=, /=) cannot store fractions in an integer "
                              f"array. Compute a new array instead of changing prior.")
            return _wrong(f"{what} fails on test input {shown}: TypeError: {exc}")
        except Exception as exc:  # noqa: BLE001 - the student's error is feedback
            return _wrong(f"{what} fails on test input {shown}: {type(exc).__name__}: {exc}")
        feedback = _diagnose_update(out, prior, likelihood, shown)
        if feedback.status != CORRECT:
            return feedback
        # an argument changed in place: the engine's guard (bayesfilt.checks.guard)
    return Feedback(CORRECT, f"{what} agrees with bf.bayes.update on all {len(cases)} test inputs "
                             f"(counts as a prior, zeros, a 50-cell corridor).")


def _has_nonfinite(out) -> bool:
    try:
        a = np.asarray(out, dtype=float)
    except Exception:  # noqa: BLE001
        return False
    return not np.all(np.isfinite(a))


def _short(a: np.ndarray) -> str:
    return np.array2string(a, precision=3, separator=", ") if a.size <= 5 else f"{a.size} cells"


# --------------------------------------------------------------------------
# Exercise 2 - Thrun's door: push, then sense "closed", three times (a derivation)
# --------------------------------------------------------------------------

def _door_run(transition, likelihood, order: str = "predict, update", normalise: bool = True,
              transposed: bool = False) -> np.ndarray:
    """bel(open) after each of the pushes, computed right or in one of the plausible wrong ways."""
    b = np.array(DOOR_START, dtype=float)
    out = []
    for step in range(DOOR_PUSHES):
        if order == "update first":                              # bf.bayes.bayes_filter's order
            if step > 0:
                b = bayes.predict(b, transition)
            b = bayes.update(b, likelihood).posterior
        elif order == "predict, update":
            if transposed:
                b = np.asarray(transition) @ b                 # sum over j of T[i, j] b_j
            elif normalise:
                b = bayes.predict(b, transition)
            else:
                b = b @ np.asarray(transition)
            if normalise:
                b = bayes.update(b, likelihood).posterior
            else:
                b = b * np.asarray(likelihood)
        elif order == "update only":
            b = bayes.update(b, likelihood).posterior
        else:                                                   # update, then predict
            b = bayes.predict(bayes.update(b, likelihood).posterior, transition)
        out.append(b[0])
    return np.array(out)


def exercise_2(answer) -> Feedback:
    """Check ``answer_2``: bel(open) after each of three steps (push, sense "closed") from 0.5.

    Diagnoses: bel(closed) given instead of bel(open); the prediction skipped
    (or "do nothing" used); the update done before the push; the row of
    "sense open" used; an unnormalised belief; the transition applied as
    ``transition @ belief``; only the first value right (each push must start
    from the previous posterior); full beliefs or a single value given.
    """
    what = "answer_2"
    if answer is None or answer is Ellipsis:
        return _not_attempted(what)
    push, sensor = np.array(DOOR_PUSH), np.array(DOOR_SENSOR)
    closed, sense_open = sensor[1], sensor[0]
    ref = _door_run(push, closed)
    a, bad = _as_float_array(answer, what)
    if bad is not None:
        return bad
    if a.shape == (DOOR_PUSHES, 2):
        if _close(a[:, 0], ref, ATOL_HAND) or _close(a[:, 1], ref, ATOL_HAND):
            return _wrong(f"{what} holds whole beliefs, two numbers per reading; give "
                          f"bel(open) only, an array of shape ({DOOR_PUSHES},).")
        return _wrong(f"{what} must be bel(open) only, one number per reading, an array of "
                      f"shape ({DOOR_PUSHES},); got shape {a.shape}.")
    if a.size == 1:
        if _close(a.reshape(()), ref[0], ATOL_HAND):
            return _wrong(f"{what} is the first value only (and it is right); give all "
                          f"{DOOR_PUSHES}, an array of shape ({DOOR_PUSHES},).")
        return _wrong(f"{what} must be {DOOR_PUSHES} numbers, bel(open) after each reading, "
                      f"an array of shape ({DOOR_PUSHES},); got a single number.")
    if a.shape != ref.shape:
        return compare_array(a, ref, what=what, atol=ATOL_HAND, rtol=0)
    if _close(a, ref, ATOL_HAND):
        return Feedback(CORRECT, f"{what} matches the reference. Three 'closed' readings, yet "
                                 f"look how bel(open) moves: each push opens a closed door with "
                                 f"probability 0.8, while a 'closed' reading favours 'closed' "
                                 f"only 2 : 1 (0.8 / 0.4).")
    diagnoses = [
        (1.0 - ref, "gives bel(closed); the question asks for bel(open), the first entry of "
                    "each belief."),
        (_door_run(push, closed, order="update only"),
         "has no push in it: the belief only follows the readings. Predict with the push "
         "(door_transitions['push']) before each reading."),
        (_door_run(push, closed, order="update first"),
         "starts with a reading, not a push: bf.bayes.bayes_filter updates with its first "
         "likelihood at t = 0, before any prediction, so bayes_filter([0.5, 0.5], push, "
         "[door_sensor[1]] * 3) senses, pushes, senses, pushes, senses. Give it a likelihood of "
         "ones at t = 0 (no_measurement, no reading yet) and keep posteriors[1:]."),
        (_door_run(push, closed, order="update, predict"),
         "reports the belief after the push that follows each reading: the push comes "
         "first, then the reading, and the answer is the posterior after each reading."),
        (_door_run(push, sense_open), "uses the likelihood of 'sense open' (row 0 of "
                                      "door_sensor); the reading is 'closed': row 1."),
        (_door_run(push, closed, normalise=False),
         "is not normalised: after each product prior x likelihood, divide by the evidence so "
         "that the belief sums to one."),
        (_door_run(push, closed, transposed=True),
         "applies the push as transition @ belief (down the columns). The prior is "
         "belief @ transition: prior[j] = sum over i of bel[i] transition[i, j]."),
    ]
    for variant, message in diagnoses:
        if _close(a, variant, ATOL_HAND):
            return _wrong(f"{what} {message}")
    if abs(a[0] - ref[0]) <= ATOL_HAND:
        return _wrong(f"{what} has the first value right but not the later ones: each push "
                      f"starts from the posterior of the previous reading.")
    return compare_array(a, ref, what=what, atol=ATOL_HAND, rtol=0)


# --------------------------------------------------------------------------
# Exercise 3 - a position sensor: the evidence of two noise levels (an experiment)
# --------------------------------------------------------------------------

def _position_readings() -> np.ndarray:
    x_true, _ = _simulate(SECTION_1_SEED)
    return x_true + POSITION_STD * np.random.default_rng(POSITION_SEED).standard_normal(T_STEPS)


@functools.lru_cache(maxsize=16)
def _position_run(std: float, variant: str = "right"):
    """(log evidence, evidences) of section 1's filter on the position readings."""
    move, _ = _corridor()
    grid = np.arange(N_CELLS, dtype=float)
    ys = _position_readings()
    if variant == "wrapped":                                   # distance measured round the ring
        d = np.abs(ys[:, None] - grid[None, :]) % N_CELLS
        d = np.minimum(d, N_CELLS - d)
        liks = np.exp(-0.5 * (d / std) ** 2) / (math.sqrt(2 * math.pi) * std)
    else:
        liks = np.array([bayes.gaussian_likelihood(grid, y, std) for y in ys])
    initial = np.full(N_CELLS, 1.0 / N_CELLS)
    if variant == "known start":
        initial = np.eye(N_CELLS)[START_CELL]
    run = bayes.bayes_filter(initial, move, liks)
    return run.log_evidence, run.evidences


def exercise_3(answer) -> Feedback:
    """Check ``answer_3 = [log evidence with std 3 m, log evidence with std 1 m]``.

    Diagnoses: the two values swapped; likelihoods without the constant
    :math:`1/(\\sqrt{2\\pi}\\sigma)` of the normal density; the variance 9 passed as
    the standard deviation; evidences instead of log evidences; log10; the
    evidence of one step only, or per step; the wrong sign; the distance
    wrapped round the ring; the filter started at the true cell 22.
    """
    what = "answer_3"
    if answer is None or answer is Ellipsis:
        return _not_attempted(what)
    a, bad = _as_float_array(answer, what)
    if bad is not None:
        if isinstance(answer, np.ndarray) or isinstance(answer, (list, tuple)):
            try:
                if np.any(np.asarray(answer, dtype=float) == -np.inf):
                    return _wrong(f"{what} contains -inf: a log of an evidence that underflowed "
                                  f"to 0? Use run.log_evidence, a sum of logarithms.")
            except Exception:  # noqa: BLE001
                pass
        return bad
    stds = POSITION_MODEL_STDS
    ref = np.array([_position_run(s)[0] for s in stds])
    if a.size == 1:
        return _wrong(f"{what} must hold two log evidences, np.array([with std 3 m, with std "
                      f"1 m]); got a single number.")
    if a.shape != ref.shape:
        return compare_array(a, ref, what=what, atol=ATOL_LOG_EVIDENCE, rtol=0)
    if _close(a, ref, ATOL_LOG_EVIDENCE, rtol=0):
        return Feedback(CORRECT, f"{what} matches the reference. A difference d between two log "
                                 f"evidences is a factor e^d between the probabilities the two "
                                 f"models gave to the same 40 readings.")
    if _close(a, ref[::-1], ATOL_LOG_EVIDENCE, rtol=0):
        return _wrong(f"{what} has the two values swapped: first the filter with std 3 m, then "
                      f"the one with std 1 m.")
    for k, s in enumerate(stds):
        if _close(a[k], ref[k], ATOL_LOG_EVIDENCE, rtol=0):
            continue
        log_ev, evidences = _position_run(s)
        label = f"{what}[{k}] (std {s:g} m)"
        diagnoses = [
            (log_ev + T_STEPS * math.log(math.sqrt(2 * math.pi) * s),
             "uses likelihoods without the constant 1/(sqrt(2 pi) std) of the normal density. "
             "It cancels in every posterior, but not in the evidence, and it differs between "
             "std 3 m and 1 m: the comparison needs the true density, as "
             "bf.bayes.gaussian_likelihood returns it."),
            (_position_run(s * s)[0] if s != 1.0 else np.nan,
             f"passes the variance {s * s:g} where the standard deviation {s:g} is expected."),
            (math.exp(log_ev), "is an evidence, not a log evidence: take the natural "
                                    "logarithm (run.log_evidence, a sum of logarithms)."),
            (log_ev / math.log(10), "uses log10; the log evidence is a natural logarithm."),
            (math.log(evidences[-1]), "is the evidence of the last reading only; the "
                                           "evidence of the whole record is the product over all "
                                           "40 steps (the sum of their logarithms)."),
            (log_ev / T_STEPS, "is the log evidence per step; give that of the whole "
                                    "record, the sum over all 40 steps."),
            (-log_ev, "has the wrong sign: the log evidence is log p(y_0:39), not its "
                           "negative."),
            (_position_run(s, "wrapped")[0],
             "measures the distance round the ring; use bf.bayes.gaussian_likelihood(grid, "
             "y_pos[t], std) as it is (it ignores the wrap-around)."),
            (_position_run(s, "known start")[0],
             "starts the filter at the true cell 22, which the filter does not know: start, as "
             "in section 1, from the uniform belief."),
        ]
        for value, message in diagnoses:
            tiny = 0 < value < 1e-3                  # an evidence, not a log: compare relatively
            if np.isfinite(value) and (np.isclose(a[k], value, rtol=1e-3, atol=0) if tiny
                                       else _close(a[k], value, ATOL_LOG_EVIDENCE, rtol=0)):
                return _wrong(f"{label} {message}")
        return _wrong(f"{label} is too {'large' if a[k] > ref[k] else 'small'}. Use the readings "
                      f"y_pos of the cell as given, the uniform initial belief, move, and the "
                      f"likelihood rows bf.bayes.gaussian_likelihood(grid, y_pos[t], std) for "
                      f"t = 0..39; give log evidences to at least 2 decimals.")
    return compare_array(a, ref, what=what, atol=ATOL_LOG_EVIDENCE, rtol=0)


# --------------------------------------------------------------------------
# Exercise 4 - ambiguity: seeds whose last belief misses the truth (an experiment)
# --------------------------------------------------------------------------

@functools.lru_cache(maxsize=1)
def _ambiguity_table() -> dict:
    """For each seed: the masses near the truth at t = 39 computed right and in wrong ways."""
    move, sensor = _corridor()
    table = {}
    for seed in AMBIGUITY_SEEDS:
        x_true, y_door = _simulate(seed)
        run = bayes.bayes_filter(np.full(N_CELLS, 1 / N_CELLS), move, sensor[y_door])
        table[seed] = {
            "right": _mass_near(run.posteriors[-1], x_true[-1]),
            "prior": _mass_near(run.priors[-1], x_true[-1]),
            "t = 38": _mass_near(run.posteriors[-2], x_true[-2]),
            "cell only": float(run.posteriors[-1][x_true[-1]]),
            "start cell": _mass_near(run.posteriors[-1], x_true[0]),
        }
    return table


def _seeds_where(kind: str, below: bool = True) -> set:
    return {s for s, m in _ambiguity_table().items() if (m[kind] < THRESHOLD) == below}


def exercise_4(answer) -> Feedback:
    """Check ``answer_4``: the seeds 0-19 for which bel within 2 m of the true cell at t = 39 < 0.5.

    Diagnoses: a count given instead of the seeds; seeds outside 0-19 or
    repeated; the complement (the seeds where the filter found the robot);
    the prior instead of the posterior; t = 38 instead of 39; the probability
    of the true cell alone instead of within 2 m; the start cell instead of
    the true cell at t = 39; otherwise how many seeds are missing or extra.
    """
    what = "answer_4"
    if answer is None or answer is Ellipsis:
        return _not_attempted(what)
    ref = _seeds_where("right")
    if isinstance(answer, (bool, np.bool_)):
        return _wrong(f"{what} must be a list of seeds, got {answer!r}.")
    if isinstance(answer, numbers.Integral) or (isinstance(answer, np.ndarray)
                                                and answer.ndim == 0):
        return _wrong(f"{what} is a single number: give the list of the seeds themselves "
                      f"(e.g. [1, 7]), not how many there are.")
    if isinstance(answer, dict) or isinstance(answer, (str, bytes)) or callable(answer):
        return _wrong(f"{what} must be a list of seeds (integers from 0 to 19), got "
                      f"{type(answer).__name__}.")
    try:
        items = list(answer)
    except Exception:  # noqa: BLE001
        return _wrong(f"{what} must be a list of seeds (integers from 0 to 19), got "
                      f"{type(answer).__name__}.")
    seeds = []
    for item in items:
        if isinstance(item, (bool, np.bool_)) or not isinstance(item, numbers.Real) \
                or not float(item).is_integer():
            return _wrong(f"{what} must hold seeds, whole numbers from 0 to 19; it holds {item!r}. "
                          f"(The list of seeds, not of beliefs or of True/False per seed.)")
        seeds.append(int(item))
    outside = sorted({s for s in seeds if s not in AMBIGUITY_SEEDS})
    if outside:
        return _wrong(f"{what} holds {_listing(outside)}, outside the seeds 0 to 19 of the "
                      f"statement.")
    if len(set(seeds)) != len(seeds):
        return _wrong(f"{what} lists a seed more than once; give each seed once.")
    got = set(seeds)
    if got == ref:
        return Feedback(CORRECT, f"{what} is right. Now plot the belief of one of these seeds "
                                 f"(bf.plotting.belief_image) with the door map in mind: were "
                                 f"the readings ambiguous, or is the filter wrong?")
    diagnoses = [
        (_seeds_where("right", below=False),
         "lists the seeds where the belief within 2 m of the true cell is at least 0.5 (the "
         "robot was found); the question asks for those below 0.5."),
        (_seeds_where("prior"), "uses the prior at t = 39 (run.priors, before the last reading); "
                                "the belief is the posterior, run.posteriors[39]."),
        (_seeds_where("t = 38"), "uses the belief at t = 38; the question is about t = 39, the "
                                 "last step (index 39, or -1)."),
        (_seeds_where("cell only"), "uses the probability of the true cell alone; the question "
                                    "asks for the probability within 2 m of it, cells x - 2 .. "
                                    "x + 2 on the ring (mass_near of section 1)."),
        (_seeds_where("start cell"), "measures the belief near the start cell 22; compare with "
                                     "the true cell at t = 39, x_true[39]."),
    ]
    for variant, message in diagnoses:
        if variant != ref and got == variant:
            return _wrong(f"{what} {message}")
    extra, missing = len(got - ref), len(ref - got)
    parts = ([f"{extra} of your seeds should not be there"] if extra else []) + \
            ([f"{missing} seed(s) are missing"] if missing else [])
    return _wrong(f"{what} is not yet right: {' and '.join(parts)}. Re-run section 1's code "
                  f"exactly, only the seed changed (draw the whole path first, then the "
                  f"readings: another order gives other random numbers), and use the posterior "
                  f"at t = 39 and mass_near with the true cell at t = 39.")


# --------------------------------------------------------------------------
# Exercise 5 - prediction alone: mean and variance of the distance in 20 steps (a derivation)
# --------------------------------------------------------------------------

def _travel_reference() -> tuple[float, float]:
    """Mean and variance of the cell after PREDICTION_STEPS predictions from cell 0 (bf.bayes)."""
    move, _ = _corridor()
    belief = np.eye(N_CELLS)[0]
    for _ in range(PREDICTION_STEPS):
        belief = bayes.predict(belief, move)
    cells = np.arange(N_CELLS)            # 20 steps of at most 2 cells never wrap round 50 cells
    mean = float(belief @ cells)
    return mean, float(belief @ (cells - mean) ** 2)


def exercise_5(answer) -> Feedback:
    """Check ``answer_5 = np.array([mean, variance])`` of the distance travelled in 20 steps.

    Diagnoses: the two swapped; the commanded distance as the mean; one step's
    mean or variance; the variance scaled by m^2 instead of m; the standard
    deviation given; the second moment (mean not subtracted); the variance
    about the commanded move 1 instead of about the mean.
    """
    what = "answer_5"
    if answer is None or answer is Ellipsis:
        return _not_attempted(what)
    a, bad = _as_float_array(answer, what)
    if bad is not None:
        return bad
    m = PREDICTION_STEPS
    mean, var = _travel_reference()
    d = np.arange(len(SLIP), dtype=float)
    p = np.array(SLIP)
    step_mean = float(p @ d)
    step_var = float(p @ (d - step_mean) ** 2)
    if a.size == 1:
        return _wrong(f"{what} must be two numbers, np.array([mean, variance]); got one.")
    if a.shape != (2,):
        return compare_array(a, np.array([mean, var]), what=what, atol=ATOL_HAND, rtol=1e-4)
    if _close(a, [mean, var], ATOL_HAND, rtol=1e-4):
        return Feedback(CORRECT, f"{what} matches the reference. The belief after {m} "
                                 f"predictions from cell 0 has this mean and variance: "
                                 f"prediction alone only blurs the belief.")
    if _close(a, [var, mean], ATOL_HAND, rtol=1e-4):
        return _wrong(f"{what} has the two values swapped: first the mean, then the variance.")
    if not _close(a[0], mean, ATOL_HAND, rtol=1e-4):
        for value, message in [
            (float(m), f"is the commanded distance, {m} x 1 cell; the slip is not symmetric, so "
                       f"the mean of one step is the sum of d p(d) over d = 0, 1, 2."),
            (step_mean, f"is the mean of one step; the distance in {m} steps is the sum of "
                        f"{m} independent steps."),
        ]:
            if _close(a[0], value, ATOL_HAND, rtol=1e-4):
                return _wrong(f"the mean in {what} {message}")
        return _wrong(f"the mean in {what} is too {'large' if a[0] > mean else 'small'}.")
    for value, message in [
        (step_var, f"is the variance of one step; for {m} independent steps the variances add."),
        (m * m * step_var, f"grows like {m}^2: that is the variance of {m} times one step's "
                           f"distance (the same slip repeated). Independent steps add variances."),
        (math.sqrt(var), "is a standard deviation; the question asks for the variance."),
        (m * float(p @ d ** 2), "is a second moment: the variance is E[d^2] - E[d]^2 (subtract "
                                "the square of the mean)."),
        (var + mean ** 2, "is the second moment E[D^2] of the distance D; the variance subtracts "
                          "the square of the mean."),
        (m * float(p @ (d - 1.0) ** 2), "is the spread about the commanded move of 1 cell; the "
                                         "variance is taken about the mean step."),
    ]:
        if _close(a[1], value, ATOL_HAND, rtol=1e-4):
            return _wrong(f"the mean in {what} is right; the variance {message}")
    feedback = compare_number(float(a[1]), var, what=f"the variance in {what}", rtol=1e-4,
                              atol=ATOL_HAND)
    return _wrong(f"the mean in {what} is right; {feedback.message}")


from . import register as _register  # noqa: E402

_register(globals())
