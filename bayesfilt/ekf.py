r"""Extended Kalman filter (확장 칼만 필터): seed 000, section 3.1.

When the transition or the measurement is nonlinear,

.. math::

    x_{t+1} = f(x_t) + G w_t,\quad w_t \sim N(0, Q);\qquad
    y_t = h(x_t) + v_t,\quad v_t \sim N(0, R),

the Kalman equations no longer apply: a Gaussian pushed through ``f`` or
``h`` is not Gaussian. The EKF replaces each function by its first-order
Taylor expansion around the current estimate,

.. math::

    f(x) \approx f(\hat x_{t|t}) + F (x - \hat x_{t|t}),\quad
    F = \left.\frac{\partial f}{\partial x}\right|_{\hat x_{t|t}},\qquad
    h(x) \approx h(\hat x_{t|t-1}) + H (x - \hat x_{t|t-1}),\quad
    H = \left.\frac{\partial h}{\partial x}\right|_{\hat x_{t|t-1}},

and runs the Kalman filter on the linearised system, keeping the nonlinear
functions for the means. Import it as ``bf.ekf``::

    import bayesfilt as bf
    model = bf.models.range_bearing()
    xs, ys = bf.models.simulate(model, 100, np.random.default_rng(0),
                                x0=bf.models.RANGE_BEARING_TRUE_START)
    result = bf.ekf.extended_kalman_filter(model, ys)

Letters: the course's ``F`` and ``H`` are Kay's Jacobians :math:`A[n-1]` and
:math:`H[n]` (filterpy: ``ekf.F`` and the ``HJacobian`` function); ``G`` is
Kay's ``B``; ``R`` is Kay's ``C[n]``; ``P`` is Kay's ``M``. In Kay's
notation the *measurement* is called x[n] and the state s[n].

Use :func:`numerical_jacobian` to check a hand-written Jacobian before
trusting a filter that uses it.
"""

from __future__ import annotations

import numpy as np

from ._checks import (as_array, as_covariance, as_matrix, as_noise_gain, as_vector, check_callable,
                      check_output, observation_masks, require_finite)
from .kalman import FilterResult, Prediction, Update, _correct, _embed, _select

__all__ = ["predict", "update", "extended_kalman_filter", "numerical_jacobian"]

def _call(where: str, name: str, fun, x: np.ndarray, shape: tuple[int, ...]) -> np.ndarray:
    """Evaluate a user function at ``x``; a wrong shape or a NaN stops here, naming it."""
    return check_output(f"{where}: {name}", fun(x.copy()), shape, at=x)


# --------------------------------------------------------------------------
# The two steps
# --------------------------------------------------------------------------

def predict(x, P, f, F, Q, G=None) -> Prediction:
    r"""EKF prediction (예측): propagate the mean through ``f``, the covariance through ``F``.

    Seed 000, section 3.1, "Prediction" and "Minimum Prediction MSE Matrix"
    (Kay: :math:`\hat s[n|n-1] = a(\hat s[n-1|n-1])`,
    :math:`M[n|n-1] = A[n-1] M[n-1|n-1] A^T[n-1] + B Q B^T`):

    .. math::

        \hat x_{t+1|t} = f(\hat x_{t|t}),\qquad
        P_{t+1|t} = F P_{t|t} F^T + G Q G^T,\qquad
        F = \left.\frac{\partial f}{\partial x}\right|_{\hat x_{t|t}}.

    Parameters
    ----------
    x : array_like, shape (n,)
        Filtered mean :math:`\hat x_{t|t}`.
    P : array_like, shape (n, n)
        Filtered covariance :math:`P_{t|t}`.
    f : callable
        Transition function, (n,) -> (n,).
    F : callable
        Its Jacobian, (n,) -> (n, n), evaluated at ``x``.
    Q : array_like, shape (q, q)
        Process-noise covariance.
    G : array_like, shape (n, q), optional
        Noise gain (Kay's B); identity if omitted.

    Returns
    -------
    Prediction
        ``mean`` (n,) and ``cov`` (n, n).

    Raises
    ------
    ValueError
        If ``f`` or ``F`` returns the wrong shape or a non-finite value.

    Notes
    -----
    filterpy: ``ExtendedKalmanFilter.predict()`` computes ``F @ x``, so it is
    only right for a linear ``f``; set ``ekf.F`` to the Jacobian and
    ``ekf.Q`` to ``G Q G^T`` before calling it.
    """
    x = as_vector("x", x)
    n = x.shape[0]
    P = as_covariance("P", P, n)
    check_callable("f", f)
    check_callable("F", F)
    Q = as_covariance("Q", Q)
    G = as_noise_gain(G, n, Q.shape[0])
    return _predict(x, P, f, F, G @ Q @ G.T)


