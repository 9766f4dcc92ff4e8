"""Tests of bf.kalman against independent references.

References: filterpy 2.0.0 (KalmanFilter and its module-level predict/update),
the joint Gaussian of all measurements written out by brute force (log
likelihood and posterior of a short run, with missing rows), a plain
iteration of the Riccati recursion, the seed's textbook P - K C P form, the
information form 1 / (1 / p + 1 / r) of a scalar update (where Joseph and P - K C P differ),
scalar filters in closed form (measurement components in very different units), and the
public predict/update called step by step (kalman_filter must equal them bit for bit).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from filterpy.kalman import KalmanFilter
from filterpy.kalman import predict as fp_predict
from filterpy.kalman import update as fp_update
from scipy.stats import multivariate_normal

import bayesfilt as bf

TOL = dict(rtol=1e-9, atol=1e-10)


# --------------------------------------------------------------------------
# Helpers
# --------------------------------------------------------------------------

def random_spd(rng, k, scale=1.0):
    a = rng.standard_normal((k, k))
    return scale * (a @ a.T / k + 0.3 * np.eye(k))


def random_model(rng, n, m, q=None, p=None):
    """A random stable LinearGaussian: spectral radius 0.95, G (n, q), optional B (n, p)."""
    q = n if q is None else q
    A = rng.standard_normal((n, n))
    A *= 0.95 / np.max(np.abs(np.linalg.eigvals(A)))
    return bf.models.LinearGaussian(
        A=A, C=rng.standard_normal((m, n)), Q=random_spd(rng, q, 0.5), R=random_spd(rng, m),
        m0=rng.standard_normal(n), P0=random_spd(rng, n, 2.0), G=rng.standard_normal((n, q)),
        B=None if p is None else rng.standard_normal((n, p)))


def filterpy_run(model, ys, us=None):
    """filterpy on seed 000's time convention: update with ys[0] first, then predict/update."""
    n, m = model.state_dim, model.obs_dim
    kf = KalmanFilter(dim_x=n, dim_z=m, dim_u=0 if model.B is None else model.B.shape[1])
    kf.F = model.A.copy()
    kf.H = model.C.copy()
    kf.Q = model.G @ model.Q @ model.G.T  # filterpy has no G
    kf.R = model.R.copy()
    if model.B is not None:
        kf.B = model.B.copy()
    kf.x = model.m0.copy()
    kf.P = model.P0.copy()
    out = {k: [] for k in ("means", "covs", "pred_means", "pred_covs", "innovations",
                           "innovation_covs", "gains", "step_logliks")}
    for t in range(len(ys)):
        if t > 0:
            kf.predict(u=None if us is None else us[t - 1])
        out["pred_means"].append(kf.x.copy())
        out["pred_covs"].append(kf.P.copy())
        kf.update(ys[t])
        out["means"].append(kf.x.copy())
        out["covs"].append(kf.P.copy())
        out["innovations"].append(kf.y.copy())
        out["innovation_covs"].append(kf.S.copy())
        out["gains"].append(kf.K.copy())
        out["step_logliks"].append(kf.log_likelihood)
    return {k: np.array(v) for k, v in out.items()}


def textbook_cov_pass(model, T, observed):
    """Seed 000's recursion verbatim (P - K C P, explicit inverse): an independent reference."""
    GQG = model.G @ model.Q @ model.G.T
    P = model.P0.copy()
    preds, posts = [], []
    for t in range(T):
        if t > 0:
            P = model.A @ P @ model.A.T + GQG
        preds.append(P)
        if observed[t]:
            K = P @ model.C.T @ np.linalg.inv(model.C @ P @ model.C.T + model.R)
            P = P - K @ model.C @ P
        posts.append(P)
    return np.array(preds), np.array(posts)


def brute_force(model, ys, us=None):
    """Joint Gaussian of (x_0..x_{T-1}, observed y) written out directly.

    Returns log p(observed ys) and the mean/cov of x_{T-1} given them (Theorem
    10.2 on the joint), without any recursion over measurements.
    """
    n, m = model.state_dim, model.obs_dim
    T = len(ys)
    A, C = model.A, model.C
    GQG = model.G @ model.Q @ model.G.T
    # Stacked state X = Phi x0 + Psi W + input terms, with W the noises G w_0..G w_{T-2}
    Phi = np.zeros((T * n, n))
    Psi = np.zeros((T * n, max(T - 1, 1) * n))
    mean_x = np.zeros(T * n)
    x_det = model.m0.copy()
    for t in range(T):
        Phi[t * n:(t + 1) * n] = np.linalg.matrix_power(A, t)
        for s in range(t):
            Psi[t * n:(t + 1) * n, s * n:(s + 1) * n] = np.linalg.matrix_power(A, t - 1 - s)
        if t > 0:
            x_det = A @ x_det + (0 if us is None else model.B @ us[t - 1])
        mean_x[t * n:(t + 1) * n] = x_det
    cov_w = np.kron(np.eye(max(T - 1, 1)), GQG)
    cov_x = Phi @ model.P0 @ Phi.T + Psi @ cov_w @ Psi.T
    obs = ~np.isnan(ys).all(axis=1)
    Cbig = np.kron(np.eye(T), C)[np.repeat(obs, m)]
    y = ys[obs].ravel()
    mean_y = Cbig @ mean_x
    cov_y = Cbig @ cov_x @ Cbig.T + np.kron(np.eye(obs.sum()), model.R)
    loglik = multivariate_normal(mean_y, cov_y).logpdf(y)
    cov_xy = cov_x @ Cbig.T
    last = slice((T - 1) * n, T * n)
    W = np.linalg.solve(cov_y, cov_xy[last].T).T
    mean_last = mean_x[last] + W @ (y - mean_y)
    cov_last = cov_x[last, last] - W @ cov_xy[last].T
    return loglik, mean_last, cov_last


@pytest.fixture
def particle():
    model = bf.models.damped_particle()
    ys = bf.models.simulate(model, 60, np.random.default_rng(11)).ys
    return model, ys


# --------------------------------------------------------------------------
# Single steps
# --------------------------------------------------------------------------

@pytest.mark.parametrize("n,m", [(1, 1), (3, 2), (4, 3)])
def test_predict_and_update_equal_filterpy_functions(n, m):
    rng = np.random.default_rng(100 + n)
    model = random_model(rng, n, m, p=2)
    u = rng.standard_normal(2)
    x, P = bf.kalman.predict(model.m0, model.P0, model.A, model.Q, G=model.G, B=model.B, u=u)
    x_ref, P_ref = fp_predict(model.m0, model.P0, model.A, model.G @ model.Q @ model.G.T,
                              u=u, B=model.B)
    np.testing.assert_allclose(x, x_ref, **TOL)
    np.testing.assert_allclose(P, P_ref, **TOL)
    y = rng.standard_normal(m)
    step = bf.kalman.update(x, P, y, model.C, model.R)
    xu, Pu, r, K, S, ll = fp_update(x, P, y, model.R, model.C, return_all=True)
    for got, want in ((step.mean, xu), (step.cov, Pu), (step.innovation, r), (step.gain, K),
                      (step.innovation_cov, S)):
        np.testing.assert_allclose(got, want, **TOL)
    # Not filterpy's `ll` here: filterpy 2.0.0's module-level update() evaluates the
    # likelihood at the *updated* mean, logpdf(z, H x_post, S), which is not log p(y).
    np.testing.assert_allclose(step.loglik, multivariate_normal(model.C @ x, S).logpdf(y),
                               **TOL)
    assert not np.isclose(ll, step.loglik)
    assert isinstance(step.loglik, float)


