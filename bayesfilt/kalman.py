r"""Kalman filter (seed 000, section 2): exact Bayesian filtering for linear-Gaussian models.

For the model of :class:`bayesfilt.models.LinearGaussian`,

.. math::

    x_{t+1} = A x_t + B u_t + G w_t,\quad w_t \sim N(0, Q);\qquad
    y_t = C x_t + v_t,\quad v_t \sim N(0, R);\qquad x_0 \sim N(m_0, P_0),

every belief of the Bayes recursion is Gaussian, and the filter only has to
carry a mean and a covariance. Two steps alternate (seed 000, "Dynamic
update", "Measurement update", "Kalman gain"):

* prediction (예측): :math:`\hat x_{t+1|t} = A \hat x_{t|t} + B u_t`,
  :math:`P_{t+1|t} = A P_{t|t} A^T + G Q G^T`;
* measurement update (측정 업데이트): with the innovation
  :math:`r = y - C\hat x_{t|t-1}`, its covariance :math:`S = C P C^T + R` and
  the gain :math:`K = P C^T S^{-1}`, :math:`\hat x_{t|t} = \hat x_{t|t-1} + K r`
  and :math:`P_{t|t} = (I - KC) P (I - KC)^T + K R K^T`.

Import it as ``bf.kalman``::

    import numpy as np
    import bayesfilt as bf

    model = bf.models.damped_particle()
    xs, ys = bf.models.simulate(model, 200, np.random.default_rng(0))

    # one step at a time: ys[0] measures x_0 ~ N(m0, P0) (seed 000's time convention)
    step = bf.kalman.update(model.m0, model.P0, ys[0], model.C, model.R)
    x, P = bf.kalman.predict(step.mean, step.cov, model.A, model.Q, G=model.G)
    step = bf.kalman.update(x, P, ys[1], model.C, model.R)   # step.mean, step.loglik, ...

    # ... or a whole run
    res = bf.kalman.kalman_filter(model, ys)
    res.means, res.covs, res.loglik          # (T, n), (T, n, n), float

    # many runs of the same model at once: (M, T, m) -> every field gets an M axis
    rng = np.random.default_rng(1)
    ys_many = np.stack([bf.models.simulate(model, 200, rng).ys for _ in range(500)])
    res_m = bf.kalman.batch_kalman_filter(model, ys_many)   # res_m.means (500, 200, 4)

    # the covariance and gain the filter settles to
    ss = bf.kalman.steady_state(model)       # pred_cov, cov, gain

Missing measurements are NaN. A row of ``ys`` that is entirely NaN is a
missing measurement: the filter only predicts through it. A row with some
NaN components is a partial measurement (two sensors, one of which drops
out): the update uses the observed components only, i.e. the rows of C and
the rows and columns of R that they select, because the marginal of the
observed components :math:`y_{t,o}` given :math:`x_t` is
:math:`N(C_o x_t, R_{oo})` (:func:`select_observed`). The results keep
their full shapes (see :class:`FilterResult` for what a missing component
records)::

    ys_gap = ys.copy()
    ys_gap[50:70, 1] = np.nan                 # the second sensor drops out
    res = bf.kalman.kalman_filter(model, ys_gap)
    res.observed_components[50]               # array([ True, False])

The whole-run filter is the two steps in a plain loop, over the same
kernels that :func:`predict` and :func:`update` use: ``kalman_filter``
gives bit for bit the numbers of the single steps called in a loop.

Numerics. S is never inverted. In :func:`update`, :func:`kalman_filter`
and the EKF, S is factorised by Cholesky and the gain is obtained by
solving :math:`S K^T = C P` with that factor (one LAPACK ``dposv`` call).
:func:`batch_kalman_filter` factorises its stack of S by Cholesky too (the
factor gives the singularity test and the log-likelihoods), but obtains
the gains by an LU solve of :math:`S K^T = C P` (``numpy.linalg.solve``,
LAPACK ``dgesv``, vectorised over the stack): the two agree to rounding,
not bit for bit. Every predicted and updated covariance is symmetrised
after it is computed, so it is exactly symmetric. The covariance update
uses the Joseph form, which is, in exact arithmetic, positive
semi-definite for any gain. In floating point it
avoids the cancellation of the textbook :math:`P - KCP`, so it stays
positive semi-definite to rounding where that form goes indefinite, but it
is not a proof of positive semi-definiteness under rounding (see
:func:`update`).

Time convention (seed 000): ``ys[0]`` measures :math:`x_0 \sim N(m_0, P_0)`,
so ``pred_means[0] = m0``, ``pred_covs[0] = P0`` and ``means[t]`` is
:math:`E[x_t \mid y_0, \dots, y_t]`.

filterpy map (``filterpy.kalman.KalmanFilter``): ``A`` = ``F``, ``C`` =
``H``, ``R`` = ``R``, ``B`` = ``B``, ``m0``/``P0`` = initial ``x``/``P``,
and filterpy has no ``G``: its ``Q`` is the course's :math:`G Q G^T`.
filterpy's usual loop calls ``predict()`` then ``update()``; to reproduce
:func:`kalman_filter` start it at ``x = m0, P = P0``, call ``update(ys[0])``
first, then ``predict(); update(ys[t])`` for t = 1, 2, ...
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from scipy import linalg as sla
from scipy.linalg.lapack import dposv as _dposv
from scipy.linalg.lapack import dtrtrs as _dtrtrs

from ._checks import (as_array, as_covariance, as_inputs, as_matrix, as_noise_gain, as_square,
                      as_vector, observation_masks, require_finite)
from .gaussian import LOG_2PI, _logpdf_rows
from .models import LinearGaussian

__all__ = [
    "Prediction",
    "Update",
    "FilterResult",
    "SteadyState",
    "ObservedPart",
    "predict",
    "update",
    "kalman_filter",
    "batch_kalman_filter",
    "steady_state",
    "select_observed",
]

class Prediction(NamedTuple):
    """Predicted Gaussian: ``mean`` (n,) and ``cov`` (n, n). Unpacks as ``x, P``."""

    mean: np.ndarray
    cov: np.ndarray


class Update(NamedTuple):
    """Result of a measurement update.

    mean : (n,) posterior mean; cov : (n, n) posterior covariance;
    gain : (n, m) Kalman gain K; innovation : (m,) y - C x (or residual(y, h(x)));
    innovation_cov : (m, m) S = C P C^T + R; loglik : float, log N(innovation; 0, S).
    """

    mean: np.ndarray
    cov: np.ndarray
    gain: np.ndarray
    innovation: np.ndarray
    innovation_cov: np.ndarray
    loglik: float


class FilterResult(NamedTuple):
    """Output of a filter run over T steps (a leading batch axis M when batched).

    means (T, n) = E[x_t | y_0..y_t]; covs (T, n, n);
    pred_means (T, n) = E[x_t | y_0..y_{t-1}] (pred_means[0] = m0); pred_covs (T, n, n);
    innovations (T, m): r_t, NaN in every component that was not observed;
    innovation_covs (T, m, m): S_t, NaN in the rows and columns of the components
    that were not observed (all NaN on a missing row);
    gains (T, n, m): K_t, zero in the columns of the components that were not
    observed (all zero on a missing row), so that x_{t|t} = x_{t|t-1} + K_t r_t
    (with any value for the missing entries of r_t) and I - K_t C still hold
    with the full C;
    step_logliks (T,): log N(r_t; 0, S_t) of the observed components, 0 on missing rows;
    loglik: their sum, log p(observed y_0..y_{T-1});
    observed (T,) bool: True where at least one component of the row of ys was
    measured, False where the row was all NaN (only predicted);
    observed_components (T, m) bool: which components were measured (not NaN).
    A row is partly observed where ``observed`` is True and
    ``observed_components`` is not all True. (None in a result built without it.)
    """

    means: np.ndarray
    covs: np.ndarray
    pred_means: np.ndarray
    pred_covs: np.ndarray
    innovations: np.ndarray
    innovation_covs: np.ndarray
    gains: np.ndarray
    step_logliks: np.ndarray
    loglik: float | np.ndarray
    observed: np.ndarray
    observed_components: np.ndarray | None = None


class ObservedPart(NamedTuple):
    """The observed components of one measurement (see :func:`select_observed`).

    mask (m,) bool; y (k,) the observed values; C (k, n) the rows of C (or of a
    Jacobian H) they select; R (k, k) the rows and columns of R they select.
    """

    mask: np.ndarray
    y: np.ndarray
    C: np.ndarray
    R: np.ndarray


class SteadyState(NamedTuple):
    """Limits of the covariance recursion (see :func:`steady_state`).

    pred_cov (n, n): limit of the predicted covariance P_{t|t-1};
    cov (n, n): limit of the filtered covariance P_{t|t};
    gain (n, m): limit of the Kalman gain K_t.
    """

    pred_cov: np.ndarray
    cov: np.ndarray
    gain: np.ndarray


# --------------------------------------------------------------------------
# The two step kernels, unchecked: predict and update validate their arguments
# and call them; the filters validate once and call them every step.
# --------------------------------------------------------------------------

_EPS = np.finfo(float).eps
S_NOT_PD = ("innovation covariance S = C P C^T + R (H P H^T + R in the EKF) is singular or not "
            "positive definite: R needs a positive variance on every measurement component, "
            "or C P C^T must make up for it")
S_OVERFLOW = ("innovation covariance S = C P C^T + R overflowed to a non-finite value; "
              "the model or the data are too large for floating point")


def _predict(x, P, A, GQGt, Bu=None):
    """Prediction for a mean x (n,) or M means (M, n), and P (n, n) or a stack (D, n, n)."""
    # x_{t+1|t} = A x_{t|t} + B u_t   (written for row vectors, so that it also moves M means)
    x = x @ A.T
    if Bu is not None:
        x = x + Bu
    # P_{t+1|t} = A P_{t|t} A^T + G Q G^T
    P = A @ P @ A.T + GQGt
    # rounding leaves the sum slightly asymmetric; make it exactly symmetric
    # (.mT transposes a matrix, or each matrix of a stack)
    return x, 0.5 * (P + P.mT)


def _gain_and_joseph(P, C, R, eye_n):
    """Gain and Joseph-form covariance of a measurement update, for P (n, n) or a stack (D, n, n).

    The one place the update's covariance algebra is written: the single step,
    both filters and the EKF (with C = H) call it.
    Returns K (..., n, m), S (..., m, m), L (..., m, m) whose lower triangle is the
    Cholesky factor of S (for one P the upper triangle holds S's, not zeros), and P_post.
    Raises ValueError if S overflowed or is not safely positive definite.
    """
    PCt = P @ C.T
    # S = C P C^T + R
    S = C @ PCt + R
    if P.ndim == 2:
        # S = L L^T and S K^T = C P (so K = P C^T S^{-1}) in one LAPACK call, dposv:
        # a solve with the Cholesky factor, never an inverse of S
        L, Kt, info = _dposv(S, PCt.T, lower=1)
    else:
        try:
            L, info = np.linalg.cholesky(S), 0
        except np.linalg.LinAlgError:
            L, info = S, 1
        else:
            # K = P C^T S^{-1}: solve S K^T = C P
            Kt = np.linalg.solve(S, PCt.mT)
    # The pivot L_ii^2 is the variance of measurement component i given the components
    # before it. S is numerically singular when that is at the rounding level of S_ii
    # itself. Each pivot is compared with its own diagonal entry, not with the largest
    # one, so that components measured in very different units are not rejected.
    # Written as "every pivot is safely positive", so that a NaN fails it too.
    safe = L.diagonal(0, -2, -1) ** 2 > S.shape[-1] * _EPS * S.diagonal(0, -2, -1)
    if info != 0 or not safe.all():
        # The factorisation reads the lower triangle of S, and a NaN or inf there makes
        # it fail or leaves a NaN or inf pivot: an overflow is always caught here.
        raise ValueError(S_NOT_PD if np.isfinite(S).all() else S_OVERFLOW)
    K = Kt.mT
    IKC = eye_n - K @ C
    # P_{t|t} = (I - K C) P (I - K C)^T + K R K^T   (Joseph form, see update)
    P_post = IKC @ P @ IKC.mT + K @ R @ Kt
    return K, S, L, 0.5 * (P_post + P_post.mT)


def _correct(x, P, r, C, R, eye_n):
    """Measurement update of one mean x (n,) given its innovation r (m,).

    Shared with the EKF, where C is the Jacobian H and r may come from a residual
    function. Returns x_post, P_post, K, r, S and loglik = log N(r; 0, S) (a float).
    """
    K, S, L, P_post = _gain_and_joseph(P, C, R, eye_n)
    # x_{t|t} = x_{t|t-1} + K r
    x_post = x + K @ r
    # log N(r; 0, S) = -(z^T z + log det S + m log 2 pi) / 2 with the Cholesky factor
    # S = L L^T already at hand: z = L^{-1} r (a triangular solve, LAPACK dtrtrs) and
    # log det S = 2 sum_i log L_ii
    z = _dtrtrs(L, r, lower=1)[0]
    loglik = -0.5 * float(z @ z + 2.0 * np.log(L.diagonal()).sum() + r.shape[0] * LOG_2PI)
    return x_post, P_post, K, r, S, loglik


def _select(o, C, R):
    """The rows of C and the block of R of the observed components o (m,) bool."""
    # y_o = C_o x + v_o with v_o ~ N(0, R_oo): the marginal of the observed components
    return C[o], R[np.ix_(o, o)]


def _embed(o, K, r, S):
    """Full-shape gain (n, m), innovation (m,) and S (m, m) from those of the components o.

    The columns of K of the unobserved components are zero (they move nothing);
    their entries of r and their rows and columns of S are NaN (there is no value).
    """
    m = o.shape[0]
    K_full = np.zeros(K.shape[:-1] + (m,))
    K_full[..., o] = K
    r_full = np.full(r.shape[:-1] + (m,), np.nan)
    r_full[..., o] = r
    i = np.flatnonzero(o)
    S_full = np.full(S.shape[:-2] + (m, m), np.nan)
    S_full[..., i[:, None], i] = S
    return K_full, r_full, S_full


def select_observed(y, C, R) -> ObservedPart:
    r"""The observed components of a measurement with missing (NaN) entries.

    If :math:`y = C x + v`, :math:`v \sim N(0, R)`, the components
    :math:`o` that were observed satisfy :math:`y_o = C_o x + v_o`,
    :math:`v_o \sim N(0, R_{oo})`: the rows of C and the rows and columns
    of R that :math:`o` selects (a marginal of a Gaussian keeps its
    sub-vector and sub-block). An update with a partly-missing measurement
    is an ordinary update with :math:`(y_o, C_o, R_{oo})`; the filters of
    :mod:`bayesfilt` do this on every partly-NaN row. For an EKF pass the
    Jacobian H (evaluated at the prediction) as ``C``.

    Parameters
    ----------
    y : array_like, shape (m,)
        Measurement, NaN where a component is missing.
    C : array_like, shape (m, n)
        Measurement matrix (or Jacobian H).
    R : array_like, shape (m, m)
        Measurement-noise covariance.

    Returns
    -------
    ObservedPart
        ``mask`` (m,) bool, ``y`` (k,), ``C`` (k, n) and ``R`` (k, k), with
        k the number of observed components (0 if y is all NaN).

    Raises
    ------
    ValueError
        On wrong shapes, or an inf in ``y``.
    """
    y = as_vector("y", y, finite=False)
    m = y.shape[0]
    C = as_matrix("C", C, (m, None))
    R = as_covariance("R", R, m)
    if np.isinf(y).any():
        raise ValueError(f"y must be finite or NaN (missing), got inf at index "
                         f"{int(np.flatnonzero(np.isinf(y))[0])}")
    o = ~np.isnan(y)
    return ObservedPart(o, y[o], *_select(o, C, R))


# --------------------------------------------------------------------------
# One step
# --------------------------------------------------------------------------

def predict(x, P, A, Q, G=None, B=None, u=None) -> Prediction:
    r"""Prediction (dynamic update) of seed 000, section 2.

    .. math::

        \hat x_{t+1|t} = A \hat x_{t|t} + B u_t, \qquad
        P_{t+1|t} = A P_{t|t} A^T + G Q G^T.

    Parameters
    ----------
    x : array_like, shape (n,)
        Filtered mean :math:`\hat x_{t|t}`.
    P : array_like, shape (n, n)
        Filtered covariance :math:`P_{t|t}`, symmetric PSD.
    A : array_like, shape (n, n)
        Transition matrix (filterpy ``F``).
    Q : array_like, shape (q, q)
        Process-noise covariance, symmetric PSD.
    G : array_like, shape (n, q), optional
        Noise gain; identity if omitted (then q = n). filterpy's ``Q`` is
        :math:`G Q G^T`.
    B : array_like, shape (n, p), optional
        Control matrix; needed if ``u`` is given.
    u : array_like, shape (p,), optional
        Known input acting from t to t + 1.

    Returns
    -------
    Prediction
        ``mean`` (n,) and ``cov`` (n, n) (symmetrised).
    """
    x = as_vector("x", x)
    n = x.shape[0]
    P = as_covariance("P", P, n)
    A = as_square("A", A, n)
    Q = as_covariance("Q", Q)
    G = as_noise_gain(G, n, Q.shape[0])
    Bu = None
    if u is not None:
        if B is None:
            raise ValueError("u was given but B (the control matrix) is None")
        B = as_matrix("B", B, (n, None))
        Bu = B @ as_vector("u", u, B.shape[1])
    elif B is not None:
        as_matrix("B", B, (n, None))
    with np.errstate(over="ignore", invalid="ignore"):  # an overflow is reported just below
        mean, cov = _predict(x, P, A, G @ Q @ G.T, Bu)
    require_finite("kalman.predict", "mean", mean)
    require_finite("kalman.predict", "cov", cov)
    return Prediction(mean, cov)


def update(x, P, y, C, R) -> Update:
    r"""Measurement update of seed 000, section 2, with the Joseph-form covariance.

    .. math::

        r = y - C \hat x, \quad S = C P C^T + R, \quad K = P C^T S^{-1},

        \hat x^+ = \hat x + K r, \qquad
        P^+ = (I - K C) P (I - K C)^T + K R K^T.

    Why not the seed's :math:`P^+ = P - K C P`? In exact arithmetic the two
    agree for the optimal gain K. What the Joseph form does guarantee:

    * *Symmetry*, exactly: the result is symmetrised after it is computed
      (:math:`(P^+ + P^{+T})/2`).
    * *Positive semi-definiteness in exact arithmetic, for any gain K*: it
      is a sum of two PSD terms, :math:`(I-KC)P(I-KC)^T` and :math:`KRK^T`.
      It is also the correct covariance of the updated estimate for any K,
      not only the optimal one, so a small error in K costs only a
      second-order error in P.
    * *In floating point*, it avoids the cancellation of :math:`P - KCP`, a
      *difference* of two PSD matrices that nearly cancel when the
      measurement is precise. So it stays positive semi-definite to rounding
      in cases where the simple form goes indefinite or loses a small
      variance altogether (with :math:`P = 10^{12} I` and :math:`R = 10^{-6}`,
      :math:`P - KCP` gives the measured component variance 0; the Joseph
      form keeps its :math:`10^{-6}`). It is not a proof of positive
      semi-definiteness under rounding: its products are rounded too, and a
      nearly singular P can still come out with an eigenvalue slightly
      below zero. (A square-root filter, which carries a factor of P, is the
      remedy when that matters.)

    filterpy uses the Joseph form too.

    S is factorised by Cholesky and the gain is obtained by solving
    :math:`S K^T = C P`, never by inverting S. S is rejected as singular
    when a pivot of its factor is at the rounding level of its own diagonal
    entry, :math:`L_{ii}^2 \le m\,\epsilon\,S_{ii}`, a test that does
    not depend on the units of the measurement components.

    Parameters
    ----------
    x : array_like, shape (n,)
        Predicted mean :math:`\hat x_{t|t-1}`.
    P : array_like, shape (n, n)
        Predicted covariance :math:`P_{t|t-1}`, symmetric PSD.
    y : array_like, shape (m,)
        Measurement (finite).
    C : array_like, shape (m, n)
        Measurement matrix (filterpy ``H``).
    R : array_like, shape (m, m)
        Measurement-noise covariance, symmetric PSD.

    Returns
    -------
    Update
        ``mean`` (n,), ``cov`` (n, n), ``gain`` (n, m), ``innovation`` (m,),
        ``innovation_cov`` (m, m) and ``loglik`` :math:`\log N(r; 0, S)`,
        the log-density of this measurement given the past ones.

    Raises
    ------
    ValueError
        On wrong shapes or non-finite entries, or if S is not positive
        definite.
    """
    x = as_vector("x", x)
    n = x.shape[0]
    P = as_covariance("P", P, n)
    C = as_matrix("C", C, (None, n))
    m = C.shape[0]
    y = as_vector("y", y, m)
    R = as_covariance("R", R, m)
    with np.errstate(over="ignore", invalid="ignore"):  # an overflow is reported just below
        try:
            # r = y - C x   (innovation)
            out = Update(*_correct(x, P, y - C @ x, C, R, np.eye(n)))
        except ValueError as exc:
            raise ValueError(f"kalman.update: {exc}") from None
    for what in ("mean", "cov", "loglik"):
        require_finite("kalman.update", what, getattr(out, what))
    return out


# --------------------------------------------------------------------------
# Whole runs
# --------------------------------------------------------------------------

def _check_model(model) -> None:
    if not isinstance(model, LinearGaussian):
        raise TypeError(f"model must be a bayesfilt.models.LinearGaussian, got "
                        f"{type(model).__name__} (use bf.ekf for a NonlinearGaussian)")


def _check_inputs(model: LinearGaussian, us, T: int, batch: int | None):
    """The validated inputs u_0..u_{T-2}, (T-1, p) or (M, T-1, p), or None."""
    if us is None or batch is None or np.ndim(us) == 2:   # one input record for all runs
        return as_inputs(model, us, T)
    if model.B is None:
        raise ValueError("us was given but the model has no control matrix B")
    p = model.control_dim
    a = as_array("us", us)
    if a.ndim != 3 or a.shape[0] != batch or a.shape[2] != p:
        raise ValueError(f"us must have shape (T - 1, {p}) shared by all sequences or "
                         f"({batch}, T - 1, {p}), got shape {a.shape}")
    if a.shape[1] not in (T - 1, T):
        raise ValueError(f"us must have T - 1 = {T - 1} (or T = {T}) rows, got {a.shape[1]}")
    return a[:, : T - 1]


def _as_ys(ys, m: int, batched: bool) -> np.ndarray:
    a = as_array("ys", ys, finite=False)
    if batched:
        if a.ndim == 2 and m == 1:
            a = a[..., None]
        if a.ndim != 3 or a.shape[2] != m:
            raise ValueError(f"ys must have shape (M, T, {m}), got shape {a.shape}")
        if a.shape[0] < 1 or a.shape[1] < 1:
            raise ValueError(f"ys needs M >= 1 sequences and T >= 1 steps, got shape {a.shape}")
    else:
        if a.ndim == 1 and m == 1:
            a = a[:, None]
        if a.ndim != 2 or a.shape[1] != m:
            raise ValueError(f"ys must have shape (T, {m}), got shape {a.shape}")
        if a.shape[0] < 1:
            raise ValueError("ys must have at least one row (T >= 1)")
    return a


def kalman_filter(model: LinearGaussian, ys, us=None) -> FilterResult:
    r"""Run the Kalman filter of seed 000 over a whole sequence of measurements.

    For t = 0, ..., T-1: predict from t-1 to t (skipped at t = 0, where the
    prediction is the prior :math:`N(m_0, P_0)`), then update with
    ``ys[t]``. A row that is missing (all NaN) is not used: the filtered
    belief is the prediction. A row with some NaN components updates with
    its observed components o only, :math:`(y_{t,o}, C_o, R_{oo})` (see
    :func:`select_observed`).

    The loop calls the same two kernels as :func:`predict` and
    :func:`update`, so its numbers are bit for bit those of the single steps
    called in a loop (with ``update(x, P, *select_observed(y, C, R)[1:])``
    on a partly-NaN row); only the argument checks are done once, before
    the loop.

    Parameters
    ----------
    model : bayesfilt.models.LinearGaussian
    ys : array_like, shape (T, m)
        Measurements; ``ys[0]`` measures :math:`x_0`. NaN marks a missing
        component; an all-NaN row is a missing measurement. (A 1-D array is
        accepted when m = 1.)
    us : array_like, shape (T - 1, p), optional
        Known inputs, row t acting from t to t + 1 (needs ``model.B``); T
        rows are accepted and the last is unused. Inputs act on every step,
        whether its measurement is missing or not.

    Returns
    -------
    FilterResult
        See :class:`FilterResult`; ``loglik`` is
        :math:`\log p(y_{\text{observed}})`, the sum of the per-step
        :math:`\log N(r_t; 0, S_t)` of the observed components.

    Raises
    ------
    TypeError
        If ``model`` is not a :class:`~bayesfilt.models.LinearGaussian`.
    ValueError
        On wrong shapes, an inf in ``ys`` (named), ``us`` without
        ``model.B`` or with the wrong number of rows, or an innovation
        covariance that is not positive definite (named with its time step).
    """
    _check_model(model)
    n, m = model.state_dim, model.obs_dim
    ys = _as_ys(ys, m, batched=False)
    T = ys.shape[0]
    observed, components = observation_masks(ys)
    full = components.all(axis=1)
    us = _check_inputs(model, us, T, None)
    A, B, C, R = model.A, model.B, model.C, model.R
    GQGt = model.G @ model.Q @ model.G.T
    eye_n = np.eye(n)

    means, covs = np.empty((T, n)), np.empty((T, n, n))
    pred_means, pred_covs = np.empty((T, n)), np.empty((T, n, n))
    # a missing row keeps these: NaN innovation, zero gain, zero log-likelihood
    innovations, innovation_covs = np.full((T, m), np.nan), np.full((T, m, m), np.nan)
    gains, step_logliks = np.zeros((T, n, m)), np.zeros(T)
    # x_{0|-1} = m0, P_{0|-1} = P0: ys[0] measures x_0 (seed 000's time convention)
    x, P = model.m0, model.P0
    with np.errstate(over="ignore", invalid="ignore"):  # an overflow is reported below
        for t in range(T):
            if t > 0:
                # prediction, as predict(): x_{t|t-1} = A x_{t-1|t-1} + B u_{t-1},
                # P_{t|t-1} = A P_{t-1|t-1} A^T + G Q G^T
                x, P = _predict(x, P, A, GQGt, None if us is None else B @ us[t - 1])
            pred_means[t], pred_covs[t] = x, P
            if observed[t]:
                if full[t]:
                    y, C_o, R_o = ys[t], C, R
                else:
                    # the observed components o: y_o = C_o x + v_o, v_o ~ N(0, R_oo)
                    o = components[t]
                    y, (C_o, R_o) = ys[t, o], _select(o, C, R)
                # measurement update, as update(): r_t = y_t - C x_{t|t-1}, S_t, K_t,
                # x_{t|t} = x_{t|t-1} + K_t r_t and the Joseph-form P_{t|t}
                try:
                    x, P, K, r, S, loglik = _correct(x, P, y - C_o @ x, C_o, R_o, eye_n)
                except ValueError as exc:
                    raise ValueError(f"kalman_filter: {exc} (at time step {t})") from None
                if not full[t]:
                    K, r, S = _embed(o, K, r, S)
                gains[t], innovations[t], innovation_covs[t], step_logliks[t] = K, r, S, loglik
            means[t], covs[t] = x, P
    for what, a in (("means", means), ("covs", covs), ("pred_covs", pred_covs),
                    ("step_logliks", step_logliks)):
        require_finite("kalman_filter", what, a)
    return FilterResult(means, covs, pred_means, pred_covs, innovations, innovation_covs,
                        gains, step_logliks, float(step_logliks.sum()), observed, components)


def _missing_patterns(components: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Distinct missing-data patterns (D, T, m) of ``components`` (M, T, m), and for each
    sequence the index of its pattern."""
    if (components == components[0]).all():  # the common case, and np.unique is slow on it
        return components[:1], np.zeros(components.shape[0], dtype=np.intp)
    M = components.shape[0]
    patterns, which = np.unique(components.reshape(M, -1), axis=0, return_inverse=True)
    return patterns.reshape((-1,) + components.shape[1:]), which.reshape(-1)


def batch_kalman_filter(model: LinearGaussian, ys, us=None) -> FilterResult:
    r"""Kalman filter on M measurement sequences of the same model at once.

    The same loop as :func:`kalman_filter`, with every step applied to all M
    sequences together: the M means move with one (M, n) x (n, n) product.
    The covariances, gains and innovation covariances do not depend on the
    measured *values*, only on which components are missing, so they are
    computed once for each distinct missing-data pattern (usually one for
    all M). This is what makes many Monte Carlo runs cheap (NEES/NIS
    consistency checks, chapter 03). The result equals M calls of
    :func:`kalman_filter` to rounding (the gains come from an LU solve here,
    from the Cholesky factor there; see the module's numerics paragraph).

    Parameters
    ----------
    model : bayesfilt.models.LinearGaussian
    ys : array_like, shape (M, T, m)
        M sequences of T measurements; NaN marks a missing component, and
        all-NaN rows are missing, as in :func:`kalman_filter`. Each sequence
        may have its own pattern. (An (M, T) array is accepted when m = 1.)
    us : array_like, shape (T - 1, p) or (M, T - 1, p), optional
        Known inputs, shared by all sequences or one set per sequence
        (needs ``model.B``; T rows accepted, the last unused).

    Returns
    -------
    FilterResult
        Every field with a leading axis M: ``means`` (M, T, n), ``covs``
        (M, T, n, n), ..., ``loglik`` (M,), ``observed`` (M, T),
        ``observed_components`` (M, T, m).
        ``covs``, ``pred_covs``, ``innovation_covs`` and ``gains`` are
        read-only: sequences with the same missing-data pattern share them,
        and when all sequences do they are broadcast views that cost no
        memory (copy with ``np.array`` to modify).
    """
    _check_model(model)
    ys = _as_ys(ys, model.obs_dim, batched=True)
    M, T = ys.shape[:2]
    observed, components = observation_masks(ys)
    us = _check_inputs(model, us, T, M)
    with np.errstate(over="ignore", invalid="ignore"):  # an overflow is reported just below
        try:
            result = _batch_run(model, ys, observed, components, us)
        except ValueError as exc:
            raise ValueError(f"batch_kalman_filter: {exc}") from None
    for what in ("means", "covs", "pred_covs", "step_logliks"):
        require_finite("batch_kalman_filter", what, getattr(result, what))
    return result


def _batch_run(model: LinearGaussian, ys, observed, components, us) -> FilterResult:
    """:func:`batch_kalman_filter` after validation.

    Means, innovations and log-likelihoods have an axis of the M sequences;
    covariances, gains and S an axis of the D distinct missing-data patterns.
    Inside, arrays are time-major, (T, M, ...) and (T, D, ...), so that every
    step writes contiguous memory.
    """
    n, m = model.state_dim, model.obs_dim
    M, T = ys.shape[:2]
    A, C, R = model.A, model.C, model.R
    GQGt = model.G @ model.Q @ model.G.T
    eye_n = np.eye(n)
    patterns, which = _missing_patterns(components)
    D = patterns.shape[0]
    ys = ys.transpose(1, 0, 2)
    # B u_{t-1}: (T - 1, n) shared by all sequences, or (T - 1, M, n)
    Bus = None if us is None else (us @ model.B.T if us.ndim == 2
                                   else (us @ model.B.T).transpose(1, 0, 2))

    means, pred_means = np.empty((T, M, n)), np.empty((T, M, n))
    innovations, step_logliks = np.full((T, M, m), np.nan), np.zeros((T, M))
    covs, pred_covs = np.empty((T, D, n, n)), np.empty((T, D, n, n))
    innovation_covs, gains = np.full((T, D, m, m), np.nan), np.zeros((T, D, n, m))
    x = np.broadcast_to(model.m0, (M, n))
    P = np.broadcast_to(model.P0, (D, n, n))
    for t in range(T):
        if t > 0:
            # prediction: x_{t|t-1} = A x_{t-1|t-1} + B u_{t-1} for the M means (rows of x),
            # P_{t|t-1} = A P_{t-1|t-1} A^T + G Q G^T for the D covariances
            x, P = _predict(x, P, A, GQGt, None if Bus is None else Bus[t - 1])
        pred_means[t], pred_covs[t] = x, P
        measured = patterns[:, t]  # (D, m): which components of y_t each pattern measures
        obs = measured.any(axis=1)  # which of the D patterns measure y_t (some of it)
        if obs.any() and measured[obs].all():  # every pattern that measures y_t, all of it
            # S_t, K_t and the Joseph-form P_{t|t} of those patterns
            try:
                K, S, L, P_obs = _gain_and_joseph(P[obs], C, R, eye_n)
            except ValueError as exc:
                raise ValueError(f"{exc} (at time step {t})") from None
            if obs.all():
                P = P_obs
            else:
                P = np.array(P)
                P[obs] = P_obs
            gains[t, obs], innovation_covs[t, obs] = K, S
            # r_t = y_t - C x_{t|t-1}   (NaN for the sequences whose y_t is missing)
            r = ys[t] - x @ C.T
            innovations[t] = r
            if D == 1:  # all M sequences share K_t and S_t
                # x_{t|t} = x_{t|t-1} + K_t r_t
                x = x + r @ K[0].T
                # log N(r_t; 0, S_t)
                step_logliks[t] = _logpdf_rows(r, L[0])
            else:  # each sequence that measures y_t uses its own pattern's K_t and S_t
                seq = observed[:, t]
                # the index of each such sequence's pattern among the patterns that measure y_t
                slot = (np.cumsum(obs) - 1)[which[seq]]
                x = np.array(x)
                # x_{t|t} = x_{t|t-1} + K_t r_t
                x[seq] += (K[slot] @ r[seq, :, None])[..., 0]
                # log N(r_t; 0, S_t)
                step_logliks[t, seq] = _logpdf_rows(r[seq], L[slot])
        elif obs.any():  # patterns measure different parts of y_t: a group per set o of them
            x, P = np.array(x), np.array(P)
            # r_t = y_t - C x_{t|t-1}   (NaN in the components that are missing)
            r = ys[t] - x @ C.T
            innovations[t] = r
            sets, group = np.unique(measured[obs], axis=0, return_inverse=True)
            measuring = np.flatnonzero(obs)
            for g, o in enumerate(sets):
                pats = measuring[group.reshape(-1) == g]  # the patterns that measure y_{t,o}
                i = np.flatnonzero(o)
                # y_o = C_o x + v_o, v_o ~ N(0, R_oo): an update with C_o and R_oo
                C_o, R_o = _select(o, C, R)
                try:
                    K, S, L, P[pats] = _gain_and_joseph(P[pats], C_o, R_o, eye_n)
                except ValueError as exc:
                    raise ValueError(f"{exc} (at time step {t})") from None
                # the columns of K and the block of S of the components o
                gains[t][np.ix_(pats, np.arange(n), i)] = K
                innovation_covs[t][np.ix_(pats, i, i)] = S
                # the sequences of those patterns, and each one's slot among pats
                seq = np.flatnonzero(np.isin(which, pats))
                slot = np.searchsorted(pats, which[seq])
                r_o = r[np.ix_(seq, i)]
                # x_{t|t} = x_{t|t-1} + K_t r_{t,o}
                x[seq] += (K[slot] @ r_o[..., None])[..., 0]
                # log N(r_{t,o}; 0, S_t)
                step_logliks[t, seq] = _logpdf_rows(r_o, L[slot])
        means[t], covs[t] = x, P

    means, pred_means, innovations = (a.transpose(1, 0, 2)
                                      for a in (means, pred_means, innovations))
    step_logliks = step_logliks.T
    covs, pred_covs, innovation_covs, gains = (a.swapaxes(0, 1) for a in (
        covs, pred_covs, innovation_covs, gains))
    if D == 1:
        covs, pred_covs, innovation_covs, gains = (
            np.broadcast_to(a[0], (M,) + a.shape[1:])
            for a in (covs, pred_covs, innovation_covs, gains))
    else:
        covs, pred_covs, innovation_covs, gains = (
            a[which] for a in (covs, pred_covs, innovation_covs, gains))
        for a in (covs, pred_covs, innovation_covs, gains):
            a.setflags(write=False)
    return FilterResult(means, covs, pred_means, pred_covs, innovations, innovation_covs,
                        gains, step_logliks, step_logliks.sum(axis=1), observed, components)


# --------------------------------------------------------------------------
# Steady state
# --------------------------------------------------------------------------

def steady_state(model: LinearGaussian) -> SteadyState:
    r"""Steady-state covariances and gain of the Kalman filter of a time-invariant model.

    Returns the stabilising solution of the discrete algebraic Riccati
    equation

    .. math::

        P = A P A^T - A P C^T (C P C^T + R)^{-1} C P A^T + G Q G^T,

    which exists when :math:`(A, C)` is detectable and
    :math:`(A, G Q^{1/2})` has no uncontrollable mode on the unit circle.
    It is solved with ``scipy.linalg.solve_discrete_are(A.T, C.T, G Q G^T,
    R)`` (the filter's Riccati equation is the control one for the
    transposed system). Then :math:`K = P C^T (C P C^T + R)^{-1}` and the
    filtered covariance is :math:`(I - KC) P (I - KC)^T + K R K^T`.

    When the filter's predicted covariance :math:`P_{t+1|t}` converges to
    it (with :math:`(A, C)` detectable and R positive definite):

    * from every :math:`P_0 \succ 0` (positive definite);
    * from every :math:`P_0 \succeq 0` (positive semi-definite, singular
      included) when, in addition, :math:`(A, G Q^{1/2})` is stabilisable.

    Not "whatever :math:`P_0`": a singular :math:`P_0` can leave an unstable
    mode that the noise never excites at zero variance. With
    ``A = [[2]], C = [[1]], Q = [[0]], R = [[1]]``, this function returns
    ``pred_cov = [[3]]`` (the stabilising solution of :math:`P = 4P/(P + 1)`),
    but from ``P0 = [[0]]`` the filter stays at :math:`P_t = 0` for ever
    (:math:`0` is the other solution, not stabilising: with :math:`K = 0`
    the error dynamics :math:`A (I - KC) = 2` are unstable). From every
    ``P0 > 0`` it converges to 3.

    Parameters
    ----------
    model : bayesfilt.models.LinearGaussian
        R must be positive definite. ``m0``, ``P0`` and ``B`` play no role.

    Returns
    -------
    SteadyState
        ``pred_cov`` (n, n), ``cov`` (n, n), ``gain`` (n, m).

    Raises
    ------
    ValueError
        If the Riccati equation has no stabilising solution (e.g. an unstable
        mode of A that C does not see), or R is singular.
    """
    _check_model(model)
    A, C, R = model.A, model.C, model.R
    n = model.state_dim
    GQGt = model.G @ model.Q @ model.G.T
    as_covariance("R", R, definite=True)
    try:
        P = sla.solve_discrete_are(A.T, C.T, GQGt, R)
    except (np.linalg.LinAlgError, ValueError) as exc:
        raise ValueError("the filter's Riccati equation has no stabilising solution for this "
                         "model: (A, C) must be detectable and (A, G Q^{1/2}) must have no "
                         f"uncontrollable mode on the unit circle ({exc})") from None
    if not np.all(np.isfinite(P)):
        raise ValueError("the filter's Riccati equation has no stabilising solution for this "
                         "model (solve_discrete_are returned non-finite values)")
    P = 0.5 * (P + P.T)
    S = C @ P @ C.T + R
    # K = P C^T S^{-1}
    K = np.linalg.solve(S, C @ P).T
    # The solution must make the error dynamics A (I - K C) stable.
    rho = float(np.max(np.abs(np.linalg.eigvals(A @ (np.eye(n) - K @ C)))))
    if rho >= 1.0:
        raise ValueError("the filter's Riccati equation has no stabilising solution for this "
                         f"model: the error dynamics A (I - K C) have spectral radius {rho:.6g} "
                         ">= 1; (A, C) must be detectable")
    IKC = np.eye(n) - K @ C
    cov = IKC @ P @ IKC.T + K @ R @ K.T
    return SteadyState(P, 0.5 * (cov + cov.T), K)
