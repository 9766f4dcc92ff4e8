r"""Quiet checks: one line after a derivation that says what agreed.

Every derivation in the course is followed by a numerical check against an
independent reference (a simulation, brute force, another formula, filterpy).
In a chapter that check is one call to this module::

    import bayesfilt as bf
    bf.verify.agree("the prediction agrees with brute force", prior, brute)
    bf.verify.mc_moments("100 000 simulated x_1 agree with the recursion", draws, mean, cov)
    # prints: ✓ the prediction agrees with brute force
    #         ✓ 100 000 simulated x_1 agree with the recursion

Each function prints one short, plain line when the comparison holds,
``✓`` and the label, and raises ``AssertionError`` with a message that says
what differed when it does not. The numbers behind the tick (the tolerance,
or how many standard errors the estimate is from the exact value and the
limit) are kept, not printed: :func:`report` prints them all, once, in a
chapter's optional section "How the checks were calibrated". Several checks
that make one point print one line together::

    with bf.verify.together("the update agrees with Theorem 10.2"):
        bf.verify.agree("posterior mean", step.mean, theorem.mean)
        bf.verify.agree("posterior covariance", step.cov, theorem.cov)

There are two kinds of comparison.

**Exact up to rounding** (:func:`agree`, :func:`within`). Two computations of
the same number; the tolerance is a bound on floating-point round-off, and
the recorded detail gives the bound, not the raw difference, so that the
output does not depend on the last bits of the arithmetic.

**Monte Carlo** (:func:`mc_mean`, :func:`mc_moments`, :func:`mc_frequencies`).
An estimate from :math:`M` independent draws is compared with the exact value
in standard errors (SE). A check must not raise a false alarm for any seed, so
the limit is chosen from the failure probability, not by hand: with ``k``
entries compared at once, each one is allowed

.. math:: z_k = \Phi^{-1}\!\left(1 - \frac{\alpha}{2k}\right) \quad\text{SE},
   \qquad \alpha = 10^{-4},

so that, by the union bound, a correct result fails with probability below
:math:`\alpha` whatever the seed (:func:`z_limit`; :math:`z_1 = 3.9`,
:math:`z_{100} = 5.0`). For :func:`mc_mean` and :func:`mc_frequencies` the
standard error is that of a normal approximation (central limit theorem),
accurate for the sample sizes the chapters use (thousands of draws, no
category expected less than a few times; an entry whose exact SE is zero,
such as the frequency of an impossible cell, must match exactly).
:func:`mc_moments` needs no approximation: for Gaussian draws its limits are
exact quantiles or proven bounds (its notes). A wrong derivation is
typically off by many SE and fails.

Where the normal approximation is not good enough (skewed variables, such as
importance weights or squared deviations, whose sample means have heavier
tails than a normal's at :math:`z_k`), a bounded variable has limits that hold
for every sample size: **Bernstein's inequality** (:func:`bernstein_limits`,
:func:`mc_bounded`). For the mean :math:`\bar h` of :math:`n` independent
draws of a variable with mean :math:`\mu`, standard deviation :math:`\sigma`
and :math:`h - \mu \le b`,

.. math:: P(\bar h - \mu \ge \varepsilon) \le
   \exp\!\Big(-\frac{n \varepsilon^2}{2\sigma^2 + 2 b \varepsilon / 3}\Big),

so with :math:`L = \log(2k/\alpha)` each side's limit is
:math:`\varepsilon(b) = \frac{bL}{3n} + \sqrt{(\frac{bL}{3n})^2 + \frac{2\sigma^2 L}{n}}`
and ``k`` comparisons fail together with probability below :math:`\alpha`,
for any :math:`n` and without an approximation. The limits are wider than the
normal ones: that is their price.
"""

from __future__ import annotations

import contextlib
from statistics import NormalDist

import numpy as np

__all__ = ["z_limit", "agree", "within", "mean_se", "mc_mean", "mc_moments", "mc_frequencies",
           "bernstein_limits", "mc_bounded", "quadratic_form_limits", "mc_quadratic_form",
           "together", "report", "forget"]

