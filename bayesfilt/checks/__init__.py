r"""Exercises that answer back: checks that compare a student's answer with the library's.

Every chapter ends with exercises. Each has an *answer cell*, where the
student writes a number, an array or a small function, and a *check cell*
that calls one function of this package::

    import bayesfilt as bf
    K = ...                          # the student's answer
    bf.checks.ch02.gain(K)           # prints: correct, or what differs

A check never raises and never prints the solution. It says one of three
things:

* **not attempted yet** - the answer is still ``None`` (or the function
  still raises ``NotImplementedError``), so "Run All" runs the whole chapter;
* **correct**;
* **not yet** - and *what* differs, diagnosed the way a tutor would: a wrong
  shape (with the expected one), a transposed matrix, a result off by a
  factor (an unnormalised belief, a missing normalising constant), the wrong
  sign (an innovation written :math:`C\hat x - y`), a covariance that is not
  symmetric, a function that fails (with the input that broke it).

The reference answers are computed here, by the library (``bf.kalman``,
``bf.bayes``, ...), never stored in the notebook, so a student edition
(``tools/make_student_edition.py``) can hand out the check cells as they are.

This module holds the generic comparisons; the chapter modules
``bf.checks.ch01`` ... ``bf.checks.ch06`` hold one check per exercise.
"""

from __future__ import annotations

import copy
import functools
import importlib
import numbers
import re
import warnings
from typing import Callable, NamedTuple, Sequence

import numpy as np

__all__ = ["Feedback", "compare_array", "compare_number", "compare_function", "compare_choice",
           "NOT_ATTEMPTED", "CORRECT", "INCORRECT"]

NOT_ATTEMPTED = "not attempted yet"
CORRECT = "correct"
INCORRECT = "not yet"

_CHAPTERS = ("ch01", "ch02", "ch03", "ch04", "ch05", "ch06")


class Feedback(NamedTuple):
    """What a check says: ``status`` (one of the three above) and a ``message``.

    Its representation is the message, so a check as the last line of a
    cell shows it.
    """

    status: str
    message: str

    def __repr__(self) -> str:
        mark = {CORRECT: "Correct", NOT_ATTEMPTED: "Not attempted yet"}.get(self.status, "Not yet")
        return f"{mark}: {self.message}" if self.message else mark

    @property
    def correct(self) -> bool:
        return self.status == CORRECT


def _not_attempted(what: str) -> Feedback:
    return Feedback(NOT_ATTEMPTED, f"{what} is still None; write your answer in the cell above "
                                   f"and run it, then run this check again.")


def _not_written(what: str) -> Feedback:
    return Feedback(NOT_ATTEMPTED, f"{what} still raises NotImplementedError; write its body in "
                                   f"the cell above and run it, then run this check again.")


def _wrong(message: str) -> Feedback:
    return Feedback(INCORRECT, message)


def _never_raises(what: str):
    """Turn any unexpected failure of a check into feedback (a check must never raise)."""
    def decorate(check: Callable) -> Callable:
        @functools.wraps(check)
        def wrapper(answer):
            try:
                with np.errstate(all="ignore"), warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    return check(answer)
            except Exception as exc:  # noqa: BLE001 - feedback, not a crash
                return _wrong(f"{what} could not be checked ({type(exc).__name__}: {exc}); "
                              f"check its type and shape against the statement.")
        return wrapper
    return decorate


def _frozen(a) -> np.ndarray:
    a = np.array(a, dtype=float)
    a.setflags(write=False)
    return a


def _matches(a: np.ndarray, wrong, rtol: float, atol: float) -> bool:
    if wrong is None:
        return False
    wrong = np.asarray(wrong, dtype=float)
    return a.shape == wrong.shape and bool(np.allclose(a, wrong, rtol=rtol, atol=atol))


def _combine(parts: Sequence[tuple[str, Feedback]]) -> Feedback:
    """One feedback for an exercise with several answers: correct when all are."""
    statuses = [fb.status for _, fb in parts]
    if all(s == CORRECT for s in statuses):
        return Feedback(CORRECT, " ".join(fb.message for _, fb in parts))

    def blank(name: str, fb: Feedback) -> str:
        unwritten = "NotImplementedError" in fb.message
        return f"{name} {'still raises NotImplementedError' if unwritten else 'is still None'}"

    if all(s == NOT_ATTEMPTED for s in statuses):
        return Feedback(NOT_ATTEMPTED, f"{' and '.join(blank(n, fb) for n, fb in parts)}; write "
                                       f"your answers in the cell above and run it, then run "
                                       f"this check again.")
    lines = []
    for name, fb in parts:
        if fb.status == CORRECT:
            lines.append(f"{name}: correct.")
        elif fb.status == NOT_ATTEMPTED:
            lines.append(f"{name}: not attempted yet ({blank(name, fb)}).")
        else:
            lines.append(fb.message)
    status = INCORRECT if INCORRECT in statuses else NOT_ATTEMPTED
    return Feedback(status, " ".join(lines))


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
    if a.shape != e.shape:
        if a.ndim == 2 and a.T.shape == e.shape and np.allclose(a.T, e, rtol=rtol, atol=atol):
            return _wrong(f"{what} is transposed: expected shape {e.shape}, got {a.shape}.")
        if a.size == e.size and np.allclose(a.reshape(e.shape), e, rtol=rtol, atol=atol):
            return _wrong(f"{what} has the right numbers in the wrong shape: expected shape "
                          f"{e.shape}, got {a.shape} (reshape it).")
        return _wrong(f"{what} has the wrong shape: expected {e.shape}, got {a.shape}.")
    if np.allclose(a, e, rtol=rtol, atol=atol):
        return Feedback(CORRECT, f"{what} matches the reference.")
    if np.any(e != 0) and np.allclose(-a, e, rtol=rtol, atol=atol):
        return _wrong(f"{what} has the wrong sign (check the order of a difference, e.g. "
                      f"y - C x rather than C x - y).")
    if a.ndim == 2 and a.shape[0] == a.shape[1] and np.allclose(a.T, e, rtol=rtol, atol=atol):
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
    if a.ndim == 2 and a.shape[0] == a.shape[1] and np.allclose(e, e.T) and not np.allclose(a, a.T):
        return _wrong(f"{what} should be a covariance, which is symmetric; yours is not "
                      f"(max |A - A^T| = {np.max(np.abs(a - a.T)):.3g}).")
    wrong = ~np.isclose(a, e, rtol=rtol, atol=atol)
    where = tuple(int(i) for i in np.argwhere(wrong)[0])
    return _wrong(f"{what} has the right shape but {int(wrong.sum())} of {a.size} entries "
                  f"differ from the reference (the first at index {where}).")


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
    """Compare a number with the reference; says too large/too small, wrong sign, or a factor."""
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
    if e != 0 and a != 0 and _common_factor(np.array([a]), np.array([e])) is not None:
        ratio = a / e
        if ratio > 0 and _is_simple_factor(ratio):
            return _wrong(f"{what} is off by a simple factor (2, 1/2 or 2 pi?).")
    return _wrong(f"{what} is too {'large' if a > e else 'small'}.")


