r"""Particle filters: sequential importance sampling (SIS) and resampling (chapters 05-06).

A particle filter represents the posterior :math:`p(x_t \mid y_{0:t})` by
``N`` weighted samples, the *particles* :math:`x_t^i` with normalised weights
:math:`W_t^i` (seed 001, eq. (14)):

.. math::

    p(x_t \mid y_{0:t}) \approx \sum_{i=1}^N W_t^i\, \delta(x_t - x_t^i).

**Sequential importance sampling** (seed 001, eqs. (9)-(13); Arulampalam et
al. 2002, section IV). Each step draws every particle's new state from an
*importance density* (proposal) :math:`q(x_t \mid x_{t-1}^i, y_t)` and
multiplies its weight by how much more probable the draw is under the model
than under :math:`q`:

.. math::

    w_t^i = W_{t-1}^i\,
        \frac{p(y_t \mid x_t^i)\, p(x_t^i \mid x_{t-1}^i)}{q(x_t^i \mid x_{t-1}^i, y_t)},
    \qquad W_t^i = \frac{w_t^i}{\sum_j w_t^j}.

The sum :math:`\sum_j w_t^j` estimates the evidence
:math:`p(y_t \mid y_{0:t-1})`; the product over t estimates the likelihood
of the whole record. With the transition itself as the proposal (the
*bootstrap* filter, Gordon et al. 1993) the ratio reduces to the
likelihood :math:`p(y_t \mid x_t^i)`.

**Log domain.** Products of many small likelihoods underflow: the code
keeps log-weights and normalises with the log-sum-exp trick,
:math:`\log \sum_j e^{\ell_j} = m + \log \sum_j e^{\ell_j - m}` with
:math:`m = \max_j \ell_j`, so the largest term is :math:`e^0 = 1` and the
sum cannot underflow to zero.

**Degeneracy and resampling** (chapter 06). After a few steps almost all
weight sits on a few particles. The *effective sample size*
:math:`\mathrm{ESS} = 1 / \sum_i (W^i)^2` (between 1 and N) measures it;
when it falls below ``ess_threshold * N`` the filter resamples
(:mod:`bayesfilt.resampling`): it draws N particles from the weighted set,
so heavy particles are copied and light ones dropped (seed 000 §3.2, step
[4]), and resets the weights to 1/N.

Import it as ``bf.particle``::

    import numpy as np
    import bayesfilt as bf

    model = bf.models.ungm()
    xs, ys = bf.models.simulate(model, 50, np.random.default_rng(0))
    res = bf.particle.particle_filter(model, ys, 1000, np.random.default_rng(1))
    res.means, res.covs, res.ess, res.resampled, res.loglik

Time convention (seed 000), as in ``bf.kalman.kalman_filter``: ``ys[0]``
measures :math:`x_0`, so step 0 draws the particles from the prior
:math:`N(m_0, P_0)` and weights them by :math:`p(y_0 \mid x_0)`; step
t >= 1 moves them from t - 1 to t. An all-NaN row of ``ys`` is a missing
measurement: the particles move, the weights stay. A partly-NaN row weights
the particles by the likelihood of its observed components.

filterpy has no particle filter class; ``filterpy.monte_carlo`` holds
resampling functions only (see :mod:`bayesfilt.resampling`).
"""

from __future__ import annotations

import inspect
import numbers
from typing import Callable, NamedTuple

import numpy as np

from ._checks import (as_inputs, as_int, as_matrix, as_positive_float, as_rng, as_vector,
                      check_callable, check_output, observation_masks)
from .gaussian import _cholesky, _factor, _logpdf_rows
from .resampling import SCHEMES

__all__ = [
    "Proposal",
    "SISStep",
    "ParticleHistory",
    "ParticleFilterResult",
    "log_normalize",
    "ess",
    "weighted_mean_cov",
    "sis_step",
    "optimal_proposal",
    "transition_proposal",
    "particle_filter",
    "LOG_WEIGHTS_TOL",
]


class Proposal(NamedTuple):
    r"""An importance density :math:`q(x_t \mid x_{t-1}, y_t)`: a sampler and its log-density.

    sample : callable
        ``sample(rng, x_prev, y, t)`` -> (N, n): one draw of :math:`x_t` for
        each row of ``x_prev`` (N, n), given the measurement ``y`` (m,) at
        time ``t`` (the time of the *new* state).
    logpdf : callable
        ``logpdf(x, x_prev, y, t)`` -> (N,): :math:`\log q(x^i \mid x_{t-1}^i, y_t)`
        row by row.
    """

    sample: Callable
    logpdf: Callable


