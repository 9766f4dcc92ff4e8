"""bf.verify: each check passes on a correct result and fails on a wrong one.

The references are independent of the code under test: exact values set by
hand, and draws from numpy's generators whose laws are known.
"""

import math

import numpy as np
from scipy.integrate import quad
import pytest

import bayesfilt as bf
from statistics import NormalDist


def test_z_limit_is_the_two_sided_normal_quantile_with_a_union_bound():
    # Phi(3.8906) = 1 - 0.5e-4 (tables); with k entries alpha is split k ways
    assert abs(bf.verify.z_limit(1) - 3.8906) < 1e-4
    assert abs(bf.verify.z_limit(100) - NormalDist().inv_cdf(1 - 0.5e-6)) < 1e-12
    with pytest.raises(ValueError, match="k"):
        bf.verify.z_limit(0)
    with pytest.raises(ValueError, match="alpha"):
        bf.verify.z_limit(1, alpha=2.0)
    # Student's t, 99 dof: the tail beyond the limit, integrated from the density written out
    nu, z = 99, bf.verify.z_limit(1, dof=99)
    c = math.exp(math.lgamma((nu + 1) / 2) - math.lgamma(nu / 2)) / math.sqrt(nu * math.pi)
    tail = quad(lambda x: c * (1 + x * x / nu) ** (-(nu + 1) / 2), z, np.inf)[0]
    assert abs(2 * tail - 1e-4) < 1e-8, 2 * tail
    assert z > bf.verify.z_limit(1)                                           # heavier tails

    assert bf.verify.z_limit(1, dof=10**6) - bf.verify.z_limit(1) < 1e-3   # t -> normal
    with pytest.raises(ValueError, match="dof"):
        bf.verify.z_limit(1, dof=0)


def test_agree_passes_within_tolerance_and_fails_beyond(capsys):
    bf.verify.forget()
    bf.verify.agree("same", [1.0, 2.0], [1.0, 2.0 + 1e-14])
    assert capsys.readouterr().out == "\u2713 same\n"
    bf.verify.report()
    assert capsys.readouterr().out == "same: max |difference| < 1e-12\n"
    with pytest.raises(AssertionError, match="differ.*1.00e-06"):
        bf.verify.agree("differ", [1.0], [1.0 + 1e-6])
    with pytest.raises(AssertionError, match="NaN"):
        bf.verify.agree("nan", [np.nan], [np.nan])
    bf.verify.agree("relative", [1e6], [1e6 + 1e-5], tol=1e-10, relative=True)
    with pytest.raises(ValueError, match=r"shape \(2,\).*shape \(3,\)"):
        bf.verify.agree("shapes", [1.0, 2.0], [1.0, 2.0, 3.0])


def test_within():
    bf.verify.within("in", [0.2, 0.5], 0.0, 1.0)
    with pytest.raises(AssertionError, match="outside"):
        bf.verify.within("out", [0.2, 1.5], 0.0, 1.0)
    with pytest.raises(AssertionError):
        bf.verify.within("nan", [np.nan], 0.0, 1.0)


@pytest.mark.parametrize("seed", range(10))
def test_mc_moments_accepts_correct_draws_and_rejects_a_wrong_covariance(seed):
    rng = np.random.default_rng(seed)
    cov = np.array([[2.0, 0.6], [0.6, 0.5]])
    mean = np.array([1.0, -1.0])
    draws = rng.multivariate_normal(mean, cov, size=20_000)
    bf.verify.mc_moments("right", draws, mean, cov)
    with pytest.raises(AssertionError, match="standard errors"):
        bf.verify.mc_moments("wrong", draws, mean, cov * 1.1)   # 10 % off: ~10 SE at M = 20 000


def test_mc_mean_and_zero_se_entries():
    rng = np.random.default_rng(3)
    values = np.column_stack([rng.exponential(2.0, 50_000), np.zeros(50_000)])
    bf.verify.mc_mean("right", values, [2.0, 0.0])
    with pytest.raises(AssertionError, match="standard error 0"):
        bf.verify.mc_mean("constant entry wrong", values, [2.0, 0.1])
    with pytest.raises(AssertionError):
        bf.verify.mc_mean("mean wrong", values, [2.1, 0.0])


