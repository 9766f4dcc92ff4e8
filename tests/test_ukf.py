"""Tests of bf.ukf against independent references.

References: closed forms (linear, quadratic, cubic and quartic functions of a Gaussian),
a large Monte Carlo sample, the Kalman filter (bf.kalman, itself tested against
filterpy), an additive-noise UKF written below with plain loops from Särkkä (2013),
Algorithm 5.14, with the direct gain K = Sigma_xy S^{-1} (bf.ukf reaches it through
bf.kalman's update kernel), and filterpy 2.0.0's UnscentedKalmanFilter with
MerweScaledSigmaPoints.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from filterpy.kalman import MerweScaledSigmaPoints, UnscentedKalmanFilter
from scipy import stats

import bayesfilt as bf

TOL = dict(rtol=1e-9, atol=1e-9)
FIELDS = ("means", "covs", "pred_means", "pred_covs", "innovations", "innovation_covs", "gains",
          "step_logliks")
# (alpha, beta, kappa): the defaults, Julier's kappa = 3 - n-like spreads, a negative centre
# weight (kappa < 0), a small alpha (W^m_0 = -99 for n = 4), and wide points
PARAMS = [(1.0, 2.0, 0.0), (0.5, 2.0, 1.0), (1.0, 0.0, -1.0), (0.2, 2.0, 0.0), (2.0, 0.5, 3.0)]
# Kay's vehicle (n = 4) with alpha = 0.2 (W^m_0 = -24): its covariance goes indefinite (tested)
VEHICLE_PARAMS = [p for p in PARAMS if p[0] != 0.2]


# --------------------------------------------------------------------------
# Models and an independent UKF
# --------------------------------------------------------------------------

def pendulum(dt=0.1, g=9.81):
    """Nonlinear transition and measurement: angle/rate, measured by sin(angle) and the rate."""

    def f(x):
        x = np.asarray(x, float)
        return np.stack([x[..., 0] + dt * x[..., 1], x[..., 1] - dt * g * np.sin(x[..., 0])], -1)

    def h(x):
        x = np.asarray(x, float)
        return np.stack([np.sin(x[..., 0]), x[..., 1]], -1)

    return bf.models.NonlinearGaussian(
        f=f, F=lambda x: np.eye(2), h=h, H=lambda x: np.eye(2), Q=np.array([[1e-3]]),
        R=np.diag([0.05, 0.2]), m0=np.array([1.0, 0.0]), P0=np.diag([0.3, 0.5]),
        G=np.array([[0.0], [1.0]]))


def angle_of(d):
    """An angle difference brought into (-pi, pi] as the angle of the unit complex number."""
    return np.angle(np.exp(1j * np.asarray(d, float)))


def sarkka_ukf(f_t, h, GQGt, R, m0, P0, ys, alpha, beta, kappa, angles=None):
    """Särkkä (2013), Algorithm 5.14, written with plain loops; ys[0] measures x_0.

    The update is the textbook's direct form, K = Sigma_xy S^{-1}, P - K S K^T, with a
    plain solve and scipy's log-density: no regression slope, no solve with P, no Joseph
    form, none of bf.kalman's update code, so agreeing with bf.ukf (which goes through
    bf.kalman._correct) is a real check of that route.

    f_t(t, x): the transition from t to t + 1 of one state; h(x) of one state. ``angles``
    (m,) bool marks the measurement components that are angles: their differences are
    wrapped and their mean is the weighted mean of the wrapped differences from the
    central image. NaN components of y are missing (an all-NaN row is skipped).
    Returns a dict of the FilterResult fields.
    """
    n, m = len(m0), R.shape[0]
    angles = np.zeros(m, bool) if angles is None else angles
    lam = alpha**2 * (n + kappa) - n
    Wm = [lam / (n + lam)] + [1 / (2 * (n + lam))] * (2 * n)
    Wc = [lam / (n + lam) + 1 - alpha**2 + beta] + [1 / (2 * (n + lam))] * (2 * n)

    def points(mean, cov):
        sq = np.linalg.cholesky(cov)
        return ([mean] + [mean + np.sqrt(n + lam) * sq[:, i] for i in range(n)]
                + [mean - np.sqrt(n + lam) * sq[:, i] for i in range(n)])

    def diff(a, b):
        d = np.array(a, float) - b
        d[angles] = angle_of(d[angles])
        return d

    out = {k: [] for k in FIELDS}
    x, P = np.array(m0, float), np.array(P0, float)
    for t, y in enumerate(ys):
        if t > 0:
            Xh = [f_t(t - 1, s) for s in points(x, P)]
            x = sum(w * s for w, s in zip(Wm, Xh))
            P = sum(w * np.outer(s - x, s - x) for w, s in zip(Wc, Xh)) + GQGt
        out["pred_means"].append(x.copy())
        out["pred_covs"].append(P.copy())
        o = ~np.isnan(y)
        r_full, S_full, K_full, ll = np.full(m, np.nan), np.full((m, m), np.nan), np.zeros((n, m)), 0.0
        if o.any():
            X = points(x, P)
            Yh = [np.asarray(h(s), float)[o] for s in X]
            ang = angles[o]
            mu = sum(w * s for w, s in zip(Wm, Yh))
            mu[ang] = Yh[0][ang] + sum(w * angle_of(s[ang] - Yh[0][ang]) for w, s in zip(Wm, Yh))
            mu[ang] = angle_of(mu[ang])
            d = [s - mu for s in Yh]
            for k in range(len(d)):
                d[k][ang] = angle_of(d[k][ang])
            S = sum(w * np.outer(e, e) for w, e in zip(Wc, d)) + R[np.ix_(o, o)]
            C = sum(w * np.outer(s - x, e) for w, s, e in zip(Wc, X, d))
            K = np.linalg.solve(S, C.T).T
            v = y[o] - mu
            v[ang] = angle_of(v[ang])
            x = x + K @ v
            P = P - K @ S @ K.T
            ll = stats.multivariate_normal(np.zeros(len(v)), S).logpdf(v)
            r_full[o], S_full[np.ix_(o, o)], K_full[:, o] = v, S, K
        for key, value in (("means", x), ("covs", P), ("innovations", r_full),
                           ("innovation_covs", S_full), ("gains", K_full), ("step_logliks", ll)):
            out[key].append(np.copy(value))
    return {k: np.array(v) for k, v in out.items()}


def sarkka_for(model, ys, params, angles=None):
    def f_t(t, x):
        return model.transition_functions(t)[0](x)
    return sarkka_ukf(f_t, model.h, model.G @ model.Q @ model.G.T, model.R, model.m0,
                      model.P0, np.asarray(ys, float), *params, angles=angles)


def run_filterpy(model, ys, params, residual_z=None, z_mean_fn=None):
    """filterpy's UKF in the course's time convention: update(ys[0]) first, with its sigma
    points set to those of N(m0, P0), then predict(); update(ys[t]) (predict redraws them)."""
    n, m = model.state_dim, model.obs_dim
    points = MerweScaledSigmaPoints(n, *params)
    step = {"t": 0}

    def fx(x, dt):
        return model.transition_functions(step["t"])[0](x)

    ukf = UnscentedKalmanFilter(n, m, 1.0, hx=model.h, fx=fx, points=points,
                                residual_z=residual_z, z_mean_fn=z_mean_fn)
    ukf.x, ukf.P = model.m0.copy(), model.P0.copy()
    ukf.Q, ukf.R = model.G @ model.Q @ model.G.T, model.R.copy()
    ukf.sigmas_f = points.sigma_points(ukf.x, ukf.P)
    out = {k: [] for k in ("means", "covs", "pred_means", "pred_covs", "step_logliks")}
    for t, y in enumerate(ys):
        if t > 0:
            step["t"] = t - 1
            ukf.predict()
        out["pred_means"].append(ukf.x.copy())
        out["pred_covs"].append(ukf.P.copy())
        missing = np.isnan(y).all()
        ukf.update(None if missing else y)
        out["means"].append(ukf.x.copy())
        out["covs"].append(ukf.P.copy())
        out["step_logliks"].append(0.0 if missing else ukf.log_likelihood)
    return {k: np.array(v) for k, v in out.items()}


def filterpy_bearing_residual(a, b):
    d = np.asarray(a, float) - b
    d[1] = angle_of(d[1])
    return d


def filterpy_bearing_mean(sigmas, Wm):
    """The UT mean of (range, bearing) images: plain for the range, the weighted mean of the
    bearings' wrapped differences from the central image's for the bearing."""
    mean = Wm @ sigmas
    ref = sigmas[0, 1]
    mean[1] = angle_of(ref + Wm @ angle_of(sigmas[:, 1] - ref))
    return mean


def assert_fields(ours, ref, tol=TOL, keys=None):
    for key in keys or ref:
        np.testing.assert_allclose(getattr(ours, key), ref[key], **tol, err_msg=key)


def crossing_run():
    """A target whose bearing crosses the negative x-axis (+pi -> -pi) at t = 25."""
    model = bf.models.range_bearing(m0=(-10.0, 5.0, 0.0, 0.0), prior_var=4.0)
    sim = bf.models.simulate(model, 60, np.random.default_rng(5),
                             x0=np.array([-10.0, 5.0, 0.0, -0.2]))
    return model, sim


@pytest.fixture(scope="module")
def kay_run():
    model = bf.models.range_bearing()
    sim = bf.models.simulate(model, 60, np.random.default_rng(1),
                             x0=bf.models.RANGE_BEARING_TRUE_START)
    return model, sim


# --------------------------------------------------------------------------
# Sigma points
# --------------------------------------------------------------------------

M2, P2 = np.array([1.0, -2.0]), np.array([[2.0, 0.6], [0.6, 0.5]])


@pytest.mark.parametrize("params", PARAMS)
def test_sigma_points_have_the_mean_and_covariance(params):
    sp = bf.ukf.sigma_points(M2, P2, *params)
    assert sp.points.shape == (5, 2) and sp.mean_weights.shape == sp.cov_weights.shape == (5,)
    np.testing.assert_allclose(sp.mean_weights.sum(), 1.0, rtol=1e-12)
    np.testing.assert_allclose(sp.mean_weights @ sp.points, M2, atol=1e-12)
    d = sp.points - M2
    np.testing.assert_allclose((sp.cov_weights * d.T) @ d, P2, atol=1e-12)
    np.testing.assert_allclose((sp.mean_weights * d.T) @ d, P2, atol=1e-12)


def test_sigma_points_by_hand_in_one_dimension():
    """N(1, 4), alpha = 1, beta = 2, kappa = 2: c^2 = 3, points 1 and 1 +- 2 sqrt 3."""
    sp = bf.ukf.sigma_points([1.0], [[4.0]], alpha=1.0, beta=2.0, kappa=2.0)
    np.testing.assert_allclose(sp.points[:, 0], [1.0, 1.0 + 2 * np.sqrt(3), 1.0 - 2 * np.sqrt(3)])
    np.testing.assert_allclose(sp.mean_weights, [2 / 3, 1 / 6, 1 / 6])
    np.testing.assert_allclose(sp.cov_weights, [2 / 3 + 2, 1 / 6, 1 / 6])


def test_sigma_points_lie_along_the_columns_of_the_lower_cholesky_factor():
    sp = bf.ukf.sigma_points(M2, P2, 1.0, 2.0, 0.0)
    L = np.linalg.cholesky(P2)
    assert L[0, 1] == 0.0  # lower triangular
    np.testing.assert_allclose(sp.points[1:3] - M2, np.sqrt(2.0) * L.T, atol=1e-14)
    np.testing.assert_allclose(sp.points[3:5] - M2, -np.sqrt(2.0) * L.T, atol=1e-14)


@pytest.mark.parametrize("n, params", [(n, p) for n in (1, 2, 4) for p in PARAMS
                                         if n + p[2] > 0])   # kappa <= -n is refused (below)
def test_sigma_points_equal_filterpys(n, params):
    rng = np.random.default_rng(n)
    A = rng.standard_normal((n, n))
    P, m = A @ A.T + 0.5 * np.eye(n), rng.standard_normal(n)
    ours = bf.ukf.sigma_points(m, P, *params)
    ref = MerweScaledSigmaPoints(n, *params)
    np.testing.assert_allclose(ours.points, ref.sigma_points(m, P), rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(ours.mean_weights, ref.Wm, rtol=1e-14)
    np.testing.assert_allclose(ours.cov_weights, ref.Wc, rtol=1e-14)


# --------------------------------------------------------------------------
# The unscented transform: its exactness claims
# --------------------------------------------------------------------------

@pytest.mark.parametrize("params", PARAMS)
def test_ut_is_exact_for_a_linear_function(params):
    A, b = np.array([[1.0, 2.0], [-0.5, 0.3], [0.0, 1.0]]), np.array([0.1, 0.2, -3.0])
    ut = bf.ukf.unscented_transform(lambda x: x @ A.T + b, M2, P2, *params)
    np.testing.assert_allclose(ut.mean, A @ M2 + b, atol=1e-12)
    np.testing.assert_allclose(ut.cov, A @ P2 @ A.T, atol=1e-11)
    np.testing.assert_allclose(ut.cross_cov, P2 @ A.T, atol=1e-12)
    noisy = bf.ukf.unscented_transform(lambda x: x @ A.T + b, M2, P2, *params, noise_cov=np.eye(3))
    np.testing.assert_allclose(noisy.cov, A @ P2 @ A.T + np.eye(3), atol=1e-11)


@pytest.mark.parametrize("params", PARAMS)
def test_ut_mean_is_exact_for_a_quadratic_function(params):
    """E[x^T B x + b^T x] = tr(B P) + m^T B m + b^T m, for each of two outputs."""
    B1, B2, b = np.array([[1.0, 0.3], [0.3, -2.0]]), np.array([[0.0, 1.0], [1.0, 0.5]]), np.array([1.0, -1.0])

    def g(x):
        return np.stack([np.einsum("...i,ij,...j->...", x, B1, x) + x @ b,
                         np.einsum("...i,ij,...j->...", x, B2, x)], -1)

    exact = [np.trace(B @ P2) + M2 @ B @ M2 for B in (B1, B2)]
    exact[0] += b @ M2
    np.testing.assert_allclose(bf.ukf.unscented_transform(g, M2, P2, *params).mean, exact,
                               rtol=1e-12)


@pytest.mark.parametrize("params", PARAMS)
def test_ut_mean_is_exact_for_a_cubic_function(params):
    """E[x_i x_j x_k] = m_i m_j m_k + m_i P_jk + m_j P_ik + m_k P_ij for a Gaussian; the
    symmetric sigma points have no third central moment either."""
    def g(x):
        return np.stack([x[..., 0] ** 3, x[..., 0] * x[..., 1] ** 2, x[..., 1] ** 3], -1)

    def third(i, j, k):
        m, P = M2, P2
        return m[i] * m[j] * m[k] + m[i] * P[j, k] + m[j] * P[i, k] + m[k] * P[i, j]

    exact = [third(0, 0, 0), third(0, 1, 1), third(1, 1, 1)]
    np.testing.assert_allclose(bf.ukf.unscented_transform(g, M2, P2, *params).mean, exact,
                               rtol=1e-11)


def test_ut_variance_of_a_cubic_is_not_exact():
    """x ~ N(0, s^2): var(x^3) = 15 s^6; the UT's points 0, +-c s give c^4 s^6 (9 for c^2 = 3)."""
    s = 1.3
    ut = bf.ukf.unscented_transform(lambda x: x**3, [0.0], [[s**2]], 1.0, 2.0, 2.0)
    np.testing.assert_allclose(ut.cov[0, 0], 9.0 * s**6, rtol=1e-12)
    assert abs(ut.cov[0, 0] - 15.0 * s**6) > 5.0 * s**6