class SISStep(NamedTuple):
    """One SIS step: ``particles`` (N, n), normalised ``log_weights`` (N,), and
    ``log_increment``, the estimate of :math:`\\log p(y_t \\mid y_{0:t-1})`."""

    particles: np.ndarray
    log_weights: np.ndarray
    log_increment: float


class ParticleHistory(NamedTuple):
    """Every step's weighted particles (``keep_history=True``), before resampling.

    particles (T, N, n); weights (T, N), normalised; ancestors (T, N), the
    index of each particle's parent at the previous step (``ancestors[0]`` is
    ``arange(N)``).
    """

    particles: np.ndarray
    weights: np.ndarray
    ancestors: np.ndarray


class ParticleFilterResult(NamedTuple):
    """Output of :func:`particle_filter` over T steps.

    means (T, n) and covs (T, n, n): weighted mean and covariance of the particles
    at each step (before resampling), estimates of E[x_t | y_0..y_t] and Cov[...];
    ess (T,): effective sample size after the weight update;
    resampled (T,): True where the particles were resampled at the end of step t;
    step_logliks (T,): log p(y_t | y_0..y_{t-1}) estimates (of the observed components
    on a partly-NaN row), 0 on missing rows;
    loglik: their sum, the log-evidence estimate;
    observed (T,): True where at least one component of the row of ys was measured;
    history: a :class:`ParticleHistory` with ``keep_history=True``, else None;
    observed_components (T, m): True where the component was measured (not NaN).
    """

    means: np.ndarray
    covs: np.ndarray
    ess: np.ndarray
    resampled: np.ndarray
    step_logliks: np.ndarray
    loglik: float
    observed: np.ndarray
    history: ParticleHistory | None
    observed_components: np.ndarray | None = None


# --------------------------------------------------------------------------
# Weights
# --------------------------------------------------------------------------

def log_normalize(log_weights) -> tuple[np.ndarray, float]:
    r"""Normalise log-weights with log-sum-exp.

    .. math::

        \log W^i = \ell_i - \log \sum_j e^{\ell_j},\qquad
        \log \sum_j e^{\ell_j} = m + \log \sum_j e^{\ell_j - m},\quad m = \max_j \ell_j.

    Parameters
    ----------
    log_weights : array_like, shape (N,)
        Unnormalised log-weights :math:`\ell_i`; ``-inf`` (weight zero) is allowed.

    Returns
    -------
    log_W : ndarray, shape (N,)
        Normalised log-weights (``exp(log_W).sum() == 1`` to rounding).
    log_sum : float
        :math:`\log \sum_j e^{\ell_j}`. If the weights entering the step were
        normalised, this is the log-evidence increment
        :math:`\log \hat p(y_t \mid y_{0:t-1})`.

    Raises
    ------
    ValueError
        If a log-weight is NaN or +inf, or all are -inf (every weight is zero).
    """
    lw = as_vector("log_weights", log_weights, finite=False)
    if np.isnan(lw).any() or np.isposinf(lw).any():
        i = int(np.flatnonzero(np.isnan(lw) | np.isposinf(lw))[0])
        raise ValueError(f"log_weights must be finite or -inf, got log_weights[{i}] = {lw[i]}")
    if lw.max() == -np.inf:
        raise ValueError("log_weights are all -inf: every weight is zero, nothing to normalise")
    return _log_normalize(lw)


def _log_normalize(lw: np.ndarray) -> tuple[np.ndarray, float]:
    """:func:`log_normalize` of checked log-weights (no NaN, no +inf, not all -inf)."""
    m = lw.max()
    shifted = lw - m
    # log sum_j exp(l_j) = m + log sum_j exp(l_j - m): the largest term is exp(0) = 1
    log_rest = np.log(np.sum(np.exp(shifted)))
    # log W_i = (l_i - m) - log sum_j exp(l_j - m)  (m cancels before it can cost precision)
    return shifted - log_rest, float(m + log_rest)