def test_predict_default_G_is_identity_and_unpacks():
    x, P = bf.kalman.predict([1.0, 2.0], np.eye(2), [[1.0, 1.0], [0.0, 1.0]], 0.1 * np.eye(2))
    np.testing.assert_allclose(x, [3.0, 2.0])
    np.testing.assert_allclose(P, [[2.1, 1.0], [1.0, 1.1]])


def test_joseph_form_equals_textbook_form_on_a_well_conditioned_step():
    rng = np.random.default_rng(3)
    P, C, R = random_spd(rng, 4), rng.standard_normal((2, 4)), random_spd(rng, 2)
    step = bf.kalman.update(np.zeros(4), P, np.ones(2), C, R)
    K = P @ C.T @ np.linalg.inv(C @ P @ C.T + R)
    np.testing.assert_allclose(step.gain, K, **TOL)
    np.testing.assert_allclose(step.cov, P - K @ C @ P, rtol=1e-9, atol=1e-12)
    np.testing.assert_array_equal(step.cov, step.cov.T)


def _vague_prior_model():
    """Position measured with variance 1e-6 under a prior variance 1e12: a case where the
    Joseph form and P - K C P differ in floating point (see the test below)."""
    return bf.models.LinearGaussian(A=np.eye(2), C=[[1.0, 0.0]], Q=1e-6 * np.eye(2),
                                    R=[[1e-6]], m0=np.zeros(2), P0=1e12 * np.eye(2))


def _exact_position_variance(observed, p0=1e12, q=1e-6, r=1e-6):
    """Posterior variance of the measured component of _vague_prior_model, in information
    form 1 / (1 / p + 1 / r): no cancellation, so accurate to a few ulp."""
    out, p = [], p0
    for t, obs in enumerate(observed):
        if t > 0:
            p = p + q
        if obs:
            p = 1.0 / (1.0 / p + 1.0 / r)
        out.append(p)
    return np.array(out)


def test_joseph_form_where_it_differs_from_textbook_form():
    """P = 1e12 I, R = 1e-6: the gain rounds to K = (1, 0), so P - K C P loses the whole
    posterior variance to cancellation (gives 0), while the Joseph form keeps K R K^T = 1e-6.
    The exact value is 1e-6 (1 - 1e-18)."""
    P, C, R = 1e12 * np.eye(2), np.array([[1.0, 0.0]]), np.array([[1e-6]])
    step = bf.kalman.update(np.zeros(2), P, [0.0], C, R)
    assert step.cov[0, 0] == pytest.approx(1e-6, rel=1e-6)
    assert step.cov[1, 1] == pytest.approx(1e12, rel=1e-12)
    # The test can fail: both forms of the textbook update give 0 here, not 1e-6.
    K = P @ C.T @ np.linalg.inv(C @ P @ C.T + R)
    assert (P - K @ C @ P)[0, 0] == 0.0
    assert ((np.eye(2) - K @ C) @ P)[0, 0] == 0.0


def test_joseph_form_in_the_filters():
    """The same through kalman_filter and batch_kalman_filter (one missing-data pattern, a
    few, and many), against the information-form variance."""
    model = _vague_prior_model()
    T = 8
    ys = np.zeros((T, 1))
    res = bf.kalman.kalman_filter(model, ys)
    np.testing.assert_allclose(res.covs[:, 0, 0], _exact_position_variance([True] * T),
                               rtol=1e-6)
    assert res.covs[0, 0, 0] == pytest.approx(1e-6, rel=1e-6)  # P - K C P gives 0
    for n_patterns in (1, 3, 7):
        # sequence i misses rows 0 .. i-1, so its first update starts from P = 1e12 I
        batch = np.zeros((n_patterns, T, 1))
        for i in range(n_patterns):
            batch[i, :i] = np.nan
        res = bf.kalman.batch_kalman_filter(model, batch)
        for i in range(n_patterns):
            np.testing.assert_allclose(res.covs[i, :, 0, 0],
                                       _exact_position_variance(res.observed[i]), rtol=1e-6,
                                       err_msg=f"{n_patterns} patterns, sequence {i}")
            assert res.covs[i, i, 0, 0] == pytest.approx(1e-6, rel=1e-6)


def test_update_is_scalar_friendly():
    step = bf.kalman.update(0.0, 1.0, 0.9, 1.0, 0.5)
    np.testing.assert_allclose(step.mean, [0.6])
    np.testing.assert_allclose(step.cov, [[1.0 / 3.0]])


def test_measurement_components_in_very_different_units():
    """R = diag(1, 1e-6), P0 = diag(1e10, 1e-6), A = C = I: two independent scalar filters,
    one in metres with a vague prior, one in micrometres. S = diag(1e10 + 1, 2e-6) is far
    from singular (each pivot equals its own diagonal entry), so it must be accepted by the
    single step and by both filters. Reference: the two scalar filters in closed form."""
    r, q = np.array([1.0, 1e-6]), np.array([1e-2, 1e-8])
    model = bf.models.LinearGaussian(A=np.eye(2), C=np.eye(2), Q=np.diag(q), R=np.diag(r),
                                     m0=np.zeros(2), P0=np.diag([1e10, 1e-6]))
    T = 6
    ys = np.random.default_rng(3).standard_normal((T, 2)) * np.sqrt(r)
    # scalar filters: S = p + r, x += p / S (y - x), p = 1 / (1 / p + 1 / r)
    x, p = model.m0.copy(), np.diag(model.P0).copy()
    means, variances, loglik = [], [], 0.0
    for t in range(T):
        if t > 0:
            p = p + q
        S = p + r
        loglik += np.sum(-0.5 * ((ys[t] - x) ** 2 / S + np.log(2 * np.pi * S)))
        x = x + p / S * (ys[t] - x)
        p = 1.0 / (1.0 / p + 1.0 / r)
        means.append(x)
        variances.append(p)
    step = bf.kalman.update(model.m0, model.P0, ys[0], model.C, model.R)
    np.testing.assert_allclose(np.diag(step.cov), variances[0], rtol=1e-9)
    res = bf.kalman.kalman_filter(model, ys)
    np.testing.assert_allclose(res.means, means, rtol=1e-9, atol=1e-15)
    np.testing.assert_allclose(np.diagonal(res.covs, axis1=1, axis2=2), variances, rtol=1e-9)
    np.testing.assert_allclose(res.loglik, loglik, rtol=1e-9)
    batch = bf.kalman.batch_kalman_filter(model, np.stack([ys, ys]))
    np.testing.assert_allclose(batch.loglik, [loglik, loglik], rtol=1e-9)


# --------------------------------------------------------------------------
# The whole-run filter is the single steps in a loop
# --------------------------------------------------------------------------

