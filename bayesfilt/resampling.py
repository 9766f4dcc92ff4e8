r"""Resampling: from weighted particles to equally weighted ones.

A particle filter carries N particles :math:`x^i` with normalised importance
weights :math:`W_i \ge 0`, :math:`\sum_i W_i = 1`. After a few updates the
weights degenerate: one particle holds almost all the mass and the others
cost computing time while contributing nothing (the degeneracy problem of
Arulampalam et al. 2002, section on sequential importance sampling, and their
"use of resampling"). Resampling is the cure, seed 000 §3.2 step [4]:
particles with a small weight are reduced, those with a large weight are
multiplied, and the number of particles stays the same.

Precisely, a resampling scheme draws M *ancestor indices*
:math:`a_0, \dots, a_{M-1} \in \{0, \dots, N-1\}`; the new particle set is
:math:`x^{a_0}, \dots, x^{a_{M-1}}`, all with weight :math:`1/M`. Writing
:math:`N_i` for the number of times particle i is chosen (its number of
offspring), every scheme here is *unbiased*:

.. math::

    E[N_i] = M W_i \quad\text{for every } i,

so that :math:`\frac1M \sum_j f(x^{a_j})` is an unbiased estimate of
:math:`\sum_i W_i f(x^i)` for any test function f. The schemes differ in the
noise they add, :math:`\operatorname{Var}(N_i)`. Import the module as
``bf.resampling`` (or ``from bayesfilt import resampling``)::

    import numpy as np
    import bayesfilt as bf

    rng = np.random.default_rng(0)
    x = np.array([-1.0, 0.2, 0.5, 3.0])       # N = 4 particles (scalar states)
    w = np.array([0.1, 0.6, 0.05, 0.25])      # their weights (need not sum to 1)
    a = bf.resampling.systematic(w, rng)      # ancestors: array([1, 1, 1, 3])
    x_new = x[a]                              # the new set, weight 1/4 each
    np.bincount(a, minlength=4)               # offspring counts: array([0, 3, 0, 1])

    # every scheme has the same signature; M defaults to len(w)
    for name, scheme in bf.resampling.SCHEMES.items():
        a = scheme(w, rng, M=10)              # shape (10,), sorted ascending

The picture: the inverse CDF. Stack the weights end to end on [0, 1): the
cumulative weights :math:`\Omega_i = W_0 + \dots + W_i` cut the interval into N
pieces, piece i of length :math:`W_i`. Put M points :math:`u_j` in [0, 1)
and give each the index of the piece it falls in, the first i with
:math:`u_j < \Omega_i`. For the example above (systematic, M = 4, v = 0.637)::

    0    Om_0                              Om_1 Om_2        Om_3 = 1
    |-----|-----------------------------------|--|--------------|
     W_0                 W_1                  W_2      W_3
              ^              ^              ^              ^
    u_j = (j + v)/4 = 0.159, 0.409, 0.659, 0.909   ->   a = 1, 1, 1, 3

A large weight is a long piece and catches several points, a small one is
often missed. The four schemes differ only in how they place the points:

* **multinomial**: M independent uniform points. :math:`(N_i)` is
  multinomial, :math:`\operatorname{Var}(N_i) = M W_i (1 - W_i)`: the
  most noise, the reference the others are compared with.
* **stratified** (Kitagawa 1996): cut [0, 1) into M strata of width 1/M and
  put one independent uniform point in each, :math:`u_j = (j + v_j)/M`.
* **systematic** (Kitagawa 1996; Carpenter, Clifford & Fearnhead 1999): the
  same, with a single uniform shared by all strata, :math:`u_j = (j + v)/M`:
  the points form a comb of spacing 1/M, randomly shifted. Then
  :math:`N_i` is always :math:`\lfloor M W_i \rfloor` or
  :math:`\lceil M W_i \rceil`, the least possible spread for one count.
* **residual** (Liu & Chen 1998): keep :math:`\lfloor M W_i \rfloor` copies
  of every particle deterministically, and draw only the remaining
  :math:`R = M - \sum_i \lfloor M W_i \rfloor` multinomially from the
  residual weights :math:`M W_i - \lfloor M W_i \rfloor` (normalised).

Variance ordering (Douc, Cappé & Moulines 2005, "Comparison of resampling
schemes for particle filtering"): for every test function, residual and
stratified resampling add no more variance than multinomial resampling.
Systematic resampling is usually the least noisy in practice and the
cheapest (one random number), but no such guarantee holds for it: Douc et
al. give a counter-example where it does worse than multinomial, and for
some orderings of the particles it does not even converge as N grows
(Gerber, Chopin & Whiteley 2019). All four are unbiased.

Stratified and systematic resampling are :func:`from_uniforms` fed with
random uniforms; :func:`from_uniforms` takes the M uniforms :math:`v_j`
explicitly, which is what lets a test reproduce filterpy's
``stratified_resample`` and ``systematic_resample`` from the same random
numbers, and what a figure of the comb uses.

Cost. Every scheme takes O(N + M) operations, vectorised: one cumulative
sum and a few passes over the arrays, no search and no Python loop over the
particles (filterpy loops in Python for the stratified and systematic
schemes and runs a binary search, O(M log N), for the multinomial one).
Randomness only through the ``rng`` argument, a ``numpy.random.Generator``.
"""

