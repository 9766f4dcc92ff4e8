r"""Exercises that answer back: checks that compare a student's answer with the library's.

Every chapter ends with exercises. Each has an *answer cell*, where the student writes a number, an
array or a small function, and a *check cell* that calls one function of this package::

    import bayesfilt as bf
    gain_2 = ...                                      # the student's answer
    bf.checks.ch02.exercise_2(kalman_gain, gain_2)    # prints: correct, or what differs

A check never prints the solution. It says one of three things:

* **not attempted yet** - the answer is still ``None`` (or the function still raises
  ``NotImplementedError``), so "Run All" runs the whole chapter;
* **correct**;
* **not yet** - and *what* differs, diagnosed the way a tutor would: a wrong shape (with the
  expected one), a transposed matrix, a result off by a factor (an unnormalised belief, a missing
  normalising constant), the wrong sign (an innovation written :math:`C\hat x - y`), a covariance
  that is not symmetric, a function that fails (with the input that broke it).

The references are computed by the library, never stored in the notebook, so a student edition
(``tools/make_student_edition.py``) hands out the check cells as they are. The chapter modules
``bf.checks.ch01`` ... ``bf.checks.ch06`` hold one check per exercise, built on the comparisons here
(:func:`compare_array`, :func:`compare_number`, :func:`compare_function`, :func:`compare_choice`)
and run through one engine (:func:`exercise`): a student's function runs under a time limit
(:data:`TIME_LIMIT`), an argument or a chapter array it changes in place ends the check with a "Not
yet", and a check never raises, except under nbgrader, where a check that is not correct fails its
cell.
"""

from __future__ import annotations

import contextlib
import copy
import functools
import importlib.util
import inspect
import numbers
import os
import pkgutil
import re
import signal
import threading
import warnings
from typing import Callable, NamedTuple, Sequence

import numpy as np

__all__ = ["Feedback", "compare_array", "compare_number", "compare_function", "compare_choice",
           "exercise", "NOT_ATTEMPTED", "CORRECT", "INCORRECT", "TIME_LIMIT"]

NOT_ATTEMPTED = "not attempted yet"
CORRECT = "correct"
INCORRECT = "not yet"

#: Seconds a student's function may run on one test input before the check stops it. The
#: environment variable BAYESFILT_CHECK_TIME_LIMIT overrides it (a test sets it low).
TIME_LIMIT = float(os.environ.get("BAYESFILT_CHECK_TIME_LIMIT", "10"))


class Feedback(NamedTuple):
    """What a check says; its representation is the message, so a check cell shows it.

    Parameters
    ----------
    status : str
        ``CORRECT``, ``INCORRECT`` or ``NOT_ATTEMPTED`` (the three statuses above).
    message : str
        What is right, or what differs.
    """

    status: str
    message: str

    def __repr__(self) -> str:
        mark = {CORRECT: "Correct", NOT_ATTEMPTED: "Not attempted yet"}.get(self.status, "Not yet")
        return f"{mark}: {self.message}" if self.message else mark

    @property
    def correct(self) -> bool:
        return self.status == CORRECT


def _not_attempted(what: str, unwritten: bool = False) -> Feedback:
    todo = "still raises NotImplementedError; write its body" if unwritten else (
        "is still None; write your answer")
    return Feedback(NOT_ATTEMPTED, f"{what} {todo} in the cell above and run it, then run this "
                                   f"check again.")


def _wrong(message: str) -> Feedback:
    return Feedback(INCORRECT, message)


# --- the engine: student functions guarded (time limit, in-place changes), any failure a "Not yet"

class _Stop(BaseException):
    """_Stop(message): a student's function misbehaved, the check ends with a "Not yet" saying
    message (a BaseException, so that no ``except Exception`` of a chapter helper swallows it)."""


_timer_active = threading.local()


@contextlib.contextmanager
def _time_limit(seconds: float, message: str):
    """Stop the block after ``seconds`` (0: never) with _Stop(message): SIGALRM by
    setitimer (POSIX, main thread; elsewhere no limit); a long C call ends first."""
    if (seconds <= 0 or not hasattr(signal, "setitimer")
            or threading.current_thread() is not threading.main_thread()
            or getattr(_timer_active, "on", False)):
        yield
        return

    def stop(signum, frame):
        raise _Stop(message)

    previous = signal.signal(signal.SIGALRM, stop)
    _timer_active.on = True
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)
        _timer_active.on = False