@pytest.mark.parametrize("params", [p for p in PARAMS if 1 + p[2] > 0])       # n = 1
def test_ut_mean_of_a_quartic_is_exact_only_for_c_squared_three(params):
    """x ~ N(m, s^2): E[x^4] = m^4 + 6 m^2 s^2 + 3 s^4; the points' fourth moment is c^2 s^4."""
    m, s2 = 0.7, 1.3
    alpha, _, kappa = params
    c2 = alpha**2 * (1 + kappa)
    ut = bf.ukf.unscented_transform(lambda x: x**4, [m], [[s2]], *params)
    np.testing.assert_allclose(ut.mean, [m**4 + 6 * m**2 * s2 + c2 * s2**2], rtol=1e-12)
    julier = bf.ukf.unscented_transform(lambda x: x**4, [m], [[s2]], 1.0, 0.0, 2.0)
    np.testing.assert_allclose(julier.mean, [m**4 + 6 * m**2 * s2 + 3 * s2**2], rtol=1e-12)


@pytest.mark.parametrize("params", [p for p in PARAMS if 1 + p[2] > 0]
                         + [(1.0, 0.0, 2.0), (0.5, 1.5, 2.0)])
def test_ut_variance_of_a_quadratic_in_one_dimension(params):
    """g = a e + b e^2, e = x - m ~ N(0, s^2): the UT's variance is a^2 s^2 + b^2 s^4
    (alpha^2 kappa + beta); the exact one a^2 s^2 + 2 b^2 s^4 (so exact iff that is 2)."""
    m, s2, a, b = 0.4, 0.8, 1.5, -0.7
    alpha, beta, kappa = params
    ut = bf.ukf.unscented_transform(lambda x: a * (x - m) + b * (x - m) ** 2, [m], [[s2]],
                                    *params)
    expected = a**2 * s2 + b**2 * s2**2 * (alpha**2 * kappa + beta)
    np.testing.assert_allclose(ut.cov[0, 0], expected, rtol=1e-10)
    exact = a**2 * s2 + 2 * b**2 * s2**2
    assert np.isclose(ut.cov[0, 0], exact) == np.isclose(alpha**2 * kappa + beta, 2.0)


