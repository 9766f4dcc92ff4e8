r"""The unscented transform and the unscented Kalman filter (chapter 08, beyond the source notes).

The EKF of chapter 04 pushes a Gaussian through a nonlinear function by the
function's *tangent*; the particle filter of chapter 06 pushes thousands of
random draws through the function itself. The **unscented transform** (UT,
Julier & Uhlmann 1997) sits in between: it pushes a handful of *chosen*
points through the function itself, and reads a mean and a covariance off
their images.

For :math:`x \sim N(m, P)` with n components, take the lower Cholesky
factor :math:`P = L L^T` and its columns :math:`L_{:,j}`. The 2n + 1
**sigma points** are

.. math::

    \mathcal X_0 = m, \qquad \mathcal X_j = m + c\,L_{:,j}, \qquad
    \mathcal X_{n+j} = m - c\,L_{:,j} \quad (j = 1, \dots, n),

with :math:`c^2 = n + \lambda = \alpha^2 (n + \kappa)`, and their weights are
(the *scaled* points of Julier 2002, "The scaled unscented transformation",
in the form of Wan & van der Merwe 2000)

.. math::

    W^m_0 = \frac{\lambda}{n + \lambda}, \qquad
    W^c_0 = W^m_0 + 1 - \alpha^2 + \beta, \qquad
    W^m_j = W^c_j = \frac{1}{2(n + \lambda)} \quad (j \ge 1).

Whatever the three parameters, the weighted points have mean m and
covariance P: the centre adds nothing to the covariance, and the 2n outer
points give :math:`\sum_j L_{:,j} L_{:,j}^T = L L^T = P`. Push each through
g, :math:`\mathcal Y_j = g(\mathcal X_j)`, and take

.. math::

    \hat y = \sum_j W^m_j \mathcal Y_j, \qquad
    \Sigma_{yy} = \sum_j W^c_j (\mathcal Y_j - \hat y)(\mathcal Y_j - \hat y)^T, \qquad
    \Sigma_{xy} = \sum_j W^c_j (\mathcal X_j - m)(\mathcal Y_j - \hat y)^T.

**How accurate.** The UT is exact for a linear g (mean and covariance).
For a Gaussian its mean is exact through third order: the points share the
Gaussian's moments up to the third (the odd ones vanish for any symmetric
point set), so the mean is exact for any polynomial g of degree at most 3.
Its covariance involves moments up to the fourth and is right only through
second order. In one dimension the UT's variance of a quadratic
:math:`a e + b e^2` (e = x - m) is :math:`a^2 \sigma^2 + b^2 \sigma^4
(\alpha^2 \kappa + \beta)`, exact when :math:`\alpha^2 \kappa + \beta = 2`;
in n dimensions no setting makes it exact for every quadratic (for
:math:`x^T x`, x ~ N(0, I_4), the defaults give 32 against the exact 8: the
points have no cross moments :math:`E[e_i^2 e_j^2]`). In one dimension the
mean of a quartic is exact only for :math:`c^2 = 3` (Julier's choice
alpha = 1, kappa = 2, whose fourth moment :math:`c^2 \sigma^4` is the
Gaussian's :math:`3 \sigma^4`).

**What the parameters do.** :math:`\alpha` and :math:`\kappa` set one
number, the distance c (the points sit c standard deviations out along
each column of L), and the mean weights depend on c alone; they are separate
parameters only because :math:`W^c_0` involves :math:`\alpha` alone. A small
:math:`\alpha` gives points near m (the UT then tends to a second-order
expansion of g at m) and a large negative :math:`W^m_0`. The term
:math:`1 - \alpha^2` of :math:`W^c_0` gives the centre back part of the
fourth moment that pulling the points in removes (with it, the variance of a
1-D quadratic depends on :math:`\alpha^2 \kappa + \beta` only).
:math:`\beta` adds weight to the central point in the covariance only,
supplying the part of a Gaussian's fourth moment the points miss
(:math:`\beta = 2` when :math:`\kappa = 0`, in one dimension). The
defaults alpha = 1, beta = 2, kappa = 0 give :math:`W^m_0 = 0` and
:math:`W^c_0 = 2`, every weight non-negative in any dimension, but put the
points :math:`\sqrt n` standard deviations out, far from the mean when n is
large (the reason the scaled points have alpha); with beta = 0 they would be
the third-degree spherical cubature rule (Särkkä 2013, chapter 6).
The chapter writes them :math:`\tilde\alpha, \tilde\beta, \tilde\kappa,
\tilde\lambda` (the plain letters have other meanings in the course); the
code keeps filterpy's names ``alpha``, ``beta``, ``kappa``.

Import it as ``bf.ukf``::

    import numpy as np
    import bayesfilt as bf

    sp = bf.ukf.sigma_points([1.0], [[1.0]], alpha=1.0, beta=2.0, kappa=2.0)
    sp.points, sp.mean_weights, sp.cov_weights      # (3, 1), (3,), (3,)

    road = bf.ukf.unscented_transform(lambda x: np.sqrt(x**2 + 4.0), [1.0], [[1.0]],
                                      alpha=1.0, beta=2.0, kappa=2.0)
    road.mean, road.cov                             # (1,), (1, 1)

    model = bf.models.range_bearing()
    xs, ys = bf.models.simulate(model, 60, np.random.default_rng(0),
                                x0=bf.models.RANGE_BEARING_TRUE_START)
    res = bf.ukf.unscented_kalman_filter(model, ys)  # a bf.kalman.FilterResult

**The filter** is the additive-noise UKF of Särkkä (2013), *Bayesian
Filtering and Smoothing*, Algorithm 5.14: chapter 02's prediction and
update with every mean and covariance computed by the UT. The prediction
pushes sigma points of :math:`N(\hat x_{t|t}, P_{t|t})` through f and adds
:math:`G Q G^T`; the update draws *new* sigma points from
:math:`N(\hat x_{t|t-1}, P_{t|t-1})`, pushes them through h, and
conditions the resulting joint Gaussian of :math:`(x_t, y_t)` on
:math:`y_t` (Kay's Theorem 10.2 of chapter 02, ``bf.gaussian.condition``):

.. math::

    S_t = \Sigma_{yy} + R, \qquad K_t = \Sigma_{xy} S_t^{-1}, \qquad
    \hat x_{t|t} = \hat x_{t|t-1} + K_t (y_t - \hat y_{t|t-1}), \qquad
    P_{t|t} = P_{t|t-1} - K_t S_t K_t^T.

The textbook computes the gain directly, :math:`K_t = \Sigma_{xy} S_t^{-1}`.
``bf.ukf`` takes a longer route so that it can reuse ``bf.kalman``'s own
update kernel (the Joseph form, a Cholesky solve, the log-likelihood): it
reads the UT as a *statistical linear regression* (Lefebvre, Bruyninckx &
De Schutter 2002). The slope of the images on the points,
:math:`\bar C = \Sigma_{xy}^T P^{-1}`, plays the part of the measurement
matrix C, and the scatter of the images about that line,
:math:`\Lambda = \Sigma_{yy} - \bar C \Sigma_{xy}`, is added to R. Then
:math:`\bar C P \bar C^T + R + \Lambda = S_t` and :math:`P \bar C^T =
\Sigma_{xy}`, so the Kalman update with :math:`(\bar C, R + \Lambda)` is the
update above, in exact arithmetic. For a linear h the regression line is h
itself and :math:`\Lambda = 0`: the UKF is then the Kalman filter, to
rounding. Two costs of the route:

* it adds a solve with :math:`P = P_{t|t-1}` (with the Cholesky factor that
  drew the points) that the direct gain avoids, and so can lose accuracy
  when P is nearly singular;
* :math:`\Lambda = \sum_j W^c_j \big(\mathcal Y_j - \hat y - \bar C(\mathcal X_j -
  \hat x)\big)\big(\cdot\big)^T` is a weighted sum of squares, positive
  semi-definite when every :math:`W^c_j \ge 0`. A negative :math:`W^c_0`
  (a small alpha, or kappa < 0) can make it indefinite, and the Joseph form
  then no longer guarantees a positive semi-definite :math:`P_{t|t}` (nor
  does :math:`P - K S K^T`); the filter reports the failure at the next
  Cholesky factorisation.

The independent UKF of ``tests/test_ukf.py`` uses the direct gain, so the
test suite's agreement of the two is a real check of this route.

Time convention (seed 000), as in every filter of the course: ``ys[0]``
measures :math:`x_0 \sim N(m_0, P_0)`, so the first step is an update and
``pred_means[0] = m0``; the step from t - 1 to t uses ``f`` at time t - 1 of
a time-varying model (``model.transition_functions(t - 1)``).

**Angles.** A bearing cannot be averaged or subtracted plainly: 3.1 and
-3.1 rad both point near pi, but their plain mean is 0, the opposite
direction. With ``model.residual`` (a residual that
subtracts and wraps, e.g. ``bf.models.range_bearing_residual``) the filter

* averages the images *relative to the central one*,
  :math:`\hat y = \mathcal Y_0 + \sum_j W^m_j\, \mathrm{res}(\mathcal Y_j, \mathcal Y_0)`:
  each bearing is shifted by a multiple of 2 pi to within pi of the central
  one, and the shifted bearings are averaged plainly; then the mean is
  brought back into range with :math:`\mathrm{res}(\hat y, 0)`;
* takes every spread and the innovation with the residual,
  :math:`\mathrm{res}(\mathcal Y_j, \hat y)` and :math:`\mathrm{res}(y_t, \hat y)`.

This mean is meaningful when the sigma points' bearings spread over much
less than pi. When they spread widely, where each one lands depends on
where the cut at :math:`\mathcal Y_0 \pm \pi` falls, and the mean bearing
is only rough: at the first update of Kay's vehicle (prior N(m0, P0) around
the sensor) the bearings are 0.20, 1.37, 2.82 and -1.25 rad around the
central 0.79, and the UT's scatter adds about 0.26 rad^2 to the bearing's
variance (the :math:`\Lambda` above), against R's 0.01.

A circular mean (the angle of :math:`\sum_j W^m_j e^{i \beta_j}`) is not
used: it differs from the weighted mean of the angles when they spread, and
with a negative weight it is no longer an average of directions. When the
bearings spread little the two agree closely (the chapter's half-turn check
cannot tell them apart). The state is averaged plainly (a
``NonlinearGaussian`` has no residual for the state).

**Square root.** The points use the *lower* Cholesky factor, :math:`P = L
L^T`, and its *columns*, as Särkkä does: then the outer points contribute
:math:`\sum_j L_{:,j} L_{:,j}^T = L L^T = P`. filterpy's
``MerweScaledSigmaPoints`` uses ``scipy.linalg.cholesky``, which returns the
*upper* factor :math:`U = L^T` (:math:`P = U^T U`), and its *rows*: the
same vectors, so the same points. (Any S with :math:`S S^T = P` gives the
right first two moments; a different S, such as the symmetric square root,
gives different points and different higher-order errors. So the UT of a
nonlinear g depends on the coordinates the state is written in, not only on
the Gaussian: rotate the state and the points do not simply rotate.) A covariance
that is not positive definite has no Cholesky factor: the functions say so,
naming it, rather than returning NaN.

filterpy map (``filterpy.kalman.UnscentedKalmanFilter`` with
``MerweScaledSigmaPoints(n, alpha, beta, kappa)``): ``fx(x, dt)`` = ``f``,
``hx`` = ``h``, ``Q`` = :math:`G Q G^T`, ``residual_z`` = the model's
residual, ``z_mean_fn`` = the mean of angles above. filterpy's ``predict``
also redraws its sigma points from the predicted moments (Algorithm 5.14);
its first call must be ``update(ys[0])`` with ``ukf.sigmas_f`` set to the
sigma points of :math:`N(m_0, P_0)`, then ``predict(); update(ys[t])``.
"""