def _predict(x, P, f, F, GQGt) -> Prediction:
    """:func:`predict` without the argument checks (the filter checks once)."""
    n = x.shape[0]
    # The Jacobian is taken at the filtered mean, before it moves (Kay's A[n-1]).
    Fx = _call("ekf.predict", "Jacobian F", F, x, (n, n))
    # x_{t+1|t} = f(x_{t|t}): the mean goes through the nonlinear function itself.
    x_pred = _call("ekf.predict", "f", f, x, (n,))
    # P_{t+1|t} = F P F^T + G Q G^T
    with np.errstate(over="ignore", invalid="ignore"):  # an overflow is reported just below
        P_pred = Fx @ P @ Fx.T + GQGt
    P_pred = 0.5 * (P_pred + P_pred.T)  # remove rounding asymmetry, as bf.kalman does
    require_finite("ekf.predict", "predicted covariance F P F^T + G Q G^T", P_pred)
    return Prediction(x_pred, P_pred)


def update(x, P, y, h, H, R, residual=None) -> Update:
    r"""EKF measurement update (측정 업데이트) with the Jacobian ``H`` at the predicted mean.

    Seed 000, section 3.1, "Kalman Gain Matrix", "Correction" and "Minimum
    MSE Matrix", in the course letters:

    .. math::

        S = H P H^T + R,\qquad K = P H^T S^{-1},\qquad
        \hat x_{t|t} = \hat x_{t|t-1} + K\,(y_t - h(\hat x_{t|t-1})),

        P_{t|t} = (I - K H) P (I - K H)^T + K R K^T,

    with :math:`H = \partial h / \partial x` at :math:`\hat x_{t|t-1}`.
    The seed (after Kay) writes :math:`M[n|n] = (I - K H) M[n|n-1]`; the
    Joseph form used here is algebraically equal for the optimal gain K; it is
    a sum of two positive semi-definite terms for *any* gain, so it avoids the
    cancellation that can make :math:`P - KHP` indefinite under rounding
    (see ``bf.kalman.update`` for what it does and does not guarantee;
    filterpy uses it too).

    Parameters
    ----------
    x : array_like, shape (n,)
        Predicted mean :math:`\hat x_{t|t-1}`.
    P : array_like, shape (n, n)
        Predicted covariance :math:`P_{t|t-1}`.
    y : array_like, shape (m,)
        Measurement :math:`y_t` (finite; a missing measurement is simply not
        passed to ``update``).
    h : callable
        Measurement function, (n,) -> (m,).
    H : callable
        Its Jacobian, (n,) -> (m, n), evaluated at ``x``.
    R : array_like, shape (m, m)
        Measurement-noise covariance.
    residual : callable, optional
        ``residual(y, y_pred)`` -> innovation (m,); defaults to
        ``y - y_pred``. An angle needs wrapping, e.g.
        ``bf.models.range_bearing_residual``.

    Returns
    -------
    Update
        ``mean``, ``cov``, ``gain`` K (n, m), ``innovation`` (m,),
        ``innovation_cov`` S (m, m) and ``loglik``
        :math:`\log N(\text{innovation}; 0, S)`.

    Raises
    ------
    ValueError
        If ``h``, ``H`` or ``residual`` returns the wrong shape or a
        non-finite value, or if S is singular.

    Notes
    -----
    filterpy: ``ExtendedKalmanFilter.update(y, HJacobian=H, Hx=h, R=R,
    residual=residual)``.
    """
    x = as_vector("x", x)
    n = x.shape[0]
    P = as_covariance("P", P, n)
    R = as_covariance("R", R)
    m = R.shape[0]
    y = as_vector("y", y, m)
    check_callable("h", h)
    check_callable("H", H)
    if residual is not None:
        check_callable("residual", residual)
    return _update(x, P, y, h, H, R, residual)


