r"""The discrete Bayes filter: the Bayes recursion on a finite state space.

Chapter 01 of the course. When the state takes one of ``n`` values (cells of
a grid, doors that are open or closed), a belief is a probability vector and
both steps of the Bayes recursion are finite sums.

**Prediction** (예측, *time update*): total probability over the previous
state and the Markov assumption (seed 000 section 1, seed 001 "Prediction",
seed 002 eq. 12-13) give the Chapman-Kolmogorov equation

.. math::

    p(x_t = j \mid y_{0:t-1}) = \sum_i p(x_t = j \mid x_{t-1} = i)\,
                                       p(x_{t-1} = i \mid y_{0:t-1}),

a vector-matrix product ``prior = belief @ transition`` with
``transition[i, j] = p(x_t = j | x_{t-1} = i)`` (rows sum to one). A known
control input :math:`u_{t-1}` (seed 002) selects the transition matrix.

**Measurement update** (측정 업데이트): Bayes' rule (seed 001 eqs. 3-4,
seed 002 eqs. 9-11)

.. math::

    p(x_t \mid y_{0:t}) = \frac{p(y_t \mid x_t)\, p(x_t \mid y_{0:t-1})}
                               {p(y_t \mid y_{0:t-1})},\qquad
    p(y_t \mid y_{0:t-1}) = \sum_j p(y_t \mid x_t = j)\, p(x_t = j \mid y_{0:t-1}).

The denominator, the *evidence*, is the normalising constant (정규화 항); its
product over time is the likelihood of the whole measurement record.

Import it as ``bf.bayes``::

    import bayesfilt as bf
    move = bf.bayes.shift_transition(10, bf.bayes.gaussian_kernel(0.5), offset=1)
    prior = bf.bayes.predict(belief, move)
    posterior, evidence = bf.bayes.update(prior, likelihood)

filterpy equivalents: ``filterpy.discrete_bayes.predict(pdf, offset, kernel)``
(a cyclic or zero-padded shift; here any transition matrix), ``update(likelihood,
prior)`` (no evidence returned) and ``normalize``.
"""

from __future__ import annotations

from typing import Callable, NamedTuple

import numpy as np
from scipy.special import ndtr

from ._checks import (as_array, as_int, as_positive_float, as_vector, check_callable,
                      observation_masks)

__all__ = [
    "BayesUpdate",
    "BayesFilterResult",
    "predict",
    "update",
    "bayes_filter",
    "shift_transition",
    "gaussian_kernel",
    "grid_transition",
    "grid_likelihood",
    "gaussian_likelihood",
    "GridFilterResult",
    "grid_filter",
]

ROW_SUM_ATOL = 1e-9
MAX_KERNEL_HALF_WIDTH = 1_000_000
#: grid_filter refuses a posterior with more than this probability in an end cell.
EDGE_MASS = 1e-8


class BayesUpdate(NamedTuple):
    """Result of :func:`update`.

    posterior : ndarray, shape (n,)
        :math:`p(x_t \\mid y_{0:t})`, sums to one.
    evidence : float
        :math:`p(y_t \\mid y_{0:t-1})`, the normaliser.
    """

    posterior: np.ndarray
    evidence: float


class BayesFilterResult(NamedTuple):
    """Result of :func:`bayes_filter` over T steps.

    priors : (T, n), ``priors[t]`` = :math:`p(x_t \\mid y_{0:t-1})` (``priors[0]`` the initial belief);
    posteriors : (T, n), ``posteriors[t]`` = :math:`p(x_t \\mid y_{0:t})`;
    evidences : (T,), :math:`p(y_t \\mid y_{0:t-1})`;
    log_evidence : float, :math:`\\log p(y_{0:T-1}) = \\sum_t \\log` evidences.
    """

    priors: np.ndarray
    posteriors: np.ndarray
    evidences: np.ndarray
    log_evidence: float


# --------------------------------------------------------------------------
# argument checks
# --------------------------------------------------------------------------

def _as_belief(name: str, belief, n: int | None = None) -> np.ndarray:
    """A non-negative, finite vector with positive mass, returned normalised."""
    b = as_vector(name, belief, n)
    if np.any(b < 0):
        i = int(np.argmin(b))
        raise ValueError(f"{name} must be non-negative, got {name}[{i}] = {b[i]:.3g}")
    peak = b.max()
    if peak <= 0:
        raise ValueError(f"{name} must have positive total mass, got all zeros")
    # Unnormalised beliefs are accepted: only their shape matters. Dividing by the
    # largest entry first keeps the sum from overflowing for huge counts.
    b = b / peak
    return b / b.sum()