def test_mc_frequencies():
    rng = np.random.default_rng(4)
    probs = np.array([0.5, 0.3, 0.2, 0.0])
    draws = rng.choice(4, size=100_000, p=probs)
    bf.verify.mc_frequencies("right", draws, probs)
    with pytest.raises(AssertionError, match="standard error 0"):
        bf.verify.mc_frequencies("impossible cell drawn", np.append(draws, 3), probs)
    with pytest.raises(AssertionError):
        bf.verify.mc_frequencies("wrong law", draws, np.array([0.45, 0.35, 0.2, 0.0]))
    with pytest.raises(ValueError, match="draws"):
        bf.verify.mc_frequencies("float draws", draws.astype(float), probs)


def test_the_core_line_is_quiet_and_report_keeps_the_numbers(capsys):
    bf.verify.forget()
    rng = np.random.default_rng(5)
    draws = rng.standard_normal((4000, 1))
    bf.verify.mc_moments("draws agree with N(0, 1)", draws, [0.0], [[1.0]])
    bf.verify.within("a probability", 0.3, 0.0, 1.0)
    line = capsys.readouterr().out
    assert line == "\u2713 draws agree with N(0, 1)\n\u2713 a probability\n", line
    assert "SE" not in line and "limit" not in line
    bf.verify.report()
    details = capsys.readouterr().out.splitlines()
    assert details[0].startswith("draws agree with N(0, 1): within ") and "SE" in details[0]
    assert details[1] == "a probability: in [0, 1]"
    bf.verify.report(["a probability"])
    assert capsys.readouterr().out == "a probability: in [0, 1]\n"
    with pytest.raises(KeyError, match="labels"):
        bf.verify.report(["never checked"])


def test_together_prints_one_line_and_fails_with_the_first_failing_check(capsys):
    bf.verify.forget()
    with bf.verify.together("both forms agree"):
        bf.verify.agree("first", [1.0], [1.0])
        with bf.verify.together("inner"):          # nested blocks print nothing of their own
            bf.verify.agree("second", [2.0], [2.0])
    assert capsys.readouterr().out == "\u2713 both forms agree\n"
    bf.verify.report()
    assert capsys.readouterr().out.splitlines() == ["first: max |difference| < 1e-12",
                                                    "second: max |difference| < 1e-12"]
    with pytest.raises(AssertionError, match="wrong"):
        with bf.verify.together("never printed"):
            bf.verify.agree("right", [1.0], [1.0])
            bf.verify.agree("wrong", [1.0], [2.0])
    assert capsys.readouterr().out == ""
    with pytest.raises(ValueError, match="no check"):
        with bf.verify.together("empty"):
            pass


def test_bernstein_limits_against_the_inequality_written_out_and_a_simulation():
    # a fair die: values 1..6, mean 3.5, variance 35/12; b = 2.5 on both sides
    values, probs, n = np.arange(1.0, 7.0), np.full(6, 1 / 6), 50
    low, high = bf.verify.bernstein_limits(values, probs, n, k=2)
    L = math.log(4 / 1e-4)
    # Bernstein's bound at the limit equals alpha / (2 k) exactly
    for eps in (high, -low):
        assert math.isclose(math.exp(-n * eps**2 / (2 * 35 / 12 + 2 * 2.5 * eps / 3)),
                            1e-4 / 4, rel_tol=1e-9)
    assert math.isclose(high, -low) and high > 0
    # the limits hold: the exact law of the sum of 50 rolls (repeated convolution) puts
    # less than alpha / (2 k) beyond each limit
    pmf = np.ones(1)
    for _ in range(n):
        pmf = np.convolve(pmf, probs)
    mean_minus = np.arange(n, 6 * n + 1) / n - 3.5          # the sample mean minus 3.5
    assert pmf[mean_minus > high].sum() < 1e-4 / 4 and pmf[mean_minus < low].sum() < 1e-4 / 4
    # they are wider than the normal limit of the same false-alarm level
    assert high > bf.verify.z_limit(2) * math.sqrt(35 / 12 / n)
    with pytest.raises(ValueError, match="probs"):
        bf.verify.bernstein_limits(values, np.full(6, 0.2), n)
    with pytest.raises(ValueError, match="n"):
        bf.verify.bernstein_limits(values, probs, 0)


def test_mc_bounded_accepts_a_correct_mean_and_rejects_a_biased_one(capsys):
    bf.verify.forget()
    values, probs = np.array([0.0, 1.0]), np.array([0.9, 0.1])
    draws = (np.random.default_rng(1).random(10_000) < 0.1).astype(float)
    bf.verify.mc_bounded("rare successes agree with p = 0.1", draws, values, probs)
    assert capsys.readouterr().out == "\u2713 rare successes agree with p = 0.1\n"
    with pytest.raises(AssertionError, match="Bernstein"):
        bf.verify.mc_bounded("p = 0.13", draws, values, np.array([0.87, 0.13]))