def _same(a, b) -> bool:
    """Are two snapshots equal (arrays elementwise, NaN equal to NaN; containers recursively)?"""
    try:
        if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
            a, b = np.asarray(a), np.asarray(b)
            return a.shape == b.shape and a.dtype == b.dtype and bool(
                np.array_equal(a, b, equal_nan=a.dtype.kind in "fc"))
        if isinstance(a, (list, tuple)) and isinstance(b, (list, tuple)):
            return type(a) is type(b) and len(a) == len(b) and all(map(_same, a, b))
        if isinstance(a, dict) and isinstance(b, dict):
            return a.keys() == b.keys() and all(_same(a[k], b[k]) for k in a)
        if hasattr(a, "__dataclass_fields__") and type(a) is type(b):
            return all(_same(getattr(a, f), getattr(b, f)) for f in a.__dataclass_fields__)
        result = a == b
        return bool(result) if isinstance(result, (bool, np.bool_)) else True
    except Exception:  # noqa: BLE001 - an object we cannot compare counts as unchanged
        return True


def _guard(fun):
    """``fun`` for a check: a call over TIME_LIMIT s, or one that changes an argument or a
    chapter array in place (put back), ends the check with a "Not yet"."""
    name = getattr(fun, "__name__", "<lambda>")
    name = "your function" if name == "<lambda>" else name
    code, space = getattr(fun, "__code__", None), getattr(fun, "__globals__", None)
    refs, stack = set(), [code] if code is not None and isinstance(space, dict) else []
    while stack:                                  # the names that fun and its inner functions use
        c = stack.pop()
        refs.update(c.co_names)
        stack.extend(k for k in c.co_consts if inspect.iscode(k))
    watched = {k: obj for k in sorted(refs) if isinstance(obj := space.get(k), np.ndarray)
               or ((hasattr(obj, "_fields") or hasattr(obj, "__dataclass_fields__"))
                   and not isinstance(obj, type))}  # the chapter's arrays, tuples, dataclasses
    try:
        params = [p.name for p in inspect.signature(fun).parameters.values()
                  if p.kind in (p.POSITIONAL_ONLY, p.POSITIONAL_OR_KEYWORD)]
    except (TypeError, ValueError):
        params = []

    @functools.wraps(fun)
    def guarded(*args, **kwargs):
        try:
            before = copy.deepcopy(args)
        except Exception:  # noqa: BLE001 - an argument we cannot copy is not watched
            before = ()
        chapter = {k: copy.deepcopy(v) for k, v in watched.items()}
        with _time_limit(TIME_LIMIT, f"your function {name} did not return within "
                                     f"{TIME_LIMIT:g} s: an endless loop? (test input: "
                                     f"{_describe_args(args)})"):
            out = fun(*args, **kwargs)
        names = params + [f"argument {k + 1}" for k in range(len(params), len(args))]
        for arg, now, then in zip(names, args, before):
            if not _same(now, then):
                alias = "y" if arg == "x" else "x"
                raise _Stop(
                    f"{name} changes its argument {arg} in place ({arg} /= ..., {arg} -= ..., "
                    f"{arg}[...] = ..., or {alias} = {arg}; {alias} += ...): the caller's array "
                    f"changes too. Work on a copy ({alias} = np.array({arg}, dtype=float)) or "
                    f"write {alias} = {arg} + ... (test input: {_describe_args(before)}).")
        for k, then in chapter.items():
            if not _same(now := watched[k], then):
                if isinstance(now, np.ndarray) and now.flags.writeable and now.shape == then.shape:
                    now[...] = then                                        # put it back
                raise _Stop(f"{name} changes the chapter's variable {k} in place: the rest of "
                            f"the chapter would see it changed. Work on a copy ({k}.copy()); the "
                            f"check has put {k} back as it was.")
        return out

    return guarded