def _as_transition(name: str, transition, n: int | None = None) -> np.ndarray:
    t = as_array(name, transition, ndim=2)
    if t.shape[0] != t.shape[1]:
        raise ValueError(f"{name} must be a square (n, n) matrix, got shape {t.shape}")
    if n is not None and t.shape[0] != n:
        raise ValueError(f"{name} must have shape ({n}, {n}) to match the belief, got shape {t.shape}")
    if np.any(t < 0):
        i, j = np.argwhere(t < 0)[0]
        raise ValueError(f"{name} must be non-negative, got {name}[{i}, {j}] = {t[i, j]:.3g}")
    sums = t.sum(axis=1)
    bad = np.flatnonzero(np.abs(sums - 1.0) > ROW_SUM_ATOL)
    if bad.size:
        i = int(bad[0])
        raise ValueError(f"{name} rows must sum to 1 (transition[i, j] = p(x_t = j | x_(t-1) = i)), "
                         f"got row {i} summing to {sums[i]:.6g}")
    return t


def _as_likelihood(name: str, likelihood, n: int) -> np.ndarray:
    lik = as_vector(name, likelihood, n)
    if np.any(lik < 0):
        i = int(np.argmin(lik))
        raise ValueError(f"{name} must be non-negative, got {name}[{i}] = {lik[i]:.3g}")
    return lik


# --------------------------------------------------------------------------
# the two steps and the recursion
# --------------------------------------------------------------------------

def predict(belief, transition) -> np.ndarray:
    r"""Prediction step (Chapman-Kolmogorov): the prior over the next state.

    .. math:: \bar b_j = \sum_i b_i\, T_{ij}

    (seed 000 section 1; seed 001 "Prediction"; seed 002 eq. 12-13).

    Parameters
    ----------
    belief : array_like, shape (n,)
        :math:`p(x_{t-1} \mid y_{0:t-1})`. Normalised on entry if it is not.
    transition : array_like, shape (n, n)
        ``transition[i, j]`` = :math:`p(x_t = j \mid x_{t-1} = i, u_{t-1})`;
        every row sums to 1. With a control input, pass the matrix the
        control selects.

    Returns
    -------
    ndarray, shape (n,)
        :math:`p(x_t \mid y_{0:t-1})`, sums to one.
    """
    b = _as_belief("belief", belief)
    t = _as_transition("transition", transition, b.shape[0])
    # prior_j = sum_i belief_i T_ij
    return b @ t


def update(prior, likelihood) -> BayesUpdate:
    r"""Measurement update (Bayes' rule) with the evidence as normaliser.

    .. math::

        p(x_t \mid y_{0:t}) = \frac{p(y_t \mid x_t)\, p(x_t \mid y_{0:t-1})}
                                  {p(y_t \mid y_{0:t-1})}

    (seed 001 eqs. 3-4; seed 002 eqs. 9-11).

    Parameters
    ----------
    prior : array_like, shape (n,)
        :math:`p(x_t \mid y_{0:t-1})`. Normalised on entry if it is not.
    likelihood : array_like, shape (n,)
        :math:`p(y_t \mid x_t = j)` for each state j, non-negative. Only its
        shape matters for the posterior; its scale sets the evidence.

    Returns
    -------
    BayesUpdate
        ``posterior`` (n,) and ``evidence`` :math:`p(y_t \mid y_{0:t-1})`.

    Raises
    ------
    ValueError
        If the likelihood is zero wherever the prior has mass: the
        measurement is impossible under the model (evidence 0), and no
        posterior exists.
    """
    p = _as_belief("prior", prior)
    lik = _as_likelihood("likelihood", likelihood, p.shape[0])
    joint = p * lik
    # evidence = sum_j p(y | x = j) p(x = j | y_0:t-1)
    evidence = float(joint.sum())
    if evidence <= 0.0:
        raise ValueError("likelihood is zero wherever the prior has mass: the measurement has "
                         "probability 0 under the model (evidence p(y_t | y_0:t-1) = 0), so there is "
                         "no posterior. Check the measurement model, or whether the likelihood "
                         "underflowed (rescale it).")
    return BayesUpdate(joint / evidence, evidence)


