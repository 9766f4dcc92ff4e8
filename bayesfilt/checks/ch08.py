"""Checks of chapter 08's exercises (the unscented transform and the UKF; references by
bf.ukf). One line per exercise::

    exercise_1(points, mean_weights, cov_weights): the sigma points and weights of a 2-D
        Gaussian, by hand;
    exercise_2(ut_mean, ut_var, exact_var, beta): the unscented transform of x^2, and
        the beta that makes it exact;
    exercise_3(ut_variance, negative): the UT's variance of x^T x as a function of
        (alpha, beta, kappa), and the setting that makes it negative;
    exercise_4(ukf_update): the UKF's measurement update (sigma points, the UT's joint
        Gaussian, the gain K = Sigma_xy S^{-1}) as a function.
"""

from __future__ import annotations

import numpy as np
from scipy import linalg as sla

from .. import ukf
from . import (CORRECT, INCORRECT, Feedback, _combine, _frozen, _hinted, _named, _not_attempted, _wrong,
               compare_array, compare_choice, compare_function, compare_number, register as _register)

# the statements' numbers
M_1, P_1, PARAMS_1 = _frozen([1.0, 2.0]), _frozen([[4.0, 2.0], [2.0, 2.0]]), (0.5, 2.0, 6.0)
M_2, VAR_2 = 1.0, 0.5                                     # x ~ N(M_2, VAR_2), g(x) = x^2, alpha = 1, kappa = 0
N_3 = 4                                                   # g(x) = x^T x, x ~ N(0, I_4)
SETTINGS_3 = {"A": (1.0, 2.0, 0.0), "B": (1.0, 0.0, -1.0), "C": (0.5, 2.0, 0.0)}
# ex 3's test inputs: the three settings, then a wide one, a tilted one, and n + kappa = 0.5 (points close in)
CASES_3 = tuple(SETTINGS_3.values()) + ((2.0, 0.0, 1.0), (0.8, 1.0, 3.0), (1.5, 2.0, -3.5))
# ex 4: (x, P, y, h, R, alpha, beta, kappa). The road toy of section 1 with its setting (1, 0, 2); a range
# in 2-D with the defaults (W^c_0 = 2 != W^m_0 = 0); a linear h (the answer is the Kalman update) with a
# negative W^m_0; a 3-D state with two measurements and a negative W^c_0 = -0.5 (kappa = -1).


def _road(X):
    """The road toy's range sqrt(xi^2 + 4), (N, 1) -> (N, 1)."""
    return np.sqrt(X[..., :1] ** 2 + 4.0)


def _range(X):
    """The distance of a 2-D state from the origin, (N, 2) -> (N, 1)."""
    return np.hypot(X[..., 0], X[..., 1])[..., None]


_C_4 = _frozen([[1.0, 0.5], [0.0, 1.0]])


def _linear(X):
    """y = C x for a 2-D state, (N, 2) -> (N, 2)."""
    return X @ _C_4.T


def _range_and_square(X):
    """The range of (x_1, x_2) and x_3^2 / 2, (N, 3) -> (N, 2)."""
    return np.stack([np.hypot(X[..., 0], X[..., 1]), 0.5 * X[..., 2] ** 2], axis=-1)


CASES_4 = (
    (_frozen([1.0]), _frozen([[1.0]]), _frozen([2.5]), _road, _frozen([[0.1]]), 1.0, 0.0, 2.0),
    (_frozen([3.0, 4.0]), _frozen([[4.0, 1.0], [1.0, 2.0]]), _frozen([5.6]), _range, _frozen([[0.25]]),
     1.0, 2.0, 0.0),
    (_frozen([1.0, -1.0]), _frozen([[2.0, 0.3], [0.3, 1.0]]), _frozen([0.5, -2.0]), _linear,
     _frozen([[0.2, 0.0], [0.0, 0.3]]), 0.5, 2.0, 1.0),
    (_frozen([2.0, 1.0, 1.0]), _frozen([[1.0, 0.2, 0.0], [0.2, 0.5, 0.1], [0.0, 0.1, 0.3]]),
     _frozen([2.4, 0.8]), _range_and_square, _frozen([[0.1, 0.0], [0.0, 0.05]]), 1.0, 0.0, -1.0))


