r"""Smoothing: the state at every time, given the whole record (chapter 07).

A filter answers "where is it *now*, given what I have seen so far?": it
computes :math:`p(x_t \mid y_{0:t})`. Offline work asks "where was it
*then*, given everything?": the **smoothed** distribution
:math:`p(x_t \mid y_{0:T-1})`, which also uses the measurements that came
after t. Every smoother of this module runs the filter forward once and then
sweeps backward, from :math:`t = T-1` (where filter and smoother agree) down
to :math:`t = 0`, with one recursion (Särkkä 2013, *Bayesian Filtering and
Smoothing*, first edition, Theorem 8.1; the second edition, Särkkä & Svensson
2023, numbers its chapters differently):

.. math::

    p(x_t \mid y_{0:T-1}) = p(x_t \mid y_{0:t}) \int
        \frac{p(x_{t+1} \mid x_t)\, p(x_{t+1} \mid y_{0:T-1})}
             {p(x_{t+1} \mid y_{0:t})}\, dx_{t+1}.

Read it from the right: the smoothed belief in :math:`x_{t+1}`, divided by
the filter's prediction of it, is what the later measurements taught about
:math:`x_{t+1}`; the transition carries that lesson back to :math:`x_t`, and
multiplying by the filtered belief adds what the earlier ones said. The
measurements themselves are not needed in the backward sweep: they did
their work in the forward pass.

Four smoothers, one per kind of filter:

* :func:`rts_smoother` - linear-Gaussian models: the Rauch-Tung-Striebel
  smoother (Rauch, Tung & Striebel 1965; Särkkä 2013, Theorem 8.2), exact,
  on the :class:`~bayesfilt.kalman.FilterResult` of
  :func:`bayesfilt.kalman.kalman_filter`. Every belief is Gaussian, so the
  integral becomes a few matrix products with the smoother gain
  :math:`J_t = P_{t|t} A^T P_{t+1|t}^{-1}`.
* :func:`grid_smoother` - a one-dimensional model on a grid: the integral
  becomes a sum over cells, on the
  :class:`~bayesfilt.bayes.GridFilterResult` of
  :func:`bayesfilt.bayes.grid_filter` (the exact reference for a 1-D
  nonlinear model).
* :func:`genealogy` - the particle filter's own ancestral paths, the
  "smoother" a particle filter gives for free. Resampling makes the paths
  coalesce, so at early times few distinct states survive: a poor smoother.
* :func:`ffbsi` - forward filtering, backward simulation (Godsill, Doucet &
  West 2004; Särkkä 2013, ch. 11): draws whole trajectories backward through
  the stored particle clouds, choosing at each step among *all* N particles
  of that time, weighted by filter weight times transition density. It needs
  that density, so not for a model whose noise misses some state component.

Import it as ``bf.smoothing``::

    import numpy as np
    import bayesfilt as bf

    model = bf.models.damped_particle()
    xs, ys = bf.models.simulate(model, 100, np.random.default_rng(0))
    ys[40:60] = np.nan                                  # a gap in the record
    smooth = bf.smoothing.rts_smoother(model, bf.kalman.kalman_filter(model, ys))
    smooth.means, smooth.covs, smooth.gains            # (T, n), (T, n, n), (T - 1, n, n)

    ungm = bf.models.ungm()
    xs, ys = bf.models.simulate(ungm, 30, np.random.default_rng(1))
    grid = np.linspace(-40.0, 40.0, 801)
    exact = bf.smoothing.grid_smoother(ungm, bf.bayes.grid_filter(ungm, ys, grid))
    pf = bf.particle.particle_filter(ungm, ys, 500, np.random.default_rng(2),
                                     keep_history=True)
    paths = bf.smoothing.ffbsi(ungm, pf.history, 100, np.random.default_rng(3))
    paths.paths.mean(axis=0)                            # (T, 1): compare exact.means

Time convention (seed 000), as in every filter of the course: ``ys[0]``
measures :math:`x_0`, and the last state is :math:`x_{T-1}`, so the
smoothed quantities are written :math:`\hat x_{t|T-1}`, :math:`P_{t|T-1}`.

filterpy map: ``filterpy.kalman.rts_smoother(Xs, Ps, Fs, Qs)`` (and the
method ``KalmanFilter.rts_smoother``) returns ``(x, P, K, Pp)``: ``x`` and
``P`` are :func:`rts_smoother`'s ``means`` and ``covs``, its ``K`` is the
smoother gain :math:`J_t` (with a zero last entry), and its ``Pp`` are the
predicted covariances. filterpy recomputes the prediction as ``F x`` and has
no argument for a control input, so it cannot smooth a record filtered with
inputs (its loop must be copied and :math:`B u_t` added);
:func:`rts_smoother` reads the filter's predicted means, which include
:math:`B u_t`. filterpy has no particle or grid smoother.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from scipy import linalg as sla

from ._checks import as_array, as_inputs, as_int, as_matrix, as_rng
from .bayes import GridFilterResult
from .kalman import FilterResult, _check_inputs
from .models import LinearGaussian, NonlinearGaussian, _ModelBase
from .particle import ParticleHistory

__all__ = [
    "SmootherResult",
    "GridSmootherResult",
    "Genealogy",
    "BackwardPaths",
    "rts_smoother",
    "grid_smoother",
    "genealogy",
    "ffbsi",
]

_EPS = np.finfo(float).eps
#: Relative size below which an eigenvalue of a singular P_{t+1|t} counts as zero.
PINV_RTOL = 1e-12
#: At most this many (trajectory, particle) pairs per call of transition_logpdf in ffbsi.
FFBSI_CHUNK = 1_000_000


class SmootherResult(NamedTuple):
    r"""Output of :func:`rts_smoother` (a leading axis M for a batched filter result).

    means (T, n): :math:`\hat x_{t|T-1} = E[x_t \mid y_{0:T-1}]`;
    covs (T, n, n): :math:`P_{t|T-1}`;
    gains (T - 1, n, n): the smoother gains :math:`J_t = P_{t|t} A^T P_{t+1|t}^{-1}`;
    cross_covs (T - 1, n, n): the lag-one covariances
    :math:`\mathrm{cov}(x_{t+1}, x_t \mid y_{0:T-1}) = P_{t+1|T-1} J_t^T`
    (what the EM algorithm for A and Q needs).
    """

    means: np.ndarray
    covs: np.ndarray
    gains: np.ndarray
    cross_covs: np.ndarray


class GridSmootherResult(NamedTuple):
    r"""Output of :func:`grid_smoother`.

    grid (n,); posteriors (T, n): probability of each cell given the whole
    record :math:`y_{0:T-1}`; means (T,) and variances (T,) of those
    distributions.
    """

    grid: np.ndarray
    posteriors: np.ndarray
    means: np.ndarray
    variances: np.ndarray


class Genealogy(NamedTuple):
    r"""Output of :func:`genealogy`: the ancestral paths of the final particles.

    indices (T, N): ``indices[t, i]`` is the index, among the particles of
    time t, of the ancestor of final particle i (``indices[T - 1]`` is
    ``arange(N)``); paths (N, T, n): the states along each path; weights
    (N,): the final normalised weights :math:`W_{T-1}^{(i)}`, the weights of
    the paths; n_distinct (T,): how many distinct ancestors the N final
    particles have at each time.
    """

    indices: np.ndarray
    paths: np.ndarray
    weights: np.ndarray
    n_distinct: np.ndarray


class BackwardPaths(NamedTuple):
    r"""Output of :func:`ffbsi`: L trajectories drawn from the particle smoother.

    paths (L, T, n): trajectory l is :math:`x_{0:T-1}^{[l]}`, each an
    (approximate) draw from :math:`p(x_{0:T-1} \mid y_{0:T-1})`, equally
    weighted; indices (L, T): ``indices[l, t]`` is the particle of time t that
    trajectory l passes through (``paths[l, t] = particles[t, indices[l, t]]``).
    """

    paths: np.ndarray
    indices: np.ndarray


# --------------------------------------------------------------------------
# The RTS smoother
# --------------------------------------------------------------------------

def _smoother_gain(P_filt, A, P_pred):
    r"""J = P_{t|t} A^T P_{t+1|t}^{-1}, by solving P_{t+1|t} J^T = A P_{t|t}.

    P_{t+1|t} is singular when part of the state is known exactly and no
    noise reaches it (a zero prior variance, no process noise on it). Then
    the conditional of x_t given x_{t+1} uses the Moore-Penrose inverse: the
    deviations it multiplies lie in the range of P_{t+1|t}, where every
    generalised inverse gives the same product, so the smoothed means and
    covariances do not depend on the choice.
    """
    APt = A @ P_filt                  # = (P_{t|t} A^T)^T, as P_{t|t} is symmetric
    n = P_pred.shape[0]
    try:
        factor = sla.cho_factor(P_pred, lower=True, check_finite=False)
        pivots = np.diag(factor[0]) ** 2
        # a pivot is the variance of one component given the ones before it: at the
        # rounding level of that component's own variance, P_{t+1|t} is singular
        if np.all(pivots > 100 * n * _EPS * np.diag(P_pred)):
            # P_{t+1|t} J^T = A P_{t|t}  (Cholesky solve, no inverse)
            return sla.cho_solve(factor, APt, check_finite=False).T
    except np.linalg.LinAlgError:
        pass
    vals, vecs = np.linalg.eigh(P_pred)
    keep = vals > PINV_RTOL * max(vals.max(), 0.0)
    # J = P_{t|t} A^T (P_{t+1|t})^+, the pseudo-inverse on the kept eigenvectors
    return ((vecs[:, keep] / vals[keep]) @ (vecs[:, keep].T @ APt)).T


def _covariance_pass(A, covs, pred_covs):
    """Gains J_t (T-1, n, n), smoothed covariances (T, n, n), lag-one covariances (T-1, n, n)."""
    T, n = covs.shape[:2]
    gains, cross = np.empty((T - 1, n, n)), np.empty((T - 1, n, n))
    smoothed = np.empty((T, n, n))
    smoothed[T - 1] = covs[T - 1]      # at the last step the smoother is the filter
    for t in range(T - 2, -1, -1):
        # J_t = P_{t|t} A^T P_{t+1|t}^{-1}
        J = _smoother_gain(covs[t], A, pred_covs[t + 1])
        # P_{t|T-1} = P_{t|t} + J_t (P_{t+1|T-1} - P_{t+1|t}) J_t^T
        P = covs[t] + J @ (smoothed[t + 1] - pred_covs[t + 1]) @ J.T
        smoothed[t] = 0.5 * (P + P.T)
        # cov(x_{t+1}, x_t | y_{0:T-1}) = P_{t+1|T-1} J_t^T
        gains[t], cross[t] = J, smoothed[t + 1] @ J.T
    return gains, smoothed, cross


def _mean_pass(gains, means, pred_means):
    """Smoothed means of R runs at once: means, pred_means (R, T, n) -> (R, T, n)."""
    smoothed = np.array(means, dtype=float)
    for t in range(means.shape[1] - 2, -1, -1):
        # x_{t|T-1} = x_{t|t} + J_t (x_{t+1|T-1} - x_{t+1|t})   (rows: one per run)
        smoothed[:, t] += (smoothed[:, t + 1] - pred_means[:, t + 1]) @ gains[t].T
    return smoothed


def _check_filter_result(model: LinearGaussian, result) -> bool:
    """Shapes and model of a FilterResult; returns True when it is batched (M, T, ...)."""
    if not isinstance(model, LinearGaussian):
        extra = (" (for an EKF result the extended RTS smoother linearises f at each filtered "
                 "mean, Särkkä 2013, ch. 9; not in bayesfilt)"
                 if hasattr(model, "f") else "")
        raise TypeError(f"model must be a bf.models.LinearGaussian, got "
                        f"{type(model).__name__}{extra}")
    if not isinstance(result, FilterResult):
        raise TypeError("result must be the FilterResult of bf.kalman.kalman_filter(model, ys) "
                        f"(or batch_kalman_filter), got {type(result).__name__}")
    n = model.state_dim
    means = as_array("result.means", result.means)
    batched = means.ndim == 3
    lead = means.shape[:-2] if means.ndim in (2, 3) else ()
    if means.ndim not in (2, 3) or means.shape[-1] != n or means.shape[-2] < 1:
        raise ValueError(f"result.means must have shape (T, {n}) (or (M, T, {n}) batched) for "
                         f"this model's {n} state components, got shape {means.shape}: is "
                         "result from another model?")
    T = means.shape[-2]
    want = {"covs": lead + (T, n, n), "pred_means": lead + (T, n),
            "pred_covs": lead + (T, n, n), "observed": lead + (T,)}
    for name, shape in want.items():
        got = np.shape(getattr(result, name))
        if got != shape:
            raise ValueError(f"result.{name} must have shape {shape} to match result.means "
                             f"{means.shape}, got shape {got}")
    for name in ("covs", "pred_means", "pred_covs"):
        as_array(f"result.{name}", getattr(result, name))  # finite
    seen = getattr(result, "observed_components", None)
    if seen is not None and np.shape(seen) != lead + (T, model.obs_dim):
        raise ValueError(f"result.observed_components must have shape "
                         f"{lead + (T, model.obs_dim)} to match result.means {means.shape} "
                         f"and the model's {model.obs_dim} measured components, got shape "
                         f"{np.shape(seen)}")
    return batched


def _check_us(model, us, T: int, M: int | None):
    """The inputs u_0..u_{T-2} as (R, T - 1, p), R = 1 or M, or None; as kalman_filter's."""
    a = _check_inputs(model, us, T, M)
    return a if a is None or a.ndim == 3 else a[None]