from __future__ import annotations

import numpy as np

from ._checks import as_array, as_int, as_rng

__all__ = [
    "multinomial",
    "stratified",
    "systematic",
    "residual",
    "from_uniforms",
    "SCHEMES",
]

# Above this total, the sequential cumulative sum could overflow by round-off
# although the (pairwise) total did not; the weights are rescaled first.
_HUGE_TOTAL = 1e300


def _weights(weights) -> tuple[np.ndarray, float]:
    """``weights`` as a checked float vector ``w`` (N,) and its total, 0 < total < 1e300.

    Non-negative, finite and not all zero; unnormalised is fine. Weights whose
    sum overflows (each finite, e.g. two of 1e308) are divided by their
    maximum first: resampling depends only on their ratios.
    """
    w = as_array("weights", weights, ndim=1, finite=False)
    if w.shape[0] == 0:
        raise ValueError(f"weights must not be empty, got shape {w.shape}")
    # One pass finds both NaN and negative entries: min() propagates NaN.
    if not w.min() >= 0:
        i = int(np.flatnonzero(~(w >= 0))[0])
        if np.isnan(w[i]):
            raise ValueError(f"weights must be finite, got weights[{i}] = nan")
        raise ValueError(f"weights must be non-negative, got weights[{i}] = {float(w[i])!r}")
    with np.errstate(over="ignore"):  # an overflowing sum is handled below
        total = float(np.sum(w))
    if total == 0.0:
        raise ValueError(f"weights must not all be zero (their sum normalises them), "
                         f"got {w.shape[0]} zero weights")
    if not total <= _HUGE_TOTAL:
        infinite = np.flatnonzero(np.isinf(w))
        if infinite.size:
            raise ValueError(f"weights must be finite, got weights[{infinite[0]}] = inf")
        w = w / w.max()
        total = float(np.sum(w))
    return w, total


def _check_M(M, N: int) -> int:
    return N if M is None else as_int("M", M, minimum=1)