def test_ut_variance_of_a_squared_norm_in_four_dimensions():
    """g(x) = x^T x, x ~ N(0, I_4): UT variance beta n^2 + alpha^2 n kappa (the defaults:
    32) against the exact 2n = 8; beta = 2 does not rescue it in n dimensions."""
    n = 4
    for alpha, beta, kappa in [(1.0, 2.0, 0.0), (0.5, 2.0, 1.0), (2.0, 0.5, 3.0)]:
        ut = bf.ukf.unscented_transform(lambda x: (x**2).sum(axis=-1), np.zeros(n), np.eye(n),
                                        alpha, beta, kappa)
        np.testing.assert_allclose(ut.cov[0, 0], beta * n**2 + alpha**2 * n * kappa,
                                   rtol=1e-10, atol=1e-10)


def test_ut_mean_of_a_cubic_agrees_with_a_large_monte_carlo():
    """200 000 draws; the limit z_limit(3) with Student's t (about 4.2 SE) makes a false alarm
    rarer than 1e-4 for any seed, since the UT mean is exact for a cubic."""
    def g(x):
        return np.stack([x[..., 0] ** 3 - x[..., 1], x[..., 0] * x[..., 1] ** 2, np.sin(x[..., 0])
                         * 0.0 + x[..., 1] ** 3], -1)

    draws = g(np.random.default_rng(2024).multivariate_normal(M2, P2, size=200_000))
    ut = bf.ukf.unscented_transform(g, M2, P2, 1.0, 2.0, 0.0)
    mean, se = bf.verify.mean_se(draws)
    z = bf.verify.z_limit(3, dof=draws.shape[0] - 1)
    assert np.all(np.abs(mean - ut.mean) < z * se), (mean, ut.mean, se)


