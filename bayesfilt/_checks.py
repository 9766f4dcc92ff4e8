"""Argument checks shared by every public function of :mod:`bayesfilt`.

Each helper converts its input to a float array, checks one property and
raises a ``ValueError`` (or ``TypeError`` for the wrong kind of object) whose
message names the argument, the expected shape or property, and what it got.
The filters call these helpers on entry so that a wrong shape fails loudly
instead of broadcasting into a silently wrong answer.
"""

from __future__ import annotations

import numbers

import numpy as np

__all__ = [
    "as_array",
    "as_vector",
    "as_matrix",
    "as_square",
    "as_covariance",
    "as_int",
    "as_positive_float",
    "as_rng",
    "check_callable",
    "as_noise_gain",
    "as_inputs",
    "check_output",
    "require_finite",
    "observation_masks",
]


def _describe(a) -> str:
    a = np.asarray(a)
    return f"shape {a.shape}" if a.ndim else f"scalar {a!r}"


def as_array(name: str, value, *, ndim: int | None = None, finite: bool = True) -> np.ndarray:
    """Return ``value`` as a float array, checking its number of dimensions.

    Booleans, strings, complex numbers and ragged lists are rejected with a
    ``TypeError``: numpy would otherwise convert some of them silently.
    """
    if value is None:
        raise TypeError(f"{name} must be an array of numbers, got None")
    try:
        raw = np.asarray(value)
    except ValueError as exc:  # ragged nested lists
        raise TypeError(f"{name} must be a rectangular array of numbers, got a ragged "
                        f"{type(value).__name__}") from exc
    if raw.dtype.kind not in "iuf":
        what = {"b": "booleans", "c": "complex numbers", "U": "strings", "S": "bytes",
                "O": "objects (a ragged or mixed sequence?)"}.get(raw.dtype.kind, str(raw.dtype))
        raise TypeError(f"{name} must be an array of real numbers, got {what}")
    a = raw.astype(float, copy=False)
    if ndim is not None and a.ndim != ndim:
        raise ValueError(f"{name} must be {ndim}-dimensional, got {_describe(a)}")
    if finite and not np.all(np.isfinite(a)):
        raise ValueError(f"{name} must be finite, got NaN or inf at index "
                         f"{tuple(int(i) for i in np.argwhere(~np.isfinite(a))[0])}")
    return a


def as_vector(name: str, value, size: int | None = None, *, finite: bool = True) -> np.ndarray:
    """Return ``value`` as a 1-D float array of length ``size`` (any length if None).

    A scalar is accepted when ``size`` is 1, so that a 1-D problem can be
    written without brackets.
    """
    a = as_array(name, value, finite=finite)
    if a.ndim == 0 and size in (None, 1):
        a = a.reshape(1)
    if a.ndim != 1:
        raise ValueError(f"{name} must be a vector of shape ({size if size is not None else 'n'},), "
                         f"got {_describe(a)}")
    if size is not None and a.shape[0] != size:
        raise ValueError(f"{name} must have shape ({size},), got shape {a.shape}")
    if a.shape[0] == 0:
        raise ValueError(f"{name} must not be empty, got shape {a.shape}")
    return a


def as_matrix(name: str, value, shape: tuple[int | None, int | None] | None = None,
              *, finite: bool = True) -> np.ndarray:
    """Return ``value`` as a 2-D float array; ``None`` in ``shape`` means any size.

    A scalar is accepted for a (1, 1) matrix.
    """
    a = as_array(name, value, finite=finite)
    if a.ndim == 0 and shape is not None and all(s in (None, 1) for s in shape):
        a = a.reshape(1, 1)
    if a.ndim != 2:
        want = ("of shape (" + ", ".join("?" if s is None else str(s) for s in shape) + ")"
                if shape else "(2-D)")
        raise ValueError(f"{name} must be a matrix {want}, got {_describe(a)}")
    if 0 in a.shape:
        raise ValueError(f"{name} must not be empty, got shape {a.shape}")
    if shape is not None:
        for axis, want in enumerate(shape):
            if want is not None and a.shape[axis] != want:
                pretty = "(" + ", ".join("?" if s is None else str(s) for s in shape) + ")"
                raise ValueError(f"{name} must have shape {pretty}, got shape {a.shape}")
    return a