def exercise(check: Callable) -> Callable:
    """Make ``check`` an exercise: never raises, student functions guarded, graded by nbgrader.

    Every callable answer is guarded (time limit, in-place changes); any failure inside it is a
    "Not yet". When nbgrader autogrades or validates (``NBGRADER_EXECUTION`` set), an answer
    that is not correct raises ``AssertionError`` with its message: the cell loses its points.

    Parameters
    ----------
    check : callable
        A function of the answers that returns a :class:`Feedback`.

    Returns
    -------
    callable
        ``check`` run as an exercise (``check`` itself if it is one already).
    """
    if getattr(check, "_is_exercise", False):
        return check

    @functools.wraps(check)
    def run(*answers, **kwargs):
        guarded = [_guard(a) if callable(a) and not isinstance(a, type) else a for a in answers]
        try:
            with np.errstate(all="ignore"), warnings.catch_warnings():
                warnings.simplefilter("ignore")
                feedback = check(*guarded, **kwargs)
        except _Stop as stop:
            feedback = _wrong(stop.args[0])
        except Exception as exc:  # noqa: BLE001 - a check never raises
            feedback = _wrong(f"the check could not read your answer ({type(exc).__name__}: "
                              f"{exc}); check its type and shape against the statement.")
        if os.environ.get("NBGRADER_EXECUTION") and not feedback.correct:
            raise AssertionError(repr(feedback))                 # nbgrader: the cell fails
        return feedback

    run._is_exercise = True
    return run


def register(namespace: dict) -> None:
    """Make each ``exercise_N`` of a chapter module an :func:`exercise`, listed in ``__all__``."""
    names = [k for k, v in namespace.items() if re.fullmatch(r"exercise_\d+", k) and callable(v)]
    namespace.update({k: exercise(namespace[k]) for k in names}, __all__=names)


# --- the comparisons -----------------------------------------------------------------------------

def _frozen(a) -> np.ndarray:
    a = np.array(a, dtype=float)
    a.setflags(write=False)
    return a


def _matches(a: np.ndarray, wrong, rtol: float, atol: float) -> bool:
    w = np.asarray(np.nan if wrong is None else wrong, dtype=float)
    return wrong is not None and a.shape == w.shape and bool(np.allclose(a, w, rtol, atol))


def _combine(parts: Sequence[tuple[str, Feedback]]) -> Feedback:
    """One feedback for an exercise with several answers: correct when all are."""
    statuses = {fb.status for _, fb in parts}
    if statuses <= {CORRECT}:
        return Feedback(CORRECT, " ".join(fb.message for _, fb in parts))

    def blank(name: str, fb: Feedback) -> str:
        unwritten = "NotImplementedError" in fb.message
        return f"{name} {'still raises NotImplementedError' if unwritten else 'is still None'}"

    if statuses == {NOT_ATTEMPTED}:
        return Feedback(NOT_ATTEMPTED, f"{' and '.join(blank(n, fb) for n, fb in parts)}; write "
                                       f"your answers in the cell above and run it, then run "
                                       f"this check again.")
    return Feedback(INCORRECT if INCORRECT in statuses else NOT_ATTEMPTED, " ".join(
        f"{name}: correct." if fb.correct else fb.message if fb.status == INCORRECT
        else f"{name}: not attempted yet ({blank(name, fb)})." for name, fb in parts))


def _named(answer, expected, what: str, mistakes, note: str = "", rtol=1e-6, atol=1e-9) -> Feedback:
    """compare_array; a named mistake (an array, or a predicate on the answer) gets its message."""
    fb = compare_array(answer, expected, what, rtol=rtol, atol=atol)
    if fb.status != INCORRECT:
        return Feedback(CORRECT, f"{fb.message} {note}".strip()) if fb.correct else fb
    a = np.asarray(answer) if isinstance(answer, (list, tuple, np.ndarray, numbers.Real)) else None
    a = a.astype(float) if a is not None and a.dtype.kind in "iuf" else np.array(np.nan)
    for wrong, message in mistakes if np.all(np.isfinite(a)) else ():
        try:
            hit = wrong(a) if callable(wrong) else _matches(a, wrong, rtol, atol)
        except Exception:  # noqa: BLE001 - a mistake that does not apply to this answer
            hit = False
        if hit:
            return _wrong(message(a) if callable(message) else message)
    return fb


def _hinted(fun, hint):
    """fun, a failure re-raised with hint(exc, args) added (even one that cannot print itself)."""
    def call(*args):
        try:
            return fun(*args)
        except NotImplementedError:
            raise
        except Exception as exc:  # noqa: BLE001 - compare_function reports it, with the hint
            try:
                text = f"{exc}{hint(exc, args)}"
            except Exception:  # noqa: BLE001
                text = ""
            raise type(type(exc).__name__, (Exception,), {})(text) from None
    return call if callable(fun) else fun