# Exercise 1: the sigma points and weights of a 2-D Gaussian, by hand ---------------------------------------------
def _points_1(factor=None, scale=None, order="section") -> np.ndarray:
    """Sigma points of N(M_1, P_1) along the columns of ``factor`` (default the lower Cholesky factor), at ``scale``
    (default sqrt(n + lambda)), in section 2's order or interleaved (+1, -1, +2, -2)."""
    n, (alpha, _, kappa) = 2, PARAMS_1
    L = np.linalg.cholesky(P_1) if factor is None else factor
    c = np.sqrt(alpha**2 * (n + kappa)) if scale is None else scale
    plus, minus = M_1 + c * L.T, M_1 - c * L.T
    if order == "interleaved":
        return np.vstack([M_1] + [row for pair in zip(plus, minus) for row in pair])
    return np.vstack([M_1, plus, minus])


def _same_rows(a: np.ndarray, e: np.ndarray) -> bool:
    """The same points in another order."""
    if a.shape != e.shape:
        return False
    return bool(np.allclose(a[np.lexsort(a.T[::-1])], e[np.lexsort(e.T[::-1])], rtol=1e-6, atol=1e-9))


def exercise_1(points, mean_weights, cov_weights) -> Feedback:
    """Check ``points_1`` (5, 2), ``mean_weights_1`` (5,), ``cov_weights_1`` (5,) against ``bf.ukf.sigma_points``."""
    ref = ukf.sigma_points(M_1, P_1, *PARAMS_1)
    alpha, beta, kappa = PARAMS_1
    L = np.linalg.cholesky(P_1)
    lam = alpha**2 * (2 + kappa) - 2
    point_mistakes = [
        (_points_1(factor=L.T), "you used the rows of L (the columns of the upper factor U = L^T, P = U^T U); "
                                "the points use the columns of the lower factor L (P = L L^T)."),
        (_points_1(factor=np.real(sla.sqrtm(P_1))), "you used the symmetric square root of P_1: its points have "
         "the same mean and covariance, but section 2's (and bf.ukf's, filterpy's) use the Cholesky factor L."),
        (_points_1(scale=1.0), "the outer points lack the factor sqrt(n + lambda~): they sit sqrt(n + lambda~) "
                               "standard deviations out along each column of L."),
        (_points_1(scale=lam + 2), "the columns of L are scaled by n + lambda~; the factor is its square root."),
        (_points_1(scale=np.sqrt(2 + kappa)), "the points use sqrt(n + kappa~); the scaled points use "
                                              "sqrt(n + lambda~) = alpha~ sqrt(n + kappa~)."),
        (_points_1(factor=np.asarray(P_1)), "you used the columns of P_1 itself; the points use the columns of its "
                                            "square root L (P = L L^T)."),
        (_points_1(order="interleaved"), "the right points in another order; section 2's order is m, then the two "
                                         "+ points, then the two - points."),
        (lambda a: _same_rows(a, ref.points), "the right points in another order; section 2's order is m, then "
                                              "m + ... L[:, 0], m + ... L[:, 1], then the same with -."),
    ]
    mean_mistakes = [
        (ref.cov_weights, "these are the covariance weights W^c; the mean weights W^m differ at the centre."),
        (np.r_[kappa / (2 + kappa), np.full(4, 0.5 / (2 + kappa))], "you used kappa~ in place of lambda~ = "
         "alpha~^2 (n + kappa~) - n (the unscaled points of Julier & Uhlmann)."),
        (lambda a: a.shape == (5,) and not np.isclose(a.sum(), 1.0), "the mean weights must sum to 1."),
    ]
    w0 = ref.mean_weights[0]
    cov_mistakes = [
        (ref.mean_weights, "these are the mean weights; the covariance weights add 1 - alpha~^2 + beta~ at the "
                           "centre: W^c_0 = W^m_0 + 1 - alpha~^2 + beta~."),
        (np.r_[w0 + beta, ref.cov_weights[1:]], "W^c_0 lacks the 1 - alpha~^2 of W^m_0 + 1 - alpha~^2 + beta~."),
        (np.r_[w0 + 1 + beta, ref.cov_weights[1:]], "W^c_0 lacks the - alpha~^2 of W^m_0 + 1 - alpha~^2 + beta~."),
        (np.r_[w0 + 1 - alpha + beta, ref.cov_weights[1:]], "W^c_0 has 1 - alpha~ + beta~; the term is "
                                                            "1 - alpha~^2 + beta~ (alpha~ squared)."),
        (np.r_[w0 + 1 - alpha**2, ref.cov_weights[1:]], "W^c_0 lacks beta~: W^c_0 = W^m_0 + 1 - alpha~^2 + beta~."),
    ]
    def named(answer, expected, what, mistakes):
        return _named(answer, expected, what, [(wrong, f"{what}: {message}") for wrong, message in mistakes])

    return _combine([
        ("points_1", named(points, ref.points, "points_1", point_mistakes)),
        ("mean_weights_1", named(mean_weights, ref.mean_weights, "mean_weights_1", mean_mistakes)),
        ("cov_weights_1", named(cov_weights, ref.cov_weights, "cov_weights_1", cov_mistakes))])