def ess(weights) -> float:
    r"""Effective sample size :math:`1 / \sum_i (W^i)^2` of the normalised weights.

    Equals N for equal weights and 1 when one particle holds all the weight.

    Parameters
    ----------
    weights : array_like, shape (N,)
        Finite non-negative weights, not all zero; normalised here (divided
        by their maximum first if their sum overflows).

    Returns
    -------
    float, in [1, N]
    """
    w = as_vector("weights", weights)
    if np.any(w < 0):
        i = int(np.argmin(w))
        raise ValueError(f"weights must be non-negative, got weights[{i}] = {w[i]:.3g}")
    W = _normalised(w)
    # ESS = 1 / sum_i W_i^2
    return float(1.0 / np.dot(W, W))


def _normalised(w: np.ndarray) -> np.ndarray:
    """W = w / sum(w) for finite non-negative weights w, not all zero.

    Weights whose sum overflows (each finite, e.g. two of 1e308) are first
    divided by their maximum, as the resamplers do: W depends only on their
    ratios. Raises ValueError if they are all zero.
    """
    with np.errstate(over="ignore"):  # an overflowing sum is handled below
        total = w.sum()
    if not total > 0:
        raise ValueError("weights must not all be zero")
    if total == np.inf:
        w = w / w.max()
        total = w.sum()
    return w / total


def weighted_mean_cov(particles, weights) -> tuple[np.ndarray, np.ndarray]:
    r"""Weighted mean :math:`\sum_i W^i x^i` and covariance :math:`\sum_i W^i (x^i - \bar x)(x^i - \bar x)^T`.

    Parameters
    ----------
    particles : array_like, shape (N, n)
    weights : array_like, shape (N,)
        Finite non-negative weights, not all zero; normalised here (divided
        by their maximum first if their sum overflows).

    Returns
    -------
    mean : ndarray, shape (n,)
    cov : ndarray, shape (n, n)
    """
    X = as_matrix("particles", particles)
    W = as_vector("weights", weights, X.shape[0])
    if np.any(W < 0) or not W.max() > 0:
        raise ValueError("weights must be non-negative and not all zero, got min "
                         f"{W.min():.3g}, max {W.max():.3g}")
    # normalised here, as ess() does, so unnormalised weights cannot give a wrong answer
    return _mean_cov(X, _normalised(W))


def _mean_cov(X, W):
    # The sums run over the N particles. numpy sums fastest along a contiguous axis,
    # so they are taken on the transpose X^T (n, N), one row per state component,
    # and written with einsum, index by index as in the equations. (A matrix product
    # would hand them to OpenBLAS, whose threads, on a busy machine, can make such a
    # product on a tall array 10-100 times slower.)
    Xt = X.T.copy()
    # x_bar_j = sum_i W_i x_ji
    mean = np.einsum("ji,i->j", Xt, W)
    Dt = Xt - mean[:, None]
    # P_jk = sum_i W_i (x_ji - x_bar_j)(x_ki - x_bar_k)
    cov = np.einsum("ji,ki->jk", Dt * W, Dt)
    return mean, 0.5 * (cov + cov.T)


# --------------------------------------------------------------------------
# One SIS step (seed 001, eq. (13))
# --------------------------------------------------------------------------

def _check_proposal(proposal) -> Proposal:
    if not isinstance(proposal, Proposal):
        raise TypeError(f"proposal must be a bf.particle.Proposal(sample, logpdf) or None "
                        f"(bootstrap), got {type(proposal).__name__}")
    check_callable("proposal.sample", proposal.sample)
    check_callable("proposal.logpdf", proposal.logpdf)
    return proposal


def _log_likelihood(model, y, X, o=None):
    """log p(y | x) for every particle; a likelihood below floating point is -inf, not an error.

    With the mask ``o`` of a partly-missing y, log p(y_o | x) of the observed components.
    """
    # (y - h(x))^2 overflowing means weight 0, handled by the caller
    with np.errstate(over="ignore"):
        if o is None:
            return model.measurement_logpdf(y, X)
        return model.measurement_logpdf(y, X, observed=o)