def _check_dynamics(model, covs, pred_covs, means, pred_means, Bus, runs: list[str]):
    """The filter's predictions must be this model's (and these inputs').

    P_{t+1|t} = A P_{t|t} A^T + G Q G^T always; x_{t+1|t} = A x_{t|t} + B u_t when the
    inputs are known (Bus, rows B u_t) or the model has no B; otherwise only
    x_{t+1|t} - A x_{t|t} in the range of B can be checked. means, pred_means (R, T, n)
    are R runs that share covs, pred_covs; runs[r] names run r in a message.
    """
    A, GQGt = model.A, model.G @ model.Q @ model.G.T
    scale = max(float(np.max(np.abs(pred_covs))), 1e-300)
    gap = np.abs(A @ covs[:-1] @ A.T + GQGt - pred_covs[1:]).max(axis=(1, 2), initial=0.0)
    first = np.abs(pred_covs[0] - model.P0).max()
    bad = np.flatnonzero(gap > 1e-8 * scale)
    if first > 1e-8 * scale or bad.size:
        t = 0 if first > 1e-8 * scale else int(bad[0]) + 1
        raise ValueError(
            f"result does not come from this model{runs[0]}: its pred_covs[{t}] is not "
            + ("model.P0" if t == 0 else f"A covs[{t - 1}] A^T + G Q G^T")
            + "; smooth with the model that the filter ran on")
    mscale = max(float(np.max(np.abs(pred_means), initial=0.0)), 1.0)
    # what the filter added to A x_{t|t}: B u_t (zero without inputs)
    pushed = pred_means[:, 1:] - means[:, :-1] @ A.T
    if Bus is not None:
        off, what = pushed - Bus, "A means[{t}] + B us[{t}]"
    elif model.B is None:
        off, what = pushed, "A means[{t}] (and the model has no control matrix B)"
    else:
        # unknown inputs: only the part of B u_t outside the range of B can be seen
        Qb, _ = np.linalg.qr(model.B)
        off, what = pushed - pushed @ Qb @ Qb.T, "A means[{t}] + B u for any input u"
    bad = np.argwhere(np.abs(off).max(axis=2, initial=0.0) > 1e-8 * mscale)  # (run, t)
    if bad.size:
        r, t = (int(i) for i in bad[np.argmin(bad[:, 1])])
        raise ValueError(f"result does not come from this model{runs[r]}: its "
                         f"pred_means[{t + 1}] is not " + what.format(t=t)
                         + ("" if Bus is None else ": were these the inputs the filter ran with?"))


