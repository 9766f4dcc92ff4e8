"""Tests of bayesfilt.smoothing against independent references.

* rts_smoother: the conditional of the whole joint Gaussian of
  (x_0, ..., x_{T-1}, the observed y_t), built by stacking and conditioned
  with plain numpy (no bayesfilt), on random linear models with missing rows
  and control inputs, and with a singular P_{t+1|t}; filterpy's
  rts_smoother where nothing is missing (and where filterpy is wrong: a
  control input);
* grid_smoother: the RTS smoother on a linear-Gaussian 1-D model;
* ffbsi: given the particle filter's output, its draws follow the exact
  marginals of the backward kernel (a frequency test); over independent
  runs, its smoothed means agree with the grid smoother within their
  Monte Carlo error;
* genealogy: a hand-made history, and the particle filter's own convention;
* every documented bad input raises a clear error naming the argument.

The Monte Carlo limits give a correct implementation a failure probability
below 1e-4 for any seed (union bound over the entries compared).
"""

from __future__ import annotations

import numpy as np
import pytest
from filterpy.kalman import KalmanFilter
from filterpy.kalman import rts_smoother as fp_rts_smoother
from scipy import stats

import bayesfilt as bf
from bayesfilt.smoothing import ffbsi, genealogy, grid_smoother, rts_smoother


# ---------------------------------------------------------------------------
# The brute-force reference: condition the whole joint Gaussian (plain numpy)
# ---------------------------------------------------------------------------

def joint_conditional(A, C, Q, R, m0, P0, G, B, us, ys):
    """E and cov of x_{0:T-1} given the measured entries of ys, by stacking everything.

    x_t = mu_t + Phi_t z with z = (x_0 - m0, w_0, ..., w_{T-2}) ~ N(0, diag(P0, Q, ..., Q))
    and mu_t = A^t m0 + sum_{s<t} A^{t-1-s} B u_s; the observed y_t = C x_t + v_t.
    Returns the means (T, n), the covariances (T, n, n) and cov(x_{t+1}, x_t | y) (T-1, n, n).
    """
    T, m = ys.shape
    n, q = A.shape[0], Q.shape[0]
    mu = np.zeros((T, n))
    mu[0] = m0
    Phi = np.zeros((T * n, n + (T - 1) * q))
    Phi[:n, :n] = np.eye(n)
    for t in range(1, T):
        mu[t] = A @ mu[t - 1] + (0.0 if B is None else B @ us[t - 1])
        Phi[t * n:(t + 1) * n] = A @ Phi[(t - 1) * n:t * n]
        Phi[t * n:(t + 1) * n, n + (t - 1) * q:n + t * q] += G
    Sz = np.zeros((n + (T - 1) * q,) * 2)
    Sz[:n, :n] = P0
    for s in range(T - 1):
        Sz[n + s * q:n + (s + 1) * q, n + s * q:n + (s + 1) * q] = Q
    Sxx = Phi @ Sz @ Phi.T
    # one block of rows per step, for the components of y_t that were measured (not NaN):
    # y_{t,o} = C_o x_t + v_{t,o}, v_{t,o} ~ N(0, R_oo)
    seen = ~np.isnan(ys)
    k = int(seen.sum())
    Cbar, Rbar = np.zeros((k, T * n)), np.zeros((k, k))
    row = 0
    for t in range(T):
        o = np.flatnonzero(seen[t])
        Cbar[row:row + o.size, t * n:(t + 1) * n] = C[o]
        Rbar[row:row + o.size, row:row + o.size] = R[np.ix_(o, o)]
        row += o.size
    mean, cov = mu.reshape(-1), Sxx
    if k:
        y = ys[seen]                                  # row by row, the measured components
        Sxy, Syy = Sxx @ Cbar.T, Cbar @ Sxx @ Cbar.T + Rbar
        mean = mean + Sxy @ np.linalg.solve(Syy, y - Cbar @ mean)
        cov = Sxx - Sxy @ np.linalg.solve(Syy, Sxy.T)
    blocks = [cov[t * n:(t + 1) * n, t * n:(t + 1) * n] for t in range(T)]
    cross = [cov[(t + 1) * n:(t + 2) * n, t * n:(t + 1) * n] for t in range(T - 1)]
    return mean.reshape(T, n), np.array(blocks), np.array(cross).reshape(T - 1, n, n)


def _covariance(rng, k):
    M = rng.normal(size=(k, k))
    return M @ M.T / k + 0.3 * np.eye(k)