from __future__ import annotations

import numbers
from typing import NamedTuple

import numpy as np
from scipy.linalg import cho_solve

from ._checks import (as_covariance, as_inputs, as_matrix, as_noise_gain, as_vector,
                      check_callable, check_output, observation_masks, require_finite)
from .kalman import S_OVERFLOW, FilterResult, Prediction, Update, _correct, _embed

__all__ = ["SigmaPoints", "Transformed", "sigma_points", "unscented_transform", "predict",
           "update", "unscented_kalman_filter"]


class SigmaPoints(NamedTuple):
    """The 2n + 1 sigma points of N(m, P) and their weights (see :func:`sigma_points`).

    points (2n+1, n): row 0 is m, rows 1..n are m + c L[:, j], rows n+1..2n are
    m - c L[:, j]; mean_weights (2n+1,) W^m; cov_weights (2n+1,) W^c.
    """

    points: np.ndarray
    mean_weights: np.ndarray
    cov_weights: np.ndarray


class Transformed(NamedTuple):
    """The unscented transform of N(m, P) through g (see :func:`unscented_transform`).

    mean (k,) y_hat; cov (k, k) Sigma_yy (+ the noise covariance, if given);
    cross_cov (n, k) Sigma_xy, the covariance of x and g(x); sigmas the
    :class:`SigmaPoints`; images (2n+1, k) g of each sigma point.
    """

    mean: np.ndarray
    cov: np.ndarray
    cross_cov: np.ndarray
    sigmas: SigmaPoints
    images: np.ndarray