def rts_smoother(model: LinearGaussian, result: FilterResult, us=None) -> SmootherResult:
    r"""The Rauch-Tung-Striebel smoother: :math:`p(x_t \mid y_{0:T-1})`, linear-Gaussian model.

    From the Kalman filter's output, backward for t = T-2, ..., 0
    (Rauch, Tung & Striebel 1965; Särkkä 2013, Theorem 8.2; chapter 07
    derives it from Kay's Theorem 10.2 applied to :math:`(x_t, x_{t+1})`
    given :math:`y_{0:t}`):

    .. math::

        J_t = P_{t|t} A^T P_{t+1|t}^{-1},\qquad
        \hat x_{t|T-1} = \hat x_{t|t} + J_t(\hat x_{t+1|T-1} - \hat x_{t+1|t}),

        P_{t|T-1} = P_{t|t} + J_t (P_{t+1|T-1} - P_{t+1|t}) J_t^T,

    starting from the filter at :math:`t = T-1`. It reads the filter's
    filtered and predicted means and covariances and the model's ``A``
    (and ``G Q G^T`` to check that ``result`` belongs to ``model``).

    * **Missing measurements** need nothing special, whole rows or some
      components of a row: the recursion reads only the filter's means,
      covariances and predictions, which already used exactly the components
      that were observed (on an all-NaN row the filtered belief is the
      prediction).
    * **Control inputs** are not needed: the input enters only the predicted
      mean :math:`\hat x_{t+1|t} = A\hat x_{t|t} + B u_t`, which the filter
      result already holds, and not the covariances or the gain (a known
      input shifts :math:`x_{t+1}` without changing how it co-varies with
      :math:`x_t`). The smoothed means are therefore those of the inputs the
      filter ran with, whatever they were. Pass ``us`` to have that checked;
      without it only :math:`\hat x_{t+1|t} - A\hat x_{t|t}` in the range of
      B can be checked, so a result filtered with other inputs is not noticed.
    * **A singular** :math:`P_{t+1|t}` (part of the state known exactly, with
      no noise reaching it) uses its Moore-Penrose inverse; the smoothed
      means and covariances are then the exact conditional ones (see
      ``_smoother_gain``).

    Parameters
    ----------
    model : bf.models.LinearGaussian
        The model the filter ran on.
    result : bf.kalman.FilterResult
        ``bf.kalman.kalman_filter(model, ys)`` (with or without ``us``), or
        ``bf.kalman.batch_kalman_filter(model, ys)`` for M runs at once (the
        covariances and gains are then computed once per missing-data
        pattern, component by component).
    us : array_like, shape (T - 1, p) or (M, T - 1, p), optional
        The inputs the filter ran with, used only to check that
        ``result.pred_means`` are :math:`A\hat x_{t|t} + B u_t` (T rows are
        accepted, the last ignored, as in ``kalman_filter``).

    Returns
    -------
    SmootherResult
        ``means`` (T, n), ``covs`` (T, n, n), ``gains`` (T - 1, n, n) and
        ``cross_covs`` (T - 1, n, n); with a leading axis M for a batched
        result.

    Raises
    ------
    TypeError
        If ``model`` is not a LinearGaussian or ``result`` not a FilterResult.
    ValueError
        If the shapes of ``result`` do not match the model, its predicted
        covariances are not this model's (a result of another model), or its
        predicted means are not :math:`A\hat x_{t|t} + B u_t` (for the given
        ``us``; for some input when ``us`` is not given).

    Notes
    -----
    Cost O(T n^3), like the filter. filterpy: ``filterpy.kalman.rts_smoother``
    (see the module docstring for the differences).
    """
    batched = _check_filter_result(model, result)
    means, covs = np.asarray(result.means, float), np.asarray(result.covs, float)
    pred_means = np.asarray(result.pred_means, float)
    pred_covs = np.asarray(result.pred_covs, float)
    # which components of y_t each run measured (the rows only, for a result built without
    # observed_components): runs with one pattern share covariances and gains
    seen = getattr(result, "observed_components", None)
    seen = np.asarray(result.observed if seen is None else seen, dtype=bool)
    if not batched:
        means, covs, pred_means, pred_covs, seen = (
            a[None] for a in (means, covs, pred_means, pred_covs, seen))
    M, T, n = means.shape
    us = _check_us(model, us, T, M if batched else None)
    Bus = None if us is None else us @ model.B.T          # rows B u_t: (1 or M, T - 1, n)
    patterns, which = np.unique(seen.reshape(M, -1), axis=0, return_inverse=True)
    which = which.reshape(-1)
    out_means, out_covs = np.empty((M, T, n)), np.empty((M, T, n, n))
    gains, cross = np.empty((M, T - 1, n, n)), np.empty((M, T - 1, n, n))
    for p in range(patterns.shape[0]):
        runs = np.flatnonzero(which == p)
        k = runs[0]
        if not (np.array_equal(covs[runs], np.broadcast_to(covs[k], covs[runs].shape))
                and np.array_equal(pred_covs[runs],
                                   np.broadcast_to(pred_covs[k], pred_covs[runs].shape))):
            raise ValueError("result.covs differ between runs with the same missing "
                             "measurements: a batched result must come from "
                             "bf.kalman.batch_kalman_filter")
        _check_dynamics(model, covs[k], pred_covs[k], means[runs], pred_means[runs],
                        None if Bus is None else Bus if Bus.shape[0] == 1 else Bus[runs],
                        [f" (run {r})" if batched else "" for r in runs])
        J, P_s, C_s = _covariance_pass(model.A, covs[k], pred_covs[k])
        out_means[runs] = _mean_pass(J, means[runs], pred_means[runs])
        out_covs[runs], gains[runs], cross[runs] = P_s, J, C_s
    if not batched:
        return SmootherResult(out_means[0], out_covs[0], gains[0], cross[0])
    return SmootherResult(out_means, out_covs, gains, cross)