ALPHA = 1e-4
"""Largest probability that a Monte Carlo check fails on a correct result."""


_DETAILS: dict[str, str] = {}
"""label -> what the check measured (its tolerance or SE), in the order first checked."""

_GROUPS: list[list[str]] = []
"""Open :func:`together` blocks, innermost last: the labels checked inside each."""


def _passed(label: str, detail: str) -> None:
    """Record a passed check's detail; print its tick unless a :func:`together` block is open."""
    _DETAILS[label] = detail
    if _GROUPS:
        _GROUPS[-1].append(label)
    else:
        print(f"\u2713 {label}")


@contextlib.contextmanager
def together(label: str):
    """Run several checks that make one point, and print one line for all of them.

    Parameters
    ----------
    label : str
        The point they make, printed as ``✓ label`` once every check in the
        block has passed. Each check's own detail is recorded under its own
        label, for :func:`report`.

    Raises
    ------
    AssertionError
        From the first check in the block that fails (nothing is printed).
    ValueError
        If the block ran no check.
    """
    _GROUPS.append([])
    try:
        yield
        inner = _GROUPS[-1]
    finally:
        _GROUPS.pop()
    if not inner:
        raise ValueError(f"together({label!r}): the block ran no check")
    if _GROUPS:
        _GROUPS[-1].extend(inner)
    else:
        print(f"\u2713 {label}")


def report(labels=None) -> None:
    """Print what every passed check measured: its tolerance, or its distance in SE.

    Parameters
    ----------
    labels : sequence of str, optional
        The labels to report, in this order; by default every check passed so
        far in this session, in the order first checked.

    Raises
    ------
    KeyError
        If a requested label was never checked.
    """
    for label in _DETAILS if labels is None else labels:
        if label not in _DETAILS:
            raise KeyError(f"labels: no check named {label!r} has passed in this session")
        print(f"{label}: {_DETAILS[label]}")


def forget() -> None:
    """Clear the record that :func:`report` prints (a test starts from an empty one)."""
    _DETAILS.clear()


def z_limit(k: int = 1, alpha: float = ALPHA, dof: int | None = None) -> float:
    r"""Allowed deviation in SE when ``k`` entries are compared at once.

    Parameters
    ----------
    k : int
        Number of entries compared (>= 1).
    alpha : float
        Largest false-alarm probability of the whole comparison, in (0, 1).
    dof : int, optional
        When the SE is itself estimated from ``M`` draws, ``M - 1``: the
        quantile is then Student's t with ``dof`` degrees of freedom, which
        has heavier tails than the normal (at ``M = 100`` and ``k = 1``:
        4.07 instead of 3.89).

    Returns
    -------
    float
        :math:`\Phi^{-1}(1 - \alpha / (2k))` (or the t quantile), two-sided,
        union bound over ``k``.
    """
    if int(k) != k or k < 1:
        raise ValueError(f"k: expected a positive integer (entries compared), got {k!r}")
    if not 0 < alpha < 1:
        raise ValueError(f"alpha: expected a probability in (0, 1), got {alpha!r}")
    if dof is None:
        return NormalDist().inv_cdf(1 - alpha / (2 * int(k)))
    if int(dof) != dof or dof < 1:
        raise ValueError(f"dof: expected a positive integer (draws - 1), got {dof!r}")
    from scipy.stats import t as student_t
    return float(student_t.isf(alpha / (2 * int(k)), int(dof)))


def _same_shape(label, got, expected):
    got = np.asarray(got, dtype=float)
    expected = np.asarray(expected, dtype=float)
    if got.shape != expected.shape:
        raise ValueError(f"{label}: got has shape {got.shape} but expected has shape {expected.shape}; "
                         "compare arrays of the same shape (no broadcasting)")
    return got, expected


def _fmt_tol(tol: float) -> str:
    exponent = np.log10(tol)
    return f"1e{round(exponent)}" if abs(exponent - round(exponent)) < 1e-9 else f"{tol:.1e}"