class _Weights(NamedTuple):
    """W^m (2n+1,), W^c (2n+1,) and the scale c = sqrt(n + lambda) of the points."""

    m: np.ndarray
    c: np.ndarray
    scale: float


# --------------------------------------------------------------------------
# Sigma points and their weights
# --------------------------------------------------------------------------

def _parameter(name: str, value) -> float:
    if isinstance(value, np.ndarray) and value.ndim == 0:
        value = value.item()  # a 0-d array counts as its scalar
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Real):
        raise TypeError(f"{name} must be a real number, got {type(value).__name__} {value!r}")
    value = float(value)
    if not np.isfinite(value):
        raise ValueError(f"{name} must be finite, got {value!r}")
    return value


def _weights(n: int, alpha, beta, kappa) -> _Weights:
    """The weights of the scaled sigma points (Julier 2002; Wan & van der Merwe 2000)."""
    alpha, beta, kappa = (_parameter(k, v) for k, v in
                          (("alpha", alpha), ("beta", beta), ("kappa", kappa)))
    if alpha <= 0:
        raise ValueError(f"alpha must be > 0 (it scales the spread of the sigma points), "
                         f"got {alpha!r}")
    if n + kappa <= 0:
        raise ValueError(f"kappa must be > -n = {-n} (the points sit at sqrt(alpha^2 (n + "
                         f"kappa)) standard deviations), got {kappa!r}")
    # lambda = alpha^2 (n + kappa) - n, written as filterpy writes it (same rounding)
    lam = alpha**2 * (n + kappa) - n
    # W^m_j = W^c_j = 1 / (2 (n + lambda)) for j >= 1
    wm = np.full(2 * n + 1, 0.5 / (n + lam))
    wc = wm.copy()
    # W^m_0 = lambda / (n + lambda);  W^c_0 = W^m_0 + 1 - alpha^2 + beta
    wm[0] = lam / (n + lam)
    wc[0] = lam / (n + lam) + (1.0 - alpha**2 + beta)
    return _Weights(wm, wc, float(np.sqrt(n + lam)))


