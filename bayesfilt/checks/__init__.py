r"""Exercises that answer back: checks that compare a student's answer with the library's.

Every chapter ends with exercises. Each has an *answer cell*, where the student writes a number, an
array or a small function, and a *check cell* that calls one function of this package::

    import bayesfilt as bf
    gain_2 = ...                                      # the student's answer
    bf.checks.ch02.exercise_2(kalman_gain, gain_2)    # shows: correct, or what differs

A check never shows the solution. It says one of three things:

* **not attempted yet** - the answer is still ``None``, or the function is still a stub (its body
  only a docstring, ``pass`` or comments, or ``raise NotImplementedError``), so "Run All" runs the
  whole chapter;
* **correct**;
* **not yet** - and *what* differs, diagnosed the way a tutor would: a wrong shape (with the
  expected one), a transposed matrix, a result off by a factor (an unnormalised belief, a missing
  normalising constant), the wrong sign (an innovation written :math:`C\hat x - y`), a covariance
  that is not symmetric, a function that fails (with the input that broke it). The diagnosis comes
  first; the test input, if any, last.

The references are computed by the library when a check runs, never stored in the notebook, so a
student edition (``tools/make_student_edition.py``) hands out the check cells as they are. A choice
answer (a word, "yes" or "no", a set of letters) is stored as a salted hash (:func:`digest`), not
in clear. The chapter modules ``bf.checks.ch01`` ... hold one check per exercise, built on the
comparisons here (:func:`compare_array`, :func:`compare_number`, :func:`compare_function`,
:func:`compare_choice`) and run through one engine (:func:`exercise`, applied to every
``exercise_N`` of a module by :func:`register`).

The statement's numbers: :func:`given`
--------------------------------------
A statement's numbers are variables of the notebook (the answer cell's given data, such as
``position_3`` in chapter 02), and a teacher may change them. The engine remembers the namespace of the notebook
that called the check (the caller's globals, when they are a notebook's or a script's:
``__name__ == "__main__"``), and a check reads a number with :func:`given`, whose second argument
is the statement's value, used only where the name is absent (a unit test that passes no
namespace)::

    POSITION_3 = 12.0                               # chNN.py: the statement's value

    def exercise_3(mean, sd) -> Feedback:
        pos = float(given("position_3", POSITION_3))  # the notebook's position_3, if it has one
        return compare_number(mean, reference(pos), "mean_3")

A test passes the notebook's variables explicitly, ``ch02.exercise_3(mean, sd,
namespace={"position_3": 10.0, ...})``. A function that :func:`given` returns (a helper the statement asks the student to write,
such as ``belief_near_truth``) runs under the same guard as an answer.

The engine: a time budget, in-place changes, any failure a "Not yet"
--------------------------------------------------------------------
Every callable answer runs *guarded*:

* **One time budget per check**, :data:`TIME_LIMIT` seconds (10; the environment variable
  ``BAYESFILT_CHECK_TIME_LIMIT`` overrides it) for all the calls of the student's functions in one
  check cell together; then "Not yet: stopped after 10 s".
* **In-place changes**: an argument, or a chapter variable the function reads (an array, a named
  tuple, a model), that has changed after a call ends the check with a "Not yet"; the chapter
  variable is put back (to its value before that call), and so is a chapter variable that the
  function rebinds with ``global``.
* **Any failure** - an ``Exception`` with the input that broke it, and any other
  ``BaseException`` (``SystemExit``, ``GeneratorExit``, ...) except ``KeyboardInterrupt``, which
  stays Jupyter's interrupt - is a "Not yet"; a check never raises, except under nbgrader.

How the budget stops a function, and why this way. The check arms ``SIGALRM``
(``signal.setitimer``) for what is left of the budget, in the kernel's own process and main thread,
where notebook code runs. At the deadline the handler raises ``_Stop`` (a ``BaseException``,
so that no ``except Exception`` swallows it) and, as a bare ``except:`` could still catch that, it
also turns on a trace function (``sys.settrace`` and ``frame.f_trace`` on the student's frames) that
raises again at the next line of Python the student's code runs; the timer repeats every 50 ms
until the call has ended. An exception caught by a handler is raised again at the handler's first
line, outside the ``try``, so every pure-Python loop ends within a fraction of a second after the
deadline, whatever it catches; the trace is off the rest of the time, so a correct answer runs at
full speed. Afterwards the previous trace function, signal handler and timer are restored, so
Jupyter's interrupt (``SIGINT``) works as before. We chose this over a worker process (``fork``)
because the student's function must run *here*: a fork would change nothing in place (so the
in-place check and the "put back" would need copies shipped back), would draw from a copy of the
notebook's random generators (the same numbers on every call: ch06's check that a function draws
random numbers would see nothing), would have to pickle every result, and forking a kernel with
running threads is fragile (its output stream and its locks). Limits: where ``SIGALRM`` does not
exist (Windows) or the check runs outside the main thread, a call is not interrupted (the time is
still counted, so a check makes no further call once its budget is spent), and one long C call (a
huge numpy operation) finishes before the signal is seen; nbgrader's own cell timeout then stops
the cell.

Under nbgrader (the environment variable ``NBGRADER_EXECUTION`` set) a correct answer prints its
message and returns nothing (a value would be read as partial credit), and a check that is not
correct raises :class:`Check` with its message, whose first line carries the diagnosis within the
90 characters ``nbgrader validate`` shows; the traceback shows the check cell and no frame of the
library (no path). Elsewhere a check returns its :class:`Feedback`, which the cell displays.
"""