def bayes_filter(initial_belief, transitions, likelihoods) -> BayesFilterResult:
    r"""Run the Bayes recursion: update, then predict, then update, ...

    Seed 000's time convention: ``likelihoods[0]`` is the likelihood of
    the first measurement :math:`y_0`, which measures :math:`x_0`, whose prior
    is ``initial_belief``.

    Parameters
    ----------
    initial_belief : array_like, shape (n,)
        :math:`p(x_0)`.
    transitions : array_like, shape (n, n) or (T - 1, n, n)
        One transition matrix for every step, or ``transitions[t]`` for the
        step from :math:`x_t` to :math:`x_{t+1}` (e.g. selected by the control
        :math:`u_t`).
    likelihoods : array_like, shape (T, n)
        ``likelihoods[t, j]`` = :math:`p(y_t \mid x_t = j)`.

    Returns
    -------
    BayesFilterResult
    """
    b0 = _as_belief("initial_belief", initial_belief)
    n = b0.shape[0]
    liks = as_array("likelihoods", likelihoods, ndim=2)
    if liks.shape[1] != n:
        raise ValueError(f"likelihoods must have shape (T, {n}), got shape {liks.shape}")
    T = liks.shape[0]
    if T == 0:
        raise ValueError("likelihoods must have at least one row, got shape (0, n)")
    trans = as_array("transitions", transitions)
    if trans.ndim == 2:
        trans = np.broadcast_to(_as_transition("transitions", trans, n), (max(T - 1, 0), n, n))
    elif trans.ndim == 3:
        if trans.shape[1:] != (n, n):
            raise ValueError(f"transitions must have shape ({n}, {n}) or ({T - 1}, {n}, {n}), "
                             f"got shape {trans.shape}")
        if trans.shape[0] != T - 1:
            # T matrices for T measurements is the classic off-by-one: y_0 measures x_0
            # before any move, so only T - 1 moves happen.
            raise ValueError(f"transitions must hold T - 1 = {T - 1} matrices for T = {T} "
                             f"likelihoods, got {trans.shape[0]}: ys[0] measures x_0 before any "
                             f"move, and transitions[t] (selected by u_t) moves x_t to x_(t+1)")
        for t in range(T - 1):
            _as_transition(f"transitions[{t}]", trans[t], n)
    else:
        raise ValueError(f"transitions must have shape ({n}, {n}) or ({T - 1}, {n}, {n}), "
                         f"got shape {trans.shape}")
    priors = np.empty((T, n))
    posteriors = np.empty((T, n))
    evidences = np.empty(T)
    prior = b0
    for t in range(T):
        priors[t] = prior
        try:
            posteriors[t], evidences[t] = update(prior, liks[t])
        except ValueError as exc:
            raise ValueError(f"at step t = {t}: {exc}") from None
        if t + 1 < T:
            # prior_{t+1} = posterior_t @ T_t; rows were validated above.
            prior = posteriors[t] @ trans[t]
    return BayesFilterResult(priors, posteriors, evidences, float(np.sum(np.log(evidences))))


# --------------------------------------------------------------------------
# building transitions and likelihoods on a grid
# --------------------------------------------------------------------------