# --------------------------------------------------------------------------
# The grid smoother
# --------------------------------------------------------------------------

def _gaussian_transition(model) -> bool:
    """True for a model of bf.models whose transition density is its own Gaussian one."""
    return (isinstance(model, (LinearGaussian, NonlinearGaussian))
            and type(model).transition_logpdf is _ModelBase.transition_logpdf)


def _grid_transition(model, g, t):
    """transition[i, j] ∝ p(x_{t+1} = g_j | x_t = g_i), rows normalised (as grid_filter).

    For the course's models the density is N(g_j; f_t(g_i), G Q G^T): n means, then one
    subtraction per pair. Any other model: ``transition_logpdf`` on all n^2 pairs, as
    ``grid_filter`` does; the two agree to rounding.
    """
    if _gaussian_transition(model):
        var = float((model.G @ model.Q @ model.G.T)[0, 0])
        if not var > 0:
            raise ValueError("grid_smoother needs a transition density: G Q G^T is 0")
        # the mean of x_{t+1} from each cell, f_t(g_i) (or A g_i)
        mean = model.transition_mean(g[:, None], t=t)[:, 0]
        # log p(x_{t+1} = g_j | x_t = g_i) = -(g_j - f_t(g_i))^2 / (2 G Q G^T) + const
        log_p = np.subtract(g[None, :], mean[:, None])
        np.square(log_p, out=log_p)
        log_p *= -0.5 / var
    else:
        cells = g[:, None]
        x_from, x_to = np.repeat(cells, g.shape[0], axis=0), np.tile(cells, (g.shape[0], 1))
        log_p = model.transition_logpdf(x_to, x_from, t=t).reshape(g.shape[0], -1)
    top = log_p.max(axis=1, keepdims=True)
    if np.any(top == -np.inf):
        raise ValueError(f"grid_smoother, step t = {t}: the transition density is zero on the "
                         "whole grid from some cell: widen the grid")
    # exp(log_p - top), each row normalised (in place: n^2 numbers per step)
    log_p -= top
    vals = np.exp(log_p, out=log_p)
    vals /= vals.sum(axis=1, keepdims=True)
    return vals