from __future__ import annotations

import ast
import contextlib
import copy
import dis
import functools
import hashlib
import importlib.util
import inspect
import linecache
import numbers
import os
import pkgutil
import re
import signal
import sys
import textwrap
import threading
import time
import warnings
from typing import Callable, NamedTuple, Sequence

import numpy as np

__all__ = ["Feedback", "Check", "compare_array", "compare_number", "compare_function",
           "compare_choice", "digest", "exercise", "given", "register", "code_names", "referenced",
           "NOT_ATTEMPTED", "CORRECT", "INCORRECT", "TIME_LIMIT"]

NOT_ATTEMPTED = "not attempted yet"
CORRECT = "correct"
INCORRECT = "not yet"

#: Seconds that a student's functions may run in one check cell, all calls together. The
#: environment variable BAYESFILT_CHECK_TIME_LIMIT overrides it (a test sets it low).
TIME_LIMIT = float(os.environ.get("BAYESFILT_CHECK_TIME_LIMIT", "10"))

#: A message that is not "Correct" is shown in lines of at most this many characters, so that
#: nbgrader validate (90 characters, 4 of indent, "Check: ") shows each line whole.
WIDTH = 76


class Feedback(NamedTuple):
    """What a check says; its representation is the message, so a check cell shows it.

    Parameters
    ----------
    status : str
        ``CORRECT``, ``INCORRECT`` or ``NOT_ATTEMPTED`` (the three statuses above).
    message : str
        What is right, or what differs (the diagnosis first).
    """

    status: str
    message: str

    def __repr__(self) -> str:
        mark = {CORRECT: "Correct", NOT_ATTEMPTED: "Not attempted yet"}.get(self.status, "Not yet")
        text = f"{mark}: {self.message}" if self.message else mark
        if self.status == CORRECT:                # as the notebooks store it: one line
            return text
        return "\n".join(textwrap.fill(part, WIDTH, break_long_words=False,
                                       break_on_hyphens=False) for part in text.split("\n"))

    @property
    def correct(self) -> bool:
        return self.status == CORRECT


class Check(AssertionError):
    """Raised under nbgrader by a check that is not correct; its text is the check's message."""


def _not_attempted(what: str, unwritten: str | bool = "") -> Feedback:
    if isinstance(unwritten, bool):           # the former signature: True, NotImplementedError
        unwritten = "raises" if unwritten else ""
    todo = {"": "is still None; write your answer",
            "raises": "still raises NotImplementedError; write its body",
            "stub": "has no body yet (only its docstring); write its body"}[unwritten]
    return Feedback(NOT_ATTEMPTED, f"{what} {todo} in the cell above and run it, then run this "
                                   f"check again.")


def _wrong(message: str) -> Feedback:
    return Feedback(INCORRECT, message)


# --- choices stored as salted hashes ----------------------------------------------------------

def _normal(text: str) -> str:
    """A choice as compared: lower case, hyphens as spaces, single spaces."""
    return " ".join(str(text).strip().lower().replace("-", " ").split())