def agree(label: str, got, expected, tol: float = 1e-12, relative: bool = False) -> None:
    r"""Check that two computations of the same array agree up to rounding.

    Parameters
    ----------
    label : str
        What is compared, e.g. ``"prediction vs. brute force"``.
    got, expected : array_like, same shape
        The two computations. NaN anywhere fails.
    tol : float
        Bound on ``max |got - expected|`` (or on the relative difference,
        ``max |got - expected| / max |expected|``, if ``relative``).
    relative : bool
        Compare relative to the largest ``|expected|``.

    Raises
    ------
    AssertionError
        If the difference reaches ``tol`` or an entry is not finite.
    """
    got, expected = _same_shape(label, got, expected)
    if not (np.isfinite(got).all() and np.isfinite(expected).all()):
        raise AssertionError(f"{label}: an entry is NaN or infinite")
    diff = float(np.max(np.abs(got - expected), initial=0.0))
    what = "max |difference|"
    if relative:
        scale = float(np.max(np.abs(expected), initial=0.0))
        diff = diff / scale if scale > 0 else diff
        what = "max relative difference"
    if not diff < tol:
        raise AssertionError(f"{label}: {what} is {diff:.2e}, not below {tol:.0e}")
    _passed(label, f"{what} < {_fmt_tol(tol)}")


def within(label: str, value, low: float, high: float, unit: str = "") -> None:
    """Check that every entry of ``value`` lies in ``[low, high]``.

    Parameters
    ----------
    label : str
        What is checked.
    value : array_like
        Number(s) to check; NaN fails.
    low, high : float
        The closed interval.
    unit : str
        Appended to the recorded numbers, e.g. ``" m"``.
    """
    value = np.asarray(value, dtype=float)
    if not low <= high:
        raise ValueError(f"low, high: expected low <= high, got {low!r} > {high!r}")
    if np.isnan(value).any():
        raise AssertionError(f"{label}: a value is NaN")
    if value.min() < low or value.max() > high:
        raise AssertionError(f"{label}: values from {value.min():.4g} to {value.max():.4g}{unit}, "
                             f"outside [{low:.4g}, {high:.4g}]{unit}")
    _passed(label, f"in [{low:.4g}, {high:.4g}]{unit}")


def mean_se(values, axis: int = 0):
    r"""Sample mean of independent values and its standard error.

    Parameters
    ----------
    values : array_like, shape (M, ...)
        ``M`` >= 2 independent draws along ``axis``.
    axis : int
        The axis of the draws.

    Returns
    -------
    mean, se : ndarray, shape (...)
        The mean and :math:`s / \sqrt M`, with ``s`` the sample standard deviation.
    """
    values = np.asarray(values, dtype=float)
    M = values.shape[axis]
    if M < 2:
        raise ValueError(f"values: expected at least 2 draws along axis {axis}, got {M}")
    return values.mean(axis=axis), values.std(axis=axis, ddof=1) / np.sqrt(M)


def _in_se(label, gap, se):
    """Largest |gap| / se; an entry with se = 0 must match exactly."""
    gap, se = np.abs(np.asarray(gap, dtype=float)), np.asarray(se, dtype=float)
    if np.isnan(gap).any():
        raise AssertionError(f"{label}: an estimate is NaN")
    exact = se == 0
    if (gap[exact] > 0).any():
        raise AssertionError(f"{label}: an entry with standard error 0 (nothing random) differs "
                             f"from its exact value by {gap[exact].max():.3g}")
    return float(np.max(np.where(exact, 0.0, gap / np.where(exact, 1.0, se)), initial=0.0))


def _report(label, worst, k, z, what):
    if not worst <= z:
        raise AssertionError(f"{label}: {what} is {worst:.1f} standard errors from the exact value; "
                             f"a correct result exceeds {z:.1f} SE with probability < {ALPHA:.0e}")
    _passed(label, f"within {worst:.1f} SE of the exact value (limit {z:.1f} SE, {k} entries)")


