"""Tests of bf.resampling against independent references.

References: the exact laws of the offspring counts N_i, written out here from
the definitions (multinomial: M W (1 - W); stratified: a sum of independent
Bernoullis, one per stratum, with probability M times the overlap of the
stratum and the piece of [0, 1) that belongs to particle i; systematic:
floor or ceil of M W_i; residual: floor(M W_i) plus a multinomial rest);
filterpy 2.0.0's systematic_resample and stratified_resample fed the same
uniforms; and theorems on the range of the counts. Monte Carlo tolerances are
5 standard errors, with the standard error from the exact variance, so that
a fixed seed passes by a wide margin and a wrong law fails by many.
"""

from __future__ import annotations

import filterpy.monte_carlo.resampling as fp
import numpy as np
import pytest

from bayesfilt import resampling

SCHEMES = resampling.SCHEMES
NAMES = list(SCHEMES)

# A fixed weight vector with large, small, tiny and zero weights, deliberately
# not normalised (the functions normalise). For M in (5, 8, 9, 13) no M W_i is an
# integer, so each systematic count has a genuine floor/ceil choice.
W_RAW = 7.3 * np.array([0.3, 0.001, 0.245, 0.0005, 0.0, 0.12, 0.21, 0.0335, 0.09])
W_FIXED = W_RAW / W_RAW.sum()


def counts_of(indices, N):
    return np.bincount(indices, minlength=N)


def exact_mean_and_var(name, W, M):
    """E[N_i] and Var(N_i) of each scheme, from its definition (not from bf)."""
    MW = M * W
    if name == "multinomial":
        return MW, M * W * (1 - W)
    if name == "systematic":
        # N_i is floor(M W_i) or ceil(M W_i), with mean M W_i: a shifted Bernoulli.
        frac = MW - np.floor(MW)
        return MW, frac * (1 - frac)
    if name == "residual":
        rest = MW - np.floor(MW)
        R = M - np.floor(MW).sum()
        return MW, rest * (1 - rest / R)
    if name == "stratified":
        # Point j is uniform on stratum [j/M, (j+1)/M), independently of the others;
        # it goes to particle i with probability q_ij = M |stratum j  ∩ [C_{i-1}, C_i)|.
        C = np.concatenate([[0.0], np.cumsum(W)])
        lo = np.maximum(np.arange(M)[:, None] / M, C[None, :-1])
        hi = np.minimum((np.arange(M)[:, None] + 1) / M, C[None, 1:])
        q = M * np.clip(hi - lo, 0.0, None)
        return q.sum(axis=0), (q * (1 - q)).sum(axis=0)
    raise KeyError(name)


# --------------------------------------------------------------------------
# Output: dtype, shape, sorted, in range
# --------------------------------------------------------------------------

@pytest.mark.parametrize("name", NAMES)
@pytest.mark.parametrize("M", [None, 1, 5, 9, 40])
def test_output_is_sorted_int_array_of_length_M(name, M):
    rng = np.random.default_rng(0)
    a = SCHEMES[name](W_RAW, rng, M=M)
    want = len(W_RAW) if M is None else M
    assert a.dtype == np.intp and a.shape == (want,)
    assert np.all(np.diff(a) >= 0)
    assert a.min() >= 0 and a.max() < len(W_RAW)
    assert not np.any(a == 4), "a zero weight was selected"


def test_from_uniforms_output():
    a = resampling.from_uniforms(W_RAW, np.linspace(0.0, 0.99, 6))
    assert a.dtype == np.intp and a.shape == (6,) and np.all(np.diff(a) >= 0)


# --------------------------------------------------------------------------
# The law of the counts: E[N_i] = M W_i and the exact variances
# --------------------------------------------------------------------------

def test_exact_laws_are_unbiased():
    """The reference formulas themselves: every mean is M W_i (the stratified one is computed)."""
    for name in NAMES:
        for M in (5, 8, 9, 13):
            mean, var = exact_mean_and_var(name, W_FIXED, M)
            np.testing.assert_allclose(mean, M * W_FIXED, rtol=1e-12, atol=1e-12)
            assert np.all(var >= 0)