def _below(w: np.ndarray, M: int, u) -> np.ndarray:
    r"""For each i, the number of points :math:`u_j = (j + v_j)/M` below :math:`\Omega_i`, shape (N,).

    ``w`` are checked weights; ``u`` is an array (M,) of uniforms in [0, 1),
    or one float used for every j (systematic). O(N + M) and no search, by
    the counting argument below. The result is non-decreasing and ends at M.
    """
    # M Omega_i = M (w_0 + ... + w_i) / sum(w): the cumulative weights on the scale
    # of the strata. Dividing by the last partial sum makes Omega_{N-1} = 1 exactly
    # (x / x == 1 in floating point) and keeps Omega non-decreasing and <= 1, so
    # M Omega_i <= M with equality at the end: round-off cannot lose a point.
    MC = np.cumsum(w)
    MC /= MC[-1]
    MC *= M
    # below_i = number of points below Omega_i, in O(1) per i. Point j is below Omega_i
    # iff j + v_j < M Omega_i. With k_i = floor(M Omega_i), this holds for every j < k_i
    # (j + v_j < j + 1 <= k_i <= M Omega_i), for no j > k_i (j + v_j >= j >= k_i + 1
    # > M Omega_i), and for j = k_i iff v_{k_i} < M Omega_i - k_i. Hence
    #   below_i = k_i + [v_{k_i} < M Omega_i - k_i],
    # and below_i = M when k_i = M (then M Omega_i - k_i = 0: the test is false).
    # M Omega_i - k_i is computed exactly, so no further round-off enters.
    # The arrays are as long as the particle set and fresh memory costs page
    # faults, so they are updated in place.
    # k_i = floor(M Omega_i), by truncation since M Omega_i >= 0
    k = MC.astype(np.intp)
    # M Omega_i - k_i
    frac = np.subtract(MC, k, out=MC)
    # v_{k_i}. k_i = M only where M Omega_i = M, and there the test is false
    # whatever v says, so clipping the look-up to v_{M-1} changes nothing.
    u_k = u if np.ndim(u) == 0 else np.take(u, k, mode="clip")
    # below_i = k_i + [v_{k_i} < M Omega_i - k_i]
    below = k
    below += u_k < frac
    return below


def _expand(below: np.ndarray, M: int) -> np.ndarray:
    """Sorted ancestor indices (M,) from below_i = N_0 + ... + N_i (non-decreasing, ends at M).

    Point j goes to the first i with j < below_i; as below is non-decreasing,
    that i is the number of entries with below_i <= j. Same result as
    ``np.repeat(np.arange(N), np.diff(below, prepend=0))``, in two passes.
    """
    # how_many[v] = #{i : below_i = v}, v = 0..M-1
    how_many = np.bincount(below, minlength=M + 1)[:M]
    # a_j = #{i : below_i <= j} = how_many[0] + ... + how_many[j]  (in place)
    return np.cumsum(how_many, out=how_many)


def from_uniforms(weights, uniforms) -> np.ndarray:
    r"""Ancestors of the M stratified points built from given uniforms.

    The points are :math:`u_j = (j + v_j)/M`, :math:`j = 0, \dots, M-1`,
    one in each stratum :math:`[j/M, (j+1)/M)`; point j gets the index of the
    first cumulative weight above it,

    .. math::

        a_j = \min\{\, i : u_j < \Omega_i \,\}, \qquad
        \Omega_i = \frac{w_0 + \dots + w_i}{w_0 + \dots + w_{N-1}}.

    Independent uniforms give stratified resampling, one uniform repeated M
    times gives systematic resampling. Given the same uniforms, this is
    filterpy's ``stratified_resample`` (``u = np.random.random(N)``) and
    ``systematic_resample`` (``u = np.full(N, np.random.random())``), without
    their Python loop and without their IndexError when the cumulative sum of
    the weights falls short of 1 by round-off: here :math:`\Omega_{N-1} = 1`
    exactly, so every point finds an index.

    Parameters
    ----------
    weights : array_like, shape (N,)
        Non-negative importance weights, not all zero; normalised internally.
    uniforms : array_like, shape (M,)
        :math:`v_j \in [0, 1)`, one per stratum. M >= 1 may differ from N.

    Returns
    -------
    ndarray of intp, shape (M,)
        Ancestor indices in 0..N-1, sorted ascending. A particle of zero
        weight is never chosen.

    Raises
    ------
    ValueError
        If ``weights`` is not a non-empty vector of finite non-negative
        numbers with a positive sum, or ``uniforms`` is not a non-empty vector
        with entries in [0, 1).
    """
    w, _ = _weights(weights)
    u = as_array("uniforms", uniforms, ndim=1)
    if u.shape[0] == 0:
        raise ValueError(f"uniforms must not be empty, got shape {u.shape}")
    if not (u.min() >= 0.0 and u.max() < 1.0):
        j = int(np.flatnonzero((u < 0.0) | (u >= 1.0))[0])
        raise ValueError(f"uniforms must lie in [0, 1), got uniforms[{j}] = {float(u[j])!r}")
    return _expand(_below(w, u.shape[0], u), u.shape[0])