def mc_mean(label: str, values, expected) -> None:
    r"""Check a Monte Carlo mean against its exact value.

    Parameters
    ----------
    label : str
        What is compared.
    values : array_like, shape (M, ...)
        ``M`` independent draws of a quantity whose exact mean is ``expected``.
    expected : array_like, shape (...)
        The exact mean.

    Notes
    -----
    Each entry's SE is estimated from the ``M`` draws (:func:`mean_se`), so
    the limit is :func:`z_limit` of the number of entries with Student's t
    quantile for ``M - 1`` degrees of freedom (exact for Gaussian values, and
    close to the normal one from a few hundred draws on).
    """
    mean, se = mean_se(values)
    mean, expected = _same_shape(label, mean, expected)
    k = max(mean.size, 1)
    z = z_limit(k, dof=np.shape(values)[0] - 1)
    _report(label, _in_se(label, mean - expected, se), k, z, "a sample mean")


def _covariance_limits(cov: np.ndarray, M: int, t: float):
    r"""Limits (low, high) on ``S - cov`` for the sample covariance S of M Gaussian draws.

    ``(M - 1) (S_ij - P_ij)`` is a sum Q of ``M - 1`` independent terms
    :math:`\lambda_+ (g^2 - 1) + \lambda_- (h^2 - 1)`, g and h standard normal,
    :math:`\lambda_\pm = (P_{ij} \pm \sqrt{P_{ii} P_{jj}})/2` (the eigenvalues of
    A P for :math:`A = (e_i e_j^T + e_j e_i^T)/2`). Each term's log moment
    generating function is at most :math:`s^2 \lambda^2 / (1 - 2 s \lambda_+)`, so
    (Laurent & Massart 2000, Lemma 1, whose proof covers coefficients of both
    signs) :math:`P(Q \ge 2\|a\|\sqrt t + 2\lambda_+ t) \le e^{-t}` and
    :math:`P(Q \le -2\|a\|\sqrt t - 2|\lambda_-| t) \le e^{-t}`, with
    :math:`\|a\|^2 = (M - 1)(\lambda_+^2 + \lambda_-^2)`.
    """
    n = M - 1
    diag = np.diag(cov)
    root = np.sqrt(np.outer(diag, diag))
    plus, minus = (cov + root) / 2, np.abs(cov - root) / 2   # lambda_+ >= 0, |lambda_-|
    norm = np.sqrt(n * (plus**2 + minus**2))                  # ||a||
    # Q >= 2 ||a|| sqrt(t) + 2 lambda_+ t, Q <= -2 ||a|| sqrt(t) - 2 |lambda_-| t: each e^{-t}
    return -(2 * norm * np.sqrt(t) + 2 * minus * t) / n, (2 * norm * np.sqrt(t) + 2 * plus * t) / n