def test_ut_with_angles_averages_across_the_cut():
    """Two points of a 1-D state whose bearing images straddle +-pi: the UT mean is pi (up to
    the spread), not 0, and equals the mean of the same configuration rotated away from the cut."""
    def to_bearing(phi0):
        return lambda th: np.stack([np.ones_like(th[..., 0]),
                                    bf.models.wrap_angle(phi0 + th[..., 0])], -1)

    residual = bf.models.range_bearing_residual
    at_cut = bf.ukf.unscented_transform(to_bearing(np.pi), [0.0], [[0.04]], residual=residual)
    at_zero = bf.ukf.unscented_transform(to_bearing(0.0), [0.0], [[0.04]], residual=residual)
    assert at_cut.images[1, 1] < -2.9 and at_cut.images[2, 1] > 2.9  # both sides of the cut
    assert abs(at_zero.mean[1]) < 1e-12
    np.testing.assert_allclose(angle_of(at_cut.mean[1] - np.pi), 0.0, atol=1e-12)
    np.testing.assert_allclose(at_cut.cov, at_zero.cov, atol=1e-12)
    np.testing.assert_allclose(at_cut.cross_cov, at_zero.cross_cov, atol=1e-12)
    plain = bf.ukf.unscented_transform(to_bearing(np.pi), [0.0], [[0.04]])
    assert plain.cov[1, 1] > 1.0  # without the residual, a spread of about 2 pi