def _random_case(seed, components=False):
    """A random linear model (n <= 3, m <= 2, q <= 2, p <= 2), inputs, and a record with gaps.

    components=True: m = 2 or 3, and about 30 % of the components of y are missing one by one
    (partly-NaN rows; some rows lose everything) instead of whole rows.
    """
    rng = np.random.default_rng(seed)
    n, m, q, p = (int(k) for k in rng.integers(1, [4, 3, 3, 3]))
    if components:
        m = int(rng.integers(2, 4))
    T = int(rng.integers(2, 11))
    mats = dict(A=rng.normal(size=(n, n)) / np.sqrt(n), C=rng.normal(size=(m, n)),
                Q=_covariance(rng, q), R=_covariance(rng, m), m0=rng.normal(size=n),
                P0=_covariance(rng, n), G=rng.normal(size=(n, q)), B=rng.normal(size=(n, p)))
    model = bf.models.LinearGaussian(**mats)
    us = rng.normal(size=(T - 1, p))
    ys = bf.models.simulate(model, T, rng, us=us).ys
    if components:
        ys[rng.random(ys.shape) < 0.3] = np.nan              # missing components, anywhere
    else:
        ys[rng.random(T) < 0.3] = np.nan                     # missing rows, anywhere
    return model, mats, us, ys


@pytest.mark.parametrize("seed", range(12))
def test_rts_equals_the_conditional_of_the_whole_joint_gaussian(seed):
    model, mats, us, ys = _random_case(seed)
    smooth = rts_smoother(model, bf.kalman.kalman_filter(model, ys, us=us))
    means, covs, cross = joint_conditional(**mats, us=us, ys=ys)
    np.testing.assert_allclose(smooth.means, means, rtol=0, atol=1e-8)
    np.testing.assert_allclose(smooth.covs, covs, rtol=0, atol=1e-8)
    np.testing.assert_allclose(smooth.cross_covs, cross, rtol=0, atol=1e-8)
    T, n = means.shape
    assert smooth.gains.shape == (T - 1, n, n)


@pytest.mark.parametrize("seed", range(12))
def test_rts_with_partly_missing_rows_equals_the_conditional_of_the_whole_joint_gaussian(seed):
    """About 30 % of the components missing one by one: the filter updates with the measured
    components, and the smoother needs nothing more (it reads the filter's output)."""
    model, mats, us, ys = _random_case(100 + seed, components=True)
    res = bf.kalman.kalman_filter(model, ys, us=us)
    np.testing.assert_array_equal(res.observed_components, ~np.isnan(ys))
    smooth = rts_smoother(model, res, us=us)
    means, covs, cross = joint_conditional(**mats, us=us, ys=ys)
    np.testing.assert_allclose(smooth.means, means, rtol=0, atol=1e-8)
    np.testing.assert_allclose(smooth.covs, covs, rtol=0, atol=1e-8)
    np.testing.assert_allclose(smooth.cross_covs, cross, rtol=0, atol=1e-8)


def test_the_random_records_have_partly_missing_rows():
    """The test above is not vacuous: rows with some, but not all, components missing."""
    partly = 0
    for seed in range(12):
        ys = _random_case(100 + seed, components=True)[3]
        gone = np.isnan(ys)
        partly += int(np.sum(gone.any(axis=1) & ~gone.all(axis=1)))
    assert partly >= 20


def test_rts_gain_is_the_regression_slope_of_x_t_on_x_t_plus_1():
    """J_t = P_{t|t} A^T P_{t+1|t}^{-1}, and cov(x_{t+1}, x_t | y) = P_{t+1|T-1} J_t^T."""
    model, _, us, ys = _random_case(3)
    res = bf.kalman.kalman_filter(model, ys, us=us)
    smooth = rts_smoother(model, res)
    for t in range(ys.shape[0] - 1):
        J = res.covs[t] @ model.A.T @ np.linalg.inv(res.pred_covs[t + 1])
        np.testing.assert_allclose(smooth.gains[t], J, rtol=0, atol=1e-10)
        np.testing.assert_allclose(smooth.cross_covs[t], smooth.covs[t + 1] @ J.T, atol=1e-10)


@pytest.mark.parametrize("angle", [0.0, 0.4])
def test_rts_with_a_singular_prediction_covariance(angle):
    """A component known exactly and never pushed: P_{t+1|t} is singular and the pseudo-inverse
    gives the exact conditional. Written in a rotated basis (angle 0.4), rounding makes the
    singular P_{t+1|t} pass a Cholesky factorisation with a pivot at the rounding level."""
    S = np.array([[np.cos(angle), -np.sin(angle)], [np.sin(angle), np.cos(angle)]])
    P0 = S @ np.diag([1.0, 0.0]) @ S.T
    mats = dict(A=S @ np.array([[0.9, 1.0], [0.0, 1.0]]) @ S.T, C=np.array([[1.0, 0.3]]),
                Q=np.array([[0.5]]), R=np.array([[0.4]]), m0=S @ np.array([0.0, 2.0]),
                P0=0.5 * (P0 + P0.T), G=S @ np.array([[1.0], [0.0]]), B=None)
    model = bf.models.LinearGaussian(**mats)
    ys = bf.models.simulate(model, 10, np.random.default_rng(0)).ys
    ys[3] = np.nan
    res = bf.kalman.kalman_filter(model, ys)
    assert np.linalg.matrix_rank(res.pred_covs[4]) == 1
    smooth = rts_smoother(model, res)
    means, covs, cross = joint_conditional(**mats, us=None, ys=ys)
    np.testing.assert_allclose(smooth.means, means, rtol=0, atol=1e-8)
    np.testing.assert_allclose(smooth.covs, covs, rtol=0, atol=1e-8)
    np.testing.assert_allclose(smooth.cross_covs, cross, rtol=0, atol=1e-8)