@pytest.mark.parametrize("with_inputs", [False, True])
@pytest.mark.parametrize("missing", [[], [0, 4, 5, 17, 29]])
def test_kalman_filter_is_predict_and_update_in_a_loop(missing, with_inputs):
    """kalman_filter must give bit for bit what a student gets by calling the public
    predict and update in a loop (np.array_equal, not allclose)."""
    rng = np.random.default_rng(40 + len(missing))
    model = random_model(rng, 4, 2, q=3, p=2 if with_inputs else None)
    T = 30
    us = rng.standard_normal((T - 1, 2)) if with_inputs else None
    ys = bf.models.simulate(model, T, rng, us=us).ys
    ys[missing] = np.nan
    res = bf.kalman.kalman_filter(model, ys, us)
    x, P = model.m0, model.P0
    logliks = []
    for t in range(T):
        if t > 0:
            x, P = bf.kalman.predict(x, P, model.A, model.Q, G=model.G, B=model.B,
                                     u=None if us is None else us[t - 1])
        assert np.array_equal(res.pred_means[t], x), t
        assert np.array_equal(res.pred_covs[t], P), t
        if t in missing:
            assert np.isnan(res.innovations[t]).all() and np.isnan(res.innovation_covs[t]).all()
            assert (res.gains[t] == 0).all() and res.step_logliks[t] == 0
            assert not res.observed[t]
        else:
            step = bf.kalman.update(x, P, ys[t], model.C, model.R)
            assert np.array_equal(res.gains[t], step.gain), t
            assert np.array_equal(res.innovations[t], step.innovation), t
            assert np.array_equal(res.innovation_covs[t], step.innovation_cov), t
            assert res.step_logliks[t] == step.loglik, t
            logliks.append(step.loglik)
            x, P = step.mean, step.cov
        assert np.array_equal(res.means[t], x), t
        assert np.array_equal(res.covs[t], P), t
    assert res.loglik == pytest.approx(math.fsum(logliks), rel=1e-14, abs=0)


# --------------------------------------------------------------------------
# Whole runs against filterpy
# --------------------------------------------------------------------------

@pytest.mark.parametrize("n,m,q", [(1, 1, 1), (2, 1, 1), (2, 3, 2), (3, 2, 2), (4, 2, 2),
                                   (5, 3, 3), (5, 1, 2)])
def test_kalman_filter_equals_filterpy(n, m, q):
    rng = np.random.default_rng(10 * n + m)
    model = random_model(rng, n, m, q=q)
    ys = bf.models.simulate(model, 50, rng).ys
    ours = bf.kalman.kalman_filter(model, ys)
    ref = filterpy_run(model, ys)
    for key, want in ref.items():
        np.testing.assert_allclose(getattr(ours, key), want, **TOL, err_msg=key)
    np.testing.assert_allclose(ours.loglik, ref["step_logliks"].sum(), **TOL)
    assert ours.observed.all() and isinstance(ours.loglik, float)
    assert ours.means.shape == (50, n) and ours.gains.shape == (50, n, m)


def _filterpy_kf(model):
    kf = KalmanFilter(dim_x=model.state_dim, dim_z=model.obs_dim)
    kf.F, kf.H, kf.R = model.A.copy(), model.C.copy(), model.R.copy()
    kf.Q = model.G @ model.Q @ model.G.T  # filterpy has no G
    kf.x, kf.P = model.m0.copy(), model.P0.copy()
    return kf


def test_time_convention(particle):
    """ys[0] measures x_0 ~ N(m0, P0): step 0 is an update of the prior, no prediction."""
    model, ys = particle
    res = bf.kalman.kalman_filter(model, ys[:3])
    np.testing.assert_array_equal(res.pred_means[0], model.m0)
    np.testing.assert_array_equal(res.pred_covs[0], model.P0)
    kf = _filterpy_kf(model)
    kf.update(ys[0])                      # means[0]: the prior updated with ys[0]
    np.testing.assert_allclose(res.means[0], kf.x, **TOL)
    np.testing.assert_allclose(res.covs[0], kf.P, **TOL)
    for t in (1, 2):
        kf.predict()                      # pred_means[t]: means[t-1] moved by A
        np.testing.assert_allclose(res.pred_means[t], kf.x, **TOL)
        np.testing.assert_allclose(res.pred_covs[t], kf.P, **TOL)
        kf.update(ys[t])
        np.testing.assert_allclose(res.means[t], kf.x, **TOL)


def test_known_inputs_equal_filterpy_B_u():
    rng = np.random.default_rng(7)
    model = random_model(rng, 4, 2, q=2, p=2)
    us = rng.standard_normal((39, 2))
    ys = bf.models.simulate(model, 40, rng, us=us).ys
    ours = bf.kalman.kalman_filter(model, ys, us)
    ref = filterpy_run(model, ys, us)
    for key, want in ref.items():
        np.testing.assert_allclose(getattr(ours, key), want, **TOL, err_msg=key)
    # T rows are accepted, the last is unused
    longer = np.vstack([us, [1e6, -1e6]])
    np.testing.assert_array_equal(bf.kalman.kalman_filter(model, ys, longer).means, ours.means)


def test_damped_particle_long_run_equals_filterpy():
    """Long enough for the covariance recursion to reach its floating-point fixed point."""
    model = bf.models.damped_particle()
    ys = bf.models.simulate(model, 600, np.random.default_rng(5)).ys
    ours = bf.kalman.kalman_filter(model, ys)
    ref = filterpy_run(model, ys)
    for key, want in ref.items():
        np.testing.assert_allclose(getattr(ours, key), want, **TOL, err_msg=key)


# --------------------------------------------------------------------------
# Brute force: the joint Gaussian of all observed measurements
# --------------------------------------------------------------------------

@pytest.mark.parametrize("missing", [[], [2], [0, 3, 4], [1, 2, 3, 4, 5, 6]])
def test_loglik_and_last_posterior_equal_joint_gaussian(missing):
    rng = np.random.default_rng(21 + len(missing))
    model = random_model(rng, 3, 2, q=2, p=1)
    T = 7
    us = rng.standard_normal((T - 1, 1))
    ys = bf.models.simulate(model, T, rng, us=us).ys
    ys[missing] = np.nan
    res = bf.kalman.kalman_filter(model, ys, us)
    loglik, mean_last, cov_last = brute_force(model, ys, us)
    np.testing.assert_allclose(res.loglik, loglik, rtol=1e-9)
    np.testing.assert_allclose(res.means[-1], mean_last, rtol=1e-8, atol=1e-9)
    np.testing.assert_allclose(res.covs[-1], cov_last, rtol=1e-8, atol=1e-9)


def test_missing_rows_only_predict(particle):
    model, ys = particle
    ys = ys.copy()
    missing = [0, 5, 6, 7, 30, 59]
    ys[missing] = np.nan
    res = bf.kalman.kalman_filter(model, ys)
    # Reference: filterpy's KalmanFilter, whose update(None) skips the measurement
    kf = _filterpy_kf(model)
    for t in range(len(ys)):
        if t > 0:
            kf.predict()
        np.testing.assert_allclose(res.pred_means[t], kf.x, **TOL)
        np.testing.assert_allclose(res.pred_covs[t], kf.P, **TOL)
        kf.update(None if t in missing else ys[t])
        np.testing.assert_allclose(res.means[t], kf.x, **TOL)
        np.testing.assert_allclose(res.covs[t], kf.P, **TOL)
    np.testing.assert_array_equal(res.means[missing], res.pred_means[missing])
    np.testing.assert_array_equal(res.covs[missing], res.pred_covs[missing])
    assert np.isnan(res.innovations[missing]).all()
    assert np.isnan(res.innovation_covs[missing]).all()
    assert (res.gains[missing] == 0).all() and (res.step_logliks[missing] == 0).all()
    assert res.observed.sum() == len(ys) - len(missing) and not res.observed[missing].any()
    assert np.isfinite(res.innovations[res.observed]).all()
    np.testing.assert_allclose(res.loglik, res.step_logliks.sum(), rtol=1e-12)


def test_all_missing_is_pure_prediction():
    model = bf.models.damped_particle()
    res = bf.kalman.kalman_filter(model, np.full((4, 2), np.nan))
    assert res.loglik == 0.0 and not res.observed.any()
    P = model.P0
    for t in range(4):
        np.testing.assert_allclose(res.covs[t], P, **TOL)
        P = model.A @ P @ model.A.T + model.G @ model.Q @ model.G.T