def as_square(name: str, value, size: int | None = None, *, finite: bool = True) -> np.ndarray:
    """Return ``value`` as a square matrix (of side ``size`` if given)."""
    a = as_matrix(name, value, (size, size), finite=finite)
    if a.shape[0] != a.shape[1]:
        raise ValueError(f"{name} must be square, got shape {a.shape}")
    return a


def as_covariance(name: str, value, size: int | None = None, *, definite: bool = False,
                  rtol: float = 1e-9) -> np.ndarray:
    """Return ``value`` as a symmetric positive semi-definite matrix.

    Parameters
    ----------
    name : str
        Argument name used in error messages.
    value : array_like, shape (n, n)
        Candidate covariance. A scalar is accepted when ``size`` is 1.
    size : int, optional
        Required side length.
    definite : bool
        Require strict positive definiteness (invertibility).
    rtol : float
        Tolerance, relative to the largest absolute entry, for symmetry and
        for strict definiteness.

    Every diagonal entry (a variance) must be >= 0 exactly; the smallest
    eigenvalue may be below zero by rounding, 1e-12 * n * max |entry|.
    """
    a = as_square(name, value, size)
    scale = max(float(np.max(np.abs(a))), 1e-300)
    asym = float(np.max(np.abs(a - a.T)))
    if asym > rtol * scale:
        raise ValueError(f"{name} must be symmetric, got max |{name} - {name}^T| = {asym:.3g}")
    # A variance cannot be negative: the diagonal entries are the matrix's own numbers,
    # not computed from it, so no tolerance (however large the other entries are).
    diag = np.diag(a)
    if np.any(diag < 0):
        i = int(np.flatnonzero(diag < 0)[0])
        raise ValueError(f"{name} must be positive semi-definite, got a negative variance "
                         f"{name}[{i}, {i}] = {diag[i]:.3g}")
    # The eigenvalues are computed, and rounding moves them by about n eps |a|: allow a
    # few thousand times that below zero.
    tol = 1e-12 * scale * a.shape[0]
    eig_min = float(np.linalg.eigvalsh(0.5 * (a + a.T)).min())
    if eig_min < -tol:
        raise ValueError(f"{name} must be positive semi-definite, got smallest eigenvalue {eig_min:.3g}")
    if definite and eig_min <= rtol * scale:
        raise ValueError(f"{name} must be positive definite (invertible), "
                         f"got smallest eigenvalue {eig_min:.3g}")
    return a


def as_int(name: str, value, *, minimum: int | None = None) -> int:
    """Return ``value`` as a Python int, rejecting floats and bools."""
    if isinstance(value, np.ndarray) and value.ndim == 0:
        value = value.item()  # a 0-d array counts as its scalar
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Integral):
        raise TypeError(f"{name} must be an integer, got {type(value).__name__} {value!r}")
    value = int(value)
    if minimum is not None and value < minimum:
        raise ValueError(f"{name} must be >= {minimum}, got {value}")
    return value


def as_positive_float(name: str, value, *, allow_zero: bool = False) -> float:
    """Return ``value`` as a finite float > 0 (>= 0 with ``allow_zero``)."""
    if isinstance(value, np.ndarray) and value.ndim == 0:
        value = value.item()  # a 0-d array counts as its scalar
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Real):
        raise TypeError(f"{name} must be a real number, got {type(value).__name__} {value!r}")
    value = float(value)
    if not np.isfinite(value) or value < 0 or (value == 0 and not allow_zero):
        bound = ">= 0" if allow_zero else "> 0"
        raise ValueError(f"{name} must be finite and {bound}, got {value!r}")
    return value