def _cholesky(what: str, P: np.ndarray) -> np.ndarray:
    """Lower Cholesky factor L of P (P = L L^T); a ValueError that names ``what`` otherwise."""
    try:
        return np.linalg.cholesky(P)
    except np.linalg.LinAlgError:
        eig = np.linalg.eigvalsh(0.5 * (P + P.T)).min() if np.isfinite(P).all() else np.nan
        raise ValueError(f"{what} must be positive definite to draw sigma points (it has no "
                         f"Cholesky factor L with L L^T = {what}): smallest eigenvalue "
                         f"{eig:.3g}") from None


def _points(m: np.ndarray, L: np.ndarray, scale: float) -> np.ndarray:
    """The 2n + 1 points m, m + c L[:, j], m - c L[:, j] as rows, shape (2n+1, n)."""
    # the rows of L^T are the columns of L (filterpy: the rows of its upper factor U = L^T)
    offsets = scale * L.T
    return np.concatenate([m[None, :], m + offsets, m - offsets])


def sigma_points(mean, cov, alpha=1.0, beta=2.0, kappa=0.0) -> SigmaPoints:
    r"""The 2n + 1 scaled sigma points of :math:`N(m, P)` and their weights.

    .. math::

        \mathcal X_0 = m, \quad \mathcal X_{j} = m + c L_{:,j}, \quad
        \mathcal X_{n+j} = m - c L_{:,j}, \qquad c^2 = n + \lambda
        = \alpha^2 (n + \kappa),

        W^m_0 = \frac{\lambda}{n+\lambda}, \quad
        W^c_0 = W^m_0 + 1 - \alpha^2 + \beta, \quad
        W^m_j = W^c_j = \frac{1}{2(n+\lambda)},

    with L the lower Cholesky factor of P (:math:`P = L L^T`; see the module
    docstring for why the columns of L, and filterpy's rows of
    :math:`U = L^T`). Julier (2002); Wan & van der Merwe (2000); Särkkä (2013), eqs.
    (5.72)-(5.75). The chapter writes the parameters
    :math:`\tilde\alpha, \tilde\beta, \tilde\kappa`.

    Parameters
    ----------
    mean : array_like, shape (n,)
        m.
    cov : array_like, shape (n, n)
        P, symmetric positive definite.
    alpha : float
        > 0: spread of the points (c = alpha sqrt(n + kappa) standard deviations).
    beta : float
        Extra weight of the central point in the covariance (2 for a Gaussian).
    kappa : float
        > -n: secondary spread.

    Returns
    -------
    SigmaPoints
        ``points`` (2n+1, n), ``mean_weights`` (2n+1,), ``cov_weights`` (2n+1,).
        The mean weights sum to 1; a weight can be negative (e.g. small alpha).

    Raises
    ------
    ValueError
        On wrong shapes, a ``cov`` that is not positive definite (its smallest
        eigenvalue is named), alpha <= 0 or kappa <= -n.
    TypeError
        If a parameter is not a real number.

    Notes
    -----
    filterpy: ``MerweScaledSigmaPoints(n, alpha, beta, kappa)``,
    ``.sigma_points(mean, cov)``, ``.Wm``, ``.Wc`` (the same numbers).
    """
    m = as_vector("mean", mean)
    n = m.shape[0]
    P = as_covariance("cov", cov, n)
    w = _weights(n, alpha, beta, kappa)
    return SigmaPoints(_points(m, _cholesky("cov", P), w.scale), w.m, w.c)


# --------------------------------------------------------------------------
# The transform
# --------------------------------------------------------------------------

def _mean_and_spread(images: np.ndarray, wm: np.ndarray, residual):
    """Weighted mean of the images (2n+1, k) and their deviations from it.

    Without ``residual``: the plain weighted mean. With it (angles): the mean
    relative to the central image, then normalised by residual(mean, 0).
    """
    if residual is None:
        # y_hat = sum_j W^m_j Y_j
        mean = wm @ images
        return mean, images - mean
    ref = images[0]
    # y_hat = Y_0 + sum_j W^m_j res(Y_j, Y_0): the weighted mean of the angles on the branch
    # around the central image's, where a plain average would fail across the +-pi cut
    mean = ref + wm @ residual(images, ref)
    # back into range, e.g. a bearing into (-pi, pi]: res(y_hat, 0)
    mean = residual(mean, np.zeros_like(mean))
    return mean, residual(images, mean)


