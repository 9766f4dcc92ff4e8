"""Tests of bf.ekf against independent references.

References: filterpy 2.0.0's ExtendedKalmanFilter and KalmanFilter, closed-form
Jacobians, central differences, and the seed's own (I - K H) P form.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from filterpy.kalman import ExtendedKalmanFilter, KalmanFilter

import bayesfilt as bf

TOL = dict(rtol=1e-9, atol=1e-9)


# --------------------------------------------------------------------------
# Models used below
# --------------------------------------------------------------------------

def pendulum(dt=0.1, g=9.81):
    """Nonlinear transition AND measurement: angle/rate, measured by sin(angle) and the rate."""

    def f(x):
        x = np.asarray(x, float)
        return np.stack([x[..., 0] + dt * x[..., 1], x[..., 1] - dt * g * np.sin(x[..., 0])], -1)

    def F(x):
        return np.array([[1.0, dt], [-dt * g * np.cos(x[0]), 1.0]])

    def h(x):
        x = np.asarray(x, float)
        return np.stack([np.sin(x[..., 0]), x[..., 1]], -1)

    def H(x):
        return np.array([[np.cos(x[0]), 0.0], [0.0, 1.0]])

    return bf.models.NonlinearGaussian(f=f, F=F, h=h, H=H, Q=np.array([[1e-3]]),
                                       R=np.diag([0.05, 0.2]), m0=np.array([1.0, 0.0]),
                                       P0=np.diag([0.3, 0.5]), G=np.array([[0.0], [1.0]]))


class _FilterpyEKF(ExtendedKalmanFilter):
    """filterpy's EKF with the nonlinear mean prediction its docs ask users to add."""

    def __init__(self, model):
        super().__init__(dim_x=model.state_dim, dim_z=model.obs_dim)
        self.model = model
        self.x = model.m0.copy()
        self.P = model.P0.copy()
        self.R = model.R.copy()
        self.Q = model.G @ model.Q @ model.G.T  # filterpy has no noise gain G

    def predict_x(self, u=0):
        self.x = self.model.f(self.x)


def run_filterpy(model, ys, residual=np.subtract):
    fp = _FilterpyEKF(model)
    out = {k: [] for k in ("means", "covs", "pred_means", "pred_covs", "gains",
                           "innovations", "innovation_covs", "step_logliks")}
    for t, y in enumerate(ys):
        if t > 0:
            fp.F = model.F(fp.x)  # Jacobian at the filtered mean, before predict moves x
            fp.predict()
        out["pred_means"].append(fp.x.copy())
        out["pred_covs"].append(fp.P.copy())
        fp.update(y, HJacobian=model.H, Hx=model.h, residual=residual)
        for key, value in (("means", fp.x), ("covs", fp.P), ("gains", fp.K),
                           ("innovations", fp.y), ("innovation_covs", fp.S),
                           ("step_logliks", fp.log_likelihood)):
            out[key].append(np.copy(value))
    return {k: np.array(v) for k, v in out.items()}


def independent_bearing_residual(y, y_pred):
    """Range-bearing residual for the filterpy reference, wrapped independently of bayesfilt:
    the bearing difference is the angle of the unit complex number exp(i d), in (-pi, pi]."""
    d = np.asarray(y, float) - np.asarray(y_pred, float)
    d[1] = np.angle(np.exp(1j * d[1]))
    return d


@pytest.fixture(scope="module")
def tracking_run():
    model = bf.models.range_bearing()
    sim = bf.models.simulate(model, 100, np.random.default_rng(1),
                             x0=bf.models.RANGE_BEARING_TRUE_START)
    return model, sim


# --------------------------------------------------------------------------
# Agreement with filterpy
# --------------------------------------------------------------------------

def test_matches_filterpy_on_range_bearing(tracking_run):
    model, sim = tracking_run
    ours = bf.ekf.extended_kalman_filter(model, sim.ys)
    ref = run_filterpy(model, sim.ys, residual=independent_bearing_residual)
    for key, value in ref.items():
        np.testing.assert_allclose(getattr(ours, key), value, **TOL, err_msg=key)
    assert ours.loglik == pytest.approx(ref["step_logliks"].sum(), rel=1e-10)
    assert ours.observed.all()