def shift_transition(n: int, kernel, offset: int = 0, cyclic: bool = True) -> np.ndarray:
    r"""Transition matrix of a noisy shift on ``n`` cells.

    From cell ``i`` the state moves to cell ``i + offset + k - c`` with
    probability ``kernel[k]``, where ``c = len(kernel) // 2`` is the centre
    of the (odd-length) kernel. This is filterpy's
    ``discrete_bayes.predict(pdf, offset, kernel)`` written as a matrix.

    Parameters
    ----------
    n : int
        Number of cells.
    kernel : array_like, shape (k,), k odd
        Probabilities of the move error ``-c .. c``; non-negative, summing to 1.
    offset : int
        Commanded move in cells (negative: to the left).
    cyclic : bool
        ``True``: the grid is a ring (cell ``n`` is cell ``0``).
        ``False``: a corridor with walls; probability that would leave the
        grid stays in the end cell, so every row still sums to one
        (filterpy's ``mode='constant'`` instead loses that mass).

    Returns
    -------
    ndarray, shape (n, n)
        ``T[i, j]`` = :math:`p(x_t = j \mid x_{t-1} = i)`.
    """
    n = as_int("n", n, minimum=1)
    offset = as_int("offset", offset)
    if not isinstance(cyclic, (bool, np.bool_)):
        raise TypeError(f"cyclic must be True or False, got {type(cyclic).__name__}")
    k = as_vector("kernel", kernel)
    if k.shape[0] % 2 == 0:
        raise ValueError(f"kernel must have odd length (a centre cell), got length {k.shape[0]}")
    if np.any(k < 0):
        i = int(np.argmin(k))
        raise ValueError(f"kernel must be non-negative, got kernel[{i}] = {k[i]:.3g}")
    if abs(k.sum() - 1.0) > ROW_SUM_ATOL:
        raise ValueError(f"kernel must be non-negative and sum to 1, got sum {k.sum():.6g}")
    centre = k.shape[0] // 2
    T = np.zeros((n, n))
    rows = np.arange(n)
    for idx, weight in enumerate(k):
        dest = rows + offset + idx - centre
        dest = np.mod(dest, n) if cyclic else np.clip(dest, 0, n - 1)
        # np.add.at accumulates when several moves land on one cell (walls, small rings).
        np.add.at(T, (rows, dest), weight)
    return T


def gaussian_kernel(std: float, half_width: int | None = None) -> np.ndarray:
    r"""Move-error kernel: a normal distribution of standard deviation ``std`` cells,
    discretised by the probability of each cell :math:`[k - 1/2, k + 1/2]`.

    Parameters
    ----------
    std : float
        Standard deviation of the move error, in cells (> 0).
    half_width : int, optional
        The kernel covers offsets ``-half_width .. half_width``; default
        ``ceil(4 std)``. The mass beyond is folded back by renormalising.

    Returns
    -------
    ndarray, shape (2 half_width + 1,)
        Non-negative, sums to one.
    """
    std = as_positive_float("std", std)
    half_width = int(np.ceil(4 * std)) if half_width is None else as_int("half_width", half_width,
                                                                          minimum=0)
    if half_width > MAX_KERNEL_HALF_WIDTH:
        raise ValueError(f"half_width must be at most {MAX_KERNEL_HALF_WIDTH} cells (a kernel wider "
                         f"than any sensible grid), got {half_width} (std = {std:.3g} cells)")
    edges = (np.arange(-half_width, half_width + 2) - 0.5) / std
    probs = np.diff(ndtr(edges))
    return probs / probs.sum()


def grid_transition(grid, density: Callable) -> np.ndarray:
    r"""Transition matrix from a transition density evaluated on a grid.

    ``T[i, j]`` is proportional to ``density(grid[j], grid[i])`` =
    :math:`p(x_t = g_j \mid x_{t-1} = g_i)`, each row normalised to one: the
    grid approximation of a continuous model (e.g. :math:`x_t = a x_{t-1} + w`).

    Parameters
    ----------
    grid : array_like, shape (n,)
        Cell centres, strictly increasing.
    density : callable
        ``density(x_next, x_prev)`` evaluated with broadcasting on arrays of
        shape (1, n) and (n, 1); must return shape (n, n), non-negative.
    """
    g = _as_grid(grid)
    check_callable("density", density)
    vals = as_array("density(x_next, x_prev)", density(g[None, :], g[:, None]), ndim=2)
    if vals.shape != (g.shape[0], g.shape[0]):
        raise ValueError(f"density(x_next, x_prev) must return shape {(g.shape[0],) * 2} on the "
                         f"grid, got shape {vals.shape}")
    if np.any(vals < 0):
        raise ValueError("density(x_next, x_prev) must be non-negative")
    sums = vals.sum(axis=1)
    if np.any(sums <= 0):
        i = int(np.flatnonzero(sums <= 0)[0])
        raise ValueError(f"density(x_next, x_prev) is zero on the whole grid from grid[{i}] = "
                         f"{g[i]:.4g}: widen the grid or the density")
    return vals / sums[:, None]