# --------------------------------------------------------------------------
# The filter against the Kalman filter, an independent UKF and filterpy
# --------------------------------------------------------------------------

@pytest.mark.parametrize("params", PARAMS)
def test_ukf_equals_kalman_filter_on_a_linear_model(params):
    lin = bf.models.damped_particle()
    ys = bf.models.simulate(lin, 40, np.random.default_rng(3)).ys
    ys[[5, 6, 20]] = np.nan                                     # missing rows
    kf = bf.kalman.kalman_filter(lin, ys)
    ukf = bf.ukf.unscented_kalman_filter(bf.models.to_nonlinear(lin), ys, *params)
    tol = dict(rtol=1e-8, atol=1e-8)
    for key in FIELDS:
        np.testing.assert_allclose(getattr(ukf, key), getattr(kf, key), **tol, err_msg=key)
    assert ukf.loglik == pytest.approx(kf.loglik, rel=1e-10, abs=1e-8)
    np.testing.assert_array_equal(ukf.observed, kf.observed)


def test_ukf_equals_kalman_filter_on_a_linear_model_with_control_input():
    lin = bf.models.damped_particle(B=bf.models.damped_particle().G)
    us = np.random.default_rng(4).standard_normal((29, 2))
    ys = bf.models.simulate(lin, 30, np.random.default_rng(5), us=us).ys
    kf = bf.kalman.kalman_filter(lin, ys, us=us)
    ukf = bf.ukf.unscented_kalman_filter(lin, ys, us=us)
    for key in FIELDS:
        np.testing.assert_allclose(getattr(ukf, key), getattr(kf, key), rtol=1e-8, atol=1e-8,
                                   err_msg=key)


@pytest.mark.parametrize("params", PARAMS)
def test_ukf_equals_an_independent_ukf_on_a_nonlinear_model(params):
    model = pendulum()
    sim = bf.models.simulate(model, 50, np.random.default_rng(6), x0=np.array([1.2, 0.0]))
    ys = sim.ys.copy()
    ys[10] = np.nan
    assert_fields(bf.ukf.unscented_kalman_filter(model, ys, *params), sarkka_for(model, ys, params))


@pytest.mark.parametrize("params", [p for p in VEHICLE_PARAMS if 1 + p[2] > 0])   # n = 1
def test_ukf_equals_an_independent_ukf_on_a_time_varying_model(params):
    """(The chaotic UNGM amplifies the rounding of alpha = 0.2's weights, W^m_0 = -24, beyond
    1e-8 within 30 steps; that setting is compared on the pendulum.)"""
    """UNGM: f depends on t; the test's loop passes t - 1 for the step to t."""
    model = bf.models.ungm()
    ys = bf.models.simulate(model, 30, np.random.default_rng(7)).ys
    ours = bf.ukf.unscented_kalman_filter(model, ys, *params)
    assert_fields(ours, sarkka_for(model, ys, params), dict(rtol=1e-8, atol=1e-8))
    frozen = dataclasses.replace(model, f=lambda x, t: model.f(x, 0))
    other = bf.ukf.unscented_kalman_filter(frozen, ys, *params)
    assert np.abs(other.means - ours.means).max() > 1.0  # the time index matters