def _assert_batch_is_run_by_run(model, ys, us, batch):
    """Smoothing a batched result equals smoothing each run's own filter, to round-off."""
    for k in range(ys.shape[0]):
        one = rts_smoother(model, bf.kalman.kalman_filter(model, ys[k], us=us))
        for field in one._fields:
            np.testing.assert_allclose(getattr(batch, field)[k], getattr(one, field),
                                       rtol=0, atol=1e-12)


def test_rts_of_a_batched_result_equals_one_run_at_a_time():
    model, _, us, _ = _random_case(5)
    rng = np.random.default_rng(50)
    T = us.shape[0] + 1
    ys = bf.models.simulate_many(model, 4, T, rng, us=us).ys
    ys[1, 1] = np.nan                        # runs 1 and 2 share a missing-data pattern
    ys[2, 1] = np.nan
    batch = rts_smoother(model, bf.kalman.batch_kalman_filter(model, ys, us=us))
    _assert_batch_is_run_by_run(model, ys, us, batch)


def test_rts_of_a_batched_result_with_partly_missing_rows_groups_runs_by_component():
    """Runs 0 and 1 miss the same rows but different components: their covariances differ,
    so the smoother must group the runs by component pattern (observed_components)."""
    model, _, us, _ = _random_case(7, components=True)
    rng = np.random.default_rng(70)
    T = us.shape[0] + 1
    ys = bf.models.simulate_many(model, 4, T, rng, us=us).ys
    ys[0, 1, 0] = np.nan
    ys[1, 1, 1] = np.nan
    ys[2, 0] = np.nan
    res = bf.kalman.batch_kalman_filter(model, ys, us=us)
    np.testing.assert_array_equal(res.observed[0], res.observed[1])
    batch = rts_smoother(model, res, us=us)
    _assert_batch_is_run_by_run(model, ys, us, batch)


def test_rts_at_one_step_is_the_filter():
    model, _, _, _ = _random_case(1)
    ys = bf.models.simulate(model, 1, np.random.default_rng(1)).ys
    res = bf.kalman.kalman_filter(model, ys)
    smooth = rts_smoother(model, res)
    np.testing.assert_array_equal(smooth.means, res.means)
    assert smooth.gains.shape == (0, model.state_dim, model.state_dim)


def test_rts_checks_the_inputs_when_given_and_the_range_of_b_otherwise():
    """A result filtered with other inputs: refused when us is given; without us it is the
    exact smoother of the inputs the filter ran with (documented). Predicted means that no
    input could produce (outside A x + range(B)) are refused either way."""
    model, mats, us, ys = _random_case(4)
    other = us + 1.0
    res = bf.kalman.kalman_filter(model, ys, us=other)
    with pytest.raises(ValueError, match=r"pred_means\[1\] is not A means\[0\] \+ B us\[0\].*"
                                         r"inputs the filter ran with"):
        rts_smoother(model, res, us=us)
    smooth = rts_smoother(model, res)                       # no us: smoothed for `other`
    means, _, _ = joint_conditional(**mats, us=other, ys=ys)
    np.testing.assert_allclose(smooth.means, means, rtol=0, atol=1e-8)
    assert model.control_dim < model.state_dim              # B has a left null space
    out = np.linalg.svd(model.B)[0][:, -1]                  # a shift outside the range of B
    with pytest.raises(ValueError, match=r"pred_means\[2\] is not A means\[1\] \+ B u for "
                                         r"any input u"):
        rts_smoother(model, res._replace(pred_means=res.pred_means + np.outer(
            np.arange(ys.shape[0]) == 2, out)))
    with pytest.raises(ValueError, match=r"us must have shape \(T - 1, "):
        rts_smoother(model, res, us=us[:, :1].T)
    with pytest.raises(ValueError, match="us must have T - 1"):
        rts_smoother(model, res, us=us[:-1])


def test_rts_with_inputs_on_a_batched_result():
    model, _, us, _ = _random_case(5)
    T = us.shape[0] + 1
    ys = bf.models.simulate_many(model, 3, T, np.random.default_rng(51), us=us).ys
    per_run = np.stack([us, 2 * us, -us])
    res = bf.kalman.batch_kalman_filter(model, ys, us=per_run)
    smooth = rts_smoother(model, res, us=per_run)
    for k in range(3):
        one = rts_smoother(model, bf.kalman.kalman_filter(model, ys[k], us=per_run[k]))
        np.testing.assert_allclose(smooth.means[k], one.means, rtol=0, atol=1e-12)
    with pytest.raises(ValueError, match=r"run 1.*B us\[0\]"):
        rts_smoother(model, res, us=us)