def _check_marginal(model, what: str) -> None:
    """A partly-missing row needs ``model.measurement_logpdf(y, xs, observed=mask)``.

    ``what`` names the row, e.g. "ys row 3".
    """
    try:
        takes_mask = "observed" in inspect.signature(model.measurement_logpdf).parameters
    except (TypeError, ValueError):  # no signature to read
        takes_mask = False
    if not takes_mask:
        raise ValueError(
            f"{what} is partly NaN, but {type(model).__name__}.measurement_logpdf(y, xs) takes "
            "no observed= mask: the likelihood of the observed components alone is unknown for "
            "this model. Give it measurement_logpdf(y, xs, observed=None) returning "
            "log p(y_o | x) for the components o where observed is True (the bf.models models "
            "do), or make the row all NaN (a missing measurement)")


def _move(model, rng, X, y, t, proposal, u, o=None):
    """Draw x_t for every particle; return (X_new, log-weight increment (N,)).

    ``y`` is None for a missing measurement: the particles follow the
    transition and the weights do not change. ``o`` is the mask of the
    observed components of a partly-missing y (None if all are observed).
    """
    if y is None:
        return model.sample_transition(rng, X, u, t - 1), np.zeros(X.shape[0])
    if proposal is None:
        # Bootstrap: q = p(x_t | x_{t-1}), so the ratio in eq. (13) is p(y_t | x_t).
        X_new = model.sample_transition(rng, X, u, t - 1)
        return X_new, _log_likelihood(model, y, X_new, o)
    X_new = check_output("proposal.sample", proposal.sample(rng, X, y, t), X.shape)
    log_q = np.asarray(proposal.logpdf(X_new, X, y, t), dtype=float)
    if log_q.shape != (X.shape[0],) or not np.all(np.isfinite(log_q)):
        raise ValueError(f"proposal.logpdf must return {X.shape[0]} finite log-densities of the "
                         f"particles it drew, shape ({X.shape[0]},); got shape {log_q.shape}"
                         + ("" if log_q.shape != (X.shape[0],) else " with NaN or inf"))
    # log w_t = log W_{t-1} + log p(y_t | x_t) + log p(x_t | x_{t-1}) - log q(x_t | x_{t-1}, y_t)
    return X_new, (_log_likelihood(model, y, X_new, o)
                   + model.transition_logpdf(X_new, X, u, t - 1) - log_q)


def sis_step(model, rng, particles, log_weights, y, t: int, proposal=None, u=None) -> SISStep:
    r"""One step of sequential importance sampling, from time t - 1 to t (seed 001, eq. (13)).

    .. math::

        x_t^i \sim q(x_t \mid x_{t-1}^i, y_t),\qquad
        \log w_t^i = \log W_{t-1}^i + \log p(y_t \mid x_t^i) + \log p(x_t^i \mid x_{t-1}^i)
                     - \log q(x_t^i \mid x_{t-1}^i, y_t),

    then normalised with :func:`log_normalize`. No resampling.

    Parameters
    ----------
    model : bf.models.LinearGaussian or NonlinearGaussian
    rng : numpy.random.Generator
    particles : array_like, shape (N, n)
        :math:`x_{t-1}^i`.
    log_weights : array_like, shape (N,)
        :math:`\log W_{t-1}^i`, normalised: :math:`\log \sum_i W_{t-1}^i`
        must be 0 within ``LOG_WEIGHTS_TOL`` (1e-8), or ``log_increment``
        would not estimate :math:`\log p(y_t \mid y_{0:t-1})`. Normalise with
        :func:`log_normalize`; equal weights are ``np.full(N, -np.log(N))``.
    y : array_like, shape (m,), or None
        :math:`y_t`; None (or all NaN) for a missing measurement. A partly-NaN
        y weights by the likelihood of its observed components,
        ``model.measurement_logpdf(y, x, observed=~np.isnan(y))``; a
        ``proposal`` then receives y with its NaN entries.
    t : int
        Time index of the new state (>= 1).
    proposal : Proposal, optional
        The importance density q; None uses the transition (bootstrap), for
        which the ratio reduces to :math:`p(y_t \mid x_t^i)`. A proposal
        other than the transition needs ``model.transition_logpdf``, i.e. a
        transition with a density (:math:`G Q G^T` invertible).
    u : array_like, shape (p,), optional
        Control input :math:`u_{t-1}` (linear models with ``B``).

    Returns
    -------
    SISStep

    Raises
    ------
    ValueError
        On bad arguments (each named), ``log_weights`` that are not
        normalised, an inf in ``y``, a partly-NaN ``y`` for a model without
        ``measurement_logpdf(..., observed=)``, or when every weight is zero.
    """
    rng = as_rng("rng", rng)
    X = as_matrix("particles", particles, (None, model.state_dim))
    lw = as_vector("log_weights", log_weights, X.shape[0], finite=False)
    _check_normalised(lw)
    t = as_int("t", t, minimum=1)
    if proposal is not None:
        proposal = _check_proposal(proposal)
        if u is not None:
            raise ValueError("proposal: a Proposal receives no control input u; use "
                             "proposal=None (the bootstrap) with u")
    o = None
    if y is not None:
        y = as_vector("y", y, model.obs_dim, finite=False)
        if np.isinf(y).any():
            raise ValueError(f"y must be finite or NaN (missing), got {y}")
        if np.all(np.isnan(y)):
            y = None
        elif np.isnan(y).any():
            _check_marginal(model, "y")
            o = ~np.isnan(y)
    try:
        X_new, log_incr = _move(model, rng, X, y, t, proposal, u, o)
        if y is None:
            return SISStep(X_new, lw, 0.0)
        log_W, log_sum = _normalize_or_explain(lw + log_incr, t, y)
    except ValueError as exc:
        raise ValueError(f"sis_step, step t = {t}: {exc}") from None
    return SISStep(X_new, log_W, log_sum)