def digest(text: str, salt: str) -> str:
    """The salted hash under which a check stores a choice answer: ``"sha256:<salt>:<hex>"``.

    A chapter module writes the literal (e.g. ``SEES_5 = "sha256:ch03-ex5:..."``) and passes it to
    :func:`compare_choice` as ``expected``, so that the right option is not in the module in
    clear. Case, surrounding spaces and hyphens do not count (``_normal``).
    """
    hexa = hashlib.sha256(f"{salt}\n{_normal(text)}".encode()).hexdigest()[:20]
    return f"sha256:{salt}:{hexa}"


def _is(answer, expected: str) -> bool:
    """Does ``answer`` match ``expected``, a choice in clear or a :func:`digest`?"""
    if not isinstance(answer, str):
        return False
    if expected.startswith("sha256:"):
        return digest(answer, expected.split(":")[1]) == expected
    return _normal(answer) == _normal(expected)


# --- the engine: one check's run, its namespace and time budget -------------------------------

class _Stop(BaseException):
    """_Stop(message): a student's function misbehaved, the check ends with a "Not yet" saying
    message (a BaseException, so that no ``except Exception`` of a chapter helper swallows it)."""


class _Unwritten(NotImplementedError):
    """A function whose body is still the stub (the guard raises it instead of calling it)."""


class _Run:
    """The check being run: the notebook's namespace, the time its student functions used."""

    def __init__(self, namespace: dict | None):
        self.namespace, self.spent, self.timing = namespace, 0.0, False


_local = threading.local()


def _active() -> _Run | None:
    return getattr(_local, "run", None)


_MISSING = object()


def given(name: str, default=_MISSING):
    """The value of ``name`` in the notebook whose check is running, else ``default``.

    Parameters
    ----------
    name : str
        A variable of the statement, e.g. ``"position_3"``, or a function the statement asks the student
        to write (it comes back guarded, as an answer does).
    default
        The statement's value, used when the notebook has no such variable (a unit test that
        passes no namespace); without it the name is required.

    Returns
    -------
    object
    """
    run = _active()
    space = run.namespace if run is not None else None
    if space is None or name not in space:
        if default is _MISSING:
            raise LookupError(f"the notebook has no variable {name}")
        return default
    value = space[name]
    return _guard(value) if _is_function(value) else value


def _is_function(value) -> bool:
    return callable(value) and not isinstance(value, type) and hasattr(value, "__code__")


def _is_stub(fun) -> bool:
    """Is ``fun`` a def whose body is only a docstring, ``pass``, ``...`` or comments (nbgrader's
    stub)? Its code object only returns None; where its source is at hand (a notebook's cell), a
    body that says ``return None`` is not a stub."""
    fun = inspect.unwrap(fun)
    code = getattr(fun, "__code__", None)
    if code is None or code.co_name == "<lambda>" or not _returns_none_only(code):
        return False
    try:
        tree = ast.parse(textwrap.dedent(inspect.getsource(fun)))
    except (OSError, TypeError, SyntaxError):
        return True                                  # no source: the code object decides
    body = next((n.body for n in ast.walk(tree)
                 if isinstance(n, (ast.FunctionDef, ast.AsyncFunctionDef))), [])
    return all(isinstance(n, ast.Pass) or (isinstance(n, ast.Expr)
                                           and isinstance(n.value, ast.Constant)) for n in body)


@functools.lru_cache(maxsize=1024)
def _returns_none_only(code) -> bool:
    ops = [(i.opname, i.argval) for i in dis.get_instructions(code)
           if i.opname not in ("RESUME", "NOP", "CACHE", "COPY_FREE_VARS", "MAKE_CELL")]
    return ops in ([("LOAD_CONST", None), ("RETURN_VALUE", None)], [("RETURN_CONST", None)])


def code_names(fun, depth: int = 2) -> set[str]:
    """The global and attribute names that ``fun``'s code uses (``model.H``: ``model``, ``H``),
    with those of the notebook functions it calls, ``depth`` levels down."""
    fun = inspect.unwrap(fun)
    code, space = getattr(fun, "__code__", None), getattr(fun, "__globals__", {})
    names, stack = set(), [code] if code is not None else []
    while stack:
        c = stack.pop()
        names.update(c.co_names)
        stack.extend(k for k in c.co_consts if inspect.iscode(k))
    for name in list(names) if depth > 0 else ():
        other = space.get(name)
        if _is_function(other) and other is not fun and getattr(other, "__globals__", {}) is space:
            names |= code_names(other, depth - 1)
    return names