@pytest.mark.parametrize("params", VEHICLE_PARAMS)
def test_ukf_equals_an_independent_ukf_on_range_bearing(kay_run, params):
    model, sim = kay_run
    ref = sarkka_for(model, sim.ys, params, angles=np.array([False, True]))
    assert_fields(bf.ukf.unscented_kalman_filter(model, sim.ys, *params), ref)


@pytest.mark.parametrize("params", VEHICLE_PARAMS)
def test_ukf_equals_filterpy_on_range_bearing(kay_run, params):
    model, sim = kay_run
    ref = run_filterpy(model, sim.ys, params, filterpy_bearing_residual, filterpy_bearing_mean)
    ours = bf.ukf.unscented_kalman_filter(model, sim.ys, *params)
    assert_fields(ours, ref)
    assert ours.loglik == pytest.approx(ref["step_logliks"].sum(), rel=1e-10)


@pytest.mark.parametrize("params", PARAMS[:2])
def test_ukf_equals_filterpy_on_a_time_varying_model_with_missing_rows(params):
    model = bf.models.ungm()
    ys = bf.models.simulate(model, 30, np.random.default_rng(8)).ys
    ys[[3, 17]] = np.nan
    ours = bf.ukf.unscented_kalman_filter(model, ys, *params)
    assert_fields(ours, run_filterpy(model, ys, params), dict(rtol=1e-8, atol=1e-8))
    np.testing.assert_array_equal(ours.means[3], ours.pred_means[3])
    assert np.isnan(ours.innovations[3]).all() and not ours.gains[3].any()
    assert ours.step_logliks[3] == 0.0 and not ours.observed[3]


def test_ukf_equals_filterpy_across_the_bearing_cut():
    model, sim = crossing_run()
    assert np.abs(np.diff(sim.ys[:, 1])).max() > np.pi  # the measured bearing jumps
    ref = run_filterpy(model, sim.ys, (1.0, 2.0, 0.0), filterpy_bearing_residual,
                       filterpy_bearing_mean)
    ours = bf.ukf.unscented_kalman_filter(model, sim.ys)
    assert_fields(ours, ref)
    err = np.hypot(*(ours.means[:, :2] - sim.xs[:, :2]).T)
    assert err[10:].max() < 2.0 and np.abs(ours.innovations[:, 1]).max() < 1.0


def test_ukf_is_unchanged_by_turning_the_scene_half_round():
    """Turn the crossing run by pi about the sensor: positions and velocities change sign, the
    bearings shift by pi, from the cut at +-pi to 0, where nothing wraps. The sigma points of
    the turned Gaussians are the turned sigma points (the Cholesky factor of P is unchanged),
    so the filter's means must change sign, its covariances and log-likelihoods stay: the mean
    of the bearings across the cut equals the plain mean of the same bearings near 0."""
    model, sim = crossing_run()
    turned = dataclasses.replace(model, m0=-model.m0, residual_fn=None)   # no wrapping needed
    ys_turned = sim.ys.copy()
    ys_turned[:, 1] = bf.models.wrap_angle(sim.ys[:, 1] + np.pi)
    assert np.abs(ys_turned[:, 1]).max() < 1.5             # no bearing near the cut any more
    a = bf.ukf.unscented_kalman_filter(model, sim.ys)
    b = bf.ukf.unscented_kalman_filter(turned, ys_turned)
    np.testing.assert_allclose(b.means, -a.means, atol=1e-9)
    np.testing.assert_allclose(b.covs, a.covs, atol=1e-9)
    np.testing.assert_allclose(b.step_logliks, a.step_logliks, atol=1e-9)


def test_unwrapped_bearing_throws_the_bearing_away_at_the_cut():
    """Without the wrapping residual the images of sigma points that straddle the cut sit at
    +pi and -pi: their plain mean is near 0 and their spread several rad^2, so the UKF ignores
    the bearing for several steps (it keeps the track through the range; the EKF is lost)."""
    model, sim = crossing_run()
    naive = bf.ukf.unscented_kalman_filter(dataclasses.replace(model, residual_fn=None), sim.ys)
    good = bf.ukf.unscented_kalman_filter(model, sim.ys)
    assert (naive.innovation_covs[:, 1, 1] > 1.0).sum() >= 4
    assert good.innovation_covs[:, 1, 1].max() < 0.1
    assert np.abs(naive.innovations[:, 1]).max() > 5.0      # a jump of about 2 pi