# Exercise 2: the unscented transform of x^2 ----------------------------------------------------------------------
def _number(answer, expected, what, mistakes) -> Feedback:
    """compare_number; an answer equal to a named wrong value gets that value's message."""
    fb = compare_number(answer, expected, what)
    if fb.status != INCORRECT or " must be " in fb.message or "NaN" in fb.message:
        return fb
    value = float(np.ravel(answer)[0]) if isinstance(answer, np.ndarray) else float(answer)
    for wrong, message in mistakes:
        if not np.isclose(wrong, expected) and np.isclose(value, wrong, rtol=1e-6, atol=1e-9):
            return _wrong(f"{what}: {message}")
    return fb


def exercise_2(ut_mean, ut_var, exact_var, beta) -> Feedback:
    """Check ``ut_mean_2``, ``ut_var_2`` (beta = 0), ``exact_var_2`` and ``beta_2`` against bf.ukf."""
    m, v, s = M_2, VAR_2, np.sqrt(VAR_2)
    ut = ukf.unscented_transform(lambda x: x**2, [m], [[v]], 1.0, 0.0, 0.0)
    # the exact variance of x^2: E[(2 m e + e^2 - v)^2] = 4 m^2 v + E[e^4] - v^2 = 4 m^2 v + 2 v^2
    exact = 4 * m**2 * v + 2 * v**2
    # beta enters the UT's variance as beta (Y_0 - y_hat)^2: the beta that closes the gap
    centre = (ut.images[0, 0] - ut.mean[0]) ** 2
    beta_ref = (exact - ut.cov[0, 0]) / centre
    at_variance = ukf.unscented_transform(lambda x: x**2, [m], [[v**2]], 1.0, 0.0, 0.0)  # points at m +- v
    return _combine([
        ("ut_mean_2", _number(ut_mean, ut.mean[0], "ut_mean_2", [
            (m**2, "that is g(m), the tangent's (EKF's) mean; the UT averages g over the three points."),
            (at_variance.mean[0], "the points sit at m +- sigma, sigma = sqrt(0.5), not at m +- 0.5 (the variance)."),
            ((m + s) ** 2, "that is g at one outer point; the UT's mean is the weighted average over all three.")])),
        ("ut_var_2", _number(ut_var, ut.cov[0, 0], "ut_var_2", [
            (0.5 * ((m + s) ** 4 + (m - s) ** 4), "that is the weighted mean of g^2, not the variance: take the "
                                                 "weighted mean of (Y_j - y_hat)^2."),
            (exact, "that is the exact variance (and the UT's with beta~ = 2); with beta~ = 0 the UT's is "
                    "smaller (the centre weight W^c_0 is 0)."),
            (at_variance.cov[0, 0], "the points sit at m +- sigma, sigma = sqrt(0.5), not at m +- 0.5.")])),
        ("exact_var_2", _number(exact_var, exact, "exact_var_2", [
            (4 * m**2 * v, "the 2 sigma^4 from E[(e^2 - sigma^2)^2] = E[e^4] - sigma^4 = 3 sigma^4 - sigma^4 is "
                           "missing."),
            (4 * m**2 * v + 3 * v**2, "E[(e^2 - sigma^2)^2] = E[e^4] - sigma^4 = 2 sigma^4, not 3 sigma^4."),
            (m**4 + 6 * m**2 * v + 3 * v**2, "that is E[x^4], the second moment of x^2; subtract (E[x^2])^2."),
            (4 * m**2 * v + v**2, "use E[e^4] = 3 sigma^4 for a Gaussian: E[(e^2 - sigma^2)^2] = 2 sigma^4.")])),
        ("beta_2", _number(beta, beta_ref, "beta_2", [
            (0.0, "with beta~ = 0 the UT's variance misses 2 sigma^4."),
            (3.0, "beta~ enters as beta~ (Y_0 - y_hat)^2 = beta~ sigma^4; the gap to the exact variance is "
                  "2 sigma^4.")]))])