def compare_function(fun, reference: Callable, cases: Sequence[tuple], what: str = "your function",
                     compare: Callable = compare_array, **compare_kw) -> Feedback:
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
    compare : callable
        :func:`compare_array` or :func:`compare_number` (with ``**compare_kw``).
    """
    if fun is None:
        return _not_attempted(what)
    if not callable(fun):
        return _wrong(f"{what} must be a function (def ...), got {type(fun).__name__}.")
    for k, args in enumerate(cases):
        shown = _describe_args(args)
        try:
            out = fun(*copy.deepcopy(args))
        except NotImplementedError:
            return _not_written(what)
        except Exception as exc:  # noqa: BLE001 - any failure is feedback, not a crash
            return _wrong(f"{what} fails on test input {k + 1} ({shown}): "
                          f"{type(exc).__name__}: {exc}")
        result = compare(out, reference(*copy.deepcopy(args)),
                         what=f"the output for test input {k + 1} ({shown})", **compare_kw)
        if result.status == NOT_ATTEMPTED:
            return _wrong(f"{what} returned None on test input {k + 1} ({shown}); "
                          f"did you forget `return`?")
        if result.status != CORRECT:
            return result
    return Feedback(CORRECT, f"{what} agrees with the library on all {len(cases)} test inputs.")


def _describe_args(args: tuple) -> str:
    """The test inputs as a student can read them: small arrays in full, others by shape or type.

    Only numbers, arrays and plain lists/tuples are read as arrays; anything else (a model, a
    named tuple of arrays of different shapes, a function) is named by its type, so that
    describing an input can never fail.
    """
    parts = []
    for a in args:
        arr = None
        if isinstance(a, (numbers.Number, np.ndarray, np.generic)) or type(a) in (list, tuple):
            try:
                arr = np.asarray(a)
            except Exception:  # noqa: BLE001 - a ragged list is described by its type
                arr = None
        if arr is not None and arr.dtype.kind in "iuf" and arr.size <= 6:
            parts.append(np.array2string(arr, precision=3, separator=", "))
        elif arr is not None and arr.dtype.kind in "iuf":
            parts.append(f"array of shape {arr.shape}")
        else:
            parts.append(type(a).__name__)
    return ", ".join(parts)


def compare_choice(answer, expected: str, options: Sequence[str], what: str = "your choice",
                   hint: str = "") -> Feedback:
    """A choice among named options (case and surrounding spaces ignored)."""
    if answer is None or answer is Ellipsis:
        return _not_attempted(what)
    names = [o.lower() for o in options]
    if not isinstance(answer, str) or answer.strip().lower() not in names:
        return _wrong(f"{what} must be one of {list(options)}, got {answer!r}.")
    if answer.strip().lower() == expected.lower():
        return Feedback(CORRECT, f"{what} is right.")
    return _wrong(f"{what} is not the right option." + (f" Hint: {hint}" if hint else ""))


def __getattr__(name: str):
    if name in _CHAPTERS or re.fullmatch(r"ch\d\d", name):
        try:
            module = importlib.import_module(f".{name}", __name__)
        except ModuleNotFoundError as exc:
            if exc.name != f"{__name__}.{name}":
                raise  # the chapter module exists but an import inside it fails: show that
            # No checks for this chapter (yet): an AttributeError, so hasattr() is False.
            raise AttributeError(f"module 'bayesfilt.checks' has no attribute {name!r} "
                                 f"(there is no bayesfilt/checks/{name}.py)") from None
        globals()[name] = module
        return module
    raise AttributeError(f"module 'bayesfilt.checks' has no attribute {name!r}")


def __dir__():
    import pkgutil

    chapters = {m.name for m in pkgutil.iter_modules(__path__) if re.fullmatch(r"ch\d\d", m.name)}
    return sorted(set(globals()) | chapters)