def test_a_negative_centre_weight_can_make_the_covariance_indefinite_in_filterpy_too(kay_run):
    """alpha = 0.2 on Kay's vehicle: W^m_0 = 1 - 4 / 0.16 = -24. After three updates P_{2|2} has
    a large negative eigenvalue, in filterpy as in bayesfilt (the algorithm, not the code)."""
    model, sim = kay_run
    params = (0.2, 2.0, 0.0)
    ours = bf.ukf.unscented_kalman_filter(model, sim.ys[:3], *params)
    ref = run_filterpy(model, sim.ys[:3], params, filterpy_bearing_residual, filterpy_bearing_mean)
    assert_fields(ours, ref, dict(rtol=1e-8, atol=1e-8), keys=["means", "covs"])
    assert np.linalg.eigvalsh(ours.covs[2]).min() < -100.0
    with pytest.raises(ValueError, match=r"step t = 3: the filtered covariance .* must be positive "
                                         r"definite.*W\^m_0 = -24"):
        bf.ukf.unscented_kalman_filter(model, sim.ys[:4], *params)


def test_partly_missing_rows_use_the_observed_components():
    """A row with the bearing missing (range only), one with the range missing (bearing only),
    against the independent UKF, which selects the components itself."""
    model = bf.models.range_bearing()
    sim = bf.models.simulate(model, 30, np.random.default_rng(9), x0=bf.models.RANGE_BEARING_TRUE_START)
    ys = sim.ys.copy()
    ys[4, 1] = np.nan
    ys[9, 0] = np.nan
    ys[12] = np.nan
    ours = bf.ukf.unscented_kalman_filter(model, ys)
    assert_fields(ours, sarkka_for(model, ys, (1.0, 2.0, 0.0), angles=np.array([False, True])))
    assert np.isnan(ours.innovations[4, 1]) and np.isfinite(ours.innovations[4, 0])
    assert np.isnan(ours.innovation_covs[4, 1]).all() and np.isnan(ours.innovation_covs[4, :, 1]).all()
    assert not ours.gains[4, :, 1].any() and ours.gains[4, :, 0].any()
    assert ours.observed[4] and ours.observed[9] and not ours.observed[12]


def test_single_steps_equal_the_filter_and_theorem_10_2(kay_run):
    model, sim = kay_run
    res = bf.ukf.unscented_kalman_filter(model, sim.ys[:2])
    up0 = bf.ukf.update(model.m0, model.P0, sim.ys[0], model.h, model.R, residual=model.residual)
    pred = bf.ukf.predict(up0.mean, up0.cov, model.f, model.Q, model.G)
    up1 = bf.ukf.update(pred.mean, pred.cov, sim.ys[1], model.h, model.R,
                        residual=model.residual)
    np.testing.assert_array_equal(res.means[0], up0.mean)
    np.testing.assert_allclose(res.pred_means[1], pred.mean, rtol=1e-14)
    np.testing.assert_allclose(res.covs[1], up1.cov, rtol=1e-12)
    # the update conditions the UT's joint Gaussian of (x, y) on y (Kay's Theorem 10.2)
    ut = bf.ukf.unscented_transform(model.h, pred.mean, pred.cov, noise_cov=model.R,
                                    residual=model.residual)
    y_adj = ut.mean + model.residual(sim.ys[1], ut.mean)   # y on the branch of y_hat
    post = bf.gaussian.condition(pred.mean, ut.mean, pred.cov, ut.cross_cov, ut.cov, y_adj)
    np.testing.assert_allclose(up1.mean, post.mean, atol=1e-10)
    np.testing.assert_allclose(up1.cov, post.cov, atol=1e-10)


# --------------------------------------------------------------------------
# Bad inputs
# --------------------------------------------------------------------------

@pytest.mark.parametrize("args, kwargs, exc, match", [
    ((M2, [[1.0, 2.0], [2.0, 1.0]]), {}, ValueError, "cov must be positive semi-definite"),
    ((M2, [[1.0, 1.0], [1.0, 1.0]]), {}, ValueError,
     "cov must be positive definite to draw sigma points .* smallest eigenvalue"),
    ((M2, np.eye(3)), {}, ValueError, r"cov must have shape \(2, 2\)"),
    ((M2, P2), dict(alpha=0.0), ValueError, "alpha must be > 0"),
    ((M2, P2), dict(alpha=True), TypeError, "alpha must be a real number"),
    ((M2, P2), dict(beta=np.nan), ValueError, "beta must be finite"),
    ((M2, P2), dict(kappa=-2.0), ValueError, r"kappa must be > -n = -2"),
    ((M2, P2), dict(kappa="0"), TypeError, "kappa must be a real number"),
    (([1.0, np.nan], P2), {}, ValueError, "mean must be finite"),
])
def test_sigma_points_bad_inputs(args, kwargs, exc, match):
    with pytest.raises(exc, match=match):
        bf.ukf.sigma_points(*args, **kwargs)


@pytest.mark.parametrize("fun, kwargs, match", [
    (lambda x: x[0], {}, r"fun must act row by row on the \(5, 2\) sigma points"),
    (lambda x: np.full((5, 2), np.nan), {}, "fun returned non-finite"),
    (lambda x: x, dict(noise_cov=np.eye(3)), r"noise_cov must have shape \(2, 2\)"),
    (lambda x: x, dict(residual=lambda a, b: np.zeros(3)), r"residual must return shape \(5, 2\)"),
])
def test_unscented_transform_bad_inputs(fun, kwargs, match):
    with pytest.raises(ValueError, match=match):
        bf.ukf.unscented_transform(fun, M2, P2, **kwargs)
    with pytest.raises(TypeError, match="fun must be callable"):
        bf.ukf.unscented_transform(None, M2, P2)