# ---------------------------------------------------------------------------
# filterpy
# ---------------------------------------------------------------------------

def _filterpy_filter(model, ys, us=None):
    """filterpy's KalmanFilter in the course's time convention: update(y_0) first."""
    kf = KalmanFilter(dim_x=model.state_dim, dim_z=model.obs_dim)
    kf.F, kf.H, kf.R = model.A.copy(), model.C.copy(), model.R.copy()
    kf.Q = model.G @ model.Q @ model.G.T             # filterpy's Q is the course's G Q G^T
    kf.x, kf.P = model.m0.copy(), model.P0.copy()
    if us is not None:
        kf.B = model.B.copy()
    xs, Ps = [], []
    for t, y in enumerate(ys):
        if t > 0:
            kf.predict(u=0 if us is None else us[t - 1])
        kf.update(y)
        xs.append(kf.x.copy())
        Ps.append(kf.P.copy())
    return kf, np.array(xs), np.array(Ps)


def test_rts_equals_filterpy_where_nothing_is_missing():
    model = bf.models.damped_particle()
    ys = bf.models.simulate(model, 60, np.random.default_rng(7)).ys
    smooth = rts_smoother(model, bf.kalman.kalman_filter(model, ys))
    kf, xs, Ps = _filterpy_filter(model, ys)
    T = len(ys)
    # module function: Fs[k], Qs[k] move x_k to x_{k+1}; the method reads Fs[k + 1] instead
    x, P, K, Pp = fp_rts_smoother(xs, Ps, [kf.F] * T, [kf.Q] * T)
    np.testing.assert_allclose(smooth.means, x, rtol=0, atol=1e-10)
    np.testing.assert_allclose(smooth.covs, P, rtol=0, atol=1e-10)
    np.testing.assert_allclose(smooth.gains, K[:-1], rtol=0, atol=1e-10)
    x2, P2, _, _ = kf.rts_smoother(xs, Ps)
    np.testing.assert_allclose(smooth.means, x2, rtol=0, atol=1e-10)
    np.testing.assert_allclose(smooth.covs, P2, rtol=0, atol=1e-10)


def test_filterpy_rts_ignores_a_control_input():
    """filterpy predicts F x in its smoother, without B u: with an input it is off, ours is not."""
    model = bf.models.damped_particle(B=np.array([[0.0], [1.0], [0.0], [0.0]]))
    T = 30
    us = np.full((T - 1, 1), 0.2)
    ys = bf.models.simulate(model, T, np.random.default_rng(8), us=us).ys
    smooth = rts_smoother(model, bf.kalman.kalman_filter(model, ys, us=us))
    mats = dict(A=model.A, C=model.C, Q=model.Q, R=model.R, m0=model.m0, P0=model.P0, G=model.G,
                B=model.B)
    means, _, _ = joint_conditional(**mats, us=us, ys=ys)
    np.testing.assert_allclose(smooth.means, means, rtol=0, atol=1e-8)
    kf, xs, Ps = _filterpy_filter(model, ys, us)
    x, _, _, _ = fp_rts_smoother(xs, Ps, [kf.F] * T, [kf.Q] * T)
    np.testing.assert_allclose(xs, bf.kalman.kalman_filter(model, ys, us=us).means, atol=1e-10)
    assert np.abs(x - means).max() > 1.0     # filterpy's smoothed means miss the pushes


# ---------------------------------------------------------------------------
# The grid smoother
# ---------------------------------------------------------------------------

MODEL_1D = bf.models.LinearGaussian(A=[[0.9]], C=[[0.5]], Q=[[0.5]], R=[[0.4]], m0=[1.0],
                                    P0=[[2.0]])
GRID_1D = np.linspace(-12.0, 12.0, 801)


def _record_1d(T=12, seed=3):
    ys = bf.models.simulate(MODEL_1D, T, np.random.default_rng(seed)).ys
    ys[4:7] = np.nan
    return ys


def test_grid_smoother_equals_rts_on_a_linear_gaussian_model():
    ys = _record_1d()
    exact = grid_smoother(MODEL_1D, bf.bayes.grid_filter(MODEL_1D, ys, GRID_1D))
    smooth = rts_smoother(MODEL_1D, bf.kalman.kalman_filter(MODEL_1D, ys))
    np.testing.assert_allclose(exact.means, smooth.means[:, 0], rtol=0, atol=1e-10)
    np.testing.assert_allclose(exact.variances, smooth.covs[:, 0, 0], rtol=0, atol=1e-10)
    # the smoothed distribution itself, cell by cell (a Gaussian, discretised)
    cell = GRID_1D[1] - GRID_1D[0]
    for t in (0, 5, 11):
        density = stats.norm.pdf(GRID_1D, smooth.means[t, 0], np.sqrt(smooth.covs[t, 0, 0]))
        np.testing.assert_allclose(exact.posteriors[t], density * cell, rtol=0, atol=1e-10)
    np.testing.assert_allclose(exact.posteriors.sum(axis=1), 1.0, atol=1e-12)