def grid_likelihood(grid, y, density: Callable) -> np.ndarray:
    r"""Likelihood :math:`p(y \mid x = g_j)` of one measurement at every grid cell.

    Parameters
    ----------
    grid : array_like, shape (n,)
    y : float or array_like
        The measurement.
    density : callable
        ``density(y, x)`` = :math:`p(y \mid x)`, vectorised over ``x`` (n,).

    Returns
    -------
    ndarray, shape (n,)
    """
    g = _as_grid(grid)
    check_callable("density", density)
    vals = as_vector("density(y, grid)", density(y, g), g.shape[0])
    if np.any(vals < 0):
        raise ValueError("density(y, grid) must be non-negative")
    return vals


def gaussian_likelihood(grid, y: float, std: float) -> np.ndarray:
    r"""Likelihood of a position measurement :math:`y = x + v`, :math:`v \sim N(0, \sigma^2)`.

    Parameters
    ----------
    grid : array_like, shape (n,)
        Cell centres :math:`g_j`, strictly increasing.
    y : float
        The measured position (one number, or an array of shape (1,)).
    std : float
        Measurement-noise standard deviation :math:`\sigma > 0`, in the units of ``grid``.

    Returns
    -------
    ndarray, shape (n,)
        :math:`N(y; g_j, \sigma^2)` for every cell centre :math:`g_j` (a density in y, not
        normalised over the grid).
    """
    g = _as_grid(grid)
    std = as_positive_float("std", std)
    y = float(as_vector("y", y, 1)[0])
    z = (y - g) / std
    return np.exp(-0.5 * z * z) / (np.sqrt(2.0 * np.pi) * std)


def _as_grid(grid) -> np.ndarray:
    g = as_vector("grid", grid)
    if g.shape[0] > 1 and np.any(np.diff(g) <= 0):
        raise ValueError("grid must be strictly increasing")
    return g


# --------------------------------------------------------------------------
# An exact reference for one-dimensional continuous models (chapter 06)
# --------------------------------------------------------------------------

class GridFilterResult(NamedTuple):
    """Output of :func:`grid_filter`.

    grid (n,); posteriors (T, n): probability of each cell given y_0..y_t;
    means (T,) and variances (T,) of the posterior; loglik: the grid estimate of
    log p(y_0, ..., y_{T-1}).
    """

    grid: np.ndarray
    posteriors: np.ndarray
    means: np.ndarray
    variances: np.ndarray
    loglik: float


def _row_normalised_exp(log_vals: np.ndarray, what: str) -> np.ndarray:
    m = log_vals.max(axis=1, keepdims=True)
    if np.any(m == -np.inf):
        i = int(np.flatnonzero(m[:, 0] == -np.inf)[0])
        raise ValueError(f"{what} is zero on the whole grid from row {i}: widen the grid")
    vals = np.exp(log_vals - m)
    return vals / vals.sum(axis=1, keepdims=True)