def mc_moments(label: str, draws, mean, cov) -> None:
    r"""Check the sample mean and covariance of Gaussian draws against theory.

    Parameters
    ----------
    label : str
        What is compared.
    draws : array_like, shape (M, d)
        ``M`` independent draws of :math:`N(m, P)`.
    mean : array_like, shape (d,)
        The exact mean m.
    cov : array_like, shape (d, d)
        The exact covariance :math:`P`.

    Notes
    -----
    The ``k = d + d (d + 1) / 2`` entries (means and the upper triangle of
    the sample covariance, ``np.cov``'s, with ``M - 1``) share the false-alarm
    probability ``ALPHA`` by the union bound, ``ALPHA / (2k)`` on each
    side of each entry, and every limit is exact or a proven bound for
    Gaussian draws, with no normal approximation:

    * a sample mean is exactly :math:`N(m_i, P_{ii}/M)`: its limit is
      :func:`z_limit` of ``k`` entries standard errors;
    * a sample variance is a scaled chi-square, :math:`P_{ii}\chi^2_{M-1}/(M-1)`,
      whose upper tail is heavier than a normal's: its limits are the exact
      chi-square quantiles;
    * an off-diagonal sample covariance has chi-square-like tails too: its
      limits are Laurent & Massart's (2000) bounds for sums of
      :math:`\lambda(g^2 - 1)` (``_covariance_limits``), a little wider
      (about 5 SE where a normal would allow 4.4 to 4.6).

    The recorded detail gives the largest deviation in standard errors,
    :math:`\sqrt{P_{ii}/M}` for a mean and :math:`\sqrt{(P_{ii}P_{jj} + P_{ij}^2)/(M-1)}`
    for a covariance entry (exact for Gaussian draws), and the limits.
    """
    draws = np.asarray(draws, dtype=float)
    if draws.ndim != 2:
        raise ValueError(f"draws: expected shape (M, d), got {draws.shape}")
    M, d = draws.shape
    if M < 3:
        raise ValueError(f"draws: expected at least 3 draws, got {M}")
    mean = np.asarray(mean, dtype=float)
    cov = np.asarray(cov, dtype=float)
    if mean.shape != (d,) or cov.shape != (d, d):
        raise ValueError(f"mean, cov: expected shapes ({d},) and ({d}, {d}) for draws of shape "
                         f"{draws.shape}, got {mean.shape} and {cov.shape}")
    diag = np.diag(cov)
    iu = np.triu_indices(d)
    k = d + len(iu[0])
    z = z_limit(k)
    gap_m = draws.mean(axis=0) - mean
    gap_c = (np.atleast_2d(np.cov(draws.T)) - cov)[iu]
    se_m = np.sqrt(diag / M)
    se_c = np.sqrt((np.outer(diag, diag) + cov**2) / (M - 1))[iu]
    low, high = _covariance_limits(cov, M, np.log(2 * k / ALPHA))
    # a variance entry: (M - 1) S_ii / P_ii is chi-square with M - 1 degrees of freedom, so its
    # limits are exact quantiles (the bound above is for the off-diagonal entries)
    from scipy.stats import chi2
    q_low, q_high = chi2.ppf(ALPHA / (2 * k), M - 1), chi2.isf(ALPHA / (2 * k), M - 1)
    i = np.arange(d)
    low[i, i], high[i, i] = diag * (q_low / (M - 1) - 1), diag * (q_high / (M - 1) - 1)
    low, high = low[iu], high[iu]
    if np.isnan(gap_m).any() or np.isnan(gap_c).any():
        raise AssertionError(f"{label}: an estimate is NaN")
    worst = _in_se(label, np.concatenate([gap_m, gap_c]), np.concatenate([se_m, se_c]))
    exact = se_c == 0                 # a zero-variance entry: its sample covariance is exact
    bad_m = np.abs(gap_m) > z * se_m
    bad_c = ~exact & ((gap_c < low) | (gap_c > high))
    if bad_m.any() or bad_c.any():
        what = "a sample mean" if bad_m.any() else "a sample covariance entry"
        raise AssertionError(f"{label}: {what} is beyond its limit ({worst:.1f} standard errors "
                             f"from the exact value); a correct result goes beyond it with "
                             f"probability < {ALPHA:.0e}")
    c_lim = np.where(exact, np.nan, np.maximum(high, -low) / np.where(exact, 1.0, se_c))
    _passed(label, f"within {worst:.1f} SE of the exact value (limits {z:.1f} SE for a mean, "
                   f"up to {np.nanmax(c_lim, initial=z):.1f} SE for a covariance; {k} entries)")


