"""Tests of bf.bayes against independent references: brute force over state
paths, Monte Carlo, and filterpy.discrete_bayes."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from filterpy import discrete_bayes as fdb

import bayesfilt as bf

RNG_SEED = 20261122


def random_transition(rng, n):
    t = rng.random((n, n)) ** 3  # skewed rows, some near zero
    return t / t.sum(axis=1, keepdims=True)


def random_belief(rng, n):
    b = rng.random(n)
    return b / b.sum()


# --------------------------------------------------------------------------
# prediction
# --------------------------------------------------------------------------

def test_predict_is_total_probability_written_out():
    rng = np.random.default_rng(RNG_SEED)
    n = 7
    belief, trans = random_belief(rng, n), random_transition(rng, n)
    expected = np.array([sum(belief[i] * trans[i, j] for i in range(n)) for j in range(n)])
    np.testing.assert_allclose(bf.bayes.predict(belief, trans), expected, rtol=1e-13, atol=0)


def test_predict_conserves_mass_and_normalises_its_input():
    rng = np.random.default_rng(1)
    trans = random_transition(rng, 12)
    unnormalised = 5.0 * random_belief(rng, 12)
    prior = bf.bayes.predict(unnormalised, trans)
    assert prior.sum() == pytest.approx(1.0, abs=1e-14)
    np.testing.assert_allclose(prior, bf.bayes.predict(unnormalised / 5.0, trans), rtol=1e-14)


def test_predict_matches_monte_carlo():
    rng = np.random.default_rng(2)
    n, draws = 6, 200_000
    belief, trans = random_belief(rng, n), random_transition(rng, n)
    start = rng.choice(n, size=draws, p=belief)
    # Inverse-CDF sampling of each particle's next cell from its transition row.
    cdf = np.cumsum(trans, axis=1)
    nxt = np.minimum((rng.random(draws)[:, None] > cdf[start]).sum(axis=1), n - 1)
    freq = np.bincount(nxt, minlength=n) / draws
    prior = bf.bayes.predict(belief, trans)
    # 5 binomial standard errors: a wrong formula is off by far more.
    tol = 5 * np.sqrt(prior * (1 - prior) / draws)
    assert np.all(np.abs(freq - prior) < tol)


# --------------------------------------------------------------------------
# update
# --------------------------------------------------------------------------

def test_update_is_bayes_rule():
    prior = np.array([0.5, 0.3, 0.2])
    lik = np.array([0.1, 0.6, 0.3])
    post, evidence = bf.bayes.update(prior, lik)
    assert evidence == pytest.approx(0.05 + 0.18 + 0.06, rel=1e-14)
    np.testing.assert_allclose(post, np.array([0.05, 0.18, 0.06]) / 0.29, rtol=1e-14)


def test_update_scaling_the_likelihood_scales_only_the_evidence():
    rng = np.random.default_rng(3)
    prior, lik = random_belief(rng, 9), rng.random(9)
    a = bf.bayes.update(prior, lik)
    b = bf.bayes.update(prior, 1000.0 * lik)
    np.testing.assert_allclose(a.posterior, b.posterior, rtol=1e-13)
    assert b.evidence == pytest.approx(1000.0 * a.evidence, rel=1e-13)


def test_update_keeps_zero_prior_cells_at_zero():
    post, _ = bf.bayes.update([0.0, 0.5, 0.5], [1.0, 1.0, 3.0])
    assert post[0] == 0.0 and post.sum() == pytest.approx(1.0)


# --------------------------------------------------------------------------
# the recursion against brute force over all state paths
# --------------------------------------------------------------------------

def brute_force(initial, transitions, liks):
    """p(y_0:T-1) and p(x_T-1 | y_0:T-1) by summing over every state path."""
    T, n = liks.shape
    joint_last = np.zeros(n)
    for path in itertools.product(range(n), repeat=T):
        p = initial[path[0]] * liks[0, path[0]]
        for t in range(1, T):
            p *= transitions[t - 1][path[t - 1], path[t]] * liks[t, path[t]]
        joint_last[path[-1]] += p
    return joint_last.sum(), joint_last / joint_last.sum()


@pytest.mark.parametrize("n,T", [(2, 6), (3, 5), (5, 4)])
def test_bayes_filter_evidence_and_posterior_equal_brute_force(n, T):
    rng = np.random.default_rng(n * 100 + T)
    initial = random_belief(rng, n)
    transitions = np.stack([random_transition(rng, n) for _ in range(T - 1)])
    liks = rng.random((T, n))
    result = bf.bayes.bayes_filter(initial, transitions, liks)
    evidence, last = brute_force(initial, transitions, liks)
    assert np.exp(result.log_evidence) == pytest.approx(evidence, rel=1e-12)
    np.testing.assert_allclose(result.posteriors[-1], last, rtol=1e-12)
    assert result.priors.shape == result.posteriors.shape == (T, n)
    np.testing.assert_allclose(result.priors[0], initial)


def test_bayes_filter_with_one_shared_transition_equals_stacked():
    rng = np.random.default_rng(4)
    trans, liks = random_transition(rng, 4), rng.random((6, 4))
    a = bf.bayes.bayes_filter(np.ones(4), trans, liks)
    b = bf.bayes.bayes_filter(np.ones(4), np.stack([trans] * 5), liks)
    np.testing.assert_allclose(a.posteriors, b.posteriors, rtol=1e-14)
    assert a.log_evidence == pytest.approx(b.log_evidence, rel=1e-14)


# --------------------------------------------------------------------------
# against filterpy.discrete_bayes
# --------------------------------------------------------------------------

@pytest.mark.parametrize("trial", range(10))
def test_cyclic_shift_matches_filterpy(trial):
    rng = np.random.default_rng(100 + trial)
    n = int(rng.integers(5, 40))
    kernel = rng.random(2 * int(rng.integers(0, 3)) + 1)
    kernel /= kernel.sum()
    offset = int(rng.integers(-7, 8))
    belief = random_belief(rng, n)
    ours = bf.bayes.predict(belief, bf.bayes.shift_transition(n, kernel, offset, cyclic=True))
    theirs = fdb.predict(belief, offset, kernel, mode="wrap")
    np.testing.assert_allclose(ours, theirs, atol=1e-15, rtol=1e-12)


def test_full_recursion_matches_filterpy():
    rng = np.random.default_rng(5)
    n, kernel, offset = 30, np.array([0.1, 0.8, 0.1]), 1
    trans = bf.bayes.shift_transition(n, kernel, offset)
    belief_ours = belief_fp = np.full(n, 1.0 / n)
    for _ in range(20):
        lik = rng.random(n)
        belief_ours = bf.bayes.update(bf.bayes.predict(belief_ours, trans), lik).posterior
        belief_fp = fdb.update(lik, fdb.predict(belief_fp, offset, kernel))
    np.testing.assert_allclose(belief_ours, belief_fp, atol=1e-14)


def test_non_cyclic_shift_keeps_mass_where_filterpy_loses_it():
    n, kernel = 10, np.array([0.2, 0.6, 0.2])
    belief = np.zeros(n)
    belief[-2] = 1.0  # next to the right wall, commanded one cell to the right
    ours = bf.bayes.predict(belief, bf.bayes.shift_transition(n, kernel, 1, cyclic=False))
    theirs = fdb.predict(belief, 1, kernel, mode="constant")
    assert ours.sum() == pytest.approx(1.0)
    assert ours[-1] == pytest.approx(0.8)  # the wall stops the overshoot: 0.6 + 0.2
    assert theirs.sum() == pytest.approx(0.8)  # filterpy: the overshoot fell off the grid
    # Away from the walls the two agree.
    belief = np.zeros(n)
    belief[4] = 1.0
    np.testing.assert_allclose(
        bf.bayes.predict(belief, bf.bayes.shift_transition(n, kernel, 1, cyclic=False)),
        fdb.predict(belief, 1, kernel, mode="constant"), atol=1e-15)


# --------------------------------------------------------------------------
# grid helpers
# --------------------------------------------------------------------------

def test_gaussian_kernel_against_cell_probabilities():
    from scipy.stats import norm
    k = bf.bayes.gaussian_kernel(1.3, half_width=6)
    edges = np.arange(-6.5, 7.0, 1.0)
    expected = np.diff(norm.cdf(edges, scale=1.3))
    np.testing.assert_allclose(k, expected / expected.sum(), rtol=1e-12)
    assert k.shape == (13,) and k[6] == k.max()


def test_grid_transition_and_likelihood_of_a_gaussian_model():
    from scipy.stats import norm
    grid = np.linspace(-5, 5, 101)
    trans = bf.bayes.grid_transition(grid, lambda xn, xp: norm.pdf(xn, loc=0.9 * xp, scale=0.5))
    np.testing.assert_allclose(trans.sum(axis=1), 1.0, rtol=1e-13)
    # The mean of each row (away from the edges) is 0.9 x_prev.
    row = 50 + 10
    assert trans[row] @ grid == pytest.approx(0.9 * grid[row], abs=1e-6)
    lik = bf.bayes.gaussian_likelihood(grid, 1.0, 0.7)
    np.testing.assert_allclose(lik, norm.pdf(1.0, loc=grid, scale=0.7), rtol=1e-13)
    np.testing.assert_allclose(bf.bayes.grid_likelihood(grid, 1.0, lambda y, x: norm.pdf(y, x, 0.7)),
                               lik, rtol=1e-13)


# --------------------------------------------------------------------------
# bad input: clear errors that name the argument
# --------------------------------------------------------------------------

GOOD_T = np.full((3, 3), 1 / 3)


@pytest.mark.parametrize("belief,transition,match", [
    (np.ones((3, 1)), GOOD_T, "belief must be a vector"),
    ([0.5, 0.5], GOOD_T, r"transition must have shape \(2, 2\)"),
    ([0.5, -0.1, 0.6], GOOD_T, r"belief must be non-negative"),
    ([0.5, np.nan, 0.5], GOOD_T, "belief must be finite"),
    ([0.0, 0.0, 0.0], GOOD_T, "belief must have positive total mass"),
    (np.ones(3), np.ones((3, 2)) / 2, "transition must be a square"),
    (np.ones(3), np.full((3, 3), 0.3), "transition rows must sum to 1"),
    (np.ones(3), np.array([[1.2, -0.2, 0], [0, 1, 0], [0, 0, 1]]), "transition must be non-negative"),
    (np.ones(3), np.array([[np.inf, 0, 0], [0, 1, 0], [0, 0, 1]]), "transition must be finite"),
])
def test_predict_rejects_bad_input(belief, transition, match):
    with pytest.raises(ValueError, match=match):
        bf.bayes.predict(belief, transition)


@pytest.mark.parametrize("prior,likelihood,match", [
    ([0.5, 0.5], [1.0, 1.0, 1.0], r"likelihood must have shape \(2,\)"),
    ([0.5, 0.5], [1.0, -1.0], "likelihood must be non-negative"),
    ([0.5, 0.5], [1.0, np.nan], "likelihood must be finite"),
    ([0.0, 1.0], [1.0, 0.0], "likelihood is zero wherever the prior has mass"),
    ([[0.5, 0.5]], [1.0, 1.0], "prior must be a vector"),
])
def test_update_rejects_bad_input(prior, likelihood, match):
    with pytest.raises(ValueError, match=match):
        bf.bayes.update(prior, likelihood)


def test_update_does_not_return_nan_on_zero_evidence():
    with pytest.raises(ValueError, match="evidence"):
        bf.bayes.update([1.0, 0.0], [0.0, 5.0])


def test_type_errors_name_the_argument():
    with pytest.raises(TypeError, match="belief"):
        bf.bayes.predict(None, GOOD_T)
    with pytest.raises(TypeError, match="belief"):
        bf.bayes.predict(["a", "b", "c"], GOOD_T)
    with pytest.raises(TypeError, match="n must be an integer"):
        bf.bayes.shift_transition(3.0, [1.0])
    with pytest.raises(TypeError, match="density"):
        bf.bayes.grid_likelihood([0.0, 1.0], 0.0, density="normal")


@pytest.mark.parametrize("kwargs,match", [
    (dict(n=5, kernel=[0.5, 0.5]), "kernel must have odd length"),
    (dict(n=5, kernel=[0.5, 0.6, 0.1]), "kernel must be non-negative and sum to 1"),
    (dict(n=0, kernel=[1.0]), "n must be >= 1"),
])
def test_shift_transition_rejects_bad_input(kwargs, match):
    with pytest.raises(ValueError, match=match):
        bf.bayes.shift_transition(**kwargs)


def test_bayes_filter_rejects_bad_shapes_and_reports_the_step():
    with pytest.raises(ValueError, match=r"likelihoods must have shape \(T, 3\)"):
        bf.bayes.bayes_filter(np.ones(3), GOOD_T, np.ones((4, 2)))
    with pytest.raises(ValueError, match="transitions must hold T - 1 = 3 matrices"):
        bf.bayes.bayes_filter(np.ones(3), np.stack([GOOD_T] * 7), np.ones((4, 3)))
    # T matrices for T measurements: a control list shifted by one must not pass silently
    with pytest.raises(ValueError, match=r"got 4: ys\[0\] measures x_0 before any move"):
        bf.bayes.bayes_filter(np.ones(3), np.stack([GOOD_T] * 4), np.ones((4, 3)))
    with pytest.raises(ValueError, match="transitions must have shape"):
        bf.bayes.bayes_filter(np.ones(3), np.ones((3, 2, 2)), np.ones((4, 3)))
    with pytest.raises(ValueError, match=r"transitions\[1\] rows must sum to 1"):
        bf.bayes.bayes_filter(np.ones(3), np.stack([GOOD_T, GOOD_T * 0.9, GOOD_T]), np.ones((4, 3)))
    liks = np.ones((4, 3))
    liks[2] = 0.0
    with pytest.raises(ValueError, match="at step t = 2"):
        bf.bayes.bayes_filter(np.ones(3), GOOD_T, liks)


def test_grid_helpers_reject_bad_input():
    with pytest.raises(ValueError, match="grid must be strictly increasing"):
        bf.bayes.gaussian_likelihood([0.0, 0.0, 1.0], 0.0, 1.0)
    with pytest.raises(ValueError, match="std must be finite and > 0"):
        bf.bayes.gaussian_likelihood([0.0, 1.0], 0.0, 0.0)
    with pytest.raises(ValueError, match="density.*zero on the whole grid"):
        bf.bayes.grid_transition([0.0, 1.0], lambda xn, xp: 0.0 * xn * xp)
    with pytest.raises(ValueError, match=r"must return shape \(2, 2\)"):
        bf.bayes.grid_transition([0.0, 1.0], lambda xn, xp: np.ones(3)[:, None] * np.ones(3))


def test_huge_counts_are_normalised_without_overflow():
    prior = bf.bayes.predict([1e308, 1e308, 1.0], np.eye(3))
    np.testing.assert_allclose(prior, [0.5, 0.5, 0.0], atol=1e-300)


def test_negative_kernel_entries_are_named():
    with pytest.raises(ValueError, match=r"kernel must be non-negative, got kernel\[0\] = -0.5"):
        bf.bayes.shift_transition(5, [-0.5, 2.0, -0.5])


def test_absurd_kernel_width_is_refused():
    with pytest.raises(ValueError, match="half_width must be at most"):
        bf.bayes.gaussian_kernel(1e9)


def test_bad_types_are_type_errors():
    with pytest.raises(TypeError, match="likelihood must be an array of real numbers, got booleans"):
        bf.bayes.update([0.5, 0.5], [True, False])
    with pytest.raises(ValueError, match="belief must not be empty"):
        bf.bayes.predict([], np.zeros((0, 0)))


# --- the grid filter of a continuous 1-D model: an exact reference for chapter 06 ---

def _scalar_linear_model(**kw):
    args = dict(A=[[0.9]], C=[[1.0]], Q=[[0.5]], R=[[0.3]], m0=[1.0], P0=[[2.0]])
    args.update(kw)
    return bf.models.LinearGaussian(**args)


def test_grid_filter_equals_the_kalman_filter_on_a_linear_model():
    # The Kalman filter is exact here, and independent of the grid code.
    model = _scalar_linear_model()
    xs, ys = bf.models.simulate(model, 30, np.random.default_rng(3))
    ys[7] = np.nan                                  # a missing measurement
    grid = np.linspace(-15, 15, 1201)               # cells 0.025 wide, posterior std >= 0.4
    res = bf.bayes.grid_filter(model, ys, grid)
    kf = bf.kalman.kalman_filter(model, ys)
    # midpoint-rule error O(h^2 / sigma^2) relative: ~1e-3 of a std is generous
    np.testing.assert_allclose(res.means, kf.means[:, 0], atol=2e-3)
    np.testing.assert_allclose(res.variances, kf.covs[:, 0, 0], rtol=5e-3)
    assert res.loglik == pytest.approx(kf.loglik, abs=1e-2)
    np.testing.assert_allclose(res.posteriors.sum(axis=1), 1.0, rtol=1e-12)


def test_grid_filter_follows_a_time_varying_model():
    # UNGM: the grid mean must follow the time index of the cosine term; against a
    # brute-force Monte Carlo of the *prediction* alone (no measurement at t = 1).
    model = bf.models.ungm()
    ys = np.array([[np.nan], [np.nan]])
    grid = np.linspace(-40, 40, 1601)
    res = bf.bayes.grid_filter(model, ys, grid)
    rng = np.random.default_rng(0)
    x1 = model.sample_transition(rng, model.sample_initial(rng, 200_000), t=0)[:, 0]
    se = x1.std() / np.sqrt(x1.size)
    assert abs(res.means[1] - x1.mean()) < 5 * se + 1e-3, (res.means[1], x1.mean(), se)


def test_grid_filter_rejects_bad_input():
    with pytest.raises(ValueError, match="scalar state"):
        bf.bayes.grid_filter(bf.models.damped_particle(), np.zeros((3, 2)), np.linspace(0, 1, 5))
    with pytest.raises(ValueError, match="equally spaced"):
        bf.bayes.grid_filter(_scalar_linear_model(), np.zeros(3), [0.0, 1.0, 3.0])
    with pytest.raises(ValueError, match="widen"):
        bf.bayes.grid_filter(_scalar_linear_model(R=[[1e-4]]), np.array([1e3]), np.linspace(-1, 1, 50))


def test_grid_filter_never_returns_nan_and_checks_edges_on_missing_rows():
    with pytest.raises(ValueError, match="prior N\\(m0, P0\\) is zero on the whole grid"):
        bf.bayes.grid_filter(_scalar_linear_model(m0=[0.0], P0=[[1.0]]), np.array([np.nan, np.nan]),
                             np.linspace(100, 200, 101))
    # a grid too narrow for the prior must not truncate it silently, even without a measurement
    with pytest.raises(ValueError, match="step t = 0: the belief has probability"):
        bf.bayes.grid_filter(_scalar_linear_model(m0=[0.0], P0=[[1.0]]), np.array([np.nan]),
                             np.linspace(-1, 1, 41))


def test_grid_filter_on_partly_missing_rows_equals_the_kalman_filter():
    """Two correlated sensors of a scalar state, one or the other missing on some rows."""
    model = _scalar_linear_model(C=[[1.0], [0.5]], R=[[0.3, 0.1], [0.1, 0.4]])
    xs, ys = bf.models.simulate(model, 20, np.random.default_rng(4))
    ys[[2, 5, 9], 0] = np.nan
    ys[[3, 12], 1] = np.nan
    ys[15] = np.nan
    res = bf.bayes.grid_filter(model, ys, np.linspace(-15, 15, 1201))
    kf = bf.kalman.kalman_filter(model, ys)
    np.testing.assert_allclose(res.means, kf.means[:, 0], atol=2e-3)
    np.testing.assert_allclose(res.variances, kf.covs[:, 0, 0], rtol=5e-3)
    assert res.loglik == pytest.approx(kf.loglik, abs=1e-2)
    with pytest.raises(ValueError, match="ys must be finite or NaN"):
        bf.bayes.grid_filter(model, np.array([[np.inf, 0.0]]), np.linspace(-15, 15, 101))