def test_grid_smoother_last_step_is_the_filter_and_the_time_varying_model_runs():
    ungm = bf.models.ungm()
    ys = bf.models.simulate(ungm, 6, np.random.default_rng(4)).ys
    grid = np.linspace(-40.0, 40.0, 401)
    filt = bf.bayes.grid_filter(ungm, ys, grid)
    exact = grid_smoother(ungm, filt)
    np.testing.assert_array_equal(exact.posteriors[-1], filt.posteriors[-1])
    # one backward step by hand, with the transition of step 4 -> 5 (t = 4 for the UNGM)
    log_p = np.array([[ungm.transition_logpdf([b], [a], t=4) for b in grid] for a in grid[::40]])
    rows = np.exp(log_p - log_p.max(axis=1, keepdims=True))
    full = np.exp(ungm.transition_logpdf(np.tile(grid[:, None], (len(grid), 1)),
                                         np.repeat(grid[:, None], len(grid), axis=0), t=4)
                  ).reshape(len(grid), -1)
    np.testing.assert_allclose(rows / rows.sum(axis=1, keepdims=True),
                               full[::40] / full[::40].sum(axis=1, keepdims=True), atol=1e-12)
    trans = full / full.sum(axis=1, keepdims=True)
    pred = filt.posteriors[4] @ trans
    ratio = np.where(pred > 0, exact.posteriors[5] / np.where(pred > 0, pred, 1.0), 0.0)
    by_hand = filt.posteriors[4] * (trans @ ratio)
    np.testing.assert_allclose(exact.posteriors[4], by_hand / by_hand.sum(), rtol=0, atol=1e-12)


def test_grid_smoother_builds_the_transition_of_the_model_either_way():
    """The course's models: the transition from the n means f_t(g_i) and G Q G^T; a model that
    overrides transition_logpdf: the density on every pair of cells. Same result to rounding,
    on the time-varying UNGM."""
    ungm = bf.models.ungm()

    class Own(bf.models.NonlinearGaussian):
        def transition_logpdf(self, x_next, xs, u=None, t=0):
            return super().transition_logpdf(x_next, xs, u, t)

    own = Own(f=ungm.f, h=ungm.h, F=ungm.F, H=ungm.H, Q=ungm.Q, R=ungm.R, m0=ungm.m0,
              P0=ungm.P0, time_varying=True)
    assert bf.smoothing._gaussian_transition(ungm) and not bf.smoothing._gaussian_transition(own)
    ys = bf.models.simulate(ungm, 8, np.random.default_rng(5)).ys
    grid = np.linspace(-40.0, 40.0, 401)
    filt = bf.bayes.grid_filter(ungm, ys, grid)
    fast, slow = grid_smoother(ungm, filt), grid_smoother(own, filt)
    np.testing.assert_allclose(fast.posteriors, slow.posteriors, rtol=0, atol=1e-13)


# ---------------------------------------------------------------------------
# The particle filter's history: what genealogy and ffbsi rely on
# ---------------------------------------------------------------------------

def test_the_history_stores_particles_before_resampling_and_ancestors_index_the_step_before():
    quiet = bf.models.LinearGaussian(A=[[0.8]], C=[[1.0]], Q=[[1e-10]], R=[[1.0]], m0=[0.0],
                                     P0=[[4.0]])
    ys = bf.models.simulate(quiet, 15, np.random.default_rng(9)).ys
    res = bf.particle.particle_filter(quiet, ys, 200, np.random.default_rng(10),
                                      ess_threshold=1.0, keep_history=True)
    h = res.history
    # weighted particles of step t are the filter's estimate (before resampling)
    np.testing.assert_allclose(np.einsum("tin,ti->tn", h.particles, h.weights), res.means,
                               atol=1e-12)
    # x_t^(i) = 0.8 x_{t-1}^(ancestors[t][i]) + (a kick of sd 1e-5)
    for t in range(1, 15):
        moved = 0.8 * h.particles[t - 1, h.ancestors[t], 0]
        assert np.abs(h.particles[t, :, 0] - moved).max() < 1e-4
    np.testing.assert_array_equal(h.ancestors[0], np.arange(200))


# ---------------------------------------------------------------------------
# genealogy
# ---------------------------------------------------------------------------

def test_genealogy_on_a_hand_made_history():
    particles = np.arange(12.0).reshape(3, 4, 1)           # x_t^(i) = 4 t + i
    weights = np.full((3, 4), 0.25)
    ancestors = np.array([[0, 1, 2, 3], [1, 1, 3, 3], [0, 0, 1, 3]])
    g = genealogy(bf.particle.ParticleHistory(particles, weights, ancestors))
    # final particle 3 <- particle 3 at t = 1 <- particle 3 at t = 0, and so on
    np.testing.assert_array_equal(g.indices, [[1, 1, 1, 3], [0, 0, 1, 3], [0, 1, 2, 3]])
    np.testing.assert_array_equal(g.paths[:, :, 0], [[1, 4, 8], [1, 4, 9], [1, 5, 10],
                                                     [3, 7, 11]])
    np.testing.assert_array_equal(g.n_distinct, [2, 3, 4])
    np.testing.assert_array_equal(g.weights, weights[2])


