r"""State-space models: what the filters filter.

A state-space model (상태공간 모델) is two conditional distributions and a
prior. In the course notation of seed 000,

.. math::

    x_{t+1} = f(x_t) + G w_t, \qquad w_t \sim \mathcal N(0, Q),

    y_t = h(x_t) + v_t, \qquad v_t \sim \mathcal N(0, R),

    x_0 \sim \mathcal N(m_0, P_0),

with the linear case :math:`f(x) = A x + B u_t`, :math:`h(x) = C x` (a known
control input :math:`u_t` enters only the linear model). The time
convention is seed 000's: the first measurement ``ys[0]`` already measures
:math:`x_0`.

Import it as ``bf.models``::

    import bayesfilt as bf
    model = bf.models.damped_particle()
    xs, ys = bf.models.simulate(model, 100, np.random.default_rng(0))

Every model offers the same small interface, so that any filter can use any
model: a Kalman filter reads the matrices, an EKF calls ``f``/``F``/``h``/``H``,
and a particle filter (chapters 05-06) only needs

* ``model.sample_initial(rng, size)``: draws of :math:`x_0`, shape (size, n);
* ``model.sample_transition(rng, xs, u=None, t=0)``: one draw of
  :math:`x_{t+1}` for each row of ``xs`` (N, n), all particles at once;
* ``model.measurement_logpdf(y, xs)``: :math:`\log p(y \mid x)` for each row,
  shape (N,); with ``observed=mask``, :math:`\log p(y_o \mid x)` of the
  observed components o alone (a partly-missing measurement);
* ``model.transition_logpdf(x_next, xs, u=None, t=0)``:
  :math:`\log p(x_{t+1} \mid x_t)` where the transition has a density
  (needed by a proposal other than the prior).

``t`` is the time index of the state the step starts from (the step goes
from :math:`x_t` to :math:`x_{t+1}`). Most models ignore it; a model whose
transition depends on time (:func:`ungm`, built with
``NonlinearGaussian(..., time_varying=True)``) uses it. Every filter and
:func:`simulate` pass it, so a time-varying model needs no extra argument
anywhere: ``bf.models.simulate(model, T, rng)``,
``bf.ekf.extended_kalman_filter(model, ys)`` and
``bf.particle.particle_filter(model, ys, N, rng)`` work for every model.

Models may name their state components (``model.state_names``) and say
which two are planar positions (``model.position_names``), so that code that
plots positions selects them by name, never by a remembered column number:
the damped particle's state is ``[x1, x1_dot, x2, x2_dot]`` (seed 000's
order) and the vehicle's ``[xi_x, xi_y, xi_x_dot, xi_y_dot]`` (Kay's order).

Letters at the API follow seed 000; the other seeds and filterpy use other
letters for the same objects:

=====================  ==========  =====================  ===========  ==========
object                 course/000  Kay (000, section 3)   001 / 002    filterpy
=====================  ==========  =====================  ===========  ==========
state                  x           s[n]                   x_k / x_t    x
measurement            y           x[n]                   z_k / z_t    z
transition matrix      A           A[n-1] (Jacobian)      f_k          F
measurement matrix     C           H[n]                   h_k          H
process noise gain     G           B                      (in f_k)     (in Q)
process noise cov      Q           Q                      (v_k)        Q
measurement noise cov  R           C[n]                   (n_k)        R
control matrix         B           --                     u_t (002)    B
=====================  ==========  =====================  ===========  ==========
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable, NamedTuple

import numpy as np

from ._checks import (as_array, as_covariance, as_inputs, as_int, as_matrix, as_noise_gain,
                      as_positive_float, as_rng, as_vector, check_callable, check_output)
from .gaussian import _apply_to_rows, _cholesky, _logpdf_rows, _lower_inverse
from .gaussian import _factor as _noise_factor  # L L^T = cov, also for a singular cov

__all__ = [
    "LinearGaussian",
    "NonlinearGaussian",
    "Simulation",
    "simulate",
    "simulate_many",
    "damped_particle",
    "range_bearing",
    "RANGE_BEARING_TRUE_START",
    "range_bearing_residual",
    "wrap_angle",
    "to_nonlinear",
    "ungm",
    "positions",
]


def _as_states(name: str, xs, n: int) -> tuple[np.ndarray, bool]:
    """Accept one state (n,) or a batch (N, n); return (batch, was_single)."""
    a = as_array(name, xs)
    if a.ndim == 0 and n == 1:
        return a.reshape(1, 1), True
    if a.ndim == 1 and a.shape[0] == n:
        return a[None, :], True
    if a.ndim == 2 and a.shape[1] == n and a.shape[0] >= 1:
        return a, False
    raise ValueError(f"{name} must have shape ({n},) or (N, {n}), got shape {a.shape}")


def _freeze(a: np.ndarray) -> np.ndarray:
    a = np.array(a, dtype=float)
    a.setflags(write=False)
    return a


def _cholesky_or_none(cov: np.ndarray) -> np.ndarray | None:
    """Lower Cholesky factor of ``cov`` (read-only), or None if ``cov`` is singular."""
    try:
        return _freeze(np.linalg.cholesky(cov))
    except np.linalg.LinAlgError:
        return None


class _ModelBase:
    """Sampling and densities common to the linear and nonlinear models."""

    # Filled by the subclasses' __post_init__.
    Q: np.ndarray
    R: np.ndarray
    G: np.ndarray
    m0: np.ndarray
    P0: np.ndarray

    @property
    def state_dim(self) -> int:
        """Dimension n of the state x."""
        return self.m0.shape[0]

    @property
    def obs_dim(self) -> int:
        """Dimension m of the measurement y."""
        return self.R.shape[0]

    @property
    def noise_dim(self) -> int:
        """Dimension q of the process noise w (columns of G)."""
        return self.Q.shape[0]

    # --- the three pieces a particle filter needs -------------------------

    def sample_initial(self, rng: np.random.Generator, size: int) -> np.ndarray:
        """Draw ``size`` initial states :math:`x_0 \\sim N(m_0, P_0)`.

        Parameters
        ----------
        rng : numpy.random.Generator
        size : int
            Number of draws (particles), >= 1.

        Returns
        -------
        ndarray, shape (size, n)
        """
        rng = as_rng("rng", rng)
        size = as_int("size", size, minimum=1)
        z = rng.standard_normal((size, self.state_dim))
        # x_0 = m0 + L z with L L^T = P0, for every row z of z
        return self.m0 + _apply_to_rows(self._P0_factor, z)

    def sample_transition(self, rng: np.random.Generator, xs, u=None, t: int = 0) -> np.ndarray:
        """Draw :math:`x_{t+1} \\sim p(x_{t+1} \\mid x_t = x_s, u_t)` for every row.

        Parameters
        ----------
        rng : numpy.random.Generator
        xs : array_like, shape (N, n) or (n,)
            Current states (particles).
        u : array_like, shape (p,), optional
            Known control input (linear models with ``B`` only).
        t : int
            Time index of ``xs`` (used by a time-varying model only).

        Returns
        -------
        ndarray, shape (N, n) or (n,)
            One draw per row, with the noise entering through G, so a noise of
            lower dimension than the state (seed 000's damped particle) is fine.
        """
        rng = as_rng("rng", rng)
        batch, single = _as_states("xs", xs, self.state_dim)
        mean = self._transition_mean(batch, u, t)
        # G w = G L z with L L^T = Q, z ~ N(0, I): one noise draw per particle
        z = rng.standard_normal((batch.shape[0], self.noise_dim))
        # x_{t+1} = f(x_t) (+ B u_t) + G w_t, with G L held by the model
        out = mean + _apply_to_rows(self._noise_gain_factor, z)
        return out[0] if single else out

    def sample_measurement(self, rng: np.random.Generator, xs) -> np.ndarray:
        """Draw :math:`y \\sim p(y \\mid x)` for every row of ``xs``; shape (N, m) or (m,)."""
        rng = as_rng("rng", rng)
        batch, single = _as_states("xs", xs, self.state_dim)
        # y = h(x) + v, v = L z with L L^T = R
        v = _apply_to_rows(self._R_factor, rng.standard_normal((batch.shape[0], self.obs_dim)))
        out = self._measurement_mean(batch) + v
        return out[0] if single else out

    def measurement_logpdf(self, y, xs, observed=None) -> np.ndarray:
        """:math:`\\log p(y \\mid x)` for one measurement and every row of ``xs``.

        With ``observed``, the density of the observed components o alone,
        :math:`\\log p(y_o \\mid x)`: the marginal of a Gaussian
        :math:`N(h(x), R)` is :math:`N(h_o(x), R_{oo})`, the entries o of
        :math:`h(x)` and the rows and columns o of R (what a particle filter
        needs on a partly-missing row).

        Parameters
        ----------
        y : array_like, shape (m,)
            Finite; with ``observed``, only its observed entries are read (the
            others may be NaN).
        xs : array_like, shape (N, n) or (n,)
        observed : array_like of bool, shape (m,), optional
            Which components of ``y`` were observed; None means all. None
            observed gives 0 (the density of no measurement is 1).

        Returns
        -------
        ndarray, shape (N,), or float for a single state.
            Uses ``self.residual`` so that an angle is compared modulo 2 pi
            (with ``observed``, the missing entries of ``y`` are replaced by
            their prediction before it is called, so it must act component by
            component).

        Raises
        ------
        ValueError
            On wrong shapes, a non-finite observed entry of ``y``, or a
            singular R (or :math:`R_{oo}`): then p(y | x) has no density.
        """
        if observed is not None:
            return self._marginal_logpdf(y, xs, observed)
        y = as_vector("y", y, self.obs_dim)
        batch, single = _as_states("xs", xs, self.state_dim)
        residuals = self.residual(y[None, :], self._measurement_mean(batch))
        if self._R_cholesky is None:
            _cholesky("R", self.R)  # raises: a singular R gives p(y | x) no density
        # log N(r; 0, R) row by row, with the factor of R and its inverse held by the model
        out = _logpdf_rows(residuals, self._R_cholesky, self._R_cholesky_inv)
        return float(out[0]) if single else out

    def _marginal_logpdf(self, y, xs, observed) -> np.ndarray:
        """:meth:`measurement_logpdf` of the observed components ``observed`` only."""
        m = self.obs_dim
        o = np.asarray(observed)
        if o.dtype != bool or o.shape != (m,):
            raise ValueError(f"observed must be a boolean mask of shape ({m},), got "
                             f"{o.dtype} of shape {o.shape}")
        y = as_vector("y", y, m, finite=False)
        if not np.all(np.isfinite(y[o])):
            j = int(np.flatnonzero(o & ~np.isfinite(y))[0])
            raise ValueError(f"y must be finite in the observed components, got y[{j}] = {y[j]}")
        batch, single = _as_states("xs", xs, self.state_dim)
        if o.all():
            return self.measurement_logpdf(y, xs)
        if not o.any():
            return 0.0 if single else np.zeros(batch.shape[0])
        y_pred = self._measurement_mean(batch)
        # a missing entry is given its prediction (residual 0 there), then dropped
        residuals = self.residual(np.where(o, y, y_pred), y_pred)[:, o]
        # log N(r_o; 0, R_oo), with the Cholesky factor of R_oo
        L = _cholesky("R_oo (the block of R of the observed components)", self.R[np.ix_(o, o)])
        out = _logpdf_rows(residuals, L)
        return float(out[0]) if single else out

    def transition_logpdf(self, x_next, xs, u=None, t: int = 0) -> np.ndarray:
        """:math:`\\log p(x_{t+1} \\mid x_t, u_t)`, the density a proposal other than the prior needs.

        Parameters
        ----------
        x_next : array_like, shape (n,) or (N, n)
            Next states; one row is compared with every row of ``xs``.
        xs : array_like, shape (n,) or (N, n)
            Current states; one row is compared with every row of ``x_next``.
        u : array_like, shape (p,), optional
            Known control input (linear models with ``B`` only).
        t : int
            Time index of ``xs`` (used by a time-varying model only).

        Returns
        -------
        ndarray, shape (N,), or float for a single pair.

        Raises
        ------
        ValueError
            When :math:`G Q G^T` is singular: the transition then has no
            density on the whole state space (the damped particle's positions
            move deterministically given the velocities).
        """
        batch, single = _as_states("xs", xs, self.state_dim)
        nxt, _ = _as_states("x_next", x_next, self.state_dim)
        if nxt.shape[0] != 1 and batch.shape[0] == 1:
            batch, single = np.repeat(batch, nxt.shape[0], axis=0), False  # one x_t, many x_{t+1}
        if nxt.shape[0] not in (1, batch.shape[0]):
            raise ValueError(f"x_next and xs must have the same number of rows (or one of them "
                             f"a single state), got {nxt.shape[0]} and {batch.shape[0]}")
        if self._GQGt_cholesky is None:
            _cholesky("G Q G^T", self.G @ self.Q @ self.G.T)  # raises: no transition density
        out = _logpdf_rows(nxt - self._transition_mean(batch, u, t), self._GQGt_cholesky,
                           self._GQGt_cholesky_inv)
        return float(out[0]) if single else out

    def residual(self, y, y_pred) -> np.ndarray:
        """Innovation ``y - y_pred`` (overridden for angles)."""
        return np.asarray(y, dtype=float) - np.asarray(y_pred, dtype=float)

    def _check_names(self, n: int) -> None:
        """Validate ``state_names`` (n distinct strings) and ``position_names`` (two of them)."""
        names = self.state_names
        for what, value in (("state_names", names), ("position_names", self.position_names)):
            if isinstance(value, str):
                raise TypeError(f"{what} must be a tuple of strings, got the string {value!r}")
        if names is not None:
            names = tuple(names)
            if len(names) != n or not all(isinstance(a, str) for a in names) or len(set(names)) != n:
                raise ValueError(f"state_names must be {n} distinct strings, one per state "
                                 f"component, got {names!r}")
            object.__setattr__(self, "state_names", names)
        pos = self.position_names
        if pos is not None:
            pos = tuple(pos)
            if names is None or len(pos) != 2 or not set(pos) <= set(names):
                raise ValueError(f"position_names must be two of state_names {names!r}, got {pos!r}")
            object.__setattr__(self, "position_names", pos)

    def index_of(self, *names: str) -> list[int]:
        """Column indices of the named state components, e.g. ``model.index_of("x1", "x2")``."""
        if self.state_names is None:
            raise ValueError("this model has no state_names; select state columns by index")
        unknown = [a for a in names if a not in self.state_names]
        if unknown:
            raise ValueError(f"unknown state component(s) {unknown}; this model's state is "
                             f"{list(self.state_names)}")
        return [self.state_names.index(a) for a in names]

    def _check_noise_and_prior(self, n: int) -> None:
        m0 = as_vector("m0", self.m0, n)
        P0 = as_covariance("P0", self.P0, n)
        Q = as_covariance("Q", self.Q)
        G = as_noise_gain(self.G, n, Q.shape[0])
        R = as_covariance("R", self.R)
        for name, value in (("m0", m0), ("P0", P0), ("Q", Q), ("G", G), ("R", R)):
            object.__setattr__(self, name, _freeze(value))
        self._hold_factors()

    def _hold_factors(self) -> None:
        """Factor the noise and prior covariances once, when the model is built.

        Sampling and the densities use these factors at every call (a particle
        filter: every step). The model cannot change after it is built (a frozen
        dataclass whose arrays are read-only), so the factors stay valid;
        ``dataclasses.replace(model, R=...)`` builds a new model, factored anew.

        * draws: L L^T = P0, (G L_Q)(G L_Q)^T = G Q G^T and L_R L_R^T = R, so that
          ``m0 + z L^T``, ``z (G L_Q)^T`` and ``z L_R^T`` (z ~ N(0, I), one row per
          draw) have the covariances P0, G Q G^T and R; these factors exist for a
          singular covariance too;
        * densities: the Cholesky factors of R and of G Q G^T and their inverses
          (None when the matrix is singular: there is no density, and the method
          that needs it raises).
        """
        held = {
            "_P0_factor": _noise_factor(self.P0),
            "_noise_gain_factor": self.G @ _noise_factor(self.Q),
            "_R_factor": _noise_factor(self.R),
            "_R_cholesky": _cholesky_or_none(self.R),
            "_GQGt_cholesky": _cholesky_or_none(self.G @ self.Q @ self.G.T),
        }
        for name in ("_R_cholesky", "_GQGt_cholesky"):
            L = held[name]
            held[name + "_inv"] = None if L is None else _lower_inverse(L)
        for name, value in held.items():
            object.__setattr__(self, name, value if value is None else _freeze(value))


# --------------------------------------------------------------------------
# Linear-Gaussian model (seed 000, section 2)
# --------------------------------------------------------------------------

@dataclass(frozen=True, eq=False)
class LinearGaussian(_ModelBase):
    r"""Linear-Gaussian state-space model (seed 000, section 2).

    .. math::

        x_{t+1} = A x_t + B u_t + G w_t,\quad w_t \sim N(0, Q);\qquad
        y_t = C x_t + v_t,\quad v_t \sim N(0, R);\qquad x_0 \sim N(m_0, P_0).

    Parameters
    ----------
    A : array_like, shape (n, n)
        Transition matrix (filterpy ``F``).
    C : array_like, shape (m, n)
        Measurement matrix (filterpy ``H``).
    Q : array_like, shape (q, q)
        Process-noise covariance, symmetric PSD.
    R : array_like, shape (m, m)
        Measurement-noise covariance, symmetric PSD.
    m0 : array_like, shape (n,)
        Prior mean of :math:`x_0` (seed 000's :math:`\mu_0`).
    P0 : array_like, shape (n, n)
        Prior covariance of :math:`x_0` (seed 000's :math:`\Sigma_0`).
    G : array_like, shape (n, q), optional
        Noise gain; identity (q = n) if omitted. filterpy has no G: give it
        ``Q = G Q G^T``.
    B : array_like, shape (n, p), optional
        Control-input matrix for a known input u (seed 002, filterpy ``B``).
    state_names : tuple of str, optional
        A name for each state component, in order.
    position_names : tuple of two str, optional
        Which two named components are planar positions (for plots).

    Raises
    ------
    ValueError
        If a matrix has the wrong shape or a non-finite entry, or Q, R or P0
        is not symmetric positive semi-definite (the message names it).

    Notes
    -----
    Every matrix is checked on construction (shape, finiteness, symmetry and
    positive semi-definiteness of Q, R, P0); the stored arrays are read-only,
    so a model cannot change after it is built
    (``dataclasses.replace(model, R=...)`` builds a new one).
    """

    A: np.ndarray
    C: np.ndarray
    Q: np.ndarray
    R: np.ndarray
    m0: np.ndarray
    P0: np.ndarray
    G: np.ndarray | None = None
    B: np.ndarray | None = None
    state_names: tuple[str, ...] | None = None
    position_names: tuple[str, str] | None = None

    def __post_init__(self):
        A = as_matrix("A", self.A, (None, None))
        if A.shape[0] != A.shape[1]:
            raise ValueError(f"A must be square (n, n), got shape {A.shape}")
        n = A.shape[0]
        C = as_matrix("C", self.C, (None, n))
        object.__setattr__(self, "A", _freeze(A))
        object.__setattr__(self, "C", _freeze(C))
        self._check_noise_and_prior(n)
        if self.R.shape[0] != C.shape[0]:
            raise ValueError(f"R must have shape ({C.shape[0]}, {C.shape[0]}) to match C's "
                             f"{C.shape[0]} rows, got shape {self.R.shape}")
        if self.B is not None:
            object.__setattr__(self, "B", _freeze(as_matrix("B", self.B, (n, None))))
        self._check_names(n)

    @property
    def control_dim(self) -> int:
        """Dimension p of the control input (0 without B)."""
        return 0 if self.B is None else self.B.shape[1]

    def transition_mean(self, xs, u=None, t: int = 0) -> np.ndarray:
        r"""Noise-free transition :math:`A x + B u` of each row of ``xs`` (N, n); ``t`` is unused."""
        batch, single = _as_states("xs", xs, self.state_dim)
        out = self._transition_mean(batch, u, t)
        return out[0] if single else out

    def _transition_mean(self, batch, u, t):
        # A x (+ B u) for a checked batch (N, n)
        out = batch @ self.A.T
        if u is not None:
            if self.B is None:
                raise ValueError("u was given but the model has no control matrix B")
            out = out + as_vector("u", u, self.control_dim) @ self.B.T
        return out

    def measurement_mean(self, xs) -> np.ndarray:
        r"""Noise-free measurement :math:`C x` of each row of ``xs`` (N, n)."""
        batch, single = _as_states("xs", xs, self.state_dim)
        out = self._measurement_mean(batch)
        return out[0] if single else out

    def _measurement_mean(self, batch):
        # C x for a checked batch (N, n)
        return batch @ self.C.T


# --------------------------------------------------------------------------
# Nonlinear-Gaussian model (seed 000, section 3, Kay's notation)
# --------------------------------------------------------------------------

@dataclass(frozen=True, eq=False)
class NonlinearGaussian(_ModelBase):
    r"""Nonlinear model with additive Gaussian noise (seed 000, section 3.1).

    .. math::

        x_{t+1} = f(x_t) + G w_t,\quad w_t \sim N(0, Q);\qquad
        y_t = h(x_t) + v_t,\quad v_t \sim N(0, R);\qquad x_0 \sim N(m_0, P_0).

    In Kay's notation of seed 000 this is :math:`s[n] = a(s[n-1]) + B u[n]`,
    :math:`x[n] = h(s[n]) + w[n]`: Kay's ``a`` is ``f``, his ``B`` is ``G``,
    his ``C[n]`` is ``R`` and his *measurement* is called x.

    Parameters
    ----------
    f, h : callable
        Transition and measurement functions. Each must map one state (n,)
        to (n,) resp. (m,), **and** a batch (N, n) to (N, n) resp. (N, m)
        row by row, so that a particle filter can move all particles at once.
    F, H : callable
        Their Jacobians, (n,) -> (n, n) and (n,) -> (m, n).
    Q, R, m0, P0, G
        As in :class:`LinearGaussian`.
    residual_fn : callable, optional
        ``residual_fn(y, y_pred)`` -> innovation, acting on the last axis
        (exposed as the method ``model.residual``);
        defaults to subtraction. An angle measurement needs wrapping
        (see :func:`range_bearing_residual`).
    time_varying : bool
        If True, the transition depends on the time index: ``f(x, t)`` and
        ``F(x, t)`` take the index t of the state they start from (the step
        :math:`x_t \to x_{t+1}`). Every filter and :func:`simulate` pass it.
    state_names, position_names
        As in :class:`LinearGaussian`.

    Raises
    ------
    ValueError
        If a matrix is invalid (as in :class:`LinearGaussian`), or a
        function returns the wrong shape or does not act row by row.
    TypeError
        If a function is not callable or ``time_varying`` is not a bool.

    Notes
    -----
    The functions are called once on construction, at ``m0`` and at a batch
    of two distinct states near it, to check the shapes they return and that
    ``f`` and ``h`` act row by row on a batch.
    """

    f: Callable
    F: Callable
    h: Callable
    H: Callable
    Q: np.ndarray
    R: np.ndarray
    m0: np.ndarray
    P0: np.ndarray
    G: np.ndarray | None = None
    residual_fn: Callable | None = field(default=None)
    time_varying: bool = False
    state_names: tuple[str, ...] | None = None
    position_names: tuple[str, str] | None = None

    def __post_init__(self):
        for name in ("f", "F", "h", "H"):
            check_callable(name, getattr(self, name))
        if self.residual_fn is not None:
            check_callable("residual_fn", self.residual_fn)
        m0 = as_vector("m0", self.m0)
        n = m0.shape[0]
        self._check_noise_and_prior(n)
        if not isinstance(self.time_varying, (bool, np.bool_)):
            raise TypeError(f"time_varying must be True or False, got {self.time_varying!r}")
        self._check_names(n)
        m = self.R.shape[0]
        h_size = np.shape(self.h(self.m0.copy()))
        if len(h_size) == 1 and h_size[0] != m:
            raise ValueError(f"R must be ({h_size[0]}, {h_size[0]}) to match the {h_size[0]} values "
                             f"h returns, got shape {self.R.shape}")
        f, F = self.transition_functions(0)
        # Two *distinct* states: with two copies of m0 (or n = 2), a function that
        # mixes rows or columns could still return the right shape.
        pair = np.stack([self.m0, self.m0 + 0.5 + np.arange(n)])
        for name, fun, size in (("f", f, n), ("h", self.h, m)):
            got = np.shape(fun(self.m0.copy()))
            if got != (size,):
                raise ValueError(f"{name} must map shape ({n},) to ({size},), got {got}")
            rows = np.asarray(fun(pair.copy()), dtype=float)
            if rows.shape != (2, size):
                raise ValueError(f"{name} must map shape (2, {n}) to (2, {size}) (it must act "
                                 f"row-wise on a batch of states), got {rows.shape}")
            one_by_one = np.stack([np.asarray(fun(row.copy()), dtype=float) for row in pair])
            if not np.allclose(rows, one_by_one, rtol=1e-9, atol=1e-12, equal_nan=True):
                raise ValueError(f"{name} must act row-wise on a batch of states (N, {n}): "
                                 f"{name}(xs)[i] differs from {name}(xs[i]); index the last axis, "
                                 f"e.g. x[..., 0], not x[0]")
        for name, fun, want in (("F", F, (n, n)), ("H", self.H, (m, n))):
            got = np.shape(fun(self.m0.copy()))
            if got != want:
                raise ValueError(f"Jacobian {name} must return shape {want} at m0, got {got}")

    def transition_functions(self, t: int = 0) -> tuple[Callable, Callable]:
        """``(f, F)`` of the step from time ``t`` to ``t + 1``, as functions of the state only.

        For a time-invariant model these are ``self.f`` and ``self.F``; for a
        time-varying one, ``f(x, t)`` and ``F(x, t)`` with ``t`` fixed.
        """
        if not self.time_varying:
            return self.f, self.F
        return (lambda x: self.f(x, t)), (lambda x: self.F(x, t))

    def transition_mean(self, xs, u=None, t: int = 0) -> np.ndarray:
        """:math:`f(x)` (or :math:`f(x, t)` for a time-varying model) of each row of ``xs``."""
        batch, single = _as_states("xs", xs, self.state_dim)
        out = self._transition_mean(batch, u, t)
        return out[0] if single else out

    def _transition_mean(self, batch, u, t):
        # f(x) for a checked batch (N, n); what the user function returns is checked
        if u is not None:
            raise ValueError("NonlinearGaussian takes no control input u")
        f, _ = self.transition_functions(t)
        return check_output("f", f(batch), batch.shape)

    def measurement_mean(self, xs) -> np.ndarray:
        """:math:`h(x)` of each row of ``xs``."""
        batch, single = _as_states("xs", xs, self.state_dim)
        out = self._measurement_mean(batch)
        return out[0] if single else out

    def _measurement_mean(self, batch):
        # h(x) for a checked batch (N, n); what the user function returns is checked
        return check_output("h", self.h(batch), (batch.shape[0], self.obs_dim))

    def residual(self, y, y_pred) -> np.ndarray:
        """Innovation: ``residual_fn(y, y_pred)`` if given, else ``y - y_pred``."""
        y, y_pred = np.asarray(y, float), np.asarray(y_pred, float)
        for name, a in (("y", y), ("y_pred", y_pred)):
            if a.ndim == 0 or a.shape[-1] != self.obs_dim:
                raise ValueError(f"{name} must have shape (..., {self.obs_dim}), got shape {a.shape}")
        if self.residual_fn is None:
            return super().residual(y, y_pred)
        shape = np.broadcast_shapes(y.shape, y_pred.shape)
        return check_output("residual_fn", self.residual_fn(y, y_pred), shape)


def to_nonlinear(model: LinearGaussian) -> NonlinearGaussian:
    """The same linear model written as a :class:`NonlinearGaussian` (f = A x, h = C x).

    Useful to check that an EKF reduces to the Kalman filter on a linear model.
    :class:`NonlinearGaussian` takes no control input, so a model with a
    control matrix B is refused rather than silently stripped of it.

    Parameters
    ----------
    model : LinearGaussian
        Without a control matrix B.

    Returns
    -------
    NonlinearGaussian
        With f(x) = A x, F(x) = A, h(x) = C x, H(x) = C and the same Q, R, G, m0, P0 and names.
    """
    if not isinstance(model, LinearGaussian):
        raise TypeError(f"model must be a LinearGaussian, got {type(model).__name__}")
    if model.B is not None:
        raise ValueError("model has a control matrix B, which NonlinearGaussian cannot carry; "
                         "build the model without B (u = 0) to compare with an EKF")
    A, C = model.A, model.C
    return NonlinearGaussian(f=lambda x: x @ A.T, F=lambda x: A.copy(),
                             h=lambda x: x @ C.T, H=lambda x: C.copy(),
                             Q=model.Q, R=model.R, m0=model.m0, P0=model.P0, G=model.G,
                             state_names=model.state_names, position_names=model.position_names)


# --------------------------------------------------------------------------
# Simulation
# --------------------------------------------------------------------------

class Simulation(NamedTuple):
    """A simulated run: ``xs`` (T, n) true states, ``ys`` (T, m) measurements."""

    xs: np.ndarray
    ys: np.ndarray


def simulate(model, T: int, rng: np.random.Generator, us=None, x0=None) -> Simulation:
    r"""Simulate states and measurements for ``T`` time steps.

    Seed 000's time convention: :math:`x_0 \sim N(m_0, P_0)` (or the given
    ``x0``), ``ys[0]`` measures :math:`x_0`, and row ``t`` of ``us`` drives
    the step from :math:`x_t` to :math:`x_{t+1}`.

    Parameters
    ----------
    model : LinearGaussian or NonlinearGaussian
    T : int
        Number of time steps (>= 1).
    rng : numpy.random.Generator
    us : array_like, shape (T - 1, p) or (T, p), optional
        Known inputs (needs ``model.B``); with T rows the last is unused.
    x0 : array_like, shape (n,), optional
        A fixed true initial state instead of a draw from the prior (e.g.
        the nominal start of Kay's vehicle, :data:`RANGE_BEARING_TRUE_START`).

    Returns
    -------
    Simulation
        ``xs`` (T, n) and ``ys`` (T, m).
    """
    if not isinstance(model, _ModelBase):
        raise TypeError(f"model must be a LinearGaussian or NonlinearGaussian, "
                        f"got {type(model).__name__}")
    T = as_int("T", T, minimum=1)
    rng = as_rng("rng", rng)
    n = model.state_dim
    us = as_inputs(model, us, T)
    xs = np.empty((T, n))
    xs[0] = model.sample_initial(rng, 1)[0] if x0 is None else as_vector("x0", x0, n)
    for t in range(T - 1):
        with np.errstate(over="ignore", invalid="ignore"):  # an overflow is reported just below
            xs[t + 1] = model.sample_transition(rng, xs[t], None if us is None else us[t], t=t)
        if not np.all(np.isfinite(xs[t + 1])):
            raise ValueError(f"the simulated state diverged (non-finite) at step t = {t + 1}: "
                             "check that the model is stable over T steps")
    ys = model.sample_measurement(rng, xs)
    return Simulation(xs, ys)


def simulate_many(model, M: int, T: int, rng: np.random.Generator, us=None, x0=None) -> Simulation:
    """``M`` independent runs of :func:`simulate`, stacked for a batched filter or a Monte Carlo study.

    Equal to ``M`` calls of :func:`simulate` with the same generator, one after
    the other, so the same seed gives the same runs either way.

    Parameters
    ----------
    model, T, rng, us, x0
        As in :func:`simulate`; ``us`` and ``x0`` are shared by all runs.
    M : int
        Number of runs (>= 1).

    Returns
    -------
    Simulation
        ``xs`` (M, T, n) and ``ys`` (M, T, m), ready for
        ``bf.kalman.batch_kalman_filter(model, ys)``.
    """
    M = as_int("M", M, minimum=1)
    runs = [simulate(model, T, rng, us=us, x0=x0) for _ in range(M)]
    return Simulation(np.stack([run.xs for run in runs]), np.stack([run.ys for run in runs]))


# --------------------------------------------------------------------------
# The seeds' examples
# --------------------------------------------------------------------------

def damped_particle(force_var: float = 0.01, meas_var: float = 1.0, damping: float = 0.98,
                    P0=None, B=None) -> LinearGaussian:
    r"""Seed 000's particle moving in the plane under random forces and damping.

    State :math:`x = [x^1, \dot x^1, x^2, \dot x^2]^T` (positions and
    velocities, unit time step; ``state_names = ("x1", "x1_dot", "x2",
    "x2_dot")``, seed 000's order); only the positions are measured:

    .. math::

        A = \begin{bmatrix}1&1&0&0\\0&0.98&0&0\\0&0&1&1\\0&0&0&0.98\end{bmatrix},\quad
        G = \begin{bmatrix}0&0\\1&0\\0&0\\0&1\end{bmatrix},\quad
        C = \begin{bmatrix}1&0&0&0\\0&0&1&0\end{bmatrix}.

    The seed leaves Q, R and the prior open; the course chooses
    ``Q = force_var * I2`` (a random force of standard deviation 0.1 per step),
    ``R = meas_var * I2`` (position noise of standard deviation 1),
    ``m0 = 0`` (the seed's :math:`\mu_0 = 0`) and ``P0 = I4``.

    Parameters
    ----------
    force_var, meas_var : float
        Variances of each force component and each position measurement.
    damping : float
        Velocity retained per step (0.98 in the seed).
    P0 : array_like, shape (4, 4), optional
        Prior covariance (default identity).
    B : array_like, shape (4, p), optional
        Control matrix for a known push, e.g. ``G`` to push on the velocities.
    """
    force_var = as_positive_float("force_var", force_var)
    meas_var = as_positive_float("meas_var", meas_var)
    damping = as_positive_float("damping", damping, allow_zero=True)
    A = np.array([[1.0, 1.0, 0.0, 0.0],
                  [0.0, damping, 0.0, 0.0],
                  [0.0, 0.0, 1.0, 1.0],
                  [0.0, 0.0, 0.0, damping]])
    G = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 0.0], [0.0, 1.0]])
    C = np.array([[1.0, 0.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0]])
    return LinearGaussian(A=A, C=C, Q=force_var * np.eye(2), R=meas_var * np.eye(2),
                          m0=np.zeros(4), P0=np.eye(4) if P0 is None else P0, G=G, B=B,
                          state_names=("x1", "x1_dot", "x2", "x2_dot"),
                          position_names=("x1", "x2"))


def wrap_angle(angle):
    r"""Wrap angles into :math:`(-\pi, \pi]` (element-wise).

    Parameters
    ----------
    angle : float or array_like
        Angles in radians, finite.

    Returns
    -------
    ndarray (same shape)
        :math:`\pi - ((\pi - a) \bmod 2\pi)`, so that :math:`\pi` maps to
        :math:`\pi` and :math:`-\pi` to :math:`\pi`. Every value lies in
        :math:`(-\pi, \pi]`, also where rounding would give :math:`-\pi`
        (one ulp above :math:`\pi`, the mod rounds up to :math:`2\pi`): such a
        value is returned as :math:`\pi`, the same angle.
    """
    return _wrap(as_array("angle", angle))


def _wrap(angle: np.ndarray) -> np.ndarray:
    # pi - ((pi - a) mod 2 pi), in [-pi, pi]: (pi - a) mod 2 pi can round up to 2 pi
    # itself (for pi - a a tiny negative number, a one ulp above pi)
    out = np.pi - np.mod(np.pi - angle, 2.0 * np.pi)
    # -pi and pi are the same angle: keep the end of (-pi, pi] the docstring promises
    # ([()] keeps a scalar a scalar)
    return np.where(out <= -np.pi, np.pi, out)[()]


def range_bearing_residual(y, y_pred) -> np.ndarray:
    """Range-bearing innovation: plain difference for the range, wrapped for the bearing.

    Parameters
    ----------
    y, y_pred : array_like, shape (..., 2)
        Measured and predicted (range, bearing) pairs; leading axes broadcast.

    Returns
    -------
    ndarray, shape (..., 2)
        ``y - y_pred`` with the bearing difference wrapped into (-pi, pi].
    """
    y, y_pred = as_array("y", y), as_array("y_pred", y_pred)
    for name, a in (("y", y), ("y_pred", y_pred)):
        if a.ndim == 0 or a.shape[-1] != 2:
            raise ValueError(f"{name} must have shape (..., 2) (range, bearing), got shape {a.shape}")
    return _range_bearing_residual(y, y_pred)


def _range_bearing_residual(y: np.ndarray, y_pred: np.ndarray) -> np.ndarray:
    """:func:`range_bearing_residual` of checked arrays: the model's residual_fn, called every
    step on every particle (its output is checked by NonlinearGaussian.residual)."""
    r = y - y_pred
    # the bearing difference is an angle: wrap it into (-pi, pi]
    r[..., 1] = _wrap(r[..., 1])
    return r


#: Kay's nominal start: xi_x = 10 - 0.2 n, xi_y = -5 + 0.2 n.
RANGE_BEARING_TRUE_START = np.array([10.0, -5.0, -0.2, 0.2])
RANGE_BEARING_TRUE_START.setflags(write=False)


def range_bearing(velocity_var: float = 1e-4, range_var: float = 0.1, bearing_var: float = 0.01,
                  m0=(5.0, 5.0, 0.0, 0.0), prior_var: float = 100.0) -> NonlinearGaussian:
    r"""Kay's vehicle tracked by range and bearing (Example 13.4, seed 000 section 3.1).

    State :math:`[\xi_x, \xi_y, \dot\xi_x, \dot\xi_y]` (Kay's order; ``state_names =
    ("xi_x", "xi_y", "xi_x_dot", "xi_y_dot")``; Kay writes them :math:`r_x, r_y, v_x, v_y`),
    constant velocity with unit time step
    and process noise on the velocities only; the sensor at the origin
    measures

    .. math::

        \rho = \sqrt{\xi_x^2 + \xi_y^2},\qquad \beta = \operatorname{atan2}(\xi_y, \xi_x).

    Erratum (seed 000): the seed writes :math:`\beta = \arctan(r_y / r_x)`,
    which loses the quadrant once :math:`r_x < 0` (the course's :math:`\xi_x`); ``atan2`` does
    not, and the bearing innovation is wrapped into :math:`(-\pi, \pi]`.

    The filter prior is Example 13.4's numbers, ``m0 = [5, 5, 0, 0]``,
    ``P0 = 100 I``, applied at n = 0 (the course's x_0, measured by y_0).
    Kay applies them one step earlier, to :math:`\hat s[-1|-1]`,
    :math:`M[-1|-1]`, and predicts once; the exact equivalent at n = 0 is
    ``m0`` unchanged (zero velocity) and ``P0 = A (100 I) A^T + G Q G^T``
    (chapter 04). The true vehicle starts at :data:`RANGE_BEARING_TRUE_START`
    (pass it as ``x0`` to :func:`simulate`).

    Parameters
    ----------
    velocity_var : float
        Variance of the random change of each velocity per step (Kay: 1e-4).
    range_var, bearing_var : float
        Measurement-noise variances of the range (m^2) and bearing (rad^2).
    m0 : array_like, shape (4,)
        Filter prior mean.
    prior_var : float
        Filter prior variance of every state component (``P0 = prior_var I``).

    Returns
    -------
    NonlinearGaussian
        Its ``residual_fn`` is :func:`range_bearing_residual` without the input checks
        (``NonlinearGaussian.residual`` checks the shapes and the output).
    """
    velocity_var = as_positive_float("velocity_var", velocity_var)
    range_var = as_positive_float("range_var", range_var)
    bearing_var = as_positive_float("bearing_var", bearing_var)
    prior_var = as_positive_float("prior_var", prior_var)
    m0 = as_vector("m0", m0, 4)
    A = np.array([[1.0, 0.0, 1.0, 0.0],
                  [0.0, 1.0, 0.0, 1.0],
                  [0.0, 0.0, 1.0, 0.0],
                  [0.0, 0.0, 0.0, 1.0]])
    G = np.array([[0.0, 0.0], [0.0, 0.0], [1.0, 0.0], [0.0, 1.0]])

    def f(x):
        return x @ A.T

    def F(x):
        return A.copy()

    def h(x):
        x = np.asarray(x, dtype=float)
        rx, ry = x[..., 0], x[..., 1]
        return np.stack([np.hypot(rx, ry), np.arctan2(ry, rx)], axis=-1)

    def H(x):
        rx, ry = float(x[0]), float(x[1])
        r2 = rx * rx + ry * ry
        if r2 == 0.0:
            raise ValueError("range-bearing Jacobian H is undefined at the sensor (xi_x = xi_y = 0)")
        r = np.sqrt(r2)
        return np.array([[rx / r, ry / r, 0.0, 0.0],
                         [-ry / r2, rx / r2, 0.0, 0.0]])

    return NonlinearGaussian(f=f, F=F, h=h, H=H, Q=velocity_var * np.eye(2),
                             R=np.diag([range_var, bearing_var]),
                             m0=m0, P0=prior_var * np.eye(4), G=G,
                             residual_fn=_range_bearing_residual,
                             state_names=("xi_x", "xi_y", "xi_x_dot", "xi_y_dot"),
                             position_names=("xi_x", "xi_y"))


def positions(model, xs) -> np.ndarray:
    """The two planar position components of states ``xs`` (..., n), selected by name.

    ``positions(model, xs)`` is ``xs[..., model.index_of(*model.position_names)]``:
    columns 0 and 2 for the damped particle ``[x1, x1_dot, x2, x2_dot]``,
    columns 0 and 1 for the vehicle ``[xi_x, xi_y, xi_x_dot, xi_y_dot]``.

    Parameters
    ----------
    model : LinearGaussian or NonlinearGaussian
        A model with ``state_names`` and ``position_names``.
    xs : array_like, shape (..., n)
        States, or differences of states (estimation errors).

    Returns
    -------
    ndarray, shape (..., 2)
    """
    if getattr(model, "position_names", None) is None:
        raise ValueError(f"model ({type(model).__name__}) has no position_names; give the model "
                         "state_names and position_names, or select the columns yourself")
    xs = as_array("xs", xs)
    if xs.ndim == 0 or xs.shape[-1] != model.state_dim:
        raise ValueError(f"xs must have shape (..., {model.state_dim}) (full states "
                         f"{list(model.state_names)}), got shape {xs.shape}")
    return xs[..., model.index_of(*model.position_names)]


# --------------------------------------------------------------------------
# The particle-filter benchmark (chapters 05-06)
# --------------------------------------------------------------------------

def ungm(process_var: float = 10.0, meas_var: float = 1.0, prior_var: float = 5.0,
         m0: float = 0.0) -> NonlinearGaussian:
    r"""The univariate nonstationary growth model (UNGM), the particle filter's classic benchmark.

    Gordon, Salmond & Smith (1993), used as the example of Arulampalam et al.
    (2002), section VI (seed 001's source):

    .. math::

        x_{t+1} = \frac{x_t}{2} + \frac{25\, x_t}{1 + x_t^2} + 8 \cos(1.2\,(t+1)) + w_t,
        \qquad w_t \sim N(0, 10),

        y_t = \frac{x_t^2}{20} + v_t,\qquad v_t \sim N(0, 1).

    The measurement depends on :math:`x_t^2`, so it cannot tell :math:`x_t`
    from :math:`-x_t`: the posterior is often bimodal, which is what an EKF
    (one Gaussian) cannot represent.

    **Choices (reproductions differ).** Arulampalam et al. write
    :math:`8\cos(1.2k)` in the equation for :math:`x_k`, so the cosine carries
    the index of the *new* state; the course keeps that:
    ``f(x, t)`` for the step :math:`x_t \to x_{t+1}` uses
    :math:`\cos(1.2(t+1))`. Others use the index of the old state (e.g.
    RcppSMC's ``pfNonlinBS``: :math:`8\cos(1.2(n-1))` in the equation for
    :math:`x(n)`). Reproductions differ on the prior too (the example that
    accompanies D. Simon's *Optimal State Estimation* starts from x = 0.1
    with variance 2); the course takes :math:`x_0 \sim N(0, 5)`
    (``prior_var``), and, by seed 000's time
    convention, ``ys[0]`` already measures :math:`x_0` (the paper's first
    measurement is :math:`z_1`).

    Parameters
    ----------
    process_var, meas_var : float
        Variances of :math:`w_t` (10) and :math:`v_t` (1).
    prior_var : float
        Variance of the prior of :math:`x_0`.
    m0 : float
        Mean of the prior of :math:`x_0`.

    Returns
    -------
    NonlinearGaussian
        With ``time_varying=True``: ``f(x, t)`` and ``F(x, t)``.
    """
    process_var = as_positive_float("process_var", process_var)
    meas_var = as_positive_float("meas_var", meas_var)
    prior_var = as_positive_float("prior_var", prior_var)
    m0 = as_vector("m0", m0, 1)

    def f(x, t):
        x = np.asarray(x, dtype=float)
        # x_{t+1} = x_t / 2 + 25 x_t / (1 + x_t^2) + 8 cos(1.2 (t + 1))
        return 0.5 * x + 25.0 * x / (1.0 + x * x) + 8.0 * np.cos(1.2 * (t + 1))

    def F(x, t):
        x = float(np.asarray(x, dtype=float).reshape(-1)[0])
        # d/dx [x/2 + 25 x / (1 + x^2)] = 1/2 + 25 (1 - x^2) / (1 + x^2)^2
        return np.array([[0.5 + 25.0 * (1.0 - x * x) / (1.0 + x * x) ** 2]])

    def h(x):
        x = np.asarray(x, dtype=float)
        # y = x^2 / 20
        return x * x / 20.0

    def H(x):
        return np.array([[float(np.asarray(x, dtype=float).reshape(-1)[0]) / 10.0]])

    return NonlinearGaussian(f=f, F=F, h=h, H=H, Q=[[process_var]], R=[[meas_var]],
                             m0=m0, P0=[[prior_var]], time_varying=True, state_names=("x",))