# Exercise 3: the UT's variance of x^T x, and a negative weight --------------------------------------------------
def _ut_variance(alpha, beta, kappa) -> float:
    """The UT's variance of g(x) = x^T x for x ~ N(0, I_4), by bf.ukf."""
    g = lambda X: (X**2).sum(axis=-1)  # noqa: E731
    return float(ukf.unscented_transform(g, np.zeros(N_3), np.eye(N_3), alpha, beta, kappa).cov[0, 0])


def _variant_3(alpha, beta, kappa, centre="cov", outer=True, about="mean"):
    """The closed form W^c_0 n^2 + n (c^2 - n)^2 / c^2 (c^2 = n + lambda), or a mistake's variant."""
    n, c2 = N_3, alpha**2 * (N_3 + kappa)
    w0 = 1 - n / c2 + ((1 - alpha**2 + beta) if centre == "cov" else 0.0)
    if about == "zero":                                   # sum_j W^c_j Y_j^2: not centred
        return n * c2
    return w0 * n**2 + (n * (c2 - n) ** 2 / c2 if outer else 0.0)


def exercise_3(ut_variance, negative) -> Feedback:
    """Check ``ut_variance(alpha, beta, kappa)`` on CASES_3 against bf.ukf, and ``negative_3``."""
    quiet = _hinted(ut_variance, lambda exc, args: "")   # a failure that cannot even print itself
    fun = compare_function(quiet, _ut_variance, [tuple(c) for c in CASES_3], what="ut_variance",
                           compare=compare_number, mistakes=[
        (lambda a, b, k: _variant_3(a, b, k, centre="mean"), "the centre's term uses the mean weight W^m_0; the "
                                                             "variance uses W^c_0 = W^m_0 + 1 - alpha~^2 + beta~."),
        (lambda a, b, k: _variant_3(a, b, k, outer=False), "the 2n outer points' term n (n + lambda~ - n)^2 / "
                                                           "(n + lambda~) is missing."),
        (lambda a, b, k: _variant_3(a, b, k, about="zero"), "the squares are taken about 0, not about the mean "
                                                            "y_hat = n: centre the images first.")])
    variances = {k: _ut_variance(*v) for k, v in SETTINGS_3.items()}
    expected = next(k for k, v in variances.items() if v < 0)
    choice = compare_choice(negative, expected, list(SETTINGS_3), what="negative_3",
                            hint="evaluate your ut_variance at the three settings; only one has a negative "
                                 "centre weight W^c_0 together with a large centre term.")
    return _combine([("ut_variance", fun), ("negative_3", choice)])