def test_genealogy_paths_coalesce_going_back():
    ungm = bf.models.ungm()
    ys = bf.models.simulate(ungm, 40, np.random.default_rng(11)).ys
    res = bf.particle.particle_filter(ungm, ys, 300, np.random.default_rng(12), keep_history=True)
    g = genealogy(res.history)
    assert g.n_distinct[-1] == 300 and np.all(np.diff(g.n_distinct) >= 0)
    np.testing.assert_array_equal(g.paths[:, -1], res.history.particles[-1])


# ---------------------------------------------------------------------------
# ffbsi
# ---------------------------------------------------------------------------

def backward_marginals(model, X, W):
    """P(a backward trajectory passes through particle i at t), exactly, given the history.

    w^s_{T-1} = W_{T-1};  w^s_t(i) = W_t(i) sum_j w^s_{t+1}(j) p(x_{t+1}^j | x_t^i) /
    sum_k W_t(k) p(x_{t+1}^j | x_t^k): the marginals of FFBSi's backward chain (plain loops).
    """
    T, N, _ = X.shape
    ws = np.empty((T, N))
    ws[-1] = W[-1]
    for t in range(T - 2, -1, -1):
        p = np.array([[np.exp(model.transition_logpdf(X[t + 1, j], X[t, i], t=t))
                       for j in range(N)] for i in range(N)])          # p[i, j]
        kernel = W[t][:, None] * p
        kernel /= kernel.sum(axis=0, keepdims=True)                    # column j: backward kernel
        ws[t] = kernel @ ws[t + 1]
    return ws


def smallest_p_value(indices, exact):
    """Does each column of indices (L, T) look like L draws from the row of exact (T, N)?

    At each step: a chi-square test on the particles with an expected count of at least 5,
    the others pooled into one cell (or, when that cell expects fewer than 5 draws, an exact
    binomial upper tail for it: a normal approximation fails for expected counts far below
    1). Returns the smallest p-value over the steps.
    """
    L = indices.shape[0]
    smallest = 1.0
    for t, probs in enumerate(exact):
        counts = np.bincount(indices[:, t], minlength=probs.size)
        expected = L * probs
        big = expected >= 5
        rare_expected, rare_seen = expected[~big].sum(), counts[~big].sum()
        e, o = expected[big], counts[big]
        p_rare = 1.0
        if rare_expected >= 5:
            e, o = np.r_[e, rare_expected], np.r_[o, rare_seen]
        elif rare_seen:         # P(Binomial(L, rare_expected / L) >= rare_seen)
            p_rare = stats.binom.sf(rare_seen - 1, L, rare_expected / L)
        p_chi2 = stats.chi2.sf(np.sum((o - e) ** 2 / e), len(e) - 1) if len(e) > 1 else 1.0
        smallest = min(smallest, p_chi2, p_rare)
    return smallest


@pytest.fixture(scope="module")
def ungm_history():
    ungm = bf.models.ungm()
    ys = bf.models.simulate(ungm, 8, np.random.default_rng(13)).ys
    res = bf.particle.particle_filter(ungm, ys, 40, np.random.default_rng(14), keep_history=True)
    return ungm, res.history, backward_marginals(ungm, res.history.particles,
                                                 res.history.weights)


def test_ffbsi_draws_follow_the_exact_backward_marginals(ungm_history):
    """Given the filter's output, each index indices[l, t] is an independent draw from the
    exact marginal w^s_t; the smallest p-value over the T steps must exceed 1e-4 / T (union
    bound)."""
    ungm, h, exact = ungm_history
    draws = ffbsi(ungm, h, 20_000, np.random.default_rng(15))
    T = exact.shape[0]
    assert smallest_p_value(draws.indices, exact) > 1e-4 / T
    np.testing.assert_array_equal(draws.paths[:, :, 0],
                                  h.particles[np.arange(T), draws.indices, 0])


def test_the_frequency_test_rejects_a_backward_kernel_without_the_transition(ungm_history):
    """Draws from the filter weights alone (a kernel that forgets p(x_t+1 | x_t)) fail it."""
    _, h, exact = ungm_history
    rng = np.random.default_rng(16)
    T, N = exact.shape
    wrong_draws = np.stack([rng.choice(N, size=20_000, p=h.weights[t]) for t in range(T)],
                           axis=1)
    assert smallest_p_value(wrong_draws, exact) < 1e-12