def referenced(fun, depth: int = 2) -> list:
    """The objects ``fun`` reads: the globals its code names and the variables of its closure,
    with those of the notebook functions it calls, ``depth`` levels down."""
    fun = inspect.unwrap(fun)
    space, out = getattr(fun, "__globals__", {}), []
    for cell in getattr(fun, "__closure__", None) or ():
        with contextlib.suppress(ValueError):                   # an empty cell
            out.append(cell.cell_contents)
    for name in code_names(fun, depth=0):
        if name in space:
            out.append(space[name])
    for obj in list(out) if depth > 0 else ():
        if _is_function(obj) and obj is not fun:
            out += referenced(obj, depth - 1)
    return out


def _complex_step(fun) -> bool:
    """Does ``fun``'s code hold a complex constant (``1j``): a complex-step derivative?"""
    code = getattr(inspect.unwrap(fun), "__code__", None)
    stack = [code] if code is not None else []
    while stack:
        c = stack.pop()
        if any(isinstance(k, complex) for k in c.co_consts):
            return True
        stack.extend(k for k in c.co_consts if inspect.iscode(k))
    return False


def _deadline_message(name: str, whole: bool, args, params=()) -> str:
    limit = f"{TIME_LIMIT:g} s"
    how = (f"{name} did not return within {limit}: an endless loop?" if whole else
           f"{name} took more than {limit} in all over the test inputs: far too slow (each call "
           f"should take well under a second).")
    return f"stopped after {limit}: {how} (The check allows {limit} in all for your functions; " \
           f"test input: {_describe_args(args, params)}.)"


@contextlib.contextmanager
def _budget(run: _Run | None, name: str, args, params=()):
    """Run the block within what is left of the check's time budget (module docstring)."""
    left = TIME_LIMIT - (run.spent if run is not None else 0.0)
    if run is None or run.timing or TIME_LIMIT <= 0:
        yield                                 # a nested call, or no budget: time it once
        return
    whole = left >= TIME_LIMIT
    message = functools.cache(lambda: _deadline_message(name, whole, args, params))
    if left <= 0:
        raise _Stop(message())
    alarm_ok = (hasattr(signal, "setitimer")
                and threading.current_thread() is threading.main_thread())
    start, inside, previous_trace = time.perf_counter(), [True], sys.gettrace()
    guard_code = _guard_code

    def tracer(frame, event, arg):            # after the deadline: raise at the next line or call
        if not inside[0] or frame.f_code is alarm.__code__:
            return None
        if event in ("line", "call"):         # not at "exception": the try would still catch it,
            raise _Stop(message())            # and a trace function that raises is switched off
        return tracer

    def alarm(signum, frame):
        if not inside[0]:
            return
        f = frame
        while f is not None and f.f_code is not guard_code:
            f.f_trace, f.f_trace_lines = tracer, True
            f = f.f_back
        sys.settrace(tracer)
        raise _Stop(message())

    run.timing = True
    if alarm_ok:
        previous = signal.signal(signal.SIGALRM, alarm)
        signal.setitimer(signal.ITIMER_REAL, left, 0.05)       # then every 50 ms until stopped
    try:
        yield
    finally:
        inside[0] = False                     # first: neither the alarm nor the tracer acts now
        sys.settrace(previous_trace)
        if alarm_ok:
            signal.setitimer(signal.ITIMER_REAL, 0)
            signal.signal(signal.SIGALRM, previous)
        run.timing = False
        run.spent += time.perf_counter() - start


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


def _is_data(obj) -> bool:
    """A chapter variable a function must not change: an array, a named tuple, a dataclass (a
    model), a container, a random generator."""
    return isinstance(obj, (np.ndarray, np.random.Generator, list, dict, tuple)) or (
        hasattr(obj, "__dataclass_fields__") and not isinstance(obj, type))