def grid_smoother(model, result: GridFilterResult) -> GridSmootherResult:
    r"""The smoother of a one-dimensional model on the grid of :func:`bayesfilt.bayes.grid_filter`.

    The backward recursion of the module docstring with sums over cells
    (Särkkä 2013, Theorem 8.1, on a discretised state), for t = T-2, ..., 0:

    .. math::

        p_t^s(g_i) = p_t(g_i) \sum_j T_{ij}\, \frac{p_{t+1}^s(g_j)}{\bar p_{t+1}(g_j)},
        \qquad \bar p_{t+1}(g_j) = \sum_k p_t(g_k)\, T_{kj},

    with :math:`p_t` the filtered probabilities of the cells (``result``),
    :math:`\bar p_{t+1}` the filter's prediction, :math:`p^s_t` the smoothed
    ones and :math:`T_{ij} \propto p(x_{t+1} = g_j \mid x_t = g_i)` the
    transition matrix, built as ``grid_filter`` builds it (rows normalised,
    rebuilt at every step for a time-varying model). A cell that the
    prediction gives probability 0 gets smoothed probability 0 as well, so
    the ratio 0/0 counts as 0 there.

    Parameters
    ----------
    model : bf.models.LinearGaussian or NonlinearGaussian
        The model ``result`` was computed with: a scalar state with a
        transition density.
    result : bf.bayes.GridFilterResult
        ``bf.bayes.grid_filter(model, ys, grid)``.

    Returns
    -------
    GridSmootherResult
        ``grid`` (n,), ``posteriors`` (T, n), ``means`` (T,), ``variances`` (T,).

    Notes
    -----
    Cost O(T n^2), as the filter: for a time-varying model the (n, n)
    transition is rebuilt at every step. For the models of ``bf.models``
    (a Gaussian transition) it is built from the n transition means
    :math:`f_t(g_i)` and :math:`G Q G^T`, not from n^2 calls of the density,
    which makes the smoother several times faster than ``grid_filter``
    (that does not return its transitions: storing them would take
    T n^2 numbers, 250 MB for chapter 07's 801 cells and 50 steps).
    """
    if getattr(model, "state_dim", None) != 1:
        raise ValueError(f"grid_smoother needs a model with a scalar state (state_dim 1), got "
                         f"{getattr(model, 'state_dim', type(model).__name__)}")
    if not isinstance(result, GridFilterResult):
        raise TypeError("result must be the GridFilterResult of bf.bayes.grid_filter(model, ys, "
                        f"grid), got {type(result).__name__}")
    g = as_array("result.grid", result.grid, ndim=1)
    filt = as_matrix("result.posteriors", result.posteriors, (None, g.shape[0]))
    if np.any(filt < 0) or not np.allclose(filt.sum(axis=1), 1.0, atol=1e-9):
        raise ValueError("result.posteriors must hold one probability vector per step (rows "
                         "non-negative, summing to 1)")
    T = filt.shape[0]
    smoothed = np.empty_like(filt)
    smoothed[T - 1] = filt[T - 1]             # at the last step the smoother is the filter
    time_varying = getattr(model, "time_varying", False)
    trans = None
    for t in range(T - 2, -1, -1):
        if trans is None or time_varying:
            trans = _grid_transition(model, g, t)
        # the filter's prediction p(x_{t+1} | y_0:t) = sum_k p(x_t = g_k | y_0:t) T_kj
        pred = filt[t] @ trans
        # what the later measurements taught about x_{t+1}: smoothed / predicted (0/0 = 0)
        ratio = np.divide(smoothed[t + 1], pred, out=np.zeros_like(pred), where=pred > 0)
        # p(x_t = g_i | y_0:T-1) = p(x_t = g_i | y_0:t) sum_j T_ij ratio_j
        s = filt[t] * (trans @ ratio)
        smoothed[t] = s / s.sum()
    means = smoothed @ g
    variances = np.maximum(smoothed @ (g * g) - means ** 2, 0.0)
    return GridSmootherResult(g, smoothed, means, variances)