LOG_WEIGHTS_TOL = 1e-8
"""How far from 0 ``sis_step`` lets :math:`\\log \\sum_i W^i` of its incoming
log-weights be (rounding leaves a few 1e-16; an unnormalised set is off by O(1))."""


def _check_normalised(lw: np.ndarray) -> None:
    """ValueError naming ``log_weights`` unless log sum_i exp(lw_i) = 0 within LOG_WEIGHTS_TOL."""
    top = lw.max()
    if not top < np.inf:  # NaN or +inf
        i = int(np.flatnonzero(~(lw < np.inf))[0])
        raise ValueError(f"log_weights must be finite or -inf, got log_weights[{i}] = {lw[i]}")
    if top == -np.inf:
        raise ValueError("log_weights are all -inf: every weight is zero")
    # log sum_i exp(l_i) = m + log sum_i exp(l_i - m)
    log_sum = top + np.log(np.sum(np.exp(lw - top)))
    if not abs(log_sum) <= LOG_WEIGHTS_TOL:
        raise ValueError(
            f"log_weights must be normalised, log sum_i exp(log_weights[i]) = 0 within "
            f"{LOG_WEIGHTS_TOL:g}, got {log_sum:.6g}: pass the log_weights of the previous "
            "step, bf.particle.log_normalize(log_w)[0], or np.full(N, -np.log(N)) for equal "
            "weights")


def _normalize_or_explain(lw, t, y):
    """:func:`log_normalize`, with an error that says which step failed and why."""
    top = lw.max()  # NaN if a log-weight is NaN: one pass finds NaN, +inf and all -inf
    if not top < np.inf:
        raise ValueError("a log-weight is NaN or +inf (a log-density of the model or the "
                         "proposal returned NaN or +inf)")
    if top == -np.inf:
        raise ValueError(
            f"every particle's weight is zero: the measurement y_{t} = "
            f"{np.array2string(np.asarray(y), precision=4)} is impossible (log-likelihood -inf, "
            f"below floating point) under every particle. The particles missed the region the "
            f"measurement points to: use more particles, a proposal that looks at y_t, or check "
            f"the measurement model, its noise R and the data")
    return _log_normalize(lw)


# --------------------------------------------------------------------------
# Proposals (chapter 05)
# --------------------------------------------------------------------------

def transition_proposal(model) -> Proposal:
    r"""The transition :math:`p(x_t \mid x_{t-1})` written as an explicit :class:`Proposal`.

    ``particle_filter(..., proposal=None)`` uses the transition directly and
    skips the two densities that cancel; this explicit version goes through
    eq. (13) in full and must give the same weights (a check of eq. (13), and
    the starting point for a proposal of your own). It translates the
    proposal's time (that of the new state t) to the model's (that of the
    state the step starts from, t - 1). Needs a transition density
    (:math:`G Q G^T` invertible).

    Parameters
    ----------
    model : LinearGaussian or NonlinearGaussian
        The model whose transition is the proposal.

    Returns
    -------
    Proposal
        ``sample(rng, x_prev, y, t)`` draws from :math:`p(x_t \mid x_{t-1})` and
        ``logpdf(x, x_prev, y, t)`` evaluates it; both ignore ``y``.
    """
    def sample(rng, x_prev, y, t):
        return model.sample_transition(rng, x_prev, t=t - 1)

    def logpdf(x, x_prev, y, t):
        return model.transition_logpdf(x, x_prev, t=t - 1)

    return Proposal(sample, logpdf)