@pytest.mark.parametrize("name", NAMES)
@pytest.mark.parametrize("M", [5, 8, 9, 13])  # N = 9: M < N, M = N, M > N
def test_counts_unbiased_and_with_the_exact_variance(name, M):
    """Over R resamplings, mean count within 5 SE of M W_i and sample variance of the exact one.

    SE of the mean: sqrt(Var(N_i) / R) from the exact variance (plus 1e-9 for
    counts with no randomness). SE of the sample variance s^2: the finite-sample
    formula Var(s^2) = m4 / R - var^2 (R - 3) / (R (R - 1)), with the exact var
    and the sample fourth central moment m4 (counts are far from Gaussian, so the
    chi-square formula 2 var^2 / R would be wrong; for a count that is 1 or 2 with
    probability 1/2 each, m4 = var^2 and the first-order term vanishes).
    """
    R = 4000
    rng = np.random.default_rng(100 + M)
    N = len(W_RAW)
    draws = np.array([counts_of(SCHEMES[name](W_RAW, rng, M=M), N) for _ in range(R)])
    assert np.all(draws.sum(axis=1) == M)
    mean, var = exact_mean_and_var(name, W_FIXED, M)
    se_mean = np.sqrt(var / R) + 1e-9
    assert np.all(np.abs(draws.mean(axis=0) - mean) <= 5 * se_mean), (
        f"{name}: mean counts {draws.mean(axis=0)} vs M W = {mean}")
    s2 = draws.var(axis=0, ddof=1)
    m4 = ((draws - draws.mean(axis=0)) ** 4).mean(axis=0)
    se_var = np.sqrt(np.maximum(m4 / R - var**2 * (R - 3) / (R * (R - 1)), 0.0)) + 1e-9
    assert np.all(np.abs(s2 - var) <= 5 * se_var), (
        f"{name}: count variances {s2} vs exact {var}")


def test_variance_ordering_on_the_fixed_weights():
    """Douc, Cappé & Moulines (2005): residual and stratified counts vary no more than
    multinomial ones; systematic counts (floor or ceil) vary least of all."""
    for M in (5, 8, 9, 13):
        v = {name: exact_mean_and_var(name, W_FIXED, M)[1] for name in NAMES}
        for name in ("stratified", "residual", "systematic"):
            assert np.all(v[name] <= v["multinomial"] + 1e-12), name
            assert np.all(v["systematic"] <= v[name] + 1e-12), name


# --------------------------------------------------------------------------
# Ranges of the counts (theorems), over many random weight vectors
# --------------------------------------------------------------------------