def bernstein_limits(values, probs, n: int, k: int = 1, alpha: float = ALPHA):
    r"""Limits for the mean of ``n`` draws of a bounded variable, minus its exact mean.

    Parameters
    ----------
    values : array_like, shape (K,)
        The values h the variable takes (a discrete support, or a fine
        quadrature grid of a continuous variable).
    probs : array_like, shape (K,)
        Their probabilities (a probability mass function, or the density times
        the grid's cell width); they must sum to 1 within 1e-6 and are
        normalised.
    n : int
        Number of independent draws averaged.
    k : int
        Number of comparisons made at once (union bound).
    alpha : float
        Largest false-alarm probability of the ``k`` comparisons together.

    Returns
    -------
    low, high : float
        A correct sample mean minus the exact mean falls below ``low`` (or above
        ``high``) with probability below ``alpha / (2 k)``, by Bernstein's
        inequality (module docstring), for any ``n``.
    """
    values = np.asarray(values, dtype=float)
    probs = np.asarray(probs, dtype=float)
    if values.ndim != 1 or probs.shape != values.shape:
        raise ValueError(f"values, probs: expected two 1-D arrays of one length, got shapes "
                         f"{values.shape} and {probs.shape}")
    if not (np.isfinite(values).all() and np.isfinite(probs).all()) or (probs < 0).any():
        raise ValueError("values, probs: expected finite values and non-negative probabilities")
    if abs(probs.sum() - 1.0) > 1e-6:
        raise ValueError(f"probs: expected probabilities summing to 1 (within 1e-6), got a "
                         f"sum of {probs.sum():.8g}")
    if int(n) != n or n < 1:
        raise ValueError(f"n: expected a positive integer (draws averaged), got {n!r}")
    if int(k) != k or k < 1:
        raise ValueError(f"k: expected a positive integer (comparisons), got {k!r}")
    probs = probs / probs.sum()
    support = probs > 0
    mean = float(probs @ values)
    sd = float(np.sqrt(probs @ (values - mean) ** 2))
    L = np.log(2 * k / alpha)

    def eps(b):
        # epsilon(b) = b L / (3 n) + sqrt((b L / (3 n))^2 + 2 sigma^2 L / n)
        return b * L / (3 * n) + np.sqrt((b * L / (3 * n)) ** 2 + 2 * sd**2 * L / n)

    return (-float(eps(mean - values[support].min())),
            float(eps(values[support].max() - mean)))


def mc_bounded(label: str, draws, values, probs, k: int = 1) -> None:
    r"""Check the mean of draws of a bounded variable by Bernstein's inequality.

    Parameters
    ----------
    label : str
        What is compared.
    draws : array_like, shape (n,)
        ``n`` independent draws of the variable.
    values, probs : array_like, shape (K,)
        The values it can take and their probabilities (or a quadrature grid):
        see :func:`bernstein_limits`; the exact mean is ``probs @ values``.
    k : int
        Number of comparisons made at once, for the union bound (this check
        counts as one of them).

    Notes
    -----
    No normal approximation: a correct result fails with probability below
    ``ALPHA / k`` for any number of draws (module docstring).
    """
    draws = np.asarray(draws, dtype=float)
    if draws.ndim != 1 or draws.size < 1:
        raise ValueError(f"draws: expected a 1-D array of draws, got shape {draws.shape}")
    low, high = bernstein_limits(values, probs, draws.size, k)
    probs = np.asarray(probs, dtype=float)
    gap = float(draws.mean() - (probs / probs.sum()) @ np.asarray(values, dtype=float))
    if np.isnan(gap) or not low <= gap <= high:
        raise AssertionError(f"{label}: the sample mean is {gap:+.4g} from the exact mean, outside "
                             f"Bernstein's limits [{low:.4g}, {high:.4g}]; a correct result falls "
                             f"outside with probability < {ALPHA / k:.0e}")
    _passed(label, f"{gap:+.3g} from the exact mean, inside Bernstein's limits "
                   f"[{low:.3g}, {high:.3g}] ({k} comparisons)")