# --------------------------------------------------------------------------
# Particle smoothers
# --------------------------------------------------------------------------

def _check_history(history, n=None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    if not isinstance(history, ParticleHistory):
        raise TypeError("history must be the ParticleHistory of bf.particle.particle_filter(..., "
                        f"keep_history=True) (its .history), got {type(history).__name__}")
    X = as_array("history.particles", history.particles, ndim=3)
    T, N = X.shape[:2]
    if n is not None and X.shape[2] != n:
        raise ValueError(f"history.particles must have shape (T, N, {n}) for this model's {n} "
                         f"state components, got shape {X.shape}")
    W = as_matrix("history.weights", history.weights, (T, N))
    if np.any(W < 0) or not np.allclose(W.sum(axis=1), 1.0, atol=1e-9):
        raise ValueError("history.weights must be normalised weights, shape (T, N), each row "
                         "non-negative and summing to 1")
    anc = np.asarray(history.ancestors)
    if anc.shape != (T, N) or anc.dtype.kind not in "iu" or anc.min() < 0 or anc.max() >= N:
        raise ValueError(f"history.ancestors must be integer indices in 0..{N - 1}, shape "
                         f"({T}, {N}), got shape {anc.shape}, dtype {anc.dtype}")
    return X, W, anc


def genealogy(history: ParticleHistory) -> Genealogy:
    r"""The ancestral paths of a particle filter's final particles: the "free" smoother.

    Follow each final particle back through its parents: ``indices[T - 1] =
    arange(N)`` and ``indices[t - 1] = ancestors[t][indices[t]]``. Weighted by
    the final weights, the paths approximate :math:`p(x_{0:T-1} \mid y_{0:T-1})`
    (Kitagawa 1996; the SIR particle smoother of Särkkä 2013, ch. 11), so
    :math:`\sum_i W_{T-1}^{(i)} x_t^{(\text{indices}[t, i])}` estimates
    :math:`E[x_t \mid y_{0:T-1}]`. It is a poor estimate far from T - 1: each
    resampling copies some particles and drops others, so going back in time
    the paths coalesce (``n_distinct`` falls) until a handful of states, or
    one, stands for the whole smoothed distribution (path degeneracy).

    Parameters
    ----------
    history : bf.particle.ParticleHistory
        ``bf.particle.particle_filter(..., keep_history=True).history``. Its
        particles are stored before each step's resampling, with
        ``ancestors[t][i]`` the index, among the particles stored at t - 1, of
        the parent of particle i at t. With roughening, a child was moved from
        a jittered copy of its parent; the path records the parent as stored.

    Returns
    -------
    Genealogy
        ``indices`` (T, N), ``paths`` (N, T, n), ``weights`` (N,),
        ``n_distinct`` (T,).
    """
    X, W, anc = _check_history(history)
    T, N = W.shape
    idx = np.empty((T, N), dtype=np.intp)
    idx[T - 1] = np.arange(N)
    for t in range(T - 1, 0, -1):
        # the parent, at t - 1, of the particle each path passes through at t
        idx[t - 1] = anc[t][idx[t]]
    paths = np.take_along_axis(X, idx[:, :, None], axis=1).transpose(1, 0, 2)
    n_distinct = np.array([np.unique(row).size for row in idx])
    return Genealogy(idx, paths, W[T - 1].copy(), n_distinct)


def ffbsi(model, history: ParticleHistory, n_paths: int, rng, us=None) -> BackwardPaths:
    r"""Forward filtering, backward simulation: L trajectories from the particle smoother.

    Godsill, Doucet & West (2004); the backward-simulation particle smoother
    of Särkkä (2013), ch. 11. From the weighted particle clouds
    :math:`\{x_t^{(i)}, W_t^{(i)}\}` that a particle filter stored at every
    step (the filter's approximation of :math:`p(x_t \mid y_{0:t})`), draw
    each of the L trajectories backward:

    1. :math:`x_{T-1}^{[l]} = x_{T-1}^{(i)}` with probability :math:`W_{T-1}^{(i)}`;
    2. for t = T-2, ..., 0: :math:`x_t^{[l]} = x_t^{(i)}` with probability
       proportional to :math:`W_t^{(i)}\, p(x_{t+1}^{[l]} \mid x_t^{(i)})`.

    Step 2 is the backward recursion of the module docstring applied to a
    single trajectory: given :math:`x_{t+1}`, the later measurements add
    nothing about :math:`x_t`, and
    :math:`p(x_t \mid x_{t+1}, y_{0:t}) \propto p(x_{t+1} \mid x_t)\, p(x_t \mid y_{0:t})`.
    Unlike the ancestral paths of :func:`genealogy`, each step chooses among
    all N particles of its time, so the early times are not degenerate.

    Cost: one transition density per (trajectory, particle, step), O(N L T)
    evaluations and memory O(N L) per step (in chunks of at most
    ``FFBSI_CHUNK`` pairs), besides the filter's history, O(N T). For
    N = 1000, L = 100 and T = 50 that is five million densities. Given the
    particle filter's output the L trajectories are independent. Two
    relatives: the marginal smoother FFBSm (Hürzeler & Künsch 1998; Doucet,
    Godsill & Andrieu 2000; Särkkä 2013, section 11.3) runs step 2 on
    probabilities instead of draws, O(N^2 T), exact given the particles but
    for marginals only; chapter 07 writes it in a few lines as FFBSi's check.
    Rejection-sampling FFBSi (Douc, Garivier, Moulines & Olsson 2011) draws
    step 2 with an expected O(N T) cost when the transition density is
    bounded (not implemented here).

    FFBSi needs the transition *density*. A model whose noise does not reach
    every state component (:math:`G Q G^T` singular, e.g. the damped
    particle, whose positions follow the velocities exactly) has none; its
    backward simulation needs other methods (Lindsten & Schön 2013).

    Parameters
    ----------
    model : bf.models.LinearGaussian or NonlinearGaussian
        The model the particle filter ran on; its transition must have a
        density (``transition_logpdf``; :math:`G Q G^T` invertible).
    history : bf.particle.ParticleHistory
        ``bf.particle.particle_filter(..., keep_history=True).history``: the
        particles and normalised weights of each step, stored *before* that
        step's resampling, i.e. the filter's weighted approximation of
        :math:`p(x_t \mid y_{0:t})`. (The ancestors are not used.)
    n_paths : int
        L >= 1, the number of trajectories.
    rng : numpy.random.Generator
    us : array_like, shape (T - 1, p), optional
        The known inputs the filter used (linear models with ``B``); row t
        enters :math:`p(x_{t+1} \mid x_t, u_t)`.

    Returns
    -------
    BackwardPaths
        ``paths`` (L, T, n) and ``indices`` (L, T).

    Raises
    ------
    ValueError
        If the model's transition has no density, or at some step every
        particle gives trajectory l probability zero (the message names the
        step).
    """
    X, W, _ = _check_history(history, getattr(model, "state_dim", None))
    L = as_int("n_paths", n_paths, minimum=1)
    rng = as_rng("rng", rng)
    T, N = X.shape[:2]
    us = as_inputs(model, us, T)
    idx = np.empty((L, T), dtype=np.intp)
    idx[:, T - 1] = _draw_rows(np.broadcast_to(W[T - 1], (L, N)), rng)
    with np.errstate(divide="ignore"):                 # a zero weight has log-weight -inf
        log_W = np.log(W)
    chunk = max(1, FFBSI_CHUNK // N)
    for t in range(T - 2, -1, -1):
        x_next = X[t + 1, idx[:, t + 1]]               # (L, n): x_{t+1} of every trajectory
        u = None if us is None else us[t]
        for start in range(0, L, chunk):
            rows = slice(start, min(start + chunk, L))
            k = x_next[rows].shape[0]
            # log p(x_{t+1}^[l] | x_t^(i)) for every pair (l, i): k N rows at once
            try:
                log_p = model.transition_logpdf(np.repeat(x_next[rows], N, axis=0),
                                                np.tile(X[t], (k, 1)), u, t).reshape(k, N)
            except ValueError as exc:
                raise ValueError(f"ffbsi needs the transition density p(x_(t+1) | x_t): "
                                 f"{exc}") from None
            # log of W_t^(i) p(x_{t+1}^[l] | x_t^(i)), one row per trajectory
            log_b = log_W[t] + log_p
            top = log_b.max(axis=1, keepdims=True)
            if not np.all(top > -np.inf):
                raise ValueError(f"ffbsi, step t = {t}: a trajectory's x_(t+1) has probability "
                                 "zero from every particle of time t (weights times transition "
                                 "density underflow): use more particles")
            idx[rows, t] = _draw_rows(np.exp(log_b - top), rng)
    paths = X[np.arange(T)[None, :], idx]               # (L, T, n)
    return BackwardPaths(paths, idx)


def _draw_rows(weights, rng) -> np.ndarray:
    """One index per row of ``weights`` (k, N), with probabilities proportional to the row."""
    cum = np.cumsum(weights, axis=1)
    u = rng.random(weights.shape[0]) * cum[:, -1]
    # the first index whose cumulative weight exceeds u (inverse-CDF sampling)
    return np.minimum((cum <= u[:, None]).sum(axis=1), weights.shape[1] - 1)