def multinomial(weights, rng, M=None) -> np.ndarray:
    r"""Multinomial resampling: M independent draws from the weights.

    The offspring counts are multinomial,
    :math:`(N_0, \dots, N_{N-1}) \sim \mathrm{Mult}(M; W_0, \dots, W_{N-1})`,
    so :math:`E[N_i] = M W_i` and :math:`\operatorname{Var}(N_i) = M W_i
    (1 - W_i)`, the most of the four schemes. The counts are drawn directly
    (``rng.multinomial``, N binomial draws) and expanded into sorted indices,
    O(N + M); filterpy's ``multinomial_resample`` draws M uniforms and
    searches each in the cumulative sum, O(M log N).

    Parameters
    ----------
    weights : array_like, shape (N,)
        Non-negative importance weights, not all zero; normalised internally.
    rng : numpy.random.Generator
        Source of randomness, e.g. ``np.random.default_rng(0)``.
    M : int, optional
        Number of indices to draw, >= 1; default N.

    Returns
    -------
    ndarray of intp, shape (M,)
        Ancestor indices in 0..N-1, sorted ascending.

    Raises
    ------
    ValueError
        If ``weights`` is not a non-empty vector of finite non-negative
        numbers with a positive sum, or M < 1.
    TypeError
        If ``rng`` is not a Generator or M is not an integer.
    """
    w, total = _weights(weights)
    rng = as_rng("rng", rng)
    M = _check_M(M, w.shape[0])
    # (N_0, ..., N_{N-1}) ~ Mult(M; W)
    counts = rng.multinomial(M, w / total)
    return _expand(np.cumsum(counts), M)


def stratified(weights, rng, M=None) -> np.ndarray:
    r"""Stratified resampling (Kitagawa 1996): one uniform point per stratum.

    :math:`u_j = (j + v_j)/M` with independent :math:`v_j \sim U[0, 1)`,
    then :func:`from_uniforms`. Unbiased, :math:`E[N_i] = M W_i`, and never
    noisier than multinomial resampling (Douc, Cappé & Moulines 2005).
    Every count differs from :math:`M W_i` by less than 2 (up to round-off
    in the cumulative weights): the strata inside piece i contribute one
    point each, the two it cuts at its ends at most one each. filterpy:
    ``stratified_resample(W)`` (M = N and normalised weights only); given
    the same uniforms the indices are identical.

    Parameters
    ----------
    weights : array_like, shape (N,)
        Non-negative importance weights, not all zero; normalised internally.
    rng : numpy.random.Generator
        Source of randomness, e.g. ``np.random.default_rng(0)``.
    M : int, optional
        Number of indices to draw, >= 1; default N.

    Returns
    -------
    ndarray of intp, shape (M,)
        Ancestor indices in 0..N-1, sorted ascending.

    Raises
    ------
    ValueError
        If ``weights`` is not a non-empty vector of finite non-negative
        numbers with a positive sum, or M < 1.
    TypeError
        If ``rng`` is not a Generator or M is not an integer.
    """
    w, _ = _weights(weights)
    rng = as_rng("rng", rng)
    M = _check_M(M, w.shape[0])
    return _expand(_below(w, M, rng.random(M)), M)