def quadratic_form_limits(weights, k: int = 1, alpha: float = ALPHA):
    r"""Limits for a sum of weighted chi-square variables, minus its mean.

    For :math:`Q = \sum_i a_i g_i^2` with independent standard normal
    :math:`g_i` and weights :math:`a_i \ge 0` (e.g. a sum of NEES values of a
    consistent linear-Gaussian filter: a quadratic form in Gaussian errors,
    whose weights are the eigenvalues of the errors' whitened joint
    covariance), Laurent & Massart (2000, Lemma 1) give

    .. math:: P\big(Q - \textstyle\sum a_i \ge 2\|a\|\sqrt t + 2\max a_i\, t\big)
       \le e^{-t}, \qquad P\big(Q - \textstyle\sum a_i \le -2\|a\|\sqrt t\big) \le e^{-t},

    with no approximation: here :math:`e^{-t} = \alpha / (2k)`.

    Parameters
    ----------
    weights : array_like, shape (K,)
        The weights :math:`a_i \ge 0`.
    k : int
        Number of comparisons made at once (union bound).
    alpha : float
        Largest false-alarm probability of the ``k`` comparisons together.

    Returns
    -------
    low, high : float
        Limits on :math:`Q - \sum_i a_i`.
    """
    a = np.asarray(weights, dtype=float).ravel()
    if a.size < 1 or not np.isfinite(a).all() or (a < 0).any():
        raise ValueError(f"weights: expected a non-empty array of finite non-negative weights, got "
                         f"shape {a.shape}" + (f", smallest {a.min():.3g}" if a.size else ""))
    if int(k) != k or k < 1:
        raise ValueError(f"k: expected a positive integer (comparisons), got {k!r}")
    t = np.log(2 * k / alpha)
    norm = float(np.sqrt(a @ a))
    # Q - sum a >= 2 ||a|| sqrt(t) + 2 max(a) t  and  Q - sum a <= -2 ||a|| sqrt(t): each e^{-t}
    return -2 * norm * np.sqrt(t), 2 * norm * np.sqrt(t) + 2 * float(a.max()) * t


def mc_quadratic_form(label: str, value: float, weights, k: int = 1) -> None:
    r"""Check an observed sum of weighted chi-square variables against its law.

    Parameters
    ----------
    label : str
        What is compared.
    value : float
        The observed :math:`Q = \sum_i a_i g_i^2` (e.g. the sum of all NEES
        values of many independent runs).
    weights : array_like, shape (K,)
        Its weights :math:`a_i \ge 0` (:func:`quadratic_form_limits`); the
        mean of ``value`` is their sum.
    k : int
        Number of comparisons made at once (union bound).

    Notes
    -----
    A proven bound, with no normal approximation: skewed sums (a few runs of
    large NEES) are covered, where a t-test on per-run averages fails a
    little more often than it claims.
    """
    low, high = quadratic_form_limits(weights, k)
    mean = float(np.sum(weights))
    gap = float(value) - mean
    if np.isnan(gap) or not low <= gap <= high:
        raise AssertionError(f"{label}: the sum is {value:.6g} where its mean is {mean:.6g}, outside "
                             f"the limits [{mean + low:.6g}, {mean + high:.6g}]; a correct result "
                             f"falls outside with probability < {ALPHA / k:.0e}")
    se = float(np.sqrt(2 * np.sum(np.asarray(weights, dtype=float) ** 2)))
    _passed(label, f"{gap / se:+.1f} SE from its mean, inside the chi-square limits "
                   f"[{low / se:.1f}, {high / se:+.1f}] SE ({k} comparisons)")


def mc_frequencies(label: str, draws, probs) -> None:
    r"""Check how often each category was drawn against its exact probability.

    Parameters
    ----------
    label : str
        What is compared.
    draws : array_like of int, shape (M,)
        ``M`` independent draws of a category in ``0 .. K-1``.
    probs : array_like, shape (K,)
        The exact probabilities.

    Notes
    -----
    The SE of a frequency is the binomial :math:`\sqrt{p (1 - p) / M}`; a
    category of probability 0 (or 1) must be drawn never (always).
    """
    draws = np.asarray(draws)
    probs = np.asarray(probs, dtype=float)
    if draws.ndim != 1 or not np.issubdtype(draws.dtype, np.integer):
        raise ValueError(f"draws: expected a 1-D array of integer categories, got shape {draws.shape}, "
                         f"dtype {draws.dtype}")
    if probs.ndim != 1 or draws.size and (draws.min() < 0 or draws.max() >= probs.size):
        raise ValueError(f"draws: expected categories in 0..{probs.size - 1} (the length of probs), "
                         f"got {draws.min()}..{draws.max()}")
    M = draws.size
    freq = np.bincount(draws, minlength=probs.size) / M
    se = np.sqrt(probs * (1 - probs) / M)
    k = probs.size
    _report(label, _in_se(label, freq - probs, se), k, z_limit(k), "a frequency")