def _as_numbers(answer, what: str):
    """(array, None) or (None, Feedback) when the answer is not an array of real numbers."""
    try:
        a = np.asarray(answer)
    except ValueError:
        return None, _wrong(f"{what} must be a rectangular array of numbers (not a ragged list).")
    except Exception:  # noqa: BLE001 - an object numpy cannot read is feedback, not a crash
        return None, _wrong(f"{what} must be an array of numbers, got {type(answer).__name__}.")
    if a.dtype.kind not in "iuf":
        kind = {"b": "booleans", "c": "complex numbers", "U": "text", "O": "a mixed object"}
        return None, _wrong(f"{what} must be made of real numbers, got "
                            f"{kind.get(a.dtype.kind, str(a.dtype))}.")
    a = a.astype(float)
    if not np.all(np.isfinite(a)):
        return None, _wrong(f"{what} contains NaN or inf.")
    return a, None


def compare_array(answer, expected, what: str = "your answer", rtol: float = 1e-6,
                  atol: float = 1e-9, probability: bool = False) -> Feedback:
    """Compare an array answer with the reference and diagnose what differs.

    Parameters
    ----------
    answer : array_like or None
        The student's answer; None means not attempted.
    expected : array_like
        The reference (computed by the library, never shown).
    what : str
        How to name the answer in the message, e.g. ``"the gain K"``.
    rtol, atol : float
        Tolerances of ``np.allclose``.
    probability : bool
        The answer is a probability vector (a belief): say so when it is not
        normalised.

    Returns
    -------
    Feedback
    """
    if answer is None or answer is Ellipsis:
        return _not_attempted(what)
    a, bad = _as_numbers(answer, what)
    if bad is not None:
        return bad
    e = np.asarray(expected, dtype=float)
    close = functools.partial(np.allclose, rtol=rtol, atol=atol)
    square = a.ndim == 2 and a.shape[0] == a.shape[1]
    if a.shape != e.shape:
        if a.ndim == 2 and a.T.shape == e.shape and close(a.T, e):
            return _wrong(f"{what} is transposed: expected shape {e.shape}, got {a.shape}.")
        if a.size == e.size and close(a.reshape(e.shape), e):
            return _wrong(f"{what} has the right numbers in the wrong shape: expected shape "
                          f"{e.shape}, got {a.shape} (reshape it).")
        return _wrong(f"{what} has the wrong shape: expected {e.shape}, got {a.shape}.")
    if close(a, e):
        return Feedback(CORRECT, f"{what} matches the reference.")
    if np.any(e != 0) and close(-a, e):
        return _wrong(f"{what} has the wrong sign (check the order of a difference, e.g. "
                      f"y - C x rather than C x - y).")
    if square and close(a.T, e):
        return _wrong(f"{what} is transposed.")
    if probability and np.any(a < 0):
        return _wrong(f"{what} must be a probability vector, but it has a negative entry "
                      f"(a probability is never below 0).")
    scale = _common_factor(a, e)
    if scale is not None:
        if probability and not np.isclose(a.sum(), 1.0):
            return _wrong(f"{what} is not normalised: its entries sum to {a.sum():.4g}, not 1 "
                          f"(divide by the normalising constant).")
        # With one nonzero reference entry every wrong value is "a factor" of it: name a
        # factor only when the evidence is real (two entries or more) or the factor simple.
        if np.count_nonzero(e) >= 2 or _is_simple_factor(scale):
            return _wrong(f"{what} is off by a constant factor (a normalising constant, or a "
                          f"factor such as 1/2 or 2 pi, missing or extra).")
    if probability and not np.isclose(a.sum(), 1.0):
        return _wrong(f"{what} must be a probability vector: its entries sum to {a.sum():.4g}.")
    if square and np.allclose(e, e.T) and not np.allclose(a, a.T):
        return _wrong(f"{what} should be a covariance, which is symmetric; yours is not "
                      f"(max |A - A^T| = {np.max(np.abs(a - a.T)):.3g}).")
    wrong = ~np.isclose(a, e, rtol=rtol, atol=atol)
    where = tuple(int(i) for i in np.argwhere(wrong)[0])
    return _rounded(what, a, e) or _wrong(f"{what} has the right shape but {int(wrong.sum())} of "
                                          f"{a.size} entries differ from the reference (the first "
                                          f"at index {where}).")