def _moments(points, images, x, w: _Weights, residual):
    """y_hat (k,), Sigma_yy (k, k) without noise, Sigma_xy (n, k) of the sigma points' images."""
    y_hat, dy = _mean_and_spread(images, w.m, residual)
    # Sigma_yy = sum_j W^c_j (Y_j - y_hat)(Y_j - y_hat)^T
    Syy = (w.c * dy.T) @ dy
    # Sigma_xy = sum_j W^c_j (X_j - m)(Y_j - y_hat)^T
    Sxy = (w.c * (points - x).T) @ dy
    return y_hat, 0.5 * (Syy + Syy.T), Sxy


def _as_residual(residual):
    if residual is None:
        return None
    check_callable("residual", residual)

    def res(a, b):
        shape = np.broadcast_shapes(np.shape(a), np.shape(b))
        return check_output("residual", residual(np.array(a, float), np.array(b, float)), shape)
    return res


def unscented_transform(fun, mean, cov, alpha=1.0, beta=2.0, kappa=0.0, noise_cov=None,
                        residual=None) -> Transformed:
    r"""Push :math:`N(m, P)` through ``fun`` by sigma points: mean, covariance, cross-covariance.

    .. math::

        \hat y = \sum_j W^m_j \mathcal Y_j, \quad
        \Sigma_{yy} = \sum_j W^c_j (\mathcal Y_j - \hat y)(\mathcal Y_j - \hat y)^T + N, \quad
        \Sigma_{xy} = \sum_j W^c_j (\mathcal X_j - m)(\mathcal Y_j - \hat y)^T,

    with :math:`\mathcal Y_j = g(\mathcal X_j)` and N the optional noise
    covariance (Särkkä 2013, Algorithm 5.12, additive noise). Exact for a
    linear ``fun``; the mean is exact for a quadratic (and a cubic) one.

    Parameters
    ----------
    fun : callable
        g, applied once to all the sigma points: (2n+1, n) -> (2n+1, k), row by
        row (a function of one state that indexes the last axis, ``x[..., 0]``,
        does this); (2n+1,) is read as k = 1.
    mean : array_like, shape (n,)
    cov : array_like, shape (n, n)
        Symmetric positive definite.
    alpha, beta, kappa : float
        As in :func:`sigma_points`.
    noise_cov : array_like, shape (k, k), optional
        Added to :math:`\Sigma_{yy}` (additive noise, e.g. ``G Q G^T`` or ``R``).
    residual : callable, optional
        ``residual(a, b)`` -> a - b on the last axis, wrapped where a component
        is an angle (e.g. ``bf.models.range_bearing_residual``); then the mean
        is taken relative to the central image and every spread with it (see
        the module docstring). ``residual(y, 0)`` must return y normalised.

    Returns
    -------
    Transformed
        ``mean`` (k,), ``cov`` (k, k), ``cross_cov`` (n, k), ``sigmas``,
        ``images`` (2n+1, k).

    Raises
    ------
    ValueError
        On wrong shapes, a ``cov`` that is not positive definite, bad
        parameters, or a ``fun`` that does not return one finite row per point.

    Notes
    -----
    filterpy: ``unscented_transform(sigmas_f, Wm, Wc, noise_cov, mean_fn,
    residual_fn)`` takes the transformed points; it returns no cross-covariance.
    """
    check_callable("fun", fun)
    sp = sigma_points(mean, cov, alpha, beta, kappa)
    m = as_vector("mean", mean)
    n = m.shape[0]
    out = np.asarray(fun(sp.points.copy()), dtype=float)
    if out.ndim == 1 and out.shape[0] == 2 * n + 1:
        out = out[:, None]
    if out.ndim != 2 or out.shape[0] != 2 * n + 1:
        raise ValueError(f"fun must act row by row on the ({2 * n + 1}, {n}) sigma points and "
                         f"return shape ({2 * n + 1}, k), got shape {out.shape}")
    images = check_output("fun", out, out.shape)
    k = images.shape[1]
    res = _as_residual(residual)
    w = _Weights(sp.mean_weights, sp.cov_weights, 0.0)
    y_hat, Syy, Sxy = _moments(sp.points, images, m, w, res)
    if noise_cov is not None:
        Syy = Syy + as_covariance("noise_cov", noise_cov, k)
    return Transformed(y_hat, Syy, Sxy, sp, images)


# --------------------------------------------------------------------------
# The two steps of the filter
# --------------------------------------------------------------------------

def _call(name: str, fun, X: np.ndarray, k: int) -> np.ndarray:
    """fun of all sigma points X (2n+1, n) at once; a wrong shape or a NaN stops here."""
    return check_output(name, fun(X.copy()), (X.shape[0], k))


def _predict(x, P, f, GQGt, w: _Weights) -> Prediction:
    """:func:`predict` without the argument checks (the filter checks once)."""
    n = x.shape[0]
    X = _points(x, _cholesky("the filtered covariance P_{t|t}", P), w.scale)
    Y = _call("f", f, X, n)
    # x_{t+1|t} = sum_j W^m_j f(X_j);  P_{t+1|t} = sum_j W^c_j (.)(.)^T + G Q G^T
    x_pred = w.m @ Y
    dY = Y - x_pred
    P_pred = (w.c * dY.T) @ dY + GQGt
    P_pred = 0.5 * (P_pred + P_pred.T)  # exactly symmetric, as bf.kalman does
    require_finite("ukf.predict", "predicted covariance", P_pred)
    return Prediction(x_pred, P_pred)


