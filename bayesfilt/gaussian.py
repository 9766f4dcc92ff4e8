r"""Gaussian vectors: conditioning, densities, sampling and consistency tests.

The Kalman filter is one fact about Gaussians applied over and over: if
:math:`x` and :math:`y` are jointly Gaussian, then :math:`x` given
:math:`y` is Gaussian again, with a mean that is linear in :math:`y` and a
covariance that does not depend on :math:`y` at all (Kay's Theorem 10.2,
quoted in seed 000, section 2). This module holds that fact and the few
tools the course needs around it. Import it as ``bf.gaussian``::

    import numpy as np
    import bayesfilt as bf

    # x ~ N(0, 1) measured once with noise variance 0.5: y = x + v
    post = bf.gaussian.condition(mean_x=[0.0], mean_y=[0.0], cov_xx=[[1.0]],
                                 cov_xy=[[1.0]], cov_yy=[[1.5]], y=[0.9])
    post.mean, post.cov          # (0.6,), ((0.3333,),)

    # Log-density of one point (n,) or of many points (N, n)
    bf.gaussian.logpdf([0.1, 0.2], mean=np.zeros(2), cov=np.eye(2))

    # Draws, also from a singular (positive semi-definite) covariance
    xs = bf.gaussian.sample(np.random.default_rng(0), np.zeros(2),
                            [[1.0, 1.0], [1.0, 1.0]], size=1000)

    # Consistency of a filter: NEES of the estimation errors (T, n) with the
    # filter's covariances (T, n, n), and the 95 % interval of one value
    # (n_runs = 1) or of the average over n_runs Monte Carlo runs
    model = bf.models.damped_particle()
    xs, ys = bf.models.simulate(model, 100, np.random.default_rng(1))
    res = bf.kalman.kalman_filter(model, ys)
    nees = bf.gaussian.squared_mahalanobis(xs - res.means, res.covs)   # (100,)
    low, high = bf.gaussian.chi2_interval(dof=4, n_runs=1)

    # ... and whiteness of the innovations: the autocorrelation of the normalised
    # innovations at lags 1..20, about 95 % of it inside +-1.96 / sqrt(T)
    z = bf.gaussian.normalised_innovations(res.innovations, res.innovation_covs)  # (100, 2)
    acf = bf.gaussian.autocorrelation(z, max_lag=20)                              # (20, 2)
    band = 1.96 / np.sqrt(len(z))

(With missing measurements, select the observed rows first:
``res.innovations[res.observed]``, ``res.innovation_covs[res.observed]``.
A partly-observed row has values only in its observed components
``res.observed_components[t]``: keep the fully observed rows,
``res.observed_components.all(axis=-1)``, or the observed block of each row,
whose NIS has as many degrees of freedom as it has components.)

Conditioning (seed 000, Theorem 10.2, eqs. (10.24)-(10.25)). Kay states
the theorem for :math:`y` given :math:`x`; the Kalman update needs it with
the roles swapped, which is what :func:`condition` computes:

.. math::

    E(x \mid y) = E(x) + C_{xy} C_{yy}^{-1} (y - E(y)), \qquad
    C_{x \mid y} = C_{xx} - C_{xy} C_{yy}^{-1} C_{yx}.

Numerics. :math:`C_{yy}^{-1}` is never formed: a Cholesky factor of
:math:`C_{yy}` is used to *solve* the linear systems, which is cheaper and
more accurate than inverting, and fails loudly if :math:`C_{yy}` is not
positive definite.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from scipy import linalg as sla
from scipy import stats
from scipy.linalg.lapack import dtrtri as _dtrtri
from scipy.linalg.lapack import dtrtrs as _dtrtrs

from ._checks import (as_array, as_covariance, as_int, as_matrix, as_rng, as_square, as_vector)

__all__ = [
    "Gaussian",
    "condition",
    "logpdf",
    "sample",
    "squared_mahalanobis",
    "chi2_interval",
    "normalised_innovations",
    "autocorrelation",
    "Interval",
]

LOG_2PI = np.log(2.0 * np.pi)


class Interval(NamedTuple):
    """A two-sided interval ``(low, high)``."""

    low: float
    high: float


class Gaussian(NamedTuple):
    """A Gaussian distribution: ``mean`` (n,) and ``cov`` (n, n). Unpacks as ``m, P``."""

    mean: np.ndarray
    cov: np.ndarray


def _cholesky(name: str, cov: np.ndarray) -> np.ndarray:
    """Lower Cholesky factor of ``cov``; ValueError naming ``name`` if not positive definite."""
    try:
        return np.linalg.cholesky(cov)
    except np.linalg.LinAlgError:
        eig_min = float(np.linalg.eigvalsh(0.5 * (cov + np.swapaxes(cov, -1, -2))).min())
        raise ValueError(f"{name} must be positive definite, got smallest eigenvalue "
                         f"{eig_min:.3g}") from None


def _factor(cov: np.ndarray) -> np.ndarray:
    """A matrix L with L L^T = cov, also when cov is only positive semi-definite."""
    try:
        return np.linalg.cholesky(cov)
    except np.linalg.LinAlgError:
        vals, vecs = np.linalg.eigh(cov)
        return vecs * np.sqrt(np.clip(vals, 0.0, None))


def _finite_or_missing(example: str, name: str, value) -> np.ndarray:
    """``as_array(name, value)``; a NaN gets a message on the missing rows of a filter result.

    A filter leaves NaN innovations and innovation covariances on the rows
    whose measurement was missing; the message says how to leave them out,
    with a call of the function ``example``.
    """
    a = as_array(name, value, finite=False)
    nan = np.isnan(a)
    if nan.any():
        index = tuple(int(i) for i in np.argwhere(nan)[0])
        raise ValueError(
            f"{name} must be finite, got NaN at index {index}. A filter result has NaN "
            "innovations and innovation covariances on the rows whose measurement was missing: "
            f"select the observed rows, e.g. {example}(res.innovations[res.observed], "
            "res.innovation_covs[res.observed]). A partly-observed row has values in its "
            "observed components only (res.observed_components): keep the fully observed "
            "rows, res.observed_components.all(axis=-1), or the observed block of each row")
    return as_array(name, a)  # an inf gets the plain message


def _agreed_size(sizes: list[int]) -> int:
    """The size most arguments agree on (a tie goes to the first listed).

    Several arguments fix one dimension; taking the majority's size means the
    argument that disagrees is the one named in the error.
    """
    return max(sizes, key=sizes.count)


def condition(mean_x, mean_y, cov_xx, cov_xy, cov_yy, y) -> Gaussian:
    r"""Distribution of :math:`x` given :math:`y` for a jointly Gaussian pair.

    Seed 000, Theorem 10.2, eqs. (10.24)-(10.25), with the roles of x and y
    exchanged (Kay conditions y on x; the Kalman update conditions the state
    on the measurement):

    .. math::

        E(x \mid y) = \mu_x + C_{xy} C_{yy}^{-1} (y - \mu_y), \qquad
        C_{x \mid y} = C_{xx} - C_{xy} C_{yy}^{-1} C_{xy}^T.

    Parameters
    ----------
    mean_x : array_like, shape (k,)
        :math:`E(x)`.
    mean_y : array_like, shape (l,)
        :math:`E(y)`.
    cov_xx : array_like, shape (k, k)
        :math:`C_{xx}`, symmetric positive semi-definite.
    cov_xy : array_like, shape (k, l)
        Cross-covariance :math:`C_{xy} = E[(x - \mu_x)(y - \mu_y)^T]`
        (:math:`C_{yx} = C_{xy}^T`).
    cov_yy : array_like, shape (l, l)
        :math:`C_{yy}`, symmetric positive definite (it is solved against).
    y : array_like, shape (l,)
        The observed value of :math:`y`.

    Returns
    -------
    Gaussian
        ``mean`` (k,) and ``cov`` (k, k), the latter symmetrised exactly.

    Raises
    ------
    ValueError
        On a shape mismatch, a non-finite entry, a ``cov_yy`` that is not
        positive definite, or blocks that do not form a positive
        semi-definite joint covariance.
    """
    # k is fixed by mean_x, cov_xx, cov_xy and l by mean_y, cov_yy, cov_xy, y: the
    # sizes most of them agree on are taken, so that the odd one out is blamed.
    sizes = {"mean_x": as_vector("mean_x", mean_x).shape[0],
             "mean_y": as_vector("mean_y", mean_y).shape[0],
             "cov_xx": as_square("cov_xx", cov_xx).shape[0],
             "cov_yy": as_square("cov_yy", cov_yy).shape[0],
             "cov_xy": as_matrix("cov_xy", cov_xy, (None, None)).shape,
             "y": as_vector("y", y).shape[0]}
    k = _agreed_size([sizes["cov_xx"], sizes["mean_x"], sizes["cov_xy"][0]])
    l_ = _agreed_size([sizes["cov_yy"], sizes["mean_y"], sizes["y"], sizes["cov_xy"][1]])
    mean_x = as_vector("mean_x", mean_x, k)
    mean_y = as_vector("mean_y", mean_y, l_)
    cov_xx = as_covariance("cov_xx", cov_xx, k)
    cov_yy = as_covariance("cov_yy", cov_yy, l_)
    cov_xy = as_matrix("cov_xy", cov_xy, (k, l_))
    y = as_vector("y", y, l_)
    factor = (_cholesky("cov_yy", cov_yy), True)
    joint = np.block([[cov_xx, cov_xy], [cov_xy.T, cov_yy]])
    eig_min = float(np.linalg.eigvalsh(joint).min())
    if eig_min < -1e-9 * max(float(np.max(np.abs(joint))), 1e-300) * (k + l_):
        raise ValueError("cov_xy is inconsistent with cov_xx and cov_yy: the joint covariance "
                         f"[[cov_xx, cov_xy], [cov_xy^T, cov_yy]] has eigenvalue {eig_min:.3g} < 0")
    # W = C_xy C_yy^{-1}, from C_yy W^T = C_yx (solve, do not invert)
    W = sla.cho_solve(factor, cov_xy.T, check_finite=False).T
    # E(x|y) = mu_x + C_xy C_yy^{-1} (y - mu_y)          (10.24)
    mean = mean_x + W @ (y - mean_y)
    # C_{x|y} = C_xx - C_xy C_yy^{-1} C_yx              (10.25)
    cov = cov_xx - W @ cov_xy.T
    # The difference is symmetric in exact arithmetic only; make it exactly so.
    cov = 0.5 * (cov + cov.T)
    return Gaussian(mean, cov)


def logpdf(x, mean, cov):
    r"""Log-density of :math:`N(\text{mean}, \text{cov})` at one or many points.

    .. math::

        \log N(x; m, P) = -\tfrac12\left[(x-m)^T P^{-1} (x-m) + \log\det P
        + n \log 2\pi\right],

    evaluated with the Cholesky factor :math:`P = L L^T`:
    :math:`(x-m)^T P^{-1}(x-m) = \lVert L^{-1}(x-m)\rVert^2` and
    :math:`\log\det P = 2\sum_i \log L_{ii}`.

    Parameters
    ----------
    x : array_like, shape (n,) or (N, n)
        One point or N points (rows).
    mean : array_like, shape (n,)
    cov : array_like, shape (n, n)
        Symmetric positive definite.

    Returns
    -------
    float or ndarray, shape (N,)
        A float for one point, an array for a batch.
    """
    mean = as_vector("mean", mean)
    n = mean.shape[0]
    cov = as_covariance("cov", cov, n)
    xa = as_array("x", x)
    if xa.ndim == 0 and n == 1:
        xa = xa.reshape(1)
    if not ((xa.ndim == 1 and xa.shape[0] == n) or (xa.ndim == 2 and xa.shape[1] == n)):
        raise ValueError(f"x must have shape ({n},) or (N, {n}), got shape {xa.shape}")
    out = _logpdf_rows(np.atleast_2d(xa) - mean, _cholesky("cov", cov))
    return float(out[0]) if xa.ndim == 1 else out


def _apply_to_rows(F: np.ndarray, z: np.ndarray) -> np.ndarray:
    """F z_i for every row z_i of z (N, q), with F (n, q): the rows of ``z @ F.T``.

    With q = 1 the matrix product has a single term, (F z_i)_k = F_k0 z_i0, and
    is written as that product of a column and a number: numpy's @ runs 10 times
    slower on a tall (N, 1) array, and np.dot hands it to OpenBLAS, whose threads
    cost far more than they save on a busy machine.
    """
    return z * F.T if F.shape[1] == 1 else z @ F.T


def _lower_inverse(L: np.ndarray) -> np.ndarray:
    """L^{-1} of a lower-triangular factor L (n, n) (its lower triangle), from LAPACK dtrtri."""
    return np.tril(_dtrtri(L, lower=1)[0])


def _logpdf_rows(d: np.ndarray, L: np.ndarray, L_inv: np.ndarray | None = None) -> np.ndarray:
    """log N(d_i; 0, P_i) for each row d_i of ``d`` (N, n), given Cholesky factors P_i = L_i L_i^T.

    ``L`` is one factor (n, n) for all rows, of which only the lower triangle
    is read, or one factor per row (N, n, n) with zero upper triangles; either
    from a successful Cholesky factorisation (positive diagonal). ``L_inv``,
    optional, is :func:`_lower_inverse` of a single ``L``, for a caller that
    holds it (a model, whose R never changes).
    The one place the Gaussian log-density is computed: the filters' step
    log-likelihoods and the models' measurement densities call it too.
    """
    # z_i = L_i^{-1} d_i, so that z_i^T z_i = d_i^T P_i^{-1} d_i
    if L.ndim == 3:
        z = np.linalg.solve(L, d[..., None])[..., 0]
    elif d.shape[0] == 1:
        # one row: a LAPACK triangular solve, dtrtrs
        z = _dtrtrs(L, d.T, lower=1)[0].T
    else:
        # many rows: L^{-1} from LAPACK dtrtri, then one product for all of them
        # (dtrtrs with many right-hand sides wakes OpenBLAS's threads, which cost
        # far more than they save on such small systems)
        if L_inv is None:
            L_inv = _lower_inverse(L)
        z = _apply_to_rows(L_inv, d)
    # z_i^T z_i for every row (einsum: a sum over a short last axis is slow in numpy)
    maha = np.einsum("...i,...i->...", z, z)
    # log det P = 2 sum_i log L_ii
    log_det = 2.0 * np.log(L.diagonal(0, -2, -1)).sum(axis=-1)
    # -(maha + log det P + n log 2 pi) / 2, in place: maha is as long as d, and fresh
    # memory of that size costs page faults
    maha += log_det + L.shape[-1] * LOG_2PI
    maha *= -0.5
    return maha


def sample(rng: np.random.Generator, mean, cov, size: int) -> np.ndarray:
    r"""Draw ``size`` samples of :math:`N(\text{mean}, \text{cov})`.

    Each draw is :math:`m + L z` with :math:`z \sim N(0, I)` and
    :math:`L L^T = P`. ``cov`` may be singular (positive semi-definite): then
    :math:`L` comes from an eigen-decomposition instead of Cholesky and the
    draws lie in the subspace the covariance allows.

    Parameters
    ----------
    rng : numpy.random.Generator
    mean : array_like, shape (n,)
    cov : array_like, shape (n, n)
        Symmetric positive semi-definite.
    size : int
        Number of draws (>= 1).

    Returns
    -------
    ndarray, shape (size, n)
    """
    rng = as_rng("rng", rng)
    mean = as_vector("mean", mean)
    n = mean.shape[0]
    cov = as_covariance("cov", cov, n)
    size = as_int("size", size, minimum=1)
    z = rng.standard_normal((size, n))
    return mean + z @ _factor(cov).T


def squared_mahalanobis(diffs, covs, singular: str = "raise") -> np.ndarray:
    r"""Squared Mahalanobis distances :math:`d^T P^{-1} d`, broadcast over leading axes.

    With estimation errors :math:`e_t = x_t - \hat x_{t|t}` and the filter's
    covariances this is the NEES (normalised estimation error squared); with
    innovations and innovation covariances it is the NIS. For a consistent
    filter each value is :math:`\chi^2` with ``n`` degrees of freedom (see
    :func:`chi2_interval`).

    Parameters
    ----------
    diffs : array_like, shape (..., n)
        Vectors d, e.g. (T, n) errors of one run or (M, T, n) of M runs.
    covs : array_like, shape (..., n, n)
        Positive definite matrices; the leading axes broadcast against those
        of ``diffs`` (one (n, n) matrix for all, or (T, n, n) shared by M
        runs, ...).
    singular : {"raise", "inf"}
        What a covariance that is not positive definite (its Cholesky
        factorisation fails) gives: a ValueError (the default), or ``inf`` for
        its distances, e.g. the NEES of a particle cloud collapsed onto one
        point (chapter 06).

    Returns
    -------
    ndarray, shape (...)
        The broadcast leading shape (a numpy scalar for a single pair).

    Raises
    ------
    ValueError
        If the trailing shapes do not match, leading axes do not broadcast,
        an entry is not finite, ``singular`` is not one of its two values, or
        (with ``singular="raise"``) a covariance is not positive definite. A
        NaN gets a message saying to select the observed rows of a filter
        result: ``res.innovations[res.observed]``,
        ``res.innovation_covs[res.observed]`` (the missing rows are NaN).
    """
    if singular not in ("raise", "inf"):
        raise ValueError(f'singular must be "raise" or "inf", got {singular!r}')
    d = _finite_or_missing("squared_mahalanobis", "diffs", diffs)
    P = _finite_or_missing("squared_mahalanobis", "covs", covs)
    if d.ndim < 1:
        raise ValueError(f"diffs must have shape (..., n), got scalar {d!r}")
    n = d.shape[-1]
    if P.ndim < 2 or P.shape[-2:] != (n, n):
        raise ValueError(f"covs must have shape (..., {n}, {n}) to match diffs (..., {n}), "
                         f"got shape {P.shape}")
    try:
        lead = np.broadcast_shapes(d.shape[:-1], P.shape[:-2])
    except ValueError:
        raise ValueError(f"leading axes of diffs {d.shape[:-1]} and covs {P.shape[:-2]} "
                         "do not broadcast") from None
    # Symmetry relative to each matrix's own scale, so a large matrix in the batch
    # cannot hide an asymmetric small one.
    asym = np.max(np.abs(P - np.swapaxes(P, -1, -2)), axis=(-2, -1))
    scale = np.maximum(np.max(np.abs(P), axis=(-2, -1)), 1e-300)
    if np.any(asym > 1e-9 * scale):
        worst = float(np.max(asym / scale))
        raise ValueError(f"covs must be symmetric, got max |P - P^T| / max |P| = {worst:.3g}")
    try:
        L = np.linalg.cholesky(P)
        bad = None
    except np.linalg.LinAlgError:
        if singular == "raise":
            raise ValueError("covs must be positive definite (every matrix), "
                             "Cholesky factorisation failed") from None
        # factor the matrices one by one; a failed one gets L = I here and inf below
        flat = P.reshape(-1, n, n)
        L, bad = np.empty_like(flat), np.zeros(flat.shape[0], dtype=bool)
        for k, Pk in enumerate(flat):
            try:
                L[k] = np.linalg.cholesky(Pk)
            except np.linalg.LinAlgError:
                L[k], bad[k] = np.eye(n), True
        L, bad = L.reshape(P.shape), bad.reshape(P.shape[:-2])
    L = np.broadcast_to(L, lead + (n, n))
    d = np.broadcast_to(d, lead + (n,))
    # z = L^{-1} d, then d^T P^{-1} d = z^T z (one batched solve, no inverse)
    z = np.linalg.solve(L, d[..., None])[..., 0]
    out = np.sum(z * z, axis=-1)
    if bad is not None:
        out = np.where(np.broadcast_to(bad, lead), np.inf, out)[()]  # [()]: a scalar stays one
    return out


def chi2_interval(dof: int, n_runs: int = 1, confidence: float = 0.95) -> Interval:
    r"""Two-sided interval for the *average* of ``n_runs`` independent :math:`\chi^2(\text{dof})`.

    The sum of ``n_runs`` independent :math:`\chi^2(\text{dof})` values is
    :math:`\chi^2(n_\text{runs}\,\text{dof})`; the bounds of its central
    ``confidence`` interval divided by ``n_runs`` bound the average. Use it
    for the average NEES (dof = n) or NIS (dof = m) over Monte Carlo runs.

    Parameters
    ----------
    dof : int
        Degrees of freedom of each value (>= 1).
    n_runs : int
        Number of independent runs averaged (>= 1).
    confidence : float
        Probability mass inside the interval, in (0, 1).

    Returns
    -------
    Interval
        ``(low, high)``; the average lies inside with probability ``confidence``.
    """
    dof = as_int("dof", dof, minimum=1)
    n_runs = as_int("n_runs", n_runs, minimum=1)
    if isinstance(confidence, bool) or not isinstance(confidence, (int, float, np.floating)):
        raise TypeError(f"confidence must be a real number, got {type(confidence).__name__}")
    confidence = float(confidence)
    if not 0.0 < confidence < 1.0:
        raise ValueError(f"confidence must be in (0, 1), got {confidence!r}")
    total = n_runs * dof
    alpha = 1.0 - confidence
    low = stats.chi2.ppf(0.5 * alpha, total) / n_runs
    high = stats.chi2.ppf(1.0 - 0.5 * alpha, total) / n_runs
    return Interval(float(low), float(high))


def normalised_innovations(innovations, innovation_covs) -> np.ndarray:
    r"""Whitened innovations :math:`z_t = L_t^{-1} r_t`, with :math:`S_t = L_t L_t^T` (Cholesky).

    For a consistent filter the innovations :math:`r_t` are independent
    over time with covariances :math:`S_t`, so the :math:`z_t` are
    independent :math:`N(0, I)`: white noise, each component with unit
    variance. :func:`autocorrelation` of the result is the innovation
    whiteness test (chapter 03). :math:`\lVert z_t \rVert^2` is the NIS of
    step t (see :func:`squared_mahalanobis`).

    Parameters
    ----------
    innovations : array_like, shape (T, m)
        :math:`r_t`, e.g. ``res.innovations`` of a filter result.
    innovation_covs : array_like, shape (T, m, m)
        :math:`S_t`, symmetric positive definite, e.g. ``res.innovation_covs``.

    Returns
    -------
    ndarray, shape (T, m)

    Raises
    ------
    ValueError
        On a shape mismatch, a non-finite entry, or an :math:`S_t` that is
        not positive definite. A NaN (the missing rows of a filter result)
        gets a message saying to select the observed rows:
        ``normalised_innovations(res.innovations[res.observed],
        res.innovation_covs[res.observed])``.
    """
    r = _finite_or_missing("normalised_innovations", "innovations", innovations)
    S = _finite_or_missing("normalised_innovations", "innovation_covs", innovation_covs)
    if r.ndim != 2:
        raise ValueError(f"innovations must have shape (T, m), got shape {r.shape}")
    T, m = r.shape
    if S.shape != (T, m, m):
        raise ValueError(f"innovation_covs must have shape ({T}, {m}, {m}) to match innovations "
                         f"({T}, {m}), got shape {S.shape}")
    asym = np.max(np.abs(S - np.swapaxes(S, 1, 2)), axis=(1, 2))
    scale = np.maximum(np.max(np.abs(S), axis=(1, 2)), 1e-300)
    if np.any(asym > 1e-9 * scale):
        t = int(np.argmax(asym / scale))
        raise ValueError(f"innovation_covs must be symmetric, got max |S - S^T| / max |S| = "
                         f"{asym[t] / scale[t]:.3g} at step {t}")
    try:
        L = np.linalg.cholesky(S)
    except np.linalg.LinAlgError:
        raise ValueError("innovation_covs must be positive definite (every matrix), "
                         "Cholesky factorisation failed") from None
    # z_t = L_t^{-1} r_t (a solve, no inverse)
    return np.linalg.solve(L, r[..., None])[..., 0]


def autocorrelation(x, max_lag: int) -> np.ndarray:
    r"""Sample autocorrelation :math:`\hat\gamma(1), \dots, \hat\gamma(K)` of one or more sequences.

    The standard (biased) estimator, with :math:`\bar x` the sample mean:

    .. math::

        \hat\gamma(k) = \frac{\sum_{t=0}^{N-1-k} (x_t - \bar x)(x_{t+k} - \bar x)}
                           {\sum_{t=0}^{N-1} (x_t - \bar x)^2}.

    Dividing by the full sum (not by the N - k terms of the numerator) keeps
    :math:`|\hat\gamma(k)| \le 1`.

    Innovation whiteness test (the third consistency test, with NEES and
    NIS): for a consistent filter the normalised innovations
    (:func:`normalised_innovations`) are white, and for white noise each
    :math:`\hat\gamma(k)`, k >= 1, is approximately :math:`N(0, 1/N)` for
    large N. So about 95 % of the lags should lie inside the band
    :math:`\pm 1.96 / \sqrt N`; many lags outside it, or a pattern, mean
    that the innovations are correlated over time (a wrong model, or wrong
    noise covariances).

    Parameters
    ----------
    x : array_like, shape (N,) or (N, m)
        A sequence, or m sequences as columns (each is treated separately).
    max_lag : int
        Largest lag K, 1 <= K <= N - 1.

    Returns
    -------
    ndarray, shape (max_lag,) or (max_lag, m)
        Row k - 1 holds :math:`\hat\gamma(k)`.

    Raises
    ------
    ValueError
        On a non-finite entry (a NaN gets the message of
        :func:`normalised_innovations`), fewer than 2 samples, ``max_lag``
        outside [1, N - 1], or a constant sequence (no autocorrelation).
    """
    a = _finite_or_missing("normalised_innovations", "x", x)
    if a.ndim not in (1, 2):
        raise ValueError(f"x must have shape (N,) or (N, m), got shape {a.shape}")
    N = a.shape[0]
    if N < 2 or a.size == 0:
        raise ValueError(f"x needs at least 2 samples (and a column), got shape {a.shape}")
    max_lag = as_int("max_lag", max_lag, minimum=1)
    if max_lag > N - 1:
        raise ValueError(f"max_lag must be <= N - 1 = {N - 1}, got {max_lag}")
    d = a - a.mean(axis=0)
    # sum_t (x_t - xbar)^2
    denom = np.sum(d * d, axis=0)
    if np.any(denom == 0):
        raise ValueError("x is constant (in some column): its autocorrelation is undefined")
    # gamma(k) = sum_{t < N-k} (x_t - xbar)(x_{t+k} - xbar) / sum_t (x_t - xbar)^2
    return np.stack([np.sum(d[:-k] * d[k:], axis=0) for k in range(1, max_lag + 1)]) / denom