# --------------------------------------------------------------------------
# The optimal proposal of a linear-Gaussian model (chapter 05)
# --------------------------------------------------------------------------

def optimal_proposal(model) -> Proposal:
    r"""The optimal importance density :math:`p(x_t \mid x_{t-1}, y_t)` of a linear-Gaussian model.

    With :math:`\tilde Q = G Q G^T` (invertible), :math:`x_t \mid x_{t-1}` is
    :math:`N(A x_{t-1} + B u, \tilde Q)`, and conditioning on :math:`y_t = C x_t + v_t`
    is one Kalman update of that Gaussian:

    .. math::

        K = \tilde Q C^T (C \tilde Q C^T + R)^{-1},\qquad
        \mu^i = A x_{t-1}^i + K (y_t - C A x_{t-1}^i),\qquad
        \Sigma = (I - K C) \tilde Q.

    Every particle shares :math:`\Sigma`. Its weight increment (eq. (13))
    is :math:`p(y_t \mid x_{t-1}^i) = N(y_t; C A x_{t-1}^i, C \tilde Q C^T + R)`,
    which does not depend on the draw :math:`x_t^i`: this proposal minimises
    the variance of the weights given the past (Doucet, Godsill & Andrieu 2000).
    A y with NaN entries (a partly-missing measurement) is conditioned on
    its observed components o only: :math:`C_o` and :math:`R_{oo}` in place
    of C and R.

    Parameters
    ----------
    model : bf.models.LinearGaussian
        Without a control input (the proposal has no ``u``), with
        :math:`G Q G^T` positive definite.

    Returns
    -------
    Proposal
    """
    from .models import LinearGaussian

    if not isinstance(model, LinearGaussian):
        raise TypeError(f"model must be a bf.models.LinearGaussian, got {type(model).__name__}")
    if model.B is not None:
        raise ValueError("optimal_proposal: model has a control matrix B; build it without B")
    A, C, R = model.A, model.C, model.R
    Qt = model.G @ model.Q @ model.G.T
    rank = int(np.linalg.matrix_rank(Qt))
    if rank < Qt.shape[0]:
        raise ValueError(
            f"optimal_proposal needs a transition density, i.e. G Q G^T of full rank "
            f"{Qt.shape[0]}, got rank {rank}: part of the state moves deterministically. "
            f"Use proposal=None (the bootstrap), which is already optimal when C G = 0 "
            f"(the measurement does not see the noisy components directly)")
    eye_n = np.eye(A.shape[0])

    def condition(C_o, R_o):
        """K, a factor of Sigma and its Cholesky factor, for y_o = C_o x + v_o."""
        S = C_o @ Qt @ C_o.T + R_o
        # K = Q~ C^T S^{-1}
        K = np.linalg.solve(S, C_o @ Qt).T
        # Sigma = (I - K C) Q~
        Sigma = (eye_n - K @ C_o) @ Qt
        Sigma = 0.5 * (Sigma + Sigma.T)
        return K, _factor(Sigma), _cholesky("Sigma", Sigma)

    # one conditioning per set of observed components, computed when first needed
    # (a partly-NaN y conditions on its observed components: C_o, R_oo)
    full = np.ones(C.shape[0], dtype=bool)
    parts = {full.tobytes(): (full, C) + condition(C, R)}

    def part(y):
        o = ~np.isnan(y)
        key = o.tobytes()
        if key not in parts:
            C_o, R_o = C[o], R[np.ix_(o, o)]
            parts[key] = (o, C_o) + condition(C_o, R_o)
        return parts[key]

    def mean(x_prev, y, o, C_o, K):
        pred = x_prev @ A.T
        # mu = A x + K (y - C A x)
        return pred + (y[o] - pred @ C_o.T) @ K.T

    def sample(rng, x_prev, y, t):
        o, C_o, K, L_Sigma, _ = part(y)
        z = rng.standard_normal(x_prev.shape)
        return mean(x_prev, y, o, C_o, K) + z @ L_Sigma.T

    def logpdf(x, x_prev, y, t):
        o, C_o, K, _, chol_Sigma = part(y)
        return _logpdf_rows(x - mean(x_prev, y, o, C_o, K), chol_Sigma)

    return Proposal(sample, logpdf)