S_NOT_PD = ("innovation covariance S = sum_j W^c_j (Y_j - y_hat)(Y_j - y_hat)^T + R is not "
            "positive definite: R needs a positive variance on every measured component, and a "
            "negative weight W^c_0 (from alpha, beta, kappa) can make the sigma points' spread "
            "indefinite")


def _update(x, P, y, h, R, residual, w: _Weights, o=None) -> Update:
    """:func:`update` without the argument checks; ``o`` (m,) bool marks the observed
    components of a partly-missing y (None: all observed)."""
    n, m = x.shape[0], R.shape[0]
    L = _cholesky("the predicted covariance P_{t|t-1}", P)
    # new sigma points, drawn from the prediction (Algorithm 5.14), and their images
    X = _points(x, L, w.scale)
    Y = _call("h", h, X, m)
    y_hat, Syy, Sxy = _moments(X, Y, x, w, residual)
    if o is not None:
        # a missing entry is given its prediction, so that the residual sees finite numbers
        y = np.where(o, y, y_hat)
    # r_t = y_t - y_hat (wrapped by the residual where a component is an angle)
    r = y - y_hat if residual is None else residual(y, y_hat)
    R_o, r_o = R, r
    if o is not None:
        # y_o = h_o(x) + v_o, v_o ~ N(0, R_oo): the observed components' rows and block
        Syy, Sxy, R_o, r_o = Syy[np.ix_(o, o)], Sxy[:, o], R[np.ix_(o, o)], r[o]
    # Statistical linear regression of the images on the points: the slope
    # C = Sigma_xy^T P^{-1} (a Cholesky solve with the factor at hand) and the scatter about
    # it, Lambda = Sigma_yy - C Sigma_xy. Chapter 02's update with (C, R + Lambda) is the
    # UKF's: S = C P C^T + R + Lambda = Sigma_yy + R, K = P C^T S^{-1} = Sigma_xy S^{-1}.
    # (The direct K = Sigma_xy S^{-1} needs no solve with P; this route reuses bf.kalman's
    # Joseph form and log-likelihood. Lambda is PSD only if every W^c_j >= 0.)
    C = cho_solve((L, True), Sxy).T
    Lam = Syy - C @ Sxy
    R_eff = R_o + 0.5 * (Lam + Lam.T)
    with np.errstate(over="ignore", invalid="ignore"):  # an overflow is reported just below
        try:
            x_new, P_new, K, _, S, loglik = _correct(x, P, r_o, C, R_eff, np.eye(n))
        except ValueError as exc:     # S singular, or S overflowed (bf.kalman's message)
            raise ValueError(f"ukf.update: {exc if str(exc) == S_OVERFLOW else S_NOT_PD}") \
                from None
    require_finite("ukf.update", "updated covariance", P_new)
    if o is not None:
        K, r, S = _embed(o, K, r_o, S)
    return Update(x_new, P_new, K, r, S, loglik)


def predict(x, P, f, Q, G=None, alpha=1.0, beta=2.0, kappa=0.0) -> Prediction:
    r"""UKF prediction: the unscented transform of :math:`N(\hat x_{t|t}, P_{t|t})` through f.

    .. math::

        \hat x_{t+1|t} = \sum_j W^m_j f(\mathcal X_j), \qquad
        P_{t+1|t} = \sum_j W^c_j \big(f(\mathcal X_j) - \hat x_{t+1|t}\big)
        \big(f(\mathcal X_j) - \hat x_{t+1|t}\big)^T + G Q G^T,

    with :math:`\mathcal X_j` the sigma points of :math:`N(\hat x_{t|t},
    P_{t|t})` (Särkkä 2013, Algorithm 5.14, prediction).

    Parameters
    ----------
    x : array_like, shape (n,)
        Filtered mean :math:`\hat x_{t|t}`.
    P : array_like, shape (n, n)
        Filtered covariance :math:`P_{t|t}`, positive definite.
    f : callable
        Transition function applied to all sigma points at once,
        (2n+1, n) -> (2n+1, n), row by row (as ``NonlinearGaussian.f``).
    Q : array_like, shape (q, q)
        Process-noise covariance.
    G : array_like, shape (n, q), optional
        Noise gain; identity if omitted. filterpy's ``Q`` is :math:`G Q G^T`.
    alpha, beta, kappa : float
        As in :func:`sigma_points`.

    Returns
    -------
    bf.kalman.Prediction
        ``mean`` (n,) and ``cov`` (n, n).

    Raises
    ------
    ValueError
        On wrong shapes, a P that is not positive definite, bad parameters, or
        an f that does not return (2n+1, n) finite values.
    """
    x = as_vector("x", x)
    n = x.shape[0]
    P = as_covariance("P", P, n)
    check_callable("f", f)
    Q = as_covariance("Q", Q)
    G = as_noise_gain(G, n, Q.shape[0])
    w = _weights(n, alpha, beta, kappa)
    return _predict(x, P, f, G @ Q @ G.T, w)