def _guard(fun):
    """``fun`` for a check: within the check's time budget; a call that changes an argument or a
    chapter variable in place, or rebinds one, ends the check with a "Not yet" (the chapter
    variable put back); a BaseException other than KeyboardInterrupt is a "Not yet" too."""
    if getattr(fun, "_guarded", False):
        return fun
    name = getattr(fun, "__name__", "<lambda>")
    name = "your function" if name == "<lambda>" else name
    space = getattr(fun, "__globals__", None)
    space = space if isinstance(space, dict) else {}
    refs = {k for k in code_names(fun, depth=0) if k in space}
    stub = _is_stub(fun)
    try:
        params = [p.name for p in inspect.signature(fun).parameters.values()
                  if p.kind in (p.POSITIONAL_ONLY, p.POSITIONAL_OR_KEYWORD)]
    except (TypeError, ValueError):
        params = []

    @functools.wraps(fun)
    def guarded(*args, **kwargs):
        if stub:
            raise _Unwritten(name)
        try:
            before = copy.deepcopy(args)
        except Exception:  # noqa: BLE001 - an argument we cannot copy is not watched
            before = ()
        bound = {k: space[k] for k in sorted(refs) if k in space and _is_data(space[k])}
        chapter = {}
        for k, v in bound.items():                      # drawing from a generator is no change
            with contextlib.suppress(Exception):        # a variable we cannot copy is not watched
                chapter.update({} if isinstance(v, np.random.Generator) else {k: copy.deepcopy(v)})
        try:
            with _budget(_active(), name, args, params):
                out = fun(*args, **kwargs)
        except (_Stop, KeyboardInterrupt, Exception):
            raise
        except BaseException as exc:  # noqa: BLE001 - SystemExit, GeneratorExit, ...: a Not yet
            raise _Stop(_raised(exc, name, args, params)) from None
        finally:
            changed = _put_back(name, space, bound, chapter)
        if changed:
            raise _Stop(changed)
        names = params + [f"argument {k + 1}" for k in range(len(params), len(args))]
        for arg, now, then in zip(names, args, before):
            if not _same(now, then):
                alias = "y" if arg == "x" else "x"
                raise _Stop(
                    f"{name} changes its argument {arg} in place ({arg} /= ..., {arg} -= ..., "
                    f"{arg}[...] = ..., or {alias} = {arg}; {alias} += ...): the caller's array "
                    f"changes too. Work on a copy ({alias} = np.array({arg}, dtype=float)) or "
                    f"write {alias} = {arg} + ... (test input: {_describe_args(before, params)}).")
        return out

    guarded._guarded = True
    return guarded


_guard_code = _guard(lambda: 0).__code__      # the frame where the budget's trace stops


def _put_back(name: str, space: dict, bound: dict, chapter: dict) -> str:
    """Undo what one call did to the chapter's variables; the message for the first, or ""."""
    message = ""
    for k, obj in bound.items():
        if space.get(k) is not obj:                                   # global k; k = ...
            space[k] = obj
            message = message or (f"{name} rebinds the chapter's variable {k} "
                                  f"(global {k}; {k} = ...): the rest of the chapter would see "
                                  f"the new value. Use a local name instead; the check has put "
                                  f"{k} back as it was before this call.")
    for k, then in chapter.items():
        now = bound[k]
        if _same(now, then):
            continue
        restored = False
        if isinstance(now, np.ndarray) and now.flags.writeable and now.shape == then.shape:
            now[...] = then
            restored = True
        elif isinstance(now, (list, dict)):
            now.clear()
            (now.extend if isinstance(now, list) else now.update)(then)
            restored = True
        message = message or (
            f"{name} changes the chapter's variable {k} in place: the rest of the "
            f"chapter would see it changed. Work on a copy ({k}.copy())" + (
                f"; the check has put {k} back as it was before this call." if restored else "."))
    return message


def _raised(exc: BaseException, name: str, args, params=()) -> str:
    kind = type(exc).__name__
    hint = ("exit() and sys.exit() end a program, not a function: return the result instead."
            if isinstance(exc, SystemExit) else "a function ends with return (a failure with an "
            "ordinary exception, such as ValueError).")
    return (f"your function raised {kind} ({name}, test input: "
            f"{_describe_args(args, params)}): {hint}")