def as_rng(name: str, rng) -> np.random.Generator:
    """Require a ``numpy.random.Generator`` (seeded by the caller)."""
    if not isinstance(rng, np.random.Generator):
        raise TypeError(f"{name} must be a numpy.random.Generator, e.g. np.random.default_rng(0); "
                        f"got {type(rng).__name__}")
    return rng


def check_callable(name: str, fun) -> None:
    """Require ``fun`` to be callable."""
    if not callable(fun):
        raise TypeError(f"{name} must be callable, got {type(fun).__name__}")


def as_noise_gain(G, n: int, q: int) -> np.ndarray:
    """The process-noise gain G (n, q), or the identity when G is None (then Q must be n x n)."""
    if G is None:
        if q != n:
            raise ValueError(f"Q must have shape ({n}, {n}) when G is omitted (G = I), "
                             f"got shape ({q}, {q})")
        return np.eye(n)
    return as_matrix("G", G, (n, q))


def as_inputs(model, us, T: int):
    """The known inputs u_0..u_{T-2} of ``model``: a (T - 1, p) array (T rows are accepted
    and the last is dropped), or None when ``us`` is None.

    Refused: inputs for a model without a control matrix B, a column count other than
    the model's ``control_dim``, and a row count other than T - 1 or T.
    """
    if us is None:
        return None
    if getattr(model, "B", None) is None:
        raise ValueError("us was given but the model has no control matrix B")
    us, p = as_array("us", us), model.control_dim
    if us.ndim != 2 or us.shape[1] != p:
        raise ValueError(f"us must have shape (T - 1, {p}) = ({T - 1}, {p}), got shape "
                         f"{us.shape}")
    if us.shape[0] not in (T - 1, T):
        raise ValueError(f"us must have T - 1 = {T - 1} (or T = {T}) rows, got {us.shape[0]}")
    return us[: T - 1]


def check_output(what: str, out, shape: tuple[int, ...], at=None) -> np.ndarray:
    """What a user function returned, required to be a finite float array of ``shape``.

    ``what`` names the function (e.g. ``"ekf.update: Jacobian H"``); ``at`` is
    the state it was evaluated at, quoted when the output is not finite.
    """
    out = np.asarray(out, dtype=float)
    if out.shape != shape:
        raise ValueError(f"{what} must return shape {shape}, got shape {out.shape}")
    if not np.all(np.isfinite(out)):
        where = "" if at is None else f" at x = {np.array2string(np.asarray(at), precision=4)}"
        raise ValueError(f"{what} returned non-finite values (NaN or inf){where}")
    return out


def require_finite(where: str, what: str, a) -> None:
    """ValueError if a computed result overflowed; names the result and its first bad index."""
    bad = ~np.isfinite(a)
    if np.any(bad):
        index = tuple(int(i) for i in np.argwhere(bad)[0]) if np.ndim(a) else ()
        raise ValueError(f"{where}: {what} overflowed to a non-finite value"
                         + (f" at index {index}" if index else "")
                         + "; the model or the data are too large for floating point")


def observation_masks(ys: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The masks of a measurement record ``ys`` (..., m) in which NaN marks a missing component.

    Returns ``observed`` (...): True where at least one component of the row
    was measured, and ``observed_components`` (..., m): True where the
    component was measured. ValueError naming the index of an inf.
    """
    if np.isfinite(ys).all():
        return np.ones(ys.shape[:-1], dtype=bool), np.ones(ys.shape, dtype=bool)
    if np.isinf(ys).any():
        where = tuple(int(i) for i in np.argwhere(np.isinf(ys))[0])
        raise ValueError(f"ys must be finite or NaN (missing), got inf at index {where}")
    components = ~np.isnan(ys)
    return components.any(axis=-1), components