def _update(x, P, y, h, H, R, residual, o=None) -> Update:
    """:func:`update` without the argument checks (the filter checks once).

    ``o`` (m,) bool, if given, marks the observed components of ``y`` (the
    others may be NaN): the update then uses the rows of h and H and the
    rows and columns of R that o selects, and returns full-shape fields
    (see ``bf.kalman.FilterResult`` for what a missing component records).
    """
    n, m = x.shape[0], y.shape[0]
    Hx = _call("ekf.update", "Jacobian H", H, x, (m, n))
    y_pred = _call("ekf.update", "h", h, x, (m,))
    if o is not None:
        # a missing component is given the predicted value, so that residual() sees
        # finite numbers (0 there for a component-wise residual); it is then dropped
        y = np.where(o, y, y_pred)
    if residual is None:
        innovation = y - y_pred
    else:
        innovation = _call("ekf.update", "residual",
                           lambda _: residual(y.copy(), y_pred.copy()), x, (m,))
    Hx_o, R_o, r = Hx, R, innovation
    if o is not None:
        # y_o = h_o(x) + v_o, v_o ~ N(0, R_oo): the rows of H and the block of R of o
        (Hx_o, R_o), r = _select(o, Hx, R), innovation[o]
    # The update itself is the Kalman filter's, with the Jacobian H in place of C:
    # S = H P H^T + R, K = P H^T S^{-1}, x + K r and the Joseph-form covariance.
    with np.errstate(over="ignore", invalid="ignore"):  # an overflow is reported just below
        try:
            x_new, P_new, K, _, S, loglik = _correct(x, P, r, Hx_o, R_o, np.eye(n))
        except ValueError as exc:
            raise ValueError(f"ekf.update: {exc}") from None
    require_finite("ekf.update", "updated covariance", P_new)
    if o is not None:
        K, innovation, S = _embed(o, K, r, S)
    return Update(x_new, P_new, K, innovation, S, loglik)


# --------------------------------------------------------------------------
# The whole run
# --------------------------------------------------------------------------

def extended_kalman_filter(model, ys) -> FilterResult:
    r"""Run the EKF over all measurements of a :class:`bf.models.NonlinearGaussian`.

    Same time convention and result fields as ``bf.kalman.kalman_filter``:
    ``ys[0]`` measures :math:`x_0`, so the first step is an update of the
    prior :math:`N(m_0, P_0)` (``pred_means[0] = m0``); afterwards each step
    is :func:`predict` then :func:`update`. A row of ``ys`` that is all NaN is
    a missing measurement: the prediction is kept (``means[t] =
    pred_means[t]``), the innovation is NaN, the gain and the log-likelihood
    contribution are zero. A row with some NaN components updates with the
    observed components o only: the entries o of :math:`h` and the
    rows o of its Jacobian H, the rows and columns o of R
    (``bf.kalman.select_observed``), and the log-likelihood of those
    components. The innovation of a partly-NaN row is
    ``model.residual(y, h(x))`` with each missing entry of y replaced by its
    prediction, then NaN in the missing components: ``residual_fn`` must act
    component by component (as a wrapped bearing does).

    Parameters
    ----------
    model : bf.models.NonlinearGaussian
        Supplies ``f``, ``F``, ``h``, ``H``, ``Q``, ``R``, ``G``, ``m0``,
        ``P0`` and ``model.residual``. A time-varying model
        (``time_varying=True``, e.g. ``bf.models.ungm()``) gets the time index
        of each step through ``model.transition_functions(t)``. Wrap a linear model with
        ``bf.models.to_nonlinear`` (the EKF then equals the Kalman filter).
    ys : array_like, shape (T, m)
        Measurements; NaN marks a missing component.

    Returns
    -------
    bf.kalman.FilterResult
        ``means``, ``covs``, ``pred_means``, ``pred_covs``, ``innovations``,
        ``innovation_covs``, ``gains``, ``step_logliks``, ``loglik``,
        ``observed`` and ``observed_components``, as in
        ``bf.kalman.kalman_filter``. ``loglik`` is the EKF's *approximation*
        of :math:`\log p(y_0, \dots, y_{T-1})` (exact only for a linear
        model).

    Raises
    ------
    ValueError
        If ``ys`` contains inf, or if a step fails (the message names the
        step t and the function at fault).
    """
    from .models import NonlinearGaussian  # local import keeps module loading light

    where = "extended_kalman_filter"
    if not isinstance(model, NonlinearGaussian):
        raise TypeError(f"{where}: model must be a bf.models.NonlinearGaussian, got "
                        f"{type(model).__name__} (wrap a linear model with "
                        f"bf.models.to_nonlinear)")
    n, m = model.state_dim, model.obs_dim
    if m == 1 and np.ndim(ys) == 1:
        ys = np.asarray(ys)[:, None]  # a scalar measurement per step, as kalman_filter accepts
    ys = as_matrix("ys", ys, (None, m), finite=False)
    T = ys.shape[0]
    try:
        observed, components = observation_masks(ys)
    except ValueError as exc:
        raise ValueError(f"{where}: {exc}") from None
    full = components.all(axis=1)

    means, covs = np.empty((T, n)), np.empty((T, n, n))
    pred_means, pred_covs = np.empty((T, n)), np.empty((T, n, n))
    innovations, innovation_covs = np.full((T, m), np.nan), np.full((T, m, m), np.nan)
    gains, step_logliks = np.zeros((T, n, m)), np.zeros(T)
    # The model checked its matrices on construction; the loop only checks what
    # the user functions return.
    GQGt = model.G @ model.Q @ model.G.T
    x, P = model.m0.copy(), model.P0.copy()
    for t in range(T):
        try:
            if t > 0:
                # the step from t - 1 to t (a time-varying model's f and F depend on it)
                f, F = model.transition_functions(t - 1)
                x, P = _predict(x, P, f, F, GQGt)
            pred_means[t], pred_covs[t] = x, P
            if observed[t]:
                up = _update(x, P, ys[t], model.h, model.H, model.R, model.residual,
                             None if full[t] else components[t])
                x, P = up.mean, up.cov
                innovations[t], innovation_covs[t] = up.innovation, up.innovation_cov
                gains[t], step_logliks[t] = up.gain, up.loglik
        except ValueError as exc:
            raise ValueError(f"{where}, step t = {t}: {exc}") from exc
        means[t], covs[t] = x, P
    return FilterResult(means, covs, pred_means, pred_covs, innovations, innovation_covs,
                        gains, step_logliks, float(step_logliks.sum()), observed, components)