def exercise(check: Callable) -> Callable:
    """Make ``check`` an exercise: never raises, student functions guarded, graded by nbgrader.

    Every callable answer is guarded (the check's time budget, in-place changes); any failure
    inside it is a "Not yet". The check runs with the namespace of the notebook that called it
    (:func:`given`), or the one passed as the keyword ``namespace``. Under nbgrader
    (``NBGRADER_EXECUTION`` set) a correct answer prints its message and returns None, and one
    that is not correct raises :class:`Check` with its message: the cell loses its points.

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
    def run(*answers, namespace: dict | None = None, **kwargs):
        __tracebackhide__ = True  # noqa: F841 - IPython leaves this frame out of a traceback
        outer = _active()
        if outer is None:
            caller = sys._getframe(1).f_globals
            if namespace is None and caller.get("__name__") == "__main__":
                namespace = caller                          # a notebook's (or a script's)
            _local.run = _Run(namespace)
        try:
            feedback = _run(check, answers, kwargs)
        finally:
            _local.run = outer
        if outer is None and os.environ.get("NBGRADER_EXECUTION"):
            if feedback.correct:
                print(repr(feedback))           # no value: nbgrader would read it as a score
                return None
            _fail(feedback)
        return feedback

    run._is_exercise = True
    return run


def _run(check, answers, kwargs) -> Feedback:
    guarded = [_guard(a) if callable(a) and not isinstance(a, type) else a for a in answers]
    try:
        with np.errstate(all="ignore"), warnings.catch_warnings():
            warnings.simplefilter("ignore")
            return check(*guarded, **kwargs)
    except _Stop as stop:
        return _wrong(stop.args[0])
    except KeyboardInterrupt:
        raise
    except BaseException as exc:  # noqa: BLE001 - a check never raises
        return _wrong(f"the check could not read your answer ({type(exc).__name__}: "
                      f"{_text(exc)}); check its type and shape against the statement.")


def _text(exc: BaseException) -> str:
    try:
        return str(exc)
    except Exception:  # noqa: BLE001 - an exception that cannot print itself
        return "?"


# A one-line raiser compiled under a file name that is no path: IPython shows the check cell,
# hides run() (__tracebackhide__) and shows this frame, the last, as "<bayesfilt.checks>".
_RAISER_FILE = "<bayesfilt.checks>"
_RAISER = "def report(message):\n    raise Check(message) from None\n"
_raiser_space = {"Check": Check}
exec(compile(_RAISER, _RAISER_FILE, "exec"), _raiser_space)


def _fail(feedback: Feedback):
    __tracebackhide__ = True  # noqa: F841
    linecache.cache[_RAISER_FILE] = (len(_RAISER), None, _RAISER.splitlines(True), _RAISER_FILE)
    _raiser_space["report"](repr(feedback))


def register(namespace: dict) -> None:
    """Make each ``exercise_N`` of a chapter module an :func:`exercise`, listed in ``__all__``."""
    names = [k for k, v in namespace.items() if re.fullmatch(r"exercise_\d+", k) and callable(v)]
    namespace.update({k: exercise(namespace[k]) for k in names}, __all__=names)


# --- tolerances: an answer is judged in its own precision --------------------------------------

def _tolerance(answer, rtol: float, atol: float, scale: float = 1.0) -> tuple[float, float]:
    """(rtol, atol), widened to the round-off of float32 (or float16) when the answer is in it:
    no statement asks for float64."""
    try:
        dtype = answer.dtype if hasattr(answer, "dtype") else np.asarray(answer).dtype
    except Exception:  # noqa: BLE001
        return rtol, atol
    if dtype.kind == "f" and dtype.itemsize < 8:
        eps = float(np.finfo(dtype).eps)
        return max(rtol, 64 * eps), max(atol, 64 * eps * max(scale, 1.0))
    return rtol, atol


def _low_precision(answer) -> bool:
    return _tolerance(answer, 0.0, 0.0) != (0.0, 0.0)


# --- the comparisons -----------------------------------------------------------------------------

def _frozen(a) -> np.ndarray:
    a = np.array(a, dtype=float)
    a.setflags(write=False)
    return a


def _matches(a: np.ndarray, wrong, rtol: float, atol: float) -> bool:
    w = np.asarray(np.nan if wrong is None else wrong, dtype=float)
    return wrong is not None and a.shape == w.shape and bool(np.allclose(a, w, rtol, atol))


def _combine(parts: Sequence[tuple[str, Feedback]]) -> Feedback:
    """One feedback for an exercise with several answers: correct when all are; otherwise the
    first diagnosis first."""
    statuses = {fb.status for _, fb in parts}
    if statuses <= {CORRECT}:
        return Feedback(CORRECT, " ".join(fb.message for _, fb in parts))

    def blank(name: str, fb: Feedback) -> str:
        for kind in ("still raises NotImplementedError", "has no body yet"):
            if kind in fb.message:
                return f"{name} {kind}"
        return f"{name} is still None"

    if statuses == {NOT_ATTEMPTED}:
        return Feedback(NOT_ATTEMPTED, f"{' and '.join(blank(n, fb) for n, fb in parts)}; write "
                                       f"your answers in the cell above and run it, then run "
                                       f"this check again.")
    ordered = [p for p in parts if p[1].status == INCORRECT] + [
        p for p in parts if p[1].status != INCORRECT]
    return Feedback(INCORRECT if INCORRECT in statuses else NOT_ATTEMPTED, " ".join(
        f"{name}: correct." if fb.correct else fb.message if fb.status == INCORRECT
        else f"{name}: not attempted yet ({blank(name, fb)})." for name, fb in ordered))


def _named(answer, expected, what: str, mistakes, note: str = "", rtol=1e-6, atol=1e-9) -> Feedback:
    """compare_array; a named mistake (an array, or a predicate on the answer) gets its message."""
    fb = compare_array(answer, expected, what, rtol=rtol, atol=atol)
    if fb.status != INCORRECT:
        return Feedback(CORRECT, f"{fb.message} {note}".strip()) if fb.correct else fb
    if np.shape(answer) == np.shape(expected) and "decimals" in fb.message:
        return fb                                                       # rounded: say so first
    rtol, atol = _tolerance(answer, rtol, atol, float(np.max(np.abs(expected), initial=0.0)))
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
    if callable(fun):
        call.__wrapped__ = fun
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
        The student's answer; None means not attempted. A float32 answer is judged to float32
        round-off.
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
    rtol, atol = _tolerance(answer, rtol, atol, float(np.max(np.abs(e), initial=0.0)))
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
        return _wrong(f"{what} has a negative entry, but it is a probability vector (a "
                      f"probability is never below 0).")
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
        return _wrong(f"{what} does not sum to 1 (its entries sum to {a.sum():.4g}), but it is a "
                      f"probability vector.")
    if square and np.allclose(e, e.T) and not np.allclose(a, a.T):
        return _wrong(f"{what} is not symmetric, but it should be: a covariance (or a precision) "
                      f"is "
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
        The student's answer (a one-entry array counts); None means not attempted. A float32
        answer is judged to float32 round-off.
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
        answer = answer.reshape(())[()]
    if isinstance(answer, (bool, np.bool_)) or not isinstance(answer, numbers.Real):
        return _wrong(f"{what} must be a single number, got {type(answer).__name__}.")
    try:
        a, e = float(answer), float(expected)
    except (OverflowError, ValueError, TypeError):
        return _wrong(f"{what} must be a finite number of ordinary size.")
    if not np.isfinite(a):
        return _wrong(f"{what} is NaN or inf.")
    rtol, atol = _tolerance(answer, rtol, atol, abs(e))
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
                     forbidden: Sequence[tuple] = (), **compare_kw) -> Feedback:
    """Run a student's function on test inputs and compare each output with the reference.

    Parameters
    ----------
    fun : callable or None
        The student's function; None, a stub (a body of only a docstring, ``pass`` or comments)
        or one that raises ``NotImplementedError`` is not attempted yet.
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
    forbidden : sequence of (set of str or callable, str)
        What the statement rules out: a set of names (``{"model", "H"}`` for ``model.H``), or a
        predicate on the function, and the message for a function whose code uses them all
        (:func:`code_names`), said when its outputs are otherwise right.

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

    try:                                  # the reference's parameter names label the inputs
        names = [p.name for p in inspect.signature(reference).parameters.values()
                 if p.kind in (p.POSITIONAL_ONLY, p.POSITIONAL_OR_KEYWORD)]
    except (TypeError, ValueError):
        names = []
    labels = [functools.partial(_describe_args, args, names) for args in cases]   # when needed
    return _forbidden(_each_case(fun, what, cases, labels, judge), fun, what, forbidden)