def test_ffbsi_agrees_with_the_grid_smoother_within_its_monte_carlo_error():
    """R independent (particle filter + FFBSi) runs; the mean of their smoothed means over the
    runs is compared with the grid smoother's, in standard errors estimated from the runs
    (Student's t, union bound over the T steps). The particle filter's bias, O(1/N), is far
    below the standard error of R = 20 runs at N = 400 (a few percent of it)."""
    ys = _record_1d()
    exact = grid_smoother(MODEL_1D, bf.bayes.grid_filter(MODEL_1D, ys, GRID_1D))
    rng = np.random.default_rng(16)
    R, N, L = 20, 400, 100
    estimates = np.empty((R, ys.shape[0]))
    for r in range(R):
        pf = bf.particle.particle_filter(MODEL_1D, ys, N, rng, keep_history=True)
        estimates[r] = ffbsi(MODEL_1D, pf.history, L, rng).paths[:, :, 0].mean(axis=0)
    mean, se = estimates.mean(axis=0), estimates.std(axis=0, ddof=1) / np.sqrt(R)
    z = bf.verify.z_limit(ys.shape[0], dof=R - 1)
    worst = np.max(np.abs(mean - exact.means) / se)
    assert worst <= z, f"FFBSi is {worst:.1f} SE from the grid smoother (limit {z:.1f})"


def test_ffbsi_on_a_time_varying_model_agrees_with_the_rts_smoother_of_its_inputs():
    """f_t(x) = 0.9 x + 3 cos(1.2 (t + 1)) as a time-varying NonlinearGaussian is the linear
    model with B = 1 and u_t = 3 cos(1.2 (t + 1)): the RTS smoother with those inputs (exact,
    checked against brute force above) pins the time index of every backward step.
    Independent runs of particle filter + FFBSi, compared in standard errors (Student's t,
    union bound over the T steps). The same test with the index off by one fails (below)."""
    T, R, N, L = 10, 20, 300, 100
    us = 3.0 * np.cos(1.2 * (np.arange(T - 1) + 1))[:, None]
    lin = bf.models.LinearGaussian(A=[[0.9]], C=[[1.0]], Q=[[0.5]], R=[[0.4]], m0=[0.0],
                                   P0=[[1.0]], B=[[1.0]])
    ys = bf.models.simulate(lin, T, np.random.default_rng(30), us=us).ys
    exact = rts_smoother(lin, bf.kalman.kalman_filter(lin, ys, us=us), us=us).means[:, 0]

    class Late(bf.models.NonlinearGaussian):
        # a backward step that reads the transition of the step after (t + 1)
        def transition_logpdf(self, x_next, xs, u=None, t=0):
            return super().transition_logpdf(x_next, xs, u, t + 1)

    def model(kind):
        return kind(f=lambda x, t: 0.9 * x + 3.0 * np.cos(1.2 * (t + 1)), h=lambda x: x,
                    F=lambda x, t: np.array([[0.9]]), H=lambda x: np.array([[1.0]]), Q=[[0.5]],
                    R=[[0.4]], m0=[0.0], P0=[[1.0]], time_varying=True)

    def worst_se(tv):
        rng = np.random.default_rng(31)
        est = np.empty((R, T))
        for r in range(R):
            pf = bf.particle.particle_filter(tv, ys, N, rng, keep_history=True)
            est[r] = ffbsi(tv, pf.history, L, rng).paths[:, :, 0].mean(axis=0)
        mean, se = est.mean(axis=0), est.std(axis=0, ddof=1) / np.sqrt(R)
        return np.max(np.abs(mean - exact) / se)

    z = bf.verify.z_limit(T, dof=R - 1)
    assert worst_se(model(bf.models.NonlinearGaussian)) <= z
    late = worst_se(model(Late))
    assert late > 3 * z, f"an off-by-one time index is only {late:.1f} SE off"


def test_ffbsi_passes_the_inputs_and_the_time_index_to_the_transition():
    seen = []

    class Spy(bf.models.LinearGaussian):
        def transition_logpdf(self, x_next, xs, u=None, t=0):
            seen.append((t, None if u is None else float(u[0])))
            return super().transition_logpdf(x_next, xs, u, t)

    spy = Spy(A=[[0.9]], C=[[1.0]], Q=[[0.5]], R=[[0.4]], m0=[0.0], P0=[[1.0]], B=[[1.0]])
    us = np.array([[10.0], [20.0], [30.0]])
    ys = bf.models.simulate(spy, 4, np.random.default_rng(17), us=us).ys
    pf = bf.particle.particle_filter(spy, ys, 20, np.random.default_rng(18), us=us,
                                     keep_history=True)
    seen.clear()
    ffbsi(spy, pf.history, 5, np.random.default_rng(19), us=us)
    assert seen == [(2, 30.0), (1, 20.0), (0, 10.0)]


# ---------------------------------------------------------------------------
# Bad inputs
# ---------------------------------------------------------------------------

@pytest.fixture(scope="module")
def kalman_case():
    model = bf.models.damped_particle()
    ys = bf.models.simulate(model, 10, np.random.default_rng(20)).ys
    return model, bf.kalman.kalman_filter(model, ys)


