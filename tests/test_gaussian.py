"""Tests of bf.gaussian against independent references.

References: the precision-matrix (Schur complement) form of Gaussian
conditioning, least-squares regression on Monte Carlo draws, scipy.stats
(multivariate_normal, chi2), explicit per-pair linear solves, Monte Carlo
coverage of the chi-square interval, the autocorrelation written out as a
double loop, scipy's Cholesky factor, and Monte Carlo coverage of the
whiteness band +-1.96 / sqrt(N).
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy import linalg as sla
from scipy import stats

import bayesfilt as bf


def random_spd(rng, k, scale=1.0):
    a = rng.standard_normal((k, k))
    return scale * (a @ a.T / k + 0.2 * np.eye(k))


def split(joint, k):
    return joint[:k, :k], joint[:k, k:], joint[k:, k:]


# --------------------------------------------------------------------------
# condition (Theorem 10.2)
# --------------------------------------------------------------------------

@pytest.mark.parametrize("k,l", [(1, 1), (2, 2), (3, 3), (2, 3), (4, 2), (3, 1)])
def test_condition_equals_precision_form(k, l):
    """x | y from the precision matrix Lambda = Sigma^{-1}: mean mu_x - Lxx^{-1} Lxy (y - mu_y),
    covariance Lxx^{-1} (the inverse of the Schur complement)."""
    rng = np.random.default_rng(k * 10 + l)
    joint = random_spd(rng, k + l)
    mu = rng.standard_normal(k + l)
    y = rng.standard_normal(l)
    Lam = np.linalg.inv(joint)
    Lxx, Lxy = Lam[:k, :k], Lam[:k, k:]
    mean_ref = mu[:k] - np.linalg.solve(Lxx, Lxy @ (y - mu[k:]))
    cov_ref = np.linalg.inv(Lxx)
    cxx, cxy, cyy = split(joint, k)
    post = bf.gaussian.condition(mu[:k], mu[k:], cxx, cxy, cyy, y)
    assert isinstance(post, bf.gaussian.Gaussian)
    np.testing.assert_allclose(post.mean, mean_ref, rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(post.cov, cov_ref, rtol=1e-10, atol=1e-12)
    np.testing.assert_array_equal(post.cov, post.cov.T)
    m, P = post  # unpacks
    assert m.shape == (k,) and P.shape == (k, k)


def test_condition_equals_monte_carlo_regression():
    """Regress x on y over joint draws: slope = C_xy C_yy^{-1}, residual covariance = C_{x|y}."""
    rng = np.random.default_rng(1)
    k, l, N = 2, 2, 400_000
    joint = random_spd(rng, k + l)
    mu = np.array([1.0, -2.0, 0.5, 3.0])
    draws = rng.multivariate_normal(mu, joint, size=N)
    X, Y = draws[:, :k], draws[:, k:]
    design = np.column_stack([np.ones(N), Y])
    coef, *_ = np.linalg.lstsq(design, X, rcond=None)
    resid = X - design @ coef
    y0 = np.array([0.0, 2.5])
    cxx, cxy, cyy = split(joint, k)
    post = bf.gaussian.condition(mu[:k], mu[k:], cxx, cxy, cyy, y0)
    # Tolerances: 5 standard errors, estimated from the draws themselves (not from the
    # code under test). With s = diag of the residual covariance Sr and d = y0 - mean(Y):
    #   SE of the fitted E[x_i | y0]  = sqrt(s_i (1 + d^T Cov(Y)^{-1} d) / N)
    #   SE of the residual cov (i, j) = sqrt((Sr_ii Sr_jj + Sr_ij^2) / N)
    # (OLS prediction variance; variance of a Gaussian sample covariance.)
    Sr = np.cov(resid.T)
    d = y0 - Y.mean(axis=0)
    se_mean = np.sqrt(np.diag(Sr) * (1.0 + d @ np.linalg.solve(np.cov(Y.T), d)) / N)
    se_cov = np.sqrt((np.outer(np.diag(Sr), np.diag(Sr)) + Sr**2) / N)
    # E[x | y0] predicted by the fitted regression line
    assert (np.abs(coef[0] + y0 @ coef[1:] - post.mean) < 5 * se_mean).all()
    assert (np.abs(Sr - post.cov) < 5 * se_cov).all()


def test_condition_kalman_scalar_example():
    # x ~ N(0, 1), y = x + v, v ~ N(0, 0.5): posterior N(0.9 / 1.5, 1 - 1 / 1.5)
    post = bf.gaussian.condition([0.0], [0.0], [[1.0]], [[1.0]], [[1.5]], [0.9])
    np.testing.assert_allclose(post.mean, [0.6])
    np.testing.assert_allclose(post.cov, [[1.0 / 3.0]])


def test_condition_bad_inputs():
    ok = dict(mean_x=[0.0, 0.0], mean_y=[0.0], cov_xx=np.eye(2), cov_xy=[[0.5], [0.0]],
              cov_yy=[[1.0]], y=[1.0])
    cases = [
        ("cov_yy", [[0.0]], "cov_yy must be positive definite"),
        ("cov_yy", [[-1.0]], "cov_yy must be positive semi-definite"),
        ("cov_xy", [[0.5, 0.1], [0.0, 0.0]], "cov_xy must have shape"),
        ("cov_xy", [[2.0], [0.0]], "cov_xy is inconsistent"),
        ("cov_xx", [[1.0, 0.3], [0.0, 1.0]], "cov_xx must be symmetric"),
        ("cov_xx", np.eye(3), "cov_xx must have shape"),
        ("y", [1.0, 2.0], "y must have shape"),
        ("y", [np.nan], "y must be finite"),
        ("mean_x", [[0.0, 0.0]], r"mean_x must be a vector of shape \(n,\)"),
    ]
    for key, bad, match in cases:
        with pytest.raises(ValueError, match=match):
            bf.gaussian.condition(**{**ok, key: bad})


def test_condition_blames_the_argument_of_the_wrong_length():
    """Each dimension is agreed on by several arguments; the one that disagrees is named
    (a wrong-length mean_y used to be reported as a wrong cov_xy)."""
    ok = dict(mean_x=[0.0, 0.0], mean_y=[0.0], cov_xx=np.eye(2), cov_xy=[[0.5], [0.0]],
              cov_yy=[[1.0]], y=[1.0])
    for key, bad, match in [
        ("mean_y", [0.0, 0.0], r"mean_y must have shape \(1,\), got shape \(2,\)"),
        ("mean_x", [0.0, 0.0, 0.0], r"mean_x must have shape \(2,\), got shape \(3,\)"),
        ("cov_yy", np.eye(2), r"cov_yy must have shape \(1, 1\), got shape \(2, 2\)"),
        ("cov_xx", np.eye(3), r"cov_xx must have shape \(2, 2\), got shape \(3, 3\)"),
        ("cov_xy", [[0.5, 0.1], [0.0, 0.0]],
         r"cov_xy must have shape \(2, 1\), got shape \(2, 2\)"),
        ("y", [1.0, 2.0], r"y must have shape \(1,\), got shape \(2,\)"),
    ]:
        with pytest.raises(ValueError, match=match):
            bf.gaussian.condition(**{**ok, key: bad})


# --------------------------------------------------------------------------
# logpdf
# --------------------------------------------------------------------------

@pytest.mark.parametrize("n", [1, 3, 5])
def test_logpdf_equals_scipy(n):
    rng = np.random.default_rng(n)
    mean, cov = rng.standard_normal(n), random_spd(rng, n)
    xs = rng.standard_normal((7, n))
    ref = stats.multivariate_normal(mean, cov).logpdf(xs)
    got = bf.gaussian.logpdf(xs, mean, cov)
    assert got.shape == (7,)
    np.testing.assert_allclose(got, ref, rtol=1e-12)
    one = bf.gaussian.logpdf(xs[0], mean, cov)
    assert isinstance(one, float)
    np.testing.assert_allclose(one, ref[0], rtol=1e-12)


def test_logpdf_bad_inputs():
    with pytest.raises(ValueError, match="cov must be positive definite"):
        bf.gaussian.logpdf([0.0, 0.0], np.zeros(2), [[1.0, 1.0], [1.0, 1.0]])
    with pytest.raises(ValueError, match="x must have shape"):
        bf.gaussian.logpdf([0.0, 0.0, 0.0], np.zeros(2), np.eye(2))
    with pytest.raises(ValueError, match="cov must have shape"):
        bf.gaussian.logpdf([0.0, 0.0], np.zeros(2), np.eye(3))
    with pytest.raises(ValueError, match="x must be finite"):
        bf.gaussian.logpdf([np.nan, 0.0], np.zeros(2), np.eye(2))


# --------------------------------------------------------------------------
# sample
# --------------------------------------------------------------------------

def test_sample_moments():
    rng = np.random.default_rng(2)
    mean, cov = np.array([1.0, -1.0, 2.0]), random_spd(rng, 3)
    N = 200_000
    xs = bf.gaussian.sample(np.random.default_rng(3), mean, cov, N)
    assert xs.shape == (N, 3)
    # 5 standard errors per entry: SE(mean_i) = sqrt(P_ii / N) and, for a Gaussian sample,
    # SE(cov_ij) = sqrt((P_ii P_jj + P_ij^2) / N)
    var = np.diag(cov)
    assert (np.abs(xs.mean(axis=0) - mean) < 5 * np.sqrt(var / N)).all()
    assert (np.abs(np.cov(xs.T) - cov) < 5 * np.sqrt((np.outer(var, var) + cov**2) / N)).all()
    # reproducible from the seed
    np.testing.assert_array_equal(bf.gaussian.sample(np.random.default_rng(3), mean, cov, 5),
                                  xs[:5])


def test_sample_singular_covariance():
    cov = np.array([[1.0, 1.0, 0.0], [1.0, 1.0, 0.0], [0.0, 0.0, 0.0]])
    xs = bf.gaussian.sample(np.random.default_rng(4), [0.0, 0.0, 5.0], cov, 50_000)
    np.testing.assert_allclose(xs[:, 0], xs[:, 1], atol=1e-12)
    np.testing.assert_allclose(xs[:, 2], 5.0, atol=1e-12)
    np.testing.assert_allclose(np.var(xs[:, 0]), 1.0, atol=0.03)


def test_sample_bad_inputs():
    with pytest.raises(TypeError, match="rng must be a numpy.random.Generator"):
        bf.gaussian.sample(np.random.RandomState(0), [0.0], [[1.0]], 3)
    with pytest.raises(TypeError, match="rng must be a numpy.random.Generator"):
        bf.gaussian.sample(0, [0.0], [[1.0]], 3)
    with pytest.raises(ValueError, match="size must be >= 1"):
        bf.gaussian.sample(np.random.default_rng(0), [0.0], [[1.0]], 0)
    with pytest.raises(TypeError, match="size must be an integer"):
        bf.gaussian.sample(np.random.default_rng(0), [0.0], [[1.0]], 2.0)
    with pytest.raises(ValueError, match="cov must be positive semi-definite"):
        bf.gaussian.sample(np.random.default_rng(0), [0.0, 0.0], [[1.0, 2.0], [2.0, 1.0]], 3)


# --------------------------------------------------------------------------
# squared_mahalanobis
# --------------------------------------------------------------------------

def test_squared_mahalanobis_broadcasting_and_values():
    rng = np.random.default_rng(5)
    M, T, n = 4, 6, 3
    diffs = rng.standard_normal((M, T, n))
    covs = np.stack([random_spd(rng, n) for _ in range(T)])
    got = bf.gaussian.squared_mahalanobis(diffs, covs)
    assert got.shape == (M, T)
    ref = np.array([[d @ np.linalg.solve(covs[t], d) for t, d in enumerate(row)] for row in diffs])
    np.testing.assert_allclose(got, ref, rtol=1e-10)
    # one shared matrix, and a single pair
    shared = bf.gaussian.squared_mahalanobis(diffs, covs[0])
    np.testing.assert_allclose(shared[1, 2], diffs[1, 2] @ np.linalg.solve(covs[0], diffs[1, 2]))
    single = bf.gaussian.squared_mahalanobis(diffs[0, 0], covs[0])
    assert np.shape(single) == ()
    np.testing.assert_allclose(single, ref[0, 0], rtol=1e-10)


def test_nees_of_true_gaussian_errors_is_chi2():
    """NEES of errors drawn from their own covariance averages n (Monte Carlo)."""
    rng = np.random.default_rng(6)
    n, N = 4, 100_000
    cov = random_spd(rng, n)
    errs = rng.multivariate_normal(np.zeros(n), cov, size=N)  # independent of bf.gaussian
    nees = bf.gaussian.squared_mahalanobis(errs, cov)
    assert abs(nees.mean() - n) < 5 * np.sqrt(2 * n / N)
    assert stats.kstest(nees, stats.chi2(n).cdf).pvalue > 1e-3


def test_squared_mahalanobis_bad_inputs():
    with pytest.raises(ValueError, match="covs must have shape"):
        bf.gaussian.squared_mahalanobis(np.zeros((5, 2)), np.eye(3))
    with pytest.raises(ValueError, match="covs must have shape"):
        bf.gaussian.squared_mahalanobis(np.zeros((5, 2)), np.ones(2))
    with pytest.raises(ValueError, match="do not broadcast"):
        bf.gaussian.squared_mahalanobis(np.zeros((5, 2)), np.broadcast_to(np.eye(2), (4, 2, 2)))
    with pytest.raises(ValueError, match="covs must be positive definite"):
        bf.gaussian.squared_mahalanobis(np.zeros(2), [[1.0, 1.0], [1.0, 1.0]])
    with pytest.raises(ValueError, match="covs must be symmetric"):
        bf.gaussian.squared_mahalanobis(np.zeros(2), [[1.0, 0.5], [0.0, 1.0]])
    with pytest.raises(ValueError, match="diffs must be finite"):
        bf.gaussian.squared_mahalanobis([np.nan, 0.0], np.eye(2))
    with pytest.raises(ValueError, match=r"diffs must have shape \(\.\.\., n\)"):
        bf.gaussian.squared_mahalanobis(1.0, np.eye(1))


def test_squared_mahalanobis_on_missing_rows_says_to_select_the_observed_rows():
    """A filter result has NaN innovations (and innovation covariances) on its missing rows;
    the error must say how to leave them out, and the suggested call must work."""
    model = bf.models.damped_particle()
    ys = bf.models.simulate(model, 20, np.random.default_rng(7)).ys
    ys[[3, 11]] = np.nan
    res = bf.kalman.kalman_filter(model, ys)
    hint = r"select the observed rows.*res\.innovations\[res\.observed\]"
    with pytest.raises(ValueError, match=r"diffs must be finite, got NaN at index \(3, 0\).*"
                                         + hint):
        bf.gaussian.squared_mahalanobis(res.innovations, res.innovation_covs)
    with pytest.raises(ValueError, match=r"covs must be finite, got NaN at index \(3, 0, 0\).*"
                                         + hint):
        bf.gaussian.squared_mahalanobis(np.zeros((20, 2)), res.innovation_covs)
    nis = bf.gaussian.squared_mahalanobis(res.innovations[res.observed],
                                          res.innovation_covs[res.observed])
    ref = [r @ np.linalg.solve(S, r) for r, S in zip(res.innovations, res.innovation_covs)
           if np.isfinite(r).all()]
    np.testing.assert_allclose(nis, ref, rtol=1e-10)
    # inf is not a missing row: the plain message
    with pytest.raises(ValueError, match="diffs must be finite, got NaN or inf"):
        bf.gaussian.squared_mahalanobis([np.inf, 0.0], np.eye(2))


# --------------------------------------------------------------------------
# chi2_interval
# --------------------------------------------------------------------------

def test_chi2_interval_table_values():
    # Printed chi-square tables: chi2_1 2.5 % / 97.5 % points 0.000982 / 5.024,
    # chi2_4: 0.484 / 11.143
    np.testing.assert_allclose(bf.gaussian.chi2_interval(1), (0.000982, 5.024), rtol=2e-3)
    np.testing.assert_allclose(bf.gaussian.chi2_interval(4), (0.484, 11.143), rtol=2e-3)


@pytest.mark.parametrize("dof,n_runs,confidence", [(2, 1, 0.95), (4, 50, 0.95), (3, 10, 0.99)])
def test_chi2_interval_coverage_monte_carlo(dof, n_runs, confidence):
    rng = np.random.default_rng(dof * 100 + n_runs)
    N = 100_000
    avgs = rng.chisquare(dof, size=(N, n_runs)).mean(axis=1)
    low, high = bf.gaussian.chi2_interval(dof, n_runs, confidence)
    inside = np.mean((avgs >= low) & (avgs <= high))
    assert abs(inside - confidence) < 5 * np.sqrt(confidence * (1 - confidence) / N)
    # Equal tails, a = (1 - confidence) / 2 each. The tail fractions are multinomial:
    # Var(p_low - p_high) = (2 a (1 - a) + 2 a^2) / N = 2 a / N = (1 - confidence) / N,
    # so 5 standard errors are 5 sqrt((1 - confidence) / N).
    assert abs(np.mean(avgs < low) - np.mean(avgs > high)) < 5 * np.sqrt((1 - confidence) / N)


def test_chi2_interval_bad_inputs():
    with pytest.raises(ValueError, match="dof must be >= 1"):
        bf.gaussian.chi2_interval(0)
    with pytest.raises(TypeError, match="dof must be an integer"):
        bf.gaussian.chi2_interval(2.0)
    with pytest.raises(ValueError, match="n_runs must be >= 1"):
        bf.gaussian.chi2_interval(2, n_runs=0)
    with pytest.raises(ValueError, match=r"confidence must be in \(0, 1\)"):
        bf.gaussian.chi2_interval(2, confidence=1.0)
    with pytest.raises(TypeError, match="confidence must be a real number"):
        bf.gaussian.chi2_interval(2, confidence="high")


# --------------------------------------------------------------------------
# Innovation whiteness: normalised_innovations and autocorrelation
# --------------------------------------------------------------------------

def _autocorrelation_double_loop(x, max_lag):
    """gamma(k) = sum_t (x_t - xbar)(x_{t+k} - xbar) / sum_t (x_t - xbar)^2, written out."""
    N = len(x)
    xbar = sum(x) / N
    denom = sum((x[t] - xbar) ** 2 for t in range(N))
    return [sum((x[t] - xbar) * (x[t + k] - xbar) for t in range(N - k)) / denom
            for k in range(1, max_lag + 1)]


def test_autocorrelation_equals_double_loop():
    rng = np.random.default_rng(20)
    x = rng.standard_normal(40).cumsum()  # strongly correlated, so every lag matters
    got = bf.gaussian.autocorrelation(x, 12)
    assert got.shape == (12,)
    np.testing.assert_allclose(got, _autocorrelation_double_loop(list(x), 12), rtol=1e-12,
                               atol=1e-15)
    cols = rng.standard_normal((30, 3)) + [0.0, 5.0, -2.0]
    got = bf.gaussian.autocorrelation(cols, 29)
    assert got.shape == (29, 3)
    for j in range(3):
        np.testing.assert_allclose(got[:, j], _autocorrelation_double_loop(list(cols[:, j]), 29),
                                   rtol=1e-12, atol=1e-15)


def test_autocorrelation_of_white_noise_stays_in_the_band_95_percent_of_the_time():
    """For white noise each gamma(k), k >= 1, is about N(0, 1/N), so +-1.96 / sqrt(N) holds
    about 95 % of the lags; an AR(1) sequence leaves the band (the test can fail)."""
    rng = np.random.default_rng(21)
    N, runs, max_lag = 500, 400, 20
    acf = bf.gaussian.autocorrelation(rng.standard_normal((N, runs)), max_lag)
    inside = np.mean(np.abs(acf) < 1.96 / np.sqrt(N))
    # Tolerance. The 8000 values are (nearly) independent for white noise, so the fraction
    # has SE sqrt(0.95 * 0.05 / 8000) = 0.0024; 5 SE = 0.012. On top, at finite N the
    # biased estimator has Var gamma(k) = (N - k) / (N (N + 2)) < 1/N (Bartlett), which
    # raises the expected coverage to between 0.9507 (k = 1) and 0.9547 (k = 20); allow 0.005.
    assert abs(inside - 0.95) < 0.012 + 0.005
    # AR(1) with coefficient 0.5: gamma(1) = 0.5, with SE about sqrt((1 - 0.5^2) / N) = 0.04
    e = rng.standard_normal(N)
    ar = np.empty(N)
    ar[0] = e[0]
    for t in range(1, N):
        ar[t] = 0.5 * ar[t - 1] + e[t]
    rho = bf.gaussian.autocorrelation(ar, max_lag)
    assert abs(rho[0] - 0.5) < 5 * np.sqrt(0.75 / N)
    assert np.mean(np.abs(rho) < 1.96 / np.sqrt(N)) < 0.9


def test_normalised_innovations_whiten_with_the_cholesky_factor():
    rng = np.random.default_rng(22)
    T, m = 8, 3
    S = np.stack([random_spd(rng, m) for _ in range(T)])
    r = rng.standard_normal((T, m))
    z = bf.gaussian.normalised_innovations(r, S)
    assert z.shape == (T, m)
    for t in range(T):
        # z_t = L_t^{-1} r_t with L_t the lower Cholesky factor (scipy's, not numpy's)
        L = sla.cholesky(S[t], lower=True)
        np.testing.assert_allclose(L @ z[t], r[t], rtol=1e-12, atol=1e-14)
        # |z_t|^2 is the NIS r_t^T S_t^{-1} r_t
        np.testing.assert_allclose(z[t] @ z[t], r[t] @ np.linalg.solve(S[t], r[t]), rtol=1e-12)


def test_whiteness_of_a_consistent_kalman_filter():
    """The filter's normalised innovations on data from its own model are N(0, I) and white:
    sample covariance I within 5 SE, and about 95 % of the lags inside the band."""
    model = bf.models.damped_particle()
    T = 3000
    ys = bf.models.simulate(model, T, np.random.default_rng(23)).ys
    res = bf.kalman.kalman_filter(model, ys)
    z = bf.gaussian.normalised_innovations(res.innovations, res.innovation_covs)
    # SE of a sample variance of N(0, 1) is sqrt(2 / T), of a covariance sqrt(1 / T)
    cov = np.cov(z.T)
    assert np.all(np.abs(cov - np.eye(2)) < 5 * np.sqrt(np.array([[2, 1], [1, 2]]) / T))
    acf = bf.gaussian.autocorrelation(z, 50)
    # 100 values: the fraction inside has SE sqrt(0.95 * 0.05 / 100) = 0.022; allow 4 SE
    assert abs(np.mean(np.abs(acf) < 1.96 / np.sqrt(T)) - 0.95) < 4 * 0.022


def test_whiteness_helpers_on_missing_rows_say_to_select_the_observed_rows():
    model = bf.models.damped_particle()
    ys = bf.models.simulate(model, 30, np.random.default_rng(24)).ys
    ys[[0, 9]] = np.nan
    res = bf.kalman.kalman_filter(model, ys)
    hint = (r"select the observed rows, e\.g\. normalised_innovations\(res\.innovations"
            r"\[res\.observed\], res\.innovation_covs\[res\.observed\]\)")
    with pytest.raises(ValueError, match=r"innovations must be finite, got NaN at index \(0, 0\)"
                                         r"\. .*" + hint):
        bf.gaussian.normalised_innovations(res.innovations, res.innovation_covs)
    z = bf.gaussian.normalised_innovations(res.innovations[res.observed],
                                           res.innovation_covs[res.observed])
    assert z.shape == (28, 2)
    with pytest.raises(ValueError, match=r"x must be finite, got NaN at index \(0, 0\).*" + hint):
        bf.gaussian.autocorrelation(res.innovations, 5)


def test_whiteness_helpers_bad_inputs():
    S = np.broadcast_to(np.eye(2), (5, 2, 2))
    with pytest.raises(ValueError, match=r"innovations must have shape \(T, m\)"):
        bf.gaussian.normalised_innovations(np.zeros(5), S)
    with pytest.raises(ValueError, match=r"innovation_covs must have shape \(5, 2, 2\)"):
        bf.gaussian.normalised_innovations(np.zeros((5, 2)), np.eye(2))
    with pytest.raises(ValueError, match="innovation_covs must be positive definite"):
        bf.gaussian.normalised_innovations(np.zeros((1, 2)), [[[1.0, 2.0], [2.0, 1.0]]])
    with pytest.raises(ValueError, match="innovation_covs must be symmetric"):
        bf.gaussian.normalised_innovations(np.zeros((1, 2)), [[[1.0, 0.5], [0.0, 1.0]]])
    with pytest.raises(ValueError, match="innovations must be finite, got NaN or inf"):
        bf.gaussian.normalised_innovations([[np.inf, 0.0]], [np.eye(2)])
    x = np.arange(10.0)
    with pytest.raises(ValueError, match=r"max_lag must be <= N - 1 = 9, got 10"):
        bf.gaussian.autocorrelation(x, 10)
    with pytest.raises(ValueError, match="max_lag must be >= 1"):
        bf.gaussian.autocorrelation(x, 0)
    with pytest.raises(TypeError, match="max_lag must be an integer"):
        bf.gaussian.autocorrelation(x, 2.0)
    with pytest.raises(ValueError, match="x is constant"):
        bf.gaussian.autocorrelation(np.c_[x, np.ones(10)], 3)
    with pytest.raises(ValueError, match=r"x must have shape \(N,\) or \(N, m\)"):
        bf.gaussian.autocorrelation(np.zeros((4, 2, 2)), 1)
    with pytest.raises(ValueError, match="x needs at least 2 samples"):
        bf.gaussian.autocorrelation([1.0], 1)


@pytest.mark.parametrize("shape", [(1, 1), (4, 1), (2, 2), (4, 2)])
def test_apply_to_rows_is_the_matrix_product(shape):
    """The rows F z_i: one column of F is applied as a column times a number, exactly."""
    from bayesfilt.gaussian import _apply_to_rows

    rng = np.random.default_rng(7)
    F, z = rng.standard_normal(shape), rng.standard_normal((1000, shape[1]))
    np.testing.assert_array_equal(_apply_to_rows(F, z), z @ F.T)
    np.testing.assert_array_equal(_apply_to_rows(F, z[:1]), np.atleast_2d(F @ z[0]))


def test_squared_mahalanobis_singular_inf_matches_a_per_matrix_inverse():
    # independent reference: d^T P^{-1} d with np.linalg.inv, matrix by matrix; inf where P
    # is singular (a particle cloud collapsed onto a point has P = 0)
    rng = np.random.default_rng(5)
    A = rng.standard_normal((6, 3, 3))
    P = A @ A.transpose(0, 2, 1) + 0.1 * np.eye(3)
    P[2] = 0.0
    P[4] = np.outer([1.0, 2.0, 0.0], [1.0, 2.0, 0.0])     # rank one
    d = rng.standard_normal((6, 3))
    got = bf.gaussian.squared_mahalanobis(d, P, singular="inf")
    for k in range(6):
        if k in (2, 4):
            assert got[k] == np.inf, (k, got[k])
        else:
            np.testing.assert_allclose(got[k], d[k] @ np.linalg.inv(P[k]) @ d[k], rtol=1e-10)
    # one pair: a scalar, as without singular
    assert np.ndim(bf.gaussian.squared_mahalanobis(d[2], P[2], singular="inf")) == 0
    # the default still refuses a singular covariance, and a third value is refused
    with pytest.raises(ValueError, match="positive definite"):
        bf.gaussian.squared_mahalanobis(d, P)
    with pytest.raises(ValueError, match='singular must be "raise" or "inf"'):
        bf.gaussian.squared_mahalanobis(d, P, singular="nan")
    # shape errors are not turned into inf
    with pytest.raises(ValueError, match="covs must have shape"):
        bf.gaussian.squared_mahalanobis(d, P[:, :2, :2], singular="inf")


def test_nis_of_partly_observed_rows_is_pointed_to_the_observed_components():
    """A partly-observed row has NaN in its missing components: the message says how to
    select, and the NIS of each row's observed block is chi-square with as many degrees of
    freedom as observed components (checked here against the deleting formula)."""
    model = bf.models.damped_particle()
    ys = bf.models.simulate(model, 20, np.random.default_rng(8)).ys
    ys[4, 1] = np.nan
    res = bf.kalman.kalman_filter(model, ys)
    with pytest.raises(ValueError, match=r"partly-observed row .*res\.observed_components\.all"):
        bf.gaussian.squared_mahalanobis(res.innovations[res.observed],
                                        res.innovation_covs[res.observed])
    full = res.observed_components.all(axis=-1)
    assert full.sum() == 19
    bf.gaussian.squared_mahalanobis(res.innovations[full], res.innovation_covs[full])
    o = res.observed_components[4]
    nis_4 = bf.gaussian.squared_mahalanobis(res.innovations[4, o],
                                            res.innovation_covs[4][np.ix_(o, o)])
    r = ys[4, 0] - res.pred_means[4, 0]
    assert nis_4 == pytest.approx(r ** 2 / (res.pred_covs[4, 0, 0] + model.R[0, 0]), rel=1e-12)