def random_weight_vectors(seed, n_vectors=150):
    rng = np.random.default_rng(seed)
    for _ in range(n_vectors):
        N = int(rng.integers(1, 300))
        alpha = rng.choice([0.02, 0.3, 1.0, 30.0])  # from very uneven to nearly equal
        W = rng.dirichlet(np.full(N, alpha))
        M = int(rng.choice([N, max(1, N // 3), 2 * N + 1]))
        yield W, M, rng


# Slack for round-off: M W_i is computed here and in bf in different orders;
# the counts are integers, so 1e-9 cannot hide a wrong count.
EPS = 1e-9


def test_systematic_counts_are_floor_or_ceil():
    """A comb of spacing 1/M puts floor(M W_i) or ceil(M W_i) points in a piece of length W_i."""
    for W, M, rng in random_weight_vectors(1):
        c = counts_of(resampling.systematic(W, rng, M=M), len(W))
        MW = M * W
        assert np.all(c >= np.floor(MW - EPS)) and np.all(c <= np.ceil(MW + EPS))
        assert c.sum() == M


def test_stratified_counts_within_two_of_M_W():
    """Strata inside piece i give one point each, the two strata it cuts at most one each:
    floor(b) - ceil(a) <= N_i <= floor(b) - ceil(a) + 2 with a = M C_{i-1}, b = M C_i,
    hence |N_i - M W_i| < 2."""
    worst = 0.0
    for W, M, rng in random_weight_vectors(2):
        c = counts_of(resampling.stratified(W, rng, M=M), len(W))
        dev = np.abs(c - M * W)
        assert np.all(dev < 2 + EPS)
        worst = max(worst, dev.max())
    # and the bound of the systematic scheme (< 1) does not hold: stratification is looser
    assert worst > 1


def test_residual_counts_at_least_floor():
    for W, M, rng in random_weight_vectors(3):
        c = counts_of(resampling.residual(W, rng, M=M), len(W))
        assert np.all(c >= np.floor(M * W - EPS))
        assert c.sum() == M


# --------------------------------------------------------------------------
# The inverse CDF: brute force, filterpy 2.0.0
# --------------------------------------------------------------------------

def brute_force_inverse_cdf(w, u):
    """a_j = first i with (j + u_j)/M < C_i, C the normalised cumulative weights (Python loop)."""
    M = len(u)
    C = np.cumsum(w) / np.sum(w)
    C[-1] = 1.0
    return np.array([next(i for i in range(len(w)) if (j + u[j]) / M < C[i]) for j in range(M)])


def test_from_uniforms_equals_brute_force_inverse_cdf():
    """Also for M != N, which filterpy does not offer."""
    g = np.random.default_rng(11)
    for _ in range(300):
        N = int(g.integers(1, 40))
        w = g.exponential(size=N) * (g.random(N) < 0.8)
        w[g.integers(N)] += 0.1
        M = int(g.integers(1, 3 * N + 2))
        u = g.random(M)
        np.testing.assert_array_equal(resampling.from_uniforms(w, u), brute_force_inverse_cdf(w, u))
        u1 = np.full(M, g.random())
        np.testing.assert_array_equal(resampling.from_uniforms(w, u1),
                                      brute_force_inverse_cdf(w, u1))


def test_module_docstring_example():
    """The picture in the module docstring: u = 0.637, points 0.159, 0.409, 0.659, 0.909,
    cumulative weights 0.1, 0.7, 0.75, 1 -> ancestors 1, 1, 1, 3."""
    u = np.random.default_rng(0).random()
    assert round(u, 3) == 0.637
    w = [0.1, 0.6, 0.05, 0.25]
    np.testing.assert_array_equal(resampling.systematic(w, np.random.default_rng(0)), [1, 1, 1, 3])
    np.testing.assert_array_equal(brute_force_inverse_cdf(np.array(w), np.full(4, u)), [1, 1, 1, 3])


def test_systematic_and_stratified_equal_filterpy_given_the_same_uniforms():
    """filterpy draws np.random.random() (systematic) or np.random.random(N) (stratified)
    from numpy's global state; read those uniforms, reseed, and call filterpy."""
    g = np.random.default_rng(4)
    for seed in range(300):
        N = int(g.integers(1, 400))
        W = g.dirichlet(np.full(N, g.choice([0.05, 1.0, 20.0])))
        np.random.seed(seed)
        u = np.random.random()
        np.random.seed(seed)
        np.testing.assert_array_equal(resampling.from_uniforms(W, np.full(N, u)),
                                      fp.systematic_resample(W))
        np.random.seed(seed)
        us = np.random.random(N)
        np.random.seed(seed)
        np.testing.assert_array_equal(resampling.from_uniforms(W, us),
                                      fp.stratified_resample(W))


def test_schemes_use_the_documented_uniforms():
    """systematic: one u shared by the M strata; stratified: M independent u (same stream)."""
    W = W_RAW
    for M in (3, 9, 20):
        u = np.random.default_rng(M).random()
        np.testing.assert_array_equal(resampling.systematic(W, np.random.default_rng(M), M=M),
                                      resampling.from_uniforms(W, np.full(M, u)))
        us = np.random.default_rng(M).random(M)
        np.testing.assert_array_equal(resampling.stratified(W, np.random.default_rng(M), M=M),
                                      resampling.from_uniforms(W, us))


def test_filterpy_residual_resample_is_biased_ours_is_not():
    """filterpy issue #290: the rest is drawn from weights - floor(N weights) instead of the
    residuals N weights - floor(N weights). For W = (0.7, 0.1, 0.1, 0.1) those are
    (-1.3, 0.1, 0.1, 0.1); normalised by their sum -1 and searched as if sorted, they send
    every remaining draw to particle 0: filterpy always returns [0, 0, 0, 0], whereas
    E[N] = 4 W = (2.8, 0.4, 0.4, 0.4)."""
    W = np.array([0.7, 0.1, 0.1, 0.1])
    R = 2000
    np.random.seed(0)  # filterpy's own (global) random state
    theirs = np.array([counts_of(fp.residual_resample(W), 4) for _ in range(R)])
    rng = np.random.default_rng(0)
    ours = np.array([counts_of(resampling.residual(W, rng), 4) for _ in range(R)])
    mean, var = exact_mean_and_var("residual", W, 4)
    se = np.sqrt(var / R)  # 0.013 for each small particle: filterpy is 0.4 = 32 SE off
    assert np.all(np.abs(ours.mean(axis=0) - mean) <= 5 * se)
    assert np.all(np.abs(theirs.mean(axis=0) - mean) > 30 * se)
    np.testing.assert_array_equal(theirs, np.tile([4, 0, 0, 0], (R, 1)))


def test_residual_keeps_equal_weights_despite_round_off():
    """49 * (1/49) = 0.9999999999999999 in floating point: an exact floor(M W_i) is 0 for all
    49 equal weights, and residual resampling degrades to multinomial (filterpy's does). Equal
    weights must come back as one copy of each particle, for every N."""
    W = np.full(49, 1 / 49)
    assert np.floor(49 * W).sum() == 0
    np.random.seed(1)
    assert np.bincount(fp.residual_resample(W), minlength=49).max() > 1
    rng = np.random.default_rng(12)
    for N in range(1, 300):
        for w in (np.full(N, 1 / N), np.full(N, 0.1), np.full(N, 3.7e-5)):
            np.testing.assert_array_equal(resampling.residual(w, rng), np.arange(N))


def test_no_index_error_when_the_cumulative_sum_falls_short_of_one(monkeypatch):
    """cumsum of ten weights 0.1 is 0.9999999999999999. With u = 1 - 2^-53 (the largest
    value np.random.random can return) filterpy's last point (9 + u)/10 rounds to 1.0,
    is never below the cumulative sum, and its loop runs off the end."""
    W = np.full(10, 0.1)
    assert np.cumsum(W)[-1] < 1.0
    u_max = 1.0 - 2.0**-53
    monkeypatch.setattr(fp, "random", lambda *size: np.full(size, u_max) if size else u_max)
    with pytest.raises(IndexError):
        fp.systematic_resample(W)
    with pytest.raises(IndexError):
        fp.stratified_resample(W)
    a = resampling.from_uniforms(W, np.full(10, u_max))
    np.testing.assert_array_equal(a, np.arange(10))  # equal weights: one copy each


# --------------------------------------------------------------------------
# Extreme and degenerate weights
# --------------------------------------------------------------------------

@pytest.mark.parametrize("name", NAMES)
def test_huge_N_with_tiny_and_with_huge_weights(name):
    """Equal weights of any scale: every M W_i = 1. Systematic and residual return one copy of
    each particle; all stay in range with exactly M indices."""
    N = 200_000
    # 5e-324: the smallest subnormal; 1e307: the sum overflows
    for scale in (1e-300, 5e-324, 1e307):
        a = SCHEMES[name](np.full(N, scale), np.random.default_rng(6))
        assert a.shape == (N,) and a.min() >= 0 and a.max() < N and np.all(np.diff(a) >= 0)
        if name in ("systematic", "residual"):
            np.testing.assert_array_equal(a, np.arange(N))


@pytest.mark.parametrize("name", NAMES)
def test_tiny_weights_among_large_ones(name):
    """10^5 particles of weight 1e-12 next to one of weight 1: E[N] of each tiny one is ~1e-12 M."""
    N = 100_001
    w = np.full(N, 1e-12)
    w[N // 2] = 1.0
    a = SCHEMES[name](w, np.random.default_rng(7), M=1000)
    assert a.shape == (1000,) and np.all(a == N // 2)


@pytest.mark.parametrize("name", NAMES)
@pytest.mark.parametrize("M", [1, 6, 17])
def test_all_mass_on_one_particle(name, M):
    w = np.zeros(6)
    w[3] = 2.5
    for seed in range(20):
        np.testing.assert_array_equal(SCHEMES[name](w, np.random.default_rng(seed), M=M),
                                      np.full(M, 3))


@pytest.mark.parametrize("name", NAMES)
def test_zero_weights_are_never_selected(name):
    rng = np.random.default_rng(8)
    for _ in range(200):
        N = int(rng.integers(2, 50))
        w = rng.random(N) * (rng.random(N) < 0.4)
        w[rng.integers(N)] = 0.3  # at least one positive weight
        M = int(rng.integers(1, 3 * N))
        a = SCHEMES[name](w, rng, M=M)
        assert np.all(w[a] > 0)
        # also at the ends of the array, where the cumulative sum is flat
        assert np.all(SCHEMES[name](np.r_[0.0, 0.0, w, 0.0], rng, M=M) >= 2)


@pytest.mark.parametrize("name", NAMES)
def test_one_particle(name):
    np.testing.assert_array_equal(SCHEMES[name]([0.2], np.random.default_rng(0), M=4), [0, 0, 0, 0])


def test_no_global_random_state_is_used():
    state = np.random.get_state()
    for name in NAMES:
        SCHEMES[name](W_RAW, np.random.default_rng(0))
    after = np.random.get_state()
    assert state[0] == after[0] and np.array_equal(state[1], after[1]) and state[2:] == after[2:]


def test_same_seed_same_result():
    for name in NAMES:
        a = SCHEMES[name](W_RAW, np.random.default_rng(9), M=30)
        b = SCHEMES[name](W_RAW, np.random.default_rng(9), M=30)
        np.testing.assert_array_equal(a, b)


# --------------------------------------------------------------------------
# Bad inputs
# --------------------------------------------------------------------------

BAD_WEIGHTS = [
    ([0.5, 0.2, 0.1, -0.2], r"weights must be non-negative, got weights\[3\] = -0.2"),
    ([0.5, -np.inf, 0.1], r"weights must be non-negative, got weights\[1\] = -inf"),
    ([0.5, np.nan, 0.1], r"weights must be finite, got weights\[1\] = nan"),
    ([0.5, 0.1, np.inf], r"weights must be finite, got weights\[2\] = inf"),
    ([0.0, 0.0, 0.0], r"weights must not all be zero"),
    ([[0.5, 0.5], [0.5, 0.5]], r"weights must be 1-dimensional, got shape \(2, 2\)"),
    (0.5, r"weights must be 1-dimensional, got scalar"),
    ([], r"weights must not be empty"),
]


@pytest.mark.parametrize("name", NAMES)
@pytest.mark.parametrize("weights,message", BAD_WEIGHTS)
def test_bad_weights(name, weights, message):
    with pytest.raises(ValueError, match=message):
        SCHEMES[name](weights, np.random.default_rng(0))


@pytest.mark.parametrize("weights,message", BAD_WEIGHTS)
def test_bad_weights_from_uniforms(weights, message):
    with pytest.raises(ValueError, match=message):
        resampling.from_uniforms(weights, [0.5, 0.5])


@pytest.mark.parametrize("name", NAMES)
def test_bad_weight_types(name):
    with pytest.raises(TypeError, match="weights"):
        SCHEMES[name](["a", "b"], np.random.default_rng(0))
    with pytest.raises(TypeError, match="weights"):
        SCHEMES[name](None, np.random.default_rng(0))


@pytest.mark.parametrize("name", NAMES)
def test_bad_M(name):
    rng = np.random.default_rng(0)
    with pytest.raises(ValueError, match=r"M must be >= 1, got 0"):
        SCHEMES[name](W_RAW, rng, M=0)
    with pytest.raises(ValueError, match="M must be >= 1"):
        SCHEMES[name](W_RAW, rng, M=-3)
    with pytest.raises(TypeError, match="M must be an integer, got float"):
        SCHEMES[name](W_RAW, rng, M=5.0)
    with pytest.raises(TypeError, match="M must be an integer"):
        SCHEMES[name](W_RAW, rng, M=True)
    assert SCHEMES[name](W_RAW, rng, M=np.int64(4)).shape == (4,)


@pytest.mark.parametrize("name", NAMES)
def test_rng_must_be_a_generator(name):
    for bad in (None, 0, np.random.RandomState(0)):
        with pytest.raises(TypeError, match="rng must be a numpy.random.Generator"):
            SCHEMES[name](W_RAW, bad)


@pytest.mark.parametrize("uniforms,error,message", [
    ([0.5, 1.0], ValueError, r"uniforms must lie in \[0, 1\), got uniforms\[1\] = 1.0"),
    ([-0.1, 0.5], ValueError, r"uniforms must lie in \[0, 1\), got uniforms\[0\] = -0.1"),
    ([0.5, np.nan], ValueError, "uniforms must be finite"),
    ([[0.5, 0.5]], ValueError, "uniforms must be 1-dimensional"),
    ([], ValueError, "uniforms must not be empty"),
    (None, TypeError, "uniforms"),
])
def test_from_uniforms_bad_uniforms(uniforms, error, message):
    with pytest.raises(error, match=message):
        resampling.from_uniforms(W_RAW, uniforms)


def test_unknown_scheme_is_a_key_error():
    with pytest.raises(KeyError):
        resampling.SCHEMES["bootstrap"]


# --------------------------------------------------------------------------
# The boundary rule a_j = min{i : p_j < C_i}: strict, so a zero weight never wins
# --------------------------------------------------------------------------

@pytest.mark.parametrize("weights, uniforms, expected", [
    # a point at 0 is below C_1 = 1 but not below C_0 = 0: index 1, never the zero weight
    ([0.0, 1.0], [0.0], [1]),
    ([0.0, 0.0, 2.0], [0.0], [2]),
    # zero weights in the middle: C = 0.25, 0.5, 0.5, 1. Point 2 is (2 + 0)/4 = 0.5, exactly
    # on C_1 = C_2: it belongs to the first piece that ends above it, index 3
    ([1.0, 1.0, 0.0, 2.0], [0.0, 0.0, 0.0, 0.0], [0, 1, 3, 3]),
    ([1.0, 1.0, 0.0, 0.0, 2.0], [0.0, 0.0, 0.0, 0.0], [0, 1, 4, 4]),
    # zero weights at the end: C = 0.5, 1, 1, 1; the last point, 0.75, is index 1
    ([1.0, 1.0, 0.0, 0.0], [0.0, 0.0, 0.0, 0.0], [0, 0, 1, 1]),
    # a point exactly on a boundary between positive weights goes to the next piece
    ([1.0, 3.0], [0.0, 0.0, 0.0, 0.0], [0, 1, 1, 1]),
    # the largest uniform below 1 stays in the last positive piece
    ([1.0, 1.0, 0.0], [np.nextafter(1.0, 0.0)], [1]),
])
def test_from_uniforms_boundary_rule(weights, uniforms, expected):
    got = resampling.from_uniforms(weights, uniforms)
    np.testing.assert_array_equal(got, expected)
    np.testing.assert_array_equal(got, brute_force_inverse_cdf(np.array(weights),
                                                               np.array(uniforms)))
    assert np.all(np.array(weights)[got] > 0)


@pytest.mark.parametrize("name", ["systematic", "stratified"])
def test_a_uniform_of_zero_never_picks_a_zero_weight(name, monkeypatch):
    """rng.random() can return exactly 0.0; then every point is on a stratum boundary j/M."""
    w = np.array([0.0, 1.0, 0.0, 1.0, 0.0, 0.0, 2.0, 0.0])

    class Zero:
        def random(self, size=None):
            return 0.0 if size is None else np.zeros(size)

    monkeypatch.setattr(resampling, "as_rng", lambda name, rng: rng)
    a = SCHEMES[name](w, Zero(), M=8)
    np.testing.assert_array_equal(a, [1, 1, 3, 3, 6, 6, 6, 6])