def update(x, P, y, h, R, alpha=1.0, beta=2.0, kappa=0.0, residual=None) -> Update:
    r"""UKF measurement update: condition the UT's joint Gaussian of :math:`(x_t, y_t)` on y_t.

    With :math:`\mathcal X_j` the sigma points of :math:`N(\hat x_{t|t-1},
    P_{t|t-1})` and :math:`\mathcal Y_j = h(\mathcal X_j)` (Särkkä 2013,
    Algorithm 5.14, update):

    .. math::

        \hat y = \sum_j W^m_j \mathcal Y_j, \quad
        S = \sum_j W^c_j (\mathcal Y_j - \hat y)(\mathcal Y_j - \hat y)^T + R, \quad
        \Sigma_{xy} = \sum_j W^c_j (\mathcal X_j - \hat x_{t|t-1})(\mathcal Y_j - \hat y)^T,

        K = \Sigma_{xy} S^{-1}, \quad \hat x_{t|t} = \hat x_{t|t-1} + K (y - \hat y), \quad
        P_{t|t} = P_{t|t-1} - K S K^T.

    Computed with ``bf.kalman``'s update kernel (see the module docstring).

    Parameters
    ----------
    x : array_like, shape (n,)
        Predicted mean :math:`\hat x_{t|t-1}`.
    P : array_like, shape (n, n)
        Predicted covariance :math:`P_{t|t-1}`, positive definite.
    y : array_like, shape (m,)
        Measurement, finite.
    h : callable
        Measurement function applied to all sigma points at once,
        (2n+1, n) -> (2n+1, m), row by row.
    R : array_like, shape (m, m)
        Measurement-noise covariance.
    alpha, beta, kappa : float
        As in :func:`sigma_points`.
    residual : callable, optional
        ``residual(y, y_pred)``: innovation on the last axis, wrapped for an
        angle (``bf.models.range_bearing_residual``); also used for the mean
        and the spreads of the images (module docstring, "Angles").

    Returns
    -------
    bf.kalman.Update
        ``mean``, ``cov``, ``gain`` K (n, m), ``innovation`` (m,),
        ``innovation_cov`` S (m, m), ``loglik`` :math:`\log N(r; 0, S)`.

    Raises
    ------
    ValueError
        On wrong shapes, a P that is not positive definite, bad parameters, an
        h or residual that returns the wrong shape or NaN, or an S that is not
        positive definite.

    Notes
    -----
    filterpy: set ``ukf.x, ukf.P`` and ``ukf.sigmas_f =
    points.sigma_points(x, P)``, then ``ukf.update(y)``; its ``y``, ``S``,
    ``K`` and ``log_likelihood`` are ``innovation``, ``innovation_cov``,
    ``gain`` and ``loglik``.
    """
    x = as_vector("x", x)
    n = x.shape[0]
    P = as_covariance("P", P, n)
    R = as_covariance("R", R)
    y = as_vector("y", y, R.shape[0])
    check_callable("h", h)
    w = _weights(n, alpha, beta, kappa)
    return _update(x, P, y, h, R, _as_residual(residual), w)


# --------------------------------------------------------------------------
# The whole run
# --------------------------------------------------------------------------

def _check_ys(ys, m: int, where: str):
    """ys (T, m) (a 1-D array when m = 1), with the masks of observed rows and components."""
    if m == 1 and np.ndim(ys) == 1:
        ys = np.asarray(ys)[:, None]  # a scalar measurement per step, as kalman_filter accepts
    ys = as_matrix("ys", ys, (None, m), finite=False)
    try:
        observed, components = observation_masks(ys)
    except ValueError as exc:
        raise ValueError(f"{where}: {exc}") from None
    return ys, observed, components


def _linear_functions(model, us):
    """f (time-indexed, with the known input) and h of a LinearGaussian, on rows of points."""
    A, C, B = model.A, model.C, model.B
    return (lambda t: (lambda X: X @ A.T + (0.0 if us is None else B @ us[t])),
            lambda X: X @ C.T)