def _rounded(what: str, a, e) -> Feedback | None:
    """A "Not yet" if ``a`` is the reference ``e`` rounded to k = 2, ..., 6 decimals, else None."""
    a, e = np.asarray(a, dtype=float), np.asarray(e, dtype=float)
    for k in range(2, 7) if a.shape == e.shape else ():
        r = np.round(e, k)
        if np.allclose(a, r, rtol=1e-12, atol=1e-12) and not np.allclose(r, e, rtol=1e-12, atol=0):
            return _wrong(f"{what} looks rounded to {k} decimals: the check needs more than that; "
                          f"give more decimals (do not round, keep the full float).")
    return None


def _is_simple_factor(ratio: float) -> bool:
    """Is ``ratio`` 2, 1/2, 2 pi or 1/(2 pi) (or minus one of them)?"""
    return any(np.isclose(abs(ratio), r, rtol=1e-6) for r in (2.0, 0.5, 2 * np.pi, 1 / (2 * np.pi)))


def _common_factor(a: np.ndarray, e: np.ndarray) -> float | None:
    """The factor c != 1 with a = c e, if there is one."""
    nz = np.abs(e) > 1e-12 * max(np.max(np.abs(e)), 1e-300)
    if not nz.any() or np.any(a[~nz] != 0):
        return None
    c = a[nz] / e[nz]
    if np.allclose(c, c[0], rtol=1e-6) and not np.isclose(c[0], 1.0) and c[0] != 0:
        return float(c[0])
    return None


def compare_number(answer, expected: float, what: str = "your answer", rtol: float = 1e-6,
                   atol: float = 1e-9) -> Feedback:
    """Compare a number with the reference; says too large/too small, wrong sign, or a factor.

    Parameters
    ----------
    answer : float or None
        The student's answer (a one-entry array counts); None means not attempted.
    expected : float
        The reference (computed by the library, never shown).
    what, rtol, atol
        As in :func:`compare_array`.

    Returns
    -------
    Feedback
    """
    if answer is None or answer is Ellipsis:
        return _not_attempted(what)
    if isinstance(answer, np.ndarray) and answer.size == 1:
        answer = answer.item()
    if isinstance(answer, (bool, np.bool_)) or not isinstance(answer, numbers.Real):
        return _wrong(f"{what} must be a single number, got {type(answer).__name__}.")
    try:
        a, e = float(answer), float(expected)
    except (OverflowError, ValueError, TypeError):
        return _wrong(f"{what} must be a finite number of ordinary size.")
    if not np.isfinite(a):
        return _wrong(f"{what} is NaN or inf.")
    if np.isclose(a, e, rtol=rtol, atol=atol):
        return Feedback(CORRECT, f"{what} matches the reference.")
    if e != 0 and np.isclose(-a, e, rtol=rtol, atol=atol):
        return _wrong(f"{what} has the wrong sign.")
    if (e != 0 and a != 0 and _common_factor(np.array([a]), np.array([e])) is not None
            and a / e > 0 and _is_simple_factor(a / e)):
        return _wrong(f"{what} is off by a simple factor (2, 1/2 or 2 pi?).")
    return _rounded(what, a, e) or _wrong(f"{what} is too {'large' if a > e else 'small'}.")


def compare_function(fun, reference: Callable, cases: Sequence[tuple], what: str = "your function",
                     compare: Callable = compare_array, mistakes: Sequence[tuple] = (),
                     **compare_kw) -> Feedback:
    """Run a student's function on test inputs and compare each output with the reference.

    Parameters
    ----------
    fun : callable or None
        The student's function; None, or one that raises
        ``NotImplementedError``, is not attempted yet.
    reference : callable
        The library's implementation (same signature).
    cases : sequence of tuples
        Argument tuples; each is deep-copied, so a function that modifies its
        input cannot spoil the next case.
    what : str
        How to name the function in the message.
    compare, **compare_kw
        :func:`compare_array` or :func:`compare_number`, and its ``rtol``, ``atol``, ...
    mistakes : sequence of (callable, str)
        Named mistakes: a wrong implementation (same signature) and the message for an
        output that agrees with it where the reference does not.

    Returns
    -------
    Feedback
    """
    def judge(out, where: str, args: tuple) -> Feedback:
        result = compare(out, reference(*copy.deepcopy(args)), what=f"the output for {where}",
                         **compare_kw)
        if result.status == NOT_ATTEMPTED:
            return _wrong(f"{what} returned None on {where}; did you forget `return`?")
        for mistake, message in mistakes if not result.correct else ():
            with contextlib.suppress(Exception):  # a mistake that does not apply here
                if compare(out, mistake(*copy.deepcopy(args)), **compare_kw).correct:
                    return _wrong(f"{what}, {where}: {message}")
        return result

    return _each_case(fun, what, cases, [_describe_args(args) for args in cases], judge)