def systematic(weights, rng, M=None) -> np.ndarray:
    r"""Systematic resampling: a comb of M points with one random offset.

    :math:`u_j = (j + v)/M` with a single :math:`v \sim U[0, 1)`, then
    :func:`from_uniforms`. Unbiased, :math:`E[N_i] = M W_i`, and every count
    is :math:`\lfloor M W_i \rfloor` or :math:`\lceil M W_i \rceil` (up to
    round-off in the cumulative weights). The usual default, also
    Arulampalam et al. (2002), Algorithm 2; but unlike stratified and
    residual resampling it is not guaranteed to beat multinomial resampling
    for every test function (Douc, Cappé & Moulines 2005). filterpy:
    ``systematic_resample(W)`` (M = N and normalised weights only); given
    the same uniform the indices are identical.

    Parameters
    ----------
    weights : array_like, shape (N,)
        Non-negative importance weights, not all zero; normalised internally.
    rng : numpy.random.Generator
        Source of randomness, e.g. ``np.random.default_rng(0)``.
    M : int, optional
        Number of indices to draw, >= 1; default N.

    Returns
    -------
    ndarray of intp, shape (M,)
        Ancestor indices in 0..N-1, sorted ascending.

    Raises
    ------
    ValueError
        If ``weights`` is not a non-empty vector of finite non-negative
        numbers with a positive sum, or M < 1.
    TypeError
        If ``rng`` is not a Generator or M is not an integer.
    """
    w, _ = _weights(weights)
    rng = as_rng("rng", rng)
    M = _check_M(M, w.shape[0])
    return _expand(_below(w, M, rng.random()), M)


def residual(weights, rng, M=None) -> np.ndarray:
    r"""Residual resampling (Liu & Chen 1998): deterministic copies, then a multinomial rest.

    .. math::

        N_i = \lfloor M W_i \rfloor + \tilde N_i, \qquad
        (\tilde N_i) \sim \mathrm{Mult}\Big(R;\ \frac{M W_i - \lfloor M W_i \rfloor}{R}\Big),
        \qquad R = M - \sum_i \lfloor M W_i \rfloor.

    Unbiased, :math:`E[N_i] = M W_i`, never below :math:`\lfloor M W_i
    \rfloor`, and never noisier than multinomial resampling (Douc, Cappé &
    Moulines 2005). filterpy 2.0.0's ``residual_resample`` draws the rest
    from ``weights - floor(N weights)`` instead of the residuals
    ``N weights - floor(N weights)`` (filterpy issue #290): negative numbers
    as soon as some :math:`N W_i \ge 1`, and a biased result; for
    W = (0.7, 0.1, 0.1, 0.1) it always returns [0, 0, 0, 0] instead of
    counts with mean (2.8, 0.4, 0.4, 0.4).

    Parameters
    ----------
    weights : array_like, shape (N,)
        Non-negative importance weights, not all zero; normalised internally.
    rng : numpy.random.Generator
        Source of randomness, e.g. ``np.random.default_rng(0)``.
    M : int, optional
        Number of indices to draw, >= 1; default N.

    Returns
    -------
    ndarray of intp, shape (M,)
        Ancestor indices in 0..N-1, sorted ascending.

    Raises
    ------
    ValueError
        If ``weights`` is not a non-empty vector of finite non-negative
        numbers with a positive sum, or M < 1.
    TypeError
        If ``rng`` is not a Generator or M is not an integer.
    """
    w, total = _weights(weights)
    rng = as_rng("rng", rng)
    M = _check_M(M, w.shape[0])
    # M W_i
    MW = (w / total) * M
    # floor(M W_i), read with a tolerance of a few ulps: with equal weights M W_i
    # should be 1 but comes out as 0.9999999999999999 for some i, and an exact
    # floor would leave those particles to the multinomial draw. The bias is
    # below 1e-13 M W_i. The total is a pairwise sum (relative error below
    # 40 eps even for N = 10^9), so the floors still add up to at most M.
    counts = np.floor(MW * (1.0 + 64 * np.finfo(float).eps))
    # R = M - sum_i floor(M W_i)
    R = M - int(counts.sum())
    if R > 0:
        # residuals M W_i - floor(M W_i) in [0, 1), summing to R (one that the
        # tolerance made negative, by less than 1e-13 M W_i, is clipped to 0)
        rest = np.maximum(MW - counts, 0.0)
        counts += rng.multinomial(R, rest / rest.sum())
    return _expand(np.cumsum(counts.astype(np.intp)), M)


SCHEMES = {
    "multinomial": multinomial,
    "stratified": stratified,
    "systematic": systematic,
    "residual": residual,
}
"""The four schemes by name, e.g. ``SCHEMES["systematic"](W, rng)``."""
