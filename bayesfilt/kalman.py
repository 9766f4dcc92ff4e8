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

A row of ``ys`` that is entirely NaN is a missing measurement: the filter
only predicts through it.

Numerics. The covariance update uses the Joseph form (see :func:`update`),
S is factorised by Cholesky and the gain is obtained by solving linear
systems, never by inverting S; every covariance is symmetrised exactly.

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

from ._checks import (as_array, as_covariance, as_matrix, as_noise_gain, as_square, as_vector,
                      require_finite)
from .gaussian import LOG_2PI, _logpdf_rows
from .models import LinearGaussian

__all__ = [
    "Prediction",
    "Update",
    "FilterResult",
    "SteadyState",
    "predict",
    "update",
    "kalman_filter",
    "batch_kalman_filter",
    "steady_state",
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
    innovations (T, m) and innovation_covs (T, m, m), NaN on rows whose
    measurement is missing (see ``observed``); gains (T, n, m), zero on missing rows;
    step_logliks (T,), 0 on missing rows; loglik: their sum, log p(y_0..y_{T-1});
    observed (T,) bool, False where the row of ys was all NaN.
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
# Unchecked kernels: the filters validate once, then call these every step.
# --------------------------------------------------------------------------

def _predict(x, P, A, GQGt, Bu=None):
    # x_{t+1|t} = A x_{t|t} + B u_t
    x = A @ x
    if Bu is not None:
        x = x + Bu
    # P_{t+1|t} = A P_{t|t} A^T + G Q G^T
    P = A @ P @ A.T + GQGt
    return x, 0.5 * (P + P.T)


_EPS = np.finfo(float).eps
S_NOT_PD = ("innovation covariance S = C P C^T + R (H P H^T + R in the EKF) is singular or not "
            "positive definite: R needs a positive variance on every measurement component, "
            "or C P C^T must make up for it")


def _swap(a):
    return np.swapaxes(a, -1, -2)


def _gain_and_joseph(P, C, R, eye_n):
    """Gain and Joseph-form covariance of a measurement update, for P (n, n) or a stack (D, n, n).

    The one place the update's covariance algebra is written; the single step,
    the covariance passes of the filters and the EKF (with C = H) all call it.
    Returns K (..., n, m), S (..., m, m), L (..., m, m) whose lower triangle is the
    Cholesky factor of S (the upper triangle is not cleared), and P_post.
    Raises ValueError(S_NOT_PD) if S is not safely positive definite.
    """
    PCt = P @ C.T
    # S = C P C^T + R
    S = C @ PCt + R
    if not np.isfinite(S).all():
        raise ValueError("innovation covariance S = C P C^T + R overflowed to a non-finite value; "
                         "the model or the data are too large for floating point")
    # S is numerically singular when a pivot of its factor L is below the rounding
    # level of its largest entry.
    if P.ndim == 2:
        # One small S: LAPACK dposv factors S = L L^T and solves S K^T = C P in one call
        # (it leaves S's upper triangle above L: solve with L as lower triangular only).
        L, Kt, info = _dposv(S, PCt.T, lower=1)
        singular = info != 0 or min(L.diagonal()) ** 2 <= S.shape[0] * _EPS * max(S.diagonal())
    else:
        try:
            L = np.linalg.cholesky(S)
        except np.linalg.LinAlgError:
            raise ValueError(S_NOT_PD) from None
        singular = (np.diagonal(L, axis1=-2, axis2=-1).min(axis=-1) ** 2
                    <= S.shape[-1] * _EPS * np.diagonal(S, axis1=-2, axis2=-1).max(axis=-1)).any()
        # K = P C^T S^{-1}: solve S K^T = C P (no inverse)
        Kt = np.linalg.solve(S, _swap(PCt))
    if singular:
        raise ValueError(S_NOT_PD)
    K = _swap(Kt)
    IKC = eye_n - K @ C
    # P_{t|t} = (I - K C) P (I - K C)^T + K R K^T   (Joseph form)
    P_post = IKC @ P @ _swap(IKC) + K @ R @ Kt
    return K, S, L, 0.5 * (P_post + _swap(P_post))


def _correct(x, P, r, C, R, eye_n):
    """Measurement update given the innovation r (shared with the EKF, where C is the Jacobian H)."""
    K, S, L, P_post = _gain_and_joseph(P, C, R, eye_n)
    # x_{t|t} = x_{t|t-1} + K r
    x_post = x + K @ r
    # log N(r; 0, S)
    loglik = float(_logpdf_rows(r[None, :], L)[0])
    return x_post, P_post, K, r, S, loglik


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
    agree (for the optimal K). But :math:`P - KCP` is a *difference* of two
    positive semi-definite matrices: when the measurement is precise the two
    nearly cancel, and rounding can leave a result that is asymmetric or has
    a negative eigenvalue, after which the filter can diverge. The Joseph
    form is a *sum* of two PSD terms, so it cannot lose definiteness through
    cancellation, and it is the correct covariance for *any* gain K, not only
    the optimal one (so a small error in K costs only a second-order error
    in P). filterpy uses it too. The result is also symmetrised exactly.

    S is factorised by Cholesky (which also checks it is positive definite)
    and the gain is obtained by solving :math:`S K^T = C P`, never by
    inverting S.

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


def _check_observations(ys: np.ndarray, axis_names: str) -> np.ndarray:
    """Return the ``observed`` mask; ValueError for partly-missing rows or inf."""
    if np.isfinite(ys).all():
        return np.ones(ys.shape[:-1], dtype=bool)
    nan = np.isnan(ys)
    missing = nan.all(axis=-1)
    partly = nan.any(axis=-1) & ~missing
    if partly.any():
        where = tuple(int(i) for i in np.argwhere(partly)[0])
        raise ValueError(f"ys row {where if len(where) > 1 else where[0]} ({axis_names}) is "
                         "partly NaN: a missing measurement must be an all-NaN row")
    if np.isinf(ys).any():
        where = tuple(int(i) for i in np.argwhere(np.isinf(ys))[0])
        raise ValueError(f"ys must be finite or NaN (missing), got inf at index {where}")
    return ~missing


def _check_inputs(model: LinearGaussian, us, T: int, batch: int | None):
    """Return B u_t for t = 0..T-2 as (T-1, n) or (M, T-1, n), or None."""
    if us is None:
        return None
    if model.B is None:
        raise ValueError("us was given but the model has no control matrix B")
    p = model.control_dim
    a = as_array("us", us)
    if batch is not None and a.ndim == 3:
        if a.shape[0] != batch or a.shape[2] != p:
            raise ValueError(f"us must have shape (T - 1, {p}) shared by all sequences or "
                             f"({batch}, T - 1, {p}), got shape {a.shape}")
    elif a.ndim != 2 or a.shape[1] != p:
        want = f"(T - 1, {p})" + ("" if batch is None else f" or ({batch}, T - 1, {p})")
        raise ValueError(f"us must have shape {want}, got shape {a.shape}")
    rows = a.shape[-2]
    if rows not in (T - 1, T):
        raise ValueError(f"us must have T - 1 = {T - 1} (or T = {T}) rows, got {rows}")
    a = a[..., : T - 1, :]
    return a @ model.B.T


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


class _Covariances(NamedTuple):
    """The data-independent half of a filter run, per time step.

    Shapes for one missing-data pattern (a leading axis D for D patterns):
    ``covs`` and ``pred_covs`` (T, n, n); ``S`` (T, m, m), NaN where missing;
    ``gains`` (T, n, m), 0 where missing; ``chol_inv`` (T, m, m) = L^{-1}
    with S = L L^T, 0 where missing; ``log_dets`` (T,) = log det S, 0 where
    missing.
    """

    covs: np.ndarray
    pred_covs: np.ndarray
    S: np.ndarray
    gains: np.ndarray
    chol_inv: np.ndarray
    log_dets: np.ndarray


def _finish(covs, pred_covs, S, gains, chols, observed) -> _Covariances:
    """Add L^{-1} and log det S for the observed steps (any leading axes)."""
    m = S.shape[-1]
    chol_inv = np.zeros(S.shape)
    log_dets = np.zeros(S.shape[:-2])
    if observed.any():
        Ls = np.tril(chols[observed])  # only the lower triangles are the factors
        # L^{-1} from the triangular systems L X = I, once per step, so that
        # r^T S^{-1} r = |L^{-1} r|^2 vectorises over steps and sequences.
        chol_inv[observed] = np.linalg.solve(Ls, np.broadcast_to(np.eye(m), Ls.shape))
        # log det S = 2 sum_i log L_ii
        log_dets[observed] = 2.0 * np.log(np.diagonal(Ls, axis1=-2, axis2=-1)).sum(axis=-1)
    return _Covariances(covs, pred_covs, S, gains, chol_inv, log_dets)


def _covariance_pass(A, C, R, GQGt, P0, observed) -> _Covariances:
    """Covariance recursion (predict, Joseph update) for one missing-data pattern (T,).

    For a time-invariant model the recursion reaches a floating-point fixed
    point after a few dozen to a few hundred steps (the Riccati map is a
    contraction): the predicted covariance comes out bit-for-bit equal to the
    previous one. From then on every step would recompute exactly the same
    numbers, so they are reused instead. This is exact, not an
    approximation: a step is reused only when its input is bitwise identical
    to the input of the step it copies.
    """
    n, m, T = A.shape[0], C.shape[0], observed.shape[0]
    eye_n = np.eye(n)
    At = A.T
    mats = [P0]                 # every distinct covariance, indexed by the steps
    gains, Ss, chols = [], [], []
    pred_idx = [0] * T
    post_idx = [0] * T
    upd_idx = [0] * T
    P, i = P0, 0
    last_pred = None  # (P_{t-1|t-1} it was computed from, index of the P_{t|t-1} it gave)
    last_upd = None   # (P_{t|t-1} it was computed from, update index, index of P_{t|t})
    for t, obs in enumerate(observed.tolist()):
        if t > 0:
            if last_pred is not None and P is last_pred[0]:
                i = last_pred[1]
                P = mats[i]
            else:
                P_post = P
                # P_{t|t-1} = A P_{t-1|t-1} A^T + G Q G^T
                # (symmetrised with all the others after the loop)
                P = A @ P @ At + GQGt
                mats.append(P)
                i = len(mats) - 1
                last_pred = (P_post, i)
        pred_idx[t] = i
        if obs:
            if last_upd is not None and (P is last_upd[0] or (
                    P[0, 0] == last_upd[0][0, 0] and (P == last_upd[0]).all())):
                u, i = last_upd[1], last_upd[2]
                last_upd = (P, u, i)
                P = mats[i]
            else:
                P_pred = P
                try:
                    K, S, L, P = _gain_and_joseph(P, C, R, eye_n)
                except ValueError as exc:
                    raise ValueError(f"{exc} (at time step {t})") from None
                gains.append(K)
                Ss.append(S)
                chols.append(L)
                mats.append(P)
                u, i = len(gains) - 1, len(mats) - 1
                last_upd = (P_pred, u, i)
            upd_idx[t] = u
        post_idx[t] = i
    mats = np.stack(mats)
    # every covariance returned is exactly symmetric
    mats = 0.5 * (mats + _swap(mats))
    S_t = np.full((T, m, m), np.nan)
    gains_t = np.zeros((T, n, m))
    chols_t = np.zeros((T, m, m))
    if gains:
        u = np.asarray(upd_idx)[observed]
        S_t[observed] = np.stack(Ss)[u]
        gains_t[observed] = np.stack(gains)[u]
        chols_t[observed] = np.stack(chols)[u]
    return _finish(mats[post_idx], mats[pred_idx], S_t, gains_t, chols_t, observed)


def _covariance_pass_many(A, C, R, GQGt, P0, patterns) -> _Covariances:
    """The covariance recursion for D missing-data patterns (D, T) at once, vectorised over D."""
    n, m = A.shape[0], C.shape[0]
    D, T = patterns.shape
    eye_n = np.eye(n)
    covs = np.empty((D, T, n, n))
    pred_covs = np.empty((D, T, n, n))
    S_all = np.full((D, T, m, m), np.nan)
    gains = np.zeros((D, T, n, m))
    chols = np.zeros((D, T, m, m))
    P = np.broadcast_to(P0, (D, n, n))
    for t in range(T):
        if t > 0:
            # P_{t|t-1} = A P_{t-1|t-1} A^T + G Q G^T
            P = A @ P @ A.T + GQGt
            P = 0.5 * (P + _swap(P))
        pred_covs[:, t] = P
        obs = patterns[:, t]
        if obs.any():
            idx = slice(None) if obs.all() else np.flatnonzero(obs)
            try:
                K, S, L, Pn = _gain_and_joseph(P[idx], C, R, eye_n)
            except ValueError as exc:
                raise ValueError(f"{exc} (at time step {t})") from None
            if isinstance(idx, slice):
                P = Pn
            else:
                P = np.array(P)
                P[idx] = Pn
            S_all[idx, t] = S
            gains[idx, t] = K
            chols[idx, t] = L
        covs[:, t] = P
    return _finish(covs, pred_covs, S_all, gains, chols, patterns)


def _step_logliks(chol_inv, log_dets, observed, innovations) -> np.ndarray:
    """log N(r_t; 0, S_t) where observed, 0 elsewhere (time-major arrays).

    ``innovations`` (T, m) with ``chol_inv`` (T, m, m); or (T, M, m) with
    ``chol_inv`` (T, m, m) shared by the M sequences or (T, M, m, m).
    ``log_dets`` and ``observed`` have the shape of ``innovations`` without m.
    NaN innovations of missing rows give NaN here and are replaced by 0.
    """
    m = innovations.shape[-1]
    # z = L^{-1} r, so that r^T S^{-1} r = z^T z
    if chol_inv.ndim == innovations.ndim + 1:
        z = (chol_inv @ innovations[..., None])[..., 0]
    else:
        z = innovations @ _swap(chol_inv)
    maha = np.sum(z * z, axis=-1)
    # log N(r; 0, S) = -(r^T S^{-1} r + log det S + m log 2 pi) / 2
    return np.where(observed, -0.5 * (maha + log_dets + m * LOG_2PI), 0.0)


def kalman_filter(model: LinearGaussian, ys, us=None) -> FilterResult:
    r"""Run the Kalman filter of seed 000 over a whole sequence of measurements.

    For t = 0, ..., T-1: predict from t-1 to t (skipped at t = 0, where the
    prediction is the prior :math:`N(m_0, P_0)`), then update with
    ``ys[t]`` (as :func:`predict` and :func:`update` do) unless that row is
    missing (all NaN), in which case the filtered belief is the prediction.

    The arguments are validated once; the loop then runs unchecked code.
    The covariances do not depend on the measured values, so they are
    computed first, reusing steps once the recursion has reached its
    floating-point fixed point (exactly, see the source), and only the means
    are then run through the measurements.

    Parameters
    ----------
    model : bayesfilt.models.LinearGaussian
    ys : array_like, shape (T, m)
        Measurements; ``ys[0]`` measures :math:`x_0`. An all-NaN row is a
        missing measurement. (A 1-D array is accepted when m = 1.)
    us : array_like, shape (T - 1, p), optional
        Known inputs, row t acting from t to t + 1 (needs ``model.B``); T
        rows are accepted and the last is unused.

    Returns
    -------
    FilterResult
        See :class:`FilterResult`; ``loglik`` is
        :math:`\log p(y_{\text{observed}})`, the sum of the per-step
        :math:`\log N(r_t; 0, S_t)` over the observed rows.

    Raises
    ------
    TypeError
        If ``model`` is not a :class:`~bayesfilt.models.LinearGaussian`.
    ValueError
        On wrong shapes, a partly-NaN row of ``ys`` (named), an inf, ``us``
        without ``model.B`` or with the wrong number of rows, or an
        innovation covariance that is not positive definite.
    """
    _check_model(model)
    n, m = model.state_dim, model.obs_dim
    ys = _as_ys(ys, m, batched=False)
    T = ys.shape[0]
    observed = _check_observations(ys, "time step")
    Bus = _check_inputs(model, us, T, None)
    A, C = model.A, model.C
    GQGt = model.G @ model.Q @ model.G.T
    with np.errstate(over="ignore", invalid="ignore"):  # an overflow is reported below
        try:
            cov = _covariance_pass(A, C, model.R, GQGt, model.P0, observed)
        except ValueError as exc:
            raise ValueError(f"kalman_filter: {exc}") from None

    gains = cov.gains
    means = np.empty((T, n))
    pred_means = np.empty((T, n))
    obs_list = observed.tolist()
    x = model.m0
    for t in range(T):
        if t > 0:
            # x_{t|t-1} = A x_{t-1|t-1} + B u_{t-1}
            x = A @ x
            if Bus is not None:
                x = x + Bus[t - 1]
        pred_means[t] = x
        if obs_list[t]:
            # x_{t|t} = x_{t|t-1} + K_t (y_t - C x_{t|t-1})
            x = x + gains[t] @ (ys[t] - C @ x)
        means[t] = x
    # r_t = y_t - C x_{t|t-1}  (NaN rows of ys stay NaN)
    innovations = ys - pred_means @ C.T
    step_logliks = _step_logliks(cov.chol_inv, cov.log_dets, observed, innovations)
    # NaN is legitimate only in the innovations of missing rows; anything else overflowed.
    for what, a in (("means", means), ("covs", cov.pred_covs), ("step_logliks", step_logliks)):
        require_finite("kalman_filter", what, a)
    return FilterResult(means, cov.covs, pred_means, cov.pred_covs, innovations, cov.S,
                        gains, step_logliks, float(step_logliks.sum()), observed)


#: Up to this many distinct missing-data patterns, the covariance recursion runs
#: once per pattern (reusing converged steps); beyond it, once vectorised over them.
_FEW_PATTERNS = 4


def _missing_patterns(observed: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Distinct rows of ``observed`` (D, T) and, for each sequence, the index of its row."""
    if (observed == observed[0]).all():  # the common case, and np.unique is slow on it
        return observed[:1], np.zeros(observed.shape[0], dtype=np.intp)
    patterns, which = np.unique(observed, axis=0, return_inverse=True)
    return patterns, which.reshape(-1)


def batch_kalman_filter(model: LinearGaussian, ys, us=None) -> FilterResult:
    r"""Kalman filter on M measurement sequences of the same model at once.

    The covariances, gains and innovation covariances of a Kalman filter do
    not depend on the measured *values*, only on which rows are missing. So
    they are computed once for every distinct missing-data pattern, and only
    the means are propagated for all M sequences together, each step one
    (M, n) x (n, n) matrix product. This is what makes many Monte Carlo
    runs cheap (NEES/NIS consistency checks, chapter 03). The result equals
    M calls of :func:`kalman_filter` to rounding.

    Parameters
    ----------
    model : bayesfilt.models.LinearGaussian
    ys : array_like, shape (M, T, m)
        M sequences of T measurements; all-NaN rows are missing. (An (M, T)
        array is accepted when m = 1.)
    us : array_like, shape (T - 1, p) or (M, T - 1, p), optional
        Known inputs, shared by all sequences or one set per sequence
        (needs ``model.B``; T rows accepted, the last unused).

    Returns
    -------
    FilterResult
        Every field with a leading axis M: ``means`` (M, T, n), ``covs``
        (M, T, n, n), ..., ``loglik`` (M,), ``observed`` (M, T).
        ``covs``, ``pred_covs``, ``innovation_covs`` and ``gains`` are
        read-only: sequences with the same missing-data pattern share them,
        and when all sequences do they are broadcast views that cost no
        memory (copy with ``np.array`` to modify).
    """
    _check_model(model)
    ys = _as_ys(ys, model.obs_dim, batched=True)
    M, T = ys.shape[:2]
    observed = _check_observations(ys, "sequence, time step")
    Bus = _check_inputs(model, us, T, M)
    with np.errstate(over="ignore", invalid="ignore"):  # an overflow is reported just below
        try:
            result = _batch_run(model, ys, observed, Bus)
        except ValueError as exc:
            raise ValueError(f"batch_kalman_filter: {exc}") from None
    for what in ("means", "pred_covs", "step_logliks"):
        require_finite("batch_kalman_filter", what, getattr(result, what))
    return result


def _batch_run(model: LinearGaussian, ys, observed, Bus) -> FilterResult:
    """:func:`batch_kalman_filter` after validation."""
    n = model.state_dim
    M, T = ys.shape[:2]
    A, C = model.A, model.C
    At = A.T
    GQGt = model.G @ model.Q @ model.G.T
    patterns, which = _missing_patterns(observed)
    D = patterns.shape[0]
    if D <= _FEW_PATTERNS:
        parts = [_covariance_pass(A, C, model.R, GQGt, model.P0, p) for p in patterns]
        cov = _Covariances(*(np.stack(field) for field in zip(*parts)))
    else:
        cov = _covariance_pass_many(A, C, model.R, GQGt, model.P0, patterns)

    # The means. Written as one linear recursion per step,
    #   x_{t|t} = (I - K_t C) (A x_{t-1|t-1} + B u_{t-1}) + K_t y_t,
    # which is seed 000's x_{t|t-1} + K_t (y_t - C x_{t|t-1}) with the prediction
    # substituted; everything that does not depend on x is computed for all
    # steps and sequences at once, so the loop over t is one small product.
    # A missing row has K_t = 0 (its NaN measurement is replaced by 0 first).
    # Arrays are time-major (T, M, n) inside, so each step touches contiguous memory.
    y0 = ys if observed.all() else np.where(observed[..., None], ys, 0.0)
    y_tm = y0.transpose(1, 0, 2)
    eye_n = np.eye(n)
    if D == 1:
        K = cov.gains[0]                                   # (T, n, m), shared
        IKC = eye_n - K @ C                                # (T, n, n)
        # c_t = K_t y_t (+ (I - K_t C) B u_{t-1}), accumulated in place in x_tm
        x_tm = y_tm @ _swap(K)
        if Bus is not None:
            Bu_tm = Bus[:, None, :] if Bus.ndim == 2 else Bus.transpose(1, 0, 2)
            x_tm[1:] += Bu_tm @ _swap(IKC[1:])
        # F_t^T = ((I - K_t C) A)^T, right-multiplying the rows of X
        Ft = _swap(IKC @ A)
        x_tm[0] += model.m0 @ IKC[0].T
        for t in range(1, T):
            x_tm[t] += x_tm[t - 1] @ Ft[t]
    else:
        K = cov.gains[which].transpose(1, 0, 2, 3)         # (T, M, n, m)
        IKC = eye_n - K @ C                                # (T, M, n, n)
        x_tm = (K @ y_tm[..., None])[..., 0]               # (T, M, n)
        if Bus is not None:
            Bu_tm = Bus[:, None, :] if Bus.ndim == 2 else Bus.transpose(1, 0, 2)
            x_tm[1:] += (IKC[1:] @ Bu_tm[..., None])[..., 0]
        F = IKC @ A
        x_tm[0] += IKC[0] @ model.m0
        for t in range(1, T):
            x_tm[t] += (F[t] @ x_tm[t - 1, :, :, None])[..., 0]
    # x_{t|t-1} = A x_{t-1|t-1} + B u_{t-1}, x_{0|-1} = m0
    pred_tm = np.empty((T, M, n))
    pred_tm[0] = model.m0
    np.matmul(x_tm[:-1], At, out=pred_tm[1:])
    if Bus is not None:
        pred_tm[1:] += Bus[:, None, :] if Bus.ndim == 2 else Bus.transpose(1, 0, 2)
    # r_t = y_t - C x_{t|t-1}  (NaN rows of ys stay NaN)
    innov_tm = pred_tm @ C.T
    np.subtract(ys.transpose(1, 0, 2), innov_tm, out=innov_tm)
    means, pred_means, innovations = (a.transpose(1, 0, 2) for a in (x_tm, pred_tm, innov_tm))
    if D == 1:
        step_logliks = _step_logliks(cov.chol_inv[0], cov.log_dets[0][:, None], observed.T,
                                     innov_tm).T
        covs, pred_covs, S, gains = (np.broadcast_to(a[0], (M,) + a.shape[1:])
                                     for a in (cov.covs, cov.pred_covs, cov.S, cov.gains))
    else:
        step_logliks = _step_logliks(cov.chol_inv[which].transpose(1, 0, 2, 3),
                                     cov.log_dets[which].T, observed.T, innov_tm).T
        covs, pred_covs, S, gains = (a[which] for a in (cov.covs, cov.pred_covs, cov.S,
                                                        cov.gains))
        for a in (covs, pred_covs, S, gains):
            a.setflags(write=False)
    return FilterResult(means, covs, pred_means, pred_covs, innovations, S,
                        gains, step_logliks, step_logliks.sum(axis=1), observed)


# --------------------------------------------------------------------------
# Steady state
# --------------------------------------------------------------------------

def steady_state(model: LinearGaussian) -> SteadyState:
    r"""Steady-state covariances and gain of the Kalman filter of a time-invariant model.

    The predicted covariance :math:`P = P_{t+1|t}` converges (whatever
    :math:`P_0`) to the stabilising solution of the discrete algebraic
    Riccati equation

    .. math::

        P = A P A^T - A P C^T (C P C^T + R)^{-1} C P A^T + G Q G^T,

    provided :math:`(A, C)` is detectable and :math:`(A, G Q^{1/2})` has no
    uncontrollable mode on the unit circle. It is solved with
    ``scipy.linalg.solve_discrete_are(A.T, C.T, G Q G^T, R)`` (the filter's
    Riccati equation is the control one for the transposed system). Then
    :math:`K = P C^T (C P C^T + R)^{-1}` and the filtered covariance is
    :math:`(I - KC) P (I - KC)^T + K R K^T`.

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