def test_matches_filterpy_with_nonlinear_transition():
    model = pendulum()
    sim = bf.models.simulate(model, 60, np.random.default_rng(2), x0=np.array([1.2, 0.0]))
    ours = bf.ekf.extended_kalman_filter(model, sim.ys)
    ref = run_filterpy(model, sim.ys)
    for key, value in ref.items():
        np.testing.assert_allclose(getattr(ours, key), value, **TOL, err_msg=key)


def test_single_steps_match_filterpy():
    model = pendulum()
    x, P = np.array([0.4, -0.3]), np.array([[0.2, 0.05], [0.05, 0.1]])
    fp = _FilterpyEKF(model)
    fp.x, fp.P, fp.F = x.copy(), P.copy(), model.F(x)
    fp.predict()
    pred = bf.ekf.predict(x, P, model.f, model.F, model.Q, model.G)
    np.testing.assert_allclose(pred.mean, fp.x, **TOL)
    np.testing.assert_allclose(pred.cov, fp.P, **TOL)
    y = np.array([0.1, -0.5])
    fp.update(y, HJacobian=model.H, Hx=model.h)
    up = bf.ekf.update(pred.mean, pred.cov, y, model.h, model.H, model.R)
    np.testing.assert_allclose(up.mean, fp.x, **TOL)
    np.testing.assert_allclose(up.cov, fp.P, **TOL)
    np.testing.assert_allclose(up.gain, fp.K, **TOL)
    assert up.loglik == pytest.approx(fp.log_likelihood, rel=1e-10)