# --------------------------------------------------------------------------
# Checking Jacobians
# --------------------------------------------------------------------------

def numerical_jacobian(fun, x, step=None) -> np.ndarray:
    r"""Jacobian of ``fun`` at ``x`` by central differences, shape (k, n).

    .. math::

        J_{:, i} \approx \frac{\mathrm{fun}(x + \delta_i e_i) - \mathrm{fun}(x - \delta_i e_i)}
        {2 \delta_i},

    with the truncation error :math:`O(\delta^2)`. The default step
    :math:`\delta_i = \epsilon^{1/3} \max(1, |x_i|)` (about
    :math:`6 \times 10^{-6}`) balances truncation against rounding: the error
    is of order :math:`\epsilon^{2/3}` times the scale of the third
    derivative, typically 1e-10 relative for smooth functions of moderate
    curvature (bound it by 1e-8 in a test), not machine precision.

    Parameters
    ----------
    fun : callable
        (n,) -> (k,) (or a scalar, treated as k = 1).
    x : array_like, shape (n,)
        Point of evaluation.
    step : float or array_like, shape (n,), optional
        Step(s) :math:`\delta_i > 0`.

    Returns
    -------
    ndarray, shape (k, n)

    Notes
    -----
    A function with a jump, such as a bearing ``atan2`` on the negative
    x-axis, has no derivative there; differencing across the jump gives a
    huge number. Evaluate away from the cut.
    """
    where = "numerical_jacobian"
    check_callable("fun", fun)
    x = as_vector("x", x)
    n = x.shape[0]
    if step is None:
        steps = np.cbrt(np.finfo(float).eps) * np.maximum(1.0, np.abs(x))
    else:
        steps = as_array("step", step)
        steps = as_vector("step", np.broadcast_to(steps, (n,)) if steps.ndim == 0 else steps, n)
        if not np.all(steps > 0):
            raise ValueError(f"step must be > 0, got {np.array2string(steps, precision=4)}")

    def g(z):  # a scalar output counts as a vector of length 1
        return np.atleast_1d(np.asarray(fun(z), dtype=float))

    f0 = g(x.copy())
    if f0.ndim != 1:
        raise ValueError(f"{where}: fun must return a vector (k,), got shape {f0.shape}")
    _call(where, "fun", g, x, f0.shape)
    J = np.empty((f0.shape[0], n))
    for i in range(n):
        up, down = x.copy(), x.copy()
        up[i] += steps[i]
        down[i] -= steps[i]
        # Divide by the step actually taken (x + d may round), not by 2 d.
        J[:, i] = ((_call(where, "fun", g, up, f0.shape) - _call(where, "fun", g, down, f0.shape))
                   / (up[i] - down[i]))
    return J