def _each_case(fun, what: str, cases: Sequence[tuple], labels: Sequence[str],
               judge: Callable) -> Feedback:
    """``fun`` on each case (deep-copied); ``judge(out, where, args)`` says what its output is."""
    if fun is None:
        return _not_attempted(what)
    if not callable(fun):
        return _wrong(f"{what} must be a function (def ...), got {type(fun).__name__}.")
    for k, (args, label) in enumerate(zip(cases, labels)):
        where = f"test input {k + 1} ({label})"
        try:
            out = fun(*copy.deepcopy(args))
        except NotImplementedError:
            return _not_attempted(what, unwritten=True)
        except Exception as exc:  # noqa: BLE001 - any failure is feedback, not a crash
            return _wrong(f"{what} fails on {where}: {type(exc).__name__}: {exc}")
        if out is None:
            return _wrong(f"{what} returned None on {where}; did you forget `return`?")
        feedback = judge(out, where, args)
        if not feedback.correct:
            return feedback
    return Feedback(CORRECT, f"{what} agrees with the library on all {len(cases)} test inputs.")


def _describe_args(args: tuple) -> str:
    """The test inputs in words: small arrays in full, others by shape, anything else by type."""
    parts = []
    for a in args:
        arr = None     # only numbers, arrays and plain lists/tuples are read as arrays
        if isinstance(a, (numbers.Number, np.ndarray, np.generic)) or type(a) in (list, tuple):
            with contextlib.suppress(Exception):  # a ragged list is described by its type
                arr = np.asarray(a)
        if arr is None or arr.dtype.kind not in "iuf":
            parts.append(type(a).__name__)
        elif arr.size <= 6:       # one line, whatever the shape: a message is read as a sentence
            parts.append(" ".join(np.array2string(arr, precision=3, separator=", ").split()))
        else:
            parts.append(f"array of shape {arr.shape}")
    return ", ".join(parts)


def compare_choice(answer, expected: str, options: Sequence[str], what: str = "your choice",
                   hint: str = "") -> Feedback:
    """A choice among named options (case and surrounding spaces ignored).

    Parameters
    ----------
    answer : str or None
        The student's choice; None means not attempted.
    expected : str
        The right option.
    options : sequence of str
        Every option the statement names.
    what, hint : str
        How to name the answer in the message; a hint for a wrong option.

    Returns
    -------
    Feedback
    """
    if answer is None or answer is Ellipsis:
        return _not_attempted(what)
    if not isinstance(answer, str) or answer.strip().lower() not in [o.lower() for o in options]:
        return _wrong(f"{what} must be one of {list(options)}, got {answer!r}.")
    if answer.strip().lower() == expected.lower():
        return Feedback(CORRECT, f"{what} is right.")
    return _wrong(f"{what} is not the right option." + (f" Hint: {hint}" if hint else ""))


def __getattr__(name: str):
    """``bf.checks.ch02`` and the like: a chapter's module, imported when first used."""
    if not re.fullmatch(r"ch\d\d", name):
        raise AttributeError(f"module 'bayesfilt.checks' has no attribute {name!r}")
    if importlib.util.find_spec(f"{__name__}.{name}") is None:  # an AttributeError: hasattr() False
        raise AttributeError(f"module 'bayesfilt.checks' has no attribute {name!r} "
                             f"(there is no bayesfilt/checks/{name}.py)")
    return importlib.import_module(f".{name}", __name__)  # an import failing inside it shows


def __dir__():
    chapters = {m.name for m in pkgutil.iter_modules(__path__) if re.fullmatch(r"ch\d\d", m.name)}
    return sorted(set(globals()) | chapters)