# --------------------------------------------------------------------------
# The particle filter
# --------------------------------------------------------------------------

def _check_threshold(ess_threshold) -> float:
    if isinstance(ess_threshold, (bool, np.bool_)) or not isinstance(ess_threshold, numbers.Real):
        raise TypeError(f"ess_threshold must be a number in [0, 1], got {ess_threshold!r}")
    value = float(ess_threshold)
    if not 0.0 <= value <= 1.0:
        raise ValueError(f"ess_threshold must be in [0, 1] (a fraction of n_particles), got {value}")
    return value


def _check_ys(ys, m: int):
    if m == 1 and np.ndim(ys) == 1:
        ys = np.asarray(ys)[:, None]  # a scalar measurement per step
    ys = as_matrix("ys", ys, (None, m), finite=False)
    return (ys,) + observation_masks(ys)


def particle_filter(model, ys, n_particles: int, rng, proposal=None, resample="systematic",
                    ess_threshold: float = 0.5, us=None, keep_history: bool = False,
                    roughening: float | None = None) -> ParticleFilterResult:
    r"""Run a particle filter (SIS with adaptive resampling) over a measurement record.

    For t = 0, ..., T-1 (seed 000 §3.2, steps [1]-[5]; the generic particle
    filter of Arulampalam et al. 2002, Algorithm 3, which resamples when the
    ESS drops; with ``ess_threshold=1`` and the transition proposal it is
    their SIR filter, Algorithm 4):

    1. t = 0: draw N particles from the prior :math:`N(m_0, P_0)` (step [1];
       the proposal is not used at t = 0: the first weights are the
       likelihoods :math:`p(y_0 \mid x_0^{(i)})`); t >= 1: move each particle
       with the proposal (step [2]);
    2. weight them by eq. (13), normalise in the log domain (step [3]) and
       record the weighted mean, covariance and ESS;
    3. if ``ESS < ess_threshold * N`` (always when ``ess_threshold == 1``),
       resample with the named scheme and reset the weights to 1/N (step [4]);
       with ``roughening = kappa``, then jitter every particle (Gordon,
       Salmond & Smith 1993): :math:`x^{(i)}_k \leftarrow x^{(i)}_k + \kappa E_k N^{-1/n} z^{(i)}_k`,
       :math:`z^{(i)}_k \sim N(0, 1)`, :math:`E_k` the range of component k of
       the resampled particles (chapter 06, section 7).

    Parameters
    ----------
    model : bf.models.LinearGaussian or NonlinearGaussian
        Any model with the particle interface (``sample_initial``,
        ``sample_transition``, ``measurement_logpdf``, ``transition_logpdf``);
        a time-varying model gets each step's time index.
    ys : array_like, shape (T, m)
        Measurements; ``ys[0]`` measures :math:`x_0`. NaN marks a missing
        component: an all-NaN row is missing (the particles move, the
        weights stay); a partly-NaN row weights by the likelihood of its
        observed components o, :math:`p(y_{t,o} \mid x_t)`, from
        ``model.measurement_logpdf(y, xs, observed=o)`` (for the
        ``bf.models`` models, the Gaussian :math:`N(h_o(x), R_{oo})`); a
        model whose ``measurement_logpdf`` takes no ``observed`` is refused.
        A ``proposal`` receives such a y with its NaN entries. (A 1-D array
        is accepted when m = 1.)
    n_particles : int
        N >= 1.
    rng : numpy.random.Generator
    proposal : Proposal, optional
        Importance density; None is the bootstrap filter (q = transition).
    resample : str
        A key of ``bf.resampling.SCHEMES``: "systematic" (default),
        "stratified", "residual" or "multinomial".
    ess_threshold : float in [0, 1]
        0 never resamples (plain SIS, chapter 05); 1 resamples at every step
        (SIR, the bootstrap filter of Gordon et al.); 0.5 is a common choice.
    us : array_like, shape (T - 1, p), optional
        Known inputs (linear models with ``B``); row t acts from t to t + 1.
    keep_history : bool
        Also return every step's particles, weights and ancestors
        (O(T N n) memory; for plots).
    roughening : float, optional
        The constant K > 0 of roughening after each resampling, a remedy for
        sample impoverishment when the process noise is small; None (the
        default) adds no jitter.

    Returns
    -------
    ParticleFilterResult

    Raises
    ------
    ValueError
        On bad arguments (each named), an inf in ``ys``, a partly-NaN row
        for a model whose likelihood cannot be marginalised, or when at some
        step every weight is zero (the message names the step and the
        measurement).
    """
    if not hasattr(model, "sample_transition") or not hasattr(model, "measurement_logpdf"):
        raise TypeError(f"model must be a bf.models model with the particle interface, "
                        f"got {type(model).__name__}")
    N = as_int("n_particles", n_particles, minimum=1)
    rng = as_rng("rng", rng)
    if proposal is not None:
        proposal = _check_proposal(proposal)
    if not isinstance(resample, str) or resample not in SCHEMES:
        raise ValueError(f"resample must be one of {sorted(SCHEMES)}, got {resample!r}")
    scheme = SCHEMES[resample]
    threshold = _check_threshold(ess_threshold)
    if roughening is not None:
        roughening = as_positive_float("roughening", roughening)
    n = model.state_dim
    ys, observed, components = _check_ys(ys, model.obs_dim)
    T = ys.shape[0]
    if T == 0:
        raise ValueError(f"ys must have at least one row, got shape {ys.shape}")
    full = components.all(axis=1)
    if not full[observed].all():
        _check_marginal(model, f"ys row {int(np.flatnonzero(observed & ~full)[0])}")
    us = as_inputs(model, us, T)
    if proposal is not None and us is not None:
        raise ValueError("proposal: a Proposal's sample and logpdf receive no control input u, "
                         "so eq. (13) would divide p(x_t | x_(t-1), u) by a q without u; use "
                         "proposal=None (the bootstrap) with us, or a model without B")

    means, covs = np.empty((T, n)), np.empty((T, n, n))
    ess_t, resampled, step_logliks = np.empty(T), np.zeros(T, dtype=bool), np.zeros(T)
    if keep_history:
        hist_X, hist_W = np.empty((T, N, n)), np.empty((T, N))
        hist_A = np.empty((T, N), dtype=np.intp)
    parents = np.arange(N)
    X = model.sample_initial(rng, N)                          # step [1]
    log_W = np.full(N, -np.log(N))
    for t in range(T):
        y = ys[t] if observed[t] else None
        o = None if full[t] else components[t]                # the observed components
        try:
            if t == 0:
                log_incr = np.zeros(N) if y is None else _log_likelihood(model, y, X, o)
            else:                                              # step [2]
                X, log_incr = _move(model, rng, X, y, t, proposal,
                                    None if us is None else us[t - 1], o)
            if y is not None:                                  # step [3]
                log_W, step_logliks[t] = _normalize_or_explain(log_W + log_incr, t, y)
        except ValueError as exc:
            raise ValueError(f"particle_filter, step t = {t}: {exc}") from None
        W = np.exp(log_W)
        means[t], covs[t] = _mean_cov(X, W)
        # ESS = 1 / sum_i W_i^2 (not np.dot: OpenBLAS's threads would wake for a long W)
        ess_t[t] = 1.0 / np.sum(W ** 2)
        if keep_history:
            hist_X[t], hist_W[t], hist_A[t] = X, W, parents
        if threshold == 1.0 or ess_t[t] < threshold * N:      # step [4]
            parents = scheme(W, rng)
            X = X[parents]
            log_W = np.full(N, -np.log(N))
            resampled[t] = True
            if roughening is not None:
                # sigma_k = K E_k N^(-1/n), E_k the range of component k (taken on the
                # transpose, one contiguous row per component, as in _mean_cov)
                sigma = roughening * np.ptp(X.T.copy(), axis=1) * N ** (-1.0 / n)
                X = X + sigma * rng.standard_normal(X.shape)
        else:
            parents = np.arange(N)
    history = ParticleHistory(hist_X, hist_W, hist_A) if keep_history else None
    return ParticleFilterResult(means, covs, ess_t, resampled, step_logliks,
                                float(step_logliks.sum()), observed, history, components)
