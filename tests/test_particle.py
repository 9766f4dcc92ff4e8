"""bf.particle against independent references: scipy's logsumexp, the Kalman
filter (exact on linear-Gaussian models), the grid filter (exact up to its
cells on a 1-D nonlinear model) and closed-form Gaussian densities.

Particle-filter outputs are random; every test uses fixed seeds, and each
tolerance is set from the known 1/N behaviour of the Monte Carlo error with
a margin of several times the spread seen over other seeds (stated in the
comments), so the tests do not flake and still fail when the code is wrong.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import stats
from scipy.special import logsumexp

import bayesfilt as bf


def linear_model(**kw):
    """A 2-D linear-Gaussian model with a full-rank transition noise."""
    args = dict(A=[[0.9, 0.2], [0.0, 0.8]], C=[[1.0, 0.0]], Q=[[0.3, 0.05], [0.05, 0.2]],
                R=[[0.5]], m0=[0.0, 0.0], P0=np.eye(2))
    args.update(kw)
    return bf.models.LinearGaussian(**args)


# --------------------------------------------------------------------------
# Weights
# --------------------------------------------------------------------------

def test_log_normalize_matches_scipy_and_survives_underflow():
    lw = np.array([-1000.0, -1001.0, -np.inf, -1002.5])   # exp() of these underflows to 0
    log_W, log_sum = bf.particle.log_normalize(lw)
    assert log_sum == pytest.approx(logsumexp(lw), rel=1e-15)
    np.testing.assert_allclose(np.exp(log_W).sum(), 1.0, rtol=1e-14)
    assert np.exp(log_W[2]) == 0.0


@pytest.mark.parametrize("bad, match", [
    ([0.0, np.nan], "log_weights must be finite or -inf"),
    ([0.0, np.inf], "log_weights must be finite or -inf"),
    ([-np.inf, -np.inf], "every weight is zero"),
    (np.zeros((2, 2)), "log_weights must be a vector"),
])
def test_log_normalize_rejects_bad_input(bad, match):
    with pytest.raises(ValueError, match=match):
        bf.particle.log_normalize(bad)


def test_ess_extremes_and_errors():
    assert bf.particle.ess(np.full(50, 3.0)) == pytest.approx(50.0, rel=1e-14)
    assert bf.particle.ess([0.0, 0.0, 2.0]) == pytest.approx(1.0)
    # two equal weights out of four: 1 / (2 * 0.5^2) = 2
    assert bf.particle.ess([1.0, 0.0, 1.0, 0.0]) == pytest.approx(2.0)
    with pytest.raises(ValueError, match="weights must be non-negative"):
        bf.particle.ess([1.0, -0.1])
    with pytest.raises(ValueError, match="weights must not all be zero"):
        bf.particle.ess([0.0, 0.0])


def test_weighted_mean_cov_against_numpy():
    rng = np.random.default_rng(0)
    X, w = rng.standard_normal((30, 3)), rng.random(30)
    W = w / w.sum()
    mean, cov = bf.particle.weighted_mean_cov(X, W)
    np.testing.assert_allclose(mean, np.average(X, axis=0, weights=W), rtol=1e-13)
    np.testing.assert_allclose(cov, np.cov(X.T, aweights=W, bias=True), rtol=1e-12, atol=1e-15)


# --------------------------------------------------------------------------
# One SIS step (seed 001, eq. (13))
# --------------------------------------------------------------------------

def test_transition_proposal_passes_the_old_state_time_to_the_model():
    # On UNGM the cosine term makes an off-by-one in t visible: q's mean at t must be
    # f(x_{t-1}, t - 1), i.e. contain 8 cos(1.2 t).
    model = bf.models.ungm()
    q = bf.particle.transition_proposal(model)
    xp = np.zeros((200_000, 1))
    draws = q.sample(np.random.default_rng(0), xp, None, 3)
    assert abs(draws.mean() - 8 * np.cos(1.2 * 3)) < 5 * np.sqrt(10 / len(draws))
    ref = stats.norm.logpdf(1.0, 8 * np.cos(1.2 * 3), np.sqrt(10))
    np.testing.assert_allclose(q.logpdf(np.ones((1, 1)), np.zeros((1, 1)), None, 3), ref, rtol=1e-12)


def test_bootstrap_step_equals_eq_13_with_the_transition_as_proposal():
    # The bootstrap shortcut (weight = likelihood) against eq. (13) written out
    # with q = p(x_t | x_{t-1}): same draws, same normalised weights.
    model = linear_model()
    rng = np.random.default_rng(1)
    X = rng.standard_normal((200, 2))
    lw = bf.particle.log_normalize(rng.standard_normal(200))[0]
    prior_q = bf.particle.transition_proposal(model)
    a = bf.particle.sis_step(model, np.random.default_rng(7), X, lw, [0.4], t=1)
    b = bf.particle.sis_step(model, np.random.default_rng(7), X, lw, [0.4], t=1, proposal=prior_q)
    np.testing.assert_array_equal(a.particles, b.particles)
    np.testing.assert_allclose(a.log_weights, b.log_weights, rtol=1e-12, atol=1e-12)
    assert a.log_increment == pytest.approx(b.log_increment, rel=1e-12)


def test_optimal_proposal_weight_is_the_predictive_likelihood():
    # For q = p(x_t | x_{t-1}, y_t) eq. (13) must give p(y_t | x_{t-1}) whatever x_t was drawn:
    # N(y; C A x_{t-1}, C G Q G^T C^T + R), computed here with scipy.
    model = linear_model()
    q = bf.particle.optimal_proposal(model)
    rng = np.random.default_rng(2)
    xp, y = rng.standard_normal((500, 2)), np.array([0.7])
    x = q.sample(rng, xp, y, 1)
    incr = (model.measurement_logpdf(y, x) + model.transition_logpdf(x, xp) - q.logpdf(x, xp, y, 1))
    S = model.C @ model.Q @ model.C.T + model.R
    ref = stats.norm.logpdf(y[0], (xp @ model.A.T @ model.C.T)[:, 0], np.sqrt(S[0, 0]))
    np.testing.assert_allclose(incr, ref, rtol=1e-10)
    # and the draws have the conditional mean and covariance of one Kalman update
    K = model.Q @ model.C.T / S[0, 0]
    one = np.tile([0.5, -0.5], (200_000, 1))
    draws = q.sample(np.random.default_rng(3), one, y, 1)
    mu = model.A @ one[0] + (K @ (y - model.C @ model.A @ one[0]))
    Sigma = (np.eye(2) - K @ model.C) @ model.Q
    se = np.sqrt(np.diag(Sigma) / len(draws))
    assert np.all(np.abs(draws.mean(axis=0) - mu) < 5 * se), "optimal proposal mean is wrong"
    np.testing.assert_allclose(np.cov(draws.T), Sigma, rtol=0.02, atol=2e-3)


def test_optimal_proposal_needs_a_transition_density():
    with pytest.raises(ValueError, match=r"G Q G\^T of full rank 4, got rank 2.*proposal=None"):
        bf.particle.optimal_proposal(bf.models.damped_particle())
    with pytest.raises(TypeError, match="LinearGaussian"):
        bf.particle.optimal_proposal(bf.models.ungm())


def test_sis_step_missing_measurement_keeps_the_weights():
    model = linear_model()
    lw = bf.particle.log_normalize(np.arange(5.0))[0]
    out = bf.particle.sis_step(model, np.random.default_rng(0), np.zeros((5, 2)), lw, [np.nan], t=3)
    np.testing.assert_array_equal(out.log_weights, lw)
    assert out.log_increment == 0.0


# --------------------------------------------------------------------------
# The filter against exact references
# --------------------------------------------------------------------------

def test_particle_filter_converges_to_the_kalman_filter():
    model = linear_model()
    xs, ys = bf.models.simulate(model, 40, np.random.default_rng(0))
    ys[10] = np.nan
    kf = bf.kalman.kalman_filter(model, ys)
    sd = np.sqrt(np.diagonal(kf.covs, axis1=1, axis2=2))
    err = {}
    for N in (500, 8000):
        pf = bf.particle.particle_filter(model, ys, N, np.random.default_rng(100))
        err[N] = np.mean(((pf.means - kf.means) / sd) ** 2)
        # The Monte Carlo error of a weighted mean is ~ c / N in squared std units;
        # c was 1-20 over 8 seeds: N * err < 100 leaves a margin of 5.
        assert N * err[N] < 100, f"N = {N}: mean squared error {err[N]:.3g} of the PF means is too large"
        np.testing.assert_array_equal(pf.observed, kf.observed)
        assert pf.step_logliks[10] == 0.0
    # 16 times more particles: the error must shrink (by ~16; 4 is a safe floor)
    assert err[8000] < err[500] / 4, f"error did not shrink with N: {err}"


def test_log_evidence_close_to_the_kalman_log_likelihood():
    model = linear_model()
    _, ys = bf.models.simulate(model, 40, np.random.default_rng(1))
    kf = bf.kalman.kalman_filter(model, ys)
    pf = bf.particle.particle_filter(model, ys, 8000, np.random.default_rng(2))
    # |error| was <= 0.25 over 8 seeds at N = 8000; 1.0 is 4x that
    assert abs(pf.loglik - kf.loglik) < 1.0, (pf.loglik, kf.loglik)
    np.testing.assert_allclose(pf.loglik, pf.step_logliks.sum())


def test_particle_filter_with_the_optimal_proposal_matches_kalman():
    model = linear_model()
    _, ys = bf.models.simulate(model, 30, np.random.default_rng(4))
    kf = bf.kalman.kalman_filter(model, ys)
    q = bf.particle.optimal_proposal(model)
    pf = bf.particle.particle_filter(model, ys, 4000, np.random.default_rng(5), proposal=q)
    sd = np.sqrt(np.diagonal(kf.covs, axis1=1, axis2=2))
    assert 4000 * np.mean(((pf.means - kf.means) / sd) ** 2) < 100
    boot = bf.particle.particle_filter(model, ys, 4000, np.random.default_rng(5), ess_threshold=0)
    opt = bf.particle.particle_filter(model, ys, 4000, np.random.default_rng(5), proposal=q,
                                      ess_threshold=0)
    # without resampling, the optimal proposal keeps a larger ESS than the prior proposal
    assert opt.ess[-1] > boot.ess[-1], (opt.ess[-1], boot.ess[-1])


def test_particle_filter_converges_to_the_grid_filter_on_ungm():
    model = bf.models.ungm()
    xs, ys = bf.models.simulate(model, 15, np.random.default_rng(0))
    grid = bf.bayes.grid_filter(model, ys, np.linspace(-40, 40, 1601))
    pf = bf.particle.particle_filter(model, ys, 20000, np.random.default_rng(1))
    sd = np.sqrt(grid.variances)
    z = (pf.means[:, 0] - grid.means) / sd
    # bimodal posteriors make c larger than in the linear case; over seeds
    # N * mean(z^2) stayed below 40: 400 leaves a margin of 10
    assert 20000 * np.mean(z ** 2) < 400, f"PF is not close to the exact (grid) posterior means: {z}"
    assert abs(pf.loglik - grid.loglik) < 1.0


def test_ungm_runs_under_ekf_and_particle_filter_without_extra_arguments():
    model = bf.models.ungm()
    xs, ys = bf.models.simulate(model, 20, np.random.default_rng(3))
    ekf = bf.ekf.extended_kalman_filter(model, ys)
    pf = bf.particle.particle_filter(model, ys, 500, np.random.default_rng(4))
    assert ekf.means.shape == pf.means.shape == (20, 1)
    # the EKF must have used the time index too: its prediction at t = 1 is f(x_0|0, 0)
    f0 = model.f(ekf.means[0], 0)
    np.testing.assert_allclose(ekf.pred_means[1], f0, rtol=1e-14)


# --------------------------------------------------------------------------
# Resampling control, history, bad input
# --------------------------------------------------------------------------

def test_threshold_zero_never_resamples_and_one_always_does():
    model = linear_model()
    _, ys = bf.models.simulate(model, 25, np.random.default_rng(0))
    sis = bf.particle.particle_filter(model, ys, 300, np.random.default_rng(1), ess_threshold=0)
    sir = bf.particle.particle_filter(model, ys, 300, np.random.default_rng(1), ess_threshold=1)
    assert not sis.resampled.any() and sir.resampled.all()
    half = bf.particle.particle_filter(model, ys, 300, np.random.default_rng(1))
    # with the default 0.5, resampling happens exactly where ESS fell below N / 2
    np.testing.assert_array_equal(half.resampled, half.ess < 150)
    assert np.all((1 <= sis.ess) & (sis.ess <= 300 + 1e-9))


@pytest.mark.parametrize("scheme", ["multinomial", "stratified", "systematic", "residual"])
def test_every_scheme_runs_the_filter(scheme):
    model = linear_model()
    _, ys = bf.models.simulate(model, 10, np.random.default_rng(0))
    res = bf.particle.particle_filter(model, ys, 2000, np.random.default_rng(1), resample=scheme)
    kf = bf.kalman.kalman_filter(model, ys)
    sd = np.sqrt(np.diagonal(kf.covs, axis1=1, axis2=2))
    assert 2000 * np.mean(((res.means - kf.means) / sd) ** 2) < 100


def test_history_is_consistent():
    model = linear_model()
    _, ys = bf.models.simulate(model, 8, np.random.default_rng(0))
    res = bf.particle.particle_filter(model, ys, 100, np.random.default_rng(1), keep_history=True)
    h = res.history
    assert h.particles.shape == (8, 100, 2) and h.weights.shape == h.ancestors.shape == (8, 100)
    np.testing.assert_allclose(h.weights.sum(axis=1), 1.0, rtol=1e-12)
    np.testing.assert_allclose(np.einsum("tn,tnk->tk", h.weights, h.particles), res.means, rtol=1e-12)
    np.testing.assert_array_equal(h.ancestors[0], np.arange(100))
    no_resample = np.flatnonzero(~res.resampled[:-1]) + 1
    for t in no_resample:   # without resampling, each particle is its own parent
        np.testing.assert_array_equal(h.ancestors[t], np.arange(100))
    assert bf.particle.particle_filter(model, ys, 10, np.random.default_rng(1)).history is None


def test_impossible_measurement_names_the_step():
    model = linear_model()
    ys = np.array([[0.1], [0.2], [1e300], [0.0]])     # (y - Cx)^2 overflows: likelihood 0
    with pytest.raises(ValueError, match=r"step t = 2: every particle's weight is zero"):
        bf.particle.particle_filter(model, ys, 100, np.random.default_rng(0))


@pytest.mark.parametrize("kwargs, err, match", [
    (dict(n_particles=0), ValueError, "n_particles must be >= 1"),
    (dict(n_particles=10.0), TypeError, "n_particles must be an integer"),
    (dict(resample="bogus"), ValueError, "resample must be one of"),
    (dict(ess_threshold=1.5), ValueError, r"ess_threshold must be in \[0, 1\]"),
    (dict(ess_threshold=-0.1), ValueError, r"ess_threshold must be in \[0, 1\]"),
    (dict(ess_threshold="half"), TypeError, "ess_threshold must be a number"),
    (dict(rng=np.random), TypeError, "rng must be a numpy.random.Generator"),
    (dict(proposal=lambda *a: None), TypeError, "proposal must be a bf.particle.Proposal"),
    (dict(us=np.zeros((4, 1))), ValueError, "no control matrix B"),
])
def test_particle_filter_rejects_bad_arguments(kwargs, err, match):
    model = linear_model()
    args = dict(model=model, ys=np.zeros((5, 1)), n_particles=10, rng=np.random.default_rng(0))
    args.update(kwargs)
    with pytest.raises(err, match=match):
        bf.particle.particle_filter(**args)


def test_particle_filter_rejects_bad_data_and_bad_proposals():
    model, rng = linear_model(), np.random.default_rng(0)
    with pytest.raises(ValueError, match=r"ys must be finite or NaN \(missing\), got inf at "
                                         r"index \(1, 0\)"):
        bf.particle.particle_filter(model, [[0.0], [np.inf]], 10, rng)
    with pytest.raises(ValueError, match=r"ys must have shape \(\?, 1\)"):
        bf.particle.particle_filter(model, np.zeros((3, 2)), 10, rng)
    wrong_shape = bf.particle.Proposal(sample=lambda r, xp, y, t: xp[:, :1],
                                       logpdf=lambda x, xp, y, t: np.zeros(len(x)))
    with pytest.raises(ValueError, match=r"step t = 1: proposal.sample must return shape \(10, 2\)"):
        bf.particle.particle_filter(model, np.zeros((3, 1)), 10, rng, proposal=wrong_shape)
    nan_density = bf.particle.Proposal(sample=lambda r, xp, y, t: xp.copy(),
                                       logpdf=lambda x, xp, y, t: np.full(len(x), np.nan))
    with pytest.raises(ValueError, match="proposal.logpdf must return 10 finite log-densities"):
        bf.particle.particle_filter(model, np.zeros((3, 1)), 10, rng, proposal=nan_density)


def test_roughening_is_gordons_jitter_after_each_resampling():
    # Against the algorithm written out by hand (chapter 06, section 7): same random
    # stream, so the same particles up to the last bits of the weights' normalisation.
    model = linear_model()
    _, ys = bf.models.simulate(model, 12, np.random.default_rng(0))
    N, K = 500, 0.3
    rng = np.random.default_rng(1)
    X, means = model.sample_initial(rng, N), []
    for t, y in enumerate(ys):
        if t > 0:
            X = model.sample_transition(rng, X, t=t - 1)
        ll = model.measurement_logpdf(y, X)
        W = np.exp(ll - ll.max())
        W /= W.sum()
        means.append(W @ X)
        X = X[bf.resampling.systematic(W, rng)]
        X = X + K * np.ptp(X, axis=0) * N ** (-1 / 2) * rng.standard_normal(X.shape)
    res = bf.particle.particle_filter(model, ys, N, np.random.default_rng(1), ess_threshold=1.0,
                                      roughening=K)
    np.testing.assert_allclose(res.means, np.array(means), rtol=1e-10, atol=1e-12)
    plain = bf.particle.particle_filter(model, ys, N, np.random.default_rng(1), ess_threshold=1.0)
    assert not np.allclose(plain.means[1:], res.means[1:]), "roughening changed nothing"
    with pytest.raises(ValueError, match="roughening must be finite and > 0"):
        bf.particle.particle_filter(model, ys, N, np.random.default_rng(1), roughening=-1.0)


def test_weighted_mean_cov_normalises_and_rejects_negative_weights():
    mean, cov = bf.particle.weighted_mean_cov([[1.0], [2.0], [3.0]], [1.0, 1.0, 1.0])
    assert mean[0] == pytest.approx(2.0) and cov[0, 0] == pytest.approx(2 / 3)
    with pytest.raises(ValueError, match="weights must be non-negative"):
        bf.particle.weighted_mean_cov([[1.0], [2.0], [3.0]], [-1.0, 1.0, 1.0])


def test_a_proposal_with_a_control_input_is_refused():
    # a Proposal never sees u, so eq. (13) would compare p(x | x_prev, u) with a q without u
    model = linear_model(B=[[1.0], [0.0]])
    q = bf.particle.transition_proposal(model)
    with pytest.raises(ValueError, match="proposal: a Proposal's sample and logpdf receive no control"):
        bf.particle.particle_filter(model, np.zeros((4, 1)), 10, np.random.default_rng(0),
                                    proposal=q, us=np.ones((3, 1)))
    with pytest.raises(ValueError, match="proposal: a Proposal receives no control input"):
        bf.particle.sis_step(model, np.random.default_rng(0), np.zeros((5, 2)), np.full(5, -np.log(5)),
                             [0.0], t=1, proposal=q, u=[1.0])


class _BrokenLikelihood:
    """UNGM whose log-likelihood is ``bad`` (NaN or +inf) for the particles above 0."""

    def __init__(self, bad):
        self.model, self.bad = bf.models.ungm(), bad
        self.state_dim, self.obs_dim = 1, 1

    def sample_initial(self, rng, size):
        return self.model.sample_initial(rng, size)

    def sample_transition(self, rng, xs, u=None, t=0):
        return self.model.sample_transition(rng, xs, u, t)

    def measurement_logpdf(self, y, xs):
        return np.where(xs[:, 0] > 0, self.bad, self.model.measurement_logpdf(y, xs))


@pytest.mark.parametrize("bad", [np.nan, np.inf])
def test_a_nan_or_infinite_log_likelihood_is_named_not_propagated(bad):
    ys = np.ones((3, 1))
    with pytest.raises(ValueError, match=r"step t = 0: a log-weight is NaN or \+inf"):
        bf.particle.particle_filter(_BrokenLikelihood(bad), ys, 200, np.random.default_rng(0))


# --------------------------------------------------------------------------
# The ESS and the weights the filter records, against the weights recomputed
# --------------------------------------------------------------------------

@pytest.mark.parametrize("threshold", [0.0, 0.5, 1.0])
def test_recorded_ess_is_one_over_the_sum_of_squared_recorded_weights(threshold):
    model = linear_model()
    _, ys = bf.models.simulate(model, 25, np.random.default_rng(30))
    res = bf.particle.particle_filter(model, ys, 200, np.random.default_rng(31),
                                      ess_threshold=threshold, keep_history=True)
    W = res.history.weights
    for t in range(len(ys)):
        # computed here, independently: ESS_t = 1 / sum_i W_{t,i}^2, W_t normalised
        w = W[t] / math.fsum(W[t])
        want = 1.0 / math.fsum(w * w)
        assert res.ess[t] == pytest.approx(want, rel=1e-12), t
    # the weights are unequal most of the time, so the ESS is not just N or 1/max W
    assert (res.ess < 199).sum() >= 10
    assert not np.allclose(res.ess, 1.0 / W.max(axis=1), rtol=1e-3)


def two_sensor_model():
    """x in the plane measured by two correlated sensors (the second sees x_1 + x_2)."""
    return bf.models.LinearGaussian(
        A=[[0.9, 0.2], [0.0, 0.8]], C=[[1.0, 0.0], [0.5, 1.0]], Q=[[0.3, 0.05], [0.05, 0.2]],
        R=[[0.5, 0.1], [0.1, 0.4]], m0=[0.0, 0.0], P0=np.eye(2))


def _partly_missing(rng, ys):
    ys = ys.copy()
    ys[rng.random(ys.shape) < 0.3] = np.nan
    ys[[5]] = np.nan
    return ys


@pytest.mark.parametrize("threshold", [0.0, 1.0])
def test_partly_missing_rows_weight_by_the_observed_components_exactly(threshold):
    """On the particles the filter recorded, the weights must be the likelihoods of the
    observed components, N(y_o; C_o x, R_oo) by scipy, times the previous weights (no
    resampling) or alone (resampling at every step); the evidence increments likewise."""
    model = two_sensor_model()
    rng = np.random.default_rng(32)
    ys = _partly_missing(rng, bf.models.simulate(model, 20, rng).ys)
    assert (np.isnan(ys).any(axis=1) & ~np.isnan(ys).all(axis=1)).sum() >= 4
    N = 50
    res = bf.particle.particle_filter(model, ys, N, np.random.default_rng(33),
                                      ess_threshold=threshold, keep_history=True)
    np.testing.assert_array_equal(res.observed_components, ~np.isnan(ys))
    np.testing.assert_array_equal(res.observed, ~np.isnan(ys).all(axis=1))
    prev = np.full(N, 1.0 / N)
    for t in range(len(ys)):
        X = res.history.particles[t]
        keep = [j for j in range(2) if not np.isnan(ys[t, j])]
        if keep:
            lik = stats.multivariate_normal(np.zeros(len(keep)), model.R[np.ix_(keep, keep)]).pdf(
                ys[t, keep] - X @ model.C[keep].T)
        else:
            lik = np.ones(N)
        w = prev * lik
        np.testing.assert_allclose(res.history.weights[t], w / w.sum(), rtol=1e-9, err_msg=t)
        assert res.step_logliks[t] == pytest.approx(np.log(w.sum()) if keep else 0.0,
                                                    rel=1e-10, abs=1e-12), t
        prev = np.full(N, 1.0 / N) if res.resampled[t] else res.history.weights[t]


def test_partly_missing_log_evidence_close_to_the_kalman_filter():
    model = two_sensor_model()
    rng = np.random.default_rng(34)
    ys = _partly_missing(rng, bf.models.simulate(model, 20, rng).ys)
    kf = bf.kalman.kalman_filter(model, ys)
    pf = bf.particle.particle_filter(model, ys, 2000, np.random.default_rng(35))
    # Calibration: over 300 seeds at N = 2000 on these data the error had mean -0.007 and
    # sd 0.099 (extremes -0.34, +0.27); 0.7 is 7 sd. Ignoring the partly-observed rows,
    # or using R instead of R_oo, moves the log-evidence by several units.
    assert abs(pf.loglik - kf.loglik) < 0.7, (pf.loglik, kf.loglik)


def test_sis_step_on_a_partly_missing_y_with_the_optimal_proposal():
    """The optimal proposal conditions on y_o only; its weight increment is then
    p(y_o | x_{t-1}) = N(y_o; C_o A x_{t-1}, C_o G Q G^T C_o^T + R_oo), whatever the draw."""
    model = two_sensor_model()
    rng = np.random.default_rng(36)
    X = rng.standard_normal((40, 2))
    lw = bf.particle.log_normalize(rng.standard_normal(40))[0]
    y = np.array([np.nan, 0.7])
    q = bf.particle.optimal_proposal(model)
    step = bf.particle.sis_step(model, np.random.default_rng(37), X, lw, y, t=2, proposal=q)
    Co, Ro = model.C[1:], model.R[1:, 1:]
    S = Co @ model.Q @ Co.T + Ro
    log_incr = stats.multivariate_normal(np.zeros(1), S).logpdf((y[1:] - X @ model.A.T @ Co.T))
    want = lw + log_incr
    np.testing.assert_allclose(step.log_weights, want - logsumexp(want), rtol=1e-9, atol=1e-12)
    assert step.log_increment == pytest.approx(logsumexp(want), rel=1e-10)
    # and the bootstrap on the same y weights by N(y_o; C_o x_t, R_oo)
    boot = bf.particle.sis_step(model, np.random.default_rng(37), X, lw, y, t=2)
    want = lw + stats.norm(0, np.sqrt(Ro[0, 0])).logpdf(y[1] - boot.particles @ Co[0])
    np.testing.assert_allclose(boot.log_weights, want - logsumexp(want), rtol=1e-9, atol=1e-12)


class _NoMarginal:
    """A model of the particle interface whose likelihood takes no observed= mask."""

    def __init__(self, model):
        self.model = model
        self.state_dim, self.obs_dim = model.state_dim, model.obs_dim

    def sample_initial(self, rng, size):
        return self.model.sample_initial(rng, size)

    def sample_transition(self, rng, xs, u=None, t=0):
        return self.model.sample_transition(rng, xs, u, t)

    def measurement_logpdf(self, y, xs):
        return self.model.measurement_logpdf(y, xs)


def test_a_partly_missing_row_needs_a_likelihood_that_can_be_marginalised():
    model = _NoMarginal(two_sensor_model())
    ys = np.zeros((4, 2))
    ys[2] = np.nan                           # a whole missing row is fine
    res = bf.particle.particle_filter(model, ys, 20, np.random.default_rng(0))
    assert res.step_logliks[2] == 0.0
    ys[3, 0] = np.nan
    with pytest.raises(ValueError, match=r"ys row 3 is partly NaN, but _NoMarginal."
                                         r"measurement_logpdf\(y, xs\) takes no observed="):
        bf.particle.particle_filter(model, ys, 20, np.random.default_rng(0))
    with pytest.raises(ValueError, match="y is partly NaN"):
        bf.particle.sis_step(model, np.random.default_rng(0), np.zeros((3, 2)),
                             np.full(3, -np.log(3)), [np.nan, 1.0], t=1)


# --------------------------------------------------------------------------
# Overflow and the normalisation sis_step needs
# --------------------------------------------------------------------------

def test_ess_and_weighted_mean_cov_survive_an_overflowing_sum():
    assert bf.particle.ess([1e308, 1e308]) == pytest.approx(2.0, rel=1e-15)
    assert bf.particle.ess([1e308, 1e308, 0.0, 5e307]) == pytest.approx(1 / 0.36, rel=1e-14)
    mean, cov = bf.particle.weighted_mean_cov([[1.0], [3.0]], [1e308, 1e308])
    np.testing.assert_allclose(mean, [2.0], rtol=1e-15)
    np.testing.assert_allclose(cov, [[1.0]], rtol=1e-15)
    # the same as with the weights scaled down
    X = np.random.default_rng(0).standard_normal((5, 2))
    w = np.array([1.0, 2.0, 0.5, 0.0, 1.5])
    for got, want in zip(bf.particle.weighted_mean_cov(X, w / w.max() * 1.7e308),
                         bf.particle.weighted_mean_cov(X, w)):
        np.testing.assert_allclose(got, want, rtol=1e-13, atol=1e-15)
    for bad in ([np.inf, 1.0], [1.0, np.nan]):
        with pytest.raises(ValueError, match="weights must be finite"):
            bf.particle.ess(bad)
        with pytest.raises(ValueError, match="weights must be finite"):
            bf.particle.weighted_mean_cov([[1.0], [3.0]], bad)


@pytest.mark.parametrize("log_w, match", [
    (np.zeros(4), r"log_weights must be normalised.* got 1\.38629"),
    (np.full(4, np.log(0.25)) - 1e-6, "log_weights must be normalised"),
    ([0.0, np.nan, 0.0, 0.0], r"log_weights must be finite or -inf, got log_weights\[1\]"),
    ([-np.inf] * 4, "log_weights are all -inf"),
])
def test_sis_step_checks_its_log_weights_are_normalised(log_w, match):
    model = linear_model()
    with pytest.raises(ValueError, match=match):
        bf.particle.sis_step(model, np.random.default_rng(0), np.zeros((4, 2)), log_w, [0.1], t=1)


def test_sis_step_accepts_normalised_log_weights_up_to_rounding():
    model = linear_model()
    rng = np.random.default_rng(1)
    for lw in (np.full(1000, -np.log(1000)),
               bf.particle.log_normalize(rng.standard_normal(1000))[0],
               np.log(np.full(3, 1 / 3)), [0.0, -np.inf]):
        bf.particle.sis_step(model, rng, np.zeros((len(lw), 2)), lw, [0.1], t=1)
    # within the stated tolerance, 1e-8, but not beyond it
    bf.particle.sis_step(model, rng, np.zeros((2, 2)), np.log([0.5, 0.5]) + 0.9e-8, [0.1], t=1)
    with pytest.raises(ValueError, match="normalised"):
        bf.particle.sis_step(model, rng, np.zeros((2, 2)), np.log([0.5, 0.5]) + 2e-8, [0.1], t=1)
    assert bf.particle.LOG_WEIGHTS_TOL == 1e-8


class _HalfImpossible:
    """Four fixed particles 0, 1, 2, 3 that never move; y is impossible (likelihood 0) for
    the particles at 2 and 3 and equally likely for 0 and 1: the weights are exactly
    (1/2, 1/2, 0, 0) and the ESS exactly 2."""

    state_dim, obs_dim = 1, 1

    def sample_initial(self, rng, size):
        return np.arange(float(size))[:, None]

    def sample_transition(self, rng, xs, u=None, t=0):
        return np.array(xs, dtype=float)

    def measurement_logpdf(self, y, xs):
        return np.where(np.asarray(xs)[:, 0] < 2, 0.0, -np.inf)


def test_resampling_happens_when_the_ess_is_below_the_threshold_not_at_it():
    """The documented rule is ESS < ess_threshold * N: at ESS = 2 = 0.5 * 4 exactly, no
    resampling; a threshold a hair above 0.5 resamples."""
    model, ys = _HalfImpossible(), np.zeros((1, 1))
    at = bf.particle.particle_filter(model, ys, 4, np.random.default_rng(0), ess_threshold=0.5)
    assert at.ess[0] == 2.0 and not at.resampled[0]
    above = bf.particle.particle_filter(model, ys, 4, np.random.default_rng(0),
                                        ess_threshold=0.5 + 1e-12)
    assert above.resampled[0]