def test_covariance_recursion_equals_textbook_form(particle):
    model, ys = particle
    ys = ys.copy()
    ys[[4, 9, 10]] = np.nan
    res = bf.kalman.kalman_filter(model, ys)
    preds, posts = textbook_cov_pass(model, len(ys), res.observed)
    np.testing.assert_allclose(res.pred_covs, preds, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(res.covs, posts, rtol=1e-9, atol=1e-12)


def test_covariances_stay_symmetric_psd_over_1e5_steps():
    """A hard case: nearly noise-free position measurements of a constant-velocity state,
    a vague prior and 30 % of the rows missing at random (so the recursion never settles)."""
    rng = np.random.default_rng(0)
    model = bf.models.LinearGaussian(A=[[1.0, 1.0], [0.0, 1.0]], C=[[1.0, 0.0]],
                                     Q=[[1e-6]], R=[[1e-8]], m0=[0.0, 0.0],
                                     P0=1e6 * np.eye(2), G=[[0.5], [1.0]])
    T = 100_000
    ys = rng.standard_normal((T, 1))
    ys[rng.random(T) < 0.3] = np.nan
    res = bf.kalman.kalman_filter(model, ys)
    for covs in (res.covs, res.pred_covs):
        # The library symmetrises every covariance it returns, so this line checks the
        # documented contract (exactly symmetric output) and cannot detect a numerically
        # fragile update; the eigenvalue check below is the real test. (Neither separates
        # the Joseph form from P - K C P here: test_joseph_form_* do that.)
        np.testing.assert_array_equal(covs, np.swapaxes(covs, 1, 2))
        eig = np.linalg.eigvalsh(covs)
        assert eig.min() > 0.0
    assert np.isfinite(res.loglik)


# --------------------------------------------------------------------------
# Batched filter
# --------------------------------------------------------------------------

def _compare_batch(model, ys, us=None):
    batch = bf.kalman.batch_kalman_filter(model, ys, us)
    for i in range(ys.shape[0]):
        u_i = None if us is None else (us if np.ndim(us) == 2 else us[i])
        one = bf.kalman.kalman_filter(model, ys[i], u_i)
        for key in one._fields:
            np.testing.assert_allclose(np.asarray(getattr(batch, key))[i], getattr(one, key),
                                       rtol=1e-10, atol=1e-12, err_msg=f"{key}, sequence {i}")
    return batch


def test_batch_equals_per_sequence_same_pattern(particle):
    model, _ = particle
    rng = np.random.default_rng(8)
    ys = np.stack([bf.models.simulate(model, 120, rng).ys for _ in range(6)])
    ys[:, [3, 50]] = np.nan  # same missing rows in every sequence
    batch = _compare_batch(model, ys)
    assert batch.means.shape == (6, 120, 4) and batch.covs.shape == (6, 120, 4, 4)
    assert batch.loglik.shape == (6,) and batch.observed.shape == (6, 120)


def test_batch_equals_per_sequence_different_patterns():
    rng = np.random.default_rng(9)
    model = random_model(rng, 3, 2, q=1, p=2)
    us = rng.standard_normal((7, 29, 2))
    ys = np.stack([bf.models.simulate(model, 30, rng, us=us[i]).ys for i in range(7)])
    ys[1, [0, 1]] = np.nan
    ys[2, 10:20] = np.nan
    ys[4, 29] = np.nan
    ys[5, 0] = np.nan
    _compare_batch(model, ys, us)        # per-sequence inputs
    _compare_batch(model, ys, us[0])     # shared inputs


def test_batch_with_inputs_one_pattern_and_few_patterns():
    rng = np.random.default_rng(13)
    model = random_model(rng, 4, 2, q=2, p=1)
    us = rng.standard_normal((3, 24, 1))
    ys = np.stack([bf.models.simulate(model, 25, rng, us=us[i]).ys for i in range(3)])
    _compare_batch(model, ys, us)          # one pattern, per-sequence inputs
    _compare_batch(model, ys, us[1])       # one pattern, shared inputs
    ys[2, 7] = np.nan
    _compare_batch(model, ys, us)          # two patterns
    _compare_batch(model, ys, us[0])


def test_batch_equals_per_sequence_few_patterns(particle):
    """A few distinct patterns: the covariances are computed per pattern, vectorised over the
    patterns, and each sequence picks its pattern's gain."""
    model, _ = particle
    rng = np.random.default_rng(12)
    ys = np.stack([bf.models.simulate(model, 150, rng).ys for _ in range(5)])
    ys[[0, 3], 2] = np.nan
    ys[1, 100:] = np.nan
    batch = _compare_batch(model, ys)
    assert not batch.covs.flags.writeable


def test_batch_scalar_measurements_and_single_sequence():
    model = bf.models.LinearGaussian(A=[[0.9]], C=[[1.0]], Q=[[0.1]], R=[[0.5]], m0=[0.0],
                                     P0=[[1.0]])
    ys = np.random.default_rng(1).standard_normal((1, 15, 1))
    _compare_batch(model, ys)
    np.testing.assert_allclose(bf.kalman.batch_kalman_filter(model, ys[:, :, 0]).means,
                               bf.kalman.batch_kalman_filter(model, ys).means)


def test_monte_carlo_consistency_nees_and_nis():
    """Over many simulated runs the errors have exactly the covariances the filter reports:
    the run-averaged NEES (NIS) stays in the chi-square interval of the average."""
    model = bf.models.damped_particle()
    rng = np.random.default_rng(31)
    M, T = 2000, 60
    # simulate all runs at once, straight from the model equations
    xs = np.empty((M, T, 4))
    xs[:, 0] = model.m0 + rng.standard_normal((M, 4)) @ np.linalg.cholesky(model.P0).T
    for t in range(T - 1):
        w = rng.standard_normal((M, 2)) * np.sqrt(np.diag(model.Q))
        xs[:, t + 1] = xs[:, t] @ model.A.T + w @ model.G.T
    ys = xs @ model.C.T + rng.standard_normal((M, T, 2)) * np.sqrt(np.diag(model.R))
    res = bf.kalman.batch_kalman_filter(model, ys)
    nees = bf.gaussian.squared_mahalanobis(xs - res.means, res.covs).mean(axis=0)
    nis = bf.gaussian.squared_mahalanobis(res.innovations, res.innovation_covs).mean(axis=0)
    low, high = bf.gaussian.chi2_interval(4, M, confidence=0.9999)
    assert ((nees > low) & (nees < high)).all()
    low, high = bf.gaussian.chi2_interval(2, M, confidence=0.9999)
    assert ((nis > low) & (nis < high)).all()


# --------------------------------------------------------------------------
# Steady state
# --------------------------------------------------------------------------

def test_steady_state_solves_riccati_and_filter_converges(particle):
    model, _ = particle
    ss = bf.kalman.steady_state(model)
    A, C, R = model.A, model.C, model.R
    GQG = model.G @ model.Q @ model.G.T
    P = ss.pred_cov
    riccati = A @ P @ A.T - A @ P @ C.T @ np.linalg.solve(C @ P @ C.T + R, C @ P @ A.T) + GQG
    np.testing.assert_allclose(riccati, P, rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(ss.gain, P @ C.T @ np.linalg.inv(C @ P @ C.T + R), **TOL)
    np.testing.assert_allclose(ss.cov, P - ss.gain @ C @ P, rtol=1e-9, atol=1e-12)
    # The textbook recursion from a very different P0 converges to it as well
    preds, posts = textbook_cov_pass(
        bf.models.damped_particle(P0=100 * np.eye(4)), 1500, np.ones(1500, bool))
    np.testing.assert_allclose(preds[-1], ss.pred_cov, rtol=1e-8, atol=1e-12)
    # and so does the filter
    res = bf.kalman.kalman_filter(model, np.zeros((800, 2)))
    np.testing.assert_allclose(res.pred_covs[-1], ss.pred_cov, rtol=1e-8, atol=1e-12)
    np.testing.assert_allclose(res.covs[-1], ss.cov, rtol=1e-8, atol=1e-12)
    np.testing.assert_allclose(res.gains[-1], ss.gain, rtol=1e-8, atol=1e-12)


def test_steady_state_without_stabilising_solution():
    # An unstable mode (1.1) that the measurement does not see: no steady state.
    model = bf.models.LinearGaussian(A=np.diag([1.1, 0.5]), C=[[0.0, 1.0]], Q=np.eye(2),
                                     R=[[1.0]], m0=np.zeros(2), P0=np.eye(2))
    with pytest.raises(ValueError, match="stabilising"):
        bf.kalman.steady_state(model)


def test_steady_state_needs_a_definite_P0_when_the_noise_cannot_stabilise():
    """The docstring's counterexample: A = 2, C = 1, Q = 0, R = 1. (A, G Q^{1/2}) is not
    stabilisable; the Riccati equation P = 4 P / (P + 1) has the stabilising solution 3 and
    the other solution 0. From P0 = 0 the recursion stays at 0; from any P0 > 0 it goes
    to 3. Reference: the scalar recursion by hand."""
    model = bf.models.LinearGaussian(A=[[2.0]], C=[[1.0]], Q=[[0.0]], R=[[1.0]], m0=[0.0],
                                     P0=[[0.0]])
    assert bf.kalman.steady_state(model).pred_cov[0, 0] == pytest.approx(3.0, rel=1e-10)
    ys = np.zeros((60, 1))
    assert (bf.kalman.kalman_filter(model, ys).pred_covs == 0.0).all()
    for p0 in (1e-6, 1.0, 1e6):
        p = p0
        for _ in range(59):
            p = 4.0 * p / (p + 1.0)   # P_{t+1|t} = A^2 P R / (P + R) + Q
        res = bf.kalman.kalman_filter(dataclasses.replace(model, P0=[[p0]]), ys)
        assert res.pred_covs[-1, 0, 0] == pytest.approx(p, rel=1e-9)
        assert p == pytest.approx(3.0, rel=1e-9)


def test_steady_state_needs_definite_R():
    model = bf.models.LinearGaussian(A=[[0.5]], C=[[1.0]], Q=[[1.0]], R=[[0.0]], m0=[0.0],
                                     P0=[[1.0]])
    with pytest.raises(ValueError, match=r"R must be positive definite \(invertible\)"):
        bf.kalman.steady_state(model)


# --------------------------------------------------------------------------
# Bad inputs
# --------------------------------------------------------------------------

def test_bad_model_arguments():
    ok = dict(A=np.eye(2), C=[[1.0, 0.0]], Q=np.eye(2), R=[[1.0]], m0=np.zeros(2), P0=np.eye(2))
    LG = bf.models.LinearGaussian
    for key, bad, match in [
        ("A", np.ones((2, 3)), r"A must be square \(n, n\), got shape \(2, 3\)"),
        ("C", np.ones((1, 3)), r"C must have shape \(\?, 2\), got shape \(1, 3\)"),
        ("Q", [[1.0, 0.5], [0.0, 1.0]], "Q must be symmetric"),
        ("Q", [[1.0, 0.0], [0.0, -1.0]], "Q must be positive semi-definite"),
        ("R", [[-1.0]], "R must be positive semi-definite"),
        ("R", np.eye(2), r"R must have shape \(1, 1\)"),
        ("P0", [[1.0, 2.0], [2.0, 1.0]], "P0 must be positive semi-definite"),
        ("P0", [[1.0, 0.1], [0.0, 1.0]], "P0 must be symmetric"),
        ("P0", np.eye(3), r"P0 must have shape \(2, 2\), got shape \(3, 3\)"),
        ("m0", np.zeros(3), r"m0 must have shape \(2,\), got shape \(3,\)"),
        ("m0", [0.0, np.nan], "m0 must be finite"),
    ]:
        with pytest.raises(ValueError, match=match):
            LG(**{**ok, key: bad})


def test_bad_filter_arguments(particle):
    model, ys = particle
    with pytest.raises(TypeError, match="model must be a bayesfilt.models.LinearGaussian, got "
                                       "NonlinearGaussian"):
        bf.kalman.kalman_filter(bf.models.to_nonlinear(model), ys)
    with pytest.raises(TypeError, match="model must be a bayesfilt.models.LinearGaussian, got str"):
        bf.kalman.batch_kalman_filter("model", ys[None])
    with pytest.raises(ValueError, match=r"ys must have shape \(T, 2\), got shape \(60, 1\)"):
        bf.kalman.kalman_filter(model, ys[:, :1])
    with pytest.raises(ValueError, match=r"ys must have shape \(T, 2\), got shape \(1, 60, 2\)"):
        bf.kalman.kalman_filter(model, ys[None])
    with pytest.raises(ValueError, match="ys must have at least one row"):
        bf.kalman.kalman_filter(model, np.zeros((0, 2)))
    with pytest.raises(ValueError, match="ys must be finite"):
        bf.kalman.kalman_filter(model, np.array([[0.0, np.inf]]))
    partly = ys.copy()
    partly[17, 1] = np.nan
    partly[20, 0] = -np.inf
    with pytest.raises(ValueError, match=r"ys must be finite or NaN \(missing\), got inf at "
                                         r"index \(20, 0\)"):
        bf.kalman.kalman_filter(model, partly)
    with pytest.raises(ValueError, match=r"got inf at index \(1, 20, 0\)"):
        bf.kalman.batch_kalman_filter(model, np.stack([ys, partly]))
    with pytest.raises(ValueError, match=r"ys must have shape \(M, T, 2\), got shape \(60, 2\)"):
        bf.kalman.batch_kalman_filter(model, ys)
    with pytest.raises(ValueError, match="us was given but the model has no control matrix B"):
        bf.kalman.kalman_filter(model, ys, np.zeros((len(ys) - 1, 2)))
    pushed = bf.models.damped_particle(B=model.G)
    with pytest.raises(ValueError, match="us must have T - 1"):
        bf.kalman.kalman_filter(pushed, ys, np.zeros((len(ys) - 2, 2)))
    with pytest.raises(ValueError, match="us must have shape"):
        bf.kalman.kalman_filter(pushed, ys, np.zeros((len(ys) - 1, 3)))
    with pytest.raises(ValueError, match="us must be finite"):
        bf.kalman.kalman_filter(pushed, ys, np.full((len(ys) - 1, 2), np.nan))
    with pytest.raises(ValueError, match="us must have shape"):
        bf.kalman.batch_kalman_filter(pushed, np.stack([ys, ys]), np.zeros((3, len(ys) - 1, 2)))


def test_singular_innovation_covariance_names_the_step():
    # Noise-free x_0 measured exactly: after step 0, P = 0 and S = C P C^T + R = 0.
    model = bf.models.LinearGaussian(A=[[1.0]], C=[[1.0]], Q=[[0.0]], R=[[0.0]], m0=[0.0],
                                     P0=[[1.0]])
    with pytest.raises(ValueError, match="innovation covariance S .* time step 1"):
        bf.kalman.kalman_filter(model, np.zeros((3, 1)))
    with pytest.raises(ValueError, match="innovation covariance S .* time step 1"):
        bf.kalman.batch_kalman_filter(model, np.zeros((2, 3, 1)))


def test_bad_step_arguments():
    x, P, A, Q = np.zeros(2), np.eye(2), np.eye(2), np.eye(2)
    with pytest.raises(ValueError, match="P must be symmetric"):
        bf.kalman.predict(x, [[1.0, 0.2], [0.0, 1.0]], A, Q)
    with pytest.raises(ValueError, match="P must be positive semi-definite"):
        bf.kalman.predict(x, -np.eye(2), A, Q)
    with pytest.raises(ValueError, match=r"A must have shape \(2, 2\), got shape \(2, 3\)"):
        bf.kalman.predict(x, P, np.ones((2, 3)), Q)
    with pytest.raises(ValueError, match=r"A must have shape \(2, 2\), got shape \(3, 3\)"):
        bf.kalman.predict(x, P, np.eye(3), Q)
    with pytest.raises(ValueError, match="Q must have shape"):
        bf.kalman.predict(x, P, A, np.eye(1))
    with pytest.raises(ValueError, match=r"G must have shape \(2, 1\), got shape \(3, 1\)"):
        bf.kalman.predict(x, P, A, np.eye(1), G=np.ones((3, 1)))
    with pytest.raises(ValueError, match=r"u was given but B \(the control matrix\) is None"):
        bf.kalman.predict(x, P, A, Q, u=[1.0])
    with pytest.raises(ValueError, match=r"u must have shape \(2,\), got shape \(3,\)"):
        bf.kalman.predict(x, P, A, Q, B=np.eye(2), u=[1.0, 2.0, 3.0])
    with pytest.raises(ValueError, match="x must be finite"):
        bf.kalman.predict([np.nan, 0.0], P, A, Q)
    C, R = np.eye(1, 2), np.eye(1)
    with pytest.raises(ValueError, match="y must have shape"):
        bf.kalman.update(x, P, [1.0, 2.0], C, R)
    with pytest.raises(ValueError, match=r"C must have shape \(\?, 2\), got shape \(1, 3\)"):
        bf.kalman.update(x, P, [1.0], np.ones((1, 3)), R)
    with pytest.raises(ValueError, match=r"R must have shape \(1, 1\), got shape \(2, 2\)"):
        bf.kalman.update(x, P, [1.0], C, np.eye(2))
    with pytest.raises(ValueError, match="y must be finite"):
        bf.kalman.update(x, P, [np.nan], C, R)
    with pytest.raises(ValueError, match="innovation covariance S"):
        bf.kalman.update(x, np.zeros((2, 2)), [1.0], C, np.zeros((1, 1)))


# --------------------------------------------------------------------------
# Overflow is reported, never returned as NaN (API review)
# --------------------------------------------------------------------------

def test_overflow_is_an_error_not_nan():
    eye = np.eye(2)
    with pytest.raises(ValueError, match="kalman.update: .*overflowed"):
        bf.kalman.update([0.0, 0.0], 1e200 * eye, [0.0, 0.0], 1e200 * eye, eye)
    model = bf.models.LinearGaussian(A=1e30 * eye, C=eye, Q=eye, R=eye, m0=np.zeros(2), P0=eye)
    ys = np.r_[np.zeros((1, 2)), np.full((10, 2), np.nan), np.zeros((1, 2))]
    with pytest.raises(ValueError, match="kalman_filter: .* overflowed"):
        bf.kalman.kalman_filter(model, ys)
    with pytest.raises(ValueError, match="batch_kalman_filter: .* overflowed"):
        bf.kalman.batch_kalman_filter(model, ys[None])


# --------------------------------------------------------------------------
# Partly-missing measurements: an independent filter that deletes them
# --------------------------------------------------------------------------

def _knock_out(rng, ys, fraction=0.3, whole_rows=(3, 11)):
    """About ``fraction`` of the components set to NaN at random, and the rows
    ``whole_rows`` entirely (a missing measurement)."""
    ys = np.array(ys, dtype=float)
    ys[rng.random(ys.shape) < fraction] = np.nan
    ys[..., list(whole_rows), :] = np.nan
    return ys


def deleting_filter(model, ys, us=None):
    """The Kalman filter written out with the missing components deleted by hand.

    Textbook form (explicit inverse, P - K C P), no bayesfilt code: on each row
    the observed components o keep their rows of C and their rows and columns
    of R, y_o ~ N(C_o x, R_oo); a row with no observed component is skipped.
    Returns the fields of FilterResult with the documented full-shape
    conventions: NaN innovations and S entries, zero gain columns, where missing.
    """
    n, m = model.state_dim, model.obs_dim
    T = len(ys)
    A, C, R = model.A, model.C, model.R
    GQG = model.G @ model.Q @ model.G.T
    out = {"means": np.zeros((T, n)), "covs": np.zeros((T, n, n)),
           "pred_means": np.zeros((T, n)), "pred_covs": np.zeros((T, n, n)),
           "innovations": np.full((T, m), np.nan), "innovation_covs": np.full((T, m, m), np.nan),
           "gains": np.zeros((T, n, m)), "step_logliks": np.zeros(T)}
    x, P = model.m0.copy(), model.P0.copy()
    for t in range(T):
        if t > 0:
            x = A @ x + (0 if us is None else model.B @ us[t - 1])
            P = A @ P @ A.T + GQG
        out["pred_means"][t], out["pred_covs"][t] = x, P
        keep = [j for j in range(m) if not np.isnan(ys[t][j])]
        if keep:
            Co, Ro, yo = C[keep, :], R[np.ix_(keep, keep)], ys[t][keep]
            S = Co @ P @ Co.T + Ro
            K = P @ Co.T @ np.linalg.inv(S)
            r = yo - Co @ x
            out["step_logliks"][t] = multivariate_normal(Co @ x, S).logpdf(yo)
            x = x + K @ r
            P = P - K @ Co @ P
            for a, j in enumerate(keep):
                out["innovations"][t, j] = r[a]
                out["gains"][t, :, j] = K[:, a]
                for b, k in enumerate(keep):
                    out["innovation_covs"][t, j, k] = S[a, b]
        out["means"][t], out["covs"][t] = x, P
    return out


def _assert_matches(res, ref, rtol=1e-8, atol=1e-10, what=""):
    for key, want in ref.items():
        got = np.asarray(getattr(res, key))
        # the same NaN pattern, and the same numbers elsewhere
        np.testing.assert_array_equal(np.isnan(got), np.isnan(want), err_msg=f"{what} {key}")
        np.testing.assert_allclose(got, want, rtol=rtol, atol=atol, equal_nan=True,
                                   err_msg=f"{what} {key}")


@pytest.mark.parametrize("with_inputs", [False, True])
def test_partly_missing_rows_against_a_filter_that_deletes_them(with_inputs):
    rng = np.random.default_rng(70 + with_inputs)
    model = random_model(rng, 4, 3, q=2, p=2 if with_inputs else None)
    T = 40
    us = rng.standard_normal((T - 1, 2)) if with_inputs else None
    ys = _knock_out(rng, bf.models.simulate(model, T, rng, us=us).ys)
    partly = np.isnan(ys).any(axis=1) & ~np.isnan(ys).all(axis=1)
    assert partly.sum() >= 10, "the test needs many partly-missing rows"
    res = bf.kalman.kalman_filter(model, ys, us)
    ref = deleting_filter(model, ys, us)
    _assert_matches(res, ref)
    np.testing.assert_allclose(res.loglik, ref["step_logliks"].sum(), rtol=1e-10)
    np.testing.assert_array_equal(res.observed_components, ~np.isnan(ys))
    np.testing.assert_array_equal(res.observed, ~np.isnan(ys).all(axis=1))
    # an all-NaN row is a pure prediction, as before
    np.testing.assert_array_equal(res.means[[3, 11]], res.pred_means[[3, 11]])


def joint_gaussian_loglik(model, ys, us=None):
    """log p(every observed component of ys), from the joint Gaussian of all of them
    written out directly (no recursion): the stacked C x_t + v_t, observed entries kept."""
    n, m = model.state_dim, model.obs_dim
    T = len(ys)
    A, GQG = model.A, model.G @ model.Q @ model.G.T
    mean_x, cov_x = np.zeros(T * n), np.zeros((T * n, T * n))
    # x_t = A^t x_0 + sum_{s<t} A^{t-1-s} (B u_s + G w_s)
    Phi = [np.linalg.matrix_power(A, t) for t in range(T)]
    x_det = model.m0.copy()
    for t in range(T):
        if t > 0:
            x_det = A @ x_det + (0 if us is None else model.B @ us[t - 1])
        mean_x[t * n:(t + 1) * n] = x_det
        for s in range(t + 1):
            # Cov(x_t, x_s) = A^t P0 A^s^T + sum_{k < s} A^{t-1-k} GQG A^{s-1-k}^T
            c = Phi[t] @ model.P0 @ Phi[s].T
            for k in range(s):
                c = c + Phi[t - 1 - k] @ GQG @ Phi[s - 1 - k].T
            cov_x[t * n:(t + 1) * n, s * n:(s + 1) * n] = c
            cov_x[s * n:(s + 1) * n, t * n:(t + 1) * n] = c.T
    keep = ~np.isnan(ys).ravel()
    Cbig = np.kron(np.eye(T), model.C)[keep]
    cov_y = Cbig @ cov_x @ Cbig.T + np.kron(np.eye(T), model.R)[np.ix_(keep, keep)]
    return multivariate_normal(Cbig @ mean_x, cov_y).logpdf(ys.ravel()[keep])


def test_partly_missing_loglik_equals_the_joint_gaussian():
    rng = np.random.default_rng(77)
    model = random_model(rng, 3, 3, q=2, p=1)
    T = 9
    us = rng.standard_normal((T - 1, 1))
    ys = _knock_out(rng, bf.models.simulate(model, T, rng, us=us).ys, whole_rows=(4,))
    res = bf.kalman.kalman_filter(model, ys, us)
    np.testing.assert_allclose(res.loglik, joint_gaussian_loglik(model, ys, us), rtol=1e-9)
    # the brute force also holds with every row observed (no missing-data path involved)
    full = bf.models.simulate(model, T, np.random.default_rng(1), us=us).ys
    np.testing.assert_allclose(bf.kalman.kalman_filter(model, full, us).loglik,
                               joint_gaussian_loglik(model, full, us), rtol=1e-9)


def test_partly_missing_rows_are_update_on_the_selected_components_bit_for_bit():
    """kalman_filter on a partly-NaN row = update(x, P, y_o, C_o, R_oo) (select_observed)."""
    rng = np.random.default_rng(78)
    model = random_model(rng, 4, 3, q=4)
    ys = _knock_out(rng, bf.models.simulate(model, 25, rng).ys)
    res = bf.kalman.kalman_filter(model, ys)
    x, P = model.m0, model.P0
    for t in range(len(ys)):
        if t > 0:
            x, P = bf.kalman.predict(x, P, model.A, model.Q, G=model.G)
        part = bf.kalman.select_observed(ys[t], model.C, model.R)
        if part.mask.any():
            step = bf.kalman.update(x, P, part.y, part.C, part.R)
            x, P = step.mean, step.cov
            assert np.array_equal(res.gains[t][:, part.mask], step.gain), t
            assert np.array_equal(res.innovations[t][part.mask], step.innovation), t
            assert res.step_logliks[t] == step.loglik, t
        assert np.array_equal(res.means[t], x) and np.array_equal(res.covs[t], P), t


def test_select_observed_and_its_errors():
    C, R = np.arange(6.0).reshape(3, 2), np.array([[4.0, 1, 2], [1, 5, 3], [2, 3, 6]])
    part = bf.kalman.select_observed([1.0, np.nan, 3.0], C, R)
    np.testing.assert_array_equal(part.mask, [True, False, True])
    np.testing.assert_array_equal(part.y, [1.0, 3.0])
    np.testing.assert_array_equal(part.C, [[0.0, 1.0], [4.0, 5.0]])
    np.testing.assert_array_equal(part.R, [[4.0, 2.0], [2.0, 6.0]])
    assert bf.kalman.select_observed([np.nan] * 3, C, R).y.shape == (0,)
    with pytest.raises(ValueError, match="y must be finite or NaN .* index 1"):
        bf.kalman.select_observed([1.0, np.inf, 3.0], C, R)
    with pytest.raises(ValueError, match=r"C must have shape \(3, \?\)"):
        bf.kalman.select_observed([1.0, 2.0, 3.0], C[:2], R)


def test_batch_with_partly_missing_rows_and_different_patterns():
    """Sequences with their own random patterns (some shared, some all-NaN rows), with
    per-sequence and shared inputs: batch = one kalman_filter per sequence, and both
    = the deleting filter."""
    rng = np.random.default_rng(79)
    model = random_model(rng, 3, 3, q=2, p=1)
    M, T = 7, 20
    us = rng.standard_normal((M, T - 1, 1))
    ys = np.stack([bf.models.simulate(model, T, rng, us=us[i]).ys for i in range(M)])
    ys[:5] = _knock_out(rng, ys[:5], whole_rows=(2,))
    ys[5][np.isnan(ys[0])] = np.nan          # sequence 5 shares sequence 0's pattern
    # sequence 6 is fully observed
    for u in (us, us[0]):
        batch = _compare_batch(model, ys, u)
        for i in (0, 3, 6):
            ref = deleting_filter(model, ys[i], u if u.ndim == 2 else u[i])
            _assert_matches(bf.kalman.kalman_filter(model, ys[i], u if u.ndim == 2 else u[i]),
                            ref, what=f"sequence {i}")
        np.testing.assert_array_equal(batch.observed_components, ~np.isnan(ys))
        np.testing.assert_array_equal(batch.observed, ~np.isnan(ys).all(axis=2))
    # one pattern shared by all, partly missing: the D = 1 path
    ys_same = np.stack([bf.models.simulate(model, T, rng).ys for _ in range(3)])
    ys_same[:, np.isnan(ys[0])] = np.nan
    _compare_batch(model, ys_same, us[0])


def test_missing_inputs_rows_and_inf_in_every_filter():
    model = bf.models.damped_particle(B=bf.models.damped_particle().G)
    rng = np.random.default_rng(80)
    us = rng.standard_normal((29, 2))
    ys = _knock_out(rng, bf.models.simulate(model, 30, rng, us=us).ys)
    _assert_matches(bf.kalman.kalman_filter(model, ys, us), deleting_filter(model, ys, us))
    bad = ys.copy()
    bad[4, 1] = np.inf
    for run in (lambda: bf.kalman.kalman_filter(model, bad, us),
                lambda: bf.kalman.batch_kalman_filter(model, bad[None], us)):
        with pytest.raises(ValueError, match="ys must be finite or NaN"):
            run()


# --------------------------------------------------------------------------
# What a one-line change would break (issue 20's mutation survivors)
# --------------------------------------------------------------------------

def _mixed_scale_covariance(rng, n=5):
    """A covariance whose entries range from about 1e-6 to 1e6: D M D with a random
    correlation matrix M and D = diag(1e-3 .. 1e3)."""
    B = rng.standard_normal((n, n))
    M = B @ B.T + n * np.eye(n)
    M /= np.sqrt(np.outer(np.diag(M), np.diag(M)))
    D = np.diag(np.logspace(-3, 3, n))
    P = D @ M @ D
    return 0.5 * (P + P.T)


def test_predict_makes_P_exactly_symmetric_at_mixed_scales():
    """The docstring promises exact symmetry (P == P^T bit for bit), and the batch filter
    relies on it; without the symmetrisation, rounding leaves A P A^T + G Q G^T
    asymmetric here."""
    rng = np.random.default_rng(90)
    A, P = rng.standard_normal((5, 5)), _mixed_scale_covariance(rng)
    assert 1e-7 < np.abs(P).min() and np.abs(P).max() < 1e7
    Q = _mixed_scale_covariance(rng)
    raw = A @ P @ A.T + Q
    assert (raw != raw.T).any(), "the test needs a case where rounding breaks symmetry"
    _, P_pred = bf.kalman.predict(np.zeros(5), P, A, Q)
    assert np.array_equal(P_pred, P_pred.T)
    np.testing.assert_allclose(P_pred, raw, rtol=1e-12, atol=1e-12 * np.abs(raw).max())
    # the update too, and every covariance of both filters
    C, R = rng.standard_normal((3, 5)), _mixed_scale_covariance(rng, 3)
    step = bf.kalman.update(np.zeros(5), P_pred, np.ones(3), C, R)
    assert np.array_equal(step.cov, step.cov.T)
    model = bf.models.LinearGaussian(A=A / np.max(np.abs(np.linalg.eigvals(A))), C=C, Q=Q, R=R,
                                     m0=np.zeros(5), P0=P)
    ys = np.ones((6, 3))
    ys[2] = np.nan
    ys[4, 1] = np.nan
    for res in (bf.kalman.kalman_filter(model, ys),
                bf.kalman.batch_kalman_filter(model, np.stack([ys, ys + 1, ys[::-1]]))):
        for covs in (res.covs, res.pred_covs):
            assert np.array_equal(covs, np.swapaxes(covs, -1, -2))


def test_a_huge_but_well_conditioned_S_is_accepted():
    """The singularity test compares each squared pivot L_ii^2 with m eps S_ii: a test
    independent of the units. With S = 1e40 + 1 (a prior variance of 1e40), the pivot
    1e20 is far from singular; the unsquared L_ii <= m eps S_ii (1e20 <= 2e24) would
    reject it. Reference: the scalar update in information form."""
    step = bf.kalman.update([0.0], [[1e40]], [3.0], [[1.0]], [[1.0]])
    assert step.mean[0] == pytest.approx(3.0, rel=1e-15)
    assert step.cov[0, 0] == pytest.approx(1.0 / (1e-40 + 1.0), rel=1e-12)
    model = bf.models.LinearGaussian(A=[[1.0]], C=[[1.0]], Q=[[1.0]], R=[[1.0]], m0=[0.0],
                                     P0=[[1e40]])
    one = bf.kalman.kalman_filter(model, np.ones((3, 1)))
    batch = bf.kalman.batch_kalman_filter(model, np.ones((2, 3, 1)))
    for variance in (one.covs[0, 0, 0], batch.covs[0, 0, 0, 0], batch.covs[1, 0, 0, 0]):
        assert variance == pytest.approx(1.0 / (1e-40 + 1.0), rel=1e-12)


def test_a_numerically_singular_S_is_rejected():
    """S = [[1, 1], [1, 1 + eps]] (two sensors that differ by 2^-26 in one coefficient, no
    noise): its second pivot squared is eps, below m eps S_22 = 2 eps, so S is singular at
    the rounding level and must be refused, though Cholesky succeeds. (The unsquared
    test, 2^-26 > 2 eps, would accept it.)"""
    C, R = np.array([[1.0, 0.0], [1.0, 2.0 ** -26]]), np.zeros((2, 2))
    S = C @ C.T + R
    assert S[1, 1] == 1.0 + np.finfo(float).eps and np.linalg.cholesky(S)[1, 1] > 0
    with pytest.raises(ValueError, match="innovation covariance S"):
        bf.kalman.update(np.zeros(2), np.eye(2), [1.0, 1.0], C, R)
    model = bf.models.LinearGaussian(A=np.eye(2), C=C, Q=np.eye(2), R=R, m0=np.zeros(2),
                                     P0=np.eye(2))
    with pytest.raises(ValueError, match="innovation covariance S .* time step 0"):
        bf.kalman.kalman_filter(model, np.ones((2, 2)))
    with pytest.raises(ValueError, match="innovation covariance S .* time step 0"):
        bf.kalman.batch_kalman_filter(model, np.ones((2, 2, 2)))


def test_the_singularity_rule_at_its_boundary():
    """The documented rule: S is refused when a squared pivot L_ii^2 <= m eps S_ii. With
    y = (x, x + v), var v = d, P = 1, R = diag(0, d): S = [[1, 1], [1, 1 + d]] and the
    second squared pivot is d exactly. For m = 2: d = 2 eps is refused (2 eps <= 2 eps
    (1 + 2 eps)), d = 4 eps accepted (4 eps > 2 eps (1 + 4 eps)); a threshold of eps
    instead of m eps would accept the first."""
    eps = np.finfo(float).eps
    C = np.array([[1.0], [1.0]])
    with pytest.raises(ValueError, match="innovation covariance S"):
        bf.kalman.update([0.0], [[1.0]], [0.0, 0.0], C, np.diag([0.0, 2 * eps]))
    step = bf.kalman.update([0.0], [[1.0]], [0.0, 0.0], C, np.diag([0.0, 4 * eps]))
    # the first component measures x exactly: the posterior variance is 0 (to rounding)
    assert abs(step.cov[0, 0]) < 1e-15


def test_non_symmetric_gain_with_n_equal_to_m():
    """n = m = 3, so a transposed gain K^T has the right shape: only the values can tell.
    Reference: K = P C^T (C P C^T + R)^{-1} with an explicit inverse, and the filters
    against the deleting (textbook) filter."""
    rng = np.random.default_rng(91)
    model = random_model(rng, 3, 3, q=2)
    P, C, R = random_spd(rng, 3), model.C, model.R
    K = P @ C.T @ np.linalg.inv(C @ P @ C.T + R)
    assert np.abs(K - K.T).max() > 0.1, "the test needs a clearly non-symmetric gain"
    y, x = rng.standard_normal(3), rng.standard_normal(3)
    step = bf.kalman.update(x, P, y, C, R)
    np.testing.assert_allclose(step.gain, K, **TOL)
    np.testing.assert_allclose(step.mean, x + K @ (y - C @ x), **TOL)
    np.testing.assert_allclose(step.cov, P - K @ C @ P, rtol=1e-9, atol=1e-12)
    ys = bf.models.simulate(model, 30, rng).ys
    ref = deleting_filter(model, ys)
    _assert_matches(bf.kalman.kalman_filter(model, ys), ref)
    batch = bf.kalman.batch_kalman_filter(model, np.stack([ys, ys]))
    for key, want in ref.items():
        np.testing.assert_allclose(np.asarray(getattr(batch, key))[1], want, rtol=1e-8,
                                   atol=1e-10, err_msg=key)