# Exercise 4: the UKF's measurement update --------------------------------------------------------------------
def _update_4(x, P, y, h, R, alpha, beta, kappa) -> tuple:
    """bf.ukf.update's mean and covariance: the reference."""
    up = ukf.update(x, P, y, h, R, alpha, beta, kappa)
    return up.mean, up.cov


def _variant_4(x, P, y, h, R, alpha, beta, kappa, weights="cov", noise=True, centre="mean",
               cross="centred", sign=-1.0) -> tuple:
    """The direct update K = Sigma_xy S^{-1}, or a named mistake's variant of it."""
    sp = ukf.sigma_points(x, P, alpha, beta, kappa)
    X, wm = sp.points, sp.mean_weights
    wc = sp.cov_weights if weights == "cov" else wm
    Y = np.asarray(h(X.copy()), float)
    y_hat = wm @ Y if centre == "mean" else np.asarray(h(np.asarray(x, float)[None, :]), float)[0]
    dY = Y - y_hat
    S = (wc * dY.T) @ dY + (np.asarray(R) if noise else 0.0)
    dX = X - (np.asarray(x, float) if cross == "centred" else 0.0)
    Sxy = (wc * dX.T) @ dY
    K = np.linalg.solve(S, Sxy.T).T
    return np.asarray(x, float) + K @ (np.asarray(y, float) - y_hat), np.asarray(P) + sign * K @ S @ K.T


def _mean_and_cov(out, expected, what="the output", rtol=1e-6, atol=1e-9) -> Feedback:
    """A pair (mean (n,), cov (n, n)) compared entry by entry with the reference pair."""
    if out is None:
        return _not_attempted(what)
    if not isinstance(out, (tuple, list)) or len(out) != 2:
        size = f" of length {len(out)}" if isinstance(out, (tuple, list)) else ""
        return _wrong(f"{what} must be a pair (mean, cov), got {type(out).__name__}{size}.")
    for part, answer, exp in (("mean", out[0], expected[0]), ("covariance", out[1], expected[1])):
        fb = compare_array(answer, exp, what=f"the {part} in {what}", rtol=rtol, atol=atol)
        if not fb.correct:
            return fb
    return Feedback(CORRECT, f"{what} matches the reference.")


def exercise_4(ukf_update) -> Feedback:
    """Check ``ukf_update(x, P, y, h, R, alpha, beta, kappa)`` on CASES_4 against bf.ukf.update."""
    quiet = _hinted(ukf_update, lambda exc, args: "")  # a failure that cannot even print itself

    def variant(**kw):
        return lambda *args: _variant_4(*args, **kw)

    return compare_function(quiet, _update_4, [tuple(c) for c in CASES_4], what="ukf_update",
                            compare=_mean_and_cov, mistakes=[
        (variant(weights="mean"), "Sigma_yy and Sigma_xy use the covariance weights W^c (W^c_0 = W^m_0 + "
                                  "1 - alpha~^2 + beta~), not the mean weights W^m."),
        (variant(noise=False), "S_t = Sigma_yy + R: the measurement noise R is missing from S_t."),
        (variant(centre="tangent"), "y_hat is the weighted mean of the images h(X_j), not h at the mean (the "
                                    "tangent's prediction of chapter 04)."),
        (variant(cross="raw"), "Sigma_xy uses the deviations X_j - x_hat of the points from the mean, not the "
                               "points themselves."),
        (variant(sign=1.0), "the update lowers the covariance: P_{t|t} = P_{t|t-1} - K S K^T.")])


_register(globals())