def test_joseph_form_equals_seed_form():
    """Seed 000: M[n|n] = (I - K H) M[n|n-1]; equal to the Joseph form for the optimal K."""
    model = pendulum()
    x, P = np.array([0.4, -0.3]), np.array([[0.2, 0.05], [0.05, 0.1]])
    up = bf.ekf.update(x, P, np.array([0.1, -0.5]), model.h, model.H, model.R)
    Hx = model.H(x)
    S = Hx @ P @ Hx.T + model.R
    K = P @ Hx.T @ np.linalg.inv(S)
    np.testing.assert_allclose(up.cov, (np.eye(2) - K @ Hx) @ P, rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(up.mean, x + K @ (np.array([0.1, -0.5]) - model.h(x)), **TOL)


# --------------------------------------------------------------------------
# On a linear model the EKF is the Kalman filter
# --------------------------------------------------------------------------

def _linear_ys():
    model = bf.models.damped_particle()
    sim = bf.models.simulate(model, 50, np.random.default_rng(3))
    ys = sim.ys.copy()
    ys[[0, 7, 8, 30]] = np.nan  # missing measurements, including the first
    return model, ys


def test_equals_filterpy_kalman_filter_on_linear_model():
    model, ys = _linear_ys()
    ours = bf.ekf.extended_kalman_filter(bf.models.to_nonlinear(model), ys)
    kf = KalmanFilter(dim_x=4, dim_z=2)
    kf.x, kf.P = model.m0.copy(), model.P0.copy()
    kf.F, kf.H, kf.R = model.A.copy(), model.C.copy(), model.R.copy()
    kf.Q = model.G @ model.Q @ model.G.T
    for t, y in enumerate(ys):
        if t > 0:
            kf.predict()
        np.testing.assert_allclose(ours.pred_means[t], kf.x, **TOL)
        np.testing.assert_allclose(ours.pred_covs[t], kf.P, **TOL)
        kf.update(None if np.isnan(y).all() else y)
        np.testing.assert_allclose(ours.means[t], kf.x, **TOL)
        np.testing.assert_allclose(ours.covs[t], kf.P, **TOL)
    assert ours.observed.tolist() == [not np.isnan(y).all() for y in ys]
    missing = ~ours.observed
    assert np.isnan(ours.innovations[missing]).all()
    assert np.isnan(ours.innovation_covs[missing]).all()
    assert (ours.gains[missing] == 0).all() and (ours.step_logliks[missing] == 0).all()
    np.testing.assert_array_equal(ours.means[missing], ours.pred_means[missing])


def test_equals_bayesfilt_kalman_filter_on_linear_model():
    model, ys = _linear_ys()
    ours = bf.ekf.extended_kalman_filter(bf.models.to_nonlinear(model), ys)
    ref = bf.kalman.kalman_filter(model, ys)
    for key in ref._fields:
        np.testing.assert_allclose(np.asarray(getattr(ours, key), float),
                                   np.asarray(getattr(ref, key), float),
                                   rtol=1e-9, atol=1e-9, err_msg=key)


def test_time_convention_without_measurements():
    """ys[0] measures x_0: pred_means[0] is the prior, and with no data the mean follows f."""
    model = pendulum()
    ys = np.full((5, 2), np.nan)
    res = bf.ekf.extended_kalman_filter(model, ys)
    np.testing.assert_array_equal(res.pred_means[0], model.m0)
    np.testing.assert_array_equal(res.pred_covs[0], model.P0)
    x = model.m0.copy()
    for t in range(5):
        np.testing.assert_allclose(res.means[t], x, **TOL)
        x = model.f(x)
    assert res.loglik == 0.0 and not res.observed.any()


# --------------------------------------------------------------------------
# Jacobians
# --------------------------------------------------------------------------

def test_numerical_jacobian_against_closed_form():
    def fun(x):
        return np.array([x[0] ** 2 * x[1], np.exp(x[1]) + np.sin(x[2]), x[0] * x[2]])

    x = np.array([1.5, -0.7, 2.0])
    exact = np.array([[2 * x[0] * x[1], x[0] ** 2, 0.0],
                      [0.0, np.exp(x[1]), np.cos(x[2])],
                      [x[2], 0.0, x[0]]])
    np.testing.assert_allclose(bf.ekf.numerical_jacobian(fun, x), exact, rtol=1e-8, atol=1e-9)
    assert bf.ekf.numerical_jacobian(lambda z: z @ z, x).shape == (1, 3)  # scalar output
    coarse = bf.ekf.numerical_jacobian(fun, x, step=1e-2)  # O(step^2) truncation error
    assert 1e-7 < np.abs(coarse - exact).max() < 1e-3


@pytest.mark.parametrize("which", ["range_bearing", "damped_particle", "pendulum"])
def test_shipped_jacobians_match_central_differences(which):
    model = {"range_bearing": bf.models.range_bearing,
             "damped_particle": lambda: bf.models.to_nonlinear(bf.models.damped_particle()),
             "pendulum": pendulum}[which]()
    rng = np.random.default_rng(4)
    for x in rng.normal(scale=5.0, size=(20, model.state_dim)):
        if which == "range_bearing" and (x[0] < 0 and abs(x[1]) < 0.5 or np.hypot(x[0], x[1]) < 0.5):
            continue  # away from the sensor and from the bearing's jump on the negative x-axis
        np.testing.assert_allclose(model.F(x), bf.ekf.numerical_jacobian(model.f, x),
                                   rtol=1e-7, atol=1e-8, err_msg="F")
        np.testing.assert_allclose(model.H(x), bf.ekf.numerical_jacobian(model.h, x),
                                   rtol=1e-7, atol=1e-8, err_msg="H")


def test_range_bearing_jacobian_closed_form():
    """Hand derivation: dR/dr = r/R, dbeta/d(rx, ry) = (-ry, rx)/R^2."""
    model = bf.models.range_bearing()
    rx, ry = -3.0, 4.0
    expected = np.array([[rx / 5, ry / 5, 0, 0], [-ry / 25, rx / 25, 0, 0]])
    np.testing.assert_allclose(model.H(np.array([rx, ry, 0.3, 0.1])), expected, rtol=1e-12)


# --------------------------------------------------------------------------
# Bearing wrapping: a target crossing the negative x-axis
# --------------------------------------------------------------------------

def _crossing_run():
    model = bf.models.range_bearing(m0=(-10.0, 5.0, 0.0, 0.0), prior_var=4.0)
    x0 = np.array([-10.0, 5.0, 0.0, -0.2])  # xi_y = 0 (bearing +pi -> -pi) at t = 25
    sim = bf.models.simulate(model, 60, np.random.default_rng(5), x0=x0)
    return model, sim


def test_bearing_wrapped_across_negative_x_axis():
    model, sim = _crossing_run()
    beta = np.arctan2(sim.xs[:, 1], sim.xs[:, 0])
    assert beta[20] > 2.9 and beta[30] < -2.9  # the test really crosses the cut
    res = bf.ekf.extended_kalman_filter(model, sim.ys)
    err = np.hypot(*(res.means[:, :2] - sim.xs[:, :2]).T)
    assert err[10:].max() < 2.0
    assert np.abs(res.innovations[:, 1]).max() < 1.0  # no 2 pi jumps reach the update


def test_matches_filterpy_across_negative_x_axis():
    """The crossing run against filterpy with its own bearing wrap: every field agrees,
    including the innovations at the steps where the measured bearing jumps by 2 pi."""
    model, sim = _crossing_run()
    jumps = np.abs(np.diff(sim.ys[:, 1])) > np.pi
    assert jumps.any()  # the measured bearing really jumps from +pi to -pi (or back)
    ours = bf.ekf.extended_kalman_filter(model, sim.ys)
    ref = run_filterpy(model, sim.ys, residual=independent_bearing_residual)
    for key, value in ref.items():
        np.testing.assert_allclose(getattr(ours, key), value, **TOL, err_msg=key)
    assert ours.loglik == pytest.approx(ref["step_logliks"].sum(), rel=1e-10)


def test_unwrapped_bearing_residual_fails():
    model, sim = _crossing_run()
    naive = dataclasses.replace(model, residual_fn=None)  # plain y - h(x)
    res = bf.ekf.extended_kalman_filter(naive, sim.ys)
    err = np.hypot(*(res.means[:, :2] - sim.xs[:, :2]).T)
    assert err[:20].max() < 2.0  # fine before the crossing ...
    assert err[25:].max() > 10.0  # ... lost after it
    assert np.abs(res.innovations[:, 1]).max() > 5.0  # a 2 pi "innovation"


# --------------------------------------------------------------------------
# Bad inputs
# --------------------------------------------------------------------------

def _ok(x):
    return np.asarray(x, float)


X, P = np.array([1.0, 2.0]), np.eye(2)
Q2, R1 = 0.1 * np.eye(2), np.array([[0.5]])


def h1(x):
    return np.array([x[0] * x[1]])


def H1(x):
    return np.array([[x[1], x[0]]])


@pytest.mark.parametrize("kwargs, exc, match", [
    (dict(F=lambda x: np.eye(3)), ValueError, r"Jacobian F must return shape \(2, 2\)"),
    (dict(F=lambda x: np.full((2, 2), np.nan)), ValueError, "Jacobian F returned non-finite"),
    (dict(f=lambda x: x[:1]), ValueError, r"f must return shape \(2,\)"),
    (dict(f=lambda x: np.array([np.inf, 0.0])), ValueError, "f returned non-finite"),
    (dict(F=np.eye(2)), TypeError, "F must be callable"),
    (dict(P=np.eye(3)), ValueError, r"P must have shape \(2, 2\)"),
    (dict(Q=np.eye(3)), ValueError, r"Q must have shape \(2, 2\) when G is omitted"),
    (dict(Q=np.eye(1), G=np.ones((3, 1))), ValueError, r"G must have shape \(2, 1\)"),
    (dict(x=[1.0, np.nan]), ValueError, "x must be finite"),
])
def test_predict_bad_inputs(kwargs, exc, match):
    args = dict(x=X, P=P, f=_ok, F=lambda x: np.eye(2), Q=Q2, G=None) | kwargs
    with pytest.raises(exc, match=match):
        bf.ekf.predict(**args)


@pytest.mark.parametrize("kwargs, exc, match", [
    (dict(H=lambda x: np.ones((2, 2))), ValueError,
     r"ekf.update: Jacobian H must return shape \(1, 2\)"),
    (dict(H=lambda x: np.array([[np.nan, 1.0]])), ValueError,
     "ekf.update: Jacobian H returned non-finite"),
    (dict(h=lambda x: np.array([np.nan * x[0]])), ValueError, "ekf.update: h returned non-finite"),
    (dict(h=lambda x: x), ValueError, r"h must return shape \(1,\)"),
    (dict(residual=lambda y, yp: np.zeros(3)), ValueError, r"residual must return shape \(1,\)"),
    (dict(y=[1.0, 2.0]), ValueError, r"y must have shape \(1,\)"),
    (dict(R=np.array([[-1.0]])), ValueError, "R must be positive semi-definite"),
    (dict(H=lambda x: np.zeros((1, 2)), R=np.zeros((1, 1))), ValueError,
     "innovation covariance .* singular"),
    (dict(h="h"), TypeError, "h must be callable"),
])
def test_update_bad_inputs(kwargs, exc, match):
    args = dict(x=X, P=P, y=[1.5], h=h1, H=H1, R=R1, residual=None) | kwargs
    with pytest.raises(exc, match=match):
        bf.ekf.update(**args)


def test_filter_bad_inputs():
    model = pendulum()
    with pytest.raises(TypeError, match="model must be a bf.models.NonlinearGaussian, got "
                                       "LinearGaussian .wrap a linear model with "
                                       "bf.models.to_nonlinear"):
        bf.ekf.extended_kalman_filter(bf.models.damped_particle(), np.zeros((3, 2)))
    with pytest.raises(ValueError, match=r"ys must have shape \(\?, 2\), got shape \(3, 3\)"):
        bf.ekf.extended_kalman_filter(model, np.zeros((3, 3)))
    with pytest.raises(ValueError, match=r"extended_kalman_filter: ys must be finite or NaN "
                                         r"\(missing\), got inf at index \(1, 1\)"):
        bf.ekf.extended_kalman_filter(model, np.array([[0.0, 0.0], [np.nan, -np.inf]]))
    with pytest.raises(ValueError, match=r"got inf at index \(0, 0\)"):
        bf.ekf.extended_kalman_filter(model, np.array([[np.inf, 0.0]]))
    with pytest.raises(ValueError, match="ys must (have at least one row|not be empty)"):
        bf.ekf.extended_kalman_filter(model, np.zeros((0, 2)))


def test_filter_names_step_and_function_when_a_jacobian_breaks():
    base = pendulum()

    def H(x):  # fine at m0 (the model constructor checks it there), NaN later
        return base.H(x) if x[1] > -0.3 else np.full((2, 2), np.nan)

    model = dataclasses.replace(base, H=H)
    ys = np.tile([0.0, -1.0], (10, 1))  # a falling rate drives x[1] below -0.3
    with pytest.raises(ValueError, match=r"extended_kalman_filter, step t = \d+: "
                                         r"ekf.update: Jacobian H returned non-finite"):
        bf.ekf.extended_kalman_filter(model, ys)


def test_numerical_jacobian_bad_inputs():
    with pytest.raises(TypeError, match="fun must be callable"):
        bf.ekf.numerical_jacobian(None, [1.0])
    with pytest.raises(ValueError, match="step must be > 0"):
        bf.ekf.numerical_jacobian(np.sin, [1.0, 2.0], step=0.0)
    with pytest.raises(ValueError, match="step must have shape"):
        bf.ekf.numerical_jacobian(np.sin, [1.0, 2.0], step=[1e-3] * 3)
    with pytest.raises(ValueError, match="numerical_jacobian: fun returned non-finite"):
        bf.ekf.numerical_jacobian(lambda x: np.where(x > 0.5, x, np.nan), [0.0, 1.0])
    with pytest.raises(ValueError, match="fun must return a vector"):
        bf.ekf.numerical_jacobian(lambda x: np.outer(x, x), [1.0, 2.0])


def test_overflow_is_reported_not_returned():
    with pytest.raises(ValueError, match="ekf.predict: predicted covariance .* overflowed"):
        bf.ekf.predict(X, P, _ok, lambda x: 1e200 * np.eye(2), Q2)
    with pytest.raises(ValueError, match="ekf.update: innovation covariance .* overflowed"):
        bf.ekf.update(X, P, [1.5], h1, lambda x: np.array([[1e200, 0.0]]), R1)


def test_scalar_measurements_accepted_as_a_vector_and_bad_steps_named():
    model = bf.models.to_nonlinear(bf.models.LinearGaussian(A=0.9, C=1.0, Q=0.1, R=1.0, m0=0.0, P0=1.0))
    ys = np.array([0.1, -0.2, 0.3])
    np.testing.assert_allclose(bf.ekf.extended_kalman_filter(model, ys).means,
                               bf.ekf.extended_kalman_filter(model, ys[:, None]).means)
    with pytest.raises(TypeError, match="step must be an array of real numbers"):
        bf.ekf.numerical_jacobian(np.sin, [0.0], step="a")


# --------------------------------------------------------------------------
# A hand-written EKF loop: time-varying models and partly-missing rows
# --------------------------------------------------------------------------

def hand_ekf(model, ys, f, F, residual=np.subtract):
    """The EKF written out with no bayesfilt code: the step into t uses f(., t - 1) and
    F(., t - 1) (the index of the state it starts from), and a row's missing components
    are deleted by hand (entries of h, rows of H, rows and columns of R). Textbook
    update: explicit inverse and (I - K H) P."""
    n, m = model.state_dim, model.obs_dim
    T = len(ys)
    GQG = model.G @ model.Q @ model.G.T
    out = {"means": np.zeros((T, n)), "covs": np.zeros((T, n, n)),
           "pred_means": np.zeros((T, n)), "pred_covs": np.zeros((T, n, n)),
           "innovations": np.full((T, m), np.nan), "innovation_covs": np.full((T, m, m), np.nan),
           "gains": np.zeros((T, n, m)), "step_logliks": np.zeros(T)}
    x, P = model.m0.copy(), model.P0.copy()
    for t in range(T):
        if t > 0:
            Ft = F(x, t - 1)
            x = f(x, t - 1)
            P = Ft @ P @ Ft.T + GQG
        out["pred_means"][t], out["pred_covs"][t] = x, P
        keep = [j for j in range(m) if not np.isnan(ys[t][j])]
        if keep:
            y_pred = model.h(x)
            y_full = np.where(np.isnan(ys[t]), y_pred, ys[t])
            r = residual(y_full, y_pred)[keep]
            Hk = model.H(x)[keep, :]
            S = Hk @ P @ Hk.T + model.R[np.ix_(keep, keep)]
            K = P @ Hk.T @ np.linalg.inv(S)
            out["step_logliks"][t] = -0.5 * (r @ np.linalg.solve(S, r)
                                             + np.log(np.linalg.det(2 * np.pi * S)))
            x = x + K @ r
            P = (np.eye(n) - K @ Hk) @ P
            for a, j in enumerate(keep):
                out["innovations"][t, j] = r[a]
                out["gains"][t, :, j] = K[:, a]
                for b, k in enumerate(keep):
                    out["innovation_covs"][t, j, k] = S[a, b]
        out["means"][t], out["covs"][t] = x, P
    return out


def _assert_matches(res, ref, rtol=1e-8, atol=1e-9, what=""):
    for key, want in ref.items():
        got = np.asarray(getattr(res, key))
        np.testing.assert_array_equal(np.isnan(got), np.isnan(want), err_msg=f"{what} {key}")
        np.testing.assert_allclose(got, want, rtol=rtol, atol=atol, equal_nan=True,
                                   err_msg=f"{what} {key}")


def rotating_model():
    """A time-varying model whose f AND F depend on t: x_{t+1} = Rot(0.3 t) x + 0.2 sin(x),
    measured by (x_0, x_1^2 / 4, x_0 x_1 / 2)."""
    def rot(t):
        c, s = np.cos(0.3 * t), np.sin(0.3 * t)
        return np.array([[c, -s], [s, c]])

    def f(x, t):
        x = np.asarray(x, float)
        return x @ (0.97 * rot(t)).T + 0.2 * np.sin(x)

    def F(x, t):
        return 0.97 * rot(t) + 0.2 * np.diag(np.cos(x))

    def h(x):
        x = np.asarray(x, float)
        return np.stack([x[..., 0], x[..., 1] ** 2 / 4, x[..., 0] * x[..., 1] / 2], -1)

    def H(x):
        return np.array([[1.0, 0.0], [0.0, x[1] / 2], [x[1] / 2, x[0] / 2]])

    return bf.models.NonlinearGaussian(f=f, F=F, h=h, H=H, Q=0.05 * np.eye(2),
                                       R=np.diag([0.3, 0.2, 0.25]), m0=np.array([1.0, 2.0]),
                                       P0=0.5 * np.eye(2), time_varying=True)


def test_time_varying_ekf_equals_a_hand_loop_that_steps_into_t_with_f_t_minus_1():
    model = rotating_model()
    ys = bf.models.simulate(model, 30, np.random.default_rng(5)).ys
    _assert_matches(bf.ekf.extended_kalman_filter(model, ys), hand_ekf(model, ys, model.f, model.F))
    # UNGM, whose cosine carries the time index: the same
    ungm = bf.models.ungm()
    ys = bf.models.simulate(ungm, 30, np.random.default_rng(6)).ys
    _assert_matches(bf.ekf.extended_kalman_filter(ungm, ys), hand_ekf(ungm, ys, ungm.f, ungm.F))


def test_partly_missing_rows_against_a_hand_loop_that_deletes_them():
    rng = np.random.default_rng(7)
    model = rotating_model()
    ys = bf.models.simulate(model, 40, rng).ys
    ys[rng.random(ys.shape) < 0.3] = np.nan
    ys[[4, 20]] = np.nan
    assert (np.isnan(ys).any(axis=1) & ~np.isnan(ys).all(axis=1)).sum() >= 10
    res = bf.ekf.extended_kalman_filter(model, ys)
    _assert_matches(res, hand_ekf(model, ys, model.f, model.F))
    np.testing.assert_array_equal(res.observed_components, ~np.isnan(ys))
    np.testing.assert_array_equal(res.observed, ~np.isnan(ys).all(axis=1))


def test_partly_missing_range_or_bearing_with_the_wrapped_residual():
    """Range-bearing, the range missing on some rows and the bearing on others, across the
    negative x-axis where the bearing must be wrapped (independent wrap in the reference)."""
    model = bf.models.range_bearing(m0=(-8.0, 0.5, 0.0, 0.0), prior_var=1.0)
    rng = np.random.default_rng(8)
    ys = bf.models.simulate(model, 30, rng, x0=[-8.0, 1.0, 0.0, -0.1]).ys
    ys[::3, 0] = np.nan
    ys[1::4, 1] = np.nan
    res = bf.ekf.extended_kalman_filter(model, ys)
    ref = hand_ekf(model, ys, lambda x, t: model.f(x), lambda x, t: model.F(x),
                   residual=independent_bearing_residual)
    _assert_matches(res, ref)
    # the bearing crossed the cut at +-pi, so the wrap mattered
    assert (np.abs(np.diff(model.h(res.means)[:, 1])) > np.pi).any()


def test_partly_missing_ekf_on_a_linear_model_equals_the_kalman_filter():
    rng = np.random.default_rng(9)
    lin = bf.models.LinearGaussian(A=[[0.9, 0.3], [0.0, 0.8]], C=[[1.0, 0.0], [1.0, 1.0]],
                                   Q=0.2 * np.eye(2), R=[[0.5, 0.1], [0.1, 0.4]],
                                   m0=[0.0, 1.0], P0=np.eye(2))
    ys = bf.models.simulate(lin, 30, rng).ys
    ys[rng.random(ys.shape) < 0.3] = np.nan
    kf = bf.kalman.kalman_filter(lin, ys)
    ekf = bf.ekf.extended_kalman_filter(bf.models.to_nonlinear(lin), ys)
    for key in kf._fields:
        np.testing.assert_allclose(getattr(ekf, key), getattr(kf, key), rtol=1e-12, atol=1e-13,
                                   err_msg=key)


def test_ekf_predict_makes_P_exactly_symmetric_at_mixed_scales():
    """F P F^T + G Q G^T is asymmetric by rounding here; the prediction must be P == P^T
    bit for bit, as bf.kalman's, and so must every covariance of the filter."""
    rng = np.random.default_rng(12)
    n = 5
    B = rng.standard_normal((n, n))
    D = np.diag(np.logspace(-3, 3, n))
    P = D @ (B @ B.T + n * np.eye(n)) @ D
    P = 0.5 * (P + P.T)
    J = rng.standard_normal((n, n))

    def f(x):
        return np.asarray(x) @ J.T + 0.1 * np.sin(x)

    def F(x):
        return J + 0.1 * np.diag(np.cos(x))

    x = rng.standard_normal(n)
    raw = F(x) @ P @ F(x).T + np.eye(n)
    assert (raw != raw.T).any(), "the test needs a case where rounding breaks symmetry"
    pred = bf.ekf.predict(x, P, f, F, np.eye(n))
    assert np.array_equal(pred.cov, pred.cov.T)
    np.testing.assert_allclose(pred.cov, raw, rtol=1e-12, atol=1e-12 * np.abs(raw).max())
    model = bf.models.NonlinearGaussian(f=lambda x: 0.5 * f(x), F=lambda x: 0.5 * F(x),
                                        h=lambda x: np.asarray(x)[..., :2],
                                        H=lambda x: np.eye(2, n), Q=np.eye(n), R=np.eye(2),
                                        m0=np.zeros(n), P0=P)
    res = bf.ekf.extended_kalman_filter(model, np.ones((4, 2)))
    for covs in (res.covs, res.pred_covs):
        assert np.array_equal(covs, np.swapaxes(covs, 1, 2))