def test_step_bad_inputs():
    model = pendulum()
    with pytest.raises(ValueError, match=r"f must return shape \(5, 2\)"):
        bf.ukf.predict(model.m0, model.P0, lambda X: X[:, :1], model.Q, model.G)
    with pytest.raises(ValueError, match=r"Q must have shape \(2, 2\) when G is omitted"):
        bf.ukf.predict(model.m0, model.P0, model.f, model.Q)
    with pytest.raises(ValueError, match="filtered covariance P_{t|t} must be positive definite"):
        bf.ukf.predict(model.m0, np.diag([1.0, 0.0]), model.f, model.Q, model.G)
    with pytest.raises(ValueError, match=r"y must have shape \(2,\)"):
        bf.ukf.update(model.m0, model.P0, [0.1], model.h, model.R)
    with pytest.raises(ValueError, match="h returned non-finite"):
        bf.ukf.update(model.m0, model.P0, [0.1, 0.2], lambda X: np.where(X > 5.0, X, np.nan), model.R)
    with pytest.raises(TypeError, match="h must be callable"):
        bf.ukf.update(model.m0, model.P0, [0.1, 0.2], "h", model.R)
    with pytest.raises(TypeError, match="residual must be callable"):
        bf.ukf.update(model.m0, model.P0, [0.1, 0.2], model.h, model.R, residual=3)


def test_negative_weight_that_makes_s_indefinite_is_reported():
    """g(x) = x^T x of x ~ N(0, I_4) with alpha = 1, beta = 0, kappa = -1: W^c_0 = -1/3 and the
    UT's variance is -4 (the exact one is 8); with a small R the update cannot proceed."""
    ut = bf.ukf.unscented_transform(lambda X: (X**2).sum(-1), np.zeros(4), np.eye(4), 1.0, 0.0, -1.0)
    np.testing.assert_allclose(ut.cov, [[-4.0]], atol=1e-12)
    with pytest.raises(ValueError, match="ukf.update: innovation covariance .* not positive "
                                         "definite.* negative weight"):
        bf.ukf.update(np.zeros(4), np.eye(4), [4.0], lambda X: (X**2).sum(-1)[:, None],
                      [[0.1]], 1.0, 0.0, -1.0)


def test_filter_bad_inputs():
    model = pendulum()
    with pytest.raises(TypeError, match="model must be a bf.models.NonlinearGaussian"):
        bf.ukf.unscented_kalman_filter("model", np.zeros((3, 2)))
    with pytest.raises(ValueError, match=r"ys must have shape \(\?, 2\), got shape \(3, 3\)"):
        bf.ukf.unscented_kalman_filter(model, np.zeros((3, 3)))
    with pytest.raises(ValueError, match=r"ys must be finite or NaN \(missing\), got inf at "
                                         r"index \(1, 0\)"):
        bf.ukf.unscented_kalman_filter(model, np.array([[0.0, 0.0], [np.inf, 0.0]]))
    with pytest.raises(ValueError, match="us was given, but a NonlinearGaussian takes no"):
        bf.ukf.unscented_kalman_filter(model, np.zeros((3, 2)), us=np.zeros((2, 1)))
    with pytest.raises(ValueError, match="kappa must be > -n = -2"):
        bf.ukf.unscented_kalman_filter(model, np.zeros((3, 2)), kappa=-3.0)
    with pytest.raises(ValueError, match="us was given but the model has no control matrix B"):
        bf.ukf.unscented_kalman_filter(bf.models.damped_particle(), np.zeros((3, 2)),
                                       us=np.zeros((2, 2)))


def test_filter_names_the_step_that_fails():
    base = pendulum()

    def h(X):  # fine near m0 (the constructor checks it there), NaN once the rate is below -0.5
        X = np.asarray(X, float)
        return np.where(X[..., 1:] > -0.5, base.h(X), np.nan)

    model = dataclasses.replace(base, h=h)
    ys = np.tile([0.0, -1.0], (10, 1))
    with pytest.raises(ValueError, match=r"unscented_kalman_filter, step t = \d+: h returned "
                                         r"non-finite"):
        bf.ukf.unscented_kalman_filter(model, ys)


def test_scalar_measurements_as_a_vector():
    model = bf.models.to_nonlinear(bf.models.LinearGaussian(A=0.9, C=1.0, Q=0.1, R=1.0, m0=0.0, P0=1.0))
    ys = np.array([0.1, -0.2, 0.3])
    np.testing.assert_allclose(bf.ukf.unscented_kalman_filter(model, ys).means,
                               bf.ukf.unscented_kalman_filter(model, ys[:, None]).means)