def test_mc_moments_covariance_limits_are_proven_bounds():
    from scipy.stats import chi2
    from bayesfilt.verify import _covariance_limits
    P = np.array([[2.0, 0.6, 0.0], [0.6, 0.5, -0.3], [0.0, -0.3, 1.0]])
    M, k = 2000, 9
    t = math.log(2 * k / 1e-4)
    low, high = _covariance_limits(P, M, t)
    # a variance entry: (M - 1) S_ii / P_ii is chi-square with M - 1 degrees of freedom, so
    # its exact tails beyond the limits are below alpha / (2 k)
    for i in range(3):
        assert chi2.sf((M - 1) * (1 + high[i, i] / P[i, i]), M - 1) < 1e-4 / (2 * k)
        assert chi2.cdf((M - 1) * (1 + low[i, i] / P[i, i]), M - 1) < 1e-4 / (2 * k)
    # an off-diagonal entry: z^T A z with z ~ N(0, P), A = (e_i e_j^T + e_j e_i^T) / 2, is
    # sum lambda (g^2 - 1) + P_ij with lambda the eigenvalues of A P (its moment generating
    # function is det(I - 2 s A P)^(-1/2)); the limits use lambda = (P_ij +- sqrt(P_ii P_jj))/2
    for i, j in [(0, 1), (1, 2), (0, 2)]:
        A = np.zeros((3, 3))
        A[i, j] = A[j, i] = 0.5
        lam = np.sort(np.linalg.eigvals(A @ P).real)
        lam = lam[np.abs(lam) > 1e-12]
        root = math.sqrt(P[i, i] * P[j, j])
        assert np.allclose(lam, sorted([(P[i, j] - root) / 2, (P[i, j] + root) / 2]))
    # the limits are symmetric in (i, j) and wider than the normal ones, but not by much
    assert np.allclose(low, low.T) and np.allclose(high, high.T)
    se = np.sqrt((np.outer(np.diag(P), np.diag(P)) + P**2) / (M - 1))
    assert np.all(high / se > bf.verify.z_limit(k)) and np.all(high / se < 1.25 * bf.verify.z_limit(k))


def test_quadratic_form_limits_against_the_chi_square_law():
    from scipy.stats import chi2
    # equal weights: Q = a chi2_K exactly, so the limits' tails can be read off the law
    K, a, k = 400, 0.5, 3
    low, high = bf.verify.quadratic_form_limits(np.full(K, a), k)
    assert chi2.sf((a * K + high) / a, K) < 1e-4 / (2 * k)
    assert chi2.cdf((a * K + low) / a, K) < 1e-4 / (2 * k)
    # two weights: Q = 1 chi2_30 + 3 chi2_20, whose tails are one integral of the two laws
    from scipy.integrate import quad
    w = np.r_[np.full(30, 1.0), np.full(20, 3.0)]
    low, high = bf.verify.quadratic_form_limits(w, k)
    c_high, c_low = w.sum() + high, w.sum() + low
    upper = quad(lambda x: chi2.pdf(x, 30) * chi2.sf((c_high - x) / 3, 20), 0, np.inf)[0]
    lower = quad(lambda x: chi2.pdf(x, 30) * chi2.cdf((c_low - x) / 3, 20), 0, c_low)[0]
    assert upper < 1e-4 / (2 * k) and lower < 1e-4 / (2 * k), (upper, lower)
    with pytest.raises(ValueError, match="weights"):
        bf.verify.quadratic_form_limits([1.0, -1.0])


def test_mc_quadratic_form_accepts_the_law_and_rejects_a_scaled_one(capsys):
    bf.verify.forget()
    rng = np.random.default_rng(12)
    w = np.repeat([1.0, 2.0], 500)
    value = float((rng.standard_normal(1000) ** 2) @ w)
    bf.verify.mc_quadratic_form("a sum of NEES agrees with its law", value, w)
    assert capsys.readouterr().out == "\u2713 a sum of NEES agrees with its law\n"
    with pytest.raises(AssertionError, match="limits"):
        bf.verify.mc_quadratic_form("over-confident", 1.5 * value, w)