def _forbidden(fb: Feedback, fun, what: str, forbidden) -> Feedback:
    """``fb``, or a "Not yet" if a right function uses what the statement rules out."""
    if not fb.correct or not forbidden:
        return fb
    space = getattr(inspect.unwrap(fun), "__globals__", {})
    names = {k for k in code_names(fun)           # the student's own functions do not count
             if not (_is_function(space.get(k)) and getattr(space[k], "__globals__", {}) is space)}
    for needed, message in forbidden:
        if needed(fun) if callable(needed) else set(needed) <= names:
            return _wrong(f"{what} uses {message}")
    return fb


def _each_case(fun, what: str, cases: Sequence[tuple], labels: Sequence[str],
               judge: Callable) -> Feedback:
    """``fun`` on each case (deep-copied); ``judge(out, where, args)`` says what its output is,
    ``where`` being "test input k"; the label of a failing input (a string, or a function that
    makes it) ends the message."""
    if fun is None or fun is Ellipsis:
        return _not_attempted(what)
    if not callable(fun):
        return _wrong(f"{what} must be a function (def ...), got {type(fun).__name__}.")
    for k, (args, label) in enumerate(zip(cases, labels)):
        where = f"test input {k + 1}"
        feedback = _one_case(fun, what, where, args, judge)
        if feedback.status == NOT_ATTEMPTED:
            return feedback
        if not feedback.correct:
            message = feedback.message if feedback.message.startswith(what) else \
                f"{what}: {feedback.message}"
            label = label() if callable(label) else label
            return _wrong(f"{message} (Test input {k + 1}: {label}.)" if label else message)
    return Feedback(CORRECT, f"{what} agrees with the library on all {len(cases)} test inputs.")