def unscented_kalman_filter(model, ys, alpha=1.0, beta=2.0, kappa=0.0, us=None) -> FilterResult:
    r"""Run the additive-noise UKF (Särkkä 2013, Algorithm 5.14) over a whole record.

    Same time convention and result fields as ``bf.kalman.kalman_filter`` and
    ``bf.ekf.extended_kalman_filter``: ``ys[0]`` measures :math:`x_0`, so
    the first step is an update of the prior :math:`N(m_0, P_0)`
    (``pred_means[0] = m0``); afterwards each step is :func:`predict` (the
    transition of a time-varying model at t - 1 to t) then :func:`update`
    with sigma points redrawn from the prediction.

    Missing measurements are NaN. An all-NaN row is only predicted through:
    ``means[t] = pred_means[t]``, NaN innovation and S, zero gain and
    log-likelihood. A partly-NaN row updates with its observed components o:
    the entries o of the sigma points' images, the rows and columns o of R,
    and the log-likelihood of those components; its innovation and S are
    NaN, its gain zero, in the missing components (the residual is called
    with each missing entry of y replaced by its prediction, so it must act
    component by component, as a wrapped bearing does).

    Parameters
    ----------
    model : bf.models.NonlinearGaussian or bf.models.LinearGaussian
        Supplies f, h, Q, R, G, m0, P0 and ``model.residual`` (angles); a
        time-varying model gets the time index of each step through
        ``model.transition_functions(t)``. A ``LinearGaussian`` is filtered
        through f(x) = A x + B u_t, h(x) = C x (the UKF then equals the
        Kalman filter to rounding).
    ys : array_like, shape (T, m)
        Measurements; NaN marks a missing component. (1-D when m = 1.)
    alpha, beta, kappa : float
        The sigma points' parameters (:func:`sigma_points`). The defaults
        1, 2, 0 keep every weight non-negative in any dimension
        (:math:`W^m_0 = 0`, :math:`W^c_0 = 2`), but put the points sqrt(n)
        standard deviations out, far from the mean when n is large.
    us : array_like, shape (T - 1, p), optional
        Known inputs of a ``LinearGaussian`` with B (row t acts from t to t + 1);
        a ``NonlinearGaussian`` takes none.

    Returns
    -------
    bf.kalman.FilterResult
        ``means``, ``covs``, ``pred_means``, ``pred_covs``, ``innovations``,
        ``innovation_covs``, ``gains``, ``step_logliks``, ``loglik`` (the UKF's
        approximation of :math:`\log p(y_0, \dots, y_{T-1})`, exact for a
        linear model), ``observed`` and ``observed_components``.

    Raises
    ------
    TypeError
        If ``model`` is neither model class, or a parameter is not a number.
    ValueError
        On wrong shapes, an inf in ``ys``, bad parameters, ``us`` for a
        ``NonlinearGaussian``, or a step that fails (the message names the
        step t and what failed: a covariance that is not positive definite,
        a function returning NaN, ...).
    """
    from .models import LinearGaussian, NonlinearGaussian  # local: light module loading

    where = "unscented_kalman_filter"
    if not isinstance(model, (NonlinearGaussian, LinearGaussian)):
        raise TypeError(f"{where}: model must be a bf.models.NonlinearGaussian (or "
                        f"LinearGaussian), got {type(model).__name__}")
    n, m = model.state_dim, model.obs_dim
    w = _weights(n, alpha, beta, kappa)
    ys, observed, components = _check_ys(ys, m, where)
    T = ys.shape[0]
    if isinstance(model, LinearGaussian):
        us = as_inputs(model, us, T)
        transition, h = _linear_functions(model, us)
        residual = None
    else:
        if us is not None:
            raise ValueError(f"{where}: us was given, but a NonlinearGaussian takes no control "
                             "input (put a known input into f)")
        transition = lambda t: model.transition_functions(t)[0]  # noqa: E731
        h = model.h
        residual = None if model.residual_fn is None else model.residual
    full = components.all(axis=1)

    means, covs = np.empty((T, n)), np.empty((T, n, n))
    pred_means, pred_covs = np.empty((T, n)), np.empty((T, n, n))
    innovations, innovation_covs = np.full((T, m), np.nan), np.full((T, m, m), np.nan)
    gains, step_logliks = np.zeros((T, n, m)), np.zeros(T)
    GQGt, R = model.G @ model.Q @ model.G.T, model.R
    # x_{0|-1} = m0, P_{0|-1} = P0: ys[0] measures x_0 (seed 000's time convention)
    x, P = model.m0.copy(), model.P0.copy()
    for t in range(T):
        try:
            if t > 0:
                # the step from t - 1 to t (a time-varying model's f depends on it)
                x, P = _predict(x, P, transition(t - 1), GQGt, w)
            pred_means[t], pred_covs[t] = x, P
            if observed[t]:
                up = _update(x, P, ys[t], h, R, residual, w, None if full[t] else components[t])
                x, P = up.mean, up.cov
                innovations[t], innovation_covs[t] = up.innovation, up.innovation_cov
                gains[t], step_logliks[t] = up.gain, up.loglik
        except ValueError as exc:
            hint = ""
            if "positive definite" in str(exc) and min(w.m[0], w.c[0]) < 0:
                hint = (f" (the centre weights W^m_0 = {w.m[0]:.4g}, W^c_0 = {w.c[0]:.4g} of "
                        f"alpha = {alpha}, beta = {beta}, kappa = {kappa}: a negative weight can "
                        "make the UT's covariances indefinite; a larger alpha or kappa avoids it)")
            raise ValueError(f"{where}, step t = {t}: {exc}{hint}") from None
        means[t], covs[t] = x, P
    return FilterResult(means, covs, pred_means, pred_covs, innovations, innovation_covs,
                        gains, step_logliks, float(step_logliks.sum()), observed, components)