def grid_filter(model, ys, grid) -> GridFilterResult:
    r"""The Bayes recursion of a one-dimensional continuous model on a fine grid.

    The grid filter of this chapter applied to a model of ``bf.models``
    with a scalar state: cell :math:`g_j` carries the probability
    :math:`p(x_t \approx g_j \mid y_{0:t})`; the transition matrix is the
    model's transition density between cell centres, each row normalised
    (``transition[i, j]`` proportional to
    ``exp(model.transition_logpdf(g_j, g_i, t=t - 1))`` for the step to t), rebuilt at every step
    for a time-varying model; the likelihood is
    ``exp(model.measurement_logpdf(y_t, g_j))``. With cells much narrower
    than the posterior and a grid wider than its support, this is the exact
    posterior up to a discretisation error that vanishes as the cells shrink:
    the reference against which a particle filter or an EKF is judged on a
    one-dimensional nonlinear model (chapter 06).

    Parameters
    ----------
    model : bf.models.LinearGaussian or NonlinearGaussian
        With ``state_dim == 1`` and a transition density (Q > 0).
    ys : array_like, shape (T, m) or (T,) when m = 1
        Measurements; ``ys[0]`` measures :math:`x_0`; an all-NaN row is
        missing; a partly-NaN row uses the likelihood of its observed
        components (``model.measurement_logpdf(y, x, observed=...)``).
    grid : array_like, shape (n,)
        Equally spaced cell centres, strictly increasing.

    Returns
    -------
    GridFilterResult

    Notes
    -----
    Cost: an (n, n) transition per step, O(T n^2): n = 1000 cells and
    T = 50 steps take about a second.
    """
    if getattr(model, "state_dim", None) != 1:
        raise ValueError(f"grid_filter needs a model with a scalar state (state_dim 1), got "
                         f"{getattr(model, 'state_dim', type(model).__name__)}")
    g = _as_grid(grid)
    if g.shape[0] < 2 or not np.allclose(np.diff(g), g[1] - g[0], rtol=1e-6):
        raise ValueError("grid must be equally spaced with at least 2 cells")
    m = model.obs_dim
    if m == 1 and np.ndim(ys) == 1:
        ys = np.asarray(ys)[:, None]
    ys = as_array("ys", ys, ndim=2, finite=False)
    if ys.shape[1] != m or ys.shape[0] == 0:
        raise ValueError(f"ys must have shape (T, {m}) with T >= 1, got shape {ys.shape}")
    observed, components = observation_masks(ys)  # an inf is an error; NaN: missing
    cells = g[:, None]
    # p(x_0 = g_j): the prior density at the cell centres, normalised over the grid
    prior = np.exp(_logpdf_prior(model, g))
    if not prior.sum() > 0:
        raise ValueError("grid_filter: the prior N(m0, P0) is zero on the whole grid "
                         f"[{g[0]:.4g}, {g[-1]:.4g}]: move or widen the grid")
    prior = prior / prior.sum()
    time_varying = getattr(model, "time_varying", False)
    trans = None
    # every (from, to) pair of cells at once: row i * n + j pairs from = g_i with to = g_j
    x_from, x_to = np.repeat(cells, g.shape[0], axis=0), np.tile(cells, (g.shape[0], 1))
    T = ys.shape[0]
    posteriors, loglik = np.empty((T, g.shape[0])), 0.0
    for t in range(T):
        if t > 0:
            if trans is None or time_varying:
                # transition[i, j] ∝ p(x_t = g_j | x_(t-1) = g_i)
                log_p = model.transition_logpdf(x_to, x_from, t=t - 1).reshape(g.shape[0], -1)
                trans = _row_normalised_exp(log_p, "the transition density")
            prior = posteriors[t - 1] @ trans
        if not observed[t]:
            posteriors[t] = prior
            _check_edges(posteriors[t], g, t)
            continue
        o = components[t]
        # p(y_t | g_j), or p(y_{t,o} | g_j) of the observed components o of a partly-NaN row
        log_lik = (model.measurement_logpdf(ys[t], cells) if o.all()
                   else model.measurement_logpdf(ys[t], cells, observed=o))
        # posterior ∝ p(y_t | g_j) prior_j; the evidence sum_j p(y_t | g_j) prior_j
        shift = log_lik.max()
        if shift == -np.inf:
            raise ValueError(f"grid_filter, step t = {t}: the measurement has zero likelihood "
                             "on the whole grid: widen the grid")
        unnorm = np.exp(log_lik - shift) * prior
        evidence = unnorm.sum()
        if not evidence > 0:
            raise ValueError(f"grid_filter, step t = {t}: the prior and the likelihood do not "
                             "overlap on the grid: widen or refine the grid")
        posteriors[t] = unnorm / evidence
        loglik += shift + np.log(evidence)
        _check_edges(posteriors[t], g, t)
    means = posteriors @ g
    variances = posteriors @ (g * g) - means ** 2
    return GridFilterResult(g, posteriors, means, np.maximum(variances, 0.0), float(loglik))


def _check_edges(belief, g, t):
    """Mass piling up in an end cell means the true distribution is cut off there."""
    edge = max(belief[0], belief[-1])
    if edge > EDGE_MASS:
        raise ValueError(f"grid_filter, step t = {t}: the belief has probability {edge:.2g} in an "
                         f"end cell of the grid [{g[0]:.4g}, {g[-1]:.4g}]; it is cut off there: "
                         "widen the grid")


def _logpdf_prior(model, g):
    """log N(g; m0, P0) at every cell (scalar state)."""
    m0, p0 = float(model.m0[0]), float(model.P0[0, 0])
    if not p0 > 0:
        raise ValueError("grid_filter needs a prior with P0 > 0")
    return -0.5 * ((g - m0) ** 2 / p0 + np.log(2 * np.pi * p0))