def _one_case(fun, what, where, args, judge) -> Feedback:
    try:
        out = fun(*copy.deepcopy(args))
    except _Unwritten:
        return _not_attempted(what, unwritten="stub")
    except NotImplementedError:
        return _not_attempted(what, unwritten="raises")
    except Exception as exc:  # noqa: BLE001 - any failure is feedback, not a crash
        return _wrong(f"{what} fails on {where}: {type(exc).__name__}: {_text(exc)}")
    if out is None:
        if _is_stub(fun):             # called directly, not through an exercise's guard
            return _not_attempted(what, unwritten="stub")
        return _wrong(f"{what} returned None on {where}; did you forget `return`?")
    return judge(out, where, args)


def _describe_args(args: tuple, names: Sequence[str] = ()) -> str:
    """The test inputs in words: numbers, small arrays in full, others by shape, anything else by
    type; each after its parameter's name when ``names`` has one for it."""
    parts = []
    for k, a in enumerate(args):
        arr = None     # only numbers, arrays and plain lists/tuples are read as arrays
        if isinstance(a, (numbers.Number, np.ndarray, np.generic)) or type(a) in (list, tuple):
            with contextlib.suppress(Exception):  # a ragged list is described by its type
                arr = np.asarray(a)
        if arr is None or arr.dtype.kind not in "iuf":
            text = type(a).__name__
        elif arr.ndim == 0:
            text = f"{arr.item():.4g}"
        elif arr.size <= 6:       # one line, whatever the shape: a message is read as a sentence
            text = " ".join(np.array2string(arr, precision=3, separator=", ").split())
        else:
            text = f"array of shape {arr.shape}"
        parts.append(f"{names[k]} = {text}" if k < len(names) and len(names) == len(args) else text)
    return ", ".join(parts)


def compare_choice(answer, expected: str, options: Sequence[str], what: str = "your choice",
                   hint: str = "") -> Feedback:
    """A choice among named options (case, hyphens and surrounding spaces ignored).

    Parameters
    ----------
    answer : str or None
        The student's choice; None means not attempted.
    expected : str
        The right option, in clear or as a :func:`digest` (``"sha256:..."``).
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
    if not isinstance(answer, str) or _normal(answer) not in [_normal(o) for o in options]:
        shown = repr(answer) if isinstance(answer, str) else type(answer).__name__
        return _wrong(f"{what} must be one of {list(options)}, got {shown}.")
    if _is(answer, expected):
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