def test_rts_bad_inputs(kalman_case):
    model, res = kalman_case
    with pytest.raises(TypeError, match="result must be the FilterResult"):
        rts_smoother(model, (res.means, res.covs))
    with pytest.raises(TypeError, match="model must be a bf.models.LinearGaussian.*extended RTS"):
        rts_smoother(bf.models.to_nonlinear(model), res)
    with pytest.raises(ValueError, match=r"result.means must have shape \(T, 2\)"):
        rts_smoother(bf.models.LinearGaussian(A=np.eye(2), C=np.eye(2), Q=np.eye(2),
                                              R=np.eye(2), m0=np.zeros(2), P0=np.eye(2)), res)
    with pytest.raises(ValueError, match=r"result.covs must have shape \(10, 4, 4\)"):
        rts_smoother(model, res._replace(covs=res.covs[:-1]))
    with pytest.raises(ValueError, match="result.pred_covs must be finite"):
        rts_smoother(model, res._replace(pred_covs=np.full_like(res.pred_covs, np.nan)))
    with pytest.raises(ValueError, match=r"does not come from this model.*pred_covs\[1\]"):
        rts_smoother(bf.models.damped_particle(force_var=0.02), res)
    with pytest.raises(ValueError, match=r"does not come from this model.*pred_covs\[0\] is not "
                                         r"model.P0"):
        rts_smoother(bf.models.damped_particle(P0=2 * np.eye(4)), res)
    with pytest.raises(ValueError, match=r"does not come from this model.*pred_means\[1\]"):
        rts_smoother(model, res._replace(pred_means=res.pred_means + 1.0))
    with pytest.raises(ValueError, match=r"result.observed_components must have shape \(10, 2\)"):
        rts_smoother(model, res._replace(observed_components=res.observed_components[:-1]))
    with pytest.raises(ValueError, match="us was given but the model has no control matrix B"):
        rts_smoother(model, res, us=np.zeros((9, 1)))


def test_grid_smoother_bad_inputs():
    ys = _record_1d(T=4)
    filt = bf.bayes.grid_filter(MODEL_1D, ys, GRID_1D)
    with pytest.raises(ValueError, match="scalar state"):
        grid_smoother(bf.models.damped_particle(), filt)
    with pytest.raises(TypeError, match="result must be the GridFilterResult"):
        grid_smoother(MODEL_1D, filt.posteriors)
    with pytest.raises(ValueError, match="result.posteriors must hold one probability vector"):
        grid_smoother(MODEL_1D, filt._replace(posteriors=2 * filt.posteriors))
    with pytest.raises(ValueError, match=r"result.posteriors must have shape \(\?, 801\)"):
        grid_smoother(MODEL_1D, filt._replace(posteriors=filt.posteriors[:, :-1]))


@pytest.fixture(scope="module")
def particle_case():
    ungm = bf.models.ungm()
    ys = bf.models.simulate(ungm, 5, np.random.default_rng(21)).ys
    res = bf.particle.particle_filter(ungm, ys, 30, np.random.default_rng(22), keep_history=True)
    return ungm, res.history


def test_particle_smoother_bad_inputs(particle_case):
    ungm, h = particle_case
    rng = np.random.default_rng(0)
    with pytest.raises(TypeError, match="history must be the ParticleHistory"):
        genealogy(h.particles)
    with pytest.raises(TypeError, match="history must be the ParticleHistory"):
        ffbsi(ungm, None, 10, rng)
    with pytest.raises(ValueError, match="n_paths must be >= 1"):
        ffbsi(ungm, h, 0, rng)
    with pytest.raises(TypeError, match="n_paths must be an integer"):
        ffbsi(ungm, h, 2.5, rng)
    with pytest.raises(TypeError, match="rng must be a numpy.random.Generator"):
        ffbsi(ungm, h, 10, 0)
    with pytest.raises(ValueError, match=r"history.particles must have shape \(T, N, 4\)"):
        ffbsi(bf.models.damped_particle(), h, 10, rng)
    with pytest.raises(ValueError, match="history.weights must be normalised"):
        ffbsi(ungm, h._replace(weights=2 * h.weights), 10, rng)
    with pytest.raises(ValueError, match="history.ancestors must be integer indices"):
        genealogy(h._replace(ancestors=h.ancestors + 30))
    with pytest.raises(ValueError, match="us was given but the model has no control matrix B"):
        ffbsi(ungm, h, 10, rng, us=np.zeros((4, 1)))
    damped = bf.models.damped_particle()
    ys = bf.models.simulate(damped, 3, np.random.default_rng(1)).ys
    hd = bf.particle.particle_filter(damped, ys, 20, np.random.default_rng(2),
                                     keep_history=True).history
    with pytest.raises(ValueError, match="ffbsi needs the transition density"):
        ffbsi(damped, hd, 10, rng)
